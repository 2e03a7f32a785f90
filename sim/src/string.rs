//! The string: slack, a straightening toe, viscoelastic stiffness, and breaking.
//!
//! # Theory of operation
//!
//! The string runs from a clamp on the far side of the racket frame, across the head and
//! through the grommets, to the tension head's gripper on the carriage. Its **extension**
//! is the carriage travel beyond the point where the slack is gone, `ε = x − x_taut`.
//! While `ε ≤ 0` the string hangs loose and carries no force.
//!
//! Over the first `toe` millimetres the string straightens and seats in the grommets:
//! the effective extension rises quadratically, `ε_eff = ε²/(2·toe)`, then linearly,
//! `ε_eff = ε − toe/2`, so force and stiffness are continuous.
//!
//! The force is a generalised standard linear solid (a Wiechert model): an equilibrium
//! spring `K_∞ = K₀ · (1 − Σ fᵢ)` in parallel with two Maxwell arms of stiffness
//! `Kᵢ = fᵢ · K₀` and time constant `τᵢ`:
//!
//! ```text
//! T = K_∞ · ε_eff + Σ Fᵢ,      dFᵢ/dt = Kᵢ · dε_eff/dt − Fᵢ / τᵢ
//! ```
//!
//! so a fast pull sees the instantaneous stiffness `K₀` (the `stiffness_kgf_per_cm` of
//! the configuration), a string held at fixed length **relaxes** toward `K_∞ · ε_eff`,
//! and a string held at fixed tension **creeps** — the tension head must keep moving
//! during the hold. Each arm is advanced exactly for a constant strain rate over the
//! step.
//!
//! On top of the viscous arms the string has **rate-independent hysteresis**, the internal
//! friction of the polymer or gut: a string let back carries less than it did at the same
//! length on the way up, however slowly either was done. A normalised Dahl (Prandtl-type)
//! friction element `s ∈ [−1, 1]` follows the direction of the extension's motion and turns
//! round exponentially in the extension travelled, over a strain `δ`:
//!
//! ```text
//! ds/dε_eff = (sgn(dε_eff) − s) / δ,      T_h = T · (1 + h·s)
//! ```
//!
//! so after a few `δ` of drawing out the tension is `(1 + h)` of the viscoelastic `T`, after a
//! few `δ` of letting back `(1 − h)`: the loop is `2h·T` wide. The element is advanced exactly
//! for the step's extension change (`s → sgn + (s − sgn)·e^(−|Δε|/δ)`), so it is continuous,
//! unconditionally stable, independent of the step and of the rate, and does nothing while
//! the extension stands still; it scales with `T`, so it vanishes with the tension and never
//! makes the string push. With `h = 0` the tension is the viscoelastic one exactly. A string
//! cannot push: the tension is `max(0, T_h)`.
//!
//! The string breaks when its tension reaches the configured break tension, at the
//! configured time, or on request; from then on it carries nothing and no longer turns
//! the length encoder.

use crate::params::{NEWTONS_PER_KGF, StringParams};

/// What state the string is in.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum StringState {
    /// No string in the machine.
    Absent,
    /// The string is loose: the carriage has not taken up the slack.
    Slack,
    /// The string is straight and carries tension.
    Taut,
    /// The string has broken.
    Broken,
}

/// The string's state variables.
#[derive(Clone, Debug)]
pub struct StringModel {
    params: StringParams,
    /// Carriage position where the slack is gone, m.
    taut_at_m: f64,
    toe_m: f64,
    /// Instantaneous stiffness, N/m.
    stiffness: f64,
    /// Maxwell-arm forces, N.
    arms: [f64; 2],
    /// Effective extension at the previous update, m.
    last_extension: f64,
    /// The hysteresis element's state `s` (−1 let back … +1 drawn out).
    friction: f64,
    /// The extension over which the element turns round, m.
    friction_strain_m: f64,
    state: StringState,
    tension_n: f64,
}

impl StringModel {
    /// A string whose slack is gone when the carriage reaches `start_m + slack`.
    #[must_use]
    pub fn new(params: &StringParams, start_m: f64) -> Self {
        Self {
            params: *params,
            taut_at_m: start_m + params.slack_mm * 1e-3,
            toe_m: (params.toe_mm * 1e-3).max(1e-9),
            stiffness: params.stiffness_kgf_per_cm * NEWTONS_PER_KGF * 100.0,
            arms: [0.0; 2],
            last_extension: 0.0,
            friction: 0.0,
            friction_strain_m: (params.hysteresis_strain_mm * 1e-3).max(1e-9),
            state: if params.present() { StringState::Slack } else { StringState::Absent },
            tension_n: 0.0,
        }
    }

    /// The string's state.
    #[must_use]
    pub const fn state(&self) -> StringState {
        self.state
    }

    /// The tension, N.
    #[must_use]
    pub const fn tension_n(&self) -> f64 {
        self.tension_n
    }

    /// How fast the tension would fall at constant length now, N/s: `Σ aᵢ/τᵢ` over the
    /// relaxation arms — the string's creep, which a constant-pull hold makes up by
    /// stretching it further (`K·ẋ` equals it while the tension is held constant).
    #[must_use]
    pub fn relaxation_rate_n_per_s(&self) -> f64 {
        self.arms.iter().zip(self.params.relaxation).map(|(a, arm)| a / arm.time_constant_s).sum()
    }

    /// Whether the string is in the machine and unbroken (it then moves with the carriage).
    #[must_use]
    pub const fn attached(&self) -> bool {
        matches!(self.state, StringState::Slack | StringState::Taut)
    }

    /// Breaks the string now.
    pub fn break_now(&mut self) {
        if self.attached() {
            self.state = StringState::Broken;
            self.tension_n = 0.0;
            self.arms = [0.0; 2];
            self.friction = 0.0;
        }
    }

    /// The effective (toe-blended) extension for carriage position `x_m`, m.
    fn effective_extension(&self, x_m: f64) -> f64 {
        let stretch = x_m - self.taut_at_m;
        if stretch <= 0.0 {
            0.0
        } else if stretch < self.toe_m {
            stretch * stretch / (2.0 * self.toe_m)
        } else {
            stretch - 0.5 * self.toe_m
        }
    }

    /// Advances the string by `dt` seconds to carriage position `x_m` at time `now_s`;
    /// returns the tension in newtons.
    pub fn update(&mut self, x_m: f64, dt: f64, now_s: f64) -> f64 {
        if !self.attached() {
            return 0.0;
        }
        if self.params.break_at_s.is_some_and(|at| now_s >= at) {
            self.break_now();
            return 0.0;
        }
        let extension = self.effective_extension(x_m);
        let step = extension - self.last_extension;
        let rate = step / dt;
        self.last_extension = extension;
        let mut relaxing_share = 0.0;
        for (force, arm) in self.arms.iter_mut().zip(self.params.relaxation) {
            let k = arm.fraction * self.stiffness;
            let decay = (-dt / arm.time_constant_s).exp();
            // Exact for a constant strain rate over the step.
            *force = *force * decay + k * arm.time_constant_s * rate * (1.0 - decay);
            relaxing_share += arm.fraction;
        }
        let equilibrium = self.stiffness * (1.0 - relaxing_share) * extension;
        let mut total = equilibrium + self.arms.iter().sum::<f64>();
        let h = self.params.hysteresis_fraction;
        if h > 0.0 {
            // Exact for the step's extension change; nothing moves while it stands still.
            let direction = if step > 0.0 {
                1.0
            } else if step < 0.0 {
                -1.0
            } else {
                self.friction
            };
            let decay = (-step.abs() / self.friction_strain_m).exp();
            self.friction = direction + (self.friction - direction) * decay;
            total *= 1.0 + h * self.friction;
        }
        self.tension_n = total.max(0.0);
        self.state = if extension > 0.0 { StringState::Taut } else { StringState::Slack };
        if let Some(limit) = self.params.break_at_kgf {
            if self.tension_n >= limit * NEWTONS_PER_KGF {
                self.break_now();
            }
        }
        self.tension_n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::StringKind;

    #[test]
    fn no_force_until_the_slack_is_gone_then_stiffness() {
        let params = StringParams::nominal(StringKind::TennisSynthetic);
        let mut s = StringModel::new(&params, 0.0);
        let dt = 1e-3;
        for k in 0..30 {
            let x = f64::from(k) * 1e-3;
            assert_eq!(s.update(x, dt, 0.0), 0.0, "{x}");
        }
        let slack = params.slack_mm * 1e-3;
        let x = slack + 0.010;
        // Pull 10 mm in 1 ms: instantaneous stiffness.
        let t = s.update(x, dt, 0.0);
        let k0 = params.stiffness_kgf_per_cm * NEWTONS_PER_KGF * 100.0;
        let expected = k0 * (0.010 - 0.5 * params.toe_mm * 1e-3);
        assert!((t - expected).abs() / expected < 0.01, "{t} vs {expected}");
        assert_eq!(s.state(), StringState::Taut);
    }

    #[test]
    fn held_string_relaxes_toward_the_equilibrium_spring() {
        let params = StringParams::nominal(StringKind::TennisPolyester);
        let mut s = StringModel::new(&params, 0.0);
        let x = params.slack_mm * 1e-3 + 0.02;
        let first = s.update(x, 1e-3, 0.0);
        let mut later = first;
        for _ in 0..600_000 {
            later = s.update(x, 1e-3, 0.0);
        }
        let share: f64 = params.relaxation.iter().map(|a| a.fraction).sum();
        assert!(later < first);
        assert!((later / first - (1.0 - share)).abs() < 0.01, "{}", later / first);
    }

    #[test]
    fn breaks_at_the_configured_tension() {
        let mut params = StringParams::nominal(StringKind::TennisSynthetic);
        params.break_at_kgf = Some(10.0);
        let mut s = StringModel::new(&params, 0.0);
        let mut x = 0.0;
        let mut peak: f64 = 0.0;
        while s.attached() {
            x += 1e-5;
            peak = peak.max(s.update(x, 1e-3, 0.0));
        }
        assert_eq!(s.state(), StringState::Broken);
        // The last tension reported before the break was within one step of the limit.
        assert!(peak < 10.0 * NEWTONS_PER_KGF && peak > 9.9 * NEWTONS_PER_KGF, "{peak}");
        assert_eq!(s.update(x + 0.1, 1e-3, 0.0), 0.0);
    }

    /// (carriage position m, tension N) along one way of a path.
    type Curve = Vec<(f64, f64)>;

    /// A stiff tennis string without creep (so only the rate-independent loop remains) with
    /// hysteresis `h` over `δ` = 0.1 mm, drawn from `start` to `top` and let back to `end`
    /// in steps of `step_m`: the tensions at every position, on the way up and on the way back.
    fn loop_tensions(h: f64, step_m: f64, dt: f64) -> (Curve, Curve) {
        let mut params = StringParams::nominal(StringKind::TennisPolyester);
        params.relaxation =
            [crate::params::RelaxationArm { fraction: 0.0, time_constant_s: 1.0 }; 2];
        params.hysteresis_fraction = h;
        params.hysteresis_strain_mm = 0.1;
        let mut s = StringModel::new(&params, 0.0);
        let slack = params.slack_mm * 1e-3;
        let (top, back) = (slack + 0.020, slack + 0.018);
        let mut up = Vec::new();
        let mut x = 0.0;
        while x < top - 0.5 * step_m {
            x += step_m;
            up.push((x, s.update(x, dt, 0.0)));
        }
        let mut down = Vec::new();
        while x > back + 0.5 * step_m {
            x -= step_m;
            down.push((x, s.update(x, dt, 0.0)));
        }
        (up, down)
    }

    #[test]
    fn hysteresis_lets_the_string_back_below_its_way_up() {
        let h = 0.02;
        let (up, down) = loop_tensions(h, 1e-6, 50e-6);
        let (plain_up, _) = loop_tensions(0.0, 1e-6, 50e-6);
        // 1.5 mm back from the top (15 δ): the element has turned all the way round.
        let at = |curve: &[(f64, f64)], x: f64| {
            curve.iter().min_by(|a, b| (a.0 - x).abs().total_cmp(&(b.0 - x).abs())).map(|p| p.1)
        };
        let x = down.last().map(|p| p.0).unwrap_or_default() + 0.5e-3;
        let (rising, falling, elastic) =
            (at(&up, x).unwrap(), at(&down, x).unwrap(), at(&plain_up, x).unwrap());
        assert!(elastic > 100.0, "{elastic} N");
        assert!((rising / elastic - (1.0 + h)).abs() < 1e-6, "{rising} vs {elastic}");
        assert!((falling / elastic - (1.0 - h)).abs() < 1e-6, "{falling} vs {elastic}");
        let width = (rising - falling) / elastic;
        assert!((width - 2.0 * h).abs() < 1e-6, "loop {width} of the tension");
        // Continuous: no step of the tension larger than the string's own (K·Δx, here
        // ≈ 0.12 N per µm) plus the element's turn-round (2h·T·Δx/δ ≤ 0.1 N per µm).
        for pair in up.windows(2).chain(down.windows(2)) {
            assert!((pair[1].1 - pair[0].1).abs() < 0.25, "{pair:?}");
        }
        // Rate-independent and step-independent: ten times the step and the time step draw
        // the same loop.
        let (coarse_up, coarse_down) = loop_tensions(h, 1e-5, 500e-6);
        for (coarse, fine) in [(&coarse_up, &up), (&coarse_down, &down)] {
            for &(x, t) in coarse {
                let reference = at(fine, x).unwrap();
                assert!(
                    (t - reference).abs() < 1e-6 * reference.max(1.0),
                    "{x}: {t} vs {reference}"
                );
            }
        }
    }

    #[test]
    fn without_hysteresis_the_string_is_the_viscoelastic_one_exactly() {
        let params = StringParams::nominal(StringKind::TennisSynthetic);
        assert_eq!(params.hysteresis_fraction, 0.0);
        let mut s = StringModel::new(&params, 0.0);
        // The Wiechert model written out on its own, for the same back-and-forth path.
        let k0 = params.stiffness_kgf_per_cm * NEWTONS_PER_KGF * 100.0;
        let toe = params.toe_mm * 1e-3;
        let taut_at = params.slack_mm * 1e-3;
        let (mut arms, mut last) = ([0.0_f64; 2], 0.0);
        let dt = 50e-6;
        for k in 0..40_000 {
            let t = f64::from(k) * dt;
            let x = taut_at + 0.012 * (1.0 - (t * 3.0).cos()) - 0.002;
            let stretch = x - taut_at;
            let e = if stretch <= 0.0 {
                0.0
            } else if stretch < toe {
                stretch * stretch / (2.0 * toe)
            } else {
                stretch - 0.5 * toe
            };
            let rate = (e - last) / dt;
            last = e;
            let mut share = 0.0;
            for (force, arm) in arms.iter_mut().zip(params.relaxation) {
                let decay = (-dt / arm.time_constant_s).exp();
                *force =
                    *force * decay + arm.fraction * k0 * arm.time_constant_s * rate * (1.0 - decay);
                share += arm.fraction;
            }
            let expected = (k0 * (1.0 - share) * e + arms.iter().sum::<f64>()).max(0.0);
            assert_eq!(s.update(x, dt, t).to_bits(), expected.to_bits(), "{t} s");
        }
    }

    #[test]
    fn no_string_never_pulls() {
        let mut s = StringModel::new(&StringParams::nominal(StringKind::NoString), 0.0);
        assert_eq!(s.state(), StringState::Absent);
        assert_eq!(s.update(0.2, 1e-3, 0.0), 0.0);
    }
}

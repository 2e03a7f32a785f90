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
//! step. A string cannot push: the tension is `max(0, T)`.
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
        let rate = (extension - self.last_extension) / dt;
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
        let total = equilibrium + self.arms.iter().sum::<f64>();
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

    #[test]
    fn no_string_never_pulls() {
        let mut s = StringModel::new(&StringParams::nominal(StringKind::NoString), 0.0);
        assert_eq!(s.state(), StringState::Absent);
        assert_eq!(s.update(0.2, 1e-3, 0.0), 0.0);
    }
}

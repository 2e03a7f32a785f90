//! The motor's electrical side: trapezoidal back-EMF, Hall sensors, and the three-phase
//! winding currents under the bridge's switch pattern, body diodes included.
//!
//! # Theory of operation
//!
//! **Back-EMF.** Each phase's back-EMF is `e_x = k_e · ω_m · f_x(θ_e)` with `f_x` a
//! trapezoid of height ±1: phase A rises through zero at θ_e = 0°, is flat at +1 from
//! `ramp/2` to `180° − ramp/2`, falls through zero at 180°, and is flat at −1 on the other
//! side; B and C are A delayed by 120° and 240°. With the ideal 60° ramp the flat top is
//! 120° wide and six-step drive gives constant torque; a real winding's top is narrower
//! (the nominal ramp is 80°, a 100° top), so torque dips at each commutation — the
//! six-step torque ripple the paper notes. `k_e` (per phase, peak) is chosen so that the
//! line-to-line EMF **averaged over a sector** equals the motor's `Ke`, so the speed
//! constant stays the one derived from the paper's 3 700 rpm whatever the ramp.
//! Torque is power over speed: `T = k_e · Σ f_x · i_x`.
//!
//! **Hall sensors.** Hall X is high for the 180° that starts where phase X's flat top
//! starts in the ideal machine (A over 30°–210°), the mounting `taut_core::drive::
//! commutation` derives its table from; a mounting error shifts all three.
//!
//! **Currents.** The windings are a star of three `R`–`L` branches with EMFs. Each leg of
//! the bridge either ties its phase to a voltage (high-side MOSFET on: the bus; low-side
//! on: ground) or is off, when the phase can only conduct through a body diode: current
//! flowing *into* the motor is drawn from ground through the low diode (terminal at
//! `−V_d`), current flowing *out* returns to the bus through the high diode (terminal at
//! `V_bus + V_d`), and a phase with no current floats.
//!
//! **The switched leg is complementary** (`taut_core::drive::commutation`, "The switched
//! leg is complementary"; the firmware's TIM1 CHx/CHxN pairs): within one PWM period of
//! length `T` the leg marked `High` goes through four parts, as the timer's dead-time
//! generator produces them (every rising gate edge delayed by the dead time `t_d`):
//!
//! | part | length | switched leg |
//! |---|---|---|
//! | dead time | `t_d` | both off: body diodes |
//! | on | `D·T − t_d` | high side: the bus |
//! | dead time | `t_d` | both off: body diodes |
//! | off | `(1 − D)·T − t_d` | **low side: ground** |
//!
//! (a pulse shorter than the dead time never turns the high side on; `D = 0` keeps the low
//! side on all period, with no edge at all). The sector's `Low` leg stays on throughout. So
//! the winding pair sees `D·V_bus` on average for either direction of its current, less the
//! dead-time distortion `≈ ±(t_d/T)·V_bus` whose sign follows the current: the drive works
//! in two quadrants, and a duty below the back-EMF ratio drives the current backwards —
//! the motor brakes and returns energy to the bus through the high side (and the high body
//! diode in the dead times). The twin integrates the parts of every period separately (no
//! finer PWM-edge detail is needed: the electrical time constant `L/R` ≈ 1 ms is twenty PWM
//! periods), so the average is exact.
//!
//! **The bus.** [`PeriodResult::bus_charge`] is the charge the bridge took from the DC bus
//! in the period (negative while regenerating): the high switch's current in its on-part
//! plus any current returned through a high body diode. The twin's DC-bus model
//! (`crate::twin`) turns it into the bus voltage for the next period.
//!
//! Within a part every conducting branch obeys `L di/dt = u − R i` with `u` constant
//! (the neutral point found from Kirchhoff's current law), solved exactly:
//! `i(t) = u/R + (i₀ − u/R)·e^(−t/τ)`. The only events are a diode-conducting current
//! reaching zero (the diode blocks: the phase floats from then on), a floating phase's
//! terminal being pushed beyond a rail by its back-EMF (its diode starts conducting),
//! and the bus current reaching the comparator level (the hardware break switches every
//! leg off for the rest of the period). Each is found analytically and the integration
//! restarts from it, so the solution is exact for piecewise-constant EMF and the step
//! is unconditionally stable.
//!
//! **An inter-turn short** (an injected fault) leaves a fraction `s` of one phase's turns
//! in circuit. Its resistance, inductance and back-EMF are taken as `s` times the healthy
//! phase's, so every branch keeps the time constant `L/R` and the star point becomes the
//! `1/s`-weighted mean of `v − e` — the solution stays exact. (A real short scales the
//! inductance nearer `s²`, and the shorted turns carry a circulating current that drags the
//! rotor; both make the real fault's current rise faster than the twin's, not slower.)

use taut_core::drive::{HallCode, LegState, Phase, SwitchPattern};

/// Most topology events handled within one part of a PWM period (each diode can block
/// once, one can start, one comparator trip); more means a numerical pathology, and the
/// remaining time is integrated in the last topology.
const MAX_EVENTS: usize = 8;

/// Below this a current is taken as zero, A.
const ZERO_AMPS: f64 = 1e-12;

/// The shape `f_x(θ_e)` of the three phases' back-EMF at electrical angle `theta_e_deg`
/// (any real; reduced modulo 360°), for ramps `ramp_deg` wide.
#[must_use]
pub fn emf_shape(theta_e_deg: f64, ramp_deg: f64) -> [f64; 3] {
    [
        trapezoid(theta_e_deg, ramp_deg),
        trapezoid(theta_e_deg - 120.0, ramp_deg),
        trapezoid(theta_e_deg - 240.0, ramp_deg),
    ]
}

/// An angle reduced to `[0, 360)` degrees (cheaper than `rem_euclid`, which calls `fmod`).
#[must_use]
pub fn wrap_degrees(theta_deg: f64) -> f64 {
    let t = theta_deg - 360.0 * (theta_deg * (1.0 / 360.0)).floor();
    // Rounding can leave exactly 360.0 for tiny negative inputs.
    if t >= 360.0 { t - 360.0 } else { t }
}

/// Phase A's trapezoid: zero crossings at 0° (rising) and 180° (falling).
fn trapezoid(theta_deg: f64, ramp_deg: f64) -> f64 {
    let half = (ramp_deg * 0.5).max(1e-9);
    let t = wrap_degrees(theta_deg);
    // Distance to the rising crossing at 0°/360°, signed, in (−180, 180].
    let from_rise = if t > 180.0 { t - 360.0 } else { t };
    if from_rise >= 0.0 {
        // Upper half: rising ramp from 0°, flat top, falling ramp to 180°.
        (from_rise.min(180.0 - from_rise) / half).min(1.0)
    } else {
        -((-from_rise).min(180.0 + from_rise) / half).min(1.0)
    }
}

/// The sector average of half the driven line's shape, `(f_high − f_low)/2`, over the
/// sector 30°–90° with A high and B low (the same for every sector by symmetry): the
/// factor between the peak per-phase EMF constant and the sector-averaged `Ke`.
#[must_use]
pub fn sector_shape_factor(ramp_deg: f64) -> f64 {
    const SAMPLES: u32 = 600;
    let mut sum = 0.0;
    for k in 0..SAMPLES {
        let theta = 30.0 + 60.0 * (f64::from(k) + 0.5) / f64::from(SAMPLES);
        let [a, b, _] = emf_shape(theta, ramp_deg);
        sum += (a - b) * 0.5;
    }
    sum / f64::from(SAMPLES)
}

/// The Hall code the sensors output at electrical angle `theta_e_deg` (A high over
/// 30°–210°, B over 150°–330°, C over 270°–90°).
#[must_use]
pub fn hall_code(theta_e_deg: f64) -> HallCode {
    let high = |start: f64| wrap_degrees(theta_e_deg - start) < 180.0;
    HallCode::from_lines(high(30.0), high(150.0), high(270.0))
}

/// The Hall code of sensors mounted `common_deg` electrical degrees late as a group, and
/// each of A, B, C a further `sensors_deg` late (per-sensor placement error).
#[must_use]
pub fn hall_code_placed(theta_e_deg: f64, common_deg: f64, sensors_deg: [f64; 3]) -> HallCode {
    if sensors_deg == [0.0; 3] {
        return hall_code(theta_e_deg - common_deg);
    }
    let [a, b, c] = sensors_deg;
    let theta = theta_e_deg - common_deg;
    let high = |start: f64, late: f64| wrap_degrees(theta - late - start) < 180.0;
    HallCode::from_lines(high(30.0, a), high(150.0, b), high(270.0, c))
}

/// The parts of a PWM period, as the switched leg sees them.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Part {
    /// The high side conducts.
    On,
    /// Both switches off (the dead time at either edge).
    Dead,
    /// The low side conducts (the complement).
    Off,
}

/// What one leg does during one part of a PWM period.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Terminal {
    /// A MOSFET ties the phase to this voltage (conducts both ways).
    Source { volts: f64, bus: bool },
    /// Both switches off: only the body diodes can conduct.
    Diode,
}

/// The circuit constants of the winding and bridge.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Circuit {
    /// Phase resistance (winding + MOSFET), Ω.
    pub resistance: f64,
    /// Phase inductance, H.
    pub inductance: f64,
    /// Bus voltage, V (the twin sets it every period from its DC-bus model).
    pub bus_volts: f64,
    /// Body-diode drop, V.
    pub diode_drop: f64,
    /// Comparator level on the bus current, A.
    pub comparator_amps: f64,
    /// Hardware dead time at every rising gate edge of the switched leg, s.
    pub dead_time: f64,
    /// Per phase, the fraction of the winding's turns in circuit (1 = healthy): an
    /// inter-turn short leaves `s < 1` of the turns, scaling that phase's resistance,
    /// inductance and back-EMF by `s` (see [`Circuit::HEALTHY`] and the module docs).
    pub phase_scale: [f64; 3],
}

/// One part of a PWM period as the DC link sees it: how long it lasted and the charge the
/// bridge drew from the bus in it.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct BusSegment {
    /// Length of the part, s.
    pub duration: f64,
    /// Charge drawn from the bus in the part, C (negative while regenerating).
    pub charge: f64,
}

/// What happened during one PWM period.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct PeriodResult {
    /// Time-average of each phase current over the period, A.
    pub mean_current: [f64; 3],
    /// Time-average of the bus current over the high side's on-time (what a shunt sample
    /// taken during the on-time reads), A; zero when no high side conducted.
    pub on_bus_current: f64,
    /// The on-time that was actually applied, s (cut short by a comparator trip).
    pub on_time: f64,
    /// Largest |phase current| seen in the period, A.
    pub peak_current: f64,
    /// The comparator fired: the hardware break switched the bridge off.
    pub comparator_tripped: bool,
    /// Charge drawn from the DC bus over the period, C (A·s): the high switches' current
    /// plus the current returned through high body diodes; negative when regenerating.
    pub bus_charge: f64,
    /// Time-average of each phase current over the high side's on-time (what a sample taken
    /// mid on-time reads), A; equal to [`PeriodResult::mean_current`] when there was no
    /// on-time.
    pub on_mean_current: [f64; 3],
    /// The parts of the period in order (dead time, on, dead time, off; or dead time, on,
    /// break), with the charge each drew from the bus: the DC-link current's waveform at the
    /// resolution of the parts, for an RC-filtered DC-link shunt. Unused entries are zero.
    pub bus_segments: [BusSegment; 4],
}

/// The parts of a period recorded as they are solved.
#[derive(Default)]
struct Segments {
    parts: [BusSegment; 4],
    count: usize,
    /// The bus charge accumulated before the part being recorded.
    charge_before: f64,
}

impl Segments {
    /// Records a part of `duration` that ended with the accumulator at `acc`.
    fn push(&mut self, duration: f64, acc: &Accumulator) {
        if let Some(part) = self.parts.get_mut(self.count) {
            *part = BusSegment { duration, charge: acc.bus_integral - self.charge_before };
            self.count = self.count.saturating_add(1);
        }
        self.charge_before = acc.bus_integral;
    }
}

/// Accumulates integrals while a PWM period is solved.
#[derive(Default)]
struct Accumulator {
    current_integral: [f64; 3],
    /// ∫ current through the conducting high-side switches (what the shunt sees).
    shunt_integral: f64,
    /// ∫ current drawn from the bus (switches and high body diodes).
    bus_integral: f64,
    peak: f64,
}

impl Circuit {
    /// [`Circuit::phase_scale`] of a healthy winding.
    pub const HEALTHY: [f64; 3] = [1.0; 3];

    /// Solves one PWM period of length `period_s`: the `pattern` with its switched (`High`)
    /// leg complementary at `duty` — dead time, high side, dead time, low side (see the
    /// module docs) — with `emf` the phase back-EMFs (V), held over the period. `currents`
    /// are advanced in place. A comparator trip in the on-part switches every leg off for
    /// the rest of the period (the timer's break input).
    pub fn pwm_period(
        &self,
        currents: &mut [f64; 3],
        pattern: SwitchPattern,
        duty: f64,
        emf: [f64; 3],
        period_s: f64,
    ) -> PeriodResult {
        let duty = duty.clamp(0.0, 1.0);
        let has_high = pattern.count(LegState::High) > 0;
        let dead = self.dead_time.clamp(0.0, 0.5 * period_s);
        let pulse = duty * period_s;
        // The parts of the period (see the module docs); lengths sum to `period_s`.
        let (lead_dead, on_time, trail_dead) = if !has_high || duty <= 0.0 {
            (0.0, 0.0, 0.0)
        } else if pulse <= dead {
            (0.0, 0.0, pulse + dead)
        } else {
            (dead, pulse - dead, dead)
        };
        let off_time = (period_s - lead_dead - on_time - trail_dead).max(0.0);
        let mut acc = Accumulator::default();
        let mut result = PeriodResult::default();
        let mut segments = Segments::default();

        let dead_legs = self.terminals(pattern, Part::Dead);
        if lead_dead > 0.0 {
            self.solve(currents, dead_legs, emf, lead_dead, false, &mut acc);
            segments.push(lead_dead, &acc);
        }
        let mut applied_on = on_time;
        if on_time > 0.0 {
            let on_legs = self.terminals(pattern, Part::On);
            let before = acc.shunt_integral;
            let currents_before = acc.current_integral;
            let (elapsed, tripped) = self.solve(currents, on_legs, emf, on_time, true, &mut acc);
            applied_on = elapsed;
            result.comparator_tripped = tripped;
            if applied_on > 0.0 {
                result.on_bus_current = (acc.shunt_integral - before) / applied_on;
                for ((mean, after), before) in
                    result.on_mean_current.iter_mut().zip(acc.current_integral).zip(currents_before)
                {
                    *mean = (after - before) / applied_on;
                }
            }
            segments.push(applied_on, &acc);
        }
        if result.comparator_tripped {
            // The break: every gate off for the rest of the period.
            let rest = period_s - lead_dead - applied_on;
            if rest > 0.0 {
                self.solve(currents, [Terminal::Diode; 3], emf, rest, false, &mut acc);
                segments.push(rest, &acc);
            }
        } else {
            if trail_dead > 0.0 {
                self.solve(currents, dead_legs, emf, trail_dead, false, &mut acc);
                segments.push(trail_dead, &acc);
            }
            if off_time > 0.0 {
                let off_legs = self.terminals(pattern, Part::Off);
                self.solve(currents, off_legs, emf, off_time, false, &mut acc);
                segments.push(off_time, &acc);
            }
        }
        for (mean, integral) in result.mean_current.iter_mut().zip(acc.current_integral) {
            *mean = integral / period_s;
        }
        if applied_on <= 0.0 {
            result.on_mean_current = result.mean_current;
        }
        result.on_time = applied_on;
        result.peak_current = acc.peak;
        result.bus_charge = acc.bus_integral;
        result.bus_segments = segments.parts;
        result
    }

    /// The legs' terminals during one part of the period: the switched leg is the bus in
    /// the on-part, ground (its low side, the complement) in the off-part and a body diode
    /// pair in the dead times; the sector's low leg is ground throughout.
    fn terminals(&self, pattern: SwitchPattern, part: Part) -> [Terminal; 3] {
        Phase::ALL.map(|phase| match (pattern.leg(phase), part) {
            (LegState::High, Part::On) => Terminal::Source { volts: self.bus_volts, bus: true },
            (LegState::High, Part::Off) | (LegState::Low, _) => {
                Terminal::Source { volts: 0.0, bus: false }
            }
            (LegState::High, Part::Dead) | (LegState::Off, _) => Terminal::Diode,
        })
    }

    /// Integrates `duration` seconds with fixed terminals, handling diode and comparator
    /// events; returns the time integrated before a comparator trip (or `duration`) and
    /// whether it tripped (only checked when `armed`).
    fn solve(
        &self,
        currents: &mut [f64; 3],
        legs: [Terminal; 3],
        emf: [f64; 3],
        duration: f64,
        armed: bool,
        acc: &mut Accumulator,
    ) -> (f64, bool) {
        let tau = self.inductance / self.resistance;
        let healthy = self.phase_scale == Self::HEALTHY;
        let mut remaining = duration;
        // Constant bound: MAX_EVENTS topology changes per part.
        for _ in 0..MAX_EVENTS {
            if remaining <= 0.0 {
                break;
            }
            let Some(volts) = self.topology(currents, legs, emf) else {
                // No conducting path: every current is (and stays) zero.
                *currents = [0.0; 3];
                break;
            };
            let neutral = self.neutral_point(volts, emf);
            // Asymptotes of the conducting branches; a floating branch has no current.
            let asymptote: [f64; 3] =
                core::array::from_fn(|k| match (volts.get(k).copied().flatten(), emf.get(k)) {
                    (Some(v), Some(&e)) if healthy => (v - e - neutral) / self.resistance,
                    (Some(v), Some(&e)) => {
                        let scale = self.phase_scale.get(k).copied().unwrap_or(1.0);
                        (v - e - neutral) / (self.resistance * scale)
                    }
                    _ => 0.0,
                });

            // The earliest event within `remaining`. A logarithm is taken only for a
            // branch whose current really crosses its level before `remaining` is up.
            let full_decay = (-remaining / tau).exp();
            let mut step = remaining;
            let mut blocking: Option<usize> = None;
            let mut trip = false;
            for (k, ((&i0, &a), &leg)) in
                currents.iter().zip(asymptote.iter()).zip(legs.iter()).enumerate()
            {
                let at_end = a + (i0 - a) * full_decay;
                if leg == Terminal::Diode && i0 != 0.0 && i0 * a < 0.0 && i0 * at_end <= 0.0 {
                    // A diode current decaying toward the opposite sign: it blocks at zero.
                    let t = tau * ((i0 - a) / (-a)).ln();
                    if t < step {
                        step = t.max(0.0);
                        blocking = Some(k);
                        trip = false;
                    }
                }
                if armed
                    && matches!(leg, Terminal::Source { bus: true, .. })
                    && a > self.comparator_amps
                    && i0 < self.comparator_amps
                    && at_end >= self.comparator_amps
                {
                    let t = tau * ((i0 - a) / (self.comparator_amps - a)).ln();
                    if t < step {
                        step = t.max(0.0);
                        blocking = None;
                        trip = true;
                    }
                }
            }

            // Advance every branch exactly by `step`.
            let decay = if step == remaining { full_decay } else { (-step / tau).exp() };
            let integral_factor = tau * (1.0 - decay);
            for (k, ((i, &a), &leg)) in
                currents.iter_mut().zip(asymptote.iter()).zip(legs.iter()).enumerate()
            {
                let i0 = *i;
                let integral = a * step + (i0 - a) * integral_factor;
                if let Some(total) = acc.current_integral.get_mut(k) {
                    *total += integral;
                }
                let high_switch = matches!(leg, Terminal::Source { bus: true, .. });
                if high_switch {
                    acc.shunt_integral += integral;
                }
                // Current returned through a high body diode (a diode leg on the upper rail)
                // flows into the bus.
                let high_diode = leg == Terminal::Diode
                    && volts.get(k).copied().flatten().is_some_and(|v| v > self.bus_volts);
                if high_switch || high_diode {
                    acc.bus_integral += integral;
                }
                *i = a + (i0 - a) * decay;
                acc.peak = acc.peak.max(i0.abs()).max(i.abs());
            }
            if let Some(k) = blocking {
                if let Some(i) = currents.get_mut(k) {
                    *i = 0.0;
                }
            }
            // Kirchhoff: the star point has no return, so the currents sum to zero.
            let [ia, ib, _] = *currents;
            currents[2] = -ia - ib;
            for i in currents.iter_mut() {
                if i.abs() < ZERO_AMPS {
                    *i = 0.0;
                }
            }
            remaining -= step;
            if trip {
                return (duration - remaining, true);
            }
        }
        (duration, false)
    }

    /// The terminal voltage of every conducting leg (`None` = floating), or `None` when
    /// fewer than two legs can conduct.
    fn topology(
        &self,
        currents: &[f64; 3],
        legs: [Terminal; 3],
        emf: [f64; 3],
    ) -> Option<[Option<f64>; 3]> {
        let low_diode = -self.diode_drop;
        let high_diode = self.bus_volts + self.diode_drop;
        let mut volts: [Option<f64>; 3] = [None; 3];
        for ((v, &leg), &i) in volts.iter_mut().zip(legs.iter()).zip(currents.iter()) {
            *v = match leg {
                Terminal::Source { volts, .. } => Some(volts),
                Terminal::Diode if i > 0.0 => Some(low_diode),
                Terminal::Diode if i < 0.0 => Some(high_diode),
                Terminal::Diode => None,
            };
        }
        let conducting = volts.iter().filter(|v| v.is_some()).count();
        if conducting >= 2 {
            // A floating phase whose terminal (e + neutral) leaves the rails starts
            // conducting through the diode it forward-biases.
            let neutral = self.neutral_point(volts, emf);
            for (v, &e) in volts.iter_mut().zip(emf.iter()) {
                if v.is_none() {
                    let terminal = e + neutral;
                    if terminal > high_diode {
                        *v = Some(high_diode);
                    } else if terminal < low_diode {
                        *v = Some(low_diode);
                    }
                }
            }
            return Some(volts);
        }
        // At most one fixed terminal and no current: find the pair (p into the motor, q
        // out of it) whose available voltage exceeds its back-EMF difference the most.
        let into = |k: usize| -> Option<f64> {
            match legs.get(k)? {
                Terminal::Source { volts, .. } => Some(*volts),
                Terminal::Diode => Some(low_diode),
            }
        };
        let out_of = |k: usize| -> Option<f64> {
            match legs.get(k)? {
                Terminal::Source { volts, .. } => Some(*volts),
                Terminal::Diode => Some(high_diode),
            }
        };
        let mut best: Option<(usize, usize, f64, f64, f64)> = None;
        for p in 0..3 {
            for q in 0..3 {
                if p == q {
                    continue;
                }
                let (Some(vp), Some(vq), Some(ep), Some(eq)) =
                    (into(p), out_of(q), emf.get(p), emf.get(q))
                else {
                    continue;
                };
                let drive = (vp - vq) - (ep - eq);
                if drive > 0.0 && best.is_none_or(|(_, _, _, _, d)| drive > d) {
                    best = Some((p, q, vp, vq, drive));
                }
            }
        }
        let (p, q, vp, vq, _) = best?;
        let mut pair: [Option<f64>; 3] = [None; 3];
        if let Some(slot) = pair.get_mut(p) {
            *slot = Some(vp);
        }
        if let Some(slot) = pair.get_mut(q) {
            *slot = Some(vq);
        }
        Some(pair)
    }
}

impl Circuit {
    /// The star point's voltage for the conducting legs: Kirchhoff's current law. With
    /// equal branch impedances it is the mean of `v − e` over the conducting legs; with an
    /// inter-turn short (branch `k` has `s_k` of the impedance, the same time constant) the
    /// mean weighted by `1/s_k`, which keeps every branch a first-order circuit of its own.
    fn neutral_point(&self, volts: [Option<f64>; 3], emf: [f64; 3]) -> f64 {
        if self.phase_scale == Self::HEALTHY {
            return neutral_point(volts, emf);
        }
        let mut sum = 0.0;
        let mut weight = 0.0;
        for ((v, e), s) in volts.iter().zip(emf).zip(self.phase_scale) {
            if let Some(v) = v {
                let w = 1.0 / s;
                sum += (v - e) * w;
                weight += w;
            }
        }
        if weight > 0.0 { sum / weight } else { 0.0 }
    }
}

/// The star point's voltage for the conducting legs: Kirchhoff's current law with equal
/// branch impedances gives the mean of `v − e` over the conducting legs.
fn neutral_point(volts: [Option<f64>; 3], emf: [f64; 3]) -> f64 {
    let mut sum = 0.0;
    let mut count = 0.0;
    for (v, e) in volts.iter().zip(emf) {
        if let Some(v) = v {
            sum += v - e;
            count += 1.0;
        }
    }
    if count > 0.0 { sum / count } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use taut_core::drive::{Direction, Sector, six_step};

    use super::*;

    #[test]
    fn trapezoid_has_flat_tops_and_zero_crossings() {
        for ramp in [60.0, 80.0, 120.0] {
            assert!(trapezoid(0.0, ramp).abs() < 1e-12);
            assert!(trapezoid(180.0, ramp).abs() < 1e-12);
            assert!((trapezoid(90.0, ramp) - 1.0).abs() < 1e-12);
            assert!((trapezoid(270.0, ramp) + 1.0).abs() < 1e-12);
            assert!((trapezoid(-90.0, ramp) + 1.0).abs() < 1e-12);
        }
        // Ideal machine: flat top exactly 30°–150°.
        assert!((trapezoid(30.0, 60.0) - 1.0).abs() < 1e-12);
        assert!((trapezoid(150.0, 60.0) - 1.0).abs() < 1e-12);
        assert!(trapezoid(29.0, 60.0) < 1.0);
        assert!((sector_shape_factor(60.0) - 1.0).abs() < 1e-9);
        assert!(sector_shape_factor(80.0) < 1.0);
    }

    #[test]
    fn hall_sequence_matches_the_commutation_table() {
        // Sector k spans 30° + 60°·k; its middle must read the sector's code.
        for sector in Sector::ALL {
            let middle = 60.0 + 60.0 * f64::from(sector.index());
            assert_eq!(hall_code(middle), sector.hall_code(), "{sector:?}");
        }
    }

    #[test]
    fn each_hall_sensor_switches_its_own_placement_late() {
        let perfect = |theta: f64| hall_code(theta);
        // A 3° late, B 2° early, C exact; all 1° late in common.
        let placed = |theta: f64| hall_code_placed(theta, 1.0, [3.0, -2.0, 0.0]);
        assert_eq!(hall_code_placed(47.0, 2.0, [0.0; 3]), perfect(45.0));
        for k in 0..3600 {
            let theta = f64::from(k) * 0.1;
            let q = placed(theta).raw();
            // A (bit 2) rises at 30° + 4°, B (bit 1) at 150° − 1°, C (bit 0) at 270° + 1°.
            let a = |t: f64| (perfect(t).raw() >> 2) & 1;
            let b = |t: f64| (perfect(t).raw() >> 1) & 1;
            let c = |t: f64| perfect(t).raw() & 1;
            assert_eq!((q >> 2) & 1, a(theta - 4.0), "A at {theta}");
            assert_eq!((q >> 1) & 1, b(theta + 1.0), "B at {theta}");
            assert_eq!(q & 1, c(theta - 1.0), "C at {theta}");
        }
    }

    #[test]
    fn six_step_pull_gives_positive_torque_release_negative() {
        for sector in Sector::ALL {
            for step in 0..60 {
                let theta = 30.0 + 60.0 * f64::from(sector.index()) + f64::from(step) + 0.5;
                let shape = emf_shape(theta, 60.0);
                for (direction, sign) in [(Direction::Pull, 1.0), (Direction::Release, -1.0)] {
                    let pattern = six_step(sector, direction);
                    // Unit current into the high leg and out of the low leg.
                    let torque: f64 = Phase::ALL
                        .iter()
                        .zip(shape)
                        .map(|(&phase, f)| match pattern.leg(phase) {
                            LegState::High => f,
                            LegState::Low => -f,
                            LegState::Off => 0.0,
                        })
                        .sum();
                    assert!((torque * sign - 2.0).abs() < 1e-9, "{sector:?} {direction:?}");
                }
            }
        }
    }

    fn circuit() -> Circuit {
        Circuit {
            resistance: 0.423,
            inductance: 0.4e-3,
            bus_volts: 24.0,
            diode_drop: 0.8,
            comparator_amps: 15.0,
            dead_time: 1e-6,
            phase_scale: Circuit::HEALTHY,
        }
    }

    #[test]
    fn two_phase_current_settles_to_the_averaged_voltage_over_resistance() {
        let c = circuit();
        let pattern = six_step(Sector::S0, Direction::Pull); // A+ B−
        let mut i = [0.0; 3];
        let mut last = PeriodResult::default();
        for _ in 0..2000 {
            last = c.pwm_period(&mut i, pattern, 0.25, [0.0; 3], 50e-6);
        }
        // Complementary leg, positive current: the bus for D·T − t_d, a low body diode for
        // the two dead times, ground for the rest — (0.25 − 0.02)·24 − 0.04·0.8 over 2R,
        // as the period's mean (the end-of-period value sits half the ripple lower).
        let expected = ((0.25 - 0.02) * 24.0 - 0.04 * 0.8) / (2.0 * 0.423);
        let mean = last.mean_current[0];
        assert!((mean - expected).abs() < 0.01, "{mean} vs {expected}");
        assert!((i[0] - expected).abs() < 0.2, "{i:?} vs {expected}");
        assert!((i[0] + i[1]).abs() < 1e-9 && i[2] == 0.0);
    }

    #[test]
    fn a_duty_below_the_back_emf_ratio_brakes_and_returns_charge_to_the_bus() {
        let c = circuit();
        let pattern = six_step(Sector::S0, Direction::Pull); // A+ B−
        // A spinning motor: line back-EMF 12 V (A +6 V, B −6 V), duty 0.25 → 6 V applied.
        let emf = [6.0, -6.0, 0.0];
        let mut i = [0.0; 3];
        let mut last = PeriodResult::default();
        for _ in 0..2000 {
            last = c.pwm_period(&mut i, pattern, 0.25, emf, 50e-6);
        }
        // The current runs backwards (braking torque) at ≈ (0.25·24 + 0.02·24 − 12)/2R: in
        // the dead times the high body diode carries it, adding t_d/T of the bus.
        let expected = ((0.25 + 0.02) * 24.0 + 0.04 * 0.8 - 12.0) / (2.0 * 0.423);
        assert!(i[0] < 0.0, "{i:?}");
        let mean = last.mean_current[0];
        assert!((mean - expected).abs() < 0.01, "{mean} vs {expected}");
        // Energy flows into the bus: the charge taken is negative, ≈ (D·T + t_d)·i per period.
        assert!(last.bus_charge < 0.0, "{last:?}");
        let expected_charge = (0.25 * 50e-6 + 1e-6) * expected;
        assert!((last.bus_charge / expected_charge - 1.0).abs() < 0.02, "{last:?}");
        // A low-side shunt sees none of it as positive current.
        assert!(last.on_bus_current < 0.0);
    }

    #[test]
    fn zero_duty_shorts_the_pair_through_the_low_sides() {
        let c = circuit();
        let pattern = six_step(Sector::S0, Direction::Pull);
        let mut i = [0.0; 3];
        let mut last = PeriodResult::default();
        for _ in 0..2000 {
            last = c.pwm_period(&mut i, pattern, 0.0, [3.0, -3.0, 0.0], 50e-6);
        }
        // No edge at all: both windings tied to ground, the back-EMF drives −6 V / 2R.
        assert!((i[0] + 6.0 / (2.0 * 0.423)).abs() < 1e-3, "{i:?}");
        assert_eq!(last.on_time, 0.0);
        assert!(last.bus_charge.abs() < 1e-12, "{last:?}");
    }

    #[test]
    fn floating_phase_current_decays_through_the_diode_then_blocks() {
        let c = circuit();
        // Current flowing A → B, then every switch off: it must decay to zero and stay.
        let mut i = [5.0, -5.0, 0.0];
        let r = c.pwm_period(&mut i, SwitchPattern::ALL_OFF, 0.0, [0.0; 3], 50e-6);
        assert!(i[0] >= 0.0 && i[0] < 5.0);
        for _ in 0..20 {
            c.pwm_period(&mut i, SwitchPattern::ALL_OFF, 0.0, [0.0; 3], 50e-6);
        }
        assert_eq!(i, [0.0; 3]);
        assert!(r.peak_current >= 5.0 - 1e-9);
    }

    #[test]
    fn comparator_breaks_the_bridge_at_its_level() {
        let c = circuit();
        let pattern = six_step(Sector::S0, Direction::Pull);
        let mut i = [14.6, -14.6, 0.0];
        let r = c.pwm_period(&mut i, pattern, 0.95, [0.0; 3], 50e-6);
        assert!(r.comparator_tripped);
        assert!(r.on_time < 0.95 * 50e-6);
        assert!(r.peak_current <= 15.0 + 1e-6, "{}", r.peak_current);
    }

    #[test]
    fn back_emf_beyond_the_bus_conducts_through_the_diodes() {
        let c = circuit();
        // All switches off, line EMF 40 V > 24 V + 2 diodes: current must flow.
        let mut i = [0.0; 3];
        c.pwm_period(&mut i, SwitchPattern::ALL_OFF, 0.0, [20.0, -20.0, 0.0], 50e-6);
        assert!(i[0] < 0.0 && i[1] > 0.0, "{i:?}");
        // 20 V line EMF < 25.6 V: nothing flows.
        let mut j = [0.0; 3];
        c.pwm_period(&mut j, SwitchPattern::ALL_OFF, 0.0, [10.0, -10.0, 0.0], 50e-6);
        assert_eq!(j, [0.0; 3]);
    }
}

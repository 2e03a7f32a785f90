//! Friction-aware hold: the carriage's slips, seen in the motor current, damped at once.
//!
//! # Theory of operation
//!
//! In the hold the carriage is stuck most of the time — the screw's static friction holds
//! it while the string relaxes — and moves in short slips when the law's duty passes the
//! breakaway. A slip is driven by the difference between static and kinetic friction and
//! runs, unchecked, until the tension has risen enough to stop it — on this machine's
//! cogging detents, one Hall step (52.9 µm; 0.06 kgf on polyester) at a time. The load
//! cell sees it late (noise forces it through a 20 ms filter) and the Hall counter only at
//! the next edge; the **motor current** sees it at once: with the rotor stuck the winding
//! carries `I = duty·V_bus/R`, and any motion subtracts its back-EMF, `Ke·ω/R`.
//!
//! So while the carriage is stuck (no Hall step for [`STUCK_TICKS`]), [`SlipDamper`] learns
//! the stall relation `duty ≈ d₀ + c·I` (`d₀`, the duty the high side loses to the bridge's
//! dead time — 0.02 on taut's board, handed in with the controller's configuration; `c = R/V`
//! learned division-free, `c ← c + μ·(duty − d₀ − c·I)`, which also follows the bus voltage
//! as braking's pump-up decays; once learned, only from residuals below 0.004, so a slip
//! is not learned away), and once it has learned for [`LEARN_TICKS`] it reads the residual
//! `r = duty_prev − d₀ − c·I` — the back-EMF of the motion, in duty — every tick. Beyond a
//! dead zone the residual is turned into a braking force `k·F_stall·(r − r₀)` subtracted
//! from the law's force: active damping of forward slips only, acting within a tick or two
//! of the breakaway, so a slip stops long before the next detent. No division, three
//! products per tick.
//!
//! The controller owns one ([`crate::tension::ProfileConfig::slip_damping`] sets its gain) and
//! asks it for a braking force every hold tick; `REQ-TEN-15` in `docs/SPEC.md` bounds it.

use crate::drive::Duty;
use crate::fixed::{mul_wide, saturate_i32};
use crate::units::{Amps, Kgf, Q16};

/// The slip damper's dead zone: residuals below 0.002 duty (≈ 0.16 mm/s of carriage) are
/// not braked.
pub const SLIP_DEAD_ZONE: Q16 = Q16::lit("0.002");

/// The slip damper's learning rate `μ` per tick, 0.005 (per ampere of winding current).
pub const SLIP_LEARNING_RATE: Q16 = Q16::lit("0.005");

/// Ticks without a Hall step after which the carriage counts as stuck and the current model
/// learns.
pub const STUCK_TICKS: u16 = 30;

/// Ticks of agreement (the stuck carriage's residual within 0.004 duty) the model needs
/// before the slip damper acts.
pub const LEARN_TICKS: u16 = 200;

/// Once learned, the largest model residual (duty) the current model keeps learning from:
/// 0.004 (a slip's back-EMF is larger and is not learned away).
const LEARN_BAND: i32 = 262;

/// The slip damper's memory (public for proofs and fuzzing, which draw it whole).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
#[cfg_attr(kani, derive(kani::Arbitrary))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct SlipState {
    /// The learned stall relation: duty per ampere of winding current, Q8.24 bits.
    pub duty_per_amp: i32,
    /// The duty commanded at the previous tick, Q15.16 bits.
    pub last_duty: i32,
    /// Ticks since the last Hall step (saturating).
    pub quiet: u16,
    /// Ticks the model has agreed with a stuck carriage (saturating at [`LEARN_TICKS`]).
    pub learned: u16,
}

/// The slip damper (see the module docs).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct SlipDamper {
    /// The braking force per unit of residual duty, kgf bits (`k·F_stall`).
    gain: i32,
    /// The residual below which nothing is done, duty bits.
    dead_zone: i32,
    /// The learning rate `μ`, Q15.16 bits.
    rate: i32,
    /// The model's starting point, duty per ampere (Q8.24 bits).
    initial: i32,
    /// `d₀`: the duty the high side loses to the dead time, Q15.16 bits.
    dead_time_duty: i32,
    state: SlipState,
}

impl SlipDamper {
    /// A damper with braking force `gain` (kgf per unit duty of residual), dead zone
    /// `dead_zone` (duty, Q15.16), learning rate `rate` (Q15.16) and the stall relation
    /// `initial` (duty per ampere, Q15.16) to start learning from, on a bridge whose dead time
    /// takes `dead_time_duty` from the high side (the dead time over the PWM period: the
    /// board's timing, [`crate::tension::ControllerConfig::dead_time_duty`]).
    #[must_use]
    pub fn new(gain: Q16, dead_zone: Q16, rate: Q16, initial: Q16, dead_time_duty: Duty) -> Self {
        let initial = initial.max(Q16::ZERO).to_bits().saturating_mul(256);
        Self {
            gain: gain.max(Q16::ZERO).to_bits(),
            dead_zone: dead_zone.max(Q16::ZERO).to_bits(),
            rate: rate.clamp(Q16::ZERO, Q16::ONE).to_bits(),
            initial,
            dead_time_duty: i32::from(dead_time_duty.raw()),
            state: SlipState { duty_per_amp: initial, ..SlipState::default() },
        }
    }

    /// The memory (proofs, fuzzing).
    #[must_use]
    pub const fn state(&self) -> SlipState {
        self.state
    }

    /// Replaces the memory (proofs, fuzzing).
    pub fn set_state(&mut self, state: SlipState) {
        self.state = state;
    }

    /// Starts learning afresh (a new pull: the bus and the motor's temperature may differ).
    pub fn reset(&mut self) {
        self.state = SlipState { duty_per_amp: self.initial, ..SlipState::default() };
    }

    /// One tick: the winding current measured over the last tick, the Hall steps moved, the
    /// duty commanded last tick, and whether the hold is on. Returns the braking force to
    /// subtract from the law's force (zero outside the hold, while learning, and when the
    /// carriage is still).
    pub fn update(&mut self, current: Amps, moved: i32, active: bool) -> Kgf {
        let s = &mut self.state;
        s.quiet = if moved == 0 { s.quiet.saturating_add(1) } else { 0 };
        if !active {
            return Kgf::ZERO;
        }
        // c (Q8.24) × I (Q15.16) → duty in Q15.16.
        let predicted =
            saturate_i32(mul_wide(s.duty_per_amp, current.to_bits()).saturating_add(1 << 23) >> 24)
                .saturating_add(self.dead_time_duty);
        let residual = s.last_duty.saturating_sub(predicted);
        let agrees = residual.saturating_abs() <= LEARN_BAND;
        if s.quiet >= STUCK_TICKS && (s.learned < LEARN_TICKS || agrees) {
            // residual (Q15.16) × μ (Q15.16) → Q8.24.
            let step = saturate_i32(mul_wide(residual, self.rate).saturating_add(1 << 7) >> 8);
            s.duty_per_amp = s.duty_per_amp.saturating_add(step).max(0);
            if agrees {
                s.learned = s.learned.saturating_add(1).min(LEARN_TICKS);
            }
        }
        let excess = residual.saturating_sub(self.dead_zone);
        if s.learned < LEARN_TICKS {
            return Kgf::ZERO;
        }
        // Only a forward residual brakes, and never by a negative force: the excess and the
        // gain as unsigned values, so the product's sign is the types' (no sign reasoning).
        let (Ok(excess), Ok(gain)) = (u32::try_from(excess), u32::try_from(self.gain)) else {
            return Kgf::ZERO;
        };
        // u32 × u32 < 2⁶⁴: exact. Rounded Q31.32 → Q15.16, saturated to i32::MAX.
        let product = u64::from(excess).wrapping_mul(u64::from(gain));
        let bits = product.saturating_add(1 << 15) >> 16;
        Kgf::from_bits(i32::try_from(bits).unwrap_or(i32::MAX))
    }

    /// Records the duty commanded this tick (read back at the next update).
    pub fn note_duty(&mut self, duty: Duty) {
        self.state.last_duty = duty.fraction().to_bits();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stuck carriage at 2 A and duty 0.02 + 0.046·2 (the twin's stall relation).
    fn stuck(damper: &mut SlipDamper, ticks: u32) {
        let duty = Duty::from_fraction_clamped(Q16::lit("0.112"));
        for _ in 0..ticks {
            damper.note_duty(duty);
            let brake = damper.update(Amps::from_int(2), 0, true);
            assert_eq!(brake, Kgf::ZERO, "a stuck carriage is not braked");
        }
    }

    #[test]
    fn the_slip_damper_learns_the_stall_relation_then_brakes_slips_only() {
        // Starts from R/V = 0.035 duty/A, 25 % off the stall relation.
        let mut damper = SlipDamper::new(
            Q16::const_from_int(550),
            Q16::lit("0.002"),
            Q16::lit("0.005"),
            Q16::lit("0.035"),
            crate::test_support::paper_board().dead_time_duty(),
        );
        // Inactive (outside the hold): nothing, and nothing learned.
        assert_eq!(damper.update(Amps::from_int(2), 0, false), Kgf::ZERO);
        stuck(&mut damper, 2_000);
        let learned = damper.state().duty_per_amp;
        // (0.112 − 0.02)/2 A = 0.046 duty/A = 771 700 in Q8.24.
        assert!((learned - 771_700).abs() <= 500, "learned {learned}");
        // A slip: the current drops by 0.3 A at the same duty — back-EMF of 0.014 duty.
        let brake = damper.update(Amps::from_milli(1_700), 0, true);
        let expected = 550 * (14 - 2); // k·F_stall·(r − r₀) in thousandths of duty
        assert!((brake.to_milli() / 1_000 - expected / 1_000).abs() <= 1, "{brake:?}");
        // A backward motion (current up) is not braked.
        assert_eq!(damper.update(Amps::from_milli(2_300), 0, true), Kgf::ZERO);
        // A new pull starts learning afresh.
        damper.reset();
        assert_eq!(damper.update(Amps::from_milli(1_700), 0, true), Kgf::ZERO);
    }
}

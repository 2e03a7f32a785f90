//! The mechanism's nameplate: how a Hall step becomes carriage travel, derived once.
//!
//! # Theory of operation
//!
//! The paper's drive train is a BLDC motor with three Hall sensors, a 1:20 gearbox and a
//! lead screw of 25.4 mm (1 inch) lead. Six-step commutation sees six Hall sectors per
//! electrical turn, so one mechanical motor turn is `6 × POLE_PAIRS` Hall steps, one screw
//! turn `GEAR_RATIO` motor turns, and one screw turn moves the carriage by `LEAD_NM`. Every
//! conversion between Hall steps and carriage travel in taut — the controller's speed and
//! travel, the observer's stiffness, the no-string rule's 150 mm — is computed here from
//! these three numbers at compile time, so a machine with another gearbox or screw is a change
//! of one constant.
//!
//! These are nameplate facts (what the motor and the screw are sold as), not identified ones:
//! the mechanism's dynamics (inertia, friction, efficiency) are identified on the machine
//! ([`crate::tension`]), but a wrong lead or gear ratio would scale every travel and is
//! configuration, checked by the commissioning pull (the string's stiffness would read off
//! by the same factor).

/// Pole pairs of the motor (the paper's 24 V, 3 700 rpm BLDC motor: 4).
pub const POLE_PAIRS: i64 = 4;

/// Motor turns per lead-screw turn: the 1:20 gearbox.
pub const GEAR_RATIO: i64 = 20;

/// Carriage travel per lead-screw turn, nanometres: 25.4 mm.
pub const LEAD_NM: i64 = 25_400_000;

/// The motor's no-load speed on the nameplate, rpm.
pub const NO_LOAD_RPM: i64 = 3_700;

const _: () = assert!(
    POLE_PAIRS > 0 && GEAR_RATIO > 0 && LEAD_NM >= 1_000,
    "a drive train needs poles, a gearbox and a lead of at least 1 µm"
);

/// Hall steps (sector changes) per motor turn: six per electrical turn.
pub const STEPS_PER_MOTOR_TURN: i64 = 6 * POLE_PAIRS;

/// Hall steps per lead-screw turn: 24 × 20 = 480.
pub const STEPS_PER_SCREW_TURN: i64 = STEPS_PER_MOTOR_TURN * GEAR_RATIO;

/// Carriage travel per Hall step, nm, rounded: 25.4 mm / 480 = 52 916.7 → 52 917 nm.
pub const NM_PER_STEP: i64 = (LEAD_NM + STEPS_PER_SCREW_TURN / 2) / STEPS_PER_SCREW_TURN;

/// Carriage travel per Hall step in Q15.16 millimetres, rounded: 52.917 µm × 65 536 = 3 468
/// bits (computed from the exact lead, not from the rounded [`NM_PER_STEP`]).
pub const STEP_MM_BITS: i32 = step_mm_bits();

/// [`STEP_MM_BITS`], checked to fit an `i32`.
const fn step_mm_bits() -> i32 {
    const DENOMINATOR: i64 = STEPS_PER_SCREW_TURN * 1_000_000;
    const BITS: i64 = (LEAD_NM * 65_536 + DENOMINATOR / 2) / DENOMINATOR;
    let bits = BITS;
    assert!(bits > 0 && bits <= i32::MAX as i64, "a Hall step must be a representable travel");
    #[allow(clippy::cast_possible_truncation, reason = "checked against i32::MAX just above")]
    let bits = bits as i32;
    bits
}

/// Hall steps in `mm` whole millimetres of carriage travel, rounded: `mm × 480 / 25.4`
/// (saturating at `i32::MAX`, 4.4 × 10⁹ mm away).
#[must_use]
pub const fn steps_in_mm(mm: u32) -> i32 {
    // mm < 2³² and 480 × 10⁶ < 2²⁹ keep the product below 2⁶¹; the divisor is a positive
    // constant.
    let scaled = (mm as i64).saturating_mul(1_000_000 * STEPS_PER_SCREW_TURN);
    let steps = scaled.saturating_add(LEAD_NM / 2).saturating_div(LEAD_NM);
    if steps > i32::MAX as i64 {
        return i32::MAX;
    }
    #[allow(clippy::cast_possible_truncation, reason = "checked against i32::MAX just above")]
    let steps = steps as i32;
    steps
}

/// Hall steps per second at the nameplate's no-load speed: 3 700 rpm × 24 / 60 = 1 480.
pub const NO_LOAD_STEPS_PER_SECOND: i64 = NO_LOAD_RPM * STEPS_PER_MOTOR_TURN / 60;

/// The largest step count one 1 ms tick may contribute to the controller's speed and travel
/// (a larger difference is a counter glitch, clamped): 16 steps = 0.85 mm, ten times the
/// no-load speed's 1.5 steps per tick.
pub const MAX_STEPS_PER_TICK: i32 = 16;

const _: () = assert!(
    MAX_STEPS_PER_TICK as i64 * 1_000 >= 10 * NO_LOAD_STEPS_PER_SECOND,
    "the per-tick clamp must leave a tenfold margin over the fastest the carriage moves"
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_s_drive_train() {
        assert_eq!(STEPS_PER_SCREW_TURN, 480);
        assert_eq!(NM_PER_STEP, 52_917);
        assert_eq!(STEP_MM_BITS, 3_468);
        assert_eq!(steps_in_mm(150), 2_835);
        assert_eq!(NO_LOAD_STEPS_PER_SECOND, 1_480);
    }
}

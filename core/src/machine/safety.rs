//! The safety rules: thresholds and the pure checks the machine's superstates apply every
//! tick.
//!
//! # Theory of operation
//!
//! The rules are split by where they hold, matching the machine's superstates:
//!
//! - **Everywhere** ([`global_fault`]): both limit switches active, a latched drive fault.
//!   Checked in every state but the fault state, with no persistence: one sample is enough
//!   to stop. Overcurrent and bus overvoltage are the drive's: it compares every PWM period's
//!   sample (not the tick's mean) against the board's thresholds from the tared zero, switches
//!   the bridge off in that same period and reports the latched fault here.
//! - **While moving** ([`limit_guard`], [`stall`], [`load_cell_rail`]): the drive command
//!   never points toward an active limit switch (it is replaced by coast); where the
//!   carriage should be moving, duty with no Hall step for [`STALL_QUIET`] is a stall; a load-cell reading at a converter rail for
//!   [`RAIL_PERSIST`] ticks is a broken sensor.
//! - **While the string is under tension** ([`TensionWatch`]): the end-of-travel limit
//!   (tension never reached), overload, string break, no string and reversed load-cell
//!   wiring. These compare noisy tension samples, so each must persist for a few ticks
//!   before it latches — long enough to ignore a switching spike (paper fig. 22), short
//!   enough that the carriage moves well under a millimetre meanwhile.
//!
//! Every function here is pure: the same rule is called by the machine, by the Kani
//! harnesses and by the model checker.

use crate::drive::{DriveCommand, Duty, PwmTicks};
use crate::io::{Inputs, LimitSwitches};
use crate::machine::fault::FaultCode;
use crate::units::{AdcCode, Kgf, Q16};

/// Load-cell codes at or below this read as the bottom rail (≤ 9.8 mV): the amplifier output
/// is pulled to ground — open bridge, no amplifier supply.
pub const LOAD_CELL_BOTTOM_RAIL: AdcCode = AdcCode::new(8);

/// Load-cell codes at or above this read as the top rail (≥ 4.99 V): shorted bridge arm or
/// far beyond the sensor's range (≈ 53.7 kgf with the nominal chain).
pub const LOAD_CELL_TOP_RAIL: AdcCode = AdcCode::new(4_087);

/// Duty at or above which a motor that should be moving but does not turn is stalled: 10 %
/// (the slowest take-up and release duties are above it; holding at tension needs up to
/// ≈ 28 % with the motor at rest, which is why the rule only applies where motion is
/// expected).
pub const STALL_DUTY: Duty = Duty::from_raw_clamped(6_554);

/// How long a driven motor may go without a Hall step before it counts as stalled, ms.
pub const STALL_QUIET_MS: u32 = 500;

/// [`STALL_QUIET_MS`] in PWM-timer ticks, as the drive reports its quiet time.
pub const STALL_QUIET: PwmTicks = PwmTicks::from_micros(STALL_QUIET_MS * 1_000);

/// The tension above the pull's peak target that counts as overload.
pub const OVERLOAD_MARGIN: Kgf = Kgf::from_int(5);

/// The tension that is always overload, whatever the target: 53 kgf (the sensor's range
/// ends at ≈ 53.7 kgf; the machine is rated to 50).
pub const OVERLOAD_ABSOLUTE: Kgf = Kgf::from_int(53);

/// A string-break needs the tension to have reached at least this first.
pub const BREAK_MIN_PEAK: Kgf = Kgf::from_int(5);

/// Carriage travel without tension that means no string is clamped: 150 mm, in Hall steps
/// (1 step = 25.4 mm / 480): 150 × 480 / 25.4 = 2 835.
pub const NO_STRING_TRAVEL_STEPS: i32 = 2_835;

/// "Without tension": below 1 kgf.
pub const NO_STRING_TENSION: Kgf = Kgf::from_int(1);

/// A tension reading below this while pulling means the bridge is wired backwards: −0.3 kgf
/// (27 mV, 22 codes below the tare), well outside the unloaded noise. A reversed bridge's
/// output can only fall as far as the bottom rail (with the nominal 50 mV tare, −0.54 kgf),
/// so with a tare below ≈ 37 mV it reaches the rail first and reads as `E-03`.
pub const REVERSED_TENSION: Kgf = Kgf(Q16::lit("-0.3"));

/// Consecutive ticks a load-cell rail reading must persist while moving before it latches:
/// 20. Switching spikes (paper fig. 22) can throw single samples to a rail while the bridge
/// commutates; twenty in a row of one sign do not happen.
pub const RAIL_PERSIST: u8 = 20;

/// Ticks an overload must persist before it latches.
pub const OVERLOAD_PERSIST: u8 = 3;
/// Ticks a string break must persist before it latches.
pub const BREAK_PERSIST: u8 = 10;
/// Ticks a reversed reading must persist before it latches.
pub const REVERSED_PERSIST: u8 = 20;

/// The fault every state but the fault state raises at once, if any: both limits, then a
/// latched drive fault (overcurrent, bus overvoltage, current-sense zero, Hall).
#[must_use]
pub fn global_fault(inputs: &Inputs) -> Option<FaultCode> {
    if inputs.limits.both() {
        Some(FaultCode::LimitsBoth)
    } else {
        inputs.drive.fault.map(FaultCode::from_drive)
    }
}

/// `command`, or coast if it would drive toward an active limit switch.
#[must_use]
pub fn limit_guard(command: DriveCommand, limits: LimitSwitches) -> DriveCommand {
    match command.direction() {
        Some(direction) if direction.blocked_by(limits) => DriveCommand::Coast,
        _ => command,
    }
}

/// Whether the motor is stalled: it has been commanded at [`STALL_DUTY`] or more for the
/// last `driven_ms` ticks, and no Hall step came for [`STALL_QUIET`] — both at least 500 ms,
/// so a motor that was resting before the command is given its time to start. Only
/// meaningful where the carriage is expected to move (taking up slack, releasing): at
/// tension the motor legitimately stands still under load.
#[must_use]
pub fn stall(command: DriveCommand, inputs: &Inputs, driven_ms: u32) -> bool {
    command.duty() >= STALL_DUTY
        && driven_ms >= STALL_QUIET_MS
        && inputs.drive.quiet_for >= STALL_QUIET
}

/// The load-cell fault of a reading at a converter rail, if any.
#[must_use]
pub fn load_cell_rail(code: AdcCode) -> Option<FaultCode> {
    if code <= LOAD_CELL_BOTTOM_RAIL {
        Some(FaultCode::LoadCellOpen)
    } else if code >= LOAD_CELL_TOP_RAIL {
        Some(FaultCode::LoadCellShort)
    } else {
        None
    }
}

/// The overload threshold for a pull whose highest target is `peak_target`.
#[must_use]
pub fn overload_limit(peak_target: Kgf) -> Kgf {
    let relative = peak_target.saturating_add(OVERLOAD_MARGIN);
    if relative < OVERLOAD_ABSOLUTE { relative } else { OVERLOAD_ABSOLUTE }
}

/// The rules that hold while the string is under tension, with the persistence counters
/// they need. Reset when a pull (or calibration point) starts.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct TensionWatch {
    /// Hall step count when the pull started.
    pub start_steps: i32,
    /// Highest tension seen since the pull started.
    pub peak: Kgf,
    overload: u8,
    broken: u8,
    reversed: u8,
}

/// What [`TensionWatch::check`] needs to know about this tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct TensionSample {
    /// The corrected tension.
    pub tension: Kgf,
    /// The uncorrected (tared) tension, for the sign check.
    pub raw: Kgf,
    /// The drive's Hall step count.
    pub steps: i32,
    /// The limit switches.
    pub limits: LimitSwitches,
    /// The pull's highest target (pre-stretch peak).
    pub peak_target: Kgf,
}

impl TensionWatch {
    /// A watch for a pull starting at Hall count `steps`.
    #[must_use]
    pub const fn new(steps: i32) -> Self {
        Self { start_steps: steps, peak: Kgf::ZERO, overload: 0, broken: 0, reversed: 0 }
    }

    /// A watch with arbitrary counters (proofs, fuzzing); every value is a reachable one.
    #[must_use]
    pub const fn from_parts(
        start_steps: i32,
        peak: Kgf,
        overload: u8,
        broken: u8,
        reversed: u8,
    ) -> Self {
        Self { start_steps, peak, overload, broken, reversed }
    }

    /// Whether the watch is one a run can reach: a non-negative peak within the sensor's
    /// range (≤ 60 kgf), persistence counters at most their limits.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.peak >= Kgf::ZERO
            && self.peak <= Kgf::from_int(60)
            && self.overload <= OVERLOAD_PERSIST
            && self.broken <= BREAK_PERSIST
            && self.reversed <= REVERSED_PERSIST
    }

    /// Carriage travel since the pull started, in Hall steps (positive = pulling).
    #[must_use]
    pub const fn travel(&self, steps: i32) -> i32 {
        steps.wrapping_sub(self.start_steps)
    }

    /// One tick: the fault to latch, if any, in order of precedence — end of travel,
    /// overload, string break, reversed load cell, no string.
    pub fn check(&mut self, sample: &TensionSample) -> Option<FaultCode> {
        if sample.tension > self.peak {
            self.peak = sample.tension;
        }
        let persist = |counter: &mut u8, condition: bool, limit: u8| {
            *counter = if condition { counter.saturating_add(1) } else { 0 };
            *counter >= limit
        };
        let overloaded = persist(
            &mut self.overload,
            sample.tension > overload_limit(sample.peak_target),
            OVERLOAD_PERSIST,
        );
        let half_peak = Kgf::from_bits(self.peak.to_bits().checked_div(2).unwrap_or(0));
        let broken = persist(
            &mut self.broken,
            self.peak >= BREAK_MIN_PEAK && sample.tension < half_peak,
            BREAK_PERSIST,
        );
        let reversed = persist(&mut self.reversed, sample.raw < REVERSED_TENSION, REVERSED_PERSIST);
        // Both switches at once is a wiring fault, reported by the rule that holds
        // everywhere (`LimitsBoth`), not as an end of travel.
        if sample.limits.end && !sample.limits.home {
            Some(FaultCode::EndOfTravel)
        } else if overloaded {
            Some(FaultCode::Overload)
        } else if broken {
            Some(FaultCode::StringBreak)
        } else if reversed {
            Some(FaultCode::LoadCellReversed)
        } else if self.travel(sample.steps) > NO_STRING_TRAVEL_STEPS
            && self.peak < NO_STRING_TENSION
        {
            Some(FaultCode::NoString)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::{Direction, DriveFault};

    #[test]
    fn global_rules_in_order() {
        let mut inputs = Inputs::default();
        assert_eq!(global_fault(&inputs), None);
        // The tick's mean current is the drive's business (it sees every period).
        inputs.motor_current = AdcCode::MAX;
        assert_eq!(global_fault(&inputs), None);
        inputs.drive.fault = Some(DriveFault::Overcurrent);
        assert_eq!(global_fault(&inputs), Some(FaultCode::Overcurrent));
        inputs.drive.fault = Some(DriveFault::BusOvervoltage);
        assert_eq!(global_fault(&inputs), Some(FaultCode::BusOvervoltage));
        inputs.drive.fault = Some(DriveFault::HallInvalid);
        assert_eq!(global_fault(&inputs), Some(FaultCode::HallInvalid));
        inputs.limits = LimitSwitches { home: true, end: true };
        assert_eq!(global_fault(&inputs), Some(FaultCode::LimitsBoth));
    }

    #[test]
    fn limit_guard_blocks_only_toward_the_active_switch() {
        let pull = DriveCommand::Drive { direction: Direction::Pull, duty: STALL_DUTY };
        let release = DriveCommand::Drive { direction: Direction::Release, duty: STALL_DUTY };
        let end = LimitSwitches { home: false, end: true };
        let home = LimitSwitches { home: true, end: false };
        assert_eq!(limit_guard(pull, end), DriveCommand::Coast);
        assert_eq!(limit_guard(release, end), release);
        assert_eq!(limit_guard(release, home), DriveCommand::Coast);
        assert_eq!(limit_guard(pull, home), pull);
    }

    fn sample(tension: i16, steps: i32) -> TensionSample {
        TensionSample {
            tension: Kgf::from_int(tension),
            raw: Kgf::from_int(tension),
            steps,
            limits: LimitSwitches::default(),
            peak_target: Kgf::from_int(25),
        }
    }

    #[test]
    fn a_single_spike_is_not_an_overload() {
        let mut watch = TensionWatch::new(0);
        assert_eq!(watch.check(&sample(40, 10)), None);
        assert_eq!(watch.check(&sample(25, 10)), None);
        for _ in 0..OVERLOAD_PERSIST - 1 {
            assert_eq!(watch.check(&sample(31, 10)), None);
        }
        assert_eq!(watch.check(&sample(31, 10)), Some(FaultCode::Overload));
    }

    #[test]
    fn string_break_after_the_tension_collapses() {
        let mut watch = TensionWatch::new(0);
        assert_eq!(watch.check(&sample(25, 100)), None);
        for _ in 0..BREAK_PERSIST - 1 {
            assert_eq!(watch.check(&sample(2, 100)), None);
        }
        assert_eq!(watch.check(&sample(2, 100)), Some(FaultCode::StringBreak));
    }

    #[test]
    fn no_string_after_the_travel_limit() {
        let mut watch = TensionWatch::new(1_000);
        assert_eq!(watch.check(&sample(0, 1_000 + NO_STRING_TRAVEL_STEPS)), None);
        assert_eq!(
            watch.check(&sample(0, 1_001 + NO_STRING_TRAVEL_STEPS)),
            Some(FaultCode::NoString)
        );
        // With tension seen, long travel is fine (a long, stretchy string).
        let mut watch = TensionWatch::new(0);
        assert_eq!(watch.check(&sample(3, 5)), None);
        assert_eq!(watch.check(&sample(3, 5_000)), None);
    }

    #[test]
    fn reversed_reading_latches_after_persisting() {
        let mut watch = TensionWatch::new(0);
        let negative = TensionSample { raw: Kgf::from_int(-1), ..sample(0, 10) };
        for _ in 0..REVERSED_PERSIST - 1 {
            assert_eq!(watch.check(&negative), None);
        }
        assert_eq!(watch.check(&negative), Some(FaultCode::LoadCellReversed));
    }

    #[test]
    fn end_limit_while_tensioning_is_end_of_travel() {
        let mut watch = TensionWatch::new(0);
        let at_end =
            TensionSample { limits: LimitSwitches { home: false, end: true }, ..sample(3, 10) };
        assert_eq!(watch.check(&at_end), Some(FaultCode::EndOfTravel));
    }

    #[test]
    fn overload_limit_is_capped() {
        assert_eq!(overload_limit(Kgf::from_int(20)), Kgf::from_int(25));
        assert_eq!(overload_limit(Kgf::from_int(50)), OVERLOAD_ABSOLUTE);
    }
}

//! Fault and notice codes: what the display shows as `E-nn` or `n-nn` when something is wrong.
//!
//! # Theory of operation
//!
//! A [`FaultCode`] names one detected failure and shows as `E-nn`. A fault **latches**: the
//! machine enters its fault state, the bridge coasts in the same tick, the display shows the
//! code, the fault lamp lights and the beeper sounds three times; it is cleared only by the
//! operator pressing Start while the drive command is zero and the condition is gone.
//!
//! A [`Notice`] is not a failure of the machine but something the operator should know — the
//! stored record was unusable, a calibration was refused — and shows as `n-nn` until the next
//! key press while the machine goes on working (on defaults, or on the previous calibration).
//!
//! The two are different types with their own numbers, so whether a code latches is a
//! matter of its type, not of a numbering rule, and each list grows at its end: a new fault
//! takes the next `E-` number and a new notice the next `n-` number, and no code an operator
//! has learned is ever renumbered. (`E-20`…`E-22` were the notices before they had their
//! own type; those fault numbers stay unused so that an old manual is never wrong.)
//!
//! The table with causes and how to clear each code is in `docs/SPEC.md` ("Fault codes");
//! the doc line of each variant is its one-line meaning.

use crate::drive::DriveFault;
use crate::store::StoreError;

/// A latched fault, shown as `E-nn`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum FaultCode {
    /// E-01: both limit switches active at once (mechanically impossible: wiring fault).
    LimitsBoth,
    /// E-02: a limit switch stays active after the carriage moved away from it (stuck switch).
    LimitStuck,
    /// E-03: the load cell reads at the bottom rail (open circuit, amplifier unpowered).
    LoadCellOpen,
    /// E-04: the load cell reads at the top rail (short circuit or far over range).
    LoadCellShort,
    /// E-05: the unloaded load-cell reading at power-up is outside the plausible zero band.
    LoadCellZero,
    /// E-06: the tension reads below zero while pulling (reversed bridge wiring).
    LoadCellReversed,
    /// E-07: the motor test saw no Hall transitions (motor, bridge or Hall wiring).
    MotorNoRotation,
    /// E-08: the motor turned the opposite way to the command (phase or Hall order swapped).
    MotorWrongDirection,
    /// E-09: high duty with no Hall transitions while moving (stall, jam).
    Stall,
    /// E-10: motor current at or above the overcurrent limit.
    Overcurrent,
    /// E-11: the hardware overcurrent comparator tripped.
    OvercurrentTrip,
    /// E-12: the Hall sensors read `000` or `111` (sensor supply or line lost).
    HallInvalid,
    /// E-13: the rotor position skipped a sector (lost Hall edges).
    HallSequence,
    /// E-14: the end-of-travel limit was reached while pulling (tension not reached).
    EndOfTravel,
    /// E-15: the tension collapsed while pulling or holding (string broke or slipped).
    StringBreak,
    /// E-16: the carriage travelled its no-string distance without any tension.
    NoString,
    /// E-17: the tension exceeded the allowed maximum (overload).
    Overload,
    /// E-18: the set tension was not reached within the pull timeout.
    PullTimeout,
    /// E-19: the home limit was not reached within the release timeout.
    ReleaseTimeout,
    /// E-23: the DC bus reached its configured maximum (regeneration or supply overvoltage).
    BusOvervoltage,
    /// E-24: the motor-current sense's zero, tared with the bridge off, is out of tolerance.
    CurrentSenseZero,
}

impl FaultCode {
    /// Every code, in number order.
    pub const ALL: [Self; 21] = [
        Self::LimitsBoth,
        Self::LimitStuck,
        Self::LoadCellOpen,
        Self::LoadCellShort,
        Self::LoadCellZero,
        Self::LoadCellReversed,
        Self::MotorNoRotation,
        Self::MotorWrongDirection,
        Self::Stall,
        Self::Overcurrent,
        Self::OvercurrentTrip,
        Self::HallInvalid,
        Self::HallSequence,
        Self::EndOfTravel,
        Self::StringBreak,
        Self::NoString,
        Self::Overload,
        Self::PullTimeout,
        Self::ReleaseTimeout,
        Self::BusOvervoltage,
        Self::CurrentSenseZero,
    ];

    /// The number shown after `E-`.
    #[must_use]
    pub const fn number(self) -> u8 {
        match self {
            Self::LimitsBoth => 1,
            Self::LimitStuck => 2,
            Self::LoadCellOpen => 3,
            Self::LoadCellShort => 4,
            Self::LoadCellZero => 5,
            Self::LoadCellReversed => 6,
            Self::MotorNoRotation => 7,
            Self::MotorWrongDirection => 8,
            Self::Stall => 9,
            Self::Overcurrent => 10,
            Self::OvercurrentTrip => 11,
            Self::HallInvalid => 12,
            Self::HallSequence => 13,
            Self::EndOfTravel => 14,
            Self::StringBreak => 15,
            Self::NoString => 16,
            Self::Overload => 17,
            Self::PullTimeout => 18,
            Self::ReleaseTimeout => 19,
            Self::BusOvervoltage => 23,
            Self::CurrentSenseZero => 24,
        }
    }

    /// The code for a fault the drive latched.
    #[must_use]
    pub const fn from_drive(fault: DriveFault) -> Self {
        match fault {
            DriveFault::Overcurrent => Self::Overcurrent,
            DriveFault::OvercurrentTrip => Self::OvercurrentTrip,
            DriveFault::BusOvervoltage => Self::BusOvervoltage,
            DriveFault::CurrentSenseZero => Self::CurrentSenseZero,
            DriveFault::HallInvalid => Self::HallInvalid,
            DriveFault::SectorSkipped => Self::HallSequence,
        }
    }
}

/// A notice, shown as `n-nn` until the next key press; the machine keeps working.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Notice {
    /// n-01: the stored record was missing or corrupt; defaults are in use.
    StoreInvalid,
    /// n-02: a new calibration was rejected; the previous one is kept.
    CalibrationRejected,
    /// n-03: the stored calibration failed validation; the sensor runs uncorrected.
    StoredCalibrationInvalid,
    /// n-04: the load cell's zero has drifted past the drift watch since the self-test
    /// (REQ-UI-12): recalibrate.
    ZeroDrift,
}

impl Notice {
    /// Every notice, in number order.
    pub const ALL: [Self; 4] = [
        Self::StoreInvalid,
        Self::CalibrationRejected,
        Self::StoredCalibrationInvalid,
        Self::ZeroDrift,
    ];

    /// The number shown after `n-`.
    #[must_use]
    pub const fn number(self) -> u8 {
        match self {
            Self::StoreInvalid => 1,
            Self::CalibrationRejected => 2,
            Self::StoredCalibrationInvalid => 3,
            Self::ZeroDrift => 4,
        }
    }

    /// The notice for a record that could not be loaded. Every store error maps to
    /// [`Notice::StoreInvalid`]; the precise cause is in the error itself for the log.
    #[must_use]
    pub const fn from_store(_error: StoreError) -> Self {
        Self::StoreInvalid
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each list is numbered on its own, without duplicates, in order; the retired notice
    /// numbers 20–22 are never a fault's.
    #[test]
    fn faults_and_notices_are_numbered_on_their_own() {
        let mut previous = 0;
        for code in FaultCode::ALL {
            assert!(code.number() > previous, "{code:?}");
            assert!(!(20..=22).contains(&code.number()), "{code:?} took a retired number");
            previous = code.number();
        }
        assert_eq!(FaultCode::ALL.last().map(|code| code.number()), Some(24));
        for (index, notice) in Notice::ALL.iter().enumerate() {
            assert_eq!(usize::from(notice.number()), index + 1, "{notice:?}");
        }
    }
}

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
//! Each list is one table ([`crate::codes::numbered!`]): a row gives a code its number, its
//! short name, its one-line meaning (also the variant's doc) and its recovery, and the
//! enum, its list, its numbers and its decoder are generated from the rows. Adding a code is
//! one row here plus the rule that raises it. `docs/SPEC.md` ("Fault codes") adds each
//! code's causes; a test holds its numbers and names to these tables.

use crate::drive::DriveFault;
use crate::store::StoreError;

crate::codes::numbered! {
    /// A latched fault, shown as `E-nn` (its number). The table is the one place a fault is
    /// defined: its number, short name, meaning and recovery (`docs/SPEC.md`'s fault table is
    /// checked against it).
    #[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
    pub enum FaultCode {
        LimitsBoth = 1 {
            "both limit switches active",
            "both limit switches active (a wiring fault)",
            "fix the wiring, then Start"
        },
        LimitStuck = 2 {
            "limit switch stuck",
            "a limit switch is stuck closed",
            "free or replace the switch; Start runs the self-test again"
        },
        LoadCellOpen = 3 {
            "load cell at the bottom rail",
            "load cell at the bottom rail (open circuit, amplifier unpowered)",
            "reconnect the load cell, then Start"
        },
        LoadCellShort = 4 {
            "load cell at the top rail",
            "load cell at the top rail (short circuit, far over range)",
            "fix the short, then Start"
        },
        LoadCellZero = 5 {
            "load-cell zero out of band",
            "load-cell zero out of band (string loaded at power-up, drift)",
            "unload the gripper; Start runs the self-test again"
        },
        LoadCellReversed = 6 {
            "tension reads negative while pulling",
            "tension reads negative while pulling (bridge wires swapped)",
            "swap the load cell's signal wires, then Start"
        },
        MotorNoRotation = 7 {
            "motor does not turn",
            "the motor does not turn (motor, bridge or Hall wiring; seized)",
            "fix it; Start runs the self-test again"
        },
        MotorWrongDirection = 8 {
            "motor turns the wrong way",
            "the motor turns the wrong way (phases or Hall lines swapped)",
            "fix the order; Start runs the self-test again"
        },
        Stall = 9 {
            "stall",
            "stall: the carriage is jammed",
            "clear the jam, then Start"
        },
        Overcurrent = 10 {
            "overcurrent",
            "overcurrent in the motor",
            "find the cause (measure the phase resistances), then Start"
        },
        OvercurrentTrip = 11 {
            "overcurrent comparator",
            "the overcurrent comparator tripped",
            "Start (refused while the comparator is tripped)"
        },
        HallInvalid = 12 {
            "Hall invalid",
            "Hall sensors read 000 or 111 (sensor supply or a line lost)",
            "fix the Hall wiring, then Start"
        },
        HallSequence = 13 {
            "Hall sequence",
            "the rotor skipped a sector (lost Hall edges, noise)",
            "fix the Hall wiring, then Start"
        },
        EndOfTravel = 14 {
            "end of travel",
            "end of travel while pulling (string too long or slipping)",
            "Start releases the carriage home"
        },
        StringBreak = 15 {
            "string break",
            "string break: the tension collapsed (broke or slipped)",
            "Start clears the fault and the carriage returns home; then re-string"
        },
        NoString = 16 {
            "no string",
            "no string: 150 mm of travel without tension",
            "clamp the string, then Start"
        },
        Overload = 17 {
            "overload",
            "overload: the tension passed the pull's peak target + 5 kgf",
            "Start releases the carriage home"
        },
        PullTimeout = 18 {
            "pull timeout",
            "pull timeout: the tension was not reached in time",
            "Start releases the carriage home"
        },
        ReleaseTimeout = 19 {
            "release timeout",
            "release timeout: home not reached (home switch, jammed carriage)",
            "fix it, then Start"
        },
        BusOvervoltage = 23 {
            "bus overvoltage",
            "bus overvoltage (regeneration, or a supply above the rating)",
            "Start once the bus voltage is below the maximum"
        },
        CurrentSenseZero = 24 {
            "current-sense zero",
            "the motor-current sense's zero is out of tolerance",
            "Start (re-tared when the bridge is next off); check the amplifier"
        },
    }
}

impl FaultCode {
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

crate::codes::numbered! {
    /// A notice, shown as `n-nn` (its number) until the next key press; the machine keeps
    /// working. One table, as for [`FaultCode`].
    #[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
    pub enum Notice {
        StoreInvalid = 1 {
            "record invalid",
            "the stored record was missing or corrupt: defaults in use",
            "any key; the settings are stored again on the next change"
        },
        CalibrationRejected = 2 {
            "calibration rejected",
            "the new calibration was rejected: the previous one is kept",
            "any key; calibrate again"
        },
        StoredCalibrationInvalid = 3 {
            "stored calibration invalid",
            "the stored calibration is invalid: the sensor runs uncorrected",
            "any key; calibrate"
        },
        ZeroDrift = 4 {
            "recalibrate: zero drifted",
            "the load cell's zero has drifted since power-up",
            "any key; calibrate again soon"
        },
        DrivetrainWear = 5 {
            "service: drivetrain drag",
            "the motor test has become slower than at commissioning: the drivetrain drags",
            "any key; clean and lubricate the screw and the slide, then calibrate"
        },
    }
}

impl Notice {
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

    /// Every number decodes to the variant that has it and to no other; every variant's
    /// number decodes back to it.
    #[test]
    fn every_number_decodes_to_its_own_code() {
        for number in 0..=u8::MAX {
            let fault = FaultCode::ALL.iter().find(|code| code.number() == number).copied();
            assert_eq!(FaultCode::from_number(number), fault, "E-{number}");
            let notice = Notice::ALL.iter().find(|notice| notice.number() == number).copied();
            assert_eq!(Notice::from_number(number), notice, "n-{number}");
            let drive = DriveFault::ALL.iter().find(|fault| fault.number() == number).copied();
            assert_eq!(DriveFault::from_number(number), drive, "drive fault {number}");
        }
        // Every drive fault has a machine code of its own.
        for (index, fault) in DriveFault::ALL.iter().enumerate() {
            let code = FaultCode::from_drive(*fault);
            assert!(
                DriveFault::ALL[..index].iter().all(|other| FaultCode::from_drive(*other) != code),
                "{fault:?}"
            );
        }
    }

    /// `docs/SPEC.md`'s fault and notice tables list exactly these codes, each with the
    /// table's number and short name.
    #[test]
    fn the_spec_lists_every_code_with_its_name() {
        let spec = include_str!("../../../docs/SPEC.md");
        let rows = |prefix: &'static str| {
            spec.lines().filter_map(move |line| {
                let mut cells = line.split('|').map(str::trim);
                cells.next()?;
                let number: u8 = cells.next()?.strip_prefix(prefix)?.parse().ok()?;
                Some((number, cells.next()?))
            })
        };
        let faults = FaultCode::ALL.iter().map(|code| (code.number(), code.name()));
        assert_eq!(rows("E-").count(), FaultCode::ALL.len());
        for (row, code) in rows("E-").zip(faults) {
            assert_eq!(row, code);
        }
        let notices = Notice::ALL.iter().map(|notice| (notice.number(), notice.name()));
        assert_eq!(rows("n-").count(), Notice::ALL.len());
        for (row, notice) in rows("n-").zip(notices) {
            assert_eq!(row, notice);
        }
    }

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
        for (index, notice) in Notice::ALL.iter().enumerate() {
            assert_eq!(usize::from(notice.number()), index + 1, "{notice:?}");
        }
    }
}

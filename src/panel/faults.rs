//! What each fault code and notice means and how the operator clears it, in words for the
//! terminal panel: the seven-segment display has room for `E-15` only, the terminal for a
//! sentence. The wording follows `docs/SPEC.md` ("Fault codes"); core names the codes by
//! number only, so the words live here, in matches over core's enums that stop building when
//! core adds a code.

use taut_core::machine::{FaultCode, Notice};

/// A fault's meaning and how to clear it: `(meaning, recovery)`, each short enough for the
/// panel's lines.
#[must_use]
pub const fn fault_text(code: FaultCode) -> (&'static str, &'static str) {
    match code {
        FaultCode::LimitsBoth => {
            ("both limit switches active (a wiring fault)", "fix the wiring, then Start")
        }
        FaultCode::LimitStuck => (
            "a limit switch is stuck closed",
            "free or replace the switch; Start runs the self-test again",
        ),
        FaultCode::LoadCellOpen => (
            "load cell at the bottom rail (open circuit, amplifier unpowered)",
            "reconnect the load cell, then Start",
        ),
        FaultCode::LoadCellShort => (
            "load cell at the top rail (short circuit, far over range)",
            "fix the short, then Start",
        ),
        FaultCode::LoadCellZero => (
            "load-cell zero out of band (string loaded at power-up, drift)",
            "unload the gripper; Start runs the self-test again",
        ),
        FaultCode::LoadCellReversed => (
            "tension reads negative while pulling (bridge wires swapped)",
            "swap the load cell's signal wires, then Start",
        ),
        FaultCode::MotorNoRotation => (
            "the motor does not turn (motor, bridge or Hall wiring; seized)",
            "fix it; Start runs the self-test again",
        ),
        FaultCode::MotorWrongDirection => (
            "the motor turns the wrong way (phases or Hall lines swapped)",
            "fix the order; Start runs the self-test again",
        ),
        FaultCode::Stall => ("stall: the carriage is jammed", "clear the jam, then Start"),
        FaultCode::Overcurrent => (
            "overcurrent in the motor",
            "find the cause (measure the phase resistances), then Start",
        ),
        FaultCode::OvercurrentTrip => (
            "the overcurrent comparator tripped",
            "Start (refused while the comparator is tripped)",
        ),
        FaultCode::HallInvalid => (
            "Hall sensors read 000 or 111 (sensor supply or a line lost)",
            "fix the Hall wiring, then Start",
        ),
        FaultCode::HallSequence => (
            "the rotor skipped a sector (lost Hall edges, noise)",
            "fix the Hall wiring, then Start",
        ),
        FaultCode::EndOfTravel => (
            "end of travel while pulling (string too long or slipping)",
            "Start releases the carriage home",
        ),
        FaultCode::StringBreak => (
            "string break: the tension collapsed (broke or slipped)",
            "Start clears the fault and the carriage returns home; then re-string",
        ),
        FaultCode::NoString => {
            ("no string: 150 mm of travel without tension", "clamp the string, then Start")
        }
        FaultCode::Overload => (
            "overload: the tension passed the pull's peak target + 5 kgf",
            "Start releases the carriage home",
        ),
        FaultCode::PullTimeout => (
            "pull timeout: the tension was not reached in time",
            "Start releases the carriage home",
        ),
        FaultCode::ReleaseTimeout => (
            "release timeout: home not reached (home switch, jammed carriage)",
            "fix it, then Start",
        ),
        FaultCode::BusOvervoltage => (
            "bus overvoltage (regeneration, or a supply above the rating)",
            "Start once the bus voltage is below the maximum",
        ),
        FaultCode::CurrentSenseZero => (
            "the motor-current sense's zero is out of tolerance",
            "Start (re-tared when the bridge is next off); check the amplifier",
        ),
    }
}

/// A notice's meaning and how it clears: `(meaning, recovery)`.
#[must_use]
pub const fn notice_text(notice: Notice) -> (&'static str, &'static str) {
    match notice {
        Notice::StoreInvalid => (
            "the stored record was missing or corrupt: defaults in use",
            "any key; the settings are stored again on the next change",
        ),
        Notice::CalibrationRejected => (
            "the new calibration was rejected: the previous one is kept",
            "any key; calibrate again",
        ),
        Notice::StoredCalibrationInvalid => {
            ("the stored calibration is invalid: the sensor runs uncorrected", "any key; calibrate")
        }
        Notice::ZeroDrift => {
            ("the load cell's zero has drifted since power-up", "any key; calibrate again soon")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::panel::FRAME_COLUMNS;

    /// The longest prefix a text gets in the frame (`| shows: E-15 `, `| next:  `).
    const PREFIX: usize = "| shows: E-15 ".len();

    #[test]
    fn every_code_has_words_that_fit_the_panel() {
        let fits = |text: &str| {
            !text.is_empty() && PREFIX + text.chars().count() <= usize::from(FRAME_COLUMNS)
        };
        let mut meanings: Vec<&str> = Vec::new();
        for code in FaultCode::ALL {
            let (meaning, recovery) = fault_text(code);
            assert!(fits(meaning) && fits(recovery), "{code:?}: {meaning} / {recovery}");
            assert!(!meanings.contains(&meaning), "{code:?} shares its meaning");
            meanings.push(meaning);
        }
        for notice in Notice::ALL {
            let (meaning, recovery) = notice_text(notice);
            assert!(fits(meaning) && fits(recovery), "{notice:?}");
        }
    }
}

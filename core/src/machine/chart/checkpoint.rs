//! The statechart's states as the machine's public states and back: the one projection
//! ([`public_state`]) every display, log and test reads, and its inverse for a checkpoint
//! ([`state_at`], which the proofs and the resume after a reset start from).

use super::{AfterRelease, Hold, State};
use crate::machine::{Checkpoint, MachineState};

/// The state at power-up: the self-test, from its start.
pub(crate) fn power_up() -> State {
    State::self_test(0, 0)
}

/// The statechart state for a checkpoint.
pub(crate) fn state_at(checkpoint: &Checkpoint) -> State {
    let elapsed = checkpoint.elapsed;
    match checkpoint.state {
        MachineState::SelfTest => State::self_test(u16::try_from(elapsed).unwrap_or(u16::MAX), 0),
        MachineState::MotorTest => State::motor_test(
            elapsed,
            checkpoint.direction,
            checkpoint.start_steps,
            checkpoint.start_limits,
        ),
        MachineState::Homing => State::releasing(elapsed, AfterRelease::CalibrationWindow),
        MachineState::CalibrationWindow => State::calibration_window(elapsed),
        MachineState::CalibrationPull { point } => State::calibration_pull(point, 0, elapsed),
        MachineState::CalibrationEntry { point } => {
            State::calibration_entry(point, checkpoint.entered_hundredths, 0, 0)
        }
        MachineState::Ready => State::ready(checkpoint.view),
        MachineState::Pulling => State::pulling(elapsed),
        MachineState::Holding => State::holding(Hold {
            adjust: checkpoint.hold_adjust,
            held_ms: elapsed,
            timer: false,
            message: None,
        }),
        MachineState::Releasing => State::releasing(elapsed, checkpoint.then),
        MachineState::Fault(code) => State::fault(code, checkpoint.recovery, checkpoint.clearing),
    }
}

/// The public name of a statechart state.
pub(crate) fn public_state(state: &State) -> MachineState {
    match state {
        State::SelfTest { .. } => MachineState::SelfTest,
        State::MotorTest { .. } => MachineState::MotorTest,
        State::Releasing { then: AfterRelease::CalibrationWindow, .. } => MachineState::Homing,
        State::Releasing { then: AfterRelease::Ready | AfterRelease::NextPass, .. } => {
            MachineState::Releasing
        }
        State::CalibrationWindow { .. } => MachineState::CalibrationWindow,
        State::CalibrationPull { point, .. } => MachineState::CalibrationPull { point: *point },
        State::CalibrationEntry { point, .. } => MachineState::CalibrationEntry { point: *point },
        State::Ready { .. } => MachineState::Ready,
        State::Pulling { .. } => MachineState::Pulling,
        State::Holding { .. } => MachineState::Holding,
        State::Fault { code, .. } => MachineState::Fault(*code),
    }
}

//! The whole-machine model check (`REQ-SM-*` liveness and every `REQ-SAFE-*` property on
//! every simulated tick, the `tension_faults_stop_the_pull` property after every tension
//! change): the real machine composed with the abstract environment of
//! `taut_proofs::machine_model`, explored breadth-first from power-up. Prints the number of
//! abstract states and transitions explored and the ticks simulated.

#![allow(
    clippy::float_arithmetic,
    reason = "reports the run's duration in seconds; nothing is decided on it"
)]

use taut_core::machine::{MachineState, View};
use taut_core::sense::calibration::CALIBRATION_READINGS;
use taut_proofs::machine_model::{Env, explore};

/// Large enough that the exploration finishes on its own (the run asserts it did).
const STATE_LIMIT: usize = 200_000;

#[test]
fn machine_model_check() {
    let started = std::time::Instant::now();
    let report = explore(&[Env::HEALTHY], STATE_LIMIT);
    let seconds = started.elapsed().as_secs_f64();
    println!(
        "machine_model_check: {} abstract states, {} transitions, {} ticks checked, {} machine states, {seconds:.1} s",
        report.states,
        report.transitions,
        report.ticks,
        report.machine_states.len()
    );
    assert!(report.states < STATE_LIMIT, "exploration hit its limit");
    assert!(
        report.traps.is_empty(),
        "states that cannot reach Ready or a fault: {:?}",
        &report.traps[..report.traps.len().min(5)]
    );
    // The flow of the paper is in the explored space: every kind of state, the calibration
    // through its last point (faults are reached by their own actions, checked above).
    let last = u8::try_from(CALIBRATION_READINGS - 1).unwrap_or(u8::MAX);
    for kind in MachineState::KINDS {
        let state = match kind {
            MachineState::CalibrationPull { .. } => MachineState::CalibrationPull { point: last },
            MachineState::CalibrationEntry { .. } => MachineState::CalibrationEntry { point: last },
            MachineState::Fault(_) => continue,
            other => other,
        };
        assert!(report.machine_states.contains(&state), "{state:?} never reached");
    }
    // REQ-SM-09: every hold the keys make — tension or timer shown, constant pull on or off —
    // is explored (and, above, none of them is a trap).
    for hold in [(false, false), (true, false), (false, true), (true, true)] {
        assert!(report.holds.contains(&hold), "hold (timer, locked) = {hold:?} never reached");
    }
    // REQ-UI-10/11: every information and preference page is reached (and none is a trap).
    for view in [
        View::Beeper,
        View::ConstantPull,
        View::Timer,
        View::Log { entry: 0, field: 0 },
        View::Counters(0),
        View::String(0),
        View::Service(0),
    ] {
        assert!(report.ready_views.contains(&view), "{view:?} never reached");
    }
}

//! A working day on the twin (REQ-ID-08, REQ-SIM-01): consecutive pulls on one machine with
//! the drifts on, through the session report's own runner.
#![allow(
    clippy::float_arithmetic,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    reason = "host test: the twin's truth is f64, and a panic is how a test fails"
)]

use taut::cli::SessionArgs;
use taut::report::session::{DRIFT_BUDGET_KGF, run_machine};

/// A machine whose day moves its load cell's zero keeps its hold: the re-zero at rest
/// follows the zero (the machine's zero moves with the twin's offset), the hold's p99 stays
/// within the budget of the first pulls', and nothing faults or notices.
#[test]
fn a_drifting_machine_keeps_its_hold_over_consecutive_pulls() {
    let args = SessionArgs { machines: 1, pulls: 24, seed: 1, threads: Some(1), json: None };
    let r = run_machine(&args, 0);
    assert!(r.completed, "{r:?}");
    assert_eq!(r.fault, None);
    assert!(r.notices.is_empty(), "{r:?}");
    assert!(r.rezeros > 20, "{r:?}");
    // Half an hour of the day moved the load cell's apparent zero by ≈ 6 g (its whole share
    // of the hold's error without a re-zero); the machine's zero followed it to a few grams.
    assert!(r.offset_kgf.abs() > 0.004, "{r:?}");
    assert!((r.zero_moved_kgf - r.offset_kgf).abs() < 0.004, "{r:?}");
    assert!(r.hold_p99_kgf - r.first_p99_kgf <= DRIFT_BUDGET_KGF, "{r:?}");
    assert!(r.resistance_factor > 1.0 && r.friction_factor > 1.0, "{r:?}");
}

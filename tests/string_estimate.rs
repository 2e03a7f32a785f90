//! The string estimate (issue 15, REQ-SM-11): on every string preset, on the nominal machine
//! and on a machine of the family, the machine's stiffness is within 10 % and its creep
//! within 20 % of the twin's truth (`taut report string` prints the full table).
#![allow(
    clippy::float_arithmetic,
    clippy::print_stdout,
    reason = "host test: the twin's truth is f64"
)]

use taut::report::string::{CREEP_TOLERANCE, STIFFNESS_TOLERANCE, run, text};

#[test]
fn string_estimate_matches_the_twin_on_every_preset() {
    let hold_ms = 15_000;
    let rows = run(1, hold_ms);
    print!("{}", text(&rows, hold_ms));
    assert_eq!(rows.len(), 10, "five presets on two machines");
    for row in &rows {
        assert!(row.failure.is_none(), "{row:?}");
        assert!(row.stiffness_error().abs() <= STIFFNESS_TOLERANCE, "stiffness: {row:?}");
        assert!(row.creep_error().abs() <= CREEP_TOLERANCE, "creep: {row:?}");
    }
}

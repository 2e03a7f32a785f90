//! The string estimate (REQ-SM-11): on every string preset, on the nominal machine
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
    let report = text(&rows, hold_ms);
    print!("{report}");
    assert_eq!(rows.len(), 10, "five presets on two machines");
    // Markdown, as the other reports print: a header, its rule and a row per run, every one
    // with the header's 13 cells.
    let table: Vec<&str> = report.lines().filter(|l| l.starts_with('|')).collect();
    assert_eq!(table.len(), rows.len() + 2, "{report}");
    assert!(table[1].starts_with("|---|"), "{report}");
    assert!(table.iter().all(|l| l.matches('|').count() == 14 && l.ends_with('|')), "{report}");
    for row in &rows {
        assert!(row.failure.is_none(), "{row:?}");
        assert!(row.stiffness_error().abs() <= STIFFNESS_TOLERANCE, "stiffness: {row:?}");
        assert!(row.creep_error().abs() <= CREEP_TOLERANCE, "creep: {row:?}");
    }
}

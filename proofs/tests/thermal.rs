//! The winding's temperature estimate (REQ-DRV-13) under `cargo test`: the hot window's
//! current bound for every rise step of 1 K, every bus code and back-EMFs across the range;
//! the estimate's bounds along long random sequences of conducting and idle calls.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::cast_possible_truncation,
    reason = "test bookkeeping on small counts; a panic fails the test, as it should"
)]

use proptest::prelude::*;
use taut_core::drive::limit::RISE_MAX_UK;
use taut_core::drive::{DriveConfig, WindingHeat};
use taut_proofs::thermal::{heat_step_bounded, hot_window_bounds_current};

#[test]
fn hot_window_bounds_current_every_rise_and_bus_code() {
    let mut cases = 0u64;
    for kelvin in 0..=100u32 {
        for bus in (0..=4_095u16).step_by(7) {
            for emf in (-12_000..=60_000i32).step_by(997) {
                hot_window_bounds_current(kelvin * 1_000_000, bus, emf);
                cases += 1;
            }
        }
    }
    // Past the bound, the estimate is capped.
    hot_window_bounds_current(u32::MAX, 1_638, 0);
    println!("{cases} cases");
    assert!(cases > 4_000_000);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Spells of heavy conduction and rest, each many milliseconds of 50 µs calls.
    #[test]
    fn heat_step_bounded_along_sequences(
        start in 0..=RISE_MAX_UK,
        spells in prop::collection::vec((0u16..=4_095, any::<bool>(), 1u32..=20_000, 1u32..=600), 1..12),
    ) {
        let config = DriveConfig::PAPER;
        let mut heat = WindingHeat::with_rise(&config, start);
        for (codes, conducting, calls, gap) in spells {
            for _ in 0..calls {
                heat_step_bounded(&mut heat, codes, conducting, gap);
            }
        }
    }
}

//! The tension controller's step (REQ-TEN-01/02/03): from any valid state and any
//! measurement, no panic, duty within DUTY_MAX, invariant kept — several steps in a row.
#![no_main]

use libfuzzer_sys::fuzz_target;
use taut_proofs::tension::{StepCase, rsmc_step_bounded};

fuzz_target!(|cases: Vec<StepCase>| {
    for case in cases.iter().take(64) {
        rsmc_step_bounded(case);
    }
});

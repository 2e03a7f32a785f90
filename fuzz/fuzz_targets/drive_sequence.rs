//! Arbitrary sequences of fast-loop calls into the drive; every call is checked against every
//! drive safety property (REQ-DRV-01 … 08: bounded duty, no shoot-through, dead time, Hall
//! faults, overcurrent, latching, limit switches, safe reversal).
#![no_main]

use libfuzzer_sys::fuzz_target;
use taut_proofs::drive::{CheckedDrive, StepInput};

fuzz_target!(|calls: Vec<StepInput>| {
    let mut drive = CheckedDrive::new();
    // Bound the work per input; libFuzzer finds long sequences by splicing short ones.
    for call in calls.iter().take(1_024) {
        drive.step(call);
    }
});

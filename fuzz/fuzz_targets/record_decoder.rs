//! The stored record's decoder on its own (REQ-STORE-01, REQ-UI-08). The first input byte
//! picks the mode: odd = the rest laid into one 128-byte record with its CRC recomputed (so
//! mutations of the seeds' valid records reach the reserved-byte, field and calibration
//! checks behind the CRC), even = the rest decoded as it is. Oracle: a typed error, or a
//! valid record that re-encodes to the same bytes and whose calibration the machine uses
//! only if it validates (`taut_proofs::record_fuzz`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use taut_proofs::record_fuzz::check_input;

fuzz_target!(|data: &[u8]| {
    check_input(data);
});

//! Arbitrary tick sequences into the machine, from power-up or from an arbitrary checkpoint;
//! every tick is checked against every machine safety property (REQ-SAFE-01 … 07: never
//! toward an active limit, both limits → fault and coast, overcurrent → coast in the same
//! tick, releasing stops at home, bounded duty, faults and idle states coast, clears only
//! with the command zeroed). Also decodes the tick bytes as a stored record: no panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use taut_core::machine::Machine;
use taut_core::store::Record;
use taut_proofs::machine::{CheckpointInput, TickInput, apply, check_tick, resume};

fuzz_target!(|input: (Option<CheckpointInput>, Vec<TickInput>, Vec<u8>)| {
    let (start, ticks, record_bytes) = input;
    let mut machine = match start {
        Some(checkpoint) => match resume::<4>(&checkpoint) {
            Some(machine) => machine,
            None => return,
        },
        None => match taut_proofs::paper_board() {
            Some(board) => Machine::<4>::with_stored(Record::decode(&record_bytes), &board),
            None => return,
        },
    };
    // Bound the work per input; libFuzzer finds long sequences by splicing short ones.
    for tick in ticks.iter().take(4_096) {
        check_tick(&apply(&mut machine, &tick.inputs()));
    }
});

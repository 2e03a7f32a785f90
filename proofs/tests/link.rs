//! The machine link's properties under `cargo test` (REQ-LINK-01, REQ-LINK-02): the frame
//! decoder on proptest bytes and on every truncation and bit flip of real frames; the
//! no-motion rule for every state kind with every request kind, garbage between them.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    reason = "test bookkeeping on small counts; a panic fails the test, as it should"
)]

use proptest::prelude::*;
use taut_core::machine::{Checkpoint, MachineState};
use taut_core::store::Record;
use taut_link::message::{Request, WirePreferences, WireSettings, WireUnit};
use taut_proofs::link::{check_input, decoding_is_total, serving_never_moves};

/// One request of each kind, writes included (valid and invalid values).
fn every_request_kind() -> Vec<Request> {
    let settings = WireSettings {
        unit: WireUnit::Kilograms,
        tension_tenths: 270,
        speed: 3,
        pre_stretch_percent: 10,
        knot_percent: 5,
    };
    let preferences = WirePreferences { beeper: false, constant_pull: false };
    vec![
        Request::Hello,
        Request::ReadLog { page: 0 },
        Request::ReadLog { page: 200 },
        Request::ReadStatus,
        Request::ReadPreset { index: 3 },
        Request::ReadPreset { index: 99 },
        Request::ReadRecord { part: 2 },
        Request::ReadRecord { part: 9 },
        Request::ReadFaults,
        Request::Stream { period_ms: 1 },
        Request::WriteSettings { settings, preferences },
        Request::WriteSettings { settings: WireSettings { speed: 0, ..settings }, preferences },
        Request::WritePreset { index: 0, settings },
        Request::WritePreset { index: 9, settings },
        Request::StageRecord { part: 0, bytes: [0xA5; 32] },
        Request::StageRecord { part: 7, bytes: [0; 32] },
        Request::CommitRecord,
    ]
}

#[test]
fn link_no_request_moves_the_machine_in_any_state() {
    let garbage = [0x13, 0x00, 0xFF, 0x02, 0x55];
    let mut cases = 0;
    for state in MachineState::KINDS {
        for request in every_request_kind() {
            serving_never_moves(
                Record::default(),
                &Checkpoint::at(state),
                &[request],
                &garbage,
                40,
            );
            cases += 1;
        }
        // A whole restore: the staged parts of a valid record, then the commit.
        let bytes = Record::default().encode();
        let mut restore: Vec<Request> = (0..4u8)
            .map(|part| {
                let mut chunk = [0u8; 32];
                chunk.copy_from_slice(&bytes[usize::from(part) * 32..][..32]);
                Request::StageRecord { part, bytes: chunk }
            })
            .collect();
        restore.push(Request::CommitRecord);
        serving_never_moves(Record::default(), &Checkpoint::at(state), &restore, &[], 40);
        cases += 1;
    }
    println!("no-motion: {cases} cases");
    assert_eq!(cases, MachineState::KINDS.len() * (every_request_kind().len() + 1));
}

#[test]
fn link_truncated_and_flipped_frames_are_typed_errors() {
    let mut cases = 0;
    for request in every_request_kind() {
        let mut frame = [0u8; taut_link::MAX_FRAME];
        let command = taut_link::Command { seq: 7, request };
        let len = taut_link::encode(&command, &mut frame).unwrap_or(0);
        assert!(len > 1);
        assert_eq!(taut_link::decode::<taut_link::Command>(&frame[..len - 1]), Ok(command));
        for cut in 0..len {
            decoding_is_total(&frame[..cut]);
            cases += 1;
        }
        for at in 0..len - 1 {
            let mut bad = frame;
            bad[at] ^= 0x04;
            decoding_is_total(&bad[..len - 1]);
            cases += 1;
        }
    }
    println!("decoder: {cases} cases");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2_000, ..ProptestConfig::default() })]

    #[test]
    fn link_any_bytes_decode_totally(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        decoding_is_total(&bytes);
    }

    #[test]
    fn link_any_fuzz_input_keeps_the_machine_still(
        bytes in proptest::collection::vec(any::<u8>(), 0..120)
    ) {
        check_input(&bytes);
    }
}

/// The `link_frame` fuzz target's seeds run through its oracle, and they reach the server:
/// every seed draws at least one request.
#[test]
fn link_fuzz_seeds_pass_the_oracle() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/link_frame");
    let mut seeds = 0;
    for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let bytes = std::fs::read(entry.map(|e| e.path()).unwrap_or_default()).unwrap_or_default();
        let rest = &bytes[2.min(bytes.len())..];
        let garbage = usize::from(bytes.get(1).copied().unwrap_or(0) & 31).min(rest.len());
        let (_, count) = taut_proofs::link::requests_from::<8>(&rest[garbage..]);
        assert!(count > 0, "a seed with no request");
        check_input(&bytes);
        seeds += 1;
    }
    println!("link_frame seeds: {seeds}");
    assert!(seeds >= 6);
}

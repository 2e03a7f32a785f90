//! The record-decoder fuzz oracle (`REQ-STORE-01`, `REQ-UI-08`) under `cargo test`: the
//! independent CRC agrees with the core's, every seed input reaches an accepted record, the
//! committed seed corpus is the one the seeds generate, and proptest mutates the seeds in both
//! modes; the decoder's field and reserved-byte rules are checked behind a good CRC. Each test
//! prints how many cases it covered.
//!
//! Regenerate the seed corpus after a record format change with
//! `TAUT_WRITE_SEEDS=1 cargo test -p taut-proofs --test record_fuzz`.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::expect_used,
    clippy::indexing_slicing,
    reason = "test bookkeeping on small counts; a panic fails the test, as it should"
)]

mod common;

use std::fs;
use std::path::PathBuf;

use proptest::prelude::*;
use taut_core::sense::calibration::Calibration;
use taut_core::store::{FORMAT_VERSION, KNOWN_LEN, RECORD_LEN, Record, StoreError};
use taut_proofs::record_fuzz::{
    CRC_OFFSET, Mode, check_input, crc32c, decoder_is_sound, prepare, reseal, seed_inputs,
    seed_records,
};

fn seed_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/record_decoder")
}

#[test]
fn record_fuzz_crc_matches_the_core() {
    // The CRC-32/ISCSI check value ("123456789" → 0xE3069283) and the core's own records.
    assert_eq!(crc32c(b"123456789"), 0xE306_9283);
    for (name, record) in seed_records() {
        let bytes = record.encode();
        let mut resealed = bytes;
        resealed[CRC_OFFSET..].fill(0);
        reseal(&mut resealed);
        assert_eq!(resealed, bytes, "{name}: resealing a good record changed it");
    }
}

#[test]
fn record_fuzz_seeds_reach_the_field_checks() {
    // Both sides of the stored-calibration rule are seeded: calibrations the machine uses
    // and one it must refuse (n-03).
    let (mut used, mut refused) = (0, 0);
    for (name, input) in seed_inputs() {
        check_input(&input);
        let decoded = Record::decode(&prepare(&input));
        let Ok(record) = decoded else {
            panic!("{name}: the seed is not an accepted record: {decoded:?}");
        };
        if let Some(points) = record.calibration {
            match Calibration::new(&points) {
                Ok(_) => used += 1,
                Err(_) => refused += 1,
            }
        }
    }
    assert!(used >= 2 && refused >= 1, "calibrations used {used}, refused {refused}");
}

#[test]
fn record_fuzz_modes_lay_out_the_input() {
    assert!(prepare(&[]).is_empty());
    assert_eq!(Mode::from_selector(Mode::Raw.selector()), Mode::Raw);
    assert_eq!(Mode::from_selector(Mode::Resealed.selector()), Mode::Resealed);
    // Raw keeps the length (a short input is too short); resealed always makes one record.
    assert_eq!(prepare(&[0, 1, 2]), vec![1, 2]);
    assert_eq!(Record::decode(&prepare(&[0, b'T', b'T'])), Err(StoreError::TooShort));
    let resealed = prepare(&[1, b'T', b'T', 1]);
    assert_eq!(resealed.len(), RECORD_LEN);
    assert_eq!(crc32c(&resealed[..CRC_OFFSET]).to_le_bytes(), resealed[CRC_OFFSET..]);
    // An all-zero body with a good CRC gets past the CRC and fails on a field.
    let mut header_only = [0u8; RECORD_LEN];
    let length = u8::try_from(RECORD_LEN).expect("a record is at most 255 bytes");
    header_only[..4].copy_from_slice(&[b'T', b'T', FORMAT_VERSION, length]);
    reseal(&mut header_only);
    assert_eq!(Record::decode(&header_only), Err(StoreError::InvalidSettings));
    decoder_is_sound(&header_only);
}

/// The committed seed corpus (`fuzz/seeds/record_decoder/`) is exactly what the seed records
/// generate, so the fuzzer starts from records the current format accepts.
#[test]
fn record_fuzz_seed_corpus_is_current() {
    let dir = seed_dir();
    let write = std::env::var_os("TAUT_WRITE_SEEDS").is_some();
    if write {
        fs::create_dir_all(&dir).expect("create the seed directory");
    }
    for (name, input) in seed_inputs() {
        let path = dir.join(&name);
        if write {
            fs::write(&path, &input).expect("write a seed");
            continue;
        }
        let committed = fs::read(&path).unwrap_or_default();
        assert!(
            committed == input,
            "{} is missing or stale; regenerate with \
             `TAUT_WRITE_SEEDS=1 cargo test -p taut-proofs --test record_fuzz`",
            path.display()
        );
    }
    println!("record_fuzz_seed_corpus_is_current: {} seeds", seed_inputs().len());
}

/// Byte edits of the seeds, in both modes: overwrite, insert, truncate.
fn mutated_seed() -> impl Strategy<Value = Vec<u8>> {
    let seeds = seed_inputs().into_iter().map(|(_, input)| input).collect::<Vec<_>>();
    (
        0..seeds.len(),
        any::<u8>(),
        prop::collection::vec((0..RECORD_LEN + 1, any::<u8>()), 1..6),
        prop::option::of(0..RECORD_LEN + 2),
    )
        .prop_map(move |(seed, selector, edits, cut)| {
            let mut input = seeds[seed].clone();
            input[0] = selector;
            let last = input.len() - 1;
            for (at, byte) in edits {
                input[at.clamp(1, last)] = byte;
            }
            if let Some(cut) = cut {
                input.truncate(cut);
            }
            input
        })
}

#[test]
fn record_fuzz_mutated_seeds_proptest() {
    let accepted = std::sync::atomic::AtomicU32::new(0);
    common::check("record_fuzz_mutated_seeds_proptest", 20_000, mutated_seed(), |input| {
        check_input(&input);
        if Record::decode(&prepare(&input)).is_ok() {
            accepted.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    });
    let accepted = accepted.into_inner();
    println!("record_fuzz_mutated_seeds_proptest: {accepted} mutated inputs accepted");
    assert!(accepted > 100, "the mutations should often keep a valid record: {accepted}");
}

/// An edit of the settings block that starts at the given offset.
type BlockEdit = fn(&mut [u8; RECORD_LEN], usize);

/// `record` with `edit` applied and its CRC resealed, decoded.
fn decode_edited(
    record: &Record,
    edit: impl FnOnce(&mut [u8; RECORD_LEN]),
) -> Result<Record, StoreError> {
    let mut bytes = record.encode();
    edit(&mut bytes);
    reseal(&mut bytes);
    decoder_is_sound(&bytes);
    Record::decode(&bytes)
}

/// REQ-STORE-03: the reserved bytes (181–219; 105–108 are the boot counter, 109 the
/// preferences, whose undefined bits count as reserved) must be zero and byte 3 must be the
/// record's length even when the CRC is good, so a later format that uses them cannot be
/// misread as this one.
#[test]
fn record_rules_reserved_bytes_are_refused_behind_a_good_crc() {
    for (name, record) in seed_records() {
        for value in [4u8, 0x80, 0xFF] {
            let decoded = decode_edited(&record, |bytes| bytes[109] = value);
            assert_eq!(decoded, Err(StoreError::ReservedNotZero), "{name}: preferences {value}");
        }
        for index in std::iter::once(3).chain(KNOWN_LEN..CRC_OFFSET) {
            for value in [1u8, 0x80, 0xFF] {
                let decoded = decode_edited(&record, |bytes| bytes[index] = value);
                assert_eq!(
                    decoded,
                    Err(StoreError::ReservedNotZero),
                    "{name}: byte {index} = {value}"
                );
            }
        }
    }
}

/// REQ-STORE-03: every settings block (the current one and the nine presets) is checked field
/// by field behind a good CRC, at each field's first invalid value; the calibration block's
/// point count is 0 or the build's four, and an absent calibration is all zeros.
#[test]
fn record_rules_fields_are_refused_behind_a_good_crc() {
    let record = seed_records()[0].1;
    for block in 0..10 {
        let at = 4 + 6 * block;
        let edits: [(&str, BlockEdit); 9] = [
            ("tenths 49 kg", |b, at| b[at..at + 2].copy_from_slice(&49u16.to_le_bytes())),
            ("tenths 501 kg", |b, at| b[at..at + 2].copy_from_slice(&501u16.to_le_bytes())),
            ("unit 2", |b, at| b[at + 2] = 2),
            ("lb off the 0.5 step", |b, at| {
                b[at..at + 2].copy_from_slice(&251u16.to_le_bytes());
                b[at + 2] = 1;
            }),
            ("speed 0", |b, at| b[at + 3] = 0),
            ("speed 10", |b, at| b[at + 3] = 10),
            ("pre-stretch 31", |b, at| b[at + 4] = 31),
            ("knot 21", |b, at| b[at + 5] = 21),
            ("knot 255", |b, at| b[at + 5] = 255),
        ];
        for (what, edit) in edits {
            let decoded = decode_edited(&record, |bytes| edit(bytes, at));
            assert_eq!(decoded, Err(StoreError::InvalidSettings), "block {block}: {what}");
        }
        // The last valid values of each field pass.
        let decoded = decode_edited(&record, |b| {
            b[at..at + 2].copy_from_slice(&1_100u16.to_le_bytes());
            b[at + 2] = 1;
            b[at + 3] = 9;
            b[at + 4] = 30;
            b[at + 5] = 20;
        });
        assert!(decoded.is_ok(), "block {block}: the largest valid values were refused");
    }
    let calibration_flag = 64;
    for flag in [1u8, 2, 3, 5, 0xFF] {
        let decoded = decode_edited(&record, |b| b[calibration_flag] = flag);
        assert_eq!(decoded, Err(StoreError::InvalidCalibration), "flag {flag}");
    }
    for index in calibration_flag + 1..calibration_flag + 33 {
        let decoded = decode_edited(&record, |b| b[index] = 1);
        assert_eq!(decoded, Err(StoreError::InvalidCalibration), "stray calibration byte {index}");
    }
    // A count of 4 takes the 32 bytes as the four points, whatever they hold (validated at
    // boot).
    let decoded = decode_edited(&record, |b| b[calibration_flag] = 4);
    assert_eq!(decoded.map(|r| r.calibration.is_some()), Ok(true));
}

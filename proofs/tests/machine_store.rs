//! The stored record's properties (`REQ-STORE-*`) under `cargo test`: exhaustive over every
//! single-bit flip of real records and every settings value, proptest over random and
//! mutated bytes. Each test prints how many cases it covered.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::expect_used,
    clippy::indexing_slicing,
    reason = "test bookkeeping on small counts; a panic fails the test, as it should"
)]

use proptest::prelude::*;
use taut_core::machine::snapshot::{FaultSnapshot, SNAPSHOT_LEN};
use taut_core::settings::Preferences;
use taut_core::store::{FORMAT_V1, FORMAT_V2, FORMAT_V3};
use taut_core::store::{LEGACY_LEN, RECORD_LEN, Record, StoreError, checksum};
use taut_proofs::machine_store::{
    RecordInput, SettingsInput, SnapshotInput, as_version_1, as_version_2, as_version_3,
    decode_is_total, round_trips, snapshot_slot_is_canonical,
};

fn sample_records() -> Vec<Record> {
    let mut out = vec![Record::default()];
    for (pounds, tenths, speed, pre, knot, calibrated) in
        [(false, 250, 5, 0, 0, true), (true, 550, 9, 30, 20, false), (false, 500, 1, 10, 15, true)]
    {
        let settings = SettingsInput { pounds, tenths, speed, pre, knot };
        let input = RecordInput {
            settings,
            preset: settings,
            calibrated,
            calibration_bits: (655_360, 660_000),
            pulls: 12_345,
            string_mm: 6_789_012,
            boots: 0,
            preferences: 0,
            zero: None,
            fault: None,
            drivetrain: (0, 0),
        };
        out.push(input.record().expect("valid sample"));
    }
    out
}

/// Today's format only: records with a zero at calibration and a fault history (the real
/// snapshots of the record's own unit tests come with every field set).
fn sample_records_with_history() -> Vec<Record> {
    let mut out = Vec::new();
    for (index, record) in sample_records().into_iter().enumerate() {
        let fault = SnapshotInput {
            number: 15,
            boot: 70,
            time_ms: 3_600_123 + u32::try_from(index).expect("few"),
            hall_steps: -4_321,
        };
        let settings = SettingsInput { pounds: false, tenths: 250, speed: 5, pre: 0, knot: 0 };
        let input = RecordInput {
            settings,
            preset: settings,
            zero: Some((-12_345, 12_000)),
            fault: Some(fault),
            drivetrain: (271, 380),
            ..RecordInput::default()
        };
        let extra = input.record().expect("valid history");
        out.push(Record {
            calibration_zero: extra.calibration_zero,
            calibration_pulls: extra.calibration_pulls,
            faults: extra.faults,
            drivetrain: extra.drivetrain,
            ..record
        });
    }
    out
}

/// The samples with every preferences value (beeper and constant pull on or off).
fn sample_records_with_preferences() -> Vec<Record> {
    let mut out = Vec::new();
    for record in sample_records() {
        for flags in 0..4 {
            let preferences = Preferences::from_flags(flags).expect("defined bits");
            out.push(Record { preferences, ..record });
        }
    }
    out
}

#[test]
fn machine_store_bit_flips_exhaustive() {
    let mut cases = 0u32;
    for record in sample_records_with_preferences().into_iter().chain(sample_records_with_history())
    {
        round_trips(&record);
        let bytes = record.encode();
        for index in 0..RECORD_LEN {
            for bit in 0..8 {
                let mut corrupt = bytes;
                corrupt[index] ^= 1 << bit;
                decode_is_total(&corrupt);
                assert!(Record::decode(&corrupt).is_err(), "flip {index}:{bit} accepted");
                cases += 1;
            }
        }
    }
    println!("machine_store_bit_flips_exhaustive: {cases} corrupted records, all rejected");
}

/// Every sample record as an old format writes it (`old`) is read back in that `version`
/// with every field kept, and every single-bit flip of the old bytes is refused; returns
/// how many flips were tried.
fn old_records_migrate(version: u8, old: fn(&Record) -> [u8; LEGACY_LEN]) -> u32 {
    let mut cases = 0u32;
    for record in sample_records() {
        let bytes = old(&record);
        assert_eq!(Record::decode_version(&bytes), Ok((record, version)));
        decode_is_total(&bytes);
        for index in 0..LEGACY_LEN {
            for bit in 0..8 {
                let mut corrupt = bytes;
                corrupt[index] ^= 1 << bit;
                decode_is_total(&corrupt);
                assert!(Record::decode(&corrupt).is_err(), "v{version} flip {index}:{bit}");
                cases += 1;
            }
        }
    }
    cases
}

/// REQ-STORE-05: every sample record written by format version 1 is read, migrated, with
/// every field kept; a single-bit flip of the old bytes is still refused.
#[test]
fn machine_store_version_1_records_migrate() {
    let cases = old_records_migrate(FORMAT_V1, as_version_1);
    println!("machine_store_version_1_records_migrate: {cases} corrupted version-1 records");
}

/// REQ-STORE-05: every sample record written by format version 2 (no preferences byte) is
/// read with the default preferences and every other field kept; a single-bit flip of the
/// old bytes is still refused.
#[test]
fn machine_store_version_2_records_migrate() {
    let cases = old_records_migrate(FORMAT_V2, as_version_2);
    println!("machine_store_version_2_records_migrate: {cases} corrupted version-2 records");
}

/// REQ-STORE-05: every sample record written by format version 3 (128 bytes, no zero at
/// calibration, no fault history) is read with every field kept; a single-bit flip of the old
/// bytes is still refused.
#[test]
fn machine_store_version_3_records_migrate() {
    let cases = old_records_migrate(FORMAT_V3, as_version_3);
    println!("machine_store_version_3_records_migrate: {cases} corrupted version-3 records");
}

#[test]
fn machine_store_settings_exhaustive() {
    let mut accepted = 0u32;
    let mut cases = 0u32;
    for pounds in [false, true] {
        for tenths in 0..=1_200u16 {
            for speed in 0..=10u8 {
                for pre in [0u8, 5, 29, 30, 31] {
                    for knot in [0u8, 20, 21] {
                        let settings = SettingsInput { pounds, tenths, speed, pre, knot };
                        let input =
                            RecordInput { settings, preset: settings, ..RecordInput::default() };
                        cases += 1;
                        if let Some(record) = input.record() {
                            round_trips(&record);
                            accepted += 1;
                        }
                    }
                }
            }
        }
    }
    println!(
        "machine_store_settings_exhaustive: {cases} settings, {accepted} valid, all round-trip"
    );
    assert!(accepted > 10_000);
}

#[test]
fn machine_store_short_and_erased() {
    assert_eq!(Record::decode(&[]), Err(StoreError::TooShort));
    assert_eq!(Record::decode(&[0xFF; RECORD_LEN]), Err(StoreError::NoRecord));
    assert_eq!(Record::decode(&[0x00; RECORD_LEN]), Err(StoreError::NoRecord));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn machine_store_random_bytes(bytes in prop::array::uniform32(any::<u8>()), tail in prop::collection::vec(any::<u8>(), RECORD_LEN - 32)) {
        let mut all = [0u8; RECORD_LEN];
        all[..32].copy_from_slice(&bytes);
        all[32..].copy_from_slice(&tail);
        decode_is_total(&all);
    }

    #[test]
    fn machine_store_mutated_records(which in 0usize..8, index in 0usize..RECORD_LEN, value in any::<u8>()) {
        let records: Vec<Record> = sample_records().into_iter().chain(sample_records_with_history()).collect();
        let mut bytes = records[which].encode();
        bytes[index] = value;
        decode_is_total(&bytes);
    }

    /// REQ-STORE-01/05/06 past the CRC: a record of every version with up to three bytes
    /// replaced and its CRC recomputed (what the Kani harnesses' stand-in checksum lets
    /// through) decodes, when it does, to a valid record in its canonical form.
    #[test]
    fn machine_store_resealed_mutations(version in 1u8..=4, which in 0usize..8, edits in prop::collection::vec((0usize..RECORD_LEN, any::<u8>()), 1..4)) {
        let records: Vec<Record> = sample_records().into_iter().chain(sample_records_with_history()).collect();
        let record = records[which];
        let mut bytes = match version {
            1 => as_version_1(&record).to_vec(),
            2 => as_version_2(&record).to_vec(),
            3 => as_version_3(&record).to_vec(),
            _ => record.encode().to_vec(),
        };
        for (index, value) in edits {
            if index != 2 && index < bytes.len() - 4 {
                bytes[index] = value;
            }
        }
        let crc_at = bytes.len() - 4;
        let crc = checksum(&bytes[..crc_at]).to_le_bytes();
        bytes[crc_at..].copy_from_slice(&crc);
        decode_is_total(&bytes);
    }

    /// REQ-STORE-02: records built from random field values (every settings field over and
    /// past its range, any calibration, counters, preferences bits, stamp, history and wear
    /// trend) round-trip whenever the values make a record.
    #[test]
    fn machine_store_random_records_round_trip(
        settings in (any::<bool>(), 0u16..1_300, 0u8..12, 0u8..35, 0u8..25),
        preset in (any::<bool>(), 0u16..1_300, 0u8..12, 0u8..35, 0u8..25),
        calibration in proptest::option::of(any::<(i32, i32)>()),
        counters in any::<(u32, u32, u32)>(),
        preferences in 0u8..8,
        zero in proptest::option::of(any::<(i32, u32)>()),
        fault in proptest::option::of((1u8..40, any::<u16>(), any::<u32>(), any::<i32>())),
        drivetrain in any::<(u16, u16)>(),
    ) {
        let block = |(pounds, tenths, speed, pre, knot)| SettingsInput { pounds, tenths, speed, pre, knot };
        let input = RecordInput {
            settings: block(settings),
            preset: block(preset),
            calibrated: calibration.is_some(),
            calibration_bits: calibration.unwrap_or_default(),
            pulls: counters.0,
            string_mm: counters.1,
            boots: counters.2,
            preferences,
            zero,
            fault: fault.map(|(number, boot, time_ms, hall_steps)| SnapshotInput { number, boot, time_ms, hall_steps }),
            drivetrain,
        };
        if let Some(record) = input.record() {
            round_trips(&record);
        }
    }

    /// REQ-UI-13: random slot bytes, and a real snapshot's bytes with one byte replaced.
    #[test]
    fn machine_store_snapshot_slots(bytes in prop::array::uniform22(any::<u8>()), index in 0usize..SNAPSHOT_LEN, value in any::<u8>(), record in 4usize..8) {
        snapshot_slot_is_canonical(&bytes);
        let snapshot = sample_records_with_history()[record - 4].faults[0].expect("a fault");
        let mut real = FaultSnapshot::encode_slot(Some(&snapshot));
        snapshot_slot_is_canonical(&real);
        real[index] = value;
        snapshot_slot_is_canonical(&real);
    }
}

/// REQ-STORE-01 past the CRC, exhaustively over one settings block's fields: every value of
/// the set point (both units) and of the speed, pre-stretch and knot bytes, in a record of
/// every version, either refused or decoded to its canonical form.
#[test]
fn machine_store_settings_bytes_exhaustive() {
    let record = sample_records()[1];
    let mut accepted = 0u32;
    for version in 1u8..=4 {
        let base = match version {
            1 => as_version_1(&record).to_vec(),
            2 => as_version_2(&record).to_vec(),
            3 => as_version_3(&record).to_vec(),
            _ => record.encode().to_vec(),
        };
        let reseal = |bytes: &mut Vec<u8>| {
            let crc_at = bytes.len() - 4;
            let crc = checksum(&bytes[..crc_at]).to_le_bytes();
            bytes[crc_at..].copy_from_slice(&crc);
        };
        for unit in 0u8..=2 {
            for tenths in 0..=u16::MAX {
                let mut bytes = base.clone();
                bytes[4..6].copy_from_slice(&tenths.to_le_bytes());
                bytes[6] = unit;
                reseal(&mut bytes);
                decode_is_total(&bytes);
                accepted += u32::from(Record::decode(&bytes).is_ok());
            }
        }
        for field in 7..10 {
            for value in 0..=u8::MAX {
                let mut bytes = base.clone();
                bytes[field] = value;
                reseal(&mut bytes);
                decode_is_total(&bytes);
                accepted += u32::from(Record::decode(&bytes).is_ok());
            }
        }
    }
    println!("machine_store_settings_bytes_exhaustive: {accepted} accepted, all canonical");
    assert!(accepted > 1_000);
}

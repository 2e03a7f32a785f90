//! The stored record's decoder under fuzzing (`REQ-STORE-01`, `REQ-UI-08`): the oracle the
//! `record_decoder` fuzz target and `proofs/tests/record_fuzz.rs` run on every input.
//!
//! # Why a target of its own
//!
//! A record is 128 bytes behind a two-byte magic, a version byte and a CRC-32/ISCSI. Random
//! bytes almost never pass those, so a fuzzer that feeds raw bytes to [`Record::decode`]
//! explores the header checks and nothing behind them. This module gives the fuzzer two
//! **modes**, chosen by the first input byte ([`Mode::from_selector`]):
//!
//! - [`Mode::Raw`]: the rest of the input is handed to the decoder as it is (any length);
//! - [`Mode::Resealed`]: the rest is laid into a 128-byte record (zero-padded or cut) and its
//!   CRC is recomputed over bytes `0..124` and stored at `124..128`, as the firmware's writer
//!   does ([`reseal`]). Starting from valid seeds, libFuzzer's mutations then reach the
//!   reserved-byte, settings, preset, calibration-flag and counter checks.
//!
//! The CRC here is a bitwise CRC-32/ISCSI (CRC-32C: reflected polynomial `0x82F6_3B78`,
//! initial value and final XOR `0xFFFF_FFFF`) written independently of the `crc` crate the
//! core uses, so a wrong table or algorithm choice in the core would show as a mismatch.
//!
//! # The oracle ([`decoder_is_sound`])
//!
//! For any bytes, [`Record::decode`] returns; then
//! - an input shorter than [`RECORD_LEN`] is [`StoreError::TooShort`], one without the magic
//!   is [`StoreError::NoRecord`], and every error is shown as the notice `n-01`;
//! - an accepted record carries a CRC that matches its body, satisfies [`Record::is_valid`]
//!   and re-encodes to exactly the bytes it came from (one encoding per record);
//! - a stored calibration is used only if it passes [`Calibration::new`]'s validation *and*
//!   lies inside the validated range stated independently here (reference readings strictly
//!   increasing within `[KNEE, REFERENCE_MAX]`, raw readings strictly increasing above the zero
//!   reading, fitted gain within [`GAIN_RANGE_Q30`], offset within ±[`OFFSET_LIMIT`]); a
//!   machine powered up with a record whose calibration fails shows the notice `n-03`
//!   instead of using it, and one whose calibration passes shows no notice.

use crate::machine_store::{as_version_1, as_version_2, decoded_is_canonical};
use taut_core::machine::{Machine, Notice};
use taut_core::sense::calibration::{
    CALIBRATION_TARGETS, Calibration, CalibrationPoint, GAIN_RANGE_Q30, KNEE, OFFSET_LIMIT,
    REFERENCE_MAX,
};
use taut_core::settings::{SetPoint, Settings, Unit};
use taut_core::store::{
    Counters, FORMAT_VERSION, LEGACY_LEN, MAGIC, PRESET_COUNT, RECORD_LEN, Record, StoreError,
};
use taut_core::units::Kgf;

/// Where the CRC starts: the last four bytes of the record.
pub const CRC_OFFSET: usize = RECORD_LEN - 4;

/// How the fuzz target turns its input into the bytes it decodes.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Mode {
    /// The bytes after the selector, unchanged.
    Raw,
    /// The bytes after the selector laid into one record with its CRC recomputed.
    Resealed,
}

impl Mode {
    /// The selector byte that chooses this mode (the one the seeds use).
    #[must_use]
    pub const fn selector(self) -> u8 {
        match self {
            Self::Raw => 0,
            Self::Resealed => 1,
        }
    }

    /// The mode a selector byte chooses: odd bytes reseal, even bytes are raw.
    #[must_use]
    pub const fn from_selector(selector: u8) -> Self {
        if selector & 1 == 1 { Self::Resealed } else { Self::Raw }
    }
}

/// CRC-32/ISCSI of `bytes`, bit by bit.
#[must_use]
pub fn crc32c(bytes: &[u8]) -> u32 {
    const POLYNOMIAL: u32 = 0x82F6_3B78;
    let mut crc = u32::MAX;
    for &byte in bytes {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            let low_bit_set = crc & 1 == 1;
            crc = crc.wrapping_shr(1);
            if low_bit_set {
                crc ^= POLYNOMIAL;
            }
        }
    }
    !crc
}

/// Stores the CRC of bytes `0..124` at `124..128`, little-endian.
pub fn reseal(record: &mut [u8; RECORD_LEN]) {
    let (body, crc) = record.split_at_mut(CRC_OFFSET);
    crc.copy_from_slice(&crc32c(body).to_le_bytes());
}

/// The bytes the fuzz target decodes for `input`: see [`Mode`]. An empty input decodes as
/// an empty (too short) record.
#[must_use]
pub fn prepare(input: &[u8]) -> Vec<u8> {
    let Some((&selector, rest)) = input.split_first() else { return Vec::new() };
    match Mode::from_selector(selector) {
        Mode::Raw => rest.to_vec(),
        Mode::Resealed => {
            let mut record = [0u8; RECORD_LEN];
            for (slot, &byte) in record.iter_mut().zip(rest) {
                *slot = byte;
            }
            reseal(&mut record);
            record.to_vec()
        }
    }
}

/// The fuzz target's whole body: [`prepare`] then [`decoder_is_sound`].
pub fn check_input(input: &[u8]) {
    decoder_is_sound(&prepare(input));
}

/// REQ-STORE-01 and REQ-UI-08 on one input: see the module docs.
pub fn decoder_is_sound(bytes: &[u8]) {
    match Record::decode_version(bytes) {
        Err(error) => {
            if bytes.len() < LEGACY_LEN {
                assert_eq!(error, StoreError::TooShort, "REQ-STORE-01: short input");
            } else if bytes.get(..2) != Some(&MAGIC[..]) {
                assert_eq!(error, StoreError::NoRecord, "REQ-STORE-01: no magic");
            }
            assert_eq!(
                Notice::from_store(error),
                Notice::StoreInvalid,
                "REQ-UI-08: a record that fails to load is notice n-01"
            );
        }
        Ok((record, version)) => {
            let len = match version {
                1..=3 => LEGACY_LEN,
                FORMAT_VERSION => RECORD_LEN,
                _ => usize::from(bytes.get(3).copied().unwrap_or(0)),
            };
            let Some(stored) = bytes.get(..len).filter(|stored| stored.len() >= 4) else {
                panic!("REQ-STORE-01: accepted {} bytes as a record", bytes.len());
            };
            let (body, crc) = stored.split_at(len.saturating_sub(4));
            assert_eq!(
                crc32c(body).to_le_bytes(),
                crc,
                "REQ-STORE-01: accepted a record whose CRC does not match its body"
            );
            assert!(record.is_valid(), "REQ-STORE-01: decoded an invalid record");
            decoded_is_canonical(stored, &record, version);
            stored_calibration_is_validated(&record);
        }
    }
}

/// REQ-UI-08: the machine uses a stored calibration only if it validates, and then it lies in
/// the validated range; otherwise it shows `n-03`.
pub fn stored_calibration_is_validated(record: &Record) {
    let Some(board) = crate::paper_board() else { return };
    let notice = Machine::<1>::with_record(*record, &board).notice();
    let Some(stored) = record.calibration else {
        assert_eq!(notice, None, "REQ-UI-08: a notice for a record without calibration");
        return;
    };
    match Calibration::new(&stored) {
        Err(_) => assert_eq!(
            notice,
            Some(Notice::StoredCalibrationInvalid),
            "REQ-UI-08: an invalid stored calibration was not reported as n-03: {stored:?}"
        ),
        Ok(accepted) => {
            assert_eq!(notice, None, "REQ-UI-08: a valid stored calibration was refused");
            assert!(accepted.is_valid(), "REQ-UI-08: accepted calibration breaks its invariant");
            within_validated_range(&accepted);
        }
    }
}

/// The validated range, stated from the documented limits rather than from the fit.
fn within_validated_range(accepted: &Calibration) {
    let points = accepted.points();
    let mut previous_raw = Kgf::ZERO;
    let mut previous_reference = Kgf::ZERO;
    for point in points {
        assert!(
            point.raw > previous_raw && point.reference > previous_reference,
            "REQ-UI-08: accepted calibration points that do not increase: {points:?}"
        );
        assert!(
            point.reference >= KNEE && point.reference <= REFERENCE_MAX,
            "REQ-UI-08: accepted a reference reading outside [5, 55] kgf: {points:?}"
        );
        previous_raw = point.raw;
        previous_reference = point.reference;
    }
    let gain = accepted.gain_q30();
    assert!(
        gain >= GAIN_RANGE_Q30.0 && gain <= GAIN_RANGE_Q30.1,
        "REQ-UI-08: accepted a gain outside [0.8, 1.25]: {gain}"
    );
    assert!(
        accepted.offset().abs() <= OFFSET_LIMIT,
        "REQ-UI-08: accepted an offset beyond ±3 kgf: {:?}",
        accepted.offset()
    );
}

/// The records the fuzz target's seeds encode, by name: defaults; a plausible calibration;
/// pound settings with every preset different; a calibration the decoder accepts but the
/// machine must refuse (gain out of range); the largest counters.
#[must_use]
pub fn seed_records() -> Vec<(&'static str, Record)> {
    let settings = |unit: Unit, tenths: u16, speed: u8, pre: u8, knot: u8| {
        SetPoint::new(unit, tenths)
            .and_then(|point| Settings::new(point, speed, pre, knot))
            .unwrap_or(Settings::DEFAULT)
    };
    // Points at every calibration target (whatever their number): the raw reading and the
    // reference, in tenths, as functions of the point's index and target.
    let points = |of: fn(i32, i32) -> (i32, i32)| {
        let mut index = 0;
        CALIBRATION_TARGETS.map(|target| {
            let (raw, reference) = of(index, target.to_tenths_rounded());
            index = index.saturating_add(1);
            CalibrationPoint { raw: Kgf::from_tenths(raw), reference: Kgf::from_tenths(reference) }
        })
    };
    let calibrated = Record {
        calibration: Some(points(|index, target| {
            (target.saturating_add(index).saturating_sub(2), target)
        })),
        counters: Counters { pulls: 1_234, string_used_mm: 987_654, boots: 17 },
        ..Record::default()
    };
    let mut pounds = Record {
        settings: settings(Unit::Pounds, 550, 7, 10, 15),
        counters: Counters { pulls: 1, string_used_mm: 250, boots: 1 },
        ..Record::default()
    };
    let presets = [
        (Unit::Kilograms, 50, 1, 0, 0),
        (Unit::Pounds, 115, 2, 5, 5),
        (Unit::Kilograms, 235, 3, 10, 10),
        (Unit::Pounds, 555, 4, 15, 15),
        (Unit::Kilograms, 250, 5, 20, 20),
        (Unit::Pounds, 800, 6, 25, 0),
        (Unit::Kilograms, 399, 7, 30, 5),
        (Unit::Pounds, 1100, 8, 0, 10),
        (Unit::Kilograms, 500, 9, 5, 15),
    ];
    for (preset, (unit, tenths, speed, pre, knot)) in pounds.presets.iter_mut().zip(presets) {
        *preset = settings(unit, tenths, speed, pre, knot);
    }
    let refused_calibration = Record {
        calibration: Some(points(|_, target| (target, target.saturating_mul(27) / 20))),
        ..Record::default()
    };
    let extreme = Record {
        settings: settings(Unit::Kilograms, 500, 9, 30, 20),
        presets: [settings(Unit::Pounds, 1100, 1, 0, 0); PRESET_COUNT],
        calibration: Some(points(|_, target| (target.saturating_sub(5), target))),
        counters: Counters { pulls: u32::MAX, string_used_mm: u32::MAX, boots: u32::MAX },
        preferences: taut_core::settings::Preferences { beeper: false, constant_pull: false },
        ..Record::default()
    };
    vec![
        ("default", Record::default()),
        ("calibrated", calibrated),
        ("pounds_presets", pounds),
        ("calibration_refused", refused_calibration),
        ("extreme_counters", extreme),
    ]
}

/// The fuzz target's seed inputs, by file name: every seed record in both modes.
#[must_use]
pub fn seed_inputs() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for (name, record) in seed_records() {
        for (mode, suffix) in [(Mode::Raw, "raw"), (Mode::Resealed, "resealed")] {
            let mut input = vec![mode.selector()];
            input.extend_from_slice(&record.encode());
            out.push((format!("{name}_{suffix}"), input));
        }
        // The same record as format version 1 wrote it (no boot counter, no preferences) and
        // as version 2 did (no preferences), for the migrations.
        let defaults = taut_core::settings::Preferences::DEFAULT;
        let old = Record {
            counters: Counters { boots: 0, ..record.counters },
            preferences: defaults,
            ..record
        };
        let mut input = vec![Mode::Raw.selector()];
        input.extend_from_slice(&as_version_1(&old));
        out.push((format!("{name}_v1_raw"), input));
        let mut input = vec![Mode::Raw.selector()];
        input.extend_from_slice(&as_version_2(&Record { preferences: defaults, ..record }));
        out.push((format!("{name}_v2_raw"), input));
    }
    out
}

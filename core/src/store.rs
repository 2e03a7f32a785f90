//! The persisted record: settings, presets, calibration and counters, in a fixed, versioned,
//! CRC-checked byte layout.
//!
//! # Theory of operation
//!
//! Everything the machine must remember across a power cycle lives in one [`Record`]: the
//! operator's current [`Settings`] (tension set point and its unit, speed, pre-stretch, knot),
//! nine [`Settings`] presets, the reference points of the last accepted load-cell
//! calibration ([`CalibrationPoints`]) and the [`Counters`] (pulls, string used, boots). The
//! machine owns the record; when it changes one, it raises [`crate::io::Outputs::store`] and
//! the firmware writes [`Record::encode`]'s bytes to flash when convenient. At boot the
//! firmware reads the bytes back and hands [`Record::decode`]'s result to the machine; a
//! record that is missing, corrupt or from an unknown format version is a typed
//! [`StoreError`], never a panic — the machine then runs on [`Record::default`] and shows the
//! error's code once.
//!
//! Every settings field is validated when decoded, through the same constructors the panel
//! uses ([`crate::settings`]), so a record that passes [`Record::decode`] satisfies every
//! invariant the machine relies on and the per-tick path never re-checks it. The calibration
//! points are decoded as stored and validated by
//! [`crate::sense::calibration::Calibration::new`] when the machine starts: an implausible
//! calibration is then dropped with a notice, and the settings beside it are kept.
//!
//! # Layout (format version 3, little-endian, [`RECORD_LEN`] = 128 bytes)
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 2 | magic `b"TT"` |
//! | 2 | 1 | format version (3) |
//! | 3 | 1 | reserved, 0 |
//! | 4 | 6 | current settings (see below) |
//! | 10 | 54 | presets 1–9, 6 bytes each |
//! | 64 | 1 | calibration: number of points (0: none; else [`CALIBRATION_POINTS`]) |
//! | 65 | 32 | calibration: 4 × (raw reading, reference reading), each Q15.16 kgf bits (`i32`) |
//! | 97 | 4 | counter: pulls (`u32`) |
//! | 101 | 4 | counter: string used, millimetres (`u32`) |
//! | 105 | 4 | counter: boots (`u32`) |
//! | 109 | 1 | preferences: bit 0 beeper off, bit 1 constant pull off; other bits 0 |
//! | 110 | 14 | reserved, 0 |
//! | 124 | 4 | CRC-32/ISCSI of bytes 0..124 |
//!
//! Offsets from 65 on are those of four points; they are computed from
//! [`CALIBRATION_POINTS`], and a `const` assertion keeps the layout inside the record. A
//! settings block is: set point in tenths of its unit (`u16`), unit (0 kg, 1 lb), speed
//! (1–9), pre-stretch percent (0–30), knot percent (0–20).
//!
//! Reserved bytes must be zero: a later format that uses them bumps the version, so a reader
//! never misreads a newer record as an older one.
//!
//! # Migration
//!
//! Format version 1 had no boot counter and a calibration flag (0/1) where later versions have
//! the point count; version 2 had no preferences byte (it was reserved, so zero: the default
//! preferences); their other fields lie where version 3 has them. [`Record::decode`] reads a
//! version-1 or version-2 record into today's [`Record`] (boots 0 for version 1, the default
//! preferences for both) instead of refusing it, and [`Record::decode_version`] says which
//! format the bytes were in. The machine writes the record back in version 3 soon after
//! every boot (it counts the boot), so a migrated record is rewritten without the operator
//! doing anything.

use crc::{CRC_32_ISCSI, Crc};

use crate::sense::calibration::{CALIBRATION_POINTS, CalibrationPoint, CalibrationPoints};
use crate::settings::{Preferences, SetPoint, Settings, Unit};
use crate::units::Kgf;

/// Size of an encoded [`Record`] in bytes.
pub const RECORD_LEN: usize = 128;

/// The first two bytes of every record.
pub const MAGIC: [u8; 2] = *b"TT";

/// The format version this code writes (it also reads [`FORMAT_V1`] and [`FORMAT_V2`],
/// migrating them).
pub const FORMAT_VERSION: u8 = 3;

/// The second format version: no preferences byte (its place reserved, zero).
pub const FORMAT_V2: u8 = 2;

/// The first format version: no boot counter, a 0/1 calibration flag, four points.
pub const FORMAT_V1: u8 = 1;

/// Number of presets (keys P1–P9 on the panel).
pub const PRESET_COUNT: usize = 9;

const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

/// The record's checksum: CRC-32/ISCSI (Castagnoli) of `body`.
///
/// One named function so the Kani harnesses can replace it (`#[kani::stub]`): Kani 0.65's
/// code generator panics on the `crc` crate's slice pattern (`place.rs:771: assertion failed:
/// length >= min_length`, in `crc::crc32::update_table`), and the CRC is not the property
/// those harnesses prove. Its correctness is the known-answer test below. When Kani compiles
/// `crc` again the stubs can go (see `proofs/src/machine_store.rs`).
#[must_use]
pub fn checksum(body: &[u8]) -> u32 {
    CRC32.checksum(body)
}

const SETTINGS_LEN: usize = 6;
const OFFSET_SETTINGS: usize = 4;
const OFFSET_PRESETS: usize = OFFSET_SETTINGS + SETTINGS_LEN;
const OFFSET_CALIBRATION: usize = OFFSET_PRESETS + SETTINGS_LEN * PRESET_COUNT;
const OFFSET_CRC: usize = RECORD_LEN - 4;

/// Where the fields after the presets lie in one format version.
#[derive(Clone, Copy)]
struct Layout {
    /// Calibration points stored.
    points: usize,
    /// Whether the version has the boot counter.
    boots: bool,
    /// Whether the version has the preferences byte.
    preferences: bool,
}

impl Layout {
    /// Version 1: four points, no boot counter.
    const V1: Self = Self { points: 4, boots: false, preferences: false };
    /// Version 2: the boot counter, no preferences.
    const V2: Self = Self { points: CALIBRATION_POINTS, boots: true, preferences: false };
    /// Today's version.
    const CURRENT: Self = Self { points: CALIBRATION_POINTS, boots: true, preferences: true };

    /// Offset of the counters.
    const fn counters(self) -> usize {
        OFFSET_CALIBRATION.saturating_add(1).saturating_add(self.points.saturating_mul(8))
    }

    /// Offset of the reserved bytes (after the counters and the preferences).
    const fn reserved(self) -> usize {
        self.counters()
            .saturating_add(if self.boots { 12 } else { 8 })
            .saturating_add(if self.preferences { 1 } else { 0 })
    }

    /// Whether the fields end before the CRC.
    const fn fits(self) -> bool {
        self.reserved() <= OFFSET_CRC
    }
}

const _: () = assert!(
    Layout::CURRENT.fits() && Layout::V2.fits() && Layout::V1.fits() && RECORD_LEN <= 256,
    "layout overflows"
);

/// Whether today's layout would hold a calibration of `points` points (the record's side of
/// "another point count is one constant": five fit, six would not).
#[must_use]
pub const fn layout_fits(points: usize) -> bool {
    Layout { points, boots: true, preferences: true }.fits()
}

/// A unit's code in the record (0 kg, 1 lb).
const fn unit_code(unit: Unit) -> u8 {
    match unit {
        Unit::Kilograms => 0,
        Unit::Pounds => 1,
    }
}

/// The unit of a code in the record.
const fn unit_from_code(code: u8) -> Option<Unit> {
    match code {
        0 => Some(Unit::Kilograms),
        1 => Some(Unit::Pounds),
        _ => None,
    }
}

/// A settings block (see the module docs).
fn encode_settings(settings: Settings, w: &mut Writer<'_>) {
    let set_point = settings.set_point();
    w.u16(set_point.tenths());
    w.u8(unit_code(set_point.unit()));
    w.u8(settings.speed().get());
    w.u8(settings.pre_stretch().percent());
    w.u8(settings.knot().percent());
}

/// A settings block, validated through the settings' own constructors.
fn decode_settings(r: &mut Reader<'_>) -> Result<Settings, StoreError> {
    let tenths = r.u16();
    let unit = unit_from_code(r.u8());
    let (speed, pre, knot) = (r.u8(), r.u8(), r.u8());
    let unit = unit.ok_or(StoreError::InvalidSettings)?;
    let set_point = SetPoint::new(unit, tenths).map_err(|_| StoreError::InvalidSettings)?;
    Settings::new(set_point, speed, pre, knot).map_err(|_| StoreError::InvalidSettings)
}

/// The lifetime counters.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Counters {
    /// Completed pulls (reached tension and released).
    pub pulls: u32,
    /// String drawn through the machine, millimetres.
    pub string_used_mm: u32,
    /// Power-ups (counted from format version 2 on).
    pub boots: u32,
}

/// Why a stored record was not used.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum StoreError {
    /// Fewer than [`RECORD_LEN`] bytes.
    TooShort,
    /// The magic bytes are wrong: the flash holds no record (erased or never written).
    NoRecord,
    /// A format version this code does not know.
    UnknownVersion,
    /// The checksum does not match: the record is corrupt (torn write, bit rot).
    CrcMismatch,
    /// A settings or preset field is out of range.
    InvalidSettings,
    /// The calibration block is malformed (a point count other than 0 and the build's, a
    /// version-1 flag other than 0/1, or points stored without a calibration).
    InvalidCalibration,
    /// A reserved byte is not zero (or a preferences bit this version does not define).
    ReservedNotZero,
}

/// Everything the machine persists.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Record {
    /// The settings the panel shows at power-up (the last ones used).
    pub settings: Settings,
    /// Presets P1–P9.
    pub presets: [Settings; PRESET_COUNT],
    /// The last accepted calibration, if any.
    pub calibration: Option<CalibrationPoints>,
    /// Lifetime counters.
    pub counters: Counters,
    /// Beeper and constant-pull preferences.
    pub preferences: Preferences,
}

impl Record {
    /// The record's bytes: see the module docs for the layout.
    #[must_use]
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut out = [0u8; RECORD_LEN];
        let mut w = Writer { bytes: &mut out, at: 0 };
        w.bytes_from(&MAGIC);
        w.u8(FORMAT_VERSION);
        w.u8(0);
        encode_settings(self.settings, &mut w);
        for preset in &self.presets {
            encode_settings(*preset, &mut w);
        }
        match &self.calibration {
            Some(points) => {
                w.u8(u8::try_from(CALIBRATION_POINTS).unwrap_or(u8::MAX));
                for point in points {
                    w.i32(point.raw.to_bits());
                    w.i32(point.reference.to_bits());
                }
            }
            None => {
                w.u8(0);
                w.skip(CALIBRATION_POINTS.saturating_mul(8));
            }
        }
        w.u32(self.counters.pulls);
        w.u32(self.counters.string_used_mm);
        w.u32(self.counters.boots);
        w.u8(self.preferences.flags());
        // The reserved bytes stay zero; the CRC covers everything before it.
        let body = out.first_chunk::<OFFSET_CRC>().copied().unwrap_or([0; OFFSET_CRC]);
        let mut w = Writer { bytes: &mut out, at: OFFSET_CRC };
        w.u32(checksum(&body));
        out
    }

    /// The record in `bytes` (the first [`RECORD_LEN`] of them), fully validated; a
    /// version-1 record is migrated (see the module docs).
    ///
    /// # Errors
    /// A [`StoreError`] naming the first problem found, checked in the order: length, magic,
    /// version, CRC, reserved bytes, fields.
    pub fn decode(bytes: &[u8]) -> Result<Self, StoreError> {
        Self::decode_version(bytes).map(|(record, _)| record)
    }

    /// [`Record::decode`], with the format version the bytes were written in.
    ///
    /// # Errors
    /// As [`Record::decode`].
    pub fn decode_version(bytes: &[u8]) -> Result<(Self, u8), StoreError> {
        let bytes: &[u8; RECORD_LEN] = bytes.first_chunk().ok_or(StoreError::TooShort)?;
        let mut r = Reader { bytes, at: 0 };
        if r.u8() != MAGIC[0] || r.u8() != MAGIC[1] {
            return Err(StoreError::NoRecord);
        }
        let version = r.u8();
        if version != FORMAT_V1 && version != FORMAT_V2 && version != FORMAT_VERSION {
            return Err(StoreError::UnknownVersion);
        }
        let body = bytes.first_chunk::<OFFSET_CRC>().ok_or(StoreError::TooShort)?;
        let stored = Reader { bytes, at: OFFSET_CRC }.u32();
        if checksum(body) != stored {
            return Err(StoreError::CrcMismatch);
        }
        // Each version's reserved bytes from a constant offset (a model checker then reads
        // them at known places rather than at an offset that depends on the version byte).
        let tail_is_zero = match version {
            FORMAT_V1 => zero_from::<{ Layout::V1.reserved() }>(bytes),
            FORMAT_V2 => zero_from::<{ Layout::V2.reserved() }>(bytes),
            _ => zero_from::<{ Layout::CURRENT.reserved() }>(bytes),
        };
        if r.u8() != 0 || !tail_is_zero {
            return Err(StoreError::ReservedNotZero);
        }
        let settings = decode_settings(&mut r)?;
        let mut presets = [Settings::DEFAULT; PRESET_COUNT];
        for preset in &mut presets {
            *preset = decode_settings(&mut r)?;
        }
        let calibration = if version == FORMAT_V1 {
            read_v1_calibration(&mut r)?
        } else {
            read_calibration(&mut r)?
        };
        let pulls = r.u32();
        let string_used_mm = r.u32();
        let boots = if version == FORMAT_V1 { 0 } else { r.u32() };
        let counters = Counters { pulls, string_used_mm, boots };
        // Version 2 held zero here (reserved, checked above): the default preferences.
        let preferences = Preferences::from_flags(r.u8()).ok_or(StoreError::ReservedNotZero)?;
        Ok((Self { settings, presets, calibration, counters, preferences }, version))
    }

    /// Whether every settings field satisfies its invariant (true of every decoded record
    /// and of every record the machine builds).
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.settings.is_valid() && self.presets.iter().all(|preset| preset.is_valid())
    }
}

/// Whether the record's bytes from `START` up to the CRC are all zero.
fn zero_from<const START: usize>(bytes: &[u8; RECORD_LEN]) -> bool {
    bytes.get(START..OFFSET_CRC).is_some_and(|tail| tail.iter().all(|byte| *byte == 0))
}

/// `N` stored points, and whether every one of them is all zero bytes.
fn read_points<const N: usize>(r: &mut Reader<'_>) -> ([CalibrationPoint; N], bool) {
    let mut points = [CalibrationPoint::default(); N];
    let mut all_zero = true;
    for point in &mut points {
        let (raw, reference) = (r.i32(), r.i32());
        all_zero &= raw == 0 && reference == 0;
        *point =
            CalibrationPoint { raw: Kgf::from_bits(raw), reference: Kgf::from_bits(reference) };
    }
    (points, all_zero)
}

/// Today's calibration block: the point count (0 or [`CALIBRATION_POINTS`]) and the points.
fn read_calibration(r: &mut Reader<'_>) -> Result<Option<CalibrationPoints>, StoreError> {
    let count = usize::from(r.u8());
    let (points, all_zero) = read_points::<CALIBRATION_POINTS>(r);
    match count {
        0 if all_zero => Ok(None),
        CALIBRATION_POINTS => Ok(Some(points)),
        _ => Err(StoreError::InvalidCalibration),
    }
}

/// Version 1's calibration block: a 0/1 flag and four points. The points are kept when this
/// build also calibrates on four; with another count they cannot be used and are dropped
/// (the machine then asks for a calibration, and the settings are kept).
fn read_v1_calibration(r: &mut Reader<'_>) -> Result<Option<CalibrationPoints>, StoreError> {
    let flag = r.u8();
    let (points, all_zero) = read_points::<4>(r);
    match flag {
        0 if all_zero => Ok(None),
        1 => Ok(CalibrationPoints::try_from(points.as_slice()).ok()),
        _ => Err(StoreError::InvalidCalibration),
    }
}

/// Writes little-endian fields into a record at a running offset. Offsets are constants of
/// the layout, so every write lands on a fixed byte (out-of-range writes are dropped, which
/// the layout's `const` assertion rules out).
struct Writer<'a> {
    bytes: &'a mut [u8; RECORD_LEN],
    at: usize,
}

impl Writer<'_> {
    fn u8(&mut self, value: u8) {
        if let Some(slot) = self.bytes.get_mut(self.at) {
            *slot = value;
        }
        self.at = self.at.saturating_add(1);
    }

    fn bytes_from(&mut self, values: &[u8]) {
        for &value in values {
            self.u8(value);
        }
    }

    fn u16(&mut self, value: u16) {
        self.bytes_from(&value.to_le_bytes());
    }

    fn u32(&mut self, value: u32) {
        self.bytes_from(&value.to_le_bytes());
    }

    fn i32(&mut self, value: i32) {
        self.bytes_from(&value.to_le_bytes());
    }

    fn skip(&mut self, count: usize) {
        self.at = self.at.saturating_add(count);
    }
}

/// Reads little-endian fields from a record at a running offset (reads past the end give
/// zero, which the layout's `const` assertion rules out).
struct Reader<'a> {
    bytes: &'a [u8; RECORD_LEN],
    at: usize,
}

impl Reader<'_> {
    fn u8(&mut self) -> u8 {
        let value = self.bytes.get(self.at).copied().unwrap_or(0);
        self.at = self.at.saturating_add(1);
        value
    }

    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    fn i32(&mut self) -> i32 {
        i32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sense::calibration::CALIBRATION_TARGETS;

    fn settings(unit: Unit, tenths: u16, speed: u8, pre: u8, knot: u8) -> Settings {
        let made =
            SetPoint::new(unit, tenths).and_then(|point| Settings::new(point, speed, pre, knot));
        let Ok(settings) = made else { panic!("{unit:?} {tenths} must be a valid setting") };
        settings
    }

    fn sample() -> Record {
        let mut record =
            Record { settings: settings(Unit::Pounds, 550, 7, 10, 15), ..Record::default() };
        record.presets[3] = settings(Unit::Kilograms, 235, 3, 0, 0);
        let mut index = 0;
        record.calibration = Some(CALIBRATION_TARGETS.map(|target| {
            index += 1;
            let raw = target.saturating_add(Kgf::from_tenths(index - 3));
            CalibrationPoint { raw, reference: target }
        }));
        record.counters = Counters { pulls: 1234, string_used_mm: 987_654, boots: 42 };
        record
    }

    #[test]
    fn round_trips() {
        let record = sample();
        assert_eq!(Record::decode(&record.encode()), Ok(record));
        assert_eq!(Record::decode(&Record::default().encode()), Ok(Record::default()));
        // An uncalibrated machine's counters sit behind the empty calibration block, which the
        // writer skips: they must land where the reader looks.
        let uncalibrated = Record { calibration: None, ..sample() };
        assert_eq!(Record::decode(&uncalibrated.encode()), Ok(uncalibrated));
        // What the decoder accepts satisfies the record's invariant.
        for record in [sample(), uncalibrated, Record::default()] {
            assert!(record.is_valid(), "{record:?}");
        }
    }

    #[test]
    fn every_single_bit_flip_is_detected() {
        let bytes = sample().encode();
        for index in 0..RECORD_LEN {
            for bit in 0..8 {
                let mut corrupt = bytes;
                corrupt[index] ^= 1 << bit;
                assert!(Record::decode(&corrupt).is_err(), "byte {index} bit {bit}");
            }
        }
    }

    #[test]
    fn checksum_is_crc32c() {
        // The CRC-32/ISCSI check value (the catalogue's "123456789" known answer).
        assert_eq!(checksum(b"123456789"), 0xE306_9283);
        assert_eq!(checksum(b""), 0);
    }

    #[test]
    fn erased_flash_is_no_record() {
        assert_eq!(Record::decode(&[0xFF; RECORD_LEN]), Err(StoreError::NoRecord));
        assert_eq!(Record::decode(&[0; 10]), Err(StoreError::TooShort));
    }

    #[test]
    fn unknown_version_is_refused_before_the_crc() {
        for version in [0, 4, 0xFF] {
            let mut bytes = sample().encode();
            bytes[2] = version;
            assert_eq!(Record::decode(&bytes), Err(StoreError::UnknownVersion));
        }
    }

    #[test]
    fn out_of_range_fields_are_refused_even_with_a_good_crc() {
        let mut bytes = sample().encode();
        bytes[OFFSET_SETTINGS + 3] = 10; // speed 10
        let crc = checksum(&bytes[..OFFSET_CRC]).to_le_bytes();
        bytes[OFFSET_CRC..].copy_from_slice(&crc);
        assert_eq!(Record::decode(&bytes), Err(StoreError::InvalidSettings));
    }

    /// `bytes` with the CRC recomputed.
    fn resealed(mut bytes: [u8; RECORD_LEN]) -> [u8; RECORD_LEN] {
        let crc = checksum(&bytes[..OFFSET_CRC]).to_le_bytes();
        bytes[OFFSET_CRC..].copy_from_slice(&crc);
        bytes
    }

    /// `record` as format version 1 wrote it: version 1, the calibration flag 1, no boot
    /// counter (its bytes were reserved, zero).
    fn version_1(record: &Record) -> [u8; RECORD_LEN] {
        let mut bytes = record.encode();
        bytes[2] = FORMAT_V1;
        if record.calibration.is_some() {
            bytes[OFFSET_CALIBRATION] = 1;
        }
        // The boot counter and the preferences were reserved bytes, zero.
        bytes[Layout::V1.reserved()..OFFSET_CRC].fill(0);
        resealed(bytes)
    }

    /// `record` as format version 2 wrote it: version 2, no preferences byte (reserved, zero).
    fn version_2(record: &Record) -> [u8; RECORD_LEN] {
        let mut bytes = record.encode();
        bytes[2] = FORMAT_V2;
        bytes[Layout::V2.reserved()..OFFSET_CRC].fill(0);
        resealed(bytes)
    }

    #[test]
    fn a_version_2_record_is_migrated_with_the_default_preferences() {
        let record =
            Record { preferences: Preferences { beeper: false, constant_pull: false }, ..sample() };
        let old = version_2(&record);
        let migrated = Record { preferences: Preferences::DEFAULT, ..record };
        assert_eq!(Record::decode_version(&old), Ok((migrated, FORMAT_V2)));
        // Version 2's byte 109 was reserved: set, the record is refused, not misread.
        let mut reserved = old;
        reserved[Layout::V2.reserved()] = 2;
        assert_eq!(Record::decode(&resealed(reserved)), Err(StoreError::ReservedNotZero));
    }

    #[test]
    fn preferences_round_trip_and_unknown_bits_are_refused() {
        for beeper in [false, true] {
            for constant_pull in [false, true] {
                let preferences = Preferences { beeper, constant_pull };
                assert_eq!(Preferences::from_flags(preferences.flags()), Some(preferences));
                let record = Record { preferences, ..sample() };
                assert_eq!(Record::decode(&record.encode()), Ok(record));
            }
        }
        assert_eq!(Preferences::DEFAULT.flags(), 0, "zero is the default: version 2's byte");
        let at = Layout::V2.reserved();
        for flags in 4..=u8::MAX {
            assert_eq!(Preferences::from_flags(flags), None, "{flags}");
            let mut bytes = sample().encode();
            bytes[at] = flags;
            assert_eq!(Record::decode(&resealed(bytes)), Err(StoreError::ReservedNotZero));
        }
    }

    #[test]
    fn a_version_1_record_is_migrated_not_wiped() {
        let record = sample();
        let old = version_1(&record);
        let migrated = Record { counters: Counters { boots: 0, ..record.counters }, ..record };
        assert_eq!(Record::decode_version(&old), Ok((migrated, FORMAT_V1)));
        assert_eq!(Record::decode_version(&record.encode()), Ok((record, FORMAT_VERSION)));
        let empty = Record::default();
        assert_eq!(Record::decode(&version_1(&empty)), Ok(empty));
        // Version 1's own rules still hold: a flag other than 0/1, a reserved byte set.
        let mut bad_flag = old;
        bad_flag[OFFSET_CALIBRATION] = 2;
        assert_eq!(Record::decode(&resealed(bad_flag)), Err(StoreError::InvalidCalibration));
        let mut reserved = old;
        reserved[Layout::V1.reserved()] = 1;
        assert_eq!(Record::decode(&resealed(reserved)), Err(StoreError::ReservedNotZero));
    }

    #[test]
    fn the_calibration_count_must_be_none_or_this_builds() {
        let bytes = sample().encode();
        for count in 0..=u8::MAX {
            let mut changed = bytes;
            changed[OFFSET_CALIBRATION] = count;
            let decoded = Record::decode(&resealed(changed));
            if usize::from(count) == CALIBRATION_POINTS {
                assert_eq!(decoded, Ok(sample()));
            } else {
                // Points stored under a count of 0, or any other count: malformed.
                assert_eq!(decoded, Err(StoreError::InvalidCalibration), "{count}");
            }
        }
    }

    /// Points stored under "no calibration" are a malformed block in either format, whichever
    /// byte of a point (raw or reference) is set.
    #[test]
    fn stray_calibration_bytes_are_refused_in_both_formats() {
        let empty = Record::default();
        let points = OFFSET_CALIBRATION + 1..Layout::CURRENT.counters();
        for index in points {
            let mut today = empty.encode();
            today[index] = 1;
            assert_eq!(Record::decode(&resealed(today)), Err(StoreError::InvalidCalibration));
            let mut old = version_1(&empty);
            old[index] = 1;
            assert_eq!(Record::decode(&resealed(old)), Err(StoreError::InvalidCalibration));
        }
    }

    #[test]
    fn five_calibration_points_fit_the_record() {
        assert!(layout_fits(CALIBRATION_POINTS));
        assert!(layout_fits(5), "a five-point calibration is one constant away");
        assert!(!layout_fits(6), "six would need a longer record or fewer counters");
    }
}

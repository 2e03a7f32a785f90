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
//! [`StoreError`], never a panic — the machine then runs on [`Record::default`] (with the
//! counters of a newer format's record, see below) and shows the error's code once.
//!
//! Every settings field is validated when decoded, through the same constructors the panel
//! uses ([`crate::settings`]), so a record that passes [`Record::decode`] satisfies every
//! invariant the machine relies on and the per-tick path never re-checks it. The calibration
//! points are decoded as stored and validated by
//! [`crate::sense::calibration::Calibration::new`] when the machine starts: an implausible
//! calibration is then dropped with a notice, and the settings beside it are kept.
//!
//! # Layout (format version 4, little-endian, [`RECORD_LEN`] = 224 bytes)
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 2 | magic `b"TT"` |
//! | 2 | 1 | format version (4) |
//! | 3 | 1 | the record's length in bytes (224; versions 1–3: reserved, 0, and 128 bytes) |
//! | 4 | 6 | current settings (see below) |
//! | 10 | 54 | presets 1–9, 6 bytes each |
//! | 64 | 1 | calibration: number of points (0: none; else 4) |
//! | 65 | 8 × 4 | calibration: (raw reading, reference reading) per point, each Q15.16 kgf bits (`i32`) |
//! | 97 | 4 | counter: pulls (`u32`) |
//! | 101 | 4 | counter: string used, millimetres (`u32`) |
//! | 105 | 4 | counter: boots (`u32`) |
//! | 109 | 1 | preferences: bit 0 beeper off, bit 1 constant pull off; other bits 0 |
//! | 110 | 1 | the load cell's zero at calibration: 1 stored, 0 not |
//! | 111 | 4 | that zero, volts, Q15.16 bits (`i32`; 0 when not stored) |
//! | 115 | 4 | the pull counter when the calibration was accepted (`u32`; 0 when not stored): the calibration's age in pulls |
//! | 119 | 3 × 22 | fault history, the latest first ([`crate::machine::snapshot`]; an empty slot all 0) |
//! | 185 | 2 | the drivetrain's motor test at commissioning, ms (`u16`; 0: none yet; [`crate::machine::wear`]) |
//! | 187 | 2 | the motor test's trend since, ms (`u16`) |
//! | 189 | to 220 | reserved, 0 |
//! | 220 | 4 | CRC-32/ISCSI of bytes 0..220 |
//!
//! A settings block is: set point in tenths of its unit (`u16`), unit (0 kg, 1 lb), speed
//! (1–9), pre-stretch percent (0–30), knot percent (0–20).
//!
//! Reserved bytes must be zero in every version this code writes or migrates, so a reader
//! never misreads a newer record as an older one.
//!
//! # Format versions and the bump rule
//!
//! A past format never changes: every version's layout is written here as literals
//! (`Layout::V1` … `Layout::V4`; versions 1–3: four points, counters at 97, 128 bytes, CRC at
//! 124), never computed from a constant that a later build could change. A format change
//! follows one rule:
//!
//! 1. **Any change to today's layout is a new version.** The version byte goes up by one,
//!    today's layout stays here as the literal it is, and [`Record::decode`] gets a migration
//!    from it with a test that decodes a record written in it. This includes a calibration of
//!    another point count ([`CALIBRATION_POINTS`]): a `const` assertion refuses to build one
//!    until its format is written.
//! 2. **The new version appends.** Its new fields go after the last field of the previous
//!    format (in its reserved bytes, or by lengthening the record, up to [`MAX_RECORD_LEN`]),
//!    and byte 3 says the new length. No field of an earlier format ever moves or changes its
//!    meaning — in particular the counters stay at 97 (pulls), 101 (string used) and 105
//!    (boots), where every format has had them (boots since version 2); more calibration
//!    points keep the first four where they are and put the others after today's fields. A
//!    change that cannot append is a new magic, not a version.
//!
//! Because of (2), a record from a **newer** format (version above [`FORMAT_VERSION`], with
//! byte 3 a length from [`RECORD_LEN`] to [`MAX_RECORD_LEN`] and its CRC at that length
//! less 4) is read as far as this code knows it: settings, presets, calibration, counters and
//! fault history are kept, and the unknown tail is ignored (the machine then writes the record
//! back in its own format). When a field this code knows holds a value it does not accept (a
//! fault number, a setting or a preference bit that only the newer firmware has), the record
//! is refused with [`StoreError::NewerFormat`], which carries the record's counters: the
//! machine starts from the defaults with the store notice, and the counters kept. A newer
//! record's counters are therefore never lost to a firmware that is older than the record.
//!
//! # Migration
//!
//! Format version 1 had no boot counter and a calibration flag (0/1) where later versions have
//! the point count; version 2 had no preferences byte (it was reserved, so zero: the default
//! preferences); version 3 had neither the zero at calibration nor the fault history and was
//! 128 bytes long. Their other fields lie where version 4 has them.
//! [`Record::decode`] reads a version 1–3 record into today's [`Record`] (boots 0 for version
//! 1, the default preferences for 1 and 2, no zero at calibration and an empty fault history
//! for all three) instead of refusing it, and [`Record::decode_version`] says which format the
//! bytes were in. The machine writes the record back in version 4 soon after every boot (it
//! counts the boot), so a migrated record is rewritten without the operator doing anything.

use crc::{CRC_32_ISCSI, Crc};

use crate::machine::snapshot::{FAULT_HISTORY, FaultSnapshot, SNAPSHOT_LEN};
use crate::machine::wear::DrivetrainTrend;
use crate::sense::calibration::{CALIBRATION_POINTS, CalibrationPoint, CalibrationPoints};
use crate::settings::{Preferences, SetPoint, Settings, Unit};
use crate::units::{Kgf, Volts};

/// Size of an encoded [`Record`] in bytes (format version 4).
pub const RECORD_LEN: usize = 224;

/// Size of a record of format versions 1–3.
pub const LEGACY_LEN: usize = 128;

/// The longest record a newer format may write (the firmware's store holds 248 bytes).
pub const MAX_RECORD_LEN: usize = 248;

/// The bytes a newer format's record shares with today's: everything before today's reserved
/// bytes (the version and length bytes aside).
pub const KNOWN_LEN: usize = Layout::CURRENT.reserved;

/// The first two bytes of every record.
pub const MAGIC: [u8; 2] = *b"TT";

/// The format version this code writes (it also reads [`FORMAT_V1`], [`FORMAT_V2`] and
/// [`FORMAT_V3`], migrating them, and the known part of any newer version).
pub const FORMAT_VERSION: u8 = 4;

/// The third format version: 128 bytes, no zero at calibration, no fault history.
pub const FORMAT_V3: u8 = 3;

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
/// Where the counters start in every format: pulls, string used, then (from version 2)
/// boots. A format never moves them (the bump rule).
const OFFSET_COUNTERS: usize = 97;
const OFFSET_CRC: usize = RECORD_LEN - 4;
const LEGACY_CRC: usize = LEGACY_LEN - 4;

/// Where the fields after the presets lie in one format version.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Layout {
    /// The record's length (its CRC is the last four bytes).
    len: usize,
    /// Calibration points stored.
    points: usize,
    /// Offset of the counters.
    counters: usize,
    /// Whether the version has the boot counter.
    boots: bool,
    /// Whether the version has the preferences byte.
    preferences: bool,
    /// Whether the version has the zero at calibration and the fault history.
    history: bool,
    /// Offset of the reserved bytes (after the last field).
    reserved: usize,
}

impl Layout {
    /// Version 1, frozen (a past format never changes): four points, no boot counter, 128
    /// bytes.
    const V1: Self = Self {
        len: 128,
        points: 4,
        counters: 97,
        boots: false,
        preferences: false,
        history: false,
        reserved: 105,
    };
    /// Version 2, frozen: the boot counter, no preferences.
    const V2: Self = Self { boots: true, reserved: 109, ..Self::V1 };
    /// Version 3, frozen: the preferences byte.
    const V3: Self = Self { preferences: true, reserved: 110, ..Self::V2 };
    /// Version 4, frozen: the zero at calibration, the fault history and the drivetrain's
    /// trend after the preferences, 224 bytes.
    const V4: Self = Self {
        len: 224,
        points: 4,
        counters: 97,
        boots: true,
        preferences: true,
        history: true,
        reserved: 189,
    };
    /// Today's format: version 4.
    const CURRENT: Self = Self::V4;

    /// Today's fields around a calibration of `points` points, in a record of today's length:
    /// how much room another point count would take (its format would place the points after
    /// four differently, see the bump rule, but in the same number of bytes).
    const fn derived(points: usize) -> Self {
        let counters =
            OFFSET_CALIBRATION.saturating_add(1).saturating_add(points.saturating_mul(8));
        let reserved = counters
            .saturating_add(12 + 1 + 5 + 4)
            .saturating_add(FAULT_HISTORY.saturating_mul(SNAPSHOT_LEN))
            .saturating_add(4);
        Self {
            len: RECORD_LEN,
            points,
            counters,
            boots: true,
            preferences: true,
            history: true,
            reserved,
        }
    }

    /// The layout as the derivation gives it for a version's own point count and fields (the
    /// frozen literals must agree with it: a test checks).
    #[cfg(test)]
    const fn derived_legacy(points: usize, boots: bool, preferences: bool) -> Self {
        let counters =
            OFFSET_CALIBRATION.saturating_add(1).saturating_add(points.saturating_mul(8));
        let reserved = counters
            .saturating_add(if boots { 12 } else { 8 })
            .saturating_add(if preferences { 1 } else { 0 });
        Self { len: LEGACY_LEN, points, counters, boots, preferences, history: false, reserved }
    }

    /// Whether the fields end before the CRC.
    const fn fits(self) -> bool {
        self.reserved.saturating_add(4) <= self.len && self.len <= MAX_RECORD_LEN
    }
}

// Another point count is another record format (the bump rule in the module docs): today's
// layout, version 4, holds four points.
const _: () = assert!(
    CALIBRATION_POINTS == Layout::CURRENT.points,
    "another calibration point count is a new record format: see store.rs's bump rule"
);

// The counters sit where every format has had them, so a newer record never loses them.
const _: () = assert!(
    Layout::V1.counters == OFFSET_COUNTERS
        && Layout::V2.counters == OFFSET_COUNTERS
        && Layout::V3.counters == OFFSET_COUNTERS
        && Layout::V4.counters == OFFSET_COUNTERS
        && Layout::CURRENT.len == RECORD_LEN,
    "a field of a past format moved"
);

const _: () = assert!(
    Layout::CURRENT.fits()
        && Layout::V3.fits()
        && Layout::V2.fits()
        && Layout::V1.fits()
        && RECORD_LEN <= 255
        && MAX_RECORD_LEN <= 255,
    "layout overflows"
);

/// Whether a record of today's length has room for today's fields beside a calibration of
/// `points` points (up to seven fit, eight would not). Another count is still another
/// format: see the bump rule in the module docs.
#[must_use]
pub const fn layout_fits(points: usize) -> bool {
    Layout::derived(points).fits()
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
    /// Fewer bytes than the shortest record ([`LEGACY_LEN`]), or than the record's format
    /// holds.
    TooShort,
    /// The magic bytes are wrong: the flash holds no record (erased or never written).
    NoRecord,
    /// A format version this code does not know (0), or a newer one whose stated length is
    /// shorter than today's or longer than [`MAX_RECORD_LEN`].
    UnknownVersion,
    /// The checksum does not match: the record is corrupt (torn write, bit rot).
    CrcMismatch,
    /// A settings or preset field is out of range.
    InvalidSettings,
    /// The calibration block is malformed (a point count other than 0 and the build's, a
    /// version-1 flag other than 0/1, or points stored without a calibration).
    InvalidCalibration,
    /// A reserved byte is not zero (or a preferences bit this version does not define, or a
    /// version-4 length byte other than [`RECORD_LEN`]).
    ReservedNotZero,
    /// The zero at calibration's flag is not 0/1, or a zero or a pull count is stored under
    /// flag 0.
    InvalidZero,
    /// A fault snapshot's field is out of its range.
    InvalidSnapshot,
    /// A record of a newer format, intact (its CRC matches), whose fields this code knows
    /// hold a value it does not accept — one only the newer format has (a fault number, a
    /// setting's range, a preference bit). It carries the record's counters, which every
    /// format keeps in the same place, for the machine to keep.
    NewerFormat(Counters),
}

impl StoreError {
    /// The counters the refused record still gives the machine ([`StoreError::NewerFormat`]'s;
    /// `None` for every other error: nothing in the bytes can be trusted).
    #[must_use]
    pub const fn kept_counters(self) -> Option<Counters> {
        match self {
            Self::NewerFormat(counters) => Some(counters),
            _ => None,
        }
    }
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
    /// The load cell's zero in use when the calibration was accepted (the drift watch's
    /// reference for the zero's movement since calibration); `None` for a calibration
    /// migrated from a format that did not keep it.
    pub calibration_zero: Option<Volts>,
    /// The pull counter when the calibration was accepted (0 with no `calibration_zero`): see
    /// [`Record::calibration_age`].
    pub calibration_pulls: u32,
    /// The last faults with what latched them, the latest first.
    pub faults: [Option<FaultSnapshot>; FAULT_HISTORY],
    /// The drivetrain's drag trend: the motor test's time at commissioning and since.
    pub drivetrain: DrivetrainTrend,
}

impl Record {
    /// The record's bytes: see the module docs for the layout.
    #[must_use]
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut out = [0u8; RECORD_LEN];
        let mut w = Writer { bytes: &mut out, at: 0 };
        self.write(&mut w, Layout::CURRENT, FORMAT_VERSION);
        // The reserved bytes stay zero; the CRC covers everything before it.
        let crc = checksum(out.get(..OFFSET_CRC).unwrap_or(&[]));
        Writer { bytes: &mut out, at: OFFSET_CRC }.u32(crc);
        out
    }

    /// The record as format `version` 1–3 wrote it (the fields it did not have dropped; a
    /// calibration of another point count than those versions' four dropped too), or `None`
    /// for any other version: what the migration tests and proofs compare with.
    #[must_use]
    pub fn encode_legacy(&self, version: u8) -> Option<[u8; LEGACY_LEN]> {
        let mut out = [0u8; LEGACY_LEN];
        self.write_legacy(version, &mut out).then_some(out)
    }

    /// [`Record::encode_legacy`] into `out`; false (and `out` untouched) for a version other
    /// than 1–3. (A model checker reads the bytes in place: CBMC 6.6 mishandles an array of
    /// more than 64 elements inside an enum such as `Option`.)
    pub fn write_legacy(&self, version: u8, out: &mut [u8; LEGACY_LEN]) -> bool {
        let layout = match version {
            FORMAT_V1 => Layout::V1,
            FORMAT_V2 => Layout::V2,
            FORMAT_V3 => Layout::V3,
            _ => return false,
        };
        *out = [0u8; LEGACY_LEN];
        let record = Self {
            calibration: self.calibration.filter(|_| CALIBRATION_POINTS == layout.points),
            ..*self
        };
        record.write(&mut Writer { bytes: out, at: 0 }, layout, version);
        if version == FORMAT_V1 && record.calibration.is_some() {
            if let Some(flag) = out.get_mut(OFFSET_CALIBRATION) {
                *flag = 1;
            }
        }
        let crc = checksum(out.get(..LEGACY_CRC).unwrap_or(&[])).to_le_bytes();
        Writer { bytes: out, at: LEGACY_CRC }.bytes_from(&crc);
        true
    }

    /// Writes the fields `layout` has, from the version byte on.
    fn write(&self, w: &mut Writer<'_>, layout: Layout, version: u8) {
        w.bytes_from(&MAGIC);
        w.u8(version);
        w.u8(if layout.history { u8::try_from(layout.len).unwrap_or(0) } else { 0 });
        encode_settings(self.settings, w);
        for preset in &self.presets {
            encode_settings(*preset, w);
        }
        match &self.calibration {
            Some(points) if points.len() == layout.points => {
                w.u8(u8::try_from(layout.points).unwrap_or(u8::MAX));
                for point in points {
                    w.i32(point.raw.to_bits());
                    w.i32(point.reference.to_bits());
                }
            }
            _ => {
                w.u8(0);
                w.skip(layout.points.saturating_mul(8));
            }
        }
        w.u32(self.counters.pulls);
        w.u32(self.counters.string_used_mm);
        if layout.boots {
            w.u32(self.counters.boots);
        }
        if layout.preferences {
            w.u8(self.preferences.flags());
        }
        if layout.history {
            match self.calibration_zero {
                Some(zero) => {
                    w.u8(1);
                    w.i32(zero.to_bits());
                    w.u32(self.calibration_pulls);
                }
                None => {
                    w.u8(0);
                    w.i32(0);
                    w.u32(0);
                }
            }
            for slot in &self.faults {
                w.bytes_from(&FaultSnapshot::encode_slot(slot.as_ref()));
            }
            w.u16(self.drivetrain.commissioned_ms);
            w.u16(self.drivetrain.trend_ms);
        }
    }

    /// The record in `bytes`, fully validated; a version 1–3 record is migrated, a newer one
    /// read as far as this code knows it (see the module docs).
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
        if bytes.len() < LEGACY_LEN {
            return Err(StoreError::TooShort);
        }
        let header: &[u8; 4] = bytes.first_chunk().ok_or(StoreError::TooShort)?;
        let [m0, m1, version, length] = *header;
        if [m0, m1] != MAGIC {
            return Err(StoreError::NoRecord);
        }
        // One call per layout, each with its layout a constant: every offset and every loop
        // bound below is then a constant of its path (a model checker reads fixed places
        // rather than offsets that depend on the version byte).
        let record = match version {
            FORMAT_V1 => Self::decode_layout(bytes, Layout::V1, FORMAT_V1, length == 0, true)?,
            FORMAT_V2 => Self::decode_layout(bytes, Layout::V2, FORMAT_V2, length == 0, true)?,
            FORMAT_V3 => Self::decode_layout(bytes, Layout::V3, FORMAT_V3, length == 0, true)?,
            FORMAT_VERSION => {
                let stated = usize::from(length) == RECORD_LEN;
                Self::decode_layout(bytes, Layout::CURRENT, FORMAT_VERSION, stated, true)?
            }
            _ if version > FORMAT_VERSION => {
                // A newer format: today's fields at today's places, its own length and tail.
                let len = usize::from(length);
                if !(RECORD_LEN..=MAX_RECORD_LEN).contains(&len) {
                    return Err(StoreError::UnknownVersion);
                }
                let layout = Layout { len, ..Layout::CURRENT };
                match Self::decode_layout(bytes, layout, FORMAT_VERSION, true, false) {
                    Ok(record) => record,
                    // Not all of it, or not intact: nothing can be trusted.
                    Err(error @ (StoreError::TooShort | StoreError::CrcMismatch)) => {
                        return Err(error);
                    }
                    // Intact, with a value only the newer format knows: its counters stand.
                    Err(_) => return Err(StoreError::NewerFormat(read_counters(bytes))),
                }
            }
            _ => return Err(StoreError::UnknownVersion),
        };
        Ok((record, version))
    }

    /// The record in `bytes` as `layout` places its fields (read as format `version`: a
    /// newer one as today's), once its length, CRC and reserved bytes pass; `length_ok` is
    /// whether byte 3 is what the version states there, `reserved` whether the bytes after
    /// the fields must be zero (a newer version's tail is its own).
    fn decode_layout(
        bytes: &[u8],
        layout: Layout,
        version: u8,
        length_ok: bool,
        reserved: bool,
    ) -> Result<Self, StoreError> {
        let stored = bytes.get(..layout.len).ok_or(StoreError::TooShort)?;
        let (body, crc) = stored.split_at(layout.len.saturating_sub(4));
        let crc: [u8; 4] = crc.try_into().map_err(|_| StoreError::TooShort)?;
        if checksum(body) != u32::from_le_bytes(crc) {
            return Err(StoreError::CrcMismatch);
        }
        let tail_is_zero =
            !reserved || zero_between(body, layout.reserved, layout.len.saturating_sub(4));
        if !length_ok || !tail_is_zero {
            return Err(StoreError::ReservedNotZero);
        }
        let mut r = Reader { bytes: body, at: OFFSET_SETTINGS };
        let settings = decode_settings(&mut r)?;
        let mut presets = [Settings::DEFAULT; PRESET_COUNT];
        for preset in &mut presets {
            *preset = decode_settings(&mut r)?;
        }
        let calibration = match version {
            FORMAT_V1 => read_legacy_calibration(&mut r, true)?,
            FORMAT_V2 | FORMAT_V3 => read_legacy_calibration(&mut r, false)?,
            _ => read_calibration(&mut r)?,
        };
        let pulls = r.u32();
        let string_used_mm = r.u32();
        let boots = if layout.boots { r.u32() } else { 0 };
        let counters = Counters { pulls, string_used_mm, boots };
        let preferences = if layout.preferences {
            Preferences::from_flags(r.u8()).ok_or(StoreError::ReservedNotZero)?
        } else {
            Preferences::DEFAULT
        };
        let mut record =
            Self { settings, presets, calibration, counters, preferences, ..Self::default() };
        if layout.history {
            let flag = r.u8();
            let bits = r.i32();
            let pulls = r.u32();
            record.calibration_zero = match flag {
                0 if bits == 0 && pulls == 0 => None,
                1 => Some(Volts::from_bits(bits)),
                _ => return Err(StoreError::InvalidZero),
            };
            record.calibration_pulls = pulls;
            for slot in &mut record.faults {
                let mut bytes = [0u8; SNAPSHOT_LEN];
                for byte in &mut bytes {
                    *byte = r.u8();
                }
                *slot = FaultSnapshot::decode(&bytes).map_err(|_| StoreError::InvalidSnapshot)?;
            }
            record.drivetrain = DrivetrainTrend { commissioned_ms: r.u16(), trend_ms: r.u16() };
        }
        Ok(record)
    }

    /// Whether every settings field satisfies its invariant (true of every decoded record
    /// and of every record the machine builds).
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.settings.is_valid() && self.presets.iter().all(|preset| preset.is_valid())
    }

    /// Pulls since the calibration was accepted, when the record knows it (a calibration
    /// migrated from a format that did not stamp it: `None`; none at all: `None`).
    #[must_use]
    pub fn calibration_age(&self) -> Option<u32> {
        self.calibration_zero.map(|_| self.counters.pulls.saturating_sub(self.calibration_pulls))
    }

    /// Stamps the calibration just accepted with the load cell's `zero` in use and the pull
    /// counter (its age starts at zero).
    pub fn stamp_calibration(&mut self, zero: Volts) {
        self.calibration_zero = Some(zero);
        self.calibration_pulls = self.counters.pulls;
    }

    /// Puts `snapshot` at the head of the fault history, the oldest dropped.
    pub fn push_fault(&mut self, snapshot: FaultSnapshot) {
        let [latest, older, _] = self.faults;
        self.faults = [Some(snapshot), latest, older];
    }
}

/// The counters of a record of format 2 or later, at [`OFFSET_COUNTERS`].
fn read_counters(bytes: &[u8]) -> Counters {
    let mut r = Reader { bytes, at: OFFSET_COUNTERS };
    Counters { pulls: r.u32(), string_used_mm: r.u32(), boots: r.u32() }
}

/// Whether `body[start..end]` is all zero (an empty or out-of-range span is).
fn zero_between(body: &[u8], start: usize, end: usize) -> bool {
    body.get(start..end).is_none_or(|tail| tail.iter().all(|byte| *byte == 0))
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

/// Versions 1–3's calibration block: four points under a 0/1 flag (version 1, `flag`) or a
/// count of 0 or 4. The points are kept when this build also calibrates on four; with another
/// count they cannot be used and are dropped (the machine then asks for a calibration, and
/// the settings are kept).
fn read_legacy_calibration(
    r: &mut Reader<'_>,
    flag: bool,
) -> Result<Option<CalibrationPoints>, StoreError> {
    let count = r.u8();
    let (points, all_zero) = read_points::<4>(r);
    match (count, flag) {
        (0, _) if all_zero => Ok(None),
        (1, true) | (4, false) => Ok(CalibrationPoints::try_from(points.as_slice()).ok()),
        _ => Err(StoreError::InvalidCalibration),
    }
}

/// Writes little-endian fields into a record at a running offset. Offsets are constants of
/// the layout, so every write lands on a fixed byte (out-of-range writes are dropped, which
/// the layout's `const` assertion rules out).
struct Writer<'a> {
    bytes: &'a mut [u8],
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
    bytes: &'a [u8],
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
    use crate::drive::{Direction, DriveCommand, Duty};
    use crate::machine::MachineState;
    use crate::machine::fault::FaultCode;
    use crate::machine::snapshot::Latch;
    use crate::sense::calibration::CALIBRATION_TARGETS;
    use crate::units::Amps;

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
        record.stamp_calibration(Volts::from_milli(47));
        record.counters.pulls = 1300;
        record.push_fault(snapshot(FaultCode::Stall, 1_000));
        record.push_fault(snapshot(FaultCode::StringBreak, 2_000));
        record
    }

    fn snapshot(code: FaultCode, now_ms: u32) -> FaultSnapshot {
        FaultSnapshot::capture(&Latch {
            code,
            state: MachineState::Pulling,
            boots: 42,
            now_ms,
            tension: Kgf::from_tenths(201),
            current: Amps::from_milli(4_321),
            bus: Volts::from_milli(23_950),
            hall_steps: 12_345,
            command: DriveCommand::Drive {
                direction: Direction::Pull,
                duty: Duty::from_raw_clamped(30_000),
            },
        })
    }

    /// `record` without what versions 1–3 could not hold.
    fn as_legacy(record: &Record) -> Record {
        Record {
            calibration_zero: None,
            calibration_pulls: 0,
            faults: [None; FAULT_HISTORY],
            ..*record
        }
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
        let mut bytes = sample().encode();
        bytes[2] = 0;
        assert_eq!(Record::decode(&bytes), Err(StoreError::UnknownVersion));
        // A newer version must state a length from today's to the store's longest.
        for (version, length) in [(5, 0), (5, 223), (0xFF, 249), (9, 0xFF)] {
            let mut bytes = sample().encode();
            (bytes[2], bytes[3]) = (version, length);
            assert_eq!(Record::decode(&bytes), Err(StoreError::UnknownVersion), "{version}");
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
    /// counter (its bytes were reserved, zero), 128 bytes.
    fn version_1(record: &Record) -> [u8; LEGACY_LEN] {
        record.encode_legacy(FORMAT_V1).unwrap_or([0; LEGACY_LEN])
    }

    /// `record` as format version 2 wrote it: version 2, no preferences byte (reserved, zero).
    fn version_2(record: &Record) -> [u8; LEGACY_LEN] {
        record.encode_legacy(FORMAT_V2).unwrap_or([0; LEGACY_LEN])
    }

    /// `bytes` with the CRC at `len − 4` recomputed.
    fn resealed_at<const N: usize>(mut bytes: [u8; N]) -> [u8; N] {
        let crc = checksum(&bytes[..N - 4]).to_le_bytes();
        bytes[N - 4..].copy_from_slice(&crc);
        bytes
    }

    #[test]
    fn a_version_2_record_is_migrated_with_the_default_preferences() {
        let record =
            Record { preferences: Preferences { beeper: false, constant_pull: false }, ..sample() };
        let old = version_2(&record);
        let migrated = Record { preferences: Preferences::DEFAULT, ..as_legacy(&record) };
        assert_eq!(Record::decode_version(&old), Ok((migrated, FORMAT_V2)));
        // Version 2's byte 109 was reserved: set, the record is refused, not misread.
        let mut reserved = old;
        reserved[Layout::V2.reserved] = 2;
        assert_eq!(Record::decode(&resealed_at(reserved)), Err(StoreError::ReservedNotZero));
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
        let at = Layout::CURRENT.counters + 12;
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
        let migrated =
            Record { counters: Counters { boots: 0, ..record.counters }, ..as_legacy(&record) };
        assert_eq!(Record::decode_version(&old), Ok((migrated, FORMAT_V1)));
        assert_eq!(Record::decode_version(&record.encode()), Ok((record, FORMAT_VERSION)));
        let empty = Record::default();
        assert_eq!(Record::decode(&version_1(&empty)), Ok(empty));
        // Version 1's own rules still hold: a flag other than 0/1, a reserved byte set.
        let mut bad_flag = old;
        bad_flag[OFFSET_CALIBRATION] = 2;
        assert_eq!(Record::decode(&resealed_at(bad_flag)), Err(StoreError::InvalidCalibration));
        let mut reserved = old;
        reserved[Layout::V1.reserved] = 1;
        assert_eq!(Record::decode(&resealed_at(reserved)), Err(StoreError::ReservedNotZero));
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
        let points = OFFSET_CALIBRATION + 1..Layout::CURRENT.counters;
        for index in points {
            let mut today = empty.encode();
            today[index] = 1;
            assert_eq!(Record::decode(&resealed(today)), Err(StoreError::InvalidCalibration));
            let mut old = version_1(&empty);
            old[index] = 1;
            assert_eq!(Record::decode(&resealed_at(old)), Err(StoreError::InvalidCalibration));
        }
    }

    #[test]
    fn five_calibration_points_fit_the_record() {
        assert!(layout_fits(CALIBRATION_POINTS));
        assert!(layout_fits(5), "a five-point calibration is one constant away");
        assert!(layout_fits(7) && !layout_fits(8), "seven fit; eight need a longer record");
    }

    /// The frozen layouts of versions 1–4 are what the derivation gives for their four
    /// points, and today's is version 4's.
    #[test]
    fn the_frozen_layouts_are_the_derivation_at_four_points() {
        assert_eq!(Layout::V1, Layout::derived_legacy(4, false, false));
        assert_eq!(Layout::V2, Layout::derived_legacy(4, true, false));
        assert_eq!(Layout::V3, Layout::derived_legacy(4, true, true));
        assert_eq!((Layout::V3.counters, Layout::V3.reserved, Layout::V3.len), (97, 110, 128));
        assert_eq!(Layout::V4, Layout::derived(4));
        assert_eq!((Layout::V4.counters, Layout::V4.reserved, Layout::V4.len), (97, 189, 224));
        assert_eq!(Layout::CURRENT, Layout::V4);
        // Today's bytes are where the module's table says.
        let bytes = sample().encode();
        let at = |offset: usize| u32::from_le_bytes(bytes[offset..offset + 4].try_into().unwrap());
        assert_eq!((at(97), at(101), at(105)), (1300, 987_654, 42));
        assert_eq!(
            u16::from_le_bytes([bytes[185], bytes[186]]),
            sample().drivetrain.commissioned_ms
        );
    }

    /// REQ-STORE-06: a version-3 record (128 bytes) is migrated: everything it held is kept,
    /// the zero at calibration unknown and the fault history empty.
    #[test]
    fn a_version_3_record_is_migrated_with_an_empty_history() {
        let record = sample();
        let Some(old) = record.encode_legacy(FORMAT_V3) else { panic!("version 3 encodes") };
        assert_eq!(Record::decode_version(&old), Ok((as_legacy(&record), FORMAT_V3)));
        // Read from a longer buffer (the flash page) too.
        let mut page = [0xFF; 256];
        page[..LEGACY_LEN].copy_from_slice(&old);
        assert_eq!(Record::decode(&page), Ok(as_legacy(&record)));
        // Its byte 3 and its tail were reserved.
        for index in [3, Layout::V3.reserved, LEGACY_CRC - 1] {
            let mut reserved = old;
            reserved[index] = 1;
            assert_eq!(Record::decode(&resealed_at(reserved)), Err(StoreError::ReservedNotZero));
        }
        assert_eq!(Record::decode(&old[..LEGACY_LEN - 1]), Err(StoreError::TooShort));
        assert_eq!(Record::decode(&record.encode()[..RECORD_LEN - 1]), Err(StoreError::TooShort));
        assert_eq!(record.encode_legacy(FORMAT_VERSION), None);
    }

    /// `record`'s fields in a record of the next format, as long as a record can be (its own
    /// tail zero, its CRC not yet written).
    fn newer_than_today(record: &Record) -> [u8; MAX_RECORD_LEN] {
        let mut newer = [0u8; MAX_RECORD_LEN];
        newer[..OFFSET_CRC].copy_from_slice(&record.encode()[..OFFSET_CRC]);
        newer[2] = FORMAT_VERSION + 1;
        newer[3] = u8::try_from(MAX_RECORD_LEN).unwrap_or(0);
        newer
    }

    /// REQ-STORE-06: a record from a newer format — longer, its new fields in a tail this code
    /// does not know — keeps its settings, calibration, counters and fault history.
    #[test]
    fn a_newer_records_unknown_tail_never_loses_the_counters() {
        let record = sample();
        let mut newer = newer_than_today(&record);
        // Its own fields, in today's reserved bytes and beyond.
        for (index, byte) in newer.iter_mut().enumerate().skip(Layout::CURRENT.reserved) {
            *byte = u8::try_from(index % 251).unwrap_or(0) | 1;
        }
        let newer = resealed_at(newer);
        assert_eq!(Record::decode_version(&newer), Ok((record, FORMAT_VERSION + 1)));
        // Still CRC-checked over its own length.
        let mut corrupt = newer;
        corrupt[MAX_RECORD_LEN - 10] ^= 1;
        assert_eq!(Record::decode(&corrupt), Err(StoreError::CrcMismatch));
        // Its known fields are still validated: one this code does not accept leaves only the
        // counters (see the next test).
        let mut bad = newer;
        bad[OFFSET_SETTINGS + 3] = 10;
        let counters = Err(StoreError::NewerFormat(record.counters));
        assert_eq!(Record::decode(&resealed_at(bad)), counters);
        // A length of exactly today's is accepted too (a version that only changed meaning
        // of reserved bits would be a new magic, not a version).
        let mut same = record.encode();
        same[2] = FORMAT_VERSION + 3;
        assert_eq!(Record::decode_version(&resealed(same)), Ok((record, FORMAT_VERSION + 3)));
    }

    /// REQ-STORE-06: a newer record that is intact but holds a value this code does not
    /// accept in a field it knows (a fault number added later, a wider setting, a new
    /// preference bit) is refused with its counters, which the machine keeps.
    #[test]
    fn a_newer_record_this_code_cannot_read_still_gives_its_counters() {
        let record = sample();
        let newer = newer_than_today(&record);
        let first_snapshot = Layout::CURRENT.counters + 22;
        let kept = Err(StoreError::NewerFormat(record.counters));
        for (at, value) in [
            (first_snapshot, 99),      // a fault number this build does not know
            (OFFSET_SETTINGS + 3, 12), // speed 12
            (Layout::CURRENT.counters + 12, 0b100), // a third preference bit
            (OFFSET_CALIBRATION, 5),   // five points
        ] {
            let mut bytes = newer;
            bytes[at] = value;
            let decoded = Record::decode(&resealed_at(bytes));
            assert_eq!(decoded, kept, "byte {at} = {value}");
            assert_eq!(decoded.err().and_then(StoreError::kept_counters), Some(record.counters));
        }
        // Not intact: nothing is kept.
        let mut corrupt = newer;
        corrupt[first_snapshot] = 99;
        assert_eq!(Record::decode(&corrupt), Err(StoreError::CrcMismatch));
        // Today's format with the same value is corrupt, not newer: nothing is kept.
        let mut today = record.encode();
        today[first_snapshot] = 99;
        let refused = Record::decode(&resealed(today));
        assert_eq!(refused, Err(StoreError::InvalidSnapshot));
        assert_eq!(refused.err().and_then(StoreError::kept_counters), None);
    }

    /// REQ-STORE-06: the zero at calibration and the fault history round-trip; bad bytes in
    /// them are typed errors.
    #[test]
    fn the_zero_at_calibration_and_the_fault_history_round_trip_and_are_validated() {
        let mut record = sample();
        record.push_fault(snapshot(FaultCode::Overcurrent, 3_000));
        record.push_fault(snapshot(FaultCode::Overload, 4_000));
        assert_eq!(record.faults[0].map(|f| f.code), Some(FaultCode::Overload));
        assert_eq!(record.faults[2].map(|f| f.code), Some(FaultCode::StringBreak));
        assert_eq!(Record::decode(&record.encode()), Ok(record));
        let zero_flag = Layout::CURRENT.counters + 13;
        let mut bad = record.encode();
        bad[zero_flag] = 2;
        assert_eq!(Record::decode(&resealed(bad)), Err(StoreError::InvalidZero));
        assert_eq!(record.calibration_age(), Some(66), "stamped at 1234 pulls, now 1300");
        let none = Record { calibration_zero: None, calibration_pulls: 0, ..record };
        assert_eq!(none.calibration_age(), None);
        let none = none.encode();
        let mut stray_pulls = none;
        stray_pulls[zero_flag + 5] = 1;
        assert_eq!(Record::decode(&resealed(stray_pulls)), Err(StoreError::InvalidZero));
        let mut stray = none;
        stray[zero_flag + 2] = 1;
        assert_eq!(Record::decode(&resealed(stray)), Err(StoreError::InvalidZero));
        let first_snapshot = zero_flag + 9;
        let mut unknown_fault = record.encode();
        unknown_fault[first_snapshot] = 21;
        assert_eq!(Record::decode(&resealed(unknown_fault)), Err(StoreError::InvalidSnapshot));
        let mut length = record.encode();
        length[3] = 0;
        assert_eq!(Record::decode(&resealed(length)), Err(StoreError::ReservedNotZero));
        // The drivetrain's trend sits after the history, commissioning first.
        record.drivetrain = DrivetrainTrend { commissioned_ms: 271, trend_ms: 0x1234 };
        let bytes = record.encode();
        let trend = first_snapshot + FAULT_HISTORY * SNAPSHOT_LEN;
        assert_eq!(bytes[trend..trend + 4], [15, 1, 0x34, 0x12]);
        assert_eq!(Record::decode(&bytes), Ok(record));
    }
}

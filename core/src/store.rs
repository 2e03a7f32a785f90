//! The persisted record: settings, presets, calibration and counters, in a fixed, versioned,
//! CRC-checked byte layout.
//!
//! # Theory of operation
//!
//! Everything the machine must remember across a power cycle lives in one [`Record`]: the
//! operator's current [`Settings`] (tension set point and its unit, speed, pre-stretch, knot),
//! nine [`Settings`] presets, the four reference points of the last accepted load-cell
//! calibration ([`CalibrationPoints`]) and the [`Counters`] (pulls, string used). The machine
//! owns the record; when it changes one, it raises [`crate::io::Outputs::store`] and the
//! firmware writes [`Record::encode`]'s bytes to flash when convenient. At boot the firmware
//! reads the bytes back and hands [`Record::decode`]'s result to the machine; a record that is
//! missing, corrupt or from an unknown format version is a typed [`StoreError`], never a
//! panic — the machine then runs on [`Record::default`] and shows the error's code once.
//!
//! Every field is validated when decoded, through the same constructors the panel uses, so a
//! record that passes [`Record::decode`] satisfies every invariant the machine relies on and
//! the per-tick path never re-checks it.
//!
//! # Layout (format version 1, little-endian, [`RECORD_LEN`] = 128 bytes)
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 2 | magic `b"TT"` |
//! | 2 | 1 | format version (1) |
//! | 3 | 1 | reserved, 0 |
//! | 4 | 6 | current settings (see below) |
//! | 10 | 54 | presets 1–9, 6 bytes each |
//! | 64 | 1 | calibration present (0 or 1) |
//! | 65 | 32 | calibration: 4 × (raw reading, reference reading), each Q15.16 kgf bits (`i32`) |
//! | 97 | 4 | counter: pulls (`u32`) |
//! | 101 | 4 | counter: string used, millimetres (`u32`) |
//! | 105 | 19 | reserved, 0 |
//! | 124 | 4 | CRC-32/ISCSI of bytes 0..124 |
//!
//! A settings block is: set point in tenths of its unit (`u16`), unit (0 kg, 1 lb), speed
//! (1–9), pre-stretch percent (0–30), knot percent (0–20).
//!
//! Reserved bytes must be zero: a later format that uses them bumps the version, so a
//! version-1 reader never misreads a newer record as an older one.

use crc::{CRC_32_ISCSI, Crc};

use crate::units::Kgf;

/// Size of an encoded [`Record`] in bytes.
pub const RECORD_LEN: usize = 128;

/// The first two bytes of every record.
pub const MAGIC: [u8; 2] = *b"TT";

/// The format version this code writes and reads.
pub const FORMAT_VERSION: u8 = 1;

/// Number of presets (keys P1–P9 on the panel).
pub const PRESET_COUNT: usize = 9;

/// Number of reference points in a four-point calibration (10, 20, 30, 40 kgf).
pub const CALIBRATION_POINTS: usize = 4;

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
const OFFSET_COUNTERS: usize = OFFSET_CALIBRATION + 1 + 8 * CALIBRATION_POINTS;
const OFFSET_RESERVED: usize = OFFSET_COUNTERS + 8;
const OFFSET_CRC: usize = RECORD_LEN - 4;
const _: () = assert!(OFFSET_RESERVED <= OFFSET_CRC && RECORD_LEN <= 256, "layout overflows");

/// The unit the operator sets and reads tension in.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub enum Unit {
    /// Kilograms-force, set in 0.1 kg steps.
    #[default]
    Kilograms,
    /// Pounds-force, set in 0.5 lb steps.
    Pounds,
}

impl Unit {
    /// The other unit.
    #[must_use]
    pub const fn toggled(self) -> Self {
        match self {
            Self::Kilograms => Self::Pounds,
            Self::Pounds => Self::Kilograms,
        }
    }

    /// The set-point step in tenths of the unit (0.1 kg, 0.5 lb).
    #[must_use]
    pub const fn step_tenths(self) -> u16 {
        match self {
            Self::Kilograms => 1,
            Self::Pounds => 5,
        }
    }

    /// The lowest and highest set point in tenths of the unit: 5.0–50.0 kg; 11.5–110.0 lb
    /// (5.2–49.9 kg, the 0.5 lb steps inside 5–50 kg).
    #[must_use]
    pub const fn range_tenths(self) -> (u16, u16) {
        match self {
            Self::Kilograms => (50, 500),
            Self::Pounds => (115, 1100),
        }
    }

    const fn code(self) -> u8 {
        match self {
            Self::Kilograms => 0,
            Self::Pounds => 1,
        }
    }

    const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Kilograms),
            1 => Some(Self::Pounds),
            _ => None,
        }
    }
}

/// Why a settings value was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum SettingsError {
    /// The tension set point is outside its unit's range or not on its unit's step.
    TensionOutOfRange,
    /// The speed is not 1–9.
    SpeedOutOfRange,
    /// The pre-stretch is above 30 %.
    PreStretchOutOfRange,
    /// The knot increase is above 20 %.
    KnotOutOfRange,
}

/// A tension set point as the operator keyed it: tenths of a kilogram or of a pound.
///
/// Kept in the operator's unit so that a pound set point stays exactly on its 0.5 lb step;
/// [`SetPoint::to_kgf`] gives the tension the controller pulls to.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct SetPoint {
    unit: Unit,
    tenths: u16,
}

impl Default for SetPoint {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SetPoint {
    /// 25.0 kg, a common tennis tension.
    pub const DEFAULT: Self = Self { unit: Unit::Kilograms, tenths: 250 };

    /// A set point of `tenths` tenths of `unit`.
    ///
    /// # Errors
    /// [`SettingsError::TensionOutOfRange`] outside [`Unit::range_tenths`] or off the step.
    pub const fn new(unit: Unit, tenths: u16) -> Result<Self, SettingsError> {
        let (low, high) = unit.range_tenths();
        let on_step = matches!(tenths.checked_rem(unit.step_tenths()), Some(0));
        if tenths < low || tenths > high || !on_step {
            return Err(SettingsError::TensionOutOfRange);
        }
        Ok(Self { unit, tenths })
    }

    /// The unit the set point was keyed in.
    #[must_use]
    pub const fn unit(self) -> Unit {
        self.unit
    }

    /// The set point in tenths of its unit.
    #[must_use]
    pub const fn tenths(self) -> u16 {
        self.tenths
    }

    /// The tension to pull to.
    #[must_use]
    pub fn to_kgf(self) -> Kgf {
        match self.unit {
            Unit::Kilograms => Kgf::from_tenths(i32::from(self.tenths)),
            Unit::Pounds => Kgf::from_lbf_tenths(i32::from(self.tenths)),
        }
    }

    /// `steps` steps up (positive) or down (negative), clamped to the unit's range.
    #[must_use]
    pub fn stepped(self, steps: i16) -> Self {
        let (low, high) = self.unit.range_tenths();
        let delta = i32::from(steps).saturating_mul(i32::from(self.unit.step_tenths()));
        let wanted = i32::from(self.tenths).saturating_add(delta);
        let clamped = wanted.clamp(i32::from(low), i32::from(high));
        Self { unit: self.unit, tenths: u16::try_from(clamped).unwrap_or(low) }
    }

    /// The same tension in the other unit, rounded to the nearest step of that unit and
    /// clamped to its range.
    #[must_use]
    pub fn converted(self) -> Self {
        let target = self.unit.toggled();
        let kgf = self.to_kgf();
        let tenths = match target {
            Unit::Kilograms => kgf.to_tenths_rounded(),
            Unit::Pounds => {
                // Nearest multiple of 5 tenths (0.5 lb): round(x / 5) × 5.
                let lb_tenths = kgf.to_lbf_tenths_rounded();
                lb_tenths.saturating_add(2).div_euclid(5).saturating_mul(5)
            }
        };
        let (low, high) = target.range_tenths();
        let clamped = tenths.clamp(i32::from(low), i32::from(high));
        Self { unit: target, tenths: u16::try_from(clamped).unwrap_or(low) }
    }

    /// The invariant [`SetPoint::new`] establishes.
    #[must_use]
    pub const fn is_valid(self) -> bool {
        SetPoint::new(self.unit, self.tenths).is_ok()
    }
}

/// Everything the operator sets for a pull.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Settings {
    set_point: SetPoint,
    speed: u8,
    pre_stretch_percent: u8,
    knot_percent: u8,
}

impl Default for Settings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Settings {
    /// The highest speed setting.
    pub const SPEED_MAX: u8 = 9;
    /// The highest pre-stretch, percent.
    pub const PRE_STRETCH_MAX: u8 = 30;
    /// The highest knot increase, percent.
    pub const KNOT_MAX: u8 = 20;
    /// The pre-stretch step on the panel, percent.
    pub const PRE_STRETCH_STEP: u8 = 5;
    /// The knot step on the panel, percent.
    pub const KNOT_STEP: u8 = 5;

    /// 25.0 kg, speed 5, no pre-stretch, knot off.
    pub const DEFAULT: Self =
        Self { set_point: SetPoint::DEFAULT, speed: 5, pre_stretch_percent: 0, knot_percent: 0 };

    /// Validated settings.
    ///
    /// # Errors
    /// The first field out of range, as a [`SettingsError`].
    pub const fn new(
        set_point: SetPoint,
        speed: u8,
        pre_stretch_percent: u8,
        knot_percent: u8,
    ) -> Result<Self, SettingsError> {
        if !set_point.is_valid() {
            return Err(SettingsError::TensionOutOfRange);
        }
        if speed < 1 || speed > Self::SPEED_MAX {
            return Err(SettingsError::SpeedOutOfRange);
        }
        if pre_stretch_percent > Self::PRE_STRETCH_MAX {
            return Err(SettingsError::PreStretchOutOfRange);
        }
        if knot_percent > Self::KNOT_MAX {
            return Err(SettingsError::KnotOutOfRange);
        }
        Ok(Self { set_point, speed, pre_stretch_percent, knot_percent })
    }

    /// The tension set point.
    #[must_use]
    pub const fn set_point(self) -> SetPoint {
        self.set_point
    }

    /// Speed, 1 (gentlest) – 9 (fastest).
    #[must_use]
    pub const fn speed(self) -> u8 {
        self.speed
    }

    /// Pre-stretch, percent above the set point held briefly before settling (0 = off).
    #[must_use]
    pub const fn pre_stretch_percent(self) -> u8 {
        self.pre_stretch_percent
    }

    /// Knot increase, percent above the set point (0 = off).
    #[must_use]
    pub const fn knot_percent(self) -> u8 {
        self.knot_percent
    }

    /// These settings with another set point.
    #[must_use]
    pub const fn with_set_point(self, set_point: SetPoint) -> Self {
        Self { set_point, ..self }
    }

    /// These settings with the speed moved by `steps`, clamped to 1–9.
    #[must_use]
    pub fn with_speed_stepped(self, steps: i8) -> Self {
        let speed = self.speed.saturating_add_signed(steps).clamp(1, Self::SPEED_MAX);
        Self { speed, ..self }
    }

    /// These settings with the pre-stretch moved by `steps` × 5 %, clamped to 0–30 %.
    #[must_use]
    pub fn with_pre_stretch_stepped(self, steps: i8) -> Self {
        let pre = step_percent(self.pre_stretch_percent, steps, Self::PRE_STRETCH_STEP);
        Self { pre_stretch_percent: pre.min(Self::PRE_STRETCH_MAX), ..self }
    }

    /// These settings with the knot increase moved by `steps` × 5 %, clamped to 0–20 %.
    #[must_use]
    pub fn with_knot_stepped(self, steps: i8) -> Self {
        let knot = step_percent(self.knot_percent, steps, Self::KNOT_STEP);
        Self { knot_percent: knot.min(Self::KNOT_MAX), ..self }
    }

    /// The invariant [`Settings::new`] establishes.
    #[must_use]
    pub const fn is_valid(self) -> bool {
        Settings::new(self.set_point, self.speed, self.pre_stretch_percent, self.knot_percent)
            .is_ok()
    }

    fn encode_into(self, w: &mut Writer<'_>) {
        w.u16(self.set_point.tenths);
        w.u8(self.set_point.unit.code());
        w.u8(self.speed);
        w.u8(self.pre_stretch_percent);
        w.u8(self.knot_percent);
    }

    fn decode_from(r: &mut Reader<'_>) -> Result<Self, StoreError> {
        let tenths = r.u16();
        let unit = Unit::from_code(r.u8());
        let (speed, pre, knot) = (r.u8(), r.u8(), r.u8());
        let unit = unit.ok_or(StoreError::InvalidSettings)?;
        let set_point = SetPoint::new(unit, tenths).map_err(|_| StoreError::InvalidSettings)?;
        Self::new(set_point, speed, pre, knot).map_err(|_| StoreError::InvalidSettings)
    }
}

/// One calibration reference point: what the uncorrected sensor read (averaged while
/// holding) and what the reference gauge read. Stored as exact Q15.16 bits, so the correction
/// rebuilt at boot is bit-identical to the one accepted.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct CalibrationPoint {
    /// The load cell's uncorrected reading (tared, nominal scale).
    pub raw: Kgf,
    /// The reference gauge's reading keyed in by the operator.
    pub reference: Kgf,
}

/// The four reference points of an accepted calibration, 10/20/30/40 kgf in order.
///
/// The record keeps the measured points, not derived coefficients: the correction is rebuilt
/// from them (and re-validated) at boot, so a change to how the correction is computed never
/// needs a format change.
pub type CalibrationPoints = [CalibrationPoint; CALIBRATION_POINTS];

/// The lifetime counters.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Counters {
    /// Completed pulls (reached tension and released).
    pub pulls: u32,
    /// String drawn through the machine, millimetres.
    pub string_used_mm: u32,
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
    /// The calibration block is malformed (presence flag not 0/1).
    InvalidCalibration,
    /// A reserved byte is not zero.
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
        self.settings.encode_into(&mut w);
        for preset in &self.presets {
            preset.encode_into(&mut w);
        }
        match &self.calibration {
            Some(points) => {
                w.u8(1);
                for point in points {
                    w.i32(point.raw.to_bits());
                    w.i32(point.reference.to_bits());
                }
            }
            None => {
                w.u8(0);
                w.skip(8 * CALIBRATION_POINTS);
            }
        }
        w.u32(self.counters.pulls);
        w.u32(self.counters.string_used_mm);
        // The reserved bytes stay zero; the CRC covers everything before it.
        let body = out.first_chunk::<OFFSET_CRC>().copied().unwrap_or([0; OFFSET_CRC]);
        let mut w = Writer { bytes: &mut out, at: OFFSET_CRC };
        w.u32(checksum(&body));
        out
    }

    /// The record in `bytes` (the first [`RECORD_LEN`] of them), fully validated.
    ///
    /// # Errors
    /// A [`StoreError`] naming the first problem found, checked in the order: length, magic,
    /// version, CRC, reserved bytes, fields.
    pub fn decode(bytes: &[u8]) -> Result<Self, StoreError> {
        let bytes: &[u8; RECORD_LEN] = bytes.first_chunk().ok_or(StoreError::TooShort)?;
        let mut r = Reader { bytes, at: 0 };
        if r.u8() != MAGIC[0] || r.u8() != MAGIC[1] {
            return Err(StoreError::NoRecord);
        }
        if r.u8() != FORMAT_VERSION {
            return Err(StoreError::UnknownVersion);
        }
        let body = bytes.first_chunk::<OFFSET_CRC>().ok_or(StoreError::TooShort)?;
        let stored = Reader { bytes, at: OFFSET_CRC }.u32();
        if checksum(body) != stored {
            return Err(StoreError::CrcMismatch);
        }
        let mut reserved = r.u8() == 0;
        let mut tail = Reader { bytes, at: OFFSET_RESERVED };
        // Bound: OFFSET_CRC − OFFSET_RESERVED = 19 bytes.
        for _ in OFFSET_RESERVED..OFFSET_CRC {
            reserved &= tail.u8() == 0;
        }
        if !reserved {
            return Err(StoreError::ReservedNotZero);
        }
        let settings = Settings::decode_from(&mut r)?;
        let mut presets = [Settings::DEFAULT; PRESET_COUNT];
        for preset in &mut presets {
            *preset = Settings::decode_from(&mut r)?;
        }
        let flag = r.u8();
        let mut points = [CalibrationPoint::default(); CALIBRATION_POINTS];
        let mut all_zero = true;
        for point in &mut points {
            let (raw, reference) = (r.i32(), r.i32());
            all_zero &= raw == 0 && reference == 0;
            *point =
                CalibrationPoint { raw: Kgf::from_bits(raw), reference: Kgf::from_bits(reference) };
        }
        let calibration = match flag {
            0 if all_zero => None,
            1 => Some(points),
            _ => return Err(StoreError::InvalidCalibration),
        };
        let counters = Counters { pulls: r.u32(), string_used_mm: r.u32() };
        Ok(Self { settings, presets, calibration, counters })
    }

    /// Whether every settings field satisfies its invariant (true of every decoded record
    /// and of every record the machine builds).
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.settings.is_valid() && self.presets.iter().all(|preset| preset.is_valid())
    }
}

/// `value + steps × step`, saturating at 0 and 255.
fn step_percent(value: u8, steps: i8, step: u8) -> u8 {
    let wanted = i16::from(value).saturating_add(i16::from(steps).saturating_mul(i16::from(step)));
    u8::try_from(wanted.clamp(0, 255)).unwrap_or(0)
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
        record.calibration = Some([
            CalibrationPoint { raw: Kgf::from_tenths(98), reference: Kgf::from_tenths(100) },
            CalibrationPoint { raw: Kgf::from_tenths(199), reference: Kgf::from_tenths(200) },
            CalibrationPoint { raw: Kgf::from_tenths(300), reference: Kgf::from_tenths(300) },
            CalibrationPoint { raw: Kgf::from_tenths(401), reference: Kgf::from_tenths(400) },
        ]);
        record.counters = Counters { pulls: 1234, string_used_mm: 987_654 };
        record
    }

    #[test]
    fn round_trips() {
        let record = sample();
        assert_eq!(Record::decode(&record.encode()), Ok(record));
        assert_eq!(Record::decode(&Record::default().encode()), Ok(Record::default()));
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
        bytes[2] = 2;
        assert_eq!(Record::decode(&bytes), Err(StoreError::UnknownVersion));
    }

    #[test]
    fn out_of_range_fields_are_refused_even_with_a_good_crc() {
        let mut bytes = sample().encode();
        bytes[OFFSET_SETTINGS + 3] = 10; // speed 10
        let crc = checksum(&bytes[..OFFSET_CRC]).to_le_bytes();
        bytes[OFFSET_CRC..].copy_from_slice(&crc);
        assert_eq!(Record::decode(&bytes), Err(StoreError::InvalidSettings));
    }

    #[test]
    fn set_points_step_and_convert() {
        let kg = SetPoint::DEFAULT;
        assert_eq!(kg.stepped(3).tenths(), 253);
        assert_eq!(kg.stepped(-1000).tenths(), 50);
        assert_eq!(kg.stepped(1000).tenths(), 500);
        let lb = kg.converted();
        assert_eq!(
            (lb.unit(), lb.tenths()),
            (Unit::Pounds, 550),
            "25 kg = 55.1 lb → 55.0 on the 0.5 step"
        );
        assert_eq!(lb.converted().tenths(), 249, "55.0 lb = 24.95 kg");
        assert_eq!(lb.stepped(1).tenths(), 555);
        assert_eq!(SetPoint::new(Unit::Pounds, 551), Err(SettingsError::TensionOutOfRange));
        // Every valid set point in either unit converts to a valid one.
        for unit in [Unit::Kilograms, Unit::Pounds] {
            for tenths in 0..=1200 {
                if let Ok(point) = SetPoint::new(unit, tenths) {
                    assert!(point.converted().is_valid());
                    let kgf = point.to_kgf().to_tenths_rounded();
                    assert!((50..=500).contains(&kgf), "{point:?}");
                }
            }
        }
    }
}

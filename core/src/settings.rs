//! What the operator sets: one validated [`Settings`], shared by the panel, the stored record
//! and the tension controller.
//!
//! # Theory of operation
//!
//! A stringer sets five things before pressing Start (PicoBETH's panel has the same):
//!
//! - the **tension** [`SetPoint`], 5–50 kgf (the paper's range of electronic stringers), kept
//!   in the [`Unit`] it was keyed in (0.1 kg or 0.5 lb steps) so a pound set point stays
//!   exactly on its step;
//! - the **speed** [`Speed`], 1–9, which limits how fast the carriage may move while taking
//!   up slack and approaching the target ([`Speed::carriage_limit`]);
//! - the **pre-stretch** [`PreStretch`], 0–30 %: the string is first pulled to `T·(1 + p)`
//!   and then let back to `T`, which takes some of the initial creep out of a fresh string;
//! - the **knot boost** [`KnotBoost`], +0–20 %: the tension of a *knot pull*
//!   ([`PullKind::Knot`]), the last pull of a string before it is tied off, is raised by this
//!   much because a knot loses tension when it is tied.
//!
//! Each value is its own validated type, [`Settings`] holds one of each, and every
//! constructor returns the one [`SettingsError`]: a `Settings` in hand is always a set the
//! machine can pull with, whether it came from the panel's keys, from flash
//! ([`crate::store::Record::decode`] validates through these constructors) or from a test.
//!
//! The controller does not need the operator's unit: [`Settings::pull`] gives the same
//! settings as [`PullSettings`] (tension in kgf), a total conversion. [`PullSettings::new`]
//! also takes a tension in kgf directly, for pulls the operator did not key in (the
//! calibration's 10/20/30/40 kgf points, the reports' targets). Every tension the controller
//! is ever asked to reach ([`PullSettings::final_target`], [`PullSettings::peak_target`]) is
//! clipped to [`TENSION_MAX`], the machine's rating.

use crate::units::{Kgf, Q16};

/// The lowest tension a pull may be set to: 5 kgf.
pub const TENSION_MIN: Kgf = Kgf::from_int(5);

/// The highest tension a pull may be set to, and the highest the controller is ever asked to
/// reach (knot boost and pre-stretch included): 50 kgf.
pub const TENSION_MAX: Kgf = Kgf::from_int(50);

/// Why a setting was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum SettingsError {
    /// The tension is below [`TENSION_MIN`] or above [`TENSION_MAX`], or a set point is off
    /// its unit's step.
    TensionOutOfRange,
    /// The speed is not 1–9.
    SpeedOutOfRange,
    /// The pre-stretch is above 30 %.
    PreStretchOutOfRange,
    /// The knot boost is above 20 %.
    KnotBoostOutOfRange,
}

/// A carriage speed in millimetres per second, Q15.16 (range ±32 768 mm/s, resolution
/// 2⁻¹⁶ mm/s).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct MmPerSecond(pub Q16);

impl MmPerSecond {
    /// A whole number of mm/s.
    #[must_use]
    #[allow(clippy::cast_lossless, reason = "`i32::from` is not callable in a const fn")]
    pub const fn from_int(value: i16) -> Self {
        Self(Q16::const_from_int(value as i32))
    }
}

/// Carriage speed per speed step: speed `n` limits the carriage to `n × 9 mm/s`, so speed 9
/// (81 mm/s) is above the no-load speed of the screw (3 700 rpm / 20 × 25.4 mm ≈ 78 mm/s)
/// and means "as fast as the motor goes".
pub const SPEED_STEP: MmPerSecond = MmPerSecond::from_int(9);

/// `value + steps × step`, clamped to `0..=max`.
fn stepped_percent(value: u8, steps: i8, step: u8, max: u8) -> u8 {
    let wanted = i16::from(value).saturating_add(i16::from(steps).saturating_mul(i16::from(step)));
    u8::try_from(wanted.clamp(0, i16::from(max))).unwrap_or(0)
}

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

    /// The step of an adjustment while holding, in tenths of the unit: 0.1 kg, 0.2 lb
    /// (0.09 kg) — the finest the digits show, finer than the set point's 0.5 lb.
    #[must_use]
    pub const fn fine_step_tenths(self) -> i16 {
        match self {
            Self::Kilograms => 1,
            Self::Pounds => 2,
        }
    }

    /// `tenths` tenths of the unit in kgf.
    #[must_use]
    pub fn tenths_to_kgf(self, tenths: i32) -> Kgf {
        match self {
            Self::Kilograms => Kgf::from_tenths(tenths),
            Self::Pounds => Kgf::from_lbf_tenths(tenths),
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

    /// The tension to pull to, always within [`TENSION_MIN`]–[`TENSION_MAX`] (a test checks
    /// every set point of both units).
    #[must_use]
    pub fn to_kgf(self) -> Kgf {
        self.unit.tenths_to_kgf(i32::from(self.tenths))
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

/// The speed setting, 1 (gentle) to 9 (as fast as the motor goes).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
pub struct Speed(u8);

impl Speed {
    /// The slowest setting.
    pub const MIN: Self = Self(1);
    /// The fastest setting.
    pub const MAX: Self = Self(9);

    /// A speed setting.
    ///
    /// # Errors
    /// [`SettingsError::SpeedOutOfRange`] outside 1–9.
    pub const fn new(setting: u8) -> Result<Self, SettingsError> {
        if setting >= Self::MIN.0 && setting <= Self::MAX.0 {
            Ok(Self(setting))
        } else {
            Err(SettingsError::SpeedOutOfRange)
        }
    }

    /// The setting, 1–9.
    #[must_use]
    pub const fn get(self) -> u8 {
        self.0
    }

    /// `steps` settings faster (positive) or slower (negative), clamped to 1–9.
    #[must_use]
    pub fn stepped(self, steps: i8) -> Self {
        Self(self.0.saturating_add_signed(steps).clamp(Self::MIN.0, Self::MAX.0))
    }

    /// The carriage speed this setting allows, mm/s: `setting × SPEED_STEP`.
    #[must_use]
    pub fn carriage_limit(self) -> MmPerSecond {
        MmPerSecond(SPEED_STEP.0.saturating_mul_int(i32::from(self.0)))
    }
}

impl Default for Speed {
    fn default() -> Self {
        Self::MAX
    }
}

/// Pre-stretch in percent, 0–30.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct PreStretch(u8);

impl PreStretch {
    /// No pre-stretch.
    pub const NONE: Self = Self(0);
    /// The largest pre-stretch, 30 %.
    pub const MAX: Self = Self(30);
    /// The panel's step, 5 %.
    pub const STEP: u8 = 5;

    /// A pre-stretch of `percent` %.
    ///
    /// # Errors
    /// [`SettingsError::PreStretchOutOfRange`] above 30 %.
    pub const fn new(percent: u8) -> Result<Self, SettingsError> {
        if percent <= Self::MAX.0 {
            Ok(Self(percent))
        } else {
            Err(SettingsError::PreStretchOutOfRange)
        }
    }

    /// The percentage, 0–30.
    #[must_use]
    pub const fn percent(self) -> u8 {
        self.0
    }

    /// `steps` × [`PreStretch::STEP`] more (positive) or less, clamped to 0–30 %.
    #[must_use]
    pub fn stepped(self, steps: i8) -> Self {
        Self(stepped_percent(self.0, steps, Self::STEP, Self::MAX.0))
    }
}

/// Knot boost in percent, 0–20: how much higher a knot pull goes than a main pull.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct KnotBoost(u8);

impl KnotBoost {
    /// No boost.
    pub const NONE: Self = Self(0);
    /// The largest boost, 20 %.
    pub const MAX: Self = Self(20);
    /// The panel's step, 5 %.
    pub const STEP: u8 = 5;

    /// A boost of `percent` %.
    ///
    /// # Errors
    /// [`SettingsError::KnotBoostOutOfRange`] above 20 %.
    pub const fn new(percent: u8) -> Result<Self, SettingsError> {
        if percent <= Self::MAX.0 {
            Ok(Self(percent))
        } else {
            Err(SettingsError::KnotBoostOutOfRange)
        }
    }

    /// The percentage, 0–20.
    #[must_use]
    pub const fn percent(self) -> u8 {
        self.0
    }

    /// `steps` × [`KnotBoost::STEP`] more (positive) or less, clamped to 0–20 %.
    #[must_use]
    pub fn stepped(self, steps: i8) -> Self {
        Self(stepped_percent(self.0, steps, Self::STEP, Self::MAX.0))
    }
}

/// The machine's preferences: not part of a pull (presets do not hold them), set on their
/// own Ready pages and kept in the record.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Preferences {
    /// The beeper's clicks and at-tension tone (fault tones always sound: a fault is a
    /// safety signal).
    pub beeper: bool,
    /// Constant pull in the hold by default (off: every hold starts locked, `LOCK`; Function
    /// still switches it for one pull).
    pub constant_pull: bool,
}

impl Default for Preferences {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Preferences {
    /// Beeper on, constant pull on.
    pub const DEFAULT: Self = Self { beeper: true, constant_pull: true };

    /// The record's flags byte: bit 0 set = beeper off, bit 1 set = constant pull off (so
    /// zero — what a version-2 record holds in that byte — is the default).
    #[must_use]
    pub const fn flags(self) -> u8 {
        (if self.beeper { 0 } else { 1 }) | (if self.constant_pull { 0 } else { 2 })
    }

    /// The preferences of a flags byte; `None` with any other bit set.
    #[must_use]
    pub const fn from_flags(flags: u8) -> Option<Self> {
        if flags & !3 != 0 {
            return None;
        }
        Some(Self { beeper: flags & 1 == 0, constant_pull: flags & 2 == 0 })
    }
}

/// Everything the operator sets for a pull: what the panel edits, a preset holds and the
/// stored record keeps.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Settings {
    set_point: SetPoint,
    speed: Speed,
    pre_stretch: PreStretch,
    knot: KnotBoost,
}

impl Default for Settings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Settings {
    /// 25.0 kg, speed 5, no pre-stretch, knot off.
    pub const DEFAULT: Self = Self {
        set_point: SetPoint::DEFAULT,
        speed: Speed(5),
        pre_stretch: PreStretch::NONE,
        knot: KnotBoost::NONE,
    };

    /// Settings from the operator's raw numbers, each validated by its type.
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
        let speed = match Speed::new(speed) {
            Ok(speed) => speed,
            Err(error) => return Err(error),
        };
        let pre_stretch = match PreStretch::new(pre_stretch_percent) {
            Ok(pre_stretch) => pre_stretch,
            Err(error) => return Err(error),
        };
        let knot = match KnotBoost::new(knot_percent) {
            Ok(knot) => knot,
            Err(error) => return Err(error),
        };
        Ok(Self { set_point, speed, pre_stretch, knot })
    }

    /// The tension set point.
    #[must_use]
    pub const fn set_point(self) -> SetPoint {
        self.set_point
    }

    /// The speed, 1 (gentlest) – 9 (fastest).
    #[must_use]
    pub const fn speed(self) -> Speed {
        self.speed
    }

    /// The pre-stretch above the set point held briefly before settling.
    #[must_use]
    pub const fn pre_stretch(self) -> PreStretch {
        self.pre_stretch
    }

    /// The knot boost above the set point for a knot pull.
    #[must_use]
    pub const fn knot(self) -> KnotBoost {
        self.knot
    }

    /// These settings with another set point.
    #[must_use]
    pub const fn with_set_point(self, set_point: SetPoint) -> Self {
        Self { set_point, ..self }
    }

    /// These settings with the speed moved by `steps`, clamped to 1–9.
    #[must_use]
    pub fn with_speed_stepped(self, steps: i8) -> Self {
        Self { speed: self.speed.stepped(steps), ..self }
    }

    /// These settings with the pre-stretch moved by `steps` × 5 %, clamped to 0–30 %.
    #[must_use]
    pub fn with_pre_stretch_stepped(self, steps: i8) -> Self {
        Self { pre_stretch: self.pre_stretch.stepped(steps), ..self }
    }

    /// These settings with the knot boost moved by `steps` × 5 %, clamped to 0–20 %.
    #[must_use]
    pub fn with_knot_stepped(self, steps: i8) -> Self {
        Self { knot: self.knot.stepped(steps), ..self }
    }

    /// The invariant every constructor establishes (and the fields' types keep).
    #[must_use]
    pub const fn is_valid(self) -> bool {
        self.set_point.is_valid()
            && Speed::new(self.speed.0).is_ok()
            && PreStretch::new(self.pre_stretch.0).is_ok()
            && KnotBoost::new(self.knot.0).is_ok()
    }

    /// The same settings as the controller takes them (tension in kgf). Total: every set
    /// point's tension is within [`TENSION_MIN`]–[`TENSION_MAX`].
    #[must_use]
    pub fn pull(self) -> PullSettings {
        PullSettings {
            tension: self.set_point.to_kgf(),
            speed: self.speed,
            pre_stretch: self.pre_stretch,
            knot: self.knot,
        }
    }
}

/// Which kind of pull: a main-string/cross pull at the set tension, or a knot pull at the
/// set tension plus the knot boost.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub enum PullKind {
    /// A normal pull to the set tension.
    #[default]
    Main,
    /// The tie-off pull, boosted by [`KnotBoost`].
    Knot,
}

/// The settings as the tension controller takes them: the tension in kgf, the rest as the
/// operator set it.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct PullSettings {
    tension: Kgf,
    speed: Speed,
    pre_stretch: PreStretch,
    knot: KnotBoost,
}

impl Default for PullSettings {
    /// 25.0 kgf (a common tennis tension), speed 9, no pre-stretch, knot +10 %.
    fn default() -> Self {
        Self {
            tension: Kgf::from_int(25),
            speed: Speed::MAX,
            pre_stretch: PreStretch::NONE,
            knot: KnotBoost(10),
        }
    }
}

/// `value × (100 + percent) / 100`, saturating; `percent ≤ 30` keeps it far from the limit.
fn boosted(value: Kgf, percent: u8) -> Kgf {
    // (100 + p) / 100 as Q15.16: at most 1.3, rounded to the nearest 2⁻¹⁶.
    let factor = Q16::from_num(100_u16.saturating_add(u16::from(percent))).saturating_div_int(100);
    value.saturating_scale(factor)
}

impl PullSettings {
    /// A pull to `tension` kgf, which must be within [`TENSION_MIN`]–[`TENSION_MAX`] (the
    /// other three are valid by their types).
    ///
    /// # Errors
    /// [`SettingsError::TensionOutOfRange`].
    pub fn new(
        tension: Kgf,
        speed: Speed,
        pre_stretch: PreStretch,
        knot: KnotBoost,
    ) -> Result<Self, SettingsError> {
        if tension < TENSION_MIN || tension > TENSION_MAX {
            return Err(SettingsError::TensionOutOfRange);
        }
        Ok(Self { tension, speed, pre_stretch, knot })
    }

    /// The same settings with another tension.
    ///
    /// # Errors
    /// [`SettingsError::TensionOutOfRange`].
    pub fn with_tension(self, tension: Kgf) -> Result<Self, SettingsError> {
        Self::new(tension, self.speed, self.pre_stretch, self.knot)
    }

    /// The set tension.
    #[must_use]
    pub const fn tension(&self) -> Kgf {
        self.tension
    }

    /// The speed setting.
    #[must_use]
    pub const fn speed(&self) -> Speed {
        self.speed
    }

    /// The pre-stretch.
    #[must_use]
    pub const fn pre_stretch(&self) -> PreStretch {
        self.pre_stretch
    }

    /// The knot boost.
    #[must_use]
    pub const fn knot(&self) -> KnotBoost {
        self.knot
    }

    /// The tension held after the pull settles: `T`, or `T·(1 + knot)` for a knot pull,
    /// clipped to [`TENSION_MAX`].
    #[must_use]
    pub fn final_target(&self, kind: PullKind) -> Kgf {
        let target = match kind {
            PullKind::Main => self.tension,
            PullKind::Knot => boosted(self.tension, self.knot.0),
        };
        if target > TENSION_MAX { TENSION_MAX } else { target }
    }

    /// The highest tension of the pull: the final target raised by the pre-stretch,
    /// clipped to [`TENSION_MAX`]. Equal to the final target without pre-stretch.
    #[must_use]
    pub fn peak_target(&self, kind: PullKind) -> Kgf {
        let peak = boosted(self.final_target(kind), self.pre_stretch.0);
        if peak > TENSION_MAX { TENSION_MAX } else { peak }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::valid;

    #[test]
    fn ranges_are_enforced() {
        for raw in 0..=u8::MAX {
            assert_eq!(Speed::new(raw).is_ok(), (1..=9).contains(&raw));
            assert_eq!(PreStretch::new(raw).is_ok(), raw <= 30);
            assert_eq!(KnotBoost::new(raw).is_ok(), raw <= 20);
            let made = Settings::new(SetPoint::DEFAULT, raw, raw, raw);
            let expected = if !(1..=9).contains(&raw) {
                Err(SettingsError::SpeedOutOfRange)
            } else if raw > 30 {
                Err(SettingsError::PreStretchOutOfRange)
            } else if raw > 20 {
                Err(SettingsError::KnotBoostOutOfRange)
            } else {
                Ok(())
            };
            assert_eq!(made.map(|_| ()), expected, "{raw}");
            assert!(made.is_err() || made.is_ok_and(Settings::is_valid));
        }
        let ok = |tenths| {
            PullSettings::new(
                Kgf::from_tenths(tenths),
                Speed::MAX,
                PreStretch::NONE,
                KnotBoost::NONE,
            )
            .is_ok()
        };
        assert!(!ok(49));
        assert!(ok(50));
        assert!(ok(500));
        assert!(!ok(501));
    }

    #[test]
    fn steps_clamp_to_the_ranges() {
        let settings = Settings::DEFAULT;
        assert_eq!(settings.with_speed_stepped(2).speed().get(), 7);
        assert_eq!(settings.with_speed_stepped(100).speed(), Speed::MAX);
        assert_eq!(settings.with_speed_stepped(-100).speed(), Speed::MIN);
        assert_eq!(settings.with_pre_stretch_stepped(1).pre_stretch().percent(), 5);
        assert_eq!(settings.with_pre_stretch_stepped(100).pre_stretch(), PreStretch::MAX);
        assert_eq!(settings.with_pre_stretch_stepped(-1).pre_stretch(), PreStretch::NONE);
        assert_eq!(settings.with_knot_stepped(3).knot().percent(), 15);
        assert_eq!(settings.with_knot_stepped(100).knot(), KnotBoost::MAX);
        assert_eq!(settings.with_knot_stepped(-100).knot(), KnotBoost::NONE);
    }

    #[test]
    fn targets_boost_and_clip() {
        let settings = valid(PullSettings::new(
            Kgf::from_int(20),
            Speed::MAX,
            valid(PreStretch::new(10)),
            valid(KnotBoost::new(15)),
        ));
        assert_eq!(settings.final_target(PullKind::Main).to_tenths_rounded(), 200);
        assert_eq!(settings.peak_target(PullKind::Main).to_tenths_rounded(), 220);
        assert_eq!(settings.final_target(PullKind::Knot).to_tenths_rounded(), 230);
        assert_eq!(settings.peak_target(PullKind::Knot).to_tenths_rounded(), 253);
        let heavy = valid(settings.with_tension(Kgf::from_int(48)));
        assert_eq!(heavy.peak_target(PullKind::Knot), TENSION_MAX);
        assert_eq!(heavy.final_target(PullKind::Knot), TENSION_MAX);
    }

    #[test]
    fn speed_limits_scale() {
        assert_eq!(valid(Speed::new(1)).carriage_limit(), MmPerSecond::from_int(9));
        assert_eq!(Speed::MAX.carriage_limit(), MmPerSecond::from_int(81));
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
    }

    /// Every valid set point in either unit converts to a valid one, and every settings
    /// record converts to controller settings whose tension is in range: the conversion
    /// [`Settings::pull`] is total without a fallback.
    #[test]
    fn every_set_point_converts_and_pulls_in_range() {
        for unit in [Unit::Kilograms, Unit::Pounds] {
            for tenths in 0..=1200 {
                if let Ok(point) = SetPoint::new(unit, tenths) {
                    assert!(point.converted().is_valid());
                    let pull = Settings::DEFAULT.with_set_point(point).pull();
                    assert!(pull.tension() >= TENSION_MIN && pull.tension() <= TENSION_MAX);
                    assert_eq!(pull.with_tension(pull.tension()), Ok(pull), "{point:?}");
                }
            }
        }
    }
}

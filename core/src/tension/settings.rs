//! What the operator sets for a pull: tension, speed, pre-stretch, knot boost.
//!
//! # Theory of operation
//!
//! A stringer sets four things before pressing Start (PicoBETH's panel has the same four):
//!
//! - the **tension** `T`, 5–50 kgf (the paper's range of electronic stringers);
//! - the **speed**, 1–9, which limits how fast the carriage may move while taking up slack
//!   and approaching the target ([`Speed::carriage_limit`]);
//! - the **pre-stretch**, 0–30 %: the string is first pulled to `T·(1 + p)` and then let back
//!   to `T`, which takes some of the initial creep out of a fresh string;
//! - the **knot boost**, +0–20 %: the tension of a *knot pull* ([`PullKind::Knot`]), the last
//!   pull of a string before it is tied off, is raised by this much because a knot loses
//!   tension when it is tied.
//!
//! Each value is its own validated type and [`PullSettings`] holds one of each, so a
//! `PullSettings` in hand is always a set the machine can pull with; the panel, the stored
//! record and the controller share these types. Every tension the controller is ever asked
//! to reach ([`PullSettings::final_target`], [`PullSettings::peak_target`]) is clipped to
//! [`TENSION_MAX`], the machine's rating.

use crate::units::{Kgf, Q16};

/// The lowest tension a pull may be set to: 5 kgf.
pub const TENSION_MIN: Kgf = Kgf::from_int(5);

/// The highest tension a pull may be set to, and the highest the controller is ever asked to
/// reach (knot boost and pre-stretch included): 50 kgf.
pub const TENSION_MAX: Kgf = Kgf::from_int(50);

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

/// Why a setting was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum SettingsError {
    /// Tension below [`TENSION_MIN`] or above [`TENSION_MAX`].
    TensionOutOfRange,
    /// Speed outside 1–9.
    SpeedOutOfRange,
    /// Pre-stretch above 30 %.
    PreStretchOutOfRange,
    /// Knot boost above 20 %.
    KnotBoostOutOfRange,
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
}

/// Knot boost in percent, 0–20: how much higher a knot pull goes than a main pull.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct KnotBoost(u8);

impl KnotBoost {
    /// No boost.
    pub const NONE: Self = Self(0);
    /// The largest boost, 20 %.
    pub const MAX: Self = Self(20);

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

/// A validated set of pull settings.
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
    /// A set of settings; the tension must be within [`TENSION_MIN`]–[`TENSION_MAX`] (the
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
}

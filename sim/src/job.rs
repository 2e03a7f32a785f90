//! The main job's options: what `cargo run` does by default and what its options change —
//! the operator's settings, the machine's string and which machine, how long to hold. One
//! definition, so the host tool's main job and the tick-cost recorder (which replays that
//! very job on the Cortex-M4) cannot disagree about it.

use taut_core::settings::{PullKind, SetPoint, Settings, SettingsError};

use crate::operator::Plan;
use crate::{StringKind, TwinConfig};

/// Default hold time of the job, ms: a few seconds of constant pull while the string creeps.
pub const DEFAULT_HOLD_MS: u32 = 5_000;

/// What the main job does: the operator's settings, the machine's string and scenario, how
/// long to hold.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct CycleOptions {
    /// The tension to set, in the unit the operator keys it in.
    pub set_point: SetPoint,
    /// The string on the machine.
    pub string: StringKind,
    /// Speed setting, 1–9.
    pub speed: u8,
    /// Pre-stretch, percent (0–30, steps of 5).
    pub pre_stretch_percent: u8,
    /// `Some(p)`: a knot pull with the knot increase set to `p` % (0–20, steps of 5).
    pub knot_percent: Option<u8>,
    /// Machine `seed` of the twin's family instead of the nominal machine.
    pub seed: Option<u64>,
    /// How long the operator lets the machine hold before releasing, ms.
    pub hold_ms: u32,
    /// Whether the commissioning session calibrates the load cell (otherwise the machine
    /// runs on the uncorrected, tared sensor).
    pub calibrate: bool,
}

impl Default for CycleOptions {
    fn default() -> Self {
        Self {
            set_point: SetPoint::DEFAULT,
            string: StringKind::TennisSynthetic,
            speed: 5,
            pre_stretch_percent: 0,
            knot_percent: None,
            seed: None,
            hold_ms: DEFAULT_HOLD_MS,
            calibrate: true,
        }
    }
}

impl CycleOptions {
    /// The panel settings the operator will key in.
    ///
    /// # Errors
    /// [`SettingsError`] when a value is out of the panel's range.
    pub fn settings(&self) -> Result<Settings, SettingsError> {
        Settings::new(
            self.set_point,
            self.speed,
            self.pre_stretch_percent,
            self.knot_percent.unwrap_or(0),
        )
    }

    /// The twin's configuration: nominal, or machine [`Self::seed`] of the family.
    #[must_use]
    pub fn twin_config(&self) -> TwinConfig {
        self.seed.map_or_else(
            || TwinConfig::nominal(self.string),
            |seed| TwinConfig::family_kind(self.string, seed),
        )
    }

    /// The kind of pull the job makes.
    #[must_use]
    pub const fn pull_kind(&self) -> PullKind {
        if self.knot_percent.is_some() { PullKind::Knot } else { PullKind::Main }
    }

    /// The job session's plan for the operator: these settings, the pull, the hold and the
    /// release (the calibration window skipped: commissioning calibrated).
    ///
    /// # Errors
    /// [`SettingsError`] when a value is out of the panel's range.
    pub fn plan(&self) -> Result<Plan, SettingsError> {
        Ok(Plan {
            calibrate: false,
            settings: self.settings()?,
            knot_mode: self.knot_percent.is_some(),
            pull_hold_ms: Some(self.hold_ms),
        })
    }
}

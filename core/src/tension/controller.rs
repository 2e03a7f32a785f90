//! The tension controller the machine runs at 1 kHz: pull profile + control law + duty map.
//!
//! # Theory of operation
//!
//! [`TensionController::start`] arms a pull from [`PullSettings`]; every tick
//! [`TensionController::step`] takes a [`Measurement`] (calibrated tension, the drive's
//! status with its Hall step count, motor current, limit switches) and returns a
//! [`ControlOutput`]: the [`DriveCommand`] for the bridge, the [`PullPhase`], the
//! "at tension" flag the machine turns into the hold LED and the beeper, and the tension
//! estimate it acted on. [`TensionController::release`] starts the homing move and
//! [`TensionController::stop`] coasts at once.
//!
//! Every tick the measurement goes through the [`TensionEstimator`] (median of five, spike
//! clip, Hall-fused observer, rate and speed). Within a pull the drive is always commanded
//! in the pull direction: the switched leg is complementary, so a duty below the back-EMF
//! ratio brakes (`crate::drive::commutation`), and a pull never coasts or reverses.
//!
//! With the **shaped** profile (taut) a pull runs through these phases:
//!
//! 1. [`PullPhase::TakeUp`] — velocity mode: the carriage runs at the speed setting's limit
//!    (duty = back-EMF of that speed + resistive drop of the present tension, accelerating
//!    no harder than the current limit allows), taking up the slack and stretching the
//!    string, while the estimator measures the tension rate `ẏ` and the carriage speed `v`.
//! 2. [`PullPhase::Approach`] — **braking**. A carriage at speed `v` into a string of
//!    stiffness `K = ẏ/v`, braked at a constant deceleration `a`, adds `K·v²/(2a) = ẏ·v/(2a)`
//!    of tension before it stops. The braking starts in the tick where that rise reaches
//!    the gap left to the goal (the peak target less a margin of 0.02 kgf and 20 % of the
//!    rise for the stiffness estimate's error; the tension lag-compensated by the sensing
//!    delay): a comparison of two products, no division. At that tick the string's
//!    stiffness `K̂ = ẏ/v` is identified (one division-free reciprocal), the law's plant is
//!    scaled to it (`ρ = K̄/K̂`, [`Rsmc::set_plant_scale`]) and the observer starts fusing
//!    the Hall travel. The reference then follows the braking parabola exactly —
//!    `ÿ_d = −K̂·a`, from the present tension and rate to the goal with zero rate — and the
//!    law's equivalent control turns `ÿ_d` and `ẏ_d` into the braking force.
//! 3. [`PullPhase::PreStretch`] — with pre-stretch, the reference closes exponentially
//!    (time constant `τ_c`) on the peak `T(1 + p)`, held for
//!    [`ProfileConfig::pre_stretch_dwell_ms`], then
//! 4. [`PullPhase::Settle`] — the reference closes on the final target.
//! 5. [`PullPhase::Hold`] — constant pull at the final target (the reference closing on it
//!    first): the law keeps feeding string as it creeps, the carriage moving in short
//!    stick-slip steps; the **slip damper** ([`SlipDamper`], friction-aware hold) sees each
//!    slip in the motor current within a tick or two and brakes it before it runs to the
//!    next cogging detent. "At tension" latches the first time the estimated tension is
//!    within [`ProfileConfig::at_tension_band`] of the final target in this phase.
//!
//! In the settle and the hold a tension more than [`BACK_OUT_BAND`] above the reference,
//! with the law asking for no pull at all, is **backed out**: the carriage is driven toward
//! home at a speed proportional to the excess (REQ-TEN-17), so a pre-stretch peak or a
//! braking overshoot comes down in a fraction of a second even on a drivetrain that does not
//! back-drive, instead of waiting for the string to creep.
//!
//! With the **step** profile (the paper's simulation, used for the `paper_rsmc` and `pd`
//! baselines) the reference is the target from the first tick and the law acts at once;
//! the phase reads `Approach` until the tension first enters the band, then `Hold`.
//!
//! [`PullPhase::Release`] drives toward home at [`ProfileConfig::release_speed`] (velocity
//! feed-forward, duty at most [`RELEASE_DUTY_MAX`]) until the home switch closes, then goes
//! [`PullPhase::Idle`] and coasts.
//!
//! # Invariant and guarantees
//!
//! [`TensionController::is_valid`] states what every reachable state satisfies (the law's
//! integral, adaptive gain and plant scale within their bounds, the estimator's stiffness
//! within its range, the reference and targets within the tension range). For every valid
//! state and every measurement, [`TensionController::step`] returns a duty within
//! [`crate::drive::DUTY_MAX`] (by the `Duty` type), never panics, and leaves a valid
//! state; `proofs/` checks this part by part with Kani and for the whole step with
//! proptest and a fuzzer.
//!
//! # Fixed point
//!
//! The reference `y_d` is kept in Q31.32 (`i64`) so the exponential closure keeps moving
//! when its per-tick increment is below Q15.16's 15 µkgf; everything else is as in
//! [`crate::tension::law`]. The step has no division: the one reciprocal (the stiffness,
//! at the braking onset) is [`reciprocal_q24`].

use crate::drive::{DUTY_MAX, Direction, DriveCommand, Duty};
use crate::io::LimitSwitches;
use crate::settings::{MmPerSecond, PullKind, PullSettings, TENSION_MAX};
use crate::tension::estimator::{Estimate, EstimatorConfig, EstimatorError, TensionEstimator};
use crate::tension::law::{
    BoundedAdaptation, GainError, Improvements, NominalPlant, Pd, PdGains, Reference, Rsmc,
    RsmcGains, Saturation, mul_q16, mul_wide, narrow, reciprocal_q24, saturate_i32,
};
use crate::tension::motor::{DutyMap, ForceToDuty, MotorError, MotorModel, SpeedEstimator};
use crate::tension::slip::SlipDamper;
use crate::units::{Amps, Kgf, KgfPerSecond, Q16, Seconds, Volts};

/// The most duty a release (homing) move uses: 60 %.
pub const RELEASE_DUTY_MAX: Duty = Duty::from_raw_clamped(39_322);

/// The back-out (REQ-TEN-17): in the settle and the hold, a tension more than this above the
/// reference, with the law asking for no pull at all, is backed out by driving the carriage
/// toward home: 0.03 kgf, above the estimate's noise (≈ 0.005 kgf) so an at-tension string
/// never hunts between pulling and releasing.
pub const BACK_OUT_BAND: Kgf = Kgf(Q16::lit("0.03"));

/// The back-out's carriage speed per kgf of excess, mm/s: 10. The excess then decays with
/// a time constant `1/(10·K)`: 67 ms on the stiffest string (1.5 kgf/mm, still 20 times the
/// sensing lag), 0.7 s on the softest.
pub const BACK_OUT_GAIN: i32 = 10;

/// The back-out's slowest and fastest carriage speeds, mm/s: 1 (a smaller excess still
/// moves the carriage through its static friction) and 20.
pub const BACK_OUT_SPEED: (MmPerSecond, MmPerSecond) =
    (MmPerSecond(Q16::const_from_int(1)), MmPerSecond(Q16::const_from_int(20)));

/// The most duty a back-out uses: 20 % (the velocity feed-forward of 20 mm/s is ≈ 26 %
/// of the 24 V bus; the string pulls the carriage the same way, so little is needed).
pub const BACK_OUT_DUTY_MAX: Duty = Duty::from_raw_clamped(13_107);

/// The shortest and longest control periods accepted: 50 µs to 10 ms.
pub const PERIOD_RANGE_US: (u32, u32) = (50, 10_000);

/// Below this tension the string is still slack (or in its toe) and the braking is not
/// timed: 2 kgf.
pub const TAUT_TENSION: Kgf = Kgf::from_int(2);

/// The softest and stiffest string the identification accepts, kgf/mm: 0.05 and 4.
pub const STIFFNESS_RANGE: (Q16, Q16) = (Q16::lit("0.05"), Q16::const_from_int(4));

/// The slip damper's dead zone: residuals below 0.002 duty (≈ 0.16 mm/s of carriage) are
/// not braked.
pub const SLIP_DEAD_ZONE: Q16 = Q16::lit("0.002");

/// The slip damper's learning rate `μ` per tick, 0.005 (per ampere of winding current).
pub const SLIP_LEARNING_RATE: Q16 = Q16::lit("0.005");

/// The longest sensing lag a profile may declare, 0.1 s.
pub const SENSING_LAG_MAX: Q16 = Q16::lit("0.1");

/// The fastest reference rate, kgf/s (a 4 kgf/mm string at 250 mm/s).
pub const REFERENCE_RATE_MAX: KgfPerSecond = KgfPerSecond::from_int(1_000);

/// Which law computes the force.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum LawConfig {
    /// The robust sliding-mode controller (paper's or taut's, by its improvements).
    Rsmc(RsmcGains),
    /// The PD baseline.
    Pd(PdGains),
}

/// The pull profile's and the estimator's parameters; the switches are taut's improvements
/// outside the law, each measurable on its own (`taut report ablation`).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct ProfileConfig {
    /// Shaped profile (take-up, braking approach, …) or a step set point (the paper's
    /// simulation).
    pub shaped: bool,
    /// The carriage deceleration the braking is planned with, mm/s² (Q15.16).
    pub braking_deceleration: Q16,
    /// The goal of the braking sits this many per cent of the braking rise below the
    /// target, for the stiffness estimate's error.
    pub braking_margin_percent: u8,
    /// … and this much more, kgf.
    pub approach_margin: Kgf,
    /// The time constant `τ_c` of the reference's exponential closure on a target.
    pub closing_time_constant: Seconds,
    /// How long the pre-stretch peak is held, ms.
    pub pre_stretch_dwell_ms: u16,
    /// The band around the final target that counts as "at tension".
    pub at_tension_band: Kgf,
    /// The carriage speed of a release move.
    pub release_speed: MmPerSecond,
    /// Low-pass time constant of the Hall speed the current limit is computed from.
    pub speed_filter: Seconds,
    /// Low-pass time constant of the tension rate and carriage speed that time the braking.
    pub rate_filter: Seconds,
    /// The delay of the tension measurement (conversion, one tick, the median), which the
    /// braking onset compensates.
    pub sensing_lag: Seconds,
    /// Limit the filtered tension's change per tick by the carriage travel.
    pub spike_clip: bool,
    /// The Hall-fused observer's gain per tick (`None`: the law sees the filtered sample).
    pub observer_gain: Option<Q16>,
    /// Scale the law's nominal plant to the identified string stiffness.
    pub adapt_plant: bool,
    /// The observer's gain in the braking (`None`: keep `observer_gain`).
    pub observer_gain_braking: Option<Q16>,
    /// The observer's gain once the braking is over (`None`: keep the gain it had).
    pub observer_gain_hold: Option<Q16>,
    /// Friction-aware hold: damp the carriage's slips, seen in the motor current, with
    /// this many times the stall pull per unit of back-EMF duty (`None`: off).
    pub slip_damping: Option<Q16>,
    /// The stiffness the law's nominal plant was written for, kgf/mm (`K̄ = D̄·M̄`).
    pub nominal_stiffness: Q16,
}

impl ProfileConfig {
    /// Checks every parameter's range, one [`ProfileError`] per check (the controller's
    /// constructor runs it before deriving anything from the profile).
    ///
    /// # Errors
    /// The first parameter out of range.
    pub fn validate(&self) -> Result<(), ProfileError> {
        let check = |ok: bool, error| if ok { Ok(()) } else { Err(error) };
        let slip_ok =
            self.slip_damping.is_none_or(|k| k >= Q16::ZERO && k <= Q16::const_from_int(10));
        check(slip_ok, ProfileError::SlipDamping)?;
        check(self.closing_time_constant.0 > Q16::ZERO, ProfileError::ClosingTimeConstant)?;
        let decel = self.braking_deceleration;
        let decel_ok = decel >= Q16::const_from_int(50) && decel <= Q16::const_from_int(20_000);
        check(decel_ok, ProfileError::BrakingDeceleration)?;
        check(self.braking_margin_percent <= 50, ProfileError::BrakingMargin)?;
        let margin_ok =
            self.approach_margin.0 >= Q16::ZERO && self.approach_margin <= Kgf::from_int(5);
        check(margin_ok, ProfileError::ApproachMargin)?;
        check(self.at_tension_band.0 > Q16::ZERO, ProfileError::AtTensionBand)?;
        check(self.release_speed.0 > Q16::ZERO, ProfileError::ReleaseSpeed)?;
        let lag_ok = self.sensing_lag.0 >= Q16::ZERO && self.sensing_lag.0 <= SENSING_LAG_MAX;
        check(lag_ok, ProfileError::SensingLag)?;
        let stiffness = self.nominal_stiffness;
        let stiffness_ok = stiffness >= STIFFNESS_RANGE.0 && stiffness <= STIFFNESS_RANGE.1;
        check(stiffness_ok, ProfileError::NominalStiffness)
    }

    /// taut's profile.
    pub const TAUT: Self = Self {
        shaped: true,
        braking_deceleration: Q16::const_from_int(1_200),
        braking_margin_percent: 20,
        approach_margin: Kgf(Q16::lit("0.02")),
        closing_time_constant: Seconds(Q16::lit("0.03")),
        pre_stretch_dwell_ms: 300,
        at_tension_band: Kgf(Q16::lit("0.1")),
        release_speed: MmPerSecond::from_int(40),
        speed_filter: Seconds(Q16::lit("0.004")),
        rate_filter: Seconds(Q16::lit("0.016")),
        sensing_lag: Seconds(Q16::lit("0.003")),
        spike_clip: true,
        observer_gain: Some(Q16::lit("0.05")),
        adapt_plant: true,
        observer_gain_braking: Some(Q16::lit("0.02")),
        observer_gain_hold: Some(Q16::lit("0.05")),
        slip_damping: Some(Q16::ONE),
        nominal_stiffness: Q16::lit("0.5"),
    };

    /// A step set point, as in the paper's simulation: no shaping, no observer, no spike
    /// clip, no plant adaptation (the machine's median of five stays).
    pub const STEP: Self = Self {
        shaped: false,
        spike_clip: false,
        observer_gain: None,
        adapt_plant: false,
        slip_damping: None,
        ..Self::TAUT
    };
}

/// Everything a controller is built from.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct ControllerConfig {
    /// The control period (and the sample time of every derivative and integral), µs.
    pub period_us: u32,
    /// The law.
    pub law: LawConfig,
    /// How force becomes duty.
    pub duty_map: DutyMap,
    /// The motor and transmission.
    pub motor: MotorModel,
    /// The pull profile.
    pub profile: ProfileConfig,
}

/// taut's nominal plant, the voltage-driven machine (see `crate::tension::law`): `M̄` = the
/// rotor and gearbox inertia reflected to the carriage (1.6 × 10⁻⁵ kg·m² / (0.2021 mm/rad)²
/// ≈ 392 kg, plus the 2 kg carriage: 394 kg = 40.2 kgf·s²/m); `B̄` = the back-EMF damping
/// the duty map's constants imply, `c_v/c_f` = 6.82 kgf per mm/s = 6 818 kgf·s/m (the
/// screw's own viscous drag is negligible beside it); `K̄` = a mid-range string, 5 kgf/cm
/// = 500 kgf/m. So `Ā = B̄/M̄ ≈ 170 s⁻¹` and `D̄ = K̄/M̄ ≈ 12.4 s⁻²`.
pub const TAUT_PLANT: NominalPlant =
    NominalPlant { a_bar: Q16::const_from_int(170), d_bar: Q16::lit("12.4") };

/// taut's RSMC: the paper's structure with every improvement on. `λ = Ā/2 = 85` makes the
/// `ė` term of the equivalent control vanish (`c_e = (2λ − Ā)/D̄ = 0`), so the noisy
/// tension derivative only enters through `G·s`; the closed loop's bandwidth is then
/// `λ²/Ā ≈ 42 rad/s` for every string (the plant scale normalises `K`).
pub const TAUT_GAINS: RsmcGains = RsmcGains {
    lambda: Q16::const_from_int(85),
    g: Q16::lit("0.1"),
    k_phi_micro: 20_000,
    plant: TAUT_PLANT,
    improvements: Improvements {
        boundary_layer: Some(KgfPerSecond(Q16::const_from_int(20))),
        bounded_adaptation: Some(BoundedAdaptation {
            dead_zone: KgfPerSecond(Q16::const_from_int(2)),
            leakage: Q16::lit("0.5"),
            max: Kgf::from_int(2),
        }),
        anti_windup: Some(KgfPerSecond(Q16::const_from_int(2_000))),
        rate_filter: Some(Seconds(Q16::lit("0.008"))),
    },
};

/// The current every built-in configuration limits the winding to: 8 A.
pub const CURRENT_LIMIT: Amps = Amps::from_int(8);

impl ControllerConfig {
    /// taut's controller at 1 kHz.
    pub const TAUT: Self = Self {
        period_us: 1_000,
        law: LawConfig::Rsmc(TAUT_GAINS),
        duty_map: DutyMap::Proportional { current_limit: CURRENT_LIMIT },
        motor: MotorModel::PAPER,
        profile: ProfileConfig::TAUT,
    };

    /// The paper's RSMC as published (λ = 100, G = 0.2, k_φ = 0.001, `sgn`, unbounded
    /// `φ̂`, raw derivative) on the machine's nominal plant, through the same force → duty
    /// stage as taut (always pulling, a negative force brakes), step set point, at 1 kHz.
    pub const PAPER_RSMC: Self = Self {
        period_us: 1_000,
        law: LawConfig::Rsmc(RsmcGains::paper(TAUT_PLANT)),
        duty_map: DutyMap::Proportional { current_limit: CURRENT_LIMIT },
        motor: MotorModel::PAPER,
        profile: ProfileConfig::STEP,
    };

    /// The paper's PD baseline (`k_p = 100`, `k_d = 20`) through the same force → duty
    /// stage as taut, step set point, at 1 kHz.
    pub const PD: Self = Self {
        period_us: 1_000,
        law: LawConfig::Pd(PdGains::PAPER),
        duty_map: DutyMap::Proportional { current_limit: CURRENT_LIMIT },
        motor: MotorModel::PAPER,
        profile: ProfileConfig::STEP,
    };
}

/// Why a controller configuration was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum ConfigError {
    /// The period is outside [`PERIOD_RANGE_US`].
    Period,
    /// A law gain is out of range.
    Gain(GainError),
    /// The motor model is implausible.
    Motor(MotorError),
    /// A profile parameter is out of range: which one.
    Profile(ProfileError),
    /// An estimator parameter is out of range.
    Estimator(EstimatorError),
}

/// Which profile parameter was refused ([`ProfileConfig::validate`]): one variant per
/// check, so a refused configuration says what to change.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum ProfileError {
    /// `slip_damping` outside 0–10 (or too large for the duty map's stall force).
    SlipDamping,
    /// `closing_time_constant` not positive, or too short or long for the period.
    ClosingTimeConstant,
    /// `braking_deceleration` outside 50–20 000 mm/s².
    BrakingDeceleration,
    /// `braking_margin_percent` above 50.
    BrakingMargin,
    /// `approach_margin` outside 0–5 kgf.
    ApproachMargin,
    /// `at_tension_band` not positive.
    AtTensionBand,
    /// `release_speed` not positive.
    ReleaseSpeed,
    /// `sensing_lag` negative or above [`SENSING_LAG_MAX`].
    SensingLag,
    /// `nominal_stiffness` outside [`STIFFNESS_RANGE`].
    NominalStiffness,
}

/// What the controller is told each tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Measurement {
    /// The calibrated string tension.
    pub tension: Kgf,
    /// The drive's report (Hall step count for carriage speed, fault, rotation).
    pub drive: crate::drive::DriveStatus,
    /// The motor current.
    pub current: Amps,
    /// The carriage limit switches.
    pub limits: LimitSwitches,
    /// The DC bus voltage (the power board's divider); below half the motor model's bus it
    /// counts as no reading and the nominal bus is assumed ([`ForceToDuty::set_bus`]).
    pub bus: Volts,
}

/// Where in a pull the controller is.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub enum PullPhase {
    /// Not driving; the output is coast.
    #[default]
    Idle,
    /// Taking up slack at the speed setting's carriage speed.
    TakeUp,
    /// Braking into the (peak) target.
    Approach,
    /// Holding the pre-stretch peak.
    PreStretch,
    /// Coming down from the peak to the final target.
    Settle,
    /// Constant pull at the final target.
    Hold,
    /// Moving home to loosen the string.
    Release,
}

impl PullPhase {
    /// Every phase, for exhaustive checks.
    pub const ALL: [Self; 7] = [
        Self::Idle,
        Self::TakeUp,
        Self::Approach,
        Self::PreStretch,
        Self::Settle,
        Self::Hold,
        Self::Release,
    ];
}

/// What the controller asks for after a tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct ControlOutput {
    /// The command for the drive.
    pub command: DriveCommand,
    /// The phase after this tick.
    pub phase: PullPhase,
    /// The tension has reached the final target and is being held (hold LED, beeper).
    pub at_tension: bool,
    /// The reference tension `y_d` this tick (for logs and plots).
    pub reference: Kgf,
    /// The law's force this tick, kgf (zero outside the closed-loop phases).
    pub force: Kgf,
    /// The tension the controller acted on: the estimator's (spike-filtered, observed)
    /// tension — what the machine shows.
    pub tension: Kgf,
}

/// The law with its state.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
enum Law {
    Rsmc(Rsmc),
    Pd(Pd),
}

/// The controller's pull-profile state, exposed for proofs and fuzzing.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct ProfileState {
    /// The phase.
    pub phase: PullPhase,
    /// The tension of the pre-stretch peak (= final target without pre-stretch).
    pub peak: Kgf,
    /// The tension held in `Hold`.
    pub final_target: Kgf,
    /// The carriage speed limit of the speed setting.
    pub speed_limit: MmPerSecond,
    /// The reference tension `y_d`, Q31.32.
    pub reference: i64,
    /// The reference rate `ẏ_d`, kgf/s bits.
    pub reference_rate: i32,
    /// The reference's second derivative `ÿ_d`, kgf/s² bits.
    pub reference_accel: i32,
    /// Where the braking parabola ends (shaped) or the set point (step).
    pub goal: Kgf,
    /// Ticks spent in the present phase (saturating).
    pub ticks: u32,
    /// "At tension" latched.
    pub at_tension: bool,
    /// Which way the previous output saturated.
    pub saturated: Saturation,
    /// The law has not run since Start (its memory is reset on the first closed-loop tick).
    pub fresh: bool,
}

/// The tension controller. See the module docs.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct TensionController {
    law: Law,
    map: ForceToDuty,
    speed: SpeedEstimator,
    estimator: TensionEstimator,
    /// The slip damper (`None`: off).
    slip: Option<SlipDamper>,
    shaped: bool,
    adapt_plant: bool,
    /// The observer's gain in the braking.
    braking_gain: Option<Q16>,
    /// The observer's gain after the braking.
    hold_gain: Option<Q16>,
    /// `dt` in Q0.32 seconds.
    dt_q32: i64,
    /// `dt/τ_c`, Q0.32 in an `i64`.
    closing_step: i64,
    /// `1/τ_c`, Q15.16.
    inv_tau: i32,
    /// `1/(2a)`, Q8.24 s²/mm.
    inv_two_decel: i32,
    /// `a`, Q15.16 mm/s².
    decel: i32,
    /// The braking margin, a Q15.16 fraction of the rise.
    margin_fraction: i32,
    /// Approach margin, kgf bits.
    margin: i32,
    /// The sensing lag, Q8.24 s.
    lag_q24: i32,
    /// `K̄`, kgf/mm bits.
    nominal_stiffness: i32,
    dwell_ticks: u32,
    band: i32,
    release_speed: MmPerSecond,
    profile: ProfileState,
    /// The last estimate's tension (what the machine shows between pulls too).
    shown: Kgf,
}

impl Default for TensionController {
    /// taut's controller ([`ControllerConfig::TAUT`]).
    fn default() -> Self {
        Self::taut()
    }
}

/// The sensing lag in whole ticks of `period_us` (rounded, at most the observer's limit).
fn lag_ticks(lag: Seconds, period_us: u32) -> u8 {
    let lag_us = i64::from(lag.to_bits()).saturating_mul(1_000_000) >> 16;
    let ticks = lag_us
        .saturating_add(i64::from(period_us / 2))
        .checked_div(i64::from(period_us))
        .unwrap_or(0);
    let max = i64::try_from(crate::tension::estimator::LAG_TICKS_MAX).unwrap_or(0);
    u8::try_from(ticks.clamp(0, max)).unwrap_or(0)
}

/// `a × b` of a Q15.16 value and a Q8.24 factor, rounded, as Q15.16 bits.
fn mul_q24(a: i32, b_q24: i32) -> i32 {
    saturate_i32(mul_wide(a, b_q24).saturating_add(1 << 23) >> 24)
}

impl TensionController {
    /// A controller built from `config`.
    ///
    /// # Errors
    /// [`ConfigError`] naming what is out of range.
    pub fn new(config: &ControllerConfig) -> Result<Self, ConfigError> {
        let period = config.period_us;
        if period < PERIOD_RANGE_US.0 || period > PERIOD_RANGE_US.1 {
            return Err(ConfigError::Period);
        }
        let law = match config.law {
            LawConfig::Rsmc(gains) => {
                Law::Rsmc(Rsmc::new(&gains, period).map_err(ConfigError::Gain)?)
            }
            LawConfig::Pd(gains) => Law::Pd(Pd::new(&gains, period).map_err(ConfigError::Gain)?),
        };
        let map = ForceToDuty::new(&config.motor, config.duty_map).map_err(ConfigError::Motor)?;
        let p = config.profile;
        p.validate().map_err(ConfigError::Profile)?;
        const TAU_REFUSED: ConfigError = ConfigError::Profile(ProfileError::ClosingTimeConstant);
        let speed = SpeedEstimator::new(period, p.speed_filter).map_err(ConfigError::Motor)?;
        let estimator = TensionEstimator::new(
            &EstimatorConfig {
                spike_clip: p.spike_clip,
                observer_gain: p.observer_gain,
                rate_filter: p.rate_filter,
                lag_ticks: lag_ticks(p.sensing_lag, period),
            },
            period,
        )
        .map_err(ConfigError::Estimator)?;
        let slip = match p.slip_damping {
            None => None,
            Some(k) => {
                // Range checked by `validate` above.
                // k·F_stall with F_stall = 1/c_f (kgf per unit duty); the stall relation
                // starts from the model's R/V (duty per ampere).
                let stall = (1_i64 << 40)
                    .checked_div(i64::from(map.duty_per_kgf_q24()))
                    .and_then(|v| i32::try_from(v).ok())
                    .ok_or(ConfigError::Profile(ProfileError::SlipDamping))?;
                let gain = Q16::from_bits(stall).saturating_mul(k);
                // R / V as Q15.16, in 64 bits: mΩ and mV are each validated up to 60 000, beyond
                // Q15.16's integer range, so they must not be converted on their own.
                let per_amp = (i64::from(config.motor.resistance_mohm) << 16)
                    .checked_div(i64::from(config.motor.bus_mv))
                    .and_then(|bits| i32::try_from(bits).ok())
                    .map(Q16::from_bits)
                    .ok_or(ConfigError::Motor(MotorError::Parameter))?;
                Some(SlipDamper::new(gain, SLIP_DEAD_ZONE, SLIP_LEARNING_RATE, per_amp))
            }
        };
        let tau = p.closing_time_constant.0;
        let decel = p.braking_deceleration;
        // Construction-time constants (divisions allowed here, never in the step).
        let dt_q32 = (i64::from(period) << 32).checked_div(1_000_000).ok_or(ConfigError::Period)?;
        let tau_us = i64::from(tau.to_bits()).saturating_mul(1_000_000) >> 16;
        let closing_step = (i64::from(period) << 32).checked_div(tau_us).ok_or(TAU_REFUSED)?;
        if closing_step <= 0 || closing_step >= (1_i64 << 32) {
            return Err(TAU_REFUSED);
        }
        let inv_tau = Q16::ONE.checked_div(tau).ok_or(TAU_REFUSED)?.to_bits();
        let two_decel = i64::from(decel.to_bits()).saturating_mul(2);
        let inv_two_decel = i32::try_from((1_i64 << 40).checked_div(two_decel).unwrap_or(0))
            .map_err(|_| ConfigError::Profile(ProfileError::BrakingDeceleration))?;
        let margin_fraction =
            Q16::const_from_int(i32::from(p.braking_margin_percent)).saturating_div_int(100);
        Ok(Self {
            law,
            map,
            speed,
            estimator,
            slip,
            shaped: p.shaped,
            adapt_plant: p.adapt_plant,
            braking_gain: p.observer_gain_braking,
            hold_gain: p.observer_gain_hold,
            dt_q32,
            closing_step,
            inv_tau,
            inv_two_decel,
            decel: decel.to_bits(),
            margin_fraction: margin_fraction.to_bits(),
            margin: p.approach_margin.to_bits(),
            lag_q24: p.sensing_lag.0.to_bits().saturating_mul(256),
            nominal_stiffness: p.nominal_stiffness.to_bits(),
            dwell_ticks: u32::from(p.pre_stretch_dwell_ms)
                .saturating_mul(1_000)
                .checked_div(period)
                .unwrap_or(0),
            band: p.at_tension_band.to_bits(),
            release_speed: p.release_speed,
            profile: ProfileState::default(),
            shown: Kgf::ZERO,
        })
    }

    /// taut's controller at 1 kHz ([`ControllerConfig::TAUT`]).
    #[must_use]
    pub fn taut() -> Self {
        // TAUT is a constant whose validity a unit test checks; should it ever fail, the
        // paper's PD (also checked) is a safe, if worse, fallback — never a panic.
        Self::new(&ControllerConfig::TAUT)
            .or_else(|_| Self::new(&ControllerConfig::PD))
            .unwrap_or(Self::fallback())
    }

    /// A controller whose every output is zero duty (it can only brake), reachable only if
    /// the built-in configurations were broken — a unit test checks they are not.
    fn fallback() -> Self {
        Self {
            law: Law::Pd(Pd::ZERO),
            map: ForceToDuty::ZERO,
            speed: SpeedEstimator::ZERO,
            estimator: TensionEstimator::FALLBACK,
            slip: None,
            shaped: false,
            adapt_plant: false,
            braking_gain: None,
            hold_gain: None,
            dt_q32: 4_294_967,
            closing_step: 1 << 27,
            inv_tau: 32 << 16,
            inv_two_decel: 1 << 12,
            decel: 1_000 << 16,
            margin_fraction: 0,
            margin: 0,
            lag_q24: 0,
            nominal_stiffness: 1 << 15,
            dwell_ticks: 0,
            band: 6_554,
            release_speed: MmPerSecond::from_int(20),
            profile: ProfileState::default(),
            shown: Kgf::ZERO,
        }
    }

    /// Arms a pull of `kind` with `settings`; the next [`TensionController::step`] starts
    /// driving.
    pub fn start(&mut self, settings: &PullSettings, kind: PullKind) {
        let peak = settings.peak_target(kind);
        let final_target = settings.final_target(kind);
        self.speed.reset();
        self.estimator.reset();
        if let Some(slip) = &mut self.slip {
            slip.reset();
        }
        if let Law::Rsmc(rsmc) = &mut self.law {
            rsmc.set_plant_scale(Q16::ONE);
        }
        self.profile = ProfileState {
            phase: if self.shaped { PullPhase::TakeUp } else { PullPhase::Approach },
            peak,
            final_target,
            speed_limit: settings.speed().carriage_limit(),
            reference: i64::from(peak.to_bits()) << 16,
            reference_rate: 0,
            reference_accel: 0,
            goal: peak,
            ticks: 0,
            at_tension: false,
            saturated: Saturation::None,
            fresh: true,
        };
    }

    /// Starts the release (homing) move.
    pub fn release(&mut self) {
        self.profile.phase = PullPhase::Release;
        self.profile.ticks = 0;
        self.profile.at_tension = false;
    }

    /// Stops at once: idle, coasting.
    pub fn stop(&mut self) {
        self.profile.phase = PullPhase::Idle;
        self.profile.ticks = 0;
        self.profile.at_tension = false;
    }

    /// The present phase.
    #[must_use]
    pub const fn phase(&self) -> PullPhase {
        self.profile.phase
    }

    /// The profile state (for logs, proofs and fuzzing).
    #[must_use]
    pub const fn profile_state(&self) -> ProfileState {
        self.profile
    }

    /// Replaces the profile state (proofs and fuzzing); the guarantees hold for states that
    /// satisfy [`TensionController::is_valid`].
    pub fn set_profile_state(&mut self, profile: ProfileState) {
        self.profile = profile;
    }

    /// The law's RSMC, if it is one (for proofs, fuzzing and plots).
    #[must_use]
    pub fn rsmc_mut(&mut self) -> Option<&mut Rsmc> {
        match &mut self.law {
            Law::Rsmc(rsmc) => Some(rsmc),
            Law::Pd(_) => None,
        }
    }

    /// The Hall speed estimator (for proofs and fuzzing).
    pub fn speed_estimator_mut(&mut self) -> &mut SpeedEstimator {
        &mut self.speed
    }

    /// The tension estimator (for proofs and fuzzing).
    pub fn estimator_mut(&mut self) -> &mut TensionEstimator {
        &mut self.estimator
    }

    /// The slip damper, if configured (for proofs and fuzzing).
    pub fn slip_damper_mut(&mut self) -> Option<&mut SlipDamper> {
        self.slip.as_mut()
    }

    /// The invariant every reachable state satisfies: the law's and the estimator's own
    /// invariants, targets and reference within `[0, TENSION_MAX]`, the peak at or above
    /// the final target.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let law_ok = match &self.law {
            Law::Rsmc(rsmc) => rsmc.is_valid(),
            Law::Pd(_) => true,
        };
        let p = &self.profile;
        let in_range = |value: Kgf| value >= Kgf::ZERO && value <= TENSION_MAX;
        let reference_ok =
            p.reference >= 0 && p.reference <= i64::from(TENSION_MAX.to_bits()) << 16;
        law_ok
            && self.estimator.is_valid()
            && in_range(p.peak)
            && in_range(p.final_target)
            && in_range(p.goal)
            && p.final_target <= p.peak
            && reference_ok
    }

    /// The reference tension `y_d` (Q15.16).
    fn reference_kgf(&self) -> Kgf {
        Kgf::from_bits(saturate_i32(self.profile.reference.saturating_add(1 << 15) >> 16))
    }

    /// Enters `phase`.
    fn enter(&mut self, phase: PullPhase) {
        self.profile.phase = phase;
        self.profile.ticks = 0;
    }

    /// Sets the reference, clamped to `[0, TENSION_MAX]` (Q31.32).
    fn set_reference(&mut self, reference: i64) {
        let max = i64::from(TENSION_MAX.to_bits()) << 16;
        self.profile.reference = reference.clamp(0, max);
    }

    /// The tension a braking carriage still adds, `ẏ·v/(2a)`, kgf bits (see the module
    /// docs), and the lag-compensated tension `y + ẏ·t_lag`.
    fn braking_rise(&self, est: &Estimate) -> (i32, i32) {
        let rate = est.rate.to_bits().max(0);
        let speed = est.speed.0.to_bits().max(0);
        let rise = mul_q24(narrow(mul_wide(rate, speed)), self.inv_two_decel);
        let predicted = est.sample.to_bits().saturating_add(mul_q24(rate, self.lag_q24));
        (rise, predicted)
    }

    /// The braking's goal for a rise of `rise`: the peak less the margins, kgf bits.
    fn braking_goal(&self, rise: i32) -> i32 {
        self.profile
            .peak
            .to_bits()
            .saturating_sub(self.margin)
            .saturating_sub(mul_q16(rise, self.margin_fraction))
    }

    /// Whether the take-up must start braking this tick (division-free: see the module docs).
    fn braking_due(&self, est: &Estimate) -> bool {
        let (rise, predicted) = self.braking_rise(est);
        let goal = self.braking_goal(rise);
        let taut = est.sample >= TAUT_TENSION;
        (taut && predicted.saturating_add(rise) >= goal)
            || predicted >= self.profile.peak.to_bits().saturating_sub(self.margin)
    }

    /// Starts the braking: identifies the stiffness, scales the law, plans the parabola.
    fn begin_braking(&mut self, est: &Estimate) {
        let (rise, predicted) = self.braking_rise(est);
        let rate = est.rate.to_bits().clamp(0, REFERENCE_RATE_MAX.to_bits());
        // K̂ = ẏ/v, with v at least 1 mm/s (a still carriage gives the nominal string).
        let speed = est.speed.0.to_bits();
        let stiffness = if speed >= Q16::ONE.to_bits() {
            mul_q24(rate, reciprocal_q24(speed))
        } else {
            self.nominal_stiffness
        }
        .clamp(STIFFNESS_RANGE.0.to_bits(), STIFFNESS_RANGE.1.to_bits());
        if self.adapt_plant {
            let scale = mul_q24(self.nominal_stiffness, reciprocal_q24(stiffness));
            if let Law::Rsmc(rsmc) = &mut self.law {
                rsmc.set_plant_scale(Q16::from_bits(scale));
            }
        }
        self.estimator.set_stiffness(Q16::from_bits(stiffness));
        if let Some(alpha) = self.braking_gain {
            self.estimator.set_observer_gain(alpha);
        }
        let start = predicted.clamp(0, self.profile.peak.to_bits());
        self.estimator.set_tension(Kgf::from_bits(start));
        let goal = self.braking_goal(rise).clamp(start, self.profile.peak.to_bits());
        self.profile.goal = Kgf::from_bits(goal);
        self.set_reference(i64::from(start) << 16);
        self.profile.reference_rate = rate;
        // ÿ_d = −K̂·a.
        self.profile.reference_accel = narrow(mul_wide(stiffness, self.decel)).saturating_neg();
        self.profile.fresh = true;
        self.enter(PullPhase::Approach);
    }

    /// One tick of the braking parabola; ends at the goal with zero rate.
    fn advance_braking(&mut self) -> (i32, i32) {
        let p = self.profile;
        let dv = saturate_i32(i64::from(p.reference_accel).saturating_mul(self.dt_q32) >> 32);
        let next_rate = p.reference_rate.saturating_add(dv);
        let mean_rate = i64::from(p.reference_rate).saturating_add(i64::from(next_rate)) >> 1;
        let advanced = p.reference.saturating_add(mean_rate.saturating_mul(self.dt_q32) >> 16);
        let goal = i64::from(p.goal.to_bits()) << 16;
        if next_rate <= 0 || advanced >= goal {
            self.set_reference(goal);
            self.profile.reference_rate = 0;
            self.profile.reference_accel = 0;
            let next =
                if p.peak > p.final_target { PullPhase::PreStretch } else { PullPhase::Hold };
            self.enter(next);
            self.end_braking();
            (0, 0)
        } else {
            self.set_reference(advanced);
            self.profile.reference_rate = next_rate;
            (next_rate, p.reference_accel)
        }
    }

    /// The braking is over: from here the carriage moves by single Hall steps at most, and
    /// the observer (still fusing them) takes its hold gain.
    fn end_braking(&mut self) {
        if let Some(alpha) = self.hold_gain {
            self.estimator.set_observer_gain(alpha);
        }
    }

    /// One tick of the exponential closure on `target`; returns `(ẏ_d, ÿ_d)` bits.
    fn advance_closing(&mut self, target: Kgf) -> (i32, i32) {
        let goal = i64::from(target.to_bits()) << 16;
        let gap = goal.saturating_sub(self.profile.reference);
        // y_d += gap·dt/τ (Q31.32 × Q0.32 → split the product to stay in 64 bits).
        let step = (gap >> 16).saturating_mul(self.closing_step) >> 16;
        let step = if step == 0 && gap != 0 { gap.signum() } else { step };
        self.set_reference(self.profile.reference.saturating_add(step));
        let gap_bits = saturate_i32(goal.saturating_sub(self.profile.reference) >> 16);
        let rate = narrow(mul_wide(gap_bits, self.inv_tau));
        let accel = narrow(mul_wide(rate, self.inv_tau)).saturating_neg();
        self.profile.reference_rate = rate;
        self.profile.reference_accel = accel;
        (rate, accel)
    }

    /// One control tick.
    pub fn step(&mut self, m: &Measurement) -> ControlOutput {
        let speed = self.speed.update(m.drive.steps);
        self.map.set_bus(m.bus);
        let est = self.estimator.update(m.tension, m.drive.steps);
        self.shown = est.tension;
        let holding = self.profile.phase == PullPhase::Hold;
        let slip_brake = match &mut self.slip {
            Some(slip) => slip.update(m.current, est.steps, holding),
            None => Kgf::ZERO,
        };
        self.profile.ticks = self.profile.ticks.saturating_add(1);

        let mut force = Kgf::ZERO;
        let command = match self.profile.phase {
            PullPhase::Idle => DriveCommand::Coast,
            PullPhase::Release => {
                if m.limits.home {
                    self.enter(PullPhase::Idle);
                    DriveCommand::Coast
                } else {
                    // Back-driven by the string: only the back-EMF of the release speed.
                    let duty =
                        self.map.velocity_duty(self.release_speed, Kgf::ZERO, RELEASE_DUTY_MAX);
                    DriveCommand::Drive { direction: Direction::Release, duty }
                }
            }
            PullPhase::TakeUp => {
                if self.braking_due(&est) {
                    self.begin_braking(&est);
                    self.closed_loop(&est, speed, Kgf::ZERO, &mut force)
                } else {
                    // Run at the speed limit, accelerating no harder than the current
                    // limit allows.
                    let load = Kgf::from_bits(est.sample.to_bits().max(0));
                    let cruise = self.map.velocity_duty(self.profile.speed_limit, load, DUTY_MAX);
                    let limited = self.map.current_limited_duty(speed);
                    let duty = if limited < cruise { limited } else { cruise };
                    DriveCommand::Drive { direction: Direction::Pull, duty }
                }
            }
            PullPhase::Approach | PullPhase::PreStretch | PullPhase::Settle | PullPhase::Hold => {
                self.closed_loop(&est, speed, slip_brake, &mut force)
            }
        };
        if let Some(slip) = &mut self.slip {
            slip.note_duty(command.duty());
        }
        ControlOutput {
            command,
            phase: self.profile.phase,
            at_tension: self.profile.at_tension,
            reference: self.reference_kgf(),
            force,
            tension: est.tension,
        }
    }

    /// The closed-loop phases: advance the profile, run the law, map to duty.
    fn closed_loop(
        &mut self,
        est: &Estimate,
        speed: MmPerSecond,
        slip_brake: Kgf,
        force_out: &mut Kgf,
    ) -> DriveCommand {
        let y = est.tension;
        let phase = self.profile.phase;
        let (rate, accel) = if self.shaped {
            match phase {
                PullPhase::Approach => self.advance_braking(),
                PullPhase::PreStretch => self.advance_closing(self.profile.peak),
                _ => self.advance_closing(self.profile.final_target),
            }
        } else {
            let set_point = match phase {
                PullPhase::Approach | PullPhase::PreStretch => self.profile.peak,
                _ => self.profile.final_target,
            };
            self.profile.goal = set_point;
            self.set_reference(i64::from(set_point.to_bits()) << 16);
            (0, 0)
        };
        let reference = Reference {
            tension: self.reference_kgf(),
            rate: KgfPerSecond::from_bits(rate),
            accel: Q16::from_bits(accel),
        };
        if self.profile.fresh {
            // No derivative kick: the law starts from the present error.
            self.profile.fresh = false;
            let e0 = reference.tension.saturating_sub(y);
            match &mut self.law {
                Law::Rsmc(rsmc) => rsmc.reset(e0),
                Law::Pd(pd) => pd.reset(e0),
            }
        }
        let force = match &mut self.law {
            Law::Rsmc(rsmc) => rsmc.step(&reference, y, self.profile.saturated).force,
            Law::Pd(pd) => pd.step(&reference, y),
        }
        .saturating_sub(slip_brake);
        let (command, saturated) = self.map.command(force, speed);
        let command = if self.shaped && matches!(phase, PullPhase::Settle | PullPhase::Hold) {
            self.back_out(command, y)
        } else {
            command
        };
        self.profile.saturated = saturated;
        *force_out = force;
        self.transitions(phase, y);
        command
    }

    /// REQ-TEN-17, the back-out: the law's `command` unless it asks for no pull at all while
    /// the tension `y` is more than [`BACK_OUT_BAND`] above the reference; then a release at
    /// [`BACK_OUT_GAIN`] mm/s per kgf of excess (within [`BACK_OUT_SPEED`], duty at most
    /// [`BACK_OUT_DUTY_MAX`]). A drivetrain that does not back-drive (a self-locking screw,
    /// forward efficiency ≤ 0.5) holds a pre-stretch peak or a braking overshoot against
    /// the short-braked motor until the string creeps down — seconds, 4.8 kgf still over a
    /// 25 kgf target 1 s after a 20 % pre-stretch on the family's least efficient machine.
    /// The reversal itself is the drive's (REQ-DRV-08: energised toward home only once the
    /// rotor's back-EMF against it is below the current limit's).
    fn back_out(&self, command: DriveCommand, y: Kgf) -> DriveCommand {
        let excess = y.saturating_sub(self.reference_kgf());
        if !command.duty().is_zero() || excess <= BACK_OUT_BAND {
            return command;
        }
        let (slowest, fastest) = BACK_OUT_SPEED;
        let speed =
            MmPerSecond(excess.0.saturating_mul_int(BACK_OUT_GAIN).clamp(slowest.0, fastest.0));
        let duty = self.map.velocity_duty(speed, Kgf::ZERO, BACK_OUT_DUTY_MAX);
        DriveCommand::Drive { direction: Direction::Release, duty }
    }

    /// The phase changes that depend on the tension (the braking's end is in
    /// [`Self::advance_braking`]).
    fn transitions(&mut self, phase: PullPhase, y: Kgf) {
        let p = self.profile;
        let error_to = |target: Kgf| y.to_bits().saturating_sub(target.to_bits()).saturating_abs();
        let closed_on = |target: Kgf| {
            let goal = i64::from(target.to_bits()) << 16;
            goal.saturating_sub(p.reference).abs() < (1 << 22)
        };
        let peak_above = p.peak > p.final_target;
        match phase {
            PullPhase::Approach if !self.shaped => {
                if error_to(p.peak) <= self.band {
                    self.enter(if peak_above { PullPhase::PreStretch } else { PullPhase::Hold });
                }
            }
            PullPhase::PreStretch => {
                if p.ticks >= self.dwell_ticks {
                    self.enter(PullPhase::Settle);
                }
            }
            PullPhase::Settle => {
                let arrived = if self.shaped {
                    closed_on(p.final_target)
                } else {
                    error_to(p.final_target) <= self.band
                };
                if arrived {
                    self.enter(PullPhase::Hold);
                }
            }
            PullPhase::Hold => {
                if error_to(p.final_target) <= self.band {
                    self.profile.at_tension = true;
                }
            }
            PullPhase::Approach | PullPhase::Idle | PullPhase::TakeUp | PullPhase::Release => {}
        }
    }

    /// The tension last estimated (what the machine shows).
    #[must_use]
    pub const fn tension(&self) -> Kgf {
        self.shown
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::DriveStatus;
    use crate::settings::{KnotBoost, PreStretch, Speed};
    use crate::test_support::valid;

    #[test]
    fn built_in_configurations_are_valid() {
        for config in [ControllerConfig::TAUT, ControllerConfig::PAPER_RSMC, ControllerConfig::PD] {
            let controller = valid(TensionController::new(&config));
            assert!(controller.is_valid());
        }
        assert_ne!(TensionController::taut(), TensionController::fallback());
        assert!(TensionController::fallback().is_valid());
    }

    #[test]
    fn any_validated_motor_builds_without_panicking() {
        // Bus voltages and resistances up to the validated 60 V / 60 Ω lie beyond Q15.16's
        // integer range in millivolts and milliohms; construction must still be total.
        for bus_mv in [5_000, 24_000, 32_768, 48_000, 60_000] {
            for resistance_mohm in [1, 846, 60_000] {
                let motor = MotorModel { bus_mv, resistance_mohm, ..ControllerConfig::TAUT.motor };
                let config = ControllerConfig { motor, ..ControllerConfig::TAUT };
                if let Ok(controller) = TensionController::new(&config) {
                    assert!(controller.is_valid(), "{bus_mv} mV, {resistance_mohm} mΩ");
                }
            }
        }
        let motor = MotorModel { bus_mv: 48_000, ..ControllerConfig::TAUT.motor };
        let config = ControllerConfig { motor, ..ControllerConfig::TAUT };
        assert!(TensionController::new(&config).is_ok(), "a 48 V bus is a valid machine");
    }

    #[test]
    fn rejects_bad_periods() {
        let config = ControllerConfig { period_us: 20_000, ..ControllerConfig::TAUT };
        assert_eq!(TensionController::new(&config), Err(ConfigError::Period));
        let bad = ProfileConfig { braking_deceleration: Q16::ZERO, ..ProfileConfig::TAUT };
        let config = ControllerConfig { profile: bad, ..ControllerConfig::TAUT };
        assert_eq!(
            TensionController::new(&config),
            Err(ConfigError::Profile(ProfileError::BrakingDeceleration))
        );
    }

    /// Each profile check names its own parameter, at both ends of its range.
    #[test]
    fn each_profile_check_names_its_parameter() {
        let t = ProfileConfig::TAUT;
        assert_eq!(t.validate(), Ok(()));
        let cases = [
            (
                ProfileConfig { slip_damping: Some(Q16::const_from_int(11)), ..t },
                ProfileError::SlipDamping,
            ),
            (
                ProfileConfig { slip_damping: Some(Q16::from_bits(-1)), ..t },
                ProfileError::SlipDamping,
            ),
            (
                ProfileConfig { closing_time_constant: Seconds(Q16::ZERO), ..t },
                ProfileError::ClosingTimeConstant,
            ),
            (
                ProfileConfig { braking_deceleration: Q16::const_from_int(49), ..t },
                ProfileError::BrakingDeceleration,
            ),
            (
                ProfileConfig { braking_deceleration: Q16::const_from_int(20_001), ..t },
                ProfileError::BrakingDeceleration,
            ),
            (ProfileConfig { braking_margin_percent: 51, ..t }, ProfileError::BrakingMargin),
            (
                ProfileConfig { approach_margin: Kgf::from_bits(-1), ..t },
                ProfileError::ApproachMargin,
            ),
            (
                ProfileConfig { approach_margin: Kgf::from_bits((5 << 16) + 1), ..t },
                ProfileError::ApproachMargin,
            ),
            (ProfileConfig { at_tension_band: Kgf::ZERO, ..t }, ProfileError::AtTensionBand),
            (
                ProfileConfig { release_speed: MmPerSecond(Q16::ZERO), ..t },
                ProfileError::ReleaseSpeed,
            ),
            (
                ProfileConfig { sensing_lag: Seconds(Q16::from_bits(-1)), ..t },
                ProfileError::SensingLag,
            ),
            (ProfileConfig { nominal_stiffness: Q16::ZERO, ..t }, ProfileError::NominalStiffness),
        ];
        for (profile, error) in cases {
            assert_eq!(profile.validate(), Err(error), "{profile:?}");
            let config = ControllerConfig { profile, ..ControllerConfig::TAUT };
            assert_eq!(TensionController::new(&config), Err(ConfigError::Profile(error)));
        }
        // The ends of each range pass.
        let edges = ProfileConfig {
            slip_damping: Some(Q16::const_from_int(10)),
            braking_deceleration: Q16::const_from_int(20_000),
            braking_margin_percent: 50,
            approach_margin: Kgf::from_int(5),
            sensing_lag: Seconds(SENSING_LAG_MAX),
            ..t
        };
        assert_eq!(edges.validate(), Ok(()));
    }

    #[test]
    fn start_release_stop_walk_the_phases() {
        let mut controller = TensionController::taut();
        let idle = controller.step(&Measurement::default());
        assert_eq!(idle.command, DriveCommand::Coast);
        let settings = valid(PullSettings::new(
            Kgf::from_int(20),
            Speed::MAX,
            PreStretch::NONE,
            KnotBoost::NONE,
        ));
        controller.start(&settings, PullKind::Main);
        let out = controller.step(&Measurement::default());
        assert_eq!(out.phase, PullPhase::TakeUp);
        assert_eq!(out.command.direction(), Some(Direction::Pull));
        controller.release();
        let out = controller.step(&Measurement::default());
        assert_eq!(out.command.direction(), Some(Direction::Release));
        assert!(out.command.duty() <= RELEASE_DUTY_MAX);
        let home = Measurement {
            limits: LimitSwitches { home: true, end: false },
            ..Measurement::default()
        };
        let out = controller.step(&home);
        assert_eq!((out.phase, out.command), (PullPhase::Idle, DriveCommand::Coast));
        controller.start(&settings, PullKind::Main);
        controller.stop();
        assert_eq!(controller.step(&Measurement::default()).command, DriveCommand::Coast);
    }

    /// A taut controller settled in `phase` at a 25 kgf reference, the law primed by `ticks`
    /// steps at `tension`; the last output.
    fn held_at(phase: PullPhase, tension: Kgf, ticks: u16) -> ControlOutput {
        let mut controller = TensionController::taut();
        let settings = valid(PullSettings::new(
            Kgf::from_int(25),
            Speed::MAX,
            PreStretch::NONE,
            KnotBoost::NONE,
        ));
        controller.start(&settings, PullKind::Main);
        let mut profile = controller.profile_state();
        profile.phase = phase;
        profile.reference = i64::from(Kgf::from_int(25).to_bits()) << 16;
        profile.goal = Kgf::from_int(25);
        controller.set_profile_state(profile);
        let m = Measurement { tension, ..Measurement::default() };
        let mut out = controller.step(&m);
        for _ in 1..ticks {
            out = controller.step(&m);
        }
        out
    }

    #[test]
    fn an_excess_beyond_the_band_is_backed_out_in_the_settle_and_the_hold_only() {
        let above = |excess: Kgf| Kgf::from_int(25).saturating_add(excess);
        for phase in [PullPhase::Settle, PullPhase::Hold] {
            // 0.5 kgf over: toward home at 5 mm/s, within the back-out's duty cap.
            let out = held_at(phase, above(Kgf::from_tenths(5)), 50);
            assert_eq!(out.command.direction(), Some(Direction::Release), "{phase:?}");
            assert!(out.command.duty() <= BACK_OUT_DUTY_MAX);
            assert!(!out.command.duty().is_zero());
            // 5 kgf over: the speed is capped at 20 mm/s, the duty at the cap.
            let far = held_at(phase, above(Kgf::from_int(5)), 50);
            assert_eq!(far.command.direction(), Some(Direction::Release));
            assert!(far.command.duty() >= out.command.duty());
            assert!(far.command.duty() <= BACK_OUT_DUTY_MAX);
            // Exactly the band over: the law's own (pulling) command.
            let at_band = held_at(phase, above(BACK_OUT_BAND), 50);
            assert_eq!(at_band.command.direction(), Some(Direction::Pull), "{phase:?}");
            let below = held_at(phase, Kgf::from_tenths(249), 50);
            assert_eq!(below.command.direction(), Some(Direction::Pull));
        }
        // The speed grows with the excess: 0.1 kgf over moves slower than 0.5 kgf over.
        let slow = held_at(PullPhase::Hold, above(Kgf::from_tenths(1)), 50);
        let fast = held_at(PullPhase::Hold, above(Kgf::from_tenths(5)), 50);
        assert_eq!(slow.command.direction(), Some(Direction::Release));
        assert!(slow.command.duty() < fast.command.duty());
        // Never during the braking approach or the pre-stretch peak.
        for phase in [PullPhase::Approach, PullPhase::PreStretch] {
            let out = held_at(phase, above(Kgf::from_int(5)), 1);
            assert_ne!(out.command.direction(), Some(Direction::Release), "{phase:?}");
        }
    }

    /// A carriage pulled at one Hall step per tick into a `stiffness_milli` kgf/mm string
    /// whose slack ends at `slack_steps` (an ideal plant: the controller only decides when).
    fn braking_onset(stiffness_milli: i64, target: i32) -> (i32, Kgf) {
        let mut controller = TensionController::taut();
        let settings = valid(PullSettings::new(
            Kgf::from_int(valid(i16::try_from(target))),
            Speed::MAX,
            PreStretch::NONE,
            KnotBoost::NONE,
        ));
        controller.start(&settings, PullKind::Main);
        let slack_steps = 100_i64;
        for tick in 0..4_000_i32 {
            let steps = i64::from(tick);
            let stretch_nm = (steps - slack_steps).max(0) * 52_917;
            let tension_bits = stretch_nm * stiffness_milli * 65_536 / 1_000_000_000;
            let m = Measurement {
                tension: Kgf::from_bits(valid(i32::try_from(tension_bits))),
                drive: DriveStatus { steps: tick, ..DriveStatus::default() },
                ..Measurement::default()
            };
            let out = controller.step(&m);
            if out.phase == PullPhase::Approach {
                return (tick, m.tension);
            }
        }
        (-1, Kgf::ZERO)
    }

    #[test]
    fn braking_starts_when_the_remaining_gap_equals_the_braking_rise() {
        // At 52.917 mm/s and a = 1 200 mm/s² the carriage stops in v²/(2a) = 1.167 mm: a
        // 1 kgf/mm string gains 1.167 kgf, a 0.2 kgf/mm one 0.233 kgf. The braking starts
        // that far below the target, plus 5 % of it and 0.02 kgf of margin, plus the 3 ms
        // the tension measurement lags at the rate `v·K`.
        for stiffness_milli in [1_000_i64, 200] {
            let (_, at) = braking_onset(stiffness_milli, 25);
            let gap = i64::from(25_000 - at.to_milli());
            let rise = 52_917 * 52_917 * stiffness_milli / 2_400_000_000;
            let rate_per_tick = 52_917 * stiffness_milli / 1_000_000; // mkgf per ms
            let predicted = rise * 105 / 100 + 20 + 3 * rate_per_tick;
            // Within 6 % (the rate filter's settling) and one tick of travel.
            let tolerance = predicted * 6 / 100 + rate_per_tick;
            assert!(
                (gap - predicted).abs() <= tolerance,
                "K {stiffness_milli} mkgf/mm: gap {gap} mkgf, predicted {predicted}"
            );
        }
    }
}

//! The pull profile: the phases of a pull and the reference tension the law follows in each.
//!
//! # Theory of operation
//!
//! A [`Profile`] is the pull's own state machine, inside the controller: [`PullPhase`] says
//! where the pull is (take-up, braking approach, pre-stretch, settle, hold, release), and the
//! reference generator says where the tension should be this tick, `y_d`, with its rate
//! `ẏ_d` and acceleration `ÿ_d` ([`Reference`]), for the law's equivalent control. The
//! controller ([`crate::tension::controller`]) owns the profile, asks it each tick, and
//! applies what the profile identifies (the string's stiffness at the braking onset, the
//! end of the braking) to the estimator and the law; the profile itself touches neither.
//!
//! - **Take-up identification** ([`Profile::observe_take_up`], REQ-ID-06): the take-up
//!   accelerates from rest at the drive's current limit, so the ticks its speed takes from a
//!   quarter to three quarters of the speed limit measure the acceleration this machine's
//!   carriage and rotor allow. The braking is planned at [`BRAKING_PER_TAKE_UP`] times it
//!   where that is below [`ProfileConfig::braking_deceleration`]: a heavier rotor, a weaker
//!   motor or a low bus brakes from further out instead of overshooting, while a machine that
//!   can brake harder than configured keeps the configured plan.
//! - **Gripper identification** (the same window, REQ-ID-07): the gripper hangs on the load
//!   cell outboard of it, so the cell carries the string's pull *less* the force that
//!   accelerates the gripper, `F = T − m_g·a`. In the take-up the string is slack and the
//!   cell reads `m_g·a_t` above its reading at rest; summed over the window that is the
//!   momentum `m_g·Δv`, which gives `m_g`. While the carriage brakes at `a` the cell reads
//!   `m_g·a` low (a 1.1 kg gripper braked at 1.3 m/s²: 0.15 kgf) — a tension the braking
//!   parabola would otherwise drive on into — so the controller adds
//!   [`Profile::gripper_bias`] to the reading
//!   for the observer in [`PullPhase::Approach`].
//! - **Braking onset** ([`Profile::braking_due`]): a carriage at speed `v` into a string of
//!   stiffness `K = ẏ/v`, braked at a constant deceleration `a`, adds `ẏ·v/(2a)` of tension
//!   before it stops; the braking starts in the tick where that rise reaches the gap to the
//!   goal (the peak less [`ProfileConfig::approach_margin`] and
//!   [`ProfileConfig::braking_margin_percent`] of the rise; the tension lag-compensated by
//!   [`ProfileConfig::sensing_lag`]) — two products compared, no division.
//! - **Braking parabola** ([`Profile::begin_braking`], then each tick): `ÿ_d = −K̂·a` from the
//!   present tension and rate to the goal with zero rate, `K̂ = ẏ/v` identified at the onset
//!   with the one division-free reciprocal.
//! - **Exponential closure** on the pre-stretch peak and then the final target, time constant
//!   [`ProfileConfig::closing_time_constant`]: `y_d += (goal − y_d)·dt/τ_c`, with
//!   `ẏ_d = (goal − y_d)/τ_c` and `ÿ_d = −ẏ_d/τ_c`.
//! - **Step** (the paper's simulation, the baselines): `y_d` is the target from the first tick.
//! - **Transitions** that depend on the tension ([`Profile::transitions`]): the pre-stretch
//!   dwell, the settle's arrival, "at tension" in the hold.
//!
//! # Coefficients
//!
//! Everything the step needs from the configuration is derived once, with its divisions, by
//! [`ProfileCoefficients::new`] (as the law's `RsmcCoefficients` are): the step itself has no
//! division, except once per pull, when the take-up's identification ends (`Δv/(n·dt)`, its
//! `1/(2a)` and the gripper's `m_g·a`: three 64-bit divisions by checked non-zero divisors).
//! Each coefficient carries its fixed-point format in its type ([`Q16`] units, [`Q24`],
//! [`Q32`]).
//!
//! # Fixed point
//!
//! The reference `y_d` is kept in Q31.32 ([`Q32`]) so the exponential closure keeps moving
//! when its per-tick increment is below Q15.16's 15 µkgf; the rest is Q15.16 with exact
//! 64-bit products ([`crate::fixed`]).

use crate::fixed::{
    Frac32, Q24, Q32, mul_q16, mul_q24, mul_wide, narrow, reciprocal_q24, saturate_i32,
};
use crate::settings::{MmPerSecond, PullKind, PullSettings, TENSION_MAX, TENSION_MIN};
use crate::tension::estimator::Estimate;
use crate::tension::law::{Reference, Saturation};
use crate::units::{Kgf, KgfPerSecond, Q16, Seconds};

/// Below this tension the string is still slack (or in its toe) and the braking is not
/// timed: 2 kgf.
pub const TAUT_TENSION: Kgf = Kgf::from_int(2);

/// The softest and stiffest string the identification accepts, kgf/mm: 0.05 and 4.
pub const STIFFNESS_RANGE: (Q16, Q16) = (Q16::lit("0.05"), Q16::const_from_int(4));

/// The longest sensing lag a profile may declare, 0.1 s.
pub const SENSING_LAG_MAX: Q16 = Q16::lit("0.1");

/// The braking deceleration a take-up identifies is planned at this multiple of the
/// acceleration it measured (REQ-ID-06): 1.4. Braking has at least the take-up's force — the
/// drive's current window allows the full limit both ways while the take-up's current-limited
/// duty, judged on a lagging speed, delivers about half of it — and the screw's friction and
/// the string's pull both help it. On the twin's family at 4× the nominal inertia the take-up
/// accelerates at ≈ 600 mm/s² and the braking achieves ≈ 820 mm/s² (1.37×).
pub const BRAKING_PER_TAKE_UP: Q16 = Q16::lit("1.4");

/// The fewest ticks an acceleration measurement may span: 3 (a shorter one is a carriage
/// that needs no braking plan of its own; the configured one stands).
const IDENTIFY_TICKS_MIN: u32 = 3;

/// The take-up's ticks whose load-cell samples are the gripper's reading at rest: the first 4
/// (REQ-ID-07). The drive's current needs a tick or two to rise and the cell's amplifier and
/// the gripper's own spring delay the inertial force further (on the twin's family it shows
/// from the fifth tick on); four samples average the converter's noise by half.
pub const REST_TICKS: u32 = 1 << REST_SHIFT;

/// `log2` of [`REST_TICKS`]: the rest reading's mean is its sum shifted.
const REST_SHIFT: u32 = 2;

/// The most the gripper compensation adds to the load-cell reading while the carriage brakes,
/// 0.5 kgf (REQ-ID-07): a 3.5 kg gripper braked at 1 400 mm/s², over twice the heaviest
/// gripper head the family draws. A take-up that reads more than that is not accelerating a
/// gripper but pulling on a string that was not slack: nothing is identified.
pub const GRIPPER_BIAS_MAX: Kgf = Kgf(Q16::lit("0.5"));

/// The least braking deceleration an identification plans with, mm/s²: 100 (twelve times the
/// nominal machine's inertia; a take-up slower than that is a carriage dragging, and the
/// approach still brakes under closed-loop control).
pub const BRAKING_DECELERATION_MIN: Q16 = Q16::const_from_int(100);

/// The fastest reference rate, kgf/s (a 4 kgf/mm string at 250 mm/s).
pub const REFERENCE_RATE_MAX: KgfPerSecond = KgfPerSecond::from_int(1_000);

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
    /// The observer's gain once the braking is over and the carriage has stopped
    /// ([`crate::tension::controller::HOLD_GAIN_SPEED`]; `None`: keep the gain it had).
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
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
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

/// Where in a pull the controller is.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
#[cfg_attr(kani, derive(kani::Arbitrary))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
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

/// The profile's state: where the pull is and where the reference stands (exposed for logs,
/// proofs and fuzzing; [`Profile::is_valid`] states which values are reachable).
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
    /// The reference tension `y_d`, kgf in Q31.32 (see the module's fixed point).
    pub reference: Q32,
    /// The reference rate `ẏ_d`.
    pub reference_rate: KgfPerSecond,
    /// The reference's second derivative `ÿ_d`, kgf/s².
    pub reference_accel: Q16,
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
    /// The take-up's tick at which the carriage first reached a quarter of the speed limit
    /// (0: not yet), the start of the acceleration measurement (REQ-ID-06).
    pub take_up_mark: u32,
    /// The braking deceleration this pull plans with, mm/s², as the take-up identified it
    /// (0: the configured one, [`ProfileCoefficients::decel`]).
    pub braking_decel: Q16,
    /// `1/(2a)` of [`ProfileState::braking_decel`], s²/mm (0: the configured one).
    pub braking_inv_two_decel: Q24,
    /// The take-up's first [`REST_TICKS`] filtered load-cell samples, summed, kgf bits: the
    /// reading of the still gripper, before its inertial force reaches the cell (REQ-ID-07).
    pub rest_sum: i32,
    /// What the filtered load-cell samples of the acceleration window (the ticks after
    /// [`ProfileState::take_up_mark`]) read above the rest reading, summed, kgf bits: the
    /// gripper's inertial force, tick by tick (REQ-ID-07).
    pub inertial_sum: i32,
    /// What the gripper's inertia takes off the load-cell reading while the carriage brakes
    /// at the planned deceleration, as the take-up identified it (0: not identified), in
    /// `[0, GRIPPER_BIAS_MAX]` (REQ-ID-07).
    pub gripper_bias: Kgf,
}

/// Any profile state, for proofs ([`Profile::is_valid`] states which are reachable): every
/// field drawn whole (the unit types wrap `fixed` numbers, which have no `Arbitrary` of their
/// own, so the bits are drawn instead).
#[cfg(kani)]
impl kani::Arbitrary for ProfileState {
    fn any() -> Self {
        Self {
            phase: kani::any(),
            peak: Kgf::from_bits(kani::any()),
            final_target: Kgf::from_bits(kani::any()),
            speed_limit: MmPerSecond(Q16::from_bits(kani::any())),
            reference: Q32(kani::any()),
            reference_rate: KgfPerSecond::from_bits(kani::any()),
            reference_accel: Q16::from_bits(kani::any()),
            goal: Kgf::from_bits(kani::any()),
            ticks: kani::any(),
            at_tension: kani::any(),
            saturated: kani::any(),
            fresh: kani::any(),
            take_up_mark: kani::any(),
            braking_decel: Q16::from_bits(kani::any()),
            braking_inv_two_decel: Q24(kani::any()),
            rest_sum: kani::any(),
            inertial_sum: kani::any(),
            gripper_bias: Kgf::from_bits(kani::any()),
        }
    }
}

/// Any profile state, for fuzzing (as the Kani impl above).
#[cfg(feature = "arbitrary")]
impl<'a> arbitrary::Arbitrary<'a> for ProfileState {
    fn arbitrary(u: &mut arbitrary::Unstructured<'a>) -> arbitrary::Result<Self> {
        Ok(Self {
            phase: u.arbitrary()?,
            peak: Kgf::from_bits(u.arbitrary()?),
            final_target: Kgf::from_bits(u.arbitrary()?),
            speed_limit: MmPerSecond(Q16::from_bits(u.arbitrary()?)),
            reference: Q32(u.arbitrary()?),
            reference_rate: KgfPerSecond::from_bits(u.arbitrary()?),
            reference_accel: Q16::from_bits(u.arbitrary()?),
            goal: Kgf::from_bits(u.arbitrary()?),
            ticks: u.arbitrary()?,
            at_tension: u.arbitrary()?,
            saturated: u.arbitrary()?,
            fresh: u.arbitrary()?,
            take_up_mark: u.arbitrary()?,
            braking_decel: Q16::from_bits(u.arbitrary()?),
            braking_inv_two_decel: Q24(u.arbitrary()?),
            rest_sum: u.arbitrary()?,
            inertial_sum: u.arbitrary()?,
            gripper_bias: Kgf::from_bits(u.arbitrary()?),
        })
    }
}

impl ProfileState {
    /// Idle, no pull armed.
    pub const DEFAULT: Self = Self {
        phase: PullPhase::Idle,
        peak: Kgf::ZERO,
        final_target: Kgf::ZERO,
        speed_limit: MmPerSecond(Q16::ZERO),
        reference: Q32(0),
        reference_rate: KgfPerSecond::ZERO,
        reference_accel: Q16::ZERO,
        goal: Kgf::ZERO,
        ticks: 0,
        at_tension: false,
        saturated: Saturation::None,
        fresh: false,
        take_up_mark: 0,
        braking_decel: Q16::ZERO,
        braking_inv_two_decel: Q24(0),
        rest_sum: 0,
        inertial_sum: 0,
        gripper_bias: Kgf::ZERO,
    };
}

/// The profile's coefficients, derived and validated once from a [`ProfileConfig`] and the
/// control period (the step only multiplies and adds).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct ProfileCoefficients {
    /// Shaped profile, or a step set point.
    pub shaped: bool,
    /// `dt`, seconds (at most 10 ms).
    pub dt: Frac32,
    /// `dt/τ_c` (strictly between 0 and 1).
    pub closing_step: Frac32,
    /// `1/τ_c`, 1/s.
    pub inv_tau: Q16,
    /// The braking deceleration `a`, mm/s².
    pub decel: Q16,
    /// `1/(2a)`, s²/mm.
    pub inv_two_decel: Q24,
    /// The braking margin, a fraction of the braking rise.
    pub margin_fraction: Q16,
    /// The approach margin.
    pub margin: Kgf,
    /// The sensing lag, seconds.
    pub lag: Q24,
    /// `K̄`, the stiffness the law's nominal plant was written for, kgf/mm.
    pub nominal_stiffness: Q16,
    /// The pre-stretch dwell in ticks.
    pub dwell_ticks: u32,
    /// The "at tension" band.
    pub band: Kgf,
    /// The carriage speed of a release move.
    pub release_speed: MmPerSecond,
}

/// `1/(2a)` in Q8.24 s²/mm of a deceleration `a` in Q15.16 mm/s² bits (0 for `a ≤ 0`), or
/// `None` if it does not fit: the braking rise's divisor, for the configured deceleration and
/// for the one a take-up identifies alike.
fn inverse_of_twice(decel_bits: i64) -> Option<i32> {
    i32::try_from((1_i64 << 40).checked_div(decel_bits.saturating_mul(2)).unwrap_or(0)).ok()
}

/// The gripper's inertial force at the braking deceleration `decel` (Q15.16 mm/s²), kgf
/// (REQ-ID-07): the force that accelerated it summed over the window's ticks, `inertial_sum`
/// (kgf bits), is its momentum gain `m_g·Δv` once multiplied by the tick `dt`; over the
/// window's speed gain `rise` (Q15.16 mm/s) that is its mass, and times `decel` the force
/// braking takes off the reading. The window's length cancels out: one division, by the speed
/// gain. 0 for a reading that fell, a window without a speed gain, or a force above
/// [`GRIPPER_BIAS_MAX`]: no gripper explains that much, a string already pulling does.
fn inertial_force(inertial_sum: i32, dt: Frac32, decel: i64, rise: i64) -> Kgf {
    // Σ·dt in kgf·s, Q8.24: |Σ| < 2³¹ kgf bits times dt < 2³² over 2²⁴.
    let impulse = i64::from(inertial_sum.max(0)).saturating_mul(dt.wide()) >> 24;
    let bias_q24 = impulse.saturating_mul(decel).checked_div(rise).unwrap_or(0);
    let bias = bias_q24 >> 8;
    if bias > i64::from(GRIPPER_BIAS_MAX.to_bits()) {
        return Kgf::ZERO;
    }
    Kgf::from_bits(saturate_i32(bias.max(0)))
}

impl ProfileCoefficients {
    /// The coefficients of `config` at a control period of `period_us` µs (the controller
    /// validates the period first; a period the closing time constant cannot be sampled at
    /// is refused here).
    ///
    /// # Errors
    /// The [`ProfileError`] of the first parameter out of range.
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(config: &ProfileConfig, period_us: u32) -> Result<Self, ProfileError> {
        config.validate()?;
        const TAU_REFUSED: ProfileError = ProfileError::ClosingTimeConstant;
        let tau = config.closing_time_constant.0;
        let decel = config.braking_deceleration;
        let period = i64::from(period_us);
        // dt < 1 s for every period the controller accepts; a longer one has no dt/τ_c.
        let dt = (period << 32).checked_div(1_000_000).and_then(|dt| u32::try_from(dt).ok());
        let dt = dt.ok_or(TAU_REFUSED)?;
        let tau_us = i64::from(tau.to_bits()).saturating_mul(1_000_000) >> 16;
        let closing_step = (period << 32).checked_div(tau_us).ok_or(TAU_REFUSED)?;
        let closing_step =
            u32::try_from(closing_step).ok().filter(|&step| step > 0).ok_or(TAU_REFUSED)?;
        let inv_tau = Q16::ONE.checked_div(tau).ok_or(TAU_REFUSED)?;
        let inv_two_decel = inverse_of_twice(i64::from(decel.to_bits()))
            .ok_or(ProfileError::BrakingDeceleration)?;
        Ok(Self {
            shaped: config.shaped,
            dt: Frac32(dt),
            closing_step: Frac32(closing_step),
            inv_tau,
            decel,
            inv_two_decel: Q24(inv_two_decel),
            margin_fraction: Q16::const_from_int(i32::from(config.braking_margin_percent))
                .saturating_div_int(100),
            margin: config.approach_margin,
            lag: Q24::from_q16(config.sensing_lag.0),
            nominal_stiffness: config.nominal_stiffness,
            dwell_ticks: u32::from(config.pre_stretch_dwell_ms)
                .saturating_mul(1_000)
                .checked_div(period_us)
                .unwrap_or(0),
            band: config.at_tension_band,
            release_speed: config.release_speed,
        })
    }

    /// Coefficients that are valid at 1 kHz whatever the configuration (the controller's
    /// fallback, reachable only if the built-in configurations were broken).
    pub const FALLBACK: Self = Self {
        shaped: false,
        dt: Frac32(4_294_967),
        closing_step: Frac32(1 << 27),
        inv_tau: Q16::const_from_int(32),
        decel: Q16::const_from_int(1_000),
        inv_two_decel: Q24(1 << 12),
        margin_fraction: Q16::ZERO,
        margin: Kgf::ZERO,
        lag: Q24(0),
        nominal_stiffness: Q16::lit("0.5"),
        dwell_ticks: 0,
        band: Kgf(Q16::lit("0.1")),
        release_speed: MmPerSecond::from_int(20),
    };
}

/// What the braking onset identified, for the controller to apply to the law and the
/// estimator.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct BrakingOnset {
    /// The string's stiffness `K̂ = ẏ/v`, kgf/mm, within [`STIFFNESS_RANGE`].
    pub stiffness: Q16,
    /// The tension the parabola starts from (the lag-compensated tension, within the peak).
    pub start: Kgf,
}

/// One tick of the reference.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Advance {
    /// `y_d`, `ẏ_d`, `ÿ_d` for the law.
    pub reference: Reference,
    /// The braking parabola ended in this tick (the observer takes its hold gain).
    pub braking_ended: bool,
}

/// The pull profile: its coefficients and its state. See the module docs.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Profile {
    coefficients: ProfileCoefficients,
    state: ProfileState,
}

impl Profile {
    /// An idle profile built from `config` at `period_us`.
    ///
    /// # Errors
    /// As [`ProfileCoefficients::new`].
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(config: &ProfileConfig, period_us: u32) -> Result<Self, ProfileError> {
        let coefficients = ProfileCoefficients::new(config, period_us)?;
        Ok(Self { coefficients, state: ProfileState::default() })
    }

    /// An idle profile with [`ProfileCoefficients::FALLBACK`].
    pub const FALLBACK: Self =
        Self { coefficients: ProfileCoefficients::FALLBACK, state: ProfileState::DEFAULT };

    /// The coefficients.
    #[must_use]
    pub const fn coefficients(&self) -> &ProfileCoefficients {
        &self.coefficients
    }

    /// The state (for logs, proofs and fuzzing).
    #[must_use]
    pub const fn state(&self) -> ProfileState {
        self.state
    }

    /// Replaces the state (proofs and fuzzing); the guarantees hold for states that satisfy
    /// [`Profile::is_valid`].
    pub fn set_state(&mut self, state: ProfileState) {
        self.state = state;
    }

    /// The present phase.
    #[must_use]
    pub const fn phase(&self) -> PullPhase {
        self.state.phase
    }

    /// Arms a pull of `kind` with `settings`: take-up (shaped) or the approach (step), the
    /// reference at the peak, the law to be reset on its first tick.
    pub fn start(&mut self, settings: &PullSettings, kind: PullKind) {
        let peak = settings.peak_target(kind);
        self.state = ProfileState {
            phase: if self.coefficients.shaped { PullPhase::TakeUp } else { PullPhase::Approach },
            peak,
            final_target: settings.final_target(kind),
            speed_limit: settings.speed().carriage_limit(),
            reference: Q32::from_q16(peak.0),
            reference_rate: KgfPerSecond::ZERO,
            reference_accel: Q16::ZERO,
            goal: peak,
            ticks: 0,
            at_tension: false,
            saturated: Saturation::None,
            fresh: true,
            take_up_mark: 0,
            braking_decel: Q16::ZERO,
            braking_inv_two_decel: Q24(0),
            rest_sum: 0,
            inertial_sum: 0,
            gripper_bias: Kgf::ZERO,
        };
    }

    /// Starts the release (homing) move.
    pub fn release(&mut self) {
        self.state.phase = PullPhase::Release;
        self.state.ticks = 0;
        self.state.at_tension = false;
    }

    /// Idle at once.
    pub fn stop(&mut self) {
        self.state.phase = PullPhase::Idle;
        self.state.ticks = 0;
        self.state.at_tension = false;
    }

    /// Moves the held tension to `target` while holding (the operator's Up/Down): the
    /// reference closes on it as it closed on the final target (shaped) or steps to it
    /// (step), and "at tension" stays latched. Refused — nothing changes — outside
    /// [`PullPhase::Hold`] or outside [`TENSION_MIN`]–[`TENSION_MAX`]; the peak is raised
    /// to the target if it is below it, so the peak stays at or above the final target.
    pub fn retarget(&mut self, target: Kgf) -> bool {
        let accepted =
            self.state.phase == PullPhase::Hold && target >= TENSION_MIN && target <= TENSION_MAX;
        if accepted {
            self.state.final_target = target;
            self.state.peak = self.state.peak.max(target);
        }
        accepted
    }

    /// Constant pull back on after a lock-out: the reference restarts from the tension `y`
    /// (clamped to the range) and closes on the final target again, and the law restarts
    /// from the present error. Only in [`PullPhase::Hold`].
    pub fn resume_from(&mut self, y: Kgf) {
        if self.state.phase == PullPhase::Hold {
            self.set_reference(Q32::from_q16(y.0));
            self.state.fresh = true;
        }
    }

    /// Counts a tick in the present phase (saturating).
    pub fn tick(&mut self) {
        self.state.ticks = self.state.ticks.saturating_add(1);
    }

    /// Whether "at tension" has latched in this hold.
    #[must_use]
    pub const fn at_tension(&self) -> bool {
        self.state.at_tension
    }

    /// The reference tension `y_d`, rounded to Q15.16.
    #[must_use]
    pub fn reference(&self) -> Kgf {
        Kgf(self.state.reference.to_q16())
    }

    /// Takes the "law not run since Start" flag: true once per pull, on the first closed-loop
    /// tick (the law then resets its memory to the present error — no derivative kick).
    pub fn take_fresh(&mut self) -> bool {
        let fresh = self.state.fresh;
        self.state.fresh = false;
        fresh
    }

    /// Which way the previous output saturated (the law's anti-windup).
    #[must_use]
    pub const fn saturated(&self) -> Saturation {
        self.state.saturated
    }

    /// Records which way this tick's output saturated.
    pub fn set_saturated(&mut self, saturated: Saturation) {
        self.state.saturated = saturated;
    }

    /// The invariant every reachable state satisfies: targets, goal and reference within
    /// `[0, TENSION_MAX]`, the peak at or above the final target.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let p = &self.state;
        let in_range = |value: Kgf| value >= Kgf::ZERO && value <= TENSION_MAX;
        let reference_ok = p.reference.0 >= 0 && p.reference <= Q32::from_q16(TENSION_MAX.0);
        let braking_ok = p.braking_decel >= Q16::ZERO
            && p.braking_decel <= self.coefficients.decel
            && p.braking_inv_two_decel.0 >= 0
            && p.gripper_bias >= Kgf::ZERO
            && p.gripper_bias <= GRIPPER_BIAS_MAX;
        braking_ok
            && in_range(p.peak)
            && in_range(p.final_target)
            && in_range(p.goal)
            && p.final_target <= p.peak
            && reference_ok
    }

    /// Enters `phase`.
    fn enter(&mut self, phase: PullPhase) {
        self.state.phase = phase;
        self.state.ticks = 0;
    }

    /// Sets the reference, clamped to `[0, TENSION_MAX]`.
    fn set_reference(&mut self, reference: Q32) {
        let max = Q32::from_q16(TENSION_MAX.0);
        self.state.reference = Q32(reference.0.clamp(0, max.0));
    }

    /// The braking deceleration `a` this pull plans with and its `1/(2a)`: the take-up's
    /// identification where it made one, else the configured ones. (The identification sets
    /// both fields together, so the deceleration alone tells whether it has.)
    #[must_use]
    pub fn braking_deceleration(&self) -> (Q16, Q24) {
        let p = &self.state;
        if p.braking_decel > Q16::ZERO {
            (p.braking_decel, p.braking_inv_two_decel)
        } else {
            (self.coefficients.decel, self.coefficients.inv_two_decel)
        }
    }

    /// One take-up tick's look at the carriage speed `speed` and the filtered load-cell
    /// sample `sample` (REQ-ID-06, REQ-ID-07): the take-up accelerates at the current limit
    /// from rest, so the time its speed takes from a quarter to three quarters of the speed
    /// limit measures the acceleration the drive gives this carriage — its reflected inertia
    /// against the motor's force, on this machine, today. The braking is then planned at
    /// [`BRAKING_PER_TAKE_UP`] times that, where that is below the configured deceleration
    /// (never above it), and at least [`BRAKING_DECELERATION_MIN`]. Both crossings read the
    /// same lagging speed estimate, so its lag cancels out of the interval.
    ///
    /// Over the same window the string is slack, so what the load cell reads above its
    /// reading at rest (the take-up's first [`REST_TICKS`] samples) is the force that
    /// accelerates the gripper hung outboard of it, `m_g·a_t`; braking at `a` it reads
    /// `m_g·a` *less* than the string's pull. [`ProfileState::gripper_bias`] is that,
    /// `m̂_g·a`, `m̂_g` the momentum the reading's excess gave the gripper over the window
    /// divided by the window's speed gain, within `[0, GRIPPER_BIAS_MAX]`, for the controller
    /// to add to the reading while the carriage brakes ([`Profile::gripper_bias`]). Two
    /// divisions per pull, at the second crossing.
    pub fn observe_take_up(&mut self, speed: MmPerSecond, sample: Kgf) {
        let p = self.state;
        if p.phase != PullPhase::TakeUp || p.braking_decel > Q16::ZERO {
            return;
        }
        if (1..=REST_TICKS).contains(&p.ticks) {
            self.state.rest_sum = p.rest_sum.saturating_add(sample.to_bits());
        }
        let limit = p.speed_limit.0.to_bits().max(0);
        let quarter = limit >> 2;
        let speed = speed.0.to_bits();
        if p.take_up_mark == 0 {
            if quarter > 0 && speed >= quarter {
                self.state.take_up_mark = p.ticks.max(1);
            }
            return;
        }
        let rest = p.rest_sum >> REST_SHIFT;
        let inertial_sum = p.inertial_sum.saturating_add(sample.to_bits().saturating_sub(rest));
        self.state.inertial_sum = inertial_sum;
        if speed < limit.saturating_sub(quarter) {
            return;
        }
        let ticks = p.ticks.saturating_sub(p.take_up_mark);
        let c = &self.coefficients;
        // a = Δv/(n·dt): Δv < 2³¹ bits, × 2³² over n·dt (dt in 2⁻³² s), Q16 mm/s².
        let rise = i64::from(limit.saturating_sub(quarter.saturating_mul(2)));
        let span = i64::from(ticks).saturating_mul(c.dt.wide());
        let measured = if ticks >= IDENTIFY_TICKS_MIN {
            rise.saturating_mul(1_i64 << 32).checked_div(span).unwrap_or(i64::MAX)
        } else {
            i64::MAX
        };
        let planned = i64::from(BRAKING_PER_TAKE_UP.to_bits()).saturating_mul(measured) >> 16;
        let floor = i64::from(BRAKING_DECELERATION_MIN.to_bits());
        let decel = planned.clamp(floor, i64::from(c.decel.to_bits()).max(floor));
        let (Ok(decel), Some(inv)) = (i32::try_from(decel), inverse_of_twice(decel)) else {
            return;
        };
        self.state.braking_decel = Q16::from_bits(decel);
        self.state.braking_inv_two_decel = Q24(inv);
        // The window (the ticks after the mark) starts once the rest's ticks are summed.
        let rested = p.take_up_mark >= REST_TICKS;
        self.state.gripper_bias = if rested && ticks >= IDENTIFY_TICKS_MIN {
            inertial_force(inertial_sum, c.dt, i64::from(decel), rise)
        } else {
            Kgf::ZERO
        };
    }

    /// The take-up's acceleration window is over (its deceleration and the gripper's inertia
    /// are identified): the carriage runs at its take-up speed.
    #[must_use]
    pub fn take_up_identified(&self) -> bool {
        self.state.phase == PullPhase::TakeUp && self.state.braking_decel > Q16::ZERO
    }

    /// What to add to the load-cell reading this tick for the gripper's inertia: the
    /// identified [`ProfileState::gripper_bias`] while the carriage brakes along its parabola
    /// ([`PullPhase::Approach`]), else nothing (REQ-ID-07).
    #[must_use]
    pub fn gripper_bias(&self) -> Kgf {
        if self.state.phase == PullPhase::Approach { self.state.gripper_bias } else { Kgf::ZERO }
    }

    /// The tension a braking carriage still adds, `ẏ·v/(2a)`, kgf bits (see the module
    /// docs), and the lag-compensated tension `y + ẏ·t_lag`.
    fn braking_rise(&self, est: &Estimate) -> (i32, i32) {
        let c = &self.coefficients;
        let rate = est.rate.to_bits().max(0);
        let speed = est.speed.0.to_bits().max(0);
        let rise = mul_q24(narrow(mul_wide(rate, speed)), self.braking_deceleration().1);
        let predicted = est.sample.to_bits().saturating_add(mul_q24(rate, c.lag));
        (rise, predicted)
    }

    /// The braking's goal for a rise of `rise`: the peak less the margins, kgf bits.
    fn braking_goal(&self, rise: i32) -> i32 {
        let c = &self.coefficients;
        self.state
            .peak
            .to_bits()
            .saturating_sub(c.margin.to_bits())
            .saturating_sub(mul_q16(rise, c.margin_fraction.to_bits()))
    }

    /// Whether the take-up must start braking this tick (division-free: see the module docs).
    #[must_use]
    pub fn braking_due(&self, est: &Estimate) -> bool {
        let (rise, predicted) = self.braking_rise(est);
        let goal = self.braking_goal(rise);
        let taut = est.sample >= TAUT_TENSION;
        let peak_less_margin =
            self.state.peak.to_bits().saturating_sub(self.coefficients.margin.to_bits());
        (taut && predicted.saturating_add(rise) >= goal) || predicted >= peak_less_margin
    }

    /// Starts the braking: identifies the stiffness `K̂ = ẏ/v` (a still carriage gives the
    /// nominal string), plans the parabola from the lag-compensated tension to the goal, and
    /// enters [`PullPhase::Approach`]; returns what the controller applies to the law and the
    /// estimator.
    pub fn begin_braking(&mut self, est: &Estimate) -> BrakingOnset {
        let c = self.coefficients;
        let (rise, predicted) = self.braking_rise(est);
        let rate = est.rate.to_bits().clamp(0, REFERENCE_RATE_MAX.to_bits());
        let speed = est.speed.0.to_bits();
        let stiffness = if speed >= Q16::ONE.to_bits() {
            mul_q24(rate, Q24(reciprocal_q24(speed)))
        } else {
            c.nominal_stiffness.to_bits()
        }
        .clamp(STIFFNESS_RANGE.0.to_bits(), STIFFNESS_RANGE.1.to_bits());
        let start = predicted.clamp(0, self.state.peak.to_bits());
        let goal = self.braking_goal(rise).clamp(start, self.state.peak.to_bits());
        self.state.goal = Kgf::from_bits(goal);
        self.set_reference(Q32(i64::from(start) << 16));
        self.state.reference_rate = KgfPerSecond::from_bits(rate);
        // ÿ_d = −K̂·a.
        let decel = self.braking_deceleration().0;
        self.state.reference_accel =
            Q16::from_bits(narrow(mul_wide(stiffness, decel.to_bits())).saturating_neg());
        self.state.fresh = true;
        self.enter(PullPhase::Approach);
        BrakingOnset { stiffness: Q16::from_bits(stiffness), start: Kgf::from_bits(start) }
    }

    /// One tick of the braking parabola; ends at the goal with zero rate and enters the
    /// pre-stretch or the hold. Returns `(ẏ_d, ÿ_d)` bits and whether it ended.
    fn advance_braking(&mut self) -> (i32, i32, bool) {
        let p = self.state;
        let dt = self.coefficients.dt.wide();
        let accel = p.reference_accel.to_bits();
        let dv = saturate_i32(i64::from(accel).saturating_mul(dt) >> 32);
        let next_rate = p.reference_rate.to_bits().saturating_add(dv);
        let mean_rate =
            i64::from(p.reference_rate.to_bits()).saturating_add(i64::from(next_rate)) >> 1;
        let advanced = p.reference.0.saturating_add(mean_rate.saturating_mul(dt) >> 16);
        let goal = Q32::from_q16(p.goal.0);
        if next_rate <= 0 || advanced >= goal.0 {
            self.set_reference(goal);
            self.state.reference_rate = KgfPerSecond::ZERO;
            self.state.reference_accel = Q16::ZERO;
            let next =
                if p.peak > p.final_target { PullPhase::PreStretch } else { PullPhase::Hold };
            self.enter(next);
            (0, 0, true)
        } else {
            self.set_reference(Q32(advanced));
            self.state.reference_rate = KgfPerSecond::from_bits(next_rate);
            (next_rate, accel, false)
        }
    }

    /// One tick of the exponential closure on `target`; returns `(ẏ_d, ÿ_d)` bits.
    fn advance_closing(&mut self, target: Kgf) -> (i32, i32) {
        let c = &self.coefficients;
        let goal = Q32::from_q16(target.0).0;
        let gap = goal.saturating_sub(self.state.reference.0);
        // y_d += gap·dt/τ (Q31.32 × Q0.32 → split the product to stay in 64 bits).
        let step = (gap >> 16).saturating_mul(c.closing_step.wide()) >> 16;
        let step = if step == 0 && gap != 0 { gap.signum() } else { step };
        let inv_tau = c.inv_tau.to_bits();
        self.set_reference(Q32(self.state.reference.0.saturating_add(step)));
        let gap_bits = saturate_i32(goal.saturating_sub(self.state.reference.0) >> 16);
        let rate = narrow(mul_wide(gap_bits, inv_tau));
        let accel = narrow(mul_wide(rate, inv_tau)).saturating_neg();
        self.state.reference_rate = KgfPerSecond::from_bits(rate);
        self.state.reference_accel = Q16::from_bits(accel);
        (rate, accel)
    }

    /// One tick of the reference in a closed-loop phase (approach, pre-stretch, settle,
    /// hold): the braking parabola or the closure (shaped), or the set point (step).
    pub fn advance(&mut self) -> Advance {
        let phase = self.state.phase;
        let (rate, accel, braking_ended) = if self.coefficients.shaped {
            match phase {
                PullPhase::Approach => self.advance_braking(),
                PullPhase::PreStretch => {
                    let (rate, accel) = self.advance_closing(self.state.peak);
                    (rate, accel, false)
                }
                _ => {
                    let (rate, accel) = self.advance_closing(self.state.final_target);
                    (rate, accel, false)
                }
            }
        } else {
            let set_point = match phase {
                PullPhase::Approach | PullPhase::PreStretch => self.state.peak,
                _ => self.state.final_target,
            };
            self.state.goal = set_point;
            self.set_reference(Q32::from_q16(set_point.0));
            (0, 0, false)
        };
        let reference = Reference {
            tension: self.reference(),
            rate: KgfPerSecond::from_bits(rate),
            accel: Q16::from_bits(accel),
        };
        Advance { reference, braking_ended }
    }

    /// The phase changes that depend on the tension `y`, for a tick that began in `phase`
    /// (the braking's end is in [`Profile::advance`]).
    pub fn transitions(&mut self, phase: PullPhase, y: Kgf) {
        let p = self.state;
        let c = &self.coefficients;
        let band = c.band.to_bits();
        let error_to = |target: Kgf| y.to_bits().saturating_sub(target.to_bits()).saturating_abs();
        let closed_on = |target: Kgf| {
            let goal = Q32::from_q16(target.0).0;
            goal.saturating_sub(p.reference.0).abs() < (1 << 22)
        };
        let peak_above = p.peak > p.final_target;
        match phase {
            PullPhase::Approach if !c.shaped => {
                if error_to(p.peak) <= band {
                    self.enter(if peak_above { PullPhase::PreStretch } else { PullPhase::Hold });
                }
            }
            PullPhase::PreStretch => {
                if p.ticks >= c.dwell_ticks {
                    self.enter(PullPhase::Settle);
                }
            }
            PullPhase::Settle => {
                let arrived = if c.shaped {
                    closed_on(p.final_target)
                } else {
                    error_to(p.final_target) <= band
                };
                if arrived {
                    self.enter(PullPhase::Hold);
                }
            }
            PullPhase::Hold => {
                if error_to(p.final_target) <= band {
                    self.state.at_tension = true;
                }
            }
            PullPhase::Approach | PullPhase::Idle | PullPhase::TakeUp | PullPhase::Release => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            assert_eq!(Profile::new(&profile, 1_000), Err(error));
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
    fn coefficients_are_derived_once_in_their_formats() {
        let c = valid_coefficients(&ProfileConfig::TAUT, 1_000);
        // dt = 1 ms in Q0.32; dt/τ_c ≈ 1/30 (τ_c = 0.03 s is 1 966/2¹⁶ = 29 998 µs in
        // Q15.16); 1/τ_c = 33.3 s⁻¹; 1/(2·1 200 mm/s²).
        assert_eq!(c.dt, Frac32(4_294_967));
        assert_eq!(c.closing_step.wide(), (1_000_i64 << 32) / 29_998);
        assert_eq!(c.inv_tau, Q16::ONE.checked_div(Q16::lit("0.03")).unwrap_or(Q16::ZERO));
        assert_eq!(c.inv_two_decel, Q24((1 << 24) / 2_400));
        assert_eq!(c.margin_fraction, Q16::const_from_int(20).saturating_div_int(100));
        assert_eq!(c.lag, Q24::from_q16(Q16::lit("0.003")));
        assert_eq!(c.dwell_ticks, 300);
        // A closing time constant shorter than the period cannot be sampled (30/2¹⁶ s =
        // 0.46 ms).
        let tau = Seconds(Q16::from_bits(30));
        let fast = ProfileConfig { closing_time_constant: tau, ..ProfileConfig::TAUT };
        assert_eq!(Profile::new(&fast, 1_000), Err(ProfileError::ClosingTimeConstant));
        assert!(Profile::new(&fast, 100).is_ok());
        assert!(Profile::FALLBACK.is_valid());
    }

    /// A speed-9 take-up on `TAUT` whose carriage accelerates at `accel` mm/s² from rest
    /// (the speed as the controller would read it, one value per 1 ms tick), for `ms` ticks.
    fn take_up(accel: i64, ms: u32) -> Profile {
        take_up_reading(accel, ms, |_| 0)
    }

    /// [`take_up`], the load cell reading `reading(tick)` kgf bits in tick `tick` (from 1).
    fn take_up_reading(accel: i64, ms: u32, reading: impl Fn(u32) -> i32) -> Profile {
        let mut profile = Profile::new(&ProfileConfig::TAUT, 1_000).unwrap_or(Profile::FALLBACK);
        let settings = PullSettings::default();
        profile.start(&settings, PullKind::Main);
        assert_eq!(profile.phase(), PullPhase::TakeUp);
        let limit = i64::from(settings.speed().carriage_limit().0.to_bits());
        for tick in 0..ms {
            profile.tick();
            // v = a·t, Q16 mm/s, no faster than the limit.
            let speed = (accel * i64::from(tick) * 65_536 / 1_000).min(limit);
            let speed = MmPerSecond(Q16::from_bits(speed.try_into().unwrap_or(0)));
            profile.observe_take_up(speed, Kgf::from_bits(reading(tick + 1)));
            assert!(profile.is_valid());
        }
        profile
    }

    /// A gripper of `grams` on a cell that reads `rest` mkgf still: the reading in tick
    /// `tick` of a take-up at `accel` mm/s² (the inertial force from tick 5 on, as on the
    /// twin), kgf bits.
    fn gripper(grams: i64, accel: i64, rest: i64) -> impl Fn(u32) -> i32 {
        move |tick| {
            // m·a in kgf: g × mm/s² / 9.80665e6, in Q16 bits.
            let inertial = if tick > REST_TICKS { grams * accel * 65_536 / 9_806_650 } else { 0 };
            i32::try_from(rest * 65_536 / 1_000 + inertial).unwrap_or(0)
        }
    }

    /// The identified gripper bias, mkgf.
    fn bias_mkgf(profile: &Profile) -> i64 {
        i64::from(profile.state().gripper_bias.to_bits()) * 1_000 / 65_536
    }

    #[test]
    fn a_take_up_identifies_the_grippers_inertial_force_at_the_braking_deceleration() {
        // A 1.1 kg gripper on a heavy rotor's carriage (600 mm/s², braked at 840): the cell
        // reads 67 mkgf above its rest (−40 mkgf) while accelerating, so braking it reads
        // 1.1 × 0.84 / 9.81 = 94 mkgf low.
        let heavy = take_up_reading(600, 300, gripper(1_100, 600, -40));
        assert!((bias_mkgf(&heavy) - 94).abs() <= 3, "{}", bias_mkgf(&heavy));
        // On the nominal carriage (2 000 mm/s²) the braking is the configured 1 200 mm/s²:
        // 1.1 × 1.2 / 9.81 = 135 mkgf, whatever the rest reading.
        for rest in [-300, 0, 250] {
            let nominal = take_up_reading(2_000, 200, gripper(1_100, 2_000, rest));
            assert!((bias_mkgf(&nominal) - 135).abs() <= 5, "{rest}: {}", bias_mkgf(&nominal));
        }
        // No gripper, or a reading that falls while accelerating: nothing added.
        assert_eq!(bias_mkgf(&take_up_reading(600, 300, gripper(0, 600, 30))), 0);
        assert_eq!(bias_mkgf(&take_up_reading(600, 300, gripper(-500, 600, 30))), 0);
        // A reading beyond any real gripper is a string already pulling: nothing identified.
        // Up to the most the compensation adds, the gripper is believed.
        let anvil = take_up_reading(600, 300, gripper(20_000, 600, 0));
        assert_eq!(anvil.state().gripper_bias, Kgf::ZERO);
        let heaviest = take_up_reading(600, 300, gripper(3_450, 600, 0));
        assert!((bias_mkgf(&heaviest) - 295).abs() <= 8, "{}", bias_mkgf(&heaviest));
        let beyond = take_up_reading(600, 300, gripper(6_000, 600, 0));
        assert_eq!(beyond.state().gripper_bias, Kgf::ZERO);
        // No window to identify in (still accelerating; a jump to full speed; a window that
        // starts within the rest ticks): nothing added.
        assert_eq!(bias_mkgf(&take_up_reading(600, 60, gripper(1_100, 600, 0))), 0);
        assert_eq!(bias_mkgf(&take_up_reading(1_000_000, 50, gripper(1_100, 600, 0))), 0);
        assert_eq!(bias_mkgf(&take_up_reading(15_000, 50, gripper(1_100, 15_000, 0))), 0);
        // (A window from the fifth tick on is identified: 8 000 mm/s² reaches a quarter of
        // the limit in the fourth.)
        let quick = take_up_reading(8_000, 50, gripper(1_100, 8_000, 0));
        assert_eq!(quick.state().take_up_mark, REST_TICKS);
        assert!((bias_mkgf(&quick) - 135).abs() <= 10, "{}", bias_mkgf(&quick));
        // The rest is the first four ticks only: a fifth reading as high as the window's
        // does not move it.
        let late = take_up_reading(600, 300, |tick| {
            gripper(1_100, 600, -40)(tick) + if tick == REST_TICKS + 1 { 5_000 } else { 0 }
        });
        assert!((bias_mkgf(&late) - bias_mkgf(&heavy)).abs() <= 1);
        // The next pull starts afresh.
        let mut again = heavy;
        again.start(&PullSettings::default(), PullKind::Main);
        assert_eq!(again.state().gripper_bias, Kgf::ZERO);
        assert_eq!((again.state().rest_sum, again.state().inertial_sum), (0, 0));
    }

    #[test]
    fn the_inertial_force_is_the_momentum_over_the_speed_gain_up_to_its_bound() {
        // dt = 2⁻⁸ s and a braking as hard as the window's speed gain: the force is the sum's
        // Q8.24 impulse over 2⁸, exactly.
        let dt = Frac32(1 << 24);
        let force = |sum: i32| inertial_force(sum, dt, 1_000 << 16, 1_000 << 16).to_bits();
        let max = GRIPPER_BIAS_MAX.to_bits();
        assert_eq!(force(max << 8), max, "the bound itself is believed");
        assert_eq!(force((max + 1) << 8), 0, "beyond it is a string, not a gripper");
        assert_eq!(force(100 << 8), 100);
        assert_eq!(force(-(100 << 8)), 0, "a reading that fell");
        // Twice the braking, twice the force; no speed gain, nothing.
        assert_eq!(inertial_force(100 << 8, dt, 2_000 << 16, 1_000 << 16).to_bits(), 200);
        assert_eq!(inertial_force(100 << 8, dt, 1_000 << 16, 0).to_bits(), 0);
    }

    #[test]
    fn the_gripper_bias_is_added_only_while_the_carriage_brakes() {
        let mut profile = take_up_reading(600, 300, gripper(1_100, 600, 0));
        let bias = profile.state().gripper_bias;
        assert!(bias > Kgf::ZERO);
        assert_eq!(profile.gripper_bias(), Kgf::ZERO, "not in the take-up");
        for phase in PullPhase::ALL {
            let mut state = profile.state();
            state.phase = phase;
            profile.set_state(state);
            let expected = if phase == PullPhase::Approach { bias } else { Kgf::ZERO };
            assert_eq!(profile.gripper_bias(), expected, "{phase:?}");
        }
        // Validity: the bias within [0, GRIPPER_BIAS_MAX].
        let valid_with = |bits: i32| {
            let mut p = take_up(0, 1);
            let mut state = p.state();
            state.gripper_bias = Kgf::from_bits(bits);
            p.set_state(state);
            p.is_valid()
        };
        let max = GRIPPER_BIAS_MAX.to_bits();
        assert!(valid_with(0) && valid_with(max));
        assert!(!valid_with(-1) && !valid_with(max + 1));
    }

    /// The planned braking deceleration, whole mm/s².
    fn planned_decel(profile: &Profile) -> i32 {
        profile.braking_deceleration().0.to_bits() >> 16
    }

    #[test]
    fn a_take_up_identifies_the_braking_deceleration_from_its_acceleration() {
        // Nominal machine (≈ 2 000 mm/s² in its take-up): 1.4 × that is above the configured
        // 1 200, which stands.
        let nominal = take_up(2_000, 200);
        assert_eq!(nominal.braking_deceleration().0, Q16::const_from_int(1_200));
        assert_eq!(
            nominal.braking_deceleration().1,
            ProfileCoefficients::new(&ProfileConfig::TAUT, 1_000)
                .map_or(Q24(0), |c| c.inv_two_decel)
        );
        // A heavy rotor (≈ 600 mm/s²): braked at 1.4 × 600 = 840, its 1/(2a) beside it.
        let heavy = take_up(600, 300);
        let (decel, inv) = heavy.braking_deceleration();
        let a = planned_decel(&heavy);
        assert!((a - 840).abs() < 30, "planned {a} mm/s²");
        let exact = (1_i64 << 40) / (2 * i64::from(decel.to_bits()));
        assert_eq!(i64::from(inv.0), exact);
        // One bound below 1 200 a little: 850 × 1.4 = 1 190.
        let a = planned_decel(&take_up(850, 300));
        assert!((a - 1_190).abs() < 40, "planned {a} mm/s²");
        // A carriage that crawls up to speed: the floor, 100 mm/s².
        let crawling = take_up(40, 3_000);
        assert_eq!(crawling.braking_deceleration().0, BRAKING_DECELERATION_MIN);
        // Still accelerating (three quarters of the limit not reached): nothing identified.
        let early = take_up(600, 60);
        assert_eq!(early.braking_deceleration().0, Q16::const_from_int(1_200));
        // A jump to full speed within the shortest span measures nothing.
        let jump = take_up(1_000_000, 50);
        assert_eq!(jump.braking_deceleration().0, Q16::const_from_int(1_200));
        // The next pull starts afresh.
        let mut again = heavy;
        again.start(&PullSettings::default(), PullKind::Main);
        assert_eq!(again.braking_deceleration().0, Q16::const_from_int(1_200));
        assert_eq!(again.state().take_up_mark, 0);
    }

    #[test]
    fn the_identification_starts_and_ends_on_its_thresholds_and_stays_valid() {
        // Speed 9: limit 81 mm/s; the thresholds in Q15.16 bits as the profile computes them.
        let mut profile = take_up(0, 1);
        let limit = profile.state().speed_limit.0.to_bits();
        let (quarter, three_quarters) = (limit >> 2, limit - (limit >> 2));
        let at = |profile: &mut Profile, bits: i32| {
            profile.tick();
            profile.observe_take_up(MmPerSecond(Q16::from_bits(bits)), Kgf::ZERO);
        };
        at(&mut profile, quarter - 1);
        assert_eq!(profile.state().take_up_mark, 0, "below a quarter: not started");
        at(&mut profile, quarter);
        let mark = profile.state().take_up_mark;
        assert!(mark > 0, "a quarter starts the measurement");
        for _ in 0..3 {
            at(&mut profile, three_quarters - 1);
        }
        assert_eq!(profile.state().braking_decel, Q16::ZERO, "below three quarters: not done");
        at(&mut profile, three_quarters);
        // Three quarters ends it: 40.5 mm/s in 4 ms is ≈ 10 000 mm/s²; the plan stays at the
        // configured 1 200, now recorded as identified.
        assert_eq!(profile.state().braking_decel, Q16::const_from_int(1_200));
        assert_eq!(profile.state().take_up_mark, mark);
        // A speed limit too small to have a quarter measures nothing, however long.
        let mut tiny = take_up(0, 1);
        let mut state = tiny.state();
        state.speed_limit = MmPerSecond(Q16::from_bits(3));
        tiny.set_state(state);
        for _ in 0..10 {
            at(&mut tiny, 0);
        }
        assert_eq!(tiny.state().take_up_mark, 0);
        assert_eq!(tiny.state().braking_decel, Q16::ZERO);
        // Validity: the identified deceleration within [0, configured], its 1/(2a) not
        // negative.
        let valid_with = |decel: i32, inv: i32| {
            let mut p = take_up(0, 1);
            let mut state = p.state();
            state.braking_decel = Q16::from_bits(decel);
            state.braking_inv_two_decel = Q24(inv);
            p.set_state(state);
            p.is_valid()
        };
        let configured = 1_200 << 16;
        assert!(valid_with(0, 0));
        assert!(valid_with(configured, 1));
        assert!(!valid_with(-1, 0));
        assert!(!valid_with(configured + 1, 0));
        assert!(!valid_with(0, -1));
        // And the reference within [0, TENSION_MAX], both ends.
        let with_reference = |reference: i64| {
            let mut p = take_up(0, 1);
            let mut state = p.state();
            state.reference = Q32(reference);
            p.set_state(state);
            p.is_valid()
        };
        let max = Q32::from_q16(TENSION_MAX.0).0;
        assert!(with_reference(0) && with_reference(max));
        assert!(!with_reference(-1) && !with_reference(max + 1));
    }

    #[test]
    fn the_braking_parabola_uses_the_identified_deceleration() {
        let est = |speed: i32| Estimate {
            tension: Kgf::from_int(10),
            sample: Kgf::from_int(10),
            clipped: Kgf::from_int(10),
            rate: KgfPerSecond::from_int(50),
            speed: MmPerSecond(Q16::const_from_int(speed)),
            steps: 0,
        };
        let mut configured = take_up(2_000, 200);
        let mut heavy = take_up(600, 300);
        // K̂ = 50/50 = 1 kgf/mm: ÿ_d = −K̂·a.
        configured.begin_braking(&est(50));
        heavy.begin_braking(&est(50));
        let accel = |p: &Profile| p.state().reference_accel.to_bits() >> 16;
        assert!((accel(&configured) + 1_200).abs() < 5, "{}", accel(&configured));
        assert!((accel(&heavy) + 840).abs() < 35, "{}", accel(&heavy));
        // And the braking starts earlier: the rise ẏ·v/(2a) is larger for the lower a.
        let rise = |p: &Profile| p.braking_rise(&est(50)).0;
        assert!(rise(&heavy) > rise(&configured));
        // Outside the take-up nothing is measured.
        let before = heavy.state();
        heavy.observe_take_up(MmPerSecond(Q16::const_from_int(70)), Kgf::from_int(3));
        assert_eq!(heavy.state(), before);
    }

    fn valid_coefficients(config: &ProfileConfig, period_us: u32) -> ProfileCoefficients {
        ProfileCoefficients::new(config, period_us).unwrap_or(ProfileCoefficients::FALLBACK)
    }
}

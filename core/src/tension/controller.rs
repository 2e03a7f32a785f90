//! The tension controller the machine runs at 1 kHz: pull profile + control law + duty map.
//!
//! # Theory of operation
//!
//! [`TensionController::start`] arms a pull from [`PullSettings`]; every tick
//! [`TensionController::step`] takes a [`Measurement`] (calibrated tension, the drive's
//! status with its Hall step count, motor current, limit switches) and returns a
//! [`ControlOutput`]: the [`DriveCommand`] for the bridge, the [`PullPhase`] and the
//! "at tension" flag the machine turns into the hold LED and the beeper.
//! [`TensionController::release`] starts the homing move and [`TensionController::stop`]
//! coasts at once.
//!
//! With the **shaped** profile (taut) a pull runs through these phases:
//!
//! 1. [`PullPhase::TakeUp`] — velocity mode: the carriage runs at the speed setting's limit
//!    (duty = back-EMF of that speed + resistive drop of the present tension), taking up the
//!    slack and stretching the string, while the tension and its rate are watched.
//! 2. [`PullPhase::Approach`] — when the remaining tension `T_peak − y` drops to what the
//!    present tension rate would cover in the approach time constant `τ_a` (plus a small
//!    margin), the law takes over, tracking a reference that starts at the present tension
//!    and rate and closes on the target exponentially: `ẏ_d = (T − y_d)/τ_a`,
//!    `ÿ_d = −ẏ_d/τ_a`. The reference's deceleration enters the law's equivalent control
//!    (`ÿ_d/D̄`) so the carriage is braked *before* the tension arrives, which is the only
//!    way to stop hundreds of kilograms of reflected rotor inertia without overshoot.
//! 3. [`PullPhase::PreStretch`] — with pre-stretch, the peak `T(1 + p)` is held for
//!    [`ProfileConfig::pre_stretch_dwell_ms`], then
//! 4. [`PullPhase::Settle`] — the reference closes exponentially on the final target.
//! 5. [`PullPhase::Hold`] — constant pull at the final target: the law keeps feeding string
//!    as it creeps. "At tension" latches the first time the measured tension is within
//!    [`ProfileConfig::at_tension_band`] of the final target in this phase.
//!
//! With the **step** profile (the paper's simulation, used for the `paper_rsmc` and `pd`
//! baselines) the reference jumps to the target at Start and the law acts from the first
//! tick; the phase reads `Approach` until the tension first enters the band, then `Hold`.
//!
//! [`PullPhase::Release`] drives toward home at [`ProfileConfig::release_speed`] (velocity
//! feed-forward, duty at most [`RELEASE_DUTY_MAX`]) until the home switch closes, then goes
//! [`PullPhase::Idle`] and coasts.
//!
//! # Invariant and guarantees
//!
//! [`TensionController::is_valid`] states what every reachable state satisfies (the law's
//! integral and adaptive gain within their bounds, the reference within the tension range).
//! For every valid state and every measurement, [`TensionController::step`] returns a duty
//! within [`crate::drive::DUTY_MAX`] (by the `Duty` type), never panics, and leaves a valid
//! state; `proofs/` checks this with Kani, exhaustively-sampled tests and a fuzzer.
//!
//! # Fixed point
//!
//! The reference `y_d` is kept in Q31.32 (`i64`) so the exponential approach keeps moving
//! when its per-tick increment is below Q15.16's 15 µkgf; everything else is as in
//! [`crate::tension::law`].

use crate::drive::{Direction, DriveCommand, DriveStatus, Duty};
use crate::io::LimitSwitches;
use crate::tension::law::{
    BoundedAdaptation, GainError, Improvements, NominalPlant, Pd, PdGains, Reference, Rsmc,
    RsmcGains, Saturation, mul_wide, narrow, saturate_i32,
};
use crate::tension::motor::{DutyMap, ForceToDuty, MotorError, MotorModel, SpeedEstimator};
use crate::tension::settings::{MmPerSecond, PullKind, PullSettings, TENSION_MAX};
use crate::units::{Amps, Kgf, KgfPerSecond, Q16, Seconds};

/// The most duty a release (homing) move uses: 60 %.
pub const RELEASE_DUTY_MAX: Duty = Duty::from_raw_clamped(39_322);

/// The shortest and longest control periods accepted: 50 µs to 10 ms.
pub const PERIOD_RANGE_US: (u32, u32) = (50, 10_000);

/// Which law computes the force.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum LawConfig {
    /// The robust sliding-mode controller (paper's or taut's, by its improvements).
    Rsmc(RsmcGains),
    /// The PD baseline.
    Pd(PdGains),
}

/// The pull profile's parameters.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct ProfileConfig {
    /// Shaped profile (take-up, approach, …) or a step set point (the paper's simulation).
    pub shaped: bool,
    /// The approach time constant `τ_a`.
    pub approach_time_constant: Seconds,
    /// Extra tension margin before the approach starts, kgf.
    pub approach_margin: Kgf,
    /// How long the pre-stretch peak is held, ms.
    pub pre_stretch_dwell_ms: u16,
    /// The band around the final target that counts as "at tension".
    pub at_tension_band: Kgf,
    /// The carriage speed of a release move.
    pub release_speed: MmPerSecond,
    /// Low-pass time constant of the tension-rate estimate that times the approach.
    pub rate_filter: Seconds,
    /// Low-pass time constant of the Hall speed estimate.
    pub speed_filter: Seconds,
    /// The carriage's effective mass for the coast-stop prediction, kgf·s²/mm (rotor and
    /// gearbox inertia reflected through the screw plus the carriage: 394 kg = 0.0402).
    pub coast_mass: Q16,
}

impl ProfileConfig {
    /// taut's profile.
    pub const TAUT: Self = Self {
        shaped: true,
        approach_time_constant: Seconds(Q16::lit("0.15")),
        approach_margin: Kgf(Q16::lit("0.3")),
        pre_stretch_dwell_ms: 300,
        at_tension_band: Kgf(Q16::lit("0.1")),
        release_speed: MmPerSecond::from_int(40),
        rate_filter: Seconds(Q16::lit("0.005")),
        speed_filter: Seconds(Q16::lit("0.004")),
        coast_mass: Q16::lit("0.0402"),
    };

    /// A step set point, as in the paper's simulation.
    pub const STEP: Self = Self { shaped: false, ..Self::TAUT };
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

/// taut's nominal plant: `M̄` = the rotor and gearbox inertia reflected to the carriage
/// (1.6 × 10⁻⁵ kg·m² / (0.2021 mm/rad)² ≈ 392 kg, plus the 2 kg carriage: 394 kg =
/// 40.2 kgf·s²/m), `K̄` = a mid-range string, 5 kgf/cm = 500 kgf/m, `B̄` small (screw
/// viscous friction only: back-EMF is compensated in the duty map):
/// `D̄ = K̄/M̄ ≈ 12.4 s⁻²`, `Ā ≈ 2 s⁻¹`.
pub const TAUT_PLANT: NominalPlant =
    NominalPlant { a_bar: Q16::const_from_int(2), d_bar: Q16::lit("12.4") };

/// taut's RSMC: the paper's structure with every improvement on.
pub const TAUT_GAINS: RsmcGains = RsmcGains {
    lambda: Q16::const_from_int(25),
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

impl ControllerConfig {
    /// taut's controller at 1 kHz.
    pub const TAUT: Self = Self {
        period_us: 1_000,
        law: LawConfig::Rsmc(TAUT_GAINS),
        duty_map: DutyMap::BackEmf { current_limit: Amps::from_int(8) },
        motor: MotorModel::PAPER,
        profile: ProfileConfig::TAUT,
    };

    /// The paper's RSMC as published (λ = 100, G = 0.2, k_φ = 0.001, `sgn`, unbounded
    /// `φ̂`, raw derivative) on the machine's nominal plant, duty proportional to force, step
    /// set point, at 1 kHz.
    pub const PAPER_RSMC: Self = Self {
        period_us: 1_000,
        law: LawConfig::Rsmc(RsmcGains::paper(TAUT_PLANT)),
        duty_map: DutyMap::Proportional { current_limit: Amps::from_int(8) },
        motor: MotorModel::PAPER,
        profile: ProfileConfig::STEP,
    };

    /// The paper's PD baseline (`k_p = 100`, `k_d = 20`), duty proportional to force, step
    /// set point, at 1 kHz.
    pub const PD: Self = Self {
        period_us: 1_000,
        law: LawConfig::Pd(PdGains::PAPER),
        duty_map: DutyMap::Proportional { current_limit: Amps::from_int(8) },
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
    /// A profile parameter is not positive.
    Profile,
}

/// What the controller is told each tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Measurement {
    /// The calibrated string tension.
    pub tension: Kgf,
    /// The drive's report (Hall step count for carriage speed, fault, rotation).
    pub drive: DriveStatus,
    /// The motor current.
    pub current: Amps,
    /// The carriage limit switches.
    pub limits: LimitSwitches,
}

/// Where in a pull the controller is.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub enum PullPhase {
    /// Not driving; the output is coast.
    #[default]
    Idle,
    /// Taking up slack at the speed setting's carriage speed.
    TakeUp,
    /// Closing in on the (peak) target.
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
    /// The goal the reference closes on.
    pub goal: Kgf,
    /// Ticks spent in the present phase (saturating).
    pub ticks: u32,
    /// The previous measured tension, kgf bits.
    pub last_tension: i32,
    /// The filtered tension rate, kgf/s bits.
    pub rate: i32,
    /// "At tension" latched.
    pub at_tension: bool,
    /// Which way the previous output saturated.
    pub saturated: Saturation,
    /// The approach is coasting toward the target (drive off, string and friction braking).
    pub coasting: bool,
    /// The last five tension samples, kgf bits (oldest first), for the spike filter.
    pub window: [i32; 5],
}

/// The tension controller. See the module docs.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct TensionController {
    law: Law,
    map: ForceToDuty,
    speed: SpeedEstimator,
    shaped: bool,
    /// `dt/τ_a`, Q0.32 in an `i64`.
    approach_step: i64,
    /// `1/τ_a`, Q15.16.
    inv_tau: i32,
    /// `1/dt`, Hz.
    inv_dt: i32,
    /// Tension-rate filter gain, Q15.16.
    rate_alpha: i32,
    /// Approach margin, kgf bits.
    margin: i32,
    /// τ_a, Q15.16 seconds.
    tau: i32,
    dwell_ticks: u32,
    band: i32,
    /// Coast-stop mass, Q15.16 kgf·s²/mm.
    coast_mass: i32,
    /// The coast ends below this tension rate (kgf/s bits) …
    stop_rate: i32,
    /// … or below this carriage speed (mm/s bits).
    stop_speed: i32,
    release_speed: MmPerSecond,
    profile: ProfileState,
}

impl Default for TensionController {
    /// taut's controller ([`ControllerConfig::TAUT`]).
    fn default() -> Self {
        Self::taut()
    }
}

/// The median of five values: `median(e, max(min(a,b), min(c,d)), min(max(a,b), max(c,d)))`
/// (six comparisons, no branches on data beyond `min`/`max`).
#[must_use]
pub fn median5(a: i32, b: i32, c: i32, d: i32, e: i32) -> i32 {
    let f = a.min(b).max(c.min(d));
    let g = a.max(b).min(c.max(d));
    // Median of three: max(min(e, f), min(max(e, f), g)).
    e.min(f).max(e.max(f).min(g))
}

/// `dt` in Q15.16 seconds, at least one LSB.
fn dt_q16(period_us: u32) -> Q16 {
    let dt = Q16::from_num(period_us).saturating_div_int(1_000_000);
    if dt == Q16::ZERO { Q16::DELTA } else { dt }
}

/// A filter gain `dt/(τ + dt)`, Q15.16, at least one LSB.
fn alpha(period_us: u32, tau: Seconds) -> Result<i32, ConfigError> {
    let dt = dt_q16(period_us);
    if tau.0 < Q16::ZERO {
        return Err(ConfigError::Profile);
    }
    Ok(dt.checked_div(tau.0.saturating_add(dt)).ok_or(ConfigError::Profile)?.to_bits().max(1))
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
        let profile = config.profile;
        let speed =
            SpeedEstimator::new(period, profile.speed_filter).map_err(ConfigError::Motor)?;
        let tau = profile.approach_time_constant.0;
        if tau <= Q16::ZERO
            || profile.at_tension_band.0 <= Q16::ZERO
            || profile.approach_margin.0 < Q16::ZERO
            || profile.release_speed.0 <= Q16::ZERO
        {
            return Err(ConfigError::Profile);
        }
        // dt/τ in Q0.32: period_us · 2³² / (τ in µs).
        let tau_us = i64::from(tau.to_bits()).saturating_mul(1_000_000) >> 16;
        let approach_step =
            (i64::from(period) << 32).checked_div(tau_us).ok_or(ConfigError::Profile)?;
        if approach_step <= 0 || approach_step >= (1_i64 << 32) {
            return Err(ConfigError::Profile);
        }
        let inv_tau = Q16::ONE.checked_div(tau).ok_or(ConfigError::Profile)?.to_bits();
        let inv_dt = i32::try_from(1_000_000_u32.checked_div(period).unwrap_or(0))
            .map_err(|_| ConfigError::Period)?;
        Ok(Self {
            law,
            map,
            speed,
            shaped: profile.shaped,
            approach_step,
            inv_tau,
            inv_dt,
            rate_alpha: alpha(period, profile.rate_filter)?,
            margin: profile.approach_margin.to_bits(),
            tau: tau.to_bits(),
            dwell_ticks: u32::from(profile.pre_stretch_dwell_ms)
                .saturating_mul(1_000)
                .checked_div(period)
                .unwrap_or(0),
            band: profile.at_tension_band.to_bits(),
            coast_mass: profile.coast_mass.to_bits(),
            stop_rate: Q16::const_from_int(1).to_bits(),
            stop_speed: Q16::lit("0.5").to_bits(),
            release_speed: profile.release_speed,
            profile: ProfileState::default(),
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
            shaped: false,
            approach_step: 1 << 27,
            inv_tau: 40 << 16,
            inv_dt: 1_000,
            rate_alpha: 1 << 13,
            margin: 1 << 14,
            tau: 1_638,
            dwell_ticks: 0,
            band: 6_554,
            coast_mass: 0,
            stop_rate: 0,
            stop_speed: 0,
            release_speed: MmPerSecond::from_int(20),
            profile: ProfileState::default(),
        }
    }

    /// Arms a pull of `kind` with `settings`; the next [`TensionController::step`] starts
    /// driving.
    pub fn start(&mut self, settings: &PullSettings, kind: PullKind) {
        let peak = settings.peak_target(kind);
        let final_target = settings.final_target(kind);
        self.speed.reset();
        self.profile = ProfileState {
            phase: if self.shaped { PullPhase::TakeUp } else { PullPhase::Approach },
            peak,
            final_target,
            speed_limit: settings.speed().carriage_limit(),
            reference: i64::from(peak.to_bits()) << 16,
            goal: peak,
            ticks: 0,
            last_tension: 0,
            rate: 0,
            at_tension: false,
            saturated: Saturation::None,
            coasting: false,
            window: self.profile.window,
        };
        self.reset_law(Kgf::ZERO, Kgf::ZERO);
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

    /// The invariant every reachable state satisfies: the law's own invariant, targets and
    /// reference within `[0, TENSION_MAX]`, the peak at or above the final target.
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
            && in_range(p.peak)
            && in_range(p.final_target)
            && in_range(p.goal)
            && p.final_target <= p.peak
            && reference_ok
    }

    fn reset_law(&mut self, e0: Kgf, _rate: Kgf) {
        match &mut self.law {
            Law::Rsmc(rsmc) => rsmc.reset(e0),
            Law::Pd(pd) => pd.reset(e0),
        }
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

    /// Advances the exponential reference toward the goal; returns (ẏ_d, ÿ_d) in bits.
    fn advance_reference(&mut self) -> (i32, i32) {
        let goal = i64::from(self.profile.goal.to_bits()) << 16;
        let gap = goal.saturating_sub(self.profile.reference);
        // y_d += gap·dt/τ (Q31.32 × Q0.32 → split the product to stay in 64 bits).
        let step = (gap >> 16).saturating_mul(self.approach_step) >> 16;
        let step = if step == 0 && gap != 0 { gap.signum() } else { step };
        self.profile.reference = self.profile.reference.saturating_add(step);
        let gap_bits = saturate_i32(goal.saturating_sub(self.profile.reference) >> 16);
        let rate = narrow(mul_wide(gap_bits, self.inv_tau));
        let accel = narrow(mul_wide(rate, self.inv_tau)).saturating_neg();
        (rate, accel)
    }

    /// One control tick.
    pub fn step(&mut self, m: &Measurement) -> ControlOutput {
        let speed = self.speed.update(m.drive.steps);
        let [_, w1, w2, w3, w4] = self.profile.window;
        let sample = m.tension.to_bits();
        self.profile.window = [w1, w2, w3, w4, sample];
        let y = median5(w1, w2, w3, w4, sample);
        let filtered = Measurement { tension: Kgf::from_bits(y), ..*m };
        let m = &filtered;
        // Tension rate: filtered backward difference (timing of the approach only).
        let raw_rate = saturate_i32(
            i64::from(y)
                .saturating_sub(i64::from(self.profile.last_tension))
                .saturating_mul(i64::from(self.inv_dt)),
        );
        let rate_step = narrow(
            i64::from(raw_rate)
                .saturating_sub(i64::from(self.profile.rate))
                .saturating_mul(i64::from(self.rate_alpha)),
        );
        self.profile.rate = self.profile.rate.saturating_add(rate_step);
        self.profile.last_tension = y;
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
                // Coast-stop prediction: a carriage of (reflected) mass M̄ moving at v into a
                // string of stiffness K = ẏ/v stops after a further rise of
                // ẏ/ω = ẏ·√(M̄/K) = √(M̄·v·ẏ) (friction only shortens it). The drive cannot
                // brake (high-side PWM with diode freewheeling only ever motors), so the pull
                // coasts as soon as that rise reaches the remaining tension minus a margin.
                let remaining =
                    self.profile.peak.to_bits().saturating_sub(y).saturating_sub(self.margin);
                let momentum = narrow(mul_wide(self.coast_mass, speed.0.to_bits().max(0)));
                let rise_squared = mul_wide(momentum, self.profile.rate.max(0));
                if remaining <= 0 || mul_wide(remaining, remaining) <= rise_squared {
                    self.profile.coasting = true;
                    self.enter(PullPhase::Approach);
                    DriveCommand::Drive { direction: Direction::Pull, duty: Duty::ZERO }
                } else {
                    // Run at the speed limit, accelerating no harder than the current
                    // limit allows (full duty from rest would draw the stall current).
                    let load = Kgf::from_bits(y.max(0));
                    let cruise = self.map.velocity_duty(
                        self.profile.speed_limit,
                        load,
                        crate::drive::DUTY_MAX,
                    );
                    let (limited, _) = self.map.command(self.map.force_limit(), speed);
                    let duty = if limited.duty() < cruise { limited.duty() } else { cruise };
                    DriveCommand::Drive { direction: Direction::Pull, duty }
                }
            }
            PullPhase::Approach if self.profile.coasting => {
                // Coast until the tension stops rising or the carriage stops, then close the
                // loop from where the coast ended.
                if self.profile.rate <= self.stop_rate || speed.0.to_bits() <= self.stop_speed {
                    self.profile.coasting = false;
                    self.profile.reference =
                        i64::from(y.clamp(0, self.profile.peak.to_bits())) << 16;
                    self.profile.goal = self.profile.peak;
                    self.reset_law(Kgf::ZERO, Kgf::ZERO);
                    self.closed_loop(m, speed, &mut force)
                } else {
                    DriveCommand::Drive { direction: Direction::Pull, duty: Duty::ZERO }
                }
            }
            PullPhase::Approach | PullPhase::PreStretch | PullPhase::Settle | PullPhase::Hold => {
                self.closed_loop(m, speed, &mut force)
            }
        };
        ControlOutput {
            command,
            phase: self.profile.phase,
            at_tension: self.profile.at_tension,
            reference: self.reference_kgf(),
            force,
        }
    }

    /// The closed-loop phases: advance the profile, run the law, map to duty.
    fn closed_loop(
        &mut self,
        m: &Measurement,
        speed: MmPerSecond,
        force_out: &mut Kgf,
    ) -> DriveCommand {
        let y = m.tension;
        let (rate, accel) = if self.shaped {
            self.advance_reference()
        } else {
            self.profile.reference = i64::from(self.profile.goal.to_bits()) << 16;
            (0, 0)
        };
        let reference = Reference {
            tension: self.reference_kgf(),
            rate: KgfPerSecond::from_bits(rate),
            accel: Q16::from_bits(accel),
        };
        let force = match &mut self.law {
            Law::Rsmc(rsmc) => rsmc.step(&reference, y, self.profile.saturated).force,
            Law::Pd(pd) => pd.step(&reference, y),
        };
        let (command, saturated) = self.map.command(force, speed);
        self.profile.saturated = saturated;
        *force_out = force;

        // Phase transitions.
        let error_to_final =
            y.to_bits().saturating_sub(self.profile.final_target.to_bits()).saturating_abs();
        let reached_goal = {
            let goal = i64::from(self.profile.goal.to_bits()) << 16;
            goal.saturating_sub(self.profile.reference).abs() < (1 << 22)
        };
        let peak_above = self.profile.peak > self.profile.final_target;
        match self.profile.phase {
            PullPhase::Approach => {
                let arrived = if self.shaped {
                    reached_goal
                } else {
                    y.to_bits().saturating_sub(self.profile.goal.to_bits()).saturating_abs()
                        <= self.band
                };
                if arrived {
                    if peak_above {
                        self.enter(PullPhase::PreStretch);
                    } else {
                        self.enter(PullPhase::Hold);
                    }
                }
            }
            PullPhase::PreStretch => {
                if self.profile.ticks >= self.dwell_ticks {
                    self.profile.goal = self.profile.final_target;
                    self.enter(PullPhase::Settle);
                }
            }
            PullPhase::Settle => {
                let arrived = if self.shaped { reached_goal } else { error_to_final <= self.band };
                if arrived {
                    self.enter(PullPhase::Hold);
                }
            }
            PullPhase::Hold => {
                if error_to_final <= self.band {
                    self.profile.at_tension = true;
                }
            }
            PullPhase::Idle | PullPhase::TakeUp | PullPhase::Release => {}
        }
        command
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tension::settings::{KnotBoost, PreStretch, Speed};

    #[test]
    fn built_in_configurations_are_valid() {
        for config in [ControllerConfig::TAUT, ControllerConfig::PAPER_RSMC, ControllerConfig::PD] {
            let controller = TensionController::new(&config).unwrap();
            assert!(controller.is_valid());
        }
        assert_ne!(TensionController::taut(), TensionController::fallback());
    }

    #[test]
    fn median5_is_the_median_of_every_pattern() {
        // Every ordering pattern of five values drawn from 0..5 (3 125 cases).
        let mut cases = 0;
        for n in 0..3_125_i32 {
            let v = [n % 5, n / 5 % 5, n / 25 % 5, n / 125 % 5, n / 625 % 5];
            let mut sorted = v;
            sorted.sort_unstable();
            assert_eq!(median5(v[0], v[1], v[2], v[3], v[4]), sorted[2], "{v:?}");
            cases += 1;
        }
        assert_eq!(cases, 3_125);
    }

    #[test]
    fn rejects_bad_periods() {
        let config = ControllerConfig { period_us: 20_000, ..ControllerConfig::TAUT };
        assert_eq!(TensionController::new(&config), Err(ConfigError::Period));
    }

    #[test]
    fn start_release_stop_walk_the_phases() {
        let mut controller = TensionController::taut();
        let idle = controller.step(&Measurement::default());
        assert_eq!(idle.command, DriveCommand::Coast);
        let settings =
            PullSettings::new(Kgf::from_int(20), Speed::MAX, PreStretch::NONE, KnotBoost::NONE)
                .unwrap();
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
}

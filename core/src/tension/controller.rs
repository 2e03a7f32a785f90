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
//!    string, while the estimator measures the tension rate `ẏ` and the carriage speed `v`,
//!    and the profile measures the carriage's acceleration to plan the braking with
//!    ([`Profile::observe_take_up`], REQ-ID-06: no more than this machine can do) and the
//!    gripper's inertial force on the load cell (REQ-ID-07).
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
//!    law's equivalent control turns `ÿ_d` and `ẏ_d` into the braking force. While it
//!    brakes, the gripper's inertial force the take-up identified is added back to the
//!    load-cell reading ([`Profile::gripper_bias`]): decelerating, the cell reads `m_g·a`
//!    below the string's pull, and the braking would drive on into tension it does not see.
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
//! back-drive, instead of waiting for the string to creep. The back-out acts only on evidence
//! a burst of load-cell spikes cannot fake — the excess in both the estimate and the
//! burst-proof filtered sample (the estimator's median of fifteen Hall-moved samples) for
//! [`BACK_OUT_CONFIRM`] consecutive ticks — and only what a release of *this* drivetrain
//! removes: the controller identifies whether the drivetrain holds or **back-drives**
//! (REQ-TEN-20: a Hall step toward home while it commanded a pull in the settle or the hold;
//! a screw that holds never moves back under a pull). On a drivetrain that back-drives, a
//! release takes the string's whole pull off the motor, not the excess: the carriage runs
//! home under the string and the tension falls far past the reference. There the back-out
//! drives toward home, in the settle, only while the carriage backs off slower than the
//! back-out's speed (faster, the law's braking command stands and the string itself does the
//! rest), and in the hold not at all.
//!
//! **The hold only pulls** (REQ-TEN-23): in the hold the force never drops below the
//! string's own pull — the law's correction is floored at zero. A string with internal
//! friction (below) is many times stiffer for the first fraction of a millimetre after the
//! carriage turns back, and that travel is smaller than a Hall step, so neither the
//! observer nor the law sees it coming: a law that lets go of an excess of a few hundredths
//! turns the carriage back into that stiffness, the tension falls tenths of a kgf within
//! milliseconds, the law pulls hard to recover, and the hold rings. Held at its pull the
//! carriage does not turn; an excess comes off by the back-out (on a drivetrain that holds)
//! and by the string's creep, which is what a constant-pull head is for.
//!
//! In the settle and the hold a **governor** watches the error for a limit cycle (REQ-TEN-22):
//! four excursions beyond [`SWING_BAND`] of alternating sign within [`SWING_WINDOW_MS`]
//! halve the law's correction over the string's pull (`y + (u − y)/2`, the pull itself still
//! balanced in full), up to [`GOVERNOR_SHIFT_MAX`] times in a pull. The law is tuned to the
//! stiffness identified while the string was drawn out; a string with internal friction
//! (hysteresis) is many times stiffer for the first fraction of a millimetre after every
//! change of direction — `2h·T` over the turning strain `δ`, 20 × the drawn-out stiffness for
//! 3 % at 30 kgf over 0.1 mm — and a hold that moves back and forth meets that stiffness at
//! every reversal, so at full gain it can ring at 10–20 Hz with a growing swing. A hold that
//! keeps to its band (the family's without hysteresis: its p99 error is under the band) is
//! never governed.
//!
//! With the **step** profile (the paper's simulation, used for the `paper_rsmc` and `pd`
//! baselines) the reference is the target from the first tick and the law acts at once;
//! the phase reads `Approach` until the tension first enters the band, then `Hold`.
//!
//! [`PullPhase::Release`] drives toward home at [`ProfileConfig::release_speed`] (velocity
//! feed-forward, duty at most [`RELEASE_DUTY_MAX`]) until the home switch closes, then goes
//! [`PullPhase::Idle`] and coasts. The pull started on the home switch, so the controller
//! knows where home is in Hall steps (the count at the pull's first tick): the release
//! **brakes onto the switch** (REQ-TEN-21) — its speed is [`RELEASE_APPROACH_GAIN`] per
//! second times the distance left to that count, within [`RELEASE_CREEP`] and the release
//! speed, so the carriage reaches the switch at the creep speed whatever speed it released
//! at; the velocity feed-forward below the back-EMF brakes (the complementary bridge, within
//! the drive's current window). Coasting from 8 mm/s the carriage stops within tenths of a
//! millimetre of the switch, never reaching an end stop 1.5 mm past it; coasting from the
//! 40 mm/s release it ran ≈ 7 mm past.
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
//! As in [`crate::tension::law`] and [`crate::tension::profile`] (whose reference is kept
//! in Q31.32): Q15.16 signals, exact 64-bit products ([`crate::fixed`]). The step has no
//! division: the one reciprocal (the stiffness, at the braking onset) is [`reciprocal_q24`];
//! once per pull the take-up's identification divides (see [`crate::tension::profile`]).

use crate::drive::{DUTY_MAX, Direction, DriveCommand, Duty};
use crate::fixed::{Q24, mul_q16, mul_q24, reciprocal_q24};
use crate::io::LimitSwitches;
use crate::mechanism::STEP_MM_BITS;
use crate::settings::{MmPerSecond, PullKind, PullSettings};
use crate::tension::estimator::{Estimate, EstimatorConfig, EstimatorError, TensionEstimator};
use crate::tension::law::{
    BoundedAdaptation, GainError, Improvements, NominalPlant, Pd, PdGains, Rsmc, RsmcGains,
};
use crate::tension::motor::{DutyMap, ForceToDuty, MotorError, MotorModel, SpeedEstimator};
use crate::tension::profile::{Profile, ProfileConfig, ProfileError, ProfileState, PullPhase};
use crate::tension::slip::{SLIP_DEAD_ZONE, SLIP_LEARNING_RATE, SlipDamper};
use crate::units::{Amps, Kgf, KgfPerSecond, Q16, Seconds, Volts};

/// The most duty a release (homing) move uses: 60 %.
pub const RELEASE_DUTY_MAX: Duty = Duty::from_raw_clamped(39_322);

/// REQ-TEN-21: the release's speed per millimetre still to go to where the pull started,
/// 8 mm/s per mm (a time constant of 125 ms): from the 40 mm/s release the braking starts
/// 5 mm out at 320 mm/s², a few kgf of the motor's 140 kgf at the current limit.
pub const RELEASE_APPROACH_GAIN: i32 = 8;

/// REQ-TEN-21: the speed a release reaches the home switch at, 8 mm/s (2.5 V of back-EMF,
/// under the current window's 5.6 V, and a Hall step every 7 ms, far inside the stall
/// rule's 500 ms).
pub const RELEASE_CREEP: MmPerSecond = MmPerSecond::from_int(8);

/// Constant pull off (lock-out, REQ-TEN-18): the carriage is held where it was locked, with
/// this much force per Hall step it has moved from there: 0.1 kgf a step (52.9 µm), ≈ 1.9 kgf
/// per mm. The motor's force is the string's estimated pull plus this spring, mapped to duty
/// *at zero speed*, so the motor's own back-EMF damps the hold (`c_v/c_f` ≈ 6.8 kgf per mm/s:
/// a 3.6 s time constant, no oscillation on any string), and the string's pull cancels out of
/// the carriage's balance: what is left pins the carriage within a step or two of where it
/// was (a 0.1 kgf sensing error moves it one step), while the string creeps at constant
/// length — a crank machine's lock.
pub const LOCK_STIFFNESS: Kgf = Kgf(Q16::lit("0.1"));

/// The lock-out's spring acts over at most this many Hall steps either way (±5 kgf): a
/// carriage pushed further (a clamp slipping) is not yanked back at full force.
pub const LOCK_SPAN_STEPS: i32 = 50;

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

/// REQ-TEN-17: how many consecutive ticks the excess must last, in the estimate and in the
/// burst-proof filtered sample, before the back-out releases: 12 — more than a burst of
/// [`BURST_MAX`] spikes and the median's two ticks of delay, so even a burst that reached the
/// filtered sample (before the stiffness is known) is over before the release would begin.
///
/// [`BURST_MAX`]: crate::tension::estimator::BURST_MAX
pub const BACK_OUT_CONFIRM: u8 = 12;

/// REQ-TEN-20: Hall steps toward home under a pull command, in the settle and the hold, that
/// identify a drivetrain that back-drives: 2 (one step could be a Hall edge jittering at the
/// rotor's rest position).
pub const BACK_DRIVE_STEPS: u8 = 2;

/// REQ-TEN-22, the hold's governor: an error beyond this band either side of the reference,
/// in the settle or the hold, is an excursion; 0.1 kgf, above the hold's ordinary error on
/// every machine of the family (its p99 is under it), so a hold that keeps to its band never
/// counts one.
pub const SWING_BAND: Kgf = Kgf(Q16::lit("0.1"));

/// REQ-TEN-22: excursions of alternating sign, each within [`SWING_WINDOW_MS`] of the
/// run's first, that mark the loop as oscillating: 4 (three reversals, one and a half
/// periods of a limit cycle).
pub const SWING_EXCURSIONS: u8 = 4;

/// REQ-TEN-22: the window the alternating excursions must fall in, ms: 300 (a limit cycle of
/// up to 5 Hz; a slow wander, a stick-slip sawtooth that only falls, is never one).
pub const SWING_WINDOW_MS: u32 = 300;

/// REQ-TEN-22: the governor halves the law's correction at most this many times (to ⅛).
pub const GOVERNOR_SHIFT_MAX: u8 = 3;

/// The shortest and longest control periods accepted: 50 µs to 10 ms.
pub const PERIOD_RANGE_US: (u32, u32) = (50, 10_000);

/// REQ-TEN-19: the hold's observer gain per kgf/mm of the string's identified stiffness,
/// 0.15 per tick. In the hold the carriage moves a Hall step (52.9 µm) at a time, so each
/// slip raises the tension by `K·52.9 µm`: 0.01 kgf on a soft badminton string, 0.08 on a
/// stiff polyester. The observer fuses the step at once, but what the fused value misses
/// (the stiffness estimate's error, a slip that runs on between Hall edges) reaches the law
/// only at the observer's gain; at 0.05 (20 ms) the law keeps pushing through a second
/// detent before it sees the first, and the sawtooth is two steps deep. The gain that
/// balances the load cell's noise against that lag grows with the step, so with the
/// stiffness: `α = K̂ × 0.15`, within [`ProfileConfig::observer_gain_hold`] (0.05, the soft
/// strings' gain) and [`HOLD_GAIN_MAX`]. On the family's worst 40 + 40 others (default
/// gauge): pulls over 0.05 kgf of hold error 20 → 13, the true tension's settle unchanged.
///
/// [`ProfileConfig::observer_gain_hold`]: crate::tension::ProfileConfig::observer_gain_hold
pub const HOLD_GAIN_PER_STIFFNESS: Q16 = Q16::lit("0.15");

/// REQ-TEN-19: the largest hold gain the stiffness gives, 0.2 per tick (5 ms): above it
/// the load cell's hum reaches the law (at 0.3 the family's noisiest cells chatter).
pub const HOLD_GAIN_MAX: Q16 = Q16::lit("0.2");

/// REQ-TEN-22: the law's force `law` with its correction over the string's pull `y` divided
/// by `2^shift` (rounded toward −∞): `y + (law − y) / 2^shift`. The string's own pull is
/// still balanced in full; only how hard the law corrects an error is lowered.
#[must_use]
pub fn governed(law: Kgf, y: Kgf, shift: u8) -> Kgf {
    let correction = law.0.to_bits().saturating_sub(y.0.to_bits());
    let lowered = correction.checked_shr(u32::from(shift)).unwrap_or(0);
    Kgf(Q16::from_bits(y.0.to_bits().saturating_add(lowered)))
}

/// The observer's hold gain for a string of identified stiffness `stiffness` (kgf/mm) on a
/// controller configured with the hold gain `floor` (REQ-TEN-19): `stiffness ×`
/// [`HOLD_GAIN_PER_STIFFNESS`], no less than `floor` and no more than [`HOLD_GAIN_MAX`]
/// (nor `floor`, if that is higher).
#[must_use]
pub fn hold_observer_gain(floor: Q16, stiffness: Q16) -> Q16 {
    let scaled = Q16::from_bits(mul_q16(stiffness.to_bits(), HOLD_GAIN_PER_STIFFNESS.to_bits()));
    scaled.min(HOLD_GAIN_MAX).max(floor)
}

/// The carriage speed (filtered, [`SpeedEstimator`]) below which a carriage that has
/// finished its braking counts as stopped and the observer takes its hold gain: 5 mm/s, a
/// Hall step in about 10 ms.
pub const HOLD_GAIN_SPEED: MmPerSecond = MmPerSecond::from_int(5);

/// Which law computes the force.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum LawConfig {
    /// The robust sliding-mode controller (paper's or taut's, by its improvements).
    Rsmc(RsmcGains),
    /// The PD baseline.
    Pd(PdGains),
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
    /// The duty the bridge's dead time takes from the high side: the dead time over the PWM
    /// period, both the board's; at most [`DEAD_TIME_DUTY_MAX`]. The slip damper's stall model
    /// starts from it. The built-in configurations assume an ideal bridge (zero); a board
    /// sets its own ([`crate::board::BoardConfig::new`]).
    pub dead_time_duty: Duty,
}

/// The largest dead-time duty a configuration may give: 0.1 (a 5 µs dead time in a 50 µs
/// period).
pub const DEAD_TIME_DUTY_MAX: Duty = Duty::from_raw_clamped(6_554);

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

#[cfg(any(test, feature = "paper-board"))]
/// The current the paper's board limits the winding to: 8 A, its drive's
/// (`crate::drive::limit::CurrentLimit::PAPER`'s `limit_ma`). A board's controller takes its
/// limit from the board's drive ([`crate::board::BoardConfig::new`]); this is for the
/// configurations built without a board (the twin's controller benches, the reports).
pub const CURRENT_LIMIT: Amps = Amps::from_int(8);

impl ControllerConfig {
    /// taut's controller at 1 kHz for a machine with `motor`, on a board that supplies the
    /// current limit: the duty map's `current_limit` is left at zero, a configuration
    /// [`TensionController::new`] refuses, until [`crate::board::BoardConfig::new`] sets it to
    /// the board's drive limit ([`Self::with_current_limit`]) — so a board states its limit
    /// once, in its drive's configuration.
    #[must_use]
    pub const fn taut(motor: MotorModel) -> Self {
        Self {
            period_us: 1_000,
            law: LawConfig::Rsmc(TAUT_GAINS),
            duty_map: DutyMap::Proportional { current_limit: Amps::ZERO },
            motor,
            profile: ProfileConfig::TAUT,
            dead_time_duty: Duty::ZERO,
        }
    }

    /// This configuration with its duty map limiting the winding current to `current_limit`
    /// (whichever map it is).
    #[must_use]
    pub const fn with_current_limit(self, current_limit: Amps) -> Self {
        let duty_map = match self.duty_map {
            DutyMap::Proportional { .. } => DutyMap::Proportional { current_limit },
            DutyMap::BackEmf { .. } => DutyMap::BackEmf { current_limit },
        };
        Self { duty_map, ..self }
    }

    #[cfg(any(test, feature = "paper-board"))]
    /// taut's controller at 1 kHz on the paper's machine and board ([`MotorModel::PAPER`],
    /// [`CURRENT_LIMIT`]).
    pub const TAUT: Self = Self::taut(MotorModel::PAPER).with_current_limit(CURRENT_LIMIT);

    #[cfg(any(test, feature = "paper-board"))]
    /// The paper's RSMC as published (λ = 100, G = 0.2, k_φ = 0.001, `sgn`, unbounded
    /// `φ̂`, raw derivative) on the machine's nominal plant, through the same force → duty
    /// stage as taut (always pulling, a negative force brakes), step set point, at 1 kHz.
    pub const PAPER_RSMC: Self = Self {
        period_us: 1_000,
        law: LawConfig::Rsmc(RsmcGains::paper(TAUT_PLANT)),
        duty_map: DutyMap::Proportional { current_limit: CURRENT_LIMIT },
        motor: MotorModel::PAPER,
        profile: ProfileConfig::STEP,
        dead_time_duty: Duty::ZERO,
    };

    #[cfg(any(test, feature = "paper-board"))]
    /// The paper's PD baseline (`k_p = 100`, `k_d = 20`) through the same force → duty
    /// stage as taut, step set point, at 1 kHz.
    pub const PD: Self = Self {
        period_us: 1_000,
        law: LawConfig::Pd(PdGains::PAPER),
        duty_map: DutyMap::Proportional { current_limit: CURRENT_LIMIT },
        motor: MotorModel::PAPER,
        profile: ProfileConfig::STEP,
        dead_time_duty: Duty::ZERO,
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
    /// The dead-time duty is above [`DEAD_TIME_DUTY_MAX`].
    DeadTimeDuty,
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

/// The tension controller. See the module docs.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct TensionController {
    law: Law,
    map: ForceToDuty,
    speed: SpeedEstimator,
    estimator: TensionEstimator,
    /// The slip damper (`None`: off).
    slip: Option<SlipDamper>,
    /// Scale the law's plant to the stiffness identified at the braking onset.
    adapt_plant: bool,
    /// The observer's gain in the braking.
    braking_gain: Option<Q16>,
    /// The observer's gain after the braking.
    hold_gain: Option<Q16>,
    /// The braking has ended and the observer keeps its braking gain until the carriage
    /// has stopped ([`HOLD_GAIN_SPEED`]).
    hold_gain_pending: bool,
    profile: Profile,
    /// The last estimate's tension (what the machine shows between pulls too).
    shown: Kgf,
    /// Constant pull switched off for this hold: the Hall count the carriage is held at
    /// (`None`: constant pull, the default).
    lock: Option<i32>,
    /// Consecutive ticks of an excess the back-out may act on ([`BACK_OUT_CONFIRM`]).
    excess_ticks: u8,
    /// Hall steps toward home seen under a pull command in this pull's settle and hold
    /// (saturating; [`BACK_DRIVE_STEPS`] identify a back-driving drivetrain).
    backward_steps: u8,
    /// REQ-TEN-22: the law's correction `u − y` is divided by `2^governor` (0 until the
    /// settle or the hold oscillates; at most [`GOVERNOR_SHIFT_MAX`]).
    governor: u8,
    /// The sign of the last excursion beyond [`SWING_BAND`] (0: none in the window).
    swing_sign: i8,
    /// Alternating excursions in the present window.
    swings: u8,
    /// Ticks since the window's first excursion.
    swing_ticks: u32,
    /// [`SWING_WINDOW_MS`] in ticks of the configured period.
    swing_window: u32,
    /// The last tick's command was a pull.
    pulled: bool,
    /// The Hall count at the pull's first tick, on the home switch (`None`: no pull yet).
    origin: Option<i32>,
}

#[cfg(any(test, feature = "paper-board"))]
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

/// Whether a filtered carriage speed counts as stopped for the hold's observer gain:
/// `|speed| ≤` [`HOLD_GAIN_SPEED`], total over every speed (the magnitude saturates: `Q16::MIN`
/// has no negation).
fn carriage_stopped(speed: MmPerSecond) -> bool {
    speed.0.saturating_abs() <= HOLD_GAIN_SPEED.0
}

impl TensionController {
    /// A controller built from `config`.
    ///
    /// # Errors
    /// [`ConfigError`] naming what is out of range.
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(config: &ControllerConfig) -> Result<Self, ConfigError> {
        let period = config.period_us;
        if period < PERIOD_RANGE_US.0 || period > PERIOD_RANGE_US.1 {
            return Err(ConfigError::Period);
        }
        if config.dead_time_duty > DEAD_TIME_DUTY_MAX {
            return Err(ConfigError::DeadTimeDuty);
        }
        let law = match config.law {
            LawConfig::Rsmc(gains) => {
                Law::Rsmc(Rsmc::new(&gains, period).map_err(ConfigError::Gain)?)
            }
            LawConfig::Pd(gains) => Law::Pd(Pd::new(&gains, period).map_err(ConfigError::Gain)?),
        };
        let map = ForceToDuty::new(&config.motor, config.duty_map).map_err(ConfigError::Motor)?;
        let p = config.profile;
        // Checked first, so a refused profile is reported before anything derived from it
        // (the profile itself is built in place below: a `Profile` temporary here would
        // cost the start-up stack its size).
        p.validate().map_err(ConfigError::Profile)?;
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
                Some(SlipDamper::new(
                    gain,
                    SLIP_DEAD_ZONE,
                    SLIP_LEARNING_RATE,
                    per_amp,
                    config.dead_time_duty,
                ))
            }
        };
        Ok(Self {
            law,
            map,
            speed,
            estimator,
            slip,
            adapt_plant: p.adapt_plant,
            braking_gain: p.observer_gain_braking,
            hold_gain: p.observer_gain_hold,
            hold_gain_pending: false,
            profile: Profile::new(&p, period).map_err(ConfigError::Profile)?,
            shown: Kgf::ZERO,
            lock: None,
            excess_ticks: 0,
            backward_steps: 0,
            governor: 0,
            swing_sign: 0,
            swings: 0,
            swing_ticks: 0,
            swing_window: SWING_WINDOW_MS.saturating_mul(1_000).checked_div(period).unwrap_or(1),
            pulled: false,
            origin: None,
        })
    }

    #[cfg(any(test, feature = "paper-board"))]
    /// taut's controller at 1 kHz on the paper's machine and board ([`ControllerConfig::TAUT`]).
    #[must_use]
    pub fn taut() -> Self {
        // TAUT is a constant whose validity a unit test checks; should it ever fail, the
        // paper's PD (also checked) is a safe, if worse, fallback — never a panic.
        Self::new(&ControllerConfig::TAUT)
            .or_else(|_| Self::new(&ControllerConfig::PD))
            .unwrap_or(Self::braking())
    }

    /// A controller whose every output is zero duty (it can only brake), reachable only if
    /// the built-in configurations were broken — a unit test checks they are not.
    #[must_use]
    pub fn braking() -> Self {
        Self {
            law: Law::Pd(Pd::ZERO),
            map: ForceToDuty::ZERO,
            speed: SpeedEstimator::ZERO,
            estimator: TensionEstimator::FALLBACK,
            slip: None,
            adapt_plant: false,
            braking_gain: None,
            hold_gain: None,
            hold_gain_pending: false,
            profile: Profile::FALLBACK,
            shown: Kgf::ZERO,
            lock: None,
            excess_ticks: 0,
            backward_steps: 0,
            governor: 0,
            swing_sign: 0,
            swings: 0,
            swing_ticks: 0,
            swing_window: SWING_WINDOW_MS,
            pulled: false,
            origin: None,
        }
    }

    /// Arms a pull of `kind` with `settings`; the next [`TensionController::step`] starts
    /// driving.
    pub fn start(&mut self, settings: &PullSettings, kind: PullKind) {
        self.speed.reset();
        self.estimator.reset();
        if let Some(slip) = &mut self.slip {
            slip.reset();
        }
        if let Law::Rsmc(rsmc) = &mut self.law {
            rsmc.set_plant_scale(Q16::ONE);
        }
        self.profile.start(settings, kind);
        self.lock = None;
        self.hold_gain_pending = false;
        self.excess_ticks = 0;
        self.backward_steps = 0;
        self.governor = 0;
        self.swing_sign = 0;
        self.swings = 0;
        self.swing_ticks = 0;
        self.pulled = false;
        self.origin = None;
    }

    /// REQ-TEN-22: how many times this pull's governor has halved the law's correction.
    #[must_use]
    pub const fn governor(&self) -> u8 {
        self.governor
    }

    /// REQ-TEN-20: whether this pull has seen the drivetrain back-drive (a Hall step toward
    /// home under a pull command in the settle or the hold, [`BACK_DRIVE_STEPS`] of them).
    #[must_use]
    pub const fn back_drives(&self) -> bool {
        self.backward_steps >= BACK_DRIVE_STEPS
    }

    /// REQ-TEN-21: the carriage rests on the home switch at Hall count `steps` — for a release
    /// that follows no pull (the boot's homing after the motor test drove it off the switch),
    /// so that release too slows onto the switch from where it knows home to be. A pull's
    /// start forgets it and takes its own.
    pub fn set_home(&mut self, steps: i32) {
        self.origin = Some(steps);
    }

    /// Starts the release (homing) move.
    pub fn release(&mut self) {
        self.profile.release();
        self.lock = None;
    }

    /// Stops at once: idle, coasting.
    pub fn stop(&mut self) {
        self.profile.stop();
        self.lock = None;
    }

    /// REQ-TEN-18: switches constant pull off for the rest of this hold — the carriage is
    /// held at Hall count `steps` (see [`LOCK_STIFFNESS`]) and the string may creep — or back
    /// on: the reference restarts from the tension now and closes on the target as after
    /// the settle, the law restarting from the present error (no kick). Refused (false,
    /// nothing changes) outside the hold.
    pub fn set_constant_pull(&mut self, on: bool, steps: i32) -> bool {
        if self.profile.phase() != PullPhase::Hold {
            return false;
        }
        if on {
            if self.lock.take().is_some() {
                self.profile.resume_from(self.shown);
            }
        } else {
            self.lock = Some(steps);
        }
        true
    }

    /// Whether constant pull is on (it is unless switched off in this hold).
    #[must_use]
    pub const fn constant_pull(&self) -> bool {
        self.lock.is_none()
    }

    /// Moves the held tension to `target` (see [`Profile::retarget`]); whether accepted.
    pub fn retarget(&mut self, target: Kgf) -> bool {
        self.profile.retarget(target)
    }

    /// The present phase.
    #[must_use]
    pub const fn phase(&self) -> PullPhase {
        self.profile.phase()
    }

    /// The profile state (for logs, proofs and fuzzing).
    #[must_use]
    pub const fn profile_state(&self) -> ProfileState {
        self.profile.state()
    }

    /// Replaces the profile state (proofs and fuzzing); the guarantees hold for states that
    /// satisfy [`TensionController::is_valid`].
    pub fn set_profile_state(&mut self, profile: ProfileState) {
        self.profile.set_state(profile);
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

    /// The invariant every reachable state satisfies: the law's, the estimator's and the
    /// profile's own invariants (targets and reference within `[0, TENSION_MAX]`, the peak
    /// at or above the final target), and a lock-out only in the hold.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let law_ok = match &self.law {
            Law::Rsmc(rsmc) => rsmc.is_valid(),
            Law::Pd(_) => true,
        };
        let lock_ok = self.lock.is_none() || self.profile.phase() == PullPhase::Hold;
        let governor_ok = self.governor <= GOVERNOR_SHIFT_MAX
            && self.swings < SWING_EXCURSIONS
            && (-1..=1).contains(&self.swing_sign);
        law_ok && self.estimator.is_valid() && self.profile.is_valid() && lock_ok && governor_ok
    }

    /// Starts the braking ([`Profile::begin_braking`]) and applies what it identified: the
    /// law's plant scaled to the string (`ρ = K̄/K̂`), the observer given the stiffness,
    /// its braking gain and the parabola's starting tension.
    fn begin_braking(&mut self, est: &Estimate) {
        let onset = self.profile.begin_braking(est);
        if self.adapt_plant {
            let nominal = self.profile.coefficients().nominal_stiffness.to_bits();
            let scale = mul_q24(nominal, Q24(reciprocal_q24(onset.stiffness.to_bits())));
            if let Law::Rsmc(rsmc) = &mut self.law {
                rsmc.set_plant_scale(Q16::from_bits(scale));
            }
        }
        self.estimator.set_stiffness(onset.stiffness);
        if let Some(alpha) = self.braking_gain {
            self.estimator.set_observer_gain(alpha);
        }
        self.estimator.set_tension(onset.start);
    }

    /// One control tick.
    pub fn step(&mut self, m: &Measurement) -> ControlOutput {
        let speed = self.speed.update(m.drive.steps);
        self.map.set_bus(m.bus);
        // While the carriage brakes, the gripper outboard of the load cell takes its inertial
        // force off the reading (REQ-ID-07): the observer is given the string's pull.
        let sample = m.tension.saturating_add(self.profile.gripper_bias());
        // In the take-up, once the carriage runs at its speed, a burst of spikes that passes
        // the median of five is bridged at the string's own rate: it would time the braking
        // and identify the stiffness. Not while the carriage accelerates: the gripper's
        // inertial step is then a real change of the reading, which identifies the gripper.
        self.estimator.set_burst_bridge(self.profile.take_up_identified());
        let est = self.estimator.update(sample, m.drive.steps);
        self.shown = est.tension;
        let holding = self.profile.phase() == PullPhase::Hold;
        let slip_brake = match &mut self.slip {
            Some(slip) => slip.update(m.current, est.steps, holding),
            None => Kgf::ZERO,
        };
        self.profile.tick();
        if self.pulled
            && est.steps < 0
            && matches!(self.profile.phase(), PullPhase::Settle | PullPhase::Hold)
        {
            let back = u8::try_from(est.steps.unsigned_abs()).unwrap_or(u8::MAX);
            self.backward_steps = self.backward_steps.saturating_add(back);
        }

        if self.origin.is_none() && self.profile.phase() == PullPhase::TakeUp {
            self.origin = Some(m.drive.steps);
        }

        let mut force = Kgf::ZERO;
        let command = match self.profile.phase() {
            PullPhase::Idle => DriveCommand::Coast,
            PullPhase::Release => {
                if m.limits.home {
                    self.profile.stop();
                    DriveCommand::Coast
                } else {
                    // Back-driven by the string: only the back-EMF of the release speed,
                    // braked onto the switch (REQ-TEN-21).
                    let speed = self.release_speed(m.drive.steps);
                    let duty = self.map.velocity_duty(speed, Kgf::ZERO, RELEASE_DUTY_MAX);
                    DriveCommand::Drive { direction: Direction::Release, duty }
                }
            }
            PullPhase::TakeUp => {
                self.profile.observe_take_up(speed, est.clipped);
                if self.profile.braking_due(&est) {
                    self.begin_braking(&est);
                    self.closed_loop(&est, speed, Kgf::ZERO, &mut force)
                } else {
                    // Run at the speed limit, accelerating no harder than the current
                    // limit allows.
                    let load = Kgf::from_bits(est.sample.to_bits().max(0));
                    let limit = self.profile.state().speed_limit;
                    let cruise = self.map.velocity_duty(limit, load, DUTY_MAX);
                    let limited = self.map.current_limited_duty(speed);
                    let duty = if limited < cruise { limited } else { cruise };
                    DriveCommand::Drive { direction: Direction::Pull, duty }
                }
            }
            PullPhase::Hold if self.lock.is_some() => {
                self.profile.transitions(PullPhase::Hold, est.tension);
                self.locked(est.tension, m.drive.steps, &mut force)
            }
            PullPhase::Approach | PullPhase::PreStretch | PullPhase::Settle | PullPhase::Hold => {
                self.closed_loop(&est, speed, slip_brake, &mut force)
            }
        };
        if let Some(slip) = &mut self.slip {
            slip.note_duty(command.duty());
        }
        self.pulled = command.direction() == Some(Direction::Pull);
        ControlOutput {
            command,
            phase: self.profile.phase(),
            at_tension: self.profile.at_tension(),
            reference: self.profile.reference(),
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
        let phase = self.profile.phase();
        let advance = self.profile.advance();
        if advance.braking_ended {
            self.hold_gain_pending = true;
        }
        if self.hold_gain_pending && carriage_stopped(speed) {
            // From here the carriage moves by single Hall steps at most, and the observer
            // (still fusing them) takes its hold gain. Not at the parabola's end: a carriage
            // that braked short of its planned deceleration still runs on, and while it
            // decelerates the cell reads low (its low-pass lags, a gripper outboard of it
            // reads its inertial force), which the hold's faster gain would fuse.
            self.hold_gain_pending = false;
            if let Some(floor) = self.hold_gain {
                let stiffness = Q16::from_bits(self.estimator.state().stiffness);
                self.estimator.set_observer_gain(hold_observer_gain(floor, stiffness));
            }
        }
        let reference = advance.reference;
        if self.profile.take_fresh() {
            // No derivative kick: the law starts from the present error.
            let e0 = reference.tension.saturating_sub(y);
            match &mut self.law {
                Law::Rsmc(rsmc) => rsmc.reset(e0),
                Law::Pd(pd) => pd.reset(e0),
            }
        }
        let law = match &mut self.law {
            Law::Rsmc(rsmc) => rsmc.step(&reference, y, self.profile.saturated()).force,
            Law::Pd(pd) => pd.step(&reference, y),
        };
        if matches!(phase, PullPhase::Settle | PullPhase::Hold) {
            self.watch_swings(reference.tension.saturating_sub(y));
        }
        let corrected = governed(law, y, self.governor).saturating_sub(slip_brake);
        let shaped = self.profile.coefficients().shaped;
        // REQ-TEN-23: the hold only pulls. Its force never drops below the string's own pull:
        // an excess comes off by the back-out (what a release of this drivetrain removes) and
        // by the string's creep, never by the law letting go.
        let floored = shaped && phase == PullPhase::Hold && corrected < y;
        let force = if floored { y } else { corrected };
        let (command, saturated) = self.map.command(force, speed);
        let command = if shaped && matches!(phase, PullPhase::Settle | PullPhase::Hold) {
            // The back-out judges the law's own force, before the floor.
            let asks_no_pull = if floored {
                self.map.command(corrected, speed).0.duty().is_zero()
            } else {
                command.duty().is_zero()
            };
            self.back_out(command, asks_no_pull, est, speed)
        } else {
            self.excess_ticks = 0;
            command
        };
        self.profile.set_saturated(saturated);
        *force_out = force;
        self.profile.transitions(phase, y);
        command
    }

    /// REQ-TEN-22, the governor's watch on the settle's and the hold's error `e`
    /// (reference − estimate): [`SWING_EXCURSIONS`] excursions beyond [`SWING_BAND`] of
    /// alternating sign within [`SWING_WINDOW_MS`] of the first halve the law's correction
    /// once more (up to [`GOVERNOR_SHIFT_MAX`] times), and the count starts again.
    fn watch_swings(&mut self, e: Kgf) {
        if self.swing_sign != 0 {
            self.swing_ticks = self.swing_ticks.saturating_add(1);
            if self.swing_ticks > self.swing_window {
                self.swing_sign = 0;
                self.swings = 0;
            }
        }
        let sign: i8 = if e > SWING_BAND {
            1
        } else if e < Kgf(SWING_BAND.0.saturating_neg()) {
            -1
        } else {
            0
        };
        if sign == 0 || sign == self.swing_sign {
            return;
        }
        if self.swing_sign == 0 {
            self.swing_ticks = 0;
        }
        self.swing_sign = sign;
        self.swings = self.swings.saturating_add(1);
        if self.swings >= SWING_EXCURSIONS {
            self.governor = self.governor.saturating_add(1).min(GOVERNOR_SHIFT_MAX);
            self.swing_sign = 0;
            self.swings = 0;
        }
    }

    /// The lock-out's command (REQ-TEN-18): the string's pull `y` plus [`LOCK_STIFFNESS`] per
    /// Hall step short of the locked count, at zero speed; a pull only, never a reversal.
    fn locked(&self, y: Kgf, steps: i32, force_out: &mut Kgf) -> DriveCommand {
        let held_at = self.lock.unwrap_or(steps);
        let short = held_at.saturating_sub(steps).clamp(-LOCK_SPAN_STEPS, LOCK_SPAN_STEPS);
        let spring = Kgf(LOCK_STIFFNESS.0.saturating_mul_int(short));
        let force = y.saturating_add(spring);
        *force_out = force;
        self.map.command(force, MmPerSecond(Q16::ZERO)).0
    }

    /// REQ-TEN-17, the back-out: `command` unless the law asks for no pull at all
    /// (`asks_no_pull`: its own force, before the hold's floor, maps to zero duty) while
    /// the tension is more than [`BACK_OUT_BAND`] above the reference — in the estimate and
    /// in the burst-proof filtered sample, for [`BACK_OUT_CONFIRM`] consecutive ticks; then a
    /// release at [`BACK_OUT_GAIN`] mm/s per kgf of excess (within [`BACK_OUT_SPEED`], duty
    /// at most [`BACK_OUT_DUTY_MAX`]). A drivetrain that does not back-drive (a self-locking
    /// screw, forward efficiency ≤ 0.5) holds a pre-stretch peak or a braking overshoot
    /// against the short-braked motor until the string creeps down — seconds, 4.8 kgf still
    /// over a 25 kgf target 1 s after a 20 % pre-stretch on the family's least efficient
    /// machine. On a drivetrain identified as back-driving (REQ-TEN-20) the release drives
    /// only while the carriage (`speed`, mm/s, positive pulling) backs off slower than the
    /// back-out's speed: the string already pulls it home, and a release on top of that
    /// takes the string's whole pull off the motor. The reversal itself is the drive's
    /// (REQ-DRV-08: energised toward home only once the rotor's back-EMF against it is below
    /// the current limit's).
    fn back_out(
        &mut self,
        command: DriveCommand,
        asks_no_pull: bool,
        est: &Estimate,
        speed: MmPerSecond,
    ) -> DriveCommand {
        let reference = self.profile.reference();
        let excess = est.tension.saturating_sub(reference);
        let evidence = est.sample.saturating_sub(reference);
        if !asks_no_pull || excess <= BACK_OUT_BAND || evidence <= BACK_OUT_BAND {
            self.excess_ticks = 0;
            return command;
        }
        self.excess_ticks = self.excess_ticks.saturating_add(1).min(BACK_OUT_CONFIRM);
        if self.excess_ticks < BACK_OUT_CONFIRM {
            return command;
        }
        let (slowest, fastest) = BACK_OUT_SPEED;
        let target =
            MmPerSecond(excess.0.saturating_mul_int(BACK_OUT_GAIN).clamp(slowest.0, fastest.0));
        let holding = self.profile.phase() == PullPhase::Hold;
        if self.back_drives() && (holding || speed.0.saturating_neg() >= target.0) {
            return command;
        }
        let duty = self.map.velocity_duty(target, Kgf::ZERO, BACK_OUT_DUTY_MAX);
        DriveCommand::Drive { direction: Direction::Release, duty }
    }

    /// REQ-TEN-21: the release's speed at Hall count `steps`: [`RELEASE_APPROACH_GAIN`] per
    /// second times the distance left to the pull's first count, within [`RELEASE_CREEP`]
    /// and the configured release speed (which alone, without a pull to know home by).
    fn release_speed(&self, steps: i32) -> MmPerSecond {
        let fastest = self.profile.coefficients().release_speed;
        let Some(origin) = self.origin else {
            return fastest;
        };
        let left = Q16::from_bits(steps.saturating_sub(origin).saturating_mul(STEP_MM_BITS));
        let speed = left.saturating_mul_int(RELEASE_APPROACH_GAIN);
        MmPerSecond(speed.min(fastest.0).max(RELEASE_CREEP.0.min(fastest.0)))
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
    use crate::fixed::Q32;
    use crate::settings::{KnotBoost, PreStretch, Speed};
    use crate::test_support::valid;

    #[test]
    fn built_in_configurations_are_valid() {
        for config in [ControllerConfig::TAUT, ControllerConfig::PAPER_RSMC, ControllerConfig::PD] {
            let controller = valid(TensionController::new(&config));
            assert!(controller.is_valid());
        }
        assert_ne!(TensionController::taut(), TensionController::braking());
        // The board-less constructor leaves the limit to the board: refused until it is set.
        let unlimited = ControllerConfig::taut(MotorModel::PAPER);
        assert_eq!(
            TensionController::new(&unlimited),
            Err(ConfigError::Motor(MotorError::Parameter))
        );
        assert_eq!(unlimited.with_current_limit(CURRENT_LIMIT), ControllerConfig::TAUT);
        let back_emf = ControllerConfig {
            duty_map: DutyMap::BackEmf { current_limit: Amps::ZERO },
            ..ControllerConfig::TAUT
        };
        assert_eq!(
            back_emf.with_current_limit(CURRENT_LIMIT).duty_map,
            DutyMap::BackEmf { current_limit: CURRENT_LIMIT }
        );
        assert!(TensionController::braking().is_valid());
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
    fn takes_the_boards_dead_time_duty_up_to_a_tenth() {
        let with = |raw| ControllerConfig {
            dead_time_duty: Duty::from_raw_clamped(raw),
            ..ControllerConfig::TAUT
        };
        assert!(TensionController::new(&with(0)).is_ok());
        assert!(TensionController::new(&with(DEAD_TIME_DUTY_MAX.raw())).is_ok());
        assert_eq!(
            TensionController::new(&with(DEAD_TIME_DUTY_MAX.raw() + 1)),
            Err(ConfigError::DeadTimeDuty)
        );
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

    /// A taut controller with a main pull to `target` kgf at full speed started.
    fn started(target: i16) -> TensionController {
        let mut controller = TensionController::taut();
        let settings = valid(PullSettings::new(
            Kgf::from_int(target),
            Speed::MAX,
            PreStretch::NONE,
            KnotBoost::NONE,
        ));
        controller.start(&settings, PullKind::Main);
        controller
    }

    /// A taut controller settled in `phase` at a 25 kgf reference, the law primed by `ticks`
    /// steps at `tension`; the last output.
    fn held_at(phase: PullPhase, tension: Kgf, ticks: u16) -> ControlOutput {
        let mut controller = started(25);
        let mut profile = controller.profile_state();
        profile.phase = phase;
        profile.reference = Q32::from_q16(Kgf::from_int(25).0);
        profile.goal = Kgf::from_int(25);
        controller.set_profile_state(profile);
        let m = Measurement { tension, ..Measurement::default() };
        let mut out = controller.step(&m);
        for _ in 1..ticks {
            out = controller.step(&m);
        }
        out
    }

    /// A taut controller in the hold at a 25 kgf reference.
    fn holding() -> TensionController {
        let mut controller = started(25);
        let mut profile = controller.profile_state();
        profile.phase = PullPhase::Hold;
        profile.reference = Q32::from_q16(Kgf::from_int(25).0);
        profile.goal = Kgf::from_int(25);
        controller.set_profile_state(profile);
        controller
    }

    /// A taut controller in the settle, its reference at 25 kgf closing on a final 20 (a
    /// pre-stretch's peak coming down).
    fn settling() -> TensionController {
        let mut controller = holding();
        let mut profile = controller.profile_state();
        profile.phase = PullPhase::Settle;
        profile.peak = Kgf::from_int(25);
        profile.final_target = Kgf::from_int(20);
        controller.set_profile_state(profile);
        controller
    }

    /// A new 25 kgf pull on `controller`.
    fn restart(controller: &mut TensionController) {
        let settings =
            PullSettings::new(Kgf::from_int(25), Speed::MAX, PreStretch::NONE, KnotBoost::NONE);
        controller.start(&valid(settings), PullKind::Main);
    }

    /// One tick of `controller` at `tension` kgf (tenths) and Hall count `steps`.
    fn tick_at(controller: &mut TensionController, tenths: i32, steps: i32) -> ControlOutput {
        controller.step(&Measurement {
            tension: Kgf::from_tenths(tenths),
            drive: DriveStatus { steps, ..DriveStatus::default() },
            ..Measurement::default()
        })
    }

    /// REQ-TEN-17: an excess is backed out only once it has lasted [`BACK_OUT_CONFIRM`]
    /// ticks in a row — longer than any burst of spikes — and the count restarts when it
    /// stops.
    #[test]
    fn a_back_out_waits_for_an_excess_that_outlasts_any_burst() {
        let mut controller = holding();
        let mut first_release = None;
        for tick in 0..80_u32 {
            // Four ticks over, then seventeen at the reference (the filtered sample, a median
            // of five here with the stiffness unknown, clipped to 0.1 kgf a tick, is back
            // within the band by the 10th, before the count reaches 12), then over again
            // from the 21st: the count restarts there.
            let tenths = if (4..21).contains(&tick) { 250 } else { 255 };
            let out = tick_at(&mut controller, tenths, 0);
            if out.command.direction() == Some(Direction::Release) && first_release.is_none() {
                first_release = Some(tick);
            }
        }
        let first = first_release.unwrap();
        assert!(first >= 21 + u32::from(BACK_OUT_CONFIRM) - 1, "released at tick {first}");
        assert!(!controller.back_drives());
    }

    /// REQ-TEN-17: while the law still asks for some pull, no excess is backed out, however
    /// long it lasts; with the law asking for none, it is once confirmed.
    #[test]
    fn a_back_out_never_overrides_a_pull_the_law_asks_for() {
        let mut controller = holding();
        let over = Estimate {
            tension: Kgf::from_int(26),
            sample: Kgf::from_int(26),
            ..Estimate::default()
        };
        let still = MmPerSecond(Q16::ZERO);
        let pull =
            DriveCommand::Drive { direction: Direction::Pull, duty: Duty::from_raw_clamped(1_000) };
        for _ in 0..3 * u32::from(BACK_OUT_CONFIRM) {
            assert_eq!(controller.back_out(pull, false, &over, still), pull);
        }
        // The law asking for none, the command the hold's floor made of it still a pull
        // (REQ-TEN-23): released once confirmed.
        let mut released = false;
        for _ in 0..BACK_OUT_CONFIRM {
            released |= controller.back_out(pull, true, &over, still).direction()
                == Some(Direction::Release);
        }
        assert!(released);
    }

    /// REQ-TEN-23: in the hold the force never drops below the string's pull however far the
    /// tension is over the reference, and a drivetrain that back-drives is never released
    /// there; in the settle (a pre-stretch's peak coming down) the law still lets go.
    #[test]
    fn the_hold_only_pulls_and_never_lets_go_of_the_string() {
        let over = Kgf::from_tenths(265);
        for ticks in [1, 5, 50, 300] {
            let out = held_at(PullPhase::Hold, over, ticks);
            assert!(out.force >= out.tension, "{ticks}: {:?} < {:?}", out.force, out.tension);
        }
        let mut settle = settling();
        let lets_go = (0..50).any(|_| {
            let out = tick_at(&mut settle, 265, 0);
            out.phase == PullPhase::Settle && out.force < out.tension
        });
        assert!(lets_go, "the settle's law was floored");
        // Back-driving, identified: 1.5 kgf over for a second, stopped or running home, the
        // drive only ever pulls.
        let mut controller = holding();
        tick_at(&mut controller, 250, 0);
        tick_at(&mut controller, 250, -1);
        tick_at(&mut controller, 250, -2);
        assert!(controller.back_drives());
        for tick in 0..1_000 {
            let steps = if tick < 500 { -2 } else { -2 - (tick - 500) / 20 };
            let out = tick_at(&mut controller, 265, steps);
            assert_eq!(out.command.direction(), Some(Direction::Pull), "{tick}");
            assert!(out.force >= out.tension, "{tick}");
        }
    }

    /// REQ-TEN-20: a Hall step toward home while pulling, in the settle or the hold,
    /// identifies a back-driving drivetrain ([`BACK_DRIVE_STEPS`] of them); its back-out then
    /// releases, in the settle, only while the carriage backs off slower than the back-out's
    /// speed, and in the hold never (REQ-TEN-23). Steps
    /// toward home under a release, or before the settle, identify nothing; a new pull
    /// forgets it.
    #[test]
    fn a_drivetrain_that_back_drives_is_identified_and_not_released_while_it_runs_home() {
        // Under a pull in the hold: one step is not enough, two are.
        let mut controller = holding();
        tick_at(&mut controller, 250, 0);
        tick_at(&mut controller, 250, -1);
        assert!(!controller.back_drives());
        tick_at(&mut controller, 250, -2);
        assert!(controller.back_drives());
        // In the hold it is never released (REQ-TEN-23, the test below). In the settle: the
        // excess, with the carriage running home at one step a tick (53 mm/s, faster than
        // the 5 mm/s the 0.5 kgf asks): the law's braking pull stands.
        let mut controller = settling();
        tick_at(&mut controller, 255, 0);
        tick_at(&mut controller, 255, -1);
        tick_at(&mut controller, 255, -2);
        assert!(controller.back_drives());
        let mut steps = -2;
        for _ in 0..40 {
            steps -= 1;
            let out = tick_at(&mut controller, 255, steps);
            assert_ne!(out.command.direction(), Some(Direction::Release), "{steps}");
        }
        // Stopped, the excess still there: released.
        let mut released = false;
        for _ in 0..100 {
            released |= tick_at(&mut controller, 255, steps).command.direction()
                == Some(Direction::Release);
        }
        assert!(released);
        // A holding drivetrain releases with the carriage running home too.
        let mut holder = holding();
        let mut steps = 0;
        let mut released = false;
        for _ in 0..60 {
            let out = tick_at(&mut holder, 255, steps);
            if out.command.direction() == Some(Direction::Release) {
                released = true;
                steps -= 1;
            }
        }
        assert!(released && !holder.back_drives());
        // Before the settle (the take-up), steps toward home identify nothing; a new pull
        // forgets what the last one saw.
        let mut pulling = started(25);
        for tick in 0..10 {
            tick_at(&mut pulling, 0, -tick);
        }
        assert!(!pulling.back_drives());
        restart(&mut controller);
        assert!(!controller.back_drives());
    }

    /// REQ-TEN-22: the governed force keeps the string's pull and divides the law's
    /// correction over it by `2^shift` (rounded toward −∞), saturating, for every shift the
    /// governor can hold and beyond.
    #[test]
    fn the_governor_divides_only_the_correction() {
        let values = [i32::MIN, -3_276_800, -65_537, -1, 0, 1, 65_536, 1_638_400, i32::MAX];
        for law in values {
            for y in values {
                let (law_q, y_q) = (Kgf(Q16::from_bits(law)), Kgf(Q16::from_bits(y)));
                if law.checked_sub(y).is_some() {
                    assert_eq!(governed(law_q, y_q, 0), law_q, "ungoverned: the law's {law} {y}");
                }
                for shift in 0..=8_u8 {
                    let correction = law.saturating_sub(y) >> shift;
                    let want = y.saturating_add(correction);
                    assert_eq!(governed(law_q, y_q, shift).0.to_bits(), want, "{law} {y} {shift}");
                }
                assert_eq!(governed(y_q, y_q, 3), y_q, "no correction, the pull alone");
            }
        }
    }

    /// REQ-TEN-22: four excursions beyond ±0.1 kgf of alternating sign within 300 ms in the
    /// hold halve the law's correction, up to three times; an error that wanders one way,
    /// alternates slower than the window or keeps within the band never does; a new pull
    /// starts at the full correction.
    #[test]
    fn an_oscillating_hold_lowers_the_laws_correction() {
        // A 60 ms limit cycle of ±0.3 kgf: four excursions (three reversals) within 90 ms.
        let mut controller = holding();
        let mut halvings = [None; 3];
        for tick in 0..1_000_u32 {
            let tenths = if (tick / 30).is_multiple_of(2) { 253 } else { 247 };
            tick_at(&mut controller, tenths, 0);
            let governor = usize::from(controller.governor());
            if let Some(slot) = governor.checked_sub(1).and_then(|i| halvings.get_mut(i)) {
                slot.get_or_insert(tick);
            }
        }
        assert_eq!(controller.governor(), GOVERNOR_SHIFT_MAX, "at most three halvings");
        let first = halvings[0].expect("halved");
        assert!((90..=130).contains(&first), "first halving at tick {first}");
        assert!(controller.is_valid());
        // The same controller state with and without the governor: the correction over the
        // estimate is an eighth (the slip damper's brake is the same in both).
        // In the settle, where the law's correction is not floored at the string's pull.
        let mut profile = controller.profile_state();
        profile.phase = PullPhase::Settle;
        profile.final_target = Kgf::from_int(20);
        controller.set_profile_state(profile);
        let mut full = controller;
        full.governor = 0;
        let m = |c: &mut TensionController| tick_at(c, 240, 0);
        let (lowered, whole) = (m(&mut controller), m(&mut full));
        let over = |out: &ControlOutput| out.force.0.saturating_sub(out.tension.0).to_num::<f64>();
        assert!(over(&whole).abs() > 0.5, "{whole:?}");
        assert!(
            (over(&lowered) - over(&whole) / 8.0).abs() < 0.001 + over(&whole).abs() * 0.01,
            "{lowered:?} {whole:?}"
        );

        // Within the band, wandering one way, or alternating every 400 ms: never.
        for pattern in [
            |tick: u32| if (tick / 30).is_multiple_of(2) { 251 } else { 249 },
            |tick: u32| 250 - i32::try_from(tick / 100).unwrap_or(0),
            |tick: u32| if (tick / 400).is_multiple_of(2) { 253 } else { 247 },
        ] {
            let mut calm = holding();
            for tick in 0..2_000_u32 {
                tick_at(&mut calm, pattern(tick), 0);
            }
            assert_eq!(calm.governor(), 0);
        }
        // A new pull: the full correction.
        restart(&mut controller);
        assert_eq!(controller.governor(), 0);
    }

    /// REQ-TEN-22, the watch alone: the window runs from the run's first excursion and its
    /// last tick still counts; an error exactly at the band is no excursion; an error that
    /// leaves the band one way only is one excursion however often; and the governor's state
    /// is part of the controller's invariant.
    #[test]
    fn the_watch_counts_alternating_excursions_from_the_first() {
        let window = SWING_WINDOW_MS; // ticks at 1 kHz
        let governed_after = |excursions: &[(u32, Kgf)]| {
            let mut controller = holding();
            let last = excursions.iter().map(|&(tick, _)| tick).max().unwrap_or(0);
            for tick in 0..=last {
                let e =
                    excursions.iter().find(|&&(at, _)| at == tick).map_or(Kgf::ZERO, |&(_, e)| e);
                controller.watch_swings(e);
            }
            controller.governor()
        };
        let (over, under) = (Kgf::from_tenths(2), Kgf::from_tenths(-2));
        let third = window / 3;
        let run = |spacing: u32, last: u32| {
            [(0, over), (spacing, under), (2 * spacing, over), (last, under)]
        };
        assert_eq!(governed_after(&run(third, window)), 1, "the window's last tick counts");
        assert_eq!(governed_after(&run(third, window + 1)), 0, "a tick later: a new window");
        // Each within the window of the one before, not of the first: no.
        let spread = window / 2;
        assert_eq!(governed_after(&run(spread, 3 * spread)), 0);
        // At the band exactly, either way: no excursion.
        let at = |i: usize| u32::try_from(i).unwrap_or(0) * 10;
        let (edge_over, edge_under) = (SWING_BAND, Kgf(-SWING_BAND.0));
        for (first, second) in [(edge_over, under), (over, edge_under), (edge_over, edge_under)] {
            let band: [(u32, Kgf); 12] =
                core::array::from_fn(|i| (at(i), if i % 2 == 0 { first } else { second }));
            assert_eq!(governed_after(&band), 0, "{first:?} {second:?}");
        }
        // Out one way and back within the band, again and again: one excursion.
        let one_way: [(u32, Kgf); 12] = core::array::from_fn(|i| {
            (at(i), if i % 2 == 0 { over } else { Kgf(Q16::lit("0.05")) })
        });
        assert_eq!(governed_after(&one_way), 0);
        let mut controller = holding();
        assert!(controller.is_valid());
        controller.governor = GOVERNOR_SHIFT_MAX + 1;
        assert!(!controller.is_valid(), "governed past its most");
        controller.governor = GOVERNOR_SHIFT_MAX;
        controller.swings = SWING_EXCURSIONS;
        assert!(!controller.is_valid(), "a count that should have governed");
        controller.swings = SWING_EXCURSIONS - 1;
        controller.swing_sign = 2;
        assert!(!controller.is_valid(), "a sign that is none");
        controller.swing_sign = -1;
        assert!(controller.is_valid());
    }

    /// REQ-TEN-21: the release's speed is 8 mm/s per millimetre left to the pull's first
    /// Hall count, within the creep speed and the release speed; without a pull, the
    /// release speed.
    #[test]
    fn the_release_brakes_onto_the_switch_from_any_speed() {
        let fastest = ProfileConfig::TAUT.release_speed;
        let mut controller = started(25);
        assert_eq!(controller.release_speed(500), fastest, "no pull yet");
        tick_at(&mut controller, 0, 100);
        let at = |controller: &TensionController, steps: i32| {
            controller.release_speed(steps).0.to_num::<i32>()
        };
        assert_eq!(at(&controller, 2_000), fastest.0.to_num::<i32>());
        // 80 steps (4.23 mm) left: 33.9 mm/s; 40 steps: 16.9; 10 steps and at or past the
        // count: the creep speed.
        assert_eq!(at(&controller, 180), 33);
        assert_eq!(at(&controller, 140), 16);
        for steps in [110, 100, 50, -1_000] {
            assert_eq!(controller.release_speed(steps), RELEASE_CREEP, "{steps}");
        }
        // The command follows it: less duty near home than far from it.
        controller.release();
        let far = tick_at(&mut controller, 0, 2_000).command;
        let near = tick_at(&mut controller, 0, 110).command;
        assert_eq!(far.direction(), Some(Direction::Release));
        assert_eq!(near.direction(), Some(Direction::Release));
        assert!(near.duty() < far.duty(), "{near:?} {far:?}");
        // A new pull takes its own origin.
        restart(&mut controller);
        assert_eq!(controller.release_speed(180), fastest);
        tick_at(&mut controller, 0, 170);
        assert_eq!(at(&controller, 180), RELEASE_CREEP.0.to_num::<i32>());
    }

    /// REQ-TEN-18: constant pull goes off only in the hold; locked, the force is the string's
    /// pull plus 0.1 kgf per step short of the locked count (±50 steps at most), always a
    /// pull — even with the tension far over the reference, where the back-out would
    /// release; on again, the law restarts from the present tension; a release, a stop and
    /// a new pull each clear the lock.
    #[test]
    fn the_lock_out_holds_the_carriage_and_only_pulls() {
        for phase in PullPhase::ALL {
            let mut controller = TensionController::taut();
            let mut state = controller.profile_state();
            state.phase = phase;
            controller.set_profile_state(state);
            let accepted = controller.set_constant_pull(false, 100);
            assert_eq!(accepted, phase == PullPhase::Hold, "{phase:?}");
            assert_eq!(controller.constant_pull(), phase != PullPhase::Hold);
            assert!(controller.is_valid());
        }
        let mut controller = TensionController::taut();
        let mut state = controller.profile_state();
        state.phase = PullPhase::Hold;
        state.final_target = Kgf::from_int(25);
        state.peak = Kgf::from_int(25);
        controller.set_profile_state(state);
        assert!(controller.set_constant_pull(false, 1_000));
        let y = Kgf::from_int(25);
        let force_at = |steps: i32| {
            let mut force = Kgf::ZERO;
            let command = controller.locked(y, steps, &mut force);
            assert_eq!(command.direction(), Some(Direction::Pull), "{steps}");
            force
        };
        assert_eq!(force_at(1_000), y);
        assert_eq!(force_at(990), y.saturating_add(Kgf(LOCK_STIFFNESS.0 * 10)));
        assert_eq!(force_at(1_010), y.saturating_sub(Kgf(LOCK_STIFFNESS.0 * 10)));
        assert_eq!(force_at(0), y.saturating_add(Kgf(LOCK_STIFFNESS.0 * 50)), "span");
        assert_eq!(force_at(i32::MAX), y.saturating_sub(Kgf(LOCK_STIFFNESS.0 * 50)), "span");
        // Locked, 5 kgf over the reference: still a pull (unlocked, the back-out releases).
        let over = Measurement { tension: Kgf::from_int(30), ..Measurement::default() };
        for _ in 0..50 {
            let out = controller.step(&over);
            assert_eq!(out.command.direction(), Some(Direction::Pull));
            assert_eq!(out.phase, PullPhase::Hold);
        }
        // Back on: the reference restarts from the tension now, the law from its error.
        assert!(controller.set_constant_pull(true, 0));
        assert!(controller.constant_pull());
        let resumed = controller.profile_state();
        assert_eq!(resumed.reference, Q32::from_q16(controller.tension().0));
        assert!(resumed.fresh);
        assert!(controller.tension() > Kgf::from_int(26), "{:?}", controller.tension());
        // A release, a stop or a new pull clears the lock.
        for clear in 0..3 {
            controller.set_profile_state(state);
            assert!(controller.set_constant_pull(false, 0));
            match clear {
                0 => controller.release(),
                1 => controller.stop(),
                _ => controller.start(&PullSettings::default(), PullKind::Main),
            }
            assert!(controller.constant_pull(), "{clear}");
            assert!(controller.is_valid());
        }
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
        // Never during the braking approach or the pre-stretch peak, however long the excess
        // lasts there (each tick judged by the phase it began in).
        for phase in [PullPhase::Approach, PullPhase::PreStretch] {
            let mut controller = holding();
            let mut profile = controller.profile_state();
            profile.phase = phase;
            controller.set_profile_state(profile);
            let mut began = phase;
            for tick in 0..100 {
                let out = tick_at(&mut controller, 300, 0);
                if matches!(began, PullPhase::Approach | PullPhase::PreStretch) {
                    assert_ne!(
                        out.command.direction(),
                        Some(Direction::Release),
                        "{phase:?} {tick}"
                    );
                }
                began = out.phase;
            }
        }
        // Never with the step profile (the paper's controllers), in any phase.
        for config in [ControllerConfig::PAPER_RSMC, ControllerConfig::PD] {
            let mut controller = TensionController::new(&config).unwrap_or_default();
            let settings =
                PullSettings::new(Kgf::from_int(25), Speed::MAX, PreStretch::NONE, KnotBoost::NONE);
            controller.start(&valid(settings), PullKind::Main);
            for tick in 0..300 {
                let out = tick_at(&mut controller, if tick < 100 { 250 } else { 300 }, 0);
                assert_ne!(out.command.direction(), Some(Direction::Release), "{tick}");
            }
        }
    }

    /// A carriage pulled at one Hall step per tick into a `stiffness_milli` kgf/mm string
    /// whose slack ends at `slack_steps` (an ideal plant: the controller only decides when).
    fn braking_onset(stiffness_milli: i64, target: i32) -> (i32, Kgf) {
        let mut controller = started(valid(i16::try_from(target)));
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

    /// The observer keeps its braking gain after the braking parabola ends while the
    /// carriage still runs on, and takes its hold gain once the carriage has stopped.
    /// The stopped-carriage test is total and symmetric: 5 mm/s either way is stopped, one
    /// bit faster is not, and the extremes (whose magnitude does not fit) are moving.
    #[test]
    fn a_carriage_is_stopped_within_five_millimetres_per_second_either_way() {
        let at = |bits: i32| carriage_stopped(MmPerSecond(Q16::from_bits(bits)));
        let limit = HOLD_GAIN_SPEED.0.to_bits();
        assert!(at(0) && at(limit) && at(-limit));
        assert!(!at(limit + 1) && !at(-limit - 1));
        assert!(!at(i32::MIN) && !at(i32::MAX));
    }

    #[test]
    fn the_hold_gain_waits_for_the_carriage_to_stop() {
        let mut controller = started(25);
        let measure = |steps: i32| {
            // A 1 kgf/mm string whose slack ends at step 100.
            let stretch_nm = i64::from((steps - 100).max(0)) * 52_917;
            let tension_bits = stretch_nm * 65_536 / 1_000_000;
            Measurement {
                tension: Kgf::from_bits(valid(i32::try_from(tension_bits))),
                drive: DriveStatus { steps, ..DriveStatus::default() },
                ..Measurement::default()
            }
        };
        // The carriage runs at one Hall step per tick whatever the controller asks, through
        // the braking and past its end.
        let mut steps = 0;
        let mut braked = false;
        while steps < 4_000 {
            let phase = controller.step(&measure(steps)).phase;
            braked |= phase == PullPhase::Approach;
            if braked && phase != PullPhase::Approach {
                break;
            }
            assert!(!controller.hold_gain_pending, "pending before the braking ended");
            steps += 1;
        }
        assert!(braked && steps < 4_000, "the braking never ended");
        let braking = controller.braking_gain;
        let hold = controller.hold_gain;
        assert!(braking.is_some() && hold.is_some() && braking != hold);
        for _ in 0..20 {
            steps += 1;
            let _ = controller.step(&measure(steps));
            assert!(controller.hold_gain_pending, "the hold gain came while the carriage ran");
            assert_eq!(controller.estimator.observer_gain(), braking);
        }
        // Stopped: the filtered speed falls below 5 mm/s within a few of its 4 ms.
        let mut ticks = 0;
        while controller.hold_gain_pending && ticks < 100 {
            let _ = controller.step(&measure(steps));
            ticks += 1;
        }
        assert!((5..=30).contains(&ticks), "hold gain after {ticks} ticks at rest");
        // REQ-TEN-19: on this 1 kgf/mm string the hold's gain is the stiffness's, ≈ 0.15.
        let stiffness = Q16::from_bits(controller.estimator.state().stiffness);
        let expected = hold.map(|floor| hold_observer_gain(floor, stiffness));
        assert_eq!(controller.estimator.observer_gain(), expected);
        let gain = expected.map_or(0, |g| g.to_bits());
        assert!((8_500..=11_200).contains(&gain), "hold gain {gain} for {stiffness:?} kgf/mm");
    }

    /// REQ-TEN-19: the hold's observer gain is the stiffness × 0.15 within the configured
    /// floor and 0.2, for every stiffness the estimator holds (0–4 kgf/mm, in 1/256 steps).
    #[test]
    fn the_hold_gain_grows_with_the_strings_stiffness_within_its_bounds() {
        let floor = Q16::lit("0.05");
        let mut last = Q16::ZERO;
        for k in 0..=1_024_i32 {
            let stiffness = Q16::from_bits(k << 8);
            let gain = hold_observer_gain(floor, stiffness);
            let exact = (i64::from(k << 8) * i64::from(HOLD_GAIN_PER_STIFFNESS.to_bits())) >> 16;
            let want = exact.clamp(i64::from(floor.to_bits()), i64::from(HOLD_GAIN_MAX.to_bits()));
            assert!((i64::from(gain.to_bits()) - want).abs() <= 1, "{stiffness:?}: {gain:?}");
            assert!(gain >= last, "not monotonic at {stiffness:?}");
            last = gain;
        }
        // A soft string keeps the floor, a stiff one stops at the ceiling.
        assert_eq!(hold_observer_gain(floor, Q16::lit("0.2")), floor);
        assert_eq!(hold_observer_gain(floor, Q16::lit("0.5")), Q16::lit("0.075"));
        assert_eq!(hold_observer_gain(floor, Q16::const_from_int(2)), HOLD_GAIN_MAX);
        // A floor configured above the ceiling wins.
        assert_eq!(hold_observer_gain(Q16::lit("0.5"), Q16::const_from_int(4)), Q16::lit("0.5"));
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

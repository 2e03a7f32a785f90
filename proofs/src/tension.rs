//! Tension-controller properties (`REQ-TEN-01` … `05`): every part of the step is bounded
//! and keeps its invariant; the composed step too; the fixed-point law tracks its `f64`
//! reference within the stated bound.
//!
//! # Parts, each with one body and three drivers
//!
//! The controller's tick is a composition — [`TensionEstimator::update`] (spike filter,
//! observer, rate and speed), the profile (braking onset, reference), the law
//! ([`Rsmc::step`]), the force → duty stage ([`ForceToDuty::command`]) — and each part is a
//! total function of its inputs given its own invariant. So each is proven on its own, for
//! every input and every state satisfying the invariant:
//!
//! | body | Kani harness | what it checks |
//! |---|---|---|
//! | [`rsmc_step_bounded`] | `verify_rsmc_step_bounded` | the law: no panic or overflow, `φ̂ ∈ [0, φ_max]`, `\|z\| ≤ z_max`, plant scale kept |
//! | [`force_to_duty_bounded`] | `verify_force_to_duty_bounded` | always `Pull`, duty ≤ `DUTY_MAX` and within the current-limit window |
//! | [`estimator_step_bounded`] | `verify_estimator_step_bounded` | no panic, stiffness kept, the spike clip's per-tick limit |
//! | [`slip_damper_bounded`] | `verify_slip_damper_bounded` | no panic, a braking force ≥ 0 only for a forward residual, learning within bounds |
//! | [`hold_observer_gain_bounded`] | `verify_hold_observer_gain_bounded` | the hold's observer gain within the configured floor and `HOLD_GAIN_MAX` (its monotony in the stiffness, [`hold_observer_gain_monotonic`], is sampled under `cargo test` only) |
//! | [`reciprocal_total`] | `verify_reciprocal_total` | no panic for any `x`, zero for `x ≤ 0` (accuracy: [`reciprocal_accurate`], swept under `cargo test`) |
//! | [`controller_step_bounded`] | `verify_controller_step_bounded`, `verify_take_up_step_bounded`, `verify_braking_onset_step_bounded`, `verify_lock_out_step_bounded` | the composition: duty ≤ `DUTY_MAX`, `is_valid()` kept, every phase (the take-up's two branches in the second and third, the constant-pull lock-out in the fourth) |
//!
//! # Why the harnesses are small enough for CBMC
//!
//! CBMC's cost is the bit-blasted arithmetic. The law's step is fourteen products of two
//! 32-bit operands into a 64-bit result (`mul_wide`) and saturating 64-bit adds and shifts —
//! no division (the period's `1/dt` and every coefficient are computed at construction from
//! constant gains, which CBMC's simplifier folds), no `i128`, no loop. The force → duty
//! stage is four such products, the estimator seven (and a four-step loop), the slip
//! damper three, the reciprocal six plus a shift by a
//! leading-zero count and a three-iteration loop (`unwind(4)`). Each part's state is its own
//! core type — `RsmcState`, `EstimatorState`, `SlipState`, `ProfileState`, which derive
//! `kani::Arbitrary` (and `arbitrary::Arbitrary` for the fuzzer) in core — drawn whole, set
//! through the real setters and constrained only by `kani::assume(is_valid())`: an
//! over-approximation of the reachable states. The cases below bundle those states with the
//! step's inputs; they no longer mirror any state field by field. The
//! composed harnesses add the profile's dozen products to the sum of the parts; they are the
//! ones to run with `--harness` on their own.
//!
//! The same bodies run under `cargo test` (`proofs/tests/tension.rs`: proptest over the
//! valid domain, printing the cases checked) and under the `rsmc_step` fuzz target.

use taut_core::drive::{DUTY_MAX, Direction, DriveStatus};
use taut_core::fixed::{Q32, mul_wide, narrow, reciprocal_q24};
use taut_core::io::LimitSwitches;
use taut_core::mechanism::STEP_MM_BITS;
use taut_core::settings::MmPerSecond;
use taut_core::settings::{TENSION_MAX, TENSION_MIN};
use taut_core::tension::controller::{
    BACK_OUT_DUTY_MAX, HOLD_GAIN_MAX, TAUT_GAINS, TAUT_PLANT, TensionController, hold_observer_gain,
};
use taut_core::tension::estimator::{
    CLIP_ALLOWANCE, CLIP_STIFFNESS, EstimatorConfig, EstimatorState, TensionEstimator,
};
use taut_core::tension::law::{Reference, Rsmc, RsmcGains, RsmcState, Saturation};
use taut_core::tension::motor::{DutyMap, ForceToDuty, MotorModel};
use taut_core::tension::profile::{Profile, ProfileConfig, ProfileState};
use taut_core::tension::slip::{
    LEARN_TICKS, SLIP_DEAD_ZONE, SLIP_LEARNING_RATE, SlipDamper, SlipState,
};
use taut_core::tension::{ControllerConfig, Measurement, PullPhase};
use taut_core::units::{Amps, Kgf, KgfPerSecond, Q16, Seconds, Volts};

/// The paper's gains on taut's plant (a constant, for the same reason as below).
const PAPER_GAINS: RsmcGains = RsmcGains::paper(TAUT_PLANT);

/// The observer gain the estimator cases use (a constant: `Q16::lit` at run time would put
/// the `fixed` crate's string parser in every harness).
const OBSERVER_GAIN: Q16 = Q16::lit("0.05");

/// The slip damper's starting stall relation in the harness, duty per ampere (R/V of the
/// paper's motor, 0.846 Ω / 24 V).
const SLIP_INITIAL_DUTY_PER_AMP: Q16 = Q16::lit("0.035");

/// The law step's state and inputs: the law's own state type, drawn whole, and the reference
/// and measurement as bits.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct LawCase {
    /// The paper's gains (on taut's nominal plant) instead of taut's.
    pub paper: bool,
    /// The law's memory.
    pub state: RsmcState,
    /// The plant scale `ρ`, Q15.16 bits (clamped by the setter).
    pub scale: i32,
    /// Reference tension, kgf bits.
    pub y_d: i32,
    /// Reference rate, kgf/s bits.
    pub rate: i32,
    /// Reference acceleration, kgf/s² bits.
    pub accel: i32,
    /// Measured tension, kgf bits.
    pub y: i32,
    /// Which way the previous output saturated.
    pub saturated: Saturation,
}

/// The law at 1 kHz in the case's state (its invariant not yet checked).
#[must_use]
pub fn law_in(case: &LawCase) -> Rsmc {
    let gains = if case.paper { PAPER_GAINS } else { TAUT_GAINS };
    let Ok(mut law) = Rsmc::new(&gains, 1_000) else {
        panic!("REQ-TEN-06: a built-in law was rejected");
    };
    law.set_state(case.state);
    law.set_plant_scale(Q16::from_bits(case.scale));
    law
}

/// REQ-TEN-01/03 for the law: from a valid state, one step never panics or overflows, keeps
/// `φ̂ ∈ [0, φ_max]` and `|z| ≤ z_max`, and leaves the plant scale alone. Returns whether the
/// case was in the domain.
pub fn rsmc_step_bounded(case: &LawCase) -> bool {
    let mut law = law_in(case);
    if !law.is_valid() {
        return false;
    }
    let scale = law.plant_scale();
    let reference = Reference {
        tension: Kgf::from_bits(case.y_d),
        rate: KgfPerSecond::from_bits(case.rate),
        accel: Q16::from_bits(case.accel),
    };
    let _ = law.step(&reference, Kgf::from_bits(case.y), case.saturated);
    assert!(law.is_valid(), "REQ-TEN-03: the law step broke its invariant: {case:?}");
    assert_eq!(law.plant_scale(), scale, "REQ-TEN-03: the law step changed the plant scale");
    true
}

/// The paper's motor with an 8 A limit, as either map.
fn duty_stage(current_map: bool) -> ForceToDuty {
    let limit = Amps::from_int(8);
    let map = if current_map {
        DutyMap::BackEmf { current_limit: limit }
    } else {
        DutyMap::Proportional { current_limit: limit }
    };
    let Ok(stage) = ForceToDuty::new(&MotorModel::PAPER, map) else {
        panic!("REQ-TEN-06: the paper's motor model was rejected");
    };
    stage
}

/// REQ-TEN-02/09: whatever the force and the speed, both maps command `Pull` (a negative
/// force brakes) with a duty within `DUTY_MAX` and within the current-limit window around
/// the measured back-EMF (or, when the window lies wholly outside `[0, DUTY_MAX]`, its
/// nearest end). The window is the stage's own ([`ForceToDuty::current_window`], whose
/// formula is a unit test in `core`) on the measured bus `bus` (Q15.16 volts, any value).
pub fn force_to_duty_bounded(current_map: bool, force: i32, speed: i32, bus: i32) {
    let mut stage = duty_stage(current_map);
    stage.set_bus(Volts::from_bits(bus));
    let scale = stage.bus_scale();
    assert!(
        scale >= Q16::lit("0.5") && scale <= Q16::const_from_int(2),
        "REQ-TEN-16: bus scale {scale} outside [½, 2]"
    );
    let window = stage.current_window(MmPerSecond(Q16::from_bits(speed)));
    force_to_duty_within(current_map, force, speed, bus, window);
}

/// REQ-TEN-02/09 for a given current-limit `(low, high)` window (duty, Q15.16 bits, `low ≥
/// 0`, `high ≤ DUTY_MAX` as every window is): the command is `Pull`, its duty within
/// `DUTY_MAX` and inside the window, or at its nearest end when the window is empty.
pub fn force_to_duty_within(
    current_map: bool,
    force: i32,
    speed: i32,
    bus: i32,
    window: (i64, i64),
) {
    let mut stage = duty_stage(current_map);
    stage.set_bus(Volts::from_bits(bus));
    let (command, _) =
        stage.command_within(Kgf::from_bits(force), MmPerSecond(Q16::from_bits(speed)), window);
    assert_eq!(command.direction(), Some(Direction::Pull), "REQ-TEN-09: a pull never reverses");
    let duty = command.duty();
    assert!(duty <= DUTY_MAX && duty.is_valid(), "REQ-TEN-02: duty {duty:?} above DUTY_MAX");
    let (low, high) = window;
    let bits = i64::from(duty.raw());
    if low <= high {
        assert!(bits >= low && bits <= high, "REQ-TEN-09: duty {bits} outside [{low}, {high}]");
    } else {
        // No duty keeps the current within the limit (a speed beyond the motor's reach in
        // either direction): the one closest to the window — zero when back-driven, full
        // duty (the least braking) when over-running.
        assert_eq!(bits, high.max(0), "REQ-TEN-09: outside the window, the nearest duty");
    }
}

/// The estimator step's configuration switches, state (the estimator's own type, drawn whole)
/// and inputs.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct EstimatorCase {
    /// Spike clip on.
    pub clip: bool,
    /// Observer on.
    pub observer: bool,
    /// The estimator's memory.
    pub state: EstimatorState,
    /// Input: the tension sample, kgf bits.
    pub sample: i32,
    /// Input: the Hall step count.
    pub steps: i32,
}

/// REQ-TEN-01/03/10 for the estimator: from a valid state, one update never panics, keeps
/// the stiffness in range and, with the clip on, moves the filtered sample by no more than
/// the carriage's travel allows.
pub fn estimator_step_bounded(case: &EstimatorCase) -> bool {
    let config = EstimatorConfig {
        spike_clip: case.clip,
        observer_gain: case.observer.then_some(OBSERVER_GAIN),
        rate_filter: Seconds::from_milli(16),
        lag_ticks: 3,
    };
    let Ok(mut estimator) = TensionEstimator::new(&config, 1_000) else {
        panic!("REQ-TEN-06: the estimator configuration was rejected");
    };
    estimator.set_state(case.state);
    if !estimator.is_valid() {
        return false;
    }
    let before = if case.state.primed { case.state.filtered } else { case.sample };
    let out = estimator.update(Kgf::from_bits(case.sample), case.steps);
    assert!(estimator.is_valid(), "REQ-TEN-03: the estimator broke its invariant: {case:?}");
    assert!(out.steps.abs() <= 16, "REQ-TEN-10: step count change not clamped");
    if case.clip {
        let travel = out.steps.saturating_abs().saturating_mul(STEP_MM_BITS);
        let limit = narrow(mul_wide(CLIP_STIFFNESS.to_bits(), travel))
            .saturating_add(CLIP_ALLOWANCE.to_bits());
        let moved = i64::from(out.sample.to_bits()).saturating_sub(i64::from(before)).abs();
        assert!(moved <= i64::from(limit), "REQ-TEN-10: the clip let {moved} through ({limit})");
    }
    true
}

/// REQ-TEN-01: the division-free reciprocal is within 2⁻²⁰ relative (or 2 LSB) of `1/x`
/// for every `x ≥ 2⁻⁷` (Q15.16 bits ≥ 512, so that `1/x ≤ 128` fits Q8.24), checked by
/// multiplying back.
pub fn reciprocal_accurate(x: i32) -> bool {
    if x < 512 {
        return false;
    }
    let r = i64::from(reciprocal_q24(x));
    // r ≈ 2⁴⁰/x ⇔ r·x ≈ 2⁴⁰; |r·x − 2⁴⁰| ≤ x·max(2, r/2²⁰).
    let product = r.saturating_mul(i64::from(x));
    let tolerance = i64::from(x).saturating_mul((r >> 20).max(2));
    assert!(
        product.saturating_sub(1_i64 << 40).abs() <= tolerance,
        "REQ-TEN-01: 1/{x} = {r} (Q8.24) is off by more than 2⁻²⁰"
    );
    true
}

/// REQ-TEN-01, totality: the reciprocal never panics for any `x`, is zero for `x ≤ 0` and
/// saturates rather than wrapping for tiny `x`. (Its *accuracy* is [`reciprocal_accurate`]'s,
/// checked by a dense sweep and proptest: seven chained 64-bit products over 2³¹ inputs are
/// beyond what CBMC settles in minutes.)
pub fn reciprocal_total(x: i32) {
    let r = reciprocal_q24(x);
    if x <= 0 {
        assert_eq!(r, 0, "REQ-TEN-01: 1/{x} should be 0 (not positive)");
    }
}

/// The slip damper's state (its own type, drawn whole) and inputs.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct SlipCase {
    /// The damper's memory (its stall relation raised to zero and its learning count capped
    /// at [`LEARN_TICKS`]: the damper's reachable states).
    pub state: SlipState,
    /// Input: the winding current, A bits.
    pub current: i32,
    /// Input: Hall steps moved.
    pub moved: i32,
    /// Input: the hold is on.
    pub active: bool,
    /// The board's dead-time duty, raw (any board's: clamped to
    /// [`taut_core::tension::controller::DEAD_TIME_DUTY_MAX`], what a board may give).
    pub dead_time_raw: u16,
}

/// `state` moved into the damper's reachable states: a non-negative stall relation, a learning
/// count within [`LEARN_TICKS`].
#[must_use]
pub fn reachable_slip(state: SlipState) -> SlipState {
    SlipState {
        duty_per_amp: state.duty_per_amp.max(0),
        learned: state.learned.min(LEARN_TICKS),
        ..state
    }
}

/// REQ-TEN-15: the slip damper never panics, returns a braking force that is never
/// negative and is zero outside the hold, while the model is still learning, and whenever
/// the motion residual does not exceed the dead zone; its model stays non-negative and its
/// learning count within [`LEARN_TICKS`] — on every board (any dead-time duty a board may give).
pub fn slip_damper_bounded(case: &SlipCase) {
    let max = taut_core::tension::controller::DEAD_TIME_DUTY_MAX.raw();
    let dead_time_duty = taut_core::drive::Duty::from_raw_clamped(case.dead_time_raw.min(max));
    let mut damper = SlipDamper::new(
        Q16::const_from_int(550),
        SLIP_DEAD_ZONE,
        SLIP_LEARNING_RATE,
        SLIP_INITIAL_DUTY_PER_AMP,
        dead_time_duty,
    );
    damper.set_state(reachable_slip(case.state));
    let before = damper.state();
    let brake = damper.update(Amps::from_bits(case.current), case.moved, case.active);
    let after = damper.state();
    assert!(brake >= Kgf::ZERO, "REQ-TEN-15: the damper pushed ({brake:?})");
    if !case.active || (before.learned < LEARN_TICKS && after.learned < LEARN_TICKS) {
        assert_eq!(brake, Kgf::ZERO, "REQ-TEN-15: braked outside the hold or while learning");
    }
    assert!(after.duty_per_amp >= 0, "REQ-TEN-15: the stall relation went negative");
    assert!(after.learned <= LEARN_TICKS, "REQ-TEN-15: learning count out of range");
}

/// REQ-TEN-19: for any configured hold gain `floor_bits` and any identified stiffness
/// `stiffness_bits` (Q15.16 bits), the hold's observer gain is at least the floor and at most
/// the floor or [`HOLD_GAIN_MAX`] (whichever is higher).
pub fn hold_observer_gain_bounded(floor_bits: i32, stiffness_bits: i32) {
    let floor = Q16::from_bits(floor_bits);
    let gain = hold_observer_gain(floor, Q16::from_bits(stiffness_bits));
    assert!(gain >= floor, "REQ-TEN-19: the hold gain {gain:?} fell below its floor");
    assert!(gain <= floor.max(HOLD_GAIN_MAX), "REQ-TEN-19: the hold gain {gain:?} passed 0.2");
}

/// REQ-TEN-19: a stiffer string never gets a lower hold gain. Not a Kani harness: comparing
/// two products of a symbolic operand is what bit-blasting does worst (it timed out at the
/// harness limit); `cargo test` samples it over every `i32` and sweeps 0–4 kgf/mm.
pub fn hold_observer_gain_monotonic(floor_bits: i32, stiffness_bits: i32) {
    let floor = Q16::from_bits(floor_bits);
    let gain = hold_observer_gain(floor, Q16::from_bits(stiffness_bits));
    let stiffer = hold_observer_gain(floor, Q16::from_bits(stiffness_bits.saturating_add(1)));
    assert!(stiffer >= gain, "REQ-TEN-19: a stiffer string got a lower gain");
}

/// Everything one controller step depends on: each part's own state type, drawn whole, and
/// the measurement as bits.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct StepCase {
    /// Use the paper's RSMC configuration instead of taut's.
    pub paper: bool,
    /// The law's memory.
    pub law: RsmcState,
    /// The law's plant scale, Q15.16 bits.
    pub scale: i32,
    /// The tension estimator's memory.
    pub estimator: EstimatorState,
    /// The slip damper's memory.
    pub slip: SlipState,
    /// Speed filter: last step count.
    pub last_steps: i32,
    /// Speed filter: speed (bits).
    pub speed: i32,
    /// Speed filter primed.
    pub primed: bool,
    /// The profile's state.
    pub profile: ProfileState,
    /// Measurement: tension (bits).
    pub tension: i32,
    /// Measurement: Hall steps.
    pub steps: i32,
    /// Measurement: current (bits).
    pub current: i32,
    /// Measurement: home switch.
    pub home: bool,
    /// Measurement: end switch.
    pub end: bool,
    /// Measurement: bus voltage (bits).
    pub bus: i32,
    /// Constant pull switched off, the carriage held at this Hall count (only in the hold).
    pub lock: Option<i32>,
}

/// The controller in the case's state (its invariant not yet checked).
#[must_use]
pub fn controller_in(case: &StepCase) -> TensionController {
    let config = if case.paper { ControllerConfig::PAPER_RSMC } else { ControllerConfig::TAUT };
    let Ok(mut controller) = TensionController::new(&config) else {
        panic!("REQ-TEN-06: a built-in configuration was rejected");
    };
    if let Some(rsmc) = controller.rsmc_mut() {
        rsmc.set_state(case.law);
        rsmc.set_plant_scale(Q16::from_bits(case.scale));
    }
    controller.estimator_mut().set_state(case.estimator);
    if let Some(damper) = controller.slip_damper_mut() {
        damper.set_state(reachable_slip(case.slip));
    }
    controller.speed_estimator_mut().set_state(
        case.last_steps,
        MmPerSecond(Q16::from_bits(case.speed)),
        case.primed,
    );
    controller.set_profile_state(case.profile);
    if let Some(held_at) = case.lock {
        let _in_hold = controller.set_constant_pull(false, held_at);
    }
    controller
}

/// A profile state in the hold (or the phase `phase % 7` selects) from primitive values.
#[must_use]
pub fn hold_state(phase: u8, peak: i32, final_target: i32, reference: i64) -> ProfileState {
    ProfileState {
        phase: PullPhase::ALL.into_iter().nth(usize::from(phase % 7)).unwrap_or_default(),
        peak: Kgf::from_bits(peak),
        final_target: Kgf::from_bits(final_target),
        reference: Q32(reference),
        goal: Kgf::from_bits(final_target),
        at_tension: true,
        ..ProfileState::DEFAULT
    }
}

/// `base` with the take-up identification's fields of `id` — the fields a take-up
/// observation writes (REQ-ID-06/07), and the only ones.
#[must_use]
pub const fn with_identification_of(base: ProfileState, id: ProfileState) -> ProfileState {
    ProfileState {
        take_up_mark: id.take_up_mark,
        braking_decel: id.braking_decel,
        braking_inv_two_decel: id.braking_inv_two_decel,
        rest_sum: id.rest_sum,
        inertial_sum: id.inertial_sum,
        gripper_bias: id.gripper_bias,
        ..base
    }
}

/// REQ-ID-06/07 at the profile: from any valid profile state (taut's shaped profile at
/// 1 kHz), one take-up observation at any carriage speed and any load-cell sample keeps the
/// profile valid (the planned deceleration within the machine's, the gripper's bias within
/// `[0, GRIPPER_BIAS_MAX]`) and changes nothing but the identification's fields. Returns the
/// state after the observation, or `None` for a state outside the valid domain.
///
/// The composed take-up harness (`verify_take_up_step_bounded`) replaces the observation
/// by exactly this guarantee.
#[must_use]
pub fn take_up_observation_keeps_the_profile_valid(
    state: ProfileState,
    speed: i32,
    sample: i32,
) -> Option<ProfileState> {
    let Ok(mut profile) = Profile::new(&ProfileConfig::TAUT, 1_000) else {
        panic!("REQ-TEN-06: the built-in profile was rejected");
    };
    profile.set_state(state);
    if !profile.is_valid() {
        return None;
    }
    profile.observe_take_up(MmPerSecond(Q16::from_bits(speed)), Kgf::from_bits(sample));
    let after = profile.state();
    assert!(
        with_identification_of(after, state) == state,
        "REQ-ID-06: the take-up observation changed more than the identification"
    );
    assert!(profile.is_valid(), "REQ-TEN-03: the take-up observation broke the invariant");
    Some(after)
}

/// REQ-SM-08 at the controller: from any valid profile state, a retarget to any tension
/// keeps the profile valid and its final target in the tension range; it is accepted exactly
/// in the hold with the target in range, and then the final target is the new one.
pub fn retarget_keeps_the_target_in_range(state: ProfileState, target: Kgf) -> bool {
    let Ok(mut profile) = Profile::new(&ProfileConfig::TAUT, 1_000) else {
        panic!("REQ-TEN-06: the built-in profile was rejected");
    };
    profile.set_state(state);
    if !profile.is_valid() {
        return false;
    }
    let before = profile.state();
    let accepted = profile.retarget(target);
    let after = profile.state();
    let in_range = target >= TENSION_MIN && target <= TENSION_MAX;
    assert_eq!(accepted, before.phase == PullPhase::Hold && in_range, "REQ-SM-08: {target:?}");
    if accepted {
        assert_eq!(after.final_target, target, "REQ-SM-08: the target moved");
    } else {
        assert_eq!(after, before, "REQ-SM-08: a refused retarget changed the profile");
    }
    if before.phase == PullPhase::Hold {
        assert!(
            after.final_target >= TENSION_MIN && after.final_target <= TENSION_MAX
                || after.final_target == before.final_target,
            "REQ-SM-08: the hold target left the range"
        );
    }
    assert!(profile.is_valid(), "REQ-TEN-03: a retarget broke the profile's invariant");
    true
}

/// REQ-TEN-01/02/03 for the composed step: for a valid state, one step is panic-free, its
/// duty is within `DUTY_MAX`, within a pull it never reverses, and the state stays valid.
/// Returns whether the case was in the domain (the state was valid).
pub fn controller_step_bounded(case: &StepCase) -> bool {
    controller_step_checked(case).is_some()
}

/// [`controller_step_bounded`]'s checks, returning the phase the step left the controller
/// in (`None` outside the domain) — so a test can tell which branch a case took.
pub fn controller_step_checked(case: &StepCase) -> Option<PullPhase> {
    let mut controller = controller_in(case);
    if !controller.is_valid() {
        return None;
    }
    let phase = controller.phase();
    let measurement = Measurement {
        tension: Kgf::from_bits(case.tension),
        drive: DriveStatus { steps: case.steps, ..DriveStatus::default() },
        current: Amps::from_bits(case.current),
        limits: LimitSwitches { home: case.home, end: case.end },
        bus: Volts::from_bits(case.bus),
    };
    let locked = !controller.constant_pull();
    let out = controller.step(&measurement);
    let duty = out.command.duty();
    if locked && phase == PullPhase::Hold {
        assert!(
            out.command.direction() == Some(Direction::Pull),
            "REQ-TEN-18: the lock-out holds by pulling, never reverses: {:?}",
            out.command
        );
    }
    assert!(duty <= DUTY_MAX && duty.is_valid(), "REQ-TEN-02: duty {duty:?} above DUTY_MAX");
    if !matches!(phase, PullPhase::Idle | PullPhase::Release) {
        match out.command.direction() {
            Some(Direction::Pull) => {}
            // REQ-TEN-17: the back-out, only in the settle and the hold (the phase after
            // the step: a settle may have closed into the hold), at its own duty cap.
            Some(Direction::Release) => {
                assert!(
                    matches!(phase, PullPhase::Settle | PullPhase::Hold)
                        && matches!(controller.phase(), PullPhase::Settle | PullPhase::Hold)
                        && duty <= BACK_OUT_DUTY_MAX,
                    "REQ-TEN-17: a release in {phase:?} at {duty:?}"
                );
            }
            None => panic!("REQ-TEN-09: a pull never coasts"),
        }
    }
    assert!(controller.is_valid(), "REQ-TEN-03: the step broke the invariant: {case:?}");
    Some(controller.phase())
}

#[cfg(kani)]
#[allow(
    dead_code,
    reason = "the stubs are referenced only from `#[kani::stub]` attributes, which rustc's \
              dead-code analysis does not see"
)]
mod verification {
    use super::*;
    use taut_core::drive::{DriveCommand, Duty};
    use taut_core::mechanism::MAX_STEPS_PER_TICK;
    use taut_core::tension::Estimate;
    use taut_core::tension::law::{Pd, RsmcOutput};
    use taut_core::tension::motor::SpeedEstimator;

    /// REQ-TEN-01/03, the law: every valid state (paper's and taut's gains, any plant
    /// scale), every reference and measurement. Fourteen 32 × 32 → 64-bit products, no
    /// division, no loop (see the module docs).
    #[kani::proof]
    fn verify_rsmc_step_bounded() {
        let case: LawCase = kani::any();
        kani::assume(law_in(&case).is_valid());
        assert!(rsmc_step_bounded(&case));
        crate::harness_end_reached();
    }

    /// REQ-TEN-02/09, the force → duty stage: every force, speed and current-limit window
    /// (every window the stage can compute has `low ≥ 0` and `high ≤ DUTY_MAX`), both maps.
    #[kani::proof]
    fn verify_force_to_duty_bounded() {
        let (low, high): (i64, i64) = (kani::any(), kani::any());
        kani::assume(low >= 0 && high <= i64::from(DUTY_MAX.raw()));
        force_to_duty_within(kani::any(), kani::any(), kani::any(), kani::any(), (low, high));
        crate::harness_end_reached();
    }

    /// REQ-TEN-01/03/10, the estimator: every valid state and input, clip and observer on
    /// or off, the stiffness known or not. The median of five is six comparisons, the
    /// burst-proof median 15 × 15 comparisons after 15 products (the window's loops, unwound
    /// once more than their count of 15, so CBMC's unwinding assertion can show they end);
    /// seven more products and a four-step loop.
    #[kani::proof]
    #[kani::unwind(16)]
    fn verify_estimator_step_bounded() {
        let case: EstimatorCase = kani::any();
        // The estimator's invariant, as `TensionEstimator::is_valid` states it.
        kani::assume(case.state.stiffness >= 0 && case.state.stiffness <= 4 << 16);
        kani::assume(usize::from(case.state.bridged) <= taut_core::tension::estimator::BURST_MAX);
        assert!(estimator_step_bounded(&case));
        crate::harness_end_reached();
    }

    /// REQ-TEN-19, the hold's observer gain: every floor and stiffness. One product.
    #[kani::proof]
    fn verify_hold_observer_gain_bounded() {
        hold_observer_gain_bounded(kani::any(), kani::any());
        crate::harness_end_reached();
    }

    /// REQ-TEN-15, the slip damper: every state and input. Three products.
    #[kani::proof]
    fn verify_slip_damper_bounded() {
        slip_damper_bounded(&kani::any());
        crate::harness_end_reached();
    }

    /// REQ-TEN-01, the reciprocal is total: every `x` (three Newton steps, `unwind(4)`).
    #[kani::proof]
    #[kani::unwind(4)]
    fn verify_reciprocal_total() {
        reciprocal_total(kani::any());
        crate::harness_end_reached();
    }

    // # The composed step, assume–guarantee
    //
    // `verify_controller_step_bounded` checks the profile (braking onset, reference,
    // phases) around the parts, each replaced by a stub that returns *any* value the part's
    // own harness above allows — its guarantee — and leaves the part's state as it was
    // (valid by assumption; the part's harness proves its own step keeps it valid). So the
    // composition is proven for every behaviour of the parts, not for their particular
    // arithmetic, which the per-part harnesses prove. Guarantees used: the estimator's step
    // count is clamped to ±`MAX_STEPS_PER_TICK` (REQ-TEN-10); the duty stage always commands
    // `Pull` with a valid duty (REQ-TEN-02/09); the slip damper's brake is never negative
    // (REQ-TEN-15); the take-up observation writes only the identification's fields and
    // keeps the profile valid (REQ-ID-06/07, `verify_take_up_observation_valid`); everything
    // else is any value of its type.

    /// The estimator's update: any estimate, the step count within its clamp.
    fn any_estimate(_estimator: &mut TensionEstimator, _sample: Kgf, _steps: i32) -> Estimate {
        let steps: i32 = kani::any();
        kani::assume((-MAX_STEPS_PER_TICK..=MAX_STEPS_PER_TICK).contains(&steps));
        Estimate {
            tension: Kgf::from_bits(kani::any()),
            sample: Kgf::from_bits(kani::any()),
            clipped: Kgf::from_bits(kani::any()),
            rate: KgfPerSecond::from_bits(kani::any()),
            speed: MmPerSecond(Q16::from_bits(kani::any())),
            steps,
        }
    }

    /// The Hall speed: any speed.
    fn any_speed(_speed: &mut SpeedEstimator, _steps: i32) -> MmPerSecond {
        MmPerSecond(Q16::from_bits(kani::any()))
    }

    /// The law's step: any force.
    fn any_law_output(_law: &mut Rsmc, _r: &Reference, _y: Kgf, _s: Saturation) -> RsmcOutput {
        RsmcOutput {
            force: Kgf::from_bits(kani::any()),
            surface: KgfPerSecond::from_bits(kani::any()),
            equivalent: Kgf::from_bits(kani::any()),
        }
    }

    /// The PD baseline's step: any force.
    fn any_pd_force(_pd: &mut Pd, _r: &Reference, _y: Kgf) -> Kgf {
        Kgf::from_bits(kani::any())
    }

    /// The duty stage: `Pull` at any valid duty, any saturation flag.
    fn any_pull_command(
        _stage: &ForceToDuty,
        _force: Kgf,
        _speed: MmPerSecond,
    ) -> (DriveCommand, Saturation) {
        let duty = Duty::from_raw_clamped(kani::any());
        (DriveCommand::Drive { direction: Direction::Pull, duty }, kani::any())
    }

    /// The reciprocal: zero for `x ≤ 0`, any value otherwise — the guarantee
    /// `verify_reciprocal_total` proves (its accuracy, swept under `cargo test`, is not
    /// needed: every caller clamps what it makes of the result). Three calls in the braking
    /// onset's tick (the bus scale, the stiffness, the plant scale), each six products.
    fn any_reciprocal(x: i32) -> i32 {
        if x <= 0 { 0 } else { kani::any() }
    }

    /// The slip damper: any non-negative brake.
    fn any_brake(_damper: &mut SlipDamper, _current: Amps, _moved: i32, _active: bool) -> Kgf {
        let bits: i32 = kani::any();
        kani::assume(bits >= 0);
        Kgf::from_bits(bits)
    }

    /// REQ-SM-08: a retarget from any valid profile state to any tension keeps the target in
    /// the range and the profile valid.
    #[kani::proof]
    #[kani::unwind(6)]
    fn verify_hold_retarget_in_range() {
        let state = hold_state(kani::any(), kani::any(), kani::any(), kani::any());
        let _in_domain = retarget_keeps_the_target_in_range(state, Kgf::from_bits(kani::any()));
        crate::harness_end_reached();
    }

    /// REQ-ID-06/07: one take-up observation from any valid profile state, at any speed
    /// and sample, keeps the profile valid and writes only the identification (its two
    /// 64-bit divisions and the bias's, once a pull). The composed take-up harness relies on
    /// it through `any_take_up_observation`.
    #[kani::proof]
    fn verify_take_up_observation_valid() {
        let state: ProfileState = kani::any();
        let _in_domain =
            take_up_observation_keeps_the_profile_valid(state, kani::any(), kani::any());
        crate::harness_end_reached();
    }

    /// The take-up observation: the identification's fields any values that keep the
    /// profile valid, everything else as it was — the guarantee
    /// `verify_take_up_observation_valid` proves.
    fn any_take_up_observation(profile: &mut Profile, _speed: MmPerSecond, _sample: Kgf) {
        let drawn: ProfileState = kani::any();
        profile.set_state(with_identification_of(profile.state(), drawn));
        kani::assume(profile.is_valid());
    }

    /// A composed-step harness: the controller's step with its parts replaced by their
    /// proven guarantees (the stubs above; the estimator's four-step loop and the
    /// reciprocal's three Newton steps are stubbed; `unwind(6)` bounds whatever loop remains), from
    /// the drawn `StepCase` the body narrows; every outcome `controller_step_bounded` checks.
    macro_rules! composed_step {
        ($(#[$doc:meta])* fn $name:ident($case:ident) { $($narrow:tt)* }) => {
            $(#[$doc])*
            #[kani::proof]
            #[kani::unwind(6)]
            #[kani::stub(taut_core::tension::estimator::TensionEstimator::update, any_estimate)]
            #[kani::stub(taut_core::tension::motor::SpeedEstimator::update, any_speed)]
            #[kani::stub(taut_core::tension::law::Rsmc::step, any_law_output)]
            #[kani::stub(taut_core::tension::law::Pd::step, any_pd_force)]
            #[kani::stub(taut_core::tension::motor::ForceToDuty::command, any_pull_command)]
            #[kani::stub(taut_core::tension::slip::SlipDamper::update, any_brake)]
            #[kani::stub(taut_core::fixed::reciprocal_q24, any_reciprocal)]
            #[kani::stub(
                taut_core::tension::profile::Profile::observe_take_up,
                any_take_up_observation
            )]
            fn $name() {
                let mut $case: StepCase = kani::any();
                $($narrow)*
                kani::assume(controller_in(&$case).is_valid());
                assert!(controller_step_bounded(&$case));
                crate::harness_end_reached();
            }
        };
    }

    composed_step!(
        /// REQ-TEN-01/02/03, the composition: every valid controller state (law, estimator,
        /// Hall filter, profile in every phase but the take-up, which the next harness takes),
        /// every measurement, every behaviour of the parts within their proven guarantees.
        fn verify_controller_step_bounded(case) {
            case.lock = None;
            kani::assume(case.profile.phase != PullPhase::TakeUp);
        }
    );

    /// The take-up's branch: the braking is not due this tick (the velocity mode runs).
    fn braking_not_due(_profile: &Profile, _est: &Estimate) -> bool {
        false
    }

    /// The take-up's branch: the braking is due this tick (the onset runs).
    fn braking_due_now(_profile: &Profile, _est: &Estimate) -> bool {
        true
    }

    composed_step!(
        /// REQ-TEN-01/02/03 with REQ-ID-06/07: the same composition in the take-up at its
        /// speed limit — the velocity mode under the current limit, the identification within
        /// its proven guarantee (`verify_take_up_observation_valid`). `Profile::braking_due`
        /// answers "not yet" for every state, so the next harness, where it answers "now",
        /// covers the other branch: split so each stays within two minutes.
        #[kani::stub(taut_core::tension::profile::Profile::braking_due, braking_not_due)]
        fn verify_take_up_step_bounded(case) {
            case.lock = None;
            case.profile.phase = PullPhase::TakeUp;
        }
    );

    composed_step!(
        /// REQ-TEN-01/02/03 with REQ-ID-06/07: the take-up's tick on which the braking starts,
        /// from every take-up state — the stiffness identified, the parabola planned, the
        /// law's plant scaled and reset, the first closed-loop step.
        #[kani::stub(taut_core::tension::profile::Profile::braking_due, braking_due_now)]
        fn verify_braking_onset_step_bounded(case) {
            case.lock = None;
            case.profile.phase = PullPhase::TakeUp;
        }
    );

    composed_step!(
        /// REQ-TEN-18 with REQ-TEN-01/02/03: the same composition with constant pull switched
        /// off (the lock-out, only in the hold) at any Hall count — a split of the harness
        /// above so each stays within two minutes: the locked step pulls, within `DUTY_MAX`,
        /// and keeps the state valid.
        fn verify_lock_out_step_bounded(case) {
            case.lock = Some(kani::any());
            case.profile.phase = PullPhase::Hold;
        }
    );
}

//! The tension controller's properties under `cargo test`: each Kani property sampled by
//! proptest over its valid domain (or swept), and the fixed-point law against its `f64`
//! reference (REQ-TEN-01 … 05). Each test prints how many cases it checked.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::float_arithmetic,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::print_stdout,
    clippy::unwrap_used,
    reason = "test bookkeeping, the f64 comparison and its report"
)]

use std::sync::atomic::{AtomicU64, Ordering};

use proptest::prelude::*;
use taut_core::fixed::{Q24, Q32};
use taut_core::settings::MmPerSecond;
use taut_core::tension::PullPhase;
use taut_core::tension::controller::{TAUT_GAINS, TAUT_PLANT};
use taut_core::tension::estimator::EstimatorState;
use taut_core::tension::law::{RsmcGains, RsmcState, Saturation};
use taut_core::tension::profile::{GRIPPER_BIAS_MAX, ProfileState};
use taut_core::tension::slip::SlipState;
use taut_core::units::{Kgf, KgfPerSecond, Q16};
use taut_proofs::tension::{
    EstimatorCase, LawCase, SlipCase, StepCase, controller_step_bounded, controller_step_checked,
    estimator_step_bounded, force_to_duty_bounded, hold_observer_gain_bounded,
    hold_observer_gain_monotonic, hold_state, reciprocal_accurate, reciprocal_total,
    retarget_keeps_the_target_in_range, rsmc_step_bounded, slip_damper_bounded,
    take_up_observation_keeps_the_profile_valid,
};
use taut_proofs::tension_reference::{TrackStep, coefficient_errors, law_tracks_reference};

const KGF: i32 = 65_536;

fn saturation() -> impl Strategy<Value = Saturation> {
    prop_oneof![Just(Saturation::None), Just(Saturation::High), Just(Saturation::Low)]
}

/// The law's memory, steered into its valid domain (`|z|` and `φ̂` within their bounds).
fn rsmc_state() -> impl Strategy<Value = RsmcState> {
    (any::<i32>(), any::<i32>(), -2_000 * KGF..=2_000 * KGF, 0_i64..=(2_i64 << 32))
        .prop_map(|(e_prev, e_rate, z, phi_hat)| RsmcState { e_prev, e_rate, z, phi_hat })
}

fn law_case() -> impl Strategy<Value = LawCase> {
    (
        (any::<bool>(), rsmc_state(), 0..=11 * KGF),
        (any::<i32>(), any::<i32>(), any::<i32>(), any::<i32>(), saturation()),
    )
        .prop_map(|((paper, state, scale), (y_d, rate, accel, y, saturated))| LawCase {
            paper,
            state,
            scale,
            y_d,
            rate,
            accel,
            y,
            saturated,
        })
}

/// The estimator's memory, its stiffness in range.
fn estimator_state() -> impl Strategy<Value = EstimatorState> {
    (
        (any::<[i32; 15]>(), any::<[i32; 15]>(), any::<i32>(), any::<i64>(), any::<i32>()),
        (any::<i32>(), any::<i32>(), any::<bool>(), 0..=4 * KGF, any::<[i32; 4]>(), 0..=5u8),
    )
        .prop_map(
            |(
                (window, window_steps, filtered, fused, rate),
                (speed, last_steps, primed, stiffness, recent, bridged),
            )| {
                EstimatorState {
                    window,
                    window_steps,
                    filtered,
                    fused,
                    rate,
                    speed,
                    last_steps,
                    primed,
                    stiffness,
                    recent,
                    bridged,
                }
            },
        )
}

fn estimator_case() -> impl Strategy<Value = EstimatorCase> {
    (any::<bool>(), any::<bool>(), estimator_state(), any::<i32>(), any::<i32>()).prop_map(
        |(clip, observer, state, sample, steps)| EstimatorCase {
            clip,
            observer,
            state,
            sample,
            steps,
        },
    )
}

fn slip_state() -> impl Strategy<Value = SlipState> {
    (any::<i32>(), any::<i32>(), any::<u16>(), any::<u16>()).prop_map(
        |(duty_per_amp, last_duty, quiet, learned)| SlipState {
            duty_per_amp,
            last_duty,
            quiet,
            learned,
        },
    )
}

fn slip_case() -> impl Strategy<Value = SlipCase> {
    (slip_state(), any::<i32>(), any::<i32>(), any::<bool>(), any::<u16>()).prop_map(
        |(state, current, moved, active, dead_time_raw)| SlipCase {
            state,
            current,
            moved,
            active,
            dead_time_raw,
        },
    )
}

/// A profile state in the valid domain's neighbourhood: tensions within the range, the peak
/// at or above the final target, the goal at or below the peak, every phase.
fn profile_state() -> impl Strategy<Value = ProfileState> {
    (
        (
            prop::sample::select(PullPhase::ALL.to_vec()),
            0..=50 * KGF,
            0..=50 * KGF,
            0..=50 * KGF,
            any::<i32>(),
        ),
        (0_i64..=(50_i64 << 32), any::<i32>(), any::<i32>(), any::<u32>()),
        (any::<bool>(), saturation(), any::<bool>()),
        (any::<u32>(), 0..=(1_200_i32 << 16), 0..=i32::MAX),
        (any::<i32>(), any::<i32>(), 0..=GRIPPER_BIAS_MAX.to_bits()),
    )
        .prop_map(|(a, b, c, d, e)| {
            let (peak, final_target) = if a.1 >= a.2 { (a.1, a.2) } else { (a.2, a.1) };
            ProfileState {
                phase: a.0,
                peak: Kgf::from_bits(peak),
                final_target: Kgf::from_bits(final_target),
                goal: Kgf::from_bits(a.3.min(peak)),
                speed_limit: MmPerSecond(Q16::from_bits(a.4)),
                reference: Q32(b.0),
                reference_rate: KgfPerSecond::from_bits(b.1),
                reference_accel: Q16::from_bits(b.2),
                ticks: b.3,
                at_tension: c.0,
                saturated: c.1,
                fresh: c.2,
                take_up_mark: d.0,
                braking_decel: Q16::from_bits(d.1),
                braking_inv_two_decel: Q24(d.2),
                rest_sum: e.0,
                inertial_sum: e.1,
                gripper_bias: Kgf::from_bits(e.2),
            }
        })
}

fn step_case() -> impl Strategy<Value = StepCase> {
    (
        (any::<bool>(), rsmc_state(), 0..=11 * KGF, estimator_state(), slip_state()),
        (any::<i32>(), any::<i32>(), any::<bool>(), profile_state()),
        (
            -5 * KGF..=70 * KGF,
            any::<i32>(),
            any::<i32>(),
            any::<bool>(),
            any::<bool>(),
            any::<i32>(),
        ),
        prop::option::of(any::<i32>()),
    )
        .prop_map(|(a, b, f, lock)| StepCase {
            paper: a.0,
            law: a.1,
            scale: a.2,
            estimator: a.3,
            slip: a.4,
            last_steps: b.0,
            speed: b.1,
            primed: b.2,
            profile: b.3,
            tension: f.0,
            steps: f.1,
            current: f.2,
            home: f.3,
            end: f.4,
            bus: f.5,
            lock,
        })
}

static LAW_CASES: AtomicU64 = AtomicU64::new(0);
static ESTIMATOR_CASES: AtomicU64 = AtomicU64::new(0);
static STEP_CASES: AtomicU64 = AtomicU64::new(0);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    /// Mirror of `verify_rsmc_step_bounded` (Kani), steered into the valid domain.
    #[test]
    fn rsmc_step_bounded_sampled(case in law_case()) {
        if rsmc_step_bounded(&case) {
            LAW_CASES.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The law's property on unconstrained states: invalid ones are skipped, valid ones hold.
    #[test]
    fn rsmc_step_bounded_raw(case in any::<(bool, i32, i32, i32, i64, i32, i32, i32)>()) {
        let (paper, e_prev, e_rate, z, phi_hat, scale, y_d, y) = case;
        let state = RsmcState { e_prev, e_rate, z, phi_hat };
        let case = LawCase { paper, state, scale, y_d, y, ..LawCase::default() };
        let _ = rsmc_step_bounded(&case);
    }

    /// Mirror of `verify_force_to_duty_bounded` (Kani).
    #[test]
    fn force_to_duty_bounded_sampled(current_map in any::<bool>(), force in any::<i32>(), speed in any::<i32>(), bus in any::<i32>()) {
        force_to_duty_bounded(current_map, force, speed, bus);
    }

    /// Mirror of `verify_estimator_step_bounded` (Kani), over the valid domain.
    #[test]
    fn estimator_step_bounded_sampled(case in estimator_case()) {
        if estimator_step_bounded(&case) {
            ESTIMATOR_CASES.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Mirror of `verify_hold_observer_gain_bounded` (Kani): any floor, any stiffness.
    #[test]
    fn hold_observer_gain_bounded_sampled(floor in any::<i32>(), stiffness in any::<i32>()) {
        hold_observer_gain_bounded(floor, stiffness);
        hold_observer_gain_monotonic(floor, stiffness);
    }

    /// Mirror of `verify_slip_damper_bounded` (Kani).
    #[test]
    fn slip_damper_bounded_sampled(case in slip_case()) {
        slip_damper_bounded(&case);
    }

    /// Mirror of `verify_take_up_observation_valid` (Kani): any drawn profile state put in
    /// the take-up, any speed and sample.
    #[test]
    fn take_up_observation_valid_sampled(state in profile_state(), speed in any::<i32>(), sample in any::<i32>()) {
        let state = ProfileState { phase: PullPhase::TakeUp, ..state };
        let _in_domain = take_up_observation_keeps_the_profile_valid(state, speed, sample);
    }

    /// Mirror of `verify_controller_step_bounded` (Kani), steered into the valid domain.
    #[test]
    fn controller_step_bounded_sampled(case in step_case()) {
        if controller_step_bounded(&case) {
            STEP_CASES.fetch_add(1, Ordering::Relaxed);
        }
    }
}

#[test]
fn force_to_duty_bounded_swept() {
    // A grid over the physical range and beyond: forces ±2 000 kgf by 7.3, speeds
    // ±300 mm/s by 1.7, both maps, plus the format's extremes.
    let mut cases = 0_u64;
    for current_map in [false, true] {
        for force in (-2_000 * KGF..=2_000 * KGF).step_by(478_412) {
            for speed in (-300 * KGF..=300 * KGF).step_by(111_411) {
                for bus in [0, 20 * KGF, 24 * KGF, 35 * KGF] {
                    force_to_duty_bounded(current_map, force, speed, bus);
                    cases += 1;
                }
            }
        }
        for force in [i32::MIN, -1, 0, 1, i32::MAX] {
            for speed in [i32::MIN, -1, 0, 1, i32::MAX] {
                for bus in [i32::MIN, 0, 12 * KGF - 1, 12 * KGF, 48 * KGF, i32::MAX] {
                    force_to_duty_bounded(current_map, force, speed, bus);
                    cases += 1;
                }
            }
        }
    }
    println!("force_to_duty_bounded_swept: {cases} (force, speed, map) cases");
    assert!(cases > 100_000);
}

proptest! {
    #[test]
    fn reciprocal_total_for_any_x(x in any::<i32>()) {
        reciprocal_total(x);
    }
}

#[test]
fn reciprocal_accurate_swept() {
    // Every x from 2⁻⁷ to 2¹⁵ on a 0.01 % geometric grid, plus each power of two ± 1.
    let mut cases = 0_u64;
    let mut x: i64 = 512;
    while x <= i64::from(i32::MAX) {
        assert!(reciprocal_accurate(i32::try_from(x).unwrap()));
        cases += 1;
        x += (x / 10_000).max(1);
    }
    for shift in 10..31 {
        for x in [(1_i32 << shift) - 1, 1 << shift, (1 << shift) + 1] {
            assert!(reciprocal_accurate(x));
            cases += 1;
        }
    }
    println!("reciprocal_accurate_swept: {cases} values of x");
    assert!(cases > 100_000);
}

/// `verify_take_up_observation_valid` along whole take-ups: the carriage accelerating from
/// rest to each speed limit in 40–400 ticks, the cell reading a rest level plus a gripper's
/// inertial force (none, a plausible one, one past the bound, a falling one), so the rest sum,
/// the window, both divisions and the bias's bound are all reached; every observation keeps
/// the profile valid and writes only the identification.
#[test]
fn take_up_observation_valid_along_take_ups() {
    let mut identified = 0;
    for limit_mm_s in [5, 30, 60, 120] {
        for ramp_ticks in [40_i32, 100, 400] {
            for (rest, inertial) in [(0, 0), (-300, 40), (250, 200), (0, 5_000), (100, -80)] {
                let mut state = ProfileState {
                    phase: PullPhase::TakeUp,
                    peak: Kgf::from_int(30),
                    final_target: Kgf::from_int(30),
                    goal: Kgf::from_int(30),
                    speed_limit: MmPerSecond(Q16::const_from_int(limit_mm_s)),
                    ..ProfileState::DEFAULT
                };
                for tick in 1..=ramp_ticks + 20 {
                    state.ticks = tick.unsigned_abs();
                    let speed = (limit_mm_s << 16) / ramp_ticks * tick.min(ramp_ticks);
                    let accelerating = tick <= ramp_ticks;
                    let sample = (rest + if accelerating { inertial } else { 0 }) * 65;
                    state = take_up_observation_keeps_the_profile_valid(state, speed, sample)
                        .expect("a take-up from rest is in the valid domain");
                }
                if state.braking_decel > Q16::ZERO {
                    identified += 1;
                }
            }
        }
    }
    // Every take-up that reaches three quarters of its limit identifies its braking.
    assert_eq!(identified, 60, "every take-up identified its braking deceleration");
}

#[test]
fn step_properties_coverage() {
    // Runs alongside the proptests; reports how many valid states were checked, and samples
    // the composed step once more on its own to be sure the generator stays in the domain.
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig::with_cases(5_000));
    let valid = AtomicU64::new(0);
    runner
        .run(&step_case(), |case| {
            if controller_step_bounded(&case) {
                valid.fetch_add(1, Ordering::Relaxed);
            }
            Ok(())
        })
        .unwrap();
    let valid = valid.load(Ordering::Relaxed);
    println!(
        "step_properties_coverage: {valid} of 5 000 sampled controller states valid and checked \
         (plus {} law, {} estimator and {} controller states in the proptests)",
        LAW_CASES.load(Ordering::Relaxed),
        ESTIMATOR_CASES.load(Ordering::Relaxed),
        STEP_CASES.load(Ordering::Relaxed)
    );
    assert!(valid > 4_000, "the generator must mostly produce valid states");
}

#[test]
fn take_up_step_bounded_in_both_branches() {
    // Mirror of `verify_take_up_step_bounded` and `verify_braking_onset_step_bounded`
    // (Kani), which split the take-up's tick on `Profile::braking_due`: sampled take-up
    // states, each stepped with the real predicate, must reach both branches — the carriage
    // still at its speed limit, and the braking started (the step leaves the take-up).
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig::with_cases(5_000));
    let (cruising, braking) = (AtomicU64::new(0), AtomicU64::new(0));
    let take_up = step_case().prop_map(|mut case| {
        case.lock = None;
        case.profile.phase = PullPhase::TakeUp;
        case
    });
    runner
        .run(&take_up, |case| {
            match controller_step_checked(&case) {
                Some(PullPhase::TakeUp) => cruising.fetch_add(1, Ordering::Relaxed),
                // The approach, or past it: a parabola can end on its first tick.
                Some(_) => braking.fetch_add(1, Ordering::Relaxed),
                None => 0,
            };
            Ok(())
        })
        .unwrap();
    let (cruising, braking) = (cruising.into_inner(), braking.into_inner());
    println!(
        "take_up_step_bounded_in_both_branches: {cruising} take-up ticks at the speed limit, \
         {braking} braking onsets, of 5 000 sampled"
    );
    assert!(cruising >= 500 && braking >= 500, "both branches sampled: {cruising}, {braking}");
}

#[test]
fn coefficients_are_correctly_rounded() {
    // REQ-TEN-05 part 1: every derived coefficient within one unit of its last place of
    // its exact value, both laws, at 1 ms and at the paper's 0.1 ms.
    let mut checked = 0;
    for gains in [TAUT_GAINS, RsmcGains::paper(TAUT_PLANT)] {
        for period in [1_000_u32, 100] {
            for (name, error) in coefficient_errors(&gains, period) {
                assert!(error <= 1.0, "{name} at {period} µs: {error} units off");
                checked += 1;
            }
        }
    }
    println!("coefficients_are_correctly_rounded: {checked} coefficients within 1 ulp");
}

static COMPARED: AtomicU64 = AtomicU64::new(0);

fn track_steps(len: usize) -> impl Strategy<Value = Vec<TrackStep>> {
    // A tension walk and a moving reference in the machine's range: tension 0–60 kgf (the
    // first step's values are the start), reference steps ±0.1 kgf, rate ±200 kgf/s,
    // acceleration ±3 000 kgf/s², measured steps ±0.1 kgf.
    proptest::collection::vec(
        (0..60 * KGF, -200 * KGF..200 * KGF, -3_000 * KGF..3_000 * KGF, 0..60 * KGF, any::<u8>())
            .prop_map(|(y_d, rate, accel, dy, saturated)| TrackStep {
                y_d,
                rate,
                accel,
                dy,
                saturated,
            }),
        len,
    )
    .prop_map(|mut steps| {
        // After the first step, the walks' increments: ±0.1 kgf.
        for step in steps.iter_mut().skip(1) {
            step.y_d = step.y_d % (KGF / 5) - KGF / 10;
            step.dy = step.dy % (KGF / 5) - KGF / 10;
        }
        steps
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// REQ-TEN-05 part 2: over 1 000-step runs (1 s at 1 kHz, 0.1 s at 10 kHz) the fixed-point
    /// force stays within `tracking_bound(k)` of the f64 reference at every step `k`, for
    /// both laws and both periods, any plant scale.
    #[test]
    fn fixed_rsmc_tracks_float_reference(
        paper in any::<bool>(),
        fast in any::<bool>(),
        scale in (KGF / 10)..=(10 * KGF),
        steps in track_steps(1_000),
    ) {
        let compared = law_tracks_reference(paper, fast, scale, &steps);
        COMPARED.fetch_add(compared as u64, Ordering::Relaxed);
    }
}

#[test]
fn fixed_rsmc_tracks_float_reference_at_rest_and_in_a_ramp() {
    // Deterministic runs: a held string (reference constant, tension within ±0.05 kgf of
    // it) for 10 000 steps, and the braking parabola of a stiff string, each law and period.
    let mut total = 0;
    for paper in [false, true] {
        for fast in [false, true] {
            let hold: Vec<TrackStep> = (0..10_000_i32)
                .map(|k| TrackStep {
                    y_d: if k == 0 { 25 * KGF } else { 0 },
                    rate: 0,
                    accel: 0,
                    dy: if k == 0 { 25 * KGF } else { ((k * 7_919) % 6_553) - 3_276 },
                    saturated: 0,
                })
                .collect();
            total += law_tracks_reference(paper, fast, KGF, &hold);
            let ramp: Vec<TrackStep> = (0..1_000_i32)
                .map(|k| TrackStep {
                    y_d: if k == 0 { 20 * KGF } else { 50 },
                    rate: (80 - k / 20) * KGF,
                    accel: -1_600 * KGF,
                    dy: if k == 0 { 20 * KGF } else { 48 },
                    saturated: 0,
                })
                .collect();
            total += law_tracks_reference(paper, fast, 2 * KGF / 5, &ramp);
        }
    }
    println!(
        "fixed_rsmc_tracks_float_reference: {total} deterministic steps compared (plus {} in the proptest)",
        COMPARED.load(Ordering::Relaxed)
    );
    assert!(total > 40_000, "{total}");
}

/// Exhaustive part of `verify_hold_retarget_in_range` (Kani): in every phase, from a valid
/// target of every tenth of a kgf in the range, a retarget to every tenth from −1 to 60 kgf
/// (and the extremes of the format).
#[test]
fn hold_retarget_in_range_exhaustive() {
    let tenth = 6_554; // 0.1 kgf, bits
    let mut cases = 0u64;
    for phase in 0..7u8 {
        for final_tenths in (50..=500).step_by(5) {
            let final_bits = final_tenths * tenth;
            let state = hold_state(phase, final_bits, final_bits, i64::from(final_bits) << 16);
            let targets = (-10..=600).map(|t| t * tenth).chain([i32::MIN, i32::MAX, 0]);
            for target in targets {
                if retarget_keeps_the_target_in_range(state, Kgf::from_bits(target)) {
                    cases += 1;
                }
            }
        }
    }
    println!("hold_retarget_in_range_exhaustive: {cases} cases");
    assert!(cases > 300_000);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    /// Mirror of `verify_hold_retarget_in_range` (Kani) over any profile values.
    #[test]
    fn hold_retarget_in_range_sampled(
        phase in any::<u8>(),
        peak in any::<i32>(),
        final_target in any::<i32>(),
        reference in any::<i64>(),
        target in any::<i32>(),
    ) {
        let _in_domain = retarget_keeps_the_target_in_range(
            hold_state(phase, peak, final_target, reference),
            Kgf::from_bits(target),
        );
    }
}

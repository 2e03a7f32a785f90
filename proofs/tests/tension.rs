//! The tension controller's properties under `cargo test`: the Kani property sampled by
//! proptest over the valid domain (and over raw inputs), and the fixed-point law against its
//! `f64` reference (REQ-TEN-01 … 05).
#![allow(
    clippy::arithmetic_side_effects,
    clippy::float_arithmetic,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::print_stdout,
    reason = "test bookkeeping and the f64 comparison"
)]

use std::sync::atomic::{AtomicU64, Ordering};

use proptest::prelude::*;
use taut_core::tension::controller::TAUT_GAINS;
use taut_core::tension::controller::TAUT_PLANT;
use taut_core::tension::law::{Reference, Rsmc, RsmcGains, Saturation};
use taut_core::units::{Kgf, KgfPerSecond, Q16};
use taut_proofs::tension::{StepCase, rsmc_step_bounded};
use taut_proofs::tension_reference::{
    FORCE_COMPARED_MAX, FORCE_TOLERANCE_ABS, FORCE_TOLERANCE_REL, RsmcReference, SGN_GUARD, q,
};

const KGF: i32 = 65_536;

fn valid_case() -> impl Strategy<Value = StepCase> {
    (
        (
            any::<bool>(),
            any::<i32>(),
            any::<i32>(),
            -2_000 * KGF..=2_000 * KGF,
            0_i64..=(2_i64 << 32),
        ),
        (
            any::<i32>(),
            any::<i32>(),
            any::<bool>(),
            0_u8..7,
            0..=50 * KGF,
            0..=50 * KGF,
            0..=50 * KGF,
        ),
        (any::<i32>(), 0_i64..=(50_i64 << 32), any::<u32>(), any::<i32>(), any::<i32>()),
        (any::<bool>(), 0_u8..3, any::<bool>(), any::<[i32; 5]>()),
        (-5 * KGF..=70 * KGF, any::<i32>(), any::<i32>(), any::<bool>(), any::<bool>()),
    )
        .prop_map(|(a, b, c, d, e)| {
            let (peak, final_target) = if b.4 >= b.5 { (b.4, b.5) } else { (b.5, b.4) };
            StepCase {
                paper: a.0,
                e_prev: a.1,
                e_rate: a.2,
                z: a.3,
                phi_hat: a.4,
                last_steps: b.0,
                speed: b.1,
                primed: b.2,
                phase: b.3,
                peak,
                final_target,
                goal: b.6.min(peak),
                speed_limit: c.0,
                reference: c.1,
                ticks: c.2,
                last_tension: c.3,
                rate: c.4,
                at_tension: d.0,
                saturated: d.1,
                coasting: d.2,
                window: d.3,
                tension: e.0,
                steps: e.1,
                current: e.2,
                home: e.3,
                end: e.4,
            }
        })
}

static IN_DOMAIN: AtomicU64 = AtomicU64::new(0);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    /// Mirror of `verify_rsmc_step_bounded` (Kani), steered into the valid domain.
    #[test]
    fn rsmc_step_bounded_sampled(case in valid_case()) {
        if rsmc_step_bounded(&case) {
            IN_DOMAIN.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The same property on unconstrained inputs: invalid states are skipped, valid ones hold.
    #[test]
    fn rsmc_step_bounded_raw(paper in any::<bool>(), e_prev in any::<i32>(), tension in any::<i32>(), steps in any::<i32>(), phase in any::<u8>()) {
        let case = StepCase { paper, e_prev, tension, steps, phase, peak: 20 * KGF, final_target: 20 * KGF, goal: 20 * KGF, ..StepCase::default() };
        prop_assert!(rsmc_step_bounded(&case));
    }
}

#[test]
fn rsmc_step_bounded_coverage() {
    // Runs after (or alongside) the proptest; reports how many valid states were checked.
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig::with_cases(5_000));
    let valid = AtomicU64::new(0);
    runner
        .run(&valid_case(), |case| {
            if rsmc_step_bounded(&case) {
                valid.fetch_add(1, Ordering::Relaxed);
            }
            Ok(())
        })
        .unwrap();
    let valid = valid.load(Ordering::Relaxed);
    println!(
        "rsmc_step_bounded_coverage: {valid} of 5 000 sampled states valid and checked \
         (plus {} in rsmc_step_bounded_sampled)",
        IN_DOMAIN.load(Ordering::Relaxed)
    );
    assert!(valid > 4_000, "the generator must mostly produce valid states");
}

/// The gains compared: the paper's law on taut's nominal plant and taut's law.
fn gains(which: bool) -> RsmcGains {
    if which { RsmcGains::paper(TAUT_PLANT) } else { TAUT_GAINS }
}

static COMPARED: AtomicU64 = AtomicU64::new(0);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// REQ-TEN-05: over 100 steps of a random tension walk and a random ramping reference,
    /// the fixed-point force stays within `FORCE_TOLERANCE_ABS + FORCE_TOLERANCE_REL·|u|` of
    /// the f64 reference (outside the `sgn` guard band).
    #[test]
    fn fixed_rsmc_tracks_float_reference(
        which in any::<bool>(),
        fast in any::<bool>(),
        start in 0.0_f64..40.0,
        target in 5.0_f64..50.0,
        ramp in -20.0_f64..20.0,
        steps in proptest::collection::vec(-0.05_f64..0.05, 100),
    ) {
        // 0.1 ms only for the paper's law (taut's filter gain dt/(τ+dt) ≈ 0.012 at 0.1 ms is
        // quantised to 5 × 10⁻⁴ relative in Q15.16, which this bound does not cover).
        let period_us = if fast && which { 100 } else { 1_000 };
        let g = gains(which);
        let mut fixed = Rsmc::new(&g, period_us).unwrap();
        let mut float = RsmcReference::new(&g, period_us);
        let mut y = start;
        let dt = f64::from(period_us) * 1e-6;
        let mut y_d = target;
        // Both start from the same error, as `Rsmc::reset` does.
        let e0 = Kgf::from_bits(((y_d - y) * 65_536.0).round() as i32);
        fixed.reset(e0);
        float.e_prev = q(e0.to_bits());
        for (k, step) in steps.iter().enumerate() {
            y = (y + step).clamp(0.0, 60.0);
            y_d = (y_d + ramp * dt).clamp(0.0, 60.0);
            let y_bits = (y * 65_536.0).round() as i32;
            let yd_bits = (y_d * 65_536.0).round() as i32;
            let rate_bits = (ramp * 65_536.0).round() as i32;
            let r = Reference { tension: Kgf::from_bits(yd_bits), rate: KgfPerSecond::from_bits(rate_bits), accel: Q16::ZERO };
            let out = fixed.step(&r, Kgf::from_bits(y_bits), Saturation::None);
            let reference = float.step(q(yd_bits), q(rate_bits), 0.0, q(y_bits), Saturation::None);
            if (reference.surface.abs() < SGN_GUARD && which) || reference.force.abs() > FORCE_COMPARED_MAX {
                // Under sgn the two may pick opposite sides: resynchronise φ̂ and move on.
                continue;
            }
            let bound = FORCE_TOLERANCE_ABS + FORCE_TOLERANCE_REL * reference.force.abs();
            let error = (q(out.force.to_bits()) - reference.force).abs();
            prop_assert!(error <= bound, "REQ-TEN-05: paper={which} fast={fast} step {k}: fixed {} vs float {} (error {error}, bound {bound})", q(out.force.to_bits()), reference.force);
            COMPARED.fetch_add(1, Ordering::Relaxed);
        }
        if COMPARED.load(Ordering::Relaxed) % 10_000 < 300 {
            println!("fixed_rsmc_tracks_float_reference: {} steps compared so far", COMPARED.load(Ordering::Relaxed));
        }
    }
}

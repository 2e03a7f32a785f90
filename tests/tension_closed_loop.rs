//! Closed-loop tests of taut's tension controller on the digital twin (REQ-TEN-07,
//! REQ-CAL-05): a representative subset of Monte-Carlo scenarios of the original twin
//! (`TwinConfig::sample`: soft badminton to stiff polyester, low and high targets; taut's own
//! board), each calibrated by the machine's own 4-point calibration on the bench, asserting
//! the accuracy with a margin, and that taut beats the paper's two laws on the same
//! scenarios.
#![allow(
    clippy::float_arithmetic,
    clippy::print_stdout,
    clippy::indexing_slicing,
    clippy::expect_used,
    reason = "test figures in f64 over recorded traces"
)]

use taut::cli::ControllerArg;
use taut::report::accuracy::controller_config;
use taut::report::{
    Metrics, ORACLE_LIMIT_MS, PULL_MS, Scenario, commissioned_calibration, draw_target, metrics,
    pull_trace, scenario_seed,
};
use taut_core::sense::calibration::Calibration;
use taut_core::tension::ControllerConfig;
use taut_sim::{TwinConfig, bang_bang_reach_time};

/// The three controllers, by report name.
const CONTROLLERS: [(&str, ControllerArg); 3] = [
    ("taut", ControllerArg::Taut),
    ("paper_rsmc", ControllerArg::PaperRsmc),
    ("pd", ControllerArg::Pd),
];

/// Scenario `index` of the original Monte-Carlo twin, seed 1.
fn scenario(index: u64) -> Scenario {
    let seed = scenario_seed(1, index);
    let twin = TwinConfig::sample(seed);
    let target = draw_target(seed, twin.string.kind);
    Scenario::on(index, twin, target)
}

/// Scenarios of `report accuracy --seed 1` covering every string family and the target
/// range (8.2 to 34.4 kgf).
const SUBSET: [u64; 6] = [0, 1, 4, 5, 13, 14];

/// Every controller's figures on every scenario of the subset.
fn run_subset() -> Vec<[Metrics; 3]> {
    SUBSET
        .iter()
        .map(|&index| {
            let scenario = scenario(index);
            let calibration = commissioned_calibration(&scenario.twin).expect("calibrated");
            let t_min = bang_bang_reach_time(&scenario.twin, scenario.target_kgf, ORACLE_LIMIT_MS);
            let mut out: [Metrics; 3] = Default::default();
            for (slot, (name, which)) in out.iter_mut().zip(CONTROLLERS) {
                let config = controller_config(which);
                let trace = pull_trace(&scenario, &config, calibration, PULL_MS).expect("bench");
                *slot = metrics(&trace, scenario.target_kgf, t_min);
                println!(
                    "scenario {index} ({} kgf, {}), {name}: {slot:?}",
                    scenario.target_kgf,
                    scenario.twin.string.kind.name()
                );
            }
            out
        })
        .collect()
}

#[test]
fn taut_holds_tension_on_representative_scenarios() {
    let runs = run_subset();
    for (index, m) in SUBSET.iter().zip(&runs) {
        let taut = &m[0];
        assert!(taut.failure.is_none(), "scenario {index}: {:?}", taut.failure);
        assert!(taut.hold_error_kgf <= 0.1, "scenario {index}: hold error {}", taut.hold_error_kgf);
        assert!(taut.overshoot_kgf <= 0.15, "scenario {index}: overshoot {}", taut.overshoot_kgf);
        let ratio = taut.settle_ratio.unwrap_or(f64::INFINITY);
        assert!(ratio <= 1.3, "scenario {index}: ratio {ratio}");
        assert!(taut.peak_current_a <= 12.0, "scenario {index}: current {}", taut.peak_current_a);
        assert!(taut.bus_peak_v <= 40.0, "scenario {index}: bus {} V", taut.bus_peak_v);
    }
    // Better than both of the paper's laws on the same scenarios, in the worst case over
    // the subset: hold error, overshoot, chattering.
    let worst = |which: usize, f: fn(&Metrics) -> f64| {
        runs.iter().map(|m| f(&m[which])).fold(0.0_f64, f64::max)
    };
    for (figure, f) in [
        ("hold error", (|m: &Metrics| m.hold_error_kgf) as fn(&Metrics) -> f64),
        ("overshoot", |m: &Metrics| m.overshoot_kgf),
        ("chattering", |m: &Metrics| m.chattering),
    ] {
        let taut = worst(0, f);
        for (which, (name, _)) in CONTROLLERS.iter().enumerate().skip(1) {
            let baseline = worst(which, f);
            assert!(taut < baseline, "{figure}: taut {taut} not better than {name} {baseline}");
        }
    }
}

#[test]
fn calibration_removes_the_sensor_offset() {
    // Uncorrected, the twin's load cell reads ≈ 0.75 kgf low above 5 kgf (low-load deficit);
    // after the 4-point calibration the hold error against the true tension is small.
    let scenario = scenario(5);
    let taut = ControllerConfig::TAUT;
    let identity = pull_trace(&scenario, &taut, Calibration::IDENTITY, 8_000).expect("bench");
    let calibrated = commissioned_calibration(&scenario.twin).expect("calibrated");
    let fitted = pull_trace(&scenario, &taut, calibrated, 8_000).expect("bench");
    let final_error = |trace: &[taut_sim::bench::ControllerRow]| {
        let tail = &trace[trace.len() - 1_000..];
        tail.iter().map(|s| s.truth.tension_kgf - scenario.target_kgf).sum::<f64>() / 1_000.0
    };
    let (raw, corrected) = (final_error(&identity), final_error(&fitted));
    println!(
        "mean error over the last second: identity {raw:.3} kgf, calibrated {corrected:.3} kgf"
    );
    assert!(raw.abs() > 0.3, "the uncorrected sensor should be visibly off ({raw})");
    assert!(corrected.abs() < 0.05, "calibrated error {corrected}");
}

/// REQ-ID-06: a rotor four times the nominal inertia (twice past the family's 2×) braked with
/// the plan its own take-up identified. Planned at the configured 1 200 mm/s² the carriage
/// cannot brake that hard (≈ 820 mm/s² at the current limit), the braking falls behind its
/// parabola and the pull overshoots by ≈ 0.75 kgf (scenario 6 of
/// `report robustness --axes inertia` with the span widened to 0.25–4×, before REQ-ID-06);
/// identified from the take-up (≈ 600 mm/s², planned at 840) it stays within 0.1 kgf, and the
/// nominal machine is unchanged.
#[test]
fn a_heavy_rotor_is_braked_with_the_deceleration_its_take_up_identified() {
    use taut_sim::{Axis, StringKind};
    let overshoot = |inertia_scale: f64| {
        let mut twin = TwinConfig::on_axis(Axis::Inertia, 0.5, StringKind::TennisPolyester);
        twin.motor.rotor_inertia_kg_m2 *= inertia_scale;
        twin.mechanics.gear_inertia_kg_m2 *= inertia_scale;
        let scenario = Scenario::on(6, twin, 19.4);
        let calibration = commissioned_calibration(&scenario.twin).expect("calibrated");
        let trace =
            pull_trace(&scenario, &ControllerConfig::TAUT, calibration, 2_500).expect("bench");
        assert!(trace.iter().all(|r| r.truth.drive_fault.is_none()), "a drive fault");
        let peak = trace.iter().map(|r| r.truth.tension_kgf).fold(0.0, f64::max);
        println!("inertia ×{inertia_scale}: true peak {peak:.3} kgf for {}", scenario.target_kgf);
        peak - scenario.target_kgf
    };
    let nominal = overshoot(1.0);
    let heavy = overshoot(4.0);
    assert!(nominal < 0.05, "nominal overshoot {nominal}");
    assert!(heavy < 0.1, "overshoot at 4× the inertia {heavy}");
}

/// REQ-ID-07: a gripper outboard of the load cell reads its inertial force off the string's
/// pull while the carriage brakes; the take-up identifies it and the braking adds it back.
/// Soft badminton string (the braking parabola is longest there) to 8.5 kgf with grippers
/// from none to 3 kg (twice the family's heaviest), the overshoot taken over the tension the
/// pull then holds (so the calibration's own error does not hide it). Without REQ-ID-07 the
/// 1.5 kg gripper overshot by 0.040 kgf and the 3 kg one by 0.137; compensated, 0.005 and
/// 0.045 (none and 0.5 kg: 0.006 and 0.004 either way). Since REQ-TEN-19 the 3 kg gripper —
/// outside the family — overshoots 0.082: this soft string's stiffness lifts the hold's
/// observer gain to ≈ 0.07, and after the carriage stops the heavy gripper still rings on the
/// load cell; the family's grippers (≤ 1.5 kg) are unchanged at 0.005. The bound past the
/// family is the overshoot's goal maximum, 0.1 kgf.
#[test]
fn a_heavy_gripper_does_not_overshoot_a_soft_string() {
    use taut_sim::{Axis, StringKind};
    for (index, grams) in [0_u32, 500, 1_500, 3_000].into_iter().enumerate() {
        let mut twin = TwinConfig::on_axis(Axis::GripperMass, 0.5, StringKind::BadmintonSoft);
        twin.mechanics.gripper.mass_kg = f64::from(grams) / 1_000.0;
        let scenario = Scenario::on(index as u64, twin, 8.5);
        let calibration = commissioned_calibration(&scenario.twin).expect("calibrated");
        let trace =
            pull_trace(&scenario, &ControllerConfig::TAUT, calibration, 2_500).expect("bench");
        assert!(trace.iter().all(|r| r.truth.drive_fault.is_none()), "a drive fault");
        let peak = trace.iter().map(|r| r.truth.tension_kgf).fold(0.0, f64::max);
        let tail = &trace[trace.len() - 500..];
        let held = tail.iter().map(|r| r.truth.tension_kgf).sum::<f64>() / 500.0;
        let overshoot = peak - held;
        println!(
            "gripper {grams} g: true peak {peak:.3} kgf, held {held:.3}, overshoot {overshoot:.3}"
        );
        let allowed = if grams <= 1_500 { 0.02 } else { 0.1 };
        assert!(overshoot < allowed, "gripper {grams} g: overshoot {overshoot:.3} kgf");
    }
}

/// REQ-TEN-22, REQ-TEN-23: a string with internal friction is many times stiffer just after
/// every change of direction than the stiffness identified while it was drawn out, and a hold
/// that lets go of an excess turns the carriage back into that stiffness. The family's
/// machine 2 of seed 1 (a back-driving ball screw, synthetic gut at 30.2 kgf) given a 3 %
/// hysteresis: a law free to let go rang at ≈ 12 Hz, ±0.5 kgf, for the rest of the hold
/// (hold error 0.82 kgf; governed, 0.45 and 0.25 kgf peak to peak over the last five
/// seconds). Held at the string's pull, the carriage never turns back and the hold is as
/// calm as without the hysteresis: within 0.06 kgf, 0.1 kgf peak to peak.
#[test]
fn a_string_with_hysteresis_is_held_without_ringing() {
    let run = |hysteresis: f64| {
        let mut scenario = Scenario::new(1, 2, taut::cli::SensingArg::Family);
        scenario.twin.string.hysteresis_fraction = hysteresis;
        let calibration = commissioned_calibration(&scenario.twin).expect("calibrated");
        let trace =
            pull_trace(&scenario, &ControllerConfig::TAUT, calibration, PULL_MS).expect("bench");
        let end = trace.last().map_or(0.0, |row| row.t_s);
        let last: Vec<f64> = trace
            .iter()
            .filter(|row| row.t_s >= end - 5.0)
            .map(|row| row.truth.tension_kgf)
            .collect();
        let p2p = last.iter().copied().fold(f64::MIN, f64::max)
            - last.iter().copied().fold(f64::MAX, f64::min);
        let m = metrics(&trace, scenario.target_kgf, None);
        println!("hysteresis {hysteresis}: {m:?}, last 5 s peak to peak {p2p:.3} kgf");
        (m, p2p)
    };
    let (with, ring) = run(0.03);
    assert!(ring < 0.1, "the ring goes on: {ring:.3} kgf peak to peak");
    assert!(with.hold_error_kgf < 0.06, "{with:?}");
    let (without, calm) = run(0.0);
    assert!(without.hold_error_kgf < 0.05 && calm < 0.1, "{without:?} {calm:.3}");
}

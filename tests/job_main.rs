//! The main job on the twin (`taut` with no subcommand): a whole cycle through the keys,
//! decided by the machine, measured on the twin's true tension.
//!
//! One commissioning session (calibration + previous job's settings) is shared by the jobs
//! on the nominal machine, as `run` would do it for each; each job is ≈ 10–20 s of machine
//! time (under a second of test time).
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::float_arithmetic,
    clippy::print_stdout,
    reason = "a test: a panic is how it reports, and it prints the figures it checked"
)]

use std::sync::OnceLock;

use taut::cli::parse_tension;
use taut::job::summary::{Summary, entered, panel_kgf};
use taut::job::{CycleOptions, CycleRun, run};
use taut::plot::Content;
use taut_core::machine::{FaultCode, MachineState};
use taut_core::sense::calibration::{
    CALIBRATION_POINTS, CALIBRATION_READINGS, CALIBRATION_TARGETS,
};
use taut_core::settings::Unit;
use taut_sim::StringKind;
use taut_sim::bench::{Commissioning, Row, commission, factory_config, kgf};

/// Margin on the true tension while holding (the paper's accuracy is 0.1 kgw; the
/// calibration's own error counts).
const HOLD_MARGIN_KGF: f64 = 0.15;

fn commissioning() -> &'static Commissioning {
    static ONCE: OnceLock<Commissioning> = OnceLock::new();
    ONCE.get_or_init(|| {
        let config = factory_config(&CycleOptions::default().twin_config());
        commission(&config, true, &mut |_| {}).expect("commissioning")
    })
}

fn job(options: CycleOptions) -> CycleRun {
    let run = run(&options, Some(commissioning()), &mut |_| {}).expect("the job runs");
    println!("{}", taut::job::summary::table(&run));
    run
}

fn quick() -> CycleOptions {
    CycleOptions { hold_ms: 3_000, ..CycleOptions::default() }
}

fn summary(run: &CycleRun) -> Summary {
    taut::job::summary::summary(run)
}

/// The hold from 1 s after the holding lamp to the release, ms.
fn hold_window(run: &CycleRun) -> (u64, u64) {
    let holding = entered(run, MachineState::Holding, 0).expect("holding");
    let releasing = entered(run, MachineState::Releasing, holding).expect("released");
    (holding + 1_000, releasing)
}

/// The rows of the hold from 1 s after the holding lamp to the release.
fn hold_rows(run: &CycleRun) -> Vec<&Row> {
    let (from, to) = hold_window(run);
    run.rows.iter().filter(|r| r.t_ms >= from && r.t_ms < to).collect()
}

/// The panel's readings over the hold: the median within 0.1 kgf of `target`, 95 % of them
/// within 0.2 kgf (the rest are switching spikes on the per-tick reading).
fn assert_panel_reads(run: &CycleRun, target: f64) {
    let (from, to) = hold_window(run);
    let rows: Vec<usize> = (0..run.rows.len())
        .filter(|&i| run.rows[i].t_ms >= from && run.rows[i].t_ms < to)
        .collect();
    let mut shown: Vec<f64> = rows.iter().filter_map(|&i| panel_kgf(run, i)).collect();
    assert!(shown.len() + 10 >= rows.len(), "the panel shows a number while holding");
    shown.sort_by(f64::total_cmp);
    let median = shown[shown.len() / 2];
    let close = shown.iter().filter(|v| (*v - target).abs() <= 0.2).count();
    println!(
        "panel while holding: median {median:.2} kgf, {close}/{} within 0.2 kgf, range {:.2}–{:.2}",
        shown.len(),
        shown[0],
        shown[shown.len() - 1]
    );
    assert!((median - target).abs() <= 0.1, "median {median}");
    assert!(close * 100 >= shown.len() * 95, "{close} of {}", shown.len());
}

fn states(run: &CycleRun) -> Vec<MachineState> {
    run.transitions.iter().map(|t| t.state).collect()
}

#[test]
fn commissioning_stores_a_calibration_and_the_previous_job() {
    let c = commissioning();
    let record = c.record;
    let points = record.calibration.expect("a calibration is stored");
    assert_eq!(
        c.gauge_readings.len(),
        CALIBRATION_READINGS,
        "one gauge reading per point and pass"
    );
    // REQ-CAL-06: each stored point is the mean of its two passes' readings.
    let (first, second) = c.gauge_readings.split_at(CALIBRATION_POINTS);
    let means = first.iter().zip(second).map(|(a, b)| (a + b) / 2.0);
    for ((point, gauge), target) in points.iter().zip(means).zip(CALIBRATION_TARGETS) {
        let (reference, target) = (kgf(point.reference), kgf(target));
        // The operator keyed the gauge in to 0.1 kgf; the machine pulled the raw reading to
        // about the point's target, and the uncalibrated sensor reads ≈ 0.7 kgf low there.
        assert!((reference - gauge).abs() <= 0.051, "{reference} vs gauge {gauge}");
        assert!((reference - target).abs() < 1.5, "point {target}: reference {reference}");
    }
    assert_eq!(record.settings, taut_sim::operator::previous_job());
    assert_eq!(record.counters.pulls, 0);
}

#[test]
fn the_default_job_reaches_holds_and_releases_home_without_a_fault() {
    let run = job(quick());
    let summary = summary(&run);
    assert!(run.completed, "the cycle completes");
    assert!(summary.faults.is_empty(), "{:?}", summary.faults);
    // The machine went through the boot sequence and the cycle, in order.
    let expected = [
        MachineState::SelfTest,
        MachineState::MotorTest,
        MachineState::Homing,
        MachineState::CalibrationWindow,
        MachineState::Ready,
        MachineState::Pulling,
        MachineState::Holding,
        MachineState::Releasing,
        MachineState::Ready,
    ];
    assert_eq!(states(&run), expected);
    // Held at 25 kgf on the true tension.
    let hold = hold_rows(&run);
    assert!(hold.len() >= 1_900, "held ≈ 2 s after the first second: {}", hold.len());
    for row in &hold {
        assert!((row.truth.tension_kgf - 25.0).abs() <= HOLD_MARGIN_KGF, "{row:?}");
    }
    // The panel showed the tension it held (its per-tick reading includes the load cell's
    // switching spikes: a few ticks in a hundred are off by up to ≈ 0.7 kgf).
    assert_panel_reads(&run, 25.0);
    // Constant pull: the carriage followed the string's creep forward.
    assert!(summary.creep_mm.expect("held") > 0.1, "creep {:?}", summary.creep_mm);
    assert!(summary.overshoot_kgf <= 0.15, "overshoot {}", summary.overshoot_kgf);
    // Released back home: the string is slack and the carriage rests on the home switch.
    let last = run.rows.last().expect("rows");
    assert!(last.truth.tension_kgf < 0.05 && last.truth.carriage_mm <= 0.0, "{last:?}");
    // The machine logged the pull; its encoder count matches the string really drawn.
    let pull = run.pull.expect("the pull is logged");
    assert_eq!(pull.target.to_kgf(), taut_core::units::Kgf::from_int(25));
    let counted = f64::from(summary.string_used_mm.expect("counted"));
    let drawn = summary.true_string_mm.expect("drawn");
    assert!(drawn > 30.0 && (counted - drawn).abs() <= 1.0 + 0.02 * drawn, "{counted} vs {drawn}");
    assert!(summary.time_to_tension_s.expect("reached") < 10.0);
}

#[test]
fn a_pound_set_point_is_keyed_and_held_in_pounds() {
    let options = CycleOptions { set_point: parse_tension("55lb").unwrap(), ..quick() };
    let run = job(options);
    assert!(run.completed);
    assert_eq!(run.settings.set_point().unit(), Unit::Pounds);
    assert_eq!(run.settings.set_point().tenths(), 550);
    let summary = summary(&run);
    assert_eq!(summary.set_point, "55.0 lb");
    let holding = hold_rows(&run);
    assert!(holding.iter().all(|r| r.outputs.leds.lb && !r.outputs.leds.kg), "the lb lamp is lit");
    let target = 55.0 / 2.204_622_6;
    assert!((summary.target_kgf - target).abs() < 0.01, "{}", summary.target_kgf);
    for row in hold_rows(&run) {
        assert!((row.truth.tension_kgf - target).abs() <= HOLD_MARGIN_KGF, "{row:?}");
    }
    // The panel reads in pounds (converted back to kgf in the record): ≈ 55.0 lb.
    assert_panel_reads(&run, target);
}

#[test]
fn pre_stretch_peaks_above_the_set_tension_then_holds_it() {
    let options = CycleOptions { pre_stretch_percent: 10, ..quick() };
    let run = job(options);
    assert!(run.completed);
    let summary = summary(&run);
    assert!((summary.peak_target_kgf - 27.5).abs() < 0.01);
    assert!(
        summary.peak_tension_kgf > 27.0 && summary.peak_tension_kgf < 27.5 + 0.3,
        "peak {}",
        summary.peak_tension_kgf
    );
    for row in hold_rows(&run) {
        assert!((row.truth.tension_kgf - 25.0).abs() <= HOLD_MARGIN_KGF, "{row:?}");
    }
    // Without pre-stretch the peak stays at the set tension.
    let plain = taut::job::summary::summary(&job(quick()));
    assert!(plain.peak_tension_kgf < 25.0 + HOLD_MARGIN_KGF + 0.1, "{}", plain.peak_tension_kgf);
}

#[test]
fn a_knot_pull_lights_the_knot_lamp_and_holds_the_boosted_tension() {
    let options = CycleOptions { knot_percent: Some(15), ..quick() };
    let run = job(options);
    assert!(run.completed);
    let summary = summary(&run);
    assert!((summary.target_kgf - 28.75).abs() < 0.01, "{}", summary.target_kgf);
    for row in hold_rows(&run) {
        assert!((row.truth.tension_kgf - 28.75).abs() <= HOLD_MARGIN_KGF, "{row:?}");
    }
    let pull = run.pull.expect("logged");
    assert!((kgf(pull.target.to_kgf()) - 28.75).abs() < 0.01);
    // The operator switched knot mode on (Function held); the lamp stays lit through the pull.
    let pulling = entered(&run, MachineState::Pulling, 0).expect("pulled");
    let released = entered(&run, MachineState::Releasing, pulling).expect("released");
    assert!(
        run.rows
            .iter()
            .filter(|r| r.t_ms > pulling && r.t_ms < released)
            .all(|r| r.outputs.leds.knot)
    );
    assert!(!job(quick()).rows.iter().any(|r| r.outputs.leds.knot), "no knot lamp on a main pull");
}

#[test]
fn a_higher_speed_pulls_to_tension_sooner() {
    let time = |speed| {
        let run = job(CycleOptions { speed, hold_ms: 1_000, ..CycleOptions::default() });
        assert!(run.completed);
        assert_eq!(run.settings.speed().get(), speed, "the operator keyed the speed in");
        summary(&run).time_to_tension_s.expect("reached")
    };
    let (slow, fast) = (time(2), time(9));
    println!("time to tension: speed 2 {slow:.3} s, speed 9 {fast:.3} s");
    assert!(fast < slow * 0.8, "speed 9 {fast} s vs speed 2 {slow} s");
}

#[test]
fn other_speeds_and_strings_complete_the_cycle() {
    for (string, speed, tension) in
        [(StringKind::TennisPolyester, 9, "24"), (StringKind::BadmintonSoft, 2, "11.5")]
    {
        let options = CycleOptions {
            string,
            speed,
            set_point: parse_tension(tension).unwrap(),
            hold_ms: 2_000,
            ..CycleOptions::default()
        };
        let run = job(options);
        assert!(run.completed, "{string}");
        assert_eq!(run.settings.speed().get(), speed);
        let target: f64 = tension.parse().unwrap();
        for row in hold_rows(&run) {
            assert!((row.truth.tension_kgf - target).abs() <= HOLD_MARGIN_KGF, "{string}: {row:?}");
        }
    }
}

#[test]
fn without_a_string_the_machine_faults_and_the_operator_stops() {
    let options = CycleOptions { string: StringKind::NoString, ..quick() };
    let run = job(options);
    assert!(!run.completed);
    let summary = summary(&run);
    assert_eq!(summary.faults, vec![FaultCode::NoString]);
    assert!(matches!(run.transitions.last().map(|t| t.state), Some(MachineState::Fault(_))));
    assert!(run.pull.is_none());
}

#[test]
fn without_the_calibration_the_uncorrected_sensor_shows_in_the_true_tension() {
    let config = factory_config(&CycleOptions::default().twin_config());
    let bare = commission(&config, false, &mut |_| {}).expect("commissioning without calibration");
    assert!(bare.record.calibration.is_none());
    let options = CycleOptions { calibrate: false, ..quick() };
    let run = run(&options, Some(&bare), &mut |_| {}).expect("runs");
    assert!(run.completed);
    // The tared sensor reads ≈ 0.75 kgf low at 25 kgf (the paper's poor low-load
    // linearity): the machine holds its reading at 25.0 and the string carries more.
    let hold = hold_rows(&run);
    let mean = hold.iter().map(|r| r.truth.tension_kgf).sum::<f64>() / hold.len() as f64;
    println!("uncalibrated: mean true tension while holding {mean:.3} kgf");
    assert!(mean > 25.3, "{mean}");
}

#[test]
fn the_plot_has_every_panel_and_the_state_timeline() {
    let run = job(CycleOptions { hold_ms: 1_000, ..CycleOptions::default() });
    let figure = taut::job::figure::figure(&run);
    let svg = figure.to_svg();
    assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
    let mut labels: Vec<String> = Vec::new();
    for panel in &figure.panels {
        labels.push(panel.y_label.clone());
        if let Content::Lines(series) = &panel.content {
            labels.extend(series.iter().map(|s| s.label.clone()));
        }
    }
    for label in [
        "tension (kgf)",
        "carriage (mm)",
        "duty (%, − = release)",
        "winding current (A)",
        "state",
        "hold: tension − target (kgf), ±0.2",
        "true tension",
        "panel reading",
    ] {
        assert!(labels.iter().any(|l| l == label), "missing {label}");
    }
    for label in [">holding<", ">pulling<", ">self/motor test<"] {
        assert!(svg.contains(label), "missing {label}");
    }
    // One band per state entered.
    assert_eq!(svg.matches("<title>").count(), run.transitions.len());
    let json = taut::job::summary::json(&run);
    assert_eq!(json["completed"], true);
    assert_eq!(json["faults"].as_array().map(Vec::len), Some(0));
    assert!(json["hold_error_max_kgf"].as_f64().unwrap() <= HOLD_MARGIN_KGF);
}

//! `taut report accuracy`: a Monte-Carlo of pulls on the twin, three controllers on the same
//! scenarios, with the figures the issue defines.
//!
//! # Per scenario
//!
//! A scenario is a [`TwinConfig::sample`] (string kind and stiffness, slack, creep,
//! friction ±50 %, efficiency, motor spread, sensor gain/offset/non-linearity/noise/spikes,
//! Hall placement and glitches) plus a target drawn uniformly from 8–35 kgf, both from the
//! scenario's seed. First the paper's 4-point calibration is simulated against the twin's
//! reference gauge (σ = 0.02 kgf) ([`crate::sil::calibrate`]); its [`Calibration`] is then
//! used by every controller on that scenario — so the calibration's own error counts in the
//! hold error, as on a real machine. Each controller then pulls (speed 9, no pre-stretch)
//! on a fresh twin of the same scenario for [`PULL_MS`]. Metrics ([`Metrics`]):
//!
//! - **settle time**: Start to the first moment after which the *measured* tension — the
//!   tension the controller acted on and the machine shows ([`crate::sil::Sample::estimate`]:
//!   the calibrated reading through the controller's own spike filtering; the paper's laws
//!   get the median of five, taut adds its clip and observer) — stays within 0.1 kgf of the
//!   target for 0.5 s;
//! - **hold error**: the largest |true tension − target| from 1 s to 10 s after settling;
//! - **overshoot**: the largest true tension above the target before the hold window;
//! - **pull-time ratio**: settle time over `t_min`, the time the bang-bang oracle
//!   ([`oracle_reach_time`]: full duty on the same scenario) needs to first reach the target.
//!   Full duty from rest would draw the stall current (≈ 28 A) and trip the drive's 12 A
//!   overcurrent latch, so the oracle's duty is capped at what drives
//!   [`ORACLE_CURRENT_LIMIT`] at the measured speed — the fastest pull the drive permits
//!   (on a machine whose low winding resistance trips the latch even so, the next lower
//!   cap of [`ORACLE_FALLBACK_LIMITS`]);
//! - **chattering**: total variation of the signed duty per second over the hold window;
//! - **peak current**: the largest phase current of the run;
//! - **peak bus voltage**: the highest DC bus voltage of the run (braking regenerates into
//!   the bus capacitance; see `taut_sim::twin`);
//! - **failed**: never settled, or a drive fault latched. Scenarios whose target the
//!   bang-bang oracle itself cannot reach (the carriage meets the end of travel first: a
//!   soft badminton string with long slack pulled to 35 kgf) are counted as failed for every
//!   controller and reported separately as **unreachable** (table footnote, JSON key
//!   `unreachable`).

use std::sync::atomic::{AtomicUsize, Ordering};

use serde_json::{Value, json};
use taut_core::drive::{Direction, DriveCommand};
use taut_core::io::Outputs;
use taut_core::sense::calibration::Calibration;
use taut_core::tension::motor::{DutyMap, ForceToDuty, MotorModel, SpeedEstimator};
use taut_core::tension::{ControllerConfig, PullKind, PullSettings};
use taut_core::units::{Amps, Kgf, Seconds};
use taut_sim::{SimRng, Twin, TwinConfig};

use crate::plot::{Figure, Panel, Series};
use crate::sil::{Rig, Sample, calibrate, to_kgf};

/// Ticks simulated per pull: settle (≤ 4 s) + 10 s of hold + margin.
pub const PULL_MS: u32 = 16_000;
/// Band and duration of the settling criterion.
pub const SETTLE_BAND_KGF: f64 = 0.1;
/// How long the measured tension must stay in the band, s.
pub const SETTLE_HOLD_S: f64 = 0.5;
/// Hold window after settling, s.
pub const HOLD_WINDOW_S: (f64, f64) = (1.0, 10.0);

/// The three controllers, by report name.
pub const CONTROLLERS: [(&str, ControllerConfig); 3] = [
    ("taut", ControllerConfig::TAUT),
    ("paper_rsmc", ControllerConfig::PAPER_RSMC),
    ("pd", ControllerConfig::PD),
];

/// One scenario's figures for one controller.
#[derive(Clone, Copy, Debug, Default)]
pub struct Metrics {
    /// Settle time, s (`None` = never settled).
    pub settle_s: Option<f64>,
    /// Largest |true − target| in the hold window, kgf.
    pub hold_error_kgf: f64,
    /// Largest true tension above the target before the hold window, kgf.
    pub overshoot_kgf: f64,
    /// Settle time over the oracle's reach time.
    pub pull_time_ratio: f64,
    /// Total variation of duty per second in the hold window.
    pub chattering: f64,
    /// Largest phase current, A.
    pub peak_current_a: f64,
    /// Highest DC bus voltage, V.
    pub bus_peak_v: f64,
    /// Failed (never settled or faulted).
    pub failed: bool,
}

/// A scenario: twin and target.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// The machine.
    pub twin: TwinConfig,
    /// The target tension, kgf (a multiple of 0.1).
    pub target_kgf: f64,
}

impl Scenario {
    /// Scenario `index` of the run seeded `seed`.
    #[must_use]
    pub fn new(seed: u64, index: u64) -> Self {
        let scenario_seed = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(index);
        let twin = TwinConfig::sample(scenario_seed);
        let mut rng = SimRng::substream(scenario_seed, 0x7A26);
        let target_kgf = (rng.range(8.0, 35.0) * 10.0).round() / 10.0;
        Self { twin, target_kgf }
    }
}

/// The oracle's current cap: 11 A, just under the drive's 12 A latch.
pub const ORACLE_CURRENT_LIMIT: Amps = Amps::from_int(11);

/// The caps the oracle falls back to, in turn, when a machine whose winding resistance is
/// below the nominal model's trips the 12 A latch at 11 A: 10 A, then 9 A.
pub const ORACLE_FALLBACK_LIMITS: [Amps; 2] = [Amps::from_int(10), Amps::from_int(9)];

/// The bang-bang oracle: full duty (current-capped, see the module docs) from Start until
/// the true tension first reaches `target_kgf`; the time in s, or `None` within `limit_ms`.
/// The cap is computed from the nominal motor model, so on a machine whose resistance is at
/// the low end of its spread the 11 A cap can reach the drive's 12 A latch: the oracle then
/// pulls again with the next lower cap ([`ORACLE_FALLBACK_LIMITS`]) — the fastest pull the
/// drive permits on that machine. `None` means the target is out of reach (the end of
/// travel first) or every cap tripped.
#[must_use]
pub fn oracle_reach_time(config: &TwinConfig, target_kgf: f64, limit_ms: u32) -> Option<f64> {
    core::iter::once(ORACLE_CURRENT_LIMIT)
        .chain(ORACLE_FALLBACK_LIMITS)
        .find_map(|cap| oracle_pull(config, target_kgf, limit_ms, cap).ok())
        .flatten()
}

/// One oracle pull with current cap `cap`: `Ok(time)` (or `Ok(None)`, not reached within
/// `limit_ms`), `Err(())` if the drive tripped.
fn oracle_pull(
    config: &TwinConfig,
    target_kgf: f64,
    limit_ms: u32,
    cap: Amps,
) -> Result<Option<f64>, ()> {
    let mut twin = Twin::new(config);
    let map = ForceToDuty::new(&MotorModel::PAPER, DutyMap::BackEmf { current_limit: cap })
        .expect("oracle map");
    let mut speed = SpeedEstimator::new(1_000, Seconds::from_milli(2)).expect("speed estimator");
    for tick in 1..=limit_ms {
        let inputs = twin.inputs();
        let v = speed.update(inputs.drive.steps);
        let (command, _) = map.command(Kgf::MAX, v);
        let command = match command {
            DriveCommand::Drive { duty, .. } => {
                DriveCommand::Drive { direction: Direction::Pull, duty }
            }
            DriveCommand::Coast => DriveCommand::Coast,
        };
        twin.apply(&Outputs { drive: command, ..Outputs::default() });
        twin.advance_tick();
        let truth = twin.truth();
        if truth.drive_fault.is_some() {
            return Err(());
        }
        if truth.tension_kgf >= target_kgf {
            return Ok(Some(f64::from(tick) / 1000.0));
        }
    }
    Ok(None)
}

/// Runs one pull with `config` and `calibration`; returns the trace.
#[must_use]
pub fn pull_trace(
    scenario: &Scenario,
    config: &ControllerConfig,
    calibration: Calibration,
    ms: u32,
) -> Vec<Sample> {
    let mut rig = Rig::new(&scenario.twin, config, calibration);
    let settings =
        PullSettings::default().with_tension(to_kgf(scenario.target_kgf)).expect("target in range");
    rig.start(&settings, PullKind::Main);
    let mut trace = Vec::with_capacity(ms as usize);
    rig.run(ms, &mut trace);
    trace
}

/// The figures of one trace against `target` and the oracle's `t_min`.
#[must_use]
pub fn metrics(trace: &[Sample], target: f64, t_min: Option<f64>) -> Metrics {
    let measured: Vec<f64> = trace.iter().map(|s| s.estimate).collect();
    let hold_ticks = (SETTLE_HOLD_S * 1000.0) as usize;
    // The first index from which the measured tension stays in band for hold_ticks.
    let mut settle_index = None;
    let mut run_start = None;
    for (i, y) in measured.iter().enumerate() {
        if (y - target).abs() <= SETTLE_BAND_KGF {
            let start = *run_start.get_or_insert(i);
            if i + 1 - start >= hold_ticks {
                settle_index = Some(start);
                break;
            }
        } else {
            run_start = None;
        }
    }
    let fault = trace.iter().any(|s| s.fault);
    let peak_current_a = trace.iter().map(|s| s.peak_current).fold(0.0, f64::max);
    let bus_peak_v = trace.iter().map(|s| s.bus_peak).fold(0.0, f64::max);
    // A run that never settles is censored: its "settle time" is the run's length and its
    // hold window the run's last 9 s, so every figure stays a number; it counts as failed.
    let settled = settle_index.is_some();
    let run_end = trace.last().map_or(0.0, |s| s.t);
    let settle_s = match settle_index {
        Some(index) => trace[index].t,
        None => run_end - HOLD_WINDOW_S.1,
    };
    let window =
        |s: &&Sample| s.t >= settle_s + HOLD_WINDOW_S.0 && s.t <= settle_s + HOLD_WINDOW_S.1;
    let hold: Vec<&Sample> = trace.iter().filter(window).collect();
    let hold_complete = hold.last().is_some_and(|s| s.t >= settle_s + HOLD_WINDOW_S.1 - 0.01);
    let hold_error_kgf = hold.iter().map(|s| (s.tension - target).abs()).fold(0.0, f64::max);
    let overshoot_kgf = trace
        .iter()
        .filter(|s| s.t < settle_s + HOLD_WINDOW_S.0)
        .map(|s| s.tension - target)
        .fold(0.0, f64::max);
    let variation: f64 = hold.windows(2).map(|w| (w[1].duty - w[0].duty).abs()).sum();
    let chattering = variation / (HOLD_WINDOW_S.1 - HOLD_WINDOW_S.0);
    Metrics {
        settle_s: Some(if settled { settle_s } else { run_end }),
        hold_error_kgf,
        overshoot_kgf,
        pull_time_ratio: t_min.map_or(f64::NAN, |t| if settled { settle_s } else { run_end } / t),
        chattering,
        peak_current_a,
        bus_peak_v,
        failed: fault || !settled || !hold_complete,
    }
}

/// One scenario's outcome for the three controllers.
#[derive(Clone, Debug)]
pub struct ScenarioResult {
    /// The scenario index.
    pub index: u64,
    /// Target, kgf.
    pub target_kgf: f64,
    /// String kind name.
    pub string: &'static str,
    /// Oracle reach time, s.
    pub t_min: Option<f64>,
    /// The calibration's largest error over 8–35 kgf against the twin's true sensor, kgf
    /// (informational; `NaN` when the calibration was rejected).
    pub calibration_ok: bool,
    /// Metrics per controller, in the lineup's order ([`CONTROLLERS`] for the accuracy
    /// report, [`ablation_lineup`] for the ablation).
    pub metrics: Vec<Metrics>,
}

/// One controller of a report: its name, its configuration, and whether it pulls with the
/// scenario's 4-point calibration (or the identity: the uncalibrated sensor).
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// The row's name.
    pub name: &'static str,
    /// The controller.
    pub config: ControllerConfig,
    /// Pull with the simulated 4-point calibration (`false`: uncorrected sensor).
    pub calibrated: bool,
}

/// The accuracy report's lineup: [`CONTROLLERS`], all calibrated.
#[must_use]
pub fn accuracy_lineup() -> Vec<Entry> {
    CONTROLLERS.iter().map(|&(name, config)| Entry { name, config, calibrated: true }).collect()
}

/// taut with each of its improvements switched off in turn (`taut report ablation`): the
/// law's four (boundary layer, bounded adaptation, anti-windup, rate filter), the
/// back-EMF feed-forward of the voltage-drive plant, the profile's and estimator's (braking
/// approach, plant adaptation to the identified stiffness, observer, spike clip, slip
/// damping in the hold), and the 4-point calibration.
#[must_use]
pub fn ablation_lineup() -> Vec<Entry> {
    use taut_core::tension::controller::{LawConfig, ProfileConfig, TAUT_GAINS};
    use taut_core::tension::law::NominalPlant;
    use taut_core::units::Q16;
    let taut = ControllerConfig::TAUT;
    let law = |f: &dyn Fn(&mut taut_core::tension::law::RsmcGains)| {
        let mut gains = TAUT_GAINS;
        f(&mut gains);
        ControllerConfig { law: LawConfig::Rsmc(gains), ..taut }
    };
    let profile = |f: &dyn Fn(&mut ProfileConfig)| {
        let mut p = ProfileConfig::TAUT;
        f(&mut p);
        ControllerConfig { profile: p, ..taut }
    };
    // Without the back-EMF in the nominal plant (Ā = 2 s⁻¹, screw friction only) the law
    // neither feeds the reference's back-EMF forward nor expects the drive's damping.
    let no_back_emf = |gains: &mut taut_core::tension::law::RsmcGains| {
        gains.plant = NominalPlant { a_bar: Q16::const_from_int(2), ..gains.plant };
    };
    let entry = |name, config| Entry { name, config, calibrated: true };
    vec![
        entry("taut", taut),
        entry("sgn instead of boundary layer", law(&|g| g.improvements.boundary_layer = None)),
        entry("unbounded adaptation", law(&|g| g.improvements.bounded_adaptation = None)),
        entry("no anti-windup", law(&|g| g.improvements.anti_windup = None)),
        entry("raw error rate (no rate filter)", law(&|g| g.improvements.rate_filter = None)),
        entry("no back-EMF in the plant", law(&no_back_emf)),
        entry(
            "current-command duty map",
            ControllerConfig {
                duty_map: DutyMap::BackEmf {
                    current_limit: taut_core::tension::controller::CURRENT_LIMIT,
                },
                ..law(&no_back_emf)
            },
        ),
        entry("step set point (no braking approach)", profile(&|p| p.shaped = false)),
        entry("no plant adaptation", profile(&|p| p.adapt_plant = false)),
        entry("no observer", profile(&|p| p.observer_gain = None)),
        entry("no spike clip", profile(&|p| p.spike_clip = false)),
        entry("no slip damping (friction-aware hold)", profile(&|p| p.slip_damping = None)),
        Entry { name: "uncalibrated sensor", config: taut, calibrated: false },
    ]
}

/// Runs scenario `index` for every controller of the accuracy report.
#[must_use]
pub fn run_scenario(seed: u64, index: u64) -> ScenarioResult {
    run_scenario_with(seed, index, &accuracy_lineup())
}

/// Runs scenario `index` for every entry of `lineup` (one calibration and one oracle run
/// shared by all).
#[must_use]
pub fn run_scenario_with(seed: u64, index: u64, lineup: &[Entry]) -> ScenarioResult {
    let scenario = Scenario::new(seed, index);
    let calibration_run = calibrate(&scenario.twin);
    let calibration_ok = calibration_run.calibration.is_ok();
    let calibration = calibration_run.calibration.unwrap_or(Calibration::IDENTITY);
    let t_min = oracle_reach_time(&scenario.twin, scenario.target_kgf, 10_000);
    let metrics = lineup
        .iter()
        .map(|entry| {
            let correction = if entry.calibrated { calibration } else { Calibration::IDENTITY };
            let trace = pull_trace(&scenario, &entry.config, correction, PULL_MS);
            metrics(&trace, scenario.target_kgf, t_min)
        })
        .collect();
    ScenarioResult {
        index,
        target_kgf: scenario.target_kgf,
        string: scenario.twin.string.kind.name(),
        t_min,
        calibration_ok,
        metrics,
    }
}

/// Runs `count` scenarios of the accuracy report on `threads` threads, calling
/// `progress(done)` after each.
pub fn run_all(
    seed: u64,
    count: u64,
    threads: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> Vec<ScenarioResult> {
    run_lineup(seed, count, threads, progress, &accuracy_lineup())
}

/// Runs `count` scenarios for every entry of `lineup` on `threads` threads, calling
/// `progress(done)` after each.
pub fn run_lineup(
    seed: u64,
    count: u64,
    threads: usize,
    progress: &(dyn Fn(usize) + Sync),
    lineup: &[Entry],
) -> Vec<ScenarioResult> {
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let mut results: Vec<ScenarioResult> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads.max(1))
            .map(|_| {
                scope.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let index = next.fetch_add(1, Ordering::Relaxed) as u64;
                        if index >= count {
                            break;
                        }
                        mine.push(run_scenario_with(seed, index, lineup));
                        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
                    }
                    mine
                })
            })
            .collect();
        workers.into_iter().flat_map(|w| w.join().expect("worker")).collect()
    });
    results.sort_by_key(|r| r.index);
    results
}

/// The `p`-th percentile (0–100, nearest rank) of the finite values, or `NaN`.
#[must_use]
pub fn percentile(values: &[f64], p: f64) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * v.len() as f64).ceil().max(1.0) as usize;
    v[rank.min(v.len()) - 1]
}

/// Aggregated figures of one controller.
#[derive(Clone, Copy, Debug)]
pub struct Summary {
    /// p50 hold error, kgf.
    pub hold_error_p50_kgf: f64,
    /// p99 hold error, kgf.
    pub hold_error_p99_kgf: f64,
    /// Max hold error, kgf.
    pub hold_error_max_kgf: f64,
    /// p99 overshoot, kgf.
    pub overshoot_p99_kgf: f64,
    /// Median settle time, s.
    pub settle_time_p50_s: f64,
    /// Median pull-time ratio.
    pub pull_time_ratio_median: f64,
    /// Median chattering.
    pub chattering_p50: f64,
    /// Max peak current, A.
    pub peak_current_max_a: f64,
    /// Highest bus voltage, V.
    pub bus_peak_max_v: f64,
    /// Failed scenarios.
    pub failed: usize,
}

/// Aggregates controller `which` over `results`.
#[must_use]
pub fn summarize(results: &[ScenarioResult], which: usize) -> Summary {
    let all: Vec<&Metrics> = results.iter().map(|r| &r.metrics[which]).collect();
    // Every scenario counts (a failed one with its censored figures, see `metrics`).
    let of = |f: fn(&Metrics) -> f64| all.iter().map(|m| f(m)).collect::<Vec<f64>>();
    let hold = of(|m| m.hold_error_kgf);
    Summary {
        hold_error_p50_kgf: percentile(&hold, 50.0),
        hold_error_p99_kgf: percentile(&hold, 99.0),
        hold_error_max_kgf: percentile(&hold, 100.0),
        overshoot_p99_kgf: percentile(
            &all.iter().map(|m| m.overshoot_kgf).collect::<Vec<_>>(),
            99.0,
        ),
        settle_time_p50_s: percentile(&of(|m| m.settle_s.unwrap_or(f64::NAN)), 50.0),
        pull_time_ratio_median: percentile(&of(|m| m.pull_time_ratio), 50.0),
        chattering_p50: percentile(&of(|m| m.chattering), 50.0),
        peak_current_max_a: all.iter().map(|m| m.peak_current_a).fold(0.0, f64::max),
        bus_peak_max_v: all.iter().map(|m| m.bus_peak_v).fold(0.0, f64::max),
        failed: all.iter().filter(|m| m.failed).count(),
    }
}

/// A number for JSON: finite, or `null`.
fn number(x: f64) -> Value {
    if x.is_finite() { json!((x * 1e6).round() / 1e6) } else { Value::Null }
}

/// The report's JSON document.
#[must_use]
pub fn to_json(seed: u64, results: &[ScenarioResult]) -> Value {
    to_json_for(seed, results, &accuracy_lineup())
}

/// The JSON document of a report over `lineup`.
#[must_use]
pub fn to_json_for(seed: u64, results: &[ScenarioResult], lineup: &[Entry]) -> Value {
    let mut controllers = serde_json::Map::new();
    for (which, Entry { name, .. }) in lineup.iter().enumerate() {
        let s = summarize(results, which);
        controllers.insert(
            (*name).to_owned(),
            json!({
                "hold_error_p50_kgf": number(s.hold_error_p50_kgf),
                "hold_error_p99_kgf": number(s.hold_error_p99_kgf),
                "hold_error_max_kgf": number(s.hold_error_max_kgf),
                "overshoot_p99_kgf": number(s.overshoot_p99_kgf),
                "settle_time_p50_s": number(s.settle_time_p50_s),
                "pull_time_ratio_median": number(s.pull_time_ratio_median),
                "chattering_p50": number(s.chattering_p50),
                "peak_current_max_a": number(s.peak_current_max_a),
                "bus_peak_max_v": number(s.bus_peak_max_v),
                "failed": s.failed,
            }),
        );
    }
    json!({
        "scenarios": results.len(),
        "seed": seed,
        "unreachable": unreachable(results),
        "controllers": controllers,
    })
}

/// The markdown table printed on stdout.
#[must_use]
pub fn markdown(results: &[ScenarioResult]) -> String {
    markdown_for(results, &accuracy_lineup())
}

/// The markdown table of a report over `lineup`.
#[must_use]
pub fn markdown_for(results: &[ScenarioResult], lineup: &[Entry]) -> String {
    let mut out = String::from(
        "| controller | hold p50 kgf | hold p99 kgf | hold max kgf | overshoot p99 kgf | settle p50 s | pull-time ratio | chattering p50 /s | peak A | bus max V | failed |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (which, Entry { name, .. }) in lineup.iter().enumerate() {
        let s = summarize(results, which);
        out.push_str(&format!(
            "| {name} | {:.4} | {:.4} | {:.4} | {:.4} | {:.3} | {:.3} | {:.3} | {:.2} | {:.1} | {} |\n",
            s.hold_error_p50_kgf,
            s.hold_error_p99_kgf,
            s.hold_error_max_kgf,
            s.overshoot_p99_kgf,
            s.settle_time_p50_s,
            s.pull_time_ratio_median,
            s.chattering_p50,
            s.peak_current_max_a,
            s.bus_peak_max_v,
            s.failed
        ));
    }
    let beyond = unreachable(results);
    if beyond > 0 {
        out.push_str(&format!(
            "\n{beyond} of {} scenarios are beyond the machine's reach — the bang-bang oracle runs \
             into the end of travel before the target — and count as failed for every controller.\n",
            results.len()
        ));
    }
    out
}

/// Scenarios no controller can settle: the bang-bang oracle does not reach the target (the
/// carriage meets the end of travel first — a soft string with long slack at a high target).
#[must_use]
pub fn unreachable(results: &[ScenarioResult]) -> usize {
    results.iter().filter(|r| r.t_min.is_none()).count()
}

/// The time series of one pull: tension (true, measured, reference), carriage, duty,
/// current.
#[must_use]
pub fn pull_figure(trace: &[Sample], target: f64, title: &str) -> Figure {
    let series = |f: fn(&Sample) -> f64| trace.iter().map(|s| (s.t, f(s))).collect::<Vec<_>>();
    let end = trace.last().map_or(1.0, |s| s.t);
    Figure::new(
        title,
        "time since Start (s)",
        vec![
            Panel::new(
                "tension (kgf)",
                vec![
                    Series::new("true", series(|s| s.tension)),
                    Series::new("measured", series(|s| s.measured)),
                    Series::new("reference", series(|s| s.reference)),
                    Series::new("target", vec![(0.0, target), (end, target)]),
                ],
            ),
            Panel::new("carriage (mm)", vec![Series::new("position", series(|s| s.carriage_mm))]),
            Panel::new("duty (− = release)", vec![Series::new("duty", series(|s| s.duty))]),
            Panel::new("current (A)", vec![Series::new("winding", series(|s| s.current))]),
        ],
    )
}

/// The report's plots: per controller, the hold-window error (true − target) of a
/// representative subset of scenarios overlaid; and the distribution of hold errors.
#[must_use]
pub fn figures(seed: u64, results: &[ScenarioResult]) -> Vec<(String, Figure)> {
    let mut out = Vec::new();
    // Sorted hold error per controller (an empirical quantile plot).
    let mut quantiles = Vec::new();
    for (which, (name, _)) in CONTROLLERS.iter().enumerate() {
        let mut v: Vec<f64> = results.iter().map(|r| r.metrics[which].hold_error_kgf).collect();
        v.sort_by(f64::total_cmp);
        let n = v.len().max(1) as f64;
        quantiles.push(Series::new(
            name,
            v.iter().enumerate().map(|(i, e)| ((i + 1) as f64 / n * 100.0, *e)).collect(),
        ));
    }
    out.push((
        "hold_error_quantiles.svg".to_owned(),
        Figure::new(
            "hold error |true − target| per scenario, sorted (percentile → kgf)",
            "percentile of scenarios",
            vec![Panel::new("hold error (kgf)", quantiles)],
        ),
    ));
    // The first four scenarios, each controller's true tension minus target.
    for result in results.iter().take(4) {
        let scenario = Scenario::new(seed, result.index);
        let calibration = calibrate(&scenario.twin).calibration.unwrap_or(Calibration::IDENTITY);
        let mut tension = Vec::new();
        let mut duty = Vec::new();
        for (name, config) in CONTROLLERS {
            let trace = pull_trace(&scenario, &config, calibration, PULL_MS);
            tension.push(Series::new(
                name,
                trace.iter().map(|s| (s.t, s.tension - scenario.target_kgf)).collect(),
            ));
            duty.push(Series::new(name, trace.iter().map(|s| (s.t, s.duty)).collect()));
        }
        out.push((
            format!("scenario_{}.svg", result.index),
            Figure::new(
                &format!(
                    "scenario {}: {} at {:.1} kgf — three controllers",
                    result.index, result.string, result.target_kgf
                ),
                "time since Start (s)",
                vec![
                    Panel::new("true tension − target (kgf)", tension),
                    Panel::new("duty (− = release)", duty),
                ],
            ),
        ));
    }
    out
}

/// `taut report ablation`: runs [`ablation_lineup`] on `count` scenarios of seed `seed`
/// with a progress bar on stderr, prints the markdown table and writes the JSON document
/// (`{"scenarios", "seed", "controllers": {row name: {…}}}`, the accuracy report's keys).
///
/// # Panics
/// When the JSON file cannot be written (a host tool's failure, reported as it happens).
pub fn ablation_main(count: u64, seed: u64, json: Option<&std::path::Path>) {
    use std::io::Write as _;
    let threads = std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get);
    let progress = |done: usize| {
        let width = 40;
        let filled = done * width / count.max(1) as usize;
        eprint!("\r[{}{}] {done}/{count}", "#".repeat(filled), "-".repeat(width - filled));
        let _ = std::io::stderr().flush();
    };
    let lineup = ablation_lineup();
    let results = run_lineup(seed, count, threads, &progress, &lineup);
    eprintln!();
    let table = markdown_for(&results, &lineup);
    std::io::stdout().write_all(table.as_bytes()).expect("write the table");
    if let Some(path) = json {
        let doc = to_json_for(seed, &results, &lineup);
        std::fs::write(path, serde_json::to_string_pretty(&doc).expect("json"))
            .expect("write JSON");
    }
}

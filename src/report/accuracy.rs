//! `taut report accuracy`: controllers on Monte-Carlo scenarios of the family of machines,
//! against the true tension (see [`super`] for a scenario and the figures).

use std::fmt::Write as _;

use serde_json::{Value, json};
use taut_core::sense::calibration::Calibration;
use taut_core::tension::ControllerConfig;
use taut_sim::{Screw, bang_bang_reach_time};

use super::{
    AGGREGATE_HEADER, Aggregate, Failure, Machines, Metrics, ORACLE_LIMIT_MS, PULL_MS, Scenario,
    aggregate, aggregate_json, aggregate_row, commissioned_calibration, failure_counts,
    gauge_sigma_kgf, metrics, number, pull_trace,
};
use crate::cli::{AccuracyArgs, ControllerArg};
use crate::output::{Outputs, Progress, Status, json_bytes, parallel, threads};
use crate::plot::{DUTY_AXIS_PERCENT, Figure, Panel, Series, Stroke};

/// The controller of a report entry.
#[must_use]
pub const fn controller_config(which: ControllerArg) -> ControllerConfig {
    match which {
        ControllerArg::Taut => ControllerConfig::TAUT,
        ControllerArg::PaperRsmc => ControllerConfig::PAPER_RSMC,
        ControllerArg::Pd => ControllerConfig::PD,
    }
}

/// One controller of a report: its name, its configuration, and whether it pulls with the
/// machine's calibration (or the identity: the uncalibrated sensor).
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// The row's name.
    pub name: &'static str,
    /// The controller.
    pub config: ControllerConfig,
    /// Pull with the machine's 4-point calibration (`false`: uncorrected sensor).
    pub calibrated: bool,
}

/// The accuracy report's lineup for `controllers`, all calibrated.
#[must_use]
pub fn lineup(controllers: &[ControllerArg]) -> Vec<Entry> {
    controllers
        .iter()
        .map(|&c| Entry { name: c.name(), config: controller_config(c), calibrated: true })
        .collect()
}

/// One scenario's outcome for every entry of a lineup.
#[derive(Clone, Debug)]
pub struct ScenarioResult {
    /// The scenario index.
    pub index: u64,
    /// Target, kgf.
    pub target_kgf: f64,
    /// String kind name.
    pub string: &'static str,
    /// The board's current sensing.
    pub sensing: String,
    /// The machine's screw.
    pub screw: Screw,
    /// Oracle reach time, s.
    pub t_min: Option<f64>,
    /// Metrics per entry, in the lineup's order.
    pub metrics: Vec<Metrics>,
}

/// Runs `scenario` for every entry of `lineup`: one commissioning and one oracle run shared
/// by all.
#[must_use]
pub fn run_scenario(scenario: &Scenario, lineup: &[Entry]) -> ScenarioResult {
    let result = |metrics, t_min| ScenarioResult {
        index: scenario.index,
        target_kgf: scenario.target_kgf,
        string: scenario.twin.string.kind.name(),
        sensing: scenario.twin.current_sense.name(),
        screw: scenario.twin.mechanics.screw,
        t_min,
        metrics,
    };
    let calibration = match commissioned_calibration(&scenario.twin) {
        Ok(calibration) => calibration,
        Err(failure) => {
            return result(lineup.iter().map(|_| Metrics::failed(failure.clone())).collect(), None);
        }
    };
    let t_min = bang_bang_reach_time(&scenario.twin, scenario.target_kgf, ORACLE_LIMIT_MS);
    let metrics = lineup
        .iter()
        .map(|entry| {
            let correction = if entry.calibrated { calibration } else { Calibration::IDENTITY };
            match pull_trace(scenario, &entry.config, correction, PULL_MS) {
                Ok(trace) => metrics(&trace, scenario.target_kgf, t_min),
                Err(failure) => Metrics::failed(failure),
            }
        })
        .collect();
    result(metrics, t_min)
}

impl AccuracyArgs {
    /// The machines the options draw: the sensing board and the reference gauge.
    #[must_use]
    pub const fn machines(&self) -> Machines {
        Machines { sensing: self.sensing, gauge_sigma: self.gauge_sigma }
    }
}

/// Runs `count` scenarios of seed `seed` on `machines` for `lineup` on `threads` threads with
/// a progress counter.
#[must_use]
pub fn run_all(
    seed: u64,
    count: u64,
    machines: Machines,
    lineup: &[Entry],
    threads: usize,
) -> Vec<ScenarioResult> {
    let progress = Progress::new(count as usize, "scenarios");
    parallel(count, threads, &progress, &|index| {
        run_scenario(&machines.scenario(seed, index), lineup)
    })
}

/// The sensing mix of `results`: board name and count.
#[must_use]
pub fn sensing_mix(results: &[ScenarioResult]) -> Vec<(String, usize)> {
    let mut mix: Vec<(String, usize)> = Vec::new();
    for r in results {
        match mix.iter_mut().find(|(n, _)| *n == r.sensing) {
            Some((_, c)) => *c += 1,
            None => mix.push((r.sensing.clone(), 1)),
        }
    }
    mix.sort();
    mix
}

/// The Markdown table of a report over `lineup`, with each entry's failures by reason.
#[must_use]
pub fn markdown(results: &[ScenarioResult], lineup: &[Entry]) -> String {
    let mut out =
        format!("| controller {AGGREGATE_HEADER}\n|---|---|---|---|---|---|---|---|---|\n");
    for (which, entry) in lineup.iter().enumerate() {
        let all: Vec<&Metrics> = results.iter().map(|r| &r.metrics[which]).collect();
        let _ = writeln!(out, "| {}{}", entry.name, aggregate_row(&aggregate(&all)));
    }
    for (which, entry) in lineup.iter().enumerate() {
        let all: Vec<&Metrics> = results.iter().map(|r| &r.metrics[which]).collect();
        let a = aggregate(&all);
        let _ = writeln!(
            out,
            "{}: hold peak-to-peak p50 / p99 {:.3} / {:.3} kgf; coasting under a command in the hold: {} PWM periods in {} runs",
            entry.name, a.hold_p2p_kgf[0], a.hold_p2p_kgf[1], a.hold_coasting.0, a.hold_coasting.1
        );
        let by_screw: Vec<String> = by_screw(results, which)
            .iter()
            .map(|(screw, a)| {
                format!(
                    "{} ({} runs) {:.3} / {:.3}",
                    screw.name(),
                    a.runs,
                    a.hold_p2p_kgf[0],
                    a.hold_p2p_kgf[1]
                )
            })
            .collect();
        let _ = writeln!(
            out,
            "{}: hold peak-to-peak p50 / p99 by screw: {} kgf",
            entry.name,
            by_screw.join("; ")
        );
    }
    out.push_str("\nQuantiles over the scenarios that did not fail; against the true tension.\n");
    for (which, entry) in lineup.iter().enumerate() {
        let counts = failure_counts(results.iter().map(|r| &r.metrics[which]));
        if !counts.is_empty() {
            let text: Vec<String> = counts.iter().map(|(n, c)| format!("{c} {n}")).collect();
            let _ = writeln!(out, "{} failed: {}", entry.name, text.join(", "));
        }
    }
    let mix: Vec<String> = sensing_mix(results).iter().map(|(n, c)| format!("{c} {n}")).collect();
    let _ = writeln!(out, "current sensing: {}", mix.join(", "));
    out
}

/// The aggregate of entry `which` over the runs on each kind of screw (kinds with no run left
/// out).
#[must_use]
pub fn by_screw(results: &[ScenarioResult], which: usize) -> Vec<(Screw, Aggregate)> {
    [Screw::Lead, Screw::Ball]
        .into_iter()
        .filter_map(|screw| {
            let on: Vec<&Metrics> = results
                .iter()
                .filter(|r| r.screw == screw)
                .filter_map(|r| r.metrics.get(which))
                .collect();
            (!on.is_empty()).then(|| (screw, aggregate(&on)))
        })
        .collect()
}

/// The JSON document of a report over `lineup`.
#[must_use]
pub fn to_json(
    seed: u64,
    machines: Machines,
    results: &[ScenarioResult],
    lineup: &[Entry],
) -> Value {
    let mut controllers = serde_json::Map::new();
    for (which, entry) in lineup.iter().enumerate() {
        let all: Vec<&Metrics> = results.iter().map(|r| &r.metrics[which]).collect();
        let mut doc = aggregate_json(&aggregate(&all));
        for (screw, a) in by_screw(results, which) {
            let key = match screw {
                Screw::Lead => "lead_screw",
                Screw::Ball => "ball_screw",
            };
            doc[key] = json!({
                "runs": a.runs,
                "hold_p50_kgf": number(a.hold_kgf[0]),
                "hold_p99_kgf": number(a.hold_kgf[1]),
                "hold_p2p_p50_kgf": number(a.hold_p2p_kgf[0]),
                "hold_p2p_p99_kgf": number(a.hold_p2p_kgf[1]),
            });
        }
        let failures: serde_json::Map<String, Value> =
            failure_counts(all.iter().copied()).into_iter().map(|(n, c)| (n, json!(c))).collect();
        doc["failures"] = Value::Object(failures);
        controllers.insert(entry.name.to_owned(), doc);
    }
    json!({
        "scenarios": results.len(),
        "seed": seed,
        "family": "TwinConfig::family",
        "sensing": machines.sensing.name(),
        "reference_gauge_sigma_kgf": gauge_sigma_kgf(machines.gauge_sigma),
        "speed": 9,
        "targets_kgf": [super::TARGETS_KGF.0, super::TARGETS_KGF.1],
        "current_sensing": sensing_mix(results).into_iter().map(|(n, c)| json!({"board": n, "count": c})).collect::<Vec<_>>(),
        "controllers": controllers,
    })
}

/// One line per scenario (`--detail`).
#[must_use]
pub fn detail(results: &[ScenarioResult], lineup: &[Entry]) -> String {
    let mut out = String::new();
    for r in results {
        let _ = write!(
            out,
            "{:5} {:16} {:5.1} kgf  t_min {}  {:28}",
            r.index,
            r.string,
            r.target_kgf,
            r.t_min.map_or_else(|| "—".to_owned(), |t| format!("{t:.3} s")),
            r.sensing
        );
        for (entry, m) in lineup.iter().zip(&r.metrics) {
            let state = m.failure.as_ref().map_or_else(
                || {
                    format!(
                        "hold {:.3} (offset {:+.3}, sensing {:+.3}) over {:.3}",
                        m.hold_error_kgf, m.hold_offset_kgf, m.sense_offset_kgf, m.overshoot_kgf
                    )
                },
                Failure::name,
            );
            let _ = write!(out, "  {}: {state}", entry.name);
        }
        out.push('\n');
    }
    out
}

/// The subtitle of the report's plots: what was run.
fn what_was_run(seed: u64, machines: Machines, results: &[ScenarioResult]) -> String {
    format!(
        "{} scenarios of the family (seed {seed}, sensing {}), speed 9, targets 8–35 kgf by string kind (badminton ≤ 16, tennis ≥ 15), the machine's own calibration (reference gauge σ {:.3} kgf); errors against the true tension",
        results.len(),
        machines.sensing.name(),
        gauge_sigma_kgf(machines.gauge_sigma)
    )
}

/// The report's plots: the quantiles of hold error, overshoot (log scale) and settle/t_min
/// per controller, on one percentile axis of all the scenarios (each controller's failures
/// ranked last and not drawn, so its line ends where its survivors do; a controller that
/// failed every scenario is named in the subtitle, not given an empty legend entry); and the
/// scenario whose hold error was the first controller's worst.
#[must_use]
pub fn figures(
    seed: u64,
    machines: Machines,
    results: &[ScenarioResult],
    lineup: &[Entry],
) -> Vec<(String, Figure)> {
    let quantile = |which: usize, f: &dyn Fn(&Metrics) -> f64, floor: f64| {
        let mut v: Vec<f64> = results
            .iter()
            .map(|r| &r.metrics[which])
            .filter(|m| m.failure.is_none())
            .map(f)
            .filter(|e| e.is_finite())
            .map(|e| e.max(floor))
            .collect();
        v.sort_by(f64::total_cmp);
        // The empirical quantile function over all the scenarios: the k-th smallest value
        // over the k-th n-th of the percentile axis, a step each; the failures, ranked
        // last, are not drawn.
        let n = results.len().max(1) as f64;
        v.iter()
            .enumerate()
            .flat_map(|(k, e)| [(k as f64 / n * 100.0, *e), ((k + 1) as f64 / n * 100.0, *e)])
            .collect::<Vec<_>>()
    };
    let series = |f: &dyn Fn(&Metrics) -> f64, floor: f64| {
        lineup
            .iter()
            .enumerate()
            .map(|(which, e)| {
                let points = quantile(which, f, floor);
                let label = format!("{} ({} of {})", e.name, points.len() / 2, results.len());
                Series::new(&label, points)
            })
            .filter(|s| !s.points.is_empty())
            .collect::<Vec<_>>()
    };
    let none_survived: Vec<&str> = lineup
        .iter()
        .enumerate()
        .filter(|(which, _)| results.iter().all(|r| r.metrics[*which].failure.is_some()))
        .map(|(_, e)| e.name)
        .collect();
    let mut subtitle = what_was_run(seed, machines, results);
    if !none_survived.is_empty() {
        subtitle.push_str(&format!("; every scenario failed for {}", none_survived.join(", ")));
    }
    let goal = |value: f64, label: &str| {
        Series::new(label, vec![(0.0, value), (100.0, value)])
            .stroke(Stroke::Dashed)
            .colour("#555555")
    };
    let mut hold = series(&|m| m.hold_error_kgf, 1e-3);
    hold.push(goal(0.05, "goal 0.05 kgf"));
    let mut over = series(&|m| m.overshoot_kgf, 1e-3);
    over.push(goal(0.05, "goal 0.05 kgf"));
    let mut ratio = series(&|m| m.settle_ratio.unwrap_or(f64::NAN), 0.0);
    ratio.push(goal(1.5, "goal p99 1.5"));
    let mut out = vec![(
        "accuracy_quantiles.svg".to_owned(),
        Figure::new(
            "taut report accuracy: each scenario's error, sorted (empirical quantiles)",
            &subtitle,
            "percentile of all the scenarios (a controller's failed ones last, not drawn)",
            vec![
                Panel::new("hold error (kgf, log; < 0.001 shown at 0.001)", hold).log(),
                Panel::new("overshoot above target (kgf, log; 0 shown at 0.001)", over).log(),
                Panel::new("settle time / t_min", ratio),
            ],
        ),
    )];
    // The first controller's worst hold among the scenarios it did not fail.
    let worst = results
        .iter()
        .filter(|r| r.metrics.first().is_some_and(|m| m.failure.is_none()))
        .max_by(|a, b| a.metrics[0].hold_error_kgf.total_cmp(&b.metrics[0].hold_error_kgf));
    if let Some(r) = worst {
        let scenario = machines.scenario(seed, r.index);
        if let Ok(calibration) = commissioned_calibration(&scenario.twin) {
            let mut tension = Vec::new();
            let mut error = Vec::new();
            let mut duty = Vec::new();
            for entry in lineup {
                let correction = if entry.calibrated { calibration } else { Calibration::IDENTITY };
                let Ok(trace) = pull_trace(&scenario, &entry.config, correction, PULL_MS) else {
                    continue;
                };
                let pts = |f: &dyn Fn(&taut_sim::bench::ControllerRow) -> f64| {
                    trace.iter().map(|row| (row.t_s, f(row))).collect::<Vec<_>>()
                };
                tension.push(Series::new(entry.name, pts(&|row| row.truth.tension_kgf)));
                error.push(Series::new(
                    entry.name,
                    pts(&|row| row.truth.tension_kgf - r.target_kgf),
                ));
                duty.push(Series::new(entry.name, pts(&|row| super::signed_duty(row) * 100.0)));
            }
            let end = f64::from(PULL_MS) / 1_000.0;
            tension.push(
                Series::new("target", vec![(0.0, r.target_kgf), (end, r.target_kgf)])
                    .stroke(Stroke::Dashed)
                    .colour("#555555"),
            );
            out.push((
                format!("scenario_{}.svg", r.index),
                Figure::new(
                    &format!(
                        "taut report accuracy: scenario {}, {} at {:.1} kgf — {}'s worst hold ({:.3} kgf)",
                        r.index,
                        r.string,
                        r.target_kgf,
                        lineup.first().map_or("", |e| e.name),
                        r.metrics[0].hold_error_kgf
                    ),
                    &format!("family machine (seed {seed}), current sensing {}, speed 9, calibrated by the machine", r.sensing),
                    "time since Start (s)",
                    vec![
                        Panel::new("true tension (kgf)", tension),
                        Panel::new("true − target (kgf), ±0.2", error).with_y_range(-0.2, 0.2),
                        Panel::new("duty (%, − = release)", duty)
                            .with_y_range(-DUTY_AXIS_PERCENT, DUTY_AXIS_PERCENT)
                            .with_height(120.0),
                    ],
                ),
            ));
        }
    }
    out
}

/// `taut report accuracy`.
///
/// # Errors
/// An output file or directory cannot be written.
pub fn main(args: &AccuracyArgs) -> Status {
    let outputs = Outputs::new()
        .file("--json", args.json.as_deref())
        .folder("--svg", args.svg.as_deref())
        .check()?;
    let mut controllers = args.controllers.clone();
    controllers.dedup();
    let lineup = lineup(&controllers);
    let started = std::time::Instant::now();
    let machines = args.machines();
    let results = run_all(args.seed, args.scenarios, machines, &lineup, threads(args.threads));
    if args.detail {
        print!("{}", detail(&results, &lineup));
    }
    println!("{}", markdown(&results, &lineup));
    println!("wall clock: {:.1} s", started.elapsed().as_secs_f64());
    let mut files = Vec::new();
    if let Some(path) = &args.json {
        files.push((path.clone(), json_bytes(&to_json(args.seed, machines, &results, &lineup))));
    }
    if let Some(dir) = &args.svg {
        for (name, figure) in figures(args.seed, machines, &results, &lineup) {
            files.push((dir.join(name), figure.to_svg().into_bytes()));
        }
    }
    outputs.write(&files)?;
    for (path, _) in &files {
        let what = if path.extension().is_some_and(|e| e == "json") { "summary" } else { "plot" };
        println!("{what}: {}", path.display());
    }
    Ok(true)
}

//! `taut report robustness`: each uncertainty axis of the family swept alone, from its low
//! end (position 0) to its high end (1), everything else at the family's centre
//! ([`TwinConfig::on_axis`]).
//!
//! At each point of each axis the report runs several scenarios — the string kinds in turn
//! and targets drawn from each kind's stringing range within 8–35 kgf — each commissioned through the machine's own calibration
//! and pulled by taut's controller (speed 9), and keeps per axis the worst hold error,
//! overshoot and settle/t_min of the runs that did not fail, and the failures (see
//! [`super`] for the figures).
//!
//! `--beyond F` also runs every axis at `−F` and `1 + F`: its spans continued past the
//! family's ends ([`TwinConfig::beyond_axis`]), a margin the family does not promise. A
//! continued machine that is not physical (an efficiency above 1, a negative mass…) is
//! listed as such and not run. Those points have their own table and JSON section; the
//! sweep's table, plot and worst figures stay the family's.
//!
//! `--corner NAME=POSITION` (given once per axis) runs the same scenarios on one **corner**
//! instead: every named axis moved at once ([`TwinConfig::corner`]), one row per pull and
//! the worst. The sweep moves one axis at a time and the family's draws seldom put many
//! axes at their ends together; a corner asks what the extremes do jointly.

use std::fmt::Write as _;

use serde_json::{Value, json};
use taut_sim::{Axis, StringKind, TwinConfig, bang_bang_reach_time};

use super::{
    Metrics, ORACLE_LIMIT_MS, PULL_MS, Scenario, cell, commissioned_calibration, draw_target,
    failure_counts, gauge_sigma_kgf, metrics, number, pull_trace, scenario_seed,
};
use crate::cli::RobustnessArgs;
use crate::output::{Failure, Outputs, Progress, Status, json_bytes, parallel, threads};
use crate::plot::{Figure, Panel, Series, Stroke};
use taut_core::tension::ControllerConfig;

/// The string kinds the scenarios cycle through.
pub const STRINGS: [StringKind; 5] = [
    StringKind::TennisSynthetic,
    StringKind::TennisPolyester,
    StringKind::BadmintonSoft,
    StringKind::TennisGut,
    StringKind::BadmintonHard,
];

/// The string kind of scenario `index` of a sweep point: [`STRINGS`] in turn.
#[must_use]
pub fn string_for(index: u64) -> StringKind {
    STRINGS[(index % STRINGS.len() as u64) as usize]
}

/// The machine at `points` for `kind`: one point of one axis (the sweep's machine), or a
/// corner of the family (every named axis moved at once, [`TwinConfig::corner`]).
///
/// # Errors
/// An axis named twice, or a machine that is not physical (why, in words).
pub fn corner_machine(points: &[(Axis, f64)], kind: StringKind) -> Result<TwinConfig, String> {
    TwinConfig::corner(points, kind)
        .map_err(|why| format!("{}: not a physical machine ({why})", describe_corner(points, kind)))
}

/// `points` in words for `kind`: each axis's headline values, `; ` between them.
#[must_use]
pub fn describe_corner(points: &[(Axis, f64)], kind: StringKind) -> String {
    let words: Vec<String> =
        points.iter().map(|&(axis, position)| axis.describe_at(position, kind)).collect();
    words.join("; ")
}

/// Refuses a corner that is not physical for one of the string kinds the scenarios cycle
/// through ([`STRINGS`]): a usage error, before anything runs.
///
/// # Errors
/// The first string kind's refusal, in words.
pub fn check_corner(points: &[(Axis, f64)]) -> Result<(), Failure> {
    for kind in STRINGS {
        corner_machine(points, kind).map_err(Failure::Usage)?;
    }
    Ok(())
}

/// `points` as JSON: `[{ "name", "position" }, …]`.
#[must_use]
pub fn corner_json(points: &[(Axis, f64)]) -> Value {
    points
        .iter()
        .map(|(axis, position)| json!({ "name": axis.name(), "position": position }))
        .collect()
}

/// One run of the sweep.
#[derive(Clone, Debug)]
pub struct Point {
    /// The axis.
    pub axis: Axis,
    /// Its position, 0–1 (beyond the family: below 0 or above 1).
    pub position: f64,
    /// The string.
    pub string: StringKind,
    /// The target, kgf.
    pub target_kgf: f64,
    /// The figures.
    pub metrics: Metrics,
    /// Why a point beyond the family was not run: its machine is not physical.
    pub unphysical: Option<String>,
}

impl Point {
    /// Whether the point lies within the family's ranges (position 0–1).
    #[must_use]
    pub fn in_family(&self) -> bool {
        (0.0..=1.0).contains(&self.position)
    }
}

/// Runs one point of the sweep, the machine commissioned against a reference gauge of
/// standard deviation `gauge` kgf (`None`: the family's).
#[must_use]
pub fn run_point(axis: Axis, position: f64, index: u64, seed: u64, gauge: Option<f64>) -> Point {
    let string = string_for(index);
    let target_kgf = draw_target(scenario_seed(seed, index), string);
    let twin = if (0.0..=1.0).contains(&position) {
        TwinConfig::on_axis(axis, position, string)
    } else {
        match TwinConfig::beyond_axis(axis, position, string) {
            Ok(twin) => twin,
            Err(why) => {
                let metrics = Metrics::default();
                let unphysical = Some(why.to_string());
                return Point { axis, position, string, target_kgf, metrics, unphysical };
            }
        }
    };
    let metrics = pull_on(twin, index, target_kgf, gauge);
    Point { axis, position, string, target_kgf, metrics, unphysical: None }
}

/// Scenario `index`'s pull to `target_kgf` on `twin`, commissioned against a reference
/// gauge of standard deviation `gauge` kgf (`None`: the family's): its figures.
fn pull_on(twin: TwinConfig, index: u64, target_kgf: f64, gauge: Option<f64>) -> Metrics {
    let scenario = Scenario::on(index, twin, target_kgf).with_gauge_sigma(gauge);
    match commissioned_calibration(&scenario.twin) {
        Err(failure) => Metrics::failed(failure),
        Ok(calibration) => {
            let t_min = bang_bang_reach_time(&scenario.twin, target_kgf, ORACLE_LIMIT_MS);
            match pull_trace(&scenario, &ControllerConfig::TAUT, calibration, PULL_MS) {
                Ok(trace) => metrics(&trace, target_kgf, t_min),
                Err(failure) => Metrics::failed(failure),
            }
        }
    }
}

/// One pull on a corner of the family.
#[derive(Clone, Debug)]
pub struct CornerRun {
    /// The string.
    pub string: StringKind,
    /// The target, kgf.
    pub target_kgf: f64,
    /// The figures.
    pub metrics: Metrics,
}

/// Scenario `index` of `--corner`: the string kind and target the sweep's scenario `index`
/// has, on the corner `points` (physical for every string kind: [`main`] checked it).
#[must_use]
pub fn run_corner(points: &[(Axis, f64)], index: u64, seed: u64, gauge: Option<f64>) -> CornerRun {
    let string = string_for(index);
    let target_kgf = draw_target(scenario_seed(seed, index), string);
    let metrics = match corner_machine(points, string) {
        Ok(twin) => pull_on(twin, index, target_kgf, gauge),
        Err(why) => Metrics::failed(super::Failure::Bench(why)),
    };
    CornerRun { string, target_kgf, metrics }
}

/// The corner's table: one row per pull, then the worst.
#[must_use]
pub fn corner_markdown(runs: &[CornerRun]) -> String {
    let mut out = String::from(
        "| string | target kgf | hold kgf | overshoot kgf | settle/t_min | failure |\n|---|---|---|---|---|---|\n",
    );
    for r in runs {
        let m = &r.metrics;
        let _ = writeln!(
            out,
            "| {} | {:.1} | {} | {} | {} | {} |",
            r.string.name(),
            r.target_kgf,
            cell(m.hold_error_kgf, 3),
            cell(m.overshoot_kgf, 3),
            cell(m.settle_ratio.unwrap_or(f64::NAN), 2),
            m.failure.as_ref().map_or_else(|| "—".to_owned(), super::Failure::name),
        );
    }
    let w = worst_of(runs.iter().map(|r| &r.metrics));
    let _ = writeln!(
        out,
        "| **worst of {}** | | {} | {} | {} | {} failed |",
        w.runs,
        cell(w.hold_kgf, 3),
        cell(w.overshoot_kgf, 3),
        cell(w.settle_ratio, 2),
        w.failed
    );
    out
}

/// `taut report robustness --corner …`: the sweep's scenarios on one corner of the family.
fn corner_main(args: &RobustnessArgs, outputs: &Outputs) -> Status {
    check_corner(&args.corner)?;
    println!(
        "A corner of the family, every named axis at once, the rest at the centre: {}\n",
        describe_corner(&args.corner, StringKind::TennisSynthetic)
    );
    let started = std::time::Instant::now();
    let progress = Progress::new(args.scenarios as usize, "runs");
    let runs = parallel(args.scenarios, threads(args.threads), &progress, &|index| {
        run_corner(&args.corner, index, args.seed, args.gauge_sigma)
    });
    let mut files = Vec::new();
    if let Some(path) = &args.json {
        let w = worst_of(runs.iter().map(|r| &r.metrics));
        let pulls: Vec<Value> = runs
            .iter()
            .map(|r| {
                json!({
                    "string": r.string.name(),
                    "target_kgf": r.target_kgf,
                    "hold_error_kgf": number(r.metrics.hold_error_kgf),
                    "overshoot_kgf": number(r.metrics.overshoot_kgf),
                    "settle_over_t_min": number(r.metrics.settle_ratio.unwrap_or(f64::NAN)),
                    "failure": r.metrics.failure.as_ref().map(super::Failure::name),
                })
            })
            .collect();
        let doc = json!({
            "seed": args.seed,
            "scenarios": args.scenarios,
            "reference_gauge_sigma_kgf": gauge_sigma_kgf(args.gauge_sigma),
            "controller": "taut",
            "speed": 9,
            "corner": corner_json(&args.corner),
            "worst": worst_json(&w),
            "pulls": pulls,
        });
        files.push((path.clone(), json_bytes(&doc)));
    }
    outputs.write(&files)?;
    println!("{}", corner_markdown(&runs));
    println!(
        "{} runs on the corner (string kinds in turn, seed {}, reference gauge σ {:.3} kgf), wall clock {:.1} s",
        runs.len(),
        args.seed,
        gauge_sigma_kgf(args.gauge_sigma),
        started.elapsed().as_secs_f64()
    );
    if let Some(path) = &args.json {
        println!("summary: {}", path.display());
    }
    Ok(true)
}

/// The worst figures of some runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Worst {
    /// Runs.
    pub runs: usize,
    /// Largest hold error, kgf.
    pub hold_kgf: f64,
    /// Largest overshoot, kgf.
    pub overshoot_kgf: f64,
    /// Largest settle / t_min.
    pub settle_ratio: f64,
    /// Failed runs.
    pub failed: usize,
}

/// The worst figures of `points` (failures counted, not in the maxima).
#[must_use]
pub fn worst<'a>(points: impl Iterator<Item = &'a Point>) -> Worst {
    worst_of(points.map(|p| &p.metrics))
}

/// The worst figures of some runs' `metrics` (failures counted, not in the maxima).
#[must_use]
pub fn worst_of<'a>(metrics: impl Iterator<Item = &'a Metrics>) -> Worst {
    let mut w = Worst {
        runs: 0,
        hold_kgf: f64::NAN,
        overshoot_kgf: f64::NAN,
        settle_ratio: f64::NAN,
        failed: 0,
    };
    for m in metrics {
        w.runs += 1;
        if m.failure.is_some() {
            w.failed += 1;
            continue;
        }
        w.hold_kgf = w.hold_kgf.max(m.hold_error_kgf);
        w.overshoot_kgf = w.overshoot_kgf.max(m.overshoot_kgf);
        w.settle_ratio = w.settle_ratio.max(m.settle_ratio.unwrap_or(f64::NAN));
    }
    w
}

/// The positions of `points` points from 0 to 1.
#[must_use]
pub fn positions(points: u64) -> Vec<f64> {
    let last = points.saturating_sub(1).max(1) as f64;
    (0..points).map(|i| i as f64 / last).collect()
}

/// The positions past the family's ends that `--beyond` adds: `−beyond` and `1 + beyond`
/// (none for 0, and none on the current-sensing axis, whose boards have nothing beyond).
#[must_use]
pub fn beyond_positions(axis: Axis, beyond: f64) -> Vec<f64> {
    if beyond > 0.0 && axis != Axis::CurrentSensing { vec![-beyond, 1.0 + beyond] } else { vec![] }
}

/// The sweep's table: per axis its span, the worst figures, failures and their reasons.
#[must_use]
pub fn markdown(axes: &[Axis], runs: &[Point]) -> String {
    let mut out = String::from(
        "| axis | low … high | worst hold kgf | worst overshoot kgf | worst settle/t_min | failed | failures |\n|---|---|---|---|---|---|---|\n",
    );
    for &axis in axes {
        let mine: Vec<&Point> = runs.iter().filter(|p| p.axis == axis && p.in_family()).collect();
        let _ = writeln!(
            out,
            "| {} | {} | {} |",
            axis.name(),
            super::span_text(&axis.span()),
            figure_cells(&mine)
        );
    }
    out
}

/// The worst figures, failures and their reasons of `points` as table cells.
fn figure_cells(points: &[&Point]) -> String {
    let w = worst(points.iter().copied());
    let reasons: Vec<String> = failure_counts(points.iter().map(|p| &p.metrics))
        .into_iter()
        .map(|(n, c)| format!("{c} {n}"))
        .collect();
    format!(
        "{} | {} | {} | {} of {} | {}",
        cell(w.hold_kgf, 3),
        cell(w.overshoot_kgf, 3),
        cell(w.settle_ratio, 2),
        w.failed,
        w.runs,
        if reasons.is_empty() { "—".to_owned() } else { reasons.join(", ") }
    )
}

/// The table of the points past the family's ends: per axis and end, the continued value
/// and the worst figures, or why the machine there is not physical.
#[must_use]
pub fn beyond_markdown(axes: &[Axis], runs: &[Point], beyond: f64) -> String {
    let mut out = String::from(
        "| axis | position | value | worst hold kgf | worst overshoot kgf | worst settle/t_min | failed | failures |\n|---|---|---|---|---|---|---|---|\n",
    );
    for &axis in axes {
        for position in beyond_positions(axis, beyond) {
            let mine: Vec<&Point> =
                runs.iter().filter(|p| p.axis == axis && p.position == position).collect();
            let described = axis.describe_at(position, StringKind::TennisSynthetic);
            let value = described.split_once(": ").map_or(described.as_str(), |(_, v)| v).trim();
            if let Some(why) = mine.iter().find_map(|p| p.unphysical.as_ref()) {
                let _ = writeln!(
                    out,
                    "| {} | {position:.2} | {value} | not physical: {why} | | | | |",
                    axis.name()
                );
                continue;
            }
            let _ = writeln!(
                out,
                "| {} | {position:.2} | {value} | {} |",
                axis.name(),
                figure_cells(&mine)
            );
        }
    }
    out
}

/// The worst figures as JSON.
fn worst_json(w: &Worst) -> Value {
    json!({
        "runs": w.runs,
        "failed": w.failed,
        "hold_error_max_kgf": number(w.hold_kgf),
        "overshoot_max_kgf": number(w.overshoot_kgf),
        "settle_over_t_min_max": number(w.settle_ratio),
    })
}

/// The sweep as JSON: per axis, per position, the worst figures.
#[must_use]
pub fn to_json(args: &RobustnessArgs, axes: &[Axis], runs: &[Point]) -> Value {
    let mut doc = serde_json::Map::new();
    for &axis in axes {
        let points: Vec<Value> = positions(args.points)
            .into_iter()
            .map(|position| {
                let w = worst(runs.iter().filter(|p| p.axis == axis && p.position == position));
                let mut v = worst_json(&w);
                v["position"] = json!(position);
                v["at"] = json!(axis.describe_at(position, StringKind::TennisSynthetic));
                v
            })
            .collect();
        let mut entry = worst_json(&worst(runs.iter().filter(|p| p.axis == axis && p.in_family())));
        entry["span"] = json!(super::span_text(&axis.span()));
        entry["points"] = Value::Array(points);
        let beyond: Vec<Value> = beyond_positions(axis, args.beyond)
            .into_iter()
            .map(|position| {
                let mine = || runs.iter().filter(|p| p.axis == axis && p.position == position);
                let mut v = match mine().find_map(|p| p.unphysical.as_ref()) {
                    Some(why) => json!({ "unphysical": why }),
                    None => worst_json(&worst(mine())),
                };
                v["position"] = json!(position);
                v["at"] = json!(axis.describe_at(position, StringKind::TennisSynthetic));
                v
            })
            .collect();
        if !beyond.is_empty() {
            entry["beyond"] = Value::Array(beyond);
        }
        doc.insert(axis.name().to_owned(), entry);
    }
    json!({
        "seed": args.seed,
        "scenarios_per_point": args.scenarios,
        "points_per_axis": args.points,
        "beyond": args.beyond,
        "reference_gauge_sigma_kgf": gauge_sigma_kgf(args.gauge_sigma),
        "controller": "taut",
        "speed": 9,
        "axes": doc,
    })
}

/// The sweep's plot: per axis (x) the worst figure at each position (one colour per
/// position).
#[must_use]
pub fn figure(args: &RobustnessArgs, axes: &[Axis], runs: &[Point]) -> Figure {
    let positions = positions(args.points);
    let per_position = |f: &dyn Fn(&Worst) -> f64, floor: f64| {
        positions
            .iter()
            .map(|&position| {
                let points = axes
                    .iter()
                    .enumerate()
                    .map(|(i, &axis)| {
                        let w =
                            worst(runs.iter().filter(|p| p.axis == axis && p.position == position));
                        // Positions side by side around their axis, low end left; no
                        // marker where every run failed (NaN: `max` would make it the floor).
                        let v = f(&w);
                        let v = if v.is_nan() { v } else { v.max(floor) };
                        (i as f64 + (position - 0.5) * 0.4, v)
                    })
                    .collect();
                Series::new(&format!("position {position:.2}"), points).stroke(Stroke::Markers)
            })
            .collect::<Vec<_>>()
    };
    let goal = |value: f64| {
        Series::new(&format!("goal {value}"), vec![(-0.5, value), (axes.len() as f64 - 0.5, value)])
            .stroke(Stroke::Dashed)
            .colour("#555555")
    };
    let mut hold = per_position(&|w| w.hold_kgf, 1e-3);
    hold.push(goal(0.05));
    let mut over = per_position(&|w| w.overshoot_kgf, 1e-3);
    over.push(goal(0.05));
    let mut ratio = per_position(&|w| w.settle_ratio, 0.0);
    ratio.push(goal(1.5));
    let scenarios = args.scenarios.max(1) as f64;
    let failed = per_position(&|w| w.failed as f64 / scenarios * 100.0, 0.0);
    Figure::new(
        "taut report robustness: each axis of the family alone, worst case per position",
        &format!(
            "taut's controller, speed 9, {} scenario(s) per point (string kinds in turn, targets by kind within 8–35 kgf, seed {}), the machine's own calibration (reference gauge σ {:.3} kgf); 0 = the axis's low end, 1 = its high end",
            args.scenarios,
            args.seed,
            gauge_sigma_kgf(args.gauge_sigma)
        ),
        "uncertainty axis",
        vec![
            Panel::new("worst hold error (kgf, log; < 0.001 shown at 0.001)", hold).log(),
            Panel::new("worst overshoot (kgf, log; 0 shown at 0.001)", over).log(),
            Panel::new("worst settle / t_min", ratio),
            Panel::new("failed runs (%)", failed)
                .with_y_range(-5.0, 105.0)
                .with_height(120.0),
        ],
    )
    .with_categories(axes.iter().map(|a| a.name().to_owned()).collect())
}

/// The axes `args` ask for (all when none are named).
#[must_use]
pub fn axes(args: &RobustnessArgs) -> Vec<Axis> {
    if args.axes.is_empty() { Axis::ALL.to_vec() } else { args.axes.clone() }
}

/// Runs every point of every axis of `args` ([`axes`]) with a progress counter.
#[must_use]
pub fn run_all(args: &RobustnessArgs) -> Vec<Point> {
    let mut jobs: Vec<(Axis, f64, u64)> = Vec::new();
    for axis in axes(args) {
        for position in
            positions(args.points).into_iter().chain(beyond_positions(axis, args.beyond))
        {
            for index in 0..args.scenarios {
                jobs.push((axis, position, index));
            }
        }
    }
    let progress = Progress::new(jobs.len(), "runs");
    parallel(jobs.len() as u64, threads(args.threads), &progress, &|i| {
        let (axis, position, index) = jobs[i as usize];
        run_point(axis, position, index, args.seed, args.gauge_sigma)
    })
}

/// `taut report robustness`.
///
/// # Errors
/// An output file cannot be written.
pub fn main(args: &RobustnessArgs) -> Status {
    let outputs = Outputs::new()
        .file("--json", args.json.as_deref())
        .file("--svg", args.svg.as_deref())
        .check()?;
    if !args.corner.is_empty() {
        return corner_main(args, &outputs);
    }
    let axes = axes(args);
    let positions = positions(args.points);
    let started = std::time::Instant::now();
    let runs = run_all(args);
    let mut files = Vec::new();
    if let Some(path) = &args.json {
        files.push((path.clone(), json_bytes(&to_json(args, &axes, &runs))));
    }
    if let Some(path) = &args.svg {
        files.push((path.clone(), figure(args, &axes, &runs).to_svg().into_bytes()));
    }
    outputs.write(&files)?;
    println!("{}", markdown(&axes, &runs));
    let beyond = runs.iter().filter(|p| !p.in_family()).count();
    let refused = runs.iter().filter(|p| p.unphysical.is_some()).count();
    if beyond > 0 {
        println!(
            "Beyond the family: each axis's spans continued {:.2} of their width past either end (a margin, not a promise)\n",
            args.beyond
        );
        println!("{}", beyond_markdown(&axes, &runs, args.beyond));
    }
    println!(
        "{} runs ({} axes × {} points × {} scenarios{}), wall clock {:.1} s",
        runs.len() - beyond,
        axes.len(),
        positions.len(),
        args.scenarios,
        if beyond > 0 {
            format!(
                "; past the ends {} more, and {refused} not run as not physical",
                beyond - refused
            )
        } else {
            String::new()
        },
        started.elapsed().as_secs_f64()
    );
    if let Some(path) = &args.json {
        println!("summary: {}", path.display());
    }
    if let Some(path) = &args.svg {
        println!("plot: {}", path.display());
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_axis_row_is_rounded() {
        let table = markdown(&Axis::ALL, &[]);
        for line in table.lines() {
            assert!(super::super::rounded(line, 4), "a raw float in: {line}");
            assert!(!line.contains("  |"), "a stray space in: {line}");
        }
        assert!(table.contains("largest spike at 3 A 0 … 6.3 kgf"), "{table}");
    }

    #[test]
    fn numbers_are_rounded_to_significant_figures() {
        use super::super::{rounded, significant};
        assert_eq!(significant(6.304_347_826_086_957, 3), "6.3");
        assert_eq!(significant(0.86, 3), "0.86");
        assert_eq!(significant(1_200.0, 3), "1200");
        assert_eq!(significant(0.000_47, 3), "0.00047");
        assert_eq!(significant(0.0, 3), "0");
        assert!(!rounded("| spikes | 0 … 6.304347826086957 kgf |", 4));
        assert!(rounded("| 0.040 | 1.13 | 0 of 4 |", 4));
    }
}

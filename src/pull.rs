//! `taut pull`: one pull, hold and release with a tension controller alone on the twin
//! ([`taut_sim::bench::ControllerBench`]), on a machine calibrated by its own 4-point
//! calibration first.

use std::fmt::Write as _;

use taut_core::settings::PullKind;
use taut_core::tension::PullPhase;
use taut_sim::bench::{ControllerBench, ControllerRow, kgf};
use taut_sim::{StringKind, TwinConfig};

use crate::cli::{PullArgs, SensingArg};
use crate::output::{Failure, Outputs, Status, to_stderr};
use crate::plot::{Band, DUTY_AXIS_PERCENT, Figure, Panel, Series, Stroke};
use crate::report::accuracy::controller_config;
use crate::report::robustness::{corner_machine, describe_corner};
use crate::report::{Scenario, commissioned_calibration, pull_settings, signed_duty};

/// The longest a release may take before the run stops, ms.
pub const RELEASE_LIMIT_MS: u32 = 8_000;

/// What a pull ran on.
#[derive(Clone, Debug)]
pub struct PullSetup {
    /// The machine.
    pub twin: TwinConfig,
    /// The target, kgf.
    pub target_kgf: f64,
    /// Which machine, in words.
    pub machine: String,
}

/// The machine and target `args` ask for.
///
/// # Errors
/// A corner (`--axis` given more than once) that names an axis twice or is not physical:
/// a usage error, before anything runs.
pub fn setup(args: &PullArgs) -> Result<PullSetup, Failure> {
    if let Some(n) = args.scenario {
        let s = Scenario::new(1, n, SensingArg::Family);
        return Ok(PullSetup {
            twin: s.twin,
            target_kgf: s.target_kgf,
            machine: format!("scenario {n} of `taut report accuracy` (seed 1)"),
        });
    }
    let string: StringKind = args.string.map_or(StringKind::TennisSynthetic, Into::into);
    let target_kgf = args.tension.map_or(25.0, |sp| kgf(sp.to_kgf()));
    if !args.axis.is_empty() {
        return Ok(PullSetup {
            twin: corner_machine(&args.axis, string).map_err(Failure::Usage)?,
            target_kgf,
            machine: format!("the family's centre, {}", describe_corner(&args.axis, string)),
        });
    }
    let (twin, machine) = args.seed.map_or_else(
        || (TwinConfig::nominal(string), "nominal machine".to_owned()),
        |seed| (TwinConfig::family_kind(string, seed), format!("family machine {seed}")),
    );
    Ok(PullSetup { twin, target_kgf, machine })
}

/// The pull's one-line summary figures.
#[derive(Clone, Debug, PartialEq)]
pub struct PullSummary {
    /// Start until the controller's estimate stayed within 0.1 kgf of the target for 0.5 s.
    pub settle_s: Option<f64>,
    /// Largest true tension above the target, kgf.
    pub overshoot_kgf: f64,
    /// Largest |true − target| from 1 s after settling to the release, kgf.
    pub hold_error_kgf: Option<f64>,
    /// Largest true winding current, A.
    pub peak_current_a: f64,
    /// True tension at the release, kgf.
    pub tension_at_release_kgf: f64,
    /// Release until the carriage was home, s.
    pub release_s: Option<f64>,
    /// The drive faulted.
    pub drive_fault: bool,
}

/// Figures of a pull released at `release_s`.
#[must_use]
pub fn summarize(trace: &[ControllerRow], target: f64, release_s: f64) -> PullSummary {
    let pulled: Vec<&ControllerRow> = trace.iter().filter(|r| r.t_s <= release_s).collect();
    let metrics =
        crate::report::metrics(&pulled.iter().map(|r| **r).collect::<Vec<_>>(), target, Some(1.0));
    let hold: Vec<f64> = metrics.settle_s.map_or_else(Vec::new, |settle| {
        pulled
            .iter()
            .filter(|r| r.t_s >= settle + 1.0)
            .map(|r| (r.truth.tension_kgf - target).abs())
            .collect()
    });
    let idle = trace
        .iter()
        .find(|r| r.t_s > release_s && r.control.phase == PullPhase::Idle)
        .map(|r| r.t_s - release_s);
    PullSummary {
        settle_s: metrics.settle_s,
        overshoot_kgf: pulled.iter().map(|r| r.truth.tension_kgf - target).fold(0.0, f64::max),
        hold_error_kgf: (!hold.is_empty()).then(|| hold.iter().copied().fold(0.0, f64::max)),
        peak_current_a: metrics.peak_current_a,
        tension_at_release_kgf: pulled.last().map_or(0.0, |r| r.truth.tension_kgf),
        release_s: idle,
        drive_fault: trace.iter().any(|r| r.truth.drive_fault.is_some()),
    }
}

/// A controller phase's name and colour on the timeline.
const fn phase_band(phase: PullPhase) -> (&'static str, &'static str) {
    match phase {
        PullPhase::Idle => ("idle", "#e5e5e5"),
        PullPhase::TakeUp => ("take-up", "#9ecae1"),
        PullPhase::Approach => ("approach", "#6baed6"),
        PullPhase::PreStretch => ("pre-stretch", "#bcbddc"),
        PullPhase::Settle => ("settle", "#fdd0a2"),
        PullPhase::Hold => ("hold", "#31a354"),
        PullPhase::Release => ("release", "#fd8d3c"),
    }
}

/// One band per run of ticks in the same controller phase.
#[must_use]
pub fn phases(trace: &[ControllerRow]) -> Vec<Band> {
    let mut bands: Vec<Band> = Vec::new();
    let step = trace.get(1).zip(trace.first()).map_or(0.001, |(b, a)| b.t_s - a.t_s);
    for row in trace {
        let (name, colour) = phase_band(row.control.phase);
        match bands.last_mut() {
            Some(band) if band.key == name => band.to = row.t_s + step,
            _ => bands.push(Band {
                from: row.t_s,
                to: row.t_s + step,
                label: name.to_owned(),
                key: name.to_owned(),
                colour,
            }),
        }
    }
    bands
}

/// The hold zoom's measured tension is a running mean over this many ticks (1 ms each): the
/// load cell's raw noise (± 0.7 kgf on the family) would bury the true tension and the target
/// at ± 0.2 kgf; a 50 ms mean keeps the slow error a stringer would see.
pub const HOLD_MEAN_MS: usize = 50;

/// The running mean of `points`' values over the last `width` points (fewer at the start).
#[must_use]
pub fn running_mean(points: &[(f64, f64)], width: usize) -> Vec<(f64, f64)> {
    let mut sum = 0.0;
    points
        .iter()
        .enumerate()
        .map(|(k, &(t, v))| {
            sum += v;
            if k >= width {
                sum -= points[k - width].1;
            }
            (t, sum / (k + 1).min(width) as f64)
        })
        .collect()
}

/// The pull's plot: tension (true, measured, reference, target), carriage, duty, current,
/// the controller's phases on the same time axis, and the hold zoomed to ±0.2 kgf (the
/// measured tension there as a [`HOLD_MEAN_MS`] running mean).
#[must_use]
pub fn figure(
    trace: &[ControllerRow],
    target: f64,
    title: &str,
    subtitle: &str,
    settle_s: Option<f64>,
    release_s: f64,
) -> Figure {
    let series =
        |f: &dyn Fn(&ControllerRow) -> f64| trace.iter().map(|r| (r.t_s, f(r))).collect::<Vec<_>>();
    let target_line = vec![(0.0, target), (release_s, target)];
    let until_release = |f: &dyn Fn(&ControllerRow) -> f64| {
        trace.iter().filter(|r| r.t_s <= release_s).map(|r| (r.t_s, f(r))).collect::<Vec<_>>()
    };
    let mut panels = vec![
        Panel::new(
            "tension (kgf)",
            vec![
                Series::new("measured (calibrated)", series(&|r| r.measured_kgf))
                    .stroke(Stroke::Thin),
                Series::new("reference", until_release(&|r| kgf(r.control.reference)))
                    .stroke(Stroke::Dashed),
                Series::new("true", series(&|r| r.truth.tension_kgf)),
                Series::new("target", target_line).stroke(Stroke::Dashed).colour("#555555"),
            ],
        ),
        Panel::new(
            "carriage (mm)",
            vec![Series::new("position", series(&|r| r.truth.carriage_mm))],
        )
        .with_height(110.0),
        Panel::new(
            "duty (%, − = release)",
            vec![Series::new("duty", series(&|r| signed_duty(r) * 100.0))],
        )
        .with_y_range(-DUTY_AXIS_PERCENT, DUTY_AXIS_PERCENT)
        .with_height(110.0),
        Panel::new(
            "winding current (A)",
            vec![
                Series::new("tick mean", series(&|r| r.truth.current_a)),
                Series::new("peak in the tick", series(&|r| r.truth.peak_current_a))
                    .stroke(Stroke::Thin),
            ],
        )
        .with_height(110.0),
        Panel::timeline("phase", phases(trace)),
    ];
    let from = settle_s.unwrap_or(0.0).min(release_s - 0.5).max(0.0);
    let hold = |f: &dyn Fn(&ControllerRow) -> f64| {
        trace
            .iter()
            .filter(|r| r.t_s >= from && r.t_s <= release_s)
            .map(|r| (r.t_s, f(r) - target))
            .collect::<Vec<_>>()
    };
    panels.push(
        Panel::new(
            "hold: tension − target (kgf)",
            vec![
                Series::new(
                    &format!("measured, {HOLD_MEAN_MS} ms mean"),
                    running_mean(&hold(&|r| r.measured_kgf), HOLD_MEAN_MS),
                )
                .stroke(Stroke::Thin),
                Series::new("true", hold(&|r| r.truth.tension_kgf)),
                Series::new("target", vec![(from, 0.0), (release_s, 0.0)])
                    .stroke(Stroke::Dashed)
                    .colour("#555555"),
            ],
        )
        .with_y_range(-0.2, 0.2)
        .with_x_range(
            from,
            release_s.max(from + 0.1),
            "time since Start (s), from settling to the release",
        ),
    );
    Figure::new(title, subtitle, "time since Start (s)", panels)
}

/// The trace as CSV.
#[must_use]
pub fn csv(trace: &[ControllerRow]) -> String {
    let mut out = String::from(
        "time_s,true_kgf,measured_kgf,estimate_kgf,reference_kgf,duty_percent,carriage_mm,current_a,peak_current_a,bus_v,drive_fault\n",
    );
    for r in trace {
        let _ = writeln!(
            out,
            "{:.3},{:.4},{:.4},{:.4},{:.4},{:.2},{:.3},{:.3},{:.3},{:.2},{}",
            r.t_s,
            r.truth.tension_kgf,
            r.measured_kgf,
            kgf(r.control.tension),
            kgf(r.control.reference),
            signed_duty(r) * 100.0,
            r.truth.carriage_mm,
            r.truth.current_a,
            r.truth.peak_current_a,
            r.truth.bus_volts,
            u8::from(r.truth.drive_fault.is_some())
        );
    }
    out
}

/// A pull's record.
#[derive(Clone, Debug)]
pub struct PullRun {
    /// What it ran on.
    pub setup: PullSetup,
    /// Every tick from Start to home.
    pub trace: Vec<ControllerRow>,
    /// When the release began, s since Start.
    pub release_s: f64,
    /// Its figures.
    pub summary: PullSummary,
}

impl PullRun {
    /// The plot, titled with what was run.
    #[must_use]
    pub fn figure(&self, args: &PullArgs) -> Figure {
        let string = self.setup.twin.string.kind.name();
        let title = format!(
            "taut pull: {string} at {:.1} kgf, controller {}, speed {}",
            self.setup.target_kgf,
            args.controller.name(),
            args.speed
        );
        let subtitle = format!(
            "{}, current sensing {}, calibrated by the machine's own 4-point calibration; held {:.1} s, then released",
            self.setup.machine,
            self.setup.twin.current_sense.name(),
            args.hold
        );
        figure(
            &self.trace,
            self.setup.target_kgf,
            &title,
            &subtitle,
            self.summary.settle_s,
            self.release_s,
        )
    }
}

/// Runs the pull `args` ask for: commissioning (the machine's calibration), then the
/// controller pulls, holds for `--hold` and releases home.
///
/// # Errors
/// The machine is not physical, could not be calibrated, or the bench did not start.
pub fn run(args: &PullArgs) -> Result<PullRun, Failure> {
    let setup = setup(args)?;
    let calibration = commissioned_calibration(&setup.twin).map_err(|f| {
        Failure::Message(format!("the machine could not be calibrated ({})", f.name()))
    })?;
    let config = controller_config(args.controller);
    let mut bench = ControllerBench::new(&setup.twin, &config, calibration)
        .map_err(|e| Failure::Message(e.to_string()))?;
    bench.start(&pull_settings(setup.target_kgf, args.speed), PullKind::Main);
    let hold_ms = (args.hold * 1_000.0).round() as u32;
    let mut trace = Vec::with_capacity(hold_ms as usize + RELEASE_LIMIT_MS as usize);
    bench.run(hold_ms, &mut trace);
    let release_s = trace.last().map_or(0.0, |r| r.t_s);
    bench.release();
    for _ in 0..RELEASE_LIMIT_MS {
        let row = bench.tick();
        trace.push(row);
        if row.control.phase == PullPhase::Idle {
            break;
        }
    }
    let summary = summarize(&trace, setup.target_kgf, release_s);
    Ok(PullRun { setup, trace, release_s, summary })
}

/// `taut pull`: runs the pull, prints one line of figures, writes the plot and the CSV.
/// `Ok(false)` (exit 1, with a line on stderr saying why) when the tension never settled at
/// the target (no string, a machine that cannot reach it) or the drive faulted: the plot and
/// the trace are still written, they show what happened.
///
/// # Errors
/// The machine could not be calibrated, or a file cannot be written.
pub fn main(args: &PullArgs) -> Status {
    let outputs = Outputs::new()
        .file("--svg", args.svg.as_deref())
        .file("--csv", args.csv.as_deref())
        .check()?;
    let pull = run(args)?;
    let mut files = Vec::new();
    if let Some(path) = &args.svg {
        files.push((path.clone(), pull.figure(args).to_svg().into_bytes()));
    }
    if let Some(path) = &args.csv {
        files.push((path.clone(), csv(&pull.trace).into_bytes()));
    }
    outputs.write(&files)?;
    let (setup, s) = (&pull.setup, &pull.summary);
    let opt = |v: Option<f64>, unit: &str| {
        v.map_or_else(|| "never".to_owned(), |v| format!("{v:.3} {unit}"))
    };
    println!(
        "pull {} to {:.1} kgf ({}, speed {}, {}, current sensing {}): settled {}, overshoot {:.3} kgf, hold error {}, peak winding current {:.2} A, true tension at release {:.3} kgf, released in {}{}",
        setup.twin.string.kind.name(),
        setup.target_kgf,
        args.controller.name(),
        args.speed,
        setup.machine,
        setup.twin.current_sense.name(),
        opt(s.settle_s, "s"),
        s.overshoot_kgf,
        opt(s.hold_error_kgf, "kgf"),
        s.peak_current_a,
        s.tension_at_release_kgf,
        opt(s.release_s, "s"),
        if s.drive_fault { "; the drive faulted" } else { "" }
    );
    if let Some(path) = &args.svg {
        println!("plot: {}", path.display());
    }
    if let Some(path) = &args.csv {
        println!("trace: {}", path.display());
    }
    if s.settle_s.is_none() {
        to_stderr(&format!(
            "taut pull: the tension never settled at {:.1} kgf (exit status 1)\n",
            setup.target_kgf
        ));
    }
    if s.drive_fault {
        to_stderr("taut pull: the drive faulted (exit status 1)\n");
    }
    Ok(s.settle_s.is_some() && !s.drive_fault)
}

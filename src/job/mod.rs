//! The main job: one whole machine cycle on the digital twin, worked through the front
//! panel's keys by a simulated operator.
//!
//! # Theory of operation
//!
//! **The machine is the firmware's.** The job runs on [`taut_sim::bench::Bench`]: the very
//! state machine, controller and safety rules the firmware links, on the twin, tick by
//! tick, with a simulated flash. **The operator only presses keys**
//! ([`taut_sim::operator::Operator`]): it reads the 7-segment digits, the lamps and the
//! reference gauge, never the machine's state.
//!
//! **Two sessions, one flash.** [`taut_sim::bench::commission`] powers a new machine up with
//! factory defaults and a test string, has the operator run the 4-point calibration in the
//! machine's calibration states and leave the previous job's settings (22.0 kg, speed 3) on
//! the panel, and keeps the flash bytes the machine stored. [`run`] then powers the twin up
//! again from those bytes — as the next morning — and works the job: boot self-test, skip
//! the calibration window (Start), optionally toggle knot mode, walk the settings menu,
//! key the tension, press Start, wait for the holding lamp, hold for the set time while the
//! string creeps, press Start to release, and wait for the carriage to come home.
//!
//! **Figures.** Every tick is recorded as a [`taut_sim::bench::Row`];
//! [`summary`] turns the rows into the [`summary::Summary`] and [`figure`] into the plot,
//! whose state timeline is a panel of the same chart.

pub mod figure;
pub mod summary;

use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use taut_core::machine::PullRecord;
use taut_core::settings::Settings;
use taut_core::store::Record;
use taut_sim::TwinConfig;
use taut_sim::bench::{
    Bench, Commissioning, Progress, Row, Session, SessionError, Transition, commission,
    factory_config, kgf, run_session, state_name,
};
use taut_sim::operator::{Operator, display};

use crate::cli::{DEFAULT_CYCLE_SVG, JobArgs};
use crate::output::{Failure, Outputs, Status, json_bytes, to_stderr};

pub use taut_sim::job::{CycleOptions, DEFAULT_HOLD_MS};

/// The options the command line asks for (clap has validated every value).
#[must_use]
pub fn options_from_args(args: &JobArgs) -> CycleOptions {
    CycleOptions {
        set_point: args.tension,
        string: args.string.into(),
        speed: args.speed,
        pre_stretch_percent: args.pre_stretch,
        knot_percent: args.knot,
        seed: args.seed,
        hold_ms: (args.hold * 1_000.0).round() as u32,
        calibrate: !args.uncalibrated,
    }
}

/// Why the job could not run.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum JobError {
    /// The settings are outside the panel's ranges.
    Settings,
    /// A session failed.
    Session(SessionError),
}

impl std::fmt::Display for JobError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Settings => f.write_str("the settings are outside the panel's ranges"),
            Self::Session(error) => write!(f, "{error}"),
        }
    }
}

impl std::error::Error for JobError {}

/// The job's record.
#[derive(Clone, Debug)]
pub struct CycleRun {
    /// The options it ran with.
    pub options: CycleOptions,
    /// The machine it ran on.
    pub config: TwinConfig,
    /// The settings keyed in.
    pub settings: Settings,
    /// The commissioning session the machine's flash came from.
    pub commissioning: Commissioning,
    /// One row per tick.
    pub rows: Vec<Row>,
    /// Every state change, starting with the power-up state at 0.
    pub transitions: Vec<Transition>,
    /// The machine's log entry of the pull, if it completed.
    pub pull: Option<PullRecord>,
    /// The stored record at the end.
    pub record: Option<Record>,
    /// Key presses of the job.
    pub presses: u32,
    /// Store requests of the job.
    pub store_writes: u32,
    /// Whether the operator finished (back home, no fault).
    pub completed: bool,
    /// Wall-clock time of both sessions.
    pub wall: Duration,
}

impl CycleRun {
    /// The tension held and the pull's peak target, kgf.
    #[must_use]
    pub fn targets_kgf(&self) -> (f64, f64) {
        let pull = self.settings.pull();
        let kind = self.options.pull_kind();
        (kgf(pull.final_target(kind)), kgf(pull.peak_target(kind)))
    }
}

/// Runs the main job (see the module docs): commissioning (unless `commissioning` is
/// given: tests reuse one), then the job.
///
/// # Errors
/// Invalid settings, a failed commissioning, or the time limit.
pub fn run(
    options: &CycleOptions,
    commissioning: Option<&Commissioning>,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<CycleRun, JobError> {
    let started = Instant::now();
    let plan = options.plan().map_err(|_| JobError::Settings)?;
    let settings = plan.settings;
    let config = options.twin_config();
    let commissioning = match commissioning {
        Some(c) => c.clone(),
        None => commission(&factory_config(&config), options.calibrate, progress)
            .map_err(JobError::Session)?,
    };
    let mut bench = Bench::power_up(&config, &commissioning.flash).recording();
    let mut operator = Operator::new(plan);
    let mut tail: Option<u64> = None;
    run_session(&mut bench, &mut operator, Session::Job, progress, |bench, operator| {
        // A short tail after the operator is done keeps the last moments in the plot.
        if operator.finished() {
            let end = *tail.get_or_insert(bench.twin().now_ms() + 200);
            return bench.twin().now_ms() >= end;
        }
        false
    })
    .map_err(JobError::Session)?;
    let completed = operator.finished() && !operator.stopped() && bench.machine().fault().is_none();
    Ok(CycleRun {
        options: *options,
        config,
        settings,
        commissioning,
        transitions: bench.transitions().to_vec(),
        pull: bench.machine().log().last().copied(),
        record: Record::decode(bench.flash()).ok(),
        presses: operator.presses(),
        store_writes: bench.store_writes(),
        rows: bench.take_rows(),
        completed,
        wall: started.elapsed(),
    })
}

/// One progress line: session, time, state, panel text, true tension, what the operator does.
#[must_use]
pub fn progress_line(progress: &Progress<'_>) -> String {
    let session = match progress.session {
        Session::Commissioning => "commissioning",
        Session::Job => "job",
    };
    format!(
        "[{session:>13} {:7.3} s] {:<20} panel [{:<5}]  true {:6.2} kgf  operator: {}",
        progress.time_s,
        state_name(progress.state),
        display::text(&progress.display),
        progress.tension_kgf,
        progress.activity
    )
}

/// `taut` with no subcommand: runs the main job, prints progress on stderr (redrawn in
/// place on a terminal, one line per state change otherwise), the summary on stdout, writes
/// the plot (and the JSON). `Ok(true)` when the cycle completed.
///
/// # Errors
/// A session failed or a file could not be written.
pub fn main(args: &JobArgs) -> Status {
    // Fail on an output path before the run, not after it.
    let svg = args.svg.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_CYCLE_SVG));
    let outputs = Outputs::new()
        .file_or_default("--svg", args.svg.as_deref(), &svg)
        .file("--json", args.json.as_deref())
        .check()?;
    let options = options_from_args(args);
    let terminal = std::io::stderr().is_terminal();
    let mut shown = 0_u32;
    let mut progress = |p: &Progress<'_>| {
        if args.quiet {
            return;
        }
        if terminal {
            to_stderr(&format!("\r\x1b[2K{}", progress_line(p)));
        } else if p.state_changed || shown == 0 {
            to_stderr(&format!("{}\n", progress_line(p)));
        }
        shown += 1;
    };
    let result = run(&options, None, &mut progress);
    if terminal && !args.quiet {
        to_stderr("\n");
    }
    let run = result.map_err(|e| Failure::Message(e.to_string()))?;
    let mut files = vec![(svg.clone(), figure::figure(&run).to_svg().into_bytes())];
    if let Some(path) = &args.json {
        files.push((path.clone(), json_bytes(&summary::json(&run))));
    }
    outputs.write(&files)?;
    println!("{}", summary::table(&run));
    println!("plot: {}", svg.display());
    if let Some(path) = &args.json {
        println!("summary: {}", path.display());
    }
    Ok(run.completed)
}

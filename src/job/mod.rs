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
use taut_core::settings::{PullKind, SetPoint, Settings};
use taut_core::store::Record;
use taut_sim::bench::{
    Bench, Commissioning, Progress, Row, Session, SessionError, Transition, commission,
    factory_config, kgf, run_session, state_name,
};
use taut_sim::operator::{Operator, Plan, display};
use taut_sim::{StringKind, TwinConfig};

use crate::cli::{DEFAULT_CYCLE_SVG, JobArgs};
use crate::output::{Failure, Outputs, Status, json_bytes, to_stderr};

/// Default hold time of the job, ms: a few seconds of constant pull while the string creeps.
pub const DEFAULT_HOLD_MS: u32 = 5_000;

/// What the main job does: the operator's settings, the machine's string and scenario, how
/// long to hold.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct CycleOptions {
    /// The tension to set, in the unit the operator keys it in.
    pub set_point: SetPoint,
    /// The string on the machine.
    pub string: StringKind,
    /// Speed setting, 1–9.
    pub speed: u8,
    /// Pre-stretch, percent (0–30, steps of 5).
    pub pre_stretch_percent: u8,
    /// `Some(p)`: a knot pull with the knot increase set to `p` % (0–20, steps of 5).
    pub knot_percent: Option<u8>,
    /// Machine `seed` of the twin's family instead of the nominal machine.
    pub seed: Option<u64>,
    /// How long the operator lets the machine hold before releasing, ms.
    pub hold_ms: u32,
    /// Whether the commissioning session calibrates the load cell (otherwise the machine
    /// runs on the uncorrected, tared sensor).
    pub calibrate: bool,
}

impl Default for CycleOptions {
    fn default() -> Self {
        Self {
            set_point: SetPoint::DEFAULT,
            string: StringKind::TennisSynthetic,
            speed: 5,
            pre_stretch_percent: 0,
            knot_percent: None,
            seed: None,
            hold_ms: DEFAULT_HOLD_MS,
            calibrate: true,
        }
    }
}

impl CycleOptions {
    /// The options the command line asks for (clap has validated every value).
    #[must_use]
    pub fn from_args(args: &JobArgs) -> Self {
        Self {
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

    /// The panel settings the operator will key in.
    ///
    /// # Errors
    /// [`JobError::Settings`] when a value is out of the panel's range.
    pub fn settings(&self) -> Result<Settings, JobError> {
        Settings::new(
            self.set_point,
            self.speed,
            self.pre_stretch_percent,
            self.knot_percent.unwrap_or(0),
        )
        .map_err(|_| JobError::Settings)
    }

    /// The twin's configuration: nominal, or machine [`Self::seed`] of the family.
    #[must_use]
    pub fn twin_config(&self) -> TwinConfig {
        self.seed.map_or_else(
            || TwinConfig::nominal(self.string),
            |seed| TwinConfig::family_kind(self.string, seed),
        )
    }

    /// The kind of pull the job makes.
    #[must_use]
    pub const fn pull_kind(&self) -> PullKind {
        if self.knot_percent.is_some() { PullKind::Knot } else { PullKind::Main }
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
    let settings = options.settings()?;
    let config = options.twin_config();
    let commissioning = match commissioning {
        Some(c) => c.clone(),
        None => commission(&factory_config(&config), options.calibrate, progress)
            .map_err(JobError::Session)?,
    };
    let mut bench = Bench::power_up(&config, &commissioning.flash).recording();
    let plan = Plan {
        calibrate: false,
        settings,
        knot_mode: options.knot_percent.is_some(),
        pull_hold_ms: Some(options.hold_ms),
    };
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
    let options = CycleOptions::from_args(args);
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

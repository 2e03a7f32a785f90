//! The command line: every subcommand's arguments, validated by clap itself.
//!
//! Every value-taking option has a `value_parser` that rejects what the command cannot run
//! with — a range for numbers ([`ranged_f64`] also refuses NaN and infinities), a
//! [`clap::ValueEnum`] for names — so a bad value is a usage error (exit 2) in clap's one
//! message style (`error: invalid value 'nan' for '--hold <SECONDS>': …`) before anything
//! runs. Failures while running (a file that cannot be written) are one line
//! `error: …` and exit 1 ([`crate::output`]).

use std::ops::RangeInclusive;
use std::path::PathBuf;

use clap::builder::PossibleValue;
use clap::{Args, Parser, Subcommand, ValueEnum};
use taut_core::machine::string::{CREEP_SETTLE_MS, CREEP_WINDOW_MS};
use taut_core::settings::{SetPoint, Unit};
use taut_sim::{CurrentSenseParams, StringKind, TwinConfig};

/// What `taut --help` says after the options.
pub const AFTER_HELP: &str = "\
With no subcommand, taut runs the main job: a whole machine cycle on the digital twin through
the same machine the firmware links. A simulated operator commissions the machine (4-point
calibration against the reference gauge), then powers it up, keys the settings in on the
panel, presses Start, lets it hold while the string creeps and releases. Progress goes to
stderr, the summary table to stdout, the plot to --svg (out/cycle.svg).
Exit status: 0 the cycle completed, 1 it did not (a fault) or a file could not be written,
2 a usage error (a bad option, or an output path refused before the run: its folder missing,
a folder, or the same as another option's). Output files are replaced only when the run
completes its writing: a failed or interrupted run leaves the earlier files as they were.

Examples:
  taut                                   25 kg on tennis-synthetic, speed 5
  taut --tension 55lb --string tennis-poly --speed 9
  taut --pre-stretch 10 --knot --json out/cycle.json
  taut panel                             the front panel in this terminal";

/// `taut`: the host tool.
#[derive(Parser, Debug)]
#[command(
    name = "taut",
    version,
    about = "taut: the stringing machine's host tool (digital twin, reports)"
)]
#[command(args_conflicts_with_subcommands = true, after_help = AFTER_HELP)]
pub struct Cli {
    /// No subcommand: the main job (a whole machine cycle on the twin, see `taut --help`).
    #[command(subcommand)]
    pub command: Option<Command>,
    /// The main job's options.
    #[command(flatten)]
    pub job: JobArgs,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// The terminal front panel: the machine on the twin in real time (or from --script).
    ///
    /// Pages, from Ready: Function walks the settings — tension, SP speed, PS pre-stretch,
    /// Kn knot, unit, bE beeper, CP constant pull — back to the tension; Preset opens the
    /// presets (P n) and Function from there the information pages — r stringing timer, the pull
    /// log, the counters, the string (stiffness, creep), service — which Function walks
    /// back to the tension. Holding: Up/Down adjust the held tension, Function switches
    /// constant pull (LOCK / PULL), Preset shows the tension timer (t m.ss), Start releases.
    #[command(verbatim_doc_comment)]
    Panel(PanelArgs),
    /// The paper's simulation (section 7.3) with taut-core's fixed-point laws.
    Paper(PaperArgs),
    /// Reports on the twin.
    Report {
        /// Which report.
        #[command(subcommand)]
        which: ReportKind,
    },
    /// One pull, hold and release with a tension controller alone on the twin.
    Pull(PullArgs),
    /// Live tension and events from a machine over its link (--port PORT, or --twin).
    Connect(crate::link::commands::ConnectArgs),
    /// A machine's pull log, to CSV, JSON or the terminal, over its link.
    Log(crate::link::commands::LogArgs),
    /// A machine's settings, presets and calibration to a backup file, over its link.
    Backup(crate::link::commands::BackupArgs),
    /// A backup's settings, presets and calibration back onto a machine, over its link.
    Restore(crate::link::commands::RestoreArgs),
}

/// The reports.
#[derive(Subcommand, Debug)]
pub enum ReportKind {
    /// Monte-Carlo accuracy over the family of machines, against the true tension.
    Accuracy(AccuracyArgs),
    /// taut with each improvement switched off in turn, on the accuracy report's scenarios.
    Ablation(AblationArgs),
    /// Each uncertainty axis of the family swept alone from its low to its high end.
    Robustness(RobustnessArgs),
    /// Whole machine cycles across the family, with injected string breaks and faults.
    Machine(MachineArgs),
    /// The machine's string estimate (stiffness, creep) against the twin's truth, for every
    /// string preset on the nominal machine and machines of the family.
    String(StringArgs),
    /// A working day: many consecutive pulls on each of several machines of the family with
    /// the twin's slow drifts on (zero, creep, winding temperature, wear).
    Session(SessionArgs),
}

// ───────────────────────────── value parsers ─────────────────────────────

/// The shortest hold every command accepts, ms: the machine measures the creep over a fixed
/// window, [`CREEP_WINDOW_MS`] long from [`CREEP_SETTLE_MS`] into the hold, so a shorter hold
/// logs a pull without its creep.
pub const HOLD_MIN_MS: u32 = CREEP_SETTLE_MS + CREEP_WINDOW_MS;

/// The longest hold every command accepts, ms: ten minutes, longer than a stringer holds a
/// string, and still a few seconds of the twin's time per pull.
pub const HOLD_MAX_MS: u32 = 600_000;

/// The hold in seconds, for every command alike ([`HOLD_MIN_MS`]–[`HOLD_MAX_MS`], fractions
/// allowed).
///
/// # Errors
/// Not a number, not finite, or outside the range (the message says the range).
pub fn hold_seconds(text: &str) -> Result<f64, String> {
    ranged_f64(f64::from(HOLD_MIN_MS) / 1e3..=f64::from(HOLD_MAX_MS) / 1e3)(text)
}

/// A parser of finite `f64` values within `range` (NaN, infinities and values outside are
/// rejected with the range in the message).
pub fn ranged_f64(range: RangeInclusive<f64>) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |text: &str| {
        let value: f64 = text
            .trim()
            .parse()
            .map_err(|_| format!("`{text}` is not a number ({}–{})", range.start(), range.end()))?;
        if !value.is_finite() || !range.contains(&value) {
            return Err(format!("{value} is not in {}–{}", range.start(), range.end()));
        }
        Ok(value)
    }
}

/// A tension as the operator keys it: `25`, `25.5`, `25kg`, `55 lb` (kilograms unless `lb`):
/// 5.0–50.0 kg in 0.1 kg steps, or 11.5–110.0 lb in 0.5 lb steps.
///
/// # Errors
/// The text is not a number with an optional unit, or the value is not a set point.
pub fn parse_tension(text: &str) -> Result<SetPoint, String> {
    const RANGE: &str = "5.0–50.0 kg in 0.1 kg steps, or 11.5–110.0 lb in 0.5 lb steps";
    let lower = text.trim().to_ascii_lowercase();
    let (number, unit) = if let Some(n) = lower.strip_suffix("lbs").or(lower.strip_suffix("lb")) {
        (n, Unit::Pounds)
    } else if let Some(n) = lower.strip_suffix("kgf").or(lower.strip_suffix("kg")) {
        (n, Unit::Kilograms)
    } else {
        (lower.as_str(), Unit::Kilograms)
    };
    let value: f64 = number.trim().parse().map_err(|_| {
        format!("`{text}` is not a tension: a number with an optional unit (25, 25kg, 55lb)")
    })?;
    if !(0.0..=1_000.0).contains(&value) {
        return Err(format!("{value} is not a tension: {RANGE}"));
    }
    let tenths = (value * 10.0).round();
    if (value * 10.0 - tenths).abs() > 1e-6 {
        return Err(format!("{value} is not a tension: {RANGE}"));
    }
    SetPoint::new(unit, tenths as u16).map_err(|_| format!("{value} is not a tension: {RANGE}"))
}

/// A percentage from 0 to `max` in steps of 5.
fn percent_in_fives(max: u8) -> impl Fn(&str) -> Result<u8, String> + Clone {
    move |text: &str| {
        let value: u8 =
            text.trim().parse().map_err(|_| format!("`{text}` is not 0–{max} in steps of 5"))?;
        if value > max || !value.is_multiple_of(5) {
            return Err(format!("{value} is not 0–{max} in steps of 5"));
        }
        Ok(value)
    }
}

/// A parser of whole numbers within `lo..=hi` (signs, fractions, words and values outside
/// are rejected with the range in the message).
pub fn whole<T>(lo: T, hi: T) -> impl Fn(&str) -> Result<T, String> + Clone
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy + Send + Sync + 'static,
{
    move |text: &str| {
        let range = if hi_is_max(&hi) { format!("{lo} or more") } else { format!("{lo}–{hi}") };
        let value: T =
            text.trim().parse().map_err(|_| format!("`{text}` is not a whole number ({range})"))?;
        if value < lo || value > hi {
            return Err(format!("{value} is not in {range}"));
        }
        Ok(value)
    }
}

/// Whether `hi` is its type's largest value (printed as "or more").
fn hi_is_max<T: std::fmt::Display>(hi: &T) -> bool {
    hi.to_string() == u64::MAX.to_string()
}

/// Counts from 1 (`--scenarios`, `--cycles`): at least one.
fn count(max: u64) -> impl Fn(&str) -> Result<u64, String> + Clone {
    whole(1, max)
}

/// A seed: any whole number from 0.
fn seed(text: &str) -> Result<u64, String> {
    whole(0, u64::MAX)(text)
}

// ───────────────────────────── value enums ─────────────────────────────

/// A string kind on the command line: [`StringKind`] itself, every kind under its
/// [`StringKind::name`], with its [`StringKind::summary`] and its stiffness (`E·A/L`) as the
/// help; `tennis-polyester` is an alias of `tennis-poly`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct StringArg(pub StringKind);

/// Every [`StringArg`], in [`StringKind::ALL`]'s order.
const STRING_ARGS: [StringArg; StringKind::ALL.len()] = {
    let mut args = [StringArg(StringKind::NoString); StringKind::ALL.len()];
    let mut i = 0;
    while i < args.len() {
        args[i] = StringArg(StringKind::ALL[i]);
        i += 1;
    }
    args
};

impl ValueEnum for StringArg {
    fn value_variants<'a>() -> &'a [Self] {
        &STRING_ARGS
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let kind = self.0;
        let help = match kind.spec() {
            Some(spec) => format!("{} ({:.1} kgf/cm)", kind.summary(), spec.stiffness_kgf_per_cm()),
            None => kind.summary().to_owned(),
        };
        let value = PossibleValue::new(kind.name()).help(help);
        Some(if kind == StringKind::TennisPolyester {
            value.alias("tennis-polyester")
        } else {
            value
        })
    }
}

impl From<StringArg> for StringKind {
    fn from(value: StringArg) -> Self {
        value.0
    }
}

/// A tension controller.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, ValueEnum)]
pub enum ControllerArg {
    /// taut's controller (the one the machine runs).
    Taut,
    /// The paper's RSMC with its published law and gains.
    #[value(alias = "paper_rsmc")]
    PaperRsmc,
    /// The paper's PD baseline (kp = 100, kd = 20).
    Pd,
}

impl ControllerArg {
    /// The report name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Taut => "taut",
            Self::PaperRsmc => "paper_rsmc",
            Self::Pd => "pd",
        }
    }
}

/// Which current-sensing board the sampled machines have.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, ValueEnum)]
pub enum SensingArg {
    /// As the family draws it: ⅓ per-phase shunts, ⅓ DC link mid on-time, ⅓ DC link
    /// RC-filtered; the DC link's amplifier half unidirectional, half bidirectional.
    #[default]
    Family,
    /// taut's own board: a DC-link shunt sampled mid on-time, unidirectional amplifier.
    DcLink,
    /// Per-phase low-side shunts with bidirectional amplifiers.
    PerPhase,
}

impl SensingArg {
    /// The board as the command line names it (`family`, `dc-link`, `per-phase`), which the
    /// reports print and write to JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Family => "family",
            Self::DcLink => "dc-link",
            Self::PerPhase => "per-phase",
        }
    }

    /// `config` with this board.
    #[must_use]
    pub fn apply(self, mut config: TwinConfig) -> TwinConfig {
        match self {
            Self::Family => {}
            Self::DcLink => config.current_sense = CurrentSenseParams::dc_link_mid_on_time(false),
            Self::PerPhase => config.current_sense = CurrentSenseParams::per_phase_low_side(),
        }
        config
    }
}

// ───────────────────────────── the main job ─────────────────────────────

/// The main job's plot when `--svg` is not given.
pub const DEFAULT_CYCLE_SVG: &str = "out/cycle.svg";

/// The main job's command-line options (`taut` with no subcommand).
#[derive(Args, Clone, Debug)]
pub struct JobArgs {
    /// Tension to set on the panel: kilograms, or with a unit (25, 25.5kg, 55lb).
    #[arg(long, allow_negative_numbers = true, default_value = "25", value_parser = parse_tension, value_name = "KGF")]
    pub tension: SetPoint,
    /// String on the machine.
    #[arg(long, value_enum, default_value = "tennis-synthetic", value_name = "KIND")]
    pub string: StringArg,
    /// Speed setting, 1 (gentlest) to 9 (fastest).
    #[arg(long, allow_negative_numbers = true, default_value_t = 5, value_parser = whole(1_u8, 9))]
    pub speed: u8,
    /// Pre-stretch, percent above the tension (0–30, steps of 5).
    #[arg(long = "pre-stretch", allow_negative_numbers = true, default_value_t = 0, value_name = "PCT", value_parser = percent_in_fives(30))]
    pub pre_stretch: u8,
    /// Make a knot pull: knot mode on, knot increase PCT (0–20, steps of 5; 15 if omitted).
    #[arg(long, allow_negative_numbers = true, num_args = 0..=1, default_missing_value = "15", value_name = "PCT", value_parser = percent_in_fives(20))]
    pub knot: Option<u8>,
    /// Run machine N of the twin's family (`TwinConfig::family_kind`: motor, drivetrain,
    /// sensors and board drawn from their ranges) instead of the nominal machine.
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = seed)]
    pub seed: Option<u64>,
    /// Seconds the operator lets the machine hold before releasing (5–600, as in every
    /// command: the creep window ends 5 s into the hold).
    #[arg(long, allow_negative_numbers = true, default_value = "5", value_name = "SECONDS", value_parser = hold_seconds)]
    pub hold: f64,
    /// Skip the commissioning calibration: the machine runs on the tared, uncorrected sensor.
    #[arg(long)]
    pub uncalibrated: bool,
    /// Where to write the plot (default out/cycle.svg, its folder `out` created if missing;
    /// a given path's folder must exist).
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Also write the summary as JSON here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// No progress on stderr.
    #[arg(long)]
    pub quiet: bool,
}

// ───────────────────────────── panel ─────────────────────────────

/// What the machine's flash holds at power-up.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, ValueEnum)]
pub enum Flash {
    /// The record a commissioning session leaves (4-point calibration, previous job's
    /// settings), as the main job uses.
    #[default]
    Calibrated,
    /// Factory defaults (25.0 kg, no calibration): calibrate it yourself in the `CAL?`
    /// window with Function, reading the gauge.
    Factory,
    /// Erased flash: the machine starts on defaults and shows the `n-01` notice.
    Blank,
}

/// `taut panel` options.
#[derive(Args, Clone, Debug)]
pub struct PanelArgs {
    /// String on the machine.
    #[arg(long, value_enum, default_value = "tennis-synthetic", value_name = "KIND")]
    pub string: StringArg,
    /// Machine N of the twin's family instead of the nominal machine.
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = seed)]
    pub seed: Option<u64>,
    /// What the machine's flash holds at power-up.
    #[arg(long, value_enum, default_value_t = Flash::Calibrated)]
    pub flash: Flash,
    /// Run this script (`-` = standard input) instead of the interactive panel; prints a
    /// transcript to stdout. See `taut panel --help-script`.
    #[arg(long, value_name = "FILE")]
    pub script: Option<PathBuf>,
    /// Script mode: also print the whole panel after every command.
    #[arg(long)]
    pub frames: bool,
    /// Interactive mode: machine milliseconds per real millisecond (0.1–100).
    #[arg(long, allow_negative_numbers = true, default_value = "1", value_name = "FACTOR", value_parser = ranged_f64(0.1..=100.0))]
    pub rate: f64,
    /// Keep the machine's flash (settings, presets, calibration, counters) in FILE between
    /// sessions: power up from FILE when it exists (instead of --flash), and leave in it what
    /// the machine last stored when the session ends.
    #[arg(long, value_name = "FILE")]
    pub state: Option<PathBuf>,
    /// Print the script format and exit.
    #[arg(long)]
    pub help_script: bool,
}

// ───────────────────────────── paper, pull ─────────────────────────────

/// `taut paper` options.
#[derive(Args, Clone, Debug)]
pub struct PaperArgs {
    /// Write the headline figures as JSON here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the figure 18–20 plot here.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
}

/// `taut pull` options.
#[derive(Args, Clone, Debug)]
pub struct PullArgs {
    /// Target tension (5.0–50.0 kg in 0.1 kg steps, or with a unit: 55lb).
    #[arg(long, allow_negative_numbers = true, value_parser = parse_tension, value_name = "KGF", conflicts_with = "scenario")]
    pub tension: Option<SetPoint>,
    /// String kind.
    #[arg(long, value_enum, value_name = "KIND", conflicts_with = "scenario")]
    pub string: Option<StringArg>,
    /// Controller.
    #[arg(long, value_enum, default_value = "taut")]
    pub controller: ControllerArg,
    /// Speed setting, 1–9.
    #[arg(long, allow_negative_numbers = true, default_value_t = 9, value_parser = whole(1_u8, 9))]
    pub speed: u8,
    /// Seconds to hold after Start before releasing (5–600, as in every command).
    #[arg(long, allow_negative_numbers = true, default_value = "12", value_name = "SECONDS", value_parser = hold_seconds)]
    pub hold: f64,
    /// Machine N of the twin's family instead of the nominal machine.
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = seed, conflicts_with = "scenario")]
    pub seed: Option<u64>,
    /// Re-run scenario N of `taut report accuracy` (seed 1): its machine, string and target.
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = seed)]
    pub scenario: Option<u64>,
    /// The machine of `taut report robustness` at one point of one axis, the rest of the
    /// family at its centre: `NAME=POSITION`, the position 0 (the axis's low end) to 1 (its
    /// high end), e.g. `friction=1` (with `--string` and `--tension`). Given again with
    /// another axis, a corner of the family: every named axis moved at once.
    #[arg(long, value_name = "NAME=POSITION", value_parser = parse_axis_point, conflicts_with_all = ["scenario", "seed"])]
    pub axis: Vec<(taut_sim::Axis, f64)>,
    /// Write a plot (tension, hold error, carriage, duty, current) here.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Write every tick (time, true/measured/estimated tension, reference, duty, carriage,
    /// current) as CSV here.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
}

// ───────────────────────────── reports ─────────────────────────────

/// `taut report accuracy` options.
#[derive(Args, Clone, Debug)]
pub struct AccuracyArgs {
    /// Number of scenarios (machines of the family, each with a string and a target).
    #[arg(long, allow_negative_numbers = true, default_value_t = 200, value_parser = count(1_000_000))]
    pub scenarios: u64,
    /// Seed of the scenario draw.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = seed)]
    pub seed: u64,
    /// Controllers to run on every scenario (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "taut")]
    pub controllers: Vec<ControllerArg>,
    /// The machines' current-sensing board.
    #[arg(long, value_enum, default_value_t = SensingArg::Family)]
    pub sensing: SensingArg,
    /// The standard deviation of the reference gauge the machines are calibrated against, kgf
    /// (default: the family's, 0.02). 0 is an exact gauge: what the controller holds when
    /// the calibration instrument is taken out of the error.
    #[arg(long = "gauge-sigma", allow_negative_numbers = true, value_name = "KGF", value_parser = ranged_f64(0.0..=1.0))]
    pub gauge_sigma: Option<f64>,
    /// Worker threads (default: the machine's cores).
    #[arg(long, allow_negative_numbers = true, value_parser = whole(1_u16, 256))]
    pub threads: Option<u16>,
    /// Write the JSON summary here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the SVG plots into this directory.
    #[arg(long, value_name = "DIR")]
    pub svg: Option<PathBuf>,
    /// Also print one line per scenario.
    #[arg(long)]
    pub detail: bool,
}

/// `taut report ablation` options.
#[derive(Args, Clone, Debug)]
pub struct AblationArgs {
    /// Number of scenarios.
    #[arg(long, allow_negative_numbers = true, default_value_t = 200, value_parser = count(1_000_000))]
    pub scenarios: u64,
    /// Seed of the scenario draw.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = seed)]
    pub seed: u64,
    /// The machines' current-sensing board.
    #[arg(long, value_enum, default_value_t = SensingArg::Family)]
    pub sensing: SensingArg,
    /// Worker threads (default: the machine's cores).
    #[arg(long, allow_negative_numbers = true, value_parser = whole(1_u16, 256))]
    pub threads: Option<u16>,
    /// Write the JSON summary here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

/// `taut report robustness` options.
#[derive(Args, Clone, Debug)]
pub struct RobustnessArgs {
    /// Scenarios (string kind and target) per point of each axis.
    #[arg(long, allow_negative_numbers = true, default_value_t = 4, value_parser = count(10_000))]
    pub scenarios: u64,
    /// Points per axis, evenly from its low end (0) to its high end (1); at least 2.
    #[arg(long, allow_negative_numbers = true, default_value_t = 3, value_parser = whole(2_u64, 21))]
    pub points: u64,
    /// Only these axes (comma-separated names, e.g. inertia,friction); default all.
    #[arg(long, value_delimiter = ',', value_parser = parse_axis)]
    pub axes: Vec<taut_sim::Axis>,
    /// Also run each axis this fraction of its width past either end (0–1: 0.5 runs
    /// positions −0.5 and 1.5), a margin beyond the family, in a table of its own; a
    /// machine that is not physical there is listed, not run.
    #[arg(long, allow_negative_numbers = true, value_name = "FRACTION", default_value_t = 0.0, value_parser = ranged_f64(0.0..=taut_sim::family::BEYOND_MAX))]
    pub beyond: f64,
    /// Instead of the sweep, the scenarios on one corner of the family: every axis given
    /// (once each, `NAME=POSITION`, −1 … 2) moved at once, the rest at the centre.
    #[arg(long, value_name = "NAME=POSITION", allow_negative_numbers = true, value_parser = parse_axis_point_beyond, conflicts_with_all = ["axes", "points", "beyond", "svg"])]
    pub corner: Vec<(taut_sim::Axis, f64)>,
    /// Seed of the scenario draw.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = seed)]
    pub seed: u64,
    /// The standard deviation of the reference gauge the machines are calibrated against, kgf
    /// (default: the family's, 0.02); 0 is an exact gauge.
    #[arg(long = "gauge-sigma", allow_negative_numbers = true, value_name = "KGF", value_parser = ranged_f64(0.0..=1.0))]
    pub gauge_sigma: Option<f64>,
    /// Worker threads (default: the machine's cores).
    #[arg(long, allow_negative_numbers = true, value_parser = whole(1_u16, 256))]
    pub threads: Option<u16>,
    /// Write the JSON summary here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the SVG plot here.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
}

/// An uncertainty axis by name.
fn parse_axis(text: &str) -> Result<taut_sim::Axis, String> {
    text.parse().map_err(|_| {
        let names: Vec<&str> = taut_sim::Axis::ALL.iter().map(|a| a.name()).collect();
        format!("`{text}` is not an axis (one of: {})", names.join(", "))
    })
}

/// One point of an uncertainty axis: `NAME=POSITION`, the position in 0–1.
fn parse_axis_point(text: &str) -> Result<(taut_sim::Axis, f64), String> {
    axis_point_within(text, 0.0..=1.0)
}

/// One point of an uncertainty axis, past its ends too: `NAME=POSITION`, the position in
/// `−BEYOND_MAX ..= 1 + BEYOND_MAX` (whether the machine there is physical is checked when
/// it is built).
fn parse_axis_point_beyond(text: &str) -> Result<(taut_sim::Axis, f64), String> {
    let beyond = taut_sim::family::BEYOND_MAX;
    axis_point_within(text, -beyond..=1.0 + beyond)
}

/// `NAME=POSITION` with the position in `range`.
fn axis_point_within(
    text: &str,
    range: RangeInclusive<f64>,
) -> Result<(taut_sim::Axis, f64), String> {
    let (name, position) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}` is not NAME=POSITION (e.g. friction=1)"))?;
    let axis = parse_axis(name)?;
    let position = ranged_f64(range)(position)?;
    Ok((axis, position))
}

/// `taut report machine` options.
#[derive(Args, Clone, Debug)]
pub struct MachineArgs {
    /// Number of whole machine cycles (boot, set, pull, hold, release).
    #[arg(long, allow_negative_numbers = true, default_value_t = 100, value_parser = count(1_000_000))]
    pub cycles: u64,
    /// Seed of the machine draw.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = seed)]
    pub seed: u64,
    /// Break the string during the hold in every Kth cycle (0: never).
    #[arg(long, allow_negative_numbers = true, default_value_t = 10, value_name = "K", value_parser = seed)]
    pub break_every: u64,
    /// Inject a real fault (in turn a 95 % phase short, a seized carriage and an 80 % phase short) during the pull
    /// in every Kth cycle (0: never).
    #[arg(long, allow_negative_numbers = true, default_value_t = 25, value_name = "K", value_parser = seed)]
    pub fault_every: u64,
    /// The machines' current-sensing board.
    #[arg(long, value_enum, default_value_t = SensingArg::Family)]
    pub sensing: SensingArg,
    /// Every cycle on the machine of `taut report robustness` at one point of one axis (the
    /// string kinds in turn, the rest of the family at its centre) instead of the family's
    /// draws: `NAME=POSITION`, 0 the axis's low end, 1 its high end, −1 … 2 past them.
    /// Given again with another axis, a corner of the family: every named axis moved at once.
    #[arg(long, value_name = "NAME=POSITION", allow_negative_numbers = true, value_parser = parse_axis_point_beyond)]
    pub axis: Vec<(taut_sim::Axis, f64)>,
    /// Worker threads (default: the machine's cores).
    #[arg(long, allow_negative_numbers = true, value_parser = whole(1_u16, 256))]
    pub threads: Option<u16>,
    /// Write the JSON summary here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Also print one line per cycle.
    #[arg(long)]
    pub detail: bool,
}

/// `taut report session` options.
#[derive(Args, Clone, Debug)]
pub struct SessionArgs {
    /// Machines of the family, one session each.
    #[arg(long, allow_negative_numbers = true, default_value_t = 10, value_parser = whole(1_u64, 10_000))]
    pub machines: u64,
    /// Consecutive pulls per session.
    #[arg(long, allow_negative_numbers = true, default_value_t = 200, value_parser = whole(1_u64, 100_000))]
    pub pulls: u64,
    /// Seed of the machine draw.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = seed)]
    pub seed: u64,
    /// Worker threads (default: the machine's cores).
    #[arg(long, allow_negative_numbers = true, value_parser = whole(1_u16, 256))]
    pub threads: Option<u16>,
    /// Write the JSON summary here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

/// `taut report string` options.
#[derive(Args, Clone, Debug)]
pub struct StringArgs {
    /// Machines of the family per string preset, beside the nominal machine.
    #[arg(long, allow_negative_numbers = true, default_value_t = 2, value_parser = whole(0_u64, 1_000))]
    pub seeds: u64,
    /// Seconds the operator holds before releasing (5–600, as in every command; the creep
    /// window is from 1 s to 5 s of the hold).
    #[arg(long, allow_negative_numbers = true, default_value = "20", value_name = "SECONDS", value_parser = hold_seconds)]
    pub hold: f64,
    /// Write the JSON summary here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tension_parser_accepts_units_and_rejects_off_step_values() {
        assert_eq!(parse_tension("25").map(|s| s.tenths()), Ok(250));
        assert_eq!(parse_tension("55 lb").map(|s| s.unit()), Ok(Unit::Pounds));
        for bad in ["25.55", "4.9", "50.1", "nan", "inf", "-5", "abc", "55.3lb"] {
            assert!(parse_tension(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn ranged_floats_refuse_nan_and_infinity() {
        let parse = ranged_f64(0.0..=120.0);
        assert_eq!(parse("5"), Ok(5.0));
        for bad in ["nan", "inf", "-inf", "-1", "120.5", "abc", ""] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn sensing_boards_are_named_as_the_command_line_takes_them() {
        for board in SensingArg::value_variants() {
            let typed = board.to_possible_value().map(|v| v.get_name().to_owned());
            assert_eq!(typed.as_deref(), Some(board.name()));
            assert_eq!(SensingArg::from_str(board.name(), false), Ok(*board));
        }
    }

    #[test]
    fn every_string_kind_is_taken_under_its_name() {
        assert_eq!(StringArg::value_variants().len(), StringKind::ALL.len());
        for kind in StringKind::ALL {
            let arg = StringArg::from_str(kind.name(), false).map(StringKind::from);
            assert_eq!(arg, Ok(kind), "{kind}");
            let named = StringArg(kind).to_possible_value().map(|v| v.get_name().to_owned());
            assert_eq!(named.as_deref(), Some(kind.name()));
            assert_eq!(kind.name().parse::<StringKind>(), Ok(kind));
            for command in [&["taut"][..], &["taut", "panel"], &["taut", "pull"]] {
                let line = [command, &["--string", kind.name()]].concat();
                let parsed = Cli::try_parse_from(&line).map(|cli| match cli.command {
                    None => Some(cli.job.string),
                    Some(Command::Panel(args)) => Some(args.string),
                    Some(Command::Pull(args)) => args.string,
                    Some(_) => None,
                });
                assert_eq!(parsed.ok().flatten().map(StringKind::from), Some(kind), "{line:?}");
            }
        }
        let long = StringArg::from_str("tennis-polyester", false).map(StringKind::from);
        assert_eq!(long, Ok(StringKind::TennisPolyester));
    }

    #[test]
    fn version_prints_the_package_version_and_exits_0() {
        use clap::CommandFactory as _;
        let shown = Cli::try_parse_from(["taut", "--version"]).map(|_| ()).unwrap_err();
        assert_eq!(shown.kind(), clap::error::ErrorKind::DisplayVersion);
        assert_eq!(shown.exit_code(), 0);
        let text = Cli::command().render_version();
        assert_eq!(text, format!("taut {}\n", env!("CARGO_PKG_VERSION")));
    }

    #[test]
    fn the_command_line_is_consistent() {
        use clap::CommandFactory as _;
        Cli::command().debug_assert();
    }
}

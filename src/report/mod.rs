//! The reports: Monte-Carlo runs on the family of machines, each through the one bench.
//!
//! - [`accuracy`]: controllers on scenarios of the family (machine, string, target), the
//!   figures its goals are stated in (`docs/RESULTS.md`), against the *true* tension;
//! - [`ablation`]: taut with each improvement switched off in turn, on the same scenarios;
//! - [`robustness`]: each uncertainty axis of the family swept alone;
//! - [`machine`]: whole machine cycles with injected string breaks and faults;
//! - [`string`]: the machine's string estimate (stiffness, creep) against the twin's truth.
//!
//! # A scenario, and a pull on it
//!
//! A [`Scenario`] is a machine of the family ([`TwinConfig::family`], its string kind
//! drawn with it) and a target drawn from the kind's stringing range within 8–35 kgf (badminton 8–15/16, tennis 15–35), both from the scenario's seed. It is
//! commissioned first: the simulated operator runs the **machine's own 4-point calibration**
//! on the bench against the twin's reference gauge ([`taut_sim::bench::commission`]); the
//! calibration the machine stores is then used by every controller on that scenario
//! ([`taut_sim::bench::calibration_of`]), so the calibration's own error counts in the hold
//! error, as on a real machine. A machine that faults during commissioning (a board the
//! core cannot read yet, a drive trip) fails the scenario for every controller. Each
//! controller then pulls (speed 9, no pre-stretch) on a fresh twin of the same machine for
//! [`PULL_MS`] ([`taut_sim::bench::ControllerBench`]). [`metrics`]:
//!
//! - **settle time**: Start to the first moment after which the **true** tension stays
//!   within 0.1 kgf of the target for 0.5 s (as every other figure, against the true
//!   tension: judged on the controller's estimate — what the machine shows — the figure
//!   measured the estimate's noise as much as the string, and a hold that trades a little
//!   estimate noise for a shallower sawtooth, REQ-TEN-19, read as settling later while the
//!   string had not moved);
//! - **settle / t_min**: over the bang-bang oracle's time to first reach the target
//!   ([`taut_sim::bang_bang_reach_time`]: the fastest pull the mechanism permits);
//! - **hold error**: the largest |true tension − target| from 1 s to 10 s after settling;
//! - **overshoot**: the largest true tension above the target before the hold window;
//! - **chattering**: total variation of the signed duty per second over the hold window;
//! - **peak current**: the largest true winding current of the run; **bus**: the highest bus
//!   voltage;
//! - **failed**, with the reason: commissioning faulted, the drive faulted, the tension never
//!   settled, the target is beyond the machine's reach (the oracle meets the end of travel
//!   first), or the carriage reached its end of travel during the run (the target was just
//!   within reach, but the string's creep in the hold needed more travel). Quantiles are over the scenarios that did not fail; the failures are counted
//!   beside them.

pub mod ablation;
pub mod accuracy;
pub mod machine;
pub mod robustness;
pub mod session;
pub mod string;

use taut_core::sense::calibration::Calibration;
use taut_core::settings::{KnotBoost, PreStretch, PullKind, PullSettings, Speed};
use taut_core::tension::ControllerConfig;
use taut_sim::bench::{
    ControllerBench, ControllerRow, calibration_of, commission, factory_config, fault_name, to_kgf,
};
use taut_sim::{SimRng, StringKind, TwinConfig};

use crate::cli::SensingArg;

/// Ticks simulated per pull: settle (≤ 4 s) + 10 s of hold + margin.
pub const PULL_MS: u32 = 16_000;
/// Band of the settling criterion, kgf.
pub const SETTLE_BAND_KGF: f64 = 0.1;
/// How long the measured tension must stay in the band, s.
pub const SETTLE_HOLD_S: f64 = 0.5;
/// Hold window after settling, s.
pub const HOLD_WINDOW_S: (f64, f64) = (1.0, 10.0);
/// How long the oracle may take, ms.
pub const ORACLE_LIMIT_MS: u32 = 10_000;
/// The range targets are drawn from, kgf.
pub const TARGETS_KGF: (f64, f64) = (8.0, 35.0);

/// Why a run failed.
#[derive(Clone, PartialEq, Eq, Debug)]
pub enum Failure {
    /// The machine faulted (or was rejected) during commissioning: the code or reason.
    Commissioning(String),
    /// The controller bench could not start (the load cell's zero).
    Bench(String),
    /// The drive latched a fault during the pull.
    DriveFault,
    /// The tension never settled within the run.
    NeverSettled,
    /// The target is beyond the machine's reach.
    Unreachable,
    /// The carriage reached its end of travel during the run: the string's stretch at the
    /// target and its creep in the hold need more travel than the machine has.
    OutOfTravel,
}

impl Failure {
    /// A short name for tables and JSON.
    #[must_use]
    pub fn name(&self) -> String {
        match self {
            Self::Commissioning(why) => format!("commissioning: {why}"),
            Self::Bench(why) => format!("bench: {why}"),
            Self::DriveFault => "drive fault in the pull".to_owned(),
            Self::NeverSettled => "never settled".to_owned(),
            Self::Unreachable => "target beyond reach".to_owned(),
            Self::OutOfTravel => "end of travel in the hold".to_owned(),
        }
    }
}

/// One pull's figures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Settle time, s (`None` = never settled).
    pub settle_s: Option<f64>,
    /// Settle time over the oracle's reach time.
    pub settle_ratio: Option<f64>,
    /// Largest |true − target| in the hold window, kgf.
    pub hold_error_kgf: f64,
    /// Mean true − target in the hold window, kgf: the static part of the hold error.
    pub hold_offset_kgf: f64,
    /// Largest − smallest true tension in the hold window, kgf: its ripple, the stick-slip
    /// sawtooth included.
    pub hold_p2p_kgf: f64,
    /// PWM periods in the hold window in which the drive coasted under a command because its
    /// duty window was empty (`Drive::coasting`).
    pub hold_coasting: u32,
    /// Mean true − measured (the machine's calibrated reading) in the hold window, kgf: the
    /// part of the static error that is the sensing's (calibration, load cell), not the law's.
    pub sense_offset_kgf: f64,
    /// Largest true tension above the target before the hold window, kgf.
    pub overshoot_kgf: f64,
    /// Total variation of duty per second in the hold window.
    pub chattering: f64,
    /// Largest true winding current, A.
    pub peak_current_a: f64,
    /// Highest DC bus voltage, V.
    pub bus_peak_v: f64,
    /// Why it failed, if it did.
    pub failure: Option<Failure>,
}

impl Metrics {
    /// A run that failed before it pulled.
    #[must_use]
    pub fn failed(failure: Failure) -> Self {
        Self { failure: Some(failure), ..Self::default() }
    }
}

/// A scenario: a machine of the family and a target.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// The scenario's index in its run.
    pub index: u64,
    /// The machine.
    pub twin: TwinConfig,
    /// The target tension, kgf (a multiple of 0.1).
    pub target_kgf: f64,
}

/// The seed of scenario `index` of a run seeded `seed`.
#[must_use]
pub const fn scenario_seed(seed: u64, index: u64) -> u64 {
    seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(index)
}

/// The targets drawn for a `kind` of string: its stringing range within [`TARGETS_KGF`]
/// (badminton 8–15/16 kgf, tennis 15–35 kgf; the whole range without a string).
#[must_use]
pub fn target_range(kind: StringKind) -> (f64, f64) {
    kind.spec().map_or(TARGETS_KGF, |spec| {
        let (low, high) = spec.tension_range_kgf;
        (low.max(TARGETS_KGF.0), high.min(TARGETS_KGF.1))
    })
}

/// A target for a `kind` of string drawn from [`target_range`] with `seed`, to 0.1 kgf.
#[must_use]
pub fn draw_target(seed: u64, kind: StringKind) -> f64 {
    let mut rng = SimRng::substream(seed, 0x7A26);
    let (low, high) = target_range(kind);
    (rng.range(low, high) * 10.0).round() / 10.0
}

impl Scenario {
    /// Scenario `index` of the run seeded `seed`, on boards chosen by `sensing`.
    #[must_use]
    pub fn new(seed: u64, index: u64, sensing: SensingArg) -> Self {
        let s = scenario_seed(seed, index);
        let twin = sensing.apply(TwinConfig::family(s));
        let target_kgf = draw_target(s, twin.string.kind);
        Self { index, twin, target_kgf }
    }

    /// The same scenario calibrated against a reference gauge of standard deviation
    /// `sigma_kgf` (`None`: the family's).
    #[must_use]
    pub fn with_gauge_sigma(mut self, sigma_kgf: Option<f64>) -> Self {
        if let Some(sigma) = sigma_kgf {
            self.twin.reference_gauge_sigma_kgf = sigma;
        }
        self
    }

    /// A scenario on a given machine.
    #[must_use]
    pub const fn on(index: u64, twin: TwinConfig, target_kgf: f64) -> Self {
        Self { index, twin, target_kgf }
    }
}

/// How a Monte-Carlo report's machines are drawn besides the seed: the current-sensing board
/// and the reference gauge they are commissioned against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Machines {
    /// The current-sensing board.
    pub sensing: SensingArg,
    /// The reference gauge's standard deviation, kgf (`None`: the family's).
    pub gauge_sigma: Option<f64>,
}

impl Machines {
    /// Scenario `index` of the run seeded `seed` on these machines.
    #[must_use]
    pub fn scenario(self, seed: u64, index: u64) -> Scenario {
        Scenario::new(seed, index, self.sensing).with_gauge_sigma(self.gauge_sigma)
    }
}

/// The reference gauge's standard deviation a report's machines are calibrated with, kgf:
/// `gauge`, or the family's.
#[must_use]
pub fn gauge_sigma_kgf(gauge: Option<f64>) -> f64 {
    gauge.unwrap_or(taut_sim::params::REFERENCE_GAUGE_SIGMA_KGF)
}

/// The machine's calibration of `twin`: a commissioning session through the machine's own
/// calibration states, or why it failed.
///
/// # Errors
/// The session's failure, worded.
pub fn commissioned_calibration(twin: &TwinConfig) -> Result<Calibration, Failure> {
    commission(&factory_config(twin), true, &mut |_| {}).map(|c| calibration_of(&c.record)).map_err(
        |e| {
            Failure::Commissioning(match e {
                taut_sim::bench::SessionError::CommissioningFault(code) => fault_name(code),
                other => other.to_string(),
            })
        },
    )
}

/// The pull settings of a report pull: `target_kgf` at `speed`, no pre-stretch.
#[must_use]
pub fn pull_settings(target_kgf: f64, speed: u8) -> PullSettings {
    let speed = Speed::new(speed).unwrap_or(Speed::MAX);
    PullSettings::new(to_kgf(target_kgf), speed, PreStretch::NONE, KnotBoost::NONE)
        .unwrap_or_default()
}

/// One pull of `ms` ticks with `config` and `calibration` on `scenario`'s machine.
///
/// # Errors
/// The controller bench could not start.
pub fn pull_trace(
    scenario: &Scenario,
    config: &ControllerConfig,
    calibration: Calibration,
    ms: u32,
) -> Result<Vec<ControllerRow>, Failure> {
    let mut bench = ControllerBench::new(&scenario.twin, config, calibration)
        .map_err(|e| Failure::Bench(e.to_string()))?;
    bench.start(&pull_settings(scenario.target_kgf, 9), PullKind::Main);
    let mut rows = Vec::with_capacity(ms as usize);
    bench.run(ms, &mut rows);
    Ok(rows)
}

/// The signed duty of a row (negative = release), fraction.
#[must_use]
pub fn signed_duty(row: &ControllerRow) -> f64 {
    let command = row.control.command;
    let duty = f64::from(command.duty().raw()) / 65_536.0;
    if command.direction() == Some(taut_core::drive::Direction::Release) { -duty } else { duty }
}

/// The figures of one trace against `target` and the oracle's `t_min`.
#[must_use]
pub fn metrics(trace: &[ControllerRow], target: f64, t_min: Option<f64>) -> Metrics {
    let hold_ticks = (SETTLE_HOLD_S * 1000.0) as usize;
    let mut settle_index = None;
    let mut run_start = None;
    for (i, row) in trace.iter().enumerate() {
        if (row.truth.tension_kgf - target).abs() <= SETTLE_BAND_KGF {
            let start = *run_start.get_or_insert(i);
            if i + 1 - start >= hold_ticks {
                settle_index = Some(start);
                break;
            }
        } else {
            run_start = None;
        }
    }
    let fault = trace.iter().any(|r| r.truth.drive_fault.is_some());
    let peak_current_a = trace.iter().map(|r| r.truth.peak_current_a.abs()).fold(0.0, f64::max);
    let bus_peak_v = trace.iter().map(|r| r.truth.bus_peak_volts).fold(0.0, f64::max);
    let run_end = trace.last().map_or(0.0, |r| r.t_s);
    // A run that never settles is censored: its hold window is the run's last 9 s.
    let settle_s = settle_index.and_then(|i| trace.get(i)).map(|r| r.t_s);
    let from = settle_s.unwrap_or(run_end - HOLD_WINDOW_S.1);
    let hold: Vec<&ControllerRow> = trace
        .iter()
        .filter(|r| r.t_s >= from + HOLD_WINDOW_S.0 && r.t_s <= from + HOLD_WINDOW_S.1)
        .collect();
    let hold_complete = hold.last().is_some_and(|r| r.t_s >= from + HOLD_WINDOW_S.1 - 0.01);
    let hold_error_kgf =
        hold.iter().map(|r| (r.truth.tension_kgf - target).abs()).fold(0.0, f64::max);
    let mean = |f: &dyn Fn(&ControllerRow) -> f64| {
        if hold.is_empty() {
            0.0
        } else {
            hold.iter().map(|r| f(r)).sum::<f64>() / hold.len() as f64
        }
    };
    let hold_offset_kgf = mean(&|r| r.truth.tension_kgf - target);
    let hold_p2p_kgf = hold.iter().map(|r| r.truth.tension_kgf).fold(f64::NEG_INFINITY, f64::max)
        - hold.iter().map(|r| r.truth.tension_kgf).fold(f64::INFINITY, f64::min);
    let hold_p2p_kgf = if hold.is_empty() { 0.0 } else { hold_p2p_kgf };
    let hold_coasting = match (hold.first(), hold.last()) {
        (Some(first), Some(last)) => {
            last.truth.drive_coasting.saturating_sub(first.truth.drive_coasting)
        }
        _ => 0,
    };
    let sense_offset_kgf = mean(&|r| r.truth.tension_kgf - taut_sim::bench::kgf(r.control.tension));
    let overshoot_kgf = trace
        .iter()
        .filter(|r| r.t_s < from + HOLD_WINDOW_S.0)
        .map(|r| r.truth.tension_kgf - target)
        .fold(0.0, f64::max);
    let variation: f64 =
        hold.windows(2).map(|w| (signed_duty(w[1]) - signed_duty(w[0])).abs()).sum();
    let failure = if fault {
        Some(Failure::DriveFault)
    } else if t_min.is_none() {
        Some(Failure::Unreachable)
    } else if trace.iter().any(|r| r.truth.limits.end) {
        Some(Failure::OutOfTravel)
    } else if settle_s.is_none() || !hold_complete {
        Some(Failure::NeverSettled)
    } else {
        None
    };
    Metrics {
        settle_s,
        settle_ratio: settle_s.zip(t_min).map(|(s, t)| s / t),
        hold_error_kgf,
        hold_offset_kgf,
        hold_p2p_kgf,
        hold_coasting,
        sense_offset_kgf,
        overshoot_kgf,
        chattering: variation / (HOLD_WINDOW_S.1 - HOLD_WINDOW_S.0),
        peak_current_a,
        bus_peak_v,
        failure,
    }
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

/// A number for JSON: finite (rounded to 10⁻⁶), or `null`.
#[must_use]
pub fn number(x: f64) -> serde_json::Value {
    if x.is_finite() { serde_json::json!((x * 1e6).round() / 1e6) } else { serde_json::Value::Null }
}

/// A number for a table: `—` when not finite.
#[must_use]
pub fn cell(x: f64, decimals: usize) -> String {
    if x.is_finite() { format!("{x:.decimals$}") } else { "—".to_owned() }
}

/// `x` to `digits` significant figures, without trailing zeros (`6.304347826086957` → `6.3`
/// for 2, `0.86` → `0.86`, `1200` → `1200`): how a table prints a parameter's value, which
/// is an input to read, not a figure measured to a stated precision.
#[must_use]
pub fn significant(x: f64, digits: i32) -> String {
    if !x.is_finite() {
        return "—".to_owned();
    }
    if x == 0.0 {
        return "0".to_owned();
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = usize::try_from((digits - 1 - magnitude).max(0)).unwrap_or(0);
    let text = format!("{x:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        text
    }
}

/// The span of a robustness axis as a table prints it: `largest spike at 3 A 0 … 6.3 kgf`.
#[must_use]
pub fn span_text(span: &taut_sim::family::AxisSpan) -> String {
    let text = format!(
        "{} {} … {} {}",
        span.quantity,
        significant(span.at_low_end, 3),
        significant(span.at_high_end, 3),
        span.unit
    );
    text.trim_end().to_owned()
}

/// True when `text` shows no number with more than `decimals` decimals (a figure printed
/// with `{}` instead of to its precision).
#[must_use]
pub fn rounded(text: &str, decimals: usize) -> bool {
    let bytes = text.as_bytes();
    let mut run = 0;
    let mut after_point = false;
    for (k, &b) in bytes.iter().enumerate() {
        if b.is_ascii_digit() {
            run += 1;
            if after_point && run > decimals {
                return false;
            }
        } else {
            after_point = b == b'.' && k > 0 && bytes[k - 1].is_ascii_digit();
            run = 0;
        }
    }
    true
}

/// Failure reasons and how often each occurred, most frequent first.
#[must_use]
pub fn failure_counts<'a>(metrics: impl Iterator<Item = &'a Metrics>) -> Vec<(String, usize)> {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for failure in metrics.filter_map(|m| m.failure.as_ref()) {
        let name = failure.name();
        match counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => *c += 1,
            None => counts.push((name, 1)),
        }
    }
    counts.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    counts
}

/// The aggregated figures of one controller over many runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Aggregate {
    /// Runs.
    pub runs: usize,
    /// Failed runs.
    pub failed: usize,
    /// Hold error p50, p99, max over the runs that did not fail, kgf.
    pub hold_kgf: [f64; 3],
    /// Overshoot p99, max, kgf.
    pub overshoot_kgf: [f64; 2],
    /// Settle / t_min p50, p99.
    pub settle_ratio: [f64; 2],
    /// Settle time p50, s.
    pub settle_p50_s: f64,
    /// Chattering p50, /s.
    pub chattering_p50: f64,
    /// Largest true winding current, A (every run that pulled).
    pub peak_current_max_a: f64,
    /// Highest bus voltage, V.
    pub bus_max_v: f64,
    /// Hold peak-to-peak p50, p99 over the runs that did not fail, kgf.
    pub hold_p2p_kgf: [f64; 2],
    /// PWM periods coasted under a command in the hold windows, summed over every run, and
    /// the runs with any.
    pub hold_coasting: (u64, usize),
}

/// Aggregates `metrics`.
#[must_use]
pub fn aggregate(metrics: &[&Metrics]) -> Aggregate {
    let ok: Vec<&&Metrics> = metrics.iter().filter(|m| m.failure.is_none()).collect();
    let of = |f: &dyn Fn(&Metrics) -> f64| ok.iter().map(|m| f(m)).collect::<Vec<f64>>();
    let hold = of(&|m| m.hold_error_kgf);
    let over = of(&|m| m.overshoot_kgf);
    let ratio = of(&|m| m.settle_ratio.unwrap_or(f64::NAN));
    Aggregate {
        runs: metrics.len(),
        failed: metrics.len() - ok.len(),
        hold_kgf: [percentile(&hold, 50.0), percentile(&hold, 99.0), percentile(&hold, 100.0)],
        overshoot_kgf: [percentile(&over, 99.0), percentile(&over, 100.0)],
        settle_ratio: [percentile(&ratio, 50.0), percentile(&ratio, 99.0)],
        settle_p50_s: percentile(&of(&|m| m.settle_s.unwrap_or(f64::NAN)), 50.0),
        chattering_p50: percentile(&of(&|m| m.chattering), 50.0),
        peak_current_max_a: metrics.iter().map(|m| m.peak_current_a).fold(0.0, f64::max),
        bus_max_v: metrics.iter().map(|m| m.bus_peak_v).fold(0.0, f64::max),
        hold_p2p_kgf: {
            let p2p = of(&|m| m.hold_p2p_kgf);
            [percentile(&p2p, 50.0), percentile(&p2p, 99.0)]
        },
        hold_coasting: (
            metrics.iter().map(|m| u64::from(m.hold_coasting)).sum(),
            metrics.iter().filter(|m| m.hold_coasting > 0).count(),
        ),
    }
}

/// The header of [`aggregate_row`]'s table.
pub const AGGREGATE_HEADER: &str = "| hold p50 / p99 / max kgf | overshoot p99 / max kgf | settle/t_min p50 / p99 | settle p50 s | chattering p50 /s | peak current A | bus max V | failed |";

/// One table row's cells for `a` (to follow a name cell).
#[must_use]
pub fn aggregate_row(a: &Aggregate) -> String {
    format!(
        " | {} / {} / {} | {} / {} | {} / {} | {} | {} | {} | {} | {} of {} |",
        cell(a.hold_kgf[0], 3),
        cell(a.hold_kgf[1], 3),
        cell(a.hold_kgf[2], 3),
        cell(a.overshoot_kgf[0], 3),
        cell(a.overshoot_kgf[1], 3),
        cell(a.settle_ratio[0], 2),
        cell(a.settle_ratio[1], 2),
        cell(a.settle_p50_s, 2),
        cell(a.chattering_p50, 2),
        cell(a.peak_current_max_a, 1),
        cell(a.bus_max_v, 1),
        a.failed,
        a.runs
    )
}

/// `a` as JSON.
#[must_use]
pub fn aggregate_json(a: &Aggregate) -> serde_json::Value {
    serde_json::json!({
        "runs": a.runs,
        "failed": a.failed,
        "hold_error_p50_kgf": number(a.hold_kgf[0]),
        "hold_error_p99_kgf": number(a.hold_kgf[1]),
        "hold_error_max_kgf": number(a.hold_kgf[2]),
        "overshoot_p99_kgf": number(a.overshoot_kgf[0]),
        "overshoot_max_kgf": number(a.overshoot_kgf[1]),
        "settle_over_t_min_p50": number(a.settle_ratio[0]),
        "settle_over_t_min_p99": number(a.settle_ratio[1]),
        "settle_p50_s": number(a.settle_p50_s),
        "chattering_p50": number(a.chattering_p50),
        "peak_current_max_a": number(a.peak_current_max_a),
        "bus_max_v": number(a.bus_max_v),
        "hold_p2p_p50_kgf": number(a.hold_p2p_kgf[0]),
        "hold_p2p_p99_kgf": number(a.hold_p2p_kgf[1]),
        "hold_coasting_periods": a.hold_coasting.0,
        "hold_coasting_runs": a.hold_coasting.1,
    })
}

//! The main job's figures: the summary table and its JSON, computed from the recorded rows.

use std::fmt::Write as _;

use serde_json::{Value, json};
use taut_core::drive::Direction;
use taut_core::drive::duty::DUTY_ONE;
use taut_core::machine::{FaultCode, MachineState};
use taut_core::settings::Unit;
use taut_core::units::Kgf;
use taut_sim::bench::{Row, fault_name, kgf, state_name};
use taut_sim::operator::display;

use super::CycleRun;

/// Band of the true-tension settling criterion, kgf (the paper's 0.1 kgw accuracy).
pub const SETTLE_BAND_KGF: f64 = 0.1;
/// How long the true tension must stay in the band to count as settled, ms.
pub const SETTLE_FOR_MS: u64 = 500;
/// The hold error is measured from this long after the holding lamp lit, ms.
pub const HOLD_ERROR_FROM_MS: u64 = 1_000;
/// The drive's overcurrent trip, A: the twin's board's (12 A).
#[allow(clippy::cast_lossless, reason = "`f64::from` is not callable in a const item")]
pub const TRIP_A: f64 = taut_sim::params::BoardDesign::PAPER.overcurrent_ma as f64 / 1_000.0;

/// The commanded duty of a row, signed (negative = release), percent.
#[must_use]
pub fn duty_percent(row: &Row) -> f64 {
    let duty = f64::from(row.outputs.drive.duty().raw()) / f64::from(DUTY_ONE) * 100.0;
    if row.outputs.drive.direction() == Some(Direction::Release) { -duty } else { duty }
}

/// What the panel's digits read on row `index` while pulling, holding or releasing,
/// converted to kgf (the display of a tick is written by the state the tick started in).
#[must_use]
pub fn panel_kgf(run: &CycleRun, index: usize) -> Option<f64> {
    let shown_by = match index.checked_sub(1) {
        Some(previous) => run.rows.get(previous)?.state,
        None => run.transitions.first()?.state,
    };
    if !matches!(shown_by, MachineState::Pulling | MachineState::Holding | MachineState::Releasing)
    {
        return None;
    }
    let tenths = display::tenths(&run.rows.get(index)?.outputs.display)?;
    Some(match run.settings.set_point().unit() {
        Unit::Kilograms => f64::from(tenths) / 10.0,
        Unit::Pounds => kgf(Kgf::from_lbf_tenths(tenths)),
    })
}

/// The job's figures (see [`summary`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// String kind.
    pub string: &'static str,
    /// The set point as keyed (`25.0 kg`, `55.0 lb`).
    pub set_point: String,
    /// The tension held (knot increase included), kgf.
    pub target_kgf: f64,
    /// The highest tension of the pull (pre-stretch included), kgf.
    pub peak_target_kgf: f64,
    /// Power-up to Ready (self-test, motor test, homing, calibration window), s.
    pub boot_s: Option<f64>,
    /// Start to the machine's "at tension" (the holding lamp), s.
    pub time_to_tension_s: Option<f64>,
    /// Start to the true tension staying within ±0.1 kgf of the target for 0.5 s, s.
    pub true_settle_s: Option<f64>,
    /// The highest true tension of the pull and hold, kgf.
    pub peak_tension_kgf: f64,
    /// How far the true tension went above the peak target, kgf (0 if never).
    pub overshoot_kgf: f64,
    /// Largest |true − target| from 1 s after the holding lamp to the release, kgf.
    pub hold_error_max_kgf: Option<f64>,
    /// Mean |true − target| over the same window, kgf.
    pub hold_error_mean_kgf: Option<f64>,
    /// Time held, s.
    pub hold_s: Option<f64>,
    /// Carriage advance during the hold (following the string's creep), mm.
    pub creep_mm: Option<f64>,
    /// True tension when the operator released, kgf.
    pub tension_at_release_kgf: Option<f64>,
    /// String drawn during the pull as the machine counted it, mm.
    pub string_used_mm: Option<u32>,
    /// String drawn during the pull in truth, mm.
    pub true_string_mm: Option<f64>,
    /// The string's stiffness as the machine estimated it, kgf/mm.
    pub stiffness_kgf_per_mm: Option<f64>,
    /// The string's true stiffness in this pull (true tension over true travel between 1/2
    /// and 3/4 of the target, where the machine measures), kgf/mm.
    pub true_stiffness_kgf_per_mm: Option<f64>,
    /// The twin string's instantaneous stiffness `E·A/L`, kgf/mm.
    pub instantaneous_stiffness_kgf_per_mm: f64,
    /// The string's creep in the hold as the machine estimated it, % of the tension per min.
    pub creep_percent_per_min: Option<f64>,
    /// The twin string's creep over the machine's window (1 s into the hold to the
    /// release): its relaxation rate at constant length over the true tension, %/min.
    pub true_creep_percent_per_min: Option<f64>,
    /// Release to Ready at home, s.
    pub release_s: Option<f64>,
    /// The largest winding (phase) current of the job, true, A.
    pub peak_current_a: f64,
    /// The board's current sensing (`dc-link-mid-on/unidirectional`, `per-phase/…`).
    pub current_sensing: String,
    /// The highest DC bus voltage of the job, V.
    pub bus_peak_v: f64,
    /// Faults the machine latched.
    pub faults: Vec<FaultCode>,
    /// Whether the cycle completed (home, Ready, no fault).
    pub completed: bool,
    /// Simulated time of the job, s.
    pub sim_s: f64,
    /// Wall-clock time of commissioning and job, s.
    pub wall_s: f64,
    /// Key presses in the job.
    pub presses: u32,
}

/// The machine's creep window opens this long into the hold, ms (its `CREEP_SETTLE_MS`).
const CREEP_WINDOW_FROM_MS: u64 = taut_core::machine::string::CREEP_SETTLE_MS as u64;
/// The machine's creep window lasts this long, ms (its `CREEP_WINDOW_MS`).
const CREEP_WINDOW_MS: u64 = taut_core::machine::string::CREEP_WINDOW_MS as u64;

/// The first time `state` was entered at or after `from` ms.
#[must_use]
pub fn entered(run: &CycleRun, state: MachineState, from: u64) -> Option<u64> {
    run.transitions.iter().find(|t| t.state == state && t.t_ms >= from).map(|t| t.t_ms)
}

fn rows_between(run: &CycleRun, from: u64, to: u64) -> impl Iterator<Item = &Row> {
    run.rows.iter().filter(move |r| r.t_ms >= from && r.t_ms < to)
}

/// The figures of the job.
#[must_use]
pub fn summary(run: &CycleRun) -> Summary {
    let (target, peak_target) = run.targets_kgf();
    let ready = entered(run, MachineState::Ready, 0);
    let pulling = ready.and_then(|t| entered(run, MachineState::Pulling, t));
    let holding = pulling.and_then(|t| entered(run, MachineState::Holding, t));
    let releasing = holding.and_then(|t| entered(run, MachineState::Releasing, t));
    let home = releasing.and_then(|t| entered(run, MachineState::Ready, t));
    let end = run.rows.last().map_or(0, |r| r.t_ms + 1);
    let pull_end = releasing.unwrap_or(end);
    let seconds = |ms: u64| ms as f64 / 1_000.0;

    let (peak_tension_kgf, true_settle_s) = pulling.map_or((0.0, None), |start| {
        let peak =
            rows_between(run, start, pull_end).map(|r| r.truth.tension_kgf).fold(0.0, f64::max);
        let mut run_start = None;
        let mut settled = None;
        for row in rows_between(run, start, pull_end) {
            if (row.truth.tension_kgf - target).abs() <= SETTLE_BAND_KGF {
                let since = *run_start.get_or_insert(row.t_ms);
                if row.t_ms + 1 - since >= SETTLE_FOR_MS {
                    settled = Some(seconds(since - start));
                    break;
                }
            } else {
                run_start = None;
            }
        }
        (peak, settled)
    });
    let hold_window = holding.zip(releasing).map(|(h, r)| (h + HOLD_ERROR_FROM_MS, r));
    let hold_errors: Vec<f64> = hold_window.map_or_else(Vec::new, |(from, to)| {
        rows_between(run, from, to).map(|r| (r.truth.tension_kgf - target).abs()).collect()
    });
    let hold_error_max_kgf =
        (!hold_errors.is_empty()).then(|| hold_errors.iter().copied().fold(0.0, f64::max));
    let hold_error_mean_kgf = (!hold_errors.is_empty())
        .then(|| hold_errors.iter().sum::<f64>() / hold_errors.len() as f64);
    let at = |t: Option<u64>| t.and_then(|t| run.rows.iter().find(|r| r.t_ms >= t));
    let creep_mm =
        at(holding).zip(at(releasing)).map(|(h, r)| r.truth.carriage_mm - h.truth.carriage_mm);
    let creep_window = holding
        .zip(releasing)
        .map(|(h, r)| (h + CREEP_WINDOW_FROM_MS, h + CREEP_WINDOW_FROM_MS + CREEP_WINDOW_MS, r))
        .filter(|&(_, to, released)| to <= released)
        .map(|(from, to, _)| (from, to));
    let true_creep_percent_per_min = creep_window.and_then(|(from, to)| {
        let (mut rate, mut tension, mut n) = (0.0, 0.0, 0u32);
        for row in rows_between(run, from, to) {
            rate += row.truth.string_relaxation_kgf_per_s;
            tension += row.truth.tension_kgf;
            n += 1;
        }
        (n > 0 && tension > 0.0).then(|| rate / tension * 100.0 * 60.0)
    });
    let true_stiffness_kgf_per_mm = pulling.and_then(|start| {
        let mut rows = rows_between(run, start, pull_end);
        let lower = rows.find(|r| r.truth.tension_kgf >= target / 2.0)?;
        let upper = rows.find(|r| r.truth.tension_kgf >= target * 0.75)?;
        let travel = upper.truth.carriage_mm - lower.truth.carriage_mm;
        (travel > 0.0).then(|| (upper.truth.tension_kgf - lower.truth.tension_kgf) / travel)
    });
    let true_string_mm = at(pulling)
        .zip(at(releasing))
        .map(|(p, r)| r.truth.string_travel_mm - p.truth.string_travel_mm);
    let faults = run
        .transitions
        .iter()
        .filter_map(|t| match t.state {
            MachineState::Fault(code) => Some(code),
            _ => None,
        })
        .collect();
    let unit = match run.settings.set_point().unit() {
        Unit::Kilograms => "kg",
        Unit::Pounds => "lb",
    };
    Summary {
        string: run.options.string.name(),
        set_point: format!("{:.1} {unit}", f64::from(run.settings.set_point().tenths()) / 10.0),
        target_kgf: target,
        peak_target_kgf: peak_target,
        boot_s: ready.map(seconds),
        time_to_tension_s: pulling.zip(holding).map(|(p, h)| seconds(h - p)),
        true_settle_s,
        peak_tension_kgf,
        overshoot_kgf: (peak_tension_kgf - peak_target).max(0.0),
        hold_error_max_kgf,
        hold_error_mean_kgf,
        hold_s: holding.zip(releasing).map(|(h, r)| seconds(r - h)),
        creep_mm,
        tension_at_release_kgf: at(releasing).map(|r| r.truth.tension_kgf),
        string_used_mm: run.pull.map(|p| u32::from(p.string_mm)),
        true_string_mm,
        stiffness_kgf_per_mm: run
            .pull
            .and_then(|p| p.stiffness)
            .map(|k| f64::from(k.milli()) / 1_000.0),
        true_stiffness_kgf_per_mm,
        instantaneous_stiffness_kgf_per_mm: run.config.string.stiffness_kgf_per_cm / 10.0,
        creep_percent_per_min: run
            .pull
            .and_then(|p| p.creep)
            .map(|c| f64::from(c.centi_percent_per_minute()) / 100.0),
        true_creep_percent_per_min,
        release_s: releasing.zip(home).map(|(r, h)| seconds(h - r)),
        peak_current_a: run.rows.iter().map(|r| r.truth.peak_current_a.abs()).fold(0.0, f64::max),
        current_sensing: run.config.current_sense.name(),
        bus_peak_v: run.rows.iter().map(|r| r.truth.bus_peak_volts).fold(0.0, f64::max),
        faults,
        completed: run.completed,
        sim_s: seconds(end),
        wall_s: run.wall.as_secs_f64(),
        presses: run.presses,
    }
}

/// What was run, in words: `25.0 kg, speed 5, pre-stretch 10 %, knot pull +15 %`.
#[must_use]
pub fn settings_text(run: &CycleRun, set_point: &str) -> String {
    let o = &run.options;
    let mut text = format!("{set_point}, speed {}", o.speed);
    if o.pre_stretch_percent > 0 {
        let _ = write!(text, ", pre-stretch {} %", o.pre_stretch_percent);
    }
    if let Some(knot) = o.knot_percent {
        let _ = write!(text, ", knot pull +{knot} %");
    }
    text
}

/// The machine the job ran on, in words: `nominal machine` or `family machine 7`.
#[must_use]
pub fn machine_text(run: &CycleRun) -> String {
    run.options.seed.map_or_else(|| "nominal machine".to_owned(), |s| format!("family machine {s}"))
}

/// The summary as a Markdown table.
#[must_use]
pub fn table(run: &CycleRun) -> String {
    let s = summary(run);
    let secs = |v: Option<f64>| v.map_or_else(|| "—".to_owned(), |v| format!("{v:.3} s"));
    let kg = |v: Option<f64>| v.map_or_else(|| "—".to_owned(), |v| format!("{v:.3} kgf"));
    let faults = if s.faults.is_empty() {
        "none".to_owned()
    } else {
        s.faults.iter().map(|c| state_name(MachineState::Fault(*c))).collect::<Vec<_>>().join(", ")
    };
    let rows: Vec<(&str, String)> = vec![
        ("string", s.string.to_owned()),
        ("machine", machine_text(run)),
        ("settings", settings_text(run, &s.set_point)),
        (
            "target (held) / peak target",
            format!("{:.3} / {:.3} kgf", s.target_kgf, s.peak_target_kgf),
        ),
        ("boot (self-test, motor test, homing)", secs(s.boot_s)),
        ("time to tension (Start → holding lamp)", secs(s.time_to_tension_s)),
        ("true tension settled (±0.1 kgf for 0.5 s)", secs(s.true_settle_s)),
        ("peak true tension", format!("{:.3} kgf", s.peak_tension_kgf)),
        ("overshoot above the peak target", format!("{:.3} kgf", s.overshoot_kgf)),
        ("hold error, largest true − target (from 1 s)", kg(s.hold_error_max_kgf)),
        ("hold error, mean distance true − target", kg(s.hold_error_mean_kgf)),
        ("hold time", secs(s.hold_s)),
        (
            "creep followed during the hold",
            s.creep_mm.map_or_else(|| "—".to_owned(), |v| format!("{v:.2} mm")),
        ),
        ("true tension at release", kg(s.tension_at_release_kgf)),
        (
            "string used (machine's encoder / true)",
            format!(
                "{} / {}",
                s.string_used_mm.map_or_else(|| "—".to_owned(), |v| format!("{v} mm")),
                s.true_string_mm.map_or_else(|| "—".to_owned(), |v| format!("{v:.1} mm"))
            ),
        ),
        (
            "string stiffness (machine's estimate / true in this pull / E·A/L)",
            format!(
                "{} / {} / {:.3} kgf/mm",
                s.stiffness_kgf_per_mm.map_or_else(|| "—".to_owned(), |v| format!("{v:.3}")),
                s.true_stiffness_kgf_per_mm.map_or_else(|| "—".to_owned(), |v| format!("{v:.3}")),
                s.instantaneous_stiffness_kgf_per_mm
            ),
        ),
        (
            "string creep in the hold (machine's estimate / twin's)",
            format!(
                "{} / {} % of the tension per minute",
                s.creep_percent_per_min.map_or_else(|| "—".to_owned(), |v| format!("{v:.2}")),
                s.true_creep_percent_per_min.map_or_else(|| "—".to_owned(), |v| format!("{v:.2}"))
            ),
        ),
        ("release to home", secs(s.release_s)),
        (
            "peak winding current (true)",
            format!(
                "{:.2} A ({:.0} % of the {TRIP_A:.0} A trip)",
                s.peak_current_a,
                s.peak_current_a / TRIP_A * 100.0
            ),
        ),
        ("current sensing", s.current_sensing.clone()),
        ("peak bus voltage", format!("{:.2} V", s.bus_peak_v)),
        ("faults", faults),
        ("cycle completed", if s.completed { "yes".to_owned() } else { "no".to_owned() }),
        (
            "key presses (job / commissioning)",
            format!("{} / {}", s.presses, run.commissioning.presses),
        ),
        (
            "simulated / wall clock",
            format!(
                "{:.1} s (+ {:.1} s commissioning) / {:.2} s",
                s.sim_s,
                run.commissioning.sim_ms as f64 / 1_000.0,
                s.wall_s
            ),
        ),
    ];
    let mut out = String::from("| quantity | value |\n|---|---|\n");
    for (name, value) in rows {
        let _ = writeln!(out, "| {name} | {value} |");
    }
    out
}

/// The summary as JSON (numbers in SI-ish units named in the keys).
#[must_use]
pub fn json(run: &CycleRun) -> Value {
    let s = summary(run);
    let o = &run.options;
    json!({
        "string": s.string,
        "set_point": s.set_point,
        "speed": o.speed,
        "pre_stretch_percent": o.pre_stretch_percent,
        "knot_percent": o.knot_percent,
        "seed": o.seed,
        "calibrated": run.commissioning.record.calibration.is_some(),
        "target_kgf": s.target_kgf,
        "peak_target_kgf": s.peak_target_kgf,
        "boot_s": s.boot_s,
        "time_to_tension_s": s.time_to_tension_s,
        "true_settle_s": s.true_settle_s,
        "peak_tension_kgf": s.peak_tension_kgf,
        "overshoot_kgf": s.overshoot_kgf,
        "hold_error_max_kgf": s.hold_error_max_kgf,
        "hold_error_mean_kgf": s.hold_error_mean_kgf,
        "hold_s": s.hold_s,
        "creep_mm": s.creep_mm,
        "tension_at_release_kgf": s.tension_at_release_kgf,
        "string_used_mm": s.string_used_mm,
        "true_string_mm": s.true_string_mm,
        "stiffness_kgf_per_mm": s.stiffness_kgf_per_mm,
        "true_stiffness_kgf_per_mm": s.true_stiffness_kgf_per_mm,
        "instantaneous_stiffness_kgf_per_mm": s.instantaneous_stiffness_kgf_per_mm,
        "creep_percent_per_min": s.creep_percent_per_min,
        "true_creep_percent_per_min": s.true_creep_percent_per_min,
        "release_s": s.release_s,
        "peak_current_a": s.peak_current_a,
        "current_sensing": s.current_sensing,
        "bus_peak_v": s.bus_peak_v,
        "faults": s.faults.iter().map(|c| fault_name(*c)).collect::<Vec<_>>(),
        "completed": s.completed,
        "presses": s.presses,
        "sim_s": s.sim_s,
        "wall_s": s.wall_s,
        "states": run.transitions.iter().map(|t| json!({"t_s": t.t_ms as f64 / 1_000.0, "state": state_name(t.state)})).collect::<Vec<_>>(),
    })
}

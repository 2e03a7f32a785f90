//! `taut report session`: a working day on each of several machines of the family — many
//! consecutive pulls without a power cycle, with the twin's slow drifts on.
//!
//! # A session
//!
//! Machine `i` of the family ([`TwinConfig::family`]) powers up with factory defaults and its
//! own drifts ([`DriftParams::family`]: the shop warming, the winding heating under I²R, the
//! load cell's zero moving with its temperature, creep under load, friction growing with
//! travel). The simulated operator calibrates it in its calibration states, then strings
//! the day's job — one target from the string kind's range and one speed (1–9) per machine,
//! so that what changes over the session is the day and not the job — racket after racket:
//! before every pull the operator checks the panel's settings page by page (keys in Ready),
//! every pull is a fresh length of string, pulled, held [`HOLD_MS`] and released. Between two pulls the carriage rests at home for
//! [`REST_MS`] of simulated ticks (the stringer weaving the next string; the machine may
//! re-zero), and [`GAP_S`] more of the day passes for the drifts
//! ([`taut_sim::Twin::idle`]); between rackets [`RACKET_GAP_S`].
//!
//! # The figures
//!
//! A pull's **hold error** is `|true tension − target|` over its hold from
//! [`HOLD_SETTLED_MS`] after the machine reached tension to the release (every tick). The
//! session's figure is the 99th percentile of those over all its pulls, against the same over
//! its first [`FIRST_PULLS`] pulls (the machine freshly tared and calibrated): the target is
//! that the day costs at most [`DRIFT_BUDGET_KGF`]. A p99 over a whole session also counts the
//! pulls whose approach overshot (a spread the machine has from its first pull on), so the
//! report gives the drift by itself too: a pull's **hold offset** is its mean signed error
//! `true − target` over the same samples, and the session's **offset drift** is the median of
//! the last [`FIRST_PULLS`] pulls' offsets less the median of the first's — what a stringer
//! would see as "the machine holds higher (lower) by evening". A **false fault** is any fault latched (none
//! is injected), a **false notice** any notice shown after the commissioning. The load cell's
//! apparent offset at the session's end (zero shift plus creep, the twin's truth) is what the
//! hold would carry without a re-zero; the re-zeros the machine took are counted.

use std::fmt::Write as _;

use serde_json::{Value, json};
use taut_core::machine::{FaultCode, MachineState, Notice};
use taut_core::store::Record;
use taut_sim::bench::{Bench, Session, fault_name, run_session};
use taut_sim::operator::{Operator, Plan};
use taut_sim::{DriftParams, TwinConfig};

use super::machine::{HOLD_MS, settings};
use super::{cell, number, percentile, scenario_seed};
use crate::cli::SessionArgs;
use crate::output::{Outputs, Progress, Status, json_bytes, parallel, threads};

/// Pulls per racket: a longer gap ([`RACKET_GAP_S`]) after every this many pulls.
pub const PULLS_PER_RACKET: u64 = 20;
/// Simulated ticks at rest at home between two pulls, ms.
pub const REST_MS: u64 = 4_000;
/// The rest of the time between two pulls, passed for the drifts only, s.
pub const GAP_S: f64 = 45.0;
/// The time between two rackets, passed for the drifts only, s.
pub const RACKET_GAP_S: f64 = 300.0;
/// The hold's samples start this long after the machine reached tension, ms.
pub const HOLD_SETTLED_MS: u64 = 300;
/// The pulls the session's figure is compared with.
pub const FIRST_PULLS: usize = 10;
/// How much the session's hold error p99 may exceed its first pulls', kgf.
pub const DRIFT_BUDGET_KGF: f64 = 0.01;

/// One machine's session.
#[derive(Clone, Debug)]
pub struct SessionResult {
    /// Machine index.
    pub index: u64,
    /// Pulls completed (released after their hold).
    pub pulls: usize,
    /// Hold error p99 over every pull, kgf.
    pub hold_p99_kgf: f64,
    /// Hold error p99 over the first [`FIRST_PULLS`] pulls, kgf.
    pub first_p99_kgf: f64,
    /// Hold error p99 over the last [`FIRST_PULLS`] pulls, kgf.
    pub last_p99_kgf: f64,
    /// The median hold offset (mean signed error) of the first [`FIRST_PULLS`] pulls, kgf.
    pub first_offset_kgf: f64,
    /// The same of the last [`FIRST_PULLS`] pulls, kgf.
    pub last_offset_kgf: f64,
    /// The first fault latched, if any (a false fault: nothing is injected).
    pub fault: Option<FaultCode>,
    /// Notices shown after the commissioning.
    pub notices: Vec<Notice>,
    /// The load cell's apparent offset at the end (zero shift plus creep, and the amplifier's
    /// warm-up since the machine's tare), kgf.
    pub offset_kgf: f64,
    /// The winding's temperature at the end, °C.
    pub winding_c: f64,
    /// The winding's resistance over its cold value at the end.
    pub resistance_factor: f64,
    /// The friction over its value at the start, at the end.
    pub friction_factor: f64,
    /// How far the machine's zero moved from the self-test's, kgf at the twin's sensitivity.
    pub zero_moved_kgf: f64,
    /// Re-zeros the machine took.
    pub rezeros: u16,
    /// Simulated hours of the day.
    pub hours: f64,
    /// Whether the session ran all its pulls.
    pub completed: bool,
}

/// Runs machine `index`'s session of `pulls` pulls.
#[must_use]
pub fn run_machine(args: &SessionArgs, index: u64) -> SessionResult {
    let seed = scenario_seed(args.seed, index);
    let config = TwinConfig::family(seed);
    let mut bench = Bench::power_up(&config, &Record::default().encode());
    bench.twin_mut().enable_drift(DriftParams::family(seed));
    let kind = config.string.kind;
    let mut errors: Vec<Vec<f64>> = Vec::new();
    let mut offsets: Vec<f64> = Vec::new();
    let mut fault = None;
    let mut notices = Vec::new();
    let mut tare = None;
    let mut warm_at_tare = 0.0;
    let mut commissioned = false;
    let mut completed = true;
    for pull in 0..args.pulls {
        let plan = Plan {
            calibrate: pull == 0,
            settings: settings(scenario_seed(seed, 0), kind),
            knot_mode: false,
            pull_hold_ms: Some(HOLD_MS),
        };
        let target_kgf = f64::from(plan.settings.set_point().to_kgf().to_milli()) / 1e3;
        let mut operator = if pull == 0 { Operator::new(plan) } else { Operator::at_ready(plan) };
        if pull > 0 {
            bench.twin_mut().fit_new_string();
        }
        let mut hold = Vec::new();
        let mut offset_sum = 0.0;
        let mut held_since = None;
        let outcome = run_session(&mut bench, &mut operator, Session::Job, &mut |_| {}, |b, op| {
            let machine = b.machine();
            if tare.is_none() && machine.state() == MachineState::CalibrationWindow {
                tare = Some(machine.load_cell_zero());
                warm_at_tare = b.twin().load_cell_warm_up_kgf();
            }
            if machine.state() == MachineState::Ready && pull == 0 && tare.is_some() {
                commissioned = true;
            }
            if let Some(notice) = machine.notice() {
                if commissioned && notices.last() != Some(&notice) {
                    notices.push(notice);
                }
            }
            if fault.is_none() {
                fault = machine.fault();
            }
            let now = b.twin().now_ms();
            if machine.state() == MachineState::Holding {
                let since = *held_since.get_or_insert(now);
                if now >= since + HOLD_SETTLED_MS {
                    let error = b.twin().truth().tension_kgf - target_kgf;
                    hold.push(error.abs());
                    offset_sum += error;
                }
            } else {
                held_since = None;
            }
            op.finished()
        });
        if outcome.is_err() || fault.is_some() || operator.stopped() {
            completed = false;
            break;
        }
        offsets.push(offset_sum / hold.len().max(1) as f64);
        errors.push(hold);
        // The stringer weaves the next string: the carriage rests at home, then the rest of
        // the gap passes for the drifts.
        for _ in 0..REST_MS {
            bench.tick();
            if let Some(notice) = bench.machine().notice() {
                if notices.last() != Some(&notice) {
                    notices.push(notice);
                }
            }
        }
        let gap = if (pull + 1) % PULLS_PER_RACKET == 0 { RACKET_GAP_S } else { GAP_S };
        bench.twin_mut().idle(gap);
    }
    let flat = |pulls: &[Vec<f64>]| pulls.iter().flatten().copied().collect::<Vec<f64>>();
    let first = errors.get(..FIRST_PULLS.min(errors.len())).unwrap_or(&[]);
    let last = errors.get(errors.len().saturating_sub(FIRST_PULLS)..).unwrap_or(&[]);
    let first_offsets = offsets.get(..FIRST_PULLS.min(offsets.len())).unwrap_or(&[]);
    let last_offsets = offsets.get(offsets.len().saturating_sub(FIRST_PULLS)..).unwrap_or(&[]);
    let drift = bench.twin().drift().copied();
    let gain = config.load_cell.volts_per_kgf;
    let zero_moved_kgf = tare.map_or(f64::NAN, |t: taut_core::units::Volts| {
        f64::from(bench.machine().load_cell_zero().to_bits() - t.to_bits()) / 65_536.0 / gain
    });
    SessionResult {
        index,
        pulls: errors.len(),
        hold_p99_kgf: percentile(&flat(&errors), 99.0),
        first_p99_kgf: percentile(&flat(first), 99.0),
        last_p99_kgf: percentile(&flat(last), 99.0),
        first_offset_kgf: percentile(first_offsets, 50.0),
        last_offset_kgf: percentile(last_offsets, 50.0),
        fault,
        notices,
        offset_kgf: drift.map_or(f64::NAN, |d| d.offset_kgf())
            + (bench.twin().load_cell_warm_up_kgf() - warm_at_tare),
        winding_c: drift.map_or(f64::NAN, |d| d.winding_c()),
        resistance_factor: drift.map_or(f64::NAN, |d| d.resistance_factor()),
        friction_factor: drift.map_or(f64::NAN, |d| d.friction_factor()),
        zero_moved_kgf,
        rezeros: bench.machine().rezeros(),
        hours: drift.map_or(f64::NAN, |d| d.time_s() / 3_600.0),
        completed: completed && errors.len() as u64 == args.pulls,
    }
}

/// The report as Markdown: a title line, one table row per machine, the worst figures.
#[must_use]
pub fn text(results: &[SessionResult], pulls: u64) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "working-day sessions: {} machines × {pulls} consecutive pulls, drifts on \
         (hold error = |true − target| over each hold from {HOLD_SETTLED_MS} ms after tension)\n",
        results.len()
    );
    let _ = writeln!(
        out,
        "| machine | pulls | hours | hold p99 kgf | first {FIRST_PULLS} kgf | last {FIRST_PULLS} kgf | \
         excess kgf | hold offset first / last kgf | offset drift kgf | load-cell offset kgf | \
         zero moved kgf | re-zeros | winding °C | R× | friction× | faults | notices |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in results {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.index,
            r.pulls,
            cell(r.hours, 2),
            cell(r.hold_p99_kgf, 3),
            cell(r.first_p99_kgf, 3),
            cell(r.last_p99_kgf, 3),
            cell(r.hold_p99_kgf - r.first_p99_kgf, 3),
            cell(r.first_offset_kgf, 4),
            cell(r.last_offset_kgf, 4),
            cell(r.last_offset_kgf - r.first_offset_kgf, 4),
            cell(r.offset_kgf, 3),
            cell(r.zero_moved_kgf, 3),
            r.rezeros,
            cell(r.winding_c, 1),
            cell(r.resistance_factor, 3),
            cell(r.friction_factor, 3),
            r.fault.map_or_else(|| "0".to_owned(), fault_name),
            if r.notices.is_empty() {
                "0".to_owned()
            } else {
                r.notices
                    .iter()
                    .map(|n| format!("n-{:02}", n.number()))
                    .collect::<Vec<_>>()
                    .join(" ")
            },
        );
    }
    let worst =
        results.iter().map(|r| r.hold_p99_kgf - r.first_p99_kgf).fold(f64::NEG_INFINITY, f64::max);
    let drift = results
        .iter()
        .map(|r| (r.last_offset_kgf - r.first_offset_kgf).abs())
        .fold(f64::NEG_INFINITY, f64::max);
    let faults = results.iter().filter(|r| r.fault.is_some()).count();
    let notices: usize = results.iter().map(|r| r.notices.len()).sum();
    let incomplete = results.iter().filter(|r| !r.completed).count();
    let _ = writeln!(
        out,
        "\nworst session hold p99 over its first {FIRST_PULLS} pulls': {} kgf (target ≤ \
         {DRIFT_BUDGET_KGF}); largest hold offset drift (last {FIRST_PULLS} pulls' median \
         against the first's): {} kgf; false faults: {faults}; false notices: {notices}; \
         sessions not completed: {incomplete}",
        cell(worst, 3),
        cell(drift, 4)
    );
    out
}

/// The JSON summary.
fn to_json(args: &SessionArgs, results: &[SessionResult]) -> Value {
    json!({
        "machines": args.machines,
        "pulls": args.pulls,
        "seed": args.seed,
        "sessions": results.iter().map(|r| json!({
            "index": r.index,
            "pulls": r.pulls,
            "hours": number(r.hours),
            "hold_error_p99_kgf": number(r.hold_p99_kgf),
            "first_pulls_hold_error_p99_kgf": number(r.first_p99_kgf),
            "last_pulls_hold_error_p99_kgf": number(r.last_p99_kgf),
            "first_pulls_hold_offset_kgf": number(r.first_offset_kgf),
            "last_pulls_hold_offset_kgf": number(r.last_offset_kgf),
            "offset_kgf": number(r.offset_kgf),
            "zero_moved_kgf": number(r.zero_moved_kgf),
            "rezeros": r.rezeros,
            "winding_c": number(r.winding_c),
            "resistance_factor": number(r.resistance_factor),
            "friction_factor": number(r.friction_factor),
            "fault": r.fault.map(fault_name),
            "notices": r.notices.iter().map(|n| n.number()).collect::<Vec<_>>(),
            "completed": r.completed,
        })).collect::<Vec<_>>(),
    })
}

/// `taut report session`.
///
/// # Errors
/// An unwritable JSON path.
pub fn main(args: &SessionArgs) -> Status {
    let outputs = Outputs::new().file("--json", args.json.as_deref()).check()?;
    let started = std::time::Instant::now();
    let progress = Progress::new(args.machines as usize, "sessions");
    let results =
        parallel(args.machines, threads(args.threads), &progress, &|i| run_machine(args, i));
    let files: Vec<_> =
        args.json.iter().map(|path| (path.clone(), json_bytes(&to_json(args, &results)))).collect();
    outputs.write(&files)?;
    print!("{}", text(&results, args.pulls));
    println!("wall clock: {:.1} s", started.elapsed().as_secs_f64());
    if let Some(path) = &args.json {
        println!("summary: {}", path.display());
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_is_a_markdown_table() {
        let text = text(&[], 200);
        let lines: Vec<&str> = text.lines().collect();
        let header = lines.iter().position(|l| l.starts_with("| machine |")).unwrap_or(usize::MAX);
        assert!(header < lines.len(), "no table header in\n{text}");
        let columns = lines[header].matches('|').count();
        assert!(lines[header + 1].starts_with("|---|"), "no separator under the header");
        assert_eq!(lines[header + 1].matches('|').count(), columns, "separator and header differ");
    }
}

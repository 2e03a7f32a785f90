//! `taut report string`: the machine's estimate of the string itself — its stiffness near
//! the set tension and its creep in the hold (`taut_core::machine::string`) — against the
//! twin's truth, for every string preset on the nominal machine and on machines of the
//! family.
//!
//! # A run
//!
//! The machine is commissioned on the bench (the operator's 4-point calibration against the
//! reference gauge, [`commission`]), powers up with that record, and the operator keys in a
//! target in the middle of the kind's stringing range, presses Start, holds for `--hold`
//! seconds and releases. The estimate is the pull's log entry. The truth:
//!
//! - **stiffness**: the string's own stiffness in this pull — the twin's true tension gained
//!   over the true carriage travel between 1/2 and 3/4 of the target, the same stretch of the
//!   load line the machine measures on. The string's instantaneous stiffness `E·A/L` (the
//!   twin's `stiffness_kgf_per_cm`) is printed beside it: a pull at a finite speed reads less
//!   (its relaxation arms give way while it pulls — up to 10 % on a soft badminton string at
//!   speed 1), which is the string's behaviour at that speed, not the estimate's error;
//! - **creep**: the rate at which the string's tension would fall at constant length, `Σ aᵢ/τᵢ`
//!   over the twin's relaxation arms, averaged over the same window the machine measures in
//!   (from 1 s into the hold to the release), as a share of the true tension per minute.
//!
//! Acceptance: stiffness within 10 % and creep within 20 % of the truth.

use std::fmt::Write as _;

use serde_json::{Value, json};
use taut_core::io::{Key, Keys};
use taut_core::machine::{MachineState, PullRecord};
use taut_sim::bench::{Bench, commission, factory_config};
use taut_sim::{StringKind, TwinConfig};

use super::{cell, number, target_range};
use crate::cli::StringArgs;
use crate::output::{Outputs, Status, json_bytes};

/// The stiffness estimate's acceptance: within this share of the truth.
pub const STIFFNESS_TOLERANCE: f64 = 0.10;
/// The creep estimate's acceptance: within this share of the truth.
pub const CREEP_TOLERANCE: f64 = 0.20;
/// The machine's creep window opens this long into the hold, ms (its `CREEP_SETTLE_MS`).
const WINDOW_OPENS_MS: u64 = taut_core::machine::string::CREEP_SETTLE_MS as u64;
/// The machine's creep window closes this long into the hold, ms (`CREEP_WINDOW_MS` later).
const WINDOW_CLOSES_MS: u64 = WINDOW_OPENS_MS + taut_core::machine::string::CREEP_WINDOW_MS as u64;

/// One string on one machine: the estimate beside the truth.
#[derive(Clone, Debug)]
pub struct Estimate {
    /// The string preset.
    pub kind: StringKind,
    /// `nominal` or `family N`.
    pub machine: String,
    /// The speed setting pulled at.
    pub speed: u8,
    /// The target, kgf.
    pub target_kgf: f64,
    /// The string's true stiffness in this pull: the true tension gained over the true
    /// carriage travel between 1/2 and 3/4 of the target, kgf/mm.
    pub stiffness_true: f64,
    /// The string's instantaneous stiffness `E·A/L` (the twin's parameter), kgf/mm: above
    /// the pull's by what the relaxation gives way at the pull's speed.
    pub stiffness_instantaneous: f64,
    /// The machine's estimate, kgf/mm (NaN: none).
    pub stiffness_estimate: f64,
    /// The twin's creep over the window, %/min.
    pub creep_true: f64,
    /// The machine's estimate, %/min (NaN: none).
    pub creep_estimate: f64,
    /// Why the run did not give an estimate, if it did not.
    pub failure: Option<String>,
}

impl Estimate {
    /// The stiffness error, share of the truth.
    #[must_use]
    pub fn stiffness_error(&self) -> f64 {
        self.stiffness_estimate / self.stiffness_true - 1.0
    }

    /// The estimate against the instantaneous stiffness `E·A/L`, share of it.
    #[must_use]
    pub fn instantaneous_error(&self) -> f64 {
        self.stiffness_estimate / self.stiffness_instantaneous - 1.0
    }

    /// The creep error, share of the truth.
    #[must_use]
    pub fn creep_error(&self) -> f64 {
        self.creep_estimate / self.creep_true - 1.0
    }

    /// Whether both are within their tolerance.
    #[must_use]
    pub fn accepted(&self) -> bool {
        self.failure.is_none()
            && self.stiffness_error().abs() <= STIFFNESS_TOLERANCE
            && self.creep_error().abs() <= CREEP_TOLERANCE
    }
}

/// Presses `key` for 60 ms, then lets 60 ms pass.
fn press(bench: &mut Bench, key: Key) {
    bench.twin_mut().press(Keys::NONE.with(key), 60);
    bench.run(120);
}

/// Runs until the machine is in `state`, within `max_ms`.
fn reach(bench: &mut Bench, state: MachineState, max_ms: u64) -> Result<(), String> {
    if bench.run_until(max_ms, |b| b.machine().state() == state) {
        Ok(())
    } else {
        Err(format!("{} not reached (in {:?})", state.name(), bench.machine().state()))
    }
}

/// One pull of `kind`'s middle tension on `config`, held `hold_ms`: the log entry, the true
/// creep rate over the machine's window (kgf/s), the true mean tension in it (kgf) and the
/// string's true stiffness in the pull (kgf/mm, between 1/2 and 3/4 of the target).
///
/// # Errors
/// Commissioning failed, a state was not reached, or nothing was logged.
pub fn pull_and_hold(
    config: &TwinConfig,
    target_tenths: u16,
    speed: u8,
    hold_ms: u64,
) -> Result<(PullRecord, f64, f64, f64), String> {
    let commissioned = commission(&factory_config(config), true, &mut |_| {})
        .map_err(|e| format!("commissioning: {e}"))?;
    let mut bench = Bench::power_up(config, &commissioned.flash);
    reach(&mut bench, MachineState::CalibrationWindow, 10_000)?;
    press(&mut bench, Key::Start);
    reach(&mut bench, MachineState::Ready, 2_000)?;
    // Key in the target (0.1 kg a press).
    for _ in 0..1_000 {
        let set = bench.machine().record().settings.set_point().tenths();
        if set == target_tenths {
            break;
        }
        press(&mut bench, if set < target_tenths { Key::Up } else { Key::Down });
    }
    // The speed page (Function), then back to the tension page (four more).
    press(&mut bench, Key::Function);
    for _ in 0..20 {
        let set = bench.machine().record().settings.speed().get();
        if set == speed {
            break;
        }
        press(&mut bench, if set < speed { Key::Up } else { Key::Down });
    }
    for _ in 0..5 {
        press(&mut bench, Key::Function);
    }
    if bench.machine().record().settings.speed().get() != speed {
        return Err(format!("speed {speed} not keyed in"));
    }
    press(&mut bench, Key::Start);
    // The string's own stiffness at this pull: the true tension gained over the true
    // carriage travel between 1/2 and 3/4 of the target, as the machine's probe measures it.
    let target = f64::from(target_tenths) / 10.0;
    // (true tension kgf, true carriage mm) where the tension first reached each point.
    let mut lower: Option<(f64, f64)> = None;
    let mut upper: Option<(f64, f64)> = None;
    let mut in_pull = 0u32;
    while bench.machine().state() != MachineState::Holding {
        in_pull += 1;
        if in_pull > 70_000 {
            return Err(format!("holding not reached (in {:?})", bench.machine().state()));
        }
        bench.tick();
        let truth = bench.twin().truth();
        let point = (truth.tension_kgf, truth.carriage_mm);
        if lower.is_none() && truth.tension_kgf >= target / 2.0 {
            lower = Some(point);
        }
        if upper.is_none() && truth.tension_kgf >= target * 0.75 {
            upper = Some(point);
        }
    }
    let rate_stiffness = match (lower, upper) {
        (Some((t0, x0)), Some((t1, x1))) if x1 > x0 => (t1 - t0) / (x1 - x0),
        _ => f64::NAN,
    };
    let (mut rate_sum, mut tension_sum, mut samples) = (0.0, 0.0, 0u64);
    for held in 1..=hold_ms {
        bench.tick();
        if held > WINDOW_OPENS_MS && held <= WINDOW_CLOSES_MS {
            let truth = bench.twin().truth();
            rate_sum += truth.string_relaxation_kgf_per_s;
            tension_sum += truth.tension_kgf;
            samples += 1;
        }
        if bench.machine().state() != MachineState::Holding {
            return Err(format!("left the hold: {:?}", bench.machine().state()));
        }
    }
    press(&mut bench, Key::Start);
    reach(&mut bench, MachineState::Ready, 40_000)?;
    let entry = *bench.machine().log().last().ok_or("nothing logged")?;
    let n = samples.max(1) as f64;
    Ok((entry, rate_sum / n, tension_sum / n, rate_stiffness))
}

/// The estimate of `kind` on `config` (`machine` names it).
#[must_use]
pub fn estimate(
    kind: StringKind,
    config: &TwinConfig,
    machine: String,
    speed: u8,
    hold_ms: u64,
) -> Estimate {
    let (low, high) = target_range(kind);
    let target_tenths = ((low + high) * 5.0).round() as u16;
    let mut out = Estimate {
        kind,
        machine,
        speed,
        target_kgf: f64::from(target_tenths) / 10.0,
        stiffness_true: f64::NAN,
        stiffness_instantaneous: config.string.stiffness_kgf_per_cm / 10.0,
        stiffness_estimate: f64::NAN,
        creep_true: f64::NAN,
        creep_estimate: f64::NAN,
        failure: None,
    };
    match pull_and_hold(config, target_tenths, speed, hold_ms) {
        Ok((entry, rate, tension, stiffness)) => {
            out.stiffness_true = stiffness;
            out.creep_true = rate / tension * 100.0 * 60.0;
            out.stiffness_estimate =
                entry.stiffness.map_or(f64::NAN, |k| f64::from(k.milli()) / 1_000.0);
            out.creep_estimate =
                entry.creep.map_or(f64::NAN, |c| f64::from(c.centi_percent_per_minute()) / 100.0);
            if entry.stiffness.is_none() || entry.creep.is_none() {
                out.failure = Some("no estimate logged".to_owned());
            }
        }
        Err(why) => out.failure = Some(why),
    }
    out
}

/// The speed settings the runs cycle through: the gentlest, the fastest and the middle.
pub const SPEEDS: [u8; 3] = [1, 9, 5];

/// The runs: every preset on the nominal machine at speed 3, then on `seeds` machines of the
/// family at the speeds of [`SPEEDS`] in turn.
#[must_use]
pub fn run(seeds: u64, hold_ms: u64) -> Vec<Estimate> {
    let mut out = Vec::new();
    for kind in StringKind::STRINGS {
        out.push(estimate(kind, &TwinConfig::nominal(kind), "nominal".to_owned(), 3, hold_ms));
        for seed in 1..=seeds {
            let config = TwinConfig::family_kind(kind, seed);
            let speed = SPEEDS[usize::try_from(seed - 1).unwrap_or(0) % SPEEDS.len()];
            out.push(estimate(kind, &config, format!("family {seed}"), speed, hold_ms));
        }
    }
    out
}

/// The report as Markdown: a title line, the table (one row per run) and the worst figures.
#[must_use]
pub fn text(rows: &[Estimate], hold_ms: u64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "String estimate against the twin (hold {:.0} s; stiffness kgf/mm, creep %/min of the tension)\n",
        hold_ms as f64 / 1e3
    );
    s.push_str(
        "| string | machine | speed | target kgf | K true | K est | error | E·A/L | vs it | creep | est | error | verdict |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let verdict = match &r.failure {
            Some(why) => format!("FAILED: {why}"),
            None if r.accepted() => "ok".to_owned(),
            None => "OUT OF TOLERANCE".to_owned(),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {} | {} | {} % | {:.3} | {} % | {} | {} | {} % | {verdict} |",
            r.kind.name(),
            r.machine,
            r.speed,
            r.target_kgf,
            cell(r.stiffness_true, 3),
            cell(r.stiffness_estimate, 3),
            cell(r.stiffness_error() * 100.0, 1),
            r.stiffness_instantaneous,
            cell(r.instantaneous_error() * 100.0, 1),
            cell(r.creep_true, 2),
            cell(r.creep_estimate, 2),
            cell(r.creep_error() * 100.0, 1),
        );
    }
    let worst = |error: fn(&Estimate) -> f64| {
        rows.iter()
            .map(|r| error(r).abs())
            .fold(0.0_f64, |a, b| if b.is_nan() { a } else { a.max(b) })
    };
    let accepted = rows.iter().filter(|r| r.accepted()).count();
    let _ = writeln!(
        s,
        "\nWorst: stiffness {:.1} % (tolerance {:.0} %; against E·A/L {:.1} %), creep {:.1} % (tolerance {:.0} %); {accepted}/{} within both",
        worst(Estimate::stiffness_error) * 100.0,
        STIFFNESS_TOLERANCE * 100.0,
        worst(Estimate::instantaneous_error) * 100.0,
        worst(Estimate::creep_error) * 100.0,
        CREEP_TOLERANCE * 100.0,
        rows.len()
    );
    s
}

/// The JSON summary.
#[must_use]
pub fn to_json(rows: &[Estimate], hold_ms: u64) -> Value {
    json!({
        "hold_ms": hold_ms,
        "stiffness_tolerance": STIFFNESS_TOLERANCE,
        "creep_tolerance": CREEP_TOLERANCE,
        "runs": rows.iter().map(|r| json!({
            "string": r.kind.name(),
            "machine": r.machine,
            "speed": r.speed,
            "target_kgf": number(r.target_kgf),
            "stiffness_true_kgf_per_mm": number(r.stiffness_true),
            "stiffness_instantaneous_kgf_per_mm": number(r.stiffness_instantaneous),
            "stiffness_estimate_kgf_per_mm": number(r.stiffness_estimate),
            "creep_true_percent_per_min": number(r.creep_true),
            "creep_estimate_percent_per_min": number(r.creep_estimate),
            "accepted": r.accepted(),
            "failure": r.failure,
        })).collect::<Vec<_>>(),
    })
}

/// `taut report string`. `Ok(false)` when an estimate is out of tolerance.
///
/// # Errors
/// The JSON file cannot be written.
pub fn main(args: &StringArgs) -> Status {
    let outputs = Outputs::new().file("--json", args.json.as_deref()).check()?;
    // Within HOLD_MIN_MS..=HOLD_MAX_MS (the parser's range): the cast is exact.
    let hold_ms = u64::from((args.hold * 1_000.0).round() as u32);
    let rows = run(args.seeds, hold_ms);
    let files: Vec<_> =
        args.json.iter().map(|path| (path.clone(), json_bytes(&to_json(&rows, hold_ms)))).collect();
    outputs.write(&files)?;
    print!("{}", text(&rows, hold_ms));
    if let Some(path) = &args.json {
        println!("summary: {}", path.display());
    }
    Ok(rows.iter().all(Estimate::accepted))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_is_markdown_with_rounded_rows() {
        let row = Estimate {
            kind: StringKind::TennisSynthetic,
            machine: "nominal".to_owned(),
            speed: 3,
            target_kgf: 25.0,
            stiffness_true: 0.748_123_456,
            stiffness_instantaneous: 0.758_333_333,
            stiffness_estimate: 0.747_654_321,
            creep_true: 35.281_234,
            creep_estimate: 35.391_234,
            failure: None,
        };
        let text = text(&[row], 20_000);
        let lines: Vec<&str> = text.lines().collect();
        let header = lines.iter().position(|l| l.starts_with("| string |"));
        let header = header.unwrap_or(usize::MAX);
        assert!(header < lines.len(), "no table header in\n{text}");
        assert!(lines.get(header + 1).is_some_and(|l| l.starts_with("|---|")), "{text}");
        assert!(super::super::rounded(&text, 3), "a raw float in\n{text}");
    }
}

//! `taut report machine`: whole machine cycles across the family of machines — the
//! firmware's `Machine` on the bench, worked by the simulated operator — with string breaks
//! and real faults injected in some of them.
//!
//! # A cycle
//!
//! Machine `i` of the family ([`TwinConfig::family`]: inertia 0.5–2×, friction, bus
//! 20–30 V, both kinds of current sensing, …, or the board `--sensing` names) powers up with
//! factory defaults; the operator runs the 4-point calibration in the machine's calibration
//! states, keys a target drawn from the string kind's stringing range (badminton 8–15/16 kg, tennis 15–35 kg) and a speed drawn from 1–9, presses Start, holds
//! for [`HOLD_MS`] and releases: boot, homing, calibration, set, pull, hold, release.
//!
//! With `--axis NAME=POSITION` every cycle runs instead on the robustness sweep's machine at
//! that point — the family's centre with one axis moved, the string kinds in turn — and the
//! position may lie past the axis's ends (−1 … 2, [`TwinConfig::beyond_axis`]): whether the
//! machine's fault detection holds on a machine the family does not contain. A point whose
//! machine is not physical is refused before any cycle runs.
//!
//! # Injections (deterministic by cycle index)
//!
//! - every `--break-every`th cycle (index `k−1`, `2k−1`, …): the string breaks
//!   [`BREAK_AFTER_MS`] into the hold;
//! - every `--fault-every`th cycle (index `k/2`, `k/2 + k`, …): a real fault
//!   [`FAULT_AFTER_MS`] into the pull — while the carriage runs at the take-up speed — in
//!   turn a 95 % inter-turn short of phase A (a real overcurrent: the winding current rises
//!   past the trip), a seized carriage (a stalled rotor under the pull's full duty command),
//!   and an 80 % inter-turn short. The twin's 80 % short (resistance, inductance and back-EMF
//!   of the phase scaled alike) stays below the trip under the duty window: it is reported
//!   with the true peak current it reached, *contained* if that is below the trip, and
//!   detected when its sustained excess over the window's limit latches E-10.
//!
//! A fault the machine latches in a cycle with nothing injected, or before the injection, is
//! a **false fault**; the first fault latched after an injection is its **detection**, timed
//! from the injection. The true peak winding current of every run without an injected
//! electrical fault ([`taut_sim::Truth::peak_current_a`]) is reported as a share of the
//! drive's 12 A trip, and the highest bus voltage of all runs.

use std::fmt::Write as _;

use serde_json::{Value, json};
use taut_core::drive::Phase;
use taut_core::machine::{FaultCode, MachineState};
use taut_core::settings::{SetPoint, Settings, Unit};
use taut_core::store::Record;
use taut_sim::bench::{Bench, Session, fault_name, run_session};
use taut_sim::operator::{Operator, Plan};
use taut_sim::twin::Fault;
use taut_sim::{SimRng, StringKind, TwinConfig};

use super::robustness::{check_corner, corner_json, corner_machine, describe_corner, string_for};
use super::{cell, number, percentile, scenario_seed, target_range};
use crate::cli::MachineArgs;
use crate::job::summary::TRIP_A;
use crate::output::{Outputs, Progress, Status, json_bytes, parallel, threads};

/// How long the operator holds before releasing, ms.
pub const HOLD_MS: u32 = 2_000;
/// A string break is injected this long after the machine enters Holding, ms.
pub const BREAK_AFTER_MS: u64 = 500;
/// A real fault is injected this long after the machine enters Pulling, ms.
pub const FAULT_AFTER_MS: u64 = 100;

/// What a cycle has injected.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Injection {
    /// Nothing: a healthy machine.
    None,
    /// The string breaks during the hold.
    StringBreak,
    /// 95 % of phase A's turns shorted during the pull: a real overcurrent.
    ShortedPhase,
    /// The carriage seizes during the pull (a stalled rotor at full duty command).
    StalledRotor,
    /// 80 % of phase A's turns shorted during the pull: contained below the trip.
    PartialShort,
}

impl Injection {
    /// A short name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::StringBreak => "string break",
            Self::ShortedPhase => "shorted phase 95 %",
            Self::StalledRotor => "stalled rotor",
            Self::PartialShort => "shorted phase 80 %",
        }
    }

    /// What cycle `index` injects.
    #[must_use]
    pub const fn for_cycle(index: u64, break_every: u64, fault_every: u64) -> Self {
        if fault_every > 0 && index % fault_every == fault_every / 2 {
            match (index / fault_every) % 3 {
                0 => Self::ShortedPhase,
                1 => Self::StalledRotor,
                _ => Self::PartialShort,
            }
        } else if break_every > 0 && index % break_every == break_every - 1 {
            Self::StringBreak
        } else {
            Self::None
        }
    }
}

/// One cycle's outcome.
#[derive(Clone, Debug)]
pub struct Cycle {
    /// Index.
    pub index: u64,
    /// The board's current sensing.
    pub sensing: String,
    /// The supply voltage, V.
    pub supply_v: f64,
    /// What was injected.
    pub injection: Injection,
    /// When it was injected, ms since power-up (`None`: never reached the point).
    pub injected_ms: Option<u64>,
    /// The first fault latched, with its time (ms since power-up).
    pub fault: Option<(FaultCode, u64)>,
    /// The cycle completed: released home with no fault.
    pub completed: bool,
    /// The largest true winding current, A.
    pub peak_current_a: f64,
    /// The largest true winding current from the injection on, A (0 without one).
    pub peak_after_injection_a: f64,
    /// The highest bus voltage, V.
    pub bus_peak_v: f64,
    /// The state the cycle ended in.
    pub last_state: MachineState,
    /// How many times the carriage met the end stop past the home switch.
    pub end_stop_hits: u32,
    /// Where the carriage ended, mm from where the home switch closes (0).
    pub rest_mm: f64,
}

impl Cycle {
    /// A fault on a healthy machine (nothing injected yet).
    #[must_use]
    pub fn false_fault(&self) -> Option<FaultCode> {
        let (code, at) = self.fault?;
        match self.injected_ms {
            Some(injected) if at >= injected => None,
            _ => Some(code),
        }
    }

    /// The detection of the injection: code and time from the injection, ms.
    #[must_use]
    pub fn detection(&self) -> Option<(FaultCode, u64)> {
        let (code, at) = self.fault?;
        let injected = self.injected_ms?;
        (at >= injected).then(|| (code, at - injected))
    }
}

/// The settings of cycle `seed` on a `kind` of string: a target from the kind's range
/// ([`target_range`], 0.1 kg) and a speed from 1–9.
#[must_use]
pub fn settings(seed: u64, kind: StringKind) -> Settings {
    let mut rng = SimRng::substream(seed, 0x5E77);
    let (low, high) = target_range(kind);
    let tenths = (rng.range(low, high) * 10.0).round() as u16;
    let speed = (rng.range(1.0, 10.0).floor() as u8).clamp(1, 9);
    SetPoint::new(Unit::Kilograms, tenths)
        .and_then(|sp| Settings::new(sp, speed, 0, 0))
        .unwrap_or_default()
}

/// Cycle `index`'s machine: the family's draw for `seed`, or with `--axis` the sweep's
/// machine at that point (or the corner of several) with the string kinds in turn (and
/// `seed` for its noise). A machine that is not physical ([`corner_machine`] refuses it
/// before any cycle runs) falls back to the family's centre.
fn machine(args: &MachineArgs, index: u64, seed: u64) -> TwinConfig {
    if args.axis.is_empty() {
        return TwinConfig::family(seed);
    }
    let kind = string_for(index);
    corner_machine(&args.axis, kind)
        .unwrap_or_else(|_| TwinConfig::family_centre(kind))
        .with_seed(seed)
}

/// Runs cycle `index`.
#[must_use]
pub fn run_cycle(args: &MachineArgs, index: u64) -> Cycle {
    let seed = scenario_seed(args.seed, index);
    let config = args.sensing.apply(machine(args, index, seed));
    run_cycle_on(&config, args, index)
}

/// Cycle `index` of `args` (its settings, injection and hold) on the machine `config`.
#[must_use]
pub fn run_cycle_on(config: &TwinConfig, args: &MachineArgs, index: u64) -> Cycle {
    let seed = scenario_seed(args.seed, index);
    let injection = Injection::for_cycle(index, args.break_every, args.fault_every);
    let mut bench = Bench::power_up(config, &Record::default().encode());
    let plan = Plan {
        calibrate: true,
        settings: settings(seed, config.string.kind),
        knot_mode: false,
        pull_hold_ms: Some(HOLD_MS),
    };
    let mut operator = Operator::new(plan);
    let mut entered: Option<(MachineState, u64)> = None;
    let mut injected_ms = None;
    let mut fault = None;
    let (mut peak_current_a, mut bus_peak_v, mut peak_after_a) = (0.0_f64, 0.0_f64, 0.0_f64);
    let _ = run_session(&mut bench, &mut operator, Session::Job, &mut |_| {}, |bench, operator| {
        let now = bench.twin().now_ms();
        let truth = bench.twin().truth();
        peak_current_a = peak_current_a.max(truth.peak_current_a.abs());
        if injected_ms.is_some() {
            peak_after_a = peak_after_a.max(truth.peak_current_a.abs());
        }
        bus_peak_v = bus_peak_v.max(truth.bus_peak_volts);
        let state = bench.machine().state();
        if entered.is_none_or(|(s, _)| s != state) {
            entered = Some((state, now));
        }
        if fault.is_none() {
            if let Some(code) = bench.machine().fault() {
                fault = Some((code, now));
            }
        }
        if injected_ms.is_none() {
            let since = |wanted: MachineState| {
                entered.filter(|(s, _)| *s == wanted).map_or(0, |(_, t)| now - t)
            };
            let inject =
                match injection {
                    Injection::None => None,
                    Injection::StringBreak => (since(MachineState::Holding) >= BREAK_AFTER_MS)
                        .then_some(Fault::StringBreak),
                    Injection::ShortedPhase => (since(MachineState::Pulling) >= FAULT_AFTER_MS)
                        .then_some(Fault::ShortedPhase { phase: Phase::A, shorted_percent: 95 }),
                    Injection::PartialShort => (since(MachineState::Pulling) >= FAULT_AFTER_MS)
                        .then_some(Fault::ShortedPhase { phase: Phase::A, shorted_percent: 80 }),
                    Injection::StalledRotor => (since(MachineState::Pulling) >= FAULT_AFTER_MS)
                        .then_some(Fault::CarriageJam),
                };
            if let Some(f) = inject {
                bench.twin_mut().inject(f);
                injected_ms = Some(now);
            }
        }
        operator.finished()
    });
    Cycle {
        index,
        sensing: config.current_sense.name(),
        supply_v: config.bridge.bus_volts,
        injection,
        injected_ms,
        fault,
        completed: operator.finished() && !operator.stopped() && bench.machine().fault().is_none(),
        peak_current_a,
        peak_after_injection_a: peak_after_a,
        bus_peak_v,
        last_state: bench.machine().state(),
        end_stop_hits: bench.twin().truth().end_stop_hits,
        rest_mm: bench.twin().truth().carriage_mm,
    }
}

/// Counts by key, sorted by key.
fn tally<K: Ord + Clone>(keys: impl Iterator<Item = K>) -> Vec<(K, usize)> {
    let mut out: Vec<(K, usize)> = Vec::new();
    for key in keys {
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, c)) => *c += 1,
            None => out.push((key, 1)),
        }
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// What became of one kind of injection.
#[derive(Clone, Debug)]
pub struct Detections {
    /// The kind.
    pub kind: Injection,
    /// Cycles planned to have it (a cycle that faulted before the point of injection never
    /// gets it).
    pub planned: usize,
    /// Cycles it was injected in.
    pub injected: usize,
    /// Cycles in which the machine latched a fault after it.
    pub detected: usize,
    /// The codes it latched, with counts.
    pub codes: Vec<(String, usize)>,
    /// The slowest detection, ms from the injection.
    pub slowest_ms: Option<u64>,
    /// The largest true winding current after the injection over these cycles, A.
    pub peak_after_a: f64,
}

/// The report's figures.
#[derive(Clone, Debug)]
pub struct Findings {
    /// Cycles run.
    pub cycles: usize,
    /// Cycles that completed.
    pub completed: usize,
    /// False faults by code.
    pub false_faults: Vec<(String, usize)>,
    /// Per injection kind.
    pub injections: Vec<Detections>,
    /// Peak winding current over the runs without an electrical fault injected: max, p99, A.
    pub peak_current_a: (f64, f64),
    /// Highest bus voltage, V.
    pub bus_max_v: f64,
    /// Current-sensing mix.
    pub sensing: Vec<(String, usize)>,
    /// Arrivals at the end stop past the home switch, over every cycle, the cycles with any,
    /// and of those the cycles that completed (normal operation: no fault latched).
    pub end_stop: (u32, usize, usize),
    /// The completed cycles' largest distance of the carriage at rest from the home switch,
    /// mm.
    pub rest_max_mm: f64,
}

/// Aggregates `cycles`.
#[must_use]
pub fn findings(cycles: &[Cycle]) -> Findings {
    let false_faults = tally(cycles.iter().filter_map(Cycle::false_fault).map(fault_name));
    let injections = [
        Injection::StringBreak,
        Injection::ShortedPhase,
        Injection::StalledRotor,
        Injection::PartialShort,
    ]
    .into_iter()
    .map(|kind| {
        let mine: Vec<&Cycle> =
            cycles.iter().filter(|c| c.injection == kind && c.injected_ms.is_some()).collect();
        let detected: Vec<(FaultCode, u64)> = mine.iter().filter_map(|c| c.detection()).collect();
        let codes = tally(detected.iter().map(|(code, _)| fault_name(*code)));
        let slowest_ms = detected.iter().map(|(_, ms)| *ms).max();
        let planned = cycles.iter().filter(|c| c.injection == kind).count();
        let peak_after_a = mine.iter().map(|c| c.peak_after_injection_a).fold(0.0, f64::max);
        Detections {
            kind,
            planned,
            injected: mine.len(),
            detected: detected.len(),
            codes,
            slowest_ms,
            peak_after_a,
        }
    })
    .collect();
    let healthy: Vec<f64> = cycles
        .iter()
        .filter(|c| {
            !matches!(
                c.injection,
                Injection::ShortedPhase | Injection::StalledRotor | Injection::PartialShort
            )
        })
        .map(|c| c.peak_current_a)
        .collect();
    Findings {
        cycles: cycles.len(),
        completed: cycles.iter().filter(|c| c.completed).count(),
        false_faults,
        injections,
        peak_current_a: (percentile(&healthy, 100.0), percentile(&healthy, 99.0)),
        bus_max_v: cycles.iter().map(|c| c.bus_peak_v).fold(0.0, f64::max),
        sensing: tally(cycles.iter().map(|c| c.sensing.clone())),
        end_stop: (
            cycles.iter().map(|c| c.end_stop_hits).sum(),
            cycles.iter().filter(|c| c.end_stop_hits > 0).count(),
            cycles.iter().filter(|c| c.end_stop_hits > 0 && c.completed).count(),
        ),
        rest_max_mm: cycles
            .iter()
            .filter(|c| c.completed)
            .map(|c| c.rest_mm.abs())
            .fold(0.0, f64::max),
    }
}

/// The report as text.
#[must_use]
pub fn text(f: &Findings) -> String {
    let mut out = String::new();
    let healthy_faults: usize = f.false_faults.iter().map(|(_, c)| c).sum();
    let _ = writeln!(
        out,
        "{} cycles, {} completed; false faults (a fault on a healthy machine): {healthy_faults}",
        f.cycles, f.completed
    );
    out.push_str("\n| fault code | false faults |\n|---|---|\n");
    for (code, count) in &f.false_faults {
        let _ = writeln!(out, "| {code} | {count} |");
    }
    if f.false_faults.is_empty() {
        out.push_str("| — | 0 |\n");
    }
    out.push_str(
        "\n| injected | planned | cycles injected | detected | codes | slowest detection | true peak current after |\n|---|---|---|---|---|---|---|\n",
    );
    for d in &f.injections {
        let (kind, injected, detected, slowest) = (d.kind, &d.injected, &d.detected, d.slowest_ms);
        let codes: Vec<String> = d.codes.iter().map(|(c, n)| format!("{n} {c}")).collect();
        let _ = writeln!(
            out,
            "| {} | {} | {injected} | {detected} ({}) | {} | {} | {} |",
            kind.name(),
            d.planned,
            if *injected > 0 {
                format!("{:.0} %", *detected as f64 / *injected as f64 * 100.0)
            } else {
                "—".to_owned()
            },
            if codes.is_empty() { "—".to_owned() } else { codes.join(", ") },
            slowest.map_or_else(|| "—".to_owned(), |ms| format!("{ms} ms")),
            if *injected > 0 && d.kind != Injection::StringBreak {
                format!(
                    "{} A ({})",
                    cell(d.peak_after_a, 2),
                    if d.peak_after_a < TRIP_A {
                        "contained below the trip"
                    } else {
                        "past the trip"
                    }
                )
            } else {
                "—".to_owned()
            }
        );
    }
    let (max, p99) = f.peak_current_a;
    let _ = writeln!(
        out,
        "\ntrue peak winding current per run (runs without an injected electrical fault): max {} A ({} % of the {TRIP_A:.0} A trip), p99 {} A ({} %)",
        cell(max, 2),
        cell(max / TRIP_A * 100.0, 0),
        cell(p99, 2),
        cell(p99 / TRIP_A * 100.0, 0)
    );
    let _ = writeln!(out, "highest bus voltage: {} V", cell(f.bus_max_v, 2));
    let mix: Vec<String> = f.sensing.iter().map(|(n, c)| format!("{c} {n}")).collect();
    let _ = writeln!(out, "current sensing: {}", mix.join(", "));
    let _ = writeln!(
        out,
        "end stop past the home switch met {} times (in {} cycles, {} of them completed); completed cycles at rest within {} mm of the home switch",
        f.end_stop.0,
        f.end_stop.1,
        f.end_stop.2,
        cell(f.rest_max_mm, 2)
    );
    out
}

/// The report as JSON.
#[must_use]
pub fn to_json(args: &MachineArgs, f: &Findings) -> Value {
    json!({
        "cycles": f.cycles,
        "seed": args.seed,
        "sensing": args.sensing.name(),
        "axis": corner_json(&args.axis),
        "break_every": args.break_every,
        "fault_every": args.fault_every,
        "completed": f.completed,
        "false_faults": f.false_faults.iter().map(|(c, n)| json!({"code": c, "count": n})).collect::<Vec<_>>(),
        "injections": f.injections.iter().map(|d| json!({
            "kind": d.kind.name(),
            "planned": d.planned,
            "cycles": d.injected,
            "detected": d.detected,
            "codes": d.codes.iter().map(|(c, n)| json!({"code": c, "count": n})).collect::<Vec<_>>(),
            "slowest_detection_ms": d.slowest_ms,
            "peak_current_after_a": number(d.peak_after_a),
        })).collect::<Vec<_>>(),
        "peak_current_max_a": number(f.peak_current_a.0),
        "peak_current_p99_a": number(f.peak_current_a.1),
        "peak_current_max_percent_of_trip": number(f.peak_current_a.0 / TRIP_A * 100.0),
        "peak_current_p99_percent_of_trip": number(f.peak_current_a.1 / TRIP_A * 100.0),
        "bus_max_v": number(f.bus_max_v),
        "current_sensing": f.sensing.iter().map(|(n, c)| json!({"board": n, "count": c})).collect::<Vec<_>>(),
        "end_stop_hits": f.end_stop.0,
        "end_stop_cycles": f.end_stop.1,
        "end_stop_completed_cycles": f.end_stop.2,
        "rest_from_home_max_mm": number(f.rest_max_mm),
    })
}

/// `taut report machine`.
///
/// # Errors
/// The JSON file cannot be written.
pub fn main(args: &MachineArgs) -> Status {
    let outputs = Outputs::new().file("--json", args.json.as_deref()).check()?;
    if !args.axis.is_empty() {
        check_corner(&args.axis)?;
        println!(
            "every cycle on the family's centre with {}\n",
            describe_corner(&args.axis, StringKind::TennisSynthetic)
        );
    }
    let started = std::time::Instant::now();
    let progress = Progress::new(args.cycles as usize, "cycles");
    let cycles = parallel(args.cycles, threads(args.threads), &progress, &|i| run_cycle(args, i));
    let f = findings(&cycles);
    let files: Vec<_> =
        args.json.iter().map(|path| (path.clone(), json_bytes(&to_json(args, &f)))).collect();
    outputs.write(&files)?;
    if args.detail {
        for c in &cycles {
            println!(
                "{:5} {:28} {:4.1} V  {:13} fault {:8} peak {:5.2} A  bus {:5.2} V  {}",
                c.index,
                c.sensing,
                c.supply_v,
                c.injection.name(),
                c.fault.map_or_else(
                    || "—".to_owned(),
                    |(code, at)| format!("{} at {:.3} s", fault_name(code), at as f64 / 1e3)
                ),
                c.peak_current_a,
                c.bus_peak_v,
                if c.completed { "completed" } else { "not completed" }
            );
        }
    }
    print!("{}", text(&f));
    println!("wall clock: {:.1} s", started.elapsed().as_secs_f64());
    if let Some(path) = &args.json {
        println!("summary: {}", path.display());
    }
    Ok(true)
}

//! The main job's machine cycle on the image: the same operator, plan and twin as the host
//! bench's main job, with the firmware in place of taut-core on the host.
//!
//! Two sessions, as a builder's first day goes: **commissioning** on erased flash (boot,
//! self-test, the calibration window — calibrated with the reference gauge in two passes,
//! or skipped for a short run —, the previous job's settings keyed in and stored by the
//! firmware's settings store on the emulated flash), then a **power cycle** (the part reset,
//! flash kept) and the **job** (power-up from the stored record, the set point keyed in,
//! Start, hold, Start to release, home). The same plan runs on the host bench (taut-core
//! linked into the host, `taut_sim::bench`), and both runs' figures are computed by one
//! function from what both have alike: the panel's lamps and the twin's truth.

use taut_core::io::Leds;
use taut_core::settings::{SetPoint, Settings, Unit};
use taut_sim::bench::{
    self as host_bench, Bench as HostBench, Session, factory_config, run_session,
};
use taut_sim::operator::{Operator, Plan, previous_job};
use taut_sim::params::{StringKind, TwinConfig};
use taut_sim::twin::Twin;

use crate::bench::Bench;
use crate::elf::Image;
use crate::mcu::Mcu;
use crate::soc::Stop;

/// One tick of a run, as both benches record it.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    /// Milliseconds since the job session's power-up.
    pub t_ms: u64,
    /// The lamps.
    pub leds: Leds,
    /// True tension, kgf.
    pub tension_kgf: f64,
    /// True peak winding current in the tick, A.
    pub peak_current_a: f64,
    /// Carriage, mm.
    pub carriage_mm: f64,
}

/// The figures compared.
#[derive(Debug, Clone, Copy, Default)]
pub struct Figures {
    /// From the pulling lamp's first light to the holding lamp's, s.
    pub time_to_tension_s: Option<f64>,
    /// Mean and largest |true − target| over the hold after its first 0.5 s, kgf.
    pub hold_error_mean_kgf: f64,
    /// The largest.
    pub hold_error_max_kgf: f64,
    /// Highest true tension, kgf.
    pub peak_tension_kgf: f64,
    /// Highest true winding current, A.
    pub peak_current_a: f64,
    /// The carriage at the end, mm.
    pub end_carriage_mm: f64,
    /// The fault lamp lit.
    pub faulted: bool,
    /// Hold length, s.
    pub hold_s: f64,
}

/// The figures of a run at `target_kgf`.
pub fn figures(samples: &[Sample], target_kgf: f64) -> Figures {
    let mut f = Figures::default();
    let pull = samples.iter().find(|s| s.leds.pulling).map(|s| s.t_ms);
    let hold = samples.iter().find(|s| s.leds.holding).map(|s| s.t_ms);
    if let (Some(p), Some(h)) = (pull, hold) {
        f.time_to_tension_s = Some((h - p) as f64 / 1e3);
    }
    let mut n = 0.0;
    let mut sum = 0.0;
    let mut held = 0;
    for s in samples {
        f.peak_tension_kgf = f.peak_tension_kgf.max(s.tension_kgf);
        f.peak_current_a = f.peak_current_a.max(s.peak_current_a);
        f.faulted |= s.leds.fault;
        if s.leds.holding {
            held += 1;
            if hold.is_some_and(|h| s.t_ms >= h + 500) {
                let e = (s.tension_kgf - target_kgf).abs();
                sum += e;
                n += 1.0;
                f.hold_error_max_kgf = f.hold_error_max_kgf.max(e);
            }
        }
    }
    f.hold_s = f64::from(held) / 1e3;
    f.hold_error_mean_kgf = if n > 0.0 { sum / n } else { 0.0 };
    f.end_carriage_mm = samples.last().map_or(0.0, |s| s.carriage_mm);
    f
}

/// What to run.
#[derive(Debug, Clone, Copy)]
pub struct Scenario {
    /// Calibrate in commissioning (two passes with the reference gauge) or skip it.
    pub calibrate: bool,
    /// Set point, kg.
    pub tension_tenths_kg: u16,
    /// Hold, ms.
    pub hold_ms: u32,
    /// The string.
    pub string: StringKind,
}

impl Scenario {
    /// The operator's settings.
    pub fn settings(&self) -> Settings {
        SetPoint::new(Unit::Kilograms, self.tension_tenths_kg)
            .and_then(|s| Settings::new(s, 3, 0, 0))
            .unwrap_or_else(|_| previous_job())
    }

    /// The twin.
    pub fn config(&self) -> TwinConfig {
        TwinConfig::nominal(self.string)
    }

    /// The job session's plan: the scenario's settings, pull, hold, release.
    pub fn job_plan(&self) -> Plan {
        Plan {
            calibrate: false,
            settings: self.settings(),
            knot_mode: false,
            pull_hold_ms: Some(self.hold_ms),
        }
    }

    /// The target, kgf.
    pub fn target_kgf(&self) -> f64 {
        f64::from(self.tension_tenths_kg) / 10.0
    }
}

/// A run's result on one bench.
#[derive(Debug, Clone)]
pub struct Run {
    /// The job session's ticks.
    pub samples: Vec<Sample>,
    /// Commissioning length, ms.
    pub commissioning_ms: u64,
    /// The figures.
    pub figures: Figures,
    /// The operator finished the plan (and was not stopped by a fault).
    pub completed: bool,
}

/// The longest a session may take, ms.
pub const SESSION_LIMIT_MS: u64 = 300_000;

/// Runs the scenario on the host bench (taut-core on the host).
pub fn host(scenario: &Scenario) -> Result<Run, String> {
    let config = scenario.config();
    let commissioning =
        host_bench::commission(&factory_config(&config), scenario.calibrate, &mut |_| {})
            .map_err(|e| format!("host commissioning: {e:?}"))?;
    let mut bench = HostBench::power_up(&config, &commissioning.flash).recording();
    let plan = scenario.job_plan();
    let mut operator = Operator::new(plan);
    let mut tail = None;
    run_session(&mut bench, &mut operator, Session::Job, &mut |_| {}, |bench, operator| {
        if operator.finished() {
            let end = *tail.get_or_insert(bench.twin().now_ms() + 200);
            return bench.twin().now_ms() >= end;
        }
        false
    })
    .map_err(|e| format!("host job: {e:?}"))?;
    let samples: Vec<Sample> = bench
        .rows()
        .iter()
        .map(|r| Sample {
            t_ms: r.t_ms,
            leds: r.outputs.leds,
            tension_kgf: r.truth.tension_kgf,
            peak_current_a: r.truth.peak_current_a,
            carriage_mm: r.truth.carriage_mm,
        })
        .collect();
    let figures = figures(&samples, scenario.target_kgf());
    Ok(Run {
        samples,
        commissioning_ms: commissioning.sim_ms,
        figures,
        completed: operator.finished() && !operator.stopped(),
    })
}

/// Progress of a PIL run: (session, simulated ms, panel text).
pub type Progress<'a> = &'a mut dyn FnMut(&str, u64, &Bench);

/// Runs one session of `operator` on the PIL bench until `done`.
fn session(
    bench: &mut Bench,
    operator: &mut Operator,
    name: &str,
    progress: Progress<'_>,
    mut done: impl FnMut(&mut Bench, &Operator) -> bool,
) -> Result<(), Stop> {
    let limit = std::env::var("TAUT_PIL_SESSION_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(SESSION_LIMIT_MS);
    for _ in 0..limit {
        bench.tick()?;
        operator.act(&mut bench.twin);
        if bench.twin.now_ms().is_multiple_of(100) {
            progress(name, bench.twin.now_ms(), bench);
        }
        if done(bench, operator) {
            return Ok(());
        }
    }
    Err(Stop::Misuse(format!("{name}: not finished within {} s of simulated time", limit / 1000)))
}

/// The PIL run's result, with the bench at its end (for its checks and timing).
pub struct PilRun {
    /// The run.
    pub run: Run,
    /// The bench.
    pub bench: Bench,
    /// The PC's traffic on the machine link during the job, and what came back.
    pub traffic: crate::link::Traffic,
}

/// A machine commissioned on the image: the bench at the end of the commissioning session.
pub struct Commissioned {
    /// The part (its flash holds the stored record).
    pub mcu: Mcu,
    /// The bench as the session left it.
    pub bench: Bench,
    /// The session's length, ms.
    pub ms: u64,
}

/// The commissioning session on the image (see the module docs).
pub fn commission_on(
    image: Image,
    scenario: &Scenario,
    progress: Progress<'_>,
) -> Result<Bench, (Stop, Option<Box<Bench>>)> {
    let config = scenario.config();
    let mcu = Mcu::new(image).map_err(|e| (Stop::Misuse(e), None))?;
    let mut bench = Bench::new(mcu, Twin::new(&factory_config(&config)));
    // Done once the operator has finished and the firmware has written the record and then
    // been idle for a second.
    let plan = Plan {
        calibrate: scenario.calibrate,
        settings: previous_job(),
        knot_mode: false,
        pull_hold_ms: None,
    };
    let mut operator = Operator::new(plan);
    let mut quiet_since: Option<(u64, u64)> = None;
    let result =
        session(&mut bench, &mut operator, "commissioning", progress, |bench, operator| {
            if operator.stopped() {
                return true;
            }
            let programmed = bench.mcu.soc().flash.programmed;
            if !operator.finished() || programmed == 0 {
                return false;
            }
            let now = bench.twin.now_ms();
            match quiet_since {
                Some((count, since)) if count == programmed => now >= since + 1000,
                _ => {
                    quiet_since = Some((programmed, now));
                    false
                }
            }
        });
    if let Err(stop) = result {
        return Err((stop, Some(Box::new(bench))));
    }
    if operator.stopped() {
        return Err((
            Stop::Misuse("commissioning stopped by a fault on the panel".into()),
            Some(Box::new(bench)),
        ));
    }
    Ok(bench)
}

/// [`commission_on`] without progress, for the fault injections.
pub fn commission(image: Image, scenario: &Scenario) -> Result<Commissioned, Stop> {
    let bench = commission_on(image, scenario, &mut |_, _, _| {}).map_err(|(stop, _)| stop)?;
    let ms = bench.twin.now_ms();
    let Bench { mcu, .. } = bench;
    let twin = Twin::new(&scenario.config());
    let bench = Bench::new(Mcu::new(mcu.image().clone()).map_err(Stop::Misuse)?, twin);
    Ok(Commissioned { mcu, bench, ms })
}

/// Runs the scenario on the image.
pub fn pil(
    image: Image,
    scenario: &Scenario,
    progress: Progress<'_>,
) -> Result<PilRun, (Stop, Option<Box<Bench>>)> {
    let config = scenario.config();
    let bench = commission_on(image, scenario, progress)?;
    let commissioning_ms = bench.twin.now_ms();
    // Power cycle: the part resets with its flash; a new twin from the job's configuration.
    let window_start = bench.window_start();
    let Bench { mut mcu, checker, periods, .. } = bench;
    if let Err(e) = mcu.reset("power cycle") {
        return Err((Stop::Misuse(e), None));
    }
    let mut bench = Bench::new(mcu, Twin::new(&config));
    bench.checker = checker;
    bench.periods = periods;
    bench.set_window_start(window_start);
    let plan = scenario.job_plan();
    let mut operator = Operator::new(plan);
    let mut samples = Vec::new();
    let mut tail = None;
    let mut traffic = crate::link::Traffic::default();
    let result = session(&mut bench, &mut operator, "job", progress, |bench, operator| {
        let (_, leds) = bench.panel();
        let now = bench.twin.now_ms();
        let busy = leds.pulling || leds.holding;
        traffic.millisecond(&mut bench.line, now, busy, operator.finished() && !busy);
        let truth = bench.twin.truth();
        samples.push(Sample {
            t_ms: bench.twin.now_ms(),
            leds,
            tension_kgf: truth.tension_kgf,
            peak_current_a: truth.peak_current_a,
            carriage_mm: truth.carriage_mm,
        });
        if operator.finished() {
            // The closing reads of the link are answered within a second.
            let end = *tail.get_or_insert(bench.twin.now_ms() + 200);
            return bench.twin.now_ms() >= end && (traffic.done() || now >= end + 1_000);
        }
        false
    });
    if let Err(stop) = result {
        return Err((stop, Some(Box::new(bench))));
    }
    let figures = figures(&samples, scenario.target_kgf());
    let completed = operator.finished() && !operator.stopped();
    Ok(PilRun { run: Run { samples, commissioning_ms, figures, completed }, bench, traffic })
}

/// The tolerances within which the image's figures must agree with the host bench's: the
/// time to tension within 5 % (the image's fast loop sees the sensors of its own sampling
/// instants and commutates on its own Hall reads), the hold's mean error within 0.2 kgf (the
/// board's load-cell divider reads 0.6 % low until a calibration takes it out: 0.15 kgf at
/// 25 kgf), the peak winding current within 10 %.
pub const TIME_TO_TENSION_TOLERANCE: f64 = 0.05;
/// See [`TIME_TO_TENSION_TOLERANCE`].
pub const HOLD_ERROR_TOLERANCE_KGF: f64 = 0.2;
/// See [`TIME_TO_TENSION_TOLERANCE`].
pub const PEAK_CURRENT_TOLERANCE: f64 = 0.10;

/// Whether two runs' figures agree, and a line per figure.
pub struct Agreement {
    /// Every figure within its tolerance.
    pub agrees: bool,
    /// What was compared.
    pub lines: Vec<String>,
}

/// Compares the image's figures with the host bench's.
pub fn agreement(pil: &Figures, host: &Figures) -> Agreement {
    let mut lines = Vec::new();
    let mut agrees = true;
    let mut judge = |name: &str, ok: bool, text: String| {
        agrees &= ok;
        lines.push(format!("{name}: {text} ({})", if ok { "agrees" } else { "DISAGREES" }));
    };
    match (pil.time_to_tension_s, host.time_to_tension_s) {
        (Some(p), Some(h)) => {
            let rel = (p - h).abs() / h;
            judge(
                "time to tension",
                rel <= TIME_TO_TENSION_TOLERANCE,
                format!(
                    "{:.1} % apart, tolerance {:.0} %",
                    100.0 * rel,
                    100.0 * TIME_TO_TENSION_TOLERANCE
                ),
            );
        }
        _ => judge("time to tension", false, "not reached on both benches".into()),
    }
    let d = (pil.hold_error_mean_kgf - host.hold_error_mean_kgf).abs();
    judge(
        "hold error",
        d <= HOLD_ERROR_TOLERANCE_KGF,
        format!("{d:.3} kgf apart, tolerance {HOLD_ERROR_TOLERANCE_KGF} kgf"),
    );
    let rel = (pil.peak_current_a - host.peak_current_a).abs() / host.peak_current_a.max(1e-9);
    judge(
        "peak current",
        rel <= PEAK_CURRENT_TOLERANCE,
        format!("{:.1} % apart, tolerance {:.0} %", 100.0 * rel, 100.0 * PEAK_CURRENT_TOLERANCE),
    );
    judge(
        "faults",
        !pil.faulted && !host.faulted,
        format!("fault lamp {} / {}", pil.faulted, host.faulted),
    );
    Agreement { agrees, lines }
}

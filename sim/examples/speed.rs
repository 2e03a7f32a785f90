//! How fast the twin runs: a 30 s pull / hold / release cycle, timed.
//!
//! The cycle is driven by a deliberately simple host-side controller (this is a speed
//! benchmark of the twin, not a controller): ramp to 95 % duty, slow down near the target,
//! hold the measured tension with a proportional–integral duty law for 20 s, then release
//! to the home switch. The figure printed is wall-clock seconds per simulated 30 s cycle,
//! which must be well under one second in release builds for Monte-Carlo use.
//!
//! `cargo run -p taut-sim --release --example speed [CYCLES] [--family]`
//!
//! With `--family` the scenarios are machines of the family (`TwinConfig::family_kind`:
//! backlash, gripper ringing, clamp, every current-sensing kind), each board's amplifier
//! made unidirectional at taut-core's gain so the core's drive, which does not read a
//! mid-rail zero yet, keeps running.
#![allow(
    clippy::float_arithmetic,
    clippy::print_stdout,
    clippy::cast_precision_loss,
    reason = "a host benchmark printing float results"
)]

use std::time::Instant;

use taut_core::drive::Direction;
use taut_core::io::{Inputs, Outputs};

use taut_sim::{CurrentSenseParams, StringKind, Twin, TwinConfig, drive_at, run};

/// The benchmark's simple controller: state and one step per tick.
struct Cycle {
    /// The paper's load-cell chain, untared.
    scale: taut_core::sense::load_cell::LoadCellScale,
    target_kgf: f64,
    integral: f64,
    held_since: Option<u32>,
    releasing: Option<u32>,
}

impl Cycle {
    fn step(&mut self, inputs: &Inputs) -> Outputs {
        let t = inputs.now_ms;
        let tension = self.scale.to_kgf(inputs.load_cell).0.to_num::<f64>();
        let command = if t >= 25_000 {
            let since = t.saturating_sub(*self.releasing.get_or_insert(t));
            let ramp = (f64::from(since) / 100.0).min(1.0);
            if inputs.limits.home { None } else { Some((Direction::Release, 0.6 * ramp)) }
        } else {
            let error = self.target_kgf - tension;
            if self.held_since.is_none() && error < 0.5 {
                self.held_since = Some(t);
            }
            if self.held_since.is_none() {
                let ramp = (f64::from(t) / 100.0).min(1.0);
                let approach = (error / 5.0).clamp(0.15, 1.0);
                Some((Direction::Pull, 0.95 * ramp * approach))
            } else {
                self.integral = (self.integral + 0.00002 * error).clamp(0.0, 0.5);
                Some((Direction::Pull, (0.02 * error + self.integral).clamp(0.0, 0.95)))
            }
        };
        let drive = command.map_or(Default::default(), |(d, duty)| drive_at(d, duty));
        Outputs { drive, ..Outputs::default() }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let family = args.iter().any(|a| a == "--family");
    let cycles: u32 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(5);
    let mut total = 0.0;
    let mut last = None;
    for cycle in 0..cycles {
        // Monte-Carlo scenarios (every noise source on, Hall reads voted) on a synthetic.
        let config = if family {
            let mut config = TwinConfig::family_kind(StringKind::TennisSynthetic, u64::from(cycle));
            let nominal = CurrentSenseParams::nominal();
            config.current_sense.offset_volts = nominal.offset_volts;
            config.current_sense.volts_per_amp = nominal.volts_per_amp;
            config
        } else {
            TwinConfig::sample_kind(StringKind::TennisSynthetic, u64::from(cycle))
        };
        let mut twin = Twin::new(&config);
        let scale = taut_sim::bench::board_for(&config).load_cell();
        let mut controller =
            Cycle { scale, target_kgf: 25.0, integral: 0.0, held_since: None, releasing: None };
        let start = Instant::now();
        let trace = run(&mut twin, 30_000, |inputs| controller.step(inputs));
        let elapsed = start.elapsed().as_secs_f64();
        total += elapsed;
        last = Some((trace, controller.held_since));
    }
    let per_cycle = total / f64::from(cycles.max(1));
    println!(
        "twin speed{}: {per_cycle:.3} s wall-clock per 30 s pull/hold/release cycle \
         ({:.0}× real time; 600 000 PWM periods, 30 000 ticks; mean of {cycles})",
        if family { " (family)" } else { "" },
        30.0 / per_cycle
    );
    if let Some((trace, held)) = last {
        let peak = trace.peak_tension_kgf();
        let at = |ms: usize| trace.rows.get(ms).map_or(0.0, |r| r.truth.tension_kgf);
        println!(
            "cycle check: peak {peak:.2} kgf, tension at 10 s {:.2} kgf, at 24 s {:.2} kgf, \
             hold from {:?} ms, end position {:.1} mm, fault {:?}",
            at(10_000),
            at(24_000),
            held,
            trace.last().map_or(0.0, |r| r.truth.carriage_mm),
            trace.last().and_then(|r| r.truth.drive_fault)
        );
    }
}

//! Open-loop pull: ramp the duty up to a fixed value, pull until the **true** tension
//! reaches a target, then let the motor coast — for every string kind.
//!
//! Shows what the machine does with no controller at all: how long the pull takes, how far
//! the ≈ 400 kg equivalent inertia of rotor and gearbox overshoots the target after the
//! drive lets go, and how the string relaxes and back-drives the screw afterwards. The
//! duty is ramped over 100 ms because a step to 95 % into a standing motor draws
//! 0.95 × 24 V / 0.85 Ω ≈ 27 A and trips the drive's 12 A overcurrent limit (try
//! `RAMP_MS = 0` to see it).
//!
//! `cargo run -p taut-sim --release --example open_loop [DUTY] [TARGET_KGF] [RAMP_MS]`
#![allow(
    clippy::float_arithmetic,
    clippy::print_stdout,
    reason = "a host example printing float results"
)]

use taut_core::drive::Direction;
use taut_core::io::Outputs;
use taut_sim::{StringKind, Twin, TwinConfig, drive_at};

fn main() {
    let mut args = std::env::args().skip(1);
    let duty: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(0.95);
    let target: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(20.0);
    let ramp_ms: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(100.0);
    println!(
        "open loop: duty ramped to {duty:.2} over {ramp_ms} ms, pull until {target} kgf (true), \
         then coast for 5 s"
    );
    println!(
        "| string | K₀ kgf/cm | reach s | speed mm/s | peak kgf | overshoot kgf | peak A | \
         after 5 s kgf | fault |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for kind in StringKind::STRINGS {
        let config = TwinConfig::nominal(kind);
        let mut twin = Twin::new(&config);
        let mut reached: Option<(f64, f64)> = None;
        let mut peak_current: f64 = 0.0;
        let mut peak_tension: f64 = 0.0;
        let mut fault = None;
        for tick in 0..20_000_u32 {
            let truth = twin.truth();
            if reached.is_none() && truth.tension_kgf >= target {
                reached = Some((truth.time_s, truth.carriage_mm_per_s));
            }
            if reached.is_some_and(|(at, _)| truth.time_s > at + 5.0) {
                break;
            }
            let ramp = if ramp_ms > 0.0 { (f64::from(tick) / ramp_ms).min(1.0) } else { 1.0 };
            let outputs = if reached.is_some() {
                Outputs::default()
            } else {
                Outputs { drive: drive_at(Direction::Pull, duty * ramp), ..Outputs::default() }
            };
            twin.apply(&outputs);
            twin.advance_tick();
            let after = twin.truth();
            peak_current = peak_current.max(after.peak_current_a);
            peak_tension = peak_tension.max(after.tension_kgf);
            fault = fault.or(after.drive_fault);
            if fault.is_some() {
                break;
            }
        }
        let end = twin.truth().tension_kgf;
        let k = config.string.stiffness_kgf_per_cm;
        let fault = fault.map_or_else(|| "–".to_owned(), |f| format!("{f:?}"));
        match reached {
            Some((at, speed)) => println!(
                "| {kind} | {k:.2} | {at:.3} | {speed:.1} | {peak_tension:.2} | {:.2} | \
                 {peak_current:.2} | {end:.2} | {fault} |",
                peak_tension - target
            ),
            None => println!(
                "| {kind} | {k:.2} | never | – | {peak_tension:.2} | – | {peak_current:.2} | \
                 {end:.2} | {fault} |"
            ),
        }
    }
}

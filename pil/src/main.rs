//! `taut-pil`: the firmware image on the emulated STM32G431, closed around the digital twin.
//!
//! ```text
//! taut-pil [--elf PATH] [--calibrate] [--tension KG] [--hold S] [--boot MS]
//! ```
//!
//! Runs the main job's machine cycle on the image and on the host bench, prints both runs'
//! figures side by side, the gate-level checks, the interrupt timing and the stack; exits 0
//! only when the cycle completed on the image with no gate violation and no unmodelled
//! register access.
#![allow(clippy::print_stdout, clippy::print_stderr, reason = "a command-line tool's output")]

use std::process::ExitCode;

use taut_pil::cycle::{self, Figures, Scenario};
use taut_pil::elf::Image;
use taut_pil::mcu::Mcu;
use taut_pil::report;
use taut_sim::params::StringKind;

struct Args {
    elf: String,
    scenario: Scenario,
    boot_ms: Option<u64>,
    faults: bool,
}

fn usage(error: &str) -> ExitCode {
    eprintln!("taut-pil: {error}");
    eprintln!(
        "usage: taut-pil [--elf PATH] [--calibrate] [--tension KG] [--hold SECONDS] [--boot MS]"
    );
    ExitCode::from(2)
}

fn parse() -> Result<Args, String> {
    let mut args = Args {
        elf: "target/thumbv7em-none-eabihf/firmware/taut-firmware".into(),
        scenario: Scenario {
            calibrate: false,
            tension_tenths_kg: 250,
            hold_ms: 2_000,
            string: StringKind::TennisSynthetic,
        },
        boot_ms: None,
        faults: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--elf" => args.elf = value("--elf")?,
            "--calibrate" => args.scenario.calibrate = true,
            "--tension" => {
                let v: f64 = value("--tension")?
                    .parse()
                    .map_err(|_| "--tension: a number of kg".to_string())?;
                if !(5.0..=80.0).contains(&v) {
                    return Err("--tension: 5 to 80 kg".into());
                }
                args.scenario.tension_tenths_kg = (v * 10.0).round() as u16;
            }
            "--hold" => {
                let v: f64 = value("--hold")?.parse().map_err(|_| "--hold: seconds".to_string())?;
                if !(0.5..=120.0).contains(&v) {
                    return Err("--hold: 0.5 to 120 s".into());
                }
                args.scenario.hold_ms = (v * 1000.0).round() as u32;
            }
            "--faults" => args.faults = true,
            "--boot" => {
                args.boot_ms =
                    Some(value("--boot")?.parse().map_err(|_| "--boot: milliseconds".to_string())?)
            }
            other => return Err(format!("unknown option {other}")),
        }
    }
    Ok(args)
}

fn row(name: &str, pil: String, host: String) {
    println!("| {name} | {pil} | {host} |");
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".into(), |v| format!("{v:.digits$}"))
}

fn compare(pil: &Figures, host: &Figures) {
    println!("| figure | firmware on the emulated G431 | taut-core on the host |");
    println!("|---|---|---|");
    row(
        "time to tension (pull lamp → hold lamp), s",
        fmt_opt(pil.time_to_tension_s, 3),
        fmt_opt(host.time_to_tension_s, 3),
    );
    row(
        "hold error after 0.5 s, mean / max, kgf",
        format!("{:.3} / {:.3}", pil.hold_error_mean_kgf, pil.hold_error_max_kgf),
        format!("{:.3} / {:.3}", host.hold_error_mean_kgf, host.hold_error_max_kgf),
    );
    row(
        "peak true tension, kgf",
        format!("{:.2}", pil.peak_tension_kgf),
        format!("{:.2}", host.peak_tension_kgf),
    );
    row(
        "peak winding current, A",
        format!("{:.2}", pil.peak_current_a),
        format!("{:.2}", host.peak_current_a),
    );
    row("hold, s", format!("{:.2}", pil.hold_s), format!("{:.2}", host.hold_s));
    row(
        "carriage at the end, mm",
        format!("{:.1}", pil.end_carriage_mm),
        format!("{:.1}", host.end_carriage_mm),
    );
    row("fault lamp", format!("{}", pil.faulted), format!("{}", host.faulted));
}

fn faults(image: &Image, scenario: &Scenario, started: std::time::Instant) -> ExitCode {
    use taut_pil::faults::{self, Injection};
    eprintln!("commissioning a machine on the image …");
    let flash = match faults::commissioned_flash(image, scenario) {
        Ok(f) => f,
        Err(stop) => {
            println!("commissioning stopped: {stop}");
            return ExitCode::from(1);
        }
    };
    println!("## Faults at the pins");
    println!();
    println!("| injection | result | what the machine did | gate violations |");
    println!("|---|---|---|---|");
    let mut failed = 0;
    let only = std::env::var("TAUT_PIL_FAULT").unwrap_or_default();
    for injection in Injection::ALL.into_iter().filter(|i| i.name().contains(only.as_str())) {
        eprintln!("{} …", injection.name());
        let outcome = faults::run(image, &flash, scenario, injection);
        if !outcome.passed {
            failed += 1;
        }
        println!(
            "| {} | {} | {} | {} |",
            injection.name(),
            if outcome.passed { "pass" } else { "FAIL" },
            outcome.detail,
            outcome.violations
        );
    }
    println!();
    println!(
        "{} of {} injections passed in {:.0} s of wall time",
        Injection::ALL.len() - failed,
        Injection::ALL.len(),
        started.elapsed().as_secs_f64()
    );
    if failed == 0 { ExitCode::SUCCESS } else { ExitCode::from(1) }
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => return usage(&e),
    };
    let bytes = match std::fs::read(&args.elf) {
        Ok(b) => b,
        Err(e) => {
            eprintln!(
                "taut-pil: cannot read the image {}: {e} (build it with scripts/firmware-size or cargo build -p taut-firmware --profile firmware --target thumbv7em-none-eabihf)",
                args.elf
            );
            return ExitCode::from(1);
        }
    };
    let image = match Image::parse(&bytes) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("taut-pil: {}: {e}", args.elf);
            return ExitCode::from(1);
        }
    };
    let started = std::time::Instant::now();
    if let Some(ms) = args.boot_ms {
        let mut mcu = match Mcu::new(image) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("taut-pil: {e}");
                return ExitCode::from(1);
            }
        };
        let result = mcu.run_until(ms * 170_000);
        let mut log = taut_pil::rtt::Reader::new(mcu.image());
        let mut writes = Vec::new();
        log.poll(|a, n| mcu.read_memory(a, n), |a, b| writes.push((a, b.to_vec())));
        println!("firmware log (defmt over RTT; {} frames that did not decode):", log.corrupt);
        for line in &log.lines {
            println!("  {:>5} {}", line.level, line.text);
        }
        println!("boot: {result:?} at cycle {} in {}", mcu.cycles(), mcu.describe(mcu.pc()));
        println!("{}", report::timing(&mcu));
        let soc = mcu.soc();
        println!(
            "panel updates {} (errors {}), grids {:02x?}; flash programmed {} double words, {} pages erased; ADC conversions {:?} {:?}; IWDG reloads {}",
            soc.panel.updates,
            soc.panel.errors,
            soc.panel.grids,
            soc.flash.programmed,
            soc.flash.erased,
            soc.adc[0].conversions,
            soc.adc[1].conversions,
            soc.iwdg.reloads
        );
        println!("wall {:.1} s", started.elapsed().as_secs_f64());
        return if result.is_ok() { ExitCode::SUCCESS } else { ExitCode::from(1) };
    }
    if args.faults {
        return faults(&image, &args.scenario, started);
    }
    eprintln!("host bench: running the scenario with taut-core on the host …");
    let host = match cycle::host(&args.scenario) {
        Ok(h) => h,
        Err(e) => {
            eprintln!("taut-pil: {e}");
            return ExitCode::from(1);
        }
    };
    eprintln!("emulated G431: running the image {} …", args.elf);
    let mut last = String::new();
    let mut progress = |session: &str, ms: u64, bench: &taut_pil::bench::Bench| {
        let (display, leds) = bench.panel();
        let text = taut_sim::operator::display::text(&display);
        let line = format!(
            "{session} {:>7.1} s  panel [{text}]{}{}{}  tension {:6.2} kgf",
            ms as f64 / 1e3,
            if leds.pulling { " pull" } else { "" },
            if leds.holding { " hold" } else { "" },
            if leds.fault { " FAULT" } else { "" },
            bench.twin.truth().tension_kgf
        );
        let key = format!("{session}{text}{}{}{}", leds.pulling, leds.holding, leds.fault);
        if key != last {
            eprintln!("{line}");
            last = key;
        }
    };
    let outcome = cycle::pil(image, &args.scenario, &mut progress);
    let wall = started.elapsed().as_secs_f64();
    match outcome {
        Ok(run) => {
            println!("## The machine cycle on the image");
            println!();
            compare(&run.run.figures, &host.figures);
            println!();
            println!("{}", report::checks(&run.bench));
            println!(
                "firmware log (defmt over RTT, the job session; {} frames that did not decode):",
                run.bench.log.corrupt
            );
            for line in &run.bench.log.lines {
                println!("  {:>5} {}", line.level, line.text);
            }
            println!();
            println!("{}", report::timing(&run.bench.mcu));
            println!(
                "simulated {:.1} s (commissioning {:.1} s) in {wall:.0} s of wall time",
                run.bench.periods as f64 * 50e-6,
                run.run.commissioning_ms as f64 / 1e3
            );
            let (latency_ok, worst) = report::fast_loop_latency(&run.bench.mcu);
            println!(
                "fast-loop latency: longest {worst} cycles beyond what the design allows ({}; limit {} cycles, flash writes excluded)",
                if latency_ok { "within" } else { "OVER" },
                report::FAST_LOOP_LATENCY_LIMIT
            );
            let agreement = cycle::agreement(&run.run.figures, &host.figures);
            for line in &agreement.lines {
                println!("{line}");
            }
            println!();
            println!("## The machine link on the emulated USART2 during the job");
            println!();
            let board = taut_link::message::BoardId::from(taut_pil::link::unique_id_bytes());
            let (link_ok, lines) = run.traffic.verdict(board);
            for line in &lines {
                println!("{line}");
            }
            let line = &run.bench.line;
            println!(
                "line: {} bytes to the machine ({} sent), {} bytes back; {} received bytes the machine's DMA did not take",
                line.delivered,
                run.traffic.bytes_sent,
                line.from_machine.len(),
                run.bench.mcu.soc().serial.lost
            );
            let clean = run.bench.checker.violations.is_empty()
                && latency_ok
                && agreement.agrees
                && link_ok
                && run.bench.mcu.soc().serial.lost == 0;
            if run.run.completed && clean { ExitCode::SUCCESS } else { ExitCode::from(1) }
        }
        Err((stop, bench)) => {
            println!("the run stopped: {stop}");
            if let Some(bench) = bench {
                let (display, leds) = bench.panel();
                println!(
                    "at {:.3} s simulated, pc in {}; the panel shows [{}]{}",
                    bench.periods as f64 * 50e-6,
                    bench.mcu.describe(bench.mcu.pc()),
                    taut_sim::operator::display::text(&display),
                    if leds.fault { " with the fault lamp" } else { "" }
                );
                println!("{}", report::checks(&bench));
            }
            ExitCode::from(1)
        }
    }
}

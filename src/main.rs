//! `taut`: the host tool. Runs the stringing machine's controller on its digital twin.
#![allow(clippy::float_arithmetic, reason = "host tool: reports in f64")]
#![allow(clippy::print_stdout, reason = "a command-line tool prints")]
#![allow(
    clippy::arithmetic_side_effects,
    clippy::cast_possible_truncation,
    reason = "host tool: progress-bar and sample arithmetic on small counts"
)]
#![allow(
    clippy::expect_used,
    reason = "host tool: a failed write or a broken built-in configuration ends the command with               its message"
)]

use clap::{Parser, Subcommand};
use taut::sil::{Rig, Sample};
use taut_core::sense::calibration::Calibration;
use taut_core::tension::{ControllerConfig, PullKind, PullSettings};
use taut_sim::{StringKind, TwinConfig};

#[derive(Parser)]
#[command(name = "taut", about = "taut: the stringing machine's host tool (digital twin, reports)")]
#[command(args_conflicts_with_subcommands = true, after_help = taut::cycle::AFTER_HELP)]
struct Cli {
    /// No subcommand: the main job (a whole machine cycle on the twin, see `taut --help`).
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    job: taut::cycle::JobArgs,
}

#[derive(Subcommand)]
enum Command {
    /// The terminal front panel: the machine on the twin in real time (or from --script).
    Panel(taut::panel::PanelArgs),
    /// The paper's simulation (section 7.3) with taut-core's fixed-point laws.
    Paper {
        /// Write the headline figures as JSON here.
        #[arg(long)]
        json: Option<std::path::PathBuf>,
        /// Write the figure 18–20 plot here.
        #[arg(long)]
        svg: Option<std::path::PathBuf>,
    },
    /// Reports on the twin.
    Report {
        #[command(subcommand)]
        which: ReportKind,
    },
    /// One pull, hold and release on the twin.
    Pull {
        /// Target tension, kgf.
        #[arg(long, default_value_t = 25.0)]
        tension: f64,
        /// String kind.
        #[arg(long, default_value = "tennis-synthetic")]
        string: StringKind,
        /// Controller: taut, paper_rsmc, pd.
        #[arg(long, default_value = "taut")]
        controller: String,
        /// Monte-Carlo scenario seed instead of the nominal machine.
        #[arg(long)]
        seed: Option<u64>,
        /// Re-run scenario N of `report accuracy --seed 1` (with its calibration) instead.
        #[arg(long)]
        scenario: Option<u64>,
        /// Write a plot (tension, carriage, duty, current) here.
        #[arg(long)]
        svg: Option<std::path::PathBuf>,
        /// Print every 20th tick.
        #[arg(long)]
        verbose: bool,
    },
}

#[derive(Subcommand)]
enum ReportKind {
    /// Monte-Carlo accuracy of taut, paper_rsmc and pd on the same scenarios.
    Accuracy {
        /// Number of scenarios.
        #[arg(long, default_value_t = 200)]
        scenarios: u64,
        /// Seed of the scenario draw.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Write the JSON summary here.
        #[arg(long)]
        json: Option<std::path::PathBuf>,
        /// Write SVG plots into this directory.
        #[arg(long)]
        svg: Option<std::path::PathBuf>,
    },
    /// taut with each improvement switched off in turn, on the accuracy report's scenarios.
    Ablation {
        /// Number of scenarios.
        #[arg(long, default_value_t = 200)]
        scenarios: u64,
        /// Seed of the scenario draw.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Write the JSON summary here.
        #[arg(long)]
        json: Option<std::path::PathBuf>,
    },
}

fn main() {
    let cli = Cli::parse();
    let Some(command) = cli.command else { std::process::exit(taut::cycle::main_job(&cli.job)) };
    match command {
        Command::Panel(args) => std::process::exit(taut::panel::main(&args)),
        Command::Report { which: ReportKind::Ablation { scenarios, seed, json } } => {
            taut::report::ablation_main(scenarios, seed, json.as_deref());
        }
        Command::Report { which: ReportKind::Accuracy { scenarios, seed, json, svg } } => {
            use std::io::Write as _;
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            let progress = |done: usize| {
                let width = 40;
                let filled = done * width / scenarios.max(1) as usize;
                eprint!(
                    "\r[{}{}] {done}/{scenarios}",
                    "#".repeat(filled),
                    "-".repeat(width - filled)
                );
                let _ = std::io::stderr().flush();
            };
            let results = taut::report::run_all(seed, scenarios, threads, &progress);
            eprintln!();
            println!("{}", taut::report::markdown(&results));
            if let Some(path) = json {
                let doc = taut::report::to_json(seed, &results);
                std::fs::write(&path, serde_json::to_string_pretty(&doc).expect("json"))
                    .expect("write JSON");
            }
            if let Some(dir) = svg {
                std::fs::create_dir_all(&dir).expect("create SVG directory");
                for (name, figure) in taut::report::figures(seed, &results) {
                    std::fs::write(dir.join(name), figure.to_svg()).expect("write SVG");
                }
            }
            if std::env::var_os("TAUT_REPORT_DETAIL").is_some() {
                for r in &results {
                    println!(
                        "{:4} {:16} T={:5.1} tmin={:?} cal={} {:?}",
                        r.index,
                        r.string,
                        r.target_kgf,
                        r.t_min,
                        r.calibration_ok,
                        r.metrics.first()
                    );
                }
            }
        }
        Command::Paper { json, svg } => {
            let (rsmc, pd, h) = taut::paper::run();
            let show = |x: Option<f64>| x.map_or("never".to_owned(), |v| format!("{v:.4}"));
            println!("| figure | taut re-run | paper |\n|---|---|---|");
            println!("| RSMC time to 10 kgw (98 %) | {} s | ≈ 0.02 s |", show(h.rsmc_reach_s));
            println!("| PD time to 10 kgw (98 %) | {} s | ≈ 0.05 s |", show(h.pd_reach_s));
            println!("| PD steady-state error | {:.4} kgw | ≈ 0.018 kgw |", h.pd_steady_error_kgw);
            if let Some(path) = json {
                let doc = serde_json::json!({
                    "rsmc_reach_s": h.rsmc_reach_s,
                    "pd_reach_s": h.pd_reach_s,
                    "pd_steady_error_kgw": h.pd_steady_error_kgw,
                });
                std::fs::write(&path, serde_json::to_string_pretty(&doc).expect("json"))
                    .expect("write JSON");
            }
            if let Some(path) = svg {
                std::fs::write(&path, taut::paper::figure(&rsmc, &pd).to_svg()).expect("write SVG");
            }
        }
        Command::Pull { tension, string, controller, seed, scenario, svg, verbose } => {
            let config = match controller.as_str() {
                "paper_rsmc" => ControllerConfig::PAPER_RSMC,
                "pd" => ControllerConfig::PD,
                _ => ControllerConfig::TAUT,
            };
            let twin = seed.map_or_else(
                || TwinConfig::nominal(string),
                |s| TwinConfig::sample_kind(string, s),
            );
            let (twin, tension, calibration) = match scenario {
                Some(n) => {
                    let s = taut::report::Scenario::new(1, n);
                    let cal =
                        taut::sil::calibrate(&s.twin).calibration.unwrap_or(Calibration::IDENTITY);
                    let t_min = taut::report::oracle_reach_time(&s.twin, s.target_kgf, 10_000);
                    println!(
                        "scenario {n}: {} T={} t_min={t_min:?} cal={cal:?}",
                        s.twin.string.kind.name(),
                        s.target_kgf
                    );
                    (s.twin, s.target_kgf, cal)
                }
                None => {
                    // A calibrated machine, as in the field: the 4-point calibration first.
                    let cal =
                        taut::sil::calibrate(&twin).calibration.unwrap_or(Calibration::IDENTITY);
                    (twin, tension, cal)
                }
            };
            let mut rig = Rig::new(&twin, &config, calibration);
            let settings = PullSettings::default()
                .with_tension(taut::sil::to_kgf(tension))
                .expect("tension 5–50 kgf");
            rig.start(&settings, PullKind::Main);
            let mut trace: Vec<Sample> = Vec::new();
            // Pull and hold 12 s, then release until home (at most 8 s more).
            rig.run(12_000, &mut trace);
            rig.controller.release();
            for _ in 0..8_000 {
                let (sample, out, _) = rig.tick();
                trace.push(sample);
                if out.phase == taut_core::tension::PullPhase::Idle {
                    break;
                }
            }
            let m = taut::report::metrics(trace.get(..12_000).unwrap_or(&trace), tension, None);
            let hold_end = trace.iter().filter(|s| s.t <= 12.0).count();
            println!(
                "pull {} to {tension:.1} kgf ({controller}): settled {} s, overshoot {:.3} kgf, hold error {:.3} kgf, chattering {:.2}/s, peak current {:.2} A, final true tension {:.3} kgf, released in {:.2} s",
                twin.string.kind.name(),
                m.settle_s.map_or("never".to_owned(), |s| format!("{s:.3}")),
                m.overshoot_kgf,
                m.hold_error_kgf,
                m.chattering,
                m.peak_current_a,
                trace.get(hold_end.saturating_sub(1)).map_or(f64::NAN, |s| s.tension),
                trace.last().map_or(0.0, |s| s.t) - 12.0,
            );
            if let Some(path) = svg {
                std::fs::write(
                    &path,
                    taut::report::pull_figure(&trace, tension, "taut pull").to_svg(),
                )
                .expect("write SVG");
            }
            for s in trace.iter().step_by(20).take(if verbose { usize::MAX } else { 0 }) {
                println!(
                    "{:6.3} T={:7.3} m={:7.3} r={:7.3} d={:6.3} x={:7.2} i={:5.2} f={:8.2} {:?} {}",
                    s.t,
                    s.tension,
                    s.measured,
                    s.reference,
                    s.duty,
                    s.carriage_mm,
                    s.current,
                    s.force,
                    s.phase,
                    s.fault
                );
            }
        }
    }
}

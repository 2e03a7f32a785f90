//! The main job's options, command line and plot layout: cheap checks, plus one end-to-end
//! run of the `taut` binary as the README's first command runs it.
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::float_arithmetic,
    clippy::print_stdout,
    reason = "a test: a panic is how it reports"
)]

use std::process::Command;

use clap::Parser;
use taut::cli::{JobArgs, parse_tension};
use taut::job::CycleOptions;
use taut::job::figure::timeline;
use taut::plot::{Figure, Panel, Series};
use taut_core::machine::MachineState;
use taut_core::settings::Unit;
use taut_sim::bench::Transition;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    job: JobArgs,
}

fn args(line: &[&str]) -> Result<CycleOptions, String> {
    let cli = Cli::try_parse_from(std::iter::once("taut").chain(line.iter().copied()))
        .map_err(|e| e.to_string())?;
    Ok(taut::job::options_from_args(&cli.job))
}

#[test]
fn tensions_parse_in_kilograms_and_pounds() {
    let ok = |text: &str, unit, tenths| {
        let set_point = parse_tension(text).unwrap_or_else(|e| panic!("{text}: {e}"));
        assert_eq!((set_point.unit(), set_point.tenths()), (unit, tenths), "{text}");
    };
    ok("25", Unit::Kilograms, 250);
    ok("25.5", Unit::Kilograms, 255);
    ok(" 25kg", Unit::Kilograms, 250);
    ok("30 kgf", Unit::Kilograms, 300);
    ok("55lb", Unit::Pounds, 550);
    ok("55.5 LBS", Unit::Pounds, 555);
    ok("5", Unit::Kilograms, 50);
    ok("50", Unit::Kilograms, 500);
    ok("11.5lb", Unit::Pounds, 115);
    ok("110lb", Unit::Pounds, 1100);
    let bad = |text: &str, says: &str| {
        let error = parse_tension(text).expect_err(text);
        assert!(error.contains(says), "{text}: {error}");
    };
    bad("fifty", "not a tension: a number");
    bad("25 stone", "not a tension: a number");
    for out_of_range in ["4.9", "50.1", "25.05", "55.2lb", "111lb", "-3", "nan", "inf"] {
        bad(out_of_range, "5.0–50.0 kg in 0.1 kg steps");
    }
}

#[test]
fn command_line_options_become_the_operators_settings() {
    let defaults = args(&[]).unwrap();
    assert_eq!(defaults, CycleOptions::default());
    let settings = defaults.settings().unwrap();
    assert_eq!((settings.set_point().tenths(), settings.speed().get()), (250, 5));

    let o = args(&[
        "--tension",
        "55lb",
        "--string",
        "tennis-poly",
        "--speed",
        "9",
        "--pre-stretch",
        "10",
        "--knot",
        "--seed",
        "7",
        "--hold",
        "5.5",
        "--uncalibrated",
    ])
    .unwrap();
    assert_eq!(o.set_point.unit(), Unit::Pounds);
    assert_eq!(o.string, taut_sim::StringKind::TennisPolyester);
    assert_eq!((o.speed, o.pre_stretch_percent, o.knot_percent), (9, 10, Some(15)));
    assert_eq!((o.seed, o.hold_ms, o.calibrate), (Some(7), 5_500, false));
    assert_eq!(o.pull_kind(), taut_core::settings::PullKind::Knot);
    assert_eq!(o.twin_config(), taut_sim::TwinConfig::family_kind(o.string, 7));
    assert_eq!(args(&["--knot", "20"]).unwrap().knot_percent, Some(20));

    for (line, message) in [
        (&["--speed", "0"][..], "0"),
        (&["--speed", "10"][..], "10"),
        (&["--tension", "60"][..], "tension"),
        (&["--pre-stretch", "12"][..], "pre-stretch"),
        (&["--pre-stretch", "35"][..], "pre-stretch"),
        (&["--knot", "25"][..], "knot"),
        (&["--string", "rope"][..], "rope"),
        (&["--hold=-1"][..], "hold"),
        (&["--hold", "601"][..], "hold"),
        (&["--hold", "4.9"][..], "hold"),
    ] {
        let error = args(line).unwrap_err();
        assert!(error.contains(message), "{line:?}: {error}");
    }
}

#[test]
fn the_state_timeline_shares_the_plots_time_axis() {
    let transitions = [
        Transition { t_ms: 0, state: MachineState::SelfTest },
        Transition { t_ms: 6_000, state: MachineState::Ready },
    ];
    let figure = Figure::new(
        "axis",
        "what was run",
        "time (s)",
        vec![
            Panel::new("y", vec![Series::new("line", vec![(0.0, 1.0), (12.0, 2.0)])]),
            Panel::timeline("state", timeline(&transitions, 12.0)),
        ],
    );
    let (svg, geometry) = figure.render();
    let (line, strip) = (geometry.panels[0], geometry.panels[1]);
    // One time scale: the strip's t = 0, 6 and 12 s are the line panel's.
    for t in [0.0, 6.0, 12.0] {
        assert!((line.x.px(t) - strip.x.px(t)).abs() < 1e-9, "{t} s");
    }
    // The second band starts half way along the axis, drawn where the geometry says.
    let x = strip.x.px(6.0);
    assert!(
        svg.contains(&format!("<rect x=\"{x:.1}\" y=\"{:.1}\"", strip.area.y)),
        "band at {x:.1}"
    );
    assert_eq!(svg.matches("<svg").count(), 1, "one document, nothing nested");
}

#[test]
fn the_binary_runs_the_main_job_with_no_subcommand() {
    // In a folder of its own with no `out/`: the default plot's folder is created.
    let dir = std::env::temp_dir().join(format!("taut-cycle-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let svg = dir.join("out/cycle.svg");
    let json = dir.join("cycle.json");
    let output = Command::new(env!("CARGO_BIN_EXE_taut"))
        .args(["--hold", "5", "--json", "cycle.json"])
        .current_dir(&dir)
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stdout}\n{stderr}");
    assert!(output.status.success(), "exit {:?}", output.status);
    assert!(stdout.contains("| time to tension (Start → holding lamp) |"));
    assert!(stdout.contains("| cycle completed | yes |"));
    let table: Vec<&str> = stdout.lines().filter(|l| l.starts_with('|')).collect();
    assert!(
        table.len() >= 20 && table.iter().all(|l| l.matches('|').count() == 3),
        "a 2-column table"
    );
    assert!(stdout.contains("plot: out/cycle.svg"));
    // Progress on stderr (not a terminal here: one line per state change).
    for state in ["motor test", "homing", "pulling", "holding", "releasing"] {
        assert!(stderr.contains(state), "progress names {state}");
    }
    let plot = std::fs::read_to_string(&svg).expect("the plot is written");
    assert!(plot.starts_with("<svg") && plot.contains("holding"));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("valid JSON");
    assert_eq!(summary["completed"], true);
    assert_eq!(summary["set_point"], "25.0 kg");
    std::fs::remove_dir_all(&dir).ok();

    let refused = Command::new(env!("CARGO_BIN_EXE_taut"))
        .args(["--tension", "70"])
        .current_dir(std::env::temp_dir())
        .output()
        .expect("runs");
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("5.0–50.0 kg"));
}

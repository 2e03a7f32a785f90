//! Every subcommand and every option that takes a value, given bad input: out of range,
//! NaN, infinite, negative, non-numeric, an unknown name, zero counts, an unwritable path,
//! a missing or malformed script. Each run must end with exit status 2 (a usage error, in
//! clap's message style, or an output path refused before the run, `error: --svg …`) or 1 (a
//! failure while running, one line `error: …`), a readable message naming the culprit — and
//! never 101 (a panic).
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::print_stdout,
    clippy::panic,
    reason = "a test: a panic is how it reports"
)]

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, PoisonError};

/// Held while this binary starts a child. Between its fork and its exec a child holds a
/// copy of every descriptor of this process — the tests run on parallel threads, so one
/// test's child could keep another test's pipe open. With the lock, a pipe that one test
/// closes is closed everywhere (`spawn` returns only after the child's exec has run).
static SPAWNING: Mutex<()> = Mutex::new(());

/// Starts `command` under [`SPAWNING`].
fn spawn(command: &mut Command) -> Child {
    let _alone = SPAWNING.lock().unwrap_or_else(PoisonError::into_inner);
    command.spawn().expect("starts")
}

/// A usage error (clap's, or a script's syntax).
const USAGE: i32 = 2;
/// A failure while running.
const RUNTIME: i32 = 1;

/// A directory of this test's own with a plain file in it, so `file/x` can never be created
/// (not even by root), and `cwd/`, the runs' working directory, holding an earlier plot at
/// the main job's default path (`out/cycle.svg`).
fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("taut-bad-input-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("cwd/out")).unwrap();
    std::fs::write(dir.join("cwd/out/cycle.svg"), EARLIER_PLOT).unwrap();
    std::fs::write(dir.join("file"), "not a directory").unwrap();
    std::fs::write(dir.join("bad.script"), "until ready 10000\npress up 0\n").unwrap();
    std::fs::write(dir.join("nan.script"), "expect tension nan 30\n").unwrap();
    dir
}

/// What the working directory's `out/cycle.svg` holds before the runs, and after them.
const EARLIER_PLOT: &str = "an earlier plot";

/// `(arguments, expected exit status, a word the message must contain)`. `UNWRITABLE` and
/// `SCRIPTS` are replaced by paths in the scratch directory.
const TABLE: &[(&[&str], i32, &str)] = &[
    // ── the main job ──
    (&["--tension", "500"], USAGE, "--tension"),
    (&["--tension", "4.9"], USAGE, "5.0–50.0 kg"),
    (&["--tension", "nan"], USAGE, "--tension"),
    (&["--tension", "inf"], USAGE, "--tension"),
    (&["--tension", "-5"], USAGE, "--tension"),
    (&["--tension", "abc"], USAGE, "not a tension"),
    (&["--tension", "25.55"], USAGE, "0.1 kg steps"),
    (&["--string", "rope"], USAGE, "--string"),
    (&["--speed", "0"], USAGE, "--speed"),
    (&["--speed", "10"], USAGE, "--speed"),
    (&["--speed", "-1"], USAGE, "--speed"),
    (&["--speed", "abc"], USAGE, "--speed"),
    (&["--pre-stretch", "12"], USAGE, "steps of 5"),
    (&["--pre-stretch", "35"], USAGE, "--pre-stretch"),
    (&["--pre-stretch", "-5"], USAGE, "--pre-stretch"),
    (&["--knot", "25"], USAGE, "--knot"),
    (&["--knot", "abc"], USAGE, "--knot"),
    (&["--seed", "-1"], USAGE, "--seed"),
    (&["--seed", "abc"], USAGE, "--seed"),
    (&["--hold", "-1"], USAGE, "--hold"),
    (&["--hold", "601"], USAGE, "--hold"),
    (&["--hold", "4.9"], USAGE, "5–600"),
    (&["--hold", "nan"], USAGE, "--hold"),
    (&["--hold", "inf"], USAGE, "--hold"),
    (&["--hold", "abc"], USAGE, "--hold"),
    (&["--svg", "UNWRITABLE/cycle.svg"], USAGE, "error: --svg "),
    (&["--json", "UNWRITABLE/cycle.json"], USAGE, "error: --json "),
    // ── pull ──
    (&["pull", "--tension", "500"], USAGE, "--tension"),
    (&["pull", "--tension", "4.9"], USAGE, "--tension"),
    (&["pull", "--tension", "50.1"], USAGE, "--tension"),
    (&["pull", "--tension", "nan"], USAGE, "--tension"),
    (&["pull", "--tension", "inf"], USAGE, "--tension"),
    (&["pull", "--tension", "-5"], USAGE, "--tension"),
    (&["pull", "--tension", "25.55"], USAGE, "--tension"),
    (&["pull", "--string", "rope"], USAGE, "--string"),
    (&["pull", "--controller", "foo"], USAGE, "--controller"),
    (&["pull", "--controller", "PD"], USAGE, "--controller"),
    (&["pull", "--axis", "friction"], USAGE, "NAME=POSITION"),
    (&["pull", "--axis", "gravity=0.5"], USAGE, "not an axis"),
    (&["pull", "--axis", "friction=1.5"], USAGE, "not in 0–1"),
    (&["pull", "--axis", "friction=nan"], USAGE, "not in 0–1"),
    (&["pull", "--axis", "friction=1", "--seed", "3"], USAGE, "--seed"),
    (&["pull", "--axis", "friction=1", "--scenario", "3"], USAGE, "--scenario"),
    (&["pull", "--axis", "friction=1", "--axis", "friction=0"], USAGE, "given twice"),
    (&["pull", "--axis", "bus-supply=1", "--axis", "bus-clamp=0"], USAGE, "not a physical machine"),
    (&["pull", "--speed", "0"], USAGE, "--speed"),
    (&["pull", "--speed", "abc"], USAGE, "--speed"),
    (&["pull", "--hold", "0"], USAGE, "--hold"),
    (&["pull", "--hold", "4.9"], USAGE, "5–600"),
    (&["pull", "--hold", "601"], USAGE, "5–600"),
    (&["pull", "--hold", "nan"], USAGE, "--hold"),
    (&["pull", "--hold", "-1"], USAGE, "--hold"),
    (&["pull", "--hold", "abc"], USAGE, "--hold"),
    (&["pull", "--seed", "-1"], USAGE, "--seed"),
    (&["pull", "--scenario", "abc"], USAGE, "--scenario"),
    (&["pull", "--tension", "10", "--scenario", "2"], USAGE, "cannot be used with"),
    (&["pull", "--seed", "3", "--scenario", "2"], USAGE, "cannot be used with"),
    (&["pull", "--svg", "UNWRITABLE/pull.svg"], USAGE, "error: --svg "),
    (&["pull", "--csv", "UNWRITABLE/pull.csv"], USAGE, "error: --csv "),
    // ── paper ──
    (&["paper", "--json", "UNWRITABLE/paper.json"], USAGE, "error: --json "),
    (&["paper", "--svg", "UNWRITABLE/paper.svg"], USAGE, "error: --svg "),
    // ── panel ──
    (&["panel", "--string", "rope"], USAGE, "--string"),
    (&["panel", "--seed", "abc"], USAGE, "--seed"),
    (&["panel", "--flash", "erased"], USAGE, "--flash"),
    (&["panel", "--rate", "0"], USAGE, "0.1–100"),
    (&["panel", "--rate", "-1"], USAGE, "--rate"),
    (&["panel", "--rate", "nan"], USAGE, "--rate"),
    (&["panel", "--rate", "inf"], USAGE, "--rate"),
    (&["panel", "--rate", "1000"], USAGE, "--rate"),
    (&["panel", "--rate", "abc"], USAGE, "--rate"),
    (&["panel", "--script", "SCRIPTS/missing.script"], RUNTIME, "cannot read"),
    (&["panel", "--script", "SCRIPTS/bad.script"], USAGE, "count 0 is not in 1–1000"),
    (&["panel", "--script", "SCRIPTS/nan.script"], USAGE, "tension NaN is not in 0–60 kgf"),
    (&["panel", "--state", "UNWRITABLE/panel.state"], USAGE, "error: --state "),
    (&["panel", "--state", "SCRIPTS/bad.script"], USAGE, "not a machine's flash image"),
    // ── report accuracy ──
    (&["report", "accuracy", "--scenarios", "0"], USAGE, "--scenarios"),
    (&["report", "accuracy", "--scenarios", "-1"], USAGE, "--scenarios"),
    (&["report", "accuracy", "--scenarios", "1.5"], USAGE, "--scenarios"),
    (&["report", "accuracy", "--scenarios", "abc"], USAGE, "--scenarios"),
    (&["report", "accuracy", "--seed", "-1"], USAGE, "--seed"),
    (&["report", "accuracy", "--controllers", "taut,foo"], USAGE, "--controllers"),
    (&["report", "accuracy", "--sensing", "hall"], USAGE, "--sensing"),
    (&["report", "accuracy", "--threads", "0"], USAGE, "--threads"),
    (&["report", "accuracy", "--gauge-sigma", "-0.01"], USAGE, "--gauge-sigma"),
    (&["report", "accuracy", "--gauge-sigma", "1.5"], USAGE, "--gauge-sigma"),
    (&["report", "accuracy", "--gauge-sigma", "nan"], USAGE, "--gauge-sigma"),
    (&["report", "accuracy", "--gauge-sigma", "abc"], USAGE, "--gauge-sigma"),
    (&["report", "accuracy", "--json", "UNWRITABLE/a.json"], USAGE, "error: --json "),
    (&["report", "accuracy", "--svg", "UNWRITABLE/plots"], USAGE, "error: --svg "),
    // ── report ablation ──
    (&["report", "ablation", "--scenarios", "0"], USAGE, "--scenarios"),
    (&["report", "ablation", "--seed", "abc"], USAGE, "--seed"),
    (&["report", "ablation", "--sensing", "hall"], USAGE, "--sensing"),
    (&["report", "ablation", "--threads", "abc"], USAGE, "--threads"),
    (&["report", "ablation", "--json", "UNWRITABLE/a.json"], USAGE, "error: --json "),
    // ── report robustness ──
    (&["report", "robustness", "--scenarios", "0"], USAGE, "--scenarios"),
    (&["report", "robustness", "--points", "1"], USAGE, "--points"),
    (&["report", "robustness", "--points", "nan"], USAGE, "--points"),
    (&["report", "robustness", "--gauge-sigma", "-1"], USAGE, "--gauge-sigma"),
    (&["report", "robustness", "--gauge-sigma", "inf"], USAGE, "--gauge-sigma"),
    (&["report", "robustness", "--axes", "gravity"], USAGE, "not an axis"),
    (&["report", "robustness", "--corner", "inertia=1", "--axes", "friction"], USAGE, "--axes"),
    (&["report", "robustness", "--corner", "inertia=1", "--beyond", "0.5"], USAGE, "--beyond"),
    (
        &["report", "robustness", "--corner", "inertia=1", "--corner", "inertia=0"],
        USAGE,
        "given twice",
    ),
    (
        &["report", "robustness", "--corner", "bus-supply=1", "--corner", "bus-clamp=0"],
        USAGE,
        "not a physical machine",
    ),
    (&["report", "robustness", "--corner", "inertia=2.5"], USAGE, "not in -1–2"),
    (&["report", "robustness", "--seed", "-3"], USAGE, "--seed"),
    (&["report", "robustness", "--threads", "0"], USAGE, "--threads"),
    (&["report", "robustness", "--beyond", "-0.5"], USAGE, "--beyond"),
    (&["report", "robustness", "--beyond", "1.5"], USAGE, "--beyond"),
    (&["report", "robustness", "--beyond", "nan"], USAGE, "--beyond"),
    (&["report", "robustness", "--json", "UNWRITABLE/r.json"], USAGE, "error: --json "),
    (&["report", "robustness", "--svg", "UNWRITABLE/r.svg"], USAGE, "error: --svg "),
    // ── report machine ──
    (&["report", "machine", "--cycles", "0"], USAGE, "--cycles"),
    (&["report", "machine", "--cycles", "-1"], USAGE, "--cycles"),
    (&["report", "machine", "--cycles", "abc"], USAGE, "--cycles"),
    (&["report", "machine", "--seed", "abc"], USAGE, "--seed"),
    (&["report", "machine", "--break-every", "-1"], USAGE, "--break-every"),
    (&["report", "machine", "--fault-every", "abc"], USAGE, "--fault-every"),
    (&["report", "machine", "--sensing", "hall"], USAGE, "--sensing"),
    (&["report", "machine", "--threads", "0"], USAGE, "--threads"),
    (&["report", "machine", "--axis", "inertia"], USAGE, "NAME=POSITION"),
    (&["report", "machine", "--axis", "gravity=1"], USAGE, "not an axis"),
    (&["report", "machine", "--axis", "inertia=2.5"], USAGE, "not in -1–2"),
    (&["report", "machine", "--axis", "backlash=-0.5"], USAGE, "not a physical machine"),
    (&["report", "machine", "--axis", "slack=1", "--axis", "slack=1"], USAGE, "given twice"),
    (&["report", "machine", "--axis", "inertia=1", "--axis", "inertia=3"], USAGE, "not in -1–2"),
    (&["report", "machine", "--json", "UNWRITABLE/m.json"], USAGE, "error: --json "),
    // ── report session ──
    (&["report", "session", "--machines", "0"], USAGE, "--machines"),
    (&["report", "session", "--pulls", "0"], USAGE, "--pulls"),
    (&["report", "session", "--pulls", "abc"], USAGE, "--pulls"),
    (&["report", "session", "--seed", "abc"], USAGE, "--seed"),
    (&["report", "session", "--threads", "0"], USAGE, "--threads"),
    (&["report", "session", "--json", "UNWRITABLE/s.json"], USAGE, "error: --json "),
    // ── report string ──
    (&["report", "string", "--seeds", "-1"], USAGE, "--seeds"),
    (&["report", "string", "--seeds", "1001"], USAGE, "--seeds"),
    (&["report", "string", "--hold", "4.9"], USAGE, "5–600"),
    (&["report", "string", "--hold", "601"], USAGE, "5–600"),
    (&["report", "string", "--hold", "abc"], USAGE, "--hold"),
    (&["report", "string", "--json", "UNWRITABLE/s.json"], USAGE, "error: --json "),
    // ── unknown subcommands and options ──
    (&["report", "speed"], USAGE, "unrecognized subcommand"),
    (&["pull", "--force", "9"], USAGE, "--force"),
    // ── the machine link ──
    (&["connect", "--port", "SCRIPTS/no-such-port"], RUNTIME, "cannot open"),
    (&["connect", "--twin", "--port", "x"], USAGE, "cannot be used with"),
    (&["connect", "--twin", "--pulls", "21"], USAGE, "--pulls"),
    (&["connect", "--twin", "--period-ms", "5"], USAGE, "--period-ms"),
    (&["connect", "--twin", "--seconds", "0"], USAGE, "--seconds"),
    (&["log", "--port", "SCRIPTS/no-such-port"], RUNTIME, "cannot open"),
    (&["log", "--twin", "--pulls", "abc"], USAGE, "--pulls"),
    (&["log", "--twin", "--csv", "UNWRITABLE/log.csv"], USAGE, "error: --csv "),
    (&["log", "--twin", "--json", "UNWRITABLE/log.json"], USAGE, "error: --json "),
    (
        &["backup", "--port", "SCRIPTS/no-such-port", "--out", "SCRIPTS/b.json"],
        RUNTIME,
        "cannot open",
    ),
    (&["backup", "--twin", "--out", "UNWRITABLE/backup.json"], USAGE, "error: --out "),
    (
        &["restore", "SCRIPTS/missing.json", "--port", "SCRIPTS/no-such-port"],
        RUNTIME,
        "cannot read",
    ),
    (&["restore", "SCRIPTS/bad.script", "--twin"], RUNTIME, "not a taut backup"),
];

#[test]
fn every_bad_input_is_refused_with_a_message_and_the_right_status() {
    let dir = scratch();
    let unwritable = dir.join("file");
    let mut failures = Vec::new();
    for (args, status, says) in TABLE {
        let args: Vec<String> = args
            .iter()
            .map(|a| {
                a.replace("UNWRITABLE", &unwritable.to_string_lossy())
                    .replace("SCRIPTS", &dir.to_string_lossy())
            })
            .collect();
        let output = spawn(
            Command::new(env!("CARGO_BIN_EXE_taut"))
                .args(&args)
                .current_dir(dir.join("cwd"))
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped()),
        )
        .wait_with_output()
        .expect("runs");
        let stderr = String::from_utf8_lossy(&output.stderr);
        let code = output.status.code();
        let first = stderr.lines().find(|l| l.starts_with("error:")).unwrap_or("");
        let readable = first.contains(says) || stderr.contains(says);
        println!("{:<70} → {code:?} {first}", args.join(" "));
        if code != Some(*status)
            || !readable
            || stderr.contains("panicked")
            || stderr.contains("RUST_BACKTRACE")
        {
            failures.push(format!("{args:?}: exit {code:?} (want {status}), stderr:\n{stderr}"));
        }
        if *status == RUNTIME {
            let lines = stderr.lines().filter(|l| l.starts_with("error:")).count();
            if lines != 1 {
                failures.push(format!("{args:?}: {lines} error lines, want one:\n{stderr}"));
            }
        }
    }
    // A refused run touches no file: not even the default plot of the folder it runs in.
    let plot = std::fs::read_to_string(dir.join("cwd/out/cycle.svg")).unwrap_or_default();
    let folder: Vec<_> =
        std::fs::read_dir(dir.join("cwd")).unwrap().map(|e| e.unwrap().file_name()).collect();
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(plot, EARLIER_PLOT, "the working directory's out/cycle.svg is left alone");
    assert_eq!(folder, ["out"], "nothing new in the working directory");
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        TABLE.len(),
        failures.join("\n")
    );
}

#[test]
fn the_table_covers_every_subcommand_and_every_value_taking_option() {
    use clap::CommandFactory as _;
    let cli = taut::cli::Cli::command();
    let subcommands: Vec<&str> = cli.get_subcommands().map(clap::Command::get_name).collect();
    // A row is for the main job when it does not start with a subcommand's name.
    let main_job = |args: &[&str]| args.first().is_none_or(|a| !subcommands.contains(a));
    let mut missing = Vec::new();
    let mut check = |path: &[&str], command: &clap::Command| {
        for arg in command.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            if !arg.get_action().takes_values() || long == "help" {
                continue;
            }
            let flag = format!("--{long}");
            let covered = TABLE.iter().any(|(args, _, _)| {
                args.len() > path.len()
                    && args[..path.len()] == *path
                    && (!path.is_empty() || main_job(args))
                    && args[path.len()..].contains(&flag.as_str())
            });
            if !covered {
                missing.push(format!("{} {flag}", path.join(" ")));
            }
        }
    };
    check(&[], &cli);
    for sub in cli.get_subcommands() {
        let name = sub.get_name();
        if name == "report" {
            for report in sub.get_subcommands() {
                check(&["report", report.get_name()], report);
            }
        } else {
            check(&[name], sub);
        }
    }
    assert!(missing.is_empty(), "options without a bad-input row: {missing:?}");
}

/// Which of the tool's output streams go to a pipe whose reader is gone.
#[derive(Clone, Copy)]
enum Closed {
    /// Standard output only (`taut … | head -1`).
    Stdout,
    /// Standard error only (progress to a log reader that quit).
    Stderr,
    /// Both (`taut … 2>&1 | head -1`).
    Both,
}

/// Runs the tool in `dir` with `closed` streams on a pipe whose reader is already gone (so
/// the first write fails, however fast the tool is), the others collected; returns the exit
/// status and what the open stream received.
fn with_closed_pipe(args: &[&str], dir: &std::path::Path, closed: Closed) -> (Option<i32>, String) {
    // The lock keeps a sibling test's child, forked but not yet exec'd, from holding a copy
    // of the reader.
    let alone = SPAWNING.lock().unwrap_or_else(PoisonError::into_inner);
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let mut command = Command::new(env!("CARGO_BIN_EXE_taut"));
    command.args(args).current_dir(dir).stdin(Stdio::null());
    match closed {
        Closed::Stdout => command.stdout(writer).stderr(Stdio::piped()),
        Closed::Stderr => command.stdout(Stdio::piped()).stderr(writer),
        Closed::Both => command.stdout(writer.try_clone().unwrap()).stderr(writer),
    };
    let child = command.spawn().unwrap();
    drop(command);
    drop(alone);
    let out = child.wait_with_output().unwrap();
    let open = match closed {
        Closed::Stdout => &out.stderr,
        Closed::Stderr | Closed::Both => &out.stdout,
    };
    let open = String::from_utf8_lossy(open).into_owned();
    println!("{args:?}: status {:?}, open stream {open:?}", out.status.code());
    (out.status.code(), open)
}

/// A reader that closes its end of the pipe early (`taut … | head -1`): the tool stops
/// quietly with the status of a `SIGPIPE`-killed filter (141), not a panic (101) with a
/// backtrace on the terminal.
#[test]
fn a_closed_pipe_ends_the_output_quietly() {
    let (status, stderr) = with_closed_pipe(&["paper"], &std::env::temp_dir(), Closed::Stdout);
    assert_eq!(status, Some(141), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "stderr: {stderr}");
}

/// The panel's script transcript into a closed pipe (`taut panel --script … | head -1`)
/// ends as any filter's does: status 141 and no message, not a failed script (1).
#[test]
fn a_script_transcript_into_a_closed_pipe_ends_as_a_filter_does() {
    let (status, stderr) = with_closed_pipe(
        &["panel", "--flash", "blank", "--script", "-"],
        &std::env::temp_dir(),
        Closed::Stdout,
    );
    assert_eq!(status, Some(141), "stderr: {stderr}");
    assert_eq!(stderr, "", "no message");
}

/// A closed stderr is as quiet as a closed stdout (`taut --svg x.svg 2>&1 | head -1`): no
/// panic ("failed printing to stderr", 101); the run goes on and writes its plot, and the
/// closed stdout then ends it with 141. A usage error and a refused path keep their status.
#[test]
fn a_closed_stderr_is_as_quiet_as_a_closed_stdout() {
    let dir = std::env::temp_dir().join(format!("taut-closed-stderr-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (status, _) = with_closed_pipe(&["--hold", "5", "--svg", "x.svg"], &dir, Closed::Both);
    assert_eq!(status, Some(141));
    let plot = std::fs::read_to_string(dir.join("x.svg")).unwrap_or_default();
    assert!(plot.starts_with("<svg"), "the plot is written: {} bytes", plot.len());

    let (status, stdout) =
        with_closed_pipe(&["--hold", "5", "--svg", "y.svg"], &dir, Closed::Stderr);
    assert_eq!(status, Some(0), "the run completes");
    assert!(stdout.contains("plot: y.svg"), "{stdout}");
    assert!(dir.join("y.svg").is_file());

    let (status, _) = with_closed_pipe(&["--tension", "70"], &dir, Closed::Stderr);
    assert_eq!(status, Some(2));
    let (status, _) = with_closed_pipe(&["--svg", "missing/x.svg"], &dir, Closed::Stderr);
    assert_eq!(status, Some(2));
    let (status, _) = with_closed_pipe(&["pull", "--string", "none"], &dir, Closed::Stderr);
    assert_ne!(status, Some(101), "no panic");
    std::fs::remove_dir_all(&dir).ok();
}

/// Exit status 0 only when what was asked for happened: a pull with no string in the gripper
/// never settles at its target, and says so (it used to exit 0); a pull that settles exits 0.
#[test]
fn a_pull_that_never_settles_exits_1() {
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_taut"))
            .args(args)
            .current_dir(std::env::temp_dir())
            .stdin(Stdio::null())
            .output()
            .expect("runs")
    };
    let none = run(&["pull", "--string", "none", "--hold", "5"]);
    let stderr = String::from_utf8_lossy(&none.stderr);
    assert_eq!(none.status.code(), Some(1), "{stderr}");
    assert!(String::from_utf8_lossy(&none.stdout).contains("settled never"));
    assert!(stderr.contains("never settled at 25.0 kgf"), "{stderr}");
    let pulled = run(&["pull", "--string", "tennis-poly", "--hold", "5"]);
    assert_eq!(pulled.status.code(), Some(0), "{}", String::from_utf8_lossy(&pulled.stderr));
}

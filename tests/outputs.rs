//! The tool's output files as a user meets them, through the binary: a bad output path is
//! refused before the run (exit status 2, one line naming the option) and touches no file; a
//! run that completes replaces its files and leaves no temporary file; a run killed half way
//! leaves the files of an earlier run as they were. Every run's working directory is a
//! folder of the test's own, so no run can reach a file of the checkout.
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::print_stdout,
    clippy::panic,
    reason = "a test: a panic is how it reports"
)]

use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// An empty folder of this test's own under the build's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("outputs").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The tool run with `args` in `dir`.
fn taut(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_taut"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("runs")
}

/// Every file under `dir` with its contents, sorted by path.
fn contents(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut all = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                all.push((path.clone(), Vec::new()));
                stack.push(path);
            } else {
                all.push((path.clone(), std::fs::read(&path).unwrap()));
            }
        }
    }
    all.sort();
    all
}

#[test]
fn a_bad_output_path_is_refused_before_the_run_and_touches_no_file() {
    let dir = scratch("refused");
    std::fs::create_dir(dir.join("out")).unwrap();
    std::fs::create_dir(dir.join("a folder")).unwrap();
    std::fs::write(dir.join("out/cycle.svg"), "an earlier plot").unwrap();
    std::fs::write(dir.join("keep.json"), "an earlier summary").unwrap();
    std::fs::write(dir.join("a.svg"), "an earlier pull").unwrap();
    let before = contents(&dir);
    // (arguments, the option named, what the message says)
    let mut cases: Vec<(&[&str], &str, &str)> = vec![
        // The default --svg (out/cycle.svg) is left alone when --json is refused.
        (&["--json", "a folder"], "--json", "is a folder, not a file"),
        (&["--svg", "missing/deeper/x.svg"], "--svg", "the folder missing/deeper does not exist"),
        (&["--svg", "x.svg", "--json", "./x.svg"], "--json", "the same path as --svg's"),
        (&["--svg", "keep.json", "--json", "keep.json"], "--json", "the same path as --svg's"),
        (&["pull", "--svg", "a.svg", "--csv", "a.svg"], "--csv", "the same path as --svg's"),
        (&["pull", "--svg", "a.svg", "--csv", "a.svg/"], "--csv", "is a folder"),
        (
            &["report", "accuracy", "--svg", "out", "--json", "out/a.json"],
            "--svg",
            "a folder of plots that holds --json's file",
        ),
        (&["report", "robustness", "--json", "keep.json/x"], "--json", "is a file, not a folder"),
    ];
    if cfg!(target_os = "linux") {
        cases.extend([
            (&["--svg", "/proc/x.svg", "--json", "keep.json"][..], "--svg", "cannot create"),
            (&["paper", "--svg", "/proc/x.svg", "--json", "keep.json"], "--svg", "cannot create"),
            (&["pull", "--svg", "a.svg", "--csv", "/proc/x.csv"], "--csv", "cannot create"),
        ]);
    }
    let mut failures = Vec::new();
    for (args, option, says) in &cases {
        let out = taut(&dir, args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
        println!("{args:?} → {:?} {errors:?}", out.status.code());
        let named = errors.len() == 1
            && errors[0].starts_with(&format!("error: {option} "))
            && errors[0].contains(says);
        if out.status.code() != Some(2) || !named || !out.stdout.is_empty() {
            failures.push(format!("{args:?}: exit {:?}, stderr {stderr}", out.status.code()));
        }
    }
    assert_eq!(contents(&dir), before, "a refused run touches no file and makes no folder");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_completed_run_replaces_its_files_and_leaves_no_temporary_file() {
    let dir = scratch("completed");
    std::fs::write(dir.join("paper.svg"), "an earlier plot").unwrap();
    let out = taut(&dir, &["paper", "--svg", "paper.svg", "--json", "paper.json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let files = contents(&dir);
    let names: Vec<String> =
        files.iter().map(|(p, _)| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["paper.json", "paper.svg"], "no temporary file left");
    assert!(files[1].1.starts_with(b"<svg"), "the plot is replaced");
    let summary: serde_json::Value = serde_json::from_slice(&files[0].1).unwrap();
    assert!(summary["pd_steady_error_kgw"].is_number());
}

/// Ctrl-C sends `SIGINT`, which ends the tool as a kill does (it installs no handler): the
/// run is killed once its progress shows it under way.
#[test]
fn a_run_killed_half_way_leaves_the_earlier_files_as_they_were() {
    let dir = scratch("killed");
    std::fs::write(dir.join("cycle.svg"), "an earlier plot").unwrap();
    std::fs::write(dir.join("cycle.json"), "an earlier summary").unwrap();
    let before = contents(&dir);
    let mut child = Command::new(env!("CARGO_BIN_EXE_taut"))
        .args(["--hold", "120", "--svg", "cycle.svg", "--json", "cycle.json"])
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let mut progress = BufReader::new(child.stderr.take().unwrap());
    let mut first = String::new();
    progress.read_line(&mut first).unwrap();
    assert!(first.contains("kgf"), "the run is under way: {first}");
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert_eq!(contents(&dir), before, "the earlier files, untouched");
}

/// A report whose stderr is a pipe or a log prints its progress as lines (it used to print
/// nothing until the end): one when it starts, one every few seconds, one when it is done.
#[test]
fn a_report_into_a_pipe_prints_its_progress_as_lines() {
    let dir = scratch("progress");
    let out = taut(&dir, &["report", "accuracy", "--scenarios", "2", "--threads", "1"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stderr}");
    assert!(out.status.success(), "{stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert!(lines.first().is_some_and(|l| l.starts_with("0/2 scenarios, ")), "{stderr}");
    assert!(
        lines.last().is_some_and(|l| l.starts_with("2/2 scenarios, ") && l.ends_with(", done"))
    );
    assert!(!stderr.contains('\r'), "no carriage returns in a log");
}

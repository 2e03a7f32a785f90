//! The scripts that break the code on purpose (`scripts/break-drive`, `scripts/break-machine`,
//! `scripts/break-binding`) are checks of the checks: each seeds a bug by replacing a piece of
//! the tree's text and expects a test or a proof to go red. A table whose text has moved tests
//! nothing, and a run whose tool is missing proves nothing, so both must fail loudly. These
//! tests hold the tables to today's tree (`--check`) and show that the scripts do fail: on a
//! tree without the text, and when Kani is not there. Nothing here writes into the repository.
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::panic,
    reason = "a test: a panic is how it reports"
)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn python(script: &str, args: &[&str], cwd: &Path, path: Option<&str>) -> Output {
    let mut command = Command::new("python3");
    command.arg(root().join("scripts").join(script)).args(args).current_dir(cwd);
    if let Some(path) = path {
        command.env("PATH", path);
    }
    command.output().expect("python3 runs (the scripts need it)")
}

/// An empty folder of this test's own under the build's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scripts").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(output: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

#[test]
fn every_seeded_bug_still_finds_the_text_it_breaks() {
    for script in ["break-drive", "break-machine", "break-binding"] {
        let output = python(script, &["--check"], &root(), None);
        assert!(output.status.success(), "{script} --check: {}", text(&output));
        assert!(text(&output).contains("every original text found"), "{script}: {}", text(&output));
    }
}

#[test]
fn a_stale_table_fails_before_anything_runs() {
    let dir = scratch("stale");
    let init = Command::new("git").args(["init", "-q"]).current_dir(&dir).status().unwrap();
    assert!(init.success());
    for script in ["break-drive", "break-machine", "break-binding"] {
        let output = python(script, &["--check"], &dir, None);
        assert!(!output.status.success(), "{script} passed on an empty tree: {}", text(&output));
        assert!(text(&output).contains("update the"), "{script}: {}", text(&output));
    }
}

#[test]
fn without_kani_the_proof_runs_fail_and_leave_no_worktree() {
    // The PATH with, first, a `cargo` that knows no `kani`.
    let bin = scratch("no-kani");
    let cargo = bin.join("cargo");
    std::fs::write(&cargo, "#!/bin/sh\necho \"error: no such command: $1\" >&2\nexit 101\n")
        .unwrap();
    let mut permissions = std::fs::metadata(&cargo).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut permissions, 0o755);
    std::fs::set_permissions(&cargo, permissions).unwrap();
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    for script in ["break-drive", "break-machine"] {
        let output = python(script, &["--no-tests"], &root(), Some(&path));
        assert!(!output.status.success(), "{script} without Kani exited 0: {}", text(&output));
        assert!(text(&output).contains("Kani is not installed"), "{script}: {}", text(&output));
    }
    assert!(!root().join("target/break-drive/worktree").exists());
}

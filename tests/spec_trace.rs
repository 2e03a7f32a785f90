//! Traceability: every requirement in `docs/SPEC.md` names what enforces it, and every name
//! exists.
//!
//! The spec's requirement tables have rows `| REQ-XXX-NN | requirement | enforced by |`; the
//! last column lists backticked names, each a test function, a Kani harness (`verify_*`), a
//! model-check property, or a cargo-fuzz target. This test
//! - finds every requirement id and checks ids are unique;
//! - checks each row names at least one enforcing item, and that each name exists in the tree
//!   as a `fn` (in any crate's sources or tests) or as a fuzz target (`fuzz/fuzz_targets/*.rs`);
//! - checks safety requirements (`REQ-DRV-*`, `REQ-SAFE-*`) name a Kani harness or a
//!   model-check property, not only tests;
//! - checks every `REQ-…` id quoted in the code is defined in the spec, so a property's failure
//!   message always points at a real requirement.
#![allow(
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    reason = "a test: a panic is how it reports"
)]

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

const SOURCE_DIRS: [&str; 8] = ["core", "proofs", "sim", "src", "tests", "firmware", "fuzz", "pil"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        if name == "target" || name.to_string_lossy().starts_with('.') {
            continue;
        }
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Names that exist in the tree: every `fn name` and fuzz target, and (separately) every string
/// literal that is an identifier — model-check properties are named by such strings.
struct Defined {
    items: BTreeSet<String>,
    literals: BTreeSet<String>,
}

fn defined_names() -> Defined {
    let mut files = Vec::new();
    for dir in SOURCE_DIRS {
        rust_files(&root().join(dir), &mut files);
    }
    let mut names = BTreeSet::new();
    let mut literals = BTreeSet::new();
    for file in &files {
        let text = fs::read_to_string(file).expect("readable source");
        for (at, _) in text.match_indices("fn ") {
            let before = text[..at].chars().last();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let name: String =
                text[at + 3..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if !name.is_empty() {
                names.insert(name);
            }
        }
        for piece in text.split('"').skip(1).step_by(2) {
            if !piece.is_empty() && piece.chars().all(|c| c.is_alphanumeric() || c == '_') {
                literals.insert(piece.to_owned());
            }
        }
    }
    if let Ok(entries) = fs::read_dir(root().join("fuzz/fuzz_targets")) {
        for entry in entries.flatten() {
            if let Some(stem) = entry.path().file_stem() {
                names.insert(stem.to_string_lossy().into_owned());
            }
        }
    }
    Defined { items: names, literals }
}

struct Requirement {
    id: String,
    enforced_by: Vec<(String, String)>,
}

fn requirements(spec: &str) -> Vec<Requirement> {
    let mut out = Vec::new();
    for line in spec.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // A table row starts with '|', so cells[0] is empty and cells[1] the first column.
        if cells.len() < 4 || !cells[1].starts_with("REQ-") {
            continue;
        }
        let id = cells[1].to_owned();
        let last = cells[cells.len() - 2];
        let mut enforced_by = Vec::new();
        let mut rest = last;
        while let Some(start) = rest.find('`') {
            let after = &rest[start + 1..];
            let Some(end) = after.find('`') else { break };
            let name = after[..end].to_owned();
            let tail = &after[end + 1..];
            let kind = tail
                .trim_start()
                .strip_prefix('(')
                .and_then(|t| t.split(')').next())
                .unwrap_or("")
                .to_owned();
            enforced_by.push((name, kind));
            rest = tail;
        }
        out.push(Requirement { id, enforced_by });
    }
    out
}

#[test]
fn every_requirement_names_existing_enforcement() {
    let spec = fs::read_to_string(root().join("docs/SPEC.md")).expect("docs/SPEC.md exists");
    let requirements = requirements(&spec);
    assert!(!requirements.is_empty(), "no requirements found in docs/SPEC.md");
    let defined = defined_names();

    let mut seen = BTreeSet::new();
    let mut problems = Vec::new();
    let mut by_area: BTreeMap<String, usize> = BTreeMap::new();
    let mut links = 0;
    for requirement in &requirements {
        let area = requirement.id.rsplit_once('-').map_or("", |(area, _)| area).to_owned();
        *by_area.entry(area.clone()).or_default() += 1;
        if !seen.insert(requirement.id.clone()) {
            problems.push(format!("{} is defined twice", requirement.id));
        }
        if requirement.enforced_by.is_empty() {
            problems.push(format!("{} names nothing that enforces it", requirement.id));
        }
        for (name, kind) in &requirement.enforced_by {
            links += 1;
            let exists = defined.items.contains(name)
                || (kind.contains("model check") && defined.literals.contains(name));
            if !exists {
                problems.push(format!("{} names `{name}`, which does not exist", requirement.id));
            }
        }
        let safety = area == "REQ-DRV" || area == "REQ-SAFE";
        let proven = requirement
            .enforced_by
            .iter()
            .any(|(name, kind)| name.starts_with("verify_") || kind.contains("model check"));
        if safety && !proven {
            problems.push(format!("{} is a safety requirement with no proof", requirement.id));
        }
    }
    assert!(problems.is_empty(), "spec traceability problems:\n{}", problems.join("\n"));
    println!(
        "every_requirement_names_existing_enforcement: {} requirements ({}), {links} links, all resolve",
        requirements.len(),
        by_area.iter().map(|(area, n)| format!("{area}: {n}")).collect::<Vec<_>>().join(", ")
    );
}

#[test]
fn every_requirement_quoted_in_code_is_in_the_spec() {
    let spec = fs::read_to_string(root().join("docs/SPEC.md")).expect("docs/SPEC.md exists");
    let ids: BTreeSet<String> = requirements(&spec).into_iter().map(|r| r.id).collect();
    let mut files = Vec::new();
    for dir in SOURCE_DIRS {
        rust_files(&root().join(dir), &mut files);
    }
    let mut unknown = BTreeSet::new();
    for file in &files {
        let text = fs::read_to_string(file).expect("readable source");
        for (at, _) in text.match_indices("REQ-") {
            let id: String =
                text[at..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '-').collect();
            // Only complete ids (`REQ-AREA-NN`), not prefixes quoted in prose.
            let complete = id.rsplit_once('-').is_some_and(|(area, number)| {
                area.len() > 4 && !number.is_empty() && number.chars().all(|c| c.is_ascii_digit())
            });
            if complete && !ids.contains(&id) {
                unknown.insert(format!("{id} (in {})", file.display()));
            }
        }
    }
    assert!(unknown.is_empty(), "ids quoted in code but not in docs/SPEC.md:\n{unknown:#?}");
}

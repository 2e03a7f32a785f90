//! `taut` (library part): the host tool — the main job, the terminal panel, the reports and
//! the plots, all running the firmware's machine (or its tension controller) on the digital
//! twin through the one bench, [`taut_sim::bench`].
//!
//! The `taut` binary (`src/main.rs`) parses the command line ([`cli`]) and calls one entry
//! function per subcommand: [`job::main`], [`panel::main`], [`pull::main`], [`paper::main`],
//! [`report::accuracy::main`], [`report::ablation::main`], [`report::robustness::main`],
//! [`report::machine::main`]. Each returns an [`output::Status`]; failures are one line.
//! Modules depend downwards only: `cli`, `output`, `plot` at the bottom; `report` on them;
//! `pull` on `report`; `job`, `panel`, `paper` on the bottom three.
#![allow(
    clippy::float_arithmetic,
    reason = "host-side reports: metrics, percentiles and plots are computed in f64"
)]
#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_precision_loss,
    clippy::cast_possible_wrap,
    reason = "f64 ↔ integer conversions of counts, pixels and rounded values, each clamped first"
)]
#![allow(
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    reason = "host tool: counts and indices of its own vectors; an overflow or a bad index is a \
              bug, not a user's input"
)]
#![allow(clippy::print_stdout, reason = "a command-line tool prints its results")]
#![deny(
    clippy::print_stderr,
    reason = "`eprintln!` panics when stderr is closed (`taut 2>&1 | head -1`): diagnostics go \
              through `output::to_stderr`"
)]

pub mod cli;
pub mod job;
pub mod link;
pub mod output;
pub mod panel;
pub mod paper;
pub mod plot;
pub mod pull;
pub mod report;

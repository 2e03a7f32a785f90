//! `taut` (library part): the host side of taut — software-in-the-loop runs of the tension
//! controller on the digital twin, the reports built on them, and the SVG plots.
//!
//! The `taut` binary (`src/main.rs`) is a thin clap front end over these modules; the root
//! `tests/` use them directly.
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
    reason = "host tool: an overflow or bad index is a bug that should stop the report loudly"
)]
#![allow(clippy::expect_used, reason = "host tool: a broken built-in configuration is a bug")]

pub mod cycle;
pub mod panel;
pub mod paper;
pub mod plot;
pub mod report;
pub mod sil;

//! taut-core: everything a racket-stringing machine decides, and nothing it touches.
//!
//! This crate is the whole of taut's logic — BLDC commutation and its safety interlocks,
//! the conversion of sensor codes into tension, the tension controller and the operator's
//! machine — written as pure, allocation-free functions of their inputs, so that the same
//! code runs on the motor-control MCU, inside the digital twin, under `cargo test`, under the
//! fuzzer and under Kani.
//!
//! Rules held throughout: `no_std`, no allocation, no `unsafe`, no floating point, no panic
//! paths (no `unwrap`/`expect`, no unchecked indexing, no overflowing arithmetic — the
//! workspace's clippy table denies them), loops with constant bounds, physical units as
//! types ([`units`]).
//!
//! Map:
//! - [`units`]: kgf, volts, amps, … as Q15.16 fixed-point newtypes; ADC codes.
//! - [`io`]: the per-tick [`io::Inputs`] / [`io::Outputs`] boundary to hardware.
//! - [`drive`]: Hall decoding, six-step table, dead time, duty bound, reversal, overcurrent.
//! - [`sense`]: ADC codes → amperes and kilograms-force.
#![no_std]
#![forbid(unsafe_code)]
#![cfg_attr(
    test,
    allow(
        clippy::arithmetic_side_effects,
        clippy::cast_possible_truncation,
        reason = "unit tests compute expected values from small constants; an overflow there \
                  panics the test, which is the report we want"
    )
)]

pub mod drive;
pub mod io;
pub mod machine;
pub mod sense;
pub mod store;
pub mod tension;
pub mod units;

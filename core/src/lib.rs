//! taut-core: everything a racket-stringing machine decides, and nothing it touches.
//!
//! This crate is the whole of taut's logic — BLDC commutation and its safety interlocks,
//! the conversion of sensor codes into tension, the tension controller and the operator's
//! machine — written as pure, allocation-free functions of their inputs, so that the same
//! code runs on the motor-control MCU, inside the digital twin, under `cargo test`, under the
//! fuzzer and under Kani.
//!
//! Rules held throughout: `no_std`, no allocation, memory safety by the compiler alone
//! (`forbid` below), no floating point, no panic paths (no unchecked unwrapping or indexing,
//! no overflowing arithmetic — the workspace's clippy table denies them), loops with
//! constant bounds, physical units as types ([`units`]).
//!
//! Map:
//! - [`units`]: kgf, volts, amps, … as Q15.16 fixed-point newtypes; ADC codes.
//! - [`fixed`]: exact wide products, rounding, saturation, the division-free reciprocal.
//! - [`io`]: the per-tick [`io::Inputs`] / [`io::Outputs`] boundary to hardware.
//! - [`drive`]: Hall decoding, six-step table, dead time, duty bound, reversal, overcurrent.
//! - [`sense`]: ADC codes → amperes and kilograms-force; the 4-point calibration.
//! - [`settings`]: what the operator sets (tension, speed, pre-stretch, knot, unit), validated
//!   once and shared by the panel, the record and the controller.
//! - [`tension`]: the tension controller (RSMC as published, taut's RSMC, PD) and pull profile.
//! - [`machine`]: the operator's statig machine, panel, safety rules and fault codes.
//! - [`mechanism`]: the drive train's nameplate (pole pairs, gear ratio, lead) and every
//!   Hall-step ↔ travel conversion derived from it.
//! - [`store`]: the persisted record.
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

// The fuzz targets' `arbitrary` derives expand to `std::thread_local!`: only that host-side
// build links `std` (the firmware's and every other build stay `no_std`).
#[cfg(feature = "arbitrary")]
extern crate std;

pub mod board;
mod codes;
pub mod drive;
pub mod fixed;
pub mod io;
pub mod machine;
pub mod mechanism;
pub mod sense;
pub mod settings;
pub mod store;
pub mod tension;
pub mod units;

/// Helpers for the unit tests.
#[cfg(test)]
mod test_support {
    /// The paper's board ([`crate::board::paper`]).
    pub fn paper_board() -> crate::board::BoardConfig {
        valid(crate::board::paper())
    }

    /// The value of a result a test expects to be valid; a failure names the error.
    pub fn valid<T, E: core::fmt::Debug>(result: Result<T, E>) -> T {
        match result {
            Ok(value) => value,
            Err(error) => panic!("expected a valid value, got {error:?}"),
        }
    }
}

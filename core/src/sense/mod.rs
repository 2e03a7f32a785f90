//! Sensing: turning converter codes into physical quantities.
//!
//! The firmware hands the core raw [`AdcCode`](crate::units::AdcCode)s; everything that gives
//! them meaning — reference voltage, amplifier gains, calibration — lives here so that the
//! twin, the tests and the board all read the same numbers the same way.

pub mod calibration;
#[cfg(any(test, feature = "paper-board"))]
pub mod current;
pub mod load_cell;
pub mod rezero;

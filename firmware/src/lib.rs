//! taut-firmware: the hardware half of taut — every register, pin and flash page, and no
//! decisions.
//!
//! # Theory of operation
//!
//! taut's one rule is that `taut-core` holds all logic and no hardware, and this crate holds
//! all hardware and no logic. The image (`src/main.rs` and its `hardware` module, built only
//! for `thumbv7em-none-eabihf`) samples the peripherals into the core's boundary types, calls
//! the core, and writes what the core returns back to the peripherals. Every branch in this
//! crate is about hardware: a register encoding, a flash page, a pin level.
//!
//! This library is the part of the firmware that does not touch a peripheral, so it builds and
//! is tested on the host like the rest of the workspace (Stabilizer's layout):
//!
//! - [`pins`]: the board, its pin map and wiring table (the README's table is generated
//!   from it and checked against it).
//! - [`bridge`]: the TIM1 register images that put a [`taut_core::drive::SwitchPattern`] and
//!   a [`taut_core::drive::Duty`] on the bridge, and the hardware dead-time encoding of
//!   [`timing::DEAD_TIME_TICKS`].
//! - [`timing`]: the board's timer clock, PWM period and dead time, and how they reach core
//!   (the dead time in the drive's configuration, elapsed time as [`taut_core::drive::DriveTime`]).
//! - [`flash_layout`] and [`settings`]: where the persisted record lives in internal flash and
//!   the power-safe store (sequential-storage) that keeps it there.
//! - [`link`]: the machine link's receive and transmit rings (the USART's DMA fills and
//!   drains them; the server of `taut-link` reads and writes them).
//! - [`panel`]: the TM1637 7-segment driver that shifts the core's
//!   [`taut_core::io::Segments`] out on two wires.
//! - [`timing`]: the PWM period and dead time from the core, and where in the period the ADCs
//!   sample (checked against them at compile time).
//! - [`log`]: the one place that knows about defmt.
#![no_std]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects,
        reason = "unit tests: a failed unwrap, index or overflow panics the test, which is the \
                  report we want"
    )
)]

#[cfg(test)]
extern crate std;

pub mod board;
pub mod bridge;
pub mod flash_layout;
pub mod link;
pub mod log;
pub mod panel;
pub mod pins;
pub mod settings;
pub mod timing;

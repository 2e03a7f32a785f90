//! taut-link: the machine link — the protocol between a taut machine and a PC on the board's
//! USB virtual serial port, and the machine's side of it.
//!
//! # Theory of operation
//!
//! The host (the `taut` tool) and the machine (the firmware, or the twin) share this crate,
//! so both ends encode and decode the same types in the same way:
//!
//! - [`frame`]: a message is postcard bytes plus a CRC-16, COBS-stuffed and ended by a zero
//!   byte; every size is bounded and decoding any bytes gives a message or a typed error;
//! - [`message`]: the requests a host may send and the responses, samples and events the
//!   machine sends, with the protocol's version in the hello;
//! - [`server`]: the machine's side. It holds a
//!   [`taut_core::machine::access::LinkAccess`] — reads and a record proposal that core
//!   accepts only while the machine idles in Ready — and never the machine itself, so no
//!   frame can reach a drive command, a key or a state transition (the no-motion rule,
//!   REQ-LINK-02).
//!
//! `no_std`, no allocation, no `unsafe`, no panics: the firmware links it into a
//! low-priority task beside the 1 kHz tick.
#![no_std]
#![forbid(unsafe_code)]

pub mod frame;
pub mod message;
pub mod server;

pub use frame::{Deframer, FrameError, MAX_FRAME, MAX_PAYLOAD, decode, encode};
pub use message::{Command, Message, PROTOCOL_VERSION, Request, Response};
pub use server::{BAUD, LINE_BYTES_PER_MS, Server, Sink, TX_QUEUE};

//! The host's side of the machine link: the `connect`, `log`, `backup` and `restore`
//! commands, over the board's serial port or over the twin.
//!
//! # Theory of operation
//!
//! A [`Line`] is a byte pipe to a machine: a serial port ([`SerialLine`], the NUCLEO's
//! ST-LINK virtual COM port) or the twin ([`twin::TwinLine`], the firmware's machine on the
//! digital twin served by the same `taut_link::Server`). A [`Client`] frames requests onto
//! it and reads frames back with `taut_link`'s own codec: [`Client::request`] waits for the
//! reply to one request (samples and events that arrive meanwhile are kept for
//! [`Client::next_unsolicited`]), and first of all [`Client::hello`] checks the protocol
//! version. Nothing a client sends can move the machine: the protocol has no such request.

pub mod commands;
pub mod twin;

use std::collections::VecDeque;
use std::io::{Read as _, Write as _};
use std::time::{Duration, Instant};
use taut_core::store::RECORD_LEN;

use taut_link::message::{
    Identity, LOG_PAGE_ENTRIES, LogEntry, PROTOCOL_VERSION, RECORD_PART_LEN, RECORD_PARTS, Refusal,
    Request, Response,
};
use taut_link::{Command, Message};
use taut_link::{Deframer, FrameError, MAX_FRAME, encode};

use crate::output::Failure;

/// A byte pipe to a machine.
pub trait Line {
    /// Sends `bytes`.
    ///
    /// # Errors
    /// The port's error.
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()>;

    /// Reads what arrived within `timeout_ms` (0 bytes at the timeout).
    ///
    /// # Errors
    /// The port's error.
    fn read_some(&mut self, buffer: &mut [u8], timeout_ms: u32) -> std::io::Result<usize>;

    /// A clock, ms (the machine's on the twin, the wall clock's on a port).
    fn now_ms(&self) -> u64;
}

pub use taut_link::BAUD;

/// A serial port.
pub struct SerialLine {
    port: Box<dyn serialport::SerialPort>,
    started: Instant,
}

impl SerialLine {
    /// Opens `path` at [`BAUD`], 8N1.
    ///
    /// # Errors
    /// The port cannot be opened.
    pub fn open(path: &str) -> Result<Self, Failure> {
        let port = serialport::new(path, BAUD)
            .timeout(Duration::from_millis(50))
            .open()
            .map_err(|error| Failure::Message(format!("cannot open {path}: {error}")))?;
        Ok(Self { port, started: Instant::now() })
    }
}

impl Line for SerialLine {
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn read_some(&mut self, buffer: &mut [u8], timeout_ms: u32) -> std::io::Result<usize> {
        self.port.set_timeout(Duration::from_millis(u64::from(timeout_ms.max(1))))?;
        match self.port.read(buffer) {
            Ok(count) => Ok(count),
            Err(error) if error.kind() == std::io::ErrorKind::TimedOut => Ok(0),
            Err(error) => Err(error),
        }
    }

    fn now_ms(&self) -> u64 {
        u64::try_from(self.started.elapsed().as_millis()).unwrap_or(u64::MAX)
    }
}

/// The serial ports the system lists, one line each.
///
/// # Errors
/// The system's port list cannot be read.
pub fn list_ports() -> Result<Vec<String>, Failure> {
    let ports = serialport::available_ports()
        .map_err(|error| Failure::Message(format!("cannot list serial ports: {error}")))?;
    Ok(ports
        .into_iter()
        .map(|port| match port.port_type {
            serialport::SerialPortType::UsbPort(usb) => format!(
                "{}  USB {:04x}:{:04x} {}",
                port.port_name,
                usb.vid,
                usb.pid,
                usb.product.unwrap_or_default()
            ),
            _ => port.port_name,
        })
        .collect())
}

/// How long a reply may take, ms (the line's time, the twin's on the twin).
pub const REPLY_TIMEOUT_MS: u32 = 1_000;

/// The host's end of the link (see the module docs).
pub struct Client<L: Line> {
    line: L,
    deframer: Deframer,
    unsolicited: VecDeque<Response>,
    bad_frames: u32,
    seq: u16,
}

impl<L: Line> Client<L> {
    /// A client on `line`.
    pub fn new(line: L) -> Self {
        Self {
            line,
            deframer: Deframer::new(),
            unsolicited: VecDeque::new(),
            bad_frames: 0,
            seq: 0,
        }
    }

    /// The line.
    pub fn line(&self) -> &L {
        &self.line
    }

    /// The line, to drive it (the twin's ticks).
    pub fn line_mut(&mut self) -> &mut L {
        &mut self.line
    }

    /// Frames from the machine that did not decode.
    #[must_use]
    pub const fn bad_frames(&self) -> u32 {
        self.bad_frames
    }

    /// Sends `request` without waiting; returns its sequence number.
    ///
    /// # Errors
    /// The line's error.
    pub fn send(&mut self, request: &Request) -> Result<u16, Failure> {
        self.seq = self.seq.wrapping_add(1);
        let command = Command { seq: self.seq, request: *request };
        let mut frame = [0u8; MAX_FRAME];
        let len = encode(&command, &mut frame)
            .map_err(|error| Failure::Message(format!("cannot frame {request:?}: {error:?}")))?;
        self.line.write_all(&frame[..len]).map_err(|error| link_error(&error))?;
        Ok(self.seq)
    }

    /// Reads what arrives within `timeout_ms`; returns the messages, in order.
    ///
    /// # Errors
    /// The line's error.
    pub fn receive(&mut self, timeout_ms: u32) -> Result<Vec<Message>, Failure> {
        let mut buffer = [0u8; 256];
        let count = self.line.read_some(&mut buffer, timeout_ms).map_err(|e| link_error(&e))?;
        let mut messages = Vec::new();
        for &byte in &buffer[..count] {
            match self.deframer.push::<Message>(byte) {
                Some(Ok(message)) => messages.push(message),
                Some(Err(FrameError::Empty)) | None => {}
                Some(Err(_)) => self.bad_frames += 1,
            }
        }
        Ok(messages)
    }

    /// The next sample or event (kept while waiting for replies, or newly arrived), waiting
    /// up to `timeout_ms`.
    ///
    /// # Errors
    /// The line's error.
    pub fn next_unsolicited(&mut self, timeout_ms: u32) -> Result<Option<Response>, Failure> {
        if let Some(message) = self.unsolicited.pop_front() {
            return Ok(Some(message));
        }
        let messages = self.receive(timeout_ms)?;
        // Replies to commands no longer waited for are dropped.
        self.unsolicited
            .extend(messages.into_iter().filter(|m| m.reply_to.is_none()).map(|m| m.response));
        Ok(self.unsolicited.pop_front())
    }

    /// Sends `request` and returns its reply.
    ///
    /// # Errors
    /// No reply within [`REPLY_TIMEOUT_MS`], or the line's error.
    pub fn request(&mut self, request: &Request) -> Result<Response, Failure> {
        let seq = self.send(request)?;
        let started = self.line.now_ms();
        loop {
            for message in self.receive(50)? {
                match message.reply_to {
                    Some(answered) if answered == seq => return Ok(message.response),
                    // A late reply to an earlier command.
                    Some(_) => {}
                    None => self.unsolicited.push_back(message.response),
                }
            }
            if self.line.now_ms().saturating_sub(started) > u64::from(REPLY_TIMEOUT_MS) {
                return Err(Failure::Message(format!(
                    "the machine did not answer {request:?} within {REPLY_TIMEOUT_MS} ms"
                )));
            }
        }
    }

    /// The machine's identity, after checking its protocol version.
    ///
    /// # Errors
    /// No identity, or another protocol version.
    pub fn hello(&mut self) -> Result<Identity, Failure> {
        match self.request(&Request::Hello)? {
            Response::Identity(identity) if identity.protocol == PROTOCOL_VERSION => Ok(identity),
            Response::Identity(identity) => Err(Failure::Message(format!(
                "the machine speaks link protocol {}, this tool {PROTOCOL_VERSION}",
                identity.protocol
            ))),
            other => Err(unexpected(&other)),
        }
    }

    /// Every pull of the machine's log, latest first.
    ///
    /// # Errors
    /// An unexpected reply or the line's error.
    pub fn pull_log(&mut self) -> Result<Vec<LogEntry>, Failure> {
        let mut entries = Vec::new();
        for page in 0..=u8::MAX {
            match self.request(&Request::ReadLog { page })? {
                Response::LogPage(log) => {
                    entries.extend(log.entries.iter().flatten().copied());
                    let read = (usize::from(page) + 1) * LOG_PAGE_ENTRIES;
                    if read >= usize::from(log.total) {
                        break;
                    }
                }
                Response::Refused(Refusal::OutOfRange) => break,
                other => return Err(unexpected(&other)),
            }
        }
        Ok(entries)
    }

    /// The stored record's bytes.
    ///
    /// # Errors
    /// An unexpected reply or the line's error.
    pub fn record_bytes(&mut self) -> Result<[u8; RECORD_LEN], Failure> {
        let mut record = [0u8; RECORD_LEN];
        for part in 0..RECORD_PARTS {
            match self.request(&Request::ReadRecord { part })? {
                Response::RecordPart { part: got, bytes } if got == part => {
                    let start = usize::from(part) * RECORD_PART_LEN;
                    record[start..start + RECORD_PART_LEN].copy_from_slice(&bytes);
                }
                other => return Err(unexpected(&other)),
            }
        }
        Ok(record)
    }

    /// Stages `record` and proposes it; returns the machine's answer.
    ///
    /// # Errors
    /// An unexpected reply or the line's error.
    pub fn propose_record(&mut self, record: &[u8; RECORD_LEN]) -> Result<Response, Failure> {
        for part in 0..RECORD_PARTS {
            let start = usize::from(part) * RECORD_PART_LEN;
            let mut bytes = [0u8; RECORD_PART_LEN];
            bytes.copy_from_slice(&record[start..start + RECORD_PART_LEN]);
            match self.request(&Request::StageRecord { part, bytes })? {
                Response::Accepted => {}
                other => return Err(unexpected(&other)),
            }
        }
        self.request(&Request::CommitRecord)
    }
}

/// A reply the command did not expect, as a failure.
fn unexpected(reply: &Response) -> Failure {
    Failure::Message(format!("unexpected reply from the machine: {reply:?}"))
}

/// A line's error, as a failure.
fn link_error(error: &std::io::Error) -> Failure {
    Failure::Message(format!("the link failed: {error}"))
}

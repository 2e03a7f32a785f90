//! The twin on the link: the firmware's machine on the digital twin, served by the same
//! [`Server`] the firmware runs, behind a simulated serial line.
//!
//! # Theory of operation
//!
//! [`TwinLine`] owns a machine, a twin, a simulated flash and a simulated operator, and
//! steps them one 1 ms tick at a time exactly as [`taut_sim::bench::step`] does for every
//! other host run. After each tick it does what the firmware's link task does: hands the
//! server the bytes the line delivered in that millisecond, then lets it observe the tick
//! (samples, events). The line runs at the ST-LINK virtual COM port's 115 200 baud, 8N1:
//! [`LINE_BYTES_PER_MS`] bytes a millisecond each way, with a transmit queue of
//! [`TX_QUEUE`] bytes (the firmware's transmit ring, the same size) that drops frames when full. Time passes
//! only when the host reads ([`Line::read_some`]): the twin is a fake that owns time.
//!
//! The operator works a session: the machine is commissioned first (calibration, the
//! previous job's settings), then pulls `pulls` times, holding each for `hold_ms`.

use std::collections::VecDeque;

use taut_core::io::{Inputs, Outputs};
use taut_core::machine::Machine;
use taut_core::machine::access::LinkAccess;
use taut_core::store::{RECORD_LEN, Record};
use taut_link::message::BoardId;
use taut_link::{Server, Sink};
use taut_sim::bench::{Progress, SessionError, commission, factory_config, machine_for, step};
use taut_sim::operator::{Operator, Plan, previous_job};
use taut_sim::{StringKind, Twin, TwinConfig};

use super::Line;

pub use taut_link::{LINE_BYTES_PER_MS, TX_QUEUE};

/// The twin's board identity.
pub const TWIN_BOARD: BoardId = *b"taut-twin-01";

/// The host tool's version as the twin's firmware version.
#[must_use]
pub fn firmware_version() -> [u8; 3] {
    let mut parts = env!("CARGO_PKG_VERSION").split('.').map(|p| p.parse::<u8>().unwrap_or(0));
    [parts.next().unwrap_or(0), parts.next().unwrap_or(0), parts.next().unwrap_or(0)]
}

/// The machine's transmit queue.
#[derive(Debug, Default)]
struct TxQueue {
    bytes: VecDeque<u8>,
}

impl Sink for TxQueue {
    fn send(&mut self, frame: &[u8]) -> bool {
        if self.bytes.len() + frame.len() > TX_QUEUE {
            return false;
        }
        self.bytes.extend(frame);
        true
    }
}

/// What the operator does on the twin.
#[derive(Clone, Copy, Debug)]
pub struct Session {
    /// Pulls to make after power-up (0: the machine idles in Ready).
    pub pulls: u32,
    /// Hold of each pull, ms.
    pub hold_ms: u32,
}

/// The twin behind a simulated serial line (see the module docs).
pub struct TwinLine {
    machine: Machine,
    twin: Twin,
    flash: [u8; RECORD_LEN],
    server: Server,
    operator: Option<Operator>,
    plan: Plan,
    pulls_left: u32,
    to_machine: VecDeque<u8>,
    tx: TxQueue,
    to_host: VecDeque<u8>,
    last: (Inputs, Outputs),
}

impl TwinLine {
    /// A twin powered up from `flash`, with `session` to work.
    #[must_use]
    pub fn power_up(config: &TwinConfig, flash: &[u8; RECORD_LEN], session: Session) -> Self {
        let machine = machine_for(config, Record::decode(flash));
        let plan = Plan {
            calibrate: false,
            settings: previous_job(),
            knot_mode: false,
            pull_hold_ms: Some(session.hold_ms),
        };
        Self {
            machine,
            twin: Twin::new(config),
            flash: *flash,
            server: Server::new(TWIN_BOARD, firmware_version()),
            operator: (session.pulls > 0).then(|| Operator::new(plan)),
            plan,
            pulls_left: session.pulls,
            to_machine: VecDeque::new(),
            tx: TxQueue::default(),
            to_host: VecDeque::new(),
            last: (Inputs::default(), Outputs::default()),
        }
    }

    /// A nominal machine commissioned on its test string (calibrated, the previous job's
    /// settings stored), powered up again with `session` to work.
    ///
    /// # Errors
    /// The commissioning failed.
    pub fn commissioned(session: Session) -> Result<Self, SessionError> {
        let config = TwinConfig::nominal(StringKind::TennisSynthetic);
        let commissioning = commission(&factory_config(&config), true, &mut |_: &Progress<'_>| {})?;
        Ok(Self::power_up(&config, &commissioning.flash, session))
    }

    /// A nominal machine with a factory-fresh flash (the defaults), idle after power-up.
    #[must_use]
    pub fn factory_fresh() -> Self {
        let config = TwinConfig::nominal(StringKind::TennisSynthetic);
        Self::power_up(&config, &Record::default().encode(), Session { pulls: 0, hold_ms: 0 })
    }

    /// One 1 ms tick of the machine, the twin, the operator and the link.
    pub fn tick(&mut self) {
        let machine = &mut self.machine;
        let operator = &mut self.operator;
        let row = step(
            &mut self.twin,
            |inputs| machine.tick(inputs),
            |twin| {
                if let Some(operator) = operator.as_mut() {
                    operator.act(twin);
                }
            },
        );
        if row.outputs.store {
            self.flash = self.machine.record().encode();
        }
        self.last = (row.inputs, row.outputs);
        self.next_pull();
        // The link task: the millisecond's bytes in, then the tick observed.
        let take = self.to_machine.len().min(LINE_BYTES_PER_MS);
        let arrived: Vec<u8> = self.to_machine.drain(..take).collect();
        let mut access = LinkAccess::new(&mut self.machine);
        self.server.receive(&arrived, &mut access, &mut self.tx);
        self.server.observe(&row.inputs, &row.outputs, &access, &mut self.tx);
        let send = self.tx.bytes.len().min(LINE_BYTES_PER_MS);
        self.to_host.extend(self.tx.bytes.drain(..send));
    }

    /// Starts the next pull of the session once the operator finished one.
    fn next_pull(&mut self) {
        let finished = self.operator.as_ref().is_some_and(Operator::finished);
        if finished {
            self.pulls_left = self.pulls_left.saturating_sub(1);
            self.operator = (self.pulls_left > 0).then(|| Operator::at_ready(self.plan));
        }
    }

    /// Whether the operator's session is over.
    #[must_use]
    pub fn session_done(&self) -> bool {
        self.operator.is_none()
    }

    /// Bytes sent to the machine that the line has not delivered yet.
    #[must_use]
    pub fn pending_to_machine(&self) -> usize {
        self.to_machine.len()
    }

    /// The machine (for tests: what the panel would show).
    #[must_use]
    pub const fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The simulated flash.
    #[must_use]
    pub const fn flash(&self) -> &[u8; RECORD_LEN] {
        &self.flash
    }

    /// The twin.
    #[must_use]
    pub const fn twin(&self) -> &Twin {
        &self.twin
    }

    /// The inputs and outputs of the last tick.
    #[must_use]
    pub const fn last_tick(&self) -> &(Inputs, Outputs) {
        &self.last
    }
}

impl Line for TwinLine {
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.to_machine.extend(bytes);
        Ok(())
    }

    fn read_some(&mut self, buffer: &mut [u8], timeout_ms: u32) -> std::io::Result<usize> {
        for _ in 0..timeout_ms {
            if !self.to_host.is_empty() {
                break;
            }
            self.tick();
        }
        let count = self.to_host.len().min(buffer.len());
        for (slot, byte) in buffer.iter_mut().zip(self.to_host.drain(..count)) {
            *slot = byte;
        }
        Ok(count)
    }

    fn now_ms(&self) -> u64 {
        self.twin.now_ms()
    }
}

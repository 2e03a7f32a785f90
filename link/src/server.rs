//! The machine's side of the link: requests in, replies, samples and events out.
//!
//! # Theory of operation
//!
//! The board's binding (the firmware's link task, or the twin) owns a [`Server`] and calls
//!
//! - [`Server::receive`] with the bytes that arrived on the line: they are deframed, each
//!   complete request is answered ([`Server::respond`]) and the answer framed into the
//!   [`Sink`]; a frame that does not decode is answered with
//!   [`Refusal::BadFrame`](crate::message::Refusal::BadFrame);
//! - [`Server::observe`] after each machine tick, with that tick's inputs and outputs: while
//!   the host asked for a stream, a [`LiveSample`] every period, an [`Event`] at each state
//!   change, latched fault (with the inputs that latched it) and logged pull.
//!
//! Both take the machine only as a [`LinkAccess`], whose only write is a record proposal
//! that core accepts only while idle in Ready, so nothing here can move the machine
//! (REQ-LINK-02). Neither blocks: a sink that is full drops the message and the server
//! reports the count in the next [`Event::Dropped`] it can send. The work per call is
//! bounded by the bytes handed in (the binding hands in what the line delivered, at most a
//! DMA buffer).

use taut_core::io::{Inputs, Outputs};
use taut_core::machine::MachineState;
use taut_core::machine::access::{LinkAccess, WriteRefused};
use taut_core::store::{FORMAT_VERSION, RECORD_LEN, Record};

use crate::frame::{Deframer, MAX_FRAME, encode};
use crate::message::{
    BoardId, Command, Event, Faults, Identity, InputSnapshot, LOG_PAGE_ENTRIES, LiveSample,
    LogEntry, LogPage, Message, PROTOCOL_VERSION, RECORD_PART_LEN, RECORD_PARTS, Refusal, Request,
    Response, SAMPLE_PERIOD_MIN_MS, Status, WireSettings, WireState,
};

/// The line's rate, baud (8 data bits, no parity, one stop bit): the ST-LINK virtual COM
/// port's standard rate, which every host opens without configuration.
pub const BAUD: u32 = 115_200;

/// Bytes a millisecond the line carries each way at [`BAUD`], 8N1 (11.52, rounded down).
pub const LINE_BYTES_PER_MS: usize = 11;

/// The transmit queue a binding gives the server, bytes: six of the longest frames
/// ([`MAX_FRAME`]), so a log page, an event and a sample queued in one tick never wait for
/// each other, and 89 ms of the line at [`BAUD`] — the line, not the queue, bounds the rate.
/// A frame that finds no room is dropped and counted ([`Event::Dropped`]).
pub const TX_QUEUE: usize = 1_024;

/// Where the server's frames go: the line's transmit queue.
pub trait Sink {
    /// Queues one whole frame; `false` when there is no room (the frame is dropped).
    fn send(&mut self, frame: &[u8]) -> bool;
}

/// The machine's side of the link (see the module docs).
#[derive(Clone, Debug)]
pub struct Server {
    board: BoardId,
    firmware: [u8; 3],
    deframer: Deframer,
    staged: [u8; RECORD_LEN],
    staged_parts: u8,
    period_ms: u16,
    last_sample_ms: Option<u32>,
    last_state: Option<MachineState>,
    last_pulls: Option<u32>,
    dropped: u16,
}

impl Server {
    /// A server for board `board` running firmware `firmware` (major, minor, patch).
    #[must_use]
    pub const fn new(board: BoardId, firmware: [u8; 3]) -> Self {
        Self {
            board,
            firmware,
            deframer: Deframer::new(),
            staged: [0; RECORD_LEN],
            staged_parts: 0,
            period_ms: 0,
            last_sample_ms: None,
            last_state: None,
            last_pulls: None,
            dropped: 0,
        }
    }

    /// The sample period the host asked for, ms (0: not streaming).
    #[must_use]
    pub const fn period_ms(&self) -> u16 {
        self.period_ms
    }

    /// Takes `bytes` from the line; answers every request they complete.
    pub fn receive<const LOG: usize>(
        &mut self,
        bytes: &[u8],
        machine: &mut LinkAccess<'_, LOG>,
        sink: &mut impl Sink,
    ) {
        for &byte in bytes {
            let (reply_to, response) = match self.deframer.push::<Command>(byte) {
                None => continue,
                Some(Ok(command)) => (Some(command.seq), self.respond(&command.request, machine)),
                Some(Err(_)) => (None, Response::Refused(Refusal::BadFrame)),
            };
            self.send(&Message { reply_to, response }, sink);
        }
    }

    /// The answer to `request` (the only place a request acts).
    pub fn respond<const LOG: usize>(
        &mut self,
        request: &Request,
        machine: &mut LinkAccess<'_, LOG>,
    ) -> Response {
        let record = *machine.record();
        match *request {
            Request::Hello => Response::Identity(Identity {
                protocol: PROTOCOL_VERSION,
                firmware: self.firmware,
                board: self.board,
                record_format: FORMAT_VERSION,
                boots: record.counters.boots,
                pulls: record.counters.pulls,
                calibrated: record.calibration.is_some(),
                calibration_age_pulls: record.calibration_age(),
            }),
            Request::ReadLog { page } => Self::log_page(page, machine),
            Request::ReadStatus => Response::Status(Status {
                state: machine.state().into(),
                pulls: record.counters.pulls,
                string_used_mm: record.counters.string_used_mm,
                boots: record.counters.boots,
                settings: record.settings.into(),
                preferences: record.preferences.into(),
            }),
            Request::ReadPreset { index } => match record.presets.get(usize::from(index)) {
                Some(preset) => Response::Preset { index, settings: (*preset).into() },
                None => Response::Refused(Refusal::OutOfRange),
            },
            Request::ReadRecord { part } => {
                let bytes = record.encode();
                match part_range(part).and_then(|range| bytes.get(range)) {
                    Some(slice) => {
                        let mut part_bytes = [0u8; RECORD_PART_LEN];
                        part_bytes.copy_from_slice(slice);
                        Response::RecordPart { part, bytes: part_bytes }
                    }
                    None => Response::Refused(Refusal::OutOfRange),
                }
            }
            Request::ReadFaults => Response::Faults(Faults {
                latched: match machine.state() {
                    MachineState::Fault(code) => Some(code.number()),
                    _ => None,
                },
                history: machine.fault_history().map(|code| code.map(|c| c.number())),
            }),
            Request::Stream { period_ms } => {
                self.period_ms =
                    if period_ms == 0 { 0 } else { period_ms.max(SAMPLE_PERIOD_MIN_MS) };
                self.last_sample_ms = None;
                Response::Accepted
            }
            Request::WriteSettings { settings, preferences } => match settings.to_settings() {
                Ok(settings) => Self::propose(
                    machine,
                    &Record { settings, preferences: preferences.into(), ..record },
                ),
                Err(error) => Response::Refused(Refusal::Settings(error)),
            },
            Request::WritePreset { index, settings } => {
                Self::write_preset(machine, record, index, settings)
            }
            Request::StageRecord { part, bytes } => {
                match part_range(part).and_then(|range| self.staged.get_mut(range)) {
                    Some(slot) => {
                        slot.copy_from_slice(&bytes);
                        self.staged_parts |= 1u8.checked_shl(u32::from(part)).unwrap_or(0);
                        Response::Accepted
                    }
                    None => Response::Refused(Refusal::OutOfRange),
                }
            }
            Request::CommitRecord => {
                let complete = self.staged_parts == (1u8 << RECORD_PARTS).wrapping_sub(1);
                self.staged_parts = 0;
                match Record::decode(&self.staged) {
                    Ok(staged) if complete => Self::propose(machine, &staged),
                    _ => Response::Refused(Refusal::InvalidRecord),
                }
            }
        }
    }

    /// After each machine tick: samples and events while streaming (see the module docs).
    pub fn observe<const LOG: usize>(
        &mut self,
        inputs: &Inputs,
        outputs: &Outputs,
        machine: &LinkAccess<'_, LOG>,
        sink: &mut impl Sink,
    ) {
        let state = machine.state();
        let pulls = machine.record().counters.pulls;
        let previous_state = self.last_state.replace(state);
        let previous_pulls = self.last_pulls.replace(pulls);
        if self.period_ms == 0 {
            return;
        }
        if self.dropped > 0 {
            let count = core::mem::take(&mut self.dropped);
            self.notify(Response::Event(Event::Dropped { count }), sink);
        }
        if let Some(from) = previous_state.filter(|from| *from != state) {
            let time_ms = inputs.now_ms;
            let change = Event::State { time_ms, from: from.into(), to: state.into() };
            self.notify(Response::Event(change), sink);
            if let MachineState::Fault(code) = state {
                let snapshot = InputSnapshot {
                    load_cell_code: inputs.load_cell.get(),
                    motor_current_code: inputs.motor_current.get(),
                    bus_voltage_code: inputs.bus_voltage.get(),
                    carriage_steps: inputs.drive.steps,
                    current_milli_amps: inputs.drive.current.to_milli(),
                    bus_milli_volts: inputs.drive.bus.to_milli(),
                    home_limit: inputs.limits.home,
                    end_limit: inputs.limits.end,
                    drive_fault: inputs.drive.fault.is_some(),
                };
                let fault = Event::Fault { time_ms, code: code.number(), inputs: snapshot };
                self.notify(Response::Event(fault), sink);
            }
        }
        if previous_pulls.is_some_and(|before| before != pulls) {
            if let Some(last) = machine.log().last() {
                let entry = LogEntry::from_record(pulls, last);
                self.notify(Response::Event(Event::Logged(entry)), sink);
            }
        }
        let due = self
            .last_sample_ms
            .is_none_or(|last| inputs.now_ms.wrapping_sub(last) >= u32::from(self.period_ms));
        if due {
            self.last_sample_ms = Some(inputs.now_ms);
            // The tick's figures only when a sample is due (not every tick).
            let figures = machine.figures(inputs, outputs);
            let sample = LiveSample {
                time_ms: figures.now_ms,
                state: WireState::from(state),
                target_milli_kgf: figures.target.to_milli(),
                tension_milli_kgf: figures.tension.to_milli(),
                carriage_steps: figures.carriage_steps,
                duty_raw: figures.duty_raw,
                current_milli_amps: figures.current.to_milli(),
                bus_milli_volts: figures.bus.to_milli(),
            };
            self.notify(Response::Sample(sample), sink);
        }
    }

    /// Frames `message` into `sink`, counting it when it cannot be sent.
    fn send(&mut self, message: &Message, sink: &mut impl Sink) {
        let mut frame = [0u8; MAX_FRAME];
        let sent = match encode(message, &mut frame) {
            Ok(len) => frame.get(..len).is_some_and(|bytes| sink.send(bytes)),
            Err(_) => false,
        };
        if !sent {
            self.dropped = self.dropped.saturating_add(1);
        }
    }

    /// Sends a sample or an event (a message that answers no command).
    fn notify(&mut self, response: Response, sink: &mut impl Sink) {
        self.send(&Message { reply_to: None, response }, sink);
    }

    /// Page `page` of the log, latest first.
    fn log_page<const LOG: usize>(page: u8, machine: &LinkAccess<'_, LOG>) -> Response {
        let log = machine.log();
        let first = usize::from(page).saturating_mul(LOG_PAGE_ENTRIES);
        if page > 0 && first >= log.len() {
            return Response::Refused(Refusal::OutOfRange);
        }
        let pulls = machine.record().counters.pulls;
        let mut entries = [None; LOG_PAGE_ENTRIES];
        for (offset, slot) in entries.iter_mut().enumerate() {
            let back = first.saturating_add(offset);
            *slot = log.back(back).map(|record| {
                let number = pulls.saturating_sub(u32::try_from(back).unwrap_or(u32::MAX));
                LogEntry::from_record(number, record)
            });
        }
        let total = u8::try_from(log.len()).unwrap_or(u8::MAX);
        Response::LogPage(LogPage { page, total, entries })
    }

    /// Proposes `record` with preset `index` replaced by `settings`.
    fn write_preset<const LOG: usize>(
        machine: &mut LinkAccess<'_, LOG>,
        mut record: Record,
        index: u8,
        settings: WireSettings,
    ) -> Response {
        let settings = match settings.to_settings() {
            Ok(settings) => settings,
            Err(error) => return Response::Refused(Refusal::Settings(error)),
        };
        match record.presets.get_mut(usize::from(index)) {
            Some(slot) => *slot = settings,
            None => return Response::Refused(Refusal::OutOfRange),
        }
        Self::propose(machine, &record)
    }

    /// Proposes `record` to the machine.
    fn propose<const LOG: usize>(machine: &mut LinkAccess<'_, LOG>, record: &Record) -> Response {
        match machine.propose_record(record) {
            Ok(()) => Response::Accepted,
            Err(WriteRefused::NotIdle) => Response::Refused(Refusal::NotIdle),
            Err(WriteRefused::InvalidSettings) => Response::Refused(Refusal::InvalidRecord),
            Err(WriteRefused::InvalidCalibration) => Response::Refused(Refusal::InvalidCalibration),
        }
    }
}

/// The byte range of record part `part`, if there is one.
fn part_range(part: u8) -> Option<core::ops::Range<usize>> {
    if part >= RECORD_PARTS {
        return None;
    }
    let start = usize::from(part).saturating_mul(RECORD_PART_LEN);
    Some(start..start.saturating_add(RECORD_PART_LEN))
}

#[cfg(test)]
#[allow(
    clippy::indexing_slicing,
    clippy::panic,
    reason = "unit tests: an index or a panic is how a test fails"
)]
mod tests {
    use super::*;
    use crate::frame::{Deframer, encode};
    use taut_core::io::LimitSwitches;
    use taut_core::machine::{Checkpoint, FaultCode, Machine};
    use taut_core::settings::{SetPoint, Settings, Unit};

    /// A sink that keeps every frame, or refuses them all.
    #[derive(Default)]
    struct Line {
        frames: std::vec::Vec<std::vec::Vec<u8>>,
        full: bool,
    }

    extern crate std;

    impl Sink for Line {
        fn send(&mut self, frame: &[u8]) -> bool {
            if self.full {
                return false;
            }
            self.frames.push(frame.to_vec());
            true
        }
    }

    impl Line {
        /// Every message sent, decoded.
        fn messages(&self) -> std::vec::Vec<Message> {
            let mut deframer = Deframer::new();
            let mut out = std::vec::Vec::new();
            for byte in self.frames.iter().flatten() {
                if let Some(Ok(message)) = deframer.push::<Message>(*byte) {
                    out.push(message);
                }
            }
            out
        }
    }

    fn ready() -> Machine {
        Machine::resume(
            Record::default(),
            &Checkpoint::at(MachineState::Ready),
            &taut_core::board::paper().expect("the paper's board"),
        )
    }

    fn settings_30kg() -> Settings {
        match SetPoint::new(Unit::Kilograms, 300).and_then(|p| Settings::new(p, 7, 10, 5)) {
            Ok(settings) => settings,
            Err(error) => panic!("valid settings: {error:?}"),
        }
    }

    /// The stream's period: as asked, raised to the shortest, and 0 to stop.
    #[test]
    fn the_stream_period_is_what_the_host_asked_within_the_shortest() {
        let mut machine = ready();
        let mut access = LinkAccess::new(&mut machine);
        let mut server = Server::new([0; 12], [0, 1, 0]);
        assert_eq!(server.period_ms(), 0, "not streaming until asked");
        for (asked, period) in [(100, 100), (5, SAMPLE_PERIOD_MIN_MS), (0, 0), (20, 20)] {
            let response = server.respond(&Request::Stream { period_ms: asked }, &mut access);
            assert_eq!(response, Response::Accepted);
            assert_eq!(server.period_ms(), period, "asked {asked} ms");
        }
    }

    /// Bytes in: a framed request is answered to its number, garbage is refused as a bad
    /// frame.
    #[test]
    fn received_frames_are_answered_and_garbage_refused() {
        let mut machine = ready();
        let mut server = Server::new([7; 12], [1, 2, 3]);
        let mut line = Line::default();
        let mut frame = [0u8; MAX_FRAME];
        let len = encode(&Command { seq: 9, request: Request::Hello }, &mut frame).unwrap_or(0);
        let mut bytes = std::vec![3u8, 1, 0];
        bytes.extend_from_slice(&frame[..len]);
        server.receive(&bytes, &mut LinkAccess::new(&mut machine), &mut line);
        let messages = line.messages();
        assert_eq!(messages.len(), 2, "{messages:?}");
        assert_eq!(messages[0].response, Response::Refused(Refusal::BadFrame));
        assert_eq!(messages[1].reply_to, Some(9));
        let Response::Identity(identity) = messages[1].response else {
            panic!("{:?}", messages[1]);
        };
        assert_eq!((identity.board, identity.firmware), ([7; 12], [1, 2, 3]));
    }

    /// While streaming: samples at the period, a state change and a latched fault as events;
    /// a frame the line could not take is counted and reported once there is room.
    #[test]
    fn observing_streams_samples_events_and_what_was_dropped() {
        let mut machine = ready();
        let mut server = Server::new([0; 12], [0, 1, 0]);
        let mut line = Line::default();
        let inputs = |now_ms| Inputs { now_ms, ..Inputs::default() };
        let outputs = Outputs::default();
        // Not streaming: nothing is sent.
        server.observe(&inputs(1), &outputs, &LinkAccess::new(&mut machine), &mut line);
        assert!(line.frames.is_empty());
        let _ =
            server.respond(&Request::Stream { period_ms: 20 }, &mut LinkAccess::new(&mut machine));
        for now in 2..=42 {
            server.observe(&inputs(now), &outputs, &LinkAccess::new(&mut machine), &mut line);
        }
        let times: std::vec::Vec<u32> = line
            .messages()
            .iter()
            .filter_map(|m| match m.response {
                Response::Sample(sample) => Some(sample.time_ms),
                _ => None,
            })
            .collect();
        assert_eq!(times, [2, 22, 42], "a sample every 20 ms, the first at once");
        // A fault: the state change and the fault with its inputs.
        let both = LimitSwitches { home: true, end: true };
        let latching = Inputs { now_ms: 43, limits: both, ..Inputs::default() };
        let _ = machine.tick(&latching);
        line.frames.clear();
        server.observe(&latching, &outputs, &LinkAccess::new(&mut machine), &mut line);
        let events: std::vec::Vec<Event> = line
            .messages()
            .iter()
            .filter_map(|m| if let Response::Event(e) = m.response { Some(e) } else { None })
            .collect();
        assert!(
            matches!(events[0], Event::State { time_ms: 43, to: WireState::Fault(_), .. }),
            "{events:?}"
        );
        let Event::Fault { code, inputs: snapshot, .. } = events[1] else { panic!("{events:?}") };
        assert_eq!(code, FaultCode::LimitsBoth.number());
        assert!(snapshot.home_limit && snapshot.end_limit);
        // A full line: the sample is dropped and counted, then reported.
        line.full = true;
        server.observe(&inputs(70), &outputs, &LinkAccess::new(&mut machine), &mut line);
        line.full = false;
        server.observe(&inputs(71), &outputs, &LinkAccess::new(&mut machine), &mut line);
        let dropped = line
            .messages()
            .iter()
            .any(|m| m.response == Response::Event(Event::Dropped { count: 1 }));
        assert!(dropped, "{:?}", line.messages());
    }

    /// The fault latched now is read as such; outside a fault none is.
    #[test]
    fn the_latched_fault_is_read() {
        let mut faulted: Machine = Machine::resume(
            Record::default(),
            &Checkpoint::at(MachineState::Fault(FaultCode::LimitsBoth)),
            &taut_core::board::paper().expect("the paper's board"),
        );
        let mut server = Server::new([0; 12], [0, 1, 0]);
        let Response::Faults(faults) =
            server.respond(&Request::ReadFaults, &mut LinkAccess::new(&mut faulted))
        else {
            panic!("no faults reply")
        };
        assert_eq!(faults.latched, Some(FaultCode::LimitsBoth.number()));
        let mut machine = ready();
        let Response::Faults(faults) =
            server.respond(&Request::ReadFaults, &mut LinkAccess::new(&mut machine))
        else {
            panic!("no faults reply")
        };
        assert_eq!(faults.latched, None);
    }

    /// The log's pages: the first always (empty or not), a page past the log refused.
    #[test]
    fn log_pages_past_the_log_are_refused() {
        let mut machine = ready();
        let mut server = Server::new([0; 12], [0, 1, 0]);
        let mut access = LinkAccess::new(&mut machine);
        let Response::LogPage(page) = server.respond(&Request::ReadLog { page: 0 }, &mut access)
        else {
            panic!("page 0 of an empty log")
        };
        assert_eq!((page.page, page.total), (0, 0));
        assert!(page.entries.iter().all(Option::is_none));
        assert_eq!(
            server.respond(&Request::ReadLog { page: 1 }, &mut access),
            Response::Refused(Refusal::OutOfRange)
        );
    }

    /// Settings written in Ready are the machine's, with the preferences.
    #[test]
    fn settings_written_in_ready_are_taken_with_the_preferences() {
        let mut machine = ready();
        let mut server = Server::new([0; 12], [0, 1, 0]);
        let preferences = crate::message::WirePreferences { beeper: false, constant_pull: true };
        let request = Request::WriteSettings { settings: settings_30kg().into(), preferences };
        assert_eq!(
            server.respond(&request, &mut LinkAccess::new(&mut machine)),
            Response::Accepted
        );
        assert_eq!(machine.record().settings, settings_30kg());
        assert!(machine.record().preferences.constant_pull);
        assert!(!machine.record().preferences.beeper);
    }

    /// A record is restored only once every part is staged since the last commit; each part
    /// is the stored record's own bytes, and a part past the record is refused.
    #[test]
    fn a_record_is_committed_only_whole() {
        let mut source = Record { settings: settings_30kg(), ..Record::default() };
        source.counters.pulls = 5;
        let mut from: Machine = Machine::resume(
            source,
            &Checkpoint::at(MachineState::Ready),
            &taut_core::board::paper().expect("the paper's board"),
        );
        let mut server = Server::new([0; 12], [0, 1, 0]);
        let mut parts = std::vec::Vec::new();
        for part in 0..RECORD_PARTS {
            let Response::RecordPart { bytes, .. } =
                server.respond(&Request::ReadRecord { part }, &mut LinkAccess::new(&mut from))
            else {
                panic!("part {part}")
            };
            parts.push(bytes);
        }
        assert_eq!(
            server.respond(
                &Request::ReadRecord { part: RECORD_PARTS },
                &mut LinkAccess::new(&mut from)
            ),
            Response::Refused(Refusal::OutOfRange)
        );
        let encoded: std::vec::Vec<u8> = parts.iter().flatten().copied().collect();
        assert_eq!(encoded[..], source.encode()[..]);
        let mut to = ready();
        let mut access = LinkAccess::new(&mut to);
        // Every part but the last: refused, and the staging starts afresh.
        for (part, bytes) in (0..).zip(&parts).take(parts.len() - 1) {
            let stage = Request::StageRecord { part, bytes: *bytes };
            assert_eq!(server.respond(&stage, &mut access), Response::Accepted);
        }
        assert_eq!(
            server.respond(&Request::CommitRecord, &mut access),
            Response::Refused(Refusal::InvalidRecord)
        );
        for (part, bytes) in (0..).zip(&parts) {
            let stage = Request::StageRecord { part, bytes: *bytes };
            assert_eq!(server.respond(&stage, &mut access), Response::Accepted);
        }
        assert_eq!(server.respond(&Request::CommitRecord, &mut access), Response::Accepted);
        // After a commit the staging starts afresh: every part but one again (the staged bytes
        // still hold the whole record) is refused.
        for (part, bytes) in (0..).zip(&parts).skip(1) {
            let stage = Request::StageRecord { part, bytes: *bytes };
            assert_eq!(server.respond(&stage, &mut access), Response::Accepted);
        }
        assert_eq!(
            server.respond(&Request::CommitRecord, &mut access),
            Response::Refused(Refusal::InvalidRecord)
        );
        assert_eq!(to.record().settings, settings_30kg());
        assert_eq!(to.record().counters.pulls, 0, "the machine's own counters");
        let stage = Request::StageRecord { part: RECORD_PARTS, bytes: parts[0] };
        assert_eq!(
            server.respond(&stage, &mut LinkAccess::new(&mut to)),
            Response::Refused(Refusal::OutOfRange)
        );
    }
}

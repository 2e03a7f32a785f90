//! The machine link's properties (REQ-LINK-01, REQ-LINK-02): the frame decoder is total,
//! and no frame moves the machine.
//!
//! # The properties
//!
//! - [`decoding_is_total`]: for any bytes, [`taut_link::decode`] returns a request or a
//!   typed [`taut_link::FrameError`]; a request it returns re-encodes to a frame that decodes
//!   to the same request; a [`Deframer`] fed the bytes as a stream never holds more than one
//!   frame's bytes.
//! - [`serving_never_moves`]: a machine in any state, served any requests and any garbage,
//!   stays in its state; outside Ready its record is unchanged too, and in every state the
//!   ticks after it command exactly what an unserved twin of the machine commands (the
//!   served and unserved machines differ at most in a record accepted in Ready: its settings
//!   and the panel's return to the tension page).
//!
//! The message layer of [`decoding_is_total`] (postcard on any short payload) is a Kani
//! harness; the frame layer (COBS and the CRC over a 162-byte body) did not verify within the
//! two-minute budget of a harness and is checked by the tests and the fuzzer only. The
//! no-motion rule's Kani harnesses take a machine at any valid checkpoint of a state kind
//! (`crate::machine`'s compositional set-up), any request of any kind with any field values,
//! and check that answering it leaves the state (and, outside Ready, the record) as it was; the
//! record's codec and the calibration fit are over-approximated by any value. Both bodies run
//! in `proofs/tests/link.rs` (every state kind × every request kind, then ticks compared with an
//! unserved copy; truncations and bit flips of real frames; proptest) and in the `link_frame`
//! fuzz target ([`check_input`]).

use taut_core::io::{Inputs, Outputs};
use taut_core::machine::access::LinkAccess;
use taut_core::machine::{Checkpoint, Machine, MachineState};
use taut_core::store::Record;
use taut_core::units::AdcCode;
use taut_link::frame::{Deframer, MAX_FRAME, take_message};
use taut_link::message::{Command, Request};
use taut_link::server::{Server, Sink};

/// A sink that accepts and forgets every frame, counting them.
#[derive(Clone, Copy, Default, Debug)]
pub struct CountingSink {
    /// Frames sent.
    pub frames: u32,
}

impl Sink for CountingSink {
    fn send(&mut self, frame: &[u8]) -> bool {
        assert!(frame.len() <= MAX_FRAME, "REQ-LINK-01: a frame longer than MAX_FRAME");
        self.frames = self.frames.saturating_add(1);
        true
    }
}

/// REQ-LINK-01: decoding `bytes` (one frame without its delimiter, and the same bytes as a
/// stream) is total and canonical.
pub fn decoding_is_total(bytes: &[u8]) {
    if let Ok(command) = taut_link::decode::<Command>(bytes) {
        let mut frame = [0u8; MAX_FRAME];
        let Ok(len) = taut_link::encode(&command, &mut frame) else {
            panic!("REQ-LINK-01: a decoded request does not re-encode");
        };
        let body = frame.get(..len.saturating_sub(1)).unwrap_or(&[]);
        assert!(
            taut_link::decode::<Command>(body) == Ok(command),
            "REQ-LINK-01: a request's frame decodes to another request"
        );
    }
    let mut deframer = Deframer::new();
    for &byte in bytes {
        let _ = deframer.push::<Command>(byte);
        assert!(deframer.pending() <= MAX_FRAME, "REQ-LINK-01: the deframer outgrew a frame");
    }
}

/// The inputs of tick `t` after serving: the machine at rest, unloaded, at home.
fn quiet_inputs(t: u32) -> Inputs {
    Inputs {
        now_ms: t,
        load_cell: AdcCode::new(41),
        limits: taut_core::io::LimitSwitches { home: true, end: false },
        ..Inputs::default()
    }
}

/// Frames every request of `requests` into one byte stream, `garbage` before each.
fn stream(requests: &[Request], garbage: &[u8], out: &mut [u8]) -> usize {
    let mut len = 0usize;
    for (seq, request) in (0u16..).zip(requests) {
        for &byte in garbage {
            if let Some(slot) = out.get_mut(len) {
                *slot = byte;
                len = len.saturating_add(1);
            }
        }
        // A delimiter ends the garbage so the request starts a frame of its own.
        if let Some(slot) = out.get_mut(len) {
            *slot = 0;
            len = len.saturating_add(1);
        }
        let mut frame = [0u8; MAX_FRAME];
        let command = Command { seq, request: *request };
        if let Ok(frame_len) = taut_link::encode(&command, &mut frame) {
            for &byte in frame.get(..frame_len).unwrap_or(&[]) {
                if let Some(slot) = out.get_mut(len) {
                    *slot = byte;
                    len = len.saturating_add(1);
                }
            }
        }
    }
    len
}

/// REQ-LINK-02: serving `requests` (each after `garbage`) to a machine at `checkpoint`
/// moves nothing (see the module docs); `ticks` ticks after it are compared.
pub fn serving_never_moves(
    record: Record,
    checkpoint: &Checkpoint,
    requests: &[Request],
    garbage: &[u8],
    ticks: u32,
) {
    let Some(board) = crate::paper_board() else { return };
    let mut served: Machine = Machine::resume(record, checkpoint, &board);
    let mut unserved = served.clone();
    let before = served.state();
    let mut bytes = [0u8; 4_096];
    let len = stream(requests, garbage, &mut bytes);
    let mut server = Server::new([0; 12], [0, 1, 0]);
    let mut sink = CountingSink::default();
    server.receive(bytes.get(..len).unwrap_or(&[]), &mut LinkAccess::new(&mut served), &mut sink);
    assert!(served.state() == before, "REQ-LINK-02: a frame changed the machine's state");
    let idle = before == MachineState::Ready;
    if !idle {
        assert!(
            served.record() == unserved.record(),
            "REQ-LINK-02: a frame changed the record outside Ready"
        );
    }
    for t in 1..=ticks {
        let inputs = quiet_inputs(t);
        let a: Outputs = served.tick(&inputs);
        let b: Outputs = unserved.tick(&inputs);
        assert!(a.drive == b.drive, "REQ-LINK-02: a frame changed a drive command");
        assert!(
            a.clear_drive_fault == b.clear_drive_fault,
            "REQ-LINK-02: a frame cleared a drive fault"
        );
        assert!(served.state() == unserved.state(), "REQ-LINK-02: a frame changed a transition");
        if !idle {
            assert!(a == b, "REQ-LINK-02: a frame changed the outputs outside Ready");
        }
    }
}

/// The requests drawn from `bytes` (postcard payloads back to back), at most `N`.
pub fn requests_from<const N: usize>(mut bytes: &[u8]) -> ([Option<Request>; N], usize) {
    let mut requests = [None; N];
    let mut count = 0usize;
    for slot in &mut requests {
        match take_message::<Request>(bytes) {
            Ok((request, rest)) => {
                *slot = Some(request);
                count = count.saturating_add(1);
                bytes = rest;
            }
            Err(_) => break,
        }
    }
    (requests, count)
}

/// The fuzz target's oracle: the first byte picks the machine's state kind, the next one
/// how many garbage bytes precede each request; the rest is the garbage and the requests'
/// payloads. Both properties run.
pub fn check_input(data: &[u8]) {
    decoding_is_total(data);
    let (selector, rest) = data.split_first().unwrap_or((&0, &[]));
    let (garbage_len, rest) = rest.split_first().unwrap_or((&0, &[]));
    let kinds = MachineState::KINDS;
    let kind = kinds.get(usize::from(*selector).checked_rem(kinds.len()).unwrap_or(0)).copied();
    let split = usize::from(*garbage_len & 31).min(rest.len());
    let (garbage, payloads) = rest.split_at(split);
    let (requests, count) = requests_from::<8>(payloads);
    let mut list = [Request::Hello; 8];
    for (slot, request) in list.iter_mut().zip(requests.iter().flatten()) {
        *slot = *request;
    }
    if let Some(state) = kind {
        let requests = list.get(..count).unwrap_or(&[]);
        serving_never_moves(Record::default(), &Checkpoint::at(state), requests, garbage, 20);
    }
}

#[cfg(kani)]
mod verification {
    use super::*;
    use crate::machine::verification::checkpoint_in;
    use taut_core::sense::calibration::{Calibration, CalibrationError, CalibrationPoints};
    use taut_core::store::{RECORD_LEN, StoreError};
    use taut_link::message::{RECORD_PART_LEN, WirePreferences, WireSettings, WireUnit};

    /// REQ-LINK-01, the message layer: any payload of up to 6 bytes is a command or a typed
    /// error.
    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_link_frame_decoding_is_total() {
        let bytes: [u8; 6] = kani::any();
        let len: usize = kani::any();
        kani::assume(len <= bytes.len());
        let _ = take_message::<Command>(bytes.get(..len).unwrap_or(&[]));
        crate::harness_end_reached();
    }

    /// Any settings as the wire carries them (valid or not).
    fn any_settings() -> WireSettings {
        WireSettings {
            unit: if kani::any() { WireUnit::Kilograms } else { WireUnit::Pounds },
            tension_tenths: kani::any(),
            speed: kani::any(),
            pre_stretch_percent: kani::any(),
            knot_percent: kani::any(),
        }
    }

    /// Any request of every kind, with any fields.
    fn any_request() -> Request {
        match kani::any::<u8>() {
            0 => Request::Hello,
            1 => Request::ReadLog { page: kani::any() },
            2 => Request::ReadStatus,
            3 => Request::ReadPreset { index: kani::any() },
            4 => Request::ReadRecord { part: kani::any() },
            5 => Request::ReadFaults,
            6 => Request::Stream { period_ms: kani::any() },
            7 => Request::WriteSettings {
                settings: any_settings(),
                preferences: WirePreferences { beeper: kani::any(), constant_pull: kani::any() },
            },
            8 => Request::WritePreset { index: kani::any(), settings: any_settings() },
            9 => Request::StageRecord { part: kani::any(), bytes: [kani::any(); RECORD_PART_LEN] },
            _ => Request::CommitRecord,
        }
    }

    /// The record's encoding, over-approximated: any bytes (a read; no property reads them).
    fn any_record_bytes(_record: &Record) -> [u8; RECORD_LEN] {
        [kani::any(); RECORD_LEN]
    }

    /// Decoding a staged record, over-approximated: refused, or the default record (a valid
    /// record; what matters is that it is proposed, and the proposal is what is checked).
    fn any_decoded(_bytes: &[u8]) -> Result<Record, StoreError> {
        if kani::any() { Ok(Record::default()) } else { Err(StoreError::CrcMismatch) }
    }

    /// The calibration fit of a proposed record, over-approximated: accepted or rejected.
    fn any_calibration_fit(_points: &CalibrationPoints) -> Result<Calibration, CalibrationError> {
        if kani::any() { Ok(Calibration::IDENTITY) } else { Err(CalibrationError::PointOffLine) }
    }

    /// REQ-LINK-02 for one state kind: any request, answered by the server, leaves a machine
    /// at any valid checkpoint of `state` in that state with its record unchanged (outside
    /// Ready: the server's one write, a record proposal, is refused there); in Ready the
    /// machine stays in Ready. Every request kind with every field value; the record's codec
    /// and the calibration fit are over-approximated (they are `crate::machine_store`'s and
    /// core's own tests'), which makes the proof hold for any record they could produce.
    fn serving_any_request_never_moves(state: MachineState) {
        let checkpoint = checkpoint_in(state);
        // The paper's board; that it builds is checked here too (a panic fails the harness).
        let board = crate::paper_board().expect("the paper's board builds");
        let mut machine = Machine::<1>::resume(Record::default(), &checkpoint, &board);
        let (state_before, record_before) = (machine.state(), *machine.record());
        let mut server = Server::new([0; 12], [0, 1, 0]);
        let request = any_request();
        let _ = server.respond(&request, &mut LinkAccess::new(&mut machine));
        assert!(machine.state() == state_before, "REQ-LINK-02: a request changed the state");
        if state_before != MachineState::Ready {
            assert!(
                *machine.record() == record_before,
                "REQ-LINK-02: a request changed the record outside Ready"
            );
        }
    }

    macro_rules! no_motion {
        ($(#[$doc:meta])* fn $name:ident = $state:expr) => {
            $(#[$doc])*
            #[kani::proof]
            #[kani::unwind(10)]
            #[kani::stub(taut_core::store::Record::encode, any_record_bytes)]
            #[kani::stub(taut_core::store::Record::decode, any_decoded)]
            #[kani::stub(taut_core::sense::calibration::Calibration::new, any_calibration_fit)]
            fn $name() {
                serving_any_request_never_moves($state);
                crate::harness_end_reached();
            }
        };
    }

    no_motion!(
        /// REQ-LINK-02 while the machine pulls.
        fn verify_link_never_moves_a_pulling_machine = MachineState::Pulling
    );
    no_motion!(
        /// REQ-LINK-02 while the machine holds.
        fn verify_link_never_moves_a_holding_machine = MachineState::Holding
    );
    no_motion!(
        /// REQ-LINK-02 while the machine releases.
        fn verify_link_never_moves_a_releasing_machine = MachineState::Releasing
    );
    no_motion!(
        /// REQ-LINK-02 in Ready: the state stays Ready (a proposed record may be taken).
        fn verify_link_keeps_a_ready_machine_ready = MachineState::Ready
    );
}

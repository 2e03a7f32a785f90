//! The PC's side of the machine link on the bench: `taut-link`'s own codec on the emulated
//! USART2, working the image's server during the machine cycle.
//!
//! [`Host`] frames commands onto the bench's [`Line`] and decodes what comes back;
//! [`Traffic`] is what the PC does during the job: it says hello and asks for the live stream
//! as the job starts, then, while the machine pulls and holds, keeps the line busy both
//! ways — every kind of read, a settings write (which the machine must refuse while it pulls),
//! random garbage, cut frames and runs of zero bytes (a line held low) between them — and reads the log and the counters once the
//! machine is idle again. [`Traffic::verdict`] checks what came back: every frame intact,
//! every request answered, the write refused, the stream and events present, the log's last
//! pull the counters' last.

use taut_link::message::{
    BoardId, Event, LiveSample, Refusal, Request, Response, WirePreferences, WireSettings,
    WireState,
};
use taut_link::{Deframer, MAX_FRAME, Message, PROTOCOL_VERSION, encode};

use crate::bench::Line;

/// The PC's end of the link: commands out, messages in.
#[derive(Debug, Default)]
pub struct Host {
    seq: u16,
    deframer: Deframer,
    /// Bytes read from the line so far.
    pub read: usize,
    /// Replies: (the command's number, the response).
    pub replies: Vec<(u16, Response)>,
    /// Live samples.
    pub samples: Vec<LiveSample>,
    /// Events.
    pub events: Vec<Event>,
    /// Frames from the machine that did not decode.
    pub corrupt: u64,
    /// Refusals of frames that did not decode (answers to garbage).
    pub bad_frames: u64,
}

impl Host {
    /// Sends `request`; its number.
    pub fn send(&mut self, line: &mut Line, request: Request) -> u16 {
        self.seq = self.seq.wrapping_add(1);
        let mut frame = [0u8; MAX_FRAME];
        if let Ok(len) = encode(&taut_link::Command { seq: self.seq, request }, &mut frame) {
            line.to_machine.extend(&frame[..len]);
        }
        self.seq
    }

    /// Reads what the machine sent since the last call.
    pub fn poll(&mut self, line: &mut Line) {
        let bytes = line.from_machine.get(self.read..).unwrap_or(&[]).to_vec();
        self.read += bytes.len();
        for byte in bytes {
            match self.deframer.push::<Message>(byte) {
                None => {}
                Some(Err(_)) => self.corrupt += 1,
                Some(Ok(Message { reply_to: Some(seq), response })) => {
                    self.replies.push((seq, response));
                }
                Some(Ok(Message { reply_to: None, response })) => match response {
                    Response::Sample(sample) => self.samples.push(sample),
                    Response::Event(event) => self.events.push(event),
                    Response::Refused(Refusal::BadFrame) => self.bad_frames += 1,
                    _ => self.corrupt += 1,
                },
            }
        }
    }

    /// The reply to command `seq`, if it came.
    pub fn reply(&self, seq: u16) -> Option<&Response> {
        self.replies.iter().find(|(s, _)| *s == seq).map(|(_, r)| r)
    }
}

/// What the PC does during the job, and what it saw (see the module docs).
#[derive(Debug)]
pub struct Traffic {
    /// The PC's end.
    pub host: Host,
    hello: Option<u16>,
    /// Requests sent: (number, request).
    pub sent: Vec<(u16, Request)>,
    /// Settings writes sent while the machine pulled or held.
    writes_in_pull: Vec<u16>,
    /// Garbage chunks sent (each ends a frame the machine cannot decode).
    pub garbage: u64,
    /// Runs of zero bytes sent (a line held low).
    pub breaks: u64,
    /// Bytes sent in all.
    pub bytes_sent: u64,
    /// The closing reads: status and log page 0.
    closing: Option<(u16, u16)>,
    /// The closing write, in Ready: the settings the status reported, written back.
    write_in_ready: Option<u16>,
    seed: u64,
}

/// Requests outstanding at most while the PC floods the line: the machine's replies then
/// keep its transmit line busy without queueing past its transmit ring.
const OUTSTANDING: usize = 2;

impl Default for Traffic {
    fn default() -> Self {
        Self {
            host: Host::default(),
            hello: None,
            sent: Vec::new(),
            writes_in_pull: Vec::new(),
            garbage: 0,
            breaks: 0,
            bytes_sent: 0,
            closing: None,
            write_in_ready: None,
            seed: 0x9E37_79B9_7F4A_7C15,
        }
    }
}

impl Traffic {
    fn random(&mut self) -> u64 {
        self.seed ^= self.seed << 13;
        self.seed ^= self.seed >> 7;
        self.seed ^= self.seed << 17;
        self.seed
    }

    fn send(&mut self, line: &mut Line, request: Request) -> u16 {
        let before = line.to_machine.len();
        let seq = self.host.send(line, request);
        self.bytes_sent += (line.to_machine.len() - before) as u64;
        self.sent.push((seq, request));
        seq
    }

    /// One millisecond of the PC: `busy` while the machine pulls or holds, `idle` once the
    /// job is over and the machine is back in Ready.
    pub fn millisecond(&mut self, line: &mut Line, now_ms: u64, busy: bool, idle: bool) {
        self.host.poll(line);
        if self.hello.is_none() {
            self.hello = Some(self.send(line, Request::Hello));
            self.send(line, Request::Stream { period_ms: 20 });
            return;
        }
        if idle {
            if self.closing.is_none() && line.to_machine.is_empty() {
                let status = self.send(line, Request::ReadStatus);
                let log = self.send(line, Request::ReadLog { page: 0 });
                self.closing = Some((status, log));
            }
            if let (Some((status, _)), None) = (self.closing, self.write_in_ready) {
                if let Some(Response::Status(status)) = self.host.reply(status).copied() {
                    let (settings, preferences) = (status.settings, status.preferences);
                    let seq = self.send(line, Request::WriteSettings { settings, preferences });
                    self.write_in_ready = Some(seq);
                }
            }
            return;
        }
        if !busy || !line.to_machine.is_empty() {
            return;
        }
        let answered = |seq: &u16| self.host.reply(*seq).is_some();
        let outstanding = self.sent.iter().filter(|(seq, _)| !answered(seq)).count();
        if outstanding >= OUTSTANDING {
            return;
        }
        let pick = self.random() % 10;
        let request = match pick {
            0 => Request::ReadLog { page: (now_ms % 5) as u8 },
            1 => Request::ReadStatus,
            2 => Request::ReadFaults,
            3 => Request::ReadRecord { part: (now_ms % 7) as u8 },
            4 => Request::ReadPreset { index: (now_ms % 9) as u8 },
            5 => Request::Stream { period_ms: 20 },
            6 => {
                let settings = WireSettings::from(taut_core::settings::Settings::default());
                let preferences =
                    WirePreferences::from(taut_core::settings::Preferences::default());
                let seq = self.send(line, Request::WriteSettings { settings, preferences });
                self.writes_in_pull.push(seq);
                return;
            }
            9 => {
                // A line held low (a break, a cable pulled out mid-byte): zero bytes, which
                // delimit only empty frames.
                let len = 1 + self.random() % 30;
                line.to_machine.extend(std::iter::repeat_n(0u8, len as usize));
                self.bytes_sent += len;
                self.breaks += 1;
                return;
            }
            _ => {
                // Garbage: random bytes, a cut frame, then the delimiter.
                let len = 1 + self.random() % 40;
                for _ in 0..len {
                    line.to_machine.push_back((self.random() % 255 + 1) as u8);
                }
                line.to_machine.push_back(0);
                self.bytes_sent += len + 1;
                self.garbage += 1;
                return;
            }
        };
        self.send(line, request);
    }

    /// Whether the closing reads have been answered.
    pub fn done(&self) -> bool {
        let answered = |seq: u16| self.host.reply(seq).is_some();
        self.closing.is_some_and(|(a, b)| answered(a) && answered(b))
            && self.write_in_ready.is_some_and(answered)
    }

    /// What the traffic showed, and whether every check held: `board` is the part's unique
    /// id, `pulls_before` the counter before the job.
    pub fn verdict(&self, board: BoardId) -> (bool, Vec<String>) {
        let mut lines = Vec::new();
        let mut ok = true;
        let mut judge = |name: &str, good: bool, text: String| {
            ok &= good;
            lines.push(format!("{name}: {text} ({})", if good { "ok" } else { "FAILED" }));
        };
        let h = &self.host;
        match self.hello.and_then(|seq| h.reply(seq)) {
            Some(Response::Identity(id)) => judge(
                "hello",
                id.protocol == PROTOCOL_VERSION && id.board == board,
                format!(
                    "protocol {}, firmware {}.{}.{}, board id {} (the part's unique id: {}), {} boots, {} pulls",
                    id.protocol,
                    id.firmware[0],
                    id.firmware[1],
                    id.firmware[2],
                    hex(&id.board),
                    id.board == board,
                    id.boots,
                    id.pulls
                ),
            ),
            other => judge("hello", false, format!("answered {other:?}")),
        }
        let unanswered: Vec<u16> =
            self.sent.iter().map(|(seq, _)| *seq).filter(|seq| h.reply(*seq).is_none()).collect();
        let dropped: u64 = h
            .events
            .iter()
            .map(|e| if let Event::Dropped { count } = e { u64::from(*count) } else { 0 })
            .sum();
        judge(
            "requests",
            unanswered.is_empty() && h.corrupt == 0,
            format!(
                "{} sent, {} answered, {} frames from the machine corrupt, {} dropped by the machine",
                self.sent.len(),
                self.sent.len() - unanswered.len(),
                h.corrupt,
                dropped
            ),
        );
        judge(
            "garbage",
            h.bad_frames >= 1 && h.bad_frames <= self.garbage + 1,
            format!(
                "{} chunks of garbage and cut frames sent, {} refused as bad frames; {} runs of a line held low, ignored",
                self.garbage, h.bad_frames, self.breaks
            ),
        );
        let refused = self
            .writes_in_pull
            .iter()
            .filter(|seq| matches!(h.reply(**seq), Some(Response::Refused(Refusal::NotIdle))))
            .count();
        judge(
            "no motion",
            refused == self.writes_in_pull.len() && !self.writes_in_pull.is_empty(),
            format!(
                "{} settings writes during the pull, {refused} refused as not idle",
                self.writes_in_pull.len()
            ),
        );
        let accepted = self.write_in_ready.map(|seq| h.reply(seq));
        judge(
            "write in Ready",
            matches!(accepted, Some(Some(Response::Accepted))),
            format!("the settings read back, written back once the machine idled: {accepted:?}"),
        );
        let pulling = h
            .samples
            .iter()
            .filter(|s| matches!(s.state, WireState::Pulling | WireState::Holding))
            .count();
        let ordered = h.samples.windows(2).all(|w| w[1].time_ms > w[0].time_ms);
        let peak = h.samples.iter().map(|s| s.tension_milli_kgf).max().unwrap_or(0);
        judge(
            "live stream",
            pulling > 0 && ordered,
            format!(
                "{} samples ({pulling} in the pull and hold), in time order {ordered}, highest tension {:.2} kgf; {} events",
                h.samples.len(),
                f64::from(peak) / 1000.0,
                h.events.len()
            ),
        );
        match self.closing.map(|(status, log)| (h.reply(status), h.reply(log))) {
            Some((Some(Response::Status(status)), Some(Response::LogPage(page)))) => {
                let latest = page.entries[0];
                judge(
                    "log",
                    latest.is_some_and(|entry| entry.pull == status.pulls),
                    format!(
                        "{} pulls counted, the log's latest is pull {:?}: {}",
                        status.pulls,
                        latest.map(|e| e.pull),
                        latest.map_or("none".into(), |e| format!(
                            "target {:.2} kgf, reached {:.2}, peak {:.2}, held {} s",
                            f64::from(e.target_centi_kgf) / 100.0,
                            f64::from(e.reached_centi_kgf) / 100.0,
                            f64::from(e.peak_centi_kgf) / 100.0,
                            e.held_s
                        ))
                    ),
                );
            }
            other => judge("log", false, format!("closing reads answered {other:?}")),
        }
        (ok, lines)
    }
}

/// The emulated part's unique id as the link's board id (the firmware's little-endian words).
pub fn unique_id_bytes() -> [u8; 12] {
    let mut id = [0u8; 12];
    for (chunk, word) in id.chunks_exact_mut(4).zip(crate::soc::UNIQUE_ID) {
        chunk.copy_from_slice(&word.to_le_bytes());
    }
    id
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

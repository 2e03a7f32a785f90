//! `taut connect`, `taut log`, `taut backup` and `taut restore`: the machine link's commands,
//! each against a board's serial port (`--port`) or the twin (`--twin`).
//!
//! # Theory of operation
//!
//! Every command opens a [`Client`] on its [`Line`], says hello (which checks the protocol
//! version) and then only reads, except `restore`, which proposes a whole record that the
//! machine accepts only while it idles in Ready. Output files go through
//! [`crate::output::Outputs`]: checked before the machine is asked anything, written only
//! when complete, so a failed command never destroys an earlier file.
//!
//! On the twin (`--twin`) the machine is commissioned first (calibrated, the previous job's
//! settings stored); `connect` and `log` then let the simulated operator pull `--pulls`
//! times, `backup` reads the commissioned machine, and `restore` restores into a
//! factory-fresh one — the backup → factory reset → restore round trip.

use std::io::IsTerminal as _;
use std::path::PathBuf;

use clap::Args;
use serde_json::json;
use taut_core::machine::MachineState;
use taut_core::store::{FORMAT_VERSION, RECORD_LEN, Record};
use taut_link::message::{
    Event, Identity, LiveSample, LogEntry, Refusal, Request, Response, SAMPLE_PERIOD_MIN_MS,
    WireState,
};

use super::twin::{Session, TwinLine};
use super::{Client, Line, SerialLine, list_ports};
use crate::output::{Failure, Outputs, Status, to_stderr};

/// Which machine a link command talks to.
#[derive(Args, Debug, Clone)]
pub struct Target {
    /// The board's serial port: the NUCLEO's ST-LINK virtual COM port (Linux /dev/ttyACM0,
    /// macOS /dev/cu.usbmodem…, Windows COM3). Without --port or --twin, the ports are
    /// listed.
    #[arg(long, value_name = "PORT", conflicts_with = "twin")]
    pub port: Option<String>,
    /// The firmware's machine on the digital twin, served by the same link code.
    #[arg(long)]
    pub twin: bool,
}

/// `taut connect`.
#[derive(Args, Debug)]
pub struct ConnectArgs {
    /// The machine.
    #[command(flatten)]
    pub target: Target,
    /// With --twin: pulls the simulated operator makes (0–20).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=20))]
    pub pulls: u32,
    /// Live sample period, ms (20–1000).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u16).range(20..=1000))]
    pub period_ms: u16,
    /// Stop after this many seconds (the machine's; default: on a port, until interrupted;
    /// on the twin, when its session is over).
    #[arg(long, value_name = "SECONDS", value_parser = clap::value_parser!(u32).range(1..=86_400))]
    pub seconds: Option<u32>,
}

/// `taut log`.
#[derive(Args, Debug)]
pub struct LogArgs {
    /// The machine.
    #[command(flatten)]
    pub target: Target,
    /// With --twin: pulls the simulated operator makes before the log is read (0–20).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=20))]
    pub pulls: u32,
    /// Write the pull log as CSV here.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Write the pull log as JSON here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

/// `taut backup`.
#[derive(Args, Debug)]
pub struct BackupArgs {
    /// The machine.
    #[command(flatten)]
    pub target: Target,
    /// The backup file (JSON: the board, the stored record and its readable settings).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// `taut restore`.
#[derive(Args, Debug)]
pub struct RestoreArgs {
    /// The backup file `taut backup` wrote.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// The machine.
    #[command(flatten)]
    pub target: Target,
    /// Restore a backup of another board, or of an older record format.
    #[arg(long)]
    pub force: bool,
}

/// The hold of each pull the twin's operator makes, ms.
const TWIN_HOLD_MS: u32 = 3_000;

/// The line a command talks over, or `None` after listing the ports.
fn open(target: &Target, session: Session) -> Result<Option<Box<dyn LinkLine>>, Failure> {
    if target.twin {
        let twin = if session.pulls == 0 && session.hold_ms == 0 {
            TwinLine::factory_fresh()
        } else {
            TwinLine::commissioned(session)
                .map_err(|error| Failure::Message(format!("the twin: {error}")))?
        };
        return Ok(Some(Box::new(twin)));
    }
    let Some(port) = &target.port else {
        let ports = list_ports()?;
        if ports.is_empty() {
            println!("no serial ports found; connect the board's USB cable (ST-LINK)");
        } else {
            println!("serial ports (give one with --port):");
            for port in ports {
                println!("  {port}");
            }
        }
        return Ok(None);
    };
    Ok(Some(Box::new(SerialLine::open(port)?)))
}

/// A line, with what the commands need of the twin behind it.
pub trait LinkLine: Line {
    /// The twin, when the line is one.
    fn as_twin(&mut self) -> Option<&mut TwinLine> {
        None
    }
}

impl LinkLine for SerialLine {}

impl LinkLine for TwinLine {
    fn as_twin(&mut self) -> Option<&mut TwinLine> {
        Some(self)
    }
}

impl Line for Box<dyn LinkLine> {
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        (**self).write_all(bytes)
    }
    fn read_some(&mut self, buffer: &mut [u8], timeout_ms: u32) -> std::io::Result<usize> {
        (**self).read_some(buffer, timeout_ms)
    }
    fn now_ms(&self) -> u64 {
        (**self).now_ms()
    }
}

/// The machine-state name the host tool uses everywhere.
fn state_name(state: WireState) -> String {
    state.to_state().map_or_else(|| format!("{state:?}"), taut_sim::bench::state_name)
}

/// The identity as one line.
fn identity_line(identity: &Identity) -> String {
    let [major, minor, patch] = identity.firmware;
    format!(
        "machine {} firmware {major}.{minor}.{patch}, link protocol {}, record format {}, \
         {} boots, {} pulls, {}",
        board_hex(&identity.board),
        identity.protocol,
        identity.record_format,
        identity.boots,
        identity.pulls,
        match (identity.calibrated, identity.calibration_age_pulls) {
            (false, _) => "not calibrated".to_owned(),
            (true, Some(age)) => format!("calibrated {age} pulls ago"),
            (true, None) => "calibrated (age unknown: an older record)".to_owned(),
        }
    )
}

/// A board id as hex.
fn board_hex(board: &[u8]) -> String {
    board.iter().map(|b| format!("{b:02x}")).collect()
}

/// Hex back to bytes.
fn from_hex(text: &str) -> Option<Vec<u8>> {
    if !text.len().is_multiple_of(2) {
        return None;
    }
    (0..text.len())
        .step_by(2)
        .map(|i| text.get(i..i + 2).and_then(|pair| u8::from_str_radix(pair, 16).ok()))
        .collect()
}

/// One sample as a terminal line with a bar of the tension (0–50 kg).
#[must_use]
pub fn sample_line(sample: &LiveSample) -> String {
    const WIDTH: usize = 40;
    let tension = f64::from(sample.tension_milli_kgf) / 1_000.0;
    let target = f64::from(sample.target_milli_kgf) / 1_000.0;
    let filled = ((tension / 50.0).clamp(0.0, 1.0) * WIDTH as f64).round() as usize;
    let mark = ((target / 50.0).clamp(0.0, 1.0) * WIDTH as f64).round() as usize;
    let bar: String = (0..WIDTH)
        .map(|i| match (i < filled, i == mark.min(WIDTH - 1)) {
            (_, true) => '|',
            (true, false) => '#',
            (false, false) => ' ',
        })
        .collect();
    format!(
        "{:>9.3} s  {:<11} target {:>5.1} kg  tension {:>5.1} kg  [{bar}]  carriage {:>6} steps  duty {:>4.1} %",
        f64::from(sample.time_ms) / 1_000.0,
        state_name(sample.state),
        target,
        tension,
        sample.carriage_steps,
        f64::from(sample.duty_raw) / 655.36,
    )
}

/// One event as a line.
#[must_use]
pub fn event_line(event: &Event) -> String {
    match event {
        Event::State { time_ms, from, to } => format!(
            "{:>9.3} s  event: {} -> {}",
            f64::from(*time_ms) / 1_000.0,
            state_name(*from),
            state_name(*to)
        ),
        Event::Fault { time_ms, code, inputs } => format!(
            "{:>9.3} s  event: fault E-{code:02} latched; inputs: load cell {} motor current {} \
             bus {} (codes), carriage {} steps, limits home {} end {}, drive fault {}",
            f64::from(*time_ms) / 1_000.0,
            inputs.load_cell_code,
            inputs.motor_current_code,
            inputs.bus_voltage_code,
            inputs.carriage_steps,
            inputs.home_limit,
            inputs.end_limit,
            inputs.drive_fault
        ),
        Event::Logged(entry) => format!(
            "           event: pull {} logged: target {:.2} kg, peak {:.2} kg, {:.2} s to tension, held {} s",
            entry.pull,
            f64::from(entry.target_centi_kgf) / 100.0,
            f64::from(entry.peak_centi_kgf) / 100.0,
            f64::from(entry.time_to_tension_ms) / 1_000.0,
            entry.held_s
        ),
        Event::Dropped { count } => {
            format!("           event: {count} messages dropped (line full)")
        }
    }
}

/// `taut connect`: live tension and events.
///
/// # Errors
/// The link failed.
pub fn connect(args: &ConnectArgs) -> Status {
    let session = Session { pulls: args.pulls, hold_ms: TWIN_HOLD_MS };
    let Some(line) = open(&args.target, session)? else { return Ok(true) };
    let mut client = Client::new(line);
    let identity = client.hello()?;
    println!("{}", identity_line(&identity));
    match client
        .request(&Request::Stream { period_ms: args.period_ms.max(SAMPLE_PERIOD_MIN_MS) })?
    {
        Response::Accepted => {}
        other => {
            return Err(Failure::Message(format!("the machine refused the stream: {other:?}")));
        }
    }
    let terminal = std::io::stdout().is_terminal();
    let started = client.line().now_ms();
    let limit_ms = args.seconds.map(|s| u64::from(s) * 1_000);
    let mut last_state = None;
    loop {
        let now = client.line().now_ms();
        if limit_ms.is_some_and(|limit| now.saturating_sub(started) >= limit) {
            break;
        }
        let twin_done = client.line_mut().as_twin().is_some_and(|twin| {
            twin.session_done() && twin.machine().state() == MachineState::Ready
        });
        if twin_done && limit_ms.is_none() && last_state == Some(MachineState::Ready) {
            break;
        }
        match client.next_unsolicited(200)? {
            Some(Response::Sample(sample)) => {
                last_state = sample.state.to_state();
                if terminal {
                    print!("\r{}\x1b[K", sample_line(&sample));
                    let _ = std::io::Write::flush(&mut std::io::stdout());
                } else {
                    println!("{}", sample_line(&sample));
                }
            }
            Some(Response::Event(event)) => {
                if terminal {
                    print!("\r\x1b[K");
                }
                println!("{}", event_line(&event));
            }
            Some(other) => to_stderr(&format!("unexpected message: {other:?}\n")),
            None => {}
        }
    }
    if terminal {
        println!();
    }
    let _ = client.request(&Request::Stream { period_ms: 0 });
    if client.bad_frames() > 0 {
        to_stderr(&format!("{} frames from the machine did not decode\n", client.bad_frames()));
    }
    Ok(true)
}

/// The CSV of `entries` (oldest first): the log's own figures.
#[must_use]
pub fn log_csv(entries: &[LogEntry]) -> String {
    let mut text = String::from(
        "pull,target_kg,reached_kg,peak_kg,adjust_kg,time_to_tension_s,held_s,string_mm,\
         stiffness_kgf_per_mm,creep_percent_per_min\n",
    );
    let optional = |value: Option<u16>, scale: f64, places: usize| {
        value.map_or_else(String::new, |v| format!("{:.places$}", f64::from(v) / scale))
    };
    for e in entries {
        text.push_str(&format!(
            "{},{:.2},{:.2},{:.2},{:.2},{:.3},{},{},{},{}\n",
            e.pull,
            f64::from(e.target_centi_kgf) / 100.0,
            f64::from(e.reached_centi_kgf) / 100.0,
            f64::from(e.peak_centi_kgf) / 100.0,
            f64::from(e.adjust_centi_kgf) / 100.0,
            f64::from(e.time_to_tension_ms) / 1_000.0,
            e.held_s,
            e.string_mm,
            optional(e.stiffness_milli_kgf_per_mm, 1_000.0, 3),
            optional(e.creep_centi_percent_per_min, 100.0, 2),
        ));
    }
    text
}

/// The JSON of `entries` (oldest first).
#[must_use]
pub fn log_json(identity: &Identity, entries: &[LogEntry]) -> serde_json::Value {
    let pulls: Vec<_> = entries
        .iter()
        .map(|e| {
            json!({
                "pull": e.pull,
                "target_kg": f64::from(e.target_centi_kgf) / 100.0,
                "reached_kg": f64::from(e.reached_centi_kgf) / 100.0,
                "peak_kg": f64::from(e.peak_centi_kgf) / 100.0,
                "adjust_kg": f64::from(e.adjust_centi_kgf) / 100.0,
                "time_to_tension_s": f64::from(e.time_to_tension_ms) / 1_000.0,
                "held_s": e.held_s,
                "string_mm": e.string_mm,
                "stiffness_kgf_per_mm": e.stiffness_milli_kgf_per_mm.map(|v| f64::from(v) / 1_000.0),
                "creep_percent_per_min": e.creep_centi_percent_per_min.map(|v| f64::from(v) / 100.0),
            })
        })
        .collect();
    json!({ "board": board_hex(&identity.board), "pulls": pulls })
}

/// Lets the twin's operator finish the session (no-op on a port).
fn finish_session(line: &mut Box<dyn LinkLine>) {
    if let Some(twin) = line.as_twin() {
        for _ in 0..taut_sim::bench::SESSION_LIMIT_MS {
            if twin.session_done() && twin.machine().state() == MachineState::Ready {
                break;
            }
            twin.tick();
        }
    }
}

/// `taut log`: the pull log to CSV, JSON or the terminal.
///
/// # Errors
/// A bad output path (before the machine is asked), or the link failed.
pub fn log(args: &LogArgs) -> Status {
    let outputs = Outputs::new()
        .file("--csv", args.csv.as_deref())
        .file("--json", args.json.as_deref())
        .check()?;
    let session = Session { pulls: args.pulls, hold_ms: TWIN_HOLD_MS };
    let Some(mut line) = open(&args.target, session)? else { return Ok(true) };
    finish_session(&mut line);
    let mut client = Client::new(line);
    let identity = client.hello()?;
    let mut entries = client.pull_log()?;
    entries.reverse();
    to_stderr(&format!("{}\n{} pulls in the log\n", identity_line(&identity), entries.len()));
    let mut files = Vec::new();
    if let Some(path) = &args.csv {
        files.push((path.clone(), log_csv(&entries).into_bytes()));
    }
    if let Some(path) = &args.json {
        files.push((path.clone(), crate::output::json_bytes(&log_json(&identity, &entries))));
    }
    if files.is_empty() {
        print!("{}", log_csv(&entries));
    }
    outputs.write(&files)?;
    Ok(true)
}

/// `taut backup`: the stored record and the board to a JSON file.
///
/// # Errors
/// A bad output path (before the machine is asked), or the link failed.
pub fn backup(args: &BackupArgs) -> Status {
    let outputs = Outputs::new().file("--out", Some(&args.out)).check()?;
    let session = Session { pulls: 0, hold_ms: TWIN_HOLD_MS };
    let Some(line) = open(&args.target, session)? else { return Ok(true) };
    let mut client = Client::new(line);
    let identity = client.hello()?;
    let bytes = client.record_bytes()?;
    let document = backup_json(&identity, &bytes)?;
    outputs.write(&[(args.out.clone(), crate::output::json_bytes(&document))])?;
    println!("{}\nbacked up to {}", identity_line(&identity), args.out.display());
    Ok(true)
}

/// The backup document of a machine's record.
///
/// # Errors
/// The record the machine sent does not decode.
pub fn backup_json(
    identity: &Identity,
    bytes: &[u8; RECORD_LEN],
) -> Result<serde_json::Value, Failure> {
    let record = Record::decode(bytes).map_err(|error| {
        Failure::Message(format!("the machine's record does not decode: {error:?}"))
    })?;
    let settings = |s: taut_core::settings::Settings| {
        json!({
            "tension_tenths": s.set_point().tenths(),
            "unit": format!("{:?}", s.set_point().unit()),
            "speed": s.speed().get(),
            "pre_stretch_percent": s.pre_stretch().percent(),
            "knot_percent": s.knot().percent(),
        })
    };
    Ok(json!({
        "format": "taut-backup",
        "board": board_hex(&identity.board),
        "protocol": identity.protocol,
        "record_format": identity.record_format,
        "record": board_hex(bytes),
        "settings": settings(record.settings),
        "presets": record.presets.iter().map(|p| settings(*p)).collect::<Vec<_>>(),
        "calibrated": record.calibration.is_some(),
        "counters": { "pulls": record.counters.pulls, "boots": record.counters.boots },
    }))
}

/// A backup file read back: the board and the record bytes.
#[derive(Debug, Clone, Copy)]
pub struct Backup {
    /// The board it came from.
    pub board: [u8; 12],
    /// The stored record.
    pub record: [u8; RECORD_LEN],
    /// The record's format version.
    pub record_format: u8,
}

/// Reads a backup document.
///
/// # Errors
/// Not a backup, or its record does not decode.
pub fn parse_backup(text: &str) -> Result<Backup, Failure> {
    let bad = |what: &str| Failure::Message(format!("not a taut backup: {what}"));
    let doc: serde_json::Value = serde_json::from_str(text).map_err(|e| bad(&e.to_string()))?;
    if doc["format"] != "taut-backup" {
        return Err(bad("no \"format\": \"taut-backup\""));
    }
    let board = doc["board"].as_str().and_then(from_hex).ok_or_else(|| bad("board"))?;
    let board: [u8; 12] = board.try_into().map_err(|_| bad("board"))?;
    let record = doc["record"].as_str().and_then(from_hex).ok_or_else(|| bad("record"))?;
    let record: [u8; RECORD_LEN] = record.try_into().map_err(|_| bad("record length"))?;
    let (_, record_format) = Record::decode_version(&record)
        .map_err(|error| bad(&format!("its record does not decode: {error:?}")))?;
    Ok(Backup { board, record, record_format })
}

/// Restores `backup` over `client`: checks the board and the format (unless `force`) and
/// proposes the record; returns what the machine said.
///
/// # Errors
/// Another board or an older format without `force`, a refusal, or the link failed.
pub fn restore_over<L: Line>(
    client: &mut Client<L>,
    backup: &Backup,
    force: bool,
) -> Result<Identity, Failure> {
    let identity = client.hello()?;
    if backup.board != identity.board && !force {
        return Err(Failure::Message(format!(
            "the backup is of board {}, this machine is {}: nothing restored (--force restores it)",
            board_hex(&backup.board),
            board_hex(&identity.board)
        )));
    }
    if backup.record_format < FORMAT_VERSION && !force {
        return Err(Failure::Message(format!(
            "the backup's record format {} is older than this machine's {FORMAT_VERSION}: \
             nothing restored (--force restores it, migrated)",
            backup.record_format
        )));
    }
    match client.propose_record(&backup.record)? {
        Response::Accepted => Ok(identity),
        Response::Refused(Refusal::NotIdle) => Err(Failure::Message(
            "the machine is not idle in Ready (pulling, holding, calibrating or a fault): \
             nothing restored"
                .into(),
        )),
        Response::Refused(reason) => {
            Err(Failure::Message(format!("the machine refused the record: {reason:?}")))
        }
        other => Err(Failure::Message(format!("unexpected reply: {other:?}"))),
    }
}

/// `taut restore`: a backup's settings, presets, preferences and calibration back onto the
/// machine (on the twin: onto a factory-fresh machine).
///
/// # Errors
/// The file cannot be read or is not a backup, the machine refused, or the link failed.
pub fn restore(args: &RestoreArgs) -> Status {
    let text = std::fs::read_to_string(&args.file)
        .map_err(|error| Failure::Read { path: args.file.clone(), error })?;
    let backup = parse_backup(&text)?;
    let session = Session { pulls: 0, hold_ms: 0 };
    let Some(mut line) = open(&args.target, session)? else { return Ok(true) };
    if let Some(twin) = line.as_twin() {
        // A factory-fresh twin powers up, waits out the calibration window and idles.
        for _ in 0..60_000 {
            if twin.machine().state() == MachineState::Ready {
                break;
            }
            twin.tick();
        }
    }
    let mut client = Client::new(line);
    let identity = restore_over(&mut client, &backup, args.force)?;
    println!(
        "{}\nrestored settings, presets, preferences and calibration from {}",
        identity_line(&identity),
        args.file.display()
    );
    Ok(true)
}

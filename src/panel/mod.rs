//! `taut panel`: the machine's front panel in a terminal — keys in, 7-segment display, lamps,
//! beeper and a tension gauge out — with the machine running on the twin in real time, or
//! driven by a script.
//!
//! # Theory of operation
//!
//! A [`PanelSession`] is a [`Bench`] (the firmware's [`taut_core::machine::Machine`] on the
//! twin, see [`taut_sim::bench`]) plus the key levels a person is holding down. Each
//! [`PanelSession::tick`] puts those levels on the twin's key inputs and runs one 1 ms tick;
//! the machine alone decides what happens (debounce, repeat, long presses, states, faults).
//! [`PanelSession::frame`] draws the panel from the machine's outputs only: the display from
//! its segment bitmaps ([`display::art`]), the lamps from `Outputs::leds`, the beeper from
//! `Outputs::beeper`; beside them a tension gauge (the reference gauge in the string path:
//! what the string really carries, with the set point marked), the carriage position and the
//! machine's state name — what a firmware developer wants to see while trying the UI.
//!
//! Two front ends share it:
//!
//! - [`terminal`] (interactive): raw keyboard input through `crossterm`, ticks paced to the
//!   wall clock (1 ms of machine time per 1 ms of real time, or `--rate` times that), the
//!   frame redrawn about 30 times a second. Every key press is queued and reaches the
//!   machine as its own tap, however quickly they come; a key the terminal auto-repeats
//!   (held down) is held on the panel, whose own repeat then runs
//!   ([`terminal::KeyHolds`]). The long presses (Function: knot mode, Preset: store) have
//!   their own keys (`F`, `P`). Where the terminal supports the keyboard-enhancement
//!   protocol (kitty, foot, WezTerm, recent Alacritty/iTerm2), real press and release events
//!   are used. A string break latches `E-15`: Start clears it and the carriage returns home,
//!   `n` fits a new string.
//! - [`script`] (no terminal): a small text format of key presses, waits and checks, run as
//!   fast as the twin goes; it prints a transcript (and frames) to stdout. Tests drive the
//!   panel through it.

pub mod faults;
pub mod script;
pub mod terminal;

use taut_core::io::{Key, Keys, Outputs};
use taut_core::machine::snapshot::FAULT_HISTORY;
use taut_core::machine::{MachineState, View};
use taut_core::sense::calibration::CALIBRATION_POINTS;
use taut_core::settings::Unit;
use taut_core::store::{RECORD_LEN, Record};
use taut_sim::bench::{
    Bench, SessionError, commission, factory_config, fault_name, kgf, state_name,
};
use taut_sim::operator::{Page, page_shown};
use taut_sim::{StringKind, StringState, TwinConfig};

pub use crate::cli::{Flash, PanelArgs};
use crate::output::{self, Failure, Status, to_stderr};
pub use taut_sim::operator::display;

/// How long a queued tap holds its key down, ms (the panel debounces for 20 ms).
pub const TAP_MS: u64 = 60;
/// How long a queued tap leaves its key up before the next, ms.
pub const TAP_GAP_MS: u64 = 40;
/// How long a key the terminal auto-repeats stays down after each repeat, ms (longer than
/// a terminal's repeat interval, so the key stays down between repeats).
pub const HOLD_MS: u64 = 100;
/// How long a "long press" key (`F`, `P`) holds Function or Preset down, ms (the machine
/// needs 1.5 s after its 20 ms debounce).
pub const LONG_PRESS_HOLD_MS: u64 = 1_700;
/// Full scale of the tension gauge, kgf.
pub const GAUGE_FULL_SCALE_KGF: f64 = 50.0;
/// Width of the tension gauge's bar, characters.
pub const GAUGE_WIDTH: usize = 50;

/// The machine on the twin with a person's key levels.
pub struct PanelSession {
    bench: Bench,
    keys: Keys,
    string: StringKind,
    seed: Option<u64>,
    last_outputs: Outputs,
    /// The flash as the machine last stored it.
    flash: [u8; RECORD_LEN],
}

impl PanelSession {
    /// A session on a twin of `string` (nominal, or machine `seed` of the family) whose
    /// machine powers up
    /// from `flash`. [`Flash::Calibrated`] first runs a commissioning session on the same
    /// twin configuration (a fraction of a second).
    ///
    /// # Errors
    /// The commissioning failed.
    pub fn new(string: StringKind, seed: Option<u64>, flash: Flash) -> Result<Self, SessionError> {
        let config = seed.map_or_else(
            || TwinConfig::nominal(string),
            |seed| TwinConfig::family_kind(string, seed),
        );
        let bytes = match flash {
            Flash::Calibrated => commission(&factory_config(&config), true, &mut |_| {})?.flash,
            Flash::Factory => Record::default().encode(),
            Flash::Blank => [0xFF; RECORD_LEN],
        };
        Ok(Self::from_flash(string, seed, &bytes))
    }

    /// A session whose machine powers up from the flash image `bytes` (a session's
    /// [`PanelSession::flash`], kept in a `--state` file).
    #[must_use]
    pub fn from_flash(string: StringKind, seed: Option<u64>, bytes: &[u8; RECORD_LEN]) -> Self {
        let config = seed.map_or_else(
            || TwinConfig::nominal(string),
            |seed| TwinConfig::family_kind(string, seed),
        );
        Self {
            bench: Bench::power_up(&config, bytes),
            keys: Keys::NONE,
            string,
            seed,
            last_outputs: Outputs::default(),
            flash: *bytes,
        }
    }

    /// The flash as the machine last stored it (settings, presets, calibration, counters):
    /// what a power cycle would start from.
    #[must_use]
    pub const fn flash(&self) -> &[u8; RECORD_LEN] {
        &self.flash
    }

    /// Puts `key` down (it stays down until [`PanelSession::release`]).
    pub fn press(&mut self, key: Key) {
        self.keys = self.keys.with(key);
    }

    /// Lets `key` go.
    pub fn release(&mut self, key: Key) {
        self.keys = Keys::from_bits(self.keys.bits() & !Keys::NONE.with(key).bits());
    }

    /// Sets every key level at once.
    pub fn set_keys(&mut self, keys: Keys) {
        self.keys = keys;
    }

    /// The keys held down.
    #[must_use]
    pub const fn keys(&self) -> Keys {
        self.keys
    }

    /// One 1 ms tick with the keys held now; returns the machine's outputs.
    pub fn tick(&mut self) -> Outputs {
        let keys = self.keys;
        self.bench.twin_mut().set_keys(keys);
        self.last_outputs = self.bench.tick();
        if self.last_outputs.store {
            self.flash = self.bench.machine().record().encode();
        }
        self.last_outputs
    }

    /// Milliseconds since power-up.
    #[must_use]
    pub fn now_ms(&self) -> u64 {
        self.bench.twin().now_ms()
    }

    /// The machine's outputs of the last tick.
    #[must_use]
    pub const fn outputs(&self) -> &Outputs {
        &self.last_outputs
    }

    /// The machine's state.
    #[must_use]
    pub fn state(&self) -> MachineState {
        self.bench.machine().state()
    }

    /// The bench (machine and twin).
    #[must_use]
    pub const fn bench(&self) -> &Bench {
        &self.bench
    }

    /// The bench, to inject twin faults or break the string.
    pub fn bench_mut(&mut self) -> &mut Bench {
        &mut self.bench
    }

    /// The reference gauge's reading now (true tension + its σ = 0.02 kgf noise), kgf.
    pub fn read_gauge(&mut self) -> f64 {
        self.bench.twin_mut().reference_gauge()
    }

    /// The set point as the machine stored it, in kgf.
    #[must_use]
    pub fn set_point_kgf(&self) -> f64 {
        kgf(self.bench.machine().record().settings.set_point().to_kgf())
    }

    /// One transcript line: time, state, display text, lamps lit, beeper.
    #[must_use]
    pub fn status_line(&self) -> String {
        let out = &self.last_outputs;
        format!(
            "t={:9.3} s  state={:<20} display=[{:<5}]  leds={:<16} beep={}  tension={:6.2} kgf",
            self.now_ms() as f64 / 1_000.0,
            state_name(self.state()),
            display::text(&out.display),
            lamps(out),
            if out.beeper { "on " } else { "off" },
            self.bench.twin().truth().tension_kgf,
        )
    }

    /// The whole panel as lines of text (see the module docs).
    #[must_use]
    pub fn frame(&self) -> Vec<String> {
        // The widest line is the keys line (94 characters); see [`FRAME_COLUMNS`].
        let out = &self.last_outputs;
        let truth = self.bench.twin().truth();
        let scenario = self.seed.map_or_else(|| "nominal".to_owned(), |s| format!("seed {s}"));
        let [a, b, c] = display::art(&out.display);
        let led = |on: bool, name: &str| format!("[{}] {name:<6}", if on { '*' } else { ' ' });
        let mut lines = Vec::with_capacity(12);
        lines.push(format!(
            "+-- taut front panel -- {} ({scenario}) -- t = {:.3} s",
            self.string.name(),
            self.now_ms() as f64 / 1_000.0
        ));
        lines.push(format!(
            "|   {a}    {}{}{}",
            led(out.leds.kg, "kg"),
            led(out.leds.lb, "lb"),
            led(out.leds.knot, "knot")
        ));
        lines.push(format!(
            "|   {b}    {}{}{}",
            led(out.leds.pulling, "pull"),
            led(out.leds.holding, "hold"),
            led(out.leds.fault, "fault")
        ));
        // A hold with constant pull off shows `LOCK` on the display for a second only; the
        // terminal keeps saying so for the whole hold.
        let locked = self.state() == MachineState::Holding && !self.bench.machine().constant_pull();
        lines.push(format!(
            "|   {c}    beeper: {:<6}{}",
            if out.beeper { "BEEP" } else { "-" },
            if locked { "[*] LOCK: constant pull off" } else { "" }
        ));
        lines.push(format!(
            "| state: {:<20} carriage {:6.1} mm   string {:?}",
            state_name(self.state()),
            truth.carriage_mm,
            truth.string
        ));
        lines.push(format!(
            "| gauge {} {:6.2} kgf",
            gauge_bar(truth.tension_kgf, self.set_point_kgf()),
            truth.tension_kgf
        ));
        let unit = self.bench.machine().record().settings.set_point().unit();
        lines.push(format!(
            "|       0 kgf {:>width$} set point {:.1} {}",
            format!("{GAUGE_FULL_SCALE_KGF:.0} kgf"),
            f64::from(self.bench.machine().record().settings.set_point().tenths()) / 10.0,
            if unit == Unit::Pounds { "lb" } else { "kg" },
            width = GAUGE_WIDTH - 4
        ));
        let view = self.bench.machine().view();
        let shows = match (self.state(), self.bench.machine().notice()) {
            (MachineState::Fault(code), _) => {
                format!("{} {}", fault_name(code), faults::fault_text(code).0)
            }
            (MachineState::Ready, Some(notice)) if page_shown(&out.display).is_none() => {
                format!("n-{:02} {}", notice.number(), faults::notice_text(notice).0)
            }
            _ => information_text(view).unwrap_or_else(|| page_text(self.state(), out)),
        };
        lines.push(format!("| shows: {shows}"));
        if let Some(hint) = self.hint() {
            lines.push(format!("| next:  {hint}"));
        }
        lines.push("| keys: Up/+  Down/-  Start: space/Enter  Function: f (F = hold)  Preset: p (P = hold)".to_owned());
        lines.push("|       b breaks the string, n fits a new string, q quits".to_owned());
        lines.push("+--".to_owned());
        lines
    }

    /// What the operator can do next, when it is not obvious: how a fault or a notice
    /// clears, a new string after a break, constant pull back on in a locked hold.
    #[must_use]
    pub fn hint(&self) -> Option<&'static str> {
        let machine = self.bench.machine();
        let broken = self.bench.twin().truth().string == StringState::Broken;
        match (self.state(), broken) {
            (MachineState::Fault(code), _) => Some(faults::fault_text(code).1),
            (MachineState::Ready, true) => Some("n fits a new string, then Start pulls it"),
            (MachineState::Ready, false) if page_shown(&self.last_outputs.display).is_none() => {
                machine.notice().map(|notice| faults::notice_text(notice).1)
            }
            (MachineState::Holding, _) if !machine.constant_pull() => {
                Some("the carriage stays put and the string may creep; Function: constant pull on")
            }
            _ => None,
        }
    }

    /// Fits a new string (after a break, with the carriage home).
    pub fn restring(&mut self) {
        self.bench.twin_mut().fit_new_string();
    }
}

/// The lamps lit, as a comma-separated list (`kg,hold`), or `-`.
#[must_use]
pub fn lamps(outputs: &Outputs) -> String {
    let l = outputs.leds;
    let names: Vec<&str> = [
        (l.kg, "kg"),
        (l.lb, "lb"),
        (l.pulling, "pull"),
        (l.holding, "hold"),
        (l.fault, "fault"),
        (l.knot, "knot"),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, name)| *name)
    .collect();
    if names.is_empty() { "-".to_owned() } else { names.join(",") }
}

/// The gauge bar: `[####....|....]`, filled to `tension_kgf` of [`GAUGE_FULL_SCALE_KGF`], with
/// `|` at the set point.
#[must_use]
pub fn gauge_bar(tension_kgf: f64, set_point_kgf: f64) -> String {
    let cells = |kgf: f64| {
        ((kgf / GAUGE_FULL_SCALE_KGF * GAUGE_WIDTH as f64).round().clamp(0.0, GAUGE_WIDTH as f64))
            as usize
    };
    let filled = cells(tension_kgf);
    let mark = cells(set_point_kgf).min(GAUGE_WIDTH - 1);
    let mut bar = String::with_capacity(GAUGE_WIDTH + 2);
    bar.push('[');
    for cell in 0..GAUGE_WIDTH {
        bar.push(if cell == mark {
            '|'
        } else if cell < filled {
            '#'
        } else {
            '.'
        });
    }
    bar.push(']');
    bar
}

/// The columns and rows [`PanelSession::frame`] needs (plus the status line).
pub const FRAME_COLUMNS: u16 = 96;
/// The rows the interactive panel needs.
pub const FRAME_ROWS: u16 = 15;

/// What an information page shows and which keys work on it (`None` for the other pages).
#[must_use]
pub fn information_text(view: View) -> Option<String> {
    let text = match view {
        View::Timer => {
            "stringing timer r m.ss (Up: start/stop, Down: reset when stopped; Function: the pull log)"
        }
        View::Log { .. } => {
            "pull log, label then value (Up: older pull, Down: newer, Preset: next field — PULL SEt PEAk Adj riSE HOLd Str StiF CrEP; Function: counters)"
        }
        View::Counters(_) => {
            "counters, label then value (Up/Down: PULL bOOt Str m; Function: the string)"
        }
        View::String(_) => {
            "the last pull's string: StiF kgf/mm, CrEP %/min of the tension (Up/Down; Function: service)"
        }
        View::Service(_) => {
            return Some(format!(
                "service (Up/Down: Cd load-cell code, tArE zero V, CAL1-{CALIBRATION_POINTS} raw kgf, bUS V, Err1-{FAULT_HISTORY} faults, drFt zero drift kgf; Start: self-test again; Function: the tension)"
            ));
        }
        _ => return None,
    };
    Some(text.to_owned())
}

/// What the display shows, in words: the Ready page and its range, or the state's reading.
#[must_use]
pub fn page_text(state: MachineState, outputs: &Outputs) -> String {
    if state != MachineState::Ready {
        return match state {
            MachineState::Holding => {
                // The timer's point (its colon) is on the second digit; a tension's on the third.
                if display::has_point(&outputs.display, 1) {
                    "tension timer (m.ss since at tension; Preset: back to the tension)".to_owned()
                } else {
                    "the measured tension — Up/Down adjust the hold (0.1 kg / 0.2 lb), \
                     Function: constant pull off (LOCK) / on (PULL), Preset: tension timer, \
                     Start releases"
                        .to_owned()
                }
            }
            MachineState::Pulling | MachineState::Releasing => "the measured tension".to_owned(),
            MachineState::CalibrationEntry { .. } => {
                "calibration: key in the gauge's reading with Up/Down, then Start".to_owned()
            }
            MachineState::CalibrationWindow => {
                "CAL? — Function calibrates, any other key skips".to_owned()
            }
            MachineState::Fault(_) => "the fault code".to_owned(),
            other => state_name(other),
        };
    }
    if display::text(&outputs.display).starts_with('P')
        && display::page_value(&outputs.display, b"P ").is_some()
    {
        return "preset page (P n): Up/Down choose, Start loads, hold Preset stores; Function: the information pages".to_owned();
    }
    match page_shown(&outputs.display) {
        Some((Page::Tension, _)) => {
            "tension set point (Up/Down: 0.1 kg / 0.5 lb; Function: next page)".to_owned()
        }
        Some((Page::Speed, _)) => "SP n: pull speed 1 (gentlest) – 9 (fastest)".to_owned(),
        Some((Page::PreStretch, _)) => "PSnn: pre-stretch, % above the tension (0–30)".to_owned(),
        Some((Page::Knot, _)) => {
            "Knnn: knot increase, % (0–20; knot mode: hold Function)".to_owned()
        }
        Some((Page::Unit, _)) => "unit: kg or lb (Up/Down converts the set point)".to_owned(),
        None => "a notice (any key clears it)".to_owned(),
    }
}

/// The flash image in a `--state` file, `None` when there is no file yet.
///
/// # Errors
/// The file cannot be read, or is not a flash image (its size).
fn read_state(path: &std::path::Path) -> Result<Option<[u8; RECORD_LEN]>, Failure> {
    let bytes = match std::fs::read(path) {
        Ok(bytes) => bytes,
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(error) => return Err(Failure::Read { path: path.to_owned(), error }),
    };
    <[u8; RECORD_LEN]>::try_from(bytes.as_slice()).map(Some).map_err(|_| {
        Failure::Usage(format!(
            "--state {}: not a machine's flash image ({} bytes, not {RECORD_LEN})",
            path.display(),
            bytes.len()
        ))
    })
}

/// `taut panel`: the interactive panel, or the script. `Ok(false)` when a script's check
/// failed.
///
/// # Errors
/// Commissioning failed, the script cannot be read or parsed, or the terminal failed.
pub fn main(args: &PanelArgs) -> Status {
    if args.help_script {
        println!("{}", script::FORMAT_HELP);
        return Ok(true);
    }
    let outputs = output::Outputs::new().file("--state", args.state.as_deref()).check()?;
    let stored = match &args.state {
        Some(path) => read_state(path)?,
        None => None,
    };
    // The script is read and parsed first: a bad script fails before the machine powers up.
    let script = match &args.script {
        Some(path) => {
            let read = |error| Failure::Read { path: path.clone(), error };
            let text = if path.as_os_str() == "-" {
                let mut text = String::new();
                std::io::Read::read_to_string(&mut std::io::stdin(), &mut text).map_err(read)?;
                text
            } else {
                std::fs::read_to_string(path).map_err(read)?
            };
            let parsed = script::Script::parse(&text)
                .map_err(|e| Failure::Usage(format!("{}: {e}", path.display())))?;
            Some((path, parsed))
        }
        None => None,
    };
    let mut session = match stored {
        Some(bytes) => PanelSession::from_flash(args.string.into(), args.seed, &bytes),
        None => PanelSession::new(args.string.into(), args.seed, args.flash)
            .map_err(|e| Failure::Message(e.to_string()))?,
    };
    // The machine's flash, kept for the next session (whatever ended this one).
    let keep = |session: &PanelSession| {
        let files: Vec<_> =
            args.state.iter().map(|path| (path.clone(), session.flash().to_vec())).collect();
        outputs.write(&files)
    };
    let Some((path, parsed)) = script else {
        let ran =
            terminal::run(&mut session, args.rate).map_err(|e| Failure::Message(e.to_string()));
        keep(&session)?;
        ran?;
        return Ok(true);
    };
    let mut stdout = std::io::stdout().lock();
    let ran = parsed.run(&mut session, args.frames, &mut stdout);
    keep(&session)?;
    match ran {
        Ok(()) => Ok(true),
        Err(script::ScriptFailure::Io(error)) if error.kind() == std::io::ErrorKind::BrokenPipe => {
            Err(Failure::ClosedStdout)
        }
        Err(failure) => {
            to_stderr(&format!("error: {}: {failure}\n", path.display()));
            Ok(false)
        }
    }
}

//! Scripted front panel: key presses, waits and checks from a text file, run without a
//! terminal, printing a transcript.
//!
//! # Theory of operation
//!
//! [`Script::parse`] reads one command per line into [`Line`]s (syntax errors name the
//! line); [`Script::run`] executes them on a [`PanelSession`], advancing the machine tick by
//! tick as the commands say, and writes a transcript: one line per command with the panel's
//! status after it, one line per state change the machine made meanwhile, and — on `frame`
//! or with `--frames` — the whole panel. An `expect` or `until` that fails stops the run
//! with a [`ScriptFailure`] naming the line, what was expected and what the panel showed, so
//! a script is also a test. The format is [`FORMAT_HELP`].

use std::fmt;
use std::io::{self, Write};

use taut_core::io::{Key, Outputs};
use taut_core::machine::MachineState;

use taut_sim::bench::state_name;
use taut_sim::operator::display;

use super::PanelSession;

/// The script format, as `taut panel --help-script` prints it.
pub const FORMAT_HELP: &str = "\
taut panel script: one command per line; `#` starts a comment; blank lines are skipped.
A line may start with a time in ms since power-up (`500 press start`): the panel first
runs until then (a time in the past is an error).

  wait MS                  run MS milliseconds
  press KEY [N]            tap KEY N times (default 1): down 100 ms, then up 100 ms
  hold KEY MS              hold KEY down for MS ms, then let go (and run 100 ms more)
  down KEY | up KEY        put KEY down / let it go; it stays so until changed
  until STATE [MS]         run until the machine is in STATE and has drawn its panel
                           (1 ms after entering it; fails after MS, default 60000)
  until CHECK [MS]         run until CHECK holds (any check of `expect`, same limit):
                           until display 25.0 3000, until led hold on, until tension 20 30
  expect state STATE       fail unless the machine is in STATE
  expect display TEXT      fail unless the display reads TEXT
  expect led LED on|off    fail unless the lamp is lit / dark (kg lb pull hold fault knot)
  expect beeper on|off     fail unless the beeper sounds / is silent
  expect tension MIN MAX   fail unless the true string tension is within MIN..MAX kgf
  print                    print the panel's status line
  frame                    print the whole panel
  gauge                    print the reference gauge's reading (calibrating by script)
  break                    break the string
  restring                 fit a new string (after a break: first clear the fault with
                           Start and let the carriage come home)

KEY    start, up, down, function (or f), preset (or p)
STATE  self-test, motor-test, homing, calibration-window, calibration-pull,
       calibration-entry, ready, pulling, holding, releasing, fault, or a code E-nn
TEXT   the display as the transcript prints it (25.0, SP 5, CAL?, E-15, kg); put it in
       double quotes when it has inner spaces (\"SP 5\"); outer spaces and case do not
       matter (seven segments have no case)

Example (the calibrated machine shows the previous job's 22.0 kg at power-up):
  until ready 10000
  expect display 22.0
  press up 5
  expect display 22.5
  press start
  until holding 20000
  wait 2000
  expect tension 22.2 22.8
  press start
  until ready 20000
";

/// Tap: how long a `press` holds the key, and how long it then waits with the key up, ms.
pub const PRESS_MS: u64 = 100;
/// Default limit of an `until`, ms.
pub const UNTIL_LIMIT_MS: u64 = 60_000;

/// A lamp on the panel.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Lamp {
    /// Kilograms.
    Kg,
    /// Pounds.
    Lb,
    /// Pulling.
    Pull,
    /// Holding.
    Hold,
    /// Fault.
    Fault,
    /// Knot mode.
    Knot,
}

impl Lamp {
    fn parse(word: &str) -> Option<Self> {
        Some(match word {
            "kg" => Self::Kg,
            "lb" => Self::Lb,
            "pull" | "pulling" => Self::Pull,
            "hold" | "holding" => Self::Hold,
            "fault" => Self::Fault,
            "knot" => Self::Knot,
            _ => return None,
        })
    }

    const fn lit(self, outputs: &Outputs) -> bool {
        let l = outputs.leds;
        match self {
            Self::Kg => l.kg,
            Self::Lb => l.lb,
            Self::Pull => l.pulling,
            Self::Hold => l.holding,
            Self::Fault => l.fault,
            Self::Knot => l.knot,
        }
    }
}

/// A machine state as a script names it: a kind by the core's name
/// ([`MachineState::name`]: `self-test` … `releasing`, `fault` for any fault), or one fault by
/// its code (`E-15`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum StatePattern {
    /// Every state of this kind ([`MachineState::KINDS`]).
    Kind(MachineState),
    /// The fault with this number.
    Fault(u8),
}

impl StatePattern {
    fn parse(word: &str) -> Option<Self> {
        if let Some(kind) = MachineState::KINDS.into_iter().find(|kind| kind.name() == word) {
            return Some(Self::Kind(kind));
        }
        let number = word.strip_prefix("E-").or_else(|| word.strip_prefix("e-"))?;
        Some(Self::Fault(number.parse().ok()?))
    }

    /// Whether `state` is one this pattern names.
    #[must_use]
    pub fn matches(self, state: MachineState) -> bool {
        match (self, state) {
            (Self::Kind(kind), _) => kind.name() == state.name(),
            (Self::Fault(number), MachineState::Fault(code)) => code.number() == number,
            (Self::Fault(_), _) => false,
        }
    }
}

/// A check of what the panel shows.
#[derive(Clone, PartialEq, Debug)]
pub enum Check {
    /// The machine is in a state.
    State(StatePattern),
    /// The display reads this text (outer spaces and case ignored).
    Display(String),
    /// A lamp is lit (`true`) or dark.
    Lamp(Lamp, bool),
    /// The beeper sounds (`true`) or not.
    Beeper(bool),
    /// The true tension is within `[min, max]` kgf.
    Tension(f64, f64),
}

impl Check {
    /// Whether the panel passes the check now.
    #[must_use]
    pub fn holds(&self, session: &PanelSession) -> bool {
        let outputs = session.outputs();
        match self {
            Self::State(pattern) => pattern.matches(session.state()),
            Self::Display(text) => {
                display::text(&outputs.display).trim().eq_ignore_ascii_case(text.trim())
            }
            Self::Lamp(lamp, lit) => lamp.lit(outputs) == *lit,
            Self::Beeper(on) => outputs.beeper == *on,
            Self::Tension(min, max) => {
                let tension = session.bench().twin().truth().tension_kgf;
                tension >= *min && tension <= *max
            }
        }
    }
}

impl fmt::Display for Check {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::State(pattern) => write!(f, "state {pattern:?}"),
            Self::Display(text) => write!(f, "display \"{}\"", text.trim()),
            Self::Lamp(lamp, lit) => write!(f, "lamp {lamp:?} {}", if *lit { "on" } else { "off" }),
            Self::Beeper(on) => write!(f, "beeper {}", if *on { "on" } else { "off" }),
            Self::Tension(min, max) => write!(f, "tension within {min}..{max} kgf"),
        }
    }
}

/// One script command.
#[derive(Clone, PartialEq, Debug)]
pub enum Command {
    /// Run this many ms.
    Wait(u64),
    /// Tap a key this many times.
    Press(Key, u32),
    /// Hold a key this many ms.
    Hold(Key, u64),
    /// Put a key down.
    Down(Key),
    /// Let a key go.
    Up(Key),
    /// Run until the check holds, at most this many ms.
    Until(Check, u64),
    /// Fail unless the check holds.
    Expect(Check),
    /// Print the status line.
    Print,
    /// Print the panel.
    Frame,
    /// Print the reference gauge.
    Gauge,
    /// Break the string.
    Break,
    /// Fit a new string.
    Restring,
}

/// A key's name in scripts.
#[must_use]
pub const fn key_name(key: Key) -> &'static str {
    match key {
        Key::Start => "start",
        Key::Up => "up",
        Key::Down => "down",
        Key::Function => "function",
        Key::Preset => "preset",
    }
}

impl StatePattern {
    /// The pattern's name in scripts.
    #[must_use]
    pub fn name(self) -> String {
        match self {
            Self::Kind(kind) => kind.name().to_owned(),
            Self::Fault(number) => format!("E-{number:02}"),
        }
    }
}

impl Lamp {
    /// The lamp's name in scripts.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Kg => "kg",
            Self::Lb => "lb",
            Self::Pull => "pull",
            Self::Hold => "hold",
            Self::Fault => "fault",
            Self::Knot => "knot",
        }
    }
}

/// The check as a script writes it after `expect` (display text always quoted).
fn check_text(check: &Check) -> String {
    let on = |b: bool| if b { "on" } else { "off" };
    match check {
        Check::State(pattern) => format!("state {}", pattern.name()),
        Check::Display(text) => format!("display \"{text}\""),
        Check::Lamp(lamp, lit) => format!("led {} {}", lamp.name(), on(*lit)),
        Check::Beeper(sounding) => format!("beeper {}", on(*sounding)),
        Check::Tension(min, max) => format!("tension {min} {max}"),
    }
}

/// The command in the script format: what [`Script::parse`] reads back as the same command.
impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Wait(ms) => write!(f, "wait {ms}"),
            Self::Press(key, times) => write!(f, "press {} {times}", key_name(*key)),
            Self::Hold(key, ms) => write!(f, "hold {} {ms}", key_name(*key)),
            Self::Down(key) => write!(f, "down {}", key_name(*key)),
            Self::Up(key) => write!(f, "up {}", key_name(*key)),
            Self::Until(Check::State(pattern), limit) => {
                write!(f, "until {} {limit}", pattern.name())
            }
            Self::Until(Check::Display(text), limit) => {
                write!(f, "until display \"{text}\" {limit}")
            }
            Self::Until(other, limit) => write!(f, "until {} {limit}", check_text(other)),
            Self::Expect(check) => write!(f, "expect {}", check_text(check)),
            Self::Print => f.write_str("print"),
            Self::Frame => f.write_str("frame"),
            Self::Gauge => f.write_str("gauge"),
            Self::Break => f.write_str("break"),
            Self::Restring => f.write_str("restring"),
        }
    }
}

/// One parsed line.
#[derive(Clone, PartialEq, Debug)]
pub struct Line {
    /// 1-based line number in the file.
    pub number: usize,
    /// Run until this time (ms since power-up) first.
    pub at: Option<u64>,
    /// The command.
    pub command: Command,
    /// The line as written (without comment).
    pub text: String,
}

/// A syntax error.
#[derive(Clone, PartialEq, Eq, Debug)]
pub struct ParseError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for ParseError {}

/// Why a run stopped.
#[derive(Debug)]
pub enum ScriptFailure {
    /// An `expect` or `until` failed, or a time was in the past.
    Failed {
        /// 1-based line number.
        line: usize,
        /// What was expected, and what the panel showed.
        message: String,
    },
    /// Writing the transcript failed.
    Io(io::Error),
}

impl fmt::Display for ScriptFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Failed { line, message } => write!(f, "line {line}: {message}"),
            Self::Io(error) => write!(f, "writing the transcript: {error}"),
        }
    }
}

impl std::error::Error for ScriptFailure {}

impl From<io::Error> for ScriptFailure {
    fn from(error: io::Error) -> Self {
        Self::Io(error)
    }
}

/// Splits a line into words; `"…"` is one word (without the quotes).
fn words(text: &str) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
        } else if c == '"' {
            chars.next();
            let mut word = String::new();
            loop {
                match chars.next() {
                    Some('"') => break,
                    Some(c) => word.push(c),
                    None => return Err("unterminated quote".to_owned()),
                }
            }
            out.push(word);
        } else {
            let mut word = String::new();
            while let Some(&c) = chars.peek() {
                if c.is_whitespace() {
                    break;
                }
                word.push(c);
                chars.next();
            }
            out.push(word);
        }
    }
    Ok(out)
}

fn key(word: &str) -> Result<Key, String> {
    Ok(match word.to_ascii_lowercase().as_str() {
        "start" => Key::Start,
        "up" => Key::Up,
        "down" => Key::Down,
        "function" | "f" => Key::Function,
        "preset" | "p" => Key::Preset,
        other => return Err(format!("unknown key `{other}` (start, up, down, function, preset)")),
    })
}

fn number<T: std::str::FromStr>(word: Option<&String>, what: &str) -> Result<T, String> {
    let word = word.ok_or_else(|| format!("missing {what}"))?;
    word.parse().map_err(|_| format!("`{word}` is not a valid {what}"))
}

/// The longest a script may wait, hold or run until, ms (an hour of machine time).
pub const LONGEST_MS: u64 = 3_600_000;
/// The most presses one `press` makes.
pub const MOST_PRESSES: u32 = 1_000;

/// A duration in ms, 1…[`LONGEST_MS`].
fn duration(word: Option<&String>, what: &str) -> Result<u64, String> {
    let ms: u64 = number(word, what)?;
    if (1..=LONGEST_MS).contains(&ms) {
        Ok(ms)
    } else {
        Err(format!("{what} {ms} is not in 1–{LONGEST_MS}"))
    }
}

/// A tension bound, kgf: a finite number in 0–60.
fn tension_bound(word: Option<&String>) -> Result<f64, String> {
    let kgf: f64 = number(word, "tension (kgf)")?;
    if kgf.is_finite() && (0.0..=60.0).contains(&kgf) {
        Ok(kgf)
    } else {
        Err(format!("tension {kgf} is not in 0–60 kgf"))
    }
}

fn on_off(word: Option<&String>) -> Result<bool, String> {
    match word.map(String::as_str) {
        Some("on") => Ok(true),
        Some("off") => Ok(false),
        _ => Err("expected on or off".to_owned()),
    }
}

fn state(word: Option<&String>) -> Result<StatePattern, String> {
    let word = word.ok_or("missing state")?;
    StatePattern::parse(word).ok_or_else(|| format!("unknown state `{word}`"))
}

fn check(words: &[String]) -> Result<Check, String> {
    let what = words.first().map(String::as_str);
    match what {
        Some("state") => Ok(Check::State(state(words.get(1))?)),
        Some("display") => Ok(Check::Display(words.get(1).ok_or("missing display text")?.clone())),
        Some("led" | "lamp") => {
            let name = words.get(1).ok_or("missing lamp")?;
            let lamp = Lamp::parse(name).ok_or_else(|| format!("unknown lamp `{name}`"))?;
            Ok(Check::Lamp(lamp, on_off(words.get(2))?))
        }
        Some("beeper") => Ok(Check::Beeper(on_off(words.get(1))?)),
        Some("tension") => {
            let (min, max) = (tension_bound(words.get(1))?, tension_bound(words.get(2))?);
            if min > max {
                return Err(format!("tension range {min}–{max} is empty"));
            }
            Ok(Check::Tension(min, max))
        }
        _ => Err("expect what? state, display, led, beeper or tension".to_owned()),
    }
}

/// How many words a check takes (`display 25.0`: 2, `led hold on`: 3).
const fn check_words(check: &Check) -> usize {
    match check {
        Check::State(_) | Check::Display(_) | Check::Beeper(_) => 2,
        Check::Lamp(..) | Check::Tension(..) => 3,
    }
}

fn command(words: &[String]) -> Result<Command, String> {
    let name = words.first().map(String::as_str).unwrap_or_default();
    let rest = words.get(1..).unwrap_or_default();
    let arity = |max: usize| {
        if rest.len() > max { Err(format!("too many words after `{name}`")) } else { Ok(()) }
    };
    let command = match name {
        "wait" => {
            arity(1)?;
            Command::Wait(duration(rest.first(), "duration (ms)")?)
        }
        "press" => {
            arity(2)?;
            let times = match rest.get(1) {
                Some(_) => number(rest.get(1), "count")?,
                None => 1,
            };
            if !(1..=MOST_PRESSES).contains(&times) {
                return Err(format!("count {times} is not in 1–{MOST_PRESSES}"));
            }
            Command::Press(key(rest.first().ok_or("missing key")?)?, times)
        }
        "hold" => {
            arity(2)?;
            Command::Hold(
                key(rest.first().ok_or("missing key")?)?,
                duration(rest.get(1), "duration (ms)")?,
            )
        }
        "down" => {
            arity(1)?;
            Command::Down(key(rest.first().ok_or("missing key")?)?)
        }
        "up" => {
            arity(1)?;
            Command::Up(key(rest.first().ok_or("missing key")?)?)
        }
        "until" => {
            let (condition, used) = match rest.first().map(String::as_str) {
                Some("state" | "display" | "led" | "lamp" | "beeper" | "tension") => {
                    let condition = check(rest)?;
                    let used = check_words(&condition);
                    (condition, used)
                }
                _ => (Check::State(state(rest.first())?), 1),
            };
            arity(used + 1)?;
            let limit = match rest.get(used) {
                Some(_) => duration(rest.get(used), "limit (ms)")?,
                None => UNTIL_LIMIT_MS,
            };
            Command::Until(condition, limit)
        }
        "expect" => {
            let check = check(rest)?;
            arity(check_words(&check))?;
            Command::Expect(check)
        }
        "print" | "frame" | "gauge" | "break" | "restring" => {
            arity(0)?;
            match name {
                "print" => Command::Print,
                "frame" => Command::Frame,
                "gauge" => Command::Gauge,
                "restring" => Command::Restring,
                _ => Command::Break,
            }
        }
        other => return Err(format!("unknown command `{other}` (see taut panel --help-script)")),
    };
    Ok(command)
}

/// A parsed script.
#[derive(Clone, PartialEq, Debug, Default)]
pub struct Script {
    /// The commands in order.
    pub lines: Vec<Line>,
}

impl Script {
    /// Parses `text` (see [`FORMAT_HELP`]).
    ///
    /// # Errors
    /// The first line that is not a valid command.
    pub fn parse(text: &str) -> Result<Self, ParseError> {
        let mut lines = Vec::new();
        for (index, raw) in text.lines().enumerate() {
            let number = index + 1;
            let content = raw.split('#').next().unwrap_or_default().trim();
            if content.is_empty() {
                continue;
            }
            let fail = |message: String| ParseError { line: number, message };
            let mut list = words(content).map_err(fail)?;
            let at = match list.first() {
                Some(first) if first.chars().all(|c| c.is_ascii_digit()) => {
                    let at = first.parse().map_err(|_| fail(format!("bad time `{first}`")))?;
                    list.remove(0);
                    Some(at)
                }
                _ => None,
            };
            if list.is_empty() {
                return Err(fail("a time with no command".to_owned()));
            }
            let command = command(&list).map_err(fail)?;
            lines.push(Line { number, at, command, text: content.to_owned() });
        }
        Ok(Self { lines })
    }

    /// Runs the script on `session`, writing the transcript to `out` (and the whole panel
    /// after each command when `frames`).
    ///
    /// # Errors
    /// The first failing `expect` or `until`, a time in the past, or a write error.
    pub fn run(
        &self,
        session: &mut PanelSession,
        frames: bool,
        out: &mut dyn Write,
    ) -> Result<(), ScriptFailure> {
        writeln!(out, "{}", session.status_line())?;
        for line in &self.lines {
            let fail = |message: String| ScriptFailure::Failed { line: line.number, message };
            if let Some(at) = line.at {
                let now = session.now_ms();
                if at < now {
                    return Err(fail(format!("time {at} ms is in the past (now {now} ms)")));
                }
                advance(session, at - now, out)?;
            }
            match &line.command {
                Command::Wait(ms) => advance(session, *ms, out)?,
                Command::Press(key, times) => {
                    for _ in 0..*times {
                        session.press(*key);
                        advance(session, PRESS_MS, out)?;
                        session.release(*key);
                        advance(session, PRESS_MS, out)?;
                    }
                }
                Command::Hold(key, ms) => {
                    session.press(*key);
                    advance(session, *ms, out)?;
                    session.release(*key);
                    advance(session, PRESS_MS, out)?;
                }
                Command::Down(key) => session.press(*key),
                Command::Up(key) => session.release(*key),
                Command::Until(check, limit) => {
                    let mut waited = 0;
                    while !check.holds(session) {
                        if waited >= *limit {
                            return Err(fail(format!(
                                "{check} not reached within {limit} ms; panel: {}",
                                session.status_line()
                            )));
                        }
                        advance(session, 1, out)?;
                        waited += 1;
                    }
                    // A state draws its panel from its first tick on: one more tick so the
                    // panel shows the state reached.
                    if matches!(check, Check::State(_)) && waited > 0 {
                        advance(session, 1, out)?;
                    }
                }
                Command::Expect(check) => {
                    if !check.holds(session) {
                        return Err(fail(format!(
                            "expected {check}; panel: {}",
                            session.status_line()
                        )));
                    }
                }
                Command::Print | Command::Frame => {}
                Command::Gauge => {
                    let reading = session.read_gauge();
                    writeln!(out, "gauge: {reading:.2} kgf")?;
                }
                Command::Break => session.bench_mut().twin_mut().break_string(),
                Command::Restring => session.bench_mut().twin_mut().fit_new_string(),
            }
            writeln!(out, "{:<28} | {}", line.text, session.status_line())?;
            if frames || line.command == Command::Frame {
                for row in session.frame() {
                    writeln!(out, "{row}")?;
                }
            }
        }
        Ok(())
    }
}

/// Runs `ms` ticks, writing a transcript line at every state change.
fn advance(session: &mut PanelSession, ms: u64, out: &mut dyn Write) -> io::Result<()> {
    for _ in 0..ms {
        let before = session.state();
        session.tick();
        let after = session.state();
        if after != before {
            writeln!(
                out,
                "{:<28} | t={:9.3} s  {} -> {}",
                "",
                session.now_ms() as f64 / 1_000.0,
                state_name(before),
                state_name(after)
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_command() {
        let script = Script::parse(
            "# a comment\n\
             500 press start\n\
             wait 2000\n\
             hold up 800   # trailing comment\n\
             press down 3\n\
             down f\n\
             up function\n\
             until holding 20000\n\
             until display \"SP 5\"\n\
             until led hold on 500\n\
             until tension 20 30\n\
             expect state E-15\n\
             expect display 25.0\n\
             expect led hold on\n\
             expect beeper off\n\
             expect tension 24.5 25.5\n\
             print\nframe\ngauge\nbreak\n",
        )
        .unwrap();
        let commands: Vec<&Command> = script.lines.iter().map(|l| &l.command).collect();
        assert_eq!(script.lines[0].at, Some(500));
        assert_eq!(script.lines[0].number, 2);
        assert_eq!(
            commands,
            vec![
                &Command::Press(Key::Start, 1),
                &Command::Wait(2000),
                &Command::Hold(Key::Up, 800),
                &Command::Press(Key::Down, 3),
                &Command::Down(Key::Function),
                &Command::Up(Key::Function),
                &Command::Until(Check::State(StatePattern::Kind(MachineState::Holding)), 20_000),
                &Command::Until(Check::Display("SP 5".to_owned()), UNTIL_LIMIT_MS),
                &Command::Until(Check::Lamp(Lamp::Hold, true), 500),
                &Command::Until(Check::Tension(20.0, 30.0), UNTIL_LIMIT_MS),
                &Command::Expect(Check::State(StatePattern::Fault(15))),
                &Command::Expect(Check::Display("25.0".to_owned())),
                &Command::Expect(Check::Lamp(Lamp::Hold, true)),
                &Command::Expect(Check::Beeper(false)),
                &Command::Expect(Check::Tension(24.5, 25.5)),
                &Command::Print,
                &Command::Frame,
                &Command::Gauge,
                &Command::Break,
            ]
        );
    }

    #[test]
    fn errors_name_the_line() {
        let cases = [
            ("wait\n", "missing duration"),
            ("\n\npress sideways\n", "unknown key"),
            ("until nowhere\n", "unknown state"),
            ("expect led moon on\n", "unknown lamp"),
            ("expect beeper loud\n", "on or off"),
            ("jump 3\n", "unknown command"),
            ("wait 10 20\n", "too many words"),
            ("500\n", "no command"),
            ("expect display \"25.0\n", "unterminated quote"),
        ];
        for (text, message) in cases {
            let error = Script::parse(text).unwrap_err();
            assert!(error.message.contains(message), "{text:?}: {error}");
            assert_eq!(error.line, text.lines().count(), "{text:?}");
        }
    }

    #[test]
    fn state_patterns_match_their_states() {
        use taut_core::machine::FaultCode;
        let pattern = |word: &str| StatePattern::parse(word).unwrap();
        let broken = MachineState::Fault(FaultCode::StringBreak);
        assert!(pattern("calibration-pull").matches(MachineState::CalibrationPull { point: 2 }));
        assert!(pattern("fault").matches(broken));
        assert!(pattern("E-15").matches(broken));
        assert!(!pattern("E-16").matches(broken));
        assert!(!pattern("ready").matches(MachineState::Releasing));
        assert!(!pattern("E-15").matches(MachineState::Ready));
        assert_eq!(StatePattern::parse("standby"), None);
        // Every kind's name parses back to it, and the script prints it the same way.
        for kind in MachineState::KINDS {
            assert_eq!(pattern(kind.name()), StatePattern::Kind(kind));
            assert_eq!(pattern(kind.name()).name(), kind.name());
        }
    }
}

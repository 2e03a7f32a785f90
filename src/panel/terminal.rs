//! The interactive front panel: the keyboard as the panel's keys, the terminal as its glass,
//! the machine on the twin paced to the wall clock.
//!
//! # Theory of operation
//!
//! [`run`] puts the terminal in raw mode on the alternate screen (restored by a guard on
//! every exit path, panics included) and loops: read the pending key events, run machine
//! ticks until machine time catches up with `rate ×` the wall-clock time since start
//! (at most [`MAX_CATCH_UP_TICKS`] per pass — if the host cannot keep up, the clock is
//! re-anchored rather than bursting, and the frame says "behind"), redraw the panel about
//! every [`FRAME_MS`], and sleep in `event::poll` until the next pass.
//!
//! **Key levels from key events.** The machine wants contact levels every millisecond; a
//! terminal sends events. [`KeyHolds`] turns them into levels: with the keyboard
//! enhancement protocol a key is down from its press to its release event; without it each
//! press (or auto-repeat) holds the key for [`super::TAP_MS`] of machine time, so a held
//! key stays down while the terminal repeats it. `F` and `P` hold Function and Preset for
//! [`super::LONG_PRESS_HOLD_MS`]: the panel's long presses (knot mode, store preset).

use std::io::{self, IsTerminal as _, Write};
use std::time::{Duration, Instant};

use crossterm::event::{
    self, Event, KeyCode, KeyEvent, KeyEventKind, KeyModifiers, KeyboardEnhancementFlags,
    PopKeyboardEnhancementFlags, PushKeyboardEnhancementFlags,
};
use crossterm::{cursor, queue, style, terminal};
use taut_core::io::{Key, Keys};

use super::{LONG_PRESS_HOLD_MS, PanelSession, TAP_MS};

/// Redraw period, ms (≈ 30 frames a second).
pub const FRAME_MS: u64 = 33;
/// The most machine ticks run in one pass before the clock is re-anchored.
pub const MAX_CATCH_UP_TICKS: u32 = 500;

/// What a keyboard key does on the panel.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Action {
    /// A panel key: held while the keyboard key is (or for a tap).
    Key(Key),
    /// A panel key held for a long press.
    Long(Key),
    /// Break the string.
    BreakString,
    /// Leave the panel.
    Quit,
}

/// The panel action of a keyboard key, if any: arrows, `+`/`-`, `k`/`j` for Up/Down;
/// space, Enter, `s` for Start; `f`/`F` Function (short/long); `p`/`P` Preset; `b` breaks
/// the string; `q`, Esc, Ctrl-C quit.
#[must_use]
pub fn action(code: KeyCode, modifiers: KeyModifiers) -> Option<Action> {
    if modifiers.contains(KeyModifiers::CONTROL) && code == KeyCode::Char('c') {
        return Some(Action::Quit);
    }
    Some(match code {
        KeyCode::Up | KeyCode::Right | KeyCode::Char('+' | '=' | 'k') => Action::Key(Key::Up),
        KeyCode::Down | KeyCode::Left | KeyCode::Char('-' | '_' | 'j') => Action::Key(Key::Down),
        KeyCode::Enter | KeyCode::Char(' ' | 's') => Action::Key(Key::Start),
        KeyCode::Char('f') => Action::Key(Key::Function),
        KeyCode::Char('F') => Action::Long(Key::Function),
        KeyCode::Char('p') => Action::Key(Key::Preset),
        KeyCode::Char('P') => Action::Long(Key::Preset),
        KeyCode::Char('b') => Action::BreakString,
        KeyCode::Char('q' | 'Q') | KeyCode::Esc => Action::Quit,
        _ => return None,
    })
}

const fn index(key: Key) -> usize {
    match key {
        Key::Start => 0,
        Key::Up => 1,
        Key::Down => 2,
        Key::Function => 3,
        Key::Preset => 4,
    }
}

/// Key levels from key events (see the module docs). Times are machine milliseconds.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct KeyHolds {
    /// Whether release events arrive (keyboard enhancement active).
    releases: bool,
    /// Per key: down until this time (exclusive).
    until: [u64; 5],
    /// Per key: the hold is a long press (release events do not end it).
    long: [bool; 5],
}

impl KeyHolds {
    /// No key down; `releases` says whether the terminal sends release events.
    #[must_use]
    pub const fn new(releases: bool) -> Self {
        Self { releases, until: [0; 5], long: [false; 5] }
    }

    /// A press, auto-repeat or release of `key` at machine time `now`.
    pub fn event(&mut self, key: Key, kind: KeyEventKind, now: u64) {
        let i = index(key);
        if self.long[i] && self.until[i] > now {
            return;
        }
        self.long[i] = false;
        self.until[i] = match (self.releases, kind) {
            (true, KeyEventKind::Press) => u64::MAX,
            (true, KeyEventKind::Release) => now,
            (true, KeyEventKind::Repeat) => self.until[i],
            (false, KeyEventKind::Release) => self.until[i],
            (false, _) => self.until[i].max(now + TAP_MS),
        };
    }

    /// A long press of `key` at `now`.
    pub fn long_press(&mut self, key: Key, now: u64) {
        let i = index(key);
        self.long[i] = true;
        self.until[i] = now + LONG_PRESS_HOLD_MS;
    }

    /// The key levels at machine time `now`.
    #[must_use]
    pub fn keys_at(&self, now: u64) -> Keys {
        let mut keys = Keys::NONE;
        for key in Key::ALL {
            if self.until[index(key)] > now {
                keys = keys.with(key);
            }
        }
        keys
    }
}

/// Restores the terminal when dropped.
struct Screen {
    enhanced: bool,
}

impl Screen {
    fn enter() -> io::Result<Self> {
        terminal::enable_raw_mode()?;
        let mut out = io::stdout();
        let entered =
            queue!(out, terminal::EnterAlternateScreen, cursor::Hide).and_then(|()| out.flush());
        let mut screen = Self { enhanced: false };
        entered?;
        if terminal::supports_keyboard_enhancement().unwrap_or(false) {
            queue!(
                out,
                PushKeyboardEnhancementFlags(
                    KeyboardEnhancementFlags::REPORT_EVENT_TYPES
                        | KeyboardEnhancementFlags::DISAMBIGUATE_ESCAPE_CODES
                )
            )?;
            out.flush()?;
            screen.enhanced = true;
        }
        Ok(screen)
    }
}

impl Drop for Screen {
    fn drop(&mut self) {
        let mut out = io::stdout();
        if self.enhanced {
            let _ = queue!(out, PopKeyboardEnhancementFlags);
        }
        let _ = queue!(out, cursor::Show, terminal::LeaveAlternateScreen);
        let _ = out.flush();
        let _ = terminal::disable_raw_mode();
    }
}

/// Runs the interactive panel until the user quits.
///
/// # Errors
/// No terminal on stdin/stdout, or a terminal I/O error.
pub fn run(session: &mut PanelSession, rate: f64) -> io::Result<()> {
    if !io::stdin().is_terminal() || !io::stdout().is_terminal() {
        return Err(io::Error::other(
            "the interactive panel needs a terminal; use --script FILE to run without one",
        ));
    }
    if !(rate.is_finite() && rate > 0.0 && rate <= 100.0) {
        return Err(io::Error::other("--rate must be within 0–100"));
    }
    let screen = Screen::enter()?;
    let mut holds = KeyHolds::new(screen.enhanced);
    let mut anchor = (Instant::now(), session.now_ms());
    let mut last_draw: Option<Instant> = None;
    let mut behind = false;
    let mut out = io::stdout();
    queue!(out, terminal::Clear(terminal::ClearType::All))?;
    loop {
        while event::poll(Duration::ZERO)? {
            match event::read()? {
                Event::Key(KeyEvent { code, modifiers, kind, .. }) => {
                    let now = session.now_ms();
                    match action(code, modifiers) {
                        Some(Action::Quit) if kind != KeyEventKind::Release => return Ok(()),
                        Some(Action::Key(key)) => holds.event(key, kind, now),
                        Some(Action::Long(key)) if kind == KeyEventKind::Press => {
                            holds.long_press(key, now);
                        }
                        Some(Action::BreakString) if kind == KeyEventKind::Press => {
                            session.bench_mut().twin_mut().break_string();
                        }
                        _ => {}
                    }
                }
                Event::Resize(..) => queue!(out, terminal::Clear(terminal::ClearType::All))?,
                _ => {}
            }
        }
        let elapsed_ms = anchor.0.elapsed().as_secs_f64() * 1_000.0 * rate;
        let target = anchor.1 + elapsed_ms as u64;
        let mut ticks = 0;
        while session.now_ms() < target && ticks < MAX_CATCH_UP_TICKS {
            session.set_keys(holds.keys_at(session.now_ms()));
            session.tick();
            ticks += 1;
        }
        if session.now_ms() < target {
            behind = true;
            anchor = (Instant::now(), session.now_ms());
        }
        if last_draw.is_none_or(|t| t.elapsed() >= Duration::from_millis(FRAME_MS)) {
            last_draw = Some(Instant::now());
            let mut lines = session.frame();
            lines.push(format!(
                "  rate {rate}x{}{}   keys down: {:05b}",
                if screen.enhanced { ", key releases seen" } else { "" },
                if behind { ", host behind real time" } else { "" },
                session.keys().bits()
            ));
            for (row, line) in lines.iter().enumerate() {
                queue!(
                    out,
                    cursor::MoveTo(0, u16::try_from(row).unwrap_or(u16::MAX)),
                    style::Print(line),
                    terminal::Clear(terminal::ClearType::UntilNewLine)
                )?;
            }
            out.flush()?;
        }
        event::poll(Duration::from_millis(2))?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_hold_for_the_tap_time_and_repeats_extend() {
        let mut holds = KeyHolds::new(false);
        holds.event(Key::Up, KeyEventKind::Press, 1_000);
        assert_eq!(holds.keys_at(1_000), Keys::NONE.with(Key::Up));
        assert_eq!(holds.keys_at(1_000 + TAP_MS), Keys::NONE);
        holds.event(Key::Up, KeyEventKind::Press, 1_100);
        assert!(holds.keys_at(1_100 + TAP_MS - 1).contains(Key::Up));
    }

    #[test]
    fn with_release_events_a_key_is_down_until_released() {
        let mut holds = KeyHolds::new(true);
        holds.event(Key::Start, KeyEventKind::Press, 0);
        assert!(holds.keys_at(60_000).contains(Key::Start));
        holds.event(Key::Start, KeyEventKind::Release, 60_000);
        assert_eq!(holds.keys_at(60_000), Keys::NONE);
    }

    #[test]
    fn long_press_outlasts_its_release() {
        let mut holds = KeyHolds::new(true);
        holds.long_press(Key::Function, 0);
        holds.event(Key::Function, KeyEventKind::Release, 10);
        assert!(holds.keys_at(LONG_PRESS_HOLD_MS - 1).contains(Key::Function));
        assert!(!holds.keys_at(LONG_PRESS_HOLD_MS).contains(Key::Function));
    }

    #[test]
    fn bindings() {
        let none = KeyModifiers::NONE;
        assert_eq!(action(KeyCode::Up, none), Some(Action::Key(Key::Up)));
        assert_eq!(action(KeyCode::Char('-'), none), Some(Action::Key(Key::Down)));
        assert_eq!(action(KeyCode::Char(' '), none), Some(Action::Key(Key::Start)));
        assert_eq!(action(KeyCode::Enter, none), Some(Action::Key(Key::Start)));
        assert_eq!(
            action(KeyCode::Char('F'), KeyModifiers::SHIFT),
            Some(Action::Long(Key::Function))
        );
        assert_eq!(action(KeyCode::Char('c'), KeyModifiers::CONTROL), Some(Action::Quit));
        assert_eq!(action(KeyCode::Char('x'), none), None);
    }
}

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
//! terminal sends events. [`KeyHolds`] turns them into levels: every press is queued as a
//! tap of its own ([`super::TAP_MS`] down, [`super::TAP_GAP_MS`] up), so presses that come
//! faster than the machine's debounce can take them are delayed, never lost; a key the
//! terminal auto-repeats is held down (its events come closer than [`AUTO_REPEAT_MS`]), so
//! the panel's own repeat runs. With the keyboard enhancement protocol a key is down from
//! its press to its release event. `F` and `P` hold Function and Preset for
//! [`super::LONG_PRESS_HOLD_MS`]: the panel's long presses (knot mode, store preset). A
//! terminal smaller than the panel is refused at start, and told so while it is resized
//! too small.

use std::io::{self, IsTerminal as _, Write};
use std::time::{Duration, Instant};

use crossterm::event::{
    self, Event, KeyCode, KeyEvent, KeyEventKind, KeyModifiers, KeyboardEnhancementFlags,
    PopKeyboardEnhancementFlags, PushKeyboardEnhancementFlags,
};
use crossterm::{cursor, queue, style, terminal};
use taut_core::io::{Key, Keys};

use super::{FRAME_COLUMNS, FRAME_ROWS, LONG_PRESS_HOLD_MS, PanelSession, TAP_GAP_MS, TAP_MS};

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
    /// Fit a new string.
    Restring,
    /// Leave the panel.
    Quit,
}

/// The panel action of a keyboard key, if any: arrows, `+`/`-`, `k`/`j` for Up/Down;
/// space, Enter, `s` for Start; `f`/`F` Function (short/long); `p`/`P` Preset; `b` breaks
/// the string, `n` fits a new one; `q`, Esc, Ctrl-C quit.
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
        KeyCode::Char('n') => Action::Restring,
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

/// A press and a repeat closer than this are one held key (a terminal's auto-repeat runs
/// at 25–40 ms; a person tapping quickly, ≥ 80 ms apart), ms.
pub const AUTO_REPEAT_MS: u64 = 70;

/// One key's schedule: the intervals it is down, in order.
#[derive(Clone, PartialEq, Eq, Debug, Default)]
struct Schedule {
    /// `[from, until)` intervals of machine time, oldest first.
    down: std::collections::VecDeque<(u64, u64)>,
    /// The last press or repeat event, ms.
    last_event: Option<u64>,
    /// A long press runs until the end of the last interval; releases do not end it.
    long: bool,
}

impl Schedule {
    /// When the key is next free to go down for a new tap.
    fn next_free(&self, now: u64) -> u64 {
        self.down.back().map_or(now, |&(_, until)| (until + TAP_GAP_MS).max(now))
    }

    /// Queues a tap.
    fn tap(&mut self, now: u64, length: u64) {
        let from = self.next_free(now);
        self.down.push_back((from, from + length));
    }
}

/// Key levels from key events (see the module docs). Times are machine milliseconds.
///
/// Every press is queued as its own tap of [`TAP_MS`] down and [`TAP_GAP_MS`] up after the
/// taps already queued, so quick presses are never merged or lost. A press that follows the
/// previous event of the same key within [`AUTO_REPEAT_MS`] is the terminal repeating a
/// held key: it extends the key's current hold instead, so the machine sees one long press
/// and repeats by itself. With release events (keyboard enhancement), a key is down from its
/// press (queued like a tap) until its release, and at least [`TAP_MS`].
#[derive(Clone, PartialEq, Eq, Debug)]
pub struct KeyHolds {
    /// Whether release events arrive (keyboard enhancement active).
    releases: bool,
    keys: [Schedule; 5],
}

impl KeyHolds {
    /// No key down; `releases` says whether the terminal sends release events.
    #[must_use]
    pub fn new(releases: bool) -> Self {
        Self { releases, keys: Default::default() }
    }

    /// A press, auto-repeat or release of `key` at machine time `now`.
    pub fn event(&mut self, key: Key, kind: KeyEventKind, now: u64) {
        let releases = self.releases;
        let s = &mut self.keys[index(key)];
        if s.long && s.down.back().is_some_and(|&(_, until)| until > now) {
            return;
        }
        s.long = false;
        let repeat = kind == KeyEventKind::Repeat
            || s.last_event.is_some_and(|t| now.saturating_sub(t) < AUTO_REPEAT_MS);
        match (releases, kind) {
            (true, KeyEventKind::Release) => {
                if let Some(last) = s.down.back_mut() {
                    if last.1 == u64::MAX {
                        last.1 = now.max(last.0 + TAP_MS);
                    }
                }
            }
            (true, _) => {
                if !repeat || s.down.back().is_none_or(|&(_, until)| until != u64::MAX) {
                    let from = s.next_free(now);
                    s.down.push_back((from, u64::MAX));
                }
            }
            (false, KeyEventKind::Release) => {}
            (false, _) => {
                match s.down.back_mut() {
                    // The terminal repeating a held key: keep it down.
                    Some(last) if repeat && last.1 + TAP_GAP_MS >= now => {
                        last.1 = last.1.max(now + super::HOLD_MS);
                    }
                    _ => s.tap(now, TAP_MS),
                }
            }
        }
        if kind != KeyEventKind::Release {
            s.last_event = Some(now);
        }
    }

    /// A long press of `key` at `now`.
    pub fn long_press(&mut self, key: Key, now: u64) {
        let s = &mut self.keys[index(key)];
        s.tap(now, LONG_PRESS_HOLD_MS);
        s.long = true;
    }

    /// The key levels at machine time `now` (intervals that have ended are dropped).
    pub fn keys_at(&mut self, now: u64) -> Keys {
        let mut keys = Keys::NONE;
        for key in Key::ALL {
            let s = &mut self.keys[index(key)];
            while s.down.front().is_some_and(|&(_, until)| until <= now) {
                s.down.pop_front();
            }
            if s.down.front().is_some_and(|&(from, _)| from <= now) {
                keys = keys.with(key);
            }
        }
        keys
    }

    /// Taps still queued, all keys.
    #[must_use]
    pub fn queued(&self) -> usize {
        self.keys.iter().map(|s| s.down.len()).sum()
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
    let too_small = |(columns, rows): (u16, u16)| columns < FRAME_COLUMNS || rows < FRAME_ROWS;
    let size = terminal::size()?;
    if too_small(size) {
        return Err(io::Error::other(format!(
            "the terminal is {}×{}; the panel needs at least {FRAME_COLUMNS}×{FRAME_ROWS} (columns × rows)",
            size.0, size.1
        )));
    }
    let mut small = false;
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
                        Some(Action::Restring) if kind == KeyEventKind::Press => {
                            session.restring();
                        }
                        _ => {}
                    }
                }
                Event::Resize(columns, rows) => {
                    small = too_small((columns, rows));
                    queue!(out, terminal::Clear(terminal::ClearType::All))?;
                }
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
            let mut lines = if small {
                vec![format!(
                    "The terminal is too small for the panel: make it at least {FRAME_COLUMNS}×{FRAME_ROWS} (q quits)."
                )]
            } else {
                session.frame()
            };
            if !small {
                lines.push(format!(
                    "  rate {rate}x{}{}   keys down: {:05b}   taps queued: {}",
                    if screen.enhanced { ", key releases seen" } else { "" },
                    if behind { ", host behind real time" } else { "" },
                    session.keys().bits(),
                    holds.queued()
                ));
            }
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
    fn quick_presses_are_queued_and_each_one_counts() {
        let mut holds = KeyHolds::new(false);
        // 28 presses 80 ms apart: faster than a tap plus its gap, slower than auto-repeat.
        for i in 0..28 {
            holds.event(Key::Up, KeyEventKind::Press, 1_000 + i * 80);
        }
        let mut taps = 0;
        let mut was_down = false;
        for now in 1_000..10_000 {
            let down = holds.keys_at(now).contains(Key::Up);
            if down && !was_down {
                taps += 1;
            }
            was_down = down;
        }
        assert_eq!(taps, 28);
        assert_eq!(holds.queued(), 0);
    }

    #[test]
    fn an_auto_repeated_key_is_held() {
        let mut holds = KeyHolds::new(false);
        holds.event(Key::Up, KeyEventKind::Press, 0);
        // The terminal starts repeating after 500 ms, every 33 ms, for two seconds.
        let mut t = 500;
        while t < 2_500 {
            holds.event(Key::Up, KeyEventKind::Press, t);
            t += 33;
        }
        assert!(holds.keys_at(10).contains(Key::Up));
        let held = (600..2_400).all(|now| holds.keys_at(now).contains(Key::Up));
        assert!(held, "a held key stays down for the panel's own repeat");
    }

    #[test]
    fn with_release_events_a_key_is_down_until_released() {
        let mut holds = KeyHolds::new(true);
        holds.event(Key::Start, KeyEventKind::Press, 0);
        assert!(holds.keys_at(30_000).contains(Key::Start));
        holds.event(Key::Start, KeyEventKind::Release, 60_000);
        assert_eq!(holds.keys_at(60_000), Keys::NONE);
        // A press and release in the same instant still make a tap.
        holds.event(Key::Up, KeyEventKind::Press, 70_000);
        holds.event(Key::Up, KeyEventKind::Release, 70_000);
        assert!(holds.keys_at(70_000 + TAP_MS - 1).contains(Key::Up));
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

//! The front panel: debounced keys with hold-to-repeat, seven-segment text, the beeper.
//!
//! # Theory of operation
//!
//! **Keys.** The firmware reports raw contact levels every tick ([`Keys`]). Each key has an
//! integrator ([`KeyPad`]): it counts up while the contact reads closed and down while it
//! reads open, and the key's debounced level changes only when the count reaches
//! [`DEBOUNCE_MS`] or zero — contact bounce shorter than that never produces a second
//! press. A debounced press becomes one [`KeyEvent::Press`]. While exactly one key is held,
//! Up and Down repeat ([`KeyEvent::Repeat`]) after [`REPEAT_DELAY_MS`], every
//! [`REPEAT_PERIOD_MS`], and every [`REPEAT_FAST_PERIOD_MS`] once held for
//! [`REPEAT_FAST_AFTER_MS`]; the other keys report one [`KeyEvent::Long`] when held for
//! [`LONG_PRESS_MS`]. At most one event leaves per tick: presses that debounce in the same
//! tick wait their turn (Start first), so none is lost.
//!
//! **Display.** Four digits, each a [`Segments`] bitmap (segment `a` = bit 0 … `g` = bit 6,
//! decimal point bit 7). [`glyph`] maps the characters the machine writes (digits, the
//! letters of `CAL`, `E-`, `SP`, `PS`, `Kn`, `P`, `Unit`, `kg`, `lb`, `GOOd`, `dOnE`, …) to
//! bitmaps; [`text`] renders four characters, [`tenths`] a value with one decimal
//! (`25.0`, `110.0` → `110.0` needs the point on the third digit), [`labelled`] a short
//! label and a number (`SP 5`, `PS10`), [`fault`] `E-nn`, [`clock`] a timer as `m:ss` with
//! the decimal point for the colon (`t1.05`, `12.05`).
//!
//! **Beeper.** A [`Beeper`] plays one [`Beep`] pattern at a time from its start time: a
//! click on a key press, a long tone at tension, three tones for a fault.

use crate::io::{Display, Key, Keys, Segments};

/// Milliseconds a contact must read steadily closed (or open) to change the key's state.
pub const DEBOUNCE_MS: u8 = 20;
/// Hold time before Up/Down start repeating.
pub const REPEAT_DELAY_MS: u16 = 500;
/// Repeat period while held.
pub const REPEAT_PERIOD_MS: u16 = 100;
/// Hold time after which the repeat speeds up.
pub const REPEAT_FAST_AFTER_MS: u16 = 2_000;
/// Repeat period once sped up.
pub const REPEAT_FAST_PERIOD_MS: u16 = 25;
/// Hold time of Start, Function or Preset that counts as a long press.
pub const LONG_PRESS_MS: u16 = 1_500;

/// One thing the operator did with the keys.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum KeyEvent {
    /// The key went down.
    Press(Key),
    /// Up or Down is being held: one more step.
    Repeat(Key),
    /// Start, Function or Preset has been held for [`LONG_PRESS_MS`].
    Long(Key),
}

impl KeyEvent {
    /// The key the event is about.
    #[must_use]
    pub const fn key(self) -> Key {
        match self {
            Self::Press(key) | Self::Repeat(key) | Self::Long(key) => key,
        }
    }

    /// Whether this is a step of Up (`+1`) or Down (`-1`), by press or repeat.
    #[must_use]
    pub const fn step(self) -> i8 {
        match self {
            Self::Press(Key::Up) | Self::Repeat(Key::Up) => 1,
            Self::Press(Key::Down) | Self::Repeat(Key::Down) => -1,
            _ => 0,
        }
    }
}

/// Whether `key` repeats when held (Up, Down) rather than reporting a long press.
const fn repeats(key: Key) -> bool {
    matches!(key, Key::Up | Key::Down)
}

/// The debouncer and repeat generator for the five keys.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct KeyPad {
    /// Per key, 0 ..= [`DEBOUNCE_MS`]: how long the contact has read closed, net.
    integrators: [u8; 5],
    /// The debounced levels.
    down: Keys,
    /// Debounced presses not yet reported.
    pending: Keys,
    /// How long the single held key has been held, ms (saturating).
    held_ms: u16,
    /// Whether the long press of the held key has been reported.
    long_sent: bool,
}

impl KeyPad {
    /// All keys up.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            integrators: [0; 5],
            down: Keys::NONE,
            pending: Keys::NONE,
            held_ms: 0,
            long_sent: false,
        }
    }

    /// The debounced key levels.
    #[must_use]
    pub const fn down(&self) -> Keys {
        self.down
    }

    /// Whether any key is (debounced) down or any press is waiting to be reported.
    #[must_use]
    pub const fn busy(&self) -> bool {
        !self.down.is_empty() || !self.pending.is_empty()
    }

    /// One millisecond: take the raw levels, return at most one event.
    pub fn tick(&mut self, raw: Keys) -> Option<KeyEvent> {
        let before = self.down;
        // Bound: five keys.
        for (key, integrator) in Key::ALL.iter().zip(self.integrators.iter_mut()) {
            if raw.contains(*key) {
                *integrator = integrator.saturating_add(1).min(DEBOUNCE_MS);
            } else {
                *integrator = integrator.saturating_sub(1);
            }
            if *integrator >= DEBOUNCE_MS {
                self.down = self.down.with(*key);
            } else if *integrator == 0 {
                self.down = Keys::from_bits(self.down.bits() & !key_bit(*key));
            }
        }
        let pressed = self.down.bits() & !before.bits();
        self.pending = Keys::from_bits(self.pending.bits() | pressed);
        if pressed != 0 || self.down != before {
            self.held_ms = 0;
            self.long_sent = false;
        } else {
            self.held_ms = self.held_ms.saturating_add(1);
        }

        // Presses first, one per tick, in `Key::ALL` order.
        if let Some(key) = Key::ALL.iter().copied().find(|key| self.pending.contains(*key)) {
            self.pending = Keys::from_bits(self.pending.bits() & !key_bit(key));
            return Some(KeyEvent::Press(key));
        }

        // Hold behaviour only with exactly one key down.
        let held = single(self.down)?;
        if repeats(held) {
            let period = if self.held_ms >= REPEAT_FAST_AFTER_MS {
                REPEAT_FAST_PERIOD_MS
            } else {
                REPEAT_PERIOD_MS
            };
            let since = self.held_ms.checked_sub(REPEAT_DELAY_MS)?;
            (since.checked_rem(period) == Some(0) && since > 0).then_some(KeyEvent::Repeat(held))
        } else if self.held_ms >= LONG_PRESS_MS && !self.long_sent {
            self.long_sent = true;
            Some(KeyEvent::Long(held))
        } else {
            None
        }
    }

    /// The invariant every reachable key pad satisfies (integrators within their range).
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.integrators.iter().all(|&count| count <= DEBOUNCE_MS)
    }

    /// A key pad with arbitrary internal state (for proofs and the fuzzer): integrators are
    /// clamped into range, so the result always satisfies [`KeyPad::is_valid`].
    #[must_use]
    pub fn from_parts(
        integrators: [u8; 5],
        down: Keys,
        pending: Keys,
        held_ms: u16,
        long_sent: bool,
    ) -> Self {
        let mut clamped = integrators;
        for count in &mut clamped {
            *count = (*count).min(DEBOUNCE_MS);
        }
        Self { integrators: clamped, down, pending, held_ms, long_sent }
    }
}

/// The bit of `key` in a [`Keys`] set.
const fn key_bit(key: Key) -> u8 {
    Keys::NONE.with(key).bits()
}

/// The only key in `keys`, if exactly one.
fn single(keys: Keys) -> Option<Key> {
    let mut found = None;
    // Bound: five keys.
    for key in Key::ALL {
        if keys.contains(key) {
            if found.is_some() {
                return None;
            }
            found = Some(key);
        }
    }
    found
}

/// A blank digit.
pub const BLANK: Segments = Segments(0);
/// The decimal-point bit.
pub const DECIMAL_POINT: u8 = 0x80;

/// The bitmap of a character; characters without a seven-segment form are blank.
#[must_use]
pub const fn glyph(character: u8) -> Segments {
    Segments(match character {
        b'0' | b'O' => 0x3F,
        b'1' | b'I' => 0x06,
        b'2' => 0x5B,
        b'3' => 0x4F,
        b'4' => 0x66,
        b'5' | b'S' | b's' => 0x6D,
        b'6' => 0x7D,
        b'7' => 0x07,
        b'8' | b'B' => 0x7F,
        b'9' | b'g' => 0x6F,
        b'A' | b'a' => 0x77,
        b'b' => 0x7C,
        b'C' => 0x39,
        b'c' => 0x58,
        b'd' | b'D' => 0x5E,
        b'E' | b'e' => 0x79,
        b'F' | b'f' => 0x71,
        b'G' => 0x3D,
        b'H' => 0x76,
        b'h' => 0x74,
        b'i' => 0x04,
        b'J' | b'j' => 0x1E,
        b'K' | b'k' => 0x75,
        b'L' | b'l' => 0x38,
        b'n' | b'N' => 0x54,
        b'o' => 0x5C,
        b'P' | b'p' => 0x73,
        b'r' | b'R' => 0x50,
        b't' | b'T' => 0x78,
        b'U' => 0x3E,
        b'u' => 0x1C,
        b'y' | b'Y' => 0x6E,
        b'-' => 0x40,
        b'_' => 0x08,
        b'?' => 0x53,
        _ => 0x00,
    })
}

/// Four characters, left to right.
#[must_use]
pub const fn text(characters: &[u8; 4]) -> Display {
    [glyph(characters[0]), glyph(characters[1]), glyph(characters[2]), glyph(characters[3])]
}

/// The ASCII digit of `number % 10`: the digit of a label numbered on the panel (`CAL1`,
/// `C2-1`, `Err3`), whose count is kept to nine where it is defined.
#[must_use]
#[allow(clippy::cast_possible_truncation, reason = "a remainder of 10 fits any integer type")]
pub const fn last_digit(number: usize) -> u8 {
    digit((number % 10) as u32)
}

/// The ASCII digit of `value % 10`.
const fn digit(value: u32) -> u8 {
    match value.checked_rem(10) {
        Some(1) => b'1',
        Some(2) => b'2',
        Some(3) => b'3',
        Some(4) => b'4',
        Some(5) => b'5',
        Some(6) => b'6',
        Some(7) => b'7',
        Some(8) => b'8',
        Some(9) => b'9',
        _ => b'0',
    }
}

/// A value in tenths, right-aligned with one decimal: `250` → ` 25.0`, `1100` → `110.0`,
/// `-3` → `-0.3`. Out of the display's range (below −99.9 or above 999.9) shows `----`.
#[must_use]
pub fn tenths(value: i32) -> Display {
    if !(-999..=9_999).contains(&value) {
        return text(b"----");
    }
    let magnitude = value.unsigned_abs();
    let mut out = [BLANK; 4];
    // Digits right to left: tenths, ones (with the point), tens, hundreds.
    let mut rest = magnitude;
    let mut position = 4usize;
    // Bound: four digits.
    for place in 0..4u8 {
        position = position.saturating_sub(1);
        let Some(slot) = out.get_mut(position) else { break };
        if place < 2 || rest > 0 {
            let mut segments = glyph(digit(rest));
            if place == 1 {
                segments.0 |= DECIMAL_POINT;
            }
            *slot = segments;
        } else {
            if value < 0 {
                *slot = glyph(b'-');
            }
            break;
        }
        rest = rest.checked_div(10).unwrap_or(0);
    }
    out
}

/// A value in hundredths, right-aligned with two decimals: `2004` → `20.04`, `500` →
/// ` 5.00` (the calibration entry: a reference gauge reads to 0.01 kg). Outside 0–99.99
/// shows `----`.
#[must_use]
pub fn hundredths(value: i32) -> Display {
    let Ok(magnitude) = u32::try_from(value) else { return text(b"----") };
    if magnitude > 9_999 {
        return text(b"----");
    }
    let mut out = [BLANK; 4];
    let mut rest = magnitude;
    // Digits right to left: hundredths, tenths, ones (with the point), tens (blank if 0).
    for (place, slot) in out.iter_mut().rev().enumerate() {
        if place < 3 || rest > 0 {
            let mut segments = glyph(digit(rest));
            if place == 2 {
                segments.0 |= DECIMAL_POINT;
            }
            *slot = segments;
        }
        rest = rest.checked_div(10).unwrap_or(0);
    }
    out
}

/// A two-character label and a number up to 99, right-aligned: `SP 5`, `PS10`, `P 3`.
#[must_use]
pub const fn labelled(label: &[u8; 2], value: u8) -> Display {
    let tens = value / 10;
    let ones_digit = digit(value as u32);
    let tens_glyph = if tens == 0 { BLANK } else { glyph(digit(tens as u32)) };
    [glyph(label[0]), glyph(label[1]), tens_glyph, glyph(ones_digit)]
}

/// A whole number right-aligned on four digits, leading zeros blank (`  12`, `1234`); from
/// 9 999 on the display stays at `9999`.
#[must_use]
pub const fn integer(value: u32) -> Display {
    let capped = if value > 9_999 { 9_999 } else { value };
    [
        leading_digit(capped, 1_000),
        leading_digit(capped, 100),
        leading_digit(capped, 10),
        glyph(digit(capped)),
    ]
}

/// The digit of `value` at `place` (1 000, 100, 10), blank while `value` is below it.
const fn leading_digit(value: u32, place: u32) -> Segments {
    match value.checked_div(place) {
        Some(shifted) if value >= place => glyph(digit(shifted)),
        _ => BLANK,
    }
}

/// A timer of `seconds` as `m:ss` on four digits, the decimal point standing for the colon:
/// under ten minutes a one-letter `label` leads (`t1.05` = the tension timer at 1 min 5 s),
/// from ten minutes the label gives way to the minutes' tens (`12.05`); from 99:59 on the
/// display stays at `99.59`.
#[must_use]
pub const fn clock(label: u8, seconds: u32) -> Display {
    let capped = if seconds > 5_999 { 5_999 } else { seconds };
    let minutes = capped / 60;
    let rest = capped % 60;
    let lead = if minutes < 10 { glyph(label) } else { glyph(digit(minutes / 10)) };
    let ones = Segments(glyph(digit(minutes)).0 | DECIMAL_POINT);
    [lead, ones, glyph(digit(rest / 10)), glyph(digit(rest))]
}

/// `E-nn` for a fault number.
#[must_use]
pub const fn fault(number: u8) -> Display {
    code(b'E', number)
}

/// `n-nn` for a notice number.
#[must_use]
pub const fn notice(number: u8) -> Display {
    code(b'n', number)
}

/// `L-nn`: a letter, a dash and two digits.
const fn code(letter: u8, number: u8) -> Display {
    let tens = (number / 10) % 10;
    [glyph(letter), glyph(b'-'), glyph(digit(tens as u32)), glyph(digit(number as u32))]
}

/// A beeper sound.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Beep {
    /// 15 ms: a key was accepted.
    Click,
    /// 400 ms: tension reached.
    AtTension,
    /// Three 200 ms tones 200 ms apart: a fault latched.
    Fault,
    /// Two 100 ms tones: a refused action or a notice.
    Refused,
}

impl Beep {
    /// Whether the beeper sounds `elapsed` ms after the pattern started.
    #[must_use]
    pub const fn sounding(self, elapsed: u32) -> bool {
        match self {
            Self::Click => elapsed < 15,
            Self::AtTension => elapsed < 400,
            Self::Fault => elapsed < 1_000 && (elapsed / 200).is_multiple_of(2),
            Self::Refused => elapsed < 300 && (elapsed / 100).is_multiple_of(2),
        }
    }
}

/// Plays one [`Beep`] at a time.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Beeper {
    playing: Option<(Beep, u32)>,
}

impl Beeper {
    /// Silent.
    #[must_use]
    pub const fn new() -> Self {
        Self { playing: None }
    }

    /// Starts `beep` at `now_ms`, replacing whatever was playing.
    pub fn play(&mut self, beep: Beep, now_ms: u32) {
        self.playing = Some((beep, now_ms));
    }

    /// Whether the beeper sounds at `now_ms`; a finished pattern is forgotten.
    pub fn sounding(&mut self, now_ms: u32) -> bool {
        let Some((beep, started)) = self.playing else { return false };
        let elapsed = now_ms.wrapping_sub(started);
        if elapsed >= 1_000 {
            self.playing = None;
            return false;
        }
        beep.sounding(elapsed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hundredths_show_two_decimals_and_refuse_what_does_not_fit() {
        assert_eq!(
            hundredths(2_004),
            [glyph(b'2'), Segments(glyph(b'0').0 | DECIMAL_POINT), glyph(b'0'), glyph(b'4')]
        );
        assert_eq!(
            hundredths(500),
            [BLANK, Segments(glyph(b'5').0 | DECIMAL_POINT), glyph(b'0'), glyph(b'0')]
        );
        assert_eq!(
            hundredths(7),
            [BLANK, Segments(glyph(b'0').0 | DECIMAL_POINT), glyph(b'0'), glyph(b'7')]
        );
        assert_eq!(
            hundredths(9_999),
            [glyph(b'9'), Segments(glyph(b'9').0 | DECIMAL_POINT), glyph(b'9'), glyph(b'9')]
        );
        for bad in [-1, 10_000, i32::MIN, i32::MAX] {
            assert_eq!(hundredths(bad), text(b"----"), "{bad}");
        }
    }

    fn run(pad: &mut KeyPad, raw: Keys, ms: u32) -> heapless::Vec<(u32, KeyEvent), 256> {
        let mut events = heapless::Vec::new();
        for t in 0..ms {
            if let Some(event) = pad.tick(raw) {
                assert!(events.push((t, event)).is_ok(), "more than 256 key events");
            }
        }
        events
    }

    #[test]
    fn a_burst_of_distinct_quick_presses_counts_every_press() {
        // 25 presses of Up, each 30 ms down and 30 ms up (an operator tapping as fast as a
        // finger can, ≈ 16 a second): each is a press of its own, none merged.
        for (down, up) in [(30_u32, 30_u32), (DEBOUNCE_MS.into(), DEBOUNCE_MS.into()), (60, 25)] {
            let mut pad = KeyPad::new();
            let mut presses = 0;
            for _ in 0..25 {
                let pressed = run(&mut pad, Keys::NONE.with(Key::Up), down);
                let released = run(&mut pad, Keys::NONE, up);
                presses += pressed
                    .iter()
                    .chain(released.iter())
                    .filter(|(_, e)| *e == KeyEvent::Press(Key::Up))
                    .count();
            }
            assert_eq!(presses, 25, "{down} ms down, {up} ms up");
        }
        // Bounce shorter than the debounce time is no press.
        let mut pad = KeyPad::new();
        let mut presses = 0;
        for _ in 0..25 {
            let bounce = run(&mut pad, Keys::NONE.with(Key::Up), u32::from(DEBOUNCE_MS) - 1);
            let gap = run(&mut pad, Keys::NONE, u32::from(DEBOUNCE_MS));
            presses += bounce.len() + gap.len();
        }
        assert_eq!(presses, 0);
    }

    #[test]
    fn a_press_is_reported_once_after_the_debounce_time() {
        let mut pad = KeyPad::new();
        let events = run(&mut pad, Keys::NONE.with(Key::Start), 1_000);
        assert_eq!(events.as_slice(), &[(u32::from(DEBOUNCE_MS) - 1, KeyEvent::Press(Key::Start))]);
    }

    #[test]
    fn bounce_shorter_than_the_debounce_time_is_ignored() {
        let mut pad = KeyPad::new();
        let start = Keys::NONE.with(Key::Start);
        // Contact chatters: 3 ms closed, 3 ms open, for 60 ms.
        for t in 0..60 {
            let raw = if (t / 3) % 2 == 0 { start } else { Keys::NONE };
            assert_eq!(pad.tick(raw), None, "t = {t}");
        }
        // Then a clean, steady press: exactly one event.
        let events = run(&mut pad, start, 100);
        assert_eq!(events.len(), 1);
        // A release that chatters does not produce a second press.
        for t in 0..60 {
            let raw = if (t / 3) % 2 == 0 { Keys::NONE } else { start };
            assert!(pad.tick(raw).is_none());
        }
    }

    #[test]
    fn up_repeats_and_speeds_up() {
        let mut pad = KeyPad::new();
        let events = run(&mut pad, Keys::NONE.with(Key::Up), 3_000);
        assert_eq!(events[0].1, KeyEvent::Press(Key::Up));
        let repeats: heapless::Vec<u32, 256> = events.iter().skip(1).map(|(t, _)| *t).collect();
        assert!(events.iter().skip(1).all(|(_, e)| *e == KeyEvent::Repeat(Key::Up)));
        // First repeat a little after the delay.
        let first = repeats[0];
        assert_eq!(
            first,
            u32::from(DEBOUNCE_MS) - 1 + u32::from(REPEAT_DELAY_MS) + u32::from(REPEAT_PERIOD_MS)
        );
        // Slow repeats before 2 s, fast after.
        assert_eq!(repeats[1] - repeats[0], u32::from(REPEAT_PERIOD_MS));
        let last_two = &repeats[repeats.len() - 2..];
        assert_eq!(last_two[1] - last_two[0], u32::from(REPEAT_FAST_PERIOD_MS));
    }

    #[test]
    fn function_held_gives_one_long_press() {
        let mut pad = KeyPad::new();
        let events = run(&mut pad, Keys::NONE.with(Key::Function), 5_000);
        assert_eq!(
            events.iter().map(|(_, e)| *e).collect::<heapless::Vec<_, 4>>().as_slice(),
            &[KeyEvent::Press(Key::Function), KeyEvent::Long(Key::Function)]
        );
    }

    #[test]
    fn simultaneous_presses_are_all_reported() {
        let mut pad = KeyPad::new();
        let both = Keys::NONE.with(Key::Up).with(Key::Preset);
        let events = run(&mut pad, both, 100);
        let keys: heapless::Vec<KeyEvent, 4> = events.iter().map(|(_, e)| *e).collect();
        assert_eq!(keys.as_slice(), &[KeyEvent::Press(Key::Up), KeyEvent::Press(Key::Preset)]);
    }

    #[test]
    fn numbers_render() {
        assert_eq!(tenths(250), [BLANK, glyph(b'2'), Segments(glyph(b'5').0 | 0x80), glyph(b'0')]);
        assert_eq!(tenths(50), [BLANK, BLANK, Segments(glyph(b'5').0 | 0x80), glyph(b'0')]);
        assert_eq!(
            tenths(1100),
            [glyph(b'1'), glyph(b'1'), Segments(glyph(b'0').0 | 0x80), glyph(b'0')]
        );
        assert_eq!(tenths(-3), [BLANK, glyph(b'-'), Segments(glyph(b'0').0 | 0x80), glyph(b'3')]);
        assert_eq!(
            tenths(-123),
            [glyph(b'-'), glyph(b'1'), Segments(glyph(b'2').0 | 0x80), glyph(b'3')]
        );
        assert_eq!(tenths(10_000), text(b"----"));
        assert_eq!(tenths(-1_000), text(b"----"));
        assert_eq!(fault(3), text(b"E-03"));
        assert_eq!(fault(17), text(b"E-17"));
        assert_eq!(labelled(b"SP", 5), text(b"SP 5"));
        assert_eq!(labelled(b"PS", 30), text(b"PS30"));
    }

    /// REQ-SM-10: `m.ss` with the point for the colon, a label under ten minutes, the
    /// minutes' tens from ten, `99.59` at most.
    #[test]
    fn a_clock_shows_minutes_and_seconds() {
        let with_colon = |chars: &[u8; 4]| {
            let [a, b, c, d] = text(chars);
            [a, Segments(b.0 | DECIMAL_POINT), c, d]
        };
        assert_eq!(clock(b't', 0), with_colon(b"t000"));
        assert_eq!(clock(b't', 59), with_colon(b"t059"));
        assert_eq!(clock(b't', 60), with_colon(b"t100"));
        assert_eq!(clock(b't', 61), with_colon(b"t101"));
        assert_eq!(clock(b'r', 599), with_colon(b"r959"));
        assert_eq!(clock(b't', 600), with_colon(b"1000"));
        assert_eq!(clock(b't', 725), with_colon(b"1205"));
        assert_eq!(clock(b't', 5_999), with_colon(b"9959"));
        assert_eq!(clock(b't', 6_000), with_colon(b"9959"));
        assert_eq!(clock(b't', u32::MAX), with_colon(b"9959"));
        // Every second of the first 100 minutes reads back as itself.
        let value = |segments: Segments| {
            (0..10u32).find(|&d| glyph(digit(d)).0 == segments.0 & !DECIMAL_POINT).unwrap_or(99)
        };
        for seconds in 0..6_000u32 {
            let [lead, ones, tens_s, ones_s] = clock(b't', seconds);
            let minutes_tens = if seconds < 600 { 0 } else { value(lead) };
            let read = (minutes_tens * 10 + value(ones)) * 60 + value(tens_s) * 10 + value(ones_s);
            assert_eq!(read, seconds);
            assert_ne!(ones.0 & DECIMAL_POINT, 0);
        }
    }

    #[test]
    fn integers_are_right_aligned_and_capped() {
        assert_eq!(integer(0), [BLANK, BLANK, BLANK, glyph(b'0')]);
        assert_eq!(integer(12), [BLANK, BLANK, glyph(b'1'), glyph(b'2')]);
        assert_eq!(integer(105), [BLANK, glyph(b'1'), glyph(b'0'), glyph(b'5')]);
        assert_eq!(integer(1_234), text(b"1234"));
        assert_eq!(integer(9_999), text(b"9999"));
        assert_eq!(integer(u32::MAX), text(b"9999"));
    }

    #[test]
    fn every_digit_has_a_distinct_glyph() {
        for a in b'0'..=b'9' {
            for b in b'0'..=b'9' {
                assert_eq!(a == b, glyph(a) == glyph(b));
            }
        }
    }

    #[test]
    fn beeper_patterns() {
        let mut beeper = Beeper::new();
        beeper.play(Beep::Fault, 1_000);
        let on: u32 = (1_000..3_000).map(|t| u32::from(beeper.sounding(t))).sum();
        assert_eq!(on, 600, "three 200 ms tones");
        assert!(!beeper.sounding(5_000));
    }
}

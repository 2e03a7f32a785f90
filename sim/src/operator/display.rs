//! Reading the machine's 7-segment display as a person does: ASCII art, text and numbers,
//! all computed from the segment bitmaps the machine outputs.
//!
//! # Theory of operation
//!
//! The machine never hands out strings: its display is four [`Segments`] bitmaps
//! (`Outputs::display`, segment `a` = bit 0 … `g` = bit 6, decimal point bit 7), exactly what
//! the firmware shifts into the display driver. Everything here works backwards from those
//! bits, as a person reading the panel does, so what the host shows is what the glass would
//! show — a wrong bitmap in the core shows up as a wrong picture here.
//!
//! - [`art`] draws the four digits as three lines of ASCII, each digit three characters wide
//!   plus a column for its decimal point:
//!
//!   ```text
//!        _   _   _
//!        _| |_  | |
//!       |_   _|.|_|
//!   ```
//!
//! - [`text`] reads the digits as characters. Some bitmaps are both a digit and a letter
//!   (`0`/`O`, `5`/`S`, `9`/`g`); like a reader, it takes the letter when the glyph stands
//!   next to letters — its left neighbour is a letter, or it leads a word whose next glyph is
//!   an unambiguous letter — and the digit otherwise: `SP 5`, `PS10`, `kn15`, ` kg `, `GOOd`,
//!   `E-05`, `25.0`. Seven segments have no case: a letter reads in the case its glyph
//!   resembles (`k`, `L`, `b`, `n`), so compare text case-insensitively.
//! - [`number`] reads a right-aligned number with at most one decimal (`25.0` → 250 tenths,
//!   ` SP 5` → none) and [`page_value`] the number of a labelled page (`SP 5` → 5).

#![allow(
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    reason = "index arithmetic on the four fixed digits and decimal values of at most four digits"
)]

use taut_core::io::{Display, Segments};
use taut_core::machine::panel::{DECIMAL_POINT, glyph};

/// The characters the decoder knows, in order of preference for a bitmap that several share
/// (digits first, so a lone `5` reads as five).
const CHARACTERS: &[u8] = b"0123456789AbCcdEFGHhiJkLnoPrtUuy-_?";

/// Letters whose bitmap is also a digit's, with that digit.
const AMBIGUOUS: [(u8, u8); 3] = [(b'O', b'0'), (b'S', b'5'), (b'g', b'9')];

/// What one digit's bitmap (without its decimal point) reads as.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Reading {
    /// All segments off.
    Blank,
    /// A digit that is also a letter (`0`/`O`, `5`/`S`, `9`/`g`).
    Either { digit: u8, letter: u8 },
    /// A digit only.
    Digit(u8),
    /// A letter only.
    Letter(u8),
    /// A sign or punctuation (`-`, `_`, `?`).
    Mark(u8),
    /// A bitmap no character of the machine uses.
    Unknown,
}

fn reading(segments: Segments) -> Reading {
    let bits = segments.0 & !DECIMAL_POINT;
    if bits == 0 {
        return Reading::Blank;
    }
    let Some(&character) = CHARACTERS.iter().find(|&&c| glyph(c).0 == bits) else {
        return Reading::Unknown;
    };
    if let Some(&(letter, digit)) = AMBIGUOUS.iter().find(|&&(_, d)| d == character) {
        return Reading::Either { digit, letter };
    }
    match character {
        b'0'..=b'9' => Reading::Digit(character),
        b'-' | b'_' | b'?' => Reading::Mark(character),
        _ => Reading::Letter(character),
    }
}

/// Whether digit `index` has its decimal point lit.
#[must_use]
pub fn has_point(display: &Display, index: usize) -> bool {
    display.get(index).is_some_and(|s| s.0 & DECIMAL_POINT != 0)
}

/// The display as characters, four of them plus a `.` after each lit decimal point
/// (`" 25.0"` is `[' ', '2', '5', '.', '0']`). Blank digits are spaces, bitmaps the machine
/// never writes are `#`.
#[must_use]
pub fn text(display: &Display) -> String {
    let readings: Vec<Reading> = display.iter().map(|s| reading(*s)).collect();
    let mut letters = [false; 4];
    let mut out = String::new();
    for (index, segments) in display.iter().enumerate() {
        let left_is_letter = index > 0 && letters[index - 1];
        let leads = index == 0 || readings[index - 1] == Reading::Blank;
        let right_is_letter = matches!(readings.get(index + 1), Some(Reading::Letter(_)));
        let character = match readings[index] {
            Reading::Blank => b' ',
            Reading::Either { digit, letter } => {
                // A glyph with the decimal point is a number's (`t1.05`: the timer's
                // minutes), whatever stands left of it.
                let pointed = segments.0 & DECIMAL_POINT != 0;
                if !pointed && (left_is_letter || (leads && right_is_letter)) {
                    letters[index] = true;
                    letter
                } else {
                    digit
                }
            }
            Reading::Digit(c) | Reading::Mark(c) => c,
            Reading::Letter(c) => {
                letters[index] = true;
                c
            }
            Reading::Unknown => b'#',
        };
        out.push(char::from(character));
        if segments.0 & DECIMAL_POINT != 0 {
            out.push('.');
        }
    }
    out
}

/// The value of digit `segments` if it shows a digit.
fn digit_value(segments: Segments) -> Option<i32> {
    match reading(segments) {
        Reading::Digit(c) | Reading::Either { digit: c, .. } => Some(i32::from(c - b'0')),
        _ => None,
    }
}

/// A right-aligned number on the display, in tenths when the third digit carries the
/// decimal point (`25.0` → 250, `-0.3` → −3, `110.0` → 1100), else as an integer (`1234`).
/// `None` when anything but digits, a leading minus and blanks is shown.
#[must_use]
pub fn number(display: &Display) -> Option<i32> {
    let mut value: i32 = 0;
    let mut negative = false;
    let mut seen_digit = false;
    for segments in display {
        match reading(*segments) {
            Reading::Blank if !seen_digit && !negative => {}
            Reading::Mark(b'-') if !seen_digit && !negative => negative = true,
            _ => {
                let digit = digit_value(*segments)?;
                value = value * 10 + digit;
                seen_digit = true;
            }
        }
    }
    if !seen_digit {
        return None;
    }
    Some(if negative { -value } else { value })
}

/// Tenths shown on a one-decimal number display (`25.0` → 250); `None` unless the third
/// digit carries the decimal point and the digits read as a number.
#[must_use]
pub fn tenths(display: &Display) -> Option<i32> {
    if !has_point(display, 2) {
        return None;
    }
    number(display)
}

/// Hundredths shown on a two-decimal number display (`20.04` → 2004, the calibration
/// entry); `None` unless the second digit carries the decimal point and the digits read as a
/// number.
#[must_use]
pub fn hundredths(display: &Display) -> Option<i32> {
    if !has_point(display, 1) {
        return None;
    }
    number(display)
}

/// The number of a labelled page (`SP 5` → 5, `PS10` → 10, `Kn15` → 15, `P 3` → 3) if the
/// first two digits show `label` as the machine draws it.
#[must_use]
pub fn page_value(display: &Display, label: &[u8; 2]) -> Option<u8> {
    let [first, second, tens, ones] = *display;
    if first != glyph(label[0]) || second != glyph(label[1]) {
        return None;
    }
    let tens = if tens.0 == 0 { 0 } else { digit_value(tens)? };
    let ones = digit_value(ones)?;
    u8::try_from(tens * 10 + ones).ok()
}

/// The display as three lines of ASCII art (see the module docs), 16 characters each.
#[must_use]
pub fn art(display: &Display) -> [String; 3] {
    let mut lines = [String::new(), String::new(), String::new()];
    for segments in display {
        let lit = |bit: u8| segments.0 & (1 << bit) != 0;
        let mark = |bit: u8, on: char| if lit(bit) { on } else { ' ' };
        // a = 0, b = 1, c = 2, d = 3, e = 4, f = 5, g = 6, point = 7.
        lines[0].extend([' ', mark(0, '_'), ' ', ' ']);
        lines[1].extend([mark(5, '|'), mark(6, '_'), mark(1, '|'), ' ']);
        lines[2].extend([mark(4, '|'), mark(3, '_'), mark(2, '|'), mark(7, '.')]);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use taut_core::machine::panel::{fault, labelled, tenths as show_tenths, text as show};

    #[test]
    fn reads_what_the_machine_writes() {
        assert_eq!(text(&show_tenths(250)), " 25.0");
        assert_eq!(text(&show_tenths(1100)), "110.0");
        assert_eq!(text(&show_tenths(-3)), " -0.3");
        assert_eq!(text(&labelled(b"SP", 5)), "SP 5");
        assert_eq!(text(&labelled(b"PS", 10)), "PS10");
        assert_eq!(text(&labelled(b"Kn", 15)), "kn15");
        assert_eq!(text(&labelled(b"P ", 3)), "P  3");
        assert_eq!(text(&show(b" kg ")), " kg ");
        assert_eq!(text(&show(b" lb ")), " Lb ");
        assert_eq!(text(&show(b"tESt")), "tESt");
        assert_eq!(text(&show(b"CAL?")), "CAL?");
        assert_eq!(text(&show(b"HOnE")), "HOnE");
        assert_eq!(text(&fault(5)), "E-05");
        assert_eq!(text(&show(b"----")), "----");
    }

    #[test]
    fn numbers_round_trip_over_the_whole_display_range() {
        for value in -999..=9_999 {
            assert_eq!(tenths(&show_tenths(value)), Some(value), "{value}");
        }
        assert_eq!(tenths(&labelled(b"SP", 5)), None);
        assert_eq!(tenths(&fault(3)), None);
    }

    #[test]
    fn labelled_pages_read_back() {
        for value in 0..=99 {
            assert_eq!(page_value(&labelled(b"PS", value), b"PS"), Some(value));
            assert_eq!(page_value(&labelled(b"PS", value), b"SP"), None);
        }
    }

    #[test]
    fn art_draws_each_segment_in_its_place() {
        let eight = [Segments(0xFF); 4];
        assert_eq!(art(&eight), [" _  ".repeat(4), "|_| ".repeat(4), "|_|.".repeat(4)]);
        let one = taut_core::machine::panel::text(b"1111");
        assert_eq!(art(&one), ["    ".repeat(4), "  | ".repeat(4), "  | ".repeat(4)]);
        assert_eq!(art(&show_tenths(250))[2], "    |_   _|.|_| ");
    }
}

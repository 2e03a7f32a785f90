//! The per-pull log and the string-length counter.
//!
//! # Theory of operation
//!
//! Every pull that reaches tension and is released leaves one [`PullRecord`] (target,
//! tension when released, time to tension, peak, how long it was held, the operator's
//! adjustment during the hold, string drawn) in a fixed-capacity ring buffer
//! ([`PullLog`], a `heapless::Deque`): when it is full the oldest record is dropped, so the
//! log always holds the most recent pulls and never allocates. The log lives in RAM only;
//! the lifetime totals go to the persisted [`crate::store::Counters`].
//!
//! The string drawn through the machine is measured by the quadrature encoder the string
//! turns ([`crate::io::Inputs::string_counter`], a 16-bit counter that wraps). The machine
//! takes the wrapping difference of consecutive readings every tick — far less than half
//! the counter's range can pass in 1 ms — so the wrap never loses counts, and converts the
//! pull's total to millimetres with [`STRING_COUNTS_PER_MM`] when the pull completes.

use heapless::Deque;

use crate::machine::string::{CreepRate, Stiffness};
use crate::units::Kgf;

/// Counts of the string encoder per millimetre of string: a 100-line encoder (400 counts
/// per turn in quadrature) on a measuring wheel of 50 mm circumference. At the fastest
/// carriage speed (≈ 81 mm/s) that is ≈ 0.65 counts per tick, far below the 32 768 a tick
/// could take before the 16-bit difference became ambiguous.
pub const STRING_COUNTS_PER_MM: i32 = 8;

/// Default capacity of the pull log: a whole racket — a tennis or badminton racket takes
/// 18–22 tension pulls and 4 knots — with room to spare (28 × 18 B = 504 B of the
/// firmware's 8 KiB of RAM; 32 entries did not fit beside the stringer's head).
pub const PULL_LOG_CAPACITY: usize = 28;

/// A tension as the log keeps it: hundredths of a kgf in 16 bits (±327.67 kgf), rounded —
/// finer than the display's tenth, half the size of a [`Kgf`].
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct LoggedKgf(i16);

impl LoggedKgf {
    /// `tension` rounded to the hundredth, saturating at ±327.67 kgf.
    #[must_use]
    pub fn from_kgf(tension: Kgf) -> Self {
        let hundredths = tension.to_hundredths_rounded();
        let clamped = hundredths.clamp(i32::from(i16::MIN), i32::from(i16::MAX));
        Self(i16::try_from(clamped).unwrap_or_default())
    }

    /// The tension.
    #[must_use]
    pub fn to_kgf(self) -> Kgf {
        Kgf::from_hundredths(i32::from(self.0))
    }

    /// Hundredths of a kgf.
    #[must_use]
    pub const fn hundredths(self) -> i16 {
        self.0
    }
}

/// One completed pull: 18 bytes.
/// Tensions are [`LoggedKgf`]; the times and the length are 16-bit: no pull reaches tension
/// later than its time limit (at most [`crate::machine::pull_timeout`]'s 64.4 s, below
/// 65.5 s), no hold is near 18 hours and no pull draws 65 m of string; the conversions
/// saturate all the same.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct PullRecord {
    /// The tension held at the end (the final target with the hold's adjustment).
    pub target: LoggedKgf,
    /// The measured tension when the operator released.
    pub reached: LoggedKgf,
    /// The highest tension measured during the pull.
    pub peak: LoggedKgf,
    /// The operator's adjustment of the target during the hold (Up/Down): `target` less
    /// this is what the pull was set to.
    pub adjust: LoggedKgf,
    /// Milliseconds from Start to "at tension".
    pub time_to_tension_ms: u16,
    /// Seconds from "at tension" to the release (the tension timer when released).
    pub held_s: u16,
    /// String drawn during the pull, millimetres.
    pub string_mm: u16,
    /// The string's stiffness near the set tension (see [`super::string`]), if measured.
    pub stiffness: Option<Stiffness>,
    /// The string's creep during the hold (see [`super::string`]), if the hold was long
    /// enough at constant pull.
    pub creep: Option<CreepRate>,
}

/// The most recent pulls, oldest first.
#[derive(Clone, Debug, Default)]
pub struct PullLog<const N: usize> {
    entries: Deque<PullRecord, N>,
}

impl<const N: usize> PullLog<N> {
    /// An empty log.
    #[must_use]
    pub const fn new() -> Self {
        Self { entries: Deque::new() }
    }

    /// Appends `record`, dropping the oldest when full.
    pub fn push(&mut self, record: PullRecord) {
        if self.entries.is_full() {
            let _oldest = self.entries.pop_front();
        }
        // After making room the push cannot fail (only a zero-capacity log refuses it,
        // which then simply logs nothing).
        let _refused = self.entries.push_back(record);
    }

    /// The records, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &PullRecord> {
        self.entries.iter()
    }

    /// The most recent record.
    #[must_use]
    pub fn last(&self) -> Option<&PullRecord> {
        self.entries.back()
    }

    /// The record `back` pulls before the latest (0: the latest).
    #[must_use]
    pub fn back(&self, back: usize) -> Option<&PullRecord> {
        let index = self.len().checked_sub(back)?.checked_sub(1)?;
        self.entries.iter().nth(index)
    }

    /// Number of records held.
    #[must_use]
    pub fn len(&self) -> usize {
        self.entries.storage_len()
    }

    /// Whether the log is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Millimetres of string for `counts` encoder counts, rounded to the nearest millimetre;
/// negative totals (string pulled back) count as zero.
#[must_use]
pub fn string_mm(counts: i32) -> u32 {
    let half = STRING_COUNTS_PER_MM / 2;
    let mm = counts.max(0).saturating_add(half).checked_div(STRING_COUNTS_PER_MM).unwrap_or(0);
    u32::try_from(mm).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_keeps_the_latest() {
        let mut log = PullLog::<3>::new();
        for i in 0..5u16 {
            log.push(PullRecord { time_to_tension_ms: i, ..PullRecord::default() });
        }
        let kept: heapless::Vec<u16, 3> = log.iter().map(|r| r.time_to_tension_ms).collect();
        assert_eq!(kept.as_slice(), &[2, 3, 4]);
        assert_eq!(log.len(), 3);
        assert_eq!(log.last().map(|r| r.time_to_tension_ms), Some(4));
        assert_eq!(log.back(0).map(|r| r.time_to_tension_ms), Some(4));
        assert_eq!(log.back(2).map(|r| r.time_to_tension_ms), Some(2));
        assert_eq!(log.back(3), None);
        assert_eq!(log.back(usize::MAX), None);
    }

    #[test]
    fn logged_tensions_keep_the_hundredth_and_saturate() {
        for hundredths in -6_000..=6_000 {
            let logged = LoggedKgf::from_kgf(Kgf::from_hundredths(hundredths));
            assert_eq!(i32::from(logged.hundredths()), hundredths);
            assert_eq!(logged.to_kgf(), Kgf::from_hundredths(hundredths));
        }
        assert_eq!(LoggedKgf::from_kgf(Kgf::MAX).hundredths(), i16::MAX);
        assert_eq!(LoggedKgf::from_kgf(Kgf::MIN).hundredths(), i16::MIN);
        assert_eq!(LoggedKgf::from_kgf(Kgf::from_milli(25_004)).hundredths(), 2_500);
        assert_eq!(LoggedKgf::from_kgf(Kgf::from_milli(25_006)).hundredths(), 2_501);
        assert_eq!(size_of::<PullRecord>(), 18);
    }

    #[test]
    fn counts_round_to_millimetres() {
        assert_eq!(string_mm(0), 0);
        assert_eq!(string_mm(-50), 0);
        assert_eq!(string_mm(3), 0);
        assert_eq!(string_mm(4), 1);
        assert_eq!(string_mm(8 * 250), 250);
    }
}

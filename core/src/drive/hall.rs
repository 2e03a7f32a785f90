//! Hall-sensor decoding: three bits → one of six rotor sectors, with glitch rejection and
//! skipped-sector detection.
//!
//! # Theory of operation
//!
//! Three Hall sensors 120 electrical degrees apart split one electrical revolution into six
//! 60° **sectors**. Each sensor is high for half a revolution, so exactly one or two of the
//! three bits are set in every valid state; `000` and `111` cannot occur on a healthy motor
//! and mean an unplugged connector, a dead sensor supply or a shorted line.
//!
//! The paper measured forward rotation (phases A → B → C) as
//! `101 → 100 → 110 → 010 → 011 → 001` (bits written A B C). taut numbers the sectors in that
//! order, so forward rotation always steps the sector number by +1 (mod 6) and reverse
//! rotation by −1.
//!
//! Hall lines run beside the motor phases and pick up switching noise. Two filters keep a
//! glitch from ever reaching the commutation table:
//!
//! 1. [`vote`]: the firmware reads the three lines [`HALL_VOTES`] times back to back and a
//!    bit is taken as set when the majority of reads saw it set (VESC's scheme).
//! 2. [`HallFilter`]: a voted code is **accepted** only after it has been seen on
//!    [`HALL_CONFIRM_READS`] consecutive calls. At 3 700 rpm with four pole pairs a sector
//!    lasts ≈ 680 µs, so at a 20 kHz call rate a real edge is confirmed within 50 µs while a
//!    one-call spike never is.
//!
//! Once accepted, a sector change is classified by [`SectorStep::between`]: the rotor can
//! move one sector per call at most (calls are far faster than sectors), so a jump of two or
//! three sectors means lost Hall edges or a wrong reading — a fault, as ODrive treats it.

/// How many back-to-back reads [`vote`] takes the majority of (VESC votes over 7).
pub const HALL_VOTES: usize = 7;

/// Consecutive calls a voted code must be seen on before [`HallFilter`] accepts it.
pub const HALL_CONFIRM_READS: u8 = 2;

/// The three Hall bits as read from the sensors: bit 2 = A, bit 1 = B, bit 0 = C, so the
/// paper's `101` is `HallCode::from_raw(0b101)`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct HallCode(u8);

impl HallCode {
    /// All eight codes, `000` to `111`, for exhaustive checks.
    pub const ALL: [Self; 8] =
        [Self(0), Self(1), Self(2), Self(3), Self(4), Self(5), Self(6), Self(7)];

    /// The code from its three bits.
    #[must_use]
    pub const fn from_lines(a: bool, b: bool, c: bool) -> Self {
        Self(((a as u8) << 2) | ((b as u8) << 1) | (c as u8))
    }

    /// The code from a raw value; only the low three bits are kept (bits above bit 2 are
    /// not Hall lines).
    #[must_use]
    pub const fn from_raw(raw: u8) -> Self {
        Self(raw & 0b111)
    }

    /// The raw value, 0 ..= 7.
    #[must_use]
    pub const fn raw(self) -> u8 {
        self.0
    }

    /// The sector this code stands for, or `None` for the impossible codes `000` and `111`.
    #[must_use]
    pub const fn sector(self) -> Option<Sector> {
        match self.0 {
            0b101 => Some(Sector::S0),
            0b100 => Some(Sector::S1),
            0b110 => Some(Sector::S2),
            0b010 => Some(Sector::S3),
            0b011 => Some(Sector::S4),
            0b001 => Some(Sector::S5),
            _ => None,
        }
    }
}

/// One of the six 60° electrical sectors, numbered in forward-rotation order starting at
/// the paper's first code `101`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Sector {
    /// Hall `101`.
    S0,
    /// Hall `100`.
    S1,
    /// Hall `110`.
    S2,
    /// Hall `010`.
    S3,
    /// Hall `011`.
    S4,
    /// Hall `001`.
    S5,
}

impl Sector {
    /// The six sectors in forward order.
    pub const ALL: [Self; 6] = [Self::S0, Self::S1, Self::S2, Self::S3, Self::S4, Self::S5];

    /// The sector's position in forward order, 0 ..= 5.
    #[must_use]
    pub const fn index(self) -> u8 {
        match self {
            Self::S0 => 0,
            Self::S1 => 1,
            Self::S2 => 2,
            Self::S3 => 3,
            Self::S4 => 4,
            Self::S5 => 5,
        }
    }

    /// The Hall code that reads as this sector.
    #[must_use]
    pub const fn hall_code(self) -> HallCode {
        HallCode(match self {
            Self::S0 => 0b101,
            Self::S1 => 0b100,
            Self::S2 => 0b110,
            Self::S3 => 0b010,
            Self::S4 => 0b011,
            Self::S5 => 0b001,
        })
    }

    /// The sector `steps` positions further in forward order (mod 6).
    #[must_use]
    pub const fn advanced(self, steps: u8) -> Self {
        // index ≤ 5 and steps % 6 ≤ 5, so the sum ≤ 10 and cannot overflow.
        match self.index().wrapping_add(steps % 6) % 6 {
            0 => Self::S0,
            1 => Self::S1,
            2 => Self::S2,
            3 => Self::S3,
            4 => Self::S4,
            _ => Self::S5,
        }
    }
}

/// How the accepted sector moved between two accepted readings.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum SectorStep {
    /// Same sector.
    Stay,
    /// One sector forward (+1 mod 6).
    Forward,
    /// One sector backward (−1 mod 6).
    Backward,
    /// Two or three sectors away: Hall edges were lost or misread.
    Skipped,
}

impl SectorStep {
    /// Classifies the move from `from` to `to`.
    #[must_use]
    pub const fn between(from: Sector, to: Sector) -> Self {
        // (to − from) mod 6; both indices ≤ 5, so 6 + to − from ∈ 1..=11 never wraps.
        match to.index().wrapping_add(6).wrapping_sub(from.index()) % 6 {
            0 => Self::Stay,
            1 => Self::Forward,
            5 => Self::Backward,
            _ => Self::Skipped,
        }
    }
}

/// Per-bit majority of [`HALL_VOTES`] back-to-back reads of the three Hall lines.
///
/// A bit is set in the result when it is set in at least four of the seven reads, so up to
/// three corrupted reads of any line are outvoted.
#[must_use]
pub fn vote(reads: &[HallCode; HALL_VOTES]) -> HallCode {
    const LINE_MASKS: [u8; 3] = [0b100, 0b010, 0b001];
    let mut counts = [0u8; 3];
    // Constant bound: HALL_VOTES (7) reads × 3 lines.
    for read in reads {
        for (count, mask) in counts.iter_mut().zip(LINE_MASKS) {
            *count = count.saturating_add(u8::from(read.0 & mask != 0));
        }
    }
    let majority = |count: u8| count > 3;
    let [a, b, c] = counts;
    HallCode::from_lines(majority(a), majority(b), majority(c))
}

/// The accepted Hall state after confirmation.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum HallState {
    /// No code has been confirmed yet (power-up).
    Unknown,
    /// A valid code is confirmed: the rotor is in this sector.
    Sector(Sector),
    /// `000` or `111` has been confirmed: the sensors are not working.
    Invalid(HallCode),
}

/// Accepts a Hall code only after it has been read on [`HALL_CONFIRM_READS`] consecutive
/// calls.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct HallFilter {
    candidate: HallCode,
    seen: u8,
    accepted: HallState,
}

impl Default for HallFilter {
    fn default() -> Self {
        Self::new()
    }
}

impl HallFilter {
    /// A filter that has accepted nothing yet.
    #[must_use]
    pub const fn new() -> Self {
        Self { candidate: HallCode(0), seen: 0, accepted: HallState::Unknown }
    }

    /// Feeds one (voted) read; returns the accepted state after it.
    pub fn update(&mut self, code: HallCode) -> HallState {
        if code == self.candidate {
            self.seen = self.seen.saturating_add(1).min(HALL_CONFIRM_READS);
        } else {
            self.candidate = code;
            self.seen = 1;
        }
        if self.seen >= HALL_CONFIRM_READS {
            self.accepted = match code.sector() {
                Some(sector) => HallState::Sector(sector),
                None => HallState::Invalid(code),
            };
        }
        self.accepted
    }

    /// The state accepted so far.
    #[must_use]
    pub const fn accepted(&self) -> HallState {
        self.accepted
    }

    /// Whether the filter's fields are consistent (used by proofs that start from an
    /// arbitrary filter): the confirmation count never exceeds its bound.
    #[must_use]
    pub const fn is_valid(&self) -> bool {
        self.seen <= HALL_CONFIRM_READS && self.candidate.0 <= 0b111
    }

    /// A filter in an arbitrary state, for proofs. Returns `None` unless the state is one
    /// [`HallFilter::update`] can reach.
    #[must_use]
    pub fn from_parts(candidate: HallCode, seen: u8, accepted: HallState) -> Option<Self> {
        let filter = Self { candidate, seen, accepted };
        filter.is_valid().then_some(filter)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A raw value keeps its three low bits, the Hall lines A, B, C from bit 2 down, and
    /// nothing else: every byte.
    #[test]
    fn a_raw_code_is_its_three_low_bits() {
        for raw in 0..=u8::MAX {
            let code = HallCode::from_raw(raw);
            assert_eq!(code.raw(), raw & 0b111, "{raw:#010b}");
            let line = |bit: u8| raw & (1 << bit) != 0;
            assert_eq!(code, HallCode::from_lines(line(2), line(1), line(0)), "{raw:#010b}");
        }
    }

    #[test]
    fn paper_forward_sequence_steps_forward() {
        let codes = [0b101, 0b100, 0b110, 0b010, 0b011, 0b001];
        for pair in 0..6 {
            let from = HallCode::from_raw(codes[pair]).sector();
            let to = HallCode::from_raw(codes[(pair + 1) % 6]).sector();
            let (Some(from), Some(to)) = (from, to) else { panic!("the paper's codes are valid") };
            assert_eq!(SectorStep::between(from, to), SectorStep::Forward);
            assert_eq!(SectorStep::between(to, from), SectorStep::Backward);
        }
    }

    #[test]
    fn exactly_two_codes_are_invalid() {
        for code in HallCode::ALL {
            let invalid = code.raw() == 0b000 || code.raw() == 0b111;
            assert_eq!(code.sector().is_none(), invalid, "{code:?}");
        }
        for sector in Sector::ALL {
            assert_eq!(sector.hall_code().sector(), Some(sector));
        }
    }

    #[test]
    fn jumps_of_two_or_three_are_skips() {
        for from in Sector::ALL {
            for steps in 0..6u8 {
                let expected = match steps {
                    0 => SectorStep::Stay,
                    1 => SectorStep::Forward,
                    5 => SectorStep::Backward,
                    _ => SectorStep::Skipped,
                };
                assert_eq!(SectorStep::between(from, from.advanced(steps)), expected);
            }
        }
    }

    #[test]
    fn vote_outvotes_three_bad_reads_of_every_line() {
        let good = HallCode::from_raw(0b101);
        let bad = HallCode::from_raw(0b010);
        let mut reads = [good; HALL_VOTES];
        reads[0] = bad;
        reads[3] = bad;
        reads[6] = bad;
        assert_eq!(vote(&reads), good);
        reads[5] = bad;
        assert_eq!(vote(&reads), bad);
    }

    #[test]
    fn filter_ignores_one_call_glitch_and_confirms_real_edge() {
        let mut filter = HallFilter::new();
        let s0 = Sector::S0.hall_code();
        let s1 = Sector::S1.hall_code();
        assert_eq!(filter.update(s0), HallState::Unknown);
        assert_eq!(filter.update(s0), HallState::Sector(Sector::S0));
        // A one-call glitch to 000 is never accepted.
        assert_eq!(filter.update(HallCode::from_raw(0)), HallState::Sector(Sector::S0));
        assert_eq!(filter.update(s0), HallState::Sector(Sector::S0));
        // A real edge is accepted on its second read.
        assert_eq!(filter.update(s1), HallState::Sector(Sector::S0));
        assert_eq!(filter.update(s1), HallState::Sector(Sector::S1));
        // A stuck-at-111 sensor is accepted as invalid.
        let stuck = HallCode::from_raw(0b111);
        filter.update(stuck);
        assert_eq!(filter.update(stuck), HallState::Invalid(stuck));
    }
}

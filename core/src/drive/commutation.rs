//! Six-step commutation: which of the bridge's six MOSFETs conduct in each rotor sector.
//!
//! # The bridge
//!
//! Three legs (phases A, B, C), each a high-side and a low-side N-channel MOSFET between the
//! 24 V bus and ground, the phase winding on the leg's midpoint. A leg has three safe states:
//! high side on (phase tied to +24 V through the PWM), low side on (phase tied to ground), or
//! both off (phase floating). The fourth combination — both on — shorts the bus through the
//! leg (**shoot-through**) and destroys the MOSFETs. [`LegState`] has no variant for it, so no
//! value of [`SwitchPattern`] can express it; [`SwitchPattern::gates`] expands a pattern into
//! the six gate signals the firmware drives, and the proofs check those signals directly.
//!
//! # How the table was derived
//!
//! A BLDC motor's phase back-EMFs are trapezoids 120° apart; maximum steady torque comes from
//! driving current **into** the phase whose back-EMF is on its flat positive top and **out
//! of** the phase on its flat negative bottom, leaving the third (on a slope) floating. Put
//! phase A's flat top at electrical angle 30°–150°; B's is then 150°–270° and C's 270°–30°,
//! and the bottoms are half a turn later (A: 210°–330°, B: 330°–90°, C: 90°–210°). Cutting
//! the turn at the commutation instants 30°, 90°, … gives six sectors and, in each, one
//! top phase (high side) and one bottom phase (low side):
//!
//! | θ (elec.) | top | bottom | Hall A B C | sector | forward pattern |
//! |---|---|---|---|---|---|
//! | 30–90°   | A | B | 1 0 1 | S0 | A+ B− |
//! | 90–150°  | A | C | 1 0 0 | S1 | A+ C− |
//! | 150–210° | B | C | 1 1 0 | S2 | B+ C− |
//! | 210–270° | B | A | 0 1 0 | S3 | B+ A− |
//! | 270–330° | C | A | 0 1 1 | S4 | C+ A− |
//! | 330–30°  | C | B | 0 0 1 | S5 | C+ B− |
//!
//! The Hall column assumes the usual mounting for six-step motors: each sensor switches at a
//! commutation instant, Hall X being high for the 180° that starts where phase X's flat top
//! starts (A high over 30°–210°). Read top to bottom, the Hall column is exactly the forward
//! sequence the paper measured, `101 → 100 → 110 → 010 → 011 → 001` (its figure 16), which
//! confirms the mounting up to a whole number of sectors; the power-on motor check
//! (a short low-duty drive that must produce Hall steps in the commanded direction) catches a
//! motor whose sensors are mounted otherwise.
//!
//! Reverse torque is the same table with high and low exchanged — which is the forward entry
//! three sectors on: `reverse(k) = forward(k + 3)`.
//!
//! Consecutive forward (or reverse) entries differ in exactly two legs: one leg turns off and
//! another turns on, and **no leg ever changes directly between high and low**. Such a
//! change happens only when the direction reverses or a sector is skipped; the dead-time
//! sequencer ([`super::dead_time`]) makes it pass through off.
//!
//! PWM is applied to the high-side switch; the low-side switch of the sector stays on for the
//! whole sector (paper, section 6.3 and figure 17).
//!
//! # The switched leg is complementary
//!
//! In the leg marked [`LegState::High`] the high-side switch conducts for the duty part of
//! each PWM period and that leg's **low-side switch conducts for the rest** — its complement,
//! with the hardware dead time between the two edges (the dsPIC's "complementary mode" the
//! paper uses, where "the low-side pin is always the inverse of the high-side pin"; on the
//! STM32G4, TIM1's CHx/CHxN pair with its dead-time generator). So the winding pair sees the
//! average voltage `duty × V_bus` whatever the direction of its current: the drive works in
//! two quadrants, and a duty below the back-EMF ratio **brakes** the motor (regenerating into
//! the bus) instead of letting it freewheel through a body diode. That is what lets the
//! tension loop decelerate the carriage's large reflected inertia before the string's target,
//! and it keeps the current continuous at light load, where a diode-freewheeling bridge falls
//! into discontinuous conduction and its torque stops following the duty. It also recharges
//! the high side's bootstrap capacitor every period.
//!
//! The two switches of the switched leg never conduct together: the timer's complementary output
//! inserts the board's dead time ([`super::DriveConfig::dead_time`]) at every edge, in hardware,
//! within the period. The core's guarantees are one level up, between periods: a leg's *state*
//! never changes between [`LegState::High`] and [`LegState::Low`] without the sequencer's own dead
//! time of both-off ([`super::dead_time`]).

use super::Direction;
use super::hall::Sector;

/// The state of one bridge leg. Shoot-through (both switches on) is not representable.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub enum LegState {
    /// Both switches off; the phase floats.
    #[default]
    Off,
    /// The switched leg: high side on for the duty part of each PWM period, the leg's low
    /// side on for the rest (its complement, with the hardware dead time at every edge).
    High,
    /// Low-side switch on for the whole sector; high-side switch off.
    Low,
}

impl LegState {
    /// The three leg states, for exhaustive checks.
    pub const ALL: [Self; 3] = [Self::Off, Self::High, Self::Low];

    /// Whether either switch of the leg conducts.
    #[must_use]
    pub const fn is_on(self) -> bool {
        !matches!(self, Self::Off)
    }
}

/// One of the three bridge legs (motor phases).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Phase {
    /// Phase A (dsPIC PWM1H/PWM1L, STM32 TIM1_CH1/CH1N).
    A,
    /// Phase B (PWM2H/PWM2L, TIM1_CH2/CH2N).
    B,
    /// Phase C (PWM3H/PWM3L, TIM1_CH3/CH3N).
    C,
}

impl Phase {
    /// The three phases in order.
    pub const ALL: [Self; 3] = [Self::A, Self::B, Self::C];
}

/// The six gate commands of the bridge, as the firmware programs them once per pattern:
/// `true` on a high side = "switched by the PWM" (its low side then being the hardware
/// complement, never on at the same instant), `true` on a low side = "on for the whole
/// sector". A leg with both set would be a static shoot-through command.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Gates {
    /// Phase A high side.
    pub a_high: bool,
    /// Phase A low side.
    pub a_low: bool,
    /// Phase B high side.
    pub b_high: bool,
    /// Phase B low side.
    pub b_low: bool,
    /// Phase C high side.
    pub c_high: bool,
    /// Phase C low side.
    pub c_low: bool,
}

impl Gates {
    /// `(high, low)` of one leg.
    #[must_use]
    pub const fn leg(&self, phase: Phase) -> (bool, bool) {
        match phase {
            Phase::A => (self.a_high, self.a_low),
            Phase::B => (self.b_high, self.b_low),
            Phase::C => (self.c_high, self.c_low),
        }
    }
}

/// The state of all three legs: what the bridge is told to do.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct SwitchPattern {
    /// Phase A's leg.
    pub a: LegState,
    /// Phase B's leg.
    pub b: LegState,
    /// Phase C's leg.
    pub c: LegState,
}

impl SwitchPattern {
    /// Every switch off: the safe state of the bridge.
    pub const ALL_OFF: Self = Self { a: LegState::Off, b: LegState::Off, c: LegState::Off };

    /// One leg's state.
    #[must_use]
    pub const fn leg(&self, phase: Phase) -> LegState {
        match phase {
            Phase::A => self.a,
            Phase::B => self.b,
            Phase::C => self.c,
        }
    }

    /// A copy with one leg changed.
    #[must_use]
    pub const fn with_leg(mut self, phase: Phase, state: LegState) -> Self {
        match phase {
            Phase::A => self.a = state,
            Phase::B => self.b = state,
            Phase::C => self.c = state,
        }
        self
    }

    /// Whether every switch is off.
    #[must_use]
    pub const fn is_all_off(&self) -> bool {
        !self.a.is_on() && !self.b.is_on() && !self.c.is_on()
    }

    /// The six gate signals.
    #[must_use]
    pub const fn gates(&self) -> Gates {
        Gates {
            a_high: matches!(self.a, LegState::High),
            a_low: matches!(self.a, LegState::Low),
            b_high: matches!(self.b, LegState::High),
            b_low: matches!(self.b, LegState::Low),
            c_high: matches!(self.c, LegState::High),
            c_low: matches!(self.c, LegState::Low),
        }
    }

    /// How many legs are in `state`.
    #[must_use]
    pub fn count(&self, state: LegState) -> u8 {
        let same = |leg: LegState| u8::from(leg == state);
        same(self.a).saturating_add(same(self.b)).saturating_add(same(self.c))
    }

    const fn high_low(high: Phase, low: Phase) -> Self {
        Self::ALL_OFF.with_leg(high, LegState::High).with_leg(low, LegState::Low)
    }
}

/// The forward table, indexed by sector (see the module docs for its derivation).
const FORWARD: [SwitchPattern; 6] = [
    SwitchPattern::high_low(Phase::A, Phase::B), // S0, Hall 101
    SwitchPattern::high_low(Phase::A, Phase::C), // S1, Hall 100
    SwitchPattern::high_low(Phase::B, Phase::C), // S2, Hall 110
    SwitchPattern::high_low(Phase::B, Phase::A), // S3, Hall 010
    SwitchPattern::high_low(Phase::C, Phase::A), // S4, Hall 011
    SwitchPattern::high_low(Phase::C, Phase::B), // S5, Hall 001
];

/// The six-step pattern for the rotor in `sector` and torque in `direction`.
///
/// [`Direction::Pull`] is forward torque (the Hall sequence of the paper's figure 16);
/// [`Direction::Release`] is reverse torque, `forward(sector + 3)`.
#[must_use]
pub const fn six_step(sector: Sector, direction: Direction) -> SwitchPattern {
    let sector = match direction {
        Direction::Pull => sector,
        Direction::Release => sector.advanced(3),
    };
    match sector {
        Sector::S0 => FORWARD[0],
        Sector::S1 => FORWARD[1],
        Sector::S2 => FORWARD[2],
        Sector::S3 => FORWARD[3],
        Sector::S4 => FORWARD[4],
        Sector::S5 => FORWARD[5],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_entry_is_one_high_one_low_one_off() {
        for sector in Sector::ALL {
            for direction in [Direction::Pull, Direction::Release] {
                let p = six_step(sector, direction);
                assert_eq!(p.count(LegState::High), 1, "{sector:?} {direction:?}");
                assert_eq!(p.count(LegState::Low), 1, "{sector:?} {direction:?}");
                assert_eq!(p.count(LegState::Off), 1, "{sector:?} {direction:?}");
            }
        }
    }

    /// A pattern is all off exactly when each of its three legs is off: every one of the 27
    /// combinations of leg states.
    #[test]
    fn all_off_means_every_leg_off() {
        let states = [LegState::Off, LegState::High, LegState::Low];
        for a in states {
            for b in states {
                for c in states {
                    let p = SwitchPattern::ALL_OFF
                        .with_leg(Phase::A, a)
                        .with_leg(Phase::B, b)
                        .with_leg(Phase::C, c);
                    let off = [a, b, c].iter().all(|&leg| leg == LegState::Off);
                    assert_eq!(p.is_all_off(), off, "{a:?} {b:?} {c:?}");
                }
            }
        }
    }

    #[test]
    fn reverse_swaps_high_and_low() {
        for sector in Sector::ALL {
            let f = six_step(sector, Direction::Pull);
            let r = six_step(sector, Direction::Release);
            for phase in Phase::ALL {
                let expected = match f.leg(phase) {
                    LegState::High => LegState::Low,
                    LegState::Low => LegState::High,
                    LegState::Off => LegState::Off,
                };
                assert_eq!(r.leg(phase), expected);
            }
        }
    }

    #[test]
    fn adjacent_sectors_never_swap_a_leg() {
        for sector in Sector::ALL {
            for direction in [Direction::Pull, Direction::Release] {
                let now = six_step(sector, direction);
                for next in [sector.advanced(1), sector.advanced(5)] {
                    let then = six_step(next, direction);
                    for phase in Phase::ALL {
                        let swap = matches!(
                            (now.leg(phase), then.leg(phase)),
                            (LegState::High, LegState::Low) | (LegState::Low, LegState::High)
                        );
                        assert!(!swap, "{sector:?}→{next:?} {direction:?} swaps {phase:?}");
                    }
                }
            }
        }
    }
}

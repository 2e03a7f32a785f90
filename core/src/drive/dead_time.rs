//! The dead-time sequencer: no leg switches on until it has been fully off for the dead time.
//!
//! # Why
//!
//! A MOSFET does not stop conducting the instant its gate is released (the IRF2807 takes
//! ≈100 ns, the gate driver adds its propagation delay). If one switch of a leg is turned on
//! while the other is still conducting, the bus is shorted through the leg. The cure is a
//! **dead time**: both switches of the leg off for at least the dead time before the other
//! one turns on.
//!
//! The dead time is a fact of the board (its MOSFETs and gate drivers), so it is handed in with the
//! board's configuration ([`super::DriveConfig::dead_time`], validated between [`DEAD_TIME_MIN`]
//! and [`DEAD_TIME_MAX`]); the firmware programs the same value into the timer's hardware dead-time
//! generator, which inserts it between a channel and its complementary output. This sequencer is
//! the second, independent layer, in software, and it is stricter: a leg may only turn **on** (to
//! either side) after having been **off** for at least the dead time, and a request to change a leg
//! directly from one side to the other is carried out as "off now, the new side once the dead time
//! has passed". So no sequence of requests can make a leg go high → low or low → high without the
//! dead time of both-off in between.
//!
//! # Time
//!
//! The sequencer counts in [`DriveTime`] (100 ns). Each call says how much time has
//! passed since the previous one (the previous output has been on the gates for that long);
//! off-times accumulate with saturation, so a leg that has been off for a long time stays
//! ready. At power-up every leg is taken as *just* switched off — the conservative reading.

use super::DriveTime;
use super::commutation::{LegState, Phase, SwitchPattern};

/// The shortest dead time a configuration may give: 100 ns, one [`DriveTime`] unit (a
/// MOSFET's own turn-off time; a board needs more for its gate drivers' mismatch).
pub const DEAD_TIME_MIN: DriveTime = DriveTime(1);

/// The longest dead time a configuration may give: 5 µs (beyond it the body diodes carry a
/// tenth of a 20 kHz period, and the duty map's dead-time loss is no longer small).
pub const DEAD_TIME_MAX: DriveTime = DriveTime::from_micros(5);

/// One leg's sequencing state.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
struct LegTimer {
    /// What the leg is doing now.
    state: LegState,
    /// How long the leg has been off (meaningful only while `state` is `Off`; zero otherwise).
    off_for: DriveTime,
}

impl LegTimer {
    fn step(&mut self, requested: LegState, elapsed: DriveTime, dead_time: DriveTime) -> LegState {
        if !self.state.is_on() {
            self.off_for = DriveTime(self.off_for.0.saturating_add(elapsed.0));
        }
        self.state = match (self.state, requested) {
            (now, wanted) if now == wanted => now,
            // Turning off is always allowed and starts the off-time.
            (_, LegState::Off) => LegState::Off,
            // Turning on from off: only once the dead time has passed.
            (LegState::Off, wanted) => {
                if self.off_for.0 >= dead_time.0 {
                    wanted
                } else {
                    LegState::Off
                }
            }
            // High ↔ low directly: go off now; the new side comes on a later call.
            (_, _) => LegState::Off,
        };
        if self.state.is_on() {
            self.off_for = DriveTime(0);
        }
        self.state
    }
}

/// Sequences requested switch patterns onto the bridge so that every leg honours its dead
/// time.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct DeadTimeSequencer {
    legs: [LegTimer; 3],
    /// The board's dead time (within [`DEAD_TIME_MIN`]..=[`DEAD_TIME_MAX`]).
    dead_time: DriveTime,
}

impl DeadTimeSequencer {
    /// All legs off, each taken as switched off just now, honouring `dead_time` (held within
    /// [`DEAD_TIME_MIN`]..=[`DEAD_TIME_MAX`]; a configuration is refused outside them, see
    /// [`super::DriveConfig::new`], so the bound never moves a configured dead time).
    #[must_use]
    pub fn new(dead_time: DriveTime) -> Self {
        let off = LegTimer { state: LegState::Off, off_for: DriveTime(0) };
        Self { legs: [off; 3], dead_time: dead_time.clamp(DEAD_TIME_MIN, DEAD_TIME_MAX) }
    }

    /// The dead time this sequencer honours.
    #[must_use]
    pub const fn dead_time(&self) -> DriveTime {
        self.dead_time
    }

    /// Moves toward `requested`, `elapsed` after the previous call; returns the pattern
    /// to put on the gates now. Legs that must wait for the dead time are off in the result.
    pub fn step(&mut self, requested: SwitchPattern, elapsed: DriveTime) -> SwitchPattern {
        let mut out = SwitchPattern::ALL_OFF;
        // Constant bound: three legs.
        for (leg, phase) in self.legs.iter_mut().zip(Phase::ALL) {
            out = out.with_leg(phase, leg.step(requested.leg(phase), elapsed, self.dead_time));
        }
        out
    }

    /// Whether [`Self::step`] with `requested` and `elapsed` would put `requested` on the gates
    /// in full (no leg held off for its dead time).
    #[must_use]
    pub fn ready_for(&self, requested: SwitchPattern, elapsed: DriveTime) -> bool {
        self.legs.iter().zip(Phase::ALL).all(|(leg, phase)| {
            let wanted = requested.leg(phase);
            wanted == leg.state
                || !wanted.is_on()
                || (!leg.state.is_on()
                    && leg.off_for.0.saturating_add(elapsed.0) >= self.dead_time.0)
        })
    }

    /// Turns every leg off at once (faults). Turning off never needs a dead time.
    pub fn all_off(&mut self) {
        for leg in &mut self.legs {
            if leg.state.is_on() {
                *leg = LegTimer { state: LegState::Off, off_for: DriveTime(0) };
            }
        }
    }

    /// The pattern currently on the gates.
    #[must_use]
    pub fn pattern(&self) -> SwitchPattern {
        let [a, b, c] = self.legs;
        SwitchPattern { a: a.state, b: b.state, c: c.state }
    }

    /// How long `phase`'s leg has been off (zero while it is on).
    #[must_use]
    pub fn off_for(&self, phase: Phase) -> DriveTime {
        let [a, b, c] = self.legs;
        match phase {
            Phase::A => a.off_for,
            Phase::B => b.off_for,
            Phase::C => c.off_for,
        }
    }

    /// A sequencer in an arbitrary state, for proofs that start mid-sequence: `legs` gives
    /// each leg's state and how long it has been off, `dead_time` the board's. `None` unless
    /// [`Self::is_valid`].
    #[must_use]
    pub fn from_parts(legs: [(LegState, DriveTime); 3], dead_time: DriveTime) -> Option<Self> {
        let [a, b, c] = legs.map(|(state, off_for)| LegTimer { state, off_for });
        let sequencer = Self { legs: [a, b, c], dead_time };
        sequencer.is_valid().then_some(sequencer)
    }

    /// The sequencer's invariant: a leg that is on has a zero off-time, and the dead time is
    /// one a configuration may give.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        (DEAD_TIME_MIN..=DEAD_TIME_MAX).contains(&self.dead_time)
            && self.legs.iter().all(|leg| !leg.state.is_on() || leg.off_for.0 == 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// taut's board: 1 µs.
    const DEAD_TIME: DriveTime = DriveTime::from_micros(1);

    const A_HIGH_B_LOW: SwitchPattern =
        SwitchPattern { a: LegState::High, b: LegState::Low, c: LegState::Off };
    const A_LOW_B_HIGH: SwitchPattern =
        SwitchPattern { a: LegState::Low, b: LegState::High, c: LegState::Off };

    #[test]
    fn first_drive_waits_for_dead_time() {
        let mut seq = DeadTimeSequencer::new(DEAD_TIME);
        assert_eq!(seq.step(A_HIGH_B_LOW, DriveTime(0)), SwitchPattern::ALL_OFF);
        assert_eq!(seq.step(A_HIGH_B_LOW, DriveTime(DEAD_TIME.0 - 1)), SwitchPattern::ALL_OFF);
        assert_eq!(seq.step(A_HIGH_B_LOW, DriveTime(1)), A_HIGH_B_LOW);
    }

    #[test]
    fn reversal_passes_through_off_for_the_dead_time() {
        let mut seq = DeadTimeSequencer::new(DEAD_TIME);
        seq.step(A_HIGH_B_LOW, DEAD_TIME);
        assert_eq!(seq.pattern(), A_HIGH_B_LOW);
        // Even a long gap does not let a leg swap sides in one call.
        assert_eq!(seq.step(A_LOW_B_HIGH, DriveTime(1_000_000)), SwitchPattern::ALL_OFF);
        assert_eq!(seq.step(A_LOW_B_HIGH, DriveTime(DEAD_TIME.0 - 1)), SwitchPattern::ALL_OFF);
        assert_eq!(seq.step(A_LOW_B_HIGH, DriveTime(1)), A_LOW_B_HIGH);
    }

    #[test]
    fn off_time_saturates_instead_of_wrapping() {
        let mut seq = DeadTimeSequencer::new(DEAD_TIME);
        seq.step(SwitchPattern::ALL_OFF, DriveTime(u32::MAX));
        seq.step(SwitchPattern::ALL_OFF, DriveTime(u32::MAX));
        assert_eq!(seq.off_for(Phase::A), DriveTime(u32::MAX));
        assert_eq!(seq.step(A_HIGH_B_LOW, DriveTime(0)), A_HIGH_B_LOW);
    }
}

//! The safety rules: thresholds and the pure checks the machine's superstates apply every
//! tick.
//!
//! # Theory of operation
//!
//! The rules are split by where they hold, matching the machine's superstates:
//!
//! - **Everywhere** ([`global_fault`]): both limit switches active, a latched drive fault.
//!   Checked in every state but the fault state, with no persistence: one sample is enough
//!   to stop. Overcurrent and bus overvoltage are the drive's: it compares every PWM period's
//!   sample (not the tick's mean) against the board's thresholds from the tared zero, switches
//!   the bridge off in that same period and reports the latched fault here.
//! - **While moving** ([`limit_guard`], [`stall`], [`load_cell_rail`]): the drive command
//!   never points toward an active limit switch (it is replaced by coast); where the
//!   carriage should be moving, duty with no Hall step for [`STALL_QUIET`] is a stall; a
//!   load-cell reading at a converter rail for [`RAIL_PERSIST`] ticks is a broken sensor.
//! - **While the string is under tension** ([`TensionWatch`]): the end-of-travel limit
//!   (tension never reached), overload, string break, no string and reversed load-cell
//!   wiring. These decide on *evidence*, never on one sample: the paper's amplifier board
//!   showed "many spikes" (fig. 22), and one +5 kgf sample must not set the peak that a string
//!   break is measured against. Each tension (corrected and raw) is first **tracked**: the
//!   tracked value moves toward each sample by at most [`TRACK_SLEW`] (1 kgf) per tick, so a
//!   spike of any height moves it by at most 1 kgf, and two in a row (rare at a few % of
//!   samples) by 2, while a real tension, which changes by well under 1 kgf per millisecond
//!   even on the stiffest string at full speed, is followed exactly. The rules then read the
//!   tracked values.
//!
//!   A **burst** — a gate driver ringing across several conversions, up to [`BURST_MAX`]
//!   consecutive samples — holds a tracked value off for up to twice its length (the slew out
//!   and the slew back), longer than any persistence a break or an overload can afford. So
//!   the judgements a burst could fake on an intact string — the tension has risen past the
//!   peak, has fallen below half of it, has passed the overload limit — are also put to the
//!   **majority of the last [`EVIDENCE_WINDOW`] samples**: the peak rises only while at least
//!   [`EVIDENCE_MAJORITY`] of them lay above it, and a break or an overload needs at least as
//!   many beyond its threshold as well as the tracked tension. A burst with
//!   [`SPIKES_BESIDE`] single spikes of the same sign beside it is a minority of the window
//!   whatever its height and wherever it falls — the estimator's median rejects the same
//!   outliers (its window is the same size) — while a string that has broken reads near zero
//!   from the next sample on and wins the majority at the [`EVIDENCE_MAJORITY`]th. Each
//!   judgement is a bit a tick in a 15-bit history: a shift and a population count, no
//!   sorting. The detection times follow (`docs/SPEC.md`, REQ-SAFE-09): a collapse from a peak
//!   of `P` kgf is tracked below `P/2` in `⌊P/2⌋ + 1` ticks and has the majority in 8, so it
//!   latches in `max(⌊P/2⌋ + 1, 8)` ms — 26 ms at the 50 kgf rating, 8 ms below 14 kgf; a
//!   step from a steady `T` past the overload limit `L` in `max(⌊L − T⌋ + 1, 8)` ms.
//!
//! Every function here is pure: the same rule is called by the machine, by the Kani
//! harnesses and by the model checker.

use crate::drive::{DriveCommand, DriveTime, Duty};
use crate::io::{Inputs, LimitSwitches};
use crate::machine::fault::FaultCode;
use crate::tension::estimator::{BURST_MAX, SPIKES_BESIDE};
use crate::units::{AdcCode, Kgf, Q16};

/// Load-cell codes at or below this read as the bottom rail (≤ 9.8 mV): the amplifier output
/// is pulled to ground — open bridge, no amplifier supply.
pub const LOAD_CELL_BOTTOM_RAIL: AdcCode = AdcCode::new(8);

/// Load-cell codes at or above this read as the top rail (≥ 4.99 V): shorted bridge arm or
/// far beyond the sensor's range (≈ 53.7 kgf with the nominal chain).
pub const LOAD_CELL_TOP_RAIL: AdcCode = AdcCode::new(4_087);

/// Duty at or above which a motor that should be moving but does not turn is stalled: 5 %
/// (1.2 V on a 24 V bus: ≈ 1.4 A into the winding at rest, several times the no-load
/// current, so a free carriage turns). The slowest take-up — speed 1, 9 mm/s, ≈ 2.8 V of
/// back-EMF — is 7.8 % even on a 36 V bus, where the duty map scales it down: at 10 % a
/// seized carriage at speed 1 on a pumped bus was never a stall and waited for the pull's
/// time limit. Holding at tension needs up to ≈ 28 % with the motor at rest, which is why
/// the rule only applies where motion is expected.
pub const STALL_DUTY: Duty = Duty::from_raw_clamped(3_277);

/// How long a driven motor may go without a Hall step before it counts as stalled, ms.
pub const STALL_QUIET_MS: u32 = 500;

/// [`STALL_QUIET_MS`] in drive time, as the drive reports its quiet time.
pub const STALL_QUIET: DriveTime = DriveTime::from_micros(STALL_QUIET_MS * 1_000);

/// The tension above the pull's peak target that counts as overload.
pub const OVERLOAD_MARGIN: Kgf = Kgf::from_int(5);

/// The tension that is always overload, whatever the target: 53 kgf (the sensor's range
/// ends at ≈ 53.7 kgf; the machine is rated to 50).
pub const OVERLOAD_ABSOLUTE: Kgf = Kgf::from_int(53);

/// A string-break needs the tension to have reached at least this first.
pub const BREAK_MIN_PEAK: Kgf = Kgf::from_int(5);

/// The most the peak a string break is measured against rises in one tick: 0.15 kgf. A real
/// tension rises at most ≈ 0.12 kgf/ms (78 mm/s, the screw's no-load speed, into the
/// stiffest string, 15 kgf/cm), so the peak keeps up with every real pull once the
/// majority of the window is above it.
pub const PEAK_RISE: Kgf = Kgf(Q16::lit("0.15"));

/// The samples the peak's rise and a string break are judged over: the last 15, the
/// estimator's median window ([`crate::tension::estimator::WINDOW`]).
pub const EVIDENCE_WINDOW: u32 = 2 * EVIDENCE_MAJORITY - 1;

/// How many of the [`EVIDENCE_WINDOW`] samples must agree: 8 — one more than a burst of
/// [`BURST_MAX`] spikes with [`SPIKES_BESIDE`] single spikes of the same sign beside it.
pub const EVIDENCE_MAJORITY: u32 = 8;
const _: () = assert!(
    EVIDENCE_MAJORITY as usize == BURST_MAX + SPIKES_BESIDE + 1,
    "the majority outnumbers a burst and its single spikes"
);
const _: () = assert!(
    EVIDENCE_WINDOW as usize == crate::tension::estimator::WINDOW,
    "the same outliers as the estimator's median"
);

/// The bits of an evidence history that are inside the window.
pub const EVIDENCE_BITS: u16 = (1 << EVIDENCE_WINDOW) - 1;

/// Carriage travel without tension that means no string is clamped: 150 mm, in Hall steps
/// ([`crate::mechanism::steps_in_mm`]: 150 × 480 / 25.4 = 2 835).
pub const NO_STRING_TRAVEL_STEPS: i32 = crate::mechanism::steps_in_mm(150);

/// "Without tension": below 1 kgf.
pub const NO_STRING_TENSION: Kgf = Kgf::from_int(1);

/// A tension reading below this while pulling means the bridge is wired backwards: −0.3 kgf
/// (27 mV, 22 codes below the tare), well outside the unloaded noise. A reversed bridge's
/// output can only fall as far as the bottom rail (with the nominal 50 mV tare, −0.54 kgf),
/// so with a tare below ≈ 37 mV it reaches the rail first and reads as `E-03`.
pub const REVERSED_TENSION: Kgf = Kgf(Q16::lit("-0.3"));

/// Consecutive ticks a load-cell rail reading must persist while moving before it latches:
/// 20. Switching spikes (paper fig. 22) can throw single samples to a rail while the bridge
/// commutates; twenty in a row of one sign do not happen.
pub const RAIL_PERSIST: u8 = 20;

/// The most a tracked tension moves toward its sample in one tick: 1 kgf. A real tension
/// moves far less per millisecond (a 50 kgf pull takes ≥ 0.2 s on the stiffest string); a
/// switching spike of any height moves the tracked value by at most this.
pub const TRACK_SLEW: Kgf = Kgf::from_int(1);

/// The range a tracked tension is kept in: ± 60 kgf, beyond the sensor's ≈ 54 kgf.
pub const TRACK_LIMIT: Kgf = Kgf::from_int(60);

/// Ticks a tracked tension must stay at or above [`NO_STRING_TENSION`] before the string
/// counts as loaded (a pair of spikes lifts it for at most two).
pub const LOADED_PERSIST: u8 = 10;

/// Ticks a reversed reading must persist before it latches.
pub const REVERSED_PERSIST: u8 = 20;

/// The fault every state but the fault state raises at once, if any: both limits, then a
/// latched drive fault (overcurrent, bus overvoltage, current-sense zero, Hall).
#[must_use]
pub fn global_fault(inputs: &Inputs) -> Option<FaultCode> {
    if inputs.limits.both() {
        Some(FaultCode::LimitsBoth)
    } else {
        inputs.drive.fault.map(FaultCode::from_drive)
    }
}

/// `command`, or coast if it would drive toward an active limit switch.
#[must_use]
pub fn limit_guard(command: DriveCommand, limits: LimitSwitches) -> DriveCommand {
    match command.direction() {
        Some(direction) if direction.blocked_by(limits) => DriveCommand::Coast,
        _ => command,
    }
}

/// Whether the motor is stalled: it has been commanded at [`STALL_DUTY`] or more for the
/// last `driven_ms` ticks, and no Hall step came for [`STALL_QUIET`] — both at least 500 ms,
/// so a motor that was resting before the command is given its time to start. Only
/// meaningful where the carriage is expected to move (taking up slack, releasing): at
/// tension the motor legitimately stands still under load.
#[must_use]
pub fn stall(command: DriveCommand, inputs: &Inputs, driven_ms: u32) -> bool {
    command.duty() >= STALL_DUTY
        && driven_ms >= STALL_QUIET_MS
        && inputs.drive.quiet_for >= STALL_QUIET
}

/// The load-cell fault of a reading at a converter rail, if any.
#[must_use]
pub fn load_cell_rail(code: AdcCode) -> Option<FaultCode> {
    if code <= LOAD_CELL_BOTTOM_RAIL {
        Some(FaultCode::LoadCellOpen)
    } else if code >= LOAD_CELL_TOP_RAIL {
        Some(FaultCode::LoadCellShort)
    } else {
        None
    }
}

/// The overload threshold for a pull whose highest target is `peak_target`.
#[must_use]
pub fn overload_limit(peak_target: Kgf) -> Kgf {
    let relative = peak_target.saturating_add(OVERLOAD_MARGIN);
    if relative < OVERLOAD_ABSOLUTE { relative } else { OVERLOAD_ABSOLUTE }
}

/// `tracked` moved toward `sample` by at most [`TRACK_SLEW`], kept within ± [`TRACK_LIMIT`].
#[must_use]
pub fn track(tracked: Kgf, sample: Kgf) -> Kgf {
    let gap = sample.saturating_sub(tracked);
    let step = if gap > TRACK_SLEW {
        TRACK_SLEW
    } else if gap < Kgf::ZERO.saturating_sub(TRACK_SLEW) {
        Kgf::ZERO.saturating_sub(TRACK_SLEW)
    } else {
        gap
    };
    let moved = tracked.saturating_add(step);
    let low = Kgf::ZERO.saturating_sub(TRACK_LIMIT);
    if moved > TRACK_LIMIT {
        TRACK_LIMIT
    } else if moved < low {
        low
    } else {
        moved
    }
}

/// `history` with this tick's judgement shifted in, kept to the window.
const fn witness(history: u16, holds: bool) -> u16 {
    ((history << 1) | holds as u16) & EVIDENCE_BITS
}

/// Whether the majority of the window's samples are witnesses.
const fn majority(history: u16) -> bool {
    (history & EVIDENCE_BITS).count_ones() >= EVIDENCE_MAJORITY
}

/// The rules that hold while the string is under tension, with the tracked tensions and
/// persistence counters they need. Reset when a pull (or calibration point) starts; the
/// tracked tensions start at zero (the load cell was tared at rest).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct TensionWatch {
    /// Hall step count when the pull started.
    pub start_steps: i32,
    /// Highest tracked tension since the pull started, reached at no more than [`PEAK_RISE`] a
    /// tick and only while the majority of the window's samples lay above it.
    pub peak: Kgf,
    /// The corrected tension, tracked ([`track`]).
    pub tension: Kgf,
    /// The uncorrected tension, tracked.
    pub raw: Kgf,
    reversed: u8,
    loaded: u8,
    /// One bit a tick, the newest lowest: the sample lay above the peak.
    above: u16,
    /// One bit a tick, the newest lowest: the sample lay below half the peak.
    below: u16,
    /// One bit a tick, the newest lowest: the sample lay above the overload limit.
    over: u16,
}

/// What [`TensionWatch::check`] needs to know about this tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct TensionSample {
    /// The corrected tension.
    pub tension: Kgf,
    /// The uncorrected (tared) tension, for the sign check.
    pub raw: Kgf,
    /// The drive's Hall step count.
    pub steps: i32,
    /// The limit switches.
    pub limits: LimitSwitches,
    /// The pull's highest target (pre-stretch peak).
    pub peak_target: Kgf,
}

impl TensionWatch {
    /// A watch for a pull starting at Hall count `steps`.
    #[must_use]
    pub const fn new(steps: i32) -> Self {
        Self {
            start_steps: steps,
            peak: Kgf::ZERO,
            tension: Kgf::ZERO,
            raw: Kgf::ZERO,
            reversed: 0,
            loaded: 0,
            above: 0,
            below: 0,
            over: 0,
        }
    }

    /// A watch with arbitrary values (proofs, fuzzing): `tracked` is (peak, tension, raw),
    /// `counters` (reversed, loaded), `evidence` the histories (above the peak, below half of
    /// it, above the overload limit). [`TensionWatch::is_valid`] says which a run can reach.
    #[must_use]
    pub const fn from_parts(
        start_steps: i32,
        tracked: [Kgf; 3],
        counters: [u8; 2],
        evidence: [u16; 3],
    ) -> Self {
        let [peak, tension, raw] = tracked;
        let [reversed, loaded] = counters;
        let [above, below, over] = evidence;
        Self { start_steps, peak, tension, raw, reversed, loaded, above, below, over }
    }

    /// Whether the watch is one a run can reach: tracked values within ± [`TRACK_LIMIT`],
    /// a peak between zero and the limit (it may lag a rising tension), persistence
    /// counters at most their limits, histories no longer than the window.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let low = Kgf::ZERO.saturating_sub(TRACK_LIMIT);
        let within = |value: Kgf| value >= low && value <= TRACK_LIMIT;
        self.peak >= Kgf::ZERO
            && self.peak <= TRACK_LIMIT
            && within(self.tension)
            && within(self.raw)
            && self.reversed <= REVERSED_PERSIST
            && self.loaded <= LOADED_PERSIST
            && self.above & !EVIDENCE_BITS == 0
            && self.below & !EVIDENCE_BITS == 0
            && self.over & !EVIDENCE_BITS == 0
    }

    /// Whether the string has carried tension: the tracked tension stayed at or above
    /// [`NO_STRING_TENSION`] for [`LOADED_PERSIST`] ticks in a row since the pull started.
    #[must_use]
    pub const fn loaded(&self) -> bool {
        self.loaded >= LOADED_PERSIST
    }

    /// Carriage travel since the pull started, in Hall steps (positive = pulling).
    #[must_use]
    pub const fn travel(&self, steps: i32) -> i32 {
        steps.wrapping_sub(self.start_steps)
    }

    /// One tick: tracks the sample's tensions, then returns the fault to latch, if any, in
    /// order of precedence — end of travel, overload, string break, reversed load cell, no
    /// string.
    pub fn check(&mut self, sample: &TensionSample) -> Option<FaultCode> {
        self.tension = track(self.tension, sample.tension);
        self.raw = track(self.raw, sample.raw);
        self.above = witness(self.above, sample.tension > self.peak);
        if self.tension > self.peak && majority(self.above) {
            self.peak = self.tension.min(self.peak.saturating_add(PEAK_RISE));
        }
        let persist = |counter: &mut u8, condition: bool, limit: u8| {
            *counter = if condition { counter.saturating_add(1).min(limit) } else { 0 };
            *counter >= limit
        };
        if !self.loaded() {
            persist(&mut self.loaded, self.tension >= NO_STRING_TENSION, LOADED_PERSIST);
        }
        let limit = overload_limit(sample.peak_target);
        self.over = witness(self.over, sample.tension > limit);
        let overloaded = self.tension > limit && majority(self.over);
        let half_peak = Kgf::from_bits(self.peak.to_bits().checked_div(2).unwrap_or(0));
        self.below = witness(self.below, sample.tension < half_peak);
        let broken =
            self.peak >= BREAK_MIN_PEAK && self.tension < half_peak && majority(self.below);
        let reversed = persist(&mut self.reversed, self.raw < REVERSED_TENSION, REVERSED_PERSIST);
        // Both switches at once is a wiring fault, reported by the rule that holds
        // everywhere (`LimitsBoth`), not as an end of travel.
        if sample.limits.end && !sample.limits.home {
            Some(FaultCode::EndOfTravel)
        } else if overloaded {
            Some(FaultCode::Overload)
        } else if broken {
            Some(FaultCode::StringBreak)
        } else if reversed {
            Some(FaultCode::LoadCellReversed)
        } else if self.travel(sample.steps) > NO_STRING_TRAVEL_STEPS && !self.loaded() {
            Some(FaultCode::NoString)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::{Direction, DriveFault};

    #[test]
    fn global_rules_in_order() {
        let mut inputs = Inputs::default();
        assert_eq!(global_fault(&inputs), None);
        // The tick's mean current is the drive's business (it sees every period).
        inputs.motor_current = AdcCode::MAX;
        assert_eq!(global_fault(&inputs), None);
        inputs.drive.fault = Some(DriveFault::Overcurrent);
        assert_eq!(global_fault(&inputs), Some(FaultCode::Overcurrent));
        inputs.drive.fault = Some(DriveFault::BusOvervoltage);
        assert_eq!(global_fault(&inputs), Some(FaultCode::BusOvervoltage));
        inputs.drive.fault = Some(DriveFault::HallInvalid);
        assert_eq!(global_fault(&inputs), Some(FaultCode::HallInvalid));
        inputs.limits = LimitSwitches { home: true, end: true };
        assert_eq!(global_fault(&inputs), Some(FaultCode::LimitsBoth));
    }

    #[test]
    fn stall_needs_duty_time_driven_and_no_step_each_at_its_threshold() {
        let at = |duty: Duty| DriveCommand::Drive { direction: Direction::Pull, duty };
        let mut inputs = Inputs::default();
        inputs.drive.quiet_for = STALL_QUIET;
        // 500 ms without a step is 500 000 µs of drive time.
        assert_eq!(STALL_QUIET, DriveTime::from_micros(500_000));
        assert!(stall(at(STALL_DUTY), &inputs, STALL_QUIET_MS));
        // Each condition one unit short of its threshold: no stall.
        let below = Duty::from_raw_clamped(STALL_DUTY.raw() - 1);
        assert!(!stall(at(below), &inputs, STALL_QUIET_MS));
        assert!(!stall(at(STALL_DUTY), &inputs, STALL_QUIET_MS - 1));
        inputs.drive.quiet_for = DriveTime(STALL_QUIET.0 - 1);
        assert!(!stall(at(STALL_DUTY), &inputs, STALL_QUIET_MS));
        // Only one condition met: no stall.
        inputs.drive.quiet_for = DriveTime(0);
        assert!(!stall(at(crate::drive::DUTY_MAX), &inputs, u32::MAX));
        inputs.drive.quiet_for = DriveTime(u32::MAX);
        assert!(!stall(DriveCommand::Coast, &inputs, u32::MAX));
        assert!(!stall(at(crate::drive::DUTY_MAX), &inputs, 0));
    }

    #[test]
    fn load_cell_rails_at_their_codes() {
        assert_eq!(load_cell_rail(AdcCode::new(0)), Some(FaultCode::LoadCellOpen));
        assert_eq!(load_cell_rail(LOAD_CELL_BOTTOM_RAIL), Some(FaultCode::LoadCellOpen));
        assert_eq!(load_cell_rail(AdcCode::new(LOAD_CELL_BOTTOM_RAIL.get() + 1)), None);
        assert_eq!(load_cell_rail(AdcCode::new(2_048)), None);
        assert_eq!(load_cell_rail(AdcCode::new(LOAD_CELL_TOP_RAIL.get() - 1)), None);
        assert_eq!(load_cell_rail(LOAD_CELL_TOP_RAIL), Some(FaultCode::LoadCellShort));
        assert_eq!(load_cell_rail(AdcCode::MAX), Some(FaultCode::LoadCellShort));
    }

    #[test]
    fn watch_validity_is_its_invariant() {
        let fresh = TensionWatch::new(7);
        assert!(fresh.is_valid());
        let kgf = Kgf::from_int;
        let full = EVIDENCE_BITS;
        let watch = |peak, tension, raw, counters, evidence| {
            TensionWatch::from_parts(0, [kgf(peak), kgf(tension), kgf(raw)], counters, evidence)
        };
        let all = [full; 3];
        assert!(watch(60, 60, -60, [20, 10], all).is_valid());
        assert!(!watch(61, 0, 0, [0; 2], [0; 3]).is_valid());
        assert!(!watch(-1, -2, 0, [0; 2], [0; 3]).is_valid());
        // The peak may lag a rising tension (it rises at most PEAK_RISE a tick).
        assert!(watch(10, 11, 0, [0; 2], [0; 3]).is_valid());
        assert!(!watch(10, -61, 0, [0; 2], [0; 3]).is_valid());
        assert!(!watch(10, 0, 61, [0; 2], [0; 3]).is_valid());
        assert!(!watch(10, 0, -61, [0; 2], [0; 3]).is_valid());
        assert!(!watch(10, 0, 0, [21, 0], [0; 3]).is_valid());
        assert!(!watch(10, 0, 0, [0, 11], [0; 3]).is_valid());
        // A history holds the window's bits only, the oldest outside it gone.
        assert_eq!(full, 0x7FFF);
        for history in 0..3 {
            let mut beyond = [0; 3];
            beyond[history] = full + 1;
            assert!(!watch(10, 0, 0, [0; 2], beyond).is_valid(), "{history}");
        }
        // Every tick keeps a valid watch valid, whatever the sample.
        let mut running = watch(60, 60, -60, [20, 10], all);
        for tension in [i16::MIN, -61, 0, 61, i16::MAX] {
            running.check(&sample(tension, 0));
            assert!(running.is_valid(), "{running:?}");
        }
    }

    #[test]
    fn the_evidence_is_the_majority_of_the_window() {
        assert_eq!(EVIDENCE_WINDOW, 15);
        // The newest judgement is the lowest bit; the one fifteen ticks old leaves.
        assert_eq!(witness(0, true), 1);
        assert_eq!(witness(1, false), 2);
        assert_eq!(witness(EVIDENCE_BITS, false), EVIDENCE_BITS - 1);
        assert_eq!(witness(1 << (EVIDENCE_WINDOW - 1), false), 0);
        // Eight of fifteen, wherever they lie, and no fewer.
        assert!(majority(0xFF));
        assert!(majority(0x5555));
        assert!(!majority(0x7F));
        assert!(!majority(0x2AAA));
        assert!(!majority(0xFF00 & !EVIDENCE_BITS), "bits outside the window are not counted");
    }

    #[test]
    fn limit_guard_blocks_only_toward_the_active_switch() {
        let pull = DriveCommand::Drive { direction: Direction::Pull, duty: STALL_DUTY };
        let release = DriveCommand::Drive { direction: Direction::Release, duty: STALL_DUTY };
        let end = LimitSwitches { home: false, end: true };
        let home = LimitSwitches { home: true, end: false };
        assert_eq!(limit_guard(pull, end), DriveCommand::Coast);
        assert_eq!(limit_guard(release, end), release);
        assert_eq!(limit_guard(release, home), DriveCommand::Coast);
        assert_eq!(limit_guard(pull, home), pull);
    }

    fn sample(tension: i16, steps: i32) -> TensionSample {
        TensionSample {
            tension: Kgf::from_int(tension),
            raw: Kgf::from_int(tension),
            steps,
            limits: LimitSwitches::default(),
            peak_target: Kgf::from_int(25),
        }
    }

    /// Feeds `tension` (at Hall count `steps`) for `ticks`; the first fault and its tick.
    fn feed(
        watch: &mut TensionWatch,
        tension: i16,
        steps: i32,
        ticks: u32,
    ) -> Option<(u32, FaultCode)> {
        (1..=ticks).find_map(|tick| watch.check(&sample(tension, steps)).map(|code| (tick, code)))
    }

    /// A watch that has followed a steady `tension` for long enough to track it.
    fn settled_at(tension: i16) -> TensionWatch {
        let mut watch = TensionWatch::new(0);
        assert_eq!(feed(&mut watch, tension, 10, 400), None);
        assert_eq!(watch.tension, Kgf::from_int(tension));
        assert_eq!(watch.peak, Kgf::from_int(tension.max(0)));
        watch
    }

    #[test]
    fn tracking_moves_at_most_one_kgf_a_tick_and_stays_in_range() {
        let one = TRACK_SLEW;
        assert_eq!(track(Kgf::ZERO, Kgf::from_int(5)), one);
        assert_eq!(track(Kgf::ZERO, Kgf::from_int(-5)), Kgf::ZERO.saturating_sub(one));
        assert_eq!(track(Kgf::from_int(3), Kgf::from_tenths(35)), Kgf::from_tenths(35));
        assert_eq!(track(TRACK_LIMIT, Kgf::MAX), TRACK_LIMIT);
        assert_eq!(track(Kgf::MIN, Kgf::MIN), Kgf::ZERO.saturating_sub(TRACK_LIMIT));
    }

    #[test]
    fn a_spike_is_not_an_overload_and_does_not_set_the_peak() {
        let mut watch = settled_at(25);
        // One +20 kgf sample, then the true tension again: the tracked tension moves 1 kgf,
        // the peak not at all (one sample of fifteen is no majority).
        assert_eq!(watch.check(&sample(45, 10)), None);
        assert_eq!(watch.tension, Kgf::from_int(26));
        assert_eq!(watch.peak, Kgf::from_int(25));
        assert_eq!(feed(&mut watch, 25, 10, 50), None);
        // A real overload: the tension steps to 31 (limit 30) and stays. Tracked above 30
        // after 6 ticks, the majority of the window above it at the 8th.
        assert_eq!(feed(&mut watch, 31, 10, 100), Some((EVIDENCE_MAJORITY, FaultCode::Overload)));
        // From 20 kgf the tracked tension is what takes longest: above 30 at the 11th tick.
        let mut watch = settled_at(20);
        assert_eq!(feed(&mut watch, 40, 10, 100), Some((11, FaultCode::Overload)));
    }

    #[test]
    fn string_break_after_the_tension_collapses_within_its_time() {
        let mut watch = settled_at(25);
        // Tracked below 12.5 (half the peak) at the 13th tick (⌊P/2⌋ + 1), the majority of
        // the window below it from the 8th: the break latches at the 13th.
        assert_eq!(feed(&mut watch, 0, 100, 100), Some((13, FaultCode::StringBreak)));
        // Below 14 kgf the majority is what takes longest: the 8th tick.
        let mut watch = settled_at(10);
        let expected = EVIDENCE_MAJORITY;
        assert_eq!(feed(&mut watch, 0, 100, 100), Some((expected, FaultCode::StringBreak)));
        // At the 50 kgf rating: within the spec's 26 ms.
        let at = |tension| TensionSample { peak_target: Kgf::from_int(50), ..sample(tension, 10) };
        let mut watch = TensionWatch::new(0);
        for _ in 0..400 {
            assert_eq!(watch.check(&at(50)), None);
        }
        assert_eq!(watch.peak, Kgf::from_int(50));
        let tick = (1..=100u32).find(|_| watch.check(&at(0)).is_some());
        assert_eq!(tick, Some(26));
    }

    /// Feeds a pull to `tension` held steady for 400 ticks, then `spiked(tick)` samples
    /// `by` kgf off it for 100 ticks; whether anything faulted, and the peak.
    fn spiked_hold(tension: i16, by: i16, spiked: impl Fn(u32) -> bool) -> (bool, Kgf) {
        let at =
            |value: i16| TensionSample { peak_target: Kgf::from_int(tension), ..sample(value, 10) };
        let mut watch = TensionWatch::new(0);
        let mut faulted = (0..400).any(|_| watch.check(&at(tension)).is_some());
        assert_eq!(watch.peak, Kgf::from_int(tension));
        faulted |= (0..100u32).any(|tick| {
            let value = if spiked(tick) { tension.saturating_add(by) } else { tension };
            watch.check(&at(value)).is_some()
        });
        (faulted, watch.peak)
    }

    #[test]
    fn no_burst_of_up_to_the_estimators_length_breaks_an_intact_string_or_lifts_the_peak() {
        // Any burst of ≤ BURST_MAX samples of any height either way, alone or with
        // SPIKES_BESIDE single spikes of the same sign beside it, at any steady tension from
        // 1 to 50 kgf held at its target: no fault, and the peak never rises above the
        // tension.
        let burst_max = u32::try_from(BURST_MAX).unwrap_or(0);
        for tension in 1..=50_i16 {
            for burst in 1..=burst_max {
                for by in [-60, -tension, -3, 3, 40] {
                    let alone = |tick| (2..2 + burst).contains(&tick);
                    let beside = |tick| alone(tick) || tick == burst + 5 || tick == burst + 7;
                    for (what, spiked) in
                        [("alone", &alone as &dyn Fn(u32) -> bool), ("beside", &beside)]
                    {
                        let (faulted, peak) = spiked_hold(tension, by, spiked);
                        assert!(!faulted, "{tension} kgf, {burst} × {by} {what}");
                        assert_eq!(peak, Kgf::from_int(tension), "{tension} kgf, {burst} × {by}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_burst_up_then_a_burst_down_is_not_a_break() {
        // The family's false E-15: pulling at 4.6 kgf after a peak of 5.1, a burst of three
        // samples 3 kgf high, then — 33 ms later — five samples 4 kgf low. Under a 1 kgf-slewed
        // peak with a persistence of five ticks the first lifted the peak to 5.86 and the
        // second held the tracked tension below half of it for five ticks.
        let mut watch = TensionWatch::new(0);
        let tenths = |t: i32| TensionSample { tension: Kgf::from_tenths(t), ..sample(0, 10) };
        for _ in 0..400 {
            assert_eq!(watch.check(&tenths(51)), None);
        }
        for _ in 0..50 {
            assert_eq!(watch.check(&tenths(46)), None);
        }
        let peak = watch.peak;
        let script = [76, 76, 76].iter().chain(&[46; 30]).chain(&[6, 6, 6, 6, 6]).chain(&[46; 50]);
        for &value in script {
            assert_eq!(watch.check(&tenths(value)), None, "{value}");
        }
        assert_eq!(watch.peak, peak);
        // Every pairing of an upward and a downward burst of up to BURST_MAX samples, at
        // every gap up to the window, near the break's floor: no fault.
        let burst_max = u32::try_from(BURST_MAX).unwrap_or(0);
        for tension in 3..=8_i16 {
            for (up, down) in (1..=burst_max).flat_map(|up| (1..=burst_max).map(move |d| (up, d))) {
                for gap in 0..EVIDENCE_WINDOW {
                    let mut watch = settled_at(tension);
                    let faulted = (0..100u32).any(|tick| {
                        let value = if tick < up {
                            tension.saturating_add(40)
                        } else if (up + gap..up + gap + down).contains(&tick) {
                            0
                        } else {
                            tension
                        };
                        watch.check(&sample(value, 10)).is_some()
                    });
                    assert!(!faulted, "{tension} kgf, {up} up, {gap} apart, {down} down");
                }
            }
        }
    }

    #[test]
    fn a_drop_spike_after_a_spike_peak_is_not_a_break() {
        // Tension 8 kgf; a +5 spike then a −8 spike: the tracked tension moves 9 → 8 → 7.
        let mut watch = settled_at(8);
        assert_eq!(watch.check(&sample(13, 10)), None);
        assert_eq!(watch.check(&sample(0, 10)), None);
        assert_eq!(feed(&mut watch, 8, 10, 100), None);
    }

    #[test]
    fn spikes_at_five_percent_never_fault_an_intact_string() {
        // A pull to 25 kgf and a 20 s hold with a ±5 kgf spike on 5 % of the samples
        // (deterministic pseudo-random positions), pairs included.
        let mut watch = TensionWatch::new(0);
        let mut state = 0x2545_F491_u32;
        let mut spikes = 0u32;
        for tick in 0..20_000u32 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let truth = i16::try_from(tick.min(250) / 10).unwrap_or(25);
            let spike = match state % 40 {
                0 => 5,
                1 => -5,
                _ => 0,
            };
            spikes += u32::from(spike != 0);
            assert_eq!(watch.check(&sample(truth + spike, 10)), None, "tick {tick}");
        }
        assert!(spikes > 900, "{spikes}");
        // The spikes never make a majority of the window: the peak is the true 25 kgf.
        assert_eq!(watch.peak, Kgf::from_int(25));
    }

    #[test]
    fn no_string_after_the_travel_limit() {
        let mut watch = TensionWatch::new(1_000);
        assert_eq!(watch.check(&sample(0, 1_000 + NO_STRING_TRAVEL_STEPS)), None);
        assert_eq!(
            watch.check(&sample(0, 1_001 + NO_STRING_TRAVEL_STEPS)),
            Some(FaultCode::NoString)
        );
        // Spikes while the carriage runs empty do not count as a string.
        let mut watch = TensionWatch::new(0);
        for _ in 0..20 {
            assert_eq!(watch.check(&sample(5, 100)), None);
            assert_eq!(watch.check(&sample(5, 100)), None);
            assert_eq!(feed(&mut watch, 0, 100, 8), None);
        }
        assert_eq!(watch.check(&sample(0, 5_000)), Some(FaultCode::NoString));
        // With tension held, long travel is fine (a long, stretchy string).
        let mut watch = TensionWatch::new(0);
        assert_eq!(feed(&mut watch, 3, 5, u32::from(LOADED_PERSIST) + 2), None);
        assert!(watch.loaded());
        assert_eq!(watch.check(&sample(3, 5_000)), None);
    }

    #[test]
    fn reversed_reading_latches_after_persisting() {
        let mut watch = TensionWatch::new(0);
        let negative = TensionSample { raw: Kgf::from_int(-1), ..sample(0, 10) };
        // Exactly at the threshold is not reversed.
        let at = TensionSample { raw: REVERSED_TENSION, ..sample(0, 10) };
        let mut level =
            TensionWatch::from_parts(0, [Kgf::ZERO, Kgf::ZERO, REVERSED_TENSION], [0; 2], [0; 3]);
        for _ in 0..u32::from(REVERSED_PERSIST) * 2 {
            assert_eq!(level.check(&at), None);
        }
        // The tracked raw tension is below −0.3 from the first tick.
        for _ in 0..REVERSED_PERSIST - 1 {
            assert_eq!(watch.check(&negative), None);
        }
        assert_eq!(watch.check(&negative), Some(FaultCode::LoadCellReversed));
    }

    #[test]
    fn end_limit_while_tensioning_is_end_of_travel() {
        let mut watch = TensionWatch::new(0);
        let at_end =
            TensionSample { limits: LimitSwitches { home: false, end: true }, ..sample(3, 10) };
        assert_eq!(watch.check(&at_end), Some(FaultCode::EndOfTravel));
    }

    #[test]
    fn overload_limit_is_capped() {
        assert_eq!(overload_limit(Kgf::from_int(20)), Kgf::from_int(25));
        assert_eq!(overload_limit(Kgf::from_int(50)), OVERLOAD_ABSOLUTE);
    }
}

//! The drive's safety properties (`REQ-DRV-*`), each a plain function over one recorded call.
//!
//! # How the properties are checked
//!
//! A call of the fast loop is described by a [`StepInput`] made only of primitive values
//! (Hall bits, a command, converter codes, flags, elapsed ticks), so Kani (`kani::any()`),
//! proptest and libFuzzer (`arbitrary`) can all generate it. [`apply`] feeds one input to a
//! [`Drive`] exactly as the firmware does — hold the command, optionally ask for a fault
//! clear, then run [`Drive::step`] — and returns a [`StepRecord`] of the states before and
//! after and the emitted output. Each property is a function of the record (and, for
//! properties about sequences, of an [`Observer`] that remembers what was emitted before);
//! it panics with a message naming its requirement id when the property fails.
//!
//! Three drivers run the same bodies:
//! - the Kani harnesses in [`verification`] (`cargo kani -p taut-proofs`), over every input
//!   sequence three calls deep from power-up, and inductively from any valid sequencer state;
//! - `proofs/tests/drive.rs` under `cargo test`: exhaustive over the finite domains (sector ×
//!   direction tables, every duty value, every reachable state three calls deep over an
//!   alphabet with one representative per behaviour class) and proptest over long random
//!   sequences with full-range inputs;
//! - the cargo-fuzz target `drive_sequence` over arbitrary call sequences.
//!
//! # Independence
//!
//! The properties do not reuse the drive's own bookkeeping. Overcurrent is judged by
//! converting the code with [`current::amps`] and comparing it with [`OVERCURRENT_LIMIT`]
//! (the drive compares codes against a precomputed threshold); dead time and reversal are
//! judged from the emitted patterns and the elapsed ticks alone (the drive keeps its own
//! timers); the table is judged against the exhaustive facts "one high, one low, different
//! legs" and "every on-leg matches [`six_step`] for the accepted sector and the commanded
//! direction".

use taut_core::drive::{
    ClearRefused, DEAD_TIME, DUTY_MAX, Direction, Drive, DriveCommand, DriveOutput, DriveSample,
    Duty, HallCode, HallState, LegState, OVERCURRENT_LIMIT, Phase, PwmTicks, REVERSAL_QUIET,
    Sector, SectorStep, SwitchPattern, six_step,
};
use taut_core::io::LimitSwitches;
use taut_core::sense::current;
use taut_core::units::AdcCode;

/// The command part of a [`StepInput`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub enum CommandInput {
    /// [`DriveCommand::Coast`].
    Coast,
    /// Pull at this raw duty (clamped to [`DUTY_MAX`] by [`Duty::from_raw_clamped`]).
    Pull(u16),
    /// Release at this raw duty.
    Release(u16),
}

impl CommandInput {
    /// The drive command this stands for.
    #[must_use]
    pub fn command(self) -> DriveCommand {
        match self {
            Self::Coast => DriveCommand::Coast,
            Self::Pull(raw) => DriveCommand::Drive {
                direction: Direction::Pull,
                duty: Duty::from_raw_clamped(raw),
            },
            Self::Release(raw) => DriveCommand::Drive {
                direction: Direction::Release,
                duty: Duty::from_raw_clamped(raw),
            },
        }
    }
}

/// One call of the fast loop, in primitive values.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct StepInput {
    /// Raw Hall bits (only the low three are lines).
    pub hall: u8,
    /// The command held from the control tick.
    pub command: CommandInput,
    /// Whether the control tick asks for a fault clear before this call.
    pub clear: bool,
    /// Raw bus-current code (saturated to 12 bits).
    pub current: u16,
    /// Overcurrent comparator flag.
    pub trip: bool,
    /// Home limit switch.
    pub home: bool,
    /// End limit switch.
    pub end: bool,
    /// PWM-timer ticks since the previous call.
    pub elapsed: u32,
}

impl StepInput {
    /// The fast-loop sample this input describes.
    #[must_use]
    pub fn sample(&self) -> DriveSample {
        DriveSample {
            hall: HallCode::from_raw(self.hall),
            current: AdcCode::new(self.current),
            overcurrent_trip: self.trip,
            bus_voltage: AdcCode::MIN,
            limits: LimitSwitches { home: self.home, end: self.end },
            elapsed: PwmTicks(self.elapsed),
        }
    }
}

/// Everything about one call that the properties look at.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct StepRecord {
    /// What was fed in.
    pub input: StepInput,
    /// The drive before the call (before the command was set).
    pub before: Drive,
    /// The held command when the clear was attempted (if it was).
    pub command_at_clear: DriveCommand,
    /// The result of the clear, if one was asked for.
    pub clear: Option<Result<(), ClearRefused>>,
    /// What the drive emitted.
    pub output: DriveOutput,
    /// The drive after the call.
    pub after: Drive,
}

impl StepRecord {
    /// Whether a fault clear succeeded in this call.
    #[must_use]
    pub fn cleared(&self) -> bool {
        matches!(self.clear, Some(Ok(())))
    }
}

/// Feeds one input to `drive` as the firmware would: hold the command, optionally clear,
/// then step.
pub fn apply(drive: &mut Drive, input: &StepInput) -> StepRecord {
    let before = *drive;
    drive.set_command(input.command.command());
    let command_at_clear = drive.command();
    let clear = input.clear.then(|| drive.clear_fault());
    let output = drive.step(input.sample());
    StepRecord { input: *input, before, command_at_clear, clear, output, after: *drive }
}

/// REQ-DRV-01, bounded duty: every emitted duty is at most [`DUTY_MAX`], and it is zero when
/// no high side conducts, when a fault is latched, and when the accepted Hall state is not a
/// valid sector.
pub fn bounded_duty(record: &StepRecord) {
    let out = record.output;
    assert!(out.duty <= DUTY_MAX, "REQ-DRV-01: duty {} above DUTY_MAX", out.duty.raw());
    assert!(out.duty.is_valid(), "REQ-DRV-01: duty invariant broken");
    if out.pattern.count(LegState::High) == 0 {
        assert!(out.duty.is_zero(), "REQ-DRV-01: duty without a conducting high side");
    }
    if record.after.fault().is_some() {
        assert!(out.duty.is_zero(), "REQ-DRV-01: duty while faulted");
    }
    if !matches!(record.after.hall(), HallState::Sector(_)) {
        assert!(out.duty.is_zero(), "REQ-DRV-01: duty with no valid Hall sector");
    }
}

/// REQ-DRV-02, no shoot-through in any emitted pattern: no leg has both gates on, at most
/// one high side and one low side conduct, and every conducting leg is the six-step table's
/// entry for the accepted sector and the commanded direction.
pub fn no_shoot_through(record: &StepRecord) {
    pattern_is_safe(&record.output.pattern);
    let pattern = record.output.pattern;
    if pattern.is_all_off() {
        return;
    }
    let HallState::Sector(sector) = record.after.hall() else {
        panic!("REQ-DRV-02: a leg conducts with no valid Hall sector");
    };
    let Some(direction) = record.input.command.command().direction() else {
        panic!("REQ-DRV-02: a leg conducts while coasting");
    };
    let table = six_step(sector, direction);
    for phase in Phase::ALL {
        let leg = pattern.leg(phase);
        assert!(
            !leg.is_on() || leg == table.leg(phase),
            "REQ-DRV-02: leg {phase:?} is {leg:?}, table says {:?}",
            table.leg(phase)
        );
    }
}

/// The per-pattern half of REQ-DRV-02, on the six gate signals the firmware applies.
pub fn pattern_is_safe(pattern: &SwitchPattern) {
    let gates = pattern.gates();
    let mut highs = 0u8;
    let mut lows = 0u8;
    for phase in Phase::ALL {
        let (high, low) = gates.leg(phase);
        assert!(!(high && low), "REQ-DRV-02: shoot-through on leg {phase:?}");
        highs = highs.saturating_add(u8::from(high));
        lows = lows.saturating_add(u8::from(low));
    }
    assert!(highs <= 1 && lows <= 1, "REQ-DRV-02: {highs} high and {lows} low sides on");
}

/// REQ-DRV-02, the table itself: every (sector, direction) entry has exactly one high side
/// and one low side on, on different legs, and the third leg off.
pub fn six_step_entry_is_well_formed(sector: Sector, direction: Direction) {
    let entry = six_step(sector, direction);
    pattern_is_safe(&entry);
    assert_eq!(entry.count(LegState::High), 1, "REQ-DRV-02: {sector:?} {direction:?} highs");
    assert_eq!(entry.count(LegState::Low), 1, "REQ-DRV-02: {sector:?} {direction:?} lows");
    assert_eq!(entry.count(LegState::Off), 1, "REQ-DRV-02: {sector:?} {direction:?} offs");
}

/// REQ-DRV-09, commutation: the sectors are numbered in the paper's forward Hall order, the
/// release table is the pull table three sectors on (high and low exchanged), and moving one
/// sector either way never changes a leg directly between high and low.
pub fn commutation_is_consistent(sector: Sector, direction: Direction) {
    let next = sector.advanced(1);
    assert_eq!(
        SectorStep::between(sector, next),
        SectorStep::Forward,
        "REQ-DRV-09: {sector:?}→{next:?} is not a forward step"
    );
    assert_eq!(
        six_step(sector, Direction::Release),
        six_step(sector.advanced(3), Direction::Pull),
        "REQ-DRV-09: release table is not the pull table three sectors on"
    );
    let now = six_step(sector, direction);
    for then in [six_step(next, direction), six_step(sector.advanced(5), direction)] {
        for phase in Phase::ALL {
            let swap = matches!(
                (now.leg(phase), then.leg(phase)),
                (LegState::High, LegState::Low) | (LegState::Low, LegState::High)
            );
            assert!(!swap, "REQ-DRV-09: adjacent sectors swap leg {phase:?} at {sector:?}");
        }
    }
}

/// What the sequence properties remember between calls, built only from the emitted outputs,
/// the elapsed ticks and the accepted Hall state.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Observer {
    /// Per leg: the side it was last on (`Off` if never) and the ticks it has been off since.
    legs: [(LegState, u32); 3],
    /// The previous call's emitted pattern.
    previous: SwitchPattern,
    /// The direction of the last emitted non-off pattern.
    last_direction: Option<Direction>,
    /// Whether an all-off pattern was emitted since then.
    off_since: bool,
    /// The accepted sector last seen.
    last_sector: Option<Sector>,
    /// Ticks since the accepted sector last changed.
    quiet_for: u32,
    /// The direction the accepted sector last moved.
    rotation: Option<Direction>,
    /// The comparator flag in the previous call.
    last_trip: bool,
}

impl Observer {
    /// An observer at power-up: every leg off and never on.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes in one call, after the properties have judged it.
    pub fn observe(&mut self, record: &StepRecord) {
        let elapsed = record.input.elapsed;
        let pattern = record.output.pattern;
        for (slot, phase) in self.legs.iter_mut().zip(Phase::ALL) {
            let (last_on, off_for) = *slot;
            let was = self.previous.leg(phase);
            let now = pattern.leg(phase);
            *slot = if now.is_on() {
                (now, 0)
            } else if was.is_on() {
                (last_on_or(was, last_on), 0)
            } else {
                (last_on, off_for.saturating_add(elapsed))
            };
        }
        self.previous = pattern;
        self.last_trip = record.input.trip;
        if pattern.is_all_off() {
            self.off_since = true;
        } else {
            self.last_direction = record.input.command.command().direction();
            self.off_since = false;
        }
        self.quiet_for = self.quiet_for.saturating_add(elapsed);
        if let HallState::Invalid(_) = record.after.hall() {
            // A confirmed invalid code ends the run of valid sectors: the next valid sector
            // is a fresh start, not a step from the one before the sensors failed.
            self.last_sector = None;
        }
        if let HallState::Sector(sector) = record.after.hall() {
            if let Some(previous) = self.last_sector {
                match SectorStep::between(previous, sector) {
                    SectorStep::Forward => {
                        self.rotation = Some(Direction::Pull);
                        self.quiet_for = 0;
                    }
                    SectorStep::Backward => {
                        self.rotation = Some(Direction::Release);
                        self.quiet_for = 0;
                    }
                    SectorStep::Stay | SectorStep::Skipped => {}
                }
            }
            self.last_sector = Some(sector);
        }
    }
}

fn last_on_or(was: LegState, last_on: LegState) -> LegState {
    if was.is_on() { was } else { last_on }
}

/// REQ-DRV-03, dead time: no leg changes between high and low — directly, or through an
/// off spell — unless it has been off for at least [`DEAD_TIME`] ticks in between.
pub fn dead_time_respected(observer: &Observer, record: &StepRecord) {
    let elapsed = record.input.elapsed;
    for (&(last_on, off_for), phase) in observer.legs.iter().zip(Phase::ALL) {
        let was = observer.previous.leg(phase);
        let now = record.output.pattern.leg(phase);
        if !now.is_on() {
            continue;
        }
        if was.is_on() {
            assert_eq!(was, now, "REQ-DRV-03: leg {phase:?} swapped {was:?}→{now:?} directly");
        } else if last_on.is_on() && last_on != now {
            let off = off_for.saturating_add(elapsed);
            assert!(
                off >= DEAD_TIME.0,
                "REQ-DRV-03: leg {phase:?} {last_on:?}→{now:?} after only {off} ticks off"
            );
        }
    }
}

/// REQ-DRV-04, Hall faults: a confirmed `000`/`111`, or a jump of two or more sectors between
/// two consecutively accepted valid sectors, switches everything off and latches a fault in
/// the same call.
pub fn hall_fault_turns_off(observer: &Observer, record: &StepRecord) {
    let skipped = match (observer.last_sector, record.after.hall()) {
        (Some(previous), HallState::Sector(now)) => {
            SectorStep::between(previous, now) == SectorStep::Skipped
        }
        _ => false,
    };
    let invalid = matches!(record.after.hall(), HallState::Invalid(_));
    if invalid || skipped {
        assert_eq!(record.output, DriveOutput::OFF, "REQ-DRV-04: bridge on after a Hall fault");
        assert!(record.after.fault().is_some(), "REQ-DRV-04: Hall fault not latched");
    }
}

/// REQ-DRV-05, overcurrent: a current sample at or above [`OVERCURRENT_LIMIT`], or the
/// comparator flag, switches everything off and latches a fault in the same call.
pub fn overcurrent_turns_off(record: &StepRecord) {
    let sample = record.input.sample();
    if sample.overcurrent_trip || current::amps(sample.current) >= OVERCURRENT_LIMIT {
        assert_eq!(record.output, DriveOutput::OFF, "REQ-DRV-05: bridge on during overcurrent");
        assert!(record.after.fault().is_some(), "REQ-DRV-05: overcurrent not latched");
    }
}

/// REQ-DRV-06, latching: a latched fault keeps everything off until a clear succeeds; a
/// clear succeeds only with the held command zeroed (coast) — so no old command runs on —
/// and not while the comparator is still tripped. Latching a fault drops the held command.
pub fn fault_latched_until_cleared(observer: &Observer, record: &StepRecord) {
    if record.cleared() {
        assert_eq!(
            record.command_at_clear,
            DriveCommand::Coast,
            "REQ-DRV-06: fault cleared with a non-zero command held"
        );
        assert!(!observer.last_trip, "REQ-DRV-06: fault cleared while the comparator trips");
    }
    if record.before.fault().is_some() && !record.cleared() {
        assert_eq!(record.output, DriveOutput::OFF, "REQ-DRV-06: bridge on while latched");
        assert_eq!(record.after.fault(), record.before.fault(), "REQ-DRV-06: fault changed");
    }
    if record.before.fault().is_none() && record.after.fault().is_some() {
        assert_eq!(record.after.command(), DriveCommand::Coast, "REQ-DRV-06: command kept");
    }
}

/// REQ-DRV-07, limit switches: the bridge is never energised toward an actuated limit switch.
pub fn never_toward_active_limit(record: &StepRecord) {
    if record.output.pattern.is_all_off() {
        return;
    }
    let limits = record.input.sample().limits;
    if let Some(direction) = record.input.command.command().direction() {
        assert!(
            !direction.blocked_by(limits),
            "REQ-DRV-07: driving {direction:?} into an active limit {limits:?}"
        );
    }
}

/// REQ-DRV-08, safe reversal: the bridge goes from all-off to energised only in a call where
/// the rotor has made no accepted Hall step for [`REVERSAL_QUIET`] or its last step was in the
/// commanded direction (so it is never driven hard against its own back-EMF), and it is never
/// energised one way in the call right after being energised the other way.
pub fn safe_reversal(observer: &Observer, record: &StepRecord) {
    if record.output.pattern.is_all_off() {
        return;
    }
    let Some(direction) = record.input.command.command().direction() else {
        return;
    };
    if let Some(last) = observer.last_direction {
        assert!(
            last == direction || observer.off_since,
            "REQ-DRV-08: reversed {last:?}→{direction:?} with no off call"
        );
    }
    if !observer.previous.is_all_off() {
        return;
    }
    let (quiet_for, rotation) = rotor_after(observer, record);
    assert!(
        quiet_for >= REVERSAL_QUIET.0 || rotation == Some(direction),
        "REQ-DRV-08: energised {direction:?} while the rotor turns {rotation:?}, quiet {quiet_for} ticks"
    );
}

/// The rotor as seen at the end of `record`'s call: ticks since the accepted sector last
/// moved, and the way it last moved.
fn rotor_after(observer: &Observer, record: &StepRecord) -> (u32, Option<Direction>) {
    let step = match (observer.last_sector, record.after.hall()) {
        (Some(previous), HallState::Sector(now)) => SectorStep::between(previous, now),
        _ => SectorStep::Stay,
    };
    match step {
        SectorStep::Forward => (0, Some(Direction::Pull)),
        SectorStep::Backward => (0, Some(Direction::Release)),
        SectorStep::Stay | SectorStep::Skipped => {
            (observer.quiet_for.saturating_add(record.input.elapsed), observer.rotation)
        }
    }
}

/// A drive under observation: every call is checked against every property.
#[derive(Clone, Copy, Debug, Default)]
pub struct CheckedDrive {
    /// The drive.
    pub drive: Drive,
    /// The observer of its outputs.
    pub observer: Observer,
}

impl CheckedDrive {
    /// A fresh drive and observer.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Applies one input and checks REQ-DRV-01 … 08 on the call.
    pub fn step(&mut self, input: &StepInput) -> StepRecord {
        let record = apply(&mut self.drive, input);
        check_all(&self.observer, &record);
        self.observer.observe(&record);
        record
    }
}

/// Every drive property on one call.
pub fn check_all(observer: &Observer, record: &StepRecord) {
    bounded_duty(record);
    no_shoot_through(record);
    dead_time_respected(observer, record);
    hall_fault_turns_off(observer, record);
    overcurrent_turns_off(record);
    fault_latched_until_cleared(observer, record);
    never_toward_active_limit(record);
    safe_reversal(observer, record);
}

/// REQ-DRV-03, inductively: from *any* valid sequencer state (any legs, any off-times), one
/// call with any request never swaps a leg's side directly and never turns a leg on before it
/// has been off for [`DEAD_TIME`].
pub fn sequencer_step_is_safe(
    legs: [(LegState, PwmTicks); 3],
    requested: SwitchPattern,
    elapsed: PwmTicks,
) {
    let Some(mut sequencer) = taut_core::drive::DeadTimeSequencer::from_parts(legs) else {
        return;
    };
    let before = sequencer.pattern();
    let out = sequencer.step(requested, elapsed);
    pattern_is_safe_per_leg(&out);
    for (phase, (state, off_for)) in Phase::ALL.into_iter().zip(legs) {
        let was = before.leg(phase);
        let now = out.leg(phase);
        assert_eq!(was, state, "sequencer state round-trip");
        if now.is_on() && was != now {
            assert!(!was.is_on(), "REQ-DRV-03: leg {phase:?} swapped {was:?}→{now:?} directly");
            assert!(
                off_for.0.saturating_add(elapsed.0) >= DEAD_TIME.0,
                "REQ-DRV-03: leg {phase:?} on after {} ticks off",
                off_for.0.saturating_add(elapsed.0)
            );
        }
        if now.is_on() {
            assert_eq!(now, requested.leg(phase), "sequencer emitted an unrequested state");
        }
    }
    assert!(sequencer.is_valid(), "sequencer invariant broken");
}

fn pattern_is_safe_per_leg(pattern: &SwitchPattern) {
    let gates = pattern.gates();
    for phase in Phase::ALL {
        let (high, low) = gates.leg(phase);
        assert!(!(high && low), "REQ-DRV-02: shoot-through on leg {phase:?}");
    }
}

/// Kani harnesses: `cargo kani -p taut-proofs`.
#[cfg(kani)]
mod verification {
    use super::*;

    /// Runs three arbitrary calls from power-up, checking `property` on each.
    fn three_calls(property: impl Fn(&Observer, &StepRecord)) {
        let mut drive = Drive::new();
        let mut observer = Observer::new();
        for _ in 0..3 {
            let input: StepInput = kani::any();
            let record = apply(&mut drive, &input);
            property(&observer, &record);
            observer.observe(&record);
        }
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_bounded_duty() {
        three_calls(|_, record| bounded_duty(record));
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_no_shoot_through() {
        three_calls(|_, record| no_shoot_through(record));
    }

    fn any_sector() -> Sector {
        Sector::S0.advanced(kani::any::<u8>() % 6)
    }

    fn any_direction() -> Direction {
        if kani::any() { Direction::Pull } else { Direction::Release }
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_six_step_table() {
        six_step_entry_is_well_formed(any_sector(), any_direction());
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_commutation_consistent() {
        commutation_is_consistent(any_sector(), any_direction());
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_dead_time_sequence() {
        three_calls(dead_time_respected);
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_dead_time_inductive() {
        let leg = || -> (LegState, PwmTicks) {
            let state = match kani::any::<u8>() % 3 {
                0 => LegState::Off,
                1 => LegState::High,
                _ => LegState::Low,
            };
            (state, PwmTicks(kani::any()))
        };
        let requested = SwitchPattern { a: leg().0, b: leg().0, c: leg().0 };
        sequencer_step_is_safe([leg(), leg(), leg()], requested, PwmTicks(kani::any()));
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_hall_fault_all_off() {
        three_calls(hall_fault_turns_off);
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_overcurrent_all_off() {
        three_calls(|_, record| overcurrent_turns_off(record));
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_fault_latched_until_cleared() {
        three_calls(fault_latched_until_cleared);
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_limit_interlock() {
        three_calls(|_, record| never_toward_active_limit(record));
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_safe_reversal() {
        three_calls(safe_reversal);
    }
}

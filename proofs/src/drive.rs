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
//! converting the code's distance from the drive's tared zero with [`current::amps`] and
//! comparing it with the trip the drive's configuration was built with
//! ([`taut_core::drive::DriveConfig::trip`]; the drive compares codes against a precomputed
//! threshold); the bus by converting its code to millivolts; dead time, reversal and the
//! current window are judged from the emitted patterns, the Hall states and the elapsed ticks
//! alone, with the back-EMF recomputed from the motor's constant (the drive keeps its own
//! timers); the table is judged against the exhaustive facts "one high, one low, different
//! legs" and "every on-leg matches [`six_step`] for the accepted sector and the commanded
//! direction".

use taut_core::drive::{
    ClearRefused, DUTY_MAX, Direction, Drive, DriveCommand, DriveOutput, DriveSample, DriveTime,
    Duty, HALL_CONFIRM_READS, HallCode, HallState, LegState, Phase, Sector, SectorStep,
    SwitchPattern, six_step,
};
use taut_core::io::LimitSwitches;
use taut_core::sense::current;
use taut_core::units::{AdcCode, Q16};

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
    /// Time since the previous call, [`DriveTime`] units (100 ns).
    pub elapsed: u32,
    /// Raw bus-voltage code (saturated to 12 bits).
    pub bus: u16,
}

impl StepInput {
    /// The fast-loop sample this input describes.
    #[must_use]
    pub fn sample(&self) -> DriveSample {
        DriveSample {
            hall: HallCode::from_raw(self.hall),
            current: AdcCode::new(self.current),
            overcurrent_trip: self.trip,
            bus_voltage: AdcCode::new(self.bus.min(4_095)),
            limits: LimitSwitches { home: self.home, end: self.end },
            elapsed: DriveTime(self.elapsed),
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

/// REQ-DRV-01 at the type: every way of making a [`Duty`] — from any raw value, from any
/// Q15.16 fraction — gives one within [`DUTY_MAX`], and its PWM compare value is at most
/// 95 % of any timer period. (The drive's window clamps again; this is the layer beneath it.)
pub fn duty_constructors_bounded(raw: u16, fraction: i32, period_ticks: u16) {
    for duty in [Duty::from_raw_clamped(raw), Duty::from_fraction_clamped(Q16::from_bits(fraction))]
    {
        assert!(
            duty <= DUTY_MAX && duty.is_valid(),
            "REQ-DRV-01: duty {} above DUTY_MAX",
            duty.raw()
        );
        let compare = u32::from(duty.compare_ticks(period_ticks));
        assert!(
            compare * 100 <= u32::from(period_ticks) * 95,
            "REQ-DRV-01: compare {compare} above 95 % of {period_ticks}"
        );
    }
}

/// REQ-DRV-02, no shoot-through in any emitted pattern: no leg has both gates on, at most
/// one high side and one low side conduct, and every conducting leg is the six-step table's
/// entry for the accepted sector and the commanded direction — or, braking (REQ-DRV-15), the
/// entry of the direction against it.
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
    assert!(
        pattern_direction(record).is_some(),
        "REQ-DRV-02: {pattern:?} follows neither table entry of {sector:?} ({direction:?} commanded)"
    );
}

/// The direction whose six-step entry for the accepted sector `record`'s pattern follows
/// (every conducting leg as that entry has it; at least one conducting). An entry and its
/// reverse put the same pair across the bus the other way round (`reverse(k) =
/// forward(k + 3)`), so a conducting pattern follows at most one of them.
#[must_use]
pub fn pattern_direction(record: &StepRecord) -> Option<Direction> {
    let pattern = record.output.pattern;
    let HallState::Sector(sector) = record.after.hall() else { return None };
    if pattern.is_all_off() {
        return None;
    }
    [Direction::Pull, Direction::Release].into_iter().find(|&direction| {
        let table = six_step(sector, direction);
        Phase::ALL.iter().all(|&phase| {
            let leg = pattern.leg(phase);
            !leg.is_on() || leg == table.leg(phase)
        })
    })
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
    /// Ticks between the last two moves of the accepted sector the same way (0: none yet).
    interval: u32,
    /// The way the accepted sector last moved by one step, forgotten at an invalid code or a
    /// skip.
    last_step: Option<Direction>,
    /// Ticks between the last two steps when the last reversed the one before (a turn-around).
    turn_gap: Option<u32>,
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
            self.last_direction = pattern_direction(record);
            self.off_since = false;
        }
        let rotor = rotor_after(self, record);
        (self.quiet_for, self.rotation, self.interval) =
            (rotor.quiet_for, rotor.rotation, rotor.interval);
        (self.last_step, self.turn_gap) = (rotor.last_step, rotor.turn_gap);
        if let HallState::Invalid(_) = record.after.hall() {
            // A confirmed invalid code ends the run of valid sectors: the next valid sector
            // is a fresh start, not a step from the one before the sensors failed.
            self.last_sector = None;
            self.last_step = None;
        }
        if let HallState::Sector(sector) = record.after.hall() {
            self.last_sector = Some(sector);
        }
    }
}

fn last_on_or(was: LegState, last_on: LegState) -> LegState {
    if was.is_on() { was } else { last_on }
}

/// REQ-DRV-03, dead time: no leg changes between high and low — directly, or through an
/// off spell — unless it has been off for at least the board's dead time in between.
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
                off >= record.before.config().dead_time().0,
                "REQ-DRV-03: leg {phase:?} {last_on:?}→{now:?} after only {off} units off"
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

/// A drive that has accepted `sector` from a rotor at rest (coasting, 24 V, no current), and
/// the observer that watched it: three calls from reset cannot accept two sectors one after
/// the other (each takes [`HALL_CONFIRM_READS`] reads), so the skipped-sector half of
/// REQ-DRV-04 starts here.
#[must_use]
pub fn at_rest_in(sector: Sector) -> (Drive, Observer) {
    let mut drive = Drive::new();
    let mut observer = Observer::new();
    let rest = StepInput {
        hall: sector.hall_code().raw(),
        command: CommandInput::Coast,
        clear: false,
        current: 0,
        trip: false,
        home: false,
        end: false,
        elapsed: 8_500,
        bus: 1_638,
    };
    for _ in 0..HALL_CONFIRM_READS {
        let record = apply(&mut drive, &rest);
        observer.observe(&record);
    }
    assert_eq!(drive.hall(), HallState::Sector(sector), "the prefix accepts {sector:?}");
    (drive, observer)
}

/// REQ-DRV-04 from a rotor accepted in `sector`: after any inputs, every call whose Hall
/// state is invalid or skipped a sector has the bridge off and a latched fault.
pub fn hall_fault_after(sector: Sector, inputs: &[StepInput]) {
    let (mut drive, mut observer) = at_rest_in(sector);
    for input in inputs {
        let record = apply(&mut drive, input);
        hall_fault_turns_off(&observer, &record);
        observer.observe(&record);
    }
}

/// The bus voltage of a code, mV, by the board's divider (60 V full scale).
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 4 095, mV ≤ 120 000, duty ≤ 65 535, divisors ≥ 1, all in i64/u64"
)]
fn bus_mv(code: AdcCode) -> u32 {
    u32::from(code.get()) * 60_000 / 4_096
}

/// REQ-DRV-05, overcurrent and bus overvoltage: a current sample whose distance from the
/// tared zero is at or above the trip of the drive's board
/// ([`taut_core::drive::DriveConfig::trip`]), the comparator flag, or a bus at or above its
/// configured maximum switches everything off and latches a fault in the same call.
pub fn overcurrent_turns_off(record: &StepRecord) {
    let sample = record.input.sample();
    let zero = record.before.current_zero().get();
    let from_zero = AdcCode::new(sample.current.get().abs_diff(zero));
    let config = record.before.config();
    let over = current::amps(from_zero) >= config.trip()
        || bus_mv(sample.bus_voltage) >= config.bus().max_mv;
    if sample.overcurrent_trip || over {
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

/// The direction whose six-step entry for the accepted sector has `record`'s conducting high
/// side (the entry and its reverse put the pair across the bus the other way round, so the
/// high side alone tells them apart; that the other legs follow the same entry is REQ-DRV-02's).
/// A cheaper [`pattern_direction`] for the properties that only look at conducting calls.
#[must_use]
pub fn high_side_direction(record: &StepRecord) -> Option<Direction> {
    let HallState::Sector(sector) = record.after.hall() else { return None };
    let pattern = record.output.pattern;
    let phase = Phase::ALL.into_iter().find(|&phase| pattern.leg(phase) == LegState::High)?;
    Some(if six_step(sector, Direction::Pull).leg(phase) == LegState::High {
        Direction::Pull
    } else {
        Direction::Release
    })
}

/// REQ-DRV-07, limit switches: the bridge is never energised under a command toward an
/// actuated limit switch, nor with the table of a direction toward one (a brake included).
pub fn never_toward_active_limit(record: &StepRecord) {
    if record.output.pattern.is_all_off() {
        return;
    }
    let limits = record.input.sample().limits;
    for direction in [record.input.command.command().direction(), pattern_direction(record)]
        .into_iter()
        .flatten()
    {
        assert!(
            !direction.blocked_by(limits),
            "REQ-DRV-07: driving {direction:?} into an active limit {limits:?}"
        );
    }
}

/// REQ-DRV-08, safe reversal: the bridge goes from all-off to energised only in a call where
/// the rotor does not turn against the commanded torque with a back-EMF of `I_lim·R` or more
/// (so no duty, not even zero, could keep the current within the limit) — the back-EMF bound
/// recomputed from the Hall steps the observer saw — and it is never energised one way in the
/// call right after being energised the other way.
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 4 095, mV ≤ 120 000, duty ≤ 65 535, divisors ≥ 1, all in i64/u64"
)]
pub fn safe_reversal(observer: &Observer, record: &StepRecord) {
    // The drive's own bookkeeping: a reversal passes through a call with nothing energised
    // (the dead-time sequencer would hold the gates off anyway; this is the rule itself).
    if let (Some(was), Some(now)) =
        (record.before.status().energized, record.after.status().energized)
    {
        assert!(was == now, "REQ-DRV-08: energised {now:?} in the call right after {was:?}");
    }
    if record.output.pattern.is_all_off() {
        return;
    }
    let Some(direction) = pattern_direction(record) else {
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
    let emf = emf_toward(observer, record, direction);
    let ir = i64::from(record.after.ir_mv());
    assert!(
        emf > -ir,
        "REQ-DRV-08: energised {direction:?} against a back-EMF of {emf} mV (limit {ir} mV)"
    );
}

/// The back-EMF bound, mV, toward `direction` at the end of `record`'s call: from the
/// observer's own Hall bookkeeping and the motor's constant (`K / max(interval, quiet)`,
/// `K / max(quiet, 1)` against the torque after a single step or with no step seen since
/// power-up — after a turn-around at most `Ke·a_max` × the time since the step before —, 0
/// along it after a single step).
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 4 095, mV ≤ 120 000, duty ≤ 65 535, divisors ≥ 1, all in i64/u64"
)]
fn emf_toward(observer: &Observer, record: &StepRecord, direction: Direction) -> i64 {
    let Rotor { quiet_for, rotation, interval, turn_gap, .. } = rotor_after(observer, record);
    // u32 throughout (a 32-bit divider is what the drive uses, and is cheap for CBMC).
    let limit = record.before.config().limit();
    let k = limit.emf_mv_time;
    let Some(rotation) = rotation else {
        return -i64::from((k / quiet_for.max(1)).min(60_000));
    };
    let ticks = if interval == 0 {
        if rotation == direction {
            return 0;
        }
        let one_step = (k / quiet_for.max(1)).min(60_000);
        // After a turn-around: at rest after the step before, gaining at most
        // `accel_emf_mv_per_1024` mV per 1 024 ticks since (plus the Hall filter's 100 µs lag).
        // u32, saturating: a saturated product is far above the 60 V cap.
        let turn = turn_gap.map_or(60_000, |gap| {
            (gap.saturating_add(quiet_for)
                .saturating_add(1_000)
                .saturating_mul(limit.accel_emf_mv_per_1024)
                >> 10)
                .min(60_000)
        });
        return -i64::from(one_step.min(turn));
    } else {
        interval.max(quiet_for)
    };
    let e = i64::from((k / ticks).min(60_000));
    if rotation == direction { e } else { -e }
}

/// REQ-DRV-10, current window: whenever a high side conducts, the duty keeps the winding
/// current within the limit for the back-EMF bound and the bus (floored at the lockout):
/// `duty·V − e ≤ I_lim·R`, and, unless the duty is at its cap, `duty·V − e ≥ −I_lim·R`, or
/// `≥ 0` above the regeneration threshold (no braking current pumps the bus). Rounding: the
/// window is computed to 2.4 × 10⁻⁴ of the bus, so the check allows 10 mV.
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 4 095, mV ≤ 120 000, duty ≤ 65 535, divisors ≥ 1, all in i64/u64"
)]
pub fn duty_within_window(observer: &Observer, record: &StepRecord) {
    let out = record.output;
    if out.pattern.count(LegState::High) == 0 {
        return;
    }
    let Some(direction) = high_side_direction(record) else { return };
    let config = record.before.config();
    let bus = record.input.sample().bus_voltage;
    let v = i64::from(bus_mv(bus).max(config.bus().floor_mv));
    let applied = i64::from(out.duty.raw()) * v / 65_536;
    let e = emf_toward(observer, record, direction);
    let ir = i64::from(record.after.ir_mv());
    assert!(applied - e <= ir + 10, "REQ-DRV-10: motoring {applied} mV against {e} mV");
    if out.duty < DUTY_MAX {
        let floor = if bus_mv(bus) >= config.bus().regen_mv { 0 } else { -ir };
        assert!(applied - e >= floor - 10, "REQ-DRV-10: braking {applied} mV against {e} mV");
    }
}

/// REQ-DRV-15, four-quadrant torque: the bridge follows the table of the direction against
/// the command only to brake a rotor that turns that way at a *measured* speed (its last two
/// steps that way) too fast for any duty of the command's own table to keep the current within
/// the limit (the back-EMF bound against the command at least `I_lim·R`), and then never
/// drives that way: `duty·V − e ≤ 0` (to the window's 10 mV rounding) — the winding's current
/// runs against the rotation, torque toward the command. Its current bound is REQ-DRV-10's, in
/// the table's own direction; REQ-DRV-07 keeps it off a direction toward an actuated switch.
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 4 095, mV ≤ 120 000, duty ≤ 65 535, divisors ≥ 1, all in i64/u64"
)]
pub fn brakes_only_against_the_command(observer: &Observer, record: &StepRecord) {
    let (Some(along), Some(commanded)) =
        (pattern_direction(record), record.input.command.command().direction())
    else {
        return;
    };
    if along == commanded {
        return;
    }
    let rotor = rotor_after(observer, record);
    assert!(
        rotor.rotation == Some(along) && rotor.interval != 0,
        "REQ-DRV-15: braking {along:?} without a measured rotation that way"
    );
    let ir = i64::from(record.after.ir_mv());
    let against = emf_toward(observer, record, commanded);
    assert!(
        against <= -ir,
        "REQ-DRV-15: braking with the {commanded:?} window open ({against} mV)"
    );
    if record.output.pattern.count(LegState::High) > 0 {
        let config = record.before.config();
        let bus = record.input.sample().bus_voltage;
        let v = i64::from(bus_mv(bus).max(config.bus().floor_mv));
        let applied = i64::from(record.output.duty.raw()) * v / 65_536;
        let e = emf_toward(observer, record, along);
        assert!(applied - e <= 10, "REQ-DRV-15: driving {along:?}: {applied} mV against {e} mV");
    }
}

/// The rotor as the observer sees it.
struct Rotor {
    /// Ticks since the accepted sector last moved.
    quiet_for: u32,
    /// The way it last moved.
    rotation: Option<Direction>,
    /// Ticks between its last two steps the same way (0: none yet).
    interval: u32,
    /// The way its last step went, if the steps before it were one valid sequence.
    last_step: Option<Direction>,
    /// Ticks between its last two steps if the last reversed the one before.
    turn_gap: Option<u32>,
}

/// The rotor as seen at the end of `record`'s call.
fn rotor_after(observer: &Observer, record: &StepRecord) -> Rotor {
    let step = match (observer.last_sector, record.after.hall()) {
        (Some(previous), HallState::Sector(now)) => SectorStep::between(previous, now),
        _ => SectorStep::Stay,
    };
    let quiet = observer.quiet_for.saturating_add(record.input.elapsed);
    let stepped = |direction: Direction| Rotor {
        quiet_for: 0,
        rotation: Some(direction),
        interval: if observer.rotation == Some(direction) { quiet } else { 0 },
        last_step: Some(direction),
        turn_gap: (observer.last_step == Some(direction.reversed())).then_some(quiet),
    };
    let stayed = |last_step| Rotor {
        quiet_for: quiet,
        rotation: observer.rotation,
        interval: observer.interval,
        last_step,
        turn_gap: observer.turn_gap,
    };
    match step {
        SectorStep::Forward => stepped(Direction::Pull),
        SectorStep::Backward => stepped(Direction::Release),
        SectorStep::Stay => stayed(observer.last_step),
        SectorStep::Skipped => stayed(None),
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

    /// Applies one input and checks REQ-DRV-01 … 08 and 10 on the call.
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
    duty_within_window(observer, record);
    brakes_only_against_the_command(observer, record);
}

/// REQ-DRV-03, inductively: from *any* valid sequencer state (any legs, any off-times, any
/// dead time a configuration accepts), one call with any request never swaps a leg's side
/// directly and never turns a leg on before it has been off for the dead time.
pub fn sequencer_step_is_safe(
    legs: [(LegState, DriveTime); 3],
    dead_time: DriveTime,
    requested: SwitchPattern,
    elapsed: DriveTime,
) {
    let Some(mut sequencer) = taut_core::drive::DeadTimeSequencer::from_parts(legs, dead_time)
    else {
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
                off_for.0.saturating_add(elapsed.0) >= dead_time.0,
                "REQ-DRV-03: leg {phase:?} on after {} units off",
                off_for.0.saturating_add(elapsed.0)
            );
        }
        if now.is_on() {
            assert_eq!(now, requested.leg(phase), "sequencer emitted an unrequested state");
        }
    }
    assert!(sequencer.is_valid(), "sequencer invariant broken");
    assert_eq!(sequencer.dead_time(), dead_time, "the dead time is the configured one");
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
        crate::harness_end_reached();
    }

    #[kani::proof]
    fn verify_duty_type_bounded() {
        duty_constructors_bounded(kani::any(), kani::any(), kani::any());
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_no_shoot_through() {
        three_calls(|_, record| no_shoot_through(record));
        crate::harness_end_reached();
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
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_commutation_consistent() {
        commutation_is_consistent(any_sector(), any_direction());
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_dead_time_sequence() {
        three_calls(dead_time_respected);
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_dead_time_inductive() {
        let leg = || -> (LegState, DriveTime) {
            let state = match kani::any::<u8>() % 3 {
                0 => LegState::Off,
                1 => LegState::High,
                _ => LegState::Low,
            };
            (state, DriveTime(kani::any()))
        };
        let requested = SwitchPattern { a: leg().0, b: leg().0, c: leg().0 };
        sequencer_step_is_safe(
            [leg(), leg(), leg()],
            DriveTime(kani::any()),
            requested,
            DriveTime(kani::any()),
        );
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_hall_fault_all_off() {
        three_calls(hall_fault_turns_off);
        crate::harness_end_reached();
    }

    /// REQ-DRV-04's skipped sector: two arbitrary calls from a rotor accepted in S0 (see
    /// [`at_rest_in`]; the sectors are symmetric under the table's rotation).
    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_hall_skip_latches() {
        hall_fault_after(Sector::S0, &[kani::any(), kani::any()]);
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_overcurrent_all_off() {
        three_calls(|_, record| overcurrent_turns_off(record));
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_fault_latched_until_cleared() {
        three_calls(fault_latched_until_cleared);
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_limit_interlock() {
        three_calls(|_, record| never_toward_active_limit(record));
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_safe_reversal() {
        three_calls(safe_reversal);
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_brakes_only_against_the_command() {
        three_calls(brakes_only_against_the_command);
        crate::harness_end_reached();
    }

    /// Three arbitrary calls, each on the nominal 24 V bus or at the regeneration threshold's
    /// 38 V (a fully symbolic bus makes the divider circuits of the window and of the property
    /// too slow; every bus code is covered by `window_bounds_current_every_bus_code` and the
    /// drive suites), the bus chosen per call — a bus that jumps moves the window under the
    /// applied duty — but the last call's fixed to `last_bus`: the two harnesses below cover
    /// both, each within the time budget.
    fn duty_within_window_three_calls(last_bus: u16) {
        let mut drive = Drive::new();
        let mut observer = Observer::new();
        for call in 0..3 {
            let bus = if call == 2 {
                last_bus
            } else if kani::any() {
                1_638
            } else {
                2_594
            };
            let input = StepInput { bus, ..kani::any() };
            let record = apply(&mut drive, &input);
            duty_within_window(&observer, &record);
            observer.observe(&record);
        }
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_duty_within_window() {
        duty_within_window_three_calls(1_638);
        crate::harness_end_reached();
    }

    #[kani::proof]
    #[kani::unwind(8)]
    fn verify_duty_within_window_regenerating() {
        duty_within_window_three_calls(2_594);
        crate::harness_end_reached();
    }

    /// REQ-DRV-12's evidence: for any code, zero and applied duty, on a winding sense and on
    /// a link-average one, "motoring" means a current the board reads in the driven
    /// direction, at least an eighth of the limit (× the duty on a link average, the duty at
    /// least a quarter) — so a braking, coasting or noisy reading can never count an
    /// overspeed.
    #[kani::proof]
    fn verify_motoring_evidence() {
        let code: u16 = kani::any();
        let zero: u16 = kani::any();
        let duty: u16 = kani::any();
        motoring_evidence(code, zero, duty);
        crate::harness_end_reached();
    }

    /// REQ-DRV-10 at the window itself: for every back-EMF, on the nominal 24 V bus and at
    /// the regeneration threshold (where the lower edge changes rule), each edge of the
    /// window keeps the current within the limit. Every bus code is covered by `proofs/tests/drive.rs`
    /// (`window_bounds_current_every_bus_code`); a symbolic bus divisor makes CBMC's
    /// divider circuits too slow for the two-minute budget.
    #[kani::proof]
    #[kani::unwind(3)]
    fn verify_window_bounds_current() {
        let emf: i32 = kani::any();
        for bus in [1_638u16, 2_595] {
            window_bounds_current(bus, emf);
        }
        crate::harness_end_reached();
    }
}

/// REQ-DRV-10 on [`taut_core::drive::DriveConfig::window`] alone, for a bus code and a
/// back-EMF (mV, positive along the torque): the upper edge motors with at most `I_lim·R`,
/// the lower edge brakes with at most `I_lim·R` (0 above the regeneration threshold) unless
/// it is the cap, and the window is empty exactly when the rotor turns against the torque
/// with `|e| ≥ I_lim·R`.
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 4 095, mV ≤ 120 000, duty ≤ 65 535, divisors ≥ 1, all in i64/u64"
)]
pub fn window_bounds_current(bus: u16, emf_mv: i32) {
    let config = taut_core::drive::DriveConfig::PAPER;
    let bus = AdcCode::new(bus.min(4_095));
    let e = i64::from(emf_mv.clamp(-60_000, 60_000));
    let ir = i64::from(config.ir_mv());
    let v = i64::from(bus_mv(bus).max(config.bus().floor_mv));
    match config.window(bus, emf_mv) {
        None => assert!(e <= -ir, "REQ-DRV-10: no window at {e} mV"),
        Some(window) => {
            assert!(e > -ir, "REQ-DRV-10: a window against {e} mV");
            assert!(window.low <= window.high, "REQ-DRV-10: empty window");
            let high = i64::from(window.high.raw()) * v / 65_536;
            assert!(high - e <= ir + 10, "REQ-DRV-10: upper edge {high} mV at {e} mV");
            if window.low < DUTY_MAX {
                let low = i64::from(window.low.raw()) * v / 65_536;
                let floor = if bus_mv(bus) >= config.bus().regen_mv { 0 } else { -ir };
                assert!(low - e >= floor - 10, "REQ-DRV-10: lower edge {low} mV at {e} mV");
            }
        }
    }
}

/// REQ-DRV-12 on [`taut_core::drive::DriveConfig::motoring`]: on the paper's winding sense a
/// code is motoring exactly when it is at least `limit/8` codes above the zero; on a
/// link-average sense exactly when `(code − zero) × 2¹⁶ ≥ max(D, ¼) × limit/8`; never at or
/// below the zero, never below the quarter-duty floor's `limit/32` (≥ 4 × the worst noise).
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 65 535, duty < 2¹⁶, in u64"
)]
pub fn motoring_evidence(code: u16, zero: u16, duty: u16) {
    use taut_core::drive::limit::{CurrentLimit, CurrentSense};
    let (code, zero, duty) = (AdcCode::new(code), AdcCode::new(zero), Duty::from_raw_clamped(duty));
    let above = u64::from(code.get().saturating_sub(zero.get()));
    let winding = taut_core::drive::DriveConfig::PAPER;
    let eighth = u64::from(winding.limit_codes() / 8);
    assert_eq!(
        winding.motoring(code, zero, duty),
        code.get() > zero.get() && above >= eighth,
        "REQ-DRV-12: winding motoring at {above} codes"
    );
    let Ok(link) = taut_core::drive::DriveConfig::new(
        CurrentSense::LINK_AVERAGE_BIDIRECTIONAL,
        taut_core::drive::BusSense::PAPER,
        CurrentLimit::PAPER,
        12_000,
        taut_core::drive::DriveConfig::PAPER.dead_time(),
    ) else {
        panic!("the link-average board is a valid configuration");
    };
    let eighth = u64::from(link.limit_codes() / 8);
    let scaled = u64::from(duty.raw().max(16_384)) * eighth;
    let motoring = link.motoring(code, zero, duty);
    assert_eq!(
        motoring,
        code.get() > zero.get() && above * 65_536 >= scaled,
        "REQ-DRV-12: link motoring at {above} codes, duty {}",
        duty.raw()
    );
    if motoring {
        assert!(above * 32 >= eighth * 8, "REQ-DRV-12: motoring below a quarter of 1 A");
    }
}

//! The machine's safety properties (`REQ-SAFE-*`), each a plain function over one recorded
//! tick.
//!
//! # How the properties are checked
//!
//! A tick is described by a [`TickInput`] of primitive values (converter codes, flags, a
//! key bit set, counters), and a starting point by a [`CheckpointInput`] of primitive values
//! that [`CheckpointInput::checkpoint`] turns into a [`Checkpoint`] through the machine's
//! own constructors. [`apply`] feeds one tick to a [`Machine`] and returns a [`TickRecord`]:
//! the state before, the inputs, the outputs and the state after. Each property is a
//! function of the record that panics naming its requirement id when it fails.
//!
//! The drivers:
//! - Kani ([`verification`]), at two levels. **Per rule**: the limit guard the motion
//!   superstate applies (`verify_limit_guard`) and the global rules every state applies
//!   (`verify_global_fault`), for every input. **Per tick**, composed: one harness per machine
//!   state (`verify_tick_in_*`) starts from **any valid checkpoint of that state** — every
//!   timer value, any tare, any tension-watch counters, any flags — feeds one arbitrary tick
//!   and checks every property ([`check_tick`]); together they cover every state. The parts
//!   of a tick that are not a safety rule (the tension controller, the key pad, the
//!   load-cell arithmetic, the working display, the calibration fit) are replaced by stubs
//!   returning *any* value, so the rules are proven to hold whatever those parts compute
//!   (see the module's comments for each stub and the unwind bound). This over-approximates
//!   "any state reachable within a bounded number of ticks" — the boot sequence alone takes
//!   thousands of ticks, far beyond a bounded unrolling — but it is one tick: that every
//!   reachable state satisfies [`Checkpoint::is_valid`] is checked by the model check and
//!   the tests, not proven. Other assumptions: the record is the default one (its fields
//!   are validated at decode and do not reach the safety rules); the pull log has
//!   capacity 1.
//! - `proofs/tests/machine_properties.rs`: exhaustive over the finite part of that space
//!   (every state × limits × faults × current × key × load-cell band), proptest over the
//!   rest; `proofs/tests/machine_model.rs`: the whole-machine model check, which calls
//!   [`check_tick`] on every tick it simulates.
//! - `fuzz/fuzz_targets/machine.rs`: arbitrary tick sequences from power-up or a
//!   checkpoint.
//!
//! # Independence
//!
//! The properties look only at the inputs, the outputs and the public state. Overcurrent is
//! the drive's to judge (every PWM period, from the tared zero: `proofs::drive`); at the
//! machine it arrives as a latched drive fault, and the tick's mean current code alone
//! never faults the machine.

use taut_core::drive::limit::CurrentSense;
use taut_core::drive::{DUTY_MAX, Direction, DriveCommand, DriveFault, DriveStatus, DriveTime};
use taut_core::io::{Inputs, Keys, LimitSwitches, Outputs};
use taut_core::machine::{
    AfterRelease, Checkpoint, FaultCode, KeyPad, Machine, MachineState, Recovery, View,
    hold_adjustment, hold_target, panel, safety::TensionWatch,
};
use taut_core::sense::calibration::CALIBRATION_READINGS;
use taut_core::settings::{TENSION_MAX, TENSION_MIN, Unit};
use taut_core::store::Record;
use taut_core::units::{AdcCode, Kgf, Volts};

/// One tick of inputs, in primitive values.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct TickInput {
    /// Milliseconds since power-up.
    pub now_ms: u32,
    /// Load-cell code (saturated to 12 bits).
    pub load_cell: u16,
    /// Motor-current code (saturated to 12 bits).
    pub motor_current: u16,
    /// The drive's latched fault: 0 none, 1 overcurrent, 2 comparator, 3 Hall invalid,
    /// 4 sector skipped, others none.
    pub drive_fault: u8,
    /// Hall steps since power-up.
    pub steps: i32,
    /// Milliseconds since the last Hall step.
    pub quiet_ms: u16,
    /// Home limit switch.
    pub home: bool,
    /// End limit switch.
    pub end: bool,
    /// Raw key bits.
    pub keys: u8,
    /// String-encoder count.
    pub string_counter: u16,
}

impl TickInput {
    /// The machine inputs this stands for.
    #[must_use]
    pub fn inputs(&self) -> Inputs {
        let fault = DriveFault::from_number(self.drive_fault);
        Inputs {
            now_ms: self.now_ms,
            load_cell: AdcCode::new(self.load_cell),
            motor_current: AdcCode::new(self.motor_current),
            bus_voltage: AdcCode::MIN,
            drive: DriveStatus {
                fault,
                steps: self.steps,
                rotation: None,
                quiet_for: DriveTime::from_micros(u32::from(self.quiet_ms).saturating_mul(1_000)),
                energized: None,
                // Any code of the paper's board, as the drive reports it (what the tick's
                // motor-current input used to be converted with).
                current: CurrentSense::PAPER.amps(AdcCode::new(self.motor_current), AdcCode::MIN),
                bus: Volts::ZERO,
            },
            string_counter: self.string_counter,
            limits: LimitSwitches { home: self.home, end: self.end },
            keys: Keys::from_bits(self.keys),
        }
    }
}

/// A starting point, in primitive values.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct CheckpointInput {
    /// Which state (modulo the number of kinds).
    pub state: u8,
    /// Calibration point, fault code index or preset index, by state.
    pub index: u8,
    /// Ticks already spent in the state.
    pub elapsed: u32,
    /// Motor test: pull (false) or release (true).
    pub release: bool,
    /// Hall count at the start of the motor test or pull.
    pub start_steps: i32,
    /// Motor test: home switch at its start.
    pub start_home: bool,
    /// Motor test: end switch at its start.
    pub start_end: bool,
    /// Calibration entry value, hundredths of a kg.
    pub entered: u16,
    /// Releasing: to Ready (0), to the calibration window (1) or to the calibration's next
    /// pass (2), modulo 3.
    pub then: u8,
    /// Fault: recovery by self-test (true) or home (false).
    pub self_test: bool,
    /// Fault: clear-attempt ticks left.
    pub clearing: u16,
    /// Ready page (modulo 13; the preset, log, counters, string and service pages take
    /// their item from `index`).
    pub view: u8,
    /// Tare code.
    pub tare: u16,
    /// Peak tension seen, tenths of a kgf (above 1 000 reads as 100 kgf, which the
    /// checkpoint's invariant rejects).
    pub peak_tenths: u16,
    /// The tracked tension and raw tension, tenths of a kgf.
    pub tracked_tenths: [i16; 2],
    /// Persistence counters: reversed, loaded.
    pub counters: [u8; 2],
    /// Evidence histories, a bit a tick: above the peak, below half of it, above the
    /// overload limit (bits beyond the window are rejected by the checkpoint's invariant).
    pub evidence: [u16; 3],
    /// Knot mode.
    pub knot: bool,
    /// Key-pad integrators.
    pub integrators: [u8; 5],
    /// Key-pad debounced and pending bits.
    pub key_bits: (u8, u8),
    /// Key-pad hold time.
    pub held_ms: u16,
    /// Key-pad long press sent.
    pub long_sent: bool,
    /// Consecutive ticks at a load-cell rail.
    pub rail_ticks: u8,
    /// Holding: the operator's adjustment, tenths of the unit.
    pub hold_adjust: i16,
}

/// Number of state kinds [`CheckpointInput::state`] selects from: every kind the machine has
/// ([`MachineState::KINDS`]).
#[expect(
    clippy::cast_possible_truncation,
    reason = "eleven kinds; a const item cannot use try_from, and a test checks the count"
)]
pub const STATE_KINDS: u8 = MachineState::KINDS.len() as u8;

/// The pull log's capacity as the checkpoint's index type.
#[expect(
    clippy::cast_possible_truncation,
    reason = "a few dozen entries; a const item cannot use try_from"
)]
const LOG_ENTRIES: u8 = taut_core::machine::PULL_LOG_CAPACITY as u8;

/// The calibration's reading count (its points in both passes) as the checkpoint's index type.
#[expect(
    clippy::cast_possible_truncation,
    reason = "a handful of readings (the record's layout allows five points, two passes); a const item cannot use try_from"
)]
const CALIBRATION_READINGS_U8: u8 = CALIBRATION_READINGS as u8;

impl CheckpointInput {
    /// The checkpoint, built through the machine's constructors. Not every input gives a
    /// valid checkpoint: check [`Checkpoint::is_valid`].
    #[must_use]
    pub fn checkpoint(&self) -> Checkpoint {
        let point = self.index % CALIBRATION_READINGS_U8;
        const CODES: usize = FaultCode::ALL.len();
        let code_index = usize::from(self.index) % CODES;
        let code = FaultCode::ALL.get(code_index).copied().unwrap_or(FaultCode::LimitsBoth);
        let kind = MachineState::KINDS.get(usize::from(self.state % STATE_KINDS));
        let state = match kind.copied().unwrap_or(MachineState::Ready) {
            MachineState::CalibrationPull { .. } => MachineState::CalibrationPull { point },
            MachineState::CalibrationEntry { .. } => MachineState::CalibrationEntry { point },
            MachineState::Fault(_) => MachineState::Fault(code),
            other => other,
        };
        let view = match self.view % 13 {
            0 => View::Tension,
            1 => View::Speed,
            2 => View::PreStretch,
            3 => View::Knot,
            4 => View::Unit,
            5 => View::Preset(self.index % 9),
            6 => View::Timer,
            7 => View::Log { entry: self.index % LOG_ENTRIES, field: self.index % 9 },
            8 => View::Counters(self.index % 3),
            9 => View::String(self.index % 2),
            10 => View::Beeper,
            11 => View::ConstantPull,
            _ => View::Service(self.index % 10),
        };
        // The tracked tension never exceeds the peak (the watch's invariant).
        let peak_tenths = i32::from(self.peak_tenths.min(600));
        let [tension_tenths, raw_tenths] =
            self.tracked_tenths.map(|t| i32::from(t.clamp(-600, 600)));
        let tension_tenths = tension_tenths.min(peak_tenths);
        Checkpoint {
            state,
            elapsed: self.elapsed,
            direction: if self.release { Direction::Release } else { Direction::Pull },
            start_steps: self.start_steps,
            start_limits: LimitSwitches { home: self.start_home, end: self.start_end },
            entered_hundredths: self.entered,
            then: match self.then % 3 {
                0 => AfterRelease::Ready,
                1 => AfterRelease::CalibrationWindow,
                _ => AfterRelease::NextPass,
            },
            recovery: if self.self_test { Recovery::SelfTest } else { Recovery::Home },
            clearing: self.clearing,
            view,
            hold_adjust: self.hold_adjust,
            tare: AdcCode::new(self.tare),
            watch: TensionWatch::from_parts(
                self.start_steps,
                [
                    Kgf::from_tenths(peak_tenths),
                    Kgf::from_tenths(tension_tenths),
                    Kgf::from_tenths(raw_tenths),
                ],
                self.counters,
                self.evidence,
            ),
            knot_mode: self.knot,
            keypad: KeyPad::from_parts(
                self.integrators,
                Keys::from_bits(self.key_bits.0),
                Keys::from_bits(self.key_bits.1),
                self.held_ms,
                self.long_sent,
            ),
            rail_ticks: self.rail_ticks,
        }
    }
}

/// Everything about one tick that the properties look at.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct TickRecord {
    /// The state before the tick.
    pub before: MachineState,
    /// The inputs of the tick.
    pub inputs: Inputs,
    /// The outputs of the tick.
    pub outputs: Outputs,
    /// The state after the tick.
    pub after: MachineState,
}

/// One tick of `machine`, recorded.
pub fn apply<const LOG: usize>(machine: &mut Machine<LOG>, inputs: &Inputs) -> TickRecord {
    let before = machine.state();
    let outputs = machine.tick(inputs);
    TickRecord { before, inputs: *inputs, outputs, after: machine.state() }
}

/// REQ-SAFE-01: the drive command never points toward an active limit switch.
pub fn never_toward_active_limit(record: &TickRecord) {
    if let Some(direction) = record.outputs.drive.direction() {
        assert!(
            !direction.blocked_by(record.inputs.limits),
            "REQ-SAFE-01: {direction:?} commanded into an active limit ({:?}) in {:?}",
            record.inputs.limits,
            record.before
        );
    }
}

/// REQ-SAFE-02: both limit switches active → a latched fault and the bridge off, in the
/// same tick.
pub fn both_limits_fault_and_coast(record: &TickRecord) {
    if record.inputs.limits.both() {
        assert_eq!(
            record.outputs.drive,
            DriveCommand::Coast,
            "REQ-SAFE-02: drive with both limits"
        );
        assert!(
            matches!(record.after, MachineState::Fault(_)),
            "REQ-SAFE-02: both limits active but {:?} → {:?}",
            record.before,
            record.after
        );
    }
}

/// REQ-SAFE-03: a latched drive fault (overcurrent, bus overvoltage, current-sense zero,
/// Hall) → the bridge off in the same tick, and a latched fault.
pub fn overcurrent_coasts(record: &TickRecord) {
    if record.inputs.drive.fault.is_some() {
        assert_eq!(
            record.outputs.drive,
            DriveCommand::Coast,
            "REQ-SAFE-03: drive command with overcurrent/drive fault in {:?}",
            record.before
        );
        assert!(
            matches!(record.after, MachineState::Fault(_)),
            "REQ-SAFE-03: overcurrent but {:?} → {:?}",
            record.before,
            record.after
        );
    }
}

/// REQ-SAFE-04: releasing (or homing) stops at the home limit: with home active the command
/// is not Release and the machine has left the releasing state.
pub fn releasing_stops_at_home(record: &TickRecord) {
    let releasing = matches!(record.before, MachineState::Releasing | MachineState::Homing);
    if releasing && record.inputs.limits.home {
        assert_ne!(
            record.outputs.drive.direction(),
            Some(Direction::Release),
            "REQ-SAFE-04: still releasing at home"
        );
        assert!(
            !matches!(record.after, MachineState::Releasing | MachineState::Homing),
            "REQ-SAFE-04: stayed in {:?} at home",
            record.after
        );
    }
}

/// REQ-SAFE-05: the duty is bounded by `DUTY_MAX` in every state.
pub fn duty_bounded(record: &TickRecord) {
    let duty = record.outputs.drive.duty();
    assert!(duty <= DUTY_MAX && duty.is_valid(), "REQ-SAFE-05: duty {} above the cap", duty.raw());
}

/// REQ-SAFE-06: a latched fault coasts and shows its code; a state that does not move never
/// drives.
pub fn fault_and_idle_coast(record: &TickRecord) {
    if let MachineState::Fault(code) = record.after {
        assert_eq!(record.outputs.drive, DriveCommand::Coast, "REQ-SAFE-06: drive while faulted");
        assert_eq!(
            record.outputs.display,
            panel::fault(code.number()),
            "REQ-SAFE-06: fault {code:?} not on the display"
        );
        assert!(record.outputs.leds.fault, "REQ-SAFE-06: fault lamp off");
    }
    if !record.after.is_moving() {
        assert_eq!(
            record.outputs.drive,
            DriveCommand::Coast,
            "REQ-SAFE-06: {:?} is not a moving state but drives",
            record.after
        );
    }
}

/// REQ-SAFE-07: a drive-fault clear is only ever requested with the drive command zeroed,
/// and only from the fault state.
pub fn clear_only_with_zero_command(record: &TickRecord) {
    if record.outputs.clear_drive_fault {
        assert_eq!(record.outputs.drive, DriveCommand::Coast, "REQ-SAFE-07: clear with a command");
        assert!(
            matches!(record.before, MachineState::Fault(_)),
            "REQ-SAFE-07: clear requested from {:?}",
            record.before
        );
    }
}

/// REQ-SAFE-08: a latched fault is left only by the operator's clear: in the tick the
/// machine leaves the fault state it is asking the drive to clear (with coast), and the
/// inputs show no cause that holds everywhere — both limits, a latched drive fault,
/// overcurrent.
pub fn fault_latches(record: &TickRecord) {
    let left_fault = matches!(record.before, MachineState::Fault(_))
        && !matches!(record.after, MachineState::Fault(_));
    if left_fault {
        assert!(record.outputs.clear_drive_fault, "REQ-SAFE-08: fault left without a clear");
        assert_eq!(
            record.outputs.drive,
            DriveCommand::Coast,
            "REQ-SAFE-08: cleared with a command"
        );
        let inputs = &record.inputs;
        assert!(
            !inputs.limits.both() && inputs.drive.fault.is_none(),
            "REQ-SAFE-08: fault cleared while its cause is present: {inputs:?}"
        );
    }
}

/// Every per-tick property.
pub fn check_tick(record: &TickRecord) {
    never_toward_active_limit(record);
    both_limits_fault_and_coast(record);
    overcurrent_coasts(record);
    releasing_stops_at_home(record);
    duty_bounded(record);
    fault_and_idle_coast(record);
    clear_only_with_zero_command(record);
    fault_latches(record);
}

/// A machine at `input`'s checkpoint with the default record, if the checkpoint is valid.
#[must_use]
pub fn resume<const LOG: usize>(input: &CheckpointInput) -> Option<Machine<LOG>> {
    let checkpoint = input.checkpoint();
    let board = crate::paper_board()?;
    checkpoint.is_valid().then(|| Machine::<LOG>::resume(Record::default(), &checkpoint, &board))
}

/// REQ-SAFE-01 at the rule the motion superstate applies: for any command and any limit
/// switches, [`safety::limit_guard`](taut_core::machine::safety::limit_guard) never lets a
/// command toward an active limit through, and leaves every other command unchanged.
pub fn limit_guard_is_sound(command: DriveCommand, limits: LimitSwitches) {
    let guarded = taut_core::machine::safety::limit_guard(command, limits);
    if let Some(direction) = guarded.direction() {
        assert!(!direction.blocked_by(limits), "REQ-SAFE-01: guard let {direction:?} through");
    }
    let blocked = command.direction().is_some_and(|direction| direction.blocked_by(limits));
    let expected = if blocked { DriveCommand::Coast } else { command };
    assert_eq!(guarded, expected, "REQ-SAFE-01: guard changed an allowed command");
}

/// REQ-SM-08: one Up/Down while holding, from any adjustment on a pull whose final target
/// `base` is in the tension range, never leaves [`TENSION_MIN`]–[`TENSION_MAX`]: the step is
/// refused, or the new target is in range, is the base plus the new adjustment, and the
/// adjustment moved by exactly one fine step of the unit in the key's direction.
pub fn hold_adjustment_in_range(base: Kgf, unit: Unit, adjust: i16, step: i8) {
    if base < TENSION_MIN || base > TENSION_MAX || !matches!(step, -1 | 1) {
        return;
    }
    if let Some((next, target)) = hold_adjustment(base, unit, adjust, step) {
        assert!(
            (TENSION_MIN..=TENSION_MAX).contains(&target),
            "REQ-SM-08: a hold adjustment left the range: {target:?}"
        );
        assert_eq!(target, hold_target(base, unit, next), "REQ-SM-08: target and adjustment");
        assert_eq!(
            i32::from(next).wrapping_sub(i32::from(adjust)),
            i32::from(step).wrapping_mul(i32::from(unit.fine_step_tenths())),
            "REQ-SM-08: one fine step"
        );
    }
}

/// REQ-SAFE-02/03 at the rule every state applies: both limits and a latched drive fault
/// each raise a global fault; nothing else does.
pub fn global_fault_is_sound(inputs: &Inputs) {
    let fault = taut_core::machine::safety::global_fault(inputs);
    if inputs.limits.both() {
        assert_eq!(fault, Some(FaultCode::LimitsBoth), "REQ-SAFE-02: both limits missed");
    }
    if inputs.drive.fault.is_some() {
        assert!(fault.is_some(), "REQ-SAFE-03: drive fault missed");
    }
    if !inputs.limits.both() && inputs.drive.fault.is_none() {
        assert_eq!(fault, None, "REQ-SAFE-03: a global fault without a cause");
    }
}

#[cfg(kani)]
#[allow(
    dead_code,
    reason = "the stubs are referenced only from `#[kani::stub]` attributes, which rustc's \
              dead-code analysis does not see"
)]
pub(crate) mod verification {
    use super::*;
    use taut_core::io::{Display, Key, Segments};
    use taut_core::machine::KeyEvent;
    use taut_core::sense::calibration::{Calibration, CalibrationError, CalibrationPoints};
    use taut_core::sense::load_cell::LoadCellScale;
    use taut_core::settings::{PullKind, PullSettings, Unit};
    use taut_core::tension::{ControlOutput, Measurement, PullPhase, TensionController};

    // # The whole-tick harnesses: one per machine state, every REQ-SAFE property
    //
    // `verify_tick_in_*` starts a machine in an arbitrary valid checkpoint of one state
    // (every timer, counter, tare, tension-watch value and flag the invariant allows),
    // feeds it one arbitrary tick and checks every per-tick property (`check_tick`). The
    // eleven harnesses together cover every state, so each REQ-SAFE property is proven for
    // one tick from every valid state (that every reachable state is valid is checked by the
    // model check and the tests, not proven).
    //
    // They are compositional. The machine's safety rules must hold whatever the rest of a
    // tick computes, so the parts that are not a safety rule, and that are proven or tested
    // on their own, are replaced by stubs that return *any* value of their type
    // (over-approximations: every behaviour of the real part is among the stub's):
    // - the tension controller's step (`any_control_step`; its bounds are
    //   `crate::tension`'s harnesses): the rules hold for every controller;
    // - arming the controller at the start of a pull (`any_start`): nothing, since no state
    //   it writes is read by the stubbed step (with symbolic settings, as after a key in
    //   Ready or a confirmed calibration point, its divisions alone outgrew CBMC's memory);
    // - the key pad (`any_key_event`; its debounce is tested in `core`): any key event;
    // - the load-cell scale and the calibration's correction (`any_tension`,
    //   `any_corrected`; their accuracy is `crate::fixed_point`'s): any tension, raw or
    //   corrected, independently;
    // - the working display's digits, the tenths digits of Ready's set point and the
    //   hundredths of the calibration entry (`any_tension_digits`, `any_tenths_digits` for
    //   both; `panel`'s unit tests check them): any digits (no property reads them; the fault display the properties
    //   do read is not stubbed);
    // - the calibration fit, run when the last point is confirmed (`any_calibration_fit`):
    //   accepted or rejected (its value is not read again in the tick that computes it).
    //
    // Why it matters for the cost: statig finds a transition's common ancestor by recursing
    // over superstates (`depth`, `common_ancestor_depth`), and with the target state symbolic
    // CBMC unrolls that recursion to the unwind bound at every call. The chart is three
    // superstates deep, so `unwind(5)` covers it (CBMC's unwinding assertions check that);
    // the only loop longer than four iterations in a tick is the key pad's over five keys,
    // which the stub removes. A machine at a checkpoint therefore starts with a fresh key pad
    // (`KeyPad::new()` is valid: a unit test) and the checkpoint's invariant is assumed
    // without the pad's part (`Checkpoint::chart_is_valid`).

    /// The controller's step, over-approximated: any command, phase and flags.
    fn any_control_step(_controller: &mut TensionController, _m: &Measurement) -> ControlOutput {
        ControlOutput {
            command: any_command(),
            phase: PullPhase::ALL
                .get(usize::from(kani::any::<u8>()))
                .copied()
                .unwrap_or(PullPhase::Idle),
            at_tension: kani::any(),
            reference: Kgf::from_bits(kani::any()),
            force: Kgf::from_bits(kani::any()),
            tension: Kgf::from_bits(kani::any()),
        }
    }

    /// Any drive command: coast, or either direction at any duty.
    fn any_command() -> DriveCommand {
        let duty = taut_core::drive::Duty::from_raw_clamped(kani::any());
        match kani::any::<u8>() % 3 {
            0 => DriveCommand::Coast,
            1 => DriveCommand::Drive { direction: Direction::Pull, duty },
            _ => DriveCommand::Drive { direction: Direction::Release, duty },
        }
    }

    /// Arming the controller, over-approximated by doing nothing: with its step stubbed
    /// (`any_control_step`), no state the arming writes is read again in a tick.
    fn any_start(_controller: &mut TensionController, _settings: &PullSettings, _kind: PullKind) {}

    /// A pull's peak target, over-approximated: any tension (the overload threshold it sets
    /// is not part of a per-tick safety property; its arithmetic is `crate::tension`'s).
    fn any_peak_target(_settings: &PullSettings, _kind: PullKind) -> Kgf {
        Kgf::from_bits(kani::any())
    }

    /// The key pad, over-approximated: any event (or none) in any tick.
    fn any_key_event(_pad: &mut KeyPad, _raw: Keys) -> Option<KeyEvent> {
        let key = Key::ALL.get(usize::from(kani::any::<u8>())).copied()?;
        match kani::any::<u8>() {
            0 => Some(KeyEvent::Press(key)),
            1 => Some(KeyEvent::Repeat(key)),
            2 => Some(KeyEvent::Long(key)),
            _ => None,
        }
    }

    /// Any event of one key, or none. Ready and the calibration entry are proven without a
    /// key and (Ready) with Start: with any key, one harness outgrew CBMC's 24 GiB, and per
    /// key the others did not finish in 10 min (see `docs/SPEC.md`, "What is proven").
    fn any_event_of(key: Key) -> Option<KeyEvent> {
        match kani::any::<u8>() {
            0 => Some(KeyEvent::Press(key)),
            1 => Some(KeyEvent::Repeat(key)),
            2 => Some(KeyEvent::Long(key)),
            _ => None,
        }
    }

    /// No key event.
    fn no_key_event(_pad: &mut KeyPad, _raw: Keys) -> Option<KeyEvent> {
        None
    }

    /// Any event of Start, or none.
    fn start_events(_pad: &mut KeyPad, _raw: Keys) -> Option<KeyEvent> {
        any_event_of(Key::Start)
    }

    /// A converter code in kgf, over-approximated: any tension.
    fn any_tension(_scale: &LoadCellScale, _code: AdcCode) -> Kgf {
        Kgf::from_bits(kani::any())
    }

    /// The calibration's correction, over-approximated: any tension.
    fn any_corrected(_calibration: &Calibration, _raw: Kgf) -> Kgf {
        Kgf::from_bits(kani::any())
    }

    /// The digits of a working tension, over-approximated: any display.
    fn any_tension_digits(_tension: Kgf, _unit: Unit) -> Display {
        let bits: [u8; 4] = kani::any();
        bits.map(Segments)
    }

    /// The digits of a tenths value (Ready's set point, the calibration entry), over-approximated:
    /// any display. No property reads them.
    fn any_tenths_digits(_tenths: i32) -> Display {
        let bits: [u8; 4] = kani::any();
        bits.map(Segments)
    }

    /// The calibration fit, over-approximated by its two outcomes.
    /// The timer's digits: not a safety rule (the clock has its own exhaustive test).
    fn any_clock_digits(_label: u8, _seconds: u32) -> Display {
        let bits: [u8; 4] = kani::any();
        bits.map(Segments)
    }

    /// A tension in the operator's unit, any value: the hold adjustment's range rule is
    /// proven on its own (`verify_hold_adjustment_in_range`); here any target it yields.
    fn any_unit_tension(_unit: Unit, _tenths: i32) -> Kgf {
        Kgf::from_bits(kani::any())
    }

    fn any_calibration_fit(_points: &CalibrationPoints) -> Result<Calibration, CalibrationError> {
        if kani::any() { Ok(Calibration::IDENTITY) } else { Err(CalibrationError::PointOffLine) }
    }

    /// An arbitrary valid checkpoint in `state` (with a fresh key pad, see above).
    pub(crate) fn checkpoint_in(state: MachineState) -> Checkpoint {
        let watch = TensionWatch::from_parts(
            kani::any(),
            [Kgf::from_bits(kani::any()), Kgf::from_bits(kani::any()), Kgf::from_bits(kani::any())],
            kani::any(),
            kani::any(),
        );
        let view = match kani::any::<u8>() {
            0 => View::Speed,
            1 => View::PreStretch,
            2 => View::Knot,
            3 => View::Unit,
            4 => View::Preset(kani::any()),
            5 => View::Timer,
            6 => View::Log { entry: kani::any(), field: kani::any() },
            7 => View::Counters(kani::any()),
            8 => View::String(kani::any()),
            9 => View::Service(kani::any()),
            10 => View::Beeper,
            11 => View::ConstantPull,
            _ => View::Tension,
        };
        let checkpoint = Checkpoint {
            state,
            elapsed: kani::any(),
            direction: if kani::any() { Direction::Pull } else { Direction::Release },
            start_steps: kani::any(),
            start_limits: LimitSwitches { home: kani::any(), end: kani::any() },
            entered_hundredths: kani::any(),
            then: match kani::any::<u8>() % 3 {
                0 => AfterRelease::Ready,
                1 => AfterRelease::CalibrationWindow,
                _ => AfterRelease::NextPass,
            },
            recovery: if kani::any() { Recovery::Home } else { Recovery::SelfTest },
            clearing: kani::any(),
            view,
            hold_adjust: kani::any(),
            tare: AdcCode::new(kani::any()),
            watch,
            knot_mode: kani::any(),
            keypad: KeyPad::new(),
            rail_ticks: kani::any(),
        };
        kani::assume(checkpoint.chart_is_valid());
        checkpoint
    }

    /// One arbitrary tick of a machine at an arbitrary valid checkpoint in `state` whose
    /// Ready page satisfies `pages` (two harnesses that split the pages between them cover
    /// every page; each is a smaller problem for the solver than both at once).
    fn one_tick_on(state: MachineState, pages: fn(View) -> bool) -> TickRecord {
        let checkpoint = checkpoint_in(state);
        kani::assume(pages(checkpoint.view));
        // The paper's board; that it builds is checked here too (a panic fails the harness).
        let board = crate::paper_board().expect("the paper's board builds");
        let mut machine = Machine::<1>::resume(Record::default(), &checkpoint, &board);
        let tick: TickInput = kani::any();
        apply(&mut machine, &tick.inputs())
    }

    /// A whole-tick harness for one state: every REQ-SAFE property (`check_tick`).
    macro_rules! whole_tick {
        ($(#[$doc:meta])* fn $name:ident = $state:expr) => {
            whole_tick!($(#[$doc])* fn $name = $state, keys = any_key_event);
        };
        ($(#[$doc:meta])* fn $name:ident = $state:expr, keys = $keys:ident) => {
            whole_tick!($(#[$doc])* fn $name = $state, keys = $keys, pages = |_| true);
        };
        ($(#[$doc:meta])* fn $name:ident = $state:expr, keys = $keys:ident, pages = $pages:expr) => {
            $(#[$doc])*
            #[kani::proof]
            #[kani::unwind(5)]
            #[kani::stub(taut_core::tension::TensionController::step, any_control_step)]
            #[kani::stub(taut_core::tension::TensionController::start, any_start)]
            #[kani::stub(taut_core::settings::PullSettings::peak_target, any_peak_target)]
            #[kani::stub(taut_core::machine::KeyPad::tick, $keys)]
            #[kani::stub(taut_core::sense::load_cell::LoadCellScale::to_kgf, any_tension)]
            #[kani::stub(taut_core::sense::calibration::Calibration::correct, any_corrected)]
            #[kani::stub(taut_core::machine::tension_display, any_tension_digits)]
            #[kani::stub(taut_core::machine::panel::tenths, any_tenths_digits)]
            #[kani::stub(taut_core::machine::panel::hundredths, any_tenths_digits)]
            #[kani::stub(taut_core::machine::panel::clock, any_clock_digits)]
            #[kani::stub(taut_core::settings::Unit::tenths_to_kgf, any_unit_tension)]
            #[kani::stub(taut_core::sense::calibration::Calibration::new, any_calibration_fit)]
            fn $name() {
                check_tick(&one_tick_on($state, $pages));
                crate::harness_end_reached();
            }
        };
    }

    whole_tick!(
        /// REQ-SAFE-01…08 in the power-on self-test.
        fn verify_tick_in_self_test =
        MachineState::SelfTest
    );
    whole_tick!(
        /// REQ-SAFE-01…08 in the motor test (either direction, any start limits).
        fn verify_tick_in_motor_test =
        MachineState::MotorTest
    );
    whole_tick!(
        /// REQ-SAFE-01…08 while homing at boot.
        fn verify_tick_in_homing =
        MachineState::Homing
    );
    whole_tick!(
        /// REQ-SAFE-01…08 in the calibration window.
        fn verify_tick_in_calibration_window =
        MachineState::CalibrationWindow
    );
    whole_tick!(
        /// REQ-SAFE-01…08 pulling to any calibration point.
        fn verify_tick_in_calibration_pull =
        MachineState::CalibrationPull { point: kani::any() }
    );
    whole_tick!(
        /// REQ-SAFE-01…08 holding any calibration point for the operator's entry, with no key.
        fn verify_tick_in_calibration_entry =
        MachineState::CalibrationEntry { point: kani::any() },
        keys = no_key_event
    );
    whole_tick!(
        /// REQ-SAFE-01…08 in Ready, on any page, with no key.
        fn verify_tick_in_ready =
        MachineState::Ready,
        keys = no_key_event
    );
    whole_tick!(
        /// REQ-SAFE-01…08 in Ready, on the tension, a settings or the preset page, with any
        /// event of Start.
        fn verify_tick_in_ready_start =
        MachineState::Ready,
        keys = start_events,
        pages = |view: View| !view.is_information()
    );
    whole_tick!(
        /// REQ-SAFE-01…08 in Ready, on an information page (the service page's self-test
        /// included), with any event of Start.
        fn verify_tick_in_ready_start_information =
        MachineState::Ready,
        keys = start_events,
        pages = View::is_information
    );
    whole_tick!(
        /// REQ-SAFE-01…08 pulling.
        fn verify_tick_in_pulling =
        MachineState::Pulling
    );
    whole_tick!(
        /// REQ-SAFE-01…08 holding.
        fn verify_tick_in_holding =
        MachineState::Holding
    );
    whole_tick!(
        /// REQ-SAFE-01…08 releasing after a pull.
        fn verify_tick_in_releasing =
        MachineState::Releasing
    );
    whole_tick!(
        /// REQ-SAFE-01…08 with any fault latched (any recovery, any clear attempt).
        fn verify_tick_in_fault =
        MachineState::Fault(
            FaultCode::ALL.get(usize::from(kani::any::<u8>())).copied().unwrap_or(FaultCode::Stall)
        )
    );

    /// The limit rule alone, for any command: small and always fast, beside the whole-tick
    /// harness above.
    #[kani::proof]
    fn verify_limit_guard() {
        let duty = taut_core::drive::Duty::from_raw_clamped(kani::any());
        let command = match kani::any::<u8>() % 3 {
            0 => DriveCommand::Coast,
            1 => DriveCommand::Drive { direction: Direction::Pull, duty },
            _ => DriveCommand::Drive { direction: Direction::Release, duty },
        };
        limit_guard_is_sound(command, LimitSwitches { home: kani::any(), end: kani::any() });
        crate::harness_end_reached();
    }

    /// REQ-SM-08: a hold adjustment never moves the target outside the validated range,
    /// for any final target in the range, either unit, any adjustment so far and Up or Down.
    #[kani::proof]
    fn verify_hold_adjustment_in_range() {
        let base = Kgf::from_bits(kani::any());
        kani::assume(base >= TENSION_MIN && base <= TENSION_MAX);
        let unit = if kani::any() { Unit::Kilograms } else { Unit::Pounds };
        let step: i8 = if kani::any() { 1 } else { -1 };
        hold_adjustment_in_range(base, unit, kani::any(), step);
        crate::harness_end_reached();
    }

    /// The global-fault rule alone, for any inputs.
    #[kani::proof]
    fn verify_global_fault() {
        let tick: TickInput = kani::any();
        global_fault_is_sound(&tick.inputs());
        crate::harness_end_reached();
    }
}

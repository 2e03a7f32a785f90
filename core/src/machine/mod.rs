//! The operator's machine: boot self-test, calibration, set, pull, hold, release and faults,
//! as a typed hierarchical state machine (statig), with the panel, the counters and the
//! persisted record.
//!
//! # Theory of operation
//!
//! [`Machine::tick`] runs once per millisecond (the paper's control period). It
//!
//! 1. debounces the keys into at most one [`KeyEvent`] ([`panel::KeyPad`]); a key pressed
//!    within [`VIEW_WAKE`] of a page returning to the tension by itself only wakes the panel
//!    (the operator, still reading the page, did not see it go: the key was meant for it),
//! 2. converts the load-cell code into the tared raw tension and the calibrated tension,
//!    keeps a short running average of the raw reading (for calibration points) and takes
//!    the string encoder's count since the previous tick,
//! 3. hands all of it to the statechart as **exactly one** statig event (`Tick`),
//!    whose states write the drive command, display, lamps and store request into a
//!    context,
//! 4. logs a completed pull with the highest tension the panel showed in it (the display's
//!    own filter: the break detector's tracked peak follows the load cell's noise and is the
//!    safety rules' alone), starts any beeper pattern a state asked for, and returns the
//!    [`Outputs`].
//!
//! The wake and the shown peak are the panel's business, kept here beside the debounce
//! rather than in the statechart's storage: the statechart sees a woken key as no key.
//!
//! The statechart is in `chart.rs` (one function per state; its header draws the state
//! tree); read it next to `docs/SPEC.md`'s "The machine" section, whose tables it
//! implements. Its safety rules are in [`safety`], the fault codes in [`fault`], the panel's
//! keys, digits and beeper in [`panel`], the pull log in [`log`].
//!
//! The drive's fast loop is separate ([`crate::drive::Drive`]): the machine sees it only
//! through [`Inputs::drive`] and steers it only through [`Outputs::drive`] and
//! [`Outputs::clear_drive_fault`], which every binding hands to
//! [`crate::drive::Drive::apply`]: the command first, then the clear, so a clear is always
//! requested with the command already at coast.
//!
//! # Cost per tick
//!
//! One debounce pass over five keys, one multiplication for the tension, one for its
//! correction, a shift-and-add average, one statig dispatch climbing at most three
//! superstates, one controller step in the moving states and a four-digit render. Nothing
//! loops over the log or the record.

pub mod access;
mod chart;
pub mod fault;
pub mod log;
pub mod panel;
pub mod safety;
pub mod snapshot;
pub mod string;
pub mod wear;

use statig::prelude::{InitializedStateMachine, IntoStateMachineExt};

use crate::board::BoardConfig;
use crate::drive::{Direction, DriveCommand};
use crate::io::{Inputs, LimitSwitches, Outputs};
use crate::store::{Record, StoreError};
use crate::units::{AdcCode, Kgf};

pub use chart::{
    ADJUST_SHOWN_MS, AfterRelease, CALIBRATION_SETTLE, CALIBRATION_SPEED, CALIBRATION_WINDOW,
    CLEAR_ATTEMPT, COUNTER_ITEMS, ENTRY_MAX, ENTRY_MIN, Hold, HoldMessage, LABEL_MS, LOG_FIELDS,
    MOTOR_TEST_DUTY, MOTOR_TEST_STEPS, MOTOR_TEST_TIMEOUT, PULL_TIMEOUT, PULL_TIMEOUT_APPROACH_MS,
    PULL_TIMEOUT_TRAVEL_MM, RELEASE_TIMEOUT, Recovery, SELF_TEST_SETTLE, SELF_TEST_TICKS,
    SERVICE_ITEMS, STORE_DELAY, StringingTimer, VIEW_TIMEOUT, View, calibration_settings,
    fault_persists, hold_adjustment, hold_target, point_of_reading, pull_timeout, tension_display,
};
pub use fault::{FaultCode, Notice};
pub use log::{LoggedKgf, PULL_LOG_CAPACITY, PullLog, PullRecord};
pub use panel::{Beep, KeyEvent, KeyPad};

use chart::{Chart, Context, Sample, State, Tick};
use panel::Beeper;

/// Shift of the raw-tension running average: a first-order filter with a time constant of
/// 2⁶ = 64 ticks.
const AVERAGE_SHIFT: u32 = 6;

/// The largest hold adjustment a run can reach, tenths of the unit: the whole tension range
/// (45 kgf) is 450 tenths of a kg or 992 of a pound.
pub const HOLD_ADJUST_MAX: u16 = 1_000;

/// The state the machine is in, as a small value for displays, logs and tests.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum MachineState {
    /// Power-on self-test of the limit switches and the load cell.
    SelfTest,
    /// Power-on motor test.
    MotorTest,
    /// Power-on homing to the home limit.
    Homing,
    /// Waiting for the calibration key after the self-test.
    CalibrationWindow,
    /// Pulling to calibration reading `point` (0–7: 10, 20, 30, 40 kgf, in two passes).
    CalibrationPull {
        /// 0-based reading: the point is `point % 4`, the pass `point / 4`.
        point: u8,
    },
    /// Holding calibration reading `point` while the operator keys in the reference reading.
    CalibrationEntry {
        /// 0-based reading: the point is `point % 4`, the pass `point / 4`.
        point: u8,
    },
    /// Idle, showing and adjusting the settings.
    Ready,
    /// Pulling to the set tension.
    Pulling,
    /// Holding the set tension.
    Holding,
    /// Returning to the home limit after a pull, an abort or a cleared fault.
    Releasing,
    /// A fault is latched.
    Fault(FaultCode),
}

impl MachineState {
    /// One state of each kind (calibration point 0, the first fault code): the list the
    /// names below are checked against, and that scripts look names up in.
    pub const KINDS: [Self; 11] = [
        Self::SelfTest,
        Self::MotorTest,
        Self::Homing,
        Self::CalibrationWindow,
        Self::CalibrationPull { point: 0 },
        Self::CalibrationEntry { point: 0 },
        Self::Ready,
        Self::Pulling,
        Self::Holding,
        Self::Releasing,
        Self::Fault(FaultCode::LimitsBoth),
    ];

    /// The state's kind as one word — the one table of state names: the panel script's
    /// patterns, the host tool's legends, progress lines and JSON all use it (with the
    /// calibration point or the fault code added where they show one).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::SelfTest => "self-test",
            Self::MotorTest => "motor-test",
            Self::Homing => "homing",
            Self::CalibrationWindow => "calibration-window",
            Self::CalibrationPull { .. } => "calibration-pull",
            Self::CalibrationEntry { .. } => "calibration-entry",
            Self::Ready => "ready",
            Self::Pulling => "pulling",
            Self::Holding => "holding",
            Self::Releasing => "releasing",
            Self::Fault(_) => "fault",
        }
    }

    /// The state's kind: its index in [`MachineState::KINDS`] (the fault snapshot's state
    /// byte).
    #[must_use]
    pub const fn kind(self) -> u8 {
        match self {
            Self::SelfTest => 0,
            Self::MotorTest => 1,
            Self::Homing => 2,
            Self::CalibrationWindow => 3,
            Self::CalibrationPull { .. } => 4,
            Self::CalibrationEntry { .. } => 5,
            Self::Ready => 6,
            Self::Pulling => 7,
            Self::Holding => 8,
            Self::Releasing => 9,
            Self::Fault(_) => 10,
        }
    }

    /// Whether the machine may drive the motor in this state.
    #[must_use]
    pub const fn is_moving(self) -> bool {
        matches!(
            self,
            Self::MotorTest
                | Self::Homing
                | Self::CalibrationPull { .. }
                | Self::CalibrationEntry { .. }
                | Self::Pulling
                | Self::Holding
                | Self::Releasing
        )
    }
}

/// A machine's starting point other than power-up, for verification and replay: the state
/// to be in, the timer and data of that state, and the context a real run would have built
/// on the way there. Every field takes any value of its type; [`Checkpoint::is_valid`] says
/// which combinations the machine can actually reach, and [`Machine::resume`] is only
/// specified for those.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Checkpoint {
    /// The state.
    pub state: MachineState,
    /// Ticks already spent in it.
    pub elapsed: u32,
    /// Motor test: the direction under test; ignored elsewhere.
    pub direction: Direction,
    /// Motor test: Hall count at its start; the pull's start count in tensioned states.
    pub start_steps: i32,
    /// Motor test: the limits when it started.
    pub start_limits: LimitSwitches,
    /// Calibration entry: the value keyed in so far, hundredths of a kg (500–5 500).
    pub entered_hundredths: u16,
    /// Releasing: where it leads.
    pub then: AfterRelease,
    /// Fault: where clearing leads.
    pub recovery: Recovery,
    /// Fault: clear-attempt ticks left.
    pub clearing: u16,
    /// Ready: the page shown.
    pub view: View,
    /// Holding: the operator's adjustment, tenths of the set point's unit (`elapsed` is the
    /// tension timer).
    pub hold_adjust: i16,
    /// The unloaded load-cell code the self-test tared at.
    pub tare: AdcCode,
    /// Tensioned states: the tension rules' state (start count, peak, persistence counters).
    pub watch: safety::TensionWatch,
    /// Knot mode.
    pub knot_mode: bool,
    /// The key pad's debounce state.
    pub keypad: KeyPad,
    /// Moving states: consecutive ticks the load cell has read at a rail.
    pub rail_ticks: u8,
}

impl Checkpoint {
    /// A checkpoint for `state` with every other field at its power-up value.
    #[must_use]
    pub const fn at(state: MachineState) -> Self {
        Self {
            state,
            elapsed: 0,
            direction: Direction::Pull,
            start_steps: 0,
            start_limits: LimitSwitches { home: false, end: false },
            entered_hundredths: 1_000,
            then: AfterRelease::Ready,
            recovery: Recovery::Home,
            clearing: 0,
            view: View::Tension,
            hold_adjust: 0,
            tare: AdcCode::new(41),
            watch: safety::TensionWatch::new(0),
            knot_mode: false,
            keypad: KeyPad::new(),
            rail_ticks: 0,
        }
    }

    /// Whether a real run can be in this checkpoint: the chart's part
    /// ([`Checkpoint::chart_is_valid`]) and a valid key pad.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.chart_is_valid() && self.keypad.is_valid()
    }

    /// The invariant of everything but the key pad (whose own is [`KeyPad::is_valid`]):
    /// calibration readings 0–7 (the four points in two passes), entered value 50–550, a page's indices within their lists
    /// ([`View::is_valid`]), a hold adjustment
    /// within ±[`HOLD_ADJUST_MAX`], clear attempt within its length, a valid tension watch.
    /// (Any tare code: one outside the board's zero band leaves the board's nominal zero in
    /// use, as [`Machine::resume`] says.)
    #[must_use]
    pub fn chart_is_valid(&self) -> bool {
        let point_ok = match self.state {
            MachineState::CalibrationPull { point } | MachineState::CalibrationEntry { point } => {
                usize::from(point) < crate::sense::calibration::CALIBRATION_READINGS
            }
            _ => true,
        };
        let view_ok = self.view.is_valid();
        point_ok
            && view_ok
            && self.hold_adjust.unsigned_abs() <= HOLD_ADJUST_MAX
            && (ENTRY_MIN..=ENTRY_MAX).contains(&self.entered_hundredths)
            && self.clearing <= CLEAR_ATTEMPT
            && self.watch.is_valid()
            && self.rail_ticks < safety::RAIL_PERSIST
    }
}

/// The machine: the statechart, its panel and its log. `LOG` is the pull log's capacity.
#[derive(Clone)]
pub struct Machine<const LOG: usize = PULL_LOG_CAPACITY> {
    chart: InitializedStateMachine<Chart>,
    keypad: KeyPad,
    beeper: Beeper,
    log: PullLog<LOG>,
    raw_average: Kgf,
    /// The two raw samples before this tick's (for the average's median of three).
    raw_recent: [Kgf; 2],
    /// The Hall count filtered exactly as `raw_average` (median of three, then the same
    /// average), ×2¹⁶: the string probe's travel, lagging as its tension does.
    steps_average: i64,
    /// The two Hall counts before this tick's.
    steps_recent: [i32; 2],
    string_counter: Option<u16>,
    /// The drive command of the last tick (a fault's snapshot).
    command: DriveCommand,
    /// A settings page returned to the tension by itself and no key came since.
    page_timed_out: bool,
    /// The key whose press only woke the panel: its repeats and long press are dropped too.
    waking_key: Option<crate::io::Key>,
    /// The highest calibrated average tension of the present pull (Pulling and Holding).
    shown_peak: Kgf,
}

/// Ticks after a settings page returned to the tension by itself in which a key only wakes
/// the panel.
pub const VIEW_WAKE: u32 = 1_500;

impl Machine {
    /// A machine on `board` at power-up with the persisted `record`.
    #[must_use]
    pub fn new(record: Record, board: &BoardConfig) -> Self {
        Self::with_record(record, board)
    }

    /// A machine at power-up with whatever the store yielded: a record that failed to load
    /// is replaced by defaults and its notice (`n-01`) is shown once Ready; the counters of
    /// a newer format's record it could not read are kept ([`StoreError::kept_counters`]).
    #[must_use]
    pub fn from_stored(stored: Result<Record, StoreError>, board: &BoardConfig) -> Self {
        Self::with_stored(stored, board)
    }
}

impl<const LOG: usize> Machine<LOG> {
    /// A machine with a pull log of capacity `LOG` at power-up with `record` (the boot is
    /// counted in it).
    #[must_use]
    pub fn with_record(record: Record, board: &BoardConfig) -> Self {
        let mut chart = Chart::new(record, board);
        chart.count_boot();
        Self::build(chart, chart::power_up(), Sample::default(), KeyPad::new())
    }

    /// As [`Machine::from_stored`], with a pull log of capacity `LOG`.
    #[must_use]
    pub fn with_stored(stored: Result<Record, StoreError>, board: &BoardConfig) -> Self {
        match stored {
            Ok(record) => Self::with_record(record, board),
            Err(error) => {
                let counters = error.kept_counters().unwrap_or_default();
                let mut chart = Chart::new(Record { counters, ..Record::default() }, board);
                chart.count_boot();
                chart.notice = Some(Notice::from_store(error));
                Self::build(chart, chart::power_up(), Sample::default(), KeyPad::new())
            }
        }
    }

    /// A machine on `board` already at `checkpoint` (see [`Checkpoint`]): the state's entry
    /// actions run as on a real entry, with `record`'s settings; the load cell tared at the
    /// checkpoint's tare, or at the board's nominal zero if that tare is outside the zero band.
    #[must_use]
    pub fn resume(record: Record, checkpoint: &Checkpoint, board: &BoardConfig) -> Self {
        let mut chart = Chart::new(record, board);
        chart.booting = matches!(
            checkpoint.state,
            MachineState::SelfTest | MachineState::MotorTest | MachineState::Homing
        );
        chart.knot_mode = checkpoint.knot_mode;
        if let Ok(scale) = chart.scale.tared_at(checkpoint.tare) {
            chart.scale = scale;
            chart.rezero = crate::sense::rezero::Rezero::new(scale.zero(), chart.rezero.bands());
        }
        let state = chart::state_at(checkpoint);
        let sample = Sample {
            inputs: Inputs {
                drive: crate::drive::DriveStatus {
                    steps: checkpoint.start_steps,
                    ..Default::default()
                },
                ..Inputs::default()
            },
            ..Sample::default()
        };
        chart.watch = checkpoint.watch;
        chart.rail_ticks = checkpoint.rail_ticks;
        chart.resuming = true;
        Self::build(chart, state, sample, checkpoint.keypad)
    }

    fn build(chart: Chart, state: State, sample: Sample, keypad: KeyPad) -> Self {
        let mut uninitialized = chart.uninitialized_state_machine();
        *uninitialized.state_mut() = state;
        let mut context = Context::new(sample);
        let initialized = uninitialized.init_with_context(&mut context);
        Self {
            chart: initialized,
            keypad,
            beeper: Beeper::new(),
            log: PullLog::new(),
            raw_average: Kgf::ZERO,
            raw_recent: [Kgf::ZERO; 2],
            steps_average: i64::from(sample.inputs.drive.steps) << 16,
            steps_recent: [sample.inputs.drive.steps; 2],
            string_counter: None,
            command: DriveCommand::Coast,
            page_timed_out: false,
            waking_key: None,
            shown_peak: Kgf::ZERO,
        }
    }

    /// One 1 ms tick: exactly one statig event.
    pub fn tick(&mut self, inputs: &Inputs) -> Outputs {
        let pressed = self.keypad.tick(inputs.keys);
        let key = self.wake(pressed);
        let chart = self.chart.inner();
        let raw = chart.scale.to_kgf(inputs.load_cell);
        let tension = chart.calibration.correct(raw);
        // Running average of the median of the last three samples: avg += (median − avg) / 64.
        // The median removes a one-sample switching spike entirely (a 5 kgf spike would move
        // a plain average by 5/64 ≈ 0.08 kgf for tens of milliseconds, and the calibration
        // pairs the average with the reference gauge at the moment of Start: seen as 0.2 kgf
        // at the 40 kg point on the family); a ramp passes with one tick of delay.
        let [older, old] = self.raw_recent;
        self.raw_recent = [old, raw];
        let median = older.min(old).max(older.max(old).min(raw));
        let gap = median.to_bits().saturating_sub(self.raw_average.to_bits());
        self.raw_average =
            Kgf::from_bits(self.raw_average.to_bits().saturating_add(gap >> AVERAGE_SHIFT));
        // The Hall count through the same filter, so a straight load line T = K·x + c stays
        // straight between the two averages whatever the speed does (a linear filter
        // commutes with it): the probe's K = ΔT/Δx carries no lag.
        let steps = inputs.drive.steps;
        let [older_steps, old_steps] = self.steps_recent;
        self.steps_recent = [old_steps, steps];
        let steps_median = older_steps.min(old_steps).max(older_steps.max(old_steps).min(steps));
        let steps_gap = (i64::from(steps_median) << 16).saturating_sub(self.steps_average);
        self.steps_average = self.steps_average.saturating_add(steps_gap >> AVERAGE_SHIFT);
        let string_counts = match self.string_counter {
            // The wrapping difference of a 16-bit counter, read as signed.
            Some(previous) => {
                i16::from_ne_bytes(inputs.string_counter.wrapping_sub(previous).to_ne_bytes())
            }
            None => 0,
        };
        self.string_counter = Some(inputs.string_counter);

        let sample = Sample {
            inputs: *inputs,
            key,
            raw,
            tension,
            raw_average: self.raw_average,
            steps_average: self.steps_average,
            string_counts,
        };
        let mut context = Context::new(sample);
        let before = *self.chart.state();
        context.prior = Some((chart::public_state(&before), self.command));
        self.chart.handle_with_context(&Tick(sample), &mut context);
        self.page_timed_out = match (&before, self.chart.state()) {
            (State::Ready { view: page }, State::Ready { view: View::Tension }) => {
                self.page_timed_out || (key.is_none() && *page != View::Tension)
            }
            (_, State::Ready { .. }) => self.page_timed_out,
            _ => false,
        };
        // The shown peak: the calibrated average, from the tick the pull starts to its release.
        let moving = |state| matches!(state, MachineState::Pulling | MachineState::Holding);
        let was_moving = moving(chart::public_state(&before));
        if was_moving || moving(self.state()) {
            let averaged = self.chart.inner().calibration.correct(self.raw_average);
            self.shown_peak = if was_moving { self.shown_peak.max(averaged) } else { averaged };
        }
        if let Some(mut record) = context.completed {
            record.peak = LoggedKgf::from_kgf(self.shown_peak);
            self.log.push(record);
        }
        let mut outputs = context.out;
        if let State::Ready { view } = self.chart.state() {
            let chart = self.chart.inner();
            if let (Some((entry, field)), None) = (view.log_field(), chart.notice) {
                outputs.display = if chart.idle < LABEL_MS {
                    LOG_FIELDS.get(usize::from(field)).map_or([panel::BLANK; 4], |l| panel::text(l))
                } else {
                    self.log_value(entry, field)
                };
            }
        }
        let beep = match context.beep {
            Some(beep) => Some(beep),
            None => matches!(pressed, Some(KeyEvent::Press(_))).then_some(Beep::Click),
        };
        // The beeper preference mutes clicks and tones, never the fault pattern.
        let audible = self.chart.inner().record.preferences.beeper;
        if let Some(beep) = beep.filter(|beep| audible || *beep == Beep::Fault) {
            self.beeper.play(beep, inputs.now_ms);
        }
        outputs.beeper = self.beeper.sounding(inputs.now_ms);
        self.command = outputs.drive;
        outputs
    }

    /// The key event the statechart gets for `pressed`: none for a press within
    /// [`VIEW_WAKE`] of a settings page returning to the tension by itself (it only wakes the
    /// panel), nor for that key's repeats and long press.
    fn wake(&mut self, pressed: Option<KeyEvent>) -> Option<KeyEvent> {
        let in_ready = matches!(self.chart.state(), State::Ready { .. });
        match pressed {
            Some(KeyEvent::Press(key)) => {
                let woken = core::mem::take(&mut self.page_timed_out)
                    && in_ready
                    && self.chart.inner().idle < VIEW_TIMEOUT.saturating_add(VIEW_WAKE);
                self.waking_key = woken.then_some(key);
                (!woken).then_some(KeyEvent::Press(key))
            }
            Some(event) if self.waking_key == Some(event.key()) => None,
            other => other,
        }
    }

    /// The log page's value: `field` of [`LOG_FIELDS`] of the entry `entry` back from the
    /// latest, or `----` when the log has no such entry or the pull no such measurement.
    fn log_value(&self, entry: u8, field: u8) -> crate::io::Display {
        let chart = self.chart.inner();
        let unit = chart.record.settings.set_point().unit();
        let none = panel::text(b"----");
        let Some(record) = self.log.back(usize::from(entry)) else { return none };
        match field {
            0 => panel::integer(chart.record.counters.pulls.saturating_sub(u32::from(entry))),
            1 => tension_display(record.target.to_kgf(), unit),
            2 => tension_display(record.peak.to_kgf(), unit),
            3 => tension_display(record.adjust.to_kgf(), unit),
            4 => panel::hundredths(i32::from(record.time_to_tension_ms / 10)),
            5 => panel::clock(b' ', u32::from(record.held_s)),
            6 => panel::integer(u32::from(record.string_mm)),
            7 => record.stiffness.map_or(none, |k| panel::hundredths(i32::from(k.milli() / 10))),
            _ => record
                .creep
                .map_or(none, |c| panel::tenths(i32::from(c.centi_percent_per_minute() / 10))),
        }
    }

    /// The stringing timer.
    #[must_use]
    pub fn stringing_timer(&self) -> StringingTimer {
        self.chart.inner().stringing
    }

    /// The record to persist when [`Outputs::store`] is set.
    #[must_use]
    pub fn record(&self) -> &Record {
        &self.chart.inner().record
    }

    /// The load cell's zero in use: the self-test's tare, or the last re-zero at rest's.
    #[must_use]
    pub fn load_cell_zero(&self) -> crate::units::Volts {
        self.chart.inner().scale.zero()
    }

    /// Re-zeros at rest taken since power-up (REQ-ID-08).
    #[must_use]
    pub fn rezeros(&self) -> u16 {
        self.chart.inner().rezeros
    }

    /// The current state.
    #[must_use]
    pub fn state(&self) -> MachineState {
        chart::public_state(self.chart.state())
    }

    /// The latched fault, if any.
    #[must_use]
    pub fn fault(&self) -> Option<FaultCode> {
        match self.state() {
            MachineState::Fault(code) => Some(code),
            _ => None,
        }
    }

    /// The notice shown in Ready until a key is pressed, if any.
    #[must_use]
    pub fn notice(&self) -> Option<Notice> {
        self.chart.inner().notice
    }

    /// The recent pulls, oldest first.
    #[must_use]
    pub fn log(&self) -> &PullLog<LOG> {
        &self.log
    }

    /// The page the Ready panel shows (Tension outside Ready).
    #[must_use]
    pub fn view(&self) -> View {
        match self.chart.state() {
            State::Ready { view } => *view,
            _ => View::Tension,
        }
    }

    /// The hold's data (adjustment, tension timer, page) while holding.
    #[must_use]
    pub fn hold(&self) -> Option<Hold> {
        match self.chart.state() {
            State::Holding { hold } => Some(*hold),
            _ => None,
        }
    }

    /// Whether the tension controller pulls constantly (false: switched off in this hold).
    #[must_use]
    pub fn constant_pull(&self) -> bool {
        self.chart.inner().controller.constant_pull()
    }

    /// Knot mode.
    #[must_use]
    pub fn knot_mode(&self) -> bool {
        self.chart.inner().knot_mode
    }

    /// The tension rules' state of the present pull (for proofs and diagnostics).
    #[must_use]
    pub fn watch(&self) -> safety::TensionWatch {
        self.chart.inner().watch
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{Key, Keys};
    use crate::settings::Unit;

    /// A code's volts on the paper's board's converter.
    fn volts(code: AdcCode) -> crate::units::Volts {
        crate::test_support::paper_board().load_cell().volts(code)
    }

    /// Every kind has its own name, and the payload (point, fault code) never changes it.
    #[test]
    fn each_state_kind_has_one_name() {
        for (index, kind) in MachineState::KINDS.iter().enumerate() {
            for other in MachineState::KINDS.iter().skip(index + 1) {
                assert_ne!(kind.name(), other.name());
            }
        }
        assert_eq!(MachineState::CalibrationPull { point: 3 }.name(), "calibration-pull");
        assert_eq!(MachineState::CalibrationEntry { point: 2 }.name(), "calibration-entry");
        assert_eq!(MachineState::Fault(FaultCode::Overload).name(), "fault");
    }

    /// A state's kind is its index in the list of kinds, whatever its payload.
    #[test]
    fn each_state_kind_is_its_index_in_the_list() {
        for (index, kind) in MachineState::KINDS.iter().enumerate() {
            assert_eq!(usize::from(kind.kind()), index, "{}", kind.name());
        }
        assert_eq!(MachineState::CalibrationEntry { point: 5 }.kind(), 5);
        assert_eq!(MachineState::Fault(FaultCode::Overload).kind(), 10);
    }

    /// A newer format's record this build cannot read leaves its counters to the machine,
    /// which starts from the defaults and shows the store notice; any other store error
    /// leaves nothing.
    #[test]
    fn a_newer_records_counters_survive_the_store_notice() {
        let counters =
            crate::store::Counters { pulls: 5_000, string_used_mm: 3_210_000, boots: 77 };
        let machine: Machine = Machine::with_stored(
            Err(StoreError::NewerFormat(counters)),
            &crate::test_support::paper_board(),
        );
        let record = machine.record();
        assert_eq!(record.counters, crate::store::Counters { boots: 78, ..counters });
        assert_eq!((record.settings, record.calibration), (Record::default().settings, None));
        assert_eq!(machine.notice(), Some(Notice::StoreInvalid));
        let machine: Machine =
            Machine::with_stored(Err(StoreError::CrcMismatch), &crate::test_support::paper_board());
        assert_eq!(machine.record().counters.pulls, 0);
        assert_eq!(machine.record().counters.boots, 1);
        assert_eq!(machine.notice(), Some(Notice::StoreInvalid));
    }

    /// Feeds `ticks` ticks reading `code`; returns the last outputs.
    fn holding_with(machine: &mut Machine, code: AdcCode, ticks: u32, now: &mut u32) -> Outputs {
        let mut out = Outputs::default();
        for _ in 0..ticks {
            *now = now.wrapping_add(1);
            let inputs = Inputs { now_ms: *now, load_cell: code, ..Inputs::default() };
            out = machine.tick(&inputs);
        }
        out
    }

    /// REQ-UI-11: with the beeper off a key does not click, but a fault still sounds.
    #[test]
    fn a_muted_beeper_still_sounds_a_fault() {
        let mut record = Record::default();
        record.preferences.beeper = false;
        for muted in [true, false] {
            record.preferences.beeper = !muted;
            let mut machine: Machine = Machine::resume(
                record,
                &Checkpoint::at(MachineState::Ready),
                &crate::test_support::paper_board(),
            );
            let mut clicked = false;
            for now in 1..=60u32 {
                let keys = if now <= 40 { Keys::NONE.with(Key::Up) } else { Keys::NONE };
                let inputs =
                    Inputs { now_ms: now, keys, load_cell: AdcCode::new(41), ..Inputs::default() };
                clicked |= machine.tick(&inputs).beeper;
            }
            assert_eq!(clicked, !muted, "a key click, muted {muted}");
            let both = LimitSwitches { home: true, end: true };
            let inputs = Inputs { now_ms: 61, limits: both, ..Inputs::default() };
            let out = machine.tick(&inputs);
            assert_eq!(machine.fault(), Some(FaultCode::LimitsBoth));
            assert!(out.beeper, "the fault sounds, muted {muted}");
        }
    }

    /// Ticks a machine in Ready at home, untouched, for `ticks` ticks with the load-cell code
    /// `code(tick)` and the carriage's Hall count `steps(tick)`.
    fn at_home(
        machine: &mut Machine,
        ticks: u32,
        now: &mut u32,
        code: impl Fn(u32) -> u16,
        steps: impl Fn(u32) -> i32,
    ) {
        let home = LimitSwitches { home: true, end: false };
        for t in 0..ticks {
            *now = now.wrapping_add(1);
            let drive = crate::drive::DriveStatus { steps: steps(t), ..Default::default() };
            let inputs = Inputs {
                now_ms: *now,
                load_cell: AdcCode::new(code(t)),
                limits: home,
                drive,
                ..Inputs::default()
            };
            let _ = machine.tick(&inputs);
        }
    }

    /// REQ-ID-08: at rest in Ready the zero follows a drifted but unloaded load cell; a string
    /// held in the gripper, a hand pushing it (steady or not), or a carriage that moves are
    /// refused and the zero stays.
    #[test]
    fn a_rezero_is_taken_at_rest_and_refused_while_the_gripper_holds_a_string_or_is_pushed() {
        let tare = AdcCode::new(41);
        let fresh = || {
            Machine::resume(
                Record::default(),
                &Checkpoint::at(MachineState::Ready),
                &crate::test_support::paper_board(),
            )
        };
        let mut now = 0;
        // Drifted by two codes, unloaded: re-zeroed after 2 s of rest and five windows.
        let mut machine = fresh();
        assert_eq!(machine.load_cell_zero(), volts(tare));
        at_home(&mut machine, 2_499, &mut now, |_| 43, |_| 0);
        assert_eq!(machine.load_cell_zero(), volts(tare), "not before five windows");
        at_home(&mut machine, 1, &mut now, |_| 43, |_| 0);
        assert_eq!(machine.load_cell_zero(), volts(AdcCode::new(43)));
        assert_eq!(machine.rezeros(), 1);
        // A string held in the gripper: 0.1 kgf, steady.
        let held = crate::test_support::paper_board()
            .load_cell()
            .tared_at(tare)
            .map(|s| s.to_code(Kgf::from_milli(100)));
        let Ok(held) = held else { panic!("the nominal scale tares at 41") };
        let mut machine = fresh();
        at_home(&mut machine, 10_000, &mut now, |_| held.get(), |_| 0);
        assert_eq!(machine.load_cell_zero(), volts(tare), "a held string");
        // A hand pushing the gripper: a few codes that wander from window to window.
        let mut machine = fresh();
        at_home(
            &mut machine,
            10_000,
            &mut now,
            |t| 41 + [0, 3, 1, 4, 2][(t / 70 % 5) as usize],
            |_| 0,
        );
        assert_eq!(machine.load_cell_zero(), volts(tare), "a pushed gripper");
        // A hand pushing hard and steadily: refused as loaded.
        let mut machine = fresh();
        at_home(&mut machine, 10_000, &mut now, |_| 60, |_| 0);
        assert_eq!(machine.load_cell_zero(), volts(tare), "a steady push");
        // The carriage nudged every second (a hand on the gripper moves it): never at rest.
        let mut machine = fresh();
        at_home(&mut machine, 10_000, &mut now, |_| 43, |t| (t / 1_000).cast_signed());
        assert_eq!(machine.load_cell_zero(), volts(tare), "a moving carriage");
        assert_eq!(machine.rezeros(), 0);
        // A tare is not taken away from home either.
        let mut machine = fresh();
        for t in 0..10_000u32 {
            let inputs = Inputs { now_ms: t, load_cell: AdcCode::new(43), ..Inputs::default() };
            let _ = machine.tick(&inputs);
        }
        assert_eq!(machine.load_cell_zero(), volts(tare), "away from home");
    }

    /// REQ-ID-08: a zero that keeps drifting is followed step by step up to the range from
    /// the self-test's tare, never beyond it.
    #[test]
    fn a_drifting_zero_is_followed_up_to_its_range_from_the_self_tests_tare() {
        let mut machine = Machine::resume(
            Record::default(),
            &Checkpoint::at(MachineState::Ready),
            &crate::test_support::paper_board(),
        );
        let mut now = 0;
        // One code (1.22 mV, 0.013 kgf) every 3 s, for 60 codes (73 mV, 0.80 kgf): the range
        // is 0.5435 kgf, 50 mV on the paper's chain.
        for code in 41..=101u16 {
            at_home(&mut machine, 3_000, &mut now, |_| code, |_| 0);
        }
        let reference = volts(AdcCode::new(41)).0;
        let moved = machine.load_cell_zero().0.saturating_sub(reference);
        let scale = crate::test_support::paper_board().load_cell();
        let range = crate::sense::rezero::RezeroBands::for_scale(&scale).range().0;
        assert_eq!(range, crate::units::Q16::lit("0.05"));
        assert!(moved <= range, "{moved}");
        assert!(moved > range.saturating_sub(volts(AdcCode::new(2)).0));
    }

    /// REQ-UI-12: the drift watch — a zero followed past 0.2717 kgf (25 mV on the paper's
    /// chain) from the self-test's asks for a recalibration (n-04) once; the service page
    /// shows the drift.
    #[test]
    fn a_zero_drifted_past_the_watch_raises_the_recalibration_notice_once() {
        let mut machine = Machine::resume(
            Record::default(),
            &Checkpoint::at(MachineState::Ready),
            &crate::test_support::paper_board(),
        );
        let mut now = 0;
        // Up to 20 codes (24.4 mV, 0.265 kgf) above the tare: followed, no notice.
        for code in 41..=61u16 {
            at_home(&mut machine, 3_000, &mut now, |_| code, |_| 0);
        }
        assert_eq!(machine.load_cell_zero(), volts(AdcCode::new(61)));
        assert_eq!(machine.notice(), None);
        // 21 codes (25.6 mV, 0.279 kgf): the notice, shown in Ready.
        at_home(&mut machine, 3_000, &mut now, |_| 62, |_| 0);
        assert_eq!(machine.notice(), Some(Notice::ZeroDrift));
        assert_eq!(machine.notice().map(Notice::number), Some(4));
        // A key acknowledges it; further drift does not raise it again this boot.
        let press = Inputs {
            now_ms: now + 1,
            keys: Keys::NONE.with(Key::Down),
            limits: LimitSwitches { home: true, end: false },
            load_cell: AdcCode::new(62),
            ..Inputs::default()
        };
        for t in 0..40 {
            let _ = machine.tick(&Inputs { now_ms: now + 1 + t, ..press });
        }
        now += 40;
        at_home(&mut machine, 200, &mut now, |_| 62, |_| 0);
        assert_eq!(machine.notice(), None);
        for code in 62..=70u16 {
            at_home(&mut machine, 3_000, &mut now, |_| code, |_| 0);
        }
        assert_eq!(machine.notice(), None);
    }

    #[test]
    fn a_switching_spike_never_reaches_the_digits() {
        let mut machine = Machine::resume(
            Record::default(),
            &Checkpoint::at(MachineState::Holding),
            &crate::test_support::paper_board(),
        );
        // A checkpoint's pull has no target, so stay under the 5 kgf overload margin.
        let steady = crate::test_support::paper_board().load_cell().to_code(Kgf::from_milli(3_040));
        let spike = crate::test_support::paper_board().load_cell().to_code(Kgf::from_milli(3_740));
        let mut now = 0;
        let settled = holding_with(&mut machine, steady, 1_000, &mut now);
        assert_eq!(machine.state(), MachineState::Holding);
        assert_eq!(settled.display, tension_display(Kgf::from_tenths(30), Unit::Kilograms));
        // One tick 0.7 kgf high, then steady again: the digits never move.
        let at_spike = holding_with(&mut machine, spike, 1, &mut now);
        assert_eq!(at_spike.display, settled.display);
        for _ in 0..400 {
            assert_eq!(holding_with(&mut machine, steady, 1, &mut now).display, settled.display);
        }
    }
}

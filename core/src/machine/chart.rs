//! The statechart itself: one function per state, superstates for the shared safety rules.
//!
//! # Theory of operation
//!
//! This file is the machine's behaviour, written for [`statig`]: each `#[state]` function is
//! one state of `docs/SPEC.md` ("The machine", States), each `#[superstate]` a group of
//! states sharing rules, each `#[action]` what happens on entering or leaving one.
//!
//! ```text
//! operational ─┬─ self_test            (boot: limits, load cell, tare)
//!              ├─ calibration_window   (boot: Function → calibrate)
//!              ├─ ready                (set tension, speed, pre-stretch, knot, unit, presets)
//!              └─ motion ─┬─ motor_test          (boot: brief low-duty drive, Hall check)
//!                         ├─ releasing           (to the home limit; homing at boot)
//!                         └─ tensioned ─┬─ pulling, holding
//!                                       └─ calibration_pull, calibration_entry
//! fault                                 (latched; outside `operational`)
//! ```
//!
//! **Propose, then dispose.** Every tick is one [`Tick`] event. A leaf state computes its
//! drive command, display and lamps into the context and *proposes* its next state
//! (`context.next`), then returns `Super` — it never transitions by itself. The event then
//! climbs the superstates, innermost first: `tensioned` applies the tension rules, `motion`
//! the moving rules (never toward an active limit, stall, sensor rails), `operational` the
//! rules that hold everywhere (both limits, drive fault, overcurrent). Any of them may veto
//! with a fault: it zeroes the drive command *in this tick* and transitions to `fault`.
//! Only `operational`, the outermost, commits the leaf's proposal. So no state can skip a
//! safety rule, and a fault always wins over a proposal.
//!
//! **Safe entries and exits.** Leaving `motion` and entering `fault` zero the drive command;
//! a non-moving state never writes one, so it coasts (the context starts every tick at
//! coast).

use statig::prelude::*;

use crate::drive::{Direction, DriveCommand, Duty};
use crate::io::{Inputs, Key, Leds, LimitSwitches, Outputs};
use crate::machine::MachineState;
use crate::machine::fault::FaultCode;
use crate::machine::log::{PullRecord, string_mm};
use crate::machine::panel::{self, Beep, KeyEvent};
use crate::machine::safety::{self, TensionSample};
use crate::machine::snapshot::{FaultSnapshot, Latch};
use crate::sense::calibration::CALIBRATION_POINTS;
use crate::sense::rezero::Rezero;
use crate::settings::{PullKind, Speed, TENSION_MAX, TENSION_MIN, Unit};
use crate::units::Kgf;

mod calibrating;
mod checkpoint;
mod pages;
mod storage;

use calibrating::{calibration_label, entry_average};
pub use calibrating::{calibration_settings, point_of_reading};
pub(crate) use checkpoint::{power_up, public_state, state_at};
pub use pages::{
    ADJUST_SHOWN_MS, COUNTER_ITEMS, DISPLAY_REFRESH_MS, HoldMessage, LABEL_MS, LOG_FIELDS,
    SERVICE_ITEMS, StringingTimer, VIEW_TIMEOUT, View, tension_display,
};
pub use storage::Chart;

/// Ticks the self-test takes: [`SELF_TEST_SETTLE`] ticks for the amplifier to settle,
/// then 100 readings of the unloaded load cell averaged (the limits are watched throughout).
/// 100 ms is five periods of 50 Hz mains and six of 60 Hz, so the hum averages out of the
/// tare (over a span that is not whole periods, up to a tenth of the hum's peak would stay in
/// it: an offset in every pull until the next boot).
pub const SELF_TEST_TICKS: u16 = 116;
/// Ticks at the start of the self-test whose load-cell readings are not averaged.
pub const SELF_TEST_SETTLE: u16 = 16;
/// The motor test's duty: 15 %.
pub const MOTOR_TEST_DUTY: Duty = Duty::from_raw_clamped(9_830);
/// Hall steps the motor test must see in the commanded direction: 48 = two motor turns,
/// 2.5 mm of carriage travel — enough to leave a limit switch's actuation zone.
pub const MOTOR_TEST_STEPS: i32 = 48;
/// Ticks the motor test may take.
pub const MOTOR_TEST_TIMEOUT: u32 = 1_500;
/// How long after the self-test the calibration key is accepted.
pub const CALIBRATION_WINDOW: u32 = 5_000;
/// Ticks a calibration point must be held at tension before the operator is asked for the
/// reference reading (the raw reading's average settles meanwhile).
pub const CALIBRATION_SETTLE: u32 = 1_000;
/// The speed setting used to pull calibration points.
pub const CALIBRATION_SPEED: u8 = 3;
/// The calibration entry's range, hundredths of a kg: 5.00–55.00 (the reference readings
/// `Calibration::new` accepts). The entry is keyed to 0.01 kg, a reference gauge's
/// resolution: keyed to the set point's 0.1 kg, the rounding (up to ±0.05 kgf per point, the
/// same way at every point when the chain's offset is constant) would stay in the fitted line.
pub const ENTRY_MIN: u16 = 500;
/// See [`ENTRY_MIN`].
pub const ENTRY_MAX: u16 = 5_500;
/// A calibration point that has not reached tension after this many ticks faults, and no
/// pull's limit is shorter ([`pull_timeout`]).
pub const PULL_TIMEOUT: u32 = 40_000;
/// The carriage travel a pull's time limit allows for at the speed setting's limit, mm: more
/// than any machine's slack plus stretch (the twin's whole travel is 250 mm; a pull that
/// needs more ends at the end switch, E-14, first).
pub const PULL_TIMEOUT_TRAVEL_MM: u32 = 400;
/// Added to the travel time for the approach's slow end and the string's creep while the
/// tension closes, ms.
pub const PULL_TIMEOUT_APPROACH_MS: u32 = 20_000;

/// How long a pull at `speed` may take to reach tension: [`PULL_TIMEOUT_TRAVEL_MM`] at the
/// speed's carriage limit plus [`PULL_TIMEOUT_APPROACH_MS`], and at least [`PULL_TIMEOUT`]
/// (64.4 s at speed 1, 42.2 s at 2, 40 s from 3 up). A fixed 40 s would fault honest pulls
/// of a soft string at speed 1 (9 mm/s: 250 mm of take-up alone is 28 s); a jammed carriage
/// is a stall (E-09) long before, and a string slipping in its clamp still ends here.
#[must_use]
pub fn pull_timeout(speed: Speed) -> u32 {
    // The speed's carriage limit in whole mm/s (a whole number: 9 per step).
    let limit_bits = speed.carriage_limit().0.to_bits().checked_shr(16).unwrap_or(0);
    let mm_per_s = u32::try_from(limit_bits).unwrap_or(0);
    let travel_ms = PULL_TIMEOUT_TRAVEL_MM.saturating_mul(1_000).checked_div(mm_per_s).unwrap_or(0);
    travel_ms.saturating_add(PULL_TIMEOUT_APPROACH_MS).max(PULL_TIMEOUT)
}
/// A release that has not reached home after this many ticks faults.
pub const RELEASE_TIMEOUT: u32 = 40_000;
/// Ticks the fault state keeps asking the drive to clear after the operator's Start.
pub const CLEAR_ATTEMPT: u16 = 100;
/// Ticks without a key before a settings change is written to the store.
pub const STORE_DELAY: u32 = 2_000;

/// The hold's own data: the operator's adjustment, the tension timer, the page shown.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Hold {
    /// The adjustment of the held target, tenths of the set point's unit (fine steps of
    /// 0.1 kg or 0.2 lb); the held target is [`hold_target`] of it.
    pub adjust: i16,
    /// The tension timer: milliseconds since the tension was reached.
    pub held_ms: u32,
    /// Whether the digits show the tension timer instead of the tension.
    pub timer: bool,
    /// What the digits show after a key, and for how many more milliseconds.
    pub message: Option<(HoldMessage, u16)>,
}

impl Hold {
    /// Just arrived at tension: no adjustment, the timer at zero, the tension shown.
    pub const AT_TENSION: Self = Self { adjust: 0, held_ms: 0, timer: false, message: None };
}

/// The held target of a pull whose final target is `base`, adjusted by `adjust` tenths of
/// `unit` (not clamped: [`hold_adjustment`] never lets it leave the tension range).
#[must_use]
pub fn hold_target(base: Kgf, unit: Unit, adjust: i16) -> Kgf {
    base.saturating_add(unit.tenths_to_kgf(i32::from(adjust)))
}

/// REQ-SM-08, one Up (`step` = 1) or Down (−1) while holding, from adjustment `adjust` on a
/// pull whose final target is `base`: the new adjustment and held target, or `None` — the
/// adjustment refused — when the target would leave [`TENSION_MIN`]–[`TENSION_MAX`] (a
/// knot pull's boosted target adjusts within the same range).
#[must_use]
pub fn hold_adjustment(base: Kgf, unit: Unit, adjust: i16, step: i8) -> Option<(i16, Kgf)> {
    let next = adjust.checked_add(i16::from(step).checked_mul(unit.fine_step_tenths())?)?;
    let target = hold_target(base, unit, next);
    (target >= TENSION_MIN && target <= TENSION_MAX).then_some((next, target))
}

/// What one tick tells the machine: the inputs and what the machine made of them before
/// dispatch (the debounced key event, the tension readings).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Sample {
    /// The raw inputs.
    pub inputs: Inputs,
    /// The key event of this tick, if any.
    pub key: Option<KeyEvent>,
    /// The tared, uncorrected tension.
    pub raw: Kgf,
    /// The calibrated tension.
    pub tension: Kgf,
    /// The uncorrected tension averaged over ≈ 64 ms (calibration points).
    pub raw_average: Kgf,
    /// The Hall count through the same filter as `raw_average`, ×2¹⁶ (the string probe).
    pub steps_average: i64,
    /// String-encoder counts since the previous tick.
    pub string_counts: i16,
}

/// The statig event: one per 1 ms tick.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Tick(pub Sample);

/// What states write during a tick.
#[derive(Debug)]
pub struct Context {
    /// This tick's sample (for entry and exit actions, which see no event).
    pub sample: Sample,
    /// The outputs being built; starts at coast with a blank panel.
    pub out: Outputs,
    /// The leaf state's proposal, committed by `operational` unless a rule vetoes it.
    pub next: Option<State>,
    /// A beeper pattern to start.
    pub beep: Option<Beep>,
    /// A pull completed this tick: log it.
    pub completed: Option<PullRecord>,
    /// The leaf expects the carriage to move now (taking up slack, releasing): the stall
    /// rule applies.
    pub expect_motion: bool,
    /// The state and drive command before this tick (a fault's snapshot).
    pub prior: Option<(MachineState, DriveCommand)>,
}

impl Context {
    /// A fresh context for `sample`.
    #[must_use]
    pub fn new(sample: Sample) -> Self {
        Self {
            sample,
            out: Outputs::default(),
            next: None,
            beep: None,
            completed: None,
            expect_motion: false,
            prior: None,
        }
    }
}

/// Where a fault's clearing leads.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Recovery {
    /// Raised during the boot sequence: run the self-test again (the paper: fix, power-cycle).
    SelfTest,
    /// Raised in operation: release to the home limit, then Ready.
    Home,
}

/// Where a release leads once home.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum AfterRelease {
    /// Boot homing: on to the calibration window.
    CalibrationWindow,
    /// After a pull, an abort or a fault: Ready.
    Ready,
    /// Between the calibration's passes: the second pass's first point
    /// (`calibration_pull(CALIBRATION_POINTS)`).
    NextPass,
}

/// Whether a pull is still taking up slack: below half its peak target, where the carriage
/// must be moving.
fn taking_up(tension: Kgf, peak_target: Kgf) -> bool {
    tension < Kgf::from_bits(peak_target.to_bits().checked_div(2).unwrap_or(0))
}

/// Whether a key event is a press of any key.
const fn pressed(key: Option<KeyEvent>) -> bool {
    matches!(key, Some(KeyEvent::Press(_)))
}

#[state_machine(
    initial = "State::self_test(0, 0)",
    state(derive(Clone, Copy, PartialEq, Eq, Debug)),
    superstate(derive(Debug)),
    visibility = "pub"
)]
impl Chart {
    // ───────────────────────────── superstates ─────────────────────────────

    /// Rules that hold in every state but `fault`; commits the leaf's proposal.
    #[superstate]
    fn operational(&mut self, context: &mut Context, event: &Tick) -> Outcome<State> {
        let Tick(sample) = event;
        self.resuming = false;
        if let Some(code) = safety::global_fault(&sample.inputs) {
            return self.trip(context, code);
        }
        match context.next.take() {
            Some(next) => Transition(next),
            None => Handled,
        }
    }

    /// Rules for every state that may drive the motor.
    #[superstate(
        superstate = "operational",
        entry_action = "enter_motion",
        exit_action = "exit_motion"
    )]
    fn motion(&mut self, context: &mut Context, event: &Tick) -> Outcome<State> {
        let Tick(sample) = event;
        context.out.drive = safety::limit_guard(context.out.drive, sample.inputs.limits);
        let driving = context.expect_motion && context.out.drive.duty() >= safety::STALL_DUTY;
        self.driven_ms = if driving { self.driven_ms.saturating_add(1) } else { 0 };
        if driving && safety::stall(context.out.drive, &sample.inputs, self.driven_ms) {
            return self.trip(context, FaultCode::Stall);
        }
        let rail = safety::load_cell_rail(sample.inputs.load_cell);
        self.rail_ticks = if rail.is_some() { self.rail_ticks.saturating_add(1) } else { 0 };
        if let Some(code) = rail.filter(|_| self.rail_ticks >= safety::RAIL_PERSIST) {
            return self.trip(context, code);
        }
        Super
    }

    /// Entering motion: no rail reading seen yet.
    #[action]
    fn enter_motion(&mut self) {
        self.driven_ms = 0;
        if !self.resuming {
            self.rail_ticks = 0;
        }
    }

    /// Leaving motion: the bridge coasts.
    #[action]
    fn exit_motion(&mut self, context: &mut Context) {
        context.out.drive = DriveCommand::Coast;
    }

    /// Rules for every state that holds the string under tension.
    #[superstate(superstate = "motion")]
    fn tensioned(&mut self, context: &mut Context, event: &Tick) -> Outcome<State> {
        let Tick(sample) = event;
        let check = TensionSample {
            tension: sample.tension,
            raw: sample.raw,
            steps: sample.inputs.drive.steps,
            limits: sample.inputs.limits,
            peak_target: self.peak_target,
        };
        if let Some(code) = self.watch.check(&check) {
            return self.trip(context, code);
        }
        self.string_counts = self.string_counts.saturating_add(i32::from(sample.string_counts));
        Super
    }

    // ───────────────────────────── boot ─────────────────────────────

    /// Power-on self-test: limits not both active, load cell off its rails and inside the
    /// zero band (then tared), for [`SELF_TEST_TICKS`].
    #[state(superstate = "operational", entry_action = "enter_self_test")]
    fn self_test(
        &mut self,
        context: &mut Context,
        event: &Tick,
        elapsed: &mut u16,
        code_sum: &mut u32,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        context.out.display = panel::text(b"tESt");
        if *elapsed >= SELF_TEST_SETTLE {
            *code_sum = code_sum.saturating_add(u32::from(sample.inputs.load_cell.get()));
        }
        *elapsed = elapsed.saturating_add(1);
        if *elapsed >= SELF_TEST_TICKS {
            // 100 samples of ≤ 4095: the sum fits. The rail check reads the whole-code mean;
            // the tare keeps the fraction.
            let averaged = SELF_TEST_TICKS.saturating_sub(SELF_TEST_SETTLE);
            let mean = crate::units::AdcCode::new(
                u16::try_from(code_sum.checked_div(u32::from(averaged)).unwrap_or(0))
                    .unwrap_or(u16::MAX),
            );
            context.next = Some(if let Some(code) = safety::load_cell_rail(mean) {
                State::fault(code, Recovery::SelfTest, 0)
            } else {
                match self.scale.tared_at_mean(*code_sum, averaged) {
                    Ok(scale) => {
                        self.scale = scale;
                        self.rezero = Rezero::new(scale.zero(), self.rezero.bands())
                            .taken_at(sample.inputs.now_ms);
                        let limits = sample.inputs.limits;
                        let direction =
                            if limits.end { Direction::Release } else { Direction::Pull };
                        State::motor_test(0, direction, sample.inputs.drive.steps, limits)
                    }
                    Err(_) => State::fault(FaultCode::LoadCellZero, Recovery::SelfTest, 0),
                }
            });
        }
        Super
    }

    /// Entering the self-test: the boot sequence starts (again).
    #[action]
    fn enter_self_test(&mut self) {
        self.booting = true;
        self.controller.stop();
    }

    /// Motor test: a brief low-duty drive must give [`MOTOR_TEST_STEPS`] Hall steps in the
    /// commanded direction within [`MOTOR_TEST_TIMEOUT`]; the switch the carriage started on
    /// must have opened.
    #[state(superstate = "motion")]
    fn motor_test(
        &mut self,
        context: &mut Context,
        event: &Tick,
        elapsed: &mut u32,
        direction: &mut Direction,
        start_steps: &mut i32,
        start_limits: &mut LimitSwitches,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        context.out.display = panel::text(b"tESt");
        context.out.drive = DriveCommand::Drive { direction: *direction, duty: MOTOR_TEST_DUTY };
        *elapsed = elapsed.saturating_add(1);
        let moved = sample.inputs.drive.steps.wrapping_sub(*start_steps);
        let forward = match direction {
            Direction::Pull => moved,
            Direction::Release => moved.saturating_neg(),
        };
        let limits = sample.inputs.limits;
        let stuck = (start_limits.home && limits.home) || (start_limits.end && limits.end);
        context.next = if forward >= MOTOR_TEST_STEPS {
            context.out.drive = DriveCommand::Coast;
            // The drivetrain's drag trend (REQ-UI-14): the test's time against commissioning.
            if self.record.drivetrain.observe(*elapsed) && self.notice.is_none() {
                self.notice = Some(super::Notice::DrivetrainWear);
            }
            self.dirty = true;
            if start_limits.home {
                // REQ-TEN-21: home is where the test started; the homing slows onto it.
                self.controller.set_home(*start_steps);
            }
            Some(if stuck {
                State::fault(FaultCode::LimitStuck, Recovery::SelfTest, 0)
            } else {
                State::releasing(0, AfterRelease::CalibrationWindow)
            })
        } else if forward <= MOTOR_TEST_STEPS.saturating_neg() {
            Some(State::fault(FaultCode::MotorWrongDirection, Recovery::SelfTest, 0))
        } else if *elapsed >= MOTOR_TEST_TIMEOUT {
            Some(State::fault(FaultCode::MotorNoRotation, Recovery::SelfTest, 0))
        } else {
            None
        };
        Super
    }

    /// After the self-test: the calibration key (Function) starts a calibration; any other
    /// key, or [`CALIBRATION_WINDOW`] without one, goes to Ready.
    #[state(superstate = "operational", entry_action = "enter_calibration_window")]
    fn calibration_window(
        &mut self,
        context: &mut Context,
        event: &Tick,
        elapsed: &mut u32,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        context.out.display = panel::text(b"CAL?");
        context.out.leds = self.unit_leds();
        *elapsed = elapsed.saturating_add(1);
        context.next = match sample.key {
            Some(KeyEvent::Press(Key::Function)) => Some(State::calibration_pull(0, 0, 0)),
            Some(KeyEvent::Press(_)) => Some(State::ready(View::Tension)),
            _ if *elapsed >= CALIBRATION_WINDOW => Some(State::ready(View::Tension)),
            _ => None,
        };
        Super
    }

    /// The boot sequence is over.
    #[action]
    fn enter_calibration_window(&mut self) {
        self.booting = false;
    }

    // ───────────────────────────── calibration ─────────────────────────────

    /// Pull to calibration point `point` by the raw reading and hold it for
    /// [`CALIBRATION_SETTLE`]; any key aborts; [`PULL_TIMEOUT`] faults.
    #[state(superstate = "tensioned", entry_action = "enter_calibration_pull")]
    fn calibration_pull(
        &mut self,
        context: &mut Context,
        event: &Tick,
        point: &mut u8,
        settled: &mut u32,
        elapsed: &mut u32,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        *elapsed = elapsed.saturating_add(1);
        context.out.display = panel::text(&calibration_label(usize::from(*point)));
        let output = self.controller.step(&Self::measurement(sample, sample.raw));
        context.out.drive = output.command;
        context.expect_motion = taking_up(sample.raw, self.peak_target);
        context.out.leds = Leds { pulling: true, holding: output.at_tension, ..self.unit_leds() };
        *settled = if output.at_tension { settled.saturating_add(1) } else { 0 };
        context.next = if pressed(sample.key) {
            context.out.drive = DriveCommand::Coast;
            Some(State::releasing(0, AfterRelease::Ready))
        } else if *settled >= CALIBRATION_SETTLE {
            let entered = u16::try_from(
                sample
                    .raw_average
                    .to_hundredths_rounded()
                    .clamp(i32::from(ENTRY_MIN), i32::from(ENTRY_MAX)),
            )
            .unwrap_or(ENTRY_MIN);
            Some(State::calibration_entry(*point, entered, 0, 0))
        } else if *elapsed >= PULL_TIMEOUT && *elapsed >= pull_timeout(self.pull_settings().speed())
        {
            Some(State::fault(FaultCode::PullTimeout, Recovery::Home, 0))
        } else {
            None
        };
        Super
    }

    /// Arms the controller for a calibration point.
    #[action]
    fn enter_calibration_pull(&mut self, context: &mut Context, point: &mut u8) {
        let settings = calibration_settings(*point);
        self.controller.start(&settings, PullKind::Main);
        if point_of_reading(*point) == 0 {
            // Each pass starts from home.
            self.begin_pull(context, settings.peak_target(PullKind::Main));
        } else {
            // Keep the watch (the string stays loaded between points); raise the overload
            // threshold to the new target.
            self.peak_target = settings.peak_target(PullKind::Main);
        }
        context.beep = Some(Beep::Click);
    }

    /// Holding point `point`: the operator keys in the reference gauge's reading (Up/Down,
    /// 0.01 kg, shown as `20.04`) and confirms with Start; Function or Preset abort.
    ///
    /// The reading paired with the gauge's is the averaged raw reading over the whole entry
    /// (`sum` over `ticks`), not the one at the moment of Start: the gauge was read at some
    /// moment of the entry, seconds before, and meanwhile the constant pull's stick-slip moves
    /// the tension around the point's target by up to a cogging detent (0.07 kgf on a stiff
    /// string). Against the entry's mean the gauge's moment is off by one sawtooth's deviation;
    /// against the Start's moment by the difference of two.
    #[state(superstate = "tensioned")]
    fn calibration_entry(
        &mut self,
        context: &mut Context,
        event: &Tick,
        point: &mut u8,
        entered: &mut u16,
        sum: &mut i64,
        ticks: &mut u32,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        *sum = sum.saturating_add(i64::from(sample.raw_average.to_bits()));
        *ticks = ticks.saturating_add(1);
        let output = self.controller.step(&Self::measurement(sample, sample.raw));
        context.out.drive = output.command;
        context.out.display = panel::hundredths(i32::from(*entered));
        context.out.leds = Leds { holding: true, ..self.unit_leds() };
        context.next = match sample.key {
            Some(key @ (KeyEvent::Press(Key::Up | Key::Down) | KeyEvent::Repeat(_))) => {
                let stepped = i32::from(*entered).saturating_add(i32::from(key.step()));
                *entered = u16::try_from(stepped.clamp(i32::from(ENTRY_MIN), i32::from(ENTRY_MAX)))
                    .unwrap_or(*entered);
                None
            }
            Some(KeyEvent::Press(Key::Start)) => {
                let raw = entry_average(*sum, *ticks).unwrap_or(sample.raw_average);
                Some(self.confirm_point(context, raw, *point, *entered))
            }
            Some(KeyEvent::Press(Key::Function | Key::Preset)) => {
                context.out.drive = DriveCommand::Coast;
                Some(State::releasing(0, AfterRelease::Ready))
            }
            _ => None,
        };
        Super
    }

    // ───────────────────────────── operation ─────────────────────────────

    /// Ready: the panel shows the set tension (or a settings page) and the keys change it;
    /// Start pulls.
    #[state(superstate = "operational", entry_action = "enter_ready")]
    fn ready(&mut self, context: &mut Context, event: &Tick, view: &mut View) -> Outcome<State> {
        let Tick(sample) = event;
        context.out.leds = self.unit_leds();
        self.idle = if sample.key.is_some() { 0 } else { self.idle.saturating_add(1) };
        if self.dirty && self.idle >= STORE_DELAY {
            self.dirty = false;
            context.out.store = true;
        }
        self.rezero_at_rest(sample);
        self.ready_panel(context, sample, view);
        Super
    }

    /// Entering Ready: the controller idles; the rest for a re-zero starts now.
    #[action]
    fn enter_ready(&mut self) {
        self.controller.stop();
        self.booting = false;
        self.rezero.restart();
    }

    /// Closed-loop pull to the set tension (the controller's profile); any key aborts to
    /// releasing; at tension → holding.
    #[state(superstate = "tensioned", entry_action = "enter_pulling")]
    fn pulling(
        &mut self,
        context: &mut Context,
        event: &Tick,
        elapsed: &mut u32,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        let output = self.controller.step(&Self::measurement(sample, sample.tension));
        context.out.drive = output.command;
        context.expect_motion = taking_up(sample.tension, self.peak_target);
        context.out.leds = Leds { pulling: true, ..self.unit_leds() };
        self.show_working_tension(context, sample);
        let averaged = self.calibration.correct(sample.raw_average);
        self.probe.pulling(sample.steps_average, averaged, self.base_target());
        *elapsed = elapsed.saturating_add(1);
        context.next = if pressed(sample.key) {
            context.out.drive = DriveCommand::Coast;
            Some(State::releasing(0, AfterRelease::Ready))
        } else if output.at_tension {
            self.time_to_tension = *elapsed;
            // Constant pull off in the preferences: the hold starts locked (`LOCK`).
            let locked = !self.record.preferences.constant_pull
                && self.controller.set_constant_pull(false, sample.inputs.drive.steps);
            let message = locked.then_some((HoldMessage::Locked, ADJUST_SHOWN_MS));
            Some(State::holding(Hold { message, ..Hold::AT_TENSION }))
        } else if *elapsed >= PULL_TIMEOUT && *elapsed >= pull_timeout(self.pull_settings().speed())
        {
            Some(State::fault(FaultCode::PullTimeout, Recovery::Home, 0))
        } else {
            None
        };
        Super
    }

    /// Arms the controller with the operator's settings.
    #[action]
    fn enter_pulling(&mut self, context: &mut Context) {
        let kind = if self.knot_mode { PullKind::Knot } else { PullKind::Main };
        let settings = self.pull_settings();
        self.controller.start(&settings, kind);
        self.begin_pull(context, settings.peak_target(kind));
    }

    /// Constant pull at the set tension (the beeper sounds on arrival). Start releases and
    /// logs the pull; Up/Down move the held target by the unit's fine step
    /// ([`hold_adjustment`]; the new target shows for [`ADJUST_SHOWN_MS`], and one that would
    /// leave the tension range is refused with the refusal tones); Function switches constant
    /// pull off for this hold (`LOCK`: the carriage stays where it is and the string may
    /// creep) and on again (`PULL`); Preset switches the digits between the live tension and
    /// the tension timer (`t1.05`: time since the tension was reached); any other key (a
    /// long press) does nothing — no surprise release.
    #[state(superstate = "tensioned", entry_action = "enter_holding")]
    fn holding(&mut self, context: &mut Context, event: &Tick, hold: &mut Hold) -> Outcome<State> {
        let Tick(sample) = event;
        let output = self.controller.step(&Self::measurement(sample, sample.tension));
        context.out.drive = output.command;
        context.out.leds = Leds { holding: true, ..self.unit_leds() };
        hold.held_ms = hold.held_ms.saturating_add(1);
        self.probe.holding(sample.inputs.drive.steps, hold.held_ms);
        let unit = self.record.settings.set_point().unit();
        match sample.key {
            Some(KeyEvent::Press(Key::Start)) => {
                let record = self.pull_record(sample, hold);
                let counters = &mut self.record.counters;
                counters.pulls = counters.pulls.saturating_add(1);
                counters.string_used_mm =
                    counters.string_used_mm.saturating_add(string_mm(self.string_counts));
                self.dirty = true;
                context.completed = Some(record);
                context.out.drive = DriveCommand::Coast;
                context.next = Some(State::releasing(0, AfterRelease::Ready));
            }
            Some(key) if key.step() != 0 => {
                match hold_adjustment(self.base_target(), unit, hold.adjust, key.step()) {
                    Some((adjust, target)) if self.controller.retarget(target) => {
                        hold.adjust = adjust;
                        hold.message = Some((HoldMessage::Target, ADJUST_SHOWN_MS));
                        self.probe.hold_changed(hold.held_ms);
                    }
                    _ => {
                        if pressed(sample.key) {
                            context.beep = Some(Beep::Refused);
                        }
                    }
                }
            }
            Some(KeyEvent::Press(Key::Function)) => {
                let on = !self.controller.constant_pull();
                if self.controller.set_constant_pull(on, sample.inputs.drive.steps) {
                    let message = if on { HoldMessage::ConstantPull } else { HoldMessage::Locked };
                    hold.message = Some((message, ADJUST_SHOWN_MS));
                    self.probe.hold_changed(hold.held_ms);
                } else {
                    context.beep = Some(Beep::Refused);
                }
            }
            Some(KeyEvent::Press(Key::Preset)) => {
                hold.timer = !hold.timer;
                hold.message = None;
                self.shown.1 = u16::MAX;
            }
            _ => {}
        }
        self.hold_panel(context, sample, hold, unit);
        Super
    }

    /// At tension.
    #[action]
    fn enter_holding(&mut self, context: &mut Context) {
        context.beep = Some(Beep::AtTension);
    }

    /// Reverse to the home limit at the controller's bounded release speed, then go on.
    #[state(superstate = "motion", entry_action = "enter_releasing")]
    fn releasing(
        &mut self,
        context: &mut Context,
        event: &Tick,
        elapsed: &mut u32,
        then: &mut AfterRelease,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        match then {
            AfterRelease::CalibrationWindow => context.out.display = panel::text(b"HOnE"),
            AfterRelease::Ready | AfterRelease::NextPass => {
                self.show_working_tension(context, sample);
            }
        }
        context.out.leds = self.unit_leds();
        *elapsed = elapsed.saturating_add(1);
        context.next = if sample.inputs.limits.home {
            Some(match then {
                AfterRelease::CalibrationWindow => State::calibration_window(0),
                AfterRelease::Ready => State::ready(View::Tension),
                AfterRelease::NextPass => State::calibration_pull(
                    u8::try_from(CALIBRATION_POINTS).unwrap_or(u8::MAX),
                    0,
                    0,
                ),
            })
        } else if *elapsed >= RELEASE_TIMEOUT {
            Some(State::fault(FaultCode::ReleaseTimeout, self.recovery(), 0))
        } else {
            let release = self.controller.step(&Self::measurement(sample, sample.tension)).command;
            context.out.drive = match (then, release) {
                // REQ-TEN-21: the homing after the motor test slows onto the switch from the
                // count the test started at (the controller's release), string-free, so never
                // below the test's own duty, which has just moved this drivetrain out: a worn
                // one that the creep speed's duty would stall still comes home.
                (
                    AfterRelease::CalibrationWindow,
                    DriveCommand::Drive { direction: Direction::Release, duty },
                ) => DriveCommand::Drive {
                    direction: Direction::Release,
                    duty: duty.max(MOTOR_TEST_DUTY),
                },
                (_, release) => release,
            };
            context.expect_motion = true;
            None
        };
        Super
    }

    /// Start the release move.
    #[action]
    fn enter_releasing(&mut self) {
        self.controller.release();
    }

    // ───────────────────────────── fault ─────────────────────────────

    /// A latched fault: coast, show `E-nn`; Start (with the drive command zeroed and the
    /// cause gone) asks the drive to clear for up to [`CLEAR_ATTEMPT`] ticks, then recovers.
    #[state(entry_action = "enter_fault")]
    fn fault(
        &mut self,
        context: &mut Context,
        event: &Tick,
        code: &mut FaultCode,
        recovery: &mut Recovery,
        clearing: &mut u16,
    ) -> Outcome<State> {
        let Tick(sample) = event;
        self.resuming = false;
        context.out.drive = DriveCommand::Coast;
        context.out.display = panel::fault(code.number());
        context.out.leds = Leds { fault: true, ..self.unit_leds() };
        let persists = fault_persists(*code, &sample.inputs);
        if *clearing > 0 {
            context.out.clear_drive_fault = true;
            *clearing = clearing.saturating_sub(1);
            if sample.inputs.drive.fault.is_none() && !persists {
                return Transition(match recovery {
                    Recovery::SelfTest => State::self_test(0, 0),
                    Recovery::Home => State::releasing(0, AfterRelease::Ready),
                });
            }
            if *clearing == 0 {
                context.beep = Some(Beep::Refused);
            }
        } else if sample.key == Some(KeyEvent::Press(Key::Start)) {
            if persists {
                context.beep = Some(Beep::Refused);
            } else {
                context.out.clear_drive_fault = true;
                *clearing = CLEAR_ATTEMPT;
            }
        }
        Handled
    }

    /// Entering a fault: coast, show the code, stop the controller, sound the fault pattern.
    #[action]
    fn enter_fault(&mut self, context: &mut Context, code: &mut FaultCode) {
        context.out.drive = DriveCommand::Coast;
        let (inputs, tension) = (&context.sample.inputs, context.sample.tension);
        let latch = Latch::of(*code, context.prior, inputs, tension, self.record.counters.boots);
        self.record.push_fault(FaultSnapshot::capture(&latch));
        context.out.store = true;
        context.out.display = panel::fault(code.number());
        context.out.leds = Leds { fault: true, ..self.unit_leds() };
        context.next = None;
        self.controller.stop();
        context.beep = Some(Beep::Fault);
    }
}

/// Whether a fault cannot clear now: its own cause, or both limits, is still visible in
/// `inputs`. A latched drive
/// fault is cleared by the drive itself when asked with the command at coast, so the fault
/// state keeps asking while it waits for it.
#[must_use]
pub fn fault_persists(code: FaultCode, inputs: &Inputs) -> bool {
    let own = match code {
        FaultCode::LoadCellOpen | FaultCode::LoadCellShort => {
            safety::load_cell_rail(inputs.load_cell) == Some(code)
        }
        _ => false,
    };
    own || inputs.limits.both()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::{SetPoint, Settings};

    #[test]
    fn the_pull_time_limit_covers_the_travel_at_the_set_speed() {
        let limits: [u32; 9] = core::array::from_fn(|i| {
            let Ok(speed) = Speed::new(u8::try_from(i + 1).unwrap_or(1)) else { panic!("{i}") };
            pull_timeout(speed)
        });
        // 400 mm at 9·n mm/s + 20 s, never below 40 s.
        assert_eq!(
            limits,
            [64_444, 42_222, 40_000, 40_000, 40_000, 40_000, 40_000, 40_000, 40_000]
        );
    }

    #[test]
    fn every_valid_setting_converts_to_pull_settings() {
        let mut cases = 0u32;
        for unit in [Unit::Kilograms, Unit::Pounds] {
            for tenths in 0..=1_200u16 {
                let Ok(point) = SetPoint::new(unit, tenths) else { continue };
                for speed in 1..=9u8 {
                    for pre in (0..=30u8).step_by(5) {
                        for knot in (0..=20u8).step_by(5) {
                            let Ok(settings) = Settings::new(point, speed, pre, knot) else {
                                panic!("{point:?} {speed} {pre} {knot} must be valid")
                            };
                            let pull = settings.pull();
                            assert_eq!(pull.tension(), point.to_kgf());
                            assert_eq!(pull.speed().get(), speed);
                            assert_eq!(pull.pre_stretch().percent(), pre);
                            assert_eq!(pull.knot().percent(), knot);
                            cases += 1;
                        }
                    }
                }
            }
        }
        assert!(cases > 200_000, "{cases}");
    }
}

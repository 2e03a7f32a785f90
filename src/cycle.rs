//! The main job: one whole machine cycle on the digital twin, worked through the front
//! panel's keys by a simulated operator.
//!
//! # Theory of operation
//!
//! **The machine is the firmware's.** A [`Bench`] wires [`taut_core::machine::Machine`] — the
//! very state machine, controller and safety rules the firmware links — to a
//! [`taut_sim::Twin`] exactly as the board's 1 kHz tick does: sample the twin's raw
//! [`taut_core::io::Inputs`], tick the machine, apply its [`Outputs`] (drive command, display,
//! LEDs, beeper), persist the record whenever the machine raises `Outputs::store` (a
//! simulated flash holding the encoded bytes), then let one millisecond of physics pass.
//!
//! **The operator only presses keys.** An [`Operator`] stands in front of the twin. It
//! reads what a person reads — the 7-segment digits (decoded from the segment bitmaps by
//! [`crate::panel::display`]), the LEDs, whether the carriage has come to rest at home, and
//! the reference gauge during a calibration — and its only action is pressing keys through
//! the twin's key API (taps of 80 ms with 200 ms between, or holding Up/Down to use the
//! panel's own repeat). It never looks at the machine's state: every state change of the
//! cycle — self-test, motor test, homing, pulling, "at tension", holding, releasing, home,
//! and any fault — is decided by the machine. A fault lamp makes the operator stop.
//!
//! **Two sessions, one flash.** [`commission`] powers a new machine up with factory
//! defaults and a test string ([`factory_config`]), has the operator run the paper's 4-point
//! calibration in the calibration window (Function; at each point the machine pulls by its
//! raw reading, the operator reads the reference gauge and keys the value in) and then leave
//! the previous job's settings
//! ([`previous_job`]: 22.0 kg, speed 3) on the panel, and keeps the flash bytes the machine
//! stored. [`run`] then powers the twin up again from those bytes — as the next morning —
//! and works the job: boot self-test, skip the calibration window (Start), optionally
//! toggle knot mode (Function held), walk the settings menu with Function (speed,
//! pre-stretch, knot %, unit) setting each page with Up/Down, key the tension on the
//! tension page, press Start, wait for the holding lamp, hold for the set time while the
//! string creeps, press Start to release, and wait for the carriage to come home.
//!
//! **Figures.** Every tick of the job is recorded as a [`Row`] (true tension from the twin,
//! the panel's reading, carriage, duty, current, machine state); [`CycleRun::summary`]
//! turns the rows into the [`Summary`] (time to tension, overshoot, hold error, creep,
//! string used, peak current, faults), [`CycleRun::figure_svg`] into the plot with the
//! machine-state timeline under it.

use std::fmt;
use std::fmt::Write as _;
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use taut_core::drive::Direction;
use taut_core::drive::duty::DUTY_ONE;
use taut_core::io::{Display, Key, Keys, Leds, Outputs};
use taut_core::machine::panel::text as panel_text;
use taut_core::machine::{FaultCode, Machine, MachineState, PullRecord, to_pull_settings};
use taut_core::store::{RECORD_LEN, Record, SetPoint, Settings, Unit};
use taut_core::tension::PullKind;
use taut_core::units::Kgf;
use taut_sim::{StringKind, Twin, TwinConfig};

use crate::panel::display;
use crate::plot::{Figure, Panel, Series};

/// How long the operator holds a key for a tap, ms (the panel debounces for 20 ms).
pub const TAP_MS: u64 = 80;
/// How long the operator waits after letting go of a key before looking again, ms.
pub const PAUSE_MS: u64 = 200;
/// How long the operator looks at the reference gauge before keying its reading in, ms.
pub const GAUGE_READ_MS: u64 = 800;
/// Up/Down further than this many steps from the wanted value: hold the key (the panel
/// repeats) instead of tapping.
pub const HOLD_ABOVE_STEPS: i32 = 8;
/// A held Up/Down is let go this many steps before the wanted value (then taps finish).
pub const RELEASE_WITHIN_STEPS: i32 = 2;
/// The carriage must rest at home this long before the operator counts it as home, ms.
pub const HOME_REST_MS: u64 = 300;
/// Default hold time of the job, ms: a few seconds of constant pull while the string creeps.
pub const DEFAULT_HOLD_MS: u32 = 5_000;
/// The longest a session may take, simulated ms; past it the run stops as incomplete.
pub const SESSION_LIMIT_MS: u64 = 240_000;
/// Band of the true-tension settling criterion, kgf (the paper's 0.1 kgw accuracy).
pub const SETTLE_BAND_KGF: f64 = 0.1;
/// How long the true tension must stay in the band to count as settled, ms.
pub const SETTLE_FOR_MS: u64 = 500;
/// The hold error is measured from this long after the holding lamp lit, ms.
pub const HOLD_ERROR_FROM_MS: u64 = 1_000;

/// The settings the previous job left on the machine (the commissioning session keys them
/// in): 22.0 kg, speed 3, no pre-stretch, no knot increase.
#[must_use]
pub fn previous_job() -> Settings {
    let set_point = SetPoint::new(Unit::Kilograms, 220).expect("22.0 kg is a valid set point");
    Settings::new(set_point, 3, 0, 0).expect("valid previous-job settings")
}

// ───────────────────────────── options ─────────────────────────────

/// Why a main-job option was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum OptionError {
    /// The tension is not a number with an optional `kg`/`lb` unit.
    TensionSyntax,
    /// The tension is outside 5.0–50.0 kg (11.5–110.0 lb) or off the unit's step (0.1 kg,
    /// 0.5 lb).
    TensionOutOfRange,
    /// The speed is not 1–9.
    Speed,
    /// The pre-stretch is not 0–30 % in steps of 5.
    PreStretch,
    /// The knot increase is not 0–20 % in steps of 5.
    Knot,
    /// The hold time is not 0–120 s.
    Hold,
}

impl fmt::Display for OptionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::TensionSyntax => "tension: a number with an optional unit, e.g. 25, 25kg, 55lb",
            Self::TensionOutOfRange => {
                "tension: 5.0–50.0 kg in 0.1 kg steps, or 11.5–110.0 lb in 0.5 lb steps"
            }
            Self::Speed => "speed: 1–9",
            Self::PreStretch => "pre-stretch: 0–30 % in steps of 5",
            Self::Knot => "knot: 0–20 % in steps of 5",
            Self::Hold => "hold: 0–120 s",
        })
    }
}

impl std::error::Error for OptionError {}

/// A tension as the operator keys it: `25`, `25.5`, `25kg`, `55 lb` (kilograms unless `lb`).
///
/// # Errors
/// [`OptionError::TensionSyntax`] or [`OptionError::TensionOutOfRange`].
pub fn parse_tension(text: &str) -> Result<SetPoint, OptionError> {
    let lower = text.trim().to_ascii_lowercase();
    let (number, unit) = if let Some(n) = lower.strip_suffix("lbs").or(lower.strip_suffix("lb")) {
        (n, Unit::Pounds)
    } else if let Some(n) = lower.strip_suffix("kgf").or(lower.strip_suffix("kg")) {
        (n, Unit::Kilograms)
    } else {
        (lower.as_str(), Unit::Kilograms)
    };
    let value: f64 = number.trim().parse().map_err(|_| OptionError::TensionSyntax)?;
    if !(0.0..=1_000.0).contains(&value) {
        return Err(OptionError::TensionOutOfRange);
    }
    let tenths = (value * 10.0).round();
    if (value * 10.0 - tenths).abs() > 1e-6 {
        return Err(OptionError::TensionOutOfRange);
    }
    SetPoint::new(unit, tenths as u16).map_err(|_| OptionError::TensionOutOfRange)
}

/// What the main job does: the operator's settings, the machine's string and scenario, how
/// long to hold.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct CycleOptions {
    /// The tension to set, in the unit the operator keys it in.
    pub set_point: SetPoint,
    /// The string on the machine.
    pub string: StringKind,
    /// Speed setting, 1–9.
    pub speed: u8,
    /// Pre-stretch, percent (0–30, steps of 5).
    pub pre_stretch_percent: u8,
    /// `Some(p)`: a knot pull with the knot increase set to `p` % (0–20, steps of 5).
    pub knot_percent: Option<u8>,
    /// A Monte-Carlo scenario of the twin (`TwinConfig::sample_kind`) instead of the
    /// nominal machine.
    pub seed: Option<u64>,
    /// How long the operator lets the machine hold before releasing, ms.
    pub hold_ms: u32,
    /// Whether the commissioning session calibrates the load cell (otherwise the machine
    /// runs on the uncorrected, tared sensor).
    pub calibrate: bool,
}

impl Default for CycleOptions {
    fn default() -> Self {
        Self {
            set_point: SetPoint::DEFAULT,
            string: StringKind::TennisSynthetic,
            speed: 5,
            pre_stretch_percent: 0,
            knot_percent: None,
            seed: None,
            hold_ms: DEFAULT_HOLD_MS,
            calibrate: true,
        }
    }
}

impl CycleOptions {
    /// The panel settings the operator will key in.
    ///
    /// # Errors
    /// The first option out of range.
    pub fn settings(&self) -> Result<Settings, OptionError> {
        if !(1..=Settings::SPEED_MAX).contains(&self.speed) {
            return Err(OptionError::Speed);
        }
        if self.pre_stretch_percent > Settings::PRE_STRETCH_MAX
            || self.pre_stretch_percent % Settings::PRE_STRETCH_STEP != 0
        {
            return Err(OptionError::PreStretch);
        }
        let knot = self.knot_percent.unwrap_or(0);
        if knot > Settings::KNOT_MAX || knot % Settings::KNOT_STEP != 0 {
            return Err(OptionError::Knot);
        }
        Settings::new(self.set_point, self.speed, self.pre_stretch_percent, knot)
            .map_err(|_| OptionError::TensionOutOfRange)
    }

    /// The twin's configuration: nominal, or the Monte-Carlo scenario of [`Self::seed`].
    #[must_use]
    pub fn twin_config(&self) -> TwinConfig {
        self.seed.map_or_else(
            || TwinConfig::nominal(self.string),
            |seed| TwinConfig::sample_kind(self.string, seed),
        )
    }

    /// The kind of pull the job makes.
    #[must_use]
    pub const fn pull_kind(&self) -> PullKind {
        if self.knot_percent.is_some() { PullKind::Knot } else { PullKind::Main }
    }
}

// ───────────────────────────── the bench ─────────────────────────────

/// The machine on the twin, wired as the firmware wires the board (see the module docs).
pub struct Bench {
    machine: Machine,
    twin: Twin,
    flash: [u8; RECORD_LEN],
    store_writes: u32,
}

impl Bench {
    /// Powers the twin and the machine up; the machine loads its record from `flash` as the
    /// firmware does (a corrupt or blank flash gives defaults and the `E-20` notice).
    #[must_use]
    pub fn power_up(config: &TwinConfig, flash: &[u8; RECORD_LEN]) -> Self {
        Self {
            machine: Machine::from_stored(Record::decode(flash)),
            twin: Twin::new(config),
            flash: *flash,
            store_writes: 0,
        }
    }

    /// One 1 ms tick: sample the twin, tick the machine, apply its outputs and persist the
    /// record if asked; then `operator` may look at the twin and press keys (seen from the
    /// next tick on, as a key read live by the firmware); then one millisecond of physics.
    pub fn tick(&mut self, operator: impl FnOnce(&mut Twin)) -> Outputs {
        let inputs = self.twin.inputs();
        let outputs = self.machine.tick(&inputs);
        self.twin.apply(&outputs);
        if outputs.store {
            self.flash = self.machine.record().encode();
            self.store_writes = self.store_writes.saturating_add(1);
        }
        operator(&mut self.twin);
        self.twin.advance_tick();
        outputs
    }

    /// The machine (read-only: only keys and physics change it).
    #[must_use]
    pub const fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The twin.
    #[must_use]
    pub const fn twin(&self) -> &Twin {
        &self.twin
    }

    /// The twin, to press keys, inject faults or read the reference gauge.
    pub fn twin_mut(&mut self) -> &mut Twin {
        &mut self.twin
    }

    /// The simulated flash: the last record the machine asked to store (or what it booted
    /// from).
    #[must_use]
    pub const fn flash(&self) -> &[u8; RECORD_LEN] {
        &self.flash
    }

    /// How many times the machine asked to store its record since power-up.
    #[must_use]
    pub const fn store_writes(&self) -> u32 {
        self.store_writes
    }
}

// ───────────────────────────── the operator ─────────────────────────────

/// A page of the Ready panel, as the operator recognises it on the display.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Page {
    /// The tension set point (`25.0`).
    Tension,
    /// `SP n`.
    Speed,
    /// `PSnn`.
    PreStretch,
    /// `Knnn`.
    Knot,
    /// ` kg ` / ` lb `.
    Unit,
}

impl Page {
    /// The page after this one in the order the operator walks the menu.
    const fn next(self) -> Self {
        match self {
            Self::Speed => Self::PreStretch,
            Self::PreStretch => Self::Knot,
            Self::Knot => Self::Unit,
            Self::Unit | Self::Tension => Self::Tension,
        }
    }
}

/// The page the display shows and its value (tenths of the unit for the tension; percent,
/// speed; 0 = kg, 1 = lb for the unit).
#[must_use]
pub fn page_shown(display: &Display) -> Option<(Page, i32)> {
    if let Some(tenths) = display::tenths(display) {
        return Some((Page::Tension, tenths));
    }
    let labelled = [(Page::Speed, b"SP"), (Page::PreStretch, b"PS"), (Page::Knot, b"Kn")];
    for (page, label) in labelled {
        if let Some(value) = display::page_value(display, label) {
            return Some((page, i32::from(value)));
        }
    }
    if *display == panel_text(b" kg ") {
        return Some((Page::Unit, 0));
    }
    if *display == panel_text(b" lb ") {
        return Some((Page::Unit, 1));
    }
    None
}

/// What the operator sets out to do in one session.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Plan {
    /// Calibrate in the calibration window (else skip it with Start).
    pub calibrate: bool,
    /// The settings to leave on the panel.
    pub settings: Settings,
    /// Knot mode (the knot lamp) wanted.
    pub knot_mode: bool,
    /// `Some(ms)`: pull, hold this long, release. `None`: only set up the panel.
    pub pull_hold_ms: Option<u32>,
}

/// Where the operator is in the plan.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Step {
    /// Waiting for `CAL?` after the boot sequence.
    AwaitCalibrationWindow,
    /// Waiting for the machine to ask for calibration point `point`'s reference value.
    AwaitReferenceRequest { point: u8 },
    /// Looking at the gauge since `since`.
    ReadGauge { point: u8, since: u64 },
    /// Keying `tenths` in for point `point`.
    KeyReference { point: u8, tenths: i32 },
    /// Waiting for the carriage to rest at home after the calibration.
    AwaitHomeAfterCalibration { since: Option<u64> },
    /// Toggling knot mode by holding Function.
    KnotMode,
    /// Walking the settings menu towards `page`.
    Menu { page: Page },
    /// Settings are on the panel: press Start.
    Start,
    /// Waiting for the holding lamp.
    AwaitTension,
    /// Holding since `since`.
    Hold { since: u64 },
    /// Waiting for the carriage to rest at home after the release.
    AwaitHome { since: Option<u64> },
    /// The plan is done.
    Done,
    /// The fault lamp lit: the operator stopped.
    Stopped,
}

/// The simulated operator (see the module docs).
#[derive(Clone, Debug)]
pub struct Operator {
    plan: Plan,
    step: Step,
    busy_until: u64,
    held: Option<Key>,
    presses: u32,
    gauge_readings: Vec<f64>,
}

impl Operator {
    /// An operator about to work `plan` on a machine that is powering up.
    #[must_use]
    pub const fn new(plan: Plan) -> Self {
        Self {
            plan,
            step: Step::AwaitCalibrationWindow,
            busy_until: 0,
            held: None,
            presses: 0,
            gauge_readings: Vec::new(),
        }
    }

    /// Whether the plan is finished (or abandoned at a fault).
    #[must_use]
    pub const fn finished(&self) -> bool {
        matches!(self.step, Step::Done | Step::Stopped)
    }

    /// Whether the operator stopped at a fault lamp.
    #[must_use]
    pub const fn stopped(&self) -> bool {
        matches!(self.step, Step::Stopped)
    }

    /// Key presses so far (a hold counts once).
    #[must_use]
    pub const fn presses(&self) -> u32 {
        self.presses
    }

    /// The reference gauge readings keyed in, kgf, one per calibration point.
    #[must_use]
    pub fn gauge_readings(&self) -> &[f64] {
        &self.gauge_readings
    }

    /// What the operator is doing, for progress lines.
    #[must_use]
    pub const fn activity(&self) -> &'static str {
        match self.step {
            Step::AwaitCalibrationWindow => "waiting for the self-test",
            Step::AwaitReferenceRequest { .. } => "calibrating: machine pulls",
            Step::ReadGauge { .. } => "calibrating: reading the gauge",
            Step::KeyReference { .. } => "calibrating: keying the reference",
            Step::AwaitHomeAfterCalibration { .. } | Step::AwaitHome { .. } => {
                "waiting for the carriage"
            }
            Step::KnotMode => "switching knot mode",
            Step::Menu { page: Page::Speed } => "setting the speed",
            Step::Menu { page: Page::PreStretch } => "setting the pre-stretch",
            Step::Menu { page: Page::Knot } => "setting the knot increase",
            Step::Menu { page: Page::Unit } => "setting the unit",
            Step::Menu { page: Page::Tension } => "setting the tension",
            Step::Start => "pressing Start",
            Step::AwaitTension => "machine pulls",
            Step::Hold { .. } => "machine holds",
            Step::Done => "done",
            Step::Stopped => "stopped at a fault",
        }
    }

    fn tap(&mut self, twin: &mut Twin, key: Key) {
        twin.press(Keys::NONE.with(key), TAP_MS);
        self.busy_until = twin.now_ms() + TAP_MS + PAUSE_MS;
        self.presses += 1;
    }

    fn hold(&mut self, twin: &mut Twin, key: Key) {
        twin.set_keys(Keys::NONE.with(key));
        self.held = Some(key);
        self.presses += 1;
    }

    fn let_go(&mut self, twin: &mut Twin) {
        twin.set_keys(Keys::NONE);
        self.held = None;
        self.busy_until = twin.now_ms() + PAUSE_MS;
    }

    /// Moves a value shown as `shown` towards `wanted` in steps of `step` with Up/Down:
    /// taps when close, holds the key when far. Returns `true` once it shows `wanted` with
    /// no key down.
    fn adjust(&mut self, twin: &mut Twin, shown: i32, wanted: i32, step: i32) -> bool {
        let diff = wanted - shown;
        let key = if diff > 0 { Key::Up } else { Key::Down };
        let steps = (diff.abs() + step - 1) / step.max(1);
        if let Some(held) = self.held {
            if diff == 0 || held != key || steps <= RELEASE_WITHIN_STEPS {
                self.let_go(twin);
            }
            return false;
        }
        if diff == 0 {
            return true;
        }
        if steps > HOLD_ABOVE_STEPS {
            self.hold(twin, key);
        } else {
            self.tap(twin, key);
        }
        false
    }

    /// Whether the carriage rests at home with no motion lamp lit, for [`HOME_REST_MS`]
    /// since `since` (updated).
    fn at_rest_home(twin: &Twin, since: &mut Option<u64>) -> bool {
        let truth = twin.truth();
        let leds = twin.outputs().leds;
        let resting = truth.limits.home
            && truth.carriage_mm_per_s.abs() < 0.5
            && !leds.pulling
            && !leds.holding;
        if !resting {
            *since = None;
            return false;
        }
        let start = *since.get_or_insert(twin.now_ms());
        twin.now_ms() >= start + HOME_REST_MS
    }

    /// The step after the panel is set up (or the calibration is done).
    const fn after_menu(&self) -> Step {
        if self.plan.pull_hold_ms.is_some() { Step::Start } else { Step::Done }
    }

    /// Looks at the machine and maybe presses a key. Called once per tick.
    pub fn act(&mut self, twin: &mut Twin) {
        let now = twin.now_ms();
        let outputs = *twin.outputs();
        if outputs.leds.fault && !self.finished() {
            if self.held.is_some() {
                self.let_go(twin);
            }
            self.step = Step::Stopped;
            return;
        }
        if self.held.is_none() && now < self.busy_until {
            return;
        }
        let shown = outputs.display;
        self.step = match self.step {
            Step::AwaitCalibrationWindow => {
                if shown == panel_text(b"CAL?") {
                    if self.plan.calibrate {
                        self.tap(twin, Key::Function);
                        Step::AwaitReferenceRequest { point: 0 }
                    } else {
                        self.tap(twin, Key::Start);
                        self.setup_step(&outputs)
                    }
                } else {
                    self.step
                }
            }
            Step::AwaitReferenceRequest { point } => {
                // The machine shows the value to confirm (a number) with only the holding
                // lamp once the point has settled; while pulling it shows `CALn`.
                if display::tenths(&shown).is_some()
                    && outputs.leds.holding
                    && !outputs.leds.pulling
                {
                    Step::ReadGauge { point, since: now }
                } else {
                    self.step
                }
            }
            Step::ReadGauge { point, since } => {
                if now >= since + GAUGE_READ_MS {
                    let gauge = twin.reference_gauge();
                    self.gauge_readings.push(gauge);
                    let tenths = ((gauge * 10.0).round() as i32).clamp(50, 550);
                    Step::KeyReference { point, tenths }
                } else {
                    self.step
                }
            }
            Step::KeyReference { point, tenths } => match display::tenths(&shown) {
                Some(value) => {
                    if self.adjust(twin, value, tenths, 1) {
                        self.tap(twin, Key::Start);
                        if point >= 3 {
                            Step::AwaitHomeAfterCalibration { since: None }
                        } else {
                            Step::AwaitReferenceRequest { point: point + 1 }
                        }
                    } else {
                        self.step
                    }
                }
                None => self.step,
            },
            Step::AwaitHomeAfterCalibration { mut since } => {
                if Self::at_rest_home(twin, &mut since) {
                    self.setup_step(&outputs)
                } else {
                    Step::AwaitHomeAfterCalibration { since }
                }
            }
            Step::KnotMode => {
                if outputs.leds.knot == self.plan.knot_mode {
                    if self.held.is_some() {
                        self.let_go(twin);
                    }
                    Step::Menu { page: Page::Speed }
                } else {
                    if self.held.is_none() {
                        self.hold(twin, Key::Function);
                    }
                    self.step
                }
            }
            Step::Menu { page } => self.menu(twin, &shown, page),
            Step::Start => {
                self.tap(twin, Key::Start);
                Step::AwaitTension
            }
            Step::AwaitTension => {
                if outputs.leds.holding {
                    Step::Hold { since: now }
                } else {
                    self.step
                }
            }
            Step::Hold { since } => {
                let hold_ms = u64::from(self.plan.pull_hold_ms.unwrap_or(0));
                if now >= since + hold_ms {
                    self.tap(twin, Key::Start);
                    Step::AwaitHome { since: None }
                } else {
                    self.step
                }
            }
            Step::AwaitHome { mut since } => {
                if Self::at_rest_home(twin, &mut since) {
                    Step::Done
                } else {
                    Step::AwaitHome { since }
                }
            }
            Step::Done | Step::Stopped => self.step,
        };
    }

    /// The first step of setting up the panel in Ready.
    fn setup_step(&self, outputs: &Outputs) -> Step {
        if outputs.leds.knot == self.plan.knot_mode {
            Step::Menu { page: Page::Speed }
        } else {
            Step::KnotMode
        }
    }

    /// One look at the menu while heading for `page`.
    fn menu(&mut self, twin: &mut Twin, shown: &Display, page: Page) -> Step {
        let leds = twin.outputs().leds;
        // A notice (`E-nn` without the fault lamp) goes away with any key.
        if display::text(shown).starts_with("E-") && !leds.fault {
            self.tap(twin, Key::Down);
            return Step::Menu { page };
        }
        let settings = self.plan.settings;
        let Some((on, value)) = page_shown(shown) else {
            if self.held.is_some() {
                self.let_go(twin);
            }
            self.tap(twin, Key::Function);
            return Step::Menu { page };
        };
        if on != page {
            if self.held.is_some() {
                self.let_go(twin);
                return Step::Menu { page };
            }
            self.tap(twin, Key::Function);
            return Step::Menu { page };
        }
        let set_point = settings.set_point();
        let done = match page {
            Page::Speed => self.adjust(twin, value, i32::from(settings.speed()), 1),
            Page::PreStretch => self.adjust(
                twin,
                value,
                i32::from(settings.pre_stretch_percent()),
                i32::from(Settings::PRE_STRETCH_STEP),
            ),
            Page::Knot => self.adjust(
                twin,
                value,
                i32::from(settings.knot_percent()),
                i32::from(Settings::KNOT_STEP),
            ),
            Page::Unit => {
                let wanted = i32::from(set_point.unit() == Unit::Pounds);
                if value == wanted {
                    true
                } else {
                    // Up (or Down) on the unit page converts the set point.
                    self.tap(twin, Key::Up);
                    false
                }
            }
            Page::Tension => self.adjust(
                twin,
                value,
                i32::from(set_point.tenths()),
                i32::from(set_point.unit().step_tenths()),
            ),
        };
        if !done {
            return Step::Menu { page };
        }
        if page == Page::Tension {
            return self.after_menu();
        }
        self.tap(twin, Key::Function);
        Step::Menu { page: page.next() }
    }
}

// ───────────────────────────── sessions ─────────────────────────────

/// Why a session could not be completed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum CycleError {
    /// The options are invalid.
    Options(OptionError),
    /// The machine latched a fault during commissioning.
    CommissioningFault(FaultCode),
    /// The machine rejected the calibration (`E-21`).
    CalibrationRejected,
    /// Commissioning ended without the machine storing the settings and calibration.
    NothingStored,
    /// A session did not finish within [`SESSION_LIMIT_MS`].
    Timeout,
}

impl fmt::Display for CycleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Options(error) => write!(f, "{error}"),
            Self::CommissioningFault(code) => {
                write!(f, "the machine faulted during commissioning: E-{:02}", code.number())
            }
            Self::CalibrationRejected => f.write_str("the machine rejected the calibration (E-21)"),
            Self::NothingStored => f.write_str("commissioning ended without a stored record"),
            Self::Timeout => f.write_str("a session did not finish in the simulated time limit"),
        }
    }
}

impl std::error::Error for CycleError {}

/// Which session a progress report is from.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Session {
    /// Calibration and previous-job settings on a new machine.
    Commissioning,
    /// The job.
    Job,
}

/// A progress report, every 50 simulated ms and at every state change.
#[derive(Clone, Copy, Debug)]
pub struct Progress<'a> {
    /// The session.
    pub session: Session,
    /// Simulated time since the session's power-up, s.
    pub time_s: f64,
    /// The machine's state.
    pub state: MachineState,
    /// The display.
    pub display: Display,
    /// True tension, kgf.
    pub tension_kgf: f64,
    /// What the operator is doing.
    pub activity: &'a str,
    /// Whether the state changed on this tick.
    pub state_changed: bool,
}

/// The result of [`commission`].
#[derive(Clone, Debug)]
pub struct Commissioning {
    /// The flash contents the machine left.
    pub flash: [u8; RECORD_LEN],
    /// The stored record.
    pub record: Record,
    /// The reference gauge readings the operator keyed in, kgf.
    pub gauge_readings: Vec<f64>,
    /// Simulated length of the session, ms.
    pub sim_ms: u64,
    /// Key presses.
    pub presses: u32,
}

fn report(
    progress: &mut dyn FnMut(&Progress<'_>),
    session: Session,
    bench: &Bench,
    operator: &Operator,
    state_changed: bool,
) {
    progress(&Progress {
        session,
        time_s: bench.twin().now_ms() as f64 / 1_000.0,
        state: bench.machine().state(),
        display: bench.twin().outputs().display,
        tension_kgf: bench.twin().truth().tension_kgf,
        activity: operator.activity(),
        state_changed,
    });
}

/// Runs `bench` with `operator` until `done` or the time limit, reporting progress.
fn drive(
    bench: &mut Bench,
    operator: &mut Operator,
    session: Session,
    progress: &mut dyn FnMut(&Progress<'_>),
    mut each_tick: impl FnMut(&Bench, &Outputs),
    mut done: impl FnMut(&Bench, &Operator) -> bool,
) -> Result<(), CycleError> {
    let mut last_state = bench.machine().state();
    // A state's first display is written on the tick after it is entered: a state change
    // is reported one tick late, with its own display.
    let mut changed = false;
    for tick in 0..SESSION_LIMIT_MS {
        let outputs = bench.tick(|twin| operator.act(twin));
        each_tick(bench, &outputs);
        if changed || tick % 50 == 0 {
            report(progress, session, bench, operator, changed);
        }
        let state = bench.machine().state();
        changed = state != last_state;
        last_state = state;
        if done(bench, operator) {
            return Ok(());
        }
    }
    Err(CycleError::Timeout)
}

/// The string the commissioning calibrates with: the machine's own load cell, motor and
/// mechanics (all of `config`) with a nominal tennis-synthetic test string in it — the
/// calibration is the sensor's, not the job string's, and a job with no string (or a soft
/// one) still gets a calibrated machine.
#[must_use]
pub fn factory_config(config: &TwinConfig) -> TwinConfig {
    let mut factory = *config;
    factory.string = TwinConfig::nominal(StringKind::TennisSynthetic).string;
    factory
}

/// The commissioning session on a new machine built from `config` (see the module docs):
/// calibrate (if `calibrate`), key in [`previous_job`], wait for the machine to store.
///
/// # Errors
/// A fault, a rejected calibration, no store, or the time limit.
pub fn commission(
    config: &TwinConfig,
    calibrate: bool,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<Commissioning, CycleError> {
    let factory = Record::default().encode();
    let mut bench = Bench::power_up(config, &factory);
    let plan = Plan { calibrate, settings: previous_job(), knot_mode: false, pull_hold_ms: None };
    let mut operator = Operator::new(plan);
    let mut rejected = false;
    drive(
        &mut bench,
        &mut operator,
        Session::Commissioning,
        progress,
        |bench, _| rejected |= bench.machine().notice() == Some(FaultCode::CalibrationRejected),
        |bench, operator| {
            if !operator.finished() {
                return false;
            }
            if operator.stopped() {
                return true;
            }
            let stored = Record::decode(bench.flash());
            stored.is_ok_and(|r| {
                r.settings == plan.settings && (!calibrate || r.calibration.is_some())
            })
        },
    )?;
    if let Some(code) = bench.machine().fault() {
        return Err(CycleError::CommissioningFault(code));
    }
    if rejected {
        return Err(CycleError::CalibrationRejected);
    }
    let record = Record::decode(bench.flash()).map_err(|_| CycleError::NothingStored)?;
    Ok(Commissioning {
        flash: *bench.flash(),
        record,
        gauge_readings: operator.gauge_readings().to_vec(),
        sim_ms: bench.twin().now_ms(),
        presses: operator.presses(),
    })
}

/// One recorded tick of the job.
#[derive(Clone, Copy, Debug)]
pub struct Row {
    /// Milliseconds since power-up.
    pub t_ms: u64,
    /// The machine's state after the tick.
    pub state: MachineState,
    /// True tension, kgf.
    pub tension_kgf: f64,
    /// The display's number while pulling, holding or releasing, converted to kgf.
    pub panel_kgf: Option<f64>,
    /// Carriage position, mm.
    pub carriage_mm: f64,
    /// String drawn past the encoder since power-up (truth), mm.
    pub string_mm: f64,
    /// Commanded duty, signed (negative = release), fraction.
    pub duty: f64,
    /// Winding current, tick mean, A.
    pub current_a: f64,
    /// Largest phase current in the tick, A.
    pub peak_current_a: f64,
    /// The panel's lamps.
    pub leds: Leds,
}

/// A state the machine entered, and when.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Transition {
    /// Milliseconds since power-up.
    pub t_ms: u64,
    /// The state entered.
    pub state: MachineState,
}

/// The job's record.
#[derive(Clone, Debug)]
pub struct CycleRun {
    /// The options it ran with.
    pub options: CycleOptions,
    /// The settings keyed in.
    pub settings: Settings,
    /// The commissioning session the machine's flash came from.
    pub commissioning: Commissioning,
    /// One row per tick.
    pub rows: Vec<Row>,
    /// Every state change, starting with the power-up state at 0.
    pub transitions: Vec<Transition>,
    /// The machine's log entry of the pull, if it completed.
    pub pull: Option<PullRecord>,
    /// The stored record at the end.
    pub record: Option<Record>,
    /// Key presses of the job.
    pub presses: u32,
    /// Store requests of the job.
    pub store_writes: u32,
    /// Whether the operator finished (back home, no fault).
    pub completed: bool,
    /// Wall-clock time of both sessions.
    pub wall: Duration,
}

/// A Q15.16 tension as `f64` kgf.
#[must_use]
pub fn kgf(value: Kgf) -> f64 {
    f64::from(value.to_bits()) / 65_536.0
}

/// Runs the main job (see the module docs): commissioning (unless `commissioning` is
/// given: tests reuse one), then the job.
///
/// # Errors
/// Invalid options, a failed commissioning, or the time limit.
pub fn run(
    options: &CycleOptions,
    commissioning: Option<&Commissioning>,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<CycleRun, CycleError> {
    let started = Instant::now();
    let settings = options.settings().map_err(CycleError::Options)?;
    let config = options.twin_config();
    let commissioning = match commissioning {
        Some(c) => c.clone(),
        None => commission(&factory_config(&config), options.calibrate, progress)?,
    };
    let mut bench = Bench::power_up(&config, &commissioning.flash);
    let plan = Plan {
        calibrate: false,
        settings,
        knot_mode: options.knot_percent.is_some(),
        pull_hold_ms: Some(options.hold_ms),
    };
    let mut operator = Operator::new(plan);
    let mut rows = Vec::with_capacity(60_000);
    let mut transitions = vec![Transition { t_ms: 0, state: bench.machine().state() }];
    let unit = settings.set_point().unit();
    let mut tail: Option<u64> = None;
    // The display of a tick is written by the state the tick started in.
    let mut previous = bench.machine().state();
    drive(
        &mut bench,
        &mut operator,
        Session::Job,
        progress,
        |bench, outputs| {
            let truth = bench.twin().truth();
            let state = bench.machine().state();
            let t_ms = bench.twin().now_ms();
            if transitions.last().is_none_or(|t| t.state != state) {
                transitions.push(Transition { t_ms, state });
            }
            let shown_by = std::mem::replace(&mut previous, state);
            let panel_kgf = match shown_by {
                MachineState::Pulling | MachineState::Holding | MachineState::Releasing => {
                    display::tenths(&outputs.display).map(|tenths| match unit {
                        Unit::Kilograms => f64::from(tenths) / 10.0,
                        Unit::Pounds => kgf(Kgf::from_lbf_tenths(tenths)),
                    })
                }
                _ => None,
            };
            let duty = f64::from(outputs.drive.duty().raw()) / f64::from(DUTY_ONE);
            rows.push(Row {
                t_ms,
                state,
                tension_kgf: truth.tension_kgf,
                panel_kgf,
                carriage_mm: truth.carriage_mm,
                string_mm: truth.string_travel_mm,
                duty: if outputs.drive.direction() == Some(Direction::Release) {
                    -duty
                } else {
                    duty
                },
                current_a: truth.current_a,
                peak_current_a: truth.peak_current_a,
                leds: outputs.leds,
            });
        },
        |bench, operator| {
            // A short tail after the operator is done keeps the last moments in the plot.
            if operator.finished() {
                let end = *tail.get_or_insert(bench.twin().now_ms() + 200);
                return bench.twin().now_ms() >= end;
            }
            false
        },
    )?;
    let completed = operator.finished() && !operator.stopped() && bench.machine().fault().is_none();
    Ok(CycleRun {
        options: *options,
        settings,
        commissioning,
        rows,
        transitions,
        pull: bench.machine().log().last().copied(),
        record: Record::decode(bench.flash()).ok(),
        presses: operator.presses(),
        store_writes: bench.store_writes(),
        completed,
        wall: started.elapsed(),
    })
}

// ───────────────────────────── figures ─────────────────────────────

/// The job's figures (see [`CycleRun::summary`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// String kind.
    pub string: &'static str,
    /// The set point as keyed (`25.0 kg`, `55.0 lb`).
    pub set_point: String,
    /// The tension held (knot increase included), kgf.
    pub target_kgf: f64,
    /// The highest tension of the pull (pre-stretch included), kgf.
    pub peak_target_kgf: f64,
    /// Power-up to Ready (self-test, motor test, homing, calibration window), s.
    pub boot_s: Option<f64>,
    /// Start to the machine's "at tension" (the holding lamp), s.
    pub time_to_tension_s: Option<f64>,
    /// Start to the true tension staying within ±0.1 kgf of the target for 0.5 s, s.
    pub true_settle_s: Option<f64>,
    /// The highest true tension of the pull and hold, kgf.
    pub peak_tension_kgf: f64,
    /// How far the true tension went above the peak target, kgf (0 if never).
    pub overshoot_kgf: f64,
    /// Largest |true − target| from 1 s after the holding lamp to the release, kgf.
    pub hold_error_max_kgf: Option<f64>,
    /// Mean |true − target| over the same window, kgf.
    pub hold_error_mean_kgf: Option<f64>,
    /// Time held, s.
    pub hold_s: Option<f64>,
    /// Carriage advance during the hold (following the string's creep), mm.
    pub creep_mm: Option<f64>,
    /// True tension when the operator released, kgf.
    pub tension_at_release_kgf: Option<f64>,
    /// String drawn during the pull as the machine counted it, mm.
    pub string_used_mm: Option<u32>,
    /// String drawn during the pull in truth, mm.
    pub true_string_mm: Option<f64>,
    /// Release to Ready at home, s.
    pub release_s: Option<f64>,
    /// Largest phase current, A.
    pub peak_current_a: f64,
    /// Faults the machine latched.
    pub faults: Vec<FaultCode>,
    /// Whether the cycle completed (home, Ready, no fault).
    pub completed: bool,
    /// Simulated time of the job, s.
    pub sim_s: f64,
    /// Wall-clock time of commissioning and job, s.
    pub wall_s: f64,
    /// Key presses in the job.
    pub presses: u32,
}

impl CycleRun {
    /// The first time `state` was entered at or after `from` ms.
    #[must_use]
    pub fn entered(&self, state: MachineState, from: u64) -> Option<u64> {
        self.transitions.iter().find(|t| t.state == state && t.t_ms >= from).map(|t| t.t_ms)
    }

    /// The tension held and the pull's peak target, kgf.
    #[must_use]
    pub fn targets_kgf(&self) -> (f64, f64) {
        let pull = to_pull_settings(&self.settings);
        let kind = self.options.pull_kind();
        (kgf(pull.final_target(kind)), kgf(pull.peak_target(kind)))
    }

    fn rows_between(&self, from: u64, to: u64) -> impl Iterator<Item = &Row> {
        self.rows.iter().filter(move |r| r.t_ms >= from && r.t_ms < to)
    }

    fn row_at(&self, t_ms: u64) -> Option<&Row> {
        self.rows.iter().find(|r| r.t_ms >= t_ms)
    }

    /// The figures of the job.
    #[must_use]
    pub fn summary(&self) -> Summary {
        let (target, peak_target) = self.targets_kgf();
        let ready = self.entered(MachineState::Ready, 0);
        let pulling = ready.and_then(|t| self.entered(MachineState::Pulling, t));
        let holding = pulling.and_then(|t| self.entered(MachineState::Holding, t));
        let releasing = holding.and_then(|t| self.entered(MachineState::Releasing, t));
        let home = releasing.and_then(|t| self.entered(MachineState::Ready, t));
        let end = self.rows.last().map_or(0, |r| r.t_ms + 1);
        let pull_end = releasing.unwrap_or(end);
        let seconds = |ms: u64| ms as f64 / 1_000.0;

        let (peak_tension_kgf, true_settle_s) = pulling.map_or((0.0, None), |start| {
            let peak =
                self.rows_between(start, pull_end).map(|r| r.tension_kgf).fold(0.0, f64::max);
            let mut run_start = None;
            let mut settled = None;
            for row in self.rows_between(start, pull_end) {
                if (row.tension_kgf - target).abs() <= SETTLE_BAND_KGF {
                    let since = *run_start.get_or_insert(row.t_ms);
                    if row.t_ms + 1 - since >= SETTLE_FOR_MS {
                        settled = Some(seconds(since - start));
                        break;
                    }
                } else {
                    run_start = None;
                }
            }
            (peak, settled)
        });
        let hold_window = holding.zip(releasing).map(|(h, r)| (h + HOLD_ERROR_FROM_MS, r));
        let hold_errors: Vec<f64> = hold_window.map_or_else(Vec::new, |(from, to)| {
            self.rows_between(from, to).map(|r| (r.tension_kgf - target).abs()).collect()
        });
        let hold_error_max_kgf =
            (!hold_errors.is_empty()).then(|| hold_errors.iter().copied().fold(0.0, f64::max));
        let hold_error_mean_kgf = (!hold_errors.is_empty())
            .then(|| hold_errors.iter().sum::<f64>() / hold_errors.len() as f64);
        let at = |t: Option<u64>| t.and_then(|t| self.row_at(t));
        let creep_mm = at(holding).zip(at(releasing)).map(|(h, r)| r.carriage_mm - h.carriage_mm);
        let true_string_mm = at(pulling).zip(at(releasing)).map(|(p, r)| r.string_mm - p.string_mm);
        let mut faults = Vec::new();
        for t in &self.transitions {
            if let MachineState::Fault(code) = t.state {
                faults.push(code);
            }
        }
        let unit = match self.settings.set_point().unit() {
            Unit::Kilograms => "kg",
            Unit::Pounds => "lb",
        };
        Summary {
            string: self.options.string.name(),
            set_point: format!(
                "{:.1} {unit}",
                f64::from(self.settings.set_point().tenths()) / 10.0
            ),
            target_kgf: target,
            peak_target_kgf: peak_target,
            boot_s: ready.map(seconds),
            time_to_tension_s: pulling.zip(holding).map(|(p, h)| seconds(h - p)),
            true_settle_s,
            peak_tension_kgf,
            overshoot_kgf: (peak_tension_kgf - peak_target).max(0.0),
            hold_error_max_kgf,
            hold_error_mean_kgf,
            hold_s: holding.zip(releasing).map(|(h, r)| seconds(r - h)),
            creep_mm,
            tension_at_release_kgf: at(releasing).map(|r| r.tension_kgf),
            string_used_mm: self.pull.map(|p| p.string_mm),
            true_string_mm,
            release_s: releasing.zip(home).map(|(r, h)| seconds(h - r)),
            peak_current_a: self.rows.iter().map(|r| r.peak_current_a).fold(0.0, f64::max),
            faults,
            completed: self.completed,
            sim_s: seconds(end),
            wall_s: self.wall.as_secs_f64(),
            presses: self.presses,
        }
    }

    /// The summary as a Markdown table.
    #[must_use]
    pub fn summary_table(&self) -> String {
        let s = self.summary();
        let o = &self.options;
        let secs = |v: Option<f64>| v.map_or_else(|| "—".to_owned(), |v| format!("{v:.3} s"));
        let kg = |v: Option<f64>| v.map_or_else(|| "—".to_owned(), |v| format!("{v:.3} kgf"));
        let mut settings = format!("{}, speed {}", s.set_point, o.speed);
        if o.pre_stretch_percent > 0 {
            let _ = write!(settings, ", pre-stretch {} %", o.pre_stretch_percent);
        }
        if let Some(knot) = o.knot_percent {
            let _ = write!(settings, ", knot pull +{knot} %");
        }
        let faults = if s.faults.is_empty() {
            "none".to_owned()
        } else {
            s.faults
                .iter()
                .map(|c| format!("E-{:02} {c:?}", c.number()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let rows: Vec<(&str, String)> = vec![
            ("string", s.string.to_owned()),
            ("settings", settings),
            (
                "target (held) / peak target",
                format!("{:.3} / {:.3} kgf", s.target_kgf, s.peak_target_kgf),
            ),
            ("boot (self-test, motor test, homing)", secs(s.boot_s)),
            ("time to tension (Start → holding lamp)", secs(s.time_to_tension_s)),
            ("true tension settled (±0.1 kgf for 0.5 s)", secs(s.true_settle_s)),
            ("peak true tension", format!("{:.3} kgf", s.peak_tension_kgf)),
            ("overshoot above the peak target", format!("{:.3} kgf", s.overshoot_kgf)),
            ("hold error, largest true − target (from 1 s)", kg(s.hold_error_max_kgf)),
            ("hold error, mean distance true − target", kg(s.hold_error_mean_kgf)),
            ("hold time", secs(s.hold_s)),
            (
                "creep followed during the hold",
                s.creep_mm.map_or_else(|| "—".to_owned(), |v| format!("{v:.2} mm")),
            ),
            ("true tension at release", kg(s.tension_at_release_kgf)),
            (
                "string used (machine's encoder / true)",
                format!(
                    "{} / {}",
                    s.string_used_mm.map_or_else(|| "—".to_owned(), |v| format!("{v} mm")),
                    s.true_string_mm.map_or_else(|| "—".to_owned(), |v| format!("{v:.1} mm"))
                ),
            ),
            ("release to home", secs(s.release_s)),
            ("peak current", format!("{:.2} A", s.peak_current_a)),
            ("faults", faults),
            ("cycle completed", if s.completed { "yes".to_owned() } else { "no".to_owned() }),
            (
                "key presses (job / commissioning)",
                format!("{} / {}", s.presses, self.commissioning.presses),
            ),
            (
                "simulated / wall clock",
                format!(
                    "{:.1} s (+ {:.1} s commissioning) / {:.2} s",
                    s.sim_s,
                    self.commissioning.sim_ms as f64 / 1_000.0,
                    s.wall_s
                ),
            ),
        ];
        let mut out = String::from("| quantity | value |\n|---|---|\n");
        for (name, value) in rows {
            let _ = writeln!(out, "| {name} | {value} |");
        }
        out
    }

    /// The summary as JSON (numbers in SI-ish units named in the keys).
    #[must_use]
    pub fn summary_json(&self) -> Value {
        let s = self.summary();
        let o = &self.options;
        json!({
            "string": s.string,
            "set_point": s.set_point,
            "speed": o.speed,
            "pre_stretch_percent": o.pre_stretch_percent,
            "knot_percent": o.knot_percent,
            "seed": o.seed,
            "calibrated": self.commissioning.record.calibration.is_some(),
            "target_kgf": s.target_kgf,
            "peak_target_kgf": s.peak_target_kgf,
            "boot_s": s.boot_s,
            "time_to_tension_s": s.time_to_tension_s,
            "true_settle_s": s.true_settle_s,
            "peak_tension_kgf": s.peak_tension_kgf,
            "overshoot_kgf": s.overshoot_kgf,
            "hold_error_max_kgf": s.hold_error_max_kgf,
            "hold_error_mean_kgf": s.hold_error_mean_kgf,
            "hold_s": s.hold_s,
            "creep_mm": s.creep_mm,
            "tension_at_release_kgf": s.tension_at_release_kgf,
            "string_used_mm": s.string_used_mm,
            "true_string_mm": s.true_string_mm,
            "release_s": s.release_s,
            "peak_current_a": s.peak_current_a,
            "faults": s.faults.iter().map(|c| format!("E-{:02}", c.number())).collect::<Vec<_>>(),
            "completed": s.completed,
            "presses": s.presses,
            "sim_s": s.sim_s,
            "wall_s": s.wall_s,
            "states": self.transitions.iter().map(|t| json!({"t_s": t.t_ms as f64 / 1_000.0, "state": state_name(t.state)})).collect::<Vec<_>>(),
        })
    }

    /// The plot: tension (true, target, panel), carriage, duty, current, and the machine's
    /// state timeline under them, as one SVG document.
    #[must_use]
    pub fn figure_svg(&self) -> String {
        let (target, _) = self.targets_kgf();
        let t = |r: &Row| r.t_ms as f64 / 1_000.0;
        let all = |value: fn(&Row) -> f64| self.rows.iter().map(|r| (t(r), value(r))).collect();
        let tensioned: Vec<&Row> = self
            .rows
            .iter()
            .filter(|r| matches!(r.state, MachineState::Pulling | MachineState::Holding))
            .collect();
        let target_line = match (tensioned.first(), tensioned.last()) {
            (Some(a), Some(b)) => vec![(t(a), target), (t(b), target)],
            _ => Vec::new(),
        };
        let panel_reading: Vec<(f64, f64)> =
            self.rows.iter().filter_map(|r| r.panel_kgf.map(|v| (t(r), v))).collect();
        let s = self.summary();
        let mut title = format!(
            "taut main job on the twin: {} at {}, speed {}",
            s.string, s.set_point, self.options.speed
        );
        if self.options.pre_stretch_percent > 0 {
            let _ = write!(title, ", pre-stretch {} %", self.options.pre_stretch_percent);
        }
        if let Some(knot) = self.options.knot_percent {
            let _ = write!(title, ", knot pull +{knot} %");
        }
        let figure = Figure::new(
            &title,
            "time since power-up (s)",
            vec![
                Panel::new(
                    "tension (kgf)",
                    vec![
                        Series::new("true tension", all(|r| r.tension_kgf)),
                        Series::new("target", target_line),
                        Series::new("panel reading", panel_reading),
                    ],
                ),
                Panel::new("carriage (mm)", vec![Series::new("carriage", all(|r| r.carriage_mm))]),
                Panel::new(
                    "duty (%, − = release)",
                    vec![Series::new("commanded duty", all(|r| r.duty * 100.0))],
                ),
                Panel::new(
                    "current (A)",
                    vec![
                        Series::new("winding (tick mean)", all(|r| r.current_a)),
                        Series::new("peak phase", all(|r| r.peak_current_a)),
                    ],
                ),
            ],
        );
        let end = self.rows.last().map_or(0.0, t);
        with_timeline(&figure.to_svg(), &self.transitions, end)
    }
}

/// A short name of a machine state, for legends, JSON and the panel.
#[must_use]
pub fn state_name(state: MachineState) -> String {
    match state {
        MachineState::SelfTest => "self-test".to_owned(),
        MachineState::MotorTest => "motor test".to_owned(),
        MachineState::Homing => "homing".to_owned(),
        MachineState::CalibrationWindow => "calibration window".to_owned(),
        MachineState::CalibrationPull { point } => format!("calibration pull {}", point + 1),
        MachineState::CalibrationEntry { point } => format!("calibration entry {}", point + 1),
        MachineState::Ready => "ready".to_owned(),
        MachineState::Pulling => "pulling".to_owned(),
        MachineState::Holding => "holding".to_owned(),
        MachineState::Releasing => "releasing".to_owned(),
        MachineState::Fault(code) => format!("fault E-{:02}", code.number()),
    }
}

/// The colour of a state's band on the timeline.
const fn state_colour(state: MachineState) -> &'static str {
    match state {
        MachineState::SelfTest | MachineState::MotorTest => "#bcbddc",
        MachineState::Homing => "#9ecae1",
        MachineState::CalibrationWindow => "#c7e9c0",
        MachineState::CalibrationPull { .. } | MachineState::CalibrationEntry { .. } => "#fdd0a2",
        MachineState::Ready => "#e5e5e5",
        MachineState::Pulling => "#6baed6",
        MachineState::Holding => "#31a354",
        MachineState::Releasing => "#fd8d3c",
        MachineState::Fault(_) => "#de2d26",
    }
}

/// Height of the timeline strip added under a figure, px.
const TIMELINE_HEIGHT: f64 = 80.0;

/// The value of attribute `name` in the first tag of `svg` that starts with `tag_start`.
fn attribute(svg: &str, tag_start: &str, name: &str) -> Option<f64> {
    let tag = &svg[svg.find(tag_start)?..];
    let tag = &tag[..tag.find('>')?];
    let key = format!(" {name}=\"");
    let value = &tag[tag.find(&key)? + key.len()..];
    value[..value.find('"')?].parse().ok()
}

/// `figure_svg` (a document from [`Figure::to_svg`]) with the machine-state timeline drawn
/// under it on the same time axis: one coloured band per state, labelled where it is wide
/// enough, and a legend. The figure is nested unchanged; its plot area (left edge, width,
/// total height) is read from its own first panel frame, and its x axis spans the data, which
/// runs from 0 to `end_s`.
#[must_use]
pub fn with_timeline(figure_svg: &str, transitions: &[Transition], end_s: f64) -> String {
    let width = attribute(figure_svg, "<svg", "width").unwrap_or(900.0);
    let height = attribute(figure_svg, "<svg", "height").unwrap_or(0.0);
    let left = attribute(figure_svg, "<rect x=", "x").unwrap_or(80.0);
    let plot_w = attribute(figure_svg, "<rect x=", "width").unwrap_or(width - 100.0);
    let x_px = |t: f64| left + if end_s > 0.0 { t / end_s * plot_w } else { 0.0 };
    let total = height + TIMELINE_HEIGHT;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{total}" viewBox="0 0 {width} {total}" font-family="sans-serif" font-size="11"><rect width="100%" height="100%" fill="white"/>"#
    );
    svg.push_str(figure_svg);
    let top = height;
    let band = 22.0;
    let _ = write!(
        svg,
        r#"<text transform="translate(18,{:.1}) rotate(-90)" text-anchor="middle">state</text>"#,
        top + band / 2.0
    );
    let mut legend: Vec<(String, &str)> = Vec::new();
    for (index, transition) in transitions.iter().enumerate() {
        let from = transition.t_ms as f64 / 1_000.0;
        let to = transitions.get(index + 1).map_or(end_s, |n| n.t_ms as f64 / 1_000.0);
        let (x0, x1) = (x_px(from), x_px(to.max(from)));
        let colour = state_colour(transition.state);
        let name = state_name(transition.state);
        let _ = write!(
            svg,
            r#"<rect x="{x0:.1}" y="{top:.1}" width="{:.1}" height="{band}" fill="{colour}"><title>{name}: {from:.3}–{to:.3} s</title></rect>"#,
            (x1 - x0).max(0.5)
        );
        if x1 - x0 > 7.0 * name.len() as f64 {
            let _ = write!(
                svg,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{name}</text>"#,
                (x0 + x1) / 2.0,
                top + 15.0
            );
        }
        let key = match transition.state {
            MachineState::CalibrationPull { .. } | MachineState::CalibrationEntry { .. } => {
                "calibration".to_owned()
            }
            MachineState::SelfTest | MachineState::MotorTest => "self-test, motor test".to_owned(),
            _ => name,
        };
        if !legend.iter().any(|(k, _)| *k == key) {
            legend.push((key, colour));
        }
    }
    let _ = write!(
        svg,
        r##"<rect x="{left}" y="{top:.1}" width="{plot_w}" height="{band}" fill="none" stroke="#444"/>"##
    );
    let mut x = left;
    let y = top + band + 24.0;
    for (name, colour) in legend {
        let _ = write!(
            svg,
            r#"<rect x="{x:.1}" y="{:.1}" width="12" height="12" fill="{colour}"/><text x="{:.1}" y="{y:.1}">{name}</text>"#,
            y - 10.0,
            x + 16.0
        );
        x += 28.0 + 6.5 * name.len() as f64;
    }
    svg.push_str("</svg>");
    svg
}

// ───────────────────────────── command line ─────────────────────────────

/// What `taut --help` says after the options.
pub const AFTER_HELP: &str = "\
With no subcommand, taut runs the main job: a whole machine cycle on the digital twin through
the same machine the firmware links. A simulated operator commissions the machine (4-point
calibration against the reference gauge), then powers it up, keys the settings in on the
panel, presses Start, lets it hold while the string creeps and releases. Progress goes to
stderr, the summary table to stdout, the plot to --svg (out/cycle.svg).

Examples:
  taut                                   25 kg on tennis-synthetic, speed 5
  taut --tension 55lb --string tennis-poly --speed 9
  taut --pre-stretch 10 --knot --json out/cycle.json
  taut panel                             the front panel in this terminal";

/// The main job's command-line options (`taut` with no subcommand).
#[derive(clap::Args, Clone, Debug)]
pub struct JobArgs {
    /// Tension to set on the panel: kilograms, or with a unit (25, 25.5kg, 55lb).
    #[arg(long, default_value = "25", value_parser = tension_arg, value_name = "KGF")]
    pub tension: SetPoint,
    /// String on the machine: badminton-soft, badminton-hard, tennis-gut, tennis-synthetic,
    /// tennis-poly, none.
    #[arg(long, default_value = "tennis-synthetic", value_name = "KIND")]
    pub string: StringKind,
    /// Speed setting, 1 (gentlest) to 9 (fastest).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u8).range(1..=9))]
    pub speed: u8,
    /// Pre-stretch, percent above the tension (0–30, steps of 5).
    #[arg(long = "pre-stretch", default_value_t = 0, value_name = "PCT")]
    pub pre_stretch: u8,
    /// Make a knot pull: knot mode on, knot increase PCT (0–20, steps of 5; 15 if omitted).
    #[arg(long, num_args = 0..=1, default_missing_value = "15", value_name = "PCT")]
    pub knot: Option<u8>,
    /// Run a Monte-Carlo scenario of the twin (string stiffness, slack, friction, sensors…)
    /// instead of the nominal machine.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Seconds the operator lets the machine hold before releasing.
    #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
    pub hold: f64,
    /// Skip the commissioning calibration: the machine runs on the tared, uncorrected sensor.
    #[arg(long)]
    pub uncalibrated: bool,
    /// Where to write the plot.
    #[arg(long, default_value = "out/cycle.svg", value_name = "FILE")]
    pub svg: std::path::PathBuf,
    /// Also write the summary as JSON here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<std::path::PathBuf>,
    /// No progress on stderr.
    #[arg(long)]
    pub quiet: bool,
}

fn tension_arg(text: &str) -> Result<SetPoint, String> {
    parse_tension(text).map_err(|e| e.to_string())
}

impl JobArgs {
    /// The options these arguments ask for.
    ///
    /// # Errors
    /// An option out of range.
    pub fn options(&self) -> Result<CycleOptions, OptionError> {
        let options = CycleOptions {
            set_point: self.tension,
            string: self.string,
            speed: self.speed,
            pre_stretch_percent: self.pre_stretch,
            knot_percent: self.knot,
            seed: self.seed,
            hold_ms: if (0.0..=120.0).contains(&self.hold) {
                (self.hold * 1_000.0).round() as u32
            } else {
                return Err(OptionError::Hold);
            },
            calibrate: !self.uncalibrated,
        };
        options.settings()?;
        Ok(options)
    }
}

/// One progress line: session, time, state, panel text, true tension, what the operator does.
#[must_use]
pub fn progress_line(progress: &Progress<'_>) -> String {
    let session = match progress.session {
        Session::Commissioning => "commissioning",
        Session::Job => "job",
    };
    format!(
        "[{session:>13} {:7.3} s] {:<20} panel [{:<5}]  true {:6.2} kgf  operator: {}",
        progress.time_s,
        state_name(progress.state),
        display::text(&progress.display),
        progress.tension_kgf,
        progress.activity
    )
}

/// `taut` with no subcommand: runs the main job, prints progress on stderr, the summary on
/// stdout, writes the plot (and the JSON); returns the process exit code (0 completed, 1
/// the cycle did not complete, 2 the job could not run).
#[must_use]
pub fn main_job(args: &JobArgs) -> i32 {
    use std::io::{IsTerminal as _, Write as _};
    let options = match args.options() {
        Ok(options) => options,
        Err(error) => {
            eprintln!("taut: {error}");
            return 2;
        }
    };
    let terminal = std::io::stderr().is_terminal();
    let mut shown = 0_u32;
    let mut progress = |p: &Progress<'_>| {
        if args.quiet {
            return;
        }
        if terminal {
            eprint!("\r\x1b[2K{}", progress_line(p));
            let _ = std::io::stderr().flush();
        } else if p.state_changed || shown == 0 {
            eprintln!("{}", progress_line(p));
        }
        shown += 1;
    };
    let run = match run(&options, None, &mut progress) {
        Ok(run) => run,
        Err(error) => {
            if terminal && !args.quiet {
                eprintln!();
            }
            eprintln!("taut: {error}");
            return 2;
        }
    };
    if terminal && !args.quiet {
        eprintln!();
    }
    println!("{}", run.summary_table());
    if let Some(parent) = args.svg.parent().filter(|p| !p.as_os_str().is_empty()) {
        if let Err(error) = std::fs::create_dir_all(parent) {
            eprintln!("taut: cannot create {}: {error}", parent.display());
            return 2;
        }
    }
    if let Err(error) = std::fs::write(&args.svg, run.figure_svg()) {
        eprintln!("taut: cannot write {}: {error}", args.svg.display());
        return 2;
    }
    println!("plot: {}", args.svg.display());
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&run.summary_json()).unwrap_or_default();
        if let Err(error) = std::fs::write(path, text) {
            eprintln!("taut: cannot write {}: {error}", path.display());
            return 2;
        }
        println!("summary: {}", path.display());
    }
    if run.completed { 0 } else { 1 }
}

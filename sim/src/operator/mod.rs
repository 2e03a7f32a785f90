//! The simulated operator: a person in front of the machine who only presses keys and reads
//! the panel.
//!
//! # Theory of operation
//!
//! An [`Operator`] reads what a person reads — the 7-segment digits (decoded from the
//! segment bitmaps by [`display`]), the lamps, whether the carriage has come to rest at
//! home, and the reference gauge during a calibration — and its only action is pressing keys
//! through the twin's key API (taps of [`TAP_MS`] with [`PAUSE_MS`] between, or holding
//! Up/Down to use the panel's own repeat). It never looks at the machine's state: every state
//! change — self-test, motor test, homing, the calibration window, each calibration point,
//! pulling, "at tension", holding, releasing, home, and any fault — is decided by the
//! machine. A fault lamp makes the operator stop.
//!
//! What it sets out to do is a [`Plan`]: calibrate in the `CAL?` window (the reference gauge
//! hooked in on its cord in place of the string — [`StringParams::calibration_fixture`] — and
//! Function; at each
//! point the machine pulls by its raw reading, the operator reads the reference gauge for
//! [`GAUGE_READ_MS`] and keys the value in with Up/Down, then Start — eight times: the
//! machine takes its four points in two passes, homing in between on its own) or skip it (Start); toggle
//! knot mode (Function held); walk the settings menu with Function (speed, pre-stretch, knot
//! %, unit) setting each page with Up/Down; key the tension on the tension page; then, if the
//! plan pulls, press Start, wait for the holding lamp, hold for the planned time and press
//! Start to release, and wait for the carriage to come home. [`crate::bench`] runs it against
//! the machine on the twin.

#![allow(
    clippy::arithmetic_side_effects,
    reason = "millisecond timestamps from the twin's clock and small step counts: no overflow \
              within a session (a u64 of ms is 584 million years)"
)]

pub mod display;

use taut_core::io::{Display, Key, Keys, Outputs};
use taut_core::machine::panel::text as panel_text;
use taut_core::sense::calibration::CALIBRATION_READINGS;
use taut_core::settings::{KnotBoost, PreStretch, SetPoint, Settings, Unit};

use crate::params::StringParams;
use crate::twin::Twin;

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

/// The settings the previous job left on the machine (the commissioning session keys them
/// in): 22.0 kg, speed 3, no pre-stretch, no knot increase.
#[must_use]
pub fn previous_job() -> Settings {
    SetPoint::new(Unit::Kilograms, 220)
        .and_then(|set_point| Settings::new(set_point, 3, 0, 0))
        .unwrap_or_default()
}

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
    /// Keying `hundredths` in for point `point` (the entry is to 0.01 kg, as the gauge reads).
    KeyReference { point: u8, hundredths: i32 },
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

    /// An operator about to work `plan` on a machine already in Ready (the next pull of a
    /// working day): sets the panel up (knot mode, then the settings pages), then pulls.
    #[must_use]
    pub const fn at_ready(plan: Plan) -> Self {
        Self {
            plan,
            step: Step::KnotMode,
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
                        // Hook in the reference gauge on its cord in place of the string.
                        twin.fit_string(&StringParams::calibration_fixture());
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
                if display::hundredths(&shown).is_some()
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
                    let hundredths = ((gauge * 100.0).round() as i32).clamp(500, 5_500);
                    Step::KeyReference { point, hundredths }
                } else {
                    self.step
                }
            }
            Step::KeyReference { point, hundredths } => match display::hundredths(&shown) {
                Some(value) => {
                    if self.adjust(twin, value, hundredths, 1) {
                        self.tap(twin, Key::Start);
                        if usize::from(point) + 1 >= CALIBRATION_READINGS {
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
                    // Unhook the gauge and fit the racket's string.
                    twin.fit_new_string();
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
        // A notice (`n-nn`, never with the fault lamp) goes away with any key.
        if display::text(shown).starts_with("n-") && !leds.fault {
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
            Page::Speed => self.adjust(twin, value, i32::from(settings.speed().get()), 1),
            Page::PreStretch => self.adjust(
                twin,
                value,
                i32::from(settings.pre_stretch().percent()),
                i32::from(PreStretch::STEP),
            ),
            Page::Knot => self.adjust(
                twin,
                value,
                i32::from(settings.knot().percent()),
                i32::from(KnotBoost::STEP),
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

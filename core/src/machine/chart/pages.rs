//! The Ready pages: what the panel shows while the machine is idle and what each key does
//! there — the settings pages, the presets, the stringing timer, the pull log, the counters,
//! the string estimate and the service page — and the hold's digits.
//!
//! # Theory of operation
//!
//! The pages are the operator's interface, not the machine's safety: nothing here drives the
//! motor or decides a fault. `Chart::ready` (in `chart.rs`, with the states and their rules)
//! hands the tick to [`Chart::ready_panel`], which shows a pending notice or hands the key
//! to [`Chart::ready_key`]; that changes the settings in the record, moves between pages
//! ([`View`]) and returns the state it *proposes* next (a pull, a self-test from the service
//! page, calibration); the chart commits it only if no safety rule vetoes it in the same
//! tick. [`Chart::render`] draws the page on the four digits. `Chart::holding` likewise
//! leaves its digits to [`Chart::hold_panel`]. Keeping them here means a change to a page
//! never touches the statechart the whole-tick proofs cover (they still run through these
//! functions: Ready and the hold are among their states).

use super::calibrating::calibration_label;
use super::{Chart, Context, Hold, Sample, State, hold_target, pressed};
use crate::io::Key;
use crate::machine::panel::{self, Beep, KeyEvent};
use crate::machine::snapshot::FAULT_HISTORY;
use crate::sense::calibration::CALIBRATION_POINTS;
use crate::settings::Unit;
use crate::store::PRESET_COUNT;
use crate::units::{Kgf, Volts};

/// While the carriage works the display refreshes every 200 ms (5 Hz, what the eye reads
/// comfortably) from the ≈ 64 ms running average, so single-tick switching spikes (paper
/// fig. 22) never reach the digits and the last digit does not flicker.
pub const DISPLAY_REFRESH_MS: u16 = 200;
/// Ticks without a key before the panel returns from a settings page to the tension.
pub const VIEW_TIMEOUT: u32 = 5_000;

/// How long the digits show the new target after a hold adjustment (or `LOCK` / `PULL`
/// after Function), ms.
pub const ADJUST_SHOWN_MS: u16 = 1_000;

/// What the hold's digits show for [`ADJUST_SHOWN_MS`] after a key.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum HoldMessage {
    /// The adjusted target.
    Target,
    /// `LOCK`: constant pull off, the carriage held where it is.
    Locked,
    /// `PULL`: constant pull on again.
    ConstantPull,
}

/// A tension on the display in `unit`.
#[must_use]
pub fn tension_display(tension: Kgf, unit: Unit) -> crate::io::Display {
    match unit {
        Unit::Kilograms => panel::tenths(tension.to_tenths_rounded()),
        Unit::Pounds => panel::tenths(tension.to_lbf_tenths_rounded()),
    }
}

/// The page the Ready panel shows.
///
/// The settings pages (Tension … Unit, then the beeper and constant-pull preferences) follow
/// each other on Function; Preset opens the preset page (where a long Preset stores), and
/// Function from there the information pages (stringing timer, pull log, counters, string,
/// service), which Function walks back to the tension.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub enum View {
    /// The tension set point (`25.0`).
    #[default]
    Tension,
    /// Speed 1–9 (`SP 5`).
    Speed,
    /// Pre-stretch 0–30 % (`PS10`).
    PreStretch,
    /// Knot boost 0–20 % (`Kn15`).
    Knot,
    /// Unit (` kg` / ` lb`).
    Unit,
    /// The beeper's clicks and at-tension tone on or off (`bEon` / `bEoF`; fault tones
    /// always sound).
    Beeper,
    /// Constant pull in the hold by default, or every hold locked (`CPon` / `CPoF`).
    ConstantPull,
    /// Preset selection (`P 3`); the number is 0-based.
    Preset(u8),
    /// The stringing timer (`r1.05`: r for the racket; an `S` would read as a 5): Up starts
    /// and stops it, Down resets it when stopped.
    Timer,
    /// The pull log: `entry` back from the latest (Up: older, Down: newer), `field` of
    /// [`LOG_FIELDS`] (Preset: the next).
    Log {
        /// 0 = the latest pull.
        entry: u8,
        /// Which of the entry's fields.
        field: u8,
    },
    /// The lifetime counters, item of [`COUNTER_ITEMS`] (Up/Down).
    Counters(u8),
    /// The last pull's string estimate: 0 stiffness, 1 creep (Up/Down).
    String(u8),
    /// The service page, item of [`SERVICE_ITEMS`] (Up/Down); Start runs the self-test
    /// again.
    Service(u8),
}

/// The pull log page's fields, each shown as its label for [`LABEL_MS`] after a key, then
/// its value: the pull's number, the target held, the peak, the hold's adjustment, the time
/// to tension (s), the hold time (m.ss), the string used (mm), the string's stiffness
/// (kgf/mm) and creep (%/min).
pub const LOG_FIELDS: [&[u8; 4]; 9] =
    [b"PULL", b"SEt ", b"PEAk", b"Adj ", b"riSE", b"HOLd", b"Str ", b"StiF", b"CrEP"];
/// The counters page's items: pulls, power-ups, string used (m).
pub const COUNTER_ITEMS: [&[u8; 4]; 3] = [b"PULL", b"bOOt", b"Str "];
/// The service page's items' labels, in the order Up walks them: the live load-cell code, the
/// tare code, each calibration point's raw reading (kgf) under its first-pass label, the bus
/// voltage, the last faults since power-up, the zero's drift since the self-test (kgf, the
/// drift watch's, REQ-UI-12), the calibration's age in pulls and the drivetrain's drag trend
/// (the motor test's time, % of its commissioning, REQ-UI-14). The points and the faults are
/// as many as [`CALIBRATION_POINTS`] and [`FAULT_HISTORY`] say.
pub const SERVICE_ITEMS: [[u8; 4]; SERVICE_ITEM_COUNT] = service_items();

/// How many items the service page has.
pub const SERVICE_ITEM_COUNT: usize = DRAG_ITEM + 1;

/// The service page's first calibration point, after the code and the zero.
const FIRST_POINT_ITEM: usize = 2;
/// The service page's bus voltage, after the calibration points.
const BUS_ITEM: usize = FIRST_POINT_ITEM + CALIBRATION_POINTS;
/// The service page's latest fault, after the bus voltage.
const FIRST_FAULT_ITEM: usize = BUS_ITEM + 1;
/// The service page's zero drift, after the faults.
const DRIFT_ITEM: usize = FIRST_FAULT_ITEM + FAULT_HISTORY;
/// The service page's calibration age.
const AGE_ITEM: usize = DRIFT_ITEM + 1;
/// The service page's drag trend, the last item.
const DRAG_ITEM: usize = AGE_ITEM + 1;

// `Err1`… has one digit for the fault.
const _: () = assert!(FAULT_HISTORY <= 9, "a fault's service label has one digit");

/// One item of the service page.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum ServiceItem {
    /// The live load-cell code (`Cd`).
    LoadCellCode,
    /// The tared zero, V (`tArE`).
    Zero,
    /// Calibration point `n`'s raw reading, kgf (`CAL1`…).
    CalibrationPoint(usize),
    /// The bus voltage, V (`bUS`).
    BusVoltage,
    /// The `n`th latest fault since power-up (`Err1`…).
    Fault(usize),
    /// The zero's drift since the self-test, kgf (`drFt`).
    ZeroDrift,
    /// Pulls since the calibration (`CAgE`).
    CalibrationAge,
    /// The drivetrain's drag trend, % (`drAG`).
    Drag,
}

impl ServiceItem {
    /// The item at `index` of the service page, if there is one.
    const fn at(index: usize) -> Option<Self> {
        Some(match index {
            0 => Self::LoadCellCode,
            1 => Self::Zero,
            BUS_ITEM => Self::BusVoltage,
            DRIFT_ITEM => Self::ZeroDrift,
            AGE_ITEM => Self::CalibrationAge,
            DRAG_ITEM => Self::Drag,
            _ if index < BUS_ITEM => Self::CalibrationPoint(index.saturating_sub(FIRST_POINT_ITEM)),
            _ if index < DRIFT_ITEM => Self::Fault(index.saturating_sub(FIRST_FAULT_ITEM)),
            _ => return None,
        })
    }

    /// The item's label.
    const fn label(self) -> [u8; 4] {
        match self {
            Self::LoadCellCode => *b"Cd  ",
            Self::Zero => *b"tArE",
            Self::CalibrationPoint(point) => calibration_label(point),
            Self::BusVoltage => *b"bUS ",
            Self::Fault(latest) => [b'E', b'r', b'r', panel::last_digit(latest.saturating_add(1))],
            Self::ZeroDrift => *b"drFt",
            Self::CalibrationAge => *b"CAgE",
            Self::Drag => *b"drAG",
        }
    }
}

/// Every service item's label, in order.
#[allow(
    clippy::indexing_slicing,
    reason = "a const fn cannot call `get_mut`; `index < SERVICE_ITEM_COUNT` is the loop's own \
              bound, and a `const` that indexed out of bounds would fail to compile rather than \
              panic"
)]
const fn service_items() -> [[u8; 4]; SERVICE_ITEM_COUNT] {
    let mut items = [*b"----"; SERVICE_ITEM_COUNT];
    let mut index = 0;
    while index < SERVICE_ITEM_COUNT {
        if let Some(item) = ServiceItem::at(index) {
            items[index] = item.label();
        }
        index = index.saturating_add(1);
    }
    items
}

/// How long an information page shows its item's label after a key, ms.
pub const LABEL_MS: u32 = 1_000;

/// The string page's fields: stiffness and creep, the log's last two.
const STRING_FIELDS: [u8; 2] = [7, 8];

impl View {
    /// The page Function moves to.
    #[must_use]
    pub const fn next(self) -> Self {
        match self {
            Self::Tension => Self::Speed,
            Self::Speed => Self::PreStretch,
            Self::PreStretch => Self::Knot,
            Self::Knot => Self::Unit,
            Self::Unit => Self::Beeper,
            Self::Beeper => Self::ConstantPull,
            Self::ConstantPull | Self::Service(_) => Self::Tension,
            Self::Preset(_) => Self::Timer,
            Self::Timer => Self::Log { entry: 0, field: 0 },
            Self::Log { .. } => Self::Counters(0),
            Self::Counters(_) => Self::String(0),
            Self::String(_) => Self::Service(0),
        }
    }

    /// Whether this is one of the information pages (no setting changes on it).
    #[must_use]
    pub const fn is_information(self) -> bool {
        matches!(
            self,
            Self::Timer | Self::Log { .. } | Self::Counters(_) | Self::String(_) | Self::Service(_)
        )
    }

    /// The log entry and field this page shows, if it shows one (the log and string pages).
    #[must_use]
    pub fn log_field(self) -> Option<(u8, u8)> {
        match self {
            Self::Log { entry, field } => Some((entry, field)),
            Self::String(which) => STRING_FIELDS.get(usize::from(which)).map(|&field| (0, field)),
            _ => None,
        }
    }

    /// Whether this page is valid: its indices within their lists.
    #[must_use]
    pub fn is_valid(self) -> bool {
        match self {
            Self::Preset(index) => usize::from(index) < PRESET_COUNT,
            Self::Log { entry, field } => {
                usize::from(entry) < crate::machine::log::PULL_LOG_CAPACITY
                    && usize::from(field) < LOG_FIELDS.len()
            }
            Self::Counters(item) => usize::from(item) < COUNTER_ITEMS.len(),
            Self::String(item) => usize::from(item) < STRING_FIELDS.len(),
            Self::Service(item) => usize::from(item) < SERVICE_ITEMS.len(),
            _ => true,
        }
    }
}

/// The stringing timer: the whole racket's time, started, stopped and reset from its page,
/// running through pulls, releases and faults alike (it reads the machine's millisecond
/// clock, so nothing counts it per tick).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct StringingTimer {
    /// Milliseconds counted by the runs before the present one.
    banked_ms: u32,
    /// The clock ([`Inputs::now_ms`]) when the present run started, if running.
    since: Option<u32>,
}

impl StringingTimer {
    /// Milliseconds counted at clock `now` (the clock wraps; a run shorter than 49 days
    /// counts right).
    #[must_use]
    pub const fn elapsed_ms(&self, now: u32) -> u32 {
        match self.since {
            Some(since) => self.banked_ms.saturating_add(now.wrapping_sub(since)),
            None => self.banked_ms,
        }
    }

    /// Whether it is running.
    #[must_use]
    pub const fn running(&self) -> bool {
        self.since.is_some()
    }

    /// Starts it at clock `now`, or stops it there.
    pub fn start_stop(&mut self, now: u32) {
        self.banked_ms = self.elapsed_ms(now);
        self.since = if self.since.is_some() { None } else { Some(now) };
    }

    /// Back to zero — refused (false) while it runs.
    pub fn reset(&mut self) -> bool {
        let stopped = self.since.is_none();
        if stopped {
            self.banked_ms = 0;
        }
        stopped
    }
}

impl Chart {
    /// The Ready panel this tick: back to the tension after [`VIEW_TIMEOUT`] without a key; a
    /// pending notice, which the next key acknowledges and does nothing else; otherwise the
    /// key's effect ([`Chart::ready_key`], whose proposal goes to `context.next`) and the
    /// page drawn.
    pub(super) fn ready_panel(&mut self, context: &mut Context, sample: &Sample, view: &mut View) {
        if *view != View::Tension && self.idle >= VIEW_TIMEOUT {
            *view = View::Tension;
        }
        if let Some(notice) = self.notice {
            context.out.display = panel::notice(notice.number());
            if pressed(sample.key) {
                // The key acknowledges the notice and does nothing else.
                self.notice = None;
            }
            return;
        }
        if let Some(key) = sample.key {
            context.next = self.ready_key(context, sample, view, key);
        }
        context.out.display = self.render(*view, sample);
    }

    /// The hold's digits: a message after a key for [`ADJUST_SHOWN_MS`] (the adjusted
    /// target, `LOCK`, `PULL`), the tension timer, or the working tension.
    pub(super) fn hold_panel(
        &mut self,
        context: &mut Context,
        sample: &Sample,
        hold: &mut Hold,
        unit: Unit,
    ) {
        if let Some((message, left)) = hold.message {
            hold.message = left.checked_sub(1).filter(|&ms| ms > 0).map(|ms| (message, ms));
            context.out.display = match message {
                HoldMessage::Target => {
                    tension_display(hold_target(self.base_target(), unit, hold.adjust), unit)
                }
                HoldMessage::Locked => panel::text(b"LOCK"),
                HoldMessage::ConstantPull => panel::text(b"PULL"),
            };
            self.shown.1 = u16::MAX;
        } else if hold.timer {
            context.out.display = panel::clock(b't', hold.held_ms.checked_div(1_000).unwrap_or(0));
        } else {
            self.show_working_tension(context, sample);
        }
    }

    /// One key in Ready; returns the proposed next state.
    pub(super) fn ready_key(
        &mut self,
        context: &mut Context,
        sample: &Sample,
        view: &mut View,
        key: KeyEvent,
    ) -> Option<State> {
        let settings = self.record.settings;
        let step = key.step();
        let now = sample.inputs.now_ms;
        match (key, *view) {
            (KeyEvent::Press(Key::Start), View::Service(_)) => Some(State::self_test(0, 0)),
            (KeyEvent::Press(Key::Preset), View::Preset(_)) => None,
            (KeyEvent::Press(Key::Preset), View::Log { entry, field }) => {
                let next = field.saturating_add(1);
                let field = if usize::from(next) < LOG_FIELDS.len() { next } else { 0 };
                *view = View::Log { entry, field };
                None
            }
            (KeyEvent::Press(Key::Up), View::Timer) => {
                self.stringing.start_stop(now);
                None
            }
            (KeyEvent::Press(Key::Down), View::Timer) => {
                if !self.stringing.reset() {
                    context.beep = Some(Beep::Refused);
                }
                None
            }
            (_, page) if page.is_information() && step != 0 => {
                // Up: the next item (an older log entry), Down: the previous; clamped.
                let within = |index: u8, count: usize| {
                    let last = u8::try_from(count.saturating_sub(1)).unwrap_or(0);
                    index.saturating_add_signed(step).min(last)
                };
                *view = match page {
                    View::Log { entry, field } => View::Log {
                        entry: within(entry, crate::machine::log::PULL_LOG_CAPACITY),
                        field,
                    },
                    View::Counters(item) => View::Counters(within(item, COUNTER_ITEMS.len())),
                    View::String(item) => View::String(within(item, STRING_FIELDS.len())),
                    View::Service(item) => View::Service(within(item, SERVICE_ITEMS.len())),
                    other => other,
                };
                None
            }
            (KeyEvent::Press(Key::Start), View::Preset(index)) => {
                if let Some(preset) = self.record.presets.get(usize::from(index)) {
                    self.record.settings = *preset;
                    self.dirty = true;
                }
                *view = View::Tension;
                None
            }
            (KeyEvent::Press(Key::Start), _) => {
                if sample.inputs.limits.end {
                    context.beep = Some(Beep::Refused);
                    None
                } else {
                    if self.dirty {
                        self.dirty = false;
                        context.out.store = true;
                    }
                    Some(State::pulling(0))
                }
            }
            (KeyEvent::Press(Key::Function), _) => {
                *view = view.next();
                None
            }
            (KeyEvent::Long(Key::Function), _) => {
                // The press that began the hold turned the page; a long press means knot
                // mode instead, shown on the tension page.
                self.knot_mode = !self.knot_mode;
                *view = View::Tension;
                None
            }
            (KeyEvent::Press(Key::Preset), _) => {
                *view = View::Preset(0);
                None
            }
            (KeyEvent::Long(Key::Preset), View::Preset(index)) => {
                if let Some(preset) = self.record.presets.get_mut(usize::from(index)) {
                    *preset = settings;
                    self.dirty = true;
                    context.beep = Some(Beep::AtTension);
                }
                *view = View::Tension;
                None
            }
            (_, View::Preset(index)) if step != 0 => {
                let last = u8::try_from(PRESET_COUNT.saturating_sub(1)).unwrap_or(0);
                *view = View::Preset(index.saturating_add_signed(step).min(last));
                None
            }
            (_, View::Beeper | View::ConstantPull) if step != 0 => {
                let preferences = &mut self.record.preferences;
                if *view == View::Beeper {
                    preferences.beeper = !preferences.beeper;
                } else {
                    preferences.constant_pull = !preferences.constant_pull;
                }
                self.dirty = true;
                None
            }
            (_, page) if step != 0 => {
                let updated = match page {
                    View::Tension => {
                        settings.with_set_point(settings.set_point().stepped(i16::from(step)))
                    }
                    View::Speed => settings.with_speed_stepped(step),
                    View::PreStretch => settings.with_pre_stretch_stepped(step),
                    View::Knot => settings.with_knot_stepped(step),
                    View::Unit => settings.with_set_point(settings.set_point().converted()),
                    _ => settings,
                };
                if updated != settings {
                    self.record.settings = updated;
                    self.dirty = true;
                }
                None
            }
            _ => None,
        }
    }

    /// The Ready display for `view` at clock `now` (the log and string pages are the
    /// machine's, which keeps the log: [`crate::machine::Machine::tick`] draws them).
    pub(super) fn render(&self, view: View, sample: &Sample) -> crate::io::Display {
        let settings = self.record.settings;
        let labelled_item = |label: Option<&[u8; 4]>, value: crate::io::Display| match label {
            Some(label) if self.idle < LABEL_MS => panel::text(label),
            _ => value,
        };
        match view {
            View::Tension => panel::tenths(i32::from(settings.set_point().tenths())),
            View::Speed => panel::labelled(b"SP", settings.speed().get()),
            View::PreStretch => panel::labelled(b"PS", settings.pre_stretch().percent()),
            View::Knot => panel::labelled(b"Kn", settings.knot().percent()),
            View::Unit => match settings.set_point().unit() {
                Unit::Kilograms => panel::text(b" kg "),
                Unit::Pounds => panel::text(b" lb "),
            },
            View::Beeper => {
                panel::text(if self.record.preferences.beeper { b"bEon" } else { b"bEoF" })
            }
            View::ConstantPull => {
                panel::text(if self.record.preferences.constant_pull { b"CPon" } else { b"CPoF" })
            }
            View::Preset(index) => panel::labelled(b"P ", index.saturating_add(1)),
            View::Timer => {
                let ms = self.stringing.elapsed_ms(sample.inputs.now_ms);
                panel::clock(b'r', ms.checked_div(1_000).unwrap_or(0))
            }
            View::Counters(item) => {
                let counters = &self.record.counters;
                let value = match item {
                    0 => panel::integer(counters.pulls),
                    1 => panel::integer(counters.boots),
                    // Metres with one decimal.
                    _ => panel::tenths(
                        i32::try_from(counters.string_used_mm.checked_div(100).unwrap_or(0))
                            .unwrap_or(i32::MAX),
                    ),
                };
                labelled_item(COUNTER_ITEMS.get(usize::from(item)).copied(), value)
            }
            View::Service(item) => labelled_item(
                SERVICE_ITEMS.get(usize::from(item)),
                self.service_value(item, sample),
            ),
            View::Log { .. } | View::String(_) => panel::text(b"----"),
        }
    }

    /// The service page's value of `item` (see [`SERVICE_ITEMS`]).
    pub(super) fn service_value(&self, item: u8, sample: &Sample) -> crate::io::Display {
        match ServiceItem::at(usize::from(item)) {
            Some(ServiceItem::LoadCellCode) => {
                panel::integer(u32::from(sample.inputs.load_cell.get()))
            }
            // The tared zero, volts to the hundredth (`0.05`).
            Some(ServiceItem::Zero) => {
                panel::hundredths(self.scale.zero().to_milli().checked_div(10).unwrap_or(0))
            }
            Some(ServiceItem::CalibrationPoint(point)) => {
                match self.record.calibration.as_ref().and_then(|points| points.get(point)) {
                    Some(p) => panel::hundredths(p.raw.to_hundredths_rounded()),
                    None => panel::text(b"----"),
                }
            }
            Some(ServiceItem::BusVoltage) => {
                panel::tenths(sample.inputs.drive.bus.to_milli().checked_div(100).unwrap_or(0))
            }
            Some(ServiceItem::Fault(latest)) => {
                match self.record.faults.get(latest).copied().flatten() {
                    Some(snapshot) => panel::fault(snapshot.code.number()),
                    None => panel::text(b"----"),
                }
            }
            // The zero's drift since the self-test, kgf to the hundredth at the scale's gain.
            Some(ServiceItem::ZeroDrift) => {
                let moved = Volts(self.scale.zero().0.saturating_sub(self.rezero.reference().0));
                let kgf = Kgf(moved.0.saturating_mul(self.scale.kgf_per_volt()));
                panel::hundredths(kgf.to_hundredths_rounded())
            }
            Some(ServiceItem::CalibrationAge) => {
                self.record.calibration_age().map_or(panel::text(b"----"), panel::integer)
            }
            Some(ServiceItem::Drag) => {
                self.record.drivetrain.percent().map_or(panel::text(b"----"), panel::integer)
            }
            None => panel::text(b"----"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_cycle_back_to_tension() {
        let mut view = View::Tension;
        for _ in 0..7 {
            assert!(!view.is_information());
            view = view.next();
        }
        assert_eq!(view, View::Tension);
        assert_eq!(View::Preset(4).next(), View::Timer, "the presets lead to the information");
        // The information pages: timer, log, counters, string, service, then the tension.
        let mut view = View::Timer;
        let mut walked = 0;
        while view != View::Tension {
            assert!(view.is_information() && view.is_valid(), "{view:?}");
            view = view.next();
            walked += 1;
        }
        assert_eq!(walked, 5);
        assert!(!View::Log { entry: 32, field: 0 }.is_valid());
        assert!(!View::Log { entry: 0, field: 9 }.is_valid());
        assert!(!View::Counters(3).is_valid() && !View::String(2).is_valid());
        assert!(
            View::Service(12).is_valid()
                && !View::Service(13).is_valid()
                && !View::Preset(9).is_valid()
        );
        assert_eq!(View::String(1).log_field(), Some((0, 8)));
        assert_eq!(View::Log { entry: 3, field: 2 }.log_field(), Some((3, 2)));
        assert_eq!(View::Counters(0).log_field(), None);
    }

    /// The service page's items follow the calibration points and the fault history: today
    /// four points and three faults.
    #[test]
    fn service_items_follow_the_calibration_points() {
        if (CALIBRATION_POINTS, FAULT_HISTORY) == (4, 3) {
            let today = [
                *b"Cd  ", *b"tArE", *b"CAL1", *b"CAL2", *b"CAL3", *b"CAL4", *b"bUS ", *b"Err1",
                *b"Err2", *b"Err3", *b"drFt", *b"CAgE", *b"drAG",
            ];
            assert_eq!(SERVICE_ITEMS.as_slice(), today.as_slice());
        }
        assert_eq!(SERVICE_ITEM_COUNT, 6 + CALIBRATION_POINTS + FAULT_HISTORY);
        for point in 0..CALIBRATION_POINTS {
            let item = ServiceItem::at(FIRST_POINT_ITEM + point);
            assert_eq!(item, Some(ServiceItem::CalibrationPoint(point)));
            assert_eq!(
                SERVICE_ITEMS.get(FIRST_POINT_ITEM + point),
                Some(&calibration_label(point))
            );
        }
        assert_eq!(ServiceItem::at(SERVICE_ITEM_COUNT), None);
    }

    #[test]
    fn the_stringing_timer_starts_stops_and_resets_when_stopped() {
        let mut timer = StringingTimer::default();
        assert_eq!(timer.elapsed_ms(5_000), 0);
        timer.start_stop(1_000);
        assert!(timer.running());
        assert_eq!(timer.elapsed_ms(61_000), 60_000);
        assert!(!timer.reset(), "no reset while running");
        timer.start_stop(61_000);
        assert!(!timer.running());
        assert_eq!(timer.elapsed_ms(99_000), 60_000, "stopped: it holds");
        timer.start_stop(100_000);
        assert_eq!(timer.elapsed_ms(100_500), 60_500, "a second run adds on");
        // Across the clock's wrap.
        let mut wrapping = StringingTimer::default();
        wrapping.start_stop(u32::MAX - 499);
        assert_eq!(wrapping.elapsed_ms(500), 1_000);
        wrapping.start_stop(500);
        assert!(wrapping.reset());
        assert_eq!(wrapping.elapsed_ms(9_999), 0);
    }
}

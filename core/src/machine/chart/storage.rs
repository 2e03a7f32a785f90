//! The statechart's shared storage: what every state may read and change (statig's
//! `Self`), and the helpers the states share — building it from the record, latching a
//! fault, the working tension on the display, starting a pull's bookkeeping, re-zeroing at
//! rest, the log entry of a pull.
//!
//! # Theory of operation
//!
//! A statig state carries only its own local data (`elapsed`, a `Hold`, a `View`); what
//! lives across states — the record, the calibration and load-cell scale, the controller,
//! the tension rules' watch, the notice, the counters of the present pull — is here. The
//! states in `chart.rs` are its only writers.

use statig::prelude::{Outcome, Transition};

use super::{
    Context, DISPLAY_REFRESH_MS, Hold, Recovery, Sample, State, StringingTimer, hold_target,
    tension_display,
};
use crate::drive::DriveCommand;
use crate::io::Leds;
use crate::machine::fault::{FaultCode, Notice};
use crate::machine::log::{LoggedKgf, PullRecord, string_mm};
use crate::machine::safety::TensionWatch;
use crate::machine::string::StringProbe;
use crate::sense::calibration::{
    CALIBRATION_POINTS, Calibration, CalibrationPoint, CalibrationPoints,
};
use crate::sense::load_cell::LoadCellScale;
use crate::sense::rezero::{RestSample, Retare, Rezero, RezeroBands};
use crate::settings::{PullKind, PullSettings, Unit};
use crate::store::Record;
use crate::tension::{Measurement, TensionController};
use crate::units::Kgf;

/// The machine's shared storage: what every state may read and change.
#[derive(Clone, Debug)]
pub struct Chart {
    /// The persisted record.
    pub record: Record,
    /// The load-cell correction (from the record's calibration, or identity).
    pub calibration: Calibration,
    /// The load-cell scale, tared by the self-test and again at rest in Ready.
    pub scale: LoadCellScale,
    /// The re-zero at rest (REQ-ID-08): its reference is the self-test's tare.
    pub rezero: Rezero,
    /// Re-zeros taken since power-up (saturating).
    pub rezeros: u16,
    /// The drift watch's notice was raised since power-up (once a boot).
    pub drift_noticed: bool,
    /// The tension controller.
    pub controller: TensionController,
    /// A notice to show in Ready until a key is pressed.
    pub notice: Option<Notice>,
    /// Whether the boot sequence is still running (faults then recover by a new self-test).
    pub booting: bool,
    /// The record changed and is not yet stored.
    pub dirty: bool,
    /// Ticks since the last key event (saturating).
    pub idle: u32,
    /// Knot mode: the next pulls are knot pulls.
    pub knot_mode: bool,
    /// The tension rules' state for the present pull.
    pub watch: TensionWatch,
    /// The present pull's peak target (for the overload rule).
    pub peak_target: Kgf,
    /// Ticks from Start to "at tension" of the present pull.
    pub time_to_tension: u32,
    /// String-encoder counts of the present pull.
    pub string_counts: i32,
    /// The string's stiffness and creep, measured through the present pull.
    pub probe: StringProbe,
    /// The calibration points taken so far.
    pub calibration_points: CalibrationPoints,
    /// Consecutive moving ticks with the load cell at a rail.
    pub rail_ticks: u8,
    /// Consecutive ticks the carriage was expected to move under at least the stall duty.
    pub driven_ms: u32,
    /// The tension digits shown while the carriage works, and how long ago they were
    /// refreshed ([`DISPLAY_REFRESH_MS`]).
    pub shown: (crate::io::Display, u16),
    /// The stringing timer.
    pub stringing: StringingTimer,
    /// Set while [`crate::machine::Machine::resume`] enters its checkpoint's state: the entry
    /// actions then keep the checkpoint's watch and rail count instead of starting afresh.
    /// Cleared by the first tick.
    pub resuming: bool,
}

impl Chart {
    /// The shared storage for `record`: its calibration rebuilt and validated (an invalid
    /// one is replaced by identity and reported as a notice).
    #[must_use]
    pub fn new(record: Record, board: &crate::board::BoardConfig) -> Self {
        let (calibration, notice) = match record.calibration {
            None => (Calibration::IDENTITY, None),
            Some(points) => match Calibration::new(&points) {
                Ok(calibration) => (calibration, None),
                Err(_) => (Calibration::IDENTITY, Some(Notice::StoredCalibrationInvalid)),
            },
        };
        Self {
            record,
            calibration,
            scale: board.load_cell(),
            rezero: Rezero::new(
                board.load_cell().zero(),
                RezeroBands::for_scale(&board.load_cell()),
            ),
            rezeros: 0,
            drift_noticed: false,
            controller: board.controller(),
            notice,
            booting: true,
            dirty: false,
            idle: 0,
            knot_mode: false,
            watch: TensionWatch::new(0),
            peak_target: Kgf::ZERO,
            time_to_tension: 0,
            string_counts: 0,
            probe: StringProbe::NEW,
            calibration_points: [CalibrationPoint::default(); CALIBRATION_POINTS],
            rail_ticks: 0,
            driven_ms: 0,
            shown: (crate::io::Display::default(), u16::MAX),
            stringing: StringingTimer::default(),
            resuming: false,
        }
    }

    /// The controller's measurement for this tick, with the given tension.
    pub(super) fn measurement(sample: &Sample, tension: Kgf) -> Measurement {
        Measurement {
            tension,
            drive: sample.inputs.drive,
            current: sample.inputs.drive.current,
            limits: sample.inputs.limits,
            bus: sample.inputs.drive.bus,
        }
    }

    /// Counts a power-up in the record and marks it for storing (it is written once the
    /// machine idles in Ready, which also rewrites a record migrated from an older format in
    /// today's).
    pub fn count_boot(&mut self) {
        self.record.counters.boots = self.record.counters.boots.saturating_add(1);
        self.dirty = true;
    }

    /// Where a fault raised now recovers to.
    pub(super) const fn recovery(&self) -> Recovery {
        if self.booting { Recovery::SelfTest } else { Recovery::Home }
    }

    /// Latch `code`: coast now, then the fault state.
    pub(super) fn trip(&self, context: &mut Context, code: FaultCode) -> Outcome<State> {
        context.out.drive = DriveCommand::Coast;
        context.next = None;
        Transition(State::fault(code, self.recovery(), 0))
    }

    /// The operator's settings as controller settings.
    pub(super) fn pull_settings(&self) -> PullSettings {
        self.record.settings.pull()
    }

    /// The tension while the carriage works: the calibrated running average, refreshed every
    /// [`DISPLAY_REFRESH_MS`].
    pub(super) fn show_working_tension(&mut self, context: &mut Context, sample: &Sample) {
        let (digits, age) = self.shown;
        self.shown = if age >= DISPLAY_REFRESH_MS.saturating_sub(1) {
            let tension = self.calibration.correct(sample.raw_average);
            (tension_display(tension, self.record.settings.set_point().unit()), 0)
        } else {
            (digits, age.saturating_add(1))
        };
        context.out.display = self.shown.0;
    }

    /// The unit lamps.
    pub(super) fn unit_leds(&self) -> Leds {
        let unit = self.record.settings.set_point().unit();
        Leds {
            kg: unit == Unit::Kilograms,
            lb: unit == Unit::Pounds,
            knot: self.knot_mode,
            ..Leds::default()
        }
    }

    /// Starts tracking a pull (or calibration point) of peak target `peak`.
    pub(super) fn begin_pull(&mut self, context: &Context, peak: Kgf) {
        if !self.resuming {
            self.watch = TensionWatch::new(context.sample.inputs.drive.steps);
        }
        self.peak_target = peak;
        self.time_to_tension = 0;
        self.string_counts = 0;
        self.probe = StringProbe::NEW;
        self.shown.1 = u16::MAX;
    }
}

impl Chart {
    /// REQ-ID-08, one tick in Ready: the re-zero rule sees the limits, the Hall count, the
    /// keys and the load cell, and an accepted zero becomes the scale's (same gain).
    pub(super) fn rezero_at_rest(&mut self, sample: &Sample) {
        let inputs = &sample.inputs;
        let rest = RestSample {
            home: inputs.limits.home,
            end: inputs.limits.end,
            steps: inputs.drive.steps,
            key: sample.key.is_some() || inputs.keys != crate::io::Keys::NONE,
            code: inputs.load_cell,
            now_ms: inputs.now_ms,
        };
        if let Some(Retare::Zero(zero)) =
            self.rezero.observe(&rest, self.scale.zero(), self.scale.reference())
        {
            if let Ok(scale) = self.scale.with_zero(zero) {
                self.scale = scale;
                self.rezeros = self.rezeros.saturating_add(1);
                // REQ-UI-12: the drift watch, once a boot, never over another notice.
                let calibrated_at = self.record.calibration_zero;
                if !self.drift_noticed
                    && self.notice.is_none()
                    && self.rezero.drifted_since(zero, calibrated_at)
                {
                    self.notice = Some(Notice::ZeroDrift);
                    self.drift_noticed = true;
                }
            }
        }
    }

    /// The final target of the present pull before any hold adjustment.
    pub(super) fn base_target(&self) -> Kgf {
        let kind = if self.knot_mode { PullKind::Knot } else { PullKind::Main };
        self.pull_settings().final_target(kind)
    }

    /// The log entry of the pull being released from `hold`.
    pub(super) fn pull_record(&self, sample: &Sample, hold: &Hold) -> PullRecord {
        let unit = self.record.settings.set_point().unit();
        PullRecord {
            target: LoggedKgf::from_kgf(hold_target(self.base_target(), unit, hold.adjust)),
            reached: LoggedKgf::from_kgf(self.calibration.correct(sample.raw_average)),
            peak: LoggedKgf::from_kgf(self.watch.peak),
            adjust: LoggedKgf::from_kgf(unit.tenths_to_kgf(i32::from(hold.adjust))),
            time_to_tension_ms: u16::try_from(self.time_to_tension).unwrap_or(u16::MAX),
            held_s: u16::try_from(hold.held_ms.checked_div(1_000).unwrap_or(0)).unwrap_or(u16::MAX),
            string_mm: u16::try_from(string_mm(self.string_counts)).unwrap_or(u16::MAX),
            stiffness: self.probe.stiffness(),
            // At constant pull only: a locked carriage does not creep.
            creep: if self.controller.constant_pull() {
                let held = hold_target(self.base_target(), unit, hold.adjust);
                self.probe.creep(held)
            } else {
                None
            },
        }
    }
}

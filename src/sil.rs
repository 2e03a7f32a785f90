//! Software in the loop: taut-core's tension controller driving the digital twin.
//!
//! # Theory of operation
//!
//! Each 1 ms tick does what the firmware and the machine do around the controller:
//! the twin's raw [`Inputs`] are converted by the core's own sensing code — the load-cell
//! code through [`LoadCellScale`] (tared at power-up on the unloaded reading) and the
//! [`Calibration`], the current code through `sense::current` — into a [`Measurement`];
//! [`TensionController::step`] answers with a drive command, which goes back to the twin as
//! [`Outputs`]. Every tick is recorded as a [`Sample`] (truth and what the controller saw),
//! which the reports turn into metrics and plots.
//!
//! [`calibrate`] runs the paper's 4-point calibration on the twin: pull to 10, 20, 30,
//! 40 kgf by the raw reading with the identity correction, hold, average the raw reading
//! (through the same median of five the controller uses, so switching spikes do not bias
//! it) over half a second, read the reference gauge once in the middle of that window (as
//! the operator keys in one value; a reading paired with the average of the window around
//! it, so a slow drift of the held tension cancels), and fit [`Calibration::new`].

use taut_core::drive::DriveCommand;
use taut_core::io::{Inputs, Outputs};
use taut_core::sense::calibration::{
    CALIBRATION_TARGETS, Calibration, CalibrationError, CalibrationPoint, CalibrationPoints,
};
use taut_core::sense::current;
use taut_core::sense::load_cell::LoadCellScale;
use taut_core::tension::{
    ControlOutput, ControllerConfig, Measurement, PullKind, PullPhase, PullSettings,
    TensionController,
};
use taut_core::units::{AdcCode, Kgf};
use taut_sim::{Twin, TwinConfig};

/// Ticks averaged to tare the load cell at power-up.
pub const TARE_TICKS: u32 = 64;

/// One recorded tick.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sample {
    /// Time since Start, s.
    pub t: f64,
    /// True tension, kgf.
    pub tension: f64,
    /// What the controller was given (calibrated, before its spike filter), kgf.
    pub measured: f64,
    /// The tension the controller acted on (its spike-filtered, observed estimate: what the
    /// machine shows), kgf.
    pub estimate: f64,
    /// The controller's reference, kgf.
    pub reference: f64,
    /// Signed duty (negative = release), fraction.
    pub duty: f64,
    /// Carriage position, mm.
    pub carriage_mm: f64,
    /// Winding current, A.
    pub current: f64,
    /// Largest phase current in the tick, A.
    pub peak_current: f64,
    /// The controller's phase.
    pub phase: PullPhase,
    /// The controller's force, kgf.
    pub force: f64,
    /// A drive fault is latched.
    pub fault: bool,
    /// The highest DC bus voltage in the tick, V.
    pub bus_peak: f64,
}

/// Kgf as f64.
#[must_use]
pub fn kgf(value: Kgf) -> f64 {
    f64::from(value.to_bits()) / 65_536.0
}

/// f64 kgf as Kgf (rounded, saturating).
#[must_use]
pub fn to_kgf(value: f64) -> Kgf {
    Kgf::from_bits((value * 65_536.0).round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32)
}

/// The signed duty of a command.
#[must_use]
pub fn signed_duty(command: DriveCommand) -> f64 {
    let duty = f64::from(command.duty().raw()) / 65_536.0;
    match command.direction() {
        Some(taut_core::drive::Direction::Release) => -duty,
        _ => duty,
    }
}

/// The machine around the controller: twin, sensing chain, controller.
pub struct Rig {
    /// The twin.
    pub twin: Twin,
    /// The tared load-cell scale.
    pub scale: LoadCellScale,
    /// The calibration in use.
    pub calibration: Calibration,
    /// The controller.
    pub controller: TensionController,
    /// Ticks since Start.
    ticks: u64,
}

impl Rig {
    /// Powers up a twin, tares the load cell over [`TARE_TICKS`] and builds the controller.
    ///
    /// # Panics
    /// When `config` is not a valid controller configuration (a programming error in the
    /// host tool).
    #[must_use]
    pub fn new(twin: &TwinConfig, config: &ControllerConfig, calibration: Calibration) -> Self {
        let mut twin = Twin::new(twin);
        let mut sum = 0_u32;
        for _ in 0..TARE_TICKS {
            sum += u32::from(twin.inputs().load_cell.get());
            twin.apply(&Outputs::default());
            twin.advance_tick();
        }
        let code = AdcCode::new(((sum + TARE_TICKS / 2) / TARE_TICKS) as u16);
        let scale = LoadCellScale::NOMINAL.tared_at(code).unwrap_or(LoadCellScale::NOMINAL);
        let controller = TensionController::new(config).expect("controller configuration");
        Self { twin, scale, calibration, controller, ticks: 0 }
    }

    /// The measurement the controller gets from `inputs`.
    #[must_use]
    pub fn measure(&self, inputs: &Inputs) -> Measurement {
        let raw = self.scale.to_kgf(inputs.load_cell);
        Measurement {
            tension: self.calibration.correct(raw),
            drive: inputs.drive,
            current: current::amps(inputs.motor_current),
            limits: inputs.limits,
        }
    }

    /// The uncorrected reading (for calibration).
    #[must_use]
    pub fn raw(&self, inputs: &Inputs) -> Kgf {
        self.scale.to_kgf(inputs.load_cell)
    }

    /// Starts a pull.
    pub fn start(&mut self, settings: &PullSettings, kind: PullKind) {
        self.controller.start(settings, kind);
        self.ticks = 0;
    }

    /// One tick: measure, control, apply, advance the physics; returns the record.
    pub fn tick(&mut self) -> (Sample, ControlOutput, Inputs) {
        let inputs = self.twin.inputs();
        let measurement = self.measure(&inputs);
        let out = self.controller.step(&measurement);
        self.twin.apply(&Outputs { drive: out.command, ..Outputs::default() });
        self.twin.advance_tick();
        self.ticks += 1;
        let truth = self.twin.truth();
        let sample = Sample {
            t: self.ticks as f64 / 1000.0,
            tension: truth.tension_kgf,
            measured: kgf(measurement.tension),
            reference: kgf(out.reference),
            duty: signed_duty(out.command),
            carriage_mm: truth.carriage_mm,
            current: truth.current_a,
            peak_current: truth.peak_current_a,
            phase: out.phase,
            force: kgf(out.force),
            fault: truth.drive_fault.is_some(),
            estimate: kgf(out.tension),
            bus_peak: truth.bus_peak_volts,
        };
        (sample, out, inputs)
    }

    /// Runs `ticks` ticks, appending to `trace`.
    pub fn run(&mut self, ticks: u32, trace: &mut Vec<Sample>) {
        for _ in 0..ticks {
            let (sample, _, _) = self.tick();
            trace.push(sample);
        }
    }
}

/// The result of a simulated 4-point calibration.
#[derive(Clone, Copy, Debug)]
pub struct CalibrationRun {
    /// The points as measured.
    pub points: CalibrationPoints,
    /// The fit, or why it was rejected.
    pub calibration: Result<Calibration, CalibrationError>,
}

/// Ticks held at each calibration point before averaging, and ticks averaged.
pub const CALIBRATION_SETTLE_TICKS: u32 = 1_500;
/// Ticks averaged at each calibration point.
pub const CALIBRATION_AVERAGE_TICKS: u32 = 500;

/// The paper's calibration on a twin built from `config` (see the module docs).
#[must_use]
pub fn calibrate(config: &TwinConfig) -> CalibrationRun {
    // The reference gauge and its fixture replace the string: a stiff, short load path
    // (a polyester-like 12.5 kgf/cm, 10 mm slack), so 40 kgf is reached within the travel
    // whatever string the scenario strings afterwards. The machine — motor, friction,
    // sensor chain — is the scenario's own.
    let mut config = *config;
    config.string = taut_sim::params::StringParams::nominal(taut_sim::StringKind::TennisPolyester);
    config.string.slack_mm = 10.0;
    let config = &config;
    let mut rig = Rig::new(config, &ControllerConfig::TAUT, Calibration::IDENTITY);
    let zero = {
        // Unloaded: the raw reading right after taring.
        let mut sum = 0.0;
        for _ in 0..CALIBRATION_AVERAGE_TICKS {
            let inputs = rig.twin.inputs();
            sum += kgf(rig.raw(&inputs));
            rig.twin.apply(&Outputs::default());
            rig.twin.advance_tick();
        }
        sum / f64::from(CALIBRATION_AVERAGE_TICKS)
    };
    let mut points = CalibrationPoints { zero: to_kgf(zero), ..CalibrationPoints::default() };
    for (slot, target) in points.points.iter_mut().zip(CALIBRATION_TARGETS) {
        let settings = PullSettings::default().with_tension(target).expect("calibration target");
        rig.start(&settings, PullKind::Main);
        for _ in 0..CALIBRATION_SETTLE_TICKS {
            rig.tick();
        }
        let mut sum = 0.0;
        let mut reference = 0.0;
        let mut window = [kgf(rig.raw(&rig.twin.inputs())); 5];
        for tick in 0..CALIBRATION_AVERAGE_TICKS {
            let inputs = rig.twin.inputs();
            window.rotate_left(1);
            window[4] = kgf(rig.raw(&inputs));
            let mut sorted = window;
            sorted.sort_by(f64::total_cmp);
            sum += sorted[2];
            if tick == CALIBRATION_AVERAGE_TICKS / 2 {
                reference = rig.twin.reference_gauge();
            }
            rig.tick();
        }
        *slot = CalibrationPoint {
            raw: to_kgf(sum / f64::from(CALIBRATION_AVERAGE_TICKS)),
            reference: to_kgf(reference),
        };
    }
    CalibrationRun { points, calibration: Calibration::new(&points) }
}

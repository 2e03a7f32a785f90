//! The one bench: the firmware's [`Machine`] (or, for controller studies, its tension
//! controller alone) on the twin, tick by tick, with the simulated operator — the single
//! loop every host-side run goes through (the main job, the terminal panel, every report,
//! the integration tests).
//!
//! # Theory of operation
//!
//! **One tick** ([`step`]) is what the board's 1 kHz interrupt does: sample the twin's raw
//! [`Inputs`], let the controller decide the [`Outputs`], apply them to the twin, let an
//! observer (the operator) look and press keys (seen from the next tick on, as a key read
//! live), then let one millisecond of physics pass. [`crate::trace::run`], [`Bench::tick`]
//! and [`ControllerBench::tick`] are all this function.
//!
//! **The machine bench** ([`Bench`]) wires [`Machine`] — the very state machine,
//! controller and safety rules the firmware links — to a [`Twin`]: it persists the record
//! whenever the machine raises [`Outputs::store`] (a simulated flash holding the encoded
//! bytes), keeps every state the machine entered ([`Transition`]) and, when asked, a [`Row`]
//! per tick (time, state, inputs, outputs, truth). [`machine_for`] is the one place a
//! machine is built for a twin configuration.
//!
//! **Sessions.** [`run_session`] runs a bench with an [`Operator`] until the operator's plan
//! is done (or the time limit), reporting [`Progress`]. [`commission`] is the session on a
//! new machine: the operator runs the 4-point calibration in the machine's own calibration
//! states, reading the twin's reference gauge ([`Twin::reference_gauge`]) and keying each
//! value in, then leaves [`previous_job`]'s settings on the panel; what the machine stored is
//! the [`Commissioning`]'s flash.
//!
//! **The controller bench** ([`ControllerBench`]) steps taut-core's
//! [`TensionController`] alone, for reports that compare control laws the machine does not
//! run (the paper's RSMC, PD) or switch improvements off. Its sensing chain is the
//! machine's: the load cell tared as the self-test tares it ([`tare`]) and corrected by the
//! calibration a [`commission`] session stored ([`calibration_of`]) — never a calibration of
//! its own.
//!
//! **The oracle** ([`bang_bang_reach_time`]) is the physical limit of a pull: the fastest
//! the twin's motor can bring the string to a tension without tripping the drive.

use std::fmt;

use taut_core::board::BoardConfig;
use taut_core::drive::Direction;
use taut_core::io::{Display, Inputs, Outputs};
use taut_core::machine::{
    FaultCode, Machine, MachineState, Notice, SELF_TEST_SETTLE, SELF_TEST_TICKS,
};
use taut_core::sense::calibration::Calibration;
use taut_core::sense::load_cell::LoadCellScale;
use taut_core::settings::{PullKind, PullSettings};
use taut_core::store::{RECORD_LEN, Record, StoreError};
use taut_core::tension::{
    ConfigError, ControlOutput, ControllerConfig, Measurement, TensionController,
};
use taut_core::units::Kgf;

use crate::operator::{Operator, Plan, previous_job};
use crate::params::{CurrentSenseParams, StringKind, TwinConfig};
use crate::trace::TraceRow;
use crate::twin::{Truth, Twin, drive_at};

// ───────────────────────────── one tick ─────────────────────────────

/// One control tick: sample, decide, apply, let `observe` look at the twin (and press keys),
/// advance one millisecond. Returns what the controller saw and did and the truth after it.
pub fn step(
    twin: &mut Twin,
    decide: impl FnOnce(&Inputs) -> Outputs,
    observe: impl FnOnce(&mut Twin),
) -> TraceRow {
    let inputs = twin.inputs();
    let outputs = decide(&inputs);
    twin.apply(&outputs);
    observe(twin);
    twin.advance_tick();
    TraceRow { inputs, outputs, truth: twin.truth() }
}

/// A Q15.16 tension as `f64` kgf.
#[must_use]
pub fn kgf(value: Kgf) -> f64 {
    f64::from(value.to_bits()) / 65_536.0
}

/// `f64` kgf as a Q15.16 tension (rounded, saturating).
#[must_use]
pub fn to_kgf(value: f64) -> Kgf {
    Kgf::from_bits((value * 65_536.0).round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32)
}

// ───────────────────────────── core types, in one place ─────────────────────────────

/// The board of a twin of `config`: its design ([`crate::params::BoardDesign`]: converter
/// reference, bus divider, dead time, overcurrent trip) with its current sensing
/// ([`TwinConfig::current_sense`]'s drive configuration), the twin's PWM period
/// ([`crate::twin::PWM_PERIOD`]), the paper's load-cell chain (50 mV at no load)
/// with its gain scaled to keep the paper's full scale on the board's converter (92 mV/kgf on
/// 5 V), and taut's controller. Every board the twin's family builds is valid (a test checks
/// each sensing kind); were one ever refused, the paper's board stands in.
#[must_use]
pub fn board_for(config: &TwinConfig) -> BoardConfig {
    use taut_core::board::{PAPER_KGF_PER_VOLT, PAPER_LOAD_CELL_ZERO};
    let reference = config.board.adc_reference;
    let scaled = i64::from(PAPER_KGF_PER_VOLT.to_bits())
        .saturating_mul(5_000)
        .checked_div(i64::from(reference.millivolts()))
        .unwrap_or(i64::MAX);
    let gain = taut_core::units::Q16::from_bits(i32::try_from(scaled).unwrap_or(i32::MAX));
    let built = LoadCellScale::new(reference, PAPER_LOAD_CELL_ZERO, gain)
        .map_err(|_| taut_core::board::BoardError::LoadCell)
        .and_then(|load_cell| {
            BoardConfig::new(
                config.current_sense.drive_config(&config.board),
                crate::twin::PWM_PERIOD,
                load_cell,
                ControllerConfig::TAUT,
            )
        });
    built.or_else(|_| taut_core::board::paper()).unwrap_or_else(|_| unreachable_board())
}

/// Only reachable if the paper's board itself were refused, which core's own tests rule out.
#[allow(clippy::panic, reason = "the paper's board is a constant checked by core's tests")]
fn unreachable_board() -> BoardConfig {
    panic!("the paper's board is valid")
}

/// The machine for a twin of `config`, powered up with what the store yielded (a record
/// that failed to load gives defaults and the `n-01` notice). The one place the host builds
/// a [`Machine`]: the board it is given is [`board_for`].
#[must_use]
pub fn machine_for(config: &TwinConfig, stored: Result<Record, StoreError>) -> Machine {
    Machine::from_stored(stored, &board_for(config))
}

/// A short name of a machine state, for progress lines, legends, JSON and the panel: the
/// core's one name table ([`MachineState::name`]) in words, with the calibration point
/// (1–4) or the fault code added.
#[must_use]
pub fn state_name(state: MachineState) -> String {
    let words = state.name().replace('-', " ");
    match state {
        MachineState::CalibrationPull { point } | MachineState::CalibrationEntry { point } => {
            format!("{words} {}", point.saturating_add(1))
        }
        MachineState::Fault(code) => fault_name(code),
        _ => words,
    }
}

/// A fault code as the panel shows it (`E-10`).
#[must_use]
pub fn fault_name(code: FaultCode) -> String {
    format!("E-{:02}", code.number())
}

/// The load-cell correction the machine builds from `record`'s stored calibration (identity
/// when there is none, or when it does not validate — the machine then shows `n-03`).
#[must_use]
pub fn calibration_of(record: &Record) -> Calibration {
    let Some(points) = record.calibration else { return Calibration::IDENTITY };
    Calibration::new(&points).unwrap_or(Calibration::IDENTITY)
}

/// Ticks the self-test lets the load-cell amplifier settle before it averages (the
/// machine's `SELF_TEST_SETTLE`).
pub const TARE_SETTLE_TICKS: u16 = SELF_TEST_SETTLE;

/// Tares a freshly powered twin as the machine's self-test does: the bridge off for
/// [`SELF_TEST_TICKS`], the mean load-cell code after [`TARE_SETTLE_TICKS`] is the zero.
/// `None` when that zero is outside the load cell's band (the machine latches `E-05`).
pub fn tare(twin: &mut Twin) -> Option<LoadCellScale> {
    let mut sum = 0_u32;
    for tick in 0..SELF_TEST_TICKS {
        let row = step(twin, |_| Outputs::default(), |_| {});
        if tick >= TARE_SETTLE_TICKS {
            sum = sum.saturating_add(u32::from(row.inputs.load_cell.get()));
        }
    }
    board_for(twin.config())
        .load_cell()
        .tared_at_mean(sum, SELF_TEST_TICKS.saturating_sub(TARE_SETTLE_TICKS))
        .ok()
}

/// The controller's measurement from `inputs` through `scale` and `calibration`.
#[must_use]
pub fn measurement(
    inputs: &Inputs,
    scale: &LoadCellScale,
    calibration: &Calibration,
) -> Measurement {
    Measurement {
        tension: calibration.correct(scale.to_kgf(inputs.load_cell)),
        drive: inputs.drive,
        current: inputs.drive.current,
        limits: inputs.limits,
        bus: inputs.drive.bus,
    }
}

// ───────────────────────────── the machine bench ─────────────────────────────

/// A state the machine entered, and when.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Transition {
    /// Milliseconds since power-up (the end of the tick that entered it).
    pub t_ms: u64,
    /// The state entered.
    pub state: MachineState,
}

/// One recorded tick of a machine bench.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Row {
    /// Milliseconds since power-up at the end of the tick.
    pub t_ms: u64,
    /// The machine's state after the tick.
    pub state: MachineState,
    /// What the machine sampled.
    pub inputs: Inputs,
    /// What it decided.
    pub outputs: Outputs,
    /// The physics at the end of the tick.
    pub truth: Truth,
}

/// The machine on the twin, wired as the firmware wires the board (see the module docs).
pub struct Bench {
    machine: Machine,
    twin: Twin,
    flash: [u8; RECORD_LEN],
    store_writes: u32,
    outputs: Outputs,
    transitions: Vec<Transition>,
    rows: Option<Vec<Row>>,
}

impl Bench {
    /// Powers the twin and the machine up; the machine loads its record from `flash` as the
    /// firmware does (a corrupt or blank flash gives defaults and the `n-01` notice).
    #[must_use]
    pub fn power_up(config: &TwinConfig, flash: &[u8; RECORD_LEN]) -> Self {
        let mut bench = Self::with_machine(config, machine_for(config, Record::decode(flash)));
        bench.flash = *flash;
        bench
    }

    /// A machine at power-up with `record` (as if it were in the flash).
    #[must_use]
    pub fn new(config: &TwinConfig, record: Record) -> Self {
        Self::power_up(config, &record.encode())
    }

    /// A machine at power-up with the default record, on a nominal twin with a `kind` string.
    #[must_use]
    pub fn nominal(kind: StringKind) -> Self {
        Self::new(&TwinConfig::nominal(kind), Record::default())
    }

    /// `machine` (e.g. resumed at a checkpoint) in a twin of `config`; the flash holds its
    /// record.
    #[must_use]
    pub fn with_machine(config: &TwinConfig, machine: Machine) -> Self {
        let state = machine.state();
        Self {
            flash: machine.record().encode(),
            machine,
            twin: Twin::new(config),
            store_writes: 0,
            outputs: Outputs::default(),
            transitions: vec![Transition { t_ms: 0, state }],
            rows: None,
        }
    }

    /// This bench, recording a [`Row`] per tick from now on.
    #[must_use]
    pub fn recording(mut self) -> Self {
        self.rows = Some(Vec::with_capacity(60_000));
        self
    }

    /// One 1 ms tick (see [`step`]); the record is persisted if the machine asks.
    pub fn tick(&mut self) -> Outputs {
        self.tick_with(|_| {})
    }

    /// One tick during which `operator` may look at the twin and press keys after the
    /// machine's outputs are applied (seen from the next tick on).
    pub fn tick_with(&mut self, operator: impl FnOnce(&mut Twin)) -> Outputs {
        let machine = &mut self.machine;
        let row = step(&mut self.twin, |inputs| machine.tick(inputs), operator);
        self.outputs = row.outputs;
        if row.outputs.store {
            self.flash = self.machine.record().encode();
            self.store_writes = self.store_writes.saturating_add(1);
        }
        let state = self.machine.state();
        let t_ms = self.twin.now_ms();
        if self.transitions.last().is_none_or(|t| t.state != state) {
            self.transitions.push(Transition { t_ms, state });
        }
        if let Some(rows) = &mut self.rows {
            rows.push(Row {
                t_ms,
                state,
                inputs: row.inputs,
                outputs: row.outputs,
                truth: row.truth,
            });
        }
        row.outputs
    }

    /// Runs `ms` ticks.
    pub fn run(&mut self, ms: u64) {
        for _ in 0..ms {
            self.tick();
        }
    }

    /// Runs until `done` holds (`true`) or `max_ms` ticks pass (`false`).
    pub fn run_until(&mut self, max_ms: u64, mut done: impl FnMut(&Self) -> bool) -> bool {
        for _ in 0..max_ms {
            if done(self) {
                return true;
            }
            self.tick();
        }
        done(self)
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

    /// The machine's outputs of the last tick.
    #[must_use]
    pub const fn outputs(&self) -> &Outputs {
        &self.outputs
    }

    /// The display of the last tick.
    #[must_use]
    pub const fn display(&self) -> &Display {
        &self.outputs.display
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

    /// Every state the machine entered, the power-up state first (at 0 ms).
    #[must_use]
    pub fn transitions(&self) -> &[Transition] {
        &self.transitions
    }

    /// Whether the machine went through `state` at some point.
    #[must_use]
    pub fn visited(&self, state: MachineState) -> bool {
        self.transitions.iter().any(|t| t.state == state)
    }

    /// The recorded rows (empty unless [`Bench::recording`]).
    #[must_use]
    pub fn rows(&self) -> &[Row] {
        self.rows.as_deref().unwrap_or(&[])
    }

    /// Takes the recorded rows out of the bench.
    pub fn take_rows(&mut self) -> Vec<Row> {
        self.rows.take().unwrap_or_default()
    }
}

// ───────────────────────────── sessions ─────────────────────────────

/// The longest a session may take, simulated ms; past it the session stops as incomplete.
pub const SESSION_LIMIT_MS: u64 = 240_000;

/// Why a session could not be completed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum SessionError {
    /// The machine latched a fault during commissioning.
    CommissioningFault(FaultCode),
    /// The machine rejected the calibration (`n-02`).
    CalibrationRejected,
    /// Commissioning ended without the machine storing the settings and calibration.
    NothingStored,
    /// A session did not finish within [`SESSION_LIMIT_MS`].
    Timeout,
}

impl fmt::Display for SessionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::CommissioningFault(code) => {
                write!(f, "the machine faulted during commissioning: {}", fault_name(*code))
            }
            Self::CalibrationRejected => f.write_str("the machine rejected the calibration (n-02)"),
            Self::NothingStored => f.write_str("commissioning ended without a stored record"),
            Self::Timeout => f.write_str("a session did not finish in the simulated time limit"),
        }
    }
}

impl std::error::Error for SessionError {}

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

/// Runs `bench` with `operator` until `done` or [`SESSION_LIMIT_MS`], reporting progress
/// every 50 ms and at each state change (one tick late, with the new state's own display).
/// `done` sees the bench after every tick and may act on it (inject a fault, break the
/// string) before the next.
///
/// # Errors
/// [`SessionError::Timeout`].
pub fn run_session(
    bench: &mut Bench,
    operator: &mut Operator,
    session: Session,
    progress: &mut dyn FnMut(&Progress<'_>),
    mut done: impl FnMut(&mut Bench, &Operator) -> bool,
) -> Result<(), SessionError> {
    let mut last_state = bench.machine().state();
    let mut changed = false;
    for tick in 0..SESSION_LIMIT_MS {
        bench.tick_with(|twin| operator.act(twin));
        if changed || tick % 50 == 0 {
            progress(&Progress {
                session,
                time_s: bench.twin().now_ms() as f64 / 1_000.0,
                state: bench.machine().state(),
                display: bench.outputs().display,
                tension_kgf: bench.twin().truth().tension_kgf,
                activity: operator.activity(),
                state_changed: changed,
            });
        }
        let state = bench.machine().state();
        changed = state != last_state;
        last_state = state;
        if done(bench, operator) {
            return Ok(());
        }
    }
    Err(SessionError::Timeout)
}

/// The machine a commissioning calibrates: all of `config` (load cell, motor, mechanics,
/// current sensing) with a nominal tennis-synthetic test string in it — the calibration is
/// the sensor's, not the job string's, and a job with no string (or a soft one) still gets
/// a calibrated machine.
#[must_use]
pub fn factory_config(config: &TwinConfig) -> TwinConfig {
    let mut factory = *config;
    factory.string = TwinConfig::nominal(StringKind::TennisSynthetic).string;
    factory
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

/// The commissioning session on a new machine built from `config` (use
/// [`factory_config`] for the test string): factory defaults in the flash; the operator
/// calibrates (if `calibrate`) through the machine's calibration states, keys in
/// [`previous_job`], and waits for the machine to store.
///
/// # Errors
/// A fault, a rejected calibration, no store, or the time limit.
pub fn commission(
    config: &TwinConfig,
    calibrate: bool,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<Commissioning, SessionError> {
    let mut bench = Bench::power_up(config, &Record::default().encode());
    let plan = Plan { calibrate, settings: previous_job(), knot_mode: false, pull_hold_ms: None };
    let mut operator = Operator::new(plan);
    let mut rejected = false;
    run_session(&mut bench, &mut operator, Session::Commissioning, progress, |bench, operator| {
        rejected |= bench.machine().notice() == Some(Notice::CalibrationRejected);
        if !operator.finished() {
            return false;
        }
        if operator.stopped() {
            return true;
        }
        Record::decode(bench.flash())
            .is_ok_and(|r| r.settings == plan.settings && (!calibrate || r.calibration.is_some()))
    })?;
    if let Some(code) = bench.machine().fault() {
        return Err(SessionError::CommissioningFault(code));
    }
    if rejected {
        return Err(SessionError::CalibrationRejected);
    }
    let record = Record::decode(bench.flash()).map_err(|_| SessionError::NothingStored)?;
    Ok(Commissioning {
        flash: *bench.flash(),
        record,
        gauge_readings: operator.gauge_readings().to_vec(),
        sim_ms: bench.twin().now_ms(),
        presses: operator.presses(),
    })
}

// ───────────────────────────── the controller bench ─────────────────────────────

/// Why a controller bench could not be built.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum BenchError {
    /// The controller configuration is invalid.
    Controller(ConfigError),
    /// The unloaded load cell reads outside its zero band (the machine's `E-05`).
    LoadCellZero,
}

impl fmt::Display for BenchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Controller(error) => write!(f, "invalid controller configuration ({error:?})"),
            Self::LoadCellZero => f.write_str("the load cell's zero is out of band (E-05)"),
        }
    }
}

impl std::error::Error for BenchError {}

/// One recorded tick of a controller bench.
#[derive(Clone, Copy, Debug)]
pub struct ControllerRow {
    /// Time since Start, s.
    pub t_s: f64,
    /// What the bench sampled.
    pub inputs: Inputs,
    /// The calibrated reading the controller was given, kgf.
    pub measured_kgf: f64,
    /// What the controller answered.
    pub control: ControlOutput,
    /// The physics at the end of the tick.
    pub truth: Truth,
}

/// taut-core's tension controller alone on the twin, with the machine's sensing chain (see
/// the module docs).
pub struct ControllerBench {
    twin: Twin,
    scale: LoadCellScale,
    calibration: Calibration,
    controller: TensionController,
    started_ms: u64,
}

impl ControllerBench {
    /// Powers a twin of `config` up, tares it as the self-test does and builds `controller`
    /// on the twin's board (its dead-time duty the board's, [`board_for`]) with the load-cell
    /// correction `calibration` (from [`calibration_of`] a commissioned
    /// record, or [`Calibration::IDENTITY`] for an uncalibrated machine).
    ///
    /// # Errors
    /// An invalid controller configuration or an out-of-band load-cell zero.
    pub fn new(
        config: &TwinConfig,
        controller: &ControllerConfig,
        calibration: Calibration,
    ) -> Result<Self, BenchError> {
        let on_board =
            ControllerConfig { dead_time_duty: board_for(config).dead_time_duty(), ..*controller };
        let controller = TensionController::new(&on_board).map_err(BenchError::Controller)?;
        let mut twin = Twin::new(config);
        let scale = tare(&mut twin).ok_or(BenchError::LoadCellZero)?;
        let started_ms = twin.now_ms();
        Ok(Self { twin, scale, calibration, controller, started_ms })
    }

    /// Starts a pull.
    pub fn start(&mut self, settings: &PullSettings, kind: PullKind) {
        self.controller.start(settings, kind);
        self.started_ms = self.twin.now_ms();
    }

    /// Releases (back to the home switch).
    pub fn release(&mut self) {
        self.controller.release();
    }

    /// One tick: measure, control, apply, advance.
    pub fn tick(&mut self) -> ControllerRow {
        let (scale, calibration) = (self.scale, self.calibration);
        let controller = &mut self.controller;
        let mut seen = None;
        let row = step(
            &mut self.twin,
            |inputs| {
                let m = measurement(inputs, &scale, &calibration);
                let control = controller.step(&m);
                seen = Some((kgf(m.tension), control));
                Outputs { drive: control.command, ..Outputs::default() }
            },
            |_| {},
        );
        let (measured_kgf, control) = seen.unwrap_or((0.0, self.idle_output()));
        ControllerRow {
            t_s: self.twin.now_ms().saturating_sub(self.started_ms) as f64 / 1_000.0,
            inputs: row.inputs,
            measured_kgf,
            control,
            truth: row.truth,
        }
    }

    fn idle_output(&self) -> ControlOutput {
        ControlOutput {
            command: taut_core::drive::DriveCommand::Coast,
            phase: self.controller.phase(),
            at_tension: false,
            reference: Kgf::ZERO,
            force: Kgf::ZERO,
            tension: Kgf::ZERO,
        }
    }

    /// Runs `ticks` ticks, appending each row to `rows`.
    pub fn run(&mut self, ticks: u32, rows: &mut Vec<ControllerRow>) {
        for _ in 0..ticks {
            rows.push(self.tick());
        }
    }

    /// The twin.
    #[must_use]
    pub const fn twin(&self) -> &Twin {
        &self.twin
    }

    /// The twin, to inject faults.
    pub fn twin_mut(&mut self) -> &mut Twin {
        &mut self.twin
    }

    /// The load-cell correction in use.
    #[must_use]
    pub const fn calibration(&self) -> &Calibration {
        &self.calibration
    }
}

// ───────────────────────────── the oracle ─────────────────────────────

/// The current the bang-bang oracle allows itself, A: below the drive's 12 A software
/// overcurrent limit with margin for the PWM ripple and commutation transients.
pub const ORACLE_CURRENT_LIMIT_A: f64 = 10.0;

/// The physical limit of a pull: the time from Start until the true tension first reaches
/// `target_kgf` when the motor pulls flat out — a bang-bang oracle on the same machine —
/// or `None` if it does not within `limit_ms` (the end of travel first, or the drive
/// faults).
///
/// "Flat out" is full duty except while the rotor is still accelerating, where the oracle,
/// which knows the true speed and motor constants, caps the duty at
/// `(Ke·ω + 2R·I_lim) / V_bus` so the winding current stays below
/// [`ORACLE_CURRENT_LIMIT_A`]: a plain step to 95 % into a standing motor draws ≈ 27 A and
/// the drive's 12 A limit trips, so that is not a pull the machine can make. The oracle
/// measures the mechanism, not the board: it runs with taut's own current sensing (a
/// unidirectional DC-link shunt) whatever `config` has, so the drive's overcurrent check
/// reads the winding current as it was designed to. It starts like a controller bench's
/// pull, after the self-test's [`SELF_TEST_TICKS`] of coasting from power-up.
#[must_use]
pub fn bang_bang_reach_time(config: &TwinConfig, target_kgf: f64, limit_ms: u32) -> Option<f64> {
    let mut config = *config;
    config.current_sense = CurrentSenseParams::nominal();
    let mut twin = Twin::new(&config);
    for _ in 0..SELF_TEST_TICKS {
        step(&mut twin, |_| Outputs::default(), |_| {});
    }
    let start_s = twin.truth().time_s;
    let m = config.motor;
    let two_r = 2.0 * m.phase_resistance_ohm;
    for _ in 0..limit_ms {
        let truth = twin.truth();
        if truth.drive_fault.is_some() {
            return None;
        }
        if truth.tension_kgf >= target_kgf {
            return Some(truth.time_s - start_s);
        }
        let omega = (truth.motor_rpm * core::f64::consts::TAU / 60.0).max(0.0);
        let volts = truth.bus_volts.max(1.0);
        let duty = (m.ke_volts_per_rad_s * omega + two_r * ORACLE_CURRENT_LIMIT_A) / volts;
        let pull = Outputs { drive: drive_at(Direction::Pull, duty), ..Outputs::default() };
        step(&mut twin, |_| pull, |_| {});
    }
    None
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, reason = "a panic is how a test fails")]
mod tests {
    use super::*;
    use taut_core::sense::calibration::CALIBRATION_READINGS;

    #[test]
    fn oracle_reaches_the_target_without_tripping_and_scales_with_slack() {
        let mut config = TwinConfig::nominal(StringKind::TennisSynthetic);
        let t1 = bang_bang_reach_time(&config, 25.0, 10_000).expect("reaches");
        config.string.slack_mm += 20.0;
        let t2 = bang_bang_reach_time(&config, 25.0, 10_000).expect("reaches");
        // 20 mm more slack at the ≈ 67 mm/s full speed: ≈ 0.3 s more.
        assert!((t2 - t1 - 0.3).abs() < 0.05, "{t1} {t2}");
        // 30 mm slack + 25 kgf / 7.6 kgf/cm ≈ 63 mm at ≈ 67 mm/s: about a second.
        assert!(t1 > 0.8 && t1 < 1.3, "{t1}");
        let none = TwinConfig::nominal(StringKind::NoString);
        assert_eq!(bang_bang_reach_time(&none, 25.0, 2_000), None);
    }

    #[test]
    fn oracle_ignores_the_board_it_measures_the_mechanism() {
        let mut config = TwinConfig::nominal(StringKind::TennisSynthetic);
        let nominal = bang_bang_reach_time(&config, 20.0, 10_000).expect("reaches");
        config.current_sense = CurrentSenseParams::per_phase_low_side();
        assert_eq!(bang_bang_reach_time(&config, 20.0, 10_000), Some(nominal));
    }

    #[test]
    fn commissioning_calibrates_through_the_machine_and_the_controller_bench_uses_it() {
        let config = factory_config(&TwinConfig::nominal(StringKind::TennisSynthetic));
        let done = commission(&config, true, &mut |_| {}).expect("commissioned");
        assert_eq!(done.gauge_readings.len(), CALIBRATION_READINGS);
        assert!(done.record.calibration.is_some());
        let calibration = calibration_of(&done.record);
        assert_ne!(calibration, Calibration::IDENTITY);
        let mut bench =
            ControllerBench::new(&config, &ControllerConfig::TAUT, calibration).expect("bench");
        let settings = PullSettings::default().with_tension(Kgf::from_int(20)).expect("20 kgf");
        bench.start(&settings, PullKind::Main);
        let mut rows = Vec::new();
        bench.run(6_000, &mut rows);
        let last = rows.last().expect("rows");
        assert!((last.truth.tension_kgf - 20.0).abs() < 0.15, "{}", last.truth.tension_kgf);
    }

    #[test]
    fn the_bench_records_rows_and_transitions() {
        let mut bench = Bench::nominal(StringKind::TennisGut).recording();
        bench.run(3_000);
        assert_eq!(bench.rows().len(), 3_000);
        assert_eq!(bench.transitions().first().map(|t| t.state), Some(MachineState::SelfTest));
        assert!(bench.visited(MachineState::Homing));
        assert_eq!(bench.rows().last().map(|r| r.t_ms), Some(3_000));
    }
}

//! The twin itself: the machine's physics around taut-core's own drive, stepped one
//! millisecond at a time.
//!
//! # Theory of operation
//!
//! A [`Twin`] owns a [`taut_core::drive::Drive`] exactly as the firmware's PWM interrupt
//! does. [`Twin::advance_tick`] simulates one 1 ms control tick as twenty 50 µs PWM
//! periods; in each one it
//!
//! 1. reads the Hall sensors from the rotor's electrical angle (mounting offset, stuck
//!    lines, read glitches voted over seven reads with `taut_core::drive::hall::vote`,
//!    injected glitch bursts),
//! 2. calls `Drive::step` with that code, the previous period's bus-current sample and
//!    comparator flag, the (possibly miswired) limit switches and one PWM period of
//!    elapsed time ([`PWM_PERIOD`], 50 µs of the drive's `DriveTime`),
//! 3. applies the returned switch pattern and duty to the three-phase winding model
//!    ([`crate::motor`]) with the back-EMF of the current speed and angle,
//! 4. turns the mean phase currents into torque and moves the rotor, gearbox, screw and
//!    carriage as one rigid body with load-dependent Coulomb friction (the gearbox and
//!    screw efficiencies), static friction, viscous loss, cogging and hard end stops,
//! 5. stretches the string ([`crate::string`]) and filters the load-cell amplifier.
//!
//! 6. charges or discharges the DC bus with what the bridge drew in the period.
//!
//! At the end of the tick the sensors are sampled into an [`Inputs`] snapshot: what the
//! firmware would read at the start of the next tick. The controller under test reads
//! [`Twin::inputs`], decides, and hands its [`Outputs`] to [`Twin::apply`]; the panel
//! outputs are recorded. [`Twin::truth`] reports the physical state the sensors only
//! approximate.
//!
//! # Mechanics in one line
//!
//! Everything is referred to the motor shaft, with `r = lead / (2π·ratio)` metres of
//! carriage per motor radian:
//!
//! ```text
//! J·dω/dt = T_em + T_cog − r·F_string − B·ω − sgn(ω)·(T₀ + a·r·|F_string| + b·|T_em|)
//! J = J_rotor + J_gear + m·r²
//! ```
//!
//! where `a` and `b` reproduce the forward and back-driven efficiencies (see
//! `MechanicsParams::friction_coefficients`). At rest the same friction times the
//! stiction ratio must be exceeded before the carriage moves.
//!
//! # The DC bus
//!
//! The bridge's switched leg is complementary (see [`crate::motor`]), so a duty below the
//! back-EMF ratio brakes the motor and returns energy to the bus. A bench supply cannot
//! sink that current, so the bus is modelled as it is built: the supply, an ideal source at
//! `bus_volts` behind `supply_ohm`, feeds the bulk capacitance `C` through a blocking diode
//! (an ideal-diode OR-ing stage), and the rest of the machine draws a constant auxiliary
//! current. Per PWM period, with `i` the bridge's mean current from the bus
//! ([`crate::motor::PeriodResult::bus_charge`] over the period) plus the auxiliary load:
//!
//! ```text
//! C·dv/dt = max(0, (V_s − v)/R_s) − i
//! ```
//!
//! solved exactly for constant `i` (exponential toward `V_s − R_s·i` while the diode
//! conducts, a straight line while it blocks, the switch between them located
//! analytically). The bridge sees the bus voltage of the start of each period; the truth
//! reports it ([`Truth::bus_volts`]) and its highest value in the tick
//! ([`Truth::bus_peak_volts`]). Regenerated energy has nowhere to go but the capacitor and
//! the auxiliary load, so braking pumps the bus up — to the **clamp**
//! (`BridgeParams::clamp_volts`, a TVS or brake chopper) if the board has one: the bus
//! then stays at the clamp voltage and the clamp burns the rest ([`Truth::bus_clamped`]).
//! The voltage is exact per period and rises monotonically within one while it pumps, so
//! `min(v, clamp)` at the period's end is the exact clamped solution.
//!
//! # Backlash
//!
//! With `MechanicsParams::backlash_mm > 0` the drivetrain is two bodies: the motor side
//! (rotor, gearbox, screw: `J_m = J_rotor + J_gear`) and the carriage with its gripper
//! (mass `m`), coupled through a dead band of width `b` in the carriage's position
//! relative to the screw, `g = x − r·θ ∈ [−b/2, +b/2]`. At `g = −b/2` the screw pushes the
//! carriage toward the pull (the **pull flank**, where string tension keeps it), at `+b/2`
//! toward home (the **release flank**). While a flank is engaged the two move as the rigid
//! body above; the flank lets go when the force it must pass, `m·a + T + F_slide`, would
//! change sign. In between, each body moves on its own (the motor side with its own
//! Coulomb friction and drag, the carriage with the string and the slide's friction, both
//! with stiction), and on reaching a flank they merge in a perfectly inelastic impact
//! (momentum kept). So after a release the motor turns `b / r` before a pull moves the
//! carriage or loads the string.
//!
//! # The gripper on the load cell
//!
//! The gripper (mass `m_g`, `MechanicsParams::gripper`) hangs on the load cell, outboard of
//! it: the load cell carries the string tension plus the force that accelerates the
//! gripper, through its own spring `k` (damping ratio `ζ`):
//!
//! ```text
//! F_cell'' + 2ζω_n·F_cell' + ω_n²·F_cell = ω_n²·(T + m_g·a),   ω_n = √(k / m_g)
//! ```
//!
//! with `a` the carriage's acceleration in each 50 µs step, solved exactly for an input
//! held over the step. So the reading is `T + m_g·a` smoothed by a 200–800 Hz resonance, and
//! an impact (an end stop, the backlash taken up at speed) rings the load cell.
//! [`Truth::load_cell_force_kgf`] is `F_cell`; with `m_g = 0` it is the tension.

use taut_core::drive::duty::DUTY_ONE;
use taut_core::drive::{
    Drive, DriveCommand, DriveFault, DriveSample, DriveTime, HallCode, LegState, Phase,
    SwitchPattern, TIME_UNITS_PER_SECOND, hall,
};
use taut_core::io::{Inputs, Keys, LimitSwitches, Outputs};
use taut_core::units::AdcCode;

use crate::drift::{Drift, DriftParams};
use crate::motor::{Circuit, emf_shape, hall_code_placed, sector_shape_factor};
use crate::params::{NEWTONS_PER_KGF, StringParams, TwinConfig};
use crate::rng::SimRng;
use crate::sensors::{BusVoltageSense, CurrentSense, LoadCell, LoadCellFault};
use crate::string::{StringModel, StringState};

/// The twin's board's PWM frequency: 20 kHz, as taut's (`firmware/src/timing.rs`).
pub const PWM_FREQUENCY_HZ: u32 = 20_000;

/// One PWM period in the drive's time: 50 µs.
pub const PWM_PERIOD: DriveTime = DriveTime(TIME_UNITS_PER_SECOND / PWM_FREQUENCY_HZ);

/// PWM periods per 1 ms tick: 20 kHz / 1 kHz.
pub const PERIODS_PER_TICK: u32 = PWM_FREQUENCY_HZ / 1_000;

/// One PWM period, s.
pub const PWM_PERIOD_S: f64 = 1.0 / PWM_FREQUENCY_HZ as f64;

/// One control tick, s.
pub const TICK_S: f64 = 1e-3;

/// Which limit switch.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum LimitSwitch {
    /// The home (released) end.
    Home,
    /// The far (pulled) end.
    End,
}

/// A fault the twin can be told to exhibit ([`Twin::inject`]).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Fault {
    /// One Hall line reads `level` whatever the rotor does (broken wire, dead sensor).
    HallLineStuck {
        /// The phase whose sensor is stuck.
        phase: Phase,
        /// The level it is stuck at.
        level: bool,
    },
    /// The Hall lines read `code` for the next `periods` PWM periods (a noise burst long
    /// enough to survive the vote).
    HallGlitch {
        /// What the lines read.
        code: HallCode,
        /// For how many PWM periods.
        periods: u32,
    },
    /// A limit switch's wiring reads `closed` whatever the carriage does.
    LimitSwitchStuck {
        /// Which switch.
        switch: LimitSwitch,
        /// The level it reads.
        closed: bool,
    },
    /// The load cell's wiring fails.
    LoadCell(LoadCellFault),
    /// The current-sense amplifier output is lost (reads 0 A): only the hardware
    /// comparator still sees the current.
    CurrentSenseOpen,
    /// The carriage is mechanically seized (stall): the rotor stops with it.
    CarriageJam,
    /// An inter-turn short in one phase: `shorted_percent` % of its turns are shorted, so its
    /// resistance, inductance and back-EMF fall to what the remaining turns give (see
    /// [`crate::motor`]) and the current through it rises far above what the duty would
    /// drive through a healthy winding. Clamped to 1–95 %.
    ShortedPhase {
        /// The phase.
        phase: Phase,
        /// Share of the phase's turns shorted, %.
        shorted_percent: u8,
    },
    /// The string breaks (now, or at the tick [`Twin::inject_at`] names). Clearing injected
    /// faults does not mend it.
    StringBreak,
}

/// The faults currently injected.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
struct ActiveFaults {
    hall_stuck: [Option<bool>; 3],
    glitch: Option<(HallCode, u32)>,
    home: Option<bool>,
    end: Option<bool>,
    load_cell: Option<LoadCellFault>,
    current_open: bool,
    jam: bool,
    short: Option<(Phase, u8)>,
}

/// What the board's pins see, for a bench that runs the firmware itself ([`Twin::pins`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pins {
    /// The Hall lines' code as wired (stuck lines included).
    pub hall: HallCode,
    /// The limit switches as wired (`true` = actuated).
    pub limits: LimitSwitches,
    /// The overcurrent comparator fired in the last period.
    pub comparator: bool,
    /// The current amplifier's code of the last period's on-time sample (5 V meaning).
    pub current: AdcCode,
    /// The DC bus voltage, V.
    pub bus_volts: f64,
}

/// The physical state, which the sensors only approximate.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Truth {
    /// Time since power-up, s.
    pub time_s: f64,
    /// String tension at the load cell, kgf.
    pub tension_kgf: f64,
    /// Carriage position, mm (0 = where the home switch closes; increasing = pulling).
    pub carriage_mm: f64,
    /// Carriage velocity, mm/s (positive = pulling).
    pub carriage_mm_per_s: f64,
    /// How many times since power-up the carriage has met the end stop past the home switch
    /// (each arrival once, however long it stays there).
    pub end_stop_hits: u32,
    /// Motor speed, rpm (positive = forward, the pull direction).
    pub motor_rpm: f64,
    /// Winding current, mean over the last tick of `(|i_a| + |i_b| + |i_c|) / 2` (the
    /// current through the driven pair), A.
    pub current_a: f64,
    /// Largest phase current magnitude during the last tick, A.
    pub peak_current_a: f64,
    /// Electromagnetic torque, mean over the last tick, N·m (positive = pull).
    pub torque_nm: f64,
    /// Duty applied in the last PWM period, fraction of the period (0 when no high side
    /// conducted).
    pub duty: f64,
    /// The switch pattern of the last PWM period.
    pub pattern: SwitchPattern,
    /// The drive's latched fault.
    pub drive_fault: Option<DriveFault>,
    /// The drive's count of calls since power-up that coasted under a drive command because
    /// its duty window was empty (`Drive::coasting`): torque asked for and none given.
    pub drive_coasting: u32,
    /// The hardware overcurrent comparator fired during the last tick.
    pub comparator_tripped: bool,
    /// The string's state.
    pub string: StringState,
    /// How fast the string's tension would fall at constant length, kgf/s (its creep:
    /// the relaxation arms' `Σ aᵢ/τᵢ`).
    pub string_relaxation_kgf_per_s: f64,
    /// The limit switches as the carriage actuates them (before any wiring fault).
    pub limits: LimitSwitches,
    /// The Hall code the rotor angle produces (before glitches and faults).
    pub hall: HallCode,
    /// The carriage is held by static friction.
    pub stuck: bool,
    /// String drawn through the tension head since power-up, mm.
    pub string_travel_mm: f64,
    /// Load-cell amplifier output before noise and spikes, V.
    pub load_cell_volts: f64,
    /// DC bus voltage at the end of the tick, V.
    pub bus_volts: f64,
    /// Highest DC bus voltage during the tick, V.
    pub bus_peak_volts: f64,
    /// The bus clamp conducted during the tick (the bus reached `clamp_volts`).
    pub bus_clamped: bool,
    /// Winding current of the driven pair, signed: the current out of the motor through
    /// the pattern's low leg (positive in the commanded direction, negative while braking;
    /// outside the commutation transients the current through both driven windings), mean
    /// over the tick, A; zero in periods with no driven pair (coast), where
    /// [`Truth::current_a`] still shows any current decaying through the body diodes.
    pub winding_current_a: f64,
    /// The force on the load cell's spring: the string tension plus the gripper's inertial
    /// force and ringing (equal to the tension with no gripper mass), kgf.
    pub load_cell_force_kgf: f64,
    /// Where the carriage sits in the backlash, mm: `−b/2` on the pull flank (string
    /// tension keeps it there), `+b/2` on the release flank; always 0 without backlash.
    pub backlash_mm: f64,
}

/// Per-tick sums.
#[derive(Clone, Copy, Debug, Default)]
struct TickSums {
    current: f64,
    torque: f64,
    measured_current: f64,
    peak: f64,
    comparator: bool,
    bus_peak: f64,
    clamped: bool,
    winding: f64,
    /// Σ i² over the phases and periods, A² (the copper loss's sum).
    current_squared: f64,
}

/// Which flank of the backlash the carriage rests on.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Flank {
    /// `g = −b/2`: the screw pushes the carriage toward the pull.
    Pull,
    /// `g = +b/2`: the screw pushes the carriage toward home.
    Release,
    /// In the dead band: the bodies move on their own.
    Free,
}

/// The gripper ringing on the load cell: the exact discrete-time transition of the
/// second-order response over one PWM period, and its state.
#[derive(Clone, Copy, Debug)]
struct GripperRing {
    /// State transition over one period of `[F − F_in, F']`.
    phi: [[f64; 2]; 2],
    /// Gripper mass, kg.
    mass_kg: f64,
    /// The load cell's force, N.
    force: f64,
    /// Its rate, N/s.
    rate: f64,
}

impl GripperRing {
    /// The transition of `F'' + 2ζω·F' + ω²·F = ω²·F_in` over `dt` for an input held over
    /// it, in deviation coordinates `[F − F_in, F']` (underdamped, `ζ < 1`).
    fn new(mass_kg: f64, stiffness: f64, zeta: f64, dt: f64) -> Self {
        let omega = (stiffness / mass_kg).sqrt();
        let sigma = zeta * omega;
        let omega_d = omega * (1.0 - zeta * zeta).sqrt();
        let decay = (-sigma * dt).exp();
        let (sin, cos) = (omega_d * dt).sin_cos();
        let phi = [
            [decay * (cos + sigma / omega_d * sin), decay * sin / omega_d],
            [-decay * omega * omega / omega_d * sin, decay * (cos - sigma / omega_d * sin)],
        ];
        Self { phi, mass_kg, force: 0.0, rate: 0.0 }
    }

    /// Advances one period under tension `tension_n` and carriage acceleration `accel`;
    /// returns the load cell's force, N.
    fn step(&mut self, tension_n: f64, accel: f64) -> f64 {
        let input = tension_n + self.mass_kg * accel;
        let [[a, b], [c, d]] = self.phi;
        let deviation = self.force - input;
        self.force = input + a * deviation + b * self.rate;
        self.rate = c * deviation + d * self.rate;
        self.force
    }
}

/// The digital twin of the stringing machine. See the module docs.
#[derive(Clone, Debug)]
pub struct Twin {
    config: TwinConfig,
    drive: Drive,
    circuit: Circuit,
    current_sense: CurrentSense,
    bus_sense: BusVoltageSense,
    load_cell: LoadCell,
    string: StringModel,
    gripper: Option<GripperRing>,
    // Derived constants.
    ke_phase: f64,
    metres_per_rad: f64,
    inertia: f64,
    coulomb: f64,
    load_friction: f64,
    motor_friction: f64,
    viscous: f64,
    theta_e_offset_deg: f64,
    cogging_phase: f64,
    low_stop_m: f64,
    high_stop_m: f64,
    /// Arrivals at the low (home-side) stop, and whether the carriage is resting on it.
    end_stop: (u32, bool),
    /// Backlash at the carriage, m (0: rigid drivetrain).
    backlash_m: f64,
    /// Motor-side inertia (rotor, gearbox, screw), kg·m².
    motor_inertia: f64,
    /// Moving mass at the carriage (carriage and gripper), kg.
    carriage_mass: f64,
    /// Coulomb friction of the motor side alone (bearings, drag), N·m.
    motor_side_coulomb: f64,
    /// Slide friction of the carriage alone, N.
    slide_friction: f64,
    // State.
    ticks: u64,
    currents: [f64; 3],
    theta: f64,
    omega: f64,
    stuck: bool,
    /// Carriage position relative to the screw within the backlash, m.
    gap_m: f64,
    /// Carriage velocity, m/s.
    carriage_v: f64,
    carriage_stuck: bool,
    flank: Flank,
    /// The load cell's force, N.
    load_cell_force_n: f64,
    bus_volts: f64,
    string_travel_m: f64,
    current_code: AdcCode,
    comparator_flag: bool,
    last_pattern: SwitchPattern,
    last_duty: f64,
    last_switching: bool,
    last_commutated: bool,
    last_amps: f64,
    sums: TickSums,
    rng_load_cell: SimRng,
    rng_current: SimRng,
    rng_hall: SimRng,
    /// PWM periods until the next Hall burst.
    hall_burst_in: u64,
    /// Read-line trials (7 reads × 3 lines per period) until the next flipped read.
    hall_flip_in: u64,
    rng_gauge: SimRng,
    rng_bus: SimRng,
    faults: ActiveFaults,
    scheduled: Vec<(u64, Fault)>,
    keys: Keys,
    key_events: Vec<(u64, Keys)>,
    sampled: Inputs,
    outputs: Outputs,
    truth: Truth,
    /// The working day's drifts, when a session enabled them.
    drift: Option<DayDrift>,
}

/// The drifts of a working day and the twin's values they scale (see [`crate::drift`]).
#[derive(Clone, Copy, Debug)]
struct DayDrift {
    drift: Drift,
    cold_resistance: f64,
    coulomb: f64,
    motor_side_coulomb: f64,
    slide_friction: f64,
    position_m: f64,
}

impl Twin {
    /// This twin with its drive in plain voltage mode: the current window opened to just
    /// below the trip with a resistance far above the motor's, so the duty passes unchanged.
    /// For the physics tests that must drive currents taut's current-limited drive never asks
    /// for (a stall at high duty, a shorted phase past the trip); never for taut's figures.
    #[must_use]
    pub fn with_voltage_mode_drive(mut self) -> Self {
        use taut_core::drive::limit::{BusSense, CurrentLimit};
        let board = self.config.board;
        let sense = self.config.current_sense.drive_config(&board).sense();
        let open = CurrentLimit {
            limit_ma: board.overcurrent_ma.saturating_sub(1_000),
            resistance_mohm: 5_000,
            fold_back_ma: board.overcurrent_ma.saturating_sub(1),
            ..CurrentLimit::PAPER
        };
        // No bus rule and no zero check either: the physics under test must not be cut short.
        let bus = BusSense { regen_mv: 59_000, max_mv: 59_900, ..BusSense::PAPER };
        let sense = taut_core::drive::limit::CurrentSense { zero_tolerance: 4_095, ..sense };
        if let Ok(config) = taut_core::drive::DriveConfig::new(
            sense,
            bus,
            open,
            board.overcurrent_ma,
            board.dead_time,
        ) {
            self.drive = Drive::with_config(config);
        }
        self
    }
}

impl Twin {
    /// A machine at power-up: carriage resting on the home switch, rotor at a random
    /// (seeded) angle, drive coasting, string (if any) slack.
    #[must_use]
    pub fn new(config: &TwinConfig) -> Self {
        let c = *config;
        let m = &c.motor;
        let k = &c.mechanics;
        let metres_per_rad = k.metres_per_radian();
        let (a, b) = k.friction_coefficients();
        let moving_mass = k.carriage_mass_kg + k.gripper.mass_kg;
        let (inertia, coulomb, load_friction, motor_friction) = if k.decoupled {
            (m.rotor_inertia_kg_m2, m.coulomb_torque_nm, 0.0, 0.0)
        } else {
            (
                m.rotor_inertia_kg_m2
                    + k.gear_inertia_kg_m2
                    + moving_mass * metres_per_rad * metres_per_rad,
                m.coulomb_torque_nm + k.drag_torque_nm + k.slide_friction_n * metres_per_rad,
                a,
                b,
            )
        };
        let shape = sector_shape_factor(m.emf_ramp_deg).max(1e-6);
        let mut setup = SimRng::substream(c.seed, 0x5E70);
        let start_m = k.start_mm * 1e-3;
        let backlash_m = if k.decoupled { 0.0 } else { k.backlash_mm.max(0.0) * 1e-3 };
        // Powered up long ago: the capacitor sits where the auxiliary load holds it.
        let bus_volts = c.bridge.bus_volts - c.bridge.supply_ohm * c.bridge.aux_load_amps;
        let gripper = (k.gripper.mass_kg > 0.0 && !k.decoupled).then(|| {
            GripperRing::new(
                k.gripper.mass_kg,
                k.gripper.load_cell_stiffness_n_per_m,
                k.gripper.damping_ratio,
                PWM_PERIOD_S,
            )
        });
        let mut twin = Self {
            config: c,
            drive: Drive::with_config(c.current_sense.drive_config(&c.board)),
            circuit: Circuit {
                resistance: m.phase_resistance_ohm,
                inductance: m.phase_inductance_h,
                bus_volts: c.bridge.bus_volts,
                diode_drop: c.bridge.diode_drop_v,
                comparator_amps: c.bridge.comparator_amps,
                dead_time: c.bridge.dead_time_s,
                phase_scale: Circuit::HEALTHY,
            },
            current_sense: CurrentSense::new(&c.current_sense, c.board.adc_reference),
            bus_sense: BusVoltageSense::new(&c.bus_sense, bus_volts, c.board.adc_reference),
            load_cell: LoadCell::new(&c.load_cell, c.board.adc_reference),
            // The carriage rests on the release flank: homing drove it there.
            string: StringModel::new(&c.string, start_m),
            gripper,
            ke_phase: m.ke_volts_per_rad_s / (2.0 * shape),
            metres_per_rad,
            inertia,
            coulomb,
            load_friction,
            motor_friction,
            viscous: m.viscous_nm_per_rad_s,
            theta_e_offset_deg: setup.range(0.0, 360.0),
            cogging_phase: setup.range(0.0, core::f64::consts::TAU),
            low_stop_m: (k.home_switch_mm - k.overtravel_mm) * 1e-3,
            end_stop: (0, false),
            high_stop_m: (k.end_switch_mm + k.overtravel_mm) * 1e-3,
            backlash_m,
            motor_inertia: m.rotor_inertia_kg_m2 + k.gear_inertia_kg_m2,
            carriage_mass: moving_mass,
            motor_side_coulomb: m.coulomb_torque_nm + k.drag_torque_nm,
            slide_friction: k.slide_friction_n,
            ticks: 0,
            currents: [0.0; 3],
            theta: (start_m - 0.5 * backlash_m) / metres_per_rad,
            omega: 0.0,
            stuck: true,
            gap_m: 0.5 * backlash_m,
            carriage_v: 0.0,
            carriage_stuck: true,
            flank: Flank::Release,
            load_cell_force_n: 0.0,
            bus_volts,
            string_travel_m: 0.0,
            // The converter holds the amplifier's rest output before the first period (not
            // code 0, which a mid-rail board reads as −25 A).
            current_code: CurrentSense::new(&c.current_sense, c.board.adc_reference).rest_code(),
            comparator_flag: false,
            last_pattern: SwitchPattern::ALL_OFF,
            last_duty: 0.0,
            last_switching: false,
            last_commutated: false,
            last_amps: 0.0,
            sums: TickSums::default(),
            rng_load_cell: SimRng::substream(c.seed, 1),
            rng_current: SimRng::substream(c.seed, 2),
            rng_hall: SimRng::substream(c.seed, 3),
            hall_burst_in: u64::MAX,
            hall_flip_in: u64::MAX,
            rng_gauge: SimRng::substream(c.seed, 4),
            rng_bus: SimRng::substream(c.seed, 5),
            faults: ActiveFaults::default(),
            scheduled: Vec::new(),
            keys: Keys::NONE,
            key_events: Vec::new(),
            sampled: Inputs::default(),
            outputs: Outputs::default(),
            drift: None,
            truth: Truth {
                time_s: 0.0,
                tension_kgf: 0.0,
                carriage_mm: k.start_mm,
                carriage_mm_per_s: 0.0,
                end_stop_hits: 0,
                motor_rpm: 0.0,
                current_a: 0.0,
                peak_current_a: 0.0,
                torque_nm: 0.0,
                duty: 0.0,
                pattern: SwitchPattern::ALL_OFF,
                drive_fault: None,
                drive_coasting: 0,
                comparator_tripped: false,
                string: StringState::Absent,
                string_relaxation_kgf_per_s: 0.0,
                limits: LimitSwitches::default(),
                hall: HallCode::from_raw(0),
                stuck: true,
                string_travel_mm: 0.0,
                load_cell_volts: 0.0,
                bus_volts: c.bridge.bus_volts,
                bus_peak_volts: c.bridge.bus_volts,
                bus_clamped: false,
                winding_current_a: 0.0,
                load_cell_force_kgf: 0.0,
                backlash_mm: 0.0,
            },
        };
        twin.hall_burst_in = twin.rng_hall.geometric_gap(c.hall.burst_probability);
        twin.hall_flip_in = twin.rng_hall.geometric_gap(c.hall.read_flip_probability);
        twin.sample_sensors();
        twin
    }

    /// The configuration this twin was built from.
    #[must_use]
    pub const fn config(&self) -> &TwinConfig {
        &self.config
    }

    /// What the firmware would sample at the start of this tick: the converter codes, the
    /// encoder count and the drive status as they were at the end of the last tick; the
    /// digital levels (keys, limit switches) as they are now, so a key press or wiring
    /// fault set between ticks is seen at once.
    #[must_use]
    pub fn inputs(&self) -> Inputs {
        Inputs { keys: self.keys, limits: self.wired_limits(), ..self.sampled }
    }

    /// Applies one tick's outputs: the drive's through `Drive::apply` (the command, then a
    /// clear request), and the panel outputs are recorded.
    pub fn apply(&mut self, outputs: &Outputs) {
        // A refused clear leaves the fault latched; the machine sees it in `Inputs::drive`.
        let _refused = self.drive.apply(outputs.drive, outputs.clear_drive_fault);
        self.outputs = *outputs;
    }

    /// The outputs last applied (display, LEDs, beeper, store request, drive command).
    #[must_use]
    pub const fn outputs(&self) -> &Outputs {
        &self.outputs
    }

    /// The drive inside the twin (its fault, status, pattern), for tests.
    #[must_use]
    pub const fn drive(&self) -> &Drive {
        &self.drive
    }

    /// The current code of the last PWM period: what the drive got as
    /// `DriveSample::current` (the tick's `Inputs::motor_current` is the mean of twenty).
    #[must_use]
    pub const fn current_sample(&self) -> AdcCode {
        self.current_code
    }

    /// The current-sensing chain (design gain and offset: decode codes with
    /// [`CurrentSense::amps_of`]).
    #[must_use]
    pub const fn current_sense(&self) -> &CurrentSense {
        &self.current_sense
    }

    /// The bus-voltage divider and oversampler (decode codes with
    /// [`BusVoltageSense::volts_of`]).
    #[must_use]
    pub const fn bus_sense(&self) -> &BusVoltageSense {
        &self.bus_sense
    }

    /// Milliseconds since power-up (the value `Inputs::now_ms` carries, unwrapped).
    #[must_use]
    pub const fn now_ms(&self) -> u64 {
        self.ticks
    }

    /// The physical state at the end of the last tick.
    #[must_use]
    pub const fn truth(&self) -> Truth {
        self.truth
    }

    /// Holds `keys` down until changed.
    pub fn set_keys(&mut self, keys: Keys) {
        self.keys = keys;
    }

    /// Presses `keys` now and releases them (all keys up) `for_ms` ticks later.
    pub fn press(&mut self, keys: Keys, for_ms: u64) {
        self.keys = keys;
        self.schedule_keys(self.ticks.saturating_add(for_ms), Keys::NONE);
    }

    /// From tick `at_ms` on, the keys read `keys` (until the next scheduled change or
    /// [`Twin::set_keys`]). A script of presses is a list of these.
    pub fn schedule_keys(&mut self, at_ms: u64, keys: Keys) {
        let index = self.key_events.partition_point(|&(at, _)| at <= at_ms);
        self.key_events.insert(index, (at_ms, keys));
    }

    /// What a reference tension gauge in the string path reads now: the true tension plus
    /// normal error of the configured σ (0.02 kgf nominal), kgf.
    pub fn reference_gauge(&mut self) -> f64 {
        self.truth.tension_kgf + self.rng_gauge.gaussian(self.config.reference_gauge_sigma_kgf)
    }

    /// Breaks the string now.
    pub fn break_string(&mut self) {
        self.string.break_now();
    }

    /// Fits a new string of the configured kind in the gripper, with the carriage where it
    /// is: its slack is taken up from here, as when a stringer re-strings after a break.
    pub fn fit_new_string(&mut self) {
        self.string = StringModel::new(&self.config.string, self.position_m());
    }

    /// Fits `string` in the gripper with the carriage where it is — the calibration fixture
    /// ([`StringParams::calibration_fixture`]), or a string other than the configured one:
    /// its slack is taken up from here. [`Twin::fit_new_string`] puts the configured kind back.
    pub fn fit_string(&mut self, string: &StringParams) {
        self.string = StringModel::new(string, self.position_m());
    }

    /// Adds `kgf` (at the configured sensitivity) to each of the next `samples` load-cell
    /// samples: a burst of spikes placed exactly, for tests.
    pub fn inject_load_cell_burst(&mut self, samples: u32, kgf: f64) {
        self.load_cell.inject_burst(samples, kgf * self.config.load_cell.volts_per_kgf);
    }

    /// Starts exhibiting `fault` now (until [`Twin::clear_injected`]).
    pub fn inject(&mut self, fault: Fault) {
        let f = &mut self.faults;
        match fault {
            Fault::HallLineStuck { phase, level } => {
                if let Some(slot) = f.hall_stuck.get_mut(phase_index(phase)) {
                    *slot = Some(level);
                }
            }
            Fault::HallGlitch { code, periods } => f.glitch = Some((code, periods)),
            Fault::LimitSwitchStuck { switch: LimitSwitch::Home, closed } => f.home = Some(closed),
            Fault::LimitSwitchStuck { switch: LimitSwitch::End, closed } => f.end = Some(closed),
            Fault::LoadCell(fault) => f.load_cell = Some(fault),
            Fault::CurrentSenseOpen => f.current_open = true,
            Fault::CarriageJam => f.jam = true,
            Fault::ShortedPhase { phase, shorted_percent } => {
                let percent = shorted_percent.clamp(1, 95);
                f.short = Some((phase, percent));
                let mut scale = Circuit::HEALTHY;
                if let Some(s) = scale.get_mut(phase_index(phase)) {
                    *s = 1.0 - f64::from(percent) / 100.0;
                }
                self.circuit.phase_scale = scale;
            }
            Fault::StringBreak => self.string.break_now(),
        }
    }

    /// Schedules `fault` to start at the beginning of tick `at_ms` (the tick that begins
    /// when [`Twin::now_ms`] reads `at_ms`): the physics of that millisecond already has it,
    /// and the [`Inputs`] of the next tick are the first to show its effect. A time already
    /// past injects at the start of the next tick. Deterministic: the schedule is part of
    /// the run, like the keys.
    pub fn inject_at(&mut self, at_ms: u64, fault: Fault) {
        let index = self.scheduled.partition_point(|&(at, _)| at <= at_ms);
        self.scheduled.insert(index, (at_ms, fault));
    }

    /// Removes every injected fault (a broken string stays broken); scheduled ones still
    /// come.
    pub fn clear_injected(&mut self) {
        self.faults = ActiveFaults::default();
        self.circuit.phase_scale = Circuit::HEALTHY;
    }

    /// Enables the working day's drifts ([`crate::drift`]) from now on: the winding's
    /// resistance, the load cell's zero and creep and the drivetrain's friction follow them
    /// tick by tick (and over [`Twin::idle`]).
    pub fn enable_drift(&mut self, params: DriftParams) {
        self.drift = Some(DayDrift {
            drift: Drift::new(params),
            cold_resistance: self.circuit.resistance,
            coulomb: self.coulomb,
            motor_side_coulomb: self.motor_side_coulomb,
            slide_friction: self.slide_friction,
            position_m: self.position_m(),
        });
    }

    /// The working day's drifts, if enabled.
    #[must_use]
    pub fn drift(&self) -> Option<&Drift> {
        self.drift.as_ref().map(|d| &d.drift)
    }

    /// Lets `seconds` of the day pass at rest without simulating them tick by tick (the
    /// stringer between pulls: the motor coasts, so no copper loss; the load cell's load is
    /// the present one). Only the drifts move (the day's, and the load-cell amplifier's
    /// warm-up); the machine sees their result from the next tick on.
    pub fn idle(&mut self, seconds: f64) {
        let load_kgf = self.load_cell_force_n / NEWTONS_PER_KGF;
        if let Some(day) = &mut self.drift {
            day.drift.step(seconds.max(0.0), 0.0, load_kgf, 0.0);
        }
        self.load_cell.idle(seconds);
        self.apply_drift();
    }

    /// How far the load-cell amplifier's zero has moved since power-up as the chain warms
    /// (`LoadCellParams::zero_drift_volts_per_s`), in kgf of reading.
    #[must_use]
    pub fn load_cell_warm_up_kgf(&self) -> f64 {
        self.load_cell.warm_up_volts() / self.config.load_cell.volts_per_kgf
    }

    /// One step of the drifts over the tick just simulated.
    fn step_drift(&mut self, dt: f64) {
        let periods = f64::from(PERIODS_PER_TICK);
        let copper_w = self.sums.current_squared / periods * self.circuit.resistance;
        let load_kgf = self.load_cell_force_n / NEWTONS_PER_KGF;
        let position = self.position_m();
        if let Some(day) = &mut self.drift {
            day.drift.step(dt, copper_w, load_kgf, position - day.position_m);
            day.position_m = position;
        }
        self.apply_drift();
    }

    /// Sets the drifted values.
    fn apply_drift(&mut self) {
        if let Some(day) = &self.drift {
            let d = &day.drift;
            self.circuit.resistance = day.cold_resistance * d.resistance_factor();
            let wear = d.friction_factor();
            self.coulomb = day.coulomb * wear;
            self.motor_side_coulomb = day.motor_side_coulomb * wear;
            self.slide_friction = day.slide_friction * wear;
            self.load_cell.set_drift_kgf(d.offset_kgf());
        }
    }

    /// One millisecond of physics: twenty PWM periods, then the sensors are sampled.
    pub fn advance_tick(&mut self) {
        self.begin_tick();
        // Constant bound: PERIODS_PER_TICK (20) PWM periods.
        for _ in 0..PERIODS_PER_TICK {
            self.pwm_period();
        }
        self.end_tick();
    }

    /// The start of a tick when the bridge is driven from outside (a processor-in-the-loop
    /// bench running the firmware itself): scheduled faults land, the tick's sums restart.
    /// Then [`Twin::external_period`] once per PWM period, then [`Twin::end_tick`].
    pub fn begin_tick(&mut self) {
        while let Some(&(at, fault)) = self.scheduled.first() {
            if at > self.ticks {
                break;
            }
            self.scheduled.remove(0);
            self.inject(fault);
        }
        self.sums = TickSums::default();
    }

    /// The end of a tick begun with [`Twin::begin_tick`]: the key events due, the sensors
    /// sampled into [`Twin::inputs`].
    pub fn end_tick(&mut self) {
        self.ticks = self.ticks.wrapping_add(1);
        self.step_drift(TICK_S);
        while let Some(&(at, keys)) = self.key_events.first() {
            if at > self.ticks {
                break;
            }
            self.keys = keys;
            self.key_events.remove(0);
        }
        self.sample_sensors();
    }

    /// Carriage position, m.
    fn position_m(&self) -> f64 {
        self.theta * self.metres_per_rad + self.gap_m
    }

    /// Electrical angle, degrees (unreduced).
    fn theta_e_deg(&self) -> f64 {
        f64::from(self.config.motor.pole_pairs) * self.theta.to_degrees() + self.theta_e_offset_deg
    }

    /// The limit switches as actuated by the carriage.
    fn true_limits(&self) -> LimitSwitches {
        if self.config.mechanics.decoupled {
            return LimitSwitches::default();
        }
        let mm = self.position_m() * 1e3;
        LimitSwitches {
            home: mm <= self.config.mechanics.home_switch_mm,
            end: mm >= self.config.mechanics.end_switch_mm,
        }
    }

    /// The limit switches as the wiring reports them.
    fn wired_limits(&self) -> LimitSwitches {
        let t = self.true_limits();
        LimitSwitches {
            home: self.faults.home.unwrap_or(t.home),
            end: self.faults.end.unwrap_or(t.end),
        }
    }

    /// The Hall code the firmware's voted read produces this period.
    fn read_hall(&mut self, true_code: HallCode) -> HallCode {
        if let Some((code, left)) = self.faults.glitch {
            self.faults.glitch = left.checked_sub(1).filter(|&n| n > 0).map(|n| (code, n));
            return code;
        }
        let mut raw = true_code.raw();
        for (stuck, mask) in self.faults.hall_stuck.iter().zip([0b100u8, 0b010, 0b001]) {
            match stuck {
                Some(true) => raw |= mask,
                Some(false) => raw &= !mask,
                None => {}
            }
        }
        let code = HallCode::from_raw(raw);
        // Rare events are scheduled by geometric gaps (exactly the same statistics as one
        // Bernoulli draw per trial, at one draw per event): a burst corrupts one line for
        // all seven reads of a period; a flip corrupts one line of one read.
        let mut burst_mask = 0u8;
        if self.hall_burst_in == 0 {
            burst_mask = 0b100u8 >> self.rng_hall.below(3);
            self.hall_burst_in = self.rng_hall.geometric_gap(self.config.hall.burst_probability);
        } else {
            self.hall_burst_in = self.hall_burst_in.saturating_sub(1);
        }
        const TRIALS: u64 = (hall::HALL_VOTES as u64) * 3;
        if burst_mask == 0 && self.hall_flip_in >= TRIALS {
            self.hall_flip_in = self.hall_flip_in.saturating_sub(TRIALS);
            return code;
        }
        let mut reads = [code; hall::HALL_VOTES];
        for read in &mut reads {
            *read = HallCode::from_raw(read.raw() ^ burst_mask);
        }
        // Constant bound: at most TRIALS (21) flips in one period.
        for _ in 0..TRIALS {
            if self.hall_flip_in >= TRIALS {
                break;
            }
            let trial = self.hall_flip_in;
            let mask = 0b100u8 >> (trial % 3);
            if let Some(read) = reads.get_mut(usize::try_from(trial / 3).unwrap_or(0)) {
                *read = HallCode::from_raw(read.raw() ^ mask);
            }
            let gap = self.rng_hall.geometric_gap(self.config.hall.read_flip_probability);
            self.hall_flip_in = trial.saturating_add(1).saturating_add(gap);
        }
        self.hall_flip_in = self.hall_flip_in.saturating_sub(TRIALS);
        hall::vote(&reads)
    }

    /// One PWM period of the fast loop and the physics.
    fn pwm_period(&mut self) {
        let theta_e = self.theta_e_deg();
        let hall = &self.config.hall;
        let true_hall = hall_code_placed(theta_e, hall.offset_deg, hall.sensor_offsets_deg);
        let hall_read = self.read_hall(true_hall);
        let sample = DriveSample {
            hall: hall_read,
            current: self.current_code,
            overcurrent_trip: self.comparator_flag,
            bus_voltage: self.bus_sense.register(),
            limits: self.wired_limits(),
            elapsed: PWM_PERIOD,
        };
        let out = self.drive.step(sample);
        let duty = f64::from(out.duty.raw()) / f64::from(DUTY_ONE);
        self.bridge_period(out.pattern, duty);
    }

    /// What the board's pins see now, for a bench that drives the bridge from outside: the
    /// Hall lines as wired (stuck lines included; the firmware votes its own reads), the
    /// limit switches as wired, the overcurrent comparator's output of the last period, the
    /// current amplifier's code of the last period's on-time sample, and the true bus voltage.
    #[must_use]
    pub fn pins(&self) -> Pins {
        let theta_e = self.theta_e_deg();
        let hall = &self.config.hall;
        let mut raw = hall_code_placed(theta_e, hall.offset_deg, hall.sensor_offsets_deg).raw();
        for (stuck, mask) in self.faults.hall_stuck.iter().zip([0b100u8, 0b010, 0b001]) {
            match stuck {
                Some(true) => raw |= mask,
                Some(false) => raw &= !mask,
                None => {}
            }
        }
        Pins {
            hall: HallCode::from_raw(raw),
            limits: self.wired_limits(),
            comparator: self.comparator_flag,
            current: self.current_code,
            bus_volts: self.bus_volts,
        }
    }

    /// One PWM period with the bridge driven from outside: `pattern` with its switched leg at
    /// `duty` and `dead_time_s` at each of its rising edges (what a bench measured on the
    /// gates), instead of taut-core's drive.
    pub fn external_period(&mut self, pattern: SwitchPattern, duty: f64, dead_time_s: f64) {
        let configured = self.circuit.dead_time;
        self.circuit.dead_time = dead_time_s;
        self.bridge_period(pattern, duty);
        self.circuit.dead_time = configured;
    }

    /// The physics of one PWM period under a bridge pattern and duty.
    fn bridge_period(&mut self, pattern: SwitchPattern, duty: f64) {
        let dt = PWM_PERIOD_S;
        let theta_e = self.theta_e_deg();

        // Electrical.
        let shape = emf_shape(theta_e, self.config.motor.emf_ramp_deg);
        let scale = self.circuit.phase_scale;
        let shorted = scale != Circuit::HEALTHY;
        let mut emf = shape.map(|f| self.ke_phase * self.omega * f);
        if shorted {
            for (e, s) in emf.iter_mut().zip(scale) {
                *e *= s;
            }
        }
        self.circuit.bus_volts = self.bus_volts;
        let result = self.circuit.pwm_period(&mut self.currents, pattern, duty, emf, dt);
        let (bus_volts, clamped) = self.next_bus_volts(result.bus_charge / dt, dt);
        self.bus_volts = bus_volts;
        self.bus_sense.convert(&mut self.rng_bus, self.bus_volts);
        let torque: f64 = if shorted {
            self.ke_phase
                * shape
                    .iter()
                    .zip(scale)
                    .zip(result.mean_current)
                    .map(|((f, s), i)| f * s * i)
                    .sum::<f64>()
        } else {
            self.ke_phase * shape.iter().zip(result.mean_current).map(|(f, i)| f * i).sum::<f64>()
        };

        // Sensors of the fast loop.
        let measured = self.current_sense.sample_period(
            &mut self.rng_current,
            &result,
            pattern,
            dt,
            self.faults.current_open,
        );
        self.current_code = self.current_sense.code(measured);
        self.comparator_flag = result.comparator_tripped;
        let driving = pattern.count(LegState::High) > 0;
        self.last_commutated =
            driving && self.last_pattern.count(LegState::High) > 0 && pattern != self.last_pattern;
        self.last_switching = driving && result.on_time > 0.0 && duty < 1.0;
        self.last_pattern = pattern;
        self.last_duty = if driving { duty } else { 0.0 };
        let winding = result.mean_current.iter().map(|i| i.abs()).sum::<f64>() * 0.5;
        self.last_amps = winding;
        // The current out of the motor through the pattern's low leg.
        let signed_winding = if driving {
            Phase::ALL
                .iter()
                .zip(result.mean_current)
                .filter(|(phase, _)| pattern.leg(**phase) == LegState::Low)
                .map(|(_, i)| -i)
                .sum::<f64>()
        } else {
            0.0
        };

        // Mechanics and string.
        let x_before = self.position_m();
        let v_before = self.carriage_v;
        self.mechanics(torque, dt);
        let x = self.position_m();
        if self.string.attached() {
            self.string_travel_m += x - x_before;
        }
        let now_s = self.ticks as f64 * TICK_S;
        let tension_n = self.string.update(x, dt, now_s);
        if let Some(gripper) = &mut self.gripper {
            let accel = (self.carriage_v - v_before) / dt;
            self.load_cell_force_n = gripper.step(tension_n, accel);
        } else {
            self.load_cell_force_n = tension_n;
        }
        self.load_cell.update(self.load_cell_force_n / NEWTONS_PER_KGF, dt);

        let s = &mut self.sums;
        s.current += winding;
        s.torque += torque;
        s.measured_current += measured;
        s.peak = s.peak.max(result.peak_current);
        s.comparator |= result.comparator_tripped;
        s.bus_peak = s.bus_peak.max(self.bus_volts);
        s.clamped |= clamped;
        s.winding += signed_winding;
        s.current_squared += result.mean_current.iter().map(|i| i * i).sum::<f64>();
    }

    /// The bus voltage after `dt` with the bridge drawing `bridge_amps` on average, and
    /// whether the clamp conducted (see "The DC bus" in the module docs): exact for a
    /// constant load.
    fn next_bus_volts(&self, bridge_amps: f64, dt: f64) -> (f64, bool) {
        let v = self.unclamped_bus_volts(bridge_amps, dt);
        match self.config.bridge.clamp_volts {
            Some(clamp) if v > clamp => (clamp, true),
            _ => (v, false),
        }
    }

    /// The bus voltage after `dt` without a clamp.
    fn unclamped_bus_volts(&self, bridge_amps: f64, dt: f64) -> f64 {
        let b = &self.config.bridge;
        let (supply, r, c) = (b.bus_volts, b.supply_ohm, b.bus_capacitance_f);
        let load = bridge_amps + b.aux_load_amps;
        let tau = r * c;
        // While the diode conducts: exponential toward the loaded supply voltage.
        let settled = supply - r * load;
        let mut v = self.bus_volts;
        let mut left = dt;
        if v > supply {
            // Diode blocking: the capacitor alone carries the load.
            if load <= 0.0 {
                return v - load * left / c;
            }
            let to_supply = (v - supply) * c / load;
            if to_supply >= left {
                return v - load * left / c;
            }
            v = supply;
            left -= to_supply;
        }
        // Diode conducting (v ≤ supply).
        if load < 0.0 {
            // Charging past the supply: the diode blocks once v reaches it.
            let to_supply = tau * ((settled - v) / (settled - supply)).ln();
            if to_supply < left {
                return supply - load * (left - to_supply) / c;
            }
        }
        settled + (v - settled) * (-left / tau).exp()
    }

    /// Moves the drivetrain by one step under `torque_em`: one rigid body, or with backlash
    /// the motor side and the carriage (see "Backlash" in the module docs).
    fn mechanics(&mut self, torque_em: f64, dt: f64) {
        if self.faults.jam {
            self.omega = 0.0;
            self.stuck = true;
            self.carriage_v = 0.0;
            self.carriage_stuck = true;
            return;
        }
        if self.backlash_m <= 0.0 {
            self.rigid_body(torque_em, dt);
            self.carriage_v = self.omega * self.metres_per_rad;
            self.carriage_stuck = self.stuck;
            return;
        }
        if self.flank != Flank::Free {
            // Try the step as one body; if the flank would have to pull, take it back and
            // let the bodies part instead.
            let before = (self.theta, self.omega, self.stuck);
            self.rigid_body(torque_em, dt);
            let accel = (self.omega - before.1) / dt * self.metres_per_rad;
            // Held as one body by static friction, the motor side alone may still break
            // away from the flank: it only has its own friction to overcome.
            let breaks_away = self.stuck && {
                let applied = torque_em + self.cogging_torque();
                let own = self.motor_side_coulomb * self.config.mechanics.stiction_ratio;
                match self.flank {
                    Flank::Pull => applied < -own,
                    Flank::Release => applied > own,
                    Flank::Free => false,
                }
            };
            if !breaks_away && self.flank_holds(accel) {
                self.carriage_v = self.omega * self.metres_per_rad;
                self.carriage_stuck = self.stuck;
                return;
            }
            (self.theta, self.omega, self.stuck) = before;
            self.flank = Flank::Free;
        }
        self.free_bodies(torque_em, dt);
    }

    /// The cogging torque at the present rotor angle, N·m.
    fn cogging_torque(&self) -> f64 {
        let m = &self.config.motor;
        m.cogging_torque_nm
            * (f64::from(m.cogging_periods_per_turn) * self.theta + self.cogging_phase).sin()
    }

    /// The rigid drivetrain (no backlash, or a flank engaged): one step.
    fn rigid_body(&mut self, torque_em: f64, dt: f64) {
        let decoupled = self.config.mechanics.decoupled;
        let load = if decoupled { 0.0 } else { self.string.tension_n() * self.metres_per_rad };
        let m = &self.config.motor;
        let cogging = m.cogging_torque_nm
            * (f64::from(m.cogging_periods_per_turn) * self.theta + self.cogging_phase).sin();
        let applied = torque_em + cogging - load;
        let friction =
            self.coulomb + self.load_friction * load.abs() + self.motor_friction * torque_em.abs();
        if self.stuck {
            if applied.abs() <= friction * self.config.mechanics.stiction_ratio {
                self.omega = 0.0;
            } else {
                self.omega = (applied - applied.signum() * friction) / self.inertia * dt;
                self.stuck = false;
            }
        } else {
            let acceleration =
                (applied - self.viscous * self.omega - self.omega.signum() * friction)
                    / self.inertia;
            let next = self.omega + acceleration * dt;
            if next * self.omega <= 0.0 {
                self.omega = 0.0;
                self.stuck = true;
            } else {
                self.omega = next;
            }
        }
        self.theta += self.omega * dt;
        if !decoupled {
            let x = self.position_m();
            self.note_end_stop(x);
            if x < self.low_stop_m || x > self.high_stop_m {
                let clamped = x.clamp(self.low_stop_m, self.high_stop_m);
                self.theta = (clamped - self.gap_m) / self.metres_per_rad;
                self.omega = 0.0;
                self.stuck = true;
            }
        }
    }

    /// Whether the engaged flank can pass the force a rigid step at carriage acceleration
    /// `accel` needs: the screw can only push the carriage away from the flank (toward the
    /// pull on the pull flank, toward home on the release flank).
    fn flank_holds(&self, accel: f64) -> bool {
        let slide = if self.carriage_v == 0.0 {
            0.0
        } else {
            self.slide_friction * self.carriage_v.signum()
        };
        // What the screw must push the carriage with (toward the pull).
        let push = self.carriage_mass * accel + self.string.tension_n() + slide;
        match self.flank {
            Flank::Pull => push >= 0.0,
            Flank::Release => push <= 0.0,
            Flank::Free => false,
        }
    }

    /// In the dead band: the motor side and the carriage each take one step on their own;
    /// reaching a flank merges them in an inelastic impact.
    fn free_bodies(&mut self, torque_em: f64, dt: f64) {
        let stiction = self.config.mechanics.stiction_ratio;
        let cogging = self.cogging_torque();
        // Motor side: the motor's torque against its own friction.
        let (omega, stuck) = karnopp(
            self.omega,
            self.stuck,
            torque_em + cogging,
            self.motor_side_coulomb,
            self.viscous,
            stiction,
            self.motor_inertia,
            dt,
        );
        self.omega = omega;
        self.stuck = stuck;
        // Carriage: the string against the slide's friction.
        let (v, carriage_stuck) = karnopp(
            self.carriage_v,
            self.carriage_stuck,
            -self.string.tension_n(),
            self.slide_friction,
            0.0,
            stiction,
            self.carriage_mass,
            dt,
        );
        self.carriage_v = v;
        self.carriage_stuck = carriage_stuck;
        let x = self.position_m() + self.carriage_v * dt;
        self.theta += self.omega * dt;
        let screw = self.theta * self.metres_per_rad;
        let half = 0.5 * self.backlash_m;
        let gap = x - screw;
        let flank = if gap <= -half {
            Flank::Pull
        } else if gap >= half {
            Flank::Release
        } else {
            Flank::Free
        };
        self.gap_m = gap.clamp(-half, half);
        if flank != Flank::Free {
            // Inelastic impact: the two bodies leave the flank with their common momentum.
            let r = self.metres_per_rad;
            let momentum =
                self.motor_inertia * self.omega + self.carriage_mass * r * self.carriage_v;
            self.omega = momentum / self.inertia;
            self.carriage_v = self.omega * r;
            self.stuck = self.omega == 0.0;
            self.carriage_stuck = self.stuck;
            self.flank = flank;
            self.theta = (x - self.gap_m) / r;
        }
        let x = self.position_m();
        self.note_end_stop(x);
        if x < self.low_stop_m || x > self.high_stop_m {
            // The carriage hits a hard stop; the motor side follows only if engaged.
            let clamped = x.clamp(self.low_stop_m, self.high_stop_m);
            self.carriage_v = 0.0;
            self.carriage_stuck = true;
            if self.flank == Flank::Free {
                self.gap_m = (clamped - self.theta * self.metres_per_rad).clamp(-half, half);
            } else {
                self.theta = (clamped - self.gap_m) / self.metres_per_rad;
                self.omega = 0.0;
                self.stuck = true;
            }
        }
    }

    /// Counts an arrival at the home-side stop: the carriage at `x` (m, before the stop
    /// clamps it) at or past it after having been clear of it (by 1 µm).
    fn note_end_stop(&mut self, x: f64) {
        let (hits, resting) = self.end_stop;
        if x <= self.low_stop_m {
            self.end_stop = (if resting { hits } else { hits.saturating_add(1) }, true);
        } else if x > self.low_stop_m + 1e-6 {
            self.end_stop = (hits, false);
        }
    }

    /// Samples every sensor into the tick's [`Inputs`] and updates the truth.
    fn sample_sensors(&mut self) {
        let periods = f64::from(PERIODS_PER_TICK);
        let s = self.sums;
        let ticks_started = self.ticks > 0;
        let tension_kgf = self.string.tension_n() / NEWTONS_PER_KGF;
        let load_cell = self.load_cell.sample(
            &mut self.rng_load_cell,
            self.ticks as f64 * TICK_S,
            self.last_switching,
            self.last_commutated,
            self.last_amps,
            self.faults.load_cell,
        );
        let mean_measured = if ticks_started { s.measured_current / periods } else { 0.0 };
        let counts = self.string_travel_m
            * 1e3
            * self.config.encoder.counts_per_mm
            * (1.0 + self.config.encoder.scale_error);
        let counts = counts.round().clamp(-9.0e15, 9.0e15) as i64;
        self.sampled = Inputs {
            now_ms: (self.ticks & u64::from(u32::MAX)) as u32,
            load_cell,
            motor_current: self.current_sense.code(mean_measured),
            bus_voltage: self.bus_sense.register(),
            drive: self.drive.status(),
            string_counter: (counts.rem_euclid(65_536)) as u16,
            limits: self.wired_limits(),
            keys: self.keys,
        };
        let x = self.position_m();
        let hall = &self.config.hall;
        self.truth = Truth {
            time_s: self.ticks as f64 * TICK_S,
            tension_kgf,
            carriage_mm: x * 1e3,
            carriage_mm_per_s: self.carriage_v * 1e3,
            end_stop_hits: self.end_stop.0,
            motor_rpm: self.omega * 60.0 / core::f64::consts::TAU,
            current_a: if ticks_started { s.current / periods } else { 0.0 },
            peak_current_a: s.peak,
            torque_nm: if ticks_started { s.torque / periods } else { 0.0 },
            duty: self.last_duty,
            pattern: self.last_pattern,
            drive_fault: self.drive.fault(),
            drive_coasting: self.drive.coasting(),
            comparator_tripped: s.comparator,
            string: self.string.state(),
            string_relaxation_kgf_per_s: self.string.relaxation_rate_n_per_s() / NEWTONS_PER_KGF,
            limits: self.true_limits(),
            hall: hall_code_placed(self.theta_e_deg(), hall.offset_deg, hall.sensor_offsets_deg),
            stuck: self.carriage_stuck,
            string_travel_mm: self.string_travel_m * 1e3,
            load_cell_volts: self.load_cell.output_volts(),
            bus_volts: self.bus_volts,
            bus_peak_volts: if ticks_started { s.bus_peak } else { self.bus_volts },
            bus_clamped: s.clamped,
            winding_current_a: if ticks_started { s.winding / periods } else { 0.0 },
            load_cell_force_kgf: self.load_cell_force_n / NEWTONS_PER_KGF,
            backlash_mm: self.gap_m * 1e3,
        };
    }
}

/// One semi-implicit Euler step of a body of inertia `inertia` at speed `speed` under
/// `applied` force (or torque), with Coulomb friction `coulomb`, viscous coefficient
/// `viscous` and static friction `stiction × coulomb` (Karnopp): the new speed and whether it
/// is stuck.
#[allow(clippy::too_many_arguments, reason = "one body's state and constants, all scalars")]
fn karnopp(
    speed: f64,
    stuck: bool,
    applied: f64,
    coulomb: f64,
    viscous: f64,
    stiction: f64,
    inertia: f64,
    dt: f64,
) -> (f64, bool) {
    if stuck || speed == 0.0 {
        if applied.abs() <= coulomb * stiction {
            return (0.0, true);
        }
        return ((applied - applied.signum() * coulomb) / inertia * dt, false);
    }
    let acceleration = (applied - viscous * speed - speed.signum() * coulomb) / inertia;
    let next = speed + acceleration * dt;
    if next * speed <= 0.0 { (0.0, true) } else { (next, false) }
}

/// Phase A, B, C → 0, 1, 2.
const fn phase_index(phase: Phase) -> usize {
    match phase {
        Phase::A => 0,
        Phase::B => 1,
        Phase::C => 2,
    }
}

/// A drive command from a direction and a duty fraction (clamped to `[0, DUTY_MAX]`).
#[must_use]
pub fn drive_at(direction: taut_core::drive::Direction, duty: f64) -> DriveCommand {
    let raw = (duty.clamp(0.0, 1.0) * f64::from(DUTY_ONE)).round().min(f64::from(u16::MAX));
    DriveCommand::Drive { direction, duty: taut_core::drive::Duty::from_raw_clamped(raw as u16) }
}

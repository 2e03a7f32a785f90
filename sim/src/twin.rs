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
//!    elapsed timer ticks,
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
//! the auxiliary load, so braking pumps the bus up.

use taut_core::drive::duty::DUTY_ONE;
use taut_core::drive::{
    Drive, DriveCommand, DriveFault, DriveSample, HallCode, LegState, PWM_FREQUENCY_HZ,
    PWM_PERIOD_TICKS, Phase, PwmTicks, SwitchPattern, hall,
};
use taut_core::io::{Inputs, Keys, LimitSwitches, Outputs};
use taut_core::units::AdcCode;

use crate::motor::{Circuit, emf_shape, hall_code, sector_shape_factor};
use crate::params::{NEWTONS_PER_KGF, TwinConfig};
use crate::rng::SimRng;
use crate::sensors::{CurrentSense, LoadCell, LoadCellFault};
use crate::string::{StringModel, StringState};

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
    /// The carriage is mechanically seized (stall).
    CarriageJam,
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
    /// The hardware overcurrent comparator fired during the last tick.
    pub comparator_tripped: bool,
    /// The string's state.
    pub string: StringState,
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
}

/// The digital twin of the stringing machine. See the module docs.
#[derive(Clone, Debug)]
pub struct Twin {
    config: TwinConfig,
    drive: Drive,
    circuit: Circuit,
    current_sense: CurrentSense,
    load_cell: LoadCell,
    string: StringModel,
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
    // State.
    ticks: u64,
    currents: [f64; 3],
    theta: f64,
    omega: f64,
    stuck: bool,
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
    faults: ActiveFaults,
    keys: Keys,
    key_events: Vec<(u64, Keys)>,
    sampled: Inputs,
    outputs: Outputs,
    truth: Truth,
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
        let (inertia, coulomb, load_friction, motor_friction) = if k.decoupled {
            (m.rotor_inertia_kg_m2, m.coulomb_torque_nm, 0.0, 0.0)
        } else {
            (
                m.rotor_inertia_kg_m2
                    + k.gear_inertia_kg_m2
                    + k.carriage_mass_kg * metres_per_rad * metres_per_rad,
                m.coulomb_torque_nm + k.drag_torque_nm + k.slide_friction_n * metres_per_rad,
                a,
                b,
            )
        };
        let shape = sector_shape_factor(m.emf_ramp_deg).max(1e-6);
        let mut setup = SimRng::substream(c.seed, 0x5E70);
        let start_m = k.start_mm * 1e-3;
        let mut twin = Self {
            config: c,
            drive: Drive::new(),
            circuit: Circuit {
                resistance: m.phase_resistance_ohm,
                inductance: m.phase_inductance_h,
                bus_volts: c.bridge.bus_volts,
                diode_drop: c.bridge.diode_drop_v,
                comparator_amps: c.bridge.comparator_amps,
                dead_time: c.bridge.dead_time_s,
            },
            current_sense: CurrentSense::new(&c.current_sense),
            load_cell: LoadCell::new(&c.load_cell),
            string: StringModel::new(&c.string, start_m),
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
            high_stop_m: (k.end_switch_mm + k.overtravel_mm) * 1e-3,
            ticks: 0,
            currents: [0.0; 3],
            theta: start_m / metres_per_rad,
            omega: 0.0,
            stuck: true,
            // Powered up long ago: the capacitor sits where the auxiliary load holds it.
            bus_volts: c.bridge.bus_volts - c.bridge.supply_ohm * c.bridge.aux_load_amps,
            string_travel_m: 0.0,
            current_code: AdcCode::MIN,
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
            faults: ActiveFaults::default(),
            keys: Keys::NONE,
            key_events: Vec::new(),
            sampled: Inputs::default(),
            outputs: Outputs::default(),
            truth: Truth {
                time_s: 0.0,
                tension_kgf: 0.0,
                carriage_mm: k.start_mm,
                carriage_mm_per_s: 0.0,
                motor_rpm: 0.0,
                current_a: 0.0,
                peak_current_a: 0.0,
                torque_nm: 0.0,
                duty: 0.0,
                pattern: SwitchPattern::ALL_OFF,
                drive_fault: None,
                comparator_tripped: false,
                string: StringState::Absent,
                limits: LimitSwitches::default(),
                hall: HallCode::from_raw(0),
                stuck: true,
                string_travel_mm: 0.0,
                load_cell_volts: 0.0,
                bus_volts: c.bridge.bus_volts,
                bus_peak_volts: c.bridge.bus_volts,
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

    /// Applies one tick's outputs: the drive command goes to `Drive::set_command`, a clear
    /// request to `Drive::clear_fault` (after the command, so clearing works only together
    /// with coast), and the panel outputs are recorded.
    pub fn apply(&mut self, outputs: &Outputs) {
        self.drive.set_command(outputs.drive);
        if outputs.clear_drive_fault {
            // A refusal leaves the fault latched; the machine sees it in `Inputs::drive`.
            let _refused = self.drive.clear_fault();
        }
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

    /// Starts exhibiting `fault` (until [`Twin::clear_injected`]).
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
        }
    }

    /// Removes every injected fault (a broken string stays broken).
    pub fn clear_injected(&mut self) {
        self.faults = ActiveFaults::default();
    }

    /// One millisecond of physics: twenty PWM periods, then the sensors are sampled.
    pub fn advance_tick(&mut self) {
        self.sums = TickSums::default();
        // Constant bound: PERIODS_PER_TICK (20) PWM periods.
        for _ in 0..PERIODS_PER_TICK {
            self.pwm_period();
        }
        self.ticks = self.ticks.wrapping_add(1);
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
        self.theta * self.metres_per_rad
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
        let dt = PWM_PERIOD_S;
        let theta_e = self.theta_e_deg();
        let true_hall = hall_code(theta_e - self.config.hall.offset_deg);
        let hall_read = self.read_hall(true_hall);
        let sample = DriveSample {
            hall: hall_read,
            current: self.current_code,
            overcurrent_trip: self.comparator_flag,
            bus_voltage: self.sampled.bus_voltage,
            limits: self.wired_limits(),
            elapsed: PwmTicks(u32::from(PWM_PERIOD_TICKS)),
        };
        let out = self.drive.step(sample);
        let duty = f64::from(out.duty.raw()) / f64::from(DUTY_ONE);

        // Electrical.
        let shape = emf_shape(theta_e, self.config.motor.emf_ramp_deg);
        let emf = shape.map(|f| self.ke_phase * self.omega * f);
        self.circuit.bus_volts = self.bus_volts;
        let result = self.circuit.pwm_period(&mut self.currents, out.pattern, duty, emf, dt);
        self.bus_volts = self.next_bus_volts(result.bus_charge / dt, dt);
        let torque: f64 =
            self.ke_phase * shape.iter().zip(result.mean_current).map(|(f, i)| f * i).sum::<f64>();

        // Sensors of the fast loop.
        let bus = if result.on_time > 0.0 { result.on_bus_current } else { 0.0 };
        let measured = if self.faults.current_open {
            0.0
        } else {
            self.current_sense.measure(&mut self.rng_current, bus)
        };
        self.current_code = self.current_sense.code(measured);
        self.comparator_flag = result.comparator_tripped;
        let driving = out.pattern.count(LegState::High) > 0;
        self.last_commutated = driving
            && self.last_pattern.count(LegState::High) > 0
            && out.pattern != self.last_pattern;
        self.last_switching = driving && result.on_time > 0.0 && duty < 1.0;
        self.last_pattern = out.pattern;
        self.last_duty = if driving { duty } else { 0.0 };
        let winding = result.mean_current.iter().map(|i| i.abs()).sum::<f64>() * 0.5;
        self.last_amps = winding;

        // Mechanics and string.
        let x_before = self.position_m();
        self.mechanics(torque, dt);
        let x = self.position_m();
        if self.string.attached() {
            self.string_travel_m += x - x_before;
        }
        let now_s = self.ticks as f64 * TICK_S;
        let tension_n = self.string.update(x, dt, now_s);
        self.load_cell.update(tension_n / NEWTONS_PER_KGF, dt);

        let s = &mut self.sums;
        s.current += winding;
        s.torque += torque;
        s.measured_current += measured;
        s.peak = s.peak.max(result.peak_current);
        s.comparator |= result.comparator_tripped;
        s.bus_peak = s.bus_peak.max(self.bus_volts);
    }

    /// The bus voltage after `dt` with the bridge drawing `bridge_amps` on average (see
    /// "The DC bus" in the module docs): exact for a constant load.
    fn next_bus_volts(&self, bridge_amps: f64, dt: f64) -> f64 {
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

    /// Moves the rigid drivetrain by one step under `torque_em`.
    fn mechanics(&mut self, torque_em: f64, dt: f64) {
        if self.faults.jam {
            self.omega = 0.0;
            self.stuck = true;
            return;
        }
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
            if x < self.low_stop_m || x > self.high_stop_m {
                let clamped = x.clamp(self.low_stop_m, self.high_stop_m);
                self.theta = clamped / self.metres_per_rad;
                self.omega = 0.0;
                self.stuck = true;
            }
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
            // Through a 1:12 divider (60 V full scale at the 5 V reference): a placeholder
            // until the board's divider is a parameter of its own.
            bus_voltage: crate::sensors::adc(self.bus_volts / 12.0),
            drive: self.drive.status(),
            string_counter: (counts.rem_euclid(65_536)) as u16,
            limits: self.wired_limits(),
            keys: self.keys,
        };
        let x = self.position_m();
        self.truth = Truth {
            time_s: self.ticks as f64 * TICK_S,
            tension_kgf,
            carriage_mm: x * 1e3,
            carriage_mm_per_s: self.omega * self.metres_per_rad * 1e3,
            motor_rpm: self.omega * 60.0 / core::f64::consts::TAU,
            current_a: if ticks_started { s.current / periods } else { 0.0 },
            peak_current_a: s.peak,
            torque_nm: if ticks_started { s.torque / periods } else { 0.0 },
            duty: self.last_duty,
            pattern: self.last_pattern,
            drive_fault: self.drive.fault(),
            comparator_tripped: s.comparator,
            string: self.string.state(),
            limits: self.true_limits(),
            hall: hall_code(self.theta_e_deg() - self.config.hall.offset_deg),
            stuck: self.stuck,
            string_travel_mm: self.string_travel_m * 1e3,
            load_cell_volts: self.load_cell.output_volts(),
            bus_volts: self.bus_volts,
            bus_peak_volts: if ticks_started { s.bus_peak } else { self.bus_volts },
        };
    }
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

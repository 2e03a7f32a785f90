//! The twin's parameters: every number the model uses, where it comes from, and the
//! Monte-Carlo ranges around it.
//!
//! # Theory of operation
//!
//! A [`TwinConfig`] is plain data — one struct per physical part — so a scenario can be
//! printed, compared and reproduced. [`TwinConfig::nominal`] is the paper's machine with the
//! assumptions of the crate documentation (the derivations with their arithmetic are in the
//! crate's `//!` docs and in `sim/README.md`); [`TwinConfig::sample`] draws a plausible
//! machine and string around it from a seed, for Monte-Carlo runs. Nothing here is
//! validated at run time beyond [`TwinConfig::check`]: the twin is a host tool, and a config
//! outside the physical ranges is reported, not silently repaired.

use core::fmt;
use core::str::FromStr;

use crate::rng::SimRng;
use taut_core::drive::{DriveTime, TIME_UNITS_PER_SECOND};
use taut_core::units::AdcReference;

/// The twin's board's dead time: 1 µs, as taut's (`firmware/src/timing.rs`). The bridge's
/// physics ([`BridgeParams::dead_time_s`]) and the drive's configuration both take it.
pub const BOARD_DEAD_TIME: DriveTime = DriveTime::from_micros(1);

/// The design of the electronics a twin's machine is built on — what its converter's codes
/// and its bridge's timing mean — as opposed to the sampled errors of each part around it.
/// The machine's core is given the board these make ([`crate::bench::board_for`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct BoardDesign {
    /// The converter's reference (every analogue input: load cell, current, bus).
    pub adc_reference: AdcReference,
    /// The bus voltage at converter full scale by design (reference × divider), mV.
    pub bus_full_scale_mv: u32,
    /// The bridge's dead time (the physics' [`BridgeParams::dead_time_s`] is this at nominal).
    pub dead_time: DriveTime,
    /// The drive's overcurrent trip, mA (a winding-current sample at or above it latches).
    pub overcurrent_ma: u32,
}

impl BoardDesign {
    /// The paper's board: a 5 V converter, a 1 : 12 bus divider (60 V full scale), 1 µs, a
    /// 12 A trip.
    #[allow(clippy::panic, reason = "evaluated when compiled: a refused reference stops the build")]
    pub const PAPER: Self = Self {
        adc_reference: match AdcReference::from_millivolts(5_000) {
            Some(reference) => reference,
            None => panic!("5 V is a converter reference"),
        },
        bus_full_scale_mv: 60_000,
        dead_time: BOARD_DEAD_TIME,
        overcurrent_ma: 12_000,
    };

    /// The converter's reference, volts.
    #[must_use]
    pub fn reference_volts(&self) -> f64 {
        f64::from(self.adc_reference.millivolts()) / 1_000.0
    }
}

/// Standard gravity, N per kgf.
pub const NEWTONS_PER_KGF: f64 = 9.806_65;

/// The kinds of string the twin knows, from the softest badminton string to stiff tennis
/// polyester, plus the empty machine.
///
/// Stiffness is `E·A / L` of the string between the clamp on the far side of the frame
/// and the tension head's gripper (see [`StringSpec`]); the five string kinds span
/// ≈ 1.4–15 kgf/cm.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum StringKind {
    /// Thick (0.70 mm) durable badminton multifilament: the softest string, ≈ 1.7 kgf/cm.
    BadmintonSoft,
    /// Thin (0.62 mm) high-modulus "repulsion" badminton string, ≈ 2.5 kgf/cm.
    BadmintonHard,
    /// Natural gut, 1.30 mm: the softest tennis string, ≈ 5.4 kgf/cm.
    TennisGut,
    /// Nylon "synthetic gut", 1.30 mm, ≈ 7.6 kgf/cm.
    TennisSynthetic,
    /// Co-polyester monofilament, 1.25 mm: the stiffest common string, ≈ 12.5 kgf/cm.
    TennisPolyester,
    /// No string in the gripper: the carriage pulls on nothing (fault tests).
    NoString,
}

/// Why a string-kind name was not understood.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct UnknownStringKind;

impl fmt::Display for UnknownStringKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(
            "unknown string kind (expected badminton-soft, badminton-hard, tennis-gut, \
             tennis-synthetic, tennis-poly or none)",
        )
    }
}

impl std::error::Error for UnknownStringKind {}

/// The physical description of a string kind: where its stiffness comes from, and how it
/// relaxes.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct StringSpec {
    /// String diameter, mm.
    pub gauge_mm: f64,
    /// Quasi-static Young's modulus, GPa (slow pull, not the higher impact-rate modulus
    /// string labs quote).
    pub modulus_gpa: f64,
    /// Free length between the clamp and the gripper, m.
    pub free_length_m: f64,
    /// The Monte-Carlo range of the instantaneous stiffness, kgf/cm.
    pub stiffness_range_kgf_per_cm: (f64, f64),
    /// The tensions the kind is strung at, kgf: what a stringer sets for it (manufacturers'
    /// recommendations with margin — badminton 18–35 lb, tennis 33–77 lb). The reports draw
    /// their targets here: a badminton string at 30 kgf breaks on a real machine, and on the
    /// twin it needs more travel than the carriage has.
    pub tension_range_kgf: (f64, f64),
    /// The two relaxation arms: (fraction of instantaneous stiffness, time constant s).
    pub relaxation: [RelaxationArm; 2],
}

impl StringSpec {
    /// `E·A / L` in kgf/cm.
    #[must_use]
    pub fn stiffness_kgf_per_cm(&self) -> f64 {
        let radius_m = self.gauge_mm * 0.5e-3;
        let area_m2 = core::f64::consts::PI * radius_m * radius_m;
        let newtons_per_m = self.modulus_gpa * 1e9 * area_m2 / self.free_length_m;
        newtons_per_m / NEWTONS_PER_KGF / 100.0
    }
}

impl StringKind {
    /// Every kind, including [`StringKind::NoString`].
    pub const ALL: [Self; 6] = [
        Self::BadmintonSoft,
        Self::BadmintonHard,
        Self::TennisGut,
        Self::TennisSynthetic,
        Self::TennisPolyester,
        Self::NoString,
    ];

    /// The kinds that are real strings (what Monte-Carlo scenarios draw from).
    pub const STRINGS: [Self; 5] = [
        Self::BadmintonSoft,
        Self::BadmintonHard,
        Self::TennisGut,
        Self::TennisSynthetic,
        Self::TennisPolyester,
    ];

    /// The command-line name (`tennis-poly`, …), also what [`FromStr`] accepts.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::BadmintonSoft => "badminton-soft",
            Self::BadmintonHard => "badminton-hard",
            Self::TennisGut => "tennis-gut",
            Self::TennisSynthetic => "tennis-synthetic",
            Self::TennisPolyester => "tennis-poly",
            Self::NoString => "none",
        }
    }

    /// What the kind is, in a few words (`Natural gut`), as the command line's help lists it.
    #[must_use]
    pub const fn summary(self) -> &'static str {
        match self {
            Self::BadmintonSoft => "Soft badminton string",
            Self::BadmintonHard => "Hard badminton string",
            Self::TennisGut => "Natural gut",
            Self::TennisSynthetic => "Synthetic gut",
            Self::TennisPolyester => "Polyester",
            Self::NoString => "No string in the gripper",
        }
    }

    /// The kind's physical description, or `None` for [`StringKind::NoString`].
    ///
    /// Relaxation arms are assumptions of the order of published tension-loss tests: a
    /// string held at fixed length loses a few per cent within seconds and 5–15 % within
    /// minutes, polyester and thin badminton multifilaments the most, natural gut the least.
    #[must_use]
    pub const fn spec(self) -> Option<StringSpec> {
        const fn arm(fraction: f64, time_constant_s: f64) -> RelaxationArm {
            RelaxationArm { fraction, time_constant_s }
        }
        match self {
            Self::BadmintonSoft => Some(StringSpec {
                gauge_mm: 0.70,
                modulus_gpa: 2.0,
                free_length_m: 0.45,
                stiffness_range_kgf_per_cm: (1.4, 2.2),
                tension_range_kgf: (8.0, 15.0),
                relaxation: [arm(0.05, 1.5), arm(0.10, 40.0)],
            }),
            Self::BadmintonHard => Some(StringSpec {
                gauge_mm: 0.62,
                modulus_gpa: 3.2,
                free_length_m: 0.40,
                stiffness_range_kgf_per_cm: (2.0, 3.2),
                tension_range_kgf: (8.0, 16.0),
                relaxation: [arm(0.04, 1.5), arm(0.08, 40.0)],
            }),
            Self::TennisGut => Some(StringSpec {
                gauge_mm: 1.30,
                modulus_gpa: 2.0,
                free_length_m: 0.50,
                stiffness_range_kgf_per_cm: (4.5, 6.5),
                tension_range_kgf: (15.0, 35.0),
                relaxation: [arm(0.02, 2.0), arm(0.05, 60.0)],
            }),
            Self::TennisSynthetic => Some(StringSpec {
                gauge_mm: 1.30,
                modulus_gpa: 2.8,
                free_length_m: 0.50,
                stiffness_range_kgf_per_cm: (6.0, 9.0),
                tension_range_kgf: (15.0, 35.0),
                relaxation: [arm(0.04, 1.5), arm(0.08, 40.0)],
            }),
            Self::TennisPolyester => Some(StringSpec {
                gauge_mm: 1.25,
                modulus_gpa: 4.5,
                free_length_m: 0.45,
                stiffness_range_kgf_per_cm: (10.0, 15.0),
                tension_range_kgf: (15.0, 35.0),
                relaxation: [arm(0.03, 2.0), arm(0.10, 60.0)],
            }),
            Self::NoString => None,
        }
    }
}

impl fmt::Display for StringKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for StringKind {
    type Err = UnknownStringKind;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase().replace('_', "-");
        Ok(match lower.as_str() {
            "badminton-soft" | "badminton" => Self::BadmintonSoft,
            "badminton-hard" | "badminton-repulsion" => Self::BadmintonHard,
            "tennis-gut" | "gut" | "natural-gut" => Self::TennisGut,
            "tennis-synthetic" | "synthetic" | "synthetic-gut" | "nylon" => Self::TennisSynthetic,
            "tennis-poly" | "tennis-polyester" | "poly" | "polyester" => Self::TennisPolyester,
            "none" | "no-string" => Self::NoString,
            _ => return Err(UnknownStringKind),
        })
    }
}

/// One Maxwell arm of the string's viscoelastic (generalised standard-linear-solid) model.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct RelaxationArm {
    /// The arm's share of the instantaneous stiffness (0 ..= 1; all arms together < 1).
    pub fraction: f64,
    /// The arm's relaxation time constant, s.
    pub time_constant_s: f64,
}

/// The string between the frame clamp and the tension head.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct StringParams {
    /// Which string.
    pub kind: StringKind,
    /// Instantaneous (fast-pull) stiffness `E·A/L`, kgf per cm of carriage travel.
    pub stiffness_kgf_per_cm: f64,
    /// Carriage travel from the start position before the string is straight, mm.
    pub slack_mm: f64,
    /// Length of the "toe" over which the string straightens and its stiffness ramps from
    /// zero to full, mm (a C¹ quadratic blend).
    pub toe_mm: f64,
    /// The viscoelastic arms; the remaining `1 − Σ fraction` of the stiffness is the
    /// long-term (equilibrium) spring.
    pub relaxation: [RelaxationArm; 2],
    /// Rate-independent hysteresis (the internal friction of the polymer or gut): the share
    /// `h` of the viscoelastic tension the friction element adds while the string is drawn
    /// out and takes off while it is let back (0: none; see [`crate::string`]).
    pub hysteresis_fraction: f64,
    /// The extension over which the friction element turns round after the string's motion
    /// reverses, mm (`δ`: 63 % of the way from one side of the band toward the other).
    pub hysteresis_strain_mm: f64,
    /// The string breaks when its tension first reaches this, kgf (fault tests).
    pub break_at_kgf: Option<f64>,
    /// The string breaks at this time after power-up, s (fault tests).
    pub break_at_s: Option<f64>,
}

impl StringParams {
    /// The kind's nominal string: stiffness `E·A/L`, 30 mm of slack, 1.5 mm toe.
    #[must_use]
    pub fn nominal(kind: StringKind) -> Self {
        let spec = kind.spec();
        Self {
            kind,
            stiffness_kgf_per_cm: spec.map_or(0.0, |s| s.stiffness_kgf_per_cm()),
            slack_mm: 30.0,
            toe_mm: 1.5,
            relaxation: spec
                .map_or([RelaxationArm { fraction: 0.0, time_constant_s: 1.0 }; 2], |s| {
                    s.relaxation
                }),
            hysteresis_fraction: 0.0,
            hysteresis_strain_mm: 0.1,
            break_at_kgf: None,
            break_at_s: None,
        }
    }

    /// What a stringer hooks in for the 4-point calibration: the reference gauge on a short
    /// pre-stretched polyester cord — stiff (≈ 12.5 kgf/cm), no creep, 5 mm of slack, so the 40 kgf point is
    /// reached within ≈ 40 mm of travel on any machine. (Calibrating on the racket's string
    /// itself would need the string's stretch at 40 kgf: more than the 250 mm of travel for
    /// a soft badminton string, which ends the calibration in E-14.)
    #[must_use]
    pub fn calibration_fixture() -> Self {
        Self {
            stiffness_kgf_per_cm: 4.0,
            slack_mm: 5.0,
            // A gauge's steel spring and a pre-stretched cord: no creep while a point is read.
            relaxation: [RelaxationArm { fraction: 0.0, time_constant_s: 1.0 }; 2],
            ..Self::nominal(StringKind::TennisPolyester)
        }
    }

    /// Whether a string is in the machine.
    #[must_use]
    pub fn present(&self) -> bool {
        self.kind != StringKind::NoString
    }
}

/// The brushless motor (a 57 mm, 24 V, 3 700 rpm no-load, 2.85 kgf·cm rated BLDC).
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct MotorParams {
    /// Winding resistance per phase including one MOSFET's on-resistance, Ω.
    pub phase_resistance_ohm: f64,
    /// Winding inductance per phase, H.
    pub phase_inductance_h: f64,
    /// Line-to-line back-EMF constant, averaged over a commutation sector, V per rad/s;
    /// numerically equal to the torque constant in N·m/A.
    pub ke_volts_per_rad_s: f64,
    /// Width of each back-EMF ramp between the flat top and bottom, electrical degrees
    /// (60° gives the ideal 120° flat top; more gives torque dips at commutation).
    pub emf_ramp_deg: f64,
    /// Pole pairs: one electrical turn is `1 / pole_pairs` of a mechanical turn.
    pub pole_pairs: u32,
    /// Rotor inertia, kg·m².
    pub rotor_inertia_kg_m2: f64,
    /// Bearing/seal Coulomb friction torque, N·m.
    pub coulomb_torque_nm: f64,
    /// Speed-proportional loss torque (iron losses, windage), N·m per rad/s.
    pub viscous_nm_per_rad_s: f64,
    /// Cogging torque amplitude, N·m.
    pub cogging_torque_nm: f64,
    /// Cogging periods per mechanical turn (LCM of 12 slots and 8 poles = 24).
    pub cogging_periods_per_turn: u32,
}

/// The three-phase bridge and its supply.
///
/// The bus is not stiff: the supply (a bench SMPS, which cannot sink current) feeds the bus
/// capacitance through a blocking diode, so the energy a braking motor regenerates charges
/// the capacitor and the bus voltage rises (see `crate::twin`, "The DC bus").
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct BridgeParams {
    /// Supply voltage at the bus with no current flowing, V (paper: 24 V).
    pub bus_volts: f64,
    /// MOSFET body-diode forward drop, V.
    pub diode_drop_v: f64,
    /// Level of the hardware overcurrent comparator on the bus shunt, A.
    pub comparator_amps: f64,
    /// Hardware dead time at every rising gate edge of the switched leg, s.
    pub dead_time_s: f64,
    /// Resistance between the supply and the bus (supply output, cable, blocking diode), Ω.
    pub supply_ohm: f64,
    /// Bulk capacitance on the bus, F.
    pub bus_capacitance_f: f64,
    /// Constant current the rest of the machine draws from the bus (MCU, gate drivers,
    /// load-cell excitation, display), A.
    pub aux_load_amps: f64,
    /// The bus clamp (a TVS diode or a brake chopper across the bulk capacitor), V: the bus
    /// rises to it under braking and no further, the clamp burning what the capacitor cannot
    /// take. `None`: no clamp, the bus rises as far as the regenerated energy takes it (the
    /// nominal machine; every machine of the family has one).
    pub clamp_volts: Option<f64>,
}

/// The kind of screw that turns the motor's rotation into the carriage's travel.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Screw {
    /// A trapezoidal lead screw with a sliding nut (the paper's): its friction may or may not
    /// let the string back-drive it.
    Lead,
    /// A ball screw: rolling contact, back-driven by the string with almost all its pull.
    Ball,
}

impl Screw {
    /// The name reports print.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Lead => "lead screw",
            Self::Ball => "ball screw",
        }
    }
}

/// The gearbox, lead screw and carriage.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct MechanicsParams {
    /// The kind of screw (its efficiencies and friction are the fields below).
    pub screw: Screw,
    /// Gearbox reduction (paper: 1:20).
    pub gear_ratio: f64,
    /// Lead-screw lead, mm of carriage travel per screw turn (paper: 2.54 cm).
    pub lead_mm: f64,
    /// Gearbox × screw efficiency when the motor drives the load.
    pub efficiency_forward: f64,
    /// Gearbox × screw efficiency when the load (string) back-drives the motor.
    pub efficiency_backward: f64,
    /// Gearbox and screw inertia referred to the motor shaft, kg·m².
    pub gear_inertia_kg_m2: f64,
    /// Carriage (gripper head, load cell) mass, kg.
    pub carriage_mass_kg: f64,
    /// No-load drag of gearbox and screw at the motor shaft, N·m (Coulomb).
    pub drag_torque_nm: f64,
    /// Coulomb friction of the carriage slide, N.
    pub slide_friction_n: f64,
    /// Static friction / Coulomb friction (stiction), ≥ 1.
    pub stiction_ratio: f64,
    /// Position where the home limit switch closes (at and below), mm.
    pub home_switch_mm: f64,
    /// Position where the end limit switch closes (at and above), mm.
    pub end_switch_mm: f64,
    /// How far past each switch the hard mechanical stop is, mm.
    pub overtravel_mm: f64,
    /// Carriage position at power-up, mm (resting on the home switch).
    pub start_mm: f64,
    /// The motor runs alone on the bench, uncoupled from gearbox and carriage (motor
    /// tests: no-load speed, stall).
    pub decoupled: bool,
    /// Backlash of gearbox and screw together, referred to the carriage, mm: the motor side
    /// turns through this dead band (`backlash_mm / (1000·r)` rad of motor angle) before the
    /// carriage follows a reversal. 0 = a rigid drivetrain.
    pub backlash_mm: f64,
    /// The gripper hung on the load cell, outboard of it.
    pub gripper: GripperParams,
}

/// The gripper (jaws, clamp lever, rotating head) that hangs on the load cell: the load cell
/// carries the string tension plus the force that accelerates the gripper, through the load
/// cell's own spring.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct GripperParams {
    /// Mass outboard of the load cell, kg (part of the moving mass: the carriage mass
    /// [`MechanicsParams::carriage_mass_kg`] does not include it). 0 = the load cell reads the
    /// string directly, as in the nominal machine.
    pub mass_kg: f64,
    /// The load cell's stiffness along the pull, N/m (a beam or S-type cell deflects
    /// 0.1–0.3 mm at its 50 kgf full scale).
    pub load_cell_stiffness_n_per_m: f64,
    /// Damping ratio of the gripper ringing on the load cell.
    pub damping_ratio: f64,
}

impl GripperParams {
    /// No mass outboard of the load cell; a 2.5 × 10⁶ N/m cell, 5 % damping.
    #[must_use]
    pub const fn none() -> Self {
        Self { mass_kg: 0.0, load_cell_stiffness_n_per_m: 2.5e6, damping_ratio: 0.05 }
    }

    /// The natural frequency of the gripper on the load cell, Hz (infinite without mass).
    #[must_use]
    pub fn natural_frequency_hz(&self) -> f64 {
        (self.load_cell_stiffness_n_per_m / self.mass_kg).sqrt() / core::f64::consts::TAU
    }
}

/// Switching spikes on the load-cell amplifier (paper figure 22).
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct SpikeParams {
    /// Probability that a sample taken while the bridge is switching lands in a PWM edge's
    /// ringing.
    pub pwm_probability: f64,
    /// Probability of a spike when a commutation happened in the PWM period before the
    /// sample.
    pub commutation_probability: f64,
    /// Spike amplitude independent of current, V.
    pub base_volts: f64,
    /// Spike amplitude per ampere switched, V/A.
    pub volts_per_amp: f64,
    /// Probability per switching sample that a **burst** starts: this and the next samples,
    /// 1 ..= [`SpikeParams::burst_samples_max`] in all (uniform), each a spike of the same
    /// sign (a gate driver ringing over several conversions; 0: no bursts).
    pub burst_probability: f64,
    /// The longest burst, samples.
    pub burst_samples_max: u32,
}

/// The strain-gauge bridge, instrumentation amplifier and ADC input of the tension sensor.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct LoadCellParams {
    /// Sensitivity, V per kgf (paper ≈ 0.092).
    pub volts_per_kgf: f64,
    /// Output at zero load, V.
    pub zero_volts: f64,
    /// Low-load sensitivity deficit: the response is `T − c·F_k·(1 − e^(−T/F_k))`, so the
    /// slope at zero is `(1 − c)` of the slope above ≈ 3·F_k. This is `c`.
    pub low_load_deficit: f64,
    /// The scale `F_k` of the low-load non-linearity, kgf.
    pub low_load_scale_kgf: f64,
    /// Relative gain change at 50 kgf from a quadratic term (bar/bridge non-linearity).
    pub quadratic_at_50_kgf: f64,
    /// Amplifier/anti-alias bandwidth, Hz.
    pub bandwidth_hz: f64,
    /// White noise at the ADC input, V rms.
    pub noise_volts: f64,
    /// Switching spikes.
    pub spikes: SpikeParams,
    /// Mains hum.
    pub hum: HumParams,
    /// The amplifier's zero warming up: how fast the output at zero load moves at power-up,
    /// V/s (either sign; 0: a settled chain). See [`crate::sensors`].
    pub zero_drift_volts_per_s: f64,
    /// The time constant over which that warm-up settles, s.
    pub zero_drift_settle_s: f64,
}

/// Mains hum picked up by the load-cell wiring and amplifier, referred to the amplifier's
/// output: `volts · sin(2π·f·t + phase)` added to every sample.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct HumParams {
    /// Mains frequency, Hz (50 or 60, within the grid's tolerance).
    pub frequency_hz: f64,
    /// Peak amplitude at the amplifier output, V.
    pub volts: f64,
    /// Phase at power-up, degrees.
    pub phase_deg: f64,
}

/// Where the board measures the motor current (both kinds are first-class).
///
/// What each kind reads, for a winding current `i` (positive in the commanded direction,
/// negative while braking), before the amplifier (see [`CurrentSenseParams`] for the code):
///
/// - [`CurrentSensing::PerPhaseLowSide`]: `i` itself, signed, at any instant of the period
///   (the sector's low leg carries the winding current all period, in the on and the
///   complementary off part alike); zero while coasting (no low side is on, so the firmware
///   has no shunt to read).
/// - [`CurrentSensing::DcLink`] sampled [`DcLinkSampling::MidOnTime`]: `i` during the high
///   side's on-time (then the bus current *is* the winding current), zero with no on-time.
/// - [`CurrentSensing::DcLink`] [`DcLinkSampling::Filtered`]: the RC-filtered bus current,
///   on average `≈ duty × i` (the bus carries `i` only during the on-time), with a ripple
///   that depends on the time constant and on where in the period it is read.
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum CurrentSensing {
    /// One low-side shunt per leg, each with its own amplifier; the firmware converts the one
    /// of the leg the pattern holds low.
    PerPhaseLowSide,
    /// One shunt in the DC link (the bridge's ground return).
    DcLink(DcLinkSampling),
}

/// How the firmware samples a DC-link shunt.
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum DcLinkSampling {
    /// A conversion triggered in the middle of the high side's on-time (taut's own board and
    /// firmware: TIM1 channel 4 at half the on-time).
    MidOnTime,
    /// The amplifier output behind an RC low-pass, converted once per PWM period at a fixed
    /// point of it, unsynchronised with the on-time.
    Filtered {
        /// The RC time constant, s.
        time_constant_s: f64,
        /// Where in the PWM period the conversion happens, as a fraction of the period
        /// from the period's start (the low-side turn-off), `0 ≤ phase < 1`.
        sample_phase: f64,
    },
}

/// The motor-current shunt amplifier feeding the ADC.
///
/// The converter code for a sensed current `i_s` ([`CurrentSensing`] says what `i_s` is):
///
/// ```text
/// V    = clamp(offset_volts + volts_per_amp · ((1 + gain_error)·i_s + offset_amps + noise), 0, 5 V)
/// code = AdcReference::code(V)           (12 bit; the paper's 5 V: round(V · 4096 / 5), ≤ 4095)
/// ```
///
/// `offset_volts` is 0 for a unidirectional amplifier (negative currents read 0 V: code 0)
/// and [`CurrentSenseParams::MID_RAIL_VOLTS`] for a bidirectional one (zero current reads
/// code 2048). The tick's [`taut_core::io::Inputs::motor_current`] is the code of the mean
/// of the tick's twenty per-period `V`; `DriveSample::current` is each period's code.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct CurrentSenseParams {
    /// Which shunt(s), and how they are sampled.
    pub sensing: CurrentSensing,
    /// Design gain of shunt × amplifier, V/A (taut-core's 0.2 V/A nominally).
    pub volts_per_amp: f64,
    /// Design output at zero current, V: 0 (unidirectional) or mid-rail (bidirectional).
    pub offset_volts: f64,
    /// Relative gain error of shunt × amplifier.
    pub gain_error: f64,
    /// Offset error referred to the input, A.
    pub offset_amps: f64,
    /// White noise per sample, A rms.
    pub noise_amps: f64,
}

/// The DC bus voltage divider feeding the ADC (`Inputs::bus_voltage`, `DriveSample::bus_voltage`).
///
/// The code is `AdcReference::code(V_bus / divider_ratio + noise)` per conversion, one
/// conversion per PWM period at the period's quiet end, averaged by the ADC's hardware
/// oversampler over [`BusSenseParams::OVERSAMPLING`] periods exactly as the firmware sets it
/// up: the result register — what the drive and the tick read — holds the rounded mean of the
/// last complete block of 16 codes.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct BusSenseParams {
    /// Bus volts per volt at the ADC pin (12: a 1:12 divider, 60 V full scale at 5 V).
    pub divider_ratio: f64,
    /// White noise per conversion at the ADC pin, V rms.
    pub noise_volts: f64,
}

impl BusSenseParams {
    /// Conversions the hardware oversampler averages (`taut_firmware::timing`: ratio 16).
    pub const OVERSAMPLING: u32 = 16;

    /// The paper's board's divider ([`BoardDesign::PAPER`]: 60 V full scale on 5 V, 1:12),
    /// 1 mV rms of noise at the pin.
    #[must_use]
    #[allow(clippy::cast_lossless, reason = "`f64::from` is not callable in a const fn")]
    pub const fn nominal() -> Self {
        let board = BoardDesign::PAPER;
        let divider_ratio =
            board.bus_full_scale_mv as f64 / board.adc_reference.millivolts() as f64;
        Self { divider_ratio, noise_volts: 1e-3 }
    }
}

/// The Hall sensors.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct HallParams {
    /// Mounting error common to the three sensors (the board's rotation against the
    /// stator): they switch this many electrical degrees late.
    pub offset_deg: f64,
    /// Each sensor's own placement error on top of the common one (A, B, C), electrical
    /// degrees late.
    pub sensor_offsets_deg: [f64; 3],
    /// Per-read, per-line probability that a read is flipped by switching noise (the
    /// firmware votes over seven reads).
    pub read_flip_probability: f64,
    /// Per-PWM-period probability of a burst that corrupts one line for all seven reads.
    pub burst_probability: f64,
}

/// The string-length quadrature encoder.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct EncoderParams {
    /// Counts per mm of string (nominal: 400 counts/turn on a 50 mm circumference wheel).
    pub counts_per_mm: f64,
    /// Relative scale error (wheel wear, slip).
    pub scale_error: f64,
}

/// The reference gauge every machine of the family is commissioned with: a good digital
/// tension calibrator, σ = 0.02 kgf per reading (`sim/README.md`). The reports'
/// `--gauge-sigma` replaces it.
pub const REFERENCE_GAUGE_SIGMA_KGF: f64 = 0.02;

/// Everything that defines one twin: the machine, the string, the sensors, the seed.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TwinConfig {
    /// Seed of every random process in the run (noise, spikes, glitches, rotor angle).
    pub seed: u64,
    /// The motor.
    pub motor: MotorParams,
    /// The bridge and supply.
    pub bridge: BridgeParams,
    /// Gearbox, screw, carriage.
    pub mechanics: MechanicsParams,
    /// The string.
    pub string: StringParams,
    /// The tension sensor.
    pub load_cell: LoadCellParams,
    /// The current sensor.
    pub current_sense: CurrentSenseParams,
    /// The bus-voltage divider.
    pub bus_sense: BusSenseParams,
    /// The Hall sensors.
    pub hall: HallParams,
    /// The string-length encoder.
    pub encoder: EncoderParams,
    /// Standard deviation of the reference gauge used for calibration, kgf.
    pub reference_gauge_sigma_kgf: f64,
    /// The electronics' design (converter reference, bus divider, dead time).
    pub board: BoardDesign,
}

/// Why a configuration was rejected by [`TwinConfig::check`].
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ConfigError {
    /// A resistance, inductance, inertia, constant or ratio is not positive and finite.
    NonPositive(&'static str),
    /// An efficiency is outside `(0, 1]`, or the pair cannot come from one friction law.
    Efficiency,
    /// The string's relaxation fractions are negative or sum to 1 or more.
    Relaxation,
    /// The end switch is not beyond the home switch, or the start is outside the stops.
    Travel,
    /// A parameter is outside the values it can physically take (named).
    OutOfRange(&'static str),
    /// A corner of the family names the same uncertainty axis twice (named).
    RepeatedAxis(&'static str),
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonPositive(what) => write!(f, "{what} must be positive and finite"),
            Self::Efficiency => f.write_str("efficiencies must be in (0, 1] and realisable"),
            Self::Relaxation => f.write_str("relaxation fractions must be ≥ 0 and sum below 1"),
            Self::Travel => f.write_str("travel limits are inconsistent"),
            Self::OutOfRange(what) => write!(f, "{what} is outside its physical range"),
            Self::RepeatedAxis(axis) => write!(f, "the axis {axis} is given twice"),
        }
    }
}

impl std::error::Error for ConfigError {}

/// The motor's derived nominal constants (see the crate docs for the derivation).
pub mod motor_nominal {
    /// Bus voltage, V.
    pub const BUS_VOLTS: f64 = 24.0;
    /// No-load speed at the bus voltage, rpm (paper).
    pub const NO_LOAD_RPM: f64 = 3700.0;
    /// Rated torque, N·m: 2.85 kgf·cm × 9.806 65 N/kgf × 0.01 m/cm (paper).
    pub const RATED_TORQUE_NM: f64 = 2.85 * 9.806_65 * 0.01;
    /// Rated current, A (paper).
    pub const RATED_AMPS: f64 = 5.5;
    /// Phase winding resistance (assumption: 0.82 Ω line-to-line, typical of 57 mm 24 V
    /// motors of this power), Ω.
    pub const WINDING_OHM: f64 = 0.41;
    /// IRF2807 on-resistance, Ω (paper: 13 mΩ).
    pub const MOSFET_OHM: f64 = 0.013;
    /// Phase resistance seen by the current: winding + one MOSFET, Ω.
    pub const PHASE_OHM: f64 = WINDING_OHM + MOSFET_OHM;

    /// The line-to-line `Ke` (= `Kt`) and no-load current `I₀` that satisfy both of the
    /// paper's figures: `V = Ke·ω₀ + R·I₀` at no load and `T = Kt·(I − I₀)` at rated load,
    /// solved as the positive root of `Ke²·ω₀ − (V − R·I)·Ke − R·T = 0`.
    #[must_use]
    pub fn ke_and_no_load_current() -> (f64, f64) {
        ke_and_no_load_current_for(NO_LOAD_RPM, 2.0 * PHASE_OHM)
    }

    /// The same for another no-load speed `no_load_rpm` at [`BUS_VOLTS`] and another
    /// resistance `ohm` in the no-load loop (the driven pair's `2R`, plus any equivalent
    /// resistance of speed-proportional drops), the rated point kept.
    #[must_use]
    pub fn ke_and_no_load_current_for(no_load_rpm: f64, ohm: f64) -> (f64, f64) {
        let omega = no_load_rpm * core::f64::consts::TAU / 60.0;
        let r = ohm;
        let a = BUS_VOLTS - r * RATED_AMPS;
        let ke = (a + (a * a + 4.0 * omega * r * RATED_TORQUE_NM).sqrt()) / (2.0 * omega);
        (ke, RATED_AMPS - RATED_TORQUE_NM / ke)
    }
}

impl MotorParams {
    /// The nominal motor (derivation in the crate docs).
    #[must_use]
    pub fn nominal() -> Self {
        let (ke, i0) = motor_nominal::ke_and_no_load_current();
        let omega0 = motor_nominal::NO_LOAD_RPM * core::f64::consts::TAU / 60.0;
        let coulomb = 0.005;
        // The no-load loss torque Kt·I₀ is split into bearing Coulomb friction and a
        // speed-proportional part that reaches the rest at no-load speed.
        let viscous = (ke * i0 - coulomb) / omega0;
        Self {
            phase_resistance_ohm: motor_nominal::PHASE_OHM,
            phase_inductance_h: 0.4e-3,
            ke_volts_per_rad_s: ke,
            emf_ramp_deg: 80.0,
            pole_pairs: 4,
            rotor_inertia_kg_m2: 1.5e-5,
            coulomb_torque_nm: coulomb,
            viscous_nm_per_rad_s: viscous,
            cogging_torque_nm: 0.003,
            cogging_periods_per_turn: 24,
        }
    }

    /// The no-load current `I₀` these parameters imply at no-load speed, A: loss torque
    /// over the torque constant.
    #[must_use]
    pub fn no_load_amps(&self, omega_rad_s: f64) -> f64 {
        (self.coulomb_torque_nm + self.viscous_nm_per_rad_s * omega_rad_s) / self.ke_volts_per_rad_s
    }
}

impl BridgeParams {
    /// 24 V supply, 0.8 V body diodes, 15 A comparator, taut-core's 1 µs dead time, 50 mΩ
    /// supply path, 1000 µF bulk capacitance, 0.1 A auxiliary load (sources in the crate
    /// docs).
    #[must_use]
    #[allow(clippy::cast_lossless, reason = "`f64::from` is not callable in a const fn")]
    pub const fn nominal() -> Self {
        Self {
            bus_volts: 24.0,
            diode_drop_v: 0.8,
            comparator_amps: 15.0,
            dead_time_s: BOARD_DEAD_TIME.0 as f64 / TIME_UNITS_PER_SECOND as f64,
            supply_ohm: 0.05,
            bus_capacitance_f: 1000e-6,
            aux_load_amps: 0.1,
            clamp_volts: None,
        }
    }
}

impl MechanicsParams {
    /// The nominal drivetrain (derivation in the crate docs).
    #[must_use]
    pub const fn nominal() -> Self {
        Self {
            screw: Screw::Lead,
            gear_ratio: 20.0,
            lead_mm: 25.4,
            efficiency_forward: 0.644,
            efficiency_backward: 0.600,
            gear_inertia_kg_m2: 0.1e-5,
            carriage_mass_kg: 2.0,
            drag_torque_nm: 0.003,
            slide_friction_n: 2.0,
            stiction_ratio: 1.2,
            home_switch_mm: 0.0,
            end_switch_mm: 250.0,
            overtravel_mm: 20.0,
            start_mm: -0.5,
            decoupled: false,
            backlash_mm: 0.0,
            gripper: GripperParams::none(),
        }
    }

    /// Carriage metres per motor radian: `lead / (2π · ratio)`.
    #[must_use]
    pub fn metres_per_radian(&self) -> f64 {
        self.lead_mm * 1e-3 / (core::f64::consts::TAU * self.gear_ratio)
    }

    /// The two coefficients of the load-dependent Coulomb friction `a·|T_load| + b·|T_motor|`
    /// that reproduce [`Self::efficiency_forward`] and [`Self::efficiency_backward`]:
    /// `η_f = (1 − b)/(1 + a)`, `η_b = (1 − a)/(1 + b)` (derivation in the crate docs).
    #[must_use]
    pub fn friction_coefficients(&self) -> (f64, f64) {
        let (f, b) = (self.efficiency_forward, self.efficiency_backward);
        let a = (1.0 - 2.0 * b + b * f) / (1.0 - b * f);
        (a, 1.0 - f * (1.0 + a))
    }
}

impl LoadCellParams {
    /// The paper's chain: `taut_core`'s nominal 92 mV/kgf and 50 mV zero, with the
    /// assumptions of the crate docs for non-linearity, noise and spikes.
    #[must_use]
    pub fn nominal() -> Self {
        use taut_core::board::{PAPER_LOAD_CELL_ZERO, PAPER_VOLTS_PER_KGF};
        Self {
            volts_per_kgf: PAPER_VOLTS_PER_KGF.to_num::<f64>(),
            zero_volts: PAPER_LOAD_CELL_ZERO.0.to_num::<f64>(),
            low_load_deficit: 0.3,
            low_load_scale_kgf: 2.5,
            quadratic_at_50_kgf: 0.001,
            bandwidth_hz: 500.0,
            noise_volts: 1.5e-3,
            spikes: SpikeParams {
                pwm_probability: 0.05,
                commutation_probability: 0.5,
                base_volts: 0.04,
                volts_per_amp: 0.015,
                burst_probability: 0.0,
                burst_samples_max: 0,
            },
            hum: HumParams { frequency_hz: 50.0, volts: 0.0, phase_deg: 0.0 },
            zero_drift_volts_per_s: 0.0,
            zero_drift_settle_s: 180.0,
        }
    }
}

impl CurrentSenseParams {
    /// The output of a bidirectional amplifier at zero current: half the 5 V reference.
    pub const MID_RAIL_VOLTS: f64 = 2.5;

    /// taut's own board: a DC-link shunt sampled mid on-time through a unidirectional
    /// amplifier of taut-core's gain ([`taut_core::sense::current::VOLTS_PER_AMP`]), ideal
    /// gain, 30 mA of noise per sample.
    #[must_use]
    pub fn nominal() -> Self {
        Self {
            sensing: CurrentSensing::DcLink(DcLinkSampling::MidOnTime),
            volts_per_amp: taut_core::sense::current::VOLTS_PER_AMP.to_num::<f64>(),
            offset_volts: 0.0,
            gain_error: 0.0,
            offset_amps: 0.0,
            noise_amps: 0.03,
        }
    }

    /// Design gain of a bidirectional board: 0.1 V/A, so mid-rail ± 2.5 V spans ± 25 A, the
    /// same 25 A a unidirectional board at 0.2 V/A spans from zero.
    pub const BIDIRECTIONAL_VOLTS_PER_AMP: f64 = 0.1;

    /// A board with per-phase low-side shunts and bidirectional amplifiers (they must read
    /// the braking current, which flows up through the low side), otherwise nominal errors.
    #[must_use]
    pub fn per_phase_low_side() -> Self {
        Self {
            sensing: CurrentSensing::PerPhaseLowSide,
            ..Self::nominal().bidirectional_amplifier()
        }
    }

    /// A board with one DC-link shunt sampled mid on-time; `bidirectional`: amplifier biased
    /// at mid-rail (0.1 V/A), else taut's own board (from 0 V, 0.2 V/A).
    #[must_use]
    pub fn dc_link_mid_on_time(bidirectional: bool) -> Self {
        let board = Self::nominal();
        if bidirectional { board.bidirectional_amplifier() } else { board }
    }

    /// A board with one DC-link shunt behind an RC filter of `time_constant_s`, converted at
    /// `sample_phase` of every PWM period; amplifier as for [`Self::dc_link_mid_on_time`].
    #[must_use]
    pub fn dc_link_filtered(bidirectional: bool, time_constant_s: f64, sample_phase: f64) -> Self {
        Self {
            sensing: CurrentSensing::DcLink(DcLinkSampling::Filtered {
                time_constant_s,
                sample_phase,
            }),
            ..Self::dc_link_mid_on_time(bidirectional)
        }
    }

    /// This board with a bidirectional amplifier: offset at mid-rail, 0.1 V/A.
    #[must_use]
    pub const fn bidirectional_amplifier(mut self) -> Self {
        self.offset_volts = Self::MID_RAIL_VOLTS;
        self.volts_per_amp = Self::BIDIRECTIONAL_VOLTS_PER_AMP;
        self
    }

    /// A short name of the board's sensing, for reports: `per-phase`, `dc-link-mid-on`,
    /// `dc-link-rc`, with `/bidirectional` or `/unidirectional`.
    #[must_use]
    pub fn name(&self) -> String {
        let kind = match self.sensing {
            CurrentSensing::PerPhaseLowSide => "per-phase",
            CurrentSensing::DcLink(DcLinkSampling::MidOnTime) => "dc-link-mid-on",
            CurrentSensing::DcLink(DcLinkSampling::Filtered { .. }) => "dc-link-rc",
        };
        let amplifier = if self.bidirectional() { "bidirectional" } else { "unidirectional" };
        format!("{kind}/{amplifier}")
    }

    /// The drive configuration a core on `board` with this sensing is given: what the code
    /// stands for (winding current, or the link average of an RC-filtered DC-link shunt), the
    /// design zero and gain on the board's converter, the board's bus divider, dead time and
    /// overcurrent trip, taut's current limit. (Design values: the board's errors are the twin's
    /// hidden parameters, and the drive tares the zero.)
    #[must_use]
    pub fn drive_config(&self, board: &BoardDesign) -> taut_core::drive::DriveConfig {
        use taut_core::drive::limit::{BusSense, CurrentLimit, CurrentReading, CurrentSense};
        let reading = match self.sensing {
            CurrentSensing::PerPhaseLowSide | CurrentSensing::DcLink(DcLinkSampling::MidOnTime) => {
                CurrentReading::Winding
            }
            CurrentSensing::DcLink(DcLinkSampling::Filtered { .. }) => CurrentReading::LinkAverage,
        };
        let volts_per_code = board.reference_volts() / 4096.0;
        let na_per_code = (volts_per_code / self.volts_per_amp * 1e9).round() as u32;
        let design_zero = (self.offset_volts / volts_per_code).round().clamp(0.0, 4095.0) as u16;
        // ± 0.5 A of amplifier offset is plausible; more is a fault.
        let zero_tolerance = (0.5e9 / f64::from(na_per_code.max(1))).ceil() as u16;
        let sense = CurrentSense {
            reading,
            design_zero: taut_core::units::AdcCode::new(design_zero),
            na_per_code,
            zero_tolerance,
        };
        let bus = BusSense { full_scale_mv: board.bus_full_scale_mv, ..BusSense::PAPER };
        taut_core::drive::DriveConfig::new(
            sense,
            bus,
            CurrentLimit::PAPER,
            board.overcurrent_ma,
            board.dead_time,
        )
        .unwrap_or(taut_core::drive::DriveConfig::PAPER)
    }

    /// Whether the amplifier is biased at mid-rail (reads negative currents).
    #[must_use]
    pub fn bidirectional(&self) -> bool {
        self.offset_volts > 0.0
    }

    /// The converter code of a current `amps` with no noise and no errors: what a core
    /// configured with this board's design gain and offset expects.
    #[must_use]
    pub fn ideal_code(&self, amps: f64) -> taut_core::units::AdcCode {
        crate::sensors::adc((self.offset_volts + self.volts_per_amp * amps).clamp(0.0, 5.0))
    }
}

impl HallParams {
    /// Perfectly placed sensors, no glitches.
    #[must_use]
    pub const fn nominal() -> Self {
        Self {
            offset_deg: 0.0,
            sensor_offsets_deg: [0.0; 3],
            read_flip_probability: 0.0,
            burst_probability: 0.0,
        }
    }
}

impl EncoderParams {
    /// 400 counts per turn of a 50 mm-circumference wheel: 8 counts/mm.
    #[must_use]
    pub const fn nominal() -> Self {
        Self { counts_per_mm: 8.0, scale_error: 0.0 }
    }
}

impl TwinConfig {
    /// The paper's machine with `kind` of string, seed 0.
    #[must_use]
    pub fn nominal(kind: StringKind) -> Self {
        Self {
            seed: 0,
            motor: MotorParams::nominal(),
            bridge: BridgeParams::nominal(),
            mechanics: MechanicsParams::nominal(),
            string: StringParams::nominal(kind),
            load_cell: LoadCellParams::nominal(),
            current_sense: CurrentSenseParams::nominal(),
            bus_sense: BusSenseParams::nominal(),
            hall: HallParams::nominal(),
            encoder: EncoderParams::nominal(),
            reference_gauge_sigma_kgf: REFERENCE_GAUGE_SIGMA_KGF,
            board: BoardDesign::PAPER,
        }
    }

    /// The motor alone on the bench (no gearbox, carriage or string), for motor tests.
    #[must_use]
    pub fn motor_bench() -> Self {
        let mut config = Self::nominal(StringKind::NoString);
        config.mechanics.decoupled = true;
        config
    }

    /// This configuration with another seed.
    #[must_use]
    pub const fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// A Monte-Carlo scenario: a string kind drawn uniformly from [`StringKind::STRINGS`],
    /// then [`TwinConfig::sample_kind`].
    #[must_use]
    pub fn sample(seed: u64) -> Self {
        let mut rng = SimRng::substream(seed, 0x5CE7);
        let index = rng.below(5);
        let kind = StringKind::STRINGS.into_iter().nth(index as usize);
        Self::sample_kind(kind.unwrap_or(StringKind::TennisSynthetic), seed)
    }

    /// A Monte-Carlo scenario with a given string kind: every parameter drawn uniformly from
    /// its documented range around nominal (see `sim/README.md`): motor ±5–15 %, friction
    /// ±50 %, efficiency, string stiffness/slack/creep, sensor gain/offset/non-linearity/
    /// noise/spikes, Hall placement and rare glitches. The run's noise is seeded by `seed`.
    #[must_use]
    pub fn sample_kind(kind: StringKind, seed: u64) -> Self {
        let mut rng = SimRng::substream(seed, 0xC0F1);
        let mut c = Self::nominal(kind).with_seed(seed);
        c.motor.phase_resistance_ohm *= rng.range(0.9, 1.1);
        c.motor.phase_inductance_h *= rng.range(0.85, 1.15);
        c.motor.ke_volts_per_rad_s *= rng.range(0.95, 1.05);
        c.motor.rotor_inertia_kg_m2 *= rng.range(0.8, 1.2);
        c.motor.coulomb_torque_nm *= rng.range(0.5, 1.5);
        c.motor.viscous_nm_per_rad_s *= rng.range(0.5, 1.5);
        c.motor.cogging_torque_nm *= rng.range(0.5, 1.5);
        c.bridge.bus_volts *= rng.range(0.97, 1.03);

        c.mechanics.drag_torque_nm *= rng.range(0.5, 1.5);
        c.mechanics.slide_friction_n *= rng.range(0.5, 1.5);
        c.mechanics.carriage_mass_kg *= rng.range(0.8, 1.2);
        c.mechanics.efficiency_forward = rng.range(0.56, 0.72);
        c.mechanics.efficiency_backward = c.mechanics.efficiency_forward * rng.range(0.88, 0.98);
        c.mechanics.stiction_ratio = rng.range(1.05, 1.35);

        if let Some(spec) = kind.spec() {
            let (low, high) = spec.stiffness_range_kgf_per_cm;
            c.string.stiffness_kgf_per_cm = rng.range(low, high);
            c.string.slack_mm = rng.range(10.0, 60.0);
            c.string.toe_mm = rng.range(0.5, 3.0);
            for arm in &mut c.string.relaxation {
                arm.fraction *= rng.range(0.5, 1.5);
                arm.time_constant_s *= rng.range(0.6, 1.6);
            }
        }

        c.load_cell.volts_per_kgf *= rng.range(0.97, 1.03);
        c.load_cell.zero_volts = rng.range(0.03, 0.07);
        c.load_cell.low_load_deficit = rng.range(0.15, 0.4);
        c.load_cell.low_load_scale_kgf = rng.range(1.5, 3.0);
        c.load_cell.quadratic_at_50_kgf = rng.range(-0.002, 0.002);
        c.load_cell.noise_volts = rng.range(0.8e-3, 3e-3);
        c.load_cell.spikes.pwm_probability = rng.range(0.0, 0.15);
        c.load_cell.spikes.commutation_probability = rng.range(0.2, 0.8);
        c.load_cell.spikes.base_volts *= rng.range(0.5, 2.0);
        c.load_cell.spikes.volts_per_amp *= rng.range(0.5, 2.0);

        c.current_sense.gain_error = rng.range(-0.03, 0.03);
        c.current_sense.offset_amps = rng.range(-0.05, 0.05);
        c.current_sense.noise_amps = rng.range(0.01, 0.06);

        c.hall.offset_deg = rng.range(-4.0, 4.0);
        c.hall.read_flip_probability = rng.range(0.0, 0.01);
        c.hall.burst_probability = rng.range(0.0, 1e-5);

        c.encoder.scale_error = rng.range(-0.02, 0.02);

        // Drawn last, so the parameters above keep the values they had before the bus was
        // modelled: electrolytic tolerance ±20 %, supply wiring ±50 %.
        c.bridge.bus_capacitance_f *= rng.range(0.8, 1.2);
        c.bridge.supply_ohm *= rng.range(0.5, 1.5);
        c
    }

    /// Checks that the parameters describe a physical machine.
    ///
    /// # Errors
    /// The first [`ConfigError`] found.
    pub fn check(&self) -> Result<(), ConfigError> {
        let positive = |value: f64, what| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(ConfigError::NonPositive(what))
            }
        };
        let m = &self.motor;
        positive(m.phase_resistance_ohm, "phase resistance")?;
        positive(m.phase_inductance_h, "phase inductance")?;
        positive(m.ke_volts_per_rad_s, "Ke")?;
        positive(m.rotor_inertia_kg_m2, "rotor inertia")?;
        positive(f64::from(m.pole_pairs), "pole pairs")?;
        positive(self.bridge.bus_volts, "bus voltage")?;
        positive(self.bridge.comparator_amps, "comparator level")?;
        positive(self.bridge.supply_ohm, "supply resistance")?;
        positive(self.bridge.bus_capacitance_f, "bus capacitance")?;
        if !(self.bridge.dead_time_s >= 0.0 && self.bridge.aux_load_amps >= 0.0) {
            return Err(ConfigError::NonPositive("dead time and auxiliary load"));
        }
        let k = &self.mechanics;
        positive(k.gear_ratio, "gear ratio")?;
        positive(k.lead_mm, "lead")?;
        positive(k.stiction_ratio, "stiction ratio")?;
        if !(0.0..=180.0).contains(&m.emf_ramp_deg) {
            return Err(ConfigError::NonPositive("back-EMF ramp"));
        }
        let (a, b) = k.friction_coefficients();
        let in_unit = |e: f64| e > 0.0 && e <= 1.0;
        if !in_unit(k.efficiency_forward) || !in_unit(k.efficiency_backward) || a < 0.0 || b < 0.0 {
            return Err(ConfigError::Efficiency);
        }
        let fractions: f64 = self.string.relaxation.iter().map(|arm| arm.fraction).sum();
        let arms_ok = self
            .string
            .relaxation
            .iter()
            .all(|arm| arm.fraction >= 0.0 && arm.time_constant_s > 0.0);
        if !arms_ok || fractions >= 1.0 {
            return Err(ConfigError::Relaxation);
        }
        let low_stop = k.home_switch_mm - k.overtravel_mm;
        let high_stop = k.end_switch_mm + k.overtravel_mm;
        if k.end_switch_mm <= k.home_switch_mm || k.start_mm < low_stop || k.start_mm > high_stop {
            return Err(ConfigError::Travel);
        }
        positive(self.load_cell.bandwidth_hz, "load-cell bandwidth")?;
        positive(self.encoder.counts_per_mm, "encoder counts per mm")?;
        self.check_additions()
    }

    /// The checks of the parameters the family added (clamp, backlash, gripper, hum, the
    /// sensing boards).
    fn check_additions(&self) -> Result<(), ConfigError> {
        let in_range =
            |ok: bool, what| if ok { Ok(()) } else { Err(ConfigError::OutOfRange(what)) };
        let finite_non_negative = |v: f64| v.is_finite() && v >= 0.0;
        if let Some(clamp) = self.bridge.clamp_volts {
            in_range(
                clamp.is_finite() && clamp > self.bridge.bus_volts,
                "bus clamp (above supply)",
            )?;
        }
        let k = &self.mechanics;
        in_range(k.stiction_ratio >= 1.0, "stiction ratio (static below kinetic friction)")?;
        in_range(finite_non_negative(k.backlash_mm), "backlash")?;
        in_range(!self.string.present() || finite_non_negative(self.string.slack_mm), "slack")?;
        let string = &self.string;
        in_range(
            (0.0..0.5).contains(&string.hysteresis_fraction)
                && string.hysteresis_strain_mm.is_finite()
                && string.hysteresis_strain_mm > 0.0,
            "string hysteresis",
        )?;
        let g = &k.gripper;
        in_range(finite_non_negative(g.mass_kg), "gripper mass")?;
        in_range(
            g.load_cell_stiffness_n_per_m.is_finite() && g.load_cell_stiffness_n_per_m > 0.0,
            "load-cell stiffness",
        )?;
        in_range((0.0..1.0).contains(&g.damping_ratio), "gripper damping ratio")?;
        let cell = &self.load_cell;
        in_range(
            finite_non_negative(cell.noise_volts) && (0.0..1.0).contains(&cell.low_load_deficit),
            "load-cell noise and low-load deficit",
        )?;
        let spikes = &cell.spikes;
        let probability = |p: f64| (0.0..=1.0).contains(&p);
        in_range(
            probability(spikes.pwm_probability)
                && probability(spikes.commutation_probability)
                && finite_non_negative(spikes.base_volts)
                && finite_non_negative(spikes.volts_per_amp)
                && probability(spikes.burst_probability)
                && spikes.burst_samples_max <= 64,
            "load-cell spikes",
        )?;
        in_range(
            cell.zero_drift_volts_per_s.is_finite()
                && cell.zero_drift_settle_s.is_finite()
                && cell.zero_drift_settle_s > 0.0,
            "load-cell zero drift",
        )?;
        let hum = &self.load_cell.hum;
        in_range(
            finite_non_negative(hum.volts) && hum.frequency_hz > 0.0 && hum.phase_deg.is_finite(),
            "mains hum",
        )?;
        let cs = &self.current_sense;
        in_range(cs.volts_per_amp.is_finite() && cs.volts_per_amp > 0.0, "current-sense gain")?;
        in_range((0.0..5.0).contains(&cs.offset_volts), "current-sense offset")?;
        in_range(
            cs.gain_error > -1.0 && finite_non_negative(cs.noise_amps),
            "current-sense errors",
        )?;
        if let CurrentSensing::DcLink(DcLinkSampling::Filtered { time_constant_s, sample_phase }) =
            cs.sensing
        {
            in_range(
                time_constant_s.is_finite() && time_constant_s > 0.0,
                "DC-link filter time constant",
            )?;
            in_range((0.0..1.0).contains(&sample_phase), "DC-link sampling phase")?;
        }
        let bus = &self.bus_sense;
        in_range(
            bus.divider_ratio.is_finite()
                && bus.divider_ratio > 0.0
                && finite_non_negative(bus.noise_volts),
            "bus-voltage divider",
        )?;
        in_range(
            self.hall
                .sensor_offsets_deg
                .iter()
                .chain([&self.hall.offset_deg])
                .all(|d| d.is_finite()),
            "Hall placement",
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn string_kinds_parse_and_print() {
        for kind in StringKind::ALL {
            assert_eq!(kind.name().parse::<StringKind>(), Ok(kind));
        }
        assert_eq!("Polyester".parse::<StringKind>(), Ok(StringKind::TennisPolyester));
        assert!("spaghetti".parse::<StringKind>().is_err());
    }

    #[test]
    fn stiffness_spans_soft_badminton_to_stiff_polyester() {
        let mut lowest = f64::MAX;
        let mut highest = 0.0_f64;
        for kind in StringKind::STRINGS {
            let spec = kind.spec().unwrap();
            let k = spec.stiffness_kgf_per_cm();
            let (low, high) = spec.stiffness_range_kgf_per_cm;
            assert!(low <= k && k <= high, "{kind}: {k} outside {low}..{high}");
            lowest = lowest.min(low);
            highest = highest.max(high);
        }
        assert!(lowest <= 1.5 && highest >= 15.0, "{lowest}..{highest}");
    }

    #[test]
    fn motor_constants_reconcile_the_paper() {
        let (ke, i0) = motor_nominal::ke_and_no_load_current();
        let omega0 = motor_nominal::NO_LOAD_RPM * core::f64::consts::TAU / 60.0;
        let r = 2.0 * motor_nominal::PHASE_OHM;
        assert!((ke * omega0 + r * i0 - 24.0).abs() < 1e-9);
        assert!((ke * (5.5 - i0) - motor_nominal::RATED_TORQUE_NM).abs() < 1e-9);
        assert!((0.5..1.2).contains(&i0), "I0 = {i0}");
        let m = MotorParams::nominal();
        assert!((m.no_load_amps(omega0) - i0).abs() < 1e-9);
    }

    #[test]
    fn friction_coefficients_reproduce_the_efficiencies() {
        let m = MechanicsParams::nominal();
        let (a, b) = m.friction_coefficients();
        assert!(a > 0.0 && b > 0.0);
        assert!(((1.0 - b) / (1.0 + a) - m.efficiency_forward).abs() < 1e-12);
        assert!(((1.0 - a) / (1.0 + b) - m.efficiency_backward).abs() < 1e-12);
    }

    #[test]
    fn nominal_and_sampled_configs_are_valid() {
        for kind in StringKind::ALL {
            assert_eq!(TwinConfig::nominal(kind).check(), Ok(()));
        }
        assert_eq!(TwinConfig::motor_bench().check(), Ok(()));
        for seed in 0..500 {
            let c = TwinConfig::sample(seed);
            assert_eq!(c.check(), Ok(()), "seed {seed}");
            assert_eq!(c, TwinConfig::sample(seed));
            assert!(c.string.present());
        }
    }
}

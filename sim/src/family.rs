//! The family of machines: every parameter a real unit does not print on its nameplate,
//! with its range, a seeded draw of a whole machine from them, and one-axis sweeps.
//!
//! # Theory of operation
//!
//! The nameplate is fixed — 24 V BLDC, 3 700 rpm no-load, 2.85 kgf·cm at 5.5 A, 4 pole
//! pairs with Hall sensors, 1:20 gearbox, 25.4 mm screw lead, 12-bit ADC, 5–50 kgf — and
//! everything else a builder or a factory leaves to chance is a [`Span`] in [`ranges`], each
//! with the reasoning that bounds it (datasheet classes, physics; `sim/README.md` has the
//! table). A controller tuned to one machine must hold its figures on all of them.
//!
//! - [`TwinConfig::family`] draws a whole machine from a seed: the string kind, then every
//!   span (uniform, or uniform in the logarithm for ratios like "0.5–2×"), deterministic
//!   per seed. The motor is drawn as a nameplate-consistent motor: resistance, inductance,
//!   back-EMF shape and the no-load speed (±4 % of 3 700 rpm at 24 V) are drawn, and `Ke`
//!   and the no-load current follow from the nameplate's rated point ([`family_motor`]).
//! - [`TwinConfig::family_centre`] is the machine every sweep starts from: the nominal
//!   machine with the family's own motor derivation at nominal inputs (it runs at the
//!   nameplate's 3 700 rpm) and the features every real unit has — a 30 V bus clamp, a
//!   0.5 kg gripper outboard of the load cell (on a 1.5 kg carriage: the nominal 2 kg
//!   moving mass), 0.05 mm of backlash, 1 mV of 50 Hz hum — at typical values; everything
//!   else, including taut's own current sensing (DC link, mid on-time, unidirectional), as
//!   in [`TwinConfig::nominal`].
//! - [`TwinConfig::on_axis`] moves one [`Axis`] from its low end (`position` 0) to its high
//!   end (1) with everything else at the centre; [`Axis::span`] and [`Axis::describe_at`]
//!   print where it is.

use core::fmt;
use core::str::FromStr;

use crate::params::{
    ConfigError, CurrentSenseParams, GripperParams, HumParams, MotorParams, Screw, StringKind,
    TwinConfig, motor_nominal,
};
use crate::rng::SimRng;

/// How far past either end of a span [`Span::beyond`] and [`TwinConfig::beyond_axis`] go:
/// one span's width.
pub const BEYOND_MAX: f64 = 1.0;

/// A range of one parameter: its low and high end and how a draw spreads between them.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Span {
    /// The value at position 0.
    pub low: f64,
    /// The value at position 1.
    pub high: f64,
    /// Uniform in the logarithm (for ratios: "0.5–2×" puts as many machines below 1× as
    /// above) rather than in the value.
    pub logarithmic: bool,
}

impl Span {
    /// Uniform between `low` and `high`.
    #[must_use]
    pub const fn linear(low: f64, high: f64) -> Self {
        Self { low, high, logarithmic: false }
    }

    /// Uniform in the logarithm between `low` and `high` (both positive).
    #[must_use]
    pub const fn log(low: f64, high: f64) -> Self {
        Self { low, high, logarithmic: true }
    }

    /// The value at `position` (clamped to 0 ..= 1) between the ends.
    #[must_use]
    pub fn at(&self, position: f64) -> f64 {
        self.beyond(position.clamp(0.0, 1.0))
    }

    /// The value at `position` continued past the ends the same way (linearly, or in the
    /// logarithm), the position clamped to `−BEYOND_MAX ..= 1 + BEYOND_MAX`: −0.5 lies half
    /// the span below the low end. For `taut report robustness --beyond`, which asks how far
    /// past the family's ranges the controller still holds; whether such a value is physical
    /// is [`TwinConfig::check`]'s to say.
    #[must_use]
    pub fn beyond(&self, position: f64) -> f64 {
        let p = position.clamp(-BEYOND_MAX, 1.0 + BEYOND_MAX);
        if self.logarithmic {
            self.low * (self.high / self.low).powf(p)
        } else {
            self.low + (self.high - self.low) * p
        }
    }

    /// The position (0 ..= 1) of `value` in the span (the inverse of [`Span::at`]).
    #[must_use]
    pub fn position_of(&self, value: f64) -> f64 {
        let p = if self.logarithmic {
            (value / self.low).ln() / (self.high / self.low).ln()
        } else {
            (value - self.low) / (self.high - self.low)
        };
        p.clamp(0.0, 1.0)
    }

    /// One draw.
    pub fn draw(&self, rng: &mut SimRng) -> f64 {
        self.at(rng.uniform())
    }

    /// Whether `value` lies in the span (ends included, to a relative 10⁻⁹).
    #[must_use]
    pub fn contains(&self, value: f64) -> bool {
        let (low, high) =
            if self.low <= self.high { (self.low, self.high) } else { (self.high, self.low) };
        let slack = 1e-9 * low.abs().max(high.abs()).max(1e-12);
        value >= low - slack && value <= high + slack
    }
}

/// Every range of the family, with its reasoning. `sim/README.md` has the same table.
pub mod ranges {
    use super::Span;

    // Motor (the nameplate fixes 24 V, 3 700 rpm no-load, 2.85 kgf·cm at 5.5 A, 4 pole pairs).

    /// Rotor + gearbox inertia, × nominal (1.6 × 10⁻⁵ kg·m² at the motor shaft): 57 mm BLDCs
    /// of this rating list 0.8–3 × 10⁻⁵ for the rotor alone, and a gearbox adds 5–30 %.
    pub const INERTIA_SCALE: Span = Span::log(0.5, 2.0);
    /// Winding resistance per phase, Ω: 0.41 Ω ± 10 %, a datasheet's tolerance (a stringing
    /// machine's duty is light: the winding stays near room temperature).
    pub const WINDING_OHM: Span = Span::linear(0.369, 0.451);
    /// MOSFET on-resistance, Ω: the IRF2807's 13 mΩ at 25 °C to 1.7× at a warm junction.
    pub const MOSFET_OHM: Span = Span::linear(0.013, 0.022);
    /// Inductance per phase, H: 0.6–1.2 mH line to line, the class's datasheets.
    pub const INDUCTANCE_H: Span = Span::log(0.3e-3, 0.6e-3);
    /// No-load speed at 24 V, rpm: the nameplate's 3 700 ± 4 % (`Ke` follows, so the twin
    /// runs within ± 5 %).
    pub const NO_LOAD_RPM: Span = Span::linear(3_552.0, 3_848.0);
    /// The bearing (Coulomb) share of the no-load loss torque, N·m; the rest (≈ 0.03–0.06
    /// N·m at no-load speed, fixed by the nameplate's `I₀`) is speed-proportional.
    pub const MOTOR_COULOMB_NM: Span = Span::log(0.002, 0.010);
    /// Back-EMF ramp width, electrical degrees: 60° is the ideal 120° flat top, 100° a
    /// strongly rounded trapezoid.
    pub const EMF_RAMP_DEG: Span = Span::linear(60.0, 100.0);
    /// Cogging torque amplitude, N·m: 0.35–3.2 % of rated (skewed to unskewed stators).
    pub const COGGING_NM: Span = Span::log(0.001, 0.009);

    // Bus.

    /// Supply voltage, V (the lead's 20–30 V: any 24 V-class supply, adjusted or sagging).
    pub const SUPPLY_VOLTS: Span = Span::linear(20.0, 30.0);
    /// Supply output impedance and cable, Ω.
    pub const SUPPLY_OHM: Span = Span::log(0.025, 0.1);
    /// Bulk capacitance, F: one 470 µF to one 2200 µF electrolytic, ± 20 % tolerance
    /// included.
    pub const BUS_CAPACITANCE_F: Span = Span::log(470e-6, 2200e-6);
    /// The bus clamp (TVS or brake chopper), V; never below 1.1 × the supply (a TVS's
    /// stand-off voltage must exceed the supply, a chopper's threshold sits above it).
    pub const CLAMP_VOLTS: Span = Span::linear(28.0, 36.0);
    /// The clamp's lowest level as a multiple of the supply voltage.
    pub const CLAMP_OVER_SUPPLY: f64 = 1.1;
    /// Auxiliary load (MCU, gate drivers, load-cell excitation, display), A.
    pub const AUX_LOAD_AMPS: Span = Span::linear(0.05, 0.2);
    /// Hardware comparator level, A: 15 A ± 5 % (divider and comparator offset).
    pub const COMPARATOR_AMPS: Span = Span::linear(14.25, 15.75);

    // Drivetrain.

    /// Gearbox × screw efficiency, motor driving: a worn trapezoidal screw with a polymer
    /// nut (μ 0.15, 0.72) behind a 0.7 planetary (0.50) up to a ball screw (0.93) behind a
    /// good planetary (0.92: 0.86, the most the load-proportional friction law realises
    /// with a back-driven efficiency near the forward one).
    pub const EFFICIENCY_FORWARD: Span = Span::linear(0.86, 0.50);
    /// A ball screw behind a good gearbox ([`super::Axis::BallScrew`], a quarter of the
    /// family's machines): forward efficiency 0.80–0.91 …
    pub const BALL_SCREW_FORWARD: Span = Span::linear(0.80, 0.91);
    /// … and back-driven 0.76–0.905: the string turns the motor with almost all its pull
    /// when the drive lets go (within what the friction law realises, see
    /// [`super::back_driven_efficiency`]).
    pub const BALL_SCREW_BACKWARD: Span = Span::linear(0.76, 0.905);
    /// The share of the family's machines with a ball screw.
    pub const BALL_SCREW_SHARE: f64 = 0.25;
    /// How far the end stop lies past the home switch, mm: a generous 20 mm down to a frame
    /// whose stop is 1.5 mm past the switch.
    pub const OVERTRAVEL_MM: Span = Span::linear(20.0, 1.5);
    /// Back-driven / forward efficiency (lead screws lose more backwards), limited to what
    /// the friction law can realise (see [`super::back_driven_efficiency`]).
    pub const BACK_DRIVE_RATIO: Span = Span::linear(0.98, 0.85);
    /// Gearbox and screw no-load drag at the motor, N·m (0.5–2 × 0.003).
    pub const DRAG_NM: Span = Span::log(0.0015, 0.006);
    /// Carriage slide friction, N (linear guide on balls to a plain dovetail).
    pub const SLIDE_N: Span = Span::log(1.0, 4.0);
    /// Static / Coulomb friction (ball screw and rolling guide barely stick; a polymer nut on
    /// a trapezoidal screw sticks and slips).
    pub const STICTION: Span = Span::linear(1.02, 1.5);
    /// Carriage mass without the gripper, kg.
    pub const CARRIAGE_KG: Span = Span::linear(1.0, 2.5);
    /// Backlash of gearbox and screw at the carriage, mm: a 2-stage planetary's 0.25–1.5°
    /// at its output is 0.02–0.11 mm of carriage (25.4 mm per turn), a trapezoidal nut adds
    /// up to 0.1 mm, a preloaded ball nut nothing. 0.2 mm = 1.0 rad of motor angle.
    pub const BACKLASH_MM: Span = Span::linear(0.0, 0.2);

    // Gripper and load cell.

    /// Gripper mass outboard of the load cell, kg: a small aluminium clamp to a rotating
    /// steel gripper head with its bearing.
    pub const GRIPPER_KG: Span = Span::linear(0.2, 1.5);
    /// Load-cell stiffness, N/m: a 50 kgf beam or S-type cell deflects 0.1–0.3 mm at full
    /// scale.
    pub const LOAD_CELL_STIFFNESS: Span = Span::log(1.6e6, 4.9e6);
    /// Damping ratio of the gripper ringing on the load cell (structural damping).
    pub const GRIPPER_DAMPING: Span = Span::linear(0.02, 0.1);
    /// Load-cell chain sensitivity, V/kgf: 92 mV/kgf ± 10 % (rated output tolerance of an
    /// uncalibrated cell and the amplifier's gain resistors).
    pub const SENSITIVITY: Span = Span::linear(0.0828, 0.1012);
    /// Output at zero load, V: the cell's zero balance (± 2 % of full scale) through the
    /// amplifier around its designed 50 mV, kept above the rail it cannot go below.
    pub const ZERO_VOLTS: Span = Span::linear(0.02, 0.15);
    /// Low-load deficit `c` (paper fig. 21: poor linearity below 5 kg).
    pub const LOW_LOAD_DEFICIT: Span = Span::linear(0.1, 0.5);
    /// Scale `F_k` of the low-load non-linearity, kgf. The paper's own test (fig. 21) found
    /// the chain linear from 5 to 40 kg and poorly linear below 5 kg, so the deficit must
    /// have died away by 5–10 kgf: at `F_k` = 2.5 (the nominal, the top) and c = 0.5 it is
    /// 0.17 kgf at 5 kgf and 0.02 at 10. (The earlier 1–4 kgf reached 0.11 kgf at the
    /// 10 kg calibration point — a cell that fails the paper's linearity test — and the
    /// 4-point line could not follow it: 0.03–0.06 kgf of calibration error at 8–20 kgf.)
    pub const LOW_LOAD_SCALE_KGF: Span = Span::linear(0.5, 2.5);
    /// Relative gain change at 50 kgf (strain-gauge linearity class 0.1–0.3 %).
    pub const QUADRATIC: Span = Span::linear(-0.003, 0.003);
    /// Amplifier / anti-alias bandwidth, Hz.
    pub const BANDWIDTH_HZ: Span = Span::log(100.0, 1000.0);
    /// White noise at the ADC input, V rms (0.005–0.04 kgf).
    pub const NOISE_VOLTS: Span = Span::log(0.5e-3, 4e-3);
    /// Mains hum, peak at the amplifier output, V (0–0.11 kgf): 0–40 µV picked up at the
    /// bridge (a few mV/V cell) through the ≈ 250× amplifier.
    pub const HUM_VOLTS: Span = Span::linear(0.0, 0.010);
    /// Mains frequency error (the grid's ± 1 %), × 50 or 60 Hz.
    pub const HUM_FREQUENCY_SCALE: Span = Span::linear(0.99, 1.01);
    /// Probability of a switching spike per sample while the PWM switches ("a few %").
    pub const SPIKE_PWM_PROBABILITY: Span = Span::linear(0.0, 0.05);
    /// Probability of a spike when a commutation happened in the period before the sample.
    pub const SPIKE_COMMUTATION_PROBABILITY: Span = Span::linear(0.1, 0.6);
    /// Spike amplitude independent of the current, V (up to 4.3 kgf at 92 mV/kgf).
    pub const SPIKE_BASE_VOLTS: Span = Span::linear(0.02, 0.4);
    /// Spike amplitude per ampere switched, V/A (at 3 A the largest spike is 6.3 kgf).
    pub const SPIKE_VOLTS_PER_AMP: Span = Span::linear(0.005, 0.06);
    /// Probability per switching sample that a burst of spikes starts (none to one in 100
    /// samples: a gate driver ringing across several conversions).
    pub const SPIKE_BURST_PROBABILITY: Span = Span::linear(0.0, 0.01);
    /// The longest burst, samples: 1 (single spikes) to 5.
    pub const SPIKE_BURST_SAMPLES: Span = Span::linear(1.0, 5.0);
    /// How fast the amplifier's zero moves at power-up while the chain warms, V/s (either
    /// sign; ± 6 mV a minute at the ends, ± 0.065 kgf/min at 92 mV/kgf). A strain-gauge
    /// chain's zero moves ≈ 1–1.5 mV/K at the output (the bridge's zero coefficient of 0.02 %
    /// of full scale per kelvin, an instrumentation amplifier's 1 µV/K times its gain of a few
    /// hundred) and the
    /// excitation and the amplifier warm the bridge and board by a few kelvin over their first
    /// minutes: a few mV over minutes, a board still warming briskly at the ends.
    pub const ZERO_DRIFT_VOLTS_PER_S: Span = Span::linear(-0.1e-3, 0.1e-3);
    /// The time constant over which that warm-up settles, s: a small amplifier board's and a
    /// load cell's thermal time constant (the ends settle at ± 12–30 mV, ≤ 0.33 kgf).
    pub const ZERO_DRIFT_SETTLE_S: Span = Span::linear(120.0, 300.0);

    // Current and bus sensing.

    /// Relative gain error of shunt × amplifier (1 % shunt, 1 % resistors).
    pub const CURRENT_GAIN_ERROR: Span = Span::linear(-0.03, 0.03);
    /// Offset error of a unidirectional amplifier, A at the input (± 10 mV at 0.2 V/A).
    pub const CURRENT_OFFSET_UNIDIRECTIONAL: Span = Span::linear(-0.05, 0.05);
    /// Offset error of a bidirectional amplifier, A at the input (± 25 mV at 0.1 V/A: the
    /// mid-rail divider's 1 % and the op-amp's offset).
    pub const CURRENT_OFFSET_BIDIRECTIONAL: Span = Span::linear(-0.25, 0.25);
    /// Noise per current sample, A rms.
    pub const CURRENT_NOISE: Span = Span::linear(0.01, 0.06);
    /// Time constant of a filtered DC link's RC, s (2–20 PWM periods).
    pub const DC_LINK_RC_S: Span = Span::log(0.1e-3, 1e-3);
    /// Where in the PWM period a filtered DC link is converted, fraction of the period.
    pub const DC_LINK_SAMPLE_PHASE: Span = Span::linear(0.0, 1.0);
    /// Bus divider ratio: 1:12 with 1 % resistors (± 2 %).
    pub const BUS_DIVIDER: Span = Span::linear(11.76, 12.24);
    /// Bus-voltage noise at the ADC pin, V rms.
    pub const BUS_NOISE_VOLTS: Span = Span::linear(0.5e-3, 3e-3);

    // Hall sensors and encoder.

    /// The bound on every Hall edge's error, electrical degrees (± 5°): the
    /// [`Axis::HallError`](super::Axis::HallError) sweep moves all three sensors across it.
    pub const HALL_EDGE_DEG: Span = Span::linear(-5.0, 5.0);
    /// Common Hall mounting error, electrical degrees: the sensor board's rotation against
    /// the stator (± 0.9° mechanical at 4 pole pairs), the dominant error.
    pub const HALL_COMMON_DEG: Span = Span::linear(-3.5, 3.5);
    /// Each sensor's own error on top, electrical degrees: ± 0.1 mm placement at a 20 mm
    /// radius (± 1.1°) and the switching threshold's spread. Common + own stays within
    /// [`HALL_EDGE_DEG`].
    pub const HALL_SENSOR_DEG: Span = Span::linear(-1.5, 1.5);
    /// Per-read, per-line flip probability (voted out by the firmware).
    pub const HALL_FLIP: Span = Span::linear(0.0, 0.01);
    /// Per-period burst probability (survives the vote).
    pub const HALL_BURST: Span = Span::linear(0.0, 1e-5);
    /// Encoder scale error (wheel wear, slip).
    pub const ENCODER_SCALE_ERROR: Span = Span::linear(-0.02, 0.02);

    // String (the stiffness range is per kind: `StringSpec::stiffness_range_kgf_per_cm`).

    /// Slack before the string is straight, mm.
    pub const SLACK_MM: Span = Span::linear(10.0, 60.0);
    /// Straightening toe, mm.
    pub const TOE_MM: Span = Span::linear(0.5, 3.0);
    /// Relaxation arms' stiffness fractions, × the kind's.
    pub const RELAXATION_FRACTION_SCALE: Span = Span::linear(0.5, 1.5);
    /// Relaxation arms' time constants, × the kind's.
    pub const RELAXATION_TIME_SCALE: Span = Span::linear(0.6, 1.6);
    /// Rate-independent hysteresis, the share `h` of the tension the string's internal
    /// friction adds drawn out and takes off let back: none to 3 % (a loop 6 % of the tension
    /// wide, a quasi-static loss of ≈ 6 % of the stored energy per cycle — the rate-free
    /// part of the 5–15 % a polyamide, polyester or gut string loses over a load cycle; the
    /// rate-dependent part is the relaxation arms').
    pub const STRING_HYSTERESIS: Span = Span::linear(0.0, 0.03);
    /// The string extension over which the friction turns round after a reversal, mm: the
    /// microslip of the polymer chains or gut fibres, a small part of the millimetres of
    /// stretch a pull adds.
    pub const HYSTERESIS_STRAIN_MM: Span = Span::linear(0.05, 0.2);
}

/// The back-driven efficiency for a forward efficiency `forward` at `position` (0 ..= 1)
/// of [`ranges::BACK_DRIVE_RATIO`], kept where the load-proportional friction law
/// `a·|T_load| + b·|T_motor|` can realise it (`a, b ≥ 0`: `2 − 1/η_f ≤ η_b ≤ 1/(2 − η_f)`),
/// a hair inside.
#[must_use]
pub fn back_driven_efficiency(forward: f64, position: f64) -> f64 {
    let ratio = ranges::BACK_DRIVE_RATIO;
    let (ratio_low, ratio_high) = (ratio.low.min(ratio.high), ratio.low.max(ratio.high));
    let low = (ratio_low * forward).max(2.0 - 1.0 / forward + 1e-6);
    let high = (ratio_high * forward).min(1.0 / (2.0 - forward) - 1e-6);
    Span::linear(high, low).at(position)
}

/// The ball screw's efficiencies at `position` (0 ..= 1, continued beyond) of
/// [`ranges::BALL_SCREW_FORWARD`] and [`ranges::BALL_SCREW_BACKWARD`]: (forward, backward),
/// the backward one kept where the friction law realises it (as
/// [`back_driven_efficiency`]).
#[must_use]
pub fn ball_screw_efficiency(position: f64) -> (f64, f64) {
    let forward = ranges::BALL_SCREW_FORWARD.beyond(position);
    let backward = ranges::BALL_SCREW_BACKWARD
        .beyond(position)
        .max(2.0 - 1.0 / forward + 1e-6)
        .min(1.0 / (2.0 - forward) - 1e-6);
    (forward, backward)
}

/// The longest spike burst at `position` of [`ranges::SPIKE_BURST_SAMPLES`], samples (at
/// least 1).
fn burst_samples(position: f64) -> u32 {
    ranges::SPIKE_BURST_SAMPLES.beyond(position).round().clamp(1.0, 64.0) as u32
}

/// The six-step commutation overlap's voltage loss as a multiple of the six-pulse
/// rectifier's `(3/π)·ω_e·L·I`: measured on the twin (trapezoidal back-EMF, dead time), where
/// the rectifier formula alone leaves the no-load speed 0.5 % low.
const OVERLAP_FACTOR: f64 = 1.25;

/// The nameplate-consistent motor: `winding_ohm` + `mosfet_ohm` per phase, `inductance_h`,
/// the no-load speed `no_load_rpm` at 24 V, the back-EMF `ramp_deg`, the Coulomb share
/// `coulomb_nm` of the no-load loss, and the nominal inertia and cogging. `Ke` and the
/// no-load current `I₀` solve the nameplate's two points (`motor_nominal`) with the no-load
/// loop's resistance `2R` plus the commutation overlap's `(3/π)·p·ω₀·L` (the voltage lost
/// at every sector change while the current moves between phase inductances), so the
/// twin's own no-load speed lands on `no_load_rpm` (within ± 0.5 % over the family's
/// inductances and back-EMF shapes: `sim/tests/family.rs`).
#[must_use]
pub fn family_motor(
    winding_ohm: f64,
    mosfet_ohm: f64,
    inductance_h: f64,
    no_load_rpm: f64,
    ramp_deg: f64,
    coulomb_nm: f64,
) -> MotorParams {
    let mut m = MotorParams::nominal();
    let omega0 = no_load_rpm * core::f64::consts::TAU / 60.0;
    let resistance = winding_ohm + mosfet_ohm;
    let overlap = OVERLAP_FACTOR * 3.0 / core::f64::consts::PI
        * f64::from(m.pole_pairs)
        * omega0
        * inductance_h;
    let (ke, i0) =
        motor_nominal::ke_and_no_load_current_for(no_load_rpm, 2.0 * resistance + overlap);
    m.phase_resistance_ohm = resistance;
    m.phase_inductance_h = inductance_h;
    m.ke_volts_per_rad_s = ke;
    m.emf_ramp_deg = ramp_deg;
    m.coulomb_torque_nm = coulomb_nm.min(0.5 * ke * i0);
    m.viscous_nm_per_rad_s = (ke * i0 - m.coulomb_torque_nm) / omega0;
    m
}

/// One uncertainty axis of the family, swept alone by [`TwinConfig::on_axis`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Axis {
    /// Rotor + gearbox inertia, 0.5–2× nominal.
    Inertia,
    /// Drivetrain efficiency and friction together: position 0 is the ball-screw-like end
    /// (η_f 0.86, little stiction, a carriage that coasts far), 1 a worn trapezoidal screw.
    Friction,
    /// Backlash of gearbox and screw, 0–0.2 mm at the carriage.
    Backlash,
    /// Winding resistance ± 10 % (`Ke` re-derived from the nameplate).
    MotorResistance,
    /// No-load speed 3 700 rpm ± 4 % at 24 V, i.e. `Ke`.
    MotorSpeedConstant,
    /// Winding inductance 0.3–0.6 mH per phase.
    MotorInductance,
    /// Back-EMF shape: ramps 60–100° (ideal trapezoid to strongly rounded).
    BackEmfShape,
    /// Cogging torque 0.001–0.009 N·m.
    Cogging,
    /// Load-cell sensitivity 92 mV/kgf ± 10 %.
    LoadCellGain,
    /// Load-cell zero 20–150 mV.
    LoadCellZero,
    /// Load-cell low-force non-linearity (deficit, its scale, the quadratic term).
    LoadCellNonlinearity,
    /// Load-cell amplifier bandwidth 100–1000 Hz.
    LoadCellBandwidth,
    /// Load-cell noise 0.5–4 mV rms with mains hum 0–10 mV peak.
    LoadCellNoiseHum,
    /// Switching spikes: none to "a few % of samples, up to 6 kgf".
    Spikes,
    /// Spike bursts: none to 1 % of switching samples starting a burst of up to 5
    /// consecutive spikes of one sign.
    SpikeBursts,
    /// Gripper mass outboard of the load cell, 0.2–1.5 kg.
    GripperMass,
    /// Hall mounting error, −5° to +5° electrical, all three sensors together.
    HallError,
    /// Supply voltage 20–30 V (the clamp stays ≥ 1.1× the supply).
    BusSupply,
    /// Bus clamp 28–36 V.
    BusClamp,
    /// Bulk capacitance 470–2200 µF.
    BusCapacitance,
    /// The current-sensing board: DC link mid on-time unidirectional (taut's), DC link mid
    /// on-time bidirectional, DC link RC unidirectional, DC link RC bidirectional,
    /// per-phase low side.
    CurrentSensing,
    /// String stiffness across the kind's range.
    StringStiffness,
    /// String creep: relaxation fractions ×0.5 with time constants ×1.6 (least) to ×1.5
    /// with ×0.6 (most).
    Creep,
    /// String slack 10–60 mm.
    Slack,
    /// A ball screw that back-drives: efficiency forward 0.80–0.91, back-driven 0.76–0.905,
    /// with the family's least drag and stiction.
    BallScrew,
    /// The end stop past the home switch: 20 mm down to 1.5 mm.
    EndStop,
    /// String hysteresis: none to a loop of ± 3 % of the tension (drawn out above, let back
    /// below), turning round over 0.1 mm of extension.
    StringHysteresis,
    /// The load-cell amplifier's zero warming up: moving at −0.1 to +0.1 mV/s from power-up
    /// (none at the middle), settling over 3 minutes.
    LoadCellZeroDrift,
}

/// The headline quantity an axis moves, with its value at each end, for printing.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct AxisSpan {
    /// What moves.
    pub quantity: &'static str,
    /// Its unit (empty for a ratio).
    pub unit: &'static str,
    /// Its value at position 0.
    pub at_low_end: f64,
    /// Its value at position 1.
    pub at_high_end: f64,
}

impl fmt::Display for AxisSpan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} … {} {}", self.quantity, self.at_low_end, self.at_high_end, self.unit)
    }
}

/// Why an axis name was not understood.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct UnknownAxis;

impl fmt::Display for UnknownAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("unknown axis (expected one of: ")?;
        for (k, axis) in Axis::ALL.iter().enumerate() {
            if k > 0 {
                f.write_str(", ")?;
            }
            f.write_str(axis.name())?;
        }
        f.write_str(")")
    }
}

impl std::error::Error for UnknownAxis {}

/// The boards [`Axis::CurrentSensing`] steps through, position 0 to 1.
const SENSING_BOARDS: usize = 5;

/// The current-sensing board at `index` of [`Axis::CurrentSensing`].
fn sensing_board(index: usize) -> CurrentSenseParams {
    // A mid-range filter, read in the middle of the period.
    let (tau, phase) = (0.3e-3, 0.5);
    match index {
        0 => CurrentSenseParams::dc_link_mid_on_time(false),
        1 => CurrentSenseParams::dc_link_mid_on_time(true),
        2 => CurrentSenseParams::dc_link_filtered(false, tau, phase),
        3 => CurrentSenseParams::dc_link_filtered(true, tau, phase),
        _ => CurrentSenseParams::per_phase_low_side(),
    }
}

/// The board index for a position on [`Axis::CurrentSensing`].
fn sensing_index(position: f64) -> usize {
    let last = (SENSING_BOARDS - 1) as f64;
    (position.clamp(0.0, 1.0) * last).round() as usize
}

impl Axis {
    /// Every axis, in the order reports print them.
    pub const ALL: [Self; 28] = [
        Self::Inertia,
        Self::Friction,
        Self::Backlash,
        Self::MotorResistance,
        Self::MotorSpeedConstant,
        Self::MotorInductance,
        Self::BackEmfShape,
        Self::Cogging,
        Self::LoadCellGain,
        Self::LoadCellZero,
        Self::LoadCellNonlinearity,
        Self::LoadCellBandwidth,
        Self::LoadCellNoiseHum,
        Self::Spikes,
        Self::SpikeBursts,
        Self::GripperMass,
        Self::HallError,
        Self::BusSupply,
        Self::BusClamp,
        Self::BusCapacitance,
        Self::CurrentSensing,
        Self::StringStiffness,
        Self::Creep,
        Self::Slack,
        Self::BallScrew,
        Self::EndStop,
        Self::StringHysteresis,
        Self::LoadCellZeroDrift,
    ];

    /// The command-line name (`inertia`, `load-cell-noise-hum`, …), also what [`FromStr`]
    /// accepts.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Inertia => "inertia",
            Self::Friction => "friction",
            Self::Backlash => "backlash",
            Self::MotorResistance => "motor-resistance",
            Self::MotorSpeedConstant => "motor-speed-constant",
            Self::MotorInductance => "motor-inductance",
            Self::BackEmfShape => "back-emf-shape",
            Self::Cogging => "cogging",
            Self::LoadCellGain => "load-cell-gain",
            Self::LoadCellZero => "load-cell-zero",
            Self::LoadCellNonlinearity => "load-cell-nonlinearity",
            Self::LoadCellBandwidth => "load-cell-bandwidth",
            Self::LoadCellNoiseHum => "load-cell-noise-hum",
            Self::Spikes => "spikes",
            Self::SpikeBursts => "spike-bursts",
            Self::GripperMass => "gripper-mass",
            Self::HallError => "hall-error",
            Self::BusSupply => "bus-supply",
            Self::BusClamp => "bus-clamp",
            Self::BusCapacitance => "bus-capacitance",
            Self::CurrentSensing => "current-sensing",
            Self::StringStiffness => "string-stiffness",
            Self::Creep => "creep",
            Self::Slack => "slack",
            Self::BallScrew => "ball-screw",
            Self::EndStop => "end-stop",
            Self::StringHysteresis => "string-hysteresis",
            Self::LoadCellZeroDrift => "load-cell-zero-drift",
        }
    }

    /// The headline quantity the axis moves and its value at both ends; for
    /// [`Axis::StringStiffness`] the ends depend on the kind (those of the tennis-poly
    /// range are given; see [`Axis::span_for`]).
    #[must_use]
    pub fn span(self) -> AxisSpan {
        self.span_for(StringKind::TennisPolyester)
    }

    /// [`Axis::span`] for a string `kind`.
    #[must_use]
    pub fn span_for(self, kind: StringKind) -> AxisSpan {
        use ranges as r;
        let s = |quantity, unit, span: Span| AxisSpan {
            quantity,
            unit,
            at_low_end: span.low,
            at_high_end: span.high,
        };
        // A span printed in another unit than the range's (mV of volts, % of a fraction).
        let scaled = |quantity, unit, span: Span, factor: f64| AxisSpan {
            quantity,
            unit,
            at_low_end: span.low * factor,
            at_high_end: span.high * factor,
        };
        match self {
            Self::Inertia => s("rotor + gearbox inertia", "× nominal", r::INERTIA_SCALE),
            Self::Friction => s("forward efficiency", "", r::EFFICIENCY_FORWARD),
            Self::Backlash => s("backlash", "mm", r::BACKLASH_MM),
            Self::MotorResistance => s("winding resistance", "Ω", r::WINDING_OHM),
            Self::MotorSpeedConstant => s("no-load speed at 24 V", "rpm", r::NO_LOAD_RPM),
            Self::MotorInductance => scaled("phase inductance", "mH", r::INDUCTANCE_H, 1e3),
            Self::BackEmfShape => s("back-EMF ramp", "° el.", r::EMF_RAMP_DEG),
            Self::Cogging => s("cogging torque", "N·m", r::COGGING_NM),
            Self::LoadCellGain => scaled("load-cell sensitivity", "mV/kgf", r::SENSITIVITY, 1e3),
            Self::LoadCellZero => scaled("load-cell zero", "mV", r::ZERO_VOLTS, 1e3),
            Self::LoadCellNonlinearity => s("low-load deficit c", "", r::LOW_LOAD_DEFICIT),
            Self::LoadCellBandwidth => s("load-cell bandwidth", "Hz", r::BANDWIDTH_HZ),
            Self::LoadCellNoiseHum => scaled("mains hum (peak)", "mV", r::HUM_VOLTS, 1e3),
            Self::Spikes => AxisSpan {
                quantity: "largest spike at 3 A",
                unit: "kgf",
                at_low_end: 0.0,
                at_high_end: largest_spike_kgf(1.0, 3.0),
            },
            Self::SpikeBursts => s("burst probability", "per sample", r::SPIKE_BURST_PROBABILITY),
            Self::GripperMass => s("gripper mass", "kg", r::GRIPPER_KG),
            Self::HallError => s("Hall mounting error", "° el.", r::HALL_EDGE_DEG),
            Self::BusSupply => s("supply voltage", "V", r::SUPPLY_VOLTS),
            Self::BusClamp => s("bus clamp", "V", r::CLAMP_VOLTS),
            Self::BusCapacitance => scaled("bulk capacitance", "µF", r::BUS_CAPACITANCE_F, 1e6),
            Self::CurrentSensing => AxisSpan {
                quantity: "current-sensing board",
                unit: "of 0 … 4",
                at_low_end: 0.0,
                at_high_end: (SENSING_BOARDS - 1) as f64,
            },
            Self::StringStiffness => {
                let (low, high) = kind.spec().map_or((0.0, 0.0), |s| s.stiffness_range_kgf_per_cm);
                AxisSpan {
                    quantity: "string stiffness",
                    unit: "kgf/cm",
                    at_low_end: low,
                    at_high_end: high,
                }
            }
            Self::Creep => AxisSpan {
                quantity: "relaxation fractions",
                unit: "× the kind's",
                at_low_end: r::RELAXATION_FRACTION_SCALE.low,
                at_high_end: r::RELAXATION_FRACTION_SCALE.high,
            },
            Self::Slack => s("slack", "mm", r::SLACK_MM),
            Self::BallScrew => s("back-driven efficiency", "", r::BALL_SCREW_BACKWARD),
            Self::EndStop => s("end stop past the home switch", "mm", r::OVERTRAVEL_MM),
            Self::StringHysteresis => {
                scaled("string hysteresis", "% of the tension", r::STRING_HYSTERESIS, 100.0)
            }
            Self::LoadCellZeroDrift => {
                scaled("load-cell zero drift at power-up", "mV/s", r::ZERO_DRIFT_VOLTS_PER_S, 1e3)
            }
        }
    }

    /// The axis at `position` in words, e.g. `inertia: rotor + gearbox inertia 1.41 × nominal`
    /// or `current-sensing: per-phase/bidirectional`.
    #[must_use]
    pub fn describe_at(self, position: f64, kind: StringKind) -> String {
        let p = position.clamp(-BEYOND_MAX, 1.0 + BEYOND_MAX);
        match self {
            Self::CurrentSensing => {
                format!("{}: {}", self.name(), sensing_board(sensing_index(p)).name())
            }
            Self::Spikes => format!(
                "{}: largest spike at 3 A {:.2} kgf, {:.1} % of switching samples",
                self.name(),
                largest_spike_kgf(p, 3.0),
                100.0 * Span::linear(0.0, ranges::SPIKE_PWM_PROBABILITY.high).beyond(p)
            ),
            Self::SpikeBursts => format!(
                "{}: {:.2} % of switching samples start a burst of up to {} spikes",
                self.name(),
                100.0 * ranges::SPIKE_BURST_PROBABILITY.beyond(p),
                burst_samples(p)
            ),
            Self::BallScrew => {
                let (forward, backward) = ball_screw_efficiency(p);
                format!(
                    "{}: efficiency forward {forward:.3}, back-driven {backward:.3}",
                    self.name()
                )
            }
            Self::StringHysteresis => format!(
                "{}: ± {:.2} % of the tension, turning round over {:.2} mm",
                self.name(),
                100.0 * ranges::STRING_HYSTERESIS.beyond(p),
                centre_hysteresis_strain_mm()
            ),
            Self::LoadCellZeroDrift => {
                let rate = ranges::ZERO_DRIFT_VOLTS_PER_S.beyond(p);
                format!(
                    "{}: zero moving {:+.3} mV/s ({:+.3} kgf/min at 92 mV/kgf), settling over {:.0} s",
                    self.name(),
                    rate * 1e3,
                    rate * 60.0 / 0.092,
                    centre_zero_drift_settle_s()
                )
            }
            Self::LoadCellNoiseHum => format!(
                "{}: noise {:.2} mV rms, hum {:.2} mV peak",
                self.name(),
                ranges::NOISE_VOLTS.beyond(p) * 1e3,
                ranges::HUM_VOLTS.beyond(p) * 1e3
            ),
            _ => {
                let span = self.span_for(kind);
                let value = if self.logarithmic() {
                    Span::log(span.at_low_end, span.at_high_end).beyond(p)
                } else {
                    Span::linear(span.at_low_end, span.at_high_end).beyond(p)
                };
                format!("{}: {} {value:.4} {}", self.name(), span.quantity, span.unit)
            }
        }
    }

    /// Whether the headline quantity moves uniformly in its logarithm.
    fn logarithmic(self) -> bool {
        use ranges as r;
        match self {
            Self::Inertia => r::INERTIA_SCALE.logarithmic,
            Self::MotorInductance => r::INDUCTANCE_H.logarithmic,
            Self::Cogging => r::COGGING_NM.logarithmic,
            Self::LoadCellBandwidth => r::BANDWIDTH_HZ.logarithmic,
            Self::BusCapacitance => r::BUS_CAPACITANCE_F.logarithmic,
            _ => false,
        }
    }
}

/// The largest spike (before the random 0.3–1 factor) at `amps` with the spike spans at
/// `position`, kgf at the nominal sensitivity.
fn largest_spike_kgf(position: f64, amps: f64) -> f64 {
    let volts = ranges::SPIKE_BASE_VOLTS.beyond(position)
        + ranges::SPIKE_VOLTS_PER_AMP.beyond(position) * amps;
    volts / 0.092
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Axis {
    type Err = UnknownAxis;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let wanted = s.trim().to_ascii_lowercase().replace('_', "-");
        Self::ALL.into_iter().find(|axis| axis.name() == wanted).ok_or(UnknownAxis)
    }
}

/// The string hysteresis's turn-round strain on the family's centre machine (and along
/// [`Axis::StringHysteresis`]), mm.
fn centre_hysteresis_strain_mm() -> f64 {
    crate::params::StringParams::nominal(StringKind::TennisPolyester).hysteresis_strain_mm
}

/// The load-cell warm-up's settling time on the family's centre machine (and along
/// [`Axis::LoadCellZeroDrift`]), s.
fn centre_zero_drift_settle_s() -> f64 {
    crate::params::LoadCellParams::nominal().zero_drift_settle_s
}

/// The family centre's motor: [`family_motor`] at the nominal inputs.
fn centre_motor() -> MotorParams {
    let m = MotorParams::nominal();
    family_motor(
        motor_nominal::WINDING_OHM,
        motor_nominal::MOSFET_OHM,
        m.phase_inductance_h,
        motor_nominal::NO_LOAD_RPM,
        m.emf_ramp_deg,
        m.coulomb_torque_nm,
    )
}

impl TwinConfig {
    /// The machine every [`TwinConfig::on_axis`] sweep starts from (see the module docs):
    /// [`TwinConfig::nominal`] with the family's motor derivation at nominal inputs, a 30 V
    /// clamp, a 0.5 kg gripper on a 1.5 kg carriage, 0.05 mm of backlash and 1 mV of 50 Hz
    /// hum. Seed 0.
    #[must_use]
    pub fn family_centre(kind: StringKind) -> Self {
        let mut c = Self::nominal(kind);
        c.motor = centre_motor();
        c.bridge.clamp_volts = Some(30.0);
        c.mechanics.carriage_mass_kg = 1.5;
        c.mechanics.gripper = GripperParams { mass_kg: 0.5, ..GripperParams::none() };
        c.mechanics.backlash_mm = 0.05;
        c.load_cell.hum = HumParams { frequency_hz: 50.0, volts: 1e-3, phase_deg: 0.0 };
        c
    }

    /// A machine of the family: a string kind drawn uniformly from
    /// [`StringKind::STRINGS`], then [`TwinConfig::family_kind`].
    #[must_use]
    pub fn family(seed: u64) -> Self {
        let mut rng = SimRng::substream(seed, 0xFA41);
        let index = rng.below(5);
        let kind = StringKind::STRINGS.into_iter().nth(index as usize);
        Self::family_kind(kind.unwrap_or(StringKind::TennisSynthetic), seed)
    }

    /// A machine of the family with a given string kind: every span of [`ranges`] drawn
    /// (see `sim/README.md`), deterministic per `seed`, which also seeds the run's noise.
    #[must_use]
    pub fn family_kind(kind: StringKind, seed: u64) -> Self {
        use ranges as r;
        let mut c = Self::family_centre(kind).with_seed(seed);

        let mut rng = SimRng::substream(seed, 0xFA42);
        let inertia = r::INERTIA_SCALE.draw(&mut rng);
        c.motor = family_motor(
            r::WINDING_OHM.draw(&mut rng),
            r::MOSFET_OHM.draw(&mut rng),
            r::INDUCTANCE_H.draw(&mut rng),
            r::NO_LOAD_RPM.draw(&mut rng),
            r::EMF_RAMP_DEG.draw(&mut rng),
            r::MOTOR_COULOMB_NM.draw(&mut rng),
        );
        c.motor.rotor_inertia_kg_m2 *= inertia;
        c.mechanics.gear_inertia_kg_m2 *= inertia;
        c.motor.cogging_torque_nm = r::COGGING_NM.draw(&mut rng);

        let mut rng = SimRng::substream(seed, 0xFA43);
        let b = &mut c.bridge;
        b.bus_volts = r::SUPPLY_VOLTS.draw(&mut rng);
        b.supply_ohm = r::SUPPLY_OHM.draw(&mut rng);
        b.bus_capacitance_f = r::BUS_CAPACITANCE_F.draw(&mut rng);
        let lowest_clamp = r::CLAMP_VOLTS.low.max(r::CLAMP_OVER_SUPPLY * b.bus_volts);
        b.clamp_volts = Some(Span::linear(lowest_clamp, r::CLAMP_VOLTS.high).draw(&mut rng));
        b.aux_load_amps = r::AUX_LOAD_AMPS.draw(&mut rng);
        b.comparator_amps = r::COMPARATOR_AMPS.draw(&mut rng);

        let mut rng = SimRng::substream(seed, 0xFA44);
        let k = &mut c.mechanics;
        k.efficiency_forward = r::EFFICIENCY_FORWARD.draw(&mut rng);
        k.efficiency_backward = back_driven_efficiency(k.efficiency_forward, rng.uniform());
        k.drag_torque_nm = r::DRAG_NM.draw(&mut rng);
        k.slide_friction_n = r::SLIDE_N.draw(&mut rng);
        k.stiction_ratio = r::STICTION.draw(&mut rng);
        k.carriage_mass_kg = r::CARRIAGE_KG.draw(&mut rng);
        k.backlash_mm = r::BACKLASH_MM.draw(&mut rng);
        k.gripper = GripperParams {
            mass_kg: r::GRIPPER_KG.draw(&mut rng),
            load_cell_stiffness_n_per_m: r::LOAD_CELL_STIFFNESS.draw(&mut rng),
            damping_ratio: r::GRIPPER_DAMPING.draw(&mut rng),
        };

        let mut rng = SimRng::substream(seed, 0xFA45);
        let l = &mut c.load_cell;
        l.volts_per_kgf = r::SENSITIVITY.draw(&mut rng);
        l.zero_volts = r::ZERO_VOLTS.draw(&mut rng);
        l.low_load_deficit = r::LOW_LOAD_DEFICIT.draw(&mut rng);
        l.low_load_scale_kgf = r::LOW_LOAD_SCALE_KGF.draw(&mut rng);
        l.quadratic_at_50_kgf = r::QUADRATIC.draw(&mut rng);
        l.bandwidth_hz = r::BANDWIDTH_HZ.draw(&mut rng);
        l.noise_volts = r::NOISE_VOLTS.draw(&mut rng);
        let mains = if rng.chance(0.5) { 50.0 } else { 60.0 };
        l.hum = HumParams {
            frequency_hz: mains * r::HUM_FREQUENCY_SCALE.draw(&mut rng),
            volts: r::HUM_VOLTS.draw(&mut rng),
            phase_deg: rng.range(0.0, 360.0),
        };
        l.spikes.pwm_probability = r::SPIKE_PWM_PROBABILITY.draw(&mut rng);
        l.spikes.commutation_probability = r::SPIKE_COMMUTATION_PROBABILITY.draw(&mut rng);
        l.spikes.base_volts = r::SPIKE_BASE_VOLTS.draw(&mut rng);
        l.spikes.volts_per_amp = r::SPIKE_VOLTS_PER_AMP.draw(&mut rng);

        // The axes added for back-driving screws, spike bursts and close end stops draw
        // from their own stream, so every earlier draw is what it was.
        let mut rng = SimRng::substream(seed, 0xFA49);
        let spikes = &mut c.load_cell.spikes;
        spikes.burst_probability = r::SPIKE_BURST_PROBABILITY.draw(&mut rng);
        spikes.burst_samples_max = burst_samples(rng.uniform());
        c.mechanics.overtravel_mm = r::OVERTRAVEL_MM.draw(&mut rng);
        if rng.chance(r::BALL_SCREW_SHARE) {
            let k = &mut c.mechanics;
            k.screw = Screw::Ball;
            (k.efficiency_forward, k.efficiency_backward) = ball_screw_efficiency(rng.uniform());
            k.drag_torque_nm = r::DRAG_NM.low;
            k.slide_friction_n = r::SLIDE_N.low;
            k.stiction_ratio = r::STICTION.low;
        }

        // The string's hysteresis and the load cell's warm-up drift came later still: their
        // own stream again, so every draw above and below is what it was.
        let mut rng = SimRng::substream(seed, 0xFA4A);
        c.load_cell.zero_drift_volts_per_s = r::ZERO_DRIFT_VOLTS_PER_S.draw(&mut rng);
        c.load_cell.zero_drift_settle_s = r::ZERO_DRIFT_SETTLE_S.draw(&mut rng);
        if kind.spec().is_some() {
            c.string.hysteresis_fraction = r::STRING_HYSTERESIS.draw(&mut rng);
            c.string.hysteresis_strain_mm = r::HYSTERESIS_STRAIN_MM.draw(&mut rng);
        }

        let mut rng = SimRng::substream(seed, 0xFA46);
        let bidirectional = rng.chance(0.5);
        let mut sense = match rng.below(3) {
            0 => CurrentSenseParams::per_phase_low_side(),
            1 => CurrentSenseParams::dc_link_mid_on_time(bidirectional),
            _ => CurrentSenseParams::dc_link_filtered(
                bidirectional,
                r::DC_LINK_RC_S.draw(&mut rng),
                r::DC_LINK_SAMPLE_PHASE.draw(&mut rng),
            ),
        };
        sense.gain_error = r::CURRENT_GAIN_ERROR.draw(&mut rng);
        sense.offset_amps = if sense.bidirectional() {
            r::CURRENT_OFFSET_BIDIRECTIONAL.draw(&mut rng)
        } else {
            r::CURRENT_OFFSET_UNIDIRECTIONAL.draw(&mut rng)
        };
        sense.noise_amps = r::CURRENT_NOISE.draw(&mut rng);
        c.current_sense = sense;
        c.bus_sense.divider_ratio = r::BUS_DIVIDER.draw(&mut rng);
        c.bus_sense.noise_volts = r::BUS_NOISE_VOLTS.draw(&mut rng);

        let mut rng = SimRng::substream(seed, 0xFA47);
        let h = &mut c.hall;
        h.offset_deg = r::HALL_COMMON_DEG.draw(&mut rng);
        for offset in &mut h.sensor_offsets_deg {
            *offset = r::HALL_SENSOR_DEG.draw(&mut rng);
        }
        h.read_flip_probability = r::HALL_FLIP.draw(&mut rng);
        h.burst_probability = r::HALL_BURST.draw(&mut rng);
        c.encoder.scale_error = r::ENCODER_SCALE_ERROR.draw(&mut rng);

        let mut rng = SimRng::substream(seed, 0xFA48);
        if let Some(spec) = kind.spec() {
            let (low, high) = spec.stiffness_range_kgf_per_cm;
            c.string.stiffness_kgf_per_cm = rng.range(low, high);
            c.string.slack_mm = r::SLACK_MM.draw(&mut rng);
            c.string.toe_mm = r::TOE_MM.draw(&mut rng);
            for (arm, spec_arm) in c.string.relaxation.iter_mut().zip(spec.relaxation) {
                arm.fraction = spec_arm.fraction * r::RELAXATION_FRACTION_SCALE.draw(&mut rng);
                arm.time_constant_s =
                    spec_arm.time_constant_s * r::RELAXATION_TIME_SCALE.draw(&mut rng);
            }
        }
        c
    }

    /// The [`TwinConfig::family_centre`] machine with `axis` moved to `position` (0 = its
    /// low end, 1 = its high end, clamped) and everything else at the centre. Seed 0 (use
    /// [`TwinConfig::with_seed`] for the run's noise).
    #[must_use]
    pub fn on_axis(axis: Axis, position: f64, kind: StringKind) -> Self {
        Self::axis_point(axis, position.clamp(0.0, 1.0), kind)
    }

    /// [`TwinConfig::on_axis`] past the family's ends: every span of `axis` continued to
    /// `position` ([`Span::beyond`]; clamped to `−BEYOND_MAX ..= 1 + BEYOND_MAX`), for
    /// asking how far outside the family the controller still holds. The current-sensing
    /// axis has no values beyond its boards (it stays at the nearer end).
    ///
    /// # Errors
    /// The continued machine is not physical ([`TwinConfig::check`]): an efficiency above 1,
    /// a negative mass, backlash, slack or probability, static friction below kinetic…
    pub fn beyond_axis(axis: Axis, position: f64, kind: StringKind) -> Result<Self, ConfigError> {
        let c = Self::axis_point(axis, position.clamp(-BEYOND_MAX, 1.0 + BEYOND_MAX), kind);
        c.check().map(|()| c)
    }

    /// The centre machine with `axis` at `p` (any value [`Span::beyond`] takes).
    fn axis_point(axis: Axis, p: f64, kind: StringKind) -> Self {
        let mut c = Self::family_centre(kind);
        c.move_axes(&[(axis, p)], kind);
        c
    }

    /// A corner of the family: the centre machine with every axis of `points` moved to its
    /// position at once (each as [`TwinConfig::beyond_axis`] moves it alone), for asking
    /// what the extremes do together that none does alone. The motor axes compose: the motor
    /// is re-derived once from all four of its inputs (winding, inductance, no-load speed,
    /// back-EMF shape) with the named ones moved. One axis is [`TwinConfig::beyond_axis`].
    ///
    /// # Errors
    /// An axis is named twice ([`ConfigError::RepeatedAxis`]), or the machine is not physical
    /// ([`TwinConfig::check`]; e.g. a bus clamp at 28 V over a 30 V supply).
    pub fn corner(points: &[(Axis, f64)], kind: StringKind) -> Result<Self, ConfigError> {
        for (k, (axis, _)) in points.iter().enumerate() {
            if points.iter().take(k).any(|(earlier, _)| earlier == axis) {
                return Err(ConfigError::RepeatedAxis(axis.name()));
            }
        }
        let clamped: Vec<(Axis, f64)> = points
            .iter()
            .map(|&(axis, p)| (axis, p.clamp(-BEYOND_MAX, 1.0 + BEYOND_MAX)))
            .collect();
        let mut c = Self::family_centre(kind);
        c.move_axes(&clamped, kind);
        c.check().map(|()| c)
    }

    /// Moves every axis of `points` on this machine: the motor first (re-derived once from
    /// its four inputs, if any motor axis is named), then the others in order.
    fn move_axes(&mut self, points: &[(Axis, f64)], kind: StringKind) {
        use ranges as r;
        let nominal = MotorParams::nominal();
        let (mut winding, mut inductance, mut rpm, mut ramp) = (
            motor_nominal::WINDING_OHM,
            nominal.phase_inductance_h,
            motor_nominal::NO_LOAD_RPM,
            nominal.emf_ramp_deg,
        );
        let mut motor_moved = false;
        for &(axis, p) in points {
            match axis {
                Axis::MotorResistance => winding = r::WINDING_OHM.beyond(p),
                Axis::MotorSpeedConstant => rpm = r::NO_LOAD_RPM.beyond(p),
                Axis::MotorInductance => inductance = r::INDUCTANCE_H.beyond(p),
                Axis::BackEmfShape => ramp = r::EMF_RAMP_DEG.beyond(p),
                _ => continue,
            }
            motor_moved = true;
        }
        if motor_moved {
            self.motor = family_motor(
                winding,
                motor_nominal::MOSFET_OHM,
                inductance,
                rpm,
                ramp,
                nominal.coulomb_torque_nm,
            );
        }
        for &(axis, p) in points {
            self.move_axis(axis, p, kind);
        }
    }

    /// Moves `axis` to `p` on this machine; the motor axes are [`TwinConfig::move_axes`]'s.
    fn move_axis(&mut self, axis: Axis, p: f64, kind: StringKind) {
        use ranges as r;
        let c = self;
        match axis {
            Axis::Inertia => {
                let scale = r::INERTIA_SCALE.beyond(p);
                c.motor.rotor_inertia_kg_m2 *= scale;
                c.mechanics.gear_inertia_kg_m2 *= scale;
            }
            Axis::Friction => {
                let k = &mut c.mechanics;
                k.efficiency_forward = r::EFFICIENCY_FORWARD.beyond(p);
                k.efficiency_backward = back_driven_efficiency(k.efficiency_forward, p);
                k.drag_torque_nm = r::DRAG_NM.beyond(p);
                k.slide_friction_n = r::SLIDE_N.beyond(p);
                k.stiction_ratio = r::STICTION.beyond(p);
            }
            Axis::Backlash => c.mechanics.backlash_mm = r::BACKLASH_MM.beyond(p),
            Axis::MotorResistance
            | Axis::MotorSpeedConstant
            | Axis::MotorInductance
            | Axis::BackEmfShape => {}
            Axis::Cogging => c.motor.cogging_torque_nm = r::COGGING_NM.beyond(p),
            Axis::LoadCellGain => c.load_cell.volts_per_kgf = r::SENSITIVITY.beyond(p),
            Axis::LoadCellZero => c.load_cell.zero_volts = r::ZERO_VOLTS.beyond(p),
            Axis::LoadCellNonlinearity => {
                let l = &mut c.load_cell;
                l.low_load_deficit = r::LOW_LOAD_DEFICIT.beyond(p);
                l.low_load_scale_kgf = r::LOW_LOAD_SCALE_KGF.beyond(p);
                l.quadratic_at_50_kgf = r::QUADRATIC.beyond(p);
            }
            Axis::LoadCellBandwidth => c.load_cell.bandwidth_hz = r::BANDWIDTH_HZ.beyond(p),
            Axis::LoadCellNoiseHum => {
                c.load_cell.noise_volts = r::NOISE_VOLTS.beyond(p);
                c.load_cell.hum.volts = r::HUM_VOLTS.beyond(p);
            }
            Axis::Spikes => {
                let spikes = &mut c.load_cell.spikes;
                spikes.pwm_probability = r::SPIKE_PWM_PROBABILITY.beyond(p);
                spikes.commutation_probability =
                    Span::linear(0.0, r::SPIKE_COMMUTATION_PROBABILITY.high).beyond(p);
                spikes.base_volts = r::SPIKE_BASE_VOLTS.beyond(p);
                spikes.volts_per_amp = r::SPIKE_VOLTS_PER_AMP.beyond(p);
            }
            Axis::SpikeBursts => {
                let spikes = &mut c.load_cell.spikes;
                spikes.burst_probability = r::SPIKE_BURST_PROBABILITY.beyond(p);
                spikes.burst_samples_max = burst_samples(p);
            }
            Axis::BallScrew => {
                let k = &mut c.mechanics;
                k.screw = Screw::Ball;
                (k.efficiency_forward, k.efficiency_backward) = ball_screw_efficiency(p);
                k.drag_torque_nm = r::DRAG_NM.low;
                k.slide_friction_n = r::SLIDE_N.low;
                k.stiction_ratio = r::STICTION.low;
            }
            Axis::EndStop => c.mechanics.overtravel_mm = r::OVERTRAVEL_MM.beyond(p),
            Axis::StringHysteresis => c.string.hysteresis_fraction = r::STRING_HYSTERESIS.beyond(p),
            Axis::LoadCellZeroDrift => {
                c.load_cell.zero_drift_volts_per_s = r::ZERO_DRIFT_VOLTS_PER_S.beyond(p);
            }
            Axis::GripperMass => c.mechanics.gripper.mass_kg = r::GRIPPER_KG.beyond(p),
            Axis::HallError => c.hall.offset_deg = r::HALL_EDGE_DEG.beyond(p),
            Axis::BusSupply => {
                let supply = r::SUPPLY_VOLTS.beyond(p);
                c.bridge.bus_volts = supply;
                c.bridge.clamp_volts =
                    c.bridge.clamp_volts.map(|clamp| clamp.max(r::CLAMP_OVER_SUPPLY * supply));
            }
            Axis::BusClamp => c.bridge.clamp_volts = Some(r::CLAMP_VOLTS.beyond(p)),
            Axis::BusCapacitance => c.bridge.bus_capacitance_f = r::BUS_CAPACITANCE_F.beyond(p),
            Axis::CurrentSensing => c.current_sense = sensing_board(sensing_index(p)),
            Axis::StringStiffness => {
                if let Some(spec) = kind.spec() {
                    let (low, high) = spec.stiffness_range_kgf_per_cm;
                    c.string.stiffness_kgf_per_cm = Span::linear(low, high).beyond(p);
                }
            }
            Axis::Creep => {
                let fraction = r::RELAXATION_FRACTION_SCALE.beyond(p);
                let time =
                    Span::linear(r::RELAXATION_TIME_SCALE.high, r::RELAXATION_TIME_SCALE.low)
                        .beyond(p);
                for arm in &mut c.string.relaxation {
                    arm.fraction *= fraction;
                    arm.time_constant_s *= time;
                }
            }
            Axis::Slack => {
                if c.string.present() {
                    c.string.slack_mm = r::SLACK_MM.beyond(p);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_map_positions_and_back() {
        for span in [ranges::INERTIA_SCALE, ranges::SUPPLY_VOLTS, ranges::EFFICIENCY_FORWARD] {
            for k in 0..=10 {
                let p = f64::from(k) / 10.0;
                let v = span.at(p);
                assert!(span.contains(v));
                assert!((span.position_of(v) - p).abs() < 1e-9, "{span:?} {p}");
            }
        }
        assert!((ranges::INERTIA_SCALE.at(0.5) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_corner_moves_every_named_axis_at_once() {
        let kind = StringKind::TennisPolyester;
        // One axis is `beyond_axis`, at every axis, inside and past the ends.
        for axis in Axis::ALL {
            for p in [-0.5, 0.3, 1.5] {
                assert_eq!(
                    TwinConfig::corner(&[(axis, p)], kind),
                    TwinConfig::beyond_axis(axis, p, kind),
                    "{axis:?} at {p}"
                );
            }
        }
        // Axes on different parts compose, in any order.
        let heavy = [(Axis::Inertia, 1.0), (Axis::GripperMass, 1.0), (Axis::Friction, 0.0)];
        let c = TwinConfig::corner(&heavy, kind).unwrap();
        let centre = TwinConfig::family_centre(kind);
        assert!(
            (c.motor.rotor_inertia_kg_m2 / centre.motor.rotor_inertia_kg_m2 - 2.0).abs() < 1e-12
        );
        assert!((c.mechanics.gripper.mass_kg - 1.5).abs() < 1e-12);
        assert!(
            (c.mechanics.efficiency_forward - ranges::EFFICIENCY_FORWARD.at(0.0)).abs() < 1e-12
        );
        let reversed: Vec<_> = heavy.iter().rev().copied().collect();
        assert_eq!(TwinConfig::corner(&reversed, kind), Ok(c));
        // The motor axes compose too: one motor from all the moved inputs, not the last one's.
        let both = TwinConfig::corner(
            &[(Axis::MotorResistance, 1.0), (Axis::MotorSpeedConstant, 0.0), (Axis::Inertia, 1.0)],
            kind,
        )
        .unwrap();
        let nominal = MotorParams::nominal();
        let mut expected = family_motor(
            ranges::WINDING_OHM.at(1.0),
            motor_nominal::MOSFET_OHM,
            nominal.phase_inductance_h,
            ranges::NO_LOAD_RPM.at(0.0),
            nominal.emf_ramp_deg,
            nominal.coulomb_torque_nm,
        );
        expected.rotor_inertia_kg_m2 *= 2.0;
        assert_eq!(both.motor, expected);
        let alone = TwinConfig::on_axis(Axis::MotorResistance, 1.0, kind);
        assert!(both.motor.ke_volts_per_rad_s > alone.motor.ke_volts_per_rad_s);
        // An axis named twice, and a machine that is not physical, are refused.
        assert_eq!(
            TwinConfig::corner(
                &[(Axis::Inertia, 0.0), (Axis::Backlash, 1.0), (Axis::Inertia, 1.0)],
                kind
            ),
            Err(ConfigError::RepeatedAxis("inertia"))
        );
        assert!(matches!(
            TwinConfig::corner(&[(Axis::BusSupply, 1.0), (Axis::BusClamp, 0.0)], kind),
            Err(ConfigError::OutOfRange(_))
        ));
        assert_eq!(TwinConfig::corner(&[], kind), Ok(centre));
    }

    #[test]
    fn beyond_continues_the_spans_and_refuses_what_is_not_physical() {
        // Inside the family the continued spans are the family's own.
        for axis in Axis::ALL {
            for p in [0.0, 0.3, 1.0] {
                let kind = StringKind::TennisGut;
                assert_eq!(
                    TwinConfig::beyond_axis(axis, p, kind),
                    Ok(TwinConfig::on_axis(axis, p, kind))
                );
            }
        }
        // Past the ends: linearly, or in the logarithm, by the span's width.
        assert!((ranges::INERTIA_SCALE.beyond(1.5) - 4.0).abs() < 1e-12);
        assert!((ranges::INERTIA_SCALE.beyond(-0.5) - 0.25).abs() < 1e-12);
        assert!((ranges::SUPPLY_VOLTS.beyond(1.5) - 35.0).abs() < 1e-12);
        assert!(
            (ranges::SUPPLY_VOLTS.beyond(9.0) - 40.0).abs() < 1e-12,
            "clamped at 1 + BEYOND_MAX"
        );
        assert!((ranges::SUPPLY_VOLTS.at(1.5) - 30.0).abs() < 1e-12, "`at` stays in the span");
        let far = TwinConfig::beyond_axis(Axis::Inertia, 1.5, StringKind::TennisGut);
        let centre = TwinConfig::family_centre(StringKind::TennisGut);
        let ratio = far.map(|c| c.motor.rotor_inertia_kg_m2 / centre.motor.rotor_inertia_kg_m2);
        assert!(ratio.is_ok_and(|r| (r - 4.0).abs() < 1e-9));
        assert!(Axis::Inertia.describe_at(1.5, StringKind::TennisGut).contains("4.0000"));
        // What a continued span cannot physically be is refused, with the reason.
        let kind = StringKind::TennisSynthetic;
        assert_eq!(
            TwinConfig::beyond_axis(Axis::Backlash, -0.5, kind),
            Err(ConfigError::OutOfRange("backlash"))
        );
        assert_eq!(
            TwinConfig::beyond_axis(Axis::Friction, -0.5, kind),
            Err(ConfigError::Efficiency)
        );
        assert_eq!(
            TwinConfig::beyond_axis(Axis::GripperMass, -0.5, kind),
            Err(ConfigError::OutOfRange("gripper mass"))
        );
        assert_eq!(
            TwinConfig::beyond_axis(Axis::Slack, -0.5, kind),
            Err(ConfigError::OutOfRange("slack"))
        );
        assert_eq!(
            TwinConfig::beyond_axis(Axis::Spikes, -0.5, kind),
            Err(ConfigError::OutOfRange("load-cell spikes"))
        );
        let mut sticky = TwinConfig::family_centre(kind);
        sticky.mechanics.stiction_ratio = 0.9;
        assert!(matches!(sticky.check(), Err(ConfigError::OutOfRange(_))));
    }

    #[test]
    fn back_driven_efficiency_is_realisable_across_the_range() {
        for k in 0..=100 {
            let forward = ranges::EFFICIENCY_FORWARD.at(f64::from(k) / 100.0);
            for j in 0..=10 {
                let backward = back_driven_efficiency(forward, f64::from(j) / 10.0);
                let mut m = crate::params::MechanicsParams::nominal();
                m.efficiency_forward = forward;
                m.efficiency_backward = backward;
                let (a, b) = m.friction_coefficients();
                assert!(a >= 0.0 && b >= 0.0, "{forward} {backward}: {a} {b}");
                assert!(backward <= 0.98 * forward + 1e-12 && backward >= 0.85 * forward - 1e-12);
            }
        }
    }

    #[test]
    fn axes_parse_and_print() {
        for axis in Axis::ALL {
            assert_eq!(axis.name().parse::<Axis>(), Ok(axis));
            assert!(!axis.describe_at(0.5, StringKind::TennisGut).is_empty());
        }
        assert!("gravity".parse::<Axis>().is_err());
    }

    #[test]
    fn family_centre_runs_at_the_nameplate_speed_constant() {
        let centre = TwinConfig::family_centre(StringKind::TennisGut);
        assert_eq!(centre.check(), Ok(()));
        // The overlap correction lowers Ke by ≈ 2 % against the plain derivation.
        let plain = MotorParams::nominal().ke_volts_per_rad_s;
        let ke = centre.motor.ke_volts_per_rad_s;
        assert!(ke < plain && ke > 0.97 * plain, "{ke} vs {plain}");
        // The moving mass is the nominal machine's.
        let m = centre.mechanics;
        assert!((m.carriage_mass_kg + m.gripper.mass_kg - 2.0).abs() < 1e-12);
    }
}

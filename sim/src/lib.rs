//! taut-sim: the digital twin of the paper's BLDC racket-stringing machine, driven by
//! taut-core's own drive.
//!
//! # What it is
//!
//! A physically grounded, deterministic-from-a-seed model of the machine of Chen & Jhang
//! (2013): a 24 V brushless motor commutated by **taut-core's [`Drive`]** (called every
//! 50 µs PWM period, exactly as the firmware's PWM interrupt calls it), a 1:20 gearbox
//! and a 2.54 cm-lead screw moving the gripper carriage, a string with slack,
//! viscoelastic creep and a breaking point, and the sensors the firmware reads — load
//! cell, current shunt, Hall sensors, string-length encoder, limit switches, keys — all
//! delivered as the core's raw [`Inputs`]. A controller reads [`Twin::inputs`], answers
//! with [`Outputs`] through [`Twin::apply`], and [`Twin::advance_tick`] lets one
//! millisecond of physics pass; [`Twin::truth`] reports the physical state.
//!
//! ```
//! use taut_sim::{StringKind, TwinConfig, Twin, run, drive_at};
//! use taut_core::{drive::Direction, io::Outputs};
//!
//! let mut twin = Twin::new(&TwinConfig::nominal(StringKind::TennisSynthetic));
//! let pull = Outputs { drive: drive_at(Direction::Pull, 0.5), ..Outputs::default() };
//! let trace = run(&mut twin, 300, |_inputs| pull);
//! assert!(trace.last().unwrap().truth.carriage_mm > 5.0);
//! ```
//!
//! Modules: [`params`] (every number and its Monte-Carlo range), [`family`] (the family of
//! machines sharing the nameplate: every hidden parameter's range, [`TwinConfig::family`],
//! [`Axis`] sweeps with [`TwinConfig::on_axis`]), [`motor`] (back-EMF, Hall, three-phase
//! currents with the complementary bridge and body diodes), [`string`] (slack, creep,
//! break), [`sensors`] (load cell, current, bus voltage, encoder), [`twin`] (the machine:
//! backlash, gripper, bus clamp, faults), [`bench`] (the one bench: the firmware's machine
//! or its tension controller on the twin, sessions with the simulated [`operator`],
//! commissioning through the machine's own calibration, the bang-bang oracle), [`trace`]
//! (run a closure as the controller, record, CSV), [`rng`] (the seeded generator).
//!
//! The sections below derive the **nominal** machine ([`TwinConfig::nominal`]); the
//! family's ranges around it, with their reasoning, are in [`family::ranges`] and
//! `sim/README.md`.
//!
//! # Where every parameter comes from
//!
//! "Paper" marks a number from the source paper; everything else is an assumption with
//! its reasoning. `sim/README.md` has the same table.
//!
//! ## Motor (paper: 24 V, 3 700 rpm no-load, 2.85 kgf·cm rated at 5.5 A)
//!
//! - **Resistance**: 0.41 Ω per phase (0.82 Ω line-to-line), typical of 57 mm 24 V
//!   100 W-class BLDCs, plus one IRF2807's 13 mΩ (paper) per phase: `R = 0.423 Ω`, 0.846 Ω
//!   across a driven pair. Stall current at 24 V is 24 / 0.846 ≈ 28 A, the "≈ 29 A" the
//!   drive's overcurrent docs assume.
//! - **Ke and Kt.** Rated torque `T = 2.85 × 9.806 65 × 0.01 = 0.2795 N·m`. The naive
//!   `Ke = 24 V / 387.5 rad/s = 0.0619` would make `Kt·5.5 A = 0.34 N·m`, more than rated:
//!   the motor's own losses take a no-load current `I₀`. Requiring both
//!   `24 = Ke·ω₀ + R·I₀` (no-load) and `T = Kt·(5.5 − I₀)` (rated) with `Kt = Ke` (SI,
//!   line-to-line, six-step) gives `Ke²·ω₀ − (24 − 5.5 R)·Ke − R·T = 0`, so
//!   **`Ke = Kt = 0.0601 V·s/rad (N·m/A)`, `I₀ = 0.849 A`** (loss torque 0.051 N·m);
//!   rated speed then comes out at 3 075 rpm, typical of such motors. The twin's own
//!   no-load speed extrapolated to 100 % duty is 3 606 rpm, 2.5 % lower: the steady-state
//!   equation omits the commutation overlap (current moving between phase inductances at
//!   every sector change, ≈ 0.5 V at full speed), which the three-phase model produces.
//! - **Losses**: the 0.051 N·m at no-load speed is split into 0.005 N·m bearing Coulomb
//!   friction and a speed-proportional (iron loss) part `c = 1.19 × 10⁻⁴ N·m·s/rad`.
//! - **Inductance**: 0.4 mH per phase (0.8 mH line-to-line), electrical time constant
//!   `L/R ≈ 0.95 ms` — twenty PWM periods, so the 20 kHz ripple is ≈ 0.4 A.
//! - **Pole pairs**: 4, as `taut_core::drive` assumes (one Hall step = 1/24 motor turn).
//! - **Back-EMF shape**: trapezoid with 80° ramps (100° flat top, the ideal being 120°);
//!   the peak constant is scaled so the sector-average line EMF is `Ke·ω` — torque dips
//!   ≈ 12 % at each commutation (six-step ripple), on top of the commutation current
//!   transients the three-phase model produces by itself.
//! - **Cogging**: 0.003 N·m (≈ 1 % of rated), 24 periods per turn (12 slots × 8 poles).
//! - **Rotor inertia**: 1.5 × 10⁻⁵ kg·m² (57 mm BLDCs of this rating list 1–2 × 10⁻⁵);
//!   gearbox and screw add 0.1 × 10⁻⁵ at the motor shaft.
//!
//! ## Bridge and bus
//!
//! 24 V supply (paper). Six-step drive with the sector's low side on and the switched leg
//! **complementary** (high side for the duty, its own low side for the rest of the period),
//! as `taut_core::drive::commutation` specifies and the firmware programs TIM1's CHx/CHxN
//! pairs, with the board's **1 µs dead time** (`params::BOARD_DEAD_TIME`, handed to the drive's configuration as the firmware hands it its own) at every
//! rising gate edge, during which the leg's body diodes (0.8 V) carry the current. So the
//! winding sees `duty·V_bus` (less ≈ ±0.5 V of dead-time distortion, signed with the
//! current) in either current direction: a duty below the back-EMF ratio **brakes** and
//! regenerates. Hardware overcurrent comparator on the bus shunt at **15 A**, above the
//! drive's 12 A software limit and below the 28 A stall current; it switches the bridge off
//! at once within the PWM period and raises the drive's `overcurrent_trip` flag on the next
//! period. The low-side bus shunt only sees the high switch's on-time current, and reads
//! negative (regenerated) current as zero — braking current is invisible to it.
//!
//! The **DC bus** is not stiff: the supply — an ideal source at 24 V behind 50 mΩ (output
//! impedance and cable) and a blocking diode, since a bench SMPS cannot sink current —
//! feeds a **1000 µF** bulk capacitor (assumption: one 1000 µF / 50 V low-ESR
//! electrolytic, the usual bulk capacitor of a 24 V, 100 W-class motor board; the low end
//! of 1000–2200 µF, the conservative choice for pump-up), and the electronics draw 0.1 A.
//! Regenerated energy has nowhere to go but the capacitor: a brake from full speed at half
//! the back-EMF ratio lifts the bus from 24 V to ≈ 31 V (`sim/tests/physics.rs`). The
//! Monte-Carlo varies the capacitance ±20 % and the supply resistance ±50 %.
//!
//! ## Drivetrain (paper: 1:20 gearbox, 2.54 cm lead)
//!
//! - `r = 25.4 mm / (2π × 20) = 0.2021 mm` of carriage per motor radian (1.27 mm per
//!   motor turn; one Hall step = 0.053 mm).
//! - **Reflected inertia dominates**: `J / r² = 1.6 × 10⁻⁵ / (2.02 × 10⁻⁴)² ≈ 392 kg`
//!   of equivalent carriage mass, against a 2 kg carriage — the string is pulled by a
//!   ≈ 394 kg body. At full speed (≈ 67 mm/s) it stores ≈ 0.9 J; friction and the motor's
//!   iron losses absorb most of it, but an open-loop pull that lets go exactly at 20 kgf
//!   still overshoots by 0.3 kgf (soft badminton) to 2.5 kgf (polyester) — see
//!   `examples/open_loop.rs`.
//! - **Efficiency**: the screw is assumed trapezoidal, 16 mm (14.5 mm pitch diameter),
//!   polymer nut, μ = 0.1: lead angle 29.1°, friction angle 5.9°,
//!   `η = tan λ / tan(λ + φ) = 0.795` forward and `tan(λ − φ) / tan λ = 0.770`
//!   back-driven; a two-stage 1:20 planetary gearbox 0.81 / 0.78. Together
//!   **η_f = 0.644, η_b = 0.600**. They enter as Coulomb friction proportional to the
//!   loads, `a·|T_load| + b·|T_motor|`, with `η_f = (1 − b)/(1 + a)` and
//!   `η_b = (1 − a)/(1 + b)`, so `a = 0.302`, `b = 0.162` (solved in
//!   `MechanicsParams::friction_coefficients`). A string above ≈ 8 kgf back-drives the
//!   coasting motor.
//! - **Other friction**: gearbox/screw drag 0.003 N·m at the motor, carriage slide 2 N;
//!   static friction 1.2 × Coulomb (stick-slip is real on a lead screw).
//! - **Travel**: home switch closes at ≤ 0 mm, end switch at ≥ 250 mm, rigid stops 20 mm
//!   beyond each (a carriage coasting from full speed runs on ≈ 6 mm). Power-up position
//!   −0.5 mm (resting on the home switch).
//!
//! ## String
//!
//! Stiffness `K = E·A/L` of the string between the far clamp and the gripper (free length
//! 0.40–0.50 m: across the head plus frame to gripper). Quasi-static moduli (slow pull):
//!
//! | kind | gauge | E | L | K₀ nominal | Monte-Carlo range |
//! |---|---|---|---|---|---|
//! | badminton-soft | 0.70 mm | 2.0 GPa | 0.45 m | 1.74 kgf/cm | 1.4–2.2 |
//! | badminton-hard | 0.62 mm | 3.2 GPa | 0.40 m | 2.46 kgf/cm | 2.0–3.2 |
//! | tennis-gut | 1.30 mm | 2.0 GPa | 0.50 m | 5.41 kgf/cm | 4.5–6.5 |
//! | tennis-synthetic | 1.30 mm | 2.8 GPa | 0.50 m | 7.58 kgf/cm | 6–9 |
//! | tennis-poly | 1.25 mm | 4.5 GPa | 0.45 m | 12.5 kgf/cm | 10–15 |
//!
//! so the twin spans 1.4–15 kgf/cm, the range the reports check. Slack 30 mm
//! nominal (10–60 mm sampled), a 1.5 mm straightening toe, two relaxation arms (a few %
//! at 1.5–2 s, 5–10 % at 40–60 s) so a string held at fixed length loses ≈ 4 % of its
//! tension in 10 s and a constant-pull head must keep creeping forward.
//!
//! ## Sensors
//!
//! - **Load cell**: taut-core's nominal 92 mV/kgf and 50 mV zero (paper: ≈ 920 mV at
//!   10 kgf), ±3 % gain and ±20 mV zero per scenario; low-load deficit
//!   `c·F_k·(1 − e^(−T/F_k))` with `c = 0.3`, `F_k = 2.5 kgf` (paper figure 21: poor
//!   linearity below 5 kg — 0.1 kgf off the high-load line at 5 kgf, 0.75 kgf at zero);
//!   ±0.1 % quadratic term at 50 kgf; 500 Hz amplifier bandwidth; 1.5 mV rms noise
//!   (≈ 0.016 kgf, 1.2 LSB); spikes of 40 mV + 15 mV/A with probability 5 % per sample
//!   while the PWM switches and 50 % after a commutation (paper figure 22); 12-bit ADC
//!   on the board's converter (`BoardDesign::adc_reference`: 5 V on the paper's board).
//! - **Current**: bus shunt sampled each on-time, taut-core's 0.2 V/A, 30 mA noise (the
//!   family adds per-phase low-side shunts, an RC-filtered DC link and bidirectional
//!   amplifiers: [`params::CurrentSensing`]).
//! - **Bus voltage**: a 1:12 divider, converted once per PWM period and averaged over 16 by
//!   the ADC's oversampler, as the firmware does ([`params::BusSenseParams`]).
//! - **Reference gauge**: true tension + N(0, 0.02 kgf).
//! - **Encoder**: 400 counts per turn of a 50 mm-circumference wheel on the string:
//!   **8 counts/mm**, 16-bit wrapping counter.
//! - **Hall**: ideal placement nominally; Monte-Carlo ±4° electrical, rare read flips
//!   (voted out by the firmware's seven-read vote) and rarer bursts.
//!
//! # Numerical method
//!
//! Winding currents are integrated exactly (exponential solution) within each of the four
//! parts of each PWM period, with diode blocking and comparator events located analytically
//! ([`motor`]); the mechanics advance by semi-implicit Euler at 50 µs (the fastest
//! mechanical mode, the bench motor's 3.5 ms electromechanical time constant, is 70
//! steps); static friction by the Karnopp scheme; the string's Maxwell arms exactly for a
//! constant strain rate per step. Everything is `f64` and deterministic.
//!
//! [`Drive`]: taut_core::drive::Drive
//! [`Inputs`]: taut_core::io::Inputs
//! [`Outputs`]: taut_core::io::Outputs
#![forbid(unsafe_code)]
#![allow(
    clippy::float_arithmetic,
    reason = "the twin is a host-side physics model in f64; the no-float rule is the core's"
)]
#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::cast_precision_loss,
    reason = "float → integer conversions happen only for converter codes and counters, after \
              rounding and clamping to the target range (Rust's float casts saturate)"
)]
#![cfg_attr(
    test,
    allow(
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects,
        reason = "unit tests index fixed arrays and count small loops; a panic is the report"
    )
)]

pub mod bench;
pub mod drift;
pub mod family;
pub mod job;
pub mod motor;
pub mod operator;
pub mod params;
pub mod rng;
pub mod sensors;
pub mod string;
pub mod trace;
pub mod twin;

pub use bench::{Bench, ControllerBench, bang_bang_reach_time};
pub use drift::{Drift, DriftParams};
pub use family::{Axis, AxisSpan, Span};
pub use params::{
    CurrentSenseParams, CurrentSensing, DcLinkSampling, Screw, StringKind, TwinConfig,
};
pub use rng::SimRng;
pub use sensors::{CurrentSense, LoadCellFault};
pub use string::StringState;
pub use trace::{Trace, TraceRow, run, run_until};
pub use twin::{Fault, LimitSwitch, Truth, Twin, drive_at};

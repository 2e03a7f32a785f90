//! From a force to a duty: the motor's electrical model, back-EMF compensation, the current
//! limit, and the carriage speed measured from Hall steps.
//!
//! # Theory of operation
//!
//! The control laws produce a pull `F` in kgf; the bridge takes a duty. Between them is the
//! BLDC: with six-step drive two windings conduct in series, so
//! `V_bus·duty = R·I + Ke·ω` and the pull at the carriage is `F = Kt·I·(2π·N/L)·η / g`
//! (gear ratio `N` = 20, lead `L` = 25.4 mm, efficiency `η`, `g` = 9.806 65 N/kgf). Two
//! mappings are offered ([`DutyMap`]); both always command [`Direction::Pull`] — the switched
//! leg is complementary (`crate::drive::commutation`), so a duty below the back-EMF ratio
//! *brakes*: a negative force means less pull or braking, never a release, and a pull never
//! has to reverse (or coast) the bridge:
//!
//! - **Voltage** (`DutyMap::Proportional`; taut and the baselines) — `duty = F·c_f` with
//!   `c_f = 1/F_stall`: the law's force is the *stall* pull the duty would give, i.e. a
//!   voltage command, and the drive's own back-EMF damps the carriage. The law's nominal
//!   plant includes that damping (`Ā`, see `crate::tension::law`), and its equivalent
//!   control feeds forward the back-EMF of the *reference* speed.
//! - **Current** (`DutyMap::BackEmf`) — `duty = (R·I_cmd + Ke·ω̂)/V_bus` with
//!   `I_cmd = F/(kgf per ampere)`, where `ω̂` comes from the carriage speed measured by
//!   counting Hall steps ([`SpeedEstimator`]): the measured back-EMF is cancelled, so the
//!   force is a motor force — and the drive's natural damping is gone.
//!
//! Both limit the winding current to `current_limit` in both directions from the measured
//! speed: the duty stays within `v̂·c_v ± F_lim·c_f` (`F_lim` the pull the limit gives), so
//! neither a pull nor the braking of a fast carriage (duty below the back-EMF) asks for
//! more than the limit (a bus pumped up by regeneration only lowers the real current). The
//! duty is then clamped to `[0, DUTY_MAX]`; zero duty with the pull pattern shorts the two
//! windings through the low sides, the hardest braking there is.
//!
//! # The measured bus
//!
//! The coefficients are derived for the nameplate bus (24 V), but a real supply sits
//! anywhere in 20–30 V and regenerative braking pumps the bus toward the board's clamp
//! (≈ 35 V). A duty puts `duty·V_bus` on the windings, so every duty the mapping returns is
//! multiplied by `V_nominal/V_bus` with the bus measured this tick
//! ([`ForceToDuty::set_bus`]): the force the law asks for, the back-EMF it cancels and the
//! current window all stay what they are at the nominal bus. Without it a 30 V bus makes
//! every duty 25 % stronger — and the braking that the approach plans 25 % weaker, because
//! the duty that should sit below the back-EMF sits at it.
//!
//! # Speed from Hall steps
//!
//! One Hall step is 1/24 motor turn = 1/480 screw turn = 25.4 mm / 480 ≈ 52.9 µm of
//! carriage travel. [`SpeedEstimator`] differences the drive's step counter every tick
//! (wrapping, clamped to ±16 steps per tick — 0.85 mm/ms, ten times the top speed) and
//! low-pass filters the result with time constant `τ_v`; at the 78 mm/s top speed a 1 ms
//! tick sees ≈ 1.5 steps, so `τ_v` of a few ms averages the step quantisation.
//!
//! # Fixed point
//!
//! The two duty coefficients (duty per kgf ≈ 2 × 10⁻³, duty per mm/s ≈ 1.3 × 10⁻²) are
//! Q7.24 `i32` (range ±128, resolution 6 × 10⁻⁸, ≤ 3 × 10⁻⁵ relative). Speeds are Q15.16 mm/s.
//! They are derived from the motor's data at construction in 128-bit integer arithmetic
//! (construction only; the per-tick path uses 32 × 32 → 64-bit products).

use crate::drive::{DUTY_MAX, Direction, DriveCommand, Duty};
use crate::fixed::{filter_gain, mul_wide, narrow, reciprocal_q24, saturate_i32};
use crate::mechanism::{GEAR_RATIO, LEAD_NM, MAX_STEPS_PER_TICK, NM_PER_STEP};
use crate::settings::MmPerSecond;
use crate::tension::law::{Coef, Saturation};
use crate::units::{Amps, Kgf, Q16, Seconds, Volts};

/// Fraction bits of the duty coefficients.
pub const DUTY_COEF_FRAC: u32 = 24;

/// The motor and transmission, in integer engineering units.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct MotorModel {
    /// Bus voltage, mV (paper: 24 V).
    pub bus_mv: u32,
    /// Resistance of the two conducting windings in series, mΩ.
    pub resistance_mohm: u32,
    /// Back-EMF constant, µV·s/rad (line-to-line, two windings): 24 V at 3 700 rpm.
    pub ke_micro: u32,
    /// Torque constant, µN·m/A.
    pub kt_micro: u32,
    /// Forward (pulling) efficiency of gearbox and screw, percent.
    pub efficiency_pct: u32,
}

impl MotorModel {
    #[cfg(any(test, feature = "paper-board"))]
    /// The paper's machine: 24 V bus (the 1:20 gearbox and 25.4 mm lead are
    /// [`crate::mechanism`]'s, which every conversion shares); the motor's
    /// constants as `sim/README.md` derives them from the paper's 3 700 rpm no-load and
    /// 2.85 kgf·cm at 5.5 A: `Ke = Kt = 60.1 mV·s/rad` (SI, line-to-line, once the no-load
    /// current is accounted for), 0.846 Ω across the driven pair (windings plus MOSFETs), and
    /// a forward efficiency of gearbox and screw of 64 %. These are the nominal data an
    /// engineer has from the datasheets; the Monte-Carlo varies the machine around them.
    pub const PAPER: Self = Self {
        bus_mv: 24_000,
        resistance_mohm: 846,
        ke_micro: 60_100,
        kt_micro: 60_100,
        efficiency_pct: 64,
    };
}

/// Why a motor model was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum MotorError {
    /// A parameter is zero or implausible (bus outside 5–60 V, efficiency above 100 %).
    Parameter,
    /// A derived coefficient does not fit its fixed-point format.
    Range,
}

/// How a force becomes a duty (see the module docs).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum DutyMap {
    /// Voltage command: `duty = F / F_stall`, held within the current-limit window
    /// `v̂·c_v ± F_lim·c_f` around the measured back-EMF and within `[0, DUTY_MAX]`, always
    /// in the pull direction (without the window a step from rest asks for the stall
    /// current, and a hard brake from full speed for three times the limit).
    Proportional {
        /// The largest current the mapping asks for, A.
        current_limit: Amps,
    },
    /// Current command: `duty = F·c_f + v̂·c_v`, force limited by `current_limit`, duty
    /// clamped to `[0, DUTY_MAX]` in the pull direction.
    BackEmf {
        /// The largest current the mapping asks for, A.
        current_limit: Amps,
    },
}

/// The validated, precomputed force → duty mapping.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct ForceToDuty {
    /// Duty per kgf at stall, Q7.24.
    duty_per_kgf: i32,
    /// Duty per mm/s of carriage speed (back-EMF), Q7.24.
    duty_per_mm_s: i32,
    /// The force limit of the back-EMF mapping, kgf bits (`i32::MAX` for proportional).
    force_limit: i32,
    /// Whether to compensate back-EMF.
    compensate: bool,
    /// The bus voltage the coefficients were derived for, V (Q15.16 bits).
    nominal_bus: i32,
    /// `V_nominal / V_measured` (Q15.16 bits), set every tick by [`ForceToDuty::set_bus`]:
    /// every duty the mapping returns is multiplied by it, so the same duty-derived voltage
    /// reaches the windings whatever the bus is (see the module docs).
    bus_scale: i32,
}

fn q24_ratio(num: i128, den: i128) -> Result<i32, MotorError> {
    if den <= 0 {
        return Err(MotorError::Parameter);
    }
    let scaled = num.checked_mul(1 << DUTY_COEF_FRAC).ok_or(MotorError::Range)?;
    i32::try_from(scaled.checked_div(den).ok_or(MotorError::Range)?).map_err(|_| MotorError::Range)
}

/// 2π in units of 10⁻⁹.
const TWO_PI_NANO: i128 = 6_283_185_307;
/// Standard gravity in units of 10⁻⁵ N/kgf.
const G_1E5: i128 = 980_665;

impl ForceToDuty {
    /// All coefficients zero: every command is zero duty.
    pub(crate) const ZERO: Self = Self {
        duty_per_kgf: 0,
        duty_per_mm_s: 0,
        force_limit: 0,
        compensate: true,
        nominal_bus: 24 << 16,
        bus_scale: 1 << 16,
    };

    /// Precomputes the mapping.
    ///
    /// # Errors
    /// [`MotorError`] for implausible data or coefficients outside Q7.24.
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(motor: &MotorModel, map: DutyMap) -> Result<Self, MotorError> {
        if motor.bus_mv < 5_000
            || motor.bus_mv > 60_000
            || motor.resistance_mohm == 0
            || motor.ke_micro == 0
            || motor.kt_micro == 0
            || motor.efficiency_pct == 0
            || motor.efficiency_pct > 100
        {
            return Err(MotorError::Parameter);
        }
        let bus = i128::from(motor.bus_mv);
        let r = i128::from(motor.resistance_mohm);
        let ke = i128::from(motor.ke_micro);
        let kt = i128::from(motor.kt_micro);
        // The gearbox and the screw are the mechanism's nameplate (`crate::mechanism`).
        let gear = i128::from(GEAR_RATIO);
        let lead = i128::from(LEAD_NM / 1_000);
        let eta = i128::from(motor.efficiency_pct);
        // rad of motor per mm of carriage = 2π·N / (lead_um/1000).
        // duty per mm/s = Ke·(2π·N·1000/lead_um)/V
        //   = ke_micro·1e-6 · 2π_nano·1e-9 · N · 1000 / lead_um / (bus_mv·1e-3)
        //   = ke · 2π_nano · N / (lead · bus · 1e9)
        let duty_per_mm_s = q24_ratio(
            ke.saturating_mul(TWO_PI_NANO).saturating_mul(gear),
            lead.saturating_mul(bus).saturating_mul(1_000_000_000),
        )?;
        // kgf per A = kt·1e-6 · 2π_nano·1e-9·N/(lead_um·1e-6) · η/100 / (G_1E5·1e-5)
        //           = kt · 2π_nano · N · η / (lead · G_1E5 · 1e6)
        // duty per kgf = R/(V · kgf per A) = r·1e-3 / (bus·1e-3 · kgf per A)
        //           = r · lead · G_1E5 · 1e6 / (bus · kt · 2π_nano · N · η)
        let duty_per_kgf = q24_ratio(
            r.saturating_mul(lead).saturating_mul(G_1E5).saturating_mul(1_000_000),
            bus.saturating_mul(kt)
                .saturating_mul(TWO_PI_NANO)
                .saturating_mul(gear)
                .saturating_mul(eta),
        )?;
        if duty_per_kgf <= 0 || duty_per_mm_s <= 0 {
            return Err(MotorError::Range);
        }
        let (current_limit, compensate) = match map {
            DutyMap::Proportional { current_limit } => (current_limit, false),
            DutyMap::BackEmf { current_limit } => (current_limit, true),
        };
        let force_limit = {
            {
                if current_limit.0 <= Q16::ZERO {
                    return Err(MotorError::Parameter);
                }
                // F_lim = I_lim·R/V / duty_per_kgf = I_lim · kgf per A.
                // kgf per A = (R/V)/duty_per_kgf; compute from the same integers.
                let limit = i128::from(current_limit.0.to_bits())
                    .saturating_mul(kt)
                    .saturating_mul(TWO_PI_NANO)
                    .saturating_mul(gear)
                    .saturating_mul(eta)
                    .checked_div(lead.saturating_mul(G_1E5).saturating_mul(1_000_000))
                    .ok_or(MotorError::Range)?;
                i32::try_from(limit).map_err(|_| MotorError::Range)?
            }
        };
        // bus_mv ≤ 60 000 was checked above: 60 V is 3.9 × 10⁶ bits.
        let nominal_bus = i32::try_from((bus << 16) / 1_000).map_err(|_| MotorError::Range)?;
        Ok(Self {
            duty_per_kgf,
            duty_per_mm_s,
            force_limit,
            compensate,
            nominal_bus,
            bus_scale: 1 << 16,
        })
    }

    /// Takes the bus voltage measured this tick: from now on every duty is scaled by
    /// `V_nominal / V_bus`. A reading below half the nominal bus is no reading (the board's
    /// undervoltage lockout holds the gates off there, so the duty does nothing; a missing
    /// divider reads 0) and leaves the nominal scale; a reading above twice the nominal is
    /// taken as twice (the drive faults at its configured maximum long before). So the scale
    /// is always within `[½, 2]` — never a division by a small number. Division-free: one
    /// reciprocal ([`reciprocal_q24`]).
    pub fn set_bus(&mut self, bus: Volts) {
        let nominal = self.nominal_bus;
        let measured = bus.to_bits();
        let measured =
            if measured < nominal / 2 { nominal } else { measured.min(nominal.saturating_mul(2)) };
        // Q15.16 × Q8.24 = Q.40 → Q15.16.
        let scale = mul_wide(nominal, reciprocal_q24(measured)) >> 24;
        self.bus_scale = saturate_i32(scale).clamp(1 << 15, 1 << 17);
    }

    /// The present bus scale `V_nominal / V_bus`, Q15.16 (1 until a bus is measured).
    #[must_use]
    pub const fn bus_scale(&self) -> Q16 {
        Q16::from_bits(self.bus_scale)
    }

    /// A duty (Q15.16 bits) at the nominal bus → the duty that puts the same voltage on the
    /// windings at the measured bus.
    fn on_bus(&self, bits: i64) -> i64 {
        bits.saturating_mul(i64::from(self.bus_scale)) >> 16
    }

    /// Duty per kgf at stall, Q7.24.
    #[must_use]
    pub const fn duty_per_kgf_q24(&self) -> i32 {
        self.duty_per_kgf
    }

    /// Duty per mm/s of carriage speed, Q7.24.
    #[must_use]
    pub const fn duty_per_mm_s_q24(&self) -> i32 {
        self.duty_per_mm_s
    }

    /// The force limit, kgf (`Kgf::MAX` without one).
    #[must_use]
    pub const fn force_limit(&self) -> Kgf {
        Kgf::from_bits(self.force_limit)
    }

    /// A signed duty fraction (Q15.16 bits) for force `force` at speed `speed`.
    fn signed_duty(&self, force: i32, speed: i32) -> i64 {
        let force = if self.compensate {
            force.clamp(self.force_limit.saturating_neg(), self.force_limit)
        } else {
            force
        };
        let from_force = mul_wide(force, self.duty_per_kgf);
        let from_speed = if self.compensate { mul_wide(speed, self.duty_per_mm_s) } else { 0 };
        // Q15.16 × Q7.24 = Q?.40 → Q15.16.
        self.on_bus(from_force.saturating_add(from_speed) >> (DUTY_COEF_FRAC))
    }

    /// The drive command for `force` at carriage speed `speed`, and whether it saturated:
    /// always [`Direction::Pull`], duty within the current-limit window and `[0, DUTY_MAX]`.
    #[must_use]
    pub fn command(&self, force: Kgf, speed: MmPerSecond) -> (DriveCommand, Saturation) {
        self.command_within(force, speed, self.current_window(speed))
    }

    /// [`ForceToDuty::command`] with the current-limit window given: the duty the force
    /// asks for, held inside `(low, high)` (duty, Q15.16 bits) and `[0, DUTY_MAX]`; when the
    /// window is empty (`low > high`), its nearest end. Split out so a proof can state the
    /// rule for *every* window without recomputing the one `command` uses.
    #[must_use]
    pub fn command_within(
        &self,
        force: Kgf,
        speed: MmPerSecond,
        (low, high): (i64, i64),
    ) -> (DriveCommand, Saturation) {
        let wanted = self.signed_duty(force.to_bits(), speed.0.to_bits());
        let saturation = if wanted > high {
            Saturation::High
        } else if wanted < low {
            Saturation::Low
        } else {
            Saturation::None
        };
        // `low ≤ high` unless the measured speed is beyond the motor's reach: back-driven so
        // fast that even zero duty draws more than the limit (→ zero duty, `high < 0`), or
        // over-running so fast that even full duty brakes harder than the limit (→ full
        // duty, the least braking there is). Either way the window's nearest end.
        let bits = wanted.max(low).min(high).max(0);
        let duty = Duty::from_fraction_clamped(Q16::from_bits(saturate_i32(bits)));
        (DriveCommand::Drive { direction: Direction::Pull, duty }, saturation)
    }

    /// The current-limit window at carriage speed `speed`, `(low, high)` duty as Q15.16 bits:
    /// the measured back-EMF duty `v·c_v` ± the resistive drop of the limit force
    /// `F_lim·c_f`, `high` at most [`DUTY_MAX`] and `low` at least 0 (so `low > high` when
    /// the speed is beyond the motor's reach; see [`ForceToDuty::command`]).
    #[must_use]
    pub fn current_window(&self, speed: MmPerSecond) -> (i64, i64) {
        let back_emf =
            self.on_bus(mul_wide(speed.0.to_bits(), self.duty_per_mm_s) >> DUTY_COEF_FRAC);
        let room = self.on_bus(mul_wide(self.force_limit, self.duty_per_kgf) >> DUTY_COEF_FRAC);
        let high = back_emf.saturating_add(room).min(i64::from(DUTY_MAX.raw()));
        let low = back_emf.saturating_sub(room).max(0);
        (low, high)
    }

    /// The largest duty the current limit allows at carriage speed `speed`: the measured
    /// back-EMF duty plus the resistive drop of the limit current, clamped to
    /// `[0, DUTY_MAX]` (full duty from rest would draw the stall current).
    #[must_use]
    pub fn current_limited_duty(&self, speed: MmPerSecond) -> Duty {
        let bits = self.on_bus(
            mul_wide(speed.0.to_bits(), self.duty_per_mm_s)
                .saturating_add(mul_wide(self.force_limit, self.duty_per_kgf))
                >> DUTY_COEF_FRAC,
        );
        Duty::from_fraction_clamped(Q16::from_bits(saturate_i32(bits)))
    }

    /// The duty that keeps the carriage moving at `speed` against `load` (velocity
    /// feed-forward: back-EMF plus the resistive drop of the load current), clamped to
    /// `[0, ceiling]`.
    #[must_use]
    pub fn velocity_duty(&self, speed: MmPerSecond, load: Kgf, ceiling: Duty) -> Duty {
        let bits = self.on_bus(
            mul_wide(speed.0.to_bits(), self.duty_per_mm_s)
                .saturating_add(mul_wide(load.to_bits(), self.duty_per_kgf))
                >> DUTY_COEF_FRAC,
        );
        let duty = Duty::from_fraction_clamped(Q16::from_bits(saturate_i32(bits)));
        if duty > ceiling { ceiling } else { duty }
    }
}

/// Carriage speed from the drive's Hall step counter (see the module docs).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct SpeedEstimator {
    /// mm/s per (step per tick): 52.917 µm × ticks per second, Q15.16.
    mm_s_per_step: Coef,
    /// Filter gain `dt/(τ_v + dt)`, Q15.16.
    alpha: Coef,
    /// The step count at the previous tick.
    last_steps: i32,
    /// The filtered speed, mm/s bits.
    speed: i32,
    /// Whether `last_steps` has been initialised.
    primed: bool,
}

impl SpeedEstimator {
    /// An estimator that always reads zero.
    pub(crate) const ZERO: Self =
        Self { mm_s_per_step: 0, alpha: 1, last_steps: 0, speed: 0, primed: false };

    /// An estimator for a tick of `period_us` µs and filter constant `tau`.
    ///
    /// # Errors
    /// [`MotorError::Parameter`] for a zero period or negative `tau`.
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(period_us: u32, tau: Seconds) -> Result<Self, MotorError> {
        if period_us == 0 || tau.0 < Q16::ZERO {
            return Err(MotorError::Parameter);
        }
        // mm/s per step per tick = 52 917 nm / period_us µs = 52.917/period_ms … in Q16.
        let per_step = (NM_PER_STEP << 16)
            .checked_div(i64::from(period_us))
            .and_then(|v| i32::try_from(v).ok())
            .ok_or(MotorError::Parameter)?;
        let alpha = filter_gain(period_us, tau).ok_or(MotorError::Parameter)?;
        Ok(Self { mm_s_per_step: per_step, alpha, last_steps: 0, speed: 0, primed: false })
    }

    /// Forgets the history (next update only primes).
    pub fn reset(&mut self) {
        self.primed = false;
        self.speed = 0;
    }

    /// The filtered speed.
    #[must_use]
    pub fn speed(&self) -> MmPerSecond {
        MmPerSecond(Q16::from_bits(self.speed))
    }

    /// Replaces the filter state (proofs, fuzzing).
    pub fn set_state(&mut self, last_steps: i32, speed: MmPerSecond, primed: bool) {
        self.last_steps = last_steps;
        self.speed = speed.0.to_bits();
        self.primed = primed;
    }

    /// One tick: the new step count in, the filtered speed out.
    pub fn update(&mut self, steps: i32) -> MmPerSecond {
        let delta = if self.primed {
            steps.wrapping_sub(self.last_steps).clamp(-MAX_STEPS_PER_TICK, MAX_STEPS_PER_TICK)
        } else {
            0
        };
        self.primed = true;
        self.last_steps = steps;
        // |delta| ≤ 16, per_step ≤ 2³¹/16 is not guaranteed, so saturate.
        let instant = delta.saturating_mul(self.mm_s_per_step);
        let error = i64::from(instant).saturating_sub(i64::from(self.speed));
        let step = narrow(error.saturating_mul(i64::from(self.alpha)));
        self.speed = self.speed.saturating_add(step);
        self.speed()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::valid;

    #[test]
    fn paper_motor_coefficients() {
        let map = valid(ForceToDuty::new(
            &MotorModel::PAPER,
            DutyMap::Proportional { current_limit: Amps::from_int(8) },
        ));
        // duty per mm/s = 0.0601 · 2π·20/25.4 / 24 = 0.012 389 → 80.7 mm/s at 100 %.
        let per_mm_s = f_q24(map.duty_per_mm_s_q24());
        assert!((per_mm_s - 12_389).abs() < 10, "{per_mm_s}");
        // kgf per A = 0.0601 · 4947.4 · 0.64 / 9.80665 = 19.404; duty/kgf = 0.846/(24·19.404)
        // = 0.001 817.
        let per_kgf = f_q24(map.duty_per_kgf_q24());
        assert!((per_kgf - 1_817).abs() < 5, "{per_kgf}");
    }

    /// A Q7.24 coefficient in millionths.
    fn f_q24(bits: i32) -> i64 {
        (i64::from(bits) * 1_000_000) >> 24
    }

    #[test]
    fn every_duty_is_scaled_to_the_measured_bus() {
        for map in [
            DutyMap::Proportional { current_limit: Amps::from_int(8) },
            DutyMap::BackEmf { current_limit: Amps::from_int(8) },
        ] {
            let nominal = valid(ForceToDuty::new(&MotorModel::PAPER, map));
            let speed = MmPerSecond::from_int(30);
            let duties = |m: &ForceToDuty| {
                let (low, high) = m.current_window(speed);
                [
                    i64::from(m.command(Kgf::from_int(20), speed).0.duty().raw()),
                    low,
                    high,
                    i64::from(m.current_limited_duty(speed).raw()),
                    i64::from(m.velocity_duty(speed, Kgf::from_int(10), DUTY_MAX).raw()),
                ]
            };
            let at_24 = duties(&nominal);
            assert!(at_24.iter().all(|&d| d > 0 && d < 60_000), "{at_24:?}");
            // (measured volts, expected scale in 1/1000): 30 V → 0.8, 20 V → 1.2; below half
            // the nominal is no reading (1); above twice the nominal is taken as twice (0.5).
            for (volts, scale_milli) in [
                (24, 1_000),
                (30, 800),
                (20, 1_200),
                (12, 2_000),
                (11, 1_000),
                (0, 1_000),
                (-5, 1_000),
                (100, 500),
            ] {
                let mut map = nominal;
                map.set_bus(Volts::from_int(volts));
                let scale = (i64::from(map.bus_scale().to_bits()) * 1_000 + (1 << 15)) >> 16;
                assert_eq!(scale, scale_milli, "{volts} V");
                for (scaled, base) in duties(&map).into_iter().zip(at_24) {
                    let expected = (base * scale_milli / 1_000).min(i64::from(DUTY_MAX.raw()));
                    assert!((scaled - expected).abs() <= 2, "{volts} V: {scaled} vs {expected}");
                }
            }
        }
    }

    #[test]
    fn back_emf_map_limits_and_brakes() {
        let map = valid(ForceToDuty::new(
            &MotorModel::PAPER,
            DutyMap::BackEmf { current_limit: Amps::from_int(8) },
        ));
        // 8 A × 19.404 kgf/A = 155.2 kgf.
        let limit_milli = (i64::from(map.force_limit().to_bits()) * 1000) >> 16;
        assert!((limit_milli - 155_230).abs() < 200, "{limit_milli}");
        let (cmd, sat) = map.command(Kgf::from_int(-500), MmPerSecond::from_int(0));
        assert_eq!(cmd.duty(), Duty::ZERO);
        assert_eq!(sat, Saturation::Low);
        let (cmd, sat) = map.command(Kgf::from_int(10), MmPerSecond::from_int(40));
        assert_eq!(sat, Saturation::None);
        assert_eq!(cmd.direction(), Some(Direction::Pull));
        // 10·0.001817 + 40·0.012389 = 0.51373 → 33 668 / 65 536.
        assert!((i32::from(cmd.duty().raw()) - 33_668).abs() < 40, "{cmd:?}");
    }

    #[test]
    fn current_window_is_back_emf_plus_minus_the_limit_drop() {
        let map = valid(ForceToDuty::new(
            &MotorModel::PAPER,
            DutyMap::BackEmf { current_limit: Amps::from_int(8) },
        ));
        let c_v = i64::from(map.duty_per_mm_s_q24());
        let c_f = i64::from(map.duty_per_kgf_q24());
        let room = (i64::from(map.force_limit().to_bits()) * c_f) >> 24;
        for mm_s in [-200_i16, -40, 0, 1, 40, 75, 200] {
            let speed = MmPerSecond::from_int(mm_s);
            let back_emf = (i64::from(speed.0.to_bits()) * c_v) >> 24;
            let (low, high) = map.current_window(speed);
            assert_eq!(high, (back_emf + room).min(i64::from(DUTY_MAX.raw())), "{mm_s}");
            assert_eq!(low, (back_emf - room).max(0), "{mm_s}");
        }
        // Back-driven beyond reach: the window is empty and its high end below zero.
        let (low, high) = map.current_window(MmPerSecond::from_int(-200));
        assert!(high < low && high < 0);
    }

    #[test]
    fn speed_from_steps() {
        let mut est = valid(SpeedEstimator::new(1_000, Seconds::from_milli(5)));
        let mut steps = 0_i32;
        let mut speed = MmPerSecond::default();
        // 1 step per tick = 52.9 mm/s.
        for _ in 0..200 {
            steps = steps.wrapping_add(1);
            speed = est.update(steps);
        }
        assert!((speed.0.to_num::<i32>() - 53).abs() <= 1, "{speed:?}");
    }
}

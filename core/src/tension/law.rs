//! The control laws: the paper's robust sliding-mode controller, taut's improved RSMC, and
//! the paper's PD baseline — each a force law `tension error → motor pull (kgf)`.
//!
//! # Theory of operation
//!
//! The paper (section 5) models the tension `y` of the string as a second-order plant
//! `ÿ + Ā ẏ + D̄ y = D̄ u + H` (eq. 5), with `u` the motor's pull in kgf, `Ā = B̄/M̄` and
//! `D̄ = K̄/M̄` from the nominal carriage mass, friction and string stiffness, and `H` the
//! bounded uncertainty. With the error `e = y_d − y` its controller is
//!
//! - sliding surface (eq. 9): `s = ė + 2λ e + λ² ∫ e dt`;
//! - equivalent control (eq. 12): `u_eq = (1/D̄)(2λ ė + λ² e − Ā ė − D̄ e + ÿ_d + Ā ẏ_d + D̄ y_d)`;
//! - hitting control (eq. 13): `u_h = G s + φ̂ sgn(s)`, and `u = u_eq + u_h` (eq. 11);
//! - adaptive gain (eq. 17): `dφ̂/dt = k_φ |s|` — it only grows.
//!
//! Rearranged (`y_d − e = y`, `ẏ_d − ė = ẏ`) the equivalent control is
//! `u_eq = y + c_dd ÿ_d + c_a ẏ_d + c_e ė + c_p e` with `c_dd = 1/D̄`, `c_a = Ā/D̄`,
//! `c_e = (2λ − Ā)/D̄`, `c_p = λ²/D̄`, which is how [`Rsmc::step`] evaluates it: every
//! coefficient is computed once by [`RsmcGains::coefficients`] and the step only multiplies
//! and adds. The integral is kept pre-scaled, `z = λ² ∫ e dt`, advanced by `(λ² dt)·e`.
//!
//! # The plant the law is written for
//!
//! taut drives the motor with a voltage (the duty), so the machine seen from the law's
//! force `u` — expressed as the *stall* pull the duty would give, `u = duty / c_f` — is
//! the paper's eq. (5) with `Ā = B_e/M̄`, the damping of the motor's own back-EMF reflected
//! to the carriage (≈ 170 s⁻¹: the drive is close to a velocity source), and `D̄ = K̄/M̄`.
//! Written that way the equivalent control's `Ā/D̄·ẏ_d = B_e·v_d` term *is* the back-EMF
//! compensation — of the reference speed, so the drive's natural damping is kept rather than
//! cancelled with a noisy measured speed. The string's stiffness `K` differs ten-fold
//! between strings; the controller identifies it during the take-up and sets the
//! **plant scale** `ρ = K̄/K̂` ([`Rsmc::set_plant_scale`]), which multiplies every `1/D̄`
//! term: `u_eq = y + ρ·(c_dd ÿ_d + c_a ẏ_d + c_e ė + c_p e)`. With `ρ = 1` (the default,
//! and always for the paper's law) the step is exactly eqs. (11)–(13).
//!
//! [`Improvements`] switches on, one by one, what the published law lacks:
//!
//! - **boundary layer**: `sat(s/Φ)` instead of `sgn(s)` — no chattering inside `|s| < Φ`;
//! - **bounded adaptation**: `φ̂` adapts only while `|s|` is outside a dead zone, leaks
//!   toward zero (`−σ φ̂`) and is clamped to `[0, φ_max]`;
//! - **anti-windup**: the integral stops integrating in the direction that would push an
//!   already saturated output further (conditional integration) and is clamped to `±z_max`;
//! - **filtered rate**: `ė` is a first-order low-pass of the backward difference (time
//!   constant `τ_f`), so 12-bit ADC noise (one code ≈ 0.013 kgf, ≈ 13 kgf/s as a 1 ms
//!   difference) is not amplified into the output.
//!
//! The force → duty mapping (back-EMF compensation, current limit) lives in
//! [`crate::tension::motor`]; this module only produces a force.
//!
//! # Fixed point
//!
//! Signals are Q15.16 `i32` bits: tension and error in kgf, rates in kgf/s, the second
//! derivative of the reference in kgf/s², the surface `s` in kgf/s, forces in kgf (range
//! ±32 768, resolution 2⁻¹⁶). Coefficients are Q15.16 `i32` ([`Coef`]). Every product is
//! formed exactly as a 64-bit integer from two 32-bit operands, sums are taken in 64 bits,
//! and the result is rounded once and saturated back to 32 bits, so a step costs one
//! rounding (≤ 2⁻¹⁷) per product and overflow is impossible. The adaptive gain is kept in
//! **Q31.32** (`i64`) because its increment `k_φ·dt·|s|` (≈ 10⁻⁷·|s| for the paper's
//! `k_φ = 0.001` at 0.1 ms) is far below 2⁻¹⁶; its rate coefficient `k_φ·dt` is **Q?.40**
//! (`i32`, range < 2⁻⁹, resolution 9 × 10⁻¹³).

use crate::fixed::{filter_gain, mul_q16, mul_wide, narrow, saturate_i32};
use crate::units::{Kgf, KgfPerSecond, Q16};

/// A per-tick coefficient, Q15.16 `i32` bits (range ±32 768, resolution 2⁻¹⁶).
pub type Coef = i32;

/// Fraction bits of the adaptive-rate coefficient `k_φ·dt`.
pub const KPHI_FRAC: u32 = 40;

/// The smallest plant scale `ρ = K̄/K̂` (Q15.16): a string ten times stiffer than nominal.
pub const PLANT_SCALE_MIN: Q16 = Q16::lit("0.1");

/// The largest plant scale `ρ = K̄/K̂` (Q15.16): a string ten times softer than nominal.
pub const PLANT_SCALE_MAX: Q16 = Q16::const_from_int(10);

/// A reference trajectory sample: where the tension should be, how fast it should move and
/// how fast that rate should change.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Reference {
    /// `y_d`, kgf.
    pub tension: Kgf,
    /// `ẏ_d`, kgf/s.
    pub rate: KgfPerSecond,
    /// `ÿ_d`, kgf/s², Q15.16 bits.
    pub accel: Q16,
}

impl Reference {
    /// A constant set point.
    #[must_use]
    pub const fn constant(tension: Kgf) -> Self {
        Self { tension, rate: KgfPerSecond::ZERO, accel: Q16::ZERO }
    }
}

/// The nominal plant of the paper's eq. (5): `Ā = B̄/M̄` (1/s) and `D̄ = K̄/M̄` (1/s²).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct NominalPlant {
    /// `Ā`, 1/s.
    pub a_bar: Q16,
    /// `D̄`, 1/s²; must be positive.
    pub d_bar: Q16,
}

/// What taut adds to the published law; each can be switched off to measure its effect.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Improvements {
    /// `sat(s/Φ)` with this boundary-layer width `Φ` (kgf/s) instead of `sgn(s)`.
    pub boundary_layer: Option<KgfPerSecond>,
    /// Bounded adaptation: dead zone, leakage and ceiling for `φ̂`.
    pub bounded_adaptation: Option<BoundedAdaptation>,
    /// Anti-windup: the integral `z = λ²∫e` is clamped to `±z_max` (kgf/s) and frozen in the
    /// direction that would push a saturated output further.
    pub anti_windup: Option<KgfPerSecond>,
    /// Low-pass time constant `τ_f` of the error-rate estimate, seconds.
    pub rate_filter: Option<crate::units::Seconds>,
}

impl Improvements {
    /// None of them: the law as published.
    pub const NONE: Self = Self {
        boundary_layer: None,
        bounded_adaptation: None,
        anti_windup: None,
        rate_filter: None,
    };
}

/// Bounds on the adaptive gain `φ̂`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct BoundedAdaptation {
    /// `φ̂` adapts only while `|s|` exceeds this, kgf/s.
    pub dead_zone: KgfPerSecond,
    /// Leakage rate `σ`, 1/s: `dφ̂/dt = k_φ|s| − σ φ̂`.
    pub leakage: Q16,
    /// Ceiling `φ_max`, kgf.
    pub max: Kgf,
}

/// RSMC gains in the paper's units, validated by [`RsmcGains::coefficients`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct RsmcGains {
    /// `λ`, 1/s (paper: 100).
    pub lambda: Q16,
    /// `G`, kgf per kgf/s (paper: 0.2).
    pub g: Q16,
    /// `k_φ` in units of 10⁻⁶ (paper: 0.001 → 1 000), so small rates are exact.
    pub k_phi_micro: u32,
    /// The nominal plant the equivalent control is computed from.
    pub plant: NominalPlant,
    /// taut's improvements (all `None` for the paper's law).
    pub improvements: Improvements,
}

/// Why a set of gains was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum GainError {
    /// `λ` outside `(0, 1000]` 1/s.
    Lambda,
    /// `G` negative or above 1 000.
    HittingGain,
    /// `k_φ·dt` not representable (above 2⁻⁹ per step).
    AdaptationRate,
    /// `D̄` not positive, or a derived coefficient (`1/D̄`, `λ²/D̄`, …) outside Q15.16.
    Plant,
    /// An improvement's parameter is not positive or out of range.
    Improvement,
    /// A PD gain is negative or above 10 000.
    PdGain,
}

/// The per-tick constants of an RSMC, computed once from [`RsmcGains`] and a period.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct RsmcCoefficients {
    /// `1/dt`, Hz (whole number).
    pub inv_dt: i32,
    /// `λ²·dt` (integral increment per kgf of error).
    pub lambda2_dt: Coef,
    /// `2λ`.
    pub two_lambda: Coef,
    /// `1/D̄`.
    pub c_dd: Coef,
    /// `Ā/D̄`.
    pub c_a: Coef,
    /// `(2λ − Ā)/D̄`.
    pub c_e: Coef,
    /// `λ²/D̄`.
    pub c_p: Coef,
    /// `G`.
    pub g: Coef,
    /// `k_φ·dt`, Q?.40.
    pub k_phi_dt: i32,
    /// `1/Φ` (boundary layer) or 0 for `sgn`.
    pub inv_boundary: Coef,
    /// Dead zone on `|s|`, kgf/s bits (0 = none).
    pub dead_zone: i32,
    /// `σ·dt` as Q15.16 (0 = no leakage): `φ̂` loses `φ̂·σ·dt` per step.
    pub leak_dt: Coef,
    /// `φ_max` in Q31.32 (`i64::MAX` = unbounded).
    pub phi_max: i64,
    /// `z_max` in kgf/s bits (`i32::MAX` = only the format bounds it).
    pub z_max: i32,
    /// Whether the integral freezes while the output saturates.
    pub conditional_integration: bool,
    /// `α = dt/(τ_f + dt)` of the rate filter, Q15.16 (65 536 = no filtering).
    pub rate_alpha: Coef,
}

/// A Q15.16 value as a per-tick coefficient.
fn coef_from(value: Q16) -> Coef {
    value.to_bits()
}

impl RsmcGains {
    /// The paper's gains (section 7.3): `λ = 100`, `G = 0.2`, `k_φ = 0.001`, on `plant`.
    #[must_use]
    pub const fn paper(plant: NominalPlant) -> Self {
        Self {
            lambda: Q16::const_from_int(100),
            g: Q16::lit("0.2"),
            k_phi_micro: 1_000,
            plant,
            improvements: Improvements::NONE,
        }
    }

    /// Validates the gains and computes the per-tick constants for a period of
    /// `period_us` microseconds.
    ///
    /// # Errors
    /// [`GainError`] naming the first out-of-range parameter.
    pub fn coefficients(&self, period_us: u32) -> Result<RsmcCoefficients, GainError> {
        if period_us == 0 {
            return Err(GainError::Plant);
        }
        // dt in Q15.16 is coarse (15 µs resolution); every product with dt is derived from
        // the microseconds instead.
        let micros = i64::from(period_us);
        if self.lambda <= Q16::ZERO || self.lambda > Q16::const_from_int(1_000) {
            return Err(GainError::Lambda);
        }
        if self.g < Q16::ZERO || self.g > Q16::const_from_int(1_000) {
            return Err(GainError::HittingGain);
        }
        if self.plant.d_bar <= Q16::ZERO || self.plant.a_bar < Q16::ZERO {
            return Err(GainError::Plant);
        }
        let lambda = self.lambda;
        let lambda2 = lambda.checked_mul(lambda).ok_or(GainError::Lambda)?;
        let two_lambda = lambda.checked_mul_int(2).ok_or(GainError::Lambda)?;
        // λ²·dt = λ² × µs / 10⁶, from the exact bits.
        let lambda2_dt = i64::from(lambda2.to_bits())
            .checked_mul(micros)
            .and_then(|v| v.checked_div(1_000_000))
            .and_then(|v| i32::try_from(v).ok())
            .ok_or(GainError::Lambda)?;
        let d = self.plant.d_bar;
        let c_dd = Q16::ONE.checked_div(d).ok_or(GainError::Plant)?;
        let c_a = self.plant.a_bar.checked_div(d).ok_or(GainError::Plant)?;
        let c_e = two_lambda
            .checked_sub(self.plant.a_bar)
            .and_then(|v| v.checked_div(d))
            .ok_or(GainError::Plant)?;
        let c_p = lambda2.checked_div(d).ok_or(GainError::Plant)?;
        if c_dd == Q16::ZERO {
            return Err(GainError::Plant);
        }
        // k_φ·dt in Q?.40: k_φ_micro × 10⁻⁶ × µs × 10⁻⁶ × 2⁴⁰.
        let k_phi_dt = i128::from(self.k_phi_micro)
            .checked_mul(i128::from(micros))
            .and_then(|v| v.checked_mul(1_i128 << KPHI_FRAC))
            .and_then(|v| v.checked_div(1_000_000_000_000))
            .and_then(|v| i32::try_from(v).ok())
            .ok_or(GainError::AdaptationRate)?;
        let inv_dt = i32::try_from(1_000_000_u32.checked_div(period_us).unwrap_or(0))
            .map_err(|_| GainError::Plant)?;

        let improvements = self.improvements;
        let inv_boundary = match improvements.boundary_layer {
            None => 0,
            Some(width) => {
                if width.0 <= Q16::ZERO {
                    return Err(GainError::Improvement);
                }
                coef_from(Q16::ONE.checked_div(width.0).ok_or(GainError::Improvement)?)
            }
        };
        let (dead_zone, leak_dt, phi_max) = match improvements.bounded_adaptation {
            None => (0, 0, i64::MAX),
            Some(bounds) => {
                if bounds.dead_zone.0 < Q16::ZERO
                    || bounds.leakage < Q16::ZERO
                    || bounds.max.0 <= Q16::ZERO
                {
                    return Err(GainError::Improvement);
                }
                // σ·dt from the microseconds (dt itself is coarse in Q15.16).
                let leak_dt = i64::from(bounds.leakage.to_bits())
                    .checked_mul(micros)
                    .and_then(|v| v.checked_add(500_000))
                    .and_then(|v| v.checked_div(1_000_000))
                    .ok_or(GainError::Improvement)?;
                if leak_dt >= i64::from(Q16::ONE.to_bits()) {
                    return Err(GainError::Improvement);
                }
                let leak_dt = i32::try_from(leak_dt).map_err(|_| GainError::Improvement)?;
                (bounds.dead_zone.0.to_bits(), leak_dt, i64::from(bounds.max.0.to_bits()) << 16)
            }
        };
        let (z_max, conditional_integration) = match improvements.anti_windup {
            None => (i32::MAX, false),
            Some(limit) => {
                if limit.0 <= Q16::ZERO {
                    return Err(GainError::Improvement);
                }
                (limit.0.to_bits(), true)
            }
        };
        let rate_alpha = match improvements.rate_filter {
            None => Q16::ONE.to_bits(),
            Some(tau) => filter_gain(period_us, tau).ok_or(GainError::Improvement)?,
        };
        Ok(RsmcCoefficients {
            inv_dt,
            lambda2_dt,
            two_lambda: coef_from(two_lambda),
            c_dd: coef_from(c_dd),
            c_a: coef_from(c_a),
            c_e: coef_from(c_e),
            c_p: coef_from(c_p),
            g: coef_from(self.g),
            k_phi_dt,
            inv_boundary,
            dead_zone,
            leak_dt,
            phi_max,
            z_max,
            conditional_integration,
            rate_alpha,
        })
    }
}

/// Which way the actuator saturated on the previous step, for conditional integration.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
#[cfg_attr(kani, derive(kani::Arbitrary))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub enum Saturation {
    /// Not saturated.
    #[default]
    None,
    /// The output was clipped at its upper bound (more pull was asked than given).
    High,
    /// The output was clipped at its lower bound.
    Low,
}

/// The RSMC's memory between steps (any value: [`Rsmc::is_valid`] states which are reachable;
/// proofs and fuzzing draw it whole).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
#[cfg_attr(kani, derive(kani::Arbitrary))]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct RsmcState {
    /// The previous error, kgf bits (for the backward difference).
    pub e_prev: i32,
    /// The error-rate estimate, kgf/s bits.
    pub e_rate: i32,
    /// `z = λ² ∫ e dt`, kgf/s bits.
    pub z: i32,
    /// `φ̂`, kgf, Q31.32.
    pub phi_hat: i64,
}

/// One step's result, with the internals the reports plot.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct RsmcOutput {
    /// The force `u = u_eq + u_h`, kgf.
    pub force: Kgf,
    /// The sliding variable `s`, kgf/s.
    pub surface: KgfPerSecond,
    /// The equivalent control `u_eq`, kgf.
    pub equivalent: Kgf,
}

/// The RSMC: validated constants plus state.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Rsmc {
    coefficients: RsmcCoefficients,
    state: RsmcState,
    /// The plant scale `ρ = K̄/K̂`, Q15.16 bits, in `[PLANT_SCALE_MIN, PLANT_SCALE_MAX]`.
    scale: Coef,
}

impl Rsmc {
    /// An RSMC at rest (zero integral, zero `φ̂`).
    ///
    /// # Errors
    /// [`GainError`] from [`RsmcGains::coefficients`].
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(gains: &RsmcGains, period_us: u32) -> Result<Self, GainError> {
        Ok(Self {
            coefficients: gains.coefficients(period_us)?,
            state: RsmcState::default(),
            scale: Q16::ONE.to_bits(),
        })
    }

    /// Sets the plant scale `ρ = K̄/K̂` (see the module docs), clamped to
    /// `[PLANT_SCALE_MIN, PLANT_SCALE_MAX]`.
    pub fn set_plant_scale(&mut self, scale: Q16) {
        self.scale = scale.clamp(PLANT_SCALE_MIN, PLANT_SCALE_MAX).to_bits();
    }

    /// The plant scale `ρ`.
    #[must_use]
    pub fn plant_scale(&self) -> Q16 {
        Q16::from_bits(self.scale)
    }

    /// The per-tick constants.
    #[must_use]
    pub const fn coefficients(&self) -> &RsmcCoefficients {
        &self.coefficients
    }

    /// The current state.
    #[must_use]
    pub const fn state(&self) -> RsmcState {
        self.state
    }

    /// Replaces the state (proofs, fuzzing, bumpless transfer); it must satisfy
    /// [`Rsmc::is_valid`] for the step's guarantees to hold.
    pub fn set_state(&mut self, state: RsmcState) {
        self.state = state;
    }

    /// Clears the memory and starts from error `e0` (no derivative kick on the first step).
    pub fn reset(&mut self, e0: Kgf) {
        self.state = RsmcState { e_prev: e0.to_bits(), ..RsmcState::default() };
    }

    /// The invariant: `φ̂ ∈ [0, φ_max]`, `|z| ≤ z_max`, `ρ` within its range.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let c = &self.coefficients;
        self.scale >= PLANT_SCALE_MIN.to_bits()
            && self.scale <= PLANT_SCALE_MAX.to_bits()
            && self.state.phi_hat >= 0
            && self.state.phi_hat <= c.phi_max
            && self.state.z <= c.z_max
            && self.state.z >= c.z_max.saturating_neg()
    }

    /// One step of the law for reference `r` and measured tension `y`. `saturated` says
    /// which way the actuator clipped the previous output (only used with anti-windup).
    pub fn step(&mut self, r: &Reference, y: Kgf, saturated: Saturation) -> RsmcOutput {
        let c = self.coefficients;
        let e = r.tension.0.saturating_sub(y.0).to_bits();

        // Error rate: backward difference, optionally low-pass filtered. The products are
        // exact (`wrapping_mul` cannot wrap): |e − e_prev| < 2³³ and 1/dt ≤ 20 000 < 2¹⁵
        // (periods of at least 50 µs); |Δ| < 2³⁴ and α ≤ 1 (2¹⁶ bits). An overflow check here
        // would cost a 128-bit product per tick (and in CBMC).
        let raw_rate = saturate_i32(
            i64::from(e)
                .saturating_sub(i64::from(self.state.e_prev))
                .wrapping_mul(i64::from(c.inv_dt)),
        );
        let delta = i64::from(raw_rate).saturating_sub(i64::from(self.state.e_rate));
        let e_rate = saturate_i32(
            i64::from(self.state.e_rate)
                .saturating_add(narrow(delta.wrapping_mul(i64::from(c.rate_alpha))).into()),
        );
        self.state.e_prev = e;
        self.state.e_rate = e_rate;

        // Integral z = λ²∫e, with conditional integration and clamp under anti-windup.
        let increment = narrow(mul_wide(c.lambda2_dt, e));
        let frozen = c.conditional_integration
            && match saturated {
                Saturation::High => increment > 0,
                Saturation::Low => increment < 0,
                Saturation::None => false,
            };
        if !frozen {
            let z = self.state.z.saturating_add(increment);
            self.state.z = z.clamp(c.z_max.saturating_neg(), c.z_max);
        }

        // Sliding surface s = ė + 2λe + z.
        let s_wide = i64::from(e_rate)
            .saturating_add(narrow(mul_wide(c.two_lambda, e)).into())
            .saturating_add(i64::from(self.state.z));
        let s = saturate_i32(s_wide);

        // Equivalent control: y + ρ·(c_dd ÿ_d + c_a ẏ_d + c_e ė + c_p e).
        let eq_wide = mul_wide(c.c_dd, r.accel.to_bits())
            .saturating_add(mul_wide(c.c_a, r.rate.0.to_bits()))
            .saturating_add(mul_wide(c.c_e, e_rate))
            .saturating_add(mul_wide(c.c_p, e));
        let scaled = mul_q16(narrow(eq_wide), self.scale);
        let equivalent = saturate_i32(i64::from(y.0.to_bits()).saturating_add(i64::from(scaled)));

        // Switching function: sgn(s) or sat(s/Φ), Q15.16 in [−1, 1].
        let one = Q16::ONE.to_bits();
        let minus_one = Q16::NEG_ONE.to_bits();
        let switching = if c.inv_boundary == 0 {
            match s {
                0 => 0,
                s if s > 0 => one,
                _ => minus_one,
            }
        } else {
            mul_q16(s, c.inv_boundary).clamp(minus_one, one)
        };

        // Hitting control G s + φ̂·switch (φ̂ rounded from Q31.32 to Q15.16).
        let phi_q16 = saturate_i32(self.state.phi_hat.saturating_add(1 << 15) >> 16);
        let hitting = mul_wide(c.g, s).saturating_add(mul_wide(phi_q16, switching));
        let force = saturate_i32(i64::from(equivalent).saturating_add(i64::from(narrow(hitting))));

        // Adaptation φ̂ += k_φ dt |s| (outside the dead zone), with leakage, in [0, φ_max].
        let magnitude = s.saturating_abs();
        let mut phi = self.state.phi_hat.clamp(0, c.phi_max);
        if c.leak_dt != 0 {
            // φ̂ −= φ̂·σdt: Q31.32 × Q15.16, rounded back to Q31.32. With leakage on, φ̂ is
            // clamped to φ_max < 2⁴⁷ and σdt < 2¹⁶ (both validated), so the product is below
            // 2⁶³: exact.
            let leak = phi.wrapping_mul(i64::from(c.leak_dt)).saturating_add(1 << 15) >> 16;
            phi = phi.saturating_sub(leak);
        }
        if magnitude > c.dead_zone {
            // |s| ≤ 2³¹ and k_φ·dt < 2³¹: the product is below 2⁶², exact.
            let grow = i64::from(magnitude).wrapping_mul(i64::from(c.k_phi_dt)) >> (KPHI_FRAC - 16);
            phi = phi.saturating_add(grow);
        }
        self.state.phi_hat = phi.clamp(0, c.phi_max);

        RsmcOutput {
            force: Kgf::from_bits(force),
            surface: KgfPerSecond::from_bits(s),
            equivalent: Kgf::from_bits(equivalent),
        }
    }
}

/// The paper's PD baseline gains (`u = k_p e + k_d ė`).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct PdGains {
    /// `k_p`, kgf per kgf (paper: 100).
    pub kp: Q16,
    /// `k_d`, kgf per kgf/s (paper: 20).
    pub kd: Q16,
}

impl PdGains {
    /// The paper's gains: `k_p = 100`, `k_d = 20`.
    pub const PAPER: Self = Self { kp: Q16::const_from_int(100), kd: Q16::const_from_int(20) };
}

/// The PD law with its memory (the previous error).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Pd {
    kp: Coef,
    kd: Coef,
    inv_dt: i32,
    e_prev: i32,
}

impl Pd {
    /// Zero gains at 1 kHz: always zero force.
    pub(crate) const ZERO: Self = Self { kp: 0, kd: 0, inv_dt: 1_000, e_prev: 0 };

    /// A PD controller for a period of `period_us` microseconds.
    ///
    /// # Errors
    /// [`GainError::PdGain`] for a negative or huge gain; [`GainError::Plant`] for a zero
    /// period.
    // Always inlined: from a constant configuration (the firmware's) the whole construction
    // folds to its result at compile time, so the image carries no constructor
    // (`scripts/firmware-size` checks).
    #[inline(always)]
    pub fn new(gains: &PdGains, period_us: u32) -> Result<Self, GainError> {
        let limit = Q16::const_from_int(10_000);
        if gains.kp < Q16::ZERO || gains.kd < Q16::ZERO || gains.kp > limit || gains.kd > limit {
            return Err(GainError::PdGain);
        }
        let inv_dt = i32::try_from(1_000_000_u32.checked_div(period_us).ok_or(GainError::Plant)?)
            .map_err(|_| GainError::Plant)?;
        Ok(Self { kp: gains.kp.to_bits(), kd: gains.kd.to_bits(), inv_dt, e_prev: 0 })
    }

    /// Clears the memory, starting from error `e0`.
    pub fn reset(&mut self, e0: Kgf) {
        self.e_prev = e0.to_bits();
    }

    /// One step: `u = k_p e + k_d (e − e_prev)/dt`.
    pub fn step(&mut self, r: &Reference, y: Kgf) -> Kgf {
        let e = r.tension.0.saturating_sub(y.0).to_bits();
        let rate = saturate_i32(
            i64::from(e)
                .saturating_sub(i64::from(self.e_prev))
                .saturating_mul(i64::from(self.inv_dt)),
        );
        self.e_prev = e;
        Kgf::from_bits(narrow(mul_wide(self.kp, e).saturating_add(mul_wide(self.kd, rate))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::valid;

    #[test]
    fn plant_scale_is_clamped_and_scales_the_equivalent_control() {
        let plant = NominalPlant { a_bar: Q16::const_from_int(170), d_bar: Q16::lit("12.4") };
        let gains = RsmcGains { lambda: Q16::const_from_int(85), ..RsmcGains::paper(plant) };
        let mut law = valid(Rsmc::new(&gains, 1_000));
        law.set_plant_scale(Q16::const_from_int(100));
        assert_eq!(law.plant_scale(), PLANT_SCALE_MAX);
        law.set_plant_scale(Q16::ZERO);
        assert_eq!(law.plant_scale(), PLANT_SCALE_MIN);
        assert!(law.is_valid());
        // The equivalent control's correction doubles with ρ = 2.
        let r = Reference::constant(Kgf::from_int(20));
        let y = Kgf::from_int(19);
        let mut one = valid(Rsmc::new(&gains, 1_000));
        let mut two = one;
        two.set_plant_scale(Q16::const_from_int(2));
        one.reset(Kgf::from_int(1));
        two.reset(Kgf::from_int(1));
        let u1 = one.step(&r, y, Saturation::None).equivalent.saturating_sub(y);
        let u2 = two.step(&r, y, Saturation::None).equivalent.saturating_sub(y);
        let doubled = u1.saturating_add(u1);
        assert!(u2.saturating_sub(doubled).abs() <= Kgf::from_bits(2), "{u1:?} {u2:?}");
    }
}

//! The `f64` reference of the tension control laws: the paper's equations (9)–(17) and
//! taut's improvements, written plainly in floating point, against which the fixed-point
//! `taut_core::tension::law` step is judged.
//!
//! # The stated bound (`REQ-TEN-05`)
//!
//! Over any sequence of steps with tensions and references in 0–60 kgf, for the paper's and
//! taut's gains, the fixed-point force stays within
//! `FORCE_TOLERANCE_ABS + FORCE_TOLERANCE_REL·|u|` of this reference run from the same
//! inputs, except in the steps where the reference's sliding variable lies within
//! [`SGN_GUARD`] of zero under the discontinuous `sgn` (there the two may legitimately pick
//! opposite signs of a jump of height `2φ̂`). The error comes from the Q15.16 rounding of
//! Checked at the deployed 1 ms period for both laws and at the paper's 0.1 ms for the
//! paper's law; at 0.1 ms taut's rate-filter gain `dt/(τ_f + dt)` ≈ 0.012 is quantised to
//! 5 × 10⁻⁴ relative in Q15.16, which lets the filtered rate drift by more than this bound.
//!
//! Forces beyond [`FORCE_COMPARED_MAX`] are not compared: there the fixed point saturates
//! at Q15.16's ±32 768 kgf by design (and the duty long before). The error comes from the
//! Q15.16 rounding of
//! the inputs and of each derived coefficient (`1/D̄`, `λ²/D̄`, … relative error ≤ 2⁻¹⁶ /
//! coefficient), one rounding per product, and the Q15.16 state (the error rate, the
//! integral) carried from step to step.
#![allow(
    clippy::float_arithmetic,
    clippy::cast_precision_loss,
    reason = "this module is the f64 reference the fixed-point controller is judged against"
)]

use taut_core::tension::law::{RsmcGains, Saturation};

/// Absolute part of the tracking bound, kgf.
pub const FORCE_TOLERANCE_ABS: f64 = 0.5;
/// Relative part of the tracking bound.
pub const FORCE_TOLERANCE_REL: f64 = 1e-2;
/// Largest |force| compared, kgf.
pub const FORCE_COMPARED_MAX: f64 = 16_000.0;
/// Band of `|s|` (kgf/s) in which `sgn` may differ between the two.
pub const SGN_GUARD: f64 = 0.05;

/// A Q15.16 value as f64.
#[must_use]
pub fn q(bits: i32) -> f64 {
    f64::from(bits) / 65_536.0
}

/// The f64 RSMC: the same equations as `taut_core::tension::law::Rsmc`, exact coefficients.
#[derive(Clone, Copy, Debug)]
pub struct RsmcReference {
    lambda: f64,
    g: f64,
    k_phi: f64,
    a_bar: f64,
    d_bar: f64,
    dt: f64,
    boundary: Option<f64>,
    dead_zone: f64,
    leakage: f64,
    phi_max: f64,
    z_max: f64,
    conditional: bool,
    rate_alpha: f64,
    /// Previous error, kgf.
    pub e_prev: f64,
    /// Error rate, kgf/s.
    pub e_rate: f64,
    /// `λ² ∫ e`, kgf/s.
    pub z: f64,
    /// `φ̂`, kgf.
    pub phi: f64,
}

/// One reference step's outputs.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceOutput {
    /// Force, kgf.
    pub force: f64,
    /// Sliding variable, kgf/s.
    pub surface: f64,
}

impl RsmcReference {
    /// From the same gains the core validates, for a period of `period_us` µs.
    #[must_use]
    pub fn new(gains: &RsmcGains, period_us: u32) -> Self {
        let dt = f64::from(period_us) * 1e-6;
        let imp = gains.improvements;
        let bounded = imp.bounded_adaptation;
        Self {
            lambda: gains.lambda.to_num(),
            g: gains.g.to_num(),
            k_phi: f64::from(gains.k_phi_micro) * 1e-6,
            a_bar: gains.plant.a_bar.to_num(),
            d_bar: gains.plant.d_bar.to_num(),
            dt,
            boundary: imp.boundary_layer.map(|b| b.0.to_num()),
            dead_zone: bounded.map_or(0.0, |b| b.dead_zone.0.to_num()),
            leakage: bounded.map_or(0.0, |b| b.leakage.to_num()),
            phi_max: bounded.map_or(f64::INFINITY, |b| b.max.0.to_num()),
            z_max: imp.anti_windup.map_or(f64::INFINITY, |z| z.0.to_num()),
            conditional: imp.anti_windup.is_some(),
            rate_alpha: imp.rate_filter.map_or(1.0, |tau| {
                let tau: f64 = tau.0.to_num();
                dt / (tau + dt)
            }),
            e_prev: 0.0,
            e_rate: 0.0,
            z: 0.0,
            phi: 0.0,
        }
    }

    /// One step: reference `(y_d, ẏ_d, ÿ_d)`, measured `y`, previous saturation.
    pub fn step(
        &mut self,
        y_d: f64,
        rate_d: f64,
        accel_d: f64,
        y: f64,
        saturated: Saturation,
    ) -> ReferenceOutput {
        let e = y_d - y;
        let raw_rate = (e - self.e_prev) / self.dt;
        self.e_rate += self.rate_alpha * (raw_rate - self.e_rate);
        self.e_prev = e;
        let increment = self.lambda * self.lambda * self.dt * e;
        let frozen = self.conditional
            && match saturated {
                Saturation::High => increment > 0.0,
                Saturation::Low => increment < 0.0,
                Saturation::None => false,
            };
        if !frozen {
            self.z = (self.z + increment).clamp(-self.z_max, self.z_max);
        }
        let e_rate = self.e_rate;
        let s = e_rate + 2.0 * self.lambda * e + self.z;
        // eq. (12), term by term.
        let u_eq = (2.0 * self.lambda * e_rate + self.lambda * self.lambda * e
            - self.a_bar * e_rate
            - self.d_bar * e
            + accel_d
            + self.a_bar * rate_d
            + self.d_bar * y_d)
            / self.d_bar;
        let switching = match self.boundary {
            None => {
                if s > 0.0 {
                    1.0
                } else if s < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            Some(width) => (s / width).clamp(-1.0, 1.0),
        };
        let force = u_eq + self.g * s + self.phi * switching;
        let mut phi = self.phi * (1.0 - self.leakage * self.dt);
        if s.abs() > self.dead_zone {
            phi += self.k_phi * self.dt * s.abs();
        }
        self.phi = phi.clamp(0.0, self.phi_max);
        ReferenceOutput { force, surface: s }
    }
}

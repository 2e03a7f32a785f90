//! The `f64` reference of the RSMC law — the paper's equations (9)–(17) with taut's
//! improvements, written plainly in floating point — and the stated bound within which the
//! fixed-point `taut_core::tension::law::Rsmc` step tracks it (`REQ-TEN-05`).
//!
//! # Two sources of difference, bounded separately
//!
//! 1. **Coefficients.** [`RsmcGains::coefficients`] derives every per-tick constant
//!    (`λ²dt`, `2λ`, `1/D̄`, `Ā/D̄`, `(2λ − Ā)/D̄`, `λ²/D̄`, `G`, `k_φdt`, `1/Φ`, `σdt`,
//!    the rate filter's `dt/(τ_f + dt)`) once, at construction. [`coefficient_errors`]
//!    compares each with its exact value computed in `f64` from the same (representable)
//!    gains: every one is within one unit of its last place (Q15.16, Q?.40 for `k_φdt`),
//!    at 1 ms and at the paper's 0.1 ms. (The rate filter's gain used to be formed from `dt`
//!    in Q15.16, which is 7 % off at 0.1 ms; it is now computed from the microseconds.)
//! 2. **Arithmetic.** [`RsmcReference`] evaluates the step with the fixed law's *own*
//!    coefficients in `f64`; what is left is the rounding of the step itself. Each product
//!    is formed exactly and rounded once (≤ ½ LSB, `u = 2⁻¹⁶`); the state carries it on:
//!    - the filtered error rate contracts it: `|E_ė| ≤ u/(2α)` (0 without the filter);
//!    - the integral adds one rounding per step: `|E_z(k)| ≤ k·u/2` after `k` steps;
//!    - so `|E_s(k)| ≤ E_ė + u/2 + E_z(k)`, and the force's error after `k` steps is at most
//!      `E_u(k) = u/2 + ρ·(u/2 + |c_e|·E_ė) + u/2 + G·E_s(k) + φ_max·(u/2 + E_s(k)/Φ) + u`
//!      (the last `u` for `φ̂`'s rounding to Q15.16; `φ̂` itself is kept in Q31.32 and its
//!      leak is rounded there, so its own error stays below 2⁻³⁰ kgf).
//!
//!    [`tracking_bound`] returns `E_u(k)`. It grows linearly, by `(G + φ_max/Φ)·u/2` per
//!    step — for taut's law ≈ 1.5 × 10⁻⁶ kgf per step (0.0016 kgf after 1 000 steps, 1 s at
//!    1 kHz; 0.016 kgf after 10 000, 1 s at 10 kHz) — because the integral's roundings do
//!    not cancel in the worst case.
//!
//! Under the paper's discontinuous `sgn(s)` the two may pick opposite signs when
//! `|s| ≤ E_s(k)`; that step's force is not compared (the state does not depend on the
//! sign, so the runs do not diverge). Forces whose intermediate terms reach Q15.16's limits
//! (±32 768) are not compared: there the fixed point saturates by design.
#![allow(
    clippy::float_arithmetic,
    clippy::cast_precision_loss,
    reason = "this module is the f64 reference the fixed-point controller is judged against"
)]

use taut_core::tension::controller::{TAUT_GAINS, TAUT_PLANT};
use taut_core::tension::law::{KPHI_FRAC, Reference, Rsmc, RsmcGains, Saturation};
use taut_core::units::{Kgf, KgfPerSecond, Q16};

/// One unit of Q15.16, `2⁻¹⁶`.
pub const LSB: f64 = 1.0 / 65_536.0;

/// Largest magnitude of an intermediate term (force, surface, integral) that is compared:
/// beyond it the fixed point saturates at Q15.16's ±32 768 by design.
pub const COMPARED_MAX: f64 = 30_000.0;

/// A Q15.16 value as f64.
#[must_use]
pub fn q(bits: i32) -> f64 {
    f64::from(bits) * LSB
}

/// The f64 RSMC with the fixed law's own coefficients (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct RsmcReference {
    inv_dt: f64,
    lambda2_dt: f64,
    two_lambda: f64,
    c_dd: f64,
    c_a: f64,
    c_e: f64,
    c_p: f64,
    g: f64,
    k_phi_dt: f64,
    inv_boundary: Option<f64>,
    dead_zone: f64,
    leak_dt: f64,
    phi_max: f64,
    z_max: f64,
    conditional: bool,
    rate_alpha: f64,
    scale: f64,
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
    /// The largest intermediate magnitude (raw error rate, surface, integral, equivalent
    /// control, hitting).
    pub largest_term: f64,
}

impl RsmcReference {
    /// The reference of `law`: its coefficients, plant scale and present state.
    #[must_use]
    pub fn of(law: &Rsmc) -> Self {
        let c = law.coefficients();
        let state = law.state();
        Self {
            inv_dt: f64::from(c.inv_dt),
            lambda2_dt: q(c.lambda2_dt),
            two_lambda: q(c.two_lambda),
            c_dd: q(c.c_dd),
            c_a: q(c.c_a),
            c_e: q(c.c_e),
            c_p: q(c.c_p),
            g: q(c.g),
            k_phi_dt: f64::from(c.k_phi_dt) / (1_u64 << KPHI_FRAC) as f64,
            inv_boundary: (c.inv_boundary != 0).then(|| q(c.inv_boundary)),
            dead_zone: q(c.dead_zone),
            leak_dt: q(c.leak_dt),
            phi_max: if c.phi_max == i64::MAX {
                f64::INFINITY
            } else {
                c.phi_max as f64 / 2f64.powi(32)
            },
            z_max: if c.z_max == i32::MAX { f64::INFINITY } else { q(c.z_max) },
            conditional: c.conditional_integration,
            rate_alpha: q(c.rate_alpha),
            scale: law.plant_scale().to_num::<f64>(),
            e_prev: q(state.e_prev),
            e_rate: q(state.e_rate),
            z: q(state.z),
            phi: state.phi_hat as f64 / 2f64.powi(32),
        }
    }

    /// One step: reference `(y_d, ẏ_d, ÿ_d)`, measured `y`, previous saturation — the same
    /// equations as `Rsmc::step`, term by term, in f64.
    pub fn step(
        &mut self,
        y_d: f64,
        rate_d: f64,
        accel_d: f64,
        y: f64,
        saturated: Saturation,
    ) -> ReferenceOutput {
        let e = y_d - y;
        let raw_rate = (e - self.e_prev) * self.inv_dt;
        let raw_magnitude = raw_rate.abs();
        self.e_rate += self.rate_alpha * (raw_rate - self.e_rate);
        self.e_prev = e;
        let increment = self.lambda2_dt * e;
        let frozen = self.conditional
            && match saturated {
                Saturation::High => increment > 0.0,
                Saturation::Low => increment < 0.0,
                Saturation::None => false,
            };
        if !frozen {
            self.z = (self.z + increment).clamp(-self.z_max, self.z_max);
        }
        let s = self.e_rate + self.two_lambda * e + self.z;
        // eq. (12), rearranged as in the law: y + ρ·(c_dd ÿ_d + c_a ẏ_d + c_e ė + c_p e).
        let inner = self.c_dd * accel_d + self.c_a * rate_d + self.c_e * self.e_rate + self.c_p * e;
        let equivalent = y + self.scale * inner;
        let switching = match self.inv_boundary {
            None => {
                if s > 0.0 {
                    1.0
                } else if s < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            Some(inv) => (s * inv).clamp(-1.0, 1.0),
        };
        let hitting = self.g * s + self.phi * switching;
        let force = equivalent + hitting;
        let mut phi = self.phi - self.phi * self.leak_dt;
        if s.abs() > self.dead_zone {
            phi += self.k_phi_dt * s.abs();
        }
        self.phi = phi.clamp(0.0, self.phi_max);
        let largest_term =
            [raw_magnitude, s.abs(), self.z.abs(), equivalent.abs(), hitting.abs(), inner.abs()]
                .into_iter()
                .fold(0.0, f64::max);
        ReferenceOutput { force, surface: s, largest_term }
    }
}

/// The arithmetic part of the tracking bound after `steps` steps of `law` (see the module
/// docs): `E_u(k)` in kgf.
#[must_use]
pub fn tracking_bound(law: &Rsmc, steps: u64) -> f64 {
    let r = RsmcReference::of(law);
    let half = LSB / 2.0;
    let e_rate = if r.rate_alpha >= 1.0 { 0.0 } else { half / r.rate_alpha };
    let e_z = steps as f64 * half;
    let e_s = e_rate + half + e_z;
    let phi_max = if r.phi_max.is_finite() { r.phi_max } else { r.phi.max(0.0) };
    let e_switch = r.inv_boundary.map_or(0.0, |inv| half + inv * e_s);
    half + r.scale * (half + r.c_e.abs() * e_rate) + half + r.g * e_s + phi_max * e_switch + LSB
}

/// The band of `|s|` within which `sgn(s)` may differ between the two after `steps` steps
/// (`E_s(k)`).
#[must_use]
pub fn surface_guard(law: &Rsmc, steps: u64) -> f64 {
    let r = RsmcReference::of(law);
    let half = LSB / 2.0;
    let e_rate = if r.rate_alpha >= 1.0 { 0.0 } else { half / r.rate_alpha };
    e_rate + half + steps as f64 * half
}

/// Each derived coefficient's error against its exact value, in units of its last place:
/// `(name, error)` pairs (see the module docs, part 1).
#[must_use]
pub fn coefficient_errors(gains: &RsmcGains, period_us: u32) -> Vec<(&'static str, f64)> {
    let Ok(c) = gains.coefficients(period_us) else {
        return vec![("rejected", f64::INFINITY)];
    };
    let lambda: f64 = gains.lambda.to_num();
    let a: f64 = gains.plant.a_bar.to_num();
    let d: f64 = gains.plant.d_bar.to_num();
    let dt = f64::from(period_us) * 1e-6;
    let imp = gains.improvements;
    let ulp = |name, fixed: i32, exact: f64| (name, (q(fixed) - exact).abs() / LSB);
    let mut out = vec![
        ("inv_dt", (f64::from(c.inv_dt) - 1.0 / dt).abs()),
        ulp("lambda2_dt", c.lambda2_dt, lambda * lambda * dt),
        ulp("two_lambda", c.two_lambda, 2.0 * lambda),
        ulp("c_dd", c.c_dd, 1.0 / d),
        ulp("c_a", c.c_a, a / d),
        ulp("c_e", c.c_e, (2.0 * lambda - a) / d),
        ulp("c_p", c.c_p, lambda * lambda / d),
        ulp("g", c.g, gains.g.to_num()),
        (
            "k_phi_dt",
            (f64::from(c.k_phi_dt)
                - f64::from(gains.k_phi_micro) * 1e-6 * dt * (1_u64 << KPHI_FRAC) as f64)
                .abs(),
        ),
    ];
    if let Some(width) = imp.boundary_layer {
        out.push(ulp("inv_boundary", c.inv_boundary, 1.0 / width.0.to_num::<f64>()));
    }
    if let Some(bounds) = imp.bounded_adaptation {
        out.push(ulp("leak_dt", c.leak_dt, bounds.leakage.to_num::<f64>() * dt));
    }
    if let Some(tau) = imp.rate_filter {
        let tau: f64 = tau.0.to_num();
        out.push(ulp("rate_alpha", c.rate_alpha, dt / (tau + dt)));
    }
    out
}

/// One step's inputs for the tracking property, as raw bits (normalised into the compared
/// domain by [`law_tracks_reference`]).
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
pub struct TrackStep {
    /// Change of the reference tension this step, kgf bits (clamped to ±2 kgf; the first
    /// step's value, taken modulo 60 kgf, is the starting reference).
    pub y_d: i32,
    /// Reference rate, kgf/s bits (clamped to ±1 000 kgf/s).
    pub rate: i32,
    /// Reference acceleration, kgf/s² bits (clamped to ±20 000 kgf/s²).
    pub accel: i32,
    /// Change of the measured tension this step, kgf bits (clamped to ±2 kgf).
    pub dy: i32,
    /// Saturation selector (`% 3`).
    pub saturated: u8,
}

/// Largest tension the tracking property feeds in, kgf bits (60 kgf).
const TENSION_SPAN: i32 = 60 << 16;

/// REQ-TEN-05: the fixed-point law (`paper`'s or taut's gains, at 1 ms or — `fast` — at the
/// paper's 0.1 ms, plant scale `scale`) follows its `f64` reference over the whole
/// sequence within [`tracking_bound`] at every step (outside the `sgn` guard band, and until
/// an intermediate term reaches the compared limit). Returns the steps compared.
pub fn law_tracks_reference(paper: bool, fast: bool, scale: i32, steps: &[TrackStep]) -> usize {
    let gains = if paper { RsmcGains::paper(TAUT_PLANT) } else { TAUT_GAINS };
    let period = if fast { 100 } else { 1_000 };
    let Ok(mut law) = Rsmc::new(&gains, period) else {
        panic!("REQ-TEN-06: a built-in law was rejected");
    };
    if !paper {
        law.set_plant_scale(Q16::from_bits(scale));
    }
    let first = steps.first().copied().unwrap_or_default();
    let mut y = (first.dy.rem_euclid(TENSION_SPAN)).clamp(0, TENSION_SPAN);
    let mut y_d = first.y_d.rem_euclid(TENSION_SPAN);
    law.reset(Kgf::from_bits(y_d.saturating_sub(y)));
    let mut float = RsmcReference::of(&law);
    let mut compared: usize = 0;
    for (k, input) in steps.iter().enumerate() {
        if k > 0 {
            y_d = y_d.saturating_add(input.y_d.clamp(-2 << 16, 2 << 16)).clamp(0, TENSION_SPAN);
        }
        let rate = input.rate.clamp(-1_000 << 16, 1_000 << 16);
        let accel = input.accel.clamp(-20_000 << 16, 20_000 << 16);
        if k > 0 {
            y = y.saturating_add(input.dy.clamp(-2 << 16, 2 << 16)).clamp(0, TENSION_SPAN);
        }
        let saturated = match input.saturated % 3 {
            0 => Saturation::None,
            1 => Saturation::High,
            _ => Saturation::Low,
        };
        let reference = Reference {
            tension: Kgf::from_bits(y_d),
            rate: KgfPerSecond::from_bits(rate),
            accel: Q16::from_bits(accel),
        };
        let out = law.step(&reference, Kgf::from_bits(y), saturated);
        let expected = float.step(q(y_d), q(rate), q(accel), q(y), saturated);
        if expected.largest_term > COMPARED_MAX || expected.force.abs() > COMPARED_MAX {
            // The fixed point saturates from here on by design; the runs part.
            break;
        }
        let done = u64::try_from(k).unwrap_or(u64::MAX).saturating_add(1);
        if paper && expected.surface.abs() <= surface_guard(&law, done) {
            continue;
        }
        let bound = tracking_bound(&law, done);
        let error = (q(out.force.to_bits()) - expected.force).abs();
        assert!(
            error <= bound,
            "REQ-TEN-05: paper={paper} fast={fast} step {k}: fixed {} vs f64 {} (error {error:e}, bound {bound:e})",
            q(out.force.to_bits()),
            expected.force
        );
        compared = compared.saturating_add(1);
    }
    compared
}

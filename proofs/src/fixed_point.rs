//! Fixed-point foundation properties (`REQ-FXP-*`): every conversion and saturating operation
//! of `taut_core::units` / `taut_core::sense` against an `f64` reference.
//!
//! # Bounds
//!
//! One unit in the last place of Q15.16 is `ULP = 2⁻¹⁶ ≈ 1.53 × 10⁻⁵`.
//! - ADC code → volts and → amperes: **exact** (the scale factors are whole numbers of ULPs).
//! - Load cell code → kgf: one rounded multiplication, **≤ 1 ULP** (1.5 × 10⁻⁵ kgf) from the
//!   exact `(V − V₀)·k` for the same `V₀` and `k`.
//! - Saturating add / subtract: exact when the exact result is in range, otherwise the range
//!   limit. Saturating multiply: **≤ 1 ULP** from the exact product clamped to the range.
//! - kgf ↔ tenths and lbf tenths: exact round trips over the panel's whole range.
//!
//! `f64` has 53 significant bits; every reference value here needs at most 48, so the
//! reference itself is exact.
#![allow(
    clippy::float_arithmetic,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    reason = "this module is the f64 reference the fixed-point core is judged against"
)]

use taut_core::sense::current;
use taut_core::sense::load_cell::LoadCellScale;
use taut_core::units::{AdcCode, Kgf, Q16, Volts};

/// One Q15.16 unit in the last place.
pub const ULP: f64 = 1.0 / 65_536.0;

/// The largest and smallest Q15.16 values as `f64`.
const Q16_RANGE: (f64, f64) = (-32_768.0, 32_768.0 - ULP);

fn q(value: Q16) -> f64 {
    f64::from(value.to_bits()) * ULP
}

/// REQ-FXP-01: code → volts is exact: `code × 5 / 4096`.
pub fn adc_volts_exact(raw: u16) {
    let code = AdcCode::new(raw);
    let reference = f64::from(code.get()) * 5.0 / 4096.0;
    assert_eq!(q(crate::FIVE_VOLTS.volts(code).0), reference, "REQ-FXP-01: code {raw}");
    assert!(code.get() <= 4095, "REQ-FXP-01: code above 12 bits");
}

/// REQ-FXP-02: code → amperes is exact: `code × 5 / 4096 / 0.2`.
pub fn current_amps_exact(raw: u16) {
    let code = AdcCode::new(raw);
    let reference = f64::from(code.get()) * 5.0 / 4096.0 / 0.2;
    assert_eq!(q(current::amps(code).0), reference, "REQ-FXP-02: code {raw}");
}

/// REQ-FXP-03: code → kgf through any valid load-cell scale is within 1 ULP of
/// `(V − V₀)·k`; invalid scales are rejected, never used.
pub fn load_cell_within_bound(raw: u16, zero_bits: i32, kgf_per_volt_bits: i32) {
    let zero = Volts::from_bits(zero_bits);
    let k = Q16::from_bits(kgf_per_volt_bits);
    let Ok(scale) = LoadCellScale::new(crate::FIVE_VOLTS, zero, k) else {
        return;
    };
    let code = AdcCode::new(raw);
    let reference = (f64::from(code.get()) * 5.0 / 4096.0 - q(zero.0)) * q(k);
    let got = q(scale.to_kgf(code).0);
    assert!(
        (got - reference).abs() <= ULP,
        "REQ-FXP-03: code {raw}: {got} vs {reference} (error {})",
        got - reference
    );
}

/// REQ-FXP-04: saturating add, subtract and multiply on Q15.16 against the clamped exact result.
pub fn saturating_ops_within_bound(a_bits: i32, b_bits: i32) {
    let (a, b) = (Kgf::from_bits(a_bits), Kgf::from_bits(b_bits));
    let clamp = |x: f64| x.clamp(Q16_RANGE.0, Q16_RANGE.1);
    let (fa, fb) = (q(a.0), q(b.0));
    assert_eq!(q(a.saturating_add(b).0), clamp(fa + fb), "REQ-FXP-04: {fa} + {fb}");
    assert_eq!(q(a.saturating_sub(b).0), clamp(fa - fb), "REQ-FXP-04: {fa} - {fb}");
    let product = q(a.saturating_scale(b.0).0);
    let exact = clamp(fa * fb);
    assert!((product - exact).abs() <= ULP, "REQ-FXP-04: {fa} × {fb} = {product}, not {exact}");
    assert_eq!(q(a.abs().0), clamp(fa.abs()), "REQ-FXP-04: |{fa}|");
}

/// REQ-FXP-05: the panel's units round-trip: tenths of a kgf and tenths of a pound-force
/// (0.5 lb steps are multiples of it) come back unchanged over ±3 276.7, and the kgf → lbf
/// display is the correctly rounded `kgf × 2.204 622 6` to a tenth.
pub fn panel_units_round_trip(tenths: i16) {
    let tenths = i32::from(tenths) / 10;
    let kgf = Kgf::from_tenths(tenths);
    assert_eq!(kgf.to_tenths_rounded(), tenths, "REQ-FXP-05: {tenths} tenths of a kgf");
    let lbf = Kgf::from_lbf_tenths(tenths);
    assert_eq!(lbf.to_lbf_tenths_rounded(), tenths, "REQ-FXP-05: {tenths} tenths of a lbf");
    let reference = (f64::from(tenths) / 10.0 * 2.204_622_6 * 10.0).round();
    let shown = f64::from(kgf.to_lbf_tenths_rounded());
    assert!((shown - reference).abs() <= 1.0, "REQ-FXP-05: {tenths} → {shown} lbf tenths");
}

/// REQ-FXP-06: every unit conversion is total: any `i32` of tenths, thousandths or pound
/// tenths, and any Q15.16 value, converts without panicking, saturating at the format's range,
/// and conversions of in-range values agree with the exact result to the rounding step.
pub fn unit_conversions_total(value: i32, bits: i32) {
    let exact = f64::from(value);
    let clamp = |x: f64| x.clamp(Q16_RANGE.0, Q16_RANGE.1);
    let tenths = q(Kgf::from_tenths(value).0);
    assert!((tenths - clamp(exact / 10.0)).abs() <= ULP, "REQ-FXP-06: {value} tenths → {tenths}");
    let milli = q(Kgf::from_milli(value).0);
    assert!((milli - clamp(exact / 1000.0)).abs() <= ULP, "REQ-FXP-06: {value} milli → {milli}");
    let lbf = q(Kgf::from_lbf_tenths(value).0);
    let lbf_exact = clamp(clamp(exact / 10.0) / q(taut_core::units::LBF_PER_KGF));
    assert!((lbf - lbf_exact).abs() <= 2.0 * ULP, "REQ-FXP-06: {value} lbf tenths → {lbf}");
    let kgf = Kgf::from_bits(bits);
    let shown = f64::from(kgf.to_tenths_rounded());
    assert!((shown - q(kgf.0) * 10.0).abs() <= 0.5 + 1e-9, "REQ-FXP-06: {bits} bits → {shown}");
    let shown_milli = f64::from(kgf.to_milli());
    assert!((shown_milli - q(kgf.0) * 1000.0).abs() <= 0.5 + 1e-9, "REQ-FXP-06: to_milli {bits}");
    let _ = kgf.to_lbf_tenths_rounded();
}

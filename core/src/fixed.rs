//! Fixed-point arithmetic shared by the sensing and the control: exact wide products,
//! rounding and saturation back to Q15.16, the division-free reciprocal, first-order filter
//! gains, and the wider formats the tension profile keeps its coefficients and reference in.
//!
//! # Theory of operation
//!
//! Signals in core are Q15.16 `i32` bits ([`Q16`] and the unit types built on it). A product
//! of two of them is formed exactly in an `i64` (Q31.32, [`mul_wide`]) and rounded once back
//! to Q15.16 ([`narrow`]), saturating instead of wrapping, so a chain of products costs one
//! rounding each and never overflows. Two quantities need more resolution than Q15.16 has:
//!
//! - [`Q24`] (Q8.24 in an `i32`): reciprocals and short times — `1/x` from
//!   [`reciprocal_q24`], `1/(2a)` in s²/mm, a sensing lag in seconds — whose values sit
//!   below 128 and whose relative precision matters more than their range;
//! - [`Q32`] (Q31.32 in an `i64`): a reference that must keep moving when its per-tick
//!   increment is below Q15.16's 15 µ-units;
//! - [`Frac32`] (Q0.32 in a `u32`): per-tick fractions such as `dt = 0.001 s`, which Q15.16
//!   represents only to 2 %.
//!
//! Every function here is total: no panic, no overflow, no division in the ones a control
//! tick calls ([`filter_gain`] divides, and is construction-time only).

use crate::units::{Q16, Seconds};

/// A Q8.24 value in an `i32` (`1 << 24` = 1.0; range ±128, resolution 6 × 10⁻⁸).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct Q24(pub i32);

impl Q24 {
    /// 1.0.
    pub const ONE: Self = Self(1 << 24);

    /// A Q15.16 value as Q8.24, saturating beyond ±128.
    #[must_use]
    pub fn from_q16(value: Q16) -> Self {
        Self(value.to_bits().saturating_mul(256))
    }
}

/// A fraction in `[0, 1)` as Q0.32 in a `u32` (`2³²` would be 1.0): a per-tick fraction
/// such as `dt` or `dt/τ`, resolution 2.3 × 10⁻¹⁰.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct Frac32(pub u32);

impl Frac32 {
    /// The fraction as Q0.32 in an `i64`, for 64-bit products.
    #[must_use]
    pub fn wide(self) -> i64 {
        i64::from(self.0)
    }
}

/// A Q31.32 value in an `i64` (`1 << 32` = 1.0): a signal that needs more resolution than
/// Q15.16.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct Q32(pub i64);

impl Q32 {
    /// A Q15.16 value as Q31.32 (exact).
    #[must_use]
    pub fn from_q16(value: Q16) -> Self {
        Self(i64::from(value.to_bits()) << 16)
    }

    /// Rounded to nearest and saturated to Q15.16.
    #[must_use]
    pub fn to_q16(self) -> Q16 {
        Q16::from_bits(saturate_i32(self.0.saturating_add(1 << 15) >> 16))
    }
}

/// `a × b` for Q15.16 operands, exact, as Q31.32 in an `i64` (cannot overflow: both < 2³¹).
#[must_use]
pub fn mul_wide(a: i32, b: i32) -> i64 {
    // |a·b| ≤ 2⁶², inside i64, so the product is exact and cannot wrap. (Not
    // `saturating_mul`: its overflow check costs a 128-bit product on the Cortex-M4 and in
    // CBMC, for a case that cannot happen.)
    i64::from(a).wrapping_mul(i64::from(b))
}

/// A Q31.32 `i64` rounded to nearest and saturated to Q15.16 `i32` bits.
#[must_use]
pub fn narrow(wide: i64) -> i32 {
    saturate_i32(wide.saturating_add(1 << 15) >> 16)
}

/// An `i64` clamped into `i32`.
#[must_use]
pub fn saturate_i32(value: i64) -> i32 {
    i32::try_from(value).unwrap_or(if value < 0 { i32::MIN } else { i32::MAX })
}

/// `a × b` of two Q15.16 values, rounded and saturated to Q15.16.
#[must_use]
pub fn mul_q16(a: i32, b: i32) -> i32 {
    narrow(mul_wide(a, b))
}

/// The gain `dt/(τ + dt)` of a first-order low-pass sampled every `period_us` µs, as
/// Q15.16 bits rounded to nearest (at least one LSB), computed exactly from the
/// microseconds — `dt` itself is not representable in Q15.16 to better than 7 % at 0.1 ms,
/// so it is never formed. Construction-time only (it divides); `None` for a negative `τ` or
/// a zero period.
#[must_use]
pub fn filter_gain(period_us: u32, tau: Seconds) -> Option<i32> {
    if period_us == 0 || tau.0 < Q16::ZERO {
        return None;
    }
    // α = p·2³² / (τ_bits·10⁶ + p·2¹⁶), p in µs, τ_bits = τ·2¹⁶.
    let p = i64::from(period_us);
    let den =
        i64::from(tau.to_bits()).checked_mul(1_000_000)?.checked_add(p.checked_mul(1 << 16)?)?;
    let num = p.checked_mul(1 << 32)?;
    let alpha = num.checked_add(den / 2)?.checked_div(den)?;
    i32::try_from(alpha.max(1)).ok()
}

/// `1/x` for a positive Q15.16 `x`, as Q8.24 bits (`1 << 24` = 1.0), without a division:
/// the argument is normalised to `M ∈ [½, 1)` by its leading-zero count, `1/M` is seeded
/// with the best linear guess `48/17 − 32/17·M` (relative error ≤ 1/17) and refined by
/// three Newton steps `y ← y·(2 − M·y)` (error ≤ 1/17 → 3.5 × 10⁻³ → 1.2 × 10⁻⁵ →
/// 1.5 × 10⁻¹⁰, below the output's resolution), then shifted back. Six 32 × 32-bit products.
/// Results saturate: `x ≤ 2⁻⁷` (`1/x ≥ 128`, beyond Q8.24) gives about `i32::MAX`, `x ≤ 0`
/// gives 0.
#[must_use]
pub fn reciprocal_q24(x: i32) -> i32 {
    if x <= 0 {
        return 0;
    }
    // Bit index of the leading one: 0..=30 (x > 0 has at least one leading zero).
    let top = 31_u32.saturating_sub(x.leading_zeros());
    // M = x·2^(30−top) / 2^31 ∈ [½, 1), as Q1.31 in an i64.
    let m = i64::from(x) << 30_u32.saturating_sub(top);
    // Seed, Q2.30: 48/17 − 32/17·M.
    let seed_a: i64 = 3_031_741_621; // 48/17 · 2^30
    let seed_b: i64 = 2_021_161_081; // 32/17 · 2^30
    // seed_b < 2³¹ and M < 2³¹: the product is below 2⁶² and exact (wrapping cannot occur).
    let mut y = seed_a.saturating_sub(seed_b.wrapping_mul(m) >> 31);
    // Three Newton steps (constant bound). Every operand stays below 2³²: y ∈ (0.9, 2] in
    // Q2.30 (Newton approaches 1/M ≤ 2 from below), M ∈ [½, 1) in Q1.31, the correction
    // 2 − M·y ∈ (0, 2) in Q2.30; so each product
    // is below 2⁶³ and exact (`wrapping_mul` without the overflow check that would cost a
    // 128-bit product; `reciprocal_accurate` checks the result for every input).
    for _ in 0..3 {
        // M·y: Q1.31 × Q2.30 → Q.61 → Q2.30.
        let my = m.wrapping_mul(y) >> 31;
        let correction = (2_i64 << 30).saturating_sub(my);
        y = y.wrapping_mul(correction) >> 30;
    }
    // 1/X = (1/M)·2^(15−top); as Q8.24 from Q2.30: shift by (15 − top) − 6 = 9 − top.
    let shifted = if top >= 9 {
        y >> top.saturating_sub(9)
    } else {
        y.checked_shl(9_u32.saturating_sub(top)).unwrap_or(i64::MAX)
    };
    saturate_i32(shifted)
}

/// `a × b` of a Q15.16 value and a Q8.24 factor, rounded, as Q15.16 bits.
#[must_use]
pub fn mul_q24(a: i32, b: Q24) -> i32 {
    saturate_i32(mul_wide(a, b.0).saturating_add(1 << 23) >> 24)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::valid;

    /// `1/x` in Q8.24 by integer division, the exact reference (saturated like the
    /// reciprocal).
    fn exact_q24(x: i32) -> i64 {
        ((1_i64 << 40) / i64::from(x)).min(i64::from(i32::MAX))
    }

    #[test]
    fn reciprocal_matches_the_exact_quotient() {
        // Every power of two and its neighbours, then a dense geometric sweep: 0.004 to
        // 32 767 in steps of 0.1 %.
        let mut cases = 0_u32;
        let mut check = |x: i32| {
            let got = i64::from(reciprocal_q24(x));
            let exact = exact_q24(x);
            // Within 2 LSB or 2⁻²⁰ relative (the Newton steps converge far below that).
            let tolerance = (exact >> 20).max(2);
            assert!((got - exact).abs() <= tolerance, "1/{x}: {got} vs {exact}");
            cases += 1;
        };
        for shift in 8..31 {
            let p = 1_i32 << shift;
            check(p);
            check(p - 1);
            check(p + 1);
        }
        let mut x: i64 = 256;
        while x < i64::from(i32::MAX) {
            check(i32::try_from(x).unwrap_or(i32::MAX));
            x += (x / 1_000).max(1);
        }
        assert!(cases > 10_000, "{cases}");
        assert_eq!(reciprocal_q24(0), 0);
        assert_eq!(reciprocal_q24(-5), 0);
        assert_eq!(reciprocal_q24(1), i32::MAX);
    }

    #[test]
    fn filter_gains_are_exact_to_half_an_lsb_at_every_period() {
        // α = p / (τ + p), from the microseconds: at 0.1 ms and τ = 8 ms (524 bits =
        // 7.995 6 ms in Q15.16), 100/8 095.6 of 2¹⁶ = 809.5 → 810 (the old route through
        // dt in Q15.16 took dt = 7/65 536 s, 7 % long).
        let tau = Seconds::from_milli(8);
        assert_eq!(filter_gain(100, tau), Some(810));
        for period in [50_u32, 100, 250, 1_000, 2_000, 10_000] {
            for tau_ms in [0_i32, 1, 4, 8, 16, 100] {
                let tau = Seconds::from_milli(tau_ms);
                let alpha = i64::from(valid(filter_gain(period, tau).ok_or("no gain")));
                // Exact: p·2¹⁶/(τ_µs + p) with τ_µs = τ_bits·10⁶/2¹⁶.
                let num = i128::from(period) << 32;
                let den = i128::from(tau.to_bits()) * 1_000_000 + (i128::from(period) << 16);
                // |α·den − num| ≤ den/2 ⇔ α is the nearest integer.
                let off = (i128::from(alpha) * den - num).abs();
                assert!(off * 2 <= den, "p {period} τ {tau_ms} ms: {alpha}");
            }
        }
        assert_eq!(filter_gain(0, tau), None);
    }

    #[test]
    fn the_wide_formats_round_and_saturate() {
        assert_eq!(Q32::from_q16(Q16::lit("1.5")).0, 3 << 31);
        assert_eq!(Q32(3 << 31).to_q16(), Q16::lit("1.5"));
        // Half an LSB of Q15.16 rounds up; just below it rounds down.
        assert_eq!(Q32((5 << 16) + (1 << 15)).to_q16().to_bits(), 6);
        assert_eq!(Q32((5 << 16) + (1 << 15) - 1).to_q16().to_bits(), 5);
        assert_eq!(Q32(i64::MAX).to_q16().to_bits(), i32::MAX);
        assert_eq!(Q32(i64::MIN).to_q16().to_bits(), i32::MIN);
        assert_eq!(Frac32(u32::MAX).wide(), (1_i64 << 32) - 1);
        assert_eq!(Q24::from_q16(Q16::ONE), Q24::ONE);
        assert_eq!(Q24::from_q16(Q16::const_from_int(200)).0, i32::MAX);
        // 3 × 0.5 = 1.5; a product below half an LSB rounds to zero, at half it rounds up.
        assert_eq!(mul_q24(Q16::const_from_int(3).to_bits(), Q24(1 << 23)), 3 << 15);
        assert_eq!(mul_q24(1, Q24((1 << 23) - 1)), 0);
        assert_eq!(mul_q24(1, Q24(1 << 23)), 1);
        assert_eq!(mul_q24(i32::MAX, Q24(i32::MAX)), i32::MAX);
        assert_eq!(mul_q24(i32::MIN, Q24(i32::MAX)), i32::MIN);
        assert_eq!(saturate_i32(i64::from(i32::MAX) + 1), i32::MAX);
        assert_eq!(saturate_i32(i64::from(i32::MIN) - 1), i32::MIN);
        assert_eq!(narrow(-(1 << 15)), 0);
        assert_eq!(
            mul_q16(Q16::const_from_int(-2).to_bits(), Q16::lit("0.25").to_bits()),
            -(1 << 15)
        );
    }
}

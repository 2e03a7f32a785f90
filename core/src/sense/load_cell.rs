//! The load cell: strain-gauge bridge → amplifier → 12-bit ADC code → volts → kgf.
//!
//! # Theory of operation
//!
//! A thin-film strain gauge on an aluminium bar forms one arm of a Wheatstone bridge (the
//! paper's equation 1) fed from a 9.25 V double-regulated reference; an instrumentation
//! amplifier raises the few-millivolt bridge output to the converter's 0–5 V range. The paper
//! reads ≈ 920 mV at 10 kgf, so the chain's nominal sensitivity is **92 mV/kgf** and full
//! scale (5 V) is ≈ 54 kgf, covering the 5–50 kgf tension range with margin. One ADC code is
//! 1.22 mV ≈ 0.013 kgf.
//!
//! [`LoadCellScale`] is the linear part of the conversion: `kgf = (V − V₀) × k`, with `V₀` the
//! amplifier output at zero load (found by taring at power-up) and `k` the reciprocal of the
//! sensitivity. Its parameters are validated once, when the scale is built; the per-sample
//! conversion has no error branch (it saturates). The four-point calibration against a
//! reference gauge corrects the residual non-linearity on top of this (see the calibration
//! module).
//!
//! # Error bound
//!
//! Code → volts is exact (one code is 80 Q15.16 bits). The subtraction is exact. The single
//! multiplication rounds once, so `|to_kgf(code) − (V(code) − V₀)·k| ≤ 2⁻¹⁶ kgf` against the
//! exact real-number result for the same `V₀` and `k`; `proofs/tests/fixed_point.rs` checks
//! this against a double-precision reference over every code and a proptest sweep of scales.

use crate::units::{AdcCode, Kgf, Q16, Volts};

/// Nominal sensitivity of the load-cell chain, volts per kgf (paper: ≈ 920 mV at 10 kgf).
pub const NOMINAL_VOLTS_PER_KGF: Q16 = Q16::lit("0.092");

/// Nominal `k`, kgf per volt: 1 / 0.092 = 10.869 565.
pub const NOMINAL_KGF_PER_VOLT: Q16 = Q16::lit("10.869565");

/// Nominal amplifier output at zero load: 50 mV (a small positive offset keeps the zero
/// reading clear of the converter's bottom rail, so a disconnected bridge that pulls the
/// amplifier to 0 V is told apart from an unloaded one).
pub const NOMINAL_ZERO: Volts = Volts(Q16::lit("0.05"));

/// The plausible range of `k`: a chain whose gain is off by more than ×2 either way from
/// nominal is mis-wired or mis-configured, not merely uncalibrated.
pub const KGF_PER_VOLT_RANGE: (Q16, Q16) = (Q16::lit("5.4"), Q16::lit("21.8"));

/// The plausible range of the zero-load output: 0 V to 0.5 V (≈ 5.4 kgf of offset).
pub const ZERO_RANGE: (Volts, Volts) = (Volts(Q16::ZERO), Volts(Q16::lit("0.5")));

/// Why a load-cell scale was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ScaleError {
    /// `k` outside [`KGF_PER_VOLT_RANGE`]: gain wrong by more than a factor of two.
    GainOutOfRange,
    /// Zero-load output outside [`ZERO_RANGE`]: bridge unbalanced, reversed or miswired.
    ZeroOutOfRange,
}

/// The linear ADC → kgf conversion of the load cell, validated at construction.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct LoadCellScale {
    zero: Volts,
    kgf_per_volt: Q16,
}

impl Default for LoadCellScale {
    fn default() -> Self {
        Self::NOMINAL
    }
}

impl LoadCellScale {
    /// The paper's chain: 92 mV/kgf, 50 mV offset.
    pub const NOMINAL: Self = Self { zero: NOMINAL_ZERO, kgf_per_volt: NOMINAL_KGF_PER_VOLT };

    /// A scale with zero-load output `zero` and `kgf_per_volt`.
    ///
    /// # Errors
    /// [`ScaleError`] when either parameter is outside its plausible range.
    pub fn new(zero: Volts, kgf_per_volt: Q16) -> Result<Self, ScaleError> {
        if kgf_per_volt < KGF_PER_VOLT_RANGE.0 || kgf_per_volt > KGF_PER_VOLT_RANGE.1 {
            return Err(ScaleError::GainOutOfRange);
        }
        if zero < ZERO_RANGE.0 || zero > ZERO_RANGE.1 {
            return Err(ScaleError::ZeroOutOfRange);
        }
        Ok(Self { zero, kgf_per_volt })
    }

    /// The same gain, re-zeroed at the unloaded reading `code` (taring).
    ///
    /// # Errors
    /// [`ScaleError::ZeroOutOfRange`] when the unloaded reading is implausible.
    pub fn tared_at(self, code: AdcCode) -> Result<Self, ScaleError> {
        Self::new(code.to_volts(), self.kgf_per_volt)
    }

    /// The same gain, re-zeroed at the mean of `count` unloaded readings whose codes sum to
    /// `sum`, to Q15.16 volts — the self-test's tare: a whole-code mean is off by up to one
    /// code (0.013 kgf), and the tare's error is an offset in every pull until the next boot.
    ///
    /// # Errors
    /// [`ScaleError::ZeroOutOfRange`] when the mean is implausible.
    pub fn tared_at_mean(self, sum: u32, count: u16) -> Result<Self, ScaleError> {
        Self::new(AdcCode::mean_volts(sum, count), self.kgf_per_volt)
    }

    /// Zero-load output.
    #[must_use]
    pub const fn zero(&self) -> Volts {
        self.zero
    }

    /// kgf per volt.
    #[must_use]
    pub const fn kgf_per_volt(&self) -> Q16 {
        self.kgf_per_volt
    }

    /// The tension a converter code stands for, before calibration correction.
    #[must_use]
    pub fn to_kgf(&self, code: AdcCode) -> Kgf {
        Kgf(code.to_volts().0.saturating_sub(self.zero.0).saturating_mul(self.kgf_per_volt))
    }

    /// The code a tension would read as (rounded, clamped to the converter's range); the
    /// inverse of [`LoadCellScale::to_kgf`], used by the twin and by calibration targets.
    #[must_use]
    pub fn to_code(&self, tension: Kgf) -> AdcCode {
        let volts = tension.0.saturating_div(self.kgf_per_volt).saturating_add(self.zero.0);
        AdcCode::from_volts(Volts(volts))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_point_920_mv_is_about_10_kgf_above_zero() {
        let Ok(scale) = LoadCellScale::new(Volts::ZERO, NOMINAL_KGF_PER_VOLT) else {
            panic!("a zero offset with the nominal gain is plausible")
        };
        let code = AdcCode::from_volts(Volts::from_milli(920));
        let kgf = scale.to_kgf(code);
        assert!((kgf.to_milli() - 10_000).abs() < 15, "{kgf:?}");
    }

    #[test]
    fn rejects_implausible_scales() {
        assert_eq!(
            LoadCellScale::new(NOMINAL_ZERO, Q16::from_num(1)),
            Err(ScaleError::GainOutOfRange)
        );
        assert_eq!(
            LoadCellScale::new(Volts::from_int(1), NOMINAL_KGF_PER_VOLT),
            Err(ScaleError::ZeroOutOfRange)
        );
    }

    #[test]
    fn to_code_inverts_to_kgf_within_one_code() {
        let scale = LoadCellScale::NOMINAL;
        for raw in 0..=4095u16 {
            let code = AdcCode::new(raw);
            let back = scale.to_code(scale.to_kgf(code));
            assert!(back.get().abs_diff(raw) <= 1 || raw < 41, "{raw} → {back:?}");
        }
    }
}

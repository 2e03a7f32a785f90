//! The load cell: strain-gauge bridge → amplifier → 12-bit ADC code → volts → kgf.
//!
//! # Theory of operation
//!
//! A thin-film strain gauge on an aluminium bar forms one arm of a Wheatstone bridge (the
//! paper's equation 1) fed from a 9.25 V double-regulated reference; an instrumentation
//! amplifier raises the few-millivolt bridge output to the converter's range. On the paper's
//! board (a 5 V converter) it reads ≈ 920 mV at 10 kgf: a sensitivity of 92 mV/kgf, full
//! scale ≈ 54 kgf, one code 1.22 mV ≈ 0.013 kgf. The converter's reference and the chain's
//! nominal gain and offset are the board's (`crate::board::BoardConfig`); the scale carries
//! its converter, so a code means the same volts wherever it is converted.
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
//! Code → volts is exact on a 5 V converter (one code is 80 Q15.16 bits) and within half a
//! Q15.16 bit on any other ([`AdcReference`]). The subtraction is exact. The single
//! multiplication rounds once, so `|to_kgf(code) − (V(code) − V₀)·k| ≤ 2⁻¹⁶ kgf` against the
//! exact real-number result for the same `V₀` and `k`; `proofs/tests/fixed_point.rs` checks
//! this against a double-precision reference over every code and a proptest sweep of scales.

use crate::units::{AdcCode, AdcReference, Kgf, Q16, Volts};

/// The plausible range of `k` on a 5 V converter: a chain whose full scale (`k × V_ref`) is
/// below 27 kgf cannot measure the machine's tensions with margin, one above 109 kgf gives a
/// code more than 0.027 kgf — mis-wired or mis-configured, not merely uncalibrated. A board
/// with another reference has the same full-scale range: the bounds scale by 5 V / `V_ref`
/// ([`LoadCellScale::gain_range`]).
pub const KGF_PER_VOLT_RANGE: (Q16, Q16) = (Q16::lit("5.4"), Q16::lit("21.8"));

/// The reference [`KGF_PER_VOLT_RANGE`] is stated at, mV.
const GAIN_RANGE_REFERENCE_MV: i64 = 5_000;

/// The plausible range of the zero-load output: 0 V to 0.5 V (≈ 5.4 kgf of offset at the
/// reference board's gain).
pub const ZERO_RANGE: (Volts, Volts) = (Volts(Q16::ZERO), Volts(Q16::lit("0.5")));

/// Why a load-cell scale was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ScaleError {
    /// `k` outside [`KGF_PER_VOLT_RANGE`]: gain wrong by more than a factor of two.
    GainOutOfRange,
    /// Zero-load output outside [`ZERO_RANGE`]: bridge unbalanced, reversed or miswired.
    ZeroOutOfRange,
}

/// The linear ADC → kgf conversion of the load cell, validated at construction: the
/// converter's reference, the zero-load output and the gain.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct LoadCellScale {
    reference: AdcReference,
    zero: Volts,
    kgf_per_volt: Q16,
}

impl LoadCellScale {
    /// A scale on a converter of `reference` with zero-load output `zero` and `kgf_per_volt`.
    ///
    /// # Errors
    /// [`ScaleError`] when either parameter is outside its plausible range.
    pub fn new(
        reference: AdcReference,
        zero: Volts,
        kgf_per_volt: Q16,
    ) -> Result<Self, ScaleError> {
        let (low, high) = Self::gain_range(reference);
        if kgf_per_volt < low || kgf_per_volt > high {
            return Err(ScaleError::GainOutOfRange);
        }
        if zero < ZERO_RANGE.0 || zero > ZERO_RANGE.1 {
            return Err(ScaleError::ZeroOutOfRange);
        }
        Ok(Self { reference, zero, kgf_per_volt })
    }

    /// The plausible gains on a converter of `reference`: [`KGF_PER_VOLT_RANGE`] scaled by
    /// 5 V / `V_ref` (exactly [`KGF_PER_VOLT_RANGE`] at 5 V).
    #[must_use]
    pub fn gain_range(reference: AdcReference) -> (Q16, Q16) {
        let scale = |gain: Q16| {
            let bits = i64::from(gain.to_bits())
                .saturating_mul(GAIN_RANGE_REFERENCE_MV)
                .checked_div(i64::from(reference.millivolts()))
                .unwrap_or(i64::MAX);
            Q16::from_bits(i32::try_from(bits).unwrap_or(i32::MAX))
        };
        (scale(KGF_PER_VOLT_RANGE.0), scale(KGF_PER_VOLT_RANGE.1))
    }

    /// The same converter and gain with the zero-load output at `zero` (a re-zero).
    ///
    /// # Errors
    /// [`ScaleError::ZeroOutOfRange`] when `zero` is implausible.
    pub fn with_zero(self, zero: Volts) -> Result<Self, ScaleError> {
        Self::new(self.reference, zero, self.kgf_per_volt)
    }

    /// The same gain, re-zeroed at the unloaded reading `code` (taring).
    ///
    /// # Errors
    /// [`ScaleError::ZeroOutOfRange`] when the unloaded reading is implausible.
    pub fn tared_at(self, code: AdcCode) -> Result<Self, ScaleError> {
        self.with_zero(self.reference.volts(code))
    }

    /// The same gain, re-zeroed at the mean of `count` unloaded readings whose codes sum to
    /// `sum`, to Q15.16 volts — the self-test's tare: a whole-code mean is off by up to one
    /// code (0.013 kgf), and the tare's error is an offset in every pull until the next boot.
    ///
    /// # Errors
    /// [`ScaleError::ZeroOutOfRange`] when the mean is implausible.
    pub fn tared_at_mean(self, sum: u32, count: u16) -> Result<Self, ScaleError> {
        self.with_zero(self.reference.mean_volts(sum, count))
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

    /// The converter the codes come from.
    #[must_use]
    pub const fn reference(&self) -> AdcReference {
        self.reference
    }

    /// The voltage a code stands for on this scale's converter.
    #[must_use]
    pub fn volts(&self, code: AdcCode) -> Volts {
        self.reference.volts(code)
    }

    /// The tension a converter code stands for, before calibration correction.
    #[must_use]
    pub fn to_kgf(&self, code: AdcCode) -> Kgf {
        Kgf(self
            .reference
            .volts(code)
            .0
            .saturating_sub(self.zero.0)
            .saturating_mul(self.kgf_per_volt))
    }

    /// The code a tension would read as (rounded, clamped to the converter's range); the
    /// inverse of [`LoadCellScale::to_kgf`], used by the twin and by calibration targets.
    #[must_use]
    pub fn to_code(&self, tension: Kgf) -> AdcCode {
        let volts = tension.0.saturating_div(self.kgf_per_volt).saturating_add(self.zero.0);
        self.reference.code(Volts(volts))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's chain on a 5 V converter: 92 mV/kgf, 50 mV offset.
    fn paper() -> LoadCellScale {
        let reference = AdcReference::from_millivolts(5_000).expect("5 V");
        LoadCellScale::new(reference, Volts::from_milli(50), Q16::lit("10.869565")).expect("valid")
    }

    #[test]
    fn paper_point_920_mv_is_about_10_kgf_above_zero() {
        let Ok(scale) = paper().with_zero(Volts::ZERO) else {
            panic!("a zero offset with the nominal gain is plausible")
        };
        let code = scale.reference().code(Volts::from_milli(920));
        let kgf = scale.to_kgf(code);
        assert!((kgf.to_milli() - 10_000).abs() < 15, "{kgf:?}");
    }

    #[test]
    fn rejects_implausible_scales() {
        let reference = paper().reference();
        assert_eq!(
            LoadCellScale::new(reference, paper().zero(), Q16::from_num(1)),
            Err(ScaleError::GainOutOfRange)
        );
        assert_eq!(paper().with_zero(Volts::from_int(1)), Err(ScaleError::ZeroOutOfRange));
    }

    #[test]
    fn the_gain_range_is_the_same_full_scale_on_every_converter() {
        let five = AdcReference::from_millivolts(5_000).expect("5 V");
        assert_eq!(LoadCellScale::gain_range(five), KGF_PER_VOLT_RANGE);
        let three = AdcReference::from_millivolts(3_300).expect("3.3 V");
        let (low, high) = LoadCellScale::gain_range(three);
        assert!((low.to_num::<f64>() * 3.3 - 27.0).abs() < 1e-3, "{low}");
        assert!((high.to_num::<f64>() * 3.3 - 109.0).abs() < 1e-3, "{high}");
        // The paper's gain on a 2 V converter would read only 21.7 kgf at full scale.
        let two = AdcReference::from_millivolts(2_000).expect("2 V");
        assert!(LoadCellScale::new(two, paper().zero(), paper().kgf_per_volt()).is_err());
        assert!(LoadCellScale::new(three, paper().zero(), paper().kgf_per_volt()).is_ok());
        assert!(LoadCellScale::new(three, paper().zero(), Q16::lit("16.4")).is_ok());
    }

    #[test]
    fn to_code_inverts_to_kgf_within_one_code() {
        for millivolts in [3_300, 5_000] {
            let reference = AdcReference::from_millivolts(millivolts).expect("in range");
            let gain = Q16::from_num(54.0 / (f64::from(millivolts) / 1_000.0));
            let scale = LoadCellScale::new(reference, Volts::from_milli(50), gain).expect("valid");
            for raw in 0..=4095u16 {
                let code = AdcCode::new(raw);
                let back = scale.to_code(scale.to_kgf(code));
                assert!(back.get().abs_diff(raw) <= 1 || raw < 62, "{raw} → {back:?}");
            }
        }
    }
}

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
//! # Bounds in kgf, converted once
//!
//! Core holds no board fact, so every bound on the load cell's reading is stated by what it
//! means at the gripper — a tension — and converted to volts at the converter through the
//! board's own scale ([`LoadCellScale::volts_of`]: `ΔV = F / k`), once, where the bound is
//! set up. The zero-load output's plausible band is one: at or above the converter's bottom
//! rail (0 V, a converter fact), and reading as at most [`ZERO_OFFSET_MAX`] of offset. On the
//! paper's chain that is 0.5 V; on a chain divided by 0.656 before a 3.3 V converter it is
//! 0.328 V — the same 5.43 kgf either way. The re-zero's bands follow the same rule
//! (`crate::sense::rezero::RezeroBands`).
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

/// The largest plausible zero-load output, as the tension it reads as: 5.4348 kgf, a tenth of
/// the cell's 54 kgf full scale on the paper's chain (0.5 V there, to the Q15.16 bit). An
/// unloaded cell whose amplifier reads more than this is not merely offset: the bridge is
/// unbalanced or miswired, or a string was loaded at power-up. The band's other end is the
/// converter's bottom rail, 0 V ([`LoadCellScale::zero_range`]).
pub const ZERO_OFFSET_MAX: Kgf = Kgf(Q16::lit("5.4348"));

/// Why a load-cell scale was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ScaleError {
    /// `k` outside [`KGF_PER_VOLT_RANGE`]: gain wrong by more than a factor of two.
    GainOutOfRange,
    /// Zero-load output below the converter's bottom rail or reading as more than
    /// [`ZERO_OFFSET_MAX`] ([`LoadCellScale::zero_range`]): bridge unbalanced, reversed or
    /// miswired.
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
        let (floor, ceiling) = Self::zero_range(kgf_per_volt);
        if zero < floor || zero > ceiling {
            return Err(ScaleError::ZeroOutOfRange);
        }
        Ok(Self { reference, zero, kgf_per_volt })
    }

    /// The plausible zero-load outputs of a chain of `kgf_per_volt`: from the converter's
    /// bottom rail (0 V) to the output that reads as [`ZERO_OFFSET_MAX`] (`5.4348 kgf / k`,
    /// rounded to the nearest Q15.16 bit: 0.5 V on the paper's chain). A gain
    /// [`LoadCellScale::new`] accepts puts the top at most ≈ a fifth of the converter's range
    /// (5.43 kgf over a full scale of at least 27 kgf).
    #[must_use]
    pub fn zero_range(kgf_per_volt: Q16) -> (Volts, Volts) {
        (Volts::ZERO, volts_of(ZERO_OFFSET_MAX, kgf_per_volt))
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

    /// The change of the converter's input that a change of `tension` at the gripper makes
    /// on this chain: `tension / k`, rounded to the nearest Q15.16 bit (half a bit of error),
    /// saturating. How a bound stated in kgf becomes a band in volts on this board.
    #[must_use]
    pub fn volts_of(&self, tension: Kgf) -> Volts {
        volts_of(tension, self.kgf_per_volt)
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

/// `tension / kgf_per_volt` in volts, rounded to the nearest Q15.16 bit (halves away from
/// zero), saturating at the format's range. A gain below one bit (never a valid scale's) is
/// taken as one bit.
fn volts_of(tension: Kgf, kgf_per_volt: Q16) -> Volts {
    let gain = i64::from(kgf_per_volt.to_bits()).max(1);
    let numerator = i64::from(tension.to_bits()).saturating_mul(65_536);
    let half = gain.checked_div(2).unwrap_or(0).saturating_mul(numerator.signum());
    let bits = numerator.saturating_add(half).checked_div(gain).unwrap_or(i64::MAX);
    let saturated = bits.clamp(i64::from(i32::MIN), i64::from(i32::MAX));
    Volts::from_bits(i32::try_from(saturated).unwrap_or(i32::MAX))
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

    /// On the paper's chain the band's top is 0.5 V to the bit, as before the bound was stated
    /// in kgf: 0.5 V is taken, a bit more is not; the converter's bottom rail is the floor.
    #[test]
    fn the_zero_band_is_half_a_volt_on_the_papers_chain() {
        let gain = paper().kgf_per_volt();
        assert_eq!(LoadCellScale::zero_range(gain), (Volts::ZERO, Volts(Q16::lit("0.5"))));
        let half = Volts(Q16::lit("0.5"));
        let bit = Volts::from_bits(1);
        assert!(paper().with_zero(half).is_ok() && paper().with_zero(Volts::ZERO).is_ok());
        assert_eq!(paper().with_zero(half.saturating_add(bit)), Err(ScaleError::ZeroOutOfRange));
        assert_eq!(
            paper().with_zero(Volts::ZERO.saturating_sub(bit)),
            Err(ScaleError::ZeroOutOfRange)
        );
    }

    /// A chain divided by 0.656 before a 3.3 V converter (the firmware's board): its zero band
    /// reads as the same 5.43 kgf of offset, 0.328 V at its pin.
    #[test]
    fn a_divided_chains_zero_band_is_the_same_offset_in_kgf() {
        let divider = Q16::lit("0.656126");
        let three = AdcReference::from_millivolts(3_300).expect("3.3 V");
        let gain = paper().kgf_per_volt().saturating_div(divider);
        let (floor, top) = LoadCellScale::zero_range(gain);
        assert_eq!(floor, Volts::ZERO);
        assert_eq!(top.to_bits(), 21_500, "0.328 V");
        let read = Kgf(top.0.saturating_mul(gain));
        assert!((read.to_bits() - ZERO_OFFSET_MAX.to_bits()).abs() <= 9, "{read:?}");
        let scale = LoadCellScale::new(three, top, gain).expect("the top is plausible");
        assert_eq!(
            scale.with_zero(Volts(top.0.saturating_add(Q16::from_bits(1)))),
            Err(ScaleError::ZeroOutOfRange)
        );
        // The paper's 0.5 V through the divider (0.328 V) is the same offset: at the top.
        let divided_half = Volts(Q16::lit("0.5").saturating_mul(divider));
        assert!((divided_half.to_bits() - top.to_bits()).abs() <= 1, "{divided_half:?}");
    }

    /// `F / k` to the nearest bit, halves away from zero, either sign; saturating; a gain
    /// below one bit taken as one bit.
    #[test]
    fn volts_of_divides_by_the_gain_to_the_nearest_bit() {
        let scale = paper();
        let gain = i64::from(scale.kgf_per_volt().to_bits());
        for bits in [-1_000_000i32, -35_619, -1_068, -1, 0, 1, 5, 6, 1_068, 35_619, 3_000_000] {
            let exact = f64::from(bits) * 65_536.0 / gain as f64;
            let got = scale.volts_of(Kgf::from_bits(bits)).to_bits();
            assert!((f64::from(got) - exact).abs() <= 0.5, "{bits}: {got} vs {exact}");
        }
        // 5.4348 kgf is 32 768.09 bits of volts: rounded down; 0.0163 kgf is 98.26: down;
        // 0.2717 kgf is 1 638.15: down; 0.0544 kgf is 327.98: up.
        assert_eq!(scale.volts_of(Kgf(Q16::lit("0.0544"))).to_bits(), 328);
        assert_eq!(scale.volts_of(Kgf(Q16::lit("-0.0544"))).to_bits(), -328);
        // At 2 kgf/V one bit of kgf is half a bit of volts, at 3 kgf/V a third.
        assert_eq!(volts_of(Kgf::from_bits(1), Q16::from_bits(131_072)).to_bits(), 1, "0.5 → 1");
        assert_eq!(
            volts_of(Kgf::from_bits(-1), Q16::from_bits(131_072)).to_bits(),
            -1,
            "−0.5 → −1"
        );
        assert_eq!(volts_of(Kgf::from_bits(3), Q16::from_bits(131_072)).to_bits(), 2, "1.5 → 2");
        assert_eq!(volts_of(Kgf::from_bits(1), Q16::from_bits(196_608)).to_bits(), 0, "⅓ → 0");
        assert_eq!(volts_of(Kgf::from_bits(2), Q16::from_bits(196_608)).to_bits(), 1, "⅔ → 1");
        assert_eq!(volts_of(Kgf::from_bits(-2), Q16::from_bits(196_608)).to_bits(), -1, "−⅔ → −1");
        // Saturating, and a gain below one bit taken as one bit.
        assert_eq!(volts_of(Kgf::from_int(100), Q16::from_bits(1)), Volts(Q16::MAX));
        assert_eq!(volts_of(Kgf::from_int(-100), Q16::from_bits(1)), Volts(Q16::MIN));
        assert_eq!(volts_of(Kgf::from_bits(3), Q16::ZERO).to_bits(), 3 << 16);
        assert_eq!(volts_of(Kgf::from_bits(-3), Q16::from_bits(-5)).to_bits(), -(3 << 16));
        assert_eq!(volts_of(Kgf(Q16::MAX), Q16::lit("16384")).to_bits(), 131_072);
    }
}

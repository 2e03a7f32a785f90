//! Physical quantities as types: tension, rate, voltage, current, length, ADC codes.
//!
//! Every number that crosses a function boundary in taut carries its unit in its type, so a
//! tension can never be passed where a current is expected and a raw ADC code can never be
//! mistaken for kilograms. The control core does no floating point: every quantity is a
//! fixed-point number from the [`fixed`] crate, and every operation on it **saturates** at the
//! format's limits instead of wrapping or panicking (a saturated tension is a wrong number the
//! fault logic can see; a wrapped one is a wrong number that looks right).
//!
//! # Formats
//!
//! | type | representation | range | resolution |
//! |---|---|---|---|
//! | [`Kgf`] (force, tension) | Q15.16, [`I16F16`] | ±32 768 kgf | 2⁻¹⁶ kgf ≈ 15.3 µkgf |
//! | [`KgfPerSecond`] (tension rate) | Q15.16 | ±32 768 kgf/s | 2⁻¹⁶ kgf/s |
//! | [`Volts`] | Q15.16 | ±32 768 V | 2⁻¹⁶ V ≈ 15.3 µV |
//! | [`Amps`] | Q15.16 | ±32 768 A | 2⁻¹⁶ A ≈ 15.3 µA |
//! | [`Millimeters`] (carriage travel) | Q15.16 | ±32.768 m | 2⁻¹⁶ mm ≈ 15 nm |
//! | [`Seconds`] (controller time constants) | Q15.16 | ±32 768 s | 2⁻¹⁶ s ≈ 15 µs |
//! | [`AdcCode`] | `u16`, 12 significant bits | 0 ..= 4095 | 1 LSB = 5 V / 4096 ≈ 1.22 mV |
//!
//! Q15.16 is chosen because the machine's largest quantities (tension ≤ 60 kgf, rates
//! ≤ ~2 000 kgf/s while the string is hit by the carriage, currents ≤ 30 A) sit three orders
//! of magnitude below the top of the range, while the finest resolution the product needs
//! (0.1 kgf display, 12-bit ADC ≈ 0.013 kgf per LSB) is three orders above the bottom. A
//! product of two Q15.16 numbers is formed exactly in 64 bits and rounded once, so a
//! multiplication loses at most 2⁻¹⁷ of the result's unit.
//!
//! The duty cycle has its own type, [`crate::drive::Duty`], because its bound is a safety
//! property, not a format limit.

use fixed::types::I16F16;

/// The Q15.16 fixed-point format every physical quantity in the core uses.
pub type Q16 = I16F16;

macro_rules! quantity {
    ($(#[$meta:meta])* $name:ident, $unit:literal) => {
        $(#[$meta])*
        #[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Debug)]
        pub struct $name(pub Q16);

        impl $name {
            /// Zero.
            pub const ZERO: Self = Self(Q16::ZERO);
            /// The largest representable value.
            pub const MAX: Self = Self(Q16::MAX);
            /// The most negative representable value.
            pub const MIN: Self = Self(Q16::MIN);

            #[doc = concat!("A whole number of ", $unit, ".")]
            #[must_use]
            #[allow(clippy::cast_lossless, reason = "`i32::from` is not callable in a const fn")]
            pub const fn from_int(value: i16) -> Self {
                // Every i16 is in Q15.16's integer range, so this never saturates.
                Self(Q16::const_from_int(value as i32))
            }

            #[doc = concat!("Thousandths of ", $unit, ", rounded to the nearest 2⁻¹⁶ and saturating at the format's range.")]
            #[must_use]
            pub fn from_milli(milli: i32) -> Self {
                Self(Q16::from_bits(milli_to_bits(milli)))
            }

            #[doc = concat!("The value in thousandths of ", $unit, ", rounded to the nearest (exact for every value of the format).")]
            #[must_use]
            pub fn to_milli(self) -> i32 {
                bits_to_milli(self.0.to_bits())
            }

            /// The raw Q15.16 bits (value × 65 536).
            #[must_use]
            pub const fn to_bits(self) -> i32 {
                self.0.to_bits()
            }

            /// From raw Q15.16 bits (value × 65 536).
            #[must_use]
            pub const fn from_bits(bits: i32) -> Self {
                Self(Q16::from_bits(bits))
            }

            /// Sum, saturating at the format's range.
            #[must_use]
            pub fn saturating_add(self, other: Self) -> Self {
                Self(self.0.saturating_add(other.0))
            }

            /// Difference, saturating at the format's range.
            #[must_use]
            pub fn saturating_sub(self, other: Self) -> Self {
                Self(self.0.saturating_sub(other.0))
            }

            /// Scaled by a dimensionless Q15.16 factor, saturating.
            #[must_use]
            pub fn saturating_scale(self, factor: Q16) -> Self {
                Self(self.0.saturating_mul(factor))
            }

            /// Absolute value (saturating: `MIN.abs() == MAX`).
            #[must_use]
            pub fn abs(self) -> Self {
                Self(self.0.saturating_abs())
            }

            /// Negation (saturating: `-MIN == MAX`).
            #[must_use]
            pub fn saturating_neg(self) -> Self {
                Self(self.0.saturating_neg())
            }

            /// Limited to `[low, high]`; if `low > high` the result is `low`.
            #[must_use]
            pub fn clamp_to(self, low: Self, high: Self) -> Self {
                if self < low {
                    low
                } else if self > high {
                    high
                } else {
                    self
                }
            }
        }
    };
}

quantity!(
    /// A force in kilograms-force (kgf, "kgw" in the paper): string tension, motor pull.
    /// 1 kgf = 9.806 65 N.
    Kgf,
    "kgf"
);
quantity!(
    /// A rate of change of tension, in kgf per second.
    KgfPerSecond,
    "kgf/s"
);
quantity!(
    /// An electric potential in volts.
    Volts,
    "V"
);
quantity!(
    /// An electric current in amperes.
    Amps,
    "A"
);
quantity!(
    /// A length in millimetres (carriage travel, string moved during one pull).
    Millimeters,
    "mm"
);
quantity!(
    /// A duration in seconds, for controller time constants.
    Seconds,
    "s"
);

/// Pounds-force per kilogram-force: 1 kgf = 2.204 622 6 lbf (exact ratio of the kilogram to
/// the avoirdupois pound). Q15.16, error 4 × 10⁻⁶ lbf/kgf.
pub const LBF_PER_KGF: Q16 = Q16::lit("2.2046226");

impl Kgf {
    /// Tenths of a kgf: the panel's set-point unit (`250` → 25.0 kgf).
    #[must_use]
    pub fn from_tenths(tenths: i32) -> Self {
        Self(Q16::from_bits(scaled_to_bits(tenths, 10)))
    }

    /// Hundredths of a kgf: the calibration entry's unit (`2004` → 20.04 kgf).
    #[must_use]
    pub fn from_hundredths(hundredths: i32) -> Self {
        Self(Q16::from_bits(scaled_to_bits(hundredths, 100)))
    }

    /// The tension in hundredths of a kgf, rounded to the nearest (half away from zero).
    #[must_use]
    pub fn to_hundredths_rounded(self) -> i32 {
        round_scaled(self.0, 100)
    }

    /// The tension in tenths of a kgf, rounded to the nearest tenth (half away from zero).
    #[must_use]
    pub fn to_tenths_rounded(self) -> i32 {
        round_scaled(self.0, 10)
    }

    /// The tension in tenths of a pound-force, rounded to the nearest tenth.
    #[must_use]
    pub fn to_lbf_tenths_rounded(self) -> i32 {
        round_scaled(self.0.saturating_mul(LBF_PER_KGF), 10)
    }

    /// A tension given in tenths of a pound-force.
    #[must_use]
    pub fn from_lbf_tenths(lbf_tenths: i32) -> Self {
        let lbf = Q16::from_bits(scaled_to_bits(lbf_tenths, 10));
        Self(lbf.saturating_div(LBF_PER_KGF))
    }
}

/// `value / denominator` as Q15.16 bits (`value × 65 536 / denominator`), rounded half away
/// from zero, computed in 64 bits and saturated to the format's range. `denominator` is a
/// positive constant at every call site (10 or 1000).
fn scaled_to_bits(value: i32, denominator: i64) -> i32 {
    let scaled = i64::from(value).saturating_mul(65_536);
    let half = denominator.checked_div(2).unwrap_or(0);
    let nudged =
        if scaled >= 0 { scaled.saturating_add(half) } else { scaled.saturating_sub(half) };
    let rounded = nudged.checked_div(denominator).unwrap_or(0);
    i32::try_from(rounded).unwrap_or(if rounded < 0 { i32::MIN } else { i32::MAX })
}

/// Thousandths → Q15.16 bits, rounded to nearest and saturating.
fn milli_to_bits(milli: i32) -> i32 {
    scaled_to_bits(milli, 1000)
}

/// Q15.16 bits → thousandths, rounded to the nearest (ties up). |bits| ≤ 2³¹ gives
/// |result| ≤ 32 768 000, which always fits an `i32`.
fn bits_to_milli(bits: i32) -> i32 {
    let milli = i64::from(bits).saturating_mul(1000).saturating_add(32_768).div_euclid(65_536);
    i32::try_from(milli).unwrap_or(if milli < 0 { i32::MIN } else { i32::MAX })
}

/// `value × scale`, rounded to the nearest integer, half away from zero, computed in 64 bits
/// and saturated to `i32` (the fixed crate's `round` would overflow at the top of the range).
fn round_scaled(value: Q16, scale: i32) -> i32 {
    let product = i64::from(value.to_bits()).saturating_mul(i64::from(scale));
    let magnitude = product.unsigned_abs().saturating_add(32_768).checked_div(65_536).unwrap_or(0);
    let rounded = i64::try_from(magnitude).unwrap_or(i64::MAX);
    let signed = if product < 0 { rounded.saturating_neg() } else { rounded };
    i32::try_from(signed).unwrap_or(if signed < 0 { i32::MIN } else { i32::MAX })
}

/// Number of bits the ADC converts: the paper runs the dsPIC's converter as 12-bit, and the
/// STM32G4's converters are 12-bit too.
pub const ADC_BITS: u32 = 12;
/// The largest code the 12-bit converter returns.
pub const ADC_MAX_CODE: u16 = 4095;

/// The range of converter references a board may have, mV: 1.0 V (the lowest a 12-bit
/// converter is specified down to) to 5.5 V (above any supply a logic part takes).
pub const ADC_REFERENCE_RANGE_MV: (u16, u16) = (1_000, 5_500);

/// The reference voltage of a board's 12-bit converter: what a code means in volts.
///
/// One code is `V_ref / 4096`; in Q15.16 volt bits that is `V_ref[mV] × 65 536 / 4 096 000`
/// = `V_ref[mV] × 2 / 125`, so a 5 V reference gives exactly 80 bits a code and every
/// conversion below is exact; any other reference rounds once, to the nearest bit
/// (1.5 × 10⁻⁵ V, under a hundredth of a code).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct AdcReference {
    millivolts: u16,
}

impl AdcReference {
    /// A converter whose full scale is `millivolts`; `None` outside
    /// [`ADC_REFERENCE_RANGE_MV`].
    #[must_use]
    pub const fn from_millivolts(millivolts: u16) -> Option<Self> {
        if millivolts < ADC_REFERENCE_RANGE_MV.0 || millivolts > ADC_REFERENCE_RANGE_MV.1 {
            None
        } else {
            Some(Self { millivolts })
        }
    }

    /// The reference, mV.
    #[must_use]
    pub const fn millivolts(self) -> u16 {
        self.millivolts
    }

    /// The input voltage a code stands for: `code × V_ref / 4096`, rounded to Q15.16.
    #[must_use]
    pub fn volts(self, code: AdcCode) -> Volts {
        // One product and a shift: the bits a code carries, in Q16 (`V_ref[mV] × 2 / 125`,
        // rounded: exactly 80 × 2¹⁶ at 5 V, so a 5 V code converts exactly; elsewhere the
        // per-code error is under 2⁻¹⁷ bit, under 0.04 bit over the whole range).
        let per_code = u64::from(self.millivolts)
            .saturating_mul(2 << 16)
            .saturating_add(62)
            .checked_div(125)
            .unwrap_or(0);
        let bits = u64::from(code.get()).saturating_mul(per_code).saturating_add(1 << 15) >> 16;
        Volts::from_bits(i32::try_from(bits).unwrap_or(i32::MAX))
    }

    /// The mean input voltage of `count` conversions whose codes sum to `sum`, rounded to
    /// Q15.16 (1.5 × 10⁻⁵ V): finer than one code, so an average over many noisy readings
    /// keeps the fraction a whole-code mean would drop. `count` 0 reads as 1.
    #[must_use]
    pub fn mean_volts(self, sum: u32, count: u16) -> Volts {
        // bits = sum × mV × 2 / (125 × count), rounded half up; ≤ 2³² × 5 500 × 2 fits a u64.
        let divisor = u64::from(count.max(1)).saturating_mul(125);
        let bits = u64::from(sum)
            .saturating_mul(u64::from(self.millivolts))
            .saturating_mul(2)
            .saturating_add(divisor / 2)
            .checked_div(divisor)
            .unwrap_or(0);
        Volts::from_bits(i32::try_from(bits).unwrap_or(i32::MAX))
    }

    /// The code a voltage converts to (rounded to nearest, clamped to 0 ..= 4095): the
    /// inverse of [`AdcReference::volts`], used by the digital twin and by tests.
    #[must_use]
    pub fn code(self, volts: Volts) -> AdcCode {
        // code = bits × 125 / (2 × mV), rounded half up; negative voltages read 0.
        let bits = u64::try_from(volts.to_bits().max(0)).unwrap_or(0);
        let divisor = u64::from(self.millivolts).saturating_mul(2).max(1);
        let code =
            bits.saturating_mul(125).saturating_add(divisor / 2).checked_div(divisor).unwrap_or(0);
        AdcCode::new(u16::try_from(code.min(u64::from(ADC_MAX_CODE))).unwrap_or(ADC_MAX_CODE))
    }
}

/// A 12-bit analogue-to-digital converter reading, 0 ..= 4095.
///
/// The constructor masks to 12 bits' range by saturation, so a value of this type is always a
/// code the converter could have produced.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Debug)]
pub struct AdcCode(u16);

impl AdcCode {
    /// The lowest code (input at or below 0 V).
    pub const MIN: Self = Self(0);
    /// The highest code (input at or above the reference).
    pub const MAX: Self = Self(ADC_MAX_CODE);

    /// A converter reading; values above 4095 saturate to 4095 (a converter cannot produce
    /// them, so an out-of-range raw value means a wiring or driver fault that reads as
    /// full scale, which the load-cell checks flag as a short).
    #[must_use]
    pub const fn new(raw: u16) -> Self {
        if raw > ADC_MAX_CODE { Self(ADC_MAX_CODE) } else { Self(raw) }
    }

    /// The raw code.
    #[must_use]
    pub const fn get(self) -> u16 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FIVE_VOLTS: AdcReference = match AdcReference::from_millivolts(5_000) {
        Some(reference) => reference,
        None => panic!("5 V is a converter reference"),
    };

    #[test]
    fn mean_volts_keeps_the_fraction_of_a_code() {
        // 100 readings, 37 of 41 and 63 of 42: 41.63 codes, not 41.
        let mean = FIVE_VOLTS.mean_volts(37 * 41 + 63 * 42, 100);
        assert_eq!(mean.to_bits(), (4_163 * 80 + 50) / 100);
        assert_eq!(FIVE_VOLTS.mean_volts(41 * 64, 64), FIVE_VOLTS.volts(AdcCode::new(41)));
        assert_eq!(FIVE_VOLTS.mean_volts(7, 0), FIVE_VOLTS.volts(AdcCode::new(7)));
        assert_eq!(FIVE_VOLTS.mean_volts(u32::MAX, 1).to_bits(), i32::MAX);
        // Rounded to the nearest bit: 124 × 80 / 3 = 3 306.67.
        assert_eq!(FIVE_VOLTS.mean_volts(41 + 41 + 42, 3).to_bits(), 3_307);
    }

    #[test]
    fn a_code_of_another_reference_is_its_volts_rounded_to_the_bit() {
        // 3.3 V: 52.8 bits a code; the fraction of `code × 52.8` is a multiple of 0.2, so the
        // nearest bit is `(code × 528 + 5) / 10` exactly.
        let reference = AdcReference::from_millivolts(3_300).expect("in range");
        for raw in 0..=ADC_MAX_CODE {
            let expected = (i32::from(raw) * 528 + 5) / 10;
            assert_eq!(reference.volts(AdcCode::new(raw)).to_bits(), expected, "code {raw}");
        }
    }

    #[test]
    fn adc_code_saturates_to_twelve_bits() {
        assert_eq!(AdcCode::new(5000).get(), 4095);
        assert_eq!(AdcCode::new(4095).get(), 4095);
        assert_eq!(AdcCode::new(0).get(), 0);
    }

    #[test]
    fn a_five_volt_code_is_exactly_eighty_bits() {
        for raw in 0..=ADC_MAX_CODE {
            let code = AdcCode::new(raw);
            assert_eq!(FIVE_VOLTS.volts(code).to_bits(), i32::from(raw) * 80, "code {raw}");
        }
    }

    #[test]
    fn adc_volts_round_trip_is_exact_for_every_code_and_reference() {
        for millivolts in [1_000, 1_800, 2_048, 2_500, 3_000, 3_300, 4_096, 5_000, 5_500] {
            let reference = AdcReference::from_millivolts(millivolts).expect("in range");
            for raw in 0..=ADC_MAX_CODE {
                let code = AdcCode::new(raw);
                assert_eq!(reference.code(reference.volts(code)), code, "{millivolts} mV {raw}");
            }
            let code = reference.code(Volts::from_milli(i32::from(millivolts) / 2));
            assert_eq!(code, AdcCode::new(2_048), "half the reference is mid-scale");
        }
        assert_eq!(FIVE_VOLTS.code(Volts::from_int(-1)), AdcCode::MIN);
        assert_eq!(FIVE_VOLTS.code(Volts::from_int(6)), AdcCode::MAX);
    }

    #[test]
    fn a_reference_outside_the_range_is_refused() {
        assert_eq!(AdcReference::from_millivolts(999), None);
        assert_eq!(AdcReference::from_millivolts(5_501), None);
        assert_eq!(AdcReference::from_millivolts(1_000).map(AdcReference::millivolts), Some(1_000));
        assert_eq!(AdcReference::from_millivolts(5_500).map(AdcReference::millivolts), Some(5_500));
    }

    #[test]
    fn tenths_round_trip() {
        for tenths in -600..=600 {
            assert_eq!(Kgf::from_tenths(tenths).to_tenths_rounded(), tenths);
        }
    }

    #[test]
    fn pounds_round_trip_within_half_a_tenth() {
        // 25.0 kgf = 55.1 lbf (PicoBETH and every stringer show this pair).
        assert_eq!(Kgf::from_tenths(250).to_lbf_tenths_rounded(), 551);
        for lbf_tenths in 100..=1100 {
            let back = Kgf::from_lbf_tenths(lbf_tenths).to_lbf_tenths_rounded();
            assert_eq!(back, lbf_tenths);
        }
    }

    #[test]
    fn tenths_conversions_saturate_instead_of_panicking() {
        assert_eq!(Kgf::from_tenths(i32::MAX), Kgf::MAX);
        assert_eq!(Kgf::from_tenths(i32::MIN), Kgf::MIN);
        assert_eq!(Kgf::from_tenths(500_000).to_tenths_rounded(), 327_680);
        assert_eq!(Kgf::MAX.to_tenths_rounded(), 327_680);
        assert_eq!(Kgf::MIN.to_tenths_rounded(), -327_680);
        assert_eq!(Kgf::MAX.to_lbf_tenths_rounded(), 327_680, "lbf saturates at the format's top");
        assert!(Kgf::from_lbf_tenths(i32::MAX) > Kgf::from_int(14_000));
        assert!(Kgf::from_lbf_tenths(i32::MIN) < Kgf::from_int(-14_000));
    }

    #[test]
    fn milli_conversions_cover_the_whole_range() {
        assert_eq!(Kgf::from_milli(50_000).to_milli(), 50_000, "50 kgf must not panic or clip");
        assert_eq!(Kgf::from_milli(-50_000).to_milli(), -50_000);
        assert_eq!(Kgf::from_milli(i32::MAX), Kgf::MAX);
        assert_eq!(Kgf::from_milli(i32::MIN), Kgf::MIN);
        assert_eq!(Kgf::MAX.to_milli(), 32_768_000);
        assert_eq!(Kgf::MIN.to_milli(), -32_768_000);
        for milli in (-40_000_000..=40_000_000).step_by(9_973) {
            let back = Kgf::from_milli(milli).to_milli();
            let expected = milli.clamp(-32_768_000, 32_768_000);
            assert!((back - expected).abs() <= 1, "{milli} → {back}");
        }
    }

    #[test]
    fn saturating_arithmetic_never_wraps() {
        assert_eq!(Kgf::MAX.saturating_add(Kgf::from_int(1)), Kgf::MAX);
        assert_eq!(Kgf::MIN.saturating_sub(Kgf::from_int(1)), Kgf::MIN);
        assert_eq!(Kgf::MIN.abs(), Kgf::MAX);
        assert_eq!(Kgf::MIN.saturating_neg(), Kgf::MAX);
    }
}

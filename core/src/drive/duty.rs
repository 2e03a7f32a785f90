//! The PWM duty cycle, bounded by construction.
//!
//! # Why 95 %
//!
//! The high-side MOSFETs' gate drive comes from bootstrap capacitors that recharge only while
//! the leg's low side (or the phase's freewheel path) pulls the switch node to ground, i.e.
//! during the off part of each PWM period. At 100 % duty they never recharge and the high side
//! droops out of saturation into linear mode and overheats. VESC and ODrive both cap the duty
//! at 0.95; so does taut. [`Duty`] has a private field and every constructor clamps to
//! [`DUTY_MAX`], so a duty above the cap is not a value the program can hold.
//!
//! The format is an unsigned fraction of the PWM period with 16 fractional bits
//! (`U0F16`-like: value = raw / 65 536), resolution 1.5 × 10⁻⁵ of the period — far finer than
//! a timer's own resolution (taut's board: 1 / 8 500, 20 kHz from 170 MHz;
//! [`Duty::compare_ticks`] takes the period the board counts).

use crate::units::Q16;

/// The largest duty taut ever applies: 62 259 / 65 536 = 0.949 997 of the PWM period.
pub const DUTY_MAX: Duty = Duty(62_259);

/// The denominator of the duty's raw value: a duty of `raw` is `raw / 65 536` of the period.
pub const DUTY_ONE: u32 = 65_536;

/// A PWM duty cycle in `[0, DUTY_MAX]`.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct Duty(u16);

impl Duty {
    /// Zero duty: the high side never conducts.
    pub const ZERO: Self = Self(0);

    /// A duty of `raw / 65 536` of the period, clamped to [`DUTY_MAX`].
    #[must_use]
    pub const fn from_raw_clamped(raw: u16) -> Self {
        if raw > DUTY_MAX.0 { DUTY_MAX } else { Self(raw) }
    }

    /// A duty from a Q15.16 fraction of the period (`1.0` = 100 %), clamped to
    /// `[0, DUTY_MAX]`; negative requests give zero.
    #[must_use]
    pub fn from_fraction_clamped(fraction: Q16) -> Self {
        // Q15.16 bits of a fraction are exactly the duty's raw scale (2⁻¹⁶).
        let bits = fraction.to_bits().clamp(0, i32::from(DUTY_MAX.0));
        Self(u16::try_from(bits).unwrap_or(DUTY_MAX.0))
    }

    /// The raw value, `0 ..= 62 259`.
    #[must_use]
    pub const fn raw(self) -> u16 {
        self.0
    }

    /// The duty as a Q15.16 fraction of the period.
    #[must_use]
    pub fn fraction(self) -> Q16 {
        Q16::from_bits(i32::from(self.0))
    }

    /// The compare value for a PWM timer whose period is `period_ticks`, rounded down:
    /// `period × raw / 65 536`. Never exceeds `period × 0.95`.
    #[must_use]
    pub fn compare_ticks(self, period_ticks: u16) -> u16 {
        // u16 × u16 fits a u32; dividing by 65 536 brings it back below `period_ticks`.
        let product = u32::from(period_ticks).saturating_mul(u32::from(self.0));
        u16::try_from(product.checked_div(DUTY_ONE).unwrap_or(0)).unwrap_or(0)
    }

    /// Whether the duty is zero.
    #[must_use]
    pub const fn is_zero(self) -> bool {
        self.0 == 0
    }

    /// The duty's invariant, for proofs: never above [`DUTY_MAX`].
    #[must_use]
    pub const fn is_valid(self) -> bool {
        self.0 <= DUTY_MAX.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_raw_value_clamps_to_the_cap() {
        for raw in 0..=u16::MAX {
            let duty = Duty::from_raw_clamped(raw);
            assert!(duty.is_valid());
            assert_eq!(duty.raw(), raw.min(DUTY_MAX.raw()));
        }
    }

    #[test]
    fn cap_is_just_below_95_percent() {
        // 0.95 × 65 536 = 62 259.2
        assert!(u32::from(DUTY_MAX.raw()) * 100 <= 95 * DUTY_ONE);
        assert!(u32::from(DUTY_MAX.raw() + 1) * 100 > 95 * DUTY_ONE);
    }

    #[test]
    fn compare_ticks_never_exceed_95_percent_of_any_period() {
        for period in [1u16, 100, 8_500, u16::MAX] {
            for raw in [0u16, 1, 32_768, DUTY_MAX.raw(), u16::MAX] {
                let ticks = Duty::from_raw_clamped(raw).compare_ticks(period);
                assert!(u32::from(ticks) * 100 <= 95 * u32::from(period), "{period} {raw}");
            }
        }
    }

    #[test]
    fn fractions_clamp() {
        assert_eq!(Duty::from_fraction_clamped(Q16::from_num(-1)), Duty::ZERO);
        assert_eq!(Duty::from_fraction_clamped(Q16::from_num(2)), DUTY_MAX);
        assert_eq!(Duty::from_fraction_clamped(Q16::from_bits(32_768)).raw(), 32_768);
    }
}

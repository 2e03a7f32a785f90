//! Motor current sensing: the DC-link shunt amplifier's ADC code → amperes.
//!
//! # Theory of operation
//!
//! In six-step drive exactly two phases conduct, in series, so the current through the DC-link
//! (bus) shunt during the PWM on-time *is* the winding current. taut's current chain is a
//! low-side bus shunt and an amplifier giving [`VOLTS_PER_AMP`] into the same 12-bit, 5 V
//! converter as the load cell (the paper's IMOTOR input), so 0 ..= 4095 spans 0 ..= 25 A and
//! one code is 6.1 mA. The same current also feeds a hardware comparator (the paper's
//! overcurrent protection circuit; the STM32G4's COMP → TIM1 break input) that switches the
//! bridge off without software; the drive latches its flag (see
//! [`crate::drive::DriveFault::OvercurrentTrip`]).

use crate::units::{AdcCode, Amps, Q16};

/// Current-sense gain: 0.2 V per ampere (e.g. 10 mΩ shunt × 20 amplifier gain).
pub const VOLTS_PER_AMP: Q16 = Q16::lit("0.2");

/// One code in Q15.16 ampere bits: 5 V / 4 096 codes / 0.2 V/A × 65 536 = 400.
const AMPS_BITS_PER_CODE: i32 = 400;

/// The current a converter code stands for: `volts / VOLTS_PER_AMP`, exact in Q15.16
/// (one code is 80 × 5 = 400 bits of an ampere).
#[must_use]
pub fn amps(code: AdcCode) -> Amps {
    // code ≤ 4095, so the product ≤ 1 638 000 fits an i32.
    Amps(Q16::from_bits(i32::from(code.get()).saturating_mul(AMPS_BITS_PER_CODE)))
}

/// The lowest converter code that reads as at least `limit`: `⌈limit × VOLTS_PER_AMP × 4096 / 5⌉`,
/// or `None` when even full scale reads below `limit`. Comparing codes against this threshold
/// is equivalent to comparing [`amps`] against `limit`, without a multiplication in the fast
/// path.
#[must_use]
pub fn threshold_code(limit: Amps) -> Option<AdcCode> {
    // amps(code) = code × 400 bits, so code ≥ limit_bits / 400, rounded up.
    let bits = limit.to_bits().max(0);
    let code = bits.saturating_add(399) / 400;
    u16::try_from(code).ok().filter(|&code| code <= AdcCode::MAX.get()).map(AdcCode::new)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_scale_is_25_amps() {
        assert_eq!(amps(AdcCode::new(0)), Amps::ZERO);
        // 4095 codes × 5 V / 4096 / 0.2 V/A = 24.9939 A
        assert_eq!(amps(AdcCode::MAX).to_milli(), 24_994);
    }

    #[test]
    fn threshold_code_matches_the_conversion() {
        for limit_milli in (0..=26_000).step_by(7) {
            let limit = Amps::from_milli(limit_milli);
            let threshold = threshold_code(limit);
            for raw in 0..=4095u16 {
                let code = AdcCode::new(raw);
                let trips = threshold.is_some_and(|threshold| code >= threshold);
                assert_eq!(trips, amps(code) >= limit, "{limit_milli} mA, {raw}");
            }
        }
    }
}

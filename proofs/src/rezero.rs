//! The re-zero at rest's rule (REQ-ID-08), as one property: from any valid state, one tick
//! keeps the state valid, and a zero it accepts is within its bounds of the zero in use and
//! of the self-test's tare, taken only at rest. The bounds are the rule's own bands, in volts
//! on its board's chain (`RezeroBands::for_scale`: the kgf bounds through the board's gain);
//! the Kani harness checks the property for every valid state, its bands any a board can have
//! (0–5.5 V each: every board's, and more), and every input on the paper's 5 V converter (the converter only
//! turns codes into the volts the bands are compared with; the bounds follow from the
//! comparisons whatever those volts are); `proofs/tests/rezero.rs` along random and
//! adversarial sequences from power-up, on the paper's chain and on a divided chain on a
//! 3.3 V converter.

use taut_core::sense::rezero::{DRIFT_PERIODS_MAX, RestSample, Retare, Rezero};
use taut_core::units::{AdcReference, Volts};

/// `|a − b|`, bits.
fn distance(a: Volts, b: Volts) -> u32 {
    a.to_bits().abs_diff(b.to_bits())
}

/// REQ-ID-08: one tick of the rule from the valid state `rule` with `sample`, the zero in
/// use `zero` and the converter `converter`. Returns the verdict.
pub fn rezero_step_bounded(
    rule: &mut Rezero,
    sample: &RestSample,
    zero: Volts,
    converter: AdcReference,
) -> Option<Retare> {
    assert!(rule.is_valid(), "REQ-ID-08: the property starts from a valid state");
    let reference = rule.reference();
    let bands = rule.bands();
    // The step a re-zero may take: the bands' step plus the zero's drift rate for the time
    // since the zero in use was taken (none when that is not known), at most the range.
    let age_ms = rule.zero_at().map_or(0, |at| sample.now_ms.wrapping_sub(at));
    // Whole periods of 1.024 s, at most DRIFT_PERIODS_MAX (10 bits); a valid band is at most
    // 5.5 V (19 bits): their product and the sum fit an i32 exactly.
    let periods = i32::try_from((age_ms >> 10).min(DRIFT_PERIODS_MAX)).unwrap_or(i32::MAX);
    let drift = bands.drift_rate().to_bits().wrapping_mul(periods);
    let step = i64::from(
        bands
            .step_max()
            .to_bits()
            .saturating_add(drift)
            .min(bands.range().to_bits().max(bands.step_max().to_bits())),
    );
    let verdict = rule.observe(sample, zero, converter);
    assert!(rule.is_valid(), "REQ-ID-08: the re-zero state stays valid");
    assert_eq!(rule.reference(), reference, "REQ-ID-08: the reference is the self-test's");
    assert_eq!(rule.bands(), bands, "REQ-ID-08: the bands are the board's");
    if let Some(Retare::Zero(new)) = verdict {
        assert!(
            i64::from(distance(new, zero)) <= step,
            "REQ-ID-08: a re-zero moves the zero by at most the step and the drift since"
        );
        assert_eq!(rule.zero_at(), Some(sample.now_ms), "REQ-ID-08: the new zero's time");
        assert!(
            i64::from(distance(new, reference)) <= i64::from(bands.range().to_bits()),
            "REQ-ID-08: a re-zero stays within the range of the self-test's tare"
        );
        assert!(
            sample.home && !sample.end && !sample.key,
            "REQ-ID-08: a re-zero is taken only at rest at home, untouched"
        );
    }
    verdict
}

#[cfg(kani)]
mod verification {
    use super::*;
    use taut_core::units::AdcCode;

    /// REQ-ID-08 for every valid state (its bands any a board can have, 0–5.5 V each: every
    /// board's, and more), every sample and every zero in use, on the paper's converter.
    #[kani::proof]
    #[kani::unwind(7)]
    fn verify_rezero_step_bounded() {
        let mut rule: Rezero = kani::any();
        kani::assume(rule.is_valid());
        let sample = RestSample {
            home: kani::any(),
            end: kani::any(),
            steps: kani::any(),
            key: kani::any(),
            code: AdcCode::new(kani::any()),
            now_ms: kani::any(),
        };
        let zero = Volts::from_bits(kani::any());
        let verdict = rezero_step_bounded(&mut rule, &sample, zero, crate::FIVE_VOLTS);
        // The accepting path is reachable (a harness that could only refuse would prove the
        // bounds vacuously).
        let accepted = matches!(verdict, Some(Retare::Zero(_)));
        kani::cover!(accepted, "a re-zero is accepted");
        crate::harness_end_reached();
    }
}

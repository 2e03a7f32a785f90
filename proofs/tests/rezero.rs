//! The re-zero at rest's rule (REQ-ID-08) under `cargo test`: proptest along sequences from
//! power-up — spells at rest with a drifting, noisy, humming, loaded or pushed load cell,
//! broken by keys, motion and leaving home — with the zero in use following every accepted
//! re-zero as the machine's does, on the paper's chain (92 mV/kgf, 5 V converter) and on the
//! firmware's kind (the same amplifier divided by 0.656 into a 3.3 V converter), each with
//! the bands its own scale gives; the range is checked in kgf through that scale.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::expect_used,
    reason = "test bookkeeping on small counts; a panic fails the test, as it should"
)]

use proptest::prelude::*;
use taut_core::board::{PAPER_KGF_PER_VOLT, PAPER_LOAD_CELL_ZERO};
use taut_core::sense::load_cell::LoadCellScale;
use taut_core::sense::rezero::{REZERO_RANGE, RestSample, Retare, Rezero, RezeroBands};
use taut_core::units::{AdcCode, AdcReference, Q16, Volts};
use taut_proofs::rezero::rezero_step_bounded;

/// The paper's chain, or (`divided`) the same amplifier through a 33.2 kΩ / (17.4 + 33.2) kΩ
/// divider into a 3.3 V converter.
fn scale(divided: bool) -> LoadCellScale {
    if divided {
        let divider = Q16::lit("0.656126");
        let reference = AdcReference::from_millivolts(3_300).expect("3.3 V");
        let zero = Volts(PAPER_LOAD_CELL_ZERO.0.saturating_mul(divider));
        LoadCellScale::new(reference, zero, PAPER_KGF_PER_VOLT.saturating_div(divider))
            .expect("the divided chain is plausible")
    } else {
        LoadCellScale::new(taut_proofs::FIVE_VOLTS, PAPER_LOAD_CELL_ZERO, PAPER_KGF_PER_VOLT)
            .expect("the paper's chain is plausible")
    }
}

/// One spell of a sequence.
#[derive(Clone, Debug)]
struct Spell {
    ticks: u32,
    /// The load cell's code at the start of the spell ×16 (a fraction of a code).
    base_sixteenths: u32,
    /// Drift over the spell, 1/16 codes (signed).
    drift_sixteenths: i32,
    /// Noise amplitude, codes.
    noise: u16,
    /// A wander of this many codes with period `wander_ms` (a hand), 0: none.
    wander: u16,
    wander_ms: u32,
    /// The spell breaks the rest every `break_every` ticks (0: never) with a key, motion or
    /// leaving home in turn.
    break_every: u32,
}

fn spell() -> impl Strategy<Value = Spell> {
    (
        1u32..4_000,
        (20u32 * 16)..(120 * 16),
        -64i32..64,
        0u16..4,
        prop_oneof![Just(0u16), 1u16..12],
        50u32..1_000,
        prop_oneof![Just(0u32), 1u32..5_000],
    )
        .prop_map(|(ticks, base, drift, noise, wander, wander_ms, break_every)| Spell {
            ticks,
            base_sixteenths: base,
            drift_sixteenths: drift,
            noise,
            wander,
            wander_ms,
            break_every,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// REQ-ID-08 along whole sequences from the self-test's tare, on either board.
    #[test]
    fn rezero_step_bounded_along_sequences(
        spells in proptest::collection::vec(spell(), 1..6),
        tare in 20u16..120,
        seed in any::<u64>(),
        divided in any::<bool>(),
    ) {
        let scale = scale(divided);
        let converter = scale.reference();
        let reference = scale.volts(AdcCode::new(tare));
        let mut rule = Rezero::new(reference, RezeroBands::for_scale(&scale));
        // The range in kgf, and what half a bit of volts reads as (the bands' rounding).
        let range = i64::from(REZERO_RANGE.to_bits()) << 16;
        let gain = i64::from(scale.kgf_per_volt().to_bits());
        let mut zero = reference;
        let mut rng = seed | 1;
        let mut steps = 0i32;
        let mut now_ms = 0u32;
        for spell in &spells {
            for t in 0..spell.ticks {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                let drift = i64::from(spell.drift_sixteenths) * i64::from(t) / i64::from(spell.ticks);
                let wander = if spell.wander > 0 && (t / spell.wander_ms) % 2 == 1 {
                    i64::from(spell.wander)
                } else {
                    0
                };
                let noise = if spell.noise > 0 {
                    (rng % (2 * u64::from(spell.noise) + 1)) as i64 - i64::from(spell.noise)
                } else {
                    0
                };
                let code = (i64::from(spell.base_sixteenths) + drift) / 16 + wander + noise;
                let broken = spell.break_every > 0 && t % spell.break_every == 0;
                let kind = (t / spell.break_every.max(1)) % 3;
                if broken && kind == 1 {
                    steps += 1;
                }
                let sample = RestSample {
                    home: !(broken && kind == 2),
                    end: false,
                    steps,
                    key: broken && kind == 0,
                    code: AdcCode::new(code.clamp(0, 4_095) as u16),
                    now_ms,
                };
                now_ms = now_ms.wrapping_add(1);
                if let Some(Retare::Zero(new)) =
                    rezero_step_bounded(&mut rule, &sample, zero, converter)
                {
                    zero = new;
                }
                // However the zero was walked, it never leaves the range: in volts on this
                // chain, and in kgf through its gain (to the band's half bit).
                let from_tare = (i64::from(zero.to_bits()) - i64::from(reference.to_bits())).abs();
                prop_assert!(from_tare <= i64::from(rule.bands().range().to_bits()));
                prop_assert!(2 * (from_tare * gain - range) <= gain, "{from_tare} bits");
            }
        }
    }
}

/// A steady unloaded cell drifting slowly is followed to within a code.
#[test]
fn rezero_follows_a_slow_drift() {
    let scale = scale(false);
    let reference: Volts = taut_proofs::FIVE_VOLTS.volts(AdcCode::new(41));
    let mut rule = Rezero::new(reference, RezeroBands::for_scale(&scale));
    let mut zero = reference;
    // 20 codes over 100 s at rest.
    for t in 0..100_000u32 {
        let code = AdcCode::new(41 + (t / 5_000) as u16);
        let sample = RestSample { home: true, end: false, steps: 0, key: false, code, now_ms: 0 };
        if let Some(Retare::Zero(new)) =
            rezero_step_bounded(&mut rule, &sample, zero, taut_proofs::FIVE_VOLTS)
        {
            zero = new;
        }
    }
    let last = taut_proofs::FIVE_VOLTS.volts(AdcCode::new(60));
    assert!(
        (zero.to_bits() - last.to_bits()).abs()
            <= taut_proofs::FIVE_VOLTS.volts(AdcCode::new(1)).to_bits()
    );
}

//! The fixed-point foundation (`REQ-FXP-*`) against its `f64` reference: exhaustive over every
//! ADC code, proptest over the whole Q15.16 range and every valid load-cell scale.
#![allow(clippy::arithmetic_side_effects, reason = "test bookkeeping on small counts")]

mod common;

use proptest::prelude::*;
use taut_core::sense::load_cell::{KGF_PER_VOLT_RANGE, LoadCellScale};
use taut_core::units::Q16;
use taut_proofs::fixed_point::{
    adc_volts_exact, current_amps_exact, load_cell_within_bound, panel_units_round_trip,
    saturating_ops_within_bound, unit_conversions_total,
};

#[test]
fn every_adc_code_converts_exactly() {
    for raw in 0..=u16::MAX {
        adc_volts_exact(raw);
        current_amps_exact(raw);
    }
    println!("every_adc_code_converts_exactly: 65 536 raw codes (4 096 distinct) × 2 conversions");
}

#[test]
fn panel_units_every_value() {
    for tenths in i16::MIN..=i16::MAX {
        panel_units_round_trip(tenths);
    }
    println!("panel_units_every_value: 65 536 cases");
}

#[test]
fn load_cell_every_code_nominal_and_extreme_scales() {
    let mut cases = 0u32;
    let gains = [KGF_PER_VOLT_RANGE.0.to_bits(), 712_348, KGF_PER_VOLT_RANGE.1.to_bits()];
    for gain in gains {
        // The zero band's ends on this gain (its top reads as `ZERO_OFFSET_MAX`).
        let (floor, top) = LoadCellScale::zero_range(Q16::from_bits(gain));
        for zero in [floor.to_bits(), 3_277, top.to_bits()] {
            for raw in 0..=4095 {
                load_cell_within_bound(raw, zero, gain);
                cases += 1;
            }
        }
    }
    println!("load_cell_every_code_nominal_and_extreme_scales: {cases} cases");
}

#[test]
fn load_cell_any_valid_scale() {
    // The zero drawn as a fraction (in 2⁻¹⁶) of the band its gain allows.
    let fraction = 0..=65_536i64;
    let gain = KGF_PER_VOLT_RANGE.0.to_bits()..=KGF_PER_VOLT_RANGE.1.to_bits();
    let inputs = (0..=4095u16, fraction, gain);
    common::check("load_cell_any_valid_scale", 20_000, inputs, |(raw, fraction, g)| {
        let (floor, top) = LoadCellScale::zero_range(Q16::from_bits(g));
        let span = i64::from(top.to_bits() - floor.to_bits());
        let zero = floor.to_bits() + i32::try_from((span * fraction) >> 16).expect("in the band");
        load_cell_within_bound(raw, zero, g);
    });
}

#[test]
fn load_cell_any_scale_at_all() {
    let inputs = (any::<u16>(), any::<i32>(), any::<i32>());
    common::check("load_cell_any_scale_at_all", 20_000, inputs, |(raw, z, g)| {
        load_cell_within_bound(raw, z, g);
    });
}

#[test]
fn saturating_ops_whole_range() {
    common::check("saturating_ops_whole_range", 20_000, (any::<i32>(), any::<i32>()), |(a, b)| {
        saturating_ops_within_bound(a, b);
    });
}

#[test]
fn saturating_ops_near_physical_values() {
    // ±100 in Q15.16: where every tension, current and voltage of the machine lives.
    let near = -6_553_600..6_553_600i32;
    common::check("saturating_ops_near_physical_values", 20_000, (near.clone(), near), |(a, b)| {
        saturating_ops_within_bound(a, b);
    });
}

#[test]
fn unit_conversions_total_whole_range() {
    for (value, bits) in [(i32::MAX, i32::MAX), (i32::MIN, i32::MIN), (0, 0), (-1, -1), (1, 1)] {
        unit_conversions_total(value, bits);
    }
    common::check(
        "unit_conversions_total_whole_range",
        20_000,
        (any::<i32>(), any::<i32>()),
        |(v, b)| {
            unit_conversions_total(v, b);
        },
    );
}

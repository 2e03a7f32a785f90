//! The fixed-point foundation against its f64 reference (REQ-FXP-01 … 05): ADC code → volts,
//! → amperes, → kgf through any load-cell scale; saturating Q15.16 arithmetic; panel units.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use taut_core::sense::load_cell::{KGF_PER_VOLT_RANGE, LoadCellScale};
use taut_core::units::Q16;
use taut_proofs::fixed_point::{
    adc_volts_exact, current_amps_exact, load_cell_within_bound, panel_units_round_trip,
    saturating_ops_within_bound, unit_conversions_total,
};

#[derive(Arbitrary, Debug)]
struct Case {
    code: u16,
    zero_bits: i32,
    kgf_per_volt_bits: i32,
    a_bits: i32,
    b_bits: i32,
    tenths: i16,
}

fuzz_target!(|case: Case| {
    adc_volts_exact(case.code);
    current_amps_exact(case.code);
    // Steer half the inputs into the valid scale range so the conversion itself is exercised.
    // The zero band depends on the gain (its top reads as `ZERO_OFFSET_MAX`): gain first.
    let (gain_low, gain_high) = (KGF_PER_VOLT_RANGE.0.to_bits(), KGF_PER_VOLT_RANGE.1.to_bits());
    let gain = gain_low + case.kgf_per_volt_bits.rem_euclid(gain_high - gain_low + 1);
    let (zero_low, zero_high) = LoadCellScale::zero_range(Q16::from_bits(gain));
    let (zero_low, zero_high) = (zero_low.to_bits(), zero_high.to_bits());
    let zero = zero_low + case.zero_bits.rem_euclid(zero_high - zero_low + 1);
    load_cell_within_bound(case.code, zero, gain);
    load_cell_within_bound(case.code, case.zero_bits, case.kgf_per_volt_bits);
    saturating_ops_within_bound(case.a_bits, case.b_bits);
    panel_units_round_trip(case.tenths);
    unit_conversions_total(case.a_bits, case.b_bits);
});

//! The winding's temperature estimate (REQ-DRV-13), as two properties: one call of the
//! estimate from any state it can reach keeps the resistance within [cold, hot limit] and
//! `I_lim·R` within the matching bounds; and the window computed with any such `I_lim·R`
//! keeps the motoring and braking voltage across the pair within it — so the current stays
//! within the limit for every pair whose real resistance is at least the estimate (which the
//! model's choices guarantee: `core/src/drive/limit.rs`, `WindingHeat`). The Kani harness
//! checks the first for every state and input; `proofs/tests/thermal.rs` runs both
//! exhaustively over the rise and the bus and along long heating and cooling sequences.

use taut_core::drive::DriveConfig;
use taut_core::drive::DriveTime;
use taut_core::drive::WindingHeat;
use taut_core::drive::limit::RISE_MAX_UK;
use taut_core::drive::{DUTY_MAX, Duty};
use taut_core::units::AdcCode;

/// The hot limit of the pair's resistance on `config`'s board, mΩ: `R_cold · 1.393`.
#[must_use]
pub fn hot_limit_mohm(config: &DriveConfig) -> u32 {
    let cold = config.limit().resistance_mohm;
    cold.saturating_add(cold.saturating_mul(393) / 1_000)
}

/// REQ-DRV-13: one call of the estimate from the valid state `heat`, with a sample of
/// `codes` from the zero, conducting or not, `elapsed` after the previous call.
pub fn heat_step_bounded(heat: &mut WindingHeat, codes: u16, conducting: bool, elapsed: u32) {
    let config = DriveConfig::PAPER;
    assert!(heat.is_valid(&config), "REQ-DRV-13: the property starts from a valid state");
    heat.step(&config, codes, conducting, DriveTime(elapsed));
    assert!(heat.is_valid(&config), "REQ-DRV-13: the estimate stays valid");
    assert!(heat.rise_uk() <= RISE_MAX_UK, "REQ-DRV-13: the rise is bounded");
    let (cold, hot) = (config.limit().resistance_mohm, hot_limit_mohm(&config));
    assert!(heat.resistance_mohm() >= cold, "REQ-DRV-13: never below the cold resistance");
    assert!(heat.resistance_mohm() <= hot, "REQ-DRV-13: never above the hot limit");
    let limit_ma = config.limit().limit_ma;
    assert!(heat.ir_mv() >= config.ir_mv(), "REQ-DRV-13: I·R never below the cold value");
    assert!(
        heat.ir_mv() <= limit_ma.saturating_mul(hot) / 1_000,
        "REQ-DRV-13: I·R never above the hot limit's"
    );
}

/// REQ-DRV-13 with REQ-DRV-10: the window computed with the estimate of a winding `rise_uk`
/// above cold, on the bus code `bus` against the back-EMF `emf_mv`, drives at most
/// `I_lim·R_est` (±10 mV of rounding) across the pair either way: a pair whose resistance is at
/// least `R_est` carries at most `I_lim`.
#[allow(
    clippy::arithmetic_side_effects,
    reason = "specification arithmetic on bounded values: codes ≤ 4 095, mV ≤ 120 000, duty ≤ 65 535, divisors ≥ 1, all in i64"
)]
pub fn hot_window_bounds_current(rise_uk: u32, bus: u16, emf_mv: i32) {
    let config = DriveConfig::PAPER;
    let heat = WindingHeat::with_rise(&config, rise_uk);
    let bus = AdcCode::new(bus.min(4_095));
    let e = i64::from(emf_mv.clamp(-60_000, 60_000));
    let ir = i64::from(heat.ir_mv());
    let bus_mv = i64::from(u32::from(bus.get()) * 60_000 / 4_096);
    let v = bus_mv.max(i64::from(config.bus().floor_mv));
    let volts = |duty: Duty| i64::from(duty.raw()) * v / 65_536;
    match config.window_with(bus, emf_mv, heat.ir_mv()) {
        None => assert!(e <= -ir, "REQ-DRV-13: no window at {e} mV"),
        Some(window) => {
            assert!(e > -ir, "REQ-DRV-13: a window against {e} mV");
            let high = volts(window.high);
            assert!(high - e <= ir + 10, "REQ-DRV-13: upper edge {high} mV at {e} mV");
            if window.low < DUTY_MAX {
                let low = volts(window.low);
                let floor = if bus_mv >= i64::from(config.bus().regen_mv) { 0 } else { -ir };
                assert!(low - e >= floor - 10, "REQ-DRV-13: lower edge {low} mV at {e} mV");
            }
        }
    }
}

#[cfg(kani)]
mod verification {
    use super::*;

    /// REQ-DRV-13 for every rise the estimate can be given (any `u32`, capped at the bound):
    /// the resistance and `I·R` lie within [cold, hot limit]; then one call that does not
    /// complete a span keeps them. (The span's arithmetic — 64-bit products and quotients of
    /// symbolic values — is beyond the two-minute budget; it is covered by
    /// `heat_step_bounded_along_sequences` in `proofs/tests/thermal.rs`.)
    #[kani::proof]
    fn verify_winding_heat_bounded() {
        let config = DriveConfig::PAPER;
        let mut heat = WindingHeat::with_rise(&config, kani::any());
        let elapsed: u32 = kani::any();
        kani::assume(elapsed < 5_000);
        heat_step_bounded(&mut heat, kani::any(), kani::any(), elapsed);
        crate::harness_end_reached();
    }
}

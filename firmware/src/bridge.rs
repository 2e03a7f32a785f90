//! The bridge binding: TIM1 register images for a switch pattern and a duty, and the
//! hardware dead time.
//!
//! # Theory of operation
//!
//! The core's fast loop ([`taut_core::drive::Drive::step`]) says, every PWM period, which
//! switches conduct ([`SwitchPattern`]: each leg high, low or off) and the high-side duty
//! ([`Duty`]). TIM1, the STM32G431's advanced-control timer, drives the three legs from its
//! channel pairs CH1/CH1N (phase A), CH2/CH2N (B) and CH3/CH3N (C). Each leg state maps to a
//! fixed channel configuration (RM0440, section 28.3.16, "Complementary outputs and dead-time
//! insertion", and table "Output control bits for complementary OCx and OCxN channels with
//! break feature"), with `MOE = 1` and `OSSR = 1` so that a disabled output is *driven* to its
//! inactive level rather than left floating:
//!
//! | leg | OCxM | CCxE | CCxNE | high-side gate (OCx) | low-side gate (OCxN) |
//! |---|---|---|---|---|---|
//! | high (switched) | PWM mode 1 | 1 | 1 | on while `CNT < CCRx` | the complement: on for the rest of the period |
//! | low | force inactive | 1 | 1 | OCxREF = 0: off | complement of OCxREF: on |
//! | off | force inactive | 1 | 0 | off | inactive (off) |
//!
//! The switched leg is complementary, as the core's `commutation` module specifies (the
//! paper's dsPIC "complementary mode"): its low side conducts whenever its high side does not,
//! so the drive works in two quadrants and the bootstrap capacitor recharges every period.
//! The dead-time generator delays every rising edge of OCx and OCxN by the dead time, so the
//! two switches of a leg are never on at the same instant.
//!
//! No row turns both gates of a leg on at once; [`BridgeImage::for_output`] is tested against a model
//! of that table for every pattern and duty (`bridge_image_drives_exactly_the_requested_gates`).
//! The output mode and enable bits are preloaded (`CR2.CCPC = 1`) and applied together by a
//! commutation event (`EGR.COMG`), so the three legs change in the same timer clock; the
//! compare values are preloaded and change at the next update, so a PWM pulse is never cut.
//!
//! Channel 4 has no pin: its compare event, placed in the middle of the high-side on-time,
//! triggers the ADC's injected conversion of the bus current, sampling it where it equals the
//! winding current (the core's `sense::current` docs).
//!
//! # Polarity
//!
//! The IHM08M1's L6398 drivers take an active-high high-side input and an active-**low**
//! low-side input, so every CHxN output has inverted polarity (`CCxNP = 1`) and idles high
//! (`OISxN = 1`); the idle and inactive levels therefore mean "off" on every gate. Before the
//! timer is configured the pins are inputs and the L6398's own input pull resistors hold both
//! switches off.
//!
//! # Dead time
//!
//! The hardware dead-time generator is programmed from [`DEAD_TIME_TICKS`], the same time the
//! core's dead-time sequencer enforces in software ([`crate::timing::DEAD_TIME`], handed to it
//! in the drive's configuration; [`dead_time_register`]): 170 timer clocks = 1.0 µs encodes
//! exactly as `DTG = 0x95`.
//!
//! # Break
//!
//! The overcurrent comparator drives the break input BKIN: while it is low, the hardware
//! clears `MOE` within a few clock cycles, with no software involved, and every output goes
//! to its idle (off) level. The break flag and the comparator level are reported to the core
//! as [`taut_core::drive::DriveSample::overcurrent_trip`]; `MOE` is set again only while the
//! core reports no latched fault ([`main_output_enabled`]).

use crate::timing::{
    CR2_TRGO2_IS_OC5REF, DEAD_TIME_TICKS, PWM_FREQUENCY_HZ, PWM_PERIOD_TICKS, PWM_TIMER_HZ,
};
use taut_core::drive::{DriveOutput, Duty, LegState, SwitchPattern};

/// The low-side gate inputs are active low (L6398 `LIN`).
pub const LOW_SIDE_ACTIVE_LOW: bool = true;

/// TIM1 prescaler: none, so the counter runs at [`PWM_TIMER_HZ`].
pub const PRESCALER: u16 = 0;

/// TIM1 auto-reload value for edge-aligned up-counting: the period is `ARR + 1` ticks.
pub const AUTO_RELOAD: u16 = PWM_PERIOD_TICKS.saturating_sub(1);

#[allow(clippy::cast_lossless, reason = "`u32::from` is not callable in a const item")]
const _: () = assert!(
    PWM_TIMER_HZ / PWM_FREQUENCY_HZ == PWM_PERIOD_TICKS as u32,
    "the board's PWM constants must describe the timer this module programs"
);

/// `OCxM` = force inactive (`OCxREF = 0`).
const OCM_FORCE_INACTIVE: u32 = 0b0100;
/// `OCxM` = PWM mode 1 (`OCxREF = 1` while `CNT < CCRx`).
const OCM_PWM1: u32 = 0b0110;

/// Where a channel's output-compare fields sit in its CCMR register: channel 1 and 3 at
/// shift 0, channel 2 and 4 at shift 8.
fn ccmr_channel_bits(mode: u32, second_in_register: bool) -> u32 {
    let shift = if second_in_register { 8 } else { 0 };
    // OCxM[2:0] at bits 6:4, OCxM[3] at bit 16, OCxPE (preload) at bit 3; CCxS = 00 (output).
    let low = (mode & 0b111) << 4;
    let high = ((mode >> 3) & 1) << 16;
    let preload = 1 << 3;
    (low | high | preload) << shift
}

/// Control register 2: `CCPC = 1` (mode and enable bits preloaded, applied by `COMG`),
/// `CCUS = 0` (only software `COMG` applies them), idle levels off on every gate, and TRGO2 =
/// channel 5's reference, the trigger of the slow ADC samples ([`crate::timing`]).
pub const CR2: u32 = {
    let ois_low = if LOW_SIDE_ACTIVE_LOW { 1 } else { 0 };
    // OIS1 bit 8, OIS1N bit 9, OIS2 bit 10, OIS2N bit 11, OIS3 bit 12, OIS3N bit 13.
    1 | (ois_low << 9) | (ois_low << 11) | (ois_low << 13) | CR2_TRGO2_IS_OC5REF
};

/// Break and dead-time register without `MOE`: dead time, `OSSI = OSSR = 1` (disabled outputs
/// driven to their inactive/idle level), break enabled, active low (`BKP = 0`), filtered over
/// 8 clocks (`BKF = 0011`, ≈ 47 ns), no automatic re-enable (`AOE = 0`), and `LOCK = 01` so
/// the dead time, the break configuration and the idle levels cannot be changed again until
/// reset.
#[must_use]
pub const fn bdtr(dead_time_register: u8) -> u32 {
    const OSSI: u32 = 1 << 10;
    const OSSR: u32 = 1 << 11;
    const BKE: u32 = 1 << 12;
    const BKF_8_CLOCKS: u32 = 0b0011 << 16;
    const LOCK_LEVEL_1: u32 = 0b01 << 8;
    // `u32::from` is not const; a u8 always fits.
    let dtg = dead_time_register as u32;
    dtg | LOCK_LEVEL_1 | OSSI | OSSR | BKE | BKF_8_CLOCKS
}

/// `BDTR.MOE`, the main output enable bit.
pub const MOE: u32 = 1 << 15;

/// `TIM1_AF1`: break input from the BKIN pin enabled (`BKINE = 1`), not inverted.
pub const AF1: u32 = 1;

/// Whether the main outputs should be enabled: exactly while the core reports no latched
/// drive fault. The hardware break clears `MOE` on its own; this only re-enables it once the
/// core has cleared the fault (the hardware refuses while BKIN is still active).
#[must_use]
pub const fn main_output_enabled(fault_latched: bool) -> bool {
    !fault_latched
}

/// Everything the fast loop writes to TIM1 for one [`DriveOutput`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct BridgeImage {
    /// Capture/compare mode register 1 (channels 1 and 2).
    pub ccmr1: u32,
    /// Capture/compare mode register 2 (channels 3 and 4).
    pub ccmr2: u32,
    /// Capture/compare enable register.
    pub ccer: u32,
    /// Compare value of the three phase channels (`CCR1..3`): the high-side on-time in ticks.
    pub compare: u16,
    /// Compare value of channel 4 (`CCR4`): the bus-current sampling instant.
    pub current_sample: u16,
}

/// The channel configuration of one leg: output mode, and whether OCx and OCxN are enabled.
const fn leg_config(state: LegState) -> (u32, bool, bool) {
    match state {
        LegState::High => (OCM_PWM1, true, true),
        LegState::Low => (OCM_FORCE_INACTIVE, true, true),
        LegState::Off => (OCM_FORCE_INACTIVE, true, false),
    }
}

impl BridgeImage {
    /// The register image that puts `output` on the bridge.
    #[must_use]
    pub fn for_output(output: DriveOutput) -> Self {
        let (mode_a, a_high, a_low) = leg_config(output.pattern.a);
        let (mode_b, b_high, b_low) = leg_config(output.pattern.b);
        let (mode_c, c_high, c_low) = leg_config(output.pattern.c);
        let ccmr1 = ccmr_channel_bits(mode_a, false) | ccmr_channel_bits(mode_b, true);
        // Channel 4: PWM mode 1 without an output pin; only its compare event is used.
        let ccmr2 = ccmr_channel_bits(mode_c, false) | ccmr_channel_bits(OCM_PWM1, true);
        let polarity_low = u32::from(LOW_SIDE_ACTIVE_LOW);
        let mut ccer = 0;
        // Channel x (0-based) owns CCER bits 4x (CCxE), 4x+1 (CCxP), 4x+2 (CCxNE), 4x+3 (CCxNP).
        for (index, (high, low)) in
            [(a_high, a_low), (b_high, b_low), (c_high, c_low)].into_iter().enumerate()
        {
            let shift = index.saturating_mul(4);
            ccer |= (u32::from(high) | (u32::from(low) << 2) | (polarity_low << 3)) << shift;
        }
        let compare = output.duty.compare_ticks(PWM_PERIOD_TICKS);
        Self { ccmr1, ccmr2, ccer, compare, current_sample: compare / 2 }
    }

    /// Everything off, duty zero: the image written at start-up.
    #[must_use]
    pub fn off() -> Self {
        Self::for_output(DriveOutput { pattern: SwitchPattern::ALL_OFF, duty: Duty::ZERO })
    }
}

/// Why a dead time cannot be programmed.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum DeadTimeError {
    /// Longer than the generator's maximum, [`DEAD_TIME_MAX_TICKS`] timer clocks.
    TooLong,
}

/// The longest dead time `BDTR.DTG` can express with `CKD = 00`: 63 + 32 = 63 × 16 clocks.
pub const DEAD_TIME_MAX_TICKS: u32 = (32 + 31) * 16;

/// The dead time, in timer clocks, that a `BDTR.DTG` value produces (RM0440, TIMx_BDTR:
/// `DTG[7:5] = 0xx` → `DTG` clocks; `10x` → `(64 + DTG[5:0]) × 2`; `110` → `(32 + DTG[4:0]) × 8`;
/// `111` → `(32 + DTG[4:0]) × 16`).
#[must_use]
pub const fn dead_time_ticks(register: u8) -> u32 {
    // A u8 always fits a u32; `u32::from` is not const. Every result is at most
    // (32 + 31) × 16 = 1 008, so the saturating operations never saturate.
    let value = register as u32;
    if value & 0x80 == 0 {
        value
    } else if value & 0xC0 == 0x80 {
        (value & 0x3F).saturating_add(64).saturating_mul(2)
    } else if value & 0xE0 == 0xC0 {
        (value & 0x1F).saturating_add(32).saturating_mul(8)
    } else {
        (value & 0x1F).saturating_add(32).saturating_mul(16)
    }
}

/// The `BDTR.DTG` value for the shortest dead time that is at least `ticks` timer clocks: the
/// hardware never inserts less than asked.
///
/// # Errors
/// [`DeadTimeError::TooLong`] beyond [`DEAD_TIME_MAX_TICKS`].
pub const fn dead_time_register(ticks: u32) -> Result<u8, DeadTimeError> {
    // Every encoding grows with its field, so the smallest sufficient value in the finest
    // range that reaches `dead_time` is the answer. Ranges: 0..=127 step 1, 128..=254 step 2,
    // 256..=504 step 8, 512..=1008 step 16.
    let encoded = if ticks <= 127 {
        ticks
    } else if ticks <= 254 {
        0x80 | ticks.div_ceil(2).saturating_sub(64)
    } else if ticks <= 504 {
        0xC0 | (ticks.div_ceil(8).saturating_sub(32))
    } else if ticks <= DEAD_TIME_MAX_TICKS {
        0xE0 | ticks.div_ceil(16).saturating_sub(32)
    } else {
        return Err(DeadTimeError::TooLong);
    };
    // `encoded` ≤ 0xFF by construction of each branch.
    #[allow(clippy::cast_possible_truncation, reason = "every branch yields at most 0xFF")]
    Ok(encoded as u8)
}

/// The `DTG` value for the board's [`DEAD_TIME_TICKS`], checked when the crate is compiled.
pub const DEAD_TIME_REGISTER: u8 = match dead_time_register(DEAD_TIME_TICKS) {
    Ok(register) => register,
    Err(DeadTimeError::TooLong) => 0xFF,
};

const _: () = assert!(
    dead_time_ticks(DEAD_TIME_REGISTER) == DEAD_TIME_TICKS,
    "the hardware dead time must equal the one core is given exactly"
);

#[cfg(test)]
mod tests {
    use super::*;
    use std::println;
    use taut_core::drive::{DUTY_MAX, Phase};

    /// The TIM1 output stage with `MOE = 1`, `OSSR = 1` (RM0440's table of output control
    /// bits): the logical (before polarity) level of OCx and OCxN for channel `index` at
    /// counter value `counter`, ignoring the dead-time delay of edges.
    fn outputs(image: &BridgeImage, index: usize, counter: u16) -> (bool, bool) {
        let (register, second) = match index {
            0 => (image.ccmr1, false),
            1 => (image.ccmr1, true),
            _ => (image.ccmr2, false),
        };
        let field = if second { register >> 8 } else { register };
        let mode = ((field >> 4) & 0b111) | (((field >> 16) & 1) << 3);
        let reference = match mode {
            OCM_PWM1 => counter < image.compare,
            OCM_FORCE_INACTIVE => false,
            other => panic!("unexpected output mode {other:#b}"),
        };
        let enable = image.ccer >> (4 * index);
        let (ccxe, ccxne) = (enable & 1 != 0, enable & 0b100 != 0);
        match (ccxe, ccxne) {
            (true, true) => (reference, !reference),
            (true, false) => (reference, false),
            (false, true) => (false, reference),
            (false, false) => (false, false),
        }
    }

    fn all_patterns() -> impl Iterator<Item = SwitchPattern> {
        LegState::ALL.into_iter().flat_map(|a| {
            LegState::ALL.into_iter().flat_map(move |b| {
                LegState::ALL.into_iter().map(move |c| SwitchPattern { a, b, c })
            })
        })
    }

    #[test]
    fn bridge_image_drives_exactly_the_requested_gates() {
        let duties: std::vec::Vec<Duty> = (0..=DUTY_MAX.raw())
            .step_by(997)
            .chain([1, DUTY_MAX.raw()])
            .map(Duty::from_raw_clamped)
            .collect();
        let mut cases = 0u64;
        for pattern in all_patterns() {
            for &duty in &duties {
                let image = BridgeImage::for_output(DriveOutput { pattern, duty });
                let compare = image.compare;
                let counters = (0..PWM_PERIOD_TICKS).step_by(97).chain([
                    compare.saturating_sub(1),
                    compare,
                    compare.saturating_add(1).min(AUTO_RELOAD),
                    AUTO_RELOAD,
                ]);
                for counter in counters {
                    for (index, phase) in Phase::ALL.into_iter().enumerate() {
                        let (high, low) = outputs(&image, index, counter);
                        assert!(!(high && low), "shoot-through {pattern:?} {duty:?} {counter}");
                        // The core's gate contract: a set high side is switched by the PWM with
                        // its low side as the complement; a set low side is on all sector.
                        let (switched, low_on) = pattern.gates().leg(phase);
                        let expected = (
                            switched && counter < compare,
                            low_on || (switched && counter >= compare),
                        );
                        assert_eq!((high, low), expected, "{pattern:?} {phase:?} {counter}");
                        cases += 1;
                    }
                }
            }
        }
        println!("bridge image: {cases} (pattern, duty, counter, phase) cases checked");
    }

    #[test]
    fn low_side_outputs_are_inverted_and_high_sides_are_not() {
        for pattern in all_patterns() {
            let ccer = BridgeImage::for_output(DriveOutput { pattern, duty: Duty::ZERO }).ccer;
            for index in 0..3 {
                assert_eq!(ccer >> (4 * index + 1) & 1, 0, "CC{}P", index + 1);
                assert_eq!(ccer >> (4 * index + 3) & 1, 1, "CC{}NP", index + 1);
            }
            assert_eq!(ccer >> 12, 0, "channel 4 has no output");
        }
        assert_eq!(CR2 & 1, 1, "CCPC");
        assert_eq!(CR2 & 0b10_1010_0000_0000, 0b10_1010_0000_0000, "OISxN idle high = off");
        assert_eq!(CR2 & 0b01_0101_0000_0000, 0, "OISx idle low = off");
    }

    #[test]
    fn current_is_sampled_in_the_middle_of_the_on_time() {
        for raw in (0..=DUTY_MAX.raw()).step_by(101) {
            let pattern = SwitchPattern { a: LegState::High, b: LegState::Low, c: LegState::Off };
            let image =
                BridgeImage::for_output(DriveOutput { pattern, duty: Duty::from_raw_clamped(raw) });
            assert!(image.current_sample <= image.compare);
            assert!(image.compare - image.current_sample <= image.current_sample + 1);
        }
    }

    #[test]
    fn dead_time_register_is_the_shortest_sufficient_encoding() {
        let mut cases = 0u32;
        for ticks in 0..=DEAD_TIME_MAX_TICKS {
            let register = dead_time_register(ticks).unwrap();
            let programmed = dead_time_ticks(register);
            assert!(programmed >= ticks, "{ticks}: {programmed}");
            for other in 0..=u8::MAX {
                let alternative = dead_time_ticks(other);
                assert!(!(alternative >= ticks && alternative < programmed), "{ticks}: {other:#x}");
            }
            cases += 1;
        }
        assert_eq!(dead_time_register(DEAD_TIME_MAX_TICKS + 1), Err(DeadTimeError::TooLong));
        println!("dead-time encoding: {cases} durations checked against all 256 register values");
    }

    #[test]
    fn the_core_dead_time_is_programmed_exactly() {
        assert_eq!(DEAD_TIME_REGISTER, 0x95);
        assert_eq!(dead_time_ticks(DEAD_TIME_REGISTER), DEAD_TIME_TICKS);
        assert_eq!(bdtr(DEAD_TIME_REGISTER) & 0xFF, 0x95);
        assert_eq!(bdtr(DEAD_TIME_REGISTER) & MOE, 0, "outputs start disabled");
    }

    #[test]
    fn main_output_follows_the_core_fault() {
        assert!(main_output_enabled(false));
        assert!(!main_output_enabled(true));
    }
}

//! The board's timing in one place: the timer clock, the PWM period and the dead time — facts of
//! this board that core does not know — how they are handed to core (the dead time in the
//! drive's configuration, the dead-time duty in the controller's, every elapsed time in the
//! drive's board-independent [`DriveTime`]), and where in the period the ADCs sample.
//!
//! # Theory of operation
//!
//! TIM1 counts up from 0 to [`PWM_PERIOD_TICKS`] − 1 at [`PWM_TIMER_HZ`] (edge-aligned, one
//! update per period). On the switched leg the low side turns off at the update and the high
//! side on [`DEAD_TIME_TICKS`] later; the high side turns off at the compare value
//! `CCR = duty × period` and the low side on [`DEAD_TIME_TICKS`] after that. Every other leg is
//! static within the period. The duty never exceeds [`DUTY_MAX`] (95 %), so **every period
//! ends with a quiet window** — from [`LAST_EDGE_TICKS`] (the latest possible low-side turn-on)
//! to the next update — in which no switch of any leg moves, whatever the duty:
//!
//! ```text
//!  counter 0        170                    CCR  CCR+170        8 244   8 329      8 493 8 500
//!          |  dead  |  high side on  ...    |dead|  low side on  ...  |settle|ADC1+ADC2|
//!  gates   \________/‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾\____/_________________________________________/
//!          ^ update: low off       ^ CC4 = CCR/2:             quiet ^ CC5 = 8 329: TRGO2
//!                                    ADC1 injected: current    window  ADC1 regular: bus voltage
//!                                    (mid on-time)                     ADC2 regular: load cell
//!  ADC     ...........[ 4 latency + 24.5 sample + 12.5 SAR ] ....... [ same, 41 clocks = 0.96 µs ]
//! ```
//!
//! - **Motor current** (ADC1 injected, PA0): converted on TIM1 channel 4's compare, placed by
//!   the bridge image at half the high side's on-time ([`crate::bridge::BridgeImage`]), the one
//!   place where the bus shunt carries the winding current. The fast loop reads it every
//!   period; the tick gets the mean of the tick's periods (the fast loop sums them as it reads
//!   them — no second conversion of the same pin, which two ADCs must not sample at once).
//! - **Load cell** (ADC2 regular, PB15) and **bus voltage** (ADC1 regular, PA1): converted
//!   together on TIM1's TRGO2, which is channel 5's reference (PWM mode 2: it rises at
//!   `CCR5 =` [`SLOW_SAMPLE_TICKS`], a fixed point inside the quiet window). Each ADC's
//!   hardware oversampler runs in *triggered* mode (one conversion per trigger) with ratio
//!   2^[`OVERSAMPLING_SHIFT`] = 16 and a 4-bit shift, so every 16 periods (0.8 ms) its data
//!   register holds the 12-bit mean of 16 samples, each taken at the same quiet instant. The
//!   1 ms tick reads the two data registers: finished results, no conversion started, no wait.
//!
//! Every figure above is derived from the board constants below, and the checks at the end of
//! this file fail the build if a change (a longer dead time, a higher duty cap, a shorter
//! period) would put a sample on a switching edge, or would give core a dead time other than
//! the timer's.
//!
//! # Handing the timing to core
//!
//! Core's drive counts time in [`DriveTime`] (100 ns) and never sees a clock: the fast loop
//! converts the cycle counter's counts with [`drive_time`], carrying the remainder so no time
//! is lost between calls; the dead time goes into the drive's configuration as [`DEAD_TIME`]
//! (exactly [`DEAD_TIME_TICKS`] of the timer), and the period as [`crate::board::PWM_PERIOD`];
//! the controller's dead-time duty is derived from the two by the board
//! ([`crate::board::board`]). Porting to another MCU or PWM frequency is a change of this file.

use taut_core::drive::{DUTY_MAX, DriveTime, TIME_UNITS_PER_SECOND, duty::DUTY_ONE};

/// Clock of the PWM timer: the STM32G431's TIM1 at the 170 MHz system clock.
pub const PWM_TIMER_HZ: u32 = 170_000_000;

/// PWM frequency: 20 kHz, above hearing and ≈ 24 periods per sector at full speed.
pub const PWM_FREQUENCY_HZ: u32 = 20_000;

/// Timer ticks in one PWM period (edge-aligned): 170 MHz / 20 kHz = 8 500.
#[allow(
    clippy::cast_possible_truncation,
    reason = "`u16::try_from` is not callable in a const item; the compile-time checks below refuse a period past the 16-bit timer"
)]
pub const PWM_PERIOD_TICKS: u16 = (PWM_TIMER_HZ / PWM_FREQUENCY_HZ) as u16;

/// Minimum both-off time of a leg before either of its switches turns on: 170 ticks = 1.0 µs.
/// The IRF2807 turns off in ≈100 ns, and the paper's FAN7888 gate driver (or the L6398
/// drivers of the X-NUCLEO-IHM08M1 power board) add a few hundred ns of propagation mismatch;
/// 1 µs keeps a 2× margin and costs 2 % of a 20 kHz period. The hardware dead-time generator
/// is programmed with it ([`crate::bridge::DEAD_TIME_REGISTER`]) and core's sequencer enforces
/// the same time ([`DEAD_TIME`]).
pub const DEAD_TIME_TICKS: u32 = 170;

/// Timer ticks (and DWT cycles: the same clock) per [`DriveTime`] unit: 17.
pub const TICKS_PER_DRIVE_TIME: u32 = PWM_TIMER_HZ / TIME_UNITS_PER_SECOND;

/// The dead time in core's unit, for the drive's configuration: 10 (1.0 µs).
pub const DEAD_TIME: DriveTime = DriveTime(DEAD_TIME_TICKS / TICKS_PER_DRIVE_TIME);

/// `cycles` of the 170 MHz cycle counter as drive time, and the cycles left over (under one
/// unit), which the caller counts into the next call so no time is lost.
#[must_use]
pub const fn drive_time(cycles: u32) -> (DriveTime, u32) {
    (DriveTime(cycles / TICKS_PER_DRIVE_TIME), cycles % TICKS_PER_DRIVE_TIME)
}

/// Timer ticks per ADC clock: TIM1 and the ADC kernel clock both run from the 170 MHz system
/// clock, and the ADC12 common prescaler divides it by 4 (42.5 MHz, below the G4's 60 MHz).
pub const TICKS_PER_ADC_CLOCK: u32 = 4;

/// Trigger-to-sampling latency of a regular or injected conversion, in half ADC clocks: at most
/// 4 ADC clocks with an asynchronous ADC clock (RM0440, "Timing"; taken with margin).
pub const LATENCY_HALF_CLOCKS: u32 = 2 * 4;

/// Sampling time of every channel, in half ADC clocks: 24.5 clocks (0.58 µs), what the quiet
/// window leaves room for. The load cell has 100 nF at its pin, so the ADC's 5 pF takes its
/// charge from the capacitor, not through the divider (below 0.2 LSB shared); the current
/// was already sampled this long; the bus-voltage divider is discussed in `firmware/README.md`.
pub const SAMPLE_HALF_CLOCKS: u32 = 49;

/// Successive-approximation time of a 12-bit conversion, in half ADC clocks: 12.5 clocks.
pub const SAR_HALF_CLOCKS: u32 = 25;

/// Timer ticks from a trigger to the end of its conversion.
pub const CONVERSION_TICKS: u32 =
    (LATENCY_HALF_CLOCKS + SAMPLE_HALF_CLOCKS + SAR_HALF_CLOCKS) * TICKS_PER_ADC_CLOCK / 2;

/// The largest compare value any duty produces: `period × DUTY_MAX` (as
/// [`taut_core::drive::Duty::compare_ticks`] rounds it).
#[allow(clippy::cast_lossless, reason = "`u32::from` is not callable in a const item")]
pub const MAX_COMPARE_TICKS: u32 = PWM_PERIOD_TICKS as u32 * DUTY_MAX.raw() as u32 / DUTY_ONE;

/// The latest switching edge in any period: the switched leg's low side turning on a dead time
/// after the high side turned off at the largest compare value.
pub const LAST_EDGE_TICKS: u32 = MAX_COMPARE_TICKS + DEAD_TIME_TICKS;

/// How long the switch node rings after an edge before a sample is clean: 0.5 µs.
pub const SETTLE_TICKS: u32 = PWM_TIMER_HZ / 2_000_000;

/// Where the load cell and the bus voltage are sampled: TIM1 `CCR5`, the start of the quiet
/// window plus the settling time.
#[allow(clippy::cast_possible_truncation, reason = "checked below: it lies within the period")]
pub const SLOW_SAMPLE_TICKS: u16 = (LAST_EDGE_TICKS + SETTLE_TICKS) as u16;

/// The hardware oversampler's shift: 2⁴ = 16 conversions averaged (`OVSR = 3`, `OVSS = 4`),
/// leaving a 12-bit mean.
pub const OVERSAMPLING_SHIFT: u8 = 4;

/// `TIMx_CR2.MMS2 = 1000`: TRGO2 is channel 5's reference signal.
pub const CR2_TRGO2_IS_OC5REF: u32 = 0b1000 << 20;

/// `TIMx_CCMR3`: channel 5 in PWM mode 2 (`OC5M = 0111`: reference high from `CCR5` to the end
/// of the period, so it rises at `CCR5`), no preload (`CCR5` is written once).
pub const CCMR3: u32 = 0b0111 << 4;

// The compile-time checks: a change of the board's timing that would move a sample onto a
// switching edge, or past the period, or hand core a dead time other than the timer's, stops
// the build here.
#[allow(clippy::cast_lossless, reason = "`u32::from` is not callable in a const item")]
const _: () = {
    let period = PWM_PERIOD_TICKS as u32;
    assert!(PWM_TIMER_HZ / PWM_FREQUENCY_HZ == period, "the PWM period must fit the 16-bit timer");
    assert!(
        PWM_TIMER_HZ.is_multiple_of(TIME_UNITS_PER_SECOND) && TICKS_PER_DRIVE_TIME > 0,
        "the timer clock must be a whole number of ticks per 100 ns"
    );
    assert!(
        DEAD_TIME_TICKS.is_multiple_of(TICKS_PER_DRIVE_TIME),
        "core's dead time must be the timer's exactly"
    );
    assert!(
        DEAD_TIME.0 >= taut_core::drive::DEAD_TIME_MIN.0
            && DEAD_TIME.0 <= taut_core::drive::DEAD_TIME_MAX.0,
        "the dead time must be one the drive's configuration accepts"
    );
    assert!(
        LAST_EDGE_TICKS + SETTLE_TICKS + CONVERSION_TICKS <= period,
        "the load cell and bus voltage must be sampled and converted in the quiet window, \
         before the next period's first edge"
    );
    assert!(
        MAX_COMPARE_TICKS / 2 + CONVERSION_TICKS < SLOW_SAMPLE_TICKS as u32,
        "ADC1's current conversion (mid on-time) must be done before its bus-voltage trigger"
    );
    assert!(
        (1 << OVERSAMPLING_SHIFT) * 1_000 <= PWM_FREQUENCY_HZ,
        "an oversampled result must be ready at least once per 1 ms tick"
    );
};

#[cfg(test)]
mod tests {
    use super::*;
    use taut_core::drive::Duty;

    /// Every switching edge of the switched leg in a period, for one duty.
    fn edges(duty: Duty) -> [u32; 4] {
        let compare = u32::from(duty.compare_ticks(PWM_PERIOD_TICKS));
        [0, DEAD_TIME_TICKS, compare, compare + DEAD_TIME_TICKS]
    }

    #[test]
    fn the_slow_samples_are_clear_of_every_edge_at_every_duty() {
        let start = u32::from(SLOW_SAMPLE_TICKS);
        let end = start + CONVERSION_TICKS;
        assert!(end <= u32::from(PWM_PERIOD_TICKS));
        for raw in 0..=DUTY_MAX.raw() {
            for edge in edges(Duty::from_raw_clamped(raw)) {
                assert!(edge + SETTLE_TICKS <= start, "duty {raw}: edge at {edge}");
            }
        }
    }

    #[test]
    fn the_figures_of_the_diagram() {
        assert_eq!(MAX_COMPARE_TICKS, 8_074);
        assert_eq!(LAST_EDGE_TICKS, 8_244);
        assert_eq!(SLOW_SAMPLE_TICKS, 8_329);
        assert_eq!(CONVERSION_TICKS, 164);
        assert_eq!(MAX_COMPARE_TICKS, u32::from(DUTY_MAX.compare_ticks(PWM_PERIOD_TICKS)));
        assert_eq!(DEAD_TIME, DriveTime::from_micros(1));
    }

    /// The cycle counter's counts become drive time with nothing lost: summed over calls of
    /// any lengths, the units plus the last remainder are the cycles exactly.
    #[test]
    fn cycles_become_drive_time_with_the_remainder_carried() {
        assert_eq!(drive_time(8_500), (DriveTime(500), 0), "one PWM period is 50 µs");
        assert_eq!(drive_time(16), (DriveTime(0), 16));
        assert_eq!(drive_time(u32::MAX), (DriveTime(u32::MAX / 17), u32::MAX % 17));
        let (mut units, mut carry, mut cycles) = (0u64, 0u32, 0u64);
        for call in 1..=10_000u32 {
            let gap = call.wrapping_mul(2_654_435_761) % 9_000;
            cycles += u64::from(gap);
            let (time, left) = drive_time(gap + carry);
            units += u64::from(time.0);
            carry = left;
            assert!(carry < TICKS_PER_DRIVE_TIME);
        }
        assert_eq!(units * u64::from(TICKS_PER_DRIVE_TIME) + u64::from(carry), cycles);
    }
}

//! The fast loop: every PWM period and every Hall edge, sample → `Drive::step` → TIM1.
//!
//! Two interrupts at the same, highest priority call [`step`], so they never preempt each
//! other: TIM1's update (20 kHz, the start of each PWM period) and TIM2's capture in Hall-sensor
//! mode (TIM2 XORs the three Hall lines into TI1 and captures on every edge of the result,
//! RM0440 section 29.3.26 "Interfacing with Hall sensors"), which applies a new sector at once
//! instead of up to one PWM period later. Time between calls comes from the DWT cycle counter,
//! which runs at the system clock — the same 170 MHz as TIM1 — converted to core's
//! [`DriveTime`](taut_core::drive::DriveTime) (100 ns) by [`drive_time`], 17 cycles a unit, the remainder carried into the
//! next call so no time is lost.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::DWT;
use critical_section::Mutex;
use embassy_stm32::Peri;
use embassy_stm32::gpio::{AfType, Flex, Pull};
use embassy_stm32::pac;
use embassy_stm32::pac::interrupt;
use embassy_stm32::peripherals::{PA15, PB3, PB10, TIM2};
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::timer::{Ch1, Ch2, Ch3, TimerPin};
use taut_core::drive::hall::{HALL_VOTES, vote};
use taut_core::drive::{Drive, DriveConfig, DriveOutput, DriveSample, DriveStatus, HallCode};
use taut_core::io::LimitSwitches;
use taut_core::units::AdcCode;
use taut_firmware::bridge::{BridgeImage, main_output_enabled};
use taut_firmware::pins::{self, Pin, Port};
use taut_firmware::timing::drive_time;

use super::{bridge, store};

/// The drive, shared by the fast loop (which steps it) and the control tick (which commands
/// it and reads its status). Every access is a short critical section.
static DRIVE: Mutex<RefCell<Option<Drive>>> = Mutex::new(RefCell::new(None));

/// DWT cycle count at the previous fast-loop call, less the cycles not yet counted into a
/// [`DriveTime`](taut_core::drive::DriveTime) unit (under one).
static LAST_CALL: AtomicU32 = AtomicU32::new(0);

/// The current samples since the tick last took them: their sum in bits 31..10, their count in
/// bits 9..0 (one atomic add per PWM period). A tick takes 20; up to 1 024 samples of 12-bit
/// codes (51 ms without a tick) fit both fields without carrying.
static CURRENT_SUM: AtomicU32 = AtomicU32::new(0);

/// Bits of [`CURRENT_SUM`] that count samples.
const COUNT_BITS: u32 = 10;

/// `TIMx_SR.CC1IF`.
const SR_CC1IF: u32 = 1 << 1;

/// The level of an input pin (`true` = high), read from its port's input data register.
pub fn level(pin: Pin) -> bool {
    let port = match pin.port {
        Port::A => pac::GPIOA,
        Port::B => pac::GPIOB,
        Port::C => pac::GPIOC,
        Port::D => pac::GPIOD,
        Port::F => pac::GPIOF,
        Port::G => pac::GPIOG,
    };
    port.idr().read().0 >> pin.number & 1 != 0
}

/// The limit switches: normally closed to ground, so high means actuated (or a broken wire).
pub fn limits() -> LimitSwitches {
    LimitSwitches { home: level(pins::LIMIT_HOME), end: level(pins::LIMIT_END) }
}

/// The three Hall lines, read [`HALL_VOTES`] times back to back and majority-voted.
fn hall() -> HallCode {
    let mut reads = [HallCode::default(); HALL_VOTES];
    // Constant bound: HALL_VOTES reads.
    for read in &mut reads {
        *read = HallCode::from_lines(level(pins::HALL_A), level(pins::HALL_B), level(pins::HALL_C));
    }
    vote(&reads)
}

/// Installs the drive of the board's `drive` configuration, claims the Hall pins for TIM2 and sets TIM2 up as the Hall-edge
/// interrupt source; starts the cycle counter. Interrupts stay masked until [`start`].
/// Not inlined, so its frame is not part of the start-up's.
#[inline(never)]
pub fn init(
    drive: DriveConfig,
    timer: Peri<'static, TIM2>,
    hall_a: Peri<'static, PA15>,
    hall_b: Peri<'static, PB3>,
    hall_c: Peri<'static, PB10>,
) {
    critical_section::with(|cs| DRIVE.borrow_ref_mut(cs).replace(Drive::with_config(drive)));

    let af_a = TimerPin::<TIM2, Ch1>::af_num(&*hall_a);
    let af_b = TimerPin::<TIM2, Ch2>::af_num(&*hall_b);
    let af_c = TimerPin::<TIM2, Ch3>::af_num(&*hall_c);
    for (pin, af) in
        [(Flex::new(hall_a), af_a), (Flex::new(hall_b), af_b), (Flex::new(hall_c), af_c)]
    {
        let mut pin = pin;
        pin.set_as_af_unchecked(af, AfType::input(Pull::None));
        core::mem::forget(pin);
    }
    // Enables TIM2's clock; the registers are written directly below.
    core::mem::forget(Timer::new(timer));

    let tim = pac::TIM2;
    tim.cr1().write_value(pac::timer::regs::Cr1Gp16(0));
    tim.psc().write_value(0);
    tim.arr().write_value(u32::MAX);
    // CR2.TI1S: TI1 is the XOR of CH1, CH2 and CH3.
    tim.cr2().write_value(pac::timer::regs::Cr2Gp16(1 << 7));
    // CC1S = 11: capture from TRC (the edge detector); IC1F = 1111: fDTS/32, 8 samples
    // (1.5 µs), far shorter than a sector (≥ 680 µs) and far longer than switching spikes.
    tim.ccmr_input(0).write_value(pac::timer::regs::CcmrInput2ch(0b11 | (0b1111 << 4)));
    // SMCR: TS = 00100 (TI1F_ED, every edge of the XOR), SMS = 0100 (reset mode).
    tim.smcr().write_value(pac::timer::regs::SmcrGp16((0b100 << 4) | 0b100));
    tim.ccer().write_value(pac::timer::regs::CcerGp16(1));
    tim.sr().write_value(pac::timer::regs::SrGp16(0));
    tim.dier().write_value(pac::timer::regs::DierGp16(SR_CC1IF));
    tim.cr1().write_value(pac::timer::regs::Cr1Gp16(1));

    if let Some(mut core) = cortex_m::Peripherals::take() {
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
    }
    LAST_CALL.store(DWT::cycle_count(), Ordering::Relaxed);
}

/// Unmasks the fast-loop interrupts at the highest priority.
pub fn start() {
    // SAFETY: the handlers below only touch TIM1/TIM2/ADC1 registers, GPIO input registers
    // and the critical-section-protected drive; nothing is borrowed across the unmask.
    unsafe {
        let mut nvic = cortex_m::Peripherals::steal().NVIC;
        nvic.set_priority(pac::Interrupt::TIM1_UP_TIM16, 0);
        nvic.set_priority(pac::Interrupt::TIM2, 0);
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::TIM1_UP_TIM16);
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::TIM2);
    }
}

/// The drive's status for the control tick.
pub fn status() -> DriveStatus {
    critical_section::with(|cs| DRIVE.borrow_ref(cs).as_ref().map(Drive::status))
        .unwrap_or_default()
}

/// Runs `apply` on the drive (the control tick's commands).
pub fn with_drive(apply: impl FnOnce(&mut Drive)) {
    critical_section::with(|cs| {
        if let Some(drive) = DRIVE.borrow_ref_mut(cs).as_mut() {
            apply(drive);
        }
    });
}

/// The mean of the current samples the fast loop read since the last call (the tick's
/// [`taut_core::io::Inputs::motor_current`]), rounded; zero before the first PWM period.
pub fn take_current_mean() -> AdcCode {
    let taken = CURRENT_SUM.swap(0, Ordering::Relaxed);
    let count = taken & ((1 << COUNT_BITS) - 1);
    let sum = taken >> COUNT_BITS;
    let mean = sum.saturating_add(count / 2).checked_div(count).unwrap_or(0);
    AdcCode::new(u16::try_from(mean).unwrap_or(u16::MAX))
}

/// One fast-loop call; `period` when it is the PWM period's (TIM1 update) rather than a Hall
/// edge's, so each period's current sample is summed once for the tick.
fn step(period: bool) {
    let now = DWT::cycle_count();
    let (elapsed, carry) = drive_time(now.wrapping_sub(LAST_CALL.load(Ordering::Relaxed)));
    LAST_CALL.store(now.wrapping_sub(carry), Ordering::Relaxed);
    // The injected conversion TIM1's channel 4 triggered mid on-time this period.
    let current = pac::ADC1.jdr(0).read().jdata();
    if period {
        CURRENT_SUM.fetch_add((u32::from(current) << COUNT_BITS) | 1, Ordering::Relaxed);
    }
    let sample = DriveSample {
        hall: hall(),
        current: AdcCode::new(current),
        // The break fired since the last call, or the comparator (active low) still trips.
        overcurrent_trip: bridge::take_break_flag() | !level(pins::OVERCURRENT),
        // The bus voltage ADC1 converts (hardware-averaged) at the period's quiet window.
        bus_voltage: AdcCode::new(pac::ADC1.dr().read().rdata()),
        limits: limits(),
        elapsed,
    };
    let (output, fault_latched) =
        critical_section::with(|cs| match DRIVE.borrow_ref_mut(cs).as_mut() {
            Some(drive) => (drive.step(sample), drive.fault().is_some()),
            None => (DriveOutput::OFF, true),
        });
    bridge::write_image(BridgeImage::for_output(output));
    // During a flash write the CPU may stall for a page erase: keep the bridge off then.
    bridge::set_main_output(main_output_enabled(fault_latched) && !store::flash_busy());
}

#[interrupt]
fn TIM1_UP_TIM16() {
    bridge::clear_update_flag();
    step(true);
}

#[interrupt]
fn TIM2() {
    pac::TIM2.sr().write_value(pac::timer::regs::SrGp16(!SR_CC1IF));
    step(false);
}

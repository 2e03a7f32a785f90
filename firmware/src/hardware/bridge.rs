//! TIM1: the three-phase bridge's complementary PWM, dead time and break input.
//!
//! Pins are claimed through embassy-stm32's typed constructors (so a pin without the TIM1
//! function does not compile); the timer itself is programmed at register level from the
//! images in [`taut_firmware::bridge`], because six-step needs per-leg forced states and
//! commutation events that no HAL PWM driver exposes. Channels 4 and 5 have no pins: their
//! compare events trigger the ADCs ([`taut_firmware::timing`]).

use embassy_stm32::Peri;
use embassy_stm32::gpio::{AfType, Flex, OutputType, Pull};
use embassy_stm32::pac;
use embassy_stm32::peripherals::{PA6, PA7, PA8, PA9, PA10, PB0, PB1, TIM1};
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::complementary_pwm::{ComplementaryPwm, ComplementaryPwmPin};
use embassy_stm32::timer::low_level::CountingMode;
use embassy_stm32::timer::simple_pwm::PwmPin;
use embassy_stm32::timer::{BkIn1, BreakInputPin};
use taut_firmware::bridge::{
    AF1, AUTO_RELOAD, BridgeImage, CR2, DEAD_TIME_REGISTER, MOE, PRESCALER, bdtr,
};
use taut_firmware::timing::{CCMR3, PWM_FREQUENCY_HZ, SLOW_SAMPLE_TICKS};

/// `TIMx_SR.BIF`, the break interrupt flag.
const SR_BIF: u32 = 1 << 7;
/// `TIMx_SR.UIF`, the update interrupt flag.
const SR_UIF: u32 = 1;
/// `TIMx_EGR.UG | TIMx_EGR.COMG`.
const EGR_UPDATE_AND_COMMUTATE: u32 = 1 | (1 << 5);
/// `TIMx_EGR.COMG`.
const EGR_COMMUTATE: u32 = 1 << 5;
/// `TIMx_DIER.UIE`.
const DIER_UIE: u32 = 1;
/// `TIMx_CR1`: `CEN = 1`, `ARPE = 1`, edge-aligned, up-counting.
const CR1_RUN: u32 = 1 | (1 << 7);

/// Claims the bridge pins, programs TIM1 with all gates off and `MOE = 0`, and starts the
/// counter. The update interrupt is enabled in the timer but left masked in the NVIC until
/// [`super::fast_loop::start`].
#[allow(clippy::too_many_arguments, reason = "one argument per bridge pin")]
#[inline(never)]
pub fn init(
    timer: Peri<'static, TIM1>,
    a_high: Peri<'static, PA8>,
    b_high: Peri<'static, PA9>,
    c_high: Peri<'static, PA10>,
    a_low: Peri<'static, PA7>,
    b_low: Peri<'static, PB0>,
    c_low: Peri<'static, PB1>,
    overcurrent: Peri<'static, PA6>,
) {
    let pwm = ComplementaryPwm::new(
        timer,
        Some(PwmPin::new(a_high, OutputType::PushPull)),
        Some(ComplementaryPwmPin::new(a_low, OutputType::PushPull)),
        Some(PwmPin::new(b_high, OutputType::PushPull)),
        Some(ComplementaryPwmPin::new(b_low, OutputType::PushPull)),
        Some(PwmPin::new(c_high, OutputType::PushPull)),
        Some(ComplementaryPwmPin::new(c_low, OutputType::PushPull)),
        None,
        None,
        Hertz(PWM_FREQUENCY_HZ),
        CountingMode::EdgeAlignedUp,
    );
    // The driver has enabled TIM1's clock and claimed the pins; from here on the registers
    // are written directly and the driver must not run its drop (which would stop the timer).
    core::mem::forget(pwm);

    let break_af = BreakInputPin::<TIM1, BkIn1>::af_num(&*overcurrent);
    let mut break_pin = Flex::new(overcurrent);
    break_pin.set_as_af_unchecked(break_af, AfType::input(Pull::Up));
    core::mem::forget(break_pin);

    let tim = pac::TIM1;
    tim.cr1().write_value(pac::timer::regs::Cr1Gp16(0));
    tim.psc().write_value(PRESCALER);
    tim.arr().write_value(pac::timer::regs::ArrCore(u32::from(AUTO_RELOAD)));
    tim.rcr().write_value(pac::timer::regs::RcrAdv(0));
    tim.cr2().write_value(pac::timer::regs::Cr2Adv(CR2));
    write_image(BridgeImage::off());
    // Channel 5 has no pin: its reference rises at the fixed slow-sample instant and, as
    // TRGO2, triggers the load-cell and bus-voltage conversions (`taut_firmware::timing`).
    tim.ccmr3().write_value(pac::timer::regs::Ccmr3Adv(CCMR3));
    tim.ccr5().write_value(pac::timer::regs::Ccr5Adv(u32::from(SLOW_SAMPLE_TICKS)));
    tim.af1().write_value(pac::timer::regs::Af1Adv(AF1));
    tim.bdtr().write_value(pac::timer::regs::BdtrAdv(bdtr(DEAD_TIME_REGISTER)));
    // Load every preloaded register now, then clear the flags that raised.
    tim.egr().write_value(pac::timer::regs::EgrAdv(EGR_UPDATE_AND_COMMUTATE));
    tim.sr().write_value(pac::timer::regs::SrAdv(0));
    tim.dier().write_value(pac::timer::regs::DierAdv(DIER_UIE));
    tim.cr1().write_value(pac::timer::regs::Cr1Gp16(CR1_RUN));
    taut_firmware::info!(
        "bridge: TIM1 at {} Hz, dead time DTG={=u8:#x}",
        PWM_FREQUENCY_HZ,
        DEAD_TIME_REGISTER
    );
}

/// Writes one register image: output modes and enables take effect together at the
/// commutation event generated here; compare values at the next update.
pub fn write_image(image: BridgeImage) {
    let tim = pac::TIM1;
    tim.ccmr_output(0).write_value(pac::timer::regs::CcmrOutputGp16(image.ccmr1));
    tim.ccmr_output(1).write_value(pac::timer::regs::CcmrOutputGp16(image.ccmr2));
    tim.ccer().write_value(pac::timer::regs::CcerAdv(image.ccer));
    for channel in 0..3 {
        tim.ccr(channel).write_value(pac::timer::regs::Ccr1ch(u32::from(image.compare)));
    }
    tim.ccr(3).write_value(pac::timer::regs::Ccr1ch(u32::from(image.current_sample)));
    tim.egr().write_value(pac::timer::regs::EgrAdv(EGR_COMMUTATE));
}

/// Sets or clears the main output enable. The hardware keeps `MOE` cleared while the break
/// input is active, whatever is written.
pub fn set_main_output(enabled: bool) {
    pac::TIM1.bdtr().modify(|bdtr| {
        bdtr.0 = (bdtr.0 & !MOE) | if enabled { MOE } else { 0 };
    });
}

/// Switches every gate off at once, from any context (panic, fault): clears `MOE`, so all
/// outputs go to their idle (off) levels.
pub fn emergency_off() {
    set_main_output(false);
}

/// Takes the break flag: whether the break input has fired since the last call. The flag is
/// cleared by writing 0 to it alone (the other flags are write-0-to-clear too, so they are
/// written as 1, which leaves them untouched).
pub fn take_break_flag() -> bool {
    let fired = pac::TIM1.sr().read().0 & SR_BIF != 0;
    pac::TIM1.sr().write_value(pac::timer::regs::SrAdv(!SR_BIF));
    fired
}

/// Clears the update interrupt flag (and nothing else).
pub fn clear_update_flag() {
    pac::TIM1.sr().write_value(pac::timer::regs::SrAdv(!SR_UIF));
}

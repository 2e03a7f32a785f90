//! The independent watchdog: resets the MCU if the control tick stops.
//!
//! IWDG counts down from the reload value at LSI (32 kHz) / 32 = 1 kHz and resets the chip
//! when it reaches zero (RM0440, section 42). The tick reloads it every millisecond; the
//! timeout is 100 ms, four times the longest flash page erase (during which nothing runs).
//! After a reset every GPIO is an input again and the gate drivers' input pulls hold the
//! bridge off. Programmed at register level: it is four writes.

use embassy_stm32::Peri;
use embassy_stm32::pac;
use embassy_stm32::peripherals::IWDG;

/// `IWDG_KR` keys: start, reload, unlock PR/RLR.
const KEY_START: u16 = 0xCCCC;
const KEY_RELOAD: u16 = 0xAAAA;
const KEY_UNLOCK: u16 = 0x5555;
/// `IWDG_PR = 3`: LSI / 32.
const PRESCALER_DIV32: u8 = 3;
/// Reload value: 100 counts of 1 ms.
const RELOAD: u16 = 100;

/// Starts the watchdog (it cannot be stopped again until reset).
pub fn start(_iwdg: Peri<'static, IWDG>) {
    let iwdg = pac::IWDG;
    iwdg.kr().write(|w| w.set_key(pac::iwdg::vals::Key::from_bits(KEY_START)));
    iwdg.kr().write(|w| w.set_key(pac::iwdg::vals::Key::from_bits(KEY_UNLOCK)));
    iwdg.pr().write(|w| w.set_pr(pac::iwdg::vals::Pr::from_bits(PRESCALER_DIV32)));
    iwdg.rlr().write(|w| w.set_rl(RELOAD));
    iwdg.kr().write(|w| w.set_key(pac::iwdg::vals::Key::from_bits(KEY_RELOAD)));
}

/// Reloads the countdown.
pub fn pet() {
    pac::IWDG.kr().write(|w| w.set_key(pac::iwdg::vals::Key::from_bits(KEY_RELOAD)));
}

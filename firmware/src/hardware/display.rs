//! The TM1637 panel on PB5 (clock) and PB9 (data), refreshed from thread mode.
//!
//! The control tick publishes the core's display and lamps every millisecond through
//! [`PANEL`]; [`refresher`] shows the newest each time it finishes the previous transfer
//! (≈ 1.2 ms of bit-banging at 100 kHz), so the panel lags the machine by at most ~2 ms and
//! the bit-banging never runs inside an interrupt. Since a transfer outlasts a tick, a new
//! state is always waiting; the refresher yields after each transfer so that the executor's
//! other task, the settings writer, still runs.

use embassy_stm32::Peri;
use embassy_stm32::gpio::{Level, OutputOpenDrain, Speed};
use embassy_stm32::peripherals::{PB5, PB9};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use embedded_hal::delay::DelayNs;
use taut_core::io::{Display, Leds};
use taut_firmware::panel::{Brightness, Tm1637};

use super::SYSCLK_HZ;

/// The newest display contents from the control tick.
pub static PANEL: Signal<CriticalSectionRawMutex, (Display, Leds)> = Signal::new();

/// A busy-wait delay counted in CPU cycles.
struct CycleDelay;

impl DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        // 170 cycles per µs; round up so a delay is never short.
        let cycles = u64::from(ns).saturating_mul(u64::from(SYSCLK_HZ / 1_000_000)).div_ceil(1_000);
        cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX));
    }
}

/// Shows every published panel state.
#[embassy_executor::task]
pub async fn refresher(clock: Peri<'static, PB5>, data: Peri<'static, PB9>) {
    let clock = OutputOpenDrain::new(clock, Level::High, Speed::Low);
    let data = OutputOpenDrain::new(data, Level::High, Speed::Low);
    let mut panel = Tm1637::new(clock, data, CycleDelay);
    loop {
        let (display, leds) = PANEL.wait().await;
        if panel.show(&display, leds, Brightness::MAX).is_err() {
            taut_firmware::warn!("panel: TM1637 did not acknowledge");
        }
        // A transfer takes longer than a tick, so the next panel state is always waiting
        // and `wait` never suspends: without this yield the refresher would hold the
        // executor for good and the settings writer would never run (found on the emulated
        // part, `pil/`).
        embassy_futures::yield_now().await;
    }
}

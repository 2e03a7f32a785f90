//! The 1 kHz control tick: sample → `Inputs` → machine → `Outputs` → peripherals.
//!
//! TIM6 (a basic timer: 170 MHz / 170 / 1 000) interrupts every millisecond at priority 1,
//! below the fast loop, which may preempt it at any point. The tick reads the analogue
//! channels (ADC2, software-started, hardware oversampled), the string counter (TIM4 in
//! encoder mode), the limit switches and keys (GPIO), and the drive's status; hands the
//! machine one [`Inputs`]; and applies the [`Outputs`]: the drive command (and a fault-clear
//! request) to the drive, the beeper to its pin, the display to the panel task, the record to
//! the store task.

use core::cell::RefCell;
use critical_section::Mutex;
use embassy_stm32::Peri;
use embassy_stm32::adc::{Adc, AdcConfig, Rovsm, SampleTime, Trovs};
use embassy_stm32::gpio::{Input, Level, Output, Pull, Speed};
use embassy_stm32::pac;
use embassy_stm32::pac::interrupt;
use embassy_stm32::peripherals::{
    ADC1, ADC2, PA0, PB6, PB7, PB11, PB15, PC6, PC7, PC8, PC10, PC11, PC12, PD2, TIM4, TIM6,
};
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::timer::qei::{Config as QeiConfig, Qei};
use static_cell::StaticCell;
use taut_core::io::{Inputs, Keys};
use taut_core::machine::Machine;
use taut_core::store::{Record, StoreError};
use taut_core::units::AdcCode;

use super::{display, fast_loop, store};

/// ADC1 channel of the bus current (PA0 = ADC1_IN1).
const CURRENT_CHANNEL: u8 = 1;
/// ADC1 injected trigger `JEXTSEL` = TIM1_CC4 event (RM0440, table "ADC1/2 - External
/// triggers for injected channels").
const JEXTSEL_TIM1_CC4: u8 = 1;
/// `TIMx_DIER.UIE` / `TIMx_SR.UIF`.
const UPDATE: u32 = 1;

/// The analogue inputs.
pub struct Analog {
    adc2: Adc<'static, ADC2>,
    load_cell: Peri<'static, PB15>,
    current: Peri<'static, PA0>,
}

impl Analog {
    /// Calibrates both ADCs. ADC1 converts the bus current as an injected channel on every
    /// TIM1 channel-4 compare (mid on-time, see `taut_firmware::bridge`), for the fast loop;
    /// ADC2 converts on demand for the tick, averaging 16 conversions in hardware
    /// (oversampling ratio 16, shift 4: still a 12-bit code).
    pub fn new(
        adc1: Peri<'static, ADC1>,
        adc2: Peri<'static, ADC2>,
        current: Peri<'static, PA0>,
        load_cell: Peri<'static, PB15>,
    ) -> Self {
        // Calibrates and enables ADC1; the injected group is then set up at register level
        // (the driver has no drop, so ADC1 stays enabled).
        let _calibrated = Adc::new(adc1, AdcConfig::default());
        pac::ADC1
            .smpr()
            .modify(|w| w.set_smp(usize::from(CURRENT_CHANNEL), SampleTime::CYCLES24_5));
        pac::ADC1.jsqr().write(|w| {
            w.set_jl(0);
            w.set_jsq(0, CURRENT_CHANNEL);
            w.set_jextsel(JEXTSEL_TIM1_CC4);
            w.set_jexten(pac::adc::vals::Exten::RISING_EDGE);
        });
        pac::ADC1.cr().modify(|w| w.set_jadstart(true));

        let config = AdcConfig {
            oversampling_ratio: Some(3),
            oversampling_shift: Some(4),
            oversampling_mode: Some((Rovsm::CONTINUED, Trovs::AUTOMATIC, true)),
            ..AdcConfig::default()
        };
        let adc2 = Adc::new(adc2, config);
        Self { adc2, load_cell, current }
    }

    fn load_cell(&mut self) -> AdcCode {
        // The divider's ≈ 11 kΩ source needs a long sample time (5.8 µs at 42.5 MHz).
        AdcCode::new(self.adc2.blocking_read(&mut self.load_cell, SampleTime::CYCLES247_5))
    }

    fn motor_current(&mut self) -> AdcCode {
        AdcCode::new(self.adc2.blocking_read(&mut self.current, SampleTime::CYCLES24_5))
    }
}

/// The key pins: Start, Up, Down, Function, Preset.
pub type KeyPins = (
    Peri<'static, PC6>,
    Peri<'static, PC7>,
    Peri<'static, PC8>,
    Peri<'static, PC12>,
    Peri<'static, PD2>,
);

/// What the tick owns.
pub struct Resources {
    /// The analogue inputs.
    pub analog: Analog,
    /// TIM4 and the encoder's A and B pins.
    pub encoder: (Peri<'static, TIM4>, Peri<'static, PB6>, Peri<'static, PB7>),
    /// Home and end limit switches.
    pub limits: (Peri<'static, PC10>, Peri<'static, PC11>),
    /// Start, Up, Down, Function, Preset.
    pub keys: KeyPins,
    /// The beeper output.
    pub beeper: Peri<'static, PB11>,
    /// The tick's timer.
    pub tick_timer: Peri<'static, TIM6>,
    /// The record loaded from flash, or why none could be.
    pub record: Result<Record, StoreError>,
}

struct Tick {
    machine: Machine,
    analog: Analog,
    encoder: Qei<'static, TIM4>,
    keys: [Input<'static>; 5],
    beeper: Output<'static>,
    now_ms: u32,
}

impl Tick {
    fn keys(&self) -> Keys {
        // Key::ALL order (Start, Up, Down, Function, Preset) is Keys' bit order; pressed = low.
        let bits = self
            .keys
            .iter()
            .enumerate()
            .fold(0u8, |bits, (index, key)| bits | (u8::from(key.is_low()) << index));
        Keys::from_bits(bits)
    }

    fn run(&mut self) {
        super::watchdog::pet();
        self.now_ms = self.now_ms.wrapping_add(1);
        let inputs = Inputs {
            now_ms: self.now_ms,
            load_cell: self.analog.load_cell(),
            motor_current: self.analog.motor_current(),
            drive: fast_loop::status(),
            string_counter: self.encoder.count(),
            limits: fast_loop::limits(),
            keys: self.keys(),
        };
        let outputs = self.machine.tick(&inputs);
        fast_loop::with_drive(|drive| {
            drive.set_command(outputs.drive);
            if outputs.clear_drive_fault {
                // A refusal leaves the fault latched; the machine sees it in the next status.
                let _refused = drive.clear_fault();
            }
        });
        self.beeper.set_level(Level::from(outputs.beeper));
        display::PANEL.signal((outputs.display, outputs.leds));
        if outputs.store {
            store::REQUEST.signal(self.machine.record().encode());
        }
    }
}

/// The tick's state (in its own static, placed by [`init`]), handed to the interrupt handler
/// on its first run.
static TICK: Mutex<RefCell<Option<&'static mut Tick>>> = Mutex::new(RefCell::new(None));

/// Claims the tick's peripherals, builds the machine from the stored record and programs
/// TIM6 for 1 kHz. The interrupt stays masked until [`start`].
pub fn init(resources: Resources) {
    let Resources { analog, encoder, limits, keys, beeper, tick_timer, record } = resources;
    let qei_config = QeiConfig { ch1_pull: Pull::Up, ch2_pull: Pull::Up, ..QeiConfig::default() };
    let encoder = Qei::new(encoder.0, encoder.1, encoder.2, qei_config);
    // The limit switches are read by the fast loop straight from the input registers.
    core::mem::forget(Input::new(limits.0, Pull::Up));
    core::mem::forget(Input::new(limits.1, Pull::Up));
    let keys = [
        Input::new(keys.0, Pull::Up),
        Input::new(keys.1, Pull::Up),
        Input::new(keys.2, Pull::Up),
        Input::new(keys.3, Pull::Up),
        Input::new(keys.4, Pull::Up),
    ];
    let beeper = Output::new(beeper, Level::Low, Speed::Low);
    // One static copy of the state, built in place (`init_with` writes the closure's value
    // straight into the cell, so the ≈ 1.3 KB machine is not staged on the start-up stack).
    static CELL: StaticCell<Tick> = StaticCell::new();
    let tick = CELL.init_with(|| Tick {
        machine: Machine::from_stored(record),
        analog,
        encoder,
        keys,
        beeper,
        now_ms: 0,
    });
    critical_section::with(|cs| *TICK.borrow_ref_mut(cs) = Some(tick));

    core::mem::forget(Timer::new(tick_timer));
    let tim = pac::TIM6;
    tim.psc().write_value(169);
    tim.arr().write_value(pac::timer::regs::ArrCore(999));
    tim.egr().write_value(pac::timer::regs::EgrCore(UPDATE));
    tim.sr().write_value(pac::timer::regs::SrCore(0));
    tim.dier().write_value(pac::timer::regs::DierBasicNoCr2(UPDATE));
    tim.cr1().write_value(pac::timer::regs::Cr1Core(1));
}

/// Unmasks the tick interrupt at priority 1 (below the fast loop).
pub fn start() {
    // SAFETY: the handler touches only TIM6's status register, the state it owns and the
    // critical-section-protected drive; priority 1 (0x10 with four priority bits) keeps the
    // fast loop able to preempt it.
    unsafe {
        let mut nvic = cortex_m::Peripherals::steal().NVIC;
        nvic.set_priority(pac::Interrupt::TIM6_DAC, 1 << 4);
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::TIM6_DAC);
    }
}

#[interrupt]
fn TIM6_DAC() {
    static mut STATE: Option<&'static mut Tick> = None;
    pac::TIM6.sr().write_value(pac::timer::regs::SrCore(0));
    if STATE.is_none() {
        *STATE = critical_section::with(|cs| TICK.borrow_ref_mut(cs).take());
    }
    if let Some(tick) = STATE.as_mut() {
        tick.run();
    }
}

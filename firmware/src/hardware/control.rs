//! The 1 kHz control tick: sample → `Inputs` → machine → `Outputs` → peripherals.
//!
//! TIM6 (a basic timer: 170 MHz / 170 / 1 000) interrupts every millisecond at priority 1,
//! below the fast loop, which may preempt it at any point. The tick reads finished results
//! only — the analogue values the ADCs converted on TIM1's triggers and averaged
//! ([`Analog`], timing in `taut_firmware::timing`), the string counter (TIM4 in encoder mode),
//! the limit switches and keys (GPIO), and the drive's status — hands the machine one
//! [`Inputs`], and applies the [`Outputs`]: the drive command (and a fault-clear request) to the
//! drive, the beeper to its pin, the display to the panel task, and a copy of the record to the
//! store task, which encodes and writes it in thread mode. Then, last, it serves the machine
//! link ([`link`]) with that tick's inputs and outputs.

use core::cell::RefCell;
use critical_section::Mutex;
use embassy_stm32::Peri;
use embassy_stm32::adc::{Adc, AdcChannel, AdcConfig, Presc, Rovsm, SampleTime, Trovs};
use embassy_stm32::gpio::{Input, Level, Output, Pull, Speed};
use embassy_stm32::pac;
use embassy_stm32::pac::adc::vals::{Exten, Ovrmod};
use embassy_stm32::pac::interrupt;
use embassy_stm32::peripherals::{
    ADC1, ADC2, PA0, PA1, PB6, PB7, PB11, PB15, PC6, PC7, PC8, PC10, PC11, PC12, PD2, TIM4, TIM6,
};
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::timer::qei::{Config as QeiConfig, Qei};
use static_cell::StaticCell;
use taut_core::board::BoardConfig;
use taut_core::io::{Inputs, Keys};
use taut_core::machine::Machine;
use taut_core::store::{Record, StoreError};
use taut_core::units::AdcCode;
use taut_firmware::timing::OVERSAMPLING_SHIFT;

use super::{display, fast_loop, link, store};

/// ADC1 channel of the bus current (PA0 = ADC1_IN1).
const CURRENT_CHANNEL: u8 = 1;
/// ADC1 channel of the bus voltage (PA1 = ADC1_IN2).
const BUS_VOLTAGE_CHANNEL: u8 = 2;
/// ADC2 channel of the load cell (PB15 = ADC2_IN15).
const LOAD_CELL_CHANNEL: u8 = 15;
/// ADC1 injected trigger `JEXTSEL` = TIM1_CC4 event (RM0440, table "ADC1/2 - External
/// triggers for injected channels").
const JEXTSEL_TIM1_CC4: u8 = 1;
/// ADC1/2 regular trigger `EXTSEL` = TIM1_TRGO2 (RM0440, table "ADC1/2 - External triggers
/// for regular channels": `EXTSEL = 01010`).
const EXTSEL_TIM1_TRGO2: u8 = 0b01010;
/// Every channel's sampling time: 24.5 ADC clocks (`taut_firmware::timing::SAMPLE_HALF_CLOCKS`).
const SAMPLE_TIME: SampleTime = SampleTime::CYCLES24_5;
/// `OVSR`: `n` means 2ⁿ⁺¹ conversions per result, so 16 conversions (shift 4) is `OVSR = 3`.
const OVERSAMPLING_RATIO: u8 = OVERSAMPLING_SHIFT.saturating_sub(1);
/// `TIMx_DIER.UIE` / `TIMx_SR.UIF`.
const UPDATE: u32 = 1;

/// The analogue inputs, converted by hardware on TIM1's triggers (`taut_firmware::timing`):
///
/// - ADC1 injected: the bus current at mid on-time every PWM period, read by the fast loop,
///   which also sums it for the tick's mean;
/// - ADC1 regular: the bus voltage (PA1), and ADC2 regular: the load cell (PB15), both on
///   TRGO2 in the quiet end of every PWM period, each oversampled 16× in triggered mode, so
///   the data register always holds the mean of the last 16 periods' samples.
///
/// Reading never starts a conversion and never waits.
pub struct Analog {
    _private: (),
}

/// Sets up one ADC's regular group: a single `channel`, converted on every TIM1 TRGO2 rising
/// edge, oversampled 16× with one conversion per trigger, the data register overwritten by
/// each new result (nothing reads it by DMA, so an unread result is simply superseded).
fn slow_regular_group(adc: pac::adc::Adc, channel: u8) {
    if channel <= 9 {
        adc.smpr().modify(|w| w.set_smp(usize::from(channel), SAMPLE_TIME));
    } else {
        adc.smpr2().modify(|w| w.set_smp(usize::from(channel.saturating_sub(10)), SAMPLE_TIME));
    }
    adc.sqr1().write(|w| {
        w.set_l(0);
        w.set_sq(0, channel);
    });
    adc.cfgr2().modify(|w| {
        w.set_ovsr(OVERSAMPLING_RATIO);
        w.set_ovss(OVERSAMPLING_SHIFT);
        w.set_trovs(Trovs::TRIGGERED);
        // An injected conversion (ADC1's current) pauses the accumulation and it continues.
        w.set_rovsm(Rovsm::CONTINUED);
        w.set_rovse(true);
    });
    adc.cfgr().modify(|w| {
        w.set_cont(false);
        w.set_extsel(EXTSEL_TIM1_TRGO2);
        w.set_exten(Exten::RISING_EDGE);
        w.set_ovrmod(Ovrmod::OVERWRITE);
    });
    adc.cr().modify(|w| w.set_adstart(true));
}

impl Analog {
    /// Calibrates both ADCs (embassy-stm32 runs the G4's self-calibration and enables them),
    /// puts the three pins in analogue mode, and sets up the conversions: ADC1's injected
    /// current on TIM1 channel 4, ADC1's and ADC2's regular groups on TRGO2. The conversions
    /// start with TIM1's triggers. Not inlined, so its frame is not part of the start-up's.
    #[inline(never)]
    pub fn new(
        adc1: Peri<'static, ADC1>,
        adc2: Peri<'static, ADC2>,
        current: Peri<'static, PA0>,
        bus_voltage: Peri<'static, PA1>,
        load_cell: Peri<'static, PB15>,
    ) -> Self {
        // The drivers have no drop, so both ADCs stay calibrated and enabled; from here on
        // they are programmed at register level (embassy-stm32 has no triggered oversampling).
        let _adc1 = Adc::new(adc1, AdcConfig::default());
        let _adc2 = Adc::new(adc2, AdcConfig::default());
        // Analogue mode for the three pins (the channel handles carry nothing else).
        let _current = AdcChannel::<ADC1>::degrade_adc(current);
        let _bus_voltage = AdcChannel::<ADC1>::degrade_adc(bus_voltage);
        let _load_cell = AdcChannel::<ADC2>::degrade_adc(load_cell);

        let adc1 = pac::ADC1;
        adc1.smpr().modify(|w| w.set_smp(usize::from(CURRENT_CHANNEL), SAMPLE_TIME));
        adc1.jsqr().write(|w| {
            w.set_jl(0);
            w.set_jsq(0, CURRENT_CHANNEL);
            w.set_jextsel(JEXTSEL_TIM1_CC4);
            w.set_jexten(Exten::RISING_EDGE);
        });
        adc1.cr().modify(|w| w.set_jadstart(true));
        slow_regular_group(adc1, BUS_VOLTAGE_CHANNEL);
        slow_regular_group(pac::ADC2, LOAD_CELL_CHANNEL);
        // The sampling instants assume a 42.5 MHz ADC clock (SYSCLK / 4, which embassy-stm32
        // chooses for a 170 MHz kernel clock): say so if it ever chose otherwise.
        if pac::ADC12_COMMON.ccr().read().presc() != Presc::DIV4 {
            taut_firmware::error!("ADC clock is not SYSCLK / 4: sampling instants are off");
        }
        Self { _private: () }
    }

    /// The load-cell code: the mean of the last 16 periods' quiet-window samples.
    fn load_cell(&self) -> AdcCode {
        AdcCode::new(pac::ADC2.dr().read().rdata())
    }

    /// The motor current code: the mean of this tick's mid-on-time samples.
    fn motor_current(&self) -> AdcCode {
        fast_loop::take_current_mean()
    }

    /// The DC bus voltage code: the mean of the last 16 periods' quiet-window samples of PA1,
    /// the X-NUCLEO-IHM08M1's bus divider (gain 0.0522: a code is 3.3 V / 4096 / 0.0522 =
    /// 15.4 mV of bus; full scale 63.2 V). Referred to the 3.3 V converter, unlike the 5 V
    /// meaning of the load cell's and current's codes (`firmware/README.md`).
    pub fn bus_voltage(&self) -> AdcCode {
        AdcCode::new(pac::ADC1.dr().read().rdata())
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
    /// The machine, built from the stored record ([`build_machine`]).
    pub machine: &'static mut Machine,
    /// The machine link, served after each tick's outputs.
    pub link: link::Link,
}

struct Tick {
    machine: &'static mut Machine,
    analog: Analog,
    encoder: Qei<'static, TIM4>,
    keys: [Input<'static>; 5],
    beeper: Output<'static>,
    link: link::Link,
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
            bus_voltage: self.analog.bus_voltage(),
            drive: fast_loop::status(),
            string_counter: self.encoder.count(),
            limits: fast_loop::limits(),
            keys: self.keys(),
        };
        let outputs = self.machine.tick(&inputs);
        fast_loop::with_drive(|drive| {
            // A refused clear leaves the fault latched; the machine sees it in the next status.
            let _refused = drive.apply(outputs.drive, outputs.clear_drive_fault);
        });
        self.beeper.set_level(Level::from(outputs.beeper));
        display::PANEL.signal((outputs.display, outputs.leds));
        if outputs.store {
            // A copy of the record; the store task encodes it (≈ 4 000 instructions) and writes
            // it in thread mode, never on the tick.
            store::REQUEST.signal(*self.machine.record());
        }
        // Last: the link, after every output is applied (it never delays them).
        self.link.service(self.machine, &inputs, &outputs);
    }
}

/// The tick's state (in its own static, placed by [`init`]), handed to the interrupt handler
/// on its first run.
static TICK: Mutex<RefCell<Option<&'static mut Tick>>> = Mutex::new(RefCell::new(None));

/// The machine on `board`, built from the stored record into its static. Not inlined, so the
/// construction's temporaries (`taut-core` builds the chart and the machine on the stack and
/// then moves them: ≈ 3.7 KB, the deepest start-up path of `scripts/firmware-size`) are below
/// the start-up function's small frame, not in it.
#[inline(never)]
pub fn build_machine(
    record: Result<Record, StoreError>,
    board: &BoardConfig,
) -> &'static mut Machine {
    static MACHINE: StaticCell<Machine> = StaticCell::new();
    MACHINE.init_with(|| Machine::from_stored(record, board))
}

/// Claims the tick's peripherals, takes the machine and programs TIM6 for 1 kHz. The
/// interrupt stays masked until [`start`]. Not inlined into the start-up (see
/// [`build_machine`]).
#[inline(never)]
pub fn init(resources: Resources) {
    let Resources { analog, encoder, limits, keys, beeper, tick_timer, machine, link } = resources;
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
    static CELL: StaticCell<Tick> = StaticCell::new();
    let tick = CELL.init(Tick { machine, analog, encoder, keys, beeper, link, now_ms: 0 });
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

//! The binding: NUCLEO-G431RB + X-NUCLEO-IHM08M1 peripherals ↔ taut-core.
//!
//! # Theory of operation
//!
//! Three execution contexts, by NVIC priority (the G431 has four priority bits; lower number
//! = more urgent):
//!
//! | context | trigger | rate | does |
//! |---|---|---|---|
//! | fast loop, priority 0 | TIM1 update (`TIM1_UP_TIM16`) and Hall edge capture (`TIM2`) | 20 kHz + every Hall edge | sample → [`taut_core::drive::Drive::step`] → TIM1 registers ([`fast_loop`]) |
//! | control tick, priority 1 | TIM6 update (`TIM6_DAC`) | 1 kHz | sample → [`taut_core::io::Inputs`] → machine → [`taut_core::io::Outputs`] → peripherals ([`control`]); then the machine link's bytes, moved by DMA ([`link`]) |
//! | thread mode | embassy executor | when signalled | settings store writes, TM1637 refresh ([`store`], [`display`]) |
//!
//! The hardware protections need no software at all: the overcurrent comparator's break
//! input clears TIM1's main output enable in nanoseconds, and the dead-time generator keeps
//! every leg's switches apart.
//!
//! # Why embassy (and not RTIC 2)
//!
//! The two real-time loops are plain hardware interrupts at fixed priorities — they share
//! exactly one object (the [`taut_core::drive::Drive`], behind a critical section held for a
//! few hundred cycles), which is all RTIC's resource analysis would have managed. What is
//! left is slow, blocking work that must never delay those loops: a flash write (a page erase
//! stalls the CPU for ~22 ms) and a bit-banged display. sequential-storage is async-first, so
//! an async executor in thread mode runs it directly, woken by embassy-sync signals from the
//! tick, with no block-on loop and no second framework; embassy-stm32 is the maintained HAL
//! for the G4 (clocks, flash driver, ADC calibration, typed pin functions) either way.
//!
//! Nothing here decides anything about the machine: each branch below is about hardware
//! (interrupt flags, pin levels, start-up order).
#![allow(
    unsafe_code,
    reason = "the binding unmasks interrupts and sets their priorities (cortex-m's NVIC calls \
              are unsafe); each use states why it is sound"
)]

mod bridge;
mod control;
mod display;
mod fast_loop;
mod link;
mod store;
mod watchdog;

use defmt_rtt as _;
use embassy_executor::{Executor, Spawner};
use embassy_stm32::peripherals::{IWDG, PB5, PB9};
use embassy_stm32::rcc::{Pll, PllMul, PllPreDiv, PllRDiv, PllSource, Sysclk, mux::Adcsel};
use embassy_stm32::{Config, Peri};
use static_cell::StaticCell;
use taut_firmware::timing::PWM_TIMER_HZ;

/// The system clock: HSI16 / 4 × 85 / 2 = 170 MHz. TIM1 and the DWT cycle counter both run
/// at it, so it must equal the board timing's [`PWM_TIMER_HZ`].
pub const SYSCLK_HZ: u32 = 170_000_000;

const _: () = assert!(
    SYSCLK_HZ == PWM_TIMER_HZ,
    "TIM1 and the cycle counter must run at the board timing's clock"
);

/// Clocks up and the peripherals claimed. Not inlined: the clock tree's arithmetic takes
/// ≈ 0.9 KB of stack, which must not sit under the machine's construction in [`start_up`].
#[inline(never)]
fn peripherals() -> embassy_stm32::Peripherals {
    range_one_boost();
    embassy_stm32::init(clocks())
}

/// Puts the main regulator in range 1 boost mode, which 170 MHz needs (RM0440 section 6.1.5:
/// above 150 MHz; the sequence wants it before the clock is raised, which `embassy_stm32::init`
/// does next). embassy-stm32's own `boost` setting writes `PWR_CR5` through stm32-metapac,
/// which places `R1MODE` at bit 0; RM0440 (section 6.4.5, reset value 0x0000 0100) has it at
/// bit 8, so that write leaves the regulator in normal mode, where 170 MHz is out of
/// specification. The emulated part's clock model (`pil/`) found it. The PWR interface needs
/// its bus clock for the write.
fn range_one_boost() {
    /// `RCC_APB1ENR1.PWREN`.
    const PWREN: u32 = 1 << 28;
    embassy_stm32::pac::RCC.apb1enr1().modify(|w| w.0 |= PWREN);
    // R1MODE (bit 8) = 0: boost; every other bit of PWR_CR5 is reserved (reset 0).
    embassy_stm32::pac::PWR.cr5().write_value(embassy_stm32::pac::pwr::regs::Cr5(0));
}

fn clocks() -> Config {
    let mut config = Config::default();
    config.rcc.pll = Some(Pll {
        source: PllSource::HSI,
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL85,
        divp: None,
        divq: None,
        divr: Some(PllRDiv::DIV2),
    });
    config.rcc.sys = Sysclk::PLL1_R;
    config.rcc.boost = true;
    // The ADCs run from the system clock, divided by 4 in the ADC (42.5 MHz).
    config.rcc.mux.adc12sel = Adcsel::SYS;
    config
}

/// The entry: [`start_up`] (synchronous, interrupts masked), then the executor in its static
/// runs the two thread-mode tasks for good.
///
/// Not `#[embassy_executor::main]`: that macro keeps the executor on this function's stack
/// and runs the start-up as a task, so the machine's construction (the deepest stack of the
/// start-up, see `control::build_machine`) would sit under the executor's frame and the
/// task's poll. Here it sits under this small frame only, and the executor's loop under the
/// same frame once the start-up has returned.
#[cortex_m_rt::entry]
fn main() -> ! {
    let loops = start_up();
    static EXECUTOR: StaticCell<Executor> = StaticCell::new();
    EXECUTOR.init(Executor::new()).run(move |spawner| run(spawner, loops))
}

/// What the start-up hands the executor: the thread-mode tasks' resources and the loops to
/// start once they are spawned.
struct Loops {
    store: Option<&'static mut store::Store>,
    display: (Peri<'static, PB5>, Peri<'static, PB9>),
    watchdog: Peri<'static, IWDG>,
}

/// Start-up, synchronously, before any interrupt is unmasked: clocks, bridge off, the record
/// from flash, the machine, the peripherals.
///
/// The record is read with [`store::read`], which polls the async store to completion on the
/// stack. Not inlined, so its frame is not under the executor's loop.
#[inline(never)]
fn start_up() -> Loops {
    let p = peripherals();
    taut_firmware::info!("taut-firmware: clocks up, binding peripherals");

    // Bridge first, with every gate off and the main output disabled, so no later step can
    // find the power stage in an undefined state.
    bridge::init(p.TIM1, p.PA8, p.PA9, p.PA10, p.PA7, p.PB0, p.PB1, p.PA6);

    // The record comes back from flash, and the machine is built from it, first: the
    // machine's construction is the deepest stack of the start-up (see `control::build_machine`).
    let (settings, record) = store::read(p.FLASH);
    // A refused board never reaches an image (`the_board_is_valid`); were it to, the bridge
    // stays off as `bridge::init` left it and the part waits for a reset.
    let Ok(board) = taut_firmware::board::board() else { refused_board() };
    let machine = control::build_machine(record, &board);

    let analog = control::Analog::new(p.ADC1, p.ADC2, p.PA0, p.PA1, p.PB15);
    fast_loop::init(board.drive(), p.TIM2, p.PA15, p.PB3, p.PB10);
    control::init(control::Resources {
        analog,
        encoder: (p.TIM4, p.PB6, p.PB7),
        limits: (p.PC10, p.PC11),
        keys: (p.PC6, p.PC7, p.PC8, p.PC12, p.PD2),
        beeper: p.PB11,
        tick_timer: p.TIM6,
        machine,
        link: link::Link::init(p.PA2, p.PA3),
    });
    Loops { store: settings, display: (p.PB5, p.PB9), watchdog: p.IWDG }
}

/// The executor's first call: the tasks, the watchdog, the loops.
#[inline(never)]
fn run(spawner: Spawner, loops: Loops) {
    let Loops { store, display, watchdog } = loops;
    // Each task's pool holds one task and each is spawned once, so spawning cannot fail.
    match store::writer(store) {
        Ok(task) => spawner.spawn(task),
        Err(_) => taut_firmware::error!("settings writer not started"),
    }
    match display::refresher(display.0, display.1) {
        Ok(task) => spawner.spawn(task),
        Err(_) => taut_firmware::error!("panel refresher not started"),
    }

    // The watchdog resets the MCU if the control tick stops petting it; a reset returns the
    // bridge pins to inputs, which the gate drivers' input pulls hold off.
    watchdog::start(watchdog);

    // Start the loops: fast loop first (it owns the bridge), then the control tick.
    fast_loop::start();
    control::start();
    taut_firmware::info!("taut-firmware: running");
}

/// On a panic: bridge off first, then report, then stop. The panic's message and location
/// are deliberately not read: touching them links core's formatting machinery (≈ 11 KB of
/// flash); a debugger shows where the core stopped.
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    cortex_m::interrupt::disable();
    bridge::emergency_off();
    defmt::error!("panic; bridge off");
    loop {
        cortex_m::asm::wfe();
    }
}

/// A board the firmware refuses to run: bridge off, then stop (no interrupt is unmasked yet).
#[inline(never)]
fn refused_board() -> ! {
    bridge::emergency_off();
    defmt::error!("board refused; bridge off");
    loop {
        cortex_m::asm::wfe();
    }
}

/// On a hard fault (bus error, bad instruction): bridge off, then stop.
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    bridge::emergency_off();
    loop {
        cortex_m::asm::wfe();
    }
}

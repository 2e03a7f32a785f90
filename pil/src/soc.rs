//! The STM32G431's peripherals as the firmware sees them, at register level (RM0440).
//!
//! Every register the firmware may touch is listed here with its reset value and its
//! behaviour; an access to any other address in a peripheral region stops the run with the
//! address and its name ([`Stop::Unmodelled`]), so nothing the image does is silently ignored.
//! Time is the CPU's clock (170 MHz after the firmware's clock set-up; the bench counts one
//! cycle per executed instruction, see `README.md`), and every timer, converter and watchdog
//! below is a function of it.

use std::collections::BTreeMap;
use std::fmt;

/// The G431's peripheral regions (RM0440, table "STM32G4 series memory map"), for naming
/// any access.
pub const REGIONS: &[(u32, u32, &str)] = &[
    (0x4000_0000, 0x400, "TIM2"),
    (0x4000_0400, 0x400, "TIM3"),
    (0x4000_0800, 0x400, "TIM4"),
    (0x4000_1000, 0x400, "TIM6"),
    (0x4000_1400, 0x400, "TIM7"),
    (0x4000_2400, 0x400, "CRS"),
    (0x4000_2800, 0x400, "TAMP"),
    (0x4000_2C00, 0x400, "WWDG"),
    (0x4000_3000, 0x400, "IWDG"),
    (0x4000_3800, 0x400, "SPI2"),
    (0x4000_3C00, 0x400, "SPI3"),
    (0x4000_4400, 0x400, "USART2"),
    (0x4000_4800, 0x400, "USART3"),
    (0x4000_5400, 0x400, "I2C1"),
    (0x4000_5800, 0x400, "I2C2"),
    (0x4000_6000, 0x400, "USB"),
    (0x4000_6400, 0x400, "FDCAN1"),
    (0x4000_7000, 0x400, "PWR"),
    (0x4000_8000, 0x400, "LPTIM1"),
    (0x4000_8400, 0x400, "LPUART1"),
    (0x4000_A400, 0x400, "FDCAN config"),
    (0x4000_A800, 0x400, "FDCAN RAM"),
    (0x4001_0000, 0x30, "SYSCFG"),
    (0x4001_0030, 0x100, "VREFBUF"),
    (0x4001_0200, 0x200, "COMP/OPAMP"),
    (0x4001_0400, 0x400, "EXTI"),
    (0x4001_2C00, 0x400, "TIM1"),
    (0x4001_3000, 0x400, "SPI1"),
    (0x4001_3400, 0x400, "TIM8"),
    (0x4001_3800, 0x400, "USART1"),
    (0x4001_4000, 0x400, "TIM15"),
    (0x4001_4400, 0x400, "TIM16"),
    (0x4001_4800, 0x400, "TIM17"),
    (0x4001_5400, 0x400, "SAI1"),
    (0x4002_0000, 0x400, "DMA1"),
    (0x4002_0400, 0x400, "DMA2"),
    (0x4002_0800, 0x400, "DMAMUX"),
    (0x4002_1000, 0x400, "RCC"),
    (0x4002_2000, 0x400, "FLASH"),
    (0x4002_3000, 0x400, "CRC"),
    (0x4002_4000, 0x400, "FMAC"),
    (0x4002_4400, 0x400, "CORDIC"),
    (0x4800_0000, 0x400, "GPIOA"),
    (0x4800_0400, 0x400, "GPIOB"),
    (0x4800_0800, 0x400, "GPIOC"),
    (0x4800_0C00, 0x400, "GPIOD"),
    (0x4800_1000, 0x400, "GPIOE"),
    (0x4800_1400, 0x400, "GPIOF"),
    (0x4800_1800, 0x400, "GPIOG"),
    (0x5000_0000, 0x100, "ADC1"),
    (0x5000_0100, 0x100, "ADC2"),
    (0x5000_0300, 0x100, "ADC12_COMMON"),
    (0x5000_0800, 0x400, "DAC1"),
    (0x5006_0000, 0x400, "RNG"),
    (0xE000_0000, 0x1000, "ITM"),
    (0xE000_1000, 0x1000, "DWT"),
    (0xE000_2000, 0x1000, "FPB"),
    (0xE000_E000, 0x10, "SCS"),
    (0xE000_E010, 0x10, "SysTick"),
    (0xE000_E100, 0xC00, "NVIC"),
    (0xE000_ED00, 0x90, "SCB"),
    (0xE000_ED88, 0x4, "SCB.CPACR"),
    (0xE000_EDF0, 0x10, "CoreDebug"),
    (0xE000_EF00, 0x100, "SCB/FPU"),
    (0xE004_2000, 0x400, "DBGMCU"),
];

/// The cycles of every call of one function (from its first instruction to the return to
/// its caller, whatever preempted it meanwhile): the bench times the firmware's link service
/// with it, inside the control tick's handler.
#[derive(Debug, Clone, Default)]
pub struct CallTimes {
    /// Calls in progress: (return address, cycle entered).
    open: Vec<(u32, u64)>,
    /// Calls completed.
    pub calls: u64,
    /// Their cycles, summed.
    pub total: u64,
    /// The longest.
    pub max: u64,
    /// Calls whose return the bench did not see: the function was entered again from the same
    /// call site while they were open (it is not reentrant, so they had returned). Not timed.
    pub unseen_returns: u64,
}

impl CallTimes {
    /// A block at `address` starts at `cycle`; `entry` is the function's first instruction and
    /// `link` the caller's return address when the block is the entry.
    pub fn block(&mut self, address: u32, cycle: u64, entry: u32, link: impl FnOnce() -> u32) {
        if address == entry {
            let ret = link() & !1;
            let before = self.open.len();
            self.open.retain(|&(open_ret, _)| open_ret != ret);
            self.unseen_returns += (before - self.open.len()) as u64;
            self.open.push((ret, cycle));
        } else if let Some(&(ret, start)) = self.open.last() {
            if address == ret {
                self.open.pop();
                let took = cycle.saturating_sub(start);
                self.calls += 1;
                self.total += took;
                self.max = self.max.max(took);
            }
        }
    }
}

/// The unique device id's address (RM0440 section 48.1).
pub const UID_BASE: u32 = 0x1FFF_7590;
/// The emulated part's unique id: wafer coordinates, wafer number and lot (the layout of the
/// real part's words; the values are the bench's own).
pub const UNIQUE_ID: [u32; 3] = [0x0041_0032, 0x3053_5712, 0x2038_3431];

/// The peripheral and register an address falls in, for messages.
pub fn name_of(address: u32) -> String {
    if (0x0800_0000..0x0802_0000).contains(&address) {
        return format!("FLASH memory+{:#07x}", address - 0x0800_0000);
    }
    for &(base, size, name) in REGIONS {
        if address >= base && address < base + size {
            return format!("{name}+{:#05x}", address - base);
        }
    }
    format!("{address:#010x} (no peripheral)")
}

/// Why the run stopped before the bench asked it to.
#[derive(Debug, Clone, PartialEq)]
pub enum Stop {
    /// The firmware touched a register the bench does not model.
    Unmodelled {
        /// The address.
        address: u32,
        /// A write (`true`) or a read.
        write: bool,
        /// The value written.
        value: u32,
        /// Where the access came from.
        pc: u32,
    },
    /// A peripheral saw something a correct binding never does (a protocol error).
    Misuse(String),
    /// The CPU faulted (bad memory access, undefined instruction) at `pc`.
    CpuFault {
        /// Unicorn's error.
        error: String,
        /// Where.
        pc: u32,
    },
}

impl fmt::Display for Stop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unmodelled { address, write, value, pc } => {
                if *write {
                    write!(
                        f,
                        "unmodelled register written: {} ({address:#010x}) = {value:#x} at pc {pc:#010x}",
                        name_of(*address)
                    )
                } else {
                    write!(
                        f,
                        "unmodelled register read: {} ({address:#010x}) at pc {pc:#010x}",
                        name_of(*address)
                    )
                }
            }
            Self::Misuse(text) => write!(f, "peripheral misuse: {text}"),
            Self::CpuFault { error, pc } => write!(f, "CPU fault ({error}) at pc {pc:#010x}"),
        }
    }
}

/// A block of plain registers: the listed offsets hold what was written (masked to their
/// writable bits), everything else is unmodelled.
#[derive(Debug, Clone, Default)]
pub struct Registers {
    values: BTreeMap<u32, u32>,
}

impl Registers {
    /// Registers at `offsets` with their reset values.
    pub fn new(reset: &[(u32, u32)]) -> Self {
        Self { values: reset.iter().copied().collect() }
    }
    /// The value at `offset`, if modelled.
    pub fn get(&self, offset: u32) -> Option<u32> {
        self.values.get(&offset).copied()
    }
    /// The value at `offset`, 0 if not modelled.
    pub fn value(&self, offset: u32) -> u32 {
        self.get(offset).unwrap_or(0)
    }
    /// Stores `value` at a modelled `offset`; `false` if not modelled.
    pub fn set(&mut self, offset: u32, value: u32) -> bool {
        match self.values.get_mut(&offset) {
            Some(slot) => {
                *slot = value;
                true
            }
            None => false,
        }
    }
}

/// Merges a sub-word write into a 32-bit register image (byte and half-word stores).
pub fn merge(old: u32, offset: u32, size: usize, value: u32) -> (u32, u32) {
    let shift = (offset & 3) * 8;
    let mask = match size {
        1 => 0xFF_u32,
        2 => 0xFFFF,
        _ => u32::MAX,
    } << shift;
    ((old & !mask) | ((value << shift) & mask), offset & !3)
}

/// One GPIO port (RM0440 section 9): mode, output type, pulls, output data, alternate
/// functions; the input data register reads the pins' levels.
#[derive(Debug, Clone)]
pub struct Gpio {
    /// MODER, OTYPER, OSPEEDR, PUPDR, ODR, LCKR, AFRL, AFRH.
    pub regs: Registers,
    /// The level each pin's outside world drives (`None`: nothing drives it).
    pub external: [Option<bool>; 16],
}

/// A pin's configured function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PinMode {
    /// Digital input.
    Input,
    /// General-purpose output (push-pull or open-drain).
    Output {
        /// Open drain.
        open_drain: bool,
    },
    /// Alternate function `af`.
    Alternate(u8),
    /// Analogue.
    Analog,
}

impl Gpio {
    fn new(moder: u32, pupdr: u32) -> Self {
        Self {
            regs: Registers::new(&[
                (0x00, moder),
                (0x04, 0),
                (0x08, 0),
                (0x0C, pupdr),
                (0x14, 0),
                (0x1C, 0),
                (0x20, 0),
                (0x24, 0),
            ]),
            external: [None; 16],
        }
    }

    /// The pin's mode.
    pub fn mode(&self, pin: u8) -> PinMode {
        let shift = u32::from(pin) * 2;
        match (self.regs.value(0x00) >> shift) & 3 {
            0 => PinMode::Input,
            1 => PinMode::Output { open_drain: self.regs.value(0x04) >> pin & 1 != 0 },
            2 => {
                let afr = if pin < 8 { self.regs.value(0x20) } else { self.regs.value(0x24) };
                PinMode::Alternate(((afr >> ((u32::from(pin) % 8) * 4)) & 0xF) as u8)
            }
            _ => PinMode::Analog,
        }
    }

    /// The pin's output data bit.
    pub fn output_bit(&self, pin: u8) -> bool {
        self.regs.value(0x14) >> pin & 1 != 0
    }

    /// The level on the pin: what the port drives (push-pull output, or an open-drain output
    /// pulling low), else the outside world, else the port's pull (floating reads low).
    pub fn level(&self, pin: u8) -> bool {
        match self.mode(pin) {
            PinMode::Output { open_drain: false } => self.output_bit(pin),
            PinMode::Output { open_drain: true } if !self.output_bit(pin) => false,
            _ => match self.external[usize::from(pin)] {
                Some(level) => level,
                None => (self.regs.value(0x0C) >> (u32::from(pin) * 2)) & 3 == 1,
            },
        }
    }

    fn idr(&self) -> u32 {
        (0..16u8).fold(0, |bits, pin| bits | (u32::from(self.level(pin)) << pin))
    }

    /// Reads a register; `None` if unmodelled.
    pub fn read(&self, offset: u32) -> Option<u32> {
        match offset {
            0x10 => Some(self.idr()),
            0x18 | 0x28 => Some(0),
            _ => self.regs.get(offset),
        }
    }

    /// Writes a register; `false` if unmodelled.
    pub fn write(&mut self, offset: u32, value: u32) -> bool {
        match offset {
            0x18 => {
                let odr = self.regs.value(0x14);
                let set = value & 0xFFFF;
                let reset = value >> 16;
                // BSRR: a set bit wins over a reset bit of the same pin.
                self.regs.set(0x14, (odr & !reset) | set)
            }
            0x28 => {
                let odr = self.regs.value(0x14);
                self.regs.set(0x14, odr & !(value & 0xFFFF))
            }
            0x10 => true,
            0x14 => self.regs.set(0x14, value & 0xFFFF),
            _ => self.regs.set(offset, value),
        }
    }
}

use crate::adc::{self, Adc};
use crate::tim::{self, Kind, Tim};

/// The G431's flash: 128 KiB from here, in 2 KiB pages.
pub const FLASH_BASE: u32 = 0x0800_0000;
/// Flash size.
pub const FLASH_SIZE: u32 = 128 * 1024;
/// Flash page size.
pub const PAGE_SIZE: u32 = 2048;
/// SRAM: 32 KiB (SRAM1, SRAM2 and the CCM alias, contiguous).
pub const RAM_BASE: u32 = 0x2000_0000;
/// SRAM size.
pub const RAM_SIZE: u32 = 32 * 1024;

/// The CPU clock before the firmware's clock set-up (HSI16) — the bench counts cycles at the
/// configured clock throughout; see [`Soc::sysclk_hz`].
pub const HSI_HZ: u64 = 16_000_000;
/// Cycles a page erase stalls the CPU at 170 MHz (RM0440 / datasheet: 22 ms typical).
pub const PAGE_ERASE_CYCLES: u64 = 22 * 170_000;
/// Cycles one double-word program stalls it (82 µs typical).
pub const PROGRAM_CYCLES: u64 = 82 * 170;

/// Interrupt numbers of the lines the bench drives (RM0440, vector table).
pub mod irq {
    /// ADC1 and ADC2.
    pub const ADC1_2: u32 = 18;
    /// TIM1 break.
    pub const TIM1_BRK_TIM15: u32 = 24;
    /// TIM1 update.
    pub const TIM1_UP_TIM16: u32 = 25;
    /// TIM1 capture/compare.
    pub const TIM1_CC: u32 = 27;
    /// TIM2.
    pub const TIM2: u32 = 28;
    /// TIM4.
    pub const TIM4: u32 = 30;
    /// TIM6 and DAC.
    pub const TIM6_DAC: u32 = 54;
}

/// The flash interface (RM0440 section 3.7): keys, status, control.
#[derive(Debug, Clone)]
pub struct FlashControl {
    /// ACR, KEYR, SR, CR, ECCR, OPTR, ...
    pub regs: Registers,
    key_stage: u8,
    /// The first word of a double word being programmed.
    pending_word: Option<(u32, u32)>,
    /// Double words programmed and pages erased, for the report.
    pub programmed: u64,
    /// Pages erased.
    pub erased: u64,
    /// When the interface was last locked again.
    pub last_locked_at: u64,
}

impl FlashControl {
    fn new() -> Self {
        Self {
            regs: Registers::new(&[
                (0x00, 0x0000_0600),
                (0x04, 0),
                (0x08, 0),
                (0x0C, 0),
                (0x10, 0),
                (0x14, 0xC000_0000),
                (0x18, 0),
                (0x20, 0xFFEF_F8AA),
                (0x24, 0),
                (0x28, 0),
                (0x2C, 0),
                (0x30, 0),
                (0x70, 0),
            ]),
            key_stage: 0,
            pending_word: None,
            programmed: 0,
            erased: 0,
            last_locked_at: 0,
        }
    }
    /// Whether the flash is locked (no write or erase under way).
    pub fn locked(&self) -> bool {
        self.regs.value(0x14) & (1 << 31) != 0
    }
}

/// The NVIC, the system control block's registers the firmware uses, the data watchpoint
/// unit's cycle counter.
#[derive(Debug, Clone)]
pub struct Nvic {
    /// Enabled interrupts.
    pub enabled: [u32; 4],
    /// Pending interrupts (set by software or latched from a line).
    pub pending: [u32; 4],
    /// Priority bytes of the 102 interrupts.
    pub priority: [u8; 128],
    /// SCB and DWT registers.
    pub regs: Registers,
    /// Active exceptions, innermost last: (exception number, priority).
    pub active: Vec<(u32, u8)>,
}

impl Nvic {
    fn new() -> Self {
        Self {
            enabled: [0; 4],
            pending: [0; 4],
            priority: [0; 128],
            regs: Registers::new(&[
                (0xE000_ED04, 0),
                (0xE000_ED08, 0),
                (0xE000_ED0C, 0xFA05_0000),
                (0xE000_ED10, 0),
                (0xE000_ED14, 0x0000_0200),
                (0xE000_ED18, 0),
                (0xE000_ED1C, 0),
                (0xE000_ED20, 0),
                (0xE000_ED24, 0),
                (0xE000_ED28, 0),
                (0xE000_ED2C, 0),
                (0xE000_ED88, 0),
                (0xE000_EDF0, 0),
                (0xE000_EDFC, 0),
                (0xE000_EF34, 0xC000_0000),
                (0xE000_EF38, 0),
                (0xE000_EF3C, 0),
                (0xE000_1000, 0x4000_0000),
                (0xE000_1004, 0),
            ]),
            active: Vec::new(),
        }
    }

    /// Pends interrupt `n`.
    pub fn pend(&mut self, n: u32) {
        if let Some(word) = self.pending.get_mut((n / 32) as usize) {
            *word |= 1 << (n % 32);
        }
    }

    fn is_set(bits: &[u32; 4], n: u32) -> bool {
        bits.get((n / 32) as usize).is_some_and(|w| w >> (n % 32) & 1 != 0)
    }

    /// Whether interrupt `n` is active (being handled or preempted).
    pub fn is_active(&self, n: u32) -> bool {
        self.active.iter().any(|&(e, _)| e == n + 16)
    }

    /// The pending, enabled interrupt of highest priority (lowest number, then lowest index).
    pub fn highest_pending(&self) -> Option<(u32, u8)> {
        let mut best: Option<(u32, u8)> = None;
        for n in 0..128u32 {
            if Self::is_set(&self.pending, n) && Self::is_set(&self.enabled, n) {
                let p = self.priority[n as usize] & 0xF0;
                if best.is_none_or(|(_, bp)| p < bp) {
                    best = Some((n, p));
                }
            }
        }
        best
    }

    /// Clears the pending bit of `n` (on exception entry).
    pub fn unpend(&mut self, n: u32) {
        if let Some(word) = self.pending.get_mut((n / 32) as usize) {
            *word &= !(1 << (n % 32));
        }
    }
}

/// The independent watchdog (RM0440 section 42).
#[derive(Debug, Clone, Default)]
pub struct Iwdg {
    /// Started (cannot be stopped).
    pub started: bool,
    unlocked: bool,
    /// Prescaler register.
    pub pr: u32,
    /// Reload register.
    pub rlr: u32,
    /// Cycle of the last reload.
    pub reloaded_at: u64,
    /// Reloads seen.
    pub reloads: u64,
}

impl Iwdg {
    /// The cycle at which the watchdog resets the MCU, if started, at `sysclk` (the LSI is
    /// 32 kHz).
    pub fn expiry(&self, sysclk_hz: u64) -> Option<u64> {
        self.started.then(|| {
            let lsi_ticks = (u64::from(self.rlr) + 1) * (4u64 << self.pr.min(6));
            self.reloaded_at + lsi_ticks * sysclk_hz / 32_000
        })
    }
}

/// The whole microcontroller's peripheral state, and the CPU's time.
#[derive(Debug)]
pub struct Soc {
    /// CPU cycles since reset.
    pub cycles: u64,
    /// When the CPU must stop so the bench can process events.
    pub deadline: u64,
    /// Let the next block run even if the deadline has passed (an interrupt waiting for an IT
    /// block to end must let the block at the resume point execute, or it would stop before
    /// it again and again without progress).
    pub run_one_block: bool,
    /// Why the run must stop, if it must.
    pub stop: Option<Stop>,
    /// The program counter of the current block (for messages).
    pub block_pc: u32,
    /// RCC.
    pub rcc: Registers,
    /// PWR.
    pub pwr: Registers,
    /// SYSCFG, EXTI, DBGMCU: registers written at start-up, no behaviour needed.
    pub misc: Registers,
    /// The flash interface.
    pub flash: FlashControl,
    /// GPIOA..GPIOG (E unused, kept for indexing).
    pub gpio: [Gpio; 7],
    /// TIM1.
    pub tim1: Tim,
    /// TIM2.
    pub tim2: Tim,
    /// TIM4.
    pub tim4: Tim,
    /// TIM6.
    pub tim6: Tim,
    /// ADC1, ADC2.
    pub adc: [Adc; 2],
    /// ADC12 common registers.
    pub adc_common: Registers,
    /// IWDG.
    pub iwdg: Iwdg,
    /// NVIC, SCB, DWT.
    pub nvic: Nvic,
    /// Analogue pin voltages, by (port index, pin).
    pub analog: BTreeMap<(u8, u8), f64>,
    /// A reset was requested (watchdog or `AIRCR.SYSRESETREQ`).
    pub reset_requested: Option<&'static str>,
    /// Flash writes to apply after the store (address, bytes) — the erase of a page.
    pub flash_fill: Vec<(u32, Vec<u8>)>,
    /// Cycles the CPU is stalled by a flash operation, to be added before it runs on.
    pub stall: u64,
    /// The CPU executed WFE/WFI with nothing pending: sleep to the next event.
    pub sleeping: bool,
    /// The event register (set by SEV, exception entry and return).
    pub event_register: bool,
    /// Peripheral accesses, for the report.
    pub accesses: u64,
    /// Where the core resumes after a WFE/WFI its hook took.
    pub resume_at: Option<u32>,
    /// Print every peripheral access (`TAUT_PIL_TRACE=1`).
    pub trace: bool,
    /// The panel's TM1637.
    pub panel: crate::panel::Tm1637,
    /// USART2 with its DMA channels: the machine link's port.
    pub serial: crate::usart::SerialPort,
    /// The firmware's link service calls, timed (see [`CallTimes`]).
    pub link_calls: CallTimes,
    /// The core signalled an exception return (Unicorn stops for it; the bench unstacks).
    pub stop_reason_exit: bool,
}

/// Port index of a GPIO base.
fn port_of(address: u32) -> Option<usize> {
    (0x4800_0000..0x4800_1C00)
        .contains(&address)
        .then(|| ((address - 0x4800_0000) / 0x400) as usize)
}

impl Default for Soc {
    fn default() -> Self {
        Self::new()
    }
}

impl Soc {
    /// The microcontroller at reset.
    pub fn new() -> Self {
        let rcc = Registers::new(&[
            (0x00, 0x0000_0500),
            (0x04, 0x4000_0000),
            (0x08, 0x0000_0005),
            (0x0C, 0x0000_1000),
            (0x18, 0),
            (0x1C, 0),
            (0x20, 0),
            (0x28, 0),
            (0x2C, 0),
            (0x30, 0),
            (0x38, 0),
            (0x3C, 0),
            (0x40, 0),
            (0x48, 0x0000_0100),
            (0x4C, 0),
            (0x50, 0),
            (0x58, 0x0000_0400),
            (0x5C, 0),
            (0x60, 0),
            (0x68, 0x0000_130F),
            (0x6C, 0x050F_667F),
            (0x70, 0x0000_0101),
            (0x78, 0xF2FE_63FF),
            (0x7C, 0x0000_0103),
            (0x80, 0x0437_F801),
            (0x88, 0),
            (0x90, 0),
            (0x94, 0x0C00_0000),
            (0x98, 0),
            (0x9C, 0),
        ]);
        let pwr = Registers::new(&[
            (0x00, 0x0000_0200),
            (0x04, 0),
            (0x08, 0x0000_8000),
            (0x0C, 0),
            (0x10, 0),
            (0x14, 0),
            (0x18, 0),
            (0x20, 0),
            (0x24, 0),
            (0x80, 0x0000_0100),
        ]);
        let misc = Registers::new(&[
            // SYSCFG: MEMRMP, CFGR1, EXTICR1-4, SCSR, CFGR2, SWPR, SKR.
            (0x4001_0000, 0),
            (0x4001_0004, 0x7C00_0001),
            (0x4001_0008, 0),
            (0x4001_000C, 0),
            (0x4001_0010, 0),
            (0x4001_0014, 0),
            (0x4001_0018, 0),
            (0x4001_001C, 0),
            // EXTI: IMR1, EMR1, RTSR1, FTSR1, SWIER1, PR1, IMR2 ...
            (0x4001_0400, 0xFF82_0000),
            (0x4001_0404, 0),
            (0x4001_0408, 0),
            (0x4001_040C, 0),
            (0x4001_0410, 0),
            (0x4001_0414, 0),
            (0x4001_0420, 0x0000_0087),
            (0x4001_0424, 0),
            (0x4001_0428, 0),
            (0x4001_042C, 0),
            (0x4001_0430, 0),
            (0x4001_0434, 0),
            // DBGMCU: IDCODE, CR, APB1FZR1, APB1FZR2, APB2FZR.
            (0xE004_2000, 0x2000_6468),
            (0xE004_2004, 0),
            (0xE004_2008, 0),
            (0xE004_200C, 0),
            (0xE004_2010, 0),
        ]);
        let gpio = [
            Gpio::new(0xABFF_FFFF, 0x6400_0000),
            Gpio::new(0xFFFF_FEBF, 0x0000_0100),
            Gpio::new(0xFFFF_FFFF, 0),
            Gpio::new(0xFFFF_FFFF, 0),
            Gpio::new(0xFFFF_FFFF, 0),
            Gpio::new(0xFFFF_FFFF, 0),
            Gpio::new(0xFFFF_FFFF, 0),
        ];
        // The panel module's pull-ups on PB5 (clock) and PB9 (data).
        let mut gpio = gpio;
        gpio[1].external[5] = Some(true);
        gpio[1].external[9] = Some(true);
        Self {
            cycles: 0,
            deadline: 0,
            run_one_block: false,
            stop: None,
            block_pc: 0,
            rcc,
            pwr,
            misc,
            flash: FlashControl::new(),
            gpio,
            tim1: Tim::new(Kind::Advanced),
            tim2: Tim::new(Kind::General),
            tim4: Tim::new(Kind::General),
            tim6: Tim::new(Kind::Basic),
            adc: [Adc::new(), Adc::new()],
            adc_common: Registers::new(&[(0x00, 0), (0x08, 0), (0x0C, 0)]),
            iwdg: Iwdg::default(),
            nvic: Nvic::new(),
            analog: BTreeMap::new(),
            reset_requested: None,
            flash_fill: Vec::new(),
            stall: 0,
            sleeping: false,
            event_register: false,
            accesses: 0,
            stop_reason_exit: false,
            panel: crate::panel::Tm1637::default(),
            serial: crate::usart::SerialPort::new(),
            link_calls: CallTimes::default(),
            resume_at: None,
            trace: std::env::var_os("TAUT_PIL_TRACE").is_some(),
        }
    }

    /// The system clock the firmware configured: the PLL's R output when selected, else HSI16.
    pub fn sysclk_hz(&self) -> u64 {
        let cfgr = self.rcc.value(0x08);
        if cfgr & 3 != 3 {
            return HSI_HZ;
        }
        let pll = self.rcc.value(0x0C);
        let m = u64::from((pll >> 4) & 0xF) + 1;
        let n = u64::from((pll >> 8) & 0x7F);
        let r = 2 * (u64::from((pll >> 25) & 3) + 1);
        HSI_HZ / m * n / r
    }

    /// APB1's clock (USART2's kernel clock at reset): the system clock over `CFGR.PPRE1`.
    pub fn pclk1_hz(&self) -> u64 {
        let ppre1 = (self.rcc.value(0x08) >> 8) & 7;
        self.sysclk_hz() >> if ppre1 >= 4 { ppre1 - 3 } else { 0 }
    }

    fn traced(&self, address: u32) -> bool {
        match std::env::var("TAUT_PIL_TRACE") {
            Ok(filter) if !filter.is_empty() && filter != "1" => {
                name_of(address).starts_with(filter.as_str())
            }
            _ => true,
        }
    }

    fn unmodelled(&mut self, address: u32, write: bool, value: u32) {
        if self.stop.is_none() {
            self.stop = Some(Stop::Unmodelled { address, write, value, pc: self.block_pc });
        }
    }

    /// A model's verdict on a write: modelled or not, or a misuse (which stops the run; the
    /// register counts as modelled).
    fn modelled_or_misuse(&mut self, result: Result<bool, String>) -> bool {
        result.unwrap_or_else(|text| {
            self.misuse(text);
            true
        })
    }

    fn misuse(&mut self, text: String) {
        if self.stop.is_none() {
            self.stop = Some(Stop::Misuse(text));
        }
    }

    /// A peripheral read of `size` bytes at `address`.
    pub fn read(&mut self, address: u32, size: usize) -> u32 {
        self.accesses += 1;
        if self.trace && self.traced(address) {
            let v = self.read_word(address & !3);
            eprintln!(
                "[{:>10}] {:#010x} read  {} = {:x?}",
                self.cycles,
                self.block_pc,
                name_of(address),
                v
            );
        }
        let word = address & !3;
        let value = self.read_word(word);
        match value {
            Some(v) => {
                (v >> ((address & 3) * 8))
                    & if size >= 4 { u32::MAX } else { (1u32 << (size * 8)) - 1 }
            }
            None => {
                self.unmodelled(address, false, 0);
                0
            }
        }
    }

    fn read_word(&mut self, address: u32) -> Option<u32> {
        let now = self.cycles;
        match address {
            0x4002_1000..=0x4002_13FF => self.rcc.get(address - 0x4002_1000),
            0x4000_7000..=0x4000_73FF => {
                // SR2.VOSF (bit 10) reads 0: the regulator is always ready.
                self.pwr.get(address - 0x4000_7000)
            }
            0x4002_2000..=0x4002_23FF => self.flash.regs.get(address - 0x4002_2000),
            0x4800_0000..=0x4800_1BFF => {
                let port = port_of(address)?;
                self.gpio[port].read(address & 0x3FF)
            }
            0x4001_2C00..=0x4001_2FFF => self.tim1.read(address - 0x4001_2C00, now),
            0x4000_0000..=0x4000_03FF => self.tim2.read(address - 0x4000_0000, now),
            0x4000_0800..=0x4000_0BFF => self.tim4.read(address - 0x4000_0800, now),
            0x4000_1000..=0x4000_13FF => self.tim6.read(address - 0x4000_1000, now),
            0x5000_0000..=0x5000_00FF => self.adc[0].read(address - 0x5000_0000),
            0x5000_0100..=0x5000_01FF => self.adc[1].read(address - 0x5000_0100),
            0x5000_0300..=0x5000_03FF => self.adc_common.get(address - 0x5000_0300),
            0x4000_4400..=0x4000_47FF => self.serial.read_usart(address - 0x4000_4400),
            0x4002_0000..=0x4002_03FF => self.serial.read_dma(address - 0x4002_0000),
            0x4002_0800..=0x4002_0BFF => self.serial.read_mux(address - 0x4002_0800),
            0x4000_3000 => Some(0),
            0x4000_3004 => Some(self.iwdg.pr),
            0x4000_3008 => Some(self.iwdg.rlr),
            // SR: no update in progress.
            0x4000_300C => Some(0),
            0xE000_E100..=0xE000_E10C => {
                Some(self.nvic.enabled[((address - 0xE000_E100) / 4) as usize])
            }
            0xE000_E180..=0xE000_E18C => {
                Some(self.nvic.enabled[((address - 0xE000_E180) / 4) as usize])
            }
            0xE000_E200..=0xE000_E20C => {
                Some(self.nvic.pending[((address - 0xE000_E200) / 4) as usize])
            }
            0xE000_E280..=0xE000_E28C => {
                Some(self.nvic.pending[((address - 0xE000_E280) / 4) as usize])
            }
            0xE000_E400..=0xE000_E47C => {
                let i = (address - 0xE000_E400) as usize;
                Some(u32::from_le_bytes([
                    self.nvic.priority[i],
                    self.nvic.priority[i + 1],
                    self.nvic.priority[i + 2],
                    self.nvic.priority[i + 3],
                ]))
            }
            // CPUID: Cortex-M4 r0p1.
            0xE000_ED00 => Some(0x410F_C241),
            // DWT.CYCCNT: the cycle counter, when enabled.
            0xE000_1004 => {
                let enabled = self.nvic.regs.value(0xE000_1000) & 1 != 0;
                Some(if enabled { now as u32 } else { self.nvic.regs.value(0xE000_1004) })
            }
            _ => self.nvic.regs.get(address).or_else(|| self.misc.get(address)),
        }
    }

    /// A peripheral write of `size` bytes at `address`.
    pub fn write(&mut self, address: u32, size: usize, value: u32) {
        self.accesses += 1;
        if self.trace && self.traced(address) {
            eprintln!(
                "[{:>10}] {:#010x} write {} = {value:#x} ({size} B)",
                self.cycles,
                self.block_pc,
                name_of(address)
            );
        }
        let word = address & !3;
        // Sub-word stores are merged into the register (the NVIC's priority bytes are the one
        // place the firmware stores bytes).
        let value = if size < 4 {
            match self.read_word(word) {
                Some(old) => merge(old, address, size, value).0,
                None => {
                    self.unmodelled(address, true, value);
                    return;
                }
            }
        } else {
            value
        };
        if !self.write_word(word, value) {
            self.unmodelled(address, true, value);
        }
    }

    fn write_word(&mut self, address: u32, value: u32) -> bool {
        let now = self.cycles;
        match address {
            0x4002_1000..=0x4002_13FF => self.write_rcc(address - 0x4002_1000, value),
            0x4000_7000..=0x4000_73FF => self.pwr.set(address - 0x4000_7000, value),
            0x4002_2000..=0x4002_23FF => self.write_flash_control(address - 0x4002_2000, value),
            0x4800_0000..=0x4800_1BFF => match port_of(address) {
                Some(port) => {
                    let ok = self.gpio[port].write(address & 0x3FF, value);
                    if port == 1 {
                        self.panel_lines();
                    }
                    ok
                }
                None => false,
            },
            0x4001_2C00..=0x4001_2FFF => self.tim1.write(address - 0x4001_2C00, value, now),
            0x4000_0000..=0x4000_03FF => self.tim2.write(address - 0x4000_0000, value, now),
            0x4000_0800..=0x4000_0BFF => self.tim4.write(address - 0x4000_0800, value, now),
            0x4000_1000..=0x4000_13FF => self.tim6.write(address - 0x4000_1000, value, now),
            0x5000_0000..=0x5000_00FF => self.adc[0].write(address - 0x5000_0000, value),
            0x5000_0100..=0x5000_01FF => self.adc[1].write(address - 0x5000_0100, value),
            0x5000_0300..=0x5000_03FF => self.adc_common.set(address - 0x5000_0300, value),
            0x4000_4400..=0x4000_47FF => {
                let result = self.serial.write_usart(address - 0x4000_4400, value);
                self.modelled_or_misuse(result)
            }
            0x4002_0000..=0x4002_03FF => {
                let result = self.serial.write_dma(address - 0x4002_0000, value);
                self.modelled_or_misuse(result)
            }
            0x4002_0800..=0x4002_0BFF => self.serial.write_mux(address - 0x4002_0800, value),
            0x4000_3000 => {
                match value & 0xFFFF {
                    0xCCCC => {
                        self.iwdg.started = true;
                        self.iwdg.reloaded_at = now;
                        if self.iwdg.rlr == 0 {
                            self.iwdg.rlr = 0xFFF;
                        }
                    }
                    0xAAAA => {
                        self.iwdg.reloaded_at = now;
                        self.iwdg.reloads += 1;
                    }
                    0x5555 => self.iwdg.unlocked = true,
                    _ => self.iwdg.unlocked = false,
                }
                true
            }
            0x4000_3004 | 0x4000_3008 | 0x4000_3010 => {
                if !self.iwdg.unlocked {
                    self.misuse(format!("IWDG register {} written while locked", name_of(address)));
                } else if address == 0x4000_3004 {
                    self.iwdg.pr = value & 7;
                } else if address == 0x4000_3008 {
                    self.iwdg.rlr = value & 0xFFF;
                }
                true
            }
            0xE000_E100..=0xE000_E10C => {
                self.nvic.enabled[((address - 0xE000_E100) / 4) as usize] |= value;
                true
            }
            0xE000_E180..=0xE000_E18C => {
                self.nvic.enabled[((address - 0xE000_E180) / 4) as usize] &= !value;
                true
            }
            0xE000_E200..=0xE000_E20C => {
                self.nvic.pending[((address - 0xE000_E200) / 4) as usize] |= value;
                true
            }
            0xE000_E280..=0xE000_E28C => {
                self.nvic.pending[((address - 0xE000_E280) / 4) as usize] &= !value;
                true
            }
            0xE000_E400..=0xE000_E47C => {
                let i = (address - 0xE000_E400) as usize;
                self.nvic.priority[i..i + 4].copy_from_slice(&value.to_le_bytes());
                true
            }
            0xE000_ED0C => {
                if value >> 16 != 0x05FA {
                    self.misuse(format!("AIRCR written without its key: {value:#x}"));
                    return true;
                }
                if value & 4 != 0 {
                    self.reset_requested = Some("AIRCR.SYSRESETREQ");
                }
                self.nvic.regs.set(address, (value & 0x0700) | 0xFA05_0000)
            }
            0xE000_1004 => self.nvic.regs.set(address, value),
            _ => self.nvic.regs.set(address, value) || self.misc.set(address, value),
        }
    }

    fn write_rcc(&mut self, offset: u32, value: u32) -> bool {
        let value = match offset {
            // CR: every oscillator and the PLL are ready as soon as they are switched on.
            0x00 => {
                let mut cr = value & !((1 << 10) | (1 << 17) | (1 << 25));
                if cr & (1 << 8) != 0 {
                    cr |= 1 << 10;
                }
                if cr & (1 << 16) != 0 {
                    cr |= 1 << 17;
                }
                if cr & (1 << 24) != 0 {
                    cr |= 1 << 25;
                }
                cr
            }
            // CFGR: the switch status follows the switch.
            0x08 => {
                let sw = value & 3;
                if sw == 3 && self.rcc.value(0x00) & (1 << 25) == 0 {
                    self.misuse("system clock switched to the PLL before it is locked".into());
                }
                if sw == 3 {
                    let latency = self.flash.regs.value(0x00) & 0xF;
                    // PWR_CR5.R1MODE (bit 8) = 0 is boost mode (RM0440 section 6.4.5).
                    let boost = self.pwr.value(0x80) & (1 << 8) == 0;
                    // 170 MHz needs 4 wait states and the boost mode (RM0440, table 9).
                    if latency < 4 || !boost {
                        self.misuse(format!(
                            "PLL selected with {latency} flash wait states and boost {boost}: 170 MHz needs 4 and boost"
                        ));
                    }
                }
                (value & !(3 << 2)) | (sw << 2)
            }
            // BDCR: LSE ready follows LSEON.
            0x90 => (value & !2) | ((value & 1) << 1),
            // CSR: LSI ready follows LSION.
            0x94 => (value & !2) | ((value & 1) << 1),
            // CRRCR: HSI48 ready follows HSI48ON.
            0x98 => (value & !2) | ((value & 1) << 1),
            _ => value,
        };
        self.rcc.set(offset, value)
    }

    fn write_flash_control(&mut self, offset: u32, value: u32) -> bool {
        match offset {
            0x08 => {
                match (self.flash.key_stage, value) {
                    (0, 0x4567_0123) => self.flash.key_stage = 1,
                    (1, 0xCDEF_89AB) => {
                        self.flash.key_stage = 0;
                        let cr = self.flash.regs.value(0x14) & !(1 << 31);
                        self.flash.regs.set(0x14, cr);
                    }
                    _ => self.misuse(format!("wrong flash key sequence: {value:#x}")),
                }
                true
            }
            // SR: errors and EOP are cleared by writing 1.
            0x10 => {
                let sr = self.flash.regs.value(0x10) & !(value & 0xC3FB);
                self.flash.regs.set(0x10, sr)
            }
            0x14 => {
                if self.flash.locked() {
                    self.misuse("FLASH_CR written while locked".into());
                    return true;
                }
                let mut cr = value;
                if cr & (1 << 16) != 0 {
                    cr &= !(1 << 16);
                    if cr & 2 != 0 {
                        let page = (cr >> 3) & 0x7F;
                        if page >= FLASH_SIZE / PAGE_SIZE {
                            self.misuse(format!("erase of page {page}, past the end of flash"));
                        } else {
                            self.flash_fill.push((
                                FLASH_BASE + page * PAGE_SIZE,
                                vec![0xFF; PAGE_SIZE as usize],
                            ));
                            self.stall += PAGE_ERASE_CYCLES;
                            self.flash.erased += 1;
                            let sr = self.flash.regs.value(0x10) | 1;
                            self.flash.regs.set(0x10, sr);
                        }
                    } else if cr & 4 != 0 {
                        self.misuse("mass erase requested".into());
                    }
                }
                if cr & (1 << 31) != 0 && !self.flash.locked() {
                    self.flash.last_locked_at = self.cycles;
                }
                self.flash.regs.set(0x14, cr)
            }
            _ => self.flash.regs.set(offset, value),
        }
    }

    /// Whether the flash interface was unlocked at any time since `cycle` (a write or erase
    /// was under way).
    pub fn flash_unlocked_since(&self, cycle: u64) -> bool {
        !self.flash.locked() || self.flash.last_locked_at > cycle
    }

    /// A CPU store into flash at `address` of `size` bytes, `value`, the word there before
    /// `old`: legal only while `FLASH_CR.PG` is set, as 32-bit words of an erased double word.
    /// Returns whether the store stands (the bench undoes it otherwise).
    pub fn flash_store(&mut self, address: u32, size: usize, value: u32, old: u32) -> bool {
        if self.trace && self.traced(address) {
            eprintln!(
                "[{:>10}] {:#010x} flash store {address:#010x} = {value:#x} ({size} B, was {old:#x})",
                self.cycles, self.block_pc
            );
        }
        let cr = self.flash.regs.value(0x14);
        if cr & 1 == 0 || self.flash.locked() {
            self.misuse(format!("store to flash at {address:#010x} without FLASH_CR.PG"));
            return false;
        }
        if size != 4 || !address.is_multiple_of(4) {
            self.misuse(format!("{size}-byte store to flash at {address:#010x}: words only"));
            return false;
        }
        if old != u32::MAX {
            let sr = self.flash.regs.value(0x10) | (1 << 3);
            self.flash.regs.set(0x10, sr);
            self.misuse(format!("flash at {address:#010x} programmed without an erase (PROGERR)"));
            return false;
        }
        match self.flash.pending_word.take() {
            None if address.is_multiple_of(8) => self.flash.pending_word = Some((address, value)),
            Some((first, _)) if address == first + 4 => {
                self.stall += PROGRAM_CYCLES;
                self.flash.programmed += 1;
                let sr = self.flash.regs.value(0x10) | 1;
                self.flash.regs.set(0x10, sr);
            }
            _ => {
                self.misuse(format!(
                    "flash word at {address:#010x} out of double-word order (PGSERR)"
                ));
                return false;
            }
        }
        true
    }

    /// The panel's wires after a GPIOB write: the TM1637 sees the lines, and holds DIO low
    /// while it acknowledges (PB5 clock, PB9 data; the module pulls both up).
    pub fn panel_lines(&mut self) {
        let port = &mut self.gpio[1];
        port.external[5] = Some(true);
        port.external[9] = Some(true);
        let clk = port.level(5);
        let dio = port.level(9);
        self.panel.lines(clk, dio);
        self.gpio[1].external[9] = Some(!self.panel.acking);
    }

    /// Sets an input pin's level as the outside world drives it.
    pub fn drive_pin(&mut self, port: u8, pin: u8, level: Option<bool>) {
        if let Some(gpio) = self.gpio.get_mut(usize::from(port)) {
            gpio.external[usize::from(pin)] = level;
        }
    }

    /// The voltage on an analogue input.
    pub fn set_analog(&mut self, port: u8, pin: u8, volts: f64) {
        self.analog.insert((port, pin), volts);
    }

    fn analog_of(&mut self, adc: usize, channel: u32) -> f64 {
        // The board's channels: ADC1_IN1 = PA0, ADC1_IN2 = PA1, ADC2_IN15 = PB15
        // (datasheet DS12589, pin definitions).
        let pin = match (adc, channel) {
            (0, 1) => (0u8, 0u8),
            (0, 2) => (0, 1),
            (1, 15) => (1, 15),
            _ => {
                self.misuse(format!("ADC{} channel {channel} is not wired on this board", adc + 1));
                return 0.0;
            }
        };
        if self.gpio[usize::from(pin.0)].mode(pin.1) != PinMode::Analog {
            self.misuse(format!(
                "ADC{} converts P{}{} which is not in analogue mode",
                adc + 1,
                (b'A' + pin.0) as char,
                pin.1
            ));
        }
        self.analog.get(&pin).copied().unwrap_or(0.0)
    }

    /// A timer trigger reaches the converters.
    pub fn adc_trigger(&mut self, trigger: adc::Trigger) {
        for index in 0..2 {
            if let Some(source) = self.adc[index].injected_trigger() {
                if source == adc::JEXT_TIM1_CC4 {
                    if trigger == adc::Trigger::Tim1Cc4 {
                        let volts = self.analog_of(index, self.adc[index].injected_channel());
                        self.adc[index].convert_injected(volts);
                    }
                } else {
                    self.misuse(format!(
                        "ADC{} injected trigger JEXTSEL={source} is not a modelled source",
                        index + 1
                    ));
                }
            }
            if let Some(source) = self.adc[index].regular_trigger() {
                if source == adc::EXT_TIM1_TRGO2 {
                    if trigger == adc::Trigger::Tim1Trgo2 {
                        let volts = self.analog_of(index, self.adc[index].regular_channel());
                        self.adc[index].convert_regular(volts);
                    }
                } else {
                    self.misuse(format!(
                        "ADC{} regular trigger EXTSEL={source} is not a modelled source",
                        index + 1
                    ));
                }
            }
        }
    }

    /// The interrupt lines of the modelled peripherals, latched into the NVIC's pending bits.
    pub fn latch_interrupt_lines(&mut self) {
        let tim1_sr = self.tim1.regs.value(0x10) & self.tim1.regs.value(0x0C);
        let lines = [
            (irq::TIM1_UP_TIM16, tim1_sr & tim::UIF != 0),
            (irq::TIM1_BRK_TIM15, tim1_sr & tim::BIF != 0),
            (irq::TIM1_CC, tim1_sr & 0x1E != 0),
            (irq::TIM2, self.tim2.interrupt_line()),
            (irq::TIM4, self.tim4.interrupt_line()),
            (irq::TIM6_DAC, self.tim6.interrupt_line()),
            (
                irq::ADC1_2,
                self.adc.iter().any(|a| a.regs.value(0x00) & a.regs.value(0x04) & 0x7FF != 0),
            ),
        ];
        for (n, high) in lines {
            if high && !self.nvic.is_active(n) {
                self.nvic.pend(n);
            }
        }
    }
}

impl Soc {
    /// An edge on the Hall lines (the XOR of the three on TIM2's TI1): with TIM2 in Hall
    /// mode (`CR2.TI1S`, channel 1 capturing TRC, slave mode reset on TI1F_ED) the counter is
    /// captured into `CCR1`, `CC1IF` is set, and the counter restarts.
    pub fn hall_edge(&mut self, now: u64) {
        let tim = &mut self.tim2;
        if !tim.running {
            return;
        }
        let afs_ok = [(0usize, 15u8), (1, 3), (1, 10)]
            .iter()
            .all(|&(port, pin)| self.gpio[port].mode(pin) == PinMode::Alternate(1));
        let ti1s = tim.regs.value(0x04) & (1 << 7) != 0;
        let cc1s_trc = tim.regs.value(0x18) & 3 == 3;
        let cc1e = tim.regs.value(0x20) & 1 != 0;
        let smcr = tim.regs.value(0x08);
        let ts_ti1f_ed = (smcr >> 4) & 7 == 0b100 && (smcr >> 20) & 3 == 0;
        if !(afs_ok && ti1s && cc1s_trc && cc1e && ts_ti1f_ed) {
            return;
        }
        let count = tim.count(now);
        tim.regs.set(0x34, count);
        let overcapture = tim.regs.value(0x10) & tim::CC1IF != 0;
        tim.flag(tim::CC1IF | if overcapture { 1 << 9 } else { 0 });
        // Slave mode reset (SMS = 0100): the counter restarts at the edge.
        if smcr & 0b111 == 0b100 && (smcr >> 16) & 1 == 0 {
            tim.origin = now;
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_call_is_timed_from_its_entry_to_its_return_and_an_unseen_return_is_not_timed() {
        let mut calls = CallTimes::default();
        let (entry, ret) = (0x0800_1000, 0x0800_2004);
        calls.block(entry, 100, entry, || ret | 1);
        calls.block(0x0800_1010, 150, entry, || 0);
        calls.block(ret, 400, entry, || 0);
        assert_eq!((calls.calls, calls.total, calls.max, calls.unseen_returns), (1, 300, 300, 0));
        // Entered again from the same site with the last return unseen: that call is dropped.
        calls.block(entry, 1_000, entry, || ret | 1);
        calls.block(entry, 9_000_000, entry, || ret | 1);
        calls.block(ret, 9_000_250, entry, || 0);
        assert_eq!((calls.calls, calls.max, calls.unseen_returns), (2, 300, 1));
    }

    use super::*;

    #[test]
    fn oscillators_and_the_pll_are_ready_once_on_and_the_switch_reports_itself() {
        let mut soc = Soc::new();
        soc.write(0x4002_1000, 4, (1 << 8) | (1 << 24));
        let cr = soc.read(0x4002_1000, 4);
        assert_ne!(cr & (1 << 10), 0, "HSIRDY");
        assert_ne!(cr & (1 << 25), 0, "PLLRDY");
        soc.write(0x4002_1008, 4, 1);
        assert_eq!(soc.read(0x4002_1008, 4) >> 2 & 3, 1, "SWS follows SW");
    }

    #[test]
    fn the_pll_at_170_mhz_needs_boost_and_four_wait_states() {
        let mut soc = Soc::new();
        soc.write(0x4002_1000, 4, (1 << 8) | (1 << 24));
        soc.write(0x4002_1008, 4, 3);
        assert!(matches!(soc.stop, Some(Stop::Misuse(_))), "normal mode, 0 wait states");
        let mut soc = Soc::new();
        soc.write(0x4002_1000, 4, (1 << 8) | (1 << 24));
        soc.write(0x4000_7080, 4, 0);
        soc.write(0x4002_2000, 4, 4);
        soc.write(0x4002_1008, 4, 3);
        assert_eq!(soc.stop, None);
    }

    #[test]
    fn flash_programs_erased_double_words_only_after_the_unlock_and_with_pg() {
        let mut soc = Soc::new();
        assert!(!soc.flash_store(0x0801_E000, 4, 1, u32::MAX), "locked");
        let mut soc = Soc::new();
        soc.write(0x4002_2008, 4, 0x4567_0123);
        soc.write(0x4002_2008, 4, 0xCDEF_89AB);
        soc.write(0x4002_2014, 4, 1);
        assert!(soc.flash_store(0x0801_E000, 4, 1, u32::MAX));
        assert!(soc.flash_store(0x0801_E004, 4, 2, u32::MAX));
        assert_eq!(soc.flash.programmed, 1);
        assert!(soc.stall > 0, "programming stalls the core");
        assert!(!soc.flash_store(0x0801_E008, 4, 3, 0), "not erased: PROGERR");
    }

    #[test]
    fn a_page_erase_fills_the_page_and_stalls() {
        let mut soc = Soc::new();
        soc.write(0x4002_2008, 4, 0x4567_0123);
        soc.write(0x4002_2008, 4, 0xCDEF_89AB);
        soc.write(0x4002_2014, 4, 2 | (60 << 3) | (1 << 16));
        assert_eq!(soc.flash_fill.len(), 1);
        assert_eq!(soc.flash_fill[0].0, 0x0801_E000);
        assert_eq!(soc.stall, PAGE_ERASE_CYCLES);
    }

    #[test]
    fn pins_read_what_drives_them() {
        let mut soc = Soc::new();
        // PC6 input with pull-up, nothing outside: high; a pressed key: low.
        soc.write(0x4800_0800, 4, soc.gpio[2].regs.value(0) & !(3 << 12));
        soc.write(0x4800_080C, 4, 1 << 12);
        assert_ne!(soc.read(0x4800_0810, 4) & (1 << 6), 0);
        soc.drive_pin(2, 6, Some(false));
        assert_eq!(soc.read(0x4800_0810, 4) & (1 << 6), 0);
        // PB11 push-pull output set through BSRR, cleared through BRR.
        soc.write(0x4800_0400, 4, soc.gpio[1].regs.value(0) & !(3 << 22) | (1 << 22));
        soc.write(0x4800_0418, 4, 1 << 11);
        assert!(soc.gpio[1].level(11));
        soc.write(0x4800_0428, 4, 1 << 11);
        assert!(!soc.gpio[1].level(11));
    }

    #[test]
    fn the_nvic_picks_the_highest_priority_then_the_lowest_number() {
        let mut soc = Soc::new();
        soc.write(0xE000_E100, 4, (1 << irq::TIM1_UP_TIM16) | (1 << irq::TIM2));
        soc.write(0xE000_E104, 4, 1 << (irq::TIM6_DAC - 32));
        soc.write(0xE000_E400 + irq::TIM6_DAC, 1, 0);
        soc.write(0xE000_E400 + irq::TIM1_UP_TIM16, 1, 0x10);
        soc.nvic.pend(irq::TIM1_UP_TIM16);
        soc.nvic.pend(irq::TIM6_DAC);
        assert_eq!(soc.nvic.highest_pending(), Some((irq::TIM6_DAC, 0)));
        soc.nvic.unpend(irq::TIM6_DAC);
        soc.nvic.pend(irq::TIM2);
        assert_eq!(soc.nvic.highest_pending(), Some((irq::TIM2, 0)), "priority 0 before 0x10");
    }

    #[test]
    fn the_watchdog_expires_its_reload_after_the_last_key() {
        let mut soc = Soc::new();
        soc.cycles = 1000;
        soc.write(0x4000_3000, 4, 0xCCCC);
        soc.write(0x4000_3000, 4, 0x5555);
        soc.write(0x4000_3004, 4, 3);
        soc.write(0x4000_3008, 4, 100);
        soc.write(0x4000_3000, 4, 0xAAAA);
        // (100 + 1) × 32 / 32 kHz = 101 ms at 16 MHz (the reset clock).
        assert_eq!(soc.iwdg.expiry(16_000_000), Some(1000 + 101 * 16_000));
        let mut locked = Soc::new();
        locked.write(0x4000_3004, 4, 3);
        assert!(matches!(locked.stop, Some(Stop::Misuse(_))), "PR written while locked");
    }

    #[test]
    fn an_unmodelled_register_stops_the_run_with_its_name() {
        let mut soc = Soc::new();
        let _ = soc.read(0x4000_4800, 4);
        let stop = soc.stop.clone().expect("stopped");
        assert!(stop.to_string().contains("USART3+0x000"), "{stop}");
        // A register of a modelled peripheral that the model does not hold stops it too.
        let mut soc = Soc::new();
        let _ = soc.read(0x4000_4430, 4);
        let stop = soc.stop.clone().expect("stopped");
        assert!(stop.to_string().contains("USART2+0x030"), "{stop}");
    }
}

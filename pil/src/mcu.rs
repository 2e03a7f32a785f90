//! The Cortex-M4F core running the image, and the exception model around it.
//!
//! The instruction set is Unicorn's (QEMU's Thumb-2 and VFPv4 translator, in M-profile
//! mode). What Unicorn leaves out of an M-profile core is here: the reset sequence (stack
//! pointer and reset vector from the vector table), the NVIC's choice of the next exception
//! (priorities with the G431's four bits, preemption only by a strictly higher priority,
//! `PRIMASK`, tail-chaining as a consequence of checking for pending exceptions before
//! returning to a preempted context), exception entry (the basic or FP-extended frame on
//! the main stack, 8-byte aligned, `EXC_RETURN` in `LR`, `IPSR`, `CONTROL.FPCA`) and
//! exception return (the frame popped, the preempted context restored), `WFE`/`WFI` sleep
//! with the event register, and time.
//!
//! Time is counted in executed instructions, one cycle each, at the clock the firmware set
//! up; a translated block's instructions are counted when the block starts. The run stops
//! at the block boundary after each peripheral event's instant, where the peripherals are
//! advanced and pending interrupts are taken. The firmware's busy-wait loops
//! (`cortex_m::asm::delay`: `subs rN, #1; bne`) are fast-forwarded, each skipped iteration
//! counting its two instructions, never past the next event. An interrupt pending while
//! masked is taken at the first block after the mask lifts (`CPSIE I`, or an `MSR` to
//! `PRIMASK`/`BASEPRI`/`FAULTMASK`, which is how a critical section ends).

use std::collections::HashMap;

use unicorn_engine::{Arch, ArmCpuModel, HookType, MemType, Mode, Prot, RegisterARM, Unicorn};

use crate::adc::Trigger;
use crate::elf::Image;
use crate::soc::{self, FLASH_BASE, FLASH_SIZE, RAM_BASE, RAM_SIZE, Soc, Stop};

/// R0-R7, the registers a 16-bit Thumb instruction names.
const LOW_REGISTERS: [RegisterARM; 8] = [
    RegisterARM::R0,
    RegisterARM::R1,
    RegisterARM::R2,
    RegisterARM::R3,
    RegisterARM::R4,
    RegisterARM::R5,
    RegisterARM::R6,
    RegisterARM::R7,
];

/// The word free RAM is painted with at reset.
const STACK_PAINT: u32 = 0x5AC3_5AC3;

/// Unicorn's exception number for an M-profile exception return (QEMU's
/// `EXCP_EXCEPTION_EXIT`).
const EXCP_EXCEPTION_EXIT: u32 = 8;

/// Statistics of the handlers, by exception number.
#[derive(Debug, Clone, Copy, Default)]
pub struct HandlerStats {
    /// Times entered.
    pub entries: u64,
    /// Cycles from the exception's entry to its return, including what preempted it.
    pub total_cycles: u64,
    /// The longest.
    pub max_cycles: u64,
    /// Cycles from the line's pending to the handler's first instruction, the longest.
    pub max_latency: u64,
    /// The sum of latencies.
    pub total_latency: u64,
    /// The fewest cycles.
    pub min_cycles: u64,
    /// Where the longest latency began: the cycle, the code running, the active exception.
    pub max_latency_from: (u64, u32, u32),
}

/// What the CPU did.
#[derive(Debug, Default)]
pub struct CpuState {
    /// Per exception number: stats.
    pub handlers: HashMap<u32, HandlerStats>,
    /// Active exceptions: (number, priority, entered at, EXC_RETURN, pended at).
    active: Vec<(u32, u8, u64, u32)>,
    /// When each interrupt became pending (for latency).
    pending_since: HashMap<u32, (u64, bool)>,
    /// Where the core was when each interrupt became pending: (code, active exception).
    pending_where: HashMap<u32, (u32, u32)>,
    /// Cycles spent asleep.
    pub sleep_cycles: u64,
    /// The lowest stack pointer seen at exception entry (deepest stack).
    pub lowest_sp: u32,
    /// Resets (watchdog, software).
    pub resets: Vec<(u64, &'static str)>,
    /// Where the core stood when each reset came, in the order of `resets`: the code that
    /// ran and the exceptions active (innermost last) — for a watchdog, where the image hung.
    pub reset_where: Vec<String>,
    /// The end of the last flash stall (the CPU could not run during it).
    pub last_stall_end: u64,
    /// Latencies of each interrupt not held up by a flash stall: (exception, cycles).
    pub latencies: HashMap<u32, Vec<u32>>,
}

/// The microcontroller: core, memories, peripherals.
pub struct Mcu {
    uc: Unicorn<'static, Soc>,
    image: Image,
    /// Where the CPU resumes.
    pc: u32,
    /// Peripheral events processed up to this cycle.
    processed: u64,
    /// Exception bookkeeping.
    pub cpu: CpuState,
    /// An interrupt waits for the end of an IT block.
    it_block_wait: bool,
    /// The period (its origin) whose channel-4 compare event has fired.
    cc4_done: Option<u64>,
    /// The period whose TRGO2 has fired.
    trgo2_done: Option<u64>,
}

fn err(e: unicorn_engine::uc_error) -> String {
    format!("{e:?}")
}

/// Whether the Thumb half-word starts a 32-bit instruction.
fn is_wide(halfword: u16) -> bool {
    matches!(halfword >> 11, 0b11101..=0b11111)
}

impl Mcu {
    /// Loads `image` into a fresh G431 (erased flash, then the image's segments) and resets it.
    pub fn new(image: Image) -> Result<Self, String> {
        let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB | Mode::MCLASS, Soc::new())
            .map_err(err)?;
        uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M4 as i32).map_err(err)?;
        uc.mem_map(u64::from(FLASH_BASE), u64::from(FLASH_SIZE), Prot::ALL).map_err(err)?;
        uc.mem_write(u64::from(FLASH_BASE), &vec![0xFF; FLASH_SIZE as usize]).map_err(err)?;
        uc.mem_map(u64::from(RAM_BASE), u64::from(RAM_SIZE), Prot::ALL).map_err(err)?;
        // The factory words in system memory: the 96-bit unique id (RM0440 section 48.1).
        uc.mem_map(u64::from(soc::UID_BASE & !0xFFF), 0x1000, Prot::READ).map_err(err)?;
        let uid: Vec<u8> = soc::UNIQUE_ID.iter().flat_map(|w| w.to_le_bytes()).collect();
        uc.mem_write(u64::from(soc::UID_BASE), &uid).map_err(err)?;
        for segment in &image.segments {
            uc.mem_write(u64::from(segment.address), &segment.bytes).map_err(|e| {
                format!(
                    "segment at {:#010x} ({} bytes) outside the part's memory: {e:?}",
                    segment.address,
                    segment.bytes.len()
                )
            })?;
        }
        // The peripheral regions, as MMIO: every access goes to the models.
        for (base, size) in [
            (0x4000_0000u64, 0x3_0000u64),
            (0x4800_0000, 0x2000),
            (0x5000_0000, 0x1000),
            (0x5006_0000, 0x1000),
            (0xE000_0000, 0x10_0000),
        ] {
            uc.mmio_map(
                base,
                size,
                Some(move |uc: &mut Unicorn<'_, Soc>, offset: u64, size: usize| {
                    let value = uc.get_data_mut().read((base + offset) as u32, size);
                    if uc.get_data().stop.is_some() {
                        uc.get_data_mut().deadline = 0;
                    }
                    u64::from(value)
                }),
                Some(move |uc: &mut Unicorn<'_, Soc>, offset: u64, size: usize, value: u64| {
                    let soc = uc.get_data_mut();
                    soc.write((base + offset) as u32, size, value as u32);
                    // Stopping inside a memory access would leave the core at the storing
                    // instruction, which then runs again: the next block boundary stops
                    // instead.
                    if soc.stop.is_some()
                        || soc.reset_requested.is_some()
                        || !soc.flash_fill.is_empty()
                        || soc.stall > 0
                    {
                        soc.deadline = 0;
                    }
                }),
            )
            .map_err(err)?;
        }
        // Stores into flash go through the flash interface's rules.
        uc.add_mem_hook(
            HookType::MEM_WRITE,
            u64::from(FLASH_BASE),
            u64::from(FLASH_BASE + FLASH_SIZE - 1),
            |uc: &mut Unicorn<'_, Soc>, _kind: MemType, address: u64, size: usize, value: i64| {
                let mut old = [0u8; 4];
                let _ = uc.mem_read(address & !3, &mut old);
                let soc = uc.get_data_mut();
                let stands =
                    soc.flash_store(address as u32, size, value as u32, u32::from_le_bytes(old));
                if !stands || soc.stall > 0 {
                    soc.deadline = 0;
                }
                true
            },
        )
        .map_err(err)?;
        // Instruction counting: one cycle per instruction, stop at the deadline.
        let mut flash = vec![0u8; FLASH_SIZE as usize];
        uc.mem_read(u64::from(FLASH_BASE), &mut flash).map_err(err)?;
        let mut counts: HashMap<(u32, u32), u64> = HashMap::new();
        // The firmware's link service, timed inside the control tick (`Soc::link_calls`).
        let link_service = image
            .symbols
            .iter()
            .find(|(_, (name, _))| crate::elf::demangle_short(name) == "Link::service")
            .map(|(&address, _)| address);
        uc.add_block_hook(
            u64::from(FLASH_BASE),
            u64::from(FLASH_BASE + FLASH_SIZE - 1),
            move |uc: &mut Unicorn<'_, Soc>, address: u64, size: u32| {
                let address = address as u32;
                let n = *counts.entry((address, size)).or_insert_with(|| {
                    let mut n = 0;
                    let mut at = address - FLASH_BASE;
                    let end = at + size;
                    while at < end {
                        let hw = u16::from_le_bytes([flash[at as usize], flash[at as usize + 1]]);
                        at += if is_wide(hw) { 4 } else { 2 };
                        n += 1;
                    }
                    n
                });
                if let Some(entry) = link_service {
                    let link = || uc.reg_read(RegisterARM::LR).unwrap_or(0) as u32;
                    let lr = if address == entry { link() } else { 0 };
                    let soc = uc.get_data_mut();
                    let cycles = soc.cycles;
                    soc.link_calls.block(address, cycles, entry, || lr);
                }
                let soc = uc.get_data_mut();
                soc.cycles += n;
                soc.block_pc = address;
                if soc.cycles >= soc.deadline && !std::mem::take(&mut soc.run_one_block) {
                    let _ = uc.emu_stop();
                }
            },
        )
        .map_err(err)?;
        uc.add_intr_hook(|uc: &mut Unicorn<'_, Soc>, number: u32| {
            if number == EXCP_EXCEPTION_EXIT {
                uc.get_data_mut().stop_reason_exit = true;
            } else {
                let pc = uc.pc_read().unwrap_or(0) as u32;
                let soc = uc.get_data_mut();
                if soc.stop.is_none() {
                    soc.stop =
                        Some(Stop::CpuFault { error: format!("CPU exception {number}"), pc });
                }
            }
            let _ = uc.emu_stop();
        })
        .map_err(err)?;
        let mut mcu = Self {
            uc,
            image,
            pc: 0,
            processed: 0,
            cpu: CpuState::default(),
            cc4_done: None,
            trgo2_done: None,
            it_block_wait: false,
        };
        mcu.hook_idle_and_delays()?;
        if let Ok(spec) = std::env::var("TAUT_PIL_WATCH") {
            for a in spec
                .split(',')
                .filter_map(|a| u32::from_str_radix(a.trim_start_matches("0x"), 16).ok())
            {
                mcu.uc
                    .add_code_hook(
                        u64::from(a),
                        u64::from(a),
                        |uc: &mut Unicorn<'_, Soc>, a: u64, _s: u32| {
                            let soc = uc.get_data();
                            eprintln!(
                                "[{:>10}] at {a:#010x} r0={:#x} ev={} sleeping={}",
                                soc.cycles,
                                uc.reg_read(RegisterARM::R0).unwrap_or(0),
                                soc.event_register,
                                soc.sleeping
                            );
                        },
                    )
                    .map_err(err)?;
            }
        }
        mcu.reset("power-on")?;
        Ok(mcu)
    }

    /// Code hooks on the image's `WFE`/`WFI`/`SEV` instructions and its delay loops.
    fn hook_idle_and_delays(&mut self) -> Result<(), String> {
        let mut text = Vec::new();
        for segment in &self.image.segments {
            if segment.address >= FLASH_BASE && segment.address < FLASH_BASE + FLASH_SIZE {
                text.push((segment.address, segment.bytes.clone()));
            }
        }
        for (base, bytes) in text {
            let halfwords: Vec<u16> =
                bytes.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
            for (i, &hw) in halfwords.iter().enumerate() {
                let address = base + 2 * i as u32;
                match hw {
                    // WFE, WFI: sleep until an event.
                    0xBF20 | 0xBF30 => {
                        self.hook_at(address, |uc: &mut Unicorn<'_, Soc>, a: u64, _s: u32| {
                            // The instruction is this hook's: Unicorn does not execute WFE/WFI
                            // in M-profile mode. Skip it, sleeping unless the event register
                            // was set.
                            let soc = uc.get_data_mut();
                            if soc.event_register {
                                soc.event_register = false;
                            } else {
                                soc.sleeping = true;
                            }
                            soc.resume_at = Some(a as u32 + 2);
                            let _ = uc.emu_stop();
                        })?;
                    }
                    // CPSIE I, or MSR to PRIMASK/BASEPRI/BASEPRI_MAX/FAULTMASK (a critical
                    // section's end restores PRIMASK): a pending interrupt masked until now is
                    // taken at the next block.
                    _ if hw == 0xB662
                        || (hw & 0xFFF0 == 0xF380
                            && halfwords.get(i + 1).is_some_and(|&next| {
                                next & 0xFF00 == 0x8800 && (0x10..=0x13).contains(&(next & 0xFF))
                            })) =>
                    {
                        self.hook_at(address, |uc: &mut Unicorn<'_, Soc>, _a: u64, _s: u32| {
                            let soc = uc.get_data_mut();
                            soc.latch_interrupt_lines();
                            if soc.nvic.highest_pending().is_some() {
                                soc.deadline = 0;
                            }
                        })?;
                    }
                    // SEV.
                    0xBF40 => {
                        self.hook_at(address, |uc: &mut Unicorn<'_, Soc>, _a: u64, _s: u32| {
                            uc.get_data_mut().event_register = true;
                        })?;
                    }
                    // `subs rN, #1` followed by `bne` back to it: cortex_m::asm::delay.
                    _ if hw & 0xF8FF == 0x3801 && halfwords.get(i + 1) == Some(&0xD1FD) => {
                        let reg = u32::from((hw >> 8) & 7);
                        let register = LOW_REGISTERS[reg as usize];
                        self.hook_at(
                            address,
                            move |uc: &mut Unicorn<'_, Soc>, _a: u64, _s: u32| {
                                let left = uc.reg_read(register).unwrap_or(0);
                                let soc = uc.get_data();
                                let room = soc.deadline.saturating_sub(soc.cycles) / 2;
                                let skip = left.saturating_sub(1).min(room);
                                if skip > 0 {
                                    let _ = uc.reg_write(register, left - skip);
                                    uc.get_data_mut().cycles += 2 * skip;
                                }
                            },
                        )?;
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// A code hook on the one instruction at `address`.
    fn hook_at(
        &mut self,
        address: u32,
        hook: impl FnMut(&mut Unicorn<'_, Soc>, u64, u32) + 'static,
    ) -> Result<(), String> {
        self.uc.add_code_hook(u64::from(address), u64::from(address), hook).map(|_| ()).map_err(err)
    }

    /// The image.
    pub fn image(&self) -> &Image {
        &self.image
    }

    /// The peripherals.
    pub fn soc(&self) -> &Soc {
        self.uc.get_data()
    }

    /// The peripherals, to drive inputs.
    pub fn soc_mut(&mut self) -> &mut Soc {
        self.uc.get_data_mut()
    }

    fn reg(&self, r: RegisterARM) -> u32 {
        self.uc.reg_read(r).unwrap_or(0) as u32
    }

    fn set_reg(&mut self, r: RegisterARM, v: u32) {
        let _ = self.uc.reg_write(r, u64::from(v));
    }

    fn read_u32(&self, address: u32) -> u32 {
        let mut b = [0u8; 4];
        let _ = self.uc.mem_read(u64::from(address), &mut b);
        u32::from_le_bytes(b)
    }

    fn write_u32(&mut self, address: u32, value: u32) -> Result<(), String> {
        self.uc
            .mem_write(u64::from(address), &value.to_le_bytes())
            .map_err(|e| format!("stack write at {address:#010x}: {e:?}"))
    }

    /// Reads `len` bytes of memory.
    pub fn read_memory(&self, address: u32, len: usize) -> Vec<u8> {
        let mut b = vec![0u8; len];
        let _ = self.uc.mem_read(u64::from(address), &mut b);
        b
    }

    /// Writes memory directly (the bench's probe: the flash contents before power-up).
    pub fn write_memory(&mut self, address: u32, bytes: &[u8]) -> Result<(), String> {
        self.uc.mem_write(u64::from(address), bytes).map_err(err)
    }

    /// A reset: the core and every peripheral to their reset state; flash and RAM keep their
    /// contents (RAM is undefined after a reset; the firmware's start-up initialises it).
    pub fn reset(&mut self, why: &'static str) -> Result<(), String> {
        let cycles = self.soc().cycles;
        let code = self.describe(self.soc().block_pc);
        let active: Vec<String> =
            self.soc().nvic.active.iter().map(|(n, _)| format!("exception {n}")).collect();
        let context =
            if active.is_empty() { "thread mode".to_string() } else { active.join(" in ") };
        let masks = format!(
            "PRIMASK {}, BASEPRI {:#04x}",
            self.reg(RegisterARM::PRIMASK) & 1,
            self.reg(RegisterARM::BASEPRI) & 0xFF
        );
        let soc = self.soc();
        let word = (soc::irq::TIM6_DAC / 32) as usize;
        let bit = soc::irq::TIM6_DAC % 32;
        let masks = format!(
            "{masks}; TIM6 running {}, DIER {:#x}, ARR {}, PSC {}, line {}, NVIC enabled {} pending {}",
            soc.tim6.running,
            soc.tim6.regs.value(0x0C),
            soc.tim6.arr,
            soc.tim6.psc,
            soc.tim6.interrupt_line(),
            soc.nvic.enabled[word] >> bit & 1,
            soc.nvic.pending[word] >> bit & 1
        );
        let context = format!("{context}; {masks}");
        self.cpu.reset_where.push(format!("{code} ({context})"));
        let analog = self.soc().analog.clone();
        let externals: Vec<[Option<bool>; 16]> =
            self.soc().gpio.iter().map(|g| g.external).collect();
        let mut soc = Soc::new();
        soc.cycles = cycles;
        soc.analog = analog;
        for (g, e) in soc.gpio.iter_mut().zip(externals) {
            g.external = e;
        }
        *self.uc.get_data_mut() = soc;
        self.processed = cycles;
        self.cpu.active.clear();
        self.cpu.pending_since.clear();
        self.cpu.pending_where.clear();
        self.cpu.resets.push((cycles, why));
        let sp = self.read_u32(FLASH_BASE);
        let pc = self.read_u32(FLASH_BASE + 4);
        // Stack painting: the free RAM between the statics' end and the stack's top gets a
        // pattern; the deepest stack is where the pattern is first found overwritten.
        if let Some((bottom, top)) = self.stack_region() {
            let words = (top - bottom) as usize / 4;
            let paint: Vec<u8> =
                STACK_PAINT.to_le_bytes().iter().copied().cycle().take(words * 4).collect();
            let _ = self.uc.mem_write(u64::from(bottom), &paint);
        }
        for r in LOW_REGISTERS.into_iter().chain([
            RegisterARM::R8,
            RegisterARM::R9,
            RegisterARM::R10,
            RegisterARM::R11,
            RegisterARM::R12,
        ]) {
            self.set_reg(r, 0);
        }
        self.set_reg(RegisterARM::CONTROL, 0);
        self.set_reg(RegisterARM::PRIMASK, 0);
        self.set_reg(RegisterARM::BASEPRI, 0);
        self.set_reg(RegisterARM::IPSR, 0);
        self.set_reg(RegisterARM::SP, sp);
        self.set_reg(RegisterARM::LR, 0xFFFF_FFFF);
        self.cpu.lowest_sp = sp;
        self.pc = pc & !1;
        Ok(())
    }

    /// The current execution priority: the highest (lowest number) of the active
    /// exceptions, or of `PRIMASK`; 256 in thread mode with nothing masked.
    fn execution_priority(&self) -> u16 {
        let mut p: u16 = 256;
        for &(_, prio, _, _) in &self.cpu.active {
            p = p.min(u16::from(prio));
        }
        if self.reg(RegisterARM::PRIMASK) & 1 != 0 {
            p = 0;
        }
        let basepri = self.reg(RegisterARM::BASEPRI) & 0xF0;
        if basepri != 0 {
            p = p.min(basepri as u16);
        }
        p
    }

    /// Takes the highest-priority pending interrupt if it may preempt.
    fn take_interrupt(&mut self) -> Result<bool, String> {
        let soc = self.uc.get_data_mut();
        soc.latch_interrupt_lines();
        let now = soc.cycles;
        for n in 0..128u32 {
            // Latency counts from when the interrupt is pending and enabled: a line that pended
            // before its start-up enabled it waited by design.
            let (word, bit) = ((n / 32) as usize, n % 32);
            if soc.nvic.pending[word] >> bit & 1 != 0 && soc.nvic.enabled[word] >> bit & 1 != 0 {
                // Pended while the flash is unlocked for a write or an erase: the store's
                // time, reported with the store.
                let flashing = !soc.flash.locked();
                let pc = soc.block_pc;
                let active = soc.nvic.active.last().map_or(0, |a| a.0);
                if std::env::var_os("TAUT_PIL_WHY").is_some()
                    && !self.cpu.pending_since.contains_key(&n)
                {
                    eprintln!("[{now}] irq {n} pending");
                }
                self.cpu.pending_since.entry(n).or_insert((now, flashing));
                self.cpu.pending_where.entry(n).or_insert((pc, active));
            }
        }
        let Some((n, priority)) = self.uc.get_data().nvic.highest_pending() else {
            return Ok(false);
        };
        if u16::from(priority) >= self.execution_priority() {
            if std::env::var_os("TAUT_PIL_WHY").is_some() {
                eprintln!(
                    "[{now}] irq {n} prio {priority} waits: execution priority {} primask {} basepri {} active {:?} pc {:#x}",
                    self.execution_priority(),
                    self.reg(RegisterARM::PRIMASK),
                    self.reg(RegisterARM::BASEPRI),
                    self.cpu.active,
                    self.pc
                );
            }
            return Ok(false);
        }
        // The IT state of an interrupted block would be lost: finish it first.
        let xpsr = self.reg(RegisterARM::XPSR);
        if xpsr & 0x0600_FC00 != 0 {
            if std::env::var_os("TAUT_PIL_WHY").is_some() {
                eprintln!(
                    "[{}] irq {n} waits for an IT block: xpsr {xpsr:#010x} pc {:#x}",
                    self.soc().cycles,
                    self.pc
                );
            }
            // Run the block at the resume point, then stop again at the next: the IT block
            // ends within four instructions.
            let soc = self.uc.get_data_mut();
            soc.deadline = 0;
            soc.run_one_block = true;
            self.it_block_wait = true;
            return Ok(false);
        }
        self.enter(n, priority)?;
        Ok(true)
    }

    fn enter(&mut self, n: u32, priority: u8) -> Result<(), String> {
        let exception = n + 16;
        let control = self.reg(RegisterARM::CONTROL);
        let fp_frame = control & 4 != 0;
        let sp = self.reg(RegisterARM::SP);
        let words = if fp_frame { 26 } else { 8 };
        let mut frame = sp - words * 4;
        let realigned = frame & 4 != 0;
        if realigned {
            frame -= 4;
        }
        let ipsr = self.cpu.active.last().map_or(0, |a| a.0);
        let apsr = self.reg(RegisterARM::XPSR) & 0xF80F_0000;
        let xpsr = apsr | (1 << 24) | ipsr | if realigned { 1 << 9 } else { 0 };
        let regs = [
            self.reg(RegisterARM::R0),
            self.reg(RegisterARM::R1),
            self.reg(RegisterARM::R2),
            self.reg(RegisterARM::R3),
            self.reg(RegisterARM::R12),
            self.reg(RegisterARM::LR),
            self.pc,
            xpsr,
        ];
        for (i, value) in regs.into_iter().enumerate() {
            self.write_u32(frame + 4 * i as u32, value)?;
        }
        if fp_frame {
            for i in 0..16u32 {
                let value = self.uc.reg_read(RegisterARM::S0 as i32 + i as i32).unwrap_or(0) as u32;
                self.write_u32(frame + 32 + 4 * i, value)?;
            }
            let fpscr = self.reg(RegisterARM::FPSCR);
            self.write_u32(frame + 96, fpscr)?;
        }
        let exc_return = 0xFFFF_FFE1
            | if fp_frame { 0 } else { 0x10 }
            | if self.cpu.active.is_empty() { 0x8 } else { 0 };
        self.set_reg(RegisterARM::SP, frame);
        self.set_reg(RegisterARM::LR, exc_return);
        self.set_reg(RegisterARM::CONTROL, control & !4);
        self.set_reg(RegisterARM::IPSR, exception);
        let vtor = self.uc.get_data().nvic.regs.value(0xE000_ED08);
        let base = if vtor == 0 { FLASH_BASE } else { vtor };
        let handler = self.read_u32(base + 4 * exception);
        self.pc = handler & !1;
        let now = self.soc().cycles;
        self.cpu.lowest_sp = self.cpu.lowest_sp.min(frame);
        let soc = self.uc.get_data_mut();
        soc.nvic.unpend(n);
        soc.nvic.active.push((exception, priority));
        soc.event_register = true;
        soc.sleeping = false;
        let (pended, flashing) = self.cpu.pending_since.remove(&n).unwrap_or((now, false));
        let flashing = flashing || self.soc().flash_unlocked_since(pended);
        let (pend_pc, pend_active) = self.cpu.pending_where.remove(&n).unwrap_or((0, 0));
        let stats = self
            .cpu
            .handlers
            .entry(exception)
            .or_insert(HandlerStats { min_cycles: u64::MAX, ..HandlerStats::default() });
        stats.entries += 1;
        let latency = now - pended;
        if latency > 5000 && std::env::var_os("TAUT_PIL_WHY").is_some() {
            eprintln!(
                "[{now}] exception {exception} entered {latency} cycles after pending at {pended}; flashing {flashing}"
            );
        }
        // A flash stall holds every interrupt up by design (the bridge is off then): it is
        // the store's cost, reported with the store, not the binding's latency.
        if pended >= self.cpu.last_stall_end && !flashing {
            if latency > stats.max_latency {
                stats.max_latency = latency;
                stats.max_latency_from = (pended, pend_pc, pend_active);
            }
            stats.total_latency += latency;
            self.cpu.latencies.entry(exception).or_default().push(latency as u32);
        }
        self.cpu.active.push((exception, priority, now, exc_return));
        Ok(())
    }

    fn exit(&mut self) -> Result<(), String> {
        let returned_to = self.reg(RegisterARM::PC) | 1;
        let Some((exception, _, entered, exc_return)) = self.cpu.active.pop() else {
            return Err(format!("exception return ({returned_to:#010x}) in thread mode"));
        };
        if returned_to != exc_return {
            return Err(format!(
                "exception return with {returned_to:#010x}, entered with {exc_return:#010x}"
            ));
        }
        let now = self.soc().cycles;
        if let Some(stats) = self.cpu.handlers.get_mut(&exception) {
            let took = now - entered;
            stats.total_cycles += took;
            stats.max_cycles = stats.max_cycles.max(took);
            stats.min_cycles = stats.min_cycles.min(took);
        }
        let frame = self.reg(RegisterARM::SP);
        let fp_frame = exc_return & 0x10 == 0;
        let word = |i: u32| self.read_u32(frame + 4 * i);
        let (r0, r1, r2, r3, r12, lr, pc, xpsr) =
            (word(0), word(1), word(2), word(3), word(4), word(5), word(6), word(7));
        if fp_frame {
            for i in 0..16u32 {
                let value = self.read_u32(frame + 32 + 4 * i);
                let _ = self.uc.reg_write(RegisterARM::S0 as i32 + i as i32, u64::from(value));
            }
            let fpscr = self.read_u32(frame + 96);
            self.set_reg(RegisterARM::FPSCR, fpscr);
        }
        let mut sp = frame + if fp_frame { 104 } else { 32 };
        if xpsr & (1 << 9) != 0 {
            sp += 4;
        }
        for (r, v) in [
            (RegisterARM::R0, r0),
            (RegisterARM::R1, r1),
            (RegisterARM::R2, r2),
            (RegisterARM::R3, r3),
            (RegisterARM::R12, r12),
            (RegisterARM::LR, lr),
        ] {
            self.set_reg(r, v);
        }
        self.set_reg(RegisterARM::SP, sp);
        self.set_reg(RegisterARM::APSR_NZCVQ, xpsr & 0xF800_0000);
        let control = self.reg(RegisterARM::CONTROL);
        self.set_reg(RegisterARM::CONTROL, if fp_frame { control | 4 } else { control & !4 });
        self.set_reg(RegisterARM::IPSR, xpsr & 0x1FF);
        self.pc = pc & !1;
        let soc = self.uc.get_data_mut();
        soc.nvic.active.pop();
        soc.event_register = true;
        Ok(())
    }

    /// The next peripheral event after `after`, and what it is.
    fn next_event(&self, after: u64) -> Option<(u64, Event)> {
        let soc = self.soc();
        let mut candidates: Vec<(u64, Event)> = Vec::with_capacity(6);
        let tim1 = &soc.tim1;
        // The update first: at a tie it starts the period whose compare events follow.
        if let Some(t) = tim1.next_update(after) {
            candidates.push((t, Event::Tim1Update));
        }
        if tim1.running {
            // Each compare event fires once per period, at its instant (which may be the
            // period's first cycle, the instant of the update itself).
            let end = tim1.origin + tim1.period_cycles();
            let mut once = |t: Option<u64>, done: Option<u64>, e: Event| {
                if let Some(t) = t.filter(|&t| t < end && t >= after && done != Some(tim1.origin)) {
                    candidates.push((t, e));
                }
            };
            once(tim1.compare_instant(tim1.origin, tim1.ccr[3]), self.cc4_done, Event::Tim1Cc4);
            let mms2 = (tim1.regs.value(0x04) >> 20) & 0xF;
            if mms2 == 0b1000 {
                once(
                    tim1.compare_instant(tim1.origin, tim1.ccr[4]),
                    self.trgo2_done,
                    Event::Tim1Trgo2,
                );
            }
        }
        for (t, e) in [
            (soc.tim6.next_update(after), Event::Tim6Update),
            (soc.tim2.next_update(after), Event::Tim2Update),
            (soc.iwdg.expiry(soc.sysclk_hz()).filter(|&t| t > after), Event::Watchdog),
        ] {
            if let Some(t) = t {
                candidates.push((t, e));
            }
        }
        let mut best: Option<(u64, Event)> = None;
        for c in candidates {
            if best.is_none_or(|(bt, _)| c.0 < bt) {
                best = Some(c);
            }
        }
        best
    }

    fn process(&mut self, event: Event, at: u64) -> Result<(), String> {
        let soc = self.uc.get_data_mut();
        match event {
            Event::Tim1Update => {
                soc.tim1.update_event(at, false);
            }
            Event::Tim1Cc4 => {
                self.cc4_done = Some(soc.tim1.origin);
                soc.tim1.flag(crate::tim::CC4IF);
                soc.adc_trigger(Trigger::Tim1Cc4);
            }
            Event::Tim1Trgo2 => {
                self.trgo2_done = Some(soc.tim1.origin);
                soc.adc_trigger(Trigger::Tim1Trgo2);
            }
            Event::Tim6Update => soc.tim6.update_event(at, false),
            Event::Tim2Update => soc.tim2.update_event(at, false),
            Event::Watchdog => {
                soc.reset_requested = Some("watchdog (IWDG)");
            }
        }
        Ok(())
    }

    /// Runs the CPU and the peripherals until cycle `until`. Returns early (with `Err`)
    /// if the run must stop.
    pub fn run_until(&mut self, until: u64) -> Result<(), Stop> {
        loop {
            // Peripheral events due by now.
            let now = self.soc().cycles;
            while let Some((at, event)) = self.next_event(self.processed) {
                if at > now {
                    break;
                }
                self.processed = at;
                self.process(event, at).map_err(Stop::Misuse)?;
            }
            self.processed = self.processed.max(now);
            if let Some(why) = self.uc.get_data_mut().reset_requested.take() {
                self.reset(why).map_err(Stop::Misuse)?;
                continue;
            }
            if let Some(stop) = self.soc().stop.clone() {
                return Err(stop);
            }
            if now >= until {
                return Ok(());
            }
            while self.take_interrupt().map_err(Stop::Misuse)? {}
            let mut next = self.next_event(self.processed).map_or(until, |(t, _)| t.min(until));
            if std::mem::take(&mut self.it_block_wait) {
                next = self.soc().cycles + 1;
            }
            if self.soc().sleeping {
                // Asleep with nothing to take: the clock runs to the next event.
                let soc = self.uc.get_data_mut();
                self.cpu.sleep_cycles += next.saturating_sub(soc.cycles);
                soc.cycles = soc.cycles.max(next);
                let pending = soc.nvic.highest_pending().is_some();
                if pending || soc.cycles >= until {
                    soc.sleeping = !pending;
                }
                if soc.sleeping {
                    continue;
                }
                continue;
            }
            self.uc.get_data_mut().deadline = next;
            let start = self.pc | 1;
            let result = self.uc.emu_start(u64::from(start), 0, 0, 0);
            self.pc = self.reg(RegisterARM::PC);
            let soc = self.uc.get_data_mut();
            // Flash erases land now; the CPU stalled while the flash was busy.
            let fills = std::mem::take(&mut soc.flash_fill);
            let stall = std::mem::take(&mut soc.stall);
            soc.cycles += stall;
            if stall > 0 {
                self.cpu.last_stall_end = soc.cycles;
            }
            for (address, bytes) in fills {
                self.uc
                    .mem_write(u64::from(address), &bytes)
                    .map_err(|e| Stop::Misuse(format!("erase: {e:?}")))?;
            }
            // A WFE/WFI was taken by its hook: the core resumes after it (Unicorn may have
            // refused the instruction itself, which is then no error).
            if let Some(resume) = self.uc.get_data_mut().resume_at.take() {
                self.pc = resume;
                continue;
            }
            if std::mem::take(&mut self.uc.get_data_mut().stop_reason_exit) {
                self.exit().map_err(Stop::Misuse)?;
                continue;
            }
            if let Err(e) = result {
                let pc = self.pc;
                return Err(Stop::CpuFault {
                    error: format!("{e:?} ({})", self.image.describe(pc)),
                    pc,
                });
            }
        }
    }

    /// The stack's region: from the end of the statics (`__euninit`) to `_stack_start`.
    fn stack_region(&self) -> Option<(u32, u32)> {
        let bottom = self.image.symbol("__euninit").or_else(|| self.image.symbol("__ebss"))?;
        let top = self.image.symbol("_stack_start")?;
        (bottom < top && top <= RAM_BASE + RAM_SIZE).then_some(((bottom + 3) & !3, top))
    }

    /// The deepest stack since the last reset, bytes, from the painted RAM; and the stack's
    /// room (top to the end of the statics).
    pub fn stack_high_water(&self) -> Option<(u32, u32)> {
        let (bottom, top) = self.stack_region()?;
        let bytes = self.read_memory(bottom, (top - bottom) as usize);
        let untouched = bytes
            .chunks_exact(4)
            .take_while(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]) == STACK_PAINT)
            .count() as u32;
        Some((top - bottom - 4 * untouched, top - bottom))
    }

    /// The cycle counter.
    pub fn cycles(&self) -> u64 {
        self.soc().cycles
    }

    /// Names an address of the image.
    pub fn describe(&self, address: u32) -> String {
        self.image.describe(address)
    }

    /// A word of memory (the bench's probe).
    pub fn peek(&self, address: u32) -> u32 {
        self.read_u32(address)
    }

    /// The program counter where the CPU stands.
    pub fn pc(&self) -> u32 {
        self.pc
    }

    /// Names a peripheral address (for reports).
    pub fn name_of(address: u32) -> String {
        soc::name_of(address)
    }
}

/// A peripheral event in time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Event {
    Tim1Update,
    Tim1Cc4,
    Tim1Trgo2,
    Tim6Update,
    Tim2Update,
    Watchdog,
}

//! The replay on QEMU's `mps2-an386`: instruction counts from SysTick, stack from paint.
//!
//! # Counting instructions
//!
//! QEMU runs with `-icount shift=7`: every instruction advances the virtual clock by exactly
//! 2⁷ = 128 ns, whatever it is, and device reads see the clock as of the reading instruction.
//! SysTick counts the board's 25 MHz system clock (40 ns), so a call's instruction count is the
//! SysTick difference across it × 40 / 128 — 3.2 counts per instruction, which makes the count
//! exact to the instruction after rounding. Rather than trust those two constants, the replay
//! calibrates them at start-up: it times an empty call (the cost of the two SysTick reads
//! around a call, subtracted from every measurement) and a block of exactly 1 000 `nop`s (the
//! counts per instruction). A measured call includes the `bl` into it and its return.
//!
//! # Measuring stack
//!
//! Below the replay loop's stack pointer a window is painted with [`PATTERN`]. After each
//! measured call the window is scanned from its bottom for the first word that is no longer
//! the pattern: everything above it was written by the call (its frames, saved registers and
//! locals), so the distance to the stack pointer is the call's stack high-water mark. The
//! scanned part is painted again for the next call. A word a call writes with the pattern
//! itself, or a frame it reserves and never writes, goes unseen (both make the figure low by
//! at most that frame); the exception frame the firmware's interrupt adds is not included.
#![allow(
    unsafe_code,
    reason = "painting and scanning the stack are raw memory accesses, and the calibration \
              block is inline assembly"
)]

use core::arch::asm;
use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use taut_core::machine::Machine;
use taut_core::store::Record;
use taut_tick_cost::{Call, Meter, Session, StateKind, replay};

/// The session, recorded on the host by `scripts/tick-cost`.
static SESSION: &[u8] = include_bytes!(env!("TAUT_TICK_COST_SESSION"));

/// What the painted stack holds where nothing has written.
const PATTERN: u32 = 0xC0DE_F00D;

/// Bytes painted below the loop's stack pointer: more than any measured call uses (a call
/// reaching the bottom is reported as `≥` this).
const WINDOW: usize = 8 * 1024;

/// The most ticks the replay keeps individual figures for.
const MAX_TICKS: usize = 40_000;

/// The most stores the replay keeps individual figures for.
const MAX_STORES: usize = 64;

/// Instruction counts of [`Drive::step`](taut_core::drive::Drive::step) are kept as a
/// histogram up to this many (larger ones only in the maximum).
const DRIVE_BINS: usize = 4_096;

/// What every call cost.
struct Stats {
    tick_instructions: [u16; MAX_TICKS],
    tick_stack: [u16; MAX_TICKS],
    tick_state: [u8; MAX_TICKS],
    ticks: usize,
    drive_histogram: [u32; DRIVE_BINS],
    drive_max: u32,
    drive_stack: u32,
    drive_calls: u32,
    store_instructions: [u16; MAX_STORES],
    store_stack: [u16; MAX_STORES],
    stores: usize,
}

/// The meter: SysTick and the painted stack.
struct Qemu {
    /// SysTick counts of nothing between the two reads, summed over [`CALIBRATION_RUNS`]
    /// runs (the quantisation of one run averages out).
    overhead_sum: u32,
    /// SysTick counts of 1 000 instructions.
    per_thousand: u32,
    stats: Stats,
}

/// The current SysTick value (it counts down, 24 bits).
#[inline(always)]
fn systick() -> u32 {
    SYST::get_current()
}

impl Qemu {
    /// SysTick counts across `call` (24-bit down-counter, so `start − end` modulo 2²⁴), and
    /// the stack it used below the caller's stack pointer.
    #[inline(always)]
    fn raw<R>(call: impl FnOnce() -> R) -> (R, u32, usize) {
        let sp = cortex_m::register::msp::read() as usize;
        let bottom = sp.saturating_sub(WINDOW);
        let start = systick();
        let result = call();
        let end = systick();
        let mut low = bottom;
        // Constant bound: WINDOW / 4 words.
        while low < sp {
            // SAFETY: [bottom, sp) is this program's own stack below the live frames; nothing
            // lives there between calls.
            if unsafe { core::ptr::read_volatile(low as *const u32) } != PATTERN {
                break;
            }
            low = low.saturating_add(4);
        }
        let used = sp.saturating_sub(low);
        let mut word = low;
        while word < sp {
            // SAFETY: as above; the words the call dirtied are painted again.
            unsafe { core::ptr::write_volatile(word as *mut u32, PATTERN) };
            word = word.saturating_add(4);
        }
        (result, start.wrapping_sub(end) & 0x00FF_FFFF, used)
    }

    /// Instructions in `counts` SysTick counts of a measured call.
    fn instructions(&self, counts: u32) -> u32 {
        let runs = u64::from(CALIBRATION_RUNS);
        let net =
            u64::from(counts).saturating_mul(runs).saturating_sub(u64::from(self.overhead_sum));
        let per_thousand = u64::from(self.per_thousand.max(1)).saturating_mul(runs);
        let rounded = net
            .saturating_mul(1_000)
            .saturating_add(per_thousand / 2)
            .checked_div(per_thousand)
            .unwrap_or(0);
        u32::try_from(rounded).unwrap_or(u32::MAX)
    }
}

impl Meter for Qemu {
    #[inline(always)]
    fn measure<R>(&mut self, what: Call, call: impl FnOnce() -> R) -> R {
        let (result, counts, stack) = Self::raw(call);
        let instructions = self.instructions(counts);
        let clamp = |value: u32| u16::try_from(value).unwrap_or(u16::MAX);
        let stack = u32::try_from(stack).unwrap_or(u32::MAX);
        let stats = &mut self.stats;
        match what {
            Call::Tick(state) => {
                let at = stats.ticks;
                if let (Some(i), Some(s), Some(k)) = (
                    stats.tick_instructions.get_mut(at),
                    stats.tick_stack.get_mut(at),
                    stats.tick_state.get_mut(at),
                ) {
                    *i = clamp(instructions);
                    *s = clamp(stack);
                    *k = u8::try_from(state.index()).unwrap_or(u8::MAX);
                    stats.ticks = at.saturating_add(1);
                }
            }
            Call::DriveStep => {
                let bin = usize::try_from(instructions).unwrap_or(usize::MAX);
                if let Some(count) = stats.drive_histogram.get_mut(bin) {
                    *count = count.saturating_add(1);
                }
                stats.drive_max = stats.drive_max.max(instructions);
                stats.drive_stack = stats.drive_stack.max(stack);
                stats.drive_calls = stats.drive_calls.saturating_add(1);
            }
            Call::Encode => {
                let at = stats.stores;
                if let (Some(i), Some(s)) =
                    (stats.store_instructions.get_mut(at), stats.store_stack.get_mut(at))
                {
                    *i = clamp(instructions);
                    *s = clamp(stack);
                    stats.stores = at.saturating_add(1);
                }
            }
        }
        result
    }
}

/// Paints `WINDOW` bytes below the caller's stack pointer (and a margin for the replay
/// function's own frame). Inlined, so it runs in registers.
#[inline(always)]
fn paint_below_here() {
    let sp = cortex_m::register::msp::read() as usize;
    let mut word = sp.saturating_sub(WINDOW.saturating_mul(2)) & !3;
    // Constant bound: WINDOW / 2 words; stops short of the live frame.
    while word < sp.saturating_sub(64) {
        // SAFETY: below the stack pointer, nothing is live.
        unsafe { core::ptr::write_volatile(word as *mut u32, PATTERN) };
        word = word.saturating_add(4);
    }
}

/// A call that does nothing.
#[inline(never)]
fn empty() {
    // SAFETY: an empty block touches nothing; it keeps the call from being optimised away.
    unsafe { asm!("", options(nomem, nostack, preserves_flags)) }
}

/// A call of exactly 1 000 `nop`s more than [`empty`].
#[inline(never)]
fn thousand_nops() {
    // SAFETY: `nop`s touch nothing.
    unsafe { asm!(".rept 1000", "nop", ".endr", options(nomem, nostack, preserves_flags)) }
}

/// Runs of each calibration measurement.
const CALIBRATION_RUNS: u32 = 64;

/// Calibrates the counter: SysTick counts of nothing between the two reads (summed over
/// [`CALIBRATION_RUNS`]), and of 1 000 instructions (the difference between
/// [`thousand_nops`] and [`empty`], summed likewise and rounded).
fn calibrate() -> (u32, u32) {
    paint_below_here();
    let (mut overhead, mut empty_calls, mut nops_calls) = (0_u32, 0_u32, 0_u32);
    for _ in 0..CALIBRATION_RUNS {
        overhead = overhead.saturating_add(Qemu::raw(|| ()).1);
        empty_calls = empty_calls.saturating_add(Qemu::raw(empty).1);
        nops_calls = nops_calls.saturating_add(Qemu::raw(thousand_nops).1);
    }
    let per_thousand = nops_calls
        .saturating_sub(empty_calls)
        .saturating_add(CALIBRATION_RUNS / 2)
        .checked_div(CALIBRATION_RUNS)
        .unwrap_or(0);
    (overhead, per_thousand)
}

/// Stops here (after `debug::exit`, which ends QEMU; this only idles if it did not).
fn stop() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// min, median, max of a sorted slice.
fn spread(sorted: &[u16]) -> (u16, u16, u16) {
    let min = sorted.first().copied().unwrap_or(0);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0);
    let max = sorted.last().copied().unwrap_or(0);
    (min, median, max)
}

fn print_table(stats: &Stats, scratch: &mut [u16; MAX_TICKS]) {
    hprintln!("| call | calls | instructions min | median | max | stack (bytes) |");
    hprintln!("|---|---:|---:|---:|---:|---:|");
    let ticks = stats.ticks.min(MAX_TICKS);
    let instructions = stats.tick_instructions.get(..ticks).unwrap_or(&[]);
    let stacks = stats.tick_stack.get(..ticks).unwrap_or(&[]);
    let states = stats.tick_state.get(..ticks).unwrap_or(&[]);
    let mut row = |label: &str, name: &str, keep: &dyn Fn(u8) -> bool| {
        let mut count = 0;
        let mut stack = 0;
        for ((&value, &used), &state) in instructions.iter().zip(stacks).zip(states) {
            if keep(state) {
                if let Some(slot) = scratch.get_mut(count) {
                    *slot = value;
                }
                count = count.saturating_add(1);
                stack = stack.max(used);
            }
        }
        if count == 0 {
            return;
        }
        let sorted = scratch.get_mut(..count).unwrap_or(&mut []);
        sorted.sort_unstable();
        let (min, median, max) = spread(sorted);
        hprintln!("| {}{} | {} | {} | {} | {} | {} |", label, name, count, min, median, max, stack);
    };
    for kind in StateKind::ALL {
        let index = u8::try_from(kind.index()).unwrap_or(u8::MAX);
        row("`Machine::tick` in ", kind.name(), &|state| state == index);
    }
    row("`Machine::tick`, ", "every state", &|_| true);

    let calls = stats.drive_calls;
    let mut seen = 0_u32;
    let mut min = None;
    let mut median = None;
    for (bin, &count) in stats.drive_histogram.iter().enumerate() {
        if count == 0 {
            continue;
        }
        min.get_or_insert(bin);
        seen = seen.saturating_add(count);
        if median.is_none() && seen > calls / 2 {
            median = Some(bin);
        }
    }
    hprintln!(
        "| `Drive::step` (fast loop) | {} | {} | {} | {} | {} |",
        calls,
        min.unwrap_or(0),
        median.unwrap_or(0),
        stats.drive_max,
        stats.drive_stack
    );

    let stores = stats.stores.min(MAX_STORES);
    let mut encodes = [0_u16; MAX_STORES];
    let mut stack = 0;
    for ((slot, &value), &used) in
        encodes.iter_mut().zip(&stats.store_instructions).zip(&stats.store_stack).take(stores)
    {
        *slot = value;
        stack = stack.max(used);
    }
    let sorted = encodes.get_mut(..stores).unwrap_or(&mut []);
    sorted.sort_unstable();
    let (min, median, max) = spread(sorted);
    hprintln!(
        "| `Record::encode` (a store) | {} | {} | {} | {} | {} |",
        stores,
        min,
        median,
        max,
        stack
    );
}

#[entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        debug::exit(debug::EXIT_FAILURE);
        stop()
    };
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(0x00FF_FFFF);
    core.SYST.clear_current();
    core.SYST.enable_counter();

    let session = match Session::parse(SESSION) {
        Ok(session) => session,
        Err(error) => {
            hprintln!("tick-cost: the embedded session is unusable: {:?}", error);
            debug::exit(debug::EXIT_FAILURE);
            stop()
        }
    };
    let (overhead_sum, per_thousand) = calibrate();
    let mut meter = Qemu {
        overhead_sum,
        per_thousand,
        stats: Stats {
            tick_instructions: [0; MAX_TICKS],
            tick_stack: [0; MAX_TICKS],
            tick_state: [0; MAX_TICKS],
            ticks: 0,
            drive_histogram: [0; DRIVE_BINS],
            drive_max: 0,
            drive_stack: 0,
            drive_calls: 0,
            store_instructions: [0; MAX_STORES],
            store_stack: [0; MAX_STORES],
            stores: 0,
        },
    };
    let Ok(board) = taut_core::board::paper() else {
        hprintln!("tick-cost: the paper's board was refused");
        debug::exit(debug::EXIT_FAILURE);
        stop()
    };
    let mut machine = Machine::from_stored(Record::decode(&session.header.boot_record), &board);
    paint_below_here();
    let replayed = replay(&session, &mut machine, &mut meter);

    let header = session.header;
    let faithful = replayed.fingerprint == header.fingerprint
        && replayed.stores == header.stores
        && replayed.ticks == header.ticks;
    hprintln!(
        "calibration: {} SysTick counts per 1000 instructions, {}/{} around nothing",
        per_thousand,
        overhead_sum,
        CALIBRATION_RUNS
    );
    hprintln!(
        "session: {} ticks, {} fast-loop calls, {} stores; the replay made the recorded \
         decisions: {}",
        replayed.ticks,
        replayed.drive_steps,
        replayed.stores,
        if faithful { "yes" } else { "NO" }
    );
    hprintln!();
    let mut scratch = [0_u16; MAX_TICKS];
    print_table(&meter.stats, &mut scratch);
    debug::exit(if faithful { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    stop()
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    hprintln!("tick-cost: panic");
    debug::exit(debug::EXIT_FAILURE);
    stop()
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    hprintln!("tick-cost: hard fault");
    debug::exit(debug::EXIT_FAILURE);
    stop()
}

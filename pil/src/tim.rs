//! The timers the firmware uses (RM0440 sections 28-30): TIM1 (advanced: complementary
//! outputs, dead time, break, commutation preload, channels 4 and 5 as ADC triggers), TIM2
//! (Hall-sensor capture), TIM4 (quadrature encoder) and TIM6 (the control tick).
//!
//! The counter is a function of the CPU clock: while `CEN` is set, `CNT(t) = ((t − origin) /
//! (PSC + 1)) mod (ARR + 1)`, counting up. Preloaded registers (`PSC` always, `ARR` with `ARPE`,
//! `CCRx` with `OCxPE`) take effect at the next update event; with `CR2.CCPC` the output
//! modes and enables take effect at the next commutation event (`EGR.COMG`). The effective
//! output configuration of TIM1 is recorded with the time of each change, which is what the
//! gate-level checks evaluate.

use crate::soc::Registers;

/// Which kind of timer (which registers it has).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// TIM1: everything.
    Advanced,
    /// TIM2/TIM4: capture/compare channels 1-4, slave mode, encoder.
    General,
    /// TIM6: counter and update only.
    Basic,
}

/// TIM1's output stage as it is in effect: what the gates see.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OutputConfig {
    /// Counter enabled.
    pub running: bool,
    /// Cycle at which the counter was last 0 at the start of a period.
    pub origin: u64,
    /// Effective prescaler.
    pub psc: u32,
    /// Effective auto-reload.
    pub arr: u32,
    /// Effective compare values of channels 1-3.
    pub ccr: [u32; 3],
    /// Effective output modes (`OCxM`, 4 bits) of channels 1-3.
    pub ocm: [u8; 3],
    /// Effective `CCER`.
    pub ccer: u32,
    /// `BDTR` (with `MOE` as the hardware holds it).
    pub bdtr: u32,
    /// `CR2` (idle levels).
    pub cr2: u32,
}

/// One timer.
#[derive(Debug, Clone)]
pub struct Tim {
    /// Which registers it has.
    pub kind: Kind,
    /// The registers as software reads and writes them (the preload side).
    pub regs: Registers,
    /// Effective values.
    pub psc: u32,
    /// Effective auto-reload.
    pub arr: u32,
    /// Effective compare values, channels 1-6.
    pub ccr: [u32; 6],
    /// Effective CCMR1..3.
    pub ccmr: [u32; 3],
    /// Effective CCER.
    pub ccer: u32,
    /// Cycle of the last update (counter at 0).
    pub origin: u64,
    /// Whether the counter runs.
    pub running: bool,
    /// The encoder count (TIM4 in encoder mode): the counter's value set by the outside world.
    pub external_count: Option<u32>,
    /// TIM1's effective output configuration after each change, with the cycle it changed.
    pub changes: Vec<(u64, OutputConfig)>,
    /// The break input is asserted (TIM1).
    pub break_active: bool,
    /// Output-mode or enable writes that took effect on their own while the outputs were
    /// enabled (TIM1 without the commutation preload).
    pub unbuffered_output_writes: u64,
}

/// `SR.UIF`.
pub const UIF: u32 = 1;
/// `SR.CC1IF`.
pub const CC1IF: u32 = 1 << 1;
/// `SR.CC4IF`.
pub const CC4IF: u32 = 1 << 4;
/// `SR.COMIF`.
pub const COMIF: u32 = 1 << 5;
/// `SR.BIF`.
pub const BIF: u32 = 1 << 7;
/// `BDTR.MOE`.
pub const MOE: u32 = 1 << 15;

impl Tim {
    /// A timer in its reset state.
    pub fn new(kind: Kind) -> Self {
        let mut reset = vec![
            (0x00, 0),
            (0x04, 0),
            (0x0C, 0),
            (0x10, 0),
            (0x14, 0),
            (0x24, 0),
            (0x28, 0),
            (0x2C, 0xFFFF),
            (0x3DC, 0),
        ];
        if kind != Kind::Basic {
            reset.extend([
                (0x08, 0),
                (0x18, 0),
                (0x1C, 0),
                (0x20, 0),
                (0x34, 0),
                (0x38, 0),
                (0x3C, 0),
                (0x40, 0),
                (0x5C, 0),
                (0x58, 0),
            ]);
        }
        if kind == Kind::Advanced {
            reset.extend([
                (0x30, 0),
                (0x44, 0),
                (0x48, 0),
                (0x4C, 0),
                (0x50, 0),
                (0x54, 0),
                (0x60, 1),
                (0x64, 1),
            ]);
        }
        if kind == Kind::General {
            // TIM2 is 32-bit: ARR resets to all ones.
            reset.retain(|&(o, _)| o != 0x2C);
            reset.push((0x2C, u32::MAX));
            reset.extend([(0x60, 0), (0x64, 0)]);
        }
        Self {
            kind,
            regs: Registers::new(&reset),
            psc: 0,
            arr: if kind == Kind::General { u32::MAX } else { 0xFFFF },
            ccr: [0; 6],
            ccmr: [0; 3],
            ccer: 0,
            origin: 0,
            running: false,
            external_count: None,
            changes: Vec::new(),
            break_active: false,
            unbuffered_output_writes: 0,
        }
    }

    /// Cycles per counter period.
    pub fn period_cycles(&self) -> u64 {
        (u64::from(self.psc) + 1) * (u64::from(self.arr) + 1)
    }

    /// The counter at cycle `now`.
    pub fn count(&self, now: u64) -> u32 {
        if let Some(count) = self.external_count {
            return count;
        }
        if !self.running {
            return self.regs.value(0x24);
        }
        let ticks = now.saturating_sub(self.origin) / (u64::from(self.psc) + 1);
        (ticks % (u64::from(self.arr) + 1)) as u32
    }

    /// The next update event after `now` (running timers only).
    pub fn next_update(&self, now: u64) -> Option<u64> {
        if !self.running || self.external_count.is_some() {
            return None;
        }
        let period = self.period_cycles();
        let since = now.saturating_sub(self.origin);
        Some(self.origin + (since / period + 1) * period)
    }

    /// The cycle in the current period (starting at `period_start`) at which the counter
    /// reaches `compare`, if it does.
    pub fn compare_instant(&self, period_start: u64, compare: u32) -> Option<u64> {
        (compare <= self.arr).then(|| period_start + u64::from(compare) * (u64::from(self.psc) + 1))
    }

    fn sr(&self) -> u32 {
        self.regs.value(0x10)
    }

    /// Sets status flags.
    pub fn flag(&mut self, bits: u32) {
        let sr = self.sr() | bits;
        self.regs.set(0x10, sr);
    }

    /// Whether an enabled interrupt flag is set (the timer's interrupt line).
    pub fn interrupt_line(&self) -> bool {
        self.sr() & self.regs.value(0x0C) & 0xFF != 0
    }

    /// The output configuration in effect now (TIM1).
    pub fn output_config(&self) -> OutputConfig {
        OutputConfig {
            running: self.running,
            origin: self.origin,
            psc: self.psc,
            arr: self.arr,
            ccr: [self.ccr[0], self.ccr[1], self.ccr[2]],
            ocm: [ocm(self.ccmr[0], 0), ocm(self.ccmr[0], 1), ocm(self.ccmr[1], 0)],
            ccer: self.ccer,
            bdtr: self.regs.value(0x44),
            cr2: self.regs.value(0x04),
        }
    }

    fn record(&mut self, now: u64) {
        if self.kind != Kind::Advanced {
            return;
        }
        let config = self.output_config();
        if self.changes.last().map(|(_, c)| *c) != Some(config) {
            self.changes.push((now, config));
        }
    }

    /// The update event: preloaded values take effect, the counter restarts at `now`.
    pub fn update_event(&mut self, now: u64, software: bool) {
        self.psc = self.regs.value(0x28) & 0xFFFF;
        self.arr = self.regs.value(0x2C);
        let ccmr = [self.regs.value(0x18), self.regs.value(0x1C), self.regs.value(0x50)];
        for (index, ccr) in self.ccr.iter_mut().enumerate() {
            // CCR1..4 at 0x34.., CCR5 at 0x48, CCR6 at 0x4C.
            let offset = match index {
                0..=3 => 0x34 + 4 * index as u32,
                4 => 0x48,
                _ => 0x4C,
            };
            *ccr = self.regs.value(offset) & if index == 4 { 0xFFFF } else { u32::MAX };
        }
        let _ = ccmr;
        self.origin = now;
        // UG counts as an update unless URS says only overflows do.
        let urs = self.regs.value(0x00) & (1 << 2) != 0;
        if !(software && urs) {
            self.flag(UIF);
        }
        self.record(now);
    }

    /// The commutation event: preloaded output modes and enables take effect.
    pub fn commutation_event(&mut self, now: u64) {
        self.ccmr = [self.regs.value(0x18), self.regs.value(0x1C), self.regs.value(0x50)];
        self.ccer = self.regs.value(0x20);
        self.flag(COMIF);
        self.record(now);
    }

    fn preloaded_outputs(&self) -> bool {
        self.kind == Kind::Advanced && self.regs.value(0x04) & 1 != 0
    }

    /// The break input's level changed (TIM1): while active (and enabled), `MOE` is cleared
    /// and cannot be set.
    pub fn set_break(&mut self, now: u64, active: bool) {
        let enabled = self.regs.value(0x44) & (1 << 12) != 0 && self.regs.value(0x60) & 1 != 0;
        self.break_active = active && enabled;
        if self.break_active {
            let bdtr = self.regs.value(0x44);
            if bdtr & MOE != 0 || self.sr() & BIF == 0 {
                self.regs.set(0x44, bdtr & !MOE);
                self.flag(BIF);
                self.record(now);
            }
        }
    }

    /// Reads a register; `None` if unmodelled.
    pub fn read(&self, offset: u32, now: u64) -> Option<u32> {
        match offset {
            0x24 => self.regs.get(0x24).map(|_| self.count(now)),
            0x14 => self.regs.get(0x14).map(|_| 0),
            _ => self.regs.get(offset),
        }
    }

    /// Writes a register at cycle `now`; `false` if unmodelled.
    pub fn write(&mut self, offset: u32, value: u32, now: u64) -> bool {
        match offset {
            // SR: flags are cleared by writing 0, writing 1 leaves them.
            0x10 => {
                let sr = self.sr() & value;
                self.regs.set(0x10, sr)
            }
            0x14 => {
                if self.regs.get(0x14).is_none() {
                    return false;
                }
                if value & 1 != 0 {
                    self.update_event(now, true);
                }
                if value & (1 << 5) != 0 && self.kind == Kind::Advanced {
                    self.commutation_event(now);
                }
                if value & (1 << 7) != 0 && self.kind == Kind::Advanced {
                    // BG: a software break.
                    let bdtr = self.regs.value(0x44);
                    self.regs.set(0x44, bdtr & !MOE);
                    self.flag(BIF);
                    self.record(now);
                }
                true
            }
            0x00 => {
                let was = self.running;
                let ok = self.regs.set(0x00, value & 0xFFFF);
                self.running = value & 1 != 0;
                if self.running && !was {
                    // The counter continues from CNT.
                    let count = u64::from(self.regs.value(0x24));
                    self.origin = now.saturating_sub(count * (u64::from(self.psc) + 1));
                } else if !self.running && was {
                    let count = self.count(now);
                    self.regs.set(0x24, count);
                }
                self.record(now);
                ok
            }
            0x24 => {
                let ok = self.regs.set(0x24, value);
                if self.running {
                    self.origin = now.saturating_sub(u64::from(value) * (u64::from(self.psc) + 1));
                }
                self.record(now);
                ok
            }
            0x44 => {
                // BDTR: MOE cannot be set while the break input is active.
                let value = if self.break_active { value & !MOE } else { value };
                let ok = self.regs.set(0x44, value);
                self.record(now);
                ok
            }
            0x18 | 0x1C | 0x50 | 0x20 => {
                let ok = self.regs.set(offset, value);
                if !self.preloaded_outputs() {
                    // Without CR2.CCPC each register lands on its own: while the outputs are
                    // enabled, the bridge passes through the half-written states between them.
                    if self.kind == Kind::Advanced
                        && self.running
                        && self.regs.value(0x44) & MOE != 0
                    {
                        self.unbuffered_output_writes += 1;
                    }
                    self.ccmr =
                        [self.regs.value(0x18), self.regs.value(0x1C), self.regs.value(0x50)];
                    self.ccer = self.regs.value(0x20);
                    self.record(now);
                }
                ok
            }
            0x34 | 0x38 | 0x3C | 0x40 | 0x48 | 0x4C => {
                let ok = self.regs.set(offset, value);
                let index = match offset {
                    0x48 => 4,
                    0x4C => 5,
                    _ => ((offset - 0x34) / 4) as usize,
                };
                let ccmr_reg = match index {
                    0 | 1 => self.regs.value(0x18),
                    2 | 3 => self.regs.value(0x1C),
                    _ => self.regs.value(0x50),
                };
                let preload = ccmr_reg >> (if index % 2 == 0 { 3 } else { 11 }) & 1 != 0;
                if !preload {
                    self.ccr[index] = value;
                    self.record(now);
                }
                ok
            }
            0x2C => {
                let ok = self.regs.set(0x2C, value);
                if self.regs.value(0x00) & (1 << 7) == 0 {
                    self.arr = value;
                    self.record(now);
                }
                ok
            }
            0x04 => {
                let ok = self.regs.set(0x04, value);
                self.record(now);
                ok
            }
            _ => self.regs.set(offset, value),
        }
    }
}

/// `OCxM` (4 bits: bits 6:4 and bit 16 of its half) of channel `second` (0 or 1) of a CCMR.
pub fn ocm(ccmr: u32, second: u32) -> u8 {
    let half = ccmr >> (8 * second);
    (((half >> 4) & 0b111) | (((ccmr >> (16 + 8 * second)) & 1) << 3)) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pwm_timer() -> Tim {
        let mut t = Tim::new(Kind::Advanced);
        t.write(0x2C, 8499, 0);
        t.write(0x28, 0, 0);
        t.write(0x14, 1, 0);
        t.write(0x00, 1 | (1 << 7), 0);
        t
    }

    #[test]
    fn the_counter_wraps_at_the_auto_reload_and_updates_there() {
        let t = pwm_timer();
        assert_eq!(t.period_cycles(), 8500);
        assert_eq!(t.count(100), 100);
        assert_eq!(t.count(8500), 0);
        assert_eq!(t.next_update(0), Some(8500));
        assert_eq!(t.next_update(8500), Some(17_000));
    }

    #[test]
    fn compare_values_wait_for_the_update_when_preloaded() {
        let mut t = pwm_timer();
        // OC1PE set: CCR1 is preloaded.
        t.write(0x18, 1 << 3, 10);
        t.write(0x34, 1000, 20);
        assert_eq!(t.ccr[0], 0);
        t.update_event(8500, false);
        assert_eq!(t.ccr[0], 1000);
        assert!(t.regs.value(0x10) & UIF != 0);
    }

    #[test]
    fn output_modes_wait_for_the_commutation_event_with_ccpc() {
        let mut t = pwm_timer();
        t.write(0x04, 1, 0);
        t.write(0x18, 0b110 << 4, 10);
        t.write(0x20, 0b101, 10);
        assert_eq!(t.output_config().ocm[0], 0);
        assert_eq!(t.ccer, 0);
        t.write(0x14, 1 << 5, 30);
        assert_eq!(t.output_config().ocm[0], 0b0110);
        assert_eq!(t.ccer, 0b101);
        assert!(t.regs.value(0x10) & COMIF != 0);
    }

    #[test]
    fn output_writes_without_the_preload_are_counted_while_enabled() {
        let mut t = pwm_timer();
        t.write(0x44, MOE, 0);
        t.write(0x18, 0b110 << 4, 10);
        assert_eq!(t.unbuffered_output_writes, 1, "CCPC clear: the write lands alone");
        t.write(0x04, 1, 20);
        t.write(0x18, 0b100 << 4, 30);
        t.write(0x20, 0b101, 30);
        assert_eq!(t.unbuffered_output_writes, 1, "CCPC set: the writes wait for COMG");
    }

    #[test]
    fn the_break_clears_moe_and_holds_it_clear() {
        let mut t = pwm_timer();
        t.write(0x44, MOE | (1 << 12), 0);
        t.set_break(100, true);
        assert_eq!(t.regs.value(0x44) & MOE, 0);
        assert!(t.regs.value(0x10) & BIF != 0);
        t.write(0x44, MOE | (1 << 12), 200);
        assert_eq!(t.regs.value(0x44) & MOE, 0, "MOE cannot be set while the break is active");
        t.set_break(300, false);
        t.write(0x44, MOE | (1 << 12), 400);
        assert_ne!(t.regs.value(0x44) & MOE, 0);
    }

    #[test]
    fn status_flags_clear_by_writing_zero() {
        let mut t = pwm_timer();
        t.flag(UIF | BIF);
        t.write(0x10, !UIF, 0);
        assert_eq!(t.regs.value(0x10) & (UIF | BIF), BIF);
    }

    #[test]
    fn ocm_reads_the_split_mode_field() {
        assert_eq!(ocm(0b110 << 4, 0), 0b0110);
        assert_eq!(ocm((0b100 << 12) | (1 << 24), 1), 0b1100);
    }
}

//! ADC1 and ADC2 of the G431 and their common registers (RM0440 section 21), as the
//! firmware uses them: deep-power-down exit, voltage regulator, self-calibration, the enable
//! handshake, an injected sequence of one channel and a regular sequence of one channel, each
//! started by a timer trigger, the regular one oversampled (`ROVSE`, ratio 2^(OVSR+1),
//! right shift `OVSS`, one conversion per trigger with `TROVS`).
//!
//! A conversion takes the pin's voltage at the trigger instant and quantises it on the
//! 3.3 V reference: `code = round(V / 3.3 V × 4096)`, clamped to 0..=4095. Only the two
//! trigger sources the board's timing uses are modelled (TIM1_CC4 for the injected group,
//! TIM1_TRGO2 for the regular group); an armed group waiting on any other source stops the run.

use crate::soc::Registers;

/// The reference voltage.
pub const VREF: f64 = 3.3;

/// `ISR` bits.
pub const ADRDY: u32 = 1;
/// End of regular conversion.
pub const EOC: u32 = 1 << 2;
/// End of regular sequence.
pub const EOS: u32 = 1 << 3;
/// Overrun.
pub const OVR: u32 = 1 << 4;
/// End of injected conversion.
pub const JEOC: u32 = 1 << 5;
/// End of injected sequence.
pub const JEOS: u32 = 1 << 6;

/// Injected trigger `JEXTSEL` = TIM1_CC4.
pub const JEXT_TIM1_CC4: u32 = 1;
/// Regular trigger `EXTSEL` = TIM1_TRGO2.
pub const EXT_TIM1_TRGO2: u32 = 10;

/// One converter.
#[derive(Debug, Clone)]
pub struct Adc {
    /// The registers.
    pub regs: Registers,
    /// Oversampling accumulator and count.
    accumulated: (u32, u32),
    /// Conversions done (regular, injected), for the report.
    pub conversions: (u64, u64),
}

/// What a trigger asks of the converter, or why it cannot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trigger {
    /// TIM1's channel 4 compare event.
    Tim1Cc4,
    /// TIM1's TRGO2.
    Tim1Trgo2,
}

impl Default for Adc {
    fn default() -> Self {
        Self::new()
    }
}

impl Adc {
    /// A converter at reset: deep power-down.
    pub fn new() -> Self {
        let mut offsets = vec![
            (0x00, 0),
            (0x04, 0),
            (0x08, 0x2000_0000),
            (0x0C, 0x8000_0000),
            (0x10, 0),
            (0x14, 0),
            (0x18, 0),
            (0x20, 0x0FFF_0000),
            (0x24, 0x00FF_0000),
            (0x28, 0x00FF_0000),
            (0x30, 0),
            (0x34, 0),
            (0x38, 0),
            (0x3C, 0),
            (0x40, 0),
            (0x4C, 0),
            (0x60, 0),
            (0x64, 0),
            (0x68, 0),
            (0x6C, 0),
            (0x80, 0),
            (0x84, 0),
            (0x88, 0),
            (0x8C, 0),
            (0xA0, 0),
            (0xA4, 0),
            (0xB0, 0),
            (0xB4, 0),
            (0xC0, 0),
        ];
        offsets.sort_unstable();
        Self { regs: Registers::new(&offsets), accumulated: (0, 0), conversions: (0, 0) }
    }

    /// Whether the converter is enabled and ready.
    pub fn enabled(&self) -> bool {
        self.regs.value(0x08) & 1 != 0
    }

    /// The regular group's armed trigger: (`EXTSEL`, armed).
    pub fn regular_trigger(&self) -> Option<u32> {
        let cfgr = self.regs.value(0x0C);
        let exten = (cfgr >> 10) & 3;
        let started = self.regs.value(0x08) & (1 << 2) != 0;
        (self.enabled() && started && exten != 0).then_some((cfgr >> 5) & 0x1F)
    }

    /// The injected group's armed trigger (`JEXTSEL`).
    pub fn injected_trigger(&self) -> Option<u32> {
        let jsqr = self.regs.value(0x4C);
        let jexten = (jsqr >> 7) & 3;
        let started = self.regs.value(0x08) & (1 << 3) != 0;
        (self.enabled() && started && jexten != 0).then_some((jsqr >> 2) & 0x1F)
    }

    /// The channel of the regular sequence's first rank.
    pub fn regular_channel(&self) -> u32 {
        (self.regs.value(0x30) >> 6) & 0x1F
    }

    /// The channel of the injected sequence's first rank.
    pub fn injected_channel(&self) -> u32 {
        (self.regs.value(0x4C) >> 9) & 0x1F
    }

    /// The code of `volts` on this converter.
    pub fn quantise(volts: f64) -> u32 {
        (volts / VREF * 4096.0).round().clamp(0.0, 4095.0) as u32
    }

    /// A regular conversion of `volts`, through the oversampler.
    pub fn convert_regular(&mut self, volts: f64) {
        let code = Self::quantise(volts);
        self.conversions.0 += 1;
        let cfgr2 = self.regs.value(0x10);
        let result = if cfgr2 & 1 != 0 {
            let ratio = 1u32 << (((cfgr2 >> 2) & 7) + 1);
            let shift = (cfgr2 >> 5) & 0xF;
            self.accumulated.0 += code;
            self.accumulated.1 += 1;
            if self.accumulated.1 < ratio {
                return;
            }
            let sum = self.accumulated.0;
            self.accumulated = (0, 0);
            // The shifted result is rounded (RM0440, "Oversampler").
            let rounded = if shift == 0 { sum } else { (sum + (1 << (shift - 1))) >> shift };
            rounded & 0xFFFF
        } else {
            code
        };
        let isr = self.regs.value(0x00);
        let overrun = isr & EOC != 0;
        self.regs.set(0x40, result);
        self.regs.set(0x00, isr | EOC | EOS | if overrun { OVR } else { 0 });
    }

    /// An injected conversion of `volts`.
    pub fn convert_injected(&mut self, volts: f64) {
        self.conversions.1 += 1;
        self.regs.set(0x80, Self::quantise(volts));
        let isr = self.regs.value(0x00);
        self.regs.set(0x00, isr | JEOC | JEOS);
    }

    /// Reads a register.
    pub fn read(&self, offset: u32) -> Option<u32> {
        self.regs.get(offset)
    }

    /// Writes a register; `false` if unmodelled.
    pub fn write(&mut self, offset: u32, value: u32) -> bool {
        match offset {
            // ISR: write 1 to clear.
            0x00 => {
                let isr = self.regs.value(0x00) & !value;
                self.regs.set(0x00, isr)
            }
            0x08 => {
                let mut cr = value;
                // ADCAL: the calibration completes (the bench does not model its 116 clocks).
                if cr & (1 << 31) != 0 {
                    cr &= !(1 << 31);
                    self.regs.set(0xB4, 0x0040_0040);
                }
                // ADEN: ready at once; ADDIS: disabled.
                if cr & 1 != 0 {
                    let isr = self.regs.value(0x00) | ADRDY;
                    self.regs.set(0x00, isr);
                }
                if cr & 2 != 0 {
                    cr &= !3;
                }
                // ADSTP / JADSTP stop the groups.
                if cr & (1 << 4) != 0 {
                    cr &= !((1 << 4) | (1 << 2));
                }
                if cr & (1 << 5) != 0 {
                    cr &= !((1 << 5) | (1 << 3));
                }
                // The start bits are set-only: writing 0 does not stop a group.
                let old = self.regs.value(0x08);
                cr |= old
                    & ((1 << 2) | (1 << 3))
                    & !(if value & (1 << 4) != 0 { 1 << 2 } else { 0 })
                    & !(if value & (1 << 5) != 0 { 1 << 3 } else { 0 });
                if cr & 1 == 0 {
                    cr &= !((1 << 2) | (1 << 3));
                }
                self.regs.set(0x08, cr)
            }
            0x40 | 0x80 | 0x84 | 0x88 | 0x8C => true,
            _ => self.regs.set(offset, value),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn enabled() -> Adc {
        let mut a = Adc::new();
        a.write(0x08, 1 << 28);
        a.write(0x08, (1 << 28) | (1 << 31));
        a.write(0x08, (1 << 28) | 1);
        a
    }

    #[test]
    fn calibration_and_enable_complete() {
        let a = enabled();
        assert_eq!(a.regs.value(0x08) & (1 << 31), 0);
        assert_ne!(a.regs.value(0x00) & ADRDY, 0);
        assert!(a.enabled());
    }

    #[test]
    fn codes_follow_the_reference_and_clamp() {
        assert_eq!(Adc::quantise(0.0), 0);
        assert_eq!(Adc::quantise(1.65), 2048);
        assert_eq!(Adc::quantise(3.3), 4095);
        assert_eq!(Adc::quantise(-1.0), 0);
    }

    #[test]
    fn sixteen_triggered_conversions_make_one_oversampled_result() {
        let mut a = enabled();
        // ROVSE, OVSR = 3 (16×), OVSS = 4, TROVS.
        a.write(0x10, 1 | (3 << 2) | (4 << 5) | (1 << 9));
        for i in 0..15 {
            a.convert_regular(1.0 + f64::from(i) * 0.001);
            assert_eq!(a.regs.value(0x00) & EOC, 0);
        }
        a.convert_regular(1.0);
        assert_ne!(a.regs.value(0x00) & EOC, 0);
        let mean = (0..15).map(|i| Adc::quantise(1.0 + f64::from(i) * 0.001)).sum::<u32>()
            + Adc::quantise(1.0);
        assert_eq!(a.regs.value(0x40), (mean + 8) >> 4);
    }

    #[test]
    fn the_armed_triggers_are_read_from_the_sequence_registers() {
        let mut a = enabled();
        a.write(0x4C, (1 << 9) | (1 << 7) | (JEXT_TIM1_CC4 << 2));
        a.write(0x08, (1 << 28) | 1 | (1 << 3));
        assert_eq!(a.injected_trigger(), Some(JEXT_TIM1_CC4));
        assert_eq!(a.injected_channel(), 1);
        a.write(0x0C, (1 << 10) | (EXT_TIM1_TRGO2 << 5));
        a.write(0x30, 15 << 6);
        a.write(0x08, (1 << 28) | 1 | (1 << 2));
        assert_eq!(a.regular_trigger(), Some(EXT_TIM1_TRGO2));
        assert_eq!(a.regular_channel(), 15);
        assert_eq!(a.injected_trigger(), Some(JEXT_TIM1_CC4), "writing ADSTART keeps JADSTART");
    }
}

//! The TM1637 on the panel's two wires (PB5 clock, PB9 data, both open drain with the
//! module's pull-ups), as the chip's receiver sees them (Titan Micro TM1637 datasheet,
//! "Interface" and "Commands"): a start is DIO falling while CLK is high, a stop DIO rising
//! while CLK is high; bits are sampled on CLK's rising edge, least significant first; after
//! the eighth bit's falling edge the chip pulls DIO low until the ninth clock's falling edge
//! (the acknowledge). A transfer's bytes are taken as commands at its stop: `0x40` (write,
//! auto-increment), `0xC0 | address` followed by grid bytes, `0x88 | brightness` (on).

/// The chip's state and what it shows.
#[derive(Debug, Clone)]
pub struct Tm1637 {
    clk: bool,
    dio: bool,
    in_transfer: bool,
    bit: u8,
    byte: u8,
    /// The chip holds DIO low (acknowledge).
    pub acking: bool,
    bytes: Vec<u8>,
    auto_increment: bool,
    /// The six grid registers.
    pub grids: [u8; 6],
    /// Display on, and brightness 0-7.
    pub on: Option<u8>,
    /// Complete display updates received.
    pub updates: u64,
    /// Malformed transfers (a byte cut short, an unknown command).
    pub errors: u64,
}

impl Default for Tm1637 {
    /// A chip on idle lines (both pulled up).
    fn default() -> Self {
        Self {
            clk: true,
            dio: true,
            in_transfer: false,
            bit: 0,
            byte: 0,
            acking: false,
            bytes: Vec::new(),
            auto_increment: false,
            grids: [0; 6],
            on: None,
            updates: 0,
            errors: 0,
        }
    }
}

impl Tm1637 {
    /// The lines as the MCU drives them now (`true` = released); updates the chip.
    pub fn lines(&mut self, clk: bool, dio_released: bool) {
        let dio = dio_released && !self.acking;
        if self.clk && clk {
            if self.dio && !dio {
                self.in_transfer = true;
                self.bit = 0;
                self.byte = 0;
                self.bytes.clear();
            } else if !self.dio && dio && self.in_transfer {
                self.in_transfer = false;
                // The clock's rise before a stop starts a bit that the stop then ends.
                if self.bit > 1 {
                    self.errors += 1;
                    if std::env::var_os("TAUT_PIL_TRACE").is_some() {
                        eprintln!(
                            "tm1637: stop after {} bits of a byte; bytes {:02x?}",
                            self.bit, self.bytes
                        );
                    }
                }
                self.command();
            }
        }
        if !self.clk && clk && self.in_transfer && self.bit < 8 {
            self.byte |= u8::from(dio) << self.bit;
            self.bit += 1;
        }
        if self.clk && !clk && self.in_transfer {
            if self.acking {
                self.acking = false;
                self.bytes.push(self.byte);
                self.byte = 0;
                self.bit = 0;
            } else if self.bit == 8 {
                self.acking = true;
            }
        }
        self.clk = clk;
        self.dio = dio_released && !self.acking;
    }

    fn command(&mut self) {
        let Some(&first) = self.bytes.first() else { return };
        match first {
            0x40 => self.auto_increment = true,
            0x44 => self.auto_increment = false,
            c if c & 0xF0 == 0xC0 => {
                let mut address = usize::from(c & 0x0F);
                for &b in &self.bytes[1..] {
                    if let Some(g) = self.grids.get_mut(address) {
                        *g = b;
                    }
                    if self.auto_increment {
                        address += 1;
                    }
                }
                self.updates += 1;
            }
            c if c & 0xF8 == 0x88 => self.on = Some(c & 7),
            0x80 => self.on = None,
            _ => self.errors += 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Clocks `bytes` out as one transfer, LSB first, releasing DIO for each acknowledge.
    fn transfer(chip: &mut Tm1637, bytes: &[u8]) -> Vec<bool> {
        let mut acks = Vec::new();
        chip.lines(true, true);
        chip.lines(true, false);
        chip.lines(false, false);
        for &b in bytes {
            for bit in 0..8 {
                let level = b >> bit & 1 != 0;
                chip.lines(false, level);
                chip.lines(true, level);
                chip.lines(false, level);
            }
            chip.lines(false, true);
            acks.push(chip.acking);
            chip.lines(true, true);
            chip.lines(false, true);
        }
        chip.lines(false, false);
        chip.lines(true, false);
        chip.lines(true, true);
        acks
    }

    #[test]
    fn an_update_reaches_the_grids_and_every_byte_is_acknowledged() {
        let mut chip = Tm1637::default();
        assert_eq!(transfer(&mut chip, &[0x40]), [true]);
        assert_eq!(transfer(&mut chip, &[0xC0, 0x79, 0x40, 0x3F, 0x06, 0x11, 0x00]), [true; 7]);
        assert_eq!(transfer(&mut chip, &[0x8F]), [true]);
        assert_eq!(chip.grids, [0x79, 0x40, 0x3F, 0x06, 0x11, 0x00]);
        assert_eq!(chip.on, Some(7));
        assert_eq!(chip.updates, 1);
        assert_eq!(chip.errors, 0);
    }
}

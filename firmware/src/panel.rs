//! The front panel's display: a TM1637 LED driver on two wires, bit-banged.
//!
//! # Theory of operation
//!
//! The core renders the panel itself — four [`Segments`] bitmaps and the [`Leds`] lamps — so
//! this module only has to get those bits onto the glass. The TM1637 drives up to six digit
//! grids of eight segments and talks a two-wire, I²C-like but address-less protocol
//! (Titan Micro TM1637 datasheet, sections "Interface" and "Commands"):
//!
//! - a **start** is DIO falling while CLK is high, a **stop** is DIO rising while CLK is high;
//! - bytes go **least-significant bit first**, DIO changing while CLK is low and sampled on
//!   the rising edge; after the eighth bit the chip pulls DIO low for one clock (**ACK**);
//! - a display update is three transfers: data command `0x40` (write, auto-increment), then
//!   address command `0xC0` followed by the six grid bytes, then display control
//!   `0x88 | brightness` (display on).
//!
//! Grids 1–4 are the digits, leftmost first, with the core's segment order (bit 0 = a …
//! bit 6 = g, bit 7 = decimal point), which is the TM1637's SEG1…SEG8 order. Grid 5 carries
//! the lamps, one segment line each ([`lamp_bits`]); grid 6 is unused.
//!
//! Both lines are open drain with the module's pull-ups: "high" means released. No available
//! crate was worth its weight for three fixed transfers, so the protocol is written here
//! against embedded-hal 1.0 pins and delays and tested on the host against a model of the
//! chip's receiver.

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};
use taut_core::io::{Display, Leds, Segments};

/// Data command: write to display registers, auto-increment the address.
pub const DATA_COMMAND: u8 = 0x40;
/// Address command for grid 1; grids 2–6 follow.
pub const ADDRESS_COMMAND: u8 = 0xC0;
/// Display-control command with the display switched on; the low three bits are brightness.
pub const DISPLAY_ON: u8 = 0x88;
/// Half a clock period: 5 µs, a 100 kHz bus, well inside the chip's limits.
pub const HALF_PERIOD_US: u32 = 5;

/// Display brightness, 0 (dimmest) ..= 7 (brightest): the TM1637's pulse-width steps.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Brightness(u8);

impl Brightness {
    /// The brightest setting.
    pub const MAX: Self = Self(7);

    /// A brightness level, clamped to 0 ..= 7.
    #[must_use]
    pub const fn new(level: u8) -> Self {
        if level > 7 { Self::MAX } else { Self(level) }
    }

    /// The level, 0 ..= 7.
    #[must_use]
    pub const fn level(self) -> u8 {
        self.0
    }
}

/// The lamps as the segment lines of grid 5: SEG1 = kg, SEG2 = lb, SEG3 = pulling,
/// SEG4 = holding, SEG5 = fault, SEG6 = knot.
#[must_use]
pub const fn lamp_bits(leds: Leds) -> u8 {
    (leds.kg as u8)
        | ((leds.lb as u8) << 1)
        | ((leds.pulling as u8) << 2)
        | ((leds.holding as u8) << 3)
        | ((leds.fault as u8) << 4)
        | ((leds.knot as u8) << 5)
}

/// The seven bytes after the address command: four digits, the lamps, an unused grid.
#[must_use]
pub const fn grid_bytes(display: &Display, leds: Leds) -> [u8; 6] {
    let [Segments(d1), Segments(d2), Segments(d3), Segments(d4)] = *display;
    [d1, d2, d3, d4, lamp_bits(leds), 0]
}

/// Why a display update failed.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum PanelError {
    /// A pin could not be driven or read.
    Pin,
    /// The chip did not acknowledge a byte: display unplugged or unpowered.
    NoAck,
}

/// A TM1637 on a clock and a data pin.
pub struct Tm1637<Clock, Data, Delay> {
    clock: Clock,
    data: Data,
    delay: Delay,
}

impl<Clock, Data, Delay> Tm1637<Clock, Data, Delay>
where
    Clock: OutputPin,
    Data: OutputPin + InputPin,
    Delay: DelayNs,
{
    /// A driver on `clock` and `data` (both open drain, released = high).
    pub const fn new(clock: Clock, data: Data, delay: Delay) -> Self {
        Self { clock, data, delay }
    }

    /// Shows `display` and `leds` at `brightness`.
    ///
    /// # Errors
    /// [`PanelError`] if a pin fails or the chip does not acknowledge.
    pub fn show(
        &mut self,
        display: &Display,
        leds: Leds,
        brightness: Brightness,
    ) -> Result<(), PanelError> {
        self.transfer(&[DATA_COMMAND])?;
        let grids = grid_bytes(display, leds);
        let [g1, g2, g3, g4, g5, g6] = grids;
        self.transfer(&[ADDRESS_COMMAND, g1, g2, g3, g4, g5, g6])?;
        self.transfer(&[DISPLAY_ON | brightness.level()])
    }

    /// One start … bytes … stop transfer. The stop is sent even when a byte is not
    /// acknowledged, so the bus is left idle.
    fn transfer(&mut self, bytes: &[u8]) -> Result<(), PanelError> {
        self.start()?;
        let mut result = Ok(());
        // Bounded by the longest transfer, 7 bytes.
        for &byte in bytes {
            result = self.write_byte(byte);
            if result.is_err() {
                break;
            }
        }
        self.stop()?;
        result
    }

    fn start(&mut self) -> Result<(), PanelError> {
        self.data_high()?;
        self.clock_high()?;
        self.pause();
        self.data_low()?;
        self.pause();
        self.clock_low()
    }

    fn stop(&mut self) -> Result<(), PanelError> {
        self.clock_low()?;
        self.data_low()?;
        self.pause();
        self.clock_high()?;
        self.pause();
        self.data_high()?;
        self.pause();
        Ok(())
    }

    fn write_byte(&mut self, byte: u8) -> Result<(), PanelError> {
        // Eight data bits, least significant first.
        for bit in 0..8 {
            self.clock_low()?;
            if byte >> bit & 1 == 1 {
                self.data_high()?;
            } else {
                self.data_low()?;
            }
            self.pause();
            self.clock_high()?;
            self.pause();
        }
        // Ninth clock: release DIO; the chip holds it low to acknowledge.
        self.clock_low()?;
        self.data_high()?;
        self.pause();
        self.clock_high()?;
        let acknowledged = self.data.is_low().map_err(|_| PanelError::Pin)?;
        self.pause();
        self.clock_low()?;
        if acknowledged { Ok(()) } else { Err(PanelError::NoAck) }
    }

    fn pause(&mut self) {
        self.delay.delay_us(HALF_PERIOD_US);
    }

    fn clock_high(&mut self) -> Result<(), PanelError> {
        self.clock.set_high().map_err(|_| PanelError::Pin)
    }

    fn clock_low(&mut self) -> Result<(), PanelError> {
        self.clock.set_low().map_err(|_| PanelError::Pin)
    }

    fn data_high(&mut self) -> Result<(), PanelError> {
        self.data.set_high().map_err(|_| PanelError::Pin)
    }

    fn data_low(&mut self) -> Result<(), PanelError> {
        self.data.set_low().map_err(|_| PanelError::Pin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::cell::RefCell;
    use core::convert::Infallible;
    use std::rc::Rc;
    use std::vec::Vec;

    /// A model of the TM1637's receiver, watching both lines.
    #[derive(Default)]
    struct Chip {
        clock: bool,
        /// What the controller drives on DIO (true = released).
        data_driven: bool,
        /// Whether the chip is pulling DIO low (acknowledging).
        pulling_low: bool,
        present: bool,
        in_transfer: bool,
        bits: u8,
        count: u8,
        transfers: Vec<Vec<u8>>,
    }

    impl Chip {
        fn data(&self) -> bool {
            self.data_driven && !self.pulling_low
        }

        fn set_clock(&mut self, level: bool) {
            let rising = level && !self.clock;
            let falling = !level && self.clock;
            self.clock = level;
            if falling && self.count == 8 {
                // Falling edge after the eighth bit: acknowledge during the ninth clock.
                self.pulling_low = self.present;
            }
            if falling && self.count == 9 {
                self.pulling_low = false;
                self.count = 0;
                self.bits = 0;
            }
            if rising && self.in_transfer && self.count < 8 {
                self.bits |= u8::from(self.data()) << self.count;
                self.count += 1;
                if self.count == 8 {
                    self.transfers.last_mut().unwrap().push(self.bits);
                }
            } else if rising && self.count == 8 {
                self.count = 9;
            }
        }

        fn set_data(&mut self, level: bool) {
            let before = self.data();
            self.data_driven = level;
            let after = self.data();
            // DIO only changes under a high clock at a start (falling) or a stop (rising);
            // either one abandons a partly clocked byte.
            if self.clock && before != after {
                self.count = 0;
                self.bits = 0;
                self.in_transfer = !after;
                if !after {
                    self.transfers.push(Vec::new());
                }
            }
        }
    }

    struct ClockPin(Rc<RefCell<Chip>>);
    struct DataPin(Rc<RefCell<Chip>>);
    struct NoDelay;

    impl embedded_hal::digital::ErrorType for ClockPin {
        type Error = Infallible;
    }
    impl OutputPin for ClockPin {
        fn set_low(&mut self) -> Result<(), Infallible> {
            self.0.borrow_mut().set_clock(false);
            Ok(())
        }
        fn set_high(&mut self) -> Result<(), Infallible> {
            self.0.borrow_mut().set_clock(true);
            Ok(())
        }
    }
    impl embedded_hal::digital::ErrorType for DataPin {
        type Error = Infallible;
    }
    impl OutputPin for DataPin {
        fn set_low(&mut self) -> Result<(), Infallible> {
            self.0.borrow_mut().set_data(false);
            Ok(())
        }
        fn set_high(&mut self) -> Result<(), Infallible> {
            self.0.borrow_mut().set_data(true);
            Ok(())
        }
    }
    impl InputPin for DataPin {
        fn is_high(&mut self) -> Result<bool, Infallible> {
            Ok(self.0.borrow().data())
        }
        fn is_low(&mut self) -> Result<bool, Infallible> {
            Ok(!self.0.borrow().data())
        }
    }
    impl DelayNs for NoDelay {
        fn delay_ns(&mut self, _ns: u32) {}
    }

    fn panel(present: bool) -> (Tm1637<ClockPin, DataPin, NoDelay>, Rc<RefCell<Chip>>) {
        let chip = Rc::new(RefCell::new(Chip {
            clock: true,
            data_driven: true,
            present,
            ..Chip::default()
        }));
        (Tm1637::new(ClockPin(chip.clone()), DataPin(chip.clone()), NoDelay), chip)
    }

    #[test]
    fn an_update_is_three_transfers_the_chip_decodes() {
        let (mut panel, chip) = panel(true);
        let display = [Segments(0x06), Segments(0x5B), Segments(0xCF), Segments(0x7F)];
        let leds =
            Leds { kg: true, lb: false, pulling: true, holding: false, fault: true, knot: false };
        panel.show(&display, leds, Brightness::new(3)).unwrap();
        let transfers = chip.borrow().transfers.clone();
        assert_eq!(
            transfers,
            [
                std::vec![DATA_COMMAND],
                std::vec![ADDRESS_COMMAND, 0x06, 0x5B, 0xCF, 0x7F, 0b1_0101, 0],
                std::vec![0x8B],
            ]
        );
    }

    #[test]
    fn every_byte_value_survives_the_wire() {
        let (mut panel, chip) = panel(true);
        for first in (0..=u8::MAX).step_by(4) {
            let display = [Segments(first), Segments(first ^ 0xFF), Segments(1), Segments(0x80)];
            panel.show(&display, Leds::default(), Brightness::MAX).unwrap();
            let transfers = chip.borrow().transfers.clone();
            let address = &transfers[transfers.len() - 2];
            assert_eq!(address[1..5], [first, first ^ 0xFF, 1, 0x80]);
        }
    }

    #[test]
    fn a_missing_display_is_reported_and_the_bus_left_idle() {
        let (mut panel, chip) = panel(false);
        let result = panel.show(&[Segments(0); 4], Leds::default(), Brightness::MAX);
        assert_eq!(result, Err(PanelError::NoAck));
        let chip = chip.borrow();
        assert!(chip.clock && chip.data(), "both lines released after the stop");
    }

    #[test]
    fn lamps_use_one_segment_each() {
        let one = |leds| lamp_bits(leds).count_ones();
        assert_eq!(lamp_bits(Leds::default()), 0);
        assert_eq!(one(Leds { kg: true, ..Leds::default() }), 1);
        assert_eq!(one(Leds { lb: true, ..Leds::default() }), 1);
        assert_eq!(one(Leds { pulling: true, ..Leds::default() }), 1);
        assert_eq!(one(Leds { holding: true, ..Leds::default() }), 1);
        assert_eq!(one(Leds { fault: true, ..Leds::default() }), 1);
        assert_eq!(one(Leds { knot: true, ..Leds::default() }), 1);
        let all =
            Leds { kg: true, lb: true, pulling: true, holding: true, fault: true, knot: true };
        assert_eq!(lamp_bits(all), 0b11_1111);
        assert_eq!(Brightness::new(9), Brightness::MAX);
    }
}

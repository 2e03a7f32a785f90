//! The board and its pin map: which MCU pin carries which machine signal.
//!
//! # The board
//!
//! taut runs on a **NUCLEO-G431RB** (STM32G431RB: Cortex-M4F at 170 MHz, 128 KiB flash,
//! 32 KiB SRAM, the motor-control timer TIM1 with complementary outputs, hardware dead time
//! and a break input) carrying an **X-NUCLEO-IHM08M1** three-phase power board (discrete
//! 60 V MOSFETs, L6398 half-bridge drivers, 10–48 V, 15 A rms — comfortably above the paper's
//! 24 V, 5.5 A motor). The B-G431B-ESC1 has the same MCU and would need no power board, but
//! it brings out only five free I/O lines (its CAN pads sit behind a transceiver): not enough
//! for a load cell, a string encoder, two limit switches, five keys, a display and a beeper.
//!
//! # Where the table comes from
//!
//! - The power-stage pins (TIM1 channels, break input, Hall inputs, current sense) are the
//!   ones the X-NUCLEO-IHM08M1 fixes on the Nucleo-64 morpho connectors (ST UM1996; the same
//!   table is transcribed in NuttX's `boards/arm/stm32/*/README` "Pin configuration for the
//!   X-NUCLEO-IHM08M1" section, which is what was cross-checked here).
//! - Every alternate-function number is the STM32G431RB's own (datasheet DS12589, table
//!   "Alternate function"; the same data ships in `stm32-metapac`'s chip metadata), and the
//!   image cannot build with a wrong one: the hardware module creates each timer and ADC pin
//!   through embassy-stm32's typed constructors, which only accept a pin that has that
//!   function.
//! - The machine's own I/O uses pins that neither the IHM08M1 nor the Nucleo's ST-LINK,
//!   LED, button, crystals or boot pin use ([`RESERVED`]); a test checks it.

use core::fmt;

/// A GPIO port of the STM32G431RB.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Port {
    /// GPIOA.
    A,
    /// GPIOB.
    B,
    /// GPIOC.
    C,
    /// GPIOD.
    D,
    /// GPIOF.
    F,
    /// GPIOG.
    G,
}

/// One MCU pin, e.g. `PA8`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Pin {
    /// The port.
    pub port: Port,
    /// The pin number in the port, 0 ..= 15.
    pub number: u8,
}

impl Pin {
    /// `P<port><number>`.
    #[must_use]
    pub const fn new(port: Port, number: u8) -> Self {
        Self { port, number }
    }
}

impl fmt::Display for Pin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let port = match self.port {
            Port::A => 'A',
            Port::B => 'B',
            Port::C => 'C',
            Port::D => 'D',
            Port::F => 'F',
            Port::G => 'G',
        };
        write!(f, "P{port}{}", self.number)
    }
}

/// One row of the wiring table.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Assignment {
    /// The machine signal, in the domain's words.
    pub signal: &'static str,
    /// The MCU pin.
    pub pin: Pin,
    /// The peripheral function and alternate-function number.
    pub function: &'static str,
    /// What it is wired to, and its electrical sense.
    pub wiring: &'static str,
}

const fn row(
    signal: &'static str,
    pin: Pin,
    function: &'static str,
    wiring: &'static str,
) -> Assignment {
    Assignment { signal, pin, function, wiring }
}

/// PA8: phase A high side.
pub const PHASE_A_HIGH: Pin = Pin::new(Port::A, 8);
/// PA9: phase B high side.
pub const PHASE_B_HIGH: Pin = Pin::new(Port::A, 9);
/// PA10: phase C high side.
pub const PHASE_C_HIGH: Pin = Pin::new(Port::A, 10);
/// PA7: phase A low side.
pub const PHASE_A_LOW: Pin = Pin::new(Port::A, 7);
/// PB0: phase B low side.
pub const PHASE_B_LOW: Pin = Pin::new(Port::B, 0);
/// PB1: phase C low side.
pub const PHASE_C_LOW: Pin = Pin::new(Port::B, 1);
/// PA6: overcurrent comparator → TIM1 break input.
pub const OVERCURRENT: Pin = Pin::new(Port::A, 6);
/// PA0: bus-current amplifier.
pub const MOTOR_CURRENT: Pin = Pin::new(Port::A, 0);
/// PA1: DC bus voltage divider.
pub const BUS_VOLTAGE: Pin = Pin::new(Port::A, 1);
/// PA15: Hall sensor A.
pub const HALL_A: Pin = Pin::new(Port::A, 15);
/// PB3: Hall sensor B.
pub const HALL_B: Pin = Pin::new(Port::B, 3);
/// PB10: Hall sensor C.
pub const HALL_C: Pin = Pin::new(Port::B, 10);
/// PB15: load-cell amplifier (through the 5 V → 3.3 V divider).
pub const LOAD_CELL: Pin = Pin::new(Port::B, 15);
/// PB6: string encoder channel A.
pub const ENCODER_A: Pin = Pin::new(Port::B, 6);
/// PB7: string encoder channel B.
pub const ENCODER_B: Pin = Pin::new(Port::B, 7);
/// PC10: home limit switch.
pub const LIMIT_HOME: Pin = Pin::new(Port::C, 10);
/// PC11: end-of-travel limit switch.
pub const LIMIT_END: Pin = Pin::new(Port::C, 11);
/// PC6: Start key.
pub const KEY_START: Pin = Pin::new(Port::C, 6);
/// PC7: Up key.
pub const KEY_UP: Pin = Pin::new(Port::C, 7);
/// PC8: Down key.
pub const KEY_DOWN: Pin = Pin::new(Port::C, 8);
/// PC12: Function key.
pub const KEY_FUNCTION: Pin = Pin::new(Port::C, 12);
/// PD2: Preset key.
pub const KEY_PRESET: Pin = Pin::new(Port::D, 2);
/// PB5: TM1637 clock.
pub const DISPLAY_CLOCK: Pin = Pin::new(Port::B, 5);
/// PB9: TM1637 data.
pub const DISPLAY_DATA: Pin = Pin::new(Port::B, 9);
/// PB11: beeper.
pub const BEEPER: Pin = Pin::new(Port::B, 11);

/// The wiring table: every pin the firmware drives or reads.
pub const ASSIGNMENTS: [Assignment; 25] = [
    row("phase A high side", PHASE_A_HIGH, "TIM1_CH1 (AF6)", "IHM08M1 L6398 U HIN, active high"),
    row("phase B high side", PHASE_B_HIGH, "TIM1_CH2 (AF6)", "IHM08M1 L6398 V HIN, active high"),
    row("phase C high side", PHASE_C_HIGH, "TIM1_CH3 (AF6)", "IHM08M1 L6398 W HIN, active high"),
    row("phase A low side", PHASE_A_LOW, "TIM1_CH1N (AF6)", "IHM08M1 L6398 U LIN, active low"),
    row("phase B low side", PHASE_B_LOW, "TIM1_CH2N (AF6)", "IHM08M1 L6398 V LIN, active low"),
    row("phase C low side", PHASE_C_LOW, "TIM1_CH3N (AF6)", "IHM08M1 L6398 W LIN, active low"),
    row(
        "overcurrent trip",
        OVERCURRENT,
        "TIM1_BKIN (AF6)",
        "IHM08M1 overcurrent comparator, low = trip",
    ),
    row(
        "motor (bus) current",
        MOTOR_CURRENT,
        "ADC1_IN1 (analog, injected)",
        "IHM08M1 current amplifier, single-shunt setting",
    ),
    row(
        "DC bus voltage",
        BUS_VOLTAGE,
        "ADC1_IN2 (analog, regular)",
        "IHM08M1 bus divider, gain 0.0522 (48 V reads 2.51 V)",
    ),
    row("Hall A", HALL_A, "TIM2_CH1 (AF1)", "motor Hall H1, IHM08M1 Hall/encoder connector"),
    row("Hall B", HALL_B, "TIM2_CH2 (AF1)", "motor Hall H2, IHM08M1 Hall/encoder connector"),
    row("Hall C", HALL_C, "TIM2_CH3 (AF1)", "motor Hall H3, IHM08M1 Hall/encoder connector"),
    row(
        "load cell",
        LOAD_CELL,
        "ADC2_IN15 (analog, regular)",
        "instrumentation amplifier 0–5 V through 17.4 kΩ / 33.2 kΩ divider",
    ),
    row("string encoder A", ENCODER_A, "TIM4_CH1 (AF2)", "quadrature encoder A, pull-up"),
    row("string encoder B", ENCODER_B, "TIM4_CH2 (AF2)", "quadrature encoder B, pull-up"),
    row(
        "home limit switch",
        LIMIT_HOME,
        "GPIO input, pull-up",
        "normally-closed switch to GND: high = actuated or wire broken",
    ),
    row(
        "end limit switch",
        LIMIT_END,
        "GPIO input, pull-up",
        "normally-closed switch to GND: high = actuated or wire broken",
    ),
    row("Start key", KEY_START, "GPIO input, pull-up", "key to GND: low = pressed"),
    row("Up key", KEY_UP, "GPIO input, pull-up", "key to GND: low = pressed"),
    row("Down key", KEY_DOWN, "GPIO input, pull-up", "key to GND: low = pressed"),
    row("Function key", KEY_FUNCTION, "GPIO input, pull-up", "key to GND: low = pressed"),
    row("Preset key", KEY_PRESET, "GPIO input, pull-up", "key to GND: low = pressed"),
    row(
        "display clock",
        DISPLAY_CLOCK,
        "GPIO open drain",
        "TM1637 CLK (module's 10 kΩ pull-up to 3.3 V)",
    ),
    row(
        "display data",
        DISPLAY_DATA,
        "GPIO open drain, read back",
        "TM1637 DIO (module's 10 kΩ pull-up to 3.3 V)",
    ),
    row("beeper", BEEPER, "GPIO push-pull", "NPN driver for a 5 V buzzer: high = sound"),
];

/// Pins the firmware must leave alone, with their owner.
pub const RESERVED: [(Pin, &str); 21] = [
    (Pin::new(Port::A, 13), "SWDIO (ST-LINK)"),
    (Pin::new(Port::A, 14), "SWCLK (ST-LINK)"),
    (Pin::new(Port::A, 2), "LPUART1 TX (ST-LINK virtual COM port)"),
    (Pin::new(Port::A, 3), "LPUART1 RX (ST-LINK virtual COM port)"),
    (Pin::new(Port::A, 5), "Nucleo LD2"),
    (Pin::new(Port::C, 13), "Nucleo B1 button"),
    (Pin::new(Port::C, 14), "LSE crystal"),
    (Pin::new(Port::C, 15), "LSE crystal"),
    (Pin::new(Port::F, 0), "HSE crystal"),
    (Pin::new(Port::F, 1), "HSE crystal"),
    (Pin::new(Port::G, 10), "NRST"),
    (Pin::new(Port::B, 8), "BOOT0"),
    (Pin::new(Port::A, 4), "IHM08M1 potentiometer"),
    (Pin::new(Port::B, 2), "IHM08M1 LED"),
    (Pin::new(Port::C, 0), "IHM08M1 phase W current (3-shunt)"),
    (Pin::new(Port::C, 1), "IHM08M1 phase V current (3-shunt)"),
    (Pin::new(Port::C, 2), "IHM08M1 temperature"),
    (Pin::new(Port::C, 9), "IHM08M1 BEMF divider enable"),
    (Pin::new(Port::A, 11), "IHM08M1 BKIN2"),
    (Pin::new(Port::A, 12), "IHM08M1 comparator output"),
    (Pin::new(Port::B, 4), "IHM08M1 current reference"),
];

/// Writes the wiring table as Markdown (the table in `firmware/README.md`).
///
/// # Errors
/// Whatever the writer returns.
pub fn write_markdown(out: &mut impl fmt::Write) -> fmt::Result {
    writeln!(out, "| signal | MCU pin | function | wired to |")?;
    writeln!(out, "|---|---|---|---|")?;
    for assignment in &ASSIGNMENTS {
        writeln!(
            out,
            "| {} | {} | {} | {} |",
            assignment.signal, assignment.pin, assignment.function, assignment.wiring
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::String;

    #[test]
    fn no_pin_is_assigned_twice() {
        for (index, first) in ASSIGNMENTS.iter().enumerate() {
            for second in ASSIGNMENTS.iter().skip(index + 1) {
                assert_ne!(first.pin, second.pin, "{} and {}", first.signal, second.signal);
            }
        }
    }

    #[test]
    fn no_reserved_pin_is_used() {
        for assignment in &ASSIGNMENTS {
            for (pin, owner) in &RESERVED {
                assert_ne!(assignment.pin, *pin, "{} is on {owner}", assignment.signal);
            }
        }
    }

    #[test]
    fn pin_numbers_exist_on_the_package() {
        for assignment in &ASSIGNMENTS {
            assert!(assignment.pin.number <= 15, "{}", assignment.signal);
        }
    }

    #[test]
    fn readme_table_matches_the_code() {
        let mut table = String::new();
        write_markdown(&mut table).unwrap();
        let readme = include_str!("../README.md");
        assert!(
            readme.contains(&table),
            "firmware/README.md's wiring table is stale; regenerate it with \
             `cargo run -p taut-firmware` and paste:\n{table}"
        );
    }
}

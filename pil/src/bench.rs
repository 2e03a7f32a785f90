//! The processor-in-the-loop bench: the emulated G431 running the image, the digital twin
//! around it, wired as the NUCLEO-G431RB + X-NUCLEO-IHM08M1 board is.
//!
//! Every 50 µs PWM period the bench puts the twin's signals on the part's pins — the Hall
//! lines (PA15, PB3, PB10), the limit switches (PC10, PC11, high = actuated), the keys (PC6,
//! PC7, PC8, PC12, PD2, low = pressed), the overcurrent comparator on the break input (PA6,
//! low = trip), the string encoder's count on TIM4, and the analogue voltages at PA0 (current
//! amplifier), PA1 (bus divider, gain 0.0522) and PB15 (load-cell amplifier through the
//! 17.4 kΩ / 33.2 kΩ divider) — runs the CPU through the period, evaluates the six gates from
//! TIM1 and the pins ([`crate::gates`]), checks them, and steps the twin's physics with the
//! bridge those gates make. The firmware's own drive decides everything; the twin's copy of
//! taut-core's drive is not used.
//!
//! The twin's analogue front ends produce the codes of taut-core's meaning (a 5 V converter);
//! the bench turns them back into the board's pin voltages: the load cell's amplifier volts
//! through the divider, the current amplifier's output at the level whose code on the G431's
//! 3.3 V converter equals the twin's code (the board's amplifier gain is set for that), the
//! bus through the board's divider.

use taut_core::io::{Display, Keys, Leds, Outputs, Segments};
use taut_sim::twin::{PERIODS_PER_TICK, Twin};

use crate::gates::{self, Checker};
use crate::mcu::Mcu;
use crate::soc::{Stop, irq};

/// CPU cycles per PWM period at 170 MHz.
pub const PERIOD_CYCLES: u64 = 8_500;
/// The CPU clock the bench counts in.
pub const CPU_HZ: f64 = 170e6;
/// The IHM08M1's bus divider.
pub const BUS_DIVIDER: f64 = 0.0522;
/// The load cell's divider, 33.2 / (17.4 + 33.2).
pub const LOAD_CELL_DIVIDER: f64 = 33.2 / (17.4 + 33.2);

/// The bench.
pub struct Bench {
    /// The part.
    pub mcu: Mcu,
    /// The twin.
    pub twin: Twin,
    /// The gate checks.
    pub checker: Checker,
    /// Periods run.
    pub periods: u64,
    last_hall: Option<u8>,
    /// The Hall code of the previous period (the firmware may still be commutating on it
    /// until its fast loop has run in this one).
    previous_hall: taut_core::drive::HallCode,
    /// Periods whose gates the twin's circuit could only approximate.
    pub approximated: u64,
    /// The comparator's input to the break: forced low (a trip) by a fault injection.
    pub force_break: bool,
    /// Keys held by a test on top of the operator's.
    pub extra_keys: Keys,
    /// The firmware's defmt log, read from its RTT buffer.
    pub log: crate::rtt::Reader,
    /// The priority order has been found wrong (reported once).
    priority_reported: bool,
    /// The last cycle any gate was on.
    last_gate_on: u64,
    /// The current window's first cycle.
    window_start: u64,
    /// Print every window's gates (`TAUT_PIL_GATES`).
    debug_gates: bool,
    /// The PC's end of the ST-LINK virtual COM port (USART2).
    pub line: Line,
}

/// The PC's end of the serial line: what it sends the part and what it has received.
#[derive(Debug, Default)]
pub struct Line {
    /// Bytes on their way to the part, oldest first.
    pub to_machine: std::collections::VecDeque<u8>,
    /// Bytes the part sent, oldest first (the PC's reader drains them).
    pub from_machine: Vec<u8>,
    /// Bytes the line carried to the part (received by its DMA or lost).
    pub delivered: u64,
    /// Byte times not yet used, fractions of a byte (the rate is not a whole number a ms).
    credit: f64,
}

/// The PC's port rate, baud: what the link's host opens (`taut_link::BAUD`).
pub const HOST_BAUD: f64 = taut_link::BAUD as f64;

fn port_pin(port: char, pin: u8) -> (u8, u8) {
    (port as u8 - b'A', pin)
}

impl Bench {
    /// A bench around `twin` with the part `mcu` just reset.
    pub fn new(mcu: Mcu, twin: Twin) -> Self {
        let log = crate::rtt::Reader::new(mcu.image());
        let mut bench = Self {
            log,
            mcu,
            twin,
            checker: Checker::default(),
            periods: 0,
            last_hall: None,
            previous_hall: taut_core::drive::HallCode::default(),
            approximated: 0,
            force_break: false,
            extra_keys: Keys::NONE,
            debug_gates: std::env::var_os("TAUT_PIL_GATES").is_some(),
            window_start: 0,
            last_gate_on: 0,
            priority_reported: false,
            line: Line::default(),
        };
        bench.drive_pins();
        bench.drive_hall();
        bench
    }

    /// Puts the twin's signals on the pins.
    fn drive_pins(&mut self) {
        let pins = self.twin.pins();
        let inputs = self.twin.inputs();
        let soc = self.mcu.soc_mut();
        let (home, end) = (port_pin('C', 10), port_pin('C', 11));
        soc.drive_pin(home.0, home.1, Some(pins.limits.home));
        soc.drive_pin(end.0, end.1, Some(pins.limits.end));
        let keys = inputs.keys.bits() | self.extra_keys.bits();
        for (index, (port, pin)) in [
            port_pin('C', 6),
            port_pin('C', 7),
            port_pin('C', 8),
            port_pin('C', 12),
            port_pin('D', 2),
        ]
        .into_iter()
        .enumerate()
        {
            soc.drive_pin(port, pin, Some(keys >> index & 1 == 0));
        }
        let tripped = pins.comparator || self.force_break;
        let bkin = port_pin('A', 6);
        soc.drive_pin(bkin.0, bkin.1, Some(!tripped));
        let now = soc.cycles;
        // The break input reaches TIM1 only through PA6's alternate function 6.
        let connected = soc.gpio[0].mode(6) == crate::soc::PinMode::Alternate(6);
        soc.tim1.set_break(now, connected && tripped);
        if !connected && soc.tim1.regs.value(0x44) & crate::tim::MOE != 0 {
            self.checker.violations.push(gates::Violation {
                at: now,
                check: "break input",
                detail: "bridge enabled (MOE) while PA6 is not TIM1_BKIN (AF6): the overcurrent comparator cannot stop it".into(),
            });
        }
        soc.set_analog(0, 0, f64::from(pins.current.get()) * 3.3 / 4096.0);
        soc.set_analog(0, 1, pins.bus_volts * BUS_DIVIDER);
        let amplifier = f64::from(inputs.load_cell.get()) * 5.0 / 4096.0;
        soc.set_analog(1, 15, amplifier * LOAD_CELL_DIVIDER);
        // TIM4 in encoder mode counts the string encoder's edges: the twin's count.
        soc.tim4.external_count = Some(u32::from(inputs.string_counter));
    }

    /// Puts the twin's Hall code on the lines; an edge reaches TIM2's Hall interface.
    fn drive_hall(&mut self) {
        let hall = self.twin.pins().hall.raw();
        let soc = self.mcu.soc_mut();
        for (bit, (port, pin)) in
            [(0b100u8, port_pin('A', 15)), (0b010, port_pin('B', 3)), (0b001, port_pin('B', 10))]
        {
            soc.drive_pin(port, pin, Some(hall & bit != 0));
        }
        let now = soc.cycles;
        if self.last_hall.is_some_and(|h| h != hall) {
            soc.hall_edge(now);
        }
        self.last_hall = Some(hall);
    }

    /// One PWM period.
    pub fn period(&mut self) -> Result<(), Stop> {
        // Once TIM1 runs, each window is one of its periods (update to update), so that the
        // bridge the twin gets for a window is the one the firmware set up for that period;
        // before, windows are 50 µs from reset. (The one window in between is shorter: the
        // twin then runs that much ahead of the CPU's clock, less than a period, for good.)
        let start = self.window_start;
        let tim1 = &self.mcu.soc().tim1;
        let end = match tim1.next_update(start) {
            Some(update) if tim1.running && update <= start + PERIOD_CYCLES => update,
            _ => start + PERIOD_CYCLES,
        };
        self.window_start = end;
        self.drive_pins();
        let hall_before = [self.previous_hall, self.twin.pins().hall];
        self.previous_hall = hall_before[1];
        // The twin steps whole periods, so a Hall edge appears at a window's start, where
        // TIM2 captures it (the Hall-edge interrupt then waits for the update's handler of the
        // same priority: its latency is that handler's length, not the binding's).
        self.drive_hall();
        self.mcu.run_until(end)?;
        let soc = self.mcu.soc_mut();
        let changes = std::mem::take(&mut soc.tim1.changes);
        // Keep the configuration in force at the end for the next window.
        let mut carried: Vec<_> = changes.iter().filter(|(t, _)| *t <= end).cloned().collect();
        let window = gates::evaluate(&carried, &soc.gpio, start, end).map_err(Stop::Misuse)?;
        self.checker.check(&window, start, end, &hall_before);
        if let Some(last) = carried.pop() {
            soc.tim1.changes = vec![last];
            soc.tim1.changes.extend(changes.into_iter().filter(|(t, _)| *t > end));
        }
        for leg in &window.legs {
            for &(_, e) in leg.high.iter().chain(leg.low.iter()) {
                self.last_gate_on = self.last_gate_on.max(e);
            }
        }
        // The fast loop must outrank the tick: the two timers share the clock, so whether a
        // tick ever lands on a PWM update depends on their phase at start-up, and a run's
        // latency alone would not show a wrong order.
        let nvic = &self.mcu.soc().nvic;
        let enabled = |n: u32| nvic.enabled[(n / 32) as usize] >> (n % 32) & 1 != 0;
        let prio = |n: u32| nvic.priority[n as usize] & 0xF0;
        if !self.priority_reported
            && enabled(irq::TIM6_DAC)
            && (enabled(irq::TIM1_UP_TIM16) || enabled(irq::TIM2))
        {
            let fast = prio(irq::TIM1_UP_TIM16).max(prio(irq::TIM2));
            if fast >= prio(irq::TIM6_DAC) {
                self.priority_reported = true;
                self.checker.violations.push(gates::Violation {
                    at: start,
                    check: "interrupt priorities",
                    detail: format!("the fast loop (priority {fast:#04x}) does not outrank the control tick ({:#04x}): the tick can hold it up", prio(irq::TIM6_DAC)),
                });
            }
        }
        let unbuffered = std::mem::take(&mut self.mcu.soc_mut().tim1.unbuffered_output_writes);
        if unbuffered > 0 {
            self.checker.violations.push(gates::Violation {
                at: start,
                check: "atomic commutation",
                detail: format!("{unbuffered} writes of TIM1's output modes or enables took effect one by one while the outputs were enabled (CR2.CCPC clear): the bridge passed through the states between them"),
            });
        }
        let pattern = gates::pattern_of(&window, PERIOD_CYCLES);
        let duty = gates::duty_of(&window, PERIOD_CYCLES);
        let high_legs = window.legs.iter().filter(|l| !l.high.is_empty()).count();
        if high_legs > 1 {
            self.approximated += 1;
        }
        if self.debug_gates && !pattern.is_all_off() {
            eprintln!("{start}: {:?} duty {duty:.4} legs {:?}", window.segments, window.legs);
        }
        self.twin.external_period(pattern, duty, window.dead_time as f64 / CPU_HZ);
        self.periods += 1;
        Ok(())
    }

    /// One 1 ms tick of the twin: twenty periods; then the panel as the TM1637 shows it is
    /// handed to the twin (where the operator reads it).
    pub fn tick(&mut self) -> Result<(), Stop> {
        self.twin.begin_tick();
        for _ in 0..PERIODS_PER_TICK {
            self.period()?;
        }
        self.twin.end_tick();
        self.serial_millisecond()?;
        let mcu = &mut self.mcu;
        let mut writes = Vec::new();
        self.log.poll(|a, n| mcu.read_memory(a, n), |a, b| writes.push((a, b.to_vec())));
        for (a, b) in writes {
            let _ = mcu.write_memory(a, &b);
        }
        let panel = self.panel();
        self.twin.apply(&Outputs {
            display: panel.0,
            leds: panel.1,
            beeper: self.beeper(),
            ..Outputs::default()
        });
        Ok(())
    }

    /// One millisecond of the serial line, both ways, at the rate USART2 is programmed for:
    /// each byte to the part goes where its receive DMA puts it (lost if nothing takes it),
    /// and the part's transmit DMA hands over what it sends. The line is connected only when
    /// PA2 and PA3 are USART2's (alternate function 7), and a rate more than 2.5 % off the
    /// PC's would be read as garbage, which no correct binding does: the run stops.
    fn serial_millisecond(&mut self) -> Result<(), Stop> {
        let soc = self.mcu.soc_mut();
        let per_second = soc.serial.bytes_per_second(soc.pclk1_hz());
        if per_second == 0.0 {
            self.line.credit = 0.0;
            return Ok(());
        }
        let baud = per_second * 10.0;
        if (baud - HOST_BAUD).abs() > 0.025 * HOST_BAUD {
            return Err(Stop::Misuse(format!(
                "USART2 runs at {baud:.0} baud; the PC's port at {HOST_BAUD:.0}"
            )));
        }
        let af7 = |pin: u8| soc.gpio[0].mode(pin) == crate::soc::PinMode::Alternate(7);
        let (tx_connected, rx_connected) = (af7(2), af7(3));
        self.line.credit += per_second / 1000.0;
        let bytes = self.line.credit.floor();
        self.line.credit -= bytes;
        let mut writes = Vec::new();
        let mut reads = Vec::new();
        for _ in 0..bytes as usize {
            if let Some(byte) = self.line.to_machine.pop_front() {
                self.line.delivered += 1;
                if rx_connected {
                    if let Some(address) = soc.serial.receive() {
                        writes.push((address, byte));
                    }
                }
            }
            if tx_connected {
                if let Some(address) = soc.serial.transmit() {
                    reads.push(address);
                }
            }
        }
        for (address, byte) in writes {
            self.mcu.write_memory(address, &[byte]).map_err(Stop::Misuse)?;
        }
        for address in reads {
            let byte = self.mcu.read_memory(address, 1);
            self.line.from_machine.push(byte.first().copied().unwrap_or(0));
        }
        Ok(())
    }

    /// Whether every gate has been off since `cycle`.
    pub fn gates_off_since(&self, cycle: u64) -> bool {
        self.last_gate_on <= cycle
    }

    /// The next window's first cycle.
    pub fn window_start(&self) -> u64 {
        self.window_start
    }

    /// Continues from `cycle` (a bench rebuilt around the same part).
    pub fn set_window_start(&mut self, cycle: u64) {
        self.window_start = cycle;
    }

    /// What the panel shows: the TM1637's grids 1-4 and the lamps of grid 5.
    pub fn panel(&self) -> (Display, Leds) {
        let grids = self.mcu.soc().panel.grids;
        let display: Display =
            [Segments(grids[0]), Segments(grids[1]), Segments(grids[2]), Segments(grids[3])];
        let lamps = grids[4];
        let leds = Leds {
            kg: lamps & 1 != 0,
            lb: lamps & 2 != 0,
            pulling: lamps & 4 != 0,
            holding: lamps & 8 != 0,
            fault: lamps & 16 != 0,
            knot: lamps & 32 != 0,
        };
        (display, leds)
    }

    /// The beeper pin (PB11, push-pull, high = sound).
    pub fn beeper(&self) -> bool {
        self.mcu.soc().gpio[1].level(11)
    }
}

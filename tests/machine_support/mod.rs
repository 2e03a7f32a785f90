//! The rig for the machine's scenario tests: the real machine driving the digital twin, one
//! millisecond at a time, with a record of the states it went through.
#![allow(dead_code, reason = "each scenario file uses a different part of the rig")]

use taut_core::io::{Key, Keys, Outputs};
use taut_core::machine::{Machine, MachineState};
use taut_core::store::Record;
use taut_sim::{StringKind, Twin, TwinConfig};

/// Machine + twin.
pub struct Rig {
    /// The twin.
    pub twin: Twin,
    /// The machine under test.
    pub machine: Machine,
    /// Every state the machine entered, with the time it entered it (ms).
    pub states: Vec<(u64, MachineState)>,
    /// The last outputs.
    pub outputs: Outputs,
    /// Ticks with the store request raised.
    pub store_requests: u32,
}

impl Rig {
    /// A machine at power-up with `record`, in a twin of `config`.
    pub fn new(config: &TwinConfig, record: Record) -> Self {
        Self::with_machine(config, Machine::new(record))
    }

    /// A machine at power-up with the default record, on nominal `kind` string.
    pub fn nominal(kind: StringKind) -> Self {
        Self::new(&TwinConfig::nominal(kind), Record::default())
    }

    /// `machine` in a twin of `config`.
    pub fn with_machine(config: &TwinConfig, machine: Machine) -> Self {
        let state = machine.state();
        Self {
            twin: Twin::new(config),
            machine,
            states: vec![(0, state)],
            outputs: Outputs::default(),
            store_requests: 0,
        }
    }

    /// One tick: sample, decide, apply, advance.
    pub fn tick(&mut self) {
        let inputs = self.twin.inputs();
        self.outputs = self.machine.tick(&inputs);
        self.store_requests += u32::from(self.outputs.store);
        self.twin.apply(&self.outputs);
        self.twin.advance_tick();
        let state = self.machine.state();
        if self.states.last().map(|(_, last)| *last) != Some(state) {
            self.states.push((self.twin.now_ms(), state));
        }
    }

    /// Runs `ms` ticks.
    pub fn run(&mut self, ms: u64) {
        for _ in 0..ms {
            self.tick();
        }
    }

    /// Runs until `done` holds (true) or `max_ms` pass (false).
    pub fn run_until(&mut self, max_ms: u64, mut done: impl FnMut(&Self) -> bool) -> bool {
        for _ in 0..max_ms {
            if done(self) {
                return true;
            }
            self.tick();
        }
        done(self)
    }

    /// Runs until the machine is in `state`; panics with the state history if it is not
    /// within `max_ms`.
    pub fn expect_state(&mut self, state: MachineState, max_ms: u64) {
        let reached = self.run_until(max_ms, |rig| rig.machine.state() == state);
        assert!(reached, "{state:?} not reached in {max_ms} ms; history: {:?}", self.states);
        // One tick in the state, so the outputs are the state's own (the entering tick's
        // outputs are the previous state's panel).
        self.tick();
    }

    /// Presses `key` for 60 ms, then lets 60 ms pass with it released.
    pub fn press(&mut self, key: Key) {
        self.twin.press(Keys::NONE.with(key), 60);
        self.run(120);
    }

    /// Holds `key` for `ms`, then releases it and lets 60 ms pass.
    pub fn hold(&mut self, key: Key, ms: u64) {
        self.twin.press(Keys::NONE.with(key), ms);
        self.run(ms + 60);
    }

    /// Whether the machine went through `state` at some point.
    pub fn visited(&self, state: MachineState) -> bool {
        self.states.iter().any(|(_, s)| *s == state)
    }

    /// The display as text, for messages.
    pub fn display(&self) -> [u8; 4] {
        self.outputs.display.map(|segments| segments.0)
    }
}

/// The value a display shows with one decimal (`25.0` → 250), if it shows a number.
pub fn display_tenths(display: &taut_core::io::Display) -> Option<i32> {
    use taut_core::machine::panel::{DECIMAL_POINT, glyph};
    let mut value: Option<i32> = None;
    let mut negative = false;
    for segments in display {
        let bits = segments.0 & !DECIMAL_POINT;
        if bits == 0 {
            continue;
        }
        if bits == glyph(b'-').0 {
            negative = true;
            continue;
        }
        let digit = (0..=9u8).find(|d| glyph(b'0' + d).0 == bits)?;
        value = Some(value.unwrap_or(0) * 10 + i32::from(digit));
    }
    value.map(|v| if negative { -v } else { v })
}

impl Rig {
    /// Keys in `tenths` on a numeric entry display with Up/Down presses.
    pub fn key_in(&mut self, tenths: i32) {
        // Bound: at most 600 presses (the entry range is 5.0–55.0).
        for _ in 0..600 {
            let shown = display_tenths(&self.outputs.display).expect("a number on the display");
            if shown == tenths {
                return;
            }
            self.press(if shown < tenths { Key::Up } else { Key::Down });
        }
        panic!("could not key in {tenths}");
    }
}

//! Helpers for the machine's scenario tests on the one bench ([`taut_sim::bench::Bench`]):
//! the real machine driving the digital twin, one millisecond at a time, with the states it
//! went through.
#![allow(dead_code, reason = "each scenario file uses a different part of the helpers")]

use taut_core::io::{Key, Keys};
use taut_core::machine::MachineState;
pub use taut_sim::bench::Bench as Rig;

/// What the scenario tests do with a bench beyond ticking it.
pub trait RigExt {
    /// Runs until the machine is in `state`; panics with the state history if it is not
    /// within `max_ms`, then runs one tick in the state, so the outputs are the state's own
    /// (the entering tick's outputs are the previous state's panel).
    fn expect_state(&mut self, state: MachineState, max_ms: u64);
    /// Presses `key` for 60 ms, then lets 60 ms pass with it released.
    fn press(&mut self, key: Key);
    /// Holds `key` for `ms`, then releases it and lets 60 ms pass.
    fn hold(&mut self, key: Key, ms: u64);
    /// Keys in `tenths` on a numeric entry display with Up/Down presses.
    fn key_in(&mut self, tenths: i32);
    /// Keys in `hundredths` on the calibration entry (two decimals) with Up/Down.
    fn key_in_hundredths(&mut self, hundredths: i32);
    /// The states entered, with the time (ms).
    fn states(&self) -> Vec<(u64, MachineState)>;
}

impl RigExt for Rig {
    fn expect_state(&mut self, state: MachineState, max_ms: u64) {
        let reached = self.run_until(max_ms, |rig| rig.machine().state() == state);
        assert!(reached, "{state:?} not reached in {max_ms} ms; history: {:?}", self.states());
        self.tick();
    }

    fn press(&mut self, key: Key) {
        self.twin_mut().press(Keys::NONE.with(key), 60);
        self.run(120);
    }

    fn hold(&mut self, key: Key, ms: u64) {
        self.twin_mut().press(Keys::NONE.with(key), ms);
        self.run(ms + 60);
    }

    fn key_in(&mut self, tenths: i32) {
        // Bound: at most 600 presses (the entry range is 5.0–55.0).
        for _ in 0..600 {
            let shown = display_tenths(self.display()).expect("a number on the display");
            if shown == tenths {
                return;
            }
            self.press(if shown < tenths { Key::Up } else { Key::Down });
        }
        panic!("could not key in {tenths}");
    }

    fn key_in_hundredths(&mut self, hundredths: i32) {
        // The calibration entry (5.00–55.00): holds for the long way, taps for the last steps.
        for _ in 0..2_000 {
            let shown = taut_sim::operator::display::hundredths(self.display())
                .expect("a two-decimal number on the display");
            let diff = hundredths - shown;
            if diff == 0 {
                return;
            }
            let key = if diff > 0 { Key::Up } else { Key::Down };
            if diff.abs() > 60 {
                self.hold(key, 2_500);
            } else {
                self.press(key);
            }
        }
        panic!("could not key in {hundredths}");
    }

    fn states(&self) -> Vec<(u64, MachineState)> {
        self.transitions().iter().map(|t| (t.t_ms, t.state)).collect()
    }
}

/// The value a display shows with one decimal (`25.0` → 250), if it shows a number.
pub fn display_tenths(display: &taut_core::io::Display) -> Option<i32> {
    taut_sim::operator::display::tenths(display)
}

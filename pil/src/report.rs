//! What a run prints: the gate checks and the interrupt timing measured on the image.

use std::fmt::Write;

use crate::bench::Bench;
use crate::mcu::Mcu;

/// Exception numbers of the handlers the firmware uses, by name.
const HANDLERS: &[(u32, &str)] = &[
    (16 + 25, "fast loop: TIM1 update (TIM1_UP_TIM16)"),
    (16 + 28, "fast loop: Hall edge (TIM2)"),
    (16 + 54, "control tick (TIM6_DAC)"),
];

/// The gate-level checks' summary and the first violations.
pub fn checks(bench: &Bench) -> String {
    let c = &bench.checker;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "gate-level checks: {} PWM periods, {} gate edges checked for dead time, {} violations",
        c.windows,
        c.edges,
        c.violations.len()
    );
    for v in c.violations.iter().take(10) {
        let _ = writeln!(s, "  {:>10.6} s  {}: {}", v.at as f64 / 170e6, v.check, v.detail);
    }
    s
}

/// Cycles per handler, latency, CPU load, stack.
pub fn timing(mcu: &Mcu) -> String {
    let mut s = String::new();
    let total = mcu.cycles().max(1);
    let _ = writeln!(
        s,
        "| handler | entries | cycles mean | cycles max | latency max (cycles) | CPU |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for &(n, name) in HANDLERS {
        if let Some(h) = mcu.cpu.handlers.get(&n) {
            let mean = h.total_cycles as f64 / h.entries.max(1) as f64;
            let _ = writeln!(
                s,
                "| {name} | {} | {mean:.0} | {} | {} | {:.1} % |",
                h.entries,
                h.max_cycles,
                h.max_latency,
                100.0 * h.total_cycles as f64 / total as f64
            );
        }
    }
    let _ = writeln!(
        s,
        "asleep (WFE) {:.1} % of the time; deepest stack at exception entry: {} B below the top of RAM",
        100.0 * mcu.cpu.sleep_cycles as f64 / total as f64,
        0x2000_8000u32.saturating_sub(mcu.cpu.lowest_sp)
    );
    if let Some((deepest, room)) = mcu.stack_high_water() {
        let _ = writeln!(
            s,
            "stack (painted RAM): deepest {deepest} B of the {room} B between the statics and the top of RAM since the last reset"
        );
    }
    for (at, why) in &mcu.cpu.resets {
        let _ = writeln!(s, "reset at {:.3} s: {why}", *at as f64 / 170e6);
    }
    s
}

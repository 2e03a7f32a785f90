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

/// Mean and 99th percentile of an exception's latencies (flash stalls excluded).
pub fn latency_figures(mcu: &Mcu, exception: u32) -> (f64, u32) {
    let Some(l) = mcu.cpu.latencies.get(&exception) else { return (0.0, 0) };
    if l.is_empty() {
        return (0.0, 0);
    }
    let mut sorted = l.clone();
    sorted.sort_unstable();
    let mean = sorted.iter().map(|&v| f64::from(v)).sum::<f64>() / sorted.len() as f64;
    let p99 = sorted[(sorted.len() * 99 / 100).min(sorted.len() - 1)];
    (mean, p99)
}

/// The longest fast-loop latency the binding may have, cycles: 1 000 (5.9 µs at 170 MHz,
/// an eighth of the PWM period). Only the firmware's critical sections may hold the PWM
/// period's handler up; a control tick that preempted it would, by a whole tick (≈ 1 900-4 700
/// cycles). A Hall edge may also wait for the period's handler, which has its priority (the two
/// never preempt each other, by design): its limit is this plus that handler's longest run.
pub const FAST_LOOP_LATENCY_LIMIT: u64 = 1_000;

/// Whether the fast loop's latencies stayed within their limits (see
/// [`FAST_LOOP_LATENCY_LIMIT`]); the PWM period handler's longest and the Hall edge's.
pub fn fast_loop_latency(mcu: &Mcu) -> (bool, u64) {
    let period = mcu.cpu.handlers.get(&(16 + 25));
    let hall = mcu.cpu.handlers.get(&(16 + 28));
    let period_latency = period.map_or(0, |h| h.max_latency);
    let period_run = period.map_or(0, |h| h.max_cycles);
    let hall_latency = hall.map_or(0, |h| h.max_latency);
    let ok = period_latency <= FAST_LOOP_LATENCY_LIMIT
        && hall_latency <= FAST_LOOP_LATENCY_LIMIT + period_run;
    (ok, period_latency.max(hall_latency.saturating_sub(period_run)))
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
            let (lat_mean, lat_p99) = latency_figures(mcu, n);
            let _ = writeln!(
                s,
                "| {name} | {} | {mean:.0} | {} | {lat_mean:.0} / {lat_p99} / {} | {:.1} % |",
                h.entries,
                h.max_cycles,
                h.max_latency,
                100.0 * h.total_cycles as f64 / total as f64
            );
        }
    }
    let link = &mcu.soc().link_calls;
    if link.calls > 0 {
        let _ = writeln!(
            s,
            "| of which the machine link (`Link::service`, last in the tick) | {} | {:.0} | {} | — | {:.1} % |",
            link.calls,
            link.total as f64 / link.calls as f64,
            link.max,
            100.0 * link.total as f64 / total as f64
        );
        if link.unseen_returns > 0 {
            let _ = writeln!(
                s,
                "(the machine link: {} calls whose return the bench did not see, not timed)",
                link.unseen_returns
            );
        }
    }
    let _ = writeln!(
        s,
        "asleep (WFE) {:.1} % of the time; deepest stack at exception entry: {} B below the top of RAM",
        100.0 * mcu.cpu.sleep_cycles as f64 / total as f64,
        0x2000_8000u32.saturating_sub(mcu.cpu.lowest_sp)
    );
    for &(n, name) in HANDLERS {
        if let Some(h) = mcu.cpu.handlers.get(&n) {
            let (at, pc, active) = h.max_latency_from;
            if h.max_latency > 0 {
                let _ = writeln!(
                    s,
                    "longest latency of the {name}: pending at {:.6} s while {} ran (exception {active})",
                    at as f64 / 170e6,
                    mcu.describe(pc)
                );
            }
        }
    }
    if let Some((deepest, room)) = mcu.stack_high_water() {
        let _ = writeln!(
            s,
            "stack (painted RAM): deepest {deepest} B of the {room} B between the statics and the top of RAM since the last reset"
        );
    }
    for (index, (at, why)) in mcu.cpu.resets.iter().enumerate() {
        let _ = write!(s, "reset at {:.3} s: {why}", *at as f64 / 170e6);
        // Where a watchdog caught the image: the code that ran when the tick stopped.
        match mcu.cpu.reset_where.get(index) {
            Some(place) if why.starts_with("watchdog") => {
                let _ = writeln!(s, ", while {place} ran");
            }
            _ => {
                let _ = writeln!(s);
            }
        }
    }
    s
}

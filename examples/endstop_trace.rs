// scratch: where does the carriage meet the end stop in whole machine cycles (not committed)
use taut::report::machine::{HOLD_MS, settings};
use taut::report::scenario_seed;
use taut_core::store::Record;
use taut_sim::TwinConfig;
use taut_sim::bench::{Bench, Session, run_session};
use taut_sim::operator::{Operator, Plan};
fn main() {
    let n: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(100);
    for index in 0..n {
        let seed = scenario_seed(1, index);
        let config = TwinConfig::family(seed);
        let mut bench = Bench::power_up(&config, &Record::default().encode());
        let plan = Plan {
            calibrate: true,
            settings: settings(seed, config.string.kind),
            knot_mode: false,
            pull_hold_ms: Some(HOLD_MS),
        };
        let mut operator = Operator::new(plan);
        let mut hits = 0;
        let mut hist: Vec<(u64, f64, f64)> = Vec::new();
        let _ = run_session(
            &mut bench,
            &mut operator,
            Session::Job,
            &mut |_| {},
            |bench, operator| {
                let t = bench.twin().truth();
                hist.push((bench.twin().now_ms(), t.carriage_mm, t.carriage_mm_per_s));
                if hist.len() > 400 {
                    hist.remove(0);
                }
                if t.end_stop_hits > hits {
                    hits = t.end_stop_hits;
                    let state = bench.machine().state();
                    println!(
                        "cycle {index}: hit {hits} at {} ms in {:?}, carriage {:.3} mm at {:.2} mm/s, overtravel {:.2} mm, eff_b {:.2}, screw {:?}",
                        bench.twin().now_ms(),
                        state,
                        t.carriage_mm,
                        t.carriage_mm_per_s,
                        config.mechanics.overtravel_mm,
                        config.mechanics.efficiency_backward,
                        config.mechanics.screw
                    );
                    for (ms, x, v) in hist.iter().step_by(20) {
                        println!("    {ms} {x:.3} {v:.2}");
                    }
                }
                operator.finished()
            },
        );
    }
}

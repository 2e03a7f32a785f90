//! Running a controller on the twin and recording what happened.
//!
//! # Theory of operation
//!
//! A control tick is: read [`Inputs`], decide [`Outputs`], apply them, let one millisecond
//! of physics pass. [`run`] does exactly that with any closure `FnMut(&Inputs) -> Outputs`
//! standing in for the machine, and records one [`TraceRow`] per tick — the inputs the
//! controller saw, the outputs it gave, and the [`Truth`] at the end of that millisecond —
//! so plots and reports can put what the machine believed beside what was physically
//! true. [`run_until`] stops early on a condition. [`Trace::write_csv`] dumps a trace for
//! external tools. The tick itself is [`crate::bench::step`], the one loop every bench uses;
//! the bang-bang oracle is [`crate::bench::bang_bang_reach_time`].

use std::io::{self, Write};

use taut_core::drive::Direction;
use taut_core::io::{Inputs, Outputs};

use crate::twin::{Truth, Twin};

/// One control tick: what the controller saw and did, and the physical state after it.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TraceRow {
    /// The sensors as sampled at the start of the tick.
    pub inputs: Inputs,
    /// What the controller decided.
    pub outputs: Outputs,
    /// The physical state at the end of the tick.
    pub truth: Truth,
}

/// A recorded run, one row per 1 ms tick.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    /// The rows, oldest first.
    pub rows: Vec<TraceRow>,
}

impl Trace {
    /// An empty trace.
    #[must_use]
    pub const fn new() -> Self {
        Self { rows: Vec::new() }
    }

    /// Appends a row.
    pub fn push(&mut self, row: TraceRow) {
        self.rows.push(row);
    }

    /// Number of ticks recorded.
    #[must_use]
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether nothing was recorded.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The last row.
    #[must_use]
    pub fn last(&self) -> Option<&TraceRow> {
        self.rows.last()
    }

    /// One value per row, e.g. `trace.series(|r| r.truth.tension_kgf)`.
    #[must_use]
    pub fn series(&self, value: impl Fn(&TraceRow) -> f64) -> Vec<f64> {
        self.rows.iter().map(value).collect()
    }

    /// The largest true tension in the trace, kgf (0 for an empty trace).
    #[must_use]
    pub fn peak_tension_kgf(&self) -> f64 {
        self.rows.iter().map(|r| r.truth.tension_kgf).fold(0.0, f64::max)
    }

    /// Writes the trace as CSV with a header line: time, truth columns, raw inputs and the
    /// commanded duty.
    ///
    /// # Errors
    /// Any error of the writer.
    pub fn write_csv(&self, mut out: impl Write) -> io::Result<()> {
        writeln!(
            out,
            "time_s,tension_kgf,carriage_mm,carriage_mm_per_s,motor_rpm,current_a,peak_current_a,\
             torque_nm,duty,drive_fault,comparator,string,load_cell_code,motor_current_code,\
             string_counter,limit_home,limit_end,command_direction,command_duty"
        )?;
        for r in &self.rows {
            let t = &r.truth;
            let i = &r.inputs;
            let direction = match r.outputs.drive.direction() {
                None => "coast",
                Some(Direction::Pull) => "pull",
                Some(Direction::Release) => "release",
            };
            writeln!(
                out,
                "{:.3},{:.4},{:.4},{:.3},{:.1},{:.3},{:.3},{:.5},{:.4},{:?},{},{:?},{},{},{},{},{},{},{:.4}",
                t.time_s,
                t.tension_kgf,
                t.carriage_mm,
                t.carriage_mm_per_s,
                t.motor_rpm,
                t.current_a,
                t.peak_current_a,
                t.torque_nm,
                t.duty,
                t.drive_fault,
                u8::from(t.comparator_tripped),
                t.string,
                i.load_cell.get(),
                i.motor_current.get(),
                i.string_counter,
                u8::from(i.limits.home),
                u8::from(i.limits.end),
                direction,
                f64::from(r.outputs.drive.duty().raw()) / 65_536.0,
            )?;
        }
        Ok(())
    }
}

/// Runs `controller` on `twin` for `ms` ticks and records every tick.
pub fn run<F: FnMut(&Inputs) -> Outputs>(twin: &mut Twin, ms: u32, controller: F) -> Trace {
    run_until(twin, ms, controller, |_| false)
}

/// Runs `controller` on `twin` for at most `max_ms` ticks, stopping after the first row
/// for which `stop` returns `true`.
pub fn run_until<F, S>(twin: &mut Twin, max_ms: u32, mut controller: F, mut stop: S) -> Trace
where
    F: FnMut(&Inputs) -> Outputs,
    S: FnMut(&TraceRow) -> bool,
{
    let mut trace = Trace { rows: Vec::with_capacity(usize::try_from(max_ms).unwrap_or(0)) };
    for _ in 0..max_ms {
        let row = crate::bench::step(twin, &mut controller, |_| {});
        trace.push(row);
        if stop(&row) {
            break;
        }
    }
    trace
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{StringKind, TwinConfig};
    use crate::twin::drive_at;

    #[test]
    fn csv_has_a_header_and_one_line_per_tick() {
        let mut twin = Twin::new(&TwinConfig::nominal(StringKind::TennisGut));
        let pull = Outputs { drive: drive_at(Direction::Pull, 0.3), ..Outputs::default() };
        let trace = run(&mut twin, 50, |_| pull);
        let mut out = Vec::new();
        trace.write_csv(&mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 51);
        let columns = lines[0].split(',').count();
        assert!(lines.iter().all(|l| l.split(',').count() == columns));
        assert!(lines[50].starts_with("0.050,"));
        assert!(lines[50].ends_with(",pull,0.3000"));
    }
}

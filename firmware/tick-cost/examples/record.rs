//! Records the tick-cost session: the main job's machine on the digital twin, tick by tick.
//!
//! `cargo run -p taut-tick-cost --example record -- FILE` runs the main job of
//! `cargo run --release` (nominal tennis-synthetic machine, 25.0 kg, 5 s hold): the
//! commissioning session calibrates a new machine and leaves its record on the simulated
//! flash, then the job boots the machine from that record and the simulated operator works it
//! through the boot sequence, the settings (which the machine stores), a pull, the hold and the
//! release. Every tick's [`Inputs`] to the machine goes to `FILE`
//! ([`taut_tick_cost::encode_inputs`]), with the boot record and the fingerprint of the
//! machine's outputs in the header. `scripts/tick-cost` runs this, then the thumb replay.
#![allow(clippy::print_stdout, reason = "a command-line tool reporting what it wrote")]

use std::process::ExitCode;

use taut_sim::bench::{Bench, Session, commission, factory_config, run_session};
use taut_sim::job::CycleOptions;
use taut_sim::operator::Operator;
use taut_tick_cost::{FINGERPRINT_START, Header, encode_header, encode_inputs, fold_outputs};

/// Ticks recorded after the operator is done (the machine settling at home).
const TAIL_TICKS: u32 = 200;

/// The recorded session: header and per-tick inputs, as the file's bytes.
fn record() -> Result<Vec<u8>, String> {
    let options = CycleOptions::default();
    let plan = options.plan().map_err(|error| format!("settings: {error:?}"))?;
    let config = options.twin_config();
    let commissioning = commission(&factory_config(&config), options.calibrate, &mut |_| {})
        .map_err(|error| format!("commissioning failed: {error}"))?;

    // The one bench, as the main job runs it: the machine on the twin tick by tick, the
    // operator looking and pressing between the machine's outputs and the physics.
    let mut bench = Bench::power_up(&config, &commissioning.flash).recording();
    let mut operator = Operator::new(plan);
    let mut tail = None;
    run_session(&mut bench, &mut operator, Session::Job, &mut |_| {}, |_, operator| {
        if !operator.finished() {
            return false;
        }
        let left: &mut u32 = tail.get_or_insert(TAIL_TICKS);
        let done = *left == 0;
        *left = left.saturating_sub(1);
        done
    })
    .map_err(|error| error.to_string())?;
    if operator.stopped() {
        return Err("the job did not complete (a fault)".into());
    }
    let rows = bench.take_rows();
    let fingerprint = rows.iter().fold(FINGERPRINT_START, |f, row| fold_outputs(f, &row.outputs));
    let stores =
        rows.iter().map(|row| u32::from(row.outputs.store)).fold(0_u32, u32::saturating_add);
    let ticks: Vec<_> = rows.iter().map(|row| row.inputs).collect();
    let header = Header {
        ticks: u32::try_from(ticks.len()).map_err(|_| "too many ticks")?,
        fingerprint,
        stores,
        boot_record: commissioning.flash,
    };
    let mut bytes = encode_header(&header).to_vec();
    for inputs in &ticks {
        bytes.extend_from_slice(&encode_inputs(inputs));
    }
    Ok(bytes)
}

fn main() -> ExitCode {
    let Some(path) = std::env::args_os().nth(1) else {
        eprintln!("usage: record FILE");
        return ExitCode::from(2);
    };
    match record().and_then(|bytes| {
        std::fs::write(&path, &bytes).map_err(|error| error.to_string()).map(|()| bytes.len())
    }) {
        Ok(len) => {
            println!("recorded the main job's session: {len} bytes in {}", path.to_string_lossy());
            ExitCode::SUCCESS
        }
        Err(error) => {
            eprintln!("record: {error}");
            ExitCode::FAILURE
        }
    }
}

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

use taut::cycle::{CycleOptions, Operator, Plan, SESSION_LIMIT_MS, commission, factory_config};
use taut_core::io::Inputs;
use taut_core::machine::Machine;
use taut_core::store::Record;
use taut_sim::Twin;
use taut_tick_cost::{FINGERPRINT_START, Header, encode_header, encode_inputs, fold_outputs};

/// Ticks recorded after the operator is done (the machine settling at home).
const TAIL_TICKS: u32 = 200;

/// The recorded session: header and per-tick inputs, as the file's bytes.
fn record() -> Result<Vec<u8>, String> {
    let options = CycleOptions::default();
    let settings = options.settings().map_err(|error| error.to_string())?;
    let config = options.twin_config();
    let commissioning = commission(&factory_config(&config), options.calibrate, &mut |_| {})
        .map_err(|error| format!("commissioning failed: {error}"))?;

    let mut machine = Machine::from_stored(Record::decode(&commissioning.flash));
    let mut twin = Twin::new(&config);
    let plan = Plan {
        calibrate: false,
        settings,
        knot_mode: options.knot_percent.is_some(),
        pull_hold_ms: Some(options.hold_ms),
    };
    let mut operator = Operator::new(plan);
    let mut ticks: Vec<Inputs> = Vec::new();
    let mut fingerprint = FINGERPRINT_START;
    let mut stores = 0_u32;
    let mut tail = None;
    for _ in 0..SESSION_LIMIT_MS {
        // As the board's tick (and `taut::cycle::Bench`): sample, tick, apply, then the
        // operator looks and presses, then a millisecond of physics.
        let inputs = twin.inputs();
        let outputs = machine.tick(&inputs);
        ticks.push(inputs);
        fingerprint = fold_outputs(fingerprint, &outputs);
        stores = stores.saturating_add(u32::from(outputs.store));
        twin.apply(&outputs);
        operator.act(&mut twin);
        twin.advance_tick();
        if operator.finished() {
            let left = tail.get_or_insert(TAIL_TICKS);
            if *left == 0 {
                break;
            }
            *left = left.saturating_sub(1);
        }
    }
    if !operator.finished() || operator.stopped() {
        return Err("the job did not complete (time limit or a fault)".into());
    }
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

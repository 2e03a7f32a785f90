//! Fault snapshots on the twin: a fault latched in the hold is stored with what latched it
//! in the latching tick, so a power cut right after it keeps the snapshot (REQ-UI-13).
#![allow(
    clippy::float_arithmetic,
    clippy::cast_possible_truncation,
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    reason = "host test: the twin's truth is f64, bookkeeping is on small counts, and a panic \
              is how a test fails"
)]

mod machine_support;

use machine_support::{Rig, RigExt as _};
use taut_core::drive::{Direction, DriveCommand};
use taut_core::io::Key;
use taut_core::machine::{FaultCode, MachineState};
use taut_core::store::Record;
use taut_sim::{Fault, LimitSwitch, StringKind, TwinConfig};

/// REQ-UI-13: a fault snapshot survives a power cut in the tick after the latch.
#[test]
fn a_fault_snapshot_survives_a_power_cut() {
    let config = TwinConfig::nominal(StringKind::TennisSynthetic);
    let mut rig = Rig::new(&config, Record::default());
    rig.expect_state(MachineState::Ready, 30_000);
    rig.press(Key::Start);
    rig.expect_state(MachineState::Holding, 20_000);
    rig.run(500);
    let held = rig.twin().truth().tension_kgf;
    let writes = rig.store_writes();
    rig.twin_mut().inject(Fault::LimitSwitchStuck { switch: LimitSwitch::Home, closed: true });
    rig.twin_mut().inject(Fault::LimitSwitchStuck { switch: LimitSwitch::End, closed: true });
    assert!(rig.run_until(50, |rig| rig.machine().fault().is_some()), "no fault latched");
    assert_eq!(rig.machine().fault(), Some(FaultCode::LimitsBoth));
    assert_eq!(rig.store_writes(), writes + 1, "the snapshot is stored in the latching tick");

    // The power is cut now: the next power-up reads the flash as it is.
    let flash = *rig.flash();
    let rebooted = Rig::power_up(&config, &flash);
    let record = rebooted.machine().record();
    let Some(snapshot) = record.faults[0] else { panic!("no snapshot in {:?}", record.faults) };
    assert_eq!(record.faults[1], None, "one fault so far");
    assert_eq!(snapshot.code, FaultCode::LimitsBoth);
    assert_eq!(snapshot.state, MachineState::Holding, "latched in the hold");
    assert_eq!(snapshot.boot, 1, "the first boot");
    assert!(snapshot.time_ms > 1_000, "{}", snapshot.time_ms);
    let tension = f64::from(snapshot.tension.to_hundredths_rounded()) / 100.0;
    // The machine is uncalibrated here: its reading is within a kilogram of the truth.
    assert!((tension - held).abs() < 1.0, "snapshot {tension} kgf, held {held} kgf");
    let bus = f64::from(snapshot.bus.to_milli()) / 1_000.0;
    assert!((20.0..30.0).contains(&bus), "bus {bus} V");
    assert!(snapshot.hall_steps > 100, "the carriage had moved: {}", snapshot.hall_steps);
    assert!(
        matches!(
            snapshot.command,
            DriveCommand::Coast
                | DriveCommand::Drive { direction: Direction::Pull | Direction::Release, .. }
        ),
        "{:?}",
        snapshot.command
    );
    assert_eq!(rebooted.machine().record().faults, rig.machine().record().faults);
}

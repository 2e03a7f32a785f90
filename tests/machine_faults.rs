//! Scenario tests on the twin: every fault code, raised by the failure it names, latched
//! with the bridge off and the code on the display, and cleared by the operator (Start)
//! once the cause is gone — plus the notices (`n-01`…`n-03`).
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
use taut_core::drive::{DriveCommand, HallCode, Phase};
use taut_core::io::{Inputs, Key, Keys, LimitSwitches};
use taut_core::machine::{FaultCode, Machine, MachineState, panel};
use taut_core::sense::calibration::{CALIBRATION_POINTS, CalibrationPoint};
use taut_core::settings::{SetPoint, Settings};
use taut_core::store::{Record, StoreError};
use taut_core::units::Kgf;
use taut_sim::{Fault, LimitSwitch, LoadCellFault, StringKind, TwinConfig};

/// The twin's nominal machine's board: the paper's.
fn paper_board() -> taut_core::board::BoardConfig {
    taut_core::board::paper().expect("the paper's board is valid")
}

/// Runs until a fault latches; asserts it is `code`, that the bridge was off in the
/// latching tick and that the panel shows it.
fn expect_fault(rig: &mut Rig, code: FaultCode, max_ms: u64) {
    let latched = rig.run_until(max_ms, |rig| rig.machine().fault().is_some());
    assert!(latched, "no fault within {max_ms} ms (expected {code:?}); history {:?}", rig.states());
    assert_eq!(rig.machine().fault(), Some(code), "history {:?}", rig.states());
    assert_eq!(rig.outputs().drive, DriveCommand::Coast, "bridge not off in the latching tick");
    rig.tick();
    assert_eq!(rig.outputs().display, panel::fault(code.number()));
    assert!(rig.outputs().leds.fault);
    // Latched: time alone does not clear it.
    rig.run(2_000);
    assert_eq!(rig.machine().fault(), Some(code));
    assert_eq!(rig.outputs().drive, DriveCommand::Coast);
}

/// Clears the fault with Start once the cause is gone and checks where the machine goes.
fn clear_to(rig: &mut Rig, next: MachineState) {
    rig.twin_mut().clear_injected();
    rig.press(Key::Start);
    rig.expect_state(next, 45_000);
}

fn ready(kind: StringKind) -> Rig {
    let mut rig = Rig::nominal(kind);
    rig.expect_state(MachineState::Ready, 30_000);
    rig
}

fn pull_to_hold(rig: &mut Rig) {
    rig.press(Key::Start);
    rig.expect_state(MachineState::Holding, 20_000);
}

#[test]
fn machine_fault_e01_both_limits_any_state() {
    let mut rig = ready(StringKind::TennisSynthetic);
    rig.twin_mut().inject(Fault::LimitSwitchStuck { switch: LimitSwitch::End, closed: true });
    expect_fault(&mut rig, FaultCode::LimitsBoth, 10);
    // Start is refused while the wiring fault is present.
    rig.press(Key::Start);
    assert_eq!(rig.machine().fault(), Some(FaultCode::LimitsBoth));
    clear_to(&mut rig, MachineState::Ready);
}

#[test]
fn machine_fault_e01_both_limits_while_pulling() {
    let mut rig = ready(StringKind::TennisPolyester);
    pull_to_hold(&mut rig);
    rig.twin_mut().inject(Fault::LimitSwitchStuck { switch: LimitSwitch::Home, closed: true });
    rig.twin_mut().inject(Fault::LimitSwitchStuck { switch: LimitSwitch::End, closed: true });
    expect_fault(&mut rig, FaultCode::LimitsBoth, 10);
    rig.twin_mut().clear_injected();
    clear_to(&mut rig, MachineState::Ready);
    assert!(rig.visited(MachineState::Releasing), "cleared by releasing the string first");
}

#[test]
fn machine_fault_e02_home_switch_stuck_closed() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.twin_mut().inject(Fault::LimitSwitchStuck { switch: LimitSwitch::Home, closed: true });
    expect_fault(&mut rig, FaultCode::LimitStuck, 5_000);
    // A boot fault reruns the self-test when cleared.
    clear_to(&mut rig, MachineState::Ready);
    assert!(rig.states().iter().filter(|(_, s)| *s == MachineState::SelfTest).count() >= 2);
}

#[test]
fn machine_fault_e03_e04_load_cell_open_and_short_at_boot() {
    for (fault, code) in [
        (LoadCellFault::Open, FaultCode::LoadCellOpen),
        (LoadCellFault::Short, FaultCode::LoadCellShort),
    ] {
        let mut rig = Rig::nominal(StringKind::TennisSynthetic);
        rig.twin_mut().inject(Fault::LoadCell(fault));
        expect_fault(&mut rig, code, 1_000);
        assert!(!rig.visited(MachineState::MotorTest), "the motor is not run on a broken sensor");
        // Refused while the sensor still reads at its rail.
        rig.press(Key::Start);
        assert_eq!(rig.machine().fault(), Some(code));
        clear_to(&mut rig, MachineState::Ready);
    }
}

#[test]
fn machine_fault_e03_load_cell_open_while_pulling() {
    let mut rig = ready(StringKind::TennisSynthetic);
    pull_to_hold(&mut rig);
    rig.twin_mut().inject(Fault::LoadCell(LoadCellFault::Open));
    let latched = rig.run_until(500, |rig| rig.machine().fault().is_some());
    assert!(latched);
    // Open in the middle of a pull: the reading collapses — a string break or an open
    // sensor, both stop the pull.
    assert!(
        matches!(rig.machine().fault(), Some(FaultCode::LoadCellOpen | FaultCode::StringBreak)),
        "{:?}",
        rig.machine().fault()
    );
}

#[test]
fn machine_fault_e05_load_cell_zero_out_of_band() {
    let mut config = TwinConfig::nominal(StringKind::TennisSynthetic);
    config.load_cell.zero_volts = 0.8;
    let mut rig = Rig::new(&config, Record::default());
    expect_fault(&mut rig, FaultCode::LoadCellZero, 1_000);
}

#[test]
fn machine_fault_e06_load_cell_reversed() {
    let mut rig = ready(StringKind::TennisSynthetic);
    rig.twin_mut().inject(Fault::LoadCell(LoadCellFault::Reversed));
    rig.press(Key::Start);
    expect_fault(&mut rig, FaultCode::LoadCellReversed, 20_000);
    assert!(rig.twin().truth().tension_kgf < 5.0, "stopped before the string was loaded");
    clear_to(&mut rig, MachineState::Ready);
}

#[test]
fn machine_fault_e07_motor_does_not_turn() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.twin_mut().inject(Fault::CarriageJam);
    expect_fault(&mut rig, FaultCode::MotorNoRotation, 3_000);
    assert!(rig.visited(MachineState::MotorTest));
}

#[test]
fn machine_fault_e08_motor_turns_the_wrong_way() {
    let mut config = TwinConfig::nominal(StringKind::TennisSynthetic);
    // Hall sensors mounted half an electrical turn off: the six-step table then drives the
    // rotor backwards.
    config.hall.offset_deg = 180.0;
    let mut rig = Rig::new(&config, Record::default());
    expect_fault(&mut rig, FaultCode::MotorWrongDirection, 3_000);
}

#[test]
fn machine_fault_e09_stall_or_e10_overcurrent_on_a_jam_at_speed() {
    let mut rig = ready(StringKind::TennisSynthetic);
    rig.press(Key::Start);
    rig.run(150);
    rig.twin_mut().inject(Fault::CarriageJam);
    let latched = rig.run_until(5_000, |rig| rig.machine().fault().is_some());
    assert!(latched, "history {:?}", rig.states());
    let code = rig.machine().fault().unwrap();
    assert!(
        matches!(
            code,
            FaultCode::Stall
                | FaultCode::Overcurrent
                | FaultCode::OvercurrentTrip
                | FaultCode::PullTimeout
        ),
        "{code:?}"
    );
    println!("jam at speed → {code:?}");
}

#[test]
fn machine_fault_e09_stall_scripted() {
    // Scripted inputs: a pull commanding high duty while the Hall count stands still.
    // Speed 9: the take-up drives at high duty.
    let settings = Settings::new(SetPoint::DEFAULT, 9, 0, 0).unwrap();
    let mut machine = Machine::new(Record { settings, ..Record::default() }, &paper_board());
    let mut now = 0u32;
    let mut inputs = boot_inputs();
    run_to_ready(&mut machine, &mut inputs, &mut now);
    press(&mut machine, &mut inputs, &mut now, Key::Start);
    assert_eq!(machine.state(), MachineState::Pulling);
    inputs.drive.quiet_for = taut_core::drive::DriveTime::from_micros(600_000);
    let mut latched = None;
    for _ in 0..2_000 {
        inputs.now_ms = now;
        now += 1;
        let out = machine.tick(&inputs);
        if machine.fault().is_some() {
            assert_eq!(out.drive, DriveCommand::Coast);
            latched = machine.fault();
            break;
        }
    }
    assert_eq!(latched, Some(FaultCode::Stall));
}

#[test]
fn machine_fault_e10_e11_overcurrent() {
    let mut rig = ready(StringKind::TennisPolyester);
    pull_to_hold(&mut rig);
    // A shorted winding during a pull: the drive's duty window (I_lim·R with the lowest
    // healthy resistance) keeps even the shorted pair's current below the trip — contained,
    // not detected (a shorted turn is caught only once it draws more than the window allows:
    // the fold-back then latches E-10 within 2 ms, `core::drive` tests). Pinned here: the
    // current stays under 80 % of the 12 A trip.
    let mut shorted = ready(StringKind::TennisPolyester);
    shorted.press(Key::Start);
    shorted.run(300);
    shorted.twin_mut().inject(Fault::ShortedPhase { phase: Phase::A, shorted_percent: 90 });
    let mut peak = 0.0f64;
    shorted.run_until(500, |rig| {
        peak = peak.max(rig.twin().truth().winding_current_a.abs());
        rig.machine().fault().is_some()
    });
    println!(
        "shorted phase: peak winding current {peak:.2} A, fault {:?}",
        shorted.machine().fault()
    );
    assert!(peak < 0.8 * 12.0, "{peak} A");
    // The tick's mean current code alone is not the machine's to judge (the drive sees
    // every period): a high mean with no drive fault does not fault the machine.
    let mut machine = rig.machine().clone();
    let mut inputs = rig.twin().inputs();
    inputs.motor_current = taut_core::units::AdcCode::MAX;
    let out = machine.tick(&inputs);
    assert_ne!(machine.fault(), Some(FaultCode::Overcurrent), "{out:?}");
    // The drive's own latch (here: a jam at full current) shows as E-10 or E-11.
    let mut rig = ready(StringKind::TennisPolyester);
    rig.twin_mut().inject(Fault::CurrentSenseOpen);
    pull_to_hold(&mut rig);
    println!("with the current sense open the pull still holds: {:?}", rig.machine().state());
}

#[test]
fn machine_fault_e12_hall_invalid() {
    let mut rig = ready(StringKind::TennisSynthetic);
    rig.press(Key::Start);
    rig.run(100);
    rig.twin_mut().inject(Fault::HallGlitch { code: HallCode::from_raw(0b111), periods: 200 });
    expect_fault(&mut rig, FaultCode::HallInvalid, 500);
    clear_to(&mut rig, MachineState::Ready);
}

#[test]
fn machine_fault_e13_hall_sequence() {
    let mut rig = ready(StringKind::TennisSynthetic);
    rig.press(Key::Start);
    rig.run(100);
    rig.twin_mut().inject(Fault::HallLineStuck { phase: Phase::A, level: true });
    let latched = rig.run_until(2_000, |rig| rig.machine().fault().is_some());
    assert!(latched);
    let code = rig.machine().fault().unwrap();
    assert!(matches!(code, FaultCode::HallSequence | FaultCode::HallInvalid), "{code:?}");
    println!("stuck Hall line → {code:?}");
}

#[test]
fn machine_fault_e14_end_of_travel() {
    // A very soft string at a high tension runs out of travel before reaching it.
    let mut rig = ready(StringKind::BadmintonSoft);
    rig.hold(Key::Up, 8_000);
    assert!(rig.machine().record().settings.set_point().tenths() >= 450);
    rig.press(Key::Start);
    expect_fault(&mut rig, FaultCode::EndOfTravel, 40_000);
    clear_to(&mut rig, MachineState::Ready);
    assert!(rig.twin().truth().limits.home);
}

#[test]
fn machine_fault_e15_string_break_in_hold() {
    let mut rig = ready(StringKind::TennisSynthetic);
    pull_to_hold(&mut rig);
    rig.twin_mut().break_string();
    expect_fault(&mut rig, FaultCode::StringBreak, 200);
    clear_to(&mut rig, MachineState::Ready);
}

#[test]
fn machine_fault_e16_no_string() {
    let mut rig = ready(StringKind::NoString);
    rig.press(Key::Start);
    expect_fault(&mut rig, FaultCode::NoString, 20_000);
    let travel = rig.twin().truth().carriage_mm;
    assert!(travel > 140.0 && travel < 200.0, "stopped at {travel} mm");
    clear_to(&mut rig, MachineState::Ready);
}

#[test]
fn machine_fault_e17_overload_scripted() {
    let mut machine = Machine::new(Record::default(), &paper_board());
    let mut now = 0u32;
    let mut inputs = boot_inputs();
    run_to_ready(&mut machine, &mut inputs, &mut now);
    press(&mut machine, &mut inputs, &mut now, Key::Start);
    assert_eq!(machine.state(), MachineState::Pulling);
    // A reading far above 25 + 5 kgf: the string jammed in the gripper, a sensor gain
    // fault, a runaway. The tracked tension climbs from 0 at 1 kgf a tick (REQ-SAFE-09) and
    // is above 30 at the 31st tick, when every sample of the window has long been above it:
    // it latches at once.
    inputs.load_cell = paper_board().load_cell().to_code(Kgf::from_int(35));
    inputs.drive.steps = 500;
    let mut latched_after = 0;
    for tick in 1..=50 {
        inputs.now_ms = now;
        now += 1;
        let out = machine.tick(&inputs);
        if machine.fault().is_some() {
            assert_eq!(out.drive, DriveCommand::Coast);
            latched_after = tick;
            break;
        }
    }
    assert_eq!(machine.fault(), Some(FaultCode::Overload));
    assert_eq!(latched_after, 31);
}

#[test]
fn machine_fault_e09_jam_at_low_speed() {
    let mut rig = ready(StringKind::TennisSynthetic);
    // Speed 1, then jam the carriage: the take-up duty is low (no stall), nothing moves.
    rig.press(Key::Function);
    for _ in 0..8 {
        rig.press(Key::Down);
    }
    rig.press(Key::Function);
    rig.press(Key::Function);
    rig.press(Key::Function);
    rig.press(Key::Function);
    rig.twin_mut().inject(Fault::CarriageJam);
    rig.press(Key::Start);
    let latched = rig.run_until(45_000, |rig| rig.machine().fault().is_some());
    assert!(latched);
    // The slowest take-up's duty is above the stall duty: a stall, within a second of Start
    // (500 ms driven + 500 ms without a Hall step), not the pull's time limit.
    let code = rig.machine().fault().unwrap();
    assert_eq!(code, FaultCode::Stall);
    let states = rig.states();
    let started = states.iter().rev().find(|(_, s)| *s == MachineState::Pulling).unwrap().0;
    let faulted = states.last().unwrap().0;
    assert!(faulted - started <= 1_100, "stall after {} ms", faulted - started);
    println!("jam at speed 1 → {code:?} {} ms after Start", faulted - started);
}

/// A pull that neither reaches its tension nor trips another rule: the time from Start to
/// E-18, with the carriage moving, the tension stuck at 3 kgf (a string slipping in the
/// clamp), at `speed`.
fn pull_timeout_after(speed: u8) -> u32 {
    let settings = Settings::default().with_speed_stepped(i8::try_from(speed).unwrap() - 5);
    assert_eq!(settings.speed().get(), speed);
    let mut machine = Machine::new(Record { settings, ..Record::default() }, &paper_board());
    let mut now = 0u32;
    let mut inputs = boot_inputs();
    run_to_ready(&mut machine, &mut inputs, &mut now);
    press(&mut machine, &mut inputs, &mut now, Key::Start);
    assert_eq!(machine.state(), MachineState::Pulling);
    inputs.load_cell = paper_board().load_cell().to_code(Kgf::from_int(3));
    let started = now;
    let mut ticks = 0u32;
    while machine.fault().is_none() && ticks < 70_000 {
        inputs.now_ms = now;
        now += 1;
        ticks += 1;
        if ticks.is_multiple_of(8) {
            inputs.drive.steps += 1;
            inputs.drive.quiet_for = taut_core::drive::DriveTime(0);
        }
        let out = machine.tick(&inputs);
        if machine.fault().is_some() {
            assert_eq!(out.drive, DriveCommand::Coast);
        }
    }
    assert_eq!(machine.fault(), Some(FaultCode::PullTimeout), "speed {speed}");
    now - started
}

#[test]
fn machine_fault_e18_pull_timeout_scripted() {
    // REQ-SM-07: 40 s from speed 3 up; 400 mm at the set speed + 20 s below it (speed 1:
    // 64.4 s), counted from Start — which the machine takes during the 60 ms press that
    // `pull_timeout_after` counts from the end of.
    for (speed, limit_ms) in [(5u8, 40_000u32), (1, 64_444), (2, 42_222)] {
        let after = pull_timeout_after(speed);
        assert!(
            (limit_ms - 60..=limit_ms).contains(&after),
            "speed {speed}: E-18 {after} ms after the press"
        );
        println!("speed {speed}: E-18 {after} ms after the press (limit {limit_ms} ms from Start)");
    }
}

#[test]
fn machine_fault_e19_release_timeout() {
    let mut rig = ready(StringKind::TennisSynthetic);
    pull_to_hold(&mut rig);
    rig.press(Key::Start);
    assert_eq!(rig.machine().state(), MachineState::Releasing);
    rig.twin_mut().inject(Fault::CarriageJam);
    let latched = rig.run_until(45_000, |rig| rig.machine().fault().is_some());
    assert!(latched);
    let code = rig.machine().fault().unwrap();
    // On the twin a jammed carriage draws enough current to trip first.
    assert!(
        matches!(code, FaultCode::ReleaseTimeout | FaultCode::Stall | FaultCode::Overcurrent),
        "{code:?}"
    );
    println!("jam while releasing → {code:?}");
}

#[test]
fn machine_fault_e19_release_timeout_scripted() {
    // Releasing with the home switch never closing (broken switch) and no current rise.
    let mut machine = Machine::new(Record::default(), &paper_board());
    let mut now = 0u32;
    let mut inputs = boot_inputs();
    run_to_ready(&mut machine, &mut inputs, &mut now);
    press(&mut machine, &mut inputs, &mut now, Key::Start);
    press(&mut machine, &mut inputs, &mut now, Key::Start);
    assert_eq!(machine.state(), MachineState::Releasing);
    let mut ticks = 0u32;
    while machine.fault().is_none() && ticks < 45_000 {
        inputs.now_ms = now;
        now += 1;
        ticks += 1;
        // The carriage moves (Hall steps keep coming) but home never closes.
        inputs.drive.steps -= 1;
        machine.tick(&inputs);
    }
    assert_eq!(machine.fault(), Some(FaultCode::ReleaseTimeout));
    // The release began during the key press; the timeout counts from there.
    assert!(
        ticks <= taut_core::machine::RELEASE_TIMEOUT
            && ticks + 100 > taut_core::machine::RELEASE_TIMEOUT
    );
}

#[test]
fn machine_fault_drive_latches_map_to_their_codes() {
    use taut_core::drive::DriveFault;
    for (fault, code) in [
        (DriveFault::Overcurrent, FaultCode::Overcurrent),
        (DriveFault::OvercurrentTrip, FaultCode::OvercurrentTrip),
        (DriveFault::HallInvalid, FaultCode::HallInvalid),
        (DriveFault::SectorSkipped, FaultCode::HallSequence),
        (DriveFault::BusOvervoltage, FaultCode::BusOvervoltage),
        (DriveFault::CurrentSenseZero, FaultCode::CurrentSenseZero),
    ] {
        let mut machine = Machine::new(Record::default(), &paper_board());
        let mut now = 0u32;
        let mut inputs = boot_inputs();
        run_to_ready(&mut machine, &mut inputs, &mut now);
        press(&mut machine, &mut inputs, &mut now, Key::Start);
        assert_eq!(machine.state(), MachineState::Pulling);
        inputs.drive.fault = Some(fault);
        let out = machine.tick(&inputs);
        assert_eq!(out.drive, DriveCommand::Coast);
        assert_eq!(machine.fault(), Some(code));
        // Start asks the drive to clear (with coast); the fault stays until the drive
        // reports it cleared.
        inputs.keys = Keys::NONE.with(Key::Start);
        let mut asked = false;
        for _ in 0..40 {
            let out = machine.tick(&inputs);
            asked |= out.clear_drive_fault;
            assert!(!out.clear_drive_fault || out.drive == DriveCommand::Coast);
        }
        assert!(asked);
        assert_eq!(machine.fault(), Some(code));
        inputs.keys = Keys::NONE;
        inputs.drive.fault = None;
        machine.tick(&inputs);
        assert_eq!(machine.state(), MachineState::Releasing, "{fault:?}");
    }
}

#[test]
fn machine_notice_n01_corrupt_record_uses_defaults() {
    let mut bytes = Record::default().encode();
    bytes[40] ^= 0x10;
    let stored = Record::decode(&bytes);
    assert_eq!(stored, Err(StoreError::CrcMismatch));
    let config = TwinConfig::nominal(StringKind::TennisSynthetic);
    let mut rig = Rig::with_machine(&config, Machine::from_stored(stored, &paper_board()));
    rig.expect_state(MachineState::Ready, 30_000);
    assert_eq!(rig.outputs().display, panel::notice(1));
    assert_eq!(rig.machine().fault(), None, "a notice, not a fault");
    let record = rig.machine().record();
    assert_eq!((record.settings, record.presets), (Settings::DEFAULT, Record::default().presets));
    assert_eq!((record.calibration, record.counters.pulls), (None, 0));
    assert_eq!(record.counters.boots, 1, "the defaults count this boot");
    rig.press(Key::Down);
    assert_eq!(rig.outputs().display, panel::tenths(250), "the key acknowledged the notice only");
}

#[test]
fn machine_notice_n03_stored_calibration_invalid() {
    let record = Record {
        calibration: Some(
            [CalibrationPoint { raw: Kgf::from_int(10), reference: Kgf::from_int(10) };
                CALIBRATION_POINTS],
        ),
        ..Record::default()
    };
    let mut rig = Rig::new(&TwinConfig::nominal(StringKind::TennisSynthetic), record);
    rig.expect_state(MachineState::Ready, 30_000);
    assert_eq!(rig.outputs().display, panel::notice(3));
}

#[test]
fn machine_notice_n02_calibration_rejected() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::CalibrationWindow, 5_000);
    rig.press(Key::Function);
    for point in 0..4u8 {
        rig.expect_state(MachineState::CalibrationEntry { point }, 30_000);
        // A careless operator confirms 20.00 every time: not monotonic.
        rig.key_in_hundredths(2_000);
        rig.press(Key::Start);
    }
    rig.expect_state(MachineState::Ready, 30_000);
    assert_eq!(rig.outputs().display, panel::notice(2));
    assert_eq!(rig.machine().record().calibration, None, "the old calibration is kept");
}

/// REQ-CAL-06: the second pass must agree with the first. An operator who keys the gauge's
/// reading faithfully in the first pass and half a kilogram too high at the third point of
/// the second gets n-02 and keeps the old calibration; the passes are labelled `CAL1`…
/// and `C2-1`…, with a release home between them.
#[test]
fn machine_notice_n02_calibration_passes_disagree() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::CalibrationWindow, 5_000);
    rig.press(Key::Function);
    for point in 0..8u8 {
        let label: &[u8; 4] = match point {
            0 => b"CAL1",
            3 => b"CAL4",
            4 => b"C2-1",
            7 => b"C2-4",
            _ => b"    ",
        };
        if label != b"    " {
            rig.expect_state(MachineState::CalibrationPull { point }, 30_000);
            assert_eq!(rig.outputs().display, panel::text(label), "reading {point}");
        }
        if point == 4 {
            assert!(rig.visited(MachineState::Releasing), "no release between the passes");
        }
        rig.expect_state(MachineState::CalibrationEntry { point }, 30_000);
        let gauge = rig.twin_mut().reference_gauge();
        let slip = if point == 6 { 0.5 } else { 0.0 };
        rig.key_in_hundredths(((gauge + slip) * 100.0).round() as i32);
        rig.press(Key::Start);
        if point == 6 {
            break;
        }
    }
    rig.expect_state(MachineState::Ready, 30_000);
    assert_eq!(rig.outputs().display, panel::notice(2));
    assert_eq!(rig.machine().record().calibration, None, "the old calibration is kept");
}

#[test]
fn machine_calibration_abort_by_key() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::CalibrationWindow, 5_000);
    rig.press(Key::Function);
    rig.expect_state(MachineState::CalibrationEntry { point: 0 }, 30_000);
    rig.press(Key::Function);
    rig.expect_state(MachineState::Ready, 30_000);
    assert_eq!(rig.machine().record().calibration, None);
    assert!(rig.visited(MachineState::Releasing));
}

// ───────── scripted inputs (no twin), for faults the physics cannot easily produce ─────────

fn boot_inputs() -> Inputs {
    Inputs {
        load_cell: paper_board().load_cell().to_code(Kgf::ZERO),
        limits: LimitSwitches { home: true, end: false },
        ..Inputs::default()
    }
}

/// Boot with an ideal, obedient machine: Hall steps follow the command, home switch opens
/// when the carriage leaves it.
fn run_to_ready(machine: &mut Machine, inputs: &mut Inputs, now: &mut u32) {
    for _ in 0..20_000 {
        inputs.now_ms = *now;
        *now += 1;
        let out = machine.tick(inputs);
        match out.drive.direction() {
            Some(taut_core::drive::Direction::Pull) => inputs.drive.steps += 1,
            Some(taut_core::drive::Direction::Release) => inputs.drive.steps -= 1,
            None => {}
        }
        inputs.limits.home = inputs.drive.steps <= 0;
        if machine.state() == MachineState::Ready {
            return;
        }
    }
    panic!("not ready: {:?}", machine.state());
}

fn press(machine: &mut Machine, inputs: &mut Inputs, now: &mut u32, key: Key) {
    inputs.keys = Keys::NONE.with(key);
    for _ in 0..30 {
        inputs.now_ms = *now;
        *now += 1;
        machine.tick(inputs);
    }
    inputs.keys = Keys::NONE;
    inputs.limits.home = false;
    for _ in 0..30 {
        inputs.now_ms = *now;
        *now += 1;
        machine.tick(inputs);
    }
}

/// `report machine --axis`: every cycle on the sweep's machine at that point, past the
/// family's ends too, or at a corner of several axes, the string kinds in turn; a healthy
/// cycle there completes unfaulted.
#[test]
fn machine_cycles_run_on_one_point_of_an_axis_or_a_corner() {
    use clap::Parser as _;
    let parse = |axes: &[&str]| {
        let mut line = vec!["taut", "report", "machine", "--cycles", "1"];
        for axis in axes {
            line.extend(["--axis", axis]);
        }
        let cli = taut::cli::Cli::try_parse_from(line).expect("the command line parses");
        let Some(taut::cli::Command::Report { which: taut::cli::ReportKind::Machine(args) }) =
            cli.command
        else {
            panic!("report machine")
        };
        args
    };
    let kind = StringKind::TennisSynthetic;
    let centre = TwinConfig::family_centre(kind);
    let corner_machine = taut::report::robustness::corner_machine;
    // One point past the end: 4 × the inertia.
    let args = parse(&["inertia=1.5"]);
    let machine = corner_machine(&args.axis, kind).expect("4 × the inertia is a physical machine");
    let ratio = machine.motor.rotor_inertia_kg_m2 / centre.motor.rotor_inertia_kg_m2;
    assert!((ratio - 4.0).abs() < 1e-9, "{ratio}");
    let cycle = taut::report::machine::run_cycle(&args, 1);
    assert!(cycle.completed && cycle.fault.is_none(), "{cycle:?}");
    // A corner: twice the inertia, the heaviest gripper and the smallest bulk capacitor at
    // once; a whole healthy cycle, no fault.
    let args = parse(&["inertia=1", "gripper-mass=1", "bus-capacitance=0"]);
    let machine = corner_machine(&args.axis, kind).expect("a corner of the family is physical");
    let ratio = machine.motor.rotor_inertia_kg_m2 / centre.motor.rotor_inertia_kg_m2;
    assert!((ratio - 2.0).abs() < 1e-9, "{ratio}");
    assert!((machine.mechanics.gripper.mass_kg - 1.5).abs() < 1e-9);
    assert!(machine.bridge.bus_capacitance_f < centre.bridge.bus_capacitance_f);
    let cycle = taut::report::machine::run_cycle(&args, 1);
    assert!(cycle.completed && cycle.fault.is_none(), "{cycle:?}");
    // Refused: not physical, an axis twice.
    let refused = |axes: &[&str]| corner_machine(&parse(axes).axis, kind).unwrap_err();
    assert!(refused(&["backlash=-0.5"]).contains("not a physical machine"));
    assert!(refused(&["inertia=1", "inertia=0"]).contains("given twice"));
}

/// The core counts carriage travel and speed in Hall steps of a 4-pole-pair motor (24 steps
/// a motor turn, 52.9 µm of carriage; the paper is silent on the pole count, see
/// `docs/CONSTANTS.md`). A motor with 2 or 5 pole pairs — steps of 106 or 42 µm, a
/// configuration the firmware was not built for — still runs whole cycles: boot,
/// commissioning, a pull closed on the load cell, the hold and the release, without a fault;
/// and a string break there still latches E-15.
#[test]
fn a_motor_with_another_pole_count_still_runs_whole_cycles() {
    use clap::Parser as _;
    let cli = taut::cli::Cli::try_parse_from(["taut", "report", "machine", "--cycles", "1"])
        .expect("the command line parses");
    let Some(taut::cli::Command::Report { which: taut::cli::ReportKind::Machine(args) }) =
        &cli.command
    else {
        panic!("report machine")
    };
    for pole_pairs in [2, 5] {
        for (index, kind) in [(1, StringKind::TennisPolyester), (9, StringKind::TennisSynthetic)] {
            let mut config = TwinConfig::family_centre(kind);
            config.motor.pole_pairs = pole_pairs;
            let cycle = taut::report::machine::run_cycle_on(&config, args, index);
            match cycle.injection {
                taut::report::machine::Injection::None => {
                    assert!(cycle.completed && cycle.fault.is_none(), "{pole_pairs}: {cycle:?}");
                }
                taut::report::machine::Injection::StringBreak => {
                    assert_eq!(cycle.false_fault(), None, "{pole_pairs}: {cycle:?}");
                    let detected = cycle.detection().expect("the break latches");
                    assert_eq!(detected.0, FaultCode::StringBreak, "{pole_pairs}: {cycle:?}");
                }
                other => panic!("cycle {index} injects {other:?}"),
            }
        }
    }
}

/// REQ-UI-14: a drivetrain whose drag grows boot after boot gets the wear notice (n-05) while
/// it still passes its self-test and completes a pull, and well before the motor test would
/// fail (E-07); a new one never does.
#[test]
fn a_wearing_drivetrain_raises_the_wear_notice_before_the_self_test_fails() {
    use taut_core::machine::Notice;
    let base = TwinConfig::nominal(StringKind::TennisSynthetic);
    let mut flash = Record::default().encode();
    let mut noticed_at = None;
    let mut stalled_at = None;
    let mut failed_at = None;
    // The drag multiplies the drivetrain's Coulomb friction (bearings, nut and slide), one
    // step a boot: a new machine for five boots, then wearing.
    let drags = [1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0];
    let mut drags = drags.to_vec();
    drags.extend((9..40).map(|step| f64::from(step) * 2.0));
    for (boot, drag) in drags.into_iter().enumerate() {
        let mut config = base;
        config.motor.coulomb_torque_nm *= drag;
        config.mechanics.slide_friction_n *= drag;
        let mut rig = Rig::power_up(&config, &flash);
        let ready = rig.run_until(30_000, |r| {
            matches!(r.machine().state(), MachineState::Ready | MachineState::Fault(_))
        });
        assert!(ready, "boot {boot} stuck: {:?}", rig.states());
        if let Some(code) = rig.machine().fault() {
            assert_eq!(code, FaultCode::MotorNoRotation, "boot {boot} at drag {drag}");
            failed_at = Some((boot, drag));
            break;
        }
        let percent = rig.machine().record().drivetrain.percent().unwrap_or(0);
        let noticed = rig.machine().notice() == Some(Notice::DrivetrainWear);
        if noticed {
            assert!(drag >= 4.0, "a notice on a nearly new drivetrain (drag {drag}, {percent} %)");
            noticed_at.get_or_insert((boot, drag, percent));
            rig.press(Key::Start); // acknowledges the notice
        } else {
            assert_eq!(rig.machine().notice(), None, "boot {boot}");
        }
        // One pull, held and released: does the machine still string?
        if stalled_at.is_none() {
            rig.press(Key::Start);
            let held = rig.run_until(30_000, |r| {
                matches!(r.machine().state(), MachineState::Holding | MachineState::Fault(_))
            });
            rig.run(500);
            rig.press(Key::Start);
            let home = rig.run_until(30_000, |r| {
                matches!(r.machine().state(), MachineState::Ready | MachineState::Fault(_))
            });
            if !(held && home) || rig.machine().fault().is_some() {
                stalled_at = Some((boot, drag, rig.machine().fault()));
                assert!(noticed_at.is_some(), "a pull failed before the notice: {stalled_at:?}");
                rig.press(Key::Start);
                rig.run(5_000);
            }
        }
        // Idle long enough for the record (the trend) to be stored.
        rig.run(3_000);
        flash = *rig.flash();
        println!("boot {boot}: drag {drag}, trend {percent} %");
    }
    let (boot, drag, percent) = noticed_at.expect("the wear notice never came");
    println!(
        "wear notice at boot {boot} (drag {drag}, trend {percent} %); first failed pull \
         {stalled_at:?}; motor test failed at {failed_at:?}"
    );
    let (failed, _) = failed_at.expect("the motor test never failed");
    assert!(failed > boot + 3, "the notice came only {} boots before the failure", failed - boot);
}

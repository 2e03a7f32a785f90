//! Scenario tests on the twin: the paper's flow — boot → calibration window → 4-point
//! calibration → set → pull → hold → release — and the panel around it.
#![allow(
    clippy::float_arithmetic,
    clippy::cast_possible_truncation,
    clippy::cast_precision_loss,
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    reason = "host test: the twin's truth is f64, bookkeeping is on small counts, and a panic \
              is how a test fails"
)]

mod machine_support;

use machine_support::{Rig, RigExt as _, display_tenths};
use taut_core::io::Key;
use taut_core::machine::{CALIBRATION_WINDOW, MachineState, View, panel};
use taut_core::settings::Unit;
use taut_core::store::Record;
use taut_sim::{StringKind, TwinConfig};

/// Boot on `config` and calibrate with the twin's reference gauge; returns the rig in Ready.
fn boot_and_calibrate(config: &TwinConfig) -> Rig {
    let mut rig = Rig::new(config, Record::default());
    rig.expect_state(MachineState::CalibrationWindow, 5_000);
    assert_eq!(rig.outputs().display, panel::text(b"CAL?"));
    rig.press(Key::Function);
    // Two passes over the four points (REQ-CAL-06), homing in between.
    for point in 0..8u8 {
        rig.expect_state(MachineState::CalibrationEntry { point }, 30_000);
        // The operator reads the reference gauge and keys its reading in (to 0.01 kg).
        let gauge = rig.twin_mut().reference_gauge();
        let hundredths = (gauge * 100.0).round() as i32;
        rig.key_in_hundredths(hundredths);
        rig.press(Key::Start);
    }
    rig.expect_state(MachineState::Ready, 30_000);
    rig
}

#[test]
fn machine_flow_boot_reaches_ready() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::Ready, 30_000);
    let path: Vec<MachineState> = rig.states().iter().map(|(_, s)| *s).collect();
    assert_eq!(
        path,
        [
            MachineState::SelfTest,
            MachineState::MotorTest,
            MachineState::Homing,
            MachineState::CalibrationWindow,
            MachineState::Ready
        ]
    );
    // The window lasts its preset time, then Ready shows the last setting.
    let window = rig.states()[3].0;
    let ready = rig.states()[4].0;
    assert_eq!(ready - window, u64::from(CALIBRATION_WINDOW));
    assert_eq!(display_tenths(&rig.outputs().display), Some(250));
    assert!(rig.outputs().leds.kg && !rig.outputs().leds.lb);
    println!("boot: {:?}", rig.states());
}

/// REQ-TEN-21 at boot: the homing after the motor test brakes onto the home switch from the
/// count the test started at, as a release after a pull does — on an end stop only 1.5 mm past
/// the switch, on a lead screw and on a ball screw that the carriage's momentum back-drives,
/// the carriage comes to rest within a millimetre of the switch and never meets the stop.
#[test]
fn machine_flow_the_boots_homing_stops_short_of_the_end_stop() {
    let kind = StringKind::TennisSynthetic;
    for (mut config, name) in [
        (TwinConfig::family_centre(kind), "lead screw"),
        (TwinConfig::on_axis(taut_sim::Axis::BallScrew, 1.0, kind), "ball screw"),
    ] {
        config.mechanics.overtravel_mm = 1.5;
        let mut rig = Rig::new(&config, Record::default());
        rig.expect_state(MachineState::CalibrationWindow, 5_000);
        for _ in 0..1_000 {
            rig.tick();
        }
        let truth = rig.twin().truth();
        println!(
            "{name}: at rest {:.3} mm from the switch, end stop met {} times",
            truth.carriage_mm, truth.end_stop_hits
        );
        assert_eq!(truth.end_stop_hits, 0, "{name}");
        assert!(truth.carriage_mm.abs() <= 1.0, "{name}: {truth:?}");
    }
}

#[test]
fn machine_flow_calibrate_set_pull_hold_release() {
    let config = TwinConfig::nominal(StringKind::TennisSynthetic).with_seed(7);
    let mut rig = boot_and_calibrate(&config);
    let calibration = rig.machine().record().calibration.expect("calibration stored");
    assert!(rig.store_writes() > 0, "the calibration was handed to the store");
    println!("calibration points: {calibration:?}");

    // Set 24.0 kg: ten Down presses from 25.0.
    for _ in 0..10 {
        rig.press(Key::Down);
    }
    assert_eq!(display_tenths(&rig.outputs().display), Some(240));
    assert_eq!(rig.machine().record().settings.set_point().tenths(), 240);

    // Pull, hold.
    rig.press(Key::Start);
    assert!(matches!(rig.machine().state(), MachineState::Pulling | MachineState::Holding));
    rig.expect_state(MachineState::Holding, 20_000);
    assert!(rig.outputs().leds.holding);
    rig.run(1_500);
    let truth = rig.twin().truth().tension_kgf;
    println!("held at {truth:.3} kgf (target 24.0)");
    assert!((truth - 24.0).abs() < 0.3, "held {truth} kgf");
    assert_eq!(rig.machine().state(), MachineState::Holding);

    // Release with Start: back to home, string loose, Ready again.
    rig.press(Key::Start);
    rig.expect_state(MachineState::Ready, 20_000);
    assert!(rig.twin().truth().limits.home);
    assert!(rig.twin().truth().tension_kgf < 1.0);
    let log = rig.machine().log();
    assert_eq!(log.len(), 1);
    let entry = log.last().unwrap();
    println!("log: {entry:?}");
    assert_eq!(entry.target.to_kgf().to_tenths_rounded(), 240);
    assert!((entry.reached.to_kgf().to_tenths_rounded() - 240).abs() <= 3);
    assert!(entry.peak >= entry.reached);
    assert!(entry.time_to_tension_ms > 0);
    assert!(entry.string_mm > 10, "string drawn: {} mm", entry.string_mm);
    assert_eq!(rig.machine().record().counters.pulls, 1);
    // The counters are stored once the panel is idle.
    let before = rig.store_writes();
    rig.run(3_000);
    assert!(rig.store_writes() > before);
}

#[test]
fn machine_flow_any_key_during_pull_releases() {
    let mut rig = Rig::nominal(StringKind::TennisPolyester);
    rig.expect_state(MachineState::Ready, 30_000);
    rig.press(Key::Start);
    rig.run(200);
    assert_eq!(rig.machine().state(), MachineState::Pulling);
    rig.press(Key::Down);
    assert_eq!(rig.machine().state(), MachineState::Releasing);
    rig.expect_state(MachineState::Ready, 20_000);
    assert!(rig.machine().log().is_empty(), "an aborted pull is not logged");
    assert_eq!(rig.machine().record().counters.pulls, 0);
}

#[test]
fn machine_flow_panel_settings_units_and_presets() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::Ready, 30_000);
    // Function walks the pages: speed, pre-stretch, knot, unit, beeper, constant pull.
    rig.press(Key::Function);
    assert_eq!(rig.machine().view(), View::Speed);
    assert_eq!(rig.outputs().display, panel::text(b"SP 5"));
    rig.press(Key::Up);
    assert_eq!(rig.outputs().display, panel::text(b"SP 6"));
    rig.press(Key::Function);
    rig.press(Key::Up);
    rig.press(Key::Up);
    assert_eq!(rig.outputs().display, panel::text(b"PS10"));
    rig.press(Key::Function);
    rig.press(Key::Up);
    assert_eq!(rig.outputs().display, panel::text(b"Kn 5"));
    rig.press(Key::Function);
    rig.press(Key::Up);
    assert_eq!(rig.outputs().display, panel::text(b" lb "));
    // Then the preferences (beeper, constant pull), then the tension again.
    rig.press(Key::Function);
    assert_eq!(rig.machine().view(), View::Beeper);
    rig.press(Key::Function);
    assert_eq!(rig.machine().view(), View::ConstantPull);
    rig.press(Key::Function);
    // 25.0 kg is 55.1 lb, on the 0.5 lb step: 55.0.
    assert_eq!(display_tenths(&rig.outputs().display), Some(550));
    assert!(rig.outputs().leds.lb);
    let settings = rig.machine().record().settings;
    assert_eq!(settings.set_point().unit(), Unit::Pounds);
    assert_eq!(
        (settings.speed().get(), settings.pre_stretch().percent(), settings.knot().percent()),
        (6, 10, 5)
    );
    // Up steps by 0.5 lb; holding Up repeats.
    rig.press(Key::Up);
    assert_eq!(display_tenths(&rig.outputs().display), Some(555));
    rig.hold(Key::Up, 1_000);
    let after_hold = display_tenths(&rig.outputs().display).unwrap();
    assert!(after_hold >= 555 + 5 * 4, "repeat stepped to {after_hold}");

    // Store the settings in preset 3 (Preset, Up ×2, hold Preset), change, recall.
    rig.press(Key::Preset);
    rig.press(Key::Up);
    rig.press(Key::Up);
    assert_eq!(rig.outputs().display, panel::text(b"P  3"));
    rig.hold(Key::Preset, 1_700);
    assert_eq!(rig.machine().record().presets[2], rig.machine().record().settings);
    let stored = rig.machine().record().settings;
    for _ in 0..4 {
        rig.press(Key::Down);
    }
    assert_ne!(rig.machine().record().settings, stored);
    rig.press(Key::Preset);
    rig.press(Key::Up);
    rig.press(Key::Up);
    rig.press(Key::Start);
    assert_eq!(rig.machine().record().settings, stored);
    assert_eq!(rig.machine().state(), MachineState::Ready, "Start recalls, it does not pull");

    // Knot mode: long Function.
    rig.hold(Key::Function, 1_700);
    assert!(rig.machine().knot_mode());
    assert!(rig.outputs().leds.knot);
    assert_eq!(rig.machine().view(), View::Tension);

    // The settings survive a power cycle through the store.
    rig.run(3_000);
    let bytes = rig.machine().record().encode();
    let reloaded = Record::decode(&bytes).unwrap();
    assert_eq!(reloaded.settings, rig.machine().record().settings);
    let mut again = Rig::new(&TwinConfig::nominal(StringKind::TennisSynthetic), reloaded);
    again.expect_state(MachineState::Ready, 30_000);
    assert_eq!(again.outputs().display, rig.outputs().display);
    assert!(!again.machine().knot_mode(), "knot mode is per session, not stored");
}

#[test]
fn machine_flow_hold_duty_at_full_tension() {
    let mut rig = Rig::nominal(StringKind::TennisPolyester);
    rig.expect_state(MachineState::Ready, 30_000);
    rig.hold(Key::Up, 8_000);
    rig.press(Key::Start);
    rig.expect_state(MachineState::Holding, 30_000);
    let mut max_duty = 0u16;
    for _ in 0..3_000 {
        rig.tick();
        max_duty = max_duty.max(rig.outputs().drive.duty().raw());
    }
    println!("hold at {:.2} kgf: max duty {max_duty} / 65536", rig.twin().truth().tension_kgf);
}

/// REQ-STORE-05: every power-up is counted in the record and stored once the machine idles
/// in Ready, so a record from format version 1 (no boot counter) is read with its settings
/// and calibration kept, and rewritten in today's format without the operator doing
/// anything.
#[test]
fn machine_flow_boots_are_counted_and_an_old_record_is_rewritten() {
    use taut_core::store::{FORMAT_V1, FORMAT_VERSION};
    use taut_proofs::machine_store::as_version_1;

    let config = TwinConfig::nominal(StringKind::TennisSynthetic);
    let mut keyed = Rig::new(&config, Record::default());
    keyed.expect_state(MachineState::Ready, 30_000);
    keyed.press(Key::Up);
    keyed.run(3_000);
    let settings = keyed.machine().record().settings;
    assert_eq!(Record::decode(keyed.flash()).map(|r| r.counters.boots), Ok(1));
    assert_eq!(Record::decode(keyed.flash()).map(|r| r.settings), Ok(settings));

    // The same record as version 1 wrote it: no boot counter.
    let mut old_record = *keyed.machine().record();
    old_record.counters.boots = 0;
    let old = as_version_1(&old_record);
    assert_eq!(Record::decode_version(&old).map(|(_, version)| version), Ok(FORMAT_V1));
    // The old record at the start of the store's flash, erased bytes after it.
    let mut flash = [0xFF; taut_core::store::RECORD_LEN];
    flash[..old.len()].copy_from_slice(&old);
    for boot in 1..=3 {
        let mut rig = Rig::power_up(&config, &flash);
        rig.expect_state(MachineState::Ready, 30_000);
        assert_eq!(rig.machine().notice(), None, "a version-1 record is not a corrupt one");
        rig.run(3_000);
        assert!(rig.store_writes() >= 1, "boot {boot}: the counted boot was not stored");
        flash = *rig.flash();
        let (stored, version) = Record::decode_version(&flash).expect("the stored record");
        assert_eq!(version, FORMAT_VERSION, "boot {boot}: rewritten in today's format");
        assert_eq!(stored.counters.boots, boot);
        assert_eq!(stored.settings, settings, "boot {boot}: the keyed settings are kept");
        assert_eq!(stored.presets, old_record.presets);
        assert_eq!(stored.counters.pulls, old_record.counters.pulls);
    }
}

/// The true tension averaged over `ms` of holding, kgf.
fn mean_tension(rig: &mut Rig, ms: u64) -> f64 {
    let mut sum = 0.0;
    for _ in 0..ms {
        rig.tick();
        sum += rig.twin().truth().tension_kgf;
    }
    sum / ms as f64
}

/// REQ-SM-08: Up/Down while holding move the held target by 0.1 kg without releasing, the
/// string follows, the new target shows for a second, and the pull's log entry carries the
/// adjustment; Function, Preset and long presses never release.
#[test]
fn machine_flow_hold_adjusts_the_target_without_releasing() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::Ready, 30_000);
    rig.press(Key::Start);
    rig.expect_state(MachineState::Holding, 20_000);
    rig.run(1_500);
    let before = mean_tension(&mut rig, 500);

    for _ in 0..5 {
        rig.press(Key::Up);
    }
    assert_eq!(display_tenths(&rig.outputs().display), Some(255), "the new target shows");
    assert_eq!(rig.machine().state(), MachineState::Holding);
    rig.run(2_000);
    let up = mean_tension(&mut rig, 500);
    println!("held {before:.3} kgf, +0.5 kg → {up:.3} kgf");
    assert!((up - before - 0.5).abs() < 0.05, "+0.5 kg moved the string by {:.3}", up - before);

    for _ in 0..3 {
        rig.press(Key::Down);
    }
    assert_eq!(display_tenths(&rig.outputs().display), Some(252));
    rig.run(2_000);
    let down = mean_tension(&mut rig, 500);
    println!("−0.3 kg → {down:.3} kgf");
    assert!((down - before - 0.2).abs() < 0.05, "net +0.2 kg moved it by {:.3}", down - before);

    // Keys the hold does not use do nothing — no surprise release.
    rig.press(Key::Function);
    rig.hold(Key::Function, 1_600);
    rig.hold(Key::Preset, 1_600);
    rig.press(Key::Preset);
    assert_eq!(rig.machine().state(), MachineState::Holding);
    assert!(!rig.visited(MachineState::Releasing));

    rig.press(Key::Start);
    rig.expect_state(MachineState::Ready, 20_000);
    let entry = *rig.machine().log().last().expect("the pull is logged");
    println!("log: {entry:?}");
    assert_eq!(entry.target.to_kgf().to_tenths_rounded(), 252);
    assert_eq!(entry.adjust.to_kgf().to_tenths_rounded(), 2);
    assert!(entry.held_s >= 9, "held {} s", entry.held_s);
    assert_eq!(rig.machine().record().settings.set_point().tenths(), 250, "the setting stays");
}

/// The tension timer: Preset shows it while holding; it reads `t0.00` until the hold's
/// 1 000th tick and `t0.01` from that tick on — counted in ticks, to the tick.
#[test]
fn machine_flow_tension_timer_counts_to_the_tick() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::Ready, 30_000);
    rig.press(Key::Start);
    rig.expect_state(MachineState::Holding, 20_000);
    let entered = rig.states().last().expect("holding").0;
    rig.press(Key::Preset);
    assert_eq!(rig.outputs().display, panel::clock(b't', 0));
    assert!(rig.run_until(2_000, |rig| rig.outputs().display == panel::clock(b't', 1)));
    let now = rig.twin().now_ms();
    println!("holding entered at {entered} ms, t0.01 at {now} ms");
    // The tick that enters Holding is the pull's last; the timer counts the hold's ticks.
    assert_eq!(now - entered, 1_000);
    assert!(rig.run_until(60_000, |rig| rig.outputs().display == panel::clock(b't', 61)));
    assert_eq!(rig.twin().now_ms() - entered, 61_000);
    let mut expected = panel::text(b"t101");
    expected[1].0 |= panel::DECIMAL_POINT;
    assert_eq!(rig.outputs().display, expected, "t1.01: the point stands for the colon");
    // Preset again: the tension.
    rig.press(Key::Preset);
    assert_eq!(display_tenths(&rig.outputs().display).map(|t| (t - 250).abs() <= 2), Some(true));
}

/// REQ-TEN-18: Function while holding switches constant pull off (`LOCK`): the carriage
/// stays where it is while the string creeps, the tension falling; Function again (`PULL`)
/// pulls back to the target. Never a release.
#[test]
fn machine_flow_function_locks_and_resumes_constant_pull() {
    let machines = [
        ("tennis-synthetic", TwinConfig::nominal(StringKind::TennisSynthetic)),
        ("tennis-polyester", TwinConfig::nominal(StringKind::TennisPolyester)),
        ("badminton-soft", TwinConfig::nominal(StringKind::BadmintonSoft)),
        ("family 3", TwinConfig::family(3)),
        ("family 17", TwinConfig::family(17)),
        ("family 40", TwinConfig::family(40)),
    ];
    for (kind, config) in machines {
        let mut rig = Rig::new(&config, Record::default());
        rig.expect_state(MachineState::Ready, 30_000);
        rig.press(Key::Start);
        rig.expect_state(MachineState::Holding, 20_000);
        rig.run(1_000);
        let held = mean_tension(&mut rig, 500);
        rig.press(Key::Function);
        assert_eq!(rig.outputs().display, panel::text(b"LOCK"));
        let locked_at = rig.twin().truth().carriage_mm;
        let mut travel: f64 = 0.0;
        for _ in 0..20_000 {
            rig.tick();
            travel = travel.max((rig.twin().truth().carriage_mm - locked_at).abs());
        }
        let crept = mean_tension(&mut rig, 500);
        println!(
            "{kind}: held {held:.3} kgf; locked 20 s: carriage within {travel:.3} mm, \
             tension {crept:.3} kgf"
        );
        assert!(travel < 0.2, "the lock let the carriage move {travel:.3} mm");
        assert!(crept < held - 0.05, "the string creeps at constant length");
        rig.press(Key::Function);
        assert_eq!(rig.outputs().display, panel::text(b"PULL"));
        rig.run(3_000);
        let resumed = mean_tension(&mut rig, 500);
        println!("{kind}: constant pull again: {resumed:.3} kgf");
        assert!((resumed - held).abs() < 0.05, "back to {held:.3}: {resumed:.3}");
        assert_eq!(rig.machine().state(), MachineState::Holding);
    }
}

/// REQ-UI-11: the preference pages after the unit — beeper off mutes the clicks and the
/// at-tension tone (never a fault's), constant pull off starts every hold locked — are
/// stored in the record and survive a power cycle.
#[test]
fn machine_flow_preferences_mute_the_beeper_and_lock_the_hold() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::Ready, 30_000);
    for _ in 0..5 {
        rig.press(Key::Function);
    }
    assert_eq!(rig.machine().view(), View::Beeper);
    assert_eq!(rig.outputs().display, panel::text(b"bEon"));
    rig.press(Key::Up);
    assert_eq!(rig.outputs().display, panel::text(b"bEoF"));
    rig.press(Key::Function);
    assert_eq!(rig.outputs().display, panel::text(b"CPon"));
    rig.press(Key::Down);
    assert_eq!(rig.outputs().display, panel::text(b"CPoF"));
    rig.run(2_500);
    let stored = Record::decode(rig.flash()).expect("stored");
    assert!(!stored.preferences.beeper && !stored.preferences.constant_pull);

    // Muted: a key press does not click.
    rig.press(Key::Function);
    let mut sounded = false;
    rig.twin_mut().press(taut_core::io::Keys::NONE.with(Key::Start), 60);
    for _ in 0..20_000 {
        rig.tick();
        sounded |= rig.outputs().beeper;
        if rig.machine().state() == MachineState::Holding {
            break;
        }
    }
    rig.tick();
    assert_eq!(rig.machine().state(), MachineState::Holding);
    assert!(!sounded, "no click, no at-tension tone");
    // The hold started locked.
    assert!(!rig.machine().constant_pull());
    assert_eq!(rig.outputs().display, panel::text(b"LOCK"));
    rig.press(Key::Function);
    assert!(rig.machine().constant_pull(), "Function: constant pull for this pull");
    rig.press(Key::Start);
    rig.expect_state(MachineState::Ready, 20_000);

    // A power cycle keeps them.
    let mut again = Rig::power_up(&TwinConfig::nominal(StringKind::TennisSynthetic), rig.flash());
    again.expect_state(MachineState::Ready, 30_000);
    assert_eq!(again.machine().record().preferences, stored.preferences);
}

#[test]
fn machine_flow_a_key_just_after_a_page_timed_out_only_wakes_the_panel() {
    let mut rig = Rig::nominal(StringKind::TennisSynthetic);
    rig.expect_state(MachineState::Ready, 30_000);
    rig.press(Key::Function);
    assert_eq!(rig.machine().view(), View::Speed);
    // The operator looks away: the page times out to the tension.
    rig.run(u64::from(taut_core::machine::VIEW_TIMEOUT));
    assert_eq!(rig.machine().view(), View::Tension);
    // Up meant for the speed page, pressed and held just after: no change to the set
    // tension, not even by the held key's repeats.
    rig.hold(Key::Up, 1_000);
    assert_eq!(rig.machine().record().settings.set_point().tenths(), 250);
    assert_eq!(rig.machine().record().settings.speed().get(), 5);
    assert_eq!(display_tenths(&rig.outputs().display), Some(250));
    // The next press acts on the page now shown.
    rig.press(Key::Up);
    assert_eq!(rig.machine().record().settings.set_point().tenths(), 251);
    // Once the panel has shown the tension for longer than the wake time, a key acts at once.
    rig.press(Key::Function);
    rig.run(u64::from(taut_core::machine::VIEW_TIMEOUT + taut_core::machine::VIEW_WAKE));
    assert_eq!(rig.machine().view(), View::Tension);
    rig.press(Key::Up);
    assert_eq!(rig.machine().record().settings.set_point().tenths(), 252);
}

#[test]
fn machine_flow_the_logged_peak_is_the_tension_the_string_saw() {
    // A noisy load cell: the break detector's tracked peak follows the noise, the logged
    // peak must not.
    let config = TwinConfig::nominal(StringKind::TennisPolyester).with_seed(3);
    let mut rig = boot_and_calibrate(&config);
    rig.key_in(220);
    rig.press(Key::Start);
    let mut true_peak: f64 = 0.0;
    let mut hold_ms = 0;
    for _ in 0..25_000 {
        rig.tick();
        true_peak = true_peak.max(rig.twin().truth().tension_kgf);
        if rig.machine().state() == MachineState::Holding {
            hold_ms += 1;
            if hold_ms >= 2_000 {
                break;
            }
        }
    }
    assert_eq!(hold_ms, 2_000, "held 2 s");
    let tracked = rig.machine().watch().peak.to_milli();
    rig.press(Key::Start);
    rig.expect_state(MachineState::Ready, 20_000);
    let logged = f64::from(rig.machine().log().last().unwrap().peak.to_kgf().to_milli()) / 1_000.0;
    println!(
        "true peak {true_peak:.3} kgf, logged {logged:.3}, the break detector's {:.3}",
        f64::from(tracked) / 1_000.0
    );
    // The display's filter lags the true peak by a little, the calibration is within its
    // gauge's reading error: within 0.1 kgf of the truth, never the noise's excursions.
    assert!((logged - true_peak).abs() <= 0.1, "logged {logged} against {true_peak}");
}

/// A board unlike the paper's, described to core by its `BoardConfig` alone: a 3.3 V
/// converter for every analogue input, per-phase low-side shunts with bidirectional
/// 0.1 V/A amplifiers at mid-rail, a 1 : 20 bus divider, a 0.5 µs dead time; the load-cell
/// amplifier's gain chosen for the paper's full scale on 3.3 V (60.7 mV/kgf).
fn second_board() -> (TwinConfig, taut_core::board::BoardConfig) {
    use taut_core::board::{BoardConfig, PAPER_LOAD_CELL_ZERO};
    use taut_core::drive::limit::{CurrentLimit, CurrentReading, CurrentSense};
    use taut_core::drive::{BusSense, DriveConfig, DriveTime, TIME_UNITS_PER_SECOND};
    use taut_core::sense::load_cell::LoadCellScale;
    use taut_core::tension::controller::ControllerConfig;
    use taut_core::units::{AdcCode, AdcReference, Q16};
    use taut_sim::params::{BoardDesign, CurrentSenseParams};

    let reference = AdcReference::from_millivolts(3_300).unwrap();
    let dead_time = DriveTime(5);
    let mut config = TwinConfig::nominal(StringKind::TennisSynthetic).with_seed(11);
    config.board = BoardDesign {
        adc_reference: reference,
        bus_full_scale_mv: 66_000,
        dead_time,
        overcurrent_ma: 12_000,
    };
    config.bridge.dead_time_s = f64::from(dead_time.0) / f64::from(TIME_UNITS_PER_SECOND);
    config.bus_sense.divider_ratio =
        f64::from(config.board.bus_full_scale_mv) / f64::from(reference.millivolts());
    config.current_sense = CurrentSenseParams::per_phase_low_side();
    config.current_sense.offset_volts = 1.65;
    config.load_cell.volts_per_kgf = 0.092 * 3.3 / 5.0;

    // The board's own description, written apart from the twin's so that the test compares
    // the two: 3.3 V / 4 096 / 0.1 V/A = 8.057 mA a code from mid-rail.
    let sense = CurrentSense {
        reading: CurrentReading::Winding,
        design_zero: AdcCode::new(2_048),
        na_per_code: 8_056_641,
        zero_tolerance: 63,
    };
    let bus =
        BusSense { full_scale_mv: 66_000, floor_mv: 18_000, regen_mv: 38_000, max_mv: 40_000 };
    let drive = DriveConfig::new(sense, bus, CurrentLimit::PAPER, 12_000, dead_time).unwrap();
    let load_cell =
        LoadCellScale::new(reference, PAPER_LOAD_CELL_ZERO, Q16::from_num(1.0 / 0.060_72)).unwrap();
    let board =
        BoardConfig::new(drive, DriveTime::from_micros(50), load_cell, ControllerConfig::TAUT)
            .unwrap();
    (config, board)
}

#[test]
fn machine_flow_a_second_board_runs_a_cycle_through_its_board_config() {
    use taut_core::machine::Machine;
    use taut_core::units::Q16;
    let (config, board) = second_board();
    // The twin's electronics are what the board says they are.
    assert_eq!(board.drive(), config.current_sense.drive_config(&config.board));
    assert_eq!(board.dead_time_duty().raw(), 655, "0.5 µs of 50 µs");
    let scale = board.load_cell();
    let twin_scale = taut_sim::bench::board_for(&config).load_cell();
    let gain_apart = (scale.kgf_per_volt() - twin_scale.kgf_per_volt()).abs();
    assert!(gain_apart < Q16::lit("0.01"), "{gain_apart}");

    let machine = Machine::new(Record::default(), &board);
    let mut rig = Rig::with_machine(&config, machine);
    rig.expect_state(MachineState::CalibrationWindow, 5_000);
    rig.press(Key::Function);
    for point in 0..8u8 {
        rig.expect_state(MachineState::CalibrationEntry { point }, 30_000);
        let gauge = rig.twin_mut().reference_gauge();
        rig.key_in_hundredths((gauge * 100.0).round() as i32);
        rig.press(Key::Start);
    }
    rig.expect_state(MachineState::Ready, 30_000);
    rig.press(Key::Start);
    rig.expect_state(MachineState::Holding, 20_000);
    rig.run(1_500);
    let truth = rig.twin().truth().tension_kgf;
    println!("second board: held at {truth:.3} kgf (target 25.0)");
    assert!((truth - 25.0).abs() < 0.3, "held {truth} kgf");
    rig.press(Key::Start);
    rig.expect_state(MachineState::Ready, 20_000);
    assert!(rig.twin().truth().limits.home);
    assert_eq!(rig.machine().record().counters.pulls, 1);
    assert!(rig.machine().fault().is_none());
}

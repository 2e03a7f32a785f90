//! The machine link against the twin (REQ-LINK-03 to REQ-LINK-06): `taut connect` shows a
//! pull live; the pull log a host exports shows the panel's log-page figures; backup → factory reset → restore gives
//! back the settings, presets and calibration; a flood of requests and garbage during a
//! pull changes none of its figures and never faults or stalls the machine.
#![allow(
    clippy::float_arithmetic,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    reason = "test code: a panic is the failure report"
)]

use taut::link::commands::{backup_json, log_csv, parse_backup, restore_over};
use taut::link::twin::{LINE_BYTES_PER_MS, Session, TwinLine};
use taut::link::{Client, Line};
use taut_core::machine::panel;
use taut_core::machine::{MachineState, tension_display};
use taut_core::store::Record;
use taut_core::units::Kgf;
use taut_link::message::{Request, WirePreferences, WireSettings, WireUnit};
use taut_link::{MAX_FRAME, encode};

/// Ticks `twin` until its session is over and it idles in Ready.
fn finish(twin: &mut TwinLine) {
    for _ in 0..600_000 {
        if twin.session_done() && twin.machine().state() == MachineState::Ready {
            return;
        }
        twin.tick();
    }
    panic!("the twin's session did not finish: {:?}", twin.machine().state());
}

/// A twin commissioned and powered up again, that has pulled `pulls` times.
fn session(pulls: u32) -> TwinLine {
    let mut twin = TwinLine::commissioned(Session { pulls, hold_ms: 3_000 }).expect("commissioned");
    finish(&mut twin);
    twin
}

/// REQ-LINK-04: every pull of the session is exported, and each CSV figure, read back and
/// shown as the panel's log page shows it, gives the page's digits.
#[test]
fn link_log_csv_figures_equal_the_panels_log_pages() {
    let twin = session(3);
    let record = *twin.machine().record();
    let unit = record.settings.set_point().unit();
    let panel_log: Vec<_> = twin.machine().log().iter().copied().collect();
    assert_eq!(panel_log.len(), 3, "the session's three pulls are logged");
    let mut client = Client::new(twin);
    client.hello().unwrap();
    let mut entries = client.pull_log().unwrap();
    entries.reverse();
    let csv = log_csv(&entries);
    let rows: Vec<Vec<String>> =
        csv.lines().skip(1).map(|l| l.split(',').map(str::to_owned).collect()).collect();
    assert_eq!(rows.len(), 3, "{csv}");
    let number = |text: &str| text.parse::<f64>().unwrap();
    for (index, (row, logged)) in rows.iter().zip(&panel_log).enumerate() {
        let back = (panel_log.len() - 1 - index) as u32;
        // The panel's log page: pull number, target, peak, adjust, time, hold, string.
        assert_eq!(
            panel::integer(number(&row[0]) as u32),
            panel::integer(record.counters.pulls - back)
        );
        let kgf = |text: &str| Kgf::from_milli((number(text) * 1_000.0).round() as i32);
        assert_eq!(
            tension_display(kgf(&row[1]), unit),
            tension_display(logged.target.to_kgf(), unit)
        );
        assert_eq!(
            tension_display(kgf(&row[3]), unit),
            tension_display(logged.peak.to_kgf(), unit)
        );
        assert_eq!(
            tension_display(kgf(&row[4]), unit),
            tension_display(logged.adjust.to_kgf(), unit)
        );
        let ms = (number(&row[5]) * 1_000.0).round() as i32;
        assert_eq!(
            panel::hundredths(ms / 10),
            panel::hundredths(i32::from(logged.time_to_tension_ms / 10))
        );
        assert_eq!(
            panel::clock(b' ', number(&row[6]) as u32),
            panel::clock(b' ', u32::from(logged.held_s))
        );
        assert_eq!(
            panel::integer(number(&row[7]) as u32),
            panel::integer(u32::from(logged.string_mm))
        );
        match logged.stiffness {
            Some(k) => assert_eq!(
                panel::hundredths((number(&row[8]) * 100.0).round() as i32),
                panel::hundredths(i32::from(k.milli() / 10))
            ),
            None => assert_eq!(row[8], ""),
        }
        assert!(logged.target.hundredths() > 2_000, "a real pull: {logged:?}");
    }
}

/// REQ-LINK-05: backup → factory reset → restore gives back identical settings, presets,
/// preferences and calibration; a backup of another board is refused unless forced.
#[test]
fn link_backup_factory_reset_restore_gives_back_settings_and_calibration() {
    let commissioned = session(0);
    let original = *commissioned.machine().record();
    assert!(original.calibration.is_some(), "the twin was calibrated");
    let mut client = Client::new(commissioned);
    let identity = client.hello().unwrap();
    let bytes = client.record_bytes().unwrap();
    let text = serde_json::to_string(&backup_json(&identity, &bytes).unwrap()).unwrap();
    let backup = parse_backup(&text).unwrap();

    let mut fresh = TwinLine::factory_fresh();
    finish(&mut fresh);
    assert_ne!(fresh.machine().record().settings, original.settings);
    assert_eq!(fresh.machine().record().calibration, None);
    let mut client = Client::new(fresh);
    let other_board = taut::link::commands::Backup { board: [7; 12], ..backup };
    assert!(restore_over(&mut client, &other_board, false).is_err(), "another board");
    restore_over(&mut client, &backup, false).unwrap();
    // Wait for the machine to store it (its idle delay), as after a change on the panel.
    let twin = client.line_mut();
    for _ in 0..10_000 {
        twin.tick();
    }
    let stored = Record::decode(twin.flash()).unwrap();
    for restored in [*twin.machine().record(), stored] {
        assert_eq!(restored.settings, original.settings);
        assert_eq!(restored.presets, original.presets);
        assert_eq!(restored.preferences, original.preferences);
        assert_eq!(restored.calibration, original.calibration);
    }
}

/// Sends one framed request into the twin's line.
fn send(twin: &mut TwinLine, request: &Request) {
    let mut frame = [0u8; MAX_FRAME];
    let len = encode(&taut_link::Command { seq: 0, request: *request }, &mut frame).unwrap();
    twin.write_all(&frame[..len]).unwrap();
}

/// REQ-LINK-06: the same session with and without a flood on the link (requests of every
/// kind, writes while it pulls and holds, garbage and half frames, far more than the line
/// carries): the same tension at every tick, the same log, no fault, and the machine still
/// answers right after.
#[test]
fn link_a_flood_during_pulls_changes_nothing_and_never_stalls() {
    let make = || TwinLine::commissioned(Session { pulls: 2, hold_ms: 3_000 }).unwrap();
    let (mut quiet, mut flooded) = (make(), make());
    let settings = WireSettings {
        unit: WireUnit::Kilograms,
        tension_tenths: 400,
        speed: 9,
        pre_stretch_percent: 30,
        knot_percent: 20,
    };
    let preferences = WirePreferences { beeper: false, constant_pull: false };
    let mut refused_writes = 0;
    let mut ticks = 0u32;
    let mut junk = [0u8; 24];
    let mut read = vec![0u8; 4_096];
    while !(quiet.session_done() && quiet.machine().state() == MachineState::Ready) {
        assert!(ticks < 600_000, "the session did not finish");
        // The line full all the time: a new burst whenever the last one is delivered.
        if flooded.pending_to_machine() < 2 * LINE_BYTES_PER_MS {
            let state = flooded.machine().state();
            match ticks % 4 {
                0 => send(&mut flooded, &Request::ReadLog { page: (ticks % 9) as u8 }),
                1 => send(&mut flooded, &Request::Stream { period_ms: 20 }),
                // Writes only while the pull cannot end before they arrive: they must be
                // refused (in Ready they would be accepted, as they should).
                2 if matches!(state, MachineState::Pulling | MachineState::Holding) => {
                    send(&mut flooded, &Request::WriteSettings { settings, preferences });
                    send(&mut flooded, &Request::WritePreset { index: 0, settings });
                    send(&mut flooded, &Request::CommitRecord);
                    refused_writes += 1;
                }
                _ => {
                    // Garbage and a half frame: bytes that look like a frame start, no end.
                    for (i, byte) in junk.iter_mut().enumerate() {
                        *byte = (ticks as u8).wrapping_mul(31).wrapping_add(i as u8) | 1;
                    }
                    flooded.write_all(&junk).unwrap();
                }
            }
        }
        quiet.tick();
        flooded.tick();
        let _ = flooded.read_some(&mut read, 0).unwrap();
        ticks += 1;
        assert_eq!(
            quiet.twin().truth().tension_kgf.to_bits(),
            flooded.twin().truth().tension_kgf.to_bits(),
            "the tension at tick {ticks}"
        );
        assert_eq!(quiet.last_tick().1.drive, flooded.last_tick().1.drive, "tick {ticks}");
        assert_eq!(flooded.machine().fault(), None);
    }
    assert!(refused_writes > 50, "writes were sent while the machine moved: {refused_writes}");
    let quiet_log: Vec<_> = quiet.machine().log().iter().copied().collect();
    let flooded_log: Vec<_> = flooded.machine().log().iter().copied().collect();
    assert_eq!(quiet_log.len(), 2);
    assert_eq!(quiet_log, flooded_log, "the pulls' figures");
    assert_eq!(quiet.machine().record().settings, flooded.machine().record().settings);
    // Not stalled: with the flood over, the machine answers a hello within its timeout.
    flooded.write_all(&[0]).unwrap();
    let mut client = Client::new(flooded);
    if let Err(e) = client.hello() {
        panic!("{e}")
    }
}

/// `taut connect --twin`: the hello's identity, then the live stream of a whole pull — the
/// state changes as events, the hold's samples at the target, the pull logged — and exit 0.
#[test]
fn link_connect_twin_shows_a_live_pull() {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_taut"))
        .args(["connect", "--twin", "--pulls", "1"])
        .output()
        .expect("taut runs");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let text = String::from_utf8_lossy(&output.stdout);
    let first = text.lines().next().unwrap_or_default();
    assert!(first.starts_with("machine ") && first.contains("link protocol 1"), "{first}");
    for event in
        ["event: ready -> pulling", "event: pulling -> holding", "event: releasing -> ready"]
    {
        assert!(text.contains(event), "no `{event}` in:\n{text}");
    }
    assert_eq!(text.matches("event: pull 1 logged: target 22.00 kg").count(), 1, "{text}");
    // The hold's live samples: the tension shown is the target's to the 0.1 kg.
    let holding: Vec<&str> =
        text.lines().filter(|l| l.contains(" holding ") && l.contains("tension")).collect();
    assert!(holding.len() >= 20, "{} hold samples", holding.len());
    for line in &holding {
        let tension = line.split("tension").nth(1).and_then(|t| t.split_whitespace().next());
        let value: f64 = tension.and_then(|t| t.parse().ok()).expect("a tension");
        assert!((value - 22.0).abs() <= 0.15, "{line}");
    }
}

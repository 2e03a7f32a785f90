//! `taut panel --script`: the front panel driven from a script — the display's segments,
//! the lamps, the keys' effects and the states the machine reaches.
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::float_arithmetic,
    clippy::print_stdout,
    reason = "a test: a panic is how it reports"
)]

use std::io::Write as _;
use std::process::{Command, Stdio};

use taut::panel::script::{Script, ScriptFailure};
use taut::panel::{Flash, PanelSession, display};
use taut_core::io::Segments;
use taut_core::machine::MachineState;
use taut_sim::StringKind;

fn session(flash: Flash) -> PanelSession {
    PanelSession::new(StringKind::TennisSynthetic, None, flash).expect("session")
}

/// Runs `text` on `session`, returning the transcript.
fn run(session: &mut PanelSession, text: &str) -> Result<String, (ScriptFailure, String)> {
    let script = Script::parse(text).expect("parses");
    let mut out = Vec::new();
    let result = script.run(session, false, &mut out);
    let transcript = String::from_utf8(out).unwrap();
    println!("{transcript}");
    result.map(|()| transcript.clone()).map_err(|failure| (failure, transcript))
}

const TO_READY: &str = "until calibration-window 5000\npress start\nuntil ready 1000\n";

#[test]
fn the_ready_panel_shows_25_0_as_the_right_segments() {
    let mut s = session(Flash::Factory);
    run(&mut s, &format!("{TO_READY}expect display 25.0\nexpect led kg on\nexpect led lb off\n"))
        .unwrap();
    // Blank, 2, 5 with its decimal point, 0 — segment a = bit 0 … g = bit 6, point = bit 7.
    assert_eq!(
        s.outputs().display,
        [Segments(0x00), Segments(0x5B), Segments(0x6D | 0x80), Segments(0x3F)]
    );
    let frame = s.frame().join("\n");
    let art = display::art(&s.outputs().display);
    assert_eq!(art[0], "     _   _   _  ");
    assert_eq!(art[1], "     _| |_  | | ");
    assert_eq!(art[2], "    |_   _|.|_| ");
    for line in &art {
        assert!(frame.contains(line.as_str()), "the frame draws the digits");
    }
    assert!(frame.contains("[*] kg") && frame.contains("[ ] lb"));
    assert!(frame.contains("state: ready"));
}

/// Every press counts: a burst of 25 distinct Up presses, each 20 ms down and 20 ms up (a
/// stringer tapping fast), raises the set point by 25 steps, none merged into its neighbour.
#[test]
fn a_burst_of_quick_presses_counts_every_press() {
    let mut s = session(Flash::Factory);
    let burst = "down up\nwait 20\nup up\nwait 20\n".repeat(25);
    run(&mut s, &format!("{TO_READY}expect display 25.0\n{burst}wait 300\nexpect display 27.5\n"))
        .unwrap();
}

#[test]
fn keys_walk_the_settings_pages_and_change_the_set_point() {
    let mut s = session(Flash::Factory);
    let transcript = run(
        &mut s,
        &format!(
            "{TO_READY}\
             press up 5\n\
             expect display 25.5\n\
             press down\n\
             expect display 25.4\n\
             hold up 1250\n\
             expect display 26.2\n\
             press function\n\
             expect display \"SP 5\"\n\
             press up 2\n\
             expect display \"SP 7\"\n\
             press function\n\
             expect display \"PS 0\"\n\
             press up\n\
             expect display \"PS 5\"\n\
             press function\n\
             expect display \"Kn 0\"\n\
             press function\n\
             expect display kg\n\
             press up\n\
             expect display lb\n\
             expect led lb on\n\
             press function\n\
             expect display bEon\n\
             press function\n\
             expect display CPon\n\
             press function\n\
             expect display 58.0\n"
        ),
    )
    .unwrap();
    // Held 1.25 s: the press after the 20 ms debounce, then the panel's own repeat (from
    // 0.6 s held, every 0.1 s): 1 + 7 steps.
    assert!(transcript.contains("hold up 1250"));
    let settings = s.bench().machine().record().settings;
    assert_eq!(settings.speed().get(), 7);
    assert_eq!(settings.pre_stretch().percent(), 5);
    assert_eq!(
        settings.set_point().tenths(),
        580,
        "26.2 kg → 57.8 lb → 58.0 lb on the 0.5 lb step"
    );
}

#[test]
fn a_scripted_pull_holds_beeps_and_releases() {
    let mut s = session(Flash::Calibrated);
    let transcript = run(
        &mut s,
        &format!(
            "{TO_READY}\
             expect display 22.0\n\
             press up 30\n\
             expect display 25.0\n\
             press start\n\
             expect state pulling\n\
             expect led pull on\n\
             until holding 20000\n\
             expect beeper on\n\
             expect led hold on\n\
             wait 2000\n\
             expect tension 24.85 25.15\n\
             expect beeper off\n\
             frame\n\
             press start\n\
             until ready 20000\n\
             expect led hold off\n\
             expect tension 0 0.05\n"
        ),
    );
    let transcript = transcript.unwrap_or_else(|(failure, t)| panic!("{failure}\n{t}"));
    assert!(transcript.contains("ready -> pulling"));
    assert!(transcript.contains("pulling -> holding"));
    assert!(transcript.contains("holding -> releasing"));
    assert!(transcript.contains("releasing -> ready"));
    assert!(transcript.contains("+-- taut front panel"), "the frame is printed");
    let log = s.bench().machine().log().last().copied().expect("the pull is logged");
    assert_eq!(log.target.to_kgf(), taut_core::units::Kgf::from_int(25));
}

#[test]
fn knot_mode_and_a_broken_string_show_on_the_panel() {
    let mut s = session(Flash::Factory);
    run(
        &mut s,
        &format!(
            "{TO_READY}\
             hold f 1700\n\
             expect led knot on\n\
             until display 25.0 6000\n\
             press start\n\
             until holding 20000\n\
             break\n\
             until fault 200\n\
             expect state E-15\n\
             expect display E-15\n\
             expect led fault on\n\
             expect led hold off\n"
        ),
    )
    .unwrap();
    assert_eq!(s.state(), MachineState::Fault(taut_core::machine::FaultCode::StringBreak));
}

#[test]
fn a_failed_expectation_names_its_line_and_what_the_panel_showed() {
    let mut s = session(Flash::Factory);
    let (failure, _) =
        run(&mut s, &format!("{TO_READY}# the machine shows 25.0\nexpect display 30.0\n"))
            .unwrap_err();
    let message = failure.to_string();
    assert!(message.starts_with("line 5: expected display \"30.0\""), "{message}");
    assert!(message.contains("display=[ 25.0]"), "{message}");
    let (late, _) = run(&mut s, "100 press start\n").unwrap_err();
    assert!(late.to_string().contains("in the past"), "{late}");
    let (timeout, _) = run(&mut s, "until holding 50\n").unwrap_err();
    assert!(timeout.to_string().contains("not reached within 50 ms"), "{timeout}");
}

#[test]
fn the_binary_runs_a_script_from_stdin_and_refuses_interactive_mode_without_a_terminal() {
    let script = format!("{TO_READY}expect display 25.0\nprint\n");
    let mut child = Command::new(env!("CARGO_BIN_EXE_taut"))
        .current_dir(std::env::temp_dir())
        .args(["panel", "--flash", "factory", "--frames", "--script", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    child.stdin.take().unwrap().write_all(script.as_bytes()).unwrap();
    let output = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    assert!(stdout.contains("display=[ 25.0]"));
    assert!(stdout.contains("    |_   _|.|_| "), "frames drawn");

    let failing = Command::new(env!("CARGO_BIN_EXE_taut"))
        .current_dir(std::env::temp_dir())
        .args(["panel", "--flash", "blank", "--script", "-"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(failing.status.success(), "an empty script passes");

    let interactive = Command::new(env!("CARGO_BIN_EXE_taut"))
        .current_dir(std::env::temp_dir())
        .args(["panel", "--flash", "factory"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_eq!(interactive.status.code(), Some(1), "a runtime failure, not a usage error");
    assert!(String::from_utf8_lossy(&interactive.stderr).contains("needs a terminal"));
}

#[test]
fn a_blank_flash_boots_on_defaults_with_the_store_notice() {
    let mut s = session(Flash::Blank);
    run(&mut s, &format!("{TO_READY}expect display n-01\npress down\nexpect display 25.0\n"))
        .unwrap();
}

mod format {
    use proptest::prelude::*;
    use taut::panel::script::{
        Check, Command, LONGEST_MS, Lamp, MOST_PRESSES, Script, StatePattern,
    };
    use taut_core::io::Key;
    use taut_core::machine::MachineState;

    fn key() -> impl Strategy<Value = Key> {
        prop::sample::select(Key::ALL.to_vec())
    }

    fn check() -> impl Strategy<Value = Check> {
        let states = MachineState::KINDS.map(StatePattern::Kind).to_vec();
        let lamps = vec![Lamp::Kg, Lamp::Lb, Lamp::Pull, Lamp::Hold, Lamp::Fault, Lamp::Knot];
        prop_oneof![
            prop::sample::select(states).prop_map(Check::State),
            (1..=99u8).prop_map(|n| Check::State(StatePattern::Fault(n))),
            "[A-Za-z0-9.?_ -]{0,6}".prop_map(Check::Display),
            (prop::sample::select(lamps), any::<bool>()).prop_map(|(l, on)| Check::Lamp(l, on)),
            any::<bool>().prop_map(Check::Beeper),
            (0.0..=60.0f64, 0.0..=60.0f64).prop_map(|(a, b)| Check::Tension(a.min(b), a.max(b))),
        ]
    }

    fn command() -> impl Strategy<Value = Command> {
        prop_oneof![
            (1..=LONGEST_MS).prop_map(Command::Wait),
            (key(), 1..=MOST_PRESSES).prop_map(|(k, n)| Command::Press(k, n)),
            (key(), 1..=LONGEST_MS).prop_map(|(k, ms)| Command::Hold(k, ms)),
            key().prop_map(Command::Down),
            key().prop_map(Command::Up),
            (check(), 1..=LONGEST_MS).prop_map(|(c, ms)| Command::Until(c, ms)),
            check().prop_map(Command::Expect),
            Just(Command::Print),
            Just(Command::Frame),
            Just(Command::Gauge),
            Just(Command::Break),
            Just(Command::Restring),
        ]
    }

    proptest! {
        /// Any text at all: the parser answers with a script or a line-numbered error.
        #[test]
        fn the_script_parser_never_panics(text in "\\PC{0,200}(\n\\PC{0,80}){0,8}") {
            if let Err(error) = Script::parse(&text) {
                prop_assert!(error.line >= 1 && error.line <= text.lines().count());
            }
        }

        /// Every command prints as a line that parses back to the same command, with an
        /// optional leading time.
        #[test]
        fn printed_commands_parse_back(commands in prop::collection::vec((command(), prop::option::of(any::<u32>())), 0..12)) {
            let text: String = commands
                .iter()
                .map(|(c, at)| match at {
                    Some(at) => format!("{at} {c}  # comment\n"),
                    None => format!("{c}\n"),
                })
                .collect();
            let script = Script::parse(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
            prop_assert_eq!(script.lines.len(), commands.len());
            for (line, (command, at)) in script.lines.iter().zip(&commands) {
                prop_assert_eq!(&line.command, command);
                prop_assert_eq!(line.at, at.map(u64::from));
            }
        }
    }
}

#[test]
fn the_help_script_example_runs_as_written() {
    let example: String = taut::panel::script::FORMAT_HELP
        .split_once("\nExample")
        .and_then(|(_, rest)| rest.split_once('\n'))
        .map(|(_, body)| body.lines().map(|l| format!("{}\n", l.trim())).collect())
        .expect("the help has an example");
    assert!(example.lines().count() >= 5, "{example}");
    let mut s = session(Flash::Calibrated);
    run(&mut s, &example).expect("the example passes on the default panel");
}

#[test]
fn after_a_string_break_the_stringer_clears_the_fault_restrings_and_pulls_again() {
    let mut s = session(Flash::Calibrated);
    run(
        &mut s,
        &format!(
            "{TO_READY}\
             press start\n\
             until holding 20000\n\
             break\n\
             until fault 200\n\
             expect display E-15\n\
             press start\n\
             until ready 20000\n\
             expect led fault off\n\
             restring\n\
             press start\n\
             until holding 20000\n\
             wait 1500\n\
             expect tension 21.8 22.2\n\
             press start\n\
             until ready 20000\n"
        ),
    )
    .unwrap();
    assert!(s.frame().join("\n").contains("n fits a new string"));
}

#[test]
fn the_frame_says_which_page_the_display_shows() {
    let mut s = session(Flash::Factory);
    run(&mut s, TO_READY).unwrap();
    assert!(s.frame().join("\n").contains("shows: tension set point"));
    run(&mut s, "press function\nexpect display \"SP 5\"\n").unwrap();
    assert!(s.frame().join("\n").contains("SP n: pull speed 1 (gentlest) – 9 (fastest)"));
    run(&mut s, "press function\n").unwrap();
    assert!(s.frame().join("\n").contains("PSnn: pre-stretch"));
}

/// REQ-SM-08/09/10 from a script: in a hold, +0.5 kg then −0.3 kg with the true tension
/// following within the hold accuracy and no release; Preset shows the tension timer, which
/// reads each second on its tick; Start releases, and the log entry carries the adjustment.
#[test]
fn panel_script_hold_adjusts_and_times() {
    let mut s = session(Flash::Calibrated);
    let transcript = run(&mut s, include_str!("panel/hold.txt")).unwrap();
    let machine = s.bench().machine();
    let entry = machine.log().last().expect("the pull is logged");
    println!("log: {entry:?}");
    assert_eq!(entry.adjust.to_kgf().to_tenths_rounded(), 2);
    assert_eq!(entry.target.to_kgf().to_tenths_rounded(), 222);
    assert!(entry.held_s >= 21, "{entry:?}");
    // One release only: the one Start asked for.
    assert_eq!(transcript.matches("-> releasing").count(), 1, "a key released the hold early");
}

/// REQ-UI-10 from a script: Preset twice opens the information pages, Function walks them —
/// the stringing timer (started, read to the tick, stopped, reset), the pull log (the pull
/// just made, with its adjustment), the counters, the string estimate and the service page
/// (whose Start runs the self-test again) — each showing its label for a second, then the
/// value.
#[test]
fn panel_script_information_pages() {
    let mut s = session(Flash::Calibrated);
    let transcript = run(&mut s, include_str!("panel/pages.txt")).unwrap();
    assert!(
        transcript.contains("ready -> self test"),
        "Start on the service page reruns the self-test"
    );
}

/// The display shows a fault as `E-16` only; the terminal panel says beside it what it
/// means and how to clear it, and likewise for a notice (`n-01`). Every line still fits the
/// terminal the panel asks for.
#[test]
fn a_fault_and_a_notice_show_their_meaning_and_how_to_clear_them() {
    let mut s = PanelSession::new(StringKind::NoString, None, Flash::Calibrated).expect("session");
    run(&mut s, &format!("{TO_READY}press start\nuntil fault 30000\nexpect display E-16\n"))
        .unwrap();
    let frame = s.frame();
    let text = frame.join("\n");
    assert!(text.contains("shows: E-16 no string: 150 mm of travel without tension"), "{text}");
    assert!(text.contains("next:  clamp the string, then Start"), "{text}");
    let columns = usize::from(taut::panel::FRAME_COLUMNS);
    assert!(frame.iter().all(|l| l.chars().count() <= columns), "{text}");

    let mut blank = session(Flash::Blank);
    run(&mut blank, &format!("{TO_READY}expect display n-01\n")).unwrap();
    let text = blank.frame().join("\n");
    assert!(text.contains("shows: n-01 the stored record was missing or corrupt"), "{text}");
    assert!(text.contains("next:  any key; the settings are stored again"), "{text}");
    run(&mut blank, "press down\nexpect display 25.0\n").unwrap();
    assert!(!blank.frame().join("\n").contains("n-01"), "gone once acknowledged");
}

/// Function in a hold switches constant pull off: the display says `LOCK` for a second, then
/// shows the tension again while the string creeps; the terminal panel keeps marking the hold
/// locked until constant pull is on again.
#[test]
fn a_locked_hold_stays_marked_locked_on_the_terminal() {
    let mut s = session(Flash::Calibrated);
    let lock = format!(
        "{TO_READY}press start\nuntil holding 20000\nwait 500\npress function\n\
         expect display LOCK\nwait 3000\nexpect state holding\n"
    );
    run(&mut s, &lock).unwrap();
    assert!(!s.status_line().contains("[LOCK]"), "the display is back on the tension");
    let text = s.frame().join("\n");
    assert!(text.contains("[*] LOCK: constant pull off"), "{text}");
    assert!(text.contains("next:  the carriage stays put and the string may creep"), "{text}");
    run(&mut s, "press function\nexpect display PULL\nwait 3000\n").unwrap();
    let text = s.frame().join("\n");
    assert!(
        !text.contains("LOCK: constant pull off") && !text.contains("may creep"),
        "constant pull on again: {text}"
    );
    run(&mut s, "press start\nuntil ready 20000\n").unwrap();
}

/// `--state FILE` keeps the machine's flash between sessions: a speed set in one session is
/// there in the next, and a file that is not a flash image is refused and left alone.
#[test]
fn the_panel_keeps_its_settings_between_sessions_in_a_state_file() {
    let dir = std::env::temp_dir().join(format!("taut-panel-state-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let session = |script: &str| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_taut"))
            .args(["panel", "--flash", "factory", "--state", "panel.state", "--script", "-"])
            .current_dir(&dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("runs");
        child.stdin.take().unwrap().write_all(script.as_bytes()).unwrap();
        child.wait_with_output().unwrap()
    };
    // First session: factory flash, speed 5 → 7, stored 2 s after the last key.
    let first = session(&format!(
        "{TO_READY}press function\nexpect display \"SP 5\"\npress up 2\nexpect display \"SP 7\"\nwait 2500\n"
    ));
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stdout));
    let stored = std::fs::read(dir.join("panel.state")).unwrap();
    assert_eq!(stored.len(), taut_core::store::RECORD_LEN);
    // Second session: it powers up from the file, not from the factory flash: speed 7.
    let second = session(&format!("{TO_READY}press function\nexpect display \"SP 7\"\n"));
    assert!(
        second.status.success(),
        "the speed was kept: {}{}",
        String::from_utf8_lossy(&second.stdout),
        String::from_utf8_lossy(&second.stderr)
    );
    std::fs::write(dir.join("panel.state"), "not a flash image").unwrap();
    let refused = session("");
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("not a machine's flash image"));
    assert_eq!(std::fs::read(dir.join("panel.state")).unwrap(), b"not a flash image");
    std::fs::remove_dir_all(&dir).ok();
}

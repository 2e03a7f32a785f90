//! The machine's per-tick safety properties (`REQ-SAFE-*`) under `cargo test`: exhaustive
//! over the finite part of the Kani harnesses' space, proptest over the rest. Each test
//! prints how many cases it covered.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::cast_possible_truncation,
    clippy::indexing_slicing,
    clippy::expect_used,
    reason = "test bookkeeping on small counts; a panic fails the test, as it should"
)]

use proptest::prelude::*;
use taut_core::io::Key;
use taut_core::machine::Machine;
use taut_core::units::Kgf;
use taut_proofs::machine::{
    CheckpointInput, STATE_KINDS, TickInput, apply, both_limits_fault_and_coast, check_tick,
    clear_only_with_zero_command, duty_bounded, fault_and_idle_coast, fault_latches,
    hold_adjustment_in_range, never_toward_active_limit, overcurrent_coasts,
    releasing_stops_at_home, resume,
};

/// Load-cell codes: bottom rail, the unloaded tare, ≈ 3, 25 and 52 kgf, top rail.
const LOAD_CELLS: [u16; 6] = [0, 41, 266, 1_924, 3_943, 4_095];
/// Motor current: nothing, 6 A, just under and at the 12 A limit.
const CURRENTS: [u16; 4] = [0, 984, 1_966, 1_967];
/// Hall quiet time: moving, and stalled for a second.
const QUIET_MS: [u16; 2] = [0, 1_000];

/// Every valid checkpoint kind with a spread of indices and timer values.
fn checkpoints() -> Vec<CheckpointInput> {
    let mut out = Vec::new();
    for state in 0..STATE_KINDS {
        let indices: &[u8] = if state == 10 {
            &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18]
        } else if state == 4 || state == 5 {
            // The calibration's readings: four points in two passes.
            &[0, 1, 2, 3, 4, 5, 6, 7]
        } else {
            &[0, 1, 2, 3]
        };
        for &index in indices {
            for elapsed in [0, 63, 1_499, 4_999, 39_999] {
                for (release, then, self_test, clearing) in [
                    (false, 0, false, 0),
                    (true, 1, true, 1),
                    (false, 1, false, 100),
                    (true, 2, false, 0),
                ] {
                    let input = CheckpointInput {
                        state,
                        index,
                        elapsed,
                        release,
                        start_steps: 0,
                        start_home: release,
                        start_end: false,
                        entered: 1_000,
                        then,
                        self_test,
                        clearing,
                        view: index,
                        tare: 41,
                        peak_tenths: if release { 250 } else { 0 },
                        tracked_tenths: if release { [250, 250] } else { [0, 0] },
                        counters: [0, 0],
                        evidence: [0; 3],
                        knot: release,
                        integrators: [0; 5],
                        key_bits: (0, 0),
                        held_ms: 0,
                        long_sent: false,
                        rail_ticks: if release { 19 } else { 0 },
                        hold_adjust: if release { -5 } else { 0 },
                    };
                    if input.checkpoint().is_valid() {
                        out.push(input);
                    }
                }
            }
        }
    }
    out
}

#[test]
fn machine_tick_properties_exhaustive() {
    let starts = checkpoints();
    let base: Vec<Machine<1>> = starts.iter().filter_map(resume::<1>).collect();
    assert_eq!(base.len(), starts.len());
    let mut cases = 0u64;
    for machine in &base {
        for (home, end) in [(false, false), (true, false), (false, true), (true, true)] {
            for drive_fault in 0..=4u8 {
                for &motor_current in &CURRENTS {
                    for &load_cell in &LOAD_CELLS {
                        for &quiet_ms in &QUIET_MS {
                            for keys in [0u8, 1, 2, 4, 8, 16] {
                                let tick = TickInput {
                                    now_ms: 1_000,
                                    load_cell,
                                    motor_current,
                                    drive_fault,
                                    steps: 3_000,
                                    quiet_ms,
                                    home,
                                    end,
                                    keys,
                                    string_counter: 0,
                                };
                                let mut machine = machine.clone();
                                check_tick(&apply(&mut machine, &tick.inputs()));
                                cases += 1;
                            }
                        }
                    }
                }
            }
        }
    }
    println!(
        "machine_tick_properties_exhaustive: {} checkpoints × 4 limits × 5 drive faults × 4 currents × 6 load cells × 2 quiet × 6 keys = {cases} ticks",
        base.len()
    );
    assert!(cases > 100_000);
}

/// A key held long enough to debounce reaches every state's key handling: run 25 ticks
/// with the key down from each checkpoint, checking every tick.
#[test]
fn machine_key_presses_from_every_state() {
    let mut cases = 0u64;
    for input in checkpoints() {
        for key in Key::ALL {
            for (home, end, load_cell) in
                [(false, false, 1_924), (true, false, 41), (false, true, 266)]
            {
                let mut machine = resume::<1>(&input).expect("valid checkpoint");
                for t in 0..25i32 {
                    let tick = TickInput {
                        now_ms: t.unsigned_abs(),
                        load_cell,
                        steps: t,
                        home,
                        end,
                        keys: taut_core::io::Keys::NONE.with(key).bits(),
                        ..TickInput::default()
                    };
                    check_tick(&apply(&mut machine, &tick.inputs()));
                    cases += 1;
                }
            }
        }
    }
    println!("machine_key_presses_from_every_state: {cases} ticks");
}

fn any_checkpoint() -> impl Strategy<Value = CheckpointInput> {
    (
        (
            any::<u8>(),
            any::<u8>(),
            0u32..50_000,
            any::<bool>(),
            any::<i32>(),
            any::<bool>(),
            any::<bool>(),
        ),
        (400u16..6_000, any::<u8>(), any::<bool>(), 0u16..120, any::<u8>(), 0u16..420, 0u16..600),
        (
            prop::array::uniform2(0u8..25),
            any::<bool>(),
            prop::array::uniform5(0u8..25),
            prop::array::uniform2(-600i16..600),
            prop::array::uniform3(0u16..0x8000),
        ),
        (any::<u8>(), any::<u8>(), any::<u16>(), any::<bool>(), 0u8..25, -1_200i16..1_200),
    )
        .prop_map(|(a, b, c, d)| CheckpointInput {
            state: a.0,
            index: a.1,
            elapsed: a.2,
            release: a.3,
            start_steps: a.4,
            start_home: a.5,
            start_end: a.6,
            entered: b.0,
            then: b.1,
            self_test: b.2,
            clearing: b.3,
            view: b.4,
            tare: b.5,
            peak_tenths: b.6,
            tracked_tenths: c.3,
            counters: c.0,
            evidence: c.4,
            knot: c.1,
            integrators: c.2,
            key_bits: (d.0, d.1),
            held_ms: d.2,
            long_sent: d.3,
            rail_ticks: d.4,
            hold_adjust: d.5,
        })
}

fn any_tick() -> impl Strategy<Value = TickInput> {
    (
        any::<u32>(),
        prop_oneof![0u16..4096, Just(0u16), Just(41u16), Just(4095u16)],
        prop_oneof![0u16..4096, 1_960u16..1_975],
        0u8..8,
        any::<i32>(),
        any::<u16>(),
        any::<bool>(),
        any::<bool>(),
        any::<u8>(),
        any::<u16>(),
    )
        .prop_map(
            |(
                now_ms,
                load_cell,
                motor_current,
                drive_fault,
                steps,
                quiet_ms,
                home,
                end,
                keys,
                string_counter,
            )| {
                TickInput {
                    now_ms,
                    load_cell,
                    motor_current,
                    drive_fault,
                    steps,
                    quiet_ms,
                    home,
                    end,
                    keys,
                    string_counter,
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4_000, ..ProptestConfig::default() })]

    /// Any valid checkpoint, then a sequence of arbitrary ticks.
    #[test]
    fn machine_tick_properties_proptest(start in any_checkpoint(), ticks in prop::collection::vec(any_tick(), 1..40)) {
        if let Some(mut machine) = resume::<1>(&start) {
            for tick in ticks {
                let record = apply(&mut machine, &tick.inputs());
                never_toward_active_limit(&record);
                both_limits_fault_and_coast(&record);
                overcurrent_coasts(&record);
                releasing_stops_at_home(&record);
                duty_bounded(&record);
                fault_and_idle_coast(&record);
                clear_only_with_zero_command(&record);
                fault_latches(&record);
            }
        }
    }
}

/// REQ-SAFE-01 at the rule: every command (coast, both directions × all 65 536 duties) × every
/// limit-switch combination.
#[test]
fn limit_guard_exhaustive() {
    use taut_core::drive::{Direction, DriveCommand, Duty};
    use taut_core::io::LimitSwitches;
    let mut cases = 0u64;
    for limits in LimitSwitches::ALL {
        taut_proofs::machine::limit_guard_is_sound(DriveCommand::Coast, limits);
        cases += 1;
        for raw in 0..=u16::MAX {
            for direction in Direction::ALL {
                let command = DriveCommand::Drive { direction, duty: Duty::from_raw_clamped(raw) };
                taut_proofs::machine::limit_guard_is_sound(command, limits);
                cases += 1;
            }
        }
    }
    println!("limit_guard_exhaustive: {cases} cases");
}

/// REQ-SAFE-02/03 at the rule: every limit combination × every drive fault × every current code.
#[test]
fn global_fault_exhaustive() {
    let mut cases = 0u64;
    for limits in 0..4u8 {
        for drive_fault in 0..5u8 {
            for motor_current in 0..=4095u16 {
                let tick = TickInput {
                    home: limits & 1 != 0,
                    end: limits & 2 != 0,
                    drive_fault,
                    motor_current,
                    ..TickInput::default()
                };
                taut_proofs::machine::global_fault_is_sound(&tick.inputs());
                cases += 1;
            }
        }
    }
    println!("global_fault_exhaustive: {cases} cases");
}

/// Mirror of `verify_hold_adjustment_in_range` (Kani), exhaustive over what a run can start
/// a hold from: every set point of both units as a main pull and as a 20 % knot pull, every
/// adjustment from −1 100 to +1 100 tenths (beyond the 45 kgf range in either unit), Up and
/// Down.
#[test]
fn hold_adjustment_in_range_exhaustive() {
    use taut_core::settings::{
        KnotBoost, PreStretch, PullKind, PullSettings, SetPoint, Speed, Unit,
    };
    let mut cases = 0u64;
    for unit in [Unit::Kilograms, Unit::Pounds] {
        for tenths in 0..=1_100u16 {
            let Ok(point) = SetPoint::new(unit, tenths) else { continue };
            let knot = KnotBoost::new(20).expect("valid");
            let settings = PullSettings::new(point.to_kgf(), Speed::MAX, PreStretch::NONE, knot)
                .expect("valid");
            for kind in [PullKind::Main, PullKind::Knot] {
                let base = settings.final_target(kind);
                for adjust in -1_100i16..=1_100 {
                    for step in [-1i8, 1] {
                        hold_adjustment_in_range(base, unit, adjust, step);
                        cases += 1;
                    }
                }
            }
        }
    }
    println!("hold_adjustment_in_range_exhaustive: {cases} cases");
    assert!(cases > 5_000_000);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    /// Mirror of `verify_hold_adjustment_in_range` (Kani) over any base and adjustment.
    #[test]
    fn hold_adjustment_in_range_sampled(
        base in any::<i32>(),
        pounds in any::<bool>(),
        adjust in any::<i16>(),
        up in any::<bool>(),
    ) {
        let unit = if pounds { taut_core::settings::Unit::Pounds } else { taut_core::settings::Unit::Kilograms };
        hold_adjustment_in_range(Kgf::from_bits(base), unit, adjust, if up { 1 } else { -1 });
    }
}

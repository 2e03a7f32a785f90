//! The drive properties (`REQ-DRV-*`) under `cargo test`: exhaustive over every finite domain,
//! proptest over long sequences with full-range inputs. Each test prints how many cases it
//! covered.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::cast_possible_truncation,
    clippy::expect_used,
    clippy::indexing_slicing,
    reason = "test helpers: bookkeeping on small counts; a panic fails the test, as it should"
)]

mod common;

use std::collections::HashSet;

use proptest::prelude::*;
use taut_core::drive::{
    DEAD_TIME_MAX, DEAD_TIME_MIN, DUTY_MAX, Direction, Drive, DriveConfig, DriveTime, LegState,
    REVERSAL_QUIET, Sector, SwitchPattern,
};
use taut_core::sense::current;
use taut_proofs::drive::{
    CheckedDrive, CommandInput, Observer, StepInput, apply, bounded_duty, check_all,
    commutation_is_consistent, duty_constructors_bounded, hall_fault_after, motoring_evidence,
    no_shoot_through, pattern_is_safe, sequencer_step_is_safe, six_step_entry_is_well_formed,
    window_bounds_current,
};

/// The lowest current code that is an overcurrent on the paper's board, found from the
/// conversion and the trip the board states (not from the drive's own threshold in codes).
fn first_overcurrent_code() -> u16 {
    let trip = DriveConfig::PAPER.trip();
    (0..=4095u16)
        .find(|&raw| current::amps(taut_core::units::AdcCode::new(raw)) >= trip)
        .expect("the limit is below full scale")
}

/// One representative of every behaviour class of a call's inputs: the drive's decisions
/// depend on the current only through `current ≥ limit`, on the elapsed ticks only through
/// comparisons with the dead time and `REVERSAL_QUIET` (and saturation, exercised by
/// proptest), and on the duty only by passing it through (every duty value is checked by
/// `bounded_duty_every_duty_value`).
fn alphabet() -> Vec<StepInput> {
    let dead_time = DriveConfig::PAPER.dead_time().0;
    let over = first_overcurrent_code();
    let mut inputs = Vec::new();
    for hall in 0..8u8 {
        for command in [CommandInput::Coast, CommandInput::Pull(u16::MAX), CommandInput::Release(1)]
        {
            for (current, trip) in [(0, false), (over - 1, false), (over, false), (0, true)] {
                for (home, end) in [(false, false), (true, false), (false, true), (true, true)] {
                    for elapsed in [0, dead_time - 1, dead_time, REVERSAL_QUIET.0] {
                        for (clear, bus) in [(false, 1_638), (true, 1_638), (false, 2_731)] {
                            inputs.push(StepInput {
                                hall,
                                command,
                                clear,
                                current,
                                trip,
                                home,
                                end,
                                elapsed,
                                bus,
                            });
                        }
                    }
                }
            }
        }
    }
    inputs
}

/// Mirror of `verify_duty_type_bounded` (Kani): every raw duty, fractions across and
/// beyond the range, a spread of timer periods.
#[test]
fn duty_constructors_bounded_exhaustive() {
    for raw in 0..=u16::MAX {
        let fraction = i32::from(raw) * 3 - 65_536;
        for period in [0, 1, 999, 8_500, u16::MAX] {
            duty_constructors_bounded(raw, fraction, period);
        }
    }
    for fraction in [i32::MIN, -1, 0, 62_259, 62_260, 65_536, i32::MAX] {
        duty_constructors_bounded(0, fraction, u16::MAX);
    }
}

/// Mirror of `verify_hall_skip_latches` (Kani): from a rotor accepted in each sector, every
/// pair of Hall codes over two calls, with the bridge driven either way or coasting.
#[test]
fn hall_skip_latches_from_every_sector() {
    let mut cases = 0_u32;
    for sector in (0..6).map(|k| Sector::S0.advanced(k)) {
        for first in 0..8_u8 {
            for second in 0..8_u8 {
                for command in
                    [CommandInput::Coast, CommandInput::Pull(30_000), CommandInput::Release(30_000)]
                {
                    let input = |hall| StepInput {
                        hall,
                        command,
                        clear: false,
                        current: 0,
                        trip: false,
                        home: false,
                        end: false,
                        elapsed: 8_500,
                        bus: 1_638,
                    };
                    hall_fault_after(sector, &[input(first), input(second)]);
                    cases += 1;
                }
            }
        }
    }
    assert_eq!(cases, 6 * 64 * 3);
}

/// REQ-DRV-01…08, 10: every state reachable from power-up in up to `DEPTH` calls over the
/// representative alphabet, every property on every transition.
#[test]
fn drive_properties_exhaustive_three_calls_deep() {
    const DEPTH: usize = 3;
    let alphabet = alphabet();
    let mut frontier: HashSet<(Drive, Observer)> = HashSet::from([(Drive::new(), Observer::new())]);
    let mut seen: HashSet<(Drive, Observer)> = frontier.clone();
    let mut transitions = 0u64;
    for depth in 1..=DEPTH {
        // The last call's successors are never expanded, so they are checked but not kept:
        // hashing the million states it reaches took five sixths of the test's time (91 s
        // against 15 s).
        let last = depth == DEPTH;
        let mut next = HashSet::new();
        for (drive, observer) in &frontier {
            for input in &alphabet {
                let mut drive = *drive;
                let mut observer = *observer;
                let record = apply(&mut drive, input);
                check_all(&observer, &record);
                transitions += 1;
                if !last {
                    observer.observe(&record);
                    if seen.insert((drive, observer)) {
                        next.insert((drive, observer));
                    }
                }
            }
        }
        frontier = next;
    }
    println!(
        "drive_properties_exhaustive_three_calls_deep: {} inputs per call, {} distinct states \
         expanded, {transitions} transitions checked against REQ-DRV-01…08, 10",
        alphabet.len(),
        seen.len()
    );
    assert!(seen.len() > 1_000, "the search must actually explore");
    assert_eq!(
        transitions,
        u64::try_from(seen.len() * alphabet.len()).unwrap_or(u64::MAX),
        "every expanded state is checked against every input"
    );
}

/// REQ-DRV-01: every one of the 65 536 raw duty requests, both directions, every Hall code,
/// from a drive whose rotor position is confirmed — the emitted duty never exceeds DUTY_MAX.
#[test]
fn bounded_duty_every_duty_value() {
    let mut cases = 0u64;
    for sector in Sector::ALL {
        let mut confirmed = Drive::new();
        let settle = StepInput {
            hall: sector.hall_code().raw(),
            command: CommandInput::Coast,
            clear: false,
            current: 0,
            trip: false,
            home: false,
            end: false,
            elapsed: REVERSAL_QUIET.0,
            bus: 1_638,
        };
        apply(&mut confirmed, &settle);
        apply(&mut confirmed, &settle);
        for hall in 0..8u8 {
            for raw in 0..=u16::MAX {
                for command in [CommandInput::Pull(raw), CommandInput::Release(raw)] {
                    let mut drive = confirmed;
                    let record = apply(&mut drive, &StepInput { hall, command, ..settle });
                    bounded_duty(&record);
                    no_shoot_through(&record);
                    if hall == sector.hall_code().raw() {
                        // A rotor at rest: the command passes up to the current window's
                        // upper edge (I·R / V), the slew allowance being spent by the long
                        // settle interval.
                        let direction = command.command().direction().unwrap_or(Direction::Pull);
                        let bus = taut_core::units::AdcCode::new(settle.bus);
                        let high = record.after.window(direction, bus).map_or(0, |w| w.high.raw());
                        assert_eq!(record.output.duty.raw(), raw.min(DUTY_MAX.raw()).min(high));
                    }
                    cases += 1;
                }
            }
        }
    }
    println!(
        "bounded_duty_every_duty_value: {cases} cases (6 sectors × 8 Hall codes × 65 536 duties × 2 directions)"
    );
}

/// REQ-DRV-02: the whole six-step table, and every one of the 27 leg combinations' gates.
#[test]
fn six_step_table_exhaustive() {
    let mut cases = 0;
    for sector in Sector::ALL {
        for direction in Direction::ALL {
            six_step_entry_is_well_formed(sector, direction);
            commutation_is_consistent(sector, direction);
            cases += 1;
        }
    }
    for a in LegState::ALL {
        for b in LegState::ALL {
            for c in LegState::ALL {
                let pattern = SwitchPattern { a, b, c };
                let gates = pattern.gates();
                for phase in taut_core::drive::Phase::ALL {
                    let (high, low) = gates.leg(phase);
                    assert!(!(high && low));
                }
                if pattern.count(LegState::High) <= 1 && pattern.count(LegState::Low) <= 1 {
                    pattern_is_safe(&pattern);
                }
                cases += 1;
            }
        }
    }
    println!("six_step_table_exhaustive: {cases} cases (12 table entries, 27 leg patterns)");
}

/// REQ-DRV-03 inductively: every sequencer state (27 leg combinations × off-times on both
/// sides of the dead time), every request (27), every elapsed class, for the shortest, taut's
/// and the longest dead time a configuration accepts.
#[test]
fn dead_time_inductive_exhaustive() {
    let mut cases = 0u64;
    for dead_time in [DEAD_TIME_MIN, DriveConfig::PAPER.dead_time(), DEAD_TIME_MAX] {
        let d = dead_time.0;
        let off_times = [0, 1, d - 1, d, u32::MAX];
        let elapsed = [0, 1, d - 1, d, u32::MAX];
        let legs: Vec<(LegState, DriveTime)> = LegState::ALL
            .into_iter()
            .flat_map(|state| off_times.map(move |off| (state, DriveTime(off))))
            .collect();
        for &a in &legs {
            for &b in &legs {
                for &c in &legs {
                    for ra in LegState::ALL {
                        for rb in LegState::ALL {
                            for rc in LegState::ALL {
                                for e in elapsed {
                                    let requested = SwitchPattern { a: ra, b: rb, c: rc };
                                    sequencer_step_is_safe(
                                        [a, b, c],
                                        dead_time,
                                        requested,
                                        DriveTime(e),
                                    );
                                    cases += 1;
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    println!(
        "dead_time_inductive_exhaustive: {cases} cases (3 dead times × 15³ leg states × 27 \
         requests × 5 elapsed)"
    );
}

fn step_input() -> impl Strategy<Value = StepInput> {
    let command = prop_oneof![
        Just(CommandInput::Coast),
        any::<u16>().prop_map(CommandInput::Pull),
        any::<u16>().prop_map(CommandInput::Release),
    ];
    // Hall codes mostly walk like a real rotor (small moves), sometimes jump anywhere.
    let dead_time = DriveConfig::PAPER.dead_time().0;
    let elapsed =
        prop_oneof![0..=2 * dead_time, Just(500u32), 0..=2 * REVERSAL_QUIET.0, any::<u32>(),];
    (
        any::<u8>(),
        command,
        any::<bool>(),
        0..=4095u16,
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        elapsed,
        prop_oneof![1_200..=2_400u16, any::<u16>()],
    )
        .prop_map(|(hall, command, clear, current, trip, home, end, elapsed, bus)| StepInput {
            hall,
            command,
            clear: clear && hall % 4 == 0,
            current: if trip { current } else { current / 2 },
            trip: trip && current % 16 == 0,
            home: home && current % 3 == 0,
            end: end && current % 5 == 0,
            elapsed,
            bus,
        })
}

/// A rotor-like Hall walk: each call the sector stays, steps ±1, or (rarely) jumps.
fn rotor_walk() -> impl Strategy<Value = Vec<StepInput>> {
    proptest::collection::vec((step_input(), 0..20u8), 1..200).prop_map(|steps| {
        let mut sector = 0u8;
        steps
            .into_iter()
            .map(|(mut input, walk)| {
                sector = match walk {
                    0..=11 => sector,
                    12..=15 => (sector + 1) % 6,
                    16..=18 => (sector + 5) % 6,
                    _ => input.hall % 6,
                };
                if walk != 19 || input.hall < 250 {
                    input.hall = Sector::ALL[usize::from(sector)].hall_code().raw();
                }
                input
            })
            .collect()
    })
}

/// REQ-DRV-01…08, 10 over long sequences of full-range inputs.
#[test]
fn drive_properties_random_sequences() {
    let sequences = proptest::collection::vec(step_input(), 1..200);
    common::check("drive_properties_random_sequences", 4_000, sequences, |inputs| {
        let mut drive = CheckedDrive::new();
        for input in &inputs {
            drive.step(input);
        }
    });
}

/// REQ-DRV-01…08, 10 with a rotor that turns like a real one (so the drive actually drives,
/// commutates and reverses).
#[test]
fn drive_properties_rotor_walk() {
    common::check("drive_properties_rotor_walk", 4_000, rotor_walk(), |inputs| {
        let mut drive = CheckedDrive::new();
        for input in &inputs {
            drive.step(input);
        }
    });
}

/// The properties are not vacuous: a rotor walk with a pull command does energise the bridge,
/// commutate through all six sectors, reverse, and fault.
#[test]
fn properties_see_real_driving() {
    let mut drive = CheckedDrive::new();
    let mut energised = HashSet::new();
    let base = StepInput {
        hall: 0,
        command: CommandInput::Pull(30_000),
        clear: false,
        current: 0,
        trip: false,
        home: false,
        end: false,
        elapsed: 8_500,
        bus: 1_638,
    };
    for lap in 0..2 {
        for sector in Sector::ALL {
            for _ in 0..2 {
                let record = drive.step(&StepInput { hall: sector.hall_code().raw(), ..base });
                if lap == 1 {
                    energised.insert(record.output.pattern);
                }
            }
        }
    }
    assert_eq!(energised.len(), 6, "every forward table entry was emitted");
    let release = StepInput { command: CommandInput::Release(30_000), ..base };
    let mut reversed = false;
    // One step every two periods reads as a back-EMF far above I·R: the reversal waits until
    // the quiet time brings the bound below it (2.675 × 10⁹ / 5 600 mV ≈ 56 periods).
    for _ in 0..80 {
        let record = drive.step(&StepInput { hall: Sector::S0.hall_code().raw(), ..release });
        reversed |=
            record.output.pattern == taut_core::drive::six_step(Sector::S0, Direction::Release);
    }
    assert!(reversed, "the drive reversed once the rotor's back-EMF allowed it");
}

/// The braking quadrant (REQ-DRV-15) is reached and checked: a rotor turning forward at one
/// step per 1.6 ms (≈ 9.8 V of back-EMF, past `I_lim·R`) under a release command is braked
/// through the forward table, every call checked against every property.
#[test]
fn properties_see_the_brake() {
    let mut drive = CheckedDrive::new();
    let base = StepInput {
        hall: 0,
        command: CommandInput::Pull(3_000),
        clear: false,
        current: 0,
        trip: false,
        home: false,
        end: false,
        elapsed: 3_200,
        bus: 1_638,
    };
    let mut braked = 0;
    for lap in 0..3 {
        for sector in Sector::ALL {
            let command =
                if lap == 0 { CommandInput::Pull(3_000) } else { CommandInput::Release(3_000) };
            for _ in 0..5 {
                let record =
                    drive.step(&StepInput { hall: sector.hall_code().raw(), command, ..base });
                let forward = record.output.pattern
                    == taut_core::drive::six_step(sector, Direction::Pull)
                    || record.output.pattern
                        == taut_core::drive::six_step(sector.advanced(5), Direction::Pull);
                if lap > 0 && forward && !record.output.duty.is_zero() {
                    braked += 1;
                }
            }
        }
    }
    assert!(braked > 40, "braked in {braked} calls");
}

/// REQ-DRV-10 on the window alone: every bus code × back-EMF from −61 V to +61 V in 7 mV
/// steps (and the extremes of the type).
#[test]
fn window_bounds_current_every_bus_code() {
    let mut cases = 0u64;
    for bus in 0..=4_095u16 {
        for emf in (-61_000..=61_000).step_by(7).chain([i32::MIN, i32::MAX]) {
            window_bounds_current(bus, emf);
            cases += 1;
        }
    }
    println!("window_bounds_current_every_bus_code: {cases} cases");
}

/// REQ-DRV-12's evidence: every code against a unidirectional zero (0), the mid-rail zero and
/// an offset one, at duties from 0 to full in steps of 1/64 and the quarter floor's
/// neighbours.
#[test]
fn motoring_evidence_every_code() {
    let mut cases = 0u64;
    for zero in [0u16, 2_048, 2_100] {
        for duty in (0..=65_535u16).step_by(1_024).chain([16_383, 16_384, 16_385, 65_535]) {
            for code in 0..=4_095u16 {
                motoring_evidence(code, zero, duty);
                cases += 1;
            }
        }
    }
    println!("motoring_evidence_every_code: {cases} cases");
}

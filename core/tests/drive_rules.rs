//! The drive's rules stated directly, one test per rule, under plain `cargo test`.
//!
//! The drive's safety properties are proven by Kani and checked exhaustively in
//! `proofs/tests/drive.rs`; those checks look at what the drive *emits*. The rules here are the
//! contracts of the building blocks the properties rest on — the dead-time sequencer's
//! `ready_for`, `all_off` and invariant, the Hall filter's invariant, the duty's compare value —
//! and the drive's engage rule ("the whole table entry goes on the gates in the same call"),
//! including the invariants' answers on deliberately invalid states, which no run reaches
//! (and which Kani harnesses, not run by `cargo test`, were the only ones to look at).
#![allow(
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    clippy::panic,
    reason = "a test: bookkeeping on small constants; a panic fails the test, as it should"
)]

use taut_core::drive::{
    DUTY_MAX, DeadTimeSequencer, Direction, Drive, DriveCommand, DriveConfig, DriveOutput,
    DriveSample, DriveTime, Duty, HallCode, HallFilter, HallState, LegState, Phase, REVERSAL_QUIET,
    Sector, SwitchPattern, six_step,
};

/// Off-times that straddle every comparison the sequencer makes.
/// taut's board's dead time ([`DriveConfig::PAPER`]).
const DEAD_TIME: DriveTime = DriveConfig::PAPER.dead_time();

/// One 50 µs PWM period (20 kHz) in drive time.
const PERIOD: u32 = 500;

/// A 20 kHz period of a 170 MHz timer, in timer ticks (for the compare value).
const PERIOD_TICKS: u16 = 8_500;

const OFF_TIMES: [u32; 6] = [0, 1, DEAD_TIME.0 - 1, DEAD_TIME.0, DEAD_TIME.0 + 1, u32::MAX];

/// Every valid sequencer state over `OFF_TIMES` (a leg that is on has been off for 0 ticks).
fn sequencer_states() -> Vec<[(LegState, DriveTime); 3]> {
    let mut legs = Vec::new();
    for state in LegState::ALL {
        if state.is_on() {
            legs.push((state, DriveTime(0)));
        } else {
            legs.extend(OFF_TIMES.map(|ticks| (state, DriveTime(ticks))));
        }
    }
    let mut out = Vec::new();
    for &a in &legs {
        for &b in &legs {
            for &c in &legs {
                out.push([a, b, c]);
            }
        }
    }
    out
}

fn patterns() -> Vec<SwitchPattern> {
    let mut out = Vec::new();
    for a in LegState::ALL {
        for b in LegState::ALL {
            for c in LegState::ALL {
                out.push(SwitchPattern { a, b, c });
            }
        }
    }
    out
}

fn sequencer(legs: [(LegState, DriveTime); 3]) -> DeadTimeSequencer {
    DeadTimeSequencer::from_parts(legs, DEAD_TIME)
        .unwrap_or_else(|| panic!("valid parts refused: {legs:?}"))
}

/// `ready_for(requested, elapsed)` says exactly whether `step(requested, elapsed)` puts
/// `requested` on the gates in full — for every state, request and elapsed time.
#[test]
fn ready_for_is_true_exactly_when_the_step_emits_the_whole_request() {
    let mut cases = 0u32;
    let mut ready = 0u32;
    for legs in sequencer_states() {
        for requested in patterns() {
            for elapsed in OFF_TIMES {
                let before = sequencer(legs);
                let mut after = before;
                let emitted = after.step(requested, DriveTime(elapsed));
                let full = emitted == requested;
                assert_eq!(
                    before.ready_for(requested, DriveTime(elapsed)),
                    full,
                    "{legs:?} asked {requested:?} after {elapsed} ticks emitted {emitted:?}"
                );
                cases += 1;
                ready += u32::from(full);
            }
        }
    }
    println!("ready_for: {cases} cases, {ready} ready");
    assert!(ready > 0 && ready < cases);
}

/// `all_off` switches every conducting leg off at once — no dead time is needed to turn off
/// — and that starts each such leg's off-time: none comes back before `DEAD_TIME`. A leg that
/// was already off keeps counting.
#[test]
fn all_off_turns_every_leg_off_now_and_restarts_their_dead_time() {
    let a_high_b_low = SwitchPattern { a: LegState::High, b: LegState::Low, c: LegState::Off };
    let mut gates = DeadTimeSequencer::new(DEAD_TIME);
    gates.step(SwitchPattern::ALL_OFF, DriveTime(40));
    assert_eq!(gates.step(a_high_b_low, DEAD_TIME), a_high_b_low);
    gates.step(a_high_b_low, DriveTime(50));
    let c_off_for = gates.off_for(Phase::C);
    assert_eq!(c_off_for, DriveTime(40 + DEAD_TIME.0 + 50));

    gates.all_off();
    assert_eq!(gates.pattern(), SwitchPattern::ALL_OFF);
    assert_eq!(gates.off_for(Phase::A), DriveTime(0));
    assert_eq!(gates.off_for(Phase::B), DriveTime(0));
    assert_eq!(gates.off_for(Phase::C), c_off_for, "an off leg keeps its off-time");
    assert!(gates.is_valid());
    // The legs that were on wait the full dead time again.
    assert_eq!(gates.step(a_high_b_low, DriveTime(DEAD_TIME.0 - 1)), SwitchPattern::ALL_OFF);
    assert_eq!(gates.step(a_high_b_low, DriveTime(1)), a_high_b_low);

    // From every valid state.
    for legs in sequencer_states() {
        let mut cleared = sequencer(legs);
        cleared.all_off();
        assert_eq!(cleared.pattern(), SwitchPattern::ALL_OFF, "{legs:?}");
        for (phase, (state, off_for)) in Phase::ALL.into_iter().zip(legs) {
            let expected = if state.is_on() { DriveTime(0) } else { off_for };
            assert_eq!(cleared.off_for(phase), expected, "{legs:?} {phase:?}");
        }
    }
}

/// The sequencer's invariant — a conducting leg has a zero off-time — accepts exactly the
/// states it should, `from_parts` builds exactly what it was given, and stepping from any
/// valid state keeps it.
#[test]
fn sequencer_invariant_on_reachable_and_invalid_states() {
    for legs in sequencer_states() {
        let sequencer = sequencer(legs);
        assert!(sequencer.is_valid());
        for (phase, (state, off_for)) in Phase::ALL.into_iter().zip(legs) {
            assert_eq!(sequencer.pattern().leg(phase), state);
            assert_eq!(sequencer.off_for(phase), off_for);
        }
        for requested in patterns() {
            for elapsed in OFF_TIMES {
                let mut next = sequencer;
                next.step(requested, DriveTime(elapsed));
                assert!(next.is_valid(), "{legs:?} {requested:?} {elapsed}");
            }
        }
    }
    assert!(DeadTimeSequencer::new(DEAD_TIME).is_valid());
    // A conducting leg with an off-time is not a state any run reaches, on any leg.
    let off = (LegState::Off, DriveTime(0));
    for state in [LegState::High, LegState::Low] {
        for ticks in [1, DEAD_TIME.0, u32::MAX] {
            let bad = (state, DriveTime(ticks));
            for legs in [[bad, off, off], [off, bad, off], [off, off, bad]] {
                assert_eq!(DeadTimeSequencer::from_parts(legs, DEAD_TIME), None, "{legs:?}");
            }
        }
    }
}

/// A sample reading `sector`'s Hall code, `elapsed` timer ticks after the previous call.
fn sample(sector: Sector, elapsed: u32) -> DriveSample {
    DriveSample { hall: sector.hall_code(), elapsed: DriveTime(elapsed), ..DriveSample::default() }
}

/// A drive whose Hall filter has confirmed S0 with the rotor quiet (ready to engage).
fn settled_in_s0() -> Drive {
    let mut drive = Drive::new();
    drive.step(DriveSample { elapsed: REVERSAL_QUIET, ..sample(Sector::S0, 0) });
    drive.step(DriveSample { elapsed: REVERSAL_QUIET, ..sample(Sector::S0, 0) });
    drive
}

/// The engage rule: the bridge is energised only in a call where the whole table entry clears
/// the dead time, so a half-entry (one leg on, its partner still waiting) never reaches the
/// gates; the decision and the output come from the same call.
#[test]
fn engaging_puts_the_whole_table_entry_on_the_gates_in_the_same_call() {
    let pull =
        DriveCommand::Drive { direction: Direction::Pull, duty: Duty::from_raw_clamped(20_000) };
    // Settled in S0 (rotor quiet), drive S0 (A+ B−), then the rotor steps forward to S1.
    let mut drive = settled_in_s0();
    drive.set_command(pull);
    assert_eq!(
        drive.step(sample(Sector::S0, PERIOD)).pattern,
        six_step(Sector::S0, Direction::Pull)
    );
    drive.step(sample(Sector::S1, PERIOD));
    assert_eq!(
        drive.step(sample(Sector::S1, PERIOD)).pattern,
        six_step(Sector::S1, Direction::Pull)
    );
    // Coast: A and C (S1 = A+ C−) switch off now; B has been off for a while.
    drive.set_command(DriveCommand::Coast);
    assert_eq!(drive.step(sample(Sector::S1, PERIOD)), DriveOutput::OFF);
    // Pull again a moment later. The rotor last turned forward, so it is ready at once, but
    // the entry's legs have been off for less than the dead time: nothing may come on.
    drive.set_command(pull);
    let early = drive.step(sample(Sector::S1, DEAD_TIME.0 - 1));
    assert_eq!(early, DriveOutput::OFF, "a partial entry reached the gates");
    assert_eq!(drive.status().energized, None);
    // One tick later both legs have cleared the dead time: the whole entry, at once.
    let on = drive.step(sample(Sector::S1, 1));
    assert_eq!(on.pattern, six_step(Sector::S1, Direction::Pull));
    // The duty starts from zero at the slew rate (REQ-DRV-10: ≤ 5 % per PWM period, here
    // one timer tick's worth) and never above the command.
    assert!(on.duty <= Duty::from_raw_clamped(20_000), "{:?}", on.duty);
    assert_eq!(drive.status().energized, Some(Direction::Pull));
    assert_eq!(drive.pattern(), on.pattern, "the drive reports what is on the gates");
}

/// A half-ready entry: one leg has cleared the dead time, its partner has not. Whatever the
/// rotor, the drive emits all-off until the partner is ready, then the whole entry.
#[test]
fn an_entry_with_one_leg_still_in_dead_time_waits_whole() {
    let pull =
        DriveCommand::Drive { direction: Direction::Pull, duty: Duty::from_raw_clamped(9_000) };
    let mut drive = settled_in_s0();
    drive.set_command(pull);
    // S0 = A+ B−: on.
    assert_eq!(
        drive.step(sample(Sector::S0, PERIOD)).pattern,
        six_step(Sector::S0, Direction::Pull)
    );
    // Coast for a short moment: A, B off; C has been off since power-up.
    drive.set_command(DriveCommand::Coast);
    drive.step(sample(Sector::S0, PERIOD));
    // The rotor is pushed back one sector (string tension): S5 = C+ B−. C is ready, B is not.
    drive.set_command(pull);
    drive.step(sample(Sector::S5, 10));
    let partial = drive.step(sample(Sector::S5, 10));
    assert_eq!(partial, DriveOutput::OFF, "C+ alone, without B−, reached the gates");
    let mut out = partial;
    for _ in 0..REVERSAL_QUIET.0 / PERIOD + 2 {
        out = drive.step(sample(Sector::S5, PERIOD));
        if !out.pattern.is_all_off() {
            break;
        }
    }
    assert_eq!(out.pattern, six_step(Sector::S5, Direction::Pull));
}

/// The Hall filter's invariant: the confirmation count never exceeds `HALL_CONFIRM_READS`;
/// `from_parts` accepts exactly those states, keeps what it was given, and `update` keeps
/// the invariant from each of them.
#[test]
fn hall_filter_invariant_on_reachable_and_invalid_states() {
    let accepted_states = [
        HallState::Unknown,
        HallState::Sector(Sector::S3),
        HallState::Invalid(HallCode::from_raw(0b111)),
    ];
    for candidate in HallCode::ALL {
        for accepted in accepted_states {
            for seen in 0..=u8::MAX {
                let filter = HallFilter::from_parts(candidate, seen, accepted);
                let valid = seen <= taut_core::drive::hall::HALL_CONFIRM_READS;
                assert_eq!(filter.is_some(), valid, "{candidate:?} seen {seen}");
                let Some(filter) = filter else { continue };
                assert!(filter.is_valid());
                assert_eq!(filter.accepted(), accepted);
                for code in HallCode::ALL {
                    let mut next = filter;
                    next.update(code);
                    assert!(next.is_valid(), "{candidate:?} {seen} {accepted:?} then {code:?}");
                }
            }
        }
    }
    assert!(HallFilter::new().is_valid());
    assert_eq!(HallFilter::new().accepted(), HallState::Unknown);
}

/// A code is accepted on its `HALL_CONFIRM_READS`-th consecutive read — no sooner, and from a
/// filter part-way through confirming, exactly when the count reaches the bound.
#[test]
fn hall_filter_confirms_on_the_second_read_from_any_count() {
    let s2 = Sector::S2.hall_code();
    for seen in 0..=taut_core::drive::hall::HALL_CONFIRM_READS {
        let Some(mut filter) = HallFilter::from_parts(s2, seen, HallState::Unknown) else {
            panic!("valid parts refused")
        };
        let after = filter.update(s2);
        let expected = if seen >= 1 { HallState::Sector(Sector::S2) } else { HallState::Unknown };
        assert_eq!(after, expected, "seen {seen}");
    }
}

/// The compare value is `⌊period × duty⌋` for every duty of a 20 kHz period, so the high side
/// conducts exactly the duty asked for (to the timer's resolution) and never above 95 %.
#[test]
fn compare_ticks_is_the_duty_of_the_period() {
    let period = PERIOD_TICKS;
    for raw in 0..=u16::MAX {
        let duty = Duty::from_raw_clamped(raw);
        let expected = u32::from(period) * u32::from(duty.raw()) / 65_536;
        assert_eq!(u32::from(duty.compare_ticks(period)), expected, "raw {raw}");
    }
    assert_eq!(Duty::from_raw_clamped(32_768).compare_ticks(period), period / 2);
    assert_eq!(DUTY_MAX.compare_ticks(period), 8_074, "0.949 997 of 8 500, rounded down");
    assert_eq!(Duty::ZERO.compare_ticks(period), 0);
    assert_eq!(DUTY_MAX.compare_ticks(0), 0);
}

/// Zero is zero and nothing else is; every duty a constructor gives is valid, the cap
/// included.
#[test]
fn duty_zero_and_validity() {
    assert!(Duty::ZERO.is_zero());
    assert!(Duty::default().is_zero());
    for raw in 1..=u16::MAX {
        let duty = Duty::from_raw_clamped(raw);
        assert!(!duty.is_zero(), "raw {raw}");
        assert!(duty.is_valid(), "raw {raw}");
    }
    assert!(DUTY_MAX.is_valid());
    assert!(Duty::ZERO.is_valid());
}

/// `Gates::leg` reads back the two gate signals of the named leg, as `SwitchPattern::gates`
/// sets them — the shoot-through proofs check legs through it, so it must not hide one.
#[test]
fn gates_read_back_each_leg_of_every_pattern() {
    for pattern in patterns() {
        let gates = pattern.gates();
        for phase in Phase::ALL {
            let state = pattern.leg(phase);
            let expected = (state == LegState::High, state == LegState::Low);
            assert_eq!(gates.leg(phase), expected, "{pattern:?} {phase:?}");
        }
    }
}

/// `Sector::advanced(steps)` is `steps` sectors on, modulo 6, for every `u8` (the commutation
/// table's reverse direction is `advanced(3)`; callers may pass any count).
#[test]
fn sectors_advance_modulo_six_for_every_step_count() {
    for sector in Sector::ALL {
        for steps in 0..=u8::MAX {
            let expected = (u16::from(sector.index()) + u16::from(steps)) % 6;
            assert_eq!(u16::from(sector.advanced(steps).index()), expected, "{sector:?} + {steps}");
        }
    }
}

/// REQ-DRV-08: a change of direction straight from driving (no coast between) also goes
/// through all-off and re-engages only with the whole entry of the new direction: the rotor
/// stepping on to another sector meanwhile must not let a leg of the new entry that happens to
/// be ready (off since long) reach the gates alone.
#[test]
fn a_direct_reversal_goes_through_all_off_and_re_engages_whole() {
    let duty = Duty::from_raw_clamped(9_000);
    let mut drive = settled_in_s0();
    drive.set_command(DriveCommand::Drive { direction: Direction::Pull, duty });
    // S0 = A+ B−: on.
    assert_eq!(
        drive.step(sample(Sector::S0, PERIOD)).pattern,
        six_step(Sector::S0, Direction::Pull)
    );
    // Release at once: all off in the same call, and no longer energised.
    drive.set_command(DriveCommand::Drive { direction: Direction::Release, duty });
    assert_eq!(drive.step(sample(Sector::S0, PERIOD)), DriveOutput::OFF);
    assert_eq!(drive.status().energized, None);
    // The rotor steps back to S5, whose release entry is C− B+: C has been off since
    // power-up, B for a few ticks only. Nothing may come on until B has cleared the dead time.
    for _ in 0..2 {
        let early = drive.step(sample(Sector::S5, 1));
        assert_eq!(early, DriveOutput::OFF, "a partial release entry reached the gates");
        assert_eq!(drive.status().energized, None);
    }
    let on = drive.step(sample(Sector::S5, DEAD_TIME.0));
    assert_eq!(on.pattern, six_step(Sector::S5, Direction::Release));
    assert_eq!(drive.status().energized, Some(Direction::Release));
}

//! The machine's safety rules (`machine::safety`) pinned at their thresholds, under plain
//! `cargo test`.
//!
//! A fault threshold is a number with a side: "overload" is *above* the limit, "string break"
//! is *below* half the peak, a rail is *at or beyond* its code. The whole-machine model check
//! and the scenario tests drive tensions well past each threshold, so they cannot tell `<`
//! from `<=`; a threshold that no test pins can drift by one step without anything going red.
//! Each test here puts a sample exactly on a threshold and one resolution step either side
//! (2⁻¹⁶ kgf for tensions, one converter code, one tick, one millisecond) and states which
//! side faults. The precedence of the tension faults and the tension watch's invariant
//! (including deliberately invalid watches) are stated too.
//!
//! The tension rules decide on *tracked* tensions (each moves at most `TRACK_SLEW` a tick
//! toward its sample, so one spike cannot set the peak), so a threshold test starts from a
//! watch whose tracked values already sit where the test needs them ([`settled`]) and then
//! feeds samples within one slew of them: the first sample moves the tracked value onto it.
#![allow(
    clippy::arithmetic_side_effects,
    clippy::indexing_slicing,
    reason = "a test: bookkeeping on small constants; a panic fails the test, as it should"
)]

use taut_core::drive::{
    Direction, DriveCommand, DriveFault, DriveTime, Duty, TIME_UNITS_PER_SECOND,
};
use taut_core::io::{Inputs, LimitSwitches};
use taut_core::machine::FaultCode;
use taut_core::machine::safety::{
    BREAK_MIN_PEAK, EVIDENCE_BITS, EVIDENCE_MAJORITY, LOAD_CELL_BOTTOM_RAIL, LOAD_CELL_TOP_RAIL,
    LOADED_PERSIST, NO_STRING_TENSION, NO_STRING_TRAVEL_STEPS, OVERLOAD_ABSOLUTE, OVERLOAD_MARGIN,
    PEAK_RISE, REVERSED_PERSIST, REVERSED_TENSION, STALL_DUTY, STALL_QUIET, STALL_QUIET_MS,
    TRACK_LIMIT, TRACK_SLEW, TensionSample, TensionWatch, global_fault, load_cell_rail,
    overload_limit, stall,
};
use taut_core::units::{AdcCode, Kgf};

/// One resolution step of a tension (2⁻¹⁶ kgf).
const STEP: i32 = 1;

/// The samples of the window that must lie beyond a threshold: the break's and the
/// overload's persistence.
const MAJORITY: u32 = EVIDENCE_MAJORITY;

fn kgf_bits(kgf: Kgf, steps: i32) -> Kgf {
    Kgf::from_bits(kgf.to_bits() + steps)
}

/// A quiet sample: `tension` (corrected and raw), no travel, no limit, a 25 kgf pull.
fn sample(tension: Kgf) -> TensionSample {
    TensionSample {
        tension,
        raw: tension,
        steps: 0,
        limits: LimitSwitches::default(),
        peak_target: Kgf::from_int(25),
    }
}

/// A watch from a pull started at step 0 whose tracked tension and raw reading sit at
/// `tension` and whose peak is `peak` (at least the tension), counters clear, the string
/// counted as loaded.
fn settled(peak: Kgf, tension: Kgf) -> TensionWatch {
    let watch = TensionWatch::from_parts(0, [peak, tension, tension], [0, LOADED_PERSIST], [0; 3]);
    assert!(watch.is_valid(), "{watch:?}");
    watch
}

/// Runs `ticks` identical samples through `watch`; the last tick's verdict.
fn after(
    ticks: impl Into<u32>,
    watch: &mut TensionWatch,
    sample: &TensionSample,
) -> Option<FaultCode> {
    let mut verdict = None;
    for _ in 0..ticks.into() {
        verdict = watch.check(sample);
    }
    verdict
}

#[test]
fn overload_is_strictly_above_the_limit() {
    let limit = overload_limit(Kgf::from_int(25));
    assert_eq!(limit, Kgf::from_int(30));
    let at = sample(limit);
    assert_eq!(after(MAJORITY + 5, &mut settled(limit, limit), &at), None);
    let above = sample(kgf_bits(limit, STEP));
    assert_eq!(after(MAJORITY - 1, &mut settled(limit, limit), &above), None);
    assert_eq!(after(MAJORITY, &mut settled(limit, limit), &above), Some(FaultCode::Overload));
}

#[test]
fn overload_limit_is_the_margin_above_the_peak_target_capped_at_the_absolute_limit() {
    for target_tenths in [0, 50, 250, 479, 480, 481, 500, 550, 1_000] {
        let target = Kgf::from_tenths(target_tenths);
        let relative = target.saturating_add(OVERLOAD_MARGIN);
        let expected = relative.min(OVERLOAD_ABSOLUTE);
        assert_eq!(overload_limit(target), expected, "target {target_tenths} tenths");
    }
    assert_eq!(
        overload_limit(kgf_bits(Kgf::from_int(48), -STEP)),
        kgf_bits(OVERLOAD_ABSOLUTE, -STEP)
    );
    assert_eq!(overload_limit(Kgf::MAX), OVERLOAD_ABSOLUTE, "saturates, then caps");
}

#[test]
fn an_interrupted_overload_needs_the_majority_of_the_window() {
    // Samples above the limit with one at it between: the overload latches once eight of the
    // last fifteen were above — the one at the limit delays it by a tick, it does not
    // restart the count.
    let over = sample(Kgf::from_int(31));
    let mut watch = settled(Kgf::from_int(31), Kgf::from_int(31));
    assert_eq!(after(MAJORITY - 1, &mut watch, &over), None);
    assert_eq!(watch.check(&sample(Kgf::from_int(30))), None);
    assert_eq!(watch.check(&over), Some(FaultCode::Overload));
    // Seven above, eight at the limit, then one above: the first seven have left the window.
    let mut watch = settled(Kgf::from_int(31), Kgf::from_int(31));
    assert_eq!(after(MAJORITY - 1, &mut watch, &over), None);
    assert_eq!(after(MAJORITY, &mut watch, &sample(Kgf::from_int(30))), None);
    assert_eq!(watch.check(&over), None);
    assert_eq!(after(MAJORITY - 2, &mut watch, &over), None);
    assert_eq!(watch.check(&over), Some(FaultCode::Overload));
}

#[test]
fn a_single_spike_moves_the_tracked_tension_by_one_slew_only() {
    // A +25 kgf spike on a 20 kgf hold: the tracked tension rises by TRACK_SLEW, never to
    // the spike, and the peak not at all (one sample is no majority).
    let mut watch = settled(Kgf::from_int(20), Kgf::from_int(20));
    assert_eq!(watch.check(&sample(Kgf::from_int(45))), None);
    assert_eq!(watch.tension, Kgf::from_int(20).saturating_add(TRACK_SLEW));
    assert_eq!(watch.peak, Kgf::from_int(20));
    // A sample within one slew is taken exactly.
    assert_eq!(watch.check(&sample(Kgf::from_tenths(205))), None);
    assert_eq!(watch.tension, Kgf::from_tenths(205));
    // A drop to zero (a spike down) moves it by one slew too: no break from one sample.
    assert_eq!(watch.check(&sample(Kgf::ZERO)), None);
    assert_eq!(watch.tension, Kgf::from_tenths(195));
}

#[test]
fn tracked_values_stay_within_the_track_limit() {
    let mut watch = settled(TRACK_LIMIT, TRACK_LIMIT);
    watch.check(&sample(Kgf::MAX));
    assert_eq!((watch.tension, watch.raw), (TRACK_LIMIT, TRACK_LIMIT));
    let low = Kgf::ZERO.saturating_sub(TRACK_LIMIT);
    let mut watch = TensionWatch::from_parts(0, [Kgf::ZERO, low, low], [0; 2], [0; 3]);
    watch.check(&sample(Kgf::MIN));
    assert_eq!((watch.tension, watch.raw), (low, low));
    assert!(watch.is_valid());
}

#[test]
fn string_break_is_strictly_below_half_the_peak() {
    let peak = Kgf::from_int(20);
    let half = Kgf::from_int(10);
    assert_eq!(after(MAJORITY + 5, &mut settled(peak, half), &sample(half)), None);
    let below = sample(kgf_bits(half, -STEP));
    assert_eq!(after(MAJORITY - 1, &mut settled(peak, half), &below), None);
    assert_eq!(after(MAJORITY, &mut settled(peak, half), &below), Some(FaultCode::StringBreak));
}

#[test]
fn a_sample_exactly_at_half_the_peak_is_no_evidence_of_a_break() {
    // The tracked tension already below half the peak and seven of the window's samples
    // below it: an eighth sample exactly at half is not the eighth witness, one step below is.
    let peak = Kgf::from_int(20);
    let half = Kgf::from_int(10);
    let low = Kgf::from_int(7);
    let seven = 0b111_1111;
    let watch =
        || TensionWatch::from_parts(0, [peak, low, low], [0, LOADED_PERSIST], [0, seven, 0]);
    assert_eq!(watch().check(&sample(half)), None);
    assert_eq!(watch().check(&sample(kgf_bits(half, -STEP))), Some(FaultCode::StringBreak));
}

#[test]
fn a_collapse_from_the_peak_is_a_break_once_tracked_below_half_and_the_window_agrees() {
    // From a 20 kgf hold the tracked tension falls 1 kgf a tick: below 10 kgf at the 11th
    // tick, the window's majority below since the 8th — the break latches at tick 11
    // (REQ-SAFE-09: max(⌊P/2⌋ + 1, 8) ms).
    let mut watch = settled(Kgf::from_int(20), Kgf::from_int(20));
    let gone = sample(Kgf::ZERO);
    assert_eq!(after(10_u32, &mut watch, &gone), None);
    assert_eq!(watch.check(&gone), Some(FaultCode::StringBreak));
    // From 10 kgf the tracked tension is below 5 at the 6th tick; the window decides, at
    // the 8th.
    let mut watch = settled(Kgf::from_int(10), Kgf::from_int(10));
    assert_eq!(after(MAJORITY - 1, &mut watch, &gone), None);
    assert_eq!(watch.check(&gone), Some(FaultCode::StringBreak));
}

#[test]
fn string_break_needs_the_peak_to_have_reached_the_minimum() {
    // Peak exactly at BREAK_MIN_PEAK: a collapse is a break.
    let mut watch = settled(BREAK_MIN_PEAK, Kgf::ZERO);
    assert_eq!(after(MAJORITY, &mut watch, &sample(Kgf::ZERO)), Some(FaultCode::StringBreak));
    // One step below it: slack being taken up, never a break.
    let mut watch = settled(kgf_bits(BREAK_MIN_PEAK, -STEP), Kgf::ZERO);
    assert_eq!(after(MAJORITY + 5, &mut watch, &sample(Kgf::ZERO)), None);
}

#[test]
fn the_peak_is_the_highest_tracked_tension_reached_at_the_peak_rise() {
    let mut watch = settled(Kgf::ZERO, Kgf::ZERO);
    // 8 kgf from rest: tracked 1, 2, 3 … kgf; the peak waits until eight samples have been
    // above it, then rises PEAK_RISE a tick behind the tracked tension.
    after(MAJORITY - 1, &mut watch, &sample(Kgf::from_int(8)));
    assert_eq!(watch.tension, Kgf::from_int(7));
    assert_eq!(watch.peak, Kgf::ZERO);
    after(3_u32, &mut watch, &sample(Kgf::from_int(8)));
    assert_eq!(watch.tension, Kgf::from_int(8));
    assert_eq!(watch.peak, Kgf::from_bits(PEAK_RISE.to_bits() * 3));
    // A tracked tension within one rise of the peak is taken exactly, once the window's
    // majority lies above the peak.
    let mut close = settled(Kgf::from_int(8), Kgf::from_int(8));
    let higher = sample(kgf_bits(Kgf::from_int(8), PEAK_RISE.to_bits()));
    after(MAJORITY - 1, &mut close, &higher);
    assert_eq!(close.peak, Kgf::from_int(8));
    close.check(&higher);
    assert_eq!(close.peak, kgf_bits(Kgf::from_int(8), PEAK_RISE.to_bits()));
    after(60_u32, &mut watch, &sample(Kgf::from_int(8)));
    assert_eq!(watch.peak, Kgf::from_int(8));
    for tenths in [30, 79, 0] {
        watch.check(&sample(Kgf::from_tenths(tenths)));
    }
    assert_eq!(watch.peak, Kgf::from_int(8), "a falling tension leaves the peak");
    // Negative readings never lower it below zero (it starts at zero).
    let mut watch = TensionWatch::new(0);
    watch.check(&sample(Kgf::from_int(-2)));
    assert_eq!(watch.peak, Kgf::ZERO);
}

#[test]
fn reversed_load_cell_is_strictly_below_the_reversed_tension() {
    let at = TensionSample { raw: REVERSED_TENSION, ..sample(Kgf::ZERO) };
    assert_eq!(after(REVERSED_PERSIST + 5, &mut TensionWatch::new(0), &at), None);
    let below = TensionSample { raw: kgf_bits(REVERSED_TENSION, -STEP), ..sample(Kgf::ZERO) };
    assert_eq!(after(REVERSED_PERSIST - 1, &mut TensionWatch::new(0), &below), None);
    assert_eq!(
        after(REVERSED_PERSIST, &mut TensionWatch::new(0), &below),
        Some(FaultCode::LoadCellReversed)
    );
    // The sign check reads the uncorrected reading, not the corrected tension.
    let corrected_only = TensionSample { tension: Kgf::from_int(-1), ..sample(Kgf::ZERO) };
    assert_eq!(after(REVERSED_PERSIST + 5, &mut TensionWatch::new(0), &corrected_only), None);
}

#[test]
fn no_string_is_beyond_the_travel_without_a_loaded_string() {
    // `ticks` samples at `tension` at the start, then one at `travel` steps further.
    let at_travel = |tension: Kgf, ticks: u8, travel: i32| {
        let mut watch =
            TensionWatch::from_parts(0, [tension.max(Kgf::ZERO), tension, tension], [0; 2], [0; 3]);
        after(ticks, &mut watch, &sample(tension));
        watch.check(&TensionSample { steps: travel, ..sample(tension) })
    };
    let below = kgf_bits(NO_STRING_TENSION, -STEP);
    assert_eq!(at_travel(below, 50, NO_STRING_TRAVEL_STEPS), None);
    assert_eq!(at_travel(below, 50, NO_STRING_TRAVEL_STEPS + 1), Some(FaultCode::NoString));
    // Loaded: at the tension for LOADED_PERSIST ticks (the travel check's own tick counts).
    assert_eq!(at_travel(NO_STRING_TENSION, LOADED_PERSIST - 1, 100_000), None);
    assert_eq!(
        at_travel(NO_STRING_TENSION, LOADED_PERSIST - 2, NO_STRING_TRAVEL_STEPS + 1),
        Some(FaultCode::NoString)
    );
    // Travel is counted from the pull's start, in the pulling direction only.
    assert_eq!(at_travel(Kgf::ZERO, 1, -(NO_STRING_TRAVEL_STEPS + 1)), None);
    // Once loaded, a later slack string is not "no string" (a break is the break rule's).
    let mut watch = settled(NO_STRING_TENSION, NO_STRING_TENSION);
    let slack = TensionSample { steps: NO_STRING_TRAVEL_STEPS + 1, ..sample(Kgf::ZERO) };
    assert_eq!(after(3_u32, &mut watch, &slack), None);
}

#[test]
fn travel_is_measured_from_the_start_and_wraps_with_the_step_counter() {
    let watch = TensionWatch::new(1_000);
    assert_eq!(watch.travel(1_000), 0);
    assert_eq!(watch.travel(3_835), NO_STRING_TRAVEL_STEPS);
    assert_eq!(watch.travel(-1_000), -2_000);
    let near_wrap = TensionWatch::new(i32::MAX - 10);
    assert_eq!(near_wrap.travel(i32::MIN + 10), 21, "the Hall step counter wraps");
}

#[test]
fn end_of_travel_needs_the_end_switch_alone() {
    let end = TensionSample {
        limits: LimitSwitches { home: false, end: true },
        ..sample(Kgf::from_int(3))
    };
    assert_eq!(TensionWatch::new(0).check(&end), Some(FaultCode::EndOfTravel));
    // Both switches at once is a wiring fault, reported by the global rule, not here.
    let both = TensionSample { limits: LimitSwitches { home: true, end: true }, ..end };
    assert_eq!(TensionWatch::new(0).check(&both), None);
    let home = TensionSample { limits: LimitSwitches { home: true, end: false }, ..end };
    assert_eq!(TensionWatch::new(0).check(&home), None);
}

/// End of travel, then overload, string break, reversed load cell, no string.
#[test]
fn tension_faults_in_order_of_precedence() {
    let end = LimitSwitches { home: false, end: true };
    let over = sample(Kgf::from_int(45));
    // Overload and end of travel together: end of travel.
    let mut watch = settled(Kgf::from_int(45), Kgf::from_int(45));
    after(MAJORITY - 1, &mut watch, &over);
    assert_eq!(watch.check(&TensionSample { limits: end, ..over }), Some(FaultCode::EndOfTravel));
    // Overload and a reversed reading together (a corrected overload, a negative raw): overload.
    let mut watch = TensionWatch::from_parts(
        0,
        [Kgf::from_int(45), Kgf::from_int(45), Kgf::from_int(-1)],
        [0, LOADED_PERSIST],
        [0; 3],
    );
    let both = TensionSample { raw: Kgf::from_int(-1), ..over };
    assert_eq!(after(REVERSED_PERSIST, &mut watch, &both), Some(FaultCode::Overload));
    // A break with a negative raw reading: the break first.
    let mut watch = TensionWatch::from_parts(
        0,
        [Kgf::from_int(20), Kgf::ZERO, Kgf::from_int(-1)],
        [0, LOADED_PERSIST],
        [0; 3],
    );
    let collapsed = TensionSample { raw: Kgf::from_int(-1), ..sample(Kgf::ZERO) };
    assert_eq!(after(REVERSED_PERSIST, &mut watch, &collapsed), Some(FaultCode::StringBreak));
    // Reversed and no string together: no string at once, reversed once it persists.
    let far = TensionSample { steps: NO_STRING_TRAVEL_STEPS + 1, ..collapsed };
    assert_eq!(TensionWatch::new(0).check(&far), Some(FaultCode::NoString));
    let mut watch = TensionWatch::new(0);
    assert_eq!(after(REVERSED_PERSIST, &mut watch, &far), Some(FaultCode::LoadCellReversed));
}

/// The watch's invariant: tracked values within ±60 kgf, the peak within 0–60 kgf and at
/// least the tracked tension, counters at most their persistence, histories within the
/// window; exactly at each bound is valid, one step beyond is not.
#[test]
fn tension_watch_invariant_at_its_bounds() {
    let sixty = TRACK_LIMIT;
    let minus_sixty = Kgf::ZERO.saturating_sub(TRACK_LIMIT);
    let valid = |tracked: [Kgf; 3], counters: [u8; 2], evidence: [u16; 3]| {
        TensionWatch::from_parts(7, tracked, counters, evidence).is_valid()
    };
    let zero = [Kgf::ZERO; 3];
    let none = [0; 3];
    assert!(valid(zero, [0; 2], none));
    assert!(valid([sixty, sixty, sixty], [REVERSED_PERSIST, LOADED_PERSIST], [EVIDENCE_BITS; 3]));
    assert!(valid([Kgf::ZERO, minus_sixty, minus_sixty], [0; 2], none));
    assert!(!valid(
        [kgf_bits(Kgf::ZERO, -STEP), Kgf::MIN.max(minus_sixty), Kgf::ZERO],
        [0; 2],
        none
    ));
    assert!(!valid([kgf_bits(sixty, STEP), Kgf::ZERO, Kgf::ZERO], [0; 2], none));
    assert!(!valid([Kgf::ZERO, kgf_bits(minus_sixty, -STEP), Kgf::ZERO], [0; 2], none));
    assert!(!valid([Kgf::ZERO, Kgf::ZERO, kgf_bits(minus_sixty, -STEP)], [0; 2], none));
    assert!(!valid([sixty, sixty, kgf_bits(sixty, STEP)], [0; 2], none));
    assert!(
        valid([Kgf::from_int(5), kgf_bits(Kgf::from_int(5), STEP), Kgf::ZERO], [0; 2], none),
        "a peak lagging a rising tension"
    );
    assert!(!valid(zero, [REVERSED_PERSIST + 1, 0], none));
    assert!(!valid(zero, [0, LOADED_PERSIST + 1], none));
    for history in 0..3 {
        let mut beyond = none;
        beyond[history] = EVIDENCE_BITS + 1;
        assert!(!valid(zero, [0; 2], beyond), "history {history}");
    }
    assert!(TensionWatch::new(-5).is_valid());
    assert_eq!(TensionWatch::new(-5), TensionWatch::from_parts(-5, zero, [0; 2], none));
    // A watch whose window already holds seven samples above the limit latches on the next.
    let thirty_one = Kgf::from_int(31);
    let mut watch =
        TensionWatch::from_parts(0, [thirty_one; 3], [0, LOADED_PERSIST], [0, 0, 0b111_1111]);
    assert_eq!(watch.check(&sample(thirty_one)), Some(FaultCode::Overload));
    let mut watch =
        TensionWatch::from_parts(0, [thirty_one; 3], [0, LOADED_PERSIST], [0, 0, 0b11_1111]);
    assert_eq!(watch.check(&sample(thirty_one)), None);
}

#[test]
fn load_cell_rails_are_at_or_beyond_their_codes() {
    let code = |raw: u16| load_cell_rail(AdcCode::new(raw));
    assert_eq!(code(0), Some(FaultCode::LoadCellOpen));
    assert_eq!(code(LOAD_CELL_BOTTOM_RAIL.get()), Some(FaultCode::LoadCellOpen));
    assert_eq!(code(LOAD_CELL_BOTTOM_RAIL.get() + 1), None);
    assert_eq!(code(LOAD_CELL_TOP_RAIL.get() - 1), None);
    assert_eq!(code(LOAD_CELL_TOP_RAIL.get()), Some(FaultCode::LoadCellShort));
    assert_eq!(code(4_095), Some(FaultCode::LoadCellShort));
}

#[test]
fn every_latched_drive_fault_is_a_global_fault_with_its_own_code() {
    // The tick's mean current is not a machine rule: the drive compares every PWM period's
    // sample and latches (REQ-DRV-05); the machine reports the drive's latch.
    let full_current = Inputs { motor_current: AdcCode::MAX, ..Inputs::default() };
    assert_eq!(global_fault(&full_current), None);
    for (fault, code) in [
        (DriveFault::Overcurrent, FaultCode::Overcurrent),
        (DriveFault::OvercurrentTrip, FaultCode::OvercurrentTrip),
        (DriveFault::BusOvervoltage, FaultCode::BusOvervoltage),
        (DriveFault::CurrentSenseZero, FaultCode::CurrentSenseZero),
        (DriveFault::HallInvalid, FaultCode::HallInvalid),
        (DriveFault::SectorSkipped, FaultCode::HallSequence),
    ] {
        let mut inputs = full_current;
        inputs.drive.fault = Some(fault);
        assert_eq!(global_fault(&inputs), Some(code), "{fault:?}");
        assert_eq!(FaultCode::from_drive(fault), code);
        inputs.limits = LimitSwitches { home: true, end: true };
        assert_eq!(global_fault(&inputs), Some(FaultCode::LimitsBoth));
    }
    // One switch alone is not a global fault.
    for limits in
        [LimitSwitches { home: true, end: false }, LimitSwitches { home: false, end: true }]
    {
        assert_eq!(global_fault(&Inputs { limits, ..Inputs::default() }), None);
    }
}

#[test]
fn stall_needs_the_duty_the_time_and_the_quiet_each_at_their_threshold() {
    let command = |duty: Duty| DriveCommand::Drive { direction: Direction::Pull, duty };
    let quiet = |ticks: u32| {
        let mut inputs = Inputs::default();
        inputs.drive.quiet_for = DriveTime(ticks);
        inputs
    };
    let duty = STALL_DUTY;
    let below_duty = Duty::from_raw_clamped(STALL_DUTY.raw() - 1);
    let q = STALL_QUIET.0;
    assert!(stall(command(duty), &quiet(q), STALL_QUIET_MS));
    assert!(!stall(command(below_duty), &quiet(q), STALL_QUIET_MS));
    assert!(!stall(command(duty), &quiet(q - 1), STALL_QUIET_MS));
    assert!(!stall(command(duty), &quiet(q), STALL_QUIET_MS - 1));
    assert!(!stall(DriveCommand::Coast, &quiet(u32::MAX), u32::MAX));
    // The quiet time is the same 500 ms as the command time, in 170 MHz timer ticks.
    assert_eq!(STALL_QUIET_MS, 500);
    assert_eq!(STALL_QUIET, DriveTime(500 * (TIME_UNITS_PER_SECOND / 1_000)));
    assert!(stall(command(Duty::from_raw_clamped(u16::MAX)), &quiet(u32::MAX), u32::MAX));
}

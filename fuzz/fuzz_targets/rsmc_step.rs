//! The tension controller's step and its law (REQ-TEN-01/02/03/05/09/10): from any valid
//! state and any measurement, no panic, duty within DUTY_MAX, always pulling within a pull,
//! invariant kept — part by part and composed, several steps in a row — and the fixed-point
//! law within its stated bound of the f64 reference over the fuzzed input sequence.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use taut_proofs::tension::{
    EstimatorCase, LawCase, SlipCase, StepCase, controller_step_bounded, estimator_step_bounded,
    force_to_duty_bounded, reciprocal_accurate, rsmc_step_bounded, slip_damper_bounded,
};
use taut_proofs::tension_reference::{TrackStep, law_tracks_reference};

#[derive(Arbitrary, Debug)]
struct Input {
    steps: Vec<StepCase>,
    laws: Vec<LawCase>,
    estimators: Vec<EstimatorCase>,
    slips: Vec<SlipCase>,
    maps: Vec<(bool, i32, i32, i32)>,
    reciprocals: Vec<i32>,
    track_paper: bool,
    track_fast: bool,
    track_scale: i32,
    track: Vec<TrackStep>,
}

fuzz_target!(|input: Input| {
    for case in input.steps.iter().take(64) {
        controller_step_bounded(case);
    }
    for case in input.laws.iter().take(64) {
        rsmc_step_bounded(case);
    }
    for case in input.estimators.iter().take(64) {
        estimator_step_bounded(case);
    }
    for case in input.slips.iter().take(64) {
        slip_damper_bounded(case);
    }
    for &(current_map, force, speed, bus) in input.maps.iter().take(64) {
        force_to_duty_bounded(current_map, force, speed, bus);
    }
    for &x in input.reciprocals.iter().take(64) {
        reciprocal_accurate(x);
    }
    let scale = input.track_scale.rem_euclid(10 << 16).max(1 << 13);
    let len = input.track.len().min(2_000);
    law_tracks_reference(input.track_paper, input.track_fast, scale, &input.track[..len]);
});

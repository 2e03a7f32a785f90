//! Tension-controller properties (`REQ-TEN-*`): the step is bounded and keeps its invariant;
//! the fixed-point law tracks its `f64` reference.
//!
//! [`rsmc_step_bounded`] is the one body behind the Kani harness
//! `verify_rsmc_step_bounded`, the `cargo test` mirror in `proofs/tests/tension.rs` and the
//! `rsmc_step` fuzz target: from **any** internal state that satisfies
//! `TensionController::is_valid` (law state, Hall speed filter, profile state, every phase)
//! and **any** measurement, one step never panics or overflows (the core is compiled with
//! overflow checks in tests and Kani checks every arithmetic operation), emits a duty within
//! `DUTY_MAX`, and leaves a valid state. The state is built from primitive values through
//! the controller's own setters (`set_state`, `set_profile_state`), and the invariant is
//! assumed, not constructed — an over-approximation of the reachable states.

use taut_core::drive::{DUTY_MAX, DriveStatus};
use taut_core::io::LimitSwitches;
use taut_core::tension::controller::{ProfileState, TensionController};
use taut_core::tension::law::{RsmcState, Saturation};
use taut_core::tension::{ControllerConfig, Measurement, MmPerSecond, PullPhase};
use taut_core::units::{Amps, Kgf, Q16};

/// Everything one step depends on, as primitives.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
#[cfg_attr(kani, derive(kani::Arbitrary))]
pub struct StepCase {
    /// Use the paper's RSMC configuration instead of taut's.
    pub paper: bool,
    /// Law: previous error, error rate, integral (bits).
    pub e_prev: i32,
    /// Law: error rate (bits).
    pub e_rate: i32,
    /// Law: integral (bits).
    pub z: i32,
    /// Law: adaptive gain, Q31.32.
    pub phi_hat: i64,
    /// Speed filter: last step count.
    pub last_steps: i32,
    /// Speed filter: speed (bits).
    pub speed: i32,
    /// Speed filter primed.
    pub primed: bool,
    /// Profile: phase selector (mod 7).
    pub phase: u8,
    /// Profile: peak, final, goal (bits).
    pub peak: i32,
    /// Profile: final target (bits).
    pub final_target: i32,
    /// Profile: goal (bits).
    pub goal: i32,
    /// Profile: speed limit (bits).
    pub speed_limit: i32,
    /// Profile: reference (Q31.32).
    pub reference: i64,
    /// Profile: ticks in phase.
    pub ticks: u32,
    /// Profile: last tension (bits).
    pub last_tension: i32,
    /// Profile: filtered rate (bits).
    pub rate: i32,
    /// Profile: at tension.
    pub at_tension: bool,
    /// Profile: saturation selector (mod 3).
    pub saturated: u8,
    /// Profile: coasting.
    pub coasting: bool,
    /// Profile: median window.
    pub window: [i32; 5],
    /// Measurement: tension (bits).
    pub tension: i32,
    /// Measurement: Hall steps.
    pub steps: i32,
    /// Measurement: current (bits).
    pub current: i32,
    /// Measurement: home switch.
    pub home: bool,
    /// Measurement: end switch.
    pub end: bool,
}

const PHASES: [PullPhase; 7] = [
    PullPhase::Idle,
    PullPhase::TakeUp,
    PullPhase::Approach,
    PullPhase::PreStretch,
    PullPhase::Settle,
    PullPhase::Hold,
    PullPhase::Release,
];

/// The controller in the case's state (its invariant not yet checked).
#[must_use]
pub fn controller_in(case: &StepCase) -> TensionController {
    let config = if case.paper { ControllerConfig::PAPER_RSMC } else { ControllerConfig::TAUT };
    let Ok(mut controller) = TensionController::new(&config) else {
        panic!("REQ-TEN-06: a built-in configuration was rejected");
    };
    if let Some(rsmc) = controller.rsmc_mut() {
        rsmc.set_state(RsmcState {
            e_prev: case.e_prev,
            e_rate: case.e_rate,
            z: case.z,
            phi_hat: case.phi_hat,
        });
    }
    controller.speed_estimator_mut().set_state(
        case.last_steps,
        MmPerSecond(Q16::from_bits(case.speed)),
        case.primed,
    );
    let phase = PHASES.into_iter().nth(usize::from(case.phase % 7)).unwrap_or_default();
    let saturated = match case.saturated % 3 {
        0 => Saturation::None,
        1 => Saturation::High,
        _ => Saturation::Low,
    };
    controller.set_profile_state(ProfileState {
        phase,
        peak: Kgf::from_bits(case.peak),
        final_target: Kgf::from_bits(case.final_target),
        speed_limit: MmPerSecond(Q16::from_bits(case.speed_limit)),
        reference: case.reference,
        goal: Kgf::from_bits(case.goal),
        ticks: case.ticks,
        last_tension: case.last_tension,
        rate: case.rate,
        at_tension: case.at_tension,
        saturated,
        coasting: case.coasting,
        window: case.window,
    });
    controller
}

/// REQ-TEN-01/02/03: for a valid state, one step is panic-free, its duty is within
/// `DUTY_MAX`, and the state stays valid. Returns whether the case was in the domain
/// (the state was valid).
pub fn rsmc_step_bounded(case: &StepCase) -> bool {
    let mut controller = controller_in(case);
    if !controller.is_valid() {
        return false;
    }
    let measurement = Measurement {
        tension: Kgf::from_bits(case.tension),
        drive: DriveStatus { steps: case.steps, ..DriveStatus::default() },
        current: Amps::from_bits(case.current),
        limits: LimitSwitches { home: case.home, end: case.end },
    };
    let out = controller.step(&measurement);
    let duty = out.command.duty();
    assert!(duty <= DUTY_MAX && duty.is_valid(), "REQ-TEN-02: duty {duty:?} above DUTY_MAX");
    assert!(controller.is_valid(), "REQ-TEN-03: the step broke the invariant: {case:?}");
    true
}

#[cfg(kani)]
mod verification {
    use super::*;

    /// REQ-TEN-01/02/03 for every valid state and every measurement, one step, taut's and
    /// the paper's configuration. The median window and the step count are symbolic too.
    #[kani::proof]
    #[kani::unwind(6)]
    fn verify_rsmc_step_bounded() {
        let case: StepCase = kani::any();
        let controller = controller_in(&case);
        kani::assume(controller.is_valid());
        assert!(rsmc_step_bounded(&case));
    }
}

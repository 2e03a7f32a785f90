//! Tension control: the control laws (the paper's RSMC, taut's
//! RSMC, the PD baseline), the force → duty mapping and the pull profile.
//!
//! # Theory of operation
//!
//! The machine pulls a string to a set tension and holds it there while the string creeps.
//! The plant is a BLDC motor driven by PWM duty through a 1:20 gearbox and a 25.4 mm lead
//! screw: with voltage (duty) drive the back-EMF makes the motor behave much like a
//! velocity source, the rotor's inertia reflected to the carriage is hundreds of kilograms,
//! and a stiff string gains ≈ 100 kgf/s at full speed — so precision is a question of
//! stopping in time and of holding against creep, friction and sensor noise. The bridge's
//! switched leg is complementary, so the drive brakes as well as it pulls: the controller
//! brakes the carriage into the target rather than letting it coast.
//!
//! The pieces, from the operator inward:
//!
//! - [`crate::settings`] (not here: the panel and the record share it): the validated
//!   [`crate::settings::PullSettings`] each pull starts from.
//! - [`controller`]: [`TensionController`] — `start`, `step` at 1 kHz, `release`, `stop` —
//!   the profile, the law, the estimator, the slip damper and the duty map put together.
//! - [`profile`]: the pull's phases and the reference they generate (take-up at the set
//!   speed, braking approach timed and shaped from the identified string stiffness,
//!   pre-stretch, settle, hold), from coefficients derived once.
//! - [`estimator`]: [`TensionEstimator`] — median of five, spike clip, Hall-fused tension
//!   observer, tension rate and carriage speed.
//! - [`slip`]: the hold's slip damper, which sees the carriage's stick-slip in the motor
//!   current.
//! - [`law`]: the paper's RSMC (eqs. 9–17, "as published"), taut's RSMC with each
//!   improvement switchable, and the PD baseline; each maps a tension error to a force.
//! - [`motor`]: force → duty (a voltage command, or a current command with back-EMF
//!   compensation; both always pulling — a negative force brakes — within a current limit)
//!   and the carriage speed from Hall steps.
//!
//! Everything is fixed point ([`crate::fixed`]: Q15.16 signals, 64-bit products and sums, no
//! division in the step), allocation-free and panic-free; gains are validated once at
//! construction. The requirements are `REQ-TEN-*` in `docs/SPEC.md`.

pub mod controller;
pub mod estimator;
pub mod law;
pub mod motor;
pub mod profile;
pub mod slip;

pub use controller::{
    ConfigError, ControlOutput, ControllerConfig, LawConfig, Measurement, TensionController,
};
pub use estimator::{Estimate, EstimatorConfig, TensionEstimator};
pub use law::{Improvements, NominalPlant, PdGains, Reference, RsmcGains};
pub use motor::{DutyMap, MotorModel};
pub use profile::{ProfileConfig, ProfileError, PullPhase};

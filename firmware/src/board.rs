//! This firmware's board: an STM32G431 (NUCLEO-G431RB) on the X-NUCLEO-IHM08M1 power stage,
//! with the paper's current sense and load-cell amplifier, as one validated
//! [`BoardConfig`] — everything core's rules need to know about the electronics.
//!
//! # Theory of operation
//!
//! - **Drive**: the paper's current scale (the IHM08M1's single-shunt amplifier, converted mid
//!   on-time, read from 0 A at 6.1 mA a code — the paper's 0.2 V/A on 5 V) and the paper's
//!   motor limits; the
//!   IHM08M1's bus divider (gain 0.0522) on the G4's 3.3 V converter, full scale
//!   3.3 V / 0.0522 = 63.2 V, with the paper's bus limits (lockout 18 V, no regeneration above
//!   38 V, fault at 40 V); the 12 A trip; the timer's dead time ([`crate::timing::DEAD_TIME`],
//!   the same value its dead-time generator is programmed with). These are the paper's
//!   board's parts (the twin's), which `the_drive_is_the_papers_but_for_the_bus_divider`
//!   checks value by value.
//! - **Motor**: the paper's 57 mm 24 V brushless motor through its 1:20 gearbox ([`MOTOR`]),
//!   whose constants taut's controller is built with ([`ControllerConfig::taut`]); its current
//!   limit is the drive's ([`CURRENT_LIMIT`]), which the board's constructor gives the
//!   controller.
//! - **PWM period**: [`crate::timing::PWM_PERIOD_TICKS`] of the 170 MHz timer, 50 µs; the
//!   controller's dead-time duty is derived from it and the dead time by the board's
//!   constructor, not written down.
//! - **Load cell**: the paper's amplifier (0–5 V, 92 mV/kgf, 50 mV at no load) through the
//!   17.4 kΩ / 33.2 kΩ divider into the 3.3 V converter (PB15): at the pin the chain is
//!   92 mV/kgf × 0.656 and its zero 50 mV × 0.656. The scale is the nominal one; the
//!   self-test tares the zero and the calibration corrects the rest.
//!
//! `the_board_is_valid` builds it on the host, so the image never meets a refused board.

use taut_core::board::{BoardConfig, BoardError};
use taut_core::drive::limit::{CurrentLimit, CurrentReading, CurrentSense};
use taut_core::drive::{BusSense, DriveConfig, DriveTime};
use taut_core::sense::load_cell::LoadCellScale;
use taut_core::tension::controller::ControllerConfig;
use taut_core::tension::motor::MotorModel;
use taut_core::units::{AdcCode, AdcReference, Q16, Volts};

use crate::timing::{DEAD_TIME, PWM_PERIOD_TICKS, TICKS_PER_DRIVE_TIME};

/// The converter's reference: the G431's VREF+ tied to its 3.3 V supply.
pub const ADC_REFERENCE_MV: u16 = 3_300;

/// The load cell's divider: 33.2 kΩ / (17.4 kΩ + 33.2 kΩ), as a Q16 fraction (0.656 126).
pub const LOAD_CELL_DIVIDER: Q16 = Q16::lit("0.656126");

/// The current chain: the winding current (one DC-link shunt converted mid on-time), read
/// from 0 A at 6.1 mA a code (the paper's 0.2 V/A on 5 V: 5 V / 4 096 / 0.2 V/A); its zero
/// may sit 0.5 A (82 codes) off the design's before the sense counts as faulty.
pub const CURRENT_SENSE: CurrentSense = CurrentSense {
    reading: CurrentReading::Winding,
    design_zero: AdcCode::new(0),
    na_per_code: 6_103_516,
    zero_tolerance: 82,
};

/// The paper's motor with taut's limits: 8 A kept (two thirds of the trip), the pair's least
/// resistance 0.7 Ω (the nameplate's 0.846 Ω less 17 %), `Ke·(2π/24)·10⁷` = 1.5735 × 10⁸ mV per
/// step time, the per-period fold-back at 9.5 A, and the turn-around's back-EMF slope
/// (`core`'s `CurrentLimit::accel_emf_mv_per_1024`, from the family's least inertia).
pub const CURRENT_LIMIT: CurrentLimit = CurrentLimit {
    limit_ma: 8_000,
    resistance_mohm: 700,
    emf_mv_time: 157_350_000,
    fold_back_ma: 9_500,
    accel_emf_mv_per_1024: 523,
};

/// The motor: the paper's 57 mm 24 V brushless motor (3 700 rpm no-load, 2.85 kgf·cm at
/// 5.5 A) on a 24 V bus — `Ke = Kt` = 60.1 mV·s/rad (line to line), 0.846 Ω across the driven
/// pair (windings and MOSFETs), 64 % forward efficiency of gearbox and screw (the gearbox's
/// 1:20 and the screw's 25.4 mm lead are core's `mechanism`, shared by every conversion).
pub const MOTOR: MotorModel = MotorModel {
    bus_mv: 24_000,
    resistance_mohm: 846,
    ke_micro: 60_100,
    kt_micro: 60_100,
    efficiency_pct: 64,
};

/// The IHM08M1's bus divider on the 3.3 V converter: full scale 3.3 V / 0.0522 = 63.2 V;
/// lockout at 18 V, no regeneration above 38 V, a fault at 40 V.
pub const BUS: BusSense =
    BusSense { full_scale_mv: 63_218, floor_mv: 18_000, regen_mv: 38_000, max_mv: 40_000 };

/// The load-cell amplifier's output at no load: 50 mV (clear of the bottom rail).
pub const LOAD_CELL_ZERO: Volts = Volts(Q16::lit("0.05"));

/// The load-cell amplifier's gain, kgf per volt of its output: 1 / 92 mV/kgf.
pub const LOAD_CELL_KGF_PER_VOLT: Q16 = Q16::lit("10.869565");

/// The overcurrent trip, mA: the drive's 12 A.
pub const OVERCURRENT_MA: u32 = 12_000;

/// The drive's configuration: [`DriveConfig::new`] evaluated as the firmware is built (a
/// refused part is a compile error, not a path of the image), so the board's construction
/// folds to constants.
pub const DRIVE: DriveConfig =
    match DriveConfig::new(CURRENT_SENSE, BUS, CURRENT_LIMIT, OVERCURRENT_MA, DEAD_TIME) {
        Ok(drive) => drive,
        #[allow(clippy::panic, reason = "const evaluation: fails the build, not the run")]
        Err(_) => panic!("this firmware's drive configuration is refused"),
    };

/// The PWM period in core's time unit: 8 500 ticks / 17 = 500 (50 µs).
pub const PWM_PERIOD: DriveTime = DriveTime(PWM_PERIOD_TICKS as u32 / TICKS_PER_DRIVE_TIME);

/// Why this firmware's board was refused (a host test rules each out).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Refused {
    /// The load cell's converter or chain.
    LoadCell,
    /// The board as a whole.
    Board(BoardError),
}

/// This firmware's board.
///
/// # Errors
/// [`Refused`] naming the part; `the_board_is_valid` shows none is.
// Always inlined: built from constants, the whole validation folds to its result and the
// image carries no constructor (`scripts/firmware-size` checks the controller's).
#[inline(always)]
pub fn board() -> Result<BoardConfig, Refused> {
    let reference = AdcReference::from_millivolts(ADC_REFERENCE_MV).ok_or(Refused::LoadCell)?;
    let zero = Volts(LOAD_CELL_ZERO.0.saturating_mul(LOAD_CELL_DIVIDER));
    let gain = LOAD_CELL_KGF_PER_VOLT.saturating_div(LOAD_CELL_DIVIDER);
    let load_cell = LoadCellScale::new(reference, zero, gain).map_err(|_| Refused::LoadCell)?;
    BoardConfig::new(DRIVE, PWM_PERIOD, load_cell, ControllerConfig::taut(MOTOR))
        .map_err(Refused::Board)
}

#[cfg(test)]
mod tests {
    use super::*;
    use taut_core::board::{PAPER_KGF_PER_VOLT, PAPER_LOAD_CELL_ZERO};
    use taut_core::units::Kgf;

    #[test]
    fn the_drive_is_the_papers_but_for_the_bus_divider() {
        assert_eq!(CURRENT_SENSE, CurrentSense::PAPER);
        assert_eq!(CURRENT_LIMIT, CurrentLimit::PAPER);
        assert_eq!(MOTOR, MotorModel::PAPER);
        assert_eq!(BusSense { full_scale_mv: 60_000, ..BUS }, BusSense::PAPER);
        assert_eq!(
            (LOAD_CELL_ZERO, LOAD_CELL_KGF_PER_VOLT),
            (PAPER_LOAD_CELL_ZERO, PAPER_KGF_PER_VOLT)
        );
        let paper = taut_core::board::paper().expect("the paper's board");
        let ours = board().expect("valid");
        assert_eq!(ours.pwm_period(), paper.pwm_period());
        assert_eq!(ours.dead_time_duty(), paper.dead_time_duty());
        assert_eq!(ours.drive().dead_time(), paper.drive().dead_time());
        assert_eq!(ours.drive().trip_codes(), paper.drive().trip_codes());
        assert_eq!(ours.controller(), paper.controller(), "the paper's motor and 8 A limit");
    }

    #[test]
    fn the_board_is_valid() {
        let board = board().expect("this firmware's board is valid");
        assert_eq!(board.pwm_period(), DriveTime::from_micros(50));
        assert_eq!(board.drive().dead_time(), DriveTime::from_micros(1));
        // 170 ticks of 8 500, Q0.16, rounded: 1 311.
        assert_eq!(board.dead_time_duty().raw(), 1_311);
        assert_eq!(board.load_cell().reference().millivolts(), 3_300);
    }

    #[test]
    fn the_load_cell_reads_the_amplifier_through_the_divider() {
        let scale = board().expect("valid").load_cell();
        // 25 kgf: the amplifier at 0.05 + 25 × 0.092 = 2.35 V, the pin at 2.35 × 0.656 126 =
        // 1.5419 V, code 1.5419 / 3.3 × 4 096 = 1 913.9.
        let code = AdcCode::new(1_914);
        let kgf = scale.to_kgf(code).to_milli();
        assert!((kgf - 25_000).abs() <= 20, "{kgf} mkgf");
        assert!(scale.to_kgf(scale.to_code(Kgf::from_int(40))) > Kgf::from_milli(39_980));
    }
}

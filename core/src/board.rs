//! The board a machine runs on: every fact of its electronics that core's rules use, in one
//! validated value.
//!
//! # Theory of operation
//!
//! Core's rules are written against quantities — volts, amperes, kgf, drive time — and the
//! board says what its converter codes and its timer mean in them. A [`BoardConfig`] carries:
//!
//! - the drive's configuration ([`DriveConfig`]): how the current sense reads (winding or link
//!   average, its zero and scale), the bus divider and limits, the current limit, the trip and
//!   the bridge's dead time;
//! - the PWM period, from which the dead time's share of every period — the duty the high side
//!   loses, which the controller's slip damper starts from — is derived, never written down;
//! - the load cell's converter and nominal chain ([`LoadCellScale`]: the converter's reference,
//!   the amplifier's zero-load output and gain; the self-test tares the zero, the calibration
//!   corrects the gain's residue);
//! - the controller's configuration ([`ControllerConfig`]), whose dead-time duty and current
//!   limit the board sets: the duty map's `current_limit` is the drive's
//!   ([`crate::drive::limit::CurrentLimit::limit_ma`]), so the limit the force → duty stage
//!   asks for and the one the drive's window keeps to are one statement of the board
//!   ([`ControllerConfig::taut`] leaves it to the board).
//!
//! [`BoardConfig::new`] checks each part and their agreement once, when the board is built:
//! the drive's configuration is already valid by construction, the dead time must be a sane
//! share of the period, the controller must build. A machine ([`crate::machine::Machine`]) is
//! then built *from* a board, so a port to another board is a new value, not an edit of core.
//!
//! The constructor is not a `const fn`: the controller's validation computes its derived gains
//! in fixed point, which the `fixed` crate does not offer in `const` context. A board is a
//! constant of its firmware or twin and a test of each builds it (the firmware's
//! `the_board_is_valid`), so a rejected board is a failed test, never a surprise at power-up.

use crate::drive::{DriveConfig, DriveTime, Duty};
use crate::sense::load_cell::LoadCellScale;
use crate::tension::controller::{
    ConfigError, ControllerConfig, DEAD_TIME_DUTY_MAX, TensionController,
};
use crate::units::Amps;
#[cfg(any(test, feature = "paper-board"))]
use crate::units::{AdcReference, Q16, Volts};

/// The shortest PWM period a board may have: 20 µs (50 kHz), where a 12-bit duty's resolution
/// and the drive's per-period work still fit.
pub const PWM_PERIOD_MIN: DriveTime = DriveTime::from_micros(20);

/// The longest PWM period a board may have: 100 µs (10 kHz); slower switching is audible and
/// lets the winding current ripple beyond what the current window assumes.
pub const PWM_PERIOD_MAX: DriveTime = DriveTime::from_micros(100);

/// Why a board was rejected.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum BoardError {
    /// The PWM period is outside [`PWM_PERIOD_MIN`]..=[`PWM_PERIOD_MAX`].
    PwmPeriod,
    /// The dead time takes more of the period than [`DEAD_TIME_DUTY_MAX`].
    DeadTimeShare,
    /// The controller's configuration does not build.
    Controller(ConfigError),
    /// The load cell's converter or nominal chain is out of range.
    LoadCell,
}

/// A board: the drive's configuration, its PWM period, the load cell's nominal chain and the
/// controller's configuration, validated together ([`BoardConfig::new`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct BoardConfig {
    drive: DriveConfig,
    pwm_period: DriveTime,
    load_cell: LoadCellScale,
    dead_time_duty: Duty,
    /// Built once, here: a machine copies it (a model checker then sees one construction).
    controller: TensionController,
}

impl BoardConfig {
    /// A board of `drive` switching every `pwm_period`, with the load cell's nominal chain
    /// `load_cell` and the controller `controller` (its dead-time duty is replaced by the
    /// board's: the drive's dead time over the period; its duty map's current limit by the
    /// drive's).
    ///
    /// # Errors
    /// [`BoardError`] naming what is out of range.
    pub fn new(
        drive: DriveConfig,
        pwm_period: DriveTime,
        load_cell: LoadCellScale,
        controller: ControllerConfig,
    ) -> Result<Self, BoardError> {
        if pwm_period < PWM_PERIOD_MIN || pwm_period > PWM_PERIOD_MAX {
            return Err(BoardError::PwmPeriod);
        }
        let dead_time_duty = dead_time_duty(drive.dead_time(), pwm_period);
        if dead_time_duty > DEAD_TIME_DUTY_MAX {
            return Err(BoardError::DeadTimeShare);
        }
        let config = ControllerConfig { dead_time_duty, ..controller }
            .with_current_limit(amps_of_ma(drive.limit().limit_ma));
        let controller = TensionController::new(&config).map_err(BoardError::Controller)?;
        Ok(Self { drive, pwm_period, load_cell, dead_time_duty, controller })
    }

    /// The drive's configuration.
    #[must_use]
    pub const fn drive(&self) -> DriveConfig {
        self.drive
    }

    /// The PWM period.
    #[must_use]
    pub const fn pwm_period(&self) -> DriveTime {
        self.pwm_period
    }

    /// The load cell's nominal chain (before the self-test's tare).
    #[must_use]
    pub const fn load_cell(&self) -> LoadCellScale {
        self.load_cell
    }

    /// The duty the bridge's dead time takes from the high side every period.
    #[must_use]
    pub const fn dead_time_duty(&self) -> Duty {
        self.dead_time_duty
    }

    /// The board's controller at power-up.
    #[must_use]
    pub const fn controller(&self) -> TensionController {
        self.controller
    }
}

#[cfg(any(test, feature = "paper-board"))]
/// The paper's board: its drive ([`DriveConfig::PAPER`]: one DC-link shunt read mid on-time,
/// the 1 : 12 bus divider, 8 A limit, 12 A trip, 1 µs dead time) switching at 20 kHz, the
/// paper's load-cell chain on a 5 V converter (50 mV zero-load output, 92 mV/kgf) and taut's
/// controller. The digital twin's machines and the proofs run on it; the firmware's board
/// is its own.
///
/// # Errors
/// [`BoardError`] were a part refused (core's tests show none is).
pub fn paper() -> Result<BoardConfig, BoardError> {
    let reference = AdcReference::from_millivolts(5_000).ok_or(BoardError::LoadCell)?;
    let load_cell = LoadCellScale::new(reference, PAPER_LOAD_CELL_ZERO, PAPER_KGF_PER_VOLT)
        .map_err(|_| BoardError::LoadCell)?;
    BoardConfig::new(DriveConfig::PAPER, PAPER_PWM_PERIOD, load_cell, ControllerConfig::TAUT)
}

#[cfg(any(test, feature = "paper-board"))]
/// The paper's PWM period: 50 µs (20 kHz).
pub const PAPER_PWM_PERIOD: DriveTime = DriveTime::from_micros(50);

#[cfg(any(test, feature = "paper-board"))]
/// The paper's load-cell chain's zero-load output: 50 mV (a small positive offset keeps the
/// zero reading clear of the converter's bottom rail, so a disconnected bridge that pulls the
/// amplifier to 0 V is told apart from an unloaded one).
pub const PAPER_LOAD_CELL_ZERO: Volts = Volts(Q16::lit("0.05"));

#[cfg(any(test, feature = "paper-board"))]
/// The paper's load-cell chain's sensitivity, volts per kgf (≈ 920 mV at 10 kgf).
pub const PAPER_VOLTS_PER_KGF: Q16 = Q16::lit("0.092");

#[cfg(any(test, feature = "paper-board"))]
/// The paper's chain's `k`, kgf per volt: 1 / 0.092 = 10.869 565.
pub const PAPER_KGF_PER_VOLT: Q16 = Q16::lit("10.869565");

/// `dead_time / period` as a duty, rounded to the nearest, clamped to the largest duty (a zero
/// period reads as the largest).
fn dead_time_duty(dead_time: DriveTime, period: DriveTime) -> Duty {
    let raw = u64::from(dead_time.0)
        .saturating_mul(65_536)
        .saturating_add(u64::from(period.0) / 2)
        .checked_div(u64::from(period.0))
        .unwrap_or(u64::MAX);
    Duty::from_raw_clamped(u16::try_from(raw).unwrap_or(u16::MAX))
}

/// `ma` milliamperes as [`Amps`], rounded to the nearest and saturating: `Amps::from_milli`
/// for a `u32`, in plain integers that fold at compile time when the board is a constant (an
/// image then carries no conversion; `scripts/firmware-size` checks the controller's
/// construction folds).
#[inline(always)]
fn amps_of_ma(ma: u32) -> Amps {
    let bits = u64::from(ma).saturating_mul(65_536).saturating_add(500) / 1_000;
    Amps::from_bits(i32::try_from(bits).unwrap_or(i32::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::paper_board;

    #[test]
    fn the_dead_time_duty_is_the_dead_time_over_the_period() {
        assert_eq!(paper_board().dead_time_duty().raw(), 1_311, "1 µs of 50 µs, rounded");
        assert_eq!(
            dead_time_duty(DriveTime::from_micros(1), DriveTime::from_micros(50)).raw(),
            1_311
        );
        assert_eq!(dead_time_duty(DriveTime(5), DriveTime::from_micros(50)).raw(), 655);
        assert_eq!(dead_time_duty(DriveTime(1), DriveTime(0)), Duty::from_raw_clamped(u16::MAX));
    }

    #[test]
    fn a_board_out_of_range_is_refused_with_its_reason() {
        let board = paper_board();
        let build = |period, controller| {
            BoardConfig::new(board.drive(), period, board.load_cell(), controller)
        };
        assert_eq!(
            build(DriveTime::from_micros(19), ControllerConfig::TAUT),
            Err(BoardError::PwmPeriod)
        );
        assert_eq!(
            build(DriveTime::from_micros(101), ControllerConfig::TAUT),
            Err(BoardError::PwmPeriod)
        );
        assert!(build(DriveTime::from_micros(20), ControllerConfig::TAUT).is_ok());
        assert!(build(DriveTime::from_micros(100), ControllerConfig::TAUT).is_ok());
        let slow = ControllerConfig { period_us: 1, ..ControllerConfig::TAUT };
        assert!(matches!(
            build(DriveTime::from_micros(50), slow),
            Err(BoardError::Controller(ConfigError::Period))
        ));
        let long_dead = DriveConfig::new(
            board.drive().sense(),
            board.drive().bus(),
            board.drive().limit(),
            12_000,
            DriveTime::from_micros(5),
        )
        .expect("5 µs is a dead time the drive takes");
        let at =
            |period| BoardConfig::new(long_dead, period, board.load_cell(), ControllerConfig::TAUT);
        assert_eq!(at(DriveTime::from_micros(20)), Err(BoardError::DeadTimeShare), "a quarter");
        assert!(at(DriveTime::from_micros(50)).is_ok(), "a tenth");
    }

    #[test]
    fn the_board_builds_the_controller_it_was_given_with_its_dead_time() {
        let board = paper_board();
        let config =
            ControllerConfig { dead_time_duty: board.dead_time_duty(), ..ControllerConfig::TAUT };
        assert_eq!(board.controller(), TensionController::new(&config).expect("valid"));
        assert_ne!(board.controller(), TensionController::taut(), "the ideal bridge's differs");
        assert_eq!(board.pwm_period(), DriveTime::from_micros(50));
    }

    #[test]
    fn milliamperes_convert_as_amps_from_milli_does() {
        for ma in (0..=40_000).chain([32_767_000, 32_767_999, 32_768_000, u32::MAX]) {
            let milli = i32::try_from(ma).unwrap_or(i32::MAX);
            assert_eq!(amps_of_ma(ma), Amps::from_milli(milli), "{ma} mA");
        }
    }

    #[test]
    fn the_controller_limits_the_current_to_the_drives_limit() {
        let board = paper_board();
        let drive = board.drive();
        let six_amps = crate::drive::limit::CurrentLimit { limit_ma: 6_000, ..drive.limit() };
        let Ok(drive) =
            DriveConfig::new(drive.sense(), drive.bus(), six_amps, 12_000, drive.dead_time())
        else {
            panic!("6 A is a limit the drive takes");
        };
        // Whatever limit the controller's configuration came with, and whichever map.
        let back_emf = ControllerConfig {
            duty_map: crate::tension::motor::DutyMap::BackEmf { current_limit: Amps::from_int(3) },
            ..ControllerConfig::TAUT
        };
        for given in [ControllerConfig::taut(ControllerConfig::TAUT.motor), back_emf] {
            let built = BoardConfig::new(drive, board.pwm_period(), board.load_cell(), given);
            let expected = ControllerConfig { dead_time_duty: board.dead_time_duty(), ..given }
                .with_current_limit(Amps::from_int(6));
            assert_eq!(
                built.map(|built| built.controller()),
                TensionController::new(&expected).map_err(BoardError::Controller)
            );
        }
        // On the paper's board the limit is the 8 A the built-in configurations state too.
        assert_eq!(
            BoardConfig::new(
                board.drive(),
                board.pwm_period(),
                board.load_cell(),
                ControllerConfig::taut(ControllerConfig::TAUT.motor)
            ),
            Ok(board)
        );
    }
}

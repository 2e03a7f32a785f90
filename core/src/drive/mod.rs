//! The BLDC drive: Hall decoding, six-step commutation, dead time, duty limit, safe reversal,
//! overcurrent and limit-switch interlocks — the part of the machine that can destroy hardware.
//!
//! # Theory of operation
//!
//! [`Drive::step`] runs on every PWM period (and on Hall edges): it is handed one
//! [`DriveSample`] — the voted Hall code, the bus-current code, the overcurrent comparator's
//! flag, the limit switches and the timer ticks since the previous call — and returns the
//! [`DriveOutput`] to put on the bridge: a [`SwitchPattern`] and a [`Duty`] for its high side.
//! The 1 kHz control tick talks to the drive only through [`Drive::set_command`] (direction
//! and duty, or coast) and [`Drive::clear_fault`], and reads back [`Drive::status`].
//!
//! Every call goes through the same fixed sequence, whose order is the safety argument:
//!
//! 1. **Overcurrent first.** A current code at or above [`OVERCURRENT_LIMIT`] or a set
//!    comparator flag latches a fault *in this call*, before anything else is decided.
//! 2. **Hall.** The voted code goes through the [`HallFilter`]; an accepted `000`/`111` or a
//!    jump of two or more sectors latches a fault.
//! 3. **Faulted → all off.** While a fault is latched the held command is dropped (set to
//!    coast — the lesson of VESC PR #926, where a cleared fault let the old command run on),
//!    every leg is switched off and the duty is zero. The fault stays latched until
//!    [`Drive::clear_fault`] is called while the held command is coast and the overcurrent
//!    comparator is no longer tripped.
//! 4. **What to drive.** Coast, a command toward an active limit switch, or an unknown rotor
//!    position request all-off. The bridge is **energised** (from all-off) only when the rotor
//!    is **quiet** — no Hall step for [`REVERSAL_QUIET`], so its back-EMF is below ≈ 0.8 V —
//!    or its last step was already in the commanded direction, and only in a call where the
//!    whole table entry clears the dead time; a change of direction first de-energises.
//!    Once energised, the request is [`six_step`] for the accepted sector. (Within a pull the
//!    controller therefore holds the direction with a low or zero duty rather than coasting:
//!    a coast would make a string-back-driven rotor wait to be quiet before pulling again.)
//! 5. **Dead time.** The request goes through the [`DeadTimeSequencer`], which keeps any leg
//!    that must change sides off for [`DEAD_TIME`].
//! 6. **Duty.** The held command's duty, already bounded by [`DUTY_MAX`] by its type, is
//!    emitted only while some high side is on; otherwise zero.
//!
//! The requirements this module meets are `REQ-DRV-*` in `docs/SPEC.md`; each is proven by a
//! Kani harness in `proofs/`, checked exhaustively under `cargo test` and fuzzed.

pub mod commutation;
pub mod dead_time;
pub mod duty;
pub mod hall;

pub use commutation::{Gates, LegState, Phase, SwitchPattern, six_step};
pub use dead_time::{DEAD_TIME, DeadTimeSequencer};
pub use duty::{DUTY_MAX, Duty};
pub use hall::{HallCode, HallFilter, HallState, Sector, SectorStep};

use crate::io::LimitSwitches;
use crate::sense::current;
use crate::units::{AdcCode, Amps};

/// Clock of the PWM timer: the STM32G431's TIM1 at 170 MHz.
pub const PWM_TIMER_HZ: u32 = 170_000_000;

/// PWM frequency: 20 kHz, above hearing and ≈ 24 periods per sector at full speed.
pub const PWM_FREQUENCY_HZ: u32 = 20_000;

/// Timer ticks in one PWM period (edge-aligned): 170 MHz / 20 kHz = 8 500.
pub const PWM_PERIOD_TICKS: u16 = 8_500;

/// A duration in ticks of the PWM timer ([`PWM_TIMER_HZ`]).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct PwmTicks(pub u32);

impl PwmTicks {
    /// Ticks in `micros` microseconds, saturating.
    #[must_use]
    pub const fn from_micros(micros: u32) -> Self {
        Self(micros.saturating_mul(PWM_TIMER_HZ / 1_000_000))
    }
}

/// How long the rotor must go without a Hall step before the drive may energise it the
/// other way: 20 ms. With four pole pairs that is a speed below 125 rpm (3.4 % of no-load),
/// a back-EMF below 0.8 V, so reversing at low duty cannot drive a current surge.
pub const REVERSAL_QUIET: PwmTicks = PwmTicks::from_micros(20_000);

/// Bus current that trips the drive: 12 A (motor rated 5.5 A; 50 kgf needs ≈ 3.5 A; stall
/// at 24 V would be ≈ 29 A).
pub const OVERCURRENT_LIMIT: Amps = Amps::from_int(12);

/// Which way the motor is asked to turn the lead screw.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Direction {
    /// Forward torque (Hall sequence `101 → 100 → …`): the carriage moves toward the
    /// end-of-travel limit, tensioning the string.
    Pull,
    /// Reverse torque: the carriage moves toward the home limit, releasing the string.
    Release,
}

impl Direction {
    /// Both directions.
    pub const ALL: [Self; 2] = [Self::Pull, Self::Release];

    /// The other direction.
    #[must_use]
    pub const fn reversed(self) -> Self {
        match self {
            Self::Pull => Self::Release,
            Self::Release => Self::Pull,
        }
    }

    /// Whether moving this way runs into an active limit switch.
    #[must_use]
    pub const fn blocked_by(self, limits: LimitSwitches) -> bool {
        match self {
            Self::Pull => limits.end,
            Self::Release => limits.home,
        }
    }
}

/// What the control tick asks of the drive.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub enum DriveCommand {
    /// All switches off; the motor freewheels. The **zero command**.
    #[default]
    Coast,
    /// Six-step drive with torque in `direction` at `duty`.
    Drive {
        /// Torque direction.
        direction: Direction,
        /// High-side PWM duty (bounded by [`DUTY_MAX`] by its type).
        duty: Duty,
    },
}

impl DriveCommand {
    /// The commanded duty (zero for coast).
    #[must_use]
    pub const fn duty(&self) -> Duty {
        match self {
            Self::Coast => Duty::ZERO,
            Self::Drive { duty, .. } => *duty,
        }
    }

    /// The commanded direction, if driving.
    #[must_use]
    pub const fn direction(&self) -> Option<Direction> {
        match self {
            Self::Coast => None,
            Self::Drive { direction, .. } => Some(*direction),
        }
    }
}

/// A latched drive fault.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum DriveFault {
    /// A current sample at or above [`OVERCURRENT_LIMIT`].
    Overcurrent,
    /// The hardware overcurrent comparator (break input) fired.
    OvercurrentTrip,
    /// The Hall sensors read `000` or `111` (confirmed): sensor supply lost or a line broken.
    HallInvalid,
    /// The rotor position jumped two or more sectors: Hall edges lost or misread.
    SectorSkipped,
}

/// One fast-loop sample, taken by the firmware just before calling [`Drive::step`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct DriveSample {
    /// The three Hall lines, already majority-voted over several reads ([`hall::vote`]).
    pub hall: HallCode,
    /// Bus current converter code ([`crate::sense::current`]).
    pub current: AdcCode,
    /// The overcurrent comparator / timer break flag.
    pub overcurrent_trip: bool,
    /// The DC bus voltage's converter code (board divider; see [`crate::io::Inputs`]).
    pub bus_voltage: AdcCode,
    /// The carriage limit switches.
    pub limits: LimitSwitches,
    /// PWM-timer ticks since the previous call.
    pub elapsed: PwmTicks,
}

/// What to put on the bridge now.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct DriveOutput {
    /// Which switches conduct.
    pub pattern: SwitchPattern,
    /// The high-side PWM duty.
    pub duty: Duty,
}

impl DriveOutput {
    /// Everything off.
    pub const OFF: Self = Self { pattern: SwitchPattern::ALL_OFF, duty: Duty::ZERO };
}

/// Why [`Drive::clear_fault`] refused.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum ClearRefused {
    /// The held command is not coast: clear only with the command zeroed, so no old
    /// command can run on after the fault.
    CommandNotZero,
    /// The overcurrent comparator is still tripped.
    TripStillActive,
}

/// What the drive reports to the control tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct DriveStatus {
    /// The latched fault, if any.
    pub fault: Option<DriveFault>,
    /// Accepted Hall steps since power-up, +1 per forward sector, −1 per backward (wrapping).
    /// One step is 1/24 motor turn = 25.4 mm / 480 ≈ 0.053 mm of carriage travel.
    pub steps: i32,
    /// The direction the rotor was last seen turning.
    pub rotation: Option<Direction>,
    /// Ticks since the last accepted Hall step (saturating).
    pub quiet_for: PwmTicks,
    /// The direction the bridge is energised for, if any.
    pub energized: Option<Direction>,
}

/// The drive's state. See the module docs for the order of decisions in [`Drive::step`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Drive {
    filter: HallFilter,
    last_sector: Option<Sector>,
    sequencer: DeadTimeSequencer,
    command: DriveCommand,
    energized: Option<Direction>,
    rotation: Option<Direction>,
    quiet_for: PwmTicks,
    steps: i32,
    fault: Option<DriveFault>,
    trip_active: bool,
    overcurrent_code: AdcCode,
}

impl Default for Drive {
    fn default() -> Self {
        Self::new()
    }
}

impl Drive {
    /// A drive at power-up: coasting, rotor position unknown, no fault.
    #[must_use]
    pub fn new() -> Self {
        Self {
            filter: HallFilter::new(),
            last_sector: None,
            sequencer: DeadTimeSequencer::new(),
            command: DriveCommand::Coast,
            energized: None,
            rotation: None,
            quiet_for: PwmTicks(0),
            steps: 0,
            fault: None,
            trip_active: false,
            overcurrent_code: current::threshold_code(OVERCURRENT_LIMIT).unwrap_or(AdcCode::MAX),
        }
    }

    /// Holds `command` until the next one. Latching a fault drops the held command to coast;
    /// a command set while a fault is latched is recorded but not acted on, and the fault
    /// can only be cleared while the held command is [`DriveCommand::Coast`].
    pub fn set_command(&mut self, command: DriveCommand) {
        self.command = command;
    }

    /// The held command.
    #[must_use]
    pub const fn command(&self) -> DriveCommand {
        self.command
    }

    /// Releases a latched fault.
    ///
    /// # Errors
    /// Refused unless the held command is coast and the comparator is no longer tripped;
    /// the fault then stays latched.
    pub fn clear_fault(&mut self) -> Result<(), ClearRefused> {
        if self.command != DriveCommand::Coast {
            return Err(ClearRefused::CommandNotZero);
        }
        if self.trip_active {
            return Err(ClearRefused::TripStillActive);
        }
        self.fault = None;
        // A Hall fault is re-detected on the next accepted reading if it persists; start the
        // skip check afresh from whatever the sensors say next.
        self.last_sector = match self.filter.accepted() {
            HallState::Sector(sector) => Some(sector),
            HallState::Unknown | HallState::Invalid(_) => None,
        };
        Ok(())
    }

    /// The latched fault, if any.
    #[must_use]
    pub const fn fault(&self) -> Option<DriveFault> {
        self.fault
    }

    /// What the control tick needs to know.
    #[must_use]
    pub const fn status(&self) -> DriveStatus {
        DriveStatus {
            fault: self.fault,
            steps: self.steps,
            rotation: self.rotation,
            quiet_for: self.quiet_for,
            energized: self.energized,
        }
    }

    /// The pattern currently on the gates.
    #[must_use]
    pub fn pattern(&self) -> SwitchPattern {
        self.sequencer.pattern()
    }

    /// The accepted Hall state.
    #[must_use]
    pub const fn hall(&self) -> HallState {
        self.filter.accepted()
    }

    /// One fast-loop step: see the module docs.
    pub fn step(&mut self, sample: DriveSample) -> DriveOutput {
        self.quiet_for = PwmTicks(self.quiet_for.0.saturating_add(sample.elapsed.0));

        // 1. Overcurrent, before anything else.
        self.trip_active = sample.overcurrent_trip;
        if sample.overcurrent_trip {
            self.latch(DriveFault::OvercurrentTrip);
        } else if sample.current >= self.overcurrent_code {
            self.latch(DriveFault::Overcurrent);
        }

        // 2. Hall.
        let hall = self.filter.update(sample.hall);
        match hall {
            HallState::Sector(sector) => self.track(sector),
            HallState::Invalid(_) => self.latch(DriveFault::HallInvalid),
            HallState::Unknown => {}
        }

        // 3. Faulted: all off (the command was dropped when the fault latched).
        if self.fault.is_some() {
            self.energized = None;
            self.sequencer.all_off();
            return DriveOutput::OFF;
        }

        // 4. What to drive.
        let requested = match (self.command, hall) {
            (DriveCommand::Drive { direction, .. }, HallState::Sector(sector))
                if !direction.blocked_by(sample.limits) =>
            {
                self.engage(direction, sector, sample.elapsed)
            }
            _ => {
                self.energized = None;
                SwitchPattern::ALL_OFF
            }
        };

        // 5. Dead time.
        let pattern = self.sequencer.step(requested, sample.elapsed);

        // 6. Duty only while a high side conducts.
        let duty = if pattern.count(LegState::High) > 0 { self.command.duty() } else { Duty::ZERO };
        DriveOutput { pattern, duty }
    }

    /// The pattern to request for torque in `direction` with the rotor in `sector`.
    ///
    /// Once energised for a direction the drive follows the table. Energising — from
    /// all-off, which every change of direction passes through — happens only in a call where
    /// (a) the rotor is quiet or its last Hall step was already in `direction`, and (b) the
    /// dead-time sequencer can put the whole table entry on the gates in this same call; so
    /// the decision is taken on the rotor state of the very call whose output carries it.
    fn engage(&mut self, direction: Direction, sector: Sector, elapsed: PwmTicks) -> SwitchPattern {
        let entry = six_step(sector, direction);
        match self.energized {
            Some(current) if current == direction => entry,
            Some(_) => {
                // Reversal: stop driving now; re-engage on a later call.
                self.energized = None;
                SwitchPattern::ALL_OFF
            }
            None => {
                let rotor_ready =
                    self.quiet_for >= REVERSAL_QUIET || self.rotation == Some(direction);
                if rotor_ready && self.sequencer.ready_for(entry, elapsed) {
                    self.energized = Some(direction);
                    entry
                } else {
                    SwitchPattern::ALL_OFF
                }
            }
        }
    }

    /// Follows the accepted sector: counts steps, notes rotation, detects skips.
    fn track(&mut self, sector: Sector) {
        if let Some(previous) = self.last_sector {
            match SectorStep::between(previous, sector) {
                SectorStep::Stay => {}
                SectorStep::Forward => {
                    self.steps = self.steps.wrapping_add(1);
                    self.rotation = Some(Direction::Pull);
                    self.quiet_for = PwmTicks(0);
                }
                SectorStep::Backward => {
                    self.steps = self.steps.wrapping_sub(1);
                    self.rotation = Some(Direction::Release);
                    self.quiet_for = PwmTicks(0);
                }
                SectorStep::Skipped => self.latch(DriveFault::SectorSkipped),
            }
        }
        self.last_sector = Some(sector);
    }

    /// Latches `fault` unless one is already latched (the first cause is the one reported),
    /// drops the held command and switches every leg off.
    fn latch(&mut self, fault: DriveFault) {
        if self.fault.is_none() {
            self.fault = Some(fault);
            self.command = DriveCommand::Coast;
        }
        self.sequencer.all_off();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(sector: Sector) -> DriveSample {
        DriveSample { hall: sector.hall_code(), elapsed: PwmTicks(8_500), ..Default::default() }
    }

    /// Power-up: the rotor reads `sector` and has been still for the reversal quiet time.
    fn settled(sector: Sector) -> Drive {
        let mut drive = Drive::new();
        let still = DriveSample { elapsed: REVERSAL_QUIET, ..sample(sector) };
        drive.step(still);
        drive.step(still);
        drive
    }

    fn pull(duty: u16) -> DriveCommand {
        DriveCommand::Drive { direction: Direction::Pull, duty: Duty::from_raw_clamped(duty) }
    }

    fn release(duty: u16) -> DriveCommand {
        DriveCommand::Drive { direction: Direction::Release, duty: Duty::from_raw_clamped(duty) }
    }

    #[test]
    fn drives_the_table_entry_once_the_hall_code_is_confirmed_and_the_rotor_still() {
        let mut drive = Drive::new();
        drive.set_command(pull(30_000));
        assert_eq!(drive.step(sample(Sector::S0)), DriveOutput::OFF, "not yet confirmed");
        assert_eq!(drive.step(sample(Sector::S0)), DriveOutput::OFF, "not yet quiet");
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(30_000));
        let out = drive.step(sample(Sector::S0));
        assert_eq!(out.pattern, six_step(Sector::S0, Direction::Pull));
        assert_eq!(out.duty.raw(), 30_000);
    }

    #[test]
    fn overcurrent_is_off_in_the_same_call_and_latched_until_cleared_with_coast() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(30_000));
        assert!(!drive.step(sample(Sector::S0)).pattern.is_all_off());
        let hot = DriveSample { current: AdcCode::MAX, ..sample(Sector::S0) };
        assert_eq!(drive.step(hot), DriveOutput::OFF);
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        assert_eq!(drive.command(), DriveCommand::Coast, "command dropped on fault");
        // A new command alone does not restart the drive, and blocks the clear.
        drive.set_command(pull(30_000));
        assert_eq!(drive.step(sample(Sector::S0)), DriveOutput::OFF);
        assert_eq!(drive.clear_fault(), Err(ClearRefused::CommandNotZero));
        drive.set_command(DriveCommand::Coast);
        assert_eq!(drive.clear_fault(), Ok(()));
        drive.set_command(pull(30_000));
        assert_eq!(drive.step(sample(Sector::S0)).duty.raw(), 30_000);
    }

    #[test]
    fn comparator_trip_refuses_clear_while_active() {
        let mut drive = Drive::new();
        let tripped = DriveSample { overcurrent_trip: true, ..sample(Sector::S0) };
        assert_eq!(drive.step(tripped), DriveOutput::OFF);
        assert_eq!(drive.fault(), Some(DriveFault::OvercurrentTrip));
        assert_eq!(drive.clear_fault(), Err(ClearRefused::TripStillActive));
        drive.step(sample(Sector::S0));
        assert_eq!(drive.clear_fault(), Ok(()));
    }

    #[test]
    fn skipped_sector_faults() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(10_000));
        drive.step(sample(Sector::S2));
        assert_eq!(drive.step(sample(Sector::S2)), DriveOutput::OFF);
        assert_eq!(drive.fault(), Some(DriveFault::SectorSkipped));
    }

    #[test]
    fn never_drives_into_an_active_limit() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(10_000));
        let at_end =
            DriveSample { limits: LimitSwitches { home: false, end: true }, ..sample(Sector::S0) };
        assert_eq!(drive.step(at_end), DriveOutput::OFF);
        drive.set_command(release(10_000));
        assert!(!drive.step(at_end).pattern.is_all_off(), "may back away from the limit");
    }

    #[test]
    fn reversal_waits_for_a_quiet_rotor() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(10_000));
        // Rotor turning forward: S0 → S1.
        for sector in [Sector::S0, Sector::S1, Sector::S1] {
            drive.step(sample(sector));
        }
        assert_eq!(drive.status().rotation, Some(Direction::Pull));
        assert_eq!(drive.status().energized, Some(Direction::Pull));
        drive.set_command(release(10_000));
        // A step just happened: stays off.
        for _ in 0..10 {
            assert_eq!(drive.step(sample(Sector::S1)), DriveOutput::OFF);
        }
        // After REVERSAL_QUIET without a step, the reverse entry comes on.
        let mut out = DriveOutput::OFF;
        for _ in 0..(REVERSAL_QUIET.0 / 8_500 + 2) {
            out = drive.step(sample(Sector::S1));
        }
        assert_eq!(out.pattern, six_step(Sector::S1, Direction::Release));
    }

    #[test]
    fn re_engages_at_once_when_the_rotor_already_turns_the_commanded_way() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(10_000));
        drive.step(sample(Sector::S1));
        drive.step(sample(Sector::S1));
        drive.set_command(DriveCommand::Coast);
        assert_eq!(drive.step(sample(Sector::S1)), DriveOutput::OFF);
        drive.set_command(pull(10_000));
        assert_eq!(drive.step(sample(Sector::S1)).pattern, six_step(Sector::S1, Direction::Pull));
    }
}

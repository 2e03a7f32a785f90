//! The BLDC drive: Hall decoding, six-step commutation, dead time, duty limit, safe reversal,
//! overcurrent and limit-switch interlocks — the part of the machine that can destroy hardware.
//!
//! # Theory of operation
//!
//! [`Drive::step`] runs on every PWM period (and on Hall edges): it is handed one [`DriveSample`] —
//! the voted Hall code, the bus-current code, the overcurrent comparator's flag, the limit switches
//! and the time since the previous call ([`DriveTime`]) — and returns the [`DriveOutput`] to put on
//! the bridge: a [`SwitchPattern`] and a [`Duty`] for its high side. The 1 kHz control tick talks
//! to the drive only through [`Drive::set_command`] (direction and duty, or coast) and
//! [`Drive::clear_fault`], and reads back [`Drive::status`].
//!
//! Every call goes through the same fixed sequence, whose order is the safety argument:
//!
//! 1. **Overcurrent and bus first.** A current sample at or above the board's trip
//!    ([`limit::DriveConfig::trip`]) of winding current (read through the board's
//!    [`limit::CurrentSense`], from its tared zero), a set comparator flag, or a bus at its
//!    configured maximum latches a fault *in this call*, before anything else is decided.
//! 2. **Hall.** The voted code goes through the [`HallFilter`]; an accepted `000`/`111` or a
//!    jump of two or more sectors latches a fault.
//! 3. **Faulted → all off.** While a fault is latched the held command is dropped (set to
//!    coast — the lesson of VESC PR #926, where a cleared fault let the old command run on),
//!    every leg is switched off and the duty is zero. The fault stays latched until
//!    [`Drive::clear_fault`] is called while the held command is coast and the overcurrent
//!    comparator is no longer tripped.
//! 4. **What to drive.** Coast, a command toward an active limit switch, or an unknown rotor
//!    position request all-off. A rotor turning against the commanded torque so fast that no
//!    duty of the command's table keeps the winding current within the limit (the duty
//!    window of [`limit`] is empty: `|e| ≥ I_lim·R`, from the Hall timing) is **braked**
//!    (four-quadrant torque): the table of the way it turns, at that window's lower edge,
//!    puts the limit's current through the winding against the rotation — torque toward the
//!    command, regenerating into the bus below the regeneration threshold, none above it.
//!    Only for a *measured* speed (two steps that way: the back-EMF known on both sides),
//!    never toward an actuated limit switch and never with the edge at the duty cap (a rotor
//!    faster than the bus). Otherwise — after a turn-around, whose speed is only bounded by
//!    what the rotor can have reached from rest (see [`limit`]), a lower edge from that bound
//!    would drive the rotor's way if it is in fact slow — the drive coasts; such a call is
//!    counted ([`Drive::coasting`]: torque asked for and none given). The bridge is
//!    **energised** (from all-off) only in a call where the window exists and the whole
//!    table entry clears the dead time; a change of direction first de-energises.
//!    Once energised, the request is [`six_step`] for the accepted sector. (Within a pull the
//!    controller therefore holds the direction with a low or zero duty rather than coasting:
//!    a coast would make a string-back-driven rotor wait to be quiet before pulling again.)
//! 5. **Dead time.** The request goes through the [`DeadTimeSequencer`], which keeps any leg
//!    that must change sides off for the board's dead time ([`DriveConfig::dead_time`]).
//! 6. **Duty.** Emitted only while some high side is on (otherwise zero): the held command's
//!    duty (bounded by [`DUTY_MAX`] by its type), slewed by at most
//!    [`DUTY_SLEW_PER_MS`] (pro rata of the time since the last call) from the last applied
//!    duty, folded back halfway to the zero-current duty in a period whose sampled winding
//!    current is at the fold-back threshold, and always clamped into the **duty window** — so
//!    the winding current stays within the limit whatever the command, the rotor speed or the
//!    bus voltage (`limit`).
//!    The same step keeps three confirmed rules on the current the window cannot hold, each
//!    latching an overcurrent: a sustained over-limit reading ([`FOLD_BACK_TRIP`]), a lower
//!    edge lifting the duty for [`LIFT_LIMIT`], and a rotor **motoring faster than its
//!    applied voltage** for [`OVERSPEED_LIMIT`] — with motoring current a healthy winding's
//!    back-EMF is below `D·V`, so a Hall speed above it means lost turns or flux (REQ-DRV-12).
//!
//! Between steps 2 and 3 the drive also watches the **winding balance** ([`balance`]): the
//! three conducting pairs' currents, compared once per fast revolution; a sustained imbalance
//! (an inter-turn short) latches an overcurrent like the other rules of step 1.
//!
//! While the bridge has been all-off for [`TARE_SETTLE`] the drive tares the current sense
//! (no current can flow), so an amplifier's offset — mid-rail on a bidirectional board — is
//! subtracted before the overcurrent comparison; a zero outside its tolerance is a fault.
//!
//! The requirements this module meets are `REQ-DRV-*` in `docs/SPEC.md`; each is proven by a
//! Kani harness in `proofs/`, checked exhaustively under `cargo test` and fuzzed.

pub mod balance;
pub mod commutation;
pub mod dead_time;
pub mod duty;
pub mod hall;
pub mod limit;

pub use balance::{IMBALANCE_STRIKES, WindingBalance};
pub use commutation::{Gates, LegState, Phase, SwitchPattern, six_step};
pub use dead_time::{DEAD_TIME_MAX, DEAD_TIME_MIN, DeadTimeSequencer};
pub use duty::{DUTY_MAX, Duty};
pub use hall::{HALL_CONFIRM_READS, HallCode, HallFilter, HallState, Sector, SectorStep};
pub use limit::{BusSense, DriveConfig, DutyWindow, TARE_SETTLE, TURN_LAG, WindingHeat};

use crate::io::LimitSwitches;
use crate::units::{AdcCode, Amps, Volts};
use duty::DUTY_ONE;

/// A duration in tenths of a microsecond (100 ns), the drive's board-independent unit of time.
///
/// The drive never sees a clock frequency: the firmware converts its timer's counts
/// (`firmware/src/timing.rs`), the twin its simulation step, each into this unit, and every
/// duration the drive and the machine compare against is written in microseconds. 100 ns is
/// a tenth of taut's 1 µs dead time (a dead time is configured in whole units, and the
/// firmware checks its own is one), resolves a Hall step at full speed (≈ 675 µs = 6 750
/// units) to under 0.02 %, and a `u32` of it spans 429 s.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
pub struct DriveTime(pub u32);

/// [`DriveTime`] units in one microsecond.
pub const TIME_UNITS_PER_MICRO: u32 = 10;

/// [`DriveTime`] units in one second.
pub const TIME_UNITS_PER_SECOND: u32 = 10_000_000;

impl DriveTime {
    /// `micros` microseconds, saturating.
    #[must_use]
    pub const fn from_micros(micros: u32) -> Self {
        Self(micros.saturating_mul(TIME_UNITS_PER_MICRO))
    }
}

/// Time without a Hall step after which the drive counts the rotor as at rest and tares the
/// current sense once the bridge is off: 20 ms (a speed below 125 rpm, a back-EMF below
/// 0.8 V). Reversal no longer waits for it: see [`limit`].
pub const REVERSAL_QUIET: DriveTime = DriveTime::from_micros(20_000);

/// The largest change of the applied duty per millisecond: full scale (65 540 raw units), so
/// the duty goes from zero to [`DUTY_MAX`] in under 1 ms — one control tick — and a step in the
/// command cannot outrun the Hall-based back-EMF estimate (3 277 per 50 µs PWM period).
pub const DUTY_SLEW_PER_MS: u32 = 65_540;

/// The over-limit count's rise per PWM period whose sampled winding current is above the
/// limit the duty window keeps to ([`limit::DriveConfig::over_limit`], 8 A); it falls by one
/// in every other period the bridge conducts, and is cleared when the bridge is all off.
pub const FOLD_BACK_RISE: u16 = 8;

/// How fast the duty a link-average current reading is judged by ([`Drive::step`]'s
/// `duty_hold`: the largest duty applied lately) falls, duty raw units per millisecond: 3 280
/// (164 per 50 µs PWM period), 1/20 of full scale, so from [`DUTY_MAX`] to zero in ≈ 19 ms. An
/// RC-filtered link reading forgets an earlier, higher duty with its time constant (at most
/// ≈ 1 ms), so the held duty never falls below the duty the reading still reflects.
pub const DUTY_HOLD_DECAY_PER_MS: u32 = 3_280;

/// The over-limit count at which the drive latches an overcurrent: 320 — 40 consecutive
/// periods (2 ms) above the limit, or more than one period in nine kept up (an inter-turn
/// short exceeds it in the sectors that conduct through the shorted phase, never 40 periods
/// in a row). The window bounds a healthy motor's current below the limit (it is computed
/// with the lowest resistance the pair can have), except for a moment while the Hall speed
/// estimate lags a hard acceleration; so a sustained excess is a real fault (a shorted
/// winding, a lower resistance than the board is configured for), caught before it heats
/// anything. Above the fold-back threshold (9.5 A) the duty is also folded back at once.
pub const FOLD_BACK_TRIP: u16 = 320;

/// Consecutive PWM periods of fold-back that latch an overcurrent: 40, 2 ms
/// ([`FOLD_BACK_TRIP`] / [`FOLD_BACK_RISE`]).
pub const FOLD_BACK_TRIP_PERIODS: u16 = FOLD_BACK_TRIP / FOLD_BACK_RISE;

/// How long the window's lower edge may hold the duty above the command before the drive
/// latches an overcurrent: 500 ms, net (a lifted period adds its time,
/// any other call takes its time off). The lower edge lifts the duty only to bound the
/// braking current while the rotor turns faster than the command would drive it; a healthy
/// rotor braked at the window's limit (≈ 8 A, ≈ 0.5 N·m) stops from full speed in tens of
/// milliseconds (≈ 35 ms at twice the nominal inertia), and coasting from full speed on a
/// low-friction drivetrain (the bus at its regeneration threshold) takes ≈ 0.4 s. A rotor the
/// lower edge keeps lifting for longer does not slow under braking: the motor makes less
/// back-EMF than the window computes from its Hall speed (an inter-turn short lowers one
/// phase's turns), so the lower edge itself drives motoring current past the limit — on a
/// link-average board, where no sample need show it. The current cannot be held by the
/// window, which is what [`DriveFault::Overcurrent`] means.
pub const LIFT_LIMIT: DriveTime = DriveTime::from_micros(500_000);

/// How long the rotor may turn faster than the applied voltage can drive a healthy winding,
/// while drawing motoring current, before the drive latches an overcurrent (REQ-DRV-12):
/// 20 ms, net (an overspeeding motoring period adds its time, a motoring
/// period within the voltage and any call that does not conduct take their time off, a
/// conducting period without motoring current leaves the count as it is).
///
/// With motoring current `i > 0` the winding's own equation `D·V = e + i·R + L·di/dt` gives
/// `e < D·V` whatever the load does, once the inductive transient (`τe` ≈ 1 ms) has passed:
/// a healthy motor never turns faster than its applied voltage while it motors. A winding
/// that does has lost back-EMF per unit speed — an inter-turn short (fewer turns in one
/// phase) or a demagnetised rotor — and it shows on every kind of current sense, an
/// RC-filtered link average included, because it needs only the current's sign (motoring)
/// and the Hall speed. The test allows the back-EMF constant's tolerance, the bus divider's,
/// a Hall edge placed 5° early and the link filter's lag: the Hall speed's back-EMF (nominal
/// `Ke`) must exceed the applied voltage by [`OVERSPEED_MARGIN`] and [`OVERSPEED_FLOOR_MV`],
/// with a motoring reading of at least an eighth of the window's limit (× the duty, at least
/// a quarter, on a link-average board: [`limit::DriveConfig::motoring`]).
pub const OVERSPEED_LIMIT: DriveTime = DriveTime::from_micros(20_000);

/// The overspeed test's relative margin, in eighths: the Hall speed's back-EMF × 7/8 must
/// exceed the applied voltage (a 14 % excess): a healthy motor whose `Ke` is up to 17 % below
/// the nameplate's (bus divider 2 % low) never counts at any bus up to 30 V.
pub const OVERSPEED_MARGIN: u32 = 7;

/// The overspeed test's absolute margin, mV: slow rotors (a hold's creep, a single Hall step
/// timed against the dead time's loss) are never judged.
pub const OVERSPEED_FLOOR_MV: u32 = 1_000;

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

crate::codes::numbered! {
    /// A latched drive fault; its number is the one recorded sessions and links carry.
    #[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
    pub enum DriveFault {
        /// A current sample at or above the board's trip ([`limit::DriveConfig::trip`]).
        Overcurrent = 1,
        /// The hardware overcurrent comparator (break input) fired.
        OvercurrentTrip = 2,
        /// The Hall sensors read `000` or `111` (confirmed): sensor supply lost or a line broken.
        HallInvalid = 3,
        /// The rotor position jumped two or more sectors: Hall edges lost or misread.
        SectorSkipped = 4,
        /// The DC bus reached the configured maximum (regenerated energy with nowhere to go, or
        /// a supply above the rating).
        BusOvervoltage = 5,
        /// The current sense's tared zero is outside its tolerance (amplifier offset or a fault).
        CurrentSenseZero = 6,
    }
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
    /// Time since the previous call.
    pub elapsed: DriveTime,
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
    /// Time since the last accepted Hall step (saturating).
    pub quiet_for: DriveTime,
    /// The direction the bridge is energised for, if any.
    pub energized: Option<Direction>,
    /// The motor current of the last sample, in the board's own scale and from the zero the
    /// drive tared (signed: positive above the zero).
    pub current: Amps,
    /// The bus voltage of the last sample, through the board's divider.
    pub bus: Volts,
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
    quiet_for: DriveTime,
    steps: i32,
    fault: Option<DriveFault>,
    trip_active: bool,
    config: DriveConfig,
    /// The current sense's zero, tared while the bridge is off, in 1/16 codes.
    zero16: u16,
    /// Time the bridge has been all-off (saturating).
    off_for: DriveTime,
    /// Time between the last two accepted Hall steps in the same direction (0: unknown).
    interval: DriveTime,
    /// The duty applied in the previous call (zero while no high side conducted).
    applied: Duty,
    /// The leaky fold-back count ([`FOLD_BACK_RISE`], [`FOLD_BACK_TRIP`]).
    folded: u16,
    /// The largest duty applied lately, falling by [`DUTY_HOLD_DECAY_PER_MS`]: what a
    /// link-average current reading is judged by ([`limit::DriveConfig::over_limit`]).
    duty_hold: Duty,
    /// Net time the window's lower edge has held the duty above the command ([`LIFT_LIMIT`]).
    lifted_for: DriveTime,
    /// The three conducting pairs' currents, revolution by revolution ([`balance`]).
    balance: WindingBalance,
    /// Net time the rotor has turned faster than the applied voltage drives a healthy
    /// winding while motoring ([`OVERSPEED_LIMIT`]).
    overspeed_for: DriveTime,
    /// The step interval averaged over about a revolution (1/8 per step; 0: unknown): the
    /// overspeed test's speed, free of the Hall sensors' placement and of the call's
    /// quantisation.
    interval_average: DriveTime,
    /// The last sample's current and bus codes, for [`Drive::status`].
    last_current: AdcCode,
    last_bus: AdcCode,
    /// The winding's temperature estimate: the resistance the window is computed with.
    heat: WindingHeat,
    /// Calls that coasted under a command because the window was empty
    /// ([`Drive::coasting`]).
    coasting: u32,
    /// The way the last accepted step went, forgotten when the sensors read nothing valid or
    /// a sector was skipped (the next step is then no evidence of a turn-around).
    last_step: Option<Direction>,
    /// When the last accepted step reversed `last_step` (a turn-around: the rotor's speed
    /// passed through zero after the step before), the time between the two steps
    /// ([`Drive::emf_toward`]).
    turn_gap: Option<DriveTime>,
}

/// The longest gap between calls the per-millisecond rates are scaled over: 1 ms (the slew's
/// whole range; the cap keeps the products in a `u32`).
const RATE_SPAN: u32 = 1_000 * TIME_UNITS_PER_MICRO;

/// `per_ms` raw duty units per millisecond, over `elapsed` (at most [`RATE_SPAN`]).
fn rate_for(elapsed: DriveTime, per_ms: u32) -> u16 {
    let units = elapsed.0.min(RATE_SPAN);
    let amount = units.saturating_mul(per_ms) / RATE_SPAN;
    u16::try_from(amount).unwrap_or(u16::MAX)
}

/// The held duty's fall for a call `elapsed` after the previous one, duty raw units.
fn hold_decay_for(elapsed: DriveTime) -> u16 {
    rate_for(elapsed, DUTY_HOLD_DECAY_PER_MS)
}

/// The slew allowance for a call `elapsed` after the previous one, duty raw units.
fn slew_for(elapsed: DriveTime) -> u16 {
    rate_for(elapsed, DUTY_SLEW_PER_MS)
}

#[cfg(any(test, feature = "paper-board"))]
impl Default for Drive {
    fn default() -> Self {
        Self::new()
    }
}

impl Drive {
    #[cfg(any(test, feature = "paper-board"))]
    /// A drive at power-up on taut's own board ([`DriveConfig::PAPER`]).
    #[must_use]
    pub fn new() -> Self {
        Self::with_config(DriveConfig::PAPER)
    }

    /// A drive at power-up on the board `config` describes: coasting, rotor position
    /// unknown, no fault, the current sense's zero at its design value until tared.
    #[must_use]
    pub fn with_config(config: DriveConfig) -> Self {
        Self {
            filter: HallFilter::new(),
            last_sector: None,
            sequencer: DeadTimeSequencer::new(config.dead_time()),
            command: DriveCommand::Coast,
            energized: None,
            rotation: None,
            quiet_for: DriveTime(0),
            steps: 0,
            fault: None,
            trip_active: false,
            config,
            zero16: config.sense().design_zero.get().saturating_mul(16),
            off_for: DriveTime(0),
            interval: DriveTime(0),
            applied: Duty::ZERO,
            folded: 0,
            duty_hold: Duty::ZERO,
            lifted_for: DriveTime(0),
            balance: WindingBalance::new(),
            overspeed_for: DriveTime(0),
            interval_average: DriveTime(0),
            last_current: config.sense().design_zero,
            last_bus: AdcCode::new(0),
            heat: WindingHeat::cold(&config),
            coasting: 0,
            last_step: None,
            turn_gap: None,
        }
    }

    /// The board configuration.
    #[must_use]
    pub const fn config(&self) -> DriveConfig {
        self.config
    }

    /// The current sense's tared zero code.
    #[must_use]
    pub const fn current_zero(&self) -> AdcCode {
        AdcCode::new(self.zero16 / 16)
    }

    /// The duty applied in the last call.
    #[must_use]
    pub const fn applied(&self) -> Duty {
        self.applied
    }

    /// The rotor's back-EMF estimate, mV, positive when it turns the way `direction` points:
    /// from `max(last step interval, time since the last step)` — exact at constant speed,
    /// an upper bound of the speed while the rotor slows. With one step seen, none toward
    /// its direction and one step per quiet time against it; with none seen since power-up,
    /// one step per quiet time against the torque.
    #[must_use]
    pub fn emf_toward(&self, direction: Direction) -> i32 {
        let Some(rotation) = self.rotation else {
            // No step seen since power-up: the rotor may turn either way, at most one step
            // per quiet time — counted against the torque.
            let e = i32::try_from(self.config.emf_mv(self.quiet_for.0.max(1))).unwrap_or(0);
            return e.saturating_neg();
        };
        let per_step = self.interval.0.max(self.quiet_for.0);
        if self.interval.0 == 0 {
            // One step seen, no interval yet: the speed is at most one step since then — and,
            // after a turn-around, at most what the rotor can reach from rest since the step
            // before it ([`limit::DriveConfig::turn_emf_mv`]).
            if rotation == direction {
                return 0;
            }
            let mut e = self.config.emf_mv(self.quiet_for.0.max(1));
            if let Some(gap) = self.turn_gap {
                e = e.min(self.config.turn_emf_mv(gap.0.saturating_add(self.quiet_for.0)));
            }
            return i32::try_from(e).unwrap_or(0).saturating_neg();
        }
        let e = i32::try_from(self.config.emf_mv(per_step)).unwrap_or(i32::MAX);
        if rotation == direction { e } else { e.saturating_neg() }
    }

    /// The duty window for torque in `direction` on the bus `bus` with the rotor as the drive
    /// last saw it (`None`: no duty keeps the current within the limit).
    #[must_use]
    pub fn window(&self, direction: Direction, bus: AdcCode) -> Option<DutyWindow> {
        self.config.window_with(bus, self.emf_toward(direction), self.heat.ir_mv())
    }

    /// The window for **braking** a rotor that turns against `direction` (four-quadrant
    /// torque): the window of the table for the way the rotor turns, whose lower edge puts
    /// the limit's current through the winding against the rotation — torque toward
    /// `direction` — regenerating into the bus (none above the regeneration threshold). Only
    /// for a rotor whose speed is *measured*: two steps the same way, so the back-EMF is
    /// known on both sides (after a single step against the torque, a turn-around, only an
    /// upper bound is, and a lower edge taken from it would drive the rotor's way if it is
    /// in fact slow); never toward an actuated limit switch. `None`: coast.
    fn braking_window(
        &self,
        direction: Direction,
        bus: AdcCode,
        limits: LimitSwitches,
    ) -> Option<DutyWindow> {
        let along = direction.reversed();
        let measured = self.rotation == Some(along) && self.interval.0 != 0;
        if !measured || along.blocked_by(limits) {
            return None;
        }
        // A lower edge at the cap is a rotor faster than the bus: its current flows through
        // the body diodes whatever the switches do, and the cap's low-side time would only add
        // to it.
        self.window(along, bus).filter(|window| window.low < DUTY_MAX)
    }

    /// The winding's temperature estimate ([`WindingHeat`]).
    #[must_use]
    pub const fn heat(&self) -> WindingHeat {
        self.heat
    }

    /// `I_lim·R` the window keeps to now, mV (the winding's estimated resistance).
    #[must_use]
    pub const fn ir_mv(&self) -> u32 {
        self.heat.ir_mv()
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

    /// Applies one machine tick's drive outputs: holds `command`, then — if the machine asks —
    /// releases a latched fault. The order is the rule: the clear is only granted with the
    /// command already at coast (`clear_fault`), so a clear can never release a fault into a
    /// drive command. Every binding (the firmware, the twin, the tick-cost replay) applies the
    /// machine's outputs through this one function.
    ///
    /// # Errors
    /// The clear was refused ([`Drive::clear_fault`]); the fault stays latched and the machine
    /// sees it in the next status. Without a clear request, always `Ok`.
    pub fn apply(&mut self, command: DriveCommand, clear_fault: bool) -> Result<(), ClearRefused> {
        self.set_command(command);
        if clear_fault { self.clear_fault() } else { Ok(()) }
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

    /// What the control tick needs to know. The current and the bus are converted here, with
    /// the board's configuration, so no other layer needs to know the board's scales.
    #[must_use]
    pub fn status(&self) -> DriveStatus {
        DriveStatus {
            fault: self.fault,
            steps: self.steps,
            rotation: self.rotation,
            quiet_for: self.quiet_for,
            energized: self.energized,
            current: self.config.sense().amps(self.last_current, self.current_zero()),
            bus: self.config.bus().volts(self.last_bus),
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
        // The sector and the bridge while this sample's current flowed (the previous call's).
        let (sampled_sector, sampled_driving) = (self.last_sector, !self.applied.is_zero());
        (self.last_current, self.last_bus) = (sample.current, sample.bus_voltage);
        self.quiet_for = DriveTime(self.quiet_for.0.saturating_add(sample.elapsed.0));

        // 1. Overcurrent and bus overvoltage, before anything else.
        self.trip_active = sample.overcurrent_trip;
        if sample.overcurrent_trip {
            self.latch(DriveFault::OvercurrentTrip);
        } else if self.config.overcurrent(sample.current, self.current_zero()) {
            self.latch(DriveFault::Overcurrent);
        } else if self.config.bus_over(sample.bus_voltage) {
            self.latch(DriveFault::BusOvervoltage);
        }

        // 2. Hall.
        let hall = self.filter.update(sample.hall);
        match hall {
            HallState::Sector(sector) => self.track(sector),
            HallState::Invalid(_) => {
                // The rotor may turn any number of sectors while the sensors read nothing
                // valid: the next valid sector is a fresh start, not a step from the last one
                // seen (counting it would credit a speed — a back-EMF — nobody measured).
                self.last_sector = None;
                self.last_step = None;
                self.latch(DriveFault::HallInvalid);
            }
            HallState::Unknown => {}
        }

        // The winding balance, revolution by revolution (an inter-turn short).
        let reading =
            i32::from(sample.current.get()).saturating_sub(i32::from(self.current_zero().get()));
        self.heat.step(
            &self.config,
            sample.current.get().abs_diff(self.current_zero().get()),
            sampled_driving,
            sample.elapsed,
        );
        if self.balance.update(
            sampled_sector,
            self.last_sector,
            sampled_driving,
            reading,
            sample.elapsed,
            self.config.limit_codes(),
        ) {
            self.latch(DriveFault::Overcurrent);
        }

        // 3. Faulted: all off (the command was dropped when the fault latched).
        if self.fault.is_some() {
            return self.off(sample);
        }

        // 4. What to drive, and the duty window that keeps the current within the limit.
        let mut window = None;
        let mut braking = false;
        let requested = match (self.command, hall) {
            (DriveCommand::Drive { direction, .. }, HallState::Sector(sector))
                if !direction.blocked_by(sample.limits) =>
            {
                window = self.window(direction, sample.bus_voltage);
                let mut along = direction;
                if window.is_none() {
                    // The rotor turns against the torque too fast for the table's own
                    // direction: brake it through the table of the way it turns.
                    window = self.braking_window(direction, sample.bus_voltage, sample.limits);
                    along = direction.reversed();
                    braking = window.is_some();
                }
                match window {
                    Some(_) => self.engage(along, sector, sample.elapsed),
                    None => {
                        // No measured speed to brake from, or braking is blocked: coast until
                        // the rotor slows.
                        self.coasting = self.coasting.saturating_add(1);
                        self.energized = None;
                        SwitchPattern::ALL_OFF
                    }
                }
            }
            _ => {
                self.energized = None;
                SwitchPattern::ALL_OFF
            }
        };

        // 5. Dead time.
        let pattern = self.sequencer.step(requested, sample.elapsed);

        // 6. Duty only while a high side conducts: the command's, slewed from the last applied
        //    duty, folded back toward zero current if the sampled current is high, and always
        //    inside the window.
        let (Some(window), true) = (window, pattern.count(LegState::High) > 0) else {
            return self.off_with(pattern, sample);
        };
        self.off_for = DriveTime(0);
        let slew = slew_for(sample.elapsed);
        let target = window.clamp(self.command.duty());
        let slewed = if target > self.applied {
            target.min(Duty::from_raw_clamped(self.applied.raw().saturating_add(slew)))
        } else {
            target.max(Duty::from_raw_clamped(self.applied.raw().saturating_sub(slew)))
        };
        let folding = self.config.fold_back(sample.current, self.current_zero());
        // Braking asks the lower edge itself (the most torque toward the command the limit
        // allows); the window's lower edge is what the lift rule measures either way.
        let asked = if braking { Duty::ZERO } else { self.command.duty() };
        let over_limit =
            self.config.over_limit(sample.current, self.current_zero(), self.duty_hold);
        self.folded = if over_limit {
            self.folded.saturating_add(FOLD_BACK_RISE)
        } else {
            self.folded.saturating_sub(1)
        };
        self.lifted_for = if asked < window.low {
            DriveTime(self.lifted_for.0.saturating_add(sample.elapsed.0))
        } else {
            DriveTime(self.lifted_for.0.saturating_sub(sample.elapsed.0))
        };
        self.overspeed_for = match self.overspeeding(sample.current, sample.bus_voltage) {
            Some(true) => DriveTime(self.overspeed_for.0.saturating_add(sample.elapsed.0)),
            Some(false) => DriveTime(self.overspeed_for.0.saturating_sub(sample.elapsed.0)),
            None => self.overspeed_for,
        };
        if self.folded >= FOLD_BACK_TRIP
            || self.lifted_for >= LIFT_LIMIT
            || self.overspeed_for >= OVERSPEED_LIMIT
        {
            self.latch(DriveFault::Overcurrent);
            return self.off(sample);
        }
        let duty = if folding {
            let direction = self.energized.unwrap_or(Direction::Pull);
            let zero =
                self.config.zero_current_duty(sample.bus_voltage, self.emf_toward(direction));
            let mid = u32::from(self.applied.raw()).saturating_add(u32::from(zero.raw())) / 2;
            window.clamp(Duty::from_raw_clamped(u16::try_from(mid).unwrap_or(0)))
        } else if braking {
            window.low
        } else {
            window.clamp(slewed)
        };
        self.applied = duty;
        self.hold_duty(duty, sample.elapsed);
        DriveOutput { pattern, duty }
    }

    /// All off: no high side conducts (a fault, coast, or a pattern the dead time holds off).
    fn off(&mut self, sample: DriveSample) -> DriveOutput {
        self.folded = 0;
        self.lifted_for = DriveTime(0);
        self.overspeed_for = DriveTime(0);
        self.energized = None;
        self.sequencer.all_off();
        self.off_with(SwitchPattern::ALL_OFF, sample)
    }

    /// `pattern` (no high side on) with zero duty; tares the current sense once the bridge
    /// has been all-off for [`TARE_SETTLE`].
    fn off_with(&mut self, pattern: SwitchPattern, sample: DriveSample) -> DriveOutput {
        self.applied = Duty::ZERO;
        self.hold_duty(Duty::ZERO, sample.elapsed);
        self.lifted_for = DriveTime(self.lifted_for.0.saturating_sub(sample.elapsed.0));
        self.overspeed_for = DriveTime(self.overspeed_for.0.saturating_sub(sample.elapsed.0));
        if pattern.is_all_off() {
            self.off_for = DriveTime(self.off_for.0.saturating_add(sample.elapsed.0));
            if self.off_for >= TARE_SETTLE {
                self.tare(sample.current);
            }
        } else {
            self.off_for = DriveTime(0);
        }
        DriveOutput { pattern, duty: Duty::ZERO }
    }

    /// The held duty after a call that applied `applied` `elapsed` after the previous.
    fn hold_duty(&mut self, applied: Duty, elapsed: DriveTime) {
        let fallen = self.duty_hold.raw().saturating_sub(hold_decay_for(elapsed));
        self.duty_hold = applied.max(Duty::from_raw_clamped(fallen));
    }

    /// Calls since power-up (saturating) in which a drive command was held, no fault was
    /// latched, no limit switch blocked it and the rotor's sector was known, yet the bridge
    /// was all-off because the duty window was empty (the rotor turned against the torque
    /// too fast for any duty to keep the current within the limit) and no brake was possible
    /// ([`Drive::step`]'s four-quadrant rule: a turn-around's speed is only bounded, a brake
    /// toward an actuated switch or from a rotor faster than the bus is not made): torque
    /// asked for and none given. One call per PWM period (and per Hall edge where the binding calls on
    /// edges too). A counter of the drive beside [`Drive::lifted_for`], not part of
    /// [`DriveStatus`]: the machine does not act on it; the twin and the bench read it.
    #[must_use]
    pub const fn coasting(&self) -> u32 {
        self.coasting
    }

    /// Net time the window's lower edge has held the duty above the command ([`LIFT_LIMIT`]).
    #[must_use]
    pub const fn lifted_for(&self) -> DriveTime {
        self.lifted_for
    }

    /// Net time the rotor has overspeeded while motoring ([`OVERSPEED_LIMIT`]).
    #[must_use]
    pub const fn overspeed_for(&self) -> DriveTime {
        self.overspeed_for
    }

    /// REQ-DRV-12: `None` unless the current sampled in this call (`current`, driven by the
    /// previous call's duty in the direction still energised, the rotor turning that way)
    /// is motoring; then whether the Hall speed's back-EMF (averaged over about a
    /// revolution), with its margins, exceeds the voltage that duty put on the winding from
    /// the bus `bus`.
    fn overspeeding(&self, current: AdcCode, bus: AdcCode) -> Option<bool> {
        let direction = self.energized?;
        let motoring = !self.applied.is_zero()
            && self.config.motoring(current, self.current_zero(), self.applied)
            && self.rotation == Some(direction)
            && self.interval_average.0 != 0;
        if !motoring {
            return None;
        }
        let per_step = self.interval_average.0.max(self.quiet_for.0);
        // 7 × e ≤ 7 × EMF_MAX_MV fits a u32; V × duty is one 32 × 32 → 64-bit product.
        let emf = self.config.emf_mv(per_step).saturating_mul(OVERSPEED_MARGIN) / 8;
        let applied_mv = u64::from(self.config.bus().millivolts(bus))
            .saturating_mul(u64::from(self.applied.raw()))
            >> DUTY_ONE.trailing_zeros();
        Some(u64::from(emf) > applied_mv.saturating_add(u64::from(OVERSPEED_FLOOR_MV)))
    }

    /// The duty a link-average current reading is judged by: the largest applied lately.
    #[must_use]
    pub const fn duty_hold(&self) -> Duty {
        self.duty_hold
    }

    /// One step of the current sense's tare: the zero moves 1/32 of the way to the sample
    /// (a 1.6 ms time constant at 20 kHz); a zero outside the tolerance latches a fault.
    fn tare(&mut self, code: AdcCode) {
        let target = i32::from(code.get()).saturating_mul(16);
        let zero = i32::from(self.zero16);
        let difference = target.saturating_sub(zero);
        // At least one 1/16 code per period, so the tare converges exactly.
        let step = match difference / 32 {
            0 => difference.signum(),
            step => step,
        };
        let moved = zero.saturating_add(step);
        self.zero16 = u16::try_from(moved.clamp(0, 4_095 * 16)).unwrap_or(0);
        if !self.config.zero_plausible(self.current_zero()) {
            self.latch(DriveFault::CurrentSenseZero);
        }
    }

    /// The pattern to request for torque in `direction` with the rotor in `sector`.
    ///
    /// Once energised for a direction the drive follows the table. Energising — from
    /// all-off, which every change of direction passes through — happens only in a call where
    /// (a) the rotor is quiet or its last Hall step was already in `direction`, and (b) the
    /// dead-time sequencer can put the whole table entry on the gates in this same call; so
    /// the decision is taken on the rotor state of the very call whose output carries it.
    fn engage(
        &mut self,
        direction: Direction,
        sector: Sector,
        elapsed: DriveTime,
    ) -> SwitchPattern {
        let entry = six_step(sector, direction);
        match self.energized {
            Some(current) if current == direction => entry,
            Some(_) => {
                // Reversal: stop driving now; re-engage on a later call.
                self.energized = None;
                SwitchPattern::ALL_OFF
            }
            None => {
                // The rotor's state is already judged by the window (it exists, so the rotor
                // does not turn against the torque too fast for the current limit).
                if self.sequencer.ready_for(entry, elapsed) {
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
                    self.stepped(Direction::Pull);
                }
                SectorStep::Backward => {
                    self.steps = self.steps.wrapping_sub(1);
                    self.stepped(Direction::Release);
                }
                SectorStep::Skipped => {
                    self.last_step = None;
                    self.latch(DriveFault::SectorSkipped);
                }
            }
        }
        self.last_sector = Some(sector);
    }

    /// An accepted Hall step in `direction`: the step interval (only between two steps the
    /// same way; a turn-around starts it afresh) and the rotation.
    fn stepped(&mut self, direction: Direction) {
        self.interval =
            if self.rotation == Some(direction) { self.quiet_for } else { DriveTime(0) };
        self.interval_average = match (self.interval.0, self.interval_average.0) {
            (0, _) => DriveTime(0),
            (now, 0) => DriveTime(now),
            (now, average) if now >= average => {
                DriveTime(average.saturating_add(now.saturating_sub(average) / 8))
            }
            (now, average) => DriveTime(average.saturating_sub(average.saturating_sub(now) / 8)),
        };
        self.turn_gap = (self.last_step == Some(direction.reversed())).then_some(self.quiet_for);
        self.last_step = Some(direction);
        self.rotation = Some(direction);
        self.quiet_for = DriveTime(0);
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

    /// One 50 µs PWM period of a 20 kHz board, in drive time.
    const PERIOD: u32 = 50 * TIME_UNITS_PER_MICRO;

    /// The slew allowance of one such period: 65 540 per ms × 0.05.
    const DUTY_SLEW_PER_PERIOD: u16 = 3_277;

    /// The held duty's fall in one such period: 3 280 per ms × 0.05.
    const DUTY_HOLD_DECAY_PER_PERIOD: u16 = 164;

    /// A 24 V bus (code 1 638 of the 1:12 divider).
    const BUS_24V: AdcCode = AdcCode::new(1_638);

    fn sample(sector: Sector) -> DriveSample {
        DriveSample {
            hall: sector.hall_code(),
            elapsed: DriveTime(PERIOD),
            bus_voltage: BUS_24V,
            ..Default::default()
        }
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
        // The duty slews up from zero, one period's allowance at a time …
        assert_eq!(out.duty.raw(), DUTY_SLEW_PER_PERIOD);
        // … and a rotor at rest on 24 V gets at most I·R / V = 5.6 V / 24 V, not 0.46.
        let high = drive.window(Direction::Pull, BUS_24V).map(|window| window.high);
        for _ in 0..10 {
            drive.step(sample(Sector::S0));
        }
        assert_eq!(Some(drive.applied()), high);
        assert!(drive.applied().raw() < 15_400);
    }

    /// The per-millisecond rates scale with the time since the previous call, up to 1 ms
    /// (twenty periods: a call that late may slew the whole range); no longer gap counts for
    /// more.
    #[test]
    fn per_period_rates_scale_with_the_gap_up_to_twenty_periods() {
        let period = PERIOD;
        assert_eq!(slew_for(DriveTime(period)), DUTY_SLEW_PER_PERIOD);
        assert_eq!(slew_for(DriveTime(period / 2)), DUTY_SLEW_PER_PERIOD / 2);
        assert_eq!(slew_for(DriveTime(10 * period)), 10 * DUTY_SLEW_PER_PERIOD);
        // Twenty periods' allowance is the whole range (it saturates the u16).
        assert_eq!(slew_for(DriveTime(20 * period)), u16::MAX);
        assert_eq!(slew_for(DriveTime(u32::MAX)), u16::MAX);
        assert_eq!(hold_decay_for(DriveTime(period)), DUTY_HOLD_DECAY_PER_PERIOD);
        assert_eq!(hold_decay_for(DriveTime(10 * period)), 10 * DUTY_HOLD_DECAY_PER_PERIOD);
        assert_eq!(hold_decay_for(DriveTime(20 * period)), 20 * DUTY_HOLD_DECAY_PER_PERIOD);
        assert_eq!(hold_decay_for(DriveTime(21 * period)), 20 * DUTY_HOLD_DECAY_PER_PERIOD);
        assert_eq!(hold_decay_for(DriveTime(u32::MAX)), 20 * DUTY_HOLD_DECAY_PER_PERIOD);
    }

    #[test]
    fn a_small_command_passes_unchanged_once_slewed() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(3_000));
        assert_eq!(drive.step(sample(Sector::S0)).duty.raw(), 3_000);
    }

    #[test]
    fn bus_overvoltage_is_off_in_the_same_call_and_latched() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(3_000));
        assert!(!drive.step(sample(Sector::S0)).pattern.is_all_off());
        let pumped = DriveSample { bus_voltage: AdcCode::new(2_731), ..sample(Sector::S0) };
        assert_eq!(drive.step(pumped), DriveOutput::OFF);
        assert_eq!(drive.fault(), Some(DriveFault::BusOvervoltage));
    }

    /// A drive on per-phase bidirectional sensing, fresh (`tare` false) or after 400 idle
    /// periods with the amplifier 20 codes (0.24 A) above mid-rail.
    fn bidirectional(tare: bool) -> Drive {
        let config = DriveConfig::new(
            limit::CurrentSense::PER_PHASE_BIDIRECTIONAL,
            BusSense::PAPER,
            limit::CurrentLimit::PAPER,
            12_000,
            DriveConfig::PAPER.dead_time(),
        );
        let Ok(config) = config else { panic!("valid configuration") };
        let mut drive = Drive::with_config(config);
        let idle = DriveSample { current: AdcCode::new(2_068), ..sample(Sector::S0) };
        for _ in 0..if tare { 400 } else { 0 } {
            drive.step(idle);
        }
        drive
    }

    #[test]
    fn the_status_reports_the_tared_current_and_the_bus_in_the_boards_scales() {
        let fresh = bidirectional(false).status();
        assert_eq!((fresh.current, fresh.bus), (Amps::ZERO, Volts::ZERO));
        let mut drive = bidirectional(true);
        // At the tared mid-rail zero: 0 A (a fixed 0.2 V/A unidirectional scale made 12.6 A
        // of it); 82 codes above it ≈ +1 A (the bridge is off, so the tare itself moves 1/32
        // of the way, 80 codes: 0.976 A). The bus: code 1 638 of the 1:12 divider.
        assert_eq!(drive.status().current, Amps::ZERO);
        drive.step(DriveSample { current: AdcCode::new(2_150), ..sample(Sector::S0) });
        let status = drive.status();
        let sense = limit::CurrentSense::PER_PHASE_BIDIRECTIONAL;
        assert_eq!(status.current, sense.amps(AdcCode::new(2_150), drive.current_zero()));
        assert_eq!(status.current, Amps::from_milli(976));
        assert_eq!(status.bus, BusSense::PAPER.volts(BUS_24V));
        assert_eq!(status.bus, Volts::from_milli(23_994));
    }

    #[test]
    fn a_bidirectional_sense_is_tared_and_does_not_trip_at_mid_rail() {
        // The amplifier sits 20 codes (0.24 A) above mid-rail: tared away with the bridge off.
        let mut drive = bidirectional(true);
        assert_eq!(drive.fault(), None);
        assert!(drive.current_zero().get().abs_diff(2_068) <= 1, "{:?}", drive.current_zero());
        // 12 A of winding current from the tared zero trips; 11.5 A does not.
        drive.set_command(pull(3_000));
        let at = |amps_milli: u32| DriveSample {
            current: AdcCode::new(2_068 + u16::try_from(amps_milli * 1_000 / 12_207).unwrap_or(0)),
            ..sample(Sector::S0)
        };
        drive.step(at(11_500));
        assert_eq!(drive.fault(), None);
        drive.step(at(12_100));
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
    }

    #[test]
    fn a_current_the_window_cannot_hold_down_folds_back_then_trips() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(3_000));
        drive.step(sample(Sector::S0));
        // 10 A sampled (1 639 codes at 6.1 mA): below the trip, above the fold-back.
        let hot = DriveSample { current: AdcCode::new(1_639), ..sample(Sector::S0) };
        for period in 1..FOLD_BACK_TRIP_PERIODS {
            let out = drive.step(hot);
            assert!(out.duty.raw() < 3_000, "period {period}: folded back");
            assert_eq!(drive.fault(), None);
        }
        assert_eq!(drive.step(hot), DriveOutput::OFF);
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
    }

    /// REQ-DRV-10's fold-back: each period whose sampled current is over the fold-back level
    /// moves the duty halfway from the last applied duty to the zero-current duty (here 0:
    /// the rotor is at rest, no back-EMF), inside the window.
    #[test]
    fn a_folded_period_halves_the_distance_to_the_zero_current_duty() {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(3_000));
        assert_eq!(drive.step(sample(Sector::S0)).duty.raw(), 3_000);
        let hot = DriveSample { current: AdcCode::new(1_639), ..sample(Sector::S0) };
        assert_eq!(drive.step(hot).duty.raw(), 1_500);
        assert_eq!(drive.step(hot).duty.raw(), 750);
        assert_eq!(drive.step(hot).duty.raw(), 375);
        // A cool period slews back up from there, not from the command.
        let cool = drive.step(sample(Sector::S0)).duty.raw();
        assert_eq!(cool, 3_000.min(375 + DUTY_SLEW_PER_PERIOD));
    }

    #[test]
    fn fold_back_in_more_than_one_period_in_nine_trips_and_less_does_not() {
        let hot = DriveSample { current: AdcCode::new(1_639), ..sample(Sector::S0) };
        let cool = sample(Sector::S0);
        // One hot period in every `n`: the count drifts by 8 − (n − 1) per n periods.
        let trips_within = |n: u32, periods: u32| {
            let mut drive = settled(Sector::S0);
            drive.set_command(pull(3_000));
            drive.step(cool);
            (0..periods).any(|k| {
                drive.step(if k % n == 0 { hot } else { cool });
                drive.fault() == Some(DriveFault::Overcurrent)
            })
        };
        // One in two (an inter-turn short seen in two sectors of three): 320 / 7 × 2 ≈ 92.
        assert!(trips_within(2, 100));
        assert!(!trips_within(2, 80));
        // One in eight: +1 net per eight periods — trips, slowly (≈ 2 560 periods).
        assert!(trips_within(8, 2_600));
        // One in nine balances out; one in ten never accumulates.
        assert!(!trips_within(9, 20_000));
        assert!(!trips_within(10, 20_000));
    }

    /// A link-average board (RC-filtered DC-link shunt, bidirectional amplifier) at rest,
    /// driven toward Pull at the window's edge; returns the drive and the duty it applies.
    fn link_board_driving() -> (Drive, DriveSample, Duty) {
        let Ok(config) = DriveConfig::new(
            limit::CurrentSense::LINK_AVERAGE_BIDIRECTIONAL,
            BusSense::PAPER,
            limit::CurrentLimit::PAPER,
            12_000,
            DriveConfig::PAPER.dead_time(),
        ) else {
            panic!("the link-average board is a valid configuration");
        };
        let mut drive = Drive::with_config(config);
        let rest = DriveSample { current: AdcCode::new(2_048), ..sample(Sector::S0) };
        let still = DriveSample { elapsed: REVERSAL_QUIET, ..rest };
        drive.step(still);
        drive.step(still);
        drive.set_command(pull(30_000));
        // 50 ms: the duty has slewed to the window's edge (which still widens slowly toward
        // I_lim·R/V as the time since the last Hall step bounds the back-EMF ever lower).
        for _ in 0..1_000 {
            drive.step(rest);
        }
        let duty = drive.applied();
        (drive, rest, duty)
    }

    /// The code an RC-filtered link reads for `winding_ma` at `duty`, `percent` of `D·I`.
    fn link_code(duty: Duty, winding_ma: u64, percent: u64) -> AdcCode {
        let link_ma = u64::from(duty.raw()).saturating_mul(winding_ma).saturating_mul(percent)
            / (65_536 * 100);
        // 12.207 031 mA per code above the mid-rail zero.
        let codes = link_ma.saturating_mul(1_000_000) / 12_207_031;
        AdcCode::new(2_048_u16.saturating_add(u16::try_from(codes).unwrap_or(u16::MAX)))
    }

    #[test]
    fn a_link_average_board_counts_a_winding_current_past_the_limit_by_the_duty() {
        // Near rest on 24 V the window holds the duty at its upper edge, ≈ I_lim·R/V ≈ 0.23.
        let (drive, _, duty) = link_board_driving();
        assert_eq!(drive.window(Direction::Pull, BUS_24V).map(|w| w.high), Some(duty));
        assert!((14_000..15_400).contains(&duty.raw()), "{}", duty.raw());
        // A shorted winding carrying 13 A reads ≈ 0.23 × 13 = 3.0 A on the link: far below
        // the 12 A trip, but past D × 8 A × 1.3 in every period: latched in 40 periods.
        let (mut drive, _, duty) = link_board_driving();
        let short = DriveSample { current: link_code(duty, 13_000, 100), ..sample(Sector::S0) };
        for period in 1..FOLD_BACK_TRIP_PERIODS {
            drive.step(short);
            assert_eq!(drive.fault(), None, "period {period}");
        }
        assert_eq!(drive.step(short), DriveOutput::OFF);
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        // A healthy winding at the window's limit (8 A × 0.7 Ω over the real pair's 0.764 Ω:
        // 7.3 A), read at the RC ripple's crest (127 % of D·I), never counts.
        let (mut drive, _, duty) = link_board_driving();
        let crest = DriveSample { current: link_code(duty, 7_330, 127), ..sample(Sector::S0) };
        for _ in 0..20_000 {
            drive.step(crest);
        }
        assert_eq!(drive.fault(), None);
        assert_eq!(drive.duty_hold(), drive.applied());
    }

    #[test]
    fn the_held_duty_falls_from_full_to_zero_in_about_nineteen_milliseconds() {
        let (mut drive, rest, duty) = link_board_driving();
        assert_eq!(drive.duty_hold(), duty);
        drive.set_command(DriveCommand::Coast);
        let mut periods = 0u32;
        while !drive.duty_hold().is_zero() && periods < 1_000 {
            drive.step(rest);
            periods = periods.saturating_add(1);
        }
        // The window's edge (≈ 14 800 raw) / 164 per period: ≈ 91 periods (4.5 ms).
        assert_eq!(periods, u32::from(duty.raw()).div_ceil(164));
        assert_eq!(u32::from(DUTY_MAX.raw()).div_ceil(u32::from(DUTY_HOLD_DECAY_PER_PERIOD)), 380);
    }

    /// A rotor turning forward one sector every 20 PWM periods (≈ 15.7 V of back-EMF: the
    /// window's lower edge at 24 V is ≈ 0.42), driven toward `Pull` at `duty` for `calls`
    /// periods from `drive`'s state; returns the drive's fault after the last call.
    fn turning_forward(drive: &mut Drive, first: &mut u32, calls: u32, duty: u16) {
        turning_at(drive, first, 20, calls, duty, 0);
    }

    #[test]
    fn a_lower_edge_that_keeps_lifting_the_duty_latches_an_overcurrent_at_the_lift_limit() {
        // A command below the lower edge (a healthy rotor braking, or a shorted winding's
        // runaway): the net lifted time rises by each period's time and latches at the limit.
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        turning_forward(&mut drive, &mut call, 200, 6_554);
        let lifted = drive.lifted_for();
        assert!(lifted.0 > 0, "the lower edge lifts a 10 % command at ≈ 15.7 V of back-EMF");
        let periods_left = (LIFT_LIMIT.0 - lifted.0) / PERIOD;
        turning_forward(&mut drive, &mut call, periods_left - 1, 6_554);
        assert_eq!(drive.fault(), None, "one period short of the limit");
        assert_eq!(drive.lifted_for().0, LIFT_LIMIT.0 - PERIOD);
        turning_forward(&mut drive, &mut call, 1, 6_554);
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        assert_eq!(drive.pattern(), SwitchPattern::ALL_OFF);
    }

    #[test]
    fn a_command_exactly_at_the_lower_edge_is_not_lifted() {
        // One sector every 20 periods: after the first steps the interval and the window are
        // constant, so the command can sit exactly on the lower edge.
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        turning_forward(&mut drive, &mut call, 200, 6_554);
        let low = drive.window(Direction::Pull, BUS_24V).map(|w| w.low.raw()).unwrap_or(0);
        assert!(low > 6_554);
        turning_forward(&mut drive, &mut call, 12_000, low);
        assert_eq!(drive.lifted_for().0, 0);
        assert_eq!(drive.fault(), None);
    }

    #[test]
    fn lifted_time_is_net_so_braking_spells_between_driving_never_add_up_to_a_fault() {
        // 0.4 s lifted, 0.4 s at a command above the lower edge, 0.4 s lifted again: the net
        // never reaches the 0.5 s limit (a healthy rotor braking now and then).
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        for _ in 0..3 {
            turning_forward(&mut drive, &mut call, 8_000, 6_554);
            assert_eq!(drive.fault(), None);
            assert!(drive.lifted_for().0 > 0);
            turning_forward(&mut drive, &mut call, 8_000, 60_000);
            assert_eq!(drive.fault(), None);
            assert_eq!(drive.lifted_for().0, 0, "driving above the lower edge takes it back");
        }
        // Coasting takes it back too.
        turning_forward(&mut drive, &mut call, 8_000, 6_554);
        drive.set_command(DriveCommand::Coast);
        for _ in 0..8_000 {
            drive.step(sample(Sector::S0.advanced(u8::try_from((call / 20) % 6).unwrap_or(0))));
            call += 1;
        }
        assert_eq!(drive.lifted_for().0, 0);
        assert_eq!(drive.fault(), None);
    }

    /// A rotor turning forward one sector every `per_sector` periods (20: ≈ 15.7 V of
    /// back-EMF), driven toward `Pull` at `duty` for `calls` periods with the sampled
    /// current `current` (codes; 164 = 1 A of the paper's winding sense).
    fn turning_at(
        drive: &mut Drive,
        first: &mut u32,
        per_sector: u32,
        calls: u32,
        duty: u16,
        current: u16,
    ) {
        drive.set_command(pull(duty));
        for _ in 0..calls {
            let sector = Sector::S0.advanced(u8::try_from((*first / per_sector) % 6).unwrap_or(0));
            drive.step(DriveSample { current: AdcCode::new(current), ..sample(sector) });
            *first += 1;
        }
    }

    /// 3 A of winding reading on the paper's sense.
    const THREE_AMPS: u16 = 492;

    #[test]
    fn a_rotor_that_motors_faster_than_its_voltage_latches_an_overcurrent_in_twenty_ms() {
        // ≈ 15.7 V of back-EMF against 45 % of 24 V (10.8 V): with motoring current a healthy
        // winding cannot turn this fast (REQ-DRV-12). Net overspeeding time rises by each
        // period's time and latches at 20 ms.
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        turning_at(&mut drive, &mut call, 20, 240, 29_491, 0);
        assert_eq!(drive.overspeed_for().0, 0, "no motoring current: not judged");
        turning_at(&mut drive, &mut call, 20, 200, 29_491, THREE_AMPS);
        assert_eq!(drive.overspeed_for().0, 200 * PERIOD);
        let left = (OVERSPEED_LIMIT.0 - drive.overspeed_for().0) / PERIOD;
        turning_at(&mut drive, &mut call, 20, left - 1, 29_491, THREE_AMPS);
        assert_eq!(drive.fault(), None, "one period short of the limit");
        turning_at(&mut drive, &mut call, 20, 1, 29_491, THREE_AMPS);
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        assert_eq!(drive.pattern(), SwitchPattern::ALL_OFF);
    }

    #[test]
    fn a_rotor_within_its_voltage_or_braking_is_never_an_overspeed() {
        // 70 % of 24 V (16.8 V) against ≈ 15.7 V: motoring, as a healthy winding does.
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        turning_at(&mut drive, &mut call, 20, 20_000, 45_875, THREE_AMPS);
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
        // At the margins' edge: 7/8 of 15 735 mV is 13 768 mV; 53.25 % of 23 994 mV plus a
        // volt is 13 778 mV (not above), 53.1 % plus a volt 13 741 mV (above).
        turning_at(&mut drive, &mut call, 20, 20_000, 34_900, THREE_AMPS);
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
        turning_at(&mut drive, &mut call, 20, 20, 34_800, THREE_AMPS);
        assert_eq!(drive.overspeed_for().0, 19 * PERIOD, "the first period flowed at 53.25 %");
        turning_at(&mut drive, &mut call, 20, 200, 34_900, THREE_AMPS);
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
        // Exactly at the edge (53.21 %: 12 768 mV + 1 V = 13 768 mV) is not above.
        turning_at(&mut drive, &mut call, 20, 2_000, 34_875, THREE_AMPS);
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
        // Braking (no motoring reading) at 45 %: not evidence either way, the count holds.
        turning_at(&mut drive, &mut call, 20, 100, 29_491, THREE_AMPS);
        let counted = drive.overspeed_for();
        assert_eq!(counted.0, 99 * PERIOD, "the first period's current flowed under 60 %");
        turning_at(&mut drive, &mut call, 20, 20_000, 29_491, 100);
        assert_eq!((drive.fault(), drive.overspeed_for()), (None, counted));
        // Motoring within the voltage takes it back, period by period.
        // (while the duty slews up from 45 % the first few periods still count).
        turning_at(&mut drive, &mut call, 20, 60, 45_875, THREE_AMPS);
        assert!(drive.overspeed_for() < counted);
        turning_at(&mut drive, &mut call, 20, 200, 45_875, THREE_AMPS);
        assert_eq!(drive.overspeed_for().0, 0);
        // Coasting takes it back too.
        turning_at(&mut drive, &mut call, 20, 60, 29_491, THREE_AMPS);
        assert!(drive.overspeed_for().0 > 0);
        drive.set_command(DriveCommand::Coast);
        for _ in 0..60 {
            drive.step(sample(Sector::S0.advanced(u8::try_from((call / 20) % 6).unwrap_or(0))));
            call += 1;
        }
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
    }

    #[test]
    fn the_overspeed_speed_is_averaged_over_about_a_revolution() {
        // At 20 periods a sector and 60 % (14.4 V + 1 V against 7/8 × 15.7 V) nothing
        // counts; one sector timed 15 periods (a Hall edge placed early: 21 V at once) moves
        // the average an eighth of the way (19.4 periods: 16.2 V × 7/8 = 14.2 V) and still
        // nothing counts.
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        turning_at(&mut drive, &mut call, 20, 2_400, 39_322, THREE_AMPS);
        let sector = |call: u32| Sector::S0.advanced(u8::try_from((call / 20) % 6).unwrap_or(0));
        let next = sector(call).advanced(1);
        drive.set_command(pull(39_322));
        for _ in 0..15 {
            drive.step(DriveSample { current: AdcCode::new(THREE_AMPS), ..sample(sector(call)) });
        }
        for _ in 0..40 {
            drive.step(DriveSample { current: AdcCode::new(THREE_AMPS), ..sample(next) });
        }
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
        // A rotor that really turns at 15 periods a sector (≈ 21 V: the window's lower edge
        // lifts the duty to ≈ 64 %, 15.3 V) counts once the average has come within reach
        // (7/8 of its back-EMF above 16.3 V: below ≈ 16.8 periods, eight steps on).
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        turning_at(&mut drive, &mut call, 20, 2_400, 39_322, THREE_AMPS);
        let mut fast = 0;
        turning_at(&mut drive, &mut fast, 15, 90, 39_322, THREE_AMPS);
        assert_eq!(drive.overspeed_for().0, 0, "six fast steps: the average lags");
        turning_at(&mut drive, &mut fast, 15, 150, 39_322, THREE_AMPS);
        assert!(drive.overspeed_for().0 > 0);
        // The average follows a slowing rotor up by an eighth of the gap per step: from 15
        // periods a sector at 80 % (healthy: 16.8 V + 1 V against 7/8 × 21 V) to 20 at 60 %
        // it still reads the faster speed for a few steps (counting), then takes it all back.
        let mut drive = settled(Sector::S0);
        let mut call = 0;
        turning_at(&mut drive, &mut call, 15, 3_000, 52_429, THREE_AMPS);
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
        // The last sector was S1 (call 2 999 at 15 periods); S2 comes next.
        let mut slow = 40;
        turning_at(&mut drive, &mut slow, 20, 40, 39_322, THREE_AMPS);
        assert!(drive.overspeed_for().0 > 0, "the average lags the slowing rotor");
        turning_at(&mut drive, &mut slow, 20, 2_000, 39_322, THREE_AMPS);
        assert_eq!((drive.fault(), drive.overspeed_for().0), (None, 0));
    }

    #[test]
    fn a_link_average_board_judges_motoring_by_the_duty() {
        // An RC-filtered link reads ≈ D·I: at 23 % duty 1 A of winding current reads 0.23 A.
        // Motoring means at least D × 1 A of reading (D at least a quarter), anything less
        // is not judged.
        let (drive, _, duty) = link_board_driving();
        let config = drive.config();
        let zero = AdcCode::new(2_048);
        let floor = Duty::from_raw_clamped(16_384);
        assert!(duty < floor);
        // 1 A at the floor's 25 % = 0.25 A = 20.5 codes above the zero (1 A = 81.92 codes).
        assert!(!config.motoring(AdcCode::new(2_068), zero, duty));
        assert!(config.motoring(AdcCode::new(2_069), zero, duty));
        assert!(!config.motoring(AdcCode::new(2_000), zero, duty), "braking");
        // At full duty the threshold is the full ampere.
        let full = Duty::from_raw_clamped(62_259);
        assert!(!config.motoring(AdcCode::new(2_048 + 76), zero, full));
        assert!(config.motoring(AdcCode::new(2_048 + 78), zero, full));
        // A winding sense reads the current itself: 1 A whatever the duty.
        let winding = Drive::new().config();
        let eighth = winding.limit_codes() / 8;
        assert!(winding.motoring(AdcCode::new(eighth), AdcCode::new(0), floor));
        assert!(!winding.motoring(AdcCode::new(eighth - 1), AdcCode::new(0), full));
    }

    /// `revolutions` forward revolutions at 20 periods per sector (6 ms each) under a 60 %
    /// pull, the sampled winding current `ma[k % 3]` mA in sector `k`; returns the fault.
    fn turning_with_pair_currents(revolutions: u32, ma: [u32; 3]) -> (Drive, u32) {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(39_322));
        let mut latched_in = 0;
        for revolution in 1..=revolutions {
            for sector in Sector::ALL {
                let code = ma[usize::from(sector.index() % 3)] * 1_311 / 8_000;
                let current = AdcCode::new(u16::try_from(code).unwrap_or(0));
                for _ in 0..20 {
                    drive.step(DriveSample { current, ..sample(sector) });
                }
            }
            if latched_in == 0 && drive.fault().is_some() {
                latched_in = revolution;
            }
        }
        (drive, latched_in)
    }

    #[test]
    fn a_winding_whose_pairs_carry_unequal_currents_latches_an_overcurrent() {
        // Two pairs through a shorted phase at 6 A, the third at 0.5 A: every fast revolution
        // is a strike (REQ-DRV-11); no sample is near the 8 A limit or the trip.
        let (drive, latched_in) = turning_with_pair_currents(40, [6_000, 6_000, 500]);
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        assert_eq!(drive.pattern(), SwitchPattern::ALL_OFF);
        assert!((20..=22).contains(&latched_in), "latched in revolution {latched_in}");
        // The same currents in every pair: never.
        let (balanced, _) = turning_with_pair_currents(100, [6_000, 6_000, 6_000]);
        assert_eq!(balanced.fault(), None);
        // A spread of 1.5 A on a 2 A mean — more than half the mean, less than a quarter of
        // the board's 8 A limit: never.
        let (small, _) = turning_with_pair_currents(100, [2_500, 2_500, 1_000]);
        assert_eq!(small.fault(), None);
    }

    #[test]
    fn an_implausible_current_zero_is_a_fault() {
        let mut drive = Drive::new();
        let offset = DriveSample { current: AdcCode::new(400), ..sample(Sector::S0) };
        for _ in 0..400 {
            drive.step(offset);
        }
        assert_eq!(drive.fault(), Some(DriveFault::CurrentSenseZero));
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
        drive.set_command(pull(3_000));
        assert_eq!(drive.step(sample(Sector::S0)).duty.raw(), 3_000);
    }

    #[test]
    fn applying_outputs_sets_the_command_first_and_clears_only_when_asked_with_coast() {
        let mut drive = settled(Sector::S0);
        let hot = DriveSample { current: AdcCode::MAX, ..sample(Sector::S0) };
        drive.set_command(pull(30_000));
        assert_eq!(drive.step(hot), DriveOutput::OFF);
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        // A clear together with a pull command is refused: the command is set first.
        assert_eq!(drive.apply(pull(3_000), true), Err(ClearRefused::CommandNotZero));
        assert_eq!(drive.command(), pull(3_000));
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        // Coast without a clear request: the fault stays latched.
        assert_eq!(drive.apply(DriveCommand::Coast, false), Ok(()));
        assert_eq!(drive.fault(), Some(DriveFault::Overcurrent));
        // Coast with the request: cleared, and the next command drives.
        assert_eq!(drive.apply(DriveCommand::Coast, true), Ok(()));
        assert_eq!(drive.fault(), None);
        assert_eq!(drive.apply(pull(3_000), false), Ok(()));
        assert_eq!(drive.step(sample(Sector::S0)).duty.raw(), 3_000);
    }

    #[test]
    fn a_latched_fault_starts_the_over_limit_count_afresh() {
        // 30 periods at 9 A (over the 8 A limit, under the 9.5 A fold-back): the count is at
        // 240 of 320. The comparator then trips; the fault's all-off clears the count, so
        // after the clear 10 more periods over the limit (80) do not latch again.
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(10_000));
        let over = DriveSample { current: AdcCode::new(1_475), ..sample(Sector::S0) };
        for _ in 0..30 {
            drive.step(over);
        }
        assert_eq!(drive.fault(), None);
        drive.step(DriveSample { overcurrent_trip: true, ..sample(Sector::S0) });
        assert_eq!(drive.fault(), Some(DriveFault::OvercurrentTrip));
        drive.step(sample(Sector::S0));
        drive.set_command(DriveCommand::Coast);
        assert_eq!(drive.clear_fault(), Ok(()));
        drive.set_command(pull(10_000));
        for _ in 0..10 {
            drive.step(over);
        }
        assert_eq!(drive.fault(), None);
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
    fn a_valid_sector_after_an_invalid_code_is_a_fresh_start_not_a_step() {
        let mut drive = settled(Sector::S5);
        let invalid = DriveSample { hall: HallCode::from_raw(0), ..sample(Sector::S5) };
        drive.step(invalid);
        drive.step(invalid);
        assert_eq!(drive.fault(), Some(DriveFault::HallInvalid));
        // S5 → (invalid) → S0 would be a forward step; the drive must not count it.
        drive.step(sample(Sector::S0));
        drive.step(sample(Sector::S0));
        let status = drive.status();
        assert_eq!((status.steps, status.rotation), (0, None), "{status:?}");
        // Nor is S0 → S1 after clearing a step with a known interval: one step, speed unknown.
        drive.set_command(DriveCommand::Coast);
        assert_eq!(drive.clear_fault(), Ok(()));
        drive.step(sample(Sector::S1));
        drive.step(sample(Sector::S1));
        assert_eq!(drive.status().steps, 1);
        assert_eq!(drive.interval, DriveTime(0));
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
        for _ in 0..(REVERSAL_QUIET.0 / PERIOD + 2) {
            out = drive.step(sample(Sector::S1));
        }
        assert_eq!(out.pattern, six_step(Sector::S1, Direction::Release));
    }

    /// A settled drive held toward `Pull` at `duty` whose rotor steps S0 → S1 (forward) and,
    /// `gap` periods later, S1 → S0 (backward: a turn-around under a pull command).
    fn turned_round(gap: u32, duty: u16) -> Drive {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(duty));
        for _ in 0..HALL_CONFIRM_READS {
            drive.step(sample(Sector::S1));
        }
        for _ in 0..gap {
            drive.step(sample(Sector::S1));
        }
        for _ in 0..HALL_CONFIRM_READS {
            drive.step(sample(Sector::S0));
        }
        drive
    }

    #[test]
    fn after_a_turn_around_the_back_emf_is_what_the_rotor_reached_from_rest() {
        // The backward step came 4 periods (200 µs) after the forward one, and was accepted
        // one period after it was first read: 5 periods since the step before, plus the lag.
        let drive = turned_round(3, 10_000);
        assert_eq!(drive.status().rotation, Some(Direction::Release));
        assert_eq!(drive.status().quiet_for, DriveTime(0));
        let since = 5 * PERIOD + TURN_LAG.0;
        // 523 mV per 102.4 µs over 0.35 ms, against one step per period (tens of volts).
        assert_eq!(drive.config().turn_emf_mv(5 * PERIOD), 1_787);
        assert_eq!(since * 523 / 1_024, 1_787);
        assert_eq!(drive.emf_toward(Direction::Pull), -1_787);
        assert_eq!(drive.emf_toward(Direction::Release), 0);
        // The window exists: the bridge pulls in the very next call, within it.
        let mut drive = drive;
        let out = drive.step(sample(Sector::S0));
        assert_eq!(out.pattern, six_step(Sector::S0, Direction::Pull));
        assert!(!out.duty.is_zero());
        assert_eq!(drive.coasting(), 0);
    }

    #[test]
    fn the_turn_around_bound_grows_with_time_and_yields_to_one_step_per_time() {
        let mut drive = turned_round(3, 10_000);
        let one_step = |drive: &Drive| {
            i32::try_from(drive.config().emf_mv(drive.status().quiet_for.0.max(1))).unwrap_or(0)
        };
        let mut crossed = false;
        for _ in 0..200 {
            drive.step(sample(Sector::S0));
            let since = 5 * PERIOD + drive.status().quiet_for.0;
            let turn = i32::try_from(drive.config().turn_emf_mv(since)).unwrap_or(0);
            let expected = turn.min(one_step(&drive));
            assert_eq!(drive.emf_toward(Direction::Pull), -expected);
            crossed |= one_step(&drive) < turn;
        }
        assert!(crossed, "the one-step bound takes over once it is the smaller");
    }

    #[test]
    fn a_first_step_against_the_torque_is_no_turn_around() {
        // Power-up, no step seen; then one step backward: no step before it, no turn credit.
        let mut drive = settled(Sector::S1);
        drive.set_command(pull(10_000));
        for _ in 0..HALL_CONFIRM_READS {
            drive.step(sample(Sector::S0));
        }
        // At the step itself: one step in no time, the largest back-EMF considered.
        assert_eq!(drive.emf_toward(Direction::Pull), -60_000);
        // Two steps the same way are no turn-around either (the interval bounds the speed).
        let mut drive = turned_round(3, 10_000);
        for _ in 0..4 {
            drive.step(sample(Sector::S5));
        }
        let per_step = 2 * PERIOD;
        let expected = i32::try_from(drive.config().emf_mv(per_step)).unwrap_or(0);
        assert_eq!(drive.emf_toward(Direction::Pull), -expected);
    }

    #[test]
    fn an_invalid_code_or_a_skip_forgets_the_steps_before() {
        for bad in [HallCode::from_raw(0), Sector::S3.hall_code()] {
            let mut drive = settled(Sector::S0);
            for _ in 0..HALL_CONFIRM_READS {
                drive.step(sample(Sector::S1));
            }
            for _ in 0..HALL_CONFIRM_READS {
                drive.step(DriveSample { hall: bad, ..sample(Sector::S1) });
            }
            assert!(drive.fault().is_some());
            for sector in [Sector::S1, Sector::S1, Sector::S0, Sector::S0] {
                drive.step(sample(sector));
            }
            // The backward step follows a gap in the sequence: one step in no time, no turn
            // credited (a turn-around would bound it by a few volts).
            assert_eq!(drive.emf_toward(Direction::Pull), -60_000, "{bad:?}");
        }
    }

    #[test]
    fn coasting_under_a_command_is_counted_only_for_an_empty_window() {
        // A rotor stepping backward every period under a pull: the window is empty.
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(10_000));
        let backward = [Sector::S5, Sector::S4, Sector::S3, Sector::S2, Sector::S1, Sector::S0];
        let mut coasted = 0;
        for sector in backward.iter().cycle().take(24) {
            for _ in 0..HALL_CONFIRM_READS {
                let out = drive.step(sample(*sector));
                if drive.window(Direction::Pull, BUS_24V).is_none() {
                    assert_eq!(out, DriveOutput::OFF);
                    coasted += 1;
                }
            }
        }
        assert!(coasted > 20);
        assert_eq!(drive.coasting(), coasted);
        // Coast, a blocked command and a fault are not counted.
        drive.set_command(DriveCommand::Coast);
        drive.step(sample(Sector::S5));
        drive.set_command(pull(10_000));
        let blocked = LimitSwitches { home: false, end: true };
        drive.step(DriveSample { limits: blocked, ..sample(Sector::S5) });
        drive.step(DriveSample { overcurrent_trip: true, ..sample(Sector::S4) });
        drive.step(sample(Sector::S4));
        assert_eq!(drive.coasting(), coasted);
    }

    /// A settled drive held toward `Pull` at `duty` whose rotor turns backward one step every
    /// `periods` periods (`steps` steps), with `limits`: each call's output.
    fn back_driven(
        periods: u32,
        steps: usize,
        limits: LimitSwitches,
        bus: AdcCode,
    ) -> (Drive, heapless::Vec<(Sector, DriveOutput), 512>) {
        let mut drive = settled(Sector::S0);
        drive.set_command(pull(10_000));
        let backward = [Sector::S5, Sector::S4, Sector::S3, Sector::S2, Sector::S1, Sector::S0];
        let mut outputs = heapless::Vec::new();
        for sector in backward.iter().cycle().take(steps) {
            for _ in 0..periods {
                let at = DriveSample { limits, bus_voltage: bus, ..sample(*sector) };
                assert!(outputs.push((*sector, drive.step(at))).is_ok());
            }
        }
        (drive, outputs)
    }

    #[test]
    fn a_rotor_turning_against_the_command_at_a_measured_speed_is_braked_at_the_limit() {
        // One backward step every 1.6 ms: ≈ 10 V of back-EMF against the pull, past
        // I_lim·R (≈ 5.5 V), so no pull-table duty keeps the current within the limit.
        let free = LimitSwitches { home: false, end: false };
        let (drive, outputs) = back_driven(32, 12, free, BUS_24V);
        let e = drive.emf_toward(Direction::Release);
        assert!(e > 9_000 && e < 11_000, "{e} mV");
        assert!(drive.window(Direction::Pull, BUS_24V).is_none());
        // Until the second step is accepted the speed is only bounded (one step against the
        // torque): the pull table while its window lasts, then coast. From the second step on,
        // the release table at the window's lower edge: the limit's current against the
        // rotation, torque toward the pull.
        let second = 32 + usize::from(HALL_CONFIRM_READS) - 1;
        let pull_s0 = six_step(Sector::S0, Direction::Pull);
        let before = outputs.iter().take(second);
        assert!(before.clone().all(|(_, out)| out.pattern.is_all_off() || out.pattern == pull_s0));
        let coasted = drive.coasting();
        let off = before.filter(|(_, out)| out.pattern.is_all_off()).count();
        assert_eq!(usize::try_from(coasted).unwrap_or(0), off);
        assert!(coasted > 20, "{coasted}");
        let mut drive_now = drive;
        let low = drive_now.window(Direction::Release, BUS_24V).map(|w| w.low);
        let mut previous = Sector::S4;
        for (sector, out) in outputs.iter().skip(second) {
            let entries =
                [six_step(*sector, Direction::Release), six_step(previous, Direction::Release)];
            assert!(entries.contains(&out.pattern), "{sector:?}: {out:?}");
            assert!(!out.duty.is_zero());
            previous = *sector;
        }
        // The last call's duty is the release window's lower edge for the rotor as now seen.
        drive_now.set_command(pull(10_000));
        assert_eq!(outputs.last().map(|(_, out)| out.duty), low);
        assert_eq!(drive_now.status().energized, Some(Direction::Release));
        // (e − I_lim·R) / V, to the window's rounding.
        let v = 24_000_i64;
        let applied = i64::from(low.map_or(0, Duty::raw)) * v / 65_536;
        let expected = i64::from(e) - i64::from(drive_now.ir_mv());
        assert!((applied - expected).abs() <= 10, "{applied} mV against {expected} mV");
    }

    #[test]
    fn a_brake_toward_an_actuated_limit_switch_coasts() {
        // The rotor turns toward home with the home switch closed: no release table.
        let home = LimitSwitches { home: true, end: false };
        let (drive, outputs) = back_driven(32, 12, home, BUS_24V);
        let pull_s0 = six_step(Sector::S0, Direction::Pull);
        assert!(outputs.iter().all(|(_, out)| out.pattern.is_all_off() || out.pattern == pull_s0));
        let off = outputs.iter().filter(|(_, out)| out.pattern.is_all_off()).count();
        assert_eq!(usize::try_from(drive.coasting()).unwrap_or(0), off);
        assert!(off > 300, "{off}");
    }

    #[test]
    fn above_the_regeneration_threshold_the_brake_draws_no_current() {
        // At 38 V (the regeneration threshold's code) the lower edge is the back-EMF itself.
        let bus = AdcCode::new(2_595);
        let (drive, outputs) = back_driven(32, 12, LimitSwitches::default(), bus);
        let e = i64::from(drive.emf_toward(Direction::Release));
        let (_, last) = outputs.last().copied().unwrap_or((Sector::S0, DriveOutput::OFF));
        assert!(!last.pattern.is_all_off());
        let v = i64::from(drive.config().bus().millivolts(bus));
        let applied = i64::from(last.duty.raw()) * v / 65_536;
        assert!(applied >= e && applied <= e + 10, "{applied} mV against {e} mV");
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

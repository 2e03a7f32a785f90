//! The boundary to hardware: one [`Inputs`] snapshot in, one [`Outputs`] snapshot out, per
//! 1 ms control tick.
//!
//! # Theory of operation
//!
//! Everything the machine decides is a function of what it has been told through [`Inputs`];
//! everything it wants done leaves through [`Outputs`]. The firmware's whole job is to fill
//! the first from the peripherals and apply the second to them; the digital twin does the
//! same from its physics model; tests and the fuzzer write them directly. Nothing in the core
//! reads a register or a clock on its own, so every behaviour can be replayed exactly.
//!
//! Values cross the boundary raw — converter codes, counter values, switch levels — and are
//! given meaning inside the core ([`crate::sense`]), so a board and its twin cannot disagree
//! on a scale factor.
//!
//! The fast commutation loop has its own, narrower boundary ([`crate::drive::DriveSample`] →
//! [`crate::drive::DriveOutput`]); the tick sees its result as [`Inputs::drive`] and steers
//! it through [`Outputs::drive`].

use crate::drive::{DriveCommand, DriveStatus};
use crate::units::AdcCode;

/// The two carriage limit switches, `true` = actuated.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct LimitSwitches {
    /// The home (fully released) end of travel, where a release stops.
    pub home: bool,
    /// The far end of travel, beyond which a pull must not go.
    pub end: bool,
}

impl LimitSwitches {
    /// All four combinations, for exhaustive checks.
    pub const ALL: [Self; 4] = [
        Self { home: false, end: false },
        Self { home: true, end: false },
        Self { home: false, end: true },
        Self { home: true, end: true },
    ];

    /// Both actuated at once: impossible mechanically, so a wiring fault.
    #[must_use]
    pub const fn both(&self) -> bool {
        self.home && self.end
    }
}

/// A key on the front panel.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Key {
    /// Start a pull; during a pull or hold, release.
    Start,
    /// Increase the selected value.
    Up,
    /// Decrease the selected value.
    Down,
    /// Step through the settings (speed, pre-stretch, knot, unit); hold in the calibration
    /// window to calibrate.
    Function,
    /// Recall / store a preset.
    Preset,
}

impl Key {
    /// Every key.
    pub const ALL: [Self; 5] = [Self::Start, Self::Up, Self::Down, Self::Function, Self::Preset];

    #[inline(always)]
    const fn mask(self) -> u8 {
        match self {
            Self::Start => 1,
            Self::Up => 2,
            Self::Down => 4,
            Self::Function => 8,
            Self::Preset => 16,
        }
    }
}

/// The set of keys whose contacts are closed right now (raw levels, not debounced).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Keys(u8);

impl Keys {
    /// No key pressed.
    pub const NONE: Self = Self(0);

    /// From a raw bit set (bit 0 Start, 1 Up, 2 Down, 3 Function, 4 Preset); unknown bits
    /// are dropped.
    #[must_use]
    pub const fn from_bits(bits: u8) -> Self {
        Self(bits & 0b1_1111)
    }

    /// The raw bit set.
    #[must_use]
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Whether `key` is down.
    #[must_use]
    #[inline(always)]
    pub const fn contains(self, key: Key) -> bool {
        self.0 & key.mask() != 0
    }

    /// This set with `key` down.
    #[must_use]
    #[inline]
    pub const fn with(self, key: Key) -> Self {
        Self(self.0 | key.mask())
    }

    /// Whether no key is down.
    #[must_use]
    #[inline]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
}

/// One 7-segment digit as a bitmap: bit 0 = segment a (top), 1 = b, 2 = c, 3 = d (bottom),
/// 4 = e, 5 = f, 6 = g (middle), 7 = decimal point — the order of TM1637/MAX7219 drivers.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Segments(pub u8);

/// The four-digit display, leftmost digit first.
pub type Display = [Segments; 4];

/// The panel's indicator lamps.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Leds {
    /// The displayed tension is in kilograms.
    pub kg: bool,
    /// The displayed tension is in pounds.
    pub lb: bool,
    /// The motor is pulling.
    pub pulling: bool,
    /// Tension reached and held.
    pub holding: bool,
    /// A fault is latched.
    pub fault: bool,
    /// Knot mode: the next pull is a knot pull (set tension plus the knot boost).
    pub knot: bool,
}

/// Everything the machine learns in one tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Inputs {
    /// Milliseconds since power-up, from the tick counter (wraps after 49.7 days; the core
    /// only ever takes wrapping differences).
    pub now_ms: u32,
    /// The load-cell amplifier's converter code.
    pub load_cell: AdcCode,
    /// The motor (bus) current converter code, averaged over the tick.
    pub motor_current: AdcCode,
    /// The DC bus voltage's converter code, through the power board's divider (averaged over
    /// the tick; its scale is part of the board's configuration).
    pub bus_voltage: AdcCode,
    /// The fast loop's report: fault, Hall step count, rotation.
    pub drive: DriveStatus,
    /// The string-length counter: the quadrature timer's count (wraps at 65 536).
    pub string_counter: u16,
    /// The carriage limit switches.
    pub limits: LimitSwitches,
    /// Raw key levels.
    pub keys: Keys,
}

/// Everything the machine wants done after one tick.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Default)]
pub struct Outputs {
    /// The command for the fast loop.
    pub drive: DriveCommand,
    /// Ask the fast loop to clear its latched fault (only honoured with a coast command).
    pub clear_drive_fault: bool,
    /// The 7-segment display.
    pub display: Display,
    /// The indicator lamps.
    pub leds: Leds,
    /// The beeper sounds while `true`.
    pub beeper: bool,
    /// The persisted record changed: write it to flash when convenient.
    pub store: bool,
}

//! The link's messages: what a host may ask ([`Request`]) and what the machine sends
//! ([`Response`]: replies, live samples and events).
//!
//! # Theory of operation
//!
//! Every message fits one frame ([`crate::frame::MAX_PAYLOAD`]): the pull log is read a page
//! of [`LOG_PAGE_ENTRIES`] entries at a time, the stored record a part of [`RECORD_PART_LEN`]
//! bytes at a time. Values cross the link as integers with their unit in the field name;
//! nothing is a float. The set of requests is the whole of what a host can do: reads, and
//! proposals of settings, a preset or a whole record (restore), which the machine accepts
//! only while it idles in Ready. **No request starts a pull, releases, clears a fault or
//! changes a target**; [`Request::effect`] classifies each, and it has no motion case
//! (REQ-LINK-02).
//!
//! The protocol's version is [`PROTOCOL_VERSION`]; a host checks it in the
//! [`Identity`] that answers [`Request::Hello`] before it sends anything else.

use serde::{Deserialize, Serialize};
use taut_core::machine::{FaultCode, MachineState, PullRecord};
use taut_core::settings::{Preferences, SetPoint, Settings, SettingsError, Unit};

/// The protocol's version: raised with any change to a message's encoding.
pub const PROTOCOL_VERSION: u16 = 1;

/// Pull-log entries in one [`LogPage`].
pub const LOG_PAGE_ENTRIES: usize = 4;

/// Bytes of the stored record in one [`Response::RecordPart`] or [`Request::StageRecord`].
pub const RECORD_PART_LEN: usize = 32;

/// Parts of the stored record: its length over [`RECORD_PART_LEN`] (the record's length
/// is core's, so a longer record format needs no change here).
#[allow(
    clippy::cast_possible_truncation,
    clippy::as_conversions,
    reason = "the assertion below bounds the quotient to a byte"
)]
pub const RECORD_PARTS: u8 = (taut_core::store::RECORD_LEN / RECORD_PART_LEN) as u8;
const _: () = assert!(
    taut_core::store::RECORD_LEN.is_multiple_of(RECORD_PART_LEN)
        && taut_core::store::RECORD_LEN / RECORD_PART_LEN <= 255,
    "the record splits into whole parts, at most 255"
);

/// The shortest period of the live samples, ms (50 samples a second).
pub const SAMPLE_PERIOD_MIN_MS: u16 = 20;

/// A board's identity: the MCU's 96-bit unique id (on the twin, one derived from its
/// configuration).
pub type BoardId = [u8; 12];

/// A request on the wire: the host's sequence number, which the reply echoes so that a host
/// can tell its reply from a late one to an earlier request.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct Command {
    /// The host's sequence number.
    pub seq: u16,
    /// The request.
    pub request: Request,
}

/// A frame from the machine: a reply to the command numbered `reply_to`, or (`None`) a
/// sample, an event or the refusal of a frame that did not decode.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct Message {
    /// The command this answers.
    pub reply_to: Option<u16>,
    /// The reply, sample or event.
    pub response: Response,
}

/// What a host may ask.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub enum Request {
    /// Who are you: answered by [`Response::Identity`].
    Hello,
    /// Page `page` of the pull log, latest first ([`Response::LogPage`]).
    ReadLog {
        /// 0 = the latest [`LOG_PAGE_ENTRIES`] pulls.
        page: u8,
    },
    /// The counters and the settings in use ([`Response::Status`]).
    ReadStatus,
    /// Preset `index` (0–8, the panel's P 1–P 9) ([`Response::Preset`]).
    ReadPreset {
        /// 0-based preset.
        index: u8,
    },
    /// Part `part` (0–3) of the stored record ([`Response::RecordPart`]).
    ReadRecord {
        /// 0-based part.
        part: u8,
    },
    /// The fault latched now and the faults since power-up ([`Response::Faults`]).
    ReadFaults,
    /// Live samples every `period_ms` (0 = off; shorter than [`SAMPLE_PERIOD_MIN_MS`] is
    /// raised to it) and events; answered by [`Response::Accepted`].
    Stream {
        /// Sample period, ms.
        period_ms: u16,
    },
    /// Propose the working settings and the preferences.
    WriteSettings {
        /// The settings.
        settings: WireSettings,
        /// The preferences.
        preferences: WirePreferences,
    },
    /// Propose preset `index`.
    WritePreset {
        /// 0-based preset.
        index: u8,
        /// Its settings.
        settings: WireSettings,
    },
    /// Stage part `part` of a record to restore (nothing changes until
    /// [`Request::CommitRecord`]).
    StageRecord {
        /// 0-based part.
        part: u8,
        /// Its bytes.
        bytes: [u8; RECORD_PART_LEN],
    },
    /// Propose the staged record (all parts staged since the last commit): settings,
    /// presets, preferences and calibration; the machine keeps its counters.
    CommitRecord,
}

/// What a request may do to the machine.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Effect {
    /// Nothing: a read.
    Read,
    /// Changes what the link sends (sampling), not the machine.
    Link,
    /// Stages bytes in the link's own buffer.
    Stage,
    /// Proposes a record change, which the machine accepts only idle in Ready.
    ProposeRecord,
}

impl Request {
    /// What this request may do. There is no motion case: no request reaches the drive, the
    /// keys or a state transition (REQ-LINK-02).
    #[must_use]
    pub const fn effect(&self) -> Effect {
        match self {
            Self::Hello
            | Self::ReadLog { .. }
            | Self::ReadStatus
            | Self::ReadPreset { .. }
            | Self::ReadRecord { .. }
            | Self::ReadFaults => Effect::Read,
            Self::Stream { .. } => Effect::Link,
            Self::StageRecord { .. } => Effect::Stage,
            Self::WriteSettings { .. } | Self::WritePreset { .. } | Self::CommitRecord => {
                Effect::ProposeRecord
            }
        }
    }
}

/// What the machine sends.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub enum Response {
    /// The answer to [`Request::Hello`].
    Identity(Identity),
    /// A page of the pull log.
    LogPage(LogPage),
    /// The counters and settings in use.
    Status(Status),
    /// A preset.
    Preset {
        /// 0-based preset.
        index: u8,
        /// Its settings.
        settings: WireSettings,
    },
    /// A part of the stored record.
    RecordPart {
        /// 0-based part.
        part: u8,
        /// Its bytes.
        bytes: [u8; RECORD_PART_LEN],
    },
    /// The fault latched now and the faults since power-up.
    Faults(Faults),
    /// The request was carried out.
    Accepted,
    /// The request was refused; nothing changed.
    Refused(Refusal),
    /// A live sample (while streaming).
    Sample(LiveSample),
    /// An event (while streaming).
    Event(Event),
}

/// Why a request was refused.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Serialize, Deserialize)]
pub enum Refusal {
    /// The frame did not decode (stuffing, CRC, not a request, too long).
    BadFrame,
    /// The machine is not idling in Ready: writes wait for the panel to be idle.
    NotIdle,
    /// A setting is out of its range.
    Settings(WireSettingsError),
    /// The calibration points do not make a valid calibration.
    InvalidCalibration,
    /// The staged record is incomplete or does not decode (format, checksum).
    InvalidRecord,
    /// No such log page, preset or record part.
    OutOfRange,
}

/// A setting's error, as [`SettingsError`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Serialize, Deserialize)]
pub enum WireSettingsError {
    /// The tension is out of range or off its unit's step.
    Tension,
    /// The speed is not 1–9.
    Speed,
    /// The pre-stretch is above 30 %.
    PreStretch,
    /// The knot boost is above 20 %.
    KnotBoost,
}

impl From<SettingsError> for WireSettingsError {
    fn from(error: SettingsError) -> Self {
        match error {
            SettingsError::TensionOutOfRange => Self::Tension,
            SettingsError::SpeedOutOfRange => Self::Speed,
            SettingsError::PreStretchOutOfRange => Self::PreStretch,
            SettingsError::KnotBoostOutOfRange => Self::KnotBoost,
        }
    }
}

/// The answer to [`Request::Hello`].
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct Identity {
    /// [`PROTOCOL_VERSION`] of the machine.
    pub protocol: u16,
    /// The firmware's version, major.minor.patch.
    pub firmware: [u8; 3],
    /// The board.
    pub board: BoardId,
    /// The stored record's format version.
    pub record_format: u8,
    /// Power-ups counted in the record.
    pub boots: u32,
    /// Pulls counted in the record.
    pub pulls: u32,
    /// Whether the machine holds a calibration.
    pub calibrated: bool,
    /// Pulls since the calibration was accepted, when the record knows it (`None` with no
    /// calibration, or one migrated from a format that did not stamp it).
    pub calibration_age_pulls: Option<u32>,
}

/// One pull of the log, in the log's own resolution.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, Serialize, Deserialize)]
pub struct LogEntry {
    /// The pull's number (the pull counter when it completed).
    pub pull: u32,
    /// The tension held at the end, hundredths of a kgf.
    pub target_centi_kgf: i16,
    /// The tension measured at release, hundredths of a kgf.
    pub reached_centi_kgf: i16,
    /// The highest tension of the pull, hundredths of a kgf.
    pub peak_centi_kgf: i16,
    /// The hold's adjustment, hundredths of a kgf.
    pub adjust_centi_kgf: i16,
    /// From Start to at tension, ms.
    pub time_to_tension_ms: u16,
    /// Hold time, s.
    pub held_s: u16,
    /// String drawn, mm.
    pub string_mm: u16,
    /// The string's stiffness near the set tension, thousandths of a kgf per mm.
    pub stiffness_milli_kgf_per_mm: Option<u16>,
    /// The creep in the hold, hundredths of a per cent per minute.
    pub creep_centi_percent_per_min: Option<u16>,
}

impl LogEntry {
    /// The entry for `record`, pull number `pull`.
    #[must_use]
    pub fn from_record(pull: u32, record: &PullRecord) -> Self {
        Self {
            pull,
            target_centi_kgf: record.target.hundredths(),
            reached_centi_kgf: record.reached.hundredths(),
            peak_centi_kgf: record.peak.hundredths(),
            adjust_centi_kgf: record.adjust.hundredths(),
            time_to_tension_ms: record.time_to_tension_ms,
            held_s: record.held_s,
            string_mm: record.string_mm,
            stiffness_milli_kgf_per_mm: record.stiffness.map(|k| k.milli()),
            creep_centi_percent_per_min: record.creep.map(|c| c.centi_percent_per_minute()),
        }
    }
}

/// A page of the pull log.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct LogPage {
    /// The page asked for.
    pub page: u8,
    /// Entries in the whole log.
    pub total: u8,
    /// This page's entries, latest first; `None` past the log's end.
    pub entries: [Option<LogEntry>; LOG_PAGE_ENTRIES],
}

/// The tension set point's unit.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Serialize, Deserialize)]
pub enum WireUnit {
    /// Kilograms.
    Kilograms,
    /// Pounds.
    Pounds,
}

/// Settings as the operator's raw numbers (validated by core's [`Settings::new`] on arrival).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Serialize, Deserialize)]
pub struct WireSettings {
    /// The set point's unit.
    pub unit: WireUnit,
    /// The set point, tenths of the unit.
    pub tension_tenths: u16,
    /// Speed 1–9.
    pub speed: u8,
    /// Pre-stretch, per cent.
    pub pre_stretch_percent: u8,
    /// Knot boost, per cent.
    pub knot_percent: u8,
}

impl From<Settings> for WireSettings {
    fn from(settings: Settings) -> Self {
        let set_point = settings.set_point();
        Self {
            unit: match set_point.unit() {
                Unit::Kilograms => WireUnit::Kilograms,
                Unit::Pounds => WireUnit::Pounds,
            },
            tension_tenths: set_point.tenths(),
            speed: settings.speed().get(),
            pre_stretch_percent: settings.pre_stretch().percent(),
            knot_percent: settings.knot().percent(),
        }
    }
}

impl WireSettings {
    /// These settings through core's validation.
    ///
    /// # Errors
    /// The first field out of range.
    pub fn to_settings(self) -> Result<Settings, WireSettingsError> {
        let unit = match self.unit {
            WireUnit::Kilograms => Unit::Kilograms,
            WireUnit::Pounds => Unit::Pounds,
        };
        let set_point = SetPoint::new(unit, self.tension_tenths)?;
        Ok(Settings::new(set_point, self.speed, self.pre_stretch_percent, self.knot_percent)?)
    }
}

/// The machine's preferences.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Serialize, Deserialize)]
pub struct WirePreferences {
    /// The beeper sounds clicks and tones.
    pub beeper: bool,
    /// Holds pull constantly by default.
    pub constant_pull: bool,
}

impl From<Preferences> for WirePreferences {
    fn from(preferences: Preferences) -> Self {
        Self { beeper: preferences.beeper, constant_pull: preferences.constant_pull }
    }
}

impl From<WirePreferences> for Preferences {
    fn from(wire: WirePreferences) -> Self {
        Self { beeper: wire.beeper, constant_pull: wire.constant_pull }
    }
}

/// The counters and settings in use.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct Status {
    /// The machine's state.
    pub state: WireState,
    /// Pulls completed in the machine's life.
    pub pulls: u32,
    /// String drawn in the machine's life, mm.
    pub string_used_mm: u32,
    /// Power-ups.
    pub boots: u32,
    /// The working settings.
    pub settings: WireSettings,
    /// The preferences.
    pub preferences: WirePreferences,
}

/// The fault latched now and the faults since power-up.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct Faults {
    /// The latched fault's number (`E-nn`), if any.
    pub latched: Option<u8>,
    /// The last faults since power-up, the latest first.
    pub history: [Option<u8>; 3],
}

/// A machine state on the link (fault codes by their `E-nn` number).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, Serialize, Deserialize)]
pub enum WireState {
    /// Self-test.
    SelfTest,
    /// Motor test.
    MotorTest,
    /// Homing.
    Homing,
    /// Calibration window.
    CalibrationWindow,
    /// Calibration pull to reading `0`.
    CalibrationPull(u8),
    /// Calibration entry of reading `0`.
    CalibrationEntry(u8),
    /// Ready.
    Ready,
    /// Pulling.
    Pulling,
    /// Holding.
    Holding,
    /// Releasing.
    Releasing,
    /// Fault `E-nn`.
    Fault(u8),
}

impl From<MachineState> for WireState {
    fn from(state: MachineState) -> Self {
        match state {
            MachineState::SelfTest => Self::SelfTest,
            MachineState::MotorTest => Self::MotorTest,
            MachineState::Homing => Self::Homing,
            MachineState::CalibrationWindow => Self::CalibrationWindow,
            MachineState::CalibrationPull { point } => Self::CalibrationPull(point),
            MachineState::CalibrationEntry { point } => Self::CalibrationEntry(point),
            MachineState::Ready => Self::Ready,
            MachineState::Pulling => Self::Pulling,
            MachineState::Holding => Self::Holding,
            MachineState::Releasing => Self::Releasing,
            MachineState::Fault(code) => Self::Fault(code.number()),
        }
    }
}

impl WireState {
    /// The machine state, if the fault number is one of this firmware's.
    #[must_use]
    pub fn to_state(self) -> Option<MachineState> {
        Some(match self {
            Self::SelfTest => MachineState::SelfTest,
            Self::MotorTest => MachineState::MotorTest,
            Self::Homing => MachineState::Homing,
            Self::CalibrationWindow => MachineState::CalibrationWindow,
            Self::CalibrationPull(point) => MachineState::CalibrationPull { point },
            Self::CalibrationEntry(point) => MachineState::CalibrationEntry { point },
            Self::Ready => MachineState::Ready,
            Self::Pulling => MachineState::Pulling,
            Self::Holding => MachineState::Holding,
            Self::Releasing => MachineState::Releasing,
            Self::Fault(number) => {
                MachineState::Fault(FaultCode::ALL.into_iter().find(|c| c.number() == number)?)
            }
        })
    }
}

/// One live sample.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct LiveSample {
    /// The machine's clock, ms.
    pub time_ms: u32,
    /// The state.
    pub state: WireState,
    /// The pull's target, thousandths of a kgf.
    pub target_milli_kgf: i32,
    /// The filtered tension the machine shows, thousandths of a kgf.
    pub tension_milli_kgf: i32,
    /// The carriage's position, Hall steps from power-up.
    pub carriage_steps: i32,
    /// The commanded duty, 1/65 536 of the PWM period.
    pub duty_raw: u16,
    /// The motor current, mA.
    pub current_milli_amps: i32,
    /// The bus voltage, mV.
    pub bus_milli_volts: i32,
}

/// The raw inputs of the tick that latched a fault.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub struct InputSnapshot {
    /// The load cell's ADC code.
    pub load_cell_code: u16,
    /// The motor-current ADC code.
    pub motor_current_code: u16,
    /// The bus-voltage ADC code.
    pub bus_voltage_code: u16,
    /// The carriage's Hall count.
    pub carriage_steps: i32,
    /// The motor current the drive measured, mA.
    pub current_milli_amps: i32,
    /// The bus voltage the drive measured, mV.
    pub bus_milli_volts: i32,
    /// The home limit switch.
    pub home_limit: bool,
    /// The end limit switch.
    pub end_limit: bool,
    /// Whether the drive had latched a fault of its own.
    pub drive_fault: bool,
}

/// An event.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Serialize, Deserialize)]
pub enum Event {
    /// The machine entered `to`.
    State {
        /// The machine's clock, ms.
        time_ms: u32,
        /// The state left.
        from: WireState,
        /// The state entered.
        to: WireState,
    },
    /// A fault latched, with the inputs of the tick that latched it.
    Fault {
        /// The machine's clock, ms.
        time_ms: u32,
        /// `E-nn`.
        code: u8,
        /// The inputs.
        inputs: InputSnapshot,
    },
    /// A pull completed and was logged.
    Logged(LogEntry),
    /// Samples or events were dropped because the line was full.
    Dropped {
        /// How many messages since the last report.
        count: u16,
    },
}

//! taut-tick-cost: what the firmware's real-time code costs on the Cortex-M4, measured.
//!
//! # Theory of operation
//!
//! There is no board to put a scope on, so the cost of the control tick is measured on the
//! instruction set instead: a **session** of the real machine is recorded on the host — the
//! digital twin (`taut-sim`) driven by `taut_core::machine::Machine`, worked by the main job's
//! simulated operator (boot, ready, settings keyed in and stored, pull, hold, release) — as
//! the [`Inputs`] the machine was given on every tick. The thumb replay binary
//! (`src/bin/replay.rs`) embeds that recording, builds the machine from the same stored
//! record, feeds it the same inputs through `taut-core` compiled exactly as the firmware
//! compiles it (`--profile firmware`, `thumbv7em-none-eabihf`), and counts the instructions of
//! every [`Machine::tick`], of every [`Drive::step`] and of every [`Record::encode`] under
//! QEMU (`scripts/tick-cost` explains the counting and its error).
//!
//! The replayed machine must make the same decisions as the recorded one, or the numbers are
//! not the session's: the recorder folds every tick's [`Outputs`] into a fingerprint
//! ([`fold_outputs`]) stored in the session header, and the replay recomputes it.
//!
//! # The drive
//!
//! The twin steps its own drive 20 times per tick with Hall codes the replay cannot see, so
//! the replay drives a [`Drive`] of its own: each tick it is commanded with the replayed
//! machine's [`Outputs::drive`] (and fault clear), then stepped once per PWM period (20 per
//! tick) with a Hall code rebuilt from the recorded Hall step count — the steps the twin's
//! drive counted during the tick ([`DriveStatus::steps`] of the next tick minus this one's),
//! spread evenly over the 20 periods — and the tick's current code and limit switches. The
//! calls therefore follow the machine's own commands and the rotor's recorded motion; what
//! they lack is the twin's Hall noise and its per-period current ripple.
//!
//! # The session format
//!
//! A header ([`HEADER_LEN`] bytes: magic, the per-tick record length, the tick count, the
//! expected fingerprint and store count, and the record the machine booted from), then one
//! fixed-size record of [`INPUTS_LEN`] bytes per tick, little-endian, written by
//! [`encode_inputs`] and read by [`decode_inputs`]. Those two functions destructure and build
//! [`Inputs`] field by field without `..`, so a field added to `Inputs` stops the build right
//! there: extend both (and [`INPUTS_LEN`]) and the recorder and replay follow.
#![no_std]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::arithmetic_side_effects,
        reason = "unit tests: a failed unwrap, index or overflow panics the test, which is the \
                  report we want"
    )
)]

use taut_core::drive::{
    Direction, Drive, DriveCommand, DriveFault, DriveOutput, DriveSample, DriveStatus, DriveTime,
    Sector,
};
use taut_core::io::{Inputs, Keys, LimitSwitches, Outputs};
use taut_core::machine::{Machine, MachineState};
use taut_core::store::{RECORD_LEN, Record};
use taut_core::units::{AdcCode, Amps, Volts};

/// The session file's first bytes.
pub const MAGIC: [u8; 8] = *b"TAUTSES1";

/// Bytes of one tick's [`Inputs`] in the session.
pub const INPUTS_LEN: usize = 33;

/// Bytes of the session header: magic (8), per-tick length (u16) and a reserved u16, tick
/// count (u32), fingerprint (u32), store count (u32), the boot record ([`RECORD_LEN`]).
pub const HEADER_LEN: usize = 24 + RECORD_LEN;

/// PWM periods per 1 ms tick: the fast-loop calls the replay makes per tick.
pub const PERIODS_PER_TICK: u32 = PWM_FREQUENCY_HZ / 1_000;

/// The firmware's PWM frequency, 20 kHz (`firmware/src/timing.rs`: this crate links only core).
pub const PWM_FREQUENCY_HZ: u32 = 20_000;

/// One PWM period in the drive's time: 50 µs.
pub const PWM_PERIOD: DriveTime = DriveTime::from_micros(1_000_000 / PWM_FREQUENCY_HZ);

/// [`PERIODS_PER_TICK`] as a signed step count.
#[allow(clippy::cast_possible_wrap, reason = "20 periods; checked below")]
const PERIODS: i32 = PERIODS_PER_TICK as i32;
const _: () = assert!(PERIODS_PER_TICK > 0 && PERIODS_PER_TICK < 1_000, "PERIODS is exact");

/// A little-endian writer over a fixed buffer; writes past the end are dropped (the tests
/// check that every encoder fills its buffer exactly).
struct Writer<'a> {
    bytes: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, value: &[u8]) {
        for &byte in value {
            if let Some(slot) = self.bytes.get_mut(self.at) {
                *slot = byte;
            }
            self.at = self.at.saturating_add(1);
        }
    }
    fn u8(&mut self, value: u8) {
        self.put(&[value]);
    }
    fn u16(&mut self, value: u16) {
        self.put(&value.to_le_bytes());
    }
    fn u32(&mut self, value: u32) {
        self.put(&value.to_le_bytes());
    }
    fn i32(&mut self, value: i32) {
        self.put(&value.to_le_bytes());
    }
}

/// A little-endian reader; reads past the end give zeros.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0; N];
        for slot in &mut out {
            *slot = self.bytes.get(self.at).copied().unwrap_or(0);
            self.at = self.at.saturating_add(1);
        }
        out
    }
    fn u8(&mut self) -> u8 {
        u8::from_le_bytes(self.take())
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
}

const fn direction_code(direction: Option<Direction>) -> u8 {
    match direction {
        None => 0,
        Some(Direction::Pull) => 1,
        Some(Direction::Release) => 2,
    }
}

const fn direction_from(code: u8) -> Option<Direction> {
    match code {
        1 => Some(Direction::Pull),
        2 => Some(Direction::Release),
        _ => None,
    }
}

/// A drive fault's byte: its number in core's table, 0 for none.
const fn fault_code(fault: Option<DriveFault>) -> u8 {
    match fault {
        None => 0,
        Some(fault) => fault.number(),
    }
}

/// The drive fault a byte stands for (core's table; 0 or an unknown number: none).
const fn fault_from(code: u8) -> Option<DriveFault> {
    DriveFault::from_number(code)
}

/// One tick's [`Inputs`] as bytes. The destructuring names every field: a new field in
/// `Inputs` does not compile until it is written here (and read in [`decode_inputs`]).
#[must_use]
pub fn encode_inputs(inputs: &Inputs) -> [u8; INPUTS_LEN] {
    let Inputs {
        now_ms,
        load_cell,
        motor_current,
        bus_voltage,
        drive,
        string_counter,
        limits,
        keys,
    } = *inputs;
    let DriveStatus { fault, steps, rotation, quiet_for, energized, current, bus } = drive;
    let mut bytes = [0; INPUTS_LEN];
    let mut out = Writer { bytes: &mut bytes, at: 0 };
    out.u32(now_ms);
    out.u16(load_cell.get());
    out.u16(motor_current.get());
    out.u16(bus_voltage.get());
    out.u8(fault_code(fault));
    out.i32(steps);
    out.u8(direction_code(rotation));
    out.u32(quiet_for.0);
    out.u8(direction_code(energized));
    out.i32(current.to_bits());
    out.i32(bus.to_bits());
    out.u16(string_counter);
    out.u8(u8::from(limits.home) | (u8::from(limits.end) << 1));
    out.u8(keys.bits());
    bytes
}

/// The [`Inputs`] [`encode_inputs`] wrote. Total: unknown codes read as `None`.
#[must_use]
pub fn decode_inputs(bytes: &[u8]) -> Inputs {
    let mut input = Reader { bytes, at: 0 };
    let now_ms = input.u32();
    let load_cell = AdcCode::new(input.u16());
    let motor_current = AdcCode::new(input.u16());
    let bus_voltage = AdcCode::new(input.u16());
    let fault = fault_from(input.u8());
    let steps = input.i32();
    let rotation = direction_from(input.u8());
    let quiet_for = DriveTime(input.u32());
    let energized = direction_from(input.u8());
    let current = Amps::from_bits(input.i32());
    let bus = Volts::from_bits(input.i32());
    let string_counter = input.u16();
    let limit_bits = input.u8();
    let keys = Keys::from_bits(input.u8());
    Inputs {
        now_ms,
        load_cell,
        motor_current,
        bus_voltage,
        drive: DriveStatus { fault, steps, rotation, quiet_for, energized, current, bus },
        string_counter,
        limits: LimitSwitches { home: limit_bits & 1 != 0, end: limit_bits & 2 != 0 },
        keys,
    }
}

/// FNV-1a, one byte.
fn fnv(hash: u32, byte: u8) -> u32 {
    (hash ^ u32::from(byte)).wrapping_mul(0x0100_0193)
}

/// The fingerprint before any tick.
pub const FINGERPRINT_START: u32 = 0x811C_9DC5;

/// Folds one tick's [`Outputs`] into the running fingerprint (every field, by name).
#[must_use]
pub fn fold_outputs(hash: u32, outputs: &Outputs) -> u32 {
    let Outputs { drive, clear_drive_fault, display, leds, beeper, store } = *outputs;
    let (tag, direction, duty) = match drive {
        DriveCommand::Coast => (0, 0, 0),
        DriveCommand::Drive { direction, duty } => (1, direction_code(Some(direction)), duty.raw()),
    };
    let [duty_low, duty_high] = duty.to_le_bytes();
    let lamps = [leds.kg, leds.lb, leds.pulling, leds.holding, leds.fault, leds.knot]
        .iter()
        .enumerate()
        .fold(0u8, |bits, (index, &on)| bits | (u8::from(on) << index));
    let [d0, d1, d2, d3] = display;
    let fields = [
        tag,
        direction,
        duty_low,
        duty_high,
        u8::from(clear_drive_fault),
        d0.0,
        d1.0,
        d2.0,
        d3.0,
        lamps,
        u8::from(beeper),
        u8::from(store),
    ];
    fields.iter().fold(hash, |hash, &byte| fnv(hash, byte))
}

/// What the header of a recorded session says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Ticks recorded.
    pub ticks: u32,
    /// [`fold_outputs`] over every tick's outputs, from [`FINGERPRINT_START`].
    pub fingerprint: u32,
    /// Ticks whose outputs asked to store the record.
    pub stores: u32,
    /// The encoded record the machine booted from.
    pub boot_record: [u8; RECORD_LEN],
}

/// Why a session file cannot be replayed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SessionError {
    /// Not a session file (magic).
    Magic,
    /// Recorded with a different per-tick length (a different `Inputs`): record it again.
    InputsLength,
    /// Shorter than its header says.
    Truncated,
}

/// A header as bytes.
#[must_use]
pub fn encode_header(header: &Header) -> [u8; HEADER_LEN] {
    let Header { ticks, fingerprint, stores, boot_record } = *header;
    let mut bytes = [0; HEADER_LEN];
    let mut out = Writer { bytes: &mut bytes, at: 0 };
    out.put(&MAGIC);
    out.u16(u16::try_from(INPUTS_LEN).unwrap_or(u16::MAX));
    out.u16(0);
    out.u32(ticks);
    out.u32(fingerprint);
    out.u32(stores);
    out.put(&boot_record);
    bytes
}

/// A recorded session: its header and its ticks.
#[derive(Clone, Copy, Debug)]
pub struct Session<'a> {
    /// The header.
    pub header: Header,
    ticks: &'a [u8],
}

impl<'a> Session<'a> {
    /// Reads a session file.
    ///
    /// # Errors
    /// A wrong magic or per-tick length, or a file shorter than its tick count.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, SessionError> {
        let (head, ticks) = bytes.split_at_checked(HEADER_LEN).ok_or(SessionError::Truncated)?;
        let mut input = Reader { bytes: head, at: 0 };
        if input.take::<8>() != MAGIC {
            return Err(SessionError::Magic);
        }
        if usize::from(input.u16()) != INPUTS_LEN {
            return Err(SessionError::InputsLength);
        }
        let _reserved = input.u16();
        let header = Header {
            ticks: input.u32(),
            fingerprint: input.u32(),
            stores: input.u32(),
            boot_record: input.take(),
        };
        let needed = usize::try_from(header.ticks)
            .ok()
            .and_then(|ticks| ticks.checked_mul(INPUTS_LEN))
            .ok_or(SessionError::Truncated)?;
        let ticks = ticks.get(..needed).ok_or(SessionError::Truncated)?;
        Ok(Self { header, ticks })
    }

    /// Every tick's inputs, in order.
    pub fn inputs(&self) -> impl Iterator<Item = Inputs> + 'a {
        self.ticks.chunks_exact(INPUTS_LEN).map(decode_inputs)
    }
}

/// A machine state without its data, to group ticks by.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum StateKind {
    /// [`MachineState::SelfTest`].
    SelfTest,
    /// [`MachineState::MotorTest`].
    MotorTest,
    /// [`MachineState::Homing`].
    Homing,
    /// [`MachineState::CalibrationWindow`].
    CalibrationWindow,
    /// [`MachineState::CalibrationPull`].
    CalibrationPull,
    /// [`MachineState::CalibrationEntry`].
    CalibrationEntry,
    /// [`MachineState::Ready`].
    Ready,
    /// [`MachineState::Pulling`].
    Pulling,
    /// [`MachineState::Holding`].
    Holding,
    /// [`MachineState::Releasing`].
    Releasing,
    /// [`MachineState::Fault`].
    Fault,
}

impl StateKind {
    /// Every kind, in the order the table lists them.
    pub const ALL: [Self; 11] = [
        Self::SelfTest,
        Self::MotorTest,
        Self::Homing,
        Self::CalibrationWindow,
        Self::CalibrationPull,
        Self::CalibrationEntry,
        Self::Ready,
        Self::Pulling,
        Self::Holding,
        Self::Releasing,
        Self::Fault,
    ];

    /// The kind of `state`.
    #[must_use]
    pub const fn of(state: MachineState) -> Self {
        match state {
            MachineState::SelfTest => Self::SelfTest,
            MachineState::MotorTest => Self::MotorTest,
            MachineState::Homing => Self::Homing,
            MachineState::CalibrationWindow => Self::CalibrationWindow,
            MachineState::CalibrationPull { .. } => Self::CalibrationPull,
            MachineState::CalibrationEntry { .. } => Self::CalibrationEntry,
            MachineState::Ready => Self::Ready,
            MachineState::Pulling => Self::Pulling,
            MachineState::Holding => Self::Holding,
            MachineState::Releasing => Self::Releasing,
            MachineState::Fault(_) => Self::Fault,
        }
    }

    /// Its position in [`StateKind::ALL`].
    #[must_use]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Its name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::SelfTest => "SelfTest",
            Self::MotorTest => "MotorTest",
            Self::Homing => "Homing",
            Self::CalibrationWindow => "CalibrationWindow",
            Self::CalibrationPull => "CalibrationPull",
            Self::CalibrationEntry => "CalibrationEntry",
            Self::Ready => "Ready",
            Self::Pulling => "Pulling",
            Self::Holding => "Holding",
            Self::Releasing => "Releasing",
            Self::Fault => "Fault",
        }
    }
}

/// What one measured call was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Call {
    /// [`Machine::tick`], started in this state.
    Tick(StateKind),
    /// [`Drive::step`].
    DriveStep,
    /// [`Record::encode`] of a record the machine asked to store.
    Encode,
}

/// Runs and measures the calls of the replay. The replay binary's meter counts instructions
/// and stack under QEMU; a host meter may only run them.
pub trait Meter {
    /// Runs `call` (one [`Call`]) and returns what it returned.
    fn measure<R>(&mut self, what: Call, call: impl FnOnce() -> R) -> R;
}

/// One machine tick, never inlined into the replay loop, so its stack frames sit below the
/// loop's and the painted stack sees them (the firmware calls it from its tick interrupt).
#[inline(never)]
pub fn tick_call(machine: &mut Machine, inputs: &Inputs) -> Outputs {
    machine.tick(inputs)
}

/// One fast-loop step, never inlined (see [`tick_call`]).
#[inline(never)]
pub fn drive_call(drive: &mut Drive, sample: DriveSample) -> DriveOutput {
    drive.step(sample)
}

/// One record encode, never inlined (see [`tick_call`]).
#[inline(never)]
pub fn encode_call(record: &Record) -> [u8; RECORD_LEN] {
    record.encode()
}

/// What a replay found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Replayed {
    /// Ticks replayed.
    pub ticks: u32,
    /// [`fold_outputs`] over every replayed tick.
    pub fingerprint: u32,
    /// Store requests.
    pub stores: u32,
    /// Fast-loop calls.
    pub drive_steps: u32,
    /// How many ticks started in each [`StateKind`] (index [`StateKind::index`]).
    pub state_ticks: [u32; 11],
}

/// The Hall code of the rotor `steps` sectors from where it started.
fn hall_after(steps: i32) -> taut_core::drive::HallCode {
    let sector = u8::try_from(steps.rem_euclid(6)).unwrap_or(0);
    Sector::S0.advanced(sector).hall_code()
}

/// Replays `session`: builds the machine from its boot record, ticks it with every recorded
/// input as the firmware's tick does (command and fault clear to the drive, the record
/// encoded when asked to store), and steps the drive [`PERIODS_PER_TICK`] times per tick
/// (see the module docs). Every [`Machine::tick`], [`Drive::step`] and [`Record::encode`]
/// goes through `meter`.
pub fn replay(session: &Session<'_>, machine: &mut Machine, meter: &mut impl Meter) -> Replayed {
    let mut drive = Drive::new();
    let mut replayed = Replayed {
        ticks: 0,
        fingerprint: FINGERPRINT_START,
        stores: 0,
        drive_steps: 0,
        state_ticks: [0; 11],
    };
    let mut inputs = session.inputs().peekable();
    // The rotor's position in sectors, as the recorded Hall steps moved it.
    let mut rotor = 0_i32;
    while let Some(now) = inputs.next() {
        let state = StateKind::of(machine.state());
        if let Some(count) = replayed.state_ticks.get_mut(state.index()) {
            *count = count.saturating_add(1);
        }
        let outputs = meter.measure(Call::Tick(state), || tick_call(machine, &now));
        replayed.ticks = replayed.ticks.saturating_add(1);
        replayed.fingerprint = fold_outputs(replayed.fingerprint, &outputs);
        let _refused = drive.apply(outputs.drive, outputs.clear_drive_fault);
        if outputs.store {
            replayed.stores = replayed.stores.saturating_add(1);
            let record = *machine.record();
            let _bytes = meter.measure(Call::Encode, || encode_call(&record));
        }
        // The steps the twin's drive counted during this tick, spread over its periods.
        let moved = inputs
            .peek()
            .map_or(0, |next| next.drive.steps.wrapping_sub(now.drive.steps))
            .clamp(-PERIODS, PERIODS);
        for period in 1..=PERIODS {
            let done = moved.saturating_mul(period).checked_div(PERIODS).unwrap_or(0);
            let sample = DriveSample {
                hall: hall_after(rotor.wrapping_add(done)),
                current: now.motor_current,
                overcurrent_trip: false,
                bus_voltage: now.bus_voltage,
                limits: now.limits,
                elapsed: PWM_PERIOD,
            };
            let _output = meter.measure(Call::DriveStep, || drive_call(&mut drive, sample));
            replayed.drive_steps = replayed.drive_steps.saturating_add(1);
        }
        rotor = rotor.wrapping_add(moved);
    }
    replayed
}

#[cfg(test)]
extern crate std;

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    #[test]
    fn inputs_survive_the_round_trip_and_fill_their_record() {
        let inputs = Inputs {
            now_ms: 0xDEAD_BEEF,
            load_cell: AdcCode::new(4095),
            motor_current: AdcCode::new(1234),
            bus_voltage: AdcCode::new(1638),
            drive: DriveStatus {
                fault: Some(DriveFault::SectorSkipped),
                steps: -123_456,
                rotation: Some(Direction::Release),
                quiet_for: DriveTime(987_654),
                energized: Some(Direction::Pull),
                current: Amps::from_bits(-123_457),
                bus: Volts::from_bits(24 << 16),
            },
            string_counter: 65_000,
            limits: LimitSwitches { home: false, end: true },
            keys: Keys::from_bits(0b10101),
        };
        let bytes = encode_inputs(&inputs);
        assert_eq!(decode_inputs(&bytes), inputs);
        // Every byte is written: a shorter encoder would leave the last bytes zero for some
        // input, a longer one would be cut (its writer counts past the end).
        let mut count = Writer { bytes: &mut [0; INPUTS_LEN], at: 0 };
        count.put(&bytes);
        assert_eq!(count.at, INPUTS_LEN);
        assert_ne!(bytes[INPUTS_LEN - 1], 0);
    }

    #[test]
    fn header_round_trip() {
        let header = Header {
            ticks: 7,
            fingerprint: 0x1234_5678,
            stores: 2,
            boot_record: [0xA5; RECORD_LEN],
        };
        let mut file: Vec<u8> = encode_header(&header).to_vec();
        file.extend(core::iter::repeat_n(0, 7 * INPUTS_LEN));
        let session = Session::parse(&file).unwrap();
        assert_eq!(session.header, header);
        assert_eq!(session.inputs().count(), 7);
        assert_eq!(Session::parse(&file[..file.len() - 1]).err(), Some(SessionError::Truncated));
    }
}

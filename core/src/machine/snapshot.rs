//! Fault snapshots: what the machine saw in the tick a fault latched, kept in the record.
//!
//! # Theory of operation
//!
//! A fault code says *what* tripped; a service technician also needs *how*: was the carriage
//! pulling or releasing, at what tension, with what current on what bus, where was the rotor
//! and what duty was asked of it. When a fault latches the machine takes a
//! [`FaultSnapshot`] of the tick's inputs and of the state and drive command that were in
//! force just before it, puts it at the head of the record's fault history (the last
//! [`FAULT_HISTORY`], the latest first) and stores the record at once, so the snapshot
//! survives the power cut that often follows a fault. The service page shows the history's
//! codes; the snapshots' figures are in the record for the host tool and the link.
//!
//! A snapshot is quantised when it is taken, to what its [`SNAPSHOT_LEN`] bytes hold —
//! tension to 0.01 kgf, current to 1 mA (±32.767 A), bus to 1 mV, the Hall step count whole,
//! the duty raw — so a snapshot in memory and the one read back from the record are equal.
//! Decoding checks every field ([`FaultSnapshot::decode`]): an unknown fault number or state,
//! a direction other than coast/pull/release, a duty above the cap or a coasting duty are a
//! typed [`SnapshotError`], and an empty slot is all zero bytes.
//!
//! Byte layout (little-endian): fault number (0: empty slot), state kind (its index in
//! [`MachineState::KINDS`]), state detail (the calibration reading or the fault number, else
//! 0), boot number (`u16`, the boot counter's low half), milliseconds since power-up (`u32`),
//! tension in hundredths of a kgf (`i16`), motor current in mA (`i16`), bus in mV (`u16`),
//! Hall step count (`i32`), command direction (0 coast, 1 pull, 2 release), duty (`u16` raw).

use crate::drive::{DUTY_MAX, Direction, DriveCommand, Duty};
use crate::machine::MachineState;
use crate::machine::fault::FaultCode;
use crate::units::{Amps, Kgf, Volts};

/// Snapshots the record keeps: the last three faults, the latest first.
pub const FAULT_HISTORY: usize = 3;

/// Bytes of one stored snapshot.
pub const SNAPSHOT_LEN: usize = 22;

/// What the machine saw in the tick a fault latched.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct FaultSnapshot {
    /// The fault.
    pub code: FaultCode,
    /// The state the machine was in when the fault latched.
    pub state: MachineState,
    /// The boot the fault latched in (the boot counter's low 16 bits).
    pub boot: u16,
    /// Milliseconds since that power-up.
    pub time_ms: u32,
    /// The calibrated tension, to 0.01 kgf.
    pub tension: Kgf,
    /// The motor current the drive reported, to 1 mA (±32.767 A).
    pub current: Amps,
    /// The bus voltage the drive reported, to 1 mV.
    pub bus: Volts,
    /// The Hall step count (the carriage's position).
    pub hall_steps: i32,
    /// The drive command in force when the fault latched.
    pub command: DriveCommand,
}

/// Why stored snapshot bytes were refused.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum SnapshotError {
    /// A field is out of its range: an unknown fault or state, a bad direction or duty, or an
    /// empty slot with bytes set.
    Invalid,
}

/// The snapshot's inputs, as the tick has them.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Latch {
    /// The fault.
    pub code: FaultCode,
    /// The state before the fault.
    pub state: MachineState,
    /// The record's boot counter.
    pub boots: u32,
    /// Milliseconds since power-up.
    pub now_ms: u32,
    /// The calibrated tension.
    pub tension: Kgf,
    /// The drive's current.
    pub current: Amps,
    /// The drive's bus voltage.
    pub bus: Volts,
    /// The Hall step count.
    pub hall_steps: i32,
    /// The command in force.
    pub command: DriveCommand,
}

impl Latch {
    /// The latch of `code` in a tick with `inputs` and the calibrated `tension`, the machine
    /// having been in `prior` (state and drive command; `None`: unknown, taken as the fault's
    /// own state and coast) with the boot counter at `boots`.
    #[must_use]
    pub fn of(
        code: FaultCode,
        prior: Option<(MachineState, DriveCommand)>,
        inputs: &crate::io::Inputs,
        tension: Kgf,
        boots: u32,
    ) -> Self {
        let (state, command) = prior.unwrap_or((MachineState::Fault(code), DriveCommand::Coast));
        Self {
            code,
            state,
            boots,
            now_ms: inputs.now_ms,
            tension,
            current: inputs.drive.current,
            bus: inputs.drive.bus,
            hall_steps: inputs.drive.steps,
            command,
        }
    }
}

impl FaultSnapshot {
    /// The snapshot of `latch`, quantised to what the record holds.
    #[must_use]
    pub fn capture(latch: &Latch) -> Self {
        let hundredths = latch.tension.to_hundredths_rounded();
        let ma = latch.current.to_milli().clamp(i32::from(i16::MIN), i32::from(i16::MAX));
        let mv = latch.bus.to_milli().clamp(0, i32::from(u16::MAX));
        Self {
            code: latch.code,
            state: latch.state,
            boot: u16::try_from(latch.boots & 0xFFFF).unwrap_or(0),
            time_ms: latch.now_ms,
            tension: Kgf::from_hundredths(
                hundredths.clamp(i32::from(i16::MIN), i32::from(i16::MAX)),
            ),
            current: Amps::from_milli(ma),
            bus: Volts::from_milli(mv),
            hall_steps: latch.hall_steps,
            command: latch.command,
        }
    }

    /// The snapshot's bytes (an empty slot is [`Self::encode_slot`] of `None`).
    #[must_use]
    pub fn encode(&self) -> [u8; SNAPSHOT_LEN] {
        let (kind, detail) = state_code(self.state);
        let (direction, duty) = match self.command {
            DriveCommand::Coast => (0, 0),
            DriveCommand::Drive { direction: Direction::Pull, duty } => (1, duty.raw()),
            DriveCommand::Drive { direction: Direction::Release, duty } => (2, duty.raw()),
        };
        let hundredths = self.tension.to_hundredths_rounded();
        let tension =
            i16::try_from(hundredths).unwrap_or(if hundredths < 0 { i16::MIN } else { i16::MAX });
        let ma = self.current.to_milli();
        let current = i16::try_from(ma).unwrap_or(if ma < 0 { i16::MIN } else { i16::MAX });
        let bus = u16::try_from(self.bus.to_milli().max(0)).unwrap_or(u16::MAX);
        let [b0, b1] = self.boot.to_le_bytes();
        let [t0, t1, t2, t3] = self.time_ms.to_le_bytes();
        let [k0, k1] = tension.to_le_bytes();
        let [c0, c1] = current.to_le_bytes();
        let [v0, v1] = bus.to_le_bytes();
        let [h0, h1, h2, h3] = self.hall_steps.to_le_bytes();
        let [d0, d1] = duty.to_le_bytes();
        [
            self.code.number(),
            kind,
            detail,
            b0,
            b1,
            t0,
            t1,
            t2,
            t3,
            k0,
            k1,
            c0,
            c1,
            v0,
            v1,
            h0,
            h1,
            h2,
            h3,
            direction,
            d0,
            d1,
        ]
    }

    /// A history slot's bytes: the snapshot's, or all zero for an empty slot.
    #[must_use]
    pub fn encode_slot(slot: Option<&Self>) -> [u8; SNAPSHOT_LEN] {
        slot.map_or([0; SNAPSHOT_LEN], Self::encode)
    }

    /// The snapshot in a history slot's bytes (`None`: an empty slot).
    ///
    /// # Errors
    /// [`SnapshotError::Invalid`] when a field is out of its range (see the module docs).
    pub fn decode(bytes: &[u8; SNAPSHOT_LEN]) -> Result<Option<Self>, SnapshotError> {
        let [
            number,
            kind,
            detail,
            b0,
            b1,
            t0,
            t1,
            t2,
            t3,
            k0,
            k1,
            c0,
            c1,
            v0,
            v1,
            h0,
            h1,
            h2,
            h3,
            direction,
            d0,
            d1,
        ] = *bytes;
        if number == 0 {
            return if bytes.iter().all(|byte| *byte == 0) {
                Ok(None)
            } else {
                Err(SnapshotError::Invalid)
            };
        }
        let code = fault_from_number(number).ok_or(SnapshotError::Invalid)?;
        let state = state_from_code(kind, detail).ok_or(SnapshotError::Invalid)?;
        let duty = u16::from_le_bytes([d0, d1]);
        if duty > DUTY_MAX.raw() {
            return Err(SnapshotError::Invalid);
        }
        let duty = Duty::from_raw_clamped(duty);
        let command = match direction {
            0 if duty.is_zero() => DriveCommand::Coast,
            1 => DriveCommand::Drive { direction: Direction::Pull, duty },
            2 => DriveCommand::Drive { direction: Direction::Release, duty },
            _ => return Err(SnapshotError::Invalid),
        };
        Ok(Some(Self {
            code,
            state,
            boot: u16::from_le_bytes([b0, b1]),
            time_ms: u32::from_le_bytes([t0, t1, t2, t3]),
            tension: Kgf::from_hundredths(i32::from(i16::from_le_bytes([k0, k1]))),
            current: Amps::from_milli(i32::from(i16::from_le_bytes([c0, c1]))),
            bus: Volts::from_milli(i32::from(u16::from_le_bytes([v0, v1]))),
            hall_steps: i32::from_le_bytes([h0, h1, h2, h3]),
            command,
        }))
    }
}

/// The fault shown as `E-number`, if any.
const fn fault_from_number(number: u8) -> Option<FaultCode> {
    FaultCode::from_number(number)
}

/// A state's kind ([`MachineState::kind`]) and detail byte.
const fn state_code(state: MachineState) -> (u8, u8) {
    let detail = match state {
        MachineState::CalibrationPull { point } | MachineState::CalibrationEntry { point } => point,
        MachineState::Fault(code) => code.number(),
        _ => 0,
    };
    (state.kind(), detail)
}

/// The state of a kind and detail byte, if they name one.
fn state_from_code(kind: u8, detail: u8) -> Option<MachineState> {
    let state = match *MachineState::KINDS.get(usize::from(kind))? {
        MachineState::CalibrationPull { .. } => {
            let point = u8::try_from(crate::sense::calibration::CALIBRATION_READINGS).ok()?;
            MachineState::CalibrationPull { point: (detail < point).then_some(detail)? }
        }
        MachineState::CalibrationEntry { .. } => {
            let point = u8::try_from(crate::sense::calibration::CALIBRATION_READINGS).ok()?;
            MachineState::CalibrationEntry { point: (detail < point).then_some(detail)? }
        }
        MachineState::Fault(_) => MachineState::Fault(fault_from_number(detail)?),
        other if detail == 0 => other,
        _ => return None,
    };
    Some(state)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn latch() -> Latch {
        Latch {
            code: FaultCode::StringBreak,
            state: MachineState::Holding,
            boots: 70_001,
            now_ms: 3_600_123,
            tension: Kgf::from_tenths(246),
            current: Amps::from_milli(-1_234),
            bus: Volts::from_milli(24_010),
            hall_steps: -17,
            command: DriveCommand::Drive {
                direction: Direction::Pull,
                duty: Duty::from_raw_clamped(20_000),
            },
        }
    }

    #[test]
    fn a_snapshot_round_trips_through_its_bytes() {
        let snapshot = FaultSnapshot::capture(&latch());
        assert_eq!(snapshot.boot, 4_465, "70 001 less 65 536");
        assert_eq!(FaultSnapshot::decode(&snapshot.encode()), Ok(Some(snapshot)));
        assert_eq!(FaultSnapshot::decode(&[0; SNAPSHOT_LEN]), Ok(None));
        // Every state kind, every calibration reading and fault, every command.
        let mut states = MachineState::KINDS.to_vec();
        states.extend((0..8).map(|point| MachineState::CalibrationPull { point }));
        states.extend((0..8).map(|point| MachineState::CalibrationEntry { point }));
        states.extend(FaultCode::ALL.map(MachineState::Fault));
        for state in states {
            for command in [
                DriveCommand::Coast,
                DriveCommand::Drive { direction: Direction::Release, duty: DUTY_MAX },
            ] {
                let snapshot = FaultSnapshot::capture(&Latch { state, command, ..latch() });
                assert_eq!(FaultSnapshot::decode(&snapshot.encode()), Ok(Some(snapshot)));
            }
        }
        // Out-of-range figures are saturated when taken, and read back as taken.
        let wild = FaultSnapshot::capture(&Latch {
            tension: Kgf::from_int(400),
            current: Amps::from_milli(50_000),
            bus: Volts::from_milli(-5),
            ..latch()
        });
        assert_eq!(wild.current, Amps::from_milli(32_767));
        assert_eq!(wild.bus, Volts::ZERO);
        assert_eq!(FaultSnapshot::decode(&wild.encode()), Ok(Some(wild)));
    }

    #[test]
    fn bad_snapshot_bytes_are_a_typed_error() {
        let good = FaultSnapshot::capture(&latch()).encode();
        let bad = |index: usize, value: u8| {
            let mut bytes = good;
            bytes[index] = value;
            FaultSnapshot::decode(&bytes)
        };
        assert_eq!(bad(0, 20), Err(SnapshotError::Invalid), "no E-20");
        assert_eq!(bad(1, 11), Err(SnapshotError::Invalid), "no twelfth state kind");
        assert_eq!(bad(2, 1), Err(SnapshotError::Invalid), "Holding has no detail");
        assert_eq!(bad(19, 3), Err(SnapshotError::Invalid), "no fourth direction");
        assert_eq!(bad(21, 0xFF), Err(SnapshotError::Invalid), "a duty over the cap");
        let mut coast_with_duty = good;
        coast_with_duty[19] = 0;
        assert_eq!(FaultSnapshot::decode(&coast_with_duty), Err(SnapshotError::Invalid));
        let mut empty_with_bytes = [0; SNAPSHOT_LEN];
        empty_with_bytes[5] = 1;
        assert_eq!(FaultSnapshot::decode(&empty_with_bytes), Err(SnapshotError::Invalid));
        // A calibration reading past the last, a fault state of an unknown code.
        assert_eq!(state_from_code(4, 8), None);
        assert_eq!(state_from_code(10, 20), None);
        assert_eq!(state_from_code(10, 15), Some(MachineState::Fault(FaultCode::StringBreak)));
    }
}

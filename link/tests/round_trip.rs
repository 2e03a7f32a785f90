//! Every message of the link round-trips through its frame (REQ-LINK-01): proptest draws
//! every variant of [`Command`] and [`Message`] with any field values, encodes, checks the
//! frame's bounds (one zero, at its end; at most `MAX_FRAME` bytes) and decodes it back.
#![allow(
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    reason = "test code: a panic is the failure report"
)]

use proptest::prelude::*;
use taut_link::message::{
    Event, Faults, Identity, InputSnapshot, LiveSample, LogEntry, LogPage, Refusal, Status,
    WirePreferences, WireSettings, WireSettingsError, WireState, WireUnit,
};
use taut_link::{Command, MAX_FRAME, Message, Request, Response, decode, encode};

fn settings() -> impl Strategy<Value = WireSettings> {
    (any::<bool>(), any::<u16>(), any::<u8>(), any::<u8>(), any::<u8>()).prop_map(
        |(pounds, tension_tenths, speed, pre_stretch_percent, knot_percent)| WireSettings {
            unit: if pounds { WireUnit::Pounds } else { WireUnit::Kilograms },
            tension_tenths,
            speed,
            pre_stretch_percent,
            knot_percent,
        },
    )
}

fn preferences() -> impl Strategy<Value = WirePreferences> {
    (any::<bool>(), any::<bool>())
        .prop_map(|(beeper, constant_pull)| WirePreferences { beeper, constant_pull })
}

fn request() -> impl Strategy<Value = Request> {
    prop_oneof![
        Just(Request::Hello),
        any::<u8>().prop_map(|page| Request::ReadLog { page }),
        Just(Request::ReadStatus),
        any::<u8>().prop_map(|index| Request::ReadPreset { index }),
        any::<u8>().prop_map(|part| Request::ReadRecord { part }),
        Just(Request::ReadFaults),
        any::<u16>().prop_map(|period_ms| Request::Stream { period_ms }),
        (settings(), preferences())
            .prop_map(|(settings, preferences)| Request::WriteSettings { settings, preferences }),
        (any::<u8>(), settings())
            .prop_map(|(index, settings)| Request::WritePreset { index, settings }),
        (any::<u8>(), any::<[u8; 32]>())
            .prop_map(|(part, bytes)| Request::StageRecord { part, bytes }),
        Just(Request::CommitRecord),
    ]
}

fn state() -> impl Strategy<Value = WireState> {
    prop_oneof![
        Just(WireState::SelfTest),
        Just(WireState::MotorTest),
        Just(WireState::Homing),
        Just(WireState::CalibrationWindow),
        any::<u8>().prop_map(WireState::CalibrationPull),
        any::<u8>().prop_map(WireState::CalibrationEntry),
        Just(WireState::Ready),
        Just(WireState::Pulling),
        Just(WireState::Holding),
        Just(WireState::Releasing),
        any::<u8>().prop_map(WireState::Fault),
    ]
}

fn entry() -> impl Strategy<Value = LogEntry> {
    (any::<u32>(), any::<[i16; 4]>(), any::<[u16; 3]>(), any::<Option<u16>>(), any::<Option<u16>>())
        .prop_map(|(pull, t, u, stiffness, creep)| LogEntry {
            pull,
            target_centi_kgf: t[0],
            reached_centi_kgf: t[1],
            peak_centi_kgf: t[2],
            adjust_centi_kgf: t[3],
            time_to_tension_ms: u[0],
            held_s: u[1],
            string_mm: u[2],
            stiffness_milli_kgf_per_mm: stiffness,
            creep_centi_percent_per_min: creep,
        })
}

fn event() -> impl Strategy<Value = Event> {
    let snapshot = (any::<[u16; 3]>(), any::<[i32; 3]>(), any::<[bool; 3]>()).prop_map(
        |(codes, values, flags)| InputSnapshot {
            load_cell_code: codes[0],
            motor_current_code: codes[1],
            bus_voltage_code: codes[2],
            carriage_steps: values[0],
            current_milli_amps: values[1],
            bus_milli_volts: values[2],
            home_limit: flags[0],
            end_limit: flags[1],
            drive_fault: flags[2],
        },
    );
    prop_oneof![
        (any::<u32>(), state(), state()).prop_map(|(time_ms, from, to)| Event::State {
            time_ms,
            from,
            to
        }),
        (any::<u32>(), any::<u8>(), snapshot).prop_map(|(time_ms, code, inputs)| Event::Fault {
            time_ms,
            code,
            inputs
        }),
        entry().prop_map(Event::Logged),
        any::<u16>().prop_map(|count| Event::Dropped { count }),
    ]
}

fn refusal() -> impl Strategy<Value = Refusal> {
    prop_oneof![
        Just(Refusal::BadFrame),
        Just(Refusal::NotIdle),
        Just(Refusal::Settings(WireSettingsError::Tension)),
        Just(Refusal::Settings(WireSettingsError::Speed)),
        Just(Refusal::Settings(WireSettingsError::PreStretch)),
        Just(Refusal::Settings(WireSettingsError::KnotBoost)),
        Just(Refusal::InvalidCalibration),
        Just(Refusal::InvalidRecord),
        Just(Refusal::OutOfRange),
    ]
}

fn response() -> impl Strategy<Value = Response> {
    let identity = (
        any::<u16>(),
        any::<[u8; 3]>(),
        any::<[u8; 12]>(),
        any::<u8>(),
        any::<[u32; 2]>(),
        any::<bool>(),
        any::<Option<u32>>(),
    )
        .prop_map(|(protocol, firmware, board, record_format, counts, calibrated, age)| Identity {
            protocol,
            firmware,
            board,
            record_format,
            boots: counts[0],
            pulls: counts[1],
            calibrated,
            calibration_age_pulls: age,
        });
    let page = (any::<u8>(), any::<u8>(), proptest::array::uniform4(proptest::option::of(entry())))
        .prop_map(|(page, total, entries)| LogPage { page, total, entries });
    let status = (state(), any::<[u32; 3]>(), settings(), preferences()).prop_map(
        |(state, counts, settings, preferences)| Status {
            state,
            pulls: counts[0],
            string_used_mm: counts[1],
            boots: counts[2],
            settings,
            preferences,
        },
    );
    let sample = (any::<u32>(), state(), any::<[i32; 5]>(), any::<u16>()).prop_map(
        |(time_ms, state, v, duty_raw)| LiveSample {
            time_ms,
            state,
            target_milli_kgf: v[0],
            tension_milli_kgf: v[1],
            carriage_steps: v[2],
            duty_raw,
            current_milli_amps: v[3],
            bus_milli_volts: v[4],
        },
    );
    prop_oneof![
        identity.prop_map(Response::Identity),
        page.prop_map(Response::LogPage),
        status.prop_map(Response::Status),
        (any::<u8>(), settings())
            .prop_map(|(index, settings)| Response::Preset { index, settings }),
        (any::<u8>(), any::<[u8; 32]>())
            .prop_map(|(part, bytes)| Response::RecordPart { part, bytes }),
        (any::<Option<u8>>(), any::<[Option<u8>; 3]>())
            .prop_map(|(latched, history)| Response::Faults(Faults { latched, history })),
        Just(Response::Accepted),
        refusal().prop_map(Response::Refused),
        sample.prop_map(Response::Sample),
        event().prop_map(Response::Event),
    ]
}

/// Encodes `message`, checks the frame's shape, decodes it back.
fn round_trip<T>(message: &T) -> Result<T, TestCaseError>
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let mut frame = [0u8; MAX_FRAME];
    let len = encode(message, &mut frame).map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
    prop_assert!((2..=MAX_FRAME).contains(&len));
    prop_assert_eq!(frame[len - 1], 0);
    prop_assert!(!frame[..len - 1].contains(&0));
    decode::<T>(&frame[..len - 1]).map_err(|e| TestCaseError::fail(format!("{e:?}")))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4_000, ..ProptestConfig::default() })]

    #[test]
    fn every_command_round_trips(seq in any::<u16>(), request in request()) {
        let command = Command { seq, request };
        prop_assert_eq!(round_trip(&command)?, command);
    }

    #[test]
    fn every_message_round_trips(reply_to in any::<Option<u16>>(), response in response()) {
        let message = Message { reply_to, response };
        prop_assert_eq!(round_trip(&message)?, message);
    }
}

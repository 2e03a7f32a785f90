//! The tick-cost replay: a recorded machine session on the Cortex-M4, call by call.
//!
//! Built for `thumbv7em-none-eabihf` (by `scripts/tick-cost`, profile `firmware`, with
//! `TAUT_TICK_COST_SESSION` naming the recording to embed) this is a QEMU `mps2-an386` image:
//! it replays the session ([`taut_tick_cost::replay`]), counts the instructions and the stack of
//! every [`Machine::tick`](taut_core::machine::Machine::tick),
//! [`Drive::step`](taut_core::drive::Drive::step) and
//! [`Record::encode`](taut_core::store::Record::encode), and prints the table over
//! semihosting. How the counting works and how exact it is: `scripts/tick-cost`'s header and
//! [`qemu`].
//!
//! Built for the host it replays a session file given as its argument without counting, each
//! machine tick inside a function named after the state it started in (`tick_in_pulling`, …),
//! so a profiler run on it (`valgrind --tool=callgrind`) attributes the cost per state and per
//! function. Both check that the replayed machine made the recorded decisions.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod qemu;

#[cfg(not(target_os = "none"))]
mod host {
    use taut_core::machine::Machine;
    use taut_core::store::Record;
    use taut_tick_cost::{Call, Meter, Session, StateKind, replay};

    /// Each state's ticks run inside their own never-inlined function, so a profiler's call
    /// graph splits the cost by state.
    /// (Each passes its own number through `black_box`, so the optimiser cannot merge them.)
    macro_rules! wrappers {
        ($($name:ident = $id:literal),* $(,)?) => {$(
            #[inline(never)]
            fn $name<R>(call: impl FnOnce() -> R) -> R {
                std::hint::black_box($id);
                call()
            }
        )*};
    }

    wrappers!(
        tick_in_self_test = 0_u8,
        tick_in_motor_test = 1_u8,
        tick_in_homing = 2_u8,
        tick_in_calibration_window = 3_u8,
        tick_in_calibration_pull = 4_u8,
        tick_in_calibration_entry = 5_u8,
        tick_in_ready = 6_u8,
        tick_in_pulling = 7_u8,
        tick_in_holding = 8_u8,
        tick_in_releasing = 9_u8,
        tick_in_fault = 10_u8,
        drive_steps = 11_u8,
        record_encodes = 12_u8,
    );

    /// Runs every call in its state's wrapper.
    struct Profiled;

    impl Meter for Profiled {
        fn measure<R>(&mut self, what: Call, call: impl FnOnce() -> R) -> R {
            match what {
                Call::Tick(StateKind::SelfTest) => tick_in_self_test(call),
                Call::Tick(StateKind::MotorTest) => tick_in_motor_test(call),
                Call::Tick(StateKind::Homing) => tick_in_homing(call),
                Call::Tick(StateKind::CalibrationWindow) => tick_in_calibration_window(call),
                Call::Tick(StateKind::CalibrationPull) => tick_in_calibration_pull(call),
                Call::Tick(StateKind::CalibrationEntry) => tick_in_calibration_entry(call),
                Call::Tick(StateKind::Ready) => tick_in_ready(call),
                Call::Tick(StateKind::Pulling) => tick_in_pulling(call),
                Call::Tick(StateKind::Holding) => tick_in_holding(call),
                Call::Tick(StateKind::Releasing) => tick_in_releasing(call),
                Call::Tick(StateKind::Fault) => tick_in_fault(call),
                Call::DriveStep => drive_steps(call),
                Call::Encode => record_encodes(call),
            }
        }
    }

    pub fn main() -> std::process::ExitCode {
        let Some(path) = std::env::args_os().nth(1) else {
            eprintln!("usage: replay SESSION_FILE  (scripts/tick-cost records one)");
            return std::process::ExitCode::from(2);
        };
        let bytes = match std::fs::read(&path) {
            Ok(bytes) => bytes,
            Err(error) => {
                eprintln!("cannot read {}: {error}", path.to_string_lossy());
                return std::process::ExitCode::from(2);
            }
        };
        let session = match Session::parse(&bytes) {
            Ok(session) => session,
            Err(error) => {
                eprintln!("not a session: {error:?}");
                return std::process::ExitCode::from(2);
            }
        };
        let Ok(board) = taut_core::board::paper() else {
            eprintln!("the paper's board was refused");
            return std::process::ExitCode::from(2);
        };
        let mut machine = Machine::from_stored(Record::decode(&session.header.boot_record), &board);
        let replayed = replay(&session, &mut machine, &mut Profiled);
        for kind in StateKind::ALL {
            let ticks = replayed.state_ticks.get(kind.index()).copied().unwrap_or(0);
            if ticks > 0 {
                println!("{:>18}: {ticks} ticks", kind.name());
            }
        }
        println!(
            "{} ticks, {} drive steps, {} stores",
            replayed.ticks, replayed.drive_steps, replayed.stores
        );
        let header = session.header;
        if replayed.fingerprint == header.fingerprint && replayed.stores == header.stores {
            println!("the replay made the recorded decisions");
            std::process::ExitCode::SUCCESS
        } else {
            eprintln!("the replay diverged from the recording: record the session again");
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() -> std::process::ExitCode {
    host::main()
}

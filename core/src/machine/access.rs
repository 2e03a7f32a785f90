//! The machine link's view of the machine: what a host on the link may read, and the one
//! change it may propose.
//!
//! # Theory of operation
//!
//! The link (a PC on the board's serial port) is served by code that holds a
//! [`LinkAccess`], never the [`Machine`] itself. `LinkAccess` has read methods (state, log,
//! record, fault history, the live figures of the last tick) and exactly one writing method,
//! [`LinkAccess::propose_record`], which the machine accepts **only while it idles in Ready**
//! (not during a pull, a hold, a release, a calibration or a fault) and only for a record
//! that core's own validation accepts. It has no method that ticks the machine, presses a
//! key, commands the drive, clears a fault or changes a target: the no-motion rule is a
//! property of this type's API, and `docs/SPEC.md`'s REQ-LINK section names the proofs that
//! check it.
//!
//! An accepted record replaces the settings, presets, preferences and calibration; the
//! machine keeps its own counters (pulls, string used, boots), shows the tension page and
//! stores the record after the usual idle delay, as for a change keyed on the panel.

use super::chart::{Chart, Context, Sample, State};
use super::{FaultCode, Machine, MachineState, View};
use crate::io::{Inputs, Outputs};
use crate::sense::calibration::Calibration;
use crate::store::Record;
use crate::units::Kgf;
use statig::prelude::IntoStateMachineExt;

/// Why the machine refused a record proposed over the link.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum WriteRefused {
    /// The machine is not idling in Ready (it pulls, holds, releases, calibrates, is
    /// powering up or has a fault latched): only the panel's keys act then.
    NotIdle,
    /// A setting or preset is out of its range.
    InvalidSettings,
    /// The calibration points do not make a valid calibration.
    InvalidCalibration,
}

/// The figures of one tick the link streams: each value in a named unit.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct LiveFigures {
    /// The machine's clock, ms.
    pub now_ms: u32,
    /// The state after the tick.
    pub state: MachineState,
    /// The pull's target (the peak target in a pull or hold, the set point otherwise).
    pub target: Kgf,
    /// The filtered tension the machine shows.
    pub tension: Kgf,
    /// The carriage's position, Hall steps from power-up.
    pub carriage_steps: i32,
    /// The commanded duty, raw (`raw / 65 536` of the PWM period).
    pub duty_raw: u16,
    /// The motor current the drive measured.
    pub current: crate::units::Amps,
    /// The bus voltage the drive measured.
    pub bus: crate::units::Volts,
}

/// The link's handle on a machine: reads, and [`LinkAccess::propose_record`] (see the
/// module docs). There is no way from it to the machine's `tick`, its keys or its drive.
pub struct LinkAccess<'a, const LOG: usize> {
    machine: &'a mut Machine<LOG>,
}

impl<'a, const LOG: usize> LinkAccess<'a, LOG> {
    /// The link's handle on `machine`.
    pub const fn new(machine: &'a mut Machine<LOG>) -> Self {
        Self { machine }
    }

    /// The current state.
    #[must_use]
    pub fn state(&self) -> MachineState {
        self.machine.state()
    }

    /// The persisted record (settings, presets, calibration, counters, preferences).
    #[must_use]
    pub fn record(&self) -> &Record {
        self.machine.record()
    }

    /// The recent pulls, oldest first.
    #[must_use]
    pub fn log(&self) -> &super::PullLog<LOG> {
        self.machine.log()
    }

    /// The faults latched since power-up, the latest first.
    #[must_use]
    pub fn fault_history(&self) -> [Option<FaultCode>; 3] {
        self.machine.record().faults.map(|snapshot| snapshot.map(|snapshot| snapshot.code))
    }

    /// The figures of the tick that read `inputs` and returned `outputs`.
    #[must_use]
    pub fn figures(&self, inputs: &Inputs, outputs: &Outputs) -> LiveFigures {
        let chart = self.machine.chart.inner();
        let state = self.machine.state();
        let target = if matches!(state, MachineState::Pulling | MachineState::Holding) {
            chart.peak_target
        } else {
            chart.record.settings.set_point().to_kgf()
        };
        LiveFigures {
            now_ms: inputs.now_ms,
            state,
            target,
            tension: chart.controller.tension(),
            carriage_steps: inputs.drive.steps,
            duty_raw: outputs.drive.duty().raw(),
            current: inputs.drive.current,
            bus: inputs.drive.bus,
        }
    }

    /// Proposes `proposed`'s settings, presets, preferences and calibration (with the load
    /// cell's zero at that calibration); its counters and fault history are ignored: the
    /// machine keeps its own.
    ///
    /// # Errors
    /// [`WriteRefused::NotIdle`] unless the machine idles in Ready; the first invalid part
    /// otherwise. A refused record changes nothing.
    pub fn propose_record(&mut self, proposed: &Record) -> Result<(), WriteRefused> {
        if !matches!(self.machine.chart.state(), State::Ready { .. }) {
            return Err(WriteRefused::NotIdle);
        }
        if !proposed.is_valid() {
            return Err(WriteRefused::InvalidSettings);
        }
        let calibration = match &proposed.calibration {
            None => Calibration::IDENTITY,
            Some(points) => {
                Calibration::new(points).map_err(|_| WriteRefused::InvalidCalibration)?
            }
        };
        let mut chart: Chart = self.machine.chart.inner().clone();
        // The counters and the fault history are the machine's own, never a backup's.
        let (counters, faults) = (chart.record.counters, chart.record.faults);
        chart.record = Record { counters, faults, ..*proposed };
        chart.calibration = calibration;
        chart.dirty = true;
        chart.idle = 0;
        // Re-entering Ready runs its entry action as the panel's own return to Ready does
        // (the controller idles, the rest for a re-zero starts again).
        let mut uninitialized = chart.uninitialized_state_machine();
        *uninitialized.state_mut() = State::Ready { view: View::Tension };
        let mut context = Context::new(Sample::default());
        self.machine.chart = uninitialized.init_with_context(&mut context);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::Checkpoint;
    use crate::settings::{SetPoint, Settings, Unit};

    fn settings_30kg() -> Settings {
        match SetPoint::new(Unit::Kilograms, 300).and_then(|p| Settings::new(p, 7, 10, 5)) {
            Ok(settings) => settings,
            Err(error) => panic!("valid settings: {error:?}"),
        }
    }

    /// REQ-LINK-03: a record is accepted in Ready, with the machine's own counters kept.
    #[test]
    fn a_record_is_accepted_in_ready_and_keeps_the_counters() {
        let mut record = Record::default();
        record.counters.pulls = 12;
        let mut machine: Machine = Machine::resume(
            record,
            &Checkpoint::at(MachineState::Ready),
            &crate::test_support::paper_board(),
        );
        let mut proposed = Record { settings: settings_30kg(), ..Record::default() };
        proposed.counters.pulls = 999;
        assert_eq!(LinkAccess::new(&mut machine).propose_record(&proposed), Ok(()));
        assert_eq!(machine.record().settings, settings_30kg());
        assert_eq!(machine.record().counters.pulls, 12);
        assert_eq!(machine.state(), MachineState::Ready);
    }

    /// REQ-LINK-03: the fault history is the machine's own too: a proposed record's history
    /// (a backup's, from another day or another machine) never replaces it.
    #[test]
    fn a_record_accepted_in_ready_keeps_the_fault_history() {
        use crate::drive::DriveCommand;
        use crate::machine::snapshot::{FaultSnapshot, Latch};
        use crate::units::{Amps, Volts};
        let latch = |code| Latch {
            code,
            state: MachineState::Pulling,
            boots: 3,
            now_ms: 1_000,
            tension: Kgf::from_int(20),
            current: Amps::from_milli(2_000),
            bus: Volts::from_int(24),
            hall_steps: 100,
            command: DriveCommand::Coast,
        };
        let mut own = Record::default();
        own.push_fault(FaultSnapshot::capture(&latch(FaultCode::StringBreak)));
        let mut machine: Machine = Machine::resume(
            own,
            &Checkpoint::at(MachineState::Ready),
            &crate::test_support::paper_board(),
        );
        let mut proposed = Record { settings: settings_30kg(), ..Record::default() };
        proposed.push_fault(FaultSnapshot::capture(&latch(FaultCode::LimitsBoth)));
        assert_eq!(LinkAccess::new(&mut machine).propose_record(&proposed), Ok(()));
        assert_eq!(machine.record().settings, settings_30kg());
        assert_eq!(machine.record().faults, own.faults);
    }

    /// REQ-LINK-03: outside Ready every proposal is refused and changes nothing.
    #[test]
    fn a_record_is_refused_outside_ready() {
        let proposed = Record { settings: settings_30kg(), ..Record::default() };
        for state in MachineState::KINDS {
            if state == MachineState::Ready {
                continue;
            }
            let mut machine: Machine = Machine::resume(
                Record::default(),
                &Checkpoint::at(state),
                &crate::test_support::paper_board(),
            );
            let before = *machine.record();
            let result = LinkAccess::new(&mut machine).propose_record(&proposed);
            assert_eq!(result, Err(WriteRefused::NotIdle), "{state:?}");
            assert_eq!(*machine.record(), before);
            assert_eq!(machine.state(), state);
        }
    }

    /// The reads: the fault history the service page shows, and a tick's figures.
    #[test]
    fn the_link_reads_the_fault_history_and_the_ticks_figures() {
        use crate::drive::{Direction, DriveCommand, Duty};
        use crate::io::LimitSwitches;
        let record = Record { settings: settings_30kg(), ..Record::default() };
        let mut machine: Machine = Machine::resume(
            record,
            &Checkpoint::at(MachineState::Ready),
            &crate::test_support::paper_board(),
        );
        let inputs = Inputs {
            now_ms: 7,
            drive: crate::drive::DriveStatus { steps: 17, ..Default::default() },
            ..Inputs::default()
        };
        let outputs = Outputs {
            drive: DriveCommand::Drive {
                direction: Direction::Pull,
                duty: Duty::from_raw_clamped(1_234),
            },
            ..Outputs::default()
        };
        let figures = LinkAccess::new(&mut machine).figures(&inputs, &outputs);
        assert_eq!(figures.now_ms, 7);
        assert_eq!(figures.state, MachineState::Ready);
        assert_eq!(figures.target, Kgf::from_int(30));
        assert_eq!(figures.carriage_steps, 17);
        assert_eq!(figures.duty_raw, 1_234);
        assert_eq!(LinkAccess::new(&mut machine).fault_history(), [None; 3]);
        let both = LimitSwitches { home: true, end: true };
        let _ = machine.tick(&Inputs { now_ms: 8, limits: both, ..Inputs::default() });
        let access = LinkAccess::new(&mut machine);
        assert_eq!(access.state(), MachineState::Fault(FaultCode::LimitsBoth));
        assert_eq!(access.fault_history()[0], Some(FaultCode::LimitsBoth));
        assert_eq!(access.record().settings, settings_30kg());
        assert_eq!(access.log().len(), 0);
    }
}

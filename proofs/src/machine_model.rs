//! The whole-machine model check: the real [`Machine`] composed with an abstract,
//! nondeterministic environment, explored breadth-first over every environment choice.
//!
//! # The environment
//!
//! [`Env`] abstracts the world around the controller to a few finite variables:
//!
//! | variable | values |
//! |---|---|
//! | carriage position | at home, between the limits, at the end |
//! | limit wiring fault | both switches read active, or not |
//! | tension band | unloaded, slack (3 kgf), at the target the machine is pulling to, overload (53.5 kgf), negative (−0.4 kgf), bottom rail, top rail |
//! | injected fault | none, a drive fault (Hall invalid) latched in the drive, motor current over the limit |
//! | motor | follows the command, stuck, turns backwards |
//!
//! Each step of the exploration picks one [`Action`] — press a key (held 30 ms, released
//! 30 ms), hold Function or Preset for a long press, move the carriage to a neighbouring
//! position, change the tension band, toggle the wiring fault, inject or remove a fault,
//! change the motor's behaviour, or let time pass (200 ms, 6 s, or — in the states with a
//! longer timer — until the state changes or 41 s, longer than every timeout) — and runs the **real machine** tick by tick for the
//! action's duration, feeding it the inputs the environment implies: limit switches from
//! the position and wiring, the load-cell code of the tension band (nominal chain, 50 mV
//! tare), the motor current, the drive's latched fault (cleared, as
//! [`taut_core::drive::Drive::clear_fault`] does, when the machine asks with the command at
//! coast) and a Hall count that moves one step per tick in the direction the motor turns.
//! **Every simulated tick** is checked with [`check_tick`], the same property bodies Kani
//! and the fuzzer check.
//!
//! Position is not integrated from the motion: the carriage may arrive at either limit at
//! any moment, and the tension band may change at any moment, whatever the machine does.
//! That over-approximates the physics (every real trajectory is one of the environment's
//! choices), which is what a safety check needs.
//!
//! # What is explored, and why that is exhaustive enough
//!
//! An abstract state ([`Key`]) is the machine's public state ([`MachineState`], with its
//! calibration point or fault code), the panel page (Ready's page — an information page's
//! item index only changes its digits and is not kept; the hold's tension or timer), knot mode, constant pull on or off, a pending notice, whether
//! the pull has seen tension (≥ 5 kgf, which arms the string-break rule), and the whole
//! environment. The machine's remaining data — timers, the controller's integrators, the
//! settings' values — is not part of the key: the first concrete machine that reaches a key
//! represents it. This is the usual abstraction of a timed controller (timers are explored
//! by the wait actions, which run until every timeout has expired), and it keeps the space
//! finite. What it does not cover — every combination of timer value and input — is what
//! the Kani harnesses cover, one tick from *any* valid concrete state.
//!
//! Checked:
//! - every `REQ-SAFE-*` property on every simulated tick;
//! - from every explored abstract state, Ready or a fault display is reachable (no deadlock,
//!   no trap): a backward search from those states over the explored transition graph.

use std::collections::{HashMap, HashSet, VecDeque};

use taut_core::drive::limit::CurrentSense;
use taut_core::drive::{Direction, DriveCommand, DriveFault, DriveStatus, DriveTime};
use taut_core::io::{Inputs, Key as PanelKey, Keys, LimitSwitches, Outputs};
use taut_core::machine::{MachineState, View, point_of_reading, safety};
use taut_core::sense::calibration::CALIBRATION_TARGETS;
use taut_core::sense::load_cell::LoadCellScale;
use taut_core::units::{AdcCode, Kgf, Volts};

use crate::machine::{TickRecord, check_tick};

/// The machine under check (pull log of capacity 1: the log is not part of safety).
pub type Machine = taut_core::machine::Machine<1>;

/// Where the carriage is.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Position {
    /// On the home limit switch.
    Home,
    /// Between the switches.
    Middle,
    /// On the end-of-travel switch.
    End,
}

/// What the load cell reads.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Band {
    /// No load.
    Unloaded,
    /// 3 kgf: slack taken up, far from any target.
    Slack,
    /// Exactly the tension the machine is pulling to (set point or calibration point).
    Target,
    /// 53.5 kgf: above every overload threshold, below the top rail.
    Overload,
    /// −0.4 kgf: a reversed bridge (above the bottom rail).
    Negative,
    /// 0 V: open bridge.
    RailLow,
    /// 5 V: shorted bridge.
    RailHigh,
}

/// A fault the environment injects.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Injected {
    /// Nothing.
    None,
    /// The drive has latched a Hall fault (clears when asked with coast).
    DriveFault,
    /// The motor current reads above the limit.
    Overcurrent,
}

/// How the motor responds to a drive command.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Motor {
    /// Turns the commanded way.
    Follows,
    /// Does not turn.
    Stuck,
    /// Turns the other way (swapped phases).
    Backwards,
}

/// The abstract environment.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Env {
    /// Carriage position.
    pub position: Position,
    /// Both limit switches read active (wiring fault).
    pub wiring_fault: bool,
    /// Tension band.
    pub band: Band,
    /// Injected fault.
    pub injected: Injected,
    /// Motor behaviour.
    pub motor: Motor,
}

impl Env {
    /// A healthy machine at power-up: carriage home, nothing loaded, no fault.
    pub const HEALTHY: Self = Self {
        position: Position::Home,
        wiring_fault: false,
        band: Band::Unloaded,
        injected: Injected::None,
        motor: Motor::Follows,
    };

    fn limits(&self) -> LimitSwitches {
        LimitSwitches {
            home: self.wiring_fault || self.position == Position::Home,
            end: self.wiring_fault || self.position == Position::End,
        }
    }
}

/// One nondeterministic choice of the environment.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Action {
    /// Press and release a key.
    Press(PanelKey),
    /// Hold a key for a long press, then release.
    Hold(PanelKey),
    /// Move the carriage.
    Move(Position),
    /// Change the tension band.
    Tension(Band),
    /// Toggle the limit wiring fault.
    ToggleWiring,
    /// Inject or remove a fault.
    Inject(Injected),
    /// Change the motor's behaviour.
    Motor(Motor),
    /// Let this many ticks pass.
    Wait(u32),
    /// Let time pass until the state changes, at most this many ticks.
    WaitForChange(u32),
}

/// Every action.
#[must_use]
pub fn actions() -> Vec<Action> {
    let mut out = Vec::new();
    for key in PanelKey::ALL {
        out.push(Action::Press(key));
    }
    out.push(Action::Hold(PanelKey::Function));
    out.push(Action::Hold(PanelKey::Preset));
    for position in [Position::Home, Position::Middle, Position::End] {
        out.push(Action::Move(position));
    }
    for band in [
        Band::Unloaded,
        Band::Slack,
        Band::Target,
        Band::Overload,
        Band::Negative,
        Band::RailLow,
        Band::RailHigh,
    ] {
        out.push(Action::Tension(band));
    }
    out.push(Action::ToggleWiring);
    for injected in [Injected::None, Injected::DriveFault, Injected::Overcurrent] {
        out.push(Action::Inject(injected));
    }
    for motor in [Motor::Follows, Motor::Stuck, Motor::Backwards] {
        out.push(Action::Motor(motor));
    }
    out.push(Action::Wait(200));
    out.push(Action::Wait(6_000));
    out.push(Action::WaitForChange(41_000));
    out
}

/// The concrete simulation state: machine, environment, and the environment's counters.
#[derive(Clone)]
pub struct World {
    /// The machine.
    pub machine: Machine,
    /// The environment.
    pub env: Env,
    /// Whether the drive has a latched fault.
    pub drive_fault: bool,
    /// Ticks since power-up.
    pub now_ms: u32,
    /// Hall steps.
    pub steps: i32,
    /// Ticks since the last Hall step.
    pub quiet_ms: u32,
    /// The machine's last outputs.
    pub last: Outputs,
}

/// Model-check property `tension_faults_stop_the_pull` (REQ-SAFE-09): a string-tension
/// state that sees an overload, a negative (reversed) reading or a load-cell rail for
/// [`TENSION_FAULT_MS`] has latched a fault by then — the rules track the tension at 1 kgf a
/// tick (≤ 54 ticks from any band to another) and confirm within 20 ticks.
pub fn tension_faults_stop_the_pull(before: MachineState, band: Band, after: MachineState) {
    let tensioned = matches!(
        before,
        MachineState::Pulling
            | MachineState::Holding
            | MachineState::CalibrationPull { .. }
            | MachineState::CalibrationEntry { .. }
    );
    let faulty = matches!(band, Band::Overload | Band::Negative | Band::RailLow | Band::RailHigh);
    if tensioned && faulty {
        assert!(
            matches!(after, MachineState::Fault(_)),
            "REQ-SAFE-09: {band:?} for {TENSION_FAULT_MS} ms in {before:?} left the machine in {after:?}"
        );
    }
}

/// How long a tension band is held before [`tension_faults_stop_the_pull`] is checked, ms:
/// the tracking from the highest band to a negative reading (54 ticks) plus the longest
/// persistence (20), with margin.
pub const TENSION_FAULT_MS: u32 = 80;

/// Whether `state` has a timeout longer than 6 s (the pull and release timeouts).
fn has_long_timer(state: MachineState) -> bool {
    matches!(
        state,
        MachineState::Pulling
            | MachineState::Releasing
            | MachineState::Homing
            | MachineState::CalibrationPull { .. }
    )
}

/// The load-cell code of a tension on the nominal chain tared at 50 mV.
fn code_of(tension: Kgf) -> AdcCode {
    use taut_core::board::{PAPER_KGF_PER_VOLT, PAPER_LOAD_CELL_ZERO};
    LoadCellScale::new(crate::FIVE_VOLTS, PAPER_LOAD_CELL_ZERO, PAPER_KGF_PER_VOLT)
        .map_or(AdcCode::MIN, |scale| scale.to_code(tension))
}

impl World {
    /// Power-up in `env` on the paper's board (`None` were that board refused).
    #[must_use]
    pub fn new(env: Env) -> Option<Self> {
        let board = crate::paper_board()?;
        Some(Self {
            machine: Machine::with_record(taut_core::store::Record::default(), &board),
            env,
            drive_fault: env.injected == Injected::DriveFault,
            now_ms: 0,
            steps: 0,
            quiet_ms: 1_000,
            last: Outputs::default(),
        })
    }

    /// The tension the machine is pulling to now.
    fn target(&self) -> Kgf {
        match self.machine.state() {
            MachineState::CalibrationPull { point } | MachineState::CalibrationEntry { point } => {
                CALIBRATION_TARGETS.get(point_of_reading(point)).copied().unwrap_or(Kgf::ZERO)
            }
            _ => self.machine.record().settings.set_point().to_kgf(),
        }
    }

    fn inputs(&self, keys: Keys) -> Inputs {
        let load_cell = match self.env.band {
            Band::Unloaded => code_of(Kgf::ZERO),
            Band::Slack => code_of(Kgf::from_int(3)),
            Band::Target => code_of(self.target()),
            Band::Overload => code_of(Kgf::from_tenths(535)),
            Band::Negative => code_of(Kgf::from_tenths(-4)),
            Band::RailLow => AdcCode::MIN,
            Band::RailHigh => AdcCode::MAX,
        };
        let motor_current = if self.env.injected == Injected::Overcurrent {
            AdcCode::new(2_500)
        } else {
            AdcCode::new(200)
        };
        Inputs {
            now_ms: self.now_ms,
            load_cell,
            motor_current,
            bus_voltage: AdcCode::MIN,
            drive: DriveStatus {
                fault: self.drive_fault.then_some(DriveFault::HallInvalid),
                steps: self.steps,
                rotation: None,
                quiet_for: DriveTime::from_micros(self.quiet_ms.saturating_mul(1_000)),
                energized: None,
                current: CurrentSense::PAPER.amps(motor_current, AdcCode::MIN),
                bus: Volts::ZERO,
            },
            string_counter: u16::from_ne_bytes(
                self.steps.to_ne_bytes()[..2].try_into().unwrap_or([0, 0]),
            ),
            limits: self.env.limits(),
            keys,
        }
    }

    /// One tick with `keys` held; checks every property.
    pub fn tick(&mut self, keys: Keys) -> TickRecord {
        // The motor moves according to the command the machine gave last tick.
        let moving = match (self.last.drive, self.env.motor, self.drive_fault) {
            (DriveCommand::Drive { direction, .. }, Motor::Follows, false) => Some(direction),
            (DriveCommand::Drive { direction, .. }, Motor::Backwards, false) => {
                Some(direction.reversed())
            }
            _ => None,
        };
        match moving {
            Some(Direction::Pull) if !self.env.limits().end => {
                self.steps = self.steps.wrapping_add(1);
                self.quiet_ms = 0;
            }
            Some(Direction::Release) if !self.env.limits().home => {
                self.steps = self.steps.wrapping_sub(1);
                self.quiet_ms = 0;
            }
            _ => self.quiet_ms = self.quiet_ms.saturating_add(1),
        }
        let inputs = self.inputs(keys);
        let before = self.machine.state();
        let outputs = self.machine.tick(&inputs);
        let record = TickRecord { before, inputs, outputs, after: self.machine.state() };
        check_tick(&record);
        // The drive clears its fault when asked with the command at coast.
        if outputs.clear_drive_fault && outputs.drive == DriveCommand::Coast && self.drive_fault {
            self.drive_fault = false;
            if self.env.injected == Injected::DriveFault {
                self.env.injected = Injected::None;
            }
        }
        self.last = outputs;
        self.now_ms = self.now_ms.wrapping_add(1);
        record
    }

    /// Runs `action` to completion; returns the number of ticks simulated.
    pub fn act(&mut self, action: Action) -> u32 {
        let mut ticks = 0u32;
        let mut run = |world: &mut Self, keys: Keys, count: u32| {
            for _ in 0..count {
                world.tick(keys);
            }
            ticks = ticks.saturating_add(count);
        };
        match action {
            Action::Press(key) => {
                run(self, Keys::NONE.with(key), 30);
                run(self, Keys::NONE, 30);
            }
            Action::Hold(key) => {
                run(self, Keys::NONE.with(key), 1_600);
                run(self, Keys::NONE, 30);
            }
            Action::Move(position) => {
                self.env.position = position;
                run(self, Keys::NONE, 5);
            }
            Action::Tension(band) => {
                let before = self.machine.state();
                self.env.band = band;
                run(self, Keys::NONE, TENSION_FAULT_MS);
                tension_faults_stop_the_pull(before, band, self.machine.state());
            }
            Action::ToggleWiring => {
                self.env.wiring_fault = !self.env.wiring_fault;
                run(self, Keys::NONE, 5);
            }
            Action::Inject(injected) => {
                self.env.injected = injected;
                if injected == Injected::DriveFault {
                    self.drive_fault = true;
                }
                run(self, Keys::NONE, 5);
            }
            Action::Motor(motor) => {
                self.env.motor = motor;
                run(self, Keys::NONE, 5);
            }
            Action::Wait(count) => run(self, Keys::NONE, count),
            Action::WaitForChange(limit) => {
                let start = self.machine.state();
                // Only states with a timer longer than the 6 s wait can change by time alone
                // after it; elsewhere this action is the same as `Wait(6_000)`.
                let limit = if has_long_timer(start) { limit } else { 6_000 };
                for _ in 0..limit {
                    self.tick(Keys::NONE);
                    ticks = ticks.saturating_add(1);
                    if self.machine.state() != start {
                        break;
                    }
                }
            }
        }
        ticks
    }

    /// The abstract state.
    #[must_use]
    pub fn key(&self) -> Key {
        let state = self.machine.state();
        let ready = state == MachineState::Ready;
        Key {
            state,
            view: if ready { abstract_view(self.machine.view()) } else { View::Tension },
            knot: self.machine.knot_mode(),
            notice: self.machine.notice().is_some(),
            tensioned: state.is_moving() && self.machine.watch().peak >= safety::BREAK_MIN_PEAK,
            hold_timer: self.machine.hold().is_some_and(|hold| hold.timer),
            locked: !self.machine.constant_pull(),
            env: self.env,
            drive_fault: self.drive_fault,
        }
    }
}

/// A Ready page as the abstract state keeps it: the information pages' indices (which log
/// entry, field or item is shown) change only the digits, so each page is one abstract view.
#[must_use]
pub const fn abstract_view(view: View) -> View {
    match view {
        View::Log { .. } => View::Log { entry: 0, field: 0 },
        View::Counters(_) => View::Counters(0),
        View::String(_) => View::String(0),
        View::Service(_) => View::Service(0),
        other => other,
    }
}

/// An abstract state of machine and environment.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub struct Key {
    /// The machine's state.
    pub state: MachineState,
    /// The Ready page.
    pub view: View,
    /// Knot mode.
    pub knot: bool,
    /// A notice is pending.
    pub notice: bool,
    /// The pull has seen ≥ 5 kgf.
    pub tensioned: bool,
    /// Holding: the digits show the tension timer.
    pub hold_timer: bool,
    /// Constant pull switched off (holding).
    pub locked: bool,
    /// The environment.
    pub env: Env,
    /// The drive's latched fault.
    pub drive_fault: bool,
}

impl Key {
    /// Ready, or a fault on the display: the states every state must be able to reach.
    #[must_use]
    pub fn is_home_base(&self) -> bool {
        matches!(self.state, MachineState::Ready | MachineState::Fault(_))
    }
}

/// What the exploration found.
#[derive(Debug)]
pub struct Report {
    /// Abstract states explored.
    pub states: usize,
    /// Transitions (state, action) explored.
    pub transitions: usize,
    /// Machine ticks simulated (each checked against every property).
    pub ticks: u64,
    /// States from which no Ready or fault state is reachable.
    pub traps: Vec<Key>,
    /// The machine states seen.
    pub machine_states: HashSet<MachineState>,
    /// The holds seen: (the timer shown, constant pull off).
    pub holds: HashSet<(bool, bool)>,
    /// The Ready pages seen (as [`abstract_view`] keeps them).
    pub ready_views: HashSet<View>,
}

/// Explores every abstract state reachable from power-up in each of `starts`, checking every
/// tick; then checks that Ready or a fault display is reachable from every explored state.
/// Stops exploring after `limit` abstract states (the run reports how many it saw).
#[must_use]
pub fn explore(starts: &[Env], limit: usize) -> Report {
    let actions = actions();
    let mut seen: HashMap<Key, usize> = HashMap::new();
    let mut edges: Vec<Vec<usize>> = Vec::new();
    let mut keys: Vec<Key> = Vec::new();
    let mut queue: VecDeque<(usize, World)> = VecDeque::new();
    let mut ticks = 0u64;
    let mut transitions = 0usize;
    // How each state was first reached: (parent, action), for counterexample paths.
    let mut parents: Vec<Option<(usize, Action)>> = Vec::new();
    for &env in starts {
        let Some(world) = World::new(env) else { continue };
        let key = world.key();
        if let std::collections::hash_map::Entry::Vacant(slot) = seen.entry(key) {
            slot.insert(keys.len());
            queue.push_back((keys.len(), world));
            keys.push(key);
            edges.push(Vec::new());
            parents.push(None);
        }
    }
    while let Some((index, world)) = queue.pop_front() {
        for &action in &actions {
            let mut next = world.clone();
            let acted = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| next.act(action)));
            let simulated = match acted {
                Ok(simulated) => simulated,
                Err(failure) => {
                    // A property failed: print how the environment got here, then fail.
                    eprintln!("counterexample (environment actions from power-up):");
                    for step in path(&parents, index) {
                        eprintln!("  {step:?}");
                    }
                    eprintln!("  {action:?}   <- a property failed during this action");
                    std::panic::resume_unwind(failure);
                }
            };
            ticks = ticks.saturating_add(u64::from(simulated));
            transitions = transitions.saturating_add(1);
            let key = next.key();
            let target = match seen.get(&key) {
                Some(&target) => target,
                None => {
                    let target = keys.len();
                    seen.insert(key, target);
                    keys.push(key);
                    edges.push(Vec::new());
                    parents.push(Some((index, action)));
                    if keys.len() <= limit {
                        queue.push_back((target, next));
                    }
                    target
                }
            };
            if let Some(out) = edges.get_mut(index) {
                out.push(target);
            }
        }
    }
    // Backward search from the home-base states over the explored edges.
    let mut reverse: Vec<Vec<usize>> = vec![Vec::new(); keys.len()];
    for (from, targets) in edges.iter().enumerate() {
        for &to in targets {
            if let Some(list) = reverse.get_mut(to) {
                list.push(from);
            }
        }
    }
    let mut reaches = vec![false; keys.len()];
    let mut work: Vec<usize> = Vec::new();
    for (index, key) in keys.iter().enumerate() {
        if key.is_home_base() {
            if let Some(flag) = reaches.get_mut(index) {
                *flag = true;
            }
            work.push(index);
        }
    }
    while let Some(index) = work.pop() {
        for &from in reverse.get(index).map_or(&[][..], Vec::as_slice) {
            if let Some(flag) = reaches.get_mut(from) {
                if !*flag {
                    *flag = true;
                    work.push(from);
                }
            }
        }
    }
    // Only states that were expanded count (unexpanded ones beyond the limit have no edges).
    let expanded = keys.len().min(limit);
    let traps = keys
        .iter()
        .zip(&reaches)
        .take(expanded)
        .filter(|(_, reached)| !**reached)
        .map(|(key, _)| *key)
        .collect();
    let machine_states = keys.iter().map(|key| key.state).collect();
    let holds = keys
        .iter()
        .filter(|key| key.state == MachineState::Holding)
        .map(|key| (key.hold_timer, key.locked))
        .collect();
    let ready_views =
        keys.iter().filter(|key| key.state == MachineState::Ready).map(|key| key.view).collect();
    Report { states: keys.len(), transitions, ticks, traps, machine_states, holds, ready_views }
}

/// The actions that first reached state `index`, from power-up.
fn path(parents: &[Option<(usize, Action)>], mut index: usize) -> Vec<Action> {
    let mut steps = Vec::new();
    // Bound: every parent was discovered before its child, so the walk strictly descends.
    while let Some(Some((parent, action))) = parents.get(index) {
        steps.push(*action);
        index = *parent;
    }
    steps.reverse();
    steps
}

//! `taut panel`: the machine's front panel in a terminal — keys in, 7-segment display, lamps,
//! beeper and a tension gauge out — with the machine running on the twin in real time, or
//! driven by a script.
//!
//! # Theory of operation
//!
//! A [`PanelSession`] is a [`Bench`] (the firmware's [`taut_core::machine::Machine`] on the
//! twin, see [`crate::cycle`]) plus the key levels a person is holding down. Each
//! [`PanelSession::tick`] puts those levels on the twin's key inputs and runs one 1 ms tick;
//! the machine alone decides what happens (debounce, repeat, long presses, states, faults).
//! [`PanelSession::frame`] draws the panel from the machine's outputs only: the display from
//! its segment bitmaps ([`display::art`]), the lamps from `Outputs::leds`, the beeper from
//! `Outputs::beeper`; beside them a tension gauge (the reference gauge in the string path:
//! what the string really carries, with the set point marked), the carriage position and the
//! machine's state name — what a firmware developer wants to see while trying the UI.
//!
//! Two front ends share it:
//!
//! - [`terminal`] (interactive): raw keyboard input through `crossterm`, ticks paced to the
//!   wall clock (1 ms of machine time per 1 ms of real time, or `--rate` times that), the
//!   frame redrawn about 30 times a second. A terminal reports key *presses* but usually not
//!   releases, so each key press holds the key for [`TAP_MS`] (auto-repeat extends it);
//!   the long presses (Function: knot mode, Preset: store) have their own keys (`F`, `P`).
//!   Where the terminal supports the keyboard-enhancement protocol (kitty, foot, WezTerm,
//!   recent Alacritty/iTerm2), real press and release events are used instead.
//! - [`script`] (no terminal): a small text format of key presses, waits and checks, run as
//!   fast as the twin goes; it prints a transcript (and frames) to stdout. Tests drive the
//!   panel through it.

pub use taut_sim::operator::display;
pub mod script;
pub mod terminal;

use taut_core::io::{Key, Keys, Outputs};
use taut_core::machine::MachineState;
use taut_core::store::{RECORD_LEN, Record, Unit};
use taut_sim::{StringKind, TwinConfig};

use crate::cycle::{Bench, commission, factory_config, kgf, state_name};

/// How long a key stays down after a key press from a terminal without release events, ms.
pub const TAP_MS: u64 = 150;
/// How long a "long press" key (`F`, `P`) holds Function or Preset down, ms (the machine
/// needs 1.5 s after its 20 ms debounce).
pub const LONG_PRESS_HOLD_MS: u64 = 1_700;
/// Full scale of the tension gauge, kgf.
pub const GAUGE_FULL_SCALE_KGF: f64 = 50.0;
/// Width of the tension gauge's bar, characters.
pub const GAUGE_WIDTH: usize = 50;

/// What the machine's flash holds at power-up.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, clap::ValueEnum)]
pub enum Flash {
    /// The record a commissioning session leaves (4-point calibration, previous job's
    /// settings), as the main job uses.
    #[default]
    Calibrated,
    /// Factory defaults (25.0 kg, no calibration): calibrate it yourself in the `CAL?`
    /// window with Function, reading the gauge.
    Factory,
    /// Erased flash: the machine starts on defaults and shows the `E-20` notice.
    Blank,
}

/// `taut panel` options.
#[derive(clap::Args, Clone, Debug)]
pub struct PanelArgs {
    /// String on the machine (badminton-soft … tennis-poly, none).
    #[arg(long, default_value = "tennis-synthetic", value_name = "KIND")]
    pub string: StringKind,
    /// A Monte-Carlo scenario of the twin instead of the nominal machine.
    #[arg(long)]
    pub seed: Option<u64>,
    /// What the machine's flash holds at power-up.
    #[arg(long, value_enum, default_value_t = Flash::Calibrated)]
    pub flash: Flash,
    /// Run this script (`-` = standard input) instead of the interactive panel; prints a
    /// transcript to stdout. See `taut panel --help-script`.
    #[arg(long, value_name = "FILE")]
    pub script: Option<std::path::PathBuf>,
    /// Script mode: also print the whole panel after every command.
    #[arg(long)]
    pub frames: bool,
    /// Interactive mode: machine milliseconds per real millisecond.
    #[arg(long, default_value_t = 1.0, value_name = "FACTOR")]
    pub rate: f64,
    /// Print the script format and exit.
    #[arg(long)]
    pub help_script: bool,
}

/// The machine on the twin with a person's key levels.
pub struct PanelSession {
    bench: Bench,
    keys: Keys,
    string: StringKind,
    seed: Option<u64>,
    last_outputs: Outputs,
}

impl PanelSession {
    /// A session on a twin of `string` (nominal, or scenario `seed`) whose machine powers up
    /// from `flash`. [`Flash::Calibrated`] first runs a commissioning session on the same
    /// twin configuration (a fraction of a second).
    ///
    /// # Errors
    /// The commissioning failed.
    pub fn new(
        string: StringKind,
        seed: Option<u64>,
        flash: Flash,
    ) -> Result<Self, crate::cycle::CycleError> {
        let config = seed.map_or_else(
            || TwinConfig::nominal(string),
            |seed| TwinConfig::sample_kind(string, seed),
        );
        let bytes = match flash {
            Flash::Calibrated => commission(&factory_config(&config), true, &mut |_| {})?.flash,
            Flash::Factory => Record::default().encode(),
            Flash::Blank => [0xFF; RECORD_LEN],
        };
        Ok(Self {
            bench: Bench::power_up(&config, &bytes),
            keys: Keys::NONE,
            string,
            seed,
            last_outputs: Outputs::default(),
        })
    }

    /// Puts `key` down (it stays down until [`PanelSession::release`]).
    pub fn press(&mut self, key: Key) {
        self.keys = self.keys.with(key);
    }

    /// Lets `key` go.
    pub fn release(&mut self, key: Key) {
        self.keys = Keys::from_bits(self.keys.bits() & !Keys::NONE.with(key).bits());
    }

    /// Sets every key level at once.
    pub fn set_keys(&mut self, keys: Keys) {
        self.keys = keys;
    }

    /// The keys held down.
    #[must_use]
    pub const fn keys(&self) -> Keys {
        self.keys
    }

    /// One 1 ms tick with the keys held now; returns the machine's outputs.
    pub fn tick(&mut self) -> Outputs {
        let keys = self.keys;
        self.bench.twin_mut().set_keys(keys);
        self.last_outputs = self.bench.tick(|_| {});
        self.last_outputs
    }

    /// Milliseconds since power-up.
    #[must_use]
    pub fn now_ms(&self) -> u64 {
        self.bench.twin().now_ms()
    }

    /// The machine's outputs of the last tick.
    #[must_use]
    pub const fn outputs(&self) -> &Outputs {
        &self.last_outputs
    }

    /// The machine's state.
    #[must_use]
    pub fn state(&self) -> MachineState {
        self.bench.machine().state()
    }

    /// The bench (machine and twin).
    #[must_use]
    pub const fn bench(&self) -> &Bench {
        &self.bench
    }

    /// The bench, to inject twin faults or break the string.
    pub fn bench_mut(&mut self) -> &mut Bench {
        &mut self.bench
    }

    /// The reference gauge's reading now (true tension + its σ = 0.02 kgf noise), kgf.
    pub fn read_gauge(&mut self) -> f64 {
        self.bench.twin_mut().reference_gauge()
    }

    /// The set point as the machine stored it, in kgf.
    #[must_use]
    pub fn set_point_kgf(&self) -> f64 {
        kgf(self.bench.machine().record().settings.set_point().to_kgf())
    }

    /// One transcript line: time, state, display text, lamps lit, beeper.
    #[must_use]
    pub fn status_line(&self) -> String {
        let out = &self.last_outputs;
        format!(
            "t={:9.3} s  state={:<20} display=[{:<5}]  leds={:<16} beep={}  tension={:6.2} kgf",
            self.now_ms() as f64 / 1_000.0,
            state_name(self.state()),
            display::text(&out.display),
            lamps(out),
            if out.beeper { "on " } else { "off" },
            self.bench.twin().truth().tension_kgf,
        )
    }

    /// The whole panel as lines of text (see the module docs).
    #[must_use]
    pub fn frame(&self) -> Vec<String> {
        let out = &self.last_outputs;
        let truth = self.bench.twin().truth();
        let scenario = self.seed.map_or_else(|| "nominal".to_owned(), |s| format!("seed {s}"));
        let [a, b, c] = display::art(&out.display);
        let led = |on: bool, name: &str| format!("[{}] {name:<6}", if on { '*' } else { ' ' });
        let mut lines = Vec::with_capacity(12);
        lines.push(format!(
            "+-- taut front panel -- {} ({scenario}) -- t = {:.3} s",
            self.string.name(),
            self.now_ms() as f64 / 1_000.0
        ));
        lines.push(format!(
            "|   {a}    {}{}{}",
            led(out.leds.kg, "kg"),
            led(out.leds.lb, "lb"),
            led(out.leds.knot, "knot")
        ));
        lines.push(format!(
            "|   {b}    {}{}{}",
            led(out.leds.pulling, "pull"),
            led(out.leds.holding, "hold"),
            led(out.leds.fault, "fault")
        ));
        lines.push(format!("|   {c}    beeper: {}", if out.beeper { "BEEP" } else { "-" }));
        lines.push(format!(
            "| state: {:<20} carriage {:6.1} mm   string {:?}",
            state_name(self.state()),
            truth.carriage_mm,
            truth.string
        ));
        lines.push(format!(
            "| gauge {} {:6.2} kgf",
            gauge_bar(truth.tension_kgf, self.set_point_kgf()),
            truth.tension_kgf
        ));
        let unit = self.bench.machine().record().settings.set_point().unit();
        lines.push(format!(
            "|       0 kgf {:>width$} set point {:.1} {}",
            format!("{GAUGE_FULL_SCALE_KGF:.0} kgf"),
            f64::from(self.bench.machine().record().settings.set_point().tenths()) / 10.0,
            if unit == Unit::Pounds { "lb" } else { "kg" },
            width = GAUGE_WIDTH - 4
        ));
        lines.push("| keys: Up/+  Down/-  Start: space/Enter  Function: f (F = hold)  Preset: p (P = hold)".to_owned());
        lines.push("|       b breaks the string, q quits".to_owned());
        lines.push("+--".to_owned());
        lines
    }
}

/// The lamps lit, as a comma-separated list (`kg,hold`), or `-`.
#[must_use]
pub fn lamps(outputs: &Outputs) -> String {
    let l = outputs.leds;
    let names: Vec<&str> = [
        (l.kg, "kg"),
        (l.lb, "lb"),
        (l.pulling, "pull"),
        (l.holding, "hold"),
        (l.fault, "fault"),
        (l.knot, "knot"),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, name)| *name)
    .collect();
    if names.is_empty() { "-".to_owned() } else { names.join(",") }
}

/// The gauge bar: `[####....|....]`, filled to `tension_kgf` of [`GAUGE_FULL_SCALE_KGF`], with
/// `|` at the set point.
#[must_use]
pub fn gauge_bar(tension_kgf: f64, set_point_kgf: f64) -> String {
    let cells = |kgf: f64| {
        ((kgf / GAUGE_FULL_SCALE_KGF * GAUGE_WIDTH as f64).round().clamp(0.0, GAUGE_WIDTH as f64))
            as usize
    };
    let filled = cells(tension_kgf);
    let mark = cells(set_point_kgf).min(GAUGE_WIDTH - 1);
    let mut bar = String::with_capacity(GAUGE_WIDTH + 2);
    bar.push('[');
    for cell in 0..GAUGE_WIDTH {
        bar.push(if cell == mark {
            '|'
        } else if cell < filled {
            '#'
        } else {
            '.'
        });
    }
    bar.push(']');
    bar
}

/// `taut panel`: the interactive panel, or the script; returns the process exit code.
#[must_use]
pub fn main(args: &PanelArgs) -> i32 {
    if args.help_script {
        println!("{}", script::FORMAT_HELP);
        return 0;
    }
    let mut session = match PanelSession::new(args.string, args.seed, args.flash) {
        Ok(session) => session,
        Err(error) => {
            eprintln!("taut panel: {error}");
            return 2;
        }
    };
    match &args.script {
        Some(path) => {
            let text = if path.as_os_str() == "-" {
                let mut text = String::new();
                match std::io::Read::read_to_string(&mut std::io::stdin(), &mut text) {
                    Ok(_) => text,
                    Err(error) => {
                        eprintln!("taut panel: reading the script: {error}");
                        return 2;
                    }
                }
            } else {
                match std::fs::read_to_string(path) {
                    Ok(text) => text,
                    Err(error) => {
                        eprintln!("taut panel: {}: {error}", path.display());
                        return 2;
                    }
                }
            };
            let parsed = match script::Script::parse(&text) {
                Ok(parsed) => parsed,
                Err(error) => {
                    eprintln!("taut panel: {}: {error}", path.display());
                    return 2;
                }
            };
            let mut stdout = std::io::stdout().lock();
            match parsed.run(&mut session, args.frames, &mut stdout) {
                Ok(()) => 0,
                Err(failure) => {
                    eprintln!("taut panel: {}: {failure}", path.display());
                    1
                }
            }
        }
        None => match terminal::run(&mut session, args.rate) {
            Ok(()) => 0,
            Err(error) => {
                eprintln!("taut panel: {error}");
                2
            }
        },
    }
}

//! Faults injected at the part's pins while the image strings: each starts from the same
//! commissioned machine (its settings pages of flash), pulls, and at a set moment of the pull
//! or the hold puts a fault on the pins. A fault passes when the machine latches it on the
//! panel (`E-nn`, the fault lamp) within its deadline, every gate is off from then on, and
//! the gate checks stay clean; the watchdog's when the part resets and comes back with its
//! bridge off; the power cut's when the settings survive it.

use taut_core::drive::Phase;
use taut_sim::operator::{Operator, Plan, display};
use taut_sim::twin::{Fault, LimitSwitch, Twin};

use crate::bench::Bench;
use crate::cycle::Scenario;
use crate::elf::Image;
use crate::mcu::Mcu;
use crate::soc::{FLASH_BASE, Stop};

/// The settings store's pages (the last four of the G431's flash).
pub const SETTINGS: (u32, usize) = (FLASH_BASE + 0x1_E000, 0x2000);

/// What is injected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Injection {
    /// The overcurrent comparator pulls the break input (PA6) low for 1 ms mid-pull.
    Overcurrent,
    /// All three Hall lines read low (000) mid-pull.
    HallLow,
    /// All three Hall lines read high (111) mid-pull.
    HallHigh,
    /// Both limit switches read actuated mid-pull.
    BothLimits,
    /// The string breaks in the hold.
    StringBreak,
    /// The control tick's timer stops mid-pull (a stuck control task): nothing pets the
    /// watchdog.
    StuckTick,
    /// The supply is cut while the settings store programs the flash.
    PowerCutInStore,
}

impl Injection {
    /// Every injection.
    pub const ALL: [Self; 7] = [
        Self::Overcurrent,
        Self::HallLow,
        Self::HallHigh,
        Self::BothLimits,
        Self::StringBreak,
        Self::StuckTick,
        Self::PowerCutInStore,
    ];

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Overcurrent => "overcurrent comparator on the break input (PA6)",
            Self::HallLow => "Hall lines 000",
            Self::HallHigh => "Hall lines 111",
            Self::BothLimits => "both limit switches",
            Self::StringBreak => "string break in the hold",
            Self::StuckTick => "control tick stopped (watchdog)",
            Self::PowerCutInStore => "power cut while the settings are written",
        }
    }

    /// The panel code the machine must latch, and within how many ms of the injection.
    fn expected(self) -> Option<(&'static str, u64)> {
        match self {
            Self::Overcurrent => Some(("E-11", 20)),
            Self::HallLow | Self::HallHigh => Some(("E-12", 20)),
            Self::BothLimits => Some(("E-01", 20)),
            Self::StringBreak => Some(("E-15", 50)),
            Self::StuckTick | Self::PowerCutInStore => None,
        }
    }
}

/// One injection's outcome.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// What.
    pub injection: Injection,
    /// Passed.
    pub passed: bool,
    /// What was seen.
    pub detail: String,
    /// Gate-level violations in the run.
    pub violations: usize,
}

/// Commissions a machine on the image (no calibration) and returns its settings pages.
pub fn commissioned_flash(image: &Image, scenario: &Scenario) -> Result<Vec<u8>, Stop> {
    let run = crate::cycle::commission(image.clone(), scenario)?;
    Ok(run.mcu.read_memory(SETTINGS.0, SETTINGS.1))
}

fn bench_from(image: &Image, flash: &[u8], scenario: &Scenario) -> Result<Bench, Stop> {
    let mut mcu = Mcu::new(image.clone()).map_err(Stop::Misuse)?;
    mcu.write_memory(SETTINGS.0, flash).map_err(Stop::Misuse)?;
    Ok(Bench::new(mcu, Twin::new(&scenario.config())))
}

fn panel_text(bench: &Bench) -> (String, bool) {
    let (d, leds) = bench.panel();
    (display::text(&d), leds.fault)
}

/// Runs one injection.
pub fn run(image: &Image, flash: &[u8], scenario: &Scenario, injection: Injection) -> Outcome {
    match run_inner(image, flash, scenario, injection) {
        Ok(o) => o,
        Err(stop) => Outcome {
            injection,
            passed: false,
            detail: format!("the run stopped: {stop}"),
            violations: 0,
        },
    }
}

fn run_inner(
    image: &Image,
    flash: &[u8],
    scenario: &Scenario,
    injection: Injection,
) -> Result<Outcome, Stop> {
    let mut bench = bench_from(image, flash, scenario)?;
    let plan = Plan {
        calibrate: false,
        settings: scenario.settings(),
        knot_mode: false,
        pull_hold_ms: Some(3_000),
    };
    if injection == Injection::PowerCutInStore {
        return power_cut(image, scenario, bench);
    }
    let mut operator = Operator::new(plan);
    let mut pulling_since = None;
    let mut holding_since = None;
    let mut injected_at: Option<u64> = None;
    let mut injected_cycle = 0;
    for _ in 0..40_000u32 {
        bench.tick()?;
        let now = bench.twin.now_ms();
        let (_, leds) = bench.panel();
        if leds.pulling && pulling_since.is_none() {
            pulling_since = Some(now);
        }
        if leds.holding && holding_since.is_none() {
            holding_since = Some(now);
        }
        if injected_at.is_none() {
            let due = match injection {
                Injection::StringBreak => holding_since.is_some_and(|h| now >= h + 500),
                _ => pulling_since.is_some_and(|p| now >= p + 600),
            };
            if due {
                injected_at = Some(now);
                let cycle = bench.mcu.cycles();
                match injection {
                    Injection::Overcurrent => bench.force_break = true,
                    Injection::HallLow | Injection::HallHigh => {
                        let level = injection == Injection::HallHigh;
                        for phase in [Phase::A, Phase::B, Phase::C] {
                            bench.twin.inject(Fault::HallLineStuck { phase, level });
                        }
                    }
                    Injection::BothLimits => {
                        bench.twin.inject(Fault::LimitSwitchStuck {
                            switch: LimitSwitch::Home,
                            closed: true,
                        });
                        bench.twin.inject(Fault::LimitSwitchStuck {
                            switch: LimitSwitch::End,
                            closed: true,
                        });
                    }
                    Injection::StringBreak => bench.twin.break_string(),
                    Injection::StuckTick => bench.mcu.soc_mut().tim6.running = false,
                    Injection::PowerCutInStore => {}
                }
                injected_cycle = cycle;
            }
        }
        if injection == Injection::Overcurrent && injected_at.is_some_and(|t| now > t) {
            // The comparator releases once the bridge is off.
            bench.force_break = false;
        }
        if injected_at.is_none() {
            operator.act(&mut bench.twin);
        }
        if let Some(t) = injected_at {
            if injection == Injection::StuckTick {
                if let Some(&(at, why)) =
                    bench.mcu.cpu.resets.last().filter(|(_, why)| why.starts_with("watchdog"))
                {
                    // Back safe: the part booted again and its panel shows the self-test.
                    let (text, _) = panel_text(&bench);
                    if now > t + 150 && bench.gates_off_since(at) {
                        let latency_ms = (at as f64 / 170e3) - (t as f64);
                        return Ok(Outcome {
                            injection,
                            passed: bench.checker.violations.is_empty(),
                            detail: format!(
                                "{why} reset {latency_ms:.0} ms after the tick stopped (IWDG timeout 100 ms); gates off since; the panel shows [{text}]"
                            ),
                            violations: bench.checker.violations.len(),
                        });
                    }
                }
                if now > t + 400 {
                    return Ok(Outcome {
                        injection,
                        passed: false,
                        detail: "no watchdog reset within 400 ms".into(),
                        violations: bench.checker.violations.len(),
                    });
                }
                continue;
            }
            let (code, deadline) = injection.expected().unwrap_or(("", 0));
            let (text, fault) = panel_text(&bench);
            if fault && text == code {
                // The break input switches the outputs off in hardware, within the
                // comparator's filter (8 clocks) of the trip; every other fault within the
                // tick that latches it.
                let since = if injection == Injection::Overcurrent {
                    injected_cycle + 8
                } else {
                    bench.mcu.cycles()
                };
                // Stay a while: the fault stays latched and the gates off.
                for _ in 0..100 {
                    bench.tick()?;
                }
                let (text2, fault2) = panel_text(&bench);
                let off = bench.gates_off_since(since);
                let passed = fault2 && text2 == code && off && bench.checker.violations.is_empty();
                return Ok(Outcome {
                    injection,
                    passed,
                    detail: format!(
                        "[{code}] with the fault lamp {} ms after the injection; 100 ms later [{text2}], gates {}",
                        now - t,
                        if off { "off" } else { "NOT off" }
                    ),
                    violations: bench.checker.violations.len(),
                });
            }
            if now > t + deadline {
                return Ok(Outcome {
                    injection,
                    passed: false,
                    detail: format!(
                        "no [{code}] within {deadline} ms: the panel shows [{text}] (fault lamp {fault})"
                    ),
                    violations: bench.checker.violations.len(),
                });
            }
        }
    }
    Ok(Outcome {
        injection,
        passed: false,
        detail: "the pull never reached the injection point".into(),
        violations: bench.checker.violations.len(),
    })
}

/// The power cut: the operator changes the set point; when the firmware starts programming
/// the record, the part loses power (mid-write: what was programmed stays, the rest never
/// happens). Powered up again, the machine must show either set point and no store notice.
fn power_cut(image: &Image, scenario: &Scenario, mut bench: Bench) -> Result<Outcome, Stop> {
    // The commissioned record holds the previous job's settings; the operator keys 1 kg more.
    let stored = taut_sim::operator::previous_job();
    let original = display_of(&stored);
    let tenths = stored.set_point().tenths().saturating_add(10);
    let settings = taut_core::settings::SetPoint::new(taut_core::settings::Unit::Kilograms, tenths)
        .and_then(|up| taut_core::settings::Settings::new(up, 3, 0, 0))
        .unwrap_or(stored);
    let changed = display_of(&settings);
    let plan = Plan { calibrate: false, settings, knot_mode: false, pull_hold_ms: None };
    let mut operator = Operator::new(plan);
    let before = bench.mcu.soc().flash.programmed;
    let mut cut = None;
    for _ in 0..30_000u32 {
        bench.tick()?;
        operator.act(&mut bench.twin);
        // Cut a few double words into the write.
        if bench.mcu.soc().flash.programmed >= before + 3 {
            cut = Some(bench.twin.now_ms());
            break;
        }
    }
    let Some(_) = cut else {
        return Ok(Outcome {
            injection: Injection::PowerCutInStore,
            passed: false,
            detail: "the firmware never stored the changed set point".into(),
            violations: bench.checker.violations.len(),
        });
    };
    let flash = bench.mcu.read_memory(SETTINGS.0, SETTINGS.1);
    let violations = bench.checker.violations.len();
    let mut again = bench_from(image, &flash, scenario)?;
    // Power-up: the self-test, homing, then the tension page.
    let mut seen = String::new();
    let mut shown: Vec<String> = Vec::new();
    for _ in 0..5_000u32 {
        again.tick()?;
        let (text, fault) = panel_text(&again);
        if shown.last() != Some(&text) {
            shown.push(text.clone());
            // An uncalibrated machine offers the calibration at power-up: skip it.
            if text == "CAL?" {
                again.twin.press(taut_core::io::Keys::NONE.with(taut_core::io::Key::Start), 80);
            }
        }
        if fault || text.starts_with("n-") {
            return Ok(Outcome {
                injection: Injection::PowerCutInStore,
                passed: false,
                detail: format!("after the cut the machine shows [{text}]"),
                violations,
            });
        }
        if text == original || text == changed {
            seen = text;
            break;
        }
    }
    let passed = !seen.is_empty() && violations == 0;
    Ok(Outcome {
        injection: Injection::PowerCutInStore,
        passed,
        detail: if passed {
            format!(
                "power cut 3 double words into the write; powered up again showing [{seen}] (before [{original}], keyed [{changed}]), no notice"
            )
        } else {
            format!(
                "the machine came back with neither [{original}] nor [{changed}]: it showed {shown:?}"
            )
        },
        violations,
    })
}

fn display_of(settings: &taut_core::settings::Settings) -> String {
    let tenths = settings.set_point().tenths();
    format!("{:>3}.{}", tenths / 10, tenths % 10)
}

//! The main job's plot: tension (true, target, the panel's reading), carriage, duty, current
//! and the machine's state timeline on one time axis, and the hold zoomed to ±0.2 kgf
//! around the target.

use taut_core::machine::MachineState;
use taut_sim::bench::{Transition, state_name};

use super::CycleRun;
use super::summary::{duty_percent, entered, machine_text, panel_kgf, settings_text, summary};
use crate::plot::{Band, DUTY_AXIS_PERCENT, Figure, Panel, Series, Stroke};

/// Half-height of the zoomed hold panel, kgf.
pub const HOLD_ZOOM_KGF: f64 = 0.2;

/// The colour of a state's band on the timeline.
const fn state_colour(state: MachineState) -> &'static str {
    match state {
        MachineState::SelfTest | MachineState::MotorTest => "#bcbddc",
        MachineState::Homing => "#9ecae1",
        MachineState::CalibrationWindow => "#c7e9c0",
        MachineState::CalibrationPull { .. } | MachineState::CalibrationEntry { .. } => "#fdd0a2",
        MachineState::Ready => "#e5e5e5",
        MachineState::Pulling => "#6baed6",
        MachineState::Holding => "#31a354",
        MachineState::Releasing => "#fd8d3c",
        MachineState::Fault(_) => "#de2d26",
    }
}

/// One band per state the machine was in, from `transitions` until `end_s`.
#[must_use]
pub fn timeline(transitions: &[Transition], end_s: f64) -> Vec<Band> {
    transitions
        .iter()
        .enumerate()
        .map(|(index, t)| {
            let from = t.t_ms as f64 / 1_000.0;
            let to = transitions.get(index + 1).map_or(end_s, |n| n.t_ms as f64 / 1_000.0);
            let name = state_name(t.state);
            let key = match t.state {
                MachineState::CalibrationPull { .. } | MachineState::CalibrationEntry { .. } => {
                    "calibration".to_owned()
                }
                MachineState::SelfTest | MachineState::MotorTest => "self/motor test".to_owned(),
                _ => name.clone(),
            };
            Band { from, to, label: name, key, colour: state_colour(t.state) }
        })
        .collect()
}

/// The plot (see the module docs).
#[must_use]
pub fn figure(run: &CycleRun) -> Figure {
    let (target, _) = run.targets_kgf();
    let s = summary(run);
    let t = |ms: u64| ms as f64 / 1_000.0;
    let all = |value: &dyn Fn(&taut_sim::bench::Row) -> f64| {
        run.rows.iter().map(|r| (t(r.t_ms), value(r))).collect::<Vec<_>>()
    };
    let pulling = entered(run, MachineState::Pulling, 0);
    let releasing = pulling.and_then(|p| entered(run, MachineState::Releasing, p));
    let end = run.rows.last().map_or(0, |r| r.t_ms);
    let target_line = pulling
        .map_or_else(Vec::new, |p| vec![(t(p), target), (t(releasing.unwrap_or(end)), target)]);
    let panel_reading: Vec<(f64, f64)> = (0..run.rows.len())
        .filter_map(|i| panel_kgf(run, i).map(|v| (t(run.rows[i].t_ms), v)))
        .collect();
    let bands = timeline(&run.transitions, t(end));
    let mut panels = vec![
        Panel::new(
            "tension (kgf)",
            vec![
                Series::new("panel reading", panel_reading.clone()).stroke(Stroke::Thin),
                Series::new("true tension", all(&|r| r.truth.tension_kgf)),
                Series::new("target", target_line).stroke(Stroke::Dashed).colour("#555555"),
            ],
        ),
        Panel::new("carriage (mm)", vec![Series::new("carriage", all(&|r| r.truth.carriage_mm))])
            .with_height(120.0),
        Panel::new(
            "duty (%, − = release)",
            vec![Series::new("commanded duty", all(&|r| duty_percent(r)))],
        )
        .with_y_range(-DUTY_AXIS_PERCENT, DUTY_AXIS_PERCENT)
        .with_height(120.0),
        Panel::new(
            "winding current (A)",
            vec![
                Series::new("tick mean", all(&|r| r.truth.current_a)),
                Series::new("peak in the tick", all(&|r| r.truth.peak_current_a))
                    .stroke(Stroke::Thin),
            ],
        )
        .with_height(120.0),
        Panel::timeline("state", bands),
    ];
    let holding = pulling.and_then(|p| entered(run, MachineState::Holding, p));
    if let (Some(from), Some(to)) = (holding, releasing) {
        let (from_s, to_s) = (t(from) - 0.5, t(to) + 0.5);
        let window = |points: Vec<(f64, f64)>| {
            points
                .into_iter()
                .filter(|(x, _)| *x >= from_s && *x <= to_s)
                .map(|(x, y)| (x, y - target))
                .collect::<Vec<_>>()
        };
        panels.push(
            Panel::new(
                "hold: tension − target (kgf)",
                vec![
                    Series::new("panel reading (0.1 kg)", window(panel_reading))
                        .stroke(Stroke::Thin),
                    Series::new("true tension", window(all(&|r| r.truth.tension_kgf))),
                    Series::new("target", vec![(from_s, 0.0), (to_s, 0.0)])
                        .stroke(Stroke::Dashed)
                        .colour("#555555"),
                ],
            )
            .with_y_range(-HOLD_ZOOM_KGF, HOLD_ZOOM_KGF)
            .with_x_range(from_s, to_s, "time since power-up (s), the hold zoomed in"),
        );
    }
    let title = format!("taut main job: {} at {}", s.string, settings_text(run, &s.set_point));
    let subtitle = format!(
        "{}, {}, current sensing {} — the firmware's machine on the digital twin, worked by a simulated operator",
        machine_text(run),
        if run.commissioning.record.calibration.is_some() {
            "4-point calibrated"
        } else {
            "uncalibrated"
        },
        s.current_sensing
    );
    Figure::new(&title, &subtitle, "time since power-up (s)", panels)
}

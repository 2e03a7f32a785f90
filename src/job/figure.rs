//! The main job's plot: tension (true, target, a pre-stretch's or knot's peak target, the
//! panel's reading, a fault's moment), carriage, duty, current and the machine's state
//! timeline on one time axis, and the hold zoomed around the target. Tensions are in the
//! unit the job was set in (kgf or lb). The zoom is ±0.2 kgf (±0.5 lb) when the hold is that
//! close, wider when it is not (an uncalibrated machine holds off target), at most
//! [`HOLD_ZOOM_MAX`] units; what lies beyond is marked off scale on the plot.

use taut_core::machine::MachineState;
use taut_core::settings::Unit;
use taut_sim::bench::{Transition, fault_name, state_name};

use super::CycleRun;
use super::summary::{duty_percent, entered, machine_text, panel_kgf, settings_text, summary};
use crate::plot::{Band, DUTY_AXIS_PERCENT, Figure, Panel, Series, Stroke};

/// Half-heights the zoomed hold panel chooses from, in the job's unit: the smallest that
/// holds the hold's true tension (after its first half second) with a margin.
pub const HOLD_ZOOMS: [f64; 6] = [0.2, 0.5, 1.0, 2.0, 5.0, HOLD_ZOOM_MAX];
/// The widest half-height of the zoomed hold panel, in the job's unit.
pub const HOLD_ZOOM_MAX: f64 = 10.0;
/// Pounds per kilogram (force).
const LB_PER_KG: f64 = 1.0 / 0.453_592_37;

/// The job's unit's name on the axes (`kgf`, `lb`) and its size per kgf.
#[must_use]
pub fn unit_of(run: &CycleRun) -> (&'static str, f64) {
    match run.settings.set_point().unit() {
        Unit::Kilograms => ("kgf", 1.0),
        Unit::Pounds => ("lb", LB_PER_KG),
    }
}

/// The zoomed hold panel's half-height for a largest hold error of `error` (in the job's
/// unit; `least` is the narrowest half-height in that unit).
#[must_use]
pub fn hold_zoom(error: f64, least: f64) -> f64 {
    let wanted = error.abs() * 1.2;
    HOLD_ZOOMS
        .iter()
        .copied()
        .filter(|&z| z >= least)
        .find(|&z| z >= wanted)
        .unwrap_or(HOLD_ZOOM_MAX)
}

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
    let (unit, per_kgf) = unit_of(run);
    let (target, peak) = run.targets_kgf();
    let (target, peak) = (target * per_kgf, peak * per_kgf);
    let s = summary(run);
    let t = |ms: u64| ms as f64 / 1_000.0;
    let all = |value: &dyn Fn(&taut_sim::bench::Row) -> f64| {
        run.rows.iter().map(|r| (t(r.t_ms), value(r))).collect::<Vec<_>>()
    };
    let tension = || all(&|r| r.truth.tension_kgf * per_kgf);
    let pulling = entered(run, MachineState::Pulling, 0);
    let releasing = pulling.and_then(|p| entered(run, MachineState::Releasing, p));
    let end = run.rows.last().map_or(0, |r| r.t_ms);
    let target_line = pulling
        .map_or_else(Vec::new, |p| vec![(t(p), target), (t(releasing.unwrap_or(end)), target)]);
    let panel_reading: Vec<(f64, f64)> = (0..run.rows.len())
        .filter_map(|i| panel_kgf(run, i).map(|v| (t(run.rows[i].t_ms), v * per_kgf)))
        .collect();
    let bands = timeline(&run.transitions, t(end));
    let holding = pulling.and_then(|p| entered(run, MachineState::Holding, p));
    let mut tension_series = vec![
        Series::new("panel reading", panel_reading.clone()).stroke(Stroke::Thin),
        Series::new("true tension", tension()),
        Series::new("target", target_line).stroke(Stroke::Dashed).colour("#555555"),
    ];
    if let Some(p) = pulling.filter(|_| peak > target + 1e-9) {
        // A pre-stretch or a knot pull goes to its peak first, then settles to the target.
        let what = if run.options.knot_percent.is_some() { "knot" } else { "pre-stretch" };
        let to = holding.or(releasing).unwrap_or(end);
        tension_series.push(
            Series::new(&format!("peak target ({what})"), vec![(t(p), peak), (t(to), peak)])
                .stroke(Stroke::Dashed)
                .colour("#9e6a00"),
        );
    }
    let fault = run.transitions.iter().find_map(|tr| match tr.state {
        MachineState::Fault(code) => Some((t(tr.t_ms), code)),
        _ => None,
    });
    if let Some((at, code)) = fault {
        // The fault's moment, across the tension axis.
        let top = tension().iter().map(|p| p.1).fold(target, f64::max);
        tension_series.push(
            Series::new(
                &format!("fault {} at {at:.2} s", fault_name(code)),
                vec![(at, 0.0), (at, top)],
            )
            .colour("#de2d26"),
        );
    }
    let mut panels = vec![
        Panel::new(&format!("tension ({unit})"), tension_series),
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
    if let (Some(from), Some(to)) = (holding, releasing) {
        let (from_s, to_s) = (t(from) - 0.5, t(to) + 0.5);
        let window = |points: Vec<(f64, f64)>| {
            points
                .into_iter()
                .filter(|(x, _)| *x >= from_s && *x <= to_s)
                .map(|(x, y)| (x, y - target))
                .collect::<Vec<_>>()
        };
        let true_error = window(tension());
        // The zoom holds the settled hold (its first half second is the step's tail).
        let settled_from = t(from) + 0.5;
        let error = true_error
            .iter()
            .filter(|(x, _)| *x >= settled_from && *x <= t(to))
            .map(|p| p.1.abs())
            .fold(0.0, f64::max);
        let least = if unit == "lb" { 0.5 } else { 0.2 };
        let zoom = hold_zoom(error, least);
        // The display's step: tenths of the unit the job was keyed in.
        let step = if unit == "lb" { "0.1 lb" } else { "0.1 kg" };
        panels.push(
            Panel::new(
                &format!("hold: tension − target ({unit}), ±{zoom}"),
                vec![
                    Series::new(&format!("panel reading ({step})"), window(panel_reading))
                        .stroke(Stroke::Thin),
                    Series::new("true tension", true_error),
                    Series::new("target", vec![(from_s, 0.0), (to_s, 0.0)])
                        .stroke(Stroke::Dashed)
                        .colour("#555555"),
                ],
            )
            .with_y_range(-zoom, zoom)
            .with_x_range(from_s, to_s, "time since power-up (s), the hold zoomed in"),
        );
    }
    let mut title = format!("taut main job: {} at {}", s.string, settings_text(run, &s.set_point));
    if let Some((at, code)) = fault {
        title.push_str(&format!(" — fault {} at {at:.2} s", fault_name(code)));
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hold_zoom_widens_to_the_hold_error() {
        assert_eq!(hold_zoom(0.05, 0.2), 0.2);
        assert_eq!(hold_zoom(0.74, 0.2), 1.0, "an uncalibrated machine 0.74 kg off");
        assert_eq!(hold_zoom(0.1, 0.5), 0.5, "lb: ±0.5 at least");
        assert_eq!(hold_zoom(40.0, 0.2), HOLD_ZOOM_MAX, "at most");
    }
}

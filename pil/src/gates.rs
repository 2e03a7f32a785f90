//! The six gates of the X-NUCLEO-IHM08M1's bridge, computed from TIM1's registers and the
//! pins' configuration, and the gate-level checks.
//!
//! For each channel the timer's output stage is evaluated as RM0440 specifies it: the
//! reference `OCxREF` from the output mode and the counter (PWM mode 1: high while
//! `CNT < CCRx`; PWM mode 2, forced active and forced inactive), then the complementary pair
//! from `CCxE`/`CCxNE`, `MOE`, `OSSR`/`OSSI`, the idle levels `OISx`/`OISxN` and the
//! polarities `CCxP`/`CCxNP`, with the dead time (`BDTR.DTG`) inserted at every rising edge
//! of a complementary pair. A pin carries the timer's output only in alternate function 6;
//! otherwise its GPIO configuration decides (an output drives its `ODR` bit, anything else
//! floats). The L6398 gate drivers then turn a high-side gate on while `HIN` is high and a
//! low-side gate on while `LIN` is low; a floating input is off (`HIN` has a pull-down,
//! `LIN` a pull-up).
//!
//! The checks, over every window the bench evaluates:
//! - **no shoot-through**: a leg's two gates are never on at the same time;
//! - **dead time**: every gate turns on at least [`REQUIRED_DEAD_TIME_CYCLES`] after its leg's
//!   other gate turned off;
//! - **off when disabled**: while `MOE` is clear (a fault, the break input, a flash write),
//!   every gate is off;
//! - **six-step**: every leg that is on is on as taut-core's `six_step` table has it for the
//!   sector on the Hall lines (either direction).

use taut_core::drive::{Direction, HallCode, LegState, SwitchPattern, six_step};

use crate::soc::{Gpio, PinMode};
use crate::tim::{MOE, OutputConfig};

/// The dead time the power stage needs, in CPU cycles at 170 MHz: 1 µs. The IHM08M1's
/// STL220N6F7 MOSFETs switch in ≈ 0.2 µs behind the L6398's ≈ 0.3 µs propagation; the design
/// keeps 1 µs.
pub const REQUIRED_DEAD_TIME_CYCLES: u64 = 170;

/// Where each leg's gate inputs are wired: (port, pin) of HIN and LIN, port A = 0.
pub const LEG_PINS: [((u8, u8), (u8, u8)); 3] =
    [((0, 8), (0, 7)), ((0, 9), (1, 0)), ((0, 10), (1, 1))];

/// TIM1's alternate function on every bridge pin.
pub const TIM1_AF: u8 = 6;

/// An interval of cycles, half-open.
pub type Span = (u64, u64);

/// One leg's gates over a window.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LegGates {
    /// When the high-side gate is on.
    pub high: Vec<Span>,
    /// When the low-side gate is on.
    pub low: Vec<Span>,
}

/// What a window's gates did.
#[derive(Debug, Clone, Default)]
pub struct Window {
    /// Per leg.
    pub legs: [LegGates; 3],
    /// The dead time programmed (cycles), from the last configuration.
    pub dead_time: u64,
    /// Sub-intervals with `MOE` clear.
    pub disabled: Vec<Span>,
    /// The window's segments of constant configuration, each with its bridge.
    pub segments: Vec<(u64, u64, SwitchPattern)>,
}

/// A gate-level violation.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    /// When.
    pub at: u64,
    /// Which check.
    pub check: &'static str,
    /// What was seen.
    pub detail: String,
}

/// The dead time `BDTR.DTG` programs, in timer clocks (RM0440, TIMx_BDTR, `CKD = 00`).
pub fn dead_time_ticks(dtg: u32) -> u64 {
    let dtg = u64::from(dtg & 0xFF);
    match dtg >> 5 {
        0..=3 => dtg,
        4 | 5 => (64 + (dtg & 0x3F)) * 2,
        6 => (32 + (dtg & 0x1F)) * 8,
        _ => (32 + (dtg & 0x1F)) * 16,
    }
}

fn push(spans: &mut Vec<Span>, a: u64, b: u64) {
    if b <= a {
        return;
    }
    if let Some(last) = spans.last_mut() {
        if last.1 == a {
            last.1 = b;
            return;
        }
    }
    spans.push((a, b));
}

/// What a timer output drives: a level, or nothing (disabled, Hi-Z).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drive {
    Level(bool),
    Float,
}

/// The reference's high intervals within `[a, b)` under `config` for channel `ch`, as a list.
fn reference(config: &OutputConfig, ch: usize, a: u64, b: u64) -> Result<Vec<Span>, String> {
    let mode = config.ocm[ch];
    let q = u64::from(config.psc) + 1;
    let period = q * (u64::from(config.arr) + 1);
    let ccr = u64::from(config.ccr[ch]);
    let mut out = Vec::new();
    match mode {
        0b0100 | 0b0000 => {}
        0b0101 => push(&mut out, a, b),
        0b0110 | 0b0111 => {
            if !config.running {
                // A stopped counter holds CNT; the bench treats it as at 0.
                let high = if mode == 0b0110 { ccr > 0 } else { ccr == 0 };
                if high {
                    push(&mut out, a, b);
                }
                return Ok(out);
            }
            let first = config.origin + (a.saturating_sub(config.origin) / period) * period;
            let mut p = first;
            while p < b {
                let (hi_a, hi_b) = if mode == 0b0110 {
                    (p, p + (ccr * q).min(period))
                } else {
                    (p + (ccr * q).min(period), p + period)
                };
                push(&mut out, hi_a.max(a), hi_b.min(b));
                p += period;
            }
        }
        other => {
            return Err(format!(
                "TIM1 channel {} in output mode {other:#06b}, which the bench does not model",
                ch + 1
            ));
        }
    }
    Ok(out)
}

fn complement(spans: &[Span], a: u64, b: u64) -> Vec<Span> {
    let mut out = Vec::new();
    let mut at = a;
    for &(s, e) in spans {
        push(&mut out, at, s);
        at = e;
    }
    push(&mut out, at, b);
    out
}

/// When a level that continues into a segment began.
#[derive(Debug, Clone, Copy)]
enum Edge {
    /// At this cycle.
    At(u64),
    /// Held since reset.
    Never,
}

/// Delays every rising edge by `dead`. A span at the segment's start `a` continues a level
/// that began at `continues` (the reference's last edge, perhaps in an earlier segment): it is
/// on from that edge plus the dead time at the earliest, as the dead-time generator counts
/// from the edge; a level held since reset is on from `a`.
fn delay_rising(spans: &[Span], dead: u64, a: u64, continues: Option<Edge>) -> Vec<Span> {
    let mut out = Vec::new();
    for &(s, e) in spans {
        let s2 = match continues {
            Some(Edge::At(edge)) if s == a => s.max(edge + dead),
            Some(Edge::Never) if s == a => s,
            _ => s + dead,
        };
        push(&mut out, s2, e);
    }
    out
}

/// A channel's reference at the end of the previous segment: its level and the time of its
/// last edge.
#[derive(Debug, Clone, Copy, Default)]
struct RefCarry {
    high: bool,
    /// The last edge; `None` before any (a level held since reset).
    since: Option<u64>,
}

/// What one timer output does over a segment: whether it drives, and its high spans.
type Output = (Drive, Vec<Span>);

/// The levels an output drives over `[a, b)`: high spans, and whether it drives at all.
fn channel_outputs(
    config: &OutputConfig,
    ch: usize,
    a: u64,
    b: u64,
    carry: RefCarry,
) -> Result<(Output, Output), String> {
    let ccer = config.ccer >> (4 * ch);
    let (cc_e, cc_p, cc_ne, cc_np) = (ccer & 1 != 0, ccer & 2 != 0, ccer & 4 != 0, ccer & 8 != 0);
    let moe = config.bdtr & MOE != 0;
    let ossr = config.bdtr & (1 << 11) != 0;
    let ossi = config.bdtr & (1 << 10) != 0;
    let dead = dead_time_ticks(config.bdtr);
    let ois = config.cr2 >> (8 + 2 * ch) & 1 != 0;
    let oisn = config.cr2 >> (9 + 2 * ch) & 1 != 0;
    let whole = vec![(a, b)];
    let level = |on: bool| if on { whole.clone() } else { Vec::new() };
    if !moe {
        if !(cc_e || cc_ne) || !ossi {
            return Ok(((Drive::Float, Vec::new()), (Drive::Float, Vec::new())));
        }
        return Ok(((Drive::Level(ois), level(ois)), (Drive::Level(oisn), level(oisn))));
    }
    let r = reference(config, ch, a, b)?;
    let rn = complement(&r, a, b);
    let xor = |spans: &[Span], invert: bool| {
        if invert { complement(spans, a, b) } else { spans.to_vec() }
    };
    let off =
        |pol: bool| if ossr { (Drive::Level(pol), level(pol)) } else { (Drive::Float, Vec::new()) };
    Ok(match (cc_e, cc_ne) {
        (false, false) => (off(cc_p), off(cc_np)),
        (true, false) => ((Drive::Level(true), xor(&r, cc_p)), off(cc_np)),
        (false, true) => (off(cc_p), (Drive::Level(true), xor(&rn, cc_np))),
        (true, true) => {
            // A level that continues from before this segment keeps its dead time from its
            // own edge; one held since reset has none left.
            let since = |level: bool| {
                (carry.high == level).then_some(carry.since.map_or(Edge::Never, Edge::At))
            };
            let oc = delay_rising(&r, dead, a, since(true));
            let ocn = delay_rising(&rn, dead, a, since(false));
            ((Drive::Level(true), xor(&oc, cc_p)), (Drive::Level(true), xor(&ocn, cc_np)))
        }
    })
}

/// The pin's level spans, or `None` when it floats.
fn pin_spans(
    gpio: &[Gpio; 7],
    pin: (u8, u8),
    timer: (Drive, Vec<Span>),
    a: u64,
    b: u64,
) -> Option<Vec<Span>> {
    let port = &gpio[usize::from(pin.0)];
    match port.mode(pin.1) {
        PinMode::Alternate(af) if af == TIM1_AF => match timer.0 {
            Drive::Float => None,
            Drive::Level(_) => Some(timer.1),
        },
        PinMode::Output { open_drain: false } => {
            Some(if port.output_bit(pin.1) { vec![(a, b)] } else { Vec::new() })
        }
        PinMode::Output { open_drain: true } => (!port.output_bit(pin.1)).then(Vec::new),
        _ => None,
    }
}

/// Evaluates the gates over `[a, b)` from the configurations in force (`changes`, sorted by
/// time; the first one at or before `a`).
pub fn evaluate(
    changes: &[(u64, OutputConfig)],
    gpio: &[Gpio; 7],
    a: u64,
    b: u64,
) -> Result<Window, String> {
    let mut window = Window::default();
    let mut carry = [RefCarry::default(); 3];
    for (i, (t, config)) in changes.iter().enumerate() {
        let end = changes.get(i + 1).map_or(b, |(t2, _)| *t2).min(b);
        let start = (*t).max(a);
        if end <= start {
            continue;
        }
        window.dead_time = dead_time_ticks(config.bdtr);
        if config.bdtr & MOE == 0 {
            push(&mut window.disabled, start, end);
        }
        let mut segment = [LegGates::default(), LegGates::default(), LegGates::default()];
        for (leg, &(hin, lin)) in LEG_PINS.iter().enumerate() {
            let (oc, ocn) = channel_outputs(config, leg, start, end, carry[leg])?;
            let high_level = pin_spans(gpio, hin, oc, start, end);
            let low_level = pin_spans(gpio, lin, ocn, start, end);
            // HIN active high: on while the pin is high; floating is off.
            for &(s, e) in high_level.as_deref().unwrap_or(&[]) {
                push(&mut segment[leg].high, s, e);
            }
            // LIN active low: on while the pin is driven low.
            if let Some(levels) = low_level {
                for (s, e) in complement(&levels, start, end) {
                    push(&mut segment[leg].low, s, e);
                }
            }
            // The reference's level at the segment's end and its last edge.
            let r = reference(config, leg, start, end)?;
            let high_at_end = r.last().is_some_and(|&(_, e)| e == end);
            let last_edge =
                if high_at_end { r.last().map(|&(s, _)| s) } else { r.last().map(|&(_, e)| e) };
            carry[leg] = match last_edge {
                Some(edge) if edge > start || high_at_end != carry[leg].high => {
                    RefCarry { high: high_at_end, since: Some(edge.max(start)) }
                }
                _ => RefCarry {
                    high: high_at_end,
                    since: if high_at_end == carry[leg].high {
                        carry[leg].since
                    } else {
                        Some(start)
                    },
                },
            };
        }
        let pattern = segment_pattern(&segment, start, end, window.dead_time);
        for (leg, gates) in segment.into_iter().enumerate() {
            for (s, e) in gates.high {
                push(&mut window.legs[leg].high, s, e);
            }
            for (s, e) in gates.low {
                push(&mut window.legs[leg].low, s, e);
            }
        }
        window.segments.push((start, end, pattern));
    }
    Ok(window)
}

/// A segment's bridge: per leg `High` if the high-side gate was on in it or the low-side gate
/// switched (a switched leg whose pulse is shorter than the dead time never turns its high
/// side on), `Low` if the low-side gate was on from the segment's start (give or take the
/// dead time still running from an earlier edge) to its end, `Off` if neither gate was on.
fn segment_pattern(legs: &[LegGates; 3], start: u64, end: u64, dead: u64) -> SwitchPattern {
    let state = |g: &LegGates| {
        if !g.high.is_empty() {
            LegState::High
        } else if g.low.is_empty() {
            LegState::Off
        } else if g.low.len() == 1 && g.low[0].1 == end && g.low[0].0 <= start + dead {
            LegState::Low
        } else {
            LegState::High
        }
    };
    SwitchPattern { a: state(&legs[0]), b: state(&legs[1]), c: state(&legs[2]) }
}

fn overlap(x: &[Span], y: &[Span]) -> Option<Span> {
    for &(a1, b1) in x {
        for &(a2, b2) in y {
            let (s, e) = (a1.max(a2), b1.min(b2));
            if s < e {
                return Some((s, e));
            }
        }
    }
    None
}

/// The checks' memory across windows: when each gate last turned off, whether it was on at
/// the end of the last window.
#[derive(Debug, Clone, Default)]
pub struct Checker {
    last_off: [[Option<u64>; 2]; 3],
    on_at_end: [[bool; 2]; 3],
    /// Violations found.
    pub violations: Vec<Violation>,
    /// Windows checked.
    pub windows: u64,
    /// Gate edges checked for dead time.
    pub edges: u64,
}

impl Checker {
    /// Checks one window `[a, b)`; `halls` are the codes on the Hall lines the firmware may
    /// have commutated on in it.
    pub fn check(&mut self, w: &Window, a: u64, b: u64, halls: &[HallCode]) {
        self.windows += 1;
        for (leg, gates) in w.legs.iter().enumerate() {
            let name = ["A", "B", "C"][leg];
            if let Some((s, e)) = overlap(&gates.high, &gates.low) {
                self.violations.push(Violation {
                    at: s,
                    check: "shoot-through",
                    detail: format!("leg {name}: both gates on for {} cycles", e - s),
                });
            }
            for (side, spans, other) in [(0usize, &gates.high, 1usize), (1, &gates.low, 0)] {
                for &(s, e) in spans.iter() {
                    let continuing = s == a && self.on_at_end[leg][side];
                    if !continuing {
                        self.edges += 1;
                        // The other gate's last fall before this rise.
                        let other_spans = if other == 0 { &gates.high } else { &gates.low };
                        let fell = other_spans
                            .iter()
                            .filter(|&&(_, oe)| oe <= s)
                            .map(|&(_, oe)| oe)
                            .max()
                            .or(self.last_off[leg][other]);
                        let other_on_at_start =
                            other_spans.iter().any(|&(os, oe)| os <= s && s < oe);
                        if let Some(fell) = fell {
                            if !other_on_at_start
                                && s - fell < REQUIRED_DEAD_TIME_CYCLES
                                && fell > 0
                            {
                                self.violations.push(Violation {
                                    at: s,
                                    check: "dead time",
                                    detail: format!("leg {name}: {} gate on {} cycles after the {} gate off (needs {REQUIRED_DEAD_TIME_CYCLES})", ["high", "low"][side], s - fell, ["high", "low"][other]),
                                });
                            }
                        }
                    }
                    let _ = e;
                }
            }
            for side in 0..2 {
                let spans = if side == 0 { &gates.high } else { &gates.low };
                if let Some(&(_, e)) = spans.last() {
                    if e < b {
                        self.last_off[leg][side] = Some(e);
                    }
                }
                let on_end = spans.last().is_some_and(|&(_, e)| e == b);
                if self.on_at_end[leg][side] && spans.first().is_none_or(|&(s, _)| s > a) {
                    self.last_off[leg][side] = Some(a);
                }
                self.on_at_end[leg][side] = on_end;
            }
            for &(s, e) in &w.disabled {
                if overlap(&[(s, e)], &gates.high).or(overlap(&[(s, e)], &gates.low)).is_some() {
                    self.violations.push(Violation {
                        at: s,
                        check: "off when disabled",
                        detail: format!("leg {name}: a gate is on while MOE is clear"),
                    });
                }
            }
        }
        for &(s, _, pattern) in &w.segments {
            if pattern.is_all_off() {
                continue;
            }
            let consistent = halls.iter().filter_map(|h| h.sector()).any(|sector| {
                [Direction::Pull, Direction::Release].into_iter().any(|d| {
                    let table = six_step(sector, d);
                    // A switched leg at zero duty is its low side on: `Low` where the table
                    // has `High` is the same bridge.
                    [(pattern.a, table.a), (pattern.b, table.b), (pattern.c, table.c)].iter().all(
                        |&(seen, want)| {
                            seen == LegState::Off
                                || seen == want
                                || (seen == LegState::Low && want == LegState::High)
                        },
                    )
                })
            });
            if !consistent {
                self.violations.push(Violation {
                    at: s,
                    check: "six-step",
                    detail: format!(
                        "gates {pattern:?} do not follow the six-step table for Hall {halls:?}"
                    ),
                });
            }
        }
    }
}

/// The window's bridge as the twin's circuit takes it: the pattern of its longest segment
/// (a commutation inside a window leaves two; the twin solves one per period), and the
/// switched leg's duty in that pattern, `(high on-time + dead time) / window` over the whole
/// window (the circuit inserts the dead time itself).
pub fn pattern_of(w: &Window, _length: u64) -> SwitchPattern {
    w.segments.iter().max_by_key(|(s, e, _)| e - s).map_or(SwitchPattern::ALL_OFF, |&(_, _, p)| p)
}

/// The switched leg's duty for the twin's circuit (see [`pattern_of`]).
pub fn duty_of(w: &Window, length: u64) -> f64 {
    let pattern = pattern_of(w, length);
    let mut duty: f64 = 0.0;
    for (leg, gates) in w.legs.iter().enumerate() {
        let state = [pattern.a, pattern.b, pattern.c][leg];
        let high: u64 = gates.high.iter().map(|(s, e)| e - s).sum();
        if state == LegState::High && high > 0 {
            duty = duty.max((high + w.dead_time) as f64 / length as f64);
        }
    }
    duty.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::soc::Soc;

    /// The board's pins in alternate function 6 (as the firmware sets them).
    fn board_pins() -> [Gpio; 7] {
        let mut soc = Soc::new();
        for &((hp, hn), (lp, ln)) in &LEG_PINS {
            for (port, pin) in [(hp, hn), (lp, ln)] {
                let g = &mut soc.gpio[usize::from(port)];
                let moder =
                    g.regs.value(0x00) & !(3 << (2 * u32::from(pin))) | (2 << (2 * u32::from(pin)));
                g.regs.set(0x00, moder);
                let afr = if pin < 8 { 0x20 } else { 0x24 };
                let shift = 4 * (u32::from(pin) % 8);
                let v = g.regs.value(afr) & !(0xF << shift) | (6 << shift);
                g.regs.set(afr, v);
            }
        }
        soc.gpio
    }

    /// Leg A switching at `ccr` of 8500, B low, C off; low sides active low (CCxNP) unless
    /// `wrong_polarity`.
    fn config(ccr: u32, dtg: u32, wrong_polarity: bool) -> OutputConfig {
        let np = if wrong_polarity { 0 } else { 1 };
        let ccer = (1 | 4 | (np << 3)) | ((1 | 4 | (np << 3)) << 4) | ((1 | (np << 3)) << 8);
        OutputConfig {
            running: true,
            origin: 0,
            psc: 0,
            arr: 8499,
            ccr: [ccr, 0, 0],
            ocm: [0b0110, 0b0100, 0b0100],
            ccer,
            bdtr: MOE | (1 << 10) | (1 << 11) | dtg,
            cr2: (1 << 9) | (1 << 11) | (1 << 13),
        }
    }

    #[test]
    fn dead_time_register_encodings() {
        assert_eq!(dead_time_ticks(0x7F), 127);
        assert_eq!(dead_time_ticks(0x80 | 21), (64 + 21) * 2);
        assert_eq!(dead_time_ticks(0xC0 | 1), 33 * 8);
        assert_eq!(dead_time_ticks(0xE0 | 31), 63 * 16);
    }

    #[test]
    fn a_switched_leg_has_its_dead_time_at_both_edges() {
        let pins = board_pins();
        // DTG 0x8B... the firmware's 170 clocks: (64 + 21) × 2.
        let w = evaluate(&[(0, config(4000, 0x80 | 21, false))], &pins, 0, 8500).expect("modelled");
        assert_eq!(w.legs[0].high, vec![(170, 4000)]);
        assert_eq!(w.legs[0].low, vec![(4170, 8500)]);
        assert_eq!(w.legs[1].high, vec![]);
        assert_eq!(w.legs[1].low, vec![(0, 8500)]);
        assert!(w.legs[2].high.is_empty() && w.legs[2].low.is_empty());
        let mut c = Checker::default();
        c.check(&w, 0, 8500, &[HallCode::from_raw(0b100), HallCode::from_raw(0b101)]);
        assert!(
            c.violations.iter().all(|v| v.check != "shoot-through" && v.check != "dead time"),
            "{:?}",
            c.violations
        );
    }

    #[test]
    fn a_wrong_low_side_polarity_is_shoot_through() {
        let pins = board_pins();
        let w = evaluate(&[(0, config(4000, 0x80 | 21, true))], &pins, 0, 8500).expect("modelled");
        let mut c = Checker::default();
        c.check(&w, 0, 8500, &[]);
        assert!(c.violations.iter().any(|v| v.check == "shoot-through"), "{:?}", c.violations);
    }

    #[test]
    fn a_short_dead_time_is_caught() {
        let pins = board_pins();
        let mut c = Checker::default();
        for k in 0..3u64 {
            let w = evaluate(&[(0, config(4000, 50, false))], &pins, k * 8500, (k + 1) * 8500)
                .expect("modelled");
            c.check(&w, k * 8500, (k + 1) * 8500, &[]);
        }
        assert!(c.violations.iter().any(|v| v.check == "dead time"), "{:?}", c.violations);
    }

    #[test]
    fn with_moe_clear_every_gate_idles_off() {
        let pins = board_pins();
        let mut cfg = config(4000, 0x80 | 21, false);
        cfg.bdtr &= !MOE;
        let w = evaluate(&[(0, cfg)], &pins, 0, 8500).expect("modelled");
        assert!(w.legs.iter().all(|l| l.high.is_empty() && l.low.is_empty()), "{:?}", w.legs);
        // Idle levels that drive a low side on (OISxN = 0 on an active-low input) are caught.
        cfg.cr2 = 0;
        let w = evaluate(&[(0, cfg)], &pins, 0, 8500).expect("modelled");
        let mut c = Checker::default();
        c.check(&w, 0, 8500, &[]);
        assert!(c.violations.iter().any(|v| v.check == "off when disabled"), "{:?}", c.violations);
    }

    #[test]
    fn pins_not_in_the_timer_function_float_off() {
        let pins = Soc::new().gpio;
        let w = evaluate(&[(0, config(4000, 0x80 | 21, false))], &pins, 0, 8500).expect("modelled");
        assert!(w.legs.iter().all(|l| l.high.is_empty() && l.low.is_empty()));
    }
}

//! Small SVG line plots: stacked panels sharing an x axis, with axes, ticks, labels and a
//! legend — enough for the reports' time series, without a plotting crate.
//!
//! A [`Figure`] holds [`Panel`]s stacked vertically; each panel holds [`Series`] of `(x, y)`
//! points. [`Figure::to_svg`] scales every panel to its own data range (rounded out to
//! "nice" tick steps of 1, 2 or 5 × 10ⁿ), thins long series to at most [`MAX_POINTS`] per
//! series by keeping each bucket's min and max (so spikes and chattering stay visible), and
//! returns a standalone SVG document.

use std::fmt::Write as _;

/// Points kept per series after thinning.
pub const MAX_POINTS: usize = 4_000;

/// The colours series take in order.
pub const PALETTE: [&str; 6] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#7f7f7f"];

/// One line.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// The points, in x order.
    pub points: Vec<(f64, f64)>,
}

impl Series {
    /// A series from a label and points.
    #[must_use]
    pub fn new(label: &str, points: Vec<(f64, f64)>) -> Self {
        Self { label: label.to_owned(), points }
    }
}

/// One panel: a y axis and its series.
#[derive(Clone, Debug)]
pub struct Panel {
    /// The y-axis label (with unit).
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
}

impl Panel {
    /// A panel.
    #[must_use]
    pub fn new(y_label: &str, series: Vec<Series>) -> Self {
        Self { y_label: y_label.to_owned(), series }
    }
}

/// A figure: a title, an x-axis label and stacked panels.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Title at the top.
    pub title: String,
    /// The shared x-axis label (with unit).
    pub x_label: String,
    /// The panels, top to bottom.
    pub panels: Vec<Panel>,
}

const WIDTH: f64 = 900.0;
const PANEL_HEIGHT: f64 = 200.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 40.0;
const GAP: f64 = 30.0;
const BOTTOM: f64 = 50.0;

/// A "nice" tick step near `span / 5`: 1, 2 or 5 × 10ⁿ.
#[must_use]
pub fn nice_step(span: f64) -> f64 {
    if !(span.is_finite() && span > 0.0) {
        return 1.0;
    }
    let raw = span / 5.0;
    let magnitude = 10_f64.powf(raw.log10().floor());
    let fraction = raw / magnitude;
    let nice = if fraction <= 1.0 {
        1.0
    } else if fraction <= 2.0 {
        2.0
    } else if fraction <= 5.0 {
        5.0
    } else {
        10.0
    };
    nice * magnitude
}

/// The finite range of `values`, widened when empty or flat.
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    if (hi - lo).abs() < 1e-12 {
        return (lo - 0.5, hi + 0.5);
    }
    (lo, hi)
}

/// At most [`MAX_POINTS`] points: each bucket's min and max, in order.
#[must_use]
pub fn thin(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    if points.len() <= MAX_POINTS {
        return points.to_vec();
    }
    let buckets = MAX_POINTS / 2;
    let size = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(MAX_POINTS);
    for chunk in points.chunks(size) {
        let (mut min, mut max) = (chunk[0], chunk[0]);
        for p in chunk {
            if p.1 < min.1 {
                min = *p;
            }
            if p.1 > max.1 {
                max = *p;
            }
        }
        if min.0 <= max.0 {
            out.push(min);
            out.push(max);
        } else {
            out.push(max);
            out.push(min);
        }
    }
    out
}

/// Escapes text for SVG.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// A tick label without trailing noise.
fn label(value: f64, step: f64) -> String {
    let decimals = if step >= 1.0 { 0 } else { (-step.log10()).ceil() as usize };
    format!("{value:.decimals$}")
}

impl Figure {
    /// A figure.
    #[must_use]
    pub fn new(title: &str, x_label: &str, panels: Vec<Panel>) -> Self {
        Self { title: title.to_owned(), x_label: x_label.to_owned(), panels }
    }

    /// The SVG document.
    #[must_use]
    pub fn to_svg(&self) -> String {
        let n = self.panels.len().max(1) as f64;
        let height = TOP + n * PANEL_HEIGHT + (n - 1.0) * GAP + BOTTOM;
        let plot_w = WIDTH - LEFT - RIGHT;
        let (x_lo, x_hi) = range(
            self.panels
                .iter()
                .flat_map(|p| p.series.iter())
                .flat_map(|s| s.points.iter().map(|p| p.0)),
        );
        let x_step = nice_step(x_hi - x_lo);
        let mut svg = String::new();
        let _ = write!(
            svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" viewBox="0 0 {WIDTH} {height}" font-family="sans-serif" font-size="11">"#
        );
        let _ = write!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = write!(
            svg,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
            WIDTH / 2.0,
            escape(&self.title)
        );
        let x_px = |x: f64| LEFT + (x - x_lo) / (x_hi - x_lo) * plot_w;
        for (index, panel) in self.panels.iter().enumerate() {
            let top = TOP + index as f64 * (PANEL_HEIGHT + GAP);
            let (y_lo_raw, y_hi_raw) =
                range(panel.series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
            let y_step = nice_step(y_hi_raw - y_lo_raw);
            let y_lo = (y_lo_raw / y_step).floor() * y_step;
            let y_hi = (y_hi_raw / y_step).ceil() * y_step;
            let y_px = |y: f64| top + PANEL_HEIGHT - (y - y_lo) / (y_hi - y_lo) * PANEL_HEIGHT;
            let _ = write!(
                svg,
                r##"<rect x="{LEFT}" y="{top}" width="{plot_w}" height="{PANEL_HEIGHT}" fill="none" stroke="#444"/>"##
            );
            // y ticks and grid.
            let mut y = y_lo;
            while y <= y_hi + y_step * 0.01 {
                let py = y_px(y);
                let _ = write!(
                    svg,
                    r##"<line x1="{LEFT}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                    LEFT + plot_w,
                    LEFT - 6.0,
                    py + 4.0,
                    label(y, y_step)
                );
                y += y_step;
            }
            // x ticks.
            let mut x = (x_lo / x_step).ceil() * x_step;
            while x <= x_hi + x_step * 0.01 {
                let px = x_px(x);
                let _ = write!(
                    svg,
                    r##"<line x1="{px:.1}" y1="{top}" x2="{px:.1}" y2="{:.1}" stroke="#eee"/><text x="{px:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                    top + PANEL_HEIGHT,
                    top + PANEL_HEIGHT + 14.0,
                    label(x, x_step)
                );
                x += x_step;
            }
            let _ = write!(
                svg,
                r#"<text transform="translate(18,{:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
                top + PANEL_HEIGHT / 2.0,
                escape(&panel.y_label)
            );
            for (s_index, series) in panel.series.iter().enumerate() {
                let color = PALETTE[s_index % PALETTE.len()];
                let mut path = String::new();
                for (i, (x, y)) in thin(&series.points).iter().enumerate() {
                    if !(x.is_finite() && y.is_finite()) {
                        continue;
                    }
                    let _ = write!(
                        path,
                        "{}{:.1},{:.1} ",
                        if i == 0 { "M" } else { "L" },
                        x_px(*x),
                        y_px(*y)
                    );
                }
                let _ = write!(
                    svg,
                    r#"<path d="{}" fill="none" stroke="{color}" stroke-width="1.2"/>"#,
                    path.trim_end()
                );
                let ly = top + 14.0 + s_index as f64 * 14.0;
                let lx = LEFT + plot_w - 170.0;
                let _ = write!(
                    svg,
                    r#"<line x1="{lx:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{color}" stroke-width="2"/><text x="{:.1}" y="{ly:.1}">{}</text>"#,
                    ly - 4.0,
                    lx + 18.0,
                    ly - 4.0,
                    lx + 22.0,
                    escape(&series.label)
                );
            }
        }
        let _ = write!(
            svg,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text></svg>"#,
            LEFT + plot_w / 2.0,
            height - 12.0,
            escape(&self.x_label)
        );
        svg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(10.0), 2.0);
        assert_eq!(nice_step(0.5), 0.1);
        assert_eq!(nice_step(23.0), 5.0);
    }

    #[test]
    fn svg_has_every_series_and_label() {
        let figure = Figure::new(
            "test & plot",
            "time (s)",
            vec![
                Panel::new(
                    "tension (kgf)",
                    vec![Series::new("true", vec![(0.0, 1.0), (1.0, 2.0)])],
                ),
                Panel::new(
                    "duty",
                    vec![Series::new("duty", (0..10_000).map(|i| (f64::from(i), 0.5)).collect())],
                ),
            ],
        );
        let svg = figure.to_svg();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(
            svg.contains("test &amp; plot")
                && svg.contains("tension (kgf)")
                && svg.contains(">duty<")
        );
        assert_eq!(svg.matches("<path").count(), 2);
    }

    #[test]
    fn thinning_keeps_extremes() {
        let mut points: Vec<(f64, f64)> = (0..100_000).map(|i| (f64::from(i), 0.0)).collect();
        points[54_321].1 = 9.0;
        let thinned = thin(&points);
        assert!(thinned.len() <= MAX_POINTS);
        assert!(thinned.iter().any(|p| p.1 == 9.0));
    }
}

//! SVG figures: stacked panels of line plots (linear or logarithmic), state timelines and
//! zoomed views, written by hand and returning their geometry.
//!
//! # Why a hand-written writer
//!
//! `plotters` (SVG backend) was the alternative. The plots here need three things it makes
//! awkward: a state timeline drawn as a panel of the *same* chart on the same time scale
//! (here a [`Panel::timeline`], placed by the same code as the line panels), legends in a
//! column of their own beside each panel so they can never cover data (plotters draws its
//! series labels inside the plotting area), and min/max thinning of 60 000-point traces so a
//! one-tick spike stays visible while the file stays small. With its geometry returned
//! ([`Geometry`]: every panel's rectangle and scales), callers and tests place or check
//! anything against the axes without reading SVG text back. And it adds no dependency to a
//! tool that is slow to build on the project's machines.
//!
//! # Layout
//!
//! A [`Figure`] has a title, a subtitle (what was run: string, tension, seed…; wrapped onto
//! as many lines as it needs) and [`Panel`]s stacked vertically. Panels share the figure's x
//! range unless they set their own ([`Panel::with_x_range`], e.g. a hold window zoomed in
//! time); the shared x-axis label sits under the last shared panel, a panel's own under it.
//! Each y axis is padded beyond the data (5 % of its span) and rounded out to "nice" ticks
//! of 1, 2 or 5 × 10ⁿ, about one per 36 px (x: one per 80 px), so both ends carry a label
//! and a line at the data's edge (a target) sits inside the frame. A fixed range
//! ([`Panel::with_y_range`]) clips what falls outside it. [`Scale::Log`] pads in decades and
//! labels both ends. Legends sit in a column right of the plot area, never over data. Within
//! a panel, references (dashed) are drawn first, noisy measurements (thin) next, and the
//! first series last, so it lies on top. A y label longer than its panel wraps to two lines.

use std::fmt::Write as _;

/// The duty axis of every plot, ± this many percent (a line at full duty stays inside the
/// frame).
pub const DUTY_AXIS_PERCENT: f64 = 105.0;

/// Points kept per series after thinning.
pub const MAX_POINTS: usize = 4_000;

/// The colours series take in order (colour-blind safe, Okabe–Ito).
pub const PALETTE: [&str; 7] =
    ["#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9", "#555555"];

/// Figure width, px.
pub const WIDTH: f64 = 1_000.0;
/// Left margin (y labels), px.
const LEFT: f64 = 80.0;
/// The legend column right of the plot area, px.
const LEGEND_W: f64 = 190.0;
/// Right margin beyond the legend, px.
const RIGHT: f64 = 10.0;
/// Title and the subtitle's first line, px.
const TOP: f64 = 58.0;
/// Each further line of a wrapped subtitle, px.
const SUBTITLE_LINE: f64 = 15.0;
/// Characters per subtitle line (12 px text across the figure).
const SUBTITLE_CHARS: usize = 140;
/// Pixels per y tick interval, at least (12 px labels).
const Y_TICK_PX: f64 = 36.0;
/// Pixels per x tick interval, at least.
const X_TICK_PX: f64 = 80.0;
/// Closest an inner tick label may come to a labelled end of a log axis, px.
const MIN_TICK_GAP_PX: f64 = 14.0;
/// Width of a character of 12 px text, px (DejaVu Sans's mean, for fitting labels).
const CHAR_PX: f64 = 6.8;
/// Space under a panel for its x tick labels, px.
const GAP: f64 = 34.0;
/// Space under the last panel, px.
const BOTTOM: f64 = 8.0;

/// How a line is drawn.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum Stroke {
    /// A solid line.
    #[default]
    Solid,
    /// A dashed line (targets, references).
    Dashed,
    /// A thin line behind the others (a noisy measurement).
    Thin,
    /// A dot per point, no line (values of categories).
    Markers,
}

/// One line.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// The points, in x order.
    pub points: Vec<(f64, f64)>,
    /// Colour, from [`PALETTE`] by default (in series order).
    pub colour: Option<&'static str>,
    /// Line style.
    pub stroke: Stroke,
}

impl Series {
    /// A solid series.
    #[must_use]
    pub fn new(label: &str, points: Vec<(f64, f64)>) -> Self {
        Self { label: label.to_owned(), points, colour: None, stroke: Stroke::Solid }
    }

    /// This series with `colour`.
    #[must_use]
    pub const fn colour(mut self, colour: &'static str) -> Self {
        self.colour = Some(colour);
        self
    }

    /// This series drawn with `stroke`.
    #[must_use]
    pub const fn stroke(mut self, stroke: Stroke) -> Self {
        self.stroke = stroke;
        self
    }
}

/// A coloured interval of a timeline.
#[derive(Clone, Debug)]
pub struct Band {
    /// Start, in x units.
    pub from: f64,
    /// End, in x units.
    pub to: f64,
    /// Text inside the band (where it fits).
    pub label: String,
    /// Legend entry the band belongs to.
    pub key: String,
    /// Fill colour.
    pub colour: &'static str,
}

/// The y axis' scale.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum Scale {
    /// Linear.
    #[default]
    Linear,
    /// Base-10 logarithmic (values ≤ 0 are drawn at the bottom).
    Log,
}

/// What a panel shows.
#[derive(Clone, Debug)]
pub enum Content {
    /// Lines.
    Lines(Vec<Series>),
    /// A timeline of bands.
    Timeline(Vec<Band>),
}

/// One panel.
#[derive(Clone, Debug)]
pub struct Panel {
    /// The y-axis label (with unit).
    pub y_label: String,
    /// What it shows.
    pub content: Content,
    /// A fixed y range (data outside is clipped), else the data's, padded.
    pub y_range: Option<(f64, f64)>,
    /// A fixed x range for this panel alone, else the figure's.
    pub x_range: Option<(f64, f64)>,
    /// The x-axis label of a panel with its own x range.
    pub x_label: Option<String>,
    /// The y scale.
    pub scale: Scale,
    /// Height of the plot area, px.
    pub height: f64,
}

impl Panel {
    /// A panel of lines.
    #[must_use]
    pub fn new(y_label: &str, series: Vec<Series>) -> Self {
        Self {
            y_label: y_label.to_owned(),
            content: Content::Lines(series),
            y_range: None,
            x_range: None,
            x_label: None,
            scale: Scale::Linear,
            height: 180.0,
        }
    }

    /// A timeline panel (a strip of coloured bands), as high as its legend (one line per
    /// distinct [`Band::key`]) and at least 26 px.
    #[must_use]
    pub fn timeline(y_label: &str, bands: Vec<Band>) -> Self {
        let mut keys: Vec<&str> = bands.iter().map(|b| b.key.as_str()).collect();
        keys.sort_unstable();
        keys.dedup();
        let height = (keys.len() as f64 * TIMELINE_KEY_PX).max(26.0);
        Self { height, content: Content::Timeline(bands), ..Self::new(y_label, Vec::new()) }
    }

    /// This panel with a fixed y range.
    #[must_use]
    pub const fn with_y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// This panel with its own x range and x-axis label.
    #[must_use]
    pub fn with_x_range(mut self, lo: f64, hi: f64, x_label: &str) -> Self {
        self.x_range = Some((lo, hi));
        self.x_label = Some(x_label.to_owned());
        self
    }

    /// This panel with a logarithmic y axis.
    #[must_use]
    pub const fn log(mut self) -> Self {
        self.scale = Scale::Log;
        self
    }

    /// This panel with a plot area `height` px high.
    #[must_use]
    pub const fn with_height(mut self, height: f64) -> Self {
        self.height = height;
        self
    }

    fn series(&self) -> &[Series] {
        match &self.content {
            Content::Lines(series) => series,
            Content::Timeline(_) => &[],
        }
    }
}

/// A figure: a title, a subtitle, an x-axis label and stacked panels.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Title at the top.
    pub title: String,
    /// A second line: what was run.
    pub subtitle: String,
    /// The shared x-axis label (with unit).
    pub x_label: String,
    /// The panels, top to bottom.
    pub panels: Vec<Panel>,
    /// Names of categories at x = 0, 1, 2, … (drawn slanted under the last shared panel
    /// instead of numbers).
    pub categories: Vec<String>,
}

/// A linear or logarithmic map from data to pixels.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct AxisScale {
    /// Data value at the low end.
    pub lo: f64,
    /// Data value at the high end.
    pub hi: f64,
    /// Pixel of the low end.
    pub px_lo: f64,
    /// Pixel of the high end.
    pub px_hi: f64,
    /// Logarithmic.
    pub log: bool,
}

impl AxisScale {
    /// The pixel of `value` (clamped to the axis for a log axis below its range).
    #[must_use]
    pub fn px(&self, value: f64) -> f64 {
        let (lo, hi, v) = if self.log {
            (self.lo.log10(), self.hi.log10(), value.max(self.lo).log10())
        } else {
            (self.lo, self.hi, value)
        };
        let span = if (hi - lo).abs() > 0.0 { hi - lo } else { 1.0 };
        self.px_lo + (v - lo) / span * (self.px_hi - self.px_lo)
    }
}

/// A rectangle, px.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Rect {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

/// Where a panel was drawn.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct PanelGeometry {
    /// The plot area.
    pub area: Rect,
    /// The x scale.
    pub x: AxisScale,
    /// The y scale.
    pub y: AxisScale,
}

/// Where everything was drawn.
#[derive(Clone, PartialEq, Debug)]
pub struct Geometry {
    /// Document width, px.
    pub width: f64,
    /// Document height, px.
    pub height: f64,
    /// One per panel, top to bottom.
    pub panels: Vec<PanelGeometry>,
}

/// The "nice" tick step (1, 2 or 5 × 10ⁿ) nearest to `span / intervals` (nearest on a log
/// scale, so an axis gets about `intervals` of them).
#[must_use]
pub fn nice_step(span: f64, intervals: f64) -> f64 {
    if !(span.is_finite() && span > 0.0 && intervals >= 1.0) {
        return 1.0;
    }
    let raw = span / intervals;
    let magnitude = 10_f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * magnitude)
        .min_by(|a, b| (a / raw).ln().abs().total_cmp(&(b / raw).ln().abs()))
        .unwrap_or(magnitude)
}

/// `(lo, hi)` rounded out to multiples of `step`.
fn rounded_out(lo: f64, hi: f64, step: f64) -> (f64, f64) {
    // A bound already on a tick (within rounding) stays there.
    ((lo / step + 1e-9).floor() * step, (hi / step - 1e-9).ceil() * step)
}

/// The finite range of `values`, widened when empty or flat.
fn data_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    if (hi - lo).abs() < 1e-12 {
        let pad = if lo.abs() > 1e-9 { lo.abs() * 0.1 } else { 0.5 };
        return (lo - pad, hi + pad);
    }
    (lo, hi)
}

/// `(lo, hi)` padded by 5 % of the span each side and rounded out to ticks about
/// `intervals` apart: the axis and its step.
fn padded(lo: f64, hi: f64, intervals: f64) -> (f64, f64, f64) {
    let pad = (hi - lo) * 0.05;
    let (lo, hi) = (lo - pad, hi + pad);
    let step = nice_step(hi - lo, intervals);
    let (lo, hi) = rounded_out(lo, hi, step);
    (lo, hi, step)
}

/// `text` broken at spaces into lines of at most `width` characters (a longer word stands
/// alone).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    lines.push(line);
    lines
}

/// `(lo, hi)` (both > 0) padded by 5 % of its span in decades each side and rounded out to
/// 1, 2 or 5 × 10ⁿ, so values at either end (a floor standing for 0) sit inside the frame.
fn log_padded(lo: f64, hi: f64) -> (f64, f64) {
    let (a, b) = (lo.log10(), hi.log10());
    let pad = (b - a) * 0.05;
    let (a, b) = (a - pad, b + pad);
    let down = |v: f64| {
        let decade = 10_f64.powf(v.floor());
        let m = 10_f64.powf(v - v.floor());
        decade * [5.0, 2.0, 1.0].into_iter().find(|&n| n <= m * 1.000_001).unwrap_or(1.0)
    };
    let up = |v: f64| {
        let decade = 10_f64.powf(v.floor());
        let m = 10_f64.powf(v - v.floor());
        decade * [1.0, 2.0, 5.0, 10.0].into_iter().find(|&n| n >= m * 0.999_999).unwrap_or(10.0)
    };
    (down(a), up(b))
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
fn tick_label(value: f64, step: f64) -> String {
    let decimals = if step >= 1.0 { 0 } else { (-step.log10()).ceil() as usize };
    let text = format!("{value:.decimals$}");
    if text.starts_with('-') && text.trim_start_matches(['-', '0', '.']).is_empty() {
        text.trim_start_matches('-').to_owned()
    } else {
        text
    }
}

/// Ticks of a linear axis: `lo`, `lo + step`, … up to `hi`.
fn linear_ticks(lo: f64, hi: f64, step: f64) -> Vec<(f64, String)> {
    let mut ticks = Vec::new();
    let mut k = (lo / step).round();
    while k * step <= hi + step * 1e-6 {
        let v = k * step;
        if v >= lo - step * 1e-6 {
            ticks.push((v, tick_label(v, step)));
        }
        k += 1.0;
    }
    ticks
}

/// Ticks of a log axis: every decade, 2 and 5 times it when there are few decades, and
/// both ends (a 1, 2 or 5 × 10ⁿ from [`log_padded`]) always.
fn log_ticks(lo: f64, hi: f64) -> Vec<(f64, String)> {
    let label = |v: f64| {
        let decimals = (-v.log10().floor()).max(0.0) as usize;
        format!("{v:.decimals$}")
    };
    let first = lo.log10().floor() as i32;
    let last = hi.log10().ceil() as i32;
    let few = last - first <= 3;
    let mut values = vec![lo, hi];
    for e in first..=last {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10_f64.powi(e);
            let inside = v > lo * 1.001 && v < hi * 0.999;
            if inside && (m == 1.0 || few) {
                values.push(v);
            }
        }
    }
    values.sort_by(f64::total_cmp);
    values.into_iter().map(|v| (v, label(v))).collect()
}

impl Figure {
    /// A figure.
    #[must_use]
    pub fn new(title: &str, subtitle: &str, x_label: &str, panels: Vec<Panel>) -> Self {
        Self {
            title: title.to_owned(),
            subtitle: subtitle.to_owned(),
            x_label: x_label.to_owned(),
            panels,
            categories: Vec::new(),
        }
    }

    /// This figure with categories on its x axis (at x = 0, 1, 2, …).
    #[must_use]
    pub fn with_categories(mut self, names: Vec<String>) -> Self {
        self.categories = names;
        self
    }

    /// Extra space under the last panel for slanted category names, px.
    fn category_space(&self) -> f64 {
        let longest = self.categories.iter().map(|c| c.chars().count()).max().unwrap_or(0);
        if longest == 0 { 0.0 } else { longest as f64 * 5.2 + 6.0 }
    }

    /// The subtitle's lines.
    fn subtitle_lines(&self) -> Vec<String> {
        wrap(&self.subtitle, SUBTITLE_CHARS)
    }

    /// The shared x range: the data of every panel without its own range, rounded out to
    /// ticks about [`X_TICK_PX`] apart.
    fn shared_x(&self, plot_w: f64) -> (f64, f64, f64) {
        let (lo, hi) =
            data_range(self.panels.iter().filter(|p| p.x_range.is_none()).flat_map(|p| {
                match &p.content {
                    Content::Lines(series) => {
                        series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect()
                    }
                    Content::Timeline(bands) => {
                        bands.iter().flat_map(|b| [b.from, b.to]).collect::<Vec<_>>()
                    }
                }
            }));
        if !self.categories.is_empty() {
            return (-0.5, self.categories.len() as f64 - 0.5, 1.0);
        }
        // Time axes start where the data starts: rounded out to ticks, not padded.
        let step = nice_step(hi - lo, plot_w / X_TICK_PX);
        let (lo, hi) = rounded_out(lo, hi, step);
        (lo, hi, step)
    }

    /// The SVG document.
    #[must_use]
    pub fn to_svg(&self) -> String {
        self.render().0
    }

    /// The SVG document and where each panel was drawn.
    #[must_use]
    pub fn render(&self) -> (String, Geometry) {
        let plot_w = WIDTH - LEFT - LEGEND_W - RIGHT;
        let (sx_lo, sx_hi, sx_step) = self.shared_x(plot_w);
        let subtitle = self.subtitle_lines();
        let top_space = TOP + (subtitle.len().max(1) - 1) as f64 * SUBTITLE_LINE;
        // Whole pixels, so a rasteriser's image is exactly the document.
        let height = (top_space
            + self.panels.iter().map(|p| p.height + GAP).sum::<f64>()
            + BOTTOM
            + self.category_space())
        .ceil();
        let mut svg = String::new();
        let _ = write!(
            svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" viewBox="0 0 {WIDTH} {height}" font-family="DejaVu Sans, Arial, sans-serif" font-size="12"><rect width="100%" height="100%" fill="white"/>"#
        );
        let _ = write!(
            svg,
            r#"<text x="{:.1}" y="22" text-anchor="middle" font-size="16" font-weight="bold">{}</text>"#,
            WIDTH / 2.0,
            escape(&self.title),
        );
        for (i, line) in subtitle.iter().enumerate() {
            let _ = write!(
                svg,
                r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="12" fill="#333">{}</text>"##,
                WIDTH / 2.0,
                42.0 + i as f64 * SUBTITLE_LINE,
                escape(line)
            );
        }
        let mut geometry = Geometry { width: WIDTH, height, panels: Vec::new() };
        let mut top = top_space;
        let last_shared = self.panels.iter().rposition(|p| p.x_range.is_none());
        for (index, panel) in self.panels.iter().enumerate() {
            let area = Rect { x: LEFT, y: top, w: plot_w, h: panel.height };
            let (x_lo, x_hi, x_step) = match panel.x_range {
                Some((lo, hi)) => {
                    let step = nice_step(hi - lo, plot_w / X_TICK_PX);
                    let (lo, hi) = rounded_out(lo, hi, step);
                    (lo, hi, step)
                }
                None => (sx_lo, sx_hi, sx_step),
            };
            let x =
                AxisScale { lo: x_lo, hi: x_hi, px_lo: area.x, px_hi: area.x + area.w, log: false };
            let (y, y_ticks) = y_axis(panel, area);
            geometry.panels.push(PanelGeometry { area, x, y });
            let clip = format!("clip{index}");
            let _ = write!(
                svg,
                r#"<clipPath id="{clip}"><rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}"/></clipPath>"#,
                area.x, area.y, area.w, area.h
            );
            // Grid and ticks.
            let x_ticks = if panel.x_range.is_none() && !self.categories.is_empty() {
                (0..self.categories.len()).map(|i| (i as f64, String::new())).collect()
            } else {
                linear_ticks(x_lo, x_hi, x_step)
            };
            for (v, _) in &x_ticks {
                let px = x.px(*v);
                let _ = write!(
                    svg,
                    r##"<line x1="{px:.1}" y1="{:.1}" x2="{px:.1}" y2="{:.1}" stroke="#e6e6e6"/>"##,
                    area.y,
                    area.y + area.h
                );
            }
            for (v, text) in &y_ticks {
                let py = y.px(*v);
                let _ = write!(
                    svg,
                    r##"<line x1="{:.1}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="#e6e6e6"/><text x="{:.1}" y="{:.1}" text-anchor="end">{text}</text>"##,
                    area.x,
                    area.x + area.w,
                    area.x - 6.0,
                    py + 4.0
                );
            }
            // Tick labels under every panel with its own x range, and under the last shared
            // panel; other shared panels get tick marks only.
            let labelled = panel.x_range.is_some() || Some(index) == last_shared;
            let categories = panel.x_range.is_none() && !self.categories.is_empty();
            if categories && Some(index) == last_shared {
                for (i, name) in self.categories.iter().enumerate() {
                    let px = x.px(i as f64);
                    let py = area.y + area.h + 12.0;
                    let _ = write!(
                        svg,
                        r#"<text transform="translate({px:.1},{py:.1}) rotate(-40)" text-anchor="end" font-size="11">{}</text>"#,
                        escape(name)
                    );
                }
            }
            for (v, text) in x_ticks.iter().filter(|_| !categories) {
                let px = x.px(*v);
                let _ = write!(
                    svg,
                    r##"<line x1="{px:.1}" y1="{:.1}" x2="{px:.1}" y2="{:.1}" stroke="#444"/>"##,
                    area.y + area.h,
                    area.y + area.h + 4.0
                );
                if labelled {
                    let _ = write!(
                        svg,
                        r#"<text x="{px:.1}" y="{:.1}" text-anchor="middle">{text}</text>"#,
                        area.y + area.h + 16.0
                    );
                }
            }
            // The x-axis label: a panel's own, or the figure's under the last shared panel
            // (below its category names, if any).
            let shared = (Some(index) == last_shared).then_some(&self.x_label);
            if let Some(label) = panel.x_label.as_ref().or(shared) {
                let below = if categories { self.category_space() } else { 0.0 };
                let _ = write!(
                    svg,
                    r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="#333">{}</text>"##,
                    area.x + area.w / 2.0,
                    area.y + area.h + below + 29.0,
                    escape(label)
                );
            }
            y_label(&mut svg, &panel.y_label, area);
            match &panel.content {
                Content::Lines(series) => draw_lines(&mut svg, series, &x, &y, &clip, area),
                Content::Timeline(bands) => draw_timeline(&mut svg, bands, &x, &clip, area),
            }
            let _ = write!(
                svg,
                r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#444"/>"##,
                area.x, area.y, area.w, area.h
            );
            top += panel.height + GAP;
            if categories && Some(index) == last_shared {
                top += self.category_space();
            }
        }
        svg.push_str("</svg>");
        (svg, geometry)
    }
}

/// A panel's y-axis label, rotated beside `area`: on two lines when one would be longer than
/// the panel is high, and smaller still if those would be.
fn y_label(svg: &mut String, label: &str, area: Rect) {
    let chars = label.chars().count();
    let fits = |lines: usize| chars.div_ceil(lines) as f64 * CHAR_PX <= area.h - 6.0;
    let lines = if fits(1) { vec![label.to_owned()] } else { wrap(label, chars.div_ceil(2) + 4) };
    let longest = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64;
    let size = if longest * CHAR_PX <= area.h - 6.0 {
        12.0
    } else {
        (12.0 * (area.h - 6.0) / (longest * CHAR_PX)).max(8.0)
    };
    let first_x = if lines.len() > 1 { 14.0 } else { 20.0 };
    for (i, line) in lines.iter().enumerate() {
        let _ = write!(
            svg,
            r#"<text transform="translate({:.1},{:.1}) rotate(-90)" text-anchor="middle" font-size="{size:.1}">{}</text>"#,
            first_x + i as f64 * (size + 2.0),
            area.y + area.h / 2.0,
            escape(line)
        );
    }
}

/// The y scale of `panel` in `area`, and its ticks.
fn y_axis(panel: &Panel, area: Rect) -> (AxisScale, Vec<(f64, String)>) {
    let values = panel.series().iter().flat_map(|s| s.points.iter().map(|p| p.1));
    match panel.scale {
        Scale::Log => {
            let (lo, hi) = panel.y_range.unwrap_or_else(|| {
                let (lo, hi) = data_range(values.filter(|v| *v > 0.0));
                let lo = if lo > 0.0 { lo } else { 1e-3 };
                log_padded(lo, hi.max(lo * 10.0))
            });
            let scale = AxisScale { lo, hi, px_lo: area.y + area.h, px_hi: area.y, log: true };
            // Where an inner tick crowds an end (a 10 just under a 20), one label goes: the
            // decade stays, the other is left out.
            let decade = |v: f64| (v.log10() - v.log10().round()).abs() < 1e-9;
            let all = log_ticks(lo, hi);
            let near = |a: f64, b: f64| (scale.px(a) - scale.px(b)).abs() < MIN_TICK_GAP_PX;
            let is_end = |v: f64| {
                near(v, lo) && v <= lo * (1.0 + 1e-9) || near(v, hi) && v >= hi * (1.0 - 1e-9)
            };
            let ticks = all
                .iter()
                .filter(|(v, _)| {
                    let end = if near(*v, lo) { lo } else { hi };
                    if is_end(*v) {
                        // An end yields to a decade next to it.
                        !all.iter().any(|(w, _)| {
                            !is_end(*w) && near(*w, end) && decade(*w) && !decade(end)
                        })
                    } else if near(*v, lo) || near(*v, hi) {
                        decade(*v) && !decade(end)
                    } else {
                        true
                    }
                })
                .cloned()
                .collect();
            (scale, ticks)
        }
        Scale::Linear => {
            let (lo, hi, step) = match (panel.y_range, &panel.content) {
                (Some((lo, hi)), _) => (lo, hi, nice_step(hi - lo, area.h / Y_TICK_PX)),
                (None, Content::Timeline(_)) => (0.0, 1.0, 1.0),
                (None, Content::Lines(_)) => {
                    let (lo, hi) = data_range(values);
                    padded(lo, hi, area.h / Y_TICK_PX)
                }
            };
            let scale = AxisScale { lo, hi, px_lo: area.y + area.h, px_hi: area.y, log: false };
            let ticks = if matches!(panel.content, Content::Timeline(_)) {
                Vec::new()
            } else {
                linear_ticks(lo, hi, step)
            };
            (scale, ticks)
        }
    }
}

/// Draws `series` and their legend. Legend entries keep the series' order; the lines are
/// drawn references (dashed) first, then noisy measurements (thin), then the rest, and
/// within each kind the first series last, so it lies on top.
fn draw_lines(
    svg: &mut String,
    series: &[Series],
    x: &AxisScale,
    y: &AxisScale,
    clip: &str,
    area: Rect,
) {
    let style = |index: usize, s: &Series| {
        let colour = s.colour.unwrap_or(PALETTE[index % PALETTE.len()]);
        let (width, dash) = match s.stroke {
            Stroke::Solid => (1.6, ""),
            Stroke::Dashed => (1.4, r#" stroke-dasharray="6 4""#),
            Stroke::Thin => (0.8, r#" stroke-opacity="0.5""#),
            Stroke::Markers => (0.0, ""),
        };
        (colour, width, dash)
    };
    let layer = |s: &Series| match s.stroke {
        Stroke::Dashed => 0,
        Stroke::Thin => 1,
        Stroke::Solid => 2,
        Stroke::Markers => 3,
    };
    let mut order: Vec<usize> = (0..series.len()).collect();
    order.sort_by_key(|&i| (layer(&series[i]), std::cmp::Reverse(i)));
    for index in order {
        let s = &series[index];
        let (colour, width, dash) = style(index, s);
        if s.stroke == Stroke::Markers {
            for &(px, py) in s.points.iter().filter(|(a, b)| a.is_finite() && b.is_finite()) {
                let _ = write!(
                    svg,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="3.5" fill="{colour}" fill-opacity="0.8" clip-path="url(#{clip})"/>"#,
                    x.px(px),
                    y.px(py)
                );
            }
            continue;
        }
        let mut path = String::new();
        let mut pen_down = false;
        for (px, py) in thin(&s.points) {
            if !(px.is_finite() && py.is_finite()) {
                pen_down = false;
                continue;
            }
            let _ = write!(
                path,
                "{}{:.1},{:.1} ",
                if pen_down { "L" } else { "M" },
                x.px(px),
                y.px(py)
            );
            pen_down = true;
        }
        if !path.is_empty() {
            let _ = write!(
                svg,
                r#"<path d="{}" fill="none" stroke="{colour}" stroke-width="{width}"{dash} clip-path="url(#{clip})"/>"#,
                path.trim_end()
            );
        }
    }
    draw_off_scale(svg, series, x, y, area);
    let legend_x = area.x + area.w + 12.0;
    // Only what was drawn has an entry (a series with no finite point has no line to name);
    // the colours stay those of the series' places.
    let drawn = series
        .iter()
        .enumerate()
        .filter(|(_, s)| s.points.iter().any(|(a, b)| a.is_finite() && b.is_finite()));
    for (row, (index, s)) in drawn.enumerate() {
        let (colour, _, dash) = style(index, s);
        let ly = area.y + 12.0 + row as f64 * 16.0;
        if s.stroke == Stroke::Markers {
            let _ = write!(
                svg,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{colour}"/>"#,
                legend_x + 11.0,
                ly - 4.0,
            );
        } else {
            let _ = write!(
                svg,
                r#"<line x1="{legend_x:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{colour}" stroke-width="2.5"{dash}/>"#,
                ly - 4.0,
                legend_x + 22.0,
                ly - 4.0,
            );
        }
        // A label longer than the legend column is set smaller, never cut.
        let room = LEGEND_W - 27.0 - RIGHT;
        let wide = s.label.chars().count() as f64 * CHAR_PX;
        let size = if wide <= room { 12.0 } else { (12.0 * room / wide).max(8.0) };
        let _ = write!(
            svg,
            r#"<text x="{:.1}" y="{ly:.1}" font-size="{size:.1}">{}</text>"#,
            legend_x + 27.0,
            escape(&s.label)
        );
    }
}

/// The least distance between two off-scale marks along an edge, px.
const OFF_SCALE_GAP_PX: f64 = 8.0;

/// Marks the points of `series` beyond a fixed y range (which the clip hides): a small
/// triangle on the edge they leave by, at their x, in their series' colour, and one note per
/// edge with the farthest value, so a zoomed panel never looks empty or calm by omission.
fn draw_off_scale(svg: &mut String, series: &[Series], x: &AxisScale, y: &AxisScale, area: Rect) {
    let (lo, hi) = (y.lo.min(y.hi), y.lo.max(y.hi));
    // (above, sign, farthest value) for the top edge, then the bottom one.
    for above in [true, false] {
        let mut farthest: Option<f64> = None;
        for (index, s) in series.iter().enumerate() {
            let colour = s.colour.unwrap_or(PALETTE[index % PALETTE.len()]);
            let mut last_px = f64::NEG_INFINITY;
            for &(px, py) in s.points.iter().filter(|(a, b)| a.is_finite() && b.is_finite()) {
                let out = if above { py > hi } else { py < lo };
                if !out || px < x.lo.min(x.hi) || px > x.lo.max(x.hi) || (y.log && py <= 0.0) {
                    continue;
                }
                farthest = Some(farthest.map_or(py, |f| if above { f.max(py) } else { f.min(py) }));
                let at = x.px(px);
                if at - last_px < OFF_SCALE_GAP_PX {
                    continue;
                }
                last_px = at;
                let (edge, tip) = if above {
                    (area.y + 7.0, area.y + 1.0)
                } else {
                    (area.y + area.h - 7.0, area.y + area.h - 1.0)
                };
                let _ = write!(
                    svg,
                    r#"<path d="M{:.1},{edge:.1} L{:.1},{edge:.1} L{at:.1},{tip:.1} Z" fill="{colour}" class="off-scale"/>"#,
                    at - 4.0,
                    at + 4.0,
                );
            }
        }
        if let Some(value) = farthest {
            let (arrow, ty) =
                if above { ("▲", area.y + 20.0) } else { ("▼", area.y + area.h - 12.0) };
            let _ = write!(
                svg,
                r##"<text x="{:.1}" y="{ty:.1}" font-size="11" fill="#a50f15">{arrow} off scale, to {}</text>"##,
                area.x + 6.0,
                escape(&format!("{value:+.3}"))
            );
        }
    }
}

/// The narrowest a band is drawn, px (a 20 ms state on a 15 s axis stays visible).
const MIN_BAND_PX: f64 = 3.0;
/// One line of a timeline's legend, px.
pub const TIMELINE_KEY_PX: f64 = 13.0;

fn draw_timeline(svg: &mut String, bands: &[Band], x: &AxisScale, clip: &str, area: Rect) {
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for band in bands {
        let (x0, x1) = (x.px(band.from), x.px(band.to.max(band.from)));
        let _ = write!(
            svg,
            r#"<rect x="{x0:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="{}" clip-path="url(#{clip})"><title>{}: {:.3}–{:.3} s</title></rect>"#,
            area.y,
            (x1 - x0).max(MIN_BAND_PX),
            area.h,
            band.colour,
            escape(&band.label),
            band.from,
            band.to
        );
        if x1 - x0 > 7.0 * band.label.chars().count() as f64 {
            let _ = write!(
                svg,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="11">{}</text>"#,
                (x0 + x1) / 2.0,
                area.y + area.h / 2.0 + 4.0,
                escape(&band.label)
            );
        }
        if !keys.iter().any(|(k, _)| *k == band.key) {
            keys.push((&band.key, band.colour));
        }
    }
    // The legend: one entry a line in the legend column, from the strip's top down
    // ([`Panel::timeline`] is as high as its legend needs).
    let legend_x = area.x + area.w + 12.0;
    for (index, (key, colour)) in keys.iter().enumerate() {
        let lx = legend_x;
        let y = area.y + index as f64 * TIMELINE_KEY_PX;
        let _ = write!(
            svg,
            r##"<rect x="{lx:.1}" y="{y:.1}" width="10" height="10" fill="{colour}" stroke="#888" stroke-width="0.5"/><text x="{:.1}" y="{:.1}" font-size="10">{}</text>"##,
            lx + 13.0,
            y + 9.0,
            escape(key)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(10.0, 5.0), 2.0);
        assert_eq!(nice_step(0.5, 5.0), 0.1);
        assert_eq!(nice_step(23.0, 5.0), 5.0);
        assert_eq!(nice_step(14.0, 9.0), 2.0);
        assert!((nice_step(0.5, 9.0) - 0.05).abs() < 1e-12);
    }

    #[test]
    fn axes_are_padded_so_a_line_at_the_data_edge_is_inside_the_frame() {
        let figure = Figure::new(
            "t",
            "s",
            "time (s)",
            vec![Panel::new("kgf", vec![Series::new("target", vec![(0.0, 25.0), (10.0, 25.0)])])],
        );
        let (_, geometry) = figure.render();
        let panel = geometry.panels[0];
        let py = panel.y.px(25.0);
        assert!(py > panel.area.y + 2.0 && py < panel.area.y + panel.area.h - 2.0);
        assert_eq!(panel.x.lo, 0.0);
        assert_eq!(panel.x.hi, 10.0);
    }

    #[test]
    fn svg_has_every_series_label_and_the_timeline_shares_the_x_scale() {
        let figure = Figure::new(
            "test & plot",
            "what was run",
            "time (s)",
            vec![
                Panel::new(
                    "tension (kgf)",
                    vec![Series::new("true", vec![(0.0, 1.0), (1.0, 2.0)])],
                ),
                Panel::new(
                    "duty (%)",
                    vec![Series::new(
                        "duty",
                        (0..10_000).map(|i| (f64::from(i) / 1e4, 50.0)).collect(),
                    )],
                ),
                Panel::timeline(
                    "state",
                    vec![Band {
                        from: 0.0,
                        to: 0.5,
                        label: "ready".into(),
                        key: "ready".into(),
                        colour: "#ccc",
                    }],
                ),
                Panel::new("error (kgf)", vec![Series::new("e", vec![(3.0, 0.01), (4.0, 0.02)])])
                    .with_x_range(3.0, 4.0, "hold (s)")
                    .with_y_range(-0.2, 0.2),
            ],
        );
        let (svg, geometry) = figure.render();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(svg.contains("test &amp; plot") && svg.contains("tension (kgf)"));
        assert_eq!(svg.matches("<svg").count(), 1, "no nested documents");
        assert_eq!(svg.matches("<path").count(), 3);
        assert_eq!(
            geometry.panels[2].x,
            AxisScale { px_lo: geometry.panels[0].x.px_lo, ..geometry.panels[0].x }
        );
        assert_eq!(geometry.panels[3].x.lo, 3.0);
    }

    #[test]
    fn log_axis_is_padded_and_labelled_at_both_ends() {
        let panel = Panel::new("e", vec![Series::new("q", vec![(0.0, 0.03), (100.0, 20.0)])]).log();
        let figure = Figure::new("t", "s", "x", vec![panel]);
        let (svg, geometry) = figure.render();
        let y = geometry.panels[0].y;
        assert!((y.lo - 0.02).abs() < 1e-12 && (y.hi - 50.0).abs() < 1e-9, "{y:?}");
        assert!(svg.contains(">0.02<") && svg.contains(">50<") && svg.contains(">1<"));
        assert!(y.px(0.03) < y.px(y.lo) - 2.0, "the lowest value is above the frame");
    }

    #[test]
    fn a_series_with_nothing_to_draw_has_no_legend_entry() {
        let drawn = Series::new("drawn", vec![(0.0, 1.0), (1.0, 2.0)]);
        let empty = Series::new("all failed", vec![(0.0, f64::NAN), (1.0, f64::NAN)]);
        let nothing = Series::new("no points", Vec::new());
        let figure =
            Figure::new("t", "s", "x", vec![Panel::new("kgf", vec![empty, drawn, nothing])]);
        let (svg, _) = figure.render();
        assert!(svg.contains(">drawn<"));
        assert!(!svg.contains(">all failed<") && !svg.contains(">no points<"), "{svg}");
    }

    #[test]
    fn long_subtitles_wrap_and_push_the_panels_down() {
        assert_eq!(wrap("aa bb cc", 5), ["aa bb", "cc"]);
        assert_eq!(wrap("averyverylongword x", 5), ["averyverylongword", "x"]);
        let panel = || Panel::new("kgf", vec![Series::new("s", vec![(0.0, 1.0), (1.0, 2.0)])]);
        let short = Figure::new("t", "short", "x", vec![panel()]).render().1;
        let long = Figure::new("t", &"word ".repeat(60), "x", vec![panel()]).render().1;
        assert!(long.panels[0].area.y >= short.panels[0].area.y + SUBTITLE_LINE);
    }

    #[test]
    fn points_beyond_a_fixed_range_are_marked_off_scale() {
        let inside = Series::new("inside", vec![(0.0, 0.1), (1.0, -0.1)]);
        let calm = Figure::new(
            "t",
            "s",
            "x",
            vec![Panel::new("y", vec![inside.clone()]).with_y_range(-0.2, 0.2)],
        );
        assert!(!calm.to_svg().contains("off scale"), "nothing beyond the range");
        let high = Series::new("high", vec![(0.0, 0.74), (0.5, 0.8), (1.0, 0.76)]);
        let low = Series::new("low", vec![(0.0, -0.3)]);
        let svg = Figure::new(
            "t",
            "s",
            "x",
            vec![Panel::new("y", vec![inside, high, low]).with_y_range(-0.2, 0.2)],
        )
        .to_svg();
        assert!(svg.contains("▲ off scale, to +0.800"), "{svg}");
        assert!(svg.contains("▼ off scale, to -0.300"), "{svg}");
        assert_eq!(svg.matches(r#"class="off-scale""#).count(), 4, "a mark per point, apart");
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

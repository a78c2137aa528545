//! Line charts drawn by `plotters` into SVG strings: one or more panels stacked on a
//! shared x axis (a temperature over its residual), each with named, coloured lines,
//! axes in physical units and a legend.
//!
//! Long series are thinned before drawing ([`Thinning`]): per bucket of instants the
//! smallest and the largest value are kept, in time order, so a 5.8-hour run at 1 s
//! becomes a few thousand points per line with every peak still drawn.

use std::ops::Range;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::HtmlError;

pub use crate::colour::Rgb;

/// Colours of the lines of one plot that are neither parts nor inputs (a fleet's units,
/// the recursive estimate's time constants, a rating's curve), in turn; a part's lines
/// take [`crate::colour::part`], an input's [`crate::colour::input`], as in the rerun
/// recording.
pub const PALETTE: [Rgb; 6] = [
    crate::colour::PARTS[0],
    crate::colour::PARTS[2],
    crate::colour::PARTS[3],
    crate::colour::PARTS[4],
    crate::colour::PARTS[1],
    crate::colour::INPUTS[0],
];
/// A neutral grey for bands and reference lines.
pub const GREY: Rgb = crate::colour::REFERENCE;
/// The shading of alarm stretches (red, light).
pub const ALARM: Rgb = [214, 39, 40];

/// The i-th colour of [`PALETTE`], cycling.
pub fn palette(i: usize) -> Rgb {
    PALETTE[i % PALETTE.len()]
}

/// One named line, drawn as polylines broken where the data have gaps.
#[derive(Debug, Clone)]
pub struct Line {
    /// The legend's name of the line.
    pub name: String,
    /// Its colour.
    pub colour: Rgb,
    /// Drawn dashed (a band's edge, a reference level).
    pub dashed: bool,
    /// Drawn wide (a measured trace, lightened, under the model's line).
    pub wide: bool,
    /// Runs of (x, y) points without gaps, in x order.
    pub segments: Vec<Vec<(f64, f64)>>,
}

impl Line {
    /// A solid line.
    pub fn new(name: impl Into<String>, colour: Rgb, segments: Vec<Vec<(f64, f64)>>) -> Line {
        Line {
            name: name.into(),
            colour,
            dashed: false,
            wide: false,
            segments,
        }
    }

    /// The same line, dashed.
    pub fn dashed(mut self) -> Line {
        self.dashed = true;
        self
    }

    /// Part `j`'s measured trace: wide, in the part's colour lightened
    /// ([`crate::colour::measured`]), for its model's line to be drawn over it.
    pub fn measured(name: impl Into<String>, j: usize, segments: Vec<Vec<(f64, f64)>>) -> Line {
        Line {
            wide: true,
            ..Line::new(name, crate::colour::measured(j), segments)
        }
    }

    fn points(&self) -> impl Iterator<Item = &(f64, f64)> {
        self.segments.iter().flatten()
    }
}

/// One panel: lines over the chart's shared x axis, with a y axis of its own.
#[derive(Debug, Clone)]
pub struct Panel {
    /// The y axis' label, with its unit ("temperature, °C").
    pub y_label: String,
    /// The lines, drawn in order (the last on top).
    pub lines: Vec<Line>,
    /// A shaded horizontal band [low, high] behind the lines (a confidence band).
    pub band: Option<(f64, f64)>,
    /// The y range; `None`: from the data (and the band), padded by 5 %.
    pub y_range: Option<Range<f64>>,
    /// The panel's share of the chart's height, relative to the other panels.
    pub weight: u32,
    /// Shaded stretches of x [start, end] behind the lines (alarms), full height.
    pub spans: Vec<(f64, f64)>,
}

impl Panel {
    /// A panel of weight 1 with its y range from the data.
    pub fn new(y_label: impl Into<String>, lines: Vec<Line>) -> Panel {
        Panel {
            y_label: y_label.into(),
            lines,
            band: None,
            y_range: None,
            weight: 1,
            spans: Vec::new(),
        }
    }

    /// Whether any line has a point to draw.
    pub fn has_points(&self) -> bool {
        self.lines.iter().any(|l| l.points().next().is_some())
    }

    /// The y range: given, or the data's (and the band's), padded by 5 %.
    fn y_range(&self) -> Range<f64> {
        if let Some(r) = &self.y_range {
            return r.clone();
        }
        let band = self.band.iter().flat_map(|&(a, b)| [a, b]);
        let ys = self.lines.iter().flat_map(|l| l.points().map(|p| p.1));
        padded(ys.chain(band))
    }
}

/// A chart: panels stacked on one x axis, labelled at the bottom.
#[derive(Debug, Clone)]
pub struct Chart {
    /// The x axis' label, with its unit ("time since the start, h").
    pub x_label: String,
    /// The panels, top to bottom.
    pub panels: Vec<Panel>,
    /// Width in pixels (the page scales it to its column).
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// The range of finite values, padded by 5 % each side; [−1, 1] around a constant.
fn padded(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !(lo <= hi) {
        return 0.0..1.0;
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        lo.abs().max(1.0) * 0.05
    };
    (lo - pad)..(hi + pad)
}

fn plot_error(e: impl std::fmt::Display) -> HtmlError {
    HtmlError::Figure(e.to_string())
}

fn colour(c: Rgb) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Font sizes (px) of tick labels and axis descriptions.
const TICK_FONT: u32 = 13;
const DESC_FONT: u32 = 15;

impl Chart {
    /// A chart of the given panels, 900 px wide and 320 px high per unit of weight
    /// (a single panel: 340 px).
    pub fn new(x_label: impl Into<String>, panels: Vec<Panel>) -> Chart {
        let weight: u32 = panels.iter().map(|p| p.weight).sum();
        Chart {
            x_label: x_label.into(),
            panels,
            width: 900,
            height: if weight <= 1 { 340 } else { 160 * weight + 60 },
        }
    }

    /// The chart as an `<svg>` element (no XML declaration), ready to inline in HTML.
    pub fn to_svg(&self) -> Result<String, HtmlError> {
        let mut svg = String::new();
        {
            let root =
                SVGBackend::with_string(&mut svg, (self.width, self.height)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_error)?;
            self.draw(&root)?;
            root.present().map_err(plot_error)?;
        }
        Ok(match svg.find("<svg") {
            Some(start) => svg[start..].to_owned(),
            None => svg,
        })
    }

    /// The x range shared by the panels.
    fn x_range(&self) -> Range<f64> {
        let xs = self
            .panels
            .iter()
            .flat_map(|p| p.lines.iter().flat_map(|l| l.points().map(|p| p.0)));
        let (lo, hi) = xs
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        if lo < hi {
            lo..hi
        } else if lo.is_finite() {
            (lo - 0.5)..(lo + 0.5)
        } else {
            0.0..1.0
        }
    }

    fn draw(&self, root: &DrawingArea<SVGBackend, Shift>) -> Result<(), HtmlError> {
        let x = self.x_range();
        let total: u32 = self
            .panels
            .iter()
            .map(|p| p.weight.max(1))
            .sum::<u32>()
            .max(1);
        // The bottom panel also carries the x axis' labels: give it their room.
        let axis = 50;
        let usable = self.height.saturating_sub(axis) as f64;
        let mut rest = root.clone();
        for (i, panel) in self.panels.iter().enumerate() {
            let last = i + 1 == self.panels.len();
            let area = if last {
                rest.clone()
            } else {
                let h = (usable * panel.weight.max(1) as f64 / total as f64).round() as u32;
                let (top, bottom) = rest.split_vertically(h);
                rest = bottom;
                top
            };
            draw_panel(
                &area,
                panel,
                x.clone(),
                last.then_some(self.x_label.as_str()),
            )?;
        }
        Ok(())
    }
}

/// Draws one panel; `x_label` is given to the bottom panel only.
fn draw_panel(
    area: &DrawingArea<SVGBackend, Shift>,
    panel: &Panel,
    x: Range<f64>,
    x_label: Option<&str>,
) -> Result<(), HtmlError> {
    let y = panel.y_range();
    let mut chart = ChartBuilder::on(area)
        .margin_top(8)
        .margin_right(18)
        .x_label_area_size(if x_label.is_some() { 46 } else { 8 })
        .y_label_area_size(78)
        .build_cartesian_2d(x.clone(), y.clone())
        .map_err(plot_error)?;
    let mut mesh = chart.configure_mesh();
    mesh.y_desc(panel.y_label.as_str())
        .label_style(("sans-serif", TICK_FONT))
        .axis_desc_style(("sans-serif", DESC_FONT))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .y_labels(6)
        .x_labels(10)
        .y_label_formatter(&|v| tick(*v));
    match x_label {
        Some(label) => {
            mesh.x_desc(label).x_label_formatter(&|v| tick(*v));
        }
        None => {
            mesh.x_label_formatter(&|_| String::new());
        }
    }
    mesh.draw().map_err(plot_error)?;
    draw_spans(&mut chart, &panel.spans, &y)?;
    if let Some((lo, hi)) = panel.band {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(x.start, lo), (x.end, hi)],
                colour(GREY).mix(0.18).filled(),
            )))
            .map_err(plot_error)?;
    }
    for line in &panel.lines {
        draw_line(&mut chart, line, &y)?;
    }
    if panel.lines.iter().any(|l| !l.name.is_empty()) {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(("sans-serif", TICK_FONT))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(190, 190, 190))
            .draw()
            .map_err(plot_error)?;
    }
    Ok(())
}

type Cartesian<'a> = ChartContext<'a, SVGBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Shades the x stretches `spans` over the panel's height, with one legend entry.
fn draw_spans(
    chart: &mut Cartesian<'_>,
    spans: &[(f64, f64)],
    y: &Range<f64>,
) -> Result<(), HtmlError> {
    if spans.is_empty() {
        return Ok(());
    }
    let fill = colour(ALARM).mix(0.15).filled();
    chart
        .draw_series(
            spans
                .iter()
                .map(|&(a, b)| Rectangle::new([(a, y.start), (b, y.end)], fill)),
        )
        .map_err(plot_error)?
        .label("alarm")
        .legend(move |(px, py)| Rectangle::new([(px, py - 5), (px + 22, py + 5)], fill));
    Ok(())
}

/// Draws a line's segments, clipped to the y range, with one legend entry.
fn draw_line(chart: &mut Cartesian<'_>, line: &Line, y: &Range<f64>) -> Result<(), HtmlError> {
    let style = ShapeStyle::from(&colour(line.colour)).stroke_width(if line.wide { 4 } else { 2 });
    let mut labelled = false;
    for segment in clip(&line.segments, y) {
        let drawn = if line.dashed {
            chart
                .draw_series(DashedLineSeries::new(segment, 7, 4, style))
                .map_err(plot_error)?
        } else {
            chart
                .draw_series(LineSeries::new(segment, style))
                .map_err(plot_error)?
        };
        if !labelled && !line.name.is_empty() {
            labelled = true;
            drawn
                .label(line.name.as_str())
                .legend(move |(px, py)| PathElement::new(vec![(px, py), (px + 22, py)], style));
        }
    }
    Ok(())
}

/// Segments split where a point leaves the y range (a chart with a fixed range does not
/// draw what it cannot show).
fn clip(segments: &[Vec<(f64, f64)>], y: &Range<f64>) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    for segment in segments {
        let mut run = Vec::new();
        for &(px, py) in segment {
            if py >= y.start && py <= y.end {
                run.push((px, py));
            } else if !run.is_empty() {
                out.push(std::mem::take(&mut run));
            }
        }
        if !run.is_empty() {
            out.push(run);
        }
    }
    out
}

/// A tick label: at most four significant digits, without trailing zeros.
pub fn tick(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.1e}");
    }
    let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

/// The x axis of a time plot: seconds, minutes or hours (whichever suits the span) since
/// the first instant, x = (t − t₀) / unit.
#[derive(Debug, Clone)]
pub struct TimeAxis {
    /// t₀ of an axis over grid instants (ns), else 0.
    t0_ns: i64,
    /// t₀ of an axis over times in seconds, else 0.
    t0_s: f64,
    unit_s: f64,
    /// The axis label: the clock's name and the unit, e.g. "time since the start, h".
    pub label: String,
}

impl TimeAxis {
    /// The unit for a span of `span_s` seconds, appended to `what` in the label.
    fn with_unit(t0_ns: i64, t0_s: f64, span_s: f64, what: &str) -> TimeAxis {
        let (unit_s, unit) = if span_s >= 3.0 * 3600.0 {
            (3600.0, "h")
        } else if span_s >= 180.0 {
            (60.0, "min")
        } else {
            (1.0, "s")
        };
        TimeAxis {
            t0_ns,
            t0_s,
            unit_s,
            label: format!("{what}, {unit}"),
        }
    }

    /// The axis of a recording's grid instants (ns): "time since the start".
    pub fn of_ns(time_ns: &[i64]) -> TimeAxis {
        let t0_ns = time_ns.first().copied().unwrap_or(0);
        let span_s = time_ns.last().map_or(0.0, |t| (t - t0_ns) as f64 * 1e-9);
        TimeAxis::with_unit(t0_ns, 0.0, span_s, "time since the start")
    }

    /// The axis of times in seconds, labelled `what` (e.g. "time of the schedule").
    pub fn of_seconds(time_s: &[f64], what: &str) -> TimeAxis {
        let t0_s = time_s.first().copied().unwrap_or(0.0);
        let span_s = time_s.last().map_or(0.0, |t| t - t0_s);
        TimeAxis::with_unit(0, t0_s, span_s, what)
    }

    /// x of a grid instant (ns).
    pub fn x_ns(&self, t_ns: i64) -> f64 {
        (t_ns - self.t0_ns) as f64 * 1e-9 / self.unit_s
    }

    /// x of a time in seconds.
    pub fn x_s(&self, t_s: f64) -> f64 {
        (t_s - self.t0_s) / self.unit_s
    }

    /// The unit's symbol ("h", "min" or "s").
    pub fn unit(&self) -> &str {
        self.label.rsplit(", ").next().unwrap_or("")
    }

    /// `value` over grid instants (ns), thinned to `buckets` for drawing.
    pub fn series_ns(
        &self,
        time_ns: &[i64],
        buckets: usize,
        value: impl Fn(usize) -> Option<f64>,
    ) -> Vec<Vec<(f64, f64)>> {
        let mut thin = Thinning::new(time_ns.len(), buckets);
        for (k, &t) in time_ns.iter().enumerate() {
            thin.push(k, self.x_ns(t), value(k));
        }
        thin.finish()
    }

    /// `value` over times in seconds, thinned to `buckets` for drawing.
    pub fn series_s(
        &self,
        time_s: &[f64],
        buckets: usize,
        value: impl Fn(usize) -> Option<f64>,
    ) -> Vec<Vec<(f64, f64)>> {
        let mut thin = Thinning::new(time_s.len(), buckets);
        for (k, &t) in time_s.iter().enumerate() {
            thin.push(k, self.x_s(t), value(k));
        }
        thin.finish()
    }
}

/// Thins a series of instants 0..len to at most four points per bucket of instants (the
/// first, the smallest, the largest and the last value), kept in time order, and breaks
/// the line where instants are missing for longer than a bucket.
#[derive(Debug)]
pub struct Thinning {
    bucket_len: usize,
    current: Option<Bucket>,
    last_instant: Option<usize>,
    segments: Vec<Vec<(f64, f64)>>,
}

/// One kept point: (instant, x, y).
type Kept = (usize, f64, f64);

/// The points of one bucket that are kept.
#[derive(Debug, Clone, Copy)]
struct Bucket {
    index: usize,
    first: Kept,
    min: Kept,
    max: Kept,
    last: Kept,
}

impl Thinning {
    /// Thinning of `len` instants into about `buckets` buckets.
    pub fn new(len: usize, buckets: usize) -> Thinning {
        Thinning {
            bucket_len: len.div_ceil(buckets.max(1)).max(1),
            current: None,
            last_instant: None,
            segments: Vec::new(),
        }
    }

    /// Adds instant `k` (increasing from call to call) at `x` with value `y`; `None` or a
    /// non-finite value is a missing instant.
    pub fn push(&mut self, k: usize, x: f64, y: Option<f64>) {
        let Some(y) = y.filter(|v| v.is_finite()) else {
            return;
        };
        let gap = self
            .last_instant
            .is_some_and(|last| k > last + self.bucket_len);
        self.last_instant = Some(k);
        let index = k / self.bucket_len;
        if gap || self.current.is_some_and(|b| b.index != index) {
            self.flush();
        }
        if gap || self.segments.is_empty() {
            self.segments.push(Vec::new());
        }
        let point = (k, x, y);
        let b = self.current.get_or_insert(Bucket {
            index,
            first: point,
            min: point,
            max: point,
            last: point,
        });
        if y < b.min.2 {
            b.min = point;
        }
        if y > b.max.2 {
            b.max = point;
        }
        b.last = point;
    }

    fn flush(&mut self) {
        let Some(b) = self.current.take() else {
            return;
        };
        let Some(segment) = self.segments.last_mut() else {
            return;
        };
        let mut kept = [b.first, b.min, b.max, b.last];
        kept.sort_by_key(|p| p.0);
        let mut previous = None;
        for (k, x, y) in kept {
            if previous != Some(k) {
                segment.push((x, y));
                previous = Some(k);
            }
        }
    }

    /// The thinned runs of points.
    pub fn finish(mut self) -> Vec<Vec<(f64, f64)>> {
        self.flush();
        self.segments.retain(|s| !s.is_empty());
        self.segments
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_every_extreme_in_time_order() {
        // A sawtooth of period 10 over 1000 instants, 100 buckets of 10: each bucket's
        // minimum (0, its first) and maximum (9, its last) survive, nothing else.
        let mut t = Thinning::new(1000, 100);
        for k in 0..1000 {
            t.push(k, k as f64, Some((k % 10) as f64));
        }
        let segments = t.finish();
        assert_eq!(segments.len(), 1);
        let s = &segments[0];
        assert_eq!(s.len(), 200);
        let mut t = Thinning::new(1000, 100);
        for k in 0..1000 {
            t.push(k, k as f64, Some(((k * 7 + 3) % 10) as f64));
        }
        // First, smallest, largest and last of each bucket: four points.
        assert_eq!(t.finish()[0].len(), 400);
        assert!(s.windows(2).all(|w| w[0].0 < w[1].0));
        assert_eq!(s[0], (0.0, 0.0));
        assert_eq!(s[1], (9.0, 9.0));
        assert_eq!(s[199], (999.0, 9.0));
    }

    #[test]
    fn thinning_breaks_the_line_at_a_gap_longer_than_a_bucket() {
        let mut t = Thinning::new(100, 10);
        // Unknown from 30 to 59 (three buckets) and at 15 alone: one missing value inside
        // a bucket is not a gap of the line.
        for k in 0..100 {
            let known = k != 15 && !(30..60).contains(&k);
            t.push(k, k as f64, known.then_some(1.0));
        }
        let segments = t.finish();
        assert_eq!(segments.len(), 2);
        assert_eq!(segments[0].last().unwrap().0, 29.0);
        assert_eq!(segments[1][0].0, 60.0);
    }

    #[test]
    fn short_series_are_kept_whole() {
        let mut t = Thinning::new(5, 1000);
        for k in 0..5 {
            t.push(k, k as f64, Some(k as f64 * 2.0));
        }
        assert_eq!(
            t.finish(),
            vec![vec![
                (0.0, 0.0),
                (1.0, 2.0),
                (2.0, 4.0),
                (3.0, 6.0),
                (4.0, 8.0)
            ]]
        );
    }

    #[test]
    fn ticks_are_short_and_exact_enough() {
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(2.5), "2.5");
        assert_eq!(tick(1234.0), "1234");
        assert_eq!(tick(0.012345), "0.01235");
        assert_eq!(tick(-40.0), "-40");
        assert_eq!(tick(2.0e-5), "2.0e-5");
    }

    #[test]
    fn a_chart_is_one_svg_element_with_its_labels_and_lines() {
        let line = Line::new(
            "measured <T>",
            crate::colour::part(0),
            vec![vec![(0.0, 1.0), (1.0, 2.0)]],
        );
        let chart = Chart::new("time, h", vec![Panel::new("temperature, °C", vec![line])]);
        let svg = chart.to_svg().unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..40]);
        assert!(svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("time, h") && svg.contains("temperature, °C"));
        // Text is escaped by the backend.
        assert!(svg.contains("measured &lt;T&gt;"), "{svg}");
        assert!(svg.contains("<polyline"));
    }

    #[test]
    fn points_outside_a_fixed_range_break_the_line() {
        let segments = vec![vec![(0.0, 0.5), (1.0, 5.0), (2.0, 0.7), (3.0, 0.8)]];
        assert_eq!(
            clip(&segments, &(0.0..1.0)),
            vec![vec![(0.0, 0.5)], vec![(2.0, 0.7), (3.0, 0.8)]]
        );
    }
}

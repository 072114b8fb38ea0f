//! The feed-prediction report as an SVG picture, after paper 000's Figs. 10–12: on top the
//! programmed and the predicted feed along the path length, the predicted feed coloured by what
//! limits it and the relative tool/surface feed (rebuilt through the forward kinematics) as a
//! thin line; below, every axis's velocity along the same path length, linear axes in mm/min on
//! the left scale and rotary axes in deg/min on the right one. The caller chooses the path
//! length (the command leaves rapids out: each is a dotted tick where the feed path goes on); the
//! feed panel names the operations where they start and numbers the worst slowdowns as the
//! program's comments do.
//!
//! Any number of samples: each series is first reduced to the drawing's resolution (per pixel
//! column its minimum and maximum, in the order they occur; for the predicted feed the limiter
//! of the minimum colours the column), so a million samples give a picture of a few hundred
//! kilobytes. Samples whose path length or value is not finite are skipped.
//!
//! Text goes into the SVG as `<text>` elements: plotters, built without a font backend, only
//! estimates text extents for its layout, so no font file, fontconfig or freetype is needed to
//! write the picture; the viewer's sans-serif font draws the text.
//!
//! The picture is rendered in memory ([`render`]); the command writes it with its other exports,
//! all or none.

use std::fmt::Display;
use std::ops::Range;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One series of samples along the path, ready to draw.
pub(crate) struct Report {
    /// The picture's title (first line of the header).
    pub(crate) title: String,
    /// The line under the title: machine, file, predicted cycle time, …
    pub(crate) subtitle: String,
    /// Path length of each sample in mm, the x axis of both panels (non-decreasing).
    pub(crate) path_mm: Vec<f64>,
    /// Programmed feed of each sample in mm/min.
    pub(crate) programmed: Vec<f64>,
    /// Predicted feed of each sample in mm/min.
    pub(crate) predicted: Vec<f64>,
    /// Relative tool/surface feed of each sample in mm/min, rebuilt through the forward
    /// kinematics, if computed.
    pub(crate) relative: Option<Vec<f64>>,
    /// What limits the predicted feed at each sample: an index into `limiter_names`.
    pub(crate) limiter: Vec<u16>,
    /// The names of the limiters ("programmed", "X velocity", "C jerk", "corner", …).
    pub(crate) limiter_names: Vec<String>,
    /// The velocity of every axis at each sample.
    pub(crate) axes: Vec<AxisSeries>,
    /// Where rapids were left out of the path (mm).
    pub(crate) rapids: Vec<f64>,
    /// Where each operation starts (mm) and its name.
    pub(crate) operations: Vec<(f64, String)>,
    /// The slowdowns to number: path length (mm), feed (mm/min) and number.
    pub(crate) marks: Vec<(f64, f64, usize)>,
}

/// One axis's velocity along the path.
pub(crate) struct AxisSeries {
    /// The axis letter, as in the legend ("X", "C").
    pub(crate) letter: String,
    /// Whether the axis is rotary: its velocity is then in deg/min and drawn on the right scale.
    pub(crate) rotary: bool,
    /// Velocity of each sample, mm/min for a linear axis, deg/min for a rotary one.
    pub(crate) velocity: Vec<f64>,
}

/// Why a report could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub(crate) enum PlotError {
    /// Nothing to draw: no sample, or no sample with a finite path length.
    #[error("nothing to plot: the report has no sample with a finite path length")]
    Empty,
    /// A series does not have one value per sample of `path_mm`.
    #[error("the series `{series}` has {len} values, but the path has {samples} samples")]
    Length {
        /// Which series ("programmed", "axis X", …).
        series: String,
        /// Its number of values.
        len: usize,
        /// The number of samples of `path_mm`.
        samples: usize,
    },
    /// A sample's limiter is not an index into `limiter_names`.
    #[error("sample {sample} is limited by limiter {index}, but only {count} limiter names are given")]
    Limiter {
        /// The sample.
        sample: usize,
        /// Its limiter index.
        index: u16,
        /// The number of limiter names.
        count: usize,
    },
    /// plotters failed to draw.
    #[error("cannot draw the plot: {0}")]
    Draw(String),
}

// ---------------------------------------------------------------------------------------------
// Layout (pixels).

/// Size of the picture.
const WIDTH: u32 = 1400;
/// Height of the picture.
const HEIGHT: u32 = 900;
/// Height of the header (title and subtitle).
const HEADER: u32 = 64;
/// Width of the legend column right of each panel.
const LEGEND: u32 = 240;
/// Width of the label areas left (and right) of a panel's plotting area.
const Y_LABELS: u32 = 88;
/// Height of the label area under a panel's plotting area.
const X_LABELS: u32 = 50;
/// Margin around each panel.
const MARGIN: u32 = 12;
/// Vertical distance between two legend lines.
const LEGEND_LINE: i32 = 22;
/// The longest legend label, in characters (the legend column is narrow).
const LEGEND_CHARS: usize = 26;

/// Length of a dash of the programmed feed's line.
const DASH: u32 = 7;
/// Gap between two dashes.
const GAP: u32 = 4;

/// The font family named in the SVG; the viewer picks the font.
const FONT: &str = "sans-serif";
// Colours of the rapid ticks, the operation lines and names, the slowdown numbers.
const RAPID: RGBColor = RGBColor(120, 120, 120);
const OPERATION: RGBColor = RGBColor(60, 60, 160);
const MARK: RGBColor = RGBColor(200, 0, 0);
// Colours of the grid, the programmed and relative feeds, the subtitle.
const GRID_BOLD: RGBColor = RGBColor(222, 222, 222);
const GRID_LIGHT: RGBColor = RGBColor(244, 244, 244);
const PROGRAMMED: RGBColor = RGBColor(160, 160, 160);
const RELATIVE: RGBColor = RGBColor(0, 0, 0);
const SUBTITLE: RGBColor = RGBColor(70, 70, 70);
/// Tableau 10 without its grey, then Kelly's colours of maximum contrast that differ from them:
/// distinct, and readable on white. A real program meets a dozen limiters and more (three per
/// axis, corner, look-ahead, stop, rapid…): each needs its own colour for the legend to read.
const PALETTE: [RGBColor; 22] = [
    RGBColor(31, 119, 180),  // blue
    RGBColor(255, 127, 14),  // orange
    RGBColor(214, 39, 40),   // red
    RGBColor(44, 160, 44),   // green
    RGBColor(148, 103, 189), // purple
    RGBColor(140, 86, 75),   // brown
    RGBColor(227, 119, 194), // pink
    RGBColor(188, 189, 34),  // olive
    RGBColor(23, 190, 207),  // cyan
    RGBColor(0, 83, 138),    // strong blue
    RGBColor(255, 179, 0),   // vivid yellow
    RGBColor(128, 62, 117),  // strong purple
    RGBColor(0, 125, 52),    // vivid green
    RGBColor(127, 24, 13),   // strong reddish brown
    RGBColor(246, 118, 142), // strong purplish pink
    RGBColor(147, 170, 0),   // vivid yellowish green
    RGBColor(83, 55, 122),   // strong violet
    RGBColor(206, 162, 98),  // greyish yellow
    RGBColor(241, 58, 19),   // vivid reddish orange
    RGBColor(89, 51, 21),    // deep yellowish brown
    RGBColor(166, 189, 215), // very light blue
    RGBColor(179, 40, 81),   // strong purplish red
];

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A plotters error as a `PlotError`.
fn draw_error(e: impl Display) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// The whole picture as SVG text.
/// The SVG text of the report.
pub(crate) fn render(report: &Report) -> Result<String, PlotError> {
    check(report)?;
    let x_range = x_range(&report.path_mm).ok_or(PlotError::Empty)?;
    let mut svg = String::with_capacity(256 * 1024);
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let (header, body) = root.split_vertically(HEADER);
        draw_header(&header, report)?;
        let (top, bottom) = body.split_vertically((HEIGHT - HEADER) / 2);
        let (top_chart, top_legend) = top.split_horizontally(WIDTH - LEGEND);
        draw_feeds(&top_chart, &top_legend, report, &x_range)?;
        let (bottom_chart, bottom_legend) = bottom.split_horizontally(WIDTH - LEGEND);
        draw_axes(&bottom_chart, &bottom_legend, report, &x_range)?;
        root.present().map_err(draw_error)?;
    }
    Ok(svg)
}

/// Every series has one value per sample, every limiter names a limiter, and there are samples.
fn check(report: &Report) -> Result<(), PlotError> {
    let samples = report.path_mm.len();
    let mut series: Vec<(String, usize)> = vec![
        ("programmed".into(), report.programmed.len()),
        ("predicted".into(), report.predicted.len()),
        ("limiter".into(), report.limiter.len()),
    ];
    if let Some(relative) = &report.relative {
        series.push(("relative".into(), relative.len()));
    }
    series.extend(report.axes.iter().map(|axis| (format!("axis {}", axis.letter), axis.velocity.len())));
    if let Some((series, len)) = series.into_iter().find(|(_, len)| *len != samples) {
        return Err(PlotError::Length { series, len, samples });
    }
    let count = report.limiter_names.len();
    if let Some((sample, &index)) = report.limiter.iter().enumerate().find(|(_, i)| usize::from(**i) >= count) {
        return Err(PlotError::Limiter { sample, index, count });
    }
    if samples == 0 {
        return Err(PlotError::Empty);
    }
    Ok(())
}

/// The range of the finite path lengths, widened when it is a single point; `None` if no path
/// length is finite.
fn x_range(path: &[f64]) -> Option<Range<f64>> {
    let (lo, hi) = extent(path.iter().copied(), false)?;
    if lo == hi {
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        return Some(lo - pad..hi + pad);
    }
    Some(lo..hi)
}

/// The values of the samples whose path length is finite (the values may not be).
fn finite_values<'a>(path: &'a [f64], values: &'a [f64]) -> impl Iterator<Item = f64> + 'a {
    values.iter().zip(path).filter(|(_, x)| x.is_finite()).map(|(&v, _)| v)
}

/// Smallest and largest finite value (and zero with `with_zero`), `None` if none is finite.
fn extent(values: impl Iterator<Item = f64>, with_zero: bool) -> Option<(f64, f64)> {
    let start = if with_zero { (0.0, 0.0) } else { (f64::INFINITY, f64::NEG_INFINITY) };
    let (lo, hi) = values.filter(|v| v.is_finite()).fold(start, |(lo, hi), v| (lo.min(v), hi.max(v)));
    (lo <= hi).then_some((lo, hi))
}

/// A y range holding `extent` with a little room; a bound at zero stays at zero (feeds start at
/// the x axis), a single value is widened, nothing becomes 0..1.
fn y_range(extent: Option<(f64, f64)>) -> Range<f64> {
    let Some((lo, hi)) = extent else { return 0.0..1.0 };
    if lo == hi {
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        return lo - pad..hi + pad;
    }
    let pad = (hi - lo) * 0.05;
    let lo = if lo == 0.0 { 0.0 } else { lo - pad };
    let hi = if hi == 0.0 { 0.0 } else { hi + pad };
    if lo.is_finite() && hi.is_finite() && (hi - lo).is_finite() {
        lo..hi
    } else {
        // Values near f64::MAX: keep the range representable.
        lo.max(f64::MIN / 4.0)..hi.min(f64::MAX / 4.0)
    }
}

/// Widens two ranges that both hold zero so that zero is at the same height on both scales
/// (ranges without zero are returned as they are).
fn align_zero(a: Range<f64>, b: Range<f64>) -> (Range<f64>, Range<f64>) {
    let below = |r: &Range<f64>| -r.start / (r.end - r.start);
    let (fa, fb) = (below(&a), below(&b));
    if !(0.0..=1.0).contains(&fa) || !(0.0..=1.0).contains(&fb) {
        return (a, b);
    }
    let f = fa.max(fb);
    let widen = |r: Range<f64>| {
        let under = if f > 0.0 { -r.start / f } else { 0.0 };
        let over = if f < 1.0 { r.end / (1.0 - f) } else { 0.0 };
        let span = under.max(over);
        if span.is_finite() && span > 0.0 { -f * span..(1.0 - f) * span } else { r }
    };
    (widen(a), widen(b))
}

/// How the tick labels of one scale are written.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ticks {
    /// With this many decimals.
    Fixed(usize),
    /// In scientific notation (tiny steps or huge values).
    Scientific,
}

impl Ticks {
    /// The labels for about ten ticks over `range`.
    fn over(range: &Range<f64>) -> Ticks {
        let step = (range.end - range.start).abs() / 10.0;
        let largest = range.start.abs().max(range.end.abs());
        if !step.is_finite() || largest >= 1e9 || (step > 0.0 && step < 1e-4) {
            Ticks::Scientific
        } else if step == 0.0 || step >= 1.0 {
            Ticks::Fixed(0)
        } else {
            // 0.5 → 1, 0.05 → 2, …, 0.0001 → 4.
            Ticks::Fixed((-step.log10().floor()).clamp(0.0, 4.0) as usize)
        }
    }

    /// The label of `value`, never a negative zero.
    fn label(self, value: f64) -> String {
        let text = match self {
            Ticks::Fixed(decimals) => format!("{value:.decimals$}"),
            Ticks::Scientific => format!("{value:.1e}"),
        };
        match text.strip_prefix('-') {
            Some(rest) if rest.chars().all(|c| matches!(c, '0' | '.' | 'e')) => rest.to_string(),
            _ => text,
        }
    }
}

/// The title and subtitle.
fn draw_header(area: &Area<'_>, report: &Report) -> Result<(), PlotError> {
    let left = Pos::new(HPos::Left, VPos::Top);
    let title = (FONT, 24).into_font().style(FontStyle::Bold).color(&BLACK).pos(left);
    let subtitle = (FONT, 16).into_font().color(&SUBTITLE).pos(left);
    area.draw(&Text::new(report.title.as_str(), (MARGIN as i32 + 4, 10), title)).map_err(draw_error)?;
    area.draw(&Text::new(report.subtitle.as_str(), (MARGIN as i32 + 4, 40), subtitle)).map_err(draw_error)?;
    Ok(())
}

/// A chart on `area` with the common margins, label areas, mesh and tick labels. The plotting
/// area is the same in both panels: the right label area is kept free when not `right_scale`.
fn chart<'a, 'b>(
    area: &'a Area<'b>,
    x_range: &Range<f64>,
    y_range: Range<f64>,
    right_scale: bool,
) -> Result<Chart<'a, 'b>, PlotError> {
    let mut builder = ChartBuilder::on(area);
    builder.margin(MARGIN).x_label_area_size(X_LABELS).y_label_area_size(Y_LABELS);
    if right_scale {
        builder.right_y_label_area_size(Y_LABELS);
    } else {
        builder.margin_right(MARGIN + Y_LABELS);
    }
    builder.build_cartesian_2d(x_range.clone(), y_range).map_err(draw_error)
}

/// Draws the primary mesh, axes and their descriptions.
fn draw_mesh(chart: &mut Chart<'_, '_>, y_desc: &str) -> Result<(), PlotError> {
    let (x_ticks, y_ticks) = (Ticks::over(&chart.x_range()), Ticks::over(&chart.y_range()));
    let x_label = move |v: &f64| x_ticks.label(*v);
    let y_label = move |v: &f64| y_ticks.label(*v);
    chart
        .configure_mesh()
        .x_desc("path length (mm)")
        .y_desc(y_desc)
        .x_labels(12)
        .y_labels(8)
        .x_label_formatter(&x_label)
        .y_label_formatter(&y_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .bold_line_style(GRID_BOLD.stroke_width(1))
        .light_line_style(GRID_LIGHT.stroke_width(1))
        .draw()
        .map_err(draw_error)
}

/// The top panel: programmed, predicted (by limiter) and relative feed.
fn draw_feeds(area: &Area<'_>, legend: &Area<'_>, report: &Report, x_range: &Range<f64>) -> Result<(), PlotError> {
    let path = &report.path_mm;
    let feeds = [Some(&report.programmed), Some(&report.predicted), report.relative.as_ref()];
    let values = feeds.into_iter().flatten().flat_map(|feed| finite_values(path, feed));
    let mut chart = chart(area, x_range, y_range(extent(values, true)), false)?;
    draw_mesh(&mut chart, "feed (mm/min)")?;
    let columns = Columns::new(x_range, chart.plotting_area().dim_in_pixel().0);

    // The programmed feed dashed and under the predicted one: it shows where they differ.
    let programmed = columns.polyline(path, &reduce(path, &report.programmed, &columns));
    if programmed.len() == 1 {
        draw_line(&mut chart, programmed, PROGRAMMED, 2)?;
    } else {
        let style = PROGRAMMED.stroke_width(2);
        chart.draw_series(DashedLineSeries::new(programmed, DASH, GAP, style)).map_err(draw_error)?;
    }

    // The limiters that occur, each with its colour: "programmed" blue, the others in turn.
    let mut occurs = vec![false; report.limiter_names.len()];
    for (i, (&limiter, &v)) in report.limiter.iter().zip(&report.predicted).enumerate() {
        if path[i].is_finite() && v.is_finite() {
            occurs[usize::from(limiter)] = true;
        }
    }
    let mut colours = vec![PALETTE[0]; report.limiter_names.len()];
    let mut next = 1;
    for (index, name) in report.limiter_names.iter().enumerate().filter(|(i, _)| occurs[*i]) {
        if !name.eq_ignore_ascii_case("programmed") {
            colours[index] = PALETTE[next % PALETTE.len()];
            next = next % (PALETTE.len() - 1) + 1;
        }
    }

    let predicted = reduce(path, &report.predicted, &columns);
    let runs = columns.runs(path, &predicted, &report.limiter);
    let single = runs.len() == 1 && runs.iter().all(|run| run.points.len() == 1);
    for run in runs {
        let colour = colours[usize::from(run.limiter)];
        if single {
            draw_line(&mut chart, run.points, colour, 2)?;
        } else {
            chart.draw_series(LineSeries::new(run.points, colour.stroke_width(3))).map_err(draw_error)?;
        }
    }

    if let Some(relative) = &report.relative {
        let relative = columns.polyline(path, &reduce(path, relative, &columns));
        draw_line(&mut chart, relative, RELATIVE.mix(0.7), 1)?;
    }
    draw_landmarks(&mut chart, report)?;

    let mut entries = vec![Entry::Heading("Feed".into()), Entry::Dashed("programmed".into(), PROGRAMMED.into(), 2)];
    if report.relative.is_some() {
        entries.push(Entry::Line("relative (forward kin.)".into(), RELATIVE.mix(0.7), 1));
    }
    if !report.rapids.is_empty() {
        entries.push(Entry::Dashed("rapid (left out)".into(), RAPID.into(), 1));
    }
    if !report.operations.is_empty() {
        entries.push(Entry::Line("operation start".into(), OPERATION.into(), 1));
    }
    if !report.marks.is_empty() {
        entries.push(Entry::Line("#N slowdown marked".into(), MARK.into(), 2));
    }
    entries.push(Entry::Heading("Predicted, limited by".into()));
    for (index, name) in report.limiter_names.iter().enumerate().filter(|(i, _)| occurs[*i]) {
        entries.push(Entry::Line(name.clone(), colours[index].into(), 3));
    }
    draw_legend(legend, &entries)
}

/// The rapid ticks, the operations' starts and names, the slowdowns' numbers on the feed panel.
fn draw_landmarks(chart: &mut Chart<'_, '_>, report: &Report) -> Result<(), PlotError> {
    let (x, y) = (chart.x_range(), chart.y_range());
    let inside = |v: f64| v.is_finite() && v >= x.start && v <= x.end;
    let area = chart.plotting_area();
    for &at in report.rapids.iter().filter(|v| inside(**v)) {
        let tick = DashedPathElement::new(vec![(at, y.start), (at, y.end)], 3, 3, RAPID.stroke_width(1));
        area.draw(&tick).map_err(draw_error)?;
    }
    let name_style = (FONT, 13).into_font().color(&OPERATION).pos(Pos::new(HPos::Left, VPos::Top));
    let top = y.end - (y.end - y.start) * 0.01;
    // An operation that starts before the first sample drawn (with a rapid) is named where the
    // path starts.
    for (at, name) in report.operations.iter().map(|(v, n)| (v.max(x.start), n)).filter(|(v, _)| inside(*v)) {
        area.draw(&PathElement::new(vec![(at, y.start), (at, y.end)], OPERATION.stroke_width(1)))
            .map_err(draw_error)?;
        let label: String = name.chars().take(LEGEND_CHARS).collect();
        area.draw(&Text::new(format!(" {label}"), (at, top), name_style.clone())).map_err(draw_error)?;
    }
    // Each number on a white tag just above its circle, so the lines under it do not blur it.
    let number_style =
        (FONT, 14).into_font().style(FontStyle::Bold).color(&MARK).pos(Pos::new(HPos::Center, VPos::Center));
    let (width, height) = area.dim_in_pixel();
    let per_pixel = ((x.end - x.start) / f64::from(width.max(1)), (y.end - y.start) / f64::from(height.max(1)));
    for &(at, feed, number) in report.marks.iter().filter(|(v, f, _)| inside(*v) && f.is_finite()) {
        let label = format!("#{number}");
        let (half_width, half_height) = ((label.len() as f64 * 4.5 + 3.0) * per_pixel.0, 9.0 * per_pixel.1);
        let centre = (at, feed + 4.0 * per_pixel.1 + 2.0 * half_height);
        let tag = [(centre.0 - half_width, centre.1 - half_height), (centre.0 + half_width, centre.1 + half_height)];
        area.draw(&Rectangle::new(tag, WHITE.mix(0.85).filled())).map_err(draw_error)?;
        area.draw(&Rectangle::new(tag, MARK.stroke_width(1))).map_err(draw_error)?;
        area.draw(&Circle::new((at, feed), 4, MARK.stroke_width(2))).map_err(draw_error)?;
        area.draw(&Text::new(label, centre, number_style.clone())).map_err(draw_error)?;
    }
    Ok(())
}

/// The bottom panel: every axis's velocity, rotary axes on the right scale when there are
/// linear ones too.
fn draw_axes(area: &Area<'_>, legend: &Area<'_>, report: &Report, x_range: &Range<f64>) -> Result<(), PlotError> {
    let path = &report.path_mm;
    // Each axis with its colour, the linear ones and the rotary ones.
    let coloured = report.axes.iter().enumerate().map(|(i, axis)| (axis, PALETTE[i % PALETTE.len()]));
    let (rotary, linear): (Vec<_>, Vec<_>) = coloured.clone().partition(|(axis, _)| axis.rotary);
    let dual = !linear.is_empty() && !rotary.is_empty();
    let extent_of = |axes: &[(&AxisSeries, RGBColor)]| {
        extent(axes.iter().flat_map(|(axis, _)| finite_values(path, &axis.velocity)), true)
    };
    let (primary, primary_desc) = if linear.is_empty() {
        (&rotary, "rotary axis velocity (deg/min)")
    } else {
        (&linear, "linear axis velocity (mm/min)")
    };
    if dual {
        let (primary, secondary) = align_zero(y_range(extent_of(primary)), y_range(extent_of(&rotary)));
        let secondary_ticks = Ticks::over(&secondary);
        let mut chart = chart(area, x_range, primary, true)?.set_secondary_coord(x_range.clone(), secondary);
        draw_mesh(&mut chart, primary_desc)?;
        let label = move |v: &f64| secondary_ticks.label(*v);
        chart
            .configure_secondary_axes()
            .y_desc("rotary axis velocity (deg/min)")
            .y_labels(10)
            .y_label_formatter(&label)
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .draw()
            .map_err(draw_error)?;
        let columns = Columns::new(x_range, chart.plotting_area().dim_in_pixel().0);
        for (axis, colour) in &linear {
            let points = columns.polyline(path, &reduce(path, &axis.velocity, &columns));
            draw_line(&mut chart, points, colour, 2)?;
        }
        for (axis, colour) in &rotary {
            let points = columns.polyline(path, &reduce(path, &axis.velocity, &columns));
            let style = colour.stroke_width(2);
            if points.len() == 1 {
                chart.draw_secondary_series(points.into_iter().map(|p| Circle::new(p, 3, style.filled())))
            } else {
                chart.draw_secondary_series(LineSeries::new(points, style))
            }
            .map_err(draw_error)?;
        }
    } else {
        let mut chart = chart(area, x_range, y_range(extent_of(primary)), false)?;
        draw_mesh(&mut chart, primary_desc)?;
        let columns = Columns::new(x_range, chart.plotting_area().dim_in_pixel().0);
        for (axis, colour) in primary {
            let points = columns.polyline(path, &reduce(path, &axis.velocity, &columns));
            draw_line(&mut chart, points, colour, 2)?;
        }
    }

    let mut entries = vec![Entry::Heading("Axis velocity".into())];
    for (axis, colour) in coloured {
        let unit = match (axis.rotary, dual) {
            (true, true) => "deg/min, right",
            (true, false) => "deg/min",
            (false, _) => "mm/min",
        };
        entries.push(Entry::Line(format!("{} ({unit})", axis.letter), colour.into(), 3));
    }
    if report.axes.is_empty() {
        entries.push(Entry::Heading("(no axes given)".into()));
    }
    draw_legend(legend, &entries)
}

/// Draws `points` as a line, or as a dot when there is only one.
fn draw_line(
    chart: &mut Chart<'_, '_>,
    points: Vec<(f64, f64)>,
    colour: impl Color,
    width: u32,
) -> Result<(), PlotError> {
    let style = colour.stroke_width(width);
    if points.len() == 1 {
        chart.draw_series(points.into_iter().map(|p| Circle::new(p, 3, style.filled())))
    } else {
        chart.draw_series(LineSeries::new(points, style))
    }
    .map_err(draw_error)?;
    Ok(())
}

/// One line of a legend.
enum Entry {
    /// A heading in bold.
    Heading(String),
    /// A line sample (colour, width) and its label.
    Line(String, RGBAColor, u32),
    /// A dashed line sample (colour, width) and its label.
    Dashed(String, RGBAColor, u32),
}

/// Draws a legend in its own column, beside the chart: it never covers data.
fn draw_legend(area: &Area<'_>, entries: &[Entry]) -> Result<(), PlotError> {
    let height = i32::try_from(area.dim_in_pixel().1).unwrap_or(i32::MAX);
    let fits = usize::try_from((height - 2 * MARGIN as i32) / LEGEND_LINE).unwrap_or(0).max(1);
    let shown = if entries.len() > fits { fits - 1 } else { entries.len() };
    let left = Pos::new(HPos::Left, VPos::Center);
    let mut y = MARGIN as i32 + LEGEND_LINE / 2;
    for entry in &entries[..shown] {
        match entry {
            Entry::Heading(text) => {
                let style = (FONT, 15).into_font().style(FontStyle::Bold).color(&BLACK).pos(left);
                area.draw(&Text::new(shorten(text), (6, y), style)).map_err(draw_error)?;
            }
            Entry::Line(text, colour, width) | Entry::Dashed(text, colour, width) => {
                let style = colour.stroke_width(*width);
                let sample = vec![(10, y), (40, y)];
                if matches!(entry, Entry::Dashed(..)) {
                    area.draw(&DashedPathElement::new(sample, DASH, GAP, style)).map_err(draw_error)?;
                } else {
                    area.draw(&PathElement::new(sample, style)).map_err(draw_error)?;
                }
                let style = (FONT, 14).into_font().color(&BLACK).pos(left);
                area.draw(&Text::new(shorten(text), (48, y), style)).map_err(draw_error)?;
            }
        }
        y += LEGEND_LINE;
    }
    if shown < entries.len() {
        let style = (FONT, 14).into_font().color(&SUBTITLE).pos(left);
        let more = format!("… and {} more", entries.len() - shown);
        area.draw(&Text::new(more, (10, y), style)).map_err(draw_error)?;
    }
    Ok(())
}

/// `text`, cut to fit the legend column.
fn shorten(text: &str) -> String {
    if text.chars().count() <= LEGEND_CHARS {
        return text.to_string();
    }
    let mut short: String = text.chars().take(LEGEND_CHARS - 1).collect();
    short.push('…');
    short
}

// ---------------------------------------------------------------------------------------------
// Decimation.

/// The pixel columns of the plotting area, as a map from path length to column.
struct Columns {
    /// Path length at the left edge.
    start: f64,
    /// Columns per mm.
    scale: f64,
    /// Number of columns.
    count: usize,
}

/// The extremes of one series within one column: the smallest and largest value and the
/// samples they come from (`usize::MAX` for an empty column).
#[derive(Clone, Copy)]
struct Bucket {
    lo: f64,
    lo_at: usize,
    hi: f64,
    hi_at: usize,
}

impl Bucket {
    const EMPTY: Bucket = Bucket { lo: f64::INFINITY, lo_at: usize::MAX, hi: f64::NEG_INFINITY, hi_at: usize::MAX };

    fn is_empty(&self) -> bool {
        self.lo_at == usize::MAX
    }
}

/// Consecutive columns of the predicted feed with the same limiter.
struct Run {
    limiter: u16,
    points: Vec<(f64, f64)>,
}

impl Columns {
    fn new(x_range: &Range<f64>, pixels: u32) -> Columns {
        let count = usize::try_from(pixels).unwrap_or(1).max(1);
        let span = x_range.end - x_range.start;
        let scale = if span > 0.0 && span.is_finite() { count as f64 / span } else { 0.0 };
        Columns { start: x_range.start, scale, count }
    }

    /// The column of a finite path length (float to integer casts saturate).
    fn of(&self, x: f64) -> usize {
        (((x - self.start) * self.scale) as usize).min(self.count - 1)
    }

    /// The polyline through every non-empty column's extremes, in the order they occur.
    fn polyline(&self, path: &[f64], buckets: &[Bucket]) -> Vec<(f64, f64)> {
        let mut points = Vec::with_capacity(2 * self.count);
        for bucket in buckets.iter().filter(|b| !b.is_empty()) {
            push_extremes(path, bucket, &mut points);
        }
        points
    }

    /// The polyline of the predicted feed cut where the limiter of the column's minimum
    /// changes; each run starts at the previous run's last point, so the line stays whole.
    fn runs(&self, path: &[f64], buckets: &[Bucket], limiter: &[u16]) -> Vec<Run> {
        let mut runs: Vec<Run> = Vec::new();
        for bucket in buckets.iter().filter(|b| !b.is_empty()) {
            let this = limiter[bucket.lo_at];
            match runs.last_mut() {
                Some(run) if run.limiter == this => push_extremes(path, bucket, &mut run.points),
                last => {
                    let mut points: Vec<(f64, f64)> =
                        last.and_then(|run| run.points.last().copied()).into_iter().collect();
                    push_extremes(path, bucket, &mut points);
                    runs.push(Run { limiter: this, points });
                }
            }
        }
        runs
    }
}

/// Each column's extremes of `values` (samples with a non-finite path length or value skipped).
fn reduce(path: &[f64], values: &[f64], columns: &Columns) -> Vec<Bucket> {
    let mut buckets = vec![Bucket::EMPTY; columns.count];
    for (i, (&x, &v)) in path.iter().zip(values).enumerate() {
        if !x.is_finite() || !v.is_finite() {
            continue;
        }
        let bucket = &mut buckets[columns.of(x)];
        if v < bucket.lo {
            bucket.lo = v;
            bucket.lo_at = i;
        }
        if v > bucket.hi {
            bucket.hi = v;
            bucket.hi_at = i;
        }
    }
    buckets
}

/// Appends a column's minimum and maximum, in the order they occur (one point if the same).
fn push_extremes(path: &[f64], bucket: &Bucket, points: &mut Vec<(f64, f64)>) {
    let lo = (path[bucket.lo_at], bucket.lo);
    let hi = (path[bucket.hi_at], bucket.hi);
    match bucket.lo_at.cmp(&bucket.hi_at) {
        std::cmp::Ordering::Equal => points.push(lo),
        std::cmp::Ordering::Less => points.extend([lo, hi]),
        std::cmp::Ordering::Greater => points.extend([hi, lo]),
    }
}

// ---------------------------------------------------------------------------------------------
// Output.

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    /// A 5-axis slowdown: 5000 mm/min programmed, dips at corners limited by C jerk and by the
    /// corner tolerance, X Y Z A C.
    fn synthetic(samples: usize) -> Report {
        let names = ["programmed", "X velocity", "C jerk", "corner", "cycle time", "look-ahead"];
        let length = 400.0;
        let mut report = Report {
            title: "Predicted feed".into(),
            subtitle: "mikron-ucp710 · blend.cl · predicted cycle time 12.3 s".into(),
            path_mm: Vec::with_capacity(samples),
            programmed: Vec::with_capacity(samples),
            predicted: Vec::with_capacity(samples),
            relative: Some(Vec::with_capacity(samples)),
            limiter: Vec::with_capacity(samples),
            limiter_names: names.iter().map(|s| s.to_string()).collect(),
            axes: ["X", "Y", "Z", "A", "C"]
                .iter()
                .map(|l| AxisSeries { letter: l.to_string(), rotary: *l == "A" || *l == "C", velocity: vec![] })
                .collect(),
            rapids: vec![200.0],
            operations: vec![(0.0, "ROUGH".into()), (200.0, "FINISH".into())],
            marks: vec![(80.0, 2000.0, 1), (240.0, 2000.0, 2)],
        };
        let corners = [80.0, 160.0, 240.0, 320.0];
        for i in 0..samples {
            let s = length * i as f64 / (samples.max(2) - 1) as f64;
            let d = corners.iter().map(|c| (s - c).abs()).fold(f64::INFINITY, f64::min);
            let dip = (-(d / 12.0).powi(2)).exp();
            let feed = 5000.0 - 3000.0 * dip;
            let nearest = corners.iter().position(|c| (s - c).abs() == d).unwrap_or(0);
            let limiter = if dip < 0.05 {
                0
            } else if dip > 0.8 {
                if nearest % 2 == 0 { 2 } else { 3 }
            } else {
                5
            };
            report.path_mm.push(s);
            report.programmed.push(if (150.0..200.0).contains(&s) { 4000.0 } else { 5000.0 });
            report.predicted.push(feed.min(report.programmed[i]));
            report.relative.as_mut().unwrap().push(feed * (1.0 + 0.02 * (s / 7.0).sin()));
            report.limiter.push(limiter);
            let angle = s / 60.0;
            let velocities = [
                feed * angle.cos(),
                feed * angle.sin(),
                300.0 * (s / 20.0).sin(),
                2000.0 * dip * (s / 30.0).cos(),
                9000.0 * dip,
            ];
            for (axis, v) in report.axes.iter_mut().zip(velocities) {
                axis.velocity.push(v);
            }
        }
        report
    }

    /// The contents of the `<text>` elements, after checking that the tags nest (XML-ish).
    fn texts(svg: &str) -> Vec<String> {
        let mut open: Vec<&str> = Vec::new();
        let mut texts = Vec::new();
        let mut rest = svg;
        while let Some(start) = rest.find('<') {
            let end = rest[start..].find('>').unwrap() + start;
            let tag = &rest[start + 1..end];
            if let Some(name) = tag.strip_prefix('/') {
                assert_eq!(open.pop(), Some(name), "unbalanced </{name}>");
            } else if !tag.ends_with('/') {
                let name = tag.split_whitespace().next().unwrap();
                open.push(name);
                if name == "text" {
                    let close = rest[end..].find("</text>").unwrap() + end;
                    texts.push(rest[end + 1..close].trim().to_string());
                }
            }
            rest = &rest[end + 1..];
        }
        assert!(open.is_empty(), "unclosed {open:?}");
        texts
    }

    #[test]
    fn small_report_has_title_and_legends() {
        let mut report = synthetic(2000);
        report.title = "Feed <prediction> & limits".into();
        let svg = render(&report).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let texts = texts(&svg);
        let has = |text: &str| texts.iter().any(|t| t == text);
        assert!(has("Feed &lt;prediction&gt; &amp; limits"), "escaped title in {texts:?}");
        assert!(has("mikron-ucp710 · blend.cl · predicted cycle time 12.3 s"));
        for desc in
            ["path length (mm)", "feed (mm/min)", "linear axis velocity (mm/min)", "rotary axis velocity (deg/min)"]
        {
            assert!(has(desc), "{desc}");
        }
        // A legend entry for each limiter that occurs, none for those that do not.
        for name in ["programmed", "C jerk", "corner", "look-ahead"] {
            assert!(has(name), "{name} in {texts:?}");
        }
        assert!(!has("X velocity") && !has("cycle time"));
        for axis in ["X (mm/min)", "Y (mm/min)", "Z (mm/min)", "A (deg/min, right)", "C (deg/min, right)"] {
            assert!(has(axis), "{axis}");
        }
        assert!(has("relative (forward kin.)"));
        // The rapids left out, the operations named where they start, the slowdowns numbered.
        for text in ["rapid (left out)", "operation start", "#N slowdown marked", "ROUGH", "FINISH", "#1", "#2"] {
            assert!(has(text), "{text} in {texts:?}");
        }
    }

    #[test]
    fn million_samples_stay_small() {
        let report = synthetic(1_000_000);
        let size = render(&report).unwrap().len();
        assert!(size < 2_000_000, "{size} bytes");
    }

    #[test]
    fn empty_is_an_error() {
        let report = Report {
            title: String::new(),
            subtitle: String::new(),
            path_mm: vec![],
            programmed: vec![],
            predicted: vec![],
            relative: None,
            limiter: vec![],
            limiter_names: vec![],
            axes: vec![],
            rapids: vec![],
            operations: vec![],
            marks: vec![],
        };
        assert!(matches!(render(&report), Err(PlotError::Empty)));
        let mut report = synthetic(10);
        report.path_mm.iter_mut().for_each(|x| *x = f64::NAN);
        assert!(matches!(render(&report), Err(PlotError::Empty)));
    }

    #[test]
    fn mismatched_lengths_are_errors() {
        let mut report = synthetic(10);
        report.predicted.pop();
        assert!(
            matches!(render(&report), Err(PlotError::Length { ref series, len: 9, samples: 10 }) if series == "predicted")
        );
        let mut report = synthetic(10);
        report.axes[4].velocity.push(1.0);
        let error = render(&report).unwrap_err();
        assert_eq!(error.to_string(), "the series `axis C` has 11 values, but the path has 10 samples");
        let mut report = synthetic(10);
        report.relative.as_mut().unwrap().clear();
        assert!(matches!(render(&report), Err(PlotError::Length { .. })));
        let mut report = synthetic(10);
        report.limiter[3] = 6;
        assert!(matches!(render(&report), Err(PlotError::Limiter { sample: 3, index: 6, count: 6 })));
    }

    #[test]
    fn degenerate_data_draws() {
        // A single sample.
        let report = synthetic(1);
        let svg = render(&report).unwrap();
        assert!(svg.contains("<circle"));
        // Constant values, no relative feed, no axes.
        let mut report = synthetic(50);
        report.programmed.iter_mut().for_each(|v| *v = 5000.0);
        report.predicted.iter_mut().for_each(|v| *v = 5000.0);
        report.relative = None;
        report.axes.clear();
        render(&report).unwrap();
        // Everything zero, only rotary axes.
        let mut report = synthetic(50);
        report.path_mm.iter_mut().for_each(|v| *v = 0.0);
        report.programmed.iter_mut().for_each(|v| *v = 0.0);
        report.axes.retain(|a| a.rotary);
        render(&report).unwrap();
        // NaN and infinities are skipped, huge values do not break the scales.
        let mut report = synthetic(100);
        report.path_mm[3] = f64::NAN;
        report.predicted[5] = f64::INFINITY;
        report.programmed[7] = f64::NEG_INFINITY;
        report.axes[0].velocity[9] = f64::NAN;
        report.axes[1].velocity.iter_mut().for_each(|v| *v = f64::NAN);
        report.axes[2].velocity[10] = f64::MAX;
        report.axes[2].velocity[11] = f64::MIN;
        report.relative.as_mut().unwrap()[0] = 1e300;
        let svg = render(&report).unwrap();
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
        // A path going backwards still draws.
        let mut report = synthetic(100);
        report.path_mm.reverse();
        render(&report).unwrap();
        // Many limiters: the legend is cut with a note.
        let mut report = synthetic(300);
        report.limiter_names = (0..40).map(|i| format!("limiter number {i} with a long name")).collect();
        report.limiter.iter_mut().enumerate().for_each(|(i, l)| *l = (i % 40) as u16);
        let svg = render(&report).unwrap();
        assert!(svg.contains("more"));
    }

    #[test]
    fn tick_labels() {
        assert_eq!(Ticks::over(&(0.0..5250.0)), Ticks::Fixed(0));
        assert_eq!(Ticks::over(&(-1.0..1.0)), Ticks::Fixed(1));
        assert_eq!(Ticks::over(&(0.0..0.02)), Ticks::Fixed(3));
        assert_eq!(Ticks::over(&(0.0..2e-16)), Ticks::Scientific);
        assert_eq!(Ticks::over(&(0.0..1e300)), Ticks::Scientific);
        assert_eq!(Ticks::Fixed(1).label(-0.01), "0.0");
        assert_eq!(Ticks::Fixed(0).label(-2000.0), "-2000");
        assert_eq!(Ticks::Scientific.label(2e-16), "2.0e-16");
        assert_eq!(Ticks::Scientific.label(-0.0), "0.0e0");
    }

    #[test]
    fn columns_keep_extremes_in_order() {
        let path = [0.0, 0.1, 0.2, 10.0];
        let values = [5.0, 1.0, 9.0, 3.0];
        let columns = Columns::new(&(0.0..10.0), 2);
        let buckets = reduce(&path, &values, &columns);
        assert_eq!(columns.polyline(&path, &buckets), vec![(0.1, 1.0), (0.2, 9.0), (10.0, 3.0)]);
        let runs = columns.runs(&path, &buckets, &[0, 1, 0, 2]);
        assert_eq!(runs.len(), 2);
        assert_eq!((runs[0].limiter, runs[1].limiter), (1, 2));
        assert_eq!(runs[1].points, vec![(0.2, 9.0), (10.0, 3.0)]);
    }
}

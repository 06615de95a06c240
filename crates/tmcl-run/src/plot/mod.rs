//! The SVG plot of a trace: position, velocity, the drive, inputs, outputs and events over time.
//!
//! Panels share the time axis, one under the other:
//! 1. target (AP 0) and actual (AP 1) position, µsteps;
//! 2. actual velocity (AP 3), pps;
//! 3. with `--drive`: the stallGuard2 load value (AP 206, 0..1023); the coolStep current scale (AP 180,
//!    0..31), or on a closed-loop model the current scaler (AP 123, /255); the encoder position (AP 209)
//!    minus the step position (AP 1), lost steps, or on a closed-loop model the position error (AP 237),
//!    µsteps; the coils' energy ∫ I² dt, A²·s;
//! 4. lanes, as on a logic analyser: one per digital input and output that changes (`IN0`, `OUT1`, ...),
//!    a level line that is high while the signal is, and one per kind of program event (`interrupt 0`,
//!    `target`, `stop`, ...), a mark at each, labelled with its value where there is room (`lanes`).
//!
//! The ranges and units are those of the PD28-1021 TMCL manual's axis parameter table (chapter 4: AP 3 in
//! pps, AP 180 0..31 meaning 1/32..32/32, AP 206 0..1023, AP 209 in µsteps); the TMCM-1310's closed-loop
//! parameters (AP 123, 233, 237) as `docs/tmcm-1310.md` decides them, its manual lacking that table.
//! Every axis has its unit; ticks come from `axis::Scale` (a flat series gets a range around it, integer
//! quantities integer ticks). With few events (up to `MAX_EVENT_LINES`) each also gets a vertical line
//! across the panels above the lanes. Long traces are thinned to two points per pixel column (the
//! column's minimum and maximum, so peaks stay visible). The encoder − steps and position-error panels
//! draw the minimum-to-maximum envelope over slots of a few pixel columns as a band: a difference that
//! jitters by an encoder count reads as a band with straight edges, not as a solid block of zigzag lines.

mod axis;
mod lanes;

use crate::trace::{Levels, Quantity, Trace};
use axis::{text_width, Scale};
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Up to this many events get a vertical line in the panels.
const MAX_EVENT_LINES: usize = 40;

const WIDTH: u32 = 1200;
const TITLE: u32 = 40;
/// Left of each panel: tick labels and the rotated axis description.
const Y_LABELS: u32 = 100;
const MARGIN_LEFT: u32 = 10;
/// Right of each panel: room for half of the last time label.
const MARGIN_RIGHT: u32 = 36;
/// Above each panel: its key (series names).
const KEY: u32 = 24;
/// Below each panel: the time labels.
const X_LABELS: u32 = 22;
/// Below the last panel: also `time [s]`.
const X_DESC: u32 = 20;
/// The plot's width in pixels inside a panel: one pixel column per point pair when thinning.
const COLUMNS: usize = (WIDTH - Y_LABELS - MARGIN_LEFT - MARGIN_RIGHT) as usize;
/// How many pixel columns either side an envelope takes in (see [`envelope`]).
const ENVELOPE_REACH: usize = 10;

const FONT: &str = "sans-serif";
/// The key's font size (plotters draws text at 1/1.24 of the size it is given).
const KEY_FONT: u32 = 14;
const TARGET: RGBColor = RGBColor(230, 140, 30);
const ACTUAL: RGBColor = RGBColor(30, 90, 200);
const SPEED: RGBColor = RGBColor(20, 150, 70);
const LOAD: RGBColor = RGBColor(150, 40, 160);
const SCALE: RGBColor = RGBColor(200, 60, 40);
const SLIP: RGBColor = RGBColor(60, 60, 60);
const ENERGY: RGBColor = RGBColor(190, 120, 0);

/// What went wrong drawing the plot.
pub type PlotError = Box<dyn std::error::Error>;

/// A coordinate over a [`Scale`]: its range, mapped as plotters maps an `f64` range, with exactly its
/// ticks as the key points (grid lines and labels), whatever plotters would have chosen.
struct Axis {
    inner: RangedCoordf64,
    ticks: Vec<f64>,
}

impl Ranged for Axis {
    type ValueType = f64;
    // The labels always come from a formatter given to the mesh ([`Scale::label`]).
    type FormatOption = DefaultFormatting;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<Axis, Axis>>;

/// A coordinate axis over `scale`'s range with its ticks.
fn coordinate(scale: &Scale) -> Axis {
    Axis { inner: scale.range.clone().into(), ticks: scale.ticks.clone() }
}

/// How one series is drawn.
enum Style {
    /// A line of the given width.
    Line(u32),
    /// The band between each pixel column's minimum and maximum, edged by thin lines.
    Envelope,
}

/// One series of a panel: `(seconds, value)` points (already thinned), and its name for the key.
struct Series {
    points: Vec<(f64, f64)>,
    color: RGBColor,
    style: Style,
    name: String,
}

/// One panel: its height in pixels, its axis description with the unit, its scale and series.
struct Panel {
    height: u32,
    unit: &'static str,
    scale: Scale,
    series: Vec<Series>,
}

impl Panel {
    /// A panel whose scale fits its series (integer ticks if `integer`), or that shows `fixed` if given.
    fn new(height: u32, unit: &'static str, integer: bool, fixed: Option<(f64, f64)>, series: Vec<Series>) -> Panel {
        let ticks = max_ticks(height);
        let scale = match fixed {
            Some((lo, hi)) => Scale::fixed(lo, hi, integer, ticks),
            None => {
                let (lo, hi) = series
                    .iter()
                    .flat_map(|s| &s.points)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
                if lo.is_finite() {
                    Scale::fit(lo, hi, integer, ticks)
                } else {
                    Scale::fit(0.0, 0.0, integer, ticks)
                }
            }
        };
        Panel { height, unit, scale, series }
    }
}

/// About one tick per 28 pixels of plot height.
fn max_ticks(height: u32) -> usize {
    (height.saturating_sub(KEY + X_LABELS + 4) / 28).clamp(axis::MIN_TICKS as u32, 10) as usize
}

/// The SVG of a trace, titled `title`: the panels of the columns it has (the drive's if it was recorded
/// with them), the lanes of its inputs, outputs and events.
pub fn svg(trace: &Trace, title: &str) -> Result<String, PlotError> {
    let mut out = String::new();
    draw(&mut out, title, trace)?;
    Ok(out)
}

/// Writes the SVG of a trace ([`svg`]) to `path`.
pub fn write(trace: &Trace, title: &str, path: &std::path::Path) -> Result<(), PlotError> {
    std::fs::write(path, svg(trace, title)?)?;
    Ok(())
}

/// The samples the panels draw, taken from the trace's columns.
fn samples(trace: &Trace) -> Vec<Sample> {
    let column = |q: Quantity| trace.column(q);
    let at = |c: Option<&[Option<i64>]>, r: usize| c.and_then(|c| c[r]).unwrap_or(0) as i32;
    let (target, actual, velocity) =
        (column(Quantity::TargetPosition), column(Quantity::ActualPosition), column(Quantity::Velocity));
    let drive = column(Quantity::Energy).is_some();
    let closed_loop = column(Quantity::PositionError).is_some();
    let (load, scale, encoder, energy) =
        (column(Quantity::Load), column(Quantity::CurrentScale), column(Quantity::Encoder), column(Quantity::Energy));
    let cl = Quantity::CLOSED_LOOP.map(column);
    (0..trace.len())
        .map(|r| Sample {
            micros: trace.times[r],
            target: at(target, r),
            actual: at(actual, r),
            velocity: at(velocity, r),
            drive: drive.then(|| Drive {
                load: at(load, r),
                current_scale: at(scale, r),
                encoder: at(encoder, r),
                energy: energy.and_then(|e| e[r]).unwrap_or(0) as u64,
            }),
            closed_loop: closed_loop.then(|| cl.map(|c| at(c, r))),
        })
        .collect()
}

/// What the drive reports at a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Drive {
    load: i32,
    current_scale: i32,
    encoder: i32,
    /// µA²·s.
    energy: u64,
}

/// One sample of the panels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Sample {
    micros: u64,
    target: i32,
    actual: i32,
    velocity: i32,
    drive: Option<Drive>,
    /// Virtual position, position error, scaler, status word.
    closed_loop: Option<[i32; 4]>,
}

/// One program event of the plot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Event {
    micros: u64,
    text: String,
}

fn draw(out: &mut String, title: &str, trace: &Trace) -> Result<(), PlotError> {
    let samples = &samples(trace)[..];
    let events: &[Event] =
        &trace.events.iter().map(|e| Event { micros: e.micros, text: e.event.to_string() }).collect::<Vec<_>>();
    let levels: &[Levels] = &trace.levels;
    let drive = trace.column(Quantity::Energy).is_some();
    let end = samples.last().map_or(1, |s| s.micros).max(events.last().map_or(0, |e| e.micros)).max(1);
    let time = Scale::fixed(0.0, seconds(end), false, 12);
    let mut panels = vec![position_panel(samples), velocity_panel(samples)];
    if drive {
        panels.extend(drive_panels(samples, seconds(end)));
    }
    let lanes = lanes::Lanes::new(events, levels, seconds(end));
    let height = TITLE + panels.iter().map(|p| p.height).sum::<u32>() + lanes.height();
    let root = SVGBackend::with_string(out, (WIDTH, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let (head, mut rest) = root.split_vertically(TITLE);
    let style = TextStyle::from((FONT, 24).into_font()).pos(Pos::new(HPos::Center, VPos::Center));
    head.draw(&Text::new(title.to_string(), (WIDTH as i32 / 2, TITLE as i32 / 2), style))?;
    let lines = if events.len() <= MAX_EVENT_LINES { events } else { &[] };
    for (i, panel) in panels.iter().enumerate() {
        let (area, below) = rest.split_vertically(panel.height);
        let bottom = i + 1 == panels.len() && lanes.is_empty();
        draw_panel(&area, &time, panel, lines, bottom)?;
        rest = below;
    }
    lanes.draw(&rest, &time)?;
    root.present()?;
    Ok(())
}

fn position_panel(samples: &[Sample]) -> Panel {
    let series = vec![
        line(samples, |s| s.target, TARGET, 2, "target position (AP 0)"),
        line(samples, |s| s.actual, ACTUAL, 1, "actual position (AP 1)"),
    ];
    Panel::new(300, "position [µsteps]", true, None, series)
}

fn velocity_panel(samples: &[Sample]) -> Panel {
    let series = vec![line(samples, |s| s.velocity, SPEED, 1, "actual velocity (AP 3)")];
    Panel::new(220, "velocity [pps]", true, None, series)
}

/// The `--drive` panels: load value, current scale or scaler, encoder − steps or position error, energy.
fn drive_panels(samples: &[Sample], end: f64) -> Vec<Panel> {
    let drive = |f: fn(&Drive) -> i32| move |s: &Sample| s.drive.as_ref().map_or(0, f);
    let closed_loop = samples.iter().any(|s| s.closed_loop.is_some());
    let load = line(
        samples,
        drive(|d| d.load),
        LOAD,
        1,
        "stallGuard2 load value (AP 206): 1023 unloaded, 0 at the torque limit",
    );
    let mut panels = vec![Panel::new(200, "load value (0–1023)", true, Some((-31.0, 1054.0)), vec![load])];
    if closed_loop {
        let scaler = line(
            samples,
            |s| s.closed_loop.map_or(0, |c| c[2]),
            SCALE,
            2,
            "closed-loop current scaler (AP 123): the current is AP 6 × scaler / 255",
        );
        panels.push(Panel::new(200, "current scaler (/255)", true, Some((-8.0, 263.0)), vec![scaler]));
        // In closed loop AP 1 is the encoder: the error that matters is the virtual position's lead.
        let error = |s: &Sample| s.closed_loop.map_or(0.0, |c| f64::from(c[1]));
        let error = difference(
            samples,
            end,
            error,
            "position error (AP 237): virtual position (AP 233) − actual position (AP 1)",
        );
        panels.push(Panel::new(230, "position error [µsteps]", true, None, vec![error]));
    } else {
        let scale = line(
            samples,
            drive(|d| d.current_scale),
            SCALE,
            2,
            "coolStep current scale (AP 180): the current is (n + 1)/32 of the set current",
        );
        panels.push(Panel::new(200, "current scale (0–31)", true, Some((-1.0, 32.0)), vec![scale]));
        let slip = |s: &Sample| s.drive.map_or(0.0, |d| f64::from(d.encoder) - f64::from(s.actual));
        let slip = difference(samples, end, slip, "encoder position (AP 209) − step position (AP 1): lost steps");
        panels.push(Panel::new(230, "encoder − steps [µsteps]", true, None, vec![slip]));
    }
    let energy = thin(samples, |s| s.drive.map_or(0.0, |d| d.energy as f64 / 1e6));
    let energy = Series {
        points: energy,
        color: ENERGY,
        style: Style::Line(2),
        name: "coil energy ∫ I² dt of both coils since power-up (× coil resistance = copper loss in J)".into(),
    };
    let mut energy = Panel::new(200, "coil energy [A²·s]", false, None, vec![energy]);
    // Energy only grows from 0: the axis starts at 0.
    let top = energy.series[0].points.iter().fold(0.0f64, |m, p| m.max(p.1));
    energy.scale = Scale::fit(0.0, top, false, max_ticks(200));
    panels.push(energy);
    panels
}

/// A line series of an integer quantity.
fn line(samples: &[Sample], value: impl Fn(&Sample) -> i32, color: RGBColor, width: u32, name: &str) -> Series {
    Series { points: thin(samples, |s| f64::from(value(s))), color, style: Style::Line(width), name: name.into() }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    time: &Scale,
    panel: &Panel,
    lines: &[Event],
    bottom: bool,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let mut chart = ChartBuilder::on(area)
        .margin_left(MARGIN_LEFT)
        .margin_right(MARGIN_RIGHT)
        .margin_top(KEY)
        .margin_bottom(4)
        .x_label_area_size(if bottom { X_LABELS + X_DESC } else { X_LABELS })
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(coordinate(time), coordinate(&panel.scale))?;
    let x_label = |v: &f64| time.label(*v);
    let y_label = |v: &f64| panel.scale.label(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_label_formatter(&x_label)
        .y_label_formatter(&y_label)
        .y_desc(panel.unit)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .bold_line_style(BLACK.mix(0.1))
        .light_line_style(TRANSPARENT);
    if bottom {
        mesh.x_desc("time [s]");
    }
    mesh.draw()?;
    event_lines(&mut chart, lines)?;
    for s in &panel.series {
        match s.style {
            Style::Line(width) => {
                chart.draw_series(LineSeries::new(s.points.iter().copied(), s.color.stroke_width(width)))?;
            }
            Style::Envelope => draw_envelope(&mut chart, &s.points, s.color)?,
        }
    }
    key(area, &chart, &panel.series)
}

/// The series' names above the plot, each after a short stroke of its colour.
fn key<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, chart: &Chart<DB>, series: &[Series]) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let (bx, by) = area.get_base_pixel();
    let mut x = xs.start - bx;
    let y = ys.start - by - KEY as i32 / 2;
    let style = TextStyle::from((FONT, KEY_FONT).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for s in series {
        area.draw(&PathElement::new(vec![(x, y), (x + 18, y)], s.color.stroke_width(3)))?;
        area.draw(&Text::new(s.name.clone(), (x + 24, y), style.clone()))?;
        x += 24 + text_width(&s.name, f64::from(KEY_FONT)) as i32 + 24;
    }
    Ok(())
}

/// Vertical lines at the events, across the whole panel.
fn event_lines<DB: DrawingBackend>(chart: &mut Chart<DB>, events: &[Event]) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let y = chart.y_range();
    chart.draw_series(events.iter().map(|e| {
        let x = seconds(e.micros);
        PathElement::new(vec![(x, y.start), (x, y.end)], RED.mix(0.35).stroke_width(1))
    }))?;
    Ok(())
}

/// An envelope's points come in pairs per slot, (time, minimum) then (time, maximum): the band
/// between the minima and the maxima, filled lightly and edged by thin lines.
fn draw_envelope<DB: DrawingBackend>(
    chart: &mut Chart<DB>,
    points: &[(f64, f64)],
    color: RGBColor,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let low: Vec<(f64, f64)> = points.iter().step_by(2).copied().collect();
    let high: Vec<(f64, f64)> = points.iter().skip(1).step_by(2).copied().collect();
    let band: Vec<(f64, f64)> = high.iter().chain(low.iter().rev()).copied().collect();
    chart.draw_series(std::iter::once(Polygon::new(band, color.mix(0.3).filled())))?;
    chart.draw_series(LineSeries::new(low, color.mix(0.7).stroke_width(1)))?;
    chart.draw_series(LineSeries::new(high, color.mix(0.7).stroke_width(1)))?;
    Ok(())
}

/// Microseconds as seconds.
fn seconds(micros: u64) -> f64 {
    micros as f64 / 1e6
}

/// `(seconds, value)` points of one series, at most two per pixel column: each column's minimum and
/// maximum, in time order (all samples if there are no more than that).
fn thin(samples: &[Sample], value: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    if samples.len() <= 2 * COLUMNS {
        return samples.iter().map(|s| (seconds(s.micros), value(s))).collect();
    }
    let bucket = samples.len().div_ceil(COLUMNS);
    let mut points = Vec::with_capacity(2 * COLUMNS + 2);
    for chunk in samples.chunks(bucket) {
        let lo = chunk.iter().min_by(|a, b| value(a).total_cmp(&value(b)));
        let hi = chunk.iter().max_by(|a, b| value(a).total_cmp(&value(b)));
        if let (Some(lo), Some(hi)) = (lo, hi) {
            let (first, second) = if lo.micros <= hi.micros { (lo, hi) } else { (hi, lo) };
            points.push((seconds(first.micros), value(first)));
            points.push((seconds(second.micros), value(second)));
        }
    }
    points
}

/// A difference of two positions (encoder − steps, the position error) as a line, or as a band if it
/// [`jitters`]: then it is mostly the encoder's resolution, which a line would draw as a solid block of
/// zigzags.
fn difference(samples: &[Sample], end: f64, value: impl Fn(&Sample) -> f64, name: &str) -> Series {
    let values: Vec<f64> = samples.iter().map(&value).collect();
    if jitters(&values) {
        let name = format!("{name} (band: minimum to maximum over ±{ENVELOPE_REACH} pixels)");
        Series { points: envelope(samples, end, value), color: SLIP, style: Style::Envelope, name }
    } else {
        Series { points: thin(samples, value), color: SLIP, style: Style::Line(1), name: name.into() }
    }
}

/// Whether a series jitters visibly: more than one sample in five turns (a rise then a fall, or a fall
/// then a rise; steady stretches do not count), and its moves are on average at least 1/20 of its range.
/// So the encoder's 50 µsteps on a range of 50 jitter; a closed loop's few µsteps of hold on a range of
/// 9000 do not, nor do lost steps piling up.
fn jitters(values: &[f64]) -> bool {
    let moves: Vec<f64> = values.windows(2).map(|w| w[1] - w[0]).filter(|d| *d != 0.0).collect();
    let turns = moves.windows(2).filter(|w| w[0].signum() != w[1].signum()).count();
    let (lo, hi) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let mean_move = moves.iter().map(|d| d.abs()).sum::<f64>() / moves.len().max(1) as f64;
    turns * 5 > values.len() && mean_move * 20.0 >= hi - lo
}

/// The band around `value` over the time axis `0..end`: for each pixel column that has samples, the
/// minimum and the maximum over it and [`ENVELOPE_REACH`] columns either side, as pairs of points
/// `(time, minimum), (time, maximum)` at the column's first sample. The reach smooths the edges of a
/// band whose samples alias with the encoder's steps; a real jump widens the band by a few pixels.
fn envelope(samples: &[Sample], end: f64, value: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    let mut columns: Vec<Option<(f64, f64, f64)>> = vec![None; COLUMNS + 1];
    for s in samples {
        let t = seconds(s.micros);
        let c = (((t / end.max(1e-9)) * COLUMNS as f64) as usize).min(COLUMNS);
        let v = value(s);
        let column = columns[c].get_or_insert((t, v, v));
        column.1 = column.1.min(v);
        column.2 = column.2.max(v);
    }
    let mut points = Vec::new();
    for (c, column) in columns.iter().enumerate() {
        let Some((t, _, _)) = column else { continue };
        let near = &columns[c.saturating_sub(ENVELOPE_REACH)..(c + ENVELOPE_REACH + 1).min(columns.len())];
        let (lo, hi) =
            near.iter().flatten().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), n| (lo.min(n.1), hi.max(n.2)));
        points.push((*t, lo));
        points.push((*t, hi));
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(micros: u64, actual: i32) -> Sample {
        Sample { micros, target: 0, actual, velocity: 0, drive: None, closed_loop: None }
    }

    #[test]
    fn thinning_keeps_the_extremes() {
        let samples: Vec<Sample> = (0..100_000u64).map(|i| sample(i * 1000, if i == 54_321 { 7 } else { 0 })).collect();
        let points = thin(&samples, |s| f64::from(s.actual));
        assert!(points.len() <= 2 * COLUMNS + 2);
        assert!(points.iter().any(|p| p.1 == 7.0));
        assert!(points.windows(2).all(|w| w[0].0 <= w[1].0), "in time order");
    }

    #[test]
    fn a_jittering_difference_is_a_band_with_straight_edges() {
        // Encoder − steps jumping between -50 and 0 on every sample (one encoder count is 50 µsteps),
        // 100 samples per pixel column: one band from -50 to 0, not 100 000 zigzag lines.
        let samples: Vec<Sample> = (0..100_000u64).map(|i| sample(i * 10, if i % 2 == 0 { -50 } else { 0 })).collect();
        let end = seconds(samples.last().unwrap().micros);
        let band = difference(&samples, end, |s| f64::from(s.actual), "jitter");
        assert!(matches!(band.style, Style::Envelope));
        assert!(band.points.len() <= 2 * (COLUMNS + 1), "{}", band.points.len());
        assert!(band.points.chunks(2).all(|p| p[0].1 == -50.0 && p[1].1 == 0.0));
        // Sparser than the pixels, aliased (3 samples per 2 columns): the reach still fills the band.
        let sparse: Vec<Sample> =
            (0..1500u64).map(|i| sample(i * 1000, [-49, -20, -3, -35, -11][(i * 7 % 5) as usize])).collect();
        let band = difference(&sparse, seconds(1_499_000), |s| f64::from(s.actual), "aliased");
        assert!(matches!(band.style, Style::Envelope));
        assert!(band.points.chunks(2).all(|p| p[0].1 == -49.0 && p[1].1 == -3.0));
    }

    #[test]
    fn a_smooth_difference_stays_a_line() {
        // A position error that rises and falls once (the closed loop's seizure), and steps (lost steps).
        let peak: Vec<Sample> = (0..300u64).map(|i| sample(i * 20_000, 9000 - (i as i32 - 150).abs() * 60)).collect();
        let line = difference(&peak, seconds(299 * 20_000), |s| f64::from(s.actual), "error");
        assert!(matches!(line.style, Style::Line(_)));
        assert_eq!(line.points.len(), 300);
        let steps: Vec<Sample> = (0..3000u64).map(|i| sample(i * 1000, -((i / 500) as i32) * 800)).collect();
        assert!(!jitters(&steps.iter().map(|s| f64::from(s.actual)).collect::<Vec<_>>()));
        // A hold that wobbles by a few µsteps under a peak of 9000: the wobble is not what the panel shows.
        let wobble: Vec<f64> =
            (0..300).map(|i| if (140..160).contains(&i) { 9000.0 } else { f64::from(i % 7) }).collect();
        assert!(!jitters(&wobble));
    }
}

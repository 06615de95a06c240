//! The SVG plot of a trace: position and velocity over time, with the program's events.
//!
//! Three panels share the time axis:
//! 1. target (AP 0) and actual (AP 1) position in microsteps;
//! 2. actual velocity (AP 3) in pps;
//! 3. with `--drive`: the stallGuard2 load value (AP 206) and the coolStep current scale × 32 (AP 180) on
//!    one scale 0..1023, and the encoder position (AP 209) minus the step position (AP 1): lost steps; on a
//!    closed-loop model the current scaler × 4 (AP 123) and the position error (AP 237) instead;
//! 4. an event lane per kind of event (`interrupt 0`, `out0=1`, `stop`, ...), a tick for each one.
//!
//! With few events (up to [`MAX_EVENT_LINES`]) each also gets a vertical line across the position and
//! velocity panels, labelled in the position panel. Long traces are thinned to at most [`MAX_POINTS`]
//! points per series, keeping each bucket's minimum and maximum so peaks stay visible.

use super::trace::{Event, Sample};
use plotters::prelude::*;
use std::ops::Range;
use std::path::Path;

/// Points per series at most.
const MAX_POINTS: usize = 4000;
/// Up to this many events get a vertical line in the upper panels.
const MAX_EVENT_LINES: usize = 40;
/// Up to this many events get a text label on their line.
const MAX_EVENT_LABELS: usize = 12;
/// Event lanes at most; further kinds share the last lane ("other").
const MAX_LANES: usize = 8;

const SIZE: (u32, u32) = (1200, 860);
const TARGET: RGBColor = RGBColor(230, 140, 30);
const ACTUAL: RGBColor = RGBColor(30, 90, 200);
const SPEED: RGBColor = RGBColor(20, 150, 70);

/// What went wrong drawing the plot.
pub(crate) type PlotError = Box<dyn std::error::Error>;

/// Draws `samples` and `events` into an SVG file at `path`.
pub(crate) fn draw(
    path: &Path,
    title: &str,
    samples: &[Sample],
    events: &[Event],
    drive: bool,
) -> Result<(), PlotError> {
    let size = if drive { (SIZE.0, SIZE.1 + 440) } else { SIZE };
    let root = SVGBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let (upper, lanes_area) = root.split_vertically(size.1 - 40 - lane_height(events));
    let (upper, drive_area) =
        if drive { upper.split_vertically(size.1 - 480 - lane_height(events)) } else { (upper.clone(), upper) };
    let (position_area, velocity_area) = upper.split_vertically((SIZE.1 - 40 - lane_height(events)) * 55 / 100);

    let end = samples.last().map_or(1, |s| s.micros).max(events.last().map_or(0, |e| e.micros)).max(1);
    let time = 0.0..seconds(end);
    let lines = if events.len() <= MAX_EVENT_LINES { events } else { &[] };

    let positions: Vec<(f64, f64)> =
        thin(samples, |s| f64::from(s.target)).into_iter().chain(thin(samples, |s| f64::from(s.actual))).collect();
    let mut chart =
        panel(&position_area, time.clone(), padded(positions.iter().map(|p| p.1)), "position [µsteps]", lines)?;
    series(&mut chart, thin(samples, |s| f64::from(s.target)), TARGET, 2, "target position (AP 0)")?;
    series(&mut chart, thin(samples, |s| f64::from(s.actual)), ACTUAL, 1, "actual position (AP 1)")?;
    if lines.len() <= MAX_EVENT_LABELS {
        let top = chart.y_range().end;
        chart.draw_series(
            lines.iter().map(|e| Text::new(e.text.clone(), (seconds(e.micros), top), ("sans-serif", 12).into_font())),
        )?;
    }
    legend(&mut chart)?;

    let speeds = thin(samples, |s| f64::from(s.velocity));
    let mut chart = panel(&velocity_area, time.clone(), padded(speeds.iter().map(|p| p.1)), "velocity [pps]", lines)?;
    series(&mut chart, speeds, SPEED, 1, "actual velocity (AP 3)")?;
    legend(&mut chart)?;

    if drive {
        draw_drive(&drive_area, time.clone(), samples, lines)?;
    }
    draw_lanes(&lanes_area, time, events)?;
    root.present()?;
    Ok(())
}

const LOAD: RGBColor = RGBColor(150, 40, 160);
const SCALE: RGBColor = RGBColor(200, 60, 40);
const SLIP: RGBColor = RGBColor(60, 60, 60);

/// The drive panels: load value and current scale, then encoder minus step position.
fn draw_drive<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    time: Range<f64>,
    samples: &[Sample],
    lines: &[Event],
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (load_area, slip_area) = area.split_vertically(240);
    let field = |f: fn((i32, i32, i32)) -> i32| move |s: &Sample| s.drive.map_or(0.0, |d| f64::from(f(d)));
    let closed_loop = samples.iter().any(|s| s.closed_loop.is_some());
    let mut chart = panel(&load_area, time.clone(), -20.0..1060.0, "load / current", lines)?;
    series(&mut chart, thin(samples, field(|d| d.0)), LOAD, 1, "stallGuard2 load value (AP 206)")?;
    if closed_loop {
        let scaler = thin(samples, |s| s.closed_loop.map_or(0.0, |c| f64::from(c[2]) * 4.0));
        series(&mut chart, scaler, SCALE, 2, "closed-loop current scaler × 4 (AP 123)")?;
    } else {
        series(&mut chart, thin(samples, field(|d| d.1 * 32)), SCALE, 2, "coolStep current scale × 32 (AP 180)")?;
    }
    legend(&mut chart)?;
    if closed_loop {
        // In closed loop AP 1 is the encoder: the error that matters is the virtual position's lead.
        let error = thin(samples, |s| s.closed_loop.map_or(0.0, |c| f64::from(c[1])));
        let mut chart = panel(&slip_area, time, padded(error.iter().map(|p| p.1)), "position error [µsteps]", lines)?;
        series(&mut chart, error, SLIP, 1, "virtual (AP 233) − actual position (AP 1): AP 237")?;
        return legend(&mut chart);
    }
    let slip = thin(samples, |s| s.drive.map_or(0.0, |d| f64::from(d.2) - f64::from(s.actual)));
    let mut chart = panel(&slip_area, time, padded(slip.iter().map(|p| p.1)), "encoder − steps [µsteps]", lines)?;
    series(&mut chart, slip, SLIP, 1, "encoder position (AP 209) − step position (AP 1)")?;
    legend(&mut chart)
}

type Chart<'a, DB> =
    ChartContext<'a, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>>;

/// A panel over `time` with a y axis `y` described as `what`, with the events' vertical lines.
fn panel<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, plotters::coord::Shift>,
    time: Range<f64>,
    y: Range<f64>,
    what: &str,
    lines: &[Event],
) -> Result<Chart<'a, DB>, PlotError>
where
    DB::ErrorType: 'static,
{
    let mut chart =
        ChartBuilder::on(area).margin(10).x_label_area_size(30).y_label_area_size(90).build_cartesian_2d(time, y)?;
    chart
        .configure_mesh()
        .y_desc(what)
        .x_desc("time [s]")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    event_lines(&mut chart, lines)?;
    Ok(chart)
}

/// One line series with its legend entry.
fn series<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    points: Vec<(f64, f64)>,
    color: RGBColor,
    width: u32,
    label: &str,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    chart
        .draw_series(LineSeries::new(points, color.stroke_width(width)))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    Ok(())
}

/// The legend box, lower right.
fn legend<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .draw()?;
    Ok(())
}

/// Height of the event panel: a row per lane.
fn lane_height(events: &[Event]) -> u32 {
    let n = lanes(events).len() as u32;
    if n == 0 {
        0
    } else {
        50 + 22 * n
    }
}

/// Each kind of event (its text), in order of first appearance; the last lane collects the rest.
fn lanes(events: &[Event]) -> Vec<&str> {
    let mut names: Vec<&str> = Vec::new();
    for e in events {
        if !names.contains(&e.text.as_str()) {
            names.push(&e.text);
        }
    }
    if names.len() > MAX_LANES {
        names.truncate(MAX_LANES - 1);
        names.push("other");
    }
    names
}

fn draw_lanes(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    time: Range<f64>,
    events: &[Event],
) -> Result<(), PlotError> {
    let names = lanes(events);
    if names.is_empty() {
        return Ok(());
    }
    let rows = names.len();
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(90)
        .build_cartesian_2d(time, -0.5..rows as f64 - 0.5)?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .disable_y_axis()
        .x_desc(format!("time [s] — {} program events", events.len()))
        .axis_desc_style(("sans-serif", 14))
        .x_label_style(("sans-serif", 12))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    let lane_of = |text: &str| names.iter().position(|n| *n == text).unwrap_or(rows - 1);
    let palette = [RED, ACTUAL, TARGET, SPEED, MAGENTA, CYAN, BLACK, RGBColor(120, 120, 120)];
    chart.draw_series(events.iter().map(|e| {
        let lane = lane_of(&e.text);
        let y = (rows - 1 - lane) as f64;
        let x = seconds(e.micros);
        PathElement::new(vec![(x, y - 0.35), (x, y + 0.35)], palette[lane % palette.len()].stroke_width(2))
    }))?;
    let x0 = chart.x_range().start;
    chart.draw_series(names.iter().enumerate().map(|(lane, name)| {
        Text::new(format!(" {name}"), (x0, (rows - 1 - lane) as f64 + 0.45), ("sans-serif", 13).into_font())
    }))?;
    Ok(())
}

/// Vertical lines at the events, across the whole panel.
fn event_lines<DB: DrawingBackend>(
    chart: &mut ChartContext<
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    events: &[Event],
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let y = chart.y_range();
    chart.draw_series(events.iter().map(|e| {
        let x = seconds(e.micros);
        PathElement::new(vec![(x, y.start), (x, y.end)], RED.mix(0.45).stroke_width(1))
    }))?;
    Ok(())
}

/// A value range around `values` with a margin, never empty.
fn padded(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        return -1.0..1.0;
    }
    let margin = ((hi - lo) * 0.08).max(1.0);
    lo - margin..hi + margin
}

/// Microseconds as seconds.
fn seconds(micros: u64) -> f64 {
    micros as f64 / 1e6
}

/// `(time, value)` points of one series, at most [`MAX_POINTS`]: each bucket's minimum and maximum.
fn thin(samples: &[Sample], value: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    if samples.len() <= MAX_POINTS {
        return samples.iter().map(|s| (seconds(s.micros), value(s))).collect();
    }
    let bucket = samples.len().div_ceil(MAX_POINTS / 2);
    let mut points = Vec::with_capacity(MAX_POINTS + 2);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_the_extremes() {
        let samples: Vec<Sample> = (0..100_000u64)
            .map(|i| Sample {
                micros: i * 1000,
                target: 0,
                actual: if i == 54_321 { 7 } else { 0 },
                velocity: 0,
                drive: None,
                closed_loop: None,
            })
            .collect();
        let points = thin(&samples, |s| f64::from(s.actual));
        assert!(points.len() <= MAX_POINTS);
        assert!(points.iter().any(|p| p.1 == 7.0));
        assert!(points.windows(2).all(|w| w[0].0 <= w[1].0), "in time order");
    }

    #[test]
    fn lanes_group_kinds() {
        let e = |t: &str| Event { micros: 0, text: t.into() };
        let events: Vec<Event> = ["out0=1", "out0=0", "out0=1", "stop"].iter().map(|t| e(t)).collect();
        assert_eq!(lanes(&events), ["out0=1", "out0=0", "stop"]);
        let many: Vec<Event> = (0..20).map(|n| e(&format!("interrupt {n}"))).collect();
        assert_eq!(lanes(&many).len(), MAX_LANES);
        assert_eq!(lanes(&many).last(), Some(&"other"));
    }
}

//! The SVG plot of a trace: position, velocity, the drive, switches, inputs, outputs and events over time.
//!
//! Panels share the time axis, one under the other, each drawn only if its columns are in the trace and
//! its signal moved during the run (a signal that stayed put gets a line of text under the title instead,
//! with its value):
//! 1. target (AP 0) and actual (AP 1) position, in µsteps, or in the world's unit (mm on a linear axis,
//!    degrees on a rotary one) when the run had a world file ([`crate::WorldUnit`]);
//! 2. actual velocity (AP 3), pps, and on a closed-loop model beside it the velocity measured at the
//!    encoder (AP 131, TMCM-1310 manual §3.4);
//! 3. with the drive's columns: the stallGuard2 load value (AP 206, 0..1023); the coolStep current scale
//!    (AP 180, 0..31), or on a closed-loop model the current scaler (AP 123, /255); the encoder position
//!    (AP 209) minus the step position (AP 1), lost steps, or on a closed-loop model the position error
//!    (AP 237), µsteps; the coils' energy ∫ I² dt, A²·s;
//! 4. lanes, as on a logic analyser: one per reference switch, digital input and output that changes
//!    (`HOME`, `LEFT`, `RIGHT`, `IN0`, `OUT1`, ...), a level line that is high while the signal is, and
//!    one per kind of program event (`interrupt 0`, `target`, `stop`, ...), a mark at each, labelled with
//!    its value where there is room (`lanes.rs`).
//!
//! On a model with several motors (TMCM-3110, TMCM-6110) panels 1 and 2 come once per motor, smaller and
//! named `motor N …`, each motor's positions in its own world's unit (`[motors.N]`) with a world file;
//! panel 3 and the switch lanes are motor 0's.
//!
//! The ranges and units are those of the PD28-1021 TMCL manual's axis parameter table (chapter 4: AP 3 in
//! pps, AP 180 0..31 meaning 1/32..32/32, AP 206 0..1023, AP 209 in µsteps); the TMCM-1310's closed-loop
//! parameters (AP 123, 233, 237) as `docs/tmcm-1310.md` decides them, its manual lacking that table.
//! Every axis has its unit; ticks come from `axis::Scale` (a flat series gets a range around it, integer
//! quantities integer ticks). With few events (up to 40) each also gets a faint vertical
//! line across the panels above the lanes, drawn under the grid and the axes, and none at 0 s, where it
//! would hide the value axis. Long traces are thinned to two points per pixel column (the column's minimum and maximum,
//! so peaks stay visible). The curves are drawn at sub-pixel coordinates (plotters rounds every point to
//! a whole pixel, which turns a slow ramp into a staircase), so they are written into the SVG directly.
//! The encoder − steps and position-error panels draw the minimum-to-maximum envelope over slots of a few
//! pixel columns as a band: a difference that jitters by an encoder count reads as a band with straight
//! edges, not as a solid block of zigzag lines.

mod axis;
mod lanes;

use crate::trace::{Levels, Quantity, Stamped, Trace, Values};
use axis::{format_number, text_width, Scale};
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::fmt::Write as _;

/// Up to this many events get a vertical line in the panels.
const MAX_EVENT_LINES: usize = 40;

const WIDTH: u32 = 1200;
const TITLE: u32 = 40;
/// One line of the notes under the title.
const NOTE: u32 = 20;
/// The notes' font size.
const NOTE_FONT: u32 = 14;
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
const MEASURED: RGBColor = RGBColor(0, 160, 215);

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

impl Series {
    /// The value if the series never moved.
    fn constant(&self) -> Option<f64> {
        let first = self.points.first()?.1;
        self.points.iter().all(|p| p.1 == first).then_some(first)
    }
}

/// One panel: its height in pixels, its axis description with the unit, its scale and series.
struct Panel {
    height: u32,
    unit: String,
    scale: Scale,
    series: Vec<Series>,
    /// Decimals of the values in a note.
    decimals: usize,
}

impl Panel {
    /// A panel whose scale fits its series (integer ticks if `integer`), or that shows `fixed` if given.
    fn new(height: u32, unit: &str, integer: bool, fixed: Option<(f64, f64)>, series: Vec<Series>) -> Panel {
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
        Panel { height, unit: unit.to_string(), scale, series, decimals: if integer { 0 } else { 6 } }
    }

    /// If no series moved: what the note says instead of the panel, `name: value unit` for each.
    fn note(&self) -> Option<String> {
        let values: Option<Vec<f64>> = self.series.iter().map(Series::constant).collect();
        let values = values?;
        let unit = self.unit.split_once('[').map_or("", |(_, u)| u.trim_end_matches(']'));
        let parts: Vec<String> = self
            .series
            .iter()
            .zip(values)
            .map(|(s, v)| {
                let name = s.name.split_once(':').map_or(s.name.as_str(), |(n, _)| n);
                let value = format_number(v, self.decimals);
                if unit.is_empty() {
                    format!("{name} {value}")
                } else {
                    format!("{name} {value} {unit}")
                }
            })
            .collect();
        Some(parts.join(", "))
    }
}

/// About one tick per 28 pixels of plot height.
fn max_ticks(height: u32) -> usize {
    (height.saturating_sub(KEY + X_LABELS + 4) / 28).clamp(axis::MIN_TICKS as u32, 10) as usize
}

/// The SVG of a trace, titled `title`: the panels of the columns it has (the drive's if it was recorded
/// with them) whose signals moved, a note for those that did not, and the lanes of its switches, inputs,
/// outputs and events.
pub fn svg(trace: &Trace, title: &str) -> Result<String, PlotError> {
    let mut out = String::new();
    let curves = draw(&mut out, title, trace)?;
    // The curves go in last, over the grid, each clipped to its panel's plotting area.
    let end = out.rfind("</svg>").ok_or("plotters wrote no SVG")?;
    out.insert_str(end, &curves);
    Ok(out)
}

/// Writes the SVG of a trace ([`svg`]) to `path`.
pub fn write(trace: &Trace, title: &str, path: &std::path::Path) -> Result<(), PlotError> {
    std::fs::write(path, svg(trace, title)?)?;
    Ok(())
}

/// One sample of the panels, taken from the trace's columns by meaning (`None`: the trace has no such
/// column, or the module gave no value there).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Sample {
    micros: u64,
    target: i32,
    actual: i32,
    velocity: i32,
    /// Target and actual position in the world's unit, when the run had a world.
    world: Option<(f64, f64)>,
    load: Option<i32>,
    current_scale: Option<i32>,
    encoder: Option<i32>,
    /// µA²·s.
    energy: Option<u64>,
    position_error: Option<i32>,
    scaler: Option<i32>,
    /// Closed loop: the velocity measured at the encoder (AP 131), pps.
    measured: Option<i32>,
}

/// Where the panels' samples come from: the trace's columns, read one row at a time (a trace an hour
/// long at 1 ms is 3.6 million rows: the plot never copies them), or a list (the tests).
trait Samples {
    fn len(&self) -> usize;
    fn at(&self, row: usize) -> Sample;
    fn micros(&self, row: usize) -> u64 {
        self.at(row).micros
    }
}

impl Samples for [Sample] {
    fn len(&self) -> usize {
        <[Sample]>::len(self)
    }
    fn at(&self, row: usize) -> Sample {
        self[row]
    }
}

impl Samples for Vec<Sample> {
    fn len(&self) -> usize {
        Vec::len(self)
    }
    fn at(&self, row: usize) -> Sample {
        self[row]
    }
}

/// The panels' columns of a trace, found by meaning.
struct Columns<'a> {
    trace: &'a Trace,
    /// Where the motor's positions are in its world, per row (empty without a world).
    placements: &'a [crate::trace::Placement],
    target: Option<&'a Values>,
    actual: Option<&'a Values>,
    velocity: Option<&'a Values>,
    load: Option<&'a Values>,
    scale: Option<&'a Values>,
    encoder: Option<&'a Values>,
    energy: Option<&'a Values>,
    error: Option<&'a Values>,
    scaler: Option<&'a Values>,
    measured: Option<&'a Values>,
}

impl<'a> Columns<'a> {
    /// Motor `motor`'s columns (the drive's and the closed loop's are motor 0's only).
    fn of(trace: &'a Trace, motor: u8) -> Columns<'a> {
        let column = |q: Quantity| trace.column_of(q, motor);
        let placements = match motor {
            0 => &trace.placements[..],
            m => trace.motor_placements.get(usize::from(m) - 1).map_or(&[][..], |p| &p[..]),
        };
        Columns {
            trace,
            placements,
            target: column(Quantity::TargetPosition),
            actual: column(Quantity::ActualPosition),
            velocity: column(Quantity::Velocity),
            load: column(Quantity::Load),
            scale: column(Quantity::CurrentScale),
            encoder: column(Quantity::Encoder),
            energy: column(Quantity::Energy),
            error: column(Quantity::PositionError),
            scaler: column(Quantity::Scaler),
            measured: column(Quantity::MeasuredVelocity),
        }
    }
}

impl Samples for Columns<'_> {
    fn len(&self) -> usize {
        self.trace.len()
    }

    fn micros(&self, row: usize) -> u64 {
        self.trace.times[row]
    }

    fn at(&self, r: usize) -> Sample {
        let at = |c: Option<&Values>| c.and_then(|c| c.get(r)).map(|v| v as i32);
        let (t, a) = (at(self.target).unwrap_or(0), at(self.actual).unwrap_or(0));
        Sample {
            micros: self.trace.times[r],
            target: t,
            actual: a,
            velocity: at(self.velocity).unwrap_or(0),
            world: self.placements.get(r).map(|p| (p.place(t.into()), p.place(a.into()))),
            load: at(self.load),
            current_scale: at(self.scale),
            encoder: at(self.encoder),
            energy: self.energy.and_then(|e| e.get(r)).map(|v| v as u64),
            position_error: at(self.error),
            scaler: at(self.scaler),
            measured: at(self.measured),
        }
    }
}

/// One program event of the plot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Event {
    micros: u64,
    text: String,
}

/// An event as its lane shows it: as in the trace, but a new target in the world's unit when the
/// position axis is in it (`target=50 mm` where the trace says `target=1280000`).
fn event_text(trace: &Trace, stamped: &Stamped) -> String {
    let unit = trace.header.as_ref().and_then(|h| h.world_unit.as_ref());
    match (&stamped.event, unit, trace.placements.get(stamped.row)) {
        (crate::Event::Target(t), Some(unit), Some(placement)) => {
            let v = placement.place(i64::from(*t));
            let text = format_number(v, 2);
            let text = text.trim_end_matches('0').trim_end_matches('.');
            format!("target={text} {unit}", unit = unit.name)
        }
        (crate::Event::MotorTarget { motor, target }, ..) => {
            let m = usize::from(*motor);
            let unit = trace.header.as_ref().and_then(|h| h.motor_world_units.get(m - 1));
            let placement = trace.motor_placements.get(m - 1).and_then(|p| p.get(stamped.row));
            match (unit, placement) {
                (Some(unit), Some(placement)) => {
                    let text = format_number(placement.place(i64::from(*target)), 2);
                    let text = text.trim_end_matches('0').trim_end_matches('.');
                    format!("target_m{m}={text} {unit}", unit = unit.name)
                }
                _ => stamped.event.to_string(),
            }
        }
        (event, ..) => event.to_string(),
    }
}

/// Draws the plot into `out` with plotters, and returns the curves as SVG elements to add at its end.
fn draw(out: &mut String, title: &str, trace: &Trace) -> Result<String, PlotError> {
    let samples = &Columns::of(trace, 0);
    let events: &[Event] =
        &trace.events.iter().map(|e| Event { micros: e.micros, text: event_text(trace, e) }).collect::<Vec<_>>();
    let levels: &[Levels] = &trace.levels;
    let last = samples.len().checked_sub(1).map_or(1, |r| samples.micros(r));
    let end = last.max(events.last().map_or(0, |e| e.micros)).max(1);
    let time = Scale::fixed(0.0, seconds(end), false, 12);
    let unit = trace.header.as_ref().and_then(|h| h.world_unit.as_ref()).map(|u| u.name.as_str());
    let motors = trace.motors();
    let mut candidates = if motors == 1 {
        vec![position_panel(samples, unit, None), velocity_panel(samples, None)]
    } else {
        // A position and a velocity panel per motor, motor by motor; the world's unit is motor 0's.
        let mut panels = Vec::new();
        let units = trace.header.as_ref().map_or(&[][..], |h| &h.motor_world_units[..]);
        for m in 0..motors {
            let columns = Columns::of(trace, m);
            let unit = if m == 0 { unit } else { units.get(usize::from(m) - 1).map(|u| u.name.as_str()) };
            panels.push(position_panel(&columns, unit, Some(m)));
            panels.push(velocity_panel(&columns, Some(m)));
        }
        panels
    };
    candidates.extend(drive_panels(samples, seconds(end)));
    let mut panels = Vec::new();
    let mut notes = Vec::new();
    for panel in candidates {
        match panel.note() {
            Some(note) => notes.push(note),
            None => panels.push(panel),
        }
    }
    let notes = wrap_notes(&notes);
    let lanes = lanes::Lanes::new(events, levels, seconds(end));
    let head = TITLE + notes.len() as u32 * NOTE + if notes.is_empty() { 0 } else { 6 };
    let height = head + panels.iter().map(|p| p.height).sum::<u32>() + lanes.height();
    let mut curves = String::new();
    {
        let root = SVGBackend::with_string(out, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let (top, mut rest) = root.split_vertically(head);
        let style = TextStyle::from((FONT, 24).into_font()).pos(Pos::new(HPos::Center, VPos::Center));
        top.draw(&Text::new(title.to_string(), (WIDTH as i32 / 2, TITLE as i32 / 2), style))?;
        let style = TextStyle::from((FONT, NOTE_FONT).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
        for (i, note) in notes.iter().enumerate() {
            let y = (TITLE + i as u32 * NOTE + NOTE / 2) as i32;
            top.draw(&Text::new(note.clone(), ((MARGIN_LEFT + Y_LABELS) as i32, y), style.clone()))?;
        }
        let lines = if events.len() <= MAX_EVENT_LINES { events } else { &[] };
        for (i, panel) in panels.iter().enumerate() {
            let (area, below) = rest.split_vertically(panel.height);
            let bottom = i + 1 == panels.len() && lanes.is_empty();
            curves.push_str(&draw_panel(&area, &time, panel, lines, bottom)?);
            rest = below;
        }
        lanes.draw(&rest, &time)?;
        root.present()?;
    }
    Ok(curves)
}

/// The notes of the panels left out, as lines that fit the plot's width: `Constant over the run (not
/// drawn): ...`, parts separated by `;`.
fn wrap_notes(notes: &[String]) -> Vec<String> {
    if notes.is_empty() {
        return Vec::new();
    }
    let width = f64::from(WIDTH - Y_LABELS - MARGIN_LEFT - MARGIN_RIGHT);
    let mut lines = vec!["Constant over the run (not drawn):".to_string()];
    for note in notes.iter().flat_map(|n| n.split(", ")) {
        let last = lines.last_mut().expect("one line at least");
        let candidate = format!("{last} {note};");
        if text_width(&candidate, f64::from(NOTE_FONT) / 1.24) <= width || last.ends_with(':') {
            *last = candidate;
        } else {
            lines.push(format!("    {note};"));
        }
    }
    if let Some(last) = lines.last_mut() {
        last.pop();
    }
    lines
}

/// What a per-axis panel's names begin with: `motor N ` on a model with several motors.
fn motor_label(motor: Option<u8>) -> String {
    motor.map_or(String::new(), |m| format!("motor {m} "))
}

/// Target and actual position; `motor`: which, on a model with several (then in the names and smaller).
fn position_panel(samples: &impl Samples, unit: Option<&str>, motor: Option<u8>) -> Panel {
    let label = motor_label(motor);
    let height = if motor.is_some() { 200 } else { 300 };
    match unit {
        Some(unit) => {
            let world = |f: fn((f64, f64)) -> f64| move |s: &Sample| s.world.map_or(0.0, f);
            let series = vec![
                Series {
                    points: thin(samples, world(|w| w.0)),
                    color: TARGET,
                    style: Style::Line(2),
                    name: format!("{label}target position (AP 0)"),
                },
                Series {
                    points: thin(samples, world(|w| w.1)),
                    color: ACTUAL,
                    style: Style::Line(1),
                    name: format!("{label}actual position (AP 1)"),
                },
            ];
            let mut panel = Panel::new(height, &format!("{label}position [{unit}]"), false, None, series);
            panel.decimals = panel.scale.decimals + 1;
            panel
        }
        None => {
            let series = vec![
                line(samples, |s| s.target, TARGET, 2, &format!("{label}target position (AP 0)")),
                line(samples, |s| s.actual, ACTUAL, 1, &format!("{label}actual position (AP 1)")),
            ];
            Panel::new(height, &format!("{label}position [µsteps]"), true, None, series)
        }
    }
}

fn velocity_panel(samples: &impl Samples, motor: Option<u8>) -> Panel {
    let label = motor_label(motor);
    // On a closed loop the velocity measured at the encoder is drawn thin over a wider ramp velocity, so
    // the ramp stays visible where the two agree.
    let measured = samples.len() > 0 && samples.at(0).measured.is_some();
    let width = if measured { 3 } else { 1 };
    let mut series = vec![line(samples, |s| s.velocity, SPEED, width, &format!("{label}actual velocity (AP 3)"))];
    if measured {
        let measured = |s: &Sample| s.measured.unwrap_or(0);
        series.push(line(samples, measured, MEASURED, 1, "measured velocity at the encoder (AP 131)"));
    }
    let height = if motor.is_some() { 150 } else { 220 };
    Panel::new(height, &format!("{label}velocity [pps]"), true, None, series)
}

/// The drive's panels, for the columns the trace has: load value, current scale or scaler, encoder −
/// steps or position error, energy.
fn drive_panels(samples: &impl Samples, end: f64) -> Vec<Panel> {
    let has = |f: fn(&Sample) -> bool| samples.len() > 0 && f(&samples.at(0));
    let mut panels = Vec::new();
    if has(|s| s.load.is_some()) {
        let load = line(
            samples,
            |s| s.load.unwrap_or(0),
            LOAD,
            1,
            "stallGuard2 load value (AP 206): 1023 unloaded, 0 at the torque limit",
        );
        panels.push(Panel::new(200, "load value (0–1023)", true, Some((-31.0, 1054.0)), vec![load]));
    }
    if has(|s| s.scaler.is_some()) {
        let scaler = line(
            samples,
            |s| s.scaler.unwrap_or(0),
            SCALE,
            2,
            "closed-loop current scaler (AP 123): the current is AP 6 × scaler / 255",
        );
        panels.push(Panel::new(200, "current scaler (/255)", true, Some((-8.0, 263.0)), vec![scaler]));
    } else if has(|s| s.current_scale.is_some()) {
        let scale = line(
            samples,
            |s| s.current_scale.unwrap_or(0),
            SCALE,
            2,
            "coolStep current scale (AP 180): the current is (n + 1)/32 of the set current",
        );
        panels.push(Panel::new(200, "current scale (0–31)", true, Some((-1.0, 32.0)), vec![scale]));
    }
    if has(|s| s.position_error.is_some()) {
        // In closed loop AP 1 is the encoder: the error that matters is the virtual position's lead.
        let error = |s: &Sample| s.position_error.map_or(0.0, f64::from);
        let error = difference(
            samples,
            end,
            error,
            "position error (AP 237): virtual position (AP 233) − actual position (AP 1)",
        );
        panels.push(Panel::new(230, "position error [µsteps]", true, None, vec![error]));
    } else if has(|s| s.encoder.is_some()) {
        let slip = |s: &Sample| s.encoder.map_or(0.0, |e| f64::from(e) - f64::from(s.actual));
        let slip = difference(samples, end, slip, "encoder position (AP 209) − step position (AP 1): lost steps");
        panels.push(Panel::new(230, "encoder − steps [µsteps]", true, None, vec![slip]));
    }
    if has(|s| s.energy.is_some()) {
        let energy = thin(samples, |s| s.energy.map_or(0.0, |e| e as f64 / 1e6));
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
    }
    panels
}

/// A line series of an integer quantity.
fn line(samples: &impl Samples, value: impl Fn(&Sample) -> i32, color: RGBColor, width: u32, name: &str) -> Series {
    Series { points: thin(samples, |s| f64::from(value(s))), color, style: Style::Line(width), name: name.into() }
}

/// Draws a panel's frame, grid, axes, event lines and key with plotters, and returns its curves as SVG
/// elements at sub-pixel coordinates.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    time: &Scale,
    panel: &Panel,
    lines: &[Event],
    bottom: bool,
) -> Result<String, PlotError>
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
    // Under the grid and the axes: an event at 0 s must not hide the value axis.
    event_lines(&mut chart, lines)?;
    let x_label = |v: &f64| time.label(*v);
    let y_label = |v: &f64| panel.scale.label(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_label_formatter(&x_label)
        .y_label_formatter(&y_label)
        .y_desc(panel.unit.as_str())
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .bold_line_style(BLACK.mix(0.1))
        .light_line_style(TRANSPARENT);
    if bottom {
        mesh.x_desc("time [s]");
    }
    mesh.draw()?;
    key(area, &chart, &panel.series)?;
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let frame = Frame { x: time.range.clone(), y: panel.scale.range.clone(), xs, ys };
    let mut svg = String::new();
    for s in &panel.series {
        match s.style {
            Style::Line(width) => svg.push_str(&frame.polyline(&s.points, s.color, f64::from(width), 1.0)),
            Style::Envelope => svg.push_str(&frame.envelope(&s.points, s.color)),
        }
    }
    Ok(svg)
}

/// A panel's plotting area in the SVG's pixels, and the values it shows: maps values to sub-pixel
/// coordinates as plotters maps them to whole pixels (x from the left edge to the last pixel column, y
/// from the bottom row up), without the rounding.
struct Frame {
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    xs: std::ops::Range<i32>,
    ys: std::ops::Range<i32>,
}

impl Frame {
    fn point(&self, (t, v): (f64, f64)) -> (f64, f64) {
        let fx = (t - self.x.start) / (self.x.end - self.x.start);
        let fy = (v - self.y.start) / (self.y.end - self.y.start);
        let (x0, x1) = (f64::from(self.xs.start), f64::from(self.xs.end - 1));
        let (y0, y1) = (f64::from(self.ys.end - 1), f64::from(self.ys.start));
        (x0 + fx * (x1 - x0), y0 + fy * (y1 - y0))
    }

    fn points(&self, points: impl Iterator<Item = (f64, f64)>) -> String {
        let mut text = String::new();
        for (i, p) in points.enumerate() {
            let (x, y) = self.point(p);
            let _ = write!(text, "{}{x:.2},{y:.2}", if i == 0 { "" } else { " " });
        }
        text
    }

    /// A line through `points`.
    fn polyline(&self, points: &[(f64, f64)], color: RGBColor, width: f64, opacity: f64) -> String {
        if points.is_empty() {
            return String::new();
        }
        let RGBColor(r, g, b) = color;
        format!(
            "<polyline fill=\"none\" stroke=\"#{r:02X}{g:02X}{b:02X}\" stroke-opacity=\"{opacity}\" \
             stroke-width=\"{width}\" stroke-linejoin=\"round\" points=\"{}\"/>\n",
            self.points(points.iter().copied())
        )
    }

    /// An envelope's points come in pairs per slot, (time, minimum) then (time, maximum): the band
    /// between the minima and the maxima, filled lightly and edged by thin lines.
    fn envelope(&self, points: &[(f64, f64)], color: RGBColor) -> String {
        let low: Vec<(f64, f64)> = points.iter().step_by(2).copied().collect();
        let high: Vec<(f64, f64)> = points.iter().skip(1).step_by(2).copied().collect();
        if low.is_empty() {
            return String::new();
        }
        let RGBColor(r, g, b) = color;
        let band = self.points(high.iter().chain(low.iter().rev()).copied());
        let mut svg = format!(
            "<polygon fill=\"#{r:02X}{g:02X}{b:02X}\" fill-opacity=\"0.3\" stroke=\"none\" points=\"{band}\"/>\n"
        );
        svg.push_str(&self.polyline(&low, color, 1.0, 0.7));
        svg.push_str(&self.polyline(&high, color, 1.0, 0.7));
        svg
    }
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

/// Vertical lines at the events, across the whole panel (drawn before the grid and the axes, which stay
/// on top).
fn event_lines<DB: DrawingBackend>(chart: &mut Chart<DB>, events: &[Event]) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (x, y) = (chart.x_range(), chart.y_range());
    // An event within two pixels of the value axis (one at 0 s) gets no line: it would paint over the
    // axis; its mark in the lanes stays.
    let near_axis = x.start + 2.0 * (x.end - x.start) / COLUMNS as f64;
    chart.draw_series(
        events
            .iter()
            .map(|e| seconds(e.micros))
            .filter(|&t| t > near_axis)
            .map(|t| PathElement::new(vec![(t, y.start), (t, y.end)], RED.mix(0.35).stroke_width(1))),
    )?;
    Ok(())
}

/// Microseconds as seconds.
fn seconds(micros: u64) -> f64 {
    micros as f64 / 1e6
}

/// `(seconds, value)` points of one series, at most two per pixel column: each column's minimum and
/// maximum, in time order (all samples if there are no more than that).
fn thin<S: Samples + ?Sized>(samples: &S, value: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    let n = samples.len();
    if n <= 2 * COLUMNS {
        return (0..n).map(|r| samples.at(r)).map(|s| (seconds(s.micros), value(&s))).collect();
    }
    let bucket = n.div_ceil(COLUMNS);
    let mut points = Vec::with_capacity(2 * COLUMNS + 2);
    for start in (0..n).step_by(bucket) {
        let mut lo: Option<(u64, f64)> = None;
        let mut hi: Option<(u64, f64)> = None;
        for s in (start..(start + bucket).min(n)).map(|r| samples.at(r)) {
            let v = value(&s);
            // The first of equal minima and the last of equal maxima, as `min_by`/`max_by` pick them.
            if lo.is_none_or(|(_, l)| v.total_cmp(&l).is_lt()) {
                lo = Some((s.micros, v));
            }
            if hi.is_none_or(|(_, h)| v.total_cmp(&h).is_ge()) {
                hi = Some((s.micros, v));
            }
        }
        if let (Some(lo), Some(hi)) = (lo, hi) {
            let (first, second) = if lo.0 <= hi.0 { (lo, hi) } else { (hi, lo) };
            points.push((seconds(first.0), first.1));
            points.push((seconds(second.0), second.1));
        }
    }
    points
}

/// A difference of two positions (encoder − steps, the position error) as a line, or as a band if it
/// [`jitters`]: then it is mostly the encoder's resolution, which a line would draw as a solid block of
/// zigzags.
fn difference<S: Samples + ?Sized>(samples: &S, end: f64, value: impl Fn(&Sample) -> f64, name: &str) -> Series {
    let values: Vec<f64> = (0..samples.len()).map(|r| value(&samples.at(r))).collect();
    if jitters(&values) || fills_columns(samples, end, &values) {
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

/// Whether a series fills its pixel columns: in more than half of the columns that hold samples, the
/// samples span at least half of the series' whole range. A sawtooth finer than a pixel (encoder − steps
/// sampled every millisecond for an hour: the encoder's counts alias with the step rate) has few turns
/// per sample but would still draw a solid block as a line.
fn fills_columns<S: Samples + ?Sized>(samples: &S, end: f64, values: &[f64]) -> bool {
    let (lo, hi) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    if hi <= lo {
        return false;
    }
    let mut columns: Vec<Option<(f64, f64)>> = vec![None; COLUMNS + 1];
    for (r, &v) in values.iter().enumerate() {
        let t = seconds(samples.micros(r));
        let c = (((t / end.max(1e-9)) * COLUMNS as f64) as usize).min(COLUMNS);
        let column = columns[c].get_or_insert((v, v));
        column.0 = column.0.min(v);
        column.1 = column.1.max(v);
    }
    let used = columns.iter().flatten().count();
    let full = columns.iter().flatten().filter(|(l, h)| h - l >= (hi - lo) / 2.0).count();
    full * 2 > used
}

/// The band around `value` over the time axis `0..end`: for each pixel column that has samples, the
/// minimum and the maximum over it and [`ENVELOPE_REACH`] columns either side, as pairs of points
/// `(time, minimum), (time, maximum)` at the column's first sample. The reach smooths the edges of a
/// band whose samples alias with the encoder's steps; a real jump widens the band by a few pixels.
fn envelope<S: Samples + ?Sized>(samples: &S, end: f64, value: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    let mut columns: Vec<Option<(f64, f64, f64)>> = vec![None; COLUMNS + 1];
    for s in (0..samples.len()).map(|r| samples.at(r)) {
        let t = seconds(s.micros);
        let c = (((t / end.max(1e-9)) * COLUMNS as f64) as usize).min(COLUMNS);
        let v = value(&s);
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
        Sample { micros, actual, ..Sample::default() }
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
        // A sawtooth finer than a pixel with few turns per sample (an hour at 1 ms): a band.
        let saw: Vec<Sample> = (0..200_000u64).map(|i| sample(i * 1000, -((i % 40) as i32) * 5 / 4)).collect();
        let band = difference(&saw, seconds(199_999_000), |s| f64::from(s.actual), "saw");
        assert!(matches!(band.style, Style::Envelope));
        // A hold that wobbles by a few µsteps under a peak of 9000: the wobble is not what the panel shows.
        let wobble: Vec<f64> =
            (0..300).map(|i| if (140..160).contains(&i) { 9000.0 } else { f64::from(i % 7) }).collect();
        assert!(!jitters(&wobble));
    }
}

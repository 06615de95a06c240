//! The plot's lanes, as on a logic analyser: a level line per reference switch, digital input and output
//! that changes during the run (`HOME`, `LEFT`, `RIGHT`, `IN0`, ..., `OUT0`, ...; a switch is high while
//! it is pressed), then a lane per kind of program event with a mark at each.
//!
//! An event `name=value` belongs to the lane `name` and its mark is labelled with the value (`target`
//! lane: `512000`); other events (`interrupt 0`, `stop`, `end`) are their own lane. Output events
//! (`out0=1`) are not repeated: the `OUT0` lane shows them. Labels that would touch each other or another
//! mark are left out ([`super::axis::spread`]).

use super::axis::{spread, text_width, Label, Scale};
use super::Event;
use super::{coordinate, seconds, FONT, MARGIN_LEFT, MARGIN_RIGHT, X_DESC, X_LABELS, Y_LABELS};
use crate::trace::{Levels, SWITCHES};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Event lanes at most; further kinds share the last lane ("other"), labelled with the whole event.
pub(crate) const MAX_EVENT_LANES: usize = 8;
/// The font size of the values at the marks.
const LABEL_FONT: u32 = 13;
/// Height of one lane in pixels.
const LANE: u32 = 28;
const SWITCH: RGBColor = RGBColor(150, 40, 160);
const INPUT: RGBColor = RGBColor(20, 130, 60);
const OUTPUT: RGBColor = RGBColor(30, 90, 200);
const PALETTE: [RGBColor; 8] = [
    RGBColor(200, 30, 30),
    RGBColor(30, 90, 200),
    RGBColor(230, 140, 30),
    RGBColor(20, 150, 70),
    RGBColor(170, 40, 170),
    RGBColor(0, 150, 160),
    RGBColor(0, 0, 0),
    RGBColor(120, 120, 120),
];

/// A digital signal: its name and its level from each time on (the first at the start).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Signal {
    pub name: String,
    pub color: RGBColor,
    pub edges: Vec<(f64, bool)>,
}

/// A kind of event: its name and a mark per event, with the label it gets if there is room.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Kind {
    pub name: String,
    pub marks: Vec<(f64, Option<String>)>,
}

/// The lanes of a run.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Lanes {
    pub signals: Vec<Signal>,
    pub kinds: Vec<Kind>,
    end: f64,
    events: usize,
}

impl Lanes {
    /// The lanes of `events` and `levels` (the inputs and outputs at the start and after each change) in a
    /// run of `end` seconds.
    pub fn new(events: &[Event], levels: &[Levels], end: f64) -> Lanes {
        let changed = |bits: fn(&Levels) -> u8| levels.windows(2).fold(0u8, |m, w| m | (bits(&w[0]) ^ bits(&w[1])));
        let mut signals = Vec::new();
        let switches = |l: &Levels| l.switches;
        for (prefix, color, bits) in [
            ("", SWITCH, switches as fn(&Levels) -> u8),
            ("IN", INPUT, |l: &Levels| l.inputs),
            ("OUT", OUTPUT, |l: &Levels| l.outputs),
        ] {
            let mask = changed(bits);
            let count = if prefix.is_empty() { SWITCHES.len() as u8 } else { 8 };
            for n in (0..count).filter(|n| mask >> n & 1 == 1) {
                let mut edges: Vec<(f64, bool)> = Vec::new();
                for l in levels {
                    let level = bits(l) >> n & 1 == 1;
                    if edges.last().is_none_or(|e| e.1 != level) {
                        edges.push((seconds(l.micros), level));
                    }
                }
                let name =
                    if prefix.is_empty() { SWITCHES[usize::from(n)].to_string() } else { format!("{prefix}{n}") };
                signals.push(Signal { name, color, edges });
            }
        }
        let shown_as_signal = |text: &str| {
            text.strip_prefix("out").and_then(|r| r.split_once('=')).is_some_and(|(n, _)| n.parse::<u8>().is_ok())
        };
        let mut kinds: Vec<Kind> = Vec::new();
        let mut count = 0;
        for e in events.iter().filter(|e| !shown_as_signal(&e.text)) {
            count += 1;
            let (name, value) = match e.text.split_once('=') {
                Some((name, value)) => (name, Some(value.to_string())),
                None => (e.text.as_str(), None),
            };
            let lane = match kinds.iter().position(|k| k.name == name) {
                Some(i) => i,
                None if kinds.len() < MAX_EVENT_LANES - 1 => {
                    kinds.push(Kind { name: name.to_string(), marks: Vec::new() });
                    kinds.len() - 1
                }
                None => {
                    if kinds.len() < MAX_EVENT_LANES {
                        kinds.push(Kind { name: "other".to_string(), marks: Vec::new() });
                    }
                    kinds.len() - 1
                }
            };
            let label = if kinds[lane].name == "other" { Some(e.text.clone()) } else { value };
            kinds[lane].marks.push((seconds(e.micros), label));
        }
        Lanes { signals, kinds, end, events: count }
    }

    /// Whether there is nothing to draw.
    pub fn is_empty(&self) -> bool {
        self.signals.is_empty() && self.kinds.is_empty()
    }

    /// Lanes in all.
    fn count(&self) -> usize {
        self.signals.len() + self.kinds.len()
    }

    /// The height of the lanes' panel (0 if none).
    pub fn height(&self) -> u32 {
        if self.is_empty() {
            0
        } else {
            self.count() as u32 * LANE + 10 + X_LABELS + X_DESC
        }
    }

    /// The lane names, top to bottom.
    fn names(&self) -> Vec<String> {
        self.signals.iter().map(|s| s.name.clone()).chain(self.kinds.iter().map(|k| k.name.clone())).collect()
    }

    /// Draws the lanes into `area` over the time axis `time`.
    pub fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>, time: &Scale) -> Result<(), super::PlotError>
    where
        DB::ErrorType: 'static,
    {
        if self.is_empty() {
            return Ok(());
        }
        let rows = self.count();
        // Lane i (from the top) is centred on y = rows − 1 − i; a tick at each lane names it.
        let y = |lane: usize| (rows - 1 - lane) as f64;
        let lanes = Scale { range: -0.5..rows as f64 - 0.5, ticks: (0..rows).map(|i| i as f64).collect(), decimals: 0 };
        let names = self.names();
        let mut chart = ChartBuilder::on(area)
            .margin_left(MARGIN_LEFT)
            .margin_right(MARGIN_RIGHT)
            .margin_top(10)
            .margin_bottom(4)
            .x_label_area_size(X_LABELS + X_DESC)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(coordinate(time), coordinate(&lanes))?;
        let x_label = |v: &f64| time.label(*v);
        let y_label = |v: &f64| {
            let lane = rows as f64 - 1.0 - v.round();
            names.get(lane as usize).cloned().unwrap_or_default()
        };
        let what = match self.events {
            0 => "time [s]".to_string(),
            1 => "time [s] — 1 program event".to_string(),
            n => format!("time [s] — {n} program events"),
        };
        chart
            .configure_mesh()
            .x_label_formatter(&x_label)
            .y_label_formatter(&y_label)
            .x_desc(what)
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .disable_y_mesh()
            .bold_line_style(BLACK.mix(0.1))
            .light_line_style(TRANSPARENT)
            .draw()?;
        for (i, s) in self.signals.iter().enumerate() {
            let (low, high) = (y(i) - 0.3, y(i) + 0.3);
            let level = |l: bool| if l { high } else { low };
            let mut wave: Vec<(f64, f64)> = Vec::new();
            for (k, &(t, l)) in s.edges.iter().enumerate() {
                if let Some(&(_, before)) = k.checked_sub(1).and_then(|k| s.edges.get(k)) {
                    wave.push((t, level(before)));
                }
                wave.push((t, level(l)));
            }
            if let Some(&(_, l)) = s.edges.last() {
                wave.push((self.end, level(l)));
            }
            let highs = s.edges.iter().enumerate().filter(|(_, e)| e.1).map(|(k, &(t, _))| {
                let until = s.edges.get(k + 1).map_or(self.end, |e| e.0);
                Rectangle::new([(t, low), (until, high)], s.color.mix(0.15).filled())
            });
            chart.draw_series(highs)?;
            chart.draw_series(LineSeries::new(wave, s.color.stroke_width(2)))?;
        }
        let (xs, _) = chart.plotting_area().get_pixel_range();
        let px_per_s = f64::from(xs.end - xs.start) / (time.range.end - time.range.start).max(1e-9);
        let style = TextStyle::from((FONT, LABEL_FONT).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
        for (k, kind) in self.kinds.iter().enumerate() {
            let lane = self.signals.len() + k;
            let color = PALETTE[k % PALETTE.len()];
            let (low, high) = (y(lane) - 0.35, y(lane) + 0.35);
            chart.draw_series(
                kind.marks.iter().map(|&(t, _)| PathElement::new(vec![(t, low), (t, high)], color.stroke_width(2))),
            )?;
            // Labels right of their marks, 3 px after them, where they touch nothing.
            let labels: Vec<Label> = kind
                .marks
                .iter()
                .map(|(t, text)| Label {
                    x: (t - time.range.start) * px_per_s,
                    width: text.as_deref().map_or(0.0, |text| 4.0 + text_width(text, f64::from(LABEL_FONT))),
                })
                .collect();
            let keep = spread(&labels, 3.0, f64::from(xs.end - xs.start));
            chart.draw_series(kind.marks.iter().zip(keep).filter_map(|((t, text), keep)| {
                let text = text.as_ref().filter(|_| keep)?;
                Some(Text::new(text.clone(), (t + 4.0 / px_per_s, y(lane)), style.clone()))
            }))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(micros: u64, text: &str) -> Event {
        Event { micros, text: text.into() }
    }

    #[test]
    fn events_are_grouped_by_kind_and_outputs_become_signals() {
        let events: Vec<Event> =
            [(0, "target=100"), (1000, "out0=1"), (2000, "target=-100"), (2000, "interrupt 0"), (3000, "stop")]
                .iter()
                .map(|&(t, e)| event(t, e))
                .collect();
        let levels = [
            Levels { micros: 0, inputs: 0b10, outputs: 0, switches: 0 },
            Levels { micros: 500, inputs: 0b00, outputs: 0, switches: 0 },
            Levels { micros: 1000, inputs: 0b00, outputs: 1, switches: 0 },
        ];
        let lanes = Lanes::new(&events, &levels, 0.004);
        assert_eq!(lanes.names(), ["IN1", "OUT0", "target", "interrupt 0", "stop"]);
        assert_eq!(lanes.signals[0].edges, [(0.0, true), (0.0005, false)]);
        assert_eq!(lanes.signals[1].edges, [(0.0, false), (0.001, true)]);
        assert_eq!(lanes.kinds[0].marks, [(0.0, Some("100".into())), (0.002, Some("-100".into()))]);
        assert_eq!(lanes.kinds[1].marks, [(0.002, None)]);
        assert_eq!(lanes.events, 4, "out0=1 is in the OUT0 lane");
    }

    #[test]
    fn a_signal_that_never_changes_gets_no_lane() {
        let levels = [
            Levels { micros: 0, inputs: 0b1, outputs: 0b1, switches: 0 },
            Levels { micros: 9, inputs: 0b1, outputs: 0b11, switches: 0 },
        ];
        let lanes = Lanes::new(&[], &levels, 1.0);
        assert_eq!(lanes.names(), ["OUT1"]);
        assert!(Lanes::new(&[], &levels[..1], 1.0).is_empty());
    }

    #[test]
    fn switches_that_change_get_lanes_first() {
        let levels = [
            Levels { micros: 0, inputs: 0, outputs: 0, switches: 0b100 },
            Levels { micros: 10, inputs: 0, outputs: 0, switches: 0b101 },
            Levels { micros: 20, inputs: 1, outputs: 0, switches: 0b100 },
        ];
        let lanes = Lanes::new(&[], &levels, 1.0);
        assert_eq!(lanes.names(), ["HOME", "IN0"], "RIGHT stays pressed: no lane");
        assert_eq!(lanes.signals[0].edges, [(0.0, false), (0.00001, true), (0.00002, false)]);
    }

    #[test]
    fn many_kinds_share_the_last_lane() {
        let many: Vec<Event> = (0..20).map(|n| event(n, &format!("interrupt {n}"))).collect();
        let lanes = Lanes::new(&many, &[], 1.0);
        assert_eq!(lanes.kinds.len(), MAX_EVENT_LANES);
        let other = lanes.kinds.last().unwrap();
        assert_eq!(other.name, "other");
        assert_eq!(other.marks.len(), 20 - (MAX_EVENT_LANES - 1));
        assert_eq!(other.marks[0].1.as_deref(), Some("interrupt 7"), "labelled with the whole event");
    }
}

//! Axis ticks and label layout for the plots: pure arithmetic, tested without drawing anything.
//!
//! - [`Scale`]: a value range with "nice" ticks (1, 2, 2.5 or 5 times a power of ten) and labels with just
//!   enough decimals to tell them apart. A flat series gets a range around its value; an integer-valued
//!   quantity (positions, speeds, parameter values) gets integer ticks; no label reads `-0`.
//! - [`spread`]: which text labels along a time line can be drawn without touching each other or another
//!   mark.
//! - [`text_width`]: how wide a label is drawn, estimated (the SVG has no font metrics).

use std::ops::Range;

/// A value axis: its range, the tick values inside it, and how many decimals their labels need.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Scale {
    /// The range the axis shows.
    pub range: Range<f64>,
    /// Tick values, ascending, all inside `range`.
    pub ticks: Vec<f64>,
    /// Decimals of the tick labels.
    pub decimals: usize,
}

/// Fewer ticks than this are never chosen (unless the range holds fewer integers).
pub(crate) const MIN_TICKS: usize = 5;

impl Scale {
    /// An axis for data from `lo` to `hi`, with a margin of 5 % on either side, and at most about
    /// `max_ticks` ticks (at least [`MIN_TICKS`]). A flat series (`lo == hi`) gets ±1 around its value if
    /// `integer`, else ±10 % of it (±1 around 0). With `integer` the ticks are integers. Values that are
    /// not finite are taken as 0.
    pub fn fit(lo: f64, hi: f64, integer: bool, max_ticks: usize) -> Scale {
        let (lo, hi) = finite_ordered(lo, hi);
        let (lo, hi) = if hi - lo <= lo.abs().max(hi.abs()) * 1e-9 {
            let v = (lo + hi) / 2.0;
            let half = if integer || v == 0.0 { 1.0 } else { v.abs() * 0.1 };
            (v - half, v + half)
        } else {
            (lo, hi)
        };
        let margin = (hi - lo) * 0.05;
        Scale::fixed(lo - margin, hi + margin, integer, max_ticks)
    }

    /// An axis showing exactly `lo..hi` (e.g. 0..1023 for a parameter with that range, or the run's
    /// time), with ticks inside it; `lo < hi`.
    pub fn fixed(lo: f64, hi: f64, integer: bool, max_ticks: usize) -> Scale {
        let (lo, hi) = finite_ordered(lo, hi);
        let hi = if hi > lo { hi } else { lo + 1.0 };
        let step = nice_step((hi - lo) / (max_ticks.max(MIN_TICKS) - 1) as f64, integer);
        // Tick k is k · step: multiplied, not summed, so that 0 is exactly 0 and errors do not add up.
        let first = (lo / step - 1e-9).ceil() as i64;
        let last = (hi / step + 1e-9).floor() as i64;
        let ticks = (first..=last).map(|k| k as f64 * step).collect();
        Scale { range: lo..hi, ticks, decimals: decimals(step) }
    }

    /// The label of tick value `v`.
    pub fn label(&self, v: f64) -> String {
        format_number(v, self.decimals)
    }
}

/// `(lo, hi)` with non-finite values as 0, in order.
fn finite_ordered(lo: f64, hi: f64) -> (f64, f64) {
    let f = |v: f64| if v.is_finite() { v } else { 0.0 };
    let (lo, hi) = (f(lo), f(hi));
    (lo.min(hi), lo.max(hi))
}

/// The smallest of 1, 2, 2.5 and 5 times a power of ten that is at least `raw`; with `integer`, the
/// smallest such integer, at least 1 (2.5 is skipped where it is not one).
pub(crate) fn nice_step(raw: f64, integer: bool) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    if integer && raw <= 1.0 {
        return 1.0;
    }
    let exponent = raw.log10().floor() as i32;
    for e in exponent..=exponent + 1 {
        for m in [1.0, 2.0, 2.5, 5.0] {
            let step = m * 10f64.powi(e);
            if step >= raw * (1.0 - 1e-9) && (!integer || step.fract() == 0.0) {
                return step;
            }
        }
    }
    10f64.powi(exponent + 2)
}

/// The decimals that tell multiples of `step` apart: 0 for whole steps, 1 for 0.5 or 2.5, 2 for 0.25...
fn decimals(step: f64) -> usize {
    (0..=12)
        .find(|&d| {
            let scaled = step * 10f64.powi(d as i32);
            (scaled - scaled.round()).abs() < 1e-6 * scaled.max(1.0)
        })
        .unwrap_or(12)
}

/// `v` with `decimals` decimals; a value that rounds to zero reads `0` (`0.0`, ...), never `-0`.
pub(crate) fn format_number(v: f64, decimals: usize) -> String {
    let text = format!("{v:.decimals$}");
    match text.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => text,
    }
}

/// The drawn width of `text` at font size `size` (px), estimated generously: 0.6 em per character, about
/// the widest average of the usual sans-serif fonts.
pub(crate) fn text_width(text: &str, size: f64) -> f64 {
    text.chars().count() as f64 * size * 0.6
}

/// A text label to the right of a mark on a line: the mark at `x`, the text from `x` to `x + width`
/// (pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Label {
    /// Where the mark is, and the text starts.
    pub x: f64,
    /// The text's width.
    pub width: f64,
}

/// Which labels to draw, `labels` in ascending `x`: a label is drawn if it keeps `gap` pixels from the
/// label drawn before it, and its text ends `gap` pixels before the next mark (drawn or not) and before
/// `limit` (the plot's right edge), so that no text touches another text or a mark, or leaves the plot.
/// Of several marks at one place the last keeps its label. The first label is always drawn unless the
/// next mark or the edge is too close.
pub(crate) fn spread(labels: &[Label], gap: f64, limit: f64) -> Vec<bool> {
    let mut keep = vec![false; labels.len()];
    let mut free_from = f64::NEG_INFINITY;
    for (i, label) in labels.iter().enumerate() {
        let end = label.x + label.width;
        let next_mark = labels.get(i + 1).map_or(limit, |l| l.x.min(limit));
        if label.x >= free_from && end + gap <= next_mark {
            keep[i] = true;
            free_from = end + gap;
        }
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(scale: &Scale) -> Vec<String> {
        scale.ticks.iter().map(|&t| scale.label(t)).collect()
    }

    /// Distinct labels, no `-0`, every tick inside the range, at least two ticks.
    fn check(scale: &Scale) {
        let l = labels(scale);
        let mut unique = l.clone();
        unique.dedup();
        assert_eq!(unique, l, "distinct labels: {scale:?}");
        assert!(l.len() >= 2, "at least two ticks: {scale:?}");
        let negative_zero = |t: &String| t.strip_prefix('-').is_some_and(|r| r.chars().all(|c| c == '0' || c == '.'));
        assert!(!l.iter().any(negative_zero), "no -0: {l:?}");
        assert!(scale.ticks.iter().all(|t| scale.range.contains(t) || *t == scale.range.end), "{scale:?}");
        assert!(scale.ticks.windows(2).all(|w| w[0] < w[1]), "{scale:?}");
    }

    #[test]
    fn a_flat_integer_series_gets_integer_ticks_around_it() {
        // The case: a position standing at 0 was labelled 1,1,1,0,0,0,-0,-0.
        let s = Scale::fit(0.0, 0.0, true, 10);
        check(&s);
        assert_eq!(labels(&s), ["-1", "0", "1"]);
        let s = Scale::fit(512_000.0, 512_000.0, true, 10);
        check(&s);
        assert_eq!(labels(&s), ["511999", "512000", "512001"]);
        let s = Scale::fit(-7.0, -7.0, true, 6);
        assert_eq!(labels(&s), ["-8", "-7", "-6"]);
    }

    #[test]
    fn a_flat_real_series_gets_a_range_of_ten_percent() {
        let s = Scale::fit(0.25, 0.25, false, 8);
        check(&s);
        assert!(s.range.start < 0.25 && s.range.end > 0.25);
        assert!(s.ticks.len() >= 3, "{s:?}");
        assert_eq!(labels(&s), ["0.23", "0.24", "0.25", "0.26", "0.27"]);
        let s = Scale::fit(0.0, 0.0, false, 8);
        check(&s);
        assert!(labels(&s).contains(&"0.0".to_string()), "{:?}", labels(&s));
    }

    #[test]
    fn a_tiny_range_gets_enough_decimals() {
        let s = Scale::fit(1.0001, 1.0002, false, 6);
        check(&s);
        assert!(s.decimals >= 5, "{s:?}");
        assert!(labels(&s).iter().all(|l| l.starts_with("1.000")), "{:?}", labels(&s));
        // An integer axis over a range of 1: the two integers, never 0.2 steps.
        let s = Scale::fit(0.0, 1.0, true, 10);
        check(&s);
        assert_eq!(labels(&s), ["0", "1"]);
    }

    #[test]
    fn negative_ranges_and_zero() {
        let s = Scale::fit(-51_200.0, 0.0, true, 8);
        check(&s);
        assert_eq!(labels(&s), ["-50000", "-40000", "-30000", "-20000", "-10000", "0"]);
        // Around zero with a step that is not exact in binary: 0 prints as 0.0 (never -0.0).
        let s = Scale::fit(-0.3, 0.3, false, 13);
        check(&s);
        assert_eq!(labels(&s), ["-0.3", "-0.2", "-0.1", "0.0", "0.1", "0.2", "0.3"]);
        assert_eq!(format_number(-0.000_01, 2), "0.00");
        assert_eq!(format_number(-0.0, 0), "0");
        assert_eq!(format_number(-1.5, 1), "-1.5");
    }

    #[test]
    fn integer_axes_take_integer_steps() {
        for (lo, hi) in [(0.0, 3.0), (-2.0, 2.0), (0.0, 12.0), (0.0, 31.0), (100.0, 103.0), (0.0, 1023.0)] {
            let s = Scale::fit(lo, hi, true, 10);
            check(&s);
            assert!(s.ticks.iter().all(|t| t.fract() == 0.0), "{s:?}");
            assert_eq!(s.decimals, 0);
        }
        assert_eq!(nice_step(2.2, true), 5.0, "2.5 is not an integer");
        assert_eq!(nice_step(22.0, true), 25.0);
        assert_eq!(nice_step(0.3, true), 1.0);
        assert_eq!(nice_step(0.3, false), 0.5);
        assert_eq!(nice_step(0.22, false), 0.25);
    }

    #[test]
    fn a_fixed_range_keeps_its_ends() {
        let s = Scale::fixed(0.0, 6.0, false, 12);
        assert_eq!(s.range, 0.0..6.0);
        assert_eq!(labels(&s), ["0", "1", "2", "3", "4", "5", "6"]);
        let s = Scale::fixed(0.0, 5.0, false, 12);
        assert_eq!(labels(&s), ["0.0", "0.5", "1.0", "1.5", "2.0", "2.5", "3.0", "3.5", "4.0", "4.5", "5.0"]);
        let s = Scale::fixed(0.0, 120.0, false, 12);
        assert_eq!(s.ticks.last(), Some(&120.0), "the last tick at the end");
        let s = Scale::fixed(0.0, 1023.0, true, 8);
        assert_eq!(labels(&s), ["0", "200", "400", "600", "800", "1000"]);
    }

    #[test]
    fn labels_do_not_overlap_each_other_or_marks() {
        let l = |x: f64, width: f64| Label { x, width };
        // Three labels 40 px wide at 0, 10 and 100: the first would cover the mark at 10, the second fits.
        let labels = [l(0.0, 40.0), l(10.0, 40.0), l(100.0, 40.0)];
        assert_eq!(spread(&labels, 4.0, 1000.0), [false, true, true]);
        // Marks at one place: the last one's label.
        assert_eq!(spread(&[l(5.0, 20.0), l(5.0, 20.0)], 4.0, 1000.0), [false, true]);
        // A label that would leave the plot on the right.
        assert_eq!(spread(&labels, 4.0, 120.0), [false, true, false]);
        // A dense run of marks: the drawn labels never touch each other or any mark.
        let dense: Vec<Label> = (0..200).map(|i| l(f64::from(i) * 7.0 + f64::from(i % 3), 30.0)).collect();
        let keep = spread(&dense, 3.0, f64::INFINITY);
        let drawn: Vec<&Label> = dense.iter().zip(&keep).filter(|(_, k)| **k).map(|(l, _)| l).collect();
        assert!(!drawn.is_empty());
        for d in &drawn {
            let end = d.x + d.width;
            assert!(dense.iter().all(|m| m.x <= d.x || m.x >= end + 3.0), "a mark under the label at {}", d.x);
        }
        assert!(drawn.windows(2).all(|w| w[0].x + w[0].width + 3.0 <= w[1].x));
        // Sparse ones are all drawn.
        let sparse: Vec<Label> = (0..10).map(|i| l(f64::from(i) * 100.0, 60.0)).collect();
        assert!(spread(&sparse, 4.0, 1000.0).iter().all(|k| *k));
    }
}

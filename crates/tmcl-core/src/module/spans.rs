//! Spans of motion ticks in the module: when the ticks from now on may be taken in closed form, how far
//! ([`Bounds`]), and what the module does after a span — exactly what it does after a tick, once, at the
//! span's last tick (see `advance.rs`).
//!
//! A one-motor model takes its spans as below (motor 0); a model with several motors (TMCM-3110,
//! TMCM-6110) takes a run of ticks for all at once, each moving motor's span within its own bounds and as
//! long as the shortest, while every standing motor's board stays quiet and no motor's current changes
//! by itself ([`Module::several_spans`]).
//!
//! A span needs every tick in it to be *silent*: nothing but the ramp may happen at those ticks. So the
//! module takes none:
//! - ticking one by one was asked for ([`Module::set_exact_ticks`]);
//! - in a reference search (it samples its switch after every microstep) while the speed changes (a
//!   tick in parts accelerates otherwise than a whole one) or on a closed-loop model; cruising, a search
//!   takes spans within the board's window, where every look at the switch decides as the first did;
//! - while a closed loop is closed or initialising (it measures the encoder and corrects at every tick); in open loop a closed-loop
//!   model measures the velocity AP 131 over the last ticks, so its spans end that many ticks and one
//!   before the event, and those ticks are ticked (`take_span`);
//! - while coolStep regulates (every load measurement changes the current), while the encoder deviation
//!   check (AP 212) is armed, or while an SSI encoder's clear-on-null counts turns from tick to tick;
//! - while stop on stall (AP 181) is armed and the board's load measurements read 0;
//! - when the board cannot say how long its readings stay as they are
//!   ([`crate::hal::StepDriver::quiet`] gives `None`).
//!
//! Otherwise a span ends before the next program instruction or end of a WAIT, the next timer, the
//! heartbeat, the end of the board's window (in time, travel or speed), a change of the slow-run current
//! (AP 182), and any tick the ramp makes an event of ([`crate::motion::Ramp::span`]).

use super::Module;
use crate::drive::closed_loop::{Init, VELOCITY_WINDOW};
use crate::drive::encoder;
use crate::hal::prelude::*;
use crate::hal::Board;
use crate::model::Setting;
use crate::motion::{Bounds, Limits, Ramp, RampParams, Span, TICK};
use crate::time::{Duration, Instant};
use tmcl_model::capacity::MAX_MOTORS;

/// The longest span, in ticks (about 50 days): keeps every sum of a span far inside 64 bits.
const MAX_SPAN: u64 = 1 << 32;

/// How many of the spans computed last the module remembers: the deadline's look-ahead computes the span
/// the next poll takes.
#[cfg(feature = "span-memo")]
const RECENT: usize = 2;
/// How many costly spans (braking) it remembers besides: a program that repeats its moves repeats them.
#[cfg(feature = "span-memo")]
const COSTLY: usize = 4;
/// A span is costly from this many ticks computed one by one.
#[cfg(feature = "span-memo")]
const COSTLY_WORK: u64 = 64;
/// How many ticks a deadline's look-ahead computes one by one at most.
pub(super) const LOOKAHEAD_WORK: u64 = 64;

/// A moving motor's part in a run of ticks several motors take together ([`Module::several_spans`]): its
/// span up to its last step, and its ramp at the run's end (the same, or the ticks after that step, which
/// move none, taken too).
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    at_last: Ramp,
    last: Span,
    at_end: Ramp,
}

/// Every motor's run (`None`: the motor stands).
type Runs = [Option<Run>; MAX_MOTORS as usize];

/// A span the module computed: [`crate::motion::Ramp::span`] is a function of the ramp's state, its
/// parameters, the limits and the bounds alone, so the same inputs give the same span.
#[cfg(feature = "span-memo")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Memo {
    from: Ramp,
    params: RampParams,
    limits: Limits,
    /// The bounds it was computed with.
    bounds: Bounds,
    to: Ramp,
    span: Span,
    /// The steps up to its last ticks, if it was computed for a closed loop (`loop_span.rs`).
    last: LastTicks,
}

/// The steps of a span up to each of its last ticks, for a closed loop's velocity window
/// (`loop_span.rs`): for the last `min(n, VELOCITY_WINDOW + 1)` ticks of a span of `n`, the steps up to
/// the tick before the first of them, and then up to each, relative to that.
pub(super) type LastTicks = Option<(i64, [i32; VELOCITY_WINDOW + 2])>;

#[cfg(feature = "span-memo")]
impl Memo {
    /// The span from `from` within `bounds`, if this is it: computed with the same inputs but a tick
    /// count, which gives the same span for any count from its length up to its own count, and for any
    /// longer count too if it ended before its count (at an event).
    fn answers(&self, from: &Ramp, params: &RampParams, limits: Limits, bounds: &Bounds) -> bool {
        self.from == *from
            && self.params == *params
            && self.limits == limits
            && Bounds { ticks: bounds.ticks, work: bounds.work, ..self.bounds } == *bounds
            && self.span.ticks <= bounds.ticks
            && (!self.span.capped || (bounds.ticks <= self.bounds.ticks && bounds.work <= self.bounds.work))
    }
}

/// The spans the module remembers (about 1 KiB; with the `span-memo` feature, on by default).
#[cfg(feature = "span-memo")]
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Memos {
    recent: [Option<Memo>; RECENT],
    costly: [Option<Memo>; COSTLY],
    next_recent: usize,
    next_costly: usize,
}

#[cfg(feature = "span-memo")]
impl Memos {
    pub(super) fn find(
        &self,
        from: &Ramp,
        params: &RampParams,
        limits: Limits,
        bounds: &Bounds,
    ) -> Option<(Ramp, Span, LastTicks)> {
        self.recent
            .iter()
            .chain(&self.costly)
            .flatten()
            .find(|m| m.answers(from, params, limits, bounds))
            .map(|m| (m.to, m.span, m.last))
    }

    /// Remembers the span `to`, `span` computed from `from` with these inputs.
    #[allow(clippy::too_many_arguments)] // (a memo's fields)
    pub(super) fn remember(
        &mut self,
        from: Ramp,
        params: &RampParams,
        limits: Limits,
        bounds: &Bounds,
        to: Ramp,
        span: Span,
        last: LastTicks,
    ) {
        if span.ticks > 0 {
            self.keep(Memo { from, params: *params, limits, bounds: *bounds, to, span, last });
        }
    }

    fn keep(&mut self, memo: Memo) {
        if memo.span.work >= COSTLY_WORK {
            self.costly[self.next_costly] = Some(memo);
            self.next_costly = (self.next_costly + 1) % COSTLY;
        } else {
            self.recent[self.next_recent] = Some(memo);
            self.next_recent = (self.next_recent + 1) % RECENT;
        }
    }
}

/// Without the `span-memo` feature: nothing is remembered, every span is computed.
#[cfg(not(feature = "span-memo"))]
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Memos;

#[cfg(not(feature = "span-memo"))]
impl Memos {
    pub(super) fn find(&self, _: &Ramp, _: &RampParams, _: Limits, _: &Bounds) -> Option<(Ramp, Span, LastTicks)> {
        None
    }

    #[allow(clippy::too_many_arguments)] // (a memo's fields)
    pub(super) fn remember(&mut self, _: Ramp, _: &RampParams, _: Limits, _: &Bounds, _: Ramp, _: Span, _: LastTicks) {}
}

impl<B: Board> Module<B> {
    /// Takes the motion ticks after `motion_time`, up to `now` at most, as one span if they are silent
    /// (see the module docs); then does what follows a tick, at the span's last tick. Returns whether it
    /// took any tick.
    pub(super) fn take_span(&mut self, now: Instant, params: &RampParams) -> bool {
        if !cfg!(feature = "spans") {
            return false; // (the rest is left out of the build)
        }
        #[cfg(feature = "loop-periods")]
        if self.st.axes[0].cl.active {
            // The rotor on the field: in closed form (`loop_span.rs`); else the loop's periods if it
            // cruises (`periods.rs`).
            return self.take_locked(now, params) || self.take_periods(now, params);
        }
        let Some((limits, bounds)) = self.span_bounds(Some(now)) else { return false };
        let (mut to, mut span) = self.span(params, limits, &bounds);
        if self.spec.axis.has(Setting::ClosedLoop) {
            // Open loop, a closed-loop model measures AP 131 from its encoder over the last
            // VELOCITY_WINDOW ticks, each tick the rotor's move since the one before: the span leaves
            // that many ticks and one more before its end to ticking (the first of them measures the
            // whole span's move, in a slot the others overwrite), so that the window is what ticking
            // fills it with, whenever it is read.
            let keep = VELOCITY_WINDOW as u64 + 1;
            if span.ticks <= keep {
                return false;
            }
            (to, span) = self.span(params, limits, &Bounds { ticks: span.ticks - keep, ..bounds });
            self.st.axes[0].cl.skip_ticks(span.ticks);
        }
        if span.ticks == 0 {
            return false;
        }
        self.st.axes[0].ramp = to;
        let t = self.st.motion_time + Duration::from_micros(span.ticks * TICK.micros());
        // Every tick of the span moved (|AP 3| ≥ 1) with the speed changing as before the span, so the
        // standstill time and `ramping` are as they were; the board hears of the span's steps at its
        // last tick, which is the span's last step (or the span made none).
        self.st.axes[0].unreported_steps += span.steps;
        self.after_span(t);
        true
    }

    /// What follows a run of motor 0's ticks taken at once (a span, or a closed loop's periods) ending at
    /// `t`: the board hears of the run at its last tick, and the module does once what follows a tick.
    pub(super) fn after_span(&mut self, t: Instant) {
        self.motor_at(0).update_board(t);
        self.st.motion_time = t;
        self.tick_done(t);
        self.waiting_program_slept_to(t);
    }

    /// [`Module::take_span`] for a model of several motors (TMCM-3110, TMCM-6110): the ticks after
    /// `motion_time`, up to `now` at most, taken at once by every motor (see [`Module::several_spans`]),
    /// then what follows a tick, once, at the last. Returns whether it took any tick.
    pub(super) fn take_spans(&mut self, now: Instant, params: &[RampParams]) -> bool {
        if !cfg!(feature = "spans") {
            return false;
        }
        let Some((ticks, runs)) = self.several_spans(Some(now), params, u64::MAX) else { return false };
        let start = self.st.motion_time;
        let at = |ticks: u64| start + Duration::from_micros(ticks * TICK.micros());
        // Each motor's board hears of its steps at its last step, in the order of time (a board may bring
        // the others' clocks on with its own), then of the ticks after it, which move none, at the end.
        let mut order: [usize; MAX_MOTORS as usize] = core::array::from_fn(|m| m);
        let motors = params.len();
        order[..motors].sort_unstable_by_key(|&m| (runs[m].map_or(u64::MAX, |r| r.last.ticks), m));
        for &m in &order[..motors] {
            if let Some(run) = runs[m] {
                // As in `take_span`: every tick moved or the speed changed as before the span.
                self.st.axes[m].ramp = run.at_last;
                self.st.axes[m].unreported_steps += run.last.steps;
                self.motor_at(m).update_board(at(run.last.ticks));
            }
        }
        let t = at(ticks);
        for (m, run) in runs.iter().enumerate().take(motors) {
            if let Some(run) = run {
                if run.last.ticks < ticks {
                    self.st.axes[m].ramp = run.at_end;
                    self.motor_at(m).update_board(t);
                }
            }
        }
        self.st.motion_time = t;
        self.tick_done(t);
        self.waiting_program_slept_to(t);
        true
    }

    /// The ticks after `motion_time` that every motor of a model with several can take at once, and each
    /// moving motor's run over them (`None`: standing), if there are any (`horizon`: no tick after it;
    /// `work`: [`Bounds::work`]). Each moving motor's span within its own bounds (as one motor's, see the
    /// module docs); the motors tick together, so the run is as long as the shortest. A motor's span ends
    /// on its last step: where it reached the run's tick count all the same (no event before it), the ticks
    /// after that step, which move none, are taken as a second span (`Run`); where an event ended it, the
    /// run ends there and every motor is looked at again. A standing motor's tick only reads its board (its
    /// switches, the driver's flags, the load): the run ends before its board's quiet window does, and
    /// one that has just stopped (its next tick starts its standstill or ends its speed change),
    /// searches for its reference or regulates its current with coolStep takes no span. Nor does any
    /// motor's next change of current by itself (a standby or freewheeling delay running out: the board
    /// hears of it at its instant).
    pub(super) fn several_spans(
        &mut self,
        horizon: Option<Instant>,
        params: &[RampParams],
        work: u64,
    ) -> Option<(u64, Runs)> {
        if self.spec.axis.has(Setting::ClosedLoop) || self.exact {
            return None;
        }
        let mut ticks = self.standing_bound(horizon)?;
        let mut bounds_of = [None; MAX_MOTORS as usize];
        for (m, slot) in bounds_of.iter_mut().enumerate().take(params.len()) {
            if !self.st.axes[m].is_standing() {
                let (limits, bounds, _) = self.bounds_of(m, horizon, false)?;
                ticks = ticks.min(bounds.ticks);
                *slot = Some((limits, bounds));
            }
        }
        // Each pass either finds every motor's run as long as `ticks`, or shortens it to where a motor's
        // event (or its last step before one) is — at once, so that the motors after it in the pass are
        // computed no further — and the next pass looks at the ones before again; a motor's event shortens
        // it once, so a few passes do.
        for _ in 0..=2 * params.len() {
            let mut runs: Runs = [None; MAX_MOTORS as usize];
            let mut shortened = false;
            for (m, params) in params.iter().enumerate() {
                let Some((limits, bounds)) = bounds_of[m] else { continue };
                let bounds = Bounds { ticks, work, ..bounds };
                let (at_last, last) = self.span_of(m, params, limits, &bounds);
                // (It stopped at the tick count, not at an event or for want of work.)
                let reached = last.capped && last.work < work;
                let at_end = if last.ticks == ticks {
                    Some(at_last)
                } else if reached {
                    // The ticks after its last step move none: they are taken from there.
                    let mut at = at_last;
                    let rest = at.span(params, limits, &Bounds { ticks: ticks - last.ticks, ..bounds });
                    (rest.ticks == ticks - last.ticks && rest.steps == 0).then_some(at)
                } else {
                    None
                };
                match at_end {
                    Some(at_end) => runs[m] = Some(Run { at_last, last, at_end }),
                    None if last.ticks == 0 => return None,
                    None => {
                        ticks = last.ticks;
                        shortened = true;
                    }
                }
            }
            if !shortened {
                return Some((ticks, runs));
            }
        }
        None
    }

    /// How many ticks from `motion_time` on the standing motors of a model with several let a run of
    /// ticks go, and no motor's current changes by itself (see [`Module::several_spans`]); `None`: none.
    fn standing_bound(&mut self, horizon: Option<Instant>) -> Option<u64> {
        let start = self.st.motion_time;
        let mut last = [horizon, self.drive_due().map(|(_, d)| d)].into_iter().flatten().min();
        for m in 0..self.st.axes.count() {
            if !self.st.axes[m].is_standing() {
                continue;
            }
            let axis = &self.st.axes[m];
            if axis.standstill_since.is_none() || axis.ramping || axis.reference.is_active() {
                // Just stopped: its next tick starts the standstill, or ends the speed change (the boost
                // current, AP 200, gives way), which the board hears of.
                return None;
            }
            if self.ap(m, Setting::CoolStepHysteresisStart).unwrap_or(0) != 0 {
                return None;
            }
            // Asked as it is, not brought to `start` first: a look for the deadline must leave every board
            // as it was, and a standing motor's board hears from the module only at its ticks (the first
            // thing the next one does). The window runs from where the board is: an event before `start`
            // makes the run empty, and the module ticks.
            let state = self.st.axes[m].last_drive.unwrap_or_default();
            let quiet = self.board.quiet(m, start, &state)?;
            if let Some(u) = quiet.until {
                let u = u - Duration::from_micros(1);
                last = Some(last.map_or(u, |l| l.min(u)));
            }
        }
        let ticks = match last {
            Some(t) => (t.saturating_duration_since(start).micros() / TICK.micros()).min(MAX_SPAN),
            None => MAX_SPAN,
        };
        (ticks > 0).then_some(ticks)
    }

    /// [`Module::span_ahead`] for a model of several motors.
    pub(super) fn spans_ahead(&mut self) -> u64 {
        if !cfg!(feature = "spans") {
            return 0;
        }
        let mut params = [RampParams { max_speed: 0, max_accel: 0, min_speed: 0 }; MAX_MOTORS as usize];
        let motors = self.st.axes.count();
        for (m, p) in params.iter_mut().enumerate().take(motors) {
            *p = self.ramp_params(m);
        }
        self.several_spans(None, &params[..motors], LOOKAHEAD_WORK).map_or(0, |(ticks, _)| ticks)
    }

    /// How many ticks from `motion_time` on a span would take now, without taking them (0: the next
    /// tick is an event, or no span may be taken): for the deadline.
    pub(super) fn span_ahead(&mut self) -> u64 {
        if !cfg!(feature = "spans") {
            return 0;
        }
        #[cfg(feature = "loop-periods")]
        if self.st.axes[0].cl.active {
            // A run of the locked loop, or whole periods, ending on a period's boundary (the deadline is
            // the tick after this many).
            let params = self.ramp_params(0);
            return self.locked_ahead(&params).max(self.periods_ahead(&params).saturating_sub(1));
        }
        let Some((limits, bounds)) = self.span_bounds(None) else { return 0 };
        // Braking computed only so far: a deadline before the event is only an extra poll, and a run polled
        // often (a trace) must not compute the rest of a braking phase at every poll.
        let bounds = Bounds { work: LOOKAHEAD_WORK, ..bounds };
        self.span(&self.ramp_params(0), limits, &bounds).1.ticks
    }

    /// The span from the ramp's state within `bounds`: remembered, or computed (and remembered).
    pub(super) fn span(&mut self, params: &RampParams, limits: Limits, bounds: &Bounds) -> (Ramp, Span) {
        self.span_of(0, params, limits, bounds)
    }

    /// [`Module::span`] of motor `m`'s ramp (a span is a function of a ramp's state, parameters, limits and
    /// bounds alone, so the motors share what is remembered).
    fn span_of(&mut self, m: usize, params: &RampParams, limits: Limits, bounds: &Bounds) -> (Ramp, Span) {
        let from = self.st.axes[m].ramp;
        if let Some((to, span, _)) = self.memos.find(&from, params, limits, bounds) {
            return (to, span);
        }
        let mut to = from;
        let span = to.span(params, limits, bounds);
        self.memos.remember(from, params, limits, bounds, to, span, None);
        (to, span)
    }

    /// Whether the ticks after `motion_time` may be taken as a span, and within which bounds; `horizon`:
    /// no tick after it (see the module docs).
    fn span_bounds(&mut self, horizon: Option<Instant>) -> Option<(Limits, Bounds)> {
        if self.st.axes[0].cl.engaged() {
            return None;
        }
        self.bounds(horizon, false).map(|(limits, bounds, _)| (limits, bounds))
    }

    #[cfg(feature = "loop-periods")]
    /// [`Module::span_bounds`] for a loop that is closed (`module/periods.rs`), with the board's period
    /// ([`crate::hal::StepDriver::period`]; `None` without one).
    pub(super) fn span_bounds_periodic(&mut self, horizon: Option<Instant>) -> Option<(Limits, Bounds, u64)> {
        let cl = &self.st.axes[0].cl;
        if !cl.active || cl.init != Init::Done {
            return None;
        }
        self.bounds(horizon, true).filter(|(_, _, period)| *period > 0)
    }

    /// The bounds of both, and the board's period if `periodic` (else 0).
    fn bounds(&mut self, horizon: Option<Instant>, periodic: bool) -> Option<(Limits, Bounds, u64)> {
        self.bounds_of(0, horizon, periodic)
    }

    /// [`Module::bounds`] of motor `m`'s span.
    fn bounds_of(&mut self, m: usize, horizon: Option<Instant>, periodic: bool) -> Option<(Limits, Bounds, u64)> {
        let searching = self.st.axes[m].reference.is_active();
        if self.exact
            || (searching && (self.spec.axis.has(Setting::ClosedLoop) || self.st.axes[m].ramping))
            || self.st.axes[m].standstill_since.is_some()
            || self.st.axes[m].ramp.velocity() == 0
        {
            return None;
        }
        if self.ap(m, Setting::CoolStepHysteresisStart).unwrap_or(0) != 0
            || self.ap(m, Setting::MaxEncoderDeviation).unwrap_or(0) > 0
        {
            return None; // coolStep regulates; the deviation check is armed (open loop: no closed loop here)
        }
        let prescaler =
            self.spec.axis.role(crate::model::Role::EncoderPrescaler).map_or(512, |i| self.st.axes[m].params[i]);
        if encoder::clear_on_null_enabled(prescaler) && self.motor_at(m).ssi_selected() {
            return None;
        }
        if self.spec.axis.has(Setting::ClosedLoop) && !self.st.axes[m].cl.active {
            // Open loop: the loop about to close (AP 129 and a done initialisation: it closes at the next
            // tick), or an SSI encoder, whose turns the firmware counts from reading to reading.
            let closing = self.ap(m, Setting::ClosedLoop) == Some(1) && self.st.axes[m].cl.init == Init::Done;
            if closing || self.motor_at(m).ssi_selected() {
                return None;
            }
        }
        // The board at the span's start, as a first tick would read it. With several motors, each board
        // is asked as it is: a tick brings it to its start only after the motors before it have ticked,
        // and their boards may have brought its clock on with theirs (`SimBoard`'s axes share the main
        // board's clock), so a look that brought it there first would leave it otherwise than ticking
        // does (see `several_spans`).
        let t = self.st.motion_time;
        if self.st.axes.count() == 1 {
            self.motor_at(m).sync_board(t);
        }
        let state = self.st.axes[m].last_drive?;
        let mut quiet = self.board.quiet(m, self.st.motion_time, &state)?;
        let period = if periodic { self.board.period(m, &state, &mut quiet) } else { 0 };
        if searching && !self.motor_at(m).search_goes_on() {
            // A reference search looks at its switch after every microstep; within the board's window the
            // switches stay as they are, so every look decides as this one.
            return None;
        }
        if quiet.load == 0 && self.units_to_pps(m, self.ap(m, Setting::StopOnStall).unwrap_or(0)) > 0 {
            return None; // a measurement would stop the motor
        }
        // The last tick of the span: not after the horizon, the next instruction or end of a WAIT, the
        // next timer (its tick may be the last one: the tick's sampling fires it), the heartbeat, and
        // before the end of the board's window.
        let last = [horizon, self.program_deadline(), self.timer_deadline(), self.heartbeat_expiry()]
            .into_iter()
            .flatten()
            .chain(quiet.until.map(|u| u - Duration::from_micros(1)))
            .min();
        let ticks = match last {
            Some(t) => (t.saturating_duration_since(self.st.motion_time).micros() / TICK.micros()).min(MAX_SPAN),
            None => MAX_SPAN,
        };
        if ticks == 0 {
            return None;
        }
        let (mut min_speed, mut max_speed) = (quiet.min_speed.max(1), quiet.max_speed);
        // The slow-run current (AP 183) applies at or below AP 182: the side the speed is on stays.
        let threshold = self.units_to_pps(m, self.ap(m, Setting::CoolStepThresholdSpeed).unwrap_or(0));
        if threshold > 0 {
            let threshold = threshold.unsigned_abs();
            if self.st.axes[m].ramp.velocity().unsigned_abs() <= threshold {
                max_speed = max_speed.min(threshold);
            } else {
                min_speed = min_speed.max(threshold.saturating_add(1));
            }
        }
        let bounds = Bounds {
            ticks,
            forward: quiet.forward,
            backward: quiet.backward,
            min_speed,
            max_speed,
            ramping: self.st.axes[m].ramping,
            work: u64::MAX,
        };
        Some((self.motor_at(m).limits(), bounds, period))
    }
}

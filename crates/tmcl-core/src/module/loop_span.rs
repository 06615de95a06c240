//! A closed loop whose rotor stands on the field, taken in closed form while it accelerates, brakes or
//! cruises (TMCM-1310; docs/decisions.md, "A closed loop that accelerates in closed form").
//!
//! A closed loop measures and corrects at every tick, so it takes no plain spans (`spans.rs`), and the
//! loop's periods (`periods.rs`) need a steady speed. But while the board is periodic
//! ([`crate::hal::StepDriver::period`]: the rotor stands on the field, and the encoder reads the field's
//! position in counts, rounded down, plus a constant), what the controller does at each tick is known
//! in advance:
//!
//! - The rotor stands where the field was put by the tick before, and the encoder's settings (AP 202,
//!   210 and the resolution) convert its counts back to the field's microsteps (checked against the
//!   board's counts over its period, [`crate::hal::StepDriver::counts_at`]), so the loop reads the
//!   field's position, plus a constant, less ρ, what the counts' resolution and the conversion cut off.
//!   ρ lies within a count's microsteps plus two of its value now (ρ₀), on either side (the conversion
//!   truncates towards the encoder's reference, `Motor::encoder_value`, so ρ may change sides there).
//! - If the field stands at the ramp plus the hold integrator's part, H = hold / 1024 (the loop's
//!   `field_offset` is H), a tick's controller (`drive::closed_loop::control`) finds its set point
//!   (the ramp plus H) equal to the last field plus the ramp's step: the catch-up limit does not act;
//!   the set point lies step + ρ from the rotor, so with |step| + |ρ| within β (AP 111) and half an
//!   electrical period the commutation limit does not act either. The field moves exactly as the ramp,
//!   H stays (the integrator runs only while the ramp stands), e = step + ρ − H, and gamma = ρ·256 / a
//!   full step.
//! - The current scaling (AP 113–122) regulates |gamma| or |e| (AP 115): both lie within bounds known
//!   from the steps' range. Within a band of speeds whose errors all take one branch that cannot move
//!   the scaler (`ClosedLoop::scaler_stays`), the current is constant: the I²t sum follows tick by tick
//!   in a tight loop up to its fixed point (`ClosedLoop::i2t_ahead`), the scaling's counters in closed
//!   form (`ClosedLoop::run_locked`). The following-error check (AP 125) cannot trip within the band.
//!
//! The band is given to the ramp's span (`motion/ramp/span.rs`) as its speed bounds, with the board's
//! quiet window and the span's other bounds, so the span stops before a tick that leaves it; the board
//! hears of the field's move once. What the loop measures at the run's last [`VELOCITY_WINDOW`] ticks
//! (the velocity window, AP 131, the last move, the rotor's position, the error and gamma) is computed
//! one by one: the steps up to each of those ticks, as the span noted them on its way
//! ([`crate::motion::Trail`]; else the ramp's last ticks one by one after a span of the ticks before
//! them), and the encoder's reading where the field stood at each (`StepDriver::counts_at`). The result
//! is that of ticking (`tests/event_driven.rs` in `tmcl-sim` draws closed loops both ways).
//!
//! A look for the deadline computes a braking phase only so far (`LOOKAHEAD_WORK` ticks at first); while
//! the polls come at the deadlines it gives, each poll takes the look's run as computed and the next look
//! computes four times as far (`take_locked`).

use super::spans::LastTicks;
use super::Module;
use crate::drive::closed_loop::{Init, VELOCITY_WINDOW};
use crate::hal::prelude::*;
use crate::hal::Board;
use crate::motion::{Bounds, Limits, Ramp, RampParams, Span, Trail, TICK};
use crate::time::{Duration, Instant};

/// After a look for a run that found none, the next waits this many ticks (unless the look found the
/// next event nearer).
const RETRY_TICKS: u64 = 16;

/// The most ticks a look for the deadline computes one by one (a braking phase of about a minute): from
/// `LOOKAHEAD_WORK`, the limit grows fourfold with every look whose run the next poll took whole.
const MAX_LOOK_WORK: u64 = 1 << 16;

/// A look for the deadline that found a run of the locked loop: where it started, and the run's length
/// if it was cut short by the ticks a look computes one by one (a braking phase).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Look {
    from: Instant,
    ticks: u64,
    work: u64,
}

/// A planned run of a locked loop's ticks.
struct LockedRun {
    /// The ramp after it, and its span.
    ramp: Ramp,
    span: Span,
    /// The lowest and highest error the current scaling regulates in it.
    error: (i64, i64),
    /// The I²t sum after it.
    i2t: i64,
    /// What the loop measures at its last ticks: the rotor's position (AP 209's microsteps) at the
    /// start of each of the last `measured` ticks and at the one before them (the first: the loop's
    /// `actual` before the run if the run is that short), and the ramp's step of the last tick.
    actuals: [i64; VELOCITY_WINDOW + 1],
    measured: usize,
    last_step: i64,
}

impl<B: Board> Module<B> {
    /// At the start of a tick with motor 0's loop closed (one-motor models): takes the ticks up to
    /// `now` as a run of the locked loop (see the module docs). Returns whether it took any tick.
    #[inline(never)] // out of the open loop's way
    pub(super) fn take_locked(&mut self, now: Instant, params: &RampParams) -> bool {
        if self.periods.locked_until.is_some_and(|u| self.st.motion_time < u) {
            return false;
        }
        let start = self.st.motion_time;
        // A look for the deadline from here whose run was cut short (braking, tick by tick, computed only
        // so far): if the poll comes at the deadline it gave, its run is taken as it was computed (any
        // first part of a run is one; the span is remembered), and the next look computes more. A poll
        // before it (a host polling while the motor brakes) takes the ticks up to it, and the next
        // looks compute as little as at first, so that frequent polls do not each compute the rest of
        // a braking phase; a poll after it (a caller that polls at its own pace) takes the ticks up to
        // it, as without a look.
        let mut work = u64::MAX;
        if let Some(look) = self.periods.locked_look.take().filter(|l| l.from == start) {
            let ticks = (now - start).micros() / TICK.micros();
            if ticks < look.ticks {
                self.periods.locked_work = 0;
            } else if ticks <= look.ticks + 1 {
                work = look.work;
                self.periods.locked_work = look.work.saturating_mul(4).min(MAX_LOOK_WORK);
            }
        }
        let run = match self.plan_locked(Some(now), work, params) {
            Ok(run) => run,
            Err(wait) => {
                self.periods.locked_until = Some(start + Duration::from_micros(wait * TICK.micros()));
                return false;
            }
        };
        self.periods.locked_until = None;
        let p = self.motor_at(0).locked_loop();
        let axis = &mut self.st.axes[0];
        axis.ramp = run.ramp;
        axis.cl.run_locked(&p.scale, run.error, run.span.ticks, run.i2t);
        axis.cl.measured(&run.actuals[..=run.measured], run.span.ticks);
        // The last tick's error and gamma: e = virtual − actual; the field stands at e + H from the rotor
        // and leads the ramp's step by gamma.
        let e = i64::from(axis.ramp.position.wrapping_sub(axis.cl.actual as i32));
        axis.cl.error = e.clamp(i32::MIN.into(), i32::MAX.into()) as i32;
        let lead = e + axis.cl.field_offset - run.last_step;
        axis.cl.gamma = (lead * 256 / p.full_step.max(1)).clamp(-256, 256) as i32;
        // The field moved as the ramp: its offset from the ramp is where it was.
        axis.unreported_steps += run.span.steps;
        let t = self.st.motion_time + Duration::from_micros(run.span.ticks * TICK.micros());
        self.after_span(t);
        true
    }

    /// How many ticks from `motion_time` on a run of the locked loop would take now, without taking them
    /// (0: none): for the deadline.
    pub(super) fn locked_ahead(&mut self, params: &RampParams) -> u64 {
        if self.periods.locked_until.is_some_and(|u| self.st.motion_time < u) {
            return 0;
        }
        let work = match self.periods.locked_work {
            0 => super::spans::LOOKAHEAD_WORK,
            w => w,
        };
        let from = self.st.motion_time;
        match self.plan_locked(None, work, params) {
            Ok(run) => {
                self.periods.locked_look = run.span.capped.then_some(Look { from, ticks: run.span.ticks, work });
                run.span.ticks
            }
            Err(_) => 0,
        }
    }

    /// [`Module::span`] with the steps up to its last ticks if `noting` (`None` if a tick of them is not
    /// told by the span's trail): remembered with the span, or computed with it.
    fn span_with_last(
        &mut self,
        noting: bool,
        params: &RampParams,
        limits: Limits,
        bounds: &Bounds,
    ) -> (Ramp, Span, LastTicks) {
        if !noting {
            let (to, span) = self.span(params, limits, bounds);
            return (to, span, None);
        }
        let from = self.st.axes[0].ramp;
        if let Some(found @ (_, _, Some(_))) = self.memos.find(&from, params, limits, bounds) {
            return found;
        }
        let mut trail = Trail::default();
        let mut to = from;
        let span = to.span_noting(params, limits, bounds, &mut trail);
        let last = last_ticks(&trail, &span);
        self.memos.remember(from, params, limits, bounds, to, span, last);
        (to, span, last)
    }

    /// Plans a run of the locked loop from the state now (see the module docs); `horizon`: no tick after
    /// it (`None`: a look-ahead for the deadline, braking computed only so far). Without one: after how
    /// many ticks to look again (a look costs a span: not at every tick of a loop that cannot take one).
    fn plan_locked(&mut self, horizon: Option<Instant>, work: u64, params: &RampParams) -> Result<LockedRun, u64> {
        let (cl, ramp) = (self.st.axes[0].cl, self.st.axes[0].ramp);
        if self.st.axes.count() != 1
            || !cl.active
            || cl.init != Init::Done
            || cl.torque.is_some()
            || cl.pending_us != 0
            || self.st.axes[0].reference.is_active()
            || ramp.velocity_micro() == 0
            || cl.field_offset != cl.hold / 1024
        {
            return Err(0);
        }
        let (limits, mut bounds, period) = self.span_bounds_periodic(horizon).ok_or(RETRY_TICKS)?;
        bounds.work = work;
        // The encoder reads the field's own travel: its counts over a period of the board are what the
        // encoder's settings (AP 202, 210, 140) make of the period's microsteps. (Else ρ drifts with the
        // travel: an AP 210 that is not the encoder's, for one.)
        let (f, r) = self.conversion().ok_or(RETRY_TICKS)?;
        let state = self.st.axes[0].last_drive.ok_or(RETRY_TICKS)?;
        let read = |module: &mut Self, ahead: i64| {
            let counts = module.board.counts_at(0, &state, ahead)?;
            let motor = module.motor_at(0);
            let logical = motor.logical_counts(counts);
            Some((logical, i64::from(motor.encoder_value(logical))))
        };
        let (here, _) = read(self, 0).ok_or(RETRY_TICKS)?;
        let (there, _) = read(self, i64::try_from(period).map_err(|_| RETRY_TICKS)?).ok_or(RETRY_TICKS)?;
        if i128::from(there - here) * i128::from(f) != i128::from(period) * i128::from(r) {
            return Err(RETRY_TICKS);
        }
        let p = self.motor_at(0).locked_loop();
        let actual = i64::from(self.motor_at(0).encoder_position());
        let h = (cl.hold / 1024).abs();
        // |ρ| at every tick of the run: ρ₀ now, a count's microsteps and two on either side.
        let field = i64::from(ramp.position) + cl.field_offset;
        let rho = (field - actual).abs() + (f + r.max(1) - 1) / r.max(1) + 2;
        // A tick whose |AP 3| (truncated pps) is v moves ⌊v·dt⌋ microsteps, give or take one for the
        // ramp's fraction and two for AP 3's truncation, and as much as the speed changes in a tick (the
        // step is made at the speed before or after it): `slack` microsteps either way.
        let us = i128::from(TICK.micros());
        let slack = (i128::from(params.max_accel.unsigned_abs()) * us * us / 1_000_000_000_000 + 3) as i64;
        let steps_at = |v: i64| (i128::from(v) * us / 1_000_000) as i64;
        // The highest speed whose steps are at most `hi`, and the lowest whose steps are at least `lo`.
        let top = |hi: i64| {
            let whole = i128::from(hi - slack);
            if whole < 0 {
                -1
            } else {
                (((whole + 1) * 1_000_000 - 1) / us).min(i64::MAX.into()) as i64
            }
        };
        let bottom = |lo: i64| {
            let whole = i128::from(lo.max(0) + slack);
            ((whole * 1_000_000 + us - 1) / us).min(i64::MAX.into()) as i64
        };
        // The commutation limit does not act, the following error does not trip: the steps' bound.
        let mut max_step = p.beta.min(p.max_lead) - rho;
        if p.max_error > 0 {
            max_step = max_step.min(p.max_error - rho - h);
        }
        let (mut min_speed, mut max_speed) = (1, top(max_step));
        // The current scaling's band around the speed now.
        let v = i64::from(ramp.velocity().unsigned_abs());
        let error = if p.scale_on_error {
            // |e| = |step + ρ − H| lies within |step| ± (|ρ| + |H|).
            let off = rho + h;
            let (lower, upper) = (p.scale.lower, p.scale.upper);
            // Steps whose |e| lies below the lower limit (down), within the limits, above the upper (up).
            let bands = [(i64::MIN, lower - 1 - off), (lower + off, upper - off), (upper + 1 + off, i64::MAX)];
            let s = steps_at(v);
            let (lo, hi) =
                bands.into_iter().find(|(lo, hi)| *lo <= s - slack && s + slack <= *hi).ok_or(RETRY_TICKS)?;
            if lo > i64::MIN {
                min_speed = min_speed.max(bottom(lo));
            }
            if hi < i64::MAX {
                max_speed = max_speed.min(top(hi));
            }
            ((steps_at(min_speed) - slack - off).max(0), steps_at(max_speed) + slack + off)
        } else {
            // |gamma| = |ρ|·256 / a full step.
            (0, rho * 256 / p.full_step.max(1) + 1)
        };
        if max_speed < min_speed || !cl.scaler_stays(&p.scale, error) {
            return Err(RETRY_TICKS);
        }
        bounds.min_speed = bounds.min_speed.max(min_speed.clamp(1, i64::from(u32::MAX)) as u32);
        bounds.max_speed = bounds.max_speed.min(max_speed.clamp(0, i64::from(u32::MAX)) as u32);
        // A look for the deadline notes the steps of the run's last ticks for the poll that takes it only
        // while the polls come at the deadlines (`take_locked`): else that poll takes other ticks.
        let noting = horizon.is_some() || self.periods.locked_work != 0;
        let (mut ramp, mut span, mut last) = self.span_with_last(noting, params, limits, &bounds);
        if span.ticks == 0 {
            return Err(1);
        }
        // The I²t sum at the constant current, up to the monitor's next change (that tick changes the
        // current: it is ticked).
        let (taken, mut i2t) = cl.i2t_ahead(p.rms_ma, p.tau_ms, p.i2t_limit, span.ticks);
        if taken < span.ticks {
            (ramp, span, last) = self.span_with_last(noting, params, limits, &Bounds { ticks: taken, ..bounds });
            if span.ticks == 0 {
                return Err(1);
            }
            i2t = cl.i2t_ahead(p.rms_ma, p.tau_ms, p.i2t_limit, span.ticks).1;
        }
        if horizon.is_none() {
            // (A look for the deadline needs the run's length only.)
            let actuals = [0; VELOCITY_WINDOW + 1];
            return Ok(LockedRun { ramp, span, error, i2t, actuals, measured: 0, last_step: 0 });
        }
        // The last ticks' measurements (the velocity window, AP 131): the encoder read where the field
        // stood at the start of each of the last ticks (and of the one before them). The steps up to each
        // are those the span's trail told, or else those of the ramp's last ticks one by one after a span
        // of the ticks before them.
        let keep = VELOCITY_WINDOW as u64;
        let (ones, measured) = if span.ticks > keep { (keep + 1, keep) } else { (span.ticks, span.ticks) };
        let (ones, measured) = (ones as usize, measured as usize);
        // upto[i]: the steps up to tick n − ones + i, for i = 0..=ones.
        let mut upto = [0i64; VELOCITY_WINDOW + 2];
        if let Some((base, steps)) = last {
            for (u, s) in upto.iter_mut().zip(steps).take(ones + 1) {
                *u = base + i64::from(s);
            }
        } else {
            let (mut at, head) = self.span(params, limits, &Bounds { ticks: span.ticks - ones as u64, ..bounds });
            if head.ticks != span.ticks - ones as u64 {
                return Err(1); // (a shorter span gave back ticks that make no step: not worth a second look)
            }
            upto[0] = head.steps;
            for i in 1..=ones {
                upto[i] = upto[i - 1] + at.tick(TICK, params, limits).steps;
            }
            if at != ramp || upto[ones] != span.steps {
                return Err(1); // (the ticks one by one are the span's: never)
            }
        }
        // The reading before the first measured tick (where the tick before it left the field), or the
        // loop's own if the run is no longer than the window.
        let skip = ones - measured;
        let mut actuals = [0; VELOCITY_WINDOW + 1];
        actuals[0] = if skip > 0 { read(self, upto[0]).ok_or(1u64)?.1 } else { cl.actual };
        for (slot, travel) in actuals.iter_mut().skip(1).zip(&upto[skip..ones]) {
            *slot = read(self, *travel).ok_or(1u64)?.1;
        }
        let last_step = upto[ones] - upto[ones - 1];
        Ok(LockedRun { ramp, span, error, i2t, actuals, measured, last_step })
    }
}

/// The steps up to the last ticks of `span` as its `trail` tells them (see [`LastTicks`]).
fn last_ticks(trail: &Trail, span: &Span) -> LastTicks {
    let n = span.ticks;
    let ones = n.min(VELOCITY_WINDOW as u64 + 1);
    let mut all = [0i64; VELOCITY_WINDOW + 2];
    let all = &mut all[..=ones as usize];
    if !trail.steps_from(n - ones, all) || all[ones as usize] != span.steps {
        return None;
    }
    let base = all[0];
    let mut steps = [0i32; VELOCITY_WINDOW + 2];
    for (s, a) in steps.iter_mut().zip(all.iter()) {
        *s = i32::try_from(a - base).ok()?;
    }
    Some((base, steps))
}

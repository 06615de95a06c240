//! A closed loop turning at a steady speed, taken in whole periods (TMCM-1310; docs/decisions.md, "A
//! closed loop that sleeps").
//!
//! A closed loop measures and corrects at every tick, so it takes no spans (`spans.rs`). But when the
//! ramp cruises, the ticks repeat: the ramp moves v/1000 microsteps a tick with a fraction that comes
//! back after a few ticks, the encoder's counts come back to the same phase after a whole number of
//! counts, and the loop's error, gamma and corrections run round the same cycle (at 51 200 pps with
//! 4 096 counts a revolution: 125 ticks, 6 400 microsteps). The module looks for that:
//!
//! 1. At the start of a cruising tick it keeps a *checkpoint*: the ramp, the loop, the parameters and
//!    the encoder counts, and the period's length in ticks — the fewest after which the ramp's fraction is
//!    back and its travel is a whole number of the board's period ([`crate::hal::StepDriver::period`]: where
//!    its readings repeat) and of the encoder conversion's (counts × AP 202 × microsteps / AP 210 comes
//!    out whole).
//! 2. It ticks the period, watching that nothing breaks it (the speed changing, the current changing).
//! 3. At its end it compares: if the ramp and the loop are where the checkpoint was, moved on by the
//!    period's travel, with the same parameters, the encoder counts moved on by a whole number of the
//!    conversion's period and on the same side of the encoder's reference as all through the period,
//!    then every later period repeats this one exactly (the loop is a function of its state, the board's
//!    readings of the field's position, shifted by whole periods), until something else happens.
//! 4. Then it takes as many whole periods as may pass before the next event — the same bounds as a
//!    span: the next instruction, timer, heartbeat, the end of the board's quiet window in time and
//!    travel, the ramp's next event (braking towards a target), the I²t monitor starting or stopping to
//!    limit, the position counters' wrap — in closed form: the ramp by its span, the loop moved on by
//!    the travel with its velocity window rolled, the I²t sum computed tick by tick in a tight loop up to
//!    its fixed point, the board told once.
//!
//! The result is that of ticking (`tests/event_driven.rs` in `tmcl-sim` draws closed loops both ways).

use super::Module;
use crate::axis::EncoderBase;
use crate::drive::closed_loop::{ClosedLoop, Init};
use crate::hal::Board;
use crate::model::Setting;
use crate::motion::{Bounds, Ramp, RampParams, TICK};
use crate::time::{Duration, Instant};
use tmcl_model::capacity::{MAX_AXIS_PARAMS, MAX_GLOBAL_PARAMS};

/// The longest period looked for, in ticks (10 s): a slower repetition is ticked.
const MAX_PERIOD: u64 = 10_000;

/// 10⁻¹² microsteps per microstep: the ramp's fraction.
const PICO: u128 = 1_000_000_000_000;

/// Where a period of a cruising closed loop started (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Checkpoint {
    /// The motion time at the period's start.
    at: Instant,
    /// Ticks in a period.
    ticks: u64,
    /// The ramp then.
    ramp: Ramp,
    /// The loop then.
    cl: ClosedLoop,
    /// The encoder counts then, and the encoder's reference (AP 209's base).
    counts: i64,
    encoder: EncoderBase,
    /// The axis parameters then: the period ran with these.
    params: [i32; MAX_AXIS_PARAMS],
    /// The global parameters then.
    global: [i32; MAX_GLOBAL_PARAMS],
    /// The farthest the field strayed from the step counter (microsteps) since the checkpoint was first
    /// kept.
    stray: i64,
    /// Nothing broke the period so far: the speed and the current stayed as at its start.
    steady: bool,
    /// The checkpoint is the end of a period that repeated the one before: the next does too, unless
    /// something changed.
    repeated: bool,
}

/// After a look for a checkpoint found none (the board not periodic, an event too near, a period too
/// long), the next look waits this many ticks: a loop that cannot repeat pays for the look (a quiet
/// window of the board) once in so many ticks, not at every tick.
const RETRY_TICKS: u64 = 64;

/// The checkpoint of motor 0, if one is kept (a one-motor closed-loop model cruising).
#[derive(Debug, Clone, Default)]
pub(crate) struct Periods {
    checkpoint: Option<Checkpoint>,
    /// No look for a new checkpoint before this motion time (after one that found none).
    retry: Option<Instant>,
    /// No run of the locked loop planned before this motion time (`loop_span.rs`): the ticks after the
    /// last run, which are ticked, or a while after a look that found none.
    pub(super) locked_until: Option<Instant>,
    /// The last look for the deadline at a run of the locked loop (`loop_span.rs`), and how many ticks
    /// the next such look computes one by one (0: `LOOKAHEAD_WORK`).
    pub(super) locked_look: Option<crate::module::loop_span::Look>,
    pub(super) locked_work: u64,
}

/// A jump of whole periods.
struct Jump {
    /// How many.
    periods: u64,
    /// The ramp after them.
    ramp: Ramp,
    /// The travel of one (microsteps, signed).
    shift: i64,
    /// The I²t sum after them.
    i2t: i64,
}

impl<B: Board> Module<B> {
    /// At the start of a tick with motor 0's loop closed (one-motor models): keeps, checks and takes
    /// periods (see the module docs). Returns whether it took any tick.
    #[inline(never)] // out of the open loop's way
    pub(super) fn take_periods(&mut self, now: Instant, params: &RampParams) -> bool {
        if !self.may_repeat() {
            self.periods.checkpoint = None;
            return false;
        }
        let Some(c) = &mut self.periods.checkpoint else {
            self.start_period();
            return false;
        };
        let end = c.at + Duration::from_micros(c.ticks * TICK.micros());
        if c.repeated && self.st.motion_time == c.at {
            // At a checkpoint that repeated (a jump ended here, at a poll or before an event): the next
            // periods repeat too if nothing changed since; if none may be taken now, the period from here
            // is ticked and checked at its end.
            if self.repeats_from(0).is_some() {
                if let Some(jump) = self.plan_jump(Some(now), params) {
                    self.take_jump(jump);
                    return true;
                }
                return false;
            }
        } else if self.st.motion_time < end {
            // Within the period: what must hold at every tick of it.
            let axis = &self.st.axes[0];
            c.stray = c.stray.max(axis.cl.field_offset.abs());
            c.steady &= !axis.ramping
                && axis.ramp.velocity_micro() == c.ramp.velocity_micro()
                && axis.cl.scaler == c.cl.scaler
                && axis.cl.i2t_limiting == c.cl.i2t_limiting;
            return false;
        } else if self.st.motion_time == end && c.steady && self.close_period() {
            if let Some(jump) = self.plan_jump(Some(now), params) {
                self.take_jump(jump);
                return true;
            }
            return false; // nothing to take now: the period just ticked is the next checkpoint
        }
        self.start_period();
        false
    }

    /// How many ticks from `motion_time` on the loop's periods would take now, without taking them (0:
    /// none): for the deadline.
    pub(super) fn periods_ahead(&mut self, params: &RampParams) -> u64 {
        let Some(c) = &self.periods.checkpoint else { return 0 };
        if !c.repeated || !c.steady || !self.may_repeat() {
            return 0;
        }
        let (at, ticks) = (c.at, c.ticks);
        let end = at + Duration::from_micros(ticks * TICK.micros());
        // At the end of a period (the poll that ticked it ended here), it is checked now, as the next tick
        // would, so that the deadline can be the end of the jump that tick takes; at a checkpoint that
        // repeated, nothing may have changed since.
        let here = if self.st.motion_time == end {
            self.close_period()
        } else {
            self.st.motion_time == at && self.repeats_from(0).is_some()
        };
        if here {
            return self.plan_jump(None, params).map_or(0, |j| j.periods * ticks);
        }
        if self.st.motion_time == at {
            return 0;
        }
        // Within a period after one that repeated, with the parameters it ran with: it repeats too, up to
        // its end, where the next jump is planned (unless a bound of a span comes first).
        let Some(c) = &self.periods.checkpoint else { return 0 };
        if self.st.motion_time > end || self.st.axes[0].params != c.params || *self.st.banks.globals() != c.global {
            return 0;
        }
        let travel = (2 * c.stray + 2 * travel(c.ramp.velocity_micro(), ticks) + 1) as u64;
        let rest = (end - self.st.motion_time).micros() / TICK.micros();
        let Some((_, bounds, _)) = self.span_bounds_periodic(None) else { return 0 };
        if bounds.ticks < rest || bounds.forward < travel || bounds.backward < travel {
            return 0;
        }
        rest
    }

    /// Takes a planned jump: the ticks of its periods in closed form, then what follows a tick, once.
    fn take_jump(&mut self, jump: Jump) {
        let Some(c) = &self.periods.checkpoint else { return };
        let ticks = jump.periods * c.ticks;
        let t = self.st.motion_time + Duration::from_micros(ticks * TICK.micros());
        let axis = &mut self.st.axes[0];
        axis.ramp = jump.ramp;
        axis.cl.repeat(jump.periods, c.ticks, jump.shift, jump.i2t);
        // The field's travel over whole periods is the ramp's: its offset from the ramp comes back.
        axis.unreported_steps += jump.shift * jump.periods as i64;
        self.after_span(t);
        self.move_checkpoint();
    }

    /// Whether motor 0's ticks may repeat: the loop closed and running on its own (not initialising, not
    /// in torque mode), the ramp cruising outside a reference search, whole ticks only, one motor.
    fn may_repeat(&self) -> bool {
        let axis = &self.st.axes[0];
        let cl = &axis.cl;
        self.st.axes.count() == 1
            && cl.active
            && cl.init == Init::Done
            && cl.torque.is_none()
            && cl.pending_us == 0
            && !axis.ramping
            && axis.ramp.velocity_micro() != 0
            && !axis.reference.is_active()
    }

    /// A checkpoint at the start of this tick, if the board is periodic here (looked at again only
    /// [`RETRY_TICKS`] after a look that found none).
    fn start_period(&mut self) {
        self.periods.checkpoint = None;
        if self.periods.retry.is_some_and(|r| self.st.motion_time < r) {
            return;
        }
        let found = self.span_bounds_periodic(None).and_then(|(_, _, period)| self.period_ticks(period));
        let Some(ticks) = found else {
            self.periods.retry = Some(self.st.motion_time + Duration::from_micros(RETRY_TICKS * TICK.micros()));
            return;
        };
        let counts = self.motor_at(0).encoder_counts_now();
        let axis = &self.st.axes[0];
        self.periods.checkpoint = Some(Checkpoint {
            at: self.st.motion_time,
            ticks,
            ramp: axis.ramp,
            cl: axis.cl,
            counts,
            encoder: axis.encoder,
            params: axis.params,
            global: *self.st.banks.globals(),
            stray: axis.cl.field_offset.abs(),
            steady: true,
            repeated: false,
        });
    }

    /// The encoder conversion's constants: F = AP 202 × microsteps a full step, R = AP 210 (encoder
    /// counts × F / R are microsteps, `Module::counts_to_usteps`).
    pub(super) fn conversion(&self) -> Option<(i64, i64)> {
        let per_rev = i64::from(self.ap(0, Setting::EncoderResolution)?.max(1));
        let full_steps = i64::from(self.ap(0, Setting::MotorFullSteps).unwrap_or(200).max(1));
        Some((full_steps << self.st.axes[0].microstep_resolution(&self.spec.axis).min(8), per_rev))
    }

    /// The ticks of a period (see the module docs) for a board period of `board` microsteps, if it is at
    /// most [`MAX_PERIOD`].
    fn period_ticks(&self, board: u64) -> Option<u64> {
        // The conversion comes out whole every F / gcd(F, R) microsteps.
        let (f, r) = self.conversion()?;
        let (f, r) = (f.unsigned_abs(), r.unsigned_abs());
        let travel = lcm(board, f / gcd(f, r))?;
        // A tick moves |v| × 1000 10⁻¹² microsteps: the fewest ticks whose travel is a multiple of `travel`
        // microsteps.
        let per_tick = u128::from(self.st.axes[0].ramp.velocity_micro().unsigned_abs()) * u128::from(TICK.micros());
        let unit = u128::from(travel) * PICO;
        let ticks = unit / gcd128(per_tick, unit);
        if ticks > u128::from(MAX_PERIOD) {
            return None;
        }
        // The current scaling's millisecond counters run round AP 120 and AP 121 (while the scaler stands
        // at a limit, too): a period is a whole number of their rounds.
        let round = |s| u64::from(self.ap(0, s).unwrap_or(1).max(1).unsigned_abs());
        let ticks = lcm(lcm(ticks as u64, round(Setting::CurrentScaleUpTime))?, round(Setting::CurrentScaleDownTime))?;
        (ticks <= MAX_PERIOD).then_some(ticks)
    }

    /// Whether the state now is the checkpoint's moved on by `shift` microsteps, with the same parameters
    /// and encoder reference, and the encoder counts moved on by a whole number of the conversion's
    /// period (R / gcd(F, R) counts), the checkpoint and now on one side of the encoder's reference with
    /// room for a period's strays: the counts moved by, if so.
    fn repeats_from(&mut self, shift: i64) -> Option<i64> {
        let counts = self.motor_at(0).encoder_counts_now();
        let (f, r) = self.conversion()?;
        let c = self.periods.checkpoint.as_ref()?;
        let axis = &self.st.axes[0];
        let mut ramp = c.ramp;
        ramp.position = axis.ramp.position;
        if ramp != axis.ramp
            || !axis.cl.repeats(&c.cl, shift)
            || axis.encoder != c.encoder
            || axis.params != c.params
            || *self.st.banks.globals() != c.global
        {
            return None;
        }
        let moved = counts - c.counts;
        let whole = r / gcd(f.unsigned_abs(), r.unsigned_abs()) as i64;
        if moved % whole != 0 || i128::from(moved) * i128::from(f) != i128::from(shift) * i128::from(r) {
            return None;
        }
        // The conversion truncates towards the encoder's reference (`Motor::encoder_value`, `axis/drive.rs`):
        // the period and its repetitions lie on one side of it.
        let margin = self.count_margin(c.stray, c.ramp.velocity_micro(), c.ticks)?;
        let (before, after) = (c.counts - axis.encoder.counts, counts - axis.encoder.counts);
        if before.signum() != after.signum() || before.abs() < margin || after.abs() < margin {
            return None;
        }
        Some(moved)
    }

    /// Encoder counts that cover the field's strays from the ramp and a period's travel, and two more.
    fn count_margin(&self, stray: i64, velocity: i64, ticks: u64) -> Option<i64> {
        let (f, r) = self.conversion()?;
        Some((stray + travel(velocity, ticks)) * r / f.max(1) + 2)
    }

    /// At the end of a period: whether it repeated the checkpoint's, moved on by its travel; if so, the
    /// checkpoint moves here.
    fn close_period(&mut self) -> bool {
        let Some(c) = &self.periods.checkpoint else { return false };
        let shift = i64::from(self.st.axes[0].ramp.position.wrapping_sub(c.ramp.position));
        if self.repeats_from(shift).is_none() {
            return false;
        }
        self.move_checkpoint();
        true
    }

    /// The checkpoint repeated: it moves to the state now.
    fn move_checkpoint(&mut self) {
        let counts = self.motor_at(0).encoder_counts_now();
        let axis = &self.st.axes[0];
        let Some(c) = &mut self.periods.checkpoint else { return };
        c.at = self.st.motion_time;
        c.ramp = axis.ramp;
        c.cl = axis.cl;
        c.counts = counts;
        c.stray = c.stray.max(axis.cl.field_offset.abs());
        c.steady = true;
        c.repeated = true;
    }

    /// Plans a jump of whole periods from the state now, which repeats the checkpoint's period (see the
    /// module docs): within the bounds a span would have, the ramp's span, the I²t monitor, the
    /// counters' ranges; `None` if not one whole period fits. `horizon`: no tick after it.
    fn plan_jump(&mut self, horizon: Option<Instant>, params: &RampParams) -> Option<Jump> {
        let (limits, bounds, _) = self.span_bounds_periodic(horizon)?;
        let (f, r) = self.conversion()?;
        let c = self.periods.checkpoint.as_ref()?;
        let (ticks, stray) = (c.ticks, c.stray);
        let axis = &self.st.axes[0];
        // The travel of a period: the ramp's, at its constant speed (a whole number of microsteps).
        let per_tick = i128::from(axis.ramp.velocity_micro()) * i128::from(TICK.micros());
        let shift = (per_tick * i128::from(ticks) / PICO as i128) as i64;
        if shift == 0 {
            return None;
        }
        // The field stays within the board's quiet window: it strays from the ramp by up to `stray`.
        let margin = (2 * stray + shift.abs() + 1) as u64;
        let (ahead, behind) =
            if shift > 0 { (bounds.forward, bounds.backward) } else { (bounds.backward, bounds.forward) };
        if behind < margin {
            return None;
        }
        let mut periods = (bounds.ticks / ticks).min((ahead - ahead.min(margin)) / shift.unsigned_abs());
        // The encoder position (AP 209, 32 bits) does not wrap.
        let room = (i64::from(i32::MAX) - 2 * stray - 2 * shift.abs()) - axis.cl.actual * shift.signum();
        periods = periods.min((room.max(0) / shift.abs()) as u64);
        // Towards the encoder's reference: up to a period's strays short of it.
        let since = c.counts - axis.encoder.counts;
        let per_period = shift * r / f.max(1);
        if since.signum() != per_period.signum() {
            let margin = self.count_margin(stray, axis.ramp.velocity_micro(), ticks)?;
            periods = periods.min(((since.abs() - margin).max(0) / per_period.abs().max(1)) as u64);
        }
        // The I²t sum at the period's constant current, up to the monitor's next change.
        let cl = axis.cl;
        let (rms, tau, limit) = self.motor_at(0).loop_i2t();
        let (taken, _) = cl.i2t_ahead(rms, tau, limit, periods * ticks);
        periods = periods.min(taken / ticks);
        if periods == 0 {
            return None;
        }
        // The ramp cruises all through: a span of the periods' ticks runs them all (it is capped at their
        // count, not stopped before an event, nor out of work) at the period's speed. A span that stops
        // early stops before an event: fewer periods, up to the span's last step.
        let from = self.st.axes[0].ramp;
        let cruises = |n: u64| {
            let mut probe = from;
            let span = probe.span(params, limits, &Bounds { ticks: n * ticks, ..bounds });
            let all = span.capped && span.work < bounds.work && probe.velocity_micro() == from.velocity_micro();
            (all, span.ticks)
        };
        let (all, ran) = cruises(periods);
        if !all {
            periods = ran / ticks;
            if periods == 0 || !cruises(periods).0 {
                return None;
            }
        }
        // Whole periods' ticks move the ramp by their travel and leave its fraction where it was: that state,
        // not the span's (which ends on its last step, with the cruising ticks after it given back).
        let mut ramp = from;
        ramp.cruise_whole(shift.wrapping_mul(periods as i64));
        let (_, i2t) = cl.i2t_ahead(rms, tau, limit, periods * ticks);
        Some(Jump { periods, ramp, shift, i2t })
    }
}

/// How far a ramp cruising at `velocity` µpps moves in `ticks` ticks, in whole microsteps (unsigned).
fn travel(velocity: i64, ticks: u64) -> i64 {
    let pico = u128::from(velocity.unsigned_abs()) * u128::from(TICK.micros()) * u128::from(ticks);
    (pico / PICO).min(i64::MAX as u128) as i64
}

/// The greatest common divisor (0 with 0 gives 0).
fn gcd(a: u64, b: u64) -> u64 {
    gcd128(a.into(), b.into()) as u64
}

/// [`gcd`] of 128-bit numbers.
fn gcd128(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// The least common multiple, if it fits.
fn lcm(a: u64, b: u64) -> Option<u64> {
    if a == 0 || b == 0 {
        return None;
    }
    (a / gcd(a, b)).checked_mul(b)
}

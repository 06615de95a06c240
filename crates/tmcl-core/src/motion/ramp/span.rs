//! Spans: many motion ticks in one step, with exactly the state ticking them one by one gives.
//!
//! Between two events the ramp's velocity changes by the same amount every tick — `+a·dt` while it
//! accelerates, `−a·dt` while it slows down towards AP 2 or a stop, 0 while it cruises — so the velocity
//! after `k` ticks is `v + k·Δ` and the distance travelled is the arithmetic sum
//! `fraction + dt·(k·v + Δ·k(k+1)/2)` in 10⁻¹² microsteps. Because every tick's remainder is carried and
//! the velocity keeps its sign (it changes sign only through 0, where the fraction is reset), the steps
//! of `k` ticks are that sum divided by 10¹² (truncated towards zero, as each tick does), and the
//! fraction left is its remainder: one tick's arithmetic, done once ([`Ramp::span`]).
//!
//! Where a run's length is not a simple quotient — how long a position-mode ramp accelerates or cruises
//! before the braking bound of [`super::braking_speed`] takes over, how far the axis may travel before
//! the board's window closes — the condition is monotone over the run (the distance left only shrinks,
//! the speed only grows), so a galloping binary search over the closed form finds the last tick that
//! still meets it.
//!
//! The deceleration of a position-mode ramp towards its target has no closed form: its speed is the
//! integer square root of a term in the distance left, tick by tick. Those ticks are computed with
//! [`Ramp::tick`] itself, in a tight loop without the rest of the module (no board, no program).
//!
//! A span stops before any tick that is an event: one that arrives, stops at a switch, stops, changes
//! whether the speed changes (the boost current, AP 200), or leaves the caller's [`Bounds`] (speeds,
//! travel, tick count). Such a tick is left to the caller, who runs it as a normal tick. And a span ends
//! on its last step: ticks after it that move none (slower than a step per tick) are left for the next
//! span, so that the board hears of the last step at the time it was made (see [`crate::hal::Quiet`]).

use super::{Limits, Mode, Ramp, RampParams, MICRO, TICK};

/// The tick in µs, as the arithmetic of a span uses it.
const DT: i128 = TICK.micros() as i128;
/// 10¹² (10⁻¹² microsteps per microstep), as the arithmetic of a span uses it.
const PICO: i128 = super::PICO as i128;

/// While braking, how many ticks pass between two looks for a closed-form run.
const BRAKING_RETRY: u32 = 16;

/// What every tick of a span must keep, besides the ramp's own rules (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bounds {
    /// At most this many ticks.
    pub ticks: u64,
    /// How far the step counter may move up from where the span starts (microsteps, inclusive).
    pub forward: u64,
    /// How far it may move down.
    pub backward: u64,
    /// The lowest |AP 3| (pps, truncated as [`Ramp::velocity`]) of any tick; at least 1.
    pub min_speed: u32,
    /// The highest |AP 3| of any tick.
    pub max_speed: u32,
    /// Every tick changes the speed (`true`) or none does (`false`), as the tick before the span did.
    pub ramping: bool,
    /// At most this many ticks computed one by one (braking); the span stops there, `capped`. A look-ahead
    /// for a deadline needs no more than a time no later than the next event.
    pub work: u64,
}

/// What a span did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    /// Ticks taken (0: the next tick is an event, or the bounds allow none).
    pub ticks: u64,
    /// Microsteps moved, signed (the position counter wraps at its width; this does not).
    pub steps: i64,
    /// It stopped at the bounds' tick count or work, not before an event or the bounds' travel or
    /// speeds: a longer count or more work may give a longer span.
    pub capped: bool,
    /// Ticks computed one by one (braking): what the span cost beyond its closed forms.
    pub work: u64,
}

/// A run of ticks over which the velocity changes by `dv` every tick.
#[derive(Debug, Clone, Copy)]
struct Run {
    /// Change of the velocity per tick (µpps, signed; 0 = cruising).
    dv: i64,
    /// At most this many ticks follow the rule.
    max: u64,
    /// Position mode towards the target: each tick also needs the braking bound at or above its speed,
    /// and the target still ahead after it.
    toward: Option<Toward>,
    /// Position mode moving away from the target: the distance must stay within half the counter.
    away: bool,
}

/// The braking bound's terms for a run towards the target (see [`super::braking_square`]).
#[derive(Debug, Clone, Copy)]
struct Toward {
    /// AP 5 × dt (µpps per tick).
    a_dt: u128,
    /// |distance| at the start of the run.
    distance: i64,
    /// AP 5 (pps²).
    accel: i32,
    /// The start/stop speed in µpps, at most AP 4.
    v_min: i64,
}

/// How many of the ticks a span computes one by one a [`Trail`] keeps.
const TRAIL_TICKS: usize = 64;
/// How many of a span's closed-form runs a [`Trail`] keeps.
const TRAIL_RUNS: usize = 4;

/// What a span passes on the way: the steps moved up to each of its last ticks (for a caller that
/// needs each of the last ticks, as a closed loop's velocity window does: `module/loop_span.rs`),
/// without computing them again. The ticks of a closed-form run are told from the run (its start and
/// its change per tick); those computed one by one (braking, the generic tick) are kept as they pass,
/// the last 64 of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trail {
    /// (k, the steps of ticks 1..=k) at index k mod TRAIL_TICKS, for ticks computed one by one (k ≥ 1,
    /// so an entry never written, (0, 0), names no tick).
    ticks: [(u64, i64); TRAIL_TICKS],
    /// The last closed-form runs, by where they start.
    runs: [Option<RunFrom>; TRAIL_RUNS],
    next_run: usize,
}

/// A closed-form run of a span: after tick `after` (`before` steps moved), `n` ticks of `dv` each from
/// the ramp `start`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct RunFrom {
    after: u64,
    n: u64,
    start: Ramp,
    dv: i64,
    before: i64,
}

impl Default for Trail {
    fn default() -> Self {
        Trail { ticks: [(0, 0); TRAIL_TICKS], runs: [None; TRAIL_RUNS], next_run: 0 }
    }
}

impl Trail {
    /// The steps of the span's ticks 1..=k (signed; 0 for k = 0), if the trail knows them: a tick of one
    /// of its last closed-form runs, or one of the last ticks it computed one by one.
    pub fn steps_to(&self, k: u64) -> Option<i64> {
        let mut one = [0];
        self.steps_from(k, &mut one).then_some(one[0])
    }

    /// [`Trail::steps_to`] of the ticks `k`, `k + 1`, … into `out`, one each; `false` if the trail does
    /// not know one. Consecutive ticks of a closed-form run are told one from the other, as a tick
    /// makes them.
    pub fn steps_from(&self, k: u64, out: &mut [i64]) -> bool {
        // The run the tick before was in, its ramp after that tick and the steps up to it.
        let mut within: Option<(&RunFrom, Ramp, i64)> = None;
        for (j, o) in (k..).zip(out.iter_mut()) {
            let i = (j % TRAIL_TICKS as u64) as usize;
            let (at, steps) = self.ticks[i];
            if j == 0 {
                *o = 0;
                within = None;
            } else if at == j {
                *o = steps;
                within = None;
            } else if let Some((run, ramp, steps)) = within.as_mut().filter(|(r, ..)| j <= r.after + r.n) {
                *steps += ramp.one_tick(run.dv);
                *o = *steps;
            } else {
                let Some(run) = self.runs.iter().flatten().find(|r| r.after < j && j <= r.after + r.n) else {
                    return false;
                };
                let mut ramp = run.start;
                let steps = run.before + ramp.apply(run.dv, j - run.after);
                *o = steps;
                within = Some((run, ramp, steps));
            }
        }
        true
    }
}

/// Where a span notes what it passes ([`Trail`], or nothing: `()`).
pub trait Record {
    /// Tick `k` of the span, computed one by one, brought the steps to `steps`.
    fn tick(&mut self, k: u64, steps: i64);
    /// A closed-form run of `n` ticks of `dv` each from `start`, after tick `after` and `before` steps.
    fn run(&mut self, after: u64, n: u64, start: &Ramp, dv: i64, before: i64);
}

impl Record for () {
    #[inline(always)]
    fn tick(&mut self, _: u64, _: i64) {}
    #[inline(always)]
    fn run(&mut self, _: u64, _: u64, _: &Ramp, _: i64, _: i64) {}
}

impl Record for Trail {
    #[inline(always)]
    fn tick(&mut self, k: u64, steps: i64) {
        self.ticks[(k % TRAIL_TICKS as u64) as usize] = (k, steps);
    }
    fn run(&mut self, after: u64, n: u64, start: &Ramp, dv: i64, before: i64) {
        self.runs[self.next_run] = Some(RunFrom { after, n, start: *start, dv, before });
        self.next_run = (self.next_run + 1) % TRAIL_RUNS;
    }
}

impl Ramp {
    /// Advances over as many ticks as are no events and the bounds allow, exactly as [`Ramp::tick`]
    /// would one by one with the same parameters and limits (see the module docs). The caller runs the
    /// tick after the span as a normal tick.
    pub fn span(&mut self, p: &RampParams, limits: Limits, bounds: &Bounds) -> Span {
        self.span_noting(p, limits, bounds, &mut ())
    }

    /// [`Ramp::span`], noting what it passes in `record` (a [`Trail`]).
    pub fn span_noting<R: Record>(&mut self, p: &RampParams, limits: Limits, bounds: &Bounds, record: &mut R) -> Span {
        let mut done = Span::default();
        if self.velocity == 0 {
            return done;
        }
        // The state right after the last tick of the span that moved a step (see the module docs: a
        // span ends on its last step).
        let mut mark: Option<(Ramp, Span)> = None;
        let mut retry = 0u32;
        let mut out_of_work = false;
        while done.ticks < bounds.ticks {
            let left = bounds.ticks - done.ticks;
            if retry == 0 {
                if let Some(run) = self.run(p, limits) {
                    let n = self.allowed(&run, bounds, left, done.steps);
                    if n > 0 {
                        let start = *self;
                        let steps = self.apply(run.dv, n);
                        record.run(done.ticks, n, &start, run.dv, done.steps);
                        if steps != 0 {
                            // The run's last step: at its last tick, or (slower than a step per tick) at
                            // the first tick that reached its count.
                            let j = start.last_step(run.dv, n, steps);
                            let (at, moved) = if j == n {
                                (*self, steps)
                            } else {
                                let mut at = start;
                                let moved = at.apply(run.dv, j);
                                (at, moved)
                            };
                            mark = Some((
                                at,
                                Span { ticks: done.ticks + j, steps: done.steps + moved, ..Span::default() },
                            ));
                        }
                        done.ticks += n;
                        done.steps += steps;
                        continue;
                    }
                    if run.toward.is_some() {
                        // Braking towards the target: square roots from here to the arrival, tick by
                        // tick; a run (a new target further away) is looked for again only now and then.
                        if self.brake(p, bounds, &mut done, &mut mark, record) {
                            continue;
                        }
                        retry = BRAKING_RETRY;
                    }
                }
            } else {
                retry -= 1;
            }
            if done.work >= bounds.work {
                out_of_work = true;
                break;
            }
            let before = *self;
            let r = self.tick(TICK, p, limits);
            done.work += 1;
            let total = done.steps + r.steps;
            let silent = !r.arrived
                && !r.stopped_by_switch
                && r.ramping == bounds.ramping
                && self.mode == before.mode
                && self.velocity.signum() == before.velocity.signum()
                && self.speed_within(bounds)
                && within(total, self.velocity.signum(), bounds);
            if !silent {
                *self = before;
                break;
            }
            done.ticks += 1;
            done.steps = total;
            record.tick(done.ticks, total);
            if r.steps != 0 {
                mark = Some((*self, done));
            }
        }
        let capped = done.ticks == bounds.ticks || out_of_work;
        let work = done.work;
        if let Some((at, upto)) = mark {
            // Ticks after the last step (slower than a step per tick) are given back: the span ends on the
            // step the board hears of last; the next span starts with them.
            *self = at;
            done = upto;
        }
        Span { capped, work, ..done }
    }

    /// The braking ticks of a position-mode ramp towards its target, one by one as [`Ramp::tick`] makes
    /// them, with its arithmetic reduced to what braking needs: the speed of each tick is
    /// `max(sqrt(sq(d)), u) − a·dt` for the speed `u` of the tick before and the braking term `sq` of the
    /// distance `d` left (see `braking_speed_above`), and the square root is taken only where the curve
    /// lies above `u`, from `u` by Newton's method. Stops before a tick that is an event, that would
    /// arrive, or that leaves the bounds (the caller's generic tick decides those). Adds the ticks to
    /// `done` and `mark` as [`Ramp::span`] does; returns whether it took any.
    fn brake<R: Record>(
        &mut self,
        p: &RampParams,
        b: &Bounds,
        done: &mut Span,
        mark: &mut Option<(Ramp, Span)>,
        record: &mut R,
    ) -> bool {
        let dir = self.velocity.signum();
        let distance = self.distance();
        if distance == 0 || distance.signum() != dir || !b.ramping {
            return false;
        }
        let a_dt = i64::from(p.max_accel.max(1)) * TICK.micros() as i64;
        let v_max = i64::from(p.max_speed.max(1)) * MICRO;
        let v_min = (i64::from(p.min_speed.max(0)) * MICRO).min(v_max);
        let (mut u, mut d, mut f) = (self.velocity.abs(), distance.abs(), self.fraction.abs());
        if u < v_min || u > v_max {
            return false; // the start speed's jump; above a lowered AP 4
        }
        // sq(d) = base + per_step · d (µpps²), as `braking_square`.
        let base = super::braking_square(0, p.max_accel, v_min);
        let per_step = 2 * u128::from(p.max_accel.max(1) as u32) * super::PICO as u128;
        let lo = i64::from(b.min_speed.max(1)) * MICRO;
        let hi = (i64::from(b.max_speed) + 1).saturating_mul(MICRO);
        let window = (if dir > 0 { b.forward } else { b.backward }).saturating_sub(done.steps.unsigned_abs());
        let (mut ticks, mut moved, mut last) = (0u64, 0u64, 0u64);
        let left = (b.ticks - done.ticks).min(b.work.saturating_sub(done.work));
        let (mut last_u, mut last_f, mut last_moved) = (u, f, 0u64);
        while ticks < left {
            let sq = base + per_step * d as u128;
            let next = (u as u128) + 1;
            let speed = if sq < next * next {
                u - a_dt // the deceleration AP 5 is the limit
            } else {
                let up = (u + a_dt).min(v_max);
                let reach = (up + a_dt) as u128;
                let root = if reach.saturating_mul(reach) <= sq { up + a_dt } else { root_above(sq, u as u64) as i64 };
                root - a_dt
            };
            if speed == u || speed < lo || speed >= hi {
                break; // not ramping any more, or leaving the speeds (incl. stopping)
            }
            let travel = f + speed * TICK.micros() as i64;
            let steps = travel / super::PICO;
            if steps >= d || moved + steps as u64 > window {
                break; // arriving (or passing the target), or leaving the travel
            }
            u = speed;
            f = travel - steps * super::PICO;
            d -= steps;
            moved += steps as u64;
            ticks += 1;
            record.tick(done.ticks + ticks, done.steps + moved as i64 * dir);
            if steps != 0 {
                (last, last_u, last_f, last_moved) = (ticks, u, f, moved);
            }
        }
        if ticks == 0 {
            return false;
        }
        let apply = |ramp: &mut Ramp, u: i64, f: i64, moved: u64| {
            ramp.velocity = u * dir;
            ramp.fraction = f * dir;
            ramp.position = ramp.wrap(ramp.position.wrapping_add((moved as i64 * dir) as i32));
        };
        if last > 0 {
            let mut at = *self;
            apply(&mut at, last_u, last_f, last_moved);
            *mark = Some((
                at,
                Span { ticks: done.ticks + last, steps: done.steps + last_moved as i64 * dir, ..Span::default() },
            ));
        }
        apply(self, u, f, moved);
        done.ticks += ticks;
        done.work += ticks;
        done.steps += moved as i64 * dir;
        true
    }

    /// |AP 3| of the present velocity within the bounds' speeds.
    fn speed_within(&self, b: &Bounds) -> bool {
        let speed = self.velocity().unsigned_abs();
        speed >= b.min_speed.max(1) && speed <= b.max_speed
    }

    /// The run of ticks the ramp is in, if the next tick follows one (see [`Ramp::tick`] and
    /// `position_velocity`, `approach` in the parent module, whose cases these mirror).
    fn run(&self, p: &RampParams, limits: Limits) -> Option<Run> {
        let v = self.velocity;
        if v == 0 || (v < 0 && limits.block_negative) || (v > 0 && limits.block_positive) {
            return None;
        }
        let accel = i64::from(p.max_accel.max(1)) * TICK.micros() as i64;
        let v_min = i64::from(p.min_speed.max(0)) * MICRO;
        let sign = v.signum();
        let u0 = v.abs();
        let plain = |dv: i64, max: u64| Some(Run { dv, max, toward: None, away: false });
        match self.mode {
            Mode::Velocity => {
                let target = i64::from(self.target_velocity) * MICRO;
                if v == target {
                    return plain(0, u64::MAX);
                }
                if target == 0 || (v > 0) != (target > 0) {
                    // Slowing down towards a stop or a reversal: linear while above the stop speed.
                    return (u0 - accel > v_min)
                        .then(|| ((u0 - v_min - 1) / accel) as u64)
                        .and_then(|n| plain(-accel * sign, n));
                }
                let goal = target.abs();
                if u0 < goal {
                    // Accelerating (from at least the start speed) up to the goal.
                    let n = if u0 < v_min { 0 } else { ((goal - u0) / accel) as u64 };
                    (n > 0).then_some(n).and_then(|n| plain(accel * sign, n))
                } else {
                    // Slowing down to a lower goal; below the start speed the ramp jumps to it.
                    let floor = if goal < v_min { v_min } else { goal };
                    let n = if u0 < floor { 0 } else { ((u0 - floor) / accel) as u64 };
                    (n > 0).then_some(n).and_then(|n| plain(-accel * sign, n))
                }
            }
            Mode::Position => {
                let distance = self.distance();
                if distance == 0 {
                    return None; // the tick's own stop rule decides
                }
                let toward = v * distance.signum();
                let v_max = i64::from(p.max_speed.max(1)) * MICRO;
                let v_min = v_min.min(v_max);
                if toward < 0 {
                    // Moving away (the target changed behind): braking with AP 5 until it turns.
                    if u0 - accel <= v_min {
                        return None;
                    }
                    return Some(Run {
                        dv: -accel * sign,
                        max: ((u0 - v_min - 1) / accel) as u64,
                        toward: None,
                        away: true,
                    });
                }
                let (dv, max) = if u0 < v_min {
                    return None; // the jump to the start speed
                } else if u0 < v_max && u0 + accel <= v_max {
                    (accel * sign, ((v_max - u0) / accel) as u64)
                } else if u0 == v_max {
                    (0, u64::MAX)
                } else {
                    return None; // the last tick up to AP 4, or above a lowered AP 4
                };
                let t = Toward { a_dt: accel as u128, distance: distance.abs(), accel: p.max_accel, v_min };
                Some(Run { dv, max, toward: Some(t), away: false })
            }
        }
    }

    /// How many ticks of `run` the bounds allow, after `done` steps of the span so far and with at most
    /// `left` ticks.
    fn allowed(&self, run: &Run, b: &Bounds, left: u64, done: i64) -> u64 {
        if (run.dv != 0) != b.ramping {
            return 0;
        }
        let sign = self.velocity.signum();
        let (u0, du) = (i128::from(self.velocity.abs()), i128::from(run.dv * sign));
        // Speeds of ticks 1..n within the bounds (AP 3 truncates; at least 1 pps: the axis moves).
        let lo = i128::from(b.min_speed.max(1)) * i128::from(MICRO);
        let hi = (i128::from(b.max_speed) + 1) * i128::from(MICRO) - 1;
        let mut n = run.max.min(left);
        let limit = if du > 0 {
            if u0 + du < lo || u0 + du > hi {
                return 0;
            }
            (hi - u0) / du
        } else if du < 0 {
            if u0 + du > hi || u0 + du < lo {
                return 0;
            }
            (u0 - lo) / -du
        } else {
            if u0 < lo || u0 > hi {
                return 0;
            }
            i128::from(u64::MAX)
        };
        n = n.min(u64::try_from(limit).unwrap_or(u64::MAX));
        if n == 0 {
            return 0;
        }
        let window = i128::from(if sign > 0 { b.forward } else { b.backward }) - i128::from(done.abs());
        let half = 1i128 << (31 - self.shift);
        // Where the run probably ends, from the present speed (exact for a cruise, a start for the search
        // otherwise): where the travel reaches the window, and where the braking bound takes over.
        let per_tick = u0 * DT; // 10⁻¹² microsteps per tick now
        let fraction = i128::from(self.fraction.abs());
        let ticks_to = |steps: i128| (steps * PICO - fraction).max(0) / per_tick.max(1);
        let mut guess = i128::from(n).min(ticks_to(window + 1));
        if let Some(t) = run.toward {
            let reach = (u0 + du).unsigned_abs() + t.a_dt;
            let base = super::braking_square(0, t.accel, t.v_min);
            let per_step = 2 * u128::from(t.accel.max(1) as u32) * super::PICO as u128;
            // The braking bound binds once sq(d) < reach², d the distance left: d < (reach² − base)/per_step.
            let binds = (reach.saturating_mul(reach).saturating_sub(base) / per_step) as i128;
            guess = guess.min(ticks_to(i128::from(t.distance) - binds) + 1);
        }
        let guess = u64::try_from(guess).unwrap_or(n).clamp(1, n);
        let ok = |k: u64| -> bool {
            let Some(total) = self.travel(run.dv, k) else { return false };
            let steps = whole(total);
            if steps.abs() > window {
                return false;
            }
            if let Some(t) = run.toward {
                // Tick k is free of the braking bound: (u_k + a·dt)² ≤ sq(|d| before tick k), and the target
                // is still ahead after it (no arrival).
                if steps.abs() >= i128::from(t.distance) {
                    return false;
                }
                let Some(before) = self.travel(run.dv, k - 1) else { return false };
                let left = t.distance - whole(before).unsigned_abs() as i64;
                let reach = (u0 + du * i128::from(k)) as u128 + t.a_dt;
                if reach.saturating_mul(reach) > super::braking_square(left, t.accel, t.v_min) {
                    return false;
                }
            }
            if run.away {
                let d = i128::from(self.distance().unsigned_abs()) + steps.abs();
                if d >= half {
                    return false;
                }
            }
            true
        };
        largest_near(n, guess, ok)
    }

    /// The fraction after `k` more ticks of a run with `dv` per tick, before it is split into steps:
    /// `fraction + dt·Σ_{i=1..k} (v + i·dv)` in 10⁻¹² microsteps (`None` beyond i128).
    fn travel(&self, dv: i64, k: u64) -> Option<i128> {
        let (k, v, dv) = (i128::from(k), i128::from(self.velocity), i128::from(dv));
        let sum = k.checked_mul(v)?.checked_add(dv.checked_mul(k.checked_mul(k + 1)? / 2)?)?;
        i128::from(self.fraction).checked_add(sum.checked_mul(DT)?)
    }

    /// One tick of a run with `dv` per tick ([`Ramp::apply`] of one tick, in 64 bits where they
    /// suffice); returns the steps.
    fn one_tick(&mut self, dv: i64) -> i64 {
        let v = self.velocity + dv;
        let Some(total) = v.checked_mul(TICK.micros() as i64).and_then(|t| t.checked_add(self.fraction)) else {
            return self.apply(dv, 1);
        };
        let steps = total / super::PICO;
        self.fraction = total - steps * super::PICO;
        self.velocity = v;
        self.position = self.wrap(self.position.wrapping_add(steps as i32));
        steps
    }

    /// Applies `n` ticks of a run (allowed by [`Ramp::allowed`], so the sums fit); returns the steps.
    fn apply(&mut self, dv: i64, n: u64) -> i64 {
        let total = self.travel(dv, n).unwrap_or(0);
        let steps = total / PICO;
        self.fraction = (total - steps * PICO) as i64;
        self.velocity += dv * n as i64;
        // The counter wraps: adding the steps modulo 2³² (then to the counter's width) is what adding
        // each tick's steps does.
        self.position = self.wrap(self.position.wrapping_add(steps as i32));
        steps as i64
    }

    /// For a run of `n` ticks with `dv` per tick from this state that moves `steps` (≠ 0) in all: its
    /// last tick that moved, i.e. the first at which the count reached `steps` (the count only grows).
    fn last_step(&self, dv: i64, n: u64, steps: i64) -> u64 {
        let reached = |k: u64| self.travel(dv, k).is_some_and(|t| whole(t).abs() >= i128::from(steps.abs()));
        if !reached(n - 1) {
            return n; // the usual case: the last tick moved
        }
        // The largest k that has not reached it yet, plus one.
        largest(n, |k| !reached(k)) + 1
    }
}

/// `isqrt(sq)` for an `sq` at least `(g + 1)²`: Newton's method from `g`, which lies close below the root
/// while braking (the square root of the braking curve moves little from tick to tick), in 64-bit
/// divisions; the u128 root where the numbers do not fit.
fn root_above(sq: u128, g: u64) -> u64 {
    let g = u128::from(g) + 1;
    // One step from below (lands at or a little above the root), one from above, then to the exact root.
    let Some(e) = u64::try_from(sq - g * g).ok().zip(u64::try_from(2 * g).ok()) else { return sq.isqrt() as u64 };
    let mut r = g + u128::from(e.0 / e.1);
    let over = r * r;
    if over > sq {
        let Ok(e) = u64::try_from(over - sq) else { return sq.isqrt() as u64 };
        r -= u128::from(e / (2 * r as u64));
    }
    for _ in 0..4 {
        if r * r > sq {
            r -= 1;
        } else if (r + 1) * (r + 1) <= sq {
            r += 1;
        } else {
            return r as u64;
        }
    }
    sq.isqrt() as u64
}

/// The whole microsteps in `total` 10⁻¹² microsteps, truncated towards zero as a tick does; in 64 bits
/// where it fits (a division by a constant is a multiplication there, in 128 bits a library call).
#[inline]
fn whole(total: i128) -> i128 {
    match i64::try_from(total) {
        Ok(t) => i128::from(t / super::PICO),
        Err(_) => total / PICO,
    }
}

/// Whether `total` steps in direction `sign` stay within the bounds' travel.
fn within(total: i64, sign: i64, b: &Bounds) -> bool {
    if total != 0 && total.signum() != sign {
        return false;
    }
    total.unsigned_abs() <= if sign > 0 { b.forward } else { b.backward }
}

/// [`largest`], searching outwards from `guess` (in `1..=n`): galloping up or down from it, then bisecting
/// — a few probes when the guess is close.
fn largest_near(n: u64, guess: u64, ok: impl Fn(u64) -> bool) -> u64 {
    let (mut good, mut bad);
    if ok(guess) {
        if guess == n {
            return n;
        }
        (good, bad) = (guess, None);
        let mut step = 1u64;
        while good < n {
            let probe = good.saturating_add(step).min(n);
            if ok(probe) {
                good = probe;
                step = step.saturating_mul(2);
            } else {
                bad = Some(probe);
                break;
            }
        }
        let Some(b) = bad else { return good };
        bad = Some(b);
    } else {
        let mut step = 1u64;
        let mut high = guess;
        loop {
            let probe = high.saturating_sub(step);
            if probe == 0 {
                (good, bad) = (0, Some(high));
                break;
            }
            if ok(probe) {
                (good, bad) = (probe, Some(high));
                break;
            }
            high = probe;
            step = step.saturating_mul(2);
        }
    }
    bisect(good, bad.unwrap_or(n), ok)
}

/// The largest `k` in `0..=n` with `ok(k)`, for an `ok` that holds up to some point and not after it
/// (`ok(0)` is taken to hold): galloping from 1, then bisecting.
fn largest(n: u64, ok: impl Fn(u64) -> bool) -> u64 {
    if n == 0 || !ok(1) {
        return 0;
    }
    let (mut good, mut bad) = (1u64, None);
    while good < n {
        let probe = good.saturating_mul(2).min(n);
        if ok(probe) {
            good = probe;
        } else {
            bad = Some(probe);
            break;
        }
    }
    let Some(bad) = bad else { return good };
    bisect(good, bad, ok)
}

/// The largest `k` in `good..bad` with `ok(k)`, given `ok(good)` and not `ok(bad)`: bisecting.
fn bisect(mut good: u64, mut bad: u64, ok: impl Fn(u64) -> bool) -> u64 {
    while bad - good > 1 {
        let mid = good + (bad - good) / 2;
        if ok(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    good
}

#[cfg(test)]
mod tests;

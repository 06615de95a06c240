//! Time: the motion controller, the program and the timers run up to the time the caller gives, and the
//! module says when it next needs to run.
//!
//! # Ticks, spans and events
//!
//! The motion controller works in ticks of [`TICK`]. Ticking them one by one is the reference
//! (`Module::set_exact_ticks`); by default the module takes the ticks between two events as one
//! *span* in closed form ([`crate::motion::Ramp::span`], `spans.rs`) with exactly the same result, so its
//! cost grows with the number of events, not with time. An event is anything a tick does beyond moving
//! the ramp along its current run: the ramp arriving, stopping at a switch or changing its phase
//! (accelerate, cruise, brake), a program instruction, the end of a WAIT, a timer, the heartbeat, the
//! board's window closing (a switch edge, a timeline entry, a fault), a standby delay. The deadline
//! [`Module::poll`] returns is the next of these, not the next tick.
//!
//! Where no closed form exists the module ticks, for as long as that holds: a reference search (it
//! samples its switch at every microstep), a closed loop while it moves or settles (it measures and
//! corrects every tick; at rest it sleeps, see [`crate::drive::closed_loop`], and in open loop a
//! closed-loop model's spans leave the velocity window's ticks to ticking, `spans.rs`), coolStep
//! regulating, a deviation check that is armed, and a board that cannot say when its readings next
//! change ([`crate::hal::StepDriver::quiet`] returns `None`).
//!
//! # A program that never waits
//!
//! Each instruction is an event (it takes [`crate::vm::INSTRUCTION_TIME`]), so a busy loop makes one
//! every 20 µs, and the firmware runs every one of them. A simulator may do better behind the board's
//! hook ([`crate::hal::Hook`]): at each jump back of the program within an advance the module hands the
//! hook its state (`module/pass.rs`), and the hook may move the program's and the motion controller's
//! clocks on by whole turns of a loop in a fixed point (`tmcl-sim` does); the deadline then asks the
//! hook when the program next needs a poll. Tick-by-tick mode never calls the hook: it stays the
//! reference.
//!
//! # The same result however often the caller polls
//!
//! Spans make polls rare, so nothing may depend on when the caller polls: the ramp parameters are read
//! again after the program has run (an instruction may have changed AP 4, 5 or 130), the heartbeat is
//! checked at every tick, and a standby or freewheeling delay takes effect at its time.

use super::{Module, State};
use crate::hal::prelude::*;
use crate::hal::Board;
use crate::model::Setting;
use crate::motion::{Mode, RampParams, TICK};
use crate::time::{Duration, Instant};
use crate::vm::{RunState, BUDGET};
use tmcl_model::capacity::MAX_MOTORS;
use tmcl_wire::{Opcode, Status};

/// One microsecond.
const MICROSECOND: Duration = Duration::from_micros(1);

impl<B: Board> Module<B> {
    /// Whether the motion controller ticks one by one (the reference), not in spans.
    pub fn exact_ticks(&self) -> bool {
        self.exact
    }

    /// Ticks the motion controller one by one (`true`), as the reference for the spans it takes by
    /// default (`false`); both give the same results (see `module/advance.rs`).
    pub fn set_exact_ticks(&mut self, exact: bool) {
        self.board.input();
        self.exact = exact;
    }

    /// Runs the motion controller and timers up to `now`.
    #[inline(always)]
    pub(crate) fn advance(&mut self, now: Instant) {
        if now < self.st.now {
            // Time never runs backwards for the module; a caller's late timestamp is taken as "now".
            return;
        }
        if self.st.motion_time + TICK > now && self.vm.state != RunState::Running {
            // The common case between two ticks (frames from a host): no tick is due and no program runs,
            // so only what may fall due at `now` — exactly what the loop below does in this case.
            self.st.now = now;
            self.apply_drive_due(now);
            self.after_advance(now);
            return;
        }
        self.advance_ticks(now);
    }

    /// The earliest instant at which a motor's driver current changes by itself (standby,
    /// freewheeling) or must be told of a change, and which motor.
    #[inline(always)]
    pub(crate) fn drive_due(&self) -> Option<(usize, Instant)> {
        self.st.axes.drive_due()
    }

    /// Whether every motor stands (no ramp moving, no reference search).
    #[inline(always)]
    pub(crate) fn all_standing(&self) -> bool {
        self.st.axes.all_standing()
    }

    /// [`Module::advance`] when a tick is due or a program runs.
    #[inline(never)]
    fn advance_ticks(&mut self, now: Instant) {
        self.st.now = now;
        let motors = self.st.axes.count();
        // The ramp parameters in force for the ticks, per motor, read again whenever the program has run.
        // When no tick is due (a frame between two ticks), none runs in this call: the loop's first pass
        // takes `tick_at` before the program runs and breaks on it. So the lookups are skipped and the
        // placeholder is never used.
        let placeholder = RampParams { max_speed: 0, max_accel: 0, min_speed: 0 };
        let mut params = [placeholder; MAX_MOTORS as usize];
        if self.st.motion_time + TICK <= now {
            self.read_ramp_params(&mut params);
        }
        let mut budget = BUDGET;
        let closed_loop = self.spec.axis.has(Setting::ClosedLoop);
        // The program's jumps back are reported to the board's hook within advances only.
        self.advancing = true;
        // Instructions up to and including `now`.
        let horizon = now + MICROSECOND;
        loop {
            let tick_at = self.st.motion_time + TICK;
            // The driver's state changes by itself before the next tick (a standby or freewheeling delay
            // runs out), or an instruction changed it (a parameter, a stop): the board hears of it at that
            // time, after the instructions up to then — however often the caller polls.
            if self.vm.state == RunState::Running {
                let due = self.drive_due().map(|(_, d)| d).filter(|d| *d < tick_at && *d <= now);
                let executed = self.vm.executed;
                let limit = due.map_or(tick_at, |d| tick_at.min(d + MICROSECOND));
                // (It returns early after an instruction that changed what the driver sees.)
                if self.run_program(limit.min(horizon), &mut budget) {
                    // Whole turns of a loop in a fixed point jumped over, ticks and all.
                    self.read_ramp_params(&mut params);
                    continue;
                }
                if budget == 0 {
                    break; // the rest at the next poll (its deadline is now)
                }
                if self.vm.executed != executed && tick_at <= now {
                    // An instruction may have changed AP 4, 5 or 130: the next ticks use what is in force.
                    self.read_ramp_params(&mut params);
                }
            }
            if let Some((m, d)) = self.drive_due().filter(|(_, d)| *d < tick_at && *d <= now) {
                self.motor_at(m).update_board(d); // the next delay, if any, lies after `d`
                if self.vm.state == RunState::Running && !self.exact {
                    // (After a program's command, mostly: what its settings name, `module/pass.rs`.)
                    self.name(self.st.axes[m].drive_due);
                }
                continue;
            }
            if tick_at > now {
                break;
            }
            // The heartbeat stops the motors for every tick after it ran out, whether a poll between the
            // ticks or this check sees it first.
            self.check_heartbeat(tick_at);
            if self.all_standing() {
                if self.idle_jump(now) {
                    continue;
                }
            } else if !self.exact
                && if motors == 1 { self.take_span(now, &params[0]) } else { self.take_spans(now, &params[..motors]) }
            {
                continue;
            }
            for (m, params) in params.iter().enumerate().take(motors) {
                self.tick_axis(m, tick_at, params, closed_loop);
            }
            self.st.motion_time = tick_at;
            self.tick_done(tick_at);
        }
        self.advancing = false;
        self.after_advance(now);
    }

    /// The ramp parameters in force, for every motor.
    #[inline]
    fn read_ramp_params(&self, params: &mut [RampParams; MAX_MOTORS as usize]) {
        for (m, p) in params.iter_mut().enumerate().take(self.st.axes.count()) {
            *p = self.ramp_params(m);
        }
    }

    /// Motor `m`'s motion tick ending at `tick_at` ([`crate::axis::Motor::tick`]), or a reference
    /// search's tick taken at once.
    #[inline]
    fn tick_axis(&mut self, m: usize, tick_at: Instant, params: &RampParams, closed_loop: bool) {
        // A reference search looks at its switch after every microstep (sub-ticks, §7.1).
        let parts = self.st.axes[m].tick_parts(TICK);
        if parts > 1 && !self.exact && !closed_loop && self.search_tick_at_once(m, tick_at, params, parts) {
            return;
        }
        let from = self.st.motion_time;
        let faults = self.motor_at(m).tick(from, tick_at, parts, params, closed_loop);
        self.apply(m, faults);
    }

    /// A reference search's tick in `parts` (one per microstep) taken at once when every look at the
    /// switch in it would go on: the board is quiet for the whole tick (its window reaches past the tick
    /// and the tick's travel), the search decides to go on with the switches as they are (so it does at
    /// every part: they stay), and the parts, computed by the ramp alone, move one way at speeds within
    /// the window's, the motor moving already and every part accelerating as the tick before did, or none,
    /// and coolStep off with no slow-run threshold (so the current stays what the board was told). The board hears of the tick once, at its end, as
    /// within a span. Returns whether it took the tick.
    #[inline(never)] // out of the plain tick's way
    fn search_tick_at_once(&mut self, m: usize, tick_at: Instant, params: &RampParams, parts: u64) -> bool {
        let start = self.st.motion_time;
        // (What the first part does first; a tick that falls back to its parts finds it done.)
        self.motor_at(m).sync_board(start);
        let Some(state) = self.st.axes[m].last_drive else { return false };
        let Some(quiet) = self.board.quiet(m, start, &state) else { return false };
        if quiet.until.is_some_and(|u| u <= tick_at) {
            return false;
        }
        if !self.motor_at(m).search_goes_on() {
            return false;
        }
        if self.st.axes[m].standstill_since.is_some() {
            return false; // starting: the current changes with the first part (the board must hear of it)
        }
        if !self.motor_at(m).coolstep_off() || self.ap(m, Setting::CoolStepThresholdSpeed).unwrap_or(0) != 0 {
            return false; // coolStep's current depends on the speed, which changes from part to part
        }
        let limits = self.motor_at(m).limits();
        let mut ramp = self.st.axes[m].ramp;
        let step = TICK.micros() / parts;
        // Every part accelerates as the tick before did, or none does: the boost current (AP 200) stays
        // what the board was last told, as within a span.
        let (mut total, mut last, mut ramping) = (0i64, 0i64, Some(self.st.axes[m].ramping));
        for k in 1..=parts {
            let dt = if k == parts { TICK.micros() - step * (parts - 1) } else { step };
            let r = ramp.tick(Duration::from_micros(dt), params, limits);
            let speed = ramp.velocity().unsigned_abs();
            if r.arrived
                || r.stopped_by_switch
                || speed == 0
                || speed < quiet.min_speed
                || speed > quiet.max_speed
                || total.signum() * r.steps.signum() < 0
                || ramping.is_some_and(|x| x != r.ramping)
            {
                return false;
            }
            ramping = Some(r.ramping);
            total += r.steps;
            last = r.steps;
        }
        let room = if total >= 0 { quiet.forward } else { quiet.backward };
        if (total != 0 && last == 0) || total.unsigned_abs() > room {
            return false;
        }
        let axis = &mut self.st.axes[m];
        axis.ramp = ramp;
        axis.ramping = ramping.unwrap_or(false);
        axis.moved(tick_at, total);
        self.motor_at(m).update_board(tick_at);
        true
    }

    /// What follows every motion tick (and a span, at its last tick `t`), after the board has been
    /// updated: the drive's readings of every motor, the 138 event, the interrupt sources.
    #[inline(always)]
    pub(super) fn tick_done(&mut self, t: Instant) {
        for m in 0..self.st.axes.count() {
            let faults = self.motor_at(m).drive_tick();
            self.apply(m, faults);
        }
        self.check_event(t);
        if self.vm.enabled != 0 {
            self.sample_interrupts(t);
        }
    }

    /// Every motor stands: jumps over the ticks up to the last tick boundary before the next timed event
    /// (or `now`), if no tick until then can do anything. Returns whether it jumped.
    fn idle_jump(&mut self, now: Instant) -> bool {
        let watching = self.needs_every_tick();
        let motors = self.st.axes.count();
        // Interrupts on switch or input levels sample every tick: in a quiet window of the board the
        // levels stay as they are, so the ticks up to its end may be jumped over too.
        let mut quiet_until = None;
        if watching {
            if self.exact || self.st.axes.iter().any(|a| a.standstill_since.is_none()) {
                // A motor that has just stopped starts its standstill at the next tick, as a sampled tick
                // has it.
                return false;
            }
            for m in 0..motors {
                let state = self.st.axes[m].last_drive.unwrap_or_default();
                match self.board.quiet(m, self.st.motion_time, &state) {
                    Some(q) => {
                        if let Some(u) = q.until.map(|u| u - MICROSECOND) {
                            quiet_until = Some(quiet_until.map_or(u, |q: Instant| q.min(u)));
                        }
                    }
                    None => return false,
                }
            }
        }
        // A stop outside the ramp (a stall, a deviation, the end of a reference search) leaves the motor
        // standing: the standby and freewheeling delays run from the last tick.
        for m in 0..motors {
            if self.st.axes[m].standstill_since.is_none() {
                self.st.axes[m].standstill_since = Some(self.st.motion_time);
                // The board hears of it (not before it last heard from the module), and of the standby timer.
                let t = self.st.motion_time.max(self.st.axes[m].board_time);
                self.motor_at(m).update_board(t);
            }
        }
        // The heartbeat stops the motors at the first tick after it ran out (`check_heartbeat`): the ticks
        // jumped over end at its expiry, so the tick that stops them is sampled with them stopped (a
        // target-reached interrupt's source then no longer stands at its target).
        let until = [
            self.program_deadline(),
            self.timer_deadline(),
            self.drive_due().map(|(_, d)| d),
            quiet_until,
            self.heartbeat_expiry(),
        ]
        .into_iter()
        .flatten()
        .fold(now, Instant::min);
        let tick_at = self.st.motion_time + TICK;
        if until < tick_at {
            return false;
        }
        let mut ticks = (until - self.st.motion_time).micros() / TICK.micros();
        if watching && self.spec.axis.has(Setting::ClosedLoop) {
            // A closed-loop model's loop measures (and, closed, corrects) at every tick: it sleeps through
            // the ticks only while the rotor stands and the loop is at rest (`axis/closed_loop.rs`), as
            // many as every motor's allows.
            for m in 0..motors {
                ticks = ticks.min(self.motor_at(m).closed_loop_rest(ticks, false));
            }
            if ticks == 0 {
                return false;
            }
            for m in 0..motors {
                self.motor_at(m).closed_loop_rest(ticks, true);
            }
        }
        self.st.motion_time += Duration::from_micros(ticks * TICK.micros());
        for m in 0..motors {
            self.st.axes[m].ramping = false;
        }
        self.waiting_program_slept_to(self.st.motion_time);
        if watching {
            // In place of sampled ticks, what the last of them does: the encoder followed (its counts and the
            // last zero passed are all that count), the 138 event, the interrupt sources.
            self.tick_done(self.st.motion_time);
        } else if self.vm.enabled != 0 {
            self.sample_interrupts(self.st.motion_time);
        }
        true
    }

    /// The end of an advance to `now`: the 138 event and the heartbeat. (The board has heard of every
    /// change at its time: at the ticks, and through `drive_due` for the rest.)
    #[inline(always)]
    fn after_advance(&mut self, now: Instant) {
        self.check_event(now);
        self.check_heartbeat(now);
    }

    /// Standby and freewheeling delays that have run out by `now`, each at its own time.
    #[inline]
    fn apply_drive_due(&mut self, now: Instant) {
        while let Some((m, d)) = self.drive_due().filter(|(_, d)| *d <= now) {
            self.motor_at(m).update_board(d);
        }
    }

    /// Whether interrupts that watch switches or inputs are enabled, or a closed loop runs: then every
    /// tick is sampled (unless the board is quiet, see [`Module::idle_jump`]).
    #[inline]
    fn needs_every_tick(&self) -> bool {
        self.vm.enabled & self.spec.interrupts.levels_mask != 0 || self.st.axes.iter().any(|a| a.cl.engaged())
    }

    /// §3.7.37: the second reply of command 138 when an MVP's target is reached, on the interface that
    /// asked for it.
    #[inline(always)]
    fn check_event(&mut self, now: Instant) {
        if self.st.event.pending && self.event_reached() {
            self.st.event.pending = false;
            let op = Opcode::RequestTargetReachedEvent.code();
            let port = usize::from(self.st.event.port);
            let framing = self.interface(port).map_or(crate::model::Framing::Binary, |i| i.framing);
            self.push_reply(port, framing, op, Ok((Status::TargetReached, self.st.event.mask, op)), now);
        }
    }

    /// Whether every motor of the 138 event's mask has reached its target: in position mode, standing,
    /// at the target. §3.7.37 gives the value as a bit per motor but not how several motors' arrivals are
    /// reported; ours: one reply once all of them stand at their targets (the PD28-1021's one motor: as
    /// before).
    fn event_reached(&mut self) -> bool {
        for m in 0..self.st.axes.count() {
            if self.st.event.mask & (1 << m) == 0 {
                continue;
            }
            let ramp = &self.st.axes[m].ramp;
            if !(ramp.mode == Mode::Position && ramp.is_idle() && self.motor_at(m).target_reached()) {
                return false;
            }
        }
        true
    }

    /// When the heartbeat runs out (GP 68), if it is armed: the first time more than its milliseconds
    /// after the last command.
    pub(super) fn heartbeat_expiry(&self) -> Option<Instant> {
        heartbeat_expiry(&self.st)
    }

    /// §5.1 GP 68: stop the motor when no command arrived within the heartbeat time (milliseconds; the
    /// manual gives no unit). Checked at every motion tick and every poll.
    fn check_heartbeat(&mut self, now: Instant) {
        if self.heartbeat_expiry().is_some_and(|expiry| now > expiry) {
            self.st.heartbeat_tripped = true;
            for m in 0..self.st.axes.count() {
                self.st.axes[m].ramp.rotate(0);
            }
            self.st.event.pending = false;
        }
    }

    /// When the module next needs to run (see the module docs).
    pub(crate) fn next_deadline(&mut self) -> Option<Instant> {
        let mut next: Option<Instant> = self.st.ports.iter().filter_map(|p| p.outbox.next_due()).min();
        let consider = |next: &mut Option<Instant>, t: Instant| *next = Some(next.map_or(t, |n| n.min(t)));
        // The board's hook may know better when a running program needs its next poll (a simulator that
        // found it spinning in a fixed point: not before the next event, `hal::Hook::program_rest`).
        let rest = if self.vm.state == RunState::Running && !self.exact {
            self.board.get().program_rest(self.st.now, self.board.changes())
        } else {
            None
        };
        let program = rest.unwrap_or_else(|| self.program_deadline());
        for t in [program, self.timer_deadline()].into_iter().flatten() {
            consider(&mut next, t.max(self.st.now));
        }
        for axis in self.st.axes.iter() {
            if let Some(t) = axis.next_event(&self.spec.axis, self.st.now) {
                consider(&mut next, t);
            }
        }
        if let Some(expiry) = self.heartbeat_expiry() {
            consider(&mut next, expiry + Duration::from_millis(1));
        }
        if !self.all_standing() {
            // Moving: the tick after the span the ramps can take from here (none: the next tick).
            let ticks = if self.st.axes.count() == 1 { self.span_ahead() } else { self.spans_ahead() } + 1;
            consider(&mut next, self.st.motion_time + Duration::from_micros(ticks * TICK.micros()));
        } else if self.st.event.pending || self.needs_every_tick() {
            // (After the other deadlines: a look past the earliest of them would find nothing that counts.)
            match self.idle_quiet_until(next) {
                // Levels watched in a quiet window: the first tick at or after its end.
                Some(until) => {
                    if let Some(u) = until {
                        let ticks = (u - self.st.motion_time).micros().div_ceil(TICK.micros()).max(1);
                        consider(&mut next, self.st.motion_time + Duration::from_micros(ticks * TICK.micros()));
                    }
                }
                None => consider(&mut next, self.st.motion_time + TICK),
            }
        }
        next
    }

    /// Standing, with level interrupts watched and no 138 event pending: the end of the board's quiet
    /// window, if it has one (`Some(None)`: quiet for good); `None`: every tick must be sampled. `before`:
    /// the module's earliest other deadline, past which nothing needs looking at.
    fn idle_quiet_until(&mut self, before: Option<Instant>) -> Option<Option<Instant>> {
        if self.st.event.pending || self.exact {
            return None;
        }
        let mut until: Option<Instant> = None;
        for m in 0..self.st.axes.count() {
            let state = self.st.axes[m].last_drive.unwrap_or_default();
            if let Some(u) = self.board.quiet(m, self.st.motion_time, &state)?.until {
                until = Some(until.map_or(u, |t| t.min(u)));
            }
        }
        if self.spec.axis.has(Setting::ClosedLoop) {
            // A loop at rest sleeps as long as its I²t sum neither settles nor crosses its limit: looked at
            // over a bounded stretch (a deadline at its end is only an extra poll), and not past the tick
            // of the earliest other deadline — the I²t sum is followed tick by tick until it settles, and a
            // program polled at each of its instructions must not pay for a long look at every one.
            const LOOK: u64 = 1 << 16;
            let look = before.map_or(LOOK, |t| {
                (t.saturating_duration_since(self.st.motion_time).micros().div_ceil(TICK.micros())).clamp(1, LOOK)
            });
            for m in 0..self.st.axes.count() {
                let n = self.motor_at(m).closed_loop_rest(look, false);
                if n == 0 {
                    return None;
                }
                let u = self.st.motion_time + Duration::from_micros(n * TICK.micros());
                until = Some(until.map_or(u, |t| t.min(u)));
            }
        }
        Some(until)
    }
}

/// When the heartbeat runs out (GP 68) in `st`, if it is armed (see [`Module::check_heartbeat`]).
#[inline]
pub(super) fn heartbeat_expiry(st: &State) -> Option<Instant> {
    let limit = st.banks.ready().heartbeat;
    (limit > 0 && !st.heartbeat_tripped).then(|| st.last_command + Duration::from_millis(limit as u64))
}

//! A program that spins in a fixed point: jumped over in whole turns of its loop (with the
//! `spin-skip` feature, on by default).
//!
//! A program that never waits executes an instruction every [`crate::vm::INSTRUCTION_TIME`], so an
//! hour of `Loop: GIO 255, 0 / SIO 255, 2, -1 / JA Loop` is 180 million instructions. When such a loop
//! comes back to the same address with the module's whole state as it was the turn before — but for the
//! clocks, which move with time itself — and nothing outside the program changes meanwhile, every further
//! turn does the same: the module jumps over as many whole turns as fit before the next event, adding
//! their time and their instructions, and runs the rest one by one as before.
//!
//! # Why it is exact
//!
//! The module and its board are a deterministic machine whose next steps depend on their state and on
//! time only through
//! - the ticks, [`crate::motion::TICK`] apart from `motion_time`;
//! - the instants kept in the state (a timer, a standby or freewheeling delay `drive_due`, the heartbeat);
//! - the board's readings, which a quiet window ([`crate::hal::StepDriver::quiet`]) promises to keep
//!   until its end while the driver is told nothing new;
//! - the caller's `now`, where an advance ends;
//! - and whatever reaches it from outside: a host command changes the firmware state (compared below),
//!   a change of the board through [`Module::board_mut`] counts as telling it something new: every
//!   such change, and every write to the board or the EEPROM, moves the count of changes on
//!   (`module/seam.rs`), which is the *epoch* below.
//!   [`Module::board_timeline`] moves the board's world on along its timeline, which the quiet windows
//!   announce.
//!
//! Two passes through the same address, with the program's clock as far after the last tick both times
//! (the same *phase*, so the ticks fall between the same instructions), with every field of the firmware
//! state and the program machine equal but those that move with time (the program's and the motion
//! controller's clocks by the same Δ, the instruction count by n; the board's clock and the caller's
//! `now` are not the module's to compare), with nothing told to the board in between (the *epoch*: a new
//! drive state, driver settings, outputs, an EEPROM write, the board changed from outside), and both
//! within the quiet window the board reported at the first: then from the second pass the machine does
//! exactly what it did from the first, shifted by Δ, for as long as none of the instants above falls
//! within. So k turns later it is in the second pass's state with the clocks k·Δ on and k·n more
//! instructions executed — which is what the module sets. Everything the turns would have done in
//! between is undone within each turn: that is what equal states at both passes say.
//!
//! A fixed point found with nothing due before the end of the advance also tells the deadline
//! ([`Module::poll`]): the program needs no poll before the next of those instants, until a host command
//! or the board says otherwise. A caller that polls at the deadlines polls a spinning program at its
//! events, not at its instructions.
//!
//! Not covered (the program runs instruction by instruction, as before): a moving axis, a reference
//! search, a closed-loop model, a board that cannot say it is quiet, a loop whose state changes from turn
//! to turn, a WAIT in progress at the pass, single steps (command 130), and tick-by-tick mode
//! (`Module::set_exact_ticks`), the reference this is tested against.
//!
//! # Cost
//!
//! The program machine calls [`Module::spin_pass`] after every jump back (the PC not past where it was);
//! that compares a small key (address, phase, registers, stack depth, handler) with the one remembered.
//! Only when the key comes round again is the whole state copied (the first time) or compared (the
//! next), and a loop whose whole state keeps changing is compared ever less often (every 2, 4, … 64th
//! time the key comes round).

#[cfg(feature = "spin-skip")]
use super::{Axis, Module, Registers, State};
#[cfg(feature = "spin-skip")]
use crate::hal::prelude::*;
#[cfg(feature = "spin-skip")]
use crate::hal::Board;
#[cfg(feature = "spin-skip")]
use crate::time::{Duration, Instant};
#[cfg(feature = "spin-skip")]
use crate::vm::{RunState, Vm};
#[cfg(feature = "spin-skip")]
use tmcl_model::capacity::MAX_TIMERS;

#[cfg(feature = "spin-skip")]
/// A key whose pass has not come round in this many instructions is given up for the next pass: a
/// loop's turns meet the same phase within 50 turns (a tick is 50 instructions), so loops of up to 160
/// instructions are found.
const REACH: u64 = 1 << 13;
#[cfg(feature = "spin-skip")]
/// After this many failed comparisons in a row the whole state is compared every 2⁶th time the key comes
/// round.
const MAX_BACKOFF: u32 = 6;

#[cfg(feature = "spin-skip")]
/// What a pass is recognised by, cheaply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Key {
    pc: u16,
    /// Microseconds from the last motion tick to the next instruction.
    phase: u64,
    regs: Registers,
    sp: u8,
    handler: bool,
}

#[cfg(feature = "spin-skip")]
/// The whole state at a pass, to compare the next pass with.
#[derive(Debug, Clone)]
struct Snapshot {
    st: State,
    vm: Vm,
    /// The end of the board's quiet window at the pass (`None`: quiet for good).
    until: Option<Instant>,
    /// The count of changes at the pass (`module/seam.rs`): a turn that changed anything is no fixed point.
    epoch: u32,
}

#[cfg(feature = "spin-skip")]
/// The detector (see the module docs); it watches within advances only (`armed`).
#[derive(Debug, Clone, Default)]
pub(crate) struct Spin {
    armed: bool,
    /// The key of the pass being watched and the instruction count when it was last seen.
    anchor: Option<(Key, u64)>,
    snapshot: Option<Snapshot>,
    failures: u32,
    /// Passes of the key to let go by before the next copy or comparison.
    skip: u32,
    /// A fixed point found at this count of changes (`module/seam.rs`), with nothing due before this
    /// instant (`None`: ever): the program needs no poll before it. Void once the count moves on (a host
    /// command, a library call, the board changed or told something new).
    rest: Option<(u32, Option<Instant>)>,
}

#[cfg(feature = "spin-skip")]
impl Spin {
    /// Watches (within an advance) or not (outside: a single step, command 130, jumps over nothing).
    #[inline(always)]
    pub(crate) fn arm(&mut self, armed: bool) {
        self.armed = armed;
    }

    /// Starts looking afresh (after a jump).
    fn restart(&mut self) {
        self.anchor = None;
        self.snapshot = None;
        self.failures = 0;
        self.skip = 0;
    }

    /// The program spins in a fixed point with nothing due before `now` and nothing changed since it was
    /// found (`changes`, the count now): when it needs its next poll (`Some(None)`: never by itself).
    /// `None`: not known to spin.
    pub(crate) fn rest(&self, now: Instant, changes: u32) -> Option<Option<Instant>> {
        self.rest.filter(|(at, r)| *at == changes && r.is_none_or(|e| e > now)).map(|(_, r)| r)
    }
}

#[cfg(feature = "spin-skip")]
/// Whether `b` is `a` a whole number of turns later: every field equal but the clocks, which are Δ on
/// (the program's and the motion controller's by the same Δ > 0). Returns (Δ, instructions per Δ).
///
/// Every field is named (no `..`): a field added to [`State`] or [`Vm`] does not compile until it is
/// decided here whether it moves with time.
fn turned(a: &Snapshot, st: &State, vm: &Vm) -> Option<(Duration, u64)> {
    let Vm {
        state,
        pc,
        stack,
        sp,
        wait,
        // Moves with time: Δ.
        time,
        vectors,
        enabled,
        global,
        pending,
        handler,
        timers,
        download,
        last_levels,
        was_reached,
        breakpoints,
        at_breakpoint,
        // Moves with time: the turns' instructions.
        executed,
        // Equal: a turn that refuses an instruction is no fixed point (each refusal is noted with its
        // time), so such a loop runs instruction by instruction.
        refusals,
    } = &a.vm;
    let shift = vm.time.saturating_duration_since(*time);
    let n = vm.executed.checked_sub(*executed).filter(|n| *n > 0)?;
    let same_vm = shift.micros() > 0
        && *state == vm.state
        && *pc == vm.pc
        && *stack == vm.stack
        && *sp == vm.sp
        && *wait == vm.wait
        && *vectors == vm.vectors
        && *enabled == vm.enabled
        && *global == vm.global
        && *pending == vm.pending
        && *handler == vm.handler
        && *timers == vm.timers
        && *download == vm.download
        && *last_levels == vm.last_levels
        && *was_reached == vm.was_reached
        && *breakpoints == vm.breakpoints
        && *at_breakpoint == vm.at_breakpoint
        && *refusals == vm.refusals;
    if !same_vm {
        return None;
    }
    let State {
        axes,
        global,
        interrupt,
        user,
        regs,
        host_regs,
        event,
        ports,
        asking_port,
        // Moves with time: Δ (the same phase).
        motion_time,
        // The caller's time: the same within an advance, and not the module's state.
        now: _,
        tick_base,
        rng,
        last_command,
        heartbeat_tripped,
        outputs,
        active_baud,
        unlocked,
        tmc428,
    } = &a.st;
    let same = *motion_time + shift == st.motion_time
        && axes.count() == st.axes.count()
        && axes.iter().zip(st.axes.iter()).all(|(a, b)| same_axis(a, b))
        && *global == st.global
        && *interrupt == st.interrupt
        && *user == st.user
        && *regs == st.regs
        && *host_regs == st.host_regs
        && *event == st.event
        && *ports == st.ports
        && *asking_port == st.asking_port
        && *tick_base == st.tick_base
        && *rng == st.rng
        && *last_command == st.last_command
        && *heartbeat_tripped == st.heartbeat_tripped
        && *outputs == st.outputs
        && *active_baud == st.active_baud
        && *unlocked == st.unlocked
        && *tmc428 == st.tmc428;
    same.then_some((shift, n))
}

#[cfg(feature = "spin-skip")]
/// Whether a motor's state is as it was, but for the board's clock.
fn same_axis(a: &Axis, b: &Axis) -> bool {
    let Axis {
        params,
        coords,
        ramp,
        reference,
        standstill_since,
        ramping,
        encoder,
        error_flags,
        unreported_steps,
        last_drive,
        // The board's clock: where the module last brought it. The board's own (quiet) business: it reads
        // the same at any instant of its window, and is brought to the next instant it is read at.
        board_time: _,
        drive_due,
        coolstep,
        load_measurements,
        last_counts,
        cl,
        ssi,
        interpolation,
    } = a;
    *params == b.params
        && *coords == b.coords
        && *ramp == b.ramp
        && *reference == b.reference
        && *standstill_since == b.standstill_since
        && *ramping == b.ramping
        && *encoder == b.encoder
        && *error_flags == b.error_flags
        && *unreported_steps == b.unreported_steps
        && *last_drive == b.last_drive
        && *drive_due == b.drive_due
        && *coolstep == b.coolstep
        && *load_measurements == b.load_measurements
        && *last_counts == b.last_counts
        && *cl == b.cl
        && *ssi == b.ssi
        && *interpolation == b.interpolation
}

#[cfg(feature = "spin-skip")]
impl<B: Board> Module<B> {
    /// After a jump back (the PC not past where it was), within an advance: jumps over whole turns of a
    /// loop in a fixed point (see the module docs). Returns whether it did; then the program's and the
    /// motion controller's clocks have moved on.
    #[inline(never)]
    pub(crate) fn spin_pass(&mut self) -> bool {
        if !self.spin.armed
            || self.exact
            || self.vm.state != RunState::Running
            || self.vm.wait.is_some()
            || self.vm.time <= self.st.motion_time
        {
            return false;
        }
        let key = Key {
            pc: self.vm.pc,
            phase: (self.vm.time - self.st.motion_time).micros(),
            regs: self.st.regs,
            sp: self.vm.sp,
            handler: self.vm.handler.is_some(),
        };
        let executed = self.vm.executed;
        let spin = &mut self.spin;
        match &mut spin.anchor {
            Some((k, seen)) if *k == key => *seen = executed,
            Some((_, seen)) if executed - *seen <= REACH => return false,
            anchor => {
                *anchor = Some((key, executed));
                spin.snapshot = None;
                return false;
            }
        }
        if spin.skip > 0 {
            spin.skip -= 1;
            return false;
        }
        // Every axis stands, nothing ticks by itself, and the board is quiet for each.
        let standing =
            !self.has_closed_loop() && self.st.axes.iter().all(|a| a.is_standing() && a.standstill_since.is_some());
        let mut quiet_until: Option<Option<Instant>> = standing.then_some(None);
        for m in 0..self.st.axes.count() {
            let Some(until) = quiet_until else { break };
            let drive = self.st.axes[m].last_drive.unwrap_or_default();
            quiet_until = self.board.quiet(m, self.st.motion_time, &drive).map(|q| match (until, q.until) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            });
        }
        let Some(quiet_until) = quiet_until else {
            self.spin.snapshot = None;
            return false;
        };
        let epoch = self.board.changes();
        let turn = match &self.spin.snapshot {
            // The copy's quiet window has ended since (the board may have changed): a fresh copy, no failure.
            Some(s) if s.until.is_some_and(|u| u <= self.vm.time) => None,
            Some(s) => {
                let turn = if s.epoch == epoch { turned(s, &self.st, &self.vm) } else { None };
                if turn.is_none() {
                    self.spin.failures = (self.spin.failures + 1).min(MAX_BACKOFF);
                    self.spin.skip = (1 << self.spin.failures) - 1;
                }
                turn.map(|(d, n)| (d, n, s.until))
            }
            None => None,
        };
        let Some((period, n, until)) = turn else {
            self.spin.rest = None;
            self.spin.snapshot = Some(Snapshot { st: self.st.clone(), vm: self.vm.clone(), until: quiet_until, epoch });
            return false;
        };
        // Nothing that is not the loop's may fall within the turns jumped over: the end of this advance
        // (instructions up to and including `now` run in it), the board's quiet window (as it was at both
        // passes), a standby or freewheeling delay, the heartbeat, a timer (sampled at the ticks).
        let timers = if self.vm.enabled != 0 { self.vm.timers } else { [None; MAX_TIMERS] };
        let event = [until, quiet_until, self.drive_due().map(|(_, d)| d), self.heartbeat_expiry()]
            .into_iter()
            .chain(timers)
            .flatten()
            .min();
        let now = self.st.now;
        // Nothing is due within this advance: the loop spins on in its fixed point up to `event`, and the
        // program needs no poll before it (the deadline after this advance says so).
        self.spin.rest = event.is_none_or(|e| e > now).then_some((epoch, event));
        let bound = match event {
            Some(e) if e <= now => e,
            _ => now + Duration::from_micros(1), // instructions and ticks up to and including `now`
        };
        // The last thing the k turns do happens before `t0 + k·Δ` (an instruction) and at `m0 + k·Δ` (a
        // tick), and `m0 < t0`: so k·Δ ≤ bound − t0 keeps it all before the bound.
        let room = bound.saturating_duration_since(self.vm.time).micros();
        let k = room / period.micros();
        self.spin.failures = 0;
        if k == 0 {
            return false; // (the copy stays: the next pass is a whole number of turns after it too)
        }
        let jump = Duration::from_micros(k * period.micros());
        self.vm.time += jump;
        self.st.motion_time += jump;
        self.vm.executed += k * n;
        self.spin.restart(); // (the fixed point's `rest` stays)
        true
    }
}

/// Without the `spin-skip` feature: nothing is watched, every instruction runs.
#[cfg(not(feature = "spin-skip"))]
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Spin;

#[cfg(not(feature = "spin-skip"))]
impl Spin {
    #[inline(always)]
    pub(crate) fn arm(&mut self, _: bool) {}

    #[inline(always)]
    pub(crate) fn rest(&self, _: crate::time::Instant, _: u32) -> Option<Option<crate::time::Instant>> {
        None
    }
}

#[cfg(not(feature = "spin-skip"))]
impl<B: crate::hal::Board> super::Module<B> {
    #[inline(always)]
    pub(crate) fn spin_pass(&mut self) -> bool {
        false
    }
}

//! The simulator's shortcuts behind the firmware's hook ([`tmcl_core::hal::Hook`]), as a CPU emulator
//! puts its debugger and its speed-ups behind hooks on its bus: the firmware core knows none of them.
//!
//! - [`Breakpoints`]: a debugger's breakpoints (`tmcl debug`, `tmcl run --break`): the program stops
//!   before an address, and the next run executes it.
//! - [`LoopSkip`]: a program that spins in a fixed point jumped over in whole turns of its loop.
//!
//! # The loop skip
//!
//! A program that never waits executes an instruction every [`tmcl_core::vm::INSTRUCTION_TIME`], so an
//! hour of `Loop: GIO 255, 0 / SIO 255, 2, -1 / JA Loop` is 180 million instructions. When such a loop
//! comes back to the same address with the module's whole state as it was the turn before — but for the
//! clocks, which move with time itself — and nothing outside the program changes meanwhile, every further
//! turn does the same: the hook jumps over as many whole turns as fit before the next event, adding
//! their time and their instructions ([`Pass::skip`]), and the rest runs one by one as before.
//!
//! ## Why it is exact
//!
//! The module and its board are a deterministic machine whose next steps depend on their state and on
//! time only through
//! - the ticks, [`tmcl_core::motion::TICK`] apart from the motion controller's clock;
//! - the instants kept in the state (a timer, a standby or freewheeling delay, the heartbeat:
//!   [`Pass::next_event`]) — at the pass, and in every state a turn passes through: a turn that sets AP 204
//!   to 1 and back to 12 shows the delay of 120 ms at its passes, yet every turn cuts the current where
//!   the delay of 1 has run out, so the firmware gathers what the states between two passes name (and
//!   the tick timer's next increment after a program reads it: the clock read, not the state);
//! - the board's readings, which a quiet window ([`tmcl_core::hal::StepDriver::quiet`]) promises to keep
//!   until its end while the driver is told nothing new;
//! - the caller's `now`, where a poll ends;
//! - and whatever reaches it from outside: a host command, a library call, a change of the board through
//!   `Module::board_mut`. Every such input, and every write to the board or the EEPROM, moves the
//!   module's count of changes on ([`Pass::changes`], counted at the firmware's one seam to the board),
//!   which is the *epoch* below. `Module::board_timeline` moves the board's world on along its
//!   timeline, which the quiet windows announce.
//!
//! Two passes through the same address, with the program's clock as far after the last tick both times
//! (the same *phase*, so the ticks fall between the same instructions), with every field of the firmware
//! state and the program machine equal but those that move with time ([`Pass::turned`]), with the count
//! of changes the same, and both within the quiet window the board reported at the first: then from the
//! second pass the machine does exactly what it did from the first, shifted by Δ, for as long as none of
//! the instants above falls within. So k turns later it is in the second pass's state with the clocks
//! k·Δ on and k·n more instructions executed — which is what the hook sets. Everything the turns would
//! have done in between is undone within each turn: that is what equal states at both passes say.
//!
//! A fixed point found with nothing due before the end of the poll also tells the deadline
//! ([`Hook::program_rest`]): the program needs no poll before the next of those instants, until the count
//! of changes moves on. A caller that polls at the deadlines polls a spinning program at its events, not
//! at its instructions.
//!
//! Not covered (the program runs instruction by instruction, as the firmware does): a moving axis, a
//! reference search, a closed-loop model, a board that cannot say it is quiet, a loop whose state
//! changes from turn to turn, a WAIT in progress at the pass, single steps (command 130), and
//! tick-by-tick mode (`Module::set_exact_ticks`), the reference this is tested against — the firmware
//! calls the hook in neither of the last two.
//!
//! ## Cost
//!
//! The firmware calls the hook after every jump back; that compares a small key (address, phase,
//! registers, stack depth, handler) with the one remembered. Only when the key comes round again is the
//! whole state copied (the first time) or compared (the next), and a loop whose whole state keeps
//! changing is compared ever less often (every 2, 4, … 64th time the key comes round).

use std::any::Any;
use tmcl_core::hal::{DriveState, Pass, PassKey, Quiet};
use tmcl_core::time::{Duration, Instant};
use tmcl_core::vm::MAX_PROGRAM;

#[allow(unused_imports)] // (named in the module docs)
use tmcl_core::hal::Hook;

/// A key whose pass has not come round in this many instructions is given up for the next pass: a
/// loop's turns meet the same phase within 50 turns (a tick is 50 instructions), so loops of up to 160
/// instructions are found.
const REACH: u64 = 1 << 13;
/// After this many failed comparisons in a row the whole state is compared every 2⁶th time the key comes
/// round.
const MAX_BACKOFF: u32 = 6;

/// The whole state at a pass, to compare the next pass with.
#[derive(Debug)]
struct Snapshot {
    /// The firmware's save state ([`Pass::Saved`]).
    saved: Box<dyn Any + Send>,
    /// The end of the board's quiet window at the pass (`None`: quiet for good).
    until: Option<Instant>,
    /// The count of changes at the pass: a turn that changed anything is no fixed point.
    epoch: u32,
}

/// The loop skip (see the module docs).
#[derive(Debug, Default)]
pub struct LoopSkip {
    /// The key of the pass being watched and the instruction count when it was last seen.
    anchor: Option<(PassKey, u64)>,
    snapshot: Option<Snapshot>,
    failures: u32,
    /// Passes of the key to let go by before the next copy or comparison.
    skip: u32,
    /// A fixed point found at this count of changes, with nothing due before this instant (`None`:
    /// ever): the program needs no poll before it. Void once the count moves on.
    rest: Option<(u32, Option<Instant>)>,
}

impl LoopSkip {
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
    pub fn rest(&self, now: Instant, changes: u32) -> Option<Option<Instant>> {
        self.rest.filter(|(at, r)| *at == changes && r.is_none_or(|e| e > now)).map(|(_, r)| r)
    }

    /// After a jump back: jumps over whole turns of a loop in a fixed point (see the module docs).
    /// `quiet` asks the board for motor m's quiet window at an instant with the drive state it was last
    /// given. Returns whether it jumped; then the program's and the motion controller's clocks have
    /// moved on.
    pub fn pass<P: Pass>(
        &mut self,
        pass: &mut P,
        quiet: impl FnMut(usize, Instant, &DriveState) -> Option<Quiet>,
    ) -> bool {
        self.due(pass) && self.look(pass, quiet)
    }

    /// The cheap part of a pass, at every jump back: whether its key came round and a look at the whole
    /// state is due ([`LoopSkip::look`]).
    #[inline(always)]
    pub fn due<P: Pass>(&mut self, pass: &P) -> bool {
        let Some(key) = pass.key() else { return false };
        let executed = pass.executed();
        match &mut self.anchor {
            Some((k, seen)) if *k == key => *seen = executed,
            Some((_, seen)) if executed - *seen <= REACH => return false,
            anchor => {
                *anchor = Some((key, executed));
                self.snapshot = None;
                return false;
            }
        }
        if self.skip > 0 {
            self.skip -= 1;
            return false;
        }
        true
    }

    /// A pass whose look is due ([`LoopSkip::due`]): copies the whole state, or compares it with the copy
    /// and jumps over whole turns. Returns whether it jumped.
    pub fn look<P: Pass>(
        &mut self,
        pass: &mut P,
        mut quiet: impl FnMut(usize, Instant, &DriveState) -> Option<Quiet>,
    ) -> bool {
        // Every axis stands, nothing ticks by itself, and the board is quiet for each.
        let mut quiet_until: Option<Option<Instant>> = pass.standing().then_some(None);
        let motion_time = pass.motion_time();
        for m in 0..pass.motors() {
            let Some(until) = quiet_until else { break };
            quiet_until = quiet(m, motion_time, &pass.drive(m)).map(|q| match (until, q.until) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            });
        }
        let Some(quiet_until) = quiet_until else {
            self.snapshot = None;
            return false;
        };
        let epoch = pass.changes();
        let time = pass.time();
        let next_event = pass.next_event();
        let turn = match &self.snapshot {
            // The copy's quiet window has ended since (the board may have changed): a fresh copy, no failure.
            Some(s) if s.until.is_some_and(|u| u <= time) => None,
            // An instant named since the copy has passed (nothing showed it): what the turns after it name
            // is not known from these. A fresh copy gathers them anew, no failure.
            Some(_) if next_event.is_some_and(|e| e <= time) => None,
            Some(s) => {
                let turn = match s.saved.downcast_ref::<P::Saved>() {
                    Some(saved) if s.epoch == epoch => pass.turned(saved),
                    _ => None,
                };
                if turn.is_none() {
                    self.failures = (self.failures + 1).min(MAX_BACKOFF);
                    self.skip = (1 << self.failures) - 1;
                }
                turn.map(|(d, n)| (d, n, s.until))
            }
            None => None,
        };
        let Some((period, n, until)) = turn else {
            self.rest = None;
            match &mut self.snapshot {
                // (The copy of the last pass, overwritten in place: no allocation per copy.)
                Some(s) if s.saved.is::<P::Saved>() => {
                    *s.saved.downcast_mut::<P::Saved>().expect("checked") = pass.save();
                    s.until = quiet_until;
                    s.epoch = epoch;
                }
                s => *s = Some(Snapshot { saved: Box::new(pass.save()), until: quiet_until, epoch }),
            }
            return false;
        };
        // Nothing that is not the loop's may fall within the turns jumped over: the end of this poll
        // (instructions up to and including `now` run in it), the board's quiet window (as it was at both
        // passes), a standby or freewheeling delay, the heartbeat, a timer (sampled at the ticks).
        let event = [until, quiet_until, next_event].into_iter().flatten().min();
        let now = pass.now();
        // Nothing is due within this poll: the loop spins on in its fixed point up to `event`, and the
        // program needs no poll before it (the deadline after this poll says so).
        self.rest = event.is_none_or(|e| e > now).then_some((epoch, event));
        let bound = match event {
            Some(e) if e <= now => e,
            _ => now + Duration::from_micros(1), // instructions and ticks up to and including `now`
        };
        // The last thing the k turns do happens before `t0 + k·Δ` (an instruction) and at `m0 + k·Δ` (a
        // tick), and `m0 < t0`: so k·Δ ≤ bound − t0 keeps it all before the bound.
        let room = bound.saturating_duration_since(time).micros();
        let k = room / period.micros();
        self.failures = 0;
        if k == 0 {
            return false; // (the copy stays: the next pass is a whole number of turns after it too)
        }
        pass.skip(Duration::from_micros(k * period.micros()), k * n);
        self.restart(); // (the fixed point's `rest` stays)
        true
    }
}

/// A debugger's breakpoints: the program stops before executing an address that has one; the next run
/// executes it (it passes once).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Breakpoints {
    /// Bit n: stop before executing address n.
    set: [u64; MAX_PROGRAM / 64],
    /// How many are set (none: the firmware is not asked to watch its instructions).
    count: usize,
    /// An address the next instruction passes without stopping if it is there (the breakpoint the
    /// program stopped at, or the PC a debugger resumes from); forgotten at the next instruction.
    pass: Option<u16>,
    /// The program stopped at a breakpoint and has run no instruction since.
    stopped: bool,
}

impl Default for Breakpoints {
    fn default() -> Breakpoints {
        Breakpoints { set: [0; MAX_PROGRAM / 64], count: 0, pass: None, stopped: false }
    }
}

impl Breakpoints {
    /// Sets or clears the breakpoint at `address` (one beyond program memory is ignored).
    pub fn set(&mut self, address: u16, on: bool) {
        let a = usize::from(address);
        if a < MAX_PROGRAM {
            let bit = 1u64 << (a % 64);
            let word = &mut self.set[a / 64];
            if (*word & bit != 0) != on {
                *word ^= bit;
                if on {
                    self.count += 1;
                } else {
                    self.count -= 1;
                }
            }
        }
    }

    /// Whether `address` has a breakpoint.
    pub fn has(&self, address: u16) -> bool {
        let a = usize::from(address);
        a < MAX_PROGRAM && self.set[a / 64] & (1 << (a % 64)) != 0
    }

    /// Whether any is set.
    pub fn any(&self) -> bool {
        self.count > 0
    }

    /// Whether the program stopped at a breakpoint (and has not run past one since).
    pub fn stopped_at(&self) -> bool {
        self.stopped
    }

    /// A run about to start at `pc` executes the instruction there first, whatever breakpoint sits on it:
    /// a debugger's `continue` from a breakpoint the program was stepped onto goes on, as it does after
    /// stopping there.
    pub fn resume_at(&mut self, pc: u16) {
        self.pass = Some(pc);
        self.stopped = false;
    }

    /// Before the instruction at `pc`: whether the program stops there. At a breakpoint it stops the
    /// first time and passes the next (the run that follows the stop executes it). Only a run that
    /// resumes where it stopped passes: one the debugger started elsewhere (command 129 from an
    /// address, a reset, a PC set by hand) stops at the first breakpoint it meets, even the one it
    /// stopped at before.
    pub fn stop_before(&mut self, pc: u16) -> bool {
        let resuming = self.pass.take() == Some(pc);
        self.stopped = self.has(pc) && !resuming;
        if self.stopped {
            self.pass = Some(pc);
        }
        self.stopped
    }
}

#[cfg(test)]
mod tests {
    use super::Breakpoints;

    #[test]
    fn a_breakpoint_stops_once_and_the_resumed_run_passes_it() {
        let mut b = Breakpoints::default();
        b.set(5, true);
        assert!(b.stop_before(5) && b.stopped_at());
        assert!(!b.stop_before(5), "the run that resumes at the stop executes the instruction");
        assert!(!b.stopped_at());
        assert!(b.stop_before(5), "the next time round it stops again");
    }

    #[test]
    fn a_run_started_elsewhere_after_a_stop_stops_at_the_first_breakpoint() {
        let mut b = Breakpoints::default();
        b.set(5, true);
        b.set(9, true);
        assert!(b.stop_before(5));
        // The debugger moves the PC (129 from address 9): the stop at 5 is not this run's to pass.
        assert!(b.stop_before(9), "stops at 9, the first breakpoint of the new run");
        assert!(!b.stop_before(9));
        // Moved back onto the old stop after passing other instructions: it stops there again.
        assert!(!b.stop_before(6));
        assert!(b.stop_before(5));
    }

    #[test]
    fn a_run_resumed_on_a_breakpoint_executes_it_first() {
        let mut b = Breakpoints::default();
        b.set(5, true);
        b.resume_at(5);
        assert!(!b.stopped_at());
        assert!(!b.stop_before(5));
        assert!(b.stop_before(5), "the next time round it stops");
    }
}

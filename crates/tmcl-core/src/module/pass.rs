//! The module at a jump back of its program, as the board's hook sees it ([`crate::hal::Pass`]).
//!
//! The firmware calls its board's [`crate::hal::Hook::jumped_back`] after every jump back of a running
//! program within a poll, in event-driven mode, and does nothing else about it: whatever a simulator
//! makes of it (`tmcl-sim` jumps over whole turns of a loop in a fixed point) is the simulator's. What
//! only the firmware can say is here: the pass's key, what changes by itself ahead, a copy of the whole
//! state and whether a later state is that copy a whole number of turns on — every field named, so that
//! a field added to [`State`], [`Axis`] or [`Vm`] does not compile until it is decided here whether it
//! moves with time.

use super::advance::heartbeat_expiry;
use super::{Axis, State};
use crate::hal::{DriveState, Pass, PassKey};
use crate::model::{ModelSpec, Setting};
use crate::time::{Duration, Instant};
use crate::vm::{RunState, Vm};

/// The module at a jump back: its state and program machine, lent for the hook's call.
pub(crate) struct Turn<'a> {
    pub spec: &'static ModelSpec,
    pub st: &'a mut State,
    pub vm: &'a mut Vm,
    /// The count of changes at the pass (`seam.rs`).
    pub changes: u32,
    /// The earliest instant at which something changes by itself that the program's states named since
    /// the last copy (the module's `named`: gathered in `module/program.rs` and `module/advance.rs`).
    pub named: &'a mut Option<Instant>,
}

/// The whole firmware state and program machine at a pass (about 8 KiB with six motor slots).
#[derive(Debug, Clone)]
pub struct Saved {
    st: State,
    vm: Vm,
}

impl Pass for Turn<'_> {
    type Saved = Saved;

    #[inline]
    fn key(&self) -> Option<PassKey> {
        let vm = &*self.vm;
        if vm.state != RunState::Running || vm.wait.is_some() || vm.time <= self.st.motion_time {
            return None;
        }
        let r = self.st.regs;
        Some(PassKey {
            pc: vm.pc,
            phase: (vm.time - self.st.motion_time).micros(),
            registers: (r.accumulator, r.x, r.flags),
            sp: vm.sp,
            handler: vm.handler.is_some(),
        })
    }

    #[inline]
    fn executed(&self) -> u64 {
        self.vm.executed
    }

    fn time(&self) -> Instant {
        self.vm.time
    }

    fn motion_time(&self) -> Instant {
        self.st.motion_time
    }

    fn now(&self) -> Instant {
        self.st.now
    }

    fn changes(&self) -> u32 {
        self.changes
    }

    fn motors(&self) -> usize {
        self.st.axes.count()
    }

    fn standing(&self) -> bool {
        !self.spec.axis.has(Setting::ClosedLoop)
            && self.st.axes.iter().all(|a| a.is_standing() && a.standstill_since.is_some())
    }

    fn drive(&self, motor: usize) -> DriveState {
        self.st.axes.get(motor).and_then(|a| a.last_drive).unwrap_or_default()
    }

    fn next_event(&self) -> Option<Instant> {
        // The pass's own, and what the states between the copy and the pass named: a turn may pass through
        // settings the pass does not show, and every later turn passes through them again.
        [self.st.axes.drive_due().map(|(_, d)| d), heartbeat_expiry(self.st), timers(self.vm), *self.named]
            .into_iter()
            .flatten()
            .min()
    }

    fn save(&mut self) -> Saved {
        // The instants named from here on are those of the turns after this copy.
        *self.named = None;
        Saved { st: self.st.clone(), vm: self.vm.clone() }
    }

    fn turned(&self, saved: &Saved) -> Option<(Duration, u64)> {
        turned(saved, self.st, self.vm)
    }

    fn skip(&mut self, by: Duration, instructions: u64) {
        self.vm.time += by;
        self.st.motion_time += by;
        self.vm.executed += instructions;
    }
}

/// The earliest enabled timer's expiry: timers fire only while interrupts are enabled (they are sampled at
/// the ticks).
fn timers(vm: &Vm) -> Option<Instant> {
    vm.timers.iter().flatten().filter(|_| vm.enabled != 0).copied().min()
}

/// What the global settings and the program machine name (after a program's SGP, AGP, RSGP, EI or DI):
/// the heartbeat's expiry (GP 68) and the earliest enabled timer (bank 3).
pub(crate) fn named_by_globals(st: &State, vm: &Vm) -> Option<Instant> {
    [heartbeat_expiry(st), timers(vm)].into_iter().flatten().min()
}

/// Whether `st`/`vm` is `a` a whole number of turns later: every field equal but the clocks, which are Δ
/// on (the program's and the motion controller's by the same Δ > 0). Returns (Δ, instructions per Δ).
fn turned(a: &Saved, st: &State, vm: &Vm) -> Option<(Duration, u64)> {
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
        && *refusals == vm.refusals;
    if !same_vm {
        return None;
    }
    let State {
        axes,
        banks,
        regs,
        host_regs,
        event,
        ports,
        asking_port,
        // Moves with time: Δ (the same phase).
        motion_time,
        // The caller's time: the same within a poll, and not the module's state.
        now: _,
        last_command,
        heartbeat_tripped,
        outputs,
        active_baud,
        tmc428,
    } = &a.st;
    let same = *motion_time + shift == st.motion_time
        && axes.count() == st.axes.count()
        && axes.iter().zip(st.axes.iter()).all(|(a, b)| same_axis(a, b))
        && *banks == st.banks
        && *regs == st.regs
        && *host_regs == st.host_regs
        && *event == st.event
        && *ports == st.ports
        && *asking_port == st.asking_port
        && *last_command == st.last_command
        && *heartbeat_tripped == st.heartbeat_tripped
        && *outputs == st.outputs
        && *active_baud == st.active_baud
        && *tmc428 == st.tmc428;
    same.then_some((shift, n))
}

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

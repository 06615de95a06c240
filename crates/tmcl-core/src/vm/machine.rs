//! The program machine's cycle: between two instructions it services an interrupt and looks at a
//! WAIT in progress; then it fetches the decoded cell at the PC and runs it (PD28-1021 manual §3.6,
//! §3.7.16–3.7.35).
//!
//! The machine reaches the rest of the module as a CPU reaches its bus, through [`Bus`]: a command for
//! the module (motion, parameters, I/O, interrupt enables) goes out as a [`Command`] and comes back as
//! the value it read or the status a host would have got; a WAIT asks whether its condition holds. The
//! flow and arithmetic instructions (COMP, JC, JA, CSUB, RSUB, WAIT, STOP, VECT, RETI, CALC, CALCX) are
//! the machine's own and never leave it. Each cycle returns what happened ([`Step`]); the run state
//! changes only through [`Vm::set_state`].

use super::decode::Op;
use super::{alu, flags, Context, Program, Registers, RunState, Vm, Wait, INSTRUCTION_TIME, NO_VECTOR, STACK_DEPTH};
use super::{MAX_VECTORS, WAIT_TICK};
use crate::model::{Interrupts, GLOBAL_INTERRUPTS};
use crate::time::{Duration, Instant};
use tmcl_wire::{Command, Status, WaitCondition};

/// The program machine's own parts, lent by its bus for the span of a cycle between two bus requests.
pub(crate) struct Parts<'a> {
    /// Run state, PC, stack, interrupts.
    pub vm: &'a mut Vm,
    /// The program's registers.
    pub regs: &'a mut Registers,
    /// Program memory, decoded.
    pub program: &'a Program,
}

/// What the program machine needs of the module it runs in.
pub(crate) trait Bus {
    /// The machine's own parts (the bus holds them, as a module holds its components).
    fn parts(&mut self) -> Parts<'_>;
    /// Executes a command of the module for the program at `now`: the value it reads (a command that
    /// reads none gives any value), or the status a host would have got for it.
    fn execute(&mut self, command: Command, now: Instant) -> Result<i32, Status>;
    /// Whether a WAIT has ended at `now`: `Some(false)` its condition holds, `Some(true)` it timed out
    /// (ETO), `None` not yet.
    fn wait_over(&mut self, wait: &Wait, now: Instant) -> Option<bool>;
    /// After a command for the module at `now`: whether the module must act before the next instruction
    /// (the board hears of a change at its instant), so that the machine returns to it.
    fn must_act(&self, now: Instant) -> bool;
    /// After a jump back (the PC not past where it was): the simulator's hook may move the program on by
    /// whole turns of a loop (`hal::Hook::jumped_back`). Returns whether it did: then the clocks have
    /// moved on.
    fn jumped_back(&mut self) -> bool;
    /// Whether to ask [`Bus::stop_before`] before each instruction of this run (`hal::Hook`).
    fn watches_instructions(&self) -> bool;
    /// Before the instruction at `pc`: whether the program stops there (`hal::Hook::stop_before`).
    fn stop_before(&mut self, pc: u16) -> bool;
}

/// What one instruction did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Step {
    /// It ran; the PC has moved on (to the next cell, a jump target, a handler, ...).
    Executed,
    /// It went to the module ([`Bus::execute`]): `Ok` it ran, `Err` the module refused it with the status
    /// a host would have got — skipped, noted in [`super::Refusals`], the program goes on.
    Commanded(Result<(), Status>),
    /// The machine refused it (a division by 0, status 4): skipped and noted as the module's refusals.
    Refused(Status),
    /// A WAIT began and holds the PC until its condition or its time comes.
    Waiting,
    /// The program stopped (STOP, a cell that does not run on this model, the end of memory).
    Stopped,
}

impl Vm {
    /// Enters the handler of the highest-priority pending interrupt, if allowed (between instructions).
    #[inline(always)]
    pub(crate) fn service_interrupts(&mut self, regs: &Registers) {
        if self.pending == 0 || !self.global || self.handler.is_some() {
            return;
        }
        let n = self.pending.trailing_zeros() as u8; // lower number = higher priority (§3.7.34)
        self.pending &= !(1 << n);
        let Some(address) = self.vector(n) else { return };
        self.handler = Some(Context { pc: self.pc, regs: *regs, wait: self.wait.take() });
        self.pc = address;
    }

    /// Raises interrupt `n` if it is enabled and has a vector (see the module docs).
    pub(crate) fn raise_interrupt(&mut self, n: u8) {
        if usize::from(n) < MAX_VECTORS && self.enabled & (1 << n) != 0 && self.vector(n).is_some() {
            self.pending |= 1 << n;
        }
    }

    /// EI n / DI n (§3.7.32, §3.7.33): interrupt n of the model's table (§3.6.6.1, Table 12), or 255 =
    /// globally; DI n also drops n's pending request. A number the model has no interrupt for: status 3
    /// (wrong type: the type byte names it).
    pub(crate) fn enable_interrupt(&mut self, irqs: &Interrupts, n: u8, on: bool) -> Result<(), Status> {
        if n == GLOBAL_INTERRUPTS {
            self.global = on;
        } else if irqs.find(n).is_some() {
            let bit = 1u64 << n;
            self.enabled = if on { self.enabled | bit } else { self.enabled & !bit };
            if !on {
                self.pending &= !bit;
            }
        } else {
            return Err(Status::WrongType);
        }
        Ok(())
    }

    /// VECT n, address from the host (§3.7.34, on a model whose firmware takes it in direct mode,
    /// `ModelDesc::host_vect`): the vector of interrupt n, as a program's VECT sets it. An interrupt the
    /// model lacks: status 3 (as EI); an address outside program memory (`program_memory` cells): status 4.
    pub(crate) fn set_vector(
        &mut self,
        irqs: &Interrupts,
        n: u8,
        address: i32,
        program_memory: u16,
    ) -> Result<(), Status> {
        if irqs.find(n).is_none() {
            return Err(Status::WrongType);
        }
        let to = u16::try_from(address)
            .ok()
            .filter(|a| usize::from(*a) < usize::from(program_memory))
            .ok_or(Status::InvalidValue)?;
        let slot = self.vectors.get_mut(usize::from(n)).ok_or(Status::WrongType)?;
        *slot = to;
        Ok(())
    }

    /// A WAIT that has ended: ETO if it timed out, the PC past it.
    #[inline]
    pub(crate) fn end_wait(&mut self, regs: &mut Registers, timeout: bool) {
        if timeout {
            regs.flags |= flags::TIMEOUT;
        }
        self.wait = None;
        self.pc = self.pc.wrapping_add(1);
    }
}

/// Runs the program up to (not including) `limit`, at most `budget` instructions: each cycle services
/// an interrupt, looks at a WAIT in progress and asks the bus whether to stop before the instruction
/// (a simulator's breakpoint, when it watches the instructions), then runs the instruction at the PC.
/// Returns whether the module jumped over turns of a loop ([`Bus::jumped_back`]); then the clocks have
/// moved on, past `limit`. It returns early after a command the module must act on ([`Bus::must_act`]).
#[inline(always)]
pub(crate) fn run<B: Bus>(bus: &mut B, limit: Instant, budget: &mut u32) -> bool {
    // Whether the bus watches the instructions (a simulator's breakpoints): that changes only from outside,
    // between runs; asked once, when the first instruction is due (a run that only finds its WAIT going on
    // does not pay for it).
    let mut watched: Option<bool> = None;
    loop {
        let Parts { vm, regs, .. } = bus.parts();
        if vm.state != RunState::Running || vm.time >= limit || *budget == 0 {
            return false;
        }
        let t = vm.time;
        vm.service_interrupts(regs);
        if let Some(wait) = vm.wait {
            match bus.wait_over(&wait, t) {
                Some(timeout) => {
                    let Parts { vm, regs, .. } = bus.parts();
                    vm.end_wait(regs, timeout);
                }
                None => {
                    // Sleep until the wait can end by time, or to the limit (motion may end it). A wait that
                    // has not ended has its end after `t`, so this always moves on.
                    bus.parts().vm.time = wait.until.unwrap_or(limit).min(limit).max(t + Duration::from_micros(1));
                    continue;
                }
            }
        }
        let watched = *watched.get_or_insert_with(|| bus.watches_instructions());
        if !watched {
            // A run of plain instructions: nothing happens between two of them but the clock (no interrupt
            // becomes serviceable, no WAIT, the run state stays), so only the limit, the budget and the
            // jumps back are looked at. `fit`: the instructions that fit before the limit and the budget.
            let fit = (limit - t).micros().div_ceil(INSTRUCTION_TIME.micros()).min(u64::from(*budget)) as u32;
            let mut left = fit;
            loop {
                let Parts { vm, regs, program } = bus.parts();
                let pc = vm.pc;
                let Some(op) = program.op(pc).filter(|op| op.is_plain()) else { break };
                let now = vm.time;
                plain(vm, regs, program, op, pc, now);
                vm.time = now + INSTRUCTION_TIME;
                vm.executed += 1;
                left -= 1;
                if vm.pc <= pc && bus.jumped_back() {
                    *budget -= fit - left;
                    return true;
                }
                if left == 0 {
                    break;
                }
            }
            *budget -= fit - left;
            if left != fit {
                continue; // (the next instruction is not plain, or the run is over: looked at from the top)
            }
        }
        if watched {
            let pc = bus.parts().vm.pc;
            if bus.stop_before(pc) {
                // Stop before the instruction, as command 128 would.
                bus.parts().vm.set_state(RunState::Stopped);
                return false;
            }
        }
        let vm = bus.parts().vm;
        vm.executed += 1;
        *budget -= 1;
        let pc = vm.pc;
        let step = execute(bus, t);
        let vm = bus.parts().vm;
        vm.time = t + INSTRUCTION_TIME;
        if let Step::Commanded(_) = step {
            if bus.must_act(t) {
                return false; // the board hears of it before the next instruction
            }
        }
        if bus.parts().vm.pc <= pc && bus.jumped_back() {
            return true;
        }
    }
}

/// Executes the instruction at the PC at `now` (fetch the decoded cell, run it).
#[inline(always)]
fn execute<B: Bus>(bus: &mut B, now: Instant) -> Step {
    let Parts { vm, regs, program } = bus.parts();
    let pc = vm.pc;
    let Some((op, cell)) = program.fetch(pc) else {
        vm.set_state(RunState::Stopped); // ran off the end of memory
        return Step::Stopped;
    };
    if op.is_plain() {
        return plain(vm, regs, program, op, pc, now);
    }
    let mut next = pc.wrapping_add(1);
    match op {
        // Opcode 0 (empty memory), garbage, a command the model lacks, a control command: the program
        // ends. §3.7.23 STOP likewise.
        Op::End | Op::Stop => {
            vm.set_state(RunState::Stopped);
            return Step::Stopped;
        }
        // §3.7.22 WAIT: waiting is a state; the PC stays on the WAIT until it ends. The motor byte names the
        // motor POS, REFSW, LIMSW and RFS watch.
        Op::Wait => {
            let ticks = if cell.value == -1 { regs.accumulator } else { cell.value };
            // −1 takes the value from A for every condition (§3.7.22 shows it only for TICKS); a negative
            // value, which the manual forbids without saying what it does, waits no time (TICKS) or has no
            // timeout (the others).
            let span = Duration::from_micros(WAIT_TICK.micros() * ticks.max(0) as u64);
            let condition = WaitCondition::from_code(cell.kind).unwrap_or(WaitCondition::Ticks);
            let until = match condition {
                WaitCondition::Ticks => Some(now + span),
                _ if ticks > 0 => Some(now + span),
                _ => None,
            };
            let wait = Wait { condition, motor: cell.motor, until };
            let over = bus.wait_over(&wait, now);
            let Parts { vm, regs, .. } = bus.parts();
            return match over {
                Some(timeout) => {
                    if timeout {
                        regs.flags |= flags::TIMEOUT;
                    }
                    vm.pc = next;
                    Step::Executed
                }
                None => {
                    vm.wait = Some(wait);
                    Step::Waiting
                }
            };
        }
        // §3.7.35 RETI: restores A, X, flags and the PC (and a preempted WAIT).
        Op::Reti => {
            if let Some(ctx) = vm.handler.take() {
                *regs = ctx.regs;
                vm.wait = ctx.wait;
                next = ctx.pc;
            }
        }
        // (Run by `plain` above.)
        Op::Comp | Op::Jc | Op::Ja | Op::Csub | Op::Rsub | Op::Pass | Op::Vect | Op::Calc | Op::Calcx => {}
        // The rest of the module. §3.6.5: in standalone mode a command that reads a value loads the
        // accumulator (FW V1.35: RFS STATUS too, setting the flags).
        Op::Command | Op::Load => {
            let Ok(command) = Command::decode(cell) else {
                vm.set_state(RunState::Stopped); // (cannot happen: decoded when written)
                return Step::Stopped;
            };
            let done = bus.execute(command, now);
            let Parts { vm, regs, .. } = bus.parts();
            vm.pc = next;
            return match done {
                Ok(v) => {
                    if op == Op::Load {
                        regs.load(v);
                    }
                    Step::Commanded(Ok(()))
                }
                // Refused: skipped, the program goes on; noted for a simulator (`vm/refusal.rs`).
                Err(status) => {
                    vm.refusals.note(now, pc, cell, status);
                    Step::Commanded(Err(status))
                }
            };
        }
    }
    vm.pc = next;
    Step::Executed
}

/// Runs one of the machine's own plain instructions ([`Op::is_plain`]) at `pc`, at `now`.
#[inline(always)]
fn plain(vm: &mut Vm, regs: &mut Registers, program: &Program, op: Op, pc: u16, now: Instant) -> Step {
    let cell = program.cells[usize::from(pc)];
    let mut next = pc.wrapping_add(1);
    match op {
        // §3.7.17 COMP: flags from A − operand.
        Op::Comp => alu::comp(regs, cell.value),
        // §3.7.18 JC.
        Op::Jc => {
            if alu::condition(regs.flags, cell.kind) {
                next = jump(cell.value);
            }
        }
        // §3.7.19 JA.
        Op::Ja => next = jump(cell.value),
        // §3.7.20 CSUB: ignored when the stack is full.
        Op::Csub => {
            if usize::from(vm.sp) < STACK_DEPTH {
                vm.stack[usize::from(vm.sp)] = next;
                vm.sp += 1;
                next = jump(cell.value);
            }
        }
        // §3.7.21 RSUB: ignored when the stack is empty.
        Op::Rsub => {
            if vm.sp > 0 {
                vm.sp -= 1;
                next = vm.stack[usize::from(vm.sp)];
            }
        }
        // A WAIT for a motor the model lacks is passed over like a command with status 4 (our decision).
        Op::Pass => {}
        // §3.7.34 VECT.
        Op::Vect => {
            if let Some(v) = vm.vectors.get_mut(usize::from(cell.kind)) {
                *v = u16::try_from(cell.value).unwrap_or(NO_VECTOR);
            }
        }
        // §3.7.16 CALC, §3.7.28 CALCX on the program's registers; a division by 0 is refused.
        Op::Calc | Op::Calcx => {
            let done =
                if op == Op::Calc { alu::calc(regs, cell.kind, cell.value) } else { alu::calcx(regs, cell.kind) };
            vm.pc = next;
            if let Err(status) = done {
                vm.refusals.note(now, pc, cell, status);
                return Step::Refused(status);
            }
            return Step::Executed;
        }
        // (Not plain: run by `execute`.)
        Op::End | Op::Stop | Op::Wait | Op::Reti | Op::Command | Op::Load => {}
    }
    vm.pc = next;
    Step::Executed
}

/// A jump target from a value: out-of-range targets land past memory, which stops the program.
#[inline(always)]
fn jump(address: i32) -> u16 {
    u16::try_from(address).unwrap_or(u16::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_wire::{CalcOp, Condition};

    /// A bus with nothing behind it but a log: the machine runs without a module.
    struct Bench {
        vm: Vm,
        regs: Registers,
        program: Program,
        commands: std::vec::Vec<Command>,
        jumps_back: u32,
        /// The hook's breakpoint: stop before this address (every time it is asked).
        stop_at: Option<u16>,
        /// The addresses the machine asked about.
        asked: std::vec::Vec<u16>,
    }

    impl Bus for Bench {
        fn parts(&mut self) -> Parts<'_> {
            Parts { vm: &mut self.vm, regs: &mut self.regs, program: &self.program }
        }
        fn execute(&mut self, command: Command, _: Instant) -> Result<i32, Status> {
            self.commands.push(command);
            match command {
                Command::Gap { param: 1, .. } => Ok(42),
                _ => Err(Status::InvalidValue),
            }
        }
        fn wait_over(&mut self, wait: &Wait, now: Instant) -> Option<bool> {
            wait.until.is_some_and(|u| now >= u).then_some(false)
        }
        fn must_act(&self, _: Instant) -> bool {
            false
        }
        fn jumped_back(&mut self) -> bool {
            self.jumps_back += 1;
            false
        }
        fn watches_instructions(&self) -> bool {
            self.stop_at.is_some()
        }
        fn stop_before(&mut self, pc: u16) -> bool {
            self.asked.push(pc);
            self.stop_at == Some(pc)
        }
    }

    fn bench(program: &[Command]) -> Bench {
        let spec = crate::model::MODELS[0];
        let mut b = Bench {
            vm: Vm::default(),
            regs: Registers::default(),
            program: Program::default(),
            commands: std::vec::Vec::new(),
            jumps_back: 0,
            stop_at: None,
            asked: std::vec::Vec::new(),
        };
        for (a, c) in program.iter().enumerate() {
            b.program.set(a, c.encode(), spec);
        }
        b.vm.set_state(RunState::Running);
        b
    }

    #[test]
    fn the_machine_asks_the_bus_before_each_instruction_only_when_it_watches_them() {
        let program = [
            Command::Calc { op: CalcOp::Add, operand: 1 },
            Command::Calc { op: CalcOp::Add, operand: 1 },
            Command::Calc { op: CalcOp::Add, operand: 1 },
            Command::Stop,
        ];
        let mut b = bench(&program);
        run(&mut b, Instant::from_millis(1), &mut 100);
        assert!(b.asked.is_empty(), "nothing watched: the bus is not asked");
        assert_eq!((b.regs.accumulator, b.vm.state()), (3, RunState::Stopped));
        let mut b = bench(&program);
        b.stop_at = Some(2);
        run(&mut b, Instant::from_millis(1), &mut 100);
        assert_eq!(b.asked, [0, 1, 2], "asked before each instruction, up to the stop");
        assert_eq!((b.vm.pc, b.regs.accumulator, b.vm.state()), (2, 2, RunState::Stopped), "stopped before it");
        assert_eq!(b.vm.executed, 2);
    }

    #[test]
    fn the_machine_runs_its_own_instructions_and_asks_the_bus_for_the_rest() {
        let mut b = bench(&[
            Command::Calc { op: CalcOp::Add, operand: 1 },
            Command::Comp { operand: 3 },
            Command::Jc { condition: Condition::Lower, address: 0 },
            Command::Gap { param: 1, motor: 0 },
            Command::Sap { param: 4, motor: 0, value: -5 },
            Command::Calc { op: CalcOp::Div, operand: 0 },
            Command::Stop,
        ]);
        let mut budget = 100;
        assert!(!run(&mut b, Instant::from_secs(1), &mut budget));
        // Three turns of the loop (9), GAP, SAP, CALC DIV, STOP; two jumps back, and STOP leaves the PC
        // where it was (the hook sees the machine stopped).
        assert_eq!((b.vm.executed(), budget, b.jumps_back), (13, 87, 3));
        assert_eq!(b.vm.state(), RunState::Stopped);
        assert_eq!(b.vm.time, Instant::from_micros(13 * 20));
        assert_eq!(b.regs.accumulator, 42, "GAP loads the accumulator; the refused CALC DIV leaves it");
        assert_eq!(b.commands, [Command::Gap { param: 1, motor: 0 }, Command::Sap { param: 4, motor: 0, value: -5 }]);
        let refused: std::vec::Vec<(u16, Status)> = b.vm.refusals().since(0).map(|r| (r.pc, r.status)).collect();
        assert_eq!(refused, [(4, Status::InvalidValue), (5, Status::InvalidValue)]);
    }

    #[test]
    fn a_wait_is_a_state_and_the_limit_and_budget_hold() {
        let mut b =
            bench(&[Command::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 2 }, Command::Ja { address: 1 }]);
        let mut budget = 100;
        run(&mut b, Instant::from_millis(5), &mut budget);
        assert_eq!((b.vm.pc, b.vm.wait.map(|w| w.until)), (0, Some(Some(Instant::from_millis(20)))));
        assert_eq!(b.vm.time, Instant::from_millis(5), "asleep up to the limit");
        run(&mut b, Instant::from_millis(21), &mut budget);
        // The WAIT ends at 20 ms, then JA runs at 20.00 and 20.02 ms ... up to the limit: 50 of them, budget
        // allowing; then the budget ends a run.
        assert_eq!((b.vm.wait, b.vm.executed()), (None, 51));
        let mut budget = 3;
        run(&mut b, Instant::from_secs(1), &mut budget);
        assert_eq!((b.vm.executed(), budget), (54, 0));
    }
}

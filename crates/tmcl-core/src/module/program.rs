//! Running programs on the module: the module as the program machine's bus (`vm::Bus`: the commands a
//! program gives, the WAIT conditions, the hooks), the interrupt sources, and the control commands
//! 128–135 (the machine itself, its state and its cycle, is [`crate::vm`]'s).

use super::pass::{named_by_globals, Turn};
use super::{Module, Origin};
use crate::hal::prelude::*;
use crate::hal::{Board, Nvm};
use crate::model::{ModelSpec, Setting, Source};
use crate::param::banks::Banks;
use crate::param::{persist, Role};
use crate::time::{Duration, Instant};
use crate::vm::{self, Bus, Parts, Program, Registers, RunState, Vm, Wait, EMPTY, INSTRUCTION_TIME, MAX_PROGRAM};
use tmcl_model::capacity::MAX_MOTORS;
use tmcl_wire::{Command, Instruction, Status, WaitCondition, FRAME_LEN};

impl<B: Board> Module<B> {
    /// The program machine.
    pub fn vm(&self) -> &Vm {
        &self.vm
    }

    /// Program memory.
    pub fn program(&self) -> &Program {
        &self.program
    }

    /// Loads program memory from the EEPROM (start-up).
    pub(crate) fn read_program(&mut self) {
        let (spec, program) = (self.spec, &mut self.program);
        persist::load_program(&mut self.board, spec, program.end(), |address, i| {
            if i == EMPTY && program.get(address) == Some(&EMPTY) {
                return; // already so (a fresh module, or an empty cell before and after a restart)
            }
            program.set(address, i, spec);
        });
    }

    /// Runs the program up to (not including) `limit`, at most `budget` instructions. Returns whether the
    /// board's hook moved it on by whole turns of a loop (`hal::Hook::jumped_back`): then the program's
    /// and the motion controller's clocks have moved on, past `limit`.
    pub(crate) fn run_program(&mut self, limit: Instant, budget: &mut u32) -> bool {
        vm::run(self, limit, budget)
    }

    /// Whether a wait has ended at `now`: `Some(false)` met, `Some(true)` timed out (ETO), `None` not yet.
    fn wait_done(&mut self, wait: Wait, now: Instant) -> Option<bool> {
        let m = usize::from(wait.motor);
        let met = match wait.condition {
            WaitCondition::Ticks => return wait.until.is_some_and(|u| now >= u).then_some(false),
            WaitCondition::Pos => self.motor_at(m).target_reached() && self.st.axes[m].ramp.velocity() == 0,
            // WAIT REFSW: the reference (home) switch; WAIT LIMSW: a limit (stop) switch (§3.7.22).
            WaitCondition::RefSw => self.motor_at(m).switches().2,
            WaitCondition::LimSw => {
                let (l, r, _) = self.motor_at(m).switches();
                l || r
            }
            WaitCondition::Rfs => !self.st.axes[m].reference.is_active(),
        };
        if met {
            Some(false)
        } else if wait.until.is_some_and(|u| now >= u) {
            Some(true)
        } else {
            None
        }
    }

    /// Raises interrupt `n` if it is enabled and has a vector (see [`crate::vm`]).
    pub(crate) fn raise_interrupt(&mut self, n: u8) {
        self.vm.raise_interrupt(n);
    }

    /// Samples the interrupt sources at a motion tick (timers, target reached, switch and input changes),
    /// as the model's vector table names them.
    pub(crate) fn sample_interrupts(&mut self, t: Instant) {
        let irqs = &self.spec.interrupts;
        for i in 0..self.vm.timers.len() {
            if let Some(due) = self.vm.timers[i] {
                if t >= due {
                    let n = irqs.timer(i);
                    if let Some(n) = n {
                        self.raise_interrupt(n);
                    }
                    // The next firing on the timer's grid after `t`: one period on when sampled at every
                    // tick; periods sampled at no tick (the timer not enabled while the ticks are jumped
                    // over) are skipped, so the grid does not depend on when it was sampled.
                    let period = n.map_or(0, |n| self.interrupt_config(n) as u32);
                    self.vm.timers[i] = (period > 0).then(|| {
                        let period = u64::from(period) * 1000;
                        due + Duration::from_micros(((t - due).micros() / period + 1).saturating_mul(period))
                    });
                }
            }
        }
        // Target reached, per motor: an edge of "standing at the target in position mode".
        let mut reached_now = 0u8;
        for m in 0..self.st.axes.count() {
            let ramp = &self.st.axes[m].ramp;
            let reached =
                ramp.mode == crate::motion::Mode::Position && ramp.is_idle() && self.motor_at(m).target_reached();
            if reached {
                reached_now |= 1 << m;
                if self.vm.was_reached & (1 << m) == 0 {
                    if let Some(n) = irqs.target_reached(m) {
                        self.raise_interrupt(n);
                    }
                }
            }
        }
        self.vm.was_reached = reached_now;
        let watched = self.vm.enabled & irqs.levels_mask;
        if watched == 0 {
            self.vm.last_levels = None;
            return;
        }
        let mut stops = [(false, false); MAX_MOTORS as usize];
        for (m, stop) in stops.iter_mut().enumerate().take(self.st.axes.count()) {
            let (left, right, _) = self.motor_at(m).switches();
            *stop = (left, right);
        }
        let inputs = self.board.digital_inputs();
        let mut levels = 0u64;
        // Every level source is sampled (not only the enabled ones), so that one enabled later compares
        // with its real level.
        for d in irqs.list.iter().filter(|d| d.source.is_level()) {
            let level = match d.source {
                Source::LeftStop(m) => stops.get(usize::from(m)).is_some_and(|s| s.0),
                Source::RightStop(m) => stops.get(usize::from(m)).is_some_and(|s| s.1),
                Source::Input(bit) => (inputs >> bit) & 1 == 1,
                _ => false,
            };
            levels |= u64::from(level) << d.number;
        }
        if let Some(last) = self.vm.last_levels {
            let mut changed = (last ^ levels) & watched;
            while changed != 0 {
                let n = changed.trailing_zeros() as u8;
                changed &= changed - 1;
                let is = levels >> n & 1 == 1;
                // Bank 3 trigger transition: 0 off, 1 low→high, 2 high→low, 3 both (§5.4).
                let fire = match self.interrupt_config(n) {
                    1 => is,
                    2 => !is,
                    3 => true,
                    _ => false,
                };
                if fire {
                    self.raise_interrupt(n);
                }
            }
        }
        self.vm.last_levels = Some(levels);
    }

    /// The value of interrupt `n`'s bank 3 configuration parameter (a timer period, a trigger
    /// transition); 0 (off) if it has none.
    fn interrupt_config(&self, n: u8) -> i32 {
        interrupt_config(self.spec, &self.st.banks, n)
    }

    /// When the program next needs to run, if it is running: its next instruction, the end of its WAIT,
    /// or at once when an interrupt is waiting to be serviced.
    pub fn program_deadline(&self) -> Option<Instant> {
        if self.vm.state != RunState::Running {
            return None;
        }
        let serviceable = self.vm.pending != 0 && self.vm.global && self.vm.handler.is_none();
        match self.vm.wait {
            // A wait that motion or switches can end is checked at every motion tick anyway.
            Some(w) if !serviceable => w.until,
            _ => Some(self.vm.time),
        }
    }

    /// The next timer interrupt, at the motion tick that samples it (timers are sampled at ticks).
    pub fn timer_deadline(&self) -> Option<Instant> {
        if self.vm.enabled & self.spec.interrupts.timers_mask == 0 {
            return None;
        }
        let due = self.vm.timers.iter().flatten().min().copied()?;
        let from = self.st.motion_time;
        let ticks = (due - from).micros().div_ceil(crate::motion::TICK.micros());
        Some(from + crate::time::Duration::from_micros(ticks * crate::motion::TICK.micros()))
    }

    /// Module time of the program's next instruction.
    pub fn program_time(&self) -> Instant {
        self.vm.time
    }

    /// After motion ticks taken at once up to `t` (a span, a jump over standing ticks): a waiting program
    /// is looked at before every tick and sleeps up to it, so ticking one by one leaves its clock at the
    /// last tick; an interrupt sampled at that tick is serviced from there, not from where the program
    /// last looked (a handler's WAIT timeout and timings start at the tick that raised it).
    pub(crate) fn waiting_program_slept_to(&mut self, t: Instant) {
        if self.vm.state == RunState::Running && self.vm.wait.is_some() {
            self.vm.time = self.vm.time.max(t);
        }
    }

    // ---- control commands (§3.7.38) -------------------------------------------------------------

    /// Loads a whole program into memory and the EEPROM from address 0 and clears the rest, as a
    /// download of it would (for tools: `tmcl run`, the debugger). Refused like command 132 when the
    /// program is protected against overwriting.
    pub fn load_program(&mut self, instructions: &[Instruction]) -> Result<(), Status> {
        self.board.input(); // a library call from outside (`seam.rs`)
        if self.protection() & 2 != 0 {
            return Err(Status::EepromLocked);
        }
        if instructions.len() > usize::from(self.spec.program_memory) {
            return Err(Status::InvalidValue);
        }
        self.vm.reset(&mut self.st.regs);
        self.vm.set_state(RunState::Stopped);
        let memory = usize::from(self.spec.program_memory).min(MAX_PROGRAM);
        for address in 0..memory {
            let i = instructions.get(address).copied().unwrap_or(EMPTY);
            if self.program.cells[address] != i {
                persist::store_program_cell(&mut self.board, self.spec, address, &i)?;
                self.program.set(address, i, self.spec);
            }
        }
        Ok(())
    }

    /// Mutable access to the program machine (a debugger's registers and PC; a change from outside).
    pub fn vm_mut(&mut self) -> &mut Vm {
        self.board.input(); // a change from outside (`seam.rs`)
        &mut self.vm
    }

    /// 130: execute one instruction.
    pub(crate) fn step_application(&mut self, now: Instant) {
        self.vm.set_state(RunState::Running);
        self.vm.time = self.vm.time.max(now);
        let mut budget = 1;
        let limit = self.vm.time + INSTRUCTION_TIME;
        // A waiting instruction is checked once; a step never blocks.
        if let Some(wait) = self.vm.wait {
            if let Some(timeout) = self.wait_done(wait, now) {
                self.vm.end_wait(&mut self.st.regs, timeout);
            }
        } else {
            self.run_program(limit, &mut budget);
        }
        if self.vm.state == RunState::Running {
            self.vm.set_state(RunState::Stepped);
        }
    }

    /// GP 81 bits: 1 = no read-back (disassembly), 2 = no overwrite.
    fn protection(&self) -> i32 {
        self.gp(Setting::CodeProtection).unwrap_or(0)
    }

    /// 132: download mode from `address`. Refused with status 5 when the program is protected against
    /// overwriting (GP 81 = 2 or 3; §5.1 does not say which status).
    pub(crate) fn start_download(&mut self, address: i32) -> Result<(), Status> {
        if self.protection() & 2 != 0 {
            return Err(Status::EepromLocked);
        }
        let a = u16::try_from(address).ok().filter(|a| *a < self.spec.program_memory).ok_or(Status::InvalidValue)?;
        self.vm.stop();
        self.vm.download = Some(a);
        Ok(())
    }

    /// In download mode: stores one instruction at the next address (status 101, §3.2.1).
    pub(crate) fn download(&mut self, instruction: Instruction) -> Result<(), Status> {
        let Some(address) = self.vm.download else { return Err(Status::InvalidCommand) };
        // The memory is full: one command past the last cell is refused with status 4 and nothing is
        // overwritten (the manuals name no status for it; 4 is what command 132 to that address answers).
        if address >= self.spec.program_memory {
            return Err(Status::InvalidValue);
        }
        // Only what a program of this model can execute is stored; anything else is refused and not stored.
        self.decode(instruction)?;
        persist::store_program_cell(&mut self.board, self.spec, usize::from(address), &instruction)?;
        self.program.set(usize::from(address), instruction, self.spec);
        self.vm.download = Some(address + 1); // at most program_memory ≤ 2048

        Ok(())
    }

    /// 134: the special reply `[host, opcode, type, motor, value (4, MSB first), checksum]`
    /// (§3.7.38 gives no format; this is the one pytrinamic's `tmcl_read_script` example reads). Refused
    /// with status 6 when the program is protected against disassembly (GP 81 = 1 or 3; §5.1 does not say
    /// which status).
    pub(crate) fn read_memory(&mut self, address: i32) -> Result<[u8; FRAME_LEN], Status> {
        if self.protection() & 1 != 0 {
            return Err(Status::NotAvailable);
        }
        let a = usize::try_from(address).ok().filter(|a| *a < usize::from(self.spec.program_memory));
        let cell = self.program.cells[a.ok_or(Status::InvalidValue)?];
        let mut raw = [0u8; FRAME_LEN];
        raw[0] = self.host_address();
        raw[1..8].copy_from_slice(&cell.to_bytes());
        raw[8] = tmcl_wire::checksum(&raw[..8]);
        Ok(raw)
    }

    /// After a start: GP 77 = 1 runs the program from address 0 (§8.7).
    pub(crate) fn auto_start(&mut self, now: Instant) {
        if self.gp_flag(Setting::AutoStart) && !self.program.is_empty() {
            self.vm.pc = 0;
            self.vm.set_state(RunState::Running);
            self.vm.time = now;
        }
    }
}

/// The value of interrupt `n`'s bank 3 configuration parameter in `banks` (a timer period, a trigger
/// transition; PD28-1021 manual §5.4); 0 (off) if it has none.
fn interrupt_config(spec: &ModelSpec, banks: &Banks, n: u8) -> i32 {
    let config = spec.interrupts.find(n).and_then(|d| d.config);
    config.and_then(|c| spec.interrupt.index(c)).map_or(0, |i| banks.interrupt[i])
}

/// Bank 3 parameter `parameter` was written (§5.4): a timer of `vm` whose period it is restarts from
/// `now`.
pub(crate) fn restart_timer(spec: &ModelSpec, banks: &Banks, vm: &mut Vm, parameter: u8, now: Instant) {
    let irqs = &spec.interrupts;
    for i in 0..vm.timers.len() {
        let Some(n) = irqs.timer(i) else { continue };
        if irqs.find(n).and_then(|d| d.config) == Some(parameter) {
            let period = interrupt_config(spec, banks, n) as u32;
            vm.timers[i] = (period > 0).then(|| now + Duration::from_millis(u64::from(period)));
        }
    }
}

/// GP 81 written from `old` to `new`: leaving protection against disassembly (1 or 3 → 0 or 2) erases
/// the program first, in the EEPROM of `nvm` and in `program`, and resets the machine `vm` with its
/// registers `regs` (PD28-1021 manual §5.1).
pub(crate) fn protection_changed(
    nvm: &mut impl Nvm,
    spec: &ModelSpec,
    program: &mut Program,
    vm: &mut Vm,
    regs: &mut Registers,
    (old, new): (i32, i32),
) -> Result<(), Status> {
    if old & 1 != 0 && new & 1 == 0 {
        persist::erase_program(nvm, spec)?;
        program.clear();
        vm.reset(regs);
        vm.set_state(RunState::Stopped);
    }
    Ok(())
}

/// The module is the program machine's bus: it lends the machine its parts and runs the commands a
/// program gives it through the one dispatcher, as a host's (see [`crate::vm::Bus`]).
impl<B: Board> Bus for Module<B> {
    #[inline(always)]
    fn parts(&mut self) -> Parts<'_> {
        Parts { vm: &mut self.vm, regs: &mut self.st.regs, program: &self.program }
    }

    #[inline]
    fn execute(&mut self, command: Command, now: Instant) -> Result<i32, Status> {
        let done = self.exec(command, now, Origin::Program);
        // What the program's state now names, for the board's hook (`module/pass.rs`): the heartbeat (bank
        // 0) and the timers (bank 3, and whether interrupts are enabled) change with these commands only;
        // a motor's delays are named at the board's update that a parameter write brings
        // (`module/advance.rs`).
        if !self.exact {
            match command {
                Command::Sgp { bank: 0 | 3, .. }
                | Command::Agp { bank: 0 | 3, .. }
                | Command::Rsgp { bank: 0 | 3, .. }
                | Command::Ei { .. }
                | Command::Di { .. } => self.name(named_by_globals(&self.st, &self.vm)),
                // A read of the tick timer (GP 132, "incremented every 1 ms", §5.1) reads the clock: what
                // the program does with it may change at its next increment, which no state holds.
                Command::Ggp { param, bank: 0 }
                    if self.spec.global.find(param).is_ok_and(|(_, d)| d.role == Role::TickTimer) =>
                {
                    self.name(Some(self.st.banks.tick_timer_changes(now)));
                }
                _ => {}
            }
        }
        match done? {
            super::Outcome::Value(v) => Ok(v),
            // (Commands with other replies are control commands, which end a program instead.)
            _ => Ok(0),
        }
    }

    #[inline]
    fn wait_over(&mut self, wait: &Wait, now: Instant) -> Option<bool> {
        self.wait_done(*wait, now)
    }

    /// A command that changed what the driver sees (a parameter, a stop) has its board update due at
    /// once (`module/advance.rs`). Only a command can bring it forward: an update due before the run is
    /// within the limit `advance` gave it.
    #[inline(always)]
    fn must_act(&self, now: Instant) -> bool {
        self.drive_due().is_some_and(|(_, d)| d <= now)
    }

    /// Within an advance, in event-driven mode: the board's hook sees the module at the jump back
    /// (`module/pass.rs`) and may move it on by whole turns.
    #[inline(always)]
    fn jumped_back(&mut self) -> bool {
        if !self.advancing || self.exact {
            return false;
        }
        let changes = self.board.changes();
        let mut turn = Turn { spec: self.spec, st: &mut self.st, vm: &mut self.vm, changes, named: &mut self.named };
        self.board.timeline().jumped_back(&mut turn)
    }

    #[inline(always)]
    fn watches_instructions(&self) -> bool {
        self.board.get().watches_instructions()
    }

    #[inline(always)]
    fn stop_before(&mut self, pc: u16) -> bool {
        self.board.timeline().stop_before(pc)
    }
}

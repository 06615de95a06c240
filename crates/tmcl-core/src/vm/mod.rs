//! The TMCL program machine: standalone mode (PD28-1021 manual §3.3, §3.6.3–3.6.6, §3.7.16–3.7.38,
//! chapter 8).
//!
//! The machine's state ([`Vm`], [`Program`], [`Registers`]) and its cycle (`machine.rs`) live here; it
//! reaches the rest of the module only through a narrow bus trait (`machine::Bus`: run a command, ask
//! whether a WAIT has ended, two hooks), which the module implements (`module/program.rs`), so nothing
//! here imports the module. Program memory is decoded once, when a cell is written (`decode.rs`), and
//! the arithmetic is shared with the host's direct-mode CALC and CALCX (`alu.rs`).
//!
//! The machine: between two instructions it services an interrupt and looks at a WAIT in progress, then
//! runs the decoded cell at the PC; each instruction reports what it did (`machine::Step`), and the run
//! state changes only through one setter (`Vm::set_state`, crate-internal). Waiting is a state
//! ([`Wait`]), never a loop. It runs a bounded number of instructions per poll, each taking
//! [`INSTRUCTION_TIME`] of simulated time.
//!
//! Decisions (the manual is silent; see docs/decisions.md):
//! - **Instruction time.** Each instruction takes 20 µs of module time (about 50 000 commands per second,
//!   the order of Trinamic's EEPROM-executing TMCL firmware), so a busy loop in a program advances
//!   simulated time, and timings such as `WAIT TICKS` relative to other code behave as on a module.
//! - **An instruction that fails** (a parameter out of range, a bad port) is skipped: the program goes on,
//!   as the firmware gives a program no status. An instruction that does not decode (an unknown opcode,
//!   empty memory = opcode 0) stops the program.
//! - **Registers.** A program has its own accumulator, X register and flags; direct-mode CALC, CALCX,
//!   AAP, AGP, ACO and `SIO 255, 2, -1` work on a separate host register set, so a host never disturbs a
//!   running program (manual §8.5).
//! - **Flags.** COMP sets zero/greater/lower from `A − operand`; every instruction that loads the
//!   accumulator (GAP, GGP, GIO, GCO, RFS STATUS, CALC, CALCX) sets them from `A − 0`. ZE ≡ EQ, NZ ≡ NE.
//! - **Interrupts.** The manual does not say how pending interrupts queue; ours: one pending bit per source, set when its event occurs while the interrupt
//!   is enabled (EI n) and has a vector; serviced between instructions, lowest number first, when
//!   interrupts are globally on (EI 255) and no handler runs (no nesting). A handler interrupts a WAIT,
//!   starting at the motion tick that raised the interrupt (a waiting program sleeps up to every tick);
//!   RETI resumes the WAIT where it was. DI n clears its pending bit. A timer fires every period (bank 3,
//!   ms) from the moment its period is set; period 0 = off. Which vectors exist and what raises each is
//!   the model's table ([`tmcl_model::Interrupts`]).

pub(crate) mod alu;
pub(crate) mod decode;
pub(crate) mod machine;
pub mod refusal;

pub(crate) use decode::Op;
pub(crate) use machine::{run, Bus, Parts};
pub use refusal::{Refusal, Refusals};

use crate::model::ModelSpec;
use crate::time::Instant;
use tmcl_wire::{Instruction, Opcode, Status, WaitCondition};

/// Program memory of the largest model, in commands (every model is checked against it at compile time).
pub use tmcl_model::capacity::MAX_PROGRAM;
use tmcl_model::capacity::MAX_TIMERS;
/// Interrupt numbers are below this (bits of a 64-bit mask; 255 = global).
pub use tmcl_model::capacity::MAX_VECTORS;
/// Subroutine stack depth (§3.7.20: "8 nesting levels").
pub const STACK_DEPTH: usize = 8;
/// Module time one instruction takes.
pub const INSTRUCTION_TIME: crate::time::Duration = crate::time::Duration::from_micros(20);
/// One WAIT tick (§3.7.22: "1 tick = 10 milliseconds").
pub const WAIT_TICK: crate::time::Duration = crate::time::Duration::from_millis(10);

pub(crate) const NO_VECTOR: u16 = u16::MAX;

/// How many instructions one call may run at most, so that a poll always returns.
pub const BUDGET: u32 = 1 << 20;

/// An empty program-memory cell: opcode 0, which marks the end of a program for host tools.
pub const EMPTY: Instruction = Instruction::new(Opcode::Unknown(0), 0, 0, 0);

/// Comparison and error flags (manual §3.7.17, §3.7.18, §3.7.31).
pub mod flags {
    /// Result of the last comparison or accumulator load was zero / equal.
    pub const ZERO: u16 = 1 << 0;
    /// Greater.
    pub const GREATER: u16 = 1 << 1;
    /// Lower.
    pub const LOWER: u16 = 1 << 2;
    /// ETO: timeout.
    pub const TIMEOUT: u16 = 1 << 8;
    /// EAL: external alarm.
    pub const ALARM: u16 = 1 << 9;
    /// EDV: deviation.
    pub const DEVIATION: u16 = 1 << 10;
    /// EPO: position error.
    pub const POSITION: u16 = 1 << 11;
    /// ESD: shutdown.
    pub const SHUTDOWN: u16 = 1 << 12;
}

/// The TMCL machine's registers (manual §3.6: accumulator, X register, flags).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Registers {
    /// The accumulator.
    pub accumulator: i32,
    /// The X register.
    pub x: i32,
    /// Flags, see [`flags`].
    pub flags: u16,
}

impl Registers {
    /// Sets zero/greater/lower from a comparison (COMP, and every load of the accumulator).
    pub(crate) fn set_compare(&mut self, ord: core::cmp::Ordering) {
        self.flags &= !(flags::ZERO | flags::GREATER | flags::LOWER);
        self.flags |= match ord {
            core::cmp::Ordering::Equal => flags::ZERO,
            core::cmp::Ordering::Greater => flags::GREATER,
            core::cmp::Ordering::Less => flags::LOWER,
        };
    }

    /// Loads the accumulator and sets the comparison flags from it, as a comparison with 0. The manual
    /// never lists which commands set the flags, but its §3.6.6.4 example jumps with `JC NZ` right after
    /// a GIO.
    #[inline(always)]
    pub(crate) fn load(&mut self, v: i32) {
        self.accumulator = v;
        self.set_compare(v.cmp(&0));
    }
}

/// The TMCL program memory, in RAM (a copy of the EEPROM's program area, written through on download),
/// decoded once.
///
/// Each cell keeps the byte image the firmware stores and command 134 reads back ([`Instruction`]), and
/// beside it one byte, its op: what the program machine does with it, decided when the cell is
/// written (a download, a store, the program read from the EEPROM at start-up) against the model — its
/// command set, its motors, the type byte's meaning. The machine then runs a cell without looking its
/// command up or checking its type byte again (the crate's `vm::decode`). The cost is one byte per cell (2 KiB for
/// 2048 cells, of which the 256 bytes of the earlier "command of the model" bits are saved).
#[derive(Debug, Clone)]
pub struct Program {
    pub(crate) cells: [Instruction; MAX_PROGRAM],
    /// What each cell does, decoded when it was written.
    ops: [Op; MAX_PROGRAM],
    /// Every cell from here on is empty.
    end: usize,
}

impl Default for Program {
    fn default() -> Program {
        Program::EMPTY
    }
}

impl Program {
    /// Empty program memory, as a constant: `Program::default()` copies it into place, where building
    /// the array of empty cells would take an 18 KiB temporary on the stack first (too much for a
    /// microcontroller port, see `firmware/`).
    const EMPTY: Program = Program { cells: [EMPTY; MAX_PROGRAM], ops: [Op::End; MAX_PROGRAM], end: 0 };

    /// Empties every cell, in place: a `Program` is 18 KiB, more than a microcontroller port can afford
    /// to build on its stack as a temporary (`*self = Program::default()` would).
    pub(crate) fn clear(&mut self) {
        self.cells.fill(EMPTY);
        self.ops.fill(Op::End);
        self.end = 0;
    }

    /// Writes cell `address` (inside memory) and decodes it once for `spec`'s model ([`decode::decode`]).
    pub(crate) fn set(&mut self, address: usize, instruction: Instruction, spec: &ModelSpec) {
        if address < MAX_PROGRAM {
            self.cells[address] = instruction;
            self.ops[address] = decode::decode(instruction, spec);
            if instruction != EMPTY {
                self.end = self.end.max(address + 1);
            }
        }
    }

    /// Every cell from this address on is empty (a bound, not necessarily the least).
    pub(crate) fn end(&self) -> usize {
        self.end
    }

    /// The decoded cell at `address` and its byte image, if inside memory.
    #[inline(always)]
    pub(crate) fn fetch(&self, address: u16) -> Option<(Op, Instruction)> {
        let a = usize::from(address);
        (a < MAX_PROGRAM).then(|| (self.ops[a], self.cells[a]))
    }

    /// The decoded op at `address`, if inside memory.
    #[inline(always)]
    pub(crate) fn op(&self, address: u16) -> Option<Op> {
        self.ops.get(usize::from(address)).copied()
    }

    /// The instruction at `address`, if inside memory.
    pub fn get(&self, address: usize) -> Option<&Instruction> {
        self.cells.get(address)
    }

    /// The whole memory.
    pub fn cells(&self) -> &[Instruction] {
        &self.cells
    }

    /// Number of cells up to and including the last non-empty one.
    pub fn len(&self) -> usize {
        self.cells[..self.end].iter().rposition(|c| *c != EMPTY).map_or(0, |i| i + 1)
    }

    /// Whether no cell is programmed.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Whether the program runs (GP 128: 0 stop, 1 run, 2 step, 3 reset).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RunState {
    /// Stopped (STOP, command 128, an instruction that does not decode, power-up without auto start).
    #[default]
    Stopped,
    /// Running (command 129, auto start).
    Running,
    /// Executed one instruction with command 130 and stopped again.
    Stepped,
    /// Reset with command 131, not started since.
    Reset,
}

impl RunState {
    /// GP 128's value.
    pub fn code(self) -> i32 {
        match self {
            RunState::Stopped => 0,
            RunState::Running => 1,
            RunState::Stepped => 2,
            RunState::Reset => 3,
        }
    }
}

/// A WAIT in progress (§3.7.22).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wait {
    /// What it waits for.
    pub condition: WaitCondition,
    /// The motor POS, REFSW, LIMSW and RFS watch (the motor byte, §3.7.22).
    pub motor: u8,
    /// TICKS: when the wait ends; others: when the timeout expires (ETO), if there is one.
    pub until: Option<Instant>,
}

/// What an interrupt handler saves (§3.6.6: "accumulator register, X register, flags"; RETI restores
/// them and the PC). A WAIT that the interrupt preempted is saved too.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Context {
    /// PC to return to.
    pub pc: u16,
    /// Registers.
    pub regs: Registers,
    /// A WAIT in progress.
    pub wait: Option<Wait>,
}

/// The program machine's state.
#[derive(Debug, Clone)]
pub struct Vm {
    /// Run state: read with [`Vm::state`]; it changes only through one setter, `Vm::set_state` (crate
    /// visible only so that a pass of the program can be compared, `module/pass.rs`).
    pub(crate) state: RunState,
    /// Program counter: the address of the next instruction (GP 130).
    pub pc: u16,
    pub(crate) stack: [u16; STACK_DEPTH],
    pub(crate) sp: u8,
    /// A WAIT in progress.
    pub wait: Option<Wait>,
    /// Module time of the next instruction.
    pub(crate) time: Instant,
    pub(crate) vectors: [u16; MAX_VECTORS],
    /// EI n bits.
    pub(crate) enabled: u64,
    /// EI 255.
    pub(crate) global: bool,
    /// Pending interrupt bits.
    pub(crate) pending: u64,
    /// The interrupted context while a handler runs.
    pub(crate) handler: Option<Context>,
    /// Next firing of the timers.
    pub(crate) timers: [Option<Instant>; MAX_TIMERS],
    /// Download mode (command 132): the next address to store at (GP 129 = 1 while set).
    pub(crate) download: Option<u16>,
    /// The levels of the switch and input interrupt sources at the last sample, bit n for vector n.
    pub(crate) last_levels: Option<u64>,
    /// The position-reached state of each motor at the last sample (bit m: motor m; its target-reached
    /// interrupt fires on the edge).
    pub(crate) was_reached: u8,
    /// Instructions executed since power-up (for traces and benchmarks).
    pub(crate) executed: u64,
    /// Instructions the module refused and skipped (for simulators; the firmware ignores it).
    pub(crate) refusals: Refusals,
}

impl Default for Vm {
    fn default() -> Vm {
        Vm {
            state: RunState::Stopped,
            pc: 0,
            stack: [0; STACK_DEPTH],
            sp: 0,
            wait: None,
            time: Instant::ZERO,
            vectors: [NO_VECTOR; MAX_VECTORS],
            enabled: 0,
            global: false,
            pending: 0,
            handler: None,
            timers: [None; MAX_TIMERS],
            download: None,
            last_levels: None,
            was_reached: u8::MAX,
            executed: 0,
            refusals: Refusals::default(),
        }
    }
}

impl Vm {
    /// The one place the run state changes (GP 128; command 128–131, STOP, an instruction that does not
    /// decode, a simulator's breakpoint, auto start): every transition of the program machine passes here.
    #[inline]
    pub(crate) fn set_state(&mut self, to: RunState) {
        self.state = to;
    }

    /// The run state (GP 128).
    #[inline(always)]
    pub fn state(&self) -> RunState {
        self.state
    }

    /// Whether instructions execute (running, not waiting).
    pub fn is_running(&self) -> bool {
        self.state == RunState::Running
    }

    /// Subroutine stack depth in use.
    pub fn stack_depth(&self) -> usize {
        usize::from(self.sp)
    }

    /// The subroutine stack, oldest first.
    pub fn stack(&self) -> &[u16] {
        &self.stack[..usize::from(self.sp)]
    }

    /// The vector of interrupt `n`, if defined.
    pub fn vector(&self, n: u8) -> Option<u16> {
        self.vectors.get(usize::from(n)).copied().filter(|v| *v != NO_VECTOR)
    }

    /// Whether interrupt `n` is enabled (EI n), or for 255 whether interrupts are globally on.
    pub fn interrupt_enabled(&self, n: u8) -> bool {
        if n == crate::model::GLOBAL_INTERRUPTS {
            self.global
        } else {
            n < MAX_VECTORS as u8 && self.enabled & (1 << n) != 0
        }
    }

    /// Whether an interrupt handler runs.
    pub fn in_handler(&self) -> bool {
        self.handler.is_some()
    }

    /// Download mode's next address.
    pub fn download_address(&self) -> Option<u16> {
        self.download
    }

    /// Command 128 (PD28-1021 manual §3.7.38): stop the program.
    pub(crate) fn stop(&mut self) {
        if self.state == RunState::Running {
            self.set_state(RunState::Stopped);
        }
    }

    /// Command 129 (§3.7.38, §8.6): run from the current address (type 0) or from `from` (type 1) at
    /// `now`; an address outside the model's `program_memory` is refused with status 4.
    pub(crate) fn run_from(&mut self, from: Option<i32>, now: Instant, program_memory: u16) -> Result<(), Status> {
        if let Some(a) = from {
            let a = u16::try_from(a).ok().filter(|a| *a < program_memory).ok_or(Status::InvalidValue)?;
            self.pc = a;
            self.wait = None;
        }
        self.set_state(RunState::Running);
        self.time = self.time.max(now);
        Ok(())
    }

    /// Command 131 (§3.7.38): stop, PC = 0, stack empty, the program's registers `regs` cleared (A = X =
    /// 0, flags).
    pub(crate) fn reset(&mut self, regs: &mut Registers) {
        self.set_state(RunState::Reset);
        self.pc = 0;
        self.sp = 0;
        self.wait = None;
        self.handler = None;
        self.pending = 0;
        *regs = Registers::default();
    }

    /// Command 133 (§3.7.38): leave download mode.
    pub(crate) fn quit_download(&mut self) {
        self.download = None;
    }

    /// Command 135 types 0/1 (§3.7.38): mode in bits 31..24 (GP 128), wait flag in bits 23..16 (1 = a
    /// WAIT is pending), and the download pointer (type 0) or the PC (type 1) in bits 15..0. The manual
    /// names the three fields but not their packing; this is ours.
    pub(crate) fn status(&self, program_counter: bool) -> i32 {
        let pointer = if program_counter { self.pc } else { self.download.unwrap_or(0) };
        (self.state.code() << 24) | (i32::from(self.wait.is_some()) << 16) | i32::from(pointer)
    }

    /// Instructions executed since power-up.
    pub fn executed(&self) -> u64 {
        self.executed
    }

    /// Instructions the module refused and skipped since power-up (see [`refusal`]).
    pub fn refusals(&self) -> &Refusals {
        &self.refusals
    }

    /// The interrupted context while a handler runs (registers with the flags, see [`flags`]).
    pub fn saved_context(&self) -> Option<&Context> {
        self.handler.as_ref()
    }
}

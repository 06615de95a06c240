//! Program memory decoded once: what the program machine does with each cell, decided when the cell is
//! written, not at every step.
//!
//! A cell's [`Op`] is decided against the model when the cell is written — a download (command 132's
//! mode), `Module::load_program`, the program read from the EEPROM at start-up — and
//! kept beside the cell's byte image. Everything that makes a cell end the program is decided here:
//! opcode 0 (empty memory), a number that names no command, a command the model lacks, a type byte the
//! command does not know, a control command (128–139, 242, 255: direct mode only). The machine then runs
//! a cell on its op alone: the flow and arithmetic instructions read their operand from the byte image
//! and their type byte through a match the decoder has already proved total; a command for the rest of
//! the module is rebuilt from the byte image by [`Command::decode`], which cannot fail for it any more,
//! and is as cheap as a copy next to what the module then does with it.

use crate::model::ModelSpec;
use tmcl_wire::{Command, Instruction, WaitCondition};

/// What the program machine does with one cell (one byte: see [`crate::vm::Program`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum Op {
    // The machine's own instructions that cannot end the program, start a wait, end a handler or reach
    // the module: nothing happens between two of them but the clock (see `vm/machine.rs`). First, so that
    // [`Op::is_plain`] is one comparison.
    /// COMP (§3.7.17).
    Comp,
    /// JC (§3.7.18), the condition in the type byte.
    Jc,
    /// JA (§3.7.19).
    Ja,
    /// CSUB (§3.7.20).
    Csub,
    /// RSUB (§3.7.21).
    Rsub,
    /// A WAIT for a motor the model lacks: passed over like a command refused with status 4 (our
    /// decision, see `module/program.rs`).
    Pass,
    /// VECT (§3.7.34).
    Vect,
    /// CALC (§3.7.16), the operation in the type byte.
    Calc,
    /// CALCX (§3.7.28), the operation in the type byte.
    Calcx,
    /// Ends the program: empty memory, garbage, a command the model lacks, a control command.
    #[default]
    End,
    /// STOP (§3.7.23).
    Stop,
    /// WAIT (§3.7.22), the condition in the type byte.
    Wait,
    /// RETI (§3.7.35).
    Reti,
    /// A command for the rest of the module (motion, parameters, I/O, interrupts): through the
    /// [`crate::vm::Bus`].
    Command,
    /// The same, for a command that reads a value: it loads the accumulator (§3.6.5; RFS STATUS too).
    Load,
}

impl Op {
    /// One of the machine's own instructions that change nothing but its registers, stack, vectors and
    /// PC: between two of them no interrupt becomes serviceable, no WAIT begins or ends, the run state
    /// stays.
    #[inline(always)]
    pub(crate) fn is_plain(self) -> bool {
        (self as u8) <= (Op::Calcx as u8)
    }
}

/// Decodes one cell for `spec`'s model.
pub fn decode(i: Instruction, spec: &ModelSpec) -> Op {
    if !spec.commands.contains(i.opcode) || i.opcode.is_control() {
        return Op::End;
    }
    let Ok(command) = Command::decode(i) else { return Op::End };
    match command {
        Command::Comp { .. } => Op::Comp,
        Command::Jc { .. } => Op::Jc,
        Command::Ja { .. } => Op::Ja,
        Command::Csub { .. } => Op::Csub,
        Command::Rsub => Op::Rsub,
        Command::Wait { condition, motor, .. } if condition != WaitCondition::Ticks && motor >= spec.motors => Op::Pass,
        Command::Wait { .. } => Op::Wait,
        Command::Stop => Op::Stop,
        Command::Vect { .. } => Op::Vect,
        Command::Reti => Op::Reti,
        Command::Calc { .. } => Op::Calc,
        Command::Calcx { .. } => Op::Calcx,
        c if c.reads_value() => Op::Load,
        _ => Op::Command,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vm::EMPTY;
    use tmcl_wire::Opcode;

    #[test]
    fn every_byte_pattern_decodes_as_a_checked_decode_would_run_it() {
        let spec = crate::model::MODELS[0];
        for opcode in 0..=255u8 {
            for kind in [0u8, 1, 2, 4, 5, 9, 10, 11, 12, 255] {
                let i = Instruction::new(Opcode::from(opcode), kind, 0, 7);
                let op = decode(i, spec);
                let runs = spec.commands.contains(i.opcode) && !i.opcode.is_control() && Command::decode(i).is_ok();
                assert_eq!(op != Op::End, runs, "{i:?}");
            }
        }
        assert_eq!(decode(EMPTY, spec), Op::End);
        let wait_other_motor = Instruction::new(Opcode::Wait, 1, 1, 0);
        assert_eq!(decode(wait_other_motor, spec), Op::Pass);
        let wait_ticks = Instruction::new(Opcode::Wait, 0, 1, 0);
        assert_eq!(decode(wait_ticks, spec), Op::Wait, "TICKS names no motor");
        assert_eq!(core::mem::size_of::<Op>(), 1);
    }
}

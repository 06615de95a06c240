//! The disassembler: instructions back to source that assembles to the same instructions.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use tmcl_wire::ascii::{format_instruction, has_target};
use tmcl_wire::Instruction;

/// Disassembler options.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DisasmOptions {
    /// Append each instruction's address as a comment.
    pub addresses: bool,
}

/// The label the disassembler gives an address: `L0012`.
pub fn label_name(address: usize) -> String {
    format!("L{address:04}")
}

/// Source text for `instructions`: one instruction per line, type words, and a label (`L0012:`) at
/// every address that a JA, JC, CSUB or VECT names. Targets outside the program (negative, or past its
/// end) stay numbers. Assembling the text gives `instructions` back, unknown opcodes included (they are
/// written in the raw form `#op`, see [`tmcl_wire::ascii`]).
pub fn disassemble(instructions: &[Instruction], options: DisasmOptions) -> String {
    let targets: BTreeSet<usize> = instructions
        .iter()
        .filter(|i| has_target(i.opcode))
        .filter_map(|i| usize::try_from(i.value).ok())
        .filter(|&a| a <= instructions.len())
        .collect();
    let names: std::collections::BTreeMap<i32, String> = targets.iter().map(|&a| (a as i32, label_name(a))).collect();
    let label = |a: i32| names.get(&a).map(String::as_str);
    let mut out = String::new();
    let _ = writeln!(out, "// {} instructions", instructions.len());
    for (address, i) in instructions.iter().enumerate() {
        if targets.contains(&address) {
            let _ = writeln!(out, "{}:", label_name(address));
        }
        let mut line = String::from("    ");
        let _ = format_instruction(i, &mut line, Some(&label));
        if options.addresses {
            let _ = write!(line, "{:width$}// {address}", "", width = 36usize.saturating_sub(line.len()).max(1));
        }
        let _ = writeln!(out, "{line}");
    }
    if targets.contains(&instructions.len()) {
        let _ = writeln!(out, "{}:", label_name(instructions.len()));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_wire::Opcode;

    #[test]
    fn labels_and_addresses() {
        let program = [
            Instruction::new(Opcode::Mvp, 0, 0, 1000),
            Instruction::new(Opcode::Wait, 1, 0, 0),
            Instruction::new(Opcode::Ja, 0, 0, 0),
            Instruction::new(Opcode::Jc, 5, 0, 4),
            Instruction::new(Opcode::Csub, 0, 0, 99),
        ];
        let text = disassemble(&program, DisasmOptions::default());
        assert_eq!(
            text,
            "// 5 instructions\nL0000:\n    MVP ABS, 0, 1000\n    WAIT POS, 0, 0\n    JA L0000\n    JC GE, L0004\n\
             L0004:\n    CSUB 99\n"
        );
        let text = disassemble(&program[..1], DisasmOptions { addresses: true });
        assert_eq!(text, format!("// 1 instructions\n    MVP ABS, 0, 1000{}// 0\n", " ".repeat(36 - 20)));
    }
}

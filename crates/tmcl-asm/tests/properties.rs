//! Property tests: disassembly round trips, and the assembler never panics.

use proptest::prelude::*;
use tmcl_asm::{assemble_str, disassemble, from_bin, to_bin, BuiltinResolver, DisasmOptions};
use tmcl_wire::Instruction;

fn instruction(len: usize) -> impl Strategy<Value = Instruction> {
    let byte = || prop_oneof![Just(0u8), 0..16u8, any::<u8>()];
    // Jump-like opcodes often, with targets in and around the program.
    let opcode = prop_oneof![any::<u8>(), Just(21u8), Just(22), Just(23), Just(37), 1..40u8];
    let value = prop_oneof![Just(0i32), -2..(len as i32 + 2), any::<i32>()];
    (opcode, byte(), byte(), value).prop_map(|(op, t, m, v)| Instruction::new(op.into(), t, m, v))
}

fn program() -> impl Strategy<Value = Vec<Instruction>> {
    (0usize..40).prop_flat_map(|len| proptest::collection::vec(instruction(len), len))
}

proptest! {
    #[test]
    fn disassemble_then_assemble_is_identity(instructions in program(), addresses: bool) {
        let text = disassemble(&instructions, DisasmOptions { addresses });
        let p = assemble_str("d.tmc", &text, &mut BuiltinResolver::default());
        let p = p.map_err(|d| format!("{}\n{text}", d.iter().map(|d| d.to_string()).collect::<Vec<_>>().join("\n")));
        prop_assert_eq!(p.map(|p| p.instructions), Ok(instructions.clone()));
        prop_assert_eq!(from_bin(&to_bin(&instructions)), Ok(instructions));
    }

    #[test]
    fn assembling_arbitrary_text_never_panics(text in "\\PC{0,300}") {
        let _ = assemble_str("f.tmc", &text, &mut BuiltinResolver::default());
    }

    #[test]
    fn assembling_near_misses_never_panics(
        lines in proptest::collection::vec(
            "[ \t]{0,2}(#include [A-Za-z.]{0,12}|#op|[A-Za-z_]{1,6} ?[:=]|MVP|JA|SAP|WAIT|CALCX|UF2|//)?[ ,A-Za-z0-9$#+:=/-]{0,20}",
            0..20,
        )
    ) {
        let text = lines.join("\n");
        if let Err(diags) = assemble_str("f.tmc", &text, &mut BuiltinResolver::default()) {
            for d in diags {
                let _ = d.to_string();
            }
        }
    }

    #[test]
    fn reading_arbitrary_images_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..80)) {
        let _ = from_bin(&bytes);
    }
}

//! The assembler on arbitrary source text: errors, never a panic; whatever assembles also disassembles
//! and assembles back to the same instructions.
#![no_main]
use tmcl_asm::{assemble_str, disassemble, BuiltinResolver, DisasmOptions};

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(program) = assemble_str("fuzz.tmc", text, &mut BuiltinResolver::default()) {
        let again = disassemble(&program.instructions, DisasmOptions::default());
        let back = assemble_str("again.tmc", &again, &mut BuiltinResolver::default()).expect("disassembly assembles");
        assert_eq!(back.instructions, program.instructions);
    }
});

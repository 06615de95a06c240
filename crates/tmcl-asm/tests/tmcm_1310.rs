//! The assembler for the TMCM-1310: its built-in include files (TMCM-1310 manual §6.6.1: "Interrupts.inc
//! for symbolic constants of the interrupt numbers"), its command set (no SAC) and its 1024 commands of
//! program memory (§1).
//!
//! `check_model` checks commands only; whether a program fits the program memory is checked where it is
//! loaded: `tmcl asm` warns, `tmcl run`/`debug` and the module refuse (tests/python/test_tmcm1310.py).

use tmcl_asm::{assemble_str, check_model, BuiltinResolver, Program};
use tmcl_model::tmcm_1310::SPEC;
use tmcl_wire::{Instruction, Opcode};

fn assemble(text: &str) -> Program {
    let mut resolver = BuiltinResolver { model: &SPEC };
    assemble_str("p.tmc", text, &mut resolver).unwrap_or_else(|d| panic!("{}", d[0]))
}

/// §6.6.5's timer example with the symbols of Interrupts.inc, and the input interrupts 39–46.
#[test]
fn manual_interrupt_example_with_the_1310_symbols() {
    let text = "\
#include Interrupts.inc
    VECT TI_TIMER0, Timer0Irq
    SGP TI_TIMER0, 3, 1000
    EI TI_TIMER0
    VECT TI_INPUT7, In7Irq
    SGP TI_INPUT7, 3, 3
    EI TI_INPUT7
    EI TI_GLOBAL
Loop:
    SIO 3, 2, 1
    WAIT TICKS, 0, 50
    SIO 3, 2, 0
    WAIT TICKS, 0, 50
    JA Loop
Timer0Irq:
    GIO 0, 2
    JC NZ, Out0Off
    SIO 0, 2, 1
    RETI
Out0Off:
    SIO 0, 2, 0
    RETI
In7Irq:
    RETI
";
    let p = assemble(text);
    assert_eq!(p.constants["TI_INPUT0"], 39);
    assert_eq!(p.constants["TI_INPUT4"], 43);
    assert_eq!(p.constants["TI_INPUT7"], 46);
    assert_eq!(p.constants["TI_GLOBAL"], 255);
    assert_eq!(p.instructions[0], Instruction::new(Opcode::Vect, 0, 0, 12));
    assert_eq!(p.instructions[3], Instruction::new(Opcode::Vect, 46, 0, 18));
    assert_eq!(p.instructions[4], Instruction::new(Opcode::Sgp, 46, 3, 3));
    assert!(check_model(&p, &SPEC, &mut |_, _| None).is_empty());
}

#[test]
fn the_parameter_symbols_are_the_1310s() {
    let p = assemble("#include TMCLParam.tmc\nSGP GPPassword, 0, 4321\nSAP APEncoderOffset, Motor0, 0\n");
    assert_eq!(p.constants["GPPassword"], 200);
    assert_eq!(p.constants["APClosedLoopMode"], 129);
    assert!(!p.constants.contains_key("APVsense"), "no AP 179 on the 1310");
    assert_eq!(p.instructions[0], Instruction::new(Opcode::Sgp, 200, 0, 4321));
    assert_eq!(p.instructions[1], Instruction::new(Opcode::Sap, 112, 0, 0));
}

#[test]
fn sac_is_not_a_1310_command() {
    let text = "Start: SAP 4, 0, 1000\n  SAC 0, 1, 5\nJA Start\n";
    let p = assemble(text);
    let d = check_model(&p, &SPEC, &mut |_, line| text.lines().nth(line as usize - 1).map(String::from));
    assert_eq!(d.len(), 1);
    assert_eq!((d[0].line, d[0].column, d[0].width), (2, 3, 3));
    assert!(d[0].message.starts_with("`SAC` is not a command of the TMCM-1310"), "{}", d[0].message);
}

#[test]
fn a_program_longer_than_the_memory_assembles() {
    // 1025 instructions: the assembler takes them (its own limit is 65535); the model check looks at
    // commands, not length. Loading refuses it (tmcl-core's tests, the CLI).
    let text = "CALC ADD, 1\n".repeat(1024) + "STOP\n";
    let p = assemble(&text);
    assert_eq!(p.instructions.len(), 1025);
    assert!(p.instructions.len() > usize::from(SPEC.program_memory));
    assert!(check_model(&p, &SPEC, &mut |_, _| None).is_empty());
}

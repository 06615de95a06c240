//! The assembler for the PDx-113: its built-in `TMCLParam.tmc` (the TMC428 generation's parameter names),
//! no `Interrupts.inc` (no interrupts, PDx-113 manual §5.4), its command set (SAC yes; EI, DI, VECT,
//! RETI, ACO no) and the manual's programs (§4.2, §5.7.14, §5.7.17).

use tmcl_asm::{assemble_str, check_model, BuiltinResolver, Program};
use tmcl_model::pd_113::SPEC;
use tmcl_wire::{Instruction, Opcode};

fn assemble(text: &str) -> Program {
    let mut resolver = BuiltinResolver { model: &SPEC };
    assemble_str("p.tmc", text, &mut resolver).unwrap_or_else(|d| panic!("{}", d[0]))
}

/// §4.2: "A simple example for using TMCL and the TMCL-IDE", as printed.
#[test]
fn the_first_program() {
    let p = assemble(
        "//A simple example for using TMCL and the TMCL-IDE
SAP 4, 0, 1000   //Set the maximum speed
Loop:  MVP ABS, 0, 150000   //Move to position 150000
 WAIT POS, 0, 0
 WAIT TICKS, 0, 200
 MVP ABS, 0, 0    //Move back to position 0
 WAIT POS, 0, 0
 WAIT TICKS, 0, 100
 JA Loop    // Infinite Loop
",
    );
    assert_eq!(p.instructions[0], Instruction::new(Opcode::Sap, 4, 0, 1000));
    assert_eq!(p.instructions[1], Instruction::new(Opcode::Mvp, 0, 0, 150_000));
    assert_eq!(p.instructions[7], Instruction::new(Opcode::Ja, 0, 0, 1));
    assert!(check_model(&p, &SPEC, &mut |_, _| None).is_empty());
}

/// §5.7.14 copies the inputs to the outputs; the manual prints the operand as "- 1". §5.7.17's COMP
/// example prints `GAP 1, 2, 0` with three operands (sic): the actual position is `GAP 1, 0`.
#[test]
fn the_io_and_comp_examples() {
    let p = assemble("Loop:  GIO 255, 0\nSIO 255, 2, -1\n JA Loop\n");
    assert_eq!(p.instructions[1], Instruction::new(Opcode::Sio, 255, 2, -1));
    let p = assemble("GAP 1, 0\nCOMP 1000\nJC GE, Label\nLabel: STOP\n");
    assert_eq!(p.instructions[2], Instruction::new(Opcode::Jc, 5, 0, 3), "GE is type 5 (§5.7.17)");
    assert!(check_model(&p, &SPEC, &mut |_, _| None).is_empty());
}

#[test]
fn the_parameter_symbols_are_the_tmc428_generations() {
    let p = assemble(
        "#include TMCLParam.tmc\nSAP APPulseDivisor, Motor0, 5\nSAP APRampDivisor, Motor0, 8\n\
         SAP APMicrostepResolution, Motor0, 4\nSAP APReferencingMode, Motor0, 3\nSGP GPSerialAddress, 0, 2\n",
    );
    assert_eq!(p.constants["APPulseDivisor"], 154);
    assert_eq!(p.constants["APRampDivisor"], 153);
    assert_eq!(p.constants["APMicrostepResolution"], 140);
    assert_eq!(p.constants["APReferencingMode"], 193);
    assert_eq!(p.constants["GPSerialAddress"], 66);
    assert!(!p.constants.contains_key("APRampMode") || p.constants["APRampMode"] == 138);
    let mut resolver = BuiltinResolver { model: &SPEC };
    assert!(assemble_str("p.tmc", "#include Interrupts.inc\n", &mut resolver).is_err(), "no interrupts");
}

#[test]
fn commands_of_the_model() {
    let p = assemble("SAC 0, 4, 1929379840\nEI 0\nVECT 0, L\nL: RETI\nACO 0, 0\n");
    let refused: Vec<_> = check_model(&p, &SPEC, &mut |_, _| None).into_iter().map(|d| d.to_string()).collect();
    assert_eq!(refused.len(), 4, "{refused:?}");
    assert!(refused.iter().all(|m| !m.contains("SAC")), "{refused:?}");
}

//! Every TMCL listing of the PD28-1021 TMCL firmware manual (14 listings, numbered in the order they appear
//! and saved as `tests/programs/manual_pNN_*.tmc` at the workspace root) assembles to the addresses and
//! tuples worked out by hand from the printed listings.

use std::path::PathBuf;
use tmcl_asm::{assemble, disassemble, from_bin, DisasmOptions, Program};
use tmcl_wire::Instruction;

fn program(name: &str) -> Program {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/programs").join(name);
    let program = match assemble(&path) {
        Ok(p) => p,
        Err(diags) => panic!("{name}:\n{}", diags.iter().map(|d| d.to_string()).collect::<Vec<_>>().join("\n")),
    };
    // Every listing survives the image and the disassembler too.
    assert_eq!(from_bin(&program.to_bin()).unwrap(), program.instructions);
    let text = disassemble(&program.instructions, DisasmOptions::default());
    let again = tmcl_asm::assemble_str("disassembled.tmc", &text, &mut tmcl_asm::BuiltinResolver::default()).unwrap();
    assert_eq!(again.instructions, program.instructions);
    program
}

/// (opcode, type, motor, value) per address.
fn tuples(p: &Program) -> Vec<(u8, u8, u8, i32)> {
    p.instructions.iter().map(|i: &Instruction| (i.opcode.into(), i.kind, i.motor, i.value)).collect()
}

fn label(p: &Program, name: &str) -> u16 {
    *p.labels.get(name).unwrap_or_else(|| panic!("no label {name}"))
}

#[test]
fn p01_first_steps() {
    let p = program("manual_p01_first_steps.tmc");
    assert_eq!(
        tuples(&p),
        [
            (2, 0, 0, 51200),
            (27, 0, 0, 500),
            (3, 0, 0, 0),
            (1, 0, 0, 5120),
            (27, 0, 0, 500),
            (3, 0, 0, 0),
            (5, 4, 0, 51200),
            (5, 5, 0, 51200),
            (4, 0, 0, 512000),
            (27, 1, 0, 0),
            (4, 0, 0, -512000),
            (27, 1, 0, 0),
            (22, 0, 0, 8),
        ]
    );
    assert_eq!(label(&p, "Loop"), 8);
    assert_eq!(p.symbols(), "Loop 8\n");
    let line_of = |a: u16| p.source(a).map(|s| s.line);
    assert_eq!((line_of(0), line_of(8), line_of(12)), (Some(2), Some(12), Some(16)));
    assert!(p.source(0).unwrap().file.ends_with("manual_p01_first_steps.tmc"));
}

#[test]
fn p02_timer_interrupt() {
    let p = program("manual_p02_timer_interrupt.tmc");
    assert_eq!((label(&p, "Loop"), label(&p, "Timer0Irq"), label(&p, "Out0Off")), (4, 9, 13));
    assert_eq!(p.instructions.len(), 15);
    let t = tuples(&p);
    assert_eq!(t[0], (37, 0, 0, 9)); // VECT 0, Timer0Irq
    assert_eq!(t[1], (9, 0, 3, 1000)); // SGP 0, 3, 1000
    assert_eq!(t[3], (25, 255, 0, 0)); // EI 255
    assert_eq!(t[8], (22, 0, 0, 4)); // JA Loop
    assert_eq!(t[10], (21, 1, 0, 13)); // JC NZ, Out0Off
    assert_eq!(t[12], (38, 0, 0, 0)); // RETI
}

#[test]
fn p03_interrupts_inc() {
    let p = program("manual_p03_interrupts_inc.tmc");
    assert_eq!(tuples(&p)[..4], [(37, 0, 0, 4), (9, 0, 3, 1000), (25, 0, 0, 0), (25, 255, 0, 0)]);
    // The same start as the timer-interrupt listing (`manual_p02`).
    let p2 = program("manual_p02_timer_interrupt.tmc");
    assert_eq!(tuples(&p)[1..4], tuples(&p2)[1..4]);
    assert_eq!(p.constants.get("TI_GLOBAL"), Some(&255));
}

#[test]
fn p04_copy_inputs() {
    let p = program("manual_p04_copy_inputs.tmc");
    assert_eq!(tuples(&p), [(15, 255, 0, 0), (14, 255, 2, -1), (22, 0, 0, 0)]);
}

#[test]
fn p05_comp_and_p06_jc() {
    let p = program("manual_p05_comp.tmc");
    assert_eq!(tuples(&p), [(6, 1, 0, 0), (20, 0, 0, 1000), (21, 5, 0, 3)]);
    assert_eq!(label(&p, "Label"), 3); // at the end of the program
    let p = program("manual_p06_jc.tmc");
    assert_eq!(tuples(&p), [(6, 1, 0, 0), (20, 0, 0, 1000), (21, 5, 0, 3), (2, 0, 0, 1000)]);
}

#[test]
fn p07_ja() {
    let p = program("manual_p07_ja.tmc");
    assert_eq!(tuples(&p), [(4, 0, 0, 51200), (27, 1, 0, 0), (4, 0, 0, 0), (27, 1, 0, 0), (22, 0, 0, 0)]);
}

#[test]
fn p08_csub() {
    let p = program("manual_p08_csub.tmc");
    assert_eq!(label(&p, "SubW"), 5);
    assert_eq!(
        tuples(&p),
        [
            (4, 0, 0, 10000),
            (23, 0, 0, 5),
            (4, 0, 0, 0),
            (23, 0, 0, 5),
            (22, 0, 0, 0),
            (27, 1, 0, 0),
            (27, 0, 0, 50),
            (24, 0, 0, 0)
        ]
    );
}

#[test]
fn p09_vect() {
    let p = program("manual_p09_vect.tmc");
    assert_eq!(tuples(&p), [(37, 0, 0, 2), (22, 0, 0, 1), (14, 0, 2, 1), (38, 0, 0, 0)]);
}

#[test]
fn p10_aap() {
    let p = program("manual_p10_aap.tmc");
    assert_eq!(tuples(&p), [(15, 0, 1, 0), (19, 2, 0, 4), (34, 0, 0, 0), (22, 0, 0, 0)]);
}

#[test]
fn p11_main_loop_and_p12_constants() {
    let p11 = program("manual_p11_main_loop.tmc");
    assert_eq!(label(&p11, "MainLoop"), 2);
    assert_eq!(
        tuples(&p11),
        [
            (5, 4, 0, 50000),
            (5, 5, 0, 10000),
            (4, 0, 0, 5000),
            (27, 1, 0, 0),
            (4, 0, 0, 0),
            (27, 1, 0, 0),
            (22, 0, 0, 2)
        ]
    );
    let p12 = program("manual_p12_constants.tmc");
    assert_eq!(label(&p12, "MainLoop"), 2);
    assert_eq!(tuples(&p12)[..2], tuples(&p11)[..2]);
    assert_eq!(tuples(&p12)[2], (4, 0, 0, 500000));
    assert_eq!(tuples(&p12)[6], (22, 0, 0, 2));
    assert_eq!(p12.constants.get("APMaxPositioningSpeed"), Some(&4));
    assert_eq!(p12.constants.get("MaxAcc"), Some(&10000));
}

#[test]
fn p13_user_variables() {
    let p = program("manual_p13_user_variables.tmc");
    // `AAP MyVariable, 2` kept as printed (§8.4 means AGP, since AAP writes an axis parameter of motor 2):
    // AAP 42, 2.
    assert_eq!(tuples(&p), [(9, 42, 2, 1234), (10, 42, 2, 0), (19, 2, 0, 2), (34, 42, 2, 0)]);
}

#[test]
fn p14_jump_table() {
    let p = program("manual_p14_jump_table.tmc");
    let labels: Vec<u16> =
        ["Func1", "Func2", "Func3", "Func1Start", "Func2Start", "Func3Start"].iter().map(|n| label(&p, n)).collect();
    assert_eq!(labels, [0, 1, 2, 3, 8, 12]);
    assert_eq!(tuples(&p)[..3], [(22, 0, 0, 3), (22, 0, 0, 8), (22, 0, 0, 12)]);
    assert_eq!(p.instructions.len(), 16);
    assert_eq!(p.symbols(), "Func1 0\nFunc2 1\nFunc3 2\nFunc1Start 3\nFunc2Start 8\nFunc3Start 12\n");
}

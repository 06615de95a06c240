//! Diagnostics: exact messages, places, and that every error is reported in one run.

use std::fs;
use tmcl_asm::{assemble, assemble_file, assemble_str, BuiltinResolver, Diagnostic, FileResolver};

fn errors(text: &str) -> Vec<Diagnostic> {
    assemble_str("t.tmc", text, &mut BuiltinResolver::default()).expect_err("should not assemble")
}

fn messages(text: &str) -> Vec<String> {
    errors(text).into_iter().map(|d| format!("{}:{}: {}", d.line, d.column, d.message)).collect()
}

#[test]
fn unknown_label_with_suggestion_rendered() {
    let d = errors("Loop:\n    MVP ABS, 0, 100\n    JA Lop\n");
    assert_eq!(d.len(), 1);
    assert_eq!(
        d[0].to_string(),
        "t.tmc:3:8: error: unknown label `Lop`; did you mean `Loop`?\n        JA Lop\n           ^^^"
    );
}

#[test]
fn operand_and_range_messages() {
    assert_eq!(messages("MVP ABS, 0"), ["1:1: MVP takes 3 operands, found 2"]);
    assert_eq!(messages("SAP 4, 300, 1"), ["1:8: value 300 does not fit the motor/bank byte (0..255)"]);
    assert_eq!(messages("GAP 1, 0, 0, 0"), ["1:1: GAP takes 2 or 3 operands, found 4"]);
    assert_eq!(messages("RSUB 1"), ["1:1: RSUB takes no operands, found 1"]);
    assert_eq!(messages("EI -1"), ["1:4: value -1 does not fit the type byte (0..255)"]);
    assert_eq!(messages("COMP 12x"), ["1:6: `12x` is not a valid number"]);
    assert_eq!(messages("SAP 4, , 1"), ["1:8: missing operand"]);
    assert_eq!(messages("MVP ABZ, 0, 1"), ["1:5: `ABZ` is not a type of MVP (one of ABS, REL, COORD)"]);
    assert_eq!(messages("MVPP ABS, 0, 1"), ["1:1: unknown mnemonic `MVPP`; did you mean `MVP`?"]);
    assert_eq!(messages("Start: FOO 1"), ["1:8: unknown mnemonic `FOO`"]);
    assert_eq!(
        messages("SAP MaxSped, 0, 1\nMaxSpeed = 4"),
        ["1:5: unknown symbol `MaxSped`; did you mean `MaxSpeed`?"]
    );
    assert_eq!(messages("#define X 1"), ["1:1: unknown directive `#define`"]);
}

#[test]
fn definitions() {
    assert_eq!(messages("Loop:\nJA Loop\nLoop:\n"), ["3:1: duplicate label `Loop`; first defined at t.tmc:1"]);
    assert_eq!(messages("X = 1\nX = 2\n"), ["2:1: duplicate constant `X`; first defined at t.tmc:1"]);
    assert_eq!(messages("X = 1\nX:\n"), ["2:1: `X` is already defined as a constant at t.tmc:1"]);
    // The same value twice is allowed (a header included twice).
    assert!(assemble_str("t.tmc", "X = 1\nX = 1\nCOMP X", &mut BuiltinResolver::default()).is_ok());
    assert_eq!(messages("A = B\nB = 1\n"), ["1:5: constant uses constant `B` before its definition at t.tmc:2"]);
    assert_eq!(messages("A = Bee\n"), ["1:5: unknown symbol `Bee`"]);
    assert_eq!(messages("A =\n"), ["1:1: constant `A` has no value"]);
    // Constants are usable anywhere a number is, also as type and motor, and may chain.
    let p = assemble_str("t.tmc", "P = 4\nQ = P\nM = 0\nSAP Q, M, -Q\n", &mut BuiltinResolver::default());
    assert!(p.is_err(), "-Q is not a number");
    let p = assemble_str("t.tmc", "P = 0x10\nQ = P\nM = 0\nSAP Q, M, Q\n", &mut BuiltinResolver::default()).unwrap();
    assert_eq!(p.instructions[0].to_bytes(), [5, 16, 0, 0, 0, 0, 16]);
}

#[test]
fn every_error_in_one_run() {
    let text = "Loop:\nMVP ABS, 0\nJA Lop\nSAP 4, 300, 1\n#include Nowhere.inc\nLoop:\nCOMP 1\n";
    assert_eq!(
        messages(text),
        [
            "2:1: MVP takes 3 operands, found 2",
            "3:4: unknown label `Lop`; did you mean `Loop`?",
            "4:8: value 300 does not fit the motor/bank byte (0..255)",
            "5:10: include file `Nowhere.inc` not found",
            "6:1: duplicate label `Loop`; first defined at t.tmc:1",
        ]
    );
}

#[test]
fn includes_on_disk() {
    let dir = tempfile::tempdir().unwrap();
    let path = |n: &str| dir.path().join(n);
    // A file beside the source wins over the built-in file of the same name.
    fs::write(path("TMCLParam.tmc"), "Motor0 = 7\n").unwrap();
    fs::create_dir(path("inc")).unwrap();
    fs::write(path("inc/defs.inc"), "Speed = 1000\nHelper:\nRSUB\n").unwrap();
    fs::write(path("main.tmc"), "#include TMCLParam.tmc\n#include \"defs.inc\"\nROR Motor0, Speed\nCSUB Helper\n")
        .unwrap();
    assert_eq!(
        assemble(path("main.tmc")).unwrap_err().iter().map(|d| d.message.as_str()).collect::<Vec<_>>(),
        ["include file `defs.inc` not found", "unknown symbol `Speed`", "unknown label `Helper`"]
    );
    let mut resolver = FileResolver { include_dirs: vec![path("inc")], ..Default::default() };
    let p = assemble_file(&path("main.tmc"), &mut resolver).unwrap();
    let t: Vec<_> = p.instructions.iter().map(|i| i.to_bytes()).collect();
    assert_eq!(t, [[24, 0, 0, 0, 0, 0, 0], [1, 0, 7, 0, 0, 0x03, 0xE8], [23, 0, 0, 0, 0, 0, 0]]);
    assert_eq!(p.labels.get("Helper"), Some(&0));
    assert!(p.source(0).unwrap().file.ends_with("defs.inc"));
    assert_eq!(p.source(1).unwrap().line, 3);

    // Errors in included files name those files.
    fs::write(path("bad.inc"), "\nJA Nowhere\n").unwrap();
    fs::write(path("uses_bad.tmc"), "#include bad.inc\n").unwrap();
    let d = assemble(path("uses_bad.tmc")).unwrap_err();
    assert!(d[0].file.ends_with("bad.inc") && d[0].line == 2, "{}", d[0]);

    // Cycles.
    fs::write(path("a.tmc"), "#include b.tmc\n").unwrap();
    fs::write(path("b.tmc"), "#include a.tmc\n").unwrap();
    let d = assemble(path("a.tmc")).unwrap_err();
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].message, "include cycle: `a.tmc` -> `b.tmc` -> `a.tmc`");
    assert!(d[0].file.ends_with("b.tmc"));

    // A byte-order mark and Latin-1 comments are no obstacle.
    fs::write(path("latin1.tmc"), b"\xEF\xBB\xBFROL 0, 1 // 90\xB0\nSTOP\n").unwrap();
    assert_eq!(assemble(path("latin1.tmc")).unwrap().instructions.len(), 2);

    // An unreadable main file.
    let d = assemble(path("missing.tmc")).unwrap_err();
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].line, 0);
}

#[test]
fn builtin_includes() {
    let text = "#include TMCLParam.tmc\n#include Interrupts.inc\nSAP APMaxAcceleration, Motor0, 1\nSGP IPTimer0Period, 3, 10\n\
                EI TI_TIMER2\nGGP GPSerialAddress, 0\n";
    let p = assemble_str("t.tmc", text, &mut BuiltinResolver::default()).unwrap();
    let t: Vec<_> = p.instructions.iter().map(|i| (u8::from(i.opcode), i.kind, i.motor, i.value)).collect();
    assert_eq!(t, [(5, 5, 0, 1), (9, 0, 3, 10), (25, 2, 0, 0), (10, 66, 0, 0)]);
    assert!(p.labels.is_empty());
}

//! The examples of docs/assembler.md: every fenced `tmcl` block assembles (and passes the PD28-1021's
//! model check), and every `tmcl-error` block fails with exactly the diagnostics of the `text` block that
//! follows it, as `tmcl asm` prints them for a file named `example.tmc`.

use tmcl_asm::{assemble_str, check_model, BuiltinResolver};

const DOC: &str = include_str!("../../../docs/assembler.md");

/// The fenced blocks of `doc`: (info string, body, line of the opening fence).
fn blocks(doc: &str) -> Vec<(String, String, usize)> {
    let mut out = Vec::new();
    let mut open: Option<(String, String, usize)> = None;
    for (n, line) in doc.lines().enumerate() {
        match (&mut open, line.strip_prefix("```")) {
            (None, Some(info)) => open = Some((info.trim().to_string(), String::new(), n + 1)),
            (Some(_), Some(_)) => out.extend(open.take()),
            (Some((_, body, _)), None) => {
                body.push_str(line);
                body.push('\n');
            }
            (None, None) => {}
        }
    }
    assert!(open.is_none(), "an unclosed fence in docs/assembler.md");
    out
}

#[test]
fn every_tmcl_block_assembles() {
    let blocks = blocks(DOC);
    let mut tested = 0;
    for (info, body, line) in &blocks {
        if info != "tmcl" {
            continue;
        }
        let program = assemble_str("example.tmc", body, &mut BuiltinResolver::default()).unwrap_or_else(|d| {
            let shown: Vec<String> = d.iter().map(ToString::to_string).collect();
            panic!("docs/assembler.md:{line}: the example does not assemble:\n{}", shown.join("\n"))
        });
        assert!(!program.instructions.is_empty(), "docs/assembler.md:{line}: no instructions");
        let wrong = check_model(&program, &tmcl_model::pd28_1021::SPEC, &mut |_, _| None);
        assert!(wrong.is_empty(), "docs/assembler.md:{line}: {wrong:?}");
        tested += 1;
    }
    assert!(tested >= 10, "only {tested} examples found");
}

#[test]
fn every_error_example_gives_the_errors_shown() {
    let blocks = blocks(DOC);
    let mut tested = 0;
    for (i, (info, body, line)) in blocks.iter().enumerate() {
        if info != "tmcl-error" {
            continue;
        }
        let diagnostics =
            assemble_str("example.tmc", body, &mut BuiltinResolver::default()).expect_err("the example must fail");
        let printed: Vec<String> = diagnostics.iter().map(ToString::to_string).collect();
        let expected = blocks.get(i + 1).filter(|(info, _, _)| info == "text").map(|(_, body, _)| body.trim_end());
        assert_eq!(Some(printed.join("\n").as_str()), expected, "docs/assembler.md:{line}");
        tested += 1;
    }
    assert!(tested >= 1);
}

#[test]
fn the_disassembly_shown_is_the_disassemblers() {
    let blocks = blocks(DOC);
    let first = blocks.iter().find(|(info, _, _)| info == "tmcl").expect("a first example");
    let program = assemble_str("example.tmc", &first.1, &mut BuiltinResolver::default()).expect("assembles");
    let text = tmcl_asm::disassemble(&program.instructions, tmcl_asm::DisasmOptions { addresses: true });
    let shown = blocks.iter().find(|(info, body, _)| info == "text" && body.starts_with("// ")).expect("shown");
    assert_eq!(text, shown.1);
}

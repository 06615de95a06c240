//! Checks an assembled program against a model: a command the model does not have would answer status 2
//! at download (PD28-1021 manual §3.2.1, status 2 "invalid command") and end the program if it ever ran,
//! so the assembler says so at its source line.

use crate::assemble::Program;
use crate::diag::Diagnostic;
use tmcl_model::ModelSpec;
use tmcl_wire::Opcode;

/// One diagnostic per instruction whose command `model` lacks, at its source line. `line_text` gives a
/// line's text (file name as in [`crate::SourceLine::file`], line from 1), so that the diagnostic can show
/// it with a caret under the mnemonic; without it the line is named but not shown.
pub fn check_model(
    program: &Program,
    model: &ModelSpec,
    line_text: &mut dyn FnMut(&str, u32) -> Option<String>,
) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    for (address, i) in program.instructions.iter().enumerate() {
        if model.commands.contains(i.opcode) {
            continue;
        }
        let name = match i.opcode {
            Opcode::Unknown(code) => format!("command {code}"),
            op => format!("`{op}`"),
        };
        let message = format!("{name} is not a command of the {}", model.name);
        let Some(place) = program.source_lines.get(address) else {
            out.push(Diagnostic::file("program", format!("address {address}: {message}")));
            continue;
        };
        let text = line_text(&place.file, place.line).unwrap_or_default();
        // Underline the mnemonic where the line spells it, else the line's first word.
        let mnemonic = i.opcode.to_string();
        let lower = text.to_ascii_lowercase();
        let start =
            find_word(&lower, &mnemonic.to_ascii_lowercase()).unwrap_or_else(|| text.len() - text.trim_start().len());
        let end = start + text[start..].find(|c: char| c.is_whitespace() || c == ',').unwrap_or(text.len() - start);
        out.push(Diagnostic::at(&place.file, place.line, &text, start, end, message));
    }
    out
}

/// The byte offset of `word` in `line` as a whole word.
fn find_word(line: &str, word: &str) -> Option<usize> {
    let bytes = line.as_bytes();
    let mut from = 0;
    while let Some(i) = line[from..].find(word).map(|i| i + from) {
        let before = i == 0 || !bytes[i - 1].is_ascii_alphanumeric();
        let after = bytes.get(i + word.len()).is_none_or(|b| !b.is_ascii_alphanumeric());
        if before && after {
            return Some(i);
        }
        from = i + word.len();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::includes::BuiltinResolver;
    use tmcl_model::pd28_1021::SPEC;

    #[test]
    fn sac_is_not_a_pd28_command() {
        let text = "Start: SAP 4, 0, 1000\n  sac 0, 1, 5 // SPI\nJA Start\n";
        let mut resolver = BuiltinResolver { model: &SPEC };
        let program = crate::assemble_str("p.tmc", text, &mut resolver).unwrap();
        let d = check_model(&program, &SPEC, &mut |_, line| text.lines().nth(line as usize - 1).map(String::from));
        assert_eq!(d.len(), 1);
        assert_eq!((d[0].line, d[0].column, d[0].width), (2, 3, 3));
        assert!(d[0].message.starts_with("`SAC` is not a command of the PD28-1021"), "{}", d[0].message);
        assert!(d[0].to_string().ends_with("\n      sac 0, 1, 5 // SPI\n      ^^^"), "{}", d[0]);
    }

    #[test]
    fn a_program_of_the_model_passes() {
        let mut resolver = BuiltinResolver { model: &SPEC };
        let program = crate::assemble_str("p.tmc", "ROR 0, 500\nEI 255\nSTOP\n", &mut resolver).unwrap();
        assert!(check_model(&program, &SPEC, &mut |_, _| None).is_empty());
    }
}

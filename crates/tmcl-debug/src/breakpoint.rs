//! Where a breakpoint goes: a label, an address, or a source line.
//!
//! A breakpoint sits on an instruction. A source line that holds none (a label alone, a comment, a blank
//! line) gives its breakpoint to the first instruction after it, as debuggers do for a line without code.

use tmcl_asm::Program;

/// The first instruction on line `line` of the file `same_file` accepts, or the first after it: its
/// address and the line it is on.
pub fn at_line(program: &Program, same_file: impl Fn(&str) -> bool, line: u32) -> Option<(u16, u32)> {
    program
        .source_lines
        .iter()
        .enumerate()
        .filter(|(_, s)| same_file(&s.file) && s.line >= line)
        .min_by_key(|(address, s)| (s.line, *address))
        .and_then(|(address, s)| Some((u16::try_from(address).ok()?, s.line)))
}

/// Whether a file name of the program (as the assembler recorded it) is the file a user wrote: the same,
/// or the same file below another directory (`demo.tmc` for `examples/demo.tmc`).
pub fn same_file(recorded: &str, written: &str) -> bool {
    recorded == written
        || std::path::Path::new(recorded).ends_with(written)
        || recorded.ends_with(&format!("/{written}"))
}

/// The address a user means by `place`: an address below `memory` (the program memory's size), a label,
/// or `FILE:LINE` ([`at_line`]). The error is a sentence for the user; for a misspelt label it suggests
/// the closest one.
pub fn resolve(program: &Program, memory: u16, place: &str) -> Result<u16, String> {
    if let Ok(a) = place.parse::<u16>() {
        return if a < memory { Ok(a) } else { Err(format!("Address {a} is outside program memory (0..{memory}).")) };
    }
    if let Some(&a) = program.labels.get(place) {
        return Ok(a);
    }
    if let Some((file, line)) = place.rsplit_once(':') {
        let line: u32 = line.parse().map_err(|_| format!("`{line}` is not a line number."))?;
        return match at_line(program, |name| same_file(name, file), line) {
            Some((a, _)) => Ok(a),
            None => Err(format!("No instruction at or after {file}:{line}.")),
        };
    }
    let hint = match tmcl_asm::suggest::closest(place, program.labels.keys().map(String::as_str)) {
        Some(l) => format!(" Did you mean `{l}`?"),
        None => String::new(),
    };
    Err(format!("`{place}` is not a label, an address or FILE:LINE.{hint}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_asm::{assemble_str, BuiltinResolver};

    fn program() -> Program {
        let source = "// demo\nLoop:\n  ROR 0, 100\n\n  WAIT TICKS, 0, 10\n  JA Loop\n";
        assemble_str("dir/demo.tmc", source, &mut BuiltinResolver::default()).unwrap()
    }

    #[test]
    fn lines_without_code_give_their_breakpoint_to_the_next_instruction() {
        let p = program();
        let demo = |f: &str| f == "dir/demo.tmc";
        assert_eq!(at_line(&p, demo, 1), Some((0, 3)), "a comment");
        assert_eq!(at_line(&p, demo, 2), Some((0, 3)), "a label alone");
        assert_eq!(at_line(&p, demo, 4), Some((1, 5)), "a blank line");
        assert_eq!(at_line(&p, demo, 6), Some((2, 6)));
        assert_eq!(at_line(&p, demo, 7), None, "after the last instruction");
        assert_eq!(at_line(&p, |f: &str| f == "other.tmc", 3), None);
    }

    #[test]
    fn places() {
        let p = program();
        assert_eq!(resolve(&p, 2048, "Loop"), Ok(0));
        assert_eq!(resolve(&p, 2048, "2"), Ok(2));
        assert_eq!(resolve(&p, 2048, "demo.tmc:4"), Ok(1));
        assert_eq!(resolve(&p, 2048, "dir/demo.tmc:6"), Ok(2));
        assert_eq!(resolve(&p, 2048, "2048"), Err("Address 2048 is outside program memory (0..2048).".into()));
        assert_eq!(resolve(&p, 2048, "demo.tmc:x"), Err("`x` is not a line number.".into()));
        assert_eq!(resolve(&p, 2048, "demo.tmc:9"), Err("No instruction at or after demo.tmc:9.".into()));
        assert_eq!(
            resolve(&p, 2048, "Lop"),
            Err("`Lop` is not a label, an address or FILE:LINE. Did you mean `Loop`?".into())
        );
        assert_eq!(resolve(&p, 2048, "Xyzzy"), Err("`Xyzzy` is not a label, an address or FILE:LINE.".into()));
    }
}

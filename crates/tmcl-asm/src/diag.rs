//! Assembler errors with their place in the source.

use std::fmt;

/// One error: where, what, and the source line to show it on.
///
/// Displayed as
///
/// ```text
/// prog.tmc:3:4: error: unknown label `Lop`; did you mean `Loop`?
///     JA Lop
///        ^^^
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// The file's name as given on the command line or in `#include`.
    pub file: String,
    /// Line, from 1; 0 if the error concerns the whole file.
    pub line: u32,
    /// Column of the first character, from 1 (in characters, not bytes).
    pub column: u32,
    /// Characters to underline, at least 1.
    pub width: u32,
    /// A plain sentence, without a trailing period.
    pub message: String,
    /// The source line, without its line break.
    pub source_line: String,
}

impl Diagnostic {
    /// An error about a whole file (it cannot be read).
    pub fn file(file: &str, message: String) -> Diagnostic {
        Diagnostic { file: file.into(), line: 0, column: 0, width: 0, message, source_line: String::new() }
    }

    /// An error at byte offsets `start..end` of `source_line`, which is line `line` of `file`.
    pub fn at(file: &str, line: u32, source_line: &str, start: usize, end: usize, message: String) -> Diagnostic {
        let start = floor_char_boundary(source_line, start);
        let end = floor_char_boundary(source_line, end.max(start));
        let column = source_line[..start].chars().count() as u32 + 1;
        let width = (source_line[start..end].chars().count() as u32).max(1);
        Diagnostic { file: file.into(), line, column, width, message, source_line: source_line.into() }
    }
}

fn floor_char_boundary(s: &str, mut i: usize) -> usize {
    i = i.min(s.len());
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

impl Diagnostic {
    /// The diagnostic as a warning: as its [`fmt::Display`], with `warning:` for `error:`.
    pub fn warning(&self) -> impl fmt::Display + '_ {
        Labelled(self, "warning")
    }
}

struct Labelled<'a>(&'a Diagnostic, &'static str);

impl fmt::Display for Labelled<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.render(f, self.1)
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.render(f, "error")
    }
}

impl Diagnostic {
    fn render(&self, f: &mut fmt::Formatter<'_>, label: &str) -> fmt::Result {
        if self.line == 0 {
            return write!(f, "{}: {label}: {}", self.file, self.message);
        }
        writeln!(f, "{}:{}:{}: {label}: {}", self.file, self.line, self.column, self.message)?;
        writeln!(f, "    {}", self.source_line)?;
        // Keep tabs so that the caret lines up under tabbed source.
        let pad: String = self
            .source_line
            .chars()
            .take(self.column as usize - 1)
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        write!(f, "    {pad}{}", "^".repeat(self.width as usize))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_caret_under_span() {
        let d = Diagnostic::at("p.tmc", 3, "\tJA Lop // x", 4, 7, "unknown label `Lop`".into());
        assert_eq!((d.column, d.width), (5, 3));
        assert_eq!(d.to_string(), "p.tmc:3:5: error: unknown label `Lop`\n    \tJA Lop // x\n    \t   ^^^");
        let d = Diagnostic::at("p.tmc", 1, "ä b", 2, 2, "x".into());
        assert_eq!((d.column, d.width), (2, 1));
        assert_eq!(Diagnostic::file("q.tmc", "cannot read".into()).to_string(), "q.tmc: error: cannot read");
    }
}

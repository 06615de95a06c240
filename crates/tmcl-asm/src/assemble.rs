//! The two-pass assembler.
//!
//! Pass 1 reads the main file and its includes line by line, in order: it defines labels (at the address
//! of the next instruction) and constants (evaluated at once, so they may use only earlier names), and
//! sets aside each instruction line with its address. Pass 2 parses the instruction lines, now that every
//! label is known. Errors from both passes are collected and returned together, sorted by place.

use crate::diag::Diagnostic;
use crate::includes::{FileResolver, LoadError, Resolver, Source};
use crate::suggest::closest;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::Arc;
use tmcl_wire::ascii::{self, ParseErrorKind};
use tmcl_wire::{Instruction, Opcode};

/// The most instructions a program may have (addresses are 16 bits).
pub const MAX_INSTRUCTIONS: usize = u16::MAX as usize;

/// How deeply `#include`s may nest.
const MAX_INCLUDE_DEPTH: usize = 32;

/// Where an instruction came from.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct SourceLine {
    /// The file's name, as in diagnostics.
    pub file: Arc<str>,
    /// Line, from 1.
    pub line: u32,
}

/// An assembled program.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Program {
    /// The instructions; the index is the program address.
    pub instructions: Vec<Instruction>,
    /// Every label and its address.
    pub labels: BTreeMap<String, u16>,
    /// Every constant (also those from include files) and its value.
    pub constants: BTreeMap<String, i32>,
    /// For each address, the line it was assembled from (for debuggers and traces).
    pub source_lines: Vec<SourceLine>,
}

impl Program {
    /// The `.bin` image ([`crate::image`]).
    pub fn to_bin(&self) -> Vec<u8> {
        crate::image::to_bin(&self.instructions)
    }

    /// The symbol file: one `label address` line per label, sorted by address (then by name).
    pub fn symbols(&self) -> String {
        let mut labels: Vec<(&String, &u16)> = self.labels.iter().collect();
        labels.sort_by_key(|&(name, &address)| (address, name));
        labels.into_iter().map(|(name, address)| format!("{name} {address}\n")).collect()
    }

    /// The source line of an address.
    pub fn source(&self, address: u16) -> Option<&SourceLine> {
        self.source_lines.get(address as usize)
    }
}

/// Assembles a file from disk, finding includes next to it and among the built-in files.
pub fn assemble(path: impl AsRef<Path>) -> Result<Program, Vec<Diagnostic>> {
    assemble_file(path.as_ref(), &mut FileResolver::default())
}

/// Assembles a file from disk with a given include resolver.
pub fn assemble_file(path: &Path, resolver: &mut dyn Resolver) -> Result<Program, Vec<Diagnostic>> {
    match FileResolver::read(path) {
        Ok(source) => Assembler::new(resolver).run(source),
        Err(LoadError::Unreadable(why)) => Err(vec![Diagnostic::file(&path.display().to_string(), why)]),
        Err(LoadError::NotFound) => Err(vec![Diagnostic::file(&path.display().to_string(), "not found".into())]),
    }
}

/// Assembles source text; `name` is its file name in diagnostics and the base for relative includes.
pub fn assemble_str(name: &str, text: &str, resolver: &mut dyn Resolver) -> Result<Program, Vec<Diagnostic>> {
    let source = Source { name: name.into(), key: name.into(), text: text.into() };
    Assembler::new(resolver).run(source)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SymbolKind {
    Label,
    Constant,
}

impl SymbolKind {
    fn name(self) -> &'static str {
        match self {
            SymbolKind::Label => "label",
            SymbolKind::Constant => "constant",
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Symbol {
    value: i32,
    kind: SymbolKind,
    file: usize,
    line: u32,
}

/// An instruction line set aside for pass 2.
struct Pending {
    file: usize,
    line: u32,
    /// The line's byte range in the file's text.
    line_range: (usize, usize),
    /// The instruction's byte range within the line.
    code: (usize, usize),
}

/// A constant that used a name not yet defined, to explain once everything is known.
struct Forward {
    file: usize,
    line: u32,
    line_range: (usize, usize),
    span: (usize, usize),
    name: String,
}

struct Assembler<'r> {
    resolver: &'r mut dyn Resolver,
    files: Vec<(Arc<str>, String)>,
    stack: Vec<String>,
    symbols: HashMap<String, Symbol>,
    pending: Vec<Pending>,
    forward: Vec<Forward>,
    diags: Vec<(usize, Diagnostic)>,
}

impl<'r> Assembler<'r> {
    fn new(resolver: &'r mut dyn Resolver) -> Self {
        Assembler {
            resolver,
            files: Vec::new(),
            stack: Vec::new(),
            symbols: HashMap::new(),
            pending: Vec::new(),
            forward: Vec::new(),
            diags: Vec::new(),
        }
    }

    fn run(mut self, main: Source) -> Result<Program, Vec<Diagnostic>> {
        self.pass1(main);
        self.explain_forward_references();
        let program = self.pass2();
        if self.diags.is_empty() {
            return Ok(program);
        }
        // Sort by file (in the order they were first read), then line and column.
        self.diags.sort_by_key(|(file, d)| (*file, d.line, d.column));
        Err(self.diags.into_iter().map(|(_, d)| d).collect())
    }

    fn error(&mut self, file: usize, line: u32, line_range: (usize, usize), span: (usize, usize), message: String) {
        let (name, text) = &self.files[file];
        let source_line = &text[line_range.0..line_range.1];
        self.diags.push((file, Diagnostic::at(name, line, source_line, span.0, span.1, message)));
    }

    fn place(&self, symbol: &Symbol) -> String {
        format!("{}:{}", self.files[symbol.file].0, symbol.line)
    }

    /// Reads one file, recursing into its includes.
    fn pass1(&mut self, source: Source) {
        let file = self.files.len();
        self.files.push((Arc::from(source.name.as_str()), source.text));
        self.stack.push(source.key);
        let text = self.files[file].1.clone();
        let mut line_start = 0;
        for (n, raw) in text.split('\n').enumerate() {
            let line_range = (line_start, line_start + raw.strip_suffix('\r').unwrap_or(raw).len());
            line_start += raw.len() + 1;
            self.line(file, n as u32 + 1, line_range, &text[line_range.0..line_range.1]);
        }
        self.stack.pop();
    }

    /// One line of pass 1.
    fn line(&mut self, file: usize, line: u32, line_range: (usize, usize), text: &str) {
        let code = text.find("//").map_or(text, |i| &text[..i]).trim_end();
        let mut at = 0;
        loop {
            at += code[at..].len() - code[at..].trim_start().len();
            let rest = &code[at..];
            if rest.is_empty() {
                return;
            }
            let directive =
                rest.strip_prefix('#').map(|d| &d[..d.bytes().take_while(u8::is_ascii_alphanumeric).count()]);
            if let Some(word) = directive.filter(|w| !w.eq_ignore_ascii_case("op")) {
                let span = (at, at + 1 + word.len());
                if word.eq_ignore_ascii_case("include") {
                    let arg = rest[span.1 - at..].trim();
                    let arg_at = at + rest.len() - rest[span.1 - at..].trim_start().len();
                    self.include(file, line, line_range, (arg_at, arg_at + arg.len()), arg);
                } else {
                    self.error(file, line, line_range, span, format!("unknown directive `#{word}`"));
                }
                return;
            }
            let name_len = rest.bytes().take_while(|&b| b.is_ascii_alphanumeric() || b == b'_' || b == b'.').count();
            let name = &rest[..name_len];
            if ascii::is_name(name) {
                let after = rest[name_len..].trim_start();
                let span = (at, at + name_len);
                if after.starts_with(':') {
                    let address = self.pending.len();
                    self.define(file, line, line_range, span, name, address as i32, SymbolKind::Label);
                    at = code.len() - after.len() + 1;
                    continue; // an instruction may follow on the same line
                }
                if let Some(expr) = after.strip_prefix('=') {
                    let expr_at = code.len() - expr.len();
                    self.constant(file, line, line_range, span, name, expr_at, expr);
                    return;
                }
            }
            if self.pending.len() == MAX_INSTRUCTIONS {
                let message = format!("the program has more than {MAX_INSTRUCTIONS} instructions");
                self.error(file, line, line_range, (at, code.len()), message);
            }
            self.pending.push(Pending { file, line, line_range, code: (at, code.len()) });
            return;
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn define(
        &mut self,
        file: usize,
        line: u32,
        line_range: (usize, usize),
        span: (usize, usize),
        name: &str,
        value: i32,
        kind: SymbolKind,
    ) {
        if let Some(old) = self.symbols.get(name).copied() {
            // Re-defining a constant with the same value is harmless (a header included twice).
            if kind == SymbolKind::Constant && old.kind == kind && old.value == value {
                return;
            }
            let message = if old.kind == kind {
                format!("duplicate {} `{name}`; first defined at {}", kind.name(), self.place(&old))
            } else {
                format!("`{name}` is already defined as a {} at {}", old.kind.name(), self.place(&old))
            };
            self.error(file, line, line_range, span, message);
            return;
        }
        self.symbols.insert(name.into(), Symbol { value, kind, file, line });
    }

    #[allow(clippy::too_many_arguments)]
    fn constant(
        &mut self,
        file: usize,
        line: u32,
        line_range: (usize, usize),
        span: (usize, usize),
        name: &str,
        expr_at: usize,
        expr: &str,
    ) {
        let symbols = &self.symbols;
        let value = match ascii::parse_value(expr, &mut |n| symbols.get(n).map(|s| s.value)) {
            Ok(v) => v,
            Err(e) => {
                let at = (expr_at + e.span.start, expr_at + e.span.end);
                if e.kind == ParseErrorKind::UnknownSymbol {
                    let used = e.span.of(expr).to_string();
                    self.forward.push(Forward { file, line, line_range, span: at, name: used });
                } else {
                    let (at, message) = match e.kind {
                        ParseErrorKind::Empty | ParseErrorKind::MissingOperand => {
                            (span, format!("constant `{name}` has no value"))
                        }
                        _ => (at, e.with_text(expr).to_string()),
                    };
                    self.error(file, line, line_range, at, message);
                }
                0 // defined anyway, so that its uses do not report it again
            }
        };
        self.define(file, line, line_range, span, name, value, SymbolKind::Constant);
    }

    fn include(&mut self, file: usize, line: u32, line_range: (usize, usize), span: (usize, usize), arg: &str) {
        let name = arg
            .strip_prefix('"')
            .and_then(|a| a.strip_suffix('"'))
            .or_else(|| arg.strip_prefix('<').and_then(|a| a.strip_suffix('>')))
            .unwrap_or(arg);
        if name.is_empty() {
            self.error(file, line, line_range, span, "#include needs a file name".into());
            return;
        }
        let from = self.files[file].0.clone();
        match self.resolver.load(name, &from) {
            Ok(source) if self.stack.contains(&source.key) => {
                let start = self.stack.iter().position(|k| *k == source.key).unwrap_or(0);
                let mut chain: Vec<String> = self.stack[start..].to_vec();
                chain.push(source.key);
                let chain: Vec<String> = chain
                    .iter()
                    .map(|k| {
                        format!("`{}`", Path::new(k).file_name().map_or(k.as_str().into(), |f| f.to_string_lossy()))
                    })
                    .collect();
                self.error(file, line, line_range, span, format!("include cycle: {}", chain.join(" -> ")));
            }
            Ok(_) if self.stack.len() >= MAX_INCLUDE_DEPTH => {
                self.error(file, line, line_range, span, format!("includes nest deeper than {MAX_INCLUDE_DEPTH}"));
            }
            Ok(source) => self.pass1(source),
            Err(LoadError::NotFound) => {
                self.error(file, line, line_range, span, format!("include file `{name}` not found"));
            }
            Err(LoadError::Unreadable(why)) => {
                self.error(file, line, line_range, span, format!("cannot read include file `{name}`: {why}"));
            }
        }
    }

    /// A constant that used a name not defined before it: say whether the name exists at all.
    fn explain_forward_references(&mut self) {
        for f in std::mem::take(&mut self.forward) {
            let message = match self.symbols.get(&f.name) {
                Some(s) => {
                    format!("constant uses {} `{}` before its definition at {}", s.kind.name(), f.name, self.place(s))
                }
                None => self.unknown(&f.name, false),
            };
            self.error(f.file, f.line, f.line_range, f.span, message);
        }
    }

    /// "unknown label `Lop`; did you mean `Loop`?"
    fn unknown(&self, name: &str, is_target: bool) -> String {
        let what = if is_target { "label" } else { "symbol" };
        let labels = self.symbols.iter().filter(|(_, s)| s.kind == SymbolKind::Label).map(|(n, _)| n.as_str());
        let all = self.symbols.keys().map(String::as_str);
        let mut names: Vec<&str> = if is_target { labels.chain(all).collect() } else { all.collect() };
        if is_target {
            // Labels first, so that a label wins a tie; then sort each part for a stable answer.
            let n = self.symbols.values().filter(|s| s.kind == SymbolKind::Label).count();
            names[..n].sort_unstable();
            names[n..].sort_unstable();
        } else {
            names.sort_unstable();
        }
        match closest(name, names) {
            Some(better) => format!("unknown {what} `{name}`; did you mean `{better}`?"),
            None => format!("unknown {what} `{name}`"),
        }
    }

    fn pass2(&mut self) -> Program {
        let mut program = Program::default();
        let pending = std::mem::take(&mut self.pending);
        let mut errors = Vec::new();
        for p in &pending {
            let (file_name, text) = &self.files[p.file];
            let line = &text[p.line_range.0..p.line_range.1];
            let code = &line[p.code.0..p.code.1];
            let symbols = &self.symbols;
            let instruction = match ascii::parse_instruction(code, &mut |n| symbols.get(n).map(|s| s.value)) {
                Ok(i) => i,
                Err(e) => {
                    let span = (p.code.0 + e.span.start, p.code.0 + e.span.end);
                    errors.push((p, span, self.message(code, e)));
                    Instruction::new(Opcode::Unknown(0), 0, 0, 0)
                }
            };
            program.instructions.push(instruction);
            program.source_lines.push(SourceLine { file: file_name.clone(), line: p.line });
        }
        for (p, span, message) in errors {
            self.error(p.file, p.line, p.line_range, span, message);
        }
        for (name, s) in &self.symbols {
            match s.kind {
                SymbolKind::Label => program.labels.insert(name.clone(), s.value as u16).map(drop),
                SymbolKind::Constant => program.constants.insert(name.clone(), s.value).map(drop),
            };
        }
        program
    }

    /// The message for a parse error in `code`, with suggestions.
    fn message(&self, code: &str, e: ascii::ParseError) -> String {
        let word = e.span.of(code);
        match e.kind {
            ParseErrorKind::UnknownSymbol => {
                // A name in the last operand of JA, JC, CSUB or VECT is a jump target.
                let mnemonic = code.split_whitespace().next().unwrap_or("");
                let is_target = Opcode::from_mnemonic(mnemonic).is_some_and(ascii::has_target)
                    && code[e.span.end..].trim().is_empty();
                self.unknown(word, is_target)
            }
            ParseErrorKind::UnknownMnemonic => {
                let mnemonics: Vec<String> = Opcode::ALL
                    .iter()
                    .filter(|op| !op.is_control())
                    .map(|op| op.to_string())
                    .chain(std::iter::once(ascii::RAW_MNEMONIC.to_string()))
                    .collect();
                match closest(word, mnemonics.iter().map(String::as_str)) {
                    Some(better) => format!("unknown mnemonic `{word}`; did you mean `{better}`?"),
                    None => format!("unknown mnemonic `{word}`"),
                }
            }
            _ => e.with_text(code).to_string(),
        }
    }
}

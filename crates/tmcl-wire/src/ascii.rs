//! TMCL instructions as text: the mnemonic syntax of the PD28-1021 TMCL firmware manual §3.7 ("Mnemonic:"
//! lines), shared by the assembler and the firmware's ASCII mode (§3.4).
//!
//! [`parse_instruction`] reads one instruction such as `MVP ABS, 0, 50000`; [`format_instruction`] writes
//! one back. The operands of each opcode, in order, are those of its "Mnemonic:" line:
//!
//! | Opcodes | Operands |
//! |---|---|
//! | ROR, ROL | `<motor>, <velocity>` |
//! | MST | `<motor>` |
//! | MVP | `ABS\|REL\|COORD, <motor>, <value>` |
//! | SAP, SGP, SIO, SCO | `<type>, <motor/bank>, <value>` |
//! | SAC | `<bus number>, <number of bytes>, <send data>` |
//! | GAP, STAP, RSAP, GGP, STGP, RSGP, GIO, GCO, CCO, ACO, AAP, AGP | `<type>, <motor/bank>[, <value>]` |
//! | RFS | `START\|STOP\|STATUS, <motor>[, <value>]` |
//! | CALC | `<op>, <operand>` |
//! | COMP, JA, CSUB | `<value>` |
//! | JC | `<condition>, <address>` |
//! | WAIT | `TICKS\|POS\|REFSW\|LIMSW\|RFS, <motor>, <ticks>` |
//! | CALCX | `<op>` |
//! | CLE | `ALL\|ETO\|EAL\|EDV\|EPO\|ESD` |
//! | EI, DI | `<interrupt>` |
//! | VECT | `<interrupt>, <address>` |
//! | RSUB, STOP, RETI | none |
//! | UF0..UF7 | `<type>, <motor>, <value>` |
//!
//! Fields an opcode's operands do not name are 0. The optional third operand of the two-operand
//! "get"/"store" commands fills the value field, which the manual prints as `<value>` or "don't care" and
//! which the manual itself uses in `GCO 0, 255, 0` (§3.7.25).
//!
//! # The raw form
//!
//! `#op <opcode>, <type>, <motor>, <value>` sets all four fields directly. `<opcode>` is a number or a
//! mnemonic. [`format_instruction`] writes it for the control commands (128..=255, which have no
//! mnemonic), for unknown opcodes, and for instructions with a non-zero field the mnemonic form cannot
//! express (for example `RSUB` with type 3), so that formatting and parsing again never loses a byte.
//!
//! # Operands
//!
//! An operand is a number, a type word of the opcode (in the type position, ignoring case), or a name
//! that the caller's resolver turns into a number (labels, constants). Numbers are decimal, hex with `0x`
//! or `$` (as TMCL-IDE allows), or binary with `0b`, each with an optional sign. Type, motor/bank and
//! opcode operands must be 0..=255; values must fit 32 bits (-2147483648..=4294967295, the upper half
//! wrapping to negative as in the frame).
//!
//! # Panics
//!
//! Nothing in this module panics on any input.

use crate::command::{
    CalcOp, CalcxOp, Condition, ErrorFlag, EventMode, MoveKind, RfsAction, StatusKind, VersionFormat, WaitCondition,
};
use crate::instruction::Instruction;
use crate::opcode::Opcode;
use crate::status::Status;
use core::fmt::{self, Write};

/// A byte range `start..end` in the parsed text.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Span {
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    /// A span.
    pub const fn new(start: usize, end: usize) -> Span {
        Span { start, end }
    }

    /// The spanned text, or `""` if the span does not fit `text`.
    pub fn of<'t>(&self, text: &'t str) -> &'t str {
        text.get(self.start..self.end).unwrap_or("")
    }
}

/// The field of an instruction an operand fills.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Field {
    /// The command number (raw form only).
    Opcode,
    /// The type byte.
    Type,
    /// The motor/bank byte.
    Motor,
    /// The 32-bit value.
    Value,
}

impl Field {
    /// How error messages name the field.
    pub fn name(self) -> &'static str {
        match self {
            Field::Opcode => "the opcode byte",
            Field::Type => "the type byte",
            Field::Motor => "the motor/bank byte",
            Field::Value => "the 32-bit value",
        }
    }

    fn range(self) -> (i64, i64) {
        match self {
            Field::Value => (i32::MIN as i64, u32::MAX as i64),
            _ => (0, 255),
        }
    }
}

/// What went wrong in [`parse_instruction`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParseErrorKind {
    /// The text holds no instruction.
    Empty,
    /// The first word is no mnemonic. The span covers the word.
    UnknownMnemonic,
    /// The resolver knows no such name. The span covers the name, so callers can suggest another.
    UnknownSymbol,
    /// A word in the type position is neither a type word of the opcode nor a known name.
    UnknownTypeWord {
        /// The instruction's opcode, whose words the message lists.
        opcode: Opcode,
    },
    /// Too few or too many operands. The span covers the mnemonic.
    WrongOperandCount {
        /// The opcode; `None` for the raw form `#op`.
        opcode: Option<Opcode>,
        /// Fewest operands accepted.
        min: u8,
        /// Most operands accepted.
        max: u8,
        /// Operands given.
        found: u8,
    },
    /// Nothing between two commas, or after the last one.
    MissingOperand,
    /// Looks like a number but is not one (bad digit, too many digits).
    BadNumber,
    /// Neither a number nor a name.
    BadOperand,
    /// The number does not fit its field.
    OutOfRange {
        /// The field.
        field: Field,
        /// The number given.
        value: i64,
    },
}

/// A parse error: what and where (byte offsets into the parsed text). Small and `Copy`, so that the
/// firmware's ASCII mode can use it without allocating.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParseError {
    /// What went wrong.
    pub kind: ParseErrorKind,
    /// Where.
    pub span: Span,
}

impl ParseError {
    const fn new(kind: ParseErrorKind, span: Span) -> ParseError {
        ParseError { kind, span }
    }

    /// The error with the offending text quoted, e.g. "unknown mnemonic `MVPP`" rather than
    /// "unknown mnemonic". `text` must be the text that was parsed.
    pub fn with_text<'t>(&self, text: &'t str) -> Quoted<'t> {
        Quoted { error: *self, text }
    }
}

/// [`ParseError::with_text`]'s [`fmt::Display`].
#[derive(Debug, Clone, Copy)]
pub struct Quoted<'t> {
    error: ParseError,
    text: &'t str,
}

impl fmt::Display for Quoted<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let word = self.error.span.of(self.text);
        match self.error.kind {
            ParseErrorKind::UnknownMnemonic => write!(f, "unknown mnemonic `{word}`"),
            ParseErrorKind::UnknownSymbol => write!(f, "unknown symbol `{word}`"),
            ParseErrorKind::UnknownTypeWord { opcode } => {
                write!(f, "`{word}` is not a type of {opcode}")?;
                write_words(f, opcode)
            }
            ParseErrorKind::BadNumber => write!(f, "`{word}` is not a valid number"),
            ParseErrorKind::BadOperand => write!(f, "`{word}` is not a number or a name"),
            _ => fmt::Display::fmt(&self.error, f),
        }
    }
}

fn write_words(f: &mut fmt::Formatter<'_>, opcode: Opcode) -> fmt::Result {
    let mut words = (0..=255u8).filter_map(|code| type_name(opcode, code));
    if let Some(first) = words.next() {
        write!(f, " (one of {first}")?;
        for w in words {
            write!(f, ", {w}")?;
        }
        f.write_str(")")?;
    }
    Ok(())
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            ParseErrorKind::Empty => f.write_str("expected an instruction"),
            ParseErrorKind::UnknownMnemonic => f.write_str("unknown mnemonic"),
            ParseErrorKind::UnknownSymbol => f.write_str("unknown symbol"),
            ParseErrorKind::UnknownTypeWord { opcode } => {
                write!(f, "not a type of {opcode}")?;
                write_words(f, opcode)
            }
            ParseErrorKind::WrongOperandCount { opcode, min, max, found } => {
                match opcode {
                    Some(op) => write!(f, "{op} takes ")?,
                    None => f.write_str("#op takes ")?,
                }
                match (min, max) {
                    (0, 0) => f.write_str("no operands")?,
                    (1, 1) => f.write_str("1 operand")?,
                    (a, b) if a == b => write!(f, "{a} operands")?,
                    (a, b) => write!(f, "{a} or {b} operands")?,
                }
                write!(f, ", found {found}")
            }
            ParseErrorKind::MissingOperand => f.write_str("missing operand"),
            ParseErrorKind::BadNumber => f.write_str("not a valid number"),
            ParseErrorKind::BadOperand => f.write_str("not a number or a name"),
            ParseErrorKind::OutOfRange { field, value } => {
                let (min, max) = field.range();
                write!(f, "value {value} does not fit {} ({min}..{max})", field.name())
            }
        }
    }
}

impl From<ParseError> for Status {
    /// For ASCII-mode replies: an unknown mnemonic is an invalid command (2), a bad type word a wrong
    /// type (3), anything else an invalid value (4) (manual §3.2.1 Table 4).
    fn from(e: ParseError) -> Status {
        match e.kind {
            ParseErrorKind::Empty | ParseErrorKind::UnknownMnemonic => Status::InvalidCommand,
            ParseErrorKind::UnknownTypeWord { .. } => Status::WrongType,
            _ => Status::InvalidValue,
        }
    }
}

/// The type number a word names for `opcode` (§3.7.4 MVP, §3.7.13 RFS, §3.7.16 CALC, §3.7.18 JC,
/// §3.7.22 WAIT, §3.7.28 CALCX, §3.7.31 CLE; and the types of the control commands 135, 136, 138),
/// ignoring case.
pub fn type_word(opcode: Opcode, word: &str) -> Option<u8> {
    match opcode {
        Opcode::Mvp => MoveKind::from_word(word).map(MoveKind::code),
        Opcode::Rfs => RfsAction::from_word(word).map(RfsAction::code),
        Opcode::Calc => CalcOp::from_word(word).map(CalcOp::code),
        Opcode::Calcx => CalcxOp::from_word(word).map(CalcxOp::code),
        Opcode::Jc => Condition::from_word(word).map(Condition::code),
        Opcode::Wait => WaitCondition::from_word(word).map(WaitCondition::code),
        Opcode::Cle => ErrorFlag::from_word(word).map(ErrorFlag::code),
        Opcode::GetStatus => StatusKind::from_word(word).map(StatusKind::code),
        Opcode::GetVersion => VersionFormat::from_word(word).map(VersionFormat::code),
        Opcode::RequestTargetReachedEvent => EventMode::from_word(word).map(EventMode::code),
        _ => None,
    }
}

/// The inverse of [`type_word`]: the word for a type number of `opcode`, if it has one.
pub fn type_name(opcode: Opcode, code: u8) -> Option<&'static str> {
    match opcode {
        Opcode::Mvp => MoveKind::from_code(code).map(MoveKind::word),
        Opcode::Rfs => RfsAction::from_code(code).map(RfsAction::word),
        Opcode::Calc => CalcOp::from_code(code).map(CalcOp::word),
        Opcode::Calcx => CalcxOp::from_code(code).map(CalcxOp::word),
        Opcode::Jc => Condition::from_code(code).map(Condition::word),
        Opcode::Wait => WaitCondition::from_code(code).map(WaitCondition::word),
        Opcode::Cle => ErrorFlag::from_code(code).map(ErrorFlag::word),
        Opcode::GetStatus => StatusKind::from_code(code).map(StatusKind::word),
        Opcode::GetVersion => VersionFormat::from_code(code).map(VersionFormat::word),
        Opcode::RequestTargetReachedEvent => EventMode::from_code(code).map(EventMode::word),
        _ => None,
    }
}

/// One operand position of a mnemonic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    /// The type byte as a number or name.
    Type,
    /// The type byte, where the opcode has type words.
    Word,
    /// The motor/bank byte.
    Motor,
    /// The value.
    Value,
    /// The value, an address: printed as a label when the caller has one.
    Target,
}

impl Slot {
    fn field(self) -> Field {
        match self {
            Slot::Type | Slot::Word => Field::Type,
            Slot::Motor => Field::Motor,
            Slot::Value | Slot::Target => Field::Value,
        }
    }
}

/// The operands of a mnemonic: `slots[..required]` must be given, the rest may be.
#[derive(Debug, Clone, Copy)]
struct Shape {
    slots: &'static [Slot],
    required: usize,
}

/// The operands of each mnemonic (§3.7.x "Mnemonic:" lines). `None`: no mnemonic (raw form only).
fn shape(opcode: Opcode) -> Option<Shape> {
    use Slot::*;
    const fn s(slots: &'static [Slot]) -> Shape {
        Shape { slots, required: slots.len() }
    }
    /// `<type>, <motor/bank>[, <value>]`: commands whose value the manual prints as don't care.
    const GET: Shape = Shape { slots: &[Type, Motor, Value], required: 2 };
    Some(match opcode {
        Opcode::Ror | Opcode::Rol => s(&[Motor, Value]),
        Opcode::Mst => s(&[Motor]),
        Opcode::Mvp | Opcode::Wait => s(&[Word, Motor, Value]),
        Opcode::Sap | Opcode::Sgp | Opcode::Sio | Opcode::Sco | Opcode::Sac | Opcode::UserFunction(_) => {
            s(&[Type, Motor, Value])
        }
        Opcode::Gap
        | Opcode::Stap
        | Opcode::Rsap
        | Opcode::Ggp
        | Opcode::Stgp
        | Opcode::Rsgp
        | Opcode::Gio
        | Opcode::Gco
        | Opcode::Cco
        | Opcode::Aco
        | Opcode::Aap
        | Opcode::Agp => GET,
        Opcode::Rfs => Shape { slots: &[Word, Motor, Value], required: 2 },
        Opcode::Calc => s(&[Word, Value]),
        Opcode::Comp => s(&[Value]),
        Opcode::Jc => s(&[Word, Target]),
        Opcode::Ja | Opcode::Csub => s(&[Target]),
        Opcode::Calcx | Opcode::Cle => s(&[Word]),
        Opcode::Ei | Opcode::Di => s(&[Type]),
        Opcode::Vect => s(&[Type, Target]),
        Opcode::Rsub | Opcode::Stop | Opcode::Reti => s(&[]),
        _ => return None,
    })
}

/// The mnemonic of the raw form.
pub const RAW_MNEMONIC: &str = "#op";

/// Whether `opcode`'s value is a program address (JA, JC, CSUB, VECT), which [`format_instruction`]
/// prints as a label when it can.
pub fn has_target(opcode: Opcode) -> bool {
    shape(opcode).is_some_and(|s| s.slots.contains(&Slot::Target))
}

/// A lexed operand.
enum Operand<'t> {
    Number(i64),
    Name(&'t str),
}

fn is_name_start(b: u8) -> bool {
    b.is_ascii_alphabetic() || b == b'_'
}

fn is_name_byte(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_' || b == b'.'
}

/// Whether `text` is a name an operand can refer to: a letter or `_`, then letters, digits, `_` or `.`.
pub fn is_name(text: &str) -> bool {
    let b = text.as_bytes();
    !b.is_empty() && is_name_start(b[0]) && b[1..].iter().all(|&c| is_name_byte(c))
}

fn lex_operand(text: &str) -> Result<Operand<'_>, ParseErrorKind> {
    if is_name(text) {
        return Ok(Operand::Name(text));
    }
    let (negative, digits) = match text.as_bytes().first() {
        Some(b'-') => (true, &text[1..]),
        Some(b'+') => (false, &text[1..]),
        Some(b'0'..=b'9' | b'$') => (false, text),
        _ => return Err(ParseErrorKind::BadOperand),
    };
    let (radix, digits) = if let Some(hex) = digits.strip_prefix('$') {
        (16, hex)
    } else if let Some(hex) = digits.strip_prefix("0x").or_else(|| digits.strip_prefix("0X")) {
        (16, hex)
    } else if let Some(bin) = digits.strip_prefix("0b").or_else(|| digits.strip_prefix("0B")) {
        (2, bin)
    } else {
        (10, digits)
    };
    if digits.is_empty() {
        return Err(ParseErrorKind::BadNumber);
    }
    let mut n: i64 = 0;
    for c in digits.chars() {
        let d = c.to_digit(radix).ok_or(ParseErrorKind::BadNumber)?;
        n = n.checked_mul(radix as i64).and_then(|n| n.checked_add(d as i64)).ok_or(ParseErrorKind::BadNumber)?;
        if n > 1 << 40 {
            return Err(ParseErrorKind::BadNumber);
        }
    }
    Ok(Operand::Number(if negative { -n } else { n }))
}

/// Splits `text[from..]` at commas into trimmed operand spans.
fn operand_spans(text: &str, from: usize) -> impl Iterator<Item = Span> + '_ {
    let rest = &text[from..];
    let none = rest.trim().is_empty();
    let mut start = from;
    rest.split(',').filter(move |_| !none).map(move |piece| {
        let lead = piece.len() - piece.trim_start().len();
        let span = Span::new(start + lead, start + lead + piece.trim().len());
        start += piece.len() + 1;
        span
    })
}

/// Parses one instruction (see the module docs for the syntax). `resolve` turns names that are not type
/// words into numbers; it returns `None` for names it does not know, which gives
/// [`ParseErrorKind::UnknownSymbol`] with the name's span.
pub fn parse_instruction(text: &str, resolve: &mut dyn FnMut(&str) -> Option<i32>) -> Result<Instruction, ParseError> {
    let start = text.len() - text.trim_start().len();
    let word_len = text[start..].bytes().take_while(|&b| is_name_byte(b) || b == b'#').count();
    let mn = Span::new(start, start + word_len);
    if word_len == 0 {
        let end = text.trim_end().len().max(start);
        let kind = if end == start { ParseErrorKind::Empty } else { ParseErrorKind::UnknownMnemonic };
        return Err(ParseError::new(kind, Span::new(start, end)));
    }
    let word = mn.of(text);
    let found = operand_spans(text, mn.end).count();
    let count_error = |opcode, min: usize, max: usize| {
        let kind =
            ParseErrorKind::WrongOperandCount { opcode, min: min as u8, max: max as u8, found: found.min(255) as u8 };
        ParseError::new(kind, mn)
    };
    let mut spans = operand_spans(text, mn.end);
    if word.eq_ignore_ascii_case(RAW_MNEMONIC) {
        if found != 4 {
            return Err(count_error(None, 4, 4));
        }
        let mut next = || spans.next().unwrap_or_default();
        let op_span = next();
        let opcode = match lex(text, op_span)? {
            Operand::Name(name) => match Opcode::from_mnemonic(name) {
                Some(op) => op,
                None => Opcode::from(check(Field::Opcode, symbol(name, op_span, resolve)? as i64, op_span)? as u8),
            },
            Operand::Number(n) => Opcode::from(check(Field::Opcode, n, op_span)? as u8),
        };
        let kind = operand(text, next(), Slot::Type, opcode, resolve)? as u8;
        let motor = operand(text, next(), Slot::Motor, opcode, resolve)? as u8;
        let value = operand(text, next(), Slot::Value, opcode, resolve)?;
        return Ok(Instruction::new(opcode, kind, motor, value));
    }
    let Some((opcode, shape)) = Opcode::from_mnemonic(word).and_then(|op| Some((op, shape(op)?))) else {
        return Err(ParseError::new(ParseErrorKind::UnknownMnemonic, mn));
    };
    if found < shape.required || found > shape.slots.len() {
        return Err(count_error(Some(opcode), shape.required, shape.slots.len()));
    }
    let mut i = Instruction::new(opcode, 0, 0, 0);
    for (&slot, span) in shape.slots.iter().zip(spans) {
        let n = operand(text, span, slot, opcode, resolve)?;
        match slot.field() {
            Field::Type => i.kind = n as u8,
            Field::Motor => i.motor = n as u8,
            _ => i.value = n,
        }
    }
    Ok(i)
}

/// A number as the host tools take it on their command lines and in settings (`tmcl set`, `--set`, the
/// debugger's `set`): decimal or `0x` hexadecimal, with an optional sign (`-5`, `+5`, `0x1F`, `-0x10`).
/// `None` for anything else: no spaces, no names, and none of the assembler's `$` or `0b` forms.
pub fn parse_number(text: &str) -> Option<i64> {
    let (negative, digits) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let (radix, digits) = match digits.strip_prefix("0x").or_else(|| digits.strip_prefix("0X")) {
        Some(hex) if !hex.is_empty() && hex.bytes().all(|b| b.is_ascii_hexdigit()) => (16, hex),
        None if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) => (10, digits),
        _ => return None,
    };
    let magnitude = i64::from_str_radix(digits, radix).ok()?;
    Some(if negative { -magnitude } else { magnitude })
}

/// The 32-bit value a number names: −2³¹..2³¹−1 as it is, and 2³¹..2³²−1 as the two's complement pattern
/// (`0xFFFFFFFF` = −1), as pytrinamic packs values unsigned and the assembler takes them.
pub fn value32(n: i64) -> Option<i32> {
    i32::try_from(n).ok().or_else(|| u32::try_from(n).ok().map(|v| v as i32))
}

/// Parses a value on its own, as in the value position of an instruction: a number, or a name for
/// `resolve`. Surrounding white space is ignored; spans are relative to `text`. The assembler uses it for
/// constant definitions (`MaxSpeed = 50000`).
pub fn parse_value(text: &str, resolve: &mut dyn FnMut(&str) -> Option<i32>) -> Result<i32, ParseError> {
    let start = text.len() - text.trim_start().len();
    let span = Span::new(start, start + text.trim().len());
    operand(text, span, Slot::Value, Opcode::Unknown(0), resolve)
}

fn lex(text: &str, span: Span) -> Result<Operand<'_>, ParseError> {
    if span.start == span.end {
        return Err(ParseError::new(ParseErrorKind::MissingOperand, span));
    }
    lex_operand(span.of(text)).map_err(|kind| ParseError::new(kind, span))
}

fn symbol(name: &str, span: Span, resolve: &mut dyn FnMut(&str) -> Option<i32>) -> Result<i32, ParseError> {
    resolve(name).ok_or(ParseError::new(ParseErrorKind::UnknownSymbol, span))
}

fn check(field: Field, n: i64, span: Span) -> Result<i64, ParseError> {
    let (min, max) = field.range();
    if (min..=max).contains(&n) {
        Ok(n)
    } else {
        Err(ParseError::new(ParseErrorKind::OutOfRange { field, value: n }, span))
    }
}

/// One operand, checked against its field; byte fields come back as 0..=255, values wrapped to `i32`.
fn operand(
    text: &str,
    span: Span,
    slot: Slot,
    opcode: Opcode,
    resolve: &mut dyn FnMut(&str) -> Option<i32>,
) -> Result<i32, ParseError> {
    let n = match lex(text, span)? {
        Operand::Number(n) => n,
        Operand::Name(name) => {
            if slot == Slot::Word {
                if let Some(code) = type_word(opcode, name) {
                    return Ok(code as i32);
                }
                match resolve(name) {
                    Some(n) => n as i64,
                    None => return Err(ParseError::new(ParseErrorKind::UnknownTypeWord { opcode }, span)),
                }
            } else {
                symbol(name, span, resolve)? as i64
            }
        }
    };
    Ok(check(slot.field(), n, span)? as u32 as i32)
}

/// Writes `i` in the syntax [`parse_instruction`] reads, with type words where the opcode has them
/// (`MVP ABS, 0, 50000`), and the raw form `#op` where the mnemonic form cannot hold every byte.
/// `label` names addresses for the value of JA, JC, CSUB and VECT; when it returns `None` (or is `None`)
/// the address is written as a number. Parsing the result with a resolver that knows those labels gives
/// `i` back.
pub fn format_instruction<'a>(
    i: &Instruction,
    out: &mut impl Write,
    label: Option<&dyn Fn(i32) -> Option<&'a str>>,
) -> fmt::Result {
    let Some(shape) = shape(i.opcode).filter(|s| fits(i, s)) else {
        return write!(out, "{RAW_MNEMONIC} {}, {}, {}, {}", i.opcode, i.kind, i.motor, i.value);
    };
    write!(out, "{}", i.opcode)?;
    for (n, &slot) in shape.slots.iter().enumerate() {
        if n >= shape.required && i.value == 0 {
            break; // optional value left out when 0
        }
        out.write_str(if n == 0 { " " } else { ", " })?;
        match slot {
            Slot::Type => write!(out, "{}", i.kind)?,
            Slot::Word => match type_name(i.opcode, i.kind) {
                Some(w) => out.write_str(w)?,
                None => write!(out, "{}", i.kind)?,
            },
            Slot::Motor => write!(out, "{}", i.motor)?,
            Slot::Value => write!(out, "{}", i.value)?,
            Slot::Target => match label.and_then(|l| l(i.value)) {
                Some(name) => out.write_str(name)?,
                None => write!(out, "{}", i.value)?,
            },
        }
    }
    Ok(())
}

/// Whether every non-zero field of `i` has an operand in `shape`.
fn fits(i: &Instruction, shape: &Shape) -> bool {
    let has = |f: Field| shape.slots.iter().any(|s| s.field() == f);
    (i.kind == 0 || has(Field::Type)) && (i.motor == 0 || has(Field::Motor)) && (i.value == 0 || has(Field::Value))
}

/// One ASCII-mode command line after the address character (§3.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AsciiCommand {
    /// `BIN`: leave ASCII mode (§3.4.1).
    Binary,
    /// `RUN`: start the stored TMCL program (§3.4).
    Run,
    /// `STOP`: stop the running TMCL program (§3.4). Not the program instruction STOP (28).
    Stop,
    /// A direct-mode instruction. Only the commands of [`ascii_allowed`] may be executed; the parser
    /// accepts any, so the caller can reply with a status.
    Instruction(Instruction),
}

/// Whether an instruction may be entered in ASCII mode: ROL, ROR, MST, MVP, SAP, GAP, STAP, RSAP, SGP,
/// GGP, STGP, RSGP, RFS, SIO, GIO, SCO, GCO, CCO and UF0..UF7 (PD28-1021 manual §3.4), and SAC (PDx-113
/// manual §5.6.3): the opcodes whose [`OpcodeInfo::ascii`](crate::OpcodeInfo::ascii) is set. A module
/// takes only those of its own commands, [`CommandSet::ascii_subset`](crate::CommandSet::ascii_subset).
pub const fn ascii_allowed(opcode: Opcode) -> bool {
    match opcode.info() {
        Some(info) => info.ascii,
        None => false,
    }
}

/// Parses the text of an ASCII-mode line after its address character (§3.4.2): `BIN`, `RUN`, `STOP`
/// (ignoring case) or an instruction. Spans are relative to `text`.
pub fn parse_ascii_command(
    text: &str,
    resolve: &mut dyn FnMut(&str) -> Option<i32>,
) -> Result<AsciiCommand, ParseError> {
    let word = text.trim();
    for (name, command) in [("BIN", AsciiCommand::Binary), ("RUN", AsciiCommand::Run), ("STOP", AsciiCommand::Stop)] {
        if word.eq_ignore_ascii_case(name) {
            return Ok(command);
        }
    }
    parse_instruction(text, resolve).map(AsciiCommand::Instruction)
}

/// The address character of a module or host address (§3.4.2): `A` for 1, `B` for 2, and so on up to
/// `Z` for 26. The manual does not say what larger addresses use; they have none here.
pub fn address_char(address: u8) -> Option<u8> {
    (1..=26).contains(&address).then(|| b'A' + address - 1)
}

/// The inverse of [`address_char`] (upper-case letters only).
pub fn char_address(c: u8) -> Option<u8> {
    c.is_ascii_uppercase().then(|| c - b'A' + 1)
}

/// Writes an ASCII-mode reply (§3.4.3): host address character, module address character, a space, the
/// status, a space, the value, and `<CR>`; e.g. `BA 100 -5000\r`. Addresses without a character (see
/// [`address_char`]) are written as `?`.
pub fn write_reply(out: &mut impl Write, host: u8, module: u8, status: Status, value: i32) -> fmt::Result {
    let c = |a| address_char(a).map_or('?', char::from);
    write!(out, "{}{} {} {}\r", c(host), c(module), u8::from(status), value)
}

#[cfg(test)]
mod tests;

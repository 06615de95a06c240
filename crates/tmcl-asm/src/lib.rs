//! The TMCL assembler and disassembler.
//!
//! Source syntax, as in the PD28-1021 TMCL firmware manual's listings (§2.4, §3.6.6.4, §3.7, chapter 8):
//!
//! - one instruction per line, in the mnemonic syntax of [`tmcl_wire::ascii`] (`MVP ABS, 0, 50000`);
//!   each instruction takes one program address, counting from 0 (§8.6);
//! - labels: `Loop:` on its own line or before an instruction (`Func1: JA Func1Start`), also `Loop :`;
//!   labels may be used before they are defined;
//! - constants: `MaxSpeed = 50000`, a number or an earlier name; usable wherever a number is;
//! - `#include FILE`, relative to the including file, then the search paths, then the built-in files
//!   generated from the model's tables (`TMCLParam.tmc`, `Interrupts.inc`, see [`includes`]);
//! - `//` comments to the end of the line, and blank lines.
//!
//! Names are case-sensitive; mnemonics and type words are not.
//!
//! [`assemble`] reads a file and returns a [`Program`] or every error it found ([`Diagnostic`]s, printed
//! as `file:line:column: error: ...` with the source line and a caret). [`Program::to_bin`] and
//! [`from_bin`] convert to and from the `.bin` image ([`image`]); [`disassemble`] turns instructions back
//! into source that assembles to the same instructions.

#![forbid(unsafe_code)]

mod assemble;
pub mod diag;
mod disasm;
pub mod image;
pub mod includes;
mod model_check;
pub mod operands;
pub mod suggest;

pub use assemble::{assemble, assemble_file, assemble_str, Program, SourceLine, MAX_INSTRUCTIONS};
pub use diag::Diagnostic;
pub use disasm::{disassemble, DisasmOptions};
pub use image::{from_bin, to_bin, BinError};
pub use includes::{BuiltinResolver, FileResolver, LoadError, Resolver, Source};
pub use model_check::check_model;
pub use operands::{check_operands, why_refused, Finding};

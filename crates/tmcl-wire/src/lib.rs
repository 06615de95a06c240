//! TMCL wire formats, as defined by the PD28-1021 TMCL firmware manual §3.1–3.2 (V1.05, firmware V1.42).
//!
//! This crate turns bytes into values and back, nothing else: it knows no motor, no parameter table and no
//! clock. The layers, from the bytes up:
//!
//! - [`frame`]: the 9-byte request frame as an untrusted byte view ([`Frame`]) with its field map, the 8-bit
//!   sum checksum, and the parsed [`Request`] repr.
//! - [`reply`]: the 9-byte reply frame view ([`ReplyFrame`]), the [`Reply`] repr and [`Response`], which also
//!   carries the raw special replies (command 136 type 0, command 134).
//! - [`status`]: the reply status codes ([`Status`]), unknown codes kept as values.
//! - [`opcode`]: command numbers ([`Opcode`]), unknown numbers kept as values, and the one table of what
//!   each command is: mnemonic, where it may run ([`Availability`]: direct mode, programs or both), whether
//!   it reads a value into the accumulator, whether it replies despite reply suppression, whether it only
//!   reads, whether ASCII mode takes it, and the manual section that defines it ([`OpcodeInfo`], from
//!   [`Opcode::info`]).
//!   Everything else that asks such a question ([`Opcode::is_control`], [`Command::reads_value`],
//!   [`ascii::ascii_allowed`]) reads that table.
//! - [`command_set`]: [`CommandSet`], a constant 256-bit set of command numbers: the commands a model has.
//! - [`instruction`]: one raw command ([`Instruction`]): what a frame carries and what one program-memory
//!   cell holds.
//! - [`command`]: the validated form ([`Command`]) that the firmware executes.
//! - [`ascii`]: one instruction as mnemonic text (`MVP ABS, 0, 50000`), for the assembler and ASCII mode.
//!
//! # Panics
//!
//! Nothing in this crate panics on any input. Views made with `new_checked` (or checked with `check_len`)
//! never index out of bounds; `new_unchecked` views panic on access if the buffer is shorter than a frame,
//! which the view's documentation states.
#![no_std]
#![forbid(unsafe_code)]

#[cfg(feature = "std")]
extern crate std;

pub mod ascii;
pub mod command;
pub mod command_set;
pub mod frame;
pub mod instruction;
pub mod opcode;
pub mod reply;
pub mod status;
pub mod tmc428;

pub use ascii::{format_instruction, parse_instruction, ParseError, ParseErrorKind};
pub use command::{
    CalcOp, CalcxOp, Command, Condition, ErrorFlag, EventMode, MoveTarget, RfsAction, StatusKind, VersionFormat,
    WaitCondition,
};
pub use command_set::CommandSet;
pub use frame::{checksum, Frame, Hex, Request, WireError, FRAME_LEN};
pub use instruction::Instruction;
pub use opcode::{Availability, Opcode, OpcodeInfo};
pub use reply::{Reply, ReplyFrame, Response};
pub use status::Status;

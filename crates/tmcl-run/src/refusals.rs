//! Instructions the module refused while the program ran.
//!
//! A program gets no status: the firmware skips an instruction it refuses and goes on (PD28-1021 manual
//! §3.6; the core's `tmcl_core::vm::refusal`). A simulator is where a user wants to hear of it, so a run
//! lists each refusal with its time, address, source line, the status a host would have got and why:
//! the model's table where it decides (a parameter's range, a bank, a port or motor the model lacks, as
//! `tmcl asm --module` warns), else the status's meaning (the module's state refused it, e.g. a
//! reference search with the loop open).

use crate::setup::Source;
use serde::{Deserialize, Serialize};
use tmcl_core::model::ModelSpec;
use tmcl_core::vm::refusal::Refusal;
use tmcl_core::Module;
use tmcl_sim::SimBoard;

/// At most this many refusals are listed one by one; the rest are counted.
pub const LIST_LIMIT: usize = 1000;

/// One refused instruction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refused {
    /// Which refusal since the start this is, from 1.
    pub number: u64,
    /// Simulated time it ran at, µs.
    pub time_us: u64,
    /// Its address in program memory.
    pub pc: u16,
    /// The instruction in source syntax, e.g. `SAP 4, 0, 51200`.
    pub instruction: String,
    /// Its bytes: opcode, type, motor, value.
    pub opcode: u8,
    /// The type byte.
    pub kind: u8,
    /// The motor/bank byte.
    pub motor: u8,
    /// The value.
    pub value: i32,
    /// The status the module gave it (as a host would have got in direct mode).
    pub status: u8,
    /// The source file, if the program was assembled from source.
    pub file: Option<String>,
    /// The source line, from 1.
    pub line: Option<u32>,
    /// Why: the model's table, or the status's meaning.
    pub reason: String,
}

impl Refused {
    /// `file:line: SAP 4, 0, 51200 (pc 6) at 0.000120 s: status 4: AP 4 (...) takes 0..2047 ...`.
    pub fn describe(&self) -> String {
        let place = match (&self.file, self.line) {
            (Some(f), Some(l)) => format!("{f}:{l}: "),
            _ => String::new(),
        };
        format!(
            "{place}{} (pc {}) at {} s: status {}: {}",
            self.instruction,
            self.pc,
            crate::trace::seconds(self.time_us),
            self.status,
            self.reason
        )
    }
}

/// What a run refused: the count and the list.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Refusals {
    /// Refusals in all.
    pub count: u64,
    /// The first [`LIST_LIMIT`], each as it happened, oldest first (without a trace, a poll that ran
    /// more than the core's log holds lists the last of them; the count stays exact).
    pub listed: Vec<Refused>,
}

/// Reads the module's refusals after each poll.
#[derive(Debug, Clone, Default)]
pub struct Collector {
    seen: u64,
    refusals: Refusals,
}

impl Collector {
    /// The refusals since the last call, appended to the list and returned.
    pub fn collect(&mut self, module: &Module<SimBoard>, source: &Source) -> &[Refused] {
        let log = module.vm().refusals();
        let start = self.refusals.listed.len();
        for r in log.since(self.seen) {
            if self.refusals.listed.len() < LIST_LIMIT {
                self.refusals.listed.push(refused(r, module.spec(), source));
            }
        }
        self.seen = log.count();
        self.refusals.count = log.count();
        &self.refusals.listed[start..]
    }

    /// Everything collected.
    pub fn refusals(&self) -> &Refusals {
        &self.refusals
    }
}

fn refused(r: &Refusal, model: &ModelSpec, source: &Source) -> Refused {
    let i = r.instruction;
    let mut instruction = String::new();
    let _ = tmcl_wire::ascii::format_instruction(&i, &mut instruction, None);
    let (file, line) = match source.place(r.pc) {
        Some((f, l)) => (Some(f.to_string()), Some(l)),
        None => (None, None),
    };
    let reason = match tmcl_asm::why_refused(i, model) {
        Some(f) if f.status == r.status => f.message,
        _ => r.status.description().to_string(),
    };
    Refused {
        number: r.number,
        time_us: r.at.micros(),
        pc: r.pc,
        instruction,
        opcode: i.opcode.code(),
        kind: i.kind,
        motor: i.motor,
        value: i.value,
        status: u8::from(r.status),
        file,
        line,
        reason,
    }
}

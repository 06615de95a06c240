//! Instructions the module refused while a program ran: what a simulator reports, not what the firmware
//! does.
//!
//! A program gets no status (PD28-1021 manual §3.6: only direct mode has replies), so an instruction the
//! module refuses — a parameter out of range (status 4), a type it lacks (3), a command it cannot run
//! now — is skipped and the program goes on (see the module docs of [`crate::vm`]). That stays so; the
//! program machine only notes each refusal here, heap-free: a count since power-up and the last
//! [`LOG`] refusals with the address, the instruction and the status. A simulator reads them between
//! polls ([`Refusals::since`]); a poll that ran more refusals than the log holds says so by the count.

use crate::time::Instant;
use tmcl_wire::{Instruction, Status};

/// How many refusals the log keeps.
pub const LOG: usize = 8;

/// One instruction the module refused while a program ran.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Refusal {
    /// Which refusal since power-up this is, from 1 (the count when it was noted).
    pub number: u64,
    /// The module time the instruction ran at.
    pub at: Instant,
    /// Its address in program memory.
    pub pc: u16,
    /// The instruction as stored.
    pub instruction: Instruction,
    /// The status a host would have got for it in direct mode.
    pub status: Status,
}

/// The count of refusals and the last [`LOG`] of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Refusals {
    count: u64,
    log: [Option<Refusal>; LOG],
}

impl Refusals {
    /// Notes a refusal.
    pub(crate) fn note(&mut self, at: Instant, pc: u16, instruction: Instruction, status: Status) {
        self.count += 1;
        let slot = (self.count % LOG as u64) as usize;
        self.log[slot] = Some(Refusal { number: self.count, at, pc, instruction, status });
    }

    /// Refusals since power-up.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The last refusal, if any.
    pub fn last(&self) -> Option<&Refusal> {
        self.log[(self.count % LOG as u64) as usize].as_ref().filter(|_| self.count > 0)
    }

    /// The refusals after the `seen`th that the log still holds, oldest first. Fewer than
    /// `count() − seen` when more happened than the log keeps.
    pub fn since(&self, seen: u64) -> impl Iterator<Item = &Refusal> {
        let from = seen.max(self.count.saturating_sub(LOG as u64)) + 1;
        (from..=self.count).filter_map(|n| self.log[(n % LOG as u64) as usize].as_ref())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_wire::Opcode;

    #[test]
    fn the_log_keeps_the_last_eight_in_order() {
        let mut r = Refusals::default();
        assert_eq!((r.count(), r.last(), r.since(0).count()), (0, None, 0));
        let i = Instruction::new(Opcode::Sap, 4, 0, 0);
        for pc in 0..11u16 {
            r.note(Instant::from_micros(u64::from(pc) * 20), pc, i, Status::InvalidValue);
        }
        assert_eq!(r.count(), 11);
        assert_eq!(r.last().map(|l| (l.number, l.pc)), Some((11, 10)));
        let pcs: Vec<u16> = r.since(0).map(|l| l.pc).collect();
        assert_eq!(pcs, [3, 4, 5, 6, 7, 8, 9, 10], "the last eight, oldest first");
        let pcs: Vec<u16> = r.since(9).map(|l| l.pc).collect();
        assert_eq!(pcs, [9, 10]);
        assert_eq!(r.since(11).count(), 0);
    }
}

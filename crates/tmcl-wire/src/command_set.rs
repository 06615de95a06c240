//! A set of command numbers, for what a model implements.
//!
//! The manuals differ in which commands a module has: the PD28-1021 has the interrupt commands EI, DI,
//! VECT, RETI, ACO and command 138 (PD28-1021 manual §3.5 Table 5, §3.7.37) but no SAC; the PDx-113 has
//! SAC (PDx-113 manual §5.4.3) but none of the others. A model states its commands as a [`CommandSet`],
//! and the firmware answers a command outside it with status 2, "invalid command" (PD28-1021 manual §3.2.1
//! Table 4). [`CommandSet::ascii_subset`] gives the commands the model's ASCII mode takes.
//!
//! A set is 256 bits, one per command number, so [`CommandSet::contains`] is a shift and a mask. All
//! constructors are `const fn`, so a model's set is a constant:
//!
//! ```
//! use tmcl_wire::{CommandSet, Opcode};
//!
//! const NO_INTERRUPTS: CommandSet = CommandSet::ALL_NAMED
//!     .without(Opcode::Ei)
//!     .without(Opcode::Di)
//!     .without(Opcode::Vect)
//!     .without(Opcode::Reti);
//! assert!(NO_INTERRUPTS.contains(Opcode::Mvp) && !NO_INTERRUPTS.contains(Opcode::Ei));
//! assert!(NO_INTERRUPTS.ascii_subset().contains(Opcode::Mvp));
//! assert!(!NO_INTERRUPTS.ascii_subset().contains(Opcode::Calc));
//! ```
//!
//! # Panics
//!
//! Nothing in this module panics.

use crate::opcode::{Availability, Opcode};
use core::fmt;

/// The table properties [`CommandSet`]'s derived constants select by.
#[derive(Clone, Copy)]
enum Filter {
    ReadOnly,
    ProgramOnly,
    AlwaysReplies,
    ReadsValue,
}

/// A set of command numbers (0..=255), with [`Opcode`]s in and out. Unknown numbers may be members too.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct CommandSet {
    /// Bit `n % 64` of word `n / 64` is set when command number `n` is in the set.
    words: [u64; 4],
}

impl CommandSet {
    /// No command.
    pub const EMPTY: CommandSet = CommandSet { words: [0; 4] };

    /// Every opcode of [`Opcode::ALL`]: every named command, UF0–UF7 included, and no unknown number.
    pub const ALL_NAMED: CommandSet = CommandSet::of(Opcode::ALL);

    /// The commands that only read (the table's `read_only`): a frame of one changes nothing a driver
    /// or an output sees.
    pub const READ_ONLY: CommandSet = CommandSet::ALL_NAMED.filter(Filter::ReadOnly);

    /// The commands that read a value (the table's `reads_value`): in a program they load it into the
    /// accumulator (PD28-1021 manual §3.6.5; RFS only with type STATUS, see `Command::reads_value`).
    pub const READS_VALUE: CommandSet = CommandSet::ALL_NAMED.filter(Filter::ReadsValue);

    /// The commands that reply even while replies are suppressed (the table's `always_replies`: GAP, GGP,
    /// GIO; PD28-1021 manual §5.1, GP 255).
    pub const ALWAYS_REPLY: CommandSet = CommandSet::ALL_NAMED.filter(Filter::AlwaysReplies);

    /// The commands that run only in a program (the table's [`Availability::Program`]): the host gets
    /// status 6 for them (PD28-1021 manual §3.6.3).
    pub const PROGRAM_ONLY: CommandSet = CommandSet::ALL_NAMED.filter(Filter::ProgramOnly);

    const fn filter(self, filter: Filter) -> CommandSet {
        let mut set = CommandSet::EMPTY;
        let mut code = 0usize;
        while code < 256 {
            if self.contains_code(code as u8) {
                if let Some(info) = Opcode::from_code(code as u8).info() {
                    let keep = match filter {
                        Filter::ReadOnly => info.read_only,
                        Filter::ProgramOnly => matches!(info.availability, Availability::Program),
                        Filter::AlwaysReplies => info.always_replies,
                        Filter::ReadsValue => info.reads_value,
                    };
                    if keep {
                        set = set.with(Opcode::from_code(code as u8));
                    }
                }
            }
            code += 1;
        }
        set
    }

    /// The set of `opcodes`.
    pub const fn of(opcodes: &[Opcode]) -> CommandSet {
        let mut set = CommandSet::EMPTY;
        let mut i = 0;
        while i < opcodes.len() {
            set = set.with(opcodes[i]);
            i += 1;
        }
        set
    }

    /// The set with `opcode` added.
    #[must_use]
    pub const fn with(self, opcode: Opcode) -> CommandSet {
        let code = opcode.code();
        let mut words = self.words;
        words[(code >> 6) as usize] |= 1 << (code & 63);
        CommandSet { words }
    }

    /// The set with `opcode` removed.
    #[must_use]
    pub const fn without(self, opcode: Opcode) -> CommandSet {
        let code = opcode.code();
        let mut words = self.words;
        words[(code >> 6) as usize] &= !(1 << (code & 63));
        CommandSet { words }
    }

    /// The commands in either set.
    #[must_use]
    pub const fn union(self, other: CommandSet) -> CommandSet {
        let (a, b) = (self.words, other.words);
        CommandSet { words: [a[0] | b[0], a[1] | b[1], a[2] | b[2], a[3] | b[3]] }
    }

    /// Whether every command of `other` is in this set.
    pub const fn contains_all(&self, other: CommandSet) -> bool {
        let (a, b) = (self.words, other.words);
        b[0] & !a[0] == 0 && b[1] & !a[1] == 0 && b[2] & !a[2] == 0 && b[3] & !a[3] == 0
    }

    /// Whether `opcode` is in the set. For an opcode just made from a frame byte (`Opcode::from(byte)`)
    /// this compiles to the same handful of instructions as [`CommandSet::contains_code`]; for any other
    /// opcode, [`Opcode::code`] comes first.
    #[inline]
    pub const fn contains(&self, opcode: Opcode) -> bool {
        self.contains_code(opcode.code())
    }

    /// Whether command number `code` is in the set: one word load and a bit test, for the byte of a frame
    /// before it is an [`Opcode`].
    #[inline]
    pub const fn contains_code(&self, code: u8) -> bool {
        self.words[(code >> 6) as usize] >> (code & 63) & 1 != 0
    }

    /// The commands of the set that ASCII mode takes ([`OpcodeInfo::ascii`](crate::OpcodeInfo::ascii)):
    /// the PD28-1021 manual §3.4 list and SAC (PDx-113 manual §5.6.3), as far as the set has them.
    #[must_use]
    pub const fn ascii_subset(self) -> CommandSet {
        let mut out = CommandSet::EMPTY;
        let mut i = 0;
        while i < Opcode::ALL.len() {
            let opcode = Opcode::ALL[i];
            if self.contains(opcode) && crate::ascii::ascii_allowed(opcode) {
                out = out.with(opcode);
            }
            i += 1;
        }
        out
    }

    /// How many commands the set holds.
    pub const fn len(&self) -> usize {
        let w = self.words;
        (w[0].count_ones() + w[1].count_ones() + w[2].count_ones() + w[3].count_ones()) as usize
    }

    /// Whether the set holds no command.
    pub const fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The commands, in number order.
    pub fn iter(&self) -> Iter {
        Iter { words: self.words, word: 0 }
    }
}

impl fmt::Debug for CommandSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_set().entries(self.iter()).finish()
    }
}

impl FromIterator<Opcode> for CommandSet {
    fn from_iter<I: IntoIterator<Item = Opcode>>(iter: I) -> CommandSet {
        iter.into_iter().fold(CommandSet::EMPTY, CommandSet::with)
    }
}

impl IntoIterator for CommandSet {
    type Item = Opcode;
    type IntoIter = Iter;

    fn into_iter(self) -> Iter {
        self.iter()
    }
}

impl IntoIterator for &CommandSet {
    type Item = Opcode;
    type IntoIter = Iter;

    fn into_iter(self) -> Iter {
        self.iter()
    }
}

/// The commands of a [`CommandSet`], in number order ([`CommandSet::iter`]).
#[derive(Debug, Clone)]
pub struct Iter {
    /// The members not yet returned.
    words: [u64; 4],
    /// The word to take the next member from.
    word: usize,
}

impl Iterator for Iter {
    type Item = Opcode;

    fn next(&mut self) -> Option<Opcode> {
        while let Some(bits) = self.words.get_mut(self.word) {
            if *bits != 0 {
                let bit = bits.trailing_zeros();
                *bits &= *bits - 1;
                return Some(Opcode::from((self.word as u32 * 64 + bit) as u8));
            }
            self.word += 1;
        }
        None
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = CommandSet { words: self.words }.len();
        (left, Some(left))
    }
}

impl ExactSizeIterator for Iter {}

impl core::iter::FusedIterator for Iter {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_sets() {
        let codes = |s: CommandSet| s.iter().map(Opcode::code).collect::<Vec<_>>();
        assert_eq!(codes(CommandSet::READ_ONLY), [6, 10, 15, 31, 134, 135, 136]);
        assert_eq!(codes(CommandSet::PROGRAM_ONLY), [20, 21, 22, 23, 24, 27, 28, 37, 38]);
        assert_eq!(codes(CommandSet::ALWAYS_REPLY), [6, 10, 15]);
        assert_eq!(codes(CommandSet::READS_VALUE), [6, 10, 13, 15, 29, 31]);
    }

    #[test]
    fn subsets() {
        let all = CommandSet::ALL_NAMED;
        assert!(all.contains_all(all.ascii_subset()));
        assert!(all.contains_all(CommandSet::EMPTY));
        assert!(!all.without(Opcode::Sac).contains_all(all.ascii_subset()));
    }
    use std::vec::Vec;

    fn codes(set: CommandSet) -> Vec<u8> {
        set.iter().map(u8::from).collect()
    }

    #[test]
    fn empty_and_all_named() {
        assert!(CommandSet::EMPTY.is_empty());
        assert_eq!(CommandSet::EMPTY.len(), 0);
        assert_eq!(CommandSet::EMPTY.iter().next(), None);
        assert_eq!(CommandSet::ALL_NAMED.len(), Opcode::ALL.len());
        assert_eq!(CommandSet::ALL_NAMED.iter().collect::<Vec<_>>(), Opcode::ALL);
        for code in 0..=255u8 {
            let op = Opcode::from(code);
            assert_eq!(CommandSet::ALL_NAMED.contains(op), op.info().is_some(), "{code}");
            assert_eq!(CommandSet::ALL_NAMED.contains_code(code), op.info().is_some(), "{code}");
        }
    }

    #[test]
    fn with_without_union() {
        // One number in each word, and both ends.
        let edges = [0u8, 63, 64, 127, 128, 191, 192, 255];
        let set = CommandSet::of(&edges.map(Opcode::from));
        assert_eq!(codes(set), edges);
        assert_eq!(set.len(), 8);
        let less = set.without(Opcode::from(64)).without(Opcode::from(64));
        assert_eq!(codes(less), [0, 63, 127, 128, 191, 192, 255]);
        assert_eq!(less.with(Opcode::UserFunction(0)), set);
        assert_eq!(CommandSet::EMPTY.with(Opcode::Mvp).union(CommandSet::EMPTY.with(Opcode::Sac)).len(), 2);
        assert_eq!(set.union(set), set);
        assert_eq!(set.union(CommandSet::EMPTY), set);
        assert!(set.contains(Opcode::Unknown(0)) && !set.contains(Opcode::Ror));
        let collected: CommandSet = [Opcode::Gap, Opcode::Sap, Opcode::Gap].into_iter().collect();
        assert_eq!(codes(collected), [5, 6]);
    }

    #[test]
    fn ascii_subset() {
        // The PD28-1021 §3.4 list and SAC (PDx-113 §5.6.3); unknown numbers never.
        let ascii: Vec<u8> = (1..=15).chain([29, 30, 31, 32]).chain(64..=71).collect();
        assert_eq!(codes(CommandSet::ALL_NAMED.ascii_subset()), ascii);
        let set = CommandSet::of(&[Opcode::Mvp, Opcode::Calc, Opcode::Unknown(16), Opcode::EnterAscii]);
        assert_eq!(codes(set.ascii_subset()), [4]);
        assert!(CommandSet::EMPTY.ascii_subset().is_empty());
    }

    #[test]
    fn usable_in_constants() {
        const PDX_113: CommandSet = CommandSet::ALL_NAMED
            .without(Opcode::Ei)
            .without(Opcode::Di)
            .without(Opcode::Vect)
            .without(Opcode::Reti)
            .without(Opcode::Aco);
        const HAS_SAC: bool = PDX_113.contains(Opcode::Sac);
        const LEN: usize = PDX_113.len();
        const { assert!(HAS_SAC) };
        assert_eq!(LEN, Opcode::ALL.len() - 5);
    }

    #[test]
    fn iterator_is_exact_and_debug_lists_members() {
        let set = CommandSet::of(&[Opcode::Sac, Opcode::Ror, Opcode::SoftwareReset]);
        let mut it = set.iter();
        assert_eq!(it.len(), 3);
        assert_eq!(it.next(), Some(Opcode::Ror));
        assert_eq!(it.len(), 2);
        assert_eq!(it.by_ref().count(), 2);
        assert_eq!(it.next(), None);
        assert_eq!(std::format!("{set:?}"), "{Ror, Sac, SoftwareReset}");
    }
}

#[cfg(test)]
mod proptests {
    use super::*;
    use std::vec::Vec;

    proptest::proptest! {
        /// A set holds exactly what went in, and iterates it in order without duplicates.
        #[test]
        fn behaves_like_a_sorted_set(codes: Vec<u8>, removed: Vec<u8>) {
            let mut expected: Vec<u8> = codes.iter().copied().filter(|c| !removed.contains(c)).collect();
            expected.sort_unstable();
            expected.dedup();
            let mut set = CommandSet::of(&codes.iter().map(|&c| Opcode::from(c)).collect::<Vec<_>>());
            for &c in &removed {
                set = set.without(Opcode::from(c));
            }
            proptest::prop_assert_eq!(set.iter().map(u8::from).collect::<Vec<_>>(), expected.clone());
            proptest::prop_assert_eq!(set.len(), expected.len());
            for code in 0..=255u8 {
                proptest::prop_assert_eq!(set.contains_code(code), expected.contains(&code));
            }
        }
    }
}

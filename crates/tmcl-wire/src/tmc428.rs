//! TMC428/TMC429 SPI datagrams: what SAC (command 29, PDx-113 manual §5.4.3) carries to the motion
//! controller and back.
//!
//! Defined in the TMC428 datasheet ("Serial peripheral interface for µC", "datagram structure") and
//! the TMC429 datasheet v1.07 §7.3–7.5 (Tables 7-3, 7-4), which keeps the layout: every datagram is 32
//! bits, most significant bit first.
//!
//! ```text
//! sent:      31 RRS | 30..25 ADDRESS (SMDA 30..29, IDX/JDX 28..25) | 24 RW | 23..0 DATA
//! received:  31 INT | 30 CDGW | 29 RS3 | 28 xEQt3 | 27 RS2 | 26 xEQt2 | 25 RS1 | 24 xEQt1 | 23..0 DATA
//! ```
//!
//! RRS selects the registers (0) or the on-chip RAM (1); SMDA the stepper motor 0..2 or, with 3, the
//! common registers; RW = 1 reads, 0 writes. Every 32-bit word is a datagram, so parsing never fails
//! and nothing here panics. The TMC429 datasheet's example (§7.5): writing `0x000123` to register
//! address %001101 is `0x1A000123`, reading it back `0x1B000000`, answered `…000123` with the status
//! bits in front.

/// One datagram from the microcontroller to the TMC428.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Datagram {
    /// RRS: true = on-chip RAM, false = registers.
    pub ram: bool,
    /// The 6 address bits: SMDA (bits 5..4) and IDX/JDX (bits 3..0) for registers; a RAM address.
    pub address: u8,
    /// RW: true = read, false = write.
    pub read: bool,
    /// The 24 data bits (don't care for a read).
    pub data: u32,
}

/// SMDA 3: the common (global) registers.
pub const SMDA_COMMON: u8 = 3;

impl Datagram {
    /// The datagram of a 32-bit word (the SAC value).
    pub const fn parse(word: u32) -> Datagram {
        Datagram {
            ram: word & (1 << 31) != 0,
            address: ((word >> 25) & 0x3F) as u8,
            read: word & (1 << 24) != 0,
            data: word & 0x00FF_FFFF,
        }
    }

    /// The 32-bit word.
    pub const fn emit(&self) -> u32 {
        ((self.ram as u32) << 31)
            | (((self.address & 0x3F) as u32) << 25)
            | ((self.read as u32) << 24)
            | (self.data & 0x00FF_FFFF)
    }

    /// SMDA: stepper motor 0..2, or 3 for the common registers.
    pub const fn smda(&self) -> u8 {
        self.address >> 4
    }

    /// IDX (JDX for the common registers): the register within its block, 0..15.
    pub const fn index(&self) -> u8 {
        self.address & 0x0F
    }
}

/// The status bits the TMC428 sends in front of every answer (TMC429 datasheet Table 7-4).
pub mod status {
    /// Interrupt pending.
    pub const INT: u8 = 0x80;
    /// Cover datagram waiting.
    pub const CDGW: u8 = 0x40;
    /// Reference switch of motor 3.
    pub const RS3: u8 = 0x20;
    /// Motor 3 at its target.
    pub const XEQT3: u8 = 0x10;
    /// Reference switch of motor 2.
    pub const RS2: u8 = 0x08;
    /// Motor 2 at its target.
    pub const XEQT2: u8 = 0x04;
    /// Reference switch of motor 1.
    pub const RS1: u8 = 0x02;
    /// Motor 1 at its target.
    pub const XEQT1: u8 = 0x01;
}

/// One answer from the TMC428: the status bits and 24 data bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Answer {
    /// The status bits ([`status`]).
    pub status: u8,
    /// The data read (0 for a write).
    pub data: u32,
}

impl Answer {
    /// The 32-bit word.
    pub const fn emit(&self) -> u32 {
        ((self.status as u32) << 24) | (self.data & 0x00FF_FFFF)
    }

    /// The answer in a 32-bit word.
    pub const fn parse(word: u32) -> Answer {
        Answer { status: (word >> 24) as u8, data: word & 0x00FF_FFFF }
    }
}

/// Sign-extends a register value of `bits` bits (positions are 24-bit, velocities 12-bit signed).
pub const fn sign_extend(value: u32, bits: u32) -> i32 {
    let shift = 32 - bits;
    ((value << shift) as i32) >> shift
}

#[cfg(test)]
mod tests {
    use super::*;

    /// TMC429 datasheet §7.5: a write of 0x000123 to address %001101, the read back, and the answers.
    #[test]
    fn datasheet_examples() {
        let write = Datagram::parse(0b0001_1010_0000_0000_0000_0001_0010_0011);
        assert_eq!(write, Datagram { ram: false, address: 0b001101, read: false, data: 0x123 });
        assert_eq!(write.emit(), 0x1A00_0123);
        let read = Datagram::parse(0x1B00_0000);
        assert!(read.read && read.address == 0b001101 && read.smda() == 0 && read.index() == 13);
        // All motors at their targets, no switch, no interrupt.
        let all_there = status::XEQT1 | status::XEQT2 | status::XEQT3;
        assert_eq!(Answer { status: all_there, data: 0x123 }.emit(), 0x1500_0123);
        assert_eq!(Answer::parse(0x9500_0123), Answer { status: 0x95, data: 0x123 });
    }

    #[test]
    fn every_word_round_trips() {
        for word in [0u32, u32::MAX, 0x8000_0000, 0x7E00_0000, 0x0100_0001, 0x7300_0000] {
            assert_eq!(Datagram::parse(word).emit(), word);
            assert_eq!(Answer::parse(word).emit(), word);
        }
        // The type/version register of the TMC429: RRS 0, SMDA 3, JDX 9, read.
        let d = Datagram::parse(0x7300_0000);
        assert_eq!((d.smda(), d.index(), d.read), (SMDA_COMMON, 9, true));
    }

    #[test]
    fn sign_extension() {
        assert_eq!(sign_extend(0xFF_FFFF, 24), -1);
        assert_eq!(sign_extend(0x80_0000, 24), -(1 << 23));
        assert_eq!(sign_extend(0x7FF, 12), 2047);
        assert_eq!(sign_extend(0x801, 12), -2047);
    }
}

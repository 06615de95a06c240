//! One EtherCAT datagram (ETG.1000.4, "EtherCAT PDU" / DLPDU; Beckhoff's ET1100 datasheet, "EtherCAT
//! datagram").
//!
//! | bytes | field |
//! |---|---|
//! | 0 | command |
//! | 1 | index (the master's tag, echoed) |
//! | 2..6 | address: ADP (2..4) and ADO (4..6) for physical commands, a 32-bit logical address for Lxx |
//! | 6..8 | bits 0..11 data length, 14 circulating frame, 15 more datagrams follow |
//! | 8..10 | IRQ (event request bits) |
//! | 10..10+n | data |
//! | 10+n..12+n | working counter |
//!
//! All multi-byte fields are little-endian.

use super::{enum_with_unknown, le, Error};

/// Length of the header before the data.
pub const HEADER_LEN: usize = 10;
/// Length of the working counter after the data.
pub const WKC_LEN: usize = 2;
/// The largest data length the 11-bit field holds.
pub const MAX_DATA: usize = 0x07FF;

/// Byte ranges of the datagram header.
pub mod field {
    use core::ops::Range;
    /// Command.
    pub const COMMAND: usize = 0;
    /// Index.
    pub const INDEX: usize = 1;
    /// Address (ADP + ADO, or logical).
    pub const ADDRESS: Range<usize> = 2..6;
    /// Auto-increment or configured station address (position).
    pub const ADP: Range<usize> = 2..4;
    /// Physical memory or register address (offset).
    pub const ADO: Range<usize> = 4..6;
    /// Length and flags.
    pub const LENGTH: Range<usize> = 6..8;
    /// IRQ.
    pub const IRQ: Range<usize> = 8..10;
    /// Where the data start.
    pub const DATA: usize = 10;
}

enum_with_unknown! {
    /// The datagram command (ETG.1000.4, "Command type"; ET1100 datasheet table "EtherCAT command types").
    pub enum Command(u8) {
        /// No operation.
        Nop = 0,
        /// Auto-increment physical read.
        Aprd = 1,
        /// Auto-increment physical write.
        Apwr = 2,
        /// Auto-increment physical read/write.
        Aprw = 3,
        /// Configured-address physical read.
        Fprd = 4,
        /// Configured-address physical write.
        Fpwr = 5,
        /// Configured-address physical read/write.
        Fprw = 6,
        /// Broadcast read (the data of every slave ORed).
        Brd = 7,
        /// Broadcast write.
        Bwr = 8,
        /// Broadcast read/write.
        Brw = 9,
        /// Logical read.
        Lrd = 10,
        /// Logical write.
        Lwr = 11,
        /// Logical read/write.
        Lrw = 12,
        /// Auto-increment physical read, multiple write: the addressed slave reads, the others write.
        Armw = 13,
        /// Configured-address physical read, multiple write.
        Frmw = 14,
    }
}

/// How a command picks its slaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Addressing {
    /// By position: the slave whose auto-increment address (ADP, incremented by every slave) is 0.
    AutoIncrement,
    /// By configured station address (register 0x0010, or the alias 0x0012 when enabled).
    Configured,
    /// Every slave.
    Broadcast,
    /// By logical address, through the FMMUs.
    Logical,
    /// No slave (NOP and unknown commands).
    None,
}

impl Command {
    /// How the command addresses slaves.
    pub const fn addressing(self) -> Addressing {
        match self {
            Command::Aprd | Command::Apwr | Command::Aprw | Command::Armw => Addressing::AutoIncrement,
            Command::Fprd | Command::Fpwr | Command::Fprw | Command::Frmw => Addressing::Configured,
            Command::Brd | Command::Bwr | Command::Brw => Addressing::Broadcast,
            Command::Lrd | Command::Lwr | Command::Lrw => Addressing::Logical,
            Command::Nop | Command::Unknown(_) => Addressing::None,
        }
    }

    /// Whether the command reads memory into the datagram (for ARMW/FRMW: the addressed slave does).
    pub const fn reads(self) -> bool {
        matches!(
            self,
            Command::Aprd
                | Command::Aprw
                | Command::Fprd
                | Command::Fprw
                | Command::Brd
                | Command::Brw
                | Command::Lrd
                | Command::Lrw
                | Command::Armw
                | Command::Frmw
        )
    }

    /// Whether the command writes the datagram into memory (for ARMW/FRMW: the other slaves do).
    pub const fn writes(self) -> bool {
        matches!(
            self,
            Command::Apwr
                | Command::Aprw
                | Command::Fpwr
                | Command::Fprw
                | Command::Bwr
                | Command::Brw
                | Command::Lwr
                | Command::Lrw
                | Command::Armw
                | Command::Frmw
        )
    }
}

/// A read/write view of one datagram. Accessors panic if the buffer is shorter than the header, the
/// declared data and the working counter; [`Datagram::new_checked`] rules that out. The buffer may be
/// longer (the rest of the frame): [`Datagram::total_len`] says where this datagram ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Datagram<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Datagram<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Datagram<T> {
        Datagram { buffer }
    }

    /// Wraps a buffer after [`Datagram::check_len`].
    pub fn new_checked(buffer: T) -> Result<Datagram<T>, Error> {
        let d = Datagram::new_unchecked(buffer);
        d.check_len()?;
        Ok(d)
    }

    /// Ensures that no accessor will panic.
    pub fn check_len(&self) -> Result<(), Error> {
        let b = self.buffer.as_ref();
        if b.len() < HEADER_LEN || b.len() < HEADER_LEN + usize::from(le::u16(b, 6) & 0x07FF) + WKC_LEN {
            Err(Error::Truncated)
        } else {
            Ok(())
        }
    }

    /// The underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Command.
    pub fn command(&self) -> Command {
        Command::from(self.buffer.as_ref()[field::COMMAND])
    }

    /// Index.
    pub fn index(&self) -> u8 {
        self.buffer.as_ref()[field::INDEX]
    }

    /// The address as one 32-bit number (logical commands).
    pub fn address(&self) -> u32 {
        le::u32(self.buffer.as_ref(), field::ADDRESS.start)
    }

    /// ADP: position (auto-increment) or station address (configured).
    pub fn adp(&self) -> u16 {
        le::u16(self.buffer.as_ref(), field::ADP.start)
    }

    /// ADO: the register or memory offset.
    pub fn ado(&self) -> u16 {
        le::u16(self.buffer.as_ref(), field::ADO.start)
    }

    /// Data length.
    pub fn length(&self) -> u16 {
        le::u16(self.buffer.as_ref(), field::LENGTH.start) & 0x07FF
    }

    /// The circulating-frame bit (set by a slave that closed the ring on a frame seen before).
    pub fn circulating(&self) -> bool {
        le::u16(self.buffer.as_ref(), field::LENGTH.start) & 0x4000 != 0
    }

    /// Whether another datagram follows.
    pub fn more(&self) -> bool {
        le::u16(self.buffer.as_ref(), field::LENGTH.start) & 0x8000 != 0
    }

    /// IRQ.
    pub fn irq(&self) -> u16 {
        le::u16(self.buffer.as_ref(), field::IRQ.start)
    }

    /// The data.
    pub fn data(&self) -> &[u8] {
        &self.buffer.as_ref()[field::DATA..field::DATA + usize::from(self.length())]
    }

    /// Working counter.
    pub fn wkc(&self) -> u16 {
        le::u16(self.buffer.as_ref(), field::DATA + usize::from(self.length()))
    }

    /// Header, data and working counter: where the next datagram starts.
    pub fn total_len(&self) -> usize {
        HEADER_LEN + usize::from(self.length()) + WKC_LEN
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Datagram<T> {
    /// Sets the command.
    pub fn set_command(&mut self, c: Command) {
        self.buffer.as_mut()[field::COMMAND] = c.into();
    }

    /// Sets the index.
    pub fn set_index(&mut self, i: u8) {
        self.buffer.as_mut()[field::INDEX] = i;
    }

    /// Sets the address as one 32-bit number.
    pub fn set_address(&mut self, a: u32) {
        le::set_u32(self.buffer.as_mut(), field::ADDRESS.start, a);
    }

    /// Sets ADP (a slave increments it in auto-increment commands).
    pub fn set_adp(&mut self, adp: u16) {
        le::set_u16(self.buffer.as_mut(), field::ADP.start, adp);
    }

    /// Sets ADO.
    pub fn set_ado(&mut self, ado: u16) {
        le::set_u16(self.buffer.as_mut(), field::ADO.start, ado);
    }

    /// Sets the length and the flags. Does not move the data: use on a buffer laid out for `length`.
    pub fn set_length(&mut self, length: u16, circulating: bool, more: bool) {
        let word = (length & 0x07FF) | if circulating { 0x4000 } else { 0 } | if more { 0x8000 } else { 0 };
        le::set_u16(self.buffer.as_mut(), field::LENGTH.start, word);
    }

    /// Sets the IRQ field.
    pub fn set_irq(&mut self, irq: u16) {
        le::set_u16(self.buffer.as_mut(), field::IRQ.start, irq);
    }

    /// The data, mutably.
    pub fn data_mut(&mut self) -> &mut [u8] {
        let n = usize::from(self.length());
        &mut self.buffer.as_mut()[field::DATA..field::DATA + n]
    }

    /// Sets the working counter.
    pub fn set_wkc(&mut self, wkc: u16) {
        let at = field::DATA + usize::from(self.length());
        le::set_u16(self.buffer.as_mut(), at, wkc);
    }
}

/// The header and working counter of a datagram as values (the data stay in the buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Repr {
    /// Command.
    pub command: Command,
    /// Index.
    pub index: u8,
    /// Address (ADP in the low half, ADO in the high half for physical commands).
    pub address: u32,
    /// Data length.
    pub length: u16,
    /// Circulating-frame bit.
    pub circulating: bool,
    /// More datagrams follow.
    pub more: bool,
    /// IRQ.
    pub irq: u16,
    /// Working counter.
    pub wkc: u16,
}

impl Repr {
    /// Reads the header and working counter of a checked view.
    pub fn parse<T: AsRef<[u8]>>(d: &Datagram<T>) -> Result<Repr, Error> {
        d.check_len()?;
        Ok(Repr {
            command: d.command(),
            index: d.index(),
            address: d.address(),
            length: d.length(),
            circulating: d.circulating(),
            more: d.more(),
            irq: d.irq(),
            wkc: d.wkc(),
        })
    }

    /// A physical address from station or position and register offset.
    pub const fn physical(adp: u16, ado: u16) -> u32 {
        adp as u32 | (ado as u32) << 16
    }

    /// Bytes the datagram needs (header, data, working counter).
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN + self.length as usize + WKC_LEN
    }

    /// Writes header and working counter into a view of at least [`Repr::buffer_len`] bytes (the data
    /// area is left as it is).
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, d: &mut Datagram<T>) {
        d.set_command(self.command);
        d.set_index(self.index);
        d.set_address(self.address);
        d.set_length(self.length, self.circulating, self.more);
        d.set_irq(self.irq);
        d.set_wkc(self.wkc);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SOEM's FPRD of AL status, reserved word and AL status code (6 bytes at 0x0130) of station 0x1001,
    /// as the slave answered it in the recorded session `tests/data/soem-session.txt`: INIT, code 0,
    /// working counter 1.
    static FPRD_AL_STATUS: [u8; 18] =
        [0x04, 0x05, 0x01, 0x10, 0x30, 0x01, 0x06, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00];

    #[test]
    fn deconstruct() {
        let d = Datagram::new_checked(&FPRD_AL_STATUS[..]).unwrap();
        assert_eq!(d.command(), Command::Fprd);
        assert_eq!(d.command().addressing(), Addressing::Configured);
        assert_eq!((d.index(), d.adp(), d.ado(), d.length()), (0x05, 0x1001, 0x0130, 6));
        assert!(!d.more() && !d.circulating());
        assert_eq!((d.data(), d.wkc(), d.total_len()), (&[1u8, 0, 0, 0, 0, 0][..], 1, 18));
    }

    #[test]
    fn round_trip() {
        let d = Datagram::new_checked(&FPRD_AL_STATUS[..]).unwrap();
        let repr = Repr::parse(&d).unwrap();
        assert_eq!(repr.address, Repr::physical(0x1001, 0x0130));
        let mut bytes = [0u8; 18];
        let mut out = Datagram::new_unchecked(&mut bytes[..]);
        repr.emit(&mut out);
        out.data_mut().copy_from_slice(&[1, 0, 0, 0, 0, 0]);
        assert_eq!(bytes, FPRD_AL_STATUS);
    }

    #[test]
    fn unknown_commands_keep_their_number() {
        assert_eq!(Command::from(15), Command::Unknown(15));
        assert_eq!(u8::from(Command::Unknown(15)), 15);
        assert_eq!(Command::Unknown(15).addressing(), Addressing::None);
        assert!(Command::Lrw.reads() && Command::Lrw.writes() && !Command::Lrd.writes());
    }

    #[test]
    fn declared_data_must_fit() {
        assert_eq!(Datagram::new_checked(&FPRD_AL_STATUS[..17]), Err(Error::Truncated));
        let mut long = FPRD_AL_STATUS;
        long[6] = 0xff;
        assert_eq!(Datagram::new_checked(&long[..]), Err(Error::Truncated));
    }
}

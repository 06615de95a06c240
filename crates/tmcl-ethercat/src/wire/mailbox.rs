//! The standard mailbox header (ETG.1000.4, "Mailbox"; ETG.1000.6, "Mailbox protocol").
//!
//! | bytes | field |
//! |---|---|
//! | 0..2 | length of the data after the header |
//! | 2..4 | address (station address of the source; 0 from the master) |
//! | 4 | bits 0..6 channel, 6..8 priority |
//! | 5 | bits 0..4 type (0 error, 1 AoE, 2 EoE, 3 CoE, 4 FoE, 5 SoE, 15 VoE), 4..7 counter |
//! | 6.. | data |
//!
//! The virtual TMCM-1310 carries TMCL raw, without this header, in PRE-OP, SAFE-OP and OP (its manual
//! §3.5–3.6); the header is used in BOOT, where the mailbox speaks FoE (manual §3.2, §3.3).

use super::{enum_with_unknown, le, Error};

/// Length of the header.
pub const HEADER_LEN: usize = 6;

/// Byte ranges of the header.
pub mod field {
    use core::ops::Range;
    /// Data length.
    pub const LENGTH: Range<usize> = 0..2;
    /// Address.
    pub const ADDRESS: Range<usize> = 2..4;
    /// Channel and priority.
    pub const CHANNEL: usize = 4;
    /// Type and counter.
    pub const TYPE: usize = 5;
    /// Where the data start.
    pub const DATA: usize = 6;
}

enum_with_unknown! {
    /// The mailbox protocol (header byte 5, bits 0..4).
    pub enum MailboxType(u8) {
        /// A mailbox error reply.
        Error = 0x0,
        /// ADS over EtherCAT.
        Aoe = 0x1,
        /// Ethernet over EtherCAT.
        Eoe = 0x2,
        /// CANopen over EtherCAT.
        Coe = 0x3,
        /// File access over EtherCAT.
        Foe = 0x4,
        /// Servo profile over EtherCAT.
        Soe = 0x5,
        /// Vendor specific.
        Voe = 0xF,
    }
}

enum_with_unknown! {
    /// The detail of a mailbox error reply (ETG.1000.6, "Mailbox error reply").
    pub enum ErrorDetail(u16) {
        /// Syntax of the 6-byte header is wrong.
        Syntax = 0x0001,
        /// The mailbox protocol is not supported.
        UnsupportedProtocol = 0x0002,
        /// Channel field contains a wrong value.
        InvalidChannel = 0x0003,
        /// The service in the mailbox protocol is not supported.
        ServiceNotSupported = 0x0004,
        /// The mailbox protocol header is wrong.
        InvalidHeader = 0x0005,
        /// Length of the received data is too short.
        SizeTooShort = 0x0006,
        /// Not enough memory in the slave.
        NoMoreMemory = 0x0007,
        /// The length of the data is inconsistent.
        InvalidSize = 0x0008,
    }
}

/// A read/write view of a mailbox message. Accessors panic if the buffer is shorter than the header and
/// its declared data; [`Mailbox::new_checked`] rules that out. The buffer may be longer (the rest of
/// the SyncManager buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mailbox<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Mailbox<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Mailbox<T> {
        Mailbox { buffer }
    }

    /// Wraps a buffer after [`Mailbox::check_len`].
    pub fn new_checked(buffer: T) -> Result<Mailbox<T>, Error> {
        let m = Mailbox::new_unchecked(buffer);
        m.check_len()?;
        Ok(m)
    }

    /// Ensures that no accessor will panic.
    pub fn check_len(&self) -> Result<(), Error> {
        let b = self.buffer.as_ref();
        if b.len() < HEADER_LEN || b.len() < HEADER_LEN + usize::from(le::u16(b, 0)) {
            Err(Error::Truncated)
        } else {
            Ok(())
        }
    }

    /// The underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Data length.
    pub fn length(&self) -> u16 {
        le::u16(self.buffer.as_ref(), field::LENGTH.start)
    }

    /// Address.
    pub fn address(&self) -> u16 {
        le::u16(self.buffer.as_ref(), field::ADDRESS.start)
    }

    /// Channel.
    pub fn channel(&self) -> u8 {
        self.buffer.as_ref()[field::CHANNEL] & 0x3F
    }

    /// Priority.
    pub fn priority(&self) -> u8 {
        self.buffer.as_ref()[field::CHANNEL] >> 6
    }

    /// Protocol.
    pub fn mailbox_type(&self) -> MailboxType {
        MailboxType::from(self.buffer.as_ref()[field::TYPE] & 0x0F)
    }

    /// Counter (1..7; 0 = not used).
    pub fn counter(&self) -> u8 {
        (self.buffer.as_ref()[field::TYPE] >> 4) & 0x07
    }

    /// The data.
    pub fn data(&self) -> &[u8] {
        &self.buffer.as_ref()[field::DATA..field::DATA + usize::from(self.length())]
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Mailbox<T> {
    /// The data, mutably.
    pub fn data_mut(&mut self) -> &mut [u8] {
        let n = usize::from(self.length());
        &mut self.buffer.as_mut()[field::DATA..field::DATA + n]
    }
}

/// The header as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Repr {
    /// Data length.
    pub length: u16,
    /// Address.
    pub address: u16,
    /// Channel (0..64).
    pub channel: u8,
    /// Priority (0..4).
    pub priority: u8,
    /// Protocol.
    pub mailbox_type: MailboxType,
    /// Counter (0..8).
    pub counter: u8,
}

impl Repr {
    /// Reads the header of a checked view.
    pub fn parse<T: AsRef<[u8]>>(m: &Mailbox<T>) -> Result<Repr, Error> {
        m.check_len()?;
        Ok(Repr {
            length: m.length(),
            address: m.address(),
            channel: m.channel(),
            priority: m.priority(),
            mailbox_type: m.mailbox_type(),
            counter: m.counter(),
        })
    }

    /// Bytes header and data need.
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN + self.length as usize
    }

    /// Writes the header into the first [`HEADER_LEN`] bytes of `buffer`.
    ///
    /// # Panics
    ///
    /// If `buffer` is shorter than [`HEADER_LEN`].
    pub fn emit(&self, buffer: &mut [u8]) {
        le::set_u16(buffer, field::LENGTH.start, self.length);
        le::set_u16(buffer, field::ADDRESS.start, self.address);
        buffer[field::CHANNEL] = (self.channel & 0x3F) | (self.priority & 0x03) << 6;
        buffer[field::TYPE] = (u8::from(self.mailbox_type) & 0x0F) | (self.counter & 0x07) << 4;
    }
}

/// The data of a mailbox error reply: service type 0x0001 and a detail.
pub const ERROR_REPLY_LEN: usize = 4;

/// Writes a mailbox error reply (header of type 0 and its 4 data bytes) into `buffer`; returns its length.
///
/// # Panics
///
/// If `buffer` is shorter than `HEADER_LEN + ERROR_REPLY_LEN`.
pub fn emit_error(buffer: &mut [u8], counter: u8, detail: ErrorDetail) -> usize {
    let header = Repr {
        length: ERROR_REPLY_LEN as u16,
        address: 0,
        channel: 0,
        priority: 0,
        mailbox_type: MailboxType::Error,
        counter,
    };
    header.emit(buffer);
    le::set_u16(buffer, HEADER_LEN, 0x0001);
    le::set_u16(buffer, HEADER_LEN + 2, detail.into());
    HEADER_LEN + ERROR_REPLY_LEN
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The head of an FoE write request for "fw.bin" laid out as SOEM's `ecx_FOEwrite` builds it (mailbox
    /// counter 1): length 12 (6 bytes of FoE header, 6 of name), address 0, channel 0, type 4 (FoE).
    static FOE_WRITE_HEAD: [u8; 8] = [0x0c, 0x00, 0x00, 0x00, 0x00, 0x14, 0x02, 0x00];

    #[test]
    fn deconstruct() {
        let m = Mailbox::new_unchecked(&FOE_WRITE_HEAD[..]);
        assert_eq!(m.check_len(), Err(Error::Truncated), "12 data bytes declared, 2 there");
        let mut full = [0u8; 18];
        full[..8].copy_from_slice(&FOE_WRITE_HEAD);
        let m = Mailbox::new_checked(&full[..]).unwrap();
        assert_eq!((m.length(), m.address(), m.channel(), m.priority()), (12, 0, 0, 0));
        assert_eq!((m.mailbox_type(), m.counter()), (MailboxType::Foe, 1));
        assert_eq!(m.data()[..2], [0x02, 0x00]);
    }

    #[test]
    fn round_trip() {
        let mut full = [0u8; 18];
        full[..8].copy_from_slice(&FOE_WRITE_HEAD);
        let repr = Repr::parse(&Mailbox::new_checked(&full[..]).unwrap()).unwrap();
        let mut out = [0u8; 6];
        repr.emit(&mut out);
        assert_eq!(out, FOE_WRITE_HEAD[..6]);
    }

    #[test]
    fn error_reply() {
        let mut out = [0u8; 10];
        assert_eq!(emit_error(&mut out, 2, ErrorDetail::UnsupportedProtocol), 10);
        assert_eq!(out, [4, 0, 0, 0, 0, 0x20, 1, 0, 2, 0]);
    }
}

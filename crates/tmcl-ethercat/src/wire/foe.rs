//! File access over EtherCAT, the data of a mailbox message of type 4 (ETG.1000.6, "FoE").
//!
//! | bytes | field |
//! |---|---|
//! | 0 | opcode: 1 read request, 2 write request, 3 data, 4 ack, 5 error, 6 busy |
//! | 1 | reserved |
//! | 2..6 | password (requests), packet number (data, ack), error code (error); busy: done (2..4) and entire (4..6) |
//! | 6.. | file name (requests), data (data), error text (error), busy text |
//!
//! A write runs: write request → ack 0 → data 1 → ack 1 → … The file ends with a data packet shorter than
//! the mailbox allows (possibly empty).

use super::{enum_with_unknown, le, Error};

/// Length of the FoE header.
pub const HEADER_LEN: usize = 6;

enum_with_unknown! {
    /// The FoE opcode.
    pub enum Opcode(u8) {
        /// Read request.
        Read = 1,
        /// Write request.
        Write = 2,
        /// Data.
        Data = 3,
        /// Acknowledge.
        Ack = 4,
        /// Error.
        Error = 5,
        /// Busy.
        Busy = 6,
    }
}

enum_with_unknown! {
    /// FoE error codes (ETG.1000.6, "FoE error codes").
    pub enum ErrorCode(u32) {
        /// Not defined.
        NotDefined = 0x8000,
        /// File not found.
        NotFound = 0x8001,
        /// Access denied.
        AccessDenied = 0x8002,
        /// Disk full.
        DiskFull = 0x8003,
        /// Illegal.
        Illegal = 0x8004,
        /// Packet number wrong.
        PacketNumberWrong = 0x8005,
        /// Already exists.
        AlreadyExists = 0x8006,
        /// No user.
        NoUser = 0x8007,
        /// Bootstrap only.
        BootstrapOnly = 0x8008,
        /// Not in bootstrap.
        NotBootstrap = 0x8009,
        /// No rights.
        NoRights = 0x800A,
        /// Program error.
        ProgramError = 0x800B,
    }
}

/// One FoE message as values; names, data and texts borrow from the buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Repr<'a> {
    /// Read request.
    Read {
        /// Password.
        password: u32,
        /// File name.
        name: &'a [u8],
    },
    /// Write request.
    Write {
        /// Password.
        password: u32,
        /// File name.
        name: &'a [u8],
    },
    /// A packet of the file.
    Data {
        /// Packet number, from 1.
        packet: u32,
        /// The bytes.
        data: &'a [u8],
    },
    /// Acknowledge of a packet (0: of the write request).
    Ack {
        /// Packet number.
        packet: u32,
    },
    /// Error.
    Error {
        /// Error code.
        code: ErrorCode,
        /// Text.
        text: &'a [u8],
    },
    /// Busy (the receiver needs time).
    Busy {
        /// Done.
        done: u16,
        /// Entire.
        entire: u16,
        /// Text.
        text: &'a [u8],
    },
}

impl<'a> Repr<'a> {
    /// Reads a message from the data of a mailbox message. An unknown opcode is [`Error::Malformed`].
    pub fn parse(bytes: &'a [u8]) -> Result<Repr<'a>, Error> {
        if bytes.len() < HEADER_LEN {
            return Err(Error::Truncated);
        }
        let word = le::u32(bytes, 2);
        let rest = &bytes[HEADER_LEN..];
        Ok(match Opcode::from(bytes[0]) {
            Opcode::Read => Repr::Read { password: word, name: rest },
            Opcode::Write => Repr::Write { password: word, name: rest },
            Opcode::Data => Repr::Data { packet: word, data: rest },
            Opcode::Ack => Repr::Ack { packet: word },
            Opcode::Error => Repr::Error { code: ErrorCode::from(word), text: rest },
            Opcode::Busy => Repr::Busy { done: le::u16(bytes, 2), entire: le::u16(bytes, 4), text: rest },
            Opcode::Unknown(_) => return Err(Error::Malformed),
        })
    }

    /// The opcode.
    pub fn opcode(&self) -> Opcode {
        match self {
            Repr::Read { .. } => Opcode::Read,
            Repr::Write { .. } => Opcode::Write,
            Repr::Data { .. } => Opcode::Data,
            Repr::Ack { .. } => Opcode::Ack,
            Repr::Error { .. } => Opcode::Error,
            Repr::Busy { .. } => Opcode::Busy,
        }
    }

    fn tail(&self) -> &'a [u8] {
        match *self {
            Repr::Read { name, .. } | Repr::Write { name, .. } => name,
            Repr::Data { data, .. } => data,
            Repr::Ack { .. } => &[],
            Repr::Error { text, .. } | Repr::Busy { text, .. } => text,
        }
    }

    /// Bytes the message needs.
    pub fn buffer_len(&self) -> usize {
        HEADER_LEN + self.tail().len()
    }

    /// Writes the message into `buffer`; returns its length.
    ///
    /// # Panics
    ///
    /// If `buffer` is shorter than [`Repr::buffer_len`].
    pub fn emit(&self, buffer: &mut [u8]) -> usize {
        buffer[0] = self.opcode().into();
        buffer[1] = 0;
        match *self {
            Repr::Read { password, .. } | Repr::Write { password, .. } => le::set_u32(buffer, 2, password),
            Repr::Data { packet, .. } | Repr::Ack { packet } => le::set_u32(buffer, 2, packet),
            Repr::Error { code, .. } => le::set_u32(buffer, 2, code.into()),
            Repr::Busy { done, entire, .. } => {
                le::set_u16(buffer, 2, done);
                le::set_u16(buffer, 4, entire);
            }
        }
        let tail = self.tail();
        buffer[HEADER_LEN..HEADER_LEN + tail.len()].copy_from_slice(tail);
        HEADER_LEN + tail.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A write request for "fw.bin" with password 0x12345678, laid out as SOEM's `ecx_FOEwrite` builds it
    /// (the FoE part of the mailbox message).
    static WRITE: [u8; 12] = [0x02, 0x00, 0x78, 0x56, 0x34, 0x12, b'f', b'w', b'.', b'b', b'i', b'n'];

    #[test]
    fn parse_and_emit() {
        let r = Repr::parse(&WRITE).unwrap();
        assert_eq!(r, Repr::Write { password: 0x1234_5678, name: b"fw.bin" });
        let mut out = [0u8; 12];
        assert_eq!(r.emit(&mut out), 12);
        assert_eq!(out, WRITE);
    }

    #[test]
    fn every_opcode_round_trips() {
        let all = [
            Repr::Read { password: 1, name: b"x" },
            Repr::Data { packet: 7, data: &[1, 2, 3] },
            Repr::Ack { packet: 3 },
            Repr::Error { code: ErrorCode::NotFound, text: b"no" },
            Repr::Busy { done: 1, entire: 2, text: b"" },
        ];
        for r in all {
            let mut out = [0u8; 16];
            let n = r.emit(&mut out);
            assert_eq!(n, r.buffer_len());
            assert_eq!(Repr::parse(&out[..n]), Ok(r));
        }
    }

    #[test]
    fn refusals() {
        assert_eq!(Repr::parse(&WRITE[..5]), Err(Error::Truncated));
        assert_eq!(Repr::parse(&[9, 0, 0, 0, 0, 0]), Err(Error::Malformed));
        assert_eq!(u32::from(ErrorCode::Unknown(0x1234)), 0x1234);
    }
}

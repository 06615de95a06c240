//! The 9-byte reply frame (PD28-1021 TMCL manual §3.2 "Reply format", Table 3) and the special replies.
//!
//! | byte | field |
//! |---|---|
//! | 0 | reply address (the host address, global parameter 76) |
//! | 1 | module address |
//! | 2 | status (§3.2.1) |
//! | 3 | command number (echo of the request) |
//! | 4..8 | value, MSB first |
//! | 8 | checksum: 8-bit sum of bytes 0..8 |

use crate::frame::{checksum, WireError, FRAME_LEN};
use crate::status::Status;

/// Byte ranges of the reply frame (§3.2, Table 3).
pub mod field {
    use core::ops::Range;
    /// Reply (host) address.
    pub const HOST: usize = 0;
    /// Module address.
    pub const MODULE: usize = 1;
    /// Status code.
    pub const STATUS: usize = 2;
    /// Command number the reply answers.
    pub const OPCODE: usize = 3;
    /// Value, big-endian.
    pub const VALUE: Range<usize> = 4..8;
    /// Checksum.
    pub const CHECKSUM: usize = 8;
}

/// A read/write view of a reply frame. Accessors panic on buffers shorter than [`FRAME_LEN`];
/// [`ReplyFrame::new_checked`] rules that out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplyFrame<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> ReplyFrame<T> {
    /// Reply (host) address, byte 0.
    #[inline]
    pub fn host(&self) -> u8 {
        self.buffer.as_ref()[field::HOST]
    }

    /// Module address, byte 1.
    #[inline]
    pub fn module(&self) -> u8 {
        self.buffer.as_ref()[field::MODULE]
    }

    /// Status, byte 2.
    #[inline]
    pub fn status(&self) -> Status {
        self.buffer.as_ref()[field::STATUS].into()
    }

    /// Command number, byte 3.
    #[inline]
    pub fn opcode(&self) -> u8 {
        self.buffer.as_ref()[field::OPCODE]
    }

    /// Checksum, byte 8.
    #[inline]
    pub fn checksum(&self) -> u8 {
        self.buffer.as_ref()[field::CHECKSUM]
    }

    /// Whether the checksum is right (always true under `cfg(fuzzing)`).
    #[inline]
    pub fn verify_checksum(&self) -> bool {
        cfg!(fuzzing) || self.checksum() == checksum(&self.buffer.as_ref()[..field::CHECKSUM])
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> ReplyFrame<T> {
    /// Sets byte 0.
    #[inline]
    pub fn set_host(&mut self, value: u8) {
        self.buffer.as_mut()[field::HOST] = value;
    }

    /// Sets byte 1.
    #[inline]
    pub fn set_module(&mut self, value: u8) {
        self.buffer.as_mut()[field::MODULE] = value;
    }

    /// Sets byte 2.
    #[inline]
    pub fn set_status(&mut self, value: Status) {
        self.buffer.as_mut()[field::STATUS] = value.into();
    }

    /// Sets byte 3.
    #[inline]
    pub fn set_opcode(&mut self, value: u8) {
        self.buffer.as_mut()[field::OPCODE] = value;
    }

    /// Sets bytes 4..8.
    #[inline]
    pub fn set_value(&mut self, value: i32) {
        self.buffer.as_mut()[field::VALUE].copy_from_slice(&value.to_be_bytes());
    }

    /// Computes and stores the checksum.
    #[inline]
    pub fn fill_checksum(&mut self) {
        let sum = checksum(&self.buffer.as_ref()[..field::CHECKSUM]);
        self.buffer.as_mut()[field::CHECKSUM] = sum;
    }
}

crate::frame::frame_view!(ReplyFrame);

/// A parsed normal reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reply {
    /// Reply address: the host address (GP 76).
    pub host: u8,
    /// Address of the replying module.
    pub module: u8,
    /// Status code.
    pub status: Status,
    /// Command number being answered.
    pub opcode: u8,
    /// Value.
    pub value: i32,
}

impl Reply {
    /// Parses a reply, verifying the checksum.
    #[inline]
    pub fn parse<T: AsRef<[u8]>>(frame: &ReplyFrame<T>) -> Result<Reply, WireError> {
        frame.check_len()?;
        if !frame.verify_checksum() {
            return Err(WireError::Checksum {
                expected: checksum(&frame.buffer.as_ref()[..field::CHECKSUM]),
                found: frame.checksum(),
            });
        }
        Ok(Reply {
            host: frame.host(),
            module: frame.module(),
            status: frame.status(),
            opcode: frame.opcode(),
            value: frame.value(),
        })
    }

    /// Writes the reply into a frame, checksum included.
    #[inline]
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, frame: &mut ReplyFrame<T>) {
        frame.set_host(self.host);
        frame.set_module(self.module);
        frame.set_status(self.status);
        frame.set_opcode(self.opcode);
        frame.set_value(self.value);
        frame.fill_checksum();
    }

    /// The reply as nine bytes (what [`Reply::emit`] writes, formed as an array: no view, no bounds to
    /// check).
    #[inline(always)]
    pub fn to_bytes(&self) -> [u8; FRAME_LEN] {
        let [v0, v1, v2, v3] = self.value.to_be_bytes();
        let mut bytes = [self.host, self.module, self.status.into(), self.opcode, v0, v1, v2, v3, 0];
        bytes[field::CHECKSUM] = checksum(&bytes[..field::CHECKSUM]);
        bytes
    }
}

/// What a module sends back for one request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Response {
    /// A normal reply (§3.2).
    Normal(Reply),
    /// A special 9-byte reply that is not laid out as Table 3: command 136 type 0 (host address and eight
    /// ASCII characters, no checksum) and command 134 (§3.7.38).
    Raw([u8; FRAME_LEN]),
}

impl Response {
    /// The nine bytes on the wire.
    #[inline]
    pub fn to_bytes(&self) -> [u8; FRAME_LEN] {
        match self {
            Response::Normal(reply) => reply.to_bytes(),
            Response::Raw(bytes) => *bytes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// PD28-1021 manual §3.2 / §3.7.15: reply to `GIO 0, 1` with value 302.
    static GIO_REPLY_302: [u8; 9] = [0x02, 0x01, 0x64, 0x0F, 0x00, 0x00, 0x01, 0x2E, 0xA5];
    /// PD28-1021 manual §3.7.16: reply to `CALC MUL, -5000` (the value is the operand).
    static CALC_REPLY: [u8; 9] = [0x02, 0x01, 0x64, 0x13, 0xFF, 0xFF, 0xEC, 0x78, 0xDC];
    /// §3.7.37, second reply of 138 with mask 1 in the §3.2 byte order (the manual prints module before
    /// host there, contrary to §3.2; we keep Table 3's order). Checksum computed.
    static EVENT_REPLY: [u8; 9] = [0x02, 0x01, 0x80, 0x8A, 0x00, 0x00, 0x00, 0x01, 0x0E];

    #[test]
    fn deconstruct_and_parse() {
        let frame = ReplyFrame::new_checked(&GIO_REPLY_302[..]).unwrap();
        assert_eq!((frame.host(), frame.module(), frame.status(), frame.opcode()), (2, 1, Status::Ok, 15));
        assert_eq!(frame.value(), 302);
        let reply = Reply::parse(&ReplyFrame::new_unchecked(&CALC_REPLY[..])).unwrap();
        assert_eq!(reply.value, -5000);
        assert_eq!(reply.opcode, 0x13);
    }

    #[test]
    fn emit_matches_manual() {
        let reply = Reply { host: 2, module: 1, status: Status::Ok, opcode: 15, value: 302 };
        assert_eq!(reply.to_bytes(), GIO_REPLY_302);
        let event = Reply { host: 2, module: 1, status: Status::TargetReached, opcode: 138, value: 1 };
        assert_eq!(event.to_bytes(), EVENT_REPLY);
        assert_eq!(Response::Normal(event).to_bytes(), EVENT_REPLY);
    }

    proptest::proptest! {
        /// `to_bytes` forms the array that `emit` writes through the view, for every field.
        #[test]
        fn to_bytes_is_emit(host: u8, module: u8, status: u8, opcode: u8, value: i32) {
            let reply = Reply { host, module, status: status.into(), opcode, value };
            let mut emitted = [0u8; FRAME_LEN];
            reply.emit(&mut ReplyFrame::new_unchecked(&mut emitted[..]));
            proptest::prop_assert_eq!(reply.to_bytes(), emitted);
        }
    }

    #[test]
    fn bad_checksum() {
        let mut bytes = GIO_REPLY_302;
        bytes[8] = 0;
        assert!(matches!(Reply::parse(&ReplyFrame::new_unchecked(&bytes[..])), Err(WireError::Checksum { .. })));
    }
}

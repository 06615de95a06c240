//! The 9-byte request frame (PD28-1021 TMCL manual §3.1 "Binary command format", Table 2).
//!
//! | byte | field |
//! |---|---|
//! | 0 | module (target) address |
//! | 1 | command number |
//! | 2 | type number |
//! | 3 | motor or bank number |
//! | 4..8 | value, 32 bit, MSB first |
//! | 8 | checksum: 8-bit sum of bytes 0..8 |
//!
//! The checksum is the sum of the eight preceding bytes modulo 256 (§3.1.1, the C and Delphi routines).

use crate::instruction::Instruction;
use core::fmt;

/// Length of a request or reply frame on RS485, RS232 and USB (§3.1, §3.2).
pub const FRAME_LEN: usize = 9;

/// Byte ranges of the request frame (§3.1, Table 2).
pub mod field {
    use core::ops::Range;
    /// Module (target) address.
    pub const ADDRESS: usize = 0;
    /// Command number.
    pub const OPCODE: usize = 1;
    /// Type number.
    pub const TYPE: usize = 2;
    /// Motor or bank number.
    pub const MOTOR: usize = 3;
    /// Value, big-endian.
    pub const VALUE: Range<usize> = 4..8;
    /// Checksum.
    pub const CHECKSUM: usize = 8;
}

/// The TMCL checksum: the 8-bit sum of `bytes` (§3.1.1). Pass the first eight bytes of a frame.
#[inline]
pub fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |sum, b| sum.wrapping_add(*b))
}

/// What can be wrong with a frame at the wire level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireError {
    /// The buffer is shorter than [`FRAME_LEN`].
    Truncated,
    /// The checksum byte does not match the sum of the other eight (reply status 1, §3.2.1).
    Checksum {
        /// The sum of bytes 0..8.
        expected: u8,
        /// The byte found at index 8.
        found: u8,
    },
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WireError::Truncated => write!(f, "frame shorter than {FRAME_LEN} bytes"),
            WireError::Checksum { expected, found } => {
                write!(f, "wrong checksum: expected {expected:#04x}, found {found:#04x}")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for WireError {}

/// The common part of a 9-byte frame view (request or reply): construction, the length check that makes
/// every accessor panic-free, and the buffer back.
macro_rules! frame_view {
    ($view:ident) => {
        impl<T: AsRef<[u8]>> $view<T> {
            /// Wraps a buffer without checking its length.
            pub const fn new_unchecked(buffer: T) -> $view<T> {
                $view { buffer }
            }

            /// Wraps a buffer after the length check.
            #[inline]
            pub fn new_checked(buffer: T) -> Result<$view<T>, $crate::frame::WireError> {
                let frame = Self::new_unchecked(buffer);
                frame.check_len()?;
                Ok(frame)
            }

            /// Ensures that no accessor will panic.
            #[inline]
            pub fn check_len(&self) -> Result<(), $crate::frame::WireError> {
                if self.buffer.as_ref().len() < $crate::frame::FRAME_LEN {
                    Err($crate::frame::WireError::Truncated)
                } else {
                    Ok(())
                }
            }

            /// Returns the underlying buffer.
            pub fn into_inner(self) -> T {
                self.buffer
            }

            /// Bytes 4..8 (the value), MSB first, as a signed 32-bit number.
            #[inline]
            pub fn value(&self) -> i32 {
                let b = &self.buffer.as_ref()[4..8];
                i32::from_be_bytes([b[0], b[1], b[2], b[3]])
            }
        }
    };
}
pub(crate) use frame_view;

frame_view!(Frame);

/// A read/write view of a request frame over any byte buffer.
///
/// Accessors panic if the buffer is shorter than [`FRAME_LEN`]; [`Frame::new_checked`] rules that out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Frame<T> {
    /// Module (target) address, byte 0.
    #[inline]
    pub fn address(&self) -> u8 {
        self.buffer.as_ref()[field::ADDRESS]
    }

    /// Command number, byte 1.
    #[inline]
    pub fn opcode(&self) -> u8 {
        self.buffer.as_ref()[field::OPCODE]
    }

    /// Type number, byte 2.
    #[inline]
    pub fn kind(&self) -> u8 {
        self.buffer.as_ref()[field::TYPE]
    }

    /// Motor or bank number, byte 3.
    #[inline]
    pub fn motor(&self) -> u8 {
        self.buffer.as_ref()[field::MOTOR]
    }

    /// The checksum byte, byte 8.
    #[inline]
    pub fn checksum(&self) -> u8 {
        self.buffer.as_ref()[field::CHECKSUM]
    }

    /// The checksum the frame should carry: the sum of bytes 0..8.
    #[inline]
    pub fn expected_checksum(&self) -> u8 {
        checksum(&self.buffer.as_ref()[..field::CHECKSUM])
    }

    /// Whether the checksum is right. Always true under `cfg(fuzzing)`, so that fuzzers reach the decoder.
    #[inline]
    pub fn verify_checksum(&self) -> bool {
        if cfg!(fuzzing) {
            return true;
        }
        self.checksum() == self.expected_checksum()
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Frame<T> {
    /// Sets byte 0.
    #[inline]
    pub fn set_address(&mut self, value: u8) {
        self.buffer.as_mut()[field::ADDRESS] = value;
    }

    /// Sets byte 1.
    #[inline]
    pub fn set_opcode(&mut self, value: u8) {
        self.buffer.as_mut()[field::OPCODE] = value;
    }

    /// Sets byte 2.
    #[inline]
    pub fn set_kind(&mut self, value: u8) {
        self.buffer.as_mut()[field::TYPE] = value;
    }

    /// Sets byte 3.
    #[inline]
    pub fn set_motor(&mut self, value: u8) {
        self.buffer.as_mut()[field::MOTOR] = value;
    }

    /// Sets bytes 4..8, MSB first.
    #[inline]
    pub fn set_value(&mut self, value: i32) {
        self.buffer.as_mut()[field::VALUE].copy_from_slice(&value.to_be_bytes());
    }

    /// Computes the checksum and stores it in byte 8.
    #[inline]
    pub fn fill_checksum(&mut self) {
        let sum = self.expected_checksum();
        self.buffer.as_mut()[field::CHECKSUM] = sum;
    }
}

/// A parsed request: the target address and the instruction it carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Request {
    /// Module (target) address, byte 0.
    pub address: u8,
    /// Opcode, type, motor/bank and value.
    pub instruction: Instruction,
}

impl Request {
    /// Parses a frame whose length has been checked, verifying the checksum.
    #[inline(always)]
    pub fn parse<T: AsRef<[u8]>>(frame: &Frame<T>) -> Result<Request, WireError> {
        frame.check_len()?;
        if !frame.verify_checksum() {
            return Err(WireError::Checksum { expected: frame.expected_checksum(), found: frame.checksum() });
        }
        Ok(Request {
            address: frame.address(),
            instruction: Instruction::new(frame.opcode().into(), frame.kind(), frame.motor(), frame.value()),
        })
    }

    /// Writes the request into a frame, checksum included.
    #[inline]
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, frame: &mut Frame<T>) {
        frame.set_address(self.address);
        frame.set_opcode(self.instruction.opcode.into());
        frame.set_kind(self.instruction.kind);
        frame.set_motor(self.instruction.motor);
        frame.set_value(self.instruction.value);
        frame.fill_checksum();
    }

    /// The request as the nine bytes a host sends.
    #[inline]
    pub fn to_bytes(&self) -> [u8; FRAME_LEN] {
        let mut bytes = [0u8; FRAME_LEN];
        self.emit(&mut Frame::new_unchecked(&mut bytes[..]));
        bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::opcode::Opcode;

    /// PD28-1021 manual §3.7.1 (ROR example, "ROR 0, 51200").
    static ROR_0_51200: [u8; 9] = [0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0xC8, 0x00, 0xCA];
    /// PD28-1021 manual §3.7.4 (MVP REL example, "MVP REL, 0, -10000"): a negative value.
    static MVP_REL_MINUS_10000: [u8; 9] = [0x01, 0x04, 0x01, 0x00, 0xFF, 0xFF, 0xD8, 0xF0, 0xCC];
    /// ROR 0, 500 (value 0x1F4), checksum computed: `01 01 00 00 00 00 01 F4 F7`.
    static ROR_0_500: [u8; 9] = [0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0xF4, 0xF7];

    #[test]
    fn deconstruct() {
        let frame = Frame::new_checked(&ROR_0_51200[..]).unwrap();
        assert_eq!(frame.address(), 1);
        assert_eq!(frame.opcode(), 1);
        assert_eq!(frame.kind(), 0);
        assert_eq!(frame.motor(), 0);
        assert_eq!(frame.value(), 51200);
        assert_eq!(frame.checksum(), 0xCA);
        assert!(frame.verify_checksum());
        let frame = Frame::new_checked(&MVP_REL_MINUS_10000[..]).unwrap();
        assert_eq!(frame.value(), -10000);
        assert!(frame.verify_checksum());
    }

    #[test]
    fn construct() {
        let mut bytes = [0xA5u8; 9];
        let mut frame = Frame::new_unchecked(&mut bytes[..]);
        frame.set_address(1);
        frame.set_opcode(1);
        frame.set_kind(0);
        frame.set_motor(0);
        frame.set_value(500);
        frame.fill_checksum();
        assert_eq!(bytes, ROR_0_500);
    }

    #[test]
    fn parse_emit_roundtrip() {
        let request = Request::parse(&Frame::new_unchecked(&MVP_REL_MINUS_10000[..])).unwrap();
        assert_eq!(request.address, 1);
        assert_eq!(request.instruction, Instruction::new(Opcode::Mvp, 1, 0, -10000));
        assert_eq!(request.to_bytes(), MVP_REL_MINUS_10000);
    }

    #[test]
    fn wrong_checksum() {
        let mut bytes = ROR_0_51200;
        bytes[8] ^= 1;
        assert_eq!(
            Request::parse(&Frame::new_unchecked(&bytes[..])),
            Err(WireError::Checksum { expected: 0xCA, found: 0xCB })
        );
    }

    #[test]
    fn truncated() {
        assert_eq!(Frame::new_checked(&ROR_0_51200[..8]), Err(WireError::Truncated));
        assert_eq!(Request::parse(&Frame::new_unchecked(&[][..])), Err(WireError::Truncated));
    }

    #[test]
    fn checksum_routine() {
        // §3.1.1: the checksum is the sum of bytes 0..7 modulo 256.
        assert_eq!(checksum(&[0xFF, 0x01]), 0x00);
        assert_eq!(checksum(&[]), 0);
    }
}

/// Bytes as the manual prints frames: hex pairs separated by spaces (`01 05 04 00 00 00 C3 50 1D`).
///
/// ```
/// use tmcl_wire::frame::Hex;
/// assert_eq!(format!("{}", Hex(&[0x01, 0x05, 0xC3])), "01 05 C3");
/// assert_eq!(format!("{}", Hex(&[])), "");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hex<'a>(pub &'a [u8]);

impl core::fmt::Display for Hex<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        for (i, b) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(" ")?;
            }
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

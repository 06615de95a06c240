//! The `.bin` program image: 8 bytes per instruction, as TMCL-IDE exports it and pytrinamic's tools read
//! it: opcode, type, motor/bank, value (4 bytes, MSB first) and a checksum, the 8-bit sum of those seven
//! bytes (the request frame of PD28-1021 TMCL manual §3.1 without its address byte).

use std::fmt;
use tmcl_wire::Instruction;

/// Bytes per instruction in the image.
pub const RECORD_LEN: usize = 8;

/// Why an image could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinError {
    /// The length is not a multiple of 8.
    Length {
        /// The image length in bytes.
        len: usize,
    },
    /// A record's checksum does not match its bytes.
    Checksum {
        /// The record's program address (its index).
        address: usize,
        /// The sum of its first seven bytes.
        expected: u8,
        /// The eighth byte.
        found: u8,
    },
}

impl fmt::Display for BinError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            BinError::Length { len } => {
                write!(f, "the image is {len} bytes long, which is not a multiple of {RECORD_LEN}")
            }
            BinError::Checksum { address, expected, found } => {
                write!(f, "the checksum of address {address} is 0x{found:02X}, but its bytes sum to 0x{expected:02X}")
            }
        }
    }
}

impl std::error::Error for BinError {}

/// The image of `instructions`.
pub fn to_bin(instructions: &[Instruction]) -> Vec<u8> {
    let mut out = Vec::with_capacity(instructions.len() * RECORD_LEN);
    for i in instructions {
        let bytes = i.to_bytes();
        out.extend_from_slice(&bytes);
        out.push(tmcl_wire::checksum(&bytes));
    }
    out
}

/// Reads an image, checking every checksum.
pub fn from_bin(bytes: &[u8]) -> Result<Vec<Instruction>, BinError> {
    if !bytes.len().is_multiple_of(RECORD_LEN) {
        return Err(BinError::Length { len: bytes.len() });
    }
    bytes
        .chunks_exact(RECORD_LEN)
        .enumerate()
        .map(|(address, record)| {
            let mut seven = [0u8; 7];
            seven.copy_from_slice(&record[..7]);
            let expected = tmcl_wire::checksum(&seven);
            match record[7] {
                found if found == expected => Ok(Instruction::from_bytes(seven)),
                found => Err(BinError::Checksum { address, expected, found }),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_wire::Opcode;

    #[test]
    fn records() {
        // MVP REL, 0, -10000: the request frame of the PD28-1021 manual's §3.7.4 example without its address
        // byte (01), so the checksum is 0xCC - 1.
        let image = to_bin(&[Instruction::new(Opcode::Mvp, 1, 0, -10000)]);
        assert_eq!(image, [0x04, 0x01, 0x00, 0xFF, 0xFF, 0xD8, 0xF0, 0xCB]);
        assert_eq!(from_bin(&image), Ok(vec![Instruction::new(Opcode::Mvp, 1, 0, -10000)]));
        assert_eq!(from_bin(&image[..7]), Err(BinError::Length { len: 7 }));
        let mut bad = image.clone();
        bad[7] = 0;
        assert_eq!(from_bin(&bad), Err(BinError::Checksum { address: 0, expected: 0xCB, found: 0 }));
        assert_eq!(from_bin(&[]), Ok(vec![]));
    }
}

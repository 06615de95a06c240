//! One raw TMCL command: what a frame carries between address and checksum, and what one program-memory
//! cell holds (PD28-1021 TMCL manual §3.1: "command number, type number, motor/bank number, value").

use crate::opcode::Opcode;
use core::fmt;

/// Opcode, type, motor/bank and value, unvalidated. Unknown opcodes and types are kept as they came.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Instruction {
    /// Command number (byte 1 of a request).
    pub opcode: Opcode,
    /// Type number (byte 2).
    pub kind: u8,
    /// Motor or bank number (byte 3).
    pub motor: u8,
    /// The 32-bit value (bytes 4..8, MSB first).
    pub value: i32,
}

impl Instruction {
    /// Builds an instruction.
    pub const fn new(opcode: Opcode, kind: u8, motor: u8, value: i32) -> Instruction {
        Instruction { opcode, kind, motor, value }
    }

    /// The seven bytes opcode, type, motor, value (MSB first).
    #[inline]
    pub fn to_bytes(&self) -> [u8; 7] {
        let v = self.value.to_be_bytes();
        [self.opcode.into(), self.kind, self.motor, v[0], v[1], v[2], v[3]]
    }

    /// The inverse of [`Instruction::to_bytes`].
    #[inline]
    pub fn from_bytes(bytes: [u8; 7]) -> Instruction {
        Instruction::new(
            bytes[0].into(),
            bytes[1],
            bytes[2],
            i32::from_be_bytes([bytes[3], bytes[4], bytes[5], bytes[6]]),
        )
    }
}

impl fmt::Display for Instruction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}, {}, {}", self.opcode, self.kind, self.motor, self.value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_roundtrip() {
        let i = Instruction::new(Opcode::Mvp, 1, 0, -10000);
        assert_eq!(i.to_bytes(), [4, 1, 0, 0xFF, 0xFF, 0xD8, 0xF0]);
        assert_eq!(Instruction::from_bytes(i.to_bytes()), i);
    }
}

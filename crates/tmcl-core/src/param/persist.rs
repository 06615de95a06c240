//! The EEPROM image: layout, version, and the typed reads and writes the firmware does on it.
//!
//! The manual does not give the real module's EEPROM layout (inventory AMB-6); this is ours, versioned so
//! that a later layout can migrate or refuse an old image. All numbers are big-endian.
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0x0000 | 16 | header: magic `OTMC`, layout version (u16), model tag (u16, the module number, 1021), 8 reserved |
//! | 0x0010 | 32 × 4 | axis parameter slots: the E parameters of motor 0, in table order |
//! | 0x0090 | 32 × 4 | bank 0 slots: the A parameters, in table order |
//! | 0x0110 | 64 × 4 | bank 2: user variables 0.. (the first `stored_user_variables`) |
//! | 0x0210 | 32 × 4 | coordinates 1..=20 of motor 0 (coordinate 0 is RAM only, §3.7.24) |
//! | 0x0290 | – | reserved up to 0x0400 |
//! | 0x0400 | n × 8 | TMCL program memory: per command opcode, type, motor, value (4, MSB first), checksum |
//!
//! The header is written last when the image is formatted and invalidated first, so an interrupted
//! formatting is redone at the next start. Every other value is one slot, written by one [`Nvm::write`]
//! call, which the [`Nvm`] contract makes atomic.

use crate::hal::Nvm;
use crate::model::ModelSpec;
use crate::param::{slot, ParamError};
use tmcl_wire::{checksum, Instruction};

/// The layout version this firmware writes and reads.
pub const LAYOUT_VERSION: u16 = 1;
/// The header magic.
pub const MAGIC: [u8; 4] = *b"OTMC";
/// Header offset.
pub const HEADER: usize = 0x0000;
/// Axis parameter slots.
pub const AXIS: usize = 0x0010;
/// Bank 0 slots.
pub const GLOBAL: usize = 0x0090;
/// User variable slots.
pub const USER: usize = 0x0110;
/// Coordinate slots (coordinate n at `COORDS + 4·(n−1)`).
pub const COORDS: usize = 0x0210;
/// Program memory.
pub const PROGRAM: usize = 0x0400;
/// Bytes per program-memory cell.
pub const PROGRAM_CELL: usize = 8;
/// Slots per region.
pub const SLOTS: usize = 32;

/// Where a region ends, for layout checks.
const USER_SLOTS: usize = 64;

/// The EEPROM size a model needs.
pub const fn capacity(spec: &ModelSpec) -> usize {
    PROGRAM + spec.program_memory as usize * PROGRAM_CELL
}

fn tag(spec: &ModelSpec) -> u16 {
    let b = spec.version_binary.to_be_bytes();
    u16::from(b[0]) * 100 + u16::from(b[1])
}

fn header(spec: &ModelSpec) -> [u8; 16] {
    let mut h = [0u8; 16];
    h[..4].copy_from_slice(&MAGIC);
    h[4..6].copy_from_slice(&LAYOUT_VERSION.to_be_bytes());
    h[6..8].copy_from_slice(&tag(spec).to_be_bytes());
    h
}

fn read_i32<N: Nvm>(nvm: &mut N, offset: usize) -> Result<i32, ParamError> {
    let mut b = [0u8; 4];
    nvm.read(offset, &mut b).map_err(|_| ParamError::Storage)?;
    Ok(i32::from_be_bytes(b))
}

fn write_i32<N: Nvm>(nvm: &mut N, offset: usize, value: i32) -> Result<(), ParamError> {
    nvm.write(offset, &value.to_be_bytes()).map_err(|_| ParamError::Storage)
}

/// Whether the image carries our header for this model and layout.
pub fn is_formatted<N: Nvm>(nvm: &mut N, spec: &ModelSpec) -> bool {
    let mut h = [0u8; 16];
    nvm.capacity() >= capacity(spec) && nvm.read(HEADER, &mut h).is_ok() && h == header(spec)
}

/// Writes the factory image: every persistent parameter at its default, user variables and coordinates
/// 0, and, if `erase_program`, an empty program (all cells zero: opcode 0 marks the end, as host tools
/// expect). The header goes last.
pub fn format<N: Nvm>(nvm: &mut N, spec: &ModelSpec, erase_program: bool) -> Result<(), ParamError> {
    if nvm.capacity() < capacity(spec) {
        return Err(ParamError::Storage);
    }
    nvm.write(HEADER, &[0u8; 16]).map_err(|_| ParamError::Storage)?;
    let mut region = [0u8; SLOTS * 4];
    for (base, table) in [(AXIS, spec.axis.params), (GLOBAL, spec.global.params)] {
        region.fill(0);
        for (i, d) in table.iter().enumerate() {
            if let Some(s) = slot(table, i) {
                region[s * 4..s * 4 + 4].copy_from_slice(&d.default.to_be_bytes());
            }
        }
        nvm.write(base, &region).map_err(|_| ParamError::Storage)?;
    }
    let zeros = [0u8; 256];
    nvm.write(USER, &zeros).map_err(|_| ParamError::Storage)?;
    nvm.write(COORDS, &zeros[..SLOTS * 4]).map_err(|_| ParamError::Storage)?;
    if erase_program {
        self::erase_program(nvm, spec)?;
    }
    nvm.write(HEADER, &header(spec)).map_err(|_| ParamError::Storage)
}

/// Reads the stored value of axis parameter table entry `index` (an E parameter).
pub fn load_axis<N: Nvm>(nvm: &mut N, spec: &ModelSpec, index: usize) -> Result<i32, ParamError> {
    let s = slot(spec.axis.params, index).ok_or(ParamError::NotPermitted)?;
    read_i32(nvm, AXIS + 4 * s)
}

/// Stores axis parameter table entry `index`.
pub fn store_axis<N: Nvm>(nvm: &mut N, spec: &ModelSpec, index: usize, value: i32) -> Result<(), ParamError> {
    let s = slot(spec.axis.params, index).ok_or(ParamError::NotPermitted)?;
    write_i32(nvm, AXIS + 4 * s, value)
}

/// Reads the stored value of bank 0 table entry `index` (an A parameter).
pub fn load_global<N: Nvm>(nvm: &mut N, spec: &ModelSpec, index: usize) -> Result<i32, ParamError> {
    let s = slot(spec.global.params, index).ok_or(ParamError::NotPermitted)?;
    read_i32(nvm, GLOBAL + 4 * s)
}

/// Stores bank 0 table entry `index`.
pub fn store_global<N: Nvm>(nvm: &mut N, spec: &ModelSpec, index: usize, value: i32) -> Result<(), ParamError> {
    let s = slot(spec.global.params, index).ok_or(ParamError::NotPermitted)?;
    write_i32(nvm, GLOBAL + 4 * s, value)
}

fn user_offset(spec: &ModelSpec, n: u8) -> Result<usize, ParamError> {
    if u16::from(n) < spec.stored_user_variables {
        Ok(USER + 4 * usize::from(n))
    } else {
        Err(ParamError::NotPermitted)
    }
}

/// Reads stored user variable `n`.
pub fn load_user<N: Nvm>(nvm: &mut N, spec: &ModelSpec, n: u8) -> Result<i32, ParamError> {
    read_i32(nvm, user_offset(spec, n)?)
}

/// Stores user variable `n`.
pub fn store_user<N: Nvm>(nvm: &mut N, spec: &ModelSpec, n: u8, value: i32) -> Result<(), ParamError> {
    write_i32(nvm, user_offset(spec, n)?, value)
}

fn coord_offset(spec: &ModelSpec, n: u8) -> Result<usize, ParamError> {
    if (1..=spec.coordinates).contains(&n) {
        Ok(COORDS + 4 * (usize::from(n) - 1))
    } else {
        Err(ParamError::OutOfRange)
    }
}

/// Reads stored coordinate `n` (1..=20).
pub fn load_coordinate<N: Nvm>(nvm: &mut N, spec: &ModelSpec, n: u8) -> Result<i32, ParamError> {
    read_i32(nvm, coord_offset(spec, n)?)
}

/// Stores coordinate `n` (1..=20).
pub fn store_coordinate<N: Nvm>(nvm: &mut N, spec: &ModelSpec, n: u8, value: i32) -> Result<(), ParamError> {
    write_i32(nvm, coord_offset(spec, n)?, value)
}

/// Reads program-memory cell `address`: `None` if it is outside the model's memory; an empty cell (opcode 0)
/// if its checksum is wrong (an interrupted or foreign write).
pub fn load_program_cell<N: Nvm>(nvm: &mut N, spec: &ModelSpec, address: usize) -> Option<Instruction> {
    if address >= usize::from(spec.program_memory) {
        return None;
    }
    let mut b = [0u8; PROGRAM_CELL];
    nvm.read(PROGRAM + address * PROGRAM_CELL, &mut b).ok()?;
    let mut seven = [0u8; 7];
    seven.copy_from_slice(&b[..7]);
    if checksum(&seven) != b[7] {
        return Some(Instruction::new(0.into(), 0, 0, 0));
    }
    Some(Instruction::from_bytes(seven))
}

/// Writes program-memory cell `address` (one atomic write of the 8-byte cell).
pub fn store_program_cell<N: Nvm>(
    nvm: &mut N,
    spec: &ModelSpec,
    address: usize,
    instruction: &Instruction,
) -> Result<(), ParamError> {
    if address >= usize::from(spec.program_memory) {
        return Err(ParamError::OutOfRange);
    }
    let mut b = [0u8; PROGRAM_CELL];
    b[..7].copy_from_slice(&instruction.to_bytes());
    b[7] = checksum(&b[..7]);
    nvm.write(PROGRAM + address * PROGRAM_CELL, &b).map_err(|_| ParamError::Storage)
}

/// Erases the program memory (GP 81: leaving protection against disassembly erases the program).
pub fn erase_program<N: Nvm>(nvm: &mut N, spec: &ModelSpec) -> Result<(), ParamError> {
    let zeros = [0u8; 256];
    let end = capacity(spec);
    let mut at = PROGRAM;
    while at < end {
        let n = zeros.len().min(end - at);
        nvm.write(at, &zeros[..n]).map_err(|_| ParamError::Storage)?;
        at += n;
    }
    Ok(())
}

const _: () = assert!(AXIS + SLOTS * 4 <= GLOBAL);
const _: () = assert!(GLOBAL + SLOTS * 4 <= USER);
const _: () = assert!(USER + USER_SLOTS * 4 <= COORDS);
const _: () = assert!(COORDS + SLOTS * 4 <= PROGRAM);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::pd28_1021::SPEC;
    use crate::param::find;
    use std::vec::Vec;

    /// A plain RAM EEPROM for tests, erased to 0xFF.
    pub struct RamNvm(pub Vec<u8>);

    impl Nvm for RamNvm {
        type Error = ();
        fn capacity(&self) -> usize {
            self.0.len()
        }
        fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), ()> {
            let src = self.0.get(offset..offset + buf.len()).ok_or(())?;
            buf.copy_from_slice(src);
            Ok(())
        }
        fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), ()> {
            self.0.get_mut(offset..offset + data.len()).ok_or(())?.copy_from_slice(data);
            Ok(())
        }
    }

    #[test]
    fn layout_fits_the_model() {
        assert_eq!(capacity(&SPEC), 0x0400 + 2048 * 8);
        assert!(SPEC.axis.params.iter().filter(|d| d.access.persistent()).count() <= SLOTS);
        assert!(SPEC.global.params.iter().filter(|d| d.access.persistent()).count() <= SLOTS);
        assert!(usize::from(SPEC.stored_user_variables) <= USER_SLOTS);
        assert!(usize::from(SPEC.coordinates) <= SLOTS);
    }

    #[test]
    fn format_then_load_defaults() {
        let mut nvm = RamNvm(std::vec![0xFF; capacity(&SPEC)]);
        assert!(!is_formatted(&mut nvm, &SPEC));
        format(&mut nvm, &SPEC, true).unwrap();
        assert!(is_formatted(&mut nvm, &SPEC));
        let (i, _) = find(SPEC.axis.params, 214).unwrap();
        assert_eq!(load_axis(&mut nvm, &SPEC, i), Ok(200));
        let (i, _) = find(SPEC.global.params, 66).unwrap();
        assert_eq!(load_global(&mut nvm, &SPEC, i), Ok(1));
        assert_eq!(&nvm.0[..4], b"OTMC");
        assert!(nvm.0[PROGRAM..].iter().all(|b| *b == 0));
    }

    #[test]
    fn slots_and_refusals() {
        let mut nvm = RamNvm(std::vec![0xFF; capacity(&SPEC)]);
        format(&mut nvm, &SPEC, false).unwrap();
        let (i, _) = find(SPEC.axis.params, 4).unwrap();
        store_axis(&mut nvm, &SPEC, i, 1234).unwrap();
        assert_eq!(load_axis(&mut nvm, &SPEC, i), Ok(1234));
        let (i, _) = find(SPEC.axis.params, 0).unwrap();
        assert_eq!(store_axis(&mut nvm, &SPEC, i, 1), Err(ParamError::NotPermitted));
        store_user(&mut nvm, &SPEC, 55, -7).unwrap();
        assert_eq!(load_user(&mut nvm, &SPEC, 55), Ok(-7));
        assert_eq!(store_user(&mut nvm, &SPEC, 56, 1), Err(ParamError::NotPermitted));
        store_coordinate(&mut nvm, &SPEC, 20, 99).unwrap();
        assert_eq!(load_coordinate(&mut nvm, &SPEC, 20), Ok(99));
        assert_eq!(store_coordinate(&mut nvm, &SPEC, 0, 1), Err(ParamError::OutOfRange));
        let mut small = RamNvm(std::vec![0; 16]);
        assert_eq!(format(&mut small, &SPEC, true), Err(ParamError::Storage));
    }
}

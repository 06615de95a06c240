//! The EEPROM image: header, version, and the typed reads and writes the firmware does on it.
//!
//! The layout is computed from the model at compile time ([`tmcl_model::layout`] describes it; the real
//! modules' layouts are not published, so it is ours), versioned so that a later layout can migrate or
//! refuse an old image. All numbers are big-endian. The header is written last when the image is
//! formatted and invalidated first, so an interrupted formatting is redone at the next start. Every other
//! value is one slot, written by one [`Nvm::write`] call, which the [`Nvm`] contract makes atomic.

use crate::hal::Nvm;
use crate::model::ModelSpec;
use crate::param::{slot, ParamError};
use tmcl_model::layout::{HEADER_LEN, SLOT};
use tmcl_wire::{checksum, Instruction};

pub use tmcl_model::layout::PROGRAM_CELL;

/// The layout version this firmware writes and reads.
pub const LAYOUT_VERSION: u16 = 1;
/// The header magic.
pub const MAGIC: [u8; 4] = *b"OTMC";
/// Header offset.
pub const HEADER: usize = 0x0000;

/// The EEPROM size a model needs.
pub const fn capacity(spec: &ModelSpec) -> usize {
    spec.layout().end
}

/// The EEPROM size the largest of `models` needs: what a firmware image that holds them all must set
/// aside (at compile time, `firmware/`), so that no model's image is cut short.
pub const fn max_capacity(models: &[&ModelSpec]) -> usize {
    let mut max = 0;
    let mut i = 0;
    while i < models.len() {
        let c = capacity(models[i]);
        if c > max {
            max = c;
        }
        i += 1;
    }
    max
}

fn header(spec: &ModelSpec) -> [u8; HEADER_LEN] {
    let mut h = [0u8; HEADER_LEN];
    h[..4].copy_from_slice(&MAGIC);
    h[4..6].copy_from_slice(&LAYOUT_VERSION.to_be_bytes());
    h[6..8].copy_from_slice(&spec.eeprom_tag.to_be_bytes());
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
    let mut h = [0u8; HEADER_LEN];
    nvm.capacity() >= capacity(spec) && nvm.read(HEADER, &mut h).is_ok() && h == header(spec)
}

/// Writes `len` zero bytes from `at`, in writes of at most 256 bytes.
fn zero<N: Nvm>(nvm: &mut N, mut at: usize, len: usize) -> Result<(), ParamError> {
    let zeros = [0u8; 256];
    let end = at + len;
    while at < end {
        let n = zeros.len().min(end - at);
        nvm.write(at, &zeros[..n]).map_err(|_| ParamError::Storage)?;
        at += n;
    }
    Ok(())
}

/// Writes the factory image: every persistent parameter at its default, user variables and coordinates
/// 0, and, if `erase_program`, an empty program (all cells zero: opcode 0 marks the end, as host tools
/// expect). The header goes last.
pub fn format<N: Nvm>(nvm: &mut N, spec: &ModelSpec, erase_program: bool) -> Result<(), ParamError> {
    if nvm.capacity() < capacity(spec) {
        return Err(ParamError::Storage);
    }
    let layout = spec.layout();
    nvm.write(HEADER, &[0u8; HEADER_LEN]).map_err(|_| ParamError::Storage)?;
    // One write per parameter region (at most 64 slots, the core's largest table).
    let mut region = [0u8; tmcl_model::capacity::MAX_AXIS_PARAMS * SLOT];
    // Each motor's E parameters follow the previous motor's (motor m at `axis + m · E parameters · 4`).
    let axis_stride = spec.axis.persistent() * SLOT;
    let axes = (0..usize::from(spec.motors)).map(|m| (layout.axis + m * axis_stride, spec.axis.params));
    for (base, table) in axes.chain([(layout.global, spec.global.params)]) {
        let mut len = 0;
        for (i, d) in table.iter().enumerate() {
            if let Some(s) = slot(table, i) {
                region[s * SLOT..s * SLOT + SLOT].copy_from_slice(&d.default.to_be_bytes());
                len = s * SLOT + SLOT;
            }
        }
        nvm.write(base, &region[..len]).map_err(|_| ParamError::Storage)?;
    }
    zero(nvm, layout.user, usize::from(spec.stored_user_variables) * SLOT)?;
    zero(nvm, layout.coords, usize::from(spec.coordinates) * usize::from(spec.motors) * SLOT)?;
    if erase_program {
        self::erase_program(nvm, spec)?;
    }
    nvm.write(HEADER, &header(spec)).map_err(|_| ParamError::Storage)
}

/// Where motor `motor`'s slot of axis parameter table entry `index` (an E parameter) lies: the motors'
/// E parameters one after the other, motor 0 first.
fn axis_offset(spec: &ModelSpec, motor: usize, index: usize) -> Result<usize, ParamError> {
    let s = slot(spec.axis.params, index).ok_or(ParamError::NotPermitted)?;
    if motor >= usize::from(spec.motors) {
        return Err(ParamError::NoSuchMotor);
    }
    Ok(spec.layout().axis + SLOT * (motor * spec.axis.persistent() + s))
}

/// Reads motor `motor`'s stored value of axis parameter table entry `index` (an E parameter).
pub fn load_axis<N: Nvm>(nvm: &mut N, spec: &ModelSpec, motor: usize, index: usize) -> Result<i32, ParamError> {
    read_i32(nvm, axis_offset(spec, motor, index)?)
}

/// Stores motor `motor`'s axis parameter table entry `index`.
pub fn store_axis<N: Nvm>(
    nvm: &mut N,
    spec: &ModelSpec,
    motor: usize,
    index: usize,
    value: i32,
) -> Result<(), ParamError> {
    write_i32(nvm, axis_offset(spec, motor, index)?, value)
}

/// Reads the stored value of bank 0 table entry `index` (an A parameter).
pub fn load_global<N: Nvm>(nvm: &mut N, spec: &ModelSpec, index: usize) -> Result<i32, ParamError> {
    let s = slot(spec.global.params, index).ok_or(ParamError::NotPermitted)?;
    read_i32(nvm, spec.layout().global + SLOT * s)
}

/// Stores bank 0 table entry `index`.
pub fn store_global<N: Nvm>(nvm: &mut N, spec: &ModelSpec, index: usize, value: i32) -> Result<(), ParamError> {
    let s = slot(spec.global.params, index).ok_or(ParamError::NotPermitted)?;
    write_i32(nvm, spec.layout().global + SLOT * s, value)
}

fn user_offset(spec: &ModelSpec, n: u8) -> Result<usize, ParamError> {
    if u16::from(n) < spec.stored_user_variables {
        Ok(spec.layout().user + SLOT * usize::from(n))
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

fn coord_offset(spec: &ModelSpec, motor: usize, n: u8) -> Result<usize, ParamError> {
    if motor >= usize::from(spec.motors) {
        return Err(ParamError::NoSuchMotor);
    }
    if (1..=spec.coordinates).contains(&n) {
        Ok(spec.layout().coords + SLOT * (motor * usize::from(spec.coordinates) + usize::from(n) - 1))
    } else {
        Err(ParamError::OutOfRange)
    }
}

/// Reads motor `motor`'s stored coordinate `n` (1..=20).
pub fn load_coordinate<N: Nvm>(nvm: &mut N, spec: &ModelSpec, motor: usize, n: u8) -> Result<i32, ParamError> {
    read_i32(nvm, coord_offset(spec, motor, n)?)
}

/// Stores motor `motor`'s coordinate `n` (1..=20).
pub fn store_coordinate<N: Nvm>(
    nvm: &mut N,
    spec: &ModelSpec,
    motor: usize,
    n: u8,
    value: i32,
) -> Result<(), ParamError> {
    write_i32(nvm, coord_offset(spec, motor, n)?, value)
}

/// Reads program-memory cell `address`: `None` if it is outside the model's memory; an empty cell (opcode 0)
/// if its checksum is wrong (an interrupted or foreign write).
pub fn load_program_cell<N: Nvm>(nvm: &mut N, spec: &ModelSpec, address: usize) -> Option<Instruction> {
    if address >= usize::from(spec.program_memory) {
        return None;
    }
    let mut b = [0u8; PROGRAM_CELL];
    nvm.read(spec.layout().program + address * PROGRAM_CELL, &mut b).ok()?;
    Some(cell(&b))
}

/// A program cell's instruction; an empty one (opcode 0) if its checksum is wrong.
fn cell(b: &[u8; PROGRAM_CELL]) -> Instruction {
    let mut seven = [0u8; 7];
    seven.copy_from_slice(&b[..7]);
    if checksum(&seven) != b[7] {
        return crate::vm::EMPTY;
    }
    Instruction::from_bytes(seven)
}

/// Reads the whole program memory, 32 cells per read (start-up), passing each cell's address and
/// instruction to `f`, as [`load_program_cell`] reads them one by one. A chunk that cannot be read
/// gives empty cells. Empty chunks (all zero) from cell `skip_empty_from` on are not passed at all: the
/// caller knows those cells are empty already.
pub fn load_program<N: Nvm>(
    nvm: &mut N,
    spec: &ModelSpec,
    skip_empty_from: usize,
    mut f: impl FnMut(usize, Instruction),
) {
    const CHUNK: usize = 32;
    let cells = usize::from(spec.program_memory);
    let mut buf = [0u8; CHUNK * PROGRAM_CELL];
    let mut first = 0;
    while first < cells {
        let n = CHUNK.min(cells - first);
        let bytes = &mut buf[..n * PROGRAM_CELL];
        if nvm.read(spec.layout().program + first * PROGRAM_CELL, bytes).is_err() {
            bytes.fill(0);
        }
        if first >= skip_empty_from && bytes.iter().fold(0, |any, b| any | b) == 0 {
            first += n;
            continue;
        }
        for (k, c) in bytes.chunks_exact(PROGRAM_CELL).enumerate() {
            let mut b = [0u8; PROGRAM_CELL];
            b.copy_from_slice(c);
            // Most cells are empty (all zero, which is also a valid cell): no checksum to compute.
            let i = if u64::from_ne_bytes(b) == 0 { crate::vm::EMPTY } else { cell(&b) };
            f(first + k, i);
        }
        first += n;
    }
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
    nvm.write(spec.layout().program + address * PROGRAM_CELL, &b).map_err(|_| ParamError::Storage)
}

/// Erases the program memory (GP 81: leaving protection against disassembly erases the program).
pub fn erase_program<N: Nvm>(nvm: &mut N, spec: &ModelSpec) -> Result<(), ParamError> {
    let layout = spec.layout();
    zero(nvm, layout.program, layout.end - layout.program)
}

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
        let l = SPEC.layout();
        assert_eq!((l.axis, l.global, l.user, l.coords, l.program), (0x10, 0x90, 0x110, 0x210, 0x400));
    }

    #[test]
    fn format_then_load_defaults() {
        let mut nvm = RamNvm(std::vec![0xFF; capacity(&SPEC)]);
        assert!(!is_formatted(&mut nvm, &SPEC));
        format(&mut nvm, &SPEC, true).unwrap();
        assert!(is_formatted(&mut nvm, &SPEC));
        let (i, _) = find(SPEC.axis.params, 214).unwrap();
        assert_eq!(load_axis(&mut nvm, &SPEC, 0, i), Ok(200));
        let (i, _) = find(SPEC.global.params, 66).unwrap();
        assert_eq!(load_global(&mut nvm, &SPEC, i), Ok(1));
        assert_eq!(&nvm.0[..4], b"OTMC");
        assert!(nvm.0[SPEC.layout().program..].iter().all(|b| *b == 0));
    }

    #[test]
    fn slots_and_refusals() {
        let mut nvm = RamNvm(std::vec![0xFF; capacity(&SPEC)]);
        format(&mut nvm, &SPEC, false).unwrap();
        let (i, _) = find(SPEC.axis.params, 4).unwrap();
        store_axis(&mut nvm, &SPEC, 0, i, 1234).unwrap();
        assert_eq!(load_axis(&mut nvm, &SPEC, 0, i), Ok(1234));
        let (i, _) = find(SPEC.axis.params, 0).unwrap();
        assert_eq!(store_axis(&mut nvm, &SPEC, 0, i, 1), Err(ParamError::NotPermitted));
        store_user(&mut nvm, &SPEC, 55, -7).unwrap();
        assert_eq!(load_user(&mut nvm, &SPEC, 55), Ok(-7));
        assert_eq!(store_user(&mut nvm, &SPEC, 56, 1), Err(ParamError::NotPermitted));
        store_coordinate(&mut nvm, &SPEC, 0, 20, 99).unwrap();
        // The bulk read gives what the cell-by-cell read gives, a bad checksum included.
        let i = Instruction::new(tmcl_wire::Opcode::Mvp, 0, 0, -5);
        store_program_cell(&mut nvm, &SPEC, 33, &i).unwrap();
        nvm.0[SPEC.layout().program + 40 * PROGRAM_CELL] = 4; // cell 40: opcode 4, checksum 0
        let mut all = Vec::new();
        load_program(&mut nvm, &SPEC, usize::MAX, |a, c| all.push((a, c)));
        assert_eq!(all.len(), 2048);
        for (a, c) in all {
            assert_eq!(Some(c), load_program_cell(&mut nvm, &SPEC, a), "cell {a}");
        }
        assert_eq!(load_program_cell(&mut nvm, &SPEC, 33), Some(i));
        assert_eq!(load_program_cell(&mut nvm, &SPEC, 40), Some(Instruction::new(0.into(), 0, 0, 0)));
        assert_eq!(load_coordinate(&mut nvm, &SPEC, 0, 20), Ok(99));
        assert_eq!(store_coordinate(&mut nvm, &SPEC, 0, 0, 1), Err(ParamError::OutOfRange));
        let mut small = RamNvm(std::vec![0; 16]);
        assert_eq!(format(&mut small, &SPEC, true), Err(ParamError::Storage));
    }
}

//! The EEPROM layout, computed from a model at compile time (by [`crate::ModelSpec::new`]).
//!
//! The real modules' layouts are not published; this one is ours. All numbers are big-endian.
//!
//! | region | size | content |
//! |---|---|---|
//! | header | 16 | magic `OTMC`, layout version (u16), model tag (u16), 8 reserved |
//! | axis | E parameters × 4 | the E parameters of motor 0, in table order |
//! | global | A parameters × 4 | bank 0's A parameters, in table order |
//! | user | stored user variables × 4 | bank 2 variables 0.. (those STGP can store) |
//! | coordinates | coordinates × 4 | coordinates 1..=n of motor 0 (coordinate 0 is RAM only) |
//! | program | program memory × 8 | per command: opcode, type, motor, value (4), checksum |
//!
//! Each parameter region is rounded up to whole blocks of 32 slots (128 bytes) and the program starts on
//! a 1 KiB boundary, so that a model keeps its layout when a table grows by a few entries — and the
//! PD28-1021's layout is the one its images have always had (axis 0x0010, bank 0 0x0090, user variables
//! 0x0110, coordinates 0x0210, program 0x0400).

/// Bytes per parameter slot.
pub const SLOT: usize = 4;
/// Bytes per program-memory cell.
pub const PROGRAM_CELL: usize = 8;
/// The header's size.
pub const HEADER_LEN: usize = 16;
/// Regions are whole blocks of this many bytes (32 slots).
pub const BLOCK: usize = 32 * SLOT;
/// The program region starts on a multiple of this.
pub const PROGRAM_ALIGN: usize = 1024;

/// Where each region of a model's EEPROM image starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Axis parameter slots.
    pub axis: usize,
    /// Bank 0 slots.
    pub global: usize,
    /// User variable slots.
    pub user: usize,
    /// Coordinate slots (coordinate n at `coords + 4·(n−1)`).
    pub coords: usize,
    /// Program memory.
    pub program: usize,
    /// The end of the image: the EEPROM size the model needs.
    pub end: usize,
}

const fn blocks(slots: usize) -> usize {
    (slots * SLOT).div_ceil(BLOCK) * BLOCK
}

impl Layout {
    /// The layout for the given region sizes (slots, and program cells).
    pub const fn compute(axis: usize, global: usize, user: usize, coords: usize, program: usize) -> Layout {
        let a = HEADER_LEN;
        let g = a + blocks(axis);
        let u = g + blocks(global);
        let c = u + blocks(user);
        let p = (c + blocks(coords)).div_ceil(PROGRAM_ALIGN) * PROGRAM_ALIGN;
        Layout { axis: a, global: g, user: u, coords: c, program: p, end: p + program * PROGRAM_CELL }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pd28_layout() {
        let l = Layout::compute(11, 13, 56, 20, 2048);
        assert_eq!((l.axis, l.global, l.user, l.coords, l.program), (0x10, 0x90, 0x110, 0x210, 0x400));
        assert_eq!(l.end, 0x400 + 2048 * 8);
    }

    #[test]
    fn regions_grow_by_blocks_and_never_overlap() {
        let l = Layout::compute(33, 0, 256, 0, 16);
        assert_eq!((l.global, l.user, l.coords), (0x10 + 256, 0x110, 0x110 + 1024));
        assert_eq!(l.program % PROGRAM_ALIGN, 0);
        assert!(l.program >= l.coords);
    }
}

//! An EEPROM in RAM: the configuration and program memory of a board whose flash the firmware cannot
//! write (QEMU does not emulate the LM3S6965's flash controller).
//!
//! The cells are atomic bytes, so the memory can live in a `static` without `unsafe`. It keeps its
//! contents across a software or watchdog reset when the port places it in RAM that the start-up code
//! does not clear (cortex-m-rt's `.uninit` section) and loses them at power-off; the core then finds no
//! valid image and formats it with the factory defaults, as on a module with a new EEPROM. A write cannot
//! be torn by a reset of the firmware (nothing resets in the middle of a copy), which is the atomicity
//! the [`Nvm`] contract asks for.

use core::sync::atomic::{AtomicU8, Ordering};
use tmcl_core::hal::Nvm;

/// An access past the end of the memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutOfRange;

impl core::fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("access past the end of the EEPROM")
    }
}

/// An EEPROM over a slice of atomic bytes.
pub struct RamNvm<'a> {
    cells: &'a [AtomicU8],
}

impl<'a> RamNvm<'a> {
    /// An EEPROM of `cells.len()` bytes over `cells`, with what they hold.
    pub fn new(cells: &'a [AtomicU8]) -> RamNvm<'a> {
        RamNvm { cells }
    }

    fn range(&self, offset: usize, len: usize) -> Result<&'a [AtomicU8], OutOfRange> {
        let end = offset.checked_add(len).ok_or(OutOfRange)?;
        self.cells.get(offset..end).ok_or(OutOfRange)
    }
}

impl Nvm for RamNvm<'_> {
    type Error = OutOfRange;

    fn capacity(&self) -> usize {
        self.cells.len()
    }

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), OutOfRange> {
        let cells = self.range(offset, buf.len())?;
        for (b, cell) in buf.iter_mut().zip(cells) {
            *b = cell.load(Ordering::Relaxed);
        }
        Ok(())
    }

    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), OutOfRange> {
        for (b, cell) in data.iter().zip(self.range(offset, data.len())?) {
            cell.store(*b, Ordering::Relaxed);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{OutOfRange, RamNvm};
    use core::sync::atomic::AtomicU8;
    use tmcl_core::hal::Nvm;
    use tmcl_core::model::pd28_1021;
    use tmcl_core::param::persist;

    #[test]
    fn reads_back_what_was_written_and_refuses_the_outside() {
        let cells = [const { AtomicU8::new(0) }; 16];
        let mut nvm = RamNvm::new(&cells);
        assert_eq!(nvm.capacity(), 16);
        nvm.write(3, &[1, 2, 3]).unwrap();
        let mut buf = [0u8; 5];
        nvm.read(2, &mut buf).unwrap();
        assert_eq!(buf, [0, 1, 2, 3, 0]);
        assert_eq!(nvm.write(15, &[1, 2]), Err(OutOfRange));
        assert_eq!(nvm.read(usize::MAX, &mut buf), Err(OutOfRange));
        assert_eq!(nvm.read(17, &mut []), Err(OutOfRange));
        nvm.read(16, &mut []).unwrap();
    }

    #[test]
    fn the_core_formats_a_blank_one_and_keeps_it_across_a_restart() {
        let spec = &pd28_1021::SPEC;
        let cells: Vec<AtomicU8> = (0..persist::capacity(spec)).map(|_| AtomicU8::new(0)).collect();
        let mut nvm = RamNvm::new(&cells);
        assert!(!persist::is_formatted(&mut nvm, spec));
        persist::format(&mut nvm, spec, true).unwrap();
        // A second view of the same cells (as after a reset) finds the image.
        let mut again = RamNvm::new(&cells);
        assert!(persist::is_formatted(&mut again, spec));
    }
}

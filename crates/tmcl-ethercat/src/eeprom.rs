//! The SII EEPROM: its image, generated from the model, and the ESC's EEPROM interface (registers
//! 0x0500–0x050F) through which a master reads and writes it (ET1100 datasheet, "SII EEPROM interface";
//! ETG.2010 for the contents).
//!
//! The image holds what a master needs to bring the slave to OP **without CoE** (the mailbox protocols
//! word advertises FoE only, so neither SOEM nor ethercrab asks for an object dictionary):
//!
//! | words | contents |
//! |---|---|
//! | 0x00–0x07 | ESC configuration: PDI control 0x05 (SPI, the module's microcontroller), alias 0, CRC |
//! | 0x08–0x0F | vendor ID 0x286, product code 1310, revision (major << 16 \| minor: 0x0001000E for V1.14), serial 0 |
//! | 0x14–0x17 | bootstrap mailbox: 0x1000/268 out, 0x110C/40 in (manual §3.3) |
//! | 0x18–0x1B | standard mailbox: the same |
//! | 0x1C | mailbox protocols: FoE (TMCL travels raw, it has no protocol bit) |
//! | 0x3E | size: 16 Kbit (2 KiB) |
//! | 0x40… | STRINGS, GENERAL, FMMU, SYNCM, TXPDO, RXPDO, end |
//!
//! STRINGS holds the device name as string 1 (SOEM shows string 1, ethercrab the GENERAL name index,
//! which points at it), a group, the PDO names and every entry's name from the manual's table.
//!
//! # What a master writes, kept
//!
//! A master may write the image (write enable and command 2, as on the chip): the station alias with
//! eepromtool's `-walias`, or a whole new image. Every word written goes first to a store, an
//! [`Nvm`] (the core's EEPROM trait, whose writes are atomic), and only then into the image; a store that
//! refuses the write leaves the image as it was and the command ends with the acknowledge error (bit 13),
//! as an EEPROM that does not answer. At the next start [`Eeprom::restore`] lays the words kept over the
//! image generated from the model: a written word survives a restart, and where no master wrote, a newer
//! model's image shows through. The store holds one 4-byte record per word ([`SII_STORE_LEN`] bytes):
//! the value (little-endian), 0x00 for "written" (an erased store reads 0xFF), and 0xFF; one record is
//! one atomic write, so a crash keeps a word whole or not at all. [`Volatile`] keeps nothing.

use crate::esc::Esc;
use crate::layout;
use crate::pdo;
use crate::register as reg;
use crate::wire::le;
use crate::wire::sii::{self, fmmu_usage, word, CategoryType, General, Pdo, PdoEntry, SyncManager};
use tmcl_core::hal::Nvm;
use tmcl_core::model::ethercat::DataType;
use tmcl_core::model::{EtherCatDesc, ModelSpec};

/// Size of the image: 2 KiB, 16 Kbit.
pub const SII_BYTES: usize = 2048;

/// PDI control (SII word 0, low byte): SPI slave, the module's microcontroller on the ET1100.
pub const PDI_SPI: u8 = 0x05;

/// Words in the image.
pub const SII_WORDS: usize = SII_BYTES / 2;
/// Bytes of the store of written words: one 4-byte record per word.
pub const SII_STORE_LEN: usize = 4 * SII_WORDS;
/// Length of one record in the store.
const RECORD: usize = 4;
/// The record's third byte when the word was written (an erased store reads 0xFF).
const WRITTEN: u8 = 0x00;

/// A store that keeps nothing: it reads erased and takes every write (the SII lasts as long as the
/// slave, as without `--eeprom`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Volatile;

impl Nvm for Volatile {
    type Error = core::convert::Infallible;
    fn capacity(&self) -> usize {
        SII_STORE_LEN
    }
    fn read(&mut self, _: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        buf.fill(0xFF);
        Ok(())
    }
    fn write(&mut self, _: usize, _: &[u8]) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Why the words kept could not be restored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RestoreError<E> {
    /// The store is smaller than [`SII_STORE_LEN`].
    TooSmall,
    /// The store could not be read.
    Read(E),
}

impl<E: core::fmt::Debug> core::fmt::Display for RestoreError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RestoreError::TooSmall => write!(f, "the SII store holds fewer than {SII_STORE_LEN} bytes"),
            RestoreError::Read(e) => write!(f, "the SII store cannot be read: {e:?}"),
        }
    }
}

/// The EEPROM image and the state of its interface.
#[derive(Clone, PartialEq, Eq)]
pub struct Eeprom {
    image: [u8; SII_BYTES],
}

impl core::fmt::Debug for Eeprom {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Eeprom").field("vendor", &self.word32(word::VENDOR_ID)).finish_non_exhaustive()
    }
}

/// Writes categories into an image.
struct Writer<'a> {
    image: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    /// Writes a category whose data `fill` puts into the slice it gets (at most the room left), and
    /// returns the bytes used; pads to a word.
    fn category(&mut self, kind: CategoryType, fill: impl FnOnce(&mut [u8]) -> usize) {
        let data_at = self.at + sii::CATEGORY_HEADER_LEN;
        // Room for this header and the end marker after it.
        let Some(room) = self.image.get_mut(data_at..self.image.len().saturating_sub(4)) else { return };
        let used = fill(room);
        let words = used.div_ceil(2);
        le::set_u16(self.image, self.at, kind.into());
        le::set_u16(self.image, self.at + 2, words as u16);
        self.at = data_at + 2 * words;
    }

    fn end(&mut self) {
        if self.at + 4 > self.image.len() {
            return;
        }
        le::set_u16(self.image, self.at, CategoryType::End.into());
        le::set_u16(self.image, self.at + 2, 0xFFFF);
    }
}

/// The strings of the STRINGS category, in order (index = position + 1).
fn strings(spec: &ModelSpec, map: &EtherCatDesc) -> impl Iterator<Item = &'static str> {
    [spec.name, map.group, "Outputs", "Inputs", map.mode_name, map.value_name]
        .into_iter()
        .chain(map.inputs.iter().map(|f| f.name))
}

/// String index of the name, the group, the PDO names and the first entry names.
const NAME: u8 = 1;
const GROUP: u8 = 2;
const RX_PDO_NAME: u8 = 3;
const TX_PDO_NAME: u8 = 4;
const FIRST_OUTPUT_NAME: u8 = 5;
const FIRST_INPUT_NAME: u8 = FIRST_OUTPUT_NAME + 2;

/// One PDO entry as the SII lists it: its CoE type and bit length.
#[derive(Clone, Copy)]
struct Entry {
    data_type: u8,
    bits: u8,
}

impl Eeprom {
    /// The image for `spec` with its EtherCAT description `map`: identity and process data from the
    /// map, buffers from [`layout`].
    pub fn for_model(spec: &ModelSpec, map: &EtherCatDesc) -> Eeprom {
        // Erased (0xFF) beyond the fixed words, as an EEPROM past its last category.
        let mut e = Eeprom { image: [0xFF; SII_BYTES] };
        e.image[..2 * usize::from(word::FIRST_CATEGORY)].fill(0);
        e.set_word(word::PDI_CONTROL, u16::from(PDI_SPI));
        e.set_word32(word::VENDOR_ID, map.vendor_id);
        e.set_word32(word::PRODUCT_CODE, map.product_code);
        e.set_word32(word::REVISION, map.revision);
        e.set_word32(word::SERIAL, 0);
        for at in [word::BOOT_RX_MAILBOX, word::STD_RX_MAILBOX] {
            e.set_word(at, layout::MAILBOX_OUT.start);
            e.set_word(at + 1, layout::MAILBOX_OUT.length);
        }
        for at in [word::BOOT_TX_MAILBOX, word::STD_TX_MAILBOX] {
            e.set_word(at, layout::MAILBOX_IN.start);
            e.set_word(at + 1, layout::MAILBOX_IN.length);
        }
        e.set_word(word::MAILBOX_PROTOCOL, sii::protocol::FOE);
        e.set_word(word::SIZE, (SII_BYTES * 8 / 1024 - 1) as u16);
        e.set_word(word::VERSION, 1);
        let crc = sii::crc8(&e.image[..14]);
        e.set_word(word::CHECKSUM, u16::from(crc));
        let mut w = Writer { image: &mut e.image, at: 2 * usize::from(word::FIRST_CATEGORY) };
        w.category(CategoryType::Strings, |out| {
            let mut at = 1;
            let mut count = 0u8;
            for s in strings(spec, map) {
                let b = s.as_bytes();
                if let Some(dst) = out.get_mut(at..at + 1 + b.len()) {
                    dst[0] = b.len() as u8;
                    dst[1..].copy_from_slice(b);
                    at += 1 + b.len();
                    count += 1;
                }
            }
            if let Some(first) = out.first_mut() {
                *first = count;
            }
            at
        });
        w.category(CategoryType::General, |out| {
            let g = General {
                group: GROUP,
                image: 0,
                order: NAME,
                name: NAME,
                // FoE, in BOOT.
                foe_details: 1,
                // Enable SafeOp; LRW allowed.
                flags: 0x01,
                // Own supply: nothing from the E-bus.
                ebus_current: 0,
                // Ports 0 and 1 MII (LINK IN, LINK OUT).
                physical_port: 0x0011,
                ..General::default()
            };
            match out.get_mut(..General::LEN) {
                Some(dst) => {
                    g.emit(dst);
                    General::LEN
                }
                None => 0,
            }
        });
        w.category(CategoryType::Fmmu, |out| {
            let usage = [fmmu_usage::OUTPUTS, fmmu_usage::INPUTS, fmmu_usage::SM_STATUS, fmmu_usage::UNUSED];
            match out.get_mut(..usage.len()) {
                Some(dst) => {
                    dst.copy_from_slice(&usage);
                    usage.len()
                }
                None => 0,
            }
        });
        w.category(CategoryType::SyncManager, |out| {
            let mut at = 0;
            for s in layout::sync_managers(map) {
                let sm = SyncManager {
                    start: s.start,
                    length: s.length,
                    control: s.control,
                    status: 0,
                    enable: 1,
                    sm_type: s.sm_type,
                };
                if let Some(dst) = out.get_mut(at..at + SyncManager::LEN) {
                    sm.emit(dst);
                    at += SyncManager::LEN;
                }
            }
            at
        });
        let pdo = |out: &mut [u8],
                   index: u16,
                   sm: usize,
                   name: u8,
                   object: u16,
                   first_name: u8,
                   fields: &mut dyn ExactSizeIterator<Item = Entry>| {
            let head = Pdo {
                index,
                entries: fields.len() as u8,
                sync_manager: sm as u8,
                dc_sync: 0,
                name,
                // Fixed content: the mapping cannot change.
                flags: 0x0010,
            };
            let Some(dst) = out.get_mut(..Pdo::LEN + fields.len() * PdoEntry::LEN) else { return 0 };
            head.emit(dst);
            let count = fields.len();
            for (k, (f, slot)) in fields.zip(dst[Pdo::LEN..].chunks_exact_mut(PdoEntry::LEN)).enumerate() {
                PdoEntry {
                    index: object,
                    subindex: k as u8 + 1,
                    name: first_name + k as u8,
                    data_type: f.data_type,
                    bit_length: f.bits,
                    flags: 0,
                }
                .emit(slot);
            }
            Pdo::LEN + count * PdoEntry::LEN
        };
        let mut inputs = map.inputs.iter().map(|f| Entry { data_type: f.data_type.code(), bits: f.data_type.bits() });
        w.category(CategoryType::TxPdo, |out| {
            let sm = layout::inputs(map).index;
            pdo(out, pdo::TX_PDO, sm, TX_PDO_NAME, pdo::INPUT_OBJECT, FIRST_INPUT_NAME, &mut inputs)
        });
        let mut outputs = [DataType::Unsigned32, DataType::Integer32]
            .into_iter()
            .map(|t| Entry { data_type: t.code(), bits: t.bits() });
        w.category(CategoryType::RxPdo, |out| {
            let sm = layout::OUTPUTS.index;
            pdo(out, pdo::RX_PDO, sm, RX_PDO_NAME, pdo::OUTPUT_OBJECT, FIRST_OUTPUT_NAME, &mut outputs)
        });
        w.end();
        e
    }

    /// The image.
    pub fn image(&self) -> &[u8] {
        &self.image
    }

    /// A word (0xFFFF beyond the image, as an erased EEPROM reads).
    pub fn word(&self, at: u16) -> u16 {
        let i = 2 * usize::from(at);
        match self.image.get(i..i + 2) {
            Some(b) => le::u16(b, 0),
            None => 0xFFFF,
        }
    }

    /// Two words as a 32-bit value.
    pub fn word32(&self, at: u16) -> u32 {
        u32::from(self.word(at)) | u32::from(self.word(at.wrapping_add(1))) << 16
    }

    fn set_word(&mut self, at: u16, v: u16) {
        let i = 2 * usize::from(at);
        if let Some(b) = self.image.get_mut(i..i + 2) {
            b.copy_from_slice(&v.to_le_bytes());
        }
    }

    fn set_word32(&mut self, at: u16, v: u32) {
        self.set_word(at, v as u16);
        self.set_word(at.wrapping_add(1), (v >> 16) as u16);
    }

    /// Lays the words a master wrote earlier, kept in `store`, over the image; returns how many there
    /// were. The store is only read.
    pub fn restore<N: Nvm>(&mut self, store: &mut N) -> Result<usize, RestoreError<N::Error>> {
        if store.capacity() < SII_STORE_LEN {
            return Err(RestoreError::TooSmall);
        }
        let mut kept = 0;
        let mut chunk = [0u8; 64 * RECORD];
        for (k, first) in (0..SII_WORDS).step_by(64).enumerate() {
            store.read(k * chunk.len(), &mut chunk).map_err(RestoreError::Read)?;
            for (i, record) in chunk.chunks_exact(RECORD).enumerate() {
                if record[2] == WRITTEN {
                    self.set_word((first + i) as u16, u16::from_le_bytes([record[0], record[1]]));
                    kept += 1;
                }
            }
        }
        Ok(kept)
    }

    /// What the ESC loads from the EEPROM: PDI control and ESC configuration (word 0), PDI configuration
    /// (word 1), and at power-on only (`power_on`) the station alias (word 4): a reload command does not
    /// take the alias over (ET1100 datasheet section I §11.1). Returns whether the checksum of words
    /// 0..7 is right.
    pub fn load_into(&self, esc: &mut Esc, power_on: bool) -> bool {
        esc.set_reg16(reg::PDI_CONTROL, self.word(word::PDI_CONTROL));
        esc.set_reg16(reg::PDI_CONFIGURATION, self.word(word::PDI_CONFIGURATION));
        if power_on {
            esc.set_reg16(reg::STATION_ALIAS, self.word(word::STATION_ALIAS));
        }
        sii::crc8(&self.image[..14]) == self.image[14]
    }

    /// Carries out the command a master wrote into the SII control register (0x0502–0x0503), at once:
    /// the busy bit is never seen set.
    ///
    /// | command (bits 8..11) | effect |
    /// |---|---|
    /// | 0 | nothing (clears the error bits) |
    /// | 1 read | 4 words from the address (0x0504) into the data register (0x0508) |
    /// | 2 write | the word in 0x0508 to `store`, then to the address, if write enable (bit 0) came with the command; else error bit 14; a store that fails: error bit 13, the word unchanged |
    /// | 4 reload | the configuration words into their registers (not the alias); a bad checksum sets bit 11 |
    /// | other | error bit 13 |
    pub fn command<N: Nvm>(&mut self, esc: &mut Esc, store: &mut N) {
        let control = esc.reg16(reg::SII_CONTROL);
        let address = esc.reg32(reg::SII_ADDRESS);
        let mut status = 0x0040; // 8-byte reads
        match (control >> 8) & 0x07 {
            0 => {}
            1 => {
                let data = esc.sii_data_mut();
                for k in 0..4u32 {
                    let w = u16::try_from(address.wrapping_add(k)).map_or(0xFFFF, |a| self.word(a));
                    data[2 * k as usize..2 * k as usize + 2].copy_from_slice(&w.to_le_bytes());
                }
            }
            2 if control & 0x01 != 0 => {
                let v = le::u16(esc.sii_data_mut(), 0);
                match u16::try_from(address) {
                    Ok(a) if usize::from(a) < SII_WORDS => {
                        let [lo, hi] = v.to_le_bytes();
                        match store.write(RECORD * usize::from(a), &[lo, hi, WRITTEN, 0xFF]) {
                            Ok(()) => self.set_word(a, v),
                            Err(_) => status |= 0x2000,
                        }
                    }
                    // Past the image: no EEPROM answers there.
                    _ => status |= 0x2000,
                }
            }
            2 => status |= 0x4000,
            4 => {
                if !self.load_into(esc, false) {
                    status |= 0x0800;
                }
            }
            _ => status |= 0x2000,
        }
        esc.set_reg16(reg::SII_CONTROL, status);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::sii::{categories, string};
    use tmcl_core::model::tmcm_1310::{ETHERCAT, SPEC};
    use tmcl_sim::MemNvm;

    /// A store that refuses every write (a full disk).
    struct Broken;
    impl Nvm for Broken {
        type Error = ();
        fn capacity(&self) -> usize {
            SII_STORE_LEN
        }
        fn read(&mut self, _: usize, buf: &mut [u8]) -> Result<(), ()> {
            buf.fill(0xFF);
            Ok(())
        }
        fn write(&mut self, _: usize, _: &[u8]) -> Result<(), ()> {
            Err(())
        }
    }

    #[test]
    fn a_store_that_refuses_leaves_the_word_and_says_so() {
        let mut e = Eeprom::for_model(&SPEC, &ETHERCAT);
        let mut esc = Esc::new();
        esc.ecat_write(reg::SII_DATA, &[0x34, 0x12]);
        esc.ecat_write(reg::SII_CONTROL, &[0x01, 0x02, 0x04, 0, 0, 0]);
        e.command(&mut esc, &mut Broken);
        assert_eq!(e.word(4), 0, "unchanged");
        assert_eq!(esc.reg16(reg::SII_CONTROL) & 0x2000, 0x2000, "acknowledge error");
        assert!(matches!(e.restore(&mut MemNvm::new(16)), Err(RestoreError::TooSmall)));
    }

    fn find(e: &Eeprom, kind: CategoryType) -> Vec<u8> {
        categories(e.image()).find(|c| c.category_type() == kind).map(|c| c.data().to_vec()).unwrap()
    }

    #[test]
    fn identity() {
        let e = Eeprom::for_model(&SPEC, &ETHERCAT);
        assert_eq!(e.word32(word::VENDOR_ID), 0x286);
        assert_eq!(e.word32(word::PRODUCT_CODE), 1310);
        assert_eq!(e.word32(word::REVISION), 0x0001_000E);
        assert_eq!((e.word(0x18), e.word(0x19), e.word(0x1A), e.word(0x1B)), (0x1000, 268, 0x110C, 40));
        assert_eq!(e.word(word::MAILBOX_PROTOCOL), sii::protocol::FOE);
        assert_eq!(sii::crc8(&e.image()[..14]), e.image()[14]);
    }

    #[test]
    fn categories_a_master_maps_from() {
        let e = Eeprom::for_model(&SPEC, &ETHERCAT);
        let kinds: Vec<CategoryType> = categories(e.image()).map(|c| c.category_type()).collect();
        use CategoryType as C;
        assert_eq!(kinds, [C::Strings, C::General, C::Fmmu, C::SyncManager, C::TxPdo, C::RxPdo]);
        let s = find(&e, C::Strings);
        let g = General::parse(&find(&e, C::General)).unwrap();
        assert_eq!(string(&s, g.name), Some(&b"TMCM-1310"[..]));
        assert_eq!(string(&s, 1), Some(&b"TMCM-1310"[..]));
        let sm = find(&e, C::SyncManager);
        let sm2 = sii::SyncManager::parse(&sm[16..]).unwrap();
        assert_eq!((sm2.start, sm2.length, sm2.sm_type), (0x1200, 8, 3));
        let tx = find(&e, C::TxPdo);
        let head = Pdo::parse(&tx).unwrap();
        assert_eq!((head.index, head.entries, head.sync_manager), (0x1A00, 12, 3));
        let bits: u32 = tx[8..].chunks(8).map(|c| u32::from(PdoEntry::parse(c).unwrap().bit_length)).sum();
        assert_eq!(bits, 48 * 8);
        let last = PdoEntry::parse(&tx[8 + 11 * 8..]).unwrap();
        assert_eq!(string(&s, last.name), Some(&b"Gamma"[..]));
        let rx = find(&e, C::RxPdo);
        assert_eq!(Pdo::parse(&rx).unwrap().sync_manager, 2);
        // Everything a master walks sits well inside SOEM's 4 KiB cache.
        let end = 2 * 0x40 + categories(e.image()).map(|c| c.total_len()).sum::<usize>();
        assert!(end < 1024, "categories end at byte {end}");
    }

    #[test]
    fn interface_reads_writes_and_refuses() {
        let mut e = Eeprom::for_model(&SPEC, &ETHERCAT);
        let mut esc = Esc::new();
        let mut store = MemNvm::new(SII_STORE_LEN);
        // Read words 8..12 (vendor and product).
        esc.ecat_write(reg::SII_CONTROL, &[0x00, 0x01, 0x08, 0, 0, 0]);
        e.command(&mut esc, &mut store);
        assert_eq!(esc.reg32(reg::SII_DATA), 0x286);
        assert_eq!(esc.reg32(reg::SII_DATA + 4), 1310);
        assert_eq!(esc.reg16(reg::SII_CONTROL), 0x0040);
        // A write without write enable is refused.
        esc.ecat_write(reg::SII_DATA, &[0x34, 0x12]);
        esc.ecat_write(reg::SII_CONTROL, &[0x00, 0x02, 0x04, 0, 0, 0]);
        e.command(&mut esc, &mut store);
        assert_eq!(esc.reg16(reg::SII_CONTROL) & 0x4000, 0x4000);
        assert_eq!(e.word(4), 0);
        // With write enable it lands; a reload does not take the alias over (only power-on does, ET1100
        // datasheet section I §11.1) and finds the checksum stale.
        esc.ecat_write(reg::SII_CONTROL, &[0x01, 0x02, 0x04, 0, 0, 0]);
        e.command(&mut esc, &mut store);
        assert_eq!(e.word(4), 0x1234);
        esc.ecat_write(reg::SII_CONTROL, &[0x00, 0x04]);
        e.command(&mut esc, &mut store);
        assert_eq!(esc.reg16(reg::STATION_ALIAS), 0);
        assert_eq!(esc.reg16(reg::SII_CONTROL) & 0x0800, 0x0800);
        // The word is kept: a fresh image with the store laid over it has it, and power-on loads it.
        let mut again = Eeprom::for_model(&SPEC, &ETHERCAT);
        assert!(matches!(again.restore(&mut store), Ok(1)));
        assert_eq!(again.word(4), 0x1234);
        let mut fresh = Esc::new();
        again.load_into(&mut fresh, true);
        assert_eq!(fresh.reg16(reg::STATION_ALIAS), 0x1234);
        // Reading beyond the image gives erased words.
        esc.ecat_write(reg::SII_CONTROL, &[0x00, 0x01, 0xff, 0x03, 0, 0]);
        e.command(&mut esc, &mut store);
        assert_eq!(esc.reg32(reg::SII_DATA + 4), 0xFFFF_FFFF);
    }
}

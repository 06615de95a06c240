//! The Slave Information Interface EEPROM (ETG.1000.6 "SII"; ETG.2010 "EtherCAT Slave Information
//! Interface"): fixed words 0x0000–0x003F, then categories from word 0x0040.
//!
//! Everything is little-endian and addressed in 16-bit words. A category is a header of two words (type,
//! data length in words) followed by its data; the list ends with type 0xFFFF.

use super::{enum_with_unknown, le, Error};

/// Word addresses of the fixed area (ETG.2010, "SII EEPROM content").
pub mod word {
    /// PDI control (low byte → ESC register 0x0140) and ESC configuration (high byte → 0x0141).
    pub const PDI_CONTROL: u16 = 0x0000;
    /// PDI configuration (→ 0x0150).
    pub const PDI_CONFIGURATION: u16 = 0x0001;
    /// SYNC impulse length in 10 ns (→ 0x0982).
    pub const SYNC_IMPULSE: u16 = 0x0002;
    /// Extended PDI configuration (→ 0x0152).
    pub const PDI_CONFIGURATION_2: u16 = 0x0003;
    /// Configured station alias (→ 0x0012).
    pub const STATION_ALIAS: u16 = 0x0004;
    /// Checksum of words 0..7 (low byte; [`super::crc8`]).
    pub const CHECKSUM: u16 = 0x0007;
    /// Vendor ID (2 words).
    pub const VENDOR_ID: u16 = 0x0008;
    /// Product code (2 words).
    pub const PRODUCT_CODE: u16 = 0x000A;
    /// Revision number (2 words).
    pub const REVISION: u16 = 0x000C;
    /// Serial number (2 words).
    pub const SERIAL: u16 = 0x000E;
    /// Bootstrap receive mailbox (master → slave): offset, then size.
    pub const BOOT_RX_MAILBOX: u16 = 0x0014;
    /// Bootstrap send mailbox (slave → master): offset, then size.
    pub const BOOT_TX_MAILBOX: u16 = 0x0016;
    /// Standard receive mailbox (master → slave): offset, then size.
    pub const STD_RX_MAILBOX: u16 = 0x0018;
    /// Standard send mailbox (slave → master): offset, then size.
    pub const STD_TX_MAILBOX: u16 = 0x001A;
    /// Supported mailbox protocols (bit 0 AoE, 1 EoE, 2 CoE, 3 FoE, 4 SoE, 5 VoE).
    pub const MAILBOX_PROTOCOL: u16 = 0x001C;
    /// EEPROM size in Kbit, minus 1.
    pub const SIZE: u16 = 0x003E;
    /// Version of the layout (1).
    pub const VERSION: u16 = 0x003F;
    /// The first category header.
    pub const FIRST_CATEGORY: u16 = 0x0040;
}

/// Mailbox protocol bits of [`word::MAILBOX_PROTOCOL`].
pub mod protocol {
    /// ADS over EtherCAT.
    pub const AOE: u16 = 0x0001;
    /// Ethernet over EtherCAT.
    pub const EOE: u16 = 0x0002;
    /// CANopen over EtherCAT.
    pub const COE: u16 = 0x0004;
    /// File access over EtherCAT.
    pub const FOE: u16 = 0x0008;
    /// Servo profile over EtherCAT.
    pub const SOE: u16 = 0x0010;
    /// Vendor specific.
    pub const VOE: u16 = 0x0020;
}

enum_with_unknown! {
    /// Category types (ETG.2010, "Category types").
    pub enum CategoryType(u16) {
        /// No information.
        Nop = 0,
        /// Strings: a count, then length-prefixed strings (index 1 is the first).
        Strings = 10,
        /// Data types.
        DataTypes = 20,
        /// General information.
        General = 30,
        /// FMMU usage, one byte per FMMU.
        Fmmu = 40,
        /// SyncManager configuration, 8 bytes per SyncManager.
        SyncManager = 41,
        /// FMMU to SyncManager mapping.
        FmmuExtended = 42,
        /// Sync units.
        SyncUnit = 43,
        /// TxPDO description (inputs, slave → master).
        TxPdo = 50,
        /// RxPDO description (outputs, master → slave).
        RxPdo = 51,
        /// Distributed clocks.
        Dc = 60,
        /// End of the category list.
        End = 0xFFFF,
    }
}

/// Length of a category header.
pub const CATEGORY_HEADER_LEN: usize = 4;

/// A read view of one category. Accessors panic if the buffer is shorter than the header and its
/// declared data; [`Category::new_checked`] rules that out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Category<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Category<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Category<T> {
        Category { buffer }
    }

    /// Wraps a buffer after [`Category::check_len`].
    pub fn new_checked(buffer: T) -> Result<Category<T>, Error> {
        let c = Category::new_unchecked(buffer);
        c.check_len()?;
        Ok(c)
    }

    /// Ensures that no accessor will panic. The end marker needs only its type word.
    pub fn check_len(&self) -> Result<(), Error> {
        let b = self.buffer.as_ref();
        if b.len() >= 2 && le::u16(b, 0) == 0xFFFF {
            return Ok(());
        }
        if b.len() < CATEGORY_HEADER_LEN || b.len() < CATEGORY_HEADER_LEN + 2 * usize::from(le::u16(b, 2)) {
            return Err(Error::Truncated);
        }
        Ok(())
    }

    /// Type.
    pub fn category_type(&self) -> CategoryType {
        CategoryType::from(le::u16(self.buffer.as_ref(), 0))
    }

    /// Data length in words (0 for the end marker).
    pub fn word_length(&self) -> u16 {
        if self.category_type() == CategoryType::End {
            return 0;
        }
        le::u16(self.buffer.as_ref(), 2)
    }

    /// The data.
    pub fn data(&self) -> &[u8] {
        if self.category_type() == CategoryType::End {
            return &[];
        }
        let n = 2 * usize::from(self.word_length());
        &self.buffer.as_ref()[CATEGORY_HEADER_LEN..CATEGORY_HEADER_LEN + n]
    }

    /// Header and data: where the next category starts, in bytes.
    pub fn total_len(&self) -> usize {
        CATEGORY_HEADER_LEN + 2 * usize::from(self.word_length())
    }
}

/// The categories of an EEPROM image from word 0x0040 to the end marker (or to where the list breaks).
pub fn categories(image: &[u8]) -> Categories<'_> {
    Categories { image, at: 2 * usize::from(word::FIRST_CATEGORY) }
}

/// Iterator of [`categories`].
#[derive(Debug, Clone)]
pub struct Categories<'a> {
    image: &'a [u8],
    at: usize,
}

impl<'a> Iterator for Categories<'a> {
    type Item = Category<&'a [u8]>;

    fn next(&mut self) -> Option<Category<&'a [u8]>> {
        let c = Category::new_checked(self.image.get(self.at..)?).ok()?;
        if c.category_type() == CategoryType::End {
            self.at = self.image.len();
            return None;
        }
        self.at += c.total_len();
        Some(c)
    }
}

/// String `index` (from 1) of a STRINGS category's data.
pub fn string(data: &[u8], index: u8) -> Option<&[u8]> {
    let count = *data.first()?;
    if index == 0 || index > count {
        return None;
    }
    let mut at = 1;
    for _ in 1..index {
        at += 1 + usize::from(*data.get(at)?);
    }
    let len = usize::from(*data.get(at)?);
    data.get(at + 1..at + 1 + len)
}

/// The GENERAL category (ETG.2010, "General"); 32 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct General {
    /// String index of the group.
    pub group: u8,
    /// String index of the image name.
    pub image: u8,
    /// String index of the order number.
    pub order: u8,
    /// String index of the device name.
    pub name: u8,
    /// CoE details (bit 0 SDO, 1 SDO info, 2 PDO assign, 3 PDO configuration, 4 upload at start-up, 5 SDO
    /// complete access).
    pub coe_details: u8,
    /// FoE details (bit 0: FoE supported).
    pub foe_details: u8,
    /// EoE details (bit 0: EoE supported).
    pub eoe_details: u8,
    /// SoE channels.
    pub soe_channels: u8,
    /// DS402 channels.
    pub ds402_channels: u8,
    /// Sysman class.
    pub sysman_class: u8,
    /// Flags (bit 0 enable SafeOp, 1 enable notLRW, 2 mailbox data link layer, 3 identity AL status code,
    /// 4 identity physical memory).
    pub flags: u8,
    /// Current drawn from the E-bus in mA (negative: fed into it).
    pub ebus_current: i16,
    /// Physical ports 0..3, a nibble each (0 not used, 1 MII, 2 reserved, 3 EBUS, 4 fast hot connect).
    pub physical_port: u16,
    /// Physical memory address of the identification.
    pub physical_memory_address: u16,
}

impl General {
    /// Length of the category data.
    pub const LEN: usize = 32;

    /// Reads the category data.
    pub fn parse(data: &[u8]) -> Result<General, Error> {
        if data.len() < Self::LEN {
            return Err(Error::Truncated);
        }
        Ok(General {
            group: data[0],
            image: data[1],
            order: data[2],
            name: data[3],
            coe_details: data[5],
            foe_details: data[6],
            eoe_details: data[7],
            soe_channels: data[8],
            ds402_channels: data[9],
            sysman_class: data[10],
            flags: data[11],
            ebus_current: le::u16(data, 12) as i16,
            physical_port: le::u16(data, 16),
            physical_memory_address: le::u16(data, 18),
        })
    }

    /// Writes the category data into the first [`General::LEN`] bytes of `out` (reserved bytes 0;
    /// byte 14 repeats the group index, as the layout asks).
    ///
    /// # Panics
    ///
    /// If `out` is shorter than [`General::LEN`].
    pub fn emit(&self, out: &mut [u8]) {
        out[..Self::LEN].fill(0);
        out[..4].copy_from_slice(&[self.group, self.image, self.order, self.name]);
        out[5..12].copy_from_slice(&[
            self.coe_details,
            self.foe_details,
            self.eoe_details,
            self.soe_channels,
            self.ds402_channels,
            self.sysman_class,
            self.flags,
        ]);
        le::set_u16(out, 12, self.ebus_current as u16);
        out[14] = self.group;
        le::set_u16(out, 16, self.physical_port);
        le::set_u16(out, 18, self.physical_memory_address);
    }
}

/// The usage a SYNCM entry gives a SyncManager.
pub mod sm_type {
    /// Not used or unknown.
    pub const UNUSED: u8 = 0;
    /// Mailbox out (master → slave).
    pub const MAILBOX_OUT: u8 = 1;
    /// Mailbox in (slave → master).
    pub const MAILBOX_IN: u8 = 2;
    /// Process data outputs (master → slave).
    pub const OUTPUTS: u8 = 3;
    /// Process data inputs (slave → master).
    pub const INPUTS: u8 = 4;
}

/// The usage an FMMU entry gives an FMMU.
pub mod fmmu_usage {
    /// Not used.
    pub const UNUSED: u8 = 0;
    /// Outputs.
    pub const OUTPUTS: u8 = 1;
    /// Inputs.
    pub const INPUTS: u8 = 2;
    /// SyncManager status (mailbox state).
    pub const SM_STATUS: u8 = 3;
}

/// One entry of the SYNCM category (ETG.2010, "SyncM"); 8 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SyncManager {
    /// Physical start address.
    pub start: u16,
    /// Length in bytes.
    pub length: u16,
    /// Control register value (→ SM byte 4).
    pub control: u8,
    /// Status register (not used by masters).
    pub status: u8,
    /// Enable (bit 0 → SM activate bit 0).
    pub enable: u8,
    /// Usage, see [`sm_type`].
    pub sm_type: u8,
}

impl SyncManager {
    /// Length of one entry.
    pub const LEN: usize = 8;

    /// Reads one entry.
    pub fn parse(data: &[u8]) -> Result<SyncManager, Error> {
        if data.len() < Self::LEN {
            return Err(Error::Truncated);
        }
        Ok(SyncManager {
            start: le::u16(data, 0),
            length: le::u16(data, 2),
            control: data[4],
            status: data[5],
            enable: data[6],
            sm_type: data[7],
        })
    }

    /// Writes one entry into the first [`SyncManager::LEN`] bytes of `out`.
    ///
    /// # Panics
    ///
    /// If `out` is shorter than [`SyncManager::LEN`].
    pub fn emit(&self, out: &mut [u8]) {
        le::set_u16(out, 0, self.start);
        le::set_u16(out, 2, self.length);
        out[4..8].copy_from_slice(&[self.control, self.status, self.enable, self.sm_type]);
    }
}

/// The head of one PDO in a TXPDO or RXPDO category (ETG.2010, "TXPDO and RXPDO"); 8 bytes, followed by
/// its entries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pdo {
    /// Object index of the PDO (0x1600.. outputs, 0x1A00.. inputs).
    pub index: u16,
    /// Number of entries that follow.
    pub entries: u8,
    /// The SyncManager it belongs to.
    pub sync_manager: u8,
    /// Synchronization.
    pub dc_sync: u8,
    /// String index of its name.
    pub name: u8,
    /// Flags (bit 0 mandatory, 1 default, 4 fixed content).
    pub flags: u16,
}

impl Pdo {
    /// Length of the head.
    pub const LEN: usize = 8;

    /// Reads the head.
    pub fn parse(data: &[u8]) -> Result<Pdo, Error> {
        if data.len() < Self::LEN {
            return Err(Error::Truncated);
        }
        Ok(Pdo {
            index: le::u16(data, 0),
            entries: data[2],
            sync_manager: data[3],
            dc_sync: data[4],
            name: data[5],
            flags: le::u16(data, 6),
        })
    }

    /// Writes the head into the first [`Pdo::LEN`] bytes of `out`.
    ///
    /// # Panics
    ///
    /// If `out` is shorter than [`Pdo::LEN`].
    pub fn emit(&self, out: &mut [u8]) {
        le::set_u16(out, 0, self.index);
        out[2..6].copy_from_slice(&[self.entries, self.sync_manager, self.dc_sync, self.name]);
        le::set_u16(out, 6, self.flags);
    }
}

/// One entry of a PDO; 8 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PdoEntry {
    /// Object index.
    pub index: u16,
    /// Object subindex.
    pub subindex: u8,
    /// String index of its name.
    pub name: u8,
    /// Data type (CoE numbering: 0x0004 INTEGER32, 0x0007 UNSIGNED32, …).
    pub data_type: u8,
    /// Length in bits.
    pub bit_length: u8,
    /// Flags.
    pub flags: u16,
}

impl PdoEntry {
    /// Length of one entry.
    pub const LEN: usize = 8;

    /// Reads one entry.
    pub fn parse(data: &[u8]) -> Result<PdoEntry, Error> {
        if data.len() < Self::LEN {
            return Err(Error::Truncated);
        }
        Ok(PdoEntry {
            index: le::u16(data, 0),
            subindex: data[2],
            name: data[3],
            data_type: data[4],
            bit_length: data[5],
            flags: le::u16(data, 6),
        })
    }

    /// Writes one entry into the first [`PdoEntry::LEN`] bytes of `out`.
    ///
    /// # Panics
    ///
    /// If `out` is shorter than [`PdoEntry::LEN`].
    pub fn emit(&self, out: &mut [u8]) {
        le::set_u16(out, 0, self.index);
        out[2..6].copy_from_slice(&[self.subindex, self.name, self.data_type, self.bit_length]);
        le::set_u16(out, 6, self.flags);
    }
}

/// The checksum of the ESC configuration area: CRC-8 with polynomial x⁸ + x² + x + 1 (0x07), start value
/// 0xFF, over the 14 bytes of words 0..7 (ETG.2010, "Checksum").
pub fn crc8(bytes: &[u8]) -> u8 {
    let mut crc = 0xFFu8;
    for b in bytes {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 { (crc << 1) ^ 0x07 } else { crc << 1 };
        }
    }
    crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_against_the_crc_crate() {
        // The same algorithm (width 8, poly 0x07, init 0xFF, no reflection, no final xor) from the `crc`
        // crate, the one ethercrab checks the configuration area with.
        const ALGORITHM: crc::Algorithm<u8> = crc::Algorithm {
            width: 8,
            poly: 0x07,
            init: 0xff,
            refin: false,
            refout: false,
            xorout: 0x00,
            check: 0xfb,
            residue: 0x00,
        };
        let reference = crc::Crc::<u8>::new(&ALGORITHM);
        assert_eq!(crc8(b"123456789"), 0xFB);
        assert_eq!(reference.checksum(b"123456789"), 0xFB);
        for seed in 0u8..=255 {
            let bytes: [u8; 14] = core::array::from_fn(|i| seed.wrapping_mul(31).wrapping_add(i as u8 * 7));
            assert_eq!(crc8(&bytes), reference.checksum(&bytes));
        }
    }

    #[test]
    fn categories_and_strings() {
        // Word 0x40: STRINGS with two strings ("ab", "c"), then the end marker.
        let mut image = [0xFFu8; 0x80 + 16];
        image[0x80..0x80 + 12].copy_from_slice(&[10, 0, 4, 0, 2, 2, b'a', b'b', 1, b'c', 0, 0]);
        let mut it = categories(&image);
        let c = it.next().unwrap();
        assert_eq!((c.category_type(), c.word_length()), (CategoryType::Strings, 4));
        assert_eq!(string(c.data(), 1), Some(&b"ab"[..]));
        assert_eq!(string(c.data(), 2), Some(&b"c"[..]));
        assert_eq!(string(c.data(), 3), None);
        assert_eq!(string(c.data(), 0), None);
        assert!(it.next().is_none());
    }

    #[test]
    fn entries_round_trip() {
        let g = General { name: 1, foe_details: 1, physical_port: 0x0011, ebus_current: -5, ..General::default() };
        let mut out = [0u8; 32];
        g.emit(&mut out);
        assert_eq!(General::parse(&out), Ok(g));
        let sm = SyncManager { start: 0x1000, length: 268, control: 0x26, status: 0, enable: 1, sm_type: 1 };
        sm.emit(&mut out);
        assert_eq!(out[..8], [0x00, 0x10, 0x0c, 0x01, 0x26, 0, 1, 1]);
        assert_eq!(SyncManager::parse(&out), Ok(sm));
        let p = Pdo { index: 0x1a00, entries: 12, sync_manager: 3, dc_sync: 0, name: 5, flags: 0x10 };
        p.emit(&mut out);
        assert_eq!(Pdo::parse(&out), Ok(p));
        let e = PdoEntry { index: 0x6000, subindex: 1, name: 7, data_type: 4, bit_length: 32, flags: 0 };
        e.emit(&mut out);
        assert_eq!(PdoEntry::parse(&out), Ok(e));
    }

    #[test]
    fn broken_lists_stop() {
        let mut image = [0u8; 0x80 + 4];
        image[0x80..].copy_from_slice(&[41, 0, 9, 0]); // 9 words declared, none there
        assert!(categories(&image).next().is_none());
        assert!(categories(&image[..10]).next().is_none());
    }
}

//! The ESC register addresses a master uses (Beckhoff ET1100 datasheet, section II "Register
//! description"; ETG.1000.4 "DL information", "DL control", "AL control and status", "SII", "FMMU",
//! "SyncManager"). Register space 0x0000–0x0FFF, process RAM from 0x1000.

/// ESC type (0x11: ET1100).
pub const TYPE: u16 = 0x0000;
/// ESC revision.
pub const REVISION: u16 = 0x0001;
/// ESC build (2 bytes).
pub const BUILD: u16 = 0x0002;
/// Number of FMMUs.
pub const FMMU_COUNT: u16 = 0x0004;
/// Number of SyncManagers.
pub const SM_COUNT: u16 = 0x0005;
/// Process RAM in KiB.
pub const RAM_SIZE: u16 = 0x0006;
/// Port descriptor: 2 bits per port (0 not implemented, 1 not configured, 2 EBUS, 3 MII).
pub const PORT_DESCRIPTOR: u16 = 0x0007;
/// ESC features supported (2 bytes; bit 0 byte-oriented FMMU, 2 DC, 9 LRW not supported, 10 RW
/// commands not supported).
pub const FEATURES: u16 = 0x0008;
/// Configured station address (2 bytes).
pub const STATION_ADDRESS: u16 = 0x0010;
/// Configured station alias (2 bytes; loaded from SII word 4).
pub const STATION_ALIAS: u16 = 0x0012;
/// DL control (4 bytes; 0x0103 bit 0 = station alias enabled for configured addressing).
pub const DL_CONTROL: u16 = 0x0100;
/// DL status (2 bytes).
pub const DL_STATUS: u16 = 0x0110;
/// AL control (2 bytes; bits 0..4 requested state, 4 error acknowledge, 5 device identification).
pub const AL_CONTROL: u16 = 0x0120;
/// AL status (2 bytes; bits 0..4 state, 4 error indication, 5 device identification loaded).
pub const AL_STATUS: u16 = 0x0130;
/// AL status code (2 bytes).
pub const AL_STATUS_CODE: u16 = 0x0134;
/// PDI control (1 byte; loaded from SII word 0).
pub const PDI_CONTROL: u16 = 0x0140;
/// ESC configuration (1 byte; loaded from SII word 0).
pub const ESC_CONFIGURATION: u16 = 0x0141;
/// PDI configuration (2 bytes; loaded from SII word 1).
pub const PDI_CONFIGURATION: u16 = 0x0150;
/// ECAT event mask (2 bytes).
pub const ECAT_EVENT_MASK: u16 = 0x0200;
/// ECAT event request (2 bytes).
pub const ECAT_EVENT_REQUEST: u16 = 0x0210;
/// Error counters (0x0300–0x0313; a write clears them).
pub const ERROR_COUNTERS: u16 = 0x0300;
/// Watchdog divider (2 bytes; (value + 2) × 40 ns is the watchdog tick).
pub const WATCHDOG_DIVIDER: u16 = 0x0400;
/// Watchdog time PDI (2 bytes).
pub const WATCHDOG_TIME_PDI: u16 = 0x0410;
/// Watchdog time process data (2 bytes, in watchdog ticks; 0 = off).
pub const WATCHDOG_TIME_PD: u16 = 0x0420;
/// Watchdog status process data (bit 0: 1 = not expired).
pub const WATCHDOG_STATUS: u16 = 0x0440;
/// Watchdog counter process data (expirations).
pub const WATCHDOG_COUNTER_PD: u16 = 0x0442;
/// SII EEPROM configuration (bit 0 EEPROM offered to the PDI, 1 force ECAT access).
pub const SII_CONFIGURATION: u16 = 0x0500;
/// SII EEPROM PDI access state (bit 0: the PDI holds the EEPROM).
pub const SII_PDI_ACCESS: u16 = 0x0501;
/// SII control/status (2 bytes; bit 0 write enable, 6 reads 8 bytes, 7 two address bytes, 8..11
/// command, 11 checksum error, 12 device info error, 13 command error, 14 write error, 15 busy).
pub const SII_CONTROL: u16 = 0x0502;
/// SII word address (4 bytes).
pub const SII_ADDRESS: u16 = 0x0504;
/// SII data (8 bytes read, 2 bytes written).
pub const SII_DATA: u16 = 0x0508;
/// FMMU 0; FMMU n at `FMMU + 16 n`.
pub const FMMU: u16 = 0x0600;
/// Length of one FMMU's registers.
pub const FMMU_LEN: u16 = 16;
/// SyncManager 0; SyncManager n at `SM + 8 n`.
pub const SM: u16 = 0x0800;
/// Length of one SyncManager's registers.
pub const SM_LEN: u16 = 8;
/// First DC register.
pub const DC_START: u16 = 0x0900;
/// Last DC register.
pub const DC_END: u16 = 0x09FF;
/// DC cyclic unit control (1 byte).
pub const DC_CYCLIC_CONTROL: u16 = 0x0980;
/// DC SYNC activation (1 byte; bit 0 cyclic operation, 1 SYNC0, 2 SYNC1).
pub const DC_SYNC_ACTIVATION: u16 = 0x0981;
/// User RAM (0x0F80–0x0FFF).
pub const USER_RAM: u16 = 0x0F80;
/// First byte of the process RAM.
pub const PROCESS_RAM: u16 = 0x1000;

/// Offsets inside one FMMU's 16 bytes.
pub mod fmmu {
    /// Logical start address (4 bytes).
    pub const LOGICAL_START: u16 = 0;
    /// Length in bytes (2 bytes).
    pub const LENGTH: u16 = 4;
    /// Logical start bit.
    pub const LOGICAL_START_BIT: u16 = 6;
    /// Logical stop bit.
    pub const LOGICAL_STOP_BIT: u16 = 7;
    /// Physical start address (2 bytes).
    pub const PHYSICAL_START: u16 = 8;
    /// Physical start bit.
    pub const PHYSICAL_START_BIT: u16 = 10;
    /// Type: bit 0 read, bit 1 write.
    pub const TYPE: u16 = 11;
    /// Activate: bit 0.
    pub const ACTIVATE: u16 = 12;
}

/// Offsets inside one SyncManager's 8 bytes.
pub mod sm {
    /// Physical start address (2 bytes).
    pub const START: u16 = 0;
    /// Length (2 bytes).
    pub const LENGTH: u16 = 2;
    /// Control: bits 0..2 mode (0 buffered, 2 mailbox), 2..4 direction (0 ECAT reads, 1 ECAT writes),
    /// 4 ECAT event, 5 AL event, 6 watchdog trigger.
    pub const CONTROL: u16 = 4;
    /// Status: bit 0 write event, 1 read event, 3 mailbox full, 4..6 last buffer written (buffered).
    pub const STATUS: u16 = 5;
    /// Activate: bit 0 enable, 1 repeat request, 6 latch ECAT event, 7 latch PDI event.
    pub const ACTIVATE: u16 = 6;
    /// PDI control: bit 0 deactivated by the PDI, 1 repeat acknowledge.
    pub const PDI_CONTROL: u16 = 7;
}

//! The SyncManager and FMMU configurations as a master writes them into the registers.

/// A SyncManager's mode (control bits 0..2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SmMode {
    /// Buffered, 3 buffers (process data).
    Buffered,
    /// Mailbox, 1 buffer with a full/empty handshake.
    Mailbox,
    /// A reserved value.
    Reserved(u8),
}

/// Who writes a SyncManager's buffer (control bits 2..4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SmDirection {
    /// The master reads, the application writes (inputs, the reply mailbox).
    MasterReads,
    /// The master writes, the application reads (outputs, the request mailbox).
    MasterWrites,
    /// A reserved value.
    Reserved(u8),
}

/// One SyncManager's configuration as the master wrote it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SmConfig {
    /// Physical start address.
    pub start: u16,
    /// Length in bytes.
    pub length: u16,
    /// Control register.
    pub control: u8,
    /// Activate register.
    pub activate: u8,
}

impl SmConfig {
    /// The mode.
    pub const fn mode(&self) -> SmMode {
        match self.control & 0x03 {
            0 => SmMode::Buffered,
            2 => SmMode::Mailbox,
            other => SmMode::Reserved(other),
        }
    }

    /// The direction.
    pub const fn direction(&self) -> SmDirection {
        match (self.control >> 2) & 0x03 {
            0 => SmDirection::MasterReads,
            1 => SmDirection::MasterWrites,
            other => SmDirection::Reserved(other),
        }
    }

    /// The master enabled it (activate bit 0).
    pub const fn enabled(&self) -> bool {
        self.activate & 0x01 != 0
    }

    /// A write completes the watchdog (control bit 6).
    pub const fn watchdog_trigger(&self) -> bool {
        self.control & 0x40 != 0
    }

    /// First address past its buffer.
    pub const fn end(&self) -> u32 {
        self.start as u32 + self.length as u32
    }

    /// The bytes the SyncManager occupies in RAM: one buffer in mailbox mode, three in buffered mode.
    pub const fn footprint(&self) -> u32 {
        match self.mode() {
            SmMode::Buffered => 3 * self.length as u32,
            _ => self.length as u32,
        }
    }
}

/// One FMMU's configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FmmuConfig {
    /// Logical start address.
    pub logical_start: u32,
    /// Length in bytes.
    pub length: u16,
    /// Physical start address.
    pub physical_start: u16,
    /// Maps reads (type bit 0).
    pub read: bool,
    /// Maps writes (type bit 1).
    pub write: bool,
    /// Activated.
    pub active: bool,
}

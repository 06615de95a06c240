//! Where the virtual TMCM-1310 keeps its buffers in the ESC's RAM (who it says it is, and what its
//! process data hold, is the model's `EtherCatDesc`).
//!
//! The manual gives two sets of addresses that cannot both be ESC addresses (§3.3 and §3.4 overlap; see
//! `docs/ethercat.md` and `docs/decisions.md`, "EtherCAT"):
//!
//! - §3.3 "the two mailboxes": output buffer at 4096 (0x1000), 268 bytes; input buffer at 4364
//!   (0x110C), 40 bytes. The two are contiguous and 268 = 6 (mailbox header) + 6 (FoE header) + 256
//!   (data): the sizes of a firmware-update mailbox. **Kept as they are**, for the TMCL mailbox and the
//!   bootstrap mailbox alike.
//! - §3.4 process data: outputs "0x1000, first 8 bytes", inputs "0x1078, first 44 bytes". These collide
//!   with the mailboxes (and the input table itself jumps from 0x109F to 0x1100), so they are read as the
//!   layout of the process image, not as ESC addresses. The process-data SyncManagers get their own
//!   places, each in a 0x100 block as in the manual's Figure 3.1 (three buffers of one length there):
//!   **outputs at 0x1200, inputs at 0x1300**.

use crate::pdo::OUTPUTS_LEN;
use tmcl_core::model::EtherCatDesc;

/// One SyncManager as the slave expects it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SmLayout {
    /// The SyncManager's number.
    pub index: usize,
    /// Physical start address.
    pub start: u16,
    /// Length in bytes.
    pub length: u16,
    /// Control register value: mode, direction, event bits, watchdog trigger.
    pub control: u8,
    /// SII usage (see [`crate::wire::sii::sm_type`]).
    pub sm_type: u8,
}

/// SM0, the mailbox the master writes: TMCL requests, FoE in BOOT (manual §3.3: 4096, 268 bytes).
/// Control 0x26: mailbox mode, ECAT writes, AL event.
pub const MAILBOX_OUT: SmLayout = SmLayout { index: 0, start: 0x1000, length: 268, control: 0x26, sm_type: 1 };

/// SM1, the mailbox the master reads: TMCL replies (manual §3.3: 4364, 40 bytes). Control 0x22: mailbox
/// mode, ECAT reads, AL event.
pub const MAILBOX_IN: SmLayout = SmLayout { index: 1, start: 0x110C, length: 40, control: 0x22, sm_type: 2 };

/// SM2, the process-data outputs (controller mode and value, manual §3.4). Control 0x64: buffered, ECAT
/// writes, AL event, watchdog trigger.
pub const OUTPUTS: SmLayout =
    SmLayout { index: 2, start: 0x1200, length: OUTPUTS_LEN as u16, control: 0x64, sm_type: 3 };

/// SM3, the process-data inputs of `map` (the twelve fields of manual §3.4 on the TMCM-1310, 48 bytes).
/// Control 0x20: buffered, ECAT reads, AL event.
pub const fn inputs(map: &EtherCatDesc) -> SmLayout {
    SmLayout { index: 3, start: 0x1300, length: map.inputs_len() as u16, control: 0x20, sm_type: 4 }
}

/// The four SyncManagers of a slave with process-data map `map`, in order.
pub const fn sync_managers(map: &EtherCatDesc) -> [SmLayout; 4] {
    [MAILBOX_OUT, MAILBOX_IN, OUTPUTS, inputs(map)]
}

/// Logical bytes of one FoE data packet: the request mailbox less the mailbox and FoE headers.
pub const FOE_DATA: usize = MAILBOX_OUT.length as usize - 12;

//! The EtherCAT slave of the virtual TMCM-1310 (TMCM-1310 TMCL firmware manual V1.14, chapter 3): a
//! `no_std`, heap-free emulation of what a master sees on the wire: an ESC with its registers, an SII
//! EEPROM, SyncManagers, FMMUs and the AL state machine, and behind it the TMCL firmware of
//! `tmcl-core`, reached through a raw 8-byte TMCL mailbox and cyclic process data.
//!
//! The layers, from the bytes up:
//!
//! - [`wire`]: views and reprs of the formats: Ethernet, the EtherCAT frame, datagrams, the mailbox
//!   header, FoE, the SII EEPROM. They know nothing else.
//! - [`register`]: the register map. [`esc`]: the controller's memory: registers with their write
//!   permissions, process RAM guarded by SyncManagers (mailbox and 3-buffer modes), FMMUs for logical
//!   addressing, every datagram command with its working counter.
//! - [`eeprom`]: the SII image, generated from the model, and the EEPROM interface.
//! - [`al`]: the AL states and status codes, and the one transition `match`.
//! - [`layout`] and [`pdo`]: where the buffers are and what the process data hold (manual §3.3–3.4, with
//!   the decisions its contradictions forced).
//! - [`foe`]: FoE in BOOT, to a [`foe::FileStore`].
//! - [`esi`]: the ESI file (EtherCAT Slave Information XML) from the same description as the SII.
//! - [`slave`]: [`Slave`], which ties it together around a [`tmcl_core::Module`]: `process` one frame,
//!   `poll` for time.
//! - `fuzzing` (feature `harness`, for tests and the fuzz targets only): harnesses shared by the fuzz
//!   targets and the property tests.
//!
//! # Contracts
//!
//! No panic on any input: a frame that is not EtherCAT, or whose datagrams do not fit, is refused whole
//! before anything changes; every datagram of a sound frame is executed, whatever it addresses. Time is
//! passed in; nothing reads a clock, allocates or touches the OS. `docs/ethercat.md` describes the slave
//! as a master sees it and how to test it with real masters.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod al;
pub mod eeprom;
pub mod esc;
pub mod esi;
pub mod foe;
/// Test harness (feature `harness`): the fuzz targets' bodies and a slave brought up for tests.
#[cfg(any(test, feature = "harness"))]
pub mod fuzzing;
pub mod layout;
pub mod pdo;
pub mod register;
pub mod slave;
pub mod wire;

pub use al::{AlState, AlStatus, AlStatusCode};
pub use eeprom::{Volatile, SII_STORE_LEN};
pub use foe::{FileStore, NoFiles};
pub use slave::{NoEtherCat, Slave, StoreError};

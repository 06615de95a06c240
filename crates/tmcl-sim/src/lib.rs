//! The simulated board behind the OpenTMCL core: everything `tmcl run` and `tmcl serve` need to run the firmware
//! on a PC.
//!
//! - [`nvm`]: the EEPROM, in memory ([`MemNvm`]) or in a crash-safe file ([`FileNvm`]).
//! - [`board`]: [`SimBoard`], the board the firmware core runs on, and its [`World`].

pub mod board;
pub mod fuzzing;
pub mod nvm;

pub use board::{Eeprom, SimBoard, World};
pub use nvm::{FileNvm, MemNvm, NvmError, Options};

//! The simulated board behind the OpenTMCL core: everything `tmcl run` and `tmcl serve` need to run the firmware
//! on a PC.
//!
//! - [`nvm`]: the EEPROM, in memory ([`MemNvm`]) or in a crash-safe file ([`FileNvm`]).
//! - [`board`]: [`SimBoard`], the board the firmware core runs on, and its world changed at run time
//!   ([`Change`]).
//! - [`profile`]: what the board takes from the model ([`Profile`]: encoder, driver, inputs, outputs).
//! - [`world`]: the [`World`] around the motor, from a TOML world file (`docs/world.md`).
//! - [`motor`]: the stepper and its load (load angle, lost steps, freewheeling).
//! - [`driver`]: the TMC262 as the firmware sees it (current, stallGuard2, flags, energy).
//! - [`hook`]: the simulator's shortcuts behind the firmware's hook ([`tmcl_core::hal::Hook`]): a
//!   debugger's [`Breakpoints`] and the [`LoopSkip`], which jumps a program spinning in a fixed point
//!   over whole turns of its loop.
//! - `equivalence` and `fuzzing` (feature `harness`, for tests and the fuzz targets only): event-driven runs
//!   against tick-by-tick ones, and the bodies of the fuzz targets.

pub mod board;
pub mod driver;
/// Test harness (feature `harness`): event-driven runs against tick-by-tick ones.
#[cfg(any(test, feature = "harness"))]
pub mod equivalence;
/// Test harness (feature `harness`): the fuzz targets' bodies.
#[cfg(any(test, feature = "harness"))]
pub mod fuzzing;
pub mod hook;
pub mod motor;
pub mod nvm;
pub mod profile;
pub mod world;
mod world_file;

pub use board::{Change, Eeprom, Feedback, SimBoard, SwitchId};
pub use hook::{Breakpoints, LoopSkip};
pub use nvm::{FileNvm, MemNvm, NvmError, Options};
pub use profile::Profile;
pub use world::{World, WorldError};

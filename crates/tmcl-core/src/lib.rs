//! The OpenTMCL firmware core: a TMCL module's firmware as a `no_std`, heap-free library.
//!
//! It takes bytes and time and returns bytes and its next deadline; it never reads a clock. The layers:
//!
//! - [`time`]: `Instant`/`Duration` in µs, passed in by the caller.
//! - [`hal`]: the board traits, one per capability (EEPROM, inputs, outputs, analog, switches, step
//!   driver, load measurement, encoder), and the hook a simulator may fill in ([`hal::Hook`]: its
//!   defaults do nothing; the firmware knows none of a simulator's shortcuts).
//! - [`model`]: each product's description as data, from `tmcl-model` (parameters with their meaning,
//!   ports, interrupt sources, interfaces, command set, units, driver), checked against this core's
//!   capacities when it compiles. The core asks a model for a setting or a role, never for a parameter
//!   number, and a model without one lacks the feature (see [`module`]).
//! - [`param`]: the parameter tables' types and the EEPROM image ([`param::persist`]).
//! - [`motion`]: the ramp generator and the reference search.
//! - [`drive`]: coolStep, stop on stall, the encoder checks, the closed loop and the emulated TMC428, as
//!   pure functions and state of their own.
//! - [`iface`]: per host interface a framer, an outbox and an ASCII line.
//! - [`axis`]: one motor's state ([`axis::Axis`]: parameters, ramp, reference search, coolStep, encoder,
//!   closed loop), one per motor of the model ([`axis::Axes`]), and what a motor does with the board it
//!   drives: its motion tick, its drive, its closed loop and the parameters that read them (`Motor`,
//!   `axis/motor.rs`), returning what it did beyond itself (`Faults`) to the module.
//! - [`vm`]: the program machine's state: program memory, registers, run state, stack, interrupts.
//! - [`module`]: [`Module`], the root that ties the components together and the only part that knows
//!   all of them: bytes in and replies out (`module/host.rs`, `module/ascii.rs`), the dispatcher
//!   (`module/exec.rs`), the program's steps (`module/program.rs`) and time (`module/advance.rs`).
//!   Nothing below `module` imports it.
//! - the one seam between the firmware and the board, which counts every change (`seam.rs`).
//!
//! Specification: PD28-1021 TMCL firmware manual V1.05 (firmware V1.42). Where the manual is silent or
//! contradicts itself, the code says so beside the decision, citing the manual's section, and
//! `docs/decisions.md` collects these decisions.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]

pub mod axis;
pub mod drive;
pub mod hal;
pub mod iface;
pub mod model;
pub mod module;
pub mod motion;
pub mod param;
mod seam;
pub mod time;
pub mod vm;

pub use module::{Module, Origin, Outcome, Registers, State};
pub use time::{Duration, Instant};

#[cfg(test)]
mod tests;

//! Drive features the firmware computes from driver and encoder readings: pure, integer-only functions
//! the module calls, independent of any board.
//!
//! - [`coolstep`]: the TMC262 coolStep current regulator (manual §1.2, §7.3, Table 22; AP 168–172, 180,
//!   182, 183).
//! - [`stall`]: stop on stall (manual §7.2; AP 181, 206, 207).
//! - [`encoder`]: the sensOstep deviation check and clear-on-null (manual §6.2; AP 209, 210, 212).
//! - [`closed_loop`]: position control from an encoder, current scaling, torque mode and I²t (TMCM-1310
//!   manual chapter 1, §3.4; the TMCM-1311 sibling's parameters).
//! - [`tmc428`]: SAC's SPI pass-through to an emulated TMC428/429 motion controller (PDx-113 manual
//!   §5.4.3, the TMC428 datasheet).
//!
//! The AP 207 bits they lead to are [`crate::module::error_flags`]; `wiring` calls them from the
//! module's motion tick.

pub mod closed_loop;
mod closed_loop_wiring;
pub mod coolstep;
pub mod encoder;
pub mod stall;
pub mod tmc428;
mod wiring;

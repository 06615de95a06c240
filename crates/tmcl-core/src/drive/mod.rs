//! Drive features the firmware computes from driver and encoder readings: pure, integer-only functions
//! the module calls, independent of any board.
//!
//! - [`coolstep`]: the TMC262 coolStep current regulator (manual §1.2, §7.3, Table 22; AP 168–172, 180,
//!   182, 183).
//! - [`stall`]: stop on stall (manual §7.2; AP 181, 206, 207).
//! - [`encoder`]: the sensOstep deviation check and clear-on-null (manual §6.2; AP 209, 210, 212).
//!
//! The AP 207 bits they lead to are [`crate::module::error_flags`]. None of them is wired into the
//! module yet; each module doc says what the caller passes and when.

pub mod coolstep;
pub mod encoder;
pub mod stall;
mod wiring;

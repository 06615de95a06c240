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
//! The AP 207 bits they lead to are [`error_flags`]; a motor calls them from its
//! motion tick (`axis/drive.rs`, `axis/closed_loop.rs`, `module/sac.rs`). Nothing here knows the module.

pub mod closed_loop;
pub mod coolstep;
pub mod encoder;
pub mod stall;
pub mod tmc428;

/// AP 207 bits (Table 15): 1 = stallGuard error, 2 = deviation error.
pub mod error_flags {
    /// stallGuard2 stopped the motor.
    pub const STALL: u8 = 1;
    /// The encoder deviation check stopped the motor.
    pub const DEVIATION: u8 = 2;
}

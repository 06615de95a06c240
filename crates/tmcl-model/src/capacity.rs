//! The firmware core's capacities: the sizes of its RAM tables, fixed at compile time (no heap). Every
//! model is checked against them when it is built ([`crate::ModelSpec::new`]), and the core sizes its
//! arrays with the same constants, so a model that does not fit fails to compile instead of panicking
//! or overlapping memory at start-up.

/// Motors (axes) the core drives: a model has 1 to this many (the TMCM-6110 family has six).
pub const MAX_MOTORS: u8 = 6;
/// Axis parameter slots per motor (the PD28-1021 has 58, the TMCM-1310 97).
pub const MAX_AXIS_PARAMS: usize = 112;
/// Bank 0 slots (19 on the PD28-1021).
pub const MAX_GLOBAL_PARAMS: usize = 32;
/// Bank 3 slots (9 on the PD28-1021, 23 on the TMCM-6110: timers, two switches per axis, eight inputs).
pub const MAX_INTERRUPT_PARAMS: usize = 24;
/// User variables in bank 2 (the type byte addresses 0..=255).
pub const MAX_USER_VARIABLES: usize = 256;
/// Coordinates per axis, coordinate 0 included (20 + 1 on the PD28-1021).
pub const MAX_COORDINATES: usize = 21;
/// Program memory, in commands.
pub const MAX_PROGRAM: usize = 2048;
/// Interrupt numbers are below this (they are bits of a 64-bit mask).
pub const MAX_VECTORS: usize = 64;
/// Interrupt timers.
pub const MAX_TIMERS: usize = 3;
/// Host interfaces of one module.
pub const MAX_INTERFACES: usize = 2;
/// Digital inputs (bits of the board's input byte).
pub const MAX_INPUTS: u8 = 8;
/// Digital outputs (bits of the board's output byte).
pub const MAX_OUTPUTS: u8 = 8;

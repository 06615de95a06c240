//! Motion: the ramp generator (trapezoidal position ramps, velocity mode) in integer arithmetic.

pub mod ramp;

pub use ramp::{Limits, Mode, Ramp, RampParams, TickResult, TICK};

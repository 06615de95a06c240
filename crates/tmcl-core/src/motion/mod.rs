//! Motion: the ramp generator (trapezoidal position ramps, velocity mode) in integer arithmetic, and the
//! reference search.

pub mod ramp;
pub mod reference;

pub use ramp::{Bounds, Limits, Mode, Ramp, RampParams, Span, TickResult, TICK};
pub use reference::{Reference, SearchMode};

//! Motion: the ramp generator (trapezoidal position ramps, velocity mode) in integer arithmetic, and the
//! reference search.

pub mod ramp;
pub mod reference;

pub use ramp::{Bounds, Limits, Mode, Ramp, RampParams, Record, Span, TickResult, Trail, TICK};
pub use reference::{Reference, SearchMode};

//! Runs standalone TMCL programs on a simulated OpenTMCL module, far faster than real time, and records
//! what happened: the library behind `tmcl run` and the Python package's `opentmcl.run`.
//!
//! - [`setup`]: the program ([`Source`]: TMCL source text or file, or a `.bin` image) and the module it
//!   runs on ([`Setup`]: model, settings, world).
//! - [`runner`]: [`run`] a program for a duration and get its [`Trace`] and [`Summary`]; or, with
//!   [`Simulation`], stream the rows into any [`Sink`] (a [`Csv`] file) and follow the progress.
//! - [`trace`]: the trace as typed columns with units ([`Column`], [`Quantity`], [`Unit`]), read from the
//!   model's parameter tables by meaning, plus the program's [`Event`]s and the inputs, outputs and
//!   switches at every change ([`Levels`]).
//! - `plot` (feature `plot`, on by default): the trace drawn as an SVG.
//!
//! Everything runs in simulated time from 0; the same program and options give byte-identical traces.
//!
//! ```
//! use tmcl_run::{run, Options, Quantity, Setup, Source};
//! use tmcl_core::Duration;
//! // PD28-1021 manual §2.4, shortened: out and back.
//! let setup = Setup::new("pd28-1021")?;
//! let source =
//!     Source::assemble("p.tmc", "MVP ABS, 0, 51200\nWAIT POS, 0, 0\nMVP ABS, 0, 0\nWAIT POS, 0, 0\nSTOP\n", setup.model)?;
//! let mut options = Options::new(Duration::from_secs(5));
//! options.every = Duration::from_millis(100);
//! let (trace, summary) = run(&source, &setup, &options)?;
//! // A row every 100 ms from 0 s to 5 s, and one at each event between them.
//! assert_eq!(trace.times.iter().filter(|&&t| t % 100_000 == 0).count(), 51);
//! let velocity = trace.position(Quantity::Velocity).unwrap();
//! assert_eq!(trace.columns()[velocity].unit.symbol(), "pps");
//! assert!(trace.events.iter().any(|e| e.event == tmcl_run::Event::Stop));
//! let mut csv = Vec::new();
//! trace.write_csv(&mut csv)?;
//! assert!(csv.starts_with(b"time_s,target_position,actual_position,velocity,"));
//! assert_eq!(summary.state, "stopped");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#[cfg(feature = "plot")]
pub mod plot;
mod record;
pub mod refusals;
pub mod runner;
pub mod setup;
pub mod trace;

pub use refusals::{Refusals, Refused};
pub use runner::{run, state_name, Options, RunError, Simulation, Summary};
pub use setup::{parse_value, poll, Setting, Setup, SetupError, Source, SourceError, USER_BANK};
pub use trace::{
    Column, Csv, Event, Header, Levels, Placement, Quantity, Row, Sink, Stamped, Tee, Trace, Unit, Values, WorldUnit,
};

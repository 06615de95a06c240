//! The debugger of TMCL standalone programs: the one behind `tmcl debug` and the workbench's program
//! editor.
//!
//! A TMCL module has no breakpoint command: a host controls its program with the commands 128–135
//! alone (PD28-1021 TMCL manual §3.7.38, Table 13: stop, run, step, reset, download, status). What the
//! two front ends share lives here once: where a breakpoint goes ([`breakpoint`]), the program's state as
//! 135 reports it ([`status`]). How the program is moved depends on what the
//! debugger can reach:
//!
//! - [`remote`]: any module, real or virtual, over a link. A run to a breakpoint is a run by single steps
//!   (130, then 135 for the PC), so it never runs past one; the caller implements [`remote::Target`]
//!   (one request, one reply) and decides when each next step goes out (the workbench lets a poll of its
//!   plots go between two steps).
//! - `session` (feature `sim`): a program on a simulated module in this process, in simulated time. It
//!   sets the core's breakpoints, so a run to one goes at full speed, lets simulated time pass through
//!   a WAIT, steps over subroutines, and reads every register and parameter; its command language is
//!   `tmcl debug`'s.

pub mod breakpoint;
pub mod remote;
#[cfg(feature = "sim")]
pub mod session;
pub mod status;

pub use status::AppStatus;

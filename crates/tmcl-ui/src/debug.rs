//! The workbench's program debugger: `tmcl_debug::remote` on the link, for real modules as for virtual
//! ones.
//!
//! TMCL has no breakpoint command, so a run that must stop at a breakpoint is a run by single steps
//! (command 130, then 135 for the program counter); the link thread lets a poll go between two steps
//! ([`Link::debug_step`]). The library's docs, and docs/decisions.md, have the reasoning and the limits.
//! Each stop is a `debug` event to every page ([`DebugEvent`]); the poll's reads of the program counter
//! are `prog` events ([`crate::link::ProgEvent`]).

use crate::link::Link;
use tmcl_debug::remote::Action;
use tmcl_host::HostError;
use tmcl_wire::{Command, Instruction, Status as ReplyStatus};

pub(crate) use crate::link::DebugEvent;

/// The name the editor's text has in diagnostics and source lines.
pub(crate) const SOURCE_NAME: &str = "program.tmc";

/// Runs an editor action and returns the state after it (the `debug` event, also sent to every page).
pub(crate) fn act(link: &mut Link, action: Action) -> Result<DebugEvent, HostError> {
    let report = link.with_debugger(|debugger, link| debugger.act(link, action))?;
    Ok(link.emit_debug(report))
}

/// After the breakpoints changed: a program running at full speed is stopped and goes on by single steps,
/// so that it stops at them.
pub(crate) fn breakpoints_changed(link: &mut Link) -> Result<(), HostError> {
    if let Some(report) = link.with_debugger(|debugger, link| debugger.breakpoints_changed(link))? {
        link.emit_debug(report);
    }
    Ok(())
}

/// Downloads `instructions` from address 0 (commands 132, each instruction answered with status 101,
/// then 133; PD28-1021 TMCL manual §3.7.38), stopping the program first. `progress` gets the count
/// stored so far.
pub(crate) fn download(
    link: &mut Link,
    instructions: &[Instruction],
    mut progress: impl FnMut(&Link, usize),
) -> Result<(), HostError> {
    link.debug.end_run();
    link.request(Command::StopApplication.encode())?;
    link.request(Command::StartDownload { address: 0 }.encode())?;
    let result = (|| {
        for (n, i) in instructions.iter().enumerate() {
            let reply = link.request(*i)?;
            if reply.status != ReplyStatus::Loaded {
                return Err(HostError::Status { status: reply.status, reply });
            }
            progress(link, n + 1);
        }
        Ok(())
    })();
    // Leave download mode even after an error, so the module executes commands again.
    let quit = link.request(Command::QuitDownload.encode());
    result.and(quit.map(drop))
}

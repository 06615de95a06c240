//! The program debugger of the workbench, for real modules as for virtual ones.
//!
//! It uses only the TMCL control commands (PD28-1021 TMCL manual §3.7.38, Table 13): 128 stop, 129 run,
//! 130 step, 131 reset, 132/133 download, and 135 for the mode, wait flag, program counter, accumulator
//! and X register; the user variables are global parameters of bank 2 (§5.3).
//!
//! **Breakpoints.** TMCL has no breakpoint command, so a run that must stop at a breakpoint is a run by
//! single steps: command 130, then 135 type 1 for the program counter, until the counter is at a
//! breakpoint or the program has stopped. The program therefore never runs past a breakpoint, on any
//! module; the price is speed: two requests per instruction, and the link thread lets a poll go between
//! two steps (measured: 17 instructions per second at 9600 baud, 61 on a pty at 200 requests/s). Without breakpoints, Start and Continue are plain 129 and the
//! program runs at full speed. Setting a breakpoint while the program runs at full speed stops it
//! (128) and goes on by single steps. docs/decisions.md has the reasoning and the limits.

use crate::link::{now_ms, Link};
use serde_json::{json, Value};
use std::collections::BTreeSet;
use tmcl_asm::Program;
use tmcl_host::HostError;
use tmcl_wire::{Command, Instruction, Status as ReplyStatus, StatusKind};

/// The name the editor's text has in diagnostics and source lines.
pub(crate) const SOURCE_NAME: &str = "program.tmc";

/// The application status of command 135 type 1: mode (0 stop, 1 run, 2 step, 3 reset; GP 128), the
/// wait flag and the program counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Status {
    pub mode: u8,
    pub waiting: bool,
    pub pc: u16,
}

impl Status {
    /// Unpacks the 135 type 1 value (mode in byte 3, wait flag in byte 2, PC in bytes 1..0).
    pub(crate) fn from_packed(value: i32) -> Status {
        Status { mode: (value >> 24) as u8, waiting: (value >> 16) & 0xFF != 0, pc: value as u16 }
    }

    fn mode_name(&self) -> &'static str {
        tmcl_host::ApplicationStatus::name_of(self.mode)
    }
}

/// Whether the module's 135 answers its state alone, whatever the type (the PDx-113, its manual §5.5):
/// then the program counter is GP 130 and there is no accumulator or X register to read.
pub(crate) fn plain_status(link: &Link) -> bool {
    link.model.is_some_and(|m| m.app_status == tmcl_model::AppStatusReply::Plain)
}

/// A run by single steps towards the next breakpoint.
#[derive(Debug, Clone, Copy)]
struct Continuing {
    /// Stop before the first step if the PC is at a breakpoint already (Start does, Continue does not).
    check_first: bool,
    steps: u64,
}

/// The debugger's state: the program downloaded, its breakpoints, and a run by single steps.
#[derive(Debug, Default)]
pub(crate) struct Debugger {
    program: Option<Program>,
    breakpoints: BTreeSet<u16>,
    continuing: Option<Continuing>,
    last: Option<Status>,
}

impl Debugger {
    /// Whether a run by single steps is under way.
    pub(crate) fn is_continuing(&self) -> bool {
        self.continuing.is_some()
    }

    /// The source line of a program address, when the program was downloaded from the editor.
    pub(crate) fn line_of(&self, pc: u16) -> Option<u32> {
        let program = self.program.as_ref()?;
        let source = program.source(pc)?;
        (&*source.file == SOURCE_NAME).then_some(source.line)
    }

    /// Notes a status read by the poll.
    pub(crate) fn observe(&mut self, status: &Status) {
        self.last = Some(*status);
    }

    /// The `prog` event of a status read at `t`.
    pub(crate) fn status_event(&self, status: &Status, t: f64) -> Value {
        json!({"e": "prog", "mode": status.mode, "mode_text": status.mode_name(), "waiting": status.waiting,
               "pc": status.pc, "line": self.line_of(status.pc), "continuing": self.is_continuing(), "t": t})
    }

    /// The program just downloaded.
    pub(crate) fn set_program(&mut self, program: Program) {
        self.program = Some(program);
        self.breakpoints.clear();
        self.continuing = None;
    }

    /// Sets the breakpoints at source lines: each at the first instruction on or after its line. Returns
    /// the lines that got one (a line without an instruction moves to the next instruction's line).
    pub(crate) fn set_breakpoint_lines(&mut self, lines: &[u32]) -> Vec<u32> {
        self.breakpoints.clear();
        let Some(program) = &self.program else { return Vec::new() };
        let mut effective = BTreeSet::new();
        for &line in lines {
            let found = program
                .source_lines
                .iter()
                .enumerate()
                .filter(|(_, s)| &*s.file == SOURCE_NAME && s.line >= line)
                .min_by_key(|(address, s)| (s.line, *address));
            if let Some((address, s)) = found {
                self.breakpoints.insert(address as u16);
                effective.insert(s.line);
            }
        }
        effective.into_iter().collect()
    }

    /// The breakpoint addresses.
    #[cfg(test)]
    pub(crate) fn breakpoints(&self) -> &BTreeSet<u16> {
        &self.breakpoints
    }
}

/// What the editor's buttons do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Action {
    /// From address 0: 129 type 1 (or, with breakpoints, 131 and single steps).
    Start,
    /// 128, and the end of a run by single steps.
    Stop,
    /// 130: one instruction.
    Step,
    /// From where the program stands: 129 type 0 (or, with breakpoints, single steps).
    Continue,
    /// 131: stop, PC 0, registers cleared.
    Reset,
}

/// Runs an editor action and returns the state after it (the `debug` event, also sent to every page).
pub(crate) fn act(link: &mut Link, action: Action) -> Result<Value, HostError> {
    let stepping = !link.debug.breakpoints.is_empty();
    link.debug.continuing = None;
    let reason = match action {
        Action::Stop => {
            link.request(Command::StopApplication.encode())?;
            "stopped"
        }
        Action::Step => {
            link.request(Command::StepApplication.encode())?;
            "step"
        }
        Action::Reset => {
            link.request(Command::ResetApplication.encode())?;
            "reset"
        }
        Action::Start if stepping => {
            link.request(Command::ResetApplication.encode())?;
            link.debug.continuing = Some(Continuing { check_first: true, steps: 0 });
            "continuing"
        }
        Action::Start => {
            link.request(Command::RunApplication { from: Some(0) }.encode())?;
            "running"
        }
        Action::Continue if stepping => {
            link.debug.continuing = Some(Continuing { check_first: false, steps: 0 });
            "continuing"
        }
        Action::Continue => {
            link.request(Command::RunApplication { from: None }.encode())?;
            "running"
        }
    };
    report(link, reason)
}

/// After the breakpoints changed: a program running at full speed is stopped and goes on by single steps,
/// so that it stops at them.
pub(crate) fn breakpoints_changed(link: &mut Link) -> Result<(), HostError> {
    let running = link.debug.last.is_some_and(|s| s.mode == 1);
    if running && !link.debug.breakpoints.is_empty() && !link.debug.is_continuing() {
        link.request(Command::StopApplication.encode())?;
        link.debug.continuing = Some(Continuing { check_first: true, steps: 0 });
        report(link, "continuing")?;
    }
    Ok(())
}

/// One step of a run towards a breakpoint (the link thread calls it between polls).
pub(crate) fn continue_step(link: &mut Link) {
    let Some(mut run) = link.debug.continuing else { return };
    let result = (|| {
        if !(run.check_first && run.steps == 0) {
            link.request(Command::StepApplication.encode())?;
        }
        run.steps += 1;
        let status = read_status(link)?;
        link.debug.last = Some(status);
        let at_breakpoint = link.debug.breakpoints.contains(&status.pc) && (run.steps > 1 || run.check_first);
        // 135 mode 0: the program ran into STOP (or was stopped elsewhere).
        Ok::<_, HostError>(if at_breakpoint {
            Some("breakpoint")
        } else if status.mode == 0 {
            Some("stopped")
        } else {
            None
        })
    })();
    match result {
        Ok(None) => link.debug.continuing = Some(run),
        Ok(Some(reason)) => {
            link.debug.continuing = None;
            let _ = report(link, reason);
        }
        Err(e) => {
            link.debug.continuing = None;
            link.emit(json!({"e": "debug", "reason": "error", "error": e.to_string()}));
        }
    }
}

/// Mode, wait flag and program counter: 135 type 1, or on a module whose 135 answers the state alone,
/// 135 and GP 130 (its wait flag is not reported: false).
pub(crate) fn read_status(link: &mut Link) -> Result<Status, HostError> {
    if plain_status(link) {
        let mode = link.request(Command::GetStatus { kind: StatusKind::MemoryPointer }.encode())?.value as u8;
        let pc = match link
            .model
            .and_then(|m| m.global.role(tmcl_model::Role::ProgramCounter).map(|i| m.global.params[i].number))
        {
            Some(number) => link.request(Command::Ggp { param: number, bank: 0 }.encode())?.value as u16,
            None => 0,
        };
        return Ok(Status { mode, waiting: false, pc });
    }
    let reply = link.request(Command::GetStatus { kind: StatusKind::ProgramCounter }.encode())?;
    Ok(Status::from_packed(reply.value))
}

/// Reads PC, A and X, sends the `debug` event to every page, and returns it.
fn report(link: &mut Link, reason: &str) -> Result<Value, HostError> {
    let status = read_status(link)?;
    link.debug.last = Some(status);
    let (a, x) = if plain_status(link) {
        (None, None) // no registers to read on this module
    } else {
        let a = link.request(Command::GetStatus { kind: StatusKind::Accumulator }.encode())?.value;
        (Some(a), Some(link.request(Command::GetStatus { kind: StatusKind::XRegister }.encode())?.value))
    };
    let mut event = link.debug.status_event(&status, now_ms());
    event["e"] = json!("debug");
    event["reason"] = json!(reason);
    event["acc"] = json!(a);
    event["x"] = json!(x);
    link.emit(event.clone());
    Ok(event)
}

/// Downloads `instructions` from address 0 (commands 132, each instruction answered with status 101,
/// then 133; §3.7.38), stopping the program first. `progress` gets the count stored so far.
pub(crate) fn download(
    link: &mut Link,
    instructions: &[Instruction],
    mut progress: impl FnMut(&Link, usize),
) -> Result<(), HostError> {
    link.debug.continuing = None;
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

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_asm::{assemble_str, BuiltinResolver};

    #[test]
    fn packed_status() {
        let s = Status::from_packed(0x0201_0007);
        assert_eq!(s, Status { mode: 2, waiting: true, pc: 7 });
        assert_eq!(s.mode_name(), "stepped");
    }

    #[test]
    fn breakpoints_land_on_instructions() {
        let source = "// demo\nLoop:\n  ROR 0, 100\n\n  WAIT TICKS, 0, 10\n  JA Loop\n";
        let program = assemble_str(SOURCE_NAME, source, &mut BuiltinResolver::default()).unwrap();
        let mut d = Debugger::default();
        assert!(d.set_breakpoint_lines(&[3]).is_empty(), "no program, no breakpoints");
        d.set_program(program);
        // Line 2 is a label: the breakpoint goes to line 3's instruction; line 4 is blank: to line 5.
        assert_eq!(d.set_breakpoint_lines(&[2, 4, 6, 40]), vec![3, 5, 6]);
        assert_eq!(d.breakpoints().iter().copied().collect::<Vec<_>>(), vec![0, 1, 2]);
        assert_eq!(d.line_of(1), Some(5));
        assert_eq!(d.line_of(9), None);
    }
}

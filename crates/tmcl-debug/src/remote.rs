//! The debugger for any module, real or virtual, over the TMCL control commands.
//!
//! It uses only commands 128 stop, 129 run, 130 step, 131 reset and 135 for the mode, wait flag,
//! program counter, accumulator and X register (PD28-1021 TMCL manual §3.7.38, Table 13).
//!
//! **Breakpoints.** TMCL has no breakpoint command, so a run that must stop at a breakpoint is a run by
//! single steps: command 130, then 135 type 1 for the program counter, until the counter is at a
//! breakpoint or the program has stopped. The program therefore never runs past a breakpoint, on any
//! module; the price is speed: two requests per instruction (the workbench measured 17 instructions per
//! second at 9600 baud, 61 on a pty at 200 requests/s). Without breakpoints, Start and Continue are plain
//! 129 and the program runs at full speed. Setting a breakpoint while the program runs at full speed
//! stops it (128) and goes on by single steps.
//!
//! The caller owns the link: it implements [`Target`] and calls [`Remote::continue_step`] whenever the
//! next single step may go out, so that other requests (a plot's polls) can go between two steps.

use crate::breakpoint;
use crate::status::AppStatus;
use serde::Serialize;
use std::collections::BTreeSet;
use tmcl_asm::Program;
use tmcl_model::{AppStatusReply, ModelSpec, Role};
use tmcl_wire::{Command, Instruction, Reply, StatusKind};

/// A module the debugger talks to: one request, one reply.
pub trait Target {
    /// What a failed request gives.
    type Error;
    /// Sends `instruction` and returns the module's reply.
    fn request(&mut self, instruction: Instruction) -> Result<Reply, Self::Error>;
    /// The module's model, when it is known: it says how 135 answers and where the program counter is.
    fn model(&self) -> Option<&'static ModelSpec>;
}

/// Whether the module's 135 answers its state alone, whatever the type (the PDx-113, its manual §5.5):
/// then the program counter is a global parameter and there is no accumulator or X register to read.
pub fn plain_status(model: Option<&'static ModelSpec>) -> bool {
    model.is_some_and(|m| m.app_status == AppStatusReply::Plain)
}

/// Mode, wait flag and program counter: 135 type 1, or on a module whose 135 answers the state alone,
/// 135 and the global parameter of the program counter (its wait flag is not reported: false).
pub fn read_status<T: Target>(target: &mut T) -> Result<AppStatus, T::Error> {
    let model = target.model();
    if plain_status(model) {
        let mode = target.request(Command::GetStatus { kind: StatusKind::MemoryPointer }.encode())?.value as u8;
        let pc = match model.and_then(|m| m.global.role(Role::ProgramCounter).map(|i| m.global.params[i].number)) {
            Some(number) => target.request(Command::Ggp { param: number, bank: 0 }.encode())?.value as u16,
            None => 0,
        };
        return Ok(AppStatus { mode, waiting: false, pc });
    }
    let reply = target.request(Command::GetStatus { kind: StatusKind::ProgramCounter }.encode())?;
    Ok(AppStatus::from_packed(reply.value))
}

/// What the editor's buttons do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Action {
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

/// Why the debugger reports: what it just did, or why a run by single steps ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// 128 (Stop), or a run by single steps found the program stopped (it ran into STOP).
    Stopped,
    /// 130: one instruction.
    Step,
    /// 131.
    Reset,
    /// 129: the program runs at full speed.
    Running,
    /// A run by single steps towards the next breakpoint began.
    Continuing,
    /// A run by single steps reached a breakpoint.
    Breakpoint,
}

/// The program's state as the debugger reports it (the workbench's `prog` event and the body of its
/// `debug` event).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ProgramState {
    /// 0 stop, 1 run, 2 step, 3 reset.
    pub mode: u8,
    /// The mode in words.
    pub mode_text: &'static str,
    /// A WAIT is pending.
    pub waiting: bool,
    /// The program counter.
    pub pc: u16,
    /// The source line of the program counter, when the program came from the debugger's source.
    pub line: Option<u32>,
    /// A run by single steps towards a breakpoint is under way.
    pub continuing: bool,
}

/// The state after an action or at the end of a run by single steps, with the registers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Report {
    /// The program's state.
    #[serde(flatten)]
    pub state: ProgramState,
    /// Why this report.
    pub reason: Reason,
    /// The accumulator (none on a module whose 135 answers its state alone).
    pub acc: Option<i32>,
    /// The X register (likewise).
    pub x: Option<i32>,
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
pub struct Remote {
    program: Option<Program>,
    /// The file name the program's source lines carry for the text the breakpoints are set in.
    file: String,
    breakpoints: BTreeSet<u16>,
    continuing: Option<Continuing>,
    last: Option<AppStatus>,
}

impl Remote {
    /// Whether a run by single steps is under way.
    pub fn is_continuing(&self) -> bool {
        self.continuing.is_some()
    }

    /// The source line of a program address in the debugger's file, when a program was downloaded.
    pub fn line_of(&self, pc: u16) -> Option<u32> {
        let source = self.program.as_ref()?.source(pc)?;
        (*source.file == *self.file).then_some(source.line)
    }

    /// Notes a status read elsewhere (the caller's poll).
    pub fn observe(&mut self, status: &AppStatus) {
        self.last = Some(*status);
    }

    /// The state for a status read.
    pub fn state(&self, status: &AppStatus) -> ProgramState {
        ProgramState {
            mode: status.mode,
            mode_text: status.mode_name(),
            waiting: status.waiting,
            pc: status.pc,
            line: self.line_of(status.pc),
            continuing: self.is_continuing(),
        }
    }

    /// The program just downloaded, assembled from the source `file` (the name its source lines carry,
    /// the file whose lines [`Remote::set_breakpoint_lines`] means). Clears the breakpoints.
    pub fn set_program(&mut self, program: Program, file: &str) {
        self.program = Some(program);
        self.file = file.to_string();
        self.breakpoints.clear();
        self.continuing = None;
    }

    /// Ends a run by single steps (the program was stopped, or downloaded again, elsewhere).
    pub fn end_run(&mut self) {
        self.continuing = None;
    }

    /// Sets the breakpoints at source lines: each at the first instruction on or after its line
    /// ([`breakpoint::at_line`]). Returns the lines that got one.
    pub fn set_breakpoint_lines(&mut self, lines: &[u32]) -> Vec<u32> {
        self.breakpoints.clear();
        let Some(program) = &self.program else { return Vec::new() };
        let mut effective = BTreeSet::new();
        for &line in lines {
            if let Some((address, line)) = breakpoint::at_line(program, |f| f == self.file, line) {
                self.breakpoints.insert(address);
                effective.insert(line);
            }
        }
        effective.into_iter().collect()
    }

    /// The breakpoint addresses.
    pub fn breakpoints(&self) -> &BTreeSet<u16> {
        &self.breakpoints
    }

    /// Runs an editor action and returns the state after it.
    pub fn act<T: Target>(&mut self, target: &mut T, action: Action) -> Result<Report, T::Error> {
        let stepping = !self.breakpoints.is_empty();
        self.continuing = None;
        let reason = match action {
            Action::Stop => {
                target.request(Command::StopApplication.encode())?;
                Reason::Stopped
            }
            Action::Step => {
                target.request(Command::StepApplication.encode())?;
                Reason::Step
            }
            Action::Reset => {
                target.request(Command::ResetApplication.encode())?;
                Reason::Reset
            }
            Action::Start if stepping => {
                target.request(Command::ResetApplication.encode())?;
                self.continuing = Some(Continuing { check_first: true, steps: 0 });
                Reason::Continuing
            }
            Action::Start => {
                target.request(Command::RunApplication { from: Some(0) }.encode())?;
                Reason::Running
            }
            Action::Continue if stepping => {
                self.continuing = Some(Continuing { check_first: false, steps: 0 });
                Reason::Continuing
            }
            Action::Continue => {
                target.request(Command::RunApplication { from: None }.encode())?;
                Reason::Running
            }
        };
        self.report(target, reason)
    }

    /// After the breakpoints changed: a program running at full speed is stopped and goes on by single
    /// steps, so that it stops at them. Returns the report when it did.
    pub fn breakpoints_changed<T: Target>(&mut self, target: &mut T) -> Result<Option<Report>, T::Error> {
        let running = self.last.is_some_and(|s| s.mode == 1);
        if running && !self.breakpoints.is_empty() && !self.is_continuing() {
            target.request(Command::StopApplication.encode())?;
            self.continuing = Some(Continuing { check_first: true, steps: 0 });
            return self.report(target, Reason::Continuing).map(Some);
        }
        Ok(None)
    }

    /// One step of a run towards a breakpoint. Returns `None` while the run goes on, else how it ended:
    /// the report at a breakpoint or at the program's stop, or the error that ended it.
    pub fn continue_step<T: Target>(&mut self, target: &mut T) -> Option<Result<Report, T::Error>> {
        let mut run = self.continuing?;
        let result = (|| {
            if !(run.check_first && run.steps == 0) {
                target.request(Command::StepApplication.encode())?;
            }
            run.steps += 1;
            let status = read_status(target)?;
            self.last = Some(status);
            let at_breakpoint = self.breakpoints.contains(&status.pc) && (run.steps > 1 || run.check_first);
            // 135 mode 0: the program ran into STOP (or was stopped elsewhere).
            Ok(if at_breakpoint {
                Some(Reason::Breakpoint)
            } else if status.mode == 0 {
                Some(Reason::Stopped)
            } else {
                None
            })
        })();
        match result {
            Ok(None) => {
                self.continuing = Some(run);
                None
            }
            Ok(Some(reason)) => {
                self.continuing = None;
                Some(self.report(target, reason))
            }
            Err(e) => {
                self.continuing = None;
                Some(Err(e))
            }
        }
    }

    /// Reads PC, A and X and returns the report.
    fn report<T: Target>(&mut self, target: &mut T, reason: Reason) -> Result<Report, T::Error> {
        let status = read_status(target)?;
        self.last = Some(status);
        let (acc, x) = if plain_status(target.model()) {
            (None, None) // no registers to read on this module
        } else {
            let a = target.request(Command::GetStatus { kind: StatusKind::Accumulator }.encode())?.value;
            (Some(a), Some(target.request(Command::GetStatus { kind: StatusKind::XRegister }.encode())?.value))
        };
        Ok(Report { state: self.state(&status), reason, acc, x })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_asm::{assemble_str, BuiltinResolver};

    #[test]
    fn breakpoints_land_on_instructions() {
        let source = "// demo\nLoop:\n  ROR 0, 100\n\n  WAIT TICKS, 0, 10\n  JA Loop\n";
        let program = assemble_str("program.tmc", source, &mut BuiltinResolver::default()).unwrap();
        let mut d = Remote::default();
        assert!(d.set_breakpoint_lines(&[3]).is_empty(), "no program, no breakpoints");
        d.set_program(program, "program.tmc");
        // Line 2 is a label: the breakpoint goes to line 3's instruction; line 4 is blank: to line 5.
        assert_eq!(d.set_breakpoint_lines(&[2, 4, 6, 40]), vec![3, 5, 6]);
        assert_eq!(d.breakpoints().iter().copied().collect::<Vec<_>>(), vec![0, 1, 2]);
        assert_eq!(d.line_of(1), Some(5));
        assert_eq!(d.line_of(9), None);
    }

    #[test]
    fn reports_serialize_flat() {
        let state =
            ProgramState { mode: 0, mode_text: "stopped", waiting: false, pc: 3, line: Some(5), continuing: false };
        let report = Report { state, reason: Reason::Breakpoint, acc: Some(1), x: None };
        let json = serde_json::to_string(&report).unwrap();
        assert_eq!(
            json,
            r#"{"mode":0,"mode_text":"stopped","waiting":false,"pc":3,"line":5,"continuing":false,"reason":"breakpoint","acc":1,"x":null}"#
        );
    }
}

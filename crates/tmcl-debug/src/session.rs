//! The debugger of a program on a simulated module, in this process and in simulated time: the one of
//! `tmcl debug`.
//!
//! [`Session::command`] executes one command line ([`COMMANDS_HELP`]) and writes what it says, errors
//! as plain sentences; `tmcl debug` reads the lines from stdin, so it works at a terminal and from a
//! script alike. After each stop it prints a status line (why, PC, simulated time) and the source line of
//! the PC (`file:line: text`).
//!
//! How it drives the core: stepping is command 130 ([`Command::StepApplication`]), which executes one
//! instruction; running is command 129 with the simulator's breakpoints set ([`tmcl_sim::Breakpoints`]),
//! polling the module from deadline to deadline, so the program never runs past a breakpoint. A WAIT
//! that does not end at once lets simulated time pass (the program runs, interrupts included) until the
//! next instruction; `next` steps over a CSUB the same way. While the program stands still, motion and
//! timers go on only when the debugger lets time pass (`advance`, or running).
//!
//! The simulator lets a breakpoint pass once when the run resumes where it stopped (so that `continue`
//! goes on); a run the PC was moved for stops at the first breakpoint it meets (`tmcl_sim::Breakpoints`).
//! A step executes the instruction at the PC whatever breakpoint sits there (see `Session::step_raw`).

use crate::breakpoint;
use std::collections::{BTreeSet, HashMap};
use std::io::{self, Write};
use tmcl_core::vm::{flags, RunState, INSTRUCTION_TIME, MAX_VECTORS};
use tmcl_core::{Duration, Instant, Module};
use tmcl_run::trace::seconds;
use tmcl_run::{parse_value, poll, state_name, Setup, Source, USER_BANK};
use tmcl_sim::SimBoard;
use tmcl_wire::{Command, Opcode};

/// The debugger's commands, for `help` and `tmcl debug --help`.
pub const COMMANDS_HELP: &str = "\
Debugger commands (one per line, from stdin):
  step [N], s [N]        execute N instructions (default 1); a WAIT lets time pass until it ends
  next, n                as step, but run a CSUB's subroutine to its return
  continue, c            run until a breakpoint, STOP, or --limit simulated seconds
  run                    restart: a fresh module, the program from address 0
  break WHERE, b WHERE   breakpoint at a label, an address, or FILE:LINE
  delete [N]             delete breakpoint N (all without N)
  breakpoints            list the breakpoints
  print, p               PC and source line, A, X, flags, stack, wait, time, position, velocity
  print var N | ap N | gp N[.B]   a user variable, axis parameter or global parameter
  set var N = V | ap N = V | gp N[.B] = V   write one (SGP bank 2, SAP, SGP)
  list [ADDR], l         source around the PC (or ADDR)
  time                   simulated time
  advance MS             let MS milliseconds of simulated time pass (the program stays put)
  help                   this text
  quit, q                leave (also at the end of the input)";

/// One command's answer as data (`tmcl debug --json` prints one per command).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Answer {
    /// The command line (none for the banner).
    pub command: Option<String>,
    /// What it printed, line by line.
    pub output: Vec<String>,
    /// The program counter after it.
    pub pc: u16,
    /// The program's state after it.
    pub state: String,
    /// Simulated time after it, s.
    pub time_s: f64,
    /// The instructions the module refused while this command ran (the program skipped them).
    pub refused: Vec<tmcl_run::Refused>,
}

/// Whether the session goes on after a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Read the next command.
    Continue,
    /// `quit`: leave.
    Quit,
}

/// Why the program stands still after a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stop {
    /// It executed the instructions asked for.
    Stepped,
    /// It reached user breakpoint N.
    Breakpoint(u32),
    /// It executed a STOP or a cell it cannot execute.
    Ended,
    /// `continue` ran out of simulated time.
    Limit,
}

/// A user breakpoint.
#[derive(Debug, Clone)]
struct Breakpoint {
    number: u32,
    address: u16,
}

/// A place to return to: address, subroutine depth, inside a handler or not.
type Return = (u16, usize, bool);

/// The debugger's state: the module, the program, the breakpoints, the simulated time.
pub struct Session {
    setup: Setup,
    source: Source,
    module: Module<SimBoard>,
    now: Instant,
    limit: Duration,
    breakpoints: Vec<Breakpoint>,
    next_number: u32,
    variables: BTreeSet<u8>,
    /// The program has ended (STOP, or a cell it cannot execute) since the last `run`.
    ended: bool,
    /// Source files by name, split into lines (`None`: unreadable).
    files: HashMap<String, Option<Vec<String>>>,
    /// Reads the module's refused instructions after each command.
    refusals: tmcl_run::refusals::Collector,
    /// Those of the present command (for `--json`).
    refused: Vec<tmcl_run::Refused>,
}

impl Session {
    /// A session on `module`, built by `setup` with `source` loaded (`run` builds it again); `continue`
    /// stops after `limit` of simulated time without a breakpoint or STOP.
    pub fn new(setup: Setup, source: Source, module: Module<SimBoard>, limit: Duration) -> Session {
        let variables = source.user_variables();
        Session {
            setup,
            source,
            module,
            now: Instant::ZERO,
            limit,
            breakpoints: Vec::new(),
            next_number: 1,
            variables,
            ended: false,
            files: HashMap::new(),
            refusals: tmcl_run::refusals::Collector::default(),
            refused: Vec::new(),
        }
    }

    /// The module being debugged.
    pub fn module(&self) -> &Module<SimBoard> {
        &self.module
    }

    /// The simulated time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// What `command` said (`output`) as data, with the program's state after it and the instructions
    /// the module refused while it ran (taken: the next answer has only the next command's).
    pub fn answer(&mut self, command: Option<&str>, output: &[u8]) -> Answer {
        Answer {
            command: command.map(String::from),
            output: String::from_utf8_lossy(output).lines().map(String::from).collect(),
            pc: self.module.vm().pc,
            state: state_name(self.module.vm().state()).to_string(),
            time_s: self.now.micros() as f64 / 1e6,
            refused: std::mem::take(&mut self.refused),
        }
    }

    /// What the debugger says first: the program, the module, and where the program stands.
    pub fn banner(&mut self, out: &mut dyn Write) -> io::Result<()> {
        writeln!(
            out,
            "{}: {} instructions on a simulated {}; `help` lists the commands",
            self.source.path.display(),
            self.source.program.instructions.len(),
            self.module.spec().name
        )?;
        self.location(out, self.module.vm().pc)
    }

    /// Executes one command line.
    pub fn command(&mut self, line: &str, out: &mut dyn Write) -> io::Result<Flow> {
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some((&verb, rest)) = words.split_first() else { return Ok(Flow::Continue) };
        let result = match verb.to_ascii_lowercase().as_str() {
            "quit" | "q" | "exit" => return Ok(Flow::Quit),
            "help" | "h" | "?" => writeln!(out, "{COMMANDS_HELP}").map(|_| Ok(())),
            "step" | "s" => self.count(rest).map(|n| self.steps(n, false, out)).unwrap_or_else(|e| Ok(Err(e))),
            "next" | "n" => self.count(rest).map(|n| self.steps(n, true, out)).unwrap_or_else(|e| Ok(Err(e))),
            "continue" | "c" | "cont" => self.cont(out).map(Ok),
            "run" | "r" => self.restart(out).map(Ok),
            "break" | "b" => self.add_breakpoint(rest, out),
            "delete" | "d" => self.delete(rest, out),
            "breakpoints" | "info" => self.list_breakpoints(out).map(Ok),
            "print" | "p" => self.print(rest, out),
            "set" => self.set(rest, out),
            "list" | "l" => self.list(rest, out),
            "time" => writeln!(out, "time {} s", seconds(self.now.micros())).map(Ok),
            "advance" => self.advance(rest, out),
            _ => {
                writeln!(out, "unknown command `{verb}`.")?;
                writeln!(out, "{COMMANDS_HELP}").map(|_| Ok(()))
            }
        }?;
        if let Err(message) = result {
            writeln!(out, "{message}")?;
        }
        Ok(Flow::Continue)
    }

    fn count(&self, rest: &[&str]) -> Result<u32, String> {
        match rest {
            [] => Ok(1),
            [n] => n.parse().ok().filter(|n| *n > 0).ok_or_else(|| format!("`{n}` is not a count of instructions.")),
            _ => Err("step takes at most one number, the count of instructions.".into()),
        }
    }

    fn is_user_breakpoint(&self, address: u16) -> bool {
        self.breakpoints.iter().any(|b| b.address == address)
    }

    fn user_breakpoint(&self, address: u16) -> Option<u32> {
        self.breakpoints.iter().find(|b| b.address == address).map(|b| b.number)
    }

    fn depth(&self) -> Return {
        let vm = self.module.vm();
        (vm.pc, vm.stack_depth(), vm.in_handler())
    }

    // ---- moving the program ------------------------------------------------------------------

    /// Executes the instruction at the PC with command 130, whatever breakpoint sits there, and lets the
    /// time of one instruction pass.
    fn step_raw(&mut self) {
        let pc = self.module.vm().pc;
        // No breakpoint at the PC for this one instruction: the step executes it whether or not the
        // program stopped there (the simulator's stop is forgotten at the next instruction either way).
        self.module.board_mut().breakpoints_mut().set(pc, false);
        let _ = self.module.execute(Command::StepApplication, self.now);
        let user = self.is_user_breakpoint(pc);
        self.module.board_mut().breakpoints_mut().set(pc, user);
        self.now += INSTRUCTION_TIME;
        poll(&mut self.module, self.now);
    }

    /// Runs the program (command 129) until a user breakpoint, the end, the time limit, or `until`.
    fn resume(&mut self, until: Option<Return>) -> Stop {
        let limit = self.now + self.limit;
        let temporary = until.map(|u| u.0).filter(|a| !self.is_user_breakpoint(*a));
        if let Some(a) = temporary {
            self.module.board_mut().breakpoints_mut().set(a, true);
        }
        // The run begins with the instruction at the PC, even when a breakpoint sits on it (the program
        // stopped there, or was stepped onto it): `continue` goes on from where the program stands.
        let pc = self.module.vm().pc;
        self.module.board_mut().breakpoints_mut().resume_at(pc);
        let _ = self.module.execute(Command::RunApplication { from: None }, self.now);
        let stop = loop {
            let deadline = poll(&mut self.module, self.now);
            let at_breakpoint = self.module.board().breakpoints().stopped_at();
            let vm = self.module.vm();
            if at_breakpoint && vm.state() == RunState::Stopped {
                if until.is_some_and(|u| u == self.depth()) {
                    break Stop::Stepped;
                }
                if let Some(n) = self.user_breakpoint(vm.pc) {
                    break Stop::Breakpoint(n);
                }
                // The temporary breakpoint, reached at another depth (recursion, a handler): go on.
                self.step_raw();
                let _ = self.module.execute(Command::RunApplication { from: None }, self.now);
                continue;
            }
            if vm.state() != RunState::Running {
                break Stop::Ended;
            }
            if self.now >= limit {
                let _ = self.module.execute(Command::StopApplication, self.now);
                break Stop::Limit;
            }
            self.now = deadline.unwrap_or(limit).max(self.now).min(limit);
        };
        if let Some(a) = temporary {
            self.module.board_mut().breakpoints_mut().set(a, false);
        }
        stop
    }

    /// One `step` (or `next` with `over`): one instruction, a whole WAIT, a whole subroutine call.
    fn step_once(&mut self, over: bool) -> Stop {
        let before = self.depth();
        let (pc, depth, handler) = before;
        let next = (pc.wrapping_add(1), depth, handler);
        if self.module.vm().wait.is_some() {
            return self.resume(Some(next)); // stopped inside a WAIT: finish it
        }
        let is_csub = self.source.instruction(pc).is_some_and(|i| i.opcode == Opcode::Csub)
            || self.module.program().get(usize::from(pc)).is_some_and(|i| i.opcode == Opcode::Csub);
        self.step_raw();
        let vm = self.module.vm();
        if vm.state() == RunState::Stopped {
            return Stop::Ended;
        }
        if vm.wait.is_some() || (over && is_csub && vm.stack_depth() > depth) {
            return self.resume(Some(next));
        }
        Stop::Stepped
    }

    fn steps(&mut self, n: u32, over: bool, out: &mut dyn Write) -> io::Result<Result<(), String>> {
        if self.ended {
            return Ok(Err(self.ended_message()));
        }
        let mut stop = Stop::Stepped;
        for _ in 0..n {
            stop = self.step_once(over);
            if stop != Stop::Stepped {
                break;
            }
            if let Some(b) = self.user_breakpoint(self.module.vm().pc) {
                stop = Stop::Breakpoint(b);
                break;
            }
        }
        self.report(stop, out).map(Ok)
    }

    fn cont(&mut self, out: &mut dyn Write) -> io::Result<()> {
        if self.ended {
            return writeln!(out, "{}", self.ended_message());
        }
        let mut stop = if self.module.vm().wait.is_some() { Stop::Stepped } else { self.step_once(false) };
        if stop == Stop::Stepped {
            stop = match self.user_breakpoint(self.module.vm().pc) {
                Some(b) => Stop::Breakpoint(b),
                None => self.resume(None),
            };
        }
        self.report(stop, out)
    }

    fn ended_message(&self) -> String {
        format!("The program has ended at {}; `run` starts it again.", self.module.vm().pc)
    }

    fn restart(&mut self, out: &mut dyn Write) -> io::Result<()> {
        match self.setup.build(&self.source, &mut source_line) {
            Ok(module) => self.module = module,
            Err(e) => return writeln!(out, "Cannot restart: {e}."),
        }
        self.refusals = tmcl_run::refusals::Collector::default();
        self.now = Instant::ZERO;
        self.ended = false;
        for b in &self.breakpoints {
            self.module.board_mut().breakpoints_mut().set(b.address, true);
        }
        let stop = match self.user_breakpoint(0) {
            Some(b) => Stop::Breakpoint(b),
            None => self.resume(None),
        };
        self.report(stop, out)
    }

    fn advance(&mut self, rest: &[&str], out: &mut dyn Write) -> io::Result<Result<(), String>> {
        let [ms] = rest else { return Ok(Err("advance takes one number: milliseconds of simulated time.".into())) };
        let Some(ms) = ms.parse::<u64>().ok().filter(|ms| *ms <= 1_000_000_000) else {
            return Ok(Err(format!("`{ms}` is not a number of milliseconds.")));
        };
        self.now += Duration::from_millis(ms);
        poll(&mut self.module, self.now);
        self.refusals(out)?;
        self.status_line(out, "time passed")?;
        Ok(Ok(()))
    }

    // ---- what it says ------------------------------------------------------------------------

    /// Prints the instructions the module refused since the last command (the program skipped them);
    /// returns how many.
    fn refusals(&mut self, out: &mut dyn Write) -> io::Result<usize> {
        let new = self.refusals.collect(&self.module, &self.source).to_vec();
        for r in &new {
            writeln!(out, "refused: {}", r.describe())?;
        }
        let n = new.len();
        self.refused.extend(new);
        Ok(n)
    }

    fn report(&mut self, stop: Stop, out: &mut dyn Write) -> io::Result<()> {
        self.ended = stop == Stop::Ended;
        let refused = self.refusals(out)?;
        let pc = self.module.vm().pc;
        let why = match stop {
            // A step: the status the module gave the instruction (100, or the refusal's above).
            Stop::Stepped if refused == 0 => "status 100".into(),
            Stop::Stepped => String::new(),
            Stop::Breakpoint(n) => format!("breakpoint {n}"),
            Stop::Ended => {
                let stop = self.module.program().get(usize::from(pc)).is_some_and(|i| i.opcode == Opcode::Stop);
                if stop {
                    "program stopped (STOP)".into()
                } else {
                    "program ended (no instruction to execute)".into()
                }
            }
            Stop::Limit => format!("time limit ({} s) reached", seconds(self.limit.micros())),
        };
        self.status_line(out, &why)?;
        self.location(out, pc)
    }

    fn status_line(&self, out: &mut dyn Write, why: &str) -> io::Result<()> {
        let pc = self.module.vm().pc;
        let label = self.source.label_at(pc).map(|l| format!(" ({l})")).unwrap_or_default();
        let time = seconds(self.now.micros());
        let sep = if why.is_empty() { "" } else { ", " };
        writeln!(out, "{why}{sep}pc {pc}{label}, time {time} s")
    }

    /// `file:line: text` of the instruction at `address` (or its disassembly without source).
    fn location(&mut self, out: &mut dyn Write, address: u16) -> io::Result<()> {
        if let Some((file, line)) = self.source.place(address) {
            if let Some(text) = self.source_line(&file, line) {
                return writeln!(out, "{file}:{line}: {}", text.trim());
            }
        }
        match self.module.program().get(usize::from(address)) {
            Some(i) if usize::from(address) < self.source.program.instructions.len() => {
                writeln!(out, "{address}: {}", self.disassemble(i))
            }
            _ => writeln!(out, "{address}: (no instruction)"),
        }
    }

    fn disassemble(&self, i: &tmcl_wire::Instruction) -> String {
        let mut text = String::new();
        let label = |v: i32| -> Option<&str> { self.source.label_at(u16::try_from(v).ok()?) };
        let _ = tmcl_wire::ascii::format_instruction(i, &mut text, Some(&label));
        text
    }

    /// Line `line` (from 1) of a source file, read once.
    fn source_line(&mut self, file: &str, line: u32) -> Option<String> {
        self.file_lines(file)?.get(usize::try_from(line).ok()?.checked_sub(1)?).cloned()
    }

    fn file_lines(&mut self, file: &str) -> Option<&Vec<String>> {
        let spec = self.module.spec();
        self.files
            .entry(file.to_string())
            .or_insert_with(|| {
                let text = match file.strip_prefix(tmcl_asm::includes::BUILTIN_PREFIX) {
                    Some(name) => tmcl_asm::includes::builtin_file(spec, name).map(|(_, text)| text),
                    None => std::fs::read(file).ok().map(|b| String::from_utf8_lossy(&b).into_owned()),
                };
                text.map(|t| t.lines().map(str::to_string).collect())
            })
            .as_ref()
    }

    fn print(&mut self, rest: &[&str], out: &mut dyn Write) -> io::Result<Result<(), String>> {
        match rest {
            [] => self.print_all(out).map(Ok),
            [what, n] => match self.read(what, n) {
                Ok((name, v)) => writeln!(out, "{name} = {v}").map(Ok),
                Err(e) => Ok(Err(e)),
            },
            _ => Ok(Err("print takes nothing, or `var N`, `ap N` or `gp N[.B]`.".into())),
        }
    }

    /// Reads `var N`, `ap N` or `gp N[.B]`.
    fn read(&mut self, what: &str, n: &str) -> Result<(String, i32), String> {
        let command = parameter(what, n, None)?;
        let name = format!("{} {n}", what.to_ascii_lowercase());
        let command = match command {
            Command::Sap { param, motor, .. } => Command::Gap { param, motor },
            Command::Sgp { param, bank, .. } => Command::Ggp { param, bank },
            other => other,
        };
        match self.module.execute(command, self.now) {
            Ok(tmcl_core::Outcome::Value(v)) => Ok((name, v)),
            Ok(_) => Err(format!("{name} gave no value.")),
            Err(status) => Err(format!("The module refused to read {name}: status {status}.")),
        }
    }

    fn set(&mut self, rest: &[&str], out: &mut dyn Write) -> io::Result<Result<(), String>> {
        let text = rest.join(" ");
        let Some((lhs, rhs)) = text.split_once('=') else {
            return Ok(Err("write `set var N = V`, `set ap N = V` or `set gp N[.B] = V`.".into()));
        };
        let lhs: Vec<&str> = lhs.split_whitespace().collect();
        let [what, n] = lhs[..] else {
            return Ok(Err("write `set var N = V`, `set ap N = V` or `set gp N[.B] = V`.".into()));
        };
        let Some(value) = parse_value(rhs.trim()) else {
            return Ok(Err(format!("`{}` is not a 32-bit number.", rhs.trim())));
        };
        let command = match parameter(what, n, Some(value)) {
            Ok(c) => c,
            Err(e) => return Ok(Err(e)),
        };
        match self.module.execute(command, self.now) {
            Ok(_) => {
                if let Command::Sgp { param, bank: USER_BANK, .. } = command {
                    self.variables.insert(param);
                }
                writeln!(out, "{} {n} = {value}", what.to_ascii_lowercase()).map(Ok)
            }
            Err(status) => Ok(Err(format!("The module refused it: status {status}."))),
        }
    }

    fn print_all(&mut self, out: &mut dyn Write) -> io::Result<()> {
        let vm = self.module.vm().clone();
        let regs = self.module.registers();
        let pc = vm.pc;
        let label = self.source.label_at(pc).map(|l| format!(" ({l})")).unwrap_or_default();
        write!(out, "pc {pc}{label}: ")?;
        self.location(out, pc)?;
        let mut state = state_name(vm.state()).to_string();
        if self.module.board().breakpoints().stopped_at() {
            state.push_str(" at a breakpoint");
        }
        if let Some(ctx) = vm.saved_context() {
            state.push_str(&format!(", in an interrupt handler (returns to {})", ctx.pc));
        }
        writeln!(out, "program {state}")?;
        writeln!(out, "A = {}  X = {}  flags = {}", regs.accumulator, regs.x, flag_names(regs.flags))?;
        let stack: Vec<String> = vm
            .stack()
            .iter()
            .map(|a| match self.source.label_at(*a) {
                Some(l) => format!("{a} ({l})"),
                None => a.to_string(),
            })
            .collect();
        writeln!(out, "stack [{}]", stack.join(", "))?;
        match vm.wait {
            Some(w) => {
                let until = w.until.map(|u| format!(" until {} s", seconds(u.micros())));
                writeln!(out, "wait {}{}", w.condition.word(), until.unwrap_or_default())?;
            }
            None => writeln!(out, "wait none")?,
        }
        let handlers: Vec<String> = (0..MAX_VECTORS as u8)
            .filter(|n| vm.interrupt_enabled(*n))
            .map(|n| match vm.vector(n) {
                Some(a) => format!("{n} -> {a}"),
                None => format!("{n} (no vector)"),
            })
            .collect();
        if !handlers.is_empty() {
            let global = if vm.interrupt_enabled(255) { "on" } else { "off" };
            writeln!(out, "interrupts {global}, enabled {}", handlers.join(", "))?;
        }
        writeln!(out, "time {} s", seconds(self.now.micros()))?;
        let ramp = *self.module.ramp();
        writeln!(out, "position target {} actual {}", ramp.target_position, ramp.position)?;
        writeln!(out, "velocity {} pps", ramp.velocity())?;
        writeln!(out, "outputs {:#010b}", self.module.board().outputs())?;
        let variables: Vec<String> = self
            .variables
            .clone()
            .into_iter()
            .map(|n| format!("var {n} = {}", self.module.get_global(n, USER_BANK, self.now).unwrap_or(0)))
            .collect();
        if !variables.is_empty() {
            writeln!(out, "{}", variables.join("  "))?;
        }
        Ok(())
    }

    // ---- breakpoints and source --------------------------------------------------------------

    fn add_breakpoint(&mut self, rest: &[&str], out: &mut dyn Write) -> io::Result<Result<(), String>> {
        let [place] = rest else { return Ok(Err("break takes one place: a label, an address or FILE:LINE.".into())) };
        let address = match self.resolve(place) {
            Ok(a) => a,
            Err(e) => return Ok(Err(e)),
        };
        if let Some(n) = self.user_breakpoint(address) {
            return Ok(Err(format!("Breakpoint {n} is already at {address}.")));
        }
        let number = self.next_number;
        self.next_number += 1;
        self.breakpoints.push(Breakpoint { number, address });
        self.module.board_mut().breakpoints_mut().set(address, true);
        write!(out, "breakpoint {number} at {address}: ")?;
        self.location(out, address).map(Ok)
    }

    /// A label, an address, or `FILE:LINE` (the first instruction on that line or after it).
    fn resolve(&self, place: &str) -> Result<u16, String> {
        breakpoint::resolve(&self.source.program, self.module.spec().program_memory, place)
    }

    fn delete(&mut self, rest: &[&str], out: &mut dyn Write) -> io::Result<Result<(), String>> {
        let keep: Vec<Breakpoint> = match rest {
            [] => Vec::new(),
            [n] => {
                let Some(n) = n.parse::<u32>().ok().filter(|n| self.breakpoints.iter().any(|b| b.number == *n)) else {
                    return Ok(Err(format!("There is no breakpoint {n}.")));
                };
                self.breakpoints.iter().filter(|b| b.number != n).cloned().collect()
            }
            _ => return Ok(Err("delete takes one breakpoint number, or none to delete all.".into())),
        };
        let gone = self.breakpoints.len() - keep.len();
        for b in &self.breakpoints {
            self.module.board_mut().breakpoints_mut().set(b.address, false);
        }
        self.breakpoints = keep;
        for b in &self.breakpoints {
            self.module.board_mut().breakpoints_mut().set(b.address, true);
        }
        writeln!(out, "deleted {gone} breakpoint{}", if gone == 1 { "" } else { "s" }).map(Ok)
    }

    fn list_breakpoints(&mut self, out: &mut dyn Write) -> io::Result<()> {
        if self.breakpoints.is_empty() {
            return writeln!(out, "no breakpoints");
        }
        for b in self.breakpoints.clone() {
            write!(out, "{}  {}  ", b.number, b.address)?;
            self.location(out, b.address)?;
        }
        Ok(())
    }

    /// Source lines around the line of `ADDR` (default: the PC), `=>` at the PC, `*` at breakpoints.
    fn list(&mut self, rest: &[&str], out: &mut dyn Write) -> io::Result<Result<(), String>> {
        let pc = self.module.vm().pc;
        let center = match rest {
            [] => pc,
            [place] => match self.resolve(place) {
                Ok(a) => a,
                Err(e) => return Ok(Err(e)),
            },
            _ => return Ok(Err("list takes at most one address or label.".into())),
        };
        let marks = |d: &Session, a: u16| {
            format!("{}{}", if a == pc { "=>" } else { "  " }, if d.is_user_breakpoint(a) { "*" } else { " " })
        };
        if let Some((file, line)) = self.source.place(center) {
            if let Some(count) = self.file_lines(&file).map(Vec::len) {
                let first = line.saturating_sub(5).max(1);
                let last = (line + 5).min(count as u32);
                for n in first..=last {
                    let addresses: Vec<u16> = (0..self.source.program.source_lines.len() as u16)
                        .filter(|a| self.source.place(*a).is_some_and(|(f, l)| f == file && l == n))
                        .collect();
                    let mark = match addresses.first() {
                        Some(&a) => marks(self, addresses.iter().copied().find(|x| *x == pc).unwrap_or(a)),
                        None => "   ".into(),
                    };
                    let address = addresses.first().map(|a| a.to_string()).unwrap_or_default();
                    let text = self.source_line(&file, n).unwrap_or_default();
                    writeln!(out, "{mark}{address:>5} {file}:{n}: {text}")?;
                }
                return Ok(Ok(()));
            }
        }
        let len = self.source.program.instructions.len() as u16;
        for a in center.saturating_sub(5)..(center.saturating_add(6)).min(len) {
            let text = self.module.program().get(usize::from(a)).map(|i| self.disassemble(i)).unwrap_or_default();
            writeln!(out, "{}{a:>5} {text}", marks(self, a))?;
        }
        Ok(Ok(()))
    }
}

/// The command that reads or writes `var N`, `ap N` or `gp N[.B]` (a write with `value`).
fn parameter(what: &str, n: &str, value: Option<i32>) -> Result<Command, String> {
    let number = |s: &str| s.parse::<u8>().map_err(|_| format!("`{s}` is not a parameter number (0..255)."));
    let v = value.unwrap_or(0);
    Ok(match what.to_ascii_lowercase().as_str() {
        "var" => Command::Sgp { param: number(n)?, bank: USER_BANK, value: v },
        "ap" => Command::Sap { param: number(n)?, motor: 0, value: v },
        "gp" => {
            let (p, bank) = match n.split_once('.') {
                Some((p, b)) => (number(p)?, b.parse::<u8>().map_err(|_| format!("`{b}` is not a bank number."))?),
                None => (number(n)?, 0),
            };
            Command::Sgp { param: p, bank, value: v }
        }
        _ => return Err(format!("`{what}` is not `var`, `ap` or `gp`.")),
    })
}

/// The flags in words: ZE, GT, LT and the error flags ETO, EAL, EDV, EPO, ESD (§3.7.18).
fn flag_names(f: u16) -> String {
    let names = [
        (flags::ZERO, "ZE"),
        (flags::GREATER, "GT"),
        (flags::LOWER, "LT"),
        (flags::TIMEOUT, "ETO"),
        (flags::ALARM, "EAL"),
        (flags::DEVIATION, "EDV"),
        (flags::POSITION, "EPO"),
        (flags::SHUTDOWN, "ESD"),
    ];
    let set: Vec<&str> = names.iter().filter(|(bit, _)| f & bit != 0).map(|(_, n)| *n).collect();
    if set.is_empty() {
        format!("none ({f:#06x})")
    } else {
        format!("{} ({f:#06x})", set.join(" "))
    }
}

/// Line `line` (from 1) of a file, for the diagnostics of a rebuild.
fn source_line(file: &str, line: u32) -> Option<String> {
    let text = std::fs::read_to_string(file).ok()?;
    text.lines().nth(usize::try_from(line).ok()?.checked_sub(1)?).map(String::from)
}

//! Running a program in simulated time.
//!
//! The module never reads a clock: [`Module::poll`] is told the time and answers with its next deadline,
//! so the run jumps from deadline to deadline and finishes far faster than real time, with the same
//! result every time.
//!
//! With a [`Sink`], the run polls at every deadline (each motion tick while the motor moves, each
//! instruction while the program computes, the next timer or wait otherwise) and at every sample time,
//! so every event is seen at the instruction that causes it. When no instruction can run before the next
//! sample (the program is stopped or in a WAIT TICKS, and no interrupt can be entered), it skips the
//! motion ticks in between. It records a row at each sample and at each [`Event`]:
//! - **interrupt N**: the program enters the handler of interrupt N. Every address a VECT names gets a
//!   breakpoint, so the run stops exactly there, notes the event and goes on at once;
//! - **stop** / **end**: the program stopped at a STOP, or at a cell it cannot execute;
//! - **outN=V**: output N changed;
//! - **target=N**: a new target position (MVP, SAP 0): the row still shows where the motor stands,
//!   so a program that waits for each position shows each arrival;
//! - **refused=pc N status S**: the module refused the instruction at N with status S and the program
//!   went on without it (see [`crate::refusals`]; [`Simulation::refusals`] lists them with the reason).
//!
//! Without a sink, it polls only where the simulated world changes by itself and at the end (every
//! second when a progress callback is given): the core catches up on everything in between, with the same
//! result however often it is polled.
//!
//! Between events the module takes the motion ticks in closed form (`tmcl_core::module`'s spans): an
//! hour of the manual's programs runs in milliseconds. [`Options::exact_ticks`] ticks them one by one
//! instead, the reference the spans are checked against; both give byte-identical traces.

use crate::record::Recorder;
use crate::refusals::{Collector, Refusals};
use crate::setup::{poll, Setup, SetupError, Source};
use crate::trace::{Event, Sink, Trace};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::io;
use std::time::Instant as WallInstant;
use tmcl_core::model::GLOBAL_INTERRUPTS;
use tmcl_core::motion::{Mode, TICK};
use tmcl_core::vm::{RunState, MAX_VECTORS};
use tmcl_core::{Duration, Instant, Module};
use tmcl_sim::SimBoard;
use tmcl_wire::{Command, Status, WaitCondition};

/// Without a sink, how far one poll may jump at most while progress is reported.
const COARSE_STEP: Duration = Duration::from_millis(1000);

/// How to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// How long, in simulated time.
    pub duration: Duration,
    /// A row every this much simulated time (besides one at each event). Default 10 ms.
    pub every: Duration,
    /// Also record the drive: stallGuard2 load value, coolStep current scale, encoder, coil energy; on a
    /// closed-loop model also the virtual position, position error, current scaler and status word.
    pub drive: bool,
    /// Tick the motion controller one by one, every 1 ms, instead of jumping from event to event (the
    /// reference the event-driven run is checked against; the same results, only slower).
    pub exact_ticks: bool,
}

impl Options {
    /// A run of `duration`, a row every 10 ms, without the drive.
    pub fn new(duration: Duration) -> Options {
        Options { duration, every: Duration::from_millis(10), drive: false, exact_ticks: false }
    }
}

/// What a run did.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Simulated time, µs.
    pub simulated_us: u64,
    /// Wall-clock time the run took, s.
    pub wall_s: f64,
    /// Instructions the program executed.
    pub executed: u64,
    /// The program counter at the end.
    pub pc: u16,
    /// The program's state at the end: `stopped`, `running`, `stepped` or `reset`.
    pub state: &'static str,
    /// Rows recorded (0 without a sink).
    pub rows: u64,
    /// Instructions the module refused (and the program skipped); [`Simulation::refusals`] lists them.
    pub refused: u64,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The module could not be set up.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The module refused to start the program.
    #[error("the module refused to start the program: status {0}")]
    Start(Status),
    /// The module refused to resume the program after a handler's breakpoint.
    #[error("cannot resume the program: status {0}")]
    Resume(Status),
    /// The sink failed (a CSV file that cannot be written).
    #[error("cannot write the trace: {0}")]
    Sink(#[from] io::Error),
    /// [`Simulation::run`] was called a second time: a run starts at time 0.
    #[error("the simulation has run already; set up a new one")]
    AlreadyRun,
}

/// The program's run state in words.
pub fn state_name(state: RunState) -> &'static str {
    match state {
        RunState::Stopped => "stopped",
        RunState::Running => "running",
        RunState::Stepped => "stepped",
        RunState::Reset => "reset",
    }
}

/// Runs `source` on the module `setup` describes for `options.duration`, and returns the trace (a row
/// every `options.every` and at each event) with the summary.
///
/// ```
/// use tmcl_run::{run, Options, Quantity, Setup, Source};
/// let setup = Setup::new("pd28-1021")?;
/// let source = Source::assemble("demo.tmc", "MVP ABS, 0, 5000\nWAIT POS, 0, 0\nSTOP\n", setup.model)?;
/// let (trace, summary) = run(&source, &setup, &Options::new(tmcl_core::Duration::from_secs(2)))?;
/// let position = trace.column(Quantity::ActualPosition).unwrap();
/// assert_eq!(position.last(), Some(Some(5000)));
/// assert_eq!(summary.state, "stopped");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run(source: &Source, setup: &Setup, options: &Options) -> Result<(Trace, Summary), RunError> {
    let mut simulation = Simulation::new(source, setup)?;
    let mut trace = Trace::new();
    let summary = simulation.run(options, Some(&mut trace), None)?;
    Ok((trace, summary))
}

/// A module with a program in it, ready to run (the lower-level API: to stream rows to a file, follow
/// progress, or look at the module afterwards).
pub struct Simulation {
    module: Module<SimBoard>,
    source: Source,
    setup: Setup,
    ran: bool,
    refusals: Collector,
}

impl Simulation {
    /// Sets the module up (settings, world) and loads the program; a program with commands the model lacks
    /// is refused ([`SetupError::Commands`]).
    pub fn new(source: &Source, setup: &Setup) -> Result<Simulation, SetupError> {
        let mut lines = |file: &str, line: u32| source_line(file, line);
        let module = setup.build(source, &mut lines)?;
        Ok(Simulation {
            module,
            source: source.clone(),
            setup: setup.clone(),
            ran: false,
            refusals: Collector::default(),
        })
    }

    /// The module (after a run: its state at the end).
    pub fn module(&self) -> &Module<SimBoard> {
        &self.module
    }

    /// The instructions the module refused during the run, with where and why.
    pub fn refusals(&self) -> &Refusals {
        self.refusals.refusals()
    }

    /// The module, to change before the run.
    pub fn module_mut(&mut self) -> &mut Module<SimBoard> {
        &mut self.module
    }

    /// Starts the program at 0 and runs it for `options.duration`, once. With a `sink`, records a row
    /// every `options.every` and at each event into it; without one, runs as fast as it can and records
    /// nothing. `progress` is told the simulated time now and then (about every simulated second).
    pub fn run(
        &mut self,
        options: &Options,
        sink: Option<&mut dyn Sink>,
        mut progress: Option<&mut dyn FnMut(Instant)>,
    ) -> Result<Summary, RunError> {
        if std::mem::replace(&mut self.ran, true) {
            return Err(RunError::AlreadyRun);
        }
        let module = &mut self.module;
        module.set_exact_ticks(options.exact_ticks);
        let started = WallInstant::now();
        module.execute(Command::RunApplication { from: Some(0) }, Instant::ZERO).map_err(RunError::Start)?;
        let rows = match sink {
            None => {
                run_coarse(module, options.duration, &mut progress, &mut |m| {
                    self.refusals.collect(m, &self.source);
                });
                0
            }
            Some(sink) => {
                let mut variables: BTreeSet<u8> = self.source.user_variables();
                variables.extend(self.setup.settings.iter().filter_map(|s| s.user_variable()));
                let variables: Vec<u8> = variables.into_iter().collect();
                let mut recorder =
                    Recorder::new(self.setup.model, &variables, options.drive, self.setup.world.as_ref());
                sink.start(recorder.header())?;
                let run = Traced { every: options.every, end: Instant::ZERO + options.duration };
                run.run(module, &self.source, &mut recorder, sink, &mut progress, &mut self.refusals)?;
                sink.finish()?;
                recorder.rows
            }
        };
        Ok(Summary {
            simulated_us: options.duration.micros(),
            wall_s: started.elapsed().as_secs_f64(),
            executed: module.vm().executed(),
            pc: module.vm().pc,
            state: state_name(module.vm().state()),
            rows,
            refused: module.vm().refusals().count(),
        })
    }
}

/// The text of line `line` (from 1) of `file`, for diagnostics; `None` if it cannot be read.
fn source_line(file: &str, line: u32) -> Option<String> {
    let text = std::fs::read_to_string(file).ok()?;
    text.lines().nth(usize::try_from(line).ok()?.checked_sub(1)?).map(String::from)
}

/// Runs without recording: polls only where the world changes by itself (an input timeline, a fault
/// window) and at the end, and every [`COARSE_STEP`] when progress is reported. The module catches up
/// on every tick and instruction up to the time it is polled at, with the same result however often
/// that is; the board's world moves on by itself only when polled, so its changes are stepped on exactly.
fn run_coarse(
    module: &mut Module<SimBoard>,
    duration: Duration,
    progress: &mut Option<&mut dyn FnMut(Instant)>,
    after_poll: &mut dyn FnMut(&Module<SimBoard>),
) {
    let end = Instant::ZERO + duration;
    let mut t = Instant::ZERO;
    loop {
        // One poll runs at most `tmcl_core::vm::BUDGET` instructions (so that a poll always returns);
        // a program that runs without waiting gets further in each poll at the same time until it has
        // caught up, which its deadline says (it is then still `t` or before).
        // (A poll that executed nothing is the last: whatever its deadline says, no further poll at `t`
        // would get further.)
        loop {
            let executed = module.vm().executed();
            let behind = poll(module, t).is_some_and(|d| d <= t);
            after_poll(module);
            if !behind || module.vm().executed() == executed {
                break;
            }
        }
        if let Some(report) = progress {
            report(t);
        }
        if t >= end {
            break;
        }
        let world = module.board().next_event().filter(|e| *e > t).unwrap_or(end);
        t = if progress.is_some() { (t + COARSE_STEP).min(end).min(world) } else { end.min(world) };
    }
}

/// Whether the program can execute no instruction before `until`, so that the module may be polled
/// straight at `until` without missing or delaying an event: no interrupt can be entered (interrupts
/// off, or none enabled with a vector), and the program is stopped or in a WAIT TICKS that lasts.
fn quiet_until(module: &Module<SimBoard>, until: Instant) -> bool {
    let vm = module.vm();
    if vm.interrupt_enabled(GLOBAL_INTERRUPTS)
        && (0..MAX_VECTORS as u8).any(|n| vm.interrupt_enabled(n) && vm.vector(n).is_some())
    {
        return false;
    }
    match vm.wait {
        _ if vm.state() != RunState::Running => true,
        Some(w) if w.condition == WaitCondition::Ticks => w.until.is_some_and(|u| u >= until),
        _ => false,
    }
}

/// The first motion tick after `t` (ticks are [`TICK`] apart from time 0).
fn next_tick(t: Instant) -> Instant {
    Instant::from_micros((t.micros() / TICK.micros() + 1) * TICK.micros())
}

/// A recorded run.
struct Traced {
    every: Duration,
    end: Instant,
}

/// What the last poll left behind, to see what changed.
#[derive(Clone, Copy)]
struct Watch {
    outputs: u8,
    running: bool,
    target: i32,
    /// Motors 1, 2, …: their target positions in position mode (`None` in velocity mode).
    targets: [Option<i32>; 7],
}

impl Watch {
    fn of(module: &Module<SimBoard>) -> Watch {
        let mut targets = [None; 7];
        for (m, t) in targets.iter_mut().enumerate() {
            *t = module.axis(m + 1).map(|a| a.ramp()).filter(|r| r.mode == Mode::Position).map(|r| r.target_position);
        }
        Watch {
            outputs: module.board().outputs(),
            running: module.vm().is_running(),
            target: module.ramp().target_position,
            targets,
        }
    }
}

impl Traced {
    fn run(
        &self,
        module: &mut Module<SimBoard>,
        source: &Source,
        recorder: &mut Recorder,
        sink: &mut dyn Sink,
        progress: &mut Option<&mut dyn FnMut(Instant)>,
        refusals: &mut Collector,
    ) -> Result<(), RunError> {
        let handlers = source.handler_addresses();
        for &address in &handlers {
            module.board_mut().breakpoints_mut().set(address, true);
        }
        let mut watch = Watch::of(module);
        let mut events: Vec<Event> = Vec::new();
        let mut t = Instant::ZERO;
        let mut next_sample = Instant::ZERO;
        let mut stuck = 0u32;
        let mut last_executed = module.vm().executed();
        loop {
            let deadline = poll(module, t);
            recorder.watch_levels(module, t, sink);
            events.clear();
            events
                .extend(refusals.collect(module, source).iter().map(|r| Event::Refused { pc: r.pc, status: r.status }));
            if module.board().breakpoints().stopped_at() && module.vm().state() == RunState::Stopped {
                // A handler's first instruction: name the interrupt(s) whose vector points here, go on.
                let pc = module.vm().pc;
                if module.vm().in_handler() {
                    let vm = module.vm();
                    events.extend((0..MAX_VECTORS as u8).filter(|&n| vm.vector(n) == Some(pc)).map(Event::Interrupt));
                }
                module.execute(Command::RunApplication { from: None }, t).map_err(RunError::Resume)?;
                watch.running = true;
                if !events.is_empty() {
                    recorder.record(module, t, &events, sink)?;
                }
                continue; // the program goes on at the same time
            }
            self.changes(module, &mut watch, &mut events);
            let sample = t == next_sample;
            if sample || !events.is_empty() {
                recorder.record(module, t, &events, sink)?;
            }
            if sample {
                next_sample += self.every;
                if next_sample.millis() % 1000 < self.every.millis() {
                    if let Some(report) = progress {
                        report(t);
                    }
                }
            }
            if t >= self.end {
                return Ok(());
            }
            let mut next = deadline.unwrap_or(self.end).max(t).min(next_sample).min(self.end);
            if next < next_sample && quiet_until(module, next_sample) {
                next = next_sample.min(self.end); // nothing can happen but motion: skip its ticks
            }
            // The world's next change (an input timeline, in `deadline` too): stepped on exactly, even
            // when the skip above would pass it.
            if let Some(e) = module.board().next_event().filter(|e| *e > t) {
                next = next.min(e);
            }
            // A deadline that is already due and brings nothing new (a timer that falls between motion
            // ticks is only sampled at the next tick): go on at the next tick.
            let executed = module.vm().executed();
            stuck = if next == t && executed == last_executed { stuck + 1 } else { 0 };
            last_executed = executed;
            t = if stuck > 1 { next_tick(t).min(next_sample).min(self.end) } else { next };
        }
    }

    /// Events since the last poll: a new target position, output changes, the end of the program.
    fn changes(&self, module: &Module<SimBoard>, watch: &mut Watch, events: &mut Vec<Event>) {
        let now = Watch::of(module);
        if now.target != watch.target && module.ramp().mode == Mode::Position {
            events.push(Event::Target(now.target));
        }
        for (m, (new, old)) in now.targets.iter().zip(&watch.targets).enumerate() {
            if let Some(target) = new.filter(|n| Some(*n) != *old) {
                events.push(Event::MotorTarget { motor: m as u8 + 1, target });
            }
        }
        let changed = now.outputs ^ watch.outputs;
        for n in 0..8 {
            if changed >> n & 1 == 1 {
                events.push(Event::Output { number: n, level: now.outputs >> n & 1 == 1 });
            }
        }
        if watch.running && !now.running {
            let vm = module.vm();
            let at_stop = module.program().get(usize::from(vm.pc)).is_some_and(|i| i.opcode == tmcl_wire::Opcode::Stop);
            events.push(if at_stop { Event::Stop } else { Event::End });
        }
        *watch = now;
    }
}

//! `tmcl run`: assemble a program, load it into a simulated module and run it in simulated time.
//!
//! The module never reads a clock: [`Module::poll`] is told the time and answers with its
//! next deadline, so the run jumps from deadline to deadline and finishes far faster than real time, with
//! the same result every time.
//!
//! With a trace or a plot, the run polls at every deadline (each motion tick while the motor moves, each
//! instruction while the program computes, the next timer or wait otherwise) and at every sample time,
//! so every event is seen at the instruction that causes it. When no instruction can run before the next
//! sample (the program is stopped or in a WAIT TICKS, and no interrupt can be entered), it skips the
//! motion ticks in between. It records a row at each sample and at each event:
//! - **interrupt N**: the program enters the handler of interrupt N. Every address a VECT names gets a
//!   breakpoint, so the run stops exactly there, notes the event and goes on at once;
//! - **stop** / **end**: the program stopped at a STOP, or at a cell it cannot execute;
//! - **outN=V**: output N changed;
//! - **target=N**: a new target position (MVP, SAP 0): the row still shows where the motor stands,
//!   so a program that waits for each position shows each arrival.
//!
//! Without a trace or a plot, it polls only where the simulated world changes by itself and at the end
//! (every second with a progress bar): the core catches up on everything in between, with the same
//! result however often it is polled.
//!
//! Between events the module takes the motion ticks in closed form (`tmcl_core::module`'s spans): an
//! hour of the manual's programs runs in milliseconds. `--exact-ticks` ticks them one by one instead,
//! the reference the spans are checked against; both give byte-identical traces.

use crate::error::{CliError, EXIT_CODES};
use crate::sim::plot;
use crate::sim::trace::Trace;
use crate::sim::{SimOptions, Source};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::BTreeSet;
use std::fs::File;
use std::io::{BufWriter, IsTerminal};
use std::path::PathBuf;
use std::time::Instant as WallInstant;
use tmcl_core::model::GLOBAL_INTERRUPTS;
use tmcl_core::motion::{Mode, TICK};
use tmcl_core::vm::{RunState, MAX_VECTORS};
use tmcl_core::{Duration, Instant, Module};
use tmcl_sim::SimBoard;
use tmcl_wire::{Command, WaitCondition};

/// The trace columns with their units, for `tmcl run --help`: one line per column (continuation lines
/// indented further), in the order of the CSV header; `--drive:` marks the columns of `--drive`, and
/// `--drive, closed loop:` those it adds on a closed-loop model. A test reads the names from here and
/// compares them with the header of a run.
pub const TRACE_HELP: &str = "\
Trace columns (--trace OUT.csv), in this order, one row every --every ms and one at each event.
`--drive:` marks the columns --drive adds, `--drive, closed loop:` those it adds on a closed-loop model
(--module tmcm-1310); `TMC428 units:` the column of the TMC428 generation (--module pd-113):
  time_s            simulated time in s, 6 decimals (µs)
  target_position   AP 0 target position, µsteps
  actual_position   AP 1 actual position, µsteps (the encoder while a closed loop is closed)
  velocity          AP 3 actual speed, pps (µsteps per second), signed
  accumulator       the program's accumulator
  x                 the program's X register
  pc                program counter: the address of the next instruction
  outputs           digital outputs as a number, bit n = OUTn
  varN              user variable N (bank 2), one column for each variable the program or --set names
  load              --drive: AP 206 stallGuard2 load value, 0..1023 (0: load at the torque limit)
  current_scale     --drive: AP 180 coolStep current scale, 0..31 = 1/32..32/32 of the set current
  encoder           --drive: AP 209 encoder position, µsteps
  energy_a2s        --drive: the coils' ∫ I_peak² dt since power-up, A²·s (6 decimals); times the
                    coil resistance in Ω it is the copper loss in J
  virtual_position  --drive, closed loop: AP 233 virtual position (the loop's set point), µsteps
  position_error    --drive, closed loop: AP 237 virtual − actual position, µsteps
  scaler            --drive, closed loop: AP 123 current scaler, the current is AP 6 × scaler / 255
  status_word       --drive, closed loop: AP 18 status word, bit field (bit 2 = closed loop)
  velocity_units    TMC428 units: AP 3 in the module's own unit, a TMC428 velocity -2047..2047
                    (--module pd-113; `velocity` is the same in pps)
  event             `interrupt N` (handler entered), `stop` (STOP), `end` (a cell that does not
                    execute), `outN=V` (output changed), `target=N` (a new target position, e.g.
                    MVP; the row shows where the motor was then); several are joined with `;`

The plot (--plot OUT.svg) draws, over time: target and actual position; velocity; a logic-analyser lane
for each input and output that changes (IN0.., OUT0..) and one for each kind of program event. With
--drive also the load value, the current scale (closed loop: the current scaler and the position error),
the encoder minus the step position, and the coil energy, each on its own axis with its unit.
The run is deterministic: the same program and options give byte-identical traces.";

/// Without a trace, how far one poll may jump at most while a progress bar is shown.
const COARSE_STEP: Duration = Duration::from_millis(1000);

/// Options of `tmcl run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The program: TMCL source (.tmc) or an image (.bin).
    pub file: PathBuf,
    #[command(flatten)]
    pub sim: SimOptions,
    /// How long to run, in simulated seconds (fractions allowed, down to µs).
    #[arg(long = "for", value_name = "SECONDS", value_parser = parse_seconds)]
    pub duration: Duration,
    /// Write the trace to this CSV file (columns below).
    #[arg(long, value_name = "OUT.csv")]
    pub trace: Option<PathBuf>,
    /// Draw position, velocity, inputs, outputs and events over time into this SVG file (panels below).
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<PathBuf>,
    /// Sample the trace every MS milliseconds of simulated time.
    #[arg(long, value_name = "MS", default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..))]
    pub every: u64,
    /// Also trace and plot the drive: stallGuard2 load value (AP 206), coolStep current scale (AP 180),
    /// encoder position (AP 209) beside the step position, and the coils' energy ∫ I² dt (A²·s); on a
    /// closed-loop model also the virtual position, position error, current scaler and status word.
    #[arg(long)]
    pub drive: bool,
    /// Tick the motion controller one by one, every 1 ms, instead of jumping from event to event: the
    /// reference the event-driven run is checked against. The results are the same, only slower.
    #[arg(long)]
    pub exact_ticks: bool,
}

/// Seconds as text to a [`Duration`], exactly (no floating point): `3600`, `0.5`, `1.000001`.
pub(crate) fn parse_seconds(s: &str) -> Result<Duration, String> {
    let bad = || format!("`{s}` is not a number of seconds (e.g. 60 or 0.5)");
    let (whole, fraction) = s.trim().split_once('.').unwrap_or((s.trim(), ""));
    if fraction.len() > 6 || !fraction.chars().all(|c| c.is_ascii_digit()) || (whole.is_empty() && fraction.is_empty())
    {
        return Err(bad());
    }
    let whole: u64 = if whole.is_empty() { 0 } else { whole.parse().map_err(|_| bad())? };
    let fraction: u64 = format!("{fraction:0<6}").parse().map_err(|_| bad())?;
    whole
        .checked_mul(1_000_000)
        .and_then(|w| w.checked_add(fraction))
        .filter(|m| *m <= 1_000_000 * 1_000_000_000)
        .map(Duration::from_micros)
        .ok_or_else(bad)
}

/// What `tmcl run --help` prints after the options: the trace columns and the exit codes.
pub fn after_help() -> String {
    format!("{TRACE_HELP}\n\n{EXIT_CODES}")
}

/// Runs `tmcl run`.
pub(crate) fn run(args: RunArgs, json: bool) -> Result<(), CliError> {
    execute(&args, json)
}

/// What a run did, for the summary line.
struct Summary {
    simulated: Duration,
    wall: std::time::Duration,
    executed: u64,
    pc: u16,
    state: RunState,
    rows: u64,
}

fn execute(args: &RunArgs, json: bool) -> Result<(), CliError> {
    let source = Source::load(&args.file)?;
    let mut module = args.sim.build(&source)?;
    module.set_exact_ticks(args.exact_ticks);
    let bar = progress_bar(args.duration);
    let started = WallInstant::now();
    module
        .execute(Command::RunApplication { from: Some(0) }, Instant::ZERO)
        .map_err(|status| CliError::Usage(format!("the module refused to start the program: status {status}")))?;
    let rows = if args.trace.is_none() && args.plot.is_none() {
        run_coarse(&mut module, args.duration, &bar);
        0
    } else {
        let csv = match &args.trace {
            Some(path) => Some(BufWriter::new(
                File::create(path).map_err(|e| CliError::Io(format!("cannot create {}: {e}", path.display())))?,
            )),
            None => None,
        };
        let mut variables: BTreeSet<u8> = source.user_variables();
        variables.extend(args.sim.set.iter().filter_map(|s| match *s {
            crate::sim::Setting::Global { number, bank: crate::sim::USER_BANK, .. } => Some(number),
            _ => None,
        }));
        let mut trace = Trace::new(
            csv,
            args.plot.is_some(),
            variables.into_iter().collect(),
            args.drive,
            module.spec().axis.has(tmcl_core::model::Setting::ClosedLoop),
            module.spec().kinematics != tmcl_core::model::Kinematics::Pps,
        )?;
        let run = Traced { every: Duration::from_millis(args.every), end: Instant::ZERO + args.duration };
        run.run(&mut module, &source, &mut trace, &bar)?;
        trace.finish()?;
        if let Some(path) = &args.plot {
            let title = format!("{} on a simulated {}", args.file.display(), module.spec().name);
            plot::draw(path, &title, &trace.samples, &trace.events, &trace.levels, args.drive)
                .map_err(|e| CliError::Io(format!("cannot draw {}: {e}", path.display())))?;
        }
        trace.rows
    };
    bar.finish_and_clear();
    let summary = Summary {
        simulated: args.duration,
        wall: started.elapsed(),
        executed: module.vm().executed(),
        pc: module.vm().pc,
        state: module.vm().state,
        rows,
    };
    use std::io::Write;
    writeln!(std::io::stdout(), "{}", summary.line(json))?;
    Ok(())
}

impl Summary {
    fn line(&self, json: bool) -> String {
        let simulated = self.simulated.micros() as f64 / 1e6;
        let wall = self.wall.as_secs_f64();
        let ratio = simulated / wall.max(1e-9);
        let state = state_name(self.state);
        if json {
            format!(
                "{{\"simulated_s\":{simulated},\"wall_s\":{wall:.6},\"ratio\":{ratio:.0},\"executed\":{},\"pc\":{},\
                 \"state\":\"{state}\",\"rows\":{}}}",
                self.executed, self.pc, self.rows
            )
        } else {
            format!(
                "simulated {simulated} s in {wall:.3} s wall ({ratio:.0}x real time), {} instructions executed, \
                 pc {}, program {state}",
                self.executed, self.pc
            )
        }
    }
}

/// The program's run state in words.
pub(crate) fn state_name(state: RunState) -> &'static str {
    match state {
        RunState::Stopped => "stopped",
        RunState::Running => "running",
        RunState::Stepped => "stepped",
        RunState::Reset => "reset",
    }
}

/// A progress bar on stderr if it is a terminal, hidden otherwise (tests, pipes).
fn progress_bar(duration: Duration) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(duration.millis()), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("run [{bar:30}] {msg} simulated, {elapsed} wall")
            .unwrap_or(ProgressStyle::default_bar()),
    );
    bar
}

fn show_progress(bar: &ProgressBar, now: Instant) {
    bar.set_position(now.millis());
    bar.set_message(format!("{} s", now.millis() / 1000));
}

/// Runs without recording: polls only where the world changes by itself (an input timeline, a fault
/// window) and at the end, and every [`COARSE_STEP`] when a progress bar is shown. The module catches up
/// on every tick and instruction up to the time it is polled at, with the same result however often
/// that is; the board's world moves on by itself only when polled, so its changes are stepped on exactly.
fn run_coarse(module: &mut Module<SimBoard>, duration: Duration, bar: &ProgressBar) {
    let end = Instant::ZERO + duration;
    let mut t = Instant::ZERO;
    let progress = !bar.is_hidden();
    loop {
        // One poll runs at most `tmcl_core::vm::BUDGET` instructions (so that a poll always returns);
        // a program that runs without waiting gets further in each poll at the same time until it has
        // caught up, which its deadline says (it is then still `t` or before).
        // (A poll that executed nothing is the last: whatever its deadline says, no further poll at `t`
        // would get further.)
        loop {
            let executed = module.vm().executed();
            let behind = crate::sim::poll(module, t).is_some_and(|d| d <= t);
            if !behind || module.vm().executed() == executed {
                break;
            }
        }
        if progress {
            show_progress(bar, t);
        }
        if t >= end {
            break;
        }
        let world = module.board().next_event().filter(|e| *e > t).unwrap_or(end);
        t = if progress { (t + COARSE_STEP).min(end).min(world) } else { end.min(world) };
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
        _ if vm.state != RunState::Running => true,
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
}

impl Watch {
    fn of(module: &Module<SimBoard>) -> Watch {
        Watch {
            outputs: module.board().outputs(),
            running: module.vm().is_running(),
            target: module.ramp().target_position,
        }
    }
}

impl Traced {
    fn run(
        &self,
        module: &mut Module<SimBoard>,
        source: &Source,
        trace: &mut Trace<BufWriter<File>>,
        bar: &ProgressBar,
    ) -> Result<(), CliError> {
        let handlers = source.handler_addresses();
        for &address in &handlers {
            module.vm_mut().set_breakpoint(address, true);
        }
        let mut watch = Watch::of(module);
        let mut events: Vec<String> = Vec::new();
        let mut t = Instant::ZERO;
        let mut next_sample = Instant::ZERO;
        let mut stuck = 0u32;
        let mut last_executed = module.vm().executed();
        loop {
            let deadline = crate::sim::poll(module, t);
            trace.watch_io(module, t);
            events.clear();
            if module.vm().at_breakpoint() && module.vm().state == RunState::Stopped {
                // A handler's first instruction: name the interrupt(s) whose vector points here, go on.
                let pc = module.vm().pc;
                if module.vm().in_handler() {
                    let vm = module.vm();
                    events.extend(
                        (0..MAX_VECTORS as u8).filter(|&n| vm.vector(n) == Some(pc)).map(|n| format!("interrupt {n}")),
                    );
                }
                module
                    .execute(Command::RunApplication { from: None }, t)
                    .map_err(|status| CliError::Usage(format!("cannot resume the program: status {status}")))?;
                watch.running = true;
                if !events.is_empty() {
                    trace.record(module, t, &events)?;
                }
                continue; // the program goes on at the same time
            }
            self.changes(module, &mut watch, &mut events);
            let sample = t == next_sample;
            if sample || !events.is_empty() {
                trace.record(module, t, &events)?;
            }
            if sample {
                next_sample += self.every;
                if next_sample.millis() % 1000 < self.every.millis() {
                    show_progress(bar, t);
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
    fn changes(&self, module: &Module<SimBoard>, watch: &mut Watch, events: &mut Vec<String>) {
        let now = Watch::of(module);
        if now.target != watch.target && module.ramp().mode == Mode::Position {
            events.push(format!("target={}", now.target));
        }
        let changed = now.outputs ^ watch.outputs;
        for n in 0..8 {
            if changed >> n & 1 == 1 {
                events.push(format!("out{n}={}", now.outputs >> n & 1));
            }
        }
        if watch.running && !now.running {
            let vm = module.vm();
            let at_stop = module.program().get(usize::from(vm.pc)).is_some_and(|i| i.opcode == tmcl_wire::Opcode::Stop);
            events.push(if at_stop { "stop" } else { "end" }.to_string());
        }
        *watch = now;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_parse_exactly() {
        assert_eq!(parse_seconds("3600"), Ok(Duration::from_secs(3600)));
        assert_eq!(parse_seconds("0.5"), Ok(Duration::from_millis(500)));
        assert_eq!(parse_seconds(".25"), Ok(Duration::from_millis(250)));
        assert_eq!(parse_seconds("1.000001"), Ok(Duration::from_micros(1_000_001)));
        for bad in ["", ".", "-1", "1e3", "1.0000001", "x", "99999999999999999999"] {
            assert!(parse_seconds(bad).is_err(), "{bad}");
        }
    }
}

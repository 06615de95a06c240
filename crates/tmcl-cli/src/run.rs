//! `tmcl run`: assemble a program, load it into a simulated module and run it in simulated time.
//!
//! The argument parsing and the printing; the run itself, the trace and the plot are the `tmcl-run`
//! library's ([`tmcl_run::Simulation`], [`tmcl_run::Csv`], `tmcl_run::plot`), which documents how a run
//! steps through simulated time and when it records a row.

use crate::args::parse_sim_seconds;
use crate::error::{CliError, EXIT_CODES};
use crate::sim::SimOptions;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::fs::File;
use std::io::{BufWriter, IsTerminal};
use std::path::PathBuf;
use tmcl_core::{Duration, Instant};
use tmcl_run::{Csv, Options, RunError, Simulation, Sink, Tee, Trace};

/// The trace columns with their units, for `tmcl run --help`: one line per column (continuation lines
/// indented further), in the order of the CSV header; `--drive:` marks the columns of `--drive`, and
/// `--drive, closed loop:` those it adds on a closed-loop model. A test reads the names from here and
/// compares them with the header of a run.
pub const TRACE_HELP: &str = "\
Trace columns (--trace OUT.csv), in this order, one row every --every ms and one at each event.
`--drive:` marks the columns --drive adds, `--drive, closed loop:` those it adds on a closed-loop model
(--module tmcm-1310); `TMC428 units:` the column of the TMC428/429 generation (--module pd-113,
tmcm-1140):
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
  measured_velocity --drive, closed loop: AP 131 velocity measured at the encoder, pps
  velocity_units    TMC428 units: AP 3 in the module's own unit, a TMC428 velocity -2047..2047
                    (--module pd-113, tmcm-1140; `velocity` is the same in pps)
  event             `interrupt N` (handler entered), `stop` (STOP), `end` (a cell that does not
                    execute), `outN=V` (output changed), `target=N` (a new target position, e.g.
                    MVP; the row shows where the motor was then), `refused=pc N status S` (the
                    module refused the instruction at N and the program went on without it);
                    several are joined with `;`

On a model with several motors (--module tmcm-3110, tmcm-6110) the columns above are motor 0's; each
further motor M adds its own before `event`: target_position_mM, actual_position_mM, velocity_mM, with
--drive load_mM, current_scale_mM and encoder_mM, and velocity_units_mM; a new target of motor M is the
event `target_mM=N`. The plot then has a position and a velocity panel for each motor.

A column is read from the model's parameter table by meaning (the parameter with that role, whatever its
number); a column whose parameter the model lacks is left out (the PDx-113 with --drive has energy_a2s
only), never filled with zeros, and a value the module refuses to give is an empty cell.

The plot (--plot OUT.svg) draws, over time: target and actual position (in mm or degrees with --world,
in µsteps without); velocity; a logic-analyser lane for each reference switch (HOME, LEFT, RIGHT), input
(IN0..) and output (OUT0..) that changes and one for each kind of program event. With --drive also the
load value, the current scale (closed loop: the current scaler and the position error), the encoder
minus the step position, and the coil energy, each on its own axis with its unit. A signal that never
moves gets no panel but a line under the title with its value.
The run is deterministic: the same program and options give byte-identical traces.

Refused instructions: a program gets no status, so the module skips an instruction it refuses (status 3
wrong type, 4 invalid value, ...) and goes on. The run says so: a `refused:` line for each (source line,
instruction, pc, time, status and why: the model's parameter table, e.g. the allowed range), their
count on the summary line, a `refused=pc N status S` event in the trace, and with --json the list
(`refusals`: number, time_us, pc, instruction, opcode, kind, motor, value, status, file, line, reason).
`tmcl asm --module M` warns of the same where the tables decide it, before the program runs.";

/// Options of `tmcl run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The program: TMCL source (.tmc) or an image (.bin).
    pub file: PathBuf,
    #[command(flatten)]
    pub sim: SimOptions,
    /// How long to run, in simulated seconds (fractions allowed, down to µs).
    #[arg(long = "for", value_name = "SECONDS", value_parser = parse_sim_seconds)]
    pub duration: Duration,
    /// Write the trace to this CSV file (columns below).
    #[arg(long, value_name = "OUT.csv")]
    pub trace: Option<PathBuf>,
    /// Draw position, velocity, switches, inputs, outputs and events over time into this SVG file (panels
    /// below).
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
    state: &'static str,
    rows: u64,
    refusals: tmcl_run::Refusals,
}

/// `tmcl run --json`: the summary, and every instruction the module refused.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
pub struct RunJson {
    /// Simulated time, s.
    pub simulated_s: f64,
    /// Wall-clock time, s.
    pub wall_s: f64,
    /// Simulated time per wall-clock time.
    pub ratio: f64,
    /// Instructions executed.
    pub executed: u64,
    /// The program counter at the end.
    pub pc: u16,
    /// `stopped`, `running`, `stepped` or `reset`.
    pub state: String,
    /// Trace rows written (0 without a trace or plot).
    pub rows: u64,
    /// Instructions the module refused (the program skipped them and went on).
    pub refused: u64,
    /// Each refusal (the first 1000): time, pc, instruction, status, source line, reason.
    pub refusals: Vec<tmcl_run::Refused>,
}

/// In the text output, at most this many refusals are listed one by one.
const REFUSALS_SHOWN: usize = 20;

fn execute(args: &RunArgs, json: bool) -> Result<(), CliError> {
    let setup = args.sim.setup()?;
    let source = tmcl_run::Source::load(&args.file, setup.model)?;
    let mut simulation = Simulation::new(&source, &setup).map_err(crate::sim::setup_error)?;
    let options = Options {
        duration: args.duration,
        every: Duration::from_millis(args.every),
        drive: args.drive,
        exact_ticks: args.exact_ticks,
    };
    let bar = progress_bar(args.duration);
    let mut report = |t: Instant| show_progress(&bar, t);
    let progress: Option<&mut dyn FnMut(Instant)> = if bar.is_hidden() { None } else { Some(&mut report) };
    let csv = match &args.trace {
        Some(path) => Some(Csv::new(BufWriter::new(File::create(path).map_err(|source| CliError::Write {
            action: "create",
            path: path.clone(),
            source,
        })?))),
        None => None,
    };
    let mut trace = args.plot.as_ref().map(|_| Trace::new());
    let result = match (csv, trace.as_mut()) {
        (None, None) => simulation.run(&options, None, progress),
        (Some(mut csv), None) => simulation.run(&options, Some(&mut csv as &mut dyn Sink), progress),
        (None, Some(trace)) => simulation.run(&options, Some(trace as &mut dyn Sink), progress),
        (Some(csv), Some(trace)) => simulation.run(&options, Some(&mut Tee(csv, trace) as &mut dyn Sink), progress),
    };
    let done = result.map_err(|e| match e {
        RunError::Setup(e) => crate::sim::setup_error(e),
        RunError::Sink(e) => CliError::Output(e),
        other => CliError::Usage(other.to_string()),
    })?;
    if let (Some(path), Some(trace)) = (&args.plot, &trace) {
        let title = format!("{} on a simulated {}", args.file.display(), setup.model.name);
        tmcl_run::plot::write(trace, &title, path).map_err(|source| CliError::Draw { path: path.clone(), source })?;
    }
    bar.finish_and_clear();
    let summary = Summary {
        simulated: args.duration,
        wall: std::time::Duration::from_secs_f64(done.wall_s),
        executed: done.executed,
        pc: done.pc,
        state: done.state,
        rows: done.rows,
        refusals: simulation.refusals().clone(),
    };
    use std::io::Write;
    if !json {
        for r in summary.refusals.listed.iter().take(REFUSALS_SHOWN) {
            writeln!(std::io::stdout(), "refused: {}", r.describe())?;
        }
        let more = summary.refusals.count.saturating_sub(REFUSALS_SHOWN as u64);
        if more > 0 {
            writeln!(std::io::stdout(), "refused: … and {more} more (--json lists the first 1000)")?;
        }
    }
    writeln!(std::io::stdout(), "{}", summary.line(json))?;
    Ok(())
}

impl Summary {
    fn line(&self, json: bool) -> String {
        let simulated = self.simulated.micros() as f64 / 1e6;
        let wall = self.wall.as_secs_f64();
        let ratio = simulated / wall.max(1e-9);
        let state = self.state;
        if json {
            let row = RunJson {
                simulated_s: simulated,
                wall_s: (wall * 1e6).round() / 1e6,
                ratio: ratio.round(),
                executed: self.executed,
                pc: self.pc,
                state: state.to_string(),
                rows: self.rows,
                refused: self.refusals.count,
                refusals: self.refusals.listed.clone(),
            };
            serde_json::to_string(&row).unwrap_or_default()
        } else {
            let refused = match self.refusals.count {
                0 => String::new(),
                1 => ", 1 instruction refused".to_string(),
                n => format!(", {n} instructions refused"),
            };
            format!(
                "simulated {simulated} s in {wall:.3} s wall ({ratio:.0}x real time), {} instructions executed, \
                 pc {}, program {state}{refused}",
                self.executed, self.pc
            )
        }
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

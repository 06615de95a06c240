//! The trace of a simulated run: one row per sample and per program event, written as CSV.
//!
//! The columns, in order, with their units are listed once, in `tmcl run --help`
//! ([`crate::run::TRACE_HELP`]); a test checks that the header written here is the list given there.
//! [`FIXED_COLUMNS`] come first, then a `varN` column per user variable, then [`DRIVE_COLUMNS`] and
//! [`CLOSED_LOOP_COLUMNS`] with `--drive`, [`UNITS_COLUMN`] on a model with units of its own, and
//! `event` last.
//!
//! Every value is an integer, except two with six decimals that are formatted from integers: the time
//! (from integer microseconds) and the coil energy (from integer µA²·s). The same run gives byte-identical
//! files everywhere.
//!
//! For a plot the trace also keeps the samples, the events, and every change of the digital inputs and
//! outputs at the time it happened ([`Trace::watch_io`]), not only at the samples.

use std::fmt::Write as _;
use std::io::{self, Write};
use tmcl_core::hal::Inputs as _;
use tmcl_core::{Instant, Module};
use tmcl_sim::SimBoard;

/// The columns before the user variables.
pub(crate) const FIXED_COLUMNS: [&str; 8] =
    ["time_s", "target_position", "actual_position", "velocity", "accumulator", "x", "pc", "outputs"];
/// The columns `--drive` adds after the user variables.
pub(crate) const DRIVE_COLUMNS: [&str; 4] = ["load", "current_scale", "encoder", "energy_a2s"];
/// The columns `--drive` adds after [`DRIVE_COLUMNS`] on a closed-loop model.
pub(crate) const CLOSED_LOOP_COLUMNS: [&str; 4] = ["virtual_position", "position_error", "scaler", "status_word"];
/// The column a model with units of its own (the TMC428 generation) adds before `event`: AP 3 in them.
pub(crate) const UNITS_COLUMN: &str = "velocity_units";

/// With `--drive`: what the driver reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Drive {
    /// AP 206, the stallGuard2 load value 0..=1023.
    pub load: i32,
    /// AP 180, the coolStep current scale 0..=31 ((n + 1)/32 of the set current).
    pub current_scale: i32,
    /// AP 209, the encoder position in microsteps.
    pub encoder: i32,
    /// ∫ I_peak² dt of the coils since power-up, in µA²·s (millionths of an A²·s).
    pub energy: u64,
}

/// One sample kept for the plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Sample {
    /// Simulated time in µs.
    pub micros: u64,
    /// AP 0.
    pub target: i32,
    /// AP 1.
    pub actual: i32,
    /// AP 3.
    pub velocity: i32,
    /// With `--drive`: AP 206, AP 180, AP 209 and the coil energy.
    pub drive: Option<Drive>,
    /// With `--drive` on a closed-loop model: AP 233, AP 237, AP 123, AP 18.
    pub closed_loop: Option<[i32; 4]>,
}

/// One program event kept for the plot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Event {
    /// Simulated time in µs.
    pub micros: u64,
    /// `interrupt 0`, `stop`, `out0=1`, ...
    pub text: String,
}

/// The digital inputs and outputs from a time on (kept for the plot at every change).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Levels {
    /// Simulated time in µs.
    pub micros: u64,
    /// Bit n = INn.
    pub inputs: u8,
    /// Bit n = OUTn.
    pub outputs: u8,
}

/// Records rows: writes them as CSV (if asked to) and keeps samples and events for a plot (if asked to).
pub(crate) struct Trace<W: Write> {
    csv: Option<W>,
    keep: bool,
    variables: Vec<u8>,
    drive: bool,
    closed_loop: bool,
    units: bool,
    line: String,
    /// Samples, when kept.
    pub samples: Vec<Sample>,
    /// Events, when kept.
    pub events: Vec<Event>,
    /// The inputs and outputs at the start and after each change, when kept.
    pub levels: Vec<Levels>,
    /// Rows written.
    pub rows: u64,
}

impl<W: Write> Trace<W> {
    /// A trace of `variables` (user variable numbers, ascending) that writes CSV to `csv` and keeps
    /// samples and events in memory if `keep`.
    /// `closed_loop`: the model has a closed loop (its columns come with `drive`).
    /// `units`: the model's velocities are not in pps (AP 3 in its unit gets a column of its own).
    pub fn new(
        csv: Option<W>,
        keep: bool,
        variables: Vec<u8>,
        drive: bool,
        closed_loop: bool,
        units: bool,
    ) -> io::Result<Trace<W>> {
        let mut trace = Trace {
            csv,
            keep,
            variables,
            drive,
            closed_loop: drive && closed_loop,
            units,
            line: String::new(),
            samples: Vec::new(),
            events: Vec::new(),
            levels: Vec::new(),
            rows: 0,
        };
        if let Some(out) = &mut trace.csv {
            let mut header = FIXED_COLUMNS.join(",");
            for n in &trace.variables {
                let _ = write!(header, ",var{n}");
            }
            let drive: &[&str] = if trace.drive { &DRIVE_COLUMNS } else { &[] };
            let closed_loop: &[&str] = if trace.closed_loop { &CLOSED_LOOP_COLUMNS } else { &[] };
            for column in drive.iter().chain(closed_loop) {
                header.push(',');
                header.push_str(column);
            }
            if trace.units {
                header.push(',');
                header.push_str(UNITS_COLUMN);
            }
            header.push_str(",event\n");
            out.write_all(header.as_bytes())?;
        }
        Ok(trace)
    }

    /// Records the module's state at `now`, with the events that happened (empty for a plain sample).
    pub fn record(&mut self, module: &mut Module<SimBoard>, now: Instant, events: &[String]) -> io::Result<()> {
        let ramp = *module.ramp();
        let micros = now.micros();
        let drive = self.drive.then(|| {
            let mut ap = |n| module.get_axis(n).unwrap_or(0);
            let (load, current_scale, encoder) = (ap(206), ap(180), ap(209));
            // Rounded to an integer number of µA²·s, so traces stay byte-identical everywhere.
            let energy = (module.board().energy() * 1e6).round() as u64;
            Drive { load, current_scale, encoder, energy }
        });
        let closed_loop = self.closed_loop.then(|| [233, 237, 123, 18].map(|n| module.get_axis(n).unwrap_or(0)));
        // AP 1: the step counter, or the encoder while a closed loop is closed.
        let actual = if self.closed_loop || module.state().closed_loop().active {
            module.get_axis(1).unwrap_or(ramp.position)
        } else {
            ramp.position
        };
        if self.keep {
            self.samples.push(Sample {
                micros,
                target: ramp.target_position,
                actual,
                velocity: ramp.velocity(),
                drive,
                closed_loop,
            });
            self.events.extend(events.iter().map(|text| Event { micros, text: text.clone() }));
        }
        let Some(out) = &mut self.csv else { return Ok(()) };
        let regs = module.registers();
        let line = &mut self.line;
        line.clear();
        let _ = write!(
            line,
            "{},{},{},{},{},{},{},{}",
            seconds(micros),
            ramp.target_position,
            actual,
            ramp.velocity(),
            regs.accumulator,
            regs.x,
            module.vm().pc,
            module.board().outputs()
        );
        for &n in &self.variables {
            let v = module.get_global(n, super::USER_BANK, now).unwrap_or(0);
            let _ = write!(line, ",{v}");
        }
        if let Some(Drive { load, current_scale, encoder, energy }) = drive {
            let _ = write!(line, ",{load},{current_scale},{encoder},{}", seconds(energy));
        }
        if let Some([virtual_position, error, scaler, status]) = closed_loop {
            let _ = write!(line, ",{virtual_position},{error},{scaler},{status}");
        }
        if self.units {
            let _ = write!(line, ",{}", module.get_axis(3).unwrap_or(0));
        }
        line.push(',');
        line.push_str(&events.join(";"));
        line.push('\n');
        self.rows += 1;
        out.write_all(line.as_bytes())
    }

    /// Notes the digital inputs and outputs at `now` if they changed since the last call (or if this is
    /// the first), for the plot's logic-analyser lanes. Called after every poll, so a change is kept at
    /// the time it happened, between samples too. Nothing is written to the CSV file.
    pub fn watch_io(&mut self, module: &mut Module<SimBoard>, now: Instant) {
        if !self.keep {
            return;
        }
        let outputs = module.board().outputs();
        let inputs = module.board_timeline().digital_inputs();
        if self.levels.last().is_none_or(|l| (l.inputs, l.outputs) != (inputs, outputs)) {
            self.levels.push(Levels { micros: now.micros(), inputs, outputs });
        }
    }

    /// Flushes the CSV output.
    pub fn finish(&mut self) -> io::Result<()> {
        match &mut self.csv {
            Some(out) => out.flush(),
            None => Ok(()),
        }
    }
}

/// Integer millionths as a decimal number with six decimals (no floating point: the same everywhere):
/// microseconds as seconds, µA²·s as A²·s.
pub(crate) fn seconds(micros: u64) -> String {
    format!("{}.{:06}", micros / 1_000_000, micros % 1_000_000)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_are_exact() {
        assert_eq!(seconds(0), "0.000000");
        assert_eq!(seconds(1_000_020), "1.000020");
        assert_eq!(seconds(3_600_000_000), "3600.000000");
    }
}

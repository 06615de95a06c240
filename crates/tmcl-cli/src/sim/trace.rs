//! The trace of a simulated run: one row per sample and per program event, written as CSV.
//!
//! Columns, in order (also in `tmcl run --help`):
//!
//! | column | meaning |
//! |---|---|
//! | `time_s` | simulated time in seconds, with 6 decimals (µs) |
//! | `target_position` | AP 0, microsteps |
//! | `actual_position` | AP 1, microsteps (the encoder's position while a closed loop is closed) |
//! | `velocity` | AP 3, the actual speed in pps (signed) |
//! | `accumulator`, `x` | the program's accumulator and X register |
//! | `pc` | the program counter (GP 130): the next instruction |
//! | `outputs` | the digital outputs as a number, bit n = OUTn |
//! | `varN` | user variable N (bank 2), one column per variable the program names or `--set` writes |
//! | `load`, `current_scale`, `encoder`, `energy_mas2` | with `--drive`: AP 206, AP 180, AP 209, and the motor's energy in mA²·s |
//! | `virtual_position`, `position_error`, `scaler`, `status_word` | with `--drive` on a closed-loop model (TMCM-1310): AP 233, AP 237, AP 123, AP 18 |
//! | `event` | what happened at this time: `interrupt N`, `stop`, `end`, `out0=1`, `target=N`, … (`;`-separated) |
//!
//! Every value is an integer and the time is formatted from integer microseconds, so the same run gives
//! byte-identical files.

use std::fmt::Write as _;
use std::io::{self, Write};
use tmcl_core::{Instant, Module};
use tmcl_sim::SimBoard;

/// The columns before the user variables.
pub(crate) const FIXED_COLUMNS: [&str; 8] =
    ["time_s", "target_position", "actual_position", "velocity", "accumulator", "x", "pc", "outputs"];

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
    /// With `--drive`: AP 206, AP 180, AP 209.
    pub drive: Option<(i32, i32, i32)>,
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

/// Records rows: writes them as CSV (if asked to) and keeps samples and events for a plot (if asked to).
pub(crate) struct Trace<W: Write> {
    csv: Option<W>,
    keep: bool,
    variables: Vec<u8>,
    drive: bool,
    closed_loop: bool,
    line: String,
    /// Samples, when kept.
    pub samples: Vec<Sample>,
    /// Events, when kept.
    pub events: Vec<Event>,
    /// Rows written.
    pub rows: u64,
}

impl<W: Write> Trace<W> {
    /// A trace of `variables` (user variable numbers, ascending) that writes CSV to `csv` and keeps
    /// samples and events in memory if `keep`.
    /// `closed_loop`: the model has a closed loop (its columns come with `drive`).
    pub fn new(csv: Option<W>, keep: bool, variables: Vec<u8>, drive: bool, closed_loop: bool) -> io::Result<Trace<W>> {
        let mut trace = Trace {
            csv,
            keep,
            variables,
            drive,
            closed_loop: drive && closed_loop,
            line: String::new(),
            samples: Vec::new(),
            events: Vec::new(),
            rows: 0,
        };
        if let Some(out) = &mut trace.csv {
            let mut header = FIXED_COLUMNS.join(",");
            for n in &trace.variables {
                let _ = write!(header, ",var{n}");
            }
            if trace.drive {
                header.push_str(",load,current_scale,encoder,energy_mas2");
            }
            if trace.closed_loop {
                header.push_str(",virtual_position,position_error,scaler,status_word");
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
            (ap(206), ap(180), ap(209))
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
        if let Some((load, scale, encoder)) = drive {
            // Energy in mA²·s, rounded to an integer so traces stay byte-identical everywhere.
            let energy = (module.board().energy() * 1e6).round() as i64;
            let _ = write!(line, ",{load},{scale},{encoder},{energy}");
        }
        if let Some([virtual_position, error, scaler, status]) = closed_loop {
            let _ = write!(line, ",{virtual_position},{error},{scaler},{status}");
        }
        line.push(',');
        line.push_str(&events.join(";"));
        line.push('\n');
        self.rows += 1;
        out.write_all(line.as_bytes())
    }

    /// Flushes the CSV output.
    pub fn finish(&mut self) -> io::Result<()> {
        match &mut self.csv {
            Some(out) => out.flush(),
            None => Ok(()),
        }
    }
}

/// Integer microseconds as seconds with six decimals (no floating point: the same everywhere).
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

//! What `tmcl run` and `tmcl debug` share: a simulated module with a program in it.
//!
//! - [`SimOptions`]: `--module`, `--set` and `--world`, and [`SimOptions::build`], which makes the
//!   [`Module<SimBoard>`] (in-memory EEPROM, factory defaults), applies the settings and loads the program.
//! - [`Source`]: the program as assembled (labels, source lines) or read from a `.bin` image.
//! - [`trace`]: the trace recorder and its CSV file; [`plot`]: the SVG plot of a trace.
//!
//! Everything here runs in simulated time, starting at 0: the same inputs give the same results.

pub(crate) mod plot;
pub(crate) mod trace;

use crate::error::CliError;
use clap::Args;
use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;
use tmcl_core::model::{self, ModelSpec};
use tmcl_core::{Instant, Module};
use tmcl_sim::SimBoard;
use tmcl_wire::{Command, Instruction};

/// User variables live in global parameter bank 2 (PD28-1021 manual §5.3).
pub(crate) const USER_BANK: u8 = 2;

/// Options shared by `tmcl run` and `tmcl debug`: which module, its settings, its world.
#[derive(Debug, Clone, Args)]
pub struct SimOptions {
    /// The module to simulate.
    #[arg(long, value_name = "MODEL", default_value = "pd28-1021")]
    pub module: String,
    /// Set a parameter before the program starts: apN=V (axis parameter N of motor 0), gpN=V (global
    /// parameter N, bank 0) or gpN.B=V (bank B; bank 2 holds the user variables). Repeatable.
    #[arg(long = "set", value_name = "apN=V|gpN=V|gpN.B=V")]
    pub set: Vec<Setting>,
    /// The world around the motor: a TOML world file (motor, axis, switches, loads, inputs over time,
    /// faults; see docs/world.md). Without it, a free axis.
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
}

/// One `--set`: a parameter and its value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// `apN=V`: axis parameter N of motor 0 (SAP).
    Axis {
        /// Parameter number.
        number: u8,
        /// Value.
        value: i32,
    },
    /// `gpN=V` or `gpN.B=V`: global parameter N of bank B (SGP).
    Global {
        /// Parameter number.
        number: u8,
        /// Bank (0 unless given).
        bank: u8,
        /// Value.
        value: i32,
    },
}

impl Setting {
    /// The command that applies it.
    pub fn command(self) -> Command {
        match self {
            Setting::Axis { number, value } => Command::Sap { param: number, motor: 0, value },
            Setting::Global { number, bank, value } => Command::Sgp { param: number, bank, value },
        }
    }
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Setting::Axis { number, value } => write!(f, "ap{number}={value}"),
            Setting::Global { number, bank: 0, value } => write!(f, "gp{number}={value}"),
            Setting::Global { number, bank, value } => write!(f, "gp{number}.{bank}={value}"),
        }
    }
}

impl FromStr for Setting {
    type Err = String;

    fn from_str(s: &str) -> Result<Setting, String> {
        let usage = || format!("`{s}` is not a setting: write apN=V, gpN=V or gpN.B=V");
        let (name, value) = s.split_once('=').ok_or_else(usage)?;
        let value = parse_number(value.trim()).ok_or_else(|| format!("`{}` is not a 32-bit number", value.trim()))?;
        let name = name.trim().to_ascii_lowercase();
        if let Some(n) = name.strip_prefix("ap") {
            let number = n.parse().map_err(|_| usage())?;
            return Ok(Setting::Axis { number, value });
        }
        let n = name.strip_prefix("gp").ok_or_else(usage)?;
        let (number, bank) = match n.split_once('.') {
            Some((n, b)) => (n.parse().map_err(|_| usage())?, b.parse().map_err(|_| usage())?),
            None => (n.parse().map_err(|_| usage())?, 0),
        };
        Ok(Setting::Global { number, bank, value })
    }
}

/// A decimal or `0x` hexadecimal number, possibly negative.
pub(crate) fn parse_number(s: &str) -> Option<i32> {
    let (negative, digits) = match s.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, s.strip_prefix('+').unwrap_or(s)),
    };
    let magnitude = match digits.strip_prefix("0x").or_else(|| digits.strip_prefix("0X")) {
        Some(hex) => i64::from_str_radix(hex, 16).ok()?,
        None => digits.parse::<i64>().ok()?,
    };
    let v = if negative { -magnitude } else { magnitude };
    // Hexadecimal may spell a negative value as its 32-bit pattern (0xFFFFFFFF = −1).
    i32::try_from(v).ok().or_else(|| (!negative && v <= i64::from(u32::MAX)).then_some(v as u32 as i32))
}

/// The program to simulate, with what the debugger and the trace need to know about it.
#[derive(Debug, Clone)]
pub struct Source {
    /// Instructions, labels, constants and source lines (no labels or lines for a `.bin` image).
    pub program: tmcl_asm::Program,
    /// The file it came from.
    pub path: PathBuf,
}

impl Source {
    /// Reads a program: TMCL source (assembled with the built-in include files) or a `.bin` image.
    pub fn load(path: &Path) -> Result<Source, CliError> {
        let program = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bin")) {
            let instructions = crate::program::load(path)?;
            tmcl_asm::Program { instructions, ..tmcl_asm::Program::default() }
        } else {
            crate::program::assemble(path)?
        };
        Ok(Source { program, path: path.to_path_buf() })
    }

    /// The label at `address`, if any (the first by name).
    pub fn label_at(&self, address: u16) -> Option<&str> {
        self.program.labels.iter().find(|(_, a)| **a == address).map(|(name, _)| name.as_str())
    }

    /// The instruction at `address`, if the program has one there.
    pub fn instruction(&self, address: u16) -> Option<Instruction> {
        self.program.instructions.get(usize::from(address)).copied()
    }

    /// The user variables (bank 2) the program names in SGP, GGP, AGP, STGP or RSGP, in order.
    pub fn user_variables(&self) -> BTreeSet<u8> {
        self.program
            .instructions
            .iter()
            .filter_map(|i| match Command::decode(*i).ok()? {
                Command::Sgp { param, bank: USER_BANK, .. }
                | Command::Ggp { param, bank: USER_BANK }
                | Command::Agp { param, bank: USER_BANK }
                | Command::Stgp { param, bank: USER_BANK }
                | Command::Rsgp { param, bank: USER_BANK } => Some(param),
                _ => None,
            })
            .collect()
    }

    /// Every address a VECT instruction names: where interrupt handlers may start.
    pub fn handler_addresses(&self) -> BTreeSet<u16> {
        self.program
            .instructions
            .iter()
            .filter_map(|i| match Command::decode(*i).ok()? {
                Command::Vect { address, .. } => u16::try_from(address).ok(),
                _ => None,
            })
            .collect()
    }

    /// Where the instruction at `address` came from: `file:line`, and the file name for reading.
    pub fn place(&self, address: u16) -> Option<(Arc<str>, u32)> {
        self.program.source(address).map(|l| (l.file.clone(), l.line))
    }
}

impl SimOptions {
    /// The model `--module` names.
    pub fn spec(&self) -> Result<&'static ModelSpec, CliError> {
        model::by_id(&self.module).ok_or_else(|| {
            let known: Vec<&str> = model::MODELS.iter().map(|m| m.id).collect();
            CliError::Usage(format!("unknown module `{}`; known: {}", self.module, known.join(", ")))
        })
    }

    /// A fresh module at time 0 with the settings applied and the program loaded (not started).
    pub fn build(&self, source: &Source) -> Result<Module<SimBoard>, CliError> {
        let spec = self.spec()?;
        let mut module = Module::new(board(spec, self.world.as_deref())?, spec, Instant::ZERO);
        for setting in &self.set {
            module.execute(setting.command(), Instant::ZERO).map_err(|status| {
                CliError::Usage(format!("--set {setting}: the module refused it, status {status}"))
            })?;
        }
        let wrong = tmcl_asm::check_model(&source.program, spec, &mut crate::asm::source_line);
        if !wrong.is_empty() {
            for d in &wrong {
                eprintln!("{d}");
            }
            return Err(CliError::Usage(format!(
                "{}: {} command(s) the {} does not have",
                source.path.display(),
                wrong.len(),
                spec.name
            )));
        }
        let memory = usize::from(spec.program_memory);
        if source.program.instructions.len() > memory {
            return Err(CliError::Usage(format!(
                "{}: {} instructions do not fit into the {}'s {memory} program cells",
                source.path.display(),
                source.program.instructions.len(),
                spec.name
            )));
        }
        module
            .load_program(&source.program.instructions)
            .map_err(|status| CliError::Usage(format!("cannot load the program: status {status}")))?;
        Ok(module)
    }
}

/// A board of the model (its profile: encoder, driver, inputs, outputs) with an in-memory EEPROM, in the
/// world a TOML world file describes (`docs/world.md`), or on the simulator's default free axis.
fn board(spec: &'static ModelSpec, world: Option<&Path>) -> Result<SimBoard, CliError> {
    let board = SimBoard::in_memory_for(spec);
    let Some(path) = world else { return Ok(board) };
    let world = tmcl_sim::World::load(path).map_err(|e| CliError::Usage(e.to_string()))?;
    board.with_world(world).map_err(|e| CliError::Usage(format!("{}: {e}", path.display())))
}

/// Polls the module at `t`, then lets its world catch up to `t`: the board moves on by itself only when
/// the driver is updated, which a motor at rest is not, so without this an input timeline or a fault
/// window would stall while the motor stands. Returns the module's next deadline, or the world's next
/// change if that comes first: a run never steps over a change of an input.
pub(crate) fn poll(module: &mut Module<SimBoard>, t: Instant) -> Option<Instant> {
    let deadline = module.poll(t, &mut |_: &[u8]| {});
    module.board_timeline().advance(t);
    match (deadline, module.board().next_event()) {
        (Some(d), Some(e)) => Some(d.min(e)),
        (d, e) => d.or(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_parse() {
        assert_eq!("ap4=51200".parse(), Ok(Setting::Axis { number: 4, value: 51200 }));
        assert_eq!("gp66=2".parse(), Ok(Setting::Global { number: 66, bank: 0, value: 2 }));
        assert_eq!("GP42.2=-7".parse(), Ok(Setting::Global { number: 42, bank: 2, value: -7 }));
        assert_eq!("gp0.3=0x3E8".parse(), Ok(Setting::Global { number: 0, bank: 3, value: 1000 }));
        assert_eq!("ap1=0xFFFFFFFF".parse(), Ok(Setting::Axis { number: 1, value: -1 }));
        for bad in ["ap4", "xp4=1", "ap=1", "ap4=one", "gp1.=1", "ap300=1", "ap1=99999999999"] {
            assert!(bad.parse::<Setting>().is_err(), "{bad}");
        }
        assert_eq!(Setting::Global { number: 42, bank: 2, value: -7 }.to_string(), "gp42.2=-7");
    }
}

//! What a run starts from: the program ([`Source`]) and the module it runs on ([`Setup`]: model, settings,
//! world).
//!
//! [`Setup::build`] makes the [`Module<SimBoard>`] (in-memory EEPROM, factory defaults), applies the
//! settings and loads the program; `tmcl run`, `tmcl debug` and the Python package all start here.
//! Everything runs in simulated time, starting at 0: the same inputs give the same results.

use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;
use tmcl_core::model::{self, ModelSpec};
use tmcl_core::{Instant, Module};
use tmcl_sim::{SimBoard, World};
use tmcl_wire::{Command, Instruction, Status};

/// User variables live in global parameter bank 2 (PD28-1021 manual §5.3).
pub const USER_BANK: u8 = 2;

/// One setting applied before the program starts: a parameter and its value (`ap4=51200`, `gp66=2`,
/// `gp42.2=-7` as text).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// `apN=V` or `apN.M=V`: axis parameter N of motor M (0 unless given; SAP).
    Axis {
        /// Parameter number.
        number: u8,
        /// Motor (0 unless given).
        motor: u8,
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
            Setting::Axis { number, motor, value } => Command::Sap { param: number, motor, value },
            Setting::Global { number, bank, value } => Command::Sgp { param: number, bank, value },
        }
    }

    /// The user variable (bank 2) it sets, if it sets one.
    pub fn user_variable(self) -> Option<u8> {
        match self {
            Setting::Global { number, bank: USER_BANK, .. } => Some(number),
            _ => None,
        }
    }
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Setting::Axis { number, motor: 0, value } => write!(f, "ap{number}={value}"),
            Setting::Axis { number, motor, value } => write!(f, "ap{number}.{motor}={value}"),
            Setting::Global { number, bank: 0, value } => write!(f, "gp{number}={value}"),
            Setting::Global { number, bank, value } => write!(f, "gp{number}.{bank}={value}"),
        }
    }
}

impl FromStr for Setting {
    type Err = String;

    fn from_str(s: &str) -> Result<Setting, String> {
        let usage = || format!("`{s}` is not a setting: write apN=V, apN.M=V, gpN=V or gpN.B=V");
        let (name, value) = s.split_once('=').ok_or_else(usage)?;
        let value = parse_value(value.trim()).ok_or_else(|| format!("`{}` is not a 32-bit number", value.trim()))?;
        let name = name.trim().to_ascii_lowercase();
        // The parameter number and what follows the dot: a motor (ap) or a bank (gp), 0 if none.
        let numbers = |n: &str| -> Result<(u8, u8), String> {
            match n.split_once('.') {
                Some((n, b)) => Ok((n.parse().map_err(|_| usage())?, b.parse().map_err(|_| usage())?)),
                None => Ok((n.parse().map_err(|_| usage())?, 0)),
            }
        };
        if let Some(n) = name.strip_prefix("ap") {
            let (number, motor) = numbers(n)?;
            return Ok(Setting::Axis { number, motor, value });
        }
        let n = name.strip_prefix("gp").ok_or_else(usage)?;
        let (number, bank) = numbers(n)?;
        Ok(Setting::Global { number, bank, value })
    }
}

/// A setting's value: a decimal or `0x` hexadecimal number, possibly negative; up to `0xFFFFFFFF`, read as
/// its 32-bit pattern (`0xFFFFFFFF` = −1). One parser for every tool ([`tmcl_wire::ascii::parse_number`]).
pub fn parse_value(s: &str) -> Option<i32> {
    tmcl_wire::ascii::parse_number(s).and_then(tmcl_wire::ascii::value32)
}

/// Why a program cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The file cannot be read.
    #[error("cannot read {path}: {error}")]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// A `.bin` image that is not one.
    #[error("{name}: {error}")]
    Image {
        /// The image's name.
        name: String,
        /// Why.
        error: tmcl_asm::BinError,
    },
    /// Source with assembly errors.
    #[error("{name}: {} error{}", diagnostics.len(), if diagnostics.len() == 1 { "" } else { "s" })]
    Assembly {
        /// The source's name.
        name: String,
        /// The errors, each with its place.
        diagnostics: Vec<tmcl_asm::Diagnostic>,
    },
}

/// The program to run, with what the trace and a debugger need to know about it.
#[derive(Debug, Clone)]
pub struct Source {
    /// Instructions, labels, constants and source lines (no labels or lines for a `.bin` image).
    pub program: tmcl_asm::Program,
    /// The file it came from, or the name given to source text.
    pub path: PathBuf,
}

/// Include files from disk, and the built-in ones of `model`.
fn resolver(model: &'static ModelSpec) -> tmcl_asm::FileResolver {
    tmcl_asm::FileResolver { include_dirs: Vec::new(), builtins: tmcl_asm::BuiltinResolver { model } }
}

impl Source {
    /// Reads a program for `model`: TMCL source, assembled with the model's built-in include files
    /// (`TMCLParam.tmc`, `Interrupts.inc`: its own parameter names, and the names the other models give
    /// the meanings it shares) and those next to it; or, for a `.bin` file, an image (8 bytes per
    /// instruction).
    pub fn load(path: &Path, model: &'static ModelSpec) -> Result<Source, SourceError> {
        if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bin")) {
            let bytes =
                std::fs::read(path).map_err(|error| SourceError::Unreadable { path: path.to_path_buf(), error })?;
            return Source::from_image(&path.display().to_string(), &bytes);
        }
        let program = tmcl_asm::assemble_file(path, &mut resolver(model))
            .map_err(|diagnostics| SourceError::Assembly { name: path.display().to_string(), diagnostics })?;
        Ok(Source { program, path: path.to_path_buf() })
    }

    /// Assembles source text for `model` (its built-in include files, as [`Source::load`]); `name` names it
    /// in diagnostics and is the base of relative `#include`s.
    pub fn assemble(name: &str, text: &str, model: &'static ModelSpec) -> Result<Source, SourceError> {
        let program = tmcl_asm::assemble_str(name, text, &mut resolver(model))
            .map_err(|diagnostics| SourceError::Assembly { name: name.to_string(), diagnostics })?;
        Ok(Source { program, path: PathBuf::from(name) })
    }

    /// A program from a `.bin` image (8 bytes per instruction); it has no labels or source lines.
    pub fn from_image(name: &str, bytes: &[u8]) -> Result<Source, SourceError> {
        let instructions =
            tmcl_asm::from_bin(bytes).map_err(|error| SourceError::Image { name: name.to_string(), error })?;
        Ok(Source { program: tmcl_asm::Program { instructions, ..tmcl_asm::Program::default() }, path: name.into() })
    }

    /// A program from instructions.
    pub fn from_instructions(name: &str, instructions: Vec<Instruction>) -> Source {
        Source { program: tmcl_asm::Program { instructions, ..tmcl_asm::Program::default() }, path: name.into() }
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

    /// Where the instruction at `address` came from: the file's name and the line.
    pub fn place(&self, address: u16) -> Option<(Arc<str>, u32)> {
        self.program.source(address).map(|l| (l.file.clone(), l.line))
    }
}

/// Why a module cannot be set up for a program.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// No model has this id.
    #[error(transparent)]
    UnknownModel(#[from] model::UnknownModel),
    /// A world that does not fit the module (or cannot be read).
    #[error("{0}")]
    World(String),
    /// The module refused a setting.
    #[error("--set {setting}: the module refused it, status {status}")]
    Setting {
        /// The setting.
        setting: Setting,
        /// The TMCL status of the refusal.
        status: Status,
    },
    /// The program uses commands the model does not have (each diagnostic at its line).
    #[error("{name}: {} command(s) the {model} does not have", diagnostics.len())]
    Commands {
        /// The program's name.
        name: String,
        /// The model's product name.
        model: &'static str,
        /// One diagnostic per instruction.
        diagnostics: Vec<tmcl_asm::Diagnostic>,
    },
    /// The program is longer than the model's program memory.
    #[error("{name}: {len} instructions do not fit into the {model}'s {memory} program cells")]
    TooLong {
        /// The program's name.
        name: String,
        /// Its instructions.
        len: usize,
        /// The model's product name.
        model: &'static str,
        /// The model's program memory, in instructions.
        memory: usize,
    },
    /// Loading the program failed.
    #[error("cannot load the program: status {0}")]
    Load(Status),
}

/// The module a program runs on: the model, the settings applied before the start, and its world.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The model.
    pub model: &'static ModelSpec,
    /// Parameters set before the program starts, in order.
    pub settings: Vec<Setting>,
    /// The world around the motor (`docs/world.md`); `None` for the simulator's default free axis.
    pub world: Option<World>,
}

impl Setup {
    /// A module of the model with this id (`pd28-1021`, `tmcm-1310`, `pd-113`), factory settings, free axis.
    pub fn new(model: &str) -> Result<Setup, SetupError> {
        let model = model::find(model)?;
        Ok(Setup { model, settings: Vec::new(), world: None })
    }

    /// With a world (a TOML world file read by [`World::load`] or [`World::from_toml_str`]).
    pub fn with_world(mut self, world: World) -> Setup {
        self.world = Some(world);
        self
    }

    /// With a setting applied before the start (after those given before).
    pub fn with_setting(mut self, setting: Setting) -> Setup {
        self.settings.push(setting);
        self
    }

    /// A fresh module at time 0 with the settings applied and the program loaded (not started). A program
    /// with commands the model lacks is refused with a diagnostic per instruction; `line_text` gives the
    /// text of a source line for them (the file's name and the line from 1).
    pub fn build(
        &self,
        source: &Source,
        line_text: &mut dyn FnMut(&str, u32) -> Option<String>,
    ) -> Result<Module<SimBoard>, SetupError> {
        let spec = self.model;
        let board = SimBoard::in_memory_for(spec);
        let board = match &self.world {
            Some(world) => board.with_world(world.clone()).map_err(|e| SetupError::World(e.to_string()))?,
            None => board,
        };
        let mut module = Module::new(board, spec, Instant::ZERO);
        for &setting in &self.settings {
            module
                .execute(setting.command(), Instant::ZERO)
                .map_err(|status| SetupError::Setting { setting, status })?;
        }
        let name = || source.path.display().to_string();
        let wrong = tmcl_asm::check_model(&source.program, spec, line_text);
        if !wrong.is_empty() {
            return Err(SetupError::Commands { name: name(), model: spec.name, diagnostics: wrong });
        }
        let memory = usize::from(spec.program_memory);
        let len = source.program.instructions.len();
        if len > memory {
            return Err(SetupError::TooLong { name: name(), len, model: spec.name, memory });
        }
        module.load_program(&source.program.instructions).map_err(SetupError::Load)?;
        Ok(module)
    }
}

/// Polls the module at `t`, then lets its world catch up to `t`: the board moves on by itself only when
/// the driver is updated, which a motor at rest is not, so without this an input timeline or a fault
/// window would stall while the motor stands. Returns the module's next deadline, or the world's next
/// change if that comes first: a run never steps over a change of an input.
pub fn poll(module: &mut Module<SimBoard>, t: Instant) -> Option<Instant> {
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
        assert_eq!("ap4=51200".parse(), Ok(Setting::Axis { number: 4, motor: 0, value: 51200 }));
        assert_eq!("ap4.2=300".parse(), Ok(Setting::Axis { number: 4, motor: 2, value: 300 }));
        assert_eq!(Setting::Axis { number: 4, motor: 2, value: 300 }.to_string(), "ap4.2=300");
        assert_eq!("gp66=2".parse(), Ok(Setting::Global { number: 66, bank: 0, value: 2 }));
        assert_eq!("GP42.2=-7".parse(), Ok(Setting::Global { number: 42, bank: 2, value: -7 }));
        assert_eq!("gp0.3=0x3E8".parse(), Ok(Setting::Global { number: 0, bank: 3, value: 1000 }));
        assert_eq!("ap1=0xFFFFFFFF".parse(), Ok(Setting::Axis { number: 1, motor: 0, value: -1 }));
        for bad in ["ap4", "xp4=1", "ap=1", "ap4=one", "gp1.=1", "ap300=1", "ap1=99999999999", "ap4.=1", "ap4.256=1"] {
            assert!(bad.parse::<Setting>().is_err(), "{bad}");
        }
        assert_eq!(Setting::Global { number: 42, bank: 2, value: -7 }.to_string(), "gp42.2=-7");
    }

    #[test]
    fn source_text_and_images_give_the_same_program() {
        let pd28 = model::by_id("pd28-1021").unwrap();
        let text = Source::assemble("p.tmc", "Loop: ROL 0, 500\nWAIT TICKS, 0, 10\nJA Loop\n", pd28).unwrap();
        assert_eq!(text.label_at(0), Some("Loop"));
        let image = Source::from_image("p.bin", &text.program.to_bin()).unwrap();
        assert_eq!(image.program.instructions, text.program.instructions);
        assert!(matches!(Source::from_image("x.bin", &[1, 2, 3]), Err(SourceError::Image { .. })));
        let Err(SourceError::Assembly { diagnostics, .. }) = Source::assemble("bad.tmc", "FROB 1\n", pd28) else {
            panic!("an unknown mnemonic is an error")
        };
        assert_eq!(diagnostics[0].line, 1);
    }

    #[test]
    fn the_built_in_include_files_are_the_models() {
        // AP 129 is the TMCM-1310's closed-loop mode; the PD28-1021 has no parameter of that name.
        let text = "#include TMCLParam.tmc\nSAP APClosedLoopMode, 0, 1\nSTOP\n";
        let tmcm = model::by_id("tmcm-1310").unwrap();
        let source = Source::assemble("cl.tmc", text, tmcm).unwrap();
        let first = Command::decode(source.program.instructions[0]).unwrap();
        assert_eq!(first, Command::Sap { param: 129, motor: 0, value: 1 });
        let pd28 = model::by_id("pd28-1021").unwrap();
        assert!(matches!(Source::assemble("cl.tmc", text, pd28), Err(SourceError::Assembly { .. })));
        // A name the models share (AP 4, the maximum positioning speed) assembles for each.
        for spec in model::MODELS {
            let source = Source::assemble("v.tmc", "#include TMCLParam.tmc\nSAP APMaxPositioningSpeed, 0, 100\n", spec);
            assert!(source.is_ok(), "{}", spec.id);
        }
    }
}

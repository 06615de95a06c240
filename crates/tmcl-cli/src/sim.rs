//! What `tmcl run` and `tmcl debug` share: the options that say which simulated module to build, on top
//! of the `tmcl-run` library (which builds it, runs it and records the trace).

pub(crate) use tmcl_run::{Setting, Source};

use crate::error::CliError;
use clap::Args;
use std::path::PathBuf;
use tmcl_core::Module;
use tmcl_run::{Setup, SetupError, SourceError};
use tmcl_sim::SimBoard;

/// Options shared by `tmcl run` and `tmcl debug`: which module, its settings, its world.
#[derive(Debug, Clone, Args)]
pub struct SimOptions {
    /// The module to simulate: pd28-1021, tmcm-1310, pd-113, tmcm-1140, tmcm-3110 or
    /// tmcm-6110.
    #[arg(long, value_name = "MODEL", default_value = "pd28-1021")]
    pub module: String,
    /// Set a parameter before the program starts: apN=V (axis parameter N of motor 0), apN.M=V (of motor
    /// M), gpN=V (global parameter N, bank 0) or gpN.B=V (bank B; bank 2 holds the user variables).
    /// Repeatable.
    #[arg(long = "set", value_name = "apN=V|apN.M=V|gpN=V|gpN.B=V")]
    pub set: Vec<Setting>,
    /// The world around the motor: a TOML world file (motor, axis, switches, loads, inputs over time,
    /// faults; see docs/world.md). Without it, a free axis.
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
}

impl SimOptions {
    /// The module, its settings and its world as the library takes them.
    pub fn setup(&self) -> Result<Setup, CliError> {
        let mut setup = Setup::new(&self.module).map_err(setup_error)?;
        setup.settings = self.set.clone();
        if let Some(path) = &self.world {
            let world = tmcl_sim::World::load(path)?;
            // Checked against the model here, so that the error names the file.
            SimBoard::in_memory_for(setup.model)
                .with_world(world.clone())
                .map_err(|source| CliError::Unfit { path: path.clone(), source })?;
            setup.world = Some(world);
        }
        Ok(setup)
    }

    /// The program in `path`, assembled with the built-in include files of the chosen model.
    pub fn load(&self, path: &std::path::Path) -> Result<Source, CliError> {
        let model = tmcl_core::model::find(&self.module).map_err(|e| setup_error(SetupError::UnknownModel(e)))?;
        Ok(Source::load(path, model)?)
    }

    /// A fresh module at time 0 with the settings applied and the program loaded (not started).
    pub fn build(&self, source: &Source) -> Result<Module<SimBoard>, CliError> {
        self.setup()?.build(source, &mut crate::asm::source_line).map_err(setup_error)
    }
}

/// A program that cannot be read: assembly errors with their places, or an input error.
impl From<SourceError> for CliError {
    fn from(e: SourceError) -> CliError {
        match e {
            SourceError::Assembly { name, diagnostics } => CliError::Assembly { file: name, diagnostics },
            other => CliError::Source(other),
        }
    }
}

/// A setup error as the CLI reports it: the diagnostics of commands the model lacks on stderr, each at
/// its line.
pub(crate) fn setup_error(e: SetupError) -> CliError {
    if let SetupError::Commands { diagnostics, .. } = &e {
        for d in diagnostics {
            eprintln!("{d}");
        }
    }
    CliError::Setup(e)
}

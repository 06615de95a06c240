//! `tmcl twin`: the twin of a module for CI. It reads a module's parameters (all of them, as
//! `tmcl params --save` does) and its downloaded program (command 134, PD28-1021 manual §3.7.38), then
//! writes them into a virtual module of the same model whose EEPROM is a file, by the same TMCL commands a
//! host would send (SAP + STAP, SGP + STGP, the program by 132/133): the image is made by the firmware
//! itself, never by hand. `tmcl serve --module MODEL --eeprom DIR/MODEL.eeprom` then starts a module that
//! answers as the original did after a power cycle.
//!
//! What an EEPROM image cannot carry is said, not hidden: settings without E or A in the tables (volatile,
//! lost at power-up on the real module too) and the reply switch (GP 255).

use crate::connection::{Connection, HostClient};
use crate::error::CliError;
use crate::names::{ModelOption, Models};
use crate::params::write_whole;
use clap::Args;
use serde::Serialize;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;
use tmcl_core::model::{ModelSpec, Role, Setting};
use tmcl_core::param::persist;
use tmcl_core::{Instant, Module};
use tmcl_host::paramset::{self as params, Kind, LoadOptions, ParamFile};
use tmcl_host::{Client, Transport};
use tmcl_sim::{Eeprom, FileNvm, SimBoard};
use tmcl_wire::Command;

/// Options of `tmcl twin`.
#[derive(Debug, Args)]
pub struct TwinArgs {
    #[command(flatten)]
    pub conn: Connection,
    #[command(flatten)]
    pub model: ModelOption,
    /// The directory to write the twin to: MODEL.eeprom, params.toml, program.tmc, world.toml.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// The name of the twin's EEPROM image in its directory.
pub(crate) fn image_name(model: &ModelSpec) -> String {
    format!("{}.eeprom", model.id)
}

/// What `tmcl twin` made (its `--json` line).
#[derive(Debug, Serialize)]
struct Made {
    model: &'static str,
    eeprom: String,
    params: String,
    program: Option<String>,
    world: String,
    parameters: usize,
    stored: usize,
    instructions: usize,
    volatile: Vec<String>,
    refused: Vec<String>,
    serve: String,
}

/// A virtual module of `model` with its EEPROM in the file `image` (made anew), and a client on it at
/// address 1.
fn virtual_module(model: &'static ModelSpec, image: &Path) -> Result<HostClient, CliError> {
    // The image and its journal (tmcl-sim's crash-safe file) are made anew.
    let mut journal = image.as_os_str().to_owned();
    journal.push(".journal");
    for path in [image, Path::new(&journal)] {
        match std::fs::remove_file(path) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(source) => return Err(CliError::Write { action: "replace", path: path.to_path_buf(), source }),
        }
    }
    let nvm = FileNvm::open(image, persist::capacity(model))?;
    let module = Module::new(SimBoard::for_model(model, Eeprom::File(nvm)), model, Instant::ZERO);
    let transport = tmcl_serve::InProcess::new(module);
    Ok(Client::new(Box::new(transport) as Box<dyn Transport + Send>).with_timeout(Duration::from_millis(200)))
}

/// A world file to start from: the motor's full steps as the module's tables say, the rest the default
/// world, commented (docs/world.md).
fn world_stub(model: &ModelSpec, set: &ParamFile) -> String {
    let full_steps = model
        .axis
        .params
        .iter()
        .find(|d| d.setting == Some(Setting::MotorFullSteps))
        .and_then(|d| set.params.iter().find(|e| e.kind == Kind::Ap && e.number == d.number && e.motor == Some(0)))
        .map_or(200, |e| e.value);
    format!(
        "# The world of the twin of a {name} (`tmcl twin`): what the module drives. The module's parameters\n\
         # are in its EEPROM image; what it drives is not in any parameter: describe it here (docs/world.md)\n\
         # and serve the twin with --world.\n\n\
         [motor]\n\
         full_steps = {full_steps}\n\n\
         # [axis]\n# kind = \"linear\"\n# lead = \"2 mm\"\n\n\
         # [switches.left]\n# at = \"0 mm\"\n",
        name = model.name,
    )
}

/// `tmcl twin`.
pub(crate) fn run(args: TwinArgs, json: bool) -> Result<(), CliError> {
    let mut models = Models::new(&args.model)?;
    let mut client = args.conn.open()?;
    let model = models.get(&mut client)?;
    std::fs::create_dir_all(&args.out).map_err(|source| CliError::Write {
        action: "create",
        path: args.out.clone(),
        source,
    })?;

    // 1. The module as it is: every parameter, and the program.
    let (set, notes) = params::snapshot(&mut client, model)?;
    for note in &notes {
        eprintln!("tmcl twin: {note}");
    }
    let program = client.upload_program(model.program_memory, |_| {})?;
    let params_path = args.out.join("params.toml");
    write_whole(&params_path, &params::to_toml(&set).map_err(CliError::Io)?)?;
    let program_path = (!program.is_empty()).then(|| args.out.join("program.tmc"));
    if let Some(path) = &program_path {
        let text = format!(
            "// The program of the module the twin was made of (`tmcl twin`), read back with command 134.\n{}",
            tmcl_asm::disassemble(&program, tmcl_asm::DisasmOptions { addresses: true })
        );
        write_whole(path, &text)?;
    }
    let world_path = args.out.join("world.toml");
    write_whole(&world_path, &world_stub(model, &set))?;

    // 2. The same into a virtual module whose EEPROM is the image: the address last, so the requests
    //    before it reach the module at its start address; never the reply switch.
    let image = args.out.join(image_name(model));
    let mut twin = virtual_module(model, &image)?;
    let is_address = |e: &params::Entry| e.kind == Kind::Gp && e.bank == Some(0) && e.number == 66;
    let mut ordered = set.clone();
    ordered.params.retain(|e| !(e.kind == Kind::Gp && e.bank == Some(0) && e.number == 255));
    ordered.params.sort_by_key(is_address);
    // The twin is ours: its protected parameters are unlocked with the model's password (TMCM-1310
    // manual §3.7, status 8) so that the real module's values reach its image.
    let lock = model.global.params.iter().find(|d| d.role == Role::Password);
    if let (Some(password), Some(desc)) = (model.password, lock) {
        twin.request(Command::Sgp { param: desc.number, bank: 0, value: password }.encode())?;
    }
    let outcomes = params::load(&mut twin, model, &ordered, LoadOptions { store: true, interface: true })?;
    if let Some(address) = ordered.params.iter().find(|e| is_address(e)) {
        twin.module_address = u8::try_from(address.value).unwrap_or(twin.module_address);
    }
    if !program.is_empty() {
        twin.download_program(&program, 0, |_| {})?;
    }
    let stored = outcomes.iter().filter(|o| o.result == "stored").count();
    // Volatile settings matter only where they differ from the factory default the twin starts with.
    let volatile: Vec<String> = outcomes
        .iter()
        .zip(&ordered.params)
        .filter(|(o, e)| o.result == "written" && params::default_of(model, e) != Some(e.value))
        .map(|(o, _)| o)
        .map(|o| format!("{} {} = {}", o.param, o.name, o.value))
        .collect();
    let refused: Vec<String> = outcomes
        .iter()
        .filter(|o| o.result == "refused")
        .map(|o| format!("{} {}: {}", o.param, o.name, o.why.clone().unwrap_or_default()))
        .collect();
    drop(twin);

    let serve = format!(
        "tmcl serve --module {} --eeprom {} --world {} --pty LINK",
        model.id,
        image.display(),
        world_path.display()
    );
    let mut out = io::stdout().lock();
    if json {
        let made = Made {
            model: model.id,
            eeprom: image.display().to_string(),
            params: params_path.display().to_string(),
            program: program_path.as_ref().map(|p| p.display().to_string()),
            world: world_path.display().to_string(),
            parameters: set.params.len(),
            stored,
            instructions: program.len(),
            volatile,
            refused: refused.clone(),
            serve,
        };
        writeln!(out, "{}", serde_json::to_string(&made)?)?;
    } else {
        writeln!(
            out,
            "the twin of the {} is in {}: {} parameters read, {stored} stored in {}, a program of {} instructions",
            model.name,
            args.out.display(),
            set.params.len(),
            image.display(),
            program.len()
        )?;
        if !volatile.is_empty() {
            writeln!(
                out,
                "set on the module but not in the image (no E or A in the tables: lost at power-up on the real module \
                 too): {}",
                volatile.join(", ")
            )?;
        }
        for r in &refused {
            writeln!(out, "refused by the virtual module: {r}")?;
        }
        writeln!(out, "serve it with: {serve}")?;
    }
    if !refused.is_empty() {
        return Err(CliError::Refused(format!("{} parameters could not be carried into the twin", refused.len())));
    }
    Ok(())
}

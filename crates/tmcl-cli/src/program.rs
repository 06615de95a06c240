//! Host commands for standalone programs: `tmcl download`, `upload`, `start`, `stop`, `status`
//! (PD28-1021 manual §3.7.38, commands 128–135), for real and virtual modules alike.

use crate::connection::Connection;
use crate::error::{CliError, EXIT_CODES};
use crate::output::{json_line, Downloaded, ProgramStatus, Started, Stopped, Uploaded};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::path::{Path, PathBuf};
use tmcl_asm::DisasmOptions;
use tmcl_wire::Instruction;

/// Program commands.
#[derive(Debug, Subcommand)]
pub enum ProgramCommand {
    /// Download a program (.tmc source, assembled first, or a .bin image) into the module's memory.
    #[command(after_help = EXIT_CODES)]
    Download(DownloadArgs),
    /// Read the program back from the module (command 134) and disassemble it.
    #[command(after_help = EXIT_CODES)]
    Upload(UploadArgs),
    /// Run the stored program (command 129), from where it stands or from a label or address.
    #[command(after_help = EXIT_CODES)]
    Start(StartArgs),
    /// Stop the stored program (command 128).
    #[command(after_help = EXIT_CODES)]
    Stop {
        #[command(flatten)]
        conn: Connection,
    },
    /// Show the program's state: mode, wait flag, PC, accumulator, X (commands 135, GP 128–130).
    #[command(after_help = EXIT_CODES)]
    Status {
        #[command(flatten)]
        conn: Connection,
    },
}

impl ProgramCommand {
    /// The command's name, for error messages.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            ProgramCommand::Download(_) => "download",
            ProgramCommand::Upload(_) => "upload",
            ProgramCommand::Start(_) => "start",
            ProgramCommand::Stop { .. } => "stop",
            ProgramCommand::Status { .. } => "status",
        }
    }
}

/// `tmcl download`.
#[derive(Debug, Args)]
pub struct DownloadArgs {
    #[command(flatten)]
    pub conn: Connection,
    /// The program: TMCL source (.tmc) or an image (.bin, 8 bytes per instruction).
    pub file: PathBuf,
    /// First address to store at.
    #[arg(long, value_name = "ADDR", default_value_t = 0)]
    pub at: u16,
    /// Read the program back afterwards and compare.
    #[arg(long)]
    pub verify: bool,
}

/// `tmcl upload`.
#[derive(Debug, Args)]
pub struct UploadArgs {
    #[command(flatten)]
    pub conn: Connection,
    /// Write to FILE instead of standard output (.bin writes the image, anything else source).
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Read at most N instructions (reading stops at the first empty cell anyway).
    #[arg(long, value_name = "N", default_value_t = 2048)]
    pub count: u16,
}

/// `tmcl start`.
#[derive(Debug, Args)]
pub struct StartArgs {
    #[command(flatten)]
    pub conn: Connection,
    /// Start at a label or address instead of the current PC (command 129 type 1).
    #[arg(long = "at", value_name = "LABEL|ADDR")]
    pub at: Option<String>,
    /// The source the labels come from (or a symbol file written by `tmcl asm --symbols`).
    #[arg(long, value_name = "FILE")]
    pub program: Option<PathBuf>,
}

/// Runs a program command.
pub(crate) fn run(cmd: ProgramCommand, json: bool) -> Result<(), CliError> {
    let out = &mut std::io::stdout().lock();
    match cmd {
        ProgramCommand::Download(args) => download(args, json, out),
        ProgramCommand::Upload(args) => upload(args, json, out),
        ProgramCommand::Start(args) => start(args, json, out),
        ProgramCommand::Stop { conn } => stop(conn, json, out),
        ProgramCommand::Status { conn } => status(conn, json, out),
    }
}

/// `tmcl download`: assembles or reads the program, stores it from `--at` (commands 132, 133) and reads it
/// back with `--verify` (134).
fn download(args: DownloadArgs, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let program = load(&args.file)?;
    let mut client = args.conn.open()?;
    let bar = progress(program.len() as u64, "download");
    let mut stored = 0;
    let downloaded = client.download_program(&program, args.at, |n| {
        stored = n;
        bar.set_position(n as u64)
    });
    bar.finish_and_clear();
    if let Err(source) = downloaded {
        // Say how far it got: the module holds the first `stored` instructions, the rest is whatever
        // was there before.
        let end = usize::from(args.at) + stored;
        return Err(CliError::Explained {
            source,
            explanation: format!(
                "download interrupted: {stored} of {} instructions stored (addresses {}..{end}); the \
                 program in the module is incomplete, download it again",
                program.len(),
                args.at
            ),
        });
    }
    if args.verify {
        for (n, expected) in program.iter().enumerate() {
            let got = client.read_program_memory(args.at + n as u16)?;
            if got != *expected {
                return Err(CliError::Io(format!(
                    "verify failed at address {}: stored {got}, expected {expected}",
                    usize::from(args.at) + n
                )));
            }
        }
    }
    if json {
        let verified = args.verify;
        json_line(out, &Downloaded { at: args.at, stored: program.len(), verified })?;
    } else {
        writeln!(
            out,
            "stored {} instructions at {}..{}{}",
            program.len(),
            args.at,
            usize::from(args.at) + program.len(),
            if args.verify { ", verified" } else { "" }
        )?;
    }
    Ok(())
}

/// `tmcl upload`: reads the program back (command 134) and disassembles it.
fn upload(args: UploadArgs, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let mut client = args.conn.open()?;
    let bar = progress(u64::from(args.count), "upload");
    let program = client.upload_program(args.count, |n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    let output =
        |source: std::io::Error, path: &Path| CliError::Write { action: "write", path: path.to_path_buf(), source };
    match &args.output {
        Some(path) if path.extension().is_some_and(|e| e == "bin") => {
            std::fs::write(path, tmcl_asm::to_bin(&program)).map_err(|e| output(e, path))?;
        }
        Some(path) => std::fs::write(path, disassemble(&program)).map_err(|e| output(e, path))?,
        None if json => {}
        None => out.write_all(disassemble(&program).as_bytes())?,
    }
    match (&args.output, json) {
        (Some(path), true) => {
            json_line(out, &Uploaded { output: Some(path.display().to_string()), read: program.len(), source: None })?
        }
        (None, true) => {
            let source = disassemble(&program);
            json_line(out, &Uploaded { output: None, read: program.len(), source: Some(source) })?
        }
        (Some(_), false) => eprintln!("read {} instructions", program.len()),
        (None, false) => {}
    }
    Ok(())
}

/// `tmcl start`: runs the stored program (command 129), from a label or address with `--at`.
fn start(args: StartArgs, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let at = match &args.at {
        None => None,
        Some(at) => Some(resolve(at, args.program.as_deref())?),
    };
    args.conn.open()?.run_program(at)?;
    match (at, json) {
        (at, true) => json_line(out, &Started { from: at, running: true })?,
        (Some(a), false) => writeln!(out, "running from {a}")?,
        (None, false) => writeln!(out, "running")?,
    }
    Ok(())
}

/// `tmcl stop` (command 128).
fn stop(conn: Connection, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    conn.open()?.stop_program()?;
    if json {
        json_line(out, &Stopped { stopped: true })?;
    } else {
        writeln!(out, "stopped")?;
    }
    Ok(())
}

/// `tmcl status`: the program's state (command 135, or GP 130 where 135 answers the state alone).
fn status(conn: Connection, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let mut client = conn.open()?;
    // A model whose 135 answers the state alone, whatever the type (the PDx-113, its manual §5.5),
    // has no accumulator or X register to ask for, and its program counter is GP 130 (asking 135
    // types 1 to 3 would print the state three times). Which form a module has follows from its
    // version string.
    let model = client.version_string().ok().and_then(|text| tmcl_core::model::by_version(&text));
    if let Some(model) = model.filter(|m| m.app_status == tmcl_core::model::AppStatusReply::Plain) {
        let request = tmcl_wire::Command::GetStatus { kind: tmcl_wire::StatusKind::MemoryPointer };
        let mode = client.request(request.encode())?.value as u8;
        let text = tmcl_host::ApplicationStatus::name_of(mode);
        let pc = match model.global.role(tmcl_core::model::Role::ProgramCounter) {
            Some(i) => Some(client.get_global_parameter(model.global.params[i].number, 0)?),
            None => None,
        };
        match (json, pc) {
            (true, pc) => {
                let row = ProgramStatus { accumulator: None, mode, mode_text: text, pc, waiting: None, x: None };
                json_line(out, &row)?
            }
            (false, Some(pc)) => writeln!(out, "{text}, pc {pc}")?,
            (false, None) => writeln!(out, "{text}")?,
        }
        return Ok(());
    }
    let s = client.application_status()?;
    if json {
        let row = ProgramStatus {
            accumulator: Some(s.accumulator),
            mode: s.mode,
            mode_text: s.mode_name(),
            pc: Some(i32::from(s.pc)),
            waiting: Some(s.waiting),
            x: Some(s.x),
        };
        json_line(out, &row)?;
    } else {
        writeln!(
            out,
            "{}{}, pc {}, accumulator {}, x {}",
            s.mode_name(),
            if s.waiting { " (waiting)" } else { "" },
            s.pc,
            s.accumulator,
            s.x
        )?;
    }
    Ok(())
}

fn progress(len: u64, what: &'static str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} {per_sec}")
            .unwrap_or(ProgressStyle::default_bar()),
    );
    bar.set_prefix(what);
    bar
}

fn disassemble(program: &[Instruction]) -> String {
    tmcl_asm::disassemble(program, DisasmOptions::default())
}

/// Reads a program: a `.bin` image, or TMCL source assembled with the built-in include files.
pub(crate) fn load(path: &Path) -> Result<Vec<Instruction>, CliError> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bin")) {
        let bytes = std::fs::read(path).map_err(|source| CliError::Read { path: path.to_path_buf(), source })?;
        return tmcl_asm::from_bin(&bytes)
            .map_err(|e| CliError::Content { path: path.to_path_buf(), source: e.into() });
    }
    Ok(assemble(path)?.instructions)
}

/// Assembles a source file (with the built-in include files).
pub(crate) fn assemble(path: &Path) -> Result<tmcl_asm::Program, CliError> {
    tmcl_asm::assemble(path).map_err(|diagnostics| CliError::Assembly { file: path.display().to_string(), diagnostics })
}

/// A start address: a number, or a label from the program's source or symbol file.
fn resolve(at: &str, program: Option<&Path>) -> Result<u16, CliError> {
    if let Ok(a) = at.parse::<u16>() {
        return Ok(a);
    }
    let Some(path) = program else {
        return Err(CliError::Usage(format!(
            "`{at}` is a label: give --program FILE.tmc (or a .sym file) to resolve it"
        )));
    };
    let labels: Vec<(String, u16)> = if path.extension().is_some_and(|e| e == "sym") {
        std::fs::read_to_string(path)
            .map_err(|source| CliError::Read { path: path.to_path_buf(), source })?
            .lines()
            .filter_map(|l| {
                let (name, addr) = l.split_once(char::is_whitespace)?;
                Some((name.to_string(), addr.trim().parse().ok()?))
            })
            .collect()
    } else {
        assemble(path)?.labels.into_iter().collect()
    };
    labels
        .iter()
        .find(|(name, _)| name == at)
        .map(|(_, a)| *a)
        .ok_or_else(|| CliError::Usage(format!("no label `{at}` in {}", path.display())))
}

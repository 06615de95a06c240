//! Host commands for standalone programs: `tmcl download`, `upload`, `start`, `stop`, `status`
//! (PD28-1021 manual §3.7.38, commands 128–135), for real and virtual modules alike.

use crate::host::{CliError, Connection};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tmcl_asm::DisasmOptions;
use tmcl_wire::Instruction;

/// Program commands.
#[derive(Debug, Subcommand)]
pub enum ProgramCommand {
    /// Download a program (.tmc source, assembled first, or a .bin image) into the module's memory.
    Download(DownloadArgs),
    /// Read the program back from the module (command 134) and disassemble it.
    Upload(UploadArgs),
    /// Run the stored program (command 129), from where it stands or from a label or address.
    Start(StartArgs),
    /// Stop the stored program (command 128).
    Stop,
    /// Show the program's state: mode, wait flag, PC, accumulator, X (commands 135, GP 128–130).
    Status,
}

/// `tmcl download`.
#[derive(Debug, Args)]
pub struct DownloadArgs {
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
    /// Start at a label or address instead of the current PC (command 129 type 1).
    #[arg(long = "at", value_name = "LABEL|ADDR")]
    pub at: Option<String>,
    /// The source the labels come from (or a symbol file written by `tmcl asm --symbols`).
    #[arg(long, value_name = "FILE")]
    pub program: Option<PathBuf>,
}

/// Runs a program command.
pub fn run(conn: &Connection, cmd: ProgramCommand) -> ExitCode {
    match execute(conn, cmd) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("tmcl: {err}");
            ExitCode::from(err.exit_code())
        }
    }
}

fn execute(conn: &Connection, cmd: ProgramCommand) -> Result<(), CliError> {
    match cmd {
        ProgramCommand::Download(args) => {
            let program = load(&args.file)?;
            let mut client = conn.open()?;
            let bar = progress(program.len() as u64, "download");
            client.download_program(&program, args.at, |n| bar.set_position(n as u64))?;
            bar.finish_and_clear();
            if args.verify {
                for (n, expected) in program.iter().enumerate() {
                    let got = client.read_program_memory(args.at + n as u16)?;
                    if got != *expected {
                        return Err(CliError::Usage(format!(
                            "verify failed at address {}: stored {got}, expected {expected}",
                            usize::from(args.at) + n
                        )));
                    }
                }
            }
            if conn.json {
                println!("{{\"stored\":{},\"at\":{}}}", program.len(), args.at);
            } else {
                println!(
                    "stored {} instructions at {}..{}",
                    program.len(),
                    args.at,
                    usize::from(args.at) + program.len()
                );
            }
            Ok(())
        }
        ProgramCommand::Upload(args) => {
            let mut client = conn.open()?;
            let bar = progress(u64::from(args.count), "upload");
            let program = client.upload_program(args.count, |n| bar.set_position(n as u64))?;
            bar.finish_and_clear();
            match &args.output {
                Some(path) if path.extension().is_some_and(|e| e == "bin") => {
                    std::fs::write(path, tmcl_asm::to_bin(&program))?;
                }
                Some(path) => std::fs::write(path, disassemble(&program))?,
                None => std::io::stdout().write_all(disassemble(&program).as_bytes())?,
            }
            if args.output.is_some() {
                eprintln!("read {} instructions", program.len());
            }
            Ok(())
        }
        ProgramCommand::Start(args) => {
            let at = match &args.at {
                None => None,
                Some(at) => Some(resolve(at, args.program.as_deref())?),
            };
            conn.open()?.run_program(at)?;
            match at {
                Some(a) => println!("running from {a}"),
                None => println!("running"),
            }
            Ok(())
        }
        ProgramCommand::Stop => {
            conn.open()?.stop_program()?;
            println!("stopped");
            Ok(())
        }
        ProgramCommand::Status => {
            let s = conn.open()?.application_status()?;
            if conn.json {
                println!(
                    "{{\"mode\":{},\"mode_text\":\"{}\",\"waiting\":{},\"pc\":{},\"accumulator\":{},\"x\":{}}}",
                    s.mode,
                    s.mode_name(),
                    s.waiting,
                    s.pc,
                    s.accumulator,
                    s.x
                );
            } else {
                println!(
                    "{}{}, pc {}, accumulator {}, x {}",
                    s.mode_name(),
                    if s.waiting { " (waiting)" } else { "" },
                    s.pc,
                    s.accumulator,
                    s.x
                );
            }
            Ok(())
        }
    }
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
        let bytes = std::fs::read(path).map_err(|e| CliError::Usage(format!("cannot read {}: {e}", path.display())))?;
        return tmcl_asm::from_bin(&bytes).map_err(|e| CliError::Usage(format!("{}: {e}", path.display())));
    }
    Ok(assemble(path)?.instructions)
}

/// Assembles a source file, printing every diagnostic.
pub(crate) fn assemble(path: &Path) -> Result<tmcl_asm::Program, CliError> {
    tmcl_asm::assemble(path).map_err(|diagnostics| {
        for d in &diagnostics {
            eprintln!("{d}");
        }
        CliError::Usage(format!("{}: {} error(s)", path.display(), diagnostics.len()))
    })
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
            .map_err(|e| CliError::Usage(format!("cannot read {}: {e}", path.display())))?
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

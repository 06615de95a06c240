//! `tmcl`: virtual TMCL modules and host commands for real and virtual ones.

mod asm;
mod bus;
mod debug;
mod host;
mod program;
mod pty;
mod run;
mod serve;
mod sim;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// OpenTMCL: virtual TMCL modules, and host commands for real and virtual modules.
#[derive(Debug, Parser)]
#[command(name = "tmcl", version, about, long_about = None)]
struct Cli {
    #[command(flatten)]
    connection: host::Connection,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a virtual module on a pty (--pty LINK) or a TCP port (--tcp HOST:PORT) until SIGINT/SIGTERM.
    Serve(serve::ServeArgs),
    /// Assemble a TMCL source file into a .bin image (8 bytes per instruction).
    Asm(asm::AsmArgs),
    /// Disassemble a .bin image into TMCL source.
    Disasm(asm::DisasmArgs),
    /// Run a program on a simulated module in simulated time: trace (CSV), plot (SVG), summary.
    #[command(after_help = run::TRACE_HELP)]
    Run(run::RunArgs),
    /// Debug a program on a simulated module: breakpoints, stepping, registers (commands from stdin).
    #[command(after_help = debug::COMMANDS_HELP)]
    Debug(debug::DebugArgs),
    #[command(flatten)]
    Host(host::HostCommand),
    #[command(flatten)]
    Program(program::ProgramCommand),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Serve(args) => serve::run(&cli.connection, args),
        Command::Asm(args) => asm::run_asm(args),
        Command::Disasm(args) => asm::run_disasm(args),
        Command::Run(args) => run::run(&cli.connection, args),
        Command::Debug(args) => debug::run(args),
        Command::Host(command) => host::run(&cli.connection, command),
        Command::Program(command) => program::run(&cli.connection, command),
    }
}

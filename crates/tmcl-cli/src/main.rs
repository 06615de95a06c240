//! `tmcl`: virtual TMCL modules and host commands for real and virtual ones.

mod host;
mod pty;
mod serve;

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
    #[command(flatten)]
    Host(host::HostCommand),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Serve(args) => serve::run(&cli.connection, args),
        Command::Host(command) => host::run(&cli.connection, command),
    }
}

//! `tmcl`: virtual TMCL modules and host commands for real and virtual ones.

mod host;

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
    #[command(flatten)]
    Host(host::HostCommand),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Host(command) => host::run(&cli.connection, command),
    }
}

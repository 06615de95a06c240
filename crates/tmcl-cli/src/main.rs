//! `tmcl`: virtual TMCL modules and host commands for real and virtual ones.

mod args;
mod asm;
mod connection;
mod debug;
mod error;
mod esi;
mod host;
mod log;
mod names;
mod output;
mod params;
mod program;
mod run;
mod serve;
mod share;
mod sim;
mod twin;
mod ui;
mod watch;

use clap::{Parser, Subcommand};
use error::{CliError, EXIT_CODES};
use std::ffi::OsString;

use std::process::ExitCode;

/// OpenTMCL: virtual TMCL modules, and host commands for real and virtual modules.
#[derive(Debug, Parser)]
#[command(name = "tmcl", version, about, long_about = None, after_help = EXIT_CODES)]
struct Cli {
    /// Print results and errors as JSON objects, one per line, on standard output.
    #[arg(long, global = true)]
    json: bool,
    /// Log more on stderr (never stdout): -v what the servers do (tmcl serve and tmcl share: every
    /// request and reply; the workbench: pages, links), -vv details, -vvv everything. RUST_LOG, if set,
    /// takes the place of -v (e.g. RUST_LOG=tmcl_ui=debug).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a virtual module on a pty (--pty LINK) or a TCP port (--tcp HOST:PORT) until SIGINT/SIGTERM.
    #[command(after_help = EXIT_CODES)]
    Serve(serve::ServeArgs),
    /// Share one module (a real one on a serial port) between several hosts, each on a link of its own
    /// (--pty A --pty B --tcp ADDR): one transaction at a time, each reply to the host that asked.
    #[command(after_help = EXIT_CODES)]
    Share(share::ShareArgs),
    /// Watch every transaction of a `tmcl share` or `tmcl serve` as it happens: time, host, request and
    /// reply decoded, status, round trip.
    #[command(after_help = EXIT_CODES)]
    Monitor(share::MonitorArgs),
    /// Assemble a TMCL source file into a .bin image (8 bytes per instruction).
    #[command(after_help = EXIT_CODES)]
    Asm(asm::AsmArgs),
    /// Disassemble a .bin image into TMCL source.
    #[command(after_help = EXIT_CODES)]
    Disasm(asm::DisasmArgs),
    /// Run a program on a simulated module in simulated time: trace (CSV), plot (SVG), summary.
    #[command(after_help = run::after_help())]
    Run(run::RunArgs),
    /// Debug a program on a simulated module: breakpoints, stepping, registers (commands from stdin).
    #[command(after_help = debug::after_help())]
    Debug(debug::DebugArgs),
    /// Serve the browser workbench of a module: parameters, motion, live plots, I/O, console, program
    /// editor and debugger (open the printed address in a browser).
    #[command(after_help = EXIT_CODES)]
    Ui(ui::UiArgs),
    /// Write the ESI file (EtherCAT Slave Information XML) of a module with EtherCAT, as TwinCAT,
    /// CODESYS or the IgH master read it; it says what the virtual module's SII EEPROM says.
    #[command(after_help = EXIT_CODES)]
    Esi(esi::EsiArgs),
    /// Make the twin of a module for CI: read its parameters and program, write an EEPROM image (and a
    /// world stub) that `tmcl serve --eeprom` serves as that module.
    #[command(after_help = EXIT_CODES)]
    Twin(twin::TwinArgs),
    #[command(flatten)]
    Host(host::HostCommand),
    #[command(flatten)]
    Program(program::ProgramCommand),
}

impl Command {
    /// The subcommand's name, for error messages.
    fn name(&self) -> &'static str {
        match self {
            Command::Serve(_) => "serve",
            Command::Share(_) => "share",
            Command::Monitor(_) => "monitor",
            Command::Asm(_) => "asm",
            Command::Disasm(_) => "disasm",
            Command::Run(_) => "run",
            Command::Debug(_) => "debug",
            Command::Ui(_) => "ui",
            Command::Esi(_) => "esi",
            Command::Twin(_) => "twin",
            Command::Host(c) => c.name(),
            Command::Program(c) => c.name(),
        }
    }
}

/// The subcommands that talk to a module: they take the connection options.
const HOST_COMMANDS: &[&str] = &[
    "version", "get", "set", "store", "restore", "send", "scan", "params", "wait", "watch", "download", "upload",
    "start", "stop", "status", "ui", "twin", "share",
];

/// Options of the host commands that take a value and may come before the command's name: the connection
/// options, and `--module` (the model whose parameter names are meant).
const CONNECTION_OPTIONS: &[&str] = &["--port", "--baud", "--tcp", "--address", "--timeout", "--module"];

/// Lets connection options come before the subcommand, as in `tmcl --port LINK get ap 4`: they are moved
/// behind the subcommand's name when the subcommand talks to a module. For any other subcommand they stay
/// where they are, and clap refuses them (they would mean nothing there).
fn hoist_connection_options(args: Vec<OsString>) -> Vec<OsString> {
    let mut leading = Vec::new();
    let mut i = 1;
    while i < args.len() {
        let Some(arg) = args[i].to_str() else { break };
        let name = arg.split_once('=').map_or(arg, |(n, _)| n);
        if CONNECTION_OPTIONS.contains(&name) {
            leading.push(args[i].clone());
            if !arg.contains('=') && i + 1 < args.len() {
                leading.push(args[i + 1].clone());
                i += 1;
            }
        } else if arg == "--json" || arg == "--shared" {
            leading.push(args[i].clone());
        } else {
            break;
        }
        i += 1;
    }
    let is_host = args.get(i).and_then(|a| a.to_str()).is_some_and(|c| HOST_COMMANDS.contains(&c));
    if leading.is_empty() || !is_host {
        return args;
    }
    let mut out = vec![args[0].clone(), args[i].clone()];
    out.extend(leading);
    out.extend(args[i + 1..].iter().cloned());
    out
}

fn main() -> ExitCode {
    let args = hoist_connection_options(std::env::args_os().collect());
    let json = args.iter().any(|a| a == "--json");
    let cli = match Cli::try_parse_from(&args) {
        Ok(cli) => cli,
        Err(err) if json && err.use_stderr() => {
            let message = err.kind().as_str().map_or_else(|| err.to_string(), str::to_string);
            let usage = CliError::Usage(format!("{message}; see `tmcl --help`"));
            let _ = output::json_line(&mut std::io::stdout(), &usage.to_json());
            let _ = err.print();
            return ExitCode::from(error::EXIT_USAGE);
        }
        Err(err) => err.exit(),
    };
    log::init(cli.verbose);
    let name = cli.command.name();
    let json = cli.json;
    let result = match cli.command {
        Command::Serve(mut args) => {
            args.verbose = cli.verbose > 0;
            serve::run(args, json)
        }
        Command::Share(args) => share::run(args, json, cli.verbose),
        Command::Monitor(args) => share::monitor(args, json),
        Command::Asm(args) => asm::run_asm(args, json),
        Command::Disasm(args) => asm::run_disasm(args, json),
        Command::Run(args) => run::run(args, json),
        Command::Debug(args) => debug::run(args, json),
        Command::Ui(args) => ui::run(args, json),
        Command::Esi(args) => esi::run(args, json),
        Command::Twin(args) => twin::run(args, json),
        Command::Host(command) => host::run(command, json),
        Command::Program(command) => program::run(command, json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away (`tmcl params | head`): nothing to tell anyone.
        Err(CliError::Output(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::from(error::EXIT_IO),
        Err(err) => {
            if json {
                let _ = output::json_line(&mut std::io::stdout(), &err.to_json());
            }
            err.report(name);
            ExitCode::from(err.exit_code())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    fn args(line: &str) -> Vec<OsString> {
        line.split_whitespace().map(OsString::from).collect()
    }

    /// docs/cli.md: every command's `--help`, so that the reference can never drift from the program.
    fn cli_reference() -> String {
        let mut cmd = Cli::command();
        cmd.build();
        let mut text = String::from(
            "# Command-line reference\n\n\
             Generated from `tmcl --help` and each command's `--help` by the test `the_cli_reference_is_current`\n\
             (`UPDATE_CLI_REFERENCE=1 cargo test -p tmcl-cli the_cli_reference` rewrites it). Connection options\n\
             (`--port`, `--baud`, `--tcp`, `--address`, `--timeout`) and `--module` of the host commands may also\n\
             come before the command's name: `tmcl --port /tmp/tmcl0 get ap 4`.\n",
        );
        fn walk(cmd: &mut clap::Command, path: &str, text: &mut String) {
            let mut help = cmd.render_long_help().to_string();
            if path != "tmcl" {
                // The exit codes are the same for every command: said once, under `tmcl`.
                help = help.replace(EXIT_CODES, "");
            }
            let help: Vec<&str> = help.trim_end().lines().map(str::trim_end).collect();
            text.push_str(&format!("\n## `{path}`\n\n```text\n{}\n```\n", help.join("\n")));
            for sub in cmd.get_subcommands_mut() {
                if sub.get_name() == "help" {
                    continue;
                }
                let path = format!("{path} {}", sub.get_name());
                walk(sub, &path, text);
            }
        }
        walk(&mut cmd, "tmcl", &mut text);
        text
    }

    #[test]
    fn the_cli_reference_is_current() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/cli.md");
        let text = cli_reference();
        if std::env::var_os("UPDATE_CLI_REFERENCE").is_some() {
            std::fs::write(&path, &text).unwrap();
        }
        let stored = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            stored == text,
            "docs/cli.md is not the help of this build: run `UPDATE_CLI_REFERENCE=1 cargo test -p tmcl-cli \
             the_cli_reference` and commit it"
        );
    }

    #[test]
    fn the_command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn connection_options_before_a_host_command_move_behind_it() {
        assert_eq!(
            hoist_connection_options(args("tmcl --port /tmp/l --address=3 --json get ap 4")),
            args("tmcl get --port /tmp/l --address=3 --json ap 4")
        );
        assert_eq!(hoist_connection_options(args("tmcl --tcp h:1 version")), args("tmcl version --tcp h:1"));
        // Not for commands that talk to no module: clap refuses the option there.
        assert_eq!(hoist_connection_options(args("tmcl --port x run p.tmc")), args("tmcl --port x run p.tmc"));
        assert!(Cli::try_parse_from(hoist_connection_options(args("tmcl --port x run p.tmc --for 1"))).is_err());
        assert_eq!(hoist_connection_options(args("tmcl asm p.tmc")), args("tmcl asm p.tmc"));
    }

    #[test]
    fn every_host_command_takes_the_connection_options_and_no_other_does() {
        let cmd = Cli::command();
        for sub in cmd.get_subcommands() {
            let name = sub.get_name();
            let has_port = sub.get_arguments().any(|a| a.get_id() == "port");
            assert_eq!(has_port, HOST_COMMANDS.contains(&name), "{name}");
        }
        for name in HOST_COMMANDS {
            assert!(cmd.find_subcommand(name).is_some(), "{name}");
        }
    }
}

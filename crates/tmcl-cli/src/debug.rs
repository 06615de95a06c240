//! `tmcl debug`: the debugger of `tmcl_debug::session` on stdin and stdout.
//!
//! It reads one command per line from stdin (a prompt `(tmcl) ` only when stdin is a terminal), so it
//! works at a terminal and from a script alike; everything it says goes to stdout, errors as plain
//! sentences. After each stop it prints a status line (why, PC, simulated time) and the source line of
//! the PC (`file:line: text`).

use crate::args::parse_sim_seconds;
use crate::error::{CliError, EXIT_CODES};
use crate::sim::SimOptions;
use clap::Args;
use std::io::{self, BufRead, IsTerminal, Write};
use std::path::PathBuf;
use tmcl_core::Duration;
use tmcl_debug::session::{Flow, Session, COMMANDS_HELP};

/// Options of `tmcl debug`.
#[derive(Debug, Args)]
pub struct DebugArgs {
    /// The program: TMCL source (.tmc) or an image (.bin).
    pub file: PathBuf,
    #[command(flatten)]
    pub sim: SimOptions,
    /// `continue` stops after this many simulated seconds without a breakpoint or STOP.
    #[arg(long, value_name = "SECONDS", default_value = "60", value_parser = parse_sim_seconds)]
    pub limit: Duration,
}

/// What `tmcl debug --help` prints after the options: the debugger's commands and the exit codes.
pub fn after_help() -> String {
    format!("{COMMANDS_HELP}\n\nWith --json, each command's answer is one JSON object: the command, its output lines, and\nthe program's pc, state and simulated time after it, and `refused`: the instructions the module\nrefused while it ran (status, pc, source line, reason; the program skipped them). Each step prints\nthe status the module gave the instruction: `status 100`, or a `refused:` line.\n\n{EXIT_CODES}")
}

/// Runs `tmcl debug`.
pub(crate) fn run(args: DebugArgs, json: bool) -> Result<(), CliError> {
    let source = args.sim.load(&args.file)?;
    let module = args.sim.build(&source)?;
    let mut session = Session::new(args.sim.setup()?, source, module, args.limit);
    let stdin = io::stdin();
    let interactive = stdin.is_terminal() && !json;
    let mut out = io::stdout().lock();
    let mut answer = Vec::new();
    session.banner(&mut answer)?;
    emit(&mut out, &mut session, None, &mut answer, json)?;
    let mut lines = stdin.lock().lines();
    loop {
        if interactive {
            write!(out, "(tmcl) ")?;
            out.flush()?;
        }
        let Some(line) = lines.next() else { break };
        let line = line?;
        let flow = session.command(&line, &mut answer)?;
        emit(&mut out, &mut session, Some(&line), &mut answer, json)?;
        if flow == Flow::Quit {
            break;
        }
        out.flush()?;
    }
    Ok(())
}

/// Prints one answer: as it is, or with `--json` as an object with the program's state.
fn emit(
    out: &mut dyn Write,
    session: &mut Session,
    command: Option<&str>,
    answer: &mut Vec<u8>,
    json: bool,
) -> io::Result<()> {
    let row = session.answer(command, answer);
    if json {
        writeln!(out, "{}", serde_json::to_string(&row).map_err(io::Error::other)?)?;
    } else {
        out.write_all(answer)?;
    }
    answer.clear();
    Ok(())
}

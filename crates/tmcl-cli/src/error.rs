//! How every `tmcl` subcommand fails: one error type, one set of exit codes, one JSON shape.
//!
//! An error that has a cause keeps it: [`std::error::Error::source`] gives the underlying error (an
//! `io::Error`, the world file's error, the host error), and the message already says it, so that
//! `tmcl` prints one line (`cannot write out.bin: Permission denied (os error 13)`).

use serde::Serialize;
use std::io;
use std::path::PathBuf;
use tmcl_host::HostError;
use tmcl_wire::Reply;

/// The exit codes of every subcommand, as printed in `--help`.
pub const EXIT_CODES: &str = "\
Exit codes (the same for every command):
  0  success
  1  the module answered with an error status (TMCL status below 100)
  2  usage or input error: bad arguments, an unknown parameter name, a file that cannot be read,
     assembly errors, a world file or model that does not fit
  3  no reply in time, or the port, pty, TCP connection or output failed
  4  a reply arrived but is no answer: damaged (checksum), late, or from another module or request
  5  `tmcl wait`: the condition did not come true within --within; `tmcl params --diff`: the module
     differs from the file
With --json, every command prints one JSON object per result on stdout, and on failure
{\"error\": MESSAGE, \"kind\": KIND, \"exit_code\": N} (plus \"reply\" for a status error).";

/// Exit code 1: the module said no.
pub const EXIT_STATUS: u8 = 1;
/// Exit code 2: usage or input error (also clap's own code for bad arguments).
pub const EXIT_USAGE: u8 = 2;
/// Exit code 3: no reply, or the connection or output failed.
pub const EXIT_IO: u8 = 3;
/// Exit code 4: a reply that is not the answer (damaged, late, foreign).
pub const EXIT_BAD_REPLY: u8 = 4;
/// Exit code 5: `tmcl wait` gave up.
pub const EXIT_NOT_MET: u8 = 5;

/// Why a command failed.
#[derive(Debug, thiserror::Error)]
pub(crate) enum CliError {
    /// Bad arguments that clap could not catch.
    #[error("{0}")]
    Usage(String),
    /// The module or the connection failed.
    #[error(transparent)]
    Host(#[from] HostError),
    /// A link or server failure of `tmcl serve`, or output that cannot be written.
    #[error("{0}")]
    Io(String),
    /// Writing the output failed.
    #[error("cannot write the output: {0}")]
    Output(#[from] io::Error),
    /// `tmcl wait` gave up.
    #[error("{0}")]
    NotMet(String),
    /// The module refused some of several requests (`tmcl params --load`), each reported already.
    #[error("{0}")]
    Refused(String),
    /// A program with assembly errors (each printed on stderr with its place; in JSON as `diagnostics`).
    #[error("{file}: {} error{}; nothing written or run", diagnostics.len(), if diagnostics.len() == 1 { "" } else { "s" })]
    Assembly {
        /// The program's file.
        file: String,
        /// The errors.
        diagnostics: Vec<tmcl_asm::Diagnostic>,
    },
    /// A file that cannot be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// A file or directory that cannot be made or written (`action`: `write`, `create`, `replace`).
    #[error("cannot {action} {}: {source}", path.display())]
    Write {
        /// What was tried.
        action: &'static str,
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// A file whose content cannot be used (an image, a parameter set, a plot's data).
    #[error("{}: {source}", path.display())]
    Content {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A plot that cannot be drawn.
    #[error("cannot draw {}: {source}", path.display())]
    Draw {
        /// The plot's file.
        path: PathBuf,
        /// Why.
        source: Box<dyn std::error::Error>,
    },
    /// A world file that cannot be used.
    #[error(transparent)]
    World(#[from] tmcl_sim::WorldError),
    /// An EEPROM image that cannot be opened.
    #[error(transparent)]
    Eeprom(#[from] tmcl_sim::NvmError),
    /// The workbench's server failed.
    #[error(transparent)]
    Workbench(#[from] tmcl_ui::UiError),
    /// A JSON line that cannot be written.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The signal handlers (SIGINT, SIGTERM) cannot be installed.
    #[error("cannot handle signals: {0}")]
    Signals(#[source] io::Error),
    /// A module or program that cannot be set up (`tmcl run`, `tmcl debug`, `tmcl twin`).
    #[error(transparent)]
    Setup(#[from] tmcl_run::SetupError),
    /// A program that cannot be read (not its assembly errors: those are [`CliError::Assembly`]).
    #[error(transparent)]
    Source(tmcl_run::SourceError),
    /// A world file that does not fit the module's model.
    #[error("{}: {source}", path.display())]
    Unfit {
        /// The world file.
        path: PathBuf,
        /// Why it does not fit.
        source: tmcl_sim::WorldError,
    },
    /// A server that cannot start or stopped (`tmcl serve`).
    #[error(transparent)]
    Serve(#[from] tmcl_serve::ServeError),
    /// The ESI file cannot be written.
    #[error("cannot write the ESI file: {0}")]
    Esi(#[source] std::fmt::Error),
    /// The monitor socket of a server cannot be reached.
    #[error(
        "cannot reach the monitor socket {}: {source}; is a `tmcl share` or `tmcl serve` running with a --pty \
         link there (or --monitor-socket)?",
        path.display()
    )]
    MonitorSocket {
        /// The socket.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// The monitor socket failed while it was read.
    #[error("the monitor socket failed: {0}")]
    MonitorLost(#[source] io::Error),
    /// A module's refusal with what the parameter tables say about it.
    #[error("{source}: {explanation}")]
    Explained {
        /// The refusal.
        source: HostError,
        /// Why, in words.
        explanation: String,
    },
}

impl CliError {
    /// The process exit code for this failure (see [`EXIT_CODES`]).
    pub(crate) fn exit_code(&self) -> u8 {
        match self {
            CliError::Explained { source, .. } | CliError::Host(source) => host_exit_code(source),
            CliError::NotMet(_) => EXIT_NOT_MET,
            CliError::Refused(_) => EXIT_STATUS,
            _ if self.kind() == "io" => EXIT_IO,
            _ => EXIT_USAGE,
        }
    }

    /// A one-word name of the failure for the JSON `kind` key.
    pub(crate) fn kind(&self) -> &'static str {
        match self {
            CliError::Explained { source, .. } | CliError::Host(source) => host_kind(source),
            CliError::Usage(_)
            | CliError::Setup(_)
            | CliError::Unfit { .. }
            | CliError::Serve(tmcl_serve::ServeError::Config(_)) => "usage",
            CliError::Read { .. }
            | CliError::Content { .. }
            | CliError::World(_)
            | CliError::Source(_)
            | CliError::Serve(tmcl_serve::ServeError::Input(_)) => "input",
            CliError::Assembly { .. } => "assembly",
            CliError::Io(_)
            | CliError::Output(_)
            | CliError::Write { .. }
            | CliError::Json(_)
            | CliError::Signals(_)
            | CliError::Draw { .. }
            | CliError::Eeprom(_)
            | CliError::Workbench(_)
            | CliError::Esi(_)
            | CliError::MonitorSocket { .. }
            | CliError::MonitorLost(_)
            | CliError::Serve(tmcl_serve::ServeError::Io(_)) => "io",
            CliError::NotMet(_) => "not_met",
            CliError::Refused(_) => "status",
        }
    }

    /// The failure as the JSON object `--json` prints.
    pub(crate) fn to_json(&self) -> ErrorJson {
        let reply = match self {
            CliError::Host(HostError::Status { reply, .. })
            | CliError::Explained { source: HostError::Status { reply, .. }, .. } => Some(ReplyJson::from(reply)),
            _ => None,
        };
        let diagnostics = match self {
            CliError::Assembly { diagnostics, .. } => Some(diagnostics.iter().map(DiagnosticJson::from).collect()),
            _ => None,
        };
        ErrorJson {
            diagnostics,
            error: self.to_string(),
            exit_code: self.exit_code(),
            hint: self.hint(),
            kind: self.kind(),
            reply,
        }
    }

    /// What the user can do about it, where the failure itself does not say.
    pub(crate) fn hint(&self) -> Option<String> {
        match self {
            // The right command answered, from another address: most likely the only module on the line
            // (on USB a module answers whatever address it is sent) keeps another address in GP 66.
            CliError::Host(HostError::Foreign { address, opcode, reply }) if reply.opcode == *opcode => Some(format!(
                "if module {} is the only module on the line, give --address {} (it does not answer as {address})",
                reply.module, reply.module
            )),
            CliError::Host(HostError::Timeout { .. }) => {
                Some("check --port/--tcp, --address (`tmcl scan` lists the modules) and --baud".into())
            }
            _ => None,
        }
    }

    /// Prints the failure on stderr (`tmcl COMMAND: message`, after each assembly error with its place).
    pub(crate) fn report(&self, command: &str) {
        if let CliError::Assembly { diagnostics, .. } = self {
            for d in diagnostics {
                eprintln!("{d}");
            }
        }
        eprintln!("tmcl {command}: {self}");
        if let Some(hint) = self.hint() {
            eprintln!("tmcl {command}: hint: {hint}");
        }
    }
}

/// The exit code of a host failure: the module said no (1), a reply that is no answer (4), or nothing (3).
fn host_exit_code(err: &HostError) -> u8 {
    match err {
        HostError::Status { .. } => EXIT_STATUS,
        err if err.is_reply_error() => EXIT_BAD_REPLY,
        _ => EXIT_IO,
    }
}

fn host_kind(err: &HostError) -> &'static str {
    match err {
        HostError::Status { .. } => "status",
        err if err.is_reply_error() => "bad_reply",
        HostError::Timeout { .. } => "timeout",
        _ => "io",
    }
}

/// A failure as `--json` prints it: `{"error": MESSAGE, "kind": KIND, "exit_code": N}`, with the reply of
/// a status error, a hint, and the diagnostics of assembly errors. (Fields in the order of their names,
/// as the output always had them.)
#[derive(Debug, Serialize)]
pub(crate) struct ErrorJson {
    /// Assembly errors with their places.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub diagnostics: Option<Vec<DiagnosticJson>>,
    /// The message.
    pub error: String,
    /// The process exit code.
    pub exit_code: u8,
    /// What the user can do about it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hint: Option<String>,
    /// The failure in one word.
    pub kind: &'static str,
    /// The refusing reply of a status error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reply: Option<ReplyJson>,
}

/// One assembly error with its place.
#[derive(Debug, Serialize)]
pub(crate) struct DiagnosticJson {
    pub column: u32,
    pub file: String,
    pub line: u32,
    pub message: String,
    pub width: u32,
}

impl From<&tmcl_asm::Diagnostic> for DiagnosticJson {
    fn from(d: &tmcl_asm::Diagnostic) -> DiagnosticJson {
        DiagnosticJson {
            column: d.column,
            file: d.file.clone(),
            line: d.line,
            message: d.message.clone(),
            width: d.width,
        }
    }
}

/// One reply as a JSON object. Every command uses these keys with these meanings: `address` is the module
/// address the reply came from, `host` the host address it went to, `opcode` the command number it answers.
#[derive(Debug, Clone, Copy, Serialize)]
pub(crate) struct ReplyJson {
    pub address: u8,
    pub host: u8,
    pub opcode: u8,
    pub status: u8,
    pub status_text: &'static str,
    pub value: i32,
}

impl From<&Reply> for ReplyJson {
    fn from(reply: &Reply) -> ReplyJson {
        ReplyJson {
            address: reply.module,
            host: reply.host,
            opcode: reply.opcode,
            status: u8::from(reply.status),
            status_text: reply.status.description(),
            value: reply.value,
        }
    }
}

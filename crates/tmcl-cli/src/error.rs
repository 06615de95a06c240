//! How every `tmcl` subcommand fails: one error type, one set of exit codes, one JSON shape.

use serde_json::json;
use std::io;
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
    /// A file, program, world or model that cannot be used.
    #[error("{0}")]
    Input(String),
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
            CliError::Explained { source, .. } => host_exit_code(source),
            CliError::Usage(_) | CliError::Input(_) | CliError::Assembly { .. } => EXIT_USAGE,
            CliError::Host(err) => host_exit_code(err),
            CliError::Io(_) | CliError::Output(_) => EXIT_IO,
            CliError::NotMet(_) => EXIT_NOT_MET,
            CliError::Refused(_) => EXIT_STATUS,
        }
    }

    /// A one-word name of the failure for the JSON `kind` key.
    pub(crate) fn kind(&self) -> &'static str {
        match self {
            CliError::Explained { source, .. } => host_kind(source),
            CliError::Usage(_) => "usage",
            CliError::Input(_) => "input",
            CliError::Assembly { .. } => "assembly",
            CliError::Host(err) => host_kind(err),
            CliError::Io(_) | CliError::Output(_) => "io",
            CliError::NotMet(_) => "not_met",
            CliError::Refused(_) => "status",
        }
    }

    /// The failure as the JSON object `--json` prints.
    pub(crate) fn to_json(&self) -> serde_json::Value {
        let mut value = json!({ "error": self.to_string(), "kind": self.kind(), "exit_code": self.exit_code() });
        if let CliError::Host(HostError::Status { reply, .. })
        | CliError::Explained { source: HostError::Status { reply, .. }, .. } = self
        {
            value["reply"] = reply_json(reply);
        }
        if let Some(hint) = self.hint() {
            value["hint"] = json!(hint);
        }
        if let CliError::Assembly { diagnostics, .. } = self {
            value["diagnostics"] = diagnostics
                .iter()
                .map(|d| json!({"file": d.file, "line": d.line, "column": d.column, "width": d.width, "message": d.message}))
                .collect();
        }
        value
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

/// One reply as a JSON object. Every command uses these keys with these meanings: `address` is the module
/// address the reply came from, `host` the host address it went to, `opcode` the command number it answers.
pub(crate) fn reply_json(reply: &Reply) -> serde_json::Value {
    json!({
        "status": u8::from(reply.status),
        "status_text": reply.status.description(),
        "value": reply.value,
        "address": reply.module,
        "host": reply.host,
        "opcode": reply.opcode,
    })
}

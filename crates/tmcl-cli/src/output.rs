//! What the commands print with `--json`: one typed object per line on stdout.

use crate::error::CliError;
use serde::Serialize;
use std::io::Write;

/// Writes `value` as one line of JSON.
pub(crate) fn json_line<W: Write + ?Sized>(out: &mut W, value: &impl Serialize) -> Result<(), CliError> {
    let text = serde_json::to_string(value)?;
    writeln!(out, "{text}")?;
    Ok(())
}

// The objects of the commands' `--json` lines. Their fields stand in the order of their names: the order
// the output always had (it was built as sorted maps), so that it stays byte for byte what it was.

/// `tmcl asm --emit-includes DIR` without an input: where the include files went.
#[derive(Debug, Serialize)]
pub(crate) struct Includes {
    pub includes: Option<String>,
}

/// `tmcl asm`: the image written.
#[derive(Debug, Serialize)]
pub(crate) struct Assembled {
    pub instructions: usize,
    pub output: String,
    pub symbols: Option<String>,
}

/// `tmcl disasm`: the source written to a file, or printed.
#[derive(Debug, Serialize)]
pub(crate) struct Disassembled {
    pub instructions: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

/// `tmcl version`: the version string and the binary version, decoded.
#[derive(Debug, Serialize)]
pub(crate) struct Version {
    pub address: u8,
    pub binary: i32,
    pub firmware: String,
    pub model: Option<u16>,
    pub version: String,
}

/// `tmcl scan`: one module that answered; `tmcl send 136 0`: the version string.
#[derive(Debug, Serialize)]
pub(crate) struct Found {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub address: Option<u8>,
    pub version: String,
}

/// `tmcl params`: one parameter of the tables, with its value when a module was asked.
#[derive(Debug, Serialize)]
pub(crate) struct ParamRow {
    pub access: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bank: Option<u8>,
    pub default: i32,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor: Option<u8>,
    pub name: &'static str,
    pub range: String,
    pub section: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub status: Option<u8>,
    pub title: &'static str,
    #[serde(rename = "type")]
    pub kind: u8,
    pub unit: &'static str,
    /// `null` when no module was asked; absent when the module refused (then `status`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub value: Option<Option<i32>>,
}

/// `tmcl download`: the program stored.
#[derive(Debug, Serialize)]
pub(crate) struct Downloaded {
    pub at: u16,
    pub stored: usize,
    pub verified: bool,
}

/// `tmcl upload`: the program read, written to a file or printed.
#[derive(Debug, Serialize)]
pub(crate) struct Uploaded {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    pub read: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

/// `tmcl start`.
#[derive(Debug, Serialize)]
pub(crate) struct Started {
    pub from: Option<u16>,
    pub running: bool,
}

/// `tmcl stop`.
#[derive(Debug, Serialize)]
pub(crate) struct Stopped {
    pub stopped: bool,
}

/// `tmcl status`: the program's state (registers and wait flag where the module's 135 reports them).
#[derive(Debug, Serialize)]
pub(crate) struct ProgramStatus {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accumulator: Option<i32>,
    pub mode: u8,
    pub mode_text: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pc: Option<i32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waiting: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub x: Option<i32>,
}

/// `tmcl ui`: where the workbench is.
#[derive(Debug, Serialize)]
pub(crate) struct Workbench {
    pub address: u8,
    pub url: String,
}

/// `tmcl wait`: the condition came true.
#[derive(Debug, Serialize)]
pub(crate) struct Met {
    pub condition: String,
    pub elapsed_s: f64,
    pub met: bool,
    pub value: i32,
}

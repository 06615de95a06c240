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

/// `tmcl watch`: one row, the time since the start and each value by its column's label (`ap 1
/// ActualPosition`, `io 0:1`). Keys in the order of their names, as the output always had them; a label
/// given twice is one key, with the later column's value.
#[derive(Debug)]
pub(crate) struct WatchRow<'a> {
    pub time_s: f64,
    pub labels: &'a [String],
    pub values: &'a [i32],
}

impl Serialize for WatchRow<'_> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        #[derive(Serialize)]
        #[serde(untagged)]
        enum Cell {
            Time(f64),
            Value(i32),
        }
        let mut cells = std::collections::BTreeMap::new();
        cells.insert("time_s", Cell::Time(self.time_s));
        for (label, value) in self.labels.iter().zip(self.values) {
            cells.insert(label.as_str(), Cell::Value(*value));
        }
        let mut map = serializer.serialize_map(Some(cells.len()))?;
        for (key, cell) in &cells {
            map.serialize_entry(key, cell)?;
        }
        map.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn watch_rows_keep_their_shape() {
        let labels = ["gp 0 (bank 2)".to_string(), "ap 1 ActualPosition".to_string(), "gp 0 (bank 2)".to_string()];
        let row = WatchRow { time_s: 0.25, labels: &labels, values: &[7, -5, 9] };
        let text = serde_json::to_string(&row).unwrap();
        assert_eq!(text, r#"{"ap 1 ActualPosition":-5,"gp 0 (bank 2)":9,"time_s":0.25}"#);
    }
}

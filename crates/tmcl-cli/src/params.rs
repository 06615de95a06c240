//! `tmcl params --save FILE`, `--load FILE [--store] [--any-model]` and `--diff FILE`: the parameter sets of
//! [`tmcl_host::paramset`] (what is saved, what a load writes and skips, what a diff compares) on the command
//! line.

use crate::connection::HostClient;
use crate::error::CliError;
use serde::Serialize;
use std::io::Write;
use std::path::Path;
use tmcl_core::model::ModelSpec;
use tmcl_host::paramset::{check_model, diff, from_toml, load, snapshot, to_toml, LoadOptions, Outcome, ParamFile};

/// Reads a set from `path`.
pub(crate) fn read_file(path: &Path) -> Result<ParamFile, CliError> {
    let text = std::fs::read_to_string(path).map_err(|source| CliError::Read { path: path.to_path_buf(), source })?;
    from_toml(&text).map_err(|e| CliError::Content { path: path.to_path_buf(), source: e.into() })
}

/// Writes `text` to `path` whole (a temporary file renamed over it), so a crash never leaves half a set.
pub(crate) fn write_whole(path: &Path, text: &str) -> Result<(), CliError> {
    let tmp = path.with_extension("tmp-tmcl");
    std::fs::write(&tmp, text).and_then(|()| std::fs::rename(&tmp, path)).map_err(|source| CliError::Write {
        action: "write",
        path: path.to_path_buf(),
        source,
    })
}

/// What `--save`, `--load` or `--diff` to do.
pub(crate) enum SetAction<'a> {
    Save(&'a Path),
    Load { path: &'a Path, store: bool, any_model: bool },
    Diff(&'a Path),
}

/// Runs one of the set actions on the module and prints its outcome.
pub(crate) fn run(
    action: SetAction<'_>,
    client: &mut HostClient,
    model: &'static ModelSpec,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    match action {
        SetAction::Save(path) => {
            let (file, notes) = snapshot(client, model)?;
            write_whole(path, &to_toml(&file).map_err(CliError::Io)?)?;
            for note in &notes {
                eprintln!("tmcl params: {note}");
            }
            if json {
                #[derive(Serialize)]
                struct Saved<'a> {
                    saved: String,
                    model: &'a str,
                    params: usize,
                    unread: usize,
                }
                let saved = Saved {
                    saved: path.display().to_string(),
                    model: model.id,
                    params: file.params.len(),
                    unread: notes.len(),
                };
                writeln!(out, "{}", serde_json::to_string(&saved)?)?;
            } else {
                writeln!(out, "saved {} parameters of the {} to {}", file.params.len(), model.name, path.display())?;
            }
            Ok(())
        }
        SetAction::Load { path, store, any_model } => {
            let file = read_file(path)?;
            check_model(&file, model, any_model)
                .map_err(|e| CliError::Usage(e.replace("load it as another model's set", "give --any-model")))?;
            let outcomes = load(client, model, &file, LoadOptions { store, interface: false })?;
            print_outcomes(&outcomes, json, out, |o| o.result == "skipped" || o.result == "refused")?;
            let count = |r: &str| outcomes.iter().filter(|o| o.result == r).count();
            let (written, stored, skipped, refused) =
                (count("written"), count("stored"), count("skipped"), count("refused"));
            if !json {
                writeln!(
                    out,
                    "{} of {} parameters written to the {}{}; {} unchanged, {skipped} skipped, {refused} refused",
                    written + stored,
                    outcomes.len(),
                    model.name,
                    if store { format!(" ({stored} stored in the EEPROM)") } else { String::new() },
                    count("unchanged"),
                )?;
            }
            if refused > 0 {
                return Err(CliError::Refused(format!(
                    "{refused} of {} parameters refused by the module (listed above)",
                    outcomes.len()
                )));
            }
            Ok(())
        }
        SetAction::Diff(path) => {
            let file = read_file(path)?;
            if file.module.model != model.id {
                eprintln!(
                    "tmcl params: the set is of a {}, the module is a {}: compared by number",
                    file.module.model, model.name
                );
            }
            let outcomes = diff(client, model, &file)?;
            print_outcomes(&outcomes, json, out, |o| o.result != "same" && o.result != "live")?;
            let differ = outcomes.iter().filter(|o| o.result == "differs").count();
            let live = outcomes.iter().filter(|o| o.result == "live").count();
            if !json {
                writeln!(
                    out,
                    "{differ} of {} settings differ from {} ({live} live values not compared)",
                    outcomes.len() - live,
                    path.display()
                )?;
            }
            if differ > 0 {
                return Err(CliError::NotMet(format!("{differ} parameters differ from {}", path.display())));
            }
            Ok(())
        }
    }
}

/// Prints the outcomes worth a line (`--json`: every one).
fn print_outcomes(
    outcomes: &[Outcome],
    json: bool,
    out: &mut dyn Write,
    worth: impl Fn(&Outcome) -> bool,
) -> Result<(), CliError> {
    for o in outcomes {
        if json {
            writeln!(out, "{}", serde_json::to_string(o)?)?;
            continue;
        }
        if !worth(o) {
            continue;
        }
        let entry_unit = |v: i32| if o.unit.is_empty() { v.to_string() } else { format!("{v} {}", o.unit) };
        let line = match (o.result.as_str(), o.module) {
            ("differs", Some(m)) => {
                format!("{:<9} {:<28} module {}, file {}", o.param, o.name, entry_unit(m), entry_unit(o.value))
            }
            _ => format!(
                "{:<9} {:<28} {} {}{}",
                o.param,
                o.name,
                o.result,
                entry_unit(o.value),
                o.why.as_ref().map(|w| format!(": {w}")).unwrap_or_default()
            ),
        };
        writeln!(out, "{line}")?;
    }
    Ok(())
}

//! Parameters by name and refusals in words, for the host tools (`tmcl get/set/watch/wait`, the
//! workbench): what a user types, matched against a model's tables, and what the tables say about a
//! module's refusal.
//!
//! A name is a table's identifier, as the assembler's include file `TMCLParam.tmc` defines it
//! (`MaxPositioningSpeed`, with or without its `AP`/`GP`/`IP` prefix), or the manual's name ("Maximum
//! positioning speed"), in any case and with or without spaces.

use crate::{ModelSpec, ParamDesc, Table};
use std::fmt;
use std::string::String;
use std::vec::Vec;
use tmcl_wire::Status;

/// The bank of the interrupt configuration (PD28-1021 manual §5.4).
pub const INTERRUPT_BANK: u8 = 3;

/// The table of axis parameters, or of the global parameters of `bank` (0, or 3 for the interrupt
/// configuration), if the model has one there.
pub fn table_of(model: &'static ModelSpec, axis: bool, bank: u8) -> Option<&'static Table> {
    match (axis, bank) {
        (true, _) => Some(&model.axis),
        (false, 0) => Some(&model.global),
        (false, INTERRUPT_BANK) => Some(&model.interrupt),
        (false, _) => None,
    }
}

/// The descriptor of axis parameter `number` (`axis`) or of global parameter `number` in bank `bank`, if
/// the model has it.
pub fn find(model: &'static ModelSpec, axis: bool, bank: u8, number: u8) -> Option<&'static ParamDesc> {
    table_of(model, axis, bank)?.params.iter().find(|d| d.number == number)
}

/// A parameter found by name: its number, the bank it is in (0 for axis parameters, 0 or 3 for global
/// ones), and its descriptor.
#[derive(Debug, Clone, Copy)]
pub struct Found {
    /// The parameter's number (the type byte).
    pub number: u8,
    /// Its bank (global parameters), or 0.
    pub bank: u8,
    /// What the table says about it.
    pub desc: &'static ParamDesc,
}

/// Why a name names no parameter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NameError {
    /// The name is a parameter of another bank than the one given.
    OtherBank {
        /// The parameter's identifier.
        ident: &'static str,
        /// Its bank.
        bank: u8,
        /// The bank given.
        given: u8,
    },
    /// No parameter of the model's tables has this name.
    Unknown {
        /// The model's product name.
        model: &'static str,
        /// `axis` or `global`.
        kind: &'static str,
        /// The name as given.
        name: String,
        /// The identifiers the user probably meant (at most three).
        close: Vec<&'static str>,
    },
}

impl fmt::Display for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NameError::OtherBank { ident, bank, given } => {
                write!(f, "{ident} is a parameter of bank {bank}, not of bank {given}")
            }
            NameError::Unknown { model, kind, name, close } => {
                write!(f, "the {model} has no {kind} parameter named {name:?}")?;
                match close.as_slice() {
                    [] => Ok(()),
                    [one] => write!(f, "; did you mean {one}?"),
                    several => write!(f, "; did you mean one of {}?", several.join(", ")),
                }
            }
        }
    }
}

impl std::error::Error for NameError {}

/// Letters and digits only, lower case: how names are compared.
fn normalize(text: &str) -> String {
    text.chars().filter(char::is_ascii_alphanumeric).map(|c| c.to_ascii_lowercase()).collect()
}

/// Finds an axis parameter (`axis`) or a global one of `model` by name. A global parameter is looked up
/// in bank 0 and the interrupt bank; `bank`, when given, must be the one it is in.
pub fn lookup(model: &'static ModelSpec, text: &str, axis: bool, bank: Option<u8>) -> Result<Found, NameError> {
    let wanted = normalize(text);
    // (table, bank, include-file prefix)
    let tables: &[(&'static Table, u8, &str)] = if axis {
        &[(&model.axis, 0, "ap")]
    } else {
        &[(&model.global, 0, "gp"), (&model.interrupt, INTERRUPT_BANK, "ip")]
    };
    for &(table, table_bank, prefix) in tables {
        for desc in table.params {
            let ident = normalize(desc.ident);
            let matches = wanted == ident
                || wanted.strip_prefix(prefix).is_some_and(|w| w == ident)
                || wanted == normalize(desc.name);
            if !matches {
                continue;
            }
            if let (false, Some(given)) = (axis, bank) {
                if given != table_bank {
                    return Err(NameError::OtherBank { ident: desc.ident, bank: table_bank, given });
                }
            }
            return Ok(Found { number: desc.number, bank: table_bank, desc });
        }
    }
    let candidates: Vec<&'static str> = tables.iter().flat_map(|(t, ..)| t.params.iter().map(|d| d.ident)).collect();
    Err(NameError::Unknown {
        model: model.name,
        kind: if axis { "axis" } else { "global" },
        name: text.into(),
        close: suggestions(text, &candidates),
    })
}

/// The names a user probably meant by `text`: the closest by spelling, else those that contain its letters
/// in order (`maxspeed` → `MaxPositioningSpeed`), shortest first, at most three.
fn suggestions(text: &str, candidates: &[&'static str]) -> Vec<&'static str> {
    if let Some(name) = closest(text, candidates.iter().copied()) {
        return std::vec![name];
    }
    let wanted = normalize(text);
    if wanted.len() < 3 {
        return Vec::new();
    }
    let mut found: Vec<&'static str> = candidates
        .iter()
        .copied()
        .filter(|c| {
            let mut letters = normalize(c).into_bytes().into_iter();
            wanted.bytes().all(|w| letters.any(|l| l == w))
        })
        .collect();
    found.sort_by_key(|c| c.len());
    found.truncate(3);
    found
}

/// Levenshtein distance, ignoring ASCII case.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().map(|c| c.to_ascii_lowercase()).collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().map(|c| c.to_ascii_lowercase()).enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitution = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitution.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// The candidate closest to `word` by edit distance, if it is close enough: at most a third of the word's
/// length in edits (at least one). Ties go to the first candidate. (The assembler's "did you mean" too.)
pub fn closest<'c>(word: &str, candidates: impl IntoIterator<Item = &'c str>) -> Option<&'c str> {
    let limit = (word.chars().count() / 3).max(1);
    let mut best: Option<(usize, &str)> = None;
    for c in candidates {
        let d = distance(word, c);
        if d <= limit && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| c)
}

/// What the tables say about a module's refusal of a parameter request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Refusal {
    /// The model has no such parameter (status 3).
    NoSuchParam {
        /// The model's product name.
        model: &'static str,
        /// `axis` or `global`.
        kind: &'static str,
        /// The number asked for.
        number: u8,
        /// The bank of a global parameter.
        bank: Option<u8>,
    },
    /// A write of a read-only parameter (status 3).
    ReadOnly(&'static ParamDesc),
    /// A read of a write-only parameter (status 3).
    WriteOnly(&'static ParamDesc),
    /// A value outside the parameter's range (status 4).
    OutOfRange(&'static ParamDesc),
    /// A store (STAP/STGP) of a parameter without EEPROM copy (status 4).
    NotStored(&'static ParamDesc),
    /// The parameter is password protected (status 8).
    Protected,
    /// The configuration EEPROM is locked (status 5).
    EepromLocked,
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::NoSuchParam { model, kind, number, bank } => {
                write!(f, "the {model} has no {kind} parameter {number}")?;
                match bank {
                    Some(b) => write!(f, " in bank {b}"),
                    None => Ok(()),
                }
            }
            Refusal::ReadOnly(d) => write!(f, "{} is read-only ({})", d.ident, d.access),
            Refusal::WriteOnly(d) => write!(f, "{} cannot be read ({})", d.ident, d.access),
            Refusal::OutOfRange(d) => write!(f, "{} takes {}", d.ident, d.range),
            Refusal::NotStored(d) => write!(f, "{} cannot be stored in the EEPROM ({})", d.ident, d.access),
            Refusal::Protected => f.write_str(
                "the parameter is password protected: write the password to the model's password parameter first",
            ),
            Refusal::EepromLocked => f.write_str("the configuration EEPROM is locked"),
        }
    }
}

/// Why the module refused a request of axis parameter `number` (`axis`) or of global parameter `number`
/// in bank `bank`, from what the tables say: `value` is the value of a write (`None` for a read, a store
/// or a restore), `store` whether it was a store (STAP/STGP). `None` when the tables say nothing about it.
pub fn explain(
    model: Option<&'static ModelSpec>,
    axis: bool,
    bank: u8,
    number: u8,
    status: Status,
    value: Option<i32>,
    store: bool,
) -> Option<Refusal> {
    let desc = model.and_then(|m| find(m, axis, bank, number));
    Some(match (model, desc, status) {
        (Some(model), None, Status::WrongType) => Refusal::NoSuchParam {
            model: model.name,
            kind: if axis { "axis" } else { "global" },
            number,
            bank: (!axis).then_some(bank),
        },
        (_, Some(d), Status::WrongType) if value.is_some() && !d.access.write => Refusal::ReadOnly(d),
        (_, Some(d), Status::WrongType) if value.is_none() && !store && !d.access.read => Refusal::WriteOnly(d),
        (_, Some(d), Status::InvalidValue) if value.is_some_and(|v| !d.range.contains(v)) => Refusal::OutOfRange(d),
        (_, Some(d), Status::InvalidValue) if store && !d.access.store => Refusal::NotStored(d),
        (_, _, Status::PasswordProtected) => Refusal::Protected,
        (_, _, Status::EepromLocked) => Refusal::EepromLocked,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pd28() -> &'static ModelSpec {
        crate::by_id("pd28-1021").unwrap()
    }

    #[test]
    fn names_in_any_spelling() {
        for text in ["MaxPositioningSpeed", "maxpositioningspeed", "APMaxPositioningSpeed", "Maximum positioning speed"]
        {
            let f = lookup(pd28(), text, true, None).unwrap();
            assert_eq!((f.number, f.bank), (4, 0), "{text}");
        }
        assert_eq!(lookup(pd28(), "SerialAddress", false, None).unwrap().number, 66);
        // A bank 3 name picks bank 3.
        let f = lookup(pd28(), "Timer0Period", false, None).unwrap();
        assert_eq!((f.number, f.bank), (0, 3));
        assert_eq!(lookup(pd28(), "ipTimer0Period", false, Some(3)).unwrap().bank, 3);
        let err = lookup(pd28(), "Timer0Period", false, Some(0)).unwrap_err();
        assert_eq!(err.to_string(), "Timer0Period is a parameter of bank 3, not of bank 0");
    }

    #[test]
    fn unknown_names_suggest_the_closest() {
        let err = lookup(pd28(), "maxspeed", true, None).unwrap_err().to_string();
        assert!(err.ends_with("did you mean MaxPositioningSpeed?"), "{err}");
        let err = lookup(pd28(), "speed", true, None).unwrap_err().to_string();
        assert!(err.ends_with("did you mean one of TargetSpeed, ActualSpeed, MinimumSpeed?"), "{err}");
        // The Python package's `module.get("maxspd")` names it too.
        let err = lookup(pd28(), "maxspd", true, None).unwrap_err().to_string();
        assert!(err.contains("MaxPositioningSpeed"), "{err}");
        let err = lookup(pd28(), "MaxPositionSpeed", true, None).unwrap_err().to_string();
        assert_eq!(
            err,
            "the PD28-1021 has no axis parameter named \"MaxPositionSpeed\"; did you mean MaxPositioningSpeed?"
        );
        assert_eq!(distance("kitten", "sitting"), 3);
        assert_eq!(closest("Lop", ["Loop", "Start"]), Some("Loop"));
        assert_eq!(closest("Xyz", ["Loop"]), None);
    }

    #[test]
    fn refusals_in_words() {
        let m = Some(pd28());
        let why =
            |axis, bank, n, status, value, store| explain(m, axis, bank, n, status, value, store).unwrap().to_string();
        assert_eq!(why(true, 0, 4, Status::InvalidValue, Some(0), false), "MaxPositioningSpeed takes 1..2147483647");
        assert_eq!(why(true, 0, 8, Status::WrongType, Some(1), false), "PositionReachedFlag is read-only (R)");
        assert_eq!(why(true, 0, 250, Status::WrongType, None, false), "the PD28-1021 has no axis parameter 250");
        assert_eq!(
            why(false, 3, 99, Status::WrongType, None, false),
            "the PD28-1021 has no global parameter 99 in bank 3"
        );
        assert!(why(true, 0, 1, Status::InvalidValue, None, true).starts_with("ActualPosition cannot be stored"));
        assert_eq!(explain(None, true, 0, 4, Status::InvalidCommand, None, false), None);
    }
}

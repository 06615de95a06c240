//! Parameters by name: the firmware tables' identifiers (`MaxPositioningSpeed`, as the assembler's
//! include file `TMCLParam.tmc` defines them, with or without the `AP`/`GP`/`IP` prefix) or the manual's
//! names ("Maximum positioning speed"), in any case, with or without spaces — as `tmcl ap`/`tmcl gp`.

use pyo3::exceptions::PyKeyError;
use pyo3::PyResult;
use tmcl_core::model::ModelSpec;

/// The bank of the interrupt configuration (PD28-1021 manual §5.4).
pub(crate) const INTERRUPT_BANK: u8 = 3;

/// Where a named parameter lives.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Param {
    /// An axis parameter (SAP/GAP) or a global one (SGP/GGP).
    pub axis: bool,
    /// Its number.
    pub number: u8,
    /// Its bank (global parameters; 0 for axis parameters).
    pub bank: u8,
}

/// Letters and digits only, lower case: how names are compared.
fn normalize(text: &str) -> String {
    text.chars().filter(char::is_ascii_alphanumeric).map(|c| c.to_ascii_lowercase()).collect()
}

/// Finds a parameter of `model` by name: axis parameters first, then bank 0, then the interrupt bank.
/// An unknown name is a `KeyError` naming the closest identifiers.
pub(crate) fn lookup(model: &'static ModelSpec, text: &str) -> PyResult<Param> {
    let wanted = normalize(text);
    let tables = [
        (&model.axis, true, 0, "ap"),
        (&model.global, false, 0, "gp"),
        (&model.interrupt, false, INTERRUPT_BANK, "ip"),
    ];
    for (table, axis, bank, prefix) in tables {
        for desc in table.params {
            let ident = normalize(desc.ident);
            if wanted == ident || wanted.strip_prefix(prefix) == Some(ident.as_str()) || wanted == normalize(desc.name)
            {
                return Ok(Param { axis, number: desc.number, bank });
            }
        }
    }
    let close: Vec<&str> = tables
        .iter()
        .flat_map(|(t, ..)| t.params.iter().map(|d| d.ident))
        .filter(|ident| {
            let ident = normalize(ident);
            ident.contains(&wanted) || wanted.contains(&ident) || subsequence(&wanted, &ident)
        })
        .take(3)
        .collect();
    let hint = if close.is_empty() { String::new() } else { format!("; did you mean {}?", close.join(", ")) };
    Err(PyKeyError::new_err(format!("the {} has no parameter named {text:?}{hint}", model.name)))
}

/// Whether the letters of `short` appear in `long` in order (`maxspeed` in `maxpositioningspeed`).
fn subsequence(short: &str, long: &str) -> bool {
    let mut letters = long.chars();
    !short.is_empty() && short.chars().all(|c| letters.any(|l| l == c))
}

//! Parameters by name: the firmware tables' identifiers (`MaxPositioningSpeed`, as the assembler's
//! include file `TMCLParam.tmc` defines them, with or without the `AP`/`GP`/`IP` prefix) or the manual's
//! names ("Maximum positioning speed"), in any case, with or without spaces — as `tmcl get`/`tmcl set`
//! (`tmcl_model::names`).

use pyo3::exceptions::PyKeyError;
use pyo3::PyResult;
use tmcl_core::model::names::{self as by_name, NameError};
use tmcl_core::model::ModelSpec;

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

/// Finds a parameter of `model` by name: axis parameters first, then bank 0, then the interrupt bank
/// (`tmcl_model::names::lookup`, as `tmcl get`/`tmcl set` find them). An unknown name is a `KeyError`
/// naming the closest identifiers.
pub(crate) fn lookup(model: &'static ModelSpec, text: &str) -> PyResult<Param> {
    let axis = match by_name::lookup(model, text, true, None) {
        Ok(found) => return Ok(Param { axis: true, number: found.number, bank: 0 }),
        Err(e) => e,
    };
    let global = match by_name::lookup(model, text, false, None) {
        Ok(found) => return Ok(Param { axis: false, number: found.number, bank: found.bank }),
        Err(e) => e,
    };
    let mut close: Vec<&str> = Vec::new();
    for e in [axis, global] {
        if let NameError::Unknown { close: names, .. } = e {
            for name in names {
                if !close.contains(&name) {
                    close.push(name);
                }
            }
        }
    }
    close.truncate(3);
    let hint = if close.is_empty() { String::new() } else { format!("; did you mean {}?", close.join(", ")) };
    Err(PyKeyError::new_err(format!("the {} has no parameter named {text:?}{hint}", model.name)))
}

//! The native part of the `opentmcl` Python package (`opentmcl._native`): virtual TMCL modules in the
//! Python process, the assembler and disassembler, on the OpenTMCL library crates.
//!
//! - `module`: `Module`, a virtual module on its simulated board, running in real time, with direct
//!   access (`request`, `get`, `set`) and its world (`World`).
//! - `asm`: `assemble` and `disassemble`, with the assembler's diagnostics as `AssemblyError`.
//! - `run`: `run`, a program on a simulated module far faster than real time (`tmcl-run`), its trace
//!   as columns and the refusals.
//! - `names`: parameters by name, as the firmware tables and the assembler's include file spell them.
//!
//! The Python side (`opentmcl/__init__.py`) re-exports these and adds the pytest plugin; the type hints
//! are in `opentmcl/_native.pyi`.

use pyo3::prelude::*;

mod asm;
mod module;
mod names;
mod run;

pyo3::create_exception!(
    _native,
    TmclError,
    pyo3::exceptions::PyException,
    "A module refused a request: `status` is the TMCL reply status (PD28-1021 manual §3.2.1)."
);

pyo3::create_exception!(
    _native,
    AssemblyError,
    pyo3::exceptions::PyValueError,
    "TMCL source that does not assemble: `diagnostics` lists every error, the first's place is in \
     `file`, `line` and `column`."
);

/// The `opentmcl._native` extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("TmclError", py.get_type::<TmclError>())?;
    m.add("AssemblyError", py.get_type::<AssemblyError>())?;
    m.add_class::<module::Module>()?;
    m.add_class::<module::Reply>()?;
    m.add_class::<module::World>()?;
    m.add_class::<asm::Program>()?;
    m.add_class::<asm::Diagnostic>()?;
    m.add_function(wrap_pyfunction!(asm::assemble, m)?)?;
    m.add_function(wrap_pyfunction!(asm::disassemble, m)?)?;
    m.add_function(wrap_pyfunction!(models, m)?)?;
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

/// The models a virtual module can be, by id (`pd28-1021`, `tmcm-1310`, ...), with their product names.
#[pyfunction]
fn models() -> Vec<(&'static str, &'static str)> {
    tmcl_core::model::MODELS.iter().map(|m| (m.id, m.name)).collect()
}

/// A model by id, or a `ValueError` naming the known ones.
pub(crate) fn model_by_id(id: &str) -> PyResult<&'static tmcl_core::model::ModelSpec> {
    tmcl_core::model::find(id).map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
}

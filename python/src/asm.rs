//! `assemble` and `disassemble`: `tmcl-asm` for Python, with its diagnostics as `AssemblyError`.

use crate::AssemblyError;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::collections::BTreeMap;
use std::path::PathBuf;
use tmcl_asm::{BuiltinResolver, DisasmOptions, FileResolver};
use tmcl_wire::{Instruction, Opcode};

/// An assembled TMCL program: instructions, labels, constants and where each instruction came from.
#[pyclass(module = "opentmcl._native", frozen)]
#[derive(Debug, Clone)]
pub struct Program {
    pub(crate) inner: tmcl_asm::Program,
}

#[pymethods]
impl Program {
    /// Reads a `.bin` image (8 bytes per instruction, as `tmcl asm` and the TMCL-IDE write them).
    #[staticmethod]
    fn from_bin(image: &[u8]) -> PyResult<Program> {
        let instructions = tmcl_asm::from_bin(image).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Program { inner: tmcl_asm::Program { instructions, ..tmcl_asm::Program::default() } })
    }

    /// The instructions as `(opcode, type, motor_or_bank, value)` tuples, one per program address.
    #[getter]
    fn instructions(&self) -> Vec<(u8, u8, u8, i32)> {
        self.inner.instructions.iter().map(|i| (i.opcode.code(), i.kind, i.motor, i.value)).collect()
    }

    /// Label name → program address.
    #[getter]
    fn labels(&self) -> BTreeMap<String, u16> {
        self.inner.labels.clone()
    }

    /// Constant name → value (those the source defines and those of the included files).
    #[getter]
    fn constants(&self) -> BTreeMap<String, i32> {
        self.inner.constants.clone()
    }

    /// Per instruction, the `(file, line)` it was assembled from (empty for a program read from a `.bin`).
    #[getter]
    fn lines(&self) -> Vec<(String, u32)> {
        self.inner.source_lines.iter().map(|l| (l.file.to_string(), l.line)).collect()
    }

    /// The `.bin` image: 8 bytes per instruction (opcode, type, motor, value MSB first, checksum).
    fn to_bin<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.to_bin())
    }

    /// Source text that assembles to the same instructions (see `opentmcl.disassemble`).
    #[pyo3(signature = (addresses = false))]
    fn disassemble(&self, addresses: bool) -> String {
        tmcl_asm::disassemble(&self.inner.instructions, DisasmOptions { addresses })
    }

    fn __len__(&self) -> usize {
        self.inner.instructions.len()
    }

    fn __repr__(&self) -> String {
        format!("<Program: {} instructions, {} labels>", self.inner.instructions.len(), self.inner.labels.len())
    }
}

/// One assembler error: file, line and column (from 1), the width to underline, the message and the line.
#[pyclass(module = "opentmcl._native", frozen, get_all)]
#[derive(Debug, Clone)]
pub struct Diagnostic {
    /// The file's name (`<source>` for text given directly).
    pub file: String,
    /// Line, from 1; 0 for an error about the whole file.
    pub line: u32,
    /// Column of the first character, from 1.
    pub column: u32,
    /// Characters underlined.
    pub width: u32,
    /// What is wrong, a plain sentence.
    pub message: String,
    /// The source line.
    pub source_line: String,
}

#[pymethods]
impl Diagnostic {
    fn __str__(&self) -> String {
        self.to_asm().to_string()
    }

    fn __repr__(&self) -> String {
        format!("<Diagnostic {}:{}:{}: {}>", self.file, self.line, self.column, self.message)
    }
}

impl Diagnostic {
    fn to_asm(&self) -> tmcl_asm::Diagnostic {
        tmcl_asm::Diagnostic {
            file: self.file.clone(),
            line: self.line,
            column: self.column,
            width: self.width,
            message: self.message.clone(),
            source_line: self.source_line.clone(),
        }
    }
}

impl From<tmcl_asm::Diagnostic> for Diagnostic {
    fn from(d: tmcl_asm::Diagnostic) -> Diagnostic {
        Diagnostic {
            file: d.file,
            line: d.line,
            column: d.column,
            width: d.width,
            message: d.message,
            source_line: d.source_line,
        }
    }
}

/// The `AssemblyError` for `diagnostics` (at least one): its text is every diagnostic as the CLI prints
/// them; `file`, `line`, `column` and `message` are the first's, `diagnostics` all of them.
pub(crate) fn assembly_error(py: Python<'_>, diagnostics: Vec<tmcl_asm::Diagnostic>) -> PyErr {
    let text: Vec<String> = diagnostics.iter().map(|d| d.to_string().trim_end().to_string()).collect();
    let err = AssemblyError::new_err(text.join("\n"));
    let value = err.value(py);
    let all: Vec<Diagnostic> = diagnostics.into_iter().map(Diagnostic::from).collect();
    if let Some(first) = all.first() {
        let _ = value.setattr("file", first.file.clone());
        let _ = value.setattr("line", first.line);
        let _ = value.setattr("column", first.column);
        let _ = value.setattr("message", first.message.clone());
    }
    let _ = value.setattr("diagnostics", all);
    err
}

/// Assembles TMCL source (as `tmcl asm`): text, or a path (`pathlib.Path`) to a file. `#include`s are
/// found beside the file, in `include_dirs`, then among the built-in files of `model` (`TMCLParam.tmc`,
/// `Interrupts.inc`); every command must be one the model has. Raises `AssemblyError` with every error.
#[pyfunction]
#[pyo3(signature = (source, model = "pd28-1021", include_dirs = Vec::new(), name = "<source>"))]
pub fn assemble(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    model: &str,
    include_dirs: Vec<PathBuf>,
    name: &str,
) -> PyResult<Program> {
    let spec = crate::model_by_id(model)?;
    let mut resolver = FileResolver { include_dirs, builtins: BuiltinResolver { model: spec } };
    // A str is source text; anything path-like (pathlib.Path, os.DirEntry) is a file to read.
    let (program, text) = if let Ok(text) = source.extract::<String>() {
        (py.detach(|| tmcl_asm::assemble_str(name, &text, &mut resolver)), Some((name.to_string(), text)))
    } else {
        let path: PathBuf = source.extract()?;
        (py.detach(|| tmcl_asm::assemble_file(&path, &mut resolver)), None)
    };
    let program = program.map_err(|d| assembly_error(py, d))?;
    let wrong = tmcl_asm::check_model(&program, spec, &mut |file, line| match &text {
        Some((name, text)) if name == file => text.lines().nth(line.checked_sub(1)? as usize).map(String::from),
        _ => std::fs::read_to_string(file).ok()?.lines().nth(line.checked_sub(1)? as usize).map(String::from),
    });
    if !wrong.is_empty() {
        return Err(assembly_error(py, wrong));
    }
    Ok(Program { inner: program })
}

/// Source text for a program: a `Program`, a `.bin` image (`bytes`) or a list of `(opcode, type,
/// motor_or_bank, value)` tuples. Jump targets get labels (`L0012:`); the text assembles to the same
/// instructions. `addresses=True` appends each instruction's address as a comment.
#[pyfunction]
#[pyo3(signature = (program, addresses = false))]
pub fn disassemble(program: &Bound<'_, PyAny>, addresses: bool) -> PyResult<String> {
    let instructions = instructions_of(program)?;
    Ok(tmcl_asm::disassemble(&instructions, DisasmOptions { addresses }))
}

/// The instructions of a `Program`, a `.bin` image or a list of tuples.
pub(crate) fn instructions_of(program: &Bound<'_, PyAny>) -> PyResult<Vec<Instruction>> {
    if let Ok(p) = program.cast::<Program>() {
        return Ok(p.get().inner.instructions.clone());
    }
    if let Ok(bytes) = program.cast::<PyBytes>() {
        return tmcl_asm::from_bin(bytes.as_bytes()).map_err(|e| PyValueError::new_err(e.to_string()));
    }
    let tuples: Vec<(u8, u8, u8, i32)> = program.extract().map_err(|_| {
        PyValueError::new_err("a program is a Program, a .bin image (bytes) or a list of (opcode, type, motor, value)")
    })?;
    Ok(tuples
        .into_iter()
        .map(|(op, kind, motor, value)| Instruction::new(Opcode::from(op), kind, motor, value))
        .collect())
}

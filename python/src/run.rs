//! `run`: a standalone TMCL program on a simulated module, far faster than real time (`tmcl-run`, the
//! library behind `tmcl run`), its trace as columns and the instructions the module refused.

use crate::asm::{assembly_error, instructions_of, Program};
use crate::module::load_world;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use tmcl_core::Duration;
use tmcl_run::{Options, Setting, Setup, SetupError, Simulation, Source, Trace};

/// Runs `program` (TMCL source text, a `Program`, a `.bin` image or instruction tuples) on a fresh
/// simulated `model` in `world` for `seconds` of simulated time, a row every `every` seconds and at each
/// event, and returns a dict: `columns` (name → list: `time_s` first, then the columns `tmcl run` writes,
/// in their units, `None` where the module gave no value), `units` (name → unit symbol), `events`
/// (`(time_s, kind, value)`), `refusals` (`count`, and the last ones noted: `time_s`, `pc`,
/// `instruction`, `status`) and `summary` (`state`, `pc`, `executed`, `simulated_s`, `wall_s`).
#[pyfunction]
#[pyo3(signature = (program, seconds = 3600.0, world = None, every = 0.01, model = "pd28-1021", settings = Vec::new(), drive = false))]
#[allow(clippy::too_many_arguments)]
pub fn run<'py>(
    py: Python<'py>,
    program: &Bound<'py, PyAny>,
    seconds: f64,
    world: Option<&Bound<'py, PyAny>>,
    every: f64,
    model: &str,
    settings: Vec<String>,
    drive: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let duration = micros(seconds, "seconds")?;
    let every = micros(every, "every")?;
    if every.micros() == 0 {
        return Err(PyValueError::new_err("every must be at least 1 µs"));
    }
    let source = if program.extract::<String>().is_ok() {
        // Assembled as `assemble` does, with the model's built-in include files.
        let assembled = crate::asm::assemble(py, program, model, Vec::new(), "<source>")?;
        Source { program: assembled.inner, path: "<source>".into() }
    } else if let Ok(p) = program.cast::<Program>() {
        Source { program: p.get().inner.clone(), path: "<program>".into() }
    } else {
        Source::from_instructions("<program>", instructions_of(program)?)
    };
    let mut setup = Setup::new(model).map_err(setup_error)?;
    if world.is_some() {
        setup = setup.with_world(load_world(world)?);
    }
    for text in &settings {
        let setting: Setting = text.parse().map_err(|e: String| PyValueError::new_err(e))?;
        setup = setup.with_setting(setting);
    }
    let mut simulation = Simulation::new(&source, &setup).map_err(|e| match e {
        SetupError::Commands { diagnostics, .. } => assembly_error(py, diagnostics),
        other => setup_error(other),
    })?;
    let mut options = Options::new(duration);
    options.every = every;
    options.drive = drive;
    let mut trace = Trace::new();
    let summary = py
        .detach(|| simulation.run(&options, Some(&mut trace), None))
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;

    let out = PyDict::new(py);
    let columns = PyDict::new(py);
    let units = PyDict::new(py);
    columns.set_item("time_s", trace.seconds())?;
    units.set_item("time_s", "s")?;
    for (index, column) in trace.columns().iter().enumerate() {
        columns.set_item(&column.name, trace.scaled(index))?;
        units.set_item(&column.name, column.unit.symbol())?;
    }
    out.set_item("columns", columns)?;
    out.set_item("units", units)?;
    let events = PyList::empty(py);
    for e in &trace.events {
        events.append((e.micros as f64 / 1e6, e.event.kind(), e.event.value()))?;
    }
    out.set_item("events", events)?;

    let refusals = simulation.module().vm().refusals();
    let log = PyList::empty(py);
    for r in refusals.since(0) {
        let i = r.instruction;
        let entry = PyDict::new(py);
        entry.set_item("number", r.number)?;
        entry.set_item("time_s", r.at.micros() as f64 / 1e6)?;
        entry.set_item("pc", r.pc)?;
        entry.set_item("instruction", (i.opcode.code(), i.kind, i.motor, i.value))?;
        entry.set_item(
            "text",
            tmcl_asm::disassemble(&[i], Default::default()).lines().last().unwrap_or("").trim().to_string(),
        )?;
        entry.set_item("status", u8::from(r.status))?;
        entry.set_item("status_text", r.status.description())?;
        log.append(entry)?;
    }
    let refused = PyDict::new(py);
    refused.set_item("count", refusals.count())?;
    refused.set_item("last", log)?;
    out.set_item("refusals", refused)?;

    let s = PyDict::new(py);
    s.set_item("state", summary.state)?;
    s.set_item("pc", summary.pc)?;
    s.set_item("executed", summary.executed)?;
    s.set_item("simulated_s", summary.simulated_us as f64 / 1e6)?;
    s.set_item("wall_s", summary.wall_s)?;
    s.set_item("rows", trace.len())?;
    out.set_item("summary", s)?;
    Ok(out)
}

/// Seconds as a simulated duration; negative, NaN or absurd values are a `ValueError`.
fn micros(seconds: f64, what: &str) -> PyResult<Duration> {
    if !seconds.is_finite() || !(0.0..=1e9).contains(&seconds) {
        return Err(PyValueError::new_err(format!("{what} must be between 0 and 1e9 seconds, not {seconds}")));
    }
    Ok(Duration::from_micros((seconds * 1e6).round() as u64))
}

fn setup_error(e: SetupError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

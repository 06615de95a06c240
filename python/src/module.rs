//! `Module`: a virtual TMCL module (the OpenTMCL firmware core on its simulated board) in the Python
//! process, in real time, with direct access (`request`, `get`, `set`) and its world (`World`).
//!
//! The module's time is the wall clock since it was made, as under `tmcl serve`: a motor moves while
//! Python does something else. The core is event-driven, so a module nobody asks costs nothing; each
//! request first brings it to the current instant.

use crate::names::{self, Param};
use crate::TmclError;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use tmcl_core::model::ModelSpec;
use tmcl_core::param::persist;
use tmcl_core::{Instant, Module as Core, Outcome};
use tmcl_sim::{Eeprom, FileNvm, MemNvm, SimBoard};
use tmcl_wire::{Command, Instruction, Opcode, Status};

/// A port number no model has: [`Core::poll_port`] on it brings the module to an instant without taking
/// what is queued for a host on a real interface.
const NO_PORT: usize = usize::MAX;

/// The module and its clock, shared by the Python object and (when served) the server's thread.
pub(crate) struct Shared {
    /// The firmware on its board.
    pub module: Core<SimBoard>,
    /// When the module's time 0 was.
    pub start: std::time::Instant,
    /// Set by `close`: the clock thread ends.
    pub stopped: bool,
}

impl Shared {
    /// The module's time now.
    pub fn now(&self) -> Instant {
        Instant::from_micros(self.start.elapsed().as_micros() as u64)
    }

    /// Brings the module and its world to now.
    pub fn catch_up(&mut self) -> Instant {
        self.step().0
    }

    /// Brings the module and its world to now; returns now and when either needs to run next (the
    /// module's deadline or the world's next change, whichever comes first).
    fn step(&mut self) -> (Instant, Option<Instant>) {
        let now = self.now();
        let deadline = self.module.poll_port(NO_PORT, now, &mut |_: &[u8]| {});
        self.module.board_timeline().advance(now);
        let next = [deadline, self.module.board().next_event()].into_iter().flatten().min();
        (now, next)
    }
}

/// Longest sleep of the clock thread without a deadline.
const MAX_SLEEP: std::time::Duration = std::time::Duration::from_secs(1);

/// The module's clock: a thread that brings the module to each of its deadlines and to each change of
/// its world (a fault window, a scripted load, an input), as `tmcl serve` does, so that a motor moving
/// while nobody asks meets its world at the right instants. It ends when the module is closed or gone.
fn keep_time(handle: std::sync::Weak<Mutex<Shared>>) {
    loop {
        let Some(handle) = handle.upgrade() else { return };
        let wait = {
            let Ok(mut shared) = handle.lock() else { return };
            if shared.stopped {
                return;
            }
            let (now, next) = shared.step();
            next.map_or(MAX_SLEEP, |n| std::time::Duration::from_micros((n - now).micros()).min(MAX_SLEEP))
        };
        drop(handle);
        std::thread::park_timeout(wait);
    }
}

/// Starts the clock thread of `handle`.
pub(crate) fn start_clock(handle: &Handle) -> PyResult<std::thread::JoinHandle<()>> {
    let weak = Arc::downgrade(handle);
    std::thread::Builder::new()
        .name("opentmcl-clock".into())
        .spawn(move || keep_time(weak))
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start the module's clock: {e}")))
}

/// The shared module.
pub(crate) type Handle = Arc<Mutex<Shared>>;

/// Locks the module; a panic of another thread while it held the lock is an error here, not a second
/// panic.
pub(crate) fn lock(handle: &Handle) -> PyResult<MutexGuard<'_, Shared>> {
    handle.lock().map_err(|_| PyRuntimeError::new_err("the module's thread failed; make a new module"))
}

/// A world: a path to a TOML world file (`docs/world.md`), or TOML text.
pub(crate) fn load_world(world: Option<&Bound<'_, PyAny>>) -> PyResult<tmcl_sim::World> {
    let Some(world) = world else { return Ok(tmcl_sim::World::default()) };
    if let Ok(text) = world.extract::<String>() {
        // A str is a path when it names a file or ends in .toml, else the world file's text.
        if text.trim_end().ends_with(".toml") || Path::new(&text).is_file() {
            return tmcl_sim::World::load(&text).map_err(|e| PyValueError::new_err(e.to_string()));
        }
        return tmcl_sim::World::from_toml_str(&text).map_err(|e| PyValueError::new_err(e.to_string()));
    }
    let path: PathBuf = world.extract()?;
    tmcl_sim::World::load(&path).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Builds a module of `spec` in `world`, its EEPROM in memory or in the file `eeprom`. A new EEPROM
/// takes `address` (GP 66); a stored one keeps the address it has, as a real module does.
pub(crate) fn build(
    spec: &'static ModelSpec,
    world: tmcl_sim::World,
    eeprom: Option<&Path>,
    address: u8,
) -> PyResult<Handle> {
    if address == 0 {
        return Err(PyValueError::new_err("a module address is 1..255"));
    }
    let capacity = persist::capacity(spec);
    let fresh = eeprom.is_none_or(|p| std::fs::metadata(p).map_or(true, |m| m.len() == 0));
    let nvm = match eeprom {
        Some(path) => Eeprom::File(
            FileNvm::open(path, capacity)
                .map_err(|e| PyRuntimeError::new_err(format!("EEPROM {}: {e}", path.display())))?,
        ),
        None => Eeprom::Memory(MemNvm::new(capacity)),
    };
    let start = std::time::Instant::now();
    let clock = move || Instant::from_micros(start.elapsed().as_micros() as u64);
    let board = SimBoard::for_model(spec, nvm).with_world(world).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let mut module = Core::new(board.with_clock(clock), spec, clock());
    if fresh && module.address() != address {
        module
            .execute(Command::Sgp { param: 66, bank: 0, value: i32::from(address) }, clock())
            .map_err(|s| PyValueError::new_err(format!("address {address}: {s}")))?;
    }
    Ok(Arc::new(Mutex::new(Shared { module, start, stopped: false })))
}

/// A reply: status (100 = ok, PD28-1021 manual §3.2.1), value, and the nine bytes a host would read.
#[pyclass(module = "opentmcl._native", frozen, get_all)]
#[derive(Debug, Clone)]
pub struct Reply {
    /// The status code (100 ok, 101 stored in program memory, 1–6 errors); `None` for a special reply.
    pub status: Option<u8>,
    /// The value; `None` for a special reply (136 type 0: the version text) or none at all.
    pub value: Option<i32>,
    /// The command number answered.
    pub opcode: u8,
    /// The nine bytes on the wire (empty when the command has no reply, e.g. 137 in direct access).
    pub raw: Vec<u8>,
}

#[pymethods]
impl Reply {
    /// Whether the status means success (100, 101, 128).
    #[getter]
    fn ok(&self) -> bool {
        self.status.is_some_and(|s| Status::from(s).is_success()) || (self.status.is_none() && !self.raw.is_empty())
    }

    /// The status in words, as the manual's table.
    #[getter]
    fn status_text(&self) -> &'static str {
        match self.status {
            Some(s) => Status::from(s).description(),
            None => "special reply",
        }
    }

    /// The raw bytes as `bytes`.
    fn __bytes__<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.raw)
    }

    fn __repr__(&self) -> String {
        match (self.status, self.value) {
            (Some(s), Some(v)) => format!("Reply(status={s}, value={v}, opcode={})", self.opcode),
            _ => format!("Reply(special, raw={:02X?})", self.raw),
        }
    }
}

/// The reply to `instruction`, executed as a host's request on the primary interface at `now`.
fn reply_of(shared: &mut Shared, instruction: Instruction) -> Reply {
    let now = shared.now();
    let opcode = instruction.opcode.code();
    let address = shared.module.address();
    let normal = |status: Status, value: i32| {
        let reply = tmcl_wire::Reply { host: 2, module: address, status, opcode, value };
        Reply { status: Some(status.into()), value: Some(value), opcode, raw: reply.to_bytes().to_vec() }
    };
    match shared.module.execute_instruction(now, instruction) {
        Ok(Outcome::Value(v)) | Ok(Outcome::Restart(v)) => normal(Status::Ok, v),
        Ok(Outcome::EnterAscii) => normal(Status::Ok, 0),
        Ok(Outcome::Raw(raw)) => Reply { status: None, value: None, opcode, raw: raw.to_vec() },
        Ok(Outcome::Silent) => Reply { status: None, value: None, opcode, raw: Vec::new() },
        Err(status) => normal(status, instruction.value),
    }
}

/// A command given as a mnemonic (`"GAP"`, any case) or a number.
fn opcode_of(command: &Bound<'_, PyAny>) -> PyResult<Opcode> {
    if let Ok(code) = command.extract::<u8>() {
        return Ok(Opcode::from(code));
    }
    let word: String = command.extract().map_err(|_| PyValueError::new_err("a command is a mnemonic or a number"))?;
    Opcode::from_mnemonic(word.trim()).ok_or_else(|| PyValueError::new_err(format!("unknown command {word:?}")))
}

/// A virtual TMCL module in this process: the OpenTMCL firmware core on a simulated board, in real time.
#[pyclass(module = "opentmcl._native", subclass)]
pub struct Module {
    pub(crate) handle: Handle,
    pub(crate) spec: &'static ModelSpec,
    eeprom: Option<PathBuf>,
    closed: bool,
    clock: Option<std::thread::JoinHandle<()>>,
}

impl Module {
    pub(crate) fn shared(&self) -> PyResult<MutexGuard<'_, Shared>> {
        if self.closed {
            return Err(PyRuntimeError::new_err("the module is closed"));
        }
        lock(&self.handle)
    }

    /// Wakes the clock thread: a request may have brought a deadline closer.
    fn wake(&self) {
        if let Some(clock) = &self.clock {
            clock.thread().unpark();
        }
    }

    /// A request, and the clock woken after it.
    fn ask(&self, instruction: Instruction) -> PyResult<Reply> {
        let reply = reply_of(&mut *self.shared()?, instruction);
        self.wake();
        Ok(reply)
    }

    fn param(&self, name: &str) -> PyResult<Param> {
        names::lookup(self.spec, name)
    }

    fn checked(reply: Reply) -> PyResult<i32> {
        match (reply.status, reply.value) {
            (Some(s), Some(v)) if Status::from(s).is_success() => Ok(v),
            (Some(s), _) => Err(tmcl_error(s, reply.opcode)),
            _ => Err(PyRuntimeError::new_err("no value in the reply")),
        }
    }
}

/// A `TmclError` for status `status` of command `opcode`, with `status` as an attribute.
pub(crate) fn tmcl_error(status: u8, opcode: u8) -> PyErr {
    let text = Status::from(status).description();
    let err = TmclError::new_err(format!("command {opcode}: status {status} ({text})"));
    Python::attach(|py| {
        let _ = err.value(py).setattr("status", status);
    });
    err
}

#[pymethods]
impl Module {
    /// A virtual module of `model` (`opentmcl.models()` lists them) in `world` (a TOML world file's path
    /// or text, `docs/world.md`; default a free axis), its EEPROM in memory or in the file `eeprom`
    /// (crash-safe, kept across restarts), answering at `address` while its EEPROM is new.
    #[new]
    #[pyo3(signature = (model = "pd28-1021", world = None, eeprom = None, address = 1))]
    fn new(model: &str, world: Option<&Bound<'_, PyAny>>, eeprom: Option<PathBuf>, address: u8) -> PyResult<Module> {
        let spec = crate::model_by_id(model)?;
        let world = load_world(world)?;
        let handle = build(spec, world, eeprom.as_deref(), address)?;
        let clock = Some(start_clock(&handle)?);
        Ok(Module { handle, spec, eeprom, closed: false, clock })
    }

    /// The model's id (`pd28-1021`).
    #[getter]
    fn model(&self) -> &'static str {
        self.spec.id
    }

    /// The product's name (`PD28-1021`).
    #[getter]
    fn name(&self) -> &'static str {
        self.spec.name
    }

    /// The address the module answers at now (GP 66).
    #[getter]
    fn address(&self) -> PyResult<u8> {
        Ok(self.shared()?.module.address())
    }

    /// The EEPROM file, if the EEPROM is kept in one.
    #[getter]
    fn eeprom(&self) -> Option<PathBuf> {
        self.eeprom.clone()
    }

    /// The module's time in seconds since it was made.
    #[getter]
    fn time(&self) -> PyResult<f64> {
        Ok(self.shared()?.start.elapsed().as_secs_f64())
    }

    /// Sends one command as a host on the primary interface would, without a link, and returns the
    /// reply. `command` is a mnemonic (`"GAP"`, `"MVP"`, any case) or a command number; `type`,
    /// `motor` (or bank) and `value` as in the 9-byte frame (PD28-1021 manual §3.1). A refused command
    /// is a reply with its error status, not an exception.
    #[pyo3(signature = (command, r#type = 0, motor = 0, value = 0))]
    fn request(&self, command: &Bound<'_, PyAny>, r#type: u8, motor: u8, value: i64) -> PyResult<Reply> {
        let opcode = opcode_of(command)?;
        // Hosts write values above 2^31 as their 32-bit pattern (0xFFFFFFFF = -1).
        let value = i32::try_from(value)
            .or_else(|_| u32::try_from(value).map(|v| v as i32))
            .map_err(|_| PyValueError::new_err(format!("{value} is not a 32-bit value")))?;
        let instruction = Instruction::new(opcode, r#type, motor, value);
        let reply = reply_of(&mut *self.shared()?, instruction);
        self.wake();
        Ok(reply)
    }

    /// Reads a parameter by name (`"MaxPositioningSpeed"`, `"APActualPosition"`, `"Maximum
    /// positioning speed"`): GAP of `motor` for an axis parameter, GGP for a global one. A refusal is
    /// `TmclError`, an unknown name `KeyError`.
    #[pyo3(signature = (name, motor = 0))]
    fn get(&self, name: &str, motor: u8) -> PyResult<i32> {
        let p = self.param(name)?;
        let i = if p.axis {
            Instruction::new(Opcode::Gap, p.number, motor, 0)
        } else {
            Instruction::new(Opcode::Ggp, p.number, p.bank, 0)
        };
        Module::checked(self.ask(i)?)
    }

    /// Writes a parameter by name (SAP or SGP). A refusal (read-only, out of range) is `TmclError`.
    #[pyo3(signature = (name, value, motor = 0))]
    fn set(&self, name: &str, value: i32, motor: u8) -> PyResult<()> {
        let p = self.param(name)?;
        let i = if p.axis {
            Instruction::new(Opcode::Sap, p.number, motor, value)
        } else {
            Instruction::new(Opcode::Sgp, p.number, p.bank, value)
        };
        Module::checked(self.ask(i)?).map(drop)
    }

    /// Stores a parameter's value in the EEPROM by name (STAP or STGP).
    #[pyo3(signature = (name, motor = 0))]
    fn store(&self, name: &str, motor: u8) -> PyResult<()> {
        let p = self.param(name)?;
        let i = if p.axis {
            Instruction::new(Opcode::Stap, p.number, motor, 0)
        } else {
            Instruction::new(Opcode::Stgp, p.number, p.bank, 0)
        };
        Module::checked(self.ask(i)?).map(drop)
    }

    /// Puts a program into the module's program memory (as a host's download, 132…133), not started:
    /// a `Program`, a `.bin` image or a list of `(opcode, type, motor, value)` tuples. `autostart=True`
    /// also starts it (129 type 0 at address 0).
    #[pyo3(signature = (program, start = false))]
    fn load_program(&self, program: &Bound<'_, PyAny>, start: bool) -> PyResult<()> {
        let instructions = crate::asm::instructions_of(program)?;
        let mut shared = self.shared()?;
        let now = shared.catch_up();
        if instructions.len() > usize::from(self.spec.program_memory) {
            return Err(PyValueError::new_err(format!(
                "{} instructions do not fit into the {}'s {} program cells",
                instructions.len(),
                self.spec.name,
                self.spec.program_memory
            )));
        }
        shared.module.load_program(&instructions).map_err(|s| tmcl_error(s.into(), Opcode::StartDownload.code()))?;
        if start {
            shared
                .module
                .execute_instruction(now, Instruction::new(Opcode::RunApplication, 1, 0, 0))
                .map_err(|s| tmcl_error(s.into(), Opcode::RunApplication.code()))?;
        }
        drop(shared);
        self.wake();
        Ok(())
    }

    /// The world around the motor: readings and changes (see `World`).
    #[getter]
    fn world(&self) -> World {
        World { handle: Arc::clone(&self.handle) }
    }

    /// Stops the module: its EEPROM file is synced and released (a new `Module` may open it). Further
    /// use is an error. Closing twice does nothing.
    pub(crate) fn close(&mut self) -> PyResult<()> {
        if self.closed {
            return Ok(());
        }
        let mut shared = lock(&self.handle)?;
        shared.catch_up();
        let synced = shared.module.board_mut().eeprom().sync();
        // The EEPROM file's lock goes with the board: a fresh in-memory board takes its place.
        let spec = self.spec;
        let old = std::mem::replace(&mut shared.module, Core::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO));
        drop(old);
        shared.stopped = true;
        drop(shared);
        self.closed = true;
        if let Some(clock) = self.clock.take() {
            clock.thread().unpark();
            let _ = clock.join();
        }
        synced.map_err(|e| PyRuntimeError::new_err(format!("EEPROM: {e}")))
    }

    /// Whether `close` was called.
    #[getter]
    fn closed(&self) -> bool {
        self.closed
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_exc))]
    fn __exit__(&mut self, _exc: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close()?;
        Ok(false)
    }

    fn __repr__(&self) -> String {
        let address = lock(&self.handle).map(|s| s.module.address()).unwrap_or(0);
        let state = if self.closed { ", closed" } else { "" };
        format!("<opentmcl.Module {}@{address}{state}>", self.spec.id)
    }
}

/// The world around a module's motor: what the shaft, the load and the outputs do, and the world
/// itself, which can be replaced.
#[pyclass(module = "opentmcl._native")]
pub struct World {
    handle: Handle,
}

impl World {
    fn read<T>(&self, f: impl FnOnce(&SimBoard) -> T) -> PyResult<T> {
        let mut shared = lock(&self.handle)?;
        shared.catch_up();
        Ok(f(shared.module.board()))
    }
}

#[pymethods]
impl World {
    /// Puts the motor into another world (a TOML world file's path or text, `docs/world.md`), as at
    /// power-up: the rotor at the world's start, its timeline (inputs, scripted loads, faults) counted
    /// from the module's time 0, so entries already past apply at once. The EEPROM, the parameters and
    /// the outputs are kept.
    fn load(&self, world: &Bound<'_, PyAny>) -> PyResult<()> {
        let world = load_world(Some(world))?;
        let mut shared = lock(&self.handle)?;
        let now = shared.catch_up();
        shared.module.board_mut().set_world(world).map_err(|e| PyValueError::new_err(e.to_string()))?;
        shared.module.board_timeline().advance(now);
        Ok(())
    }

    /// The rotor's position since power-up, in physical 1/256 microsteps.
    #[getter]
    fn shaft(&self) -> PyResult<i64> {
        self.read(|b| b.shaft())
    }

    /// Where the driver's field is since power-up, in physical 1/256 microsteps (the shaft of an ideal
    /// motor).
    #[getter]
    fn commanded(&self) -> PyResult<i64> {
        self.read(|b| b.commanded())
    }

    /// Full steps the rotor has fallen behind the field (negative: ahead).
    #[getter]
    fn lost_full_steps(&self) -> PyResult<i64> {
        self.read(|b| b.lost_full_steps())
    }

    /// The axis position in its unit (mm on a linear axis, degrees on a rotary one).
    #[getter]
    fn position(&self) -> PyResult<f64> {
        self.read(|b| b.axis_position())
    }

    /// The load the motor holds or moves against now (N·m).
    #[getter]
    fn load_torque(&self) -> PyResult<f64> {
        self.read(|b| b.load_torque())
    }

    /// The coil peak current now (A).
    #[getter]
    fn coil_current(&self) -> PyResult<f64> {
        self.read(|b| b.coil_current())
    }

    /// The supply voltage now (V).
    #[getter]
    fn supply_voltage(&self) -> PyResult<f64> {
        self.read(|b| b.supply_voltage())
    }

    /// The digital outputs (bit n = OUTn).
    #[getter]
    fn outputs(&self) -> PyResult<u8> {
        self.read(|b| b.outputs())
    }

    fn __repr__(&self) -> String {
        match self.read(|b| (b.axis_position(), b.load_torque())) {
            Ok((position, load)) => format!("<World: axis at {position:.3}, load {load:.3} N·m>"),
            Err(_) => "<World: module failed>".into(),
        }
    }
}

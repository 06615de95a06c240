//! `Module`: a virtual TMCL module (the OpenTMCL firmware core on its simulated board) in the Python
//! process, in real time, with direct access (`request`, `get`, `set`) and its world (`World`).
//!
//! The module's time is the wall clock since it was made, as under `tmcl serve`: a motor moves while
//! Python does something else. The core is event-driven, so a module nobody asks costs nothing; each
//! request first brings it to the current instant.

use crate::names;
use crate::TmclError;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use tmcl_core::model::ModelSpec;
use tmcl_core::param::persist;
use tmcl_core::{Instant, Module as Core, Outcome};
use tmcl_sim::world::InputChange;
use tmcl_sim::{Change, Eeprom, FileNvm, MemNvm, SimBoard, SwitchId};
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

/// Brings a module and its world to `now` without taking what is queued for a host.
fn catch_up(module: &mut Core<SimBoard>, now: Instant) {
    module.poll_port(NO_PORT, now, &mut |_: &[u8]| {});
    module.board_timeline().advance(now);
}

/// Where a `Module`'s firmware runs: in this crate's own module with its clock thread, or in a server
/// (`tmcl-serve`) that serves it on a link, reached between the serve loop's polls.
#[derive(Clone)]
pub(crate) enum Target {
    /// Not served: the module and its clock thread.
    Local(Handle),
    /// Served: module `index` of the server.
    Served {
        /// The server's handle for direct work on its modules.
        access: tmcl_serve::Access,
        /// The module's place on the line.
        index: usize,
    },
}

impl Target {
    /// Runs `f` on the module brought to now; an error once the module is closed.
    pub(crate) fn with<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Core<SimBoard>, Instant) -> R + Send + 'static,
    ) -> PyResult<R> {
        let closed = || PyRuntimeError::new_err("the module is closed");
        match self {
            Target::Local(handle) => {
                let mut shared = lock(handle)?;
                if shared.stopped {
                    return Err(closed());
                }
                let now = shared.catch_up();
                Ok(f(&mut shared.module, now))
            }
            Target::Served { access, index } => access
                .with_module(*index, move |module, now| {
                    catch_up(module, now);
                    f(module, now)
                })
                .ok_or_else(closed),
        }
    }
}

/// A server shared by the modules it serves (one, or a bus): stopped with the last of them.
pub(crate) struct Served {
    server: Option<tmcl_serve::RunningServer>,
    /// A directory made for the pty link, removed after the server.
    tempdir: Option<PathBuf>,
}

impl Served {
    /// Stops the server (links removed, EEPROM files flushed) and removes the link's directory.
    fn stop(&mut self) -> PyResult<()> {
        let stopped = self.server.take().map_or(Ok(()), |s| s.stop());
        if let Some(dir) = self.tempdir.take() {
            let _ = std::fs::remove_dir_all(dir);
        }
        stopped.map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}

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
fn reply_of(module: &mut Core<SimBoard>, now: Instant, instruction: Instruction) -> Reply {
    let opcode = instruction.opcode.code();
    let address = module.address();
    let normal = |status: Status, value: i32| {
        let reply = tmcl_wire::Reply { host: 2, module: address, status, opcode, value };
        Reply { status: Some(status.into()), value: Some(value), opcode, raw: reply.to_bytes().to_vec() }
    };
    match module.execute_instruction(now, instruction) {
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
    pub(crate) target: Target,
    pub(crate) spec: &'static ModelSpec,
    eeprom: Option<PathBuf>,
    closed: bool,
    /// The clock thread of a module that is not served.
    clock: Option<std::thread::JoinHandle<()>>,
    /// The server of a served module, shared with the other modules of its bus.
    served: Option<Arc<Mutex<Served>>>,
    link: Option<PathBuf>,
    tcp_address: Option<String>,
}

/// A link asked for: `True` (a new one), a path or address, or nothing.
fn link_option(value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Option<String>>> {
    let Some(value) = value.filter(|v| !v.is_none()) else { return Ok(None) };
    if let Ok(flag) = value.extract::<bool>() {
        return Ok(flag.then_some(None));
    }
    if let Ok(text) = value.extract::<String>() {
        return Ok(Some(Some(text)));
    }
    let path: PathBuf = value.extract()?;
    Ok(Some(Some(path.display().to_string())))
}

/// A fresh directory for a pty link, under the system's temporary directory.
fn link_dir() -> PyResult<PathBuf> {
    use std::sync::atomic::{AtomicU32, Ordering};
    static NEXT: AtomicU32 = AtomicU32::new(0);
    loop {
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("opentmcl-{}-{n}", std::process::id()));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(PyRuntimeError::new_err(format!("cannot make {}: {e}", dir.display()))),
        }
    }
}

/// What one module of a server is made of.
struct Wanted {
    spec: &'static ModelSpec,
    world: tmcl_sim::World,
    eeprom: Option<PathBuf>,
    address: u8,
}

/// Serves `wanted` on a pty (`link`), a loopback TCP port (`tcp`) or both at once — each a host interface
/// of its own on every module (a host on one never sees the replies to the other) — and returns one
/// `Module` per entry.
fn serve(
    wanted: Vec<Wanted>,
    link: Option<Option<String>>,
    tcp: Option<Option<String>>,
    wire_timing: bool,
) -> PyResult<Vec<Module>> {
    if link.is_some() && tcp.is_some() && wire_timing {
        return Err(PyValueError::new_err("wire_timing times one wire: serve on one link (link=... or tcp=...)"));
    }
    let mut tempdir = None;
    let mut links = Vec::new();
    if let Some(path) = link {
        let path = match path {
            Some(path) => PathBuf::from(path),
            None => {
                let dir = link_dir()?;
                tempdir = Some(dir.clone());
                dir.join("tmcl-link")
            }
        };
        links.push(tmcl_serve::LinkOptions::Pty(path));
    }
    if let Some(address) = tcp {
        links.push(tmcl_serve::LinkOptions::Tcp(address.unwrap_or_else(|| "127.0.0.1:0".into())));
    }
    let modules = wanted
        .iter()
        .map(|w| {
            let mut m = tmcl_serve::ModuleOptions::new(w.spec).address(w.address).world(w.world.clone());
            m.eeprom = w.eeprom.clone();
            m
        })
        .collect();
    let mut options = tmcl_serve::Options::new(modules, links);
    options.wire_timing = wire_timing;
    let server = tmcl_serve::Server::new(options).and_then(|s| s.spawn()).map_err(|e| {
        if let Some(dir) = &tempdir {
            let _ = std::fs::remove_dir_all(dir);
        }
        PyRuntimeError::new_err(e.to_string())
    })?;
    let (mut link, mut tcp_address) = (None, None);
    for info in server.links() {
        match info {
            tmcl_serve::LinkInfo::Pty { link: path, .. } => link = Some(path.clone()),
            tmcl_serve::LinkInfo::Tcp { address } => tcp_address = Some(address.to_string()),
        }
    }
    let access = server.access();
    let served = Arc::new(Mutex::new(Served { server: Some(server), tempdir }));
    Ok(wanted
        .into_iter()
        .enumerate()
        .map(|(index, w)| Module {
            target: Target::Served { access: access.clone(), index },
            spec: w.spec,
            eeprom: w.eeprom,
            closed: false,
            clock: None,
            served: Some(Arc::clone(&served)),
            link: link.clone(),
            tcp_address: tcp_address.clone(),
        })
        .collect())
}

impl Module {
    /// Runs `f` on the module brought to now.
    fn with<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Core<SimBoard>, Instant) -> R + Send + 'static,
    ) -> PyResult<R> {
        if self.closed {
            return Err(PyRuntimeError::new_err("the module is closed"));
        }
        let result = self.target.with(f);
        // A request may have brought a deadline closer: wake the clock thread.
        if let Some(clock) = &self.clock {
            clock.thread().unpark();
        }
        result
    }

    /// A request, as a host's on the primary interface.
    fn ask(&self, instruction: Instruction) -> PyResult<Reply> {
        self.with(move |module, now| reply_of(module, now, instruction))
    }

    fn checked(reply: Reply) -> PyResult<i32> {
        match (reply.status, reply.value) {
            (Some(s), Some(v)) if Status::from(s).is_success() => Ok(v),
            (Some(s), _) => Err(tmcl_error(s, reply.opcode)),
            _ => Err(PyRuntimeError::new_err("no value in the reply")),
        }
    }

    /// A read, write or store of a named parameter.
    fn named(&self, name: &str, motor: u8, value: i32, axis_op: Opcode, global_op: Opcode) -> PyResult<i32> {
        let p = names::lookup(self.spec, name)?;
        let i = if p.axis {
            Instruction::new(axis_op, p.number, motor, value)
        } else {
            Instruction::new(global_op, p.number, p.bank, value)
        };
        Module::checked(self.ask(i)?)
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

/// One module of `Module.bus`: a model id, or a dict of `Module`'s keywords.
fn wanted_of(entry: &Bound<'_, PyAny>, position: usize, interface: Option<&str>) -> PyResult<Wanted> {
    if let Ok(model) = entry.extract::<String>() {
        let spec = on_interface(crate::model_by_id(&model)?, interface)?;
        return Ok(Wanted { spec, world: tmcl_sim::World::default(), eeprom: None, address: position as u8 + 1 });
    }
    let dict = entry
        .cast::<pyo3::types::PyDict>()
        .map_err(|_| PyValueError::new_err("a module of a bus is a model id or a dict of Module's keywords"))?;
    for key in dict.keys() {
        let key: String = key.extract()?;
        if !["model", "world", "eeprom", "address", "interface"].contains(&key.as_str()) {
            return Err(PyValueError::new_err(format!("unknown keyword {key:?} for a module of a bus")));
        }
    }
    let model: String = dict.get_item("model")?.map(|m| m.extract()).transpose()?.unwrap_or_else(|| "pd28-1021".into());
    let world = dict.get_item("world")?;
    let eeprom: Option<PathBuf> = dict.get_item("eeprom")?.filter(|e| !e.is_none()).map(|e| e.extract()).transpose()?;
    let address: u8 = dict.get_item("address")?.map(|a| a.extract()).transpose()?.unwrap_or(position as u8 + 1);
    if address == 0 {
        return Err(PyValueError::new_err("a module address is 1..255"));
    }
    let own: Option<String> = dict.get_item("interface")?.filter(|i| !i.is_none()).map(|i| i.extract()).transpose()?;
    let world = load_world(world.as_ref().filter(|w| !w.is_none()))?;
    let spec = on_interface(crate::model_by_id(&model)?, own.as_deref().or(interface))?;
    Ok(Wanted { spec, world, eeprom, address })
}

/// The model served on its host interface `interface` (`"usb"`, `"rs485"`; `None`: its first), as
/// `tmcl serve --interface`: a USB-first module (the TMCM-1140, -3110, -6110) goes on an RS485 bus with
/// `interface="rs485"`.
fn on_interface(spec: &'static ModelSpec, interface: Option<&str>) -> PyResult<&'static ModelSpec> {
    let Some(name) = interface else { return Ok(spec) };
    tmcl_core::model::on_interface(spec, name).ok_or_else(|| {
        let names: Vec<&str> = spec
            .interfaces
            .iter()
            .map(|i| i.name)
            .filter(|i| tmcl_core::model::on_interface(spec, i).is_some())
            .collect();
        PyValueError::new_err(format!(
            "the {} cannot be served on {name:?}; it is served on: {}",
            spec.name,
            names.join(", ")
        ))
    })
}

#[pymethods]
impl Module {
    /// A virtual module of `model` (`opentmcl.models()` lists them) in `world` (a TOML world file's path
    /// or text, `docs/world.md`; default a free axis), its EEPROM in memory or in the file `eeprom`
    /// (crash-safe, kept across restarts), answering at `address` while its EEPROM is new. `link=True`
    /// (or a path) serves it on a pty that pytrinamic and pyserial open (`.link`); `tcp=True` (or
    /// `"HOST:PORT"`) on a loopback TCP port (`.tcp_address`), or on both at once: each link is a host
    /// interface of its own, and a host on one never sees the replies to the other.
    #[new]
    #[pyo3(signature = (model = "pd28-1021", world = None, eeprom = None, address = 1, link = None, tcp = None, wire_timing = false, interface = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &str,
        world: Option<&Bound<'_, PyAny>>,
        eeprom: Option<PathBuf>,
        address: u8,
        link: Option<&Bound<'_, PyAny>>,
        tcp: Option<&Bound<'_, PyAny>>,
        wire_timing: bool,
        interface: Option<&str>,
    ) -> PyResult<Module> {
        let spec = on_interface(crate::model_by_id(model)?, interface)?;
        let world = load_world(world)?;
        if address == 0 {
            return Err(PyValueError::new_err("a module address is 1..255"));
        }
        let (link, tcp) = (link_option(link)?, link_option(tcp)?);
        if link.is_some() || tcp.is_some() {
            let wanted = vec![Wanted { spec, world, eeprom, address }];
            return Ok(serve(wanted, link, tcp, wire_timing)?.remove(0));
        }
        let handle = build(spec, world, eeprom.as_deref(), address)?;
        let clock = Some(start_clock(&handle)?);
        Ok(Module {
            target: Target::Local(handle),
            spec,
            eeprom,
            closed: false,
            clock,
            served: None,
            link: None,
            tcp_address: None,
        })
    }

    /// Several modules on one line, as on an RS485 bus, served on one pty (`link=True` or a path, the
    /// default), a TCP port (`tcp=True` or `"HOST:PORT"`) or both: `modules` lists model ids or dicts of
    /// `Module`'s keywords (`model`, `world`, `eeprom`, `address`; addresses default to 1, 2, ...).
    /// `wire_timing=True` times every byte at its module's baud rate. `interface="rs485"` serves every
    /// module on its RS485 port (a dict's `interface` key, one of them), as `tmcl serve --interface`: the
    /// TMCM-1140, -3110 and -6110 are USB first, and a USB port answers every address (one per link).
    /// Returns the modules in line order; the line stops when the last of them is closed.
    #[staticmethod]
    #[pyo3(signature = (modules, link = None, tcp = None, wire_timing = false, interface = None))]
    fn bus(
        modules: Vec<Bound<'_, PyAny>>,
        link: Option<&Bound<'_, PyAny>>,
        tcp: Option<&Bound<'_, PyAny>>,
        wire_timing: bool,
        interface: Option<&str>,
    ) -> PyResult<Vec<Module>> {
        if modules.is_empty() {
            return Err(PyValueError::new_err("a bus needs at least one module"));
        }
        let wanted =
            modules.iter().enumerate().map(|(n, m)| wanted_of(m, n, interface)).collect::<PyResult<Vec<_>>>()?;
        let (mut link, tcp) = (link_option(link)?, link_option(tcp)?);
        if link.is_none() && tcp.is_none() {
            link = Some(None);
        }
        serve(wanted, link, tcp, wire_timing)
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
        self.with(|module, _| module.address())
    }

    /// The EEPROM file, if the EEPROM is kept in one.
    #[getter]
    fn eeprom(&self) -> Option<PathBuf> {
        self.eeprom.clone()
    }

    /// The pty link hosts open as a serial port (`None` unless served on one).
    #[getter]
    fn link(&self) -> Option<PathBuf> {
        self.link.clone()
    }

    /// The loopback TCP address hosts connect to, `"127.0.0.1:PORT"` (`None` unless served on TCP).
    #[getter]
    fn tcp_address(&self) -> Option<String> {
        self.tcp_address.clone()
    }

    /// The module's time in seconds since it started.
    #[getter]
    fn time(&self) -> PyResult<f64> {
        self.with(|_, now| now.micros() as f64 / 1e6)
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
        self.ask(Instruction::new(opcode, r#type, motor, value))
    }

    /// Reads a parameter by name (`"MaxPositioningSpeed"`, `"APActualPosition"`, `"Maximum
    /// positioning speed"`): GAP of `motor` for an axis parameter, GGP for a global one. A refusal is
    /// `TmclError`, an unknown name `KeyError`.
    #[pyo3(signature = (name, motor = 0))]
    fn get(&self, name: &str, motor: u8) -> PyResult<i32> {
        self.named(name, motor, 0, Opcode::Gap, Opcode::Ggp)
    }

    /// Writes a parameter by name (SAP or SGP). A refusal (read-only, out of range) is `TmclError`.
    #[pyo3(signature = (name, value, motor = 0))]
    fn set(&self, name: &str, value: i32, motor: u8) -> PyResult<()> {
        self.named(name, motor, value, Opcode::Sap, Opcode::Sgp).map(drop)
    }

    /// Stores a parameter's value in the EEPROM by name (STAP or STGP).
    #[pyo3(signature = (name, motor = 0))]
    fn store(&self, name: &str, motor: u8) -> PyResult<()> {
        self.named(name, motor, 0, Opcode::Stap, Opcode::Stgp).map(drop)
    }

    /// Puts a program into the module's program memory (as a host's download, 132…133), not started:
    /// a `Program`, a `.bin` image or a list of `(opcode, type, motor, value)` tuples. `start=True`
    /// also starts it at address 0 (129 type 1).
    #[pyo3(signature = (program, start = false))]
    fn load_program(&self, program: &Bound<'_, PyAny>, start: bool) -> PyResult<()> {
        let instructions = crate::asm::instructions_of(program)?;
        if instructions.len() > usize::from(self.spec.program_memory) {
            return Err(PyValueError::new_err(format!(
                "{} instructions do not fit into the {}'s {} program cells",
                instructions.len(),
                self.spec.name,
                self.spec.program_memory
            )));
        }
        self.with(move |module, now| {
            module.load_program(&instructions).map_err(|s| (s, Opcode::StartDownload))?;
            if start {
                module
                    .execute_instruction(now, Instruction::new(Opcode::RunApplication, 1, 0, 0))
                    .map_err(|s| (s, Opcode::RunApplication))?;
            }
            Ok(())
        })?
        .map_err(|(s, op): (Status, Opcode)| tmcl_error(s.into(), op.code()))
    }

    /// The world around the motor: readings and changes (see `World`).
    #[getter]
    fn world(&self) -> World {
        World { target: self.target.clone() }
    }

    /// Stops the module: a served one's link is removed (with the last module of its bus), its EEPROM
    /// file synced and released (a new `Module` may open it). Further use is an error. Closing twice
    /// does nothing.
    fn close(&mut self) -> PyResult<()> {
        if self.closed {
            return Ok(());
        }
        self.closed = true;
        if let Some(served) = self.served.take() {
            // The last module of a server stops it.
            return match Arc::try_unwrap(served) {
                Ok(served) => served.into_inner().map_or(Ok(()), |mut s| s.stop()),
                Err(_) => Ok(()),
            };
        }
        let Target::Local(handle) = &self.target else { return Ok(()) };
        let mut shared = lock(handle)?;
        shared.catch_up();
        let synced = shared.module.board_mut().eeprom().sync();
        // The EEPROM file's lock goes with the board: a fresh in-memory board takes its place.
        let spec = self.spec;
        drop(std::mem::replace(&mut shared.module, Core::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO)));
        shared.stopped = true;
        drop(shared);
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
        let address = self.with(|m, _| m.address()).unwrap_or(0);
        let state = if self.closed { ", closed" } else { "" };
        let link = match (&self.link, &self.tcp_address) {
            (Some(link), _) => format!(" on {}", link.display()),
            (None, Some(address)) => format!(" on {address}"),
            _ => String::new(),
        };
        format!("<opentmcl.Module {}@{address}{link}{state}>", self.spec.id)
    }
}

/// The world around a module's motor: what the shaft, the load and the outputs do, and the world
/// itself, which can be replaced (`load`) or changed while the module runs (the switches, `seized`,
/// `friction`, `external_torque`, the inputs; `docs/world.md`, "Changing the world at run time"). A
/// change reaches the firmware at once, as a world file's timeline entry at that instant.
#[pyclass(module = "opentmcl._native")]
pub struct World {
    target: Target,
}

impl World {
    fn read<T: Send + 'static>(&self, f: impl FnOnce(&SimBoard) -> T + Send + 'static) -> PyResult<T> {
        self.target.with(move |module, _| f(module.board()))
    }

    /// Changes the world now, through the module's counting seam (`board_mut`): the firmware's quiet
    /// windows and resting programs end, as at a timeline entry.
    fn change(&self, change: Change) -> PyResult<()> {
        self.target
            .with(move |module, _| module.board_mut().change(change))?
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    fn inputs(&self, change: InputChange) -> PyResult<()> {
        self.change(Change::Inputs(change))
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
        self.target
            .with(move |module, now| {
                module.board_mut().set_world(world)?;
                module.board_timeline().advance(now);
                Ok(())
            })?
            .map_err(|e: tmcl_sim::WorldError| PyValueError::new_err(e.to_string()))
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

    /// Whether the left stop switch is pressed now. Set `True` to press it, `False` to hold it released,
    /// whatever the axis position; `None` lets it follow the position again (its zone in the world file).
    #[getter]
    fn left(&self) -> PyResult<bool> {
        self.read(|b| b.switch_pressed(SwitchId::Left))
    }

    #[setter]
    fn set_left(&self, pressed: Option<bool>) -> PyResult<()> {
        self.change(Change::Switch(SwitchId::Left, pressed))
    }

    /// Whether the right stop switch is pressed now (set as `left`).
    #[getter]
    fn right(&self) -> PyResult<bool> {
        self.read(|b| b.switch_pressed(SwitchId::Right))
    }

    #[setter]
    fn set_right(&self, pressed: Option<bool>) -> PyResult<()> {
        self.change(Change::Switch(SwitchId::Right, pressed))
    }

    /// Whether the home switch is pressed now (set as `left`).
    #[getter]
    fn home(&self) -> PyResult<bool> {
        self.read(|b| b.switch_pressed(SwitchId::Home))
    }

    #[setter]
    fn set_home(&self, pressed: Option<bool>) -> PyResult<()> {
        self.change(Change::Switch(SwitchId::Home, pressed))
    }

    /// Whether the shaft is seized now. Set `True` to seize it where the rotor is (it moves neither way),
    /// `False` to free it (also from a world file's seizure window open now).
    #[getter]
    fn seized(&self) -> PyResult<bool> {
        self.read(|b| b.seized())
    }

    #[setter]
    fn set_seized(&self, seized: bool) -> PyResult<()> {
        self.change(if seized { Change::Seize } else { Change::Free })
    }

    /// The Coulomb friction on the shaft (N·m, ≥ 0); settable.
    #[getter]
    fn friction(&self) -> PyResult<f64> {
        self.read(|b| b.friction())
    }

    #[setter]
    fn set_friction(&self, friction: f64) -> PyResult<()> {
        self.change(Change::Friction(friction))
    }

    /// The external torque on the shaft (N·m, positive pushes toward +), as the world file's
    /// `load.script` sets it; settable (replaces the script's value until its next entry).
    #[getter]
    fn external_torque(&self) -> PyResult<f64> {
        self.read(|b| b.external_torque())
    }

    #[setter]
    fn set_external_torque(&self, torque: f64) -> PyResult<()> {
        self.change(Change::Load(torque))
    }

    /// The digital inputs (bit n = INn); settable.
    #[getter(inputs)]
    fn digital_inputs(&self) -> PyResult<u8> {
        self.read(|b| b.world.inputs)
    }

    #[setter(inputs)]
    fn set_digital_inputs(&self, bits: u8) -> PyResult<()> {
        self.inputs(InputChange { digital: Some(bits), ..InputChange::default() })
    }

    /// The analog input 0 (0..=4095); settable.
    #[getter]
    fn analog(&self) -> PyResult<u16> {
        self.read(|b| b.world.analog)
    }

    #[setter]
    fn set_analog(&self, value: u16) -> PyResult<()> {
        let analog = Some(tmcl_sim::world::Spanned::new(0..0, value));
        self.inputs(InputChange { analog, ..InputChange::default() })
    }

    /// The module temperature (°C); settable (from 100 °C the driver warns, from 150 °C it shuts down).
    #[getter]
    fn temperature(&self) -> PyResult<i32> {
        self.read(|b| b.world.temperature)
    }

    #[setter]
    fn set_temperature(&self, celsius: i32) -> PyResult<()> {
        self.inputs(InputChange { temperature: Some(celsius), ..InputChange::default() })
    }

    /// The encoder loses (or gains) `counts` counts now, as a world file's `faults.encoder_slip`.
    fn slip_encoder(&self, counts: i64) -> PyResult<()> {
        self.change(Change::EncoderSlip(counts))
    }

    fn __repr__(&self) -> String {
        match self.read(|b| (b.axis_position(), b.load_torque())) {
            Ok((position, load)) => format!("<World: axis at {position:.3}, load {load:.3} N·m>"),
            Err(_) => "<World: module failed>".into(),
        }
    }
}

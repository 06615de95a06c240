//! Virtual TMCL modules served to host software in real time: on a pseudo-terminal that hosts open as a
//! serial port, on a TCP port, and (the TMCM-1310) as an EtherCAT slave on a network interface.
//!
//! This is the library behind `tmcl serve`; embed it to run virtual modules inside another program (the
//! Python package does, for its pytest plugin). The firmware core runs on a `tmcl_sim::SimBoard`; this crate only
//! moves bytes and wall-clock time between the OS and `tmcl_core::Module` (`receive_in_turn`, `poll_port`; for
//! EtherCAT, frames between a packet socket and `tmcl_ethercat::Slave`), and sleeps until the module's next
//! deadline, the next byte, the next frame or a stop request, whichever comes first.
//!
//! # Use
//!
//! ```no_run
//! use tmcl_serve::{LinkOptions, ModuleOptions, Options, Server};
//!
//! let spec = tmcl_core::model::by_id("pd28-1021").unwrap();
//! let options = Options::new(vec![ModuleOptions::new(spec).address(1)], vec![LinkOptions::Tcp("127.0.0.1:0".into())]);
//! let server = Server::new(options)?.spawn()?;
//! println!("serving on {}", server.links()[0]);
//! // ... host software talks to the module ...
//! server.stop()?; // links removed, EEPROM files flushed
//! # Ok::<(), tmcl_serve::ServeError>(())
//! ```
//!
//! [`Server::new`] opens everything (the links, their lock files, the EEPROM files, the raw socket) and
//! fails before any of it is visible if one part cannot be had. [`Server::run`] serves on the calling
//! thread until its [`Stopper`] is told to stop (`tmcl serve` wires SIGINT and SIGTERM to it);
//! [`Server::spawn`] runs it on a thread of its own and returns a [`RunningServer`] that stops it when
//! dropped. Stopping removes the links (a pty link only while it still points at this server's pty) and
//! their lock files, and flushes every EEPROM file.
//!
//! # Several links
//!
//! [`Options::links`] may name up to four links (ptys and TCP ports mixed). Each is a host interface of its
//! own on every module (its own framer, ASCII line and replies; `tmcl_core::Module::link_port`), so a
//! script on one link and the workbench on another never see each other's replies; they share the module.
//! `wire_timing` times one wire and takes one link. A backlog of frames on any link is answered in order,
//! one reply per frame (see [`bus`]).
//!
//! # Several lines
//!
//! [`Fleet`] serves several lines in one process (`tmcl serve --fleet FILE`), each a [`Server`] on a
//! thread of its own: a rack of USB modules (one module per link) and RS485 buses side by side.
//!
//! # Layers
//!
//! - [`pty`]: a pseudo-terminal behind a symlink, with its lock file `LINK.lock` (one server per link).
//! - [`bus`]: the RS485 line the modules share, with byte timing when asked for.
//! - [`ethercat`]: the packet socket and the FoE files of `--ethercat`.
//! - this file: the modules, the links, the serve loop.

pub mod bus;
pub mod ethercat;
mod fleet;
mod in_process;
pub mod monitor;
pub mod pty;
mod serve;
pub mod share;
mod tcp;
mod trace;

use std::fmt;
use std::path::PathBuf;

pub use fleet::Fleet;
pub use in_process::InProcess;
pub use monitor::MonitorOptions;
pub use serve::{Access, RunningServer, Server, Stopper};
pub use share::{DeviceOptions, RunningShare, Share, ShareOptions};

/// Why a server could not be made or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// Options that do not fit together (several modules at one address, EtherCAT on a module without it).
    #[error("{0}")]
    Config(String),
    /// A world or model that does not fit.
    #[error("{0}")]
    Input(String),
    /// A link, file or socket the OS refused (a link another server holds, a TCP port in use).
    #[error("{0}")]
    Io(String),
}

/// One module to serve.
#[derive(Debug, Clone)]
pub struct ModuleOptions {
    /// Its model.
    pub spec: &'static tmcl_core::model::ModelSpec,
    /// The address it answers at when its EEPROM is new; a module keeps the address stored in its EEPROM
    /// (global parameter 66). `None`: the model's default (1), or on a bus its position on the line.
    pub address: Option<u8>,
    /// Keep its EEPROM in this file (crash-safe; FILE.journal beside it); `None` keeps it in memory.
    pub eeprom: Option<PathBuf>,
    /// The world its motor moves in (docs/world.md); default: a free axis.
    pub world: tmcl_sim::World,
}

impl ModuleOptions {
    /// A module of this model with a new EEPROM in memory, in a free world.
    pub fn new(spec: &'static tmcl_core::model::ModelSpec) -> ModuleOptions {
        ModuleOptions { spec, address: None, eeprom: None, world: tmcl_sim::World::default() }
    }

    /// Starts at `address` (if its EEPROM is new).
    #[must_use]
    pub fn address(mut self, address: u8) -> ModuleOptions {
        self.address = Some(address);
        self
    }

    /// Keeps its EEPROM in `file`.
    #[must_use]
    pub fn eeprom(mut self, file: impl Into<PathBuf>) -> ModuleOptions {
        self.eeprom = Some(file.into());
        self
    }

    /// Puts its motor into `world`.
    #[must_use]
    pub fn world(mut self, world: tmcl_sim::World) -> ModuleOptions {
        self.world = world;
        self
    }
}

/// A host link to serve on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkOptions {
    /// A pseudo-terminal; the path becomes a symlink to its slave side (see [`pty::Pty`]).
    Pty(PathBuf),
    /// A TCP port, `HOST:PORT` or a bare `PORT` (on 127.0.0.1); port 0 picks a free one.
    Tcp(String),
}

/// The EtherCAT interface of a TMCM-1310 (`tmcl serve --ethercat`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EtherCatOptions {
    /// The network interface (Linux).
    pub interface: String,
    /// Where files a master writes by FoE are kept; `None` counts and reports them only.
    pub foe: Option<PathBuf>,
    /// Where the words a master writes into the SII EEPROM are kept (a crash-safe file like the module's
    /// EEPROM, and its `.journal`); `None` keeps them in memory until the server stops.
    pub sii: Option<PathBuf>,
}

/// Everything a server serves.
#[derive(Debug, Clone)]
pub struct Options {
    /// The modules on the line, in order.
    pub modules: Vec<ModuleOptions>,
    /// The host links.
    pub links: Vec<LinkOptions>,
    /// The EtherCAT interface (one module only).
    pub ethercat: Option<EtherCatOptions>,
    /// Every byte at the byte time of its module's baud rate (GP 65), as on a real wire.
    pub wire_timing: bool,
    /// Tick the motion controller every 1 ms instead of sleeping from event to event.
    pub exact_ticks: bool,
    /// Log every request and reply (EtherCAT: the AL state changes) to stderr.
    pub verbose: bool,
    /// The transaction log (`--log FILE`) and the monitor socket (`tmcl monitor`), see [`monitor`].
    pub monitor: MonitorOptions,
}

impl Options {
    /// These modules on these links, nothing else.
    pub fn new(modules: Vec<ModuleOptions>, links: Vec<LinkOptions>) -> Options {
        Options {
            modules,
            links,
            ethercat: None,
            wire_timing: false,
            exact_ticks: false,
            verbose: false,
            monitor: MonitorOptions::default(),
        }
    }
}

/// A module as served.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ModuleInfo {
    /// The address it answers at (global parameter 66).
    pub address: u8,
    /// The model's id (`pd28-1021`).
    pub model: String,
    /// The model's name (`PD28-1021`).
    pub name: String,
}

/// A link as served: where hosts reach it.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinkInfo {
    /// A pty: the symlink hosts open, and the device it points at.
    Pty {
        /// The symlink.
        link: PathBuf,
        /// The slave device (`/dev/pts/N`).
        device: PathBuf,
    },
    /// A TCP port, as bound (port 0 resolved).
    Tcp {
        /// The address.
        address: std::net::SocketAddr,
    },
}

impl fmt::Display for LinkInfo {
    /// What hosts open: the link's path, or the bound address.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkInfo::Pty { link, .. } => write!(f, "{}", link.display()),
            LinkInfo::Tcp { address } => write!(f, "{address}"),
        }
    }
}

//! `tmcl serve`: a virtual module on a pty or a TCP port, in real time, and a TMCM-1310 also on a
//! network interface as an EtherCAT slave (`--ethercat`).
//!
//! The server itself is the `tmcl_serve` library; this file parses the options, builds the server's
//! [`Options`], prints where it serves and wires SIGINT and SIGTERM to its stop.

use crate::error::CliError;
use clap::Args;
use serde::Serialize;
use std::io::{self, Write};
use std::path::PathBuf;
use tmcl_core::model::{self, ModelSpec};
use tmcl_serve::{
    EtherCatOptions, LinkOptions, ModuleInfo, ModuleOptions, MonitorOptions, Options, ServeError, Server,
};

/// Options of `tmcl serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The module to simulate (pd28-1021, tmcm-1310, pd-113, tmcm-1140, tmcm-3110,
    /// tmcm-6110), as MODEL or MODEL@ADDRESS.
    /// Give it several times to put several independent modules on one line (an RS485 bus), e.g.
    /// `--module pd28-1021@1 --module pd28-1021@2`.
    #[arg(long, value_name = "MODEL[@ADDR]", default_value = "pd28-1021")]
    pub module: Vec<String>,
    /// The host interface each module is served on, by name: `usb` or `rs485` (default: the model's
    /// first one). A TMCM-1140 is reached as through its USB port, which answers every address (one
    /// module per link); `--interface rs485` puts it on an RS485 line, beside other modules.
    #[arg(long, value_name = "NAME")]
    pub interface: Option<String>,
    /// Serve on a pseudo-terminal; LINK becomes a symlink to it that hosts open as a serial port.
    ///
    /// One server per LINK: while it runs, the server holds LINK.lock beside it (its PID, with a flock). A
    /// LINK another live server holds is refused (exit code 3, naming that server's PID); a LINK left behind
    /// by a server that died (kill -9) is replaced. On exit LINK and LINK.lock are removed, LINK only if it
    /// still points at this server's pty.
    ///
    /// Give --pty (and --tcp) several times, up to 4 links in all, for several hosts at once (a script and
    /// the workbench): each link is a host interface of its own on every module (its own framer, ASCII line
    /// and replies), so no host ever sees another's replies. The module is one: what one host sets, the
    /// others read. On a bus each link reaches every module, as if each module had that many ports wired
    /// to separate hosts (see docs/decisions.md).
    #[arg(long, value_name = "LINK", required_unless_present_any = ["tcp", "ethercat"])]
    pub pty: Vec<PathBuf>,
    /// Serve on a TCP port, HOST:PORT (e.g. localhost:2323 or 127.0.0.1:2323; a bare PORT means
    /// 127.0.0.1; port 0 picks a free one).
    ///
    /// HOST may be a name; of its addresses IPv4 ones are tried first. One client at a time, as one host on a
    /// serial line: while a client is connected, a second connection is accepted and closed at once without
    /// a byte, and `tmcl` reports the port in use by another client. A port another program listens on is
    /// refused (exit code 3).
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Vec<String>,
    /// The address a module with a new EEPROM answers at (default 1; a module keeps the address stored in
    /// its EEPROM, global parameter 66).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..))]
    pub address: Option<u8>,
    /// Keep the module's EEPROM in FILE (crash-safe; FILE.journal sits beside it). Without it the EEPROM
    /// lives in memory and is lost when the server stops. One module only: for a bus use --eeprom-dir.
    #[arg(long, value_name = "FILE", conflicts_with = "eeprom_dir")]
    pub eeprom: Option<PathBuf>,
    /// Keep each module's EEPROM in DIR, as MODEL@ADDRESS.eeprom (the address it was started with).
    #[arg(long, value_name = "DIR")]
    pub eeprom_dir: Option<PathBuf>,
    /// Send and receive every byte at the byte time of each module's baud rate (GP 65), as on the real
    /// wire; without it the line is as fast as the pty.
    #[arg(long)]
    pub wire_timing: bool,
    /// Put the motor into the world described by FILE (docs/world.md); default: a free axis.
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
    /// Serve the module's EtherCAT interface too, as a slave on the network interface IFACE (Linux):
    /// raw Ethernet frames of EtherType 0x88A4, each answered as it arrives (docs/ethercat.md).
    ///
    /// For a module with EtherCAT (the TMCM-1310), one module only. A master on the other end (SOEM,
    /// pysoem, ethercrab, a PLC) finds it, brings it to OP, cycles process data and talks TMCL through
    /// its mailbox; --pty or --tcp, if given, serves its USB port to the same module at the same time.
    /// Needs CAP_NET_RAW (root). Files a master writes by FoE in BOOT land beside the EEPROM (FILE.foe,
    /// or DIR/MODEL@ADDRESS.foe) and are reported on stderr; nothing is flashed.
    #[arg(long, value_name = "IFACE")]
    pub ethercat: Option<String>,
    /// Log every request and reply to stderr (EtherCAT: the AL state changes).
    #[arg(short, long)]
    pub verbose: bool,
    /// Append every transaction on the host links to FILE, one line each: time, link, the request and the
    /// reply decoded with the model's names and units, status, round trip (with --json, one JSON object
    /// each, as `tmcl monitor --json` prints them).
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Where the monitor socket goes (default: LINK.monitor beside the first --pty link; `tmcl monitor
    /// LINK` reads it).
    #[arg(long, value_name = "PATH")]
    pub monitor_socket: Option<PathBuf>,
    /// Tick the motion controller every 1 ms, and wake up for every tick while a motor moves, instead of
    /// sleeping from event to event: the reference the event-driven module is measured against (same
    /// replies, more CPU time).
    #[arg(long)]
    pub exact_ticks: bool,
}

/// The first line of `tmcl serve --json`: what is served where.
#[derive(Debug, Serialize)]
struct Serving {
    /// The EtherCAT interface, if any.
    ethercat: Option<String>,
    /// Where hosts reach the modules (the first link's path, or the bound TCP address).
    link: Option<String>,
    /// Every link, in the order given (pty links first, then TCP).
    links: Vec<String>,
    /// The modules.
    serving: Vec<ServedModule>,
}

/// A module in [`Serving`].
#[derive(Debug, Serialize)]
struct ServedModule {
    address: u8,
    model: String,
}

impl From<ServeError> for CliError {
    fn from(e: ServeError) -> CliError {
        match e {
            ServeError::Config(m) => CliError::Usage(m),
            ServeError::Input(m) => CliError::Input(m),
            ServeError::Io(m) => CliError::Io(m),
        }
    }
}

/// Runs the server until SIGINT or SIGTERM.
pub(crate) fn run(args: ServeArgs, json: bool) -> Result<(), CliError> {
    let mut server = Server::new(options(&args, json)?)?;
    // A signal ends the server at once, under any load: every EEPROM write is already in its file
    // (crash-safe), so the fsync that only guards against a power loss is left out (docs/decisions.md).
    server.set_flush_on_stop(false);
    for note in server.notes() {
        eprintln!("tmcl serve: {note}");
    }
    let stop = server.stopper().flag();
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, std::sync::Arc::clone(&stop))
            .map_err(|e| CliError::Io(format!("cannot handle signals: {e}")))?;
    }
    let places: Vec<String> = server.links().iter().map(ToString::to_string).collect();
    let place = places.first().cloned();
    let iface = server.ethercat_interface().map(str::to_string);
    let modules = server.modules();
    if json {
        let serving = modules.iter().map(|m| ServedModule { address: m.address, model: m.model.clone() }).collect();
        let line = Serving { ethercat: iface, link: place, links: places, serving };
        println!("{}", serde_json::to_string(&line).map_err(|e| CliError::Io(e.to_string()))?);
    } else {
        let names: Vec<String> =
            modules.iter().map(|ModuleInfo { name, address, .. }| format!("{name} at address {address}")).collect();
        let mut on: Vec<String> = places;
        on.extend(iface.map(|i| format!("EtherCAT {i}")));
        println!("{}", format_args!("serving {} on {}", names.join(", "), on.join(" and ")));
    }
    let _ = io::stdout().flush();
    server.run()?;
    Ok(())
}

/// The server's options from the command line.
fn options(args: &ServeArgs, json: bool) -> Result<Options, CliError> {
    let mut wanted = Vec::new();
    for text in &args.module {
        let (spec, address) = parse_module(text).map_err(CliError::Usage)?;
        let spec = match &args.interface {
            None => spec,
            Some(name) => model::on_interface(spec, name).ok_or_else(|| {
                let names: Vec<&str> =
                    spec.interfaces.iter().map(|i| i.name).filter(|i| model::on_interface(spec, i).is_some()).collect();
                CliError::Usage(format!(
                    "the {} cannot be served on `{name}`; it is served on: {}",
                    spec.name,
                    names.join(", ")
                ))
            })?,
        };
        wanted.push((spec, address));
    }
    if wanted.len() > 1 && (args.eeprom.is_some() || args.address.is_some()) {
        return Err(CliError::Usage(
            "with several modules give each its address as MODEL@ADDR and use --eeprom-dir".into(),
        ));
    }
    let world = match &args.world {
        Some(path) => tmcl_sim::World::load(path).map_err(|e| CliError::Input(e.to_string()))?,
        None => tmcl_sim::World::default(),
    };
    if let Some(dir) = &args.eeprom_dir {
        std::fs::create_dir_all(dir).map_err(|e| CliError::Io(format!("cannot create {}: {e}", dir.display())))?;
    }
    let mut modules = Vec::new();
    for (n, (spec, address)) in wanted.into_iter().enumerate() {
        // The address a module is started with: --address, MODEL@ADDR, or (on a bus without either) its
        // position on the line. It names the module's EEPROM file in --eeprom-dir.
        let address = address.or(args.address).or((n > 0).then_some(n as u8 + 1));
        let name = format!("{}@{}", spec.id, address.unwrap_or(1));
        let eeprom = match (&args.eeprom, &args.eeprom_dir) {
            (Some(file), _) => Some(file.clone()),
            (None, Some(dir)) => Some(dir.join(format!("{name}.eeprom"))),
            (None, None) => None,
        };
        modules.push(ModuleOptions { spec, address, eeprom, world: world.clone() });
    }
    let mut links = Vec::new();
    links.extend(args.pty.iter().map(|p| LinkOptions::Pty(p.clone())));
    links.extend(args.tcp.iter().map(|t| LinkOptions::Tcp(t.clone())));
    let ethercat = args.ethercat.as_ref().map(|iface| EtherCatOptions {
        interface: iface.clone(),
        foe: match (&args.eeprom, &args.eeprom_dir, modules.first()) {
            (Some(file), _, _) => Some(with_suffix(file, ".foe")),
            (None, Some(dir), Some(m)) => Some(dir.join(format!("{}@{}.foe", m.spec.id, m.address.unwrap_or(1)))),
            _ => None,
        },
        sii: match (&args.eeprom, &args.eeprom_dir, modules.first()) {
            (Some(file), _, _) => Some(with_suffix(file, ".sii")),
            (None, Some(dir), Some(m)) => Some(dir.join(format!("{}@{}.sii", m.spec.id, m.address.unwrap_or(1)))),
            _ => None,
        },
    });
    Ok(Options {
        modules,
        links,
        ethercat,
        wire_timing: args.wire_timing,
        exact_ticks: args.exact_ticks,
        verbose: args.verbose,
        monitor: MonitorOptions {
            log: args.log.clone(),
            log_json: json,
            socket: args.monitor_socket.clone(),
            stderr: false,
        },
    })
}

/// One `--module MODEL[@ADDR]`.
fn parse_module(text: &str) -> Result<(&'static ModelSpec, Option<u8>), String> {
    let (id, address) = match text.split_once('@') {
        Some((id, a)) => (
            id,
            Some(
                a.parse::<u8>()
                    .ok()
                    .filter(|a| *a >= 1)
                    .ok_or_else(|| format!("`{a}` in `{text}` is no address (1-255)"))?,
            ),
        ),
        None => (text, None),
    };
    let spec = model::by_id(id).ok_or_else(|| {
        let known: Vec<&str> = model::MODELS.iter().map(|m| m.id).collect();
        format!("unknown module `{id}`; known: {}", known.join(", "))
    })?;
    Ok((spec, address))
}

/// `path` with `suffix` appended to its file name (`a.eeprom` → `a.eeprom.foe`).
fn with_suffix(path: &std::path::Path, suffix: &str) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(suffix);
    PathBuf::from(p)
}

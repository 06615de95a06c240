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
use tmcl_serve::{EtherCatOptions, Fleet, LinkOptions, ModuleInfo, ModuleOptions, MonitorOptions, Options, Server};

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
    #[arg(long, value_name = "LINK", required_unless_present_any = ["tcp", "ethercat", "fleet"])]
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
    /// Log every request and reply (EtherCAT: the AL state changes): set from the global `-v`.
    #[arg(skip)]
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
    /// Serve several lines in one process, as FILE describes them (TOML): each `[[line]]` table takes the
    /// options above by the same names (`module`, `pty`, `tcp`: a string or a list; `interface`, `address`, `eeprom`,
    /// `eeprom_dir`, `world`, `wire_timing`, `ethercat`, `log`, `monitor_socket`), and is served as `tmcl serve` with those options
    /// would serve it, on a thread of its own. Paths in FILE are relative to FILE's directory. --verbose and
    /// --exact-ticks apply to every line; the other options are given in FILE only. Prints one line (one
    /// JSON object with --json) per line; see README.md, "A fleet".
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = [
            "interface", "pty", "tcp", "address", "eeprom", "eeprom_dir", "wire_timing", "world", "ethercat", "log",
            "monitor_socket"
        ]
    )]
    pub fleet: Option<PathBuf>,
}

/// One or several values: `pty = "a"` or `pty = ["a", "b"]`.
#[derive(Debug, Default, serde::Deserialize)]
#[serde(untagged)]
enum OneOrMany<T> {
    #[default]
    None,
    One(T),
    Many(Vec<T>),
}

impl<T> OneOrMany<T> {
    fn into_vec(self) -> Vec<T> {
        match self {
            OneOrMany::None => Vec::new(),
            OneOrMany::One(x) => vec![x],
            OneOrMany::Many(v) => v,
        }
    }
}

/// A `[[line]]` of a fleet file: the options of `tmcl serve` for one line.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct LineSpec {
    #[serde(default)]
    module: OneOrMany<String>,
    interface: Option<String>,
    #[serde(default)]
    pty: OneOrMany<PathBuf>,
    #[serde(default)]
    tcp: OneOrMany<String>,
    address: Option<u8>,
    eeprom: Option<PathBuf>,
    eeprom_dir: Option<PathBuf>,
    #[serde(default)]
    wire_timing: bool,
    world: Option<PathBuf>,
    ethercat: Option<String>,
    log: Option<PathBuf>,
    monitor_socket: Option<PathBuf>,
}

/// A fleet file.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FleetFile {
    line: Vec<LineSpec>,
}

/// The lines of a fleet file, each as the options of `tmcl serve` (with --verbose and --exact-ticks from
/// the command line), paths relative to the file's directory.
fn fleet_lines(file: &std::path::Path, args: &ServeArgs) -> Result<Vec<ServeArgs>, CliError> {
    let text = std::fs::read_to_string(file).map_err(|source| CliError::Read { path: file.to_path_buf(), source })?;
    let fleet: FleetFile =
        toml::from_str(&text).map_err(|e| CliError::Content { path: file.to_path_buf(), source: e.into() })?;
    let dir = file.parent().unwrap_or(std::path::Path::new(""));
    let at = |p: PathBuf| if p.is_absolute() { p } else { dir.join(p) };
    let mut lines = Vec::new();
    for (n, line) in fleet.line.into_iter().enumerate() {
        let mut module = line.module.into_vec();
        if module.is_empty() {
            module.push("pd28-1021".into());
        }
        let (pty, tcp) = (line.pty.into_vec(), line.tcp.into_vec());
        if pty.is_empty() && tcp.is_empty() && line.ethercat.is_none() {
            return Err(CliError::Usage(format!(
                "{}: line {} has no link: give it `pty` or `tcp` (or `ethercat`)",
                file.display(),
                n + 1
            )));
        }
        if line.address == Some(0) {
            return Err(CliError::Usage(format!(
                "{}: line {}: address 0 is no address (1-255)",
                file.display(),
                n + 1
            )));
        }
        lines.push(ServeArgs {
            module,
            interface: line.interface,
            pty: pty.into_iter().map(at).collect(),
            tcp,
            address: line.address,
            eeprom: line.eeprom.map(at),
            eeprom_dir: line.eeprom_dir.map(at),
            wire_timing: line.wire_timing,
            world: line.world.map(at),
            ethercat: line.ethercat,
            log: line.log.map(at),
            monitor_socket: line.monitor_socket.map(at),
            verbose: args.verbose,
            exact_ticks: args.exact_ticks,
            fleet: None,
        });
    }
    if lines.is_empty() {
        return Err(CliError::Usage(format!("{}: no [[line]]", file.display())));
    }
    Ok(lines)
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

/// Runs the server until SIGINT or SIGTERM.
pub(crate) fn run(args: ServeArgs, json: bool) -> Result<(), CliError> {
    if let Some(file) = &args.fleet {
        return run_fleet(file, &args, json);
    }
    let mut server = Server::new(options(&args, json)?)?;
    // A signal ends the server at once, under any load: every EEPROM write is already in its file
    // (crash-safe), so the fsync that only guards against a power loss is left out (docs/decisions.md).
    server.set_flush_on_stop(false);
    prepare(&server)?;
    announce(&server, json)?;
    let _ = io::stdout().flush();
    server.run()?;
    Ok(())
}

/// Before a server runs: its notes on stderr, and SIGINT/SIGTERM made to stop it.
fn prepare(server: &Server) -> Result<(), CliError> {
    for note in server.notes() {
        eprintln!("tmcl serve: {note}");
    }
    server
        .stopper()
        .stop_on_signals(&[signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM])
        .map_err(CliError::Signals)
}

/// `tmcl serve --fleet FILE`: every line of FILE on a thread of its own, until SIGINT or SIGTERM.
fn run_fleet(file: &std::path::Path, args: &ServeArgs, json: bool) -> Result<(), CliError> {
    let lines = fleet_lines(file, args)?.iter().map(|line| options(line, json)).collect::<Result<Vec<_>, _>>()?;
    raise_descriptor_limit(&lines);
    let mut fleet = Fleet::new(lines)?;
    fleet.set_flush_on_stop(false);
    for server in fleet.lines() {
        prepare(server)?;
    }
    for server in fleet.lines() {
        announce(server, json)?;
    }
    let _ = io::stdout().flush();
    fleet.run()?;
    Ok(())
}

/// A fleet keeps about ten descriptors per line (the pty's two sides, its lock file and watch, the monitor socket, the
/// waker and the signals' wake-ups), and EEPROM files: the soft limit on open files (often 1024) is raised
/// to the hard one when a fleet would come near it.
fn raise_descriptor_limit(lines: &[Options]) {
    use nix::sys::resource::{getrlimit, setrlimit, Resource};
    let want = 64 + lines.iter().map(|l| 10 + 3 * l.links.len() + 2 * l.modules.len()).sum::<usize>() as u64;
    if let Ok((soft, hard)) = getrlimit(Resource::RLIMIT_NOFILE) {
        if soft < want {
            let _ = setrlimit(Resource::RLIMIT_NOFILE, hard, hard);
        }
    }
}

/// The line saying what one server serves where (one JSON object with --json).
fn announce(server: &Server, json: bool) -> Result<(), CliError> {
    let places: Vec<String> = server.links().iter().map(ToString::to_string).collect();
    let place = places.first().cloned();
    let iface = server.ethercat_interface().map(str::to_string);
    let modules = server.modules();
    if json {
        let serving = modules.iter().map(|m| ServedModule { address: m.address, model: m.model.clone() }).collect();
        let line = Serving { ethercat: iface, link: place, links: places, serving };
        println!("{}", serde_json::to_string(&line)?);
    } else {
        let names: Vec<String> =
            modules.iter().map(|ModuleInfo { name, address, .. }| format!("{name} at address {address}")).collect();
        let mut on: Vec<String> = places;
        on.extend(iface.map(|i| format!("EtherCAT {i}")));
        println!("{}", format_args!("serving {} on {}", names.join(", "), on.join(" and ")));
    }
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
        Some(path) => tmcl_sim::World::load(path)?,
        None => tmcl_sim::World::default(),
    };
    if let Some(dir) = &args.eeprom_dir {
        std::fs::create_dir_all(dir).map_err(|source| CliError::Write {
            action: "create",
            path: dir.to_path_buf(),
            source,
        })?;
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
    let spec = model::find(id).map_err(|e| e.to_string())?;
    Ok((spec, address))
}

/// `path` with `suffix` appended to its file name (`a.eeprom` → `a.eeprom.foe`).
fn with_suffix(path: &std::path::Path, suffix: &str) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(suffix);
    PathBuf::from(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        serve: ServeArgs,
    }

    fn args(line: &str) -> ServeArgs {
        Cli::try_parse_from(std::iter::once("serve").chain(line.split_whitespace())).unwrap().serve
    }

    #[test]
    fn a_fleet_file_gives_each_line_the_options_of_serve() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("fleet.toml");
        std::fs::write(
            &file,
            r#"
[[line]]
module = "tmcm-1310"
pty = "ports/usb0"
world = "/abs/world.toml"

[[line]]
module = ["pd28-1021@1", "pd-113@2"]
pty = ["ports/a", "ports/b"]
tcp = "127.0.0.1:0"
eeprom_dir = "eeprom"
wire_timing = false
"#,
        )
        .unwrap();
        let mut fleet = args(&format!("--fleet {}", file.display()));
        fleet.verbose = true; // the global -v (main sets it)
        let lines = fleet_lines(&file, &fleet).unwrap();
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[0].module, ["tmcm-1310"]);
        assert_eq!(lines[0].pty, [dir.path().join("ports/usb0")], "relative to the file's directory");
        assert_eq!(lines[0].world.as_deref(), Some(std::path::Path::new("/abs/world.toml")));
        assert!(lines[0].verbose && lines[1].verbose, "--verbose applies to every line");
        assert_eq!(lines[1].module, ["pd28-1021@1", "pd-113@2"]);
        assert_eq!(lines[1].pty, [dir.path().join("ports/a"), dir.path().join("ports/b")]);
        assert_eq!(lines[1].tcp, ["127.0.0.1:0"]);
        assert_eq!(lines[1].eeprom_dir, Some(dir.path().join("eeprom")));
        let options = options(&lines[1], false).unwrap();
        assert_eq!((options.modules.len(), options.links.len()), (2, 3));
    }

    #[test]
    fn a_fleet_file_is_checked() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("fleet.toml");
        let refused = |text: &str| {
            std::fs::write(&file, text).unwrap();
            fleet_lines(&file, &args(&format!("--fleet {}", file.display()))).unwrap_err().to_string()
        };
        assert!(refused("[[line]]\nmodule = \"pd28-1021\"\n").contains("line 1 has no link"));
        assert!(refused("[[line]]\npty = \"a\"\nspeed = 3\n").contains("unknown field `speed`"));
        assert!(refused("line = []\n").contains("no [[line]]"));
        // The per-line options are the file's: not on the command line beside it.
        assert!(Cli::try_parse_from(["serve", "--fleet", "f.toml", "--pty", "a"]).is_err());
        assert!(Cli::try_parse_from(["serve", "--fleet", "f.toml", "--exact-ticks"]).is_ok());
    }
}

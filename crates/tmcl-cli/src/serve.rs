//! `tmcl serve`: a virtual module on a pty or a TCP port, in real time.
//!
//! The firmware core runs on a [`SimBoard`]; this file only moves bytes and wall-clock time between the
//! OS and [`Module::receive`]/[`Module::poll`], and sleeps until the module's next deadline or the next
//! byte, whichever comes first.

use crate::bus::{Bus, Node};
use crate::error::CliError;
use crate::pty::Pty;
use clap::Args;
use nix::poll::{ppoll, PollFd, PollFlags};
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use tmcl_core::model::{self, ModelSpec};
use tmcl_core::param::persist;
use tmcl_core::{Instant, Module};
use tmcl_sim::{Eeprom, FileNvm, MemNvm, SimBoard};
use tmcl_wire::{Command, Frame, Instruction, Reply, ReplyFrame, Request};

/// Longest sleep between two looks at the shutdown flag.
const MAX_SLEEP: std::time::Duration = std::time::Duration::from_millis(50);

/// Options of `tmcl serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The module to simulate, as MODEL or MODEL@ADDRESS. Give it several times to put several
    /// independent modules on one line (an RS485 bus), e.g. `--module pd28-1021@1 --module pd28-1021@2`.
    #[arg(long, value_name = "MODEL[@ADDR]", default_value = "pd28-1021")]
    pub module: Vec<String>,
    /// Serve on a pseudo-terminal; LINK becomes a symlink to it that hosts open as a serial port.
    #[arg(long, value_name = "LINK", conflicts_with = "tcp", required_unless_present = "tcp")]
    pub pty: Option<PathBuf>,
    /// Serve on a TCP port instead, HOST:PORT (e.g. 127.0.0.1:2323; port 0 picks a free one).
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
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
    /// Log every request and reply to stderr.
    #[arg(short, long)]
    pub verbose: bool,
}

/// Where the bytes come from and go to.
enum Link {
    Pty(Pty),
    Tcp { listener: TcpListener, peer: Option<TcpStream> },
}

/// Runs the server until SIGINT or SIGTERM.
pub(crate) fn run(args: ServeArgs, json: bool) -> Result<(), CliError> {
    serve(args, json)
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

fn serve(args: ServeArgs, json: bool) -> Result<(), CliError> {
    let mut wanted = Vec::new();
    for text in &args.module {
        wanted.push(parse_module(text).map_err(CliError::Usage)?);
    }
    if wanted.len() > 1 && (args.eeprom.is_some() || args.address.is_some()) {
        return Err(CliError::Usage(
            "with several modules give each its address as MODEL@ADDR and use --eeprom-dir".into(),
        ));
    }
    // A link whose modules answer every address (USB) holds one module: several would all answer.
    if wanted.len() > 1 {
        if let Some((spec, _)) = wanted.iter().find(|(spec, _)| !spec.interfaces[0].address_filter) {
            return Err(CliError::Usage(format!(
                "the {} is served on its {} interface, which answers every address: one module per link",
                spec.name, spec.interfaces[0].name
            )));
        }
    }
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .map_err(|e| CliError::Io(format!("cannot handle signals: {e}")))?;
    }
    let start = std::time::Instant::now();
    let clock = move || Instant::from_micros(start.elapsed().as_micros() as u64);
    let world = match &args.world {
        Some(path) => tmcl_sim::World::load(path).map_err(|e| CliError::Input(e.to_string()))?,
        None => tmcl_sim::World::default(),
    };
    if let Some(dir) = &args.eeprom_dir {
        std::fs::create_dir_all(dir).map_err(|e| CliError::Io(format!("cannot create {}: {e}", dir.display())))?;
    }
    let mut nodes = Vec::new();
    for (n, (spec, address)) in wanted.into_iter().enumerate() {
        // The address a module is started with: --address, MODEL@ADDR, or (on a bus without either) its
        // position on the line. It names the module's EEPROM file in --eeprom-dir.
        let address = address.or(args.address).or((n > 0).then_some(n as u8 + 1));
        let name = format!("{}@{}", spec.id, address.unwrap_or(1));
        let capacity = persist::capacity(spec);
        let path = match (&args.eeprom, &args.eeprom_dir) {
            (Some(file), _) => Some(file.clone()),
            (None, Some(dir)) => Some(dir.join(format!("{name}.eeprom"))),
            (None, None) => None,
        };
        // Only a new EEPROM takes the start address: a module keeps the address it stored (GP 66 is
        // stored automatically, §5.1), as a real module keeps its address across power cycles.
        let fresh = path.as_ref().is_none_or(|p| std::fs::metadata(p).map_or(true, |m| m.len() == 0));
        let eeprom = match path {
            Some(path) => Eeprom::File(FileNvm::open(&path, capacity).map_err(|e| CliError::Io(e.to_string()))?),
            None => Eeprom::Memory(MemNvm::new(capacity)),
        };
        let board = SimBoard::for_model(spec, eeprom)
            .with_world(world.clone())
            .map_err(|e| CliError::Input(e.to_string()))?
            .with_clock(clock);
        let mut module = Module::new(board, spec, clock());
        if let Some(address) = address {
            if fresh && module.address() != address {
                module
                    .execute(Command::Sgp { param: 66, bank: 0, value: i32::from(address) }, clock())
                    .map_err(|s| CliError::Usage(format!("address {address}: {s}")))?;
            } else if module.address() != address {
                eprintln!(
                    "tmcl serve: {name}: keeping the address {} stored in its EEPROM (a start address applies to a new EEPROM)",
                    module.address()
                );
            }
        }
        nodes.push(Node::new(module, name));
    }
    let mut bus = Bus::new(nodes, args.wire_timing);
    let mut link = match (&args.pty, &args.tcp) {
        (Some(path), None) => Link::Pty(
            Pty::open(path).map_err(|e| CliError::Io(format!("cannot open a pty at {}: {e}", path.display())))?,
        ),
        (None, Some(addr)) => {
            let addr = parse_listen_address(addr).map_err(CliError::Usage)?;
            let listener =
                TcpListener::bind(addr).map_err(|e| CliError::Io(format!("cannot listen on {addr}: {e}")))?;
            listener.set_nonblocking(true).map_err(|e| CliError::Io(e.to_string()))?;
            Link::Tcp { listener, peer: None }
        }
        _ => return Err(CliError::Usage("give exactly one of --pty LINK or --tcp HOST:PORT".into())),
    };
    let place = match &link {
        Link::Pty(pty) => pty.link.display().to_string(),
        Link::Tcp { listener, .. } => listener.local_addr().map(|a| a.to_string()).unwrap_or_default(),
    };
    let modules: Vec<String> =
        bus.nodes.iter().map(|n| format!("{} at address {}", n.module.spec().name, n.module.address())).collect();
    if json {
        let names: Vec<serde_json::Value> = bus
            .nodes
            .iter()
            .map(|n| serde_json::json!({"model": n.module.spec().id, "address": n.module.address()}))
            .collect();
        println!("{}", serde_json::json!({"serving": names, "link": place}));
    } else {
        println!("serving {} on {place}", modules.join(", "));
    }
    let _ = io::stdout().flush();
    if args.verbose {
        if let Link::Pty(pty) = &link {
            eprintln!("[{}] {} -> {}", clock(), pty.link.display(), pty.device.display());
        }
    }

    let mut buf = [0u8; 4096];
    while !stop.load(Ordering::Relaxed) {
        let now = clock();
        let deadline = {
            let mut sink = Sender { link: &mut link, verbose: args.verbose, now };
            bus.poll(now, &mut |bytes: &[u8]| sink.send(bytes))
        };
        let sleep = deadline
            .map(|d| std::time::Duration::from_micros((d - clock()).micros()))
            .unwrap_or(MAX_SLEEP)
            .min(MAX_SLEEP);
        let readable = wait(&link, sleep).map_err(|e| CliError::Io(format!("poll: {e}")))?;
        if !readable {
            continue;
        }
        let received = match &mut link {
            Link::Pty(pty) => read_some(&mut pty.master, &mut buf),
            Link::Tcp { listener, peer } => match peer {
                None => {
                    if let Ok((stream, from)) = listener.accept() {
                        let _ = stream.set_nonblocking(true);
                        let _ = stream.set_nodelay(true);
                        if args.verbose {
                            eprintln!("[{}] connection from {from}", clock());
                        }
                        *peer = Some(stream);
                        // A partial frame of the previous connection must not join this one's.
                        bus.reset_link();
                    }
                    0
                }
                Some(stream) => match stream.read(&mut buf) {
                    Ok(0) | Err(_) if !would_block_or_ok(stream) => {
                        if args.verbose {
                            eprintln!("[{}] connection closed", clock());
                        }
                        *peer = None;
                        bus.reset_link();
                        0
                    }
                    Ok(n) => n,
                    Err(_) => 0,
                },
            },
        };
        if received > 0 {
            let now = clock();
            if args.verbose {
                log_request(now, &buf[..received]);
            }
            let mut sink = Sender { link: &mut link, verbose: args.verbose, now };
            bus.receive(now, &buf[..received], &mut |bytes: &[u8]| sink.send(bytes));
        }
    }
    for node in &mut bus.nodes {
        node.module
            .board_mut()
            .eeprom()
            .sync()
            .map_err(|e| CliError::Io(format!("{}: EEPROM not flushed: {e}", node.name)))?;
    }
    if args.verbose {
        eprintln!("[{}] stopped", clock());
    }
    Ok(())
}

/// `HOST:PORT`, or just `PORT` for loopback.
fn parse_listen_address(s: &str) -> Result<SocketAddr, String> {
    if let Ok(port) = s.parse::<u16>() {
        return Ok(SocketAddr::from(([127, 0, 0, 1], port)));
    }
    s.parse().map_err(|_| format!("`{s}` is not HOST:PORT (e.g. 127.0.0.1:2323) or a port number"))
}

/// After a failed or empty read: whether the stream is merely idle (true) or closed (false).
fn would_block_or_ok(stream: &mut TcpStream) -> bool {
    let mut probe = [0u8; 1];
    matches!(stream.peek(&mut probe), Err(e) if e.kind() == io::ErrorKind::WouldBlock)
}

fn read_some(file: &mut std::fs::File, buf: &mut [u8]) -> usize {
    // WouldBlock: nothing after all; EIO cannot happen while we hold the slave open.
    file.read(buf).unwrap_or_default()
}

/// Waits until the link is readable or `timeout` passes (with microsecond resolution: byte times at high
/// baud rates are far below a millisecond).
fn wait(link: &Link, timeout: std::time::Duration) -> io::Result<bool> {
    let fd = match link {
        Link::Pty(pty) => pty.master.as_fd(),
        Link::Tcp { listener, peer: None } => listener.as_fd(),
        Link::Tcp { peer: Some(stream), .. } => stream.as_fd(),
    };
    let mut fds = [PollFd::new(fd, PollFlags::POLLIN)];
    let timeout = nix::sys::time::TimeSpec::from_duration(timeout.max(std::time::Duration::from_micros(20)));
    match ppoll(&mut fds, Some(timeout), None) {
        Ok(n) => Ok(n > 0),
        Err(nix::Error::EINTR) => Ok(false),
        Err(e) => Err(io::Error::from_raw_os_error(e as i32)),
    }
}

/// Writes what the module sends; a host that is not listening loses it, as on a real line.
struct Sender<'a> {
    link: &'a mut Link,
    verbose: bool,
    now: Instant,
}

impl Sender<'_> {
    fn send(&mut self, bytes: &[u8]) {
        if self.verbose {
            log_reply(self.now, bytes);
        }
        let _ = match self.link {
            Link::Pty(pty) => pty.master.write_all(bytes),
            Link::Tcp { peer: Some(stream), .. } => stream.write_all(bytes),
            Link::Tcp { peer: None, .. } => Ok(()),
        };
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

fn log_request(now: Instant, bytes: &[u8]) {
    let what = match Frame::new_checked(bytes).map(|f| Request::parse(&f)) {
        Ok(Ok(Request { address, instruction })) if bytes.len() == 9 => describe(address, instruction),
        Ok(Err(e)) if bytes.len() == 9 => e.to_string(),
        _ => format!("{} bytes", bytes.len()),
    };
    eprintln!("[{now}] -> {}  {what}", hex(bytes));
}

fn describe(address: u8, i: Instruction) -> String {
    format!("to {address}: {} {}, {}, {}", i.opcode, i.kind, i.motor, i.value)
}

fn log_reply(now: Instant, bytes: &[u8]) {
    let what = match ReplyFrame::new_checked(bytes).map(|f| Reply::parse(&f)) {
        Ok(Ok(r)) => format!("status {}, value {}", r.status, r.value),
        _ => format!("special reply {:?}", String::from_utf8_lossy(&bytes[1.min(bytes.len())..])),
    };
    eprintln!("[{now}] <- {}  {what}", hex(bytes));
}

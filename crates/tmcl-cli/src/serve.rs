//! `tmcl serve`: a virtual module on a pty or a TCP port, in real time, and a TMCM-1310 also on a
//! network interface as an EtherCAT slave (`--ethercat`).
//!
//! The firmware core runs on a [`SimBoard`]; this file only moves bytes and wall-clock time between the
//! OS and [`Module::receive`]/[`Module::poll`] (and, for EtherCAT, frames between a packet socket and
//! [`Slave::process`]/[`Slave::poll`]), and sleeps until the module's next deadline, the next byte or
//! the next frame, whichever comes first. The deadline of a moving module is its next event, not its
//! next motion tick; a request during a move computes the state at the instant it arrives. The pty (or
//! TCP) link and the EtherCAT slave reach the same module: a host on the USB port sees what the
//! EtherCAT master does, at the same time.

use crate::bus::{Bus, Node};
use crate::error::CliError;
use crate::ethercat::{FoeFiles, RawSocket};
use crate::pty::{Pty, PtyError};
use clap::Args;
use nix::poll::{ppoll, PollFd, PollFlags};
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::os::fd::AsFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use tmcl_core::model::{self, ModelSpec};
use tmcl_core::param::persist;
use tmcl_core::{Instant, Module};
use tmcl_ethercat::{AlStatus, Slave};
use tmcl_sim::{Eeprom, FileNvm, MemNvm, SimBoard};
use tmcl_wire::{Frame, Instruction, Reply, ReplyFrame, Request};

/// Longest sleep without a deadline or a byte. A signal ends a sleep at once (`ppoll` returns EINTR and
/// the shutdown flag is looked at), so this only paces the pty's exclusive-mode check; a moving module
/// has its next event as deadline (the end of a ramp, an arrival), not its next motion tick, and costs
/// next to nothing between events.
const MAX_SLEEP: std::time::Duration = std::time::Duration::from_secs(1);

/// How often the pty's exclusive mode is checked for a host that died holding it.
const EXCLUSIVE_CHECK: std::time::Duration = std::time::Duration::from_secs(1);

/// Options of `tmcl serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The module to simulate, as MODEL or MODEL@ADDRESS. Give it several times to put several
    /// independent modules on one line (an RS485 bus), e.g. `--module pd28-1021@1 --module pd28-1021@2`.
    #[arg(long, value_name = "MODEL[@ADDR]", default_value = "pd28-1021")]
    pub module: Vec<String>,
    /// Serve on a pseudo-terminal; LINK becomes a symlink to it that hosts open as a serial port.
    ///
    /// One server per LINK: while it runs, the server holds LINK.lock beside it (its PID, with a flock). A
    /// LINK another live server holds is refused (exit code 3, naming that server's PID); a LINK left behind
    /// by a server that died (kill -9) is replaced. On exit LINK and LINK.lock are removed, LINK only if it
    /// still points at this server's pty.
    #[arg(long, value_name = "LINK", conflicts_with = "tcp", required_unless_present_any = ["tcp", "ethercat"])]
    pub pty: Option<PathBuf>,
    /// Serve on a TCP port instead, HOST:PORT (e.g. localhost:2323 or 127.0.0.1:2323; a bare PORT means
    /// 127.0.0.1; port 0 picks a free one).
    ///
    /// HOST may be a name; of its addresses IPv4 ones are tried first. One client at a time, as one host on a
    /// serial line: while a client is connected, a second connection is accepted and closed at once without
    /// a byte, and `tmcl` reports the port in use by another client. A port another program listens on is
    /// refused (exit code 3).
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
    /// Tick the motion controller every 1 ms, and wake up for every tick while a motor moves, instead of
    /// sleeping from event to event: the reference the event-driven module is measured against (same
    /// replies, more CPU time).
    #[arg(long)]
    pub exact_ticks: bool,
}

/// Where the bytes come from and go to.
enum Link {
    Pty(Pty),
    Tcp { listener: TcpListener, peer: Option<TcpStream> },
}

/// The EtherCAT side of `--ethercat`: the socket, the slave, and where FoE files go.
struct EtherCat {
    socket: RawSocket,
    slave: Slave,
    files: FoeFiles,
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
    if args.ethercat.is_some() {
        if wanted.len() > 1 {
            return Err(CliError::Usage("--ethercat serves one module".into()));
        }
        if let Some((spec, _)) = wanted.first() {
            Slave::new(spec).map_err(|_| {
                CliError::Usage(format!("the {} has no EtherCAT interface (the TMCM-1310 has)", spec.name))
            })?;
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
        module.set_exact_ticks(args.exact_ticks);
        if let Some(address) = address {
            if fresh && module.address() != address {
                module.set_address(address, clock()).map_err(|s| CliError::Usage(format!("address {address}: {s}")))?;
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
    // The raw socket first: without the privilege for it, no pty link is made at all.
    let mut ecat = match &args.ethercat {
        Some(iface) => {
            let socket = RawSocket::open(iface)?;
            let spec = bus.nodes[0].module.spec();
            let slave = Slave::new(spec).map_err(|e| CliError::Usage(e.to_string()))?;
            let foe = match (&args.eeprom, &args.eeprom_dir) {
                (Some(file), _) => Some(with_suffix(file, ".foe")),
                (None, Some(dir)) => Some(dir.join(format!("{}.foe", bus.nodes[0].name))),
                (None, None) => None,
            };
            Some(EtherCat { socket, slave, files: FoeFiles::new(foe) })
        }
        None => None,
    };
    let mut link = match (&args.pty, &args.tcp) {
        (Some(path), None) => Some(Link::Pty(Pty::open(path).map_err(|e| match e {
            PtyError::Busy { .. } => CliError::Io(e.to_string()),
            PtyError::Io(e) => CliError::Io(format!("cannot open a pty at {}: {e}", path.display())),
        })?)),
        (None, Some(addr)) => {
            let listener = listen(addr)?;
            listener.set_nonblocking(true).map_err(|e| CliError::Io(e.to_string()))?;
            Some(Link::Tcp { listener, peer: None })
        }
        (None, None) if ecat.is_some() => None,
        _ => return Err(CliError::Usage("give exactly one of --pty LINK or --tcp HOST:PORT".into())),
    };
    let place = match &link {
        Some(Link::Pty(pty)) => Some(pty.link.display().to_string()),
        Some(Link::Tcp { listener, .. }) => Some(listener.local_addr().map(|a| a.to_string()).unwrap_or_default()),
        None => None,
    };
    let iface = ecat.as_ref().map(|e| e.socket.name.clone());
    let modules: Vec<String> =
        bus.nodes.iter().map(|n| format!("{} at address {}", n.module.spec().name, n.module.address())).collect();
    if json {
        let names: Vec<serde_json::Value> = bus
            .nodes
            .iter()
            .map(|n| serde_json::json!({"model": n.module.spec().id, "address": n.module.address()}))
            .collect();
        println!("{}", serde_json::json!({"serving": names, "link": place, "ethercat": iface}));
    } else {
        let mut on: Vec<String> = place.into_iter().collect();
        on.extend(iface.map(|i| format!("EtherCAT {i}")));
        println!("serving {} on {}", modules.join(", "), on.join(" and "));
    }
    let _ = io::stdout().flush();
    if args.verbose {
        if let Some(Link::Pty(pty)) = &link {
            eprintln!("[{}] {} -> {}", clock(), pty.link.display(), pty.device.display());
        }
    }

    let mut buf = [0u8; 4096];
    let mut exclusive_checked = std::time::Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let now = clock();
        let mut deadline = {
            let mut sink = Sender { link: link.as_mut(), verbose: args.verbose, now };
            bus.poll(now, &mut |bytes: &[u8]| sink.send(bytes))
        };
        if let Some(e) = ecat.as_mut() {
            let before = e.slave.status();
            let next = e.slave.poll(now, &mut bus.nodes[0].module, &mut e.files);
            log_al(args.verbose, now, before, e.slave.status());
            deadline = [deadline, next].into_iter().flatten().min();
        }
        if let Some(Link::Pty(pty)) = &link {
            if exclusive_checked.elapsed() >= EXCLUSIVE_CHECK {
                pty.release_abandoned_exclusive_mode();
                exclusive_checked = std::time::Instant::now();
            }
        }
        let sleep = deadline
            .map(|d| std::time::Duration::from_micros((d - clock()).micros()))
            .unwrap_or(MAX_SLEEP)
            .min(MAX_SLEEP);
        let ready = wait(link.as_ref(), ecat.as_ref().map(|e| &e.socket), sleep)
            .map_err(|e| CliError::Io(format!("poll: {e}")))?;
        if let Some(e) = ecat.as_mut() {
            if ready.ethercat {
                serve_frames(e, &mut bus.nodes[0].module, &clock, args.verbose)?;
            } else {
                // No frame waits: the time to write a file a master sent by FoE.
                e.files.write_pending();
            }
        }
        let Some(link) = link.as_mut().filter(|_| ready.link) else { continue };
        // The host's bytes first: they are answered before a new TCP client is let in.
        let received = match &mut *link {
            Link::Pty(pty) => read_some(&mut pty.master, &mut buf),
            Link::Tcp { peer, .. } => match peer {
                None => 0,
                Some(stream) => match stream.read(&mut buf) {
                    Ok(n) if n > 0 => n,
                    Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => 0,
                    _ => {
                        if args.verbose {
                            eprintln!("[{}] connection closed", clock());
                        }
                        *peer = None;
                        bus.reset_link();
                        0
                    }
                },
            },
        };
        if received > 0 {
            let now = clock();
            if args.verbose {
                log_request(now, &buf[..received]);
            }
            let mut sink = Sender { link: Some(&mut *link), verbose: args.verbose, now };
            bus.receive(now, &buf[..received], &mut |bytes: &[u8]| sink.send(bytes));
        }
        if let Link::Tcp { listener, peer } = link {
            accept_clients(listener, peer, &mut bus, args.verbose, clock());
        }
    }
    if let Some(e) = ecat.as_mut() {
        e.files.write_pending();
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

/// `path` with `suffix` appended to its file name (`a.eeprom` → `a.eeprom.foe`).
fn with_suffix(path: &std::path::Path, suffix: &str) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(suffix);
    PathBuf::from(p)
}

/// Answers every EtherCAT frame waiting on the socket, each as it comes, with the time it is taken.
fn serve_frames(
    e: &mut EtherCat,
    module: &mut Module<SimBoard>,
    clock: &impl Fn() -> Instant,
    verbose: bool,
) -> Result<(), CliError> {
    let mut frame = [0u8; 2048];
    loop {
        let received =
            e.socket.recv(&mut frame).map_err(|err| CliError::Io(format!("--ethercat {}: {err}", e.socket.name)))?;
        let Some((n, from)) = received else { return Ok(()) };
        let now = clock();
        let before = e.slave.status();
        if let Some(len) = e.slave.process(now, &mut frame[..n], module, &mut e.files) {
            if let Err(err) = e.socket.send(&frame[..len], &from) {
                if verbose {
                    eprintln!("[{now}] EtherCAT: cannot send the answer: {err}");
                }
            }
        }
        log_al(verbose, now, before, e.slave.status());
    }
}

/// Logs a change of the slave's AL status (with -v).
fn log_al(verbose: bool, now: Instant, before: AlStatus, after: AlStatus) {
    if !verbose || before == after {
        return;
    }
    if after.error {
        eprintln!("[{now}] EtherCAT: {} with error, AL status code {:#06x}", after.state, u16::from(after.code));
    } else {
        eprintln!("[{now}] EtherCAT: {} -> {}", before.state, after.state);
    }
}

/// Listens on `HOST:PORT` or a bare `PORT` (on 127.0.0.1). HOST may be a name, resolved as the host side
/// resolves it (`localhost:2324`); of the addresses it resolves to, IPv4 ones are tried first, so that
/// `localhost` means 127.0.0.1 as for most clients. An address another program listens on is not skipped
/// for the next one: it is reported (exit code 3).
fn listen(text: &str) -> Result<TcpListener, CliError> {
    let mut candidates: Vec<SocketAddr> = match text.parse::<u16>() {
        Ok(port) => vec![SocketAddr::from(([127, 0, 0, 1], port))],
        Err(_) => text
            .to_socket_addrs()
            .map_err(|e| {
                CliError::Usage(format!(
                    "`{text}` is not HOST:PORT (e.g. localhost:2323, 127.0.0.1:2323) or a port: {e}"
                ))
            })?
            .collect(),
    };
    candidates.sort_by_key(SocketAddr::is_ipv6);
    let mut last = None;
    for addr in candidates {
        match TcpListener::bind(addr) {
            Ok(listener) => return Ok(listener),
            Err(e) if e.kind() == io::ErrorKind::AddrInUse => {
                return Err(CliError::Io(format!("cannot listen on {addr}: another program listens there ({e})")))
            }
            Err(e) => last = Some(format!("cannot listen on {addr}: {e}")),
        }
    }
    Err(CliError::Io(last.unwrap_or_else(|| format!("`{text}` resolves to no address"))))
}

/// Takes the connections waiting on the listener. The first becomes the client when there is none (or the
/// one there has gone); any other is closed at once without a byte: one client at a time, as one host on a
/// serial line (a second client would read the first one's replies). See docs/decisions.md.
///
/// While the client has unread bytes, new connections wait: those bytes may end in the client's close, and
/// the next connection is then the next client, not a second one.
fn accept_clients(listener: &TcpListener, peer: &mut Option<TcpStream>, bus: &mut Bus, verbose: bool, now: Instant) {
    loop {
        if let Some(stream) = peer.as_mut() {
            match peer_state(stream) {
                PeerState::Idle => {}
                PeerState::Sending => return,
                PeerState::Closed => {
                    if verbose {
                        eprintln!("[{now}] connection closed");
                    }
                    *peer = None;
                    bus.reset_link();
                }
            }
        }
        let Ok((stream, from)) = listener.accept() else { return };
        if peer.is_some() {
            if verbose {
                eprintln!("[{now}] connection from {from} turned away: another client is connected");
            }
            drop(stream);
            continue;
        }
        let _ = stream.set_nonblocking(true);
        let _ = stream.set_nodelay(true);
        if verbose {
            eprintln!("[{now}] connection from {from}");
        }
        *peer = Some(stream);
        // A partial frame of the previous connection must not join this one's.
        bus.reset_link();
    }
}

/// What a connected client is doing, as far as the socket tells without reading.
enum PeerState {
    /// Connected, nothing unread.
    Idle,
    /// Bytes are waiting to be read.
    Sending,
    /// Closed or failed.
    Closed,
}

fn peer_state(stream: &mut TcpStream) -> PeerState {
    let mut probe = [0u8; 1];
    match stream.peek(&mut probe) {
        Ok(0) => PeerState::Closed,
        Ok(_) => PeerState::Sending,
        Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => PeerState::Idle,
        Err(_) => PeerState::Closed,
    }
}

fn read_some(file: &mut std::fs::File, buf: &mut [u8]) -> usize {
    // WouldBlock: nothing after all; EIO cannot happen while we hold the slave open.
    file.read(buf).unwrap_or_default()
}

/// What woke [`wait`].
struct Ready {
    /// The link has bytes (or a TCP connection waits).
    link: bool,
    /// EtherCAT frames wait.
    ethercat: bool,
}

/// Waits until the link is readable (for TCP: the client, or the listener with a new connection), an
/// EtherCAT frame arrives, or `timeout` passes (with microsecond resolution: byte times at high baud
/// rates are far below a millisecond).
fn wait(link: Option<&Link>, ethercat: Option<&RawSocket>, timeout: std::time::Duration) -> io::Result<Ready> {
    let mut fds = match link {
        Some(Link::Pty(pty)) => vec![PollFd::new(pty.master.as_fd(), PollFlags::POLLIN)],
        Some(Link::Tcp { listener, peer }) => {
            let mut fds = vec![PollFd::new(listener.as_fd(), PollFlags::POLLIN)];
            fds.extend(peer.iter().map(|stream| PollFd::new(stream.as_fd(), PollFlags::POLLIN)));
            fds
        }
        None => Vec::new(),
    };
    let link_fds = fds.len();
    fds.extend(ethercat.map(|s| PollFd::new(s.as_fd(), PollFlags::POLLIN)));
    let timeout = nix::sys::time::TimeSpec::from_duration(timeout.max(std::time::Duration::from_micros(20)));
    let none = Ready { link: false, ethercat: false };
    match ppoll(&mut fds, Some(timeout), None) {
        Ok(0) => Ok(none),
        Ok(_) => {
            let ready = |fd: &PollFd| fd.revents().is_some_and(|r| !r.is_empty());
            Ok(Ready { link: fds[..link_fds].iter().any(ready), ethercat: fds[link_fds..].iter().any(ready) })
        }
        Err(nix::Error::EINTR) => Ok(none),
        Err(e) => Err(io::Error::from_raw_os_error(e as i32)),
    }
}

/// Writes what the module sends; a host that is not listening loses it, as on a real line.
struct Sender<'a> {
    link: Option<&'a mut Link>,
    verbose: bool,
    now: Instant,
}

impl Sender<'_> {
    fn send(&mut self, bytes: &[u8]) {
        if self.verbose {
            log_reply(self.now, bytes);
        }
        let _ = match &mut self.link {
            Some(Link::Pty(pty)) => pty.master.write_all(bytes),
            Some(Link::Tcp { peer: Some(stream), .. }) => stream.write_all(bytes),
            Some(Link::Tcp { peer: None, .. }) | None => Ok(()),
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

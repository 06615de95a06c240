//! The server: modules on a line, the host links, the serve loop.
//!
//! The deadline of a moving module is its next event, not its next motion tick; a request during a move
//! computes the state at the instant it arrives. The pty (or TCP) link and the EtherCAT slave reach the
//! same module: a host on the USB port sees what the EtherCAT master does, at the same time.

use crate::bus::{Bus, Node};
use crate::ethercat::{FoeFiles, RawSocket};
use crate::pty::{Pty, PtyError};
use crate::tcp::{accept_clients, listen};
use crate::trace::{log_al, log_reply, log_request};
use crate::{LinkInfo, LinkOptions, ModuleInfo, Options, ServeError};
use nix::poll::{ppoll, PollFd, PollFlags};
use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::os::fd::AsFd;
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use tmcl_core::param::persist;
use tmcl_core::{Instant, Module};
use tmcl_ethercat::Slave;
use tmcl_sim::{Eeprom, FileNvm, MemNvm, SimBoard};
use tmcl_wire::Command;

/// Longest sleep without a deadline or a byte. A signal or a [`Stopper::stop`] ends a sleep at once, so
/// this only paces the pty's exclusive-mode check; a moving module has its next event as deadline (the end
/// of a ramp, an arrival), not its next motion tick, and costs next to nothing between events.
const MAX_SLEEP: std::time::Duration = std::time::Duration::from_secs(1);

/// How often the pty's exclusive mode is checked for a host that died holding it.
const EXCLUSIVE_CHECK: std::time::Duration = std::time::Duration::from_secs(1);

/// Where the bytes come from and go to.
pub(crate) enum Link {
    Pty(Pty),
    Tcp { listener: TcpListener, peer: Option<TcpStream> },
}

/// The EtherCAT side of `--ethercat`: the socket, the slave, and where FoE files go.
struct EtherCat {
    socket: RawSocket,
    slave: Slave,
    files: FoeFiles,
}

/// Tells a server to stop, from any thread (or a signal handler, through [`Stopper::flag`]).
#[derive(Debug, Clone)]
pub struct Stopper {
    flag: Arc<AtomicBool>,
    waker: Arc<UnixStream>,
}

impl Stopper {
    /// Asks the server to stop; it does within a moment, removing its links and flushing its EEPROMs.
    pub fn stop(&self) {
        self.flag.store(true, Ordering::Relaxed);
        let _ = (&*self.waker).write(&[1]);
    }

    /// The flag the serve loop looks at, to be set from a signal handler (`signal_hook::flag::register`):
    /// the signal interrupts the loop's sleep, and the loop sees the flag.
    pub fn flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.flag)
    }

    /// Whether a stop was asked for.
    pub fn is_stopped(&self) -> bool {
        self.flag.load(Ordering::Relaxed)
    }
}

/// A piece of work the serve loop runs on its modules between two polls ([`Access`]).
type Job = Box<dyn FnOnce(&mut [Node], Instant) + Send>;

/// Work on the served modules from another thread, between the serve loop's polls: what a program that
/// embeds the server (the Python package) uses to read and change its modules directly, without a link,
/// while hosts talk to them on the link.
#[derive(Clone)]
pub struct Access {
    jobs: std::sync::mpsc::Sender<Job>,
    stopper: Stopper,
}

impl Access {
    /// Runs `f` on module `index` (in line order) at the server's time now, on the serve loop's thread,
    /// and returns its result; `None` when the server has stopped or has no such module.
    pub fn with_module<R: Send + 'static>(
        &self,
        index: usize,
        f: impl FnOnce(&mut Module<SimBoard>, Instant) -> R + Send + 'static,
    ) -> Option<R> {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        let job: Job = Box::new(move |nodes, now| {
            if let Some(node) = nodes.get_mut(index) {
                let _ = tx.send(f(&mut node.module, now));
            }
        });
        self.jobs.send(job).ok()?;
        // Wake the loop from its sleep; it runs the job before it sleeps again.
        let _ = (&*self.stopper.waker).write(&[1]);
        rx.recv().ok()
    }
}

/// Modules and links, open and ready to serve (see the crate docs).
pub struct Server {
    bus: Bus,
    link: Option<Link>,
    ecat: Option<EtherCat>,
    start: std::time::Instant,
    verbose: bool,
    notes: Vec<String>,
    stopper: Stopper,
    /// The loop's end of the waker pair.
    wake: UnixStream,
    /// Work from [`Access`] handles, and the sending end they clone.
    jobs: (std::sync::mpsc::Sender<Job>, std::sync::mpsc::Receiver<Job>),
}

impl Server {
    /// Makes the modules and opens the links (and the EtherCAT socket, first: without the privilege for
    /// it no link is made at all).
    ///
    /// # Errors
    ///
    /// [`ServeError::Config`] for options that do not fit together, [`ServeError::Input`] for a world the
    /// model cannot use, [`ServeError::Io`] for a link another server holds, a TCP port in use, an EEPROM
    /// file that cannot be opened.
    pub fn new(options: Options) -> Result<Server, ServeError> {
        let Options { modules, links, ethercat, wire_timing, exact_ticks, verbose } = options;
        if modules.is_empty() {
            return Err(ServeError::Config("no module to serve".into()));
        }
        // A link whose modules answer every address (USB) holds one module: several would all answer.
        if modules.len() > 1 {
            if let Some(m) = modules.iter().find(|m| !m.spec.interfaces[0].address_filter) {
                return Err(ServeError::Config(format!(
                    "the {} is served on its {} interface, which answers every address: one module per link",
                    m.spec.name, m.spec.interfaces[0].name
                )));
            }
        }
        if ethercat.is_some() {
            if modules.len() > 1 {
                return Err(ServeError::Config("--ethercat serves one module".into()));
            }
            let spec = modules[0].spec;
            Slave::new(spec).map_err(|_| {
                ServeError::Config(format!("the {} has no EtherCAT interface (the TMCM-1310 has)", spec.name))
            })?;
        }
        if links.len() > 1 {
            return Err(ServeError::Config("one host link per server".into()));
        }
        if links.is_empty() && ethercat.is_none() {
            return Err(ServeError::Config("give exactly one of --pty LINK or --tcp HOST:PORT".into()));
        }
        let start = std::time::Instant::now();
        let clock = move || Instant::from_micros(start.elapsed().as_micros() as u64);
        let mut notes = Vec::new();
        let mut nodes = Vec::new();
        for (n, options) in modules.into_iter().enumerate() {
            let spec = options.spec;
            // The address a module is started with: its option or (on a bus without one) its position on the
            // line.
            let address = options.address.or((n > 0).then_some(n as u8 + 1));
            let name = format!("{}@{}", spec.id, address.unwrap_or(1));
            let capacity = persist::capacity(spec);
            // Only a new EEPROM takes the start address: a module keeps the address it stored (GP 66 is
            // stored automatically, §5.1), as a real module keeps its address across power cycles.
            let fresh = options.eeprom.as_ref().is_none_or(|p| std::fs::metadata(p).map_or(true, |m| m.len() == 0));
            let eeprom = match &options.eeprom {
                Some(path) => Eeprom::File(FileNvm::open(path, capacity).map_err(|e| ServeError::Io(e.to_string()))?),
                None => Eeprom::Memory(MemNvm::new(capacity)),
            };
            let board = SimBoard::for_model(spec, eeprom)
                .with_world(options.world)
                .map_err(|e| ServeError::Input(e.to_string()))?
                .with_clock(clock);
            let mut module = Module::new(board, spec, clock());
            module.set_exact_ticks(exact_ticks);
            if let Some(address) = address {
                if fresh && module.address() != address {
                    module
                        .execute(Command::Sgp { param: 66, bank: 0, value: i32::from(address) }, clock())
                        .map_err(|s| ServeError::Config(format!("address {address}: {s}")))?;
                } else if module.address() != address {
                    notes.push(format!(
                        "{name}: keeping the address {} stored in its EEPROM (a start address applies to a new EEPROM)",
                        module.address()
                    ));
                }
            }
            nodes.push(Node::new(module, name));
        }
        let bus = Bus::new(nodes, wire_timing);
        // The raw socket first: without the privilege for it, no pty link is made at all.
        let ecat = match ethercat {
            Some(options) => {
                let socket = RawSocket::open(&options.interface)?;
                let slave = Slave::new(bus.nodes[0].module.spec()).map_err(|e| ServeError::Config(e.to_string()))?;
                Some(EtherCat { socket, slave, files: FoeFiles::new(options.foe) })
            }
            None => None,
        };
        let link = match links.into_iter().next() {
            Some(LinkOptions::Pty(path)) => Some(Link::Pty(Pty::open(&path).map_err(|e| match e {
                PtyError::Busy { .. } => ServeError::Io(e.to_string()),
                PtyError::Io(e) => ServeError::Io(format!("cannot open a pty at {}: {e}", path.display())),
            })?)),
            Some(LinkOptions::Tcp(addr)) => {
                let listener = listen(&addr)?;
                listener.set_nonblocking(true).map_err(|e| ServeError::Io(e.to_string()))?;
                Some(Link::Tcp { listener, peer: None })
            }
            None => None,
        };
        let (waker, wake) = UnixStream::pair().map_err(|e| ServeError::Io(format!("cannot make a waker: {e}")))?;
        wake.set_nonblocking(true).map_err(|e| ServeError::Io(e.to_string()))?;
        waker.set_nonblocking(true).map_err(|e| ServeError::Io(e.to_string()))?;
        let stopper = Stopper { flag: Arc::new(AtomicBool::new(false)), waker: Arc::new(waker) };
        Ok(Server { bus, link, ecat, start, verbose, notes, stopper, wake, jobs: std::sync::mpsc::channel() })
    }

    /// The modules, in line order, with the addresses they answer at.
    pub fn modules(&self) -> Vec<ModuleInfo> {
        self.bus
            .nodes
            .iter()
            .map(|n| ModuleInfo {
                address: n.module.address(),
                model: n.module.spec().id.to_string(),
                name: n.module.spec().name.to_string(),
            })
            .collect()
    }

    /// Where hosts reach the modules.
    pub fn links(&self) -> Vec<LinkInfo> {
        match &self.link {
            Some(Link::Pty(pty)) => vec![LinkInfo::Pty { link: pty.link.clone(), device: pty.device.clone() }],
            Some(Link::Tcp { listener, .. }) => {
                listener.local_addr().map(|address| LinkInfo::Tcp { address }).into_iter().collect()
            }
            None => Vec::new(),
        }
    }

    /// The network interface of the EtherCAT slave, if one is served.
    pub fn ethercat_interface(&self) -> Option<&str> {
        self.ecat.as_ref().map(|e| e.socket.name.as_str())
    }

    /// What the server noticed while starting that the user should hear (a start address not taken
    /// because the EEPROM holds another).
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// The handle that stops [`Server::run`].
    pub fn stopper(&self) -> Stopper {
        self.stopper.clone()
    }

    /// A handle that works on the modules directly while the server runs ([`Access::with_module`]).
    pub fn access(&self) -> Access {
        Access { jobs: self.jobs.0.clone(), stopper: self.stopper.clone() }
    }

    /// Runs the server on a thread of its own.
    ///
    /// # Errors
    ///
    /// [`ServeError::Io`] when the OS refuses the thread.
    pub fn spawn(self) -> Result<RunningServer, ServeError> {
        let links = self.links();
        let modules = self.modules();
        let stopper = self.stopper();
        let access = self.access();
        let thread = std::thread::Builder::new()
            .name("tmcl-serve".into())
            .spawn(move || self.run())
            .map_err(|e| ServeError::Io(format!("cannot start the server's thread: {e}")))?;
        Ok(RunningServer { stopper, access, thread: Some(thread), links, modules })
    }

    /// Serves until the [`Stopper`] says stop; then removes the links and flushes every EEPROM.
    ///
    /// # Errors
    ///
    /// [`ServeError::Io`] when waiting for the links fails, the EtherCAT socket fails, or an EEPROM cannot
    /// be flushed.
    pub fn run(mut self) -> Result<(), ServeError> {
        let served = self.serve();
        // Whatever ended the loop, what was written is kept.
        let mut flushed = Ok(());
        if let Some(e) = self.ecat.as_mut() {
            e.files.write_pending();
        }
        for node in &mut self.bus.nodes {
            if let Err(e) = node.module.board_mut().eeprom().sync() {
                flushed = Err(ServeError::Io(format!("{}: EEPROM not flushed: {e}", node.name)));
            }
        }
        if self.verbose {
            eprintln!("[{}] stopped", self.now());
        }
        served.and(flushed)
    }

    fn now(&self) -> Instant {
        Instant::from_micros(self.start.elapsed().as_micros() as u64)
    }

    fn serve(&mut self) -> Result<(), ServeError> {
        let start = self.start;
        let clock = move || Instant::from_micros(start.elapsed().as_micros() as u64);
        let verbose = self.verbose;
        if verbose {
            if let Some(Link::Pty(pty)) = &self.link {
                eprintln!("[{}] {} -> {}", clock(), pty.link.display(), pty.device.display());
            }
        }
        let (bus, link, ecat) = (&mut self.bus, &mut self.link, &mut self.ecat);
        let jobs = &self.jobs.1;
        let mut buf = [0u8; 4096];
        let mut exclusive_checked = std::time::Instant::now();
        while !self.stopper.is_stopped() {
            while let Ok(job) = jobs.try_recv() {
                job(&mut bus.nodes, clock());
            }
            let now = clock();
            let mut deadline = {
                let mut sink = Sender { link: link.as_mut(), verbose, now };
                bus.poll(now, &mut |bytes: &[u8]| sink.send(bytes))
            };
            if let Some(e) = ecat.as_mut() {
                let before = e.slave.status();
                let next = e.slave.poll(now, &mut bus.nodes[0].module, &mut e.files);
                log_al(verbose, now, before, e.slave.status());
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
            let ready = wait(link.as_ref(), ecat.as_ref().map(|e| &e.socket), &self.wake, sleep)
                .map_err(|e| ServeError::Io(format!("poll: {e}")))?;
            if ready.waker {
                let mut drain = [0u8; 16];
                while matches!((&self.wake).read(&mut drain), Ok(n) if n > 0) {}
            }
            if let Some(e) = ecat.as_mut() {
                if ready.ethercat {
                    serve_frames(e, &mut bus.nodes[0].module, &clock, verbose)?;
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
                            if verbose {
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
                if verbose {
                    log_request(now, &buf[..received]);
                }
                let mut sink = Sender { link: Some(&mut *link), verbose, now };
                bus.receive(now, &buf[..received], &mut |bytes: &[u8]| sink.send(bytes));
            }
            if let Link::Tcp { listener, peer } = link {
                accept_clients(listener, peer, bus, verbose, clock());
            }
        }
        Ok(())
    }
}

/// A server running on its own thread ([`Server::spawn`]); dropping it stops it.
pub struct RunningServer {
    stopper: Stopper,
    access: Access,
    thread: Option<JoinHandle<Result<(), ServeError>>>,
    links: Vec<LinkInfo>,
    modules: Vec<ModuleInfo>,
}

impl RunningServer {
    /// Where hosts reach the modules.
    pub fn links(&self) -> &[LinkInfo] {
        &self.links
    }

    /// The modules, as they were when the server started.
    pub fn modules(&self) -> &[ModuleInfo] {
        &self.modules
    }

    /// The handle that stops it.
    pub fn stopper(&self) -> Stopper {
        self.stopper.clone()
    }

    /// A handle that works on the modules directly ([`Access::with_module`]).
    pub fn access(&self) -> Access {
        self.access.clone()
    }

    /// Whether the server's thread has ended (stopped, or failed: [`RunningServer::stop`] tells how).
    pub fn is_finished(&self) -> bool {
        self.thread.as_ref().is_none_or(JoinHandle::is_finished)
    }

    /// Stops the server and waits until its links are removed and its EEPROMs flushed.
    ///
    /// # Errors
    ///
    /// What ended the server, if not the stop (see [`Server::run`]).
    pub fn stop(mut self) -> Result<(), ServeError> {
        self.finish()
    }

    fn finish(&mut self) -> Result<(), ServeError> {
        self.stopper.stop();
        match self.thread.take() {
            Some(thread) => {
                thread.join().unwrap_or_else(|_| Err(ServeError::Io("the server's thread panicked".into())))
            }
            None => Ok(()),
        }
    }
}

impl Drop for RunningServer {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

/// Answers every EtherCAT frame waiting on the socket, each as it comes, with the time it is taken.
fn serve_frames(
    e: &mut EtherCat,
    module: &mut Module<SimBoard>,
    clock: &impl Fn() -> Instant,
    verbose: bool,
) -> Result<(), ServeError> {
    let mut frame = [0u8; 2048];
    loop {
        let received =
            e.socket.recv(&mut frame).map_err(|err| ServeError::Io(format!("--ethercat {}: {err}", e.socket.name)))?;
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
    /// A stop was asked for.
    waker: bool,
}

/// Waits until the link is readable (for TCP: the client, or the listener with a new connection), an
/// EtherCAT frame arrives, a stop is asked for, or `timeout` passes (with microsecond resolution: byte
/// times at high baud rates are far below a millisecond).
fn wait(
    link: Option<&Link>,
    ethercat: Option<&RawSocket>,
    waker: &UnixStream,
    timeout: std::time::Duration,
) -> io::Result<Ready> {
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
    let ecat_fds = fds.len();
    fds.push(PollFd::new(waker.as_fd(), PollFlags::POLLIN));
    let timeout = nix::sys::time::TimeSpec::from_duration(timeout.max(std::time::Duration::from_micros(20)));
    let none = Ready { link: false, ethercat: false, waker: false };
    match ppoll(&mut fds, Some(timeout), None) {
        Ok(0) => Ok(none),
        Ok(_) => {
            let ready = |fd: &PollFd| fd.revents().is_some_and(|r| !r.is_empty());
            Ok(Ready {
                link: fds[..link_fds].iter().any(ready),
                ethercat: fds[link_fds..ecat_fds].iter().any(ready),
                waker: fds[ecat_fds..].iter().any(ready),
            })
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

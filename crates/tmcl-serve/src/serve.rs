//! The server: modules on a line, the host links, the serve loop.
//!
//! The deadline of a moving module is its next event, not its next motion tick; a request during a move
//! computes the state at the instant it arrives. The pty (or TCP) link and the EtherCAT slave reach the
//! same module: a host on the USB port sees what the EtherCAT master does, at the same time.

use crate::bus::{Bus, Node};
use crate::ethercat::{FoeFiles, RawSocket};
use crate::monitor::{Monitor, Recorder};
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

/// Longest sleep without a deadline or a byte. A [`Stopper::stop`] ends a sleep at once, and so does a
/// signal given to [`Stopper::stop_on_signals`]; a moving module has its next event as deadline (the end of
/// a ramp, an arrival), not its next motion tick, and hosts opening and closing a pty wake the loop through
/// the pty's watch ([`Pty::hosts_changed`]), so an idle server sleeps this long. It bounds the wait for a
/// stop asked for through [`Stopper::flag`] alone (a signal that lands just before the loop goes to sleep).
const MAX_SLEEP: std::time::Duration = std::time::Duration::from_secs(10);

/// The most reply bytes held for a host that does not read them (a pty's or socket's buffer is full);
/// beyond it the oldest are dropped, with a word on stderr.
const MAX_PENDING: usize = 16 << 20;

/// After a host opened or closed a pty, how long the loop waits before it looks who has the pty open (the
/// warning about two hosts) and whether a host that died left the exclusive mode set: a burst of opens and
/// closes is looked at once, a killed host's `flock` is gone by then (the kernel reports the close before
/// it drops the lock), and the look through `/proc` (milliseconds on a busy machine) does not fall on a
/// host's first requests, which come right after its open.
const HOSTS_SETTLE: std::time::Duration = std::time::Duration::from_secs(1);

/// Without a watch on a pty, how often the processes that have it open are looked up, and its exclusive
/// mode checked.
const UNWATCHED_CHECK: std::time::Duration = std::time::Duration::from_secs(2);

/// Where the bytes come from and go to.
pub(crate) enum Link {
    Pty(Pty),
    Tcp { listener: TcpListener, peer: Option<TcpStream> },
}

impl Link {
    /// Where hosts reach it.
    pub(crate) fn info(&self) -> Option<LinkInfo> {
        match self {
            Link::Pty(pty) => Some(LinkInfo::Pty { link: pty.link.clone(), device: pty.device.clone() }),
            Link::Tcp { listener, .. } => listener.local_addr().ok().map(|address| LinkInfo::Tcp { address }),
        }
    }
}

/// Opens a host link: a pty behind its symlink (with `LINK.lock`), or a listening TCP port.
pub(crate) fn open_link(options: LinkOptions) -> Result<Link, ServeError> {
    Ok(match options {
        LinkOptions::Pty(path) => Link::Pty(Pty::open(&path).map_err(|e| match e {
            PtyError::Busy { .. } => ServeError::Io(e.to_string()),
            PtyError::Io(e) => ServeError::Io(format!("cannot open a pty at {}: {e}", path.display())),
        })?),
        LinkOptions::Tcp(addr) => {
            let listener = listen(&addr)?;
            listener.set_nonblocking(true).map_err(|e| ServeError::Io(e.to_string()))?;
            Link::Tcp { listener, peer: None }
        }
    })
}

/// The EtherCAT side of `--ethercat`: the socket, the slave (its SII writes kept in a file or in
/// memory), and where FoE files go.
struct EtherCat {
    socket: RawSocket,
    slave: Slave<Eeprom>,
    files: FoeFiles,
}

/// Most frames answered in one go before the loop looks at the stop flag, the links and the time again:
/// a master that floods the slave neither starves the USB port nor delays a stop.
const FRAMES_PER_TURN: usize = 64;

/// Tells a server to stop, from any thread (or a signal handler, through [`Stopper::flag`]).
#[derive(Debug, Clone)]
pub struct Stopper {
    flag: Arc<AtomicBool>,
    waker: Arc<UnixStream>,
}

impl Stopper {
    /// A stopper and the loop's end of its waker pair (readable when a stop or a job is asked for).
    pub(crate) fn new() -> Result<(Stopper, UnixStream), ServeError> {
        let (waker, wake) = UnixStream::pair().map_err(|e| ServeError::Io(format!("cannot make a waker: {e}")))?;
        wake.set_nonblocking(true).map_err(|e| ServeError::Io(e.to_string()))?;
        waker.set_nonblocking(true).map_err(|e| ServeError::Io(e.to_string()))?;
        Ok((Stopper { flag: Arc::new(AtomicBool::new(false)), waker: Arc::new(waker) }, wake))
    }

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

    /// Stops the server when the process gets one of `signals` (SIGINT, SIGTERM): the flag is set and the
    /// loop woken from its sleep at once, however long it would sleep.
    ///
    /// # Errors
    ///
    /// When the OS refuses the handler or a descriptor for the wake-up.
    pub fn stop_on_signals(&self, signals: &[i32]) -> io::Result<()> {
        for &signal in signals {
            signal_hook::flag::register(signal, Arc::clone(&self.flag))?;
            signal_hook::low_level::pipe::register(signal, self.waker.try_clone()?)?;
        }
        Ok(())
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
    /// The host links, each with the reply bytes it did not take yet (its buffer was full): written when
    /// it can take them.
    links: Vec<(Link, Vec<u8>)>,
    /// Boxed: the slave is 15 KiB, and a server is moved onto the stack of the thread that runs it (each
    /// line of a fleet has one), where it would stay resident.
    ecat: Option<Box<EtherCat>>,
    start: std::time::Instant,
    verbose: bool,
    /// fsync the EEPROM files when the loop ends (see [`Server::set_flush_on_stop`]).
    flush_on_stop: bool,
    notes: Vec<String>,
    stopper: Stopper,
    /// The loop's end of the waker pair.
    wake: UnixStream,
    /// Work from [`Access`] handles, and the sending end they clone.
    jobs: (std::sync::mpsc::Sender<Job>, std::sync::mpsc::Receiver<Job>),
    /// The transactions for the log file and the monitor socket.
    recorder: Recorder,
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
        let Options { modules, links, ethercat, wire_timing, exact_ticks, verbose, monitor } = options;
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
        if links.len() > tmcl_core::iface::HOST_LINKS {
            return Err(ServeError::Config(format!("at most {} host links per server", tmcl_core::iface::HOST_LINKS)));
        }
        if links.len() > 1 && wire_timing {
            return Err(ServeError::Config(
                "--wire-timing times one wire: give one link (--pty or --tcp) with it".into(),
            ));
        }
        if links.is_empty() && ethercat.is_none() {
            return Err(ServeError::Config("give exactly one of --pty LINK or --tcp HOST:PORT".into()));
        }
        // The start addresses first, before any EEPROM file is opened (or given an address).
        let starts: Vec<u8> =
            modules.iter().enumerate().map(|(n, m)| m.address.unwrap_or(if n > 0 { n as u8 + 1 } else { 1 })).collect();
        for (k, a) in starts.iter().enumerate() {
            if let Some(first) = starts[..k].iter().position(|b| b == a) {
                return Err(ServeError::Config(format!(
                    "two modules at address {a}: {}@{a} and {}@{a} (modules {} and {} on the line); give each \
                     module its own address (MODEL@ADDR)",
                    modules[first].spec.id,
                    modules[k].spec.id,
                    first + 1,
                    k + 1
                )));
            }
        }
        let start = std::time::Instant::now();
        let clock = move || Instant::from_micros(start.elapsed().as_micros() as u64);
        let mut notes = Vec::new();
        let mut nodes = Vec::new();
        let options_have_eeprom = modules.iter().any(|m| m.eeprom.is_some());
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
                        .set_address(address, clock())
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
        // Two modules at one address would both answer every request to it: the host reads their replies
        // run together (a checksum error on a real line), never the answer of the one it meant.
        for (k, node) in nodes.iter().enumerate() {
            if let Some(first) = nodes[..k].iter().find(|n| n.module.address() == node.module.address()) {
                return Err(ServeError::Config(format!(
                    "two modules at address {}: {} and {}; give each module its own address (MODEL@ADDR){}",
                    node.module.address(),
                    first.name,
                    node.name,
                    if options_have_eeprom {
                        ", or another EEPROM: a module keeps the address stored in its EEPROM"
                    } else {
                        ""
                    }
                )));
            }
        }
        let bus = Bus::with_links(nodes, wire_timing, links.len().max(1));
        // The raw socket first: without the privilege for it, no pty link is made at all.
        let ecat = match ethercat {
            Some(options) => {
                let socket = RawSocket::open(&options.interface)?;
                let store = match &options.sii {
                    Some(path) => Eeprom::File(
                        FileNvm::open(path, tmcl_ethercat::SII_STORE_LEN)
                            .map_err(|e| ServeError::Io(format!("EtherCAT SII: {e}")))?,
                    ),
                    None => Eeprom::Memory(MemNvm::new(tmcl_ethercat::SII_STORE_LEN)),
                };
                let slave = Slave::with_store(bus.nodes[0].module.spec(), store).map_err(|e| match e {
                    tmcl_ethercat::StoreError::NoEtherCat => ServeError::Config(e.to_string()),
                    tmcl_ethercat::StoreError::Restore(_) => ServeError::Io(format!("EtherCAT SII: {e}")),
                })?;
                if slave.restored_words() > 0 {
                    let place = options.sii.as_ref().map(|p| p.display().to_string()).unwrap_or_default();
                    notes.push(format!(
                        "EtherCAT: SII: {} words a master wrote, restored from {place} (alias {:#06x})",
                        slave.restored_words(),
                        slave.eeprom().word(4)
                    ));
                }
                Some(Box::new(EtherCat { socket, slave, files: FoeFiles::new(options.foe) }))
            }
            None => None,
        };
        let mut opened = Vec::new();
        for options in links {
            opened.push((open_link(options)?, Vec::new()));
        }
        // What opening wrote (journal headers, a journal reset) goes to disk now, at the start: a file
        // whose blocks are still unwritten when it is closed is flushed by the close (ext4), which would
        // slow the exit instead.
        let mut bus = bus;
        for node in &mut bus.nodes {
            node.module.board_mut().eeprom().sync().map_err(|e| ServeError::Io(format!("{}: {e}", node.name)))?;
        }
        let mut ecat = ecat;
        if let Some(Eeprom::File(f)) = ecat.as_mut().map(|e| e.slave.store_mut()) {
            f.sync().map_err(|e| ServeError::Io(format!("EtherCAT SII: {e}")))?;
        }
        let (stopper, wake) = Stopper::new()?;
        let first_pty = opened.iter().find_map(|(l, _)| match l {
            Link::Pty(p) => Some(crate::monitor::socket_beside(&p.link)),
            Link::Tcp { .. } => None,
        });
        let names = opened.iter().map(|(l, _)| l.info().map(|i| i.to_string()).unwrap_or_default()).collect();
        let models = bus.nodes.iter().map(|n| (n.module.address(), n.module.spec())).collect();
        let recorder = Recorder::new(Monitor::open(&monitor, first_pty)?, names, models);
        Ok(Server {
            bus,
            links: opened,
            ecat,
            start,
            verbose,
            flush_on_stop: true,
            notes,
            stopper,
            wake,
            jobs: std::sync::mpsc::channel(),
            recorder,
        })
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
        self.links.iter().filter_map(|(link, _)| link.info()).collect()
    }

    /// The network interface of the EtherCAT slave, if one is served.
    pub fn ethercat_interface(&self) -> Option<&str> {
        self.ecat.as_ref().map(|e| e.socket.name.as_str())
    }

    /// Whether the loop's end fsyncs the EEPROM files (the module's and the EtherCAT SII's); on by default.
    ///
    /// Every EEPROM write is in its file as it happens, whole or not at all, which survives a `kill -9`;
    /// the fsync only guards the last writes against a power loss, and under disk load it takes from
    /// tens of milliseconds to seconds. `tmcl serve` turns it off so that SIGTERM ends it within 100 ms
    /// whatever the machine is doing.
    pub fn set_flush_on_stop(&mut self, flush: bool) {
        self.flush_on_stop = flush;
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
            if let (true, Eeprom::File(f)) = (self.flush_on_stop, e.slave.store_mut()) {
                if let Err(err) = f.sync() {
                    flushed = Err(ServeError::Io(format!("EtherCAT SII not flushed: {err}")));
                }
            }
        }
        for node in self.bus.nodes.iter_mut().filter(|_| self.flush_on_stop) {
            if let Err(e) = node.module.board_mut().eeprom().sync() {
                flushed = Err(ServeError::Io(format!("{}: EEPROM not flushed: {e}", node.name)));
            }
        }
        if self.verbose {
            tracing::info!("[{}] stopped", self.now());
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
            for (link, _) in &self.links {
                if let Link::Pty(pty) = link {
                    tracing::info!("[{}] {} -> {}", clock(), pty.link.display(), pty.device.display());
                }
            }
        }
        let (bus, links, ecat, recorder) = (&mut self.bus, &mut self.links, &mut self.ecat, &mut self.recorder);
        let jobs = &self.jobs.1;
        let mut buf = [0u8; 4096];
        // Per link, the hosts last warned about, and when its hosts are to be looked at next (a pty's
        // watch sets it when they change; without a watch, every UNWATCHED_CHECK).
        let mut warned: Vec<Vec<(u32, String)>> = vec![Vec::new(); links.len()];
        let mut hosts_due: Vec<Option<std::time::Instant>> = links
            .iter()
            .map(|(link, _)| match link {
                Link::Pty(pty) if pty.hosts_watch().is_none() => Some(std::time::Instant::now() + UNWATCHED_CHECK),
                _ => None,
            })
            .collect();
        while !self.stopper.is_stopped() {
            while let Ok(job) = jobs.try_recv() {
                job(&mut bus.nodes, clock());
            }
            let now = clock();
            let mut deadline = bus.poll(now, &mut |n: usize, bytes: &[u8]| {
                recorder.reply(n, bytes);
                queue(links, n, bytes, verbose, now)
            });
            recorder.tick();
            for (link, pending) in links.iter_mut() {
                write_pending(link, pending, verbose, now);
            }
            if let Some(e) = ecat.as_mut() {
                let before = e.slave.status();
                let next = e.slave.poll(now, &mut bus.nodes[0].module, &mut e.files);
                log_al(verbose, now, before, e.slave.status());
                deadline = [deadline, next].into_iter().flatten().min();
            }
            let mut sleep = MAX_SLEEP;
            for (n, (link, _)) in links.iter().enumerate() {
                let (Link::Pty(pty), Some(due)) = (link, hosts_due[n]) else { continue };
                let left = due.saturating_duration_since(std::time::Instant::now());
                if left.is_zero() {
                    pty.release_abandoned_exclusive_mode();
                    warn_intruders(pty, &mut warned[n]);
                    hosts_due[n] = pty.hosts_watch().is_none().then(|| std::time::Instant::now() + UNWATCHED_CHECK);
                } else {
                    sleep = sleep.min(left);
                }
            }
            if let Some(d) = deadline {
                sleep = sleep.min(std::time::Duration::from_micros((d - clock()).micros()));
            }
            if let Some(due) = recorder.next_due() {
                sleep = sleep.min(due.saturating_duration_since(std::time::Instant::now()));
            }
            let mut extras: Vec<_> = ecat.as_ref().map(|e| e.socket.as_fd()).into_iter().collect();
            let monitor_fd = recorder.listener().map(|_| extras.len());
            extras.extend(recorder.listener().map(|l| l.as_fd()));
            // The pty links' watches (hosts opening and closing them), after the other extras.
            let watch_fds = extras.len();
            let mut watched = Vec::new();
            for (n, (link, _)) in links.iter().enumerate() {
                if let Link::Pty(pty) = link {
                    if let Some(fd) = pty.hosts_watch() {
                        extras.push(fd);
                        watched.push(n);
                    }
                }
            }
            let ready = wait(links, &extras, &self.wake, sleep).map_err(|e| ServeError::Io(format!("poll: {e}")))?;
            drop(extras);
            for (k, &n) in watched.iter().enumerate() {
                if let (true, Link::Pty(pty)) = (ready.extras[watch_fds + k], &links[n].0) {
                    if pty.hosts_changed() && hosts_due[n].is_none() {
                        hosts_due[n] = Some(std::time::Instant::now() + HOSTS_SETTLE);
                    }
                }
            }
            if ready.waker {
                let mut drain = [0u8; 16];
                while matches!((&self.wake).read(&mut drain), Ok(n) if n > 0) {}
            }
            if monitor_fd.is_some_and(|k| ready.extras[k]) {
                recorder.monitor_mut().accept();
            }
            if let Some(e) = ecat.as_mut() {
                if ready.extras.first().copied().unwrap_or(false) {
                    serve_frames(e, &mut bus.nodes[0].module, &clock, verbose, &self.stopper)?;
                } else {
                    // No frame waits: the time to write a file a master sent by FoE.
                    e.files.write_pending();
                }
            }
            for n in 0..links.len() {
                if !ready.links.get(n).copied().unwrap_or(false) {
                    continue;
                }
                // The host's bytes first: they are answered before a new TCP client is let in.
                let received = match &mut links[n].0 {
                    Link::Pty(pty) => read_some(&mut pty.master, &mut buf),
                    Link::Tcp { peer, .. } => match peer {
                        None => 0,
                        Some(stream) => match stream.read(&mut buf) {
                            Ok(k) if k > 0 => k,
                            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => 0,
                            _ => {
                                if verbose {
                                    tracing::info!("[{}] connection closed", clock());
                                }
                                *peer = None;
                                bus.reset_link(n);
                                recorder.reset(n);
                                links[n].1.clear();
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
                    recorder.request(n, &buf[..received]);
                    bus.receive(n, now, &buf[..received], &mut |k: usize, bytes: &[u8]| {
                        recorder.reply(k, bytes);
                        queue(links, k, bytes, verbose, now)
                    });
                    let (link, pending) = &mut links[n];
                    write_pending(link, pending, verbose, now);
                }
                let (link, pending) = &mut links[n];
                if let Link::Tcp { listener, peer } = link {
                    let had = peer.is_some();
                    accept_clients(
                        listener,
                        peer,
                        &mut || {
                            bus.reset_link(n);
                            recorder.reset(n);
                        },
                        verbose,
                        clock(),
                    );
                    if had && peer.is_none() {
                        pending.clear();
                    }
                }
            }
        }
        Ok(())
    }
}

/// Warns (on stderr, once per change) when more than one other process has the pty open: hosts that open a
/// port without a lock (pyserial's default) would read each other's replies.
fn warn_intruders(pty: &Pty, warned: &mut Vec<(u32, String)>) {
    // Not this process (which keeps the pty open), nor the server LINK.lock names (this one again).
    let mut now: Vec<(u32, String)> = tmcl_host::openers(&pty.link).into_iter().map(|o| (o.pid, o.name)).collect();
    now.sort();
    if now.len() > 1 && now != *warned {
        let names: Vec<String> = now.iter().map(|(pid, name)| format!("PID {pid} ({name})")).collect();
        eprintln!(
            "tmcl serve: warning: {} has {} hosts at once: {}; they read each other's replies. Give each host a \
             link of its own (--pty A --pty B)",
            pty.link.display(),
            now.len(),
            names.join(", ")
        );
    }
    *warned = if now.len() > 1 { now } else { Vec::new() };
}

/// Queues what a module sent on link `n` (logged with -v), for [`write_pending`].
fn queue(links: &mut [(Link, Vec<u8>)], n: usize, bytes: &[u8], verbose: bool, now: Instant) {
    if verbose {
        log_reply(now, bytes);
    }
    if let Some((_, pending)) = links.get_mut(n) {
        pending.extend_from_slice(bytes);
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

/// Answers the EtherCAT frames waiting on the socket, each as it comes, with the time it is taken: at
/// most [`FRAMES_PER_TURN`], and none after a stop was asked for, so that a flood of frames delays
/// neither a stop nor the links (the frames left are answered in the next turn of the loop).
fn serve_frames(
    e: &mut EtherCat,
    module: &mut Module<SimBoard>,
    clock: &impl Fn() -> Instant,
    verbose: bool,
    stopper: &Stopper,
) -> Result<(), ServeError> {
    let mut frame = [0u8; 2048];
    for _ in 0..FRAMES_PER_TURN {
        if stopper.is_stopped() {
            return Ok(());
        }
        let received =
            e.socket.recv(&mut frame).map_err(|err| ServeError::Io(format!("--ethercat {}: {err}", e.socket.name)))?;
        let Some((n, from)) = received else { return Ok(()) };
        let now = clock();
        let before = e.slave.status();
        if let Some(len) = e.slave.process(now, &mut frame[..n], module, &mut e.files) {
            if let Err(err) = e.socket.send(&frame[..len], &from) {
                if verbose {
                    tracing::warn!("[{now}] EtherCAT: cannot send the answer: {err}");
                }
            }
        }
        log_al(verbose, now, before, e.slave.status());
    }
    Ok(())
}

pub(crate) fn read_some(file: &mut std::fs::File, buf: &mut [u8]) -> usize {
    // WouldBlock: nothing after all; EIO cannot happen while we hold the slave open.
    file.read(buf).unwrap_or_default()
}

/// What woke [`wait`].
pub(crate) struct Ready {
    /// Per link: it has bytes (or a TCP connection waits, or room for replies).
    pub(crate) links: Vec<bool>,
    /// Per extra descriptor (the EtherCAT socket; `tmcl share`'s device and monitor socket): readable.
    pub(crate) extras: Vec<bool>,
    /// A stop was asked for.
    pub(crate) waker: bool,
}

/// Waits until a link is readable (for TCP: the client, or the listener with a new connection) or, with
/// replies waiting for room, writable, an extra descriptor (the EtherCAT socket) is readable, a stop is
/// asked for, or `timeout` passes (with microsecond resolution: byte times at high baud rates are far
/// below a millisecond).
pub(crate) fn wait(
    links: &[(Link, Vec<u8>)],
    extras: &[std::os::fd::BorrowedFd<'_>],
    waker: &UnixStream,
    timeout: std::time::Duration,
) -> io::Result<Ready> {
    let mut fds = Vec::new();
    let mut owner = Vec::new();
    for (n, (link, pending)) in links.iter().enumerate() {
        let flags = if pending.is_empty() { PollFlags::POLLIN } else { PollFlags::POLLIN | PollFlags::POLLOUT };
        match link {
            Link::Pty(pty) => fds.push(PollFd::new(pty.master.as_fd(), flags)),
            Link::Tcp { listener, peer } => {
                fds.push(PollFd::new(listener.as_fd(), PollFlags::POLLIN));
                owner.push(n);
                if let Some(stream) = peer {
                    fds.push(PollFd::new(stream.as_fd(), flags));
                } else {
                    continue;
                }
            }
        }
        owner.push(n);
    }
    let link_fds = fds.len();
    fds.extend(extras.iter().map(|fd| PollFd::new(*fd, PollFlags::POLLIN)));
    let ecat_fds = fds.len();
    fds.push(PollFd::new(waker.as_fd(), PollFlags::POLLIN));
    let timeout = nix::sys::time::TimeSpec::from_duration(timeout.max(std::time::Duration::from_micros(20)));
    let mut woke = Ready { links: vec![false; links.len()], extras: vec![false; extras.len()], waker: false };
    match ppoll(&mut fds, Some(timeout), None) {
        Ok(0) => Ok(woke),
        Ok(_) => {
            let ready = |fd: &PollFd| fd.revents().is_some_and(|r| !r.is_empty());
            for (k, fd) in fds[..link_fds].iter().enumerate() {
                if ready(fd) {
                    woke.links[owner[k]] = true;
                }
            }
            woke.extras = fds[link_fds..ecat_fds].iter().map(ready).collect();
            woke.waker = fds[ecat_fds..].iter().any(ready);
            Ok(woke)
        }
        Err(nix::Error::EINTR) => Ok(woke),
        Err(e) => Err(io::Error::from_raw_os_error(e as i32)),
    }
}

/// Writes as much of `pending` as the link takes now; the rest waits for the link to take it (the host
/// reads). No TCP client: a host that is not listening loses it, as on a real line.
pub(crate) fn write_pending(link: &mut Link, pending: &mut Vec<u8>, verbose: bool, now: Instant) {
    while !pending.is_empty() {
        let written = match link {
            Link::Pty(pty) => pty.master.write(pending),
            Link::Tcp { peer: Some(stream), .. } => stream.write(pending),
            Link::Tcp { peer: None, .. } => Ok(pending.len()),
        };
        match written {
            Ok(0) => break,
            Ok(n) => {
                pending.drain(..n);
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
    if pending.len() > MAX_PENDING {
        let drop = pending.len() - MAX_PENDING;
        pending.drain(..drop);
        if verbose {
            tracing::warn!("[{now}] the host does not read its replies: {drop} bytes dropped");
        }
    }
}

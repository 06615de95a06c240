//! `tmcl share`: one module (a real one on a serial port, or any TMCL link) used by several hosts, each
//! through a link of its own.
//!
//! A serial line has one master (PD28-1021 manual §3.1: the host sends a request and waits for its reply
//! before it sends the next), and a reply carries nothing but the module address and the command number
//! to say what it answers (§3.2, Table 3). So the share owns the device and is its one master: it takes
//! one request at a time from its host links, in turn, writes it to the device, and waits for the reply
//! or the reply timeout before the next one goes out. Each reply goes to the host that asked. What it
//! knows of the protocol to keep replies where they belong:
//!
//! - **Which reply answers.** A frame with the request's command number (or status 1 with command 0, the
//!   answer to a damaged request; any frame for 134, whose reply carries the instruction read) answers
//!   the request in flight. The module address is not compared: a module on USB answers every address,
//!   one reached at its secondary address (GP 87) answers from its own, and SGP 66 changes it.
//! - **Commands that may get no reply**: 137 (factory defaults, carried out without a reply, §3.7.38),
//!   242 (boot), 255 (reset), and every command but GAP, GGP and GIO while GP 255 is set on that address
//!   (§5.1: the share follows SGP 255 as it passes). For these the share waits
//!   [`ShareOptions::no_reply_wait`] instead of the reply timeout; a reply that comes (a refusal) goes to
//!   the asker as any other.
//! - **Two replies**: 138 is answered at once, and again (status 128) when the motors reach their
//!   targets (§3.7.37). The second reply may come during another host's transaction; it goes to the host
//!   that last sent 138 to that module address, never to the host whose request is in flight.
//! - **Late replies.** After a request that got no reply, the line must have been quiet for
//!   [`ShareOptions::quiet`] before the next request goes out; a reply that comes in that time goes to
//!   the host whose request it answers. A frame that answers nothing here is shown to no host (and
//!   logged as foreign).
//! - **ASCII mode** (§3.4). Other hosts keep talking binary, so the module stays in binary mode: a host's
//!   139 is not passed on. The share switches that host's link to ASCII mode (answering the 139 in binary,
//!   with the host address the module reports, GGP 76) and translates: each line it completes (address
//!   character, command, `<CR>`) goes to the module as a binary request, and the reply comes back as an
//!   ASCII reply line (`BA 100 1234<CR>`); `BIN` returns the link to binary. There is no echo (GP 67's
//!   echo modes are the module's; with the module in binary mode nothing echoes), and lines that do not
//!   parse or hold a command ASCII mode does not take are answered by the share with the module's status
//!   for them (2, 3, 4 or 6).
//!
//! Host links are `tmcl serve`'s: ptys behind a symlink with `LINK.lock`, TCP ports with one client each;
//! a backlog of frames on a link waits in the share and is answered in order, one reply per frame. The
//! links take turns: one request of each link that has one, then again.

use crate::monitor::{decode_reply, decode_request, hex, socket_beside, Monitor, MonitorOptions, Outcome, Transaction};
use crate::serve::{open_link, wait, write_pending, Link};
use crate::tcp::accept_clients;
use crate::{LinkInfo, LinkOptions, ServeError, Stopper};
use std::collections::HashMap;
use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::os::fd::{AsFd, BorrowedFd};
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use tmcl_core::model::ModelSpec;
use tmcl_wire::ascii::{ascii_allowed, char_address, parse_ascii_command, write_reply, AsciiCommand};
use tmcl_wire::{checksum, CommandSet, Opcode, Reply, ReplyFrame, Status, FRAME_LEN};

/// How long a partial frame from a host stays before it is dropped (as `tmcl serve`'s links: a frame
/// written in pieces stays whole, a stray byte does not shift the next frames for good).
const HOST_RESYNC: Duration = Duration::from_micros(crate::bus::STREAM_RESYNC.micros());

/// The module the share forwards to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeviceOptions {
    /// A serial port or pty (a `tmcl serve` link), opened 8N1 raw at `baud`, exclusively.
    Serial {
        /// The device or link.
        path: PathBuf,
        /// Its baud rate (ignored by ptys).
        baud: u32,
        /// Open it even if other processes have it open (they would read the module's replies).
        shared: bool,
    },
    /// A TCP port speaking TMCL (`tmcl serve --tcp`, a serial-to-network adapter).
    Tcp(String),
}

/// What a share serves.
#[derive(Debug, Clone)]
pub struct ShareOptions {
    /// The module's device.
    pub device: DeviceOptions,
    /// The host links (up to [`MAX_HOST_LINKS`]).
    pub links: Vec<LinkOptions>,
    /// How long to wait for a reply (default 1 s).
    pub reply_timeout: Duration,
    /// How long to wait for a reply to a command that may get none (default 100 ms).
    pub no_reply_wait: Duration,
    /// How long the device must be quiet after a request that got no reply before the next goes out
    /// (default 30 ms: three frames at 9600 baud).
    pub quiet: Duration,
    /// The module's model, for the names and units in the monitor; `None`: learnt from a version string
    /// (136 type 0) that passes.
    pub model: Option<&'static ModelSpec>,
    /// The log file and the monitor socket.
    pub monitor: MonitorOptions,
}

/// The most host links of one share.
pub const MAX_HOST_LINKS: usize = 16;

impl ShareOptions {
    /// `device` on `links`, with the default timing.
    pub fn new(device: DeviceOptions, links: Vec<LinkOptions>) -> ShareOptions {
        ShareOptions {
            device,
            links,
            reply_timeout: Duration::from_secs(1),
            no_reply_wait: Duration::from_millis(100),
            quiet: Duration::from_millis(30),
            model: None,
            monitor: MonitorOptions::default(),
        }
    }
}

/// The device's byte stream.
enum Device {
    Serial(std::fs::File),
    Tcp(TcpStream),
}

impl Drop for Device {
    /// Gives the port back as it was found: without the exclusive mode, which would otherwise outlive the
    /// share on a pty whose server keeps it open (root aside, no other program could open it).
    fn drop(&mut self) {
        if let Device::Serial(file) = self {
            let _ = rustix::termios::ioctl_tiocnxcl(&*file);
        }
    }
}

impl Device {
    fn open(options: &DeviceOptions) -> Result<Device, ServeError> {
        match options {
            DeviceOptions::Serial { path, baud, shared } => open_serial(path, *baud, *shared).map(Device::Serial),
            DeviceOptions::Tcp(addr) => {
                let stream = TcpStream::connect(addr)
                    .map_err(|e| ServeError::Io(format!("cannot connect to the module at {addr}: {e}")))?;
                let _ = stream.set_nodelay(true);
                stream.set_nonblocking(true).map_err(|e| ServeError::Io(e.to_string()))?;
                Ok(Device::Tcp(stream))
            }
        }
    }

    fn fd(&self) -> BorrowedFd<'_> {
        match self {
            Device::Serial(f) => f.as_fd(),
            Device::Tcp(s) => s.as_fd(),
        }
    }

    /// Reads what is there: `Ok(0)` when nothing is, an error when the device is gone.
    fn read_some(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let read = match self {
            Device::Serial(f) => f.read(buf),
            Device::Tcp(s) => s.read(buf),
        };
        match read {
            Ok(0) => Err(io::Error::new(io::ErrorKind::UnexpectedEof, "the module's side closed")),
            Ok(n) => Ok(n),
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => Ok(0),
            Err(e) => Err(e),
        }
    }

    /// Writes all of `bytes`, waiting for room at most 1 s.
    fn write_all(&mut self, mut bytes: &[u8]) -> io::Result<()> {
        let deadline = Instant::now() + Duration::from_secs(1);
        while !bytes.is_empty() {
            let written = match self {
                Device::Serial(f) => f.write(bytes),
                Device::Tcp(s) => s.write(bytes),
            };
            match written {
                Ok(0) => return Err(io::Error::new(io::ErrorKind::WriteZero, "the device takes no bytes")),
                Ok(n) => bytes = &bytes[n..],
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        return Err(io::Error::new(io::ErrorKind::TimedOut, "the device takes no bytes for 1 s"));
                    }
                    let mut fds = [nix::poll::PollFd::new(self.fd(), nix::poll::PollFlags::POLLOUT)];
                    let _ = nix::poll::poll(
                        &mut fds,
                        nix::poll::PollTimeout::try_from(left).unwrap_or(nix::poll::PollTimeout::MAX),
                    );
                }
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }
}

/// Opens a serial port or pty as the host side does (`tmcl_host::SerialTransport::open_alone`): a link whose
/// server has exited is refused, and one other processes have open too unless `shared`; then 8N1 raw at
/// `baud`, exclusive (`flock` and `TIOCEXCL`), non-blocking.
fn open_serial(path: &std::path::Path, baud: u32, shared: bool) -> Result<std::fs::File, ServeError> {
    let shown = path.display();
    tmcl_host::check_link(path).map_err(|e| ServeError::Io(e.to_string()))?;
    if !shared {
        let others = tmcl_host::openers(path);
        if !others.is_empty() {
            let names: Vec<String> = others.iter().map(|o| format!("PID {} ({})", o.pid, o.name)).collect();
            return Err(ServeError::Io(format!(
                "{shown} is open in {}: they would read the module's replies. Stop them (they can use a link \
                 of the share instead), or --shared to go on anyway",
                names.join(", ")
            )));
        }
    }
    let file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc_flags())
        .open(path)
        .map_err(|e| ServeError::Io(format!("cannot open {shown}: {e}")))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            return Err(ServeError::Io(format!("{shown} is in use: another program holds it exclusively")))
        }
        Err(std::fs::TryLockError::Error(e)) => return Err(ServeError::Io(format!("cannot lock {shown}: {e}"))),
    }
    let _ = rustix::termios::ioctl_tiocexcl(&file);
    use nix::sys::termios::{cfmakeraw, cfsetspeed, tcgetattr, tcsetattr, BaudRate, ControlFlags, SetArg};
    let mut termios = tcgetattr(&file).map_err(|e| ServeError::Io(format!("{shown} is not a serial port: {e}")))?;
    cfmakeraw(&mut termios);
    termios.control_flags |= ControlFlags::CLOCAL | ControlFlags::CREAD;
    termios.control_flags &= !(ControlFlags::CSTOPB | ControlFlags::PARENB | ControlFlags::CRTSCTS);
    let rate = match baud {
        9600 => BaudRate::B9600,
        14400 | 19200 => BaudRate::B19200,
        28800 | 38400 => BaudRate::B38400,
        57600 => BaudRate::B57600,
        115200 => BaudRate::B115200,
        230400 => BaudRate::B230400,
        460800 => BaudRate::B460800,
        921600 => BaudRate::B921600,
        1000000 => BaudRate::B1000000,
        _ => return Err(ServeError::Config(format!("--baud {baud}: not a rate the serial port takes"))),
    };
    let _ = cfsetspeed(&mut termios, rate);
    tcsetattr(&file, SetArg::TCSANOW, &termios).map_err(|e| ServeError::Io(format!("{shown}: {e}")))?;
    // Input from before the share: not a reply to anything it sends.
    let _ = nix::sys::termios::tcflush(&file, nix::sys::termios::FlushArg::TCIFLUSH);
    Ok(file)
}

fn libc_flags() -> i32 {
    (nix::fcntl::OFlag::O_NOCTTY | nix::fcntl::OFlag::O_NONBLOCK).bits()
}

/// A host's ASCII mode: the line being typed, and the host address the module replies to (GP 76).
#[derive(Debug, Default)]
struct AsciiHost {
    line: Vec<u8>,
    host_address: u8,
}

/// One host link and what it sent that is not answered yet.
struct Host {
    /// Bytes received and not taken yet: a backlog of frames (or lines), and a partial one at the end.
    rx: Vec<u8>,
    last_rx: Instant,
    ascii: Option<AsciiHost>,
    name: String,
    /// Counts the clients the link has had (a TCP link's client that went away and a new one): a reply to
    /// a request of an earlier client goes to nobody.
    generation: u64,
}

/// What a request in flight is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Purpose {
    /// A host's binary request, its reply passed on as it comes.
    Forward,
    /// A host's 139: GGP 76 asks the module for the host address, and the share answers the 139.
    EnterAscii,
    /// A host's ASCII line, sent as a binary request; the reply goes back as text.
    Ascii,
}

/// The request in flight.
struct Inflight {
    host: usize,
    generation: u64,
    frame: [u8; FRAME_LEN],
    /// What the host sent (the frame, or the ASCII line).
    asked: Vec<u8>,
    purpose: Purpose,
    sent: Instant,
    deadline: Instant,
}

/// A request that got no reply: its late reply still goes to its host.
#[derive(Clone, Copy)]
struct Unanswered {
    host: usize,
    generation: u64,
    opcode: u8,
    frame: [u8; FRAME_LEN],
}

/// A module shared by several hosts, its device and links open (see the module docs).
pub struct Share {
    device: Device,
    device_name: String,
    links: Vec<(Link, Vec<u8>)>,
    hosts: Vec<Host>,
    options: ShareOptions,
    model: Option<&'static ModelSpec>,
    monitor: Monitor,
    stopper: Stopper,
    wake: UnixStream,
    inflight: Option<Inflight>,
    /// No request goes out before this instant (the device must be quiet after a missing reply).
    hold_until: Option<Instant>,
    /// The latest requests that got no reply, newest last.
    unanswered: Vec<Unanswered>,
    /// Per module address: the host that last asked for a 138 event.
    subscribers: HashMap<u8, (usize, u64)>,
    /// Module addresses whose replies GP 255 switched off.
    replies_off: HashMap<u8, bool>,
    /// Bytes from the device not taken yet, and when the last came.
    device_rx: Vec<u8>,
    device_last: Instant,
    /// The link whose turn is next.
    turn: usize,
}

impl Share {
    /// Opens the device and the host links (and the monitor socket, the log file).
    ///
    /// # Errors
    ///
    /// [`ServeError::Config`] for no link or too many, [`ServeError::Io`] for a device or link the OS
    /// refuses, a device other processes hold, a link another server holds.
    pub fn new(options: ShareOptions) -> Result<Share, ServeError> {
        if options.links.is_empty() {
            return Err(ServeError::Config("give at least one host link (--pty LINK or --tcp HOST:PORT)".into()));
        }
        if options.links.len() > MAX_HOST_LINKS {
            return Err(ServeError::Config(format!("at most {MAX_HOST_LINKS} host links per share")));
        }
        let device_name = match &options.device {
            DeviceOptions::Serial { path, .. } => {
                if options.links.iter().any(|l| matches!(l, LinkOptions::Pty(p) if p == path)) {
                    return Err(ServeError::Config(format!(
                        "{} is the device; a host link needs another path",
                        path.display()
                    )));
                }
                path.display().to_string()
            }
            DeviceOptions::Tcp(addr) => addr.clone(),
        };
        let device = Device::open(&options.device)?;
        let mut links = Vec::new();
        for link in &options.links {
            links.push((open_link(link.clone())?, Vec::new()));
        }
        let hosts = links
            .iter()
            .map(|(link, _)| Host {
                rx: Vec::new(),
                last_rx: Instant::now(),
                ascii: None,
                name: link.info().map(|i| i.to_string()).unwrap_or_default(),
                generation: 0,
            })
            .collect();
        let first_pty = links.iter().find_map(|(l, _)| match l {
            Link::Pty(p) => Some(socket_beside(&p.link)),
            Link::Tcp { .. } => None,
        });
        let monitor = Monitor::open(&options.monitor, first_pty)?;
        let (stopper, wake) = Stopper::new()?;
        Ok(Share {
            device,
            device_name,
            links,
            hosts,
            model: options.model,
            options,
            monitor,
            stopper,
            wake,
            inflight: None,
            hold_until: None,
            unanswered: Vec::new(),
            subscribers: HashMap::new(),
            replies_off: HashMap::new(),
            device_rx: Vec::new(),
            device_last: Instant::now(),
            turn: 0,
        })
    }

    /// Where hosts reach the module.
    pub fn links(&self) -> Vec<LinkInfo> {
        self.links.iter().filter_map(|(l, _)| l.info()).collect()
    }

    /// The device (its path or address).
    pub fn device(&self) -> &str {
        &self.device_name
    }

    /// The monitor socket (`tmcl monitor` connects there), if there is one.
    pub fn monitor_socket(&self) -> Option<PathBuf> {
        self.monitor.socket().map(PathBuf::from)
    }

    /// The handle that stops [`Share::run`].
    pub fn stopper(&self) -> Stopper {
        self.stopper.clone()
    }

    /// Runs the share on a thread of its own; it stops when the returned handle is dropped.
    ///
    /// # Errors
    ///
    /// [`ServeError::Io`] when the OS refuses the thread.
    pub fn spawn(self) -> Result<RunningShare, ServeError> {
        let stopper = self.stopper();
        let links = self.links();
        let thread = std::thread::Builder::new()
            .name("tmcl-share".into())
            .spawn(move || self.run())
            .map_err(|e| ServeError::Io(format!("cannot start the share's thread: {e}")))?;
        Ok(RunningShare { stopper, links, thread: Some(thread) })
    }

    /// Serves until the [`Stopper`] says stop, then removes the links.
    ///
    /// # Errors
    ///
    /// [`ServeError::Io`] when the device fails or hangs up (a module unplugged, the server behind a link
    /// stopped), or waiting fails.
    pub fn run(mut self) -> Result<(), ServeError> {
        let mut buf = [0u8; 4096];
        while !self.stopper.is_stopped() {
            let now = Instant::now();
            self.expire(now);
            self.start_next(now)?;
            for (link, pending) in &mut self.links {
                write_pending(link, pending, false, tmcl_core::Instant::ZERO);
            }
            self.monitor.flush();
            let sleep =
                self.next_deadline().map_or(Duration::from_secs(1), |d| d.saturating_duration_since(Instant::now()));
            let mut extras = vec![self.device.fd()];
            extras.extend(self.monitor.listener().map(|l| l.as_fd()));
            let ready = wait(&self.links, &extras, &self.wake, sleep.min(Duration::from_secs(1)))
                .map_err(|e| ServeError::Io(format!("poll: {e}")))?;
            if ready.waker {
                let mut drain = [0u8; 16];
                while matches!((&self.wake).read(&mut drain), Ok(n) if n > 0) {}
            }
            if ready.extras.get(1).copied().unwrap_or(false) {
                self.monitor.accept();
            }
            if ready.extras[0] {
                let n = match self.device.read_some(&mut buf) {
                    Ok(n) => n,
                    // The module's side went away as the share was told to stop (both stopped together).
                    Err(_) if self.stopper.is_stopped() => break,
                    Err(e) => return Err(ServeError::Io(format!("{}: {e}; the share stops", self.device_name))),
                };
                if n > 0 {
                    self.device_rx.extend_from_slice(&buf[..n]);
                    self.device_last = Instant::now();
                    // After a missing reply the line must be quiet before the next request goes out.
                    if let Some(hold) = self.hold_until.as_mut() {
                        *hold = (*hold).max(self.device_last + self.options.quiet);
                    }
                    self.take_device_frames();
                }
            }
            for n in 0..self.links.len() {
                if !ready.links[n] {
                    continue;
                }
                let received = match self.links[n].0.read_host(&mut buf) {
                    Some(k) => k,
                    None => {
                        self.reset_host(n);
                        0
                    }
                };
                if received > 0 {
                    let host = &mut self.hosts[n];
                    host.rx.extend_from_slice(&buf[..received]);
                    host.last_rx = Instant::now();
                }
                let (link, pending) = &mut self.links[n];
                write_pending(link, pending, false, tmcl_core::Instant::ZERO);
                if let Link::Tcp { listener, peer } = link {
                    // A client gone or a new one: what the last one left is not the new one's.
                    let mut changed = false;
                    accept_clients(listener, peer, &mut || changed = true, false, tmcl_core::Instant::ZERO);
                    if changed {
                        pending.clear();
                        self.reset_host(n);
                    }
                }
            }
        }
        Ok(())
    }

    /// Forgets what a host that went away left unanswered.
    fn reset_host(&mut self, n: usize) {
        let host = &mut self.hosts[n];
        host.rx.clear();
        host.ascii = None;
        host.generation += 1;
        self.links[n].1.clear();
    }

    /// The next instant something is due: the reply timeout, the end of a hold, a partial frame to drop.
    fn next_deadline(&self) -> Option<Instant> {
        let mut next: Vec<Instant> = Vec::new();
        next.extend(self.inflight.as_ref().map(|i| i.deadline));
        next.extend(self.hold_until);
        if !self.device_rx.is_empty() {
            next.push(self.device_last + HOST_RESYNC);
        }
        for host in &self.hosts {
            if host.ascii.is_none() && !host.rx.is_empty() && host.rx.len() < FRAME_LEN {
                next.push(host.last_rx + HOST_RESYNC);
            }
        }
        next.into_iter().min()
    }

    /// Ends a wait that ran out, the hold after it, and drops partial frames that stayed too long.
    fn expire(&mut self, now: Instant) {
        if self.inflight.as_ref().is_some_and(|i| now >= i.deadline) {
            let inflight = self.inflight.take().expect("checked");
            let opcode = inflight.frame[1];
            let address = inflight.frame[0];
            // A reset or factory default carried out: the module starts again, with replies on.
            if matches!(opcode, 137 | 242 | 255) {
                self.replies_off.remove(&address);
            }
            if inflight.purpose == Purpose::EnterAscii {
                // The module did not answer GGP 76: the host's 139 gets no answer either.
                self.hosts[inflight.host].ascii = None;
            }
            self.unanswered.push(Unanswered {
                host: inflight.host,
                generation: inflight.generation,
                opcode,
                frame: inflight.frame,
            });
            if self.unanswered.len() > 8 {
                self.unanswered.remove(0);
            }
            self.hold_until = Some(now + self.options.quiet);
            if self.monitor.wanted() {
                let mut t = Transaction::now(&self.hosts[inflight.host].name, Outcome::NoReply);
                t.request = Some(self.decode_asked(&inflight));
                t.round_trip_us = Some(now.duration_since(inflight.sent).as_micros() as u64);
                self.monitor.record(&t);
            }
        }
        if self.hold_until.is_some_and(|h| now >= h) {
            self.hold_until = None;
        }
        if !self.device_rx.is_empty() && now >= self.device_last + HOST_RESYNC {
            let bytes = std::mem::take(&mut self.device_rx);
            self.device_partial(&bytes);
        }
        for n in 0..self.hosts.len() {
            let host = &mut self.hosts[n];
            if host.ascii.is_none()
                && !host.rx.is_empty()
                && host.rx.len() < FRAME_LEN
                && now >= host.last_rx + HOST_RESYNC
            {
                let bytes = std::mem::take(&mut host.rx);
                if self.monitor.wanted() {
                    let mut t = Transaction::now(&self.hosts[n].name, Outcome::Partial);
                    t.request =
                        Some(crate::monitor::Decoded { raw: hex(&bytes), text: format!("{} bytes", bytes.len()) });
                    self.monitor.record(&t);
                }
            }
        }
    }

    /// Sends the next request (links in turn) if none is in flight and the line may take one.
    fn start_next(&mut self, now: Instant) -> Result<(), ServeError> {
        while self.inflight.is_none() && self.hold_until.is_none() {
            let count = self.hosts.len();
            let Some(n) = (0..count).map(|k| (self.turn + k) % count).find(|&n| self.has_unit(n)) else {
                return Ok(());
            };
            self.turn = (n + 1) % count;
            self.take_unit(n, now)?;
        }
        Ok(())
    }

    /// Whether host `n` has a whole frame (binary) or line (ASCII) waiting.
    fn has_unit(&self, n: usize) -> bool {
        let host = &self.hosts[n];
        match host.ascii {
            None => host.rx.len() >= FRAME_LEN,
            Some(_) => host.rx.contains(&b'\r'),
        }
    }

    /// Takes host `n`'s next frame or line and sends it (or answers it here).
    fn take_unit(&mut self, n: usize, now: Instant) -> Result<(), ServeError> {
        if self.hosts[n].ascii.is_some() {
            return self.take_line(n, now);
        }
        let mut frame = [0u8; FRAME_LEN];
        frame.copy_from_slice(&self.hosts[n].rx[..FRAME_LEN]);
        self.hosts[n].rx.drain(..FRAME_LEN);
        let valid = checksum(&frame[..8]) == frame[8];
        if valid && frame[1] == u8::from(Opcode::EnterAscii) {
            // Ask the module for the host address instead; the 139 is answered when it replies.
            self.hosts[n].ascii = Some(AsciiHost::default());
            let ggp = request_frame(frame[0], Opcode::Ggp, 76, 0, 0);
            return self.send(n, ggp, frame.to_vec(), Purpose::EnterAscii, now);
        }
        self.send(n, frame, frame.to_vec(), Purpose::Forward, now)
    }

    /// Takes host `n`'s next ASCII line (§3.4.2): translates it, or answers it here.
    fn take_line(&mut self, n: usize, now: Instant) -> Result<(), ServeError> {
        let host = &mut self.hosts[n];
        let end = host.rx.iter().position(|&b| b == b'\r').expect("has_unit");
        let raw: Vec<u8> = host.rx.drain(..=end).collect();
        // What a terminal sends: LF after CR is ignored, a backspace takes back a character, a control
        // character or a byte from 0x80 up discards the line typed so far (as the module's ASCII mode).
        let mut line = Vec::new();
        for &b in &raw[..raw.len() - 1] {
            match b {
                b'\n' => {}
                0x08 | 0x7F => {
                    line.pop();
                }
                b'\t' => line.push(b' '),
                b if !(0x20..0x80).contains(&b) => line.clear(),
                b => line.push(b),
            }
        }
        let ascii = host.ascii.as_mut().expect("ASCII mode");
        ascii.line.clone_from(&line);
        let host_address = ascii.host_address;
        let text = String::from_utf8_lossy(&line).trim_start().to_string();
        let Some(&first) = text.as_bytes().first() else { return Ok(()) };
        let Some(address) = char_address(first.to_ascii_uppercase()) else { return Ok(()) };
        let answer_here = |status: Status, value: i32| {
            let mut reply = String::new();
            let _ = write_reply(&mut reply, host_address, address, status, value);
            reply
        };
        let (reply, leave) = match parse_ascii_command(&text[1..], &mut |_| None) {
            Err(e) => (answer_here(Status::from(e), 0), false),
            Ok(AsciiCommand::Binary) => (answer_here(Status::Ok, 0), true),
            Ok(AsciiCommand::Run) => {
                let frame = request_frame(address, Opcode::RunApplication, 0, 0, 0);
                return self.send(n, frame, raw, Purpose::Ascii, now);
            }
            Ok(AsciiCommand::Stop) => {
                let frame = request_frame(address, Opcode::StopApplication, 0, 0, 0);
                return self.send(n, frame, raw, Purpose::Ascii, now);
            }
            Ok(AsciiCommand::Instruction(i)) if !ascii_allowed(i.opcode) => {
                (answer_here(Status::NotAvailable, i.value), false)
            }
            Ok(AsciiCommand::Instruction(i)) => {
                let frame = request_frame(address, i.opcode, i.kind, i.motor, i.value);
                return self.send(n, frame, raw, Purpose::Ascii, now);
            }
        };
        self.links[n].1.extend_from_slice(reply.as_bytes());
        if leave {
            self.hosts[n].ascii = None;
        }
        if self.monitor.wanted() {
            let mut t = Transaction::now(&self.hosts[n].name, Outcome::Local);
            t.request = Some(crate::monitor::Decoded {
                raw: String::from_utf8_lossy(&raw).trim_end().to_string(),
                text: text.clone(),
            });
            t.reply =
                Some(crate::monitor::Decoded { raw: reply.trim_end().to_string(), text: reply.trim_end().to_string() });
            t.round_trip_us = Some(0);
            self.monitor.record(&t);
        }
        Ok(())
    }

    /// Writes `frame` to the device for host `n` and waits for its reply.
    fn send(
        &mut self,
        n: usize,
        frame: [u8; FRAME_LEN],
        asked: Vec<u8>,
        purpose: Purpose,
        now: Instant,
    ) -> Result<(), ServeError> {
        let (address, opcode) = (frame[0], frame[1]);
        // GP 255 (bank 0): the module's replies go off or on with this request, its own reply included
        // (§5.1).
        if checksum(&frame[..8]) == frame[8] && opcode == u8::from(Opcode::Sgp) && frame[2] == 255 && frame[3] == 0 {
            let value = i32::from_be_bytes([frame[4], frame[5], frame[6], frame[7]]);
            self.replies_off.insert(address, value != 0);
        }
        let silent_ok = matches!(opcode, 137 | 242 | 255)
            || (self.replies_off.get(&address).copied().unwrap_or(false)
                && !CommandSet::ALWAYS_REPLY.contains_code(opcode));
        let wait = if silent_ok { self.options.no_reply_wait } else { self.options.reply_timeout };
        if opcode == u8::from(Opcode::RequestTargetReachedEvent) {
            self.subscribers.insert(address, (n, self.hosts[n].generation));
        }
        // Bytes from before this request answer none of it.
        if !self.device_rx.is_empty() {
            let bytes = std::mem::take(&mut self.device_rx);
            self.device_partial(&bytes);
        }
        self.device
            .write_all(&frame)
            .map_err(|e| ServeError::Io(format!("{}: {e}; the share stops", self.device_name)))?;
        let generation = self.hosts[n].generation;
        self.inflight =
            Some(Inflight { host: n, generation, frame, asked, purpose, sent: now, deadline: Instant::now() + wait });
        Ok(())
    }

    /// Takes the whole frames the device sent and routes each.
    fn take_device_frames(&mut self) {
        while self.device_rx.len() >= FRAME_LEN {
            let mut frame = [0u8; FRAME_LEN];
            frame.copy_from_slice(&self.device_rx[..FRAME_LEN]);
            let raw_version = self.inflight.as_ref().is_some_and(|i| i.frame[1] == 136 && i.frame[2] == 0);
            if raw_version {
                // The version string (136 type 0, §3.7.38): no checksum, no status.
                self.device_rx.drain(..FRAME_LEN);
                if let Some(model) = tmcl_core::model::by_version_bytes(&frame[1..]) {
                    self.model = self.model.or(Some(model));
                }
                self.answer(frame, None);
                continue;
            }
            match Reply::parse(&ReplyFrame::new_unchecked(&frame[..])) {
                Ok(reply) => {
                    self.device_rx.drain(..FRAME_LEN);
                    self.route(frame, reply);
                }
                Err(_) => {
                    // Garbage before a frame: look for one that starts later among the bytes there are.
                    let later = (1..FRAME_LEN).find(|&k| {
                        self.device_rx.len() >= k + FRAME_LEN
                            && checksum(&self.device_rx[k..k + 8]) == self.device_rx[k + 8]
                    });
                    match later {
                        Some(k) => {
                            let bytes: Vec<u8> = self.device_rx.drain(..k).collect();
                            self.device_partial(&bytes);
                        }
                        None if self.inflight.is_some() => {
                            // A damaged reply to the request in flight: the asker sees it as it came.
                            self.device_rx.drain(..FRAME_LEN);
                            self.answer(frame, None);
                        }
                        None => {
                            let bytes: Vec<u8> = self.device_rx.drain(..FRAME_LEN).collect();
                            self.device_partial(&bytes);
                        }
                    }
                }
            }
        }
    }

    /// Routes a reply: the second reply of 138 to its subscriber, the answer to the asker, a late reply
    /// to the host whose request got none, anything else nowhere.
    fn route(&mut self, frame: [u8; FRAME_LEN], reply: Reply) {
        let event =
            reply.opcode == u8::from(Opcode::RequestTargetReachedEvent) && reply.status == Status::TargetReached;
        let answers = |asked: &[u8; FRAME_LEN]| {
            reply.opcode == asked[1] || (reply.status == Status::WrongChecksum && reply.opcode == 0) || asked[1] == 134
        };
        if event {
            let host = self.subscribers.get(&reply.module).copied();
            if let Some((h, generation)) = host {
                self.deliver(h, generation, &frame);
            }
            let current = host.filter(|&(h, g)| self.hosts[h].generation == g).map(|(h, _)| h);
            self.record_unsolicited(current, &frame, Outcome::Event);
            return;
        }
        if self.inflight.as_ref().is_some_and(|i| answers(&i.frame)) {
            self.answer(frame, Some(reply));
            return;
        }
        if let Some(k) = self.unanswered.iter().rposition(|u| u.opcode == reply.opcode || answers(&u.frame)) {
            let late = self.unanswered.remove(k);
            self.deliver(late.host, late.generation, &frame);
            if self.monitor.wanted() {
                let mut t = Transaction::now(&self.hosts[late.host].name, Outcome::Late);
                t.request = Some(decode_request(&late.frame, self.model));
                let (decoded, status, _) = decode_reply(&frame, Some(&late.frame), self.model);
                t.reply = Some(decoded);
                t.status = status.map(u8::from);
                self.monitor.record(&t);
            }
            // The line is not quiet yet.
            if self.hold_until.is_some() {
                self.hold_until = Some(Instant::now() + self.options.quiet);
            }
            return;
        }
        self.record_unsolicited(None, &frame, Outcome::Foreign);
    }

    /// Ends the transaction in flight with this reply (`None`: damaged or raw) and passes it on.
    fn answer(&mut self, frame: [u8; FRAME_LEN], reply: Option<Reply>) {
        let Some(inflight) = self.inflight.take() else {
            self.record_unsolicited(None, &frame, Outcome::Foreign);
            return;
        };
        let n = inflight.host;
        let outcome = match (reply, inflight.frame[1] == 136 && inflight.frame[2] == 0) {
            (None, false) => Outcome::Damaged,
            _ => Outcome::Answered,
        };
        match inflight.purpose {
            Purpose::Forward => self.deliver(n, inflight.generation, &frame),
            Purpose::EnterAscii => {
                // The 139 answered in binary (§3.4.1), from the module's address, to the host address it
                // reported; then the link is in ASCII mode.
                let host_address =
                    reply.filter(|r| r.status.is_success()).and_then(|r| u8::try_from(r.value).ok()).unwrap_or(2);
                if let Some(a) = self.hosts[n].ascii.as_mut() {
                    a.host_address = host_address;
                }
                let module = reply.map_or(inflight.frame[0], |r| r.module);
                let r139 = Reply { host: host_address, module, status: Status::Ok, opcode: 139, value: 0 };
                self.deliver(n, inflight.generation, &r139.to_bytes());
            }
            Purpose::Ascii => {
                let mut text = String::new();
                match reply {
                    Some(r) => {
                        let _ = write_reply(&mut text, r.host, r.module, r.status, r.value);
                    }
                    None => text.push_str("?? 1 0\r"),
                }
                self.deliver(n, inflight.generation, text.as_bytes());
            }
        }
        if self.monitor.wanted() {
            let mut t = Transaction::now(&self.hosts[n].name, outcome);
            t.request = Some(self.decode_asked(&inflight));
            let (decoded, status, note) = decode_reply(&frame, Some(&inflight.frame), self.model);
            t.reply = Some(decoded);
            t.status = status.map(u8::from);
            t.note = note;
            t.round_trip_us = Some(inflight.sent.elapsed().as_micros() as u64);
            self.monitor.record(&t);
        }
    }

    /// What the host asked, decoded (an ASCII line shows as the line and the request it became).
    fn decode_asked(&self, inflight: &Inflight) -> crate::monitor::Decoded {
        let mut d = decode_request(&inflight.frame, self.model);
        match inflight.purpose {
            Purpose::Forward => {}
            Purpose::EnterAscii => d.text = format!("enter ASCII mode (139; asked as {})", d.text),
            Purpose::Ascii => {
                d.raw = String::from_utf8_lossy(&inflight.asked).trim_end().to_string();
                d.text = format!("ASCII {:?} = {}", d.raw, d.text);
            }
        }
        d
    }

    /// Queues bytes for host `n`.
    fn deliver(&mut self, n: usize, generation: u64, bytes: &[u8]) {
        if self.hosts.get(n).is_some_and(|h| h.generation == generation) {
            self.links[n].1.extend_from_slice(bytes);
        }
    }

    fn record_unsolicited(&mut self, host: Option<usize>, frame: &[u8], outcome: Outcome) {
        if !self.monitor.wanted() {
            return;
        }
        let name = host.map_or("-".to_string(), |h| self.hosts[h].name.clone());
        let mut t = Transaction::now(&name, outcome);
        let (decoded, status, _) = decode_reply(frame, None, self.model);
        t.reply = Some(decoded);
        t.status = status.map(u8::from);
        if outcome == Outcome::Event && host.is_none() {
            t.note = Some("no host asked for it (138): shown to none".into());
        }
        self.monitor.record(&t);
    }

    fn device_partial(&mut self, bytes: &[u8]) {
        if self.monitor.wanted() && !bytes.is_empty() {
            let mut t = Transaction::now("-", Outcome::Foreign);
            t.reply = Some(crate::monitor::Decoded {
                raw: hex(bytes),
                text: format!("{} stray bytes from the module", bytes.len()),
            });
            self.monitor.record(&t);
        }
    }
}

/// A request frame.
fn request_frame(address: u8, opcode: Opcode, kind: u8, motor: u8, value: i32) -> [u8; FRAME_LEN] {
    let mut f = [0u8; FRAME_LEN];
    f[..4].copy_from_slice(&[address, u8::from(opcode), kind, motor]);
    f[4..8].copy_from_slice(&value.to_be_bytes());
    f[8] = checksum(&f[..8]);
    f
}

/// A share running on its own thread ([`Share::spawn`]); dropping it stops it.
pub struct RunningShare {
    stopper: Stopper,
    links: Vec<LinkInfo>,
    thread: Option<std::thread::JoinHandle<Result<(), ServeError>>>,
}

impl RunningShare {
    /// Where hosts reach the module.
    pub fn links(&self) -> &[LinkInfo] {
        &self.links
    }

    /// Stops the share and waits until its links are removed.
    ///
    /// # Errors
    ///
    /// What ended the share, if not the stop (the device failed).
    pub fn stop(mut self) -> Result<(), ServeError> {
        self.finish()
    }

    fn finish(&mut self) -> Result<(), ServeError> {
        self.stopper.stop();
        match self.thread.take() {
            Some(t) => t.join().unwrap_or_else(|_| Err(ServeError::Io("the share's thread panicked".into()))),
            None => Ok(()),
        }
    }
}

impl Drop for RunningShare {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

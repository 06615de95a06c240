//! Serial ports (RS485 or RS232 adapters) and ptys, such as the link that `tmcl serve --pty LINK` creates.
//!
//! On Linux the port is the transport's own (`linux.rs`): a request costs one `write` and one `read`, as
//! the least a client can do (docs/benchmarks.md, "The pty path"). Elsewhere it is the `serialport`
//! crate's (`portable.rs`), which polls before each read and write.

use crate::error::HostError;
use crate::transport::{recv_until_deadline, Transport};
use std::io;
use std::time::Duration;

#[cfg(target_os = "linux")]
mod linux;
#[cfg(target_os = "linux")]
use linux::Port;
// Compiled on Linux too for its tests, which keep it building and behaving as the Linux port does.
#[cfg(any(not(target_os = "linux"), test))]
mod portable;
#[cfg(not(target_os = "linux"))]
use portable::Port;

/// How long one `write` may block: a 9-byte frame at 9600 baud takes under 10 ms.
const WRITE_TIMEOUT: Duration = Duration::from_secs(2);

/// How often, and how far apart, an open that finds the port locked is tried again: `tmcl serve` takes the
/// lock of its own pty for a moment now and then, to clear the exclusive flag a killed host left behind.
const OPEN_TRIES: u32 = 3;
const OPEN_RETRY: Duration = Duration::from_millis(15);

/// Why a port did not open.
#[derive(Debug)]
enum OpenError {
    /// Another program holds it: `EBUSY` from its `TIOCEXCL`, or its `flock`.
    Busy,
    /// Anything else, as the operating system said it.
    Other(io::Error),
}

/// A serial port opened 8N1, raw, without flow control, in the way pyserial opens one, but exclusively.
///
/// **Exclusive.** Two hosts on one line would read each other's replies, so the port is locked as
/// pyserial's `exclusive=True` and the `serialport` crate lock it: `TIOCEXCL` (the kernel refuses further
/// opens, except to root) and an exclusive `flock` (which other `tmcl` processes, pyserial with
/// `exclusive=True` and other flock users respect, root included). A port held by another program fails to
/// open with [`HostError::InUse`]. A program that opens the port without either (pyserial's default) is
/// not kept out when it runs as root, or when it opened the port first. The lock goes with the port:
/// when this transport is dropped or the process ends.
///
/// The modem lines are left alone, so ptys, which ignore the baud rate and reject modem-line ioctls, open
/// like real ports. Input pending at open time is discarded.
///
/// **Timeouts.** A reply is waited for as long as [`Transport::recv_exact`] is told, a `write` for room
/// 2 s at most. A line that hangs up (on a pty: the module side closed it) is an I/O error at once, not a
/// timeout. On Linux a request costs one `write` and one `read` system call (the wait is the terminal's
/// `VTIME`; see `serial/linux.rs`).
pub struct SerialTransport {
    port: Port,
    /// The path as given to [`SerialTransport::open`].
    name: String,
}

impl std::fmt::Debug for SerialTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialTransport").field("port", &self.name).finish()
    }
}

impl SerialTransport {
    /// Opens `path` (a device such as `/dev/ttyUSB0`, or a pty or a symlink to one) at `baud` bits per second.
    ///
    /// # Errors
    ///
    /// [`HostError::InUse`] when another program holds the port, [`HostError::StaleLink`] when `path` is the
    /// link of a `tmcl serve` that has exited (nothing is written to it), [`HostError::Open`] naming the path
    /// for anything else.
    pub fn open(path: &str, baud: u32) -> Result<SerialTransport, HostError> {
        check_link(std::path::Path::new(path))?;
        let mut tries = 0;
        let port = loop {
            tries += 1;
            match Port::open(path, baud) {
                Ok(port) => break port,
                Err(OpenError::Busy) => {
                    if tries < OPEN_TRIES {
                        std::thread::sleep(OPEN_RETRY);
                        continue;
                    }
                    return Err(HostError::InUse {
                        target: path.to_owned(),
                        detail: "another program has the port open exclusively (another host, perhaps another \
                                 `tmcl`); one host at a time, or the two would read each other's replies"
                            .to_owned(),
                    });
                }
                Err(OpenError::Other(source)) => return Err(HostError::Open { target: path.to_owned(), source }),
            }
        };
        let mut transport = SerialTransport { port, name: path.to_owned() };
        transport.clear_input();
        Ok(transport)
    }

    /// As [`SerialTransport::open`], but first refuses a port that another process has open, lock or no
    /// lock: pyserial (and so pytrinamic) opens ports without one, and as root `TIOCEXCL` keeps nobody out,
    /// so two hosts would read each other's replies. The server that made a `tmcl serve` link (the PID in
    /// `LINK.lock`) is not counted. On Linux only (`/proc/*/fd`); elsewhere nothing is checked.
    ///
    /// # Errors
    ///
    /// [`HostError::InUse`] naming the processes (PID and name), and those of [`SerialTransport::open`].
    pub fn open_alone(path: &str, baud: u32) -> Result<SerialTransport, HostError> {
        check_link(std::path::Path::new(path))?;
        let others = openers(std::path::Path::new(path));
        if !others.is_empty() {
            let names: Vec<String> = others.iter().map(|o| format!("PID {} ({})", o.pid, o.name)).collect();
            return Err(HostError::InUse {
                target: path.to_owned(),
                detail: format!(
                    "{} {} it open; two hosts on one line read each other's replies. Give each host a link of \
                     its own (`tmcl serve --pty A --pty B`, or `tmcl share` for a real module), or --shared to \
                     go on anyway",
                    names.join(", "),
                    if others.len() == 1 { "has" } else { "have" }
                ),
            });
        }
        SerialTransport::open(path, baud)
    }

    /// The port's name as given to [`SerialTransport::open`].
    pub fn name(&self) -> Option<String> {
        Some(self.name.clone())
    }
}

/// A process that has a port open.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Opener {
    /// Its process ID.
    pub pid: u32,
    /// Its name (`/proc/PID/comm`).
    pub name: String,
}

/// The other processes that have the device behind `path` open (Linux: `/proc/*/fd`): not this process,
/// and not the server that made the link (the PID in `LINK.lock`). Empty where `/proc` is not there, and
/// for processes whose descriptors this user may not read.
pub fn openers(path: &std::path::Path) -> Vec<Opener> {
    let Ok(device) = std::fs::canonicalize(path) else { return Vec::new() };
    let server = path
        .file_name()
        .map(|name| {
            let mut lock = name.to_os_string();
            lock.push(".lock");
            path.with_file_name(lock)
        })
        .and_then(|lock| std::fs::read_to_string(lock).ok())
        .and_then(|text| text.trim().parse::<u32>().ok());
    let me = std::process::id();
    let Ok(procs) = std::fs::read_dir("/proc") else { return Vec::new() };
    let mut found = Vec::new();
    for entry in procs.flatten() {
        let Some(pid) = entry.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else { continue };
        if pid == me || Some(pid) == server {
            continue;
        }
        let Ok(fds) = std::fs::read_dir(entry.path().join("fd")) else { continue };
        let holds = fds.flatten().any(|fd| std::fs::read_link(fd.path()).is_ok_and(|target| target == device));
        if holds {
            let name = std::fs::read_to_string(entry.path().join("comm")).unwrap_or_default().trim().to_string();
            found.push(Opener { pid, name });
        }
    }
    found
}

/// Refuses the link of a `tmcl serve` (or `tmcl share`) that has exited. The server writes its PID into `LINK.lock` beside
/// LINK and holds the file's `flock` while it runs; after a `kill -9` the link stays and may point at a
/// pseudo-terminal that another program (a terminal, an editor) has opened since. Whether the server lives
/// is asked of the process table (`/proc`), so that this check never takes the lock a starting server is
/// about to take. Without a lock file, or off Linux, nothing is checked.
pub fn check_link(path: &std::path::Path) -> Result<(), HostError> {
    if !std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        return Ok(());
    }
    let Some(name) = path.file_name() else { return Ok(()) };
    let mut lock_name = name.to_os_string();
    lock_name.push(".lock");
    let lock = path.with_file_name(lock_name);
    let Ok(text) = std::fs::read_to_string(&lock) else { return Ok(()) };
    let Ok(pid) = text.trim().parse::<u32>() else { return Ok(()) };
    if cfg!(target_os = "linux") && !std::path::Path::new("/proc").join(pid.to_string()).exists() {
        return Err(HostError::StaleLink { link: path.to_path_buf(), lock, pid });
    }
    Ok(())
}

impl Transport for SerialTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        // Not flushed (`tcdrain`): the reply is waited for anyway, and on a pty the flush is a system call
        // per request that waits for nothing (docs/benchmarks.md, "The pty path").
        self.port.write_all(bytes).map_err(hung_up)
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        let port = &mut self.port;
        recv_until_deadline(buf, timeout, |chunk, left| port.read(chunk, left).map_err(hung_up))
    }

    fn clear_input(&mut self) {
        // A port that cannot flush will fail the next read too, with a better message.
        let _ = self.port.clear_input();
    }
}

/// Words for the `BrokenPipe` the ports report when the line hangs up (`POLLHUP`, or `EIO` from a pty whose
/// other side closed): on a pty it means the module process closed its side (pyserial says "device reports
/// readiness to read but returned no data").
fn hung_up(e: io::Error) -> io::Error {
    if e.kind() == io::ErrorKind::BrokenPipe {
        io::Error::new(io::ErrorKind::BrokenPipe, "the port hung up (on a pty: the module side closed it)")
    } else {
        e
    }
}

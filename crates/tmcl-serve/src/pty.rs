//! The pseudo-terminal a virtual module serves on: the OS side of `tmcl serve --pty`.
//!
//! Host software opens the slave side through a symlink (LINK) as if it were a serial port. Facts this
//! module is built around (how pyserial, and so pytrinamic, opens and uses a port):
//! - the pty is put in raw mode **before** LINK appears, so a host that opens and writes at once never
//!   sees its bytes echoed back into the module's input;
//! - the module keeps a slave descriptor open itself, so reading the master never fails with EIO when no
//!   host has the port open, and hosts may open and close it any number of times;
//! - one server owns LINK at a time: it holds `LINK.lock` (see [`LinkLock`]), and a LINK another live
//!   server holds is refused with that server's PID;
//! - a stale LINK (a symlink left by a crash: its lock is free) is replaced atomically; anything else at LINK
//!   is refused;
//! - on exit LINK is removed only if it still points at this server's pty, and the lock file with it;
//! - hosts lock the port exclusively (`TIOCEXCL` and `flock`, see `tmcl_host::SerialTransport`); a host
//!   killed before it could undo `TIOCEXCL` would leave the pty closed to all other hosts but root's, so the
//!   server undoes it whenever no host holds the `flock` ([`Pty::release_abandoned_exclusive_mode`]);
//! - whether a host opened or closed the pty is told by the kernel (inotify on the slave device, which
//!   also reports the closes of a killed host), so these checks run when hosts come and go, and an idle
//!   server does no work for them ([`Pty::hosts_changed`]).

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::pty::openpty;
use nix::sys::inotify::{AddWatchFlags, InitFlags, Inotify};
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};
use std::fmt;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{self, Read};
use std::os::fd::{AsFd, AsRawFd};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// An open pty with its link.
#[derive(Debug)]
pub struct Pty {
    /// The master side: the module reads requests and writes replies here (non-blocking).
    pub master: File,
    /// Kept open so the master never reports EIO between hosts.
    slave: File,
    /// The slave device, e.g. /dev/pts/3.
    pub device: PathBuf,
    /// The symlink hosts open.
    pub link: PathBuf,
    /// Opens and closes of the slave device by any process (non-blocking); `None` where the kernel has no
    /// inotify for it, and then the server looks now and then instead.
    watch: Option<Inotify>,
    /// Held for as long as the pty is served; dropped after LINK is removed (fields drop after `drop`).
    _lock: LinkLock,
}

/// Why a pty could not be served at LINK.
#[derive(Debug)]
pub enum PtyError {
    /// Another live process holds LINK's lock.
    Busy {
        /// LINK.
        link: PathBuf,
        /// The lock file.
        lock: PathBuf,
        /// The PID the lock file names, and whether that process is alive.
        owner: Option<(u32, bool)>,
    },
    /// Anything else the OS refused.
    Io(io::Error),
}

impl From<io::Error> for PtyError {
    fn from(e: io::Error) -> PtyError {
        PtyError::Io(e)
    }
}

impl fmt::Display for PtyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PtyError::Busy { link, lock, owner } => {
                write!(f, "{} is already served by another `tmcl serve`", link.display())?;
                match owner {
                    Some((pid, true)) => write!(f, " (process {pid}, lock {})", lock.display())?,
                    Some((pid, false)) => {
                        write!(f, " (lock {} is held; the PID it names, {pid}, is not running)", lock.display())?
                    }
                    None => write!(f, " (lock {} is held)", lock.display())?,
                }
                write!(f, "; stop that server first, or choose another LINK")
            }
            PtyError::Io(e) => e.fmt(f),
        }
    }
}

fn errno(e: nix::Error) -> io::Error {
    io::Error::from_raw_os_error(e as i32)
}

impl Pty {
    /// Takes LINK's lock, opens a pty in raw mode and points `link` at its slave side.
    ///
    /// # Errors
    ///
    /// [`PtyError::Busy`] when another live server holds LINK, [`PtyError::Io`] for the rest (for example
    /// LINK is a regular file).
    pub fn open(link: &Path) -> Result<Pty, PtyError> {
        let lock = LinkLock::acquire(link)?;
        let pair = openpty(None, None).map_err(errno)?;
        let mut termios = tcgetattr(pair.slave.as_fd()).map_err(errno)?;
        cfmakeraw(&mut termios);
        tcsetattr(pair.slave.as_fd(), SetArg::TCSANOW, &termios).map_err(errno)?;
        let flags = fcntl(pair.master.as_raw_fd(), FcntlArg::F_GETFL).map_err(errno)?;
        fcntl(pair.master.as_raw_fd(), FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK))
            .map_err(errno)?;
        let device = nix::unistd::ttyname(pair.slave.as_fd()).map_err(errno)?;
        // Watched from before the link exists, so that no host's open goes unseen.
        let watch = Inotify::init(InitFlags::IN_NONBLOCK | InitFlags::IN_CLOEXEC).ok().filter(|i| {
            i.add_watch(
                &device,
                AddWatchFlags::IN_OPEN | AddWatchFlags::IN_CLOSE_WRITE | AddWatchFlags::IN_CLOSE_NOWRITE,
            )
            .is_ok()
        });
        replace_link(&device, link)?;
        Ok(Pty {
            master: File::from(pair.master),
            slave: File::from(pair.slave),
            device,
            link: link.to_path_buf(),
            watch,
            _lock: lock,
        })
    }

    /// The descriptor that becomes readable when a process opens or closes the slave device (to wait on
    /// beside the master); `None` when the server has to look now and then instead.
    pub fn hosts_watch(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.watch.as_ref().map(AsFd::as_fd)
    }

    /// Whether a process opened or closed the slave device since the last call (the events are consumed;
    /// the server's own opens are among them). Without a watch, always true: then every check is due.
    pub fn hosts_changed(&self) -> bool {
        let Some(watch) = &self.watch else { return true };
        let mut changed = false;
        while let Ok(events) = watch.read_events() {
            if events.is_empty() {
                break;
            }
            changed = true;
        }
        changed
    }

    /// Clears the pty's exclusive mode (`TIOCEXCL`) if no host holds the port's `flock`: a host that set
    /// both and was killed before it could clear the mode would otherwise keep every other host but root's
    /// out until the server stops. The `flock` is taken for a moment only; a host opening the port in that
    /// moment tries again (`tmcl_host::SerialTransport::open` does).
    pub fn release_abandoned_exclusive_mode(&self) {
        if self.slave.try_lock().is_ok() {
            let _ = rustix::termios::ioctl_tiocnxcl(&self.slave);
            let _ = self.slave.unlock();
        }
    }
}

/// The lock that makes one server the owner of LINK: the file `LINK.lock` beside it, holding the owner's PID,
/// with an exclusive `flock` on it. The kernel drops the `flock` when its owner exits, however it exits (kill
/// -9 too), so a held lock always means a live owner, and a LINK whose lock is free is stale.
#[derive(Debug)]
pub struct LinkLock {
    file: File,
    path: PathBuf,
}

impl LinkLock {
    /// How often taking the lock is tried when the lock file is replaced under us.
    const TRIES: usize = 10;

    /// Takes the lock of `link`.
    pub fn acquire(link: &Path) -> Result<LinkLock, PtyError> {
        let path = lock_path(link)?;
        for _ in 0..Self::TRIES {
            let mut file =
                OpenOptions::new().read(true).write(true).create(true).truncate(false).open(&path).map_err(|e| {
                    io::Error::new(e.kind(), format!("cannot open the lock file {}: {e}", path.display()))
                })?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    let mut text = String::new();
                    let _ = file.read_to_string(&mut text);
                    let owner = text.trim().parse::<u32>().ok().map(|pid| (pid, alive(pid)));
                    return Err(PtyError::Busy { link: link.to_path_buf(), lock: path, owner });
                }
                Err(TryLockError::Error(e)) => return Err(e.into()),
            }
            // The previous owner removes the file on exit, maybe between our open and our lock: then the
            // lock is on a file no one else will see. Start again on the file that is there now.
            let same = match (file.metadata(), std::fs::metadata(&path)) {
                (Ok(ours), Ok(there)) => (ours.dev(), ours.ino()) == (there.dev(), there.ino()),
                _ => false,
            };
            if !same {
                continue;
            }
            // The pid over what was there, then cut to its length: never truncated to 0 first, which on
            // ext4 makes the final close flush the file (auto_da_alloc) and slows a server's exit.
            let pid = format!("{}\n", std::process::id());
            std::os::unix::fs::FileExt::write_all_at(&file, pid.as_bytes(), 0)?;
            file.set_len(pid.len() as u64)?;
            return Ok(LinkLock { file, path });
        }
        Err(io::Error::other(format!("cannot take the lock {}: it keeps being replaced", path.display())).into())
    }
}

impl Drop for LinkLock {
    fn drop(&mut self) {
        // Remove the file only while it is still ours; the lock itself goes with the descriptor.
        let ours = match (self.file.metadata(), std::fs::metadata(&self.path)) {
            (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
            _ => false,
        };
        if ours {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// `LINK.lock`, beside LINK.
fn lock_path(link: &Path) -> io::Result<PathBuf> {
    let name = link.file_name().ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "LINK has no file name"))?;
    let mut lock = name.to_os_string();
    lock.push(".lock");
    Ok(link.with_file_name(lock))
}

/// Whether process `pid` exists (signal 0 checks without sending anything).
fn alive(pid: u32) -> bool {
    let Ok(pid) = i32::try_from(pid) else { return false };
    !matches!(nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), None), Err(nix::Error::ESRCH))
}

impl Drop for Pty {
    fn drop(&mut self) {
        // Remove LINK only if it still points at our device (another server may have replaced it).
        if std::fs::read_link(&self.link).is_ok_and(|target| target == self.device) {
            let _ = std::fs::remove_file(&self.link);
        }
    }
}

/// Makes `link` a symlink to `target`, replacing a stale symlink atomically (symlink beside it, rename).
fn replace_link(target: &Path, link: &Path) -> io::Result<()> {
    match std::fs::symlink_metadata(link) {
        Ok(meta) if !meta.file_type().is_symlink() => {
            return Err(io::Error::new(
                io::ErrorKind::AlreadyExists,
                format!("{} exists and is not a symlink; not replacing it", link.display()),
            ))
        }
        _ => {}
    }
    let name = link.file_name().ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "LINK has no file name"))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    let tmp = link.with_file_name(tmp_name);
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp)?;
    std::fs::rename(&tmp, link).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn link_points_at_a_raw_pty_and_goes_away() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("tmcl0");
        // A stale link from a crashed server is replaced.
        std::os::unix::fs::symlink("/dev/pts/does-not-exist", &link).unwrap();
        let mut pty = Pty::open(&link).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), pty.device);
        let mut host = OpenOptions::new().read(true).write(true).open(&link).unwrap();
        host.write_all(&[1, 2, 3, b'\n', b'\r', 0x03]).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(50));
        let mut buf = [0u8; 16];
        let n = pty.master.read(&mut buf).unwrap();
        assert_eq!(&buf[..n], &[1, 2, 3, b'\n', b'\r', 0x03], "raw: no translation, no signals");
        drop(host);
        // No host: the master reads WouldBlock, not EIO.
        let err = pty.master.read(&mut buf).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::WouldBlock);
        drop(pty);
        assert!(std::fs::symlink_metadata(&link).is_err());
        assert!(!dir.path().join("tmcl0.lock").exists(), "the lock file goes with the server");
    }

    #[test]
    fn a_held_link_is_refused_with_the_owner_pid() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("tmcl0");
        let first = Pty::open(&link).unwrap();
        let lock = std::fs::read_to_string(dir.path().join("tmcl0.lock")).unwrap();
        assert_eq!(lock.trim(), std::process::id().to_string());
        let err = Pty::open(&link).unwrap_err();
        assert!(matches!(&err, PtyError::Busy { owner: Some((pid, true)), .. } if *pid == std::process::id()));
        let text = err.to_string();
        assert!(text.contains(&format!("process {}", std::process::id())), "{text}");
        // The first server still owns its link.
        assert_eq!(std::fs::read_link(&link).unwrap(), first.device);
        drop(first);
        let again = Pty::open(&link).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), again.device);
    }

    #[test]
    fn a_stale_lock_file_is_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("tmcl0");
        // What kill -9 leaves: a link to a pty that is gone, a lock file naming a dead process, no flock.
        std::os::unix::fs::symlink("/dev/pts/does-not-exist", &link).unwrap();
        std::fs::write(dir.path().join("tmcl0.lock"), "999999999\n").unwrap();
        let pty = Pty::open(&link).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), pty.device);
    }

    #[test]
    fn link_replaced_by_someone_else_is_left_alone() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("tmcl0");
        let pty = Pty::open(&link).unwrap();
        std::fs::remove_file(&link).unwrap();
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        drop(pty);
        assert_eq!(std::fs::read_link(&link).unwrap(), Path::new("/dev/null"));
    }

    #[test]
    fn refuses_to_replace_a_regular_file() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("file");
        std::fs::write(&link, b"keep me").unwrap();
        assert!(Pty::open(&link).is_err());
        assert_eq!(std::fs::read(&link).unwrap(), b"keep me");
    }
}

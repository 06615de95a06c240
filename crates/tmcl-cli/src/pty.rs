//! The pseudo-terminal a virtual module serves on: the OS side of `tmcl serve --pty`.
//!
//! Host software opens the slave side through a symlink (LINK) as if it were a serial port. Facts this
//! module is built around (how pyserial, and so pytrinamic, opens and uses a port):
//! - the pty is put in raw mode **before** LINK appears, so a host that opens and writes at once never
//!   sees its bytes echoed back into the module's input;
//! - the module keeps a slave descriptor open itself, so reading the master never fails with EIO when no
//!   host has the port open, and hosts may open and close it any number of times;
//! - a stale LINK (a symlink left by a crash) is replaced atomically; anything else at LINK is refused.

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::pty::openpty;
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};
use std::fs::File;
use std::io;
use std::os::fd::{AsFd, AsRawFd, OwnedFd};
use std::path::{Path, PathBuf};

/// An open pty with its link.
#[derive(Debug)]
pub struct Pty {
    /// The master side: the module reads requests and writes replies here (non-blocking).
    pub master: File,
    /// Kept open so the master never reports EIO between hosts.
    _slave: OwnedFd,
    /// The slave device, e.g. /dev/pts/3.
    pub device: PathBuf,
    /// The symlink hosts open.
    pub link: PathBuf,
}

fn errno(e: nix::Error) -> io::Error {
    io::Error::from_raw_os_error(e as i32)
}

impl Pty {
    /// Opens a pty in raw mode and points `link` at its slave side.
    pub fn open(link: &Path) -> io::Result<Pty> {
        let pair = openpty(None, None).map_err(errno)?;
        let mut termios = tcgetattr(pair.slave.as_fd()).map_err(errno)?;
        cfmakeraw(&mut termios);
        tcsetattr(pair.slave.as_fd(), SetArg::TCSANOW, &termios).map_err(errno)?;
        let flags = fcntl(pair.master.as_raw_fd(), FcntlArg::F_GETFL).map_err(errno)?;
        fcntl(pair.master.as_raw_fd(), FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK))
            .map_err(errno)?;
        let device = nix::unistd::ttyname(pair.slave.as_fd()).map_err(errno)?;
        replace_link(&device, link)?;
        Ok(Pty { master: File::from(pair.master), _slave: pair.slave, device, link: link.to_path_buf() })
    }
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
    use std::io::{Read, Write};

    #[test]
    fn link_points_at_a_raw_pty_and_goes_away() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("tmcl0");
        // A stale link from a crashed server is replaced.
        std::os::unix::fs::symlink("/dev/pts/does-not-exist", &link).unwrap();
        let mut pty = Pty::open(&link).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), pty.device);
        let mut host = std::fs::OpenOptions::new().read(true).write(true).open(&link).unwrap();
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

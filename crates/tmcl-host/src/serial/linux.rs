//! The port on Linux: the transport's own tty reads and writes, so that a request costs one `write` and one
//! `read`, the system calls a minimal C client makes (docs/benchmarks.md, "The pty path").
//!
//! - **Reads** wait in the terminal itself: the port is in raw mode with `VMIN` 0 and a `VTIME`, so a
//!   blocking `read` returns what has arrived, or nothing once `VTIME` tenths of a second have passed
//!   (termios(3), "MIN == 0, TIME > 0"). The `VTIME` in force is kept while it still fits the time left
//!   ([`vtime`]), so request after request reads without setting it again; a read that gives up before the
//!   deadline is followed by another, and the last tenth is waited for in `poll`.
//! - **Writes** go to a second, non-blocking open file description of the same device (`O_NONBLOCK` is the
//!   description's, and `VTIME` needs a blocking one): a frame the terminal has room for is one `write`;
//!   only when it is full does the write wait in `poll`, [`WRITE_TIMEOUT`] at most.
//! - **Hang-up.** A hung-up terminal (a pty whose module side closed, an adapter unplugged) reads `EIO`, or
//!   0 bytes at once and every time; a read that returns 0 bytes asks `poll` whether the line hung up
//!   (`POLLHUP`) before it is taken for a `VTIME` that ran out, so a hang-up is reported, never waited out.
//!
//! All of it is safe code: the device is opened with `std::fs` (so the descriptors are owned `File`s, and
//! `rustix` borrows them), not taken from the `serialport` crate, which hands out only a raw descriptor
//! (docs/decisions.md, "The serial transport").

use super::{OpenError, WRITE_TIMEOUT};
use rustix::event::{poll, PollFd, PollFlags, Timespec};
use rustix::fs::OFlags;
use rustix::io::Errno;
use rustix::termios::{self, ControlModes, InputModes, OptionalActions, QueueSelector, SpecialCodeIndex, Termios};
use std::fs::{File, OpenOptions, TryLockError};
use std::io;
use std::os::unix::fs::OpenOptionsExt;
use std::time::{Duration, Instant};

/// An open port: 8N1, raw, no flow control, exclusive (`flock`, then `TIOCEXCL`, undone on drop).
pub(super) struct Port {
    /// Blocking, `VMIN` 0 and `VTIME` as in `termios`; holds the `flock`.
    reader: File,
    /// The same device opened again, non-blocking, for writes.
    writer: File,
    /// The terminal's settings as last set: its `VTIME` is the one in force.
    termios: Termios,
}

impl Drop for Port {
    fn drop(&mut self) {
        // The kernel keeps `TIOCEXCL` after the last close of a pty; the `flock` goes with the descriptor.
        let _ = termios::ioctl_tiocnxcl(&self.reader);
    }
}

/// The `VTIME` to wait for at most `left` with, in tenths of a second, from the one in force (`current`):
/// `current` as long as it ends no later than `left` and at most two tenths sooner; else the whole tenths
/// in `left` (at most 255, 25.5 s). `None` when less than a tenth is left: that wait is `poll`'s.
fn vtime(current: u8, left: Duration) -> Option<u8> {
    let tenths = u8::try_from(left.as_millis() / 100).unwrap_or(u8::MAX);
    if tenths == 0 {
        None
    } else if current != 0 && current <= tenths && tenths - current <= 1 {
        Some(current)
    } else {
        Some(tenths)
    }
}

/// The error for a line that hung up: a `BrokenPipe`, which the transport puts in words.
fn hang_up() -> io::Error {
    io::Error::new(io::ErrorKind::BrokenPipe, "the port hung up")
}

/// An error of the tty: `EIO` is a hang-up (a pty whose other side closed), the rest as they are.
fn tty_error(e: Errno) -> io::Error {
    if e == Errno::IO {
        hang_up()
    } else {
        e.into()
    }
}

impl Port {
    /// Opens `path` at `baud`, discarding nothing yet (the transport clears the input). The device is
    /// opened non-blocking (a real port without carrier would block the open), then the reader is made
    /// blocking once `CLOCAL` is set.
    pub(super) fn open(path: &str, baud: u32) -> Result<Port, OpenError> {
        let open = || {
            let flags = (OFlags::NOCTTY | OFlags::NONBLOCK).bits();
            OpenOptions::new()
                .read(true)
                .write(true)
                .custom_flags(i32::try_from(flags).expect("open flags fit an int"))
                .open(path)
                .map_err(|e| {
                    // EBUSY: the terminal is in another program's exclusive mode (`TIOCEXCL`).
                    if e.raw_os_error() == Some(Errno::BUSY.raw_os_error()) {
                        OpenError::Busy
                    } else {
                        OpenError::Other(e)
                    }
                })
        };
        let reader = open()?;
        match reader.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => return Err(OpenError::Busy),
            Err(TryLockError::Error(e)) => return Err(OpenError::Other(e)),
        }
        // Before `TIOCEXCL`, which refuses this second open too.
        let writer = open()?;
        let other = |e: Errno| OpenError::Other(e.into());
        let termios = termios::tcgetattr(&reader).map_err(other)?;
        let mut port = Port { reader, writer, termios };
        // From here on a failure drops `port`, which undoes this.
        termios::ioctl_tiocexcl(&port.reader).map_err(other)?;
        let t = &mut port.termios;
        t.make_raw();
        t.control_modes |= ControlModes::CREAD | ControlModes::CLOCAL | ControlModes::CS8;
        t.control_modes -= ControlModes::CSTOPB | ControlModes::PARENB | ControlModes::PARODD | ControlModes::CRTSCTS;
        t.input_modes -= InputModes::IXON | InputModes::IXOFF | InputModes::INPCK;
        t.input_modes |= InputModes::IGNPAR;
        t.set_speed(baud).map_err(other)?;
        t.special_codes[SpecialCodeIndex::VMIN] = 0;
        t.special_codes[SpecialCodeIndex::VTIME] = 0;
        termios::tcsetattr(&port.reader, OptionalActions::Now, &port.termios).map_err(other)?;
        rustix::io::ioctl_fionbio(&port.reader, false).map_err(other)?;
        Ok(port)
    }

    /// Writes all of `bytes`; when the terminal has no room, waits for it [`WRITE_TIMEOUT`] at most in all.
    pub(super) fn write_all(&mut self, mut bytes: &[u8]) -> io::Result<()> {
        let mut deadline = None;
        while !bytes.is_empty() {
            match rustix::io::write(&self.writer, bytes) {
                Ok(n) if n > 0 => bytes = &bytes[n..],
                Ok(_) | Err(Errno::AGAIN) => {
                    let deadline = *deadline.get_or_insert_with(|| Instant::now() + WRITE_TIMEOUT);
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        return Err(io::Error::new(
                            io::ErrorKind::TimedOut,
                            format!("the port took no bytes for {} s", WRITE_TIMEOUT.as_secs()),
                        ));
                    }
                    if wait(&self.writer, PollFlags::OUT, left)?.intersects(PollFlags::HUP | PollFlags::ERR) {
                        return Err(hang_up());
                    }
                }
                Err(Errno::INTR) => {}
                Err(e) => return Err(tty_error(e)),
            }
        }
        Ok(())
    }

    /// Reads what has arrived, waiting at most about `left` for the first byte: `TimedOut` when none came
    /// (perhaps sooner, by up to two tenths: the caller reads again), `BrokenPipe` when the line hung up.
    pub(super) fn read(&mut self, chunk: &mut [u8], left: Duration) -> io::Result<usize> {
        let Some(tenths) = vtime(self.termios.special_codes[SpecialCodeIndex::VTIME], left) else {
            return self.read_after_poll(chunk, left);
        };
        if tenths != self.termios.special_codes[SpecialCodeIndex::VTIME] {
            self.termios.special_codes[SpecialCodeIndex::VTIME] = tenths;
            termios::tcsetattr(&self.reader, OptionalActions::Now, &self.termios)?;
        }
        match rustix::io::read(&self.reader, &mut *chunk) {
            Ok(0) => {
                // `VTIME` ran out, or the line hung up (then every read returns 0 at once).
                if wait(&self.reader, PollFlags::IN, Duration::ZERO)?.intersects(PollFlags::HUP | PollFlags::ERR) {
                    Err(hang_up())
                } else {
                    Err(io::Error::new(io::ErrorKind::TimedOut, "no byte within VTIME"))
                }
            }
            Ok(n) => Ok(n),
            Err(e) => Err(tty_error(e)),
        }
    }

    /// A read for less than a tenth of a second: `poll` waits, then the read takes what has arrived.
    fn read_after_poll(&mut self, chunk: &mut [u8], left: Duration) -> io::Result<usize> {
        let ready = wait(&self.reader, PollFlags::IN, left)?;
        if ready.is_empty() {
            return Err(io::Error::new(io::ErrorKind::TimedOut, "no byte in time"));
        }
        if !ready.contains(PollFlags::IN) {
            return Err(hang_up());
        }
        match rustix::io::read(&self.reader, &mut *chunk) {
            // Ready, and nothing to read: hung up.
            Ok(0) => Err(hang_up()),
            Ok(n) => Ok(n),
            Err(e) => Err(tty_error(e)),
        }
    }

    /// Discards the input that has arrived and not been read.
    pub(super) fn clear_input(&mut self) -> io::Result<()> {
        Ok(termios::tcflush(&self.reader, QueueSelector::IFlush)?)
    }
}

/// Waits in `poll` at most `timeout` for `events` on `file`: what it reported (empty when the time ran
/// out; an interrupted wait reports nothing either, and the caller's loop goes on).
fn wait(file: &File, events: PollFlags, timeout: Duration) -> io::Result<PollFlags> {
    let mut fds = [PollFd::new(file, events)];
    let timeout = Timespec::try_from(timeout).unwrap_or(Timespec { tv_sec: i64::MAX, tv_nsec: 0 });
    match poll(&mut fds, Some(&timeout)) {
        Ok(_) => Ok(fds[0].revents()),
        Err(Errno::INTR) => Ok(PollFlags::empty()),
        Err(e) => Err(e.into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vtime_is_kept_while_it_fits_the_time_left() {
        let ms = Duration::from_millis;
        // The first read sets the whole tenths left; the next requests, each with a little less time left,
        // keep it.
        assert_eq!(vtime(0, ms(5000) - Duration::from_micros(3)), Some(49));
        assert_eq!(vtime(49, ms(4999)), Some(49));
        assert_eq!(vtime(49, ms(4900)), Some(49));
        assert_eq!(vtime(49, ms(5050)), Some(49));
        assert_eq!(vtime(49, ms(5099)), Some(49));
        // Never later than the time left, never more than two tenths sooner.
        assert_eq!(vtime(49, ms(4899)), Some(48));
        assert_eq!(vtime(49, ms(5100)), Some(51));
        // The rest of a wait that ended early.
        assert_eq!(vtime(49, ms(130)), Some(1));
        // Less than a tenth: poll's.
        assert_eq!(vtime(1, ms(99)), None);
        assert_eq!(vtime(0, Duration::ZERO), None);
        // Longer than VTIME can say: 25.5 s, and read again.
        assert_eq!(vtime(0, Duration::from_secs(60)), Some(255));
        assert_eq!(vtime(255, Duration::from_secs(60)), Some(255));
    }
}

//! The port on other systems than Linux: the `serialport` crate's, which polls before every read and
//! every write (`ppoll`), with its timeout set before each. Built on Linux for the tests only.

use super::{OpenError, WRITE_TIMEOUT};
use serialport::{ClearBuffer, SerialPort};
use std::io::{self, Read, Write};
use std::time::Duration;

/// An open port: 8N1, raw, no flow control, exclusive (`TIOCEXCL` and `flock` where there are such).
pub(super) struct Port {
    port: Box<dyn SerialPort>,
}

impl Port {
    /// Opens `path` at `baud`, discarding nothing yet (the transport clears the input).
    pub(super) fn open(path: &str, baud: u32) -> Result<Port, OpenError> {
        let builder = serialport::new(path, baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .exclusive(true)
            .timeout(WRITE_TIMEOUT);
        match builder.open() {
            Ok(port) => Ok(Port { port }),
            // EBUSY from TIOCEXCL or EWOULDBLOCK from flock: another program has the port.
            Err(e) if e.kind() == serialport::ErrorKind::NoDevice => Err(OpenError::Busy),
            Err(e) => Err(OpenError::Other(e.into())),
        }
    }

    /// Writes all of `bytes`, each `write` waiting at most [`WRITE_TIMEOUT`] for room; a hang-up is a
    /// `BrokenPipe` (`serialport`'s word for `POLLHUP`).
    pub(super) fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.set_timeout(WRITE_TIMEOUT).map_err(io::Error::from)?;
        self.port.write_all(bytes)
    }

    /// Reads what has arrived, waiting at most `left` for the first byte (`TimedOut` when none came).
    pub(super) fn read(&mut self, chunk: &mut [u8], left: Duration) -> io::Result<usize> {
        self.port.set_timeout(left).map_err(io::Error::from)?;
        self.port.read(chunk)
    }

    /// Discards the input that has arrived and not been read.
    pub(super) fn clear_input(&mut self) -> io::Result<()> {
        self.port.clear(ClearBuffer::Input).map_err(io::Error::from)
    }
}

/// The same behaviour as the Linux port's (tests/transports.rs), on a pty: a round trip, stale input
/// cleared, a timeout, a hang-up as a `BrokenPipe`, a second opener refused.
#[cfg(test)]
mod tests {
    use super::*;
    use std::fs::File;

    #[test]
    fn round_trip_timeout_hang_up_and_exclusive_open() {
        let pty = nix::pty::openpty(None, None).unwrap();
        let path = nix::unistd::ttyname(&pty.slave).unwrap();
        let path = path.to_str().unwrap();
        let mut master = File::from(pty.master);
        let mut port = Port::open(path, 9600).unwrap();
        assert!(matches!(Port::open(path, 9600), Err(OpenError::Busy)));

        port.write_all(b"request!!").unwrap();
        let mut got = [0u8; 9];
        master.read_exact(&mut got).unwrap();
        master.write_all(b"reply!!!!").unwrap();
        let mut n = 0;
        while n < got.len() {
            n += port.read(&mut got[n..], Duration::from_secs(5)).unwrap();
        }
        assert_eq!(&got, b"reply!!!!");

        master.write_all(b"stale").unwrap();
        std::thread::sleep(Duration::from_millis(20));
        port.clear_input().unwrap();
        let err = port.read(&mut got, Duration::from_millis(50)).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::TimedOut, "{err}");

        drop(master);
        drop(pty.slave);
        let err = port.read(&mut got, Duration::from_secs(5)).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::BrokenPipe, "{err}");
    }
}

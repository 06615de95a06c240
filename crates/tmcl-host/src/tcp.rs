//! TCP connections, as served by `tmcl serve --tcp` or a serial-to-Ethernet bridge.

use crate::error::HostError;
use crate::transport::{recv_until_deadline, Transport};
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// How long connecting and one `write` may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// A TCP connection carrying the same 9-byte frames as a serial line (pytrinamic's `socket_serial_tmcl`).
///
/// Unlike pytrinamic's socket interface, every read has a timeout.
#[derive(Debug)]
pub struct TcpTransport {
    stream: TcpStream,
}

impl TcpTransport {
    /// Connects to `addr`, `host:port` (a name or an IPv4/IPv6 literal; `[::1]:port` for IPv6).
    ///
    /// # Errors
    ///
    /// [`HostError::Open`] naming the address.
    pub fn connect(addr: &str) -> Result<TcpTransport, HostError> {
        let open_error = |source: io::Error| HostError::Open { target: addr.to_owned(), source };
        let mut last = io::Error::new(io::ErrorKind::InvalidInput, "the address resolves to nothing");
        for candidate in addr.to_socket_addrs().map_err(open_error)? {
            match TcpStream::connect_timeout(&candidate, CONNECT_TIMEOUT) {
                Ok(stream) => return TcpTransport::from_stream(stream).map_err(open_error),
                Err(e) => last = e,
            }
        }
        Err(open_error(last))
    }

    /// Wraps a connected stream (for tests and for callers that connect themselves).
    pub fn from_stream(stream: TcpStream) -> io::Result<TcpTransport> {
        stream.set_nodelay(true)?;
        stream.set_write_timeout(Some(CONNECT_TIMEOUT))?;
        Ok(TcpTransport { stream })
    }
}

impl Transport for TcpTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes)
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        let stream = &mut self.stream;
        recv_until_deadline(buf, timeout, |chunk, left| {
            stream.set_read_timeout(Some(left))?;
            stream.read(chunk)
        })
    }

    fn clear_input(&mut self) {
        if self.stream.set_nonblocking(true).is_err() {
            return;
        }
        let mut scratch = [0u8; 256];
        while matches!(self.stream.read(&mut scratch), Ok(n) if n > 0) {}
        let _ = self.stream.set_nonblocking(false);
    }
}

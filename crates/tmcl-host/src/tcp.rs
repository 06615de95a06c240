//! TCP connections, as served by `tmcl serve --tcp` or a serial-to-Ethernet bridge.

use crate::error::HostError;
use crate::transport::{recv_until_deadline, Transport};
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// What a server that closes the connection before answering anything means.
const TURNED_AWAY: &str = "the server closed the connection without answering: its TCP port is already in use \
                           by another client (`tmcl serve --tcp` serves one client at a time)";

/// How long connecting and one `write` may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// A TCP connection carrying the same 9-byte frames as a serial line (pytrinamic's `socket_serial_tmcl`).
///
/// Unlike pytrinamic's socket interface, every read has a timeout. A server that closes the connection
/// before sending a single byte is taken to be busy with another client ([`HostError::InUse`]): that is how
/// `tmcl serve --tcp` turns away a second client.
#[derive(Debug)]
pub struct TcpTransport {
    stream: TcpStream,
    /// The address as given, for messages.
    target: String,
    /// Whether any byte has arrived on this connection.
    heard: bool,
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
                Ok(stream) => {
                    let mut transport = TcpTransport::from_stream(stream).map_err(open_error)?;
                    transport.target = addr.to_owned();
                    return Ok(transport);
                }
                Err(e) => last = e,
            }
        }
        Err(open_error(last))
    }

    /// Wraps a connected stream (for tests and for callers that connect themselves).
    pub fn from_stream(stream: TcpStream) -> io::Result<TcpTransport> {
        stream.set_nodelay(true)?;
        stream.set_write_timeout(Some(CONNECT_TIMEOUT))?;
        let target = stream.peer_addr().map(|a| a.to_string()).unwrap_or_else(|_| "the TCP server".to_owned());
        Ok(TcpTransport { stream, target, heard: false })
    }

    /// The error for a connection the server closed (or reset) before sending anything.
    fn turned_away(&self) -> HostError {
        HostError::InUse { target: self.target.clone(), detail: TURNED_AWAY.to_owned() }
    }
}

/// Whether `kind` means the peer closed or reset the connection.
fn closed(kind: io::ErrorKind) -> bool {
    matches!(
        kind,
        io::ErrorKind::UnexpectedEof
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::BrokenPipe
    )
}

impl Transport for TcpTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes).map_err(|e| {
            if !self.heard && closed(e.kind()) {
                io::Error::new(e.kind(), format!("{} is in use: {TURNED_AWAY}", self.target))
            } else {
                e
            }
        })
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        let stream = &mut self.stream;
        let mut got = 0;
        let result = recv_until_deadline(buf, timeout, |chunk, left| {
            stream.set_read_timeout(Some(left))?;
            let n = stream.read(chunk)?;
            got += n;
            Ok(n)
        });
        self.heard |= got > 0;
        match result {
            Err(HostError::Io(e)) if !self.heard && closed(e.kind()) => Err(self.turned_away()),
            other => other,
        }
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

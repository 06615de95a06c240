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
    /// The read timeout the socket has now: set again only when a read must end sooner (see
    /// [`read_timeout`]), not before every read.
    read_timeout: Option<Duration>,
}

/// The read timeout to wait at most `left` with, from the one the socket has (`current`): `current` as long
/// as it ends no later than `left` and not more than [`TIMEOUT_SLACK`] sooner; else a new one half the slack
/// short of `left` (or `left` itself when that is shorter than half the slack), so that request after
/// request, each with a little less time left than the one before, reads without setting it again (a system
/// call each).
fn read_timeout(current: Option<Duration>, left: Duration) -> Duration {
    match current {
        Some(t) if t <= left && left - t <= TIMEOUT_SLACK => t,
        _ if left > TIMEOUT_SLACK / 2 => left - TIMEOUT_SLACK / 2,
        _ => left,
    }
}

/// How much sooner than asked a read may give up: it ends the wait early, and the caller waits on for
/// the rest (see `recv_until_deadline`).
const TIMEOUT_SLACK: Duration = Duration::from_millis(100);

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
        Ok(TcpTransport { stream, target, heard: false, read_timeout: None })
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
        let (stream, current) = (&mut self.stream, &mut self.read_timeout);
        let mut got = 0;
        let result = recv_until_deadline(buf, timeout, |chunk, left| {
            let wanted = read_timeout(*current, left);
            if *current != Some(wanted) {
                stream.set_read_timeout(Some(wanted))?;
                *current = Some(wanted);
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_read_timeout_is_kept_while_it_ends_in_time() {
        let ms = Duration::from_millis;
        // The first read sets it half the slack short; the next requests, each with a little less time
        // left, keep it.
        assert_eq!(read_timeout(None, ms(5000)), ms(4950));
        assert_eq!(read_timeout(Some(ms(4950)), ms(4999)), ms(4950));
        assert_eq!(read_timeout(Some(ms(4950)), ms(4951)), ms(4950));
        assert_eq!(read_timeout(Some(ms(4950)), ms(5050)), ms(4950));
        // Never later than asked, never more than the slack sooner.
        assert_eq!(read_timeout(Some(ms(4950)), ms(4900)), ms(4850));
        assert_eq!(read_timeout(Some(ms(4950)), ms(5100)), ms(5050));
        // The rest of a wait that ended early, and short waits: exactly what is left.
        assert_eq!(read_timeout(Some(ms(4950)), ms(30)), ms(30));
        assert_eq!(read_timeout(None, ms(1)), ms(1));
    }
}

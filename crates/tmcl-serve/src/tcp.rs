//! The TCP link: listening, and one client at a time.

use crate::ServeError;
use std::io;
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use tmcl_core::Instant;

/// Listens on `HOST:PORT` or a bare `PORT` (on 127.0.0.1). HOST may be a name, resolved as the host side
/// resolves it (`localhost:2324`); of the addresses it resolves to, IPv4 ones are tried first, so that
/// `localhost` means 127.0.0.1 as for most clients. An address another program listens on is not skipped
/// for the next one: it is reported.
pub(crate) fn listen(text: &str) -> Result<TcpListener, ServeError> {
    let mut candidates: Vec<SocketAddr> = match text.parse::<u16>() {
        Ok(port) => vec![SocketAddr::from(([127, 0, 0, 1], port))],
        Err(_) => text
            .to_socket_addrs()
            .map_err(|e| {
                ServeError::Config(format!(
                    "`{text}` is not HOST:PORT (e.g. localhost:2323, 127.0.0.1:2323) or a port: {e}"
                ))
            })?
            .collect(),
    };
    candidates.sort_by_key(SocketAddr::is_ipv6);
    let mut last = None;
    for addr in candidates {
        match TcpListener::bind(addr) {
            Ok(listener) => return Ok(listener),
            Err(e) if e.kind() == io::ErrorKind::AddrInUse => {
                return Err(ServeError::Io(format!("cannot listen on {addr}: another program listens there ({e})")))
            }
            Err(e) => last = Some(format!("cannot listen on {addr}: {e}")),
        }
    }
    Err(ServeError::Io(last.unwrap_or_else(|| format!("`{text}` resolves to no address"))))
}

/// Takes the connections waiting on the listener. The first becomes the client when there is none (or the
/// one there has gone); any other is closed at once without a byte: one client at a time, as one host on a
/// serial line (a second client would read the first one's replies). See docs/decisions.md.
///
/// While the client has unread bytes, new connections wait: those bytes may end in the client's close, and
/// the next connection is then the next client, not a second one.
pub(crate) fn accept_clients(
    listener: &TcpListener,
    peer: &mut Option<TcpStream>,
    reset: &mut dyn FnMut(),
    verbose: bool,
    now: Instant,
) {
    loop {
        if let Some(stream) = peer.as_mut() {
            match peer_state(stream) {
                PeerState::Idle => {}
                PeerState::Sending => return,
                PeerState::Closed => {
                    if verbose {
                        tracing::info!("[{now}] connection closed");
                    }
                    *peer = None;
                    reset();
                }
            }
        }
        let Ok((stream, from)) = listener.accept() else { return };
        if peer.is_some() {
            if verbose {
                tracing::warn!("[{now}] connection from {from} turned away: another client is connected");
            }
            drop(stream);
            continue;
        }
        let _ = stream.set_nonblocking(true);
        let _ = stream.set_nodelay(true);
        if verbose {
            tracing::info!("[{now}] connection from {from}");
        }
        *peer = Some(stream);
        // A partial frame of the previous connection must not join this one's.
        reset();
    }
}

/// What a connected client is doing, as far as the socket tells without reading.
enum PeerState {
    /// Connected, nothing unread.
    Idle,
    /// Bytes are waiting to be read.
    Sending,
    /// Closed or failed.
    Closed,
}

fn peer_state(stream: &mut TcpStream) -> PeerState {
    let mut probe = [0u8; 1];
    match stream.peek(&mut probe) {
        Ok(0) => PeerState::Closed,
        Ok(_) => PeerState::Sending,
        Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => PeerState::Idle,
        Err(_) => PeerState::Closed,
    }
}

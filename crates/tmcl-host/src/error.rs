//! What can go wrong between a host and a module.

use std::io;
use std::time::Duration;
use tmcl_wire::{Hex, Opcode, Reply, Status, FRAME_LEN};

/// An error from a [`Transport`](crate::Transport) or a [`Client`](crate::Client) call.
///
/// Three kinds, told apart by [`HostError::is_status_error`], [`HostError::is_bad_reply`] and
/// [`HostError::is_no_reply`] (`tmcl` turns them into the exit codes 1, 4 and 3):
///
/// - the module's own answer says no: [`HostError::Status`] (PD28-1021 TMCL manual §3.2.1, Table 4: status
///   codes below 100 are errors);
/// - something arrived that is not a usable answer to the request: a damaged reply
///   ([`HostError::Checksum`], [`HostError::BadVersionString`]) or a reply to another request
///   ([`HostError::Foreign`]: a late reply, or another host's traffic);
/// - nothing usable arrived: [`HostError::Open`], [`HostError::InUse`], [`HostError::Io`],
///   [`HostError::Timeout`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HostError {
    /// Opening the serial port or connecting to the TCP address failed.
    #[error("cannot open {target}: {source}")]
    Open {
        /// The port path or TCP address.
        target: String,
        /// What the operating system said.
        #[source]
        source: io::Error,
    },
    /// The serial port or pty is held exclusively by another program, or the TCP server closed the
    /// connection before answering anything because it serves another client.
    #[error("{target} is in use: {detail}")]
    InUse {
        /// The port path or TCP address.
        target: String,
        /// Who holds it and what to do, in words.
        detail: String,
    },
    /// The port is the link of a `tmcl serve` that has exited (its `LINK.lock` names a process that is gone):
    /// the link may point at a pseudo-terminal another program has since opened, so nothing was written.
    #[error(
        "{} is left from a `tmcl serve` that has exited: the server that made this link (PID {pid}) has \
         exited; nothing was written to it (it may point at another program's terminal now). Start the \
         server again, or remove {} and {}",
        link.display(), link.display(), lock.display()
    )]
    StaleLink {
        /// The link.
        link: std::path::PathBuf,
        /// Its lock file.
        lock: std::path::PathBuf,
        /// The PID the lock file names.
        pid: u32,
    },
    /// Reading or writing failed, or the other side closed the connection.
    #[error("I/O error: {0}")]
    Io(#[from] io::Error),
    /// Fewer than nine bytes arrived before the timeout.
    #[error("no reply from the module within {} s ({received} of {FRAME_LEN} bytes received)", waited.as_secs_f64())]
    Timeout {
        /// How long the host waited.
        waited: Duration,
        /// How many bytes of the frame had arrived.
        received: usize,
    },
    /// The reply's checksum byte is not the 8-bit sum of its first eight bytes (§3.2).
    #[error("reply checksum is wrong: expected {expected:#04x}, found {found:#04x} (reply {})", Hex(frame))]
    Checksum {
        /// The sum of bytes 0..8.
        expected: u8,
        /// Byte 8 as received.
        found: u8,
        /// The whole reply as received.
        frame: [u8; FRAME_LEN],
    },
    /// The module answered with an error status (below 100, §3.2.1 Table 4).
    #[error("module answered status {status}")]
    Status {
        /// The status code.
        status: Status,
        /// The whole reply; its value is usually 0 or the echoed command value.
        reply: Reply,
    },
    /// No reply answered the request, but a reply to another request did arrive: its module address or
    /// command number differs from the request's (§3.2, Table 3). It is a late reply to an earlier request
    /// (one that timed out, perhaps in another process), or another host's traffic on the line. The first
    /// such reply is kept here; it was never taken as the answer.
    #[error(
        "no answer to {} to module {address}; a reply to another request came instead: module {}, command {}, \
         status {}, value {} (reply {}): a late reply to an earlier request, or another host on the line",
        Opcode::from(*opcode), reply.module, Opcode::from(reply.opcode), reply.status, reply.value, Hex(&reply.to_bytes())
    )]
    Foreign {
        /// The module address the request went to.
        address: u8,
        /// The request's command number.
        opcode: u8,
        /// The reply that arrived instead.
        reply: Reply,
    },
    /// The answer to command 136 type 0 is not a host address followed by eight printable ASCII characters.
    #[error("the version reply is not eight ASCII characters (reply {})", Hex(frame))]
    BadVersionString {
        /// The nine bytes received.
        frame: [u8; FRAME_LEN],
    },
}

impl HostError {
    /// Whether something arrived in reply: `true` for an error status ([`HostError::is_status_error`]) and for
    /// a damaged, late or foreign reply ([`HostError::is_bad_reply`]); `false` when nothing usable arrived
    /// ([`HostError::is_no_reply`]).
    pub fn is_reply_error(&self) -> bool {
        self.is_status_error() || self.is_bad_reply()
    }

    /// Whether the module answered the request with an error status ([`HostError::Status`]).
    pub fn is_status_error(&self) -> bool {
        matches!(self, HostError::Status { .. })
    }

    /// Whether the bytes that arrived are no answer to the request: a damaged reply ([`HostError::Checksum`],
    /// [`HostError::BadVersionString`]) or a reply to another request ([`HostError::Foreign`]).
    pub fn is_bad_reply(&self) -> bool {
        matches!(self, HostError::Checksum { .. } | HostError::BadVersionString { .. } | HostError::Foreign { .. })
    }

    /// Whether nothing usable arrived: the port could not be opened or is in use, the connection failed, or
    /// no (whole) reply came in time.
    pub fn is_no_reply(&self) -> bool {
        !self.is_reply_error()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_in_plain_words() {
        let reply = Reply { host: 2, module: 1, status: Status::InvalidValue, opcode: 5, value: 0 };
        let err = HostError::Status { status: Status::InvalidValue, reply };
        assert_eq!(err.to_string(), "module answered status 4 (invalid value)");
        let err = HostError::Timeout { waited: Duration::from_millis(1500), received: 3 };
        assert_eq!(err.to_string(), "no reply from the module within 1.5 s (3 of 9 bytes received)");
        let err = HostError::Checksum { expected: 0xA5, found: 0, frame: [2, 1, 100, 15, 0, 0, 1, 46, 0] };
        assert_eq!(
            err.to_string(),
            "reply checksum is wrong: expected 0xa5, found 0x00 (reply 02 01 64 0F 00 00 01 2E 00)"
        );
    }
}

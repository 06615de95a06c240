//! What can go wrong between a host and a module.

use std::io;
use std::time::Duration;
use tmcl_wire::{Reply, Status, FRAME_LEN};

/// An error from a [`Transport`](crate::Transport) or a [`Client`](crate::Client) call.
///
/// [`HostError::Status`] is the module's own answer (PD28-1021 TMCL manual §3.2.1, Table 4: status codes below
/// 100 are errors); the other variants mean that no usable answer arrived.
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
    #[error("reply checksum is wrong: expected {expected:#04x}, found {found:#04x} (reply {})", hex(frame))]
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
    /// The answer to command 136 type 0 is not a host address followed by eight printable ASCII characters.
    #[error("the version reply is not eight ASCII characters (reply {})", hex(frame))]
    BadVersionString {
        /// The nine bytes received.
        frame: [u8; FRAME_LEN],
    },
}

impl HostError {
    /// Whether the module answered at all: `true` for [`HostError::Status`], [`HostError::Checksum`] and
    /// [`HostError::BadVersionString`] (a reply arrived but says no or is damaged), `false` for open, I/O and
    /// timeout failures (nothing usable arrived).
    pub fn is_reply_error(&self) -> bool {
        matches!(self, HostError::Status { .. } | HostError::Checksum { .. } | HostError::BadVersionString { .. })
    }
}

/// Formats bytes as space-separated hex pairs, as the manual prints frames.
pub(crate) fn hex(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        out.push_str(&format!("{b:02X}"));
    }
    out
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

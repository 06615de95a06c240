//! The byte pipe under a [`Client`](crate::Client): a serial port, a pty, a TCP connection or a test script.

use crate::error::HostError;
use std::collections::VecDeque;
use std::io;
use std::time::Duration;

/// A byte stream to one bus (RS485 adapter, pty, TCP connection).
///
/// Implementations deliver bytes in order and never drop or invent any; framing is the
/// [`Client`](crate::Client)'s job.
pub trait Transport {
    /// Writes all of `bytes`.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;

    /// Fills `buf` completely, waiting at most `timeout` in total.
    ///
    /// # Errors
    ///
    /// [`HostError::Timeout`] when `buf` is not full by then (the `received` bytes that did arrive are the
    /// first bytes of `buf`),
    /// [`HostError::Io`] when the port fails or the peer closes.
    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError>;

    /// Discards whatever has arrived and not been read yet (stale replies, a half frame after a timeout).
    fn clear_input(&mut self);
}

impl<T: Transport + ?Sized> Transport for &mut T {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).send(bytes)
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        (**self).recv_exact(buf, timeout)
    }

    fn clear_input(&mut self) {
        (**self).clear_input()
    }
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).send(bytes)
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        (**self).recv_exact(buf, timeout)
    }

    fn clear_input(&mut self) {
        (**self).clear_input()
    }
}

/// An in-memory transport for tests: it records what is sent and hands out scripted input.
///
/// Input is queued with [`MockTransport::push_input`], or with [`MockTransport::answer_next`] to arrive only
/// when the next request is sent (a reply that comes after the request); a read that wants more bytes than
/// are queued takes what there is and fails with [`HostError::Timeout`] at once (no real waiting).
#[derive(Debug, Default, Clone)]
pub struct MockTransport {
    /// Every byte sent so far, in order.
    pub sent: Vec<u8>,
    /// Bytes waiting to be read.
    pub input: VecDeque<u8>,
    /// Input that arrives on the next sends: the first entry with the next send, and so on.
    pub answers: VecDeque<Vec<u8>>,
    /// How many times [`Transport::clear_input`] was called.
    pub clears: usize,
}

impl MockTransport {
    /// An empty transport.
    pub fn new() -> MockTransport {
        MockTransport::default()
    }

    /// Queues bytes for the next reads.
    pub fn push_input(&mut self, bytes: &[u8]) {
        self.input.extend(bytes);
    }

    /// Queues bytes that arrive when a later request is sent: one call per send, in order (an empty slice for
    /// a send that gets nothing).
    pub fn answer_next(&mut self, bytes: &[u8]) {
        self.answers.push_back(bytes.to_vec());
    }

    /// Returns and forgets what has been sent.
    pub fn take_sent(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.sent)
    }
}

impl Transport for MockTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.sent.extend_from_slice(bytes);
        if let Some(answer) = self.answers.pop_front() {
            self.input.extend(answer);
        }
        Ok(())
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        for (received, slot) in buf.iter_mut().enumerate() {
            match self.input.pop_front() {
                Some(byte) => *slot = byte,
                None => return Err(HostError::Timeout { waited: timeout, received }),
            }
        }
        Ok(())
    }

    fn clear_input(&mut self) {
        self.clears += 1;
        self.input.clear();
    }
}

/// Fills `buf` with `read(chunk, time_left)` calls until it is full or `timeout` has passed. `read` returns
/// `Ok(0)` only at end of stream, and an error of kind `TimedOut` or `WouldBlock` when its wait ran out.
pub(crate) fn recv_until_deadline<F>(buf: &mut [u8], timeout: Duration, mut read: F) -> Result<(), HostError>
where
    F: FnMut(&mut [u8], Duration) -> io::Result<usize>,
{
    let start = std::time::Instant::now();
    let mut filled = 0;
    while filled < buf.len() {
        let left = timeout.saturating_sub(start.elapsed());
        if left.is_zero() {
            return Err(HostError::Timeout { waited: timeout, received: filled });
        }
        match read(&mut buf[filled..], left) {
            Ok(0) => {
                return Err(HostError::Io(io::Error::new(
                    io::ErrorKind::UnexpectedEof,
                    "the other side closed the connection",
                )))
            }
            Ok(n) => filled += n,
            Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => {}
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(HostError::Io(e)),
        }
    }
    Ok(())
}

//! The binary TMCL interface on a byte stream (PD28-1021 manual §3.1, RS485).
//!
//! [`Framer`] collects bytes into 9-byte frames. Bytes may arrive split across reads. On a serial line a
//! partial frame is dropped when the gap before the next byte exceeds [`INTER_BYTE_TIMEOUT`], so that after
//! garbage or a lost byte the stream resynchronises at the next request, as Trinamic's RS485 firmware does.
//! The timeout is the caller's to choose ([`Framer::push_within`]): a pty or a TCP socket is a buffer, not a
//! wire, and a host's bytes may sit in it or arrive in pieces far more than 5 ms apart (see
//! `Module::set_inter_byte_timeout` and docs/decisions.md).
//!
//! [`Outbox`] holds frames waiting to be sent: replies delayed by the telegram pause time (GP 75) and the
//! unsolicited target-reached events of command 138. It is a small fixed ring: no heap.

use crate::time::{Duration, Instant};
use tmcl_wire::FRAME_LEN;

/// The inter-byte gap after which a partial frame is dropped (5 ms, Trinamic's RS485 firmware value).
pub const INTER_BYTE_TIMEOUT: Duration = Duration::from_millis(5);

/// Where a module's outgoing bytes go.
pub trait Sink {
    /// Sends bytes to the host.
    fn send(&mut self, bytes: &[u8]);
}

impl<F: FnMut(&[u8])> Sink for F {
    fn send(&mut self, bytes: &[u8]) {
        self(bytes)
    }
}

/// Collects bytes into frames.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Framer {
    buf: [u8; FRAME_LEN],
    len: usize,
    last: Instant,
}

impl Framer {
    /// A framer with nothing collected.
    pub const fn new() -> Framer {
        Framer { buf: [0; FRAME_LEN], len: 0, last: Instant::ZERO }
    }

    /// Feeds one byte received at `now`; returns a complete frame when this byte completes one. A partial
    /// frame older than [`INTER_BYTE_TIMEOUT`] is dropped first.
    pub fn push(&mut self, byte: u8, now: Instant) -> Option<[u8; FRAME_LEN]> {
        self.push_within(byte, now, Some(INTER_BYTE_TIMEOUT))
    }

    /// As [`Framer::push`], with the gap after which a partial frame is dropped (`None`: it never is).
    #[inline(never)]
    pub fn push_within(&mut self, byte: u8, now: Instant, timeout: Option<Duration>) -> Option<[u8; FRAME_LEN]> {
        if self.len > 0 && timeout.is_some_and(|t| now - self.last > t) {
            self.len = 0;
        }
        self.last = now;
        self.buf[self.len] = byte;
        self.len += 1;
        if self.len == FRAME_LEN {
            self.len = 0;
            Some(self.buf)
        } else {
            None
        }
    }

    /// Notes a whole frame taken at `now` without pushing its bytes (the next byte's gap counts from it).
    pub fn touch(&mut self, now: Instant) {
        self.last = now;
    }

    /// Number of bytes of a partial frame held.
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Drops a partial frame.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

/// Bytes the outbox holds: a few replies, or an ASCII line with its echo (a module has at most one reply
/// and one event pending; the rest is margin for a host that ignores the one-request-in-flight rule).
pub const OUTBOX_BYTES: usize = 256;
/// How many separately timed messages it holds.
pub const OUTBOX_MESSAGES: usize = 16;

/// Messages waiting for their time to be sent: a byte ring with one mark (length, due time) per message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outbox {
    bytes: [u8; OUTBOX_BYTES],
    start: usize,
    used: usize,
    marks: [(u16, Instant); OUTBOX_MESSAGES],
    first: usize,
    count: usize,
}

impl Default for Outbox {
    fn default() -> Outbox {
        Outbox::new()
    }
}

impl Outbox {
    /// An empty outbox.
    pub const fn new() -> Outbox {
        Outbox {
            bytes: [0; OUTBOX_BYTES],
            start: 0,
            used: 0,
            marks: [(0, Instant::ZERO); OUTBOX_MESSAGES],
            first: 0,
            count: 0,
        }
    }

    /// Queues a message to be sent at or after `due`. Messages leave in the order they were queued (a
    /// message is never due before the one ahead of it); one with the same due time as the last one
    /// joins it. When the outbox is full the oldest messages are dropped whole (a host that floods the
    /// module loses replies, as on a real bus, but the module never blocks or panics). A message longer
    /// than the outbox is dropped.
    pub fn push(&mut self, message: &[u8], due: Instant) {
        if message.len() > OUTBOX_BYTES {
            return;
        }
        if self.count == 0 {
            // The common case, a reply to a request: nothing waits. The ring starts over at 0, so the
            // message goes in one piece, and a frame with a constant length (the copy inlined).
            self.start = 0;
            self.first = 0;
            match <&[u8; FRAME_LEN]>::try_from(message) {
                Ok(frame) => self.bytes[..FRAME_LEN].copy_from_slice(frame),
                Err(_) => self.bytes[..message.len()].copy_from_slice(message),
            }
            self.used = message.len();
            self.marks[0] = (message.len() as u16, due);
            self.count = 1;
            return;
        }
        let last = (self.count > 0).then(|| (self.first + self.count - 1) % OUTBOX_MESSAGES);
        let due = last.map_or(due, |l| due.max(self.marks[l].1));
        let joins = last
            .is_some_and(|l| self.marks[l].1 == due && usize::from(self.marks[l].0) + message.len() <= OUTBOX_BYTES);
        while self.used + message.len() > OUTBOX_BYTES || (!joins && self.count == OUTBOX_MESSAGES) {
            self.drop_first();
        }
        // Copy in at most two pieces (the ring may wrap).
        let at = (self.start + self.used) % OUTBOX_BYTES;
        let first = message.len().min(OUTBOX_BYTES - at);
        self.bytes[at..at + first].copy_from_slice(&message[..first]);
        self.bytes[..message.len() - first].copy_from_slice(&message[first..]);
        self.used += message.len();
        match last {
            Some(l) if joins && self.count > 0 && (self.first + self.count - 1) % OUTBOX_MESSAGES == l => {
                self.marks[l].0 += message.len() as u16;
            }
            _ => {
                self.marks[(self.first + self.count) % OUTBOX_MESSAGES] = (message.len() as u16, due);
                self.count += 1;
            }
        }
    }

    /// Queues a 9-byte frame to be sent at or after `due`, as [`Outbox::push`] does. The common case, a
    /// reply to a request with nothing waiting, is the frame stored at the start of the ring in place.
    #[inline(always)]
    pub fn push_frame(&mut self, frame: [u8; FRAME_LEN], due: Instant) {
        if self.count != 0 {
            return self.push(&frame, due);
        }
        self.start = 0;
        self.first = 0;
        let (head, _) = self.bytes.split_first_chunk_mut::<FRAME_LEN>().expect("the outbox holds a frame");
        *head = frame;
        self.used = FRAME_LEN;
        self.marks[0] = (FRAME_LEN as u16, due);
        self.count = 1;
    }

    fn drop_first(&mut self) {
        let n = usize::from(self.marks[self.first].0);
        self.start = (self.start + n) % OUTBOX_BYTES;
        self.used -= n;
        self.first = (self.first + 1) % OUTBOX_MESSAGES;
        self.count -= 1;
    }

    /// Sends every message due at `now`.
    #[inline(always)]
    pub fn flush(&mut self, now: Instant, sink: &mut impl Sink) {
        if self.count == 0 {
            return;
        }
        let (n, due) = self.marks[self.first % OUTBOX_MESSAGES];
        if self.count == 1 && self.start == 0 && due <= now {
            // One message at the start of the ring (what `push` makes of a reply to a request).
            self.count = 0;
            self.used = 0;
            sink.send(&self.bytes[..usize::from(n).min(OUTBOX_BYTES)]);
            return;
        }
        self.flush_due(now, sink);
    }

    fn flush_due(&mut self, now: Instant, sink: &mut impl Sink) {
        while self.count > 0 && self.marks[self.first].1 <= now {
            let n = usize::from(self.marks[self.first].0);
            let end = self.start + n;
            if end <= OUTBOX_BYTES {
                sink.send(&self.bytes[self.start..end]);
            } else {
                sink.send(&self.bytes[self.start..]);
                sink.send(&self.bytes[..end - OUTBOX_BYTES]);
            }
            self.drop_first();
        }
    }

    /// When the next message is due.
    pub fn next_due(&self) -> Option<Instant> {
        (self.count > 0).then(|| self.marks[self.first].1)
    }

    /// Number of messages waiting.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether nothing is waiting.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    const FRAME: [u8; 9] = [0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08];

    #[test]
    fn frames_split_across_reads() {
        let mut f = Framer::new();
        let t = Instant::from_millis(1);
        for b in &FRAME[..4] {
            assert_eq!(f.push(*b, t), None);
        }
        let t = t + Duration::from_millis(4);
        for b in &FRAME[4..8] {
            assert_eq!(f.push(*b, t), None);
        }
        assert_eq!(f.push(FRAME[8], t), Some(FRAME));
        assert_eq!(f.pending(), 0);
    }

    #[test]
    fn gap_drops_a_partial_frame() {
        let mut f = Framer::new();
        let t = Instant::from_millis(10);
        for b in [0xAAu8, 0xBB, 0xCC] {
            f.push(b, t);
        }
        let later = t + Duration::from_millis(6);
        let mut got = None;
        for b in FRAME {
            got = f.push(b, later);
        }
        assert_eq!(got, Some(FRAME));
    }

    #[test]
    fn outbox_keeps_order_and_time() {
        let mut o = Outbox::new();
        let t = Instant::from_millis(1);
        o.push(&[1; 9], t + Duration::from_millis(5));
        o.push(&[2; 9], t);
        let mut out = Vec::new();
        o.flush(t, &mut |b: &[u8]| out.extend_from_slice(b));
        assert!(out.is_empty(), "frame 2 waits behind frame 1");
        assert_eq!(o.next_due(), Some(t + Duration::from_millis(5)));
        o.flush(t + Duration::from_millis(5), &mut |b: &[u8]| out.extend_from_slice(b));
        assert_eq!((out.len(), out[0], out[9]), (18, 1, 2));
        assert!(o.is_empty());
    }

    #[test]
    fn outbox_overflow_drops_oldest_whole() {
        let mut o = Outbox::new();
        for i in 0..40u8 {
            o.push(&[i; 9], Instant::from_micros(u64::from(i)));
        }
        let mut out = Vec::new();
        o.flush(Instant::from_secs(1), &mut |b: &[u8]| out.extend_from_slice(b));
        assert_eq!(out.len() % 9, 0, "only whole messages");
        assert!(out.len() <= OUTBOX_BYTES);
        assert_eq!(*out.last().unwrap(), 39, "the newest survive");
        assert!(out.chunks(9).all(|c| c.iter().all(|b| *b == c[0])));
    }

    #[test]
    fn messages_with_the_same_time_join_and_wrap() {
        let mut o = Outbox::new();
        let mut out = Vec::new();
        for round in 0..100u8 {
            for c in b"AGAP 1, 0" {
                o.push(&[*c ^ round], Instant::ZERO);
            }
            o.flush(Instant::ZERO, &mut |b: &[u8]| out.extend_from_slice(b));
        }
        assert_eq!(out.len(), 900);
        assert_eq!(out[9], b'A' ^ 1);
    }
}

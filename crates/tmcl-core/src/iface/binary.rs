//! The binary TMCL interface on a byte stream (PD28-1021 manual §3.1, RS485).
//!
//! [`Framer`] collects bytes into 9-byte frames. Bytes may arrive split across reads. A partial frame is
//! dropped when the gap before the next byte exceeds [`INTER_BYTE_TIMEOUT`], so that after garbage or a
//! lost byte the stream resynchronises at the next request, as Trinamic's RS485 firmware does.
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
#[derive(Debug, Clone, Default)]
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

    /// Feeds one byte received at `now`; returns a complete frame when this byte completes one.
    pub fn push(&mut self, byte: u8, now: Instant) -> Option<[u8; FRAME_LEN]> {
        if self.len > 0 && now - self.last > INTER_BYTE_TIMEOUT {
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

    /// Number of bytes of a partial frame held.
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Drops a partial frame.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

/// How many frames the outbox holds. A module has at most one reply and one event pending at a time;
/// the rest is margin for a host that ignores the one-request-in-flight rule.
pub const OUTBOX_FRAMES: usize = 8;

/// Frames waiting for their time to be sent.
#[derive(Debug, Clone)]
pub struct Outbox {
    frames: [([u8; FRAME_LEN], Instant); OUTBOX_FRAMES],
    head: usize,
    len: usize,
}

impl Default for Outbox {
    fn default() -> Outbox {
        Outbox::new()
    }
}

impl Outbox {
    /// An empty outbox.
    pub const fn new() -> Outbox {
        Outbox { frames: [([0; FRAME_LEN], Instant::ZERO); OUTBOX_FRAMES], head: 0, len: 0 }
    }

    /// Queues a frame to be sent at or after `due`. Frames leave in the order they were queued. When the
    /// outbox is full the oldest frame is dropped (a host that floods the module loses replies, as on a
    /// real bus, but the module never blocks or panics).
    pub fn push(&mut self, frame: [u8; FRAME_LEN], due: Instant) {
        if self.len == OUTBOX_FRAMES {
            self.head = (self.head + 1) % OUTBOX_FRAMES;
            self.len -= 1;
        }
        let tail = (self.head + self.len) % OUTBOX_FRAMES;
        // Keep the order: a frame is never due before the one queued ahead of it.
        let due = match self.len {
            0 => due,
            n => due.max(self.frames[(self.head + n - 1) % OUTBOX_FRAMES].1),
        };
        self.frames[tail] = (frame, due);
        self.len += 1;
    }

    /// Sends every frame due at `now`.
    pub fn flush(&mut self, now: Instant, sink: &mut impl Sink) {
        while self.len > 0 && self.frames[self.head].1 <= now {
            sink.send(&self.frames[self.head].0);
            self.head = (self.head + 1) % OUTBOX_FRAMES;
            self.len -= 1;
        }
    }

    /// When the next frame is due.
    pub fn next_due(&self) -> Option<Instant> {
        (self.len > 0).then(|| self.frames[self.head].1)
    }

    /// Number of frames waiting.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is waiting.
    pub fn is_empty(&self) -> bool {
        self.len == 0
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
        o.push([1; 9], t + Duration::from_millis(5));
        o.push([2; 9], t);
        let mut out = Vec::new();
        o.flush(t, &mut |b: &[u8]| out.push(b[0]));
        assert!(out.is_empty(), "frame 2 waits behind frame 1");
        assert_eq!(o.next_due(), Some(t + Duration::from_millis(5)));
        o.flush(t + Duration::from_millis(5), &mut |b: &[u8]| out.push(b[0]));
        assert_eq!(out, [1, 2]);
        assert!(o.is_empty());
    }

    #[test]
    fn outbox_overflow_drops_oldest() {
        let mut o = Outbox::new();
        for i in 0..(OUTBOX_FRAMES as u8 + 2) {
            o.push([i; 9], Instant::ZERO);
        }
        let mut out = Vec::new();
        o.flush(Instant::ZERO, &mut |b: &[u8]| out.push(b[0]));
        assert_eq!(out.len(), OUTBOX_FRAMES);
        assert_eq!(out[0], 2);
    }
}

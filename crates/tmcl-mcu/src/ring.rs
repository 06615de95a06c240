//! A single-producer, single-consumer byte queue between an interrupt handler and the main loop.
//!
//! Every cell is an atomic byte and the two ends are free-running counters, so the queue needs neither a
//! lock nor `unsafe`: the producer only writes `head` and the cells between `head` and `tail + N`, the
//! consumer only writes `tail`. On a Cortex-M3 the atomics are plain loads and stores. One side must be
//! the only producer and the other the only consumer (the UART receive interrupt and the main loop, or the
//! main loop and the UART transmit interrupt).

use core::sync::atomic::{AtomicU32, AtomicU8, AtomicUsize, Ordering};

/// A queue of at most `N` bytes; `N` must be a power of two (checked when the queue is built).
pub struct ByteRing<const N: usize> {
    cells: [AtomicU8; N],
    /// Bytes written since the start (wrapping).
    head: AtomicUsize,
    /// Bytes read since the start (wrapping).
    tail: AtomicUsize,
    /// Bytes the producer had to drop because the queue was full (wrapping).
    dropped: AtomicU32,
}

impl<const N: usize> ByteRing<N> {
    const POWER_OF_TWO: () = assert!(N.is_power_of_two(), "a ByteRing's size must be a power of two");

    /// An empty queue (usable in a `static`).
    #[allow(clippy::let_unit_value)]
    pub const fn new() -> Self {
        let () = Self::POWER_OF_TWO;
        ByteRing {
            cells: [const { AtomicU8::new(0) }; N],
            head: AtomicUsize::new(0),
            tail: AtomicUsize::new(0),
            dropped: AtomicU32::new(0),
        }
    }

    /// The producer's side: appends `byte`; `false` (and the byte counted as dropped) when the queue is full.
    pub fn push(&self, byte: u8) -> bool {
        let head = self.head.load(Ordering::Relaxed);
        let tail = self.tail.load(Ordering::Acquire);
        if head.wrapping_sub(tail) >= N {
            self.dropped.fetch_add(1, Ordering::Relaxed);
            return false;
        }
        self.cells[head % N].store(byte, Ordering::Relaxed);
        self.head.store(head.wrapping_add(1), Ordering::Release);
        true
    }

    /// The consumer's side: the oldest byte, if any.
    pub fn pop(&self) -> Option<u8> {
        let tail = self.tail.load(Ordering::Relaxed);
        let head = self.head.load(Ordering::Acquire);
        if head == tail {
            return None;
        }
        let byte = self.cells[tail % N].load(Ordering::Relaxed);
        self.tail.store(tail.wrapping_add(1), Ordering::Release);
        Some(byte)
    }

    /// The consumer's side: moves up to `out.len()` bytes into `out`; returns how many.
    pub fn pop_into(&self, out: &mut [u8]) -> usize {
        let mut n = 0;
        for slot in out.iter_mut() {
            match self.pop() {
                Some(b) => *slot = b,
                None => break,
            }
            n += 1;
        }
        n
    }

    /// Bytes in the queue (exact on the consumer's side; a lower bound on the producer's).
    pub fn len(&self) -> usize {
        self.head.load(Ordering::Acquire).wrapping_sub(self.tail.load(Ordering::Acquire)).min(N)
    }

    /// Whether the queue is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Room left (exact on the producer's side).
    pub fn room(&self) -> usize {
        N - self.len()
    }

    /// Bytes dropped because the queue was full, since the start (wrapping).
    pub fn dropped(&self) -> u32 {
        self.dropped.load(Ordering::Relaxed)
    }
}

impl<const N: usize> Default for ByteRing<N> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::ByteRing;

    #[test]
    fn fifo_order_and_wraparound() {
        let ring = ByteRing::<8>::new();
        let mut next_in = 0u8;
        let mut next_out = 0u8;
        // Many times round the ring, at several fill levels.
        for round in 0..100 {
            for _ in 0..(round % 8) + 1 {
                assert!(ring.push(next_in));
                next_in = next_in.wrapping_add(1);
            }
            while let Some(b) = ring.pop() {
                assert_eq!(b, next_out);
                next_out = next_out.wrapping_add(1);
            }
        }
        assert_eq!(next_in, next_out);
        assert_eq!(ring.dropped(), 0);
    }

    #[test]
    fn full_queue_drops_and_counts() {
        let ring = ByteRing::<4>::new();
        for b in 0..4 {
            assert!(ring.push(b));
        }
        assert_eq!(ring.room(), 0);
        assert!(!ring.push(9));
        assert_eq!(ring.dropped(), 1);
        let mut out = [0u8; 8];
        assert_eq!(ring.pop_into(&mut out), 4);
        assert_eq!(&out[..4], &[0, 1, 2, 3]);
        assert!(ring.is_empty());
        assert_eq!(ring.pop(), None);
    }

    #[test]
    fn counters_wrap_around_usize() {
        let ring = ByteRing::<4>::new();
        // Start just below the wrap of the free-running counters.
        ring.head.store(usize::MAX - 1, core::sync::atomic::Ordering::Relaxed);
        ring.tail.store(usize::MAX - 1, core::sync::atomic::Ordering::Relaxed);
        for b in 10..14 {
            assert!(ring.push(b));
        }
        assert!(!ring.push(14));
        assert_eq!(ring.len(), 4);
        let mut out = [0u8; 4];
        assert_eq!(ring.pop_into(&mut out), 4);
        assert_eq!(out, [10, 11, 12, 13]);
    }

    #[test]
    fn concurrent_producer_and_consumer() {
        // The queue's contract under real concurrency (threads stand in for the interrupt handler).
        static RING: ByteRing<16> = ByteRing::new();
        const COUNT: u32 = 100_000;
        let producer = std::thread::spawn(|| {
            let mut i = 0u32;
            while i < COUNT {
                if RING.push(i as u8) {
                    i += 1;
                }
            }
        });
        let mut expected = 0u32;
        while expected < COUNT {
            if let Some(b) = RING.pop() {
                assert_eq!(b, expected as u8);
                expected += 1;
            }
        }
        producer.join().unwrap();
        assert!(RING.is_empty());
    }
}

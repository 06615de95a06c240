//! The port's clock: a millisecond tick counter that the timer interrupt (SysTick) advances, extended to
//! the core's [`Instant`].
//!
//! The core runs its motion controller in 1 ms ticks ([`tmcl_core::motion::TICK`]) and its timeouts in
//! milliseconds (the 5 ms inter-byte timeout, GP 75 telegram pause, GP 68 heartbeat), so a 1 ms timer
//! interrupt is all the time base it needs; the counter is 32 bits (an atomic store on any 32-bit
//! microcontroller) and [`Monotonic`] widens it to 64 bits, so it never wraps.

use core::sync::atomic::{AtomicU32, Ordering};
use tmcl_core::Instant;

/// The tick counter: written by the timer interrupt only, read by the main loop.
pub struct Ticks(AtomicU32);

impl Ticks {
    /// A counter at 0 (usable in a `static`).
    pub const fn new() -> Ticks {
        Ticks(AtomicU32::new(0))
    }

    /// One more millisecond (the timer interrupt's only job).
    pub fn tick(&self) {
        // The interrupt is the only writer: a load and a store are enough.
        let t = self.0.load(Ordering::Relaxed);
        self.0.store(t.wrapping_add(1), Ordering::Release);
    }

    /// Milliseconds since the start, modulo 2³².
    pub fn read(&self) -> u32 {
        self.0.load(Ordering::Acquire)
    }
}

impl Default for Ticks {
    fn default() -> Self {
        Self::new()
    }
}

/// Widens the wrapping 32-bit tick count to a 64-bit [`Instant`] that never goes back.
///
/// It must see the counter at least once every 2³² ms (49 days); the main loop sees it every millisecond.
#[derive(Debug, Clone, Copy, Default)]
pub struct Monotonic {
    last: u32,
    millis: u64,
}

impl Monotonic {
    /// At the counter's start (0 ms).
    pub const fn new() -> Monotonic {
        Monotonic { last: 0, millis: 0 }
    }

    /// The time at tick count `ticks`.
    pub fn at(&mut self, ticks: u32) -> Instant {
        self.millis += u64::from(ticks.wrapping_sub(self.last));
        self.last = ticks;
        Instant::from_millis(self.millis)
    }
}

#[cfg(test)]
mod tests {
    use super::{Monotonic, Ticks};
    use tmcl_core::Instant;

    #[test]
    fn ticks_count_milliseconds() {
        let ticks = Ticks::new();
        let mut clock = Monotonic::new();
        assert_eq!(clock.at(ticks.read()), Instant::ZERO);
        for _ in 0..1500 {
            ticks.tick();
        }
        assert_eq!(clock.at(ticks.read()), Instant::from_millis(1500));
    }

    #[test]
    fn the_32_bit_counter_wraps_and_time_goes_on() {
        let mut clock = Monotonic::new();
        let near = u32::MAX - 5;
        assert_eq!(clock.at(near), Instant::from_millis(u64::from(near)));
        assert_eq!(clock.at(4), Instant::from_millis(u64::from(u32::MAX) + 5));
        assert_eq!(clock.at(4), Instant::from_millis(u64::from(u32::MAX) + 5));
    }
}

//! The port's clock: a millisecond tick counter that the timer interrupt (SysTick) advances, extended to
//! the core's [`Instant`].
//!
//! The core runs its motion controller in 1 ms ticks ([`tmcl_core::motion::TICK`]) and its timeouts in
//! milliseconds (the 5 ms inter-byte timeout, GP 75 telegram pause, GP 68 heartbeat), so a 1 ms timer
//! interrupt is the time base. The time of a byte is finer: the microseconds into the current tick, from
//! the timer's counter, so that a reply delayed by the telegram pause never leaves early because its
//! request's time was rounded down to the millisecond. The counter is 32 bits (an atomic store on any
//! 32-bit microcontroller) and [`Monotonic`] widens it to 64 bits, so it never wraps.

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
    last_ticks: u32,
    millis: u64,
    last: Instant,
}

impl Monotonic {
    /// At the counter's start (0 ms).
    pub const fn new() -> Monotonic {
        Monotonic { last_ticks: 0, millis: 0, last: Instant::ZERO }
    }

    /// The time at tick count `ticks`, `micros` microseconds into that tick (values of 1000 and more count
    /// as 999). A reading that would go back, as one taken just as the counter wraps, before its interrupt
    /// has counted the tick, gives the latest time given instead.
    pub fn at(&mut self, ticks: u32, micros: u32) -> Instant {
        self.millis += u64::from(ticks.wrapping_sub(self.last_ticks));
        self.last_ticks = ticks;
        let now = Instant::from_micros(self.millis * 1000 + u64::from(micros.min(999)));
        self.last = self.last.max(now);
        self.last
    }
}

/// The microseconds into the current tick from a down-counting timer (SysTick) that counts from `reload`
/// to 0 once per millisecond and reads `current` now.
pub const fn micros_into_tick(reload: u32, current: u32) -> u32 {
    let period = reload as u64 + 1;
    let elapsed = period - (if current > reload { reload } else { current }) as u64 - 1;
    (elapsed * 1000 / period) as u32
}

#[cfg(test)]
mod tests {
    use super::{micros_into_tick, Monotonic, Ticks};
    use tmcl_core::Instant;

    #[test]
    fn ticks_count_milliseconds() {
        let ticks = Ticks::new();
        let mut clock = Monotonic::new();
        assert_eq!(clock.at(ticks.read(), 0), Instant::ZERO);
        for _ in 0..1500 {
            ticks.tick();
        }
        assert_eq!(clock.at(ticks.read(), 250), Instant::from_micros(1_500_250));
    }

    #[test]
    fn the_32_bit_counter_wraps_and_time_goes_on() {
        let mut clock = Monotonic::new();
        let near = u32::MAX - 5;
        assert_eq!(clock.at(near, 0), Instant::from_millis(u64::from(near)));
        assert_eq!(clock.at(4, 0), Instant::from_millis(u64::from(u32::MAX) + 5));
        assert_eq!(clock.at(4, 0), Instant::from_millis(u64::from(u32::MAX) + 5));
    }

    #[test]
    fn a_reading_at_the_wrap_before_the_interrupt_does_not_go_back() {
        let mut clock = Monotonic::new();
        assert_eq!(clock.at(7, 998), Instant::from_micros(7998));
        // The timer has wrapped (0 µs into the tick) but the interrupt has not counted it yet.
        assert_eq!(clock.at(7, 0), Instant::from_micros(7998));
        assert_eq!(clock.at(8, 1), Instant::from_micros(8001));
        assert_eq!(clock.at(8, 5000), Instant::from_micros(8999));
    }

    #[test]
    fn microseconds_from_the_down_counter() {
        // 50 MHz, 1 ms: reload 49 999.
        assert_eq!(micros_into_tick(49_999, 49_999), 0);
        assert_eq!(micros_into_tick(49_999, 24_999), 500);
        assert_eq!(micros_into_tick(49_999, 0), 999);
        assert_eq!(micros_into_tick(49_999, u32::MAX), 0);
        assert_eq!(micros_into_tick(0, 0), 0);
    }
}

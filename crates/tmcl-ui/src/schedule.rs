//! What the workbench reads from the module, and in which order: a fair poll scheduler and a rate limit.
//!
//! Every value the page shows is a [`Poll`] with a period: the plots' values every 20 ms, the I/O every
//! 300 ms, each row of the parameter table every 2 s, and so on. The line cannot carry them all at once
//! (at 9600 baud one request and its reply take 18.75 ms), so [`Schedule::next`] always picks the value
//! that is most overdue *relative to its period*: a value with half the period gets twice the share of
//! the line. When the line is fast enough every value gets its period; when it is not, every value is
//! slowed down in the same proportion, and none starves. The scheduler is a pure function of the clock
//! it is given, so its tests need no module.
//!
//! [`Limiter`] spaces all requests, the page's own included, at least `1 / rate` apart.

use std::time::{Duration, Instant};

/// One value the workbench reads again and again.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Poll {
    /// GAP `param` of `motor` (PD28-1021 TMCL manual §3.7.6).
    Axis { param: u8, motor: u8 },
    /// GGP `param` of `bank` (§3.7.10); bank 2 holds the user variables (§5.3).
    Global { param: u8, bank: u8 },
    /// GIO `port` of `bank` (§3.7.15).
    Input { port: u8, bank: u8 },
    /// RFS STATUS of `motor` (§3.7.13): 0 when no search is active.
    Reference { motor: u8 },
    /// Command 135 type 1: mode, wait flag and program counter (§3.7.38, Table 13).
    ProgramCounter,
    /// Command 135 type 2: the accumulator.
    Accumulator,
    /// Command 135 type 3: the X register.
    XRegister,
}

#[derive(Debug, Clone, Copy)]
struct Item {
    poll: Poll,
    period: Duration,
    last: Option<Instant>,
}

/// The values to read and when each was read last.
#[derive(Debug, Default)]
pub(crate) struct Schedule {
    items: Vec<Item>,
}

impl Schedule {
    /// Replaces the set of values; a value that stays keeps the time it was read last, so a change of view
    /// does not make everything due at once.
    pub(crate) fn set(&mut self, polls: impl IntoIterator<Item = (Poll, Duration)>) {
        let old = std::mem::take(&mut self.items);
        for (poll, period) in polls {
            if self.items.iter().any(|i| i.poll == poll) {
                continue;
            }
            let last = old.iter().find(|i| i.poll == poll).and_then(|i| i.last);
            self.items.push(Item { poll, period: period.max(Duration::from_millis(1)), last });
        }
    }

    /// Makes the values `which` picks due at once (in their order), after a request that changed them: a
    /// change made from the page shows without waiting for the values' turn.
    pub(crate) fn hurry(&mut self, mut which: impl FnMut(&Poll) -> bool) {
        for item in &mut self.items {
            if which(&item.poll) {
                item.last = None;
            }
        }
    }

    /// How many values are scheduled.
    pub(crate) fn len(&self) -> usize {
        self.items.len()
    }

    /// The value to read at `now`, marked as read; or, when none is due yet, the instant the next one is
    /// (`None` when nothing is scheduled at all).
    ///
    /// A value never read is due at once, in the order given to [`Schedule::set`]. Among the others, the
    /// one whose time since its last read is the largest multiple of its period comes first.
    pub(crate) fn next(&mut self, now: Instant) -> Result<Poll, Option<Instant>> {
        let mut best: Option<(usize, f64)> = None;
        let mut soonest: Option<Instant> = None;
        for (n, item) in self.items.iter().enumerate() {
            let score = match item.last {
                None => f64::INFINITY,
                Some(last) => {
                    let age = now.saturating_duration_since(last);
                    if age < item.period {
                        let due = last + item.period;
                        soonest = Some(soonest.map_or(due, |s| s.min(due)));
                        continue;
                    }
                    age.as_secs_f64() / item.period.as_secs_f64()
                }
            };
            if best.is_none_or(|(_, b)| score > b) {
                best = Some((n, score));
            }
        }
        match best {
            Some((n, _)) => {
                self.items[n].last = Some(now);
                Ok(self.items[n].poll)
            }
            None => Err(soonest),
        }
    }
}

/// Spaces requests at least `interval` apart (the start of one to the start of the next).
#[derive(Debug)]
pub(crate) struct Limiter {
    interval: Duration,
    next: Option<Instant>,
}

impl Limiter {
    /// At most `rate` requests per second.
    pub(crate) fn new(rate: f64) -> Limiter {
        let rate = if rate.is_finite() && rate > 0.0 { rate } else { 1.0 };
        Limiter { interval: Duration::from_secs_f64(1.0 / rate), next: None }
    }

    /// How long the next request must wait at `now` (zero when it may go at once).
    pub(crate) fn delay(&self, now: Instant) -> Duration {
        self.next.map_or(Duration::ZERO, |next| next.saturating_duration_since(now))
    }

    /// Takes the slot of a request that starts at `now`.
    pub(crate) fn take(&mut self, now: Instant) {
        let start = self.next.map_or(now, |next| next.max(now));
        self.next = Some(start + self.interval);
    }

    /// Waits for the next slot and takes it.
    pub(crate) fn wait(&mut self) {
        let delay = self.delay(Instant::now());
        if !delay.is_zero() {
            std::thread::sleep(delay);
        }
        self.take(Instant::now());
    }
}

/// The most requests per second a serial line at `baud` carries: a 9-byte request and its 9-byte reply, 10
/// bits per byte (8N1), and nothing else (PD28-1021 TMCL manual §3.1: one request in flight at a time).
pub(crate) fn line_rate(baud: u32) -> f64 {
    f64::from(baud.max(1)) / (18.0 * 10.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn shares_follow_the_periods_when_the_line_is_too_slow() {
        let mut s = Schedule::default();
        let fast = Poll::Axis { param: 1, motor: 0 };
        let slow = Poll::Global { param: 0, bank: 2 };
        s.set([(fast, ms(20)), (slow, ms(100))]);
        let start = Instant::now();
        let mut counts = (0, 0);
        // One request every 40 ms: slower than either period wants.
        for n in 0..600 {
            match s.next(start + ms(40 * n)) {
                Ok(p) if p == fast => counts.0 += 1,
                Ok(_) => counts.1 += 1,
                Err(_) => panic!("something is always due"),
            }
        }
        // 5 : 1, as the periods 20 : 100.
        assert!((counts.0 as f64 / counts.1 as f64 - 5.0).abs() < 0.2, "{counts:?}");
    }

    #[test]
    fn nothing_due_tells_when() {
        let mut s = Schedule::default();
        let p = Poll::ProgramCounter;
        s.set([(p, ms(100))]);
        let t0 = Instant::now();
        assert_eq!(s.next(t0), Ok(p));
        assert_eq!(s.next(t0 + ms(10)), Err(Some(t0 + ms(100))));
        assert_eq!(s.next(t0 + ms(100)), Ok(p));
        // A new set keeps the time of a value that stays.
        s.set([(p, ms(100)), (Poll::Accumulator, ms(100))]);
        assert_eq!(s.next(t0 + ms(110)), Ok(Poll::Accumulator));
        assert_eq!(s.next(t0 + ms(120)), Err(Some(t0 + ms(200))));
        // Hurried values come first, at once.
        s.hurry(|p| *p == Poll::ProgramCounter);
        assert_eq!(s.next(t0 + ms(121)), Ok(Poll::ProgramCounter));
        s.set([]);
        assert_eq!(s.next(t0), Err(None));
        assert_eq!(s.len(), 0);
    }

    #[test]
    fn the_limiter_spaces_requests() {
        let mut l = Limiter::new(50.0);
        let t0 = Instant::now();
        assert_eq!(l.delay(t0), Duration::ZERO);
        l.take(t0);
        assert_eq!(l.delay(t0), ms(20));
        assert_eq!(l.delay(t0 + ms(5)), ms(15));
        l.take(t0 + ms(25));
        assert_eq!(l.delay(t0 + ms(25)), ms(20));
        assert!((line_rate(9600) - 53.33).abs() < 0.01);
        // Nonsense rates fall back to one request a second rather than dividing by zero.
        assert_eq!(Limiter::new(0.0).interval, Duration::from_secs(1));
    }
}

//! The step/direction output: turns the microsteps the core's ramp moves into pulses for a stepper
//! driver's STEP and DIR inputs (the TMC262 of the PD28-1021 takes them so, with its SPI for the current).
//!
//! The core reports, after every motion tick, how many microsteps the field moved
//! ([`tmcl_core::hal::DriveState::moved`]). The main loop adds them to [`StepOutput`] and sets a step
//! timer to the period that spreads the steps still to go evenly over one tick ([`period`]); the timer's
//! interrupt takes one step per interrupt ([`StepOutput::take`]) and drives DIR and STEP. Steps are never
//! lost: at a rate the timer cannot reach (more than one step per `min_period`) the steps left over stay
//! pending and go out in the next tick, and a move and its reversal within one tick cancel in the count,
//! as the driver's position would.

use core::sync::atomic::{AtomicI32, Ordering};

/// The steps between the core and the driver: written by the main loop ([`StepOutput::add`]) and the step
/// interrupt ([`StepOutput::take`]), each with an atomic read-modify-write.
pub struct StepOutput {
    /// Microsteps moved by the core and not yet pulsed, signed.
    pending: AtomicI32,
    /// Pulses given since the start, signed (+1 per step in the positive direction): the position the
    /// driver has seen, modulo 2³².
    pulses: AtomicI32,
}

impl StepOutput {
    /// Nothing pending (usable in a `static`).
    pub const fn new() -> StepOutput {
        StepOutput { pending: AtomicI32::new(0), pulses: AtomicI32::new(0) }
    }

    /// The main loop's side: the core moved `moved` microsteps (signed). Returns the steps now pending.
    pub fn add(&self, moved: i64) -> i32 {
        let moved = moved.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        let previous = self
            .pending
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |p| Some(p.saturating_add(moved)))
            .unwrap_or_else(|p| p);
        previous.saturating_add(moved)
    }

    /// The step interrupt's side: takes one pending step, if there is one, and returns its direction
    /// (`true` = positive).
    pub fn take(&self) -> Option<bool> {
        let previous = self
            .pending
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |p| (p != 0).then(|| p - p.signum()))
            .ok()?;
        let positive = previous > 0;
        self.pulses.fetch_add(if positive { 1 } else { -1 }, Ordering::Relaxed);
        Some(positive)
    }

    /// Steps moved by the core and not yet pulsed.
    pub fn pending(&self) -> i32 {
        self.pending.load(Ordering::Acquire)
    }

    /// Pulses given since the start, signed.
    pub fn pulses(&self) -> i32 {
        self.pulses.load(Ordering::Relaxed)
    }
}

impl Default for StepOutput {
    fn default() -> Self {
        Self::new()
    }
}

/// The step timer's period, in timer clock cycles, that spreads `pending` steps evenly over
/// `window_us` microseconds (one motion tick), but no shorter than `min_period` (the fastest the step
/// interrupt can run) and at least 1. `None` when nothing is pending: the timer stops.
pub fn period(clock_hz: u32, window_us: u32, pending: i32, min_period: u32) -> Option<u32> {
    let steps = u64::from(pending.unsigned_abs());
    if steps == 0 {
        return None;
    }
    let window_cycles = u64::from(clock_hz) * u64::from(window_us) / 1_000_000;
    let period = (window_cycles / steps).min(u64::from(u32::MAX)) as u32;
    Some(period.max(min_period).max(1))
}

#[cfg(test)]
mod tests {
    use super::{period, StepOutput};

    /// Runs the step interrupt until nothing is pending; returns the directions it drove.
    fn drain(out: &StepOutput) -> (u32, u32) {
        let (mut up, mut down) = (0, 0);
        while let Some(positive) = out.take() {
            if positive {
                up += 1;
            } else {
                down += 1;
            }
        }
        (up, down)
    }

    #[test]
    fn every_microstep_becomes_one_pulse_in_its_direction() {
        let out = StepOutput::new();
        assert_eq!(out.add(5), 5);
        assert_eq!(drain(&out), (5, 0));
        assert_eq!(out.add(-3), -3);
        assert_eq!(drain(&out), (0, 3));
        assert_eq!(out.pulses(), 2);
        assert_eq!(out.take(), None);
    }

    #[test]
    fn leftover_steps_carry_over_and_reversals_cancel() {
        let out = StepOutput::new();
        out.add(10);
        for _ in 0..4 {
            out.take();
        }
        // The next tick's move adds to the 6 still pending; a reversal within the tick cancels.
        assert_eq!(out.add(2), 8);
        assert_eq!(out.add(-8), 0);
        assert_eq!(drain(&out), (0, 0));
        assert_eq!(out.pulses(), 4);
    }

    #[test]
    fn pulses_add_up_to_the_core_position_over_a_ramp() {
        // A ramp's per-tick moves, in both directions: the pulse count ends where the core does.
        let out = StepOutput::new();
        let moves: Vec<i64> = (0..200).map(|t| (t % 60) - 20).collect();
        for (n, &m) in moves.iter().enumerate() {
            out.add(m);
            // The timer manages part of the steps in some ticks.
            for _ in 0..(n % 7) * 5 {
                out.take();
            }
        }
        drain(&out);
        assert_eq!(i64::from(out.pulses()), moves.iter().sum::<i64>());
    }

    #[test]
    fn huge_moves_saturate_instead_of_overflowing() {
        let out = StepOutput::new();
        assert_eq!(out.add(i64::MAX), i32::MAX);
        assert_eq!(out.add(1), i32::MAX);
        assert_eq!(out.add(i64::MIN), i32::MIN + i32::MAX);
    }

    #[test]
    fn the_timer_period_spreads_the_steps_over_a_tick() {
        // 50 MHz, 1 ms tick: 51 steps (51200 pps) → 980 cycles apart.
        assert_eq!(period(50_000_000, 1000, 51, 250), Some(980));
        assert_eq!(period(50_000_000, 1000, -1, 250), Some(50_000));
        // Faster than the interrupt can go: capped, the rest carries over.
        assert_eq!(period(50_000_000, 1000, 1000, 250), Some(250));
        assert_eq!(period(50_000_000, 1000, i32::MIN, 0), Some(1));
        assert_eq!(period(50_000_000, 1000, 0, 250), None);
    }
}

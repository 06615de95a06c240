//! The ramp generator of one axis (PD28-1021 manual §3.7.1–3.7.4, chapter 4 AP 0–5, 128, 130).
//!
//! Integer arithmetic only (small MCUs have no FPU): velocities are kept in µpps (10⁻⁶ microsteps per second),
//! so one tick of `dt` µs changes the velocity by exactly `AP5 × dt` µpps and moves the axis by
//! `v × dt` 10⁻¹² microsteps; the remainders are carried, so nothing drifts however long it runs.
//!
//! - **Position mode** (AP 128 = 0, MVP, SAP 0): trapezoidal ramp. The speed rises by AP 5 per second up to
//!   AP 4 and falls again so that it arrives at the target. The ramp starts and ends at AP 130, the
//!   start/stop speed. The braking speed for a remaining distance `d` is `sqrt(2·a·d + vmin²)`, the speed
//!   from which a deceleration `a` ends at `vmin` exactly at the target. A new target during a move
//!   re-plans from the present speed; if the new target is too close to stop for, the axis decelerates
//!   with AP 5, passes it and comes back, as a real ramp generator does. Distances are wrapping
//!   differences of the position counter's width (32 bits on the PD28-1021, 24 on the TMC428
//!   generation): beyond half the counter the axis takes the shorter way round (§3.7.4 note).
//! - **Velocity mode** (AP 128 = 1, ROR/ROL/MST): the speed approaches AP 2 with AP 5 ("the speed will be
//!   changed using the maximum acceleration parameter", Table 15 AP 128), starting from and stopping at
//!   AP 130.
//! - **Limit switches** (AP 12/13; the manual only says they can be disabled): an active switch stops
//!   motion towards it at once (a hard stop, as the switch inputs of Trinamic ramp generators do); motion
//!   away stays possible.

use crate::time::Duration;

mod span;
pub use span::{Bounds, Record, Span, Trail};

/// The motion controller's update period.
pub const TICK: Duration = Duration::from_millis(1);

const MICRO: i64 = 1_000_000;
const PICO: i64 = 1_000_000_000_000;

/// Ramp mode (AP 128).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// 0: position mode.
    #[default]
    Position,
    /// 1: velocity mode.
    Velocity,
}

/// The ramp parameters in force for a tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RampParams {
    /// AP 4, maximum positioning speed (pps), ≥ 1.
    pub max_speed: i32,
    /// AP 5, maximum acceleration (pps²), ≥ 1.
    pub max_accel: i32,
    /// AP 130, start and stop speed (pps), ≥ 0.
    pub min_speed: i32,
}

/// Which directions the limit switches block this tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Limits {
    /// The left switch is active and enabled: no motion in the negative direction.
    pub block_negative: bool,
    /// The right switch is active and enabled: no motion in the positive direction.
    pub block_positive: bool,
}

/// What happened during one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TickResult {
    /// Microsteps moved (signed).
    pub steps: i64,
    /// The axis arrived at its target position during this tick (position mode).
    pub arrived: bool,
    /// The speed changed during this tick (for the boost current, AP 200).
    pub ramping: bool,
    /// A limit switch stopped the axis during this tick.
    pub stopped_by_switch: bool,
}

/// The state of one axis's ramp generator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Ramp {
    /// Position or velocity mode.
    pub mode: Mode,
    /// AP 0.
    pub target_position: i32,
    /// AP 1: the step counter.
    pub position: i32,
    /// AP 2: the velocity-mode target (pps, signed).
    pub target_velocity: i32,
    /// Present velocity in µpps, signed.
    velocity: i64,
    /// Fraction of a microstep travelled, in 10⁻¹² microsteps.
    fraction: i64,
    /// 32 − the position counter's width in bits: positions and distances are sign-extended from it.
    shift: u32,
}

impl Ramp {
    /// Sets the width of the position counter (the model's, 1..=32 bits); positions wrap around at it.
    pub fn set_position_bits(&mut self, bits: u32) {
        self.shift = 32 - bits.clamp(1, 32);
        self.position = self.wrap(self.position);
        self.target_position = self.wrap(self.target_position);
    }

    /// A counter value wrapped to the counter's width (sign-extended).
    #[inline]
    fn wrap(&self, v: i32) -> i32 {
        (v << self.shift) >> self.shift
    }

    /// The distance from the position to the target, the shorter way round the counter.
    #[inline]
    fn distance(&self) -> i64 {
        i64::from(self.wrap(self.target_position.wrapping_sub(self.position)))
    }

    /// AP 3: the present velocity in pps (truncated towards zero).
    #[inline]
    pub fn velocity(&self) -> i32 {
        (self.velocity / MICRO) as i32
    }

    #[cfg(feature = "loop-periods")]
    /// The present velocity in µpps (10⁻⁶ microsteps per second), signed: a tick of `dt` µs moves the
    /// axis by this × `dt` 10⁻¹² microsteps.
    #[inline]
    pub(crate) fn velocity_micro(&self) -> i64 {
        self.velocity
    }

    /// A cruising ramp moved on by ticks whose travel is exactly `steps` whole microsteps (a closed
    /// loop's periods, `module/periods.rs`): the velocity stays and the fraction comes back to where it
    /// was, so those ticks leave only the position moved, wrapped at the counter's width. (A span cannot
    /// give this state: it ends on its last step, before the ticks after it that move none.)
    #[cfg(feature = "loop-periods")]
    #[inline]
    pub(crate) fn cruise_whole(&mut self, steps: i64) {
        self.position = self.wrap(self.position.wrapping_add(steps as i32));
    }

    /// Whether the axis stands still and will stay so without a new command.
    #[inline]
    pub fn is_idle(&self) -> bool {
        self.velocity == 0
            && match self.mode {
                Mode::Position => self.position == self.target_position,
                Mode::Velocity => self.target_velocity == 0,
            }
    }

    /// AP 8: target and actual position are equal ("always set when ... equal", Table 15).
    #[inline]
    pub fn position_reached(&self) -> bool {
        self.position == self.target_position
    }

    /// Starts a move to `target` in position mode (MVP, SAP 0, AAP 0); the target wraps to the counter.
    pub fn move_to(&mut self, target: i32) {
        self.mode = Mode::Position;
        self.target_position = self.wrap(target);
    }

    /// Selects velocity mode with a target velocity (ROR, ROL, MST, SAP 2 in velocity mode).
    pub fn rotate(&mut self, velocity: i32) {
        self.mode = Mode::Velocity;
        self.target_velocity = velocity;
    }

    /// Sets the step counter without moving (SAP 1). A position-mode target follows, so the axis does not
    /// start to move to the old target.
    pub fn set_position(&mut self, position: i32) {
        let position = self.wrap(position);
        if self.mode == Mode::Position && self.velocity == 0 {
            self.target_position = position;
        }
        self.position = position;
        self.fraction = 0;
    }

    /// Sets the present velocity (pps, signed) without a ramp. Only for a change of scale under a running
    /// motor: on the TMC428 the velocity registers hold their value in units while the pulse divisor
    /// changes the clock, so the speed in microsteps per second jumps with it (TMC428 datasheet, the
    /// velocity formula; PDx-113 manual §6).
    pub fn set_velocity(&mut self, pps: i32) {
        self.velocity = i64::from(pps) * MICRO;
        if pps == 0 {
            self.fraction = 0;
        }
    }

    /// In position mode, the direction (±1) in which the ramp accelerates or runs at its top speed in
    /// the coming tick; 0 when it decelerates, stands or is in velocity mode. The TMC428 shows this in
    /// its v_target register, which its ramp sets itself in position mode (PDx-113 manual V1.10 p. 25,
    /// AP 2: v_max while accelerating, 0 when decelerating or at rest).
    pub fn driving(&self, p: &RampParams) -> i32 {
        if self.mode != Mode::Position || self.is_idle() {
            return 0;
        }
        let accel = i64::from(p.max_accel.max(1)) * TICK.micros() as i64;
        let next = self.position_velocity(p, accel, i64::from(p.min_speed.max(0)) * MICRO);
        let same_way = self.velocity == 0 || next.signum() == self.velocity.signum();
        if next != 0 && same_way && next.abs() >= self.velocity.abs() {
            next.signum() as i32
        } else {
            0
        }
    }

    /// Stops at once, without a ramp (limit switches, emergency stops, reset).
    pub fn hard_stop(&mut self) {
        self.velocity = 0;
        self.fraction = 0;
        match self.mode {
            Mode::Position => self.target_position = self.position,
            Mode::Velocity => self.target_velocity = 0,
        }
    }

    /// Advances the ramp by `dt`.
    pub fn tick(&mut self, dt: Duration, p: &RampParams, limits: Limits) -> TickResult {
        let dt_us = dt.micros() as i64;
        let accel = i64::from(p.max_accel.max(1)) * dt_us; // µpps per tick
        let v_min = i64::from(p.min_speed.max(0)) * MICRO;
        let before = self.velocity;
        let mut result = TickResult::default();
        let mut v = match self.mode {
            Mode::Velocity => approach(self.velocity, i64::from(self.target_velocity) * MICRO, accel, v_min),
            Mode::Position => self.position_velocity(p, accel, v_min),
        };
        if (v < 0 && limits.block_negative) || (v > 0 && limits.block_positive) {
            result.stopped_by_switch = before != 0;
            v = 0;
            self.fraction = 0;
        }
        self.velocity = v;
        result.ramping = v != before;
        if v == 0 {
            self.fraction = 0;
            return result;
        }
        // v (µpps) × dt (µs) = 10⁻¹² microsteps. |v| < 2³¹·10⁶ and dt ≤ 10⁶ µs keep this inside i64.
        self.fraction += v * dt_us;
        let steps = self.fraction / PICO;
        self.fraction -= steps * PICO;
        if self.mode == Mode::Position {
            let distance = self.distance();
            let toward = (steps > 0) == (distance > 0);
            if distance != 0 && toward && steps.abs() >= distance.abs() && self.can_stop_at_target(p, distance) {
                // Arrival: land on the target and stop (at AP 130, the stop speed).
                result.steps = distance;
                self.position = self.target_position;
                self.velocity = 0;
                self.fraction = 0;
                result.arrived = true;
                result.ramping = true;
                return result;
            }
        }
        self.position = self.wrap(self.position.wrapping_add(steps as i32));
        result.steps = steps;
        result
    }

    /// The velocity for the next tick in position mode.
    fn position_velocity(&self, p: &RampParams, accel: i64, v_min: i64) -> i64 {
        let distance = self.distance();
        if distance == 0 && self.velocity.abs() <= v_min.max(accel) {
            return 0;
        }
        let dir = if distance != 0 { distance.signum() } else { -self.velocity.signum() };
        let toward = self.velocity * dir; // speed towards the target; negative = moving away
        let v_max = i64::from(p.max_speed.max(1)) * MICRO;
        let v_min = v_min.min(v_max);
        let speed = if toward < 0 {
            // Moving away (the target changed behind us): brake with AP 5, then turn.
            let s = toward + accel;
            if s >= -v_min {
                0
            } else {
                s
            }
        } else {
            let mut up = (toward + accel).min(v_max);
            if toward < v_min {
                up = up.max(v_min); // ramps begin at the start speed AP 130
            }
            // `braking_speed(…, up).max(toward − accel)`, without the square root when the floor wins.
            braking_speed_above(distance.abs(), p.max_accel, v_min, up, toward).max(toward - accel).max(0)
        };
        speed * dir
    }

    /// Whether the present speed is one the ramp could have stopped from at the target (else the axis is
    /// overshooting a target that moved too close, and passes it).
    fn can_stop_at_target(&self, p: &RampParams, distance: i64) -> bool {
        let accel_tick = i64::from(p.max_accel.max(1)) * TICK.micros() as i64;
        let v_min = i64::from(p.min_speed.max(0)) * MICRO;
        self.velocity.abs() <= braking_speed(distance.abs(), p.max_accel, v_min, i64::MAX) + 2 * accel_tick
    }
}

/// The highest speed (µpps) for the coming tick from which the axis can still decelerate with `accel`
/// (pps²) to `v_min` within the `distance` (microsteps) left after the tick: the largest `v` with
/// `v² ≤ 2·a·(d − v·dt) + vmin²`, i.e. `v = sqrt((a·dt)² + 2·a·d + vmin²) − a·dt`. This discrete form keeps
/// the deceleration at AP 5 to the last tick. Returns `cap` when the bound is higher (skips the root).
#[inline]
fn braking_speed(distance: i64, accel: i32, v_min: i64, cap: i64) -> i64 {
    // Fast path, in u64 (most ticks: far from the target, the bound is far above `cap`). With
    // c = ⌈cap/10⁶⌉ and e = ⌈a·dt/10⁶⌉ (pps), c·(c + 2e) ≤ 2·a·d gives
    // cap² + 2·cap·a·dt ≤ 10¹²·(c² + 2·c·e) ≤ 2·a·d·10¹², so (cap + a·dt)² ≤ `sq` below and the exact
    // test would return `cap` too. Otherwise (near the braking point) the exact test decides.
    let a = u64::from(accel.max(1) as u32);
    let c = (cap.max(0) as u64).div_ceil(1_000_000);
    let e = (a * TICK.micros()).div_ceil(1_000_000);
    if c.checked_mul(c + 2 * e).is_some_and(|lhs| lhs <= (2 * a).saturating_mul(distance.unsigned_abs())) {
        return cap;
    }
    braking_speed_exact(distance, accel, v_min, cap)
}

/// `braking_speed(distance, accel, v_min, cap).max(toward − a·dt)` for a speed `toward` ≥ 0 towards the
/// target (`cap` ≥ `toward`): the speed of the coming tick before the final `.max(0)`. Where the bound lies
/// at or below `toward − a·dt` (the usual case while braking, when the deceleration AP 5 itself is the
/// limit) it returns that floor without taking the square root: `sqrt(sq) − a·dt ≤ toward − a·dt` exactly
/// when `sq < (toward + 1)²`.
#[inline]
pub(super) fn braking_speed_above(distance: i64, accel: i32, v_min: i64, cap: i64, toward: i64) -> i64 {
    let a = u64::from(accel.max(1) as u32);
    let c = (cap.max(0) as u64).div_ceil(1_000_000);
    let e = (a * TICK.micros()).div_ceil(1_000_000);
    if c.checked_mul(c + 2 * e).is_some_and(|lhs| lhs <= (2 * a).saturating_mul(distance.unsigned_abs())) {
        return cap;
    }
    let a_dt = i64::from(accel.max(1)) * TICK.micros() as i64;
    let sq = braking_square(distance, accel, v_min);
    let reach = (cap.max(0) as u128).saturating_add(a_dt as u128);
    if reach.saturating_mul(reach) <= sq {
        return cap;
    }
    let next = (toward.max(0) as u128) + 1;
    if sq < next * next {
        return toward - a_dt; // the bound is at or below the floor
    }
    braking_root(sq, a_dt)
}

/// `(a·dt)² + 2·a·d·10¹² + vmin²` (µpps²): the square of the speed from which a deceleration `a` ends at
/// `vmin` after `d` microsteps, plus the discrete form's term (see [`braking_speed`]).
#[inline]
pub(super) fn braking_square(distance: i64, accel: i32, v_min: i64) -> u128 {
    let a_dt = u128::from(accel.max(1) as u32) * TICK.micros() as u128; // µpps per tick
    let v_min = v_min.max(0) as u128;
    a_dt * a_dt
        + 2 * u128::from(accel.max(1) as u32) * distance.unsigned_abs() as u128 * 1_000_000_000_000
        + v_min * v_min
}

/// `sqrt(sq) − a·dt` (µpps), out of line: the one square root of a braking tick.
#[inline(never)]
fn braking_root(sq: u128, a_dt: i64) -> i64 {
    (sq.isqrt() - a_dt as u128) as i64
}

/// [`braking_speed`] without the fast path, in u128 (kept out of line so the fast path stays small).
#[inline(never)]
fn braking_speed_exact(distance: i64, accel: i32, v_min: i64, cap: i64) -> i64 {
    let a_dt = u128::from(accel.max(1) as u32) * TICK.micros() as u128; // µpps per tick
    let v_min = v_min.max(0) as u128;
    // In µpps²: (a·dt)² + 2·a·d·10¹² + vmin².
    let sq = a_dt * a_dt
        + 2 * u128::from(accel.max(1) as u32) * distance.unsigned_abs() as u128 * 1_000_000_000_000
        + v_min * v_min;
    let reach = (cap.max(0) as u128).saturating_add(a_dt);
    if reach.saturating_mul(reach) <= sq {
        return cap;
    }
    (sq.isqrt() - a_dt) as i64
}

/// One velocity-mode step from `v` towards `target` (both µpps) with `accel` per tick, starting from and
/// stopping at `v_min`.
fn approach(v: i64, target: i64, accel: i64, v_min: i64) -> i64 {
    if v == target {
        return v;
    }
    if v != 0 && (target == 0 || (v > 0) != (target > 0)) {
        // Decelerate towards zero first (reversal or stop); below the stop speed, stop.
        let s = v.abs() - accel;
        return if s <= v_min { 0 } else { s * v.signum() };
    }
    let dir = target.signum();
    let (speed, goal) = (v.abs(), target.abs());
    let next = if speed < goal {
        if speed < v_min {
            v_min.min(goal)
        } else {
            (speed + accel).min(goal)
        }
    } else {
        let s = (speed - accel).max(goal);
        if s < v_min && goal < v_min {
            goal
        } else {
            s
        }
    };
    next * dir
}

#[cfg(test)]
mod tests;

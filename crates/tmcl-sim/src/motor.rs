//! The stepper motor and its load: where the rotor is, given where the driver's field is.
//!
//! # The model
//!
//! Positions are in 1/256 microsteps of the motor ("µsteps", 256 per full step, manual §6.1) in the axis
//! frame: the axis's 0 mm or 0° is 0, and the rotor starts at the world's `axis.start`. One electrical
//! period of a hybrid stepper is 4 full steps = 1024 µsteps.
//!
//! - **Powered** (driver on, current > 0): the field at electrical angle θ pulls the rotor with
//!   `T_avail · sin(θ − θ_rotor)`, where `T_avail` is the holding torque scaled by the coil current. The
//!   model is quasi-static: after each move of the field (in sub-steps of at most 128 µsteps, half a full
//!   step or 45° electrical, so the rotor never jumps to the wrong period), the rotor moves along
//!   the direction of the net torque (motor + load) until the net torque no longer overcomes friction.
//!   A load below `T_avail` makes the rotor lag the field by the load angle `asin(T_load / T_avail)`
//!   (at most one full step, 90°). A load above it stops the rotor while the field runs on: once the field
//!   is more than half a period ahead, the rotor falls into the next stable point, 4 full steps behind —
//!   the steps a real stepper loses. Inertia is not a load while powered (quasi-static).
//! - **Freewheeling** (driver off, no current, bridges shut down): only the load, detent torque, friction
//!   and damping act; the rotor and load inertia integrate the motion (semi-implicit Euler, 0.1 ms
//!   steps), so a spring back-drives the shaft and a coasting rotor slows down.
//! - **Loads**: Coulomb friction (opposes motion, holds below its value), a constant torque, a spring
//!   toward a rest position, a scripted external torque (set by the board's timeline), jam regions
//!   (friction of their torque inside), hard end stops (`axis.travel`, the rotor cannot pass them) and
//!   seizures (a point the rotor cannot pass either way while the fault is active).
//! - A world with none of these loads is **trivial**: the powered rotor then sits exactly on the field
//!   (or a whole number of periods from it after freewheeling), in integer µsteps, at the cost of two
//!   additions per update.

use crate::world::{AxisKind, Invalid, Pos, World};
use std::f64::consts::{PI, TAU};
use toml::Spanned;

/// µsteps per full step.
pub const USTEPS_PER_FULL_STEP: i64 = 256;
/// µsteps per electrical period (4 full steps).
pub const USTEPS_PER_PERIOD: i64 = 4 * USTEPS_PER_FULL_STEP;
const PERIOD: f64 = USTEPS_PER_PERIOD as f64;
/// Largest field move between two settles (µsteps): 45° electrical, so a rotor at the 90° limit still
/// sees the field less than 180° ahead and is pulled forward, not back.
const SUBSTEP: i64 = 128;
/// March step of the settle search (µsteps) and its bisection depth (16 / 2^8 = 1/16 µstep).
const MARCH: f64 = 16.0;
const BISECT: u32 = 8;
/// Longest settle march (µsteps): 64 periods. A longer slide continues at the next settle.
const MARCH_LIMIT: u32 = (64 * USTEPS_PER_PERIOD as u32) / MARCH as u32;
/// Freewheeling integration step (s), and the most steps one call integrates (10 s).
const COAST_STEP: f64 = 1e-4;
const COAST_LIMIT: u32 = 100_000;

/// A jam region in µsteps with its torque.
#[derive(Debug, Clone, Copy, PartialEq)]
struct JamZone {
    lo: f64,
    hi: f64,
    torque: f64,
}

/// The motor and its load: constants compiled from the world, and the rotor's state.
#[derive(Debug, Clone)]
pub struct Mechanics {
    /// µsteps per motor revolution.
    upr: f64,
    /// µsteps per axis unit (mm or degree).
    per_unit: f64,
    /// Radians of the motor shaft per µstep.
    rad: f64,
    /// N·m per A RMS.
    torque_per_amp: f64,
    inertia: f64,
    detent: f64,
    damping: f64,
    friction: f64,
    constant: f64,
    /// (N·m per µstep, rest position in µsteps).
    spring: Option<(f64, f64)>,
    jams: Vec<JamZone>,
    travel: (f64, f64),
    /// Where the rotor was at power-up (µsteps).
    start: f64,
    /// Freewheeling integration step (s), shortened for stiff springs.
    coast_step: f64,
    trivial: bool,
    /// The rotor position (µsteps, axis frame).
    rotor: f64,
    /// Rotor speed while freewheeling (rad/s).
    omega: f64,
    /// The field position (µsteps, axis frame): where an unloaded rotor would be.
    field: i64,
    /// The scripted external torque now (N·m).
    script: f64,
    /// Active seizure points (µsteps).
    seized: Vec<f64>,
    /// The torque the motor can give now (N·m); 0 = freewheeling.
    available: f64,
    /// A trivial world only: the rotor sits on a stable point of the field — `field − rotor` is exactly a
    /// whole number of periods, both below [`EXACT`] in magnitude — so [`Mechanics::snap`] would change
    /// nothing and the load angle is ±0. Set by a snap, kept by a powered trivial
    /// [`Mechanics::drive_to`] (the rotor then moves by exactly the field's move), cleared by an
    /// unpowered one (the field moves alone). Nothing else moves the rotor of a trivial world.
    locked: bool,
}

/// How the rotor follows moves of the field (see [`Mechanics::steady`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Follow {
    /// It stays where it is.
    Still,
    /// It moves exactly as far as the field (a trivial world, locked on the field).
    Exact,
    /// It slides behind the field against friction and constant torques, always at the same lag.
    Sliding,
    /// It stays, held by friction, while the field moves towards where its pull overcomes the friction.
    Held,
}

/// A steady way of following ([`Mechanics::steady`]): how, and the rotor positions (µsteps) within
/// which it holds (the rotor's present position lies within them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Steady {
    /// How the rotor follows.
    pub follow: Follow,
    /// The lowest rotor position of the window.
    pub lo: f64,
    /// The highest.
    pub hi: f64,
    /// Sliding: how far the rotor lags the field (µsteps, signed). Held: where the field's pull overcomes
    /// the friction (µsteps): the field stays short of it.
    pub lag: f64,
    /// Sliding: the whole electrical periods the rotor sits behind (negative) or ahead of the field less
    /// the lag, after lost steps; 0 otherwise.
    pub periods: f64,
}

/// Narrows the window `lo..=hi` around `x` so that it does not cross the edges of the zone
/// `zlo..=zhi` (a rotor inside stays inside, one outside stays outside).
pub(crate) fn zone(x: f64, zlo: f64, zhi: f64, lo: &mut f64, hi: &mut f64) {
    if x < zlo {
        *hi = hi.min(zlo);
    } else if x > zhi {
        *lo = lo.max(zhi);
    } else {
        *lo = lo.max(zlo);
        *hi = hi.min(zhi);
    }
}

/// Below this magnitude (2⁵² µsteps) integer positions and their sums are exact in `f64`; beyond it the
/// [`Mechanics::locked`] shortcut steps aside and the full computation runs.
const EXACT: f64 = (1u64 << 52) as f64;

/// Converts a world position to µsteps; `key` names it in errors.
pub(crate) fn usteps(world: &World, pos: &Spanned<Pos>, key: &'static str) -> Result<f64, Invalid> {
    let full_steps = f64::from(*world.motor.full_steps.get_ref());
    let upr = full_steps * USTEPS_PER_FULL_STEP as f64;
    let linear = world.axis.kind == AxisKind::Linear;
    let lead = *world.axis.lead.get_ref();
    let wrong = |unit: &str| {
        let kind = if linear { "linear" } else { "rotary" };
        Err(Invalid::new(pos.span(), key, format!("`{unit}` is not a unit of a {kind} axis")))
    };
    Ok(match *pos.get_ref() {
        Pos::Axis(v) if linear => v / lead * upr,
        Pos::Axis(v) => v / 360.0 * upr,
        Pos::Mm(v) if linear => v / lead * upr,
        Pos::Mm(_) => return wrong("mm"),
        Pos::Deg(v) if !linear => v / 360.0 * upr,
        Pos::Deg(_) => return wrong("deg"),
        Pos::Rev(v) => v * upr,
        Pos::FullSteps(v) => v * USTEPS_PER_FULL_STEP as f64,
        Pos::Usteps(v) => v,
    })
}

/// Checks that a number is finite and at least `min` (or above it if `strict`).
pub(crate) fn positive(v: &Spanned<f64>, key: &'static str, min: f64, strict: bool) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if !x.is_finite() || x < min || (strict && x == min) {
        let rel = if strict { "above" } else { "at least" };
        return Err(Invalid::new(v.span(), key, format!("{x} must be a finite number {rel} {min}")));
    }
    Ok(x)
}

/// Checks a `[from, to]` pair and converts it to µsteps.
pub(crate) fn range(world: &World, at: &Spanned<[Pos; 2]>, key: &'static str) -> Result<(f64, f64), Invalid> {
    let [a, b] = at.get_ref();
    let lo = usteps(world, &Spanned::new(at.span(), *a), key)?;
    let hi = usteps(world, &Spanned::new(at.span(), *b), key)?;
    if lo > hi {
        return Err(Invalid::new(at.span(), key, "the range must be [low, high]"));
    }
    Ok((lo, hi))
}

impl Mechanics {
    /// Checks the mechanical part of a world and compiles it; the rotor starts at `axis.start`.
    pub(crate) fn compile(world: &World) -> Result<Mechanics, Invalid> {
        let m = &world.motor;
        let full_steps = *m.full_steps.get_ref();
        if full_steps == 0 || !full_steps.is_multiple_of(4) || full_steps > 100_000 {
            return Err(Invalid::new(m.full_steps.span(), "motor.full_steps", "must be a positive multiple of 4"));
        }
        let upr = f64::from(full_steps) * USTEPS_PER_FULL_STEP as f64;
        let holding = positive(&m.holding_torque, "motor.holding_torque", 0.0, true)?;
        let rated = positive(&m.rated_current, "motor.rated_current", 0.0, true)?;
        let rotor_inertia = positive(&m.rotor_inertia, "motor.rotor_inertia", 0.0, true)?;
        let detent = positive(&m.detent_torque, "motor.detent_torque", 0.0, false)?;
        let damping = positive(&m.damping, "motor.damping", 0.0, false)?;
        let a = &world.axis;
        let lead = positive(&a.lead, "axis.lead", 0.0, true)?;
        let per_unit = if a.kind == AxisKind::Linear { upr / lead } else { upr / 360.0 };
        let load_inertia = positive(&a.load_inertia, "axis.load_inertia", 0.0, false)?;
        let start = usteps(world, &a.start, "axis.start")?;
        let travel = match &a.travel {
            Some(t) => {
                let (lo, hi) = range(world, t, "axis.travel")?;
                if !(lo..=hi).contains(&start) {
                    return Err(Invalid::new(a.start.span(), "axis.start", "must lie within axis.travel"));
                }
                (lo, hi)
            }
            None => (f64::NEG_INFINITY, f64::INFINITY),
        };
        let l = &world.load;
        let friction = positive(&l.friction, "load.friction", 0.0, false)?;
        if !l.constant.is_finite() {
            return Err(Invalid::new(0..0, "load.constant", "must be finite"));
        }
        let spring = match &l.spring {
            Some(s) => {
                let rate = positive(&s.rate, "load.spring.rate", 0.0, false)?;
                Some((rate / per_unit, usteps(world, &s.rest, "load.spring.rest")?))
            }
            None => None,
        };
        let mut jams = Vec::new();
        for j in &l.jam {
            let (lo, hi) = range(world, &j.at, "load.jam.at")?;
            let torque = positive(&j.torque, "load.jam.torque", 0.0, false)?;
            jams.push(JamZone { lo, hi, torque });
        }
        for s in &l.script {
            if !s.torque.is_finite() {
                return Err(Invalid::new(0..0, "load.script.torque", "must be finite"));
            }
        }
        for s in &world.faults.stall {
            usteps(world, &s.at, "faults.stall.at")?;
        }
        let inertia = rotor_inertia + load_inertia;
        let rad = TAU / upr;
        // Stiffest restoring rate (N·m/rad): spring and detent; keep ω_n · step below 0.5.
        let k = spring.map_or(0.0, |(k, _)| k / rad) + detent * TAU / (USTEPS_PER_FULL_STEP as f64 * rad);
        let coast_step = if k > 0.0 { COAST_STEP.min(0.5 / (k / inertia).sqrt()) } else { COAST_STEP };
        let trivial = friction == 0.0
            && l.constant == 0.0
            && spring.is_none_or(|(k, _)| k == 0.0)
            && jams.is_empty()
            && l.script.iter().all(|s| s.torque == 0.0)
            && world.faults.stall.is_empty()
            && a.travel.is_none()
            && detent == 0.0;
        let field = start.round() as i64;
        Ok(Mechanics {
            upr,
            per_unit,
            rad,
            torque_per_amp: holding / rated,
            inertia,
            detent,
            damping,
            friction,
            constant: l.constant,
            spring,
            jams,
            travel,
            start,
            coast_step,
            trivial,
            rotor: field as f64,
            omega: 0.0,
            field,
            script: 0.0,
            seized: Vec::new(),
            available: 0.0,
            locked: false,
        })
    }

    /// µsteps per motor revolution.
    pub fn usteps_per_rev(&self) -> f64 {
        self.upr
    }

    /// µsteps per axis unit (mm or degree).
    pub fn usteps_per_unit(&self) -> f64 {
        self.per_unit
    }

    /// Where the rotor started (µsteps, axis frame).
    #[inline]
    pub fn start(&self) -> f64 {
        self.start
    }

    /// The rotor position (µsteps, axis frame).
    #[inline]
    pub fn rotor(&self) -> f64 {
        self.rotor
    }

    /// The field position (µsteps, axis frame).
    #[inline]
    pub fn field(&self) -> i64 {
        self.field
    }

    /// Whether the world has no load at all (the exact fast path).
    #[inline]
    pub fn is_trivial(&self) -> bool {
        self.trivial
    }

    /// The torque the motor can give now (N·m).
    #[inline]
    pub fn available(&self) -> f64 {
        self.available
    }

    /// N·m of holding torque per A RMS of coil current.
    #[inline]
    pub fn torque_per_amp(&self) -> f64 {
        self.torque_per_amp
    }

    /// Sets the scripted external torque (N·m).
    pub fn set_script(&mut self, torque: f64) {
        if torque != 0.0 {
            self.load_added();
        }
        self.script = torque;
    }

    /// The scripted external torque now (N·m).
    pub fn script(&self) -> f64 {
        self.script
    }

    /// Sets the active seizure points (µsteps).
    pub fn set_seized(&mut self, points: Vec<f64>) {
        if !points.is_empty() {
            self.load_added();
        }
        self.seized = points;
    }

    /// Whether a seizure holds the rotor now.
    pub fn seized(&self) -> bool {
        !self.seized.is_empty()
    }

    /// Sets the Coulomb friction (N·m, ≥ 0).
    pub fn set_friction(&mut self, friction: f64) {
        if friction != 0.0 {
            self.load_added();
        }
        self.friction = friction;
    }

    /// The Coulomb friction (N·m).
    pub fn friction(&self) -> f64 {
        self.friction
    }

    /// A load came on at run time: the world is no longer trivial (the exact fast path steps aside for
    /// good; the full computation handles any rotor, on the field or not).
    fn load_added(&mut self) {
        self.trivial = false;
        self.locked = false;
    }

    /// Whether the rotor is known to sit exactly on a stable point of the powered field in a trivial
    /// world (see [`Mechanics::is_trivial`]): the load angle is then ±0 and the rotor follows every move of
    /// the field exactly. A shortcut for the board; `false` only means "compute it".
    #[inline]
    pub fn locked(&self) -> bool {
        self.locked && self.available > 0.0
    }

    /// Whether rotor and field are both small enough for exact integer arithmetic in `f64`.
    #[inline]
    fn exact(&self) -> bool {
        self.rotor.abs() < EXACT && (self.field as f64).abs() < EXACT
    }

    /// Electrical load angle (field − rotor) in radians, wrapped to (−π, π].
    pub fn load_angle(&self) -> f64 {
        let diff = self.field as f64 - self.rotor;
        if diff == 0.0 {
            // The rotor on the field (the common case): what the lines below give for +0 (x − x is +0),
            // without the `fmod` call of `rem_euclid`.
            return 0.0;
        }
        let d = diff.rem_euclid(PERIOD);
        let d = if d > PERIOD / 2.0 { d - PERIOD } else { d };
        d * TAU / PERIOD
    }

    /// Full steps the rotor has fallen behind the field, in whole electrical periods (4 full steps each).
    pub fn lost_full_steps(&self) -> i64 {
        let periods = ((self.field as f64 - self.rotor) / PERIOD).round() as i64;
        periods * 4
    }

    /// The external torque on the rotor at `x` (N·m, positive pushes toward +), without friction.
    fn external(&self, x: f64) -> f64 {
        let mut t = self.constant + self.script;
        if let Some((k, rest)) = self.spring {
            t -= k * (x - rest);
        }
        if self.detent != 0.0 {
            t -= self.detent * (TAU * (x - self.start) / USTEPS_PER_FULL_STEP as f64).sin();
        }
        t
    }

    /// The friction magnitude at `x` (N·m).
    fn resist(&self, x: f64) -> f64 {
        let mut f = self.friction;
        for j in &self.jams {
            if (j.lo..=j.hi).contains(&x) {
                f += j.torque;
            }
        }
        f
    }

    /// The load the motor has to hold or move against at the rotor now, in N·m (its magnitude): the
    /// external torque plus friction opposing the direction the field pulls.
    pub fn load_torque(&self) -> f64 {
        let x = self.rotor;
        let ext = self.external(x);
        let pull = self.load_angle();
        let f = self.resist(x);
        if pull > 0.0 {
            (f - ext).max(0.0)
        } else if pull < 0.0 {
            (f + ext).max(0.0)
        } else {
            (ext.abs() - f).max(0.0)
        }
    }

    /// Net torque at `x` with the field on (N·m).
    fn net(&self, x: f64) -> f64 {
        let m = self.available * (TAU * (self.field as f64 - x) / PERIOD).sin();
        m + self.external(x)
    }

    /// The nearest point the rotor cannot pass moving from `x` in direction `s` (±1), if any.
    fn barrier(&self, x: f64, s: f64) -> f64 {
        let mut limit = if s > 0.0 { self.travel.1 } else { self.travel.0 };
        for &p in &self.seized {
            if s * (p - x) >= 0.0 && s * (limit - p) > 0.0 {
                limit = p;
            }
        }
        limit
    }

    /// Sets the torque the motor can give (N·m; 0 = freewheeling). `speed` is the field's speed in µsteps
    /// per second, handed to the freewheeling rotor when the power goes off.
    #[inline]
    pub fn set_available(&mut self, torque: f64, speed: f64) {
        if self.available > 0.0 && torque == 0.0 && !self.trivial {
            self.omega = speed * self.rad;
        } else if torque > 0.0 {
            self.omega = 0.0;
        }
        self.available = torque;
    }

    /// Moves the field to `field` (µsteps), letting the rotor follow. Returns whether the rotor fell more
    /// than a full step (90°) behind the field at some point: a stall.
    #[inline]
    pub fn drive_to(&mut self, field: i64) -> bool {
        let delta = field - self.field;
        if self.available <= 0.0 {
            self.field = field;
            self.locked = false;
            return false;
        }
        if self.trivial {
            // Nothing holds the rotor back: it follows the field's continuous motion exactly.
            self.snap();
            self.field = field;
            self.rotor += delta as f64;
            // Still exactly on a stable point: `rotor + delta` is exact while the true sum is below 2⁵³,
            // and a rounded sum would be at least that, so the check also catches any inexact one.
            self.locked &= self.exact();
            return false;
        }
        self.drive_loaded(field)
    }

    /// [`Mechanics::drive_to`] in a world with loads, powered (out of line: the common cases above stay
    /// small enough to inline).
    #[inline(never)]
    fn drive_loaded(&mut self, field: i64) -> bool {
        let delta = field - self.field;
        if let Some(Steady { follow: Follow::Sliding, lo, hi, lag, periods }) = self.steady(delta.signum()) {
            // Sliding on: every sub-step below settles where `solve` puts it, at `field − lag` with the same
            // lag (and the same whole periods off it), so the last one is all there is to compute (the
            // window keeps jams and stops away).
            let y = if periods == 0.0 { field as f64 - lag } else { field as f64 - lag + periods * PERIOD };
            if y - 1.0 >= lo && y + 1.0 <= hi {
                self.field = field;
                self.rotor = y;
                return false;
            }
        }
        let mut stalled = false;
        let n = (delta.unsigned_abs() as i64 + SUBSTEP - 1) / SUBSTEP;
        let from = self.field;
        for i in 1..=n.max(1) {
            self.field = from + delta * i / n.max(1);
            self.settle();
            stalled |= self.load_angle().abs() > PI / 2.0 + 1e-9;
        }
        stalled
    }

    /// A trivial world, powered: the rotor sits on the nearest stable point of the field.
    #[inline]
    fn snap(&mut self) {
        if self.locked() {
            // Already on a stable point: `behind` is a whole number of periods, so the lines below would
            // give back the same rotor (sparing the `round` call, once per update).
            return;
        }
        let behind = self.field as f64 - self.rotor;
        self.rotor = self.field as f64 - (behind / PERIOD).round() * PERIOD;
        self.locked = self.exact();
    }

    /// Powered: whether [`Mechanics::settle`] would leave the rotor where it is (it is on a stable point,
    /// held by friction, or against a stop). A long slide takes several settles (one marches at most
    /// [`MARCH_LIMIT`] steps), so a rotor still sliding is not settled.
    fn settled(&self) -> bool {
        if self.trivial {
            return self.locked();
        }
        let x = self.rotor;
        let d = self.net(x);
        if d.abs() <= self.resist(x) + 1e-12 * self.available {
            return true;
        }
        let s = d.signum();
        s * (self.barrier(x, s) - x) <= 0.0
    }

    /// Powered: moves the rotor along the net torque until friction holds it (quasi-static).
    #[inline]
    pub fn settle(&mut self) {
        if self.available <= 0.0 {
            return;
        }
        if self.trivial {
            self.snap();
            return;
        }
        self.settle_loaded();
    }

    /// [`Mechanics::settle`] in a world with loads (out of line, as [`Mechanics::drive_loaded`]).
    #[inline(never)]
    fn settle_loaded(&mut self) {
        let mut x = self.rotor;
        let d = self.net(x);
        let tolerance = 1e-12 * self.available;
        if d.abs() <= self.resist(x) + tolerance {
            return;
        }
        let s = d.signum();
        let limit = self.barrier(x, s);
        if s * (limit - x) <= 0.0 {
            return; // against a stop
        }
        if let Some(y) = self.solve(x, s, limit) {
            self.rotor = y;
            return;
        }
        let moving = |m: &Mechanics, y: f64| s * m.net(y) - m.resist(y) > tolerance;
        // A rotor that slides the whole march for sure is moved at once: loads that do not change with
        // the position (no spring, no detent, no jam's edge on the way) and exceed all the torque the
        // motor can give, so that every step of the march would find it moving. (A motor whose current
        // is far below its load slides 64 periods at every settle; the march's 4 096 looks of a sine
        // each made a reference search against such a load take 5 ms a tick: the `event_driven` fuzz
        // target's sixth find.) The one sum differs from the march's 4 096 additions at most in the
        // last bits of the position, in both time modes alike.
        if self.spring.is_none() && self.detent == 0.0 {
            let far = x + s * MARCH * f64::from(MARCH_LIMIT);
            let end = if s * (far - limit) >= 0.0 { limit } else { far };
            let (ext, f) = (self.external(x), self.resist(x));
            // (A margin for the rounding of the sum the look computes, far below any torque that matters.)
            let margin = 1e-9 * (ext.abs() + self.available + f);
            if self.jams_clear(x, end) && s * ext - self.available - f > tolerance + margin {
                self.rotor = end;
                return;
            }
        }
        for _ in 0..MARCH_LIMIT {
            let mut next = x + s * MARCH;
            let hit = s * (next - limit) >= 0.0;
            if hit {
                next = limit;
            }
            if !moving(self, next) {
                let (mut a, mut b) = (x, next);
                for _ in 0..BISECT {
                    let mid = 0.5 * (a + b);
                    if moving(self, mid) {
                        a = mid;
                    } else {
                        b = mid;
                    }
                }
                // The middle of the last interval, unless that is inside a jam the rotor stopped at.
                let mid = 0.5 * (a + b);
                x = if self.resist(mid) > self.resist(a) { a } else { mid };
                break;
            }
            x = next;
            if hit {
                break;
            }
        }
        self.rotor = x;
    }

    /// The quick way to the stop point moving from `x` in direction `s`: solve
    /// `T_avail · sin(θ) = s · friction − external` for the load angle with the loads at the current
    /// estimate, twice (Newton-like on the slowly varying loads). `None` when that is not reliable (the
    /// load exceeds the torque, a barrier or a friction change lies on the way, no convergence): then the
    /// march decides.
    fn solve(&self, x: f64, s: f64, limit: f64) -> Option<f64> {
        let mut y = x;
        let f0 = self.resist(x);
        for _ in 0..3 {
            let need = (s * self.resist(y) - self.external(y)) / self.available;
            if need.abs() > 0.999 {
                return None;
            }
            // The stable point in the rotor's own period: moving from `x` the rotor stops at the first
            // one it meets, whole periods behind (or ahead of) the field after a seizure or a slip.
            let mut next = self.field as f64 - need.asin() * PERIOD / TAU;
            let off = x - next;
            if off.abs() > PERIOD / 2.0 {
                let periods = off / PERIOD;
                let whole = periods as i64 as f64; // toward zero
                let k = if s > 0.0 && whole < periods {
                    whole + 1.0
                } else if s < 0.0 && whole > periods {
                    whole - 1.0
                } else {
                    whole
                };
                next += k * PERIOD;
            }
            let converged = (next - y).abs() < 1e-3;
            y = next;
            if converged {
                let forward = s * (y - x) >= 0.0;
                let clear = s * (limit - y) > 0.0 && self.resist(y) == f0;
                return (forward && clear && self.jams_clear(x, y)).then_some(y);
            }
        }
        None
    }

    /// Whether no jam region begins or ends between `a` and `b`.
    fn jams_clear(&self, a: f64, b: f64) -> bool {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        self.jams.iter().all(|j| !(lo..=hi).contains(&j.lo) && !(lo..=hi).contains(&j.hi))
    }

    /// How the rotor follows the field while the field moves in direction `s` (±1; 0: it stays), if it
    /// does so in a way that many moves give the same rotor as one move of their sum, and the rotor
    /// positions within which that holds (see [`Steady`]). `None`: it does not (a spring or detent
    /// torque, the rotor not yet at its lag, a load the motor cannot move, a coasting rotor).
    pub(crate) fn steady(&self, s: i64) -> Option<Steady> {
        let everywhere =
            |follow| Some(Steady { follow, lo: f64::NEG_INFINITY, hi: f64::INFINITY, lag: 0.0, periods: 0.0 });
        if self.available <= 0.0 {
            // The field moves alone. A trivial world's rotor stays; a loaded one stays while friction holds
            // it (then `coast` changes nothing until the loads do, at a timeline entry).
            let x = self.rotor;
            let held = self.trivial || (self.omega == 0.0 && self.external(x).abs() <= self.resist(x));
            return if held { everywhere(Follow::Still) } else { None };
        }
        if s == 0 {
            // Powered and quasi-static, the rotor moves only when it settles after an update: still if
            // settling would leave it where it is.
            return if self.settled() { everywhere(Follow::Still) } else { None };
        }
        if self.trivial {
            // Exactly on a stable point, it moves by exactly the field's moves while positions are exact.
            return self.locked().then_some(Steady {
                follow: Follow::Exact,
                lo: -EXACT,
                hi: EXACT,
                lag: 0.0,
                periods: 0.0,
            });
        }
        let sf = s as f64;
        let x = self.rotor;
        let need = (sf * self.resist(x) - self.external(x)) / self.available;
        if need.is_nan() || need.abs() > 0.999 {
            return None; // beyond `solve`'s reach: the march decides
        }
        let lag = need.asin() * PERIOD / TAU;
        // The stable point the rotor slides at is the field less the lag, or whole periods behind or ahead
        // of it after lost steps (a seizure, a slip, the bridges off while the field ran on): `solve`
        // puts it at the same `field − lag + k·P` after every move, computed the same way.
        let at_lag = self.field as f64 - lag;
        let periods = ((x - at_lag) / PERIOD).round();
        let sliding = at_lag + periods * PERIOD == x; // (periods 0: exactly at the lag)
        let ahead = self.field as f64 - x;
        if !sliding && self.settled() && sf * (ahead - lag) < -1.0 && ahead.abs() < PERIOD / 4.0 - 1.0 {
            // Held by friction (after a reversal, say): the field moves on alone until its pull, at the lag
            // ahead of the rotor, overcomes the friction; until then every settle leaves the rotor. Within
            // a quarter period of the rotor the pull grows steadily with the field's move all the way there
            // (beyond, after lost steps, it need not).
            return Some(Steady { follow: Follow::Held, lo: x, hi: x, lag: x + lag, periods: 0.0 });
        }
        // Sliding: after each move of the field, `settle` puts the rotor where `solve` finds the lag for
        // the friction and the constant torques, `field − asin(need)·P/2π`, the same number after every
        // move. It is there now if it has moved this way before. (With a spring or a detent torque the lag
        // depends on the position, and `solve` iterates from where the rotor was.)
        if !sliding || self.spring.is_some_and(|(k, _)| k != 0.0) || self.detent != 0.0 {
            return None;
        }
        // Within one friction zone (jams), and before the stop ahead (`solve` needs it clear).
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for j in &self.jams {
            zone(x, j.lo, j.hi, &mut lo, &mut hi);
        }
        let limit = self.barrier(x, sf);
        if sf > 0.0 {
            hi = hi.min(limit);
        } else {
            lo = lo.max(limit);
        }
        Some(Steady { follow: Follow::Sliding, lo, hi, lag, periods })
    }

    /// Freewheeling for `dt` seconds: the load back-drives the rotor against inertia, friction, damping.
    #[inline]
    pub fn coast(&mut self, dt: f64) {
        if self.available > 0.0 || self.trivial || dt <= 0.0 {
            return;
        }
        self.coast_loaded(dt);
    }

    /// [`Mechanics::coast`] when something can move the unpowered rotor (out of line).
    #[inline(never)]
    fn coast_loaded(&mut self, dt: f64) {
        let mut left = dt;
        for _ in 0..COAST_LIMIT {
            if left <= 0.0 {
                break;
            }
            let x = self.rotor;
            let ext = self.external(x);
            let f = self.resist(x);
            if self.omega == 0.0 && ext.abs() <= f {
                return; // held by friction: nothing changes until the loads do
            }
            let h = self.coast_step.min(left);
            let push = if self.omega != 0.0 { self.omega.signum() } else { ext.signum() };
            let a = (ext - self.damping * self.omega - f * push) / self.inertia;
            let mut omega = self.omega + a * h;
            if f > 0.0 && self.omega != 0.0 && omega.signum() != self.omega.signum() {
                omega = 0.0; // friction stopped it
            }
            let mut next = x + omega * h / self.rad;
            if omega != 0.0 {
                let s = omega.signum();
                let limit = self.barrier(x, s);
                if s * (next - limit) >= 0.0 {
                    next = limit;
                    omega = 0.0;
                }
            }
            self.rotor = next;
            self.omega = omega;
            left -= h;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world(toml: &str) -> Mechanics {
        Mechanics::compile(&World::from_toml_str(toml).unwrap()).unwrap()
    }

    #[test]
    fn unloaded_rotor_sits_on_the_field() {
        let mut m = world("");
        assert!(m.is_trivial());
        m.set_available(0.03, 0.0);
        for f in [1, 1000, -5000, 123_456] {
            m.drive_to(f);
            assert_eq!(m.rotor(), f as f64);
        }
    }

    #[test]
    fn load_angle_follows_asin_of_the_load() {
        let mut m = world("[load]\nconstant = -0.015");
        m.set_available(0.03, 0.0);
        m.drive_to(10_000);
        // sin(φ) = 0.5 → φ = 30° = 1024/12 µsteps behind.
        let lag = m.field() as f64 - m.rotor();
        assert!((lag - PERIOD / 12.0).abs() < 0.2, "lag {lag}");
        assert!((m.load_torque() - 0.015).abs() < 1e-6);
    }

    #[test]
    fn a_load_above_the_torque_loses_steps_in_periods() {
        let mut m = world("[load]\nconstant = -0.05");
        m.set_available(0.03, 0.0);
        let stalled = m.drive_to(5_000);
        assert!(stalled);
        // The rotor slides back under the constant load: a whole number of periods lost.
        assert_eq!(m.lost_full_steps() % 4, 0);
        assert!(m.lost_full_steps() > 0);
    }

    /// A rotor that lost whole periods (the load beyond the torque for a while) slides on whole periods
    /// behind the field: `steady` says so, and one move of many µsteps puts it where the moves one by one
    /// do (the quiet window of a board after a fault under a load).
    #[test]
    fn a_rotor_periods_behind_slides_as_steadily() {
        let mut m = world("[load]\nfriction = 0.002\nconstant = -0.05");
        m.set_available(0.03, 0.0);
        assert!(m.drive_to(5_000), "the load beyond the torque stalls the rotor");
        assert!(m.lost_full_steps() > 0);
        // Enough torque again: the rotor locks on whole periods behind and slides on with the field.
        m.set_available(0.2, 0.0);
        let mut f = 5_000;
        for _ in 0..50 {
            f += 17;
            m.drive_to(f);
        }
        let steady = m.steady(1).expect("sliding");
        assert_eq!(steady.follow, Follow::Sliding);
        assert!(steady.periods < 0.0, "whole periods behind: {steady:?}");
        let mut one_by_one = m.clone();
        for _ in 0..100 {
            f += 17;
            one_by_one.drive_to(f);
        }
        m.drive_to(f);
        assert_eq!(m.rotor(), one_by_one.rotor());
    }

    /// A load beyond all the torque the motor gives slides the rotor 64 periods at every settle, in one
    /// step where nothing on the way changes the load (the `event_driven` fuzz target's sixth find: the
    /// march looked 4 096 times), and as the march does where something does: it stops at a jam.
    #[test]
    fn a_load_beyond_the_torque_slides_64_periods_a_settle() {
        let mut m = world("[load]\nconstant = -0.05");
        m.set_available(0.03, 0.0);
        let x = m.rotor();
        m.settle();
        assert_eq!(m.rotor(), x - 64.0 * PERIOD);
        m.settle();
        assert_eq!(m.rotor(), x - 128.0 * PERIOD);
        // A jam on the way that holds the rotor: the march stops at its edge.
        let mut m =
            world("[load]\nconstant = -0.05\n[[load.jam]]\nat = [\"-30000 usteps\", \"-20000 usteps\"]\ntorque = 0.5");
        m.set_available(0.03, 0.0);
        m.settle();
        assert!((m.rotor() + 20_000.0).abs() <= 1.0, "stopped at the jam: {}", m.rotor());
        // A load the torque can hold: the rotor settles behind the field and stays.
        let mut m = world("[load]\nconstant = -0.02");
        m.set_available(0.03, 0.0);
        m.settle();
        let held = m.rotor();
        assert!((held - m.field() as f64).abs() < PERIOD / 4.0, "held near the field: {held}");
        m.settle();
        assert_eq!(m.rotor(), held);
    }
}

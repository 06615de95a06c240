//! Closed-loop control of a stepper from its encoder (TMCM-1310 manual chapter 1 and §3.4; the TMCM-1311
//! sibling's parameters AP 14–29, 111–138, 201, 202, 210, 230–237). Pure, integer-only pieces the module
//! runs once per motion tick (a motor calls them from `axis/closed_loop.rs`).
//!
//! # The model
//!
//! Positions are microsteps of the resolution in force (AP 140). The ramp generator produces the
//! *virtual* position (AP 233), the set point; the encoder gives the *actual* position (AP 1 while the
//! loop is closed, AP 209), counts × full steps per revolution (AP 202) × microsteps per full step /
//! counts per revolution (AP 210). The driver's field — where an unloaded rotor would sit — is what the
//! firmware commands. Each tick:
//!
//! 1. **Position error** e = virtual − actual (AP 237).
//! 2. **Standstill correction** (position hold): while the ramp stands, an integrator moves the set
//!    point by e · AP 136 / 1024 per millisecond, limited to ±AP 138, so that a steady load (a spring,
//!    gravity) is held at the target instead of at the target minus its load angle.
//! 3. **Catch-up**: the field moves with the ramp, plus a correction towards the set point of at most
//!    AP 124 · |e| microsteps per second (a proportional gain in 1/s), never faster than AP 126 (pps).
//!    After a blocked move the motor catches up with the ramp at that velocity.
//! 4. **Commutation limit**: the field never leads (or lags) the measured rotor by more than β (AP 111,
//!    255 ≈ 90° electrical = one full step) plus what the rotor will move in this tick — the ramp's step,
//!    but no more than the rotor moved in the last one (a blocked rotor gets β alone) — and never by half
//!    an electrical period or more. So the field cannot run away from a held rotor: at most the torque
//!    maximum is demanded, and no step is lost — the difference to open loop, where a load above the
//!    holding torque lets the field run on and the rotor drop back four full steps at a time. The window
//!    is centred on the measured rotor, never on a prediction, so a fast rotor cannot drag the field
//!    along with it. Once per millisecond, this limits the closed loop to just under two full steps per
//!    millisecond (10 rev/s of a 200-step motor); a faster ramp runs ahead of the rotor, and the
//!    following error says so. Gamma (AP 230, in 1/256 full step) is the field's lead beyond the ramp's
//!    step: the load angle.
//! 5. **Current scaling** (AP 113–123): the current is AP 6 · scaler / 255. While the regulated error
//!    — gamma (AP 115 = 0) or |e| (AP 115 = 1) — stays above AP 117 for AP 120 ms, the scaler rises by
//!    AP 118; below AP 116 for AP 121 ms it falls by AP 119; it stays within AP 113..=AP 114. With
//!    AP 122 = 0 it stays at AP 114. A light load runs at low current, a heavy one gets what it needs.
//! 6. **Following error**: |e| above AP 125 (0 = off) stops the ramp at the rotor (the virtual position
//!    becomes the actual one: no catch-up jump later), sets AP 207's deviation bit and raises
//!    interrupt 21, as the PD28-1021's deviation check does (its manual §6.2).
//!
//! **Torque mode** (AP 14, target current in mA, signed): the ramp stands at the rotor, the field leads
//! the rotor by β in the sign's direction — the torque maximum per ampere — and the current approaches
//! the target at AP 20 mA/s (0 = at once). Any motion command leaves torque mode.
//!
//! **Encoder initialisation** (AP 132 := 1, pytrinamic's closed-loop demo): with the motor at rest the
//! field holds for 100 ms, moves one electrical period (4 full steps) forward in 100 ms and back in
//! 100 ms at run current. The counts over the forward move must be those AP 210 and AP 202 predict
//! (±25 %) and in the motor's direction; then AP 112 takes the counts at electrical angle 0, the encoder
//! position is aligned with the step counter and AP 132 reads 2. Otherwise (no encoder, wrong
//! resolution, a reversed encoder, a blocked rotor) it reads 3 and the loop cannot close. A move during
//! the sequence aborts it (AP 132 reads 0).
//!
//! **Closing the loop** (AP 129 := 1): once the initialisation is done the loop closes at the next tick
//! (AP 133 reads 1); the virtual position is set to the rotor's, so closing never moves the motor.
//! Opening it makes the field the step counter again, where it stands.
//!
//! **I²t** (AP 25–29): the sum S (mA²·s) follows dS/dt = I² − S/τ (AP 25, ms) with I the RMS coil
//! current, so S settles at I²·τ. Above the limit AP 26 (0 = off) the flag (status bit 13) is set,
//! the counter AP 28 counts the event, and the current is held at the standby current AP 7 until the
//! sum is below the limit again; AP 29 clears the flag. It runs with the closed loop.
//!
//! **At rest** (a loop that sleeps): while the ramp stands and the rotor stands on the encoder reading
//! the loop last took, with no error, the controller's next tick leaves the field, the integrator and
//! gamma where they are; if the current scaler cannot move either (at its limit in the direction the
//! regulated error pushes it, or the error between the limits), every further tick changes only what
//! counts: the velocity window fills with zeros, the scaler's millisecond counters run round, and the
//! I²t sum runs on towards I²·τ. [`ClosedLoop::rest`] takes such ticks in closed form — the counters by
//! arithmetic, the I²t sum one tick at a time in a tight loop, up to its fixed point (after which
//! nothing changes at all) or to the tick at which it crosses its limit (which changes the current:
//! that tick is ticked). The result is that of ticking them (`tests/event_driven.rs` in `tmcl-sim`).
//! In open loop (the TMCM-1310 measures AP 131 from its encoder) a standing rotor's ticks only fill the
//! velocity window with zeros.
//!
//! # Constants and units
//! - β and gamma: 256 = one full step (90° electrical); β in microsteps = AP 111 · 2^res / 256, at least 1.
//! - The status word's supply limits are the board's 10–51 V (the CoE manual of the same board).
//! - The hold integrator works in 1/1024 of the error per millisecond; the correction velocity rounds up
//!   to whole microsteps per tick.

use crate::time::Duration;

/// AP 131 averages the rotor's moves over this many ticks (ms): one encoder count in the window is
/// 1000 / 32 counts per second of noise — 390 pps with 4096 counts per revolution at 256 microsteps —
/// for a lag of 16 ms.
pub const VELOCITY_WINDOW: usize = 32;

/// Encoder initialisation phases, each [`INIT_PHASE`] long.
pub const INIT_PHASE: Duration = Duration::from_millis(100);

/// AP 132's states.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Init {
    /// Not initialised (reads 0).
    #[default]
    Idle,
    /// Running (reads 1).
    Running {
        /// Microseconds into the sequence.
        elapsed_us: u64,
        /// Counts at the end of the hold phase.
        start_counts: i64,
        /// Field offset at the start.
        start_offset: i64,
        /// The forward move's verdict, once it is known.
        ok: Option<bool>,
    },
    /// Done (reads 2).
    Done,
    /// Failed (reads 3).
    Failed,
}

impl Init {
    /// AP 132's value.
    pub fn code(self) -> i32 {
        match self {
            Init::Idle => 0,
            Init::Running { .. } => 1,
            Init::Done => 2,
            Init::Failed => 3,
        }
    }
}

/// The closed loop's state (RAM, reset at every start).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ClosedLoop {
    /// AP 132.
    pub init: Init,
    /// The loop is closed (AP 133).
    pub active: bool,
    /// Field position minus the ramp's position, microsteps: 0 in open loop.
    pub field_offset: i64,
    /// The standstill integrator's set-point shift, in 1/1024 microstep.
    pub hold: i64,
    /// AP 123.
    pub scaler: u8,
    /// Milliseconds the regulated error has been above the upper / below the lower limit.
    pub up_ms: u32,
    /// See `up_ms`.
    pub down_ms: u32,
    /// AP 230 (1/256 full step, signed).
    pub gamma: i32,
    /// AP 237 (microsteps).
    pub error: i32,
    /// The actual (encoder) position at the last tick.
    pub actual: i64,
    /// How far the rotor moved in the last tick (microsteps).
    pub last_move: i64,
    /// Rotor moves of the last [`VELOCITY_WINDOW`] ticks (AP 131 = their sum · 1000 / the window).
    pub moves: [i16; VELOCITY_WINDOW],
    /// Where in `moves` the next one goes.
    pub moves_at: u8,
    /// The rotor's move and the time since the last whole millisecond (sub-ticks).
    pub pending_move: i64,
    /// See `pending_move`.
    pub pending_us: i64,
    /// Torque mode: (target, actual) current in mA.
    pub torque: Option<(i32, i32)>,
    /// I²t sum (mA²·s).
    pub i2t: i64,
    /// I²t flag (status bit 13).
    pub i2t_exceeded: bool,
    /// AP 28.
    pub i2t_count: u32,
    /// The current is limited by I²t now.
    pub i2t_limiting: bool,
}

impl ClosedLoop {
    /// Whether the loop needs a tick every millisecond: closed, or initialising.
    #[inline]
    pub fn engaged(&self) -> bool {
        self.active || matches!(self.init, Init::Running { .. })
    }

    /// AP 131: the velocity measured over the last [`VELOCITY_WINDOW`] ticks, pps.
    pub fn measured_velocity(&self) -> i32 {
        let sum: i64 = self.moves.iter().map(|m| i64::from(*m)).sum();
        (sum * 1000 / VELOCITY_WINDOW as i64) as i32 // |sum| ≤ 32 · 32768
    }

    /// Records the rotor's move over `dt_us` (a tick, or part of one while a reference search looks at
    /// its switches after every microstep); returns whether a whole millisecond is complete, for the
    /// per-millisecond regulators. The velocity window takes whole milliseconds.
    pub fn record_move(&mut self, moved: i64, dt_us: i64) -> bool {
        self.last_move = moved;
        self.pending_move += moved;
        self.pending_us += dt_us;
        if self.pending_us < 1000 {
            return false;
        }
        let at = usize::from(self.moves_at) % VELOCITY_WINDOW;
        self.moves[at] = self.pending_move.clamp(i16::MIN.into(), i16::MAX.into()) as i16;
        self.moves_at = ((at + 1) % VELOCITY_WINDOW) as u8;
        self.pending_move = 0;
        self.pending_us = 0;
        true
    }
}

/// What the position controller reads, per tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoopParams {
    /// β in microsteps (at least 1).
    pub beta: i64,
    /// Half an electrical period less one microstep: the lead never reaches it.
    pub max_lead: i64,
    /// AP 124 (1/s).
    pub gain: i64,
    /// AP 126 (pps).
    pub max_correction: i64,
    /// AP 136 (1/1024 per ms).
    pub hold_gain: i64,
    /// AP 138 (microsteps).
    pub hold_limit: i64,
    /// Tick length in µs.
    pub dt_us: i64,
}

/// The controller's answer for one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldCommand {
    /// The new field position.
    pub field: i64,
    /// The new integrator value (1/1024 microstep).
    pub hold: i64,
}

/// β (AP 111, 256 = one full step) in microsteps at resolution `res` (AP 140), at least 1.
pub fn beta_usteps(beta: i32, res: u8) -> i64 {
    ((i64::from(beta.clamp(0, 256)) << res.min(8)) / 256).max(1)
}

/// What the position controller sees in one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoopInput {
    /// The ramp's position now (after this tick's move).
    pub virtual_pos: i64,
    /// How far the ramp moved this tick.
    pub step: i64,
    /// The ramp is idle (standstill correction runs).
    pub standing: bool,
    /// The rotor's position (encoder).
    pub actual: i64,
    /// How far the rotor moved in the last tick.
    pub rotor_move: i64,
    /// The field's position before this tick.
    pub field: i64,
    /// The hold integrator (1/1024 microstep).
    pub hold: i64,
}

/// One tick of the position controller (steps 2–4 of the module docs): the new field position.
pub fn control(p: &LoopParams, input: &LoopInput) -> FieldCommand {
    let LoopInput { virtual_pos, step, standing, actual, rotor_move, field, hold } = *input;
    let e = virtual_pos - actual;
    let hold = if standing {
        let limit = p.hold_limit.saturating_mul(1024);
        (hold + e * p.hold_gain * p.dt_us / 1000).clamp(-limit, limit)
    } else {
        hold
    };
    let set_point = virtual_pos + hold / 1024;
    // Catch-up: the ramp's move plus at most gain·|e| (≤ AP 126) pps for this tick, rounded up.
    let correction_pps = (p.gain.saturating_mul(e.abs())).min(p.max_correction);
    let correction = (correction_pps * p.dt_us + 999_999) / 1_000_000;
    let base = field + step;
    let mut f = set_point.clamp(base - correction, base + correction);
    // Commutation limit around the measured rotor: β plus this tick's motion (the ramp's step, at most
    // what the rotor moved last tick), below half a period.
    let lead = (p.beta + step.abs().min(rotor_move.abs())).min(p.max_lead);
    f = f.clamp(actual - lead, actual + lead);
    FieldCommand { field: f, hold }
}

/// What the ticks of a loop at rest depend on besides its state ([`ClosedLoop::rest`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RestParams {
    /// The position controller's parameters.
    pub control: LoopParams,
    /// One full step in microsteps (gamma's unit).
    pub full_step: i64,
    /// The current scaling.
    pub scale: ScaleParams,
    /// The regulated error takes |e| (AP 115 = 1), not |gamma|.
    pub scale_on_error: bool,
    /// The RMS coil current (mA) while the loop rests: constant, since the scaler and the I²t limiting are.
    pub rms_ma: i64,
    /// AP 25 (ms).
    pub tau_ms: i64,
    /// AP 26 (0 = off).
    pub i2t_limit: i64,
}

/// A millisecond counter of the current scaling after `ticks` ticks (≥ 1) in one branch: each tick adds
/// one and a count that reaches `period` starts again at 0.
fn counter_after(count: u32, period: u32, ticks: u64) -> u32 {
    let period = u64::from(period.max(1));
    let first = if u64::from(count) + 1 >= period { 0 } else { u64::from(count) + 1 };
    ((first + (ticks - 1) % period) % period) as u32
}

impl ClosedLoop {
    /// Records `ticks` whole ticks in which the rotor did not move (the velocity window fills with zeros)
    /// — what [`ClosedLoop::record_move`] does at each of them. Only between whole ticks (nothing
    /// pending); returns whether it could.
    pub fn record_still(&mut self, ticks: u64) -> bool {
        if self.pending_us != 0 || self.pending_move != 0 {
            return false;
        }
        if ticks == 0 {
            return true;
        }
        let at = usize::from(self.moves_at) % VELOCITY_WINDOW;
        for k in 0..(ticks.min(VELOCITY_WINDOW as u64) as usize) {
            self.moves[(at + k) % VELOCITY_WINDOW] = 0;
        }
        self.moves_at = ((at as u64 + ticks % VELOCITY_WINDOW as u64) % VELOCITY_WINDOW as u64) as u8;
        self.last_move = 0;
        true
    }

    /// Passes over `ticks` ticks whose moves are not recorded: only where the next move goes into the
    /// velocity window moves on. (For a span of ticks in open loop whose last [`VELOCITY_WINDOW`] + 1
    /// ticks are ticked: those overwrite every slot, and the first of them `actual` and the pending
    /// move.)
    pub fn skip_ticks(&mut self, ticks: u64) {
        let window = VELOCITY_WINDOW as u64;
        self.moves_at = ((u64::from(self.moves_at) % window + ticks % window) % window) as u8;
    }

    /// Whether the closed loop is at rest (see the module docs) with the ramp standing at the rotor:
    /// the next tick of the controller and of the current scaling changes nothing but counters and the
    /// I²t sum. The caller has checked that the ramp stands where the encoder reads (`error` 0 now) and
    /// that the rotor has not moved since the last tick.
    pub fn at_rest(&self, p: &RestParams) -> bool {
        if !self.active
            || self.torque.is_some()
            || matches!(self.init, Init::Running { .. })
            || self.error != 0
            || self.last_move != 0
            || self.pending_us != 0
            || self.pending_move != 0
            || self.moves.iter().any(|m| *m != 0)
        {
            return false;
        }
        // The controller, relative to the rotor (as the module calls it): no error, no step, the field
        // where it is.
        let input = LoopInput {
            virtual_pos: 0,
            step: 0,
            standing: true,
            actual: 0,
            rotor_move: 0,
            field: self.field_offset,
            hold: self.hold,
        };
        let c = control(&p.control, &input);
        let gamma = (c.field * 256 / p.full_step.max(1)).clamp(-256, 256) as i32;
        if c.field != self.field_offset || c.hold != self.hold || gamma != self.gamma {
            return false;
        }
        // The scaler stays where it is at every tick from now on.
        let s = &p.scale;
        let (lo, hi) = (s.min.min(s.max), s.max);
        let error = self.regulated(p);
        if !s.enabled {
            self.scaler == hi && self.up_ms == 0 && self.down_ms == 0
        } else if error > s.upper {
            self.scaler.saturating_add(s.increment).clamp(lo, hi) == self.scaler
        } else if error < s.lower {
            self.scaler.saturating_sub(s.decrement).clamp(lo, hi) == self.scaler
        } else {
            self.scaler.clamp(lo, hi) == self.scaler
        }
    }

    /// The error the current scaling regulates at rest: |gamma|, or |e| = 0.
    fn regulated(&self, p: &RestParams) -> i64 {
        if p.scale_on_error {
            0
        } else {
            i64::from(self.gamma.unsigned_abs())
        }
    }

    /// Takes up to `ticks` ticks of a loop [at rest](ClosedLoop::at_rest) in closed form, exactly as
    /// ticking them would; stops before a tick at which the I²t monitor would start or stop limiting the
    /// current (that tick changes the current: it is ticked). Returns how many it took.
    pub fn rest(&mut self, p: &RestParams, ticks: u64) -> u64 {
        let (taken, sum) = self.i2t_ahead(p.rms_ma, p.tau_ms, p.i2t_limit, ticks);
        if taken == 0 {
            return 0;
        }
        self.i2t = sum;
        self.record_still(taken);
        let s = &p.scale;
        let error = self.regulated(p);
        if !s.enabled || (s.lower..=s.upper).contains(&error) {
            self.up_ms = 0;
            self.down_ms = 0;
        } else if error > s.upper {
            self.down_ms = 0;
            self.up_ms = counter_after(self.up_ms, s.up_ms, taken);
        } else {
            self.up_ms = 0;
            self.down_ms = counter_after(self.down_ms, s.down_ms, taken);
        }
        taken
    }
}

impl ClosedLoop {
    /// The I²t sum after up to `ticks` whole ticks at a constant RMS current `rms_ma`, as ticking gives
    /// it, and how many ticks that is: it stops before a tick at which the monitor would start or stop
    /// limiting the current (that tick changes the current). Tick by tick up to the sum's fixed point
    /// (where the gain and the decay of a tick are equal: from there on every tick leaves it as it is).
    pub fn i2t_ahead(&self, rms_ma: i64, tau_ms: i64, limit: i64, ticks: u64) -> (u64, i64) {
        let (mut taken, mut sum) = (0, self.i2t);
        while taken < ticks {
            let next = i2t_sum(sum, rms_ma, 1000, tau_ms);
            if (limit > 0 && next > limit) != self.i2t_limiting {
                break;
            }
            taken += 1;
            if next == sum {
                taken = ticks;
            }
            sum = next;
        }
        (taken, sum)
    }

    /// The rotor's moves in the velocity window, oldest first.
    fn window(&self) -> impl Iterator<Item = i16> + '_ {
        let at = usize::from(self.moves_at) % VELOCITY_WINDOW;
        (0..VELOCITY_WINDOW).map(move |k| self.moves[(at + k) % VELOCITY_WINDOW])
    }

    /// Whether the loop is where `earlier` was, moved on by `shift` microsteps: the same state in every
    /// respect but the I²t sum (which runs on towards its fixed point, [`ClosedLoop::i2t_ahead`]), the
    /// rotor's position `shift` further, and the velocity window holding the same moves (the slot the
    /// next one goes to may differ). Whole ticks only.
    pub fn repeats(&self, earlier: &ClosedLoop, shift: i64) -> bool {
        let same_but =
            |cl: &ClosedLoop| ClosedLoop { i2t: 0, actual: 0, moves: [0; VELOCITY_WINDOW], moves_at: 0, ..*cl };
        self.pending_us == 0
            && earlier.pending_us == 0
            && self.actual == earlier.actual.wrapping_add(shift)
            && same_but(self) == same_but(earlier)
            && self.window().eq(earlier.window())
    }

    /// Takes `periods` more periods of `ticks` ticks each of a loop that [repeats](ClosedLoop::repeats)
    /// with a move of `shift` microsteps a period, exactly as ticking them would: the rotor `periods` ×
    /// `shift` further on, the velocity window's next slot `periods` × `ticks` on with the same moves in
    /// it, and the I²t sum `i2t` (from [`ClosedLoop::i2t_ahead`]).
    pub fn repeat(&mut self, periods: u64, ticks: u64, shift: i64, i2t: i64) {
        let moves: [i16; VELOCITY_WINDOW] = core::array::from_fn({
            let window = self.moves;
            let at = usize::from(self.moves_at) % VELOCITY_WINDOW;
            move |k| window[(at + k) % VELOCITY_WINDOW]
        });
        let n = VELOCITY_WINDOW as u64;
        let at = ((u64::from(self.moves_at) % n + periods % n * (ticks % n)) % n) as usize;
        for (k, m) in moves.iter().enumerate() {
            self.moves[(at + k) % VELOCITY_WINDOW] = *m;
        }
        self.moves_at = at as u8;
        self.actual = self.actual.wrapping_add((periods as i64).wrapping_mul(shift));
        self.i2t = i2t;
    }
}

impl ClosedLoop {
    /// Whether the current scaling leaves the scaler where it is at every millisecond of a run in which
    /// the error it regulates (|gamma| or |e|, step 5 of the module docs) stays within `error` (lowest,
    /// highest, both ≥ 0): every millisecond takes the same branch, and that branch cannot move the
    /// scaler (it stands at the limit the branch pushes it to, or the scaling is off). So the current the
    /// loop drives stays as it is.
    pub fn scaler_stays(&self, s: &ScaleParams, error: (i64, i64)) -> bool {
        let (lo, hi) = (s.min.min(s.max), s.max);
        if !s.enabled {
            return self.scaler == hi;
        }
        // Along a rising error the branches follow each other down, between, up: a range of errors takes
        // one branch if its ends do.
        let branch = Branch::of(s, error.0);
        if branch != Branch::of(s, error.1) {
            return false;
        }
        let next = match branch {
            Branch::Up => self.scaler.saturating_add(s.increment),
            Branch::Down => self.scaler.saturating_sub(s.decrement),
            Branch::Between => self.scaler,
        };
        next.clamp(lo, hi) == self.scaler
    }

    /// Takes `ticks` whole ticks of a loop whose rotor stands on the field and whose controller leaves
    /// the field on the ramp (`module/loop_span.rs` checks both), the error the current scaling regulates
    /// within `error` all through, where [`ClosedLoop::scaler_stays`]: the scaling's millisecond counters
    /// as ticking leaves them, the I²t sum `i2t` (from [`ClosedLoop::i2t_ahead`] at the loop's constant
    /// current), and the velocity window's next slot moved on ([`ClosedLoop::skip_ticks`]; the moves of
    /// the last ticks are [`ClosedLoop::measured`]'s). The field's offset from the ramp, the hold
    /// integrator and the scaler stay.
    pub fn run_locked(&mut self, s: &ScaleParams, error: (i64, i64), ticks: u64, i2t: i64) {
        if ticks == 0 {
            return;
        }
        match Branch::of(s, error.0) {
            _ if !s.enabled => (self.up_ms, self.down_ms) = (0, 0),
            Branch::Between => (self.up_ms, self.down_ms) = (0, 0),
            Branch::Up => (self.up_ms, self.down_ms) = (counter_after(self.up_ms, s.up_ms, ticks), 0),
            Branch::Down => (self.up_ms, self.down_ms) = (0, counter_after(self.down_ms, s.down_ms, ticks)),
        }
        self.i2t = i2t;
        self.skip_ticks(ticks);
    }
}

impl ClosedLoop {
    /// After [`ClosedLoop::run_locked`] took `ticks` ticks: what the loop measured at the last of them,
    /// from `actuals`, the rotor's positions at the start of each of the last `actuals.len() − 1` ticks
    /// and at the one before them: their moves in the velocity window's slots (the next slot has moved
    /// on already), the last move and the rotor's position.
    pub fn measured(&mut self, actuals: &[i64], ticks: u64) {
        let n = actuals.len().saturating_sub(1);
        if n == 0 || ticks < n as u64 {
            return;
        }
        let window = VELOCITY_WINDOW;
        let first = (usize::from(self.moves_at) % window + window - n % window) % window;
        for (i, pair) in actuals.windows(2).enumerate() {
            let moved = pair[1] - pair[0];
            self.moves[(first + i) % window] = moved.clamp(i16::MIN.into(), i16::MAX.into()) as i16;
            self.last_move = moved;
        }
        self.actual = actuals[n];
    }
}

/// Which way one millisecond of current scaling goes for a regulated error ([`scale`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Branch {
    /// Above the upper limit: the up counter runs.
    Up,
    /// Below the lower limit (and not above the upper): the down counter runs.
    Down,
    /// Within the limits: both counters are reset.
    Between,
}

impl Branch {
    fn of(s: &ScaleParams, error: i64) -> Self {
        if error > s.upper {
            Branch::Up
        } else if error < s.lower {
            Branch::Down
        } else {
            Branch::Between
        }
    }
}

/// Current-scaling parameters (AP 113–122).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScaleParams {
    /// AP 122.
    pub enabled: bool,
    /// AP 113.
    pub min: u8,
    /// AP 114.
    pub max: u8,
    /// AP 116.
    pub lower: i64,
    /// AP 117.
    pub upper: i64,
    /// AP 118.
    pub increment: u8,
    /// AP 119.
    pub decrement: u8,
    /// AP 120 (ms).
    pub up_ms: u32,
    /// AP 121 (ms).
    pub down_ms: u32,
}

/// One millisecond of current scaling (step 5 of the module docs) for the regulated `error` (≥ 0).
pub fn scale(cl: &mut ClosedLoop, p: &ScaleParams, error: i64) {
    let (lo, hi) = (p.min.min(p.max), p.max);
    if !p.enabled {
        cl.scaler = hi;
        cl.up_ms = 0;
        cl.down_ms = 0;
        return;
    }
    match Branch::of(p, error) {
        Branch::Up => {
            cl.down_ms = 0;
            if runs_out(&mut cl.up_ms, p.up_ms) {
                cl.scaler = cl.scaler.saturating_add(p.increment);
            }
        }
        Branch::Down => {
            cl.up_ms = 0;
            if runs_out(&mut cl.down_ms, p.down_ms) {
                cl.scaler = cl.scaler.saturating_sub(p.decrement);
            }
        }
        Branch::Between => {
            cl.up_ms = 0;
            cl.down_ms = 0;
        }
    }
    cl.scaler = cl.scaler.clamp(lo, hi);
}

/// One millisecond of a counter of the current scaling (AP 120, 121: `period` ms, at least 1): whether
/// it ran out (and starts again at 0).
fn runs_out(count: &mut u32, period: u32) -> bool {
    *count += 1;
    let out = *count >= period.max(1);
    if out {
        *count = 0;
    }
    out
}

/// The I²t sum after `rms_ma` flowed for `dt_us` with time constant `tau_ms`: dS = I²·dt − S·dt/τ,
/// in mA²·s.
#[inline]
pub fn i2t_sum(sum: i64, rms_ma: i64, dt_us: i64, tau_ms: i64) -> i64 {
    let tau_us = tau_ms.max(1) * 1000;
    let gain = rms_ma * rms_ma * dt_us / 1_000_000;
    (sum + gain - sum * dt_us / tau_us).max(0)
}

/// One tick of the I²t monitor: `rms_ma` flowing for `dt_us`, time constant `tau_ms`, limit (0 = off).
/// Returns whether the sum is above the limit now.
pub fn i2t(cl: &mut ClosedLoop, rms_ma: i64, dt_us: i64, tau_ms: i64, limit: i64) -> bool {
    cl.i2t = i2t_sum(cl.i2t, rms_ma, dt_us, tau_ms);
    let over = limit > 0 && cl.i2t > limit;
    if over && !cl.i2t_limiting {
        cl.i2t_exceeded = true;
        cl.i2t_count = cl.i2t_count.wrapping_add(1);
    }
    cl.i2t_limiting = over;
    over
}

/// Status word bits (AP 18; TMCM-1310 manual §3.4's table, bits 12–13 from the TMCM-1311 manual p.68).
pub mod status {
    /// Target position reached.
    pub const TARGET_REACHED: u32 = 1 << 0;
    /// Velocity reached.
    pub const VELOCITY_REACHED: u32 = 1 << 1;
    /// The loop is closed.
    pub const CLOSED_LOOP: u32 = 1 << 2;
    /// Position mode.
    pub const POSITION_MODE: u32 = 1 << 3;
    /// Velocity mode.
    pub const VELOCITY_MODE: u32 = 1 << 4;
    /// Torque mode.
    pub const TORQUE_MODE: u32 = 1 << 5;
    /// Home switch.
    pub const HOME: u32 = 1 << 6;
    /// Left stop switch.
    pub const LEFT: u32 = 1 << 7;
    /// Right stop switch.
    pub const RIGHT: u32 = 1 << 8;
    /// Supply below 10 V.
    pub const UNDERVOLTAGE: u32 = 1 << 9;
    /// Supply above 51 V.
    pub const OVERVOLTAGE: u32 = 1 << 10;
    /// The driver reports overtemperature.
    pub const OVERTEMPERATURE: u32 = 1 << 11;
    /// Holding a position in closed loop.
    pub const POSITION_HOLD: u32 = 1 << 12;
    /// I²t exceeded (cleared by AP 29).
    pub const I2T_EXCEEDED: u32 = 1 << 13;
}

/// Undervoltage and overvoltage limits of the status word, in 0.1 V (the board's 10–51 V).
pub const SUPPLY_LIMITS: (u16, u16) = (100, 510);

#[cfg(test)]
mod tests {
    use super::*;

    const P: LoopParams = LoopParams {
        beta: 255,
        max_lead: 511,
        gain: 20,
        max_correction: 51200,
        hold_gain: 64,
        hold_limit: 512,
        dt_us: 1000,
    };

    #[test]
    fn unloaded_the_field_is_the_ramp() {
        // Rotor on the field, field on the ramp: the field moves with the ramp, as in open loop.
        let c = control(
            &P,
            &LoopInput {
                virtual_pos: 1051,
                step: 51,
                standing: false,
                actual: 1000,
                rotor_move: 51,
                field: 1000,
                hold: 0,
            },
        );
        assert_eq!(c.field, 1051);
    }

    #[test]
    fn a_held_rotor_is_led_by_at_most_beta() {
        // The ramp ran 10000 microsteps ahead of a blocked rotor: the field leads it by β, not more.
        let c = control(
            &P,
            &LoopInput {
                virtual_pos: 10_000,
                step: 51,
                standing: false,
                actual: 0,
                rotor_move: 0,
                field: 255,
                hold: 0,
            },
        );
        assert_eq!(c.field, 255);
        let c = control(
            &P,
            &LoopInput {
                virtual_pos: -10_000,
                step: -51,
                standing: false,
                actual: 0,
                rotor_move: 0,
                field: -255,
                hold: 0,
            },
        );
        assert_eq!(c.field, -255);
    }

    #[test]
    fn catch_up_is_limited_by_the_correction_velocity() {
        // The rotor is free again 5000 behind: the field moves by the ramp's step plus 51 (51200 pps).
        let c = control(
            &P,
            &LoopInput { virtual_pos: 5000, step: 0, standing: false, actual: 0, rotor_move: 0, field: 0, hold: 0 },
        );
        assert_eq!(c.field, 52);
        // A small error: gain 20/s · 100 = 2000 pps = 2 per tick.
        let c = control(
            &P,
            &LoopInput { virtual_pos: 100, step: 0, standing: false, actual: 0, rotor_move: 0, field: 0, hold: 0 },
        );
        assert_eq!(c.field, 2);
    }

    #[test]
    fn the_hold_integrator_pulls_a_loaded_rotor_to_the_target() {
        let mut hold = 0;
        let mut field = 0;
        // A load angle of 100: the rotor sits 100 behind the field.
        for _ in 0..2000 {
            let c = control(
                &P,
                &LoopInput { virtual_pos: 0, step: 0, standing: true, actual: field - 100, rotor_move: 0, field, hold },
            );
            hold = c.hold;
            field = c.field;
        }
        assert_eq!(field - 100, 0, "the rotor is at the target; the field leads it by the load angle");
    }

    #[test]
    fn beta_scales_with_the_resolution() {
        assert_eq!(beta_usteps(255, 8), 255);
        assert_eq!(beta_usteps(256, 4), 16);
        assert_eq!(beta_usteps(0, 8), 1);
    }

    #[test]
    fn current_scaling_rises_under_load_and_falls_without() {
        let p = ScaleParams { up_ms: 1, ..SCALE };
        let mut cl = ClosedLoop { scaler: 240, ..ClosedLoop::default() };
        for _ in 0..2000 {
            scale(&mut cl, &p, 0);
        }
        assert_eq!(cl.scaler, 100, "no load: down to the minimum");
        for _ in 0..5 {
            scale(&mut cl, &p, 200);
        }
        assert_eq!(cl.scaler, 140, "5 ms above the upper limit: 5 steps of 8");
        scale(&mut cl, &p, 64);
        assert_eq!(cl.scaler, 140, "between the limits: unchanged");
        scale(&mut cl, &ScaleParams { enabled: false, ..p }, 0);
        assert_eq!(cl.scaler, 240, "off: the maximum");
    }

    #[test]
    fn i2t_settles_at_i_squared_tau_and_trips_once() {
        let mut cl = ClosedLoop::default();
        for _ in 0..30_000 {
            i2t(&mut cl, 1000, 1000, 3000, 0);
        }
        // 1 A for 10 τ: within 0.01 % of 1000² · 3 s.
        assert!((cl.i2t - 3_000_000).abs() < 300, "{}", cl.i2t);
        let mut cl = ClosedLoop::default();
        let trips = (0..10_000).filter(|_| i2t(&mut cl, 2000, 1000, 3000, 1_000_000)).count();
        assert!(trips > 0 && cl.i2t_exceeded && cl.i2t_count == 1);
    }

    #[test]
    fn measured_velocity_is_the_last_32_ms() {
        let mut cl = ClosedLoop::default();
        for _ in 0..32 {
            assert!(cl.record_move(51, 1000));
        }
        assert_eq!(cl.measured_velocity(), 51_000);
        assert!(!cl.record_move(0, 400), "part of a tick");
        assert!(cl.record_move(0, 600));
        assert_eq!(cl.measured_velocity(), 31 * 51 * 1000 / 32);
        cl.record_move(1 << 40, 1000);
        assert!(cl.measured_velocity() > 0, "a huge move is clamped, not wrapped");
    }

    /// The current scaling the tests run with (the model's defaults, AP 113–122, but AP 120).
    const SCALE: ScaleParams = ScaleParams {
        enabled: true,
        min: 100,
        max: 240,
        lower: 32,
        upper: 128,
        increment: 8,
        decrement: 1,
        up_ms: 7,
        down_ms: 10,
    };

    #[test]
    fn a_loop_at_rest_in_closed_form_is_the_loop_ticked() {
        // Scaler at its minimum (down counter running round), at its maximum (up counter), between the
        // limits, off; I²t settling, and crossing its limit.
        let scale = SCALE;
        let cases = [
            (100u8, 0i32, scale, 0i64),
            (240, 200, scale, 0),
            (170, 64, scale, 0),
            (240, 0, ScaleParams { enabled: false, ..scale }, 0),
            (100, 0, scale, 100_000),
        ];
        for (scaler, gamma, scale, limit) in cases {
            let field = i64::from(gamma); // at 256 microsteps per full step, gamma is the field's lead
            let cl = ClosedLoop {
                active: true,
                init: Init::Done,
                scaler,
                gamma,
                field_offset: field,
                down_ms: if scale.enabled { 3 } else { 0 },
                ..ClosedLoop::default()
            };
            let p = RestParams {
                control: LoopParams { hold_gain: 0, ..P },
                full_step: 256,
                scale,
                scale_on_error: false,
                rms_ma: 800,
                tau_ms: 300,
                i2t_limit: limit,
            };
            assert!(cl.at_rest(&p), "{scaler} {gamma}");
            let mut ticked = cl;
            let mut rested = cl;
            let mut n = 0u64;
            while n < 5000 {
                let before = ticked;
                record_and_regulate(&mut ticked, &p);
                if ticked.i2t_limiting != before.i2t_limiting {
                    ticked = before;
                    break;
                }
                n += 1;
            }
            assert_eq!(rested.rest(&p, 5000), n, "{scaler} {gamma} {limit}");
            assert_eq!(rested, ticked, "{scaler} {gamma} {limit}");
            if limit > 0 {
                assert!(n < 5000, "the I²t limit crossed: the crossing tick is left to ticking");
            }
        }
    }

    #[test]
    fn a_locked_run_in_closed_form_is_the_loop_ticked() {
        // The scaler at its limit below (errors under the lower limit), at its limit above (over the
        // upper), between the limits, and off; moves of a rotor accelerating from 3 to about 9 microsteps a
        // tick with a wobble of the encoder's quantisation; runs shorter and longer than the window.
        let scale = SCALE;
        let cases = [
            (100u8, (0i64, 20i64), scale),
            (240, (130, 200), scale),
            (170, (40, 100), scale),
            (240, (0, 500), ScaleParams { enabled: false, ..scale }),
        ];
        for (scaler, (lo, hi), scale) in cases {
            for ticks in [5u64, 32, 33, 700] {
                let start = ClosedLoop {
                    active: true,
                    init: Init::Done,
                    scaler,
                    down_ms: 3,
                    up_ms: 2,
                    ..ClosedLoop::default()
                };
                let start = ClosedLoop { actual: 1000, moves_at: 7, ..start };
                assert!(start.scaler_stays(&scale, (lo, hi)), "{scaler} {lo}..{hi}");
                let (rms, tau) = (800, 300);
                let mut ticked = start;
                let mut actuals = vec![start.actual];
                let mut actual = start.actual;
                for k in 0..ticks {
                    actual += 3 + (k as i64 * 6) / 700 + (k as i64 % 3);
                    actuals.push(actual);
                    // The regulated error somewhere within the run's range, as the module feeds it.
                    let error = lo + (k as i64 * 7919) % (hi - lo + 1);
                    let moved = actual - ticked.actual;
                    assert!(ticked.record_move(moved, 1000));
                    ticked.actual = actual;
                    scale_tick(&mut ticked, &scale, error, rms, tau);
                }
                let mut run = start;
                let (_, i2t) = run.i2t_ahead(rms, tau, 0, ticks);
                run.run_locked(&scale, (lo, hi), ticks, i2t);
                let last = actuals.len().min(VELOCITY_WINDOW + 1);
                let from = if ticks as usize >= VELOCITY_WINDOW { actuals.len() - last } else { 0 };
                run.measured(&actuals[from..], ticks);
                assert_eq!(run, ticked, "{scaler} {lo}..{hi}, {ticks} ticks");
            }
        }
    }

    /// The current scaling and I²t of one tick, as `Motor::regulate_current` runs them.
    fn scale_tick(cl: &mut ClosedLoop, s: &ScaleParams, error: i64, rms: i64, tau: i64) {
        scale(cl, s, error);
        i2t(cl, rms, 1000, tau, 0);
    }

    /// One tick of a loop at rest, as the module runs it: the move recorded, the scaler, I²t.
    fn record_and_regulate(cl: &mut ClosedLoop, p: &RestParams) {
        assert!(cl.record_move(0, 1000));
        scale(cl, &p.scale, i64::from(cl.gamma.abs()));
        i2t(cl, p.rms_ma, 1000, p.tau_ms, p.i2t_limit);
    }

    #[test]
    fn a_moving_or_loaded_loop_is_not_at_rest() {
        let p = RestParams {
            control: P,
            full_step: 256,
            scale: ScaleParams {
                enabled: false,
                min: 0,
                max: 255,
                lower: 0,
                upper: 0,
                increment: 0,
                decrement: 0,
                up_ms: 0,
                down_ms: 0,
            },
            scale_on_error: false,
            rms_ma: 0,
            tau_ms: 1,
            i2t_limit: 0,
        };
        let rest = ClosedLoop { active: true, init: Init::Done, scaler: 255, ..ClosedLoop::default() };
        assert!(rest.at_rest(&p));
        let mut moved = rest;
        moved.moves[5] = 1;
        assert!(!moved.at_rest(&p), "moved within the velocity window");
        assert!(!ClosedLoop { error: 3, ..rest }.at_rest(&p), "an error: the loop corrects");
        assert!(!ClosedLoop { torque: Some((100, 0)), ..rest }.at_rest(&p), "torque mode");
        assert!(!ClosedLoop { active: false, ..rest }.at_rest(&p), "open");
        assert!(!ClosedLoop { gamma: 12, ..rest }.at_rest(&p), "gamma not yet the field's lead");
        assert!(!ClosedLoop { scaler: 200, ..rest }.at_rest(&p), "scaling off: the scaler goes to AP 114");
    }
}

//! How a motor runs the closed loop ([`crate::drive::closed_loop`]) at every motion tick, and what the
//! closed-loop parameters read (TMCM-1310 manual §3.4; the TMCM-1311 sibling's AP 14–29, 111–138, 230–237).

use super::motor::{Faults, Motor};
use crate::drive::closed_loop::{
    self, status, FieldCommand, Init, LoopInput, LoopParams, RestParams, ScaleParams, INIT_PHASE,
};
use crate::drive::error_flags;
use crate::hal::prelude::*;
use crate::hal::Board;
use crate::model::Setting;
use crate::motion::Mode;
use tmcl_wire::Status;

/// What the ticks of a closed loop whose rotor stands on the field depend on besides its state
/// ([`Motor::locked_loop`]).
#[cfg(feature = "loop-periods")]
#[derive(Debug, Clone, Copy)]
pub(crate) struct LockedLoop {
    /// β in microsteps (AP 111).
    pub beta: i64,
    /// Half an electrical period less one microstep: the field's lead never reaches it.
    pub max_lead: i64,
    /// One full step in microsteps (gamma's unit).
    pub full_step: i64,
    /// The current scaling (AP 113–122).
    pub scale: ScaleParams,
    /// The current scaling regulates |e| (AP 115 = 1), not |gamma|.
    pub scale_on_error: bool,
    /// AP 125 (0: no following-error check).
    pub max_error: i64,
    /// The RMS coil current the loop drives now (mA), AP 25 (ms) and AP 26: the I²t monitor's inputs.
    pub rms_ma: i64,
    /// See `rms_ma`.
    pub tau_ms: i64,
    /// See `rms_ma`.
    pub i2t_limit: i64,
}

/// √2 · 10000, for RMS ↔ peak.
const SQRT2_E4: i64 = 14142;

impl<B: Board> Motor<'_, B> {
    /// One full step in microsteps of the resolution in force.
    fn full_step(&self) -> i64 {
        1i64 << self.microstep_resolution().min(8)
    }

    /// The closed-loop conversion of encoder counts to microsteps: counts · AP 202 · 2^res / AP 210,
    /// if the model sets its encoder that way.
    pub(crate) fn counts_to_usteps(&self, counts: i64) -> Option<i64> {
        let per_rev = i128::from(self.ap(Setting::EncoderResolution)?.max(1));
        let full_steps = i128::from(self.ap(Setting::MotorFullSteps).unwrap_or(200));
        let usteps = i128::from(counts) * full_steps * i128::from(self.full_step()) / per_rev;
        Some(usteps.clamp(i64::MIN.into(), i64::MAX.into()) as i64)
    }

    /// Encoder counts per electrical period (4 full steps): AP 210 · 4 / AP 202.
    fn counts_per_period(&self) -> i64 {
        let per_rev = i64::from(self.ap(Setting::EncoderResolution).unwrap_or(1).max(1));
        let full_steps = i64::from(self.ap(Setting::MotorFullSteps).unwrap_or(200).max(1));
        per_rev * 4 / full_steps
    }

    /// Ends a running encoder initialisation early: the field goes back to the step counter. Returns how
    /// far the field moves for that.
    fn abort_init(&mut self) -> i64 {
        let Init::Running { start_offset, .. } = self.axis.cl.init else { return 0 };
        let back = start_offset - self.axis.cl.field_offset;
        self.axis.cl.field_offset = start_offset;
        self.axis.cl.init = Init::Idle;
        back
    }

    /// The peak coil current at current setting 255 in the range in force (AP 179 where the model has it).
    fn peak_ma(&self) -> i64 {
        let high = self.ap(Setting::CurrentRange) == Some(0);
        i64::from(self.spec.peak_current_ma[usize::from(high)])
    }

    /// RMS coil current in mA for a current setting.
    fn setting_to_rms_ma(&self, setting: u8) -> i64 {
        i64::from(setting) * self.peak_ma() * 10_000 / (255 * SQRT2_E4)
    }

    /// The current setting for an RMS current in mA.
    fn rms_ma_to_setting(&self, ma: i64) -> u8 {
        (ma.abs() * 255 * SQRT2_E4 / (self.peak_ma().max(1) * 10_000)).clamp(0, 255) as u8
    }

    /// The current the closed loop drives, if it drives the motor now (initialising, closed, torque mode).
    #[inline]
    pub(crate) fn closed_loop_current(&self) -> Option<u8> {
        let cl = &self.axis.cl;
        if !cl.engaged() {
            return None;
        }
        let run = self.ap(Setting::RunCurrent).unwrap_or(255).clamp(0, 255);
        if !cl.active {
            return Some(run as u8); // initialising
        }
        if cl.i2t_limiting {
            return Some(self.ap(Setting::StandbyCurrent).unwrap_or(run).clamp(0, 255) as u8);
        }
        if let Some((_, actual)) = cl.torque {
            return Some(self.rms_ma_to_setting(i64::from(actual)));
        }
        Some((run * i32::from(cl.scaler) / 255) as u8)
    }

    /// The position the encoder gives now, in microsteps (AP 209).
    fn actual_now(&mut self) -> i64 {
        let counts = self.encoder_counts_now();
        i64::from(self.encoder_value(counts))
    }

    /// One motion tick of a closed-loop model, after the ramp moved `step` microsteps in `dt_us`: measures
    /// the rotor, opens or closes the loop, runs the initialisation or the controller, and returns how far
    /// the field moves (what the board is told). In open loop that is the ramp's step.
    #[inline(never)] // out of the open-loop tick's way
    pub(crate) fn closed_loop_tick(&mut self, step: i64, dt_us: i64) -> (i64, Faults) {
        let actual = self.actual_now();
        let moved = actual - self.axis.cl.actual;
        let whole_ms = self.axis.cl.record_move(moved, dt_us);
        self.axis.cl.actual = actual;
        self.sync_loop(actual);
        if let Init::Running { .. } = self.axis.cl.init {
            return (self.init_tick(step, dt_us), Faults::NONE);
        }
        if !self.axis.cl.active {
            return (step, Faults::NONE);
        }
        let res = self.microstep_resolution();
        let virtual_pos = i64::from(self.axis.ramp.position);
        // Everything relative to the rotor (the counters wrap; their differences do not).
        let e = i64::from((virtual_pos as i32).wrapping_sub(actual as i32));
        let field_before = e - step + self.axis.cl.field_offset;
        let beta = closed_loop::beta_usteps(self.ap(Setting::CommutationLimit).unwrap_or(255), res);
        let command = if let Some((target, current)) = self.axis.cl.torque {
            // Torque mode: the ramp stands at the rotor, the field leads it by β in the current's direction.
            let slope = i64::from(self.ap(Setting::TorqueSlope).unwrap_or(0));
            let current = if slope == 0 {
                target
            } else {
                let d = (slope * dt_us / 1_000_000).max(1);
                i64::from(current).clamp(i64::from(target) - d, i64::from(target) + d) as i32
            };
            self.axis.cl.torque = Some((target, current));
            self.axis.ramp.hard_stop();
            self.axis.ramp.mode = Mode::Position;
            self.axis.ramp.set_position(actual as i32);
            FieldCommand { field: beta * i64::from(current.signum()), hold: 0 }
        } else {
            let params = self.loop_params(beta, dt_us);
            let standing = self.axis.ramp.is_idle();
            let input = LoopInput {
                virtual_pos: e,
                step,
                standing,
                actual: 0,
                rotor_move: moved,
                field: field_before,
                hold: self.axis.cl.hold,
            };
            closed_loop::control(&params, &input)
        };
        let e = i64::from((self.axis.ramp.position).wrapping_sub(actual as i32));
        self.axis.cl.hold = command.hold;
        self.axis.cl.field_offset = command.field - e;
        self.axis.cl.error = e.clamp(i32::MIN.into(), i32::MAX.into()) as i32;
        // Gamma: the field's lead beyond the ramp's step (the load angle), 256 = 90°.
        let lead = if self.axis.cl.torque.is_some() { command.field } else { command.field - step };
        self.axis.cl.gamma = (lead * 256 / self.full_step()).clamp(-256, 256) as i32;
        if whole_ms {
            self.regulate_current(e);
        }
        // Following error (AP 125): stop where the rotor is.
        let max = i64::from(self.ap(Setting::MaxFollowingError).unwrap_or(0));
        let mut faults = Faults::NONE;
        if max > 0 && e.abs() > max {
            faults = self.fault_stop(error_flags::DEVIATION);
            self.axis.ramp.set_position(actual as i32);
            self.axis.cl.field_offset = command.field;
            self.axis.cl.hold = 0;
        }
        (command.field - field_before, faults)
    }

    /// The position controller's parameters (AP 124, 126, 136, 138) for a tick of `dt_us`.
    fn loop_params(&self, beta: i64, dt_us: i64) -> LoopParams {
        let ap = |s| i64::from(self.ap(s).unwrap_or(0));
        LoopParams {
            beta,
            max_lead: 2 * self.full_step() - 1,
            gain: ap(Setting::CorrectionGain),
            max_correction: ap(Setting::MaxCorrectionVelocity),
            hold_gain: ap(Setting::HoldGain),
            hold_limit: ap(Setting::HoldLimit),
            dt_us,
        }
    }

    /// The current scaling's parameters (AP 113, 114, 116–122).
    fn scale_params(&self) -> ScaleParams {
        let ap = |s| self.ap(s).unwrap_or(0);
        ScaleParams {
            enabled: ap(Setting::CurrentScaleEnable) == 1,
            min: ap(Setting::CurrentScaleMin).clamp(0, 255) as u8,
            max: ap(Setting::CurrentScaleMax).clamp(0, 255) as u8,
            lower: i64::from(ap(Setting::CurrentScaleLower)),
            upper: i64::from(ap(Setting::CurrentScaleUpper)),
            increment: ap(Setting::CurrentScaleIncrement).clamp(0, 255) as u8,
            decrement: ap(Setting::CurrentScaleDecrement).clamp(0, 255) as u8,
            up_ms: ap(Setting::CurrentScaleUpTime) as u32,
            down_ms: ap(Setting::CurrentScaleDownTime) as u32,
        }
    }

    /// How many of the next `ticks` motion ticks motor `m`'s loop sleeps through while the motor stands
    /// (the idle jump in `module/advance.rs`; the board is quiet and the caller has checked that the
    /// motor stands): 0 unless the rotor stands where the loop last measured it and the loop is open or
    /// [at rest](closed_loop::ClosedLoop::at_rest). With `take` the ticks are taken — the loop's state
    /// becomes what ticking them gives — otherwise only counted (for the deadline).
    pub(crate) fn closed_loop_rest(&mut self, ticks: u64, take: bool) -> u64 {
        let actual = self.actual_now();
        let want = self.ap(Setting::ClosedLoop) == Some(1) && self.axis.cl.init == Init::Done;
        let mut cl = self.axis.cl;
        if ticks == 0 || actual != cl.actual || want != cl.active || matches!(cl.init, Init::Running { .. }) {
            return 0;
        }
        let taken = if !cl.active {
            // Open loop: each tick records a rotor that did not move (AP 131).
            if cl.record_still(ticks) {
                ticks
            } else {
                0
            }
        } else {
            let ramp = &self.axis.ramp;
            if !ramp.is_idle() || ramp.position.wrapping_sub(actual as i32) != 0 {
                return 0;
            }
            let res = self.microstep_resolution();
            let beta = closed_loop::beta_usteps(self.ap(Setting::CommutationLimit).unwrap_or(255), res);
            let ap = |s| i64::from(self.ap(s).unwrap_or(0));
            let p = RestParams {
                control: self.loop_params(beta, 1000),
                full_step: self.full_step(),
                scale: self.scale_params(),
                scale_on_error: ap(Setting::CurrentScaleInput) == 1,
                rms_ma: self.setting_to_rms_ma(self.closed_loop_current().unwrap_or(0)),
                tau_ms: ap(Setting::I2tTimeConstant),
                i2t_limit: ap(Setting::I2tLimit),
            };
            if !cl.at_rest(&p) {
                return 0;
            }
            cl.rest(&p, ticks)
        };
        if take {
            self.axis.cl = cl;
        }
        taken
    }

    #[cfg(feature = "loop-periods")]
    /// What a run of ticks of this motor's loop with the rotor standing on the field depends on besides
    /// the loop's state (`module/loop_span.rs`).
    pub(crate) fn locked_loop(&self) -> LockedLoop {
        let ap = |s| i64::from(self.ap(s).unwrap_or(0));
        let (rms_ma, tau_ms, i2t_limit) = self.loop_i2t();
        LockedLoop {
            beta: closed_loop::beta_usteps(
                self.ap(Setting::CommutationLimit).unwrap_or(255),
                self.microstep_resolution(),
            ),
            max_lead: 2 * self.full_step() - 1,
            full_step: self.full_step(),
            scale: self.scale_params(),
            scale_on_error: ap(Setting::CurrentScaleInput) == 1,
            max_error: ap(Setting::MaxFollowingError),
            rms_ma,
            tau_ms,
            i2t_limit,
        }
    }

    #[cfg(feature = "loop-periods")]
    /// What the I²t monitor runs with now: the RMS coil current (mA) the loop drives, AP 25 (ms) and AP 26.
    pub(crate) fn loop_i2t(&self) -> (i64, i64, i64) {
        let rms = self.setting_to_rms_ma(self.closed_loop_current().unwrap_or(0));
        let ap = |s| i64::from(self.ap(s).unwrap_or(0));
        (rms, ap(Setting::I2tTimeConstant), ap(Setting::I2tLimit))
    }

    /// Current scaling and I²t, once per tick while the loop is closed.
    fn regulate_current(&mut self, e: i64) {
        let dt_us = 1000;
        let ap = |s| self.ap(s).unwrap_or(0);
        let p = self.scale_params();
        let error = if ap(Setting::CurrentScaleInput) == 1 { e.abs() } else { i64::from(self.axis.cl.gamma.abs()) };
        let (tau, limit) = (ap(Setting::I2tTimeConstant), ap(Setting::I2tLimit));
        closed_loop::scale(&mut self.axis.cl, &p, error);
        let rms = self.setting_to_rms_ma(self.closed_loop_current().unwrap_or(0));
        closed_loop::i2t(&mut self.axis.cl, rms, dt_us, i64::from(tau), i64::from(limit));
    }

    /// Closes or opens the loop as AP 129 and the initialisation say (a write of AP 129, every tick).
    pub(crate) fn sync_loop(&mut self, actual: i64) {
        let want = self.ap(Setting::ClosedLoop) == Some(1) && self.axis.cl.init == Init::Done;
        if want && !self.axis.cl.active {
            self.close_loop(actual);
        } else if !want && self.axis.cl.active {
            self.open_loop();
        }
    }

    /// AP 129 was written: the loop closes (or opens) at once, between two ticks.
    pub(crate) fn closed_loop_switched(&mut self) {
        let actual = self.actual_now();
        self.axis.cl.actual = actual;
        self.sync_loop(actual);
    }

    /// The encoder's input (AP 201) or scale (AP 202, 210, 140) was written: the encoder position carries
    /// on from `at`, the value it had. A closed (or closing) loop opens and needs a new initialisation
    /// (AP 132 reads 0, AP 133 0): its calibration and the meaning of its positions changed under it —
    /// our decision; otherwise a loop would chase a rotor that only seemed to jump.
    pub(crate) fn encoder_rescaled(&mut self, at: i32, input_changed: bool) {
        if input_changed {
            self.configure_driver();
            self.axis.ssi = (0, 0);
        }
        self.set_encoder(at);
        if self.axis.cl.active {
            self.open_loop();
        }
        // A running initialisation's field goes back to the step counter at once; a done one is void.
        self.axis.unreported_steps += self.abort_init();
        if self.axis.cl.init == Init::Done {
            self.axis.cl.init = Init::Idle;
        }
    }

    /// Closes the loop where the rotor is: the ramp takes the rotor's position, nothing moves.
    fn close_loop(&mut self, actual: i64) {
        let field = i64::from(self.axis.ramp.position) + self.axis.cl.field_offset;
        self.axis.ramp.hard_stop();
        self.axis.ramp.set_position(actual as i32);
        let scaler = self.ap(Setting::CurrentScaleMax).unwrap_or(255).clamp(0, 255) as u8;
        let cl = &mut self.axis.cl;
        cl.active = true;
        cl.field_offset = field - actual;
        cl.hold = 0;
        cl.scaler = scaler;
        cl.up_ms = 0;
        cl.down_ms = 0;
    }

    /// Opens the loop: the step counter continues from where the field is.
    fn open_loop(&mut self) {
        let field = i64::from(self.axis.ramp.position) + self.axis.cl.field_offset;
        self.axis.ramp.set_position(field as i32);
        let cl = &mut self.axis.cl;
        cl.active = false;
        cl.field_offset = 0;
        cl.torque = None;
        cl.hold = 0;
    }

    /// One tick of the encoder initialisation (see [`closed_loop`]'s docs); returns the field's move.
    fn init_tick(&mut self, step: i64, dt_us: i64) -> i64 {
        let Init::Running { elapsed_us, start_counts, start_offset, ok } = self.axis.cl.init else { return step };
        if step != 0 || !self.axis.ramp.is_idle() {
            // A move aborts the sequence.
            return step + self.abort_init();
        }
        let before = self.axis.cl.field_offset;
        let phase = INIT_PHASE.micros();
        let t = elapsed_us + dt_us as u64;
        let period = 4 * self.full_step();
        let counts = self.encoder_counts_now();
        let (mut start, mut ok) = (start_counts, ok);
        if elapsed_us < phase && t >= phase {
            start = counts;
        }
        if elapsed_us < 2 * phase && t >= 2 * phase {
            // The forward move is over: did the encoder count one electrical period, in our direction?
            let expected = self.counts_per_period();
            let got = counts - start;
            ok = Some(expected > 0 && (got - expected).abs() * 4 <= expected);
        }
        let offset = match t {
            t if t < phase => 0,
            t if t < 2 * phase => period * (t - phase) as i64 / phase as i64,
            t if t < 3 * phase => period - period * (t - 2 * phase) as i64 / phase as i64,
            _ => 0,
        };
        self.axis.cl.field_offset = start_offset + offset;
        if t >= 3 * phase {
            if ok == Some(true) {
                self.axis.cl.init = Init::Done;
                // AP 112: the counts at electrical angle 0 (the field's angle at the start is known).
                let field = i64::from(self.axis.ramp.position) + start_offset;
                let angle = field.rem_euclid(period);
                let per_rev = i64::from(self.ap(Setting::EncoderResolution).unwrap_or(1).max(1));
                let zero = (counts - angle * self.counts_per_period() / period).rem_euclid(per_rev);
                self.set_ap(Setting::EncoderOffset, zero as i32);
                // The encoder now reads the step counter.
                let position = self.axis.ramp.position;
                self.axis.encoder = super::EncoderBase { counts, value: position };
                self.axis.cl.actual = i64::from(position);
            } else {
                self.axis.cl.init = Init::Failed;
            }
        } else {
            self.axis.cl.init = Init::Running { elapsed_us: t, start_counts: start, start_offset, ok };
        }
        let moved = self.axis.cl.field_offset - before;
        if self.axis.cl.init == Init::Done {
            // AP 129 written during the initialisation closes the loop now that it is done (our decision,
            // docs/decisions.md); the field stays where it is.
            self.sync_loop(self.axis.cl.actual);
        }
        moved
    }

    /// AP 132 := 1: starts the encoder initialisation (at rest, with the loop open; status 4 otherwise —
    /// our decision).
    pub(crate) fn start_encoder_init(&mut self, v: i32) -> Result<(), Status> {
        if v != 1 {
            return Ok(()); // 0: nothing to do
        }
        if self.axis.cl.active || !self.axis.ramp.is_idle() || self.axis.reference.is_active() {
            return Err(Status::InvalidValue);
        }
        let offset = self.axis.cl.field_offset;
        self.axis.cl.init = Init::Running { elapsed_us: 0, start_counts: 0, start_offset: offset, ok: None };
        self.axis.cl.actual = self.actual_now();
        Ok(())
    }

    /// AP 14: enters torque mode with a target current (the loop must be closed: status 4 otherwise —
    /// our decision; torque needs the encoder to commutate). A reference search stops, and a pending 138
    /// event with it.
    pub(crate) fn set_torque(&mut self, ma: i32) -> Result<Faults, Status> {
        if !self.axis.cl.active {
            return Err(Status::InvalidValue);
        }
        let current = self.axis.cl.torque.map_or(0, |(_, c)| c);
        self.axis.cl.torque = Some((ma, current));
        self.axis.reference.stop();
        Ok(Faults { drop_event: true, ..Faults::NONE })
    }

    /// Moves the counters' zero by `delta` (SAP 1, the end of a reference search): in closed loop the
    /// encoder position moves with the step counter, so that the loop sees no error.
    pub(crate) fn relabel(&mut self, delta: i32) {
        if self.axis.cl.active {
            self.axis.encoder.value = self.axis.encoder.value.wrapping_add(delta);
            self.axis.cl.actual += i64::from(delta);
        }
    }

    /// Whether the target is reached: the ramp at its target in position mode and, in closed loop, the
    /// rotor within the window (AP 134) of it.
    #[inline]
    pub(crate) fn target_reached(&mut self) -> bool {
        if !self.axis.cl.active {
            return self.axis.ramp.position_reached();
        }
        let ramp = &self.axis.ramp;
        let done = ramp.mode == Mode::Position && ramp.is_idle() && self.axis.cl.torque.is_none();
        let window = i64::from(self.ap(Setting::PositionWindow).unwrap_or(0));
        done && i64::from(self.axis.cl.error).abs() <= window
    }

    /// AP 131: the measured velocity (0 when nothing is measured: open loop at rest).
    pub(crate) fn measured_velocity(&self) -> i32 {
        if !self.axis.cl.engaged() && self.axis.ramp.is_idle() {
            0
        } else {
            self.axis.cl.measured_velocity()
        }
    }

    /// AP 16: the measured velocity is within AP 17 of the ramp's, and the ramp is not accelerating.
    pub(crate) fn velocity_reached(&self) -> bool {
        let window = i64::from(self.ap(Setting::VelocityWindow).unwrap_or(0));
        let ramp = &self.axis.ramp;
        let target = match ramp.mode {
            Mode::Velocity => ramp.target_velocity,
            Mode::Position => ramp.velocity(),
        };
        !self.axis.ramping
            && ramp.velocity() == target
            && (i64::from(self.measured_velocity()) - i64::from(ramp.velocity())).abs() <= window
    }

    /// AP 19: the closed loop's coil current, signed by the torque's direction, mA RMS; 0 in open loop.
    pub(crate) fn actual_torque_current(&self) -> i32 {
        if let Some((_, c)) = self.axis.cl.torque {
            return c;
        }
        match self.closed_loop_current() {
            Some(s) if self.axis.cl.active => {
                (self.setting_to_rms_ma(s) * i64::from(self.axis.cl.gamma.signum())) as i32
            }
            _ => 0,
        }
    }

    /// AP 18: the status word.
    pub(crate) fn status_word(&mut self) -> i32 {
        let mut w = 0u32;
        let mut set = |bit: u32, on: bool| {
            if on {
                w |= bit
            }
        };
        let (left, right, home) = self.switches();
        let reached = self.axis.ramp.mode == Mode::Position && self.target_reached();
        let torque = self.axis.cl.torque.is_some();
        let supply = self.board.supply_voltage();
        let driver = self.board.driver_flags(self.m);
        set(status::TARGET_REACHED, reached);
        set(status::VELOCITY_REACHED, self.velocity_reached());
        set(status::CLOSED_LOOP, self.axis.cl.active);
        set(status::POSITION_MODE, !torque && self.axis.ramp.mode == Mode::Position);
        set(status::VELOCITY_MODE, !torque && self.axis.ramp.mode == Mode::Velocity);
        set(status::TORQUE_MODE, torque);
        set(status::HOME, home);
        set(status::LEFT, left);
        set(status::RIGHT, right);
        set(status::UNDERVOLTAGE, supply < closed_loop::SUPPLY_LIMITS.0);
        set(status::OVERVOLTAGE, supply > closed_loop::SUPPLY_LIMITS.1);
        set(status::OVERTEMPERATURE, driver & crate::hal::driver_flag::OVERTEMPERATURE != 0);
        set(
            status::POSITION_HOLD,
            self.axis.cl.active && !torque && self.axis.ramp.mode == Mode::Position && self.axis.ramp.is_idle(),
        );
        set(status::I2T_EXCEEDED, self.axis.cl.i2t_exceeded);
        w as i32
    }
}

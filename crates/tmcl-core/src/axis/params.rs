//! GAP, SAP and AAP of one motor (PD28-1021 manual §3.7.5, §3.7.6, §3.7.29; chapter 4, Table 15): the
//! parameter's number checked against the model's table, its value read from the motor's own state
//! ([`super::Axis::read_param`]) or from what the board and the closed loop measure, and a write that reaches
//! the encoder, the driver and the closed loop where the parameter does.

use super::motor::{Faults, Motor};
use crate::hal::prelude::*;
use crate::hal::Board;
use crate::model::Setting;
use crate::param::{permitted, unlocked_for, ParamError, Role};
use crate::time::Instant;
use tmcl_wire::Status;

impl<B: Board> Motor<'_, B> {
    /// GAP of parameter `number` at `at` (`None`: whenever the board was last brought up to date); `now`
    /// is the module's time (the current in use depends on how long the motor has stood). A parameter
    /// that reads something of the board that changes with the board's own clock — a switch (it may
    /// bounce), the driver's flags (standstill after 2²⁰ clocks without a step) or the status word made
    /// of them — is read with the board brought to `at` first ([`Motor::sync_board`]), so that it is the
    /// value at the instant of the read however often the module was polled before.
    #[inline(always)]
    pub(crate) fn read(&mut self, number: u8, at: Option<Instant>, now: Instant) -> Result<i32, Status> {
        let (i, d) = permitted(&self.spec.axis, number, |d| d.access.read)?;
        // What the motor's own state gives ([`super::Axis::read_param`]); the rest reads the board or what the
        // closed loop measures.
        match self.axis.read_param(self.spec, i, d.role) {
            Some(v) => Ok(v),
            None => Ok(self.read_measured(i, d.role, at, now)),
        }
    }

    /// GAP of the parameter at index `i` of the model's axis table, whose role is `role`, for one that reads
    /// the board or what the closed loop measures ([`Motor::read`]).
    #[inline(never)] // (out of the way of the parameters the motor's own state gives)
    fn read_measured(&mut self, i: usize, role: Role, at: Option<Instant>, now: Instant) -> i32 {
        if let Some(at) = at {
            if matches!(
                role,
                Role::HomeSwitch | Role::RightSwitch | Role::LeftSwitch | Role::DriverFlags | Role::StatusWord
            ) {
                self.sync_board(at);
            }
        }
        match role {
            Role::ActualPosition => self.encoder_position(),
            Role::PositionReached => i32::from(self.target_reached()),
            Role::HomeSwitch => i32::from(self.switches().2),
            Role::RightSwitch => i32::from(self.switches().1),
            Role::LeftSwitch => i32::from(self.switches().0),
            // AP 180: the current scale 0..31 in use (current / 8, Table 22), after coolStep.
            Role::ActualCurrent => i32::from(self.current(now).0 >> 3),
            Role::LoadValue => i32::from(self.board.load(self.m).min(1023)),
            Role::DriverFlags => i32::from(self.board.driver_flags(self.m)),
            Role::EncoderPosition => self.encoder_position(),
            Role::EncoderAbsolute => self.encoder_absolute(),
            Role::VelocityReached => i32::from(self.velocity_reached()),
            Role::StatusWord => self.status_word(),
            Role::ActualTorqueCurrent => self.actual_torque_current(),
            Role::MeasuredVelocity => self.measured_velocity(),
            // Virtual minus actual position in closed loop.
            Role::PositionError => self.axis.ramp.position.wrapping_sub(self.encoder_position()),
            // (None other: `Axis::read_param` reads the rest.)
            _ => self.axis.params[i],
        }
    }

    /// SAP/AAP of parameter `number` to `v` at `now` (RAM only): checked against the model's table, the
    /// parameter's range and its protection (a protected parameter needs the banks unlocked), then
    /// written; what the write does beyond the motor (AP 14 drops a pending 138 event) is returned.
    #[inline]
    pub(crate) fn write(&mut self, number: u8, v: i32, now: Instant) -> Result<Faults, Status> {
        let (i, d) = permitted(&self.spec.axis, number, |d| d.access.write)?;
        if !d.range.contains(v) {
            return Err(ParamError::OutOfRange.into());
        }
        unlocked_for(self.banks.unlocked, d)?;
        let mut faults = Faults::NONE;
        // The encoder's input or scale changes (AP 201, 202, 210, 140 on a closed-loop model): the
        // position before, read through the old one.
        let rescales =
            (matches!(d.setting, Some(Setting::EncoderMode | Setting::EncoderResolution | Setting::MotorFullSteps))
                || d.role == Role::MicrostepResolution)
                && self.spec.axis.has(Setting::ClosedLoop);
        let encoder_before = if rescales { self.encoder_position() } else { 0 };
        // The pulse divisor (AP 154) scales the TMC428's clock: the velocity registers keep their values
        // in units, so AP 2 and AP 3 read the same and the speed in microsteps per second follows.
        let velocities = (d.setting == Some(Setting::PulseDivisor)).then(|| self.velocity_units());
        // The parameters that move the encoder's reference or reach the closed loop; the rest is what the
        // motor's own state takes ([`super::Axis::write_param`]).
        match d.role {
            Role::ActualPosition => {
                self.relabel(v.wrapping_sub(self.axis.ramp.position));
                self.axis.ramp.set_position(v)
            }
            // In closed loop the step counter moves with the encoder, so that the loop sees no error.
            Role::EncoderPosition if self.axis.cl.active => {
                let delta = v.wrapping_sub(self.encoder_position());
                let ramp = &mut self.axis.ramp;
                ramp.set_position(ramp.position.wrapping_add(delta));
                self.relabel(delta);
            }
            Role::EncoderPosition => self.set_encoder(v),
            Role::TargetCurrent => {
                faults = self.set_torque(v)?;
                self.axis.params[i] = v;
            }
            Role::EncoderInit => self.start_encoder_init(v)?,
            Role::EncoderPrescaler => {
                let now_value = self.encoder_position();
                self.axis.params[i] = v;
                self.set_encoder(now_value);
            }
            _ => self.axis.write_param(self.spec, i, d.role, v),
        }
        // Settings that act when written: the driver's own (stallGuard2 filter and threshold, current
        // range), the closed loop switched on or off, the encoder's input or scale. The driver's take
        // effect at this instant: the board is brought to it first (its clock may lag the module's).
        if matches!(
            d.setting,
            Some(Setting::StallFilter | Setting::StallThreshold | Setting::CurrentRange | Setting::EncoderMode)
        ) {
            self.sync_board(now);
        }
        match d.setting {
            Some(Setting::StallFilter | Setting::StallThreshold | Setting::CurrentRange) => self.configure_driver(),
            Some(Setting::ClosedLoop) => self.closed_loop_switched(),
            _ => {}
        }
        if rescales {
            self.encoder_rescaled(encoder_before, d.setting == Some(Setting::EncoderMode));
        }
        if let Some(units) = velocities {
            self.set_velocity_units(units);
        }
        Ok(faults)
    }

    /// The velocity registers (AP 2 target, AP 3 actual) in the model's units.
    pub(crate) fn velocity_units(&self) -> (i32, i32) {
        let ramp = &self.axis.ramp;
        (self.axis.pps_to_units(self.spec, ramp.target_velocity), self.axis.pps_to_units(self.spec, ramp.velocity()))
    }

    /// After the pulse divisor changed: the velocity registers keep `units`, so the speed in microsteps
    /// per second follows the new divisor (TMC428 datasheet: µstep rate = f_CLK · v / (2^pulse_div ·
    /// 2048 · 32); the divisor scales the clock the velocity counts in).
    pub(crate) fn set_velocity_units(&mut self, (target, actual): (i32, i32)) {
        self.axis.ramp.target_velocity = self.units_to_pps(target);
        let actual = self.units_to_pps(actual);
        self.axis.ramp.set_velocity(actual);
    }
}

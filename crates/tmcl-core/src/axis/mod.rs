//! One motor's state: an [`Axis`] per motor of the model, held in [`Axes`].
//!
//! Everything the firmware keeps for a motor lives here, together: its axis parameters and
//! coordinates, the ramp generator and reference search, coolStep/stallGuard, the encoder's reference
//! point, the closed loop, the standstill and standby bookkeeping and what the board was last told of
//! it. A model says how many motors it has ([`tmcl_model::ModelDesc::motors`], 1 to
//! [`MAX_MOTORS`]); the module runs an [`Axis`] for each, and the host and program address one by the
//! motor byte of a command (PD28-1021 manual §3.5: "motor or bank number"). Nothing here knows the
//! module: what a motor does with the board it drives — its motion tick, coolStep and the encoder
//! (`drive.rs`), the closed loop (`closed_loop.rs`), the parameters that read them (`params.rs`) — is
//! `Motor`'s (`motor.rs`), a view of one axis with the board and the settings it reads, which returns
//! what it did beyond the motor (`Faults`) for the module to apply.
//!
//! The storage is a fixed array of [`MAX_MOTORS`] axes (no heap); a model with fewer motors leaves the
//! rest unused.

mod closed_loop;
mod drive;
mod motor;
mod params;

pub(crate) use motor::{Faults, Motor};

use crate::drive::closed_loop::ClosedLoop;
use crate::drive::coolstep::CoolStep;
use crate::hal::{DriveState, SwitchInputs};
use crate::model::{Kinematics, ModelSpec, Setting, Table};
use crate::motion::{Limits, Mode, Ramp, RampParams, Reference};
use crate::param::Role;
use crate::time::{Duration, Instant};
use tmcl_model::capacity::{MAX_AXIS_PARAMS, MAX_COORDINATES, MAX_MOTORS};

/// The encoder counter's reference point: AP 209 = `value` + (counts − `counts`) × prescaler.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EncoderBase {
    /// Encoder counts (logical direction) at the reference.
    pub counts: i64,
    /// AP 209 at the reference.
    pub value: i32,
}

/// One motor's state (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Axis {
    /// The axis parameters in RAM, in the model's table order.
    pub(crate) params: [i32; MAX_AXIS_PARAMS],
    /// Coordinates 0..=n of this motor (§3.7.24).
    pub(crate) coords: [i32; MAX_COORDINATES],
    pub(crate) ramp: Ramp,
    pub(crate) reference: Reference,
    /// Since when the motor stands still (`None` while it moves).
    pub(crate) standstill_since: Option<Instant>,
    /// The last tick changed the speed (boost current, AP 200).
    pub(crate) ramping: bool,
    pub(crate) encoder: EncoderBase,
    /// AP 207.
    pub(crate) error_flags: u8,
    /// Steps moved since the board was last updated.
    pub(crate) unreported_steps: i64,
    /// What the board was last told (with `moved` = 0), to skip updates that change nothing.
    pub(crate) last_drive: Option<DriveState>,
    /// When the board was last told of this motor.
    pub(crate) board_time: Instant,
    /// When the driver current next changes on its own (standby, freewheeling), if it will.
    pub(crate) drive_due: Option<Instant>,
    /// The coolStep regulator (AP 168–183).
    pub(crate) coolstep: CoolStep,
    /// The board's stallGuard2 measurement count at the last look.
    pub(crate) load_measurements: u32,
    /// Encoder counts at the last look (clear-on-null).
    pub(crate) last_counts: i64,
    /// The closed loop (closed-loop models).
    pub(crate) cl: ClosedLoop,
    /// An SSI encoder's last reading and the counts it adds up to.
    pub(crate) ssi: (i64, i64),
    /// The scaled speed and acceleration of an interpolated MVP COORD (`module/coordinated.rs`), in
    /// force while the axis is in position mode towards that move's target.
    pub(crate) interpolation: Option<(i32, RampParams)>,
}

impl Axis {
    /// A motor at power-up at `now`: standing, parameters 0 until the module loads them.
    pub(crate) fn new(now: Instant) -> Axis {
        Axis {
            params: [0; MAX_AXIS_PARAMS],
            coords: [0; MAX_COORDINATES],
            ramp: Ramp::default(),
            reference: Reference::Idle,
            standstill_since: Some(now),
            ramping: false,
            encoder: EncoderBase::default(),
            error_flags: 0,
            unreported_steps: 0,
            last_drive: None,
            board_time: now,
            drive_due: None,
            coolstep: CoolStep::new(),
            load_measurements: 0,
            last_counts: 0,
            cl: ClosedLoop::default(),
            ssi: (0, 0),
            interpolation: None,
        }
    }

    /// The ramp generator (positions, velocity).
    pub fn ramp(&self) -> &Ramp {
        &self.ramp
    }

    /// The reference search.
    pub fn reference(&self) -> &Reference {
        &self.reference
    }

    /// The closed loop's state (closed-loop models).
    pub fn closed_loop(&self) -> &ClosedLoop {
        &self.cl
    }

    /// The error flags AP 207 reads, without clearing them.
    pub fn error_flags(&self) -> u8 {
        self.error_flags
    }

    /// The encoder's reference point.
    pub fn encoder_base(&self) -> EncoderBase {
        self.encoder
    }

    /// Whether the motor stands (the ramp idle and no reference search).
    #[inline(always)]
    pub fn is_standing(&self) -> bool {
        self.ramp.is_idle() && !self.reference.is_active()
    }

    /// The axis parameter with `setting` in the model's axis table `table`, if the model has it.
    #[inline]
    pub(crate) fn ap(&self, table: &Table, setting: Setting) -> Option<i32> {
        table.setting(setting).map(|i| self.params[i])
    }

    /// The microstep resolution as a power of two (AP 140) in the model's axis table `table`; 8 (256
    /// microsteps) for a model without it.
    #[inline]
    pub(crate) fn microstep_resolution(&self, table: &Table) -> u8 {
        table.role(Role::MicrostepResolution).map_or(8, |i| self.params[i] as u8)
    }

    /// Time after the motor stopped given in `setting` (10 ms units), if the model has it and it is set.
    #[inline]
    pub(crate) fn delay(&self, table: &Table, setting: Setting) -> Option<Duration> {
        self.ap(table, setting).filter(|d| *d > 0).map(|d| Duration::from_millis(d as u64 * 10))
    }

    /// The motor's own next event after `now`: when its driver current changes by itself while it
    /// stands (the standby current after the power-down delay AP 214, freewheeling after AP 204; PD28-1021
    /// manual §4, Table 22), if it will. `table` is the model's axis table.
    #[inline(always)]
    pub(crate) fn next_event(&self, table: &Table, now: Instant) -> Option<Instant> {
        let since = self.standstill_since?;
        [self.delay(table, Setting::PowerDownDelay), self.delay(table, Setting::FreewheelingDelay)]
            .into_iter()
            .flatten()
            .map(|d| since + d)
            .filter(|t| *t > now)
            .min()
    }

    /// One (part of a) motion tick of `dt`: the ramp generator moves on with the ramp parameters
    /// `params` (the model's units already turned into microsteps per second) within the switches'
    /// `limits`. Returns the microsteps the ramp moved (before a closed loop corrects them; then
    /// [`Axis::moved`]).
    #[inline(always)]
    pub(crate) fn advance(&mut self, dt: Duration, params: &RampParams, limits: Limits) -> i64 {
        let r = self.ramp.tick(dt, params, limits);
        self.ramping = r.ramping;
        r.steps
    }

    /// After a (part of a) tick at `t` that moved `steps` (after the closed loop): the steps the board has
    /// yet to hear of, and the standstill's start or end.
    #[inline(always)]
    pub(crate) fn moved(&mut self, t: Instant, steps: i64) {
        self.unreported_steps += steps;
        let moving = self.ramp.velocity() != 0;
        match (moving, self.standstill_since) {
            (true, Some(_)) => self.standstill_since = None,
            (false, None) => self.standstill_since = Some(t),
            _ => {}
        }
    }

    /// How many parts a motion tick of this motor has: a reference search looks at its switch after every
    /// microstep, so that the switching points, and with them the zero point, are exact to the microstep
    /// (PD28-1021 manual §7.1); otherwise one.
    #[inline(always)]
    pub(crate) fn tick_parts(&self, tick: Duration) -> u64 {
        if self.reference.is_active() {
            (u64::from(self.ramp.velocity().unsigned_abs()) / 1000 + 1).min(tick.micros())
        } else {
            1
        }
    }

    /// What motor `m`'s stop switches block now: a pressed left (right) switch blocks moving down (up)
    /// unless AP 12 (13) disables it; during a reference search nothing, since the search handles the
    /// switches itself (PD28-1021 manual §7.1: AP 12/13 do not affect it). `table` is the model's axis
    /// table, `invert` GP 79 (the end switches' polarity reversed).
    #[inline]
    pub(crate) fn limits(&self, m: usize, table: &Table, board: &mut impl SwitchInputs, invert: bool) -> Limits {
        if self.reference.is_active() {
            return Limits::default();
        }
        let (left, right, _) = switches(m, board, invert);
        let enabled = |disable: Option<i32>| disable.unwrap_or(0) == 0;
        Limits {
            block_negative: left && enabled(self.ap(table, Setting::LeftSwitchDisable)),
            block_positive: right && enabled(self.ap(table, Setting::RightSwitchDisable)),
        }
    }

    /// The axis parameter in RAM at table index `i` (the model's table order).
    pub fn param(&self, i: usize) -> Option<i32> {
        self.params.get(i).copied()
    }

    /// A velocity in the model's unit (`spec`'s kinematics, through the pulse divisor AP 154 where they
    /// have one; PDx-113 manual §5.7) as microsteps per second, the ramp's unit.
    #[inline]
    pub(crate) fn units_to_pps(&self, spec: &ModelSpec, v: i32) -> i32 {
        match spec.kinematics {
            Kinematics::Pps => v,
            k => k.velocity_to_pps(v, self.ap(&spec.axis, Setting::PulseDivisor).unwrap_or(0)),
        }
    }

    /// A velocity in microsteps per second in the model's unit (the inverse of [`Axis::units_to_pps`]).
    #[inline]
    pub(crate) fn pps_to_units(&self, spec: &ModelSpec, pps: i32) -> i32 {
        match spec.kinematics {
            Kinematics::Pps => pps,
            k => k.pps_to_velocity(pps, self.ap(&spec.axis, Setting::PulseDivisor).unwrap_or(0)),
        }
    }

    /// The ramp parameters the motor runs with: an interpolated MVP COORD's scaled speed and acceleration
    /// while it still heads for that move's target in position mode (`module/coordinated.rs`), else its
    /// own ([`Axis::own_ramp_params`]).
    #[inline]
    pub(crate) fn ramp_params(&self, spec: &ModelSpec) -> RampParams {
        if let Some((target, p)) = self.interpolation {
            if self.ramp.mode == Mode::Position && self.ramp.target_position == target {
                return p;
            }
        }
        self.own_ramp_params(spec)
    }

    /// The ramp parameters the motor's own AP 4, 5 and 130 give (PD28-1021 manual chapter 4, Table 15),
    /// in microsteps per second (and per second²) through `spec`'s kinematics.
    #[inline]
    pub(crate) fn own_ramp_params(&self, spec: &ModelSpec) -> RampParams {
        let ap = |setting| self.ap(&spec.axis, setting);
        // The maximum speed and acceleration exist in every model (checked by ModelSpec::new).
        let (v, a) = (ap(Setting::MaxPositioningSpeed).unwrap_or(1), ap(Setting::MaxAcceleration).unwrap_or(1));
        let v_min = ap(Setting::MinimumSpeed).unwrap_or(0);
        match spec.kinematics {
            Kinematics::Pps => RampParams { max_speed: v, max_accel: a, min_speed: v_min },
            k => {
                let pulse = ap(Setting::PulseDivisor).unwrap_or(0);
                let ramp = ap(Setting::RampDivisor).unwrap_or(0);
                RampParams {
                    max_speed: k.velocity_to_pps(v, pulse).max(1),
                    max_accel: k.acceleration_to_pps2(a, pulse, ramp).max(1),
                    min_speed: k.velocity_to_pps(v_min, pulse),
                }
            }
        }
    }

    /// AP 2 (the TMC428's v_target) in position mode: the ramp sets it itself, to ±v_max (AP 4) while it
    /// accelerates or runs at its top speed and to 0 while it decelerates or stands (PDx-113 manual,
    /// revision V1.10 p. 25, AP 2 "target (next) speed"; the manual V1.04 in hand lists AP 2 without
    /// saying so). The sign is the direction of travel, as the register is signed (±2047). A velocity
    /// written in position mode is kept for the next velocity mode (ROR/ROL) and read there again. The
    /// TMC429 of the TMCM-1140/3110/6110 does the same (its datasheet's ramp generator; odemis' driver and
    /// pytrinamic read AP 2 of those modules as the TMC429's register).
    #[inline]
    pub(crate) fn hardware_target_speed(&self, spec: &ModelSpec) -> i32 {
        let p = self.ramp_params(spec);
        let v_max = self.ap(&spec.axis, Setting::MaxPositioningSpeed).unwrap_or(0);
        self.ramp.driving(&p) * v_max
    }

    /// Leaves torque mode (every motion command; TMCM-1310 manual §3.4, AP 14).
    #[inline]
    pub(crate) fn leave_torque_mode(&mut self) {
        self.cl.torque = None;
    }

    /// GAP (PD28-1021 manual §3.7.6) of the axis parameter at index `i` of `spec`'s axis table, whose
    /// role is `role`, if the motor's own state gives it (chapter 4, Table 15): its value in RAM, the
    /// ramp's positions, speeds and mode, the error flags (AP 207, "cleared automatically when read"), the
    /// closed loop's own registers. `None` for a parameter that reads the board (the switches, the
    /// driver, the encoder) or what the closed loop measures: [`Motor::read`] reads those.
    #[inline]
    pub(crate) fn read_param(&mut self, spec: &ModelSpec, i: usize, role: Role) -> Option<i32> {
        let ramp = &self.ramp;
        Some(match role {
            Role::Plain | Role::MicrostepResolution | Role::EncoderPrescaler => self.params[i],
            Role::TargetPosition => ramp.target_position,
            Role::ActualPosition if !self.cl.active => ramp.position,
            // TMC428/TMC429 units (the PDx-113, the TMCM-1140/3110/6110): in position mode the motion
            // controller sets v_target itself (see `hardware_target_speed`).
            Role::TargetSpeed if ramp.mode == Mode::Position && spec.kinematics.is_tmc428() => {
                self.hardware_target_speed(spec)
            }
            Role::TargetSpeed => self.pps_to_units(spec, ramp.target_velocity),
            Role::ActualSpeed => self.pps_to_units(spec, ramp.velocity()),
            Role::RampMode => i32::from(ramp.mode == Mode::Velocity),
            // TMC428: 2 velocity; in position mode what was written, 0 (ramp) or 1 (soft).
            Role::RampModeTmc428 if ramp.mode == Mode::Velocity => 2,
            Role::RampModeTmc428 => i32::from(self.params[i] == 1),
            // AP 207: "cleared automatically when read".
            Role::ErrorFlags => i32::from(core::mem::take(&mut self.error_flags)),
            Role::TargetCurrent => self.cl.torque.map_or(self.params[i], |(t, _)| t),
            Role::I2tSum => self.cl.i2t.clamp(0, i64::from(i32::MAX)) as i32,
            Role::I2tExceedCount => self.cl.i2t_count as i32,
            Role::CurrentScale => i32::from(self.cl.scaler),
            Role::EncoderInit => self.cl.init.code(),
            Role::ClosedLoopActive => i32::from(self.cl.active),
            Role::Gamma => self.cl.gamma,
            Role::VirtualPosition => ramp.position,
            // Virtual minus actual position in closed loop (the module's); in open loop there is no such
            // error.
            Role::PositionError if !self.cl.active => 0,
            // The board's or the closed loop's measurements.
            Role::ActualPosition
            | Role::PositionError
            | Role::PositionReached
            | Role::HomeSwitch
            | Role::RightSwitch
            | Role::LeftSwitch
            | Role::ActualCurrent
            | Role::LoadValue
            | Role::DriverFlags
            | Role::EncoderPosition
            | Role::EncoderAbsolute
            | Role::VelocityReached
            | Role::StatusWord
            | Role::ActualTorqueCurrent
            | Role::MeasuredVelocity => return None,
            _ => self.params[i],
        })
    }

    /// SAP/AAP (PD28-1021 manual §3.7.5, §3.7.29) of the axis parameter at index `i` of `spec`'s axis
    /// table, whose role is `role`, to `v` (already checked against its range and protection), for one
    /// the motor's own state takes: every parameter but those that move the encoder's reference or reach
    /// the closed loop (AP 1, 14, 132, 209, 210), which [`Motor::write`] writes.
    #[inline]
    pub(crate) fn write_param(&mut self, spec: &ModelSpec, i: usize, role: Role, v: i32) {
        match role {
            // Writing the target position starts a move in position mode (§3.7.29's AAP example "transfer
            // result to target position" relies on it).
            Role::TargetPosition => {
                self.leave_torque_mode();
                self.ramp.move_to(v)
            }
            // AP 2: the velocity-mode target; in position mode it is kept for the next velocity mode.
            Role::TargetSpeed => self.ramp.target_velocity = self.units_to_pps(spec, v),
            // Listed RW in Table 15: accepted, no effect: the ramp generator owns the actual speed.
            Role::ActualSpeed => {}
            Role::RampMode => self.ramp.mode = if v == 1 { Mode::Velocity } else { Mode::Position },
            // TMC428: 2 velocity mode; 0 ramp and 1 soft are position mode (the soft approach is not
            // simulated).
            Role::RampModeTmc428 => {
                self.ramp.mode = if v == 2 { Mode::Velocity } else { Mode::Position };
                self.params[i] = v;
            }
            Role::ClearI2t => self.cl.i2t_exceeded = false,
            Role::I2tExceedCount => self.cl.i2t_count = v as u32,
            _ => self.params[i] = v,
        }
    }
}

/// Motor `m`'s logical switch states (AP 9, 10, 11: left, right, home) as `board` reads them; `invert`
/// (GP 79) reverses the polarity of the end switches.
#[inline(always)]
pub(crate) fn switches(m: usize, board: &mut impl SwitchInputs, invert: bool) -> (bool, bool, bool) {
    let s = board.switches(m);
    (s.left ^ invert, s.right ^ invert, s.home)
}

/// The motors of a module: [`MAX_MOTORS`] slots, of which the model's first `count` run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Axes {
    list: [Axis; MAX_MOTORS as usize],
    count: u8,
}

impl Axes {
    /// `count` motors (1..=[`MAX_MOTORS`], checked by the model) at power-up at `now`.
    pub(crate) fn new(count: u8, now: Instant) -> Axes {
        Axes { list: core::array::from_fn(|_| Axis::new(now)), count: count.clamp(1, MAX_MOTORS) }
    }

    /// How many motors run. (A build for one motor knows it at compile time: its loops over the motors
    /// are one pass, without bounds checks.)
    #[inline(always)]
    pub fn count(&self) -> usize {
        if MAX_MOTORS == 1 {
            1
        } else {
            usize::from(self.count)
        }
    }

    /// The motors that run.
    pub fn iter(&self) -> impl Iterator<Item = &Axis> {
        self.list[..self.count()].iter()
    }

    /// The motors that run, to change.
    pub(crate) fn iter_mut(&mut self) -> impl Iterator<Item = &mut Axis> {
        let count = self.count();
        self.list[..count].iter_mut()
    }

    /// Motor `m`, if the model has it.
    pub fn get(&self, m: usize) -> Option<&Axis> {
        self.list[..self.count()].get(m)
    }

    /// The earliest instant at which a motor's driver current changes by itself (standby,
    /// freewheeling) or the board must be told of a change, and which motor.
    #[inline(always)]
    pub(crate) fn drive_due(&self) -> Option<(usize, Instant)> {
        if self.count() == 1 {
            // (One motor, the common case: on the path of every instruction and tick.)
            return self.list[0].drive_due.map(|d| (0, d));
        }
        let mut due: Option<(usize, Instant)> = None;
        for (m, axis) in self.iter().enumerate() {
            if let Some(d) = axis.drive_due {
                if due.is_none_or(|(_, t)| d < t) {
                    due = Some((m, d));
                }
            }
        }
        due
    }

    /// Whether every motor stands (no ramp moving, no reference search).
    #[inline(always)]
    pub(crate) fn all_standing(&self) -> bool {
        if self.count() == 1 {
            return self.list[0].is_standing();
        }
        self.iter().all(|a| a.is_standing())
    }
}

impl core::ops::Index<usize> for Axes {
    type Output = Axis;
    #[inline(always)]
    fn index(&self, m: usize) -> &Axis {
        &self.list[m]
    }
}

impl core::ops::IndexMut<usize> for Axes {
    #[inline(always)]
    fn index_mut(&mut self, m: usize) -> &mut Axis {
        &mut self.list[m]
    }
}

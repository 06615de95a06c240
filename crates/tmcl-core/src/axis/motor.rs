//! One motor with what it reaches: [`Motor`], the view of an [`Axis`] together with the board it
//! drives, the model and the global settings it reads.
//!
//! Everything a motor does at a motion tick and every parameter that reads the board or the closed loop
//! is here, in one component: the drive state the board is told (current, standby, freewheeling;
//! PD28-1021 manual §4, Table 22), the switches and the limits they set (AP 9–13, GP 79), the ramp's
//! (part of a) tick, the reference search's step (§7.1), coolStep, stop on stall and the encoder
//! (`drive.rs`: §6.2, §7.2, §7.3), the closed loop (`closed_loop.rs`: TMCM-1310 manual §3.4) and the
//! axis parameters that read them (`params.rs`). What a motor does beyond itself — a program flag, an
//! interrupt, a pending 138 event dropped — it does not do: it returns it as [`Faults`], which the module
//! applies to the program machine.
//!
//! A `Motor` borrows the parts apart (the axis, the board behind its seam, the global banks) for the
//! length of one call; the module makes one with `Module::motor_at`.

use super::Axis;

use crate::hal::prelude::*;
use crate::hal::{Board, DriveState, DriverSettings};
use crate::model::{ModelSpec, Setting};
use crate::motion::reference::{Action, SwitchLevels};
use crate::motion::{Limits, Mode, RampParams, SearchMode, TICK};
use crate::param::banks::Banks;
use crate::seam::Seam;
use crate::time::{Duration, Instant};
use tmcl_wire::{RfsAction, Status};

/// What a motor's tick or command did that reaches beyond the motor, for the module to apply: the stops
/// for a fault it made (AP 207 bits, [`error_flags`](crate::drive::error_flags): a stall raises the stall
/// interrupt; a deviation or following error sets the program's deviation flag and raises the deviation
/// interrupt, PD28-1021 manual §6.2, §7.2, §3.6.6.1), and whether the pending 138 event is dropped (a
/// stop for a fault, or torque mode, ends the move it waited for).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[must_use]
pub(crate) struct Faults {
    /// The AP 207 bits of the stops made ([`error_flags`](crate::drive::error_flags)).
    pub(crate) stops: u8,
    /// The pending 138 event is dropped.
    pub(crate) drop_event: bool,
}

impl Faults {
    /// Nothing beyond the motor.
    pub(crate) const NONE: Faults = Faults { stops: 0, drop_event: false };

    /// Both.
    #[inline(always)]
    pub(crate) fn and(self, other: Faults) -> Faults {
        Faults { stops: self.stops | other.stops, drop_event: self.drop_event || other.drop_event }
    }

    /// Whether there is anything to apply.
    #[inline(always)]
    pub(crate) fn any(&self) -> bool {
        self.stops != 0 || self.drop_event
    }
}

/// Motor `m` with what it reaches (see the module docs).
pub(crate) struct Motor<'a, B> {
    /// The motor's index (the motor byte of a command).
    pub(crate) m: usize,
    pub(crate) axis: &'a mut Axis,
    pub(crate) spec: &'static ModelSpec,
    /// The global banks: the motor reads GP 79 (end switch polarity) and GP 90 (reverse shaft).
    pub(crate) banks: &'a Banks,
    /// The board, behind the seam that counts every change.
    pub(crate) board: &'a mut Seam<B>,
}

impl<B: Board> Motor<'_, B> {
    /// The value of the axis parameter with `setting`, if the model has one.
    #[inline(always)]
    pub(crate) fn ap(&self, setting: Setting) -> Option<i32> {
        self.axis.ap(&self.spec.axis, setting)
    }

    /// Sets the axis parameter with `setting`, if the model has one (results the firmware produces, e.g.
    /// AP 196/197, AP 112).
    #[inline]
    pub(crate) fn set_ap(&mut self, setting: Setting, v: i32) {
        if let Some(i) = self.spec.axis.setting(setting) {
            self.axis.params[i] = v;
        }
    }

    /// Whether the bank 0 flag with `setting` is set (a model without it: not set).
    #[inline(always)]
    fn gp_flag(&self, setting: Setting) -> bool {
        self.banks.flag(self.spec, setting)
    }

    /// A velocity in the model's unit as microsteps per second ([`Axis::units_to_pps`]).
    #[inline]
    pub(crate) fn units_to_pps(&self, v: i32) -> i32 {
        self.axis.units_to_pps(self.spec, v)
    }

    /// The microstep resolution as a power of two (AP 140); 8 (256 microsteps) for a model without it.
    #[inline]
    pub(crate) fn microstep_resolution(&self) -> u8 {
        self.axis.microstep_resolution(&self.spec.axis)
    }

    /// Logical switch states (AP 9, 10, 11: left, right, home): GP 79 reverses the polarity of the end
    /// switches.
    #[inline]
    pub(crate) fn switches(&mut self) -> (bool, bool, bool) {
        let invert = self.gp_flag(Setting::EndSwitchPolarity);
        super::switches(self.m, self.board, invert)
    }

    /// What the stop switches block now (see [`Axis::limits`]).
    #[inline]
    pub(crate) fn limits(&mut self) -> Limits {
        let invert = self.gp_flag(Setting::EndSwitchPolarity);
        self.axis.limits(self.m, &self.spec.axis, self.board, invert)
    }

    /// Encoder counts in the logical direction (GP 90 reverses motor and encoder, manual §5.1).
    #[inline]
    pub(crate) fn logical_counts(&self, physical: i64) -> i64 {
        if self.gp_flag(Setting::ReverseShaft) {
            -physical
        } else {
            physical
        }
    }

    /// Tells the board the stallGuard2 settings and the current range (start-up, and after a write to
    /// AP 173, 174 or 179).
    pub(crate) fn configure_driver(&mut self) {
        let settings = DriverSettings {
            stall_filter: self.ap(Setting::StallFilter) == Some(1),
            stall_threshold: self.ap(Setting::StallThreshold).unwrap_or(0).clamp(-64, 63) as i8,
            high_range: self.ap(Setting::CurrentRange) == Some(0),
            ssi_encoder: self.ssi_selected(),
        };
        self.board.configure(self.m, &settings);
    }

    /// The current setting now (AP 6, 7, 200, 204, 214, 167) and whether the driver is on.
    #[inline]
    pub(crate) fn current(&self, now: Instant) -> (u8, bool) {
        if self.ap(Setting::ChopperOffTime) == Some(0) {
            return (0, false); // AP 167 = 0 "completely disables all driver transistors"
        }
        if let Some(current) = self.closed_loop_current() {
            // The closed loop sets the current itself (scaling, torque mode): no standby, no freewheeling.
            return (current, true);
        }
        match self.axis.standstill_since {
            None => (self.regulated_current(self.run_current()), true),
            Some(since) => {
                let still = now - since;
                let run = self.ap(Setting::RunCurrent).unwrap_or(255);
                let table = &self.spec.axis;
                if self.axis.delay(table, Setting::FreewheelingDelay).is_some_and(|d| still >= d) {
                    (0, false)
                } else if self.axis.delay(table, Setting::PowerDownDelay).is_some_and(|d| still >= d) {
                    (self.ap(Setting::StandbyCurrent).unwrap_or(run) as u8, true)
                } else {
                    (run as u8, true)
                }
            }
        }
    }

    /// The current for a moving motor before coolStep: the boost current AP 200 while the speed changes
    /// (if not 0), else the run current AP 6 (Table 22). AP 200 is not looked up while cruising.
    #[inline]
    pub(crate) fn run_current(&self) -> i32 {
        let boost = if self.axis.ramping { self.ap(Setting::BoostCurrent).unwrap_or(0) } else { 0 };
        if boost != 0 {
            boost
        } else {
            self.ap(Setting::RunCurrent).unwrap_or(255)
        }
    }

    /// Tells the board the motor's drive state at `now`, if it changed (or steps moved) since it was last
    /// told; and when the driver current next changes by itself.
    pub(crate) fn update_board(&mut self, now: Instant) {
        let (current, enabled) = self.current(now);
        let state = DriveState {
            moved: self.axis.unreported_steps,
            position: self.axis.ramp.position,
            velocity: self.axis.ramp.velocity(),
            resolution: self.microstep_resolution(),
            current,
            enabled,
            reverse: self.gp_flag(Setting::ReverseShaft),
        };
        self.axis.drive_due = self.axis.next_event(&self.spec.axis, now);
        let unchanged = DriveState { moved: 0, ..state };
        if state.moved == 0 && self.axis.last_drive == Some(unchanged) {
            return;
        }
        self.axis.unreported_steps = 0;
        self.axis.last_drive = Some(unchanged);
        self.axis.board_time = now;
        self.board.update(self.m, now, &state);
    }

    /// Brings the board to `now` before a read of something that changes with its own clock (a bouncing
    /// switch, the driver's standstill flag): an update with what it was last told, if it has not heard
    /// from the module since. Outside the motion ticks the board's clock would otherwise be wherever the
    /// caller's polls left it.
    pub(crate) fn sync_board(&mut self, now: Instant) {
        if now <= self.axis.board_time {
            return;
        }
        self.update_board(now);
        if self.axis.board_time < now {
            if let Some(state) = self.axis.last_drive {
                self.axis.board_time = now;
                // The same state again, only to bring the board's clock on: no change (`seam.rs`).
                self.board.timeline().update(self.m, now, &state);
            }
        }
    }

    /// The motion tick from `from` (the motion clock) to `tick_at` = `from` + [`TICK`], in `parts` (one per microstep
    /// of a reference search, [`Axis::tick_parts`]): per part the board brought to its start, the ramp
    /// within the switches' limits, the closed loop (`closed_loop`: a closed-loop model), the standstill,
    /// the board told, the reference search's look at its switch.
    #[inline(always)]
    pub(crate) fn tick(
        &mut self,
        from: Instant,
        tick_at: Instant,
        parts: u64,
        params: &RampParams,
        closed_loop: bool,
    ) -> Faults {
        let tick = TICK;
        let mut faults = Faults::NONE;
        // (Most ticks are one part: no 64-bit division for them.)
        let step = if parts == 1 { tick.micros() } else { tick.micros() / parts };
        for k in 1..=parts {
            let t = if k == parts { tick_at } else { from + Duration::from_micros(step * k) };
            let dt = if k == parts { tick.micros() - step * (parts - 1) } else { step };
            // The switches as they are at the start of this (part of a) tick, a bouncing one too: the
            // board's clock there, not where the last update or the caller's poll left it.
            self.sync_board(t - Duration::from_micros(dt));
            let limits = self.limits();
            let steps = self.axis.advance(Duration::from_micros(dt), params, limits);
            let steps = if closed_loop {
                let (steps, f) = self.closed_loop_tick(steps, dt as i64);
                faults = faults.and(f);
                steps
            } else {
                steps
            };
            self.axis.moved(t, steps);
            self.update_board(t);
            if self.axis.reference.is_active() {
                self.step_reference();
            }
        }
        faults
    }

    /// What MVP REL counts from: AP 127 (TMCM-1316's options: 0 the last target, 1 the ramp's position,
    /// 2 the encoder), or the actual position for a model without it (PD28-1021 §3.7.4).
    pub(crate) fn relative_base(&mut self) -> i32 {
        match self.ap(Setting::RelativePositioning) {
            Some(0) => self.axis.ramp.target_position,
            Some(2) => self.encoder_position(),
            _ => self.axis.ramp.position,
        }
    }

    /// RFS START/STOP/STATUS (§3.7.13, §7.1); see [`crate::motion::reference`] for the decisions. The
    /// value the reply carries, and (START) the pending 138 event dropped: the search takes the motor over.
    pub(crate) fn reference_search(&mut self, action: RfsAction) -> Result<(i32, Faults), Status> {
        match action {
            RfsAction::Start => {
                // AP 193 is range-checked on write, so it always decodes.
                let value = self.ap(Setting::ReferenceSearchMode).ok_or(Status::NotAvailable)?;
                let mode = SearchMode::decode(value, self.spec.reference_modes).ok_or(Status::InvalidValue)?;
                let (fast, slow) = self.reference_speeds();
                if fast == 0 || slow == 0 {
                    // A search at speed 0 would never end: refused (our decision).
                    return Err(Status::InvalidValue);
                }
                let axis = &mut *self.axis;
                axis.error_flags = 0;
                axis.leave_torque_mode();
                axis.interpolation = None;
                if let Action::Rotate(v) = axis.reference.start(mode, fast) {
                    axis.ramp.hard_stop();
                    axis.ramp.rotate(v);
                }
                Ok((0, Faults { stops: 0, drop_event: true }))
            }
            RfsAction::Stop => {
                let axis = &mut *self.axis;
                if axis.reference.is_active() {
                    axis.reference.stop();
                    axis.ramp.rotate(0);
                }
                Ok((0, Faults::NONE))
            }
            RfsAction::Status => Ok((self.axis.reference.status(), Faults::NONE)),
        }
    }

    /// The search and switch speeds of the reference search in microsteps per second (AP 194, 195).
    #[inline]
    pub(crate) fn reference_speeds(&self) -> (i32, i32) {
        let speed = |s| self.units_to_pps(self.ap(s).unwrap_or(0));
        (speed(Setting::ReferenceSearchSpeed), speed(Setting::ReferenceSwitchSpeed))
    }

    /// One step of the reference search after a (part of a) motion tick (§7.1).
    fn step_reference(&mut self) {
        let (left, right, home) = self.switches();
        let levels = SwitchLevels { left, right, home };
        let (fast, slow) = self.reference_speeds();
        let position = self.axis.ramp.position;
        match self.axis.reference.step(levels, position, fast, slow) {
            Action::Continue => {}
            Action::Rotate(v) => {
                self.axis.ramp.hard_stop();
                self.axis.ramp.rotate(v);
            }
            Action::Done { zero, far_distance } => {
                self.axis.ramp.hard_stop();
                // AP 197: "position value just before the counter is zeroed"; AP 196: end switch distance.
                self.set_ap(Setting::LastReferencePosition, position);
                if let Some(d) = far_distance {
                    self.set_ap(Setting::EndSwitchDistance, d);
                }
                let ramp = &mut self.axis.ramp;
                ramp.mode = Mode::Position;
                ramp.set_position(position.wrapping_sub(zero));
                ramp.target_position = ramp.position;
                self.relabel(zero.wrapping_neg());
            }
            Action::Failed => self.axis.ramp.hard_stop(),
        }
    }

    /// Whether the reference search, looking at its switches as they are now, goes on as it is (the
    /// position matters only where the switch it waits for reads as it waits for): within a quiet window
    /// of the board, where the switches stay, every look decides the same.
    pub(crate) fn search_goes_on(&mut self) -> bool {
        let (left, right, home) = self.switches();
        let (fast, slow) = self.reference_speeds();
        let mut reference = self.axis.reference;
        let decision = reference.step(SwitchLevels { left, right, home }, self.axis.ramp.position, fast, slow);
        decision == Action::Continue && reference == self.axis.reference
    }

    /// Stops the motor at once for a stall, a deviation or a following error: AP 207 bit `flag` (one of
    /// [`error_flags`](crate::drive::error_flags)); the interrupt, the program's flag and the pending 138
    /// event are the module's ([`Faults`]).
    pub(crate) fn fault_stop(&mut self, flag: u8) -> Faults {
        self.axis.ramp.hard_stop();
        self.axis.reference.stop();
        self.axis.error_flags |= flag;
        Faults { stops: flag, drop_event: true }
    }
}

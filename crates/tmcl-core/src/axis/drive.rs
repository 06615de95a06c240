//! What a motor does with the drive models at every motion tick: coolStep, stop on stall, the encoder's
//! deviation check and clear-on-null (PD28-1021 manual §6.2, §7.2, §7.3; AP 168–183, 206–215), and the
//! encoder's position (AP 209, 215; TMCM-1310 manual §3.4 for an SSI encoder).

use super::motor::{Faults, Motor};
use super::EncoderBase;
use crate::drive::coolstep::{CoolStepParams, Regime};
use crate::drive::{encoder, error_flags, stall};
use crate::hal::prelude::*;
use crate::hal::Board;
use crate::model::{Role, Setting};

impl<B: Board> Motor<'_, B> {
    /// The coolStep parameters for a run-current setting `run` (AP 6, or AP 200 while boosting).
    pub(crate) fn coolstep_params(&self, run: i32) -> CoolStepParams {
        let ap = |s| self.ap(s).unwrap_or(0);
        CoolStepParams {
            cs: (run.clamp(0, 255) >> 3) as u8,
            min_quarter: ap(Setting::CoolStepMinimum) == 1,
            down_step: ap(Setting::CoolStepDownStep) as u8,
            hysteresis: ap(Setting::CoolStepHysteresis) as u8,
            up_step: ap(Setting::CoolStepUpStep) as u8,
            hysteresis_start: ap(Setting::CoolStepHysteresisStart) as u8,
            speed: self.axis.ramp.velocity().unsigned_abs(),
            threshold_speed: self.units_to_pps(ap(Setting::CoolStepThresholdSpeed)).max(0) as u32,
            slow_run_current: ap(Setting::SlowRunCurrent).clamp(0, 255) as u8,
        }
    }

    /// The running current after coolStep (AP 180 is this / 8): the slow-run current AP 183 at or below
    /// AP 182, else `run` itself when coolStep is off.
    #[inline]
    pub(crate) fn regulated_current(&self, run: i32) -> u8 {
        if self.coolstep_off() && self.ap(Setting::CoolStepThresholdSpeed).unwrap_or(0) == 0 {
            // coolStep off (SEMIN = 0) and no slow-run threshold: the common case, no more lookups.
            return run.clamp(0, 255) as u8;
        }
        let params = self.coolstep_params(run);
        match params.regime() {
            Regime::Off => run.clamp(0, 255) as u8,
            _ => self.axis.coolstep.peek(params) << 3,
        }
    }

    /// After each motion tick: new stallGuard2 readings (coolStep, stop on stall), and the encoder.
    #[inline]
    pub(crate) fn drive_tick(&mut self) -> Faults {
        let m = self.m;
        let mut faults = Faults::NONE;
        let measurements = self.board.load_measurements(m);
        // In closed loop the loop sets the current and watches the following error: coolStep, stop on
        // stall and the deviation check are open-loop functions (TMCM-1310 manual §1: stallGuard2 in open
        // loop only).
        let open_loop = !self.axis.cl.active;
        if measurements != self.axis.load_measurements && open_loop {
            self.axis.load_measurements = measurements;
            let load = self.board.load(m).min(1023);
            if !self.coolstep_off() {
                let params = self.coolstep_params(self.run_current());
                self.axis.coolstep.update(load, params);
            }
            // §7.2 / AP 181: stop when the load value reaches 0 above the stop-on-stall speed.
            let stop_speed = self.units_to_pps(self.ap(Setting::StopOnStall).unwrap_or(0));
            if stall::stall_stop(load, self.axis.ramp.velocity(), stop_speed) {
                faults = faults.and(self.fault_stop(error_flags::STALL));
            }
        }
        let prescaler = self.prescaler();
        let deviation = if open_loop { self.ap(Setting::MaxEncoderDeviation).unwrap_or(0) } else { 0 };
        if deviation == 0 && !encoder::clear_on_null_enabled(prescaler) {
            return faults;
        }
        let counts = self.encoder_counts_now();
        // §6.2: AP 210 + 4 clears the encoder position each time it passes its absolute zero.
        if encoder::clear_on_null_enabled(prescaler) {
            if let Some(zero) = encoder::null_crossing(self.axis.last_counts, counts, self.counts_per_rev()) {
                self.axis.encoder = EncoderBase { counts: zero, value: 0 };
            }
        }
        self.axis.last_counts = counts;
        // §6.2 / AP 212: stop when AP 1 and AP 209 differ by more than AP 212 while the motor is driven.
        if deviation > 0 && !self.axis.ramp.is_idle() {
            let e = self.encoder_value(counts);
            if encoder::deviation_exceeded(self.axis.ramp.position, e, deviation) {
                faults = faults.and(self.fault_stop(error_flags::DEVIATION));
            }
        }
        faults
    }

    /// Whether coolStep is off: AP 172 (SEMIN) = 0, or a model without coolStep.
    #[inline]
    pub(crate) fn coolstep_off(&self) -> bool {
        self.ap(Setting::CoolStepHysteresisStart).unwrap_or(0) == 0
    }

    /// AP 210, the encoder prescaler (512 = 1:1 for a model without one).
    #[inline]
    pub(crate) fn prescaler(&self) -> i32 {
        self.spec.axis.role(Role::EncoderPrescaler).map_or(512, |i| self.axis.params[i])
    }

    /// The encoder's counts per revolution (1024 on the PD28-1021, §6.2); a model without an encoder
    /// counts nothing, so any value is right: 1024.
    #[inline]
    pub(crate) fn counts_per_rev(&self) -> u32 {
        self.spec.encoder.map_or(1024, |e| e.counts_per_rev.max(1))
    }

    /// Whether the SSI encoder input is selected (TMCM-1310 AP 201 bit 0, our decision).
    #[inline]
    pub(crate) fn ssi_selected(&self) -> bool {
        self.ap(Setting::EncoderMode).unwrap_or(0) & 1 == 1
    }

    /// Encoder counts now, in the logical direction. An SSI encoder reports its angle within one turn; the
    /// turns are counted here from the shorter way between two readings (read at least every tick while
    /// the motor moves, far more often than half a turn).
    pub(crate) fn encoder_counts_now(&mut self) -> i64 {
        let mut physical = self.board.encoder_counts(self.m);
        if self.ssi_selected() {
            let per_rev = i64::from(self.ap(Setting::EncoderResolution).unwrap_or(1).max(1));
            let (last, total) = self.axis.ssi;
            let step = (physical - last + per_rev / 2).rem_euclid(per_rev) - per_rev / 2;
            self.axis.ssi = (physical, total + step);
            physical = total + step;
        }
        self.logical_counts(physical)
    }

    /// AP 209 for the given counts: the reference value plus the counts since, through the prescaler
    /// (PD28-1021) or the encoder and motor resolutions (closed-loop models).
    pub(crate) fn encoder_value(&self, counts: i64) -> i32 {
        let since = counts - self.axis.encoder.counts;
        let delta = match self.counts_to_usteps(since) {
            Some(d) => d,
            None => encoder::scale_counts(since, self.prescaler()),
        };
        (i64::from(self.axis.encoder.value) + delta) as i32
    }

    /// AP 209 = value at the reference + counts since × p / 512 (§6.2).
    pub(crate) fn encoder_position(&mut self) -> i32 {
        let counts = self.encoder_counts_now();
        self.encoder_value(counts)
    }

    /// Sets AP 209 to `v` at the counts the encoder reads now.
    pub(crate) fn set_encoder(&mut self, v: i32) {
        let counts = self.encoder_counts_now();
        self.axis.encoder = EncoderBase { counts, value: v };
        // Clear-on-null (AP 210 + 4) looks for zero crossings from here on: not between a reading from
        // before (taken when it was last on, perhaps long ago) and the next one, which would depend on
        // when that next one is taken.
        self.axis.last_counts = counts;
    }

    /// AP 215: the absolute single-turn value 0..counts per revolution − 1 (0..1023 on the PD28-1021),
    /// independent of the prescaler (§6.2).
    pub(crate) fn encoder_absolute(&mut self) -> i32 {
        self.encoder_counts_now().rem_euclid(i64::from(self.counts_per_rev())) as i32
    }

    /// GIO 11, 0: the encoder is within 1/256 of a revolution (±4 counts, ±1.4° on the PD28-1021) of its
    /// absolute zero (our tolerance; §6.2 gives none).
    pub(crate) fn encoder_near_zero(&mut self) -> bool {
        let per_rev = self.counts_per_rev() as i32;
        let tolerance = (per_rev / 256).max(1);
        let a = self.encoder_absolute();
        !(tolerance..=per_rev - tolerance).contains(&a)
    }
}

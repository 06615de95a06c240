//! How the module uses the drive models at every motion tick: coolStep, stop on stall, the encoder's
//! deviation check and clear-on-null (PD28-1021 manual §6.2, §7.2, §7.3; AP 168–183, 206–215), and the
//! driver settings the board needs (AP 173, 174, 179).

use super::{error_flags, EncoderBase, Module};
use crate::drive::coolstep::{CoolStepParams, Regime};
use crate::drive::{encoder, stall};
use crate::hal::prelude::*;
use crate::hal::{Board, DriverSettings};
use crate::model::{Role, Setting};
use crate::vm::flags;

impl<B: Board> Module<B> {
    /// Tells the board the stallGuard2 settings and the current range (start-up, and after a write to
    /// AP 173, 174 or 179).
    pub(crate) fn configure_driver(&mut self, m: usize) {
        let settings = DriverSettings {
            stall_filter: self.ap(m, Setting::StallFilter) == Some(1),
            stall_threshold: self.ap(m, Setting::StallThreshold).unwrap_or(0).clamp(-64, 63) as i8,
            high_range: self.ap(m, Setting::CurrentRange) == Some(0),
            ssi_encoder: self.ssi_selected(m),
        };
        self.board.configure(m, &settings);
    }

    /// The coolStep parameters for a run-current setting `run` (AP 6, or AP 200 while boosting).
    pub(crate) fn coolstep_params(&self, m: usize, run: i32) -> CoolStepParams {
        let ap = |s| self.ap(m, s).unwrap_or(0);
        CoolStepParams {
            cs: (run.clamp(0, 255) >> 3) as u8,
            min_quarter: ap(Setting::CoolStepMinimum) == 1,
            down_step: ap(Setting::CoolStepDownStep) as u8,
            hysteresis: ap(Setting::CoolStepHysteresis) as u8,
            up_step: ap(Setting::CoolStepUpStep) as u8,
            hysteresis_start: ap(Setting::CoolStepHysteresisStart) as u8,
            speed: self.st.axes[m].ramp.velocity().unsigned_abs(),
            threshold_speed: self.units_to_pps(m, ap(Setting::CoolStepThresholdSpeed)).max(0) as u32,
            slow_run_current: ap(Setting::SlowRunCurrent).clamp(0, 255) as u8,
        }
    }

    /// The running current after coolStep (AP 180 is this / 8): the slow-run current AP 183 at or below
    /// AP 182, else `run` itself when coolStep is off.
    #[inline]
    pub(crate) fn regulated_current(&self, m: usize, run: i32) -> u8 {
        if self.coolstep_off(m) && self.ap(m, Setting::CoolStepThresholdSpeed).unwrap_or(0) == 0 {
            // coolStep off (SEMIN = 0) and no slow-run threshold: the common case, no more lookups.
            return run.clamp(0, 255) as u8;
        }
        let params = self.coolstep_params(m, run);
        match params.regime() {
            Regime::Off => run.clamp(0, 255) as u8,
            _ => self.st.axes[m].coolstep.peek(params) << 3,
        }
    }

    /// After each motion tick: new stallGuard2 readings (coolStep, stop on stall), and the encoder.
    #[inline]
    pub(crate) fn drive_tick(&mut self, m: usize) {
        let measurements = self.board.load_measurements(m);
        // In closed loop the loop sets the current and watches the following error: coolStep, stop on
        // stall and the deviation check are open-loop functions (TMCM-1310 manual §1: stallGuard2 in open
        // loop only).
        let open_loop = !self.st.axes[m].cl.active;
        if measurements != self.st.axes[m].load_measurements && open_loop {
            self.st.axes[m].load_measurements = measurements;
            let load = self.board.load(m).min(1023);
            if !self.coolstep_off(m) {
                let params = self.coolstep_params(m, self.run_current(m));
                self.st.axes[m].coolstep.update(load, params);
            }
            // §7.2 / AP 181: stop when the load value reaches 0 above the stop-on-stall speed.
            let stop_speed = self.units_to_pps(m, self.ap(m, Setting::StopOnStall).unwrap_or(0));
            if stall::stall_stop(load, self.st.axes[m].ramp.velocity(), stop_speed) {
                self.fault_stop(m, error_flags::STALL, self.spec.interrupts.stall(m));
            }
        }
        let prescaler = self.prescaler(m);
        let deviation = if open_loop { self.ap(m, Setting::MaxEncoderDeviation).unwrap_or(0) } else { 0 };
        if deviation == 0 && !encoder::clear_on_null_enabled(prescaler) {
            return;
        }
        let counts = self.encoder_counts_now(m);
        // §6.2: AP 210 + 4 clears the encoder position each time it passes its absolute zero.
        if encoder::clear_on_null_enabled(prescaler) {
            if let Some(zero) = encoder::null_crossing(self.st.axes[m].last_counts, counts, self.counts_per_rev()) {
                self.st.axes[m].encoder = EncoderBase { counts: zero, value: 0 };
            }
        }
        self.st.axes[m].last_counts = counts;
        // §6.2 / AP 212: stop when AP 1 and AP 209 differ by more than AP 212 while the motor is driven.
        if deviation > 0 && !self.st.axes[m].ramp.is_idle() {
            let e = self.encoder_value(m, counts);
            if encoder::deviation_exceeded(self.st.axes[m].ramp.position, e, deviation) {
                self.st.regs.flags |= flags::DEVIATION;
                self.fault_stop(m, error_flags::DEVIATION, self.spec.interrupts.deviation(m));
            }
        }
    }

    /// Whether coolStep is off: AP 172 (SEMIN) = 0, or a model without coolStep.
    #[inline]
    pub(crate) fn coolstep_off(&self, m: usize) -> bool {
        self.ap(m, Setting::CoolStepHysteresisStart).unwrap_or(0) == 0
    }

    /// AP 210, the encoder prescaler (512 = 1:1 for a model without one).
    #[inline]
    fn prescaler(&self, m: usize) -> i32 {
        self.spec.axis.role(Role::EncoderPrescaler).map_or(512, |i| self.st.axes[m].params[i])
    }

    /// The encoder's counts per revolution (1024 on the PD28-1021, §6.2); a model without an encoder
    /// counts nothing, so any value is right: 1024.
    pub(crate) fn counts_per_rev(&self) -> u32 {
        self.spec.encoder.map_or(1024, |e| e.counts_per_rev.max(1))
    }

    /// Stops the motor at once for a stall, a deviation or a following error: AP 207 bit, interrupt (if
    /// the model has it), no 138 event.
    pub(super) fn fault_stop(&mut self, m: usize, flag: u8, interrupt: Option<u8>) {
        self.st.axes[m].ramp.hard_stop();
        self.st.axes[m].reference.stop();
        self.st.event.pending = false;
        self.st.axes[m].error_flags |= flag;
        if let Some(n) = interrupt {
            self.raise_interrupt(n);
        }
    }

    /// Whether the SSI encoder input is selected (TMCM-1310 AP 201 bit 0, our decision).
    #[inline]
    pub(crate) fn ssi_selected(&self, m: usize) -> bool {
        self.ap(m, Setting::EncoderMode).unwrap_or(0) & 1 == 1
    }

    /// Encoder counts now, in the logical direction. An SSI encoder reports its angle within one turn; the
    /// turns are counted here from the shorter way between two readings (read at least every tick while
    /// the motor moves, far more often than half a turn).
    pub(crate) fn encoder_counts_now(&mut self, m: usize) -> i64 {
        let mut physical = self.board.encoder_counts(m);
        if self.ssi_selected(m) {
            let per_rev = i64::from(self.ap(m, Setting::EncoderResolution).unwrap_or(1).max(1));
            let (last, total) = self.st.axes[m].ssi;
            let step = (physical - last + per_rev / 2).rem_euclid(per_rev) - per_rev / 2;
            self.st.axes[m].ssi = (physical, total + step);
            physical = total + step;
        }
        self.logical_counts(physical)
    }

    /// AP 209 for the given counts: the reference value plus the counts since, through the prescaler
    /// (PD28-1021) or the encoder and motor resolutions (closed-loop models).
    pub(crate) fn encoder_value(&self, m: usize, counts: i64) -> i32 {
        let since = counts - self.st.axes[m].encoder.counts;
        let delta = match self.counts_to_usteps(m, since) {
            Some(d) => d,
            None => encoder::scale_counts(since, self.prescaler(m)),
        };
        (i64::from(self.st.axes[m].encoder.value) + delta) as i32
    }
}

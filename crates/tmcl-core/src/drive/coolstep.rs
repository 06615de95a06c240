//! The coolStep current regulator of the TMC262 (PD28-1021 manual §1.2, §7.3 and Table 22; axis
//! parameters 168–172, 180, 182, 183 in chapter 4, Table 15).
//!
//! The core calls [`CoolStep::update`] once per stallGuard2 measurement (a new AP 206 value, see
//! `hal::LoadSensor::load_measurements`) and [`CoolStep::current`] whenever it needs the scale without a new
//! reading (AP 180, a speed change below the threshold). Both return the current scale 0..=31 (AP 180:
//! "0…31: 1/32 … 32/32"); the driver's current setting is then `scale × 8` in AP 6 units.
//!
//! # Decisions
//!
//! - **Thresholds (Table 15, AP 170/172).** The manual labels AP 172 the lower threshold and prints the upper one as
//!   (AP 172 + AP 170 + 1) · 32, but its "Hysteresis: (AP 172 + 1) · 32" is mislabelled and the lower
//!   formula is missing. We follow the TMC262 datasheet's SEMIN/SEMAX registers, which AP 172/170 are:
//!   the current rises when a reading is **below SEMIN · 32**, and falls when readings are **equal to or
//!   above (SEMIN + SEMAX + 1) · 32**.
//! - **Down steps (AP 169, SEDN).** The current falls by one after 32, 8, 2 or 1 readings at or above the
//!   upper threshold. Readings between the thresholds neither count nor reset the count; a reading below
//!   the lower threshold (which raises the current) resets it, as does each decrement.
//! - **Up steps (AP 171, SEUP).** Each reading below the lower threshold raises the scale by 1, 2, 4 or 8.
//! - **Bounds (AP 168, SEIMIN).** The scale stays between the minimum and CS, the scale the core chose
//!   for running (AP 6 / 8, or AP 200 / 8 while boosting). The minimum is ½ or ¼ of the *current*
//!   (CS + 1)/32, rounded down to a scale: `((CS + 1) >> 1) − 1` or `((CS + 1) >> 2) − 1`, at least 0.
//!   For CS = 31 that is 15 (16/32) and 7 (8/32).
//! - **Off (AP 172 = 0).** SEMIN = 0 switches coolStep's regulation off in the TMC262; the manual does not
//!   say so (Table 15, AP 172). Above AP 182 the scale is then CS.
//! - **Speed (AP 182, 183).** coolStep regulates only while |AP 3| is **above** AP 182 ("Above this speed
//!   coolStep becomes enabled"); at or below it the scale is AP 183 / 8, the slow-run current — whether
//!   or not coolStep is on: Table 22 ties AP 183 to the threshold speed AP 182 alone. Regulation restarts from CS each time it becomes active, so the motor starts with its full
//!   torque reserve. (Standby current after AP 214 and freewheeling are the core's business and come
//!   before this.)

/// The parameters the regulator reads, as the core has them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CoolStepParams {
    /// CS, the current scale the core chose for running, 0..=31 (AP 6 / 8; AP 200 / 8 while boosting).
    pub cs: u8,
    /// AP 168 SEIMIN: `false` = minimum ½ of CS, `true` = ¼ of CS.
    pub min_quarter: bool,
    /// AP 169 SEDN 0..=3: 32, 8, 2, 1 readings per decrement.
    pub down_step: u8,
    /// AP 170 SEMAX 0..=15: the hysteresis, in units of 32.
    pub hysteresis: u8,
    /// AP 171 SEUP 0..=3: increments of 1, 2, 4, 8.
    pub up_step: u8,
    /// AP 172 SEMIN 0..=15: the lower threshold in units of 32; 0 = coolStep off.
    pub hysteresis_start: u8,
    /// |AP 3|, the actual speed in pps.
    pub speed: u32,
    /// AP 182, the threshold speed in pps.
    pub threshold_speed: u32,
    /// AP 183, the slow-run current 0..=255.
    pub slow_run_current: u8,
}

/// What the regulator is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regime {
    /// Above AP 182 with AP 172 = 0: coolStep off, full CS.
    Off,
    /// At or below AP 182: the slow-run current AP 183.
    SlowRun,
    /// Above AP 182: regulating by stallGuard2.
    Regulating,
}

impl CoolStepParams {
    /// The lower stallGuard2 threshold, SEMIN · 32: readings below it raise the current.
    pub fn lower_threshold(&self) -> u16 {
        u16::from(self.hysteresis_start.min(15)) * 32
    }

    /// The upper stallGuard2 threshold, (SEMIN + SEMAX + 1) · 32: readings at or above it lower the
    /// current.
    pub fn upper_threshold(&self) -> u16 {
        (u16::from(self.hysteresis_start.min(15)) + u16::from(self.hysteresis.min(15)) + 1) * 32
    }

    /// Readings at or above the upper threshold per decrement (AP 169).
    pub fn readings_per_decrement(&self) -> u8 {
        [32, 8, 2, 1][usize::from(self.down_step & 3)]
    }

    /// Scale increment per reading below the lower threshold (AP 171).
    pub fn increment(&self) -> u8 {
        [1, 2, 4, 8][usize::from(self.up_step & 3)]
    }

    /// CS, limited to 0..=31.
    pub fn cs(&self) -> u8 {
        self.cs.min(31)
    }

    /// The lowest scale coolStep may set (AP 168).
    pub fn min_scale(&self) -> u8 {
        let shift = if self.min_quarter { 2 } else { 1 };
        ((self.cs() + 1) >> shift).saturating_sub(1)
    }

    /// Which regime the parameters select.
    pub fn regime(&self) -> Regime {
        if self.speed <= self.threshold_speed {
            Regime::SlowRun
        } else if self.hysteresis_start == 0 {
            Regime::Off
        } else {
            Regime::Regulating
        }
    }
}

/// The regulator's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CoolStep {
    /// The scale while regulating; `None` when not regulating (the next regulation starts from CS).
    scale: Option<u8>,
    /// Readings at or above the upper threshold since the last decrement.
    above: u8,
}

impl CoolStep {
    /// A regulator that has not regulated yet.
    pub const fn new() -> CoolStep {
        CoolStep { scale: None, above: 0 }
    }

    /// One stallGuard2 reading `load` (AP 206, 0..=1023): returns the new current scale 0..=31.
    pub fn update(&mut self, load: u16, params: CoolStepParams) -> u8 {
        if params.regime() != Regime::Regulating {
            return self.current(params);
        }
        let (min, cs) = (params.min_scale(), params.cs());
        let mut scale = self.scale.unwrap_or(cs).clamp(min, cs);
        if load < params.lower_threshold() {
            scale = scale.saturating_add(params.increment()).min(cs);
            self.above = 0;
        } else if load >= params.upper_threshold() {
            self.above = self.above.saturating_add(1);
            if self.above >= params.readings_per_decrement() {
                scale = scale.saturating_sub(1).max(min);
                self.above = 0;
            }
        }
        self.scale = Some(scale);
        scale
    }

    /// The scale [`CoolStep::current`] would return, without resetting anything (for reads).
    pub fn peek(&self, params: CoolStepParams) -> u8 {
        match params.regime() {
            Regime::Off => params.cs(),
            Regime::SlowRun => params.slow_run_current >> 3,
            Regime::Regulating => self.scale.unwrap_or(params.cs()).clamp(params.min_scale(), params.cs()),
        }
    }

    /// The current scale now, without a new reading (AP 180).
    pub fn current(&mut self, params: CoolStepParams) -> u8 {
        match params.regime() {
            Regime::Off => {
                *self = CoolStep::new();
                params.cs()
            }
            Regime::SlowRun => {
                *self = CoolStep::new();
                params.slow_run_current >> 3
            }
            Regime::Regulating => self.scale.unwrap_or(params.cs()).clamp(params.min_scale(), params.cs()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regulating above the threshold speed: CS 31, SEMIN 2, SEMAX 3 (thresholds 64 and 192).
    fn params() -> CoolStepParams {
        CoolStepParams {
            cs: 31,
            hysteresis_start: 2,
            hysteresis: 3,
            speed: 51200,
            threshold_speed: 10000,
            ..CoolStepParams::default()
        }
    }

    #[test]
    fn thresholds_follow_the_datasheet_reading_of_ap_170_172() {
        // Table 15 AP 170: upper threshold (AP 172 + AP 170 + 1) · 32; the lower formula is missing: AP 172 · 32.
        let p = params();
        assert_eq!((p.lower_threshold(), p.upper_threshold()), (64, 192));
        let max = CoolStepParams { hysteresis_start: 15, hysteresis: 15, ..p };
        assert_eq!((max.lower_threshold(), max.upper_threshold()), (480, 992));
    }

    #[test]
    fn down_step_needs_32_8_2_1_readings() {
        // Table 15 AP 169: "0...3: 32, 8, 2, 1".
        for (sedn, n) in [(0, 32), (1, 8), (2, 2), (3, 1)] {
            let p = CoolStepParams { down_step: sedn, ..params() };
            let mut c = CoolStep::new();
            for _ in 1..n {
                assert_eq!(c.update(500, p), 31);
            }
            assert_eq!(c.update(500, p), 30, "SEDN {sedn}");
        }
    }

    #[test]
    fn a_reading_at_the_upper_threshold_counts() {
        let p = CoolStepParams { down_step: 3, ..params() };
        let mut c = CoolStep::new();
        assert_eq!(c.update(191, p), 31);
        assert_eq!(c.update(192, p), 30);
    }

    #[test]
    fn up_step_is_1_2_4_8_per_reading_below_the_lower_threshold() {
        // Table 15 AP 171: "0...3: 1, 2, 4, 8".
        for (seup, inc) in [(0u8, 1u8), (1, 2), (2, 4), (3, 8)] {
            let p = CoolStepParams { up_step: seup, down_step: 3, ..params() };
            let mut c = CoolStep::new();
            for _ in 0..20 {
                c.update(1000, p);
            }
            assert_eq!(c.current(p), 15);
            assert_eq!(c.update(63, p), 15 + inc, "SEUP {seup}");
            assert_eq!(c.update(64, p), 15 + inc, "64 is not below the lower threshold");
        }
    }

    #[test]
    fn bounded_by_seimin_and_cs() {
        // Table 15 AP 168: minimum ½ or ¼ of CS; AP 180: "goes up to the CS value".
        for (quarter, min) in [(false, 15), (true, 7)] {
            let p = CoolStepParams { min_quarter: quarter, down_step: 3, up_step: 3, ..params() };
            let mut c = CoolStep::new();
            for _ in 0..40 {
                c.update(1023, p);
            }
            assert_eq!(c.current(p), min);
            for _ in 0..10 {
                c.update(0, p);
            }
            assert_eq!(c.current(p), 31);
        }
        let small = CoolStepParams { cs: 2, ..params() };
        assert_eq!(small.min_scale(), 0);
    }

    #[test]
    fn in_between_the_thresholds_holds_and_keeps_the_count() {
        let p = CoolStepParams { down_step: 2, ..params() };
        let mut c = CoolStep::new();
        assert_eq!(c.update(500, p), 31);
        assert_eq!(c.update(100, p), 31);
        assert_eq!(c.update(500, p), 30);
    }

    #[test]
    fn off_when_semin_is_zero() {
        let p = CoolStepParams { hysteresis_start: 0, slow_run_current: 40, ..params() };
        let mut c = CoolStep::new();
        assert_eq!(c.update(1023, p), 31, "above AP 182: CS, no regulation");
        // At or below AP 182 the slow-run current, coolStep on or off (Table 22).
        assert_eq!(c.current(CoolStepParams { speed: 0, ..p }), 5);
        assert_eq!(c.current(CoolStepParams { speed: 10000, ..p }), 5);
    }

    #[test]
    fn slow_run_current_at_or_below_the_threshold_speed() {
        // Table 22 V182/I183: above AP 182 coolStep, below it AP 183 (0..255 / 8).
        let p = CoolStepParams { slow_run_current: 80, down_step: 3, ..params() };
        let mut c = CoolStep::new();
        c.update(1000, p);
        assert_eq!(c.current(p), 30);
        let slow = CoolStepParams { speed: 10000, ..p };
        assert_eq!(c.update(1000, slow), 10);
        assert_eq!(c.current(slow), 10);
        // Back above: regulation restarts from CS.
        assert_eq!(c.current(p), 31);
    }

    #[test]
    fn a_lower_cs_clamps_the_scale() {
        let mut c = CoolStep::new();
        c.update(0, params());
        let lower = CoolStepParams { cs: 20, ..params() };
        assert_eq!(c.current(lower), 20);
        assert_eq!(c.update(300, lower), 20);
    }
}

//! The TMC262 driver as the firmware sees it: coil current, stallGuard2 load value, status flags, and the
//! energy figure.
//!
//! # Decisions
//!
//! - **Current** (manual chapter 4, AP 6 and Table 22: "0…255 divided by eight"): current scale
//!   CS = current / 8, coil peak current (CS + 1) / 32 of the range's maximum, 1 A peak / 0.7 A RMS in the
//!   low range (AP 179 = 1) and 2 A / 1.4 A in the high range (AP 179 = 0). The driver off
//!   ([`DriveState::enabled`] false), a shutdown flag or an undervoltage gives no current.
//! - **stallGuard2** (manual §1.1, §7.2): the load value falls linearly with the load ratio
//!   `load torque / available torque`, from 1023 unloaded to 0 at the torque limit (load angle 90°), and
//!   is 0 when the rotor did not follow the field since the last measurement (stalled: no back-EMF). The threshold AP 174 shifts it by 16 per unit
//!   (so −64..63 spans the whole 0..1023 range; higher = reads higher = less sensitive), clamped to
//!   0..=1023. One measurement is taken each time the field passes a full-step position, or one per 4 full
//!   steps averaged with the filter (AP 173). Below the minimum speed (world `driver.stallguard_min_speed`,
//!   default 0.2 rev/s) no measurement is taken, as on the TMC262, whose back-EMF based value is invalid
//!   at standstill and very low speed: **the last valid value is held** (1023 before the first one), and
//!   so is AP 208 bit 0.
//! - **AP 208 flags** (chapter 4 Table 15): bit 0 = load value 0; bits 1–6 from the world's faults
//!   (and bits 1/2 also from the module temperature: pre-warning from 100 °C, shutdown from 150 °C, the
//!   TMC262's nominal thresholds); bit 7 standstill = no step for 2^20 clocks of the 16 MHz driver clock
//!   (65.536 ms).
//! - **Energy**: ∫ (i_A² + i_B²) dt = ∫ I_peak² dt in A²·s (the two coils carry I_peak·sin and
//!   I_peak·cos). Multiply by the coil resistance for joules of copper loss. It is summed in integers —
//!   the peak current is (CS + 1)/32 of a whole number of mA, so I_peak² · dt is a whole number of
//!   (mA/32)²·µs — so that one sum over a long stretch is exactly the sum of its parts, however the
//!   stretch is cut (the board may be updated once for many motion ticks, see
//!   `tmcl_core::hal::StepDriver::update`).
//!
//! [`DriveState::enabled`]: tmcl_core::hal::DriveState::enabled

use tmcl_core::hal::{DriveState, DriverSettings};
use tmcl_core::{Duration, Instant};

/// AP 208 bit 0: stallGuard2 threshold reached.
pub const FLAG_STALL: u8 = 1 << 0;
/// AP 208 bit 7: standstill.
pub const FLAG_STANDSTILL: u8 = 1 << 7;
/// 2^20 clocks of the TMC262's 16 MHz clock.
pub const STANDSTILL_AFTER: Duration = Duration::from_micros(65_536);

/// Coil peak current in A for a drive state (0 when off), given the board's peak current at setting 255
/// in the low and high range (the model's `peak_current_ma`).
pub fn coil_current(state: &DriveState, settings: &DriverSettings, peak: [f64; 2]) -> f64 {
    if !state.enabled {
        return 0.0;
    }
    let range = if settings.high_range { peak[1] } else { peak[0] };
    f64::from((state.current >> 3) + 1) / 32.0 * range
}

/// The square of the coil peak current for a drive state, in (mA/32)² (0 when off): `(CS + 1)² · range²`,
/// with the range's peak current in mA at setting 255 (the model's `peak_current_ma`, low and high range).
/// [`coil_current`] is the same current in A.
pub fn coil_square(state: &DriveState, settings: &DriverSettings, peak_ma: [u16; 2]) -> u64 {
    if !state.enabled {
        return 0;
    }
    let range = u64::from(if settings.high_range { peak_ma[1] } else { peak_ma[0] });
    let cs = u64::from(state.current >> 3) + 1;
    cs * cs * range * range
}

/// (mA/32)²·µs in A²·s: 32² · 10⁶ (mA² in A²) · 10⁶ (µs in s).
const ENERGY_UNITS_PER_A2S: f64 = 1024.0 * 1e12;

/// The stallGuard2 value for a load ratio (0 = unloaded, 1 = at the torque limit) and threshold.
pub fn load_value(ratio: f64, threshold: i8) -> u16 {
    // The ends without the `round` call (unloaded is the common case): exactly what the formula gives.
    let base = if ratio <= 0.0 {
        1023
    } else if ratio >= 1.0 {
        0
    } else {
        (1023.0 * (1.0 - ratio.clamp(0.0, 1.0))).round() as i32
    };
    let raw = base + 16 * i32::from(threshold);
    raw.clamp(0, 1023) as u16
}

/// The driver's sensor state.
#[derive(Debug, Clone)]
pub struct Driver {
    /// AP 173/174/179 as last configured.
    pub settings: DriverSettings,
    /// Minimum speed for stallGuard2 in full steps per second.
    min_speed: f64,
    load: u16,
    measurements: u32,
    filter_sum: u32,
    filter_n: u32,
    stall_seen: bool,
    last_step: Instant,
    /// ∫ I_peak² dt in (mA/32)²·µs.
    energy: u128,
}

impl Driver {
    /// A driver at power-up; stallGuard2 measures from `min_speed` full steps per second.
    pub fn new(min_speed: f64) -> Driver {
        Driver {
            settings: DriverSettings::default(),
            min_speed,
            load: 1023,
            measurements: 0,
            filter_sum: 0,
            filter_n: 0,
            stall_seen: false,
            last_step: Instant::ZERO,
            energy: 0,
        }
    }

    /// The stallGuard2 value (AP 206).
    pub fn load(&self) -> u16 {
        self.load
    }

    /// Measurements so far (wrapping).
    pub fn measurements(&self) -> u32 {
        self.measurements
    }

    /// Energy so far in A²·s.
    pub fn energy(&self) -> f64 {
        self.energy as f64 / ENERGY_UNITS_PER_A2S
    }

    /// Adds `dt` at a coil peak current whose square is `square` (mA/32)² ([`coil_square`]).
    pub fn integrate(&mut self, square: u64, dt: Duration) {
        self.energy = self.energy.saturating_add(u128::from(square) * u128::from(dt.micros()));
    }

    /// Whether the rotor failed to follow since the last measurement (the next one reads 0).
    pub fn stall_seen(&self) -> bool {
        self.stall_seen
    }

    /// When the standstill flag (AP 208 bit 7) comes up by itself if no step is made after `now`: the
    /// next change of the flags that no update brings. `None` once it is up.
    pub fn standstill_at(&self, now: Instant) -> Option<Instant> {
        let at = self.last_step + STANDSTILL_AFTER;
        (now < at).then_some(at)
    }

    /// A step was made at `now`.
    pub fn stepped(&mut self, now: Instant) {
        self.last_step = now;
    }

    /// The field passed `crossings` full-step positions at `speed` full steps per second, with the rotor
    /// at load ratio `ratio`; `stalled` = the rotor did not follow during the move (it fell more than 90°
    /// behind, or moved less than half as far as the field: no back-EMF, so the reading is 0). One
    /// measurement per full step (the caller limits how many one update counts), in closed form: the same
    /// as measuring them one by one.
    pub fn measure(&mut self, crossings: u64, speed: f64, ratio: f64, stalled: bool) {
        if speed < self.min_speed {
            // No valid measurement down here, and nothing seen here counts for the next one.
            self.stall_seen = false;
            return;
        }
        self.stall_seen |= stalled;
        if crossings == 0 {
            return;
        }
        let ratio = if self.stall_seen { 1.0 } else { ratio };
        let value = u32::from(load_value(ratio, self.settings.stall_threshold));
        self.stall_seen = false;
        if !self.settings.stall_filter {
            self.load = value as u16;
            self.measurements = self.measurements.wrapping_add(crossings as u32);
            return;
        }
        // Filtered: one measurement per 4 full steps, the rounded mean of their values. The group under
        // way first, then whole groups (all of `value`), then the start of the next.
        let first = u64::from(4 - self.filter_n).min(crossings);
        self.filter_sum += first as u32 * value;
        self.filter_n += first as u32;
        let mut rest = crossings - first;
        if self.filter_n == 4 {
            self.load = ((self.filter_sum + 2) / 4) as u16;
            self.measurements = self.measurements.wrapping_add(1);
            (self.filter_sum, self.filter_n) = (0, 0);
            let groups = rest / 4;
            if groups > 0 {
                self.load = ((4 * value + 2) / 4) as u16;
                self.measurements = self.measurements.wrapping_add(groups as u32);
            }
            rest %= 4;
            self.filter_sum = rest as u32 * value;
            self.filter_n = rest as u32;
        }
    }

    /// AP 208 at `now`, with `extra` flags from faults and temperature.
    pub fn flags(&self, now: Instant, extra: u8) -> u8 {
        let mut f = extra;
        if self.load == 0 {
            f |= FLAG_STALL;
        }
        if now >= self.last_step + STANDSTILL_AFTER {
            f |= FLAG_STANDSTILL;
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PD28: [f64; 2] = [1.0, 2.0];

    #[test]
    fn current_scale_and_range() {
        let mut s = DriveState { enabled: true, current: 255, ..DriveState::default() };
        let low = DriverSettings::default();
        let high = DriverSettings { high_range: true, ..low };
        assert_eq!(coil_current(&s, &low, PD28), 1.0);
        assert_eq!(coil_current(&s, &high, PD28), 2.0);
        s.current = 128; // CS 16 → 17/32
        assert_eq!(coil_current(&s, &low, PD28), 17.0 / 32.0);
        s.enabled = false;
        assert_eq!(coil_current(&s, &low, PD28), 0.0);
    }

    #[test]
    fn load_value_is_linear_and_shifted_by_the_threshold() {
        assert_eq!(load_value(0.0, 0), 1023);
        assert_eq!(load_value(0.5, 0), 512);
        assert_eq!(load_value(1.0, 0), 0);
        assert_eq!(load_value(1.0, 10), 160);
        assert_eq!(load_value(0.5, -32), 0);
        assert_eq!(load_value(0.0, 63), 1023);
    }

    #[test]
    fn filter_takes_one_measurement_per_four_full_steps() {
        let mut d = Driver::new(1.0);
        d.settings.stall_filter = true;
        d.measure(3, 100.0, 0.5, false);
        assert_eq!((d.measurements(), d.load()), (0, 1023));
        d.measure(1, 100.0, 0.5, false);
        assert_eq!((d.measurements(), d.load()), (1, 512));
        d.settings.stall_filter = false;
        d.measure(2, 100.0, 0.0, false);
        assert_eq!((d.measurements(), d.load()), (3, 1023));
    }

    #[test]
    fn below_the_minimum_speed_the_value_is_held() {
        let mut d = Driver::new(40.0);
        d.measure(1, 100.0, 1.0, false);
        assert_eq!(d.load(), 0);
        d.measure(1, 10.0, 0.0, false);
        assert_eq!((d.load(), d.measurements()), (0, 1));
        assert_eq!(d.flags(Instant::ZERO, 0) & FLAG_STALL, FLAG_STALL);
    }
}

//! The sensOstep encoder's firmware functions (PD28-1021 manual §6.2; AP 209, 210, 212, 215).
//!
//! # Decisions
//!
//! - **Deviation (AP 212).** "When the actual position (parameter #1) and the encoder position
//!   (parameter #209) differ more than set here the motor will be stopped. This function is switched off
//!   when the maximum deviation is set to zero." The table gives AP 212 in "encoder steps" but AP 1 and
//!   AP 209 are both in microsteps (AP 209 is after the prescaler, §6.2), so the difference is compared in
//!   microsteps as it is. Strictly more than AP 212 trips. The core stops the motor, sets AP 207 bit
//!   value 2 ([`super::error_flags::DEVIATION`]) and raises interrupt 21.
//! - **Prescaler (AP 210).** p = prescaler · 512; bit 2 (value 4) is the clear-on-null function and is
//!   masked off; the other low bits stay (Table 20's p = 200 for 2 µsteps has bit 3 set, although §6.2.1
//!   reserves the four low bits for special functions).
//! - **Clear-on-null (AP 210 + 4).** "Clear the encoder position each time the encoder passes its
//!   absolute zero point": the zero point is the step between absolute counts 1023 and 0 (AP 215). Each
//!   time the counts cross it, either way, AP 209 is set to 0 *at that point*: the counts moved past it
//!   since are then counted from there, so nothing is lost to the update rate.

/// Whether the deviation check trips: |AP 1 − AP 209| > AP 212, with AP 212 = 0 meaning off.
pub fn deviation_exceeded(actual: i32, encoder: i32, max_deviation: i32) -> bool {
    max_deviation > 0 && (i64::from(actual) - i64::from(encoder)).unsigned_abs() > max_deviation.unsigned_abs().into()
}

/// Whether AP 210 has the clear-on-null function on (value 4 added).
pub fn clear_on_null_enabled(prescaler: i32) -> bool {
    prescaler & 4 != 0
}

/// The prescaler value without its function bit (only bit 2 is one: Table 20's 200 has bit 3 set).
pub fn prescaler_value(prescaler: i32) -> i32 {
    prescaler & !4
}

/// Encoder counts converted to microsteps through AP 210: counts · p / 512 (§6.2), rounded toward zero.
pub fn scale_counts(counts: i64, prescaler: i32) -> i64 {
    (i128::from(counts) * i128::from(prescaler_value(prescaler)) / 512) as i64
}

/// The absolute zero point crossed last when the raw counts (`per_rev` per revolution, 1024 on the
/// PD28-1021) went from `previous` to `counts`, if any: a multiple of `per_rev`. The caller sets its
/// AP 209 reference to (that point, 0).
pub fn null_crossing(previous: i64, counts: i64, per_rev: u32) -> Option<i64> {
    let per_rev = i64::from(per_rev.max(1));
    let (before, now) = (previous.div_euclid(per_rev), counts.div_euclid(per_rev));
    if before == now {
        None
    } else if now > before {
        Some(now * per_rev) // moving up: the last zero passed is the start of the current turn
    } else {
        Some((now + 1) * per_rev) // moving down: the end of the current turn
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deviation_is_off_at_zero_and_strict() {
        assert!(!deviation_exceeded(100_000, 0, 0));
        assert!(!deviation_exceeded(1000, 0, 1000));
        assert!(deviation_exceeded(1001, 0, 1000));
        assert!(deviation_exceeded(-1001, 0, 1000));
        assert!(deviation_exceeded(i32::MAX, i32::MIN, i32::MAX), "no overflow");
    }

    #[test]
    fn table_20_prescalers_make_one_revolution_the_step_count() {
        // §6.2 Table 20: microstep resolution and matching prescaler; 1024 counts = 1 revolution =
        // 200 full steps.
        for (res, p) in [(8, 25600), (7, 12800), (6, 6400), (5, 3200), (4, 1600), (3, 800), (2, 400), (1, 200)] {
            assert_eq!(scale_counts(1024, p), 200 << res, "SAP 140, 0, {res} with SAP 210, 0, {p}");
            assert_eq!(scale_counts(-1024, p), -(200 << res));
        }
        assert_eq!(scale_counts(1024, 512), 1024, "SAP 210, 0, 512 = prescaler 1");
    }

    #[test]
    fn clear_on_null_is_value_4() {
        assert!(clear_on_null_enabled(25604));
        assert!(!clear_on_null_enabled(25600));
        assert_eq!(prescaler_value(25604), 25600);
        assert_eq!(prescaler_value(200), 200, "bit 3 of Table 20's 200 stays");
    }

    #[test]
    fn null_crossings_either_way() {
        let null_crossing = |a, b| null_crossing(a, b, 1024);
        assert_eq!(null_crossing(1000, 1023), None);
        assert_eq!(null_crossing(1020, 1030), Some(1024));
        assert_eq!(null_crossing(1030, 1020), Some(1024));
        assert_eq!(null_crossing(5, -3), Some(0));
        assert_eq!(null_crossing(-3, 5), Some(0));
        assert_eq!(null_crossing(0, 3000), Some(2048), "two turns at once: the last zero");
        assert_eq!(null_crossing(3000, 0), Some(1024), "down from turn 2 to turn 0: the last zero passed");
    }

    #[test]
    fn null_crossings_of_another_resolution() {
        assert_eq!(super::null_crossing(3990, 4100, 4096), Some(4096));
        assert_eq!(super::null_crossing(1020, 1030, 4096), None);
    }
}

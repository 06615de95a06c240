//! Stop on stall (PD28-1021 manual §7.2 and chapter 4, Table 15: AP 181, 206, 207).
//!
//! "Below this speed motor will not be stopped. Above this speed motor will stop in case stallGuard2
//! load value reaches zero" (AP 181). The core calls [`stall_stop`] with each new stallGuard2 reading
//! (`hal::LoadSensor::load_measurements` changed); when it returns `true` the core stops the motor (a hard
//! stop, as on a stall the load is already holding it), sets AP 207 bit value 1
//! ([`super::error_flags::STALL`]) and raises interrupt 15 ("stallGuard axis 0").
//!
//! # Decisions
//!
//! - **AP 181 = 0 is off** (Table 15 does not say what 0 means; the parameter table in `model::pd28_1021`
//!   decides): the TMCL convention, and the factory default must not stop a motor at every stall-like reading.
//! - **"Above" is strict**: at exactly AP 181 the motor is not stopped.
//! - **Only on a new reading**: the load value of a stallGuard2 measurement taken below the board's
//!   minimum speed is not valid (TMC262), and a held value must not be taken twice; the caller checks
//!   only fresh readings. The speed is the actual speed AP 3 at that moment.

/// Whether a stallGuard2 reading `load` (AP 206) at actual speed `speed` (AP 3, pps, signed) stops the
/// motor under stop-on-stall speed `stop_speed` (AP 181).
pub fn stall_stop(load: u16, speed: i32, stop_speed: i32) -> bool {
    stop_speed > 0 && speed.unsigned_abs() > stop_speed.unsigned_abs() && load == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stops_only_above_ap_181_at_zero_load() {
        assert!(stall_stop(0, 51200, 25600));
        assert!(stall_stop(0, -51200, 25600), "either direction");
        assert!(!stall_stop(0, 25600, 25600), "at the threshold: not above it");
        assert!(!stall_stop(0, 10000, 25600), "below: never stopped");
        assert!(!stall_stop(1, 51200, 25600), "load value not yet 0");
    }

    #[test]
    fn ap_181_zero_is_off() {
        assert!(!stall_stop(0, 51200, 0));
        assert!(!stall_stop(0, i32::MIN, 0));
    }
}

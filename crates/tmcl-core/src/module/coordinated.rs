//! MVP COORD on several motors at once, as the multi-axis modules' firmware has it (TMCM-3110 and
//! TMCM-6110 TMCL firmware manuals, MVP): the motor byte is a mask of motors with bit 7 or bit 6 set, and
//! every motor in the mask moves to its own coordinate n (set before with SCO, CCO or ACO per motor).
//!
//! - **Bit 7 (`$80 | mask`)**: the motors start together, each with its own ramp (AP 4, 5, 130), and
//!   arrive when their own ramps end.
//! - **Bit 6 (`$40 | mask`)**: an interpolated move: the speeds and accelerations are scaled by each
//!   motor's distance, so that all start and arrive together and the path between the two points is a
//!   straight line. Decisions (the manuals' text at hand names the form, not the arithmetic): the profile
//!   is the fastest for which no motor exceeds its own AP 4 and AP 5 — the lead speed is the least of
//!   `v_max(m) · d_max / d(m)` over the moving motors, each motor gets `lead · d(m) / d_max` (at least
//!   1 pps, 1 pps²), and its start speed (AP 130) no more than that. The scaled values hold for this
//!   move only (AP 4 and 5 read what was set) and end with the next motion command on the motor or a new
//!   target (SAP 0). From standstill the profiles are proportional; a motor already moving brakes or
//!   accelerates from its present speed, so it may arrive apart.
//! - The reply carries the coordinate number, as MVP COORD on one motor.
//!
//! Byte vectors (TMCM-6110 manual's form; module address 1): `01 04 02 47 00 00 00 01 4F` moves motors
//! 0, 1 and 2 to coordinate 1 interpolated (`MVP COORD, $47, 1`); `01 04 02 87 00 00 00 01 8F` the
//! same without interpolation. The tests are in `tests/tmcm_3110.rs` of this crate.
//!
//! Refusals, each leaving every motor as it was (status 4, invalid value, as a motor the model lacks):
//! bits 6 and 7 both set, an empty mask, a motor in the mask the model does not have, a coordinate
//! number beyond the model's, a coordinate outside the position counter's range on any of the motors.

use super::{Module, Outcome};
use crate::hal::Board;
use crate::motion::RampParams;
use tmcl_model::capacity::MAX_MOTORS;
use tmcl_wire::Status;

/// Bit 6 of MVP COORD's motor byte: interpolated.
const INTERPOLATED: u8 = 0x40;
/// Bit 7 of MVP COORD's motor byte: together, each at its own speed.
const TOGETHER: u8 = 0x80;

impl<B: Board> Module<B> {
    /// MVP COORD, `motor` = bit 7 or bit 6 | a mask of motors, to each one's coordinate `coord`.
    pub(super) fn mvp_coordinated(&mut self, motor: u8, coord: i32) -> Result<Outcome, Status> {
        let interpolate = match motor & (INTERPOLATED | TOGETHER) {
            INTERPOLATED => true,
            TOGETHER => false,
            _ => return Err(Status::InvalidValue),
        };
        let mask = motor & !(INTERPOLATED | TOGETHER);
        let all = (1u16 << self.spec.motors) - 1;
        if mask == 0 || u16::from(mask) & !all != 0 {
            return Err(Status::InvalidValue);
        }
        let n = self.move_coordinate(coord)?;
        // Every target first: a refusal moves nothing.
        let mut targets: [Option<i32>; MAX_MOTORS as usize] = [None; MAX_MOTORS as usize];
        for (m, target) in targets.iter_mut().enumerate().take(usize::from(self.spec.motors)) {
            if mask & (1 << m) == 0 {
                continue;
            }
            let to = self.st.axes[m].coords[n];
            self.check_target(to)?;
            *target = Some(to);
        }
        let scaled = if interpolate { self.interpolation(&targets) } else { [None; MAX_MOTORS as usize] };
        for (m, target) in targets.iter().enumerate() {
            if let Some(to) = *target {
                super::exec::start_move(&mut self.st.axes[m], &mut self.st.event, to);
                self.st.axes[m].interpolation = scaled[m].map(|p| (to, p));
            }
        }
        Ok(Outcome::Value(coord))
    }

    /// The scaled ramp of each moving motor of an interpolated move (see the module's docs); `None` for a
    /// motor that stays where it is or is not in the move.
    fn interpolation(&self, targets: &[Option<i32>; MAX_MOTORS as usize]) -> [Option<RampParams>; MAX_MOTORS as usize] {
        let mut out = [None; MAX_MOTORS as usize];
        let distance = |m: usize, to: i32| (i64::from(to) - i64::from(self.st.axes[m].ramp.position)).abs();
        let moving =
            || targets.iter().enumerate().filter_map(|(m, t)| t.map(|to| (m, distance(m, to)))).filter(|(_, d)| *d > 0);
        let Some(d_max) = moving().map(|(_, d)| d).max() else { return out };
        // The lead profile (of a motor travelling d_max) that keeps every motor within its own limits.
        // (i128: a speed of up to 2^31 times a distance of up to 2^32.)
        let (mut speed, mut accel) = (i128::MAX, i128::MAX);
        for (m, d) in moving() {
            let p = self.own_ramp_params(m);
            speed = speed.min(i128::from(p.max_speed) * i128::from(d_max) / i128::from(d));
            accel = accel.min(i128::from(p.max_accel) * i128::from(d_max) / i128::from(d));
        }
        for (m, d) in moving() {
            let own = self.own_ramp_params(m);
            let scale = |v: i128| i32::try_from(v * i128::from(d) / i128::from(d_max)).unwrap_or(i32::MAX).max(1);
            let (max_speed, max_accel) = (scale(speed), scale(accel));
            out[m] = Some(RampParams { max_speed, max_accel, min_speed: own.min_speed.min(max_speed) });
        }
        out
    }
}

//! SAC (command 29, PDx-113 manual §5.4.3 "Access to external SPI device"): the SPI pass-through to an
//! emulated TMC428/429 motion controller.
//!
//! The manual names the command and is cut off before its section. TMCL's operands are `SAC <bus
//! number>, <number of bytes>, <send data>` ([`tmcl_wire::Command::Sac`]); our reading for this module:
//! bus 0 is the motion controller, whose datagrams are always 32 bits (TMC428 datasheet), so the number
//! of bytes is 4 and the value the datagram ([`tmcl_wire::tmc428`]); the reply value is the 32-bit
//! answer, status bits and data. Another bus is status 3 (wrong type: the TMC249 driver is reached only
//! through the motion controller's cover datagram), another number of bytes status 4.
//!
//! # The register file (TMC428 datasheet register map; TMC429 datasheet §8–§10)
//!
//! Motor 0 (SMDA 0) is the motor the firmware drives, so its registers are the firmware's state seen in
//! TMC428 units, and writing them is writing the axis parameter behind each (with that parameter's range
//! and status): IDX 0 x_target (AP 0; in velocity mode the target is only stored, as on the chip),
//! 1 x_actual (AP 1), 2 v_min (AP 130), 3 v_max (AP 4), 4 v_target (AP 2), 5 v_actual (AP 3; writing 0
//! stops at once — the firmware's hard stop —, another value is not taken over, the ramp owns it),
//! 6 a_max (AP 5), 7 a_actual (AP 5 while the speed changes, else 0; the sign is not modelled), 10
//! ref_conf and ramp mode (bits 1..0 = AP 138; bit 8 DISABLE_STOP_L = AP 13, bit 9 DISABLE_STOP_R =
//! AP 12; the other bits stored), 12 pulse_div (bits 15..12, AP 154), ramp_div (bits 11..8, AP 153) and
//! usrs (bits 2..0, AP 140), 9 pmul/pdiv (see [`pmul_pdiv`]: what the firmware computes from a_max and
//! the divisors, or what a host wrote since they last changed). The rest of motor 0 (8 a_threshold, 11
//! interrupt mask and flags, 13 dx_ref_tolerance, 14 x_latched) and every register of motors 1 and 2,
//! which have no motor on this board, are stored as written (24 bits) and read back; nothing acts on
//! them. IDX 15 reads 0.
//!
//! The common registers (SMDA 3): JDX 0/1 (datagram low/high word) read 0, the answer of a TMC249 with
//! no error bit set (the simulated driver has no fault); 2, 3, 4, 5, 6, 15 (cover position/length, cover
//! datagram, interface configuration, position compare and its interrupt, the stepper motor global
//! parameters) are stored; a cover datagram is sent at once, so CDGW stays 0; 8 (power down) does
//! nothing; 9 reads the TMC429's type/version 0x429101; 14 reads the reference switches (bit 0 the left,
//! bit 1 the right switch of motor 0); the others read 0. The RAM (RRS = 1, 64 addresses of two 6-bit
//! entries, the driver chain and quarter sine wave tables) is stored and read back.
//!
//! Status bits of every answer: xEQt1 = x_actual equals x_target of motor 0, xEQt2/3 likewise for the
//! stored registers of motors 1 and 2, RS1 = the left stop switch (the reference input of motor 0);
//! INT, CDGW, RS2, RS3 stay 0 (no interrupts on this module, §5.4).

use crate::hal::Board;
use crate::model::{Role, Setting};
use crate::module::Module;
use crate::motion::Mode;
use tmcl_wire::tmc428::{sign_extend, status, Answer, Datagram, SMDA_COMMON};
use tmcl_wire::Status;

/// The TMC429's type and version (TMC429 datasheet, JDX 9).
pub const TYPE_VERSION: u32 = 0x42_9101;

/// The registers no firmware state stands behind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tmc428Regs {
    motors: [[u32; 16]; 3],
    common: [u32; 16],
    ram: [u16; 64],
    /// a_max, pulse_div and ramp_div when a host last wrote motor 0's pmul/pdiv: while they are the same
    /// the written value stands, once one changes the firmware's own calculation does again.
    pmul_written_at: Option<(u32, u32, u32)>,
}

impl Default for Tmc428Regs {
    fn default() -> Self {
        // Power-up: every register 0 (the TMC428 datasheet: x_target, x_actual, v_min, v_max, a_max 0).
        Tmc428Regs { motors: [[0; 16]; 3], common: [0; 16], ram: [0; 64], pmul_written_at: None }
    }
}

/// Register 9 of a motor, pmul (bits 15..8, 128..255) and pdiv (bits 3..0), for `a_max` and the pulse
/// and ramp divisors: the pair the TMC428 datasheet's calculation gives (its section on pmul and pdiv,
/// the same in the TMC429 datasheet §8.1.7 and §8.1.10), which a firmware for the chip writes whenever
/// a_max or a divisor changes. With `p = a_max / (128 · 2^(ramp_div − pulse_div))` reduced by 1 %
/// (`p_reduction` 0.01, the datasheet's example value) it takes, of the `pdiv` in 0..=13 for which
/// `pmul = ⌊p_reduced · 8 · 2^pdiv⌋ − 128` lies in 0..=127, the last one, and `pm = pmul + 128`.
/// Computed in integers, `⌊a_max · 99 · 2^(pdiv + pulse_div) / (1600 · 2^ramp_div)⌋`, so the
/// result does not depend on floating-point rounding. No such pair (a_max 0, or a_max too small for the
/// divisors) reads 0.
pub fn pmul_pdiv(a_max: u32, pulse_div: u32, ramp_div: u32) -> u32 {
    let (a, pulse, ramp) = (u64::from(a_max & MASK11), pulse_div.min(15), ramp_div.min(15));
    let mut found = 0;
    for pdiv in 0..=13u32 {
        let scaled = (a * 99) << (pdiv + pulse);
        let x = scaled / (1600u64 << ramp);
        if (128..=255).contains(&x) {
            found = ((x as u32) << 8) | pdiv;
        }
    }
    found
}

const MASK24: u32 = 0x00FF_FFFF;
const MASK11: u32 = 0x7FF;
const MASK12: u32 = 0xFFF;

impl<B: Board> Module<B> {
    /// AP 2 (the TMC428's v_target) in position mode: the ramp sets it itself, to ±v_max (AP 4) while it
    /// accelerates or runs at its top speed and to 0 while it decelerates or stands (PDx-113 manual,
    /// revision V1.10 p. 25, AP 2 "target (next) speed"; the manual V1.04 in hand lists AP 2 without
    /// saying so). The sign is the direction of travel, as the register is signed (±2047). A velocity
    /// written in position mode is kept for the next velocity mode (ROR/ROL) and read there again.
    pub(crate) fn hardware_target_speed(&self) -> i32 {
        let p = self.ramp_params();
        let v_max = self.ap(Setting::MaxPositioningSpeed).unwrap_or(0);
        self.st.ramp.driving(&p) * v_max
    }

    /// The velocity registers in units (AP 2 as stored for velocity mode, AP 3), before the pulse divisor
    /// changes.
    pub(crate) fn velocity_units(&self) -> (i32, i32) {
        (self.pps_to_units(self.st.ramp.target_velocity), self.pps_to_units(self.st.ramp.velocity()))
    }

    /// After the pulse divisor changed: the velocity registers keep `units`, so the speed in microsteps
    /// per second follows the new divisor (TMC428 datasheet: µstep rate = f_CLK · v / (2^pulse_div ·
    /// 2048 · 32); the divisor scales the clock the velocity counts in).
    pub(crate) fn set_velocity_units(&mut self, (target, actual): (i32, i32)) {
        self.st.ramp.target_velocity = self.units_to_pps(target);
        let actual = self.units_to_pps(actual);
        self.st.ramp.set_velocity(actual);
    }

    /// SAC `bus`, `bytes`, `data`: one datagram to the motion controller; the 32-bit answer.
    pub(crate) fn sac(&mut self, bus: u8, bytes: u8, data: i32) -> Result<i32, Status> {
        if bus != 0 {
            return Err(Status::WrongType);
        }
        if bytes != 4 {
            return Err(Status::InvalidValue);
        }
        let d = Datagram::parse(data as u32);
        let read = match (d.ram, d.smda()) {
            (true, _) => self.ram(d),
            (false, SMDA_COMMON) => self.common(d),
            (false, 0) => self.motor0(d)?,
            (false, m) => self.other_motor(usize::from(m), d),
        };
        let answer = Answer { status: self.tmc428_status(), data: if d.read { read & MASK24 } else { 0 } };
        Ok(answer.emit() as i32)
    }

    fn tmc428_status(&mut self) -> u8 {
        let at = |r: &[u32; 16]| r[0] == r[1];
        let regs = &self.st.tmc428;
        let mut s = 0;
        if at(&regs.motors[1]) {
            s |= status::XEQT2;
        }
        if at(&regs.motors[2]) {
            s |= status::XEQT3;
        }
        if self.st.ramp.position == self.st.ramp.target_position {
            s |= status::XEQT1;
        }
        if self.switches().0 {
            s |= status::RS1;
        }
        s
    }

    fn ram(&mut self, d: Datagram) -> u32 {
        let cell = &mut self.st.tmc428.ram[usize::from(d.address & 0x3F)];
        if !d.read {
            *cell = (d.data & 0x3F3F) as u16;
        }
        u32::from(*cell)
    }

    fn common(&mut self, d: Datagram) -> u32 {
        let j = usize::from(d.index());
        match j {
            // Datagram low/high word: a TMC249 with no error bit set; a write only re-arms them.
            0 | 1 => 0,
            2..=6 | 15 => {
                if !d.read {
                    self.st.tmc428.common[j] = d.data & MASK24;
                }
                self.st.tmc428.common[j]
            }
            9 => TYPE_VERSION,
            14 => {
                let (left, right, _) = self.switches();
                u32::from(left) | (u32::from(right) << 1)
            }
            _ => 0,
        }
    }

    fn other_motor(&mut self, m: usize, d: Datagram) -> u32 {
        let i = usize::from(d.index());
        let Some(regs) = self.st.tmc428.motors.get_mut(m) else { return 0 };
        if i == 15 {
            return 0;
        }
        if !d.read {
            regs[i] = d.data & MASK24;
        }
        regs[i]
    }

    /// The axis parameter number with `setting` or `role`.
    fn ap_number(&self, setting: Option<Setting>, role: Option<Role>) -> Option<u8> {
        let i = match (setting, role) {
            (Some(s), _) => self.spec.axis.setting(s),
            (_, Some(r)) => self.spec.axis.role(r),
            _ => None,
        }?;
        Some(self.spec.axis.params[i].number)
    }

    fn read_ap(&mut self, setting: Option<Setting>, role: Option<Role>) -> u32 {
        match self.ap_number(setting, role) {
            Some(n) => self.get_axis(n).unwrap_or(0) as u32,
            None => 0,
        }
    }

    fn write_ap(&mut self, setting: Option<Setting>, role: Option<Role>, v: i32) -> Result<(), Status> {
        match self.ap_number(setting, role) {
            Some(n) => self.set_axis(n, v, self.st.now),
            None => Ok(()),
        }
    }

    /// Whether AP `n` (if the model has it) takes `v`, before anything is written.
    fn takes(&self, setting: Option<Setting>, role: Option<Role>, v: i32) -> Result<(), Status> {
        match self.ap_number(setting, role) {
            Some(n) => {
                let (_, d) = self.spec.axis.find(n)?;
                if d.access.write && d.range.contains(v) {
                    Ok(())
                } else {
                    Err(Status::InvalidValue)
                }
            }
            None => Ok(()),
        }
    }

    fn motor0(&mut self, d: Datagram) -> Result<u32, Status> {
        use Role as R;
        use Setting as S;
        let i = usize::from(d.index());
        let v24 = sign_extend(d.data, 24);
        let v11 = (d.data & MASK11) as i32;
        let v12 = sign_extend(d.data & MASK12, 12);
        if !d.read {
            match i {
                0 if self.st.ramp.mode == Mode::Velocity => self.st.ramp.target_position = v24,
                0 => self.write_ap(None, Some(R::TargetPosition), v24)?,
                1 => self.write_ap(None, Some(R::ActualPosition), v24)?,
                2 => self.write_ap(Some(S::MinimumSpeed), None, v11)?,
                3 => self.write_ap(Some(S::MaxPositioningSpeed), None, v11)?,
                4 => self.write_ap(None, Some(R::TargetSpeed), v12)?,
                // The firmware's hard stop writes v_actual 0; another value is not taken over.
                5 if v12 == 0 => {
                    self.st.ramp.hard_stop();
                    self.st.ramp.target_velocity = 0;
                }
                5 => {}
                6 => self.write_ap(Some(S::MaxAcceleration), None, v11)?,
                10 => {
                    let mode = (d.data & 3) as i32;
                    let (stop_l, stop_r) = (((d.data >> 8) & 1) as i32, ((d.data >> 9) & 1) as i32);
                    self.takes(None, Some(R::RampModeTmc428), mode)?;
                    self.write_ap(None, Some(R::RampModeTmc428), mode)?;
                    self.write_ap(Some(S::LeftSwitchDisable), None, stop_l)?;
                    self.write_ap(Some(S::RightSwitchDisable), None, stop_r)?;
                    self.st.tmc428.motors[0][i] = d.data & MASK24 & !0x303;
                }
                12 => {
                    let (pulse, ramp, usrs) =
                        (((d.data >> 12) & 0xF) as i32, ((d.data >> 8) & 0xF) as i32, (d.data & 7) as i32);
                    self.takes(Some(S::PulseDivisor), None, pulse)?;
                    self.takes(Some(S::RampDivisor), None, ramp)?;
                    self.takes(None, Some(R::MicrostepResolution), usrs)?;
                    self.write_ap(Some(S::PulseDivisor), None, pulse)?;
                    self.write_ap(Some(S::RampDivisor), None, ramp)?;
                    self.write_ap(None, Some(R::MicrostepResolution), usrs)?;
                }
                9 => {
                    self.st.tmc428.motors[0][i] = d.data & MASK24;
                    self.st.tmc428.pmul_written_at = Some(self.pmul_inputs());
                }
                15 => {}
                _ => self.st.tmc428.motors[0][i] = d.data & MASK24,
            }
        }
        Ok(match i {
            0 => self.st.ramp.target_position as u32,
            1 => self.read_ap(None, Some(R::ActualPosition)),
            2 => self.read_ap(Some(S::MinimumSpeed), None),
            3 => self.read_ap(Some(S::MaxPositioningSpeed), None),
            4 => self.read_ap(None, Some(R::TargetSpeed)) & MASK12,
            5 => self.read_ap(None, Some(R::ActualSpeed)) & MASK12,
            6 => self.read_ap(Some(S::MaxAcceleration), None),
            7 if self.st.ramping => self.read_ap(Some(S::MaxAcceleration), None),
            7 => 0,
            10 => {
                let mode = self.read_ap(None, Some(R::RampModeTmc428)) & 3;
                let stop_l = self.read_ap(Some(S::LeftSwitchDisable), None) & 1;
                let stop_r = self.read_ap(Some(S::RightSwitchDisable), None) & 1;
                self.st.tmc428.motors[0][i] | mode | (stop_l << 8) | (stop_r << 9)
            }
            12 => {
                let pulse = self.read_ap(Some(S::PulseDivisor), None) & 0xF;
                let ramp = self.read_ap(Some(S::RampDivisor), None) & 0xF;
                let usrs = self.read_ap(None, Some(R::MicrostepResolution)) & 7;
                (pulse << 12) | (ramp << 8) | usrs
            }
            9 => {
                let (a_max, pulse, ramp) = self.pmul_inputs();
                if self.st.tmc428.pmul_written_at == Some((a_max, pulse, ramp)) {
                    self.st.tmc428.motors[0][i]
                } else {
                    pmul_pdiv(a_max, pulse, ramp)
                }
            }
            15 => 0,
            _ => self.st.tmc428.motors[0][i],
        })
    }

    /// What motor 0's pmul/pdiv follows: a_max (AP 5), the pulse divisor (AP 154), the ramp divisor (AP 153).
    fn pmul_inputs(&mut self) -> (u32, u32, u32) {
        (
            self.read_ap(Some(Setting::MaxAcceleration), None),
            self.read_ap(Some(Setting::PulseDivisor), None) & 0xF,
            self.read_ap(Some(Setting::RampDivisor), None) & 0xF,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::pmul_pdiv;

    #[test]
    fn pmul_and_pdiv_as_the_datasheet_computes_them() {
        // a_max 1000, pulse_div 3, ramp_div 7: p = 1000 / (128 · 16) = 0.488, reduced 0.483; 0.483 · 8 ·
        // 2^6 = 247.5, so pmul 247, pdiv 6 (2^7 gives 495, out of range).
        assert_eq!(pmul_pdiv(1000, 3, 7), (247 << 8) | 6);
        // a_max 2047, pulse_div 0, ramp_div 0: p = 15.99, reduced 15.83; · 8 = 126.6 (too small), · 16 =
        // 253.3: pmul 253, pdiv 1.
        assert_eq!(pmul_pdiv(2047, 0, 0), (253 << 8) | 1);
        // a_max 1 at pulse_div 0, ramp_div 13: p = 1 / (128 · 8192); even · 8 · 2^13 it is 0.06: no pair.
        assert_eq!(pmul_pdiv(1, 0, 13), 0);
        // a_max 500 at pulse_div 3, ramp_div 7: p_reduced 0.2417; · 8 · 2^7 = 247.5: pmul 247, pdiv 7.
        assert_eq!(pmul_pdiv(500, 3, 7), (247 << 8) | 7);
        assert_eq!(pmul_pdiv(0, 3, 7), 0, "a_max 0: no pair");
        // pm always has its top bit set (128..=255), pdiv in 0..=13.
        for a in [1, 7, 100, 1000, 2047] {
            for pulse in 0..=13 {
                for ramp in 0..=13 {
                    let v = pmul_pdiv(a, pulse, ramp);
                    assert!(v == 0 || (v >> 15 == 1 && v & 0xF <= 13 && v >> 16 == 0), "{a} {pulse} {ramp}: {v:#x}");
                }
            }
        }
    }
}

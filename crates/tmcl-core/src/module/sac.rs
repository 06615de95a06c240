//! SAC on the module: the emulated TMC428/429's registers of motor 0 are the firmware's own state (see
//! [`crate::drive::tmc428`] for the register file and the decisions).

use super::Module;
use crate::drive::tmc428::{pmul_pdiv, MASK11, MASK12, MASK24, TYPE_VERSION};
use crate::hal::Board;
use crate::model::{Role, Setting};
use crate::motion::Mode;
use tmcl_wire::tmc428::{sign_extend, status, Answer, Datagram, SMDA_COMMON};
use tmcl_wire::Status;

impl<B: Board> Module<B> {
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
        if self.st.axes[0].ramp.position == self.st.axes[0].ramp.target_position {
            s |= status::XEQT1;
        }
        if self.motor_at(0).switches().0 {
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
                let (left, right, _) = self.motor_at(0).switches();
                u32::from(left) | (u32::from(right) << 1)
            }
            _ => 0,
        }
    }

    fn other_motor(&mut self, motor: usize, d: Datagram) -> u32 {
        let i = usize::from(d.index());
        let Some(regs) = self.st.tmc428.motors.get_mut(motor) else { return 0 };
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
            Some(n) => self.read_axis(0, n, None).unwrap_or(0) as u32,
            None => 0,
        }
    }

    fn write_ap(&mut self, setting: Option<Setting>, role: Option<Role>, v: i32) -> Result<(), Status> {
        match self.ap_number(setting, role) {
            Some(n) => self.write_axis(0, n, v, self.st.now),
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
                0 if self.st.axes[0].ramp.mode == Mode::Velocity => self.st.axes[0].ramp.target_position = v24,
                0 => self.write_ap(None, Some(R::TargetPosition), v24)?,
                1 => self.write_ap(None, Some(R::ActualPosition), v24)?,
                2 => self.write_ap(Some(S::MinimumSpeed), None, v11)?,
                3 => self.write_ap(Some(S::MaxPositioningSpeed), None, v11)?,
                4 => self.write_ap(None, Some(R::TargetSpeed), v12)?,
                // The firmware's hard stop writes v_actual 0; another value is not taken over.
                5 if v12 == 0 => {
                    self.st.axes[0].ramp.hard_stop();
                    self.st.axes[0].ramp.target_velocity = 0;
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
            0 => self.st.axes[0].ramp.target_position as u32,
            1 => self.read_ap(None, Some(R::ActualPosition)),
            2 => self.read_ap(Some(S::MinimumSpeed), None),
            3 => self.read_ap(Some(S::MaxPositioningSpeed), None),
            4 => self.read_ap(None, Some(R::TargetSpeed)) & MASK12,
            5 => self.read_ap(None, Some(R::ActualSpeed)) & MASK12,
            6 => self.read_ap(Some(S::MaxAcceleration), None),
            7 if self.st.axes[0].ramping => self.read_ap(Some(S::MaxAcceleration), None),
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

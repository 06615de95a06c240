//! The one dispatcher: every command a host sends goes through [`Module::execute`].
//!
//! Each arm cites the manual section that defines the command. Statuses the manual leaves open are
//! decided once, here and in [`crate::param::ParamError`]:
//! - an unknown parameter, port or coordinate number, or one that does not support the operation
//!   (a write to a read-only parameter, STAP of a parameter without E): **3, wrong type** — the type byte
//!   names it;
//! - a value out of range, a motor other than 0, a bank the command does not know: **4, invalid value**;
//! - an EEPROM that cannot be written: **5, configuration EEPROM locked**;
//! - a write or store of a password-protected parameter while the module is locked: **8, parameter is
//!   password protected** (TMCM-1310 manual §3.7);
//! - a command the model does not have: **2, invalid command** (checked before this dispatcher, by
//!   `Module::decode`);
//! - program-flow commands sent from the host (the table of opcode properties marks them "program only":
//!   JA, JC, COMP, CSUB, RSUB, WAIT, STOP, VECT, RETI; the manual's §3.6.3 calls them standalone only)
//!   and UF0–UF7 (no user functions in the standard firmware, §3.7.36): **6, command not available**.
//!   CALC, CALCX, AAP, AGP, ACO, CLE, EI and DI "could be used in direct mode" (§3.6.5) and work on the
//!   module's registers.

use crate::hal::Board;
use crate::model::{AppStatusReply, Driver, PortKind, Setting};
use crate::module::{flags, Module, Origin, Outcome, Registers, RNG_SEED};
use crate::motion::reference::Action;
use crate::motion::{Mode, SearchMode};
use crate::param::{persist, ParamDesc, ParamError, Role};
use crate::time::Instant;
use tmcl_wire::command::MAGIC_KEY;
use tmcl_wire::{
    CalcOp, CalcxOp, Command, ErrorFlag, EventMode, MoveTarget, RfsAction, Status, StatusKind, VersionFormat, FRAME_LEN,
};

type Exec = Result<Outcome, Status>;

fn value(v: i32) -> Exec {
    Ok(Outcome::Value(v))
}

impl<B: Board> Module<B> {
    /// Executes one validated command sent by the host at `now`.
    pub fn execute(&mut self, command: Command, now: Instant) -> Exec {
        self.st.asking_port = 0;
        self.exec(command, now, Origin::Host)
    }

    /// The registers a command works on: the program's or the host's (see [`crate::vm`]).
    fn regs(&mut self, origin: Origin) -> &mut Registers {
        match origin {
            Origin::Host => &mut self.st.host_regs,
            Origin::Program => &mut self.st.regs,
        }
    }

    /// Executes one validated command from the host or the program at `now`.
    pub(crate) fn exec(&mut self, command: Command, now: Instant, origin: Origin) -> Exec {
        use Command as C;
        if origin == Origin::Host {
            // A running program that spins in a fixed point may do otherwise now (`module/spin.rs`).
            self.spin.unrest();
        }
        // A parameter write may change what the driver sees (a current, the chopper, the resolution), and a
        // stop (MST, RFS) stops the motor at once: the board is brought up to date at this instant, not at
        // the next motion tick (a standing motor has none), however often the module is polled.
        if matches!(
            command,
            C::Sap { .. }
                | C::Aap { .. }
                | C::Rsap { .. }
                | C::Sgp { .. }
                | C::Agp { .. }
                | C::Rsgp { .. }
                | C::Mst { .. }
                | C::Rfs { .. }
        ) {
            self.st.drive_due = Some(self.st.drive_due.map_or(now, |t| t.min(now)));
        }
        match command {
            // §3.7.1 ROR: velocity mode, then AP 2 = velocity (a negative velocity turns left).
            C::Ror { motor, velocity } => {
                self.motor(motor)?;
                self.velocity_in_range(velocity)?;
                self.start_rotation(self.units_to_pps(velocity));
                value(velocity)
            }
            // §3.7.2 ROL: as ROR to the left: AP 2 = −velocity (the manual leaves a negative velocity open; it
            // turns right). Its range is the whole −2147483648..2147483647: the lowest value, whose negation
            // does not fit, turns right at the highest velocity, 2147483647.
            C::Rol { motor, velocity } => {
                self.motor(motor)?;
                let v = velocity.checked_neg().unwrap_or(i32::MAX);
                self.velocity_in_range(v)?;
                self.start_rotation(self.units_to_pps(v));
                value(velocity)
            }
            // §3.7.3 MST: velocity mode, target speed 0 (the printed "axis parameter #0" is a typo for AP 2),
            // decelerating with AP 5.
            C::Mst { motor } => {
                self.motor(motor)?;
                self.start_rotation(0);
                value(0)
            }
            // §3.7.4 MVP ABS/REL/COORD: AP 0 = new target, position mode (AP 128 = 0).
            C::Mvp { motor, target } => {
                self.motor(motor)?;
                let to = match target {
                    MoveTarget::Abs(p) => p,
                    // "an offset to the actual position ... must not exceed the above mentioned limits".
                    MoveTarget::Rel(d) => self.relative_base().checked_add(d).ok_or(Status::InvalidValue)?,
                    MoveTarget::Coord(n) => {
                        let n = usize::try_from(n).ok().filter(|n| *n <= usize::from(self.spec.coordinates));
                        self.st.coords[n.ok_or(Status::InvalidValue)?]
                    }
                };
                // The target must be a position the counter holds (PDx-113 manual §5.7.4: −2^23 … 2^23 − 1,
                // "the new resulting position value must not exceed the above mentioned limits, too").
                if let Some(i) = self.spec.axis.role(Role::TargetPosition) {
                    if !self.spec.axis.params[i].range.contains(to) {
                        return Err(Status::InvalidValue);
                    }
                }
                self.start_move(to);
                value(match target {
                    MoveTarget::Abs(v) | MoveTarget::Rel(v) | MoveTarget::Coord(v) => v,
                })
            }
            // §3.7.5 SAP: RAM only.
            C::Sap { param, motor, value: v } => {
                self.motor(motor)?;
                self.set_axis(param, v, now)?;
                value(v)
            }
            // §3.7.6 GAP.
            C::Gap { param, motor } => {
                self.motor(motor)?;
                value(self.read_axis(param, Some(now))?)
            }
            // §3.7.7 STAP: E parameters only.
            C::Stap { param, motor } => {
                self.motor(motor)?;
                let (i, _) = self.axis_desc(param, |d| d.access.store)?;
                self.unlocked_for(&self.spec.axis.params[i])?;
                self.spin.touch(); // an EEPROM write
                persist::store_axis(&mut self.board, self.spec, i, self.st.axis[i])?;
                value(0)
            }
            // §3.7.8 RSAP: E parameters only.
            C::Rsap { param, motor } => {
                self.motor(motor)?;
                let (i, d) = self.axis_desc(param, |d| d.access.store)?;
                let v = persist::load_axis(&mut self.board, self.spec, i)?;
                self.st.axis[i] = if d.range.contains(v) { v } else { d.default };
                value(0)
            }
            // §3.7.9 SGP.
            C::Sgp { param, bank, value: v } => {
                self.set_global(param, bank, v, now)?;
                value(v)
            }
            // §3.7.10 GGP.
            C::Ggp { param, bank } => value(self.get_global(param, bank, now)?),
            // §3.7.11 STGP: bank 2 user variables 0..55 (§5.3); bank 0 A parameters are already stored
            // and a STGP rewrites them (the manual does not say what STGP does on bank 0).
            C::Stgp { param, bank } => {
                self.bank(bank)?;
                match bank {
                    0 => {
                        let (i, _) = self.global_desc(param, |d| d.access.auto)?;
                        self.unlocked_for(&self.spec.global.params[i])?;
                        self.spin.touch(); // an EEPROM write
                        persist::store_global(&mut self.board, self.spec, i, self.st.global[i])?;
                    }
                    2 => {
                        let v = self.st.user[self.user_index(param)?];
                        self.spin.touch(); // an EEPROM write
                        persist::store_user(&mut self.board, self.spec, param, v)?
                    }
                    // A bank 1 with no parameter the sources name (PDx-113 manual §5.7.9).
                    1 => return Err(ParamError::Unknown.into()),
                    3 => return Err(ParamError::NotPermitted.into()),
                    _ => return Err(ParamError::NoSuchMotor.into()),
                }
                value(0)
            }
            // §3.7.12 RSGP.
            C::Rsgp { param, bank } => {
                self.bank(bank)?;
                match bank {
                    0 => {
                        let (i, d) = self.global_desc(param, |d| d.access.auto)?;
                        let v = persist::load_global(&mut self.board, self.spec, i)?;
                        self.st.global[i] = if d.range.contains(v) { v } else { d.default };
                    }
                    2 => {
                        let n = self.user_index(param)?;
                        self.st.user[n] = persist::load_user(&mut self.board, self.spec, param)?;
                    }
                    // A bank 1 with no parameter the sources name (PDx-113 manual §5.7.9).
                    1 => return Err(ParamError::Unknown.into()),
                    3 => return Err(ParamError::NotPermitted.into()),
                    _ => return Err(ParamError::NoSuchMotor.into()),
                }
                value(0)
            }
            // §3.7.13 RFS START/STOP/STATUS.
            C::Rfs { action, motor } => {
                self.motor(motor)?;
                value(self.reference_search(action, now)?)
            }
            // §3.7.14 SIO: bank 2 outputs; port 255 sets all from a bit vector, −1 takes it from A.
            C::Sio { port, bank, value: v } => {
                // Only bank 2 (outputs) can be set; another bank is an invalid value of the bank byte.
                if bank != 2 {
                    return Err(Status::InvalidValue);
                }
                let desc = self.spec.port(bank, port).ok_or(Status::WrongType)?;
                let bits = match desc.kind {
                    PortKind::Output(bit) => match v {
                        0 => self.st.outputs & !(1 << bit),
                        1 => self.st.outputs | (1 << bit),
                        _ => return Err(Status::InvalidValue),
                    },
                    PortKind::AllOutputs => match v {
                        -1 => self.regs(origin).accumulator as u8,
                        0..=255 => v as u8,
                        _ => return Err(Status::InvalidValue),
                    },
                    _ => return Err(Status::WrongType),
                };
                let bits = bits & (((1u16 << self.spec.outputs) - 1) as u8); // outputs ≤ 8
                if bits != self.st.outputs {
                    self.spin.touch();
                }
                self.st.outputs = bits;
                self.board.set_outputs(self.st.outputs);
                value(v)
            }
            // §3.7.15 GIO: bank 0 digital inputs, bank 1 analog inputs, bank 2 outputs read back.
            C::Gio { port, bank } => {
                let desc = self.spec.port(bank, port).ok_or(if bank <= 2 {
                    Status::WrongType
                } else {
                    Status::InvalidValue
                })?;
                value(self.read_port(desc.kind))
            }
            // §3.7.16 CALC: A ← A op operand; the reply carries the operand (example reply §3.7.16).
            C::Calc { op, operand } => {
                let a = self.regs(origin).accumulator;
                let r = match op {
                    CalcOp::Add => a.wrapping_add(operand),
                    CalcOp::Sub => a.wrapping_sub(operand),
                    CalcOp::Mul => a.wrapping_mul(operand),
                    CalcOp::Div => a
                        .checked_div(operand)
                        .or((operand == -1).then(|| a.wrapping_neg()))
                        .ok_or(Status::InvalidValue)?,
                    CalcOp::Mod => {
                        a.checked_rem(operand).or((operand == -1).then_some(0)).ok_or(Status::InvalidValue)?
                    }
                    CalcOp::And => a & operand,
                    CalcOp::Or => a | operand,
                    CalcOp::Xor => a ^ operand,
                    CalcOp::Not => !a,
                    CalcOp::Load => operand,
                };
                self.load_accumulator(origin, r);
                value(operand)
            }
            // §3.7.28 CALCX: A ← A op X; LOAD copies A to X, SWAP exchanges them, NOT inverts X (Table of
            // §3.7.28: "logical invert X register", although every other operation writes A).
            C::Calcx { op } => {
                let regs = *self.regs(origin);
                let (a, x) = (regs.accumulator, regs.x);
                let r = match op {
                    CalcxOp::Add => a.wrapping_add(x),
                    CalcxOp::Sub => a.wrapping_sub(x),
                    CalcxOp::Mul => a.wrapping_mul(x),
                    CalcxOp::Div => {
                        a.checked_div(x).or((x == -1).then(|| a.wrapping_neg())).ok_or(Status::InvalidValue)?
                    }
                    CalcxOp::Mod => a.checked_rem(x).or((x == -1).then_some(0)).ok_or(Status::InvalidValue)?,
                    CalcxOp::And => a & x,
                    CalcxOp::Or => a | x,
                    CalcxOp::Xor => a ^ x,
                    CalcxOp::Not => {
                        self.regs(origin).x = !x;
                        return value(0);
                    }
                    CalcxOp::Load => {
                        self.regs(origin).x = a;
                        return value(0);
                    }
                    CalcxOp::Swap => {
                        self.regs(origin).x = a;
                        x
                    }
                };
                self.load_accumulator(origin, r);
                value(0)
            }
            // §3.7.29 AAP: axis parameter ← A.
            C::Aap { param, motor } => {
                self.motor(motor)?;
                let a = self.regs(origin).accumulator;
                self.set_axis(param, a, now)?;
                value(a)
            }
            // §3.7.30 AGP: global parameter ← A.
            C::Agp { param, bank } => {
                let a = self.regs(origin).accumulator;
                self.set_global(param, bank, a, now)?;
                value(a)
            }
            // §3.7.24 SCO; motor 255 copies RAM → EEPROM (coordinate 0 = all of 1..20).
            C::Sco { coord, motor, position } => {
                if motor == 255 {
                    self.copy_coordinates(coord, true)?;
                    return value(0);
                }
                self.motor(motor)?;
                self.write_coordinate(coord, position)?;
                value(position)
            }
            // §3.7.25 GCO; motor 255 copies EEPROM → RAM.
            C::Gco { coord, motor } => {
                if motor == 255 {
                    self.copy_coordinates(coord, false)?;
                    return value(0);
                }
                self.motor(motor)?;
                value(self.st.coords[self.coord_index(coord)?])
            }
            // §3.7.26 CCO: coordinate ← actual position; the reply carries it.
            C::Cco { coord, motor } => {
                self.motor(motor)?;
                let p = self.st.ramp.position;
                self.write_coordinate(coord, p)?;
                value(p)
            }
            // §3.7.27 ACO: coordinate ← accumulator (as its description says; its "internal function" line says the
            // actual position).
            C::Aco { coord, motor } => {
                self.motor(motor)?;
                let a = self.regs(origin).accumulator;
                self.write_coordinate(coord, a)?;
                value(a)
            }
            // §3.7.31 CLE: clears error flags (the comparison flags stay).
            C::Cle { flag } => {
                let mask = match flag {
                    ErrorFlag::All => {
                        flags::TIMEOUT | flags::ALARM | flags::DEVIATION | flags::POSITION | flags::SHUTDOWN
                    }
                    ErrorFlag::Timeout => flags::TIMEOUT,
                    ErrorFlag::ExternalAlarm => flags::ALARM,
                    ErrorFlag::Deviation => flags::DEVIATION,
                    ErrorFlag::PositionError => flags::POSITION,
                    ErrorFlag::Shutdown => flags::SHUTDOWN,
                };
                self.regs(origin).flags &= !mask;
                value(0)
            }
            // §3.7.32 EI / §3.7.33 DI: interrupt n (Table 12) or 255 = global.
            C::Ei { interrupt } | C::Di { interrupt } => {
                let on = matches!(command, C::Ei { .. });
                if interrupt == crate::model::GLOBAL_INTERRUPTS {
                    self.vm.global = on;
                } else if self.spec.interrupts.find(interrupt).is_some() {
                    let bit = 1u64 << interrupt;
                    self.vm.enabled = if on { self.vm.enabled | bit } else { self.vm.enabled & !bit };
                    if !on {
                        self.vm.pending &= !bit;
                    }
                } else {
                    return Err(Status::WrongType);
                }
                value(0)
            }
            // Standalone-only program flow, run by the program machine (and refused from the host above),
            // and user functions, which the standard firmware does not have (§3.7.36).
            C::Comp { .. }
            | C::Jc { .. }
            | C::Ja { .. }
            | C::Csub { .. }
            | C::Rsub
            | C::Wait { .. }
            | C::Stop
            | C::Vect { .. }
            | C::Reti
            | C::UserFunction { .. } => Err(Status::NotAvailable),
            // §3.7.38 128: stop the program.
            C::StopApplication => {
                self.stop_application();
                value(0)
            }
            // §3.7.38 129: run from the current address (type 0) or a given one (type 1, §8.6).
            C::RunApplication { from } => {
                self.run_application(from, now)?;
                value(from.unwrap_or(0))
            }
            // §3.7.38 130: one instruction.
            C::StepApplication => {
                self.step_application(now);
                value(0)
            }
            // §3.7.38 131: stop, PC 0, stack, A, X and flags cleared.
            C::ResetApplication => {
                self.reset_application();
                value(0)
            }
            // §3.7.38 132/133: download mode.
            C::StartDownload { address } => {
                self.start_download(address)?;
                value(address)
            }
            C::QuitDownload => {
                self.quit_download();
                value(0)
            }
            // §3.7.38 134: read program memory (special reply).
            C::ReadMemory { address } => Ok(Outcome::Raw(self.read_memory(address)?)),
            // §3.7.38 135: application status.
            // PDx-113 manual §5.5: the state alone (0 stop, 1 run, 2 step, 3 reset), type "don't care".
            C::GetStatus { .. } if self.spec.app_status == AppStatusReply::Plain => value(self.vm.state.code()),
            C::GetStatus { kind } => value(match kind {
                StatusKind::MemoryPointer => self.application_status(false),
                StatusKind::ProgramCounter => self.application_status(true),
                StatusKind::Accumulator => self.st.regs.accumulator,
                StatusKind::XRegister => self.st.regs.x,
            }),
            // §3.4.1 command 139: ASCII mode. The reply (binary) goes out first, then the mode changes.
            C::EnterAscii => Ok(Outcome::EnterAscii),
            // §3.7.38 136: type 0 = host address + 8 characters, no checksum; type 1 = binary.
            C::GetVersion { format: VersionFormat::String } => {
                let mut raw = [0u8; FRAME_LEN];
                raw[0] = self.host_address();
                raw[1..].copy_from_slice(&self.spec.version_string);
                Ok(Outcome::Raw(raw))
            }
            C::GetVersion { format: VersionFormat::Binary } => value(self.spec.version_binary),
            // §3.7.38 137 (value 1234, checked by decode): factory defaults into the EEPROM, no reply; the
            // module then restarts on them (the program memory is kept: it is not a setting).
            C::FactoryDefault => {
                self.spin.touch(); // an EEPROM write
                persist::format(&mut self.board, self.spec, false).map_err(Status::from)?;
                Ok(Outcome::Silent)
            }
            // §3.7.37 138: type 0 = next MVP, type 1 = every MVP; value = motor mask. Mask 0 cancels (our
            // decision: the manual gives no way to turn type 1 off).
            C::RequestTargetReachedEvent { mode, mask } => {
                let all = (1i32 << self.spec.motors) - 1;
                if mask & !all != 0 {
                    return Err(Status::InvalidValue);
                }
                self.st.event.mode = (mask != 0).then_some(mode);
                self.st.event.mask = mask;
                self.st.event.port = self.st.asking_port;
                if mask == 0 {
                    self.st.event.pending = false;
                }
                value(mask)
            }
            // 242: pytrinamic's boot-loader request. The module has no boot loader on this link; it stays
            // silent so the host's reply stream stays aligned (pytrinamic expects no reply).
            C::Boot => Ok(Outcome::Silent),
            // §3.7.38 255 (value 1234): restart like a power cycle; the reply goes out first.
            C::SoftwareReset => Ok(Outcome::Restart(MAGIC_KEY)),
            // SAC (PDx-113 manual §5.4.3): SPI access to the motion controller and driver chain; the
            // emulated TMC428 answers (`crate::drive::tmc428`). A model without one: status 6.
            C::Sac { bus, bytes, data } => match self.spec.driver {
                Driver::Tmc428Tmc24x => value(self.sac(bus, bytes, data)?),
                _ => Err(Status::NotAvailable),
            },
        }
    }

    /// A global parameter bank the model has (PD28-1021 manual chapter 5; PDx-113 manual §5.7.9): else
    /// status 4, the bank byte being a value of the command.
    fn bank(&self, bank: u8) -> Result<(), Status> {
        if self.spec.banks.has(bank) {
            Ok(())
        } else {
            Err(ParamError::NoSuchMotor.into())
        }
    }

    /// A ROR/ROL velocity in the model's unit within AP 2's range (PDx-113 manual §5.7.1: 0…2047), else
    /// status 4.
    fn velocity_in_range(&self, v: i32) -> Result<(), Status> {
        match self.spec.axis.role(Role::TargetSpeed) {
            Some(i) if !self.spec.axis.params[i].range.contains(v) => Err(Status::InvalidValue),
            _ => Ok(()),
        }
    }

    /// What MVP REL counts from: AP 127 (TMCM-1316's options: 0 the last target, 1 the ramp's position,
    /// 2 the encoder), or the actual position for a model without it (PD28-1021 §3.7.4).
    fn relative_base(&mut self) -> i32 {
        match self.ap(Setting::RelativePositioning) {
            Some(0) => self.st.ramp.target_position,
            Some(2) => self.encoder_position(),
            _ => self.st.ramp.position,
        }
    }

    fn motor(&self, motor: u8) -> Result<(), Status> {
        if motor < self.spec.motors {
            Ok(())
        } else {
            Err(ParamError::NoSuchMotor.into())
        }
    }

    fn start_rotation(&mut self, velocity: i32) {
        self.leave_torque_mode();
        self.st.reference.stop();
        self.st.ramp.rotate(velocity);
        self.st.error_flags = 0; // AP 207: "cleared ... when a motion command runs"
        self.st.event.pending = false;
    }

    fn start_move(&mut self, target: i32) {
        self.leave_torque_mode();
        self.st.reference.stop();
        self.st.ramp.move_to(target);
        self.st.error_flags = 0;
        match self.st.event.mode {
            Some(EventMode::Next) => {
                self.st.event.mode = None;
                self.st.event.pending = true;
            }
            Some(EventMode::Every) => self.st.event.pending = true,
            None => {}
        }
    }

    /// Loads the accumulator and sets the comparison flags from it, as a comparison with 0. The manual never
    /// lists which commands set the flags, but its §3.6.6.4 example jumps with `JC NZ` right after a GIO.
    pub(crate) fn load_accumulator(&mut self, origin: Origin, v: i32) {
        let regs = self.regs(origin);
        regs.accumulator = v;
        crate::vm::run::set_compare(regs, v.cmp(&0));
    }

    fn axis_desc(
        &self,
        number: u8,
        allowed: impl Fn(&ParamDesc) -> bool,
    ) -> Result<(usize, &'static ParamDesc), Status> {
        permitted(&self.spec.axis, number, allowed)
    }

    fn global_desc(
        &self,
        number: u8,
        allowed: impl Fn(&ParamDesc) -> bool,
    ) -> Result<(usize, &'static ParamDesc), Status> {
        permitted(&self.spec.global, number, allowed)
    }

    /// GAP: an axis parameter's value (chapter 4, Table 15).
    pub fn get_axis(&mut self, number: u8) -> Result<i32, Status> {
        self.read_axis(number, None)
    }

    /// GAP at `now` (`None`: whenever the board was last brought up to date). A parameter that reads
    /// something of the board that changes with the board's own clock — a switch (it may bounce), the
    /// driver's flags (standstill after 2²⁰ clocks without a step) or the status word made of them — is
    /// read with the board brought to `now` first ([`Module::sync_board`]), so that it is the value at the
    /// instant of the read however often the module was polled before.
    pub(crate) fn read_axis(&mut self, number: u8, now: Option<Instant>) -> Result<i32, Status> {
        let (i, d) = self.axis_desc(number, |d| d.access.read)?;
        if let Some(now) = now {
            if matches!(
                d.role,
                Role::HomeSwitch | Role::RightSwitch | Role::LeftSwitch | Role::DriverFlags | Role::StatusWord
            ) {
                self.sync_board(now);
            }
        }
        let ramp = &self.st.ramp;
        Ok(match d.role {
            Role::Plain | Role::MicrostepResolution | Role::EncoderPrescaler => self.st.axis[i],
            Role::TargetPosition => ramp.target_position,
            Role::ActualPosition if self.st.cl.active => self.encoder_position(),
            Role::ActualPosition => ramp.position,
            // TMC428: in position mode the ramp sets v_target itself (see `hardware_target_speed`).
            Role::TargetSpeed if ramp.mode == Mode::Position && self.spec.driver == Driver::Tmc428Tmc24x => {
                self.hardware_target_speed()
            }
            Role::TargetSpeed => self.pps_to_units(ramp.target_velocity),
            Role::ActualSpeed => self.pps_to_units(ramp.velocity()),
            Role::PositionReached => i32::from(self.target_reached()),
            Role::RampMode => i32::from(ramp.mode == Mode::Velocity),
            // TMC428: 2 velocity; in position mode what was written, 0 (ramp) or 1 (soft).
            Role::RampModeTmc428 if ramp.mode == Mode::Velocity => 2,
            Role::RampModeTmc428 => i32::from(self.st.axis[i] == 1),
            Role::HomeSwitch => i32::from(self.switches().2),
            Role::RightSwitch => i32::from(self.switches().1),
            Role::LeftSwitch => i32::from(self.switches().0),
            // AP 180: the current scale 0..31 in use (current / 8, Table 22), after coolStep.
            Role::ActualCurrent => i32::from(self.current(self.st.now).0 >> 3),
            Role::LoadValue => i32::from(self.board.load().min(1023)),
            // AP 207: "cleared automatically when read".
            Role::ErrorFlags => i32::from(core::mem::take(&mut self.st.error_flags)),
            Role::DriverFlags => i32::from(self.board.driver_flags()),
            Role::EncoderPosition => self.encoder_position(),
            Role::EncoderAbsolute => self.encoder_absolute(),
            Role::TargetCurrent => self.st.cl.torque.map_or(self.st.axis[i], |(t, _)| t),
            Role::VelocityReached => i32::from(self.velocity_reached()),
            Role::StatusWord => self.status_word(),
            Role::ActualTorqueCurrent => self.actual_torque_current(),
            Role::I2tSum => self.st.cl.i2t.clamp(0, i64::from(i32::MAX)) as i32,
            Role::I2tExceedCount => self.st.cl.i2t_count as i32,
            Role::CurrentScale => i32::from(self.st.cl.scaler),
            Role::MeasuredVelocity => self.measured_velocity(),
            Role::EncoderInit => self.st.cl.init.code(),
            Role::ClosedLoopActive => i32::from(self.st.cl.active),
            Role::Gamma => self.st.cl.gamma,
            Role::VirtualPosition => self.st.ramp.position,
            // Virtual minus actual position in closed loop; in open loop there is no such error.
            Role::PositionError if self.st.cl.active => self.st.ramp.position.wrapping_sub(self.encoder_position()),
            Role::PositionError => 0,
            _ => self.st.axis[i],
        })
    }

    /// SAP/AAP: writes an axis parameter (RAM only).
    pub fn set_axis(&mut self, number: u8, v: i32, now: Instant) -> Result<(), Status> {
        let (i, d) = self.axis_desc(number, |d| d.access.write)?;
        if !d.range.contains(v) {
            return Err(ParamError::OutOfRange.into());
        }
        self.unlocked_for(d)?;
        // The encoder's input or scale changes (AP 201, 202, 210, 140 on a closed-loop model): the
        // position before, read through the old one.
        let rescales =
            (matches!(d.setting, Some(Setting::EncoderMode | Setting::EncoderResolution | Setting::MotorFullSteps))
                || d.role == Role::MicrostepResolution)
                && self.has_closed_loop();
        let encoder_before = if rescales { self.encoder_position() } else { 0 };
        // The pulse divisor (AP 154) scales the TMC428's clock: the velocity registers keep their values
        // in units, so AP 2 and AP 3 read the same and the speed in microsteps per second follows.
        let velocities = (d.setting == Some(Setting::PulseDivisor)).then(|| self.velocity_units());
        match d.role {
            // Writing the target position starts a move in position mode (§3.7.29's AAP example "transfer
            // result to target position" relies on it).
            Role::TargetPosition => {
                self.leave_torque_mode();
                self.st.ramp.move_to(v)
            }
            Role::ActualPosition => {
                self.relabel(v.wrapping_sub(self.st.ramp.position));
                self.st.ramp.set_position(v)
            }
            // AP 2: the velocity-mode target; in position mode it is kept for the next velocity mode.
            Role::TargetSpeed => self.st.ramp.target_velocity = self.units_to_pps(v),
            // Listed RW in Table 15: accepted, no effect: the ramp generator owns the actual speed.
            Role::ActualSpeed => {}
            Role::RampMode => {
                self.st.ramp.mode = if v == 1 { Mode::Velocity } else { Mode::Position };
            }
            // TMC428: 2 velocity mode; 0 ramp and 1 soft are position mode (the soft approach is not
            // simulated).
            Role::RampModeTmc428 => {
                self.st.ramp.mode = if v == 2 { Mode::Velocity } else { Mode::Position };
                self.st.axis[i] = v;
            }
            // In closed loop the step counter moves with the encoder, so that the loop sees no error.
            Role::EncoderPosition if self.st.cl.active => {
                let delta = v.wrapping_sub(self.encoder_position());
                self.st.ramp.set_position(self.st.ramp.position.wrapping_add(delta));
                self.relabel(delta);
            }
            Role::EncoderPosition => self.set_encoder(v),
            Role::TargetCurrent => {
                self.set_torque(v)?;
                self.st.axis[i] = v;
            }
            Role::EncoderInit => self.start_encoder_init(v)?,
            Role::ClearI2t => self.st.cl.i2t_exceeded = false,
            Role::I2tExceedCount => self.st.cl.i2t_count = v as u32,
            Role::EncoderPrescaler => {
                let now_value = self.encoder_position();
                self.st.axis[i] = v;
                self.set_encoder(now_value);
            }
            _ => self.st.axis[i] = v,
        }
        // Settings that act when written: the driver's own (stallGuard2 filter and threshold, current
        // range), the closed loop switched on or off, the encoder's input or scale. The driver's take
        // effect at this instant: the board is brought to it first (its clock may lag the module's).
        if matches!(
            d.setting,
            Some(Setting::StallFilter | Setting::StallThreshold | Setting::CurrentRange | Setting::EncoderMode)
        ) {
            self.sync_board(now);
        }
        match d.setting {
            Some(Setting::StallFilter | Setting::StallThreshold | Setting::CurrentRange) => self.configure_driver(),
            Some(Setting::ClosedLoop) => self.closed_loop_switched(),
            _ => {}
        }
        if rescales {
            self.encoder_rescaled(encoder_before, d.setting == Some(Setting::EncoderMode));
        }
        if let Some(units) = velocities {
            self.set_velocity_units(units);
        }

        Ok(())
    }

    /// GGP: a global parameter (chapter 5).
    pub fn get_global(&mut self, number: u8, bank: u8, now: Instant) -> Result<i32, Status> {
        self.bank(bank)?;
        match bank {
            0 => {
                let (i, d) = self.global_desc(number, |d| d.access.read)?;
                Ok(match d.role {
                    Role::ApplicationStatus => self.vm.state.code(),
                    Role::DownloadMode => i32::from(self.vm.download.is_some()),
                    Role::ProgramCounter => i32::from(self.vm.pc),
                    // GP 132: "incremented every 1 ms" (§5.1).
                    Role::TickTimer => {
                        let (at, base) = self.st.tick_base;
                        ((u64::from(base) + (now - at).millis()) & 0x7FFF_FFFF) as i32
                    }
                    // GP 133: a new random number 0..2^31−1 on every read (xorshift32).
                    Role::RandomNumber => {
                        let mut x = self.st.rng;
                        x ^= x << 13;
                        x ^= x >> 17;
                        x ^= x << 5;
                        self.st.rng = x;
                        (x & 0x7FFF_FFFF) as i32
                    }
                    // The password is never read back: 1 = unlocked, 0 = locked.
                    Role::Password => i32::from(self.st.unlocked),
                    _ => self.st.global[i],
                })
            }
            2 => Ok(self.st.user[self.user_index(number)?]),
            // A bank 1 with no parameter the sources name (PDx-113 manual §5.7.9).
            1 => Err(ParamError::Unknown.into()),
            3 => {
                let (i, _) = self.spec.interrupt.find(number)?;
                Ok(self.st.interrupt[i])
            }
            _ => Err(ParamError::NoSuchMotor.into()),
        }
    }

    /// SGP/AGP: writes a global parameter; bank 0 A parameters go to the EEPROM at once (§5.1).
    pub fn set_global(&mut self, number: u8, bank: u8, v: i32, now: Instant) -> Result<(), Status> {
        self.bank(bank)?;
        match bank {
            0 => {
                let (i, d) = self.global_desc(number, |d| d.access.write)?;
                if !d.range.contains(v) {
                    return Err(ParamError::OutOfRange.into());
                }
                self.unlocked_for(d)?;
                if d.access.auto {
                    // Stored first: if the EEPROM refuses, nothing changes.
                    self.spin.touch(); // an EEPROM write
                    persist::store_global(&mut self.board, self.spec, i, v)?;
                }
                if d.setting == Some(Setting::CodeProtection) {
                    self.protection_changed(self.st.global[i], v)?;
                }
                match d.role {
                    Role::TickTimer => self.st.tick_base = (now, v as u32),
                    // A written value seeds the generator (0 would stick; it becomes the start seed).
                    Role::RandomNumber => self.st.rng = if v == 0 { RNG_SEED } else { v as u32 },
                    // The password: the model's unlocks the protected parameters, anything else locks them.
                    Role::Password => self.st.unlocked = self.spec.password == Some(v),
                    _ => {}
                }
                self.st.global[i] = v;
                Ok(())
            }
            2 => {
                let n = self.user_index(number)?;
                self.st.user[n] = v;
                Ok(())
            }
            1 => Err(ParamError::Unknown.into()),
            3 => {
                let (i, d) = self.spec.interrupt.find(number)?;
                if !d.range.contains(v) {
                    return Err(ParamError::OutOfRange.into());
                }
                self.st.interrupt[i] = v;
                self.restart_timer(number, now);
                Ok(())
            }
            _ => Err(ParamError::NoSuchMotor.into()),
        }
    }

    fn read_port(&mut self, kind: PortKind) -> i32 {
        match kind {
            PortKind::DigitalInput(bit) => i32::from((self.board.digital_inputs() >> bit) & 1),
            PortKind::AllInputs => i32::from(self.board.digital_inputs()),
            PortKind::EncoderNearZero => i32::from(self.encoder_near_zero()),
            PortKind::Analog(ch) => i32::from(self.board.analog_input(ch).min(4095)),
            PortKind::Analog10(ch) => i32::from(self.board.analog_input(ch).min(4095) >> 2),
            PortKind::Temperature => self.board.temperature(),
            PortKind::Output(bit) => i32::from((self.st.outputs >> bit) & 1),
            PortKind::AllOutputs => i32::from(self.st.outputs),
        }
    }

    fn coord_index(&self, coord: u8) -> Result<usize, Status> {
        if coord <= self.spec.coordinates {
            Ok(usize::from(coord))
        } else {
            Err(Status::WrongType)
        }
    }

    /// Sets a coordinate; with GP 84 = 1 coordinates 1..20 also go to the EEPROM (§3.7.24).
    fn write_coordinate(&mut self, coord: u8, v: i32) -> Result<(), Status> {
        let n = self.coord_index(coord)?;
        if n > 0 && self.gp_flag(Setting::CoordinateStorage) {
            self.spin.touch(); // an EEPROM write
            persist::store_coordinate(&mut self.board, self.spec, coord, v)?;
        }
        self.st.coords[n] = v;
        Ok(())
    }

    /// SCO/GCO x, 255: coordinate 0 = all of 1..20, n = that one (§3.7.24, §3.7.25).
    fn copy_coordinates(&mut self, coord: u8, to_eeprom: bool) -> Result<(), Status> {
        let n = self.coord_index(coord)? as u8;
        let range = if n == 0 { 1..=self.spec.coordinates } else { n..=n };
        for c in range {
            if to_eeprom {
                self.spin.touch(); // an EEPROM write
                persist::store_coordinate(&mut self.board, self.spec, c, self.st.coords[usize::from(c)])?;
            } else {
                self.st.coords[usize::from(c)] = persist::load_coordinate(&mut self.board, self.spec, c)?;
            }
        }
        Ok(())
    }

    /// AP 209 = value at the reference + counts since × p / 512 (§6.2).
    fn encoder_position(&mut self) -> i32 {
        let counts = self.encoder_counts_now();
        self.encoder_value(counts)
    }

    /// Sets AP 209 to `v` at the counts the encoder reads now.
    pub(crate) fn set_encoder(&mut self, v: i32) {
        let counts = self.encoder_counts_now();
        self.st.encoder = crate::module::EncoderBase { counts, value: v };
        // Clear-on-null (AP 210 + 4) looks for zero crossings from here on: not between a reading from
        // before (taken when it was last on, perhaps long ago) and the next one, which would depend on
        // when that next one is taken.
        self.st.last_counts = counts;
    }

    /// AP 215: the absolute single-turn value 0..counts per revolution − 1 (0..1023 on the PD28-1021),
    /// independent of the prescaler (§6.2).
    fn encoder_absolute(&mut self) -> i32 {
        self.encoder_counts_now().rem_euclid(i64::from(self.counts_per_rev())) as i32
    }

    /// GIO 11, 0: the encoder is within 1/256 of a revolution (±4 counts, ±1.4° on the PD28-1021) of its
    /// absolute zero (our tolerance; §6.2 gives none).
    fn encoder_near_zero(&mut self) -> bool {
        let per_rev = self.counts_per_rev() as i32;
        let tolerance = (per_rev / 256).max(1);
        let a = self.encoder_absolute();
        !(tolerance..=per_rev - tolerance).contains(&a)
    }

    /// A bank 2 user variable's index: 0..the model's user variables (else 3, wrong type).
    fn user_index(&self, number: u8) -> Result<usize, Status> {
        let n = usize::from(number);
        if n < usize::from(self.spec.user_variables) {
            Ok(n)
        } else {
            Err(ParamError::Unknown.into())
        }
    }

    /// Refuses a write or store of a password-protected parameter while the module is locked (status 8).
    pub(crate) fn unlocked_for(&self, d: &ParamDesc) -> Result<(), Status> {
        if d.access.protected && !self.st.unlocked {
            Err(ParamError::Protected.into())
        } else {
            Ok(())
        }
    }

    /// RFS START/STOP/STATUS (§3.7.13, §7.1); see [`crate::motion::reference`] for the decisions.
    fn reference_search(&mut self, action: RfsAction, _now: Instant) -> Result<i32, Status> {
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
                self.st.error_flags = 0;
                self.st.event.pending = false;
                self.leave_torque_mode();
                if let Action::Rotate(v) = self.st.reference.start(mode, fast) {
                    self.st.ramp.hard_stop();
                    self.st.ramp.rotate(v);
                }
                Ok(0)
            }
            RfsAction::Stop => {
                if self.st.reference.is_active() {
                    self.st.reference.stop();
                    self.st.ramp.rotate(0);
                }
                Ok(0)
            }
            RfsAction::Status => Ok(self.st.reference.status()),
        }
    }
}

/// A parameter of `table` that allows what `allowed` asks (read, write, store, ...): unknown → 3, not
/// permitted → 3 (see [`ParamError`]).
fn permitted(
    table: &crate::param::Table,
    number: u8,
    allowed: impl Fn(&ParamDesc) -> bool,
) -> Result<(usize, &'static ParamDesc), Status> {
    let (i, d) = table.find(number)?;
    if allowed(d) {
        Ok((i, d))
    } else {
        Err(ParamError::NotPermitted.into())
    }
}

//! The one dispatcher: every command a host sends goes through [`Module::execute`] — the host's reads
//! (GAP, GGP, GIO) by a short way into the same arms (`Module::host_read`), as most of a host's traffic.
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

use super::{params, Axis, EventRequest, Module, Origin, Outcome};
use crate::hal::{Analog, Board, Inputs, Outputs};
use crate::model::{AppStatusReply, Driver, ModelSpec, PortKind};
use crate::param::{persist, ParamError, Role};
use crate::time::Instant;
use crate::vm::{alu, Registers, Vm};
use tmcl_wire::command::MAGIC_KEY;
use tmcl_wire::{
    CalcOp, CalcxOp, Command, EventMode, Instruction, MoveTarget, Opcode, Status, StatusKind, VersionFormat, FRAME_LEN,
};

type Exec = Result<Outcome, Status>;

/// The reads [`Module::host_read`] answers.
#[derive(Clone, Copy)]
enum Read {
    Gap,
    Ggp,
    Gio,
}

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

    /// Executes one validated command from the host or the program at `now`: one short arm per command,
    /// each citing the manual section that defines it.
    pub(crate) fn exec(&mut self, command: Command, now: Instant, origin: Origin) -> Exec {
        use Command as C;
        if origin == Origin::Host {
            // A host input: a change (`seam.rs`); what the board's hook concluded while nothing
            // changed (a program spinning in a fixed point) is void.
            self.board.input();
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
            for axis in self.st.axes.iter_mut() {
                axis.drive_due = Some(axis.drive_due.map_or(now, |t| t.min(now)));
            }
        }
        match command {
            // §3.7.1 ROR: velocity mode, then AP 2 = velocity (a negative velocity turns left).
            C::Ror { motor, velocity } => self.rotate(motor, velocity, velocity),
            // §3.7.2 ROL: as ROR to the left: AP 2 = −velocity (the manual leaves a negative velocity open; it
            // turns right). Its range is the whole −2147483648..2147483647: the lowest value, whose negation
            // does not fit, turns right at the highest velocity, 2147483647.
            C::Rol { motor, velocity } => self.rotate(motor, velocity.checked_neg().unwrap_or(i32::MAX), velocity),
            // §3.7.3 MST: velocity mode, target speed 0 (the printed "axis parameter #0" is a typo for AP 2),
            // decelerating with AP 5.
            C::Mst { motor } => {
                let m = self.motor(motor)?;
                start_rotation(&mut self.st.axes[m], &mut self.st.event, 0);
                value(0)
            }
            // MVP COORD with a motor mask (bit 6 or 7 set; TMCM-3110/6110 firmware manuals, MVP): several
            // motors to their coordinate n at once, interpolated or each at its own speed.
            C::Mvp { motor, target: MoveTarget::Coord(n) } if motor & 0xC0 != 0 && self.spec.motors > 1 => {
                self.mvp_coordinated(motor, n)
            }
            // §3.7.4 MVP ABS/REL/COORD: AP 0 = new target, position mode (AP 128 = 0).
            C::Mvp { motor, target } => self.mvp(motor, target),
            // §3.7.5 SAP: RAM only.
            C::Sap { param, motor, value: v } => {
                let m = self.motor(motor)?;
                self.write_axis(m, param, v, now)?;
                value(v)
            }
            // §3.7.6 GAP.
            C::Gap { param, motor } => value(self.gap(param, motor, now)?),
            // §3.7.7 STAP: E parameters only; the motor's RAM value, the model's table and the EEPROM.
            C::Stap { param, motor } => {
                let m = self.motor(motor)?;
                let Module { board, spec, st, .. } = self;
                params::store_axis(board, spec, &st.axes[m], m, param, st.banks.unlocked).map(|()| Outcome::Value(0))
            }
            // §3.7.8 RSAP: E parameters only; the EEPROM into the motor's RAM value.
            C::Rsap { param, motor } => {
                let m = self.motor(motor)?;
                let Module { board, spec, st, .. } = self;
                params::restore_axis(board, spec, &mut st.axes[m], m, param).map(|()| Outcome::Value(0))
            }
            // §3.7.9 SGP: the banks, and what a write reaches besides them (`params::Reach`).
            C::Sgp { param, bank, value: v } => {
                let (spec, banks, reach) = self.global_parts();
                params::write_global(spec, banks, reach, param, bank, v, now).map(|()| Outcome::Value(v))
            }
            // §3.7.10 GGP: the banks; GP 128–130 the program machine.
            C::Ggp { param, bank } => value(self.ggp(param, bank, now)?),
            // §3.7.11 STGP: bank 2 user variables 0..55 (§5.3); bank 0 A parameters are already stored
            // and a STGP rewrites them (the manual does not say what STGP does on bank 0).
            C::Stgp { param, bank } => {
                let Module { board, spec, st, .. } = self;
                params::store_global(board, spec, &st.banks, param, bank).map(|()| Outcome::Value(0))
            }
            // §3.7.12 RSGP.
            C::Rsgp { param, bank } => {
                let Module { board, spec, st, .. } = self;
                params::restore_global(board, spec, &mut st.banks, param, bank).map(|()| Outcome::Value(0))
            }
            // §3.7.13 RFS START/STOP/STATUS.
            C::Rfs { action, motor } => {
                let m = self.motor(motor)?;
                let (v, faults) = self.motor_at(m).reference_search(action)?;
                self.apply(m, faults);
                value(v)
            }
            // §3.7.14 SIO: bank 2 outputs; port 255 sets all from a bit vector, −1 takes it from A.
            C::Sio { port, bank, value: v } => {
                let a = self.regs(origin).accumulator;
                let Module { board, spec, st, .. } = self;
                sio(board, spec, &mut st.outputs, a, port, bank, v)
            }
            // §3.7.15 GIO: bank 0 digital inputs, bank 1 analog inputs, bank 2 outputs read back.
            C::Gio { port, bank } => value(self.gio(port, bank)?),
            // §3.7.16 CALC: A ← A op operand; the reply carries the operand (example reply §3.7.16).
            C::Calc { op, operand } => self.calc(op, operand, origin),
            // §3.7.28 CALCX: A ← A op X (LOAD, SWAP and NOT work on X).
            C::Calcx { op } => self.calcx(op, origin),
            // §3.7.29 AAP: axis parameter ← A.
            C::Aap { param, motor } => {
                let m = self.motor(motor)?;
                let a = self.regs(origin).accumulator;
                self.write_axis(m, param, a, now)?;
                value(a)
            }
            // §3.7.30 AGP: global parameter ← A.
            C::Agp { param, bank } => {
                let a = self.regs(origin).accumulator;
                let (spec, banks, reach) = self.global_parts();
                params::write_global(spec, banks, reach, param, bank, a, now)?;
                value(a)
            }
            // §3.7.24 SCO; motor 255 copies RAM → EEPROM (coordinate 0 = all of 1..20).
            C::Sco { coord, motor: 255, .. } => self.copy_coordinates(coord, true),
            C::Sco { coord, motor, position } => self.set_coordinate(coord, motor, position),
            // §3.7.25 GCO; motor 255 copies EEPROM → RAM.
            C::Gco { coord, motor: 255 } => self.copy_coordinates(coord, false),
            C::Gco { coord, motor } => {
                let m = self.motor(motor)?;
                value(self.st.axes[m].coords[params::coord_index(self.spec, coord)?])
            }
            // §3.7.26 CCO: coordinate ← actual position; the reply carries it.
            C::Cco { coord, motor } => {
                let m = self.motor(motor)?;
                self.set_coordinate(coord, motor, self.st.axes[m].ramp.position)
            }
            // §3.7.27 ACO: coordinate ← accumulator (as its description says; its "internal function" line says the
            // actual position).
            C::Aco { coord, motor } => {
                let a = self.regs(origin).accumulator;
                self.set_coordinate(coord, motor, a)
            }
            // §3.7.31 CLE: clears error flags (the comparison flags stay).
            C::Cle { flag } => {
                self.regs(origin).flags &= !alu::error_mask(flag);
                value(0)
            }
            // §3.7.32 EI / §3.7.33 DI: interrupt n (Table 12) or 255 = global.
            C::Ei { interrupt } => self.vm.enable_interrupt(&self.spec.interrupts, interrupt, true).and(value(0)),
            C::Di { interrupt } => self.vm.enable_interrupt(&self.spec.interrupts, interrupt, false).and(value(0)),
            // §3.7.34 VECT from the host, on a model whose firmware takes it in direct mode
            // (`ModelDesc::host_vect`: the TMCM-3110/6110, as odemis' TMCL driver uses them); the reply
            // carries the address.
            C::Vect { interrupt, address } if origin == Origin::Host && self.spec.host_vect => self
                .vm
                .set_vector(&self.spec.interrupts, interrupt, address, self.spec.program_memory)
                .and(value(address)),
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
                self.vm.stop();
                value(0)
            }
            // §3.7.38 129: run from the current address (type 0) or a given one (type 1, §8.6).
            C::RunApplication { from } => {
                self.vm.run_from(from, now, self.spec.program_memory)?;
                value(from.unwrap_or(0))
            }
            // §3.7.38 130: one instruction.
            C::StepApplication => {
                self.step_application(now);
                value(0)
            }
            // §3.7.38 131: stop, PC 0, stack, A, X and flags cleared.
            C::ResetApplication => {
                self.vm.reset(&mut self.st.regs);
                value(0)
            }
            // §3.7.38 132/133: download mode.
            C::StartDownload { address } => {
                self.start_download(address)?;
                value(address)
            }
            C::QuitDownload => {
                self.vm.quit_download();
                value(0)
            }
            // §3.7.38 134: read program memory (special reply).
            C::ReadMemory { address } => Ok(Outcome::Raw(self.read_memory(address)?)),
            // §3.7.38 135: application status.
            C::GetStatus { kind } => value(get_status(self.spec, &self.vm, &self.st.regs, kind)),
            // §3.4.1 command 139: ASCII mode. The reply (binary) goes out first, then the mode changes.
            C::EnterAscii => Ok(Outcome::EnterAscii),
            // §3.7.38 136: type 0 = host address + 8 characters, no checksum; type 1 = binary.
            C::GetVersion { format: VersionFormat::String } => Ok(Outcome::Raw(self.version_string())),
            C::GetVersion { format: VersionFormat::Binary } => value(self.spec.version_binary),
            // §3.7.38 137 (value 1234, checked by decode): factory defaults into the EEPROM, no reply; the
            // module then restarts on them (the program memory is kept: it is not a setting).
            C::FactoryDefault => {
                persist::format(&mut self.board, self.spec, false).map_err(Status::from)?;
                Ok(Outcome::Silent)
            }
            // §3.7.37 138: type 0 = next MVP, type 1 = every MVP; value = motor mask.
            C::RequestTargetReachedEvent { mode, mask } => {
                self.st.event.request(self.spec.motors, self.st.asking_port, mode, mask).and_then(value)
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

    /// SCO, CCO, ACO: coordinate `coord` ← `v` (through to the EEPROM with GP 84 = 1); the reply carries it.
    fn set_coordinate(&mut self, coord: u8, motor: u8, v: i32) -> Exec {
        let m = self.motor(motor)?;
        let Module { board, spec, st, .. } = self;
        params::write_coordinate(board, spec, &st.banks, &mut st.axes[m], m, coord, v)?;
        value(v)
    }

    /// SCO/GCO with motor 255: every motor's coordinate `coord` (0 = all) into the EEPROM or back from it;
    /// the reply carries 0.
    fn copy_coordinates(&mut self, coord: u8, to_eeprom: bool) -> Exec {
        let Module { board, spec, st, .. } = self;
        params::copy_coordinates(board, spec, &mut st.axes, coord, to_eeprom)?;
        value(0)
    }

    /// ROR, ROL: velocity mode towards `velocity` (AP 2's unit), checked against AP 2's range; the
    /// reply carries `reply`.
    fn rotate(&mut self, motor: u8, velocity: i32, reply: i32) -> Exec {
        let m = self.motor(motor)?;
        self.velocity_in_range(velocity)?;
        let axis = &mut self.st.axes[m];
        start_rotation(axis, &mut self.st.event, axis.units_to_pps(self.spec, velocity));
        value(reply)
    }

    /// MVP: a move to an absolute position, by an offset, or to a stored coordinate (§3.7.4).
    fn mvp(&mut self, motor: u8, target: MoveTarget) -> Exec {
        let m = self.motor(motor)?;
        let to = match target {
            MoveTarget::Abs(p) => p,
            // "an offset to the actual position ... must not exceed the above mentioned limits".
            MoveTarget::Rel(d) => self.motor_at(m).relative_base().checked_add(d).ok_or(Status::InvalidValue)?,
            MoveTarget::Coord(n) => self.st.axes[m].coords[self.move_coordinate(n)?],
        };
        self.check_target(to)?;
        start_move(&mut self.st.axes[m], &mut self.st.event, to);
        value(match target {
            MoveTarget::Abs(v) | MoveTarget::Rel(v) | MoveTarget::Coord(v) => v,
        })
    }

    /// The stored coordinate an MVP COORD goes to (§3.7.4): 0 to the model's last; another number is
    /// status 4 (invalid value).
    pub(super) fn move_coordinate(&self, n: i32) -> Result<usize, Status> {
        usize::try_from(n).ok().filter(|n| *n <= usize::from(self.spec.coordinates)).ok_or(Status::InvalidValue)
    }

    /// A move's target must be a position the counter holds (PDx-113 manual §5.7.4: −2^23 … 2^23 − 1,
    /// "the new resulting position value must not exceed the above mentioned limits, too"): status 4 if not.
    pub(super) fn check_target(&self, to: i32) -> Result<(), Status> {
        match self.spec.axis.role(Role::TargetPosition) {
            Some(i) if !self.spec.axis.params[i].range.contains(to) => Err(Status::InvalidValue),
            _ => Ok(()),
        }
    }

    /// GIO: a port of bank 0, 1 or 2 the model has (another port 3, another bank 4).
    fn gio(&mut self, port: u8, bank: u8) -> Result<i32, Status> {
        let missing = if bank <= 2 { Status::WrongType } else { Status::InvalidValue };
        let desc = self.spec.port(bank, port).ok_or(missing)?;
        match read_port(&mut self.board, self.st.outputs, desc.kind) {
            Some(v) => Ok(v),
            // (The encoder of motor 0: the models with this port have one motor.)
            None => Ok(i32::from(self.motor_at(0).encoder_near_zero())),
        }
    }

    /// §3.7.6 GAP: axis parameter `param` of `motor` at `now`.
    #[inline(always)]
    fn gap(&mut self, param: u8, motor: u8, now: Instant) -> Result<i32, Status> {
        let m = self.motor(motor)?;
        self.read_axis(m, param, Some(now))
    }

    /// §3.7.10 GGP: parameter `param` of bank `bank` at `now`.
    #[inline(always)]
    fn ggp(&mut self, param: u8, bank: u8, now: Instant) -> Result<i32, Status> {
        let Module { spec, st, vm, .. } = self;
        params::read_global(spec, &mut st.banks, vm, param, bank, now)
    }

    /// A host's read — GAP, GGP or GIO — answered straight from the instruction's fields; `None` for any
    /// other command, or one the model lacks (the dispatcher answers those). Reads change nothing the
    /// driver sees and are most of what a host sends (it polls positions, parameters and inputs), so they
    /// skip the decode into a [`Command`] and the dispatcher's checks for commands that change something;
    /// what they run is the dispatcher's own arm (`gap`, `ggp`, `gio`), so the value and the status are
    /// the ones [`Module::exec`] gives (a test compares both ways for every type, motor or bank and model).
    #[inline(always)]
    pub(crate) fn host_read(&mut self, i: &Instruction, now: Instant) -> Option<Result<i32, Status>> {
        let read = match i.opcode {
            Opcode::Gap => Read::Gap,
            Opcode::Ggp => Read::Ggp,
            Opcode::Gio => Read::Gio,
            _ => return None,
        };
        if !self.spec.commands.contains(i.opcode) {
            return None;
        }
        // A host input, as at the top of `exec`.
        self.board.input();
        Some(match read {
            Read::Gap => self.gap(i.kind, i.motor, now),
            Read::Ggp => self.ggp(i.kind, i.motor, now),
            Read::Gio => self.gio(i.kind, i.motor),
        })
    }

    /// CALC (§3.7.16) on the host's or the program's registers (`vm/alu.rs`); the reply carries the
    /// operand.
    fn calc(&mut self, op: CalcOp, operand: i32, origin: Origin) -> Exec {
        alu::calc(self.regs(origin), op.code(), operand)?;
        value(operand)
    }

    /// CALCX (§3.7.28) on the host's or the program's registers (`vm/alu.rs`).
    fn calcx(&mut self, op: CalcxOp, origin: Origin) -> Exec {
        alu::calcx(self.regs(origin), op.code())?;
        value(0)
    }

    /// Command 136 type 0 (§3.7.38): the host address and the model's 8 characters, no checksum.
    fn version_string(&self) -> [u8; FRAME_LEN] {
        let mut raw = [0u8; FRAME_LEN];
        raw[0] = self.host_address();
        raw[1..].copy_from_slice(&self.spec.version_string);
        raw
    }

    /// A ROR/ROL velocity in the model's unit within AP 2's range (PDx-113 manual §5.7.1: 0…2047), else
    /// status 4.
    fn velocity_in_range(&self, v: i32) -> Result<(), Status> {
        match self.spec.axis.role(Role::TargetSpeed) {
            Some(i) if !self.spec.axis.params[i].range.contains(v) => Err(Status::InvalidValue),
            _ => Ok(()),
        }
    }

    /// The motor byte of a command: a motor of the model, else status 4 (PD28-1021 manual §3.5: the
    /// motor/bank byte; chapter 3's status table: 4 = invalid value).
    pub(crate) fn motor(&self, motor: u8) -> Result<usize, Status> {
        if motor < self.spec.motors {
            Ok(usize::from(motor))
        } else {
            Err(ParamError::NoSuchMotor.into())
        }
    }
}

/// ROR/ROL/MST (PD28-1021 manual §3.7.1–3.7.3): the motor's `axis` to velocity mode towards `velocity`
/// (microsteps per second). The motion command takes the motor over: an interpolated MVP COORD's speeds,
/// torque mode and a reference search end, AP 207's flags are "cleared ... when a motion command runs",
/// and a pending 138 event (`event`) is void.
#[inline]
pub(super) fn start_rotation(axis: &mut Axis, event: &mut EventRequest, velocity: i32) {
    axis.interpolation = None;
    axis.leave_torque_mode();
    axis.reference.stop();
    axis.ramp.rotate(velocity);
    axis.error_flags = 0;
    event.pending = false;
}

/// MVP (§3.7.4, and each motor of an MVP COORD with a motor mask): the motor's `axis` to `target` in
/// position mode, taking the motor over as [`start_rotation`] does; a 138 request (§3.7.37) in `event`
/// arms its event, once for type 0 (the request is used up), at every MVP for type 1.
#[inline]
pub(super) fn start_move(axis: &mut Axis, event: &mut EventRequest, target: i32) {
    axis.interpolation = None;
    axis.leave_torque_mode();
    axis.reference.stop();
    axis.ramp.move_to(target);
    axis.error_flags = 0;
    match event.mode {
        Some(EventMode::Next) => {
            event.mode = None;
            event.pending = true;
        }
        Some(EventMode::Every) => event.pending = true,
        None => {}
    }
}

/// Command 135's value (PD28-1021 manual §3.7.38) of the program machine `vm` and its registers `regs`.
/// PDx-113 manual §5.5 (`spec`'s `AppStatusReply::Plain`): the state alone (0 stop, 1 run, 2 step,
/// 3 reset), type "don't care".
fn get_status(spec: &ModelSpec, vm: &Vm, regs: &Registers, kind: StatusKind) -> i32 {
    if spec.app_status == AppStatusReply::Plain {
        return vm.state().code();
    }
    match kind {
        StatusKind::MemoryPointer => vm.status(false),
        StatusKind::ProgramCounter => vm.status(true),
        StatusKind::Accumulator => regs.accumulator,
        StatusKind::XRegister => regs.x,
    }
}

/// SIO (PD28-1021 manual §3.7.14) of `port` in `bank` := `v`: bank 2's outputs (`outputs` as last set, bit
/// n = OUTn; port 255 all of them from a bit vector, or from the accumulator `a` for −1) and, where the
/// model has them, the switches' pull-ups of bank 0, on `board`; another bank is an invalid value of the
/// bank byte.
fn sio<O: Outputs>(board: &mut O, spec: &ModelSpec, outputs: &mut u8, a: i32, port: u8, bank: u8, v: i32) -> Exec {
    if !spec.writes_bank(bank) {
        return Err(Status::InvalidValue);
    }
    let desc = spec.output_port(bank, port).ok_or(Status::WrongType)?;
    let bits = match desc.kind {
        PortKind::PullUps => {
            let bits = u8::try_from(v).ok().filter(|b| *b <= 3).ok_or(Status::InvalidValue)?;
            board.set_pull_ups(bits);
            return value(v);
        }
        PortKind::Output(bit) => match v {
            0 => *outputs & !(1 << bit),
            1 => *outputs | (1 << bit),
            _ => return Err(Status::InvalidValue),
        },
        PortKind::AllOutputs => match v {
            -1 => a as u8,
            0..=255 => v as u8,
            _ => return Err(Status::InvalidValue),
        },
        _ => return Err(Status::WrongType),
    };
    let bits = bits & (((1u16 << spec.outputs) - 1) as u8); // outputs ≤ 8
    *outputs = bits;
    board.set_outputs(bits);
    value(v)
}

/// GIO (§3.7.15) of a port of `kind`: what `board` reads now, or the outputs as last set (`outputs`);
/// `None` for the encoder's zero (GIO 11, 0), which the motor reads (`Motor::encoder_near_zero`, `axis/drive.rs`).
fn read_port<P: Inputs + Analog>(board: &mut P, outputs: u8, kind: PortKind) -> Option<i32> {
    Some(match kind {
        PortKind::DigitalInput(bit) => i32::from((board.digital_inputs() >> bit) & 1),
        PortKind::AllInputs => i32::from(board.digital_inputs()),
        PortKind::EncoderNearZero => return None,
        PortKind::Analog(ch) => i32::from(board.analog_input(ch).min(4095)),
        PortKind::Analog10(ch) => i32::from(board.analog_input(ch).min(4095) >> 2),
        PortKind::Temperature => board.temperature(),
        PortKind::Output(bit) => i32::from((outputs >> bit) & 1),
        PortKind::AllOutputs => i32::from(outputs),
        PortKind::SupplyVoltage => i32::from(board.supply_voltage()),
        // Written only (`ModelSpec::port` never gives it to GIO).
        PortKind::PullUps => 0,
    })
}

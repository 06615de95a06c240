//! Parameters on the module: axis parameters (chapter 4), the global banks (chapter 5: bank 0
//! settings, bank 2 user variables, bank 3 interrupt configuration), coordinates (§3.7.24–3.7.27), and
//! their EEPROM copies ([`crate::param::persist`]). Statuses as the dispatcher's docs (`module/exec.rs`)
//! decide them.

use super::seam::Seam;
use super::{program, Axis, Module};
use crate::axis::Axes;
use crate::hal::prelude::*;
use crate::hal::{Board, Nvm};
use crate::model::{ModelSpec, Setting};
use crate::param::banks::Banks;
use crate::param::{persist, ParamDesc, ParamError, Role};
use crate::time::Instant;
use crate::vm::{Program, Registers, Vm};
use tmcl_wire::Status;

/// A bank of SGP, GGP, STGP and RSGP (chapter 5) the model has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Bank {
    /// Bank 0: the global parameters.
    Global,
    /// Bank 2: the user variables (§5.3).
    User,
    /// Bank 3: the interrupt configuration (§5.4).
    Interrupt,
}

impl Bank {
    /// The bank `bank` names in `spec`: one the model lacks, or one past 3, is status 4 (the bank byte
    /// being a value of the command; PD28-1021 manual chapter 5, PDx-113 manual §5.7.9); bank 1, which no
    /// source gives a parameter, is status 3 (an unknown parameter of it).
    #[inline]
    pub(crate) fn of(spec: &ModelSpec, bank: u8) -> Result<Bank, Status> {
        if !spec.banks.has(bank) {
            return Err(ParamError::NoSuchMotor.into());
        }
        match bank {
            0 => Ok(Bank::Global),
            2 => Ok(Bank::User),
            3 => Ok(Bank::Interrupt),
            1 => Err(ParamError::Unknown.into()),
            _ => Err(ParamError::NoSuchMotor.into()),
        }
    }
}

/// STAP (PD28-1021 manual §3.7.7): motor `m`'s E parameter `number` from its RAM value in `axis` into the
/// EEPROM of `nvm` (the board, behind the seam); `unlocked` is whether password-protected parameters may be
/// stored.
pub(crate) fn store_axis(
    nvm: &mut impl Nvm,
    spec: &ModelSpec,
    axis: &Axis,
    m: usize,
    number: u8,
    unlocked: bool,
) -> Result<(), Status> {
    let (i, d) = permitted(&spec.axis, number, |d| d.access.store)?;
    unlocked_for(unlocked, d)?;
    persist::store_axis(nvm, spec, m, i, axis.params[i])?;
    Ok(())
}

/// RSAP (PD28-1021 manual §3.7.8): motor `m`'s E parameter `number` back from the EEPROM of `nvm` into
/// `axis` (its default if the stored value is out of range).
pub(crate) fn restore_axis(
    nvm: &mut impl Nvm,
    spec: &ModelSpec,
    axis: &mut Axis,
    m: usize,
    number: u8,
) -> Result<(), Status> {
    let (i, d) = permitted(&spec.axis, number, |d| d.access.store)?;
    let v = persist::load_axis(nvm, spec, m, i)?;
    axis.params[i] = if d.range.contains(v) { v } else { d.default };
    Ok(())
}

impl<B: Board> Module<B> {
    /// GAP of motor 0: an axis parameter's value (chapter 4, Table 15). A library call from outside, as a
    /// host's GAP is: a read may change state (AP 207 clears on read), so it counts as an input
    /// (`module/seam.rs`).
    pub fn get_axis(&mut self, number: u8) -> Result<i32, Status> {
        self.get_axis_of(0, number)
    }

    /// GAP of motor `motor` (status 4 for a motor the model lacks), as [`Module::get_axis`].
    pub fn get_axis_of(&mut self, motor: u8, number: u8) -> Result<i32, Status> {
        self.board.input();
        let m = self.motor(motor)?;
        self.read_axis(m, number, None)
    }

    /// SAP of motor 0 without the frame: writes an axis parameter (RAM only) at `now`, as a library call
    /// from outside (an input, `module/seam.rs`).
    pub fn set_axis(&mut self, number: u8, v: i32, now: Instant) -> Result<(), Status> {
        self.set_axis_of(0, number, v, now)
    }

    /// SAP of motor `motor` (status 4 for a motor the model lacks), as [`Module::set_axis`].
    pub fn set_axis_of(&mut self, motor: u8, number: u8, v: i32, now: Instant) -> Result<(), Status> {
        self.board.input();
        let m = self.motor(motor)?;
        self.write_axis(m, number, v, now)
    }

    /// GGP without the frame: a global parameter, as a library call from outside (an input: GP 133 draws
    /// a new number at every read).
    pub fn get_global(&mut self, number: u8, bank: u8, now: Instant) -> Result<i32, Status> {
        self.board.input();
        read_global(self.spec, &mut self.st.banks, &self.vm, number, bank, now)
    }

    /// SGP without the frame: writes a global parameter at `now`, as a library call from outside (an
    /// input, `module/seam.rs`).
    pub fn set_global(&mut self, number: u8, bank: u8, v: i32, now: Instant) -> Result<(), Status> {
        self.board.input();
        let (spec, banks, reach) = self.global_parts();
        write_global(spec, banks, reach, number, bank, v, now)
    }

    /// The parts a global parameter's write takes, borrowed apart: the model, the banks, and what the write
    /// reaches besides them ([`Reach`]).
    pub(crate) fn global_parts(&mut self) -> (&'static ModelSpec, &mut Banks, Reach<'_, Seam<B>>) {
        let Module { board, spec, st, vm, program, .. } = self;
        (spec, &mut st.banks, Reach { nvm: board, vm, program, regs: &mut st.regs })
    }

    /// GAP at `now` (`None`: whenever the board was last brought up to date). A parameter that reads
    /// something of the board that changes with the board's own clock — a switch (it may bounce), the
    /// driver's flags (standstill after 2²⁰ clocks without a step) or the status word made of them — is
    /// read with the board brought to `now` first ([`Module::sync_board`]), so that it is the value at the
    /// instant of the read however often the module was polled before.
    pub(crate) fn read_axis(&mut self, m: usize, number: u8, now: Option<Instant>) -> Result<i32, Status> {
        let (i, d) = permitted(&self.spec.axis, number, |d| d.access.read)?;
        // What the motor's own state gives ([`Axis::read_param`]); the rest reads the board or what the
        // closed loop measures.
        if let Some(v) = self.st.axes[m].read_param(self.spec, i, d.role) {
            return Ok(v);
        }
        if let Some(now) = now {
            if matches!(
                d.role,
                Role::HomeSwitch | Role::RightSwitch | Role::LeftSwitch | Role::DriverFlags | Role::StatusWord
            ) {
                self.sync_board(m, now);
            }
        }
        Ok(match d.role {
            Role::ActualPosition => self.encoder_position(m),
            Role::PositionReached => i32::from(self.target_reached(m)),
            Role::HomeSwitch => i32::from(self.switches(m).2),
            Role::RightSwitch => i32::from(self.switches(m).1),
            Role::LeftSwitch => i32::from(self.switches(m).0),
            // AP 180: the current scale 0..31 in use (current / 8, Table 22), after coolStep.
            Role::ActualCurrent => i32::from(self.current(m, self.st.now).0 >> 3),
            Role::LoadValue => i32::from(self.board.load(m).min(1023)),
            Role::DriverFlags => i32::from(self.board.driver_flags(m)),
            Role::EncoderPosition => self.encoder_position(m),
            Role::EncoderAbsolute => self.encoder_absolute(m),
            Role::VelocityReached => i32::from(self.velocity_reached(m)),
            Role::StatusWord => self.status_word(m),
            Role::ActualTorqueCurrent => self.actual_torque_current(m),
            Role::MeasuredVelocity => self.measured_velocity(m),
            // Virtual minus actual position in closed loop.
            Role::PositionError => self.st.axes[m].ramp.position.wrapping_sub(self.encoder_position(m)),
            // (None other: `Axis::read_param` reads the rest.)
            _ => self.st.axes[m].params[i],
        })
    }

    /// SAP/AAP: writes an axis parameter (RAM only).
    pub(crate) fn write_axis(&mut self, m: usize, number: u8, v: i32, now: Instant) -> Result<(), Status> {
        let (i, d) = permitted(&self.spec.axis, number, |d| d.access.write)?;
        if !d.range.contains(v) {
            return Err(ParamError::OutOfRange.into());
        }
        unlocked_for(self.st.banks.unlocked, d)?;
        // The encoder's input or scale changes (AP 201, 202, 210, 140 on a closed-loop model): the
        // position before, read through the old one.
        let rescales =
            (matches!(d.setting, Some(Setting::EncoderMode | Setting::EncoderResolution | Setting::MotorFullSteps))
                || d.role == Role::MicrostepResolution)
                && self.has_closed_loop();
        let encoder_before = if rescales { self.encoder_position(m) } else { 0 };
        // The pulse divisor (AP 154) scales the TMC428's clock: the velocity registers keep their values
        // in units, so AP 2 and AP 3 read the same and the speed in microsteps per second follows.
        let velocities = (d.setting == Some(Setting::PulseDivisor)).then(|| self.velocity_units());
        // The parameters that move the encoder's reference or reach the closed loop; the rest is what the
        // motor's own state takes ([`Axis::write_param`]).
        match d.role {
            Role::ActualPosition => {
                self.relabel(m, v.wrapping_sub(self.st.axes[m].ramp.position));
                self.st.axes[m].ramp.set_position(v)
            }
            // In closed loop the step counter moves with the encoder, so that the loop sees no error.
            Role::EncoderPosition if self.st.axes[m].cl.active => {
                let delta = v.wrapping_sub(self.encoder_position(m));
                let ramp = &mut self.st.axes[m].ramp;
                ramp.set_position(ramp.position.wrapping_add(delta));
                self.relabel(m, delta);
            }
            Role::EncoderPosition => self.set_encoder(m, v),
            Role::TargetCurrent => {
                self.set_torque(m, v)?;
                self.st.axes[m].params[i] = v;
            }
            Role::EncoderInit => self.start_encoder_init(m, v)?,
            Role::EncoderPrescaler => {
                let now_value = self.encoder_position(m);
                self.st.axes[m].params[i] = v;
                self.set_encoder(m, now_value);
            }
            _ => self.st.axes[m].write_param(self.spec, i, d.role, v),
        }
        // Settings that act when written: the driver's own (stallGuard2 filter and threshold, current
        // range), the closed loop switched on or off, the encoder's input or scale. The driver's take
        // effect at this instant: the board is brought to it first (its clock may lag the module's).
        if matches!(
            d.setting,
            Some(Setting::StallFilter | Setting::StallThreshold | Setting::CurrentRange | Setting::EncoderMode)
        ) {
            self.sync_board(m, now);
        }
        match d.setting {
            Some(Setting::StallFilter | Setting::StallThreshold | Setting::CurrentRange) => self.configure_driver(m),
            Some(Setting::ClosedLoop) => self.closed_loop_switched(m),
            _ => {}
        }
        if rescales {
            self.encoder_rescaled(m, encoder_before, d.setting == Some(Setting::EncoderMode));
        }
        if let Some(units) = velocities {
            self.set_velocity_units(units);
        }

        Ok(())
    }

    /// AP 209 = value at the reference + counts since × p / 512 (§6.2).
    pub(crate) fn encoder_position(&mut self, m: usize) -> i32 {
        let counts = self.encoder_counts_now(m);
        self.encoder_value(m, counts)
    }

    /// Sets AP 209 to `v` at the counts the encoder reads now.
    pub(crate) fn set_encoder(&mut self, m: usize, v: i32) {
        let counts = self.encoder_counts_now(m);
        self.st.axes[m].encoder = crate::module::EncoderBase { counts, value: v };
        // Clear-on-null (AP 210 + 4) looks for zero crossings from here on: not between a reading from
        // before (taken when it was last on, perhaps long ago) and the next one, which would depend on
        // when that next one is taken.
        self.st.axes[m].last_counts = counts;
    }

    /// AP 215: the absolute single-turn value 0..counts per revolution − 1 (0..1023 on the PD28-1021),
    /// independent of the prescaler (§6.2).
    pub(crate) fn encoder_absolute(&mut self, m: usize) -> i32 {
        self.encoder_counts_now(m).rem_euclid(i64::from(self.counts_per_rev())) as i32
    }

    /// GIO 11, 0: the encoder is within 1/256 of a revolution (±4 counts, ±1.4° on the PD28-1021) of its
    /// absolute zero (our tolerance; §6.2 gives none).
    pub(crate) fn encoder_near_zero(&mut self, m: usize) -> bool {
        let per_rev = self.counts_per_rev() as i32;
        let tolerance = (per_rev / 256).max(1);
        let a = self.encoder_absolute(m);
        !(tolerance..=per_rev - tolerance).contains(&a)
    }
}

/// What a write of a global parameter reaches besides the banks: the EEPROM of `nvm` (bank 0's A
/// parameters are stored at once, PD28-1021 manual §5.1) and the program machine (GP 81 erases the
/// program, §5.1; a bank 3 write restarts a timer, §5.4).
pub(crate) struct Reach<'a, N> {
    /// The EEPROM (the board, behind the seam).
    pub nvm: &'a mut N,
    /// The program machine.
    pub vm: &'a mut Vm,
    /// The program memory.
    pub program: &'a mut Program,
    /// The program's registers.
    pub regs: &'a mut Registers,
}

/// GGP (PD28-1021 manual §3.7.10, chapter 5): parameter `number` of bank `bank` at `now`, from `banks`;
/// GP 128–130 report the program machine `vm` (its state, download mode, program counter).
#[inline]
pub(crate) fn read_global(
    spec: &ModelSpec,
    banks: &mut Banks,
    vm: &Vm,
    number: u8,
    bank: u8,
    now: Instant,
) -> Result<i32, Status> {
    match Bank::of(spec, bank)? {
        Bank::Global => {
            let (i, d) = permitted(&spec.global, number, |d| d.access.read)?;
            Ok(match d.role {
                Role::ApplicationStatus => vm.state.code(),
                Role::DownloadMode => i32::from(vm.download.is_some()),
                Role::ProgramCounter => i32::from(vm.pc),
                // GP 132: "incremented every 1 ms" (§5.1).
                Role::TickTimer => banks.tick_timer(now),
                // GP 133: a new random number on every read.
                Role::RandomNumber => banks.random(),
                // The password is never read back: 1 = unlocked, 0 = locked.
                Role::Password => i32::from(banks.unlocked),
                _ => banks.global(i),
            })
        }
        Bank::User => Ok(banks.user[user_index(spec, number)?]),
        Bank::Interrupt => {
            let (i, _) = spec.interrupt.find(number)?;
            Ok(banks.interrupt[i])
        }
    }
}

/// SGP/AGP (§3.7.9, §3.7.30): parameter `number` of bank `bank` := `v` at `now`; bank 0 A parameters go
/// to the EEPROM at once, before anything changes (§5.1), and GP 81 and bank 3 reach the program machine
/// ([`Reach`]).
pub(crate) fn write_global<N: Nvm>(
    spec: &ModelSpec,
    banks: &mut Banks,
    reach: Reach<'_, N>,
    number: u8,
    bank: u8,
    v: i32,
    now: Instant,
) -> Result<(), Status> {
    match Bank::of(spec, bank)? {
        Bank::Global => {
            let (i, d) = permitted(&spec.global, number, |d| d.access.write)?;
            if !d.range.contains(v) {
                return Err(ParamError::OutOfRange.into());
            }
            unlocked_for(banks.unlocked, d)?;
            if d.access.auto {
                // Stored first: if the EEPROM refuses, nothing changes.
                persist::store_global(&mut *reach.nvm, spec, i, v)?;
            }
            if d.setting == Some(Setting::CodeProtection) {
                let Reach { nvm, vm, program, regs } = reach;
                program::protection_changed(nvm, spec, program, vm, regs, (banks.global(i), v))?;
            }
            match d.role {
                Role::TickTimer => banks.tick_base = (now, v as u32),
                Role::RandomNumber => banks.seed(v),
                // The password: the model's unlocks the protected parameters, anything else locks them.
                Role::Password => banks.unlocked = spec.password == Some(v),
                _ => {}
            }
            banks.set_global(spec, i, v);
            Ok(())
        }
        Bank::User => {
            let n = user_index(spec, number)?;
            banks.user[n] = v;
            Ok(())
        }
        Bank::Interrupt => {
            let (i, d) = spec.interrupt.find(number)?;
            if !d.range.contains(v) {
                return Err(ParamError::OutOfRange.into());
            }
            banks.interrupt[i] = v;
            program::restart_timer(spec, banks, reach.vm, number, now);
            Ok(())
        }
    }
}

/// STGP (§3.7.11): a bank 0 A parameter or a bank 2 user variable of `banks` into the EEPROM of `nvm`;
/// bank 3 is not stored.
pub(crate) fn store_global(
    nvm: &mut impl Nvm,
    spec: &ModelSpec,
    banks: &Banks,
    number: u8,
    bank: u8,
) -> Result<(), Status> {
    match Bank::of(spec, bank)? {
        Bank::Global => {
            let (i, d) = permitted(&spec.global, number, |d| d.access.auto)?;
            unlocked_for(banks.unlocked, d)?;
            persist::store_global(nvm, spec, i, banks.global(i))?;
        }
        Bank::User => {
            let v = banks.user[user_index(spec, number)?];
            persist::store_user(nvm, spec, number, v)?;
        }
        Bank::Interrupt => return Err(ParamError::NotPermitted.into()),
    }
    Ok(())
}

/// RSGP (§3.7.12): a bank 0 A parameter (its default if the stored value is out of range) or a bank 2 user
/// variable back from the EEPROM of `nvm` into `banks`.
pub(crate) fn restore_global(
    nvm: &mut impl Nvm,
    spec: &ModelSpec,
    banks: &mut Banks,
    number: u8,
    bank: u8,
) -> Result<(), Status> {
    match Bank::of(spec, bank)? {
        Bank::Global => {
            let (i, d) = permitted(&spec.global, number, |d| d.access.auto)?;
            let v = persist::load_global(nvm, spec, i)?;
            banks.set_global(spec, i, if d.range.contains(v) { v } else { d.default });
        }
        Bank::User => {
            let n = user_index(spec, number)?;
            banks.user[n] = persist::load_user(nvm, spec, number)?;
        }
        Bank::Interrupt => return Err(ParamError::NotPermitted.into()),
    }
    Ok(())
}

/// SCO/CCO/ACO (PD28-1021 manual §3.7.24, §3.7.26, §3.7.27): motor `m`'s coordinate `coord` := `v` in
/// `axis`; with GP 84 = 1 (in `banks`) coordinates 1.. go to the EEPROM of `nvm` too, first (§3.7.24).
pub(crate) fn write_coordinate(
    nvm: &mut impl Nvm,
    spec: &ModelSpec,
    banks: &Banks,
    axis: &mut Axis,
    m: usize,
    coord: u8,
    v: i32,
) -> Result<(), Status> {
    let n = coord_index(spec, coord)?;
    if n > 0 && banks.flag(spec, Setting::CoordinateStorage) {
        persist::store_coordinate(nvm, spec, m, coord, v)?;
    }
    axis.coords[n] = v;
    Ok(())
}

/// SCO/GCO `coord`, 255 (§3.7.24, §3.7.25): coordinate 0 = all of 1..the model's last, n = that one, of
/// every motor in `axes` (§3.7.24 gives it for the one motor of the PD28-1021), into the EEPROM of `nvm`
/// (`to_eeprom`) or back from it.
pub(crate) fn copy_coordinates(
    nvm: &mut impl Nvm,
    spec: &ModelSpec,
    axes: &mut Axes,
    coord: u8,
    to_eeprom: bool,
) -> Result<(), Status> {
    let n = coord_index(spec, coord)? as u8;
    let range = if n == 0 { 1..=spec.coordinates } else { n..=n };
    for m in 0..axes.count() {
        for c in range.clone() {
            if to_eeprom {
                let v = axes[m].coords[usize::from(c)];
                persist::store_coordinate(nvm, spec, m, c, v)?;
            } else {
                axes[m].coords[usize::from(c)] = persist::load_coordinate(nvm, spec, m, c)?;
            }
        }
    }
    Ok(())
}

/// A bank 2 user variable's index (PD28-1021 manual §5.3): 0..`spec`'s user variables (else 3, wrong
/// type).
#[inline]
pub(crate) fn user_index(spec: &ModelSpec, number: u8) -> Result<usize, Status> {
    let n = usize::from(number);
    if n < usize::from(spec.user_variables) {
        Ok(n)
    } else {
        Err(ParamError::Unknown.into())
    }
}

/// A coordinate's index (§3.7.24–3.7.27): 0..`spec`'s coordinates (else 3, wrong type).
#[inline]
pub(crate) fn coord_index(spec: &ModelSpec, coord: u8) -> Result<usize, Status> {
    if coord <= spec.coordinates {
        Ok(usize::from(coord))
    } else {
        Err(Status::WrongType)
    }
}

/// Refuses a write or store of a password-protected parameter while the module is locked (`unlocked`
/// false): status 8 (TMCM-1310 manual §3.7).
#[inline]
pub(crate) fn unlocked_for(unlocked: bool, d: &ParamDesc) -> Result<(), Status> {
    if d.access.protected && !unlocked {
        Err(ParamError::Protected.into())
    } else {
        Ok(())
    }
}

/// A parameter of `table` that allows what `allowed` asks (read, write, store, ...): unknown → 3, not
/// permitted → 3 (see [`ParamError`]).
pub(crate) fn permitted(
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

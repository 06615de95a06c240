//! Parameters on the module: axis parameters (chapter 4), the global banks (chapter 5: bank 0
//! settings, bank 2 user variables, bank 3 interrupt configuration), coordinates (§3.7.24–3.7.27), and
//! their EEPROM copies ([`crate::param::persist`]). Statuses as the dispatcher's docs (`module/exec.rs`)
//! decide them.

use super::{program, Axis, Module};
use crate::axis::Axes;
use crate::hal::{Board, Nvm};
use crate::model::{ModelSpec, Setting};
use crate::param::banks::Banks;
use crate::param::{permitted, persist, unlocked_for, ParamError, Role};
use crate::seam::Seam;
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
    /// (`seam.rs`).
    pub fn get_axis(&mut self, number: u8) -> Result<i32, Status> {
        self.get_axis_of(0, number)
    }

    /// GAP of motor `motor` (status 4 for a motor the model lacks), as [`Module::get_axis`].
    pub fn get_axis_of(&mut self, motor: u8, number: u8) -> Result<i32, Status> {
        self.board.input();
        let m = self.motor(motor)?;
        self.read_axis(m, number, None)
    }

    /// Brings every motor's board to `now` as a read of its switches or flags does (an update with what
    /// the board was last told, if it has not heard from the module since): for a caller that looks at
    /// the boards themselves (a simulator's view of its rotors), where the module may have brought one
    /// there already (a look for its deadline) and another not yet (its next tick will).
    pub fn sync_boards(&mut self, now: Instant) {
        for m in 0..self.st.axes.count() {
            self.motor_at(m).sync_board(now);
        }
    }

    /// SAP of motor 0 without the frame: writes an axis parameter (RAM only) at `now`, as a library call
    /// from outside (an input, `seam.rs`).
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
    /// input, `seam.rs`).
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

    /// GAP of motor `m` at `at` (`None`: whenever the board was last brought up to date;
    /// [`crate::axis::Motor::read`]).
    #[inline]
    pub(crate) fn read_axis(&mut self, m: usize, number: u8, at: Option<Instant>) -> Result<i32, Status> {
        let now = self.st.now;
        self.motor_at(m).read(number, at, now)
    }

    /// SAP/AAP of motor `m` (RAM only; [`crate::axis::Motor::write`]).
    #[inline]
    pub(crate) fn write_axis(&mut self, m: usize, number: u8, v: i32, now: Instant) -> Result<(), Status> {
        let faults = self.motor_at(m).write(number, v, now)?;
        self.apply(m, faults);
        Ok(())
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

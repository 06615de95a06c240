//! Parameter descriptors: each model's axis and global parameters as static tables (STYLE.md §3.9).
//!
//! A [`ParamDesc`] says everything the firmware needs to know about one parameter: its number, name,
//! range, access letters (PD28-1021 manual Table 14 and Table 16: R, W, E, A), factory default, the
//! manual section that defines it, and its [`Role`] — whether it is a plain stored value or one the
//! firmware computes or acts on. The executor checks ranges and access from the table and dispatches on
//! the role, so a new model is a new table, not new branches.

pub mod persist;

use tmcl_wire::Status;

/// Access letters (manual Table 14 for axis parameters, Table 16 for global parameters).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Access {
    /// R: readable with GAP/GGP.
    pub read: bool,
    /// W: writable with SAP/SGP (and AAP/AGP).
    pub write: bool,
    /// E: can be stored to and restored from EEPROM with STAP/RSAP or STGP/RSGP.
    pub store: bool,
    /// A: stored to EEPROM automatically on every write (bank 0 parameters 64..128).
    pub auto: bool,
}

impl Access {
    /// Read only.
    pub const R: Access = Access { read: true, write: false, store: false, auto: false };
    /// Read and write, volatile.
    pub const RW: Access = Access { read: true, write: true, store: false, auto: false };
    /// Read, write, store and restore.
    pub const RWE: Access = Access { read: true, write: true, store: true, auto: false };
    /// Read, write, automatically stored.
    pub const RWA: Access = Access { read: true, write: true, store: false, auto: true };

    /// Whether the value lives in the EEPROM image (E or A).
    pub const fn persistent(self) -> bool {
        self.store || self.auto
    }
}

/// The value range of a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Range {
    /// `min..=max` as signed 32-bit values.
    Signed(i32, i32),
    /// Any 32-bit pattern, read as unsigned (bank 3 timer periods, 0..4294967295 ms).
    Unsigned32,
    /// A set of allowed values that is not one interval (reference search modes).
    OneOf(&'static [core::ops::RangeInclusive<i32>]),
}

impl Range {
    /// The full signed range.
    pub const ANY: Range = Range::Signed(i32::MIN, i32::MAX);
    /// 0 or 1.
    pub const FLAG: Range = Range::Signed(0, 1);

    /// Whether `value` is allowed.
    pub fn contains(&self, value: i32) -> bool {
        match self {
            Range::Signed(min, max) => (*min..=*max).contains(&value),
            Range::Unsigned32 => true,
            Range::OneOf(set) => set.iter().any(|r| r.contains(&value)),
        }
    }
}

/// What a parameter is to the firmware beyond its stored value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A setting: the value is stored as written and read back as stored.
    Plain,
    /// AP 0: writing starts a move in position mode.
    TargetPosition,
    /// AP 1: the step counter; writing sets it without moving.
    ActualPosition,
    /// AP 2: target velocity in velocity mode.
    TargetSpeed,
    /// AP 3: the ramp generator's present velocity.
    ActualSpeed,
    /// AP 8: 1 when target and actual position are equal.
    PositionReached,
    /// AP 9: home switch, logical state.
    HomeSwitch,
    /// AP 10: right limit switch, logical state.
    RightSwitch,
    /// AP 11: left limit switch, logical state.
    LeftSwitch,
    /// AP 128: 0 position mode, 1 velocity mode.
    RampMode,
    /// AP 140: microstep resolution.
    MicrostepResolution,
    /// AP 180: actual current scale 0..31.
    ActualCurrent,
    /// AP 206: stallGuard2 load value.
    LoadValue,
    /// AP 207: extended error flags, cleared when read.
    ErrorFlags,
    /// AP 208: driver error flags.
    DriverFlags,
    /// AP 209: encoder position.
    EncoderPosition,
    /// AP 210: encoder prescaler and special functions.
    EncoderPrescaler,
    /// AP 215: absolute encoder value 0..1023.
    EncoderAbsolute,
    /// GP 128: TMCL application status.
    ApplicationStatus,
    /// GP 129: download mode.
    DownloadMode,
    /// GP 130: TMCL program counter.
    ProgramCounter,
    /// GP 132: millisecond tick timer.
    TickTimer,
    /// GP 133: random number.
    RandomNumber,
}

/// One parameter of a model's table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamDesc {
    /// Parameter number (the type byte of SAP/GAP/SGP/GGP).
    pub number: u8,
    /// The manual's name.
    pub name: &'static str,
    /// A symbolic identifier for assembler include files (e.g. `MaxPositioningSpeed`).
    pub ident: &'static str,
    /// Allowed values.
    pub range: Range,
    /// Access letters.
    pub access: Access,
    /// Factory default.
    pub default: i32,
    /// Where the manual defines it, e.g. "§4 Table 15".
    pub section: &'static str,
    /// What the firmware does with it.
    pub role: Role,
}

impl ParamDesc {
    /// A plain parameter.
    pub const fn plain(
        number: u8,
        name: &'static str,
        ident: &'static str,
        range: Range,
        access: Access,
        default: i32,
        section: &'static str,
    ) -> ParamDesc {
        ParamDesc { number, name, ident, range, access, default, section, role: Role::Plain }
    }

    /// The same descriptor with a role.
    pub const fn with_role(self, role: Role) -> ParamDesc {
        ParamDesc { role, ..self }
    }
}

/// Why a parameter operation was refused; each maps to a TMCL status (STYLE.md §3.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamError {
    /// No parameter with that number in this bank (status 3, wrong type: the type byte names it).
    Unknown,
    /// The parameter cannot be read, written or stored that way (status 3: the type byte names a parameter
    /// that does not support the operation; decision for manual §4 Table 14, which gives no status).
    NotPermitted,
    /// The value is outside the range (status 4, invalid value).
    OutOfRange,
    /// No such motor or bank (status 4, invalid value: the motor/bank byte is a value of the command).
    NoSuchMotor,
    /// The EEPROM could not be written or read (status 5, configuration EEPROM locked).
    Storage,
}

impl From<ParamError> for Status {
    fn from(e: ParamError) -> Status {
        match e {
            ParamError::Unknown | ParamError::NotPermitted => Status::WrongType,
            ParamError::OutOfRange | ParamError::NoSuchMotor => Status::InvalidValue,
            ParamError::Storage => Status::EepromLocked,
        }
    }
}

/// A parameter table with a number → index map built at compile time, so lookups are O(1).
#[derive(Debug)]
pub struct Table {
    /// The descriptors, in number order.
    pub params: &'static [ParamDesc],
    index: [u8; 256],
}

/// Marks an absent number in [`Table`]'s index.
const ABSENT: u8 = 0xFF;

impl Table {
    /// Builds the table (in a `static`); panics at compile time if it has more than 255 entries or a
    /// number twice.
    pub const fn new(params: &'static [ParamDesc]) -> Table {
        assert!(params.len() < ABSENT as usize);
        let mut index = [ABSENT; 256];
        let mut i = 0;
        while i < params.len() {
            let n = params[i].number as usize;
            assert!(index[n] == ABSENT, "parameter number used twice");
            index[n] = i as u8;
            i += 1;
        }
        Table { params, index }
    }

    /// Finds a parameter: its index in the table and its descriptor.
    #[inline]
    pub fn find(&self, number: u8) -> Result<(usize, &'static ParamDesc), ParamError> {
        match self.index[usize::from(number)] {
            ABSENT => Err(ParamError::Unknown),
            i => Ok((usize::from(i), &self.params[usize::from(i)])),
        }
    }

    /// The index of a parameter the firmware knows exists (for its own lookups).
    #[inline]
    pub fn index(&self, number: u8) -> Option<usize> {
        self.find(number).ok().map(|(i, _)| i)
    }
}

/// Finds a parameter in a plain table by scanning (for tools; the firmware uses [`Table::find`]).
pub fn find(table: &'static [ParamDesc], number: u8) -> Result<(usize, &'static ParamDesc), ParamError> {
    table.iter().enumerate().find(|(_, d)| d.number == number).ok_or(ParamError::Unknown)
}

/// The position of a persistent parameter among the persistent ones of its table: its EEPROM slot.
pub fn slot(table: &'static [ParamDesc], index: usize) -> Option<usize> {
    if !table.get(index)?.access.persistent() {
        return None;
    }
    Some(table[..index].iter().filter(|d| d.access.persistent()).count())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges() {
        assert!(Range::FLAG.contains(1) && !Range::FLAG.contains(2));
        assert!(Range::Unsigned32.contains(-1));
        let modes = Range::OneOf(&[1..=8, 65..=68]);
        assert!(modes.contains(66) && !modes.contains(9) && !modes.contains(0));
    }

    #[test]
    fn statuses() {
        assert_eq!(Status::from(ParamError::OutOfRange), Status::InvalidValue);
        assert_eq!(Status::from(ParamError::Unknown), Status::WrongType);
        assert_eq!(Status::from(ParamError::Storage), Status::EepromLocked);
    }
}

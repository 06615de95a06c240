//! Parameter descriptors: each model's axis and global parameters as static tables.
//!
//! A [`ParamDesc`] says everything the firmware needs to know about one parameter: its number, name,
//! range, access letters (PD28-1021 manual Table 14 and Table 16: R, W, E, A; the TMCM-1310's password
//! protection, its manual §3.7 status 8), factory default, the manual section that defines it, and two
//! keys by meaning instead of number:
//!
//! - its [`Role`]: what a GAP or SAP of it does — a plain stored value, or one the firmware computes or
//!   acts on (the step counter, a switch, the load value, ...);
//! - its [`Setting`], if the firmware's behaviour reads (or writes) the stored value: the maximum speed,
//!   the standby delay, the serial address, ...
//!
//! The firmware never names a parameter by its number: it asks a [`Table`] for a role or a setting, and
//! a model that lacks it lacks the feature (the core documents what "absent" means for each one). A new
//! model is a new table, not new branches.

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
    /// Password protected: refused with status 8 while the module is locked (TMCM-1310 manual §3.7).
    pub protected: bool,
}

impl Access {
    /// Read only.
    pub const R: Access = Access { read: true, write: false, store: false, auto: false, protected: false };
    /// Write only (a trigger: TMCM-1311 AP 29 "clear I²t exceeded flag").
    pub const W: Access = Access { read: false, write: true, store: false, auto: false, protected: false };
    /// Read and write, volatile.
    pub const RW: Access = Access { read: true, write: true, store: false, auto: false, protected: false };
    /// Read, write, store and restore.
    pub const RWE: Access = Access { read: true, write: true, store: true, auto: false, protected: false };
    /// Read, write, automatically stored.
    pub const RWA: Access = Access { read: true, write: true, store: false, auto: true, protected: false };

    /// The same access, password protected: writes and stores are refused with status 8 while the
    /// module is locked.
    pub const fn protected(self) -> Access {
        Access { protected: true, ..self }
    }

    /// Whether the value lives in the EEPROM image (E or A).
    pub const fn persistent(self) -> bool {
        self.store || self.auto
    }
}

/// The access letters of the manuals' tables, R, W, E, A, and P for password protected (`RWE`).
impl core::fmt::Display for Access {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        use core::fmt::Write;
        for (on, letter) in
            [(self.read, 'R'), (self.write, 'W'), (self.store, 'E'), (self.auto, 'A'), (self.protected, 'P')]
        {
            if on {
                f.write_char(letter)?;
            }
        }
        Ok(())
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

/// The range as the host tools print it: `1..2147483647`, `1..8, 65..68, 129`.
impl core::fmt::Display for Range {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Range::Signed(min, max) if min == max => write!(f, "{min}"),
            Range::Signed(min, max) => write!(f, "{min}..{max}"),
            Range::Unsigned32 => write!(f, "0..{}", u32::MAX),
            Range::OneOf(set) => {
                for (n, r) in set.iter().enumerate() {
                    let sep = if n == 0 { "" } else { ", " };
                    if r.start() == r.end() {
                        write!(f, "{sep}{}", r.start())?;
                    } else {
                        write!(f, "{sep}{}..{}", r.start(), r.end())?;
                    }
                }
                Ok(())
            }
        }
    }
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

/// What a GAP or SAP of a parameter does: store and return a value ([`Role::Plain`]), or read or act on
/// the firmware's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
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
    /// The password of the protected parameters (a bank 0 parameter): writing the model's password
    /// ([`crate::ModelDesc::password`]) unlocks them until the next start, writing anything else locks them;
    /// it reads 1 while unlocked, 0 while locked, never the password.
    Password,
    // ---- closed loop (TMCM-1310; the TMCM-1311 sibling's numbers) ------------------------------------
    /// AP 14: torque-mode target current in mA, signed; writing it enters torque mode.
    TargetCurrent,
    /// AP 16: 1 while the measured velocity is within the window of the target velocity.
    VelocityReached,
    /// AP 18: the status word (target reached, velocity reached, closed loop, modes, switches, supply,
    /// temperature, position hold, I²t).
    StatusWord,
    /// AP 19: the coil current the closed loop drives, signed mA.
    ActualTorqueCurrent,
    /// AP 27: the I²t sum.
    I2tSum,
    /// AP 28: how often the I²t limit was exceeded (writable, to reset it).
    I2tExceedCount,
    /// AP 29: clears the I²t exceeded flag (write only, the value is ignored).
    ClearI2t,
    /// AP 123: the closed loop's current scale factor 0..255.
    CurrentScale,
    /// AP 131: velocity measured from the encoder, pps.
    MeasuredVelocity,
    /// AP 132: encoder initialisation: write 1 to start; reads 0 not done, 1 running, 2 done, 3 failed.
    EncoderInit,
    /// AP 133: 1 while the loop is closed.
    ClosedLoopActive,
    /// AP 230: the commutation angle: how far the field leads the rotor, 256 = one full step (90°).
    Gamma,
    /// AP 233: the ramp generator's position (the set point the closed loop follows).
    VirtualPosition,
    /// AP 237: virtual minus actual position, microsteps.
    PositionError,
    // ---- the TMC428 generation (PDx-113) -------------------------------------------------------------
    /// AP 138: the TMC428's ramp mode (TMC428 datasheet, ref_conf/ramp mode register): 0 position
    /// (ramp), 1 soft (position mode with a soft approach), 2 velocity. ROR/ROL/MST set 2, MVP sets 0.
    RampModeTmc428,
}

impl Role {
    /// Number of roles (the size of [`Table`]'s role index).
    pub const COUNT: usize = Role::RampModeTmc428 as usize + 1;
}

macro_rules! settings {
    ($( $(#[$doc:meta])* $variant:ident, )*) => {
        /// A stored value the firmware's behaviour reads (or a result it writes), by meaning. The comments
        /// name the PD28-1021 parameter as an example; each model's table says which of its parameters, if
        /// any, has the setting (manual chapter 4 Table 15 and chapter 5 Table 17 for the PD28-1021).
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        #[repr(u8)]
        pub enum Setting {
            $( $(#[$doc])* $variant, )*
        }

        impl Setting {
            /// Every setting, in declaration order.
            pub const ALL: &'static [Setting] = &[$( Setting::$variant, )*];
            /// Number of settings (the size of [`Table`]'s setting index).
            pub const COUNT: usize = Setting::ALL.len();
        }
    };
}

settings! {
    // ---- axis parameters -------------------------------------------------------------------------
    /// AP 4: maximum positioning speed (the model's velocity unit).
    MaxPositioningSpeed,
    /// AP 5: maximum acceleration (the model's acceleration unit).
    MaxAcceleration,
    /// AP 6: run current 0..255.
    RunCurrent,
    /// AP 7: standby current 0..255.
    StandbyCurrent,
    /// AP 12: right limit switch disable.
    RightSwitchDisable,
    /// AP 13: left limit switch disable.
    LeftSwitchDisable,
    /// AP 130: start and stop speed.
    MinimumSpeed,
    /// PDx-113 AP 153: the TMC428 ramp divisor.
    RampDivisor,
    /// PDx-113 AP 154: the TMC428 pulse divisor.
    PulseDivisor,
    /// AP 167: chopper off time; 0 switches the driver stages off.
    ChopperOffTime,
    /// AP 168: coolStep minimum current (SEIMIN).
    CoolStepMinimum,
    /// AP 169: coolStep current down step (SEDN).
    CoolStepDownStep,
    /// AP 170: coolStep hysteresis (SEMAX).
    CoolStepHysteresis,
    /// AP 171: coolStep current up step (SEUP).
    CoolStepUpStep,
    /// AP 172: coolStep hysteresis start (SEMIN); 0 switches coolStep off.
    CoolStepHysteresisStart,
    /// AP 173: stallGuard2 filter.
    StallFilter,
    /// AP 174: stallGuard2 threshold.
    StallThreshold,
    /// AP 179: sense resistor voltage range (1 = low, the default).
    CurrentRange,
    /// AP 181: stop on stall above this speed; 0 = off.
    StopOnStall,
    /// AP 182: coolStep threshold speed.
    CoolStepThresholdSpeed,
    /// AP 183: coolStep slow-run current.
    SlowRunCurrent,
    /// AP 193: reference search mode.
    ReferenceSearchMode,
    /// AP 194: reference search speed.
    ReferenceSearchSpeed,
    /// AP 195: reference switch speed.
    ReferenceSwitchSpeed,
    /// AP 196: end switch distance (written by the search).
    EndSwitchDistance,
    /// AP 197: last reference position (written by the search).
    LastReferencePosition,
    /// AP 200: boost current while accelerating.
    BoostCurrent,
    /// AP 204: freewheeling delay (10 ms units).
    FreewheelingDelay,
    /// AP 212: maximum encoder deviation; 0 = off.
    MaxEncoderDeviation,
    /// AP 214: power down delay (10 ms units).
    PowerDownDelay,
    // ---- closed loop (TMCM-1310 with the TMCM-1311 sibling's numbers) -----------------------------
    /// AP 17: velocity reached window (pps).
    VelocityWindow,
    /// AP 20: torque-mode current slope (mA/s); 0 = at once.
    TorqueSlope,
    /// AP 25: I²t thermal winding time constant (ms).
    I2tTimeConstant,
    /// AP 26: I²t limit (A²·ms); 0 = off.
    I2tLimit,
    /// AP 111: the largest commutation angle (0..255, 256 = 90°).
    CommutationLimit,
    /// AP 112: encoder offset: encoder counts at electrical angle 0, written by the initialisation.
    EncoderOffset,
    /// AP 113: lowest current scale.
    CurrentScaleMin,
    /// AP 114: highest current scale.
    CurrentScaleMax,
    /// AP 115: what the current scaling regulates on: 0 the commutation angle, 1 the position error.
    CurrentScaleInput,
    /// AP 116: below this error the scale steps down.
    CurrentScaleLower,
    /// AP 117: above this error the scale steps up.
    CurrentScaleUpper,
    /// AP 118: scale step up.
    CurrentScaleIncrement,
    /// AP 119: scale step down.
    CurrentScaleDecrement,
    /// AP 120: time above the upper limit before each step up (ms).
    CurrentScaleUpTime,
    /// AP 121: time below the lower limit before each step down (ms).
    CurrentScaleDownTime,
    /// AP 122: current scaling on.
    CurrentScaleEnable,
    /// AP 124: correction gain (1/s): catch-up velocity per microstep of position error.
    CorrectionGain,
    /// AP 125: maximum following error (microsteps); 0 = off.
    MaxFollowingError,
    /// AP 126: maximum correction velocity (pps).
    MaxCorrectionVelocity,
    /// AP 127: what MVP REL counts from: 0 the last target, 1 the ramp position, 2 the encoder.
    RelativePositioning,
    /// AP 129: closed loop on.
    ClosedLoop,
    /// AP 134: position reached window (microsteps).
    PositionWindow,
    /// AP 136: standstill correction gain (the hold integrator's rate, 1/1024 per ms).
    HoldGain,
    /// AP 138: standstill correction limit (microsteps).
    HoldLimit,
    /// AP 201: encoder mode (bit 0 SSI instead of A/B/N; bits 2–4 the N channel).
    EncoderMode,
    /// AP 202: motor full steps per revolution.
    MotorFullSteps,
    /// AP 210 on a closed-loop module: encoder counts per revolution.
    EncoderResolution,
    // ---- global parameters, bank 0 ---------------------------------------------------------------
    /// GP 65: baud rate index.
    BaudRate,
    /// GP 66: serial address.
    SerialAddress,
    /// GP 67: ASCII mode (bit 0 start in ASCII, bits 4/5 echo).
    AsciiMode,
    /// GP 68: serial heartbeat (ms); 0 = off.
    SerialHeartbeat,
    /// GP 75: telegram pause time (ms).
    TelegramPause,
    /// GP 76: serial host address.
    HostAddress,
    /// GP 77: auto start mode.
    AutoStart,
    /// GP 79: end switch polarity.
    EndSwitchPolarity,
    /// GP 81: TMCL code protection.
    CodeProtection,
    /// GP 84: coordinate storage.
    CoordinateStorage,
    /// GP 85: do not restore user variables.
    DoNotRestoreUserVariables,
    /// GP 87: serial secondary address; 0 = none.
    SecondaryAddress,
    /// GP 90: reverse shaft.
    ReverseShaft,
    /// GP 255: suppress reply.
    SuppressReply,
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
    /// Which setting the firmware reads it as, if any.
    pub setting: Option<Setting>,
    /// The unit of the value, from the manual's "Range \[Units\]" column (for host tools: `tmcl params`).
    pub unit: Unit,
}

/// The unit of a parameter's value, as the manuals' parameter tables give it ("Range \[Units\]").
///
/// Data for host tools (`tmcl params`, the workbench); the firmware never reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// A number without unit: a flag, a mode, a count, a bit field.
    None,
    /// Microsteps (positions).
    Microsteps,
    /// Microsteps per second (pps, PD28-1021 manual §4 Table 15).
    Pps,
    /// Microsteps per second² (pps², Table 15).
    PpsPerSecond,
    /// A current as a fraction of the module's maximum, 0..255 = 0..100 % (Table 15, AP 6).
    CurrentOf255,
    /// A current scale in 32 steps, 0..31 = 1/32..32/32 (Table 15, AP 180).
    CurrentOf32,
    /// Milliamperes.
    Milliamps,
    /// Milliseconds.
    Milliseconds,
    /// Units of 10 ms (Table 15, AP 204 and 214).
    TenMilliseconds,
    /// Encoder counts.
    EncoderCounts,
    /// Full steps.
    FullSteps,
    /// Units of 0.1 V (supply voltage).
    TenthVolts,
    /// Degrees Celsius.
    Celsius,
    /// A TMC428 velocity 0..2047: `16 MHz · v / (2^pulse_div · 2048 · 32)` microsteps per second
    /// (PDx-113 manual §5.7.1: "0…2047", the TMC428 datasheet's velocity formula).
    Tmc428Velocity,
    /// A TMC428 acceleration 0..2047: `16 MHz² · a / 2^(pulse_div + ramp_div + 29)` microsteps per second²
    /// (the TMC428 datasheet's acceleration formula).
    Tmc428Acceleration,
}

impl Unit {
    /// The unit as printed after a value; empty for [`Unit::None`].
    pub const fn symbol(self) -> &'static str {
        match self {
            Unit::None => "",
            Unit::Microsteps => "µsteps",
            Unit::Pps => "pps",
            Unit::PpsPerSecond => "pps/s",
            Unit::CurrentOf255 => "/255 of max. current",
            Unit::CurrentOf32 => "/32 of max. current (value + 1)",
            Unit::Milliamps => "mA",
            Unit::Milliseconds => "ms",
            Unit::TenMilliseconds => "× 10 ms",
            Unit::EncoderCounts => "encoder counts",
            Unit::FullSteps => "full steps",
            Unit::TenthVolts => "× 0.1 V",
            Unit::Celsius => "°C",
            Unit::Tmc428Velocity => "TMC428 v units",
            Unit::Tmc428Acceleration => "TMC428 a units",
        }
    }
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
        ParamDesc {
            number,
            name,
            ident,
            range,
            access,
            default,
            section,
            role: Role::Plain,
            setting: None,
            unit: Unit::None,
        }
    }

    /// The same descriptor with a role.
    pub const fn with_role(self, role: Role) -> ParamDesc {
        ParamDesc { role, ..self }
    }

    /// The same descriptor, read by the firmware as `setting`.
    pub const fn with_setting(self, setting: Setting) -> ParamDesc {
        ParamDesc { setting: Some(setting), ..self }
    }

    /// The same descriptor with the unit of its value.
    pub const fn with_unit(self, unit: Unit) -> ParamDesc {
        ParamDesc { unit, ..self }
    }
}

/// Why a parameter operation was refused; each maps to a TMCL status.
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
    /// The parameter is password protected and the module is locked (status 8, TMCM-1310 manual §3.7).
    Protected,
}

impl From<ParamError> for Status {
    fn from(e: ParamError) -> Status {
        match e {
            ParamError::Unknown | ParamError::NotPermitted => Status::WrongType,
            ParamError::OutOfRange | ParamError::NoSuchMotor => Status::InvalidValue,
            ParamError::Storage => Status::EepromLocked,
            ParamError::Protected => Status::PasswordProtected,
        }
    }
}

/// A parameter table with number → index, role → index and setting → index maps built at compile time,
/// so every lookup is one array access.
#[derive(Debug)]
pub struct Table {
    /// The descriptors, in number order.
    pub params: &'static [ParamDesc],
    index: [u8; 256],
    roles: [u8; Role::COUNT],
    settings: [u8; Setting::COUNT],
}

/// Marks an absent entry in [`Table`]'s maps.
const ABSENT: u8 = 0xFF;

impl Table {
    /// Builds the table (in a `static`); fails to compile if it has more than 254 entries, a number twice,
    /// numbers out of order, a role other than [`Role::Plain`] twice or a setting twice.
    pub const fn new(params: &'static [ParamDesc]) -> Table {
        assert!(params.len() < ABSENT as usize, "a parameter table holds at most 254 entries");
        let mut index = [ABSENT; 256];
        let mut roles = [ABSENT; Role::COUNT];
        let mut settings = [ABSENT; Setting::COUNT];
        let mut i = 0;
        while i < params.len() {
            let d = &params[i];
            let n = d.number as usize;
            assert!(index[n] == ABSENT, "parameter number used twice");
            assert!(i == 0 || params[i - 1].number < d.number, "parameters must be in number order");
            index[n] = i as u8;
            if !matches!(d.role, Role::Plain) {
                assert!(roles[d.role as usize] == ABSENT, "a role given to two parameters");
                roles[d.role as usize] = i as u8;
            }
            if let Some(s) = d.setting {
                assert!(settings[s as usize] == ABSENT, "a setting given to two parameters");
                settings[s as usize] = i as u8;
            }
            i += 1;
        }
        Table { params, index, roles, settings }
    }

    /// A table without parameters.
    pub const EMPTY: Table = Table::new(&[]);

    /// Finds a parameter: its index in the table and its descriptor.
    #[inline]
    pub fn find(&self, number: u8) -> Result<(usize, &'static ParamDesc), ParamError> {
        match self.index[usize::from(number)] {
            ABSENT => Err(ParamError::Unknown),
            i => Ok((usize::from(i), &self.params[usize::from(i)])),
        }
    }

    /// The index of a parameter by number.
    #[inline]
    pub fn index(&self, number: u8) -> Option<usize> {
        self.find(number).ok().map(|(i, _)| i)
    }

    /// The index of the parameter with `setting`, if the model has it.
    #[inline]
    pub const fn setting(&self, setting: Setting) -> Option<usize> {
        match self.settings[setting as usize] {
            ABSENT => None,
            i => Some(i as usize),
        }
    }

    /// The index of the parameter with `role` (not [`Role::Plain`]), if the model has it.
    #[inline]
    pub const fn role(&self, role: Role) -> Option<usize> {
        match self.roles[role as usize] {
            ABSENT => None,
            i => Some(i as usize),
        }
    }

    /// Whether the table has parameter `number`.
    pub const fn contains(&self, number: u8) -> bool {
        self.index[number as usize] != ABSENT
    }

    /// Whether the model has a parameter with `setting`.
    pub const fn has(&self, setting: Setting) -> bool {
        self.setting(setting).is_some()
    }

    /// Number of persistent (E or A) parameters: the table's EEPROM slots.
    pub const fn persistent(&self) -> usize {
        let mut n = 0;
        let mut i = 0;
        while i < self.params.len() {
            if self.params[i].access.persistent() {
                n += 1;
            }
            i += 1;
        }
        n
    }
}

/// Joins parameter lists into one array of `N` entries (in a `static`; fails to compile unless the parts
/// hold exactly `N`). Models share descriptors this way: the TMCM-1310 takes the TMC262 driver settings of
/// the PD28-1021's table, re-cited with [`cited`].
pub const fn join<const N: usize>(parts: &[&[ParamDesc]]) -> [ParamDesc; N] {
    let mut out = [ParamDesc::plain(0, "", "", Range::ANY, Access::R, 0, ""); N];
    let mut n = 0;
    let mut p = 0;
    while p < parts.len() {
        let mut i = 0;
        while i < parts[p].len() {
            assert!(n < N, "more parameters than the array holds");
            out[n] = parts[p][i];
            n += 1;
            i += 1;
        }
        p += 1;
    }
    assert!(n == N, "fewer parameters than the array holds");
    out
}

/// The entries of `table` numbered `first..=last`, with `section` as their source (the same parameters
/// documented elsewhere for another model).
pub const fn cited<const N: usize>(table: &[ParamDesc], first: u8, last: u8, section: &'static str) -> [ParamDesc; N] {
    let mut out = [ParamDesc::plain(0, "", "", Range::ANY, Access::R, 0, ""); N];
    let mut n = 0;
    let mut i = 0;
    while i < table.len() {
        if table[i].number >= first && table[i].number <= last {
            assert!(n < N, "more parameters in the range than the array holds");
            out[n] = ParamDesc { section, ..table[i] };
            n += 1;
        }
        i += 1;
    }
    assert!(n == N, "fewer parameters in the range than the array holds");
    out
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
        assert_eq!(Status::from(ParamError::Protected), Status::PasswordProtected);
    }

    static PARAMS: [ParamDesc; 3] = [
        ParamDesc::plain(0, "a", "A", Range::ANY, Access::RW, 0, "").with_role(Role::TargetPosition),
        ParamDesc::plain(4, "b", "B", Range::ANY, Access::RWE, 0, "").with_setting(Setting::MaxPositioningSpeed),
        ParamDesc::plain(9, "c", "C", Range::ANY, Access::RWE.protected(), 0, ""),
    ];
    static TABLE: Table = Table::new(&PARAMS);

    #[test]
    fn lookups_by_number_role_and_setting() {
        assert_eq!(TABLE.index(4), Some(1));
        assert_eq!(TABLE.find(5), Err(ParamError::Unknown));
        assert_eq!(TABLE.role(Role::TargetPosition), Some(0));
        assert_eq!(TABLE.role(Role::ActualPosition), None);
        assert_eq!(TABLE.setting(Setting::MaxPositioningSpeed), Some(1));
        assert_eq!(TABLE.setting(Setting::RunCurrent), None);
        assert_eq!(TABLE.persistent(), 2);
        assert!(PARAMS[2].access.protected && !PARAMS[1].access.protected);
    }
}

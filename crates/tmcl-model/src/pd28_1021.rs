//! The PD28-1021 (and the TMCM-1021 board inside it): PD28-1021 TMCL firmware manual V1.05, firmware V1.42.
//!
//! Axis parameters: manual chapter 4, Table 15 ("All Axis Parameters of the PD28-1021 Module").
//! Global parameters: chapter 5, Table 17 (bank 0), §5.2 (bank 1, not available), §5.3 Table 18 (bank 2,
//! user variables), §5.4 Table 19 (bank 3, interrupt configuration).
//!
//! # Defaults
//!
//! The manual states few factory defaults: AP 130 = 0, AP 140 = 8 (§6.1), AP 179 = 1 (low sense range,
//! the only one hardware V1.2 has), AP 204 = 0, AP 210 = 25600 (§6.2 Table 20), AP 214 = 200 (Table 22:
//! standby "two seconds after the motor has stopped"), GP 65 = 0 (9600 baud), GP 68 = 0, GP 77 = 0,
//! GP 84 = 0, GP 85 = 0, GP 255 = 0. Module address 1 and host address 2 come from the reply examples
//! (§3.2, §3.7.15) and the ASCII example (§3.4.3). Every other default below is our decision, chosen so
//! that a freshly "unpacked" virtual module moves a NEMA 11 motor safely: speeds and acceleration of
//! 1 rps (51200 pps at 256 µsteps, the manual's own examples §2.4, §6.1), a moderate run current, a low
//! standby current, and TMC262 chopper settings that are the driver datasheet's typical start values.
//!
//! # Access decisions
//!
//! Table 15 marks AP 6, 7 and 140 "RW", but the manual's own STAP and RSAP examples (§3.7.7, §3.7.8)
//! store and restore AP 6, and the firmware history (§12.1 Table 23, V1.21 and V1.34) says AP 140 is
//! "taken over from the EEPROM". We therefore make AP 6, 7 and 140 storable (E), as they are on the real
//! module.

use crate::interface::InterfaceDesc;
use crate::interrupt::{InterruptDesc, Interrupts, Source};
use crate::param::{Access, ParamDesc, Range, Role, Setting, Table, Unit};
use crate::port::{PortDesc, PortKind};
use crate::variant::{AppStatusReply, Driver, Encoder, EncoderKind, GlobalBanks, Kinematics, ReferenceModes};
use crate::{ModelDesc, ModelSpec};
use tmcl_wire::{CommandSet, Opcode};

const A: &str = "§4 Table 15";
const G: &str = "§5.1 Table 17";
const I: &str = "§5.4 Table 19";

const POS: Range = Range::ANY;
const SPEED: Range = Range::Signed(0, i32::MAX);
const CURRENT: Range = Range::Signed(0, 255);
const fn r(min: i32, max: i32) -> Range {
    Range::Signed(min, max)
}

/// Reference search modes (AP 193, §7.1 Table 21): 1..8, +64 for modes 1..4 (search the right switch
/// instead), +128 for modes 5..8 (home switch inverted). The manual's examples (§7.1.5–7.1.8) print 129..132 for
/// the inverted modes 5..8, where 128 + mode gives 133..136; 128 + 1..4 is accepted as that alias.
const RFS_MODES: Range = Range::OneOf(&[1..=8, 65..=68, 129..=136]);

/// Axis parameters of motor 0 (manual chapter 4, Table 15): 58 entries.
pub static AXIS_PARAMS: [ParamDesc; 58] = [
    ParamDesc::plain(0, "Target position", "TargetPosition", POS, Access::RW, 0, A)
        .with_role(Role::TargetPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(1, "Actual position", "ActualPosition", POS, Access::RW, 0, A)
        .with_role(Role::ActualPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(2, "Target speed", "TargetSpeed", POS, Access::RW, 0, A)
        .with_role(Role::TargetSpeed)
        .with_unit(Unit::Pps),
    // Table 15 lists it RW without saying what a write does: accepted, no effect (the ramp generator owns
    // the value).
    ParamDesc::plain(3, "Actual speed", "ActualSpeed", POS, Access::RW, 0, A)
        .with_role(Role::ActualSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(4, "Maximum positioning speed", "MaxPositioningSpeed", r(1, i32::MAX), Access::RWE, 51200, A)
        .with_setting(Setting::MaxPositioningSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(5, "Maximum acceleration", "MaxAcceleration", r(1, i32::MAX), Access::RWE, 51200, A)
        .with_setting(Setting::MaxAcceleration)
        .with_unit(Unit::PpsPerSecond),
    ParamDesc::plain(6, "Maximum current", "MaxCurrent", CURRENT, Access::RWE, 128, A)
        .with_setting(Setting::RunCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(7, "Standby current", "StandbyCurrent", CURRENT, Access::RWE, 16, A)
        .with_setting(Setting::StandbyCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(8, "Position reached flag", "PositionReachedFlag", Range::FLAG, Access::R, 1, A)
        .with_role(Role::PositionReached),
    ParamDesc::plain(9, "Home switch state", "HomeSwitchState", Range::FLAG, Access::R, 0, A)
        .with_role(Role::HomeSwitch),
    ParamDesc::plain(10, "Right limit switch state", "RightLimitSwitchState", Range::FLAG, Access::R, 0, A)
        .with_role(Role::RightSwitch),
    ParamDesc::plain(11, "Left limit switch state", "LeftLimitSwitchState", Range::FLAG, Access::R, 0, A)
        .with_role(Role::LeftSwitch),
    ParamDesc::plain(12, "Right limit switch disable", "RightLimitSwitchDisable", Range::FLAG, Access::RWE, 0, A)
        .with_setting(Setting::RightSwitchDisable),
    ParamDesc::plain(13, "Left limit switch disable", "LeftLimitSwitchDisable", Range::FLAG, Access::RWE, 0, A)
        .with_setting(Setting::LeftSwitchDisable),
    ParamDesc::plain(128, "Ramp mode", "RampMode", Range::FLAG, Access::RW, 0, A).with_role(Role::RampMode),
    ParamDesc::plain(130, "Minimum speed", "MinimumSpeed", SPEED, Access::RWE, 0, A)
        .with_setting(Setting::MinimumSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(140, "Microstep resolution", "MicrostepResolution", r(0, 8), Access::RWE, 8, A)
        .with_role(Role::MicrostepResolution),
    ParamDesc::plain(160, "Step interpolation enable", "StepInterpolationEnable", Range::FLAG, Access::RW, 0, A),
    ParamDesc::plain(161, "Double step enable", "DoubleStepEnable", Range::FLAG, Access::RW, 0, A),
    ParamDesc::plain(162, "Chopper blank time", "ChopperBlankTime", r(0, 3), Access::RW, 2, A),
    ParamDesc::plain(163, "Constant TOff mode", "ConstantTOffMode", Range::FLAG, Access::RW, 0, A),
    ParamDesc::plain(164, "Disable fast decay comparator", "DisableFastDecayComparator", Range::FLAG, Access::RW, 0, A),
    ParamDesc::plain(
        165,
        "Chopper hysteresis end / fast decay time",
        "ChopperHysteresisEnd",
        r(0, 15),
        Access::RW,
        2,
        A,
    ),
    ParamDesc::plain(
        166,
        "Chopper hysteresis start / sine wave offset",
        "ChopperHysteresisStart",
        r(0, 8),
        Access::RW,
        4,
        A,
    ),
    ParamDesc::plain(167, "Chopper off time (TOff)", "ChopperOffTime", r(0, 15), Access::RW, 5, A)
        .with_setting(Setting::ChopperOffTime),
    ParamDesc::plain(
        168,
        "smartEnergy current minimum (SEIMIN)",
        "SmartEnergyCurrentMinimum",
        Range::FLAG,
        Access::RW,
        0,
        A,
    )
    .with_setting(Setting::CoolStepMinimum),
    ParamDesc::plain(169, "smartEnergy current down step", "SmartEnergyCurrentDownStep", r(0, 3), Access::RW, 0, A)
        .with_setting(Setting::CoolStepDownStep),
    ParamDesc::plain(170, "smartEnergy hysteresis", "SmartEnergyHysteresis", r(0, 15), Access::RW, 0, A)
        .with_setting(Setting::CoolStepHysteresis),
    ParamDesc::plain(171, "smartEnergy current up step", "SmartEnergyCurrentUpStep", r(0, 3), Access::RW, 0, A)
        .with_setting(Setting::CoolStepUpStep),
    ParamDesc::plain(172, "smartEnergy hysteresis start", "SmartEnergyHysteresisStart", r(0, 15), Access::RW, 0, A)
        .with_setting(Setting::CoolStepHysteresisStart),
    ParamDesc::plain(173, "stallGuard2 filter enable", "StallGuard2FilterEnable", Range::FLAG, Access::RW, 0, A)
        .with_setting(Setting::StallFilter),
    ParamDesc::plain(174, "stallGuard2 threshold", "StallGuard2Threshold", r(-64, 63), Access::RW, 0, A)
        .with_setting(Setting::StallThreshold),
    ParamDesc::plain(175, "Slope control high side", "SlopeControlHighSide", r(0, 3), Access::RW, 3, A),
    ParamDesc::plain(176, "Slope control low side", "SlopeControlLowSide", r(0, 3), Access::RW, 3, A),
    ParamDesc::plain(177, "Short protection disable", "ShortProtectionDisable", Range::FLAG, Access::RW, 0, A),
    ParamDesc::plain(178, "Short detection timer", "ShortDetectionTimer", r(0, 3), Access::RW, 0, A),
    ParamDesc::plain(179, "Vsense", "Vsense", Range::FLAG, Access::RW, 1, A).with_setting(Setting::CurrentRange),
    ParamDesc::plain(180, "smartEnergy actual current", "SmartEnergyActualCurrent", r(0, 31), Access::R, 0, A)
        .with_role(Role::ActualCurrent)
        .with_unit(Unit::CurrentOf32),
    // 0 = stop on stall off: Table 15 does not say what 0 does ("below this speed the motor is never
    // stopped" would make it stop at any speed); off is the TMCL convention.
    ParamDesc::plain(181, "Stop on stall", "StopOnStall", SPEED, Access::RW, 0, A)
        .with_setting(Setting::StopOnStall)
        .with_unit(Unit::Pps),
    ParamDesc::plain(182, "smartEnergy threshold speed", "SmartEnergyThresholdSpeed", SPEED, Access::RW, 0, A)
        .with_setting(Setting::CoolStepThresholdSpeed)
        .with_unit(Unit::Pps),
    // Our default: the run current's default, so that switching coolStep on (AP 172) does not leave the
    // motor without current below the threshold speed AP 182.
    ParamDesc::plain(183, "smartEnergy slow run current", "SmartEnergySlowRunCurrent", CURRENT, Access::RW, 128, A)
        .with_setting(Setting::SlowRunCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(184, "Random TOff mode", "RandomTOffMode", Range::FLAG, Access::RW, 0, A),
    ParamDesc::plain(193, "Reference search mode", "ReferenceSearchMode", RFS_MODES, Access::RW, 1, A)
        .with_setting(Setting::ReferenceSearchMode),
    ParamDesc::plain(194, "Reference search speed", "ReferenceSearchSpeed", SPEED, Access::RW, 51200, A)
        .with_setting(Setting::ReferenceSearchSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(195, "Reference switch speed", "ReferenceSwitchSpeed", SPEED, Access::RW, 5120, A)
        .with_setting(Setting::ReferenceSwitchSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(196, "End switch distance", "EndSwitchDistance", POS, Access::R, 0, A)
        .with_setting(Setting::EndSwitchDistance)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(197, "Last reference position", "LastReferencePosition", POS, Access::R, 0, A)
        .with_setting(Setting::LastReferencePosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(200, "Boost current", "BoostCurrent", CURRENT, Access::RW, 0, A)
        .with_setting(Setting::BoostCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(204, "Freewheeling delay", "FreewheelingDelay", r(0, 65535), Access::RWE, 0, A)
        .with_setting(Setting::FreewheelingDelay)
        .with_unit(Unit::TenMilliseconds),
    ParamDesc::plain(206, "Actual load value", "ActualLoadValue", r(0, 1023), Access::R, 0, A)
        .with_role(Role::LoadValue),
    ParamDesc::plain(207, "Extended error flags", "ExtendedErrorFlags", r(0, 3), Access::R, 0, A)
        .with_role(Role::ErrorFlags),
    ParamDesc::plain(208, "TMC262 error flags", "DriverErrorFlags", r(0, 255), Access::R, 0, A)
        .with_role(Role::DriverFlags),
    ParamDesc::plain(209, "Encoder position", "EncoderPosition", POS, Access::RW, 0, A)
        .with_role(Role::EncoderPosition)
        .with_unit(Unit::Microsteps),
    // §6.2.1–6.2.2: p = prescaler × 512; the value 4 (bit 2) is the clear-on-null function. Table 20's p = 200
    // has bit 3 set although the low four bits are reserved, so only bit 2 is taken as a function bit.
    ParamDesc::plain(210, "Encoder prescaler", "EncoderPrescaler", POS, Access::RW, 25600, A)
        .with_role(Role::EncoderPrescaler),
    ParamDesc::plain(212, "Maximum encoder deviation", "MaxEncoderDeviation", SPEED, Access::RW, 0, A)
        .with_setting(Setting::MaxEncoderDeviation)
        .with_unit(Unit::EncoderCounts),
    ParamDesc::plain(214, "Power down delay", "PowerDownDelay", r(1, 65535), Access::RWE, 200, A)
        .with_setting(Setting::PowerDownDelay)
        .with_unit(Unit::TenMilliseconds),
    ParamDesc::plain(215, "Absolute resolver value", "AbsoluteResolverValue", r(0, 1023), Access::R, 0, A)
        .with_role(Role::EncoderAbsolute),
    ParamDesc::plain(254, "Step/direction mode", "StepDirectionMode", r(0, 5), Access::RWE, 0, A),
];

/// Bank 0 (manual §5.1, Table 17): 19 entries. "Parameters with numbers between 64 and 128 are
/// automatically stored in the EEPROM" (§5.1).
pub static GLOBAL_PARAMS: [ParamDesc; 19] = [
    ParamDesc::plain(65, "RS485 baud rate", "BaudRate", r(0, 8), Access::RWA, 0, G).with_setting(Setting::BaudRate),
    ParamDesc::plain(66, "Serial address", "SerialAddress", r(1, 255), Access::RWA, 1, G)
        .with_setting(Setting::SerialAddress),
    ParamDesc::plain(67, "ASCII mode", "AsciiMode", r(0, 63), Access::RWA, 0, G).with_setting(Setting::AsciiMode),
    // Table 17 gives no unit for the heartbeat time; milliseconds.
    ParamDesc::plain(68, "Serial heartbeat", "SerialHeartbeat", r(0, 65535), Access::RWA, 0, G)
        .with_setting(Setting::SerialHeartbeat)
        .with_unit(Unit::Milliseconds),
    // Table 17 gives no unit for the pause time; milliseconds.
    ParamDesc::plain(75, "Telegram pause time", "TelegramPauseTime", r(0, 255), Access::RWA, 0, G)
        .with_setting(Setting::TelegramPause)
        .with_unit(Unit::Milliseconds),
    ParamDesc::plain(76, "Serial host address", "SerialHostAddress", r(0, 255), Access::RWA, 2, G)
        .with_setting(Setting::HostAddress),
    ParamDesc::plain(77, "Auto start mode", "AutoStartMode", Range::FLAG, Access::RWA, 0, G)
        .with_setting(Setting::AutoStart),
    ParamDesc::plain(79, "End switch polarity", "EndSwitchPolarity", Range::FLAG, Access::RWA, 0, G)
        .with_setting(Setting::EndSwitchPolarity),
    ParamDesc::plain(81, "TMCL code protection", "CodeProtection", r(0, 3), Access::RWA, 0, G)
        .with_setting(Setting::CodeProtection),
    ParamDesc::plain(84, "Coordinate storage", "CoordinateStorage", Range::FLAG, Access::RWA, 0, G)
        .with_setting(Setting::CoordinateStorage),
    ParamDesc::plain(85, "Do not restore user variables", "DoNotRestoreUserVariables", Range::FLAG, Access::RWA, 0, G)
        .with_setting(Setting::DoNotRestoreUserVariables),
    ParamDesc::plain(87, "Serial secondary address", "SerialSecondaryAddress", r(0, 255), Access::RWA, 0, G)
        .with_setting(Setting::SecondaryAddress),
    ParamDesc::plain(90, "Reverse shaft", "ReverseShaft", Range::FLAG, Access::RWA, 0, G)
        .with_setting(Setting::ReverseShaft),
    ParamDesc::plain(128, "TMCL application status", "ApplicationStatus", r(0, 3), Access::R, 0, G)
        .with_role(Role::ApplicationStatus),
    ParamDesc::plain(129, "Download mode", "DownloadMode", Range::FLAG, Access::R, 0, G).with_role(Role::DownloadMode),
    ParamDesc::plain(130, "TMCL program counter", "ProgramCounter", POS, Access::R, 0, G)
        .with_role(Role::ProgramCounter),
    ParamDesc::plain(132, "TMCL tick timer", "TickTimer", r(0, i32::MAX), Access::RW, 0, G)
        .with_role(Role::TickTimer)
        .with_unit(Unit::Milliseconds),
    ParamDesc::plain(133, "Random number", "RandomNumber", r(0, i32::MAX), Access::RW, 0, G)
        .with_role(Role::RandomNumber),
    // "cannot be stored to EEPROM and will be reset to 0 on startup".
    ParamDesc::plain(255, "Suppress reply", "SuppressReply", Range::FLAG, Access::RW, 0, G)
        .with_setting(Setting::SuppressReply),
];

/// Bank 3 (manual §5.4, Table 19): interrupt configuration, 9 entries. The manual states no defaults:
/// all 0 (timers and triggers off).
pub static INTERRUPT_PARAMS: [ParamDesc; 9] = [
    ParamDesc::plain(0, "Timer 0 period (ms)", "Timer0Period", Range::Unsigned32, Access::RW, 0, I)
        .with_unit(Unit::Milliseconds),
    ParamDesc::plain(1, "Timer 1 period (ms)", "Timer1Period", Range::Unsigned32, Access::RW, 0, I)
        .with_unit(Unit::Milliseconds),
    ParamDesc::plain(2, "Timer 2 period (ms)", "Timer2Period", Range::Unsigned32, Access::RW, 0, I)
        .with_unit(Unit::Milliseconds),
    ParamDesc::plain(27, "Stop left 0 trigger transition", "StopLeft0Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(28, "Stop right 0 trigger transition", "StopRight0Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(39, "Input 0 trigger transition", "Input0Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(40, "Input 1 trigger transition", "Input1Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(41, "Input 2 trigger transition", "Input2Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(42, "Input 3 trigger transition", "Input3Trigger", r(0, 3), Access::RW, 0, I),
];

/// I/O ports (manual §3.7.14 SIO, §3.7.15 GIO and their port tables).
pub static PORTS: [PortDesc; 11] = [
    PortDesc { bank: 0, port: 0, kind: PortKind::DigitalInput(0), name: "IN0" },
    PortDesc { bank: 0, port: 1, kind: PortKind::DigitalInput(1), name: "IN1" },
    PortDesc { bank: 0, port: 2, kind: PortKind::DigitalInput(2), name: "IN2 (shared with OUT0)" },
    PortDesc { bank: 0, port: 3, kind: PortKind::DigitalInput(3), name: "IN3 (shared with OUT1)" },
    PortDesc { bank: 0, port: 11, kind: PortKind::EncoderNearZero, name: "encoder near absolute zero" },
    PortDesc { bank: 0, port: 255, kind: PortKind::AllInputs, name: "all digital inputs" },
    PortDesc { bank: 1, port: 0, kind: PortKind::Analog(0), name: "analog IN3" },
    PortDesc { bank: 1, port: 9, kind: PortKind::Temperature, name: "temperature" },
    PortDesc { bank: 2, port: 0, kind: PortKind::Output(0), name: "OUT0" },
    PortDesc { bank: 2, port: 1, kind: PortKind::Output(1), name: "OUT1" },
    PortDesc { bank: 2, port: 255, kind: PortKind::AllOutputs, name: "all outputs" },
];

/// Interrupt vectors (manual §3.6.6, Table 12), each with its source and its bank 3 configuration
/// parameter (§5.4 Table 19: the timer periods are parameters 0–2, the trigger transitions of the stop
/// switches and inputs have the vector's number). The symbols are those of TMCL-IDE's `Interrupts.inc`
/// (the manual shows `TI_TIMER0` and `TI_GLOBAL`, §3.6.6.4).
pub static INTERRUPTS: [InterruptDesc; 12] = [
    irq(0, "Timer 0", "TI_TIMER0", Source::Timer(0), Some(0)),
    irq(1, "Timer 1", "TI_TIMER1", Source::Timer(1), Some(1)),
    irq(2, "Timer 2", "TI_TIMER2", Source::Timer(2), Some(2)),
    irq(3, "Target position reached 0", "TI_TARGET0", Source::TargetReached(0), None),
    irq(15, "stallGuard axis 0", "TI_STALLGUARD0", Source::Stall(0), None),
    irq(21, "Deviation axis 0", "TI_DEVIATION0", Source::Deviation(0), None),
    irq(27, "Left stop switch 0", "TI_STOPLEFT0", Source::LeftStop(0), Some(27)),
    irq(28, "Right stop switch 0", "TI_STOPRIGHT0", Source::RightStop(0), Some(28)),
    irq(39, "Input change 0", "TI_INPUT0", Source::Input(0), Some(39)),
    irq(40, "Input change 1", "TI_INPUT1", Source::Input(1), Some(40)),
    irq(41, "Input change 2", "TI_INPUT2", Source::Input(2), Some(41)),
    irq(42, "Input change 3", "TI_INPUT3", Source::Input(3), Some(42)),
];

const fn irq(
    number: u8,
    name: &'static str,
    symbol: &'static str,
    source: Source,
    config: Option<u8>,
) -> InterruptDesc {
    InterruptDesc { number, name, symbol, source, config }
}

/// The commands of the PD28-1021 (manual §3.5 Table 5, §3.7.36 UF0–UF7, §3.7.38 Table 13, §3.4.1 command
/// 139), and 242, which pytrinamic sends to reach a boot loader (the module stays silent). SAC (29) is
/// not one of them.
pub const COMMANDS: CommandSet = CommandSet::ALL_NAMED.without(Opcode::Sac);

/// The PD28-1021 with firmware V1.42, as a description (for tests and variants of it).
pub const DESC: ModelDesc = ModelDesc {
    id: "pd28-1021",
    name: "PD28-1021",
    // 136 type 0: host address + 8 characters (TMC-EvalSystem GetVersion; the reply examples of §3.2).
    version_string: *b"1021V142",
    // 136 type 1: module number as two BCD-like digit pairs (10, 21), major 1, minor 42 (TMC-EvalSystem).
    version_binary: i32::from_be_bytes([10, 21, 1, 42]),
    eeprom_tag: 1021,
    motors: 1,
    axis: Table::new(&AXIS_PARAMS),
    global: Table::new(&GLOBAL_PARAMS),
    interrupt: Table::new(&INTERRUPT_PARAMS),
    user_variables: 256,
    // §5.3: "the first 56 variables can also be stored permanently in the EEPROM".
    stored_user_variables: 56,
    // §3.7.24: 20 coordinates per axis plus coordinate 0 in RAM only.
    coordinates: 20,
    // Not stated in the manual; the TMCM-1021 hardware manual gives 2048 TMCL commands of memory.
    program_memory: 2048,
    ports: &PORTS,
    interrupts: Interrupts::new(&INTERRUPTS),
    // IN0..IN3 (IN2 and IN3 shared with OUT0 and OUT1), OUT0 and OUT1 (§3.7.14, §3.7.15).
    inputs: 4,
    outputs: 2,
    // One RS485 port (§3.1), with ASCII mode (§3.4).
    interfaces: &[InterfaceDesc::RS485],
    ethercat: None,
    commands: COMMANDS,
    // §3.4: "ROL, ROR, MST, MVP, SAP, GAP, STAP, RSAP, SGP, GGP, STGP, RSGP, RFS, SIO, GIO, SCO, GCO, CCO,
    // UF0..UF7".
    ascii_commands: COMMANDS.ascii_subset(),
    host_vect: false,
    app_status: AppStatusReply::Typed,
    banks: GlobalBanks::ARM,
    kinematics: Kinematics::Pps,
    reference_modes: ReferenceModes::Pd28,
    driver: Driver::Tmc262,
    // §6.2: the sensOstep encoder, 1024 counts per revolution, absolute within one turn.
    encoder: Some(Encoder { kind: EncoderKind::SensOstep, counts_per_rev: 1024 }),
    // Chapter 4 Table 15, AP 179: 1 A peak (0.7 A RMS) in the low sense range, 2 A in the high one.
    peak_current_ma: [1000, 2000],
    // No protected parameters.
    password: None,
    manual: "PD28-1021 TMCL firmware manual V1.05 (firmware V1.42)",
};

/// The PD28-1021 with firmware V1.42.
pub static SPEC: ModelSpec = ModelSpec::new(DESC);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_counts_match_the_manual() {
        // Table 15: 58 axis parameters; Table 17: 19 bank-0 parameters; Table 19: 9 bank-3 parameters.
        assert_eq!(AXIS_PARAMS.len(), 58);
        assert_eq!(GLOBAL_PARAMS.len(), 19);
        assert_eq!(INTERRUPT_PARAMS.len(), 9);
    }

    #[test]
    fn numbers_are_sorted_and_unique() {
        for table in [&AXIS_PARAMS[..], &GLOBAL_PARAMS[..], &INTERRUPT_PARAMS[..]] {
            assert!(table.windows(2).all(|w| w[0].number < w[1].number));
        }
    }

    #[test]
    fn defaults_are_in_range() {
        for d in AXIS_PARAMS.iter().chain(&GLOBAL_PARAMS).chain(&INTERRUPT_PARAMS) {
            assert!(d.range.contains(d.default) || d.access == Access::R, "{} default {}", d.name, d.default);
        }
    }

    #[test]
    fn storable_sets() {
        let e: std::vec::Vec<u8> = AXIS_PARAMS.iter().filter(|d| d.access.store).map(|d| d.number).collect();
        // Table 15's E parameters plus the decided 6, 7, 140.
        assert_eq!(e, [4, 5, 6, 7, 12, 13, 130, 140, 204, 214, 254]);
        let a: std::vec::Vec<u8> = GLOBAL_PARAMS.iter().filter(|d| d.access.auto).map(|d| d.number).collect();
        assert_eq!(a, [65, 66, 67, 68, 75, 76, 77, 79, 81, 84, 85, 87, 90]);
    }
}

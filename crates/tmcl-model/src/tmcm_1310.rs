//! The TMCM-1310: a closed-loop stepper module with USB and EtherCAT, 8 inputs and 8 outputs, following
//! the TMCM-1310 TMCL firmware manual V1.14 (Rev. 1.17).
//!
//! # Sources, in order of authority
//!
//! The manual in hand holds its chapters 1–6.6 (features, EtherCAT, USB, ASCII, the command overview and
//! interrupts); the axis and global parameter chapters (7–11) are missing. What it names, the tables
//! below take as it is, citing it as "1310 §…":
//! - the process-data table (§3.4) names AP 0, 1, 2, 3, 14, 18, 123, 131, 209, 230, 233 and the status
//!   word's bits 0–11; its table of contents names AP 193 (§10.1.1);
//! - features (§1): 8 inputs of which 2 analog, 8 outputs, STOP_L/STOP_R, an A/B/N or SSI encoder,
//!   up to 3 A RMS, 12–48 V, 1024 commands of program memory;
//! - interrupts (§6.6): vectors 0–2, 3, 15, 21, 27, 28, 39–46, the timer period `SGP 0, 3, …`.
//!
//! Where the manual is silent, the TMCM-1311 — the same closed-loop family (3 A, 48 V, 18 GPIOs, a
//! TMC262 driver) with RS485/CAN instead of EtherCAT — gives the numbers and meanings host software
//! for the family relies on: its firmware manual V1.11 (p.68: AP 18 bits 12–13, 19, 20, 25–29, 108,
//! 109, 112; p.82: AP 201, 202, 210), the `TMCM1311` class of pytrinamic and its closed-loop demo
//! (AP 14–17, 113–138, 140, 193–196, 200–214, 230–237; the enable sequence AP 132 → 2, AP 129 → 1,
//! AP 133 → 1), and the TMCL-IDE parameter list of the TMCM-1311 (AP 110 maximum gamma, 111 beta).
//! Defaults that no source gives come from the TMCM-1316 closed-loop firmware's start values where it
//! has the same function (standby current 32, scaler minimum 100 and maximum 240, encoder resolution
//! 4096, position window 100, field-weakening velocities 300000/600000) or are our decision, marked so.
//! The board itself (a TMC262 driver, 8 inputs/8 outputs/2 stop switches, 10–51 V) is described in the
//! front page of the later CoE firmware manual of the same board (firmware V2.07).
//!
//! # Decisions
//!
//! - **Closed loop** is the core's `drive::closed_loop` model; its parameters here carry the TMCM-1311's
//!   numbers, and what each does in the simulation is written there.
//! - **Field weakening** (AP 108–110) and the standstill damping (AP 137) are stored and read back: the
//!   simulated motor has no back-EMF and a quasi-static rotor, so there is nothing for them to act on.
//! - **Password** (status 8, manual §3.7, which says nothing else): GP 200 takes the password 4321 (the
//!   code that unlocks the EEPROM on the TMC428-generation modules). Protected are the settings that guard
//!   the motor or hold the encoder calibration: the I²t time constant and limit (AP 25, 26) and the
//!   encoder offset (AP 112). Daily settings, pytrinamic's closed-loop demo among them, need no password.
//! - **Interfaces**: USB first (manual chapter 4), then the EtherCAT mailbox (chapter 3). On USB the
//!   module answers whatever address byte a command carries — a USB link has one module — and replies
//!   with its own address (GP 66). ASCII mode only on USB (§5: "can be used with the USB interface,
//!   only"). No serial baud rate, telegram pause, heartbeat or secondary address: they are RS485 settings.
//! - **Analog inputs**: IN0 and IN1 are the two analog-capable inputs (bank 1 ports 0 and 1); the manual
//!   says two of the eight are, not which.
//! - **Reference search**: the ARM-generation modes 1–8 with +64/+128 (AP 193–196 as the TMCM-1311 and
//!   the PD28-1021 have them).
//! - **Units**: pps and pps/s, as the TMCM-1311 (its manual p.68 gives velocities in pps).

use crate::ethercat::{DataType, EtherCatDesc, InputEntry, InputSource, OutputAction, OutputMode};
use crate::interface::InterfaceDesc;
use crate::interrupt::{InterruptDesc, Interrupts, Source};
use crate::param::{cited, join, Access, ParamDesc, Range, Role, Setting, Table, Unit};
use crate::pd28_1021;
use crate::port::{PortDesc, PortKind};
use crate::variant::{AppStatusReply, Driver, Encoder, EncoderKind, GlobalBanks, Kinematics, ReferenceModes};
use crate::{ModelDesc, ModelSpec};
use tmcl_wire::{CommandSet, Opcode};

/// The manual's process-data table (§3.4).
const PD: &str = "1310 §3.4";
/// The TMCM-1311 sibling: its firmware manual V1.11.
const M11: &str = "TMCM-1311 manual V1.11";
/// The TMCM-1311 sibling: pytrinamic's TMCM1311 class.
const PY: &str = "pytrinamic TMCM1311";
/// The TMCM-1311 sibling: the TMCL-IDE parameter list.
const IDE: &str = "TMCL-IDE TMCM-1311";
/// The PD28-1021 manual, chapter 4 Table 15: the ARM-generation parameters the TMCM-1311 shares.
const P28: &str = "PD28-1021 §4 Table 15 (as TMCM-1311)";
/// Bank 0 as on the PD28-1021 (§5.1 Table 17), which the TMCM-1311 shares.
const G28: &str = "PD28-1021 §5.1 Table 17 (as TMCM-1311)";
/// Our decision, written in the module docs.
const OURS: &str = "decision (tmcm_1310.rs)";
/// Interrupt configuration (§6.6).
const I: &str = "1310 §6.6";

const POS: Range = Range::ANY;
const SPEED: Range = Range::Signed(0, i32::MAX);
const CURRENT: Range = Range::Signed(0, 255);
const fn r(min: i32, max: i32) -> Range {
    Range::Signed(min, max)
}

const HEAD: [ParamDesc; 29] = [
    ParamDesc::plain(0, "Target position", "TargetPosition", POS, Access::RW, 0, PD)
        .with_role(Role::TargetPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(1, "Actual position", "ActualPosition", POS, Access::RW, 0, PD)
        .with_role(Role::ActualPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(2, "Target velocity", "TargetVelocity", POS, Access::RW, 0, PD)
        .with_role(Role::TargetSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(3, "Actual velocity", "ActualVelocity", POS, Access::RW, 0, PD)
        .with_role(Role::ActualSpeed)
        .with_unit(Unit::Pps),
    // Our defaults: 1 rps at 256 microsteps, as the PD28-1021.
    ParamDesc::plain(4, "Maximum positioning speed", "MaxVelocity", r(1, i32::MAX), Access::RWE, 51200, P28)
        .with_setting(Setting::MaxPositioningSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(5, "Maximum acceleration", "MaxAcceleration", r(1, i32::MAX), Access::RWE, 51200, P28)
        .with_setting(Setting::MaxAcceleration)
        .with_unit(Unit::PpsPerSecond),
    // Our default: half of the 3 A RMS (manual §1).
    ParamDesc::plain(6, "Maximum current", "MaxCurrent", CURRENT, Access::RWE, 128, P28)
        .with_setting(Setting::RunCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(7, "Standby current", "StandbyCurrent", CURRENT, Access::RWE, 32, P28)
        .with_setting(Setting::StandbyCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(8, "Position reached flag", "PositionReachedFlag", Range::FLAG, Access::R, 1, P28)
        .with_role(Role::PositionReached),
    ParamDesc::plain(9, "Home switch state", "HomeSwitch", Range::FLAG, Access::R, 0, P28).with_role(Role::HomeSwitch),
    ParamDesc::plain(10, "Right limit switch state", "RightEndstop", Range::FLAG, Access::R, 0, P28)
        .with_role(Role::RightSwitch),
    ParamDesc::plain(11, "Left limit switch state", "LeftEndstop", Range::FLAG, Access::R, 0, P28)
        .with_role(Role::LeftSwitch),
    ParamDesc::plain(12, "Right limit switch disable", "RightLimitSwitchDisable", Range::FLAG, Access::RWE, 0, P28)
        .with_setting(Setting::RightSwitchDisable),
    ParamDesc::plain(13, "Left limit switch disable", "LeftLimitSwitchDisable", Range::FLAG, Access::RWE, 0, P28)
        .with_setting(Setting::LeftSwitchDisable),
    // "Delta / torque" in §3.4; the torque-mode target current in mA (TMCM-1311 AP 19's range ±3000 mA).
    ParamDesc::plain(14, "Torque mode target current", "TargetTorque", r(-3000, 3000), Access::RW, 0, PD)
        .with_role(Role::TargetCurrent)
        .with_unit(Unit::Milliamps),
    ParamDesc::plain(16, "Velocity reached flag", "VelocityReachedFlag", Range::FLAG, Access::R, 0, PY)
        .with_role(Role::VelocityReached),
    // Our default window: 1 % of the default maximum speed.
    ParamDesc::plain(17, "Velocity reached window", "VelocityReachedWindow", SPEED, Access::RW, 512, PY)
        .with_setting(Setting::VelocityWindow)
        .with_unit(Unit::Pps),
    ParamDesc::plain(18, "Status word", "StatusWord", r(0, 0x3FFF), Access::R, 0, PD).with_role(Role::StatusWord),
    ParamDesc::plain(19, "Torque mode actual current", "ActualTorque", r(-3000, 3000), Access::R, 0, M11)
        .with_role(Role::ActualTorqueCurrent)
        .with_unit(Unit::Milliamps),
    ParamDesc::plain(20, "Torque mode current slope", "TorqueSlope", SPEED, Access::RW, 0, M11)
        .with_setting(Setting::TorqueSlope),
    // Our defaults: a 3 s winding time constant; the limit 0 = off.
    ParamDesc::plain(
        25,
        "Thermal winding time constant",
        "ThermalWindingTime",
        r(1, i32::MAX),
        Access::RWE.protected(),
        3000,
        M11,
    )
    .with_setting(Setting::I2tTimeConstant),
    ParamDesc::plain(26, "I2t limit", "I2tLimit", SPEED, Access::RWE.protected(), 0, M11)
        .with_setting(Setting::I2tLimit),
    ParamDesc::plain(27, "I2t sum", "I2tSum", SPEED, Access::R, 0, M11).with_role(Role::I2tSum),
    // P.68 marks it RWE; a counter that STAP would store and power-up bring back is not what a user
    // expects of "how often since start": RW.
    ParamDesc::plain(28, "I2t exceed counter", "I2tExceedCounter", SPEED, Access::RW, 0, M11)
        .with_role(Role::I2tExceedCount),
    ParamDesc::plain(29, "Clear I2t exceeded flag", "ClearI2tFlag", POS, Access::W, 0, M11).with_role(Role::ClearI2t),
    ParamDesc::plain(108, "Field weakening minimum velocity", "GammaVMin", r(0, 327_679_999), Access::RW, 300_000, M11)
        .with_unit(Unit::Pps),
    ParamDesc::plain(109, "Field weakening maximum velocity", "GammaVMax", r(0, 327_679_999), Access::RW, 600_000, M11)
        .with_unit(Unit::Pps),
    ParamDesc::plain(110, "Maximum gamma", "MaxGamma", CURRENT, Access::RW, 255, IDE),
    // Beta: how far the field may lead the rotor, 255 ≈ 90° electrical (one full step).
    ParamDesc::plain(111, "Beta (commutation limit)", "Beta", CURRENT, Access::RW, 255, IDE)
        .with_setting(Setting::CommutationLimit),
];

const CLOSED_LOOP: [ParamDesc; 26] = [
    // Written by the encoder initialisation (AP 132); protected: it is the calibration.
    ParamDesc::plain(112, "Encoder offset", "EncoderOffset", POS, Access::RWE.protected(), 0, M11)
        .with_setting(Setting::EncoderOffset),
    ParamDesc::plain(113, "Current scale minimum", "CurrentScaleMin", CURRENT, Access::RW, 100, PY)
        .with_setting(Setting::CurrentScaleMin)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(114, "Current scale maximum", "CurrentScaleMax", CURRENT, Access::RW, 240, PY)
        .with_setting(Setting::CurrentScaleMax)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(115, "Current scale input", "CurrentScaleInput", Range::FLAG, Access::RW, 0, PY)
        .with_setting(Setting::CurrentScaleInput),
    ParamDesc::plain(116, "Current scale lower error limit", "CurrentScaleLowerLimit", SPEED, Access::RW, 32, PY)
        .with_setting(Setting::CurrentScaleLower),
    ParamDesc::plain(117, "Current scale upper error limit", "CurrentScaleUpperLimit", SPEED, Access::RW, 128, PY)
        .with_setting(Setting::CurrentScaleUpper),
    ParamDesc::plain(118, "Current scale increment", "CurrentScaleIncrement", CURRENT, Access::RW, 8, PY)
        .with_setting(Setting::CurrentScaleIncrement),
    ParamDesc::plain(119, "Current scale decrement", "CurrentScaleDecrement", CURRENT, Access::RW, 1, PY)
        .with_setting(Setting::CurrentScaleDecrement),
    ParamDesc::plain(120, "Current scale increment timeout", "CurrentScaleUpTimeout", r(0, 65535), Access::RW, 1, PY)
        .with_setting(Setting::CurrentScaleUpTime),
    ParamDesc::plain(
        121,
        "Current scale decrement timeout",
        "CurrentScaleDownTimeout",
        r(0, 65535),
        Access::RW,
        10,
        PY,
    )
    .with_setting(Setting::CurrentScaleDownTime),
    ParamDesc::plain(122, "Current scale enable", "CurrentScaleEnable", Range::FLAG, Access::RW, 1, PY)
        .with_setting(Setting::CurrentScaleEnable),
    ParamDesc::plain(123, "Actual current scale", "CurrentScale", CURRENT, Access::R, 0, PD)
        .with_role(Role::CurrentScale)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(124, "Correction velocity P", "CorrectionVelocityP", r(0, 10_000), Access::RW, 20, PY)
        .with_setting(Setting::CorrectionGain),
    ParamDesc::plain(125, "Maximum following error", "MaxFollowingError", SPEED, Access::RW, 0, PY)
        .with_setting(Setting::MaxFollowingError)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(126, "Maximum correction velocity", "MaxCorrectionVelocity", SPEED, Access::RW, 51200, PY)
        .with_setting(Setting::MaxCorrectionVelocity)
        .with_unit(Unit::Pps),
    ParamDesc::plain(127, "Relative positioning option", "RelativePositioningOption", r(0, 2), Access::RW, 0, PY)
        .with_setting(Setting::RelativePositioning),
    ParamDesc::plain(128, "Ramp mode", "RampMode", Range::FLAG, Access::RW, 0, PY).with_role(Role::RampMode),
    ParamDesc::plain(129, "Closed loop mode", "ClosedLoopMode", Range::FLAG, Access::RW, 0, PY)
        .with_setting(Setting::ClosedLoop),
    ParamDesc::plain(130, "Minimum speed", "MinimumSpeed", SPEED, Access::RWE, 0, P28)
        .with_setting(Setting::MinimumSpeed)
        .with_unit(Unit::Pps),
    ParamDesc::plain(131, "Measured velocity", "MeasuredVelocity", POS, Access::R, 0, PD)
        .with_role(Role::MeasuredVelocity)
        .with_unit(Unit::Pps),
    ParamDesc::plain(132, "Encoder initialisation", "EncoderInitialization", Range::FLAG, Access::RW, 0, PY)
        .with_role(Role::EncoderInit),
    ParamDesc::plain(133, "Closed loop init flag", "ClosedLoopInitFlag", Range::FLAG, Access::R, 0, PY)
        .with_role(Role::ClosedLoopActive),
    ParamDesc::plain(134, "Position reached window", "PositionWindow", SPEED, Access::RW, 100, PY)
        .with_setting(Setting::PositionWindow)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(136, "Standstill correction gain", "StandstillGain", r(0, 1024), Access::RW, 64, PY)
        .with_setting(Setting::HoldGain),
    ParamDesc::plain(137, "Standstill correction damping", "StandstillDamping", r(0, 1024), Access::RW, 0, PY),
    ParamDesc::plain(138, "Standstill correction limit", "StandstillLimit", SPEED, Access::RW, 512, PY)
        .with_setting(Setting::HoldLimit),
];

const MICROSTEPS: [ParamDesc; 1] =
    [ParamDesc::plain(140, "Microstep resolution", "MicrostepResolution", r(0, 8), Access::RWE, 8, PY)
        .with_role(Role::MicrostepResolution)];

/// The TMC262's chopper, smartEnergy and stallGuard2 settings (TMCM-1311: AP 162–184 as on the
/// PD28-1021), without the sense-range switch AP 179: the 1310's current range is fixed at 3 A RMS.
const TMC262_A: [ParamDesc; 17] = cited(&pd28_1021::AXIS_PARAMS, 162, 178, P28);
const TMC262_B: [ParamDesc; 5] = cited(&pd28_1021::AXIS_PARAMS, 180, 184, P28);
/// Reference search (AP 193–196; modes as the PD28-1021's §7.1).
const REFERENCE: [ParamDesc; 4] = cited(&pd28_1021::AXIS_PARAMS, 193, 196, P28);

const TAIL: [ParamDesc; 15] = [
    ParamDesc::plain(200, "Boost current", "BoostCurrent", CURRENT, Access::RW, 0, P28)
        .with_setting(Setting::BoostCurrent)
        .with_unit(Unit::CurrentOf255),
    // P.82: bit 2 clear on next N, bit 3 clear on every N, bit 4 N active high. Bit 0 (our decision, the
    // manual's "A/B/N or SSI, chosen in software"): 1 = the SSI interface.
    ParamDesc::plain(201, "Encoder mode", "EncoderMode", r(0, 31), Access::RWE, 0, M11)
        .with_setting(Setting::EncoderMode),
    ParamDesc::plain(202, "Motor full step resolution", "MotorFullStepResolution", r(1, 400), Access::RWE, 200, M11)
        .with_setting(Setting::MotorFullSteps)
        .with_unit(Unit::FullSteps),
    ParamDesc::plain(204, "Freewheeling delay", "FreewheelingDelay", r(0, 65535), Access::RWE, 0, P28)
        .with_setting(Setting::FreewheelingDelay)
        .with_unit(Unit::TenMilliseconds),
    ParamDesc::plain(206, "Actual load value", "ActualLoadValue", r(0, 1023), Access::R, 0, P28)
        .with_role(Role::LoadValue),
    ParamDesc::plain(207, "Extended error flags", "ExtendedErrorFlags", r(0, 3), Access::R, 0, P28)
        .with_role(Role::ErrorFlags),
    ParamDesc::plain(208, "Driver error flags", "DriverErrorFlags", r(0, 255), Access::R, 0, P28)
        .with_role(Role::DriverFlags),
    // In µsteps: the counts are scaled by AP 210 and the motor's full steps and microsteps (AP 202, 140),
    // so that a closed loop compares it with the step position (docs/tmcm-1310.md).
    ParamDesc::plain(209, "Encoder position", "EncoderPosition", POS, Access::RW, 0, PD)
        .with_role(Role::EncoderPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(210, "Encoder resolution", "EncoderResolution", r(1, 65535), Access::RWE, 4096, M11)
        .with_setting(Setting::EncoderResolution)
        .with_unit(Unit::EncoderCounts),
    ParamDesc::plain(212, "Maximum encoder deviation", "MaxEncoderDeviation", SPEED, Access::RW, 0, P28)
        .with_setting(Setting::MaxEncoderDeviation)
        .with_unit(Unit::EncoderCounts),
    ParamDesc::plain(214, "Power down delay", "PowerDownDelay", r(1, 65535), Access::RWE, 200, P28)
        .with_setting(Setting::PowerDownDelay)
        .with_unit(Unit::TenMilliseconds),
    ParamDesc::plain(230, "Gamma", "Gamma", r(-256, 256), Access::R, 0, PD).with_role(Role::Gamma),
    ParamDesc::plain(233, "Virtual actual position", "VirtualActualPosition", POS, Access::R, 0, PD)
        .with_role(Role::VirtualPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(236, "Actual target current scale", "TargetCurrentScale", CURRENT, Access::R, 0, PY)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(237, "Position error", "PositionError", POS, Access::R, 0, PY)
        .with_role(Role::PositionError)
        .with_unit(Unit::Microsteps),
];

/// Axis parameters of motor 0: 97 entries.
pub static AXIS_PARAMS: [ParamDesc; 97] =
    join(&[&HEAD, &CLOSED_LOOP, &MICROSTEPS, &TMC262_A, &TMC262_B, &REFERENCE, &TAIL]);

/// Bank 0: the ARM-generation set without the RS485 settings, the manual's GP 67 (§5), and the password.
pub static GLOBAL_PARAMS: [ParamDesc; 15] = [
    ParamDesc::plain(66, "Module address", "SerialAddress", r(1, 255), Access::RWA, 1, G28)
        .with_setting(Setting::SerialAddress),
    ParamDesc::plain(67, "ASCII mode", "AsciiMode", r(0, 63), Access::RWA, 0, "1310 §5")
        .with_setting(Setting::AsciiMode),
    // Host address 2: the ASCII reply example `BA 100 5000` (§5).
    ParamDesc::plain(76, "Host address", "SerialHostAddress", r(0, 255), Access::RWA, 2, G28)
        .with_setting(Setting::HostAddress),
    ParamDesc::plain(77, "Auto start mode", "AutoStartMode", Range::FLAG, Access::RWA, 0, G28)
        .with_setting(Setting::AutoStart),
    ParamDesc::plain(79, "End switch polarity", "EndSwitchPolarity", Range::FLAG, Access::RWA, 0, G28)
        .with_setting(Setting::EndSwitchPolarity),
    ParamDesc::plain(81, "TMCL code protection", "CodeProtection", r(0, 3), Access::RWA, 0, G28)
        .with_setting(Setting::CodeProtection),
    ParamDesc::plain(84, "Coordinate storage", "CoordinateStorage", Range::FLAG, Access::RWA, 0, G28)
        .with_setting(Setting::CoordinateStorage),
    ParamDesc::plain(
        85,
        "Do not restore user variables",
        "DoNotRestoreUserVariables",
        Range::FLAG,
        Access::RWA,
        0,
        G28,
    )
    .with_setting(Setting::DoNotRestoreUserVariables),
    ParamDesc::plain(128, "TMCL application status", "ApplicationStatus", r(0, 3), Access::R, 0, G28)
        .with_role(Role::ApplicationStatus),
    ParamDesc::plain(129, "Download mode", "DownloadMode", Range::FLAG, Access::R, 0, G28)
        .with_role(Role::DownloadMode),
    ParamDesc::plain(130, "TMCL program counter", "ProgramCounter", POS, Access::R, 0, G28)
        .with_role(Role::ProgramCounter),
    ParamDesc::plain(132, "TMCL tick timer", "TickTimer", r(0, i32::MAX), Access::RW, 0, G28)
        .with_role(Role::TickTimer)
        .with_unit(Unit::Milliseconds),
    ParamDesc::plain(133, "Random number", "RandomNumber", r(0, i32::MAX), Access::RW, 0, G28)
        .with_role(Role::RandomNumber),
    ParamDesc::plain(200, "Password", "Password", POS, Access::RW, 0, OURS).with_role(Role::Password),
    ParamDesc::plain(255, "Suppress reply", "SuppressReply", Range::FLAG, Access::RW, 0, G28)
        .with_setting(Setting::SuppressReply),
];

/// Bank 3: the timer periods (§6.6: `SGP 0, 3, 1000` sets timer 0 to 1000 ms) and the trigger
/// transitions of the stop switches and the eight inputs (numbered as their vectors, the PD28-1021's
/// §5.4 scheme and the TMCM-1311's bank 3: 0 off, 1 rising, 2 falling, 3 both).
pub static INTERRUPT_PARAMS: [ParamDesc; 13] = join(&[&INTERRUPT_SHARED, &INPUTS_4_TO_7]);

/// Timers, stop switches and inputs 0–3: as the PD28-1021's bank 3.
const INTERRUPT_SHARED: [ParamDesc; 9] = cited(&pd28_1021::INTERRUPT_PARAMS, 0, 42, I);
const INPUTS_4_TO_7: [ParamDesc; 4] = [
    ParamDesc::plain(43, "Input 4 trigger transition", "Input4Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(44, "Input 5 trigger transition", "Input5Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(45, "Input 6 trigger transition", "Input6Trigger", r(0, 3), Access::RW, 0, I),
    ParamDesc::plain(46, "Input 7 trigger transition", "Input7Trigger", r(0, 3), Access::RW, 0, I),
];

/// I/O ports: inputs IN0–IN7 (bank 0), the analog IN0 and IN1 (bank 1, 12 bits), the temperature
/// (bank 1 port 9, as the PD28-1021), outputs OUT0–OUT7 (bank 2, the manual's `SIO 3, 2, x`).
pub static PORTS: [PortDesc; 21] = [
    PortDesc { bank: 0, port: 0, kind: PortKind::DigitalInput(0), name: "IN0" },
    PortDesc { bank: 0, port: 1, kind: PortKind::DigitalInput(1), name: "IN1" },
    PortDesc { bank: 0, port: 2, kind: PortKind::DigitalInput(2), name: "IN2" },
    PortDesc { bank: 0, port: 3, kind: PortKind::DigitalInput(3), name: "IN3" },
    PortDesc { bank: 0, port: 4, kind: PortKind::DigitalInput(4), name: "IN4" },
    PortDesc { bank: 0, port: 5, kind: PortKind::DigitalInput(5), name: "IN5" },
    PortDesc { bank: 0, port: 6, kind: PortKind::DigitalInput(6), name: "IN6" },
    PortDesc { bank: 0, port: 7, kind: PortKind::DigitalInput(7), name: "IN7" },
    PortDesc { bank: 0, port: 255, kind: PortKind::AllInputs, name: "all digital inputs" },
    PortDesc { bank: 1, port: 0, kind: PortKind::Analog(0), name: "analog IN0" },
    PortDesc { bank: 1, port: 1, kind: PortKind::Analog(1), name: "analog IN1" },
    PortDesc { bank: 1, port: 9, kind: PortKind::Temperature, name: "temperature" },
    PortDesc { bank: 2, port: 0, kind: PortKind::Output(0), name: "OUT0" },
    PortDesc { bank: 2, port: 1, kind: PortKind::Output(1), name: "OUT1" },
    PortDesc { bank: 2, port: 2, kind: PortKind::Output(2), name: "OUT2" },
    PortDesc { bank: 2, port: 3, kind: PortKind::Output(3), name: "OUT3" },
    PortDesc { bank: 2, port: 4, kind: PortKind::Output(4), name: "OUT4" },
    PortDesc { bank: 2, port: 5, kind: PortKind::Output(5), name: "OUT5" },
    PortDesc { bank: 2, port: 6, kind: PortKind::Output(6), name: "OUT6" },
    PortDesc { bank: 2, port: 7, kind: PortKind::Output(7), name: "OUT7" },
    PortDesc { bank: 2, port: 255, kind: PortKind::AllOutputs, name: "all outputs" },
];

/// Interrupt vectors (§6.6): timers, target reached, stallGuard2, deviation, the stop switches and the
/// eight inputs.
pub static INTERRUPTS: [InterruptDesc; 16] = [
    irq(0, "Timer 0", "TI_TIMER0", Source::Timer(0), Some(0)),
    irq(1, "Timer 1", "TI_TIMER1", Source::Timer(1), Some(1)),
    irq(2, "Timer 2", "TI_TIMER2", Source::Timer(2), Some(2)),
    irq(3, "Target position reached", "TI_TARGET0", Source::TargetReached(0), None),
    irq(15, "stallGuard2", "TI_STALLGUARD0", Source::Stall(0), None),
    irq(21, "Deviation", "TI_DEVIATION0", Source::Deviation(0), None),
    irq(27, "Left stop switch", "TI_STOPLEFT0", Source::LeftStop(0), Some(27)),
    irq(28, "Right stop switch", "TI_STOPRIGHT0", Source::RightStop(0), Some(28)),
    irq(39, "Input change 0", "TI_INPUT0", Source::Input(0), Some(39)),
    irq(40, "Input change 1", "TI_INPUT1", Source::Input(1), Some(40)),
    irq(41, "Input change 2", "TI_INPUT2", Source::Input(2), Some(41)),
    irq(42, "Input change 3", "TI_INPUT3", Source::Input(3), Some(42)),
    irq(43, "Input change 4", "TI_INPUT4", Source::Input(4), Some(43)),
    irq(44, "Input change 5", "TI_INPUT5", Source::Input(5), Some(44)),
    irq(45, "Input change 6", "TI_INPUT6", Source::Input(6), Some(45)),
    irq(46, "Input change 7", "TI_INPUT7", Source::Input(7), Some(46)),
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

/// The USB port (manual chapter 4): 9-byte frames and ASCII mode (§5), every address byte answered.
pub const USB: InterfaceDesc = InterfaceDesc {
    name: "usb",
    kind: crate::InterfaceKind::Usb,
    framing: crate::Framing::Binary,
    address_filter: false,
    ascii: true,
    telegram_pause: false,
    suppressible: true,
};

/// The commands of §6.1–6.6 and the control commands of the table of contents (§6.8.31 CLE, §6.8.36
/// UF0–UF7, §6.8.37 command 138, §6.8.39, command 139 of §5); no SAC (29), which the manual never names.
pub const COMMANDS: CommandSet = CommandSet::ALL_NAMED.without(Opcode::Sac);

const fn input(name: &'static str, data_type: DataType, role: Role) -> InputEntry {
    InputEntry { name, data_type, source: InputSource::Param(role) }
}

/// What an EtherCAT master sees (manual chapter 3).
///
/// Identity: vendor ID 0x286, Trinamic Motion Control in the ETG's vendor list; product code 1310, the
/// module number (Trinamic numbers its EtherCAT products so, and command 136 type 1 carries the same
/// 0x051E); revision major << 16 | minor of the firmware, 0x0001000E for V1.14, as Trinamic's ESI files
/// number revisions (0x00020003 for V2.3).
///
/// Process data (§3.4). **Outputs**: controller mode (UNSIGNED32) and value (SIGNED32). The manual heads
/// the mode table "Bit" but lists 0 "no operation" among 1, 2, 3: the mode is a **value**, 0..3, not a bit
/// mask. **Inputs**: the manual's table in its order, all **twelve** fields, 48 bytes. The text says
/// "first 44 bytes", which would drop the last field (gamma); the table lists twelve 4-byte fields and
/// nothing says which one to leave out, so all are mapped (`docs/decisions.md`, "EtherCAT"). The word
/// the manual prints as "Error flags" with the bit table "0 target reached … 11 overtemperature" is read
/// as: the status word (AP 18) carries the bit table, and the error flags field carries the module's
/// error flags (AP 207) and the driver's flags (AP 208), read without clearing them.
pub const ETHERCAT: EtherCatDesc = EtherCatDesc {
    vendor_id: 0x0000_0286,
    vendor_name: "TRINAMIC Motion Control GmbH & Co. KG",
    product_code: 1310,
    revision: 0x0001_000E,
    group: "Drives",
    mode_name: "Controller mode",
    value_name: "Value",
    modes: &[
        OutputMode { code: 0, name: "No operation", action: None },
        OutputMode { code: 1, name: "Position", action: Some(OutputAction::MoveTo) },
        OutputMode { code: 2, name: "Velocity", action: Some(OutputAction::Rotate) },
        // The torque-mode current in mA; the closed loop must be on (AP 14).
        OutputMode { code: 3, name: "Torque", action: Some(OutputAction::Param(Role::TargetCurrent)) },
    ],
    inputs: &[
        input("Target position", DataType::Integer32, Role::TargetPosition),
        input("Actual position", DataType::Integer32, Role::ActualPosition),
        input("Virtual actual position", DataType::Integer32, Role::VirtualPosition),
        input("Encoder position", DataType::Integer32, Role::EncoderPosition),
        input("Target velocity", DataType::Integer32, Role::TargetSpeed),
        input("Actual velocity", DataType::Integer32, Role::ActualSpeed),
        input("Measured velocity", DataType::Integer32, Role::MeasuredVelocity),
        // Printed "GAP 18)".
        input("Status word", DataType::Unsigned32, Role::StatusWord),
        InputEntry { name: "Error flags", data_type: DataType::Unsigned32, source: InputSource::ErrorAndDriverFlags },
        input("Scaler", DataType::Integer32, Role::CurrentScale),
        input("Delta / torque", DataType::Integer32, Role::TargetCurrent),
        // Printed "Command for read out: 230".
        input("Gamma", DataType::Integer32, Role::Gamma),
    ],
};

/// The TMCM-1310 with firmware V1.14, as a description.
pub const DESC: ModelDesc = ModelDesc {
    id: "tmcm-1310",
    name: "TMCM-1310",
    version_string: *b"1310V114",
    // 136 type 1: the module number 1310 (0x051E) in the high word, as the V1.11 manual's p.63 prints
    // (bytes 0x05, 0x1E), then major 1 and minor 14 most significant first, as the PD28-1021's reply.
    version_binary: (1310 << 16) | (1 << 8) | 14,
    eeprom_tag: 1310,
    motors: 1,
    axis: Table::new(&AXIS_PARAMS),
    global: Table::new(&GLOBAL_PARAMS),
    interrupt: Table::new(&INTERRUPT_PARAMS),
    user_variables: 256,
    stored_user_variables: 56,
    coordinates: 20,
    // §1: "memory for up to 1024 TMCL commands".
    program_memory: 1024,
    ports: &PORTS,
    interrupts: Interrupts::new(&INTERRUPTS),
    inputs: 8,
    outputs: 8,
    interfaces: &[USB, InterfaceDesc::ETHERCAT_MAILBOX],
    ethercat: Some(&ETHERCAT),
    commands: COMMANDS,
    // §5: "ROL, ROR, MST, MVP, SAP, GAP, STAP, RSAP, SGP, GGP, STGP, RSGP, RFS, SIO, GIO, SCO, GCO, CCO,
    // UF0–UF7", the PD28-1021's list.
    ascii_commands: COMMANDS.ascii_subset(),
    host_vect: false,
    app_status: AppStatusReply::Typed,
    banks: GlobalBanks::ARM,
    kinematics: Kinematics::Pps,
    reference_modes: ReferenceModes::Pd28,
    // The TMC262 (front page of the CoE manual of the same board); closed loop is firmware.
    driver: Driver::Tmc262,
    // §1: A/B/N or SSI; by default an A/B/N encoder of 4096 counts per revolution (AP 210's default).
    encoder: Some(Encoder { kind: EncoderKind::Abn, counts_per_rev: 4096 }),
    // §1: up to 3 A RMS, 4.24 A peak, one range.
    peak_current_ma: [4243, 4243],
    password: Some(4321),
    manual: "TMCM-1310 TMCL firmware manual V1.14 (Rev. 1.17)",
};

/// The TMCM-1310 with firmware V1.14.
pub static SPEC: ModelSpec = ModelSpec::new(DESC);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_sorted_and_unique() {
        for table in [&AXIS_PARAMS[..], &GLOBAL_PARAMS[..], &INTERRUPT_PARAMS[..]] {
            assert!(table.windows(2).all(|w| w[0].number < w[1].number));
        }
    }

    #[test]
    fn the_manuals_numbers_are_there() {
        for n in [0, 1, 2, 3, 14, 18, 123, 131, 193, 209, 230, 233] {
            assert!(SPEC.axis.contains(n), "AP {n} (manual §3.4 / §10.1.1)");
        }
        // The TMCM-1311 closed-loop set that pytrinamic's demo uses.
        for n in [129, 132, 133, 202, 210] {
            assert!(SPEC.axis.contains(n), "AP {n}");
        }
        assert!(!SPEC.axis.contains(179), "no sense-range switch");
    }

    #[test]
    fn defaults_are_in_range() {
        for d in AXIS_PARAMS.iter().chain(&GLOBAL_PARAMS).chain(&INTERRUPT_PARAMS) {
            assert!(d.range.contains(d.default) || !d.access.write, "{} default {}", d.name, d.default);
        }
    }

    #[test]
    fn process_data_by_meaning_lands_on_the_manuals_numbers() {
        // §3.4 names the parameters by number; the map names them by role: the same twelve.
        let numbers: Vec<u8> = ETHERCAT
            .inputs
            .iter()
            .filter_map(|e| match e.source {
                InputSource::Param(role) => SPEC.axis.role(role).map(|i| SPEC.axis.params[i].number),
                InputSource::ErrorAndDriverFlags => None,
            })
            .collect();
        assert_eq!(numbers, [0, 1, 233, 209, 2, 3, 131, 18, 123, 14, 230]);
        assert_eq!(ETHERCAT.inputs_len(), 48);
    }

    #[test]
    fn version() {
        assert_eq!(DESC.version_binary.to_be_bytes(), [0x05, 0x1E, 1, 14]);
        assert_eq!(&DESC.version_string, b"1310V114");
    }
}

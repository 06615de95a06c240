//! The TMCM-1140: one axis, a TMC429 motion controller and a TMC262 driver with stallGuard2 and
//! coolStep, a sensOstep encoder, USB, RS485 and CAN, following the TMCM-1140 TMCL firmware manual
//! V1.27 (Rev. 1.03, 2013-SEP-02).
//!
//! # Sources, in order of authority
//!
//! - The firmware manual V1.27 ("1140 manual"): its table of contents (the command set of §3.4, the
//!   ASCII interface of §3.5, interrupts, axis parameters, global parameters), the firmware version it
//!   documents (1.27), 2 A RMS and 24 V, sensOstep, USB/RS485/CAN (front page).
//! - The TMCM-1140 hardware manual (Rev. 1.01, §8.1): the TMC429 at 16 MHz, velocities and
//!   accelerations 0…2047, pulse and ramp divisors 0…13, the formulas of [`Kinematics::Tmc428`].
//! - pytrinamic's `TMCM1140` class ("pytrinamic TMCM1140"): the numbers and names of the axis
//!   parameters (0–13, 130, 138, 140, 141, 149, 150, 153, 154, 160–184, 193–197, 200, 204, 206–210,
//!   212, 214, 215), bank 0 (65–71, 75–77, 79, 81–85, 87, 90, 128, 130, 132, 133, 255), bank 3 (timers
//!   0–2, stop switches 27/28, inputs 39–42) and the I/O (IN0–IN3, OUT0, OUT1); the TMCL-IDE parameter
//!   list of the TMCM-1140 (as the tmcl_ros2 project generated it) adds GP 67 and 129.
//! - The TMC429/TMC262 firmware Trinamic published for the TMCM-1110 (TMCL-LITE-1110, the same chip
//!   pair on a sibling board, "TMC429 firmware"): what each parameter does to the two chips (AP 8 from
//!   the TMC429's status, AP 140 the TMC262's microstep resolution 0…8 = full step … 256, AP 12/13 the
//!   TMC429's stop-switch disables, AP 153/154 the divisors), the start values, and the binary version:
//!   the module number in the high word, then the firmware's major and minor number.
//! - Where the ARM-generation manuals agree with each other, the PD28-1021 manual (TMC262 chopper,
//!   smartEnergy and stallGuard2 AP 160–184, reference search AP 193–197 with the modes 1–8, encoder
//!   AP 209/210/215, bank 0 and bank 3), cited as "PD28-1021 … (as TMCM-1140)".
//!
//! # Decisions (also in docs/tmcm-1140.md)
//!
//! - **Units**: velocities (AP 2, 3, 4, 130, 181, 182, 194, 195) are TMC429 units 0…2047 scaled by the
//!   pulse divisor AP 154, the acceleration AP 5 by both divisors, as on the PDx-113; positions are
//!   24-bit (−2^23 … 2^23 − 1, the TMC429's counters).
//! - **Start values** are the TMC429 firmware's: AP 4 = 1000, AP 5 = 500, pulse divisor 2, ramp
//!   divisor 3, run current 255, standby current 32, power-down delay 200 (2 s); 256 microsteps (the
//!   TMC262's MRES 0, AP 140 = 8). The TMC262's chopper start values are the PD28-1021 model's.
//! - **Interfaces**: USB first — on a pty the module is reached as through its USB port, which answers
//!   every address, as instrument software reaches it — then RS485 (address filter GP 66/87, telegram
//!   pause GP 75); `tmcl serve --interface rs485` serves the RS485 port instead ([`on_interface`]).
//!   CAN is not simulated: its settings (GP 69–71, 82, 83) are kept and stored, with no effect.
//! - **Version**: 136 type 0 is `1140V127`; type 1 is 0x0474011B: 1140 in the high word, then 1 and 27.
//! - **Not provided** (status 3; the simulation has nothing they could read): AP 135 (the TMC429's
//!   actual acceleration), AP 216–218 (an external encoder), GP 131 (last TMCL error, only in later
//!   firmware's IDE lists).
//! - **Stored only** (kept, read back, stored where E): AP 141 (reference switch tolerance: the
//!   TMC429's three-switch mode tolerance), AP 149 (soft stop flag: the module stops at a switch as the
//!   core's switches do), AP 150 (end switch power down).
//!
//! [`on_interface`]: crate::on_interface

use crate::interface::InterfaceDesc;
use crate::interrupt::Interrupts;
use crate::param::{cited, join, Access, ParamDesc, Range, Role, Setting, Table, Unit};
use crate::pd28_1021;
use crate::port::{PortDesc, PortKind};
use crate::variant::{AppStatusReply, Driver, Encoder, EncoderKind, GlobalBanks, Kinematics, ReferenceModes};
use crate::{ModelDesc, ModelSpec};
use tmcl_wire::CommandSet;

/// pytrinamic's `TMCM1140` class.
const PY: &str = "pytrinamic TMCM1140";
/// The TMCM-1140 hardware manual §8.1 (the TMC429's units).
const HW: &str = "TMCM-1140 hardware manual §8.1";
/// The TMC429/TMC262 firmware of the TMCM-1110 (the same chip pair).
const L11: &str = "TMC429 firmware (TMCM-1110)";
/// The ARM-generation TMC262 and reference-search parameters, as the PD28-1021 manual documents them.
const P28: &str = "PD28-1021 §4 Table 15 (as TMCM-1140)";
/// Bank 0 as the PD28-1021 manual documents it.
const G28: &str = "PD28-1021 §5.1 Table 17 (as TMCM-1140)";
/// Bank 3 as the PD28-1021 manual documents it.
const I28: &str = "PD28-1021 §5.4 Table 19 (as TMCM-1140)";

/// −2^23 … 2^23 − 1: the TMC429's 24-bit position counters.
pub(crate) const POS24: Range = Range::Signed(-(1 << 23), (1 << 23) - 1);
/// TMC429 velocities 0…2047 (hardware manual §8.1).
pub(crate) const V: Range = Range::Signed(0, 2047);
/// Signed TMC429 velocities.
pub(crate) const VS: Range = Range::Signed(-2047, 2047);
const CURRENT: Range = Range::Signed(0, 255);
const fn r(min: i32, max: i32) -> Range {
    Range::Signed(min, max)
}

/// AP 0–13, 130–154: the TMC429's motion parameters (one axis).
pub(crate) const MOTION: [ParamDesc; 22] = [
    ParamDesc::plain(0, "Target (next) position", "TargetPosition", POS24, Access::RW, 0, PY)
        .with_role(Role::TargetPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(1, "Actual position", "ActualPosition", POS24, Access::RW, 0, PY)
        .with_role(Role::ActualPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(2, "Target (next) speed", "TargetVelocity", VS, Access::RW, 0, PY)
        .with_role(Role::TargetSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(3, "Actual speed", "ActualVelocity", VS, Access::R, 0, PY)
        .with_role(Role::ActualSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(4, "Maximum positioning speed", "MaxVelocity", V, Access::RWE, 1000, L11)
        .with_setting(Setting::MaxPositioningSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(5, "Maximum acceleration", "MaxAcceleration", V, Access::RWE, 500, L11)
        .with_setting(Setting::MaxAcceleration)
        .with_unit(Unit::Tmc428Acceleration),
    ParamDesc::plain(6, "Absolute max. current", "MaxCurrent", CURRENT, Access::RWE, 255, L11)
        .with_setting(Setting::RunCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(7, "Standby current", "StandbyCurrent", CURRENT, Access::RWE, 32, L11)
        .with_setting(Setting::StandbyCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(8, "Target position reached", "PositionReachedFlag", Range::FLAG, Access::R, 1, PY)
        .with_role(Role::PositionReached),
    // The home switch input (the board's third reference switch input beside STOP_L and STOP_R).
    ParamDesc::plain(9, "Reference switch status", "ReferenceSwitchStatus", Range::FLAG, Access::R, 0, PY)
        .with_role(Role::HomeSwitch),
    ParamDesc::plain(10, "Right limit switch status", "RightEndstop", Range::FLAG, Access::R, 0, PY)
        .with_role(Role::RightSwitch),
    ParamDesc::plain(11, "Left limit switch status", "LeftEndstop", Range::FLAG, Access::R, 0, PY)
        .with_role(Role::LeftSwitch),
    ParamDesc::plain(12, "Right limit switch disable", "RightLimitSwitchDisable", Range::FLAG, Access::RWE, 0, PY)
        .with_setting(Setting::RightSwitchDisable),
    ParamDesc::plain(13, "Left limit switch disable", "LeftLimitSwitchDisable", Range::FLAG, Access::RWE, 0, PY)
        .with_setting(Setting::LeftSwitchDisable),
    // The TMC429's v_min, which its firmware keeps at 1.
    ParamDesc::plain(130, "Minimum speed", "MinimumSpeed", V, Access::RWE, 1, L11)
        .with_setting(Setting::MinimumSpeed)
        .with_unit(Unit::Tmc428Velocity),
    // 0 position, 1 soft, 2 velocity (the TMC429's ramp modes); ROR/ROL/MST set 2, MVP sets 0.
    ParamDesc::plain(138, "Ramp mode", "RampMode", r(0, 2), Access::RWE, 0, PY).with_role(Role::RampModeTmc428),
    // The TMC262's microstep resolution: 0 full step … 8 = 256 microsteps (the firmware writes 8 − value
    // to MRES); 256 at the start (MRES 0).
    ParamDesc::plain(140, "Microstep resolution", "MicrostepResolution", r(0, 8), Access::RWE, 8, L11)
        .with_role(Role::MicrostepResolution),
    ParamDesc::plain(141, "Reference switch tolerance", "ReferenceSwitchTolerance", r(0, 4095), Access::RW, 0, PY)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(149, "Soft stop flag", "SoftStopFlag", Range::FLAG, Access::RWE, 0, PY),
    ParamDesc::plain(150, "End switch power down mode", "EndSwitchPowerDown", Range::FLAG, Access::RWE, 0, PY),
    ParamDesc::plain(153, "Ramp divisor", "RampDivisor", r(0, 13), Access::RWE, 3, HW)
        .with_setting(Setting::RampDivisor),
    ParamDesc::plain(154, "Pulse divisor", "PulseDivisor", r(0, 13), Access::RWE, 2, HW)
        .with_setting(Setting::PulseDivisor),
];

/// AP 160–180: the TMC262's step interpolation, chopper, smartEnergy and stallGuard2 settings.
pub(crate) const TMC262_A: [ParamDesc; 21] = cited(&pd28_1021::AXIS_PARAMS, 160, 180, P28);
/// AP 181, 182 in TMC429 velocity units (the TMC429 firmware compares them with the TMC429's speed).
pub(crate) const TMC262_SPEEDS: [ParamDesc; 2] = [
    ParamDesc::plain(181, "Stop on stall", "SmartEnergyStallVelocity", V, Access::RW, 0, PY)
        .with_setting(Setting::StopOnStall)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(182, "smartEnergy threshold speed", "SmartEnergyThresholdSpeed", V, Access::RW, 0, PY)
        .with_setting(Setting::CoolStepThresholdSpeed)
        .with_unit(Unit::Tmc428Velocity),
];
/// AP 183, 184: slow-run current, random TOff.
pub(crate) const TMC262_B: [ParamDesc; 2] = cited(&pd28_1021::AXIS_PARAMS, 183, 184, P28);
/// AP 193: the modes 1–8 with +64/+128 of the ARM-generation firmware.
pub(crate) const REF_MODE: [ParamDesc; 1] = cited(&pd28_1021::AXIS_PARAMS, 193, 193, P28);
/// AP 194, 195 in TMC429 velocity units.
pub(crate) const REF_SPEEDS: [ParamDesc; 2] = [
    ParamDesc::plain(194, "Reference search speed", "ReferenceSearchSpeed", V, Access::RWE, 500, PY)
        .with_setting(Setting::ReferenceSearchSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(195, "Reference switch speed", "ReferenceSwitchSpeed", V, Access::RWE, 50, PY)
        .with_setting(Setting::ReferenceSwitchSpeed)
        .with_unit(Unit::Tmc428Velocity),
];
/// AP 196, 197: what a reference search found (microsteps).
pub(crate) const REF_RESULTS: [ParamDesc; 2] = cited(&pd28_1021::AXIS_PARAMS, 196, 197, P28);
/// AP 200: boost current.
pub(crate) const BOOST: [ParamDesc; 1] = cited(&pd28_1021::AXIS_PARAMS, 200, 200, P28);
/// AP 204–215: freewheeling, load value, error flags, the sensOstep encoder, power-down delay.
pub(crate) const TAIL: [ParamDesc; 9] = cited(&pd28_1021::AXIS_PARAMS, 204, 215, P28);

/// Axis parameters: 62 entries.
pub static AXIS_PARAMS: [ParamDesc; 62] =
    join(&[&MOTION, &TMC262_A, &TMC262_SPEEDS, &TMC262_B, &REF_MODE, &REF_SPEEDS, &REF_RESULTS, &BOOST, &TAIL]);

const G_SERIAL: [ParamDesc; 4] = cited(&pd28_1021::GLOBAL_PARAMS, 65, 68, G28);
/// The CAN settings: kept and stored (auto, as every bank 0 parameter of 64…128), no CAN simulated.
/// Start values: 1000 kbit/s, send ID 2, receive ID 1 (the TMC429 firmware's).
const G_CAN: [ParamDesc; 3] = [
    ParamDesc::plain(69, "CAN bit rate", "CANBitRate", r(2, 8), Access::RWA, 8, PY),
    ParamDesc::plain(70, "CAN reply ID", "CANsendID", r(0, 0x7FF), Access::RWA, 2, PY),
    ParamDesc::plain(71, "CAN ID", "CANreceiveID", r(0, 0x7FF), Access::RWA, 1, PY),
];
const G_HOST: [ParamDesc; 5] = cited(&pd28_1021::GLOBAL_PARAMS, 75, 81, G28);
const G_CAN2: [ParamDesc; 2] = [
    ParamDesc::plain(82, "CAN heartbeat", "CANHeartbeat", r(0, 65535), Access::RWA, 0, PY)
        .with_unit(Unit::Milliseconds),
    ParamDesc::plain(83, "CAN secondary address", "CANSecondaryAddress", r(0, 0x7FF), Access::RWA, 0, PY),
];
const G_REST: [ParamDesc; 10] = cited(&pd28_1021::GLOBAL_PARAMS, 84, 255, G28);

/// Bank 0: 24 entries.
pub static GLOBAL_PARAMS: [ParamDesc; 24] = join(&[&G_SERIAL, &G_CAN, &G_HOST, &G_CAN2, &G_REST]);

/// Bank 3: timers 0–2, the stop switches 27/28, inputs 0–3 (pytrinamic's `GP3`, the PD28-1021's
/// numbering and transitions).
pub static INTERRUPT_PARAMS: [ParamDesc; 9] = cited(&pd28_1021::INTERRUPT_PARAMS, 0, 42, I28);

/// I/O ports (pytrinamic's `IO`): IN0–IN3 digital on bank 0, IN0 also analog (12 bits) on bank 1,
/// OUT0 and OUT1 on bank 2.
pub static PORTS: [PortDesc; 9] = [
    PortDesc { bank: 0, port: 0, kind: PortKind::DigitalInput(0), name: "IN0" },
    PortDesc { bank: 0, port: 1, kind: PortKind::DigitalInput(1), name: "IN1" },
    PortDesc { bank: 0, port: 2, kind: PortKind::DigitalInput(2), name: "IN2" },
    PortDesc { bank: 0, port: 3, kind: PortKind::DigitalInput(3), name: "IN3" },
    PortDesc { bank: 0, port: 255, kind: PortKind::AllInputs, name: "all digital inputs" },
    PortDesc { bank: 1, port: 0, kind: PortKind::Analog(0), name: "analog IN0" },
    PortDesc { bank: 2, port: 0, kind: PortKind::Output(0), name: "OUT0" },
    PortDesc { bank: 2, port: 1, kind: PortKind::Output(1), name: "OUT1" },
    PortDesc { bank: 2, port: 255, kind: PortKind::AllOutputs, name: "all outputs" },
];

/// The USB port: 9-byte frames and ASCII mode, every address byte answered (a USB link has one module);
/// the reply carries the module's address.
pub const USB: InterfaceDesc = InterfaceDesc {
    name: "usb",
    kind: crate::InterfaceKind::Usb,
    framing: crate::Framing::Binary,
    address_filter: false,
    ascii: true,
    telegram_pause: false,
    suppressible: true,
};

/// The commands: the ARM generation's set (1140 manual §3.4, as the PD28-1021's §3.5 Table 5), without
/// SAC, which the TMC429 of this generation keeps to itself.
pub const COMMANDS: CommandSet = pd28_1021::COMMANDS;

/// The TMCM-1140 with firmware V1.27, as a description (USB first).
pub const DESC: ModelDesc = ModelDesc {
    id: "tmcm-1140",
    name: "TMCM-1140",
    version_string: *b"1140V127",
    version_binary: (1140 << 16) | (1 << 8) | 27,
    eeprom_tag: 1140,
    motors: 1,
    axis: Table::new(&AXIS_PARAMS),
    global: Table::new(&GLOBAL_PARAMS),
    interrupt: Table::new(&INTERRUPT_PARAMS),
    user_variables: 256,
    // As the PD28-1021 (§5.3): the first 56 can be stored.
    stored_user_variables: 56,
    coordinates: 20,
    // The ARM-generation firmware's 2048 TMCL commands.
    program_memory: 2048,
    ports: &PORTS,
    interrupts: Interrupts::new(&pd28_1021::INTERRUPTS),
    inputs: 4,
    outputs: 2,
    interfaces: &[USB, InterfaceDesc::RS485],
    ethercat: None,
    commands: COMMANDS,
    ascii_commands: COMMANDS.ascii_subset(),
    host_vect: false,
    app_status: AppStatusReply::Typed,
    banks: GlobalBanks::ARM,
    // The TMC429 at 16 MHz (hardware manual §8.1).
    kinematics: Kinematics::Tmc428 { clock_hz: 16_000_000 },
    reference_modes: ReferenceModes::Pd28,
    driver: Driver::Tmc262,
    // sensOstep, 1024 counts per revolution (AP 215: 0…1023).
    encoder: Some(Encoder { kind: EncoderKind::SensOstep, counts_per_rev: 1024 }),
    // 2 A RMS (2.83 A peak) in the high sense range; the TMC262's low range (AP 179 = 1, the start value)
    // gives 0.165/0.305 of it.
    peak_current_ma: [1530, 2830],
    password: None,
    manual: "TMCM-1140 TMCL firmware manual V1.27 (Rev. 1.03)",
};

/// The TMCM-1140 with firmware V1.27, on its USB port.
pub static SPEC: ModelSpec = ModelSpec::new(DESC);

/// The same module served on its RS485 port (`tmcl serve --interface rs485`): on a bus with others.
pub static SPEC_RS485: ModelSpec = ModelSpec::new(ModelDesc { interfaces: &[InterfaceDesc::RS485, USB], ..DESC });

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
    fn defaults_are_in_range() {
        for d in AXIS_PARAMS.iter().chain(&GLOBAL_PARAMS).chain(&INTERRUPT_PARAMS) {
            assert!(d.range.contains(d.default) || !d.access.write, "{} default {}", d.name, d.default);
        }
    }

    /// Every axis parameter pytrinamic's `TMCM1140` names is in the table, but the three the module
    /// documents as not provided.
    #[test]
    fn pytrinamics_numbers_are_there() {
        let pytrinamic = [
            0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 130, 135, 138, 140, 141, 149, 150, 153, 154, 160, 161, 162,
            163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175, 176, 177, 178, 179, 180, 181, 182, 183,
            184, 193, 194, 195, 196, 197, 200, 204, 206, 207, 208, 209, 210, 212, 214, 215, 216, 217, 218,
        ];
        let missing: Vec<u8> = pytrinamic.into_iter().filter(|n| !SPEC.axis.contains(*n)).collect();
        assert_eq!(missing, [135, 216, 217, 218]);
        for n in [65, 66, 68, 69, 70, 71, 75, 76, 77, 79, 81, 82, 83, 84, 85, 87, 90, 128, 130, 132, 133, 255] {
            assert!(SPEC.global.contains(n), "GP {n}");
        }
        for n in [0, 1, 2, 27, 28, 39, 40, 41, 42] {
            assert!(SPEC.interrupt.contains(n), "bank 3 {n}");
        }
    }

    #[test]
    fn version() {
        assert_eq!(DESC.version_binary.to_be_bytes(), [0x04, 0x74, 1, 27]);
        assert_eq!(&DESC.version_string, b"1140V127");
    }

    #[test]
    fn usb_first_rs485_on_request() {
        assert!(!SPEC.interfaces[0].address_filter);
        assert!(SPEC_RS485.interfaces[0].address_filter);
        assert_eq!(SPEC.layout(), SPEC_RS485.layout(), "the same EEPROM either way");
    }
}

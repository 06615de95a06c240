//! The PDx-113-57/60-SE PANdrive and its electronics, the TMCM-113-60-SE: the TMC428 generation,
//! following the PDx-113-57/60-SE TMCL firmware manual V1.04 (2011-SEP-03).
//!
//! # Sources, in order of authority
//!
//! The manual in hand ("113 §…") holds chapters 1–5.7.17: features (§2), the protocol (§5.1–5.2), the
//! command overview (§5.4, §5.5), the ASCII interface (§5.6) and the commands ROR … COMP (§5.7.1–5.7.17);
//! it is cut off before the axis and global parameter chapters (6, 7). What it names the tables take as
//! it is:
//! - AP 1 (actual position: the GAP example of §5.7.6 and the COMP example of §5.7.17), AP 4 and AP 5
//!   (§5.7.4: "axis parameters #4 and #5"; §4.2 `SAP 4, 0, 1000`), AP 6 (§5.7.5: I_RMS = value ·
//!   2.8 A / 255);
//! - velocities 0…2047 (§5.7.1), positions −2^23 … 2^23 − 1 (§5.7.4), up to 16 microsteps and a
//!   sensOstep encoder of 256 increments per rotation (§2), 2048 commands of program memory (§2, §5);
//! - GP 66 (§5.7.9, §5.7.10), GP 67 (§5.6.4), bank 2 user variables (§5.7.11, §5.7.12);
//! - the ports of §5.7.14–5.7.15 (IN_0, IN_1 digital on bank 0 and 10-bit analog on bank 1; OUT_0,
//!   OUT_1 on bank 2).
//!
//! The manual's older revision (V1.10, 2009) gives AP 0–5 (p.25) and AP 203–211 (p.32). The rest of the
//! TMC428-generation set comes from the siblings' tables: the TMCL reference of the TMC428 generation
//! (the TMCM-110/111/3xx axis and global parameter tables, "TMC428 ref."), the TMCM-142 manual (AP 193's
//! three modes), the TMCM-111-56 manual (the divisors' start values), and the TMC429 firmware of the
//! TMCM-1110 (TMCL-LITE, its start values). Each entry names its source.
//!
//! # Decisions (also in docs/decisions.md, "The PDx-113")
//!
//! - **AP 0 and AP 2.** §5.7.1 says ROR writes "axis parameter #0 (target velocity)" and §5.7.4 that MVP
//!   writes "#2 target position": the reverse of the V1.10 table (p.25: 0 target position, 2 target
//!   speed), of every sibling and of the PD28-1021. The table wins: 0 is the target position, 2 the
//!   target speed. The two sentences are read as misprints; no host could use them otherwise.
//! - **Units.** Velocities (AP 2, 3, 4, 130, 194, 195) are TMC428 units 0…2047, scaled by the pulse
//!   divisor AP 154; the acceleration AP 5 by both divisors (AP 153, 154): [`Kinematics::Tmc428`] has
//!   the formulas. Start values: pulse divisor 3 and ramp divisor 7 (the TMCM-111-56, the PANdrive
//!   sibling of the same generation), AP 4 = 1000 (the manual's own `SAP 4, 0, 1000`, §4.2: 30 518
//!   microsteps/s) and AP 5 = 500 (TMCL-LITE-1110's start value: 232 831 microsteps/s²).
//! - **Microsteps.** AP 140 0…4 = full, half, 4, 8, 16 microsteps (the TMC428's usrs; §2: "up to 16
//!   microsteps"); 4 at the start.
//! - **Ramp mode** AP 138 (TMC428 ref.): 0 position, 1 soft, 2 velocity. ROR/ROL/MST set 2, MVP sets 0.
//!   The soft mode's exponential approach is not simulated: 1 moves like 0.
//! - **Reference search.** AP 193 1…3 (TMCM-142, TMC428 ref.); the speeds AP 194/195 in velocity units
//!   0…2047, as on the TMC429 modules (the manual names the TMC428/429); AP 196 the switch distance.
//! - **Encoder.** AP 209: the sensOstep position within one rotation, 0…255 (V1.10 p.32).
//! - **Stored only** (kept and read back, no effect in the simulation): AP 203 mixed decay threshold and
//!   AP 211 fullstep threshold (the TMC249's chopper), AP 205 stall detection threshold.
//! - **Not provided** (status 3, as the manual's missing chapters give a host no way to know them): the
//!   TMC428's acceleration internals (AP 135–137, 146), the current-control percentages (AP 143–145),
//!   the interrupt parameters (AP 139, 152), AP 206 (stallGuard load 0…7) and AP 208 (TMC249 error
//!   flags), AP 210 (encoder prescaler), the EEPROM lock GP 73 and bank 1's parameters.
//! - **Version.** 136 type 0 is `113V1.04`: the module number, `V`, and the firmware revision the manual
//!   documents (V1.04), with its dot, which fills the eight characters a three-digit module number leaves;
//!   type 1 is 0x010D0104: the module number as digit pairs (01, 13), then 1 and 4, as the PD28-1021's.
//! - **Interface.** One serial port, RS485 or RS232 by hardware version (§2); the frames, the reply and
//!   the address byte are the same on both (§5.1, §5.2), so one interface serves both: address filter
//!   (GP 66), ASCII mode (§5.6), telegram pause (GP 75, TMC428 ref.). Baud rates GP 65 0…7 = 9600 …
//!   115200 (TMC428 ref.); 9600 at the start (§4.1).
//! - **Commands.** §5.4 and §5.5 list them: no EI, DI, VECT, RETI (no interrupts), no ACO, no 138, no
//!   255, no 242 (none of them in any list): status 2. 135 answers the state alone (§5.5).

use crate::interface::InterfaceDesc;
use crate::interrupt::Interrupts;
use crate::param::{Access, ParamDesc, Range, Role, Setting, Table, Unit};
use crate::port::{PortDesc, PortKind};
use crate::variant::{AppStatusReply, Driver, Encoder, EncoderKind, GlobalBanks, Kinematics, ReferenceModes};
use crate::{ModelDesc, ModelSpec};
use tmcl_wire::{CommandSet, Opcode};

/// Its older revision, V1.10: the axis parameter table p.25 (AP 0–5) and p.32 (AP 203–211).
const V25: &str = "113 manual V1.10 p.25";
const V32: &str = "113 manual V1.10 p.32";
/// The TMCL reference of the TMC428 generation (TMCM-110/111/3xx axis and global parameter tables).
const REF: &str = "TMC428 ref.";
/// The TMCM-142 manual's AP 193.
const T142: &str = "TMCM-142 manual (AP 193)";
/// The TMC429 modules (TMCL-LITE-1110, PyStepRocker): 11-bit reference speeds.
const T429: &str = "TMC429 modules (TMCM-1110)";

/// −2^23 … 2^23 − 1 (§5.7.4).
const POS24: Range = Range::Signed(-(1 << 23), (1 << 23) - 1);
/// Velocities 0…2047 (§5.7.1).
const V: Range = Range::Signed(0, 2047);
const VS: Range = Range::Signed(-2047, 2047);
const CURRENT: Range = Range::Signed(0, 255);
const fn r(min: i32, max: i32) -> Range {
    Range::Signed(min, max)
}

/// Axis parameters of motor 0: 30 entries.
pub static AXIS_PARAMS: [ParamDesc; 30] = [
    // §5.7.1 and §5.7.4 swap AP 0 and AP 2; the V1.10 table (p.25) is followed (module docs).
    ParamDesc::plain(0, "Target (next) position", "TargetPosition", POS24, Access::RW, 0, V25)
        .with_role(Role::TargetPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(1, "Actual position", "ActualPosition", POS24, Access::RW, 0, "113 §5.7.6")
        .with_role(Role::ActualPosition)
        .with_unit(Unit::Microsteps),
    ParamDesc::plain(2, "Target (next) speed", "TargetSpeed", VS, Access::RW, 0, V25)
        .with_role(Role::TargetSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(3, "Actual speed", "ActualSpeed", VS, Access::R, 0, V25)
        .with_role(Role::ActualSpeed)
        .with_unit(Unit::Tmc428Velocity),
    // §4.2: `SAP 4, 0, 1000 //Set the maximum speed`; 1000 is the start value.
    ParamDesc::plain(4, "Maximum positioning speed", "MaxPositioningSpeed", V, Access::RWE, 1000, "113 §5.7.4")
        .with_setting(Setting::MaxPositioningSpeed)
        .with_unit(Unit::Tmc428Velocity),
    // TMCL-LITE-1110's start value 500.
    ParamDesc::plain(5, "Maximum acceleration", "MaxAcceleration", V, Access::RWE, 500, "113 §5.7.4")
        .with_setting(Setting::MaxAcceleration)
        .with_unit(Unit::Tmc428Acceleration),
    // §5.7.5: I_RMS = value · 2.8 A / 255; half of it at the start (as the PD28-1021).
    ParamDesc::plain(6, "Absolute max. current", "AbsMaxCurrent", CURRENT, Access::RWE, 128, "113 §5.7.5")
        .with_setting(Setting::RunCurrent)
        .with_unit(Unit::CurrentOf255),
    // TMCL-LITE-1110's start value 32.
    ParamDesc::plain(7, "Standby current", "StandbyCurrent", CURRENT, Access::RWE, 32, REF)
        .with_setting(Setting::StandbyCurrent)
        .with_unit(Unit::CurrentOf255),
    ParamDesc::plain(8, "Target position reached", "TargetPosReached", Range::FLAG, Access::R, 1, REF)
        .with_role(Role::PositionReached),
    ParamDesc::plain(9, "Reference switch status", "RefSwitchStatus", Range::FLAG, Access::R, 0, REF)
        .with_role(Role::HomeSwitch),
    ParamDesc::plain(10, "Right limit switch status", "RightLimitSwitchStatus", Range::FLAG, Access::R, 0, REF)
        .with_role(Role::RightSwitch),
    ParamDesc::plain(11, "Left limit switch status", "LeftLimitSwitchStatus", Range::FLAG, Access::R, 0, REF)
        .with_role(Role::LeftSwitch),
    ParamDesc::plain(12, "Right limit switch disable", "RightLimitSwitchDisable", Range::FLAG, Access::RWE, 0, REF)
        .with_setting(Setting::RightSwitchDisable),
    ParamDesc::plain(13, "Left limit switch disable", "LeftLimitSwitchDisable", Range::FLAG, Access::RWE, 0, REF)
        .with_setting(Setting::LeftSwitchDisable),
    // The TMC428's v_min: "keep 1" (TMC428 ref.; TMCL-LITE-1110 writes 1 at start).
    ParamDesc::plain(130, "Minimum speed", "MinimumSpeed", V, Access::RWE, 1, REF)
        .with_setting(Setting::MinimumSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(138, "Ramp mode", "RampMode", r(0, 2), Access::RW, 0, REF).with_role(Role::RampModeTmc428),
    // §2: "up to 16 microsteps": 0 full step … 4 sixteenth steps.
    ParamDesc::plain(140, "Microstep resolution", "MicrostepResolution", r(0, 4), Access::RWE, 4, REF)
        .with_role(Role::MicrostepResolution),
    // TMCM-111-56 start values: ramp divisor 7, pulse divisor 3.
    ParamDesc::plain(153, "Ramp divisor", "RampDivisor", r(0, 13), Access::RWE, 7, REF)
        .with_setting(Setting::RampDivisor),
    ParamDesc::plain(154, "Pulse divisor", "PulseDivisor", r(0, 13), Access::RWE, 3, REF)
        .with_setting(Setting::PulseDivisor),
    ParamDesc::plain(193, "Reference search mode", "ReferencingMode", r(1, 3), Access::RWE, 1, T142)
        .with_setting(Setting::ReferenceSearchMode),
    ParamDesc::plain(194, "Reference search speed", "ReferencingSearchSpeed", V, Access::RWE, 500, T429)
        .with_setting(Setting::ReferenceSearchSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(195, "Reference switch speed", "ReferencingSwitchSpeed", V, Access::RWE, 50, T429)
        .with_setting(Setting::ReferenceSwitchSpeed)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(196, "Distance end switches", "DistanceEndSwitches", POS24, Access::R, 0, REF)
        .with_setting(Setting::EndSwitchDistance)
        .with_unit(Unit::Microsteps),
    // "0…2048 or −1" (−1: permanent mixed decay); the TMC249's chopper, stored only.
    ParamDesc::plain(203, "Mixed decay threshold", "MixedDecayThreshold", r(-1, 2048), Access::RWE, 2048, V32)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(204, "Freewheeling", "FreewheelingDelay", r(0, 65535), Access::RWE, 0, V32)
        .with_setting(Setting::FreewheelingDelay)
        .with_unit(Unit::TenMilliseconds),
    // 0 = off; stored only (the first stallGuard's 0…7 load is not simulated).
    ParamDesc::plain(205, "Stall detection threshold", "StallDetectionThreshold", r(0, 7), Access::RWE, 0, V32),
    ParamDesc::plain(209, "Encoder position", "EncoderPosition", r(0, 255), Access::R, 0, V32)
        .with_role(Role::EncoderAbsolute)
        .with_unit(Unit::EncoderCounts),
    // "0 or > 2047 disables"; the TMC249's fullstep switch-over, stored only.
    ParamDesc::plain(211, "Fullstep threshold", "FullstepThreshold", r(0, 2048), Access::RWE, 0, V32)
        .with_unit(Unit::Tmc428Velocity),
    ParamDesc::plain(212, "Maximum encoder deviation", "MaxEncoderDeviation", r(0, 65535), Access::RWE, 0, REF)
        .with_setting(Setting::MaxEncoderDeviation)
        .with_unit(Unit::EncoderCounts),
    // Standby "2 s after stop" (TMC428 ref., AP 7).
    ParamDesc::plain(214, "Power down delay", "PowerDownDelay", r(1, 65535), Access::RWE, 200, REF)
        .with_setting(Setting::PowerDownDelay)
        .with_unit(Unit::TenMilliseconds),
];

/// Bank 0 (the TMC428 generation's global parameters, TMC428 ref.; GP 66 and 67 from the manual).
pub static GLOBAL_PARAMS: [ParamDesc; 11] = [
    // 0…7 = 9600, 14400, 19200, 28800, 38400, 57600, 76800, 115200; 9600 at the start (§4.1).
    ParamDesc::plain(65, "Serial baud rate", "BaudRate", r(0, 7), Access::RWA, 0, REF).with_setting(Setting::BaudRate),
    ParamDesc::plain(66, "Serial address", "SerialAddress", r(1, 255), Access::RWA, 1, "113 §5.7.9")
        .with_setting(Setting::SerialAddress),
    ParamDesc::plain(67, "ASCII mode", "AsciiMode", r(0, 63), Access::RWA, 0, "113 §5.6.4")
        .with_setting(Setting::AsciiMode),
    ParamDesc::plain(75, "Telegram pause time", "TelegramPauseTime", r(0, 255), Access::RWA, 0, REF)
        .with_setting(Setting::TelegramPause)
        .with_unit(Unit::Milliseconds),
    // Host address 2: the ASCII reply example `BA 100 -5000` (§5.6.2).
    ParamDesc::plain(76, "Serial host address", "SerialHostAddress", r(0, 255), Access::RWA, 2, REF)
        .with_setting(Setting::HostAddress),
    ParamDesc::plain(77, "Auto start mode", "AutoStartMode", Range::FLAG, Access::RWA, 0, REF)
        .with_setting(Setting::AutoStart),
    ParamDesc::plain(81, "TMCL code protection", "CodeProtection", r(0, 3), Access::RWA, 0, REF)
        .with_setting(Setting::CodeProtection),
    ParamDesc::plain(128, "TMCL application status", "ApplicationStatus", r(0, 3), Access::R, 0, REF)
        .with_role(Role::ApplicationStatus),
    ParamDesc::plain(129, "Download mode", "DownloadMode", Range::FLAG, Access::R, 0, REF)
        .with_role(Role::DownloadMode),
    ParamDesc::plain(130, "TMCL program counter", "ProgramCounter", Range::ANY, Access::R, 0, REF)
        .with_role(Role::ProgramCounter),
    ParamDesc::plain(132, "TMCL tick timer", "TickTimer", r(0, i32::MAX), Access::RW, 0, REF)
        .with_role(Role::TickTimer)
        .with_unit(Unit::Milliseconds),
];

/// I/O ports (§5.7.14, §5.7.15): IN_0 and IN_1 read digital on bank 0 and analog (10 bits) on bank 1;
/// OUT_0 and OUT_1 on bank 2.
pub static PORTS: [PortDesc; 8] = [
    PortDesc { bank: 0, port: 0, kind: PortKind::DigitalInput(0), name: "IN_0" },
    PortDesc { bank: 0, port: 1, kind: PortKind::DigitalInput(1), name: "IN_1" },
    PortDesc { bank: 0, port: 255, kind: PortKind::AllInputs, name: "all digital inputs" },
    PortDesc { bank: 1, port: 0, kind: PortKind::Analog10(0), name: "analog IN_0" },
    PortDesc { bank: 1, port: 1, kind: PortKind::Analog10(1), name: "analog IN_1" },
    PortDesc { bank: 2, port: 0, kind: PortKind::Output(0), name: "OUT_0" },
    PortDesc { bank: 2, port: 1, kind: PortKind::Output(1), name: "OUT_1" },
    PortDesc { bank: 2, port: 255, kind: PortKind::AllOutputs, name: "all outputs" },
];

/// The serial port (§5.1, §5.2): RS485 or RS232 by hardware version, the same frames and addressing.
pub const SERIAL: InterfaceDesc = InterfaceDesc {
    name: "rs485",
    kind: crate::InterfaceKind::Rs485,
    framing: crate::Framing::Binary,
    address_filter: true,
    ascii: true,
    telegram_pause: true,
    // No GP 255 on this model: nothing to suppress replies with.
    suppressible: false,
};

/// §5.4 and §5.5 (and §5.6.3 for UF0–UF7): every named command but EI, DI, VECT, RETI, ACO, 138, 242
/// and 255, which no list of the manual has.
pub const COMMANDS: CommandSet = CommandSet::ALL_NAMED
    .without(Opcode::Ei)
    .without(Opcode::Di)
    .without(Opcode::Vect)
    .without(Opcode::Reti)
    .without(Opcode::Aco)
    .without(Opcode::RequestTargetReachedEvent)
    .without(Opcode::Boot)
    .without(Opcode::SoftwareReset);

/// The PDx-113 as a description.
pub const DESC: ModelDesc = ModelDesc {
    id: "pd-113",
    name: "PDx-113-57/60-SE",
    version_string: *b"113V1.04",
    version_binary: i32::from_be_bytes([1, 13, 1, 4]),
    eeprom_tag: 113,
    motors: 1,
    axis: Table::new(&AXIS_PARAMS),
    global: Table::new(&GLOBAL_PARAMS),
    interrupt: Table::EMPTY,
    // Bank 2: TMC429 modules' 256 user variables, the first 56 storable (the TMC429 firmware, PyStepRocker).
    user_variables: 256,
    stored_user_variables: 56,
    // §5.7.4: MVP COORD takes 0..20.
    coordinates: 20,
    // §2, §5: "up to 2048 TMCL commands".
    program_memory: 2048,
    ports: &PORTS,
    interrupts: Interrupts::NONE,
    inputs: 2,
    outputs: 2,
    interfaces: &[SERIAL],
    ethercat: None,
    commands: COMMANDS,
    // §5.6.3: "ROL, ROR, MST, MVP, SAP, GAP, STAP, RSAP, SGP, GGP, STGP, RSGP, RFS, SIO, GIO, SAC, SCO,
    // GCO, CCO, UF0 … UF7".
    ascii_commands: COMMANDS.ascii_subset(),
    host_vect: false,
    app_status: AppStatusReply::Plain,
    banks: GlobalBanks::TMC428,
    // The TMC428/429 at 16 MHz (§2; the TMC428 datasheet's clock for these formulas).
    kinematics: Kinematics::Tmc428 { clock_hz: 16_000_000 },
    reference_modes: ReferenceModes::Tmc428,
    driver: Driver::Tmc428Tmc24x,
    // §2: sensOstep, 256 increments per rotation.
    encoder: Some(Encoder { kind: EncoderKind::SensOstep, counts_per_rev: 256 }),
    // §2: 2.8 A RMS, 3.96 A peak, one range.
    peak_current_ma: [3960, 3960],
    password: None,
    manual: "PDx-113-57/60-SE TMCL firmware manual V1.04",
};

/// The PDx-113 with firmware V1.04.
pub static SPEC: ModelSpec = ModelSpec::new(DESC);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_sorted_and_unique() {
        for table in [&AXIS_PARAMS[..], &GLOBAL_PARAMS[..]] {
            assert!(table.windows(2).all(|w| w[0].number < w[1].number));
        }
    }

    #[test]
    fn defaults_are_in_range() {
        for d in AXIS_PARAMS.iter().chain(&GLOBAL_PARAMS) {
            assert!(d.range.contains(d.default) || !d.access.write, "{} default {}", d.name, d.default);
        }
    }

    #[test]
    fn the_manuals_numbers_are_there() {
        for n in [0, 1, 2, 4, 5, 6, 140, 153, 154, 193, 194, 195, 203, 204, 205, 209, 211] {
            assert!(SPEC.axis.contains(n), "AP {n}");
        }
        for n in [66, 67] {
            assert!(SPEC.global.contains(n), "GP {n}");
        }
    }

    #[test]
    fn commands_of_the_manual() {
        for op in [Opcode::Sac, Opcode::Cle, Opcode::Calcx, Opcode::Aap, Opcode::Agp, Opcode::GetStatus] {
            assert!(COMMANDS.contains(op), "{op:?}");
        }
        for op in [Opcode::Ei, Opcode::Di, Opcode::Vect, Opcode::Reti, Opcode::Aco, Opcode::SoftwareReset] {
            assert!(!COMMANDS.contains(op), "{op:?}");
        }
        assert!(DESC.ascii_commands.contains(Opcode::Sac), "§5.6.3 lists SAC");
    }

    #[test]
    fn version() {
        assert_eq!(&DESC.version_string, b"113V1.04");
        assert_eq!(DESC.version_binary.to_be_bytes(), [1, 13, 1, 4]);
    }
}

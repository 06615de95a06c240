//! The TMCM-3110 (three axes) and, in [`crate::tmcm_6110`], the TMCM-6110 (six): the TMCM-1140's
//! generation with more axes — TMC429 motion controllers in their units, a TMC262 per axis with
//! stallGuard2 and coolStep, two reference switches per axis, eight inputs and eight outputs, USB, RS485
//! and CAN — as data: the core drives as many motors as the model has, each axis with its own parameters,
//! switches, ramp and interrupt sources.
//!
//! # Sources
//!
//! - The TMCM-3110 TMCL firmware manual V1.11 (Rev. 1.05, 2017-JAN-24), front page: TMC429 and TMC262,
//!   12–48 V, 8 inputs, 8 outputs, 3 × 2 reference switches, 3 encoder inputs, USB/RS485/CAN.
//! - pytrinamic's `TMCM3110` class ("pytrinamic TMCM3110"): the axis parameters (the TMCM-1140's set
//!   without AP 215, with AP 201 encoder mode, 213 group index and 254 step/direction mode), bank 0,
//!   bank 3 (timers 0–2, the stop switches of each axis 27–32, inputs 39–46) and the I/O (OUT0–OUT7;
//!   AIN0, IN1–IN3, AIN4, IN5–IN7).
//! - The TMCL-IDE parameter list of the TMCM-3110 (as the tmcl_ros2 project generated it): the same axis
//!   parameters, bank 0 with GP 67, 129 and 131.
//! - odemis' TMCL driver, which supports the TMCM-3110 and -6110 in production: the binary version
//!   (model in the high word, firmware 1.09 or later for the 3110), the analog inputs it reads (GIO 0, 1
//!   and GIO 4, 1; GIO 8, 1 the supply voltage in 0.1 V), the home switch of axis n on input IN(n+1), the
//!   reference search modes it uses (7 + 128 and 8: the ARM generation's modes 1–8).
//! - Everything the TMCM-1140 shares with them (units, start values, the TMC262's settings): the
//!   TMCM-1140's tables ([`crate::tmcm_1140`]), re-cited "(as TMCM-1140)".
//!
//! # Decisions (docs/tmcm-1140.md, "The multi-axis siblings")
//!
//! - **Per axis** every axis parameter exists once per motor, the same table for each.
//! - **Interrupt vectors** per axis: target reached 3 + n, stallGuard2 15 + n, deviation 21 + n, left and
//!   right stop switch 27 + 2n and 28 + 2n (the numbering of the ARM generation's interrupt table, the
//!   bank 3 numbers of pytrinamic's `GP3`), each source naming its axis.
//! - **Bank 3** has 17 entries on the TMCM-3110 (23 on the -6110): the core's capacity
//!   ([`crate::capacity::MAX_INTERRUPT_PARAMS`]) is 24 for them.
//! - **Encoder** (TMCM-3110 only): an external A/B encoder per axis (AP 209, prescaler 210, deviation
//!   212); AP 201 (encoder mode) is kept and stored. The TMCM-6110 has no encoder inputs.
//! - **Stored only**: AP 213 (group index), AP 254 (step/direction mode), besides the TMCM-1140's.
//! - **odemis' ports**: GIO 8, 1 reads the supply voltage in 0.1 V (odemis refuses to start below its
//!   `minpower`, 10.8 V by default; the simulated board's supply, 24 V unless the world says otherwise);
//!   SIO 0, 0, v sets the reference switches' pull-ups (odemis stores two bits for it in its user
//!   configuration and writes them back with SIO at start-up): 0..=3 taken and passed to the board, no
//!   other effect on the simulated switches, which have defined levels; GIO 0, 0 still reads IN0.

use crate::interface::InterfaceDesc;
use crate::interrupt::{InterruptDesc, Interrupts, Source};
use crate::param::{cited, join, Access, ParamDesc, Range, Table};
use crate::port::{PortDesc, PortKind};
use crate::tmcm_1140;
use crate::variant::{AppStatusReply, Driver, Encoder, EncoderKind, GlobalBanks, Kinematics, ReferenceModes};
use crate::{pd28_1021, ModelDesc, ModelSpec};

/// pytrinamic's `TMCM3110` class, where it agrees with the TMCM-1140's tables.
const PY: &str = "pytrinamic TMCM3110 (as TMCM-1140)";
/// pytrinamic's `TMCM3110` class, for what the TMCM-1140 does not have.
const PY3: &str = "pytrinamic TMCM3110";
/// pytrinamic's `GP3` of the multi-axis modules.
const GP3: &str = "pytrinamic TMCM3110/TMCM6110 GP3";

const fn r(min: i32, max: i32) -> Range {
    Range::Signed(min, max)
}

// ---- axis parameters (the same for each axis) --------------------------------------------------------

/// AP 0–154 and the TMC262's 160–197, 200 as on the TMCM-1140.
pub(crate) const MOTION: [ParamDesc; 22] = cited(&tmcm_1140::MOTION, 0, 154, PY);
pub(crate) const TMC262: [ParamDesc; 21] = cited(&tmcm_1140::TMC262_A, 160, 180, PY);
pub(crate) const TMC262_SPEEDS: [ParamDesc; 2] = cited(&tmcm_1140::TMC262_SPEEDS, 181, 182, PY);
pub(crate) const TMC262_B: [ParamDesc; 2] = cited(&tmcm_1140::TMC262_B, 183, 184, PY);
pub(crate) const REFERENCE: [ParamDesc; 5] = join(&[
    &cited::<1>(&tmcm_1140::REF_MODE, 193, 193, PY),
    &cited::<2>(&tmcm_1140::REF_SPEEDS, 194, 195, PY),
    &cited::<2>(&tmcm_1140::REF_RESULTS, 196, 197, PY),
]);
pub(crate) const BOOST: [ParamDesc; 1] = cited(&tmcm_1140::BOOST, 200, 200, PY);
/// AP 201: the encoder input's mode, kept and stored.
const ENCODER_MODE: [ParamDesc; 1] =
    [ParamDesc::plain(201, "Encoder mode", "EncoderMode", r(0, 255), Access::RWE, 0, PY3)];
/// AP 204–212: freewheeling, load value, error flags, encoder position, prescaler, deviation.
const DRIVE_ENCODER: [ParamDesc; 7] = cited(&tmcm_1140::TAIL, 204, 212, PY);
/// AP 204–208 without the encoder (the TMCM-6110).
pub(crate) const DRIVE: [ParamDesc; 4] = cited(&tmcm_1140::TAIL, 204, 208, PY);
/// AP 213: the group index (axes that start together), kept.
pub(crate) const GROUP: [ParamDesc; 1] =
    [ParamDesc::plain(213, "Group index", "GroupIndex", r(0, 255), Access::RW, 0, PY3)];
/// AP 214: power-down delay.
pub(crate) const POWER_DOWN: [ParamDesc; 1] = cited(&tmcm_1140::TAIL, 214, 214, PY);
/// AP 254: step/direction mode, kept and stored.
const STEP_DIR: [ParamDesc; 1] = cited(&pd28_1021::AXIS_PARAMS, 254, 254, PY3);

/// Axis parameters of each axis: 64 entries.
pub static AXIS_PARAMS: [ParamDesc; 64] = join(&[
    &MOTION,
    &TMC262,
    &TMC262_SPEEDS,
    &TMC262_B,
    &REFERENCE,
    &BOOST,
    &ENCODER_MODE,
    &DRIVE_ENCODER,
    &GROUP,
    &POWER_DOWN,
    &STEP_DIR,
]);

/// Bank 0: the TMCM-1140's (the same list in pytrinamic's `GP0`).
pub static GLOBAL_PARAMS: [ParamDesc; 24] = cited(&tmcm_1140::GLOBAL_PARAMS, 0, 255, PY);

/// Bank 3: the timers, the stop switches of `N` axes (27 + 2n, 28 + 2n), inputs 0–7 (39–46).
pub(crate) const fn bank3<const N: usize>(axes: usize) -> [ParamDesc; N] {
    let timers: [ParamDesc; 3] = cited(&pd28_1021::INTERRUPT_PARAMS, 0, 2, GP3);
    let mut out = [ParamDesc::plain(0, "", "", Range::ANY, Access::R, 0, ""); N];
    assert!(N == 3 + 2 * axes + 8, "3 timers, 2 switches per axis, 8 inputs");
    let mut n = 0;
    while n < 3 {
        out[n] = timers[n];
        n += 1;
    }
    let mut a = 0;
    while a < 2 * axes {
        let (name, ident) = if a % 2 == 0 { (LEFT[a / 2], LEFT_ID[a / 2]) } else { (RIGHT[a / 2], RIGHT_ID[a / 2]) };
        out[n] = ParamDesc::plain(27 + a as u8, name, ident, r(0, 3), Access::RW, 0, GP3);
        n += 1;
        a += 1;
    }
    let mut i = 0;
    while i < 8 {
        out[n] = ParamDesc::plain(39 + i as u8, INPUT[i], INPUT_ID[i], r(0, 3), Access::RW, 0, GP3);
        n += 1;
        i += 1;
    }
    out
}

const LEFT: [&str; 6] = [
    "Stop left 0 trigger transition",
    "Stop left 1 trigger transition",
    "Stop left 2 trigger transition",
    "Stop left 3 trigger transition",
    "Stop left 4 trigger transition",
    "Stop left 5 trigger transition",
];
const LEFT_ID: [&str; 6] = [
    "StopLeft0Trigger",
    "StopLeft1Trigger",
    "StopLeft2Trigger",
    "StopLeft3Trigger",
    "StopLeft4Trigger",
    "StopLeft5Trigger",
];
const RIGHT: [&str; 6] = [
    "Stop right 0 trigger transition",
    "Stop right 1 trigger transition",
    "Stop right 2 trigger transition",
    "Stop right 3 trigger transition",
    "Stop right 4 trigger transition",
    "Stop right 5 trigger transition",
];
const RIGHT_ID: [&str; 6] = [
    "StopRight0Trigger",
    "StopRight1Trigger",
    "StopRight2Trigger",
    "StopRight3Trigger",
    "StopRight4Trigger",
    "StopRight5Trigger",
];
const INPUT: [&str; 8] = [
    "Input 0 trigger transition",
    "Input 1 trigger transition",
    "Input 2 trigger transition",
    "Input 3 trigger transition",
    "Input 4 trigger transition",
    "Input 5 trigger transition",
    "Input 6 trigger transition",
    "Input 7 trigger transition",
];
const INPUT_ID: [&str; 8] = [
    "Input0Trigger",
    "Input1Trigger",
    "Input2Trigger",
    "Input3Trigger",
    "Input4Trigger",
    "Input5Trigger",
    "Input6Trigger",
    "Input7Trigger",
];

/// Bank 3 of the TMCM-3110: 17 entries.
pub static INTERRUPT_PARAMS: [ParamDesc; 17] = bank3(3);

// ---- interrupt vectors ---------------------------------------------------------------------------------

const fn v(number: u8, name: &'static str, symbol: &'static str, source: Source, config: Option<u8>) -> InterruptDesc {
    InterruptDesc { number, name, symbol, source, config }
}

/// The timers.
pub(crate) const TIMERS: [InterruptDesc; 3] = [
    v(0, "Timer 0", "TI_TIMER0", Source::Timer(0), Some(0)),
    v(1, "Timer 1", "TI_TIMER1", Source::Timer(1), Some(1)),
    v(2, "Timer 2", "TI_TIMER2", Source::Timer(2), Some(2)),
];
/// The input changes 0–7 (39–46).
pub(crate) const INPUTS: [InterruptDesc; 8] = [
    v(39, "Input change 0", "TI_INPUT0", Source::Input(0), Some(39)),
    v(40, "Input change 1", "TI_INPUT1", Source::Input(1), Some(40)),
    v(41, "Input change 2", "TI_INPUT2", Source::Input(2), Some(41)),
    v(42, "Input change 3", "TI_INPUT3", Source::Input(3), Some(42)),
    v(43, "Input change 4", "TI_INPUT4", Source::Input(4), Some(43)),
    v(44, "Input change 5", "TI_INPUT5", Source::Input(5), Some(44)),
    v(45, "Input change 6", "TI_INPUT6", Source::Input(6), Some(45)),
    v(46, "Input change 7", "TI_INPUT7", Source::Input(7), Some(46)),
];

/// Every vector of the TMCM-3110 with its axis, in number order: 3 timers, target reached 3–5,
/// stallGuard2 15–17, deviation 21–23, stop switches 27–32, inputs 39–46.
pub static VECTORS_3110: [InterruptDesc; 26] = [
    TIMERS[0],
    TIMERS[1],
    TIMERS[2],
    v(3, "Target position reached 0", "TI_TARGET0", Source::TargetReached(0), None),
    v(4, "Target position reached 1", "TI_TARGET1", Source::TargetReached(1), None),
    v(5, "Target position reached 2", "TI_TARGET2", Source::TargetReached(2), None),
    v(15, "stallGuard axis 0", "TI_STALLGUARD0", Source::Stall(0), None),
    v(16, "stallGuard axis 1", "TI_STALLGUARD1", Source::Stall(1), None),
    v(17, "stallGuard axis 2", "TI_STALLGUARD2", Source::Stall(2), None),
    v(21, "Deviation axis 0", "TI_DEVIATION0", Source::Deviation(0), None),
    v(22, "Deviation axis 1", "TI_DEVIATION1", Source::Deviation(1), None),
    v(23, "Deviation axis 2", "TI_DEVIATION2", Source::Deviation(2), None),
    v(27, "Left stop switch 0", "TI_STOPLEFT0", Source::LeftStop(0), Some(27)),
    v(28, "Right stop switch 0", "TI_STOPRIGHT0", Source::RightStop(0), Some(28)),
    v(29, "Left stop switch 1", "TI_STOPLEFT1", Source::LeftStop(1), Some(29)),
    v(30, "Right stop switch 1", "TI_STOPRIGHT1", Source::RightStop(1), Some(30)),
    v(31, "Left stop switch 2", "TI_STOPLEFT2", Source::LeftStop(2), Some(31)),
    v(32, "Right stop switch 2", "TI_STOPRIGHT2", Source::RightStop(2), Some(32)),
    INPUTS[0],
    INPUTS[1],
    INPUTS[2],
    INPUTS[3],
    INPUTS[4],
    INPUTS[5],
    INPUTS[6],
    INPUTS[7],
];

// ---- I/O, interfaces, description ---------------------------------------------------------------------

/// I/O ports (pytrinamic's `IO`): IN0–IN7 digital on bank 0, AIN0 and AIN4 analog on bank 1, OUT0–OUT7
/// on bank 2; and, as odemis' TMCL driver uses them, the supply voltage GIO 8, 1 (0.1 V) and the reference
/// switches' pull-ups SIO 0, 0.
pub static PORTS: [PortDesc; 22] = [
    PortDesc { bank: 0, port: 0, kind: PortKind::DigitalInput(0), name: "AIN0" },
    PortDesc { bank: 0, port: 1, kind: PortKind::DigitalInput(1), name: "IN1" },
    PortDesc { bank: 0, port: 2, kind: PortKind::DigitalInput(2), name: "IN2" },
    PortDesc { bank: 0, port: 3, kind: PortKind::DigitalInput(3), name: "IN3" },
    PortDesc { bank: 0, port: 4, kind: PortKind::DigitalInput(4), name: "AIN4" },
    PortDesc { bank: 0, port: 5, kind: PortKind::DigitalInput(5), name: "IN5" },
    PortDesc { bank: 0, port: 6, kind: PortKind::DigitalInput(6), name: "IN6" },
    PortDesc { bank: 0, port: 7, kind: PortKind::DigitalInput(7), name: "IN7" },
    PortDesc { bank: 0, port: 255, kind: PortKind::AllInputs, name: "all digital inputs" },
    PortDesc { bank: 1, port: 0, kind: PortKind::Analog(0), name: "analog AIN0" },
    PortDesc { bank: 1, port: 4, kind: PortKind::Analog(1), name: "analog AIN4" },
    PortDesc { bank: 1, port: 8, kind: PortKind::SupplyVoltage, name: "supply voltage (0.1 V)" },
    PortDesc { bank: 0, port: 0, kind: PortKind::PullUps, name: "reference switch pull-ups" },
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

/// The TMCM-3110 with firmware V1.11 (USB first, as the TMCM-1140), three axes.
pub const DESC: ModelDesc = ModelDesc {
    id: "tmcm-3110",
    name: "TMCM-3110",
    version_string: *b"3110V111",
    version_binary: (3110 << 16) | (1 << 8) | 11,
    eeprom_tag: 3110,
    motors: 3,
    axis: Table::new(&AXIS_PARAMS),
    global: Table::new(&GLOBAL_PARAMS),
    interrupt: Table::new(&INTERRUPT_PARAMS),
    user_variables: 256,
    stored_user_variables: 56,
    coordinates: 20,
    program_memory: 2048,
    ports: &PORTS,
    interrupts: Interrupts::new(&VECTORS_3110),
    inputs: 8,
    outputs: 8,
    interfaces: &[tmcm_1140::USB, InterfaceDesc::RS485],
    ethercat: None,
    commands: tmcm_1140::COMMANDS,
    ascii_commands: tmcm_1140::COMMANDS.ascii_subset(),
    // odemis sets its referencing handler's vector in direct mode (docs/tmcm-3110.md).
    host_vect: true,
    app_status: AppStatusReply::Typed,
    banks: GlobalBanks::ARM,
    kinematics: Kinematics::Tmc428 { clock_hz: 16_000_000 },
    reference_modes: ReferenceModes::Pd28,
    driver: Driver::Tmc262,
    // An external A/B encoder per axis; its resolution is the encoder's (the world's), 4096 as a start.
    encoder: Some(Encoder { kind: EncoderKind::Abn, counts_per_rev: 4096 }),
    // Our assumption until the hardware manual is at hand: 2.8 A RMS per axis (3.96 A peak) in the
    // TMC262's high sense range, 0.165/0.305 of it in the low one.
    peak_current_ma: [2142, 3960],
    password: None,
    manual: "TMCM-3110 TMCL firmware manual V1.11 (Rev. 1.05)",
};

/// The TMCM-3110 with firmware V1.11.
pub static SPEC: ModelSpec = ModelSpec::new(DESC);

/// The TMCM-3110 served on its RS485 port (`tmcl serve --interface rs485`): on a bus with others.
pub static SPEC_RS485: ModelSpec =
    ModelSpec::new(ModelDesc { interfaces: &[InterfaceDesc::RS485, tmcm_1140::USB], ..DESC });

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FitError, ModelSpec};

    #[test]
    fn tables_are_sorted_and_defaults_in_range() {
        for table in [&AXIS_PARAMS[..], &GLOBAL_PARAMS[..], &INTERRUPT_PARAMS[..]] {
            assert!(table.windows(2).all(|w| w[0].number < w[1].number));
            for d in table {
                assert!(d.range.contains(d.default) || !d.access.write, "{} default {}", d.name, d.default);
            }
        }
        assert!(VECTORS_3110.windows(2).all(|w| w[0].number < w[1].number));
    }

    /// pytrinamic's `TMCM3110` AP table, but AP 135 (not provided, as on the TMCM-1140).
    #[test]
    fn pytrinamics_numbers_are_there() {
        let pytrinamic = [
            0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 130, 135, 138, 140, 141, 149, 150, 153, 154, 160, 161, 162,
            163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175, 176, 177, 178, 179, 180, 181, 182, 183,
            184, 193, 194, 195, 196, 197, 200, 201, 204, 206, 207, 208, 209, 210, 212, 213, 214, 254,
        ];
        let table = Table::new(&AXIS_PARAMS);
        let missing: Vec<u8> = pytrinamic.into_iter().filter(|n| !table.contains(*n)).collect();
        assert_eq!(missing, [135]);
        let bank3: Vec<u8> = INTERRUPT_PARAMS.iter().map(|d| d.number).collect();
        assert_eq!(bank3, [0, 1, 2, 27, 28, 29, 30, 31, 32, 39, 40, 41, 42, 43, 44, 45, 46]);
    }

    #[test]
    fn fits_the_core() {
        assert_eq!(ModelSpec::check(&DESC).map(|_| ()), Ok(()));
        // One motor more than the core drives does not fit.
        let seven = ModelDesc { motors: 7, ..DESC };
        assert_eq!(ModelSpec::check(&seven).map(|_| ()), Err(FitError::Motors));
        assert_eq!(DESC.version_binary >> 16, 3110, "odemis reads the model from the high word");
        assert_eq!(DESC.version_binary & 0xFFFF, 0x010B);
    }
}

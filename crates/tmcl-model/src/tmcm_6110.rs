//! The TMCM-6110: six axes of the TMCM-3110's kind without encoder inputs ([`crate::tmcm_3110`] has the
//! sources and decisions they share).
//!
//! # Sources
//!
//! - The TMCM-6110 TMCL firmware manual V1.19 (Rev. 1.03, 2012-JUL-31), §5.6.39: command 136 (type 0
//!   the version string, e.g. `6110V100`; type 1 the version in the value field).
//! - pytrinamic's `TMCM6110` class: the axis parameters (the TMCM-3110's without the encoder AP 201,
//!   209, 210, 212 and without AP 254), bank 3 with the stop switches of six axes (27–38), the I/O of
//!   the TMCM-3110 and VIN (GIO 8, 1, the supply voltage).
//! - odemis' TMCL driver (the TMCM-6110 in production; its own simulator answers GIO 0, 4 and 8 of
//!   bank 1).

use crate::interface::InterfaceDesc;
use crate::interrupt::InterruptDesc;
use crate::interrupt::{Interrupts, Source};
use crate::param::{join, ParamDesc, Table};
use crate::tmcm_1140;
use crate::tmcm_3110::{self, bank3};
use crate::variant::{AppStatusReply, Driver, GlobalBanks, Kinematics, ReferenceModes};
use crate::{ModelDesc, ModelSpec};

/// Axis parameters of each axis: 59 entries.
pub static AXIS_PARAMS: [ParamDesc; 59] = join(&[
    &tmcm_3110::MOTION,
    &tmcm_3110::TMC262,
    &tmcm_3110::TMC262_SPEEDS,
    &tmcm_3110::TMC262_B,
    &tmcm_3110::REFERENCE,
    &tmcm_3110::BOOST,
    &tmcm_3110::DRIVE,
    &tmcm_3110::GROUP,
    &tmcm_3110::POWER_DOWN,
]);

/// Bank 3: the timers, the stop switches of six axes, inputs 0–7: 23 entries.
pub static INTERRUPT_PARAMS: [ParamDesc; 23] = bank3(6);

const fn axis_vector(number: u8, name: &'static str, symbol: &'static str, source: Source) -> InterruptDesc {
    let config = if source.is_level() { Some(number) } else { None };
    InterruptDesc { number, name, symbol, source, config }
}

/// Every vector of the TMCM-6110 with its axis, in number order: 3 timers, target reached 3–8,
/// stallGuard2 15–20, deviation 21–26, stop switches 27–38, inputs 39–46.
pub static VECTORS_6110: [InterruptDesc; 41] = {
    use Source::*;
    [
        tmcm_3110::TIMERS[0],
        tmcm_3110::TIMERS[1],
        tmcm_3110::TIMERS[2],
        axis_vector(3, "Target position reached 0", "TI_TARGET0", TargetReached(0)),
        axis_vector(4, "Target position reached 1", "TI_TARGET1", TargetReached(1)),
        axis_vector(5, "Target position reached 2", "TI_TARGET2", TargetReached(2)),
        axis_vector(6, "Target position reached 3", "TI_TARGET3", TargetReached(3)),
        axis_vector(7, "Target position reached 4", "TI_TARGET4", TargetReached(4)),
        axis_vector(8, "Target position reached 5", "TI_TARGET5", TargetReached(5)),
        axis_vector(15, "stallGuard axis 0", "TI_STALLGUARD0", Stall(0)),
        axis_vector(16, "stallGuard axis 1", "TI_STALLGUARD1", Stall(1)),
        axis_vector(17, "stallGuard axis 2", "TI_STALLGUARD2", Stall(2)),
        axis_vector(18, "stallGuard axis 3", "TI_STALLGUARD3", Stall(3)),
        axis_vector(19, "stallGuard axis 4", "TI_STALLGUARD4", Stall(4)),
        axis_vector(20, "stallGuard axis 5", "TI_STALLGUARD5", Stall(5)),
        axis_vector(21, "Deviation axis 0", "TI_DEVIATION0", Deviation(0)),
        axis_vector(22, "Deviation axis 1", "TI_DEVIATION1", Deviation(1)),
        axis_vector(23, "Deviation axis 2", "TI_DEVIATION2", Deviation(2)),
        axis_vector(24, "Deviation axis 3", "TI_DEVIATION3", Deviation(3)),
        axis_vector(25, "Deviation axis 4", "TI_DEVIATION4", Deviation(4)),
        axis_vector(26, "Deviation axis 5", "TI_DEVIATION5", Deviation(5)),
        axis_vector(27, "Left stop switch 0", "TI_STOPLEFT0", LeftStop(0)),
        axis_vector(28, "Right stop switch 0", "TI_STOPRIGHT0", RightStop(0)),
        axis_vector(29, "Left stop switch 1", "TI_STOPLEFT1", LeftStop(1)),
        axis_vector(30, "Right stop switch 1", "TI_STOPRIGHT1", RightStop(1)),
        axis_vector(31, "Left stop switch 2", "TI_STOPLEFT2", LeftStop(2)),
        axis_vector(32, "Right stop switch 2", "TI_STOPRIGHT2", RightStop(2)),
        axis_vector(33, "Left stop switch 3", "TI_STOPLEFT3", LeftStop(3)),
        axis_vector(34, "Right stop switch 3", "TI_STOPRIGHT3", RightStop(3)),
        axis_vector(35, "Left stop switch 4", "TI_STOPLEFT4", LeftStop(4)),
        axis_vector(36, "Right stop switch 4", "TI_STOPRIGHT4", RightStop(4)),
        axis_vector(37, "Left stop switch 5", "TI_STOPLEFT5", LeftStop(5)),
        axis_vector(38, "Right stop switch 5", "TI_STOPRIGHT5", RightStop(5)),
        tmcm_3110::INPUTS[0],
        tmcm_3110::INPUTS[1],
        tmcm_3110::INPUTS[2],
        tmcm_3110::INPUTS[3],
        tmcm_3110::INPUTS[4],
        tmcm_3110::INPUTS[5],
        tmcm_3110::INPUTS[6],
        tmcm_3110::INPUTS[7],
    ]
};

/// The TMCM-6110 with firmware V1.19, six axes.
pub const DESC: ModelDesc = ModelDesc {
    id: "tmcm-6110",
    name: "TMCM-6110",
    version_string: *b"6110V119",
    version_binary: (6110 << 16) | (1 << 8) | 19,
    eeprom_tag: 6110,
    motors: 6,
    axis: Table::new(&AXIS_PARAMS),
    global: Table::new(&tmcm_3110::GLOBAL_PARAMS),
    interrupt: Table::new(&INTERRUPT_PARAMS),
    user_variables: 256,
    stored_user_variables: 56,
    coordinates: 20,
    program_memory: 2048,
    ports: &tmcm_3110::PORTS,
    interrupts: Interrupts::new(&VECTORS_6110),
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
    // No encoder inputs.
    encoder: None,
    // Our assumption until the hardware manual is at hand: 1.1 A RMS per axis (1.56 A peak) in the high
    // sense range, 0.165/0.305 of it in the low one.
    peak_current_ma: [842, 1556],
    password: None,
    manual: "TMCM-6110 TMCL firmware manual V1.19 (Rev. 1.03)",
};

/// The TMCM-6110 with firmware V1.19.
pub static SPEC: ModelSpec = ModelSpec::new(DESC);

/// The TMCM-6110 served on its RS485 port (`tmcl serve --interface rs485`): on a bus with others.
pub static SPEC_RS485: ModelSpec =
    ModelSpec::new(ModelDesc { interfaces: &[InterfaceDesc::RS485, tmcm_1140::USB], ..DESC });

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FitError, ModelSpec};

    #[test]
    fn tables_are_sorted_and_defaults_in_range() {
        for table in [&AXIS_PARAMS[..], &INTERRUPT_PARAMS[..]] {
            assert!(table.windows(2).all(|w| w[0].number < w[1].number));
            for d in table {
                assert!(d.range.contains(d.default) || !d.access.write, "{} default {}", d.name, d.default);
            }
        }
        assert!(VECTORS_6110.windows(2).all(|w| w[0].number < w[1].number));
    }

    /// pytrinamic's `TMCM6110` AP table, but AP 135 (not provided, as on the TMCM-1140).
    #[test]
    fn pytrinamics_numbers_are_there() {
        let pytrinamic = [
            0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 130, 135, 138, 140, 141, 149, 150, 153, 154, 160, 161, 162,
            163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175, 176, 177, 178, 179, 180, 181, 182, 183,
            184, 193, 194, 195, 196, 197, 200, 204, 206, 207, 208, 213, 214,
        ];
        let table = Table::new(&AXIS_PARAMS);
        let missing: Vec<u8> = pytrinamic.into_iter().filter(|n| !table.contains(*n)).collect();
        assert_eq!(missing, [135]);
        assert!(!table.contains(209), "no encoder inputs");
        assert_eq!(INTERRUPT_PARAMS.len(), 3 + 12 + 8);
    }

    #[test]
    fn fits_the_core() {
        assert_eq!(ModelSpec::check(&DESC).map(|_| ()), Ok(()));
        // One motor more than the core drives does not fit.
        let seven = ModelDesc { motors: 7, ..DESC };
        assert_eq!(ModelSpec::check(&seven).map(|_| ()), Err(FitError::Motors));
        assert_eq!(DESC.version_binary >> 16, 6110);
    }
}

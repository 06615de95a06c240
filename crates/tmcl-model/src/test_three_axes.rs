//! A test-only model with three motors (feature `test-support`; no product, not shipped): the
//! PD28-1021's tables with three axes, and the per-axis interrupt vectors the PD28-1021 manual's
//! Table 12 (§3.6.6.1) leaves room for — it numbers "Target position reached 0", "stallGuard axis 0",
//! "Deviation axis 0", "Left/Right stop switch 0" as 3, 15, 21, 27/28 with the numbers between free for
//! further axes: target reached 3–5, stallGuard 15–17, deviation 21–23, stop switches 27–32 (left, right
//! per motor). It makes the core's axes as data testable (direct mode, programs and interrupts on every
//! axis) before a real multi-axis model exists.

use crate::interrupt::{InterruptDesc, Interrupts, Source};
use crate::param::{Access, ParamDesc, Range, Table};
use crate::pd28_1021;
use crate::{ModelDesc, ModelSpec};

const I: &str = "§5.4 Table 19";

const fn irq(
    number: u8,
    name: &'static str,
    symbol: &'static str,
    source: Source,
    config: Option<u8>,
) -> InterruptDesc {
    InterruptDesc { number, name, symbol, source, config }
}

const fn trigger(number: u8, name: &'static str, symbol: &'static str) -> ParamDesc {
    ParamDesc::plain(number, name, symbol, Range::Signed(0, 3), Access::RW, 0, I)
}

/// Bank 3: the PD28-1021's timer periods and input triggers, and a trigger transition per stop switch.
pub static INTERRUPT_PARAMS: [ParamDesc; 13] = [
    pd28_1021::INTERRUPT_PARAMS[0],
    pd28_1021::INTERRUPT_PARAMS[1],
    pd28_1021::INTERRUPT_PARAMS[2],
    trigger(27, "Stop left 0 trigger transition", "StopLeft0Trigger"),
    trigger(28, "Stop right 0 trigger transition", "StopRight0Trigger"),
    trigger(29, "Stop left 1 trigger transition", "StopLeft1Trigger"),
    trigger(30, "Stop right 1 trigger transition", "StopRight1Trigger"),
    trigger(31, "Stop left 2 trigger transition", "StopLeft2Trigger"),
    trigger(32, "Stop right 2 trigger transition", "StopRight2Trigger"),
    pd28_1021::INTERRUPT_PARAMS[5],
    pd28_1021::INTERRUPT_PARAMS[6],
    pd28_1021::INTERRUPT_PARAMS[7],
    pd28_1021::INTERRUPT_PARAMS[8],
];

/// The interrupt vectors, per axis where Table 12 numbers them per axis.
pub static INTERRUPTS: [InterruptDesc; 22] = [
    irq(0, "Timer 0", "TI_TIMER0", Source::Timer(0), Some(0)),
    irq(1, "Timer 1", "TI_TIMER1", Source::Timer(1), Some(1)),
    irq(2, "Timer 2", "TI_TIMER2", Source::Timer(2), Some(2)),
    irq(3, "Target position reached 0", "TI_TARGET0", Source::TargetReached(0), None),
    irq(4, "Target position reached 1", "TI_TARGET1", Source::TargetReached(1), None),
    irq(5, "Target position reached 2", "TI_TARGET2", Source::TargetReached(2), None),
    irq(15, "stallGuard axis 0", "TI_STALLGUARD0", Source::Stall(0), None),
    irq(16, "stallGuard axis 1", "TI_STALLGUARD1", Source::Stall(1), None),
    irq(17, "stallGuard axis 2", "TI_STALLGUARD2", Source::Stall(2), None),
    irq(21, "Deviation axis 0", "TI_DEVIATION0", Source::Deviation(0), None),
    irq(22, "Deviation axis 1", "TI_DEVIATION1", Source::Deviation(1), None),
    irq(23, "Deviation axis 2", "TI_DEVIATION2", Source::Deviation(2), None),
    irq(27, "Left stop switch 0", "TI_STOPLEFT0", Source::LeftStop(0), Some(27)),
    irq(28, "Right stop switch 0", "TI_STOPRIGHT0", Source::RightStop(0), Some(28)),
    irq(29, "Left stop switch 1", "TI_STOPLEFT1", Source::LeftStop(1), Some(29)),
    irq(30, "Right stop switch 1", "TI_STOPRIGHT1", Source::RightStop(1), Some(30)),
    irq(31, "Left stop switch 2", "TI_STOPLEFT2", Source::LeftStop(2), Some(31)),
    irq(32, "Right stop switch 2", "TI_STOPRIGHT2", Source::RightStop(2), Some(32)),
    irq(39, "Input change 0", "TI_INPUT0", Source::Input(0), Some(39)),
    irq(40, "Input change 1", "TI_INPUT1", Source::Input(1), Some(40)),
    irq(41, "Input change 2", "TI_INPUT2", Source::Input(2), Some(41)),
    irq(42, "Input change 3", "TI_INPUT3", Source::Input(3), Some(42)),
];

/// The three-axis test model as a description.
pub const DESC: ModelDesc = ModelDesc {
    id: "test-3axis",
    name: "three-axis test model",
    version_string: *b"3AXV0001",
    version_binary: i32::from_be_bytes([0, 3, 0, 1]),
    eeprom_tag: 3,
    motors: 3,
    interrupt: Table::new(&INTERRUPT_PARAMS),
    interrupts: Interrupts::new(&INTERRUPTS),
    manual: "test model: the PD28-1021 TMCL firmware manual V1.05 with three axes",
    ..pd28_1021::DESC
};

/// The three-axis test model.
pub static SPEC: ModelSpec = ModelSpec::new(DESC);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_axes_with_their_vectors() {
        assert_eq!(SPEC.motors, 3);
        for m in 0..3 {
            assert_eq!(SPEC.interrupts.target_reached(m), Some(3 + m as u8));
            assert_eq!(SPEC.interrupts.stall(m), Some(15 + m as u8));
            assert_eq!(SPEC.interrupts.deviation(m), Some(21 + m as u8));
        }
        assert_eq!(SPEC.interrupts.target_reached(3), None);
        // The EEPROM holds each motor's E parameters and coordinates.
        let one = pd28_1021::SPEC.layout();
        assert!(SPEC.layout().program >= one.program);
        assert!(SPEC.layout().global - SPEC.layout().axis >= 3 * SPEC.axis.persistent() * 4);
    }

    #[test]
    fn a_source_for_a_motor_the_model_lacks_does_not_fit() {
        static BAD: [InterruptDesc; 1] = [irq(6, "Target position reached 3", "T3", Source::TargetReached(3), None)];
        let d = ModelDesc { interrupts: Interrupts::new(&BAD), ..DESC };
        assert_eq!(ModelSpec::check(&d).err(), Some(crate::FitError::InterruptConfig));
    }
}

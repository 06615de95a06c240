//! The board: the core's hardware traits ([`tmcl_core::hal`]) on the LM3S6965 evaluation board.
//!
//! | Capability | Where |
//! |---|---|
//! | EEPROM ([`Nvm`]) | SRAM that survives a reset ([`crate::shim::EEPROM`], [`tmcl_mcu::nvm`]) |
//! | IN0..IN3 ([`Inputs`]) | PE0..PE3, the board's navigation switches, active low with pull-ups |
//! | OUT0, OUT1 ([`Outputs`]) | PF0 (the board's user LED), PF2 |
//! | analog input, temperature ([`Analog`]) | ADC0, ADC1 ([`crate::adc`]) |
//! | left, right, home switches ([`SwitchInputs`]) | PB4, PB5, PB6, active high with pull-downs |
//! | motor ([`StepDriver`]) | STEP PB0, DIR PB1, ENN PB2 ([`crate::steps`]) |
//! | load, encoder | none: the defaults of [`LoadSensor`] and [`EncoderCounter`] |

use crate::shim::{sysctl, EEPROM, GPIOB, GPIOE, GPIOF};
use crate::{adc, steps};
use tmcl_core::hal::{
    Analog, DriveState, EncoderCounter, Inputs, LoadSensor, Nvm, Outputs, StepDriver, SwitchInputs, Switches,
};
use tmcl_core::model::ModelSpec;
use tmcl_core::param::persist;
use tmcl_core::Instant;
use tmcl_mcu::nvm::{OutOfRange, RamNvm};

/// The digital inputs IN0..IN3 on port E.
const INPUTS: u8 = 0x0F;
/// OUT0 on PF0.
const OUT0: u8 = 1 << 0;
/// OUT1 on PF2.
const OUT1: u8 = 1 << 2;
/// The reference switches on port B.
const LEFT: u8 = 1 << 4;
const RIGHT: u8 = 1 << 5;
const HOME: u8 = 1 << 6;

/// The LM3S6965 evaluation board as a module's board.
pub struct Lm3sBoard {
    nvm: RamNvm<'static>,
    /// The newest readings of ADC0 and ADC1.
    readings: [u16; 2],
}

impl Lm3sBoard {
    /// Sets up the pins and peripherals and takes the EEPROM for `spec` (its image's size).
    pub fn new(spec: &ModelSpec) -> Lm3sBoard {
        // Ports B, E, F.
        sysctl::RCGC2.modify(|r| r | 1 << 1 | 1 << 4 | 1 << 5);
        GPIOE.dir().modify(|r| r & !u32::from(INPUTS));
        GPIOE.pur().modify(|r| r | u32::from(INPUTS));
        GPIOE.den().modify(|r| r | u32::from(INPUTS));
        let outs = u32::from(OUT0 | OUT1);
        GPIOF.dir().modify(|r| r | outs);
        GPIOF.den().modify(|r| r | outs);
        GPIOF.data(OUT0 | OUT1).write(0);
        let switches = u32::from(LEFT | RIGHT | HOME);
        GPIOB.dir().modify(|r| r & !switches);
        GPIOB.pdr().modify(|r| r | switches);
        GPIOB.den().modify(|r| r | switches);
        steps::init();
        adc::init();
        // Every model's image fits: the EEPROM is sized at compile time for the largest (`shim::EEPROM_LEN`).
        let len = persist::capacity(spec);
        Lm3sBoard { nvm: RamNvm::new(&EEPROM[..len]), readings: [0x200; 2] }
    }
}

impl Nvm for Lm3sBoard {
    type Error = OutOfRange;
    fn capacity(&self) -> usize {
        self.nvm.capacity()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), OutOfRange> {
        self.nvm.read(offset, buf)
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), OutOfRange> {
        self.nvm.write(offset, data)
    }
}

impl Inputs for Lm3sBoard {
    fn digital_inputs(&mut self) -> u8 {
        // A pressed switch pulls its pin low: input active.
        !(GPIOE.data(INPUTS).read() as u8) & INPUTS
    }
}

impl Outputs for Lm3sBoard {
    fn set_outputs(&mut self, bits: u8) {
        let level = if bits & 1 != 0 { OUT0 } else { 0 } | if bits & 2 != 0 { OUT1 } else { 0 };
        GPIOF.data(OUT0 | OUT1).write(u32::from(level));
    }
}

impl Analog for Lm3sBoard {
    fn analog_input(&mut self, channel: u8) -> u16 {
        if channel != 0 {
            return 0;
        }
        self.readings[0] = adc::latest(0, self.readings[0]);
        // The core's scale is 12 bits (0..=4095); the LM3S6965's ADC has 10.
        self.readings[0] << 2
    }

    fn temperature(&mut self) -> i32 {
        self.readings[1] = adc::latest(1, self.readings[1]);
        adc::celsius(self.readings[1])
    }
}

impl SwitchInputs for Lm3sBoard {
    /// The one motor's switches (the image's models have one motor).
    fn switches(&mut self, _motor: usize) -> Switches {
        let pins = GPIOB.data(LEFT | RIGHT | HOME).read() as u8;
        Switches { left: pins & LEFT != 0, right: pins & RIGHT != 0, home: pins & HOME != 0 }
    }
}

/// The firmware image has none of a simulator's shortcuts: the hook's defaults do nothing.
impl tmcl_core::hal::Hook for Lm3sBoard {}

impl StepDriver for Lm3sBoard {
    fn update(&mut self, _motor: usize, _now: Instant, state: &DriveState) {
        // The current, the microstep resolution and the chopper settings would go to the driver's SPI
        // port (the TMC262's SGCSCONF and DRVCTRL); the board's SSI port is wired to its display and SD
        // card, so this port drives step, direction and enable only.
        steps::enable(state.enabled);
        if state.moved != 0 {
            steps::add(if state.reverse { -state.moved } else { state.moved });
        }
    }
}

impl LoadSensor for Lm3sBoard {}
impl EncoderCounter for Lm3sBoard {}

//! A minimal board for the core's integration tests: RAM EEPROM (erased), inputs and outputs as bytes,
//! an ideal motor whose physical position integrates the field's moves, and an encoder on it. Analog
//! channel n reads `analog + n`.

#![allow(dead_code)] // each test file uses part of it

use std::vec::Vec;
use tmcl_core::hal::{
    Analog, DriveState, EncoderCounter, Inputs, LoadSensor, Nvm, Outputs, StepDriver, SwitchInputs, Switches,
};
use tmcl_core::model::ModelSpec;
use tmcl_core::param::persist;
use tmcl_core::Instant;

/// 1/256 microsteps per motor revolution (200 full steps).
pub const PHYSICAL_PER_REV: i64 = 200 * 256;

/// The board.
#[derive(Debug, Clone)]
pub struct Board {
    pub eeprom: Vec<u8>,
    pub inputs: u8,
    pub outputs: u8,
    pub drive: DriveState,
    /// Physical position in 1/256 microsteps.
    pub physical: i64,
    /// Encoder counts per revolution.
    pub counts_per_rev: i64,
    /// What analog channel 0 reads.
    pub analog: u16,
    /// °C.
    pub temperature: i32,
}

impl Board {
    /// A board with an erased EEPROM of the size `spec` needs and an encoder of `counts_per_rev`.
    pub fn new(spec: &ModelSpec, counts_per_rev: i64) -> Board {
        Board {
            eeprom: vec![0xFF; persist::capacity(spec)],
            inputs: 0,
            outputs: 0,
            drive: DriveState::default(),
            physical: 0,
            counts_per_rev,
            analog: 1000,
            temperature: 25,
        }
    }

    /// The physical position in microsteps of resolution `res` (1 << res per full step).
    pub fn steps(&self, res: u8) -> i64 {
        self.physical >> (8 - res.min(8))
    }
}

impl Nvm for Board {
    type Error = ();
    fn capacity(&self) -> usize {
        self.eeprom.len()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), ()> {
        buf.copy_from_slice(self.eeprom.get(offset..offset + buf.len()).ok_or(())?);
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), ()> {
        self.eeprom.get_mut(offset..offset + data.len()).ok_or(())?.copy_from_slice(data);
        Ok(())
    }
}
impl Inputs for Board {
    fn digital_inputs(&mut self) -> u8 {
        self.inputs
    }
}
impl Outputs for Board {
    fn set_outputs(&mut self, bits: u8) {
        self.outputs = bits;
    }
}
impl Analog for Board {
    fn analog_input(&mut self, channel: u8) -> u16 {
        self.analog + u16::from(channel)
    }
    fn temperature(&mut self) -> i32 {
        self.temperature
    }
}
impl SwitchInputs for Board {
    fn switches(&mut self, _motor: usize) -> Switches {
        Switches::default()
    }
}
impl tmcl_core::hal::Hook for Board {}

impl StepDriver for Board {
    fn update(&mut self, _motor: usize, _now: Instant, state: &DriveState) {
        let moved = state.moved << (8 - state.resolution.min(8));
        self.physical += if state.reverse { -moved } else { moved };
        self.drive = *state;
    }
}
impl LoadSensor for Board {}
impl EncoderCounter for Board {
    fn encoder_counts(&mut self, _motor: usize) -> i64 {
        self.physical * self.counts_per_rev / PHYSICAL_PER_REV
    }
}

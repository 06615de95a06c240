//! The simulated board: an ideal stepper on a free axis, switches at positions, settable inputs, and an
//! EEPROM in memory or in a crash-safe file.
//!
//! Positions in the world are physical: 1/256 microsteps of the motor shaft (51200 per revolution with a
//! 200-step motor, the PD28-1021's motor, manual §6.1). The firmware's step counter is at the resolution
//! AP 140 selects; [`SimBoard`] converts every move it is told about ([`DriveState::moved`]) and applies
//! the reverse-shaft setting, so a reset or a `SAP 1` that changes the counter does not move the shaft.

use crate::nvm::{FileNvm, MemNvm, NvmError};
use core::ops::RangeInclusive;
use tmcl_core::hal::{Drive, DriveState, Feedback, Io, Nvm, Switches};
use tmcl_core::Instant;

/// Physical 1/256 microsteps per revolution of the simulated 200-step motor.
pub const MICROSTEPS_PER_REV: i64 = 200 * 256;
/// sensOstep counts per revolution (manual §6.2).
pub const ENCODER_COUNTS_PER_REV: i64 = 1024;

/// The EEPROM behind a simulated board.
#[derive(Debug)]
pub enum Eeprom {
    /// In memory: state lives as long as the process.
    Memory(MemNvm),
    /// In a crash-safe file.
    File(FileNvm),
}

impl Nvm for Eeprom {
    type Error = NvmError;
    fn capacity(&self) -> usize {
        match self {
            Eeprom::Memory(m) => m.capacity(),
            Eeprom::File(f) => f.capacity(),
        }
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), NvmError> {
        match self {
            Eeprom::Memory(m) => m.read(offset, buf),
            Eeprom::File(f) => f.read(offset, buf),
        }
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), NvmError> {
        match self {
            Eeprom::Memory(m) => m.write(offset, data),
            Eeprom::File(f) => f.write(offset, data),
        }
    }
}

impl Eeprom {
    /// Makes sure everything written is on disk (a no-op in memory).
    pub fn sync(&mut self) -> Result<(), NvmError> {
        match self {
            Eeprom::Memory(_) => Ok(()),
            Eeprom::File(f) => f.sync(),
        }
    }
}

/// The mechanical world around the motor: where the switches are, what the inputs read.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct World {
    /// Positions (physical 1/256 microsteps) where the left stop switch is pressed.
    pub left_switch: Option<RangeInclusive<i64>>,
    /// Where the right stop switch is pressed.
    pub right_switch: Option<RangeInclusive<i64>>,
    /// Where the home switch is pressed.
    pub home_switch: Option<RangeInclusive<i64>>,
    /// Digital input levels (bit n = INn).
    pub inputs: u8,
    /// ADC reading of analog input 0, 0..=4095.
    pub analog: u16,
    /// Module temperature in °C.
    pub temperature: i32,
}

impl World {
    /// A free axis: no switches, inputs low, 25 °C.
    pub fn free() -> World {
        World { temperature: 25, ..World::default() }
    }
}

/// A simulated PD28-1021 board.
#[derive(Debug)]
pub struct SimBoard {
    eeprom: Eeprom,
    /// The world around the motor; change it at any time.
    pub world: World,
    /// Shaft position in physical 1/256 microsteps.
    shaft: i64,
    outputs: u8,
    drive: DriveState,
    updated: Instant,
}

impl SimBoard {
    /// A board on a free axis with the given EEPROM.
    pub fn new(eeprom: Eeprom) -> SimBoard {
        SimBoard {
            eeprom,
            world: World::free(),
            shaft: 0,
            outputs: 0,
            drive: DriveState::default(),
            updated: Instant::ZERO,
        }
    }

    /// A board with an in-memory EEPROM of `capacity` bytes.
    pub fn in_memory(capacity: usize) -> SimBoard {
        SimBoard::new(Eeprom::Memory(MemNvm::new(capacity)))
    }

    /// The EEPROM.
    pub fn eeprom(&mut self) -> &mut Eeprom {
        &mut self.eeprom
    }

    /// Shaft position in physical 1/256 microsteps.
    pub fn shaft(&self) -> i64 {
        self.shaft
    }

    /// Output levels (bit n = OUTn).
    pub fn outputs(&self) -> u8 {
        self.outputs
    }

    /// What the firmware last asked of the driver.
    pub fn drive(&self) -> &DriveState {
        &self.drive
    }

    /// When the firmware last updated the driver.
    pub fn updated(&self) -> Instant {
        self.updated
    }

    fn pressed(zone: &Option<RangeInclusive<i64>>, at: i64) -> bool {
        zone.as_ref().is_some_and(|z| z.contains(&at))
    }
}

impl Nvm for SimBoard {
    type Error = NvmError;
    fn capacity(&self) -> usize {
        self.eeprom.capacity()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), NvmError> {
        self.eeprom.read(offset, buf)
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), NvmError> {
        self.eeprom.write(offset, data)
    }
}

impl Io for SimBoard {
    fn digital_inputs(&mut self) -> u8 {
        self.world.inputs
    }
    fn analog_input(&mut self, channel: u8) -> u16 {
        if channel == 0 {
            self.world.analog.min(4095)
        } else {
            0
        }
    }
    fn temperature(&mut self) -> i32 {
        self.world.temperature
    }
    fn set_outputs(&mut self, bits: u8) {
        self.outputs = bits;
    }
    fn switches(&mut self) -> Switches {
        Switches {
            left: Self::pressed(&self.world.left_switch, self.shaft),
            right: Self::pressed(&self.world.right_switch, self.shaft),
            home: Self::pressed(&self.world.home_switch, self.shaft),
        }
    }
}

impl Drive for SimBoard {
    fn update(&mut self, now: Instant, state: &DriveState) {
        // An ideal motor: the shaft follows every step (a free axis never loses one).
        let per_step = 1i64 << (8 - state.resolution.min(8));
        let moved = state.moved.saturating_mul(per_step);
        self.shaft = self.shaft.saturating_add(if state.reverse { -moved } else { moved });
        self.drive = *state;
        self.updated = now;
    }

    fn feedback(&mut self) -> Feedback {
        Feedback {
            encoder_counts: (self.shaft * ENCODER_COUNTS_PER_REV).div_euclid(MICROSTEPS_PER_REV),
            load: 1023,
            driver_flags: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_core::model::pd28_1021::SPEC;
    use tmcl_core::param::persist;
    use tmcl_core::{Duration, Module};
    use tmcl_wire::{Command, MoveTarget};

    fn module() -> Module<SimBoard> {
        Module::new(SimBoard::in_memory(persist::capacity(&SPEC)), &SPEC, Instant::ZERO)
    }

    #[test]
    fn one_revolution_moves_the_shaft_and_the_encoder() {
        let mut m = module();
        let t = Instant::ZERO;
        m.execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(51200) }, t).unwrap();
        m.poll(t + Duration::from_secs(3), &mut |_: &[u8]| {});
        assert_eq!(m.board().shaft(), MICROSTEPS_PER_REV);
        assert_eq!(m.board_mut().feedback().encoder_counts, 1024);
    }

    #[test]
    fn switch_zones() {
        let mut m = module();
        m.board_mut().world.right_switch = Some(10_000..=20_000);
        let t = Instant::ZERO;
        m.execute(Command::Ror { motor: 0, velocity: 5000 }, t).unwrap();
        m.poll(t + Duration::from_secs(4), &mut |_: &[u8]| {});
        let shaft = m.board().shaft();
        assert!((10_000..10_200).contains(&shaft), "stopped at the right switch: {shaft}");
        assert!(m.board_mut().switches().right);
    }
}

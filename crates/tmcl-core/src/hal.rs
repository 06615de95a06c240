//! The board behind the firmware: small capability traits (STYLE.md §3.5, after embedded-hal).
//!
//! The core drives a motor, reads switches and inputs, sets outputs and keeps its EEPROM through these
//! traits only. The simulator (`tmcl-sim`) implements them; a microcontroller port would implement them
//! over its peripherals. Errors are associated types; the simulator uses [`core::convert::Infallible`]
//! where nothing can fail.

use crate::time::Instant;
use core::fmt::Debug;

/// Non-volatile memory: the module's configuration and program EEPROM.
///
/// # Contract
///
/// A [`Nvm::write`] call is atomic: after a crash or power loss at any moment, a later read sees either
/// all of `data` or none of it. The core relies on this and never writes one logical value in two calls.
pub trait Nvm {
    /// What can go wrong.
    type Error: Debug;

    /// Size of the memory in bytes.
    fn capacity(&self) -> usize;

    /// Reads `buf.len()` bytes from `offset`. Offsets past the end are an error, never a panic.
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error>;

    /// Writes `data` at `offset`, atomically (see the trait docs).
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Self::Error>;
}

impl<T: Nvm + ?Sized> Nvm for &mut T {
    type Error = T::Error;
    fn capacity(&self) -> usize {
        T::capacity(self)
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        T::read(self, offset, buf)
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Self::Error> {
        T::write(self, offset, data)
    }
}

/// Raw levels of the reference switches. `true` = the switch input is active with normal polarity
/// (GP 79 = 0); the core applies GP 79 itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Switches {
    /// Left stop switch (negative direction).
    pub left: bool,
    /// Right stop switch (positive direction).
    pub right: bool,
    /// Home (reference) switch.
    pub home: bool,
}

/// Digital and analog I/O of the module (PD28-1021 manual §3.7.14–3.7.15).
pub trait Io {
    /// Levels of the general-purpose digital inputs; bit n = INn.
    fn digital_inputs(&mut self) -> u8;

    /// A 12-bit ADC reading (0..=4095) of analog channel `channel`.
    fn analog_input(&mut self, channel: u8) -> u16;

    /// Module temperature in °C.
    fn temperature(&mut self) -> i32;

    /// Drives the general-purpose outputs; bit n = OUTn.
    fn set_outputs(&mut self, bits: u8);

    /// The reference switches, as they are now (the board knows where the axis is from [`Drive::update`]).
    fn switches(&mut self) -> Switches;
}

/// What the step generator asks of the motor driver, passed to [`Drive::update`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriveState {
    /// Microsteps (of the current resolution) moved since the previous update, signed. Setting the step
    /// counter (SAP 1) or a reset changes `position` without moving: `moved` is then 0.
    pub moved: i64,
    /// The step counter (axis parameter 1) in microsteps of the current resolution.
    pub position: i32,
    /// Signed velocity in microsteps per second (axis parameter 3).
    pub velocity: i32,
    /// Microstep resolution as a power of two: microsteps per full step = 1 << resolution (AP 140).
    pub resolution: u8,
    /// Current setting 0..=255 (255 = the module's maximum), after run/boost/standby selection.
    pub current: u8,
    /// Whether the driver stages are on; off = the motor freewheels (AP 204, AP 167 = 0).
    pub enabled: bool,
    /// Reverse shaft (GP 90): the motor turns the other way for the same step counter.
    pub reverse: bool,
}

/// Sensor feedback from the driver and the encoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Feedback {
    /// Physical encoder counts since power-up, 1024 per revolution (sensOstep, manual §6.2), in the
    /// motor's physical direction.
    pub encoder_counts: i64,
    /// stallGuard2 load value 0..=1023 (AP 206); 0 = maximum load.
    pub load: u16,
    /// TMC262 error flags (AP 208).
    pub driver_flags: u8,
}

impl Default for Feedback {
    fn default() -> Feedback {
        Feedback { encoder_counts: 0, load: 1023, driver_flags: 0 }
    }
}

/// TMC262 settings besides the current, passed to [`Drive::configure`] (PD28-1021 manual chapter 4,
/// Table 15). The default is the module's factory setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriverSettings {
    /// AP 173: stallGuard2 filter; `true` = one measurement per 4 full steps (filtered mode).
    pub stall_filter: bool,
    /// AP 174: stallGuard2 threshold, −64..=63; higher = less sensitive (the load value reads higher).
    pub stall_threshold: i8,
    /// AP 179 = 0: high current range, 2 A peak / 1.4 A RMS at current 255. `false` (AP 179 = 1, the
    /// default) = low range, 1 A peak / 0.7 A RMS.
    pub high_range: bool,
}

/// The motor driver and its sensors.
pub trait Drive {
    /// Called after every motion tick with the state the motor should now be in.
    fn update(&mut self, now: Instant, state: &DriveState);

    /// Sensor readings as of the last update.
    fn feedback(&mut self) -> Feedback;

    /// Applies driver settings that change rarely (AP 173, 174, 179). A board without them ignores
    /// the call (the default).
    fn configure(&mut self, settings: &DriverSettings) {
        let _ = settings;
    }

    /// How many stallGuard2 measurements the driver has taken since power-up (wrapping). Each new one is
    /// a new [`Feedback::load`] reading: the core runs one coolStep step per measurement
    /// ([`crate::drive::coolstep`]). A board without stallGuard2 never measures (the default, 0).
    fn load_measurements(&mut self) -> u32 {
        0
    }
}

/// Everything a module needs from its board.
pub trait Board: Nvm + Io + Drive {}

impl<T: Nvm + Io + Drive> Board for T {}

//! What the simulated board takes from the model — its encoder, its driver and how many inputs and
//! outputs it has — so that one board simulates every model and product differences stay data.
//!
//! # Decisions
//!
//! - **A profile is a value, made from a model.** [`Profile::of`] copies the few facts the board needs out
//!   of a [`ModelSpec`]; [`SimBoard::for_model`] builds a board for a model, [`SimBoard::for_profile`] for
//!   a profile a test or tool adjusted (`Profile { encoder: None, ..Profile::PD28_1021 }`).
//!   [`SimBoard::new`] and [`SimBoard::in_memory`] are the PD28-1021 board ([`Profile::PD28_1021`]),
//!   as they always were. The profile survives [`SimBoard::set_world`]: a world is what is around the
//!   module, the profile what the module is.
//! - **Encoder.** The counts per revolution are the model's [`Encoder::counts_per_rev`] (1024 on the
//!   PD28-1021, manual §6.2), or the world's `[encoder]` for a module that takes an external one (the
//!   TMCM-1310), counted from the world's `driver.encoder_zero`. The module selects its encoder input
//!   (`DriverSettings::ssi_encoder`): an A/B/N input reads counts since power-up, an SSI input the
//!   angle within one revolution; an input with nothing of its kind attached reads 0. A model without
//!   an encoder reads 0 counts, with or without injected encoder slip (there is nothing to slip).
//! - **Current.** The coil current at setting 255 is the model's peak current (1 A or 2 A by sense range
//!   on the PD28-1021, 4.24 A — 3 A RMS — on the TMCM-1310).
//! - **Driver.** Only the TMC262 ([`Driver::Tmc262`]) measures the load (stallGuard2): with another driver
//!   the board takes no measurement, so the load reads 1023 (no load), the measurement counter stays 0
//!   and the stall flag (AP 208 bit 0) is never set. The other flags (faults, temperature, standstill)
//!   and the coil current are modelled the same for every driver. Closed loop is the firmware's: the
//!   board only moves the field where the firmware says and reports the rotor through the encoder.
//! - **Inputs and outputs.** The digital inputs read through the model's input mask (4 inputs: bits
//!   0..=3), whatever the world sets; the outputs keep only the model's output bits (the core masks them
//!   too). [`SimBoard::world`](crate::SimBoard::world) keeps the world's levels as set.
//! - **Not from the model**: full steps per revolution and the load are the world's motor (the model
//!   describes the module, not the motor: `motor.full_steps`, 200 by default as on the PD28-1021's
//!   motor); positions in the world are physical 1/256 microsteps, and the microstep resolution in force
//!   comes with each driver update ([`DriveState::resolution`](tmcl_core::hal::DriveState::resolution),
//!   the model's AP 140).
//!
//! [`SimBoard::for_model`]: crate::SimBoard::for_model
//! [`SimBoard::for_profile`]: crate::SimBoard::for_profile
//! [`SimBoard::new`]: crate::SimBoard::new
//! [`SimBoard::in_memory`]: crate::SimBoard::in_memory
//! [`SimBoard::set_world`]: crate::SimBoard::set_world

use tmcl_core::model::{pd28_1021, Driver, Encoder, ModelSpec};

/// The facts of a model the simulated board is built from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Profile {
    /// The model's encoder; `None` = no encoder (reads 0 counts).
    pub encoder: Option<Encoder>,
    /// The motor driver: only [`Driver::Tmc262`] measures the load.
    pub driver: Driver,
    /// Number of digital inputs (IN0..): the others read 0.
    pub inputs: u8,
    /// Number of digital outputs (OUT0..): the others are not driven.
    pub outputs: u8,
    /// Peak coil current in mA at current setting 255, low and high range (the model's `peak_current_ma`).
    pub peak_current_ma: [u16; 2],
    /// Number of motors (the model's, 1 to 6): a [`crate::SimBoard`] simulates an axis for each.
    pub motors: u8,
}

impl Profile {
    /// The PD28-1021: sensOstep encoder with 1024 counts per revolution, TMC262, 4 inputs, 2 outputs.
    pub const PD28_1021: Profile = Profile::of(&pd28_1021::SPEC);

    /// The profile of a model.
    pub const fn of(spec: &ModelSpec) -> Profile {
        let d = spec.desc();
        Profile {
            encoder: d.encoder,
            driver: d.driver,
            inputs: d.inputs,
            outputs: d.outputs,
            peak_current_ma: d.peak_current_ma,
            motors: d.motors,
        }
    }

    /// Encoder counts per motor revolution, if the model has an encoder.
    pub const fn encoder_counts_per_rev(&self) -> Option<u32> {
        match self.encoder {
            Some(e) => Some(e.counts_per_rev),
            None => None,
        }
    }

    /// Whether the driver measures the load (stallGuard2 on the TMC262).
    pub const fn measures_load(&self) -> bool {
        matches!(self.driver, Driver::Tmc262)
    }

    /// The bits of the digital inputs the model has.
    pub const fn input_mask(&self) -> u8 {
        mask(self.inputs)
    }

    /// The bits of the outputs the model has.
    pub const fn output_mask(&self) -> u8 {
        mask(self.outputs)
    }
}

impl Default for Profile {
    /// The PD28-1021.
    fn default() -> Profile {
        Profile::PD28_1021
    }
}

impl From<&ModelSpec> for Profile {
    fn from(spec: &ModelSpec) -> Profile {
        Profile::of(spec)
    }
}

/// The low `n` bits (all 8 from 8 on).
const fn mask(n: u8) -> u8 {
    if n >= 8 {
        0xFF
    } else {
        (1u8 << n) - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_core::model::EncoderKind;

    #[test]
    fn the_pd28_profile_is_the_model() {
        let p = Profile::PD28_1021;
        assert_eq!(p.encoder_counts_per_rev(), Some(1024));
        assert_eq!(p.encoder.map(|e| e.kind), Some(EncoderKind::SensOstep));
        assert!(p.measures_load());
        assert_eq!((p.input_mask(), p.output_mask()), (0b1111, 0b11));
        assert_eq!(Profile::default(), Profile::of(&pd28_1021::SPEC));
    }

    #[test]
    fn masks() {
        assert_eq!([mask(0), mask(1), mask(7), mask(8)], [0, 1, 0x7F, 0xFF]);
        let p = Profile { driver: Driver::Tmc428Tmc24x, ..Profile::PD28_1021 };
        assert!(!p.measures_load());
    }
}

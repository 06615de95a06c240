//! What a microcontroller port of the OpenTMCL firmware needs besides the core, as plain `no_std` code
//! without `unsafe` that runs, and is tested, on the host as well as on the target.
//!
//! A port (the LM3S6965 image under `firmware/` is one) owns the registers and the interrupt handlers;
//! everything in them that is logic rather than a register access lives here, so that `cargo test` checks
//! it without a microcontroller:
//!
//! - [`ring`]: a lock-free single-producer, single-consumer byte queue, for the bytes an interrupt handler
//!   receives from the UART and the bytes the main loop sends through it;
//! - [`clock`]: the millisecond tick counter of the timer interrupt, extended to the core's
//!   [`tmcl_core::Instant`];
//! - [`uart`]: the divisors that set a 16×-oversampling UART (the ARM PL011 and its relatives) to each
//!   baud rate of GP 65 (PD28-1021 manual §5.1, Table 17);
//! - [`step`]: the step/direction pulse generator that turns the microsteps the core's ramp moves per
//!   motion tick into pulses, one per interrupt of a step timer;
//! - [`nvm`]: an EEPROM in RAM, for a board whose flash cannot be written (as under QEMU);
//! - [`strap`]: which model the image runs, from a configuration word the loader writes.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod clock;
pub mod nvm;
pub mod ring;
pub mod step;
pub mod strap;
pub mod uart;

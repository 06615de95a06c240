//! The register shim: the only module with `unsafe` besides the start-up code in `main.rs`.
//!
//! Everything else reaches the hardware through the [`Reg`] values made here, each from the LM3S6965 data
//! sheet's register map (section numbers below are of that data sheet, "Stellaris LM3S6965
//! Microcontroller", DS-LM3S6965), or through the safe API of the `cortex-m` crate (SysTick, SCB). A
//! [`Reg`] cannot be made outside this module, so no safe code can turn an arbitrary number into a
//! register access.
#![allow(unsafe_code)]
// Offsets are written as the data sheet lists them, offset 0 included.
#![allow(clippy::identity_op)]

use core::sync::atomic::AtomicU8;
use tmcl_core::model::MODELS;
use tmcl_core::param::persist;

/// A 32-bit memory-mapped peripheral register.
#[derive(Clone, Copy)]
pub struct Reg(usize);

impl Reg {
    /// Reads the register.
    #[inline(always)]
    pub fn read(self) -> u32 {
        // SAFETY: every `Reg` is made in this module from the data sheet's register map: a 32-bit, aligned
        // register of a peripheral that is present on the LM3S6965 (and emulated by QEMU). A volatile read
        // of a device register touches no Rust object.
        unsafe { core::ptr::read_volatile(self.0 as *const u32) }
    }

    /// Writes the register.
    #[inline(always)]
    pub fn write(self, value: u32) {
        // SAFETY: as in `read`; no register made here maps memory that Rust code owns.
        unsafe { core::ptr::write_volatile(self.0 as *mut u32, value) }
    }

    /// Reads, changes and writes back the register (not atomic: the caller owns the register).
    #[inline(always)]
    pub fn modify(self, f: impl FnOnce(u32) -> u32) {
        self.write(f(self.read()));
    }
}

/// System control (§6.5): clocks and the clock gates of the peripherals.
pub mod sysctl {
    use super::Reg;
    const BASE: usize = 0x400F_E000;
    /// Raw interrupt status (bit 6: PLL lock).
    pub const RIS: Reg = Reg(BASE + 0x050);
    /// Run-mode clock configuration.
    pub const RCC: Reg = Reg(BASE + 0x060);
    /// Run-mode clock gating 0 (bit 16: ADC).
    pub const RCGC0: Reg = Reg(BASE + 0x100);
    /// Run-mode clock gating 1 (bit 0: UART0; bits 16, 17: timers 0, 1).
    pub const RCGC1: Reg = Reg(BASE + 0x104);
    /// Run-mode clock gating 2 (bits 0..6: GPIO ports A..G).
    pub const RCGC2: Reg = Reg(BASE + 0x108);
}

/// A GPIO port (§8.5).
#[derive(Clone, Copy)]
pub struct Gpio(usize);

impl Gpio {
    /// The data register seen through the address mask `pins`: a read gives only those pins, a write
    /// changes only those pins (§8.2.1.2, "Data Register Operation").
    pub const fn data(self, pins: u8) -> Reg {
        Reg(self.0 + ((pins as usize) << 2))
    }
    /// Direction (1 = output).
    pub const fn dir(self) -> Reg {
        Reg(self.0 + 0x400)
    }
    /// Alternate function select.
    pub const fn afsel(self) -> Reg {
        Reg(self.0 + 0x420)
    }
    /// Pull-up select.
    pub const fn pur(self) -> Reg {
        Reg(self.0 + 0x510)
    }
    /// Pull-down select.
    pub const fn pdr(self) -> Reg {
        Reg(self.0 + 0x514)
    }
    /// Digital enable.
    pub const fn den(self) -> Reg {
        Reg(self.0 + 0x51C)
    }
}

/// GPIO port A (UART0 on PA0, PA1).
pub const GPIOA: Gpio = Gpio(0x4000_4000);
/// GPIO port B (the step/direction output and the reference switches).
pub const GPIOB: Gpio = Gpio(0x4000_5000);
/// GPIO port E (the evaluation board's navigation switches: the digital inputs).
pub const GPIOE: Gpio = Gpio(0x4002_4000);
/// GPIO port F (the evaluation board's user LED: OUT0).
pub const GPIOF: Gpio = Gpio(0x4002_5000);

/// UART0 (§12.6), an ARM PL011.
pub mod uart0 {
    use super::Reg;
    const BASE: usize = 0x4000_C000;
    /// Data; bits 8..11 of a read are the byte's error flags.
    pub const DR: Reg = Reg(BASE + 0x000);
    /// Receive status; a write clears the errors.
    pub const ECR: Reg = Reg(BASE + 0x004);
    /// Flags (bit 3 busy, bit 4 receive FIFO empty, bit 5 transmit FIFO full).
    pub const FR: Reg = Reg(BASE + 0x018);
    /// Integer baud-rate divisor.
    pub const IBRD: Reg = Reg(BASE + 0x024);
    /// Fractional baud-rate divisor.
    pub const FBRD: Reg = Reg(BASE + 0x028);
    /// Line control (a write latches the divisors).
    pub const LCRH: Reg = Reg(BASE + 0x02C);
    /// Control.
    pub const CTL: Reg = Reg(BASE + 0x030);
    /// Interrupt FIFO level select.
    pub const IFLS: Reg = Reg(BASE + 0x034);
    /// Interrupt mask.
    pub const IM: Reg = Reg(BASE + 0x038);
    /// Masked interrupt status.
    pub const MIS: Reg = Reg(BASE + 0x040);
    /// Interrupt clear.
    pub const ICR: Reg = Reg(BASE + 0x044);
}

/// A general-purpose timer (§9.5), used as one 32-bit timer.
#[derive(Clone, Copy)]
pub struct Timer(usize);

impl Timer {
    /// Configuration (0 = 32-bit timer).
    pub const fn cfg(self) -> Reg {
        Reg(self.0 + 0x00)
    }
    /// Timer A mode (2 = periodic).
    pub const fn tamr(self) -> Reg {
        Reg(self.0 + 0x04)
    }
    /// Control (bit 0: enable; bit 5: ADC trigger output).
    pub const fn ctl(self) -> Reg {
        Reg(self.0 + 0x0C)
    }
    /// Interrupt mask (bit 0: time-out).
    pub const fn imr(self) -> Reg {
        Reg(self.0 + 0x18)
    }
    /// Interrupt clear.
    pub const fn icr(self) -> Reg {
        Reg(self.0 + 0x24)
    }
    /// Interval load.
    pub const fn tailr(self) -> Reg {
        Reg(self.0 + 0x28)
    }
}

/// Timer 0: the step pulses.
pub const TIMER0: Timer = Timer(0x4003_0000);
/// Timer 1: the ADC's sampling trigger.
pub const TIMER1: Timer = Timer(0x4003_1000);

/// The ADC (§13.5) and its sample sequencers.
pub mod adc {
    use super::Reg;
    const BASE: usize = 0x4003_8000;
    /// Active sample sequencers.
    pub const ACTSS: Reg = Reg(BASE + 0x000);
    /// Trigger source of each sequencer (4 bits each; 5 = timer).
    pub const EMUX: Reg = Reg(BASE + 0x014);
    /// Input multiplexer of sequencer `n`.
    pub const fn ssmux(n: usize) -> Reg {
        Reg(BASE + 0x040 + 0x20 * (n & 3))
    }
    /// Control of sequencer `n`.
    pub const fn ssctl(n: usize) -> Reg {
        Reg(BASE + 0x044 + 0x20 * (n & 3))
    }
    /// Result FIFO of sequencer `n`.
    pub const fn ssfifo(n: usize) -> Reg {
        Reg(BASE + 0x048 + 0x20 * (n & 3))
    }
    /// FIFO status of sequencer `n` (bit 8: empty).
    pub const fn ssfstat(n: usize) -> Reg {
        Reg(BASE + 0x04C + 0x20 * (n & 3))
    }
}

/// The address of the board configuration word: the first word of the 256 bytes at the top of SRAM that
/// memory.x keeps from the linker (see [`tmcl_mcu::strap`]).
pub const STRAP_ADDRESS: usize = 0x2000_FF00;

/// The board configuration word (which model to run), as the loader left it.
pub fn strap_word() -> u32 {
    // SAFETY: STRAP_ADDRESS is an aligned word of on-chip SRAM that memory.x reserves: no Rust object
    // lives there, and any bit pattern is a valid u32.
    unsafe { core::ptr::read_volatile(STRAP_ADDRESS as *const u32) }
}

/// The RAM the image sets aside for the EEPROM: every model of [`MODELS`] must fit in it, or the image
/// does not build (the assertion below), instead of a model's EEPROM being cut short at start-up.
pub const EEPROM_AREA: usize = 20 * 1024;

/// The largest EEPROM image of the models in the image (all of [`MODELS`]: the strap chooses among
/// them, `tmcl_mcu::strap`).
pub const EEPROM_LEN: usize = persist::max_capacity(MODELS);

const _: () = assert!(
    EEPROM_LEN <= EEPROM_AREA,
    "a model's EEPROM image does not fit the firmware's EEPROM area (shim::EEPROM_AREA)"
);

/// The EEPROM (see [`tmcl_mcu::nvm`]): in `.uninit`, RAM that the start-up code neither clears nor
/// initialises, so that it keeps its contents across a reset (a panic resets, see `lib.rs`). The
/// initialiser is never applied.
// SAFETY: the section is NOLOAD RAM (cortex-m-rt's link.x); whatever it holds at start-up is a valid
// `AtomicU8` (every bit pattern is), and the cells are only ever accessed atomically.
#[link_section = ".uninit.tmcl_eeprom"]
pub static EEPROM: [AtomicU8; EEPROM_LEN] = [const { AtomicU8::new(0xFF) }; EEPROM_LEN];

/// Unmasks the interrupts the firmware handles in the NVIC and enables interrupts.
pub fn enable_interrupts() {
    use lm3s6965::Interrupt;
    // SAFETY: the handlers of these interrupts (`main.rs`) share data with the main loop only through
    // atomics and the lock-free queues of `tmcl_mcu`, and the main loop's critical sections use
    // `cortex_m::interrupt::free`, which unmasking does not break.
    unsafe {
        cortex_m::peripheral::NVIC::unmask(Interrupt::UART0);
        cortex_m::peripheral::NVIC::unmask(Interrupt::TIMER_0A);
        cortex_m::interrupt::enable();
    }
}

//! The system clock (50 MHz from the PLL) and SysTick, the core's 1 ms time base.

use crate::shim::sysctl::{RCC, RIS};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use tmcl_core::Instant;
use tmcl_mcu::clock::{micros_into_tick, Monotonic, Ticks};

/// The system clock: the PLL's 200 MHz divided by 4, the LM3S6965's maximum of 50 MHz.
pub const CLOCK_HZ: u32 = 50_000_000;

/// Milliseconds since start-up, counted by the SysTick interrupt.
pub static TICKS: Ticks = Ticks::new();

/// Runs the processor from the PLL at [`CLOCK_HZ`], following the data sheet's sequence (§6.3, "Initialization
/// and Configuration"): bypass the PLL, select the 8 MHz crystal of the evaluation board and power the PLL
/// up, set the divisor, wait for the PLL to lock, then leave bypass.
pub fn init() {
    const MOSCDIS: u32 = 1 << 0;
    const OSCSRC: u32 = 0x3 << 4;
    const XTAL: u32 = 0xF << 6;
    const XTAL_8MHZ: u32 = 0xE << 6;
    const BYPASS: u32 = 1 << 11;
    const OEN: u32 = 1 << 12;
    const PWRDN: u32 = 1 << 13;
    const USESYSDIV: u32 = 1 << 22;
    const SYSDIV: u32 = 0xF << 23;
    const SYSDIV_BY_4: u32 = 3 << 23;
    const PLLLRIS: u32 = 1 << 6;
    RCC.modify(|r| (r | BYPASS) & !USESYSDIV);
    RCC.modify(|r| (r & !(XTAL | OSCSRC | PWRDN | OEN | MOSCDIS)) | XTAL_8MHZ);
    RCC.modify(|r| (r & !SYSDIV) | SYSDIV_BY_4 | USESYSDIV);
    // The PLL locks within 0.5 ms; the bound keeps a board without lock running (slowly) rather than stuck.
    for _ in 0..100_000 {
        if RIS.read() & PLLLRIS != 0 {
            break;
        }
    }
    RCC.modify(|r| r & !BYPASS);
}

/// Starts SysTick: one interrupt per millisecond from the processor clock.
pub fn start_systick(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(CLOCK_HZ / 1000 - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// The time now: the tick count and the microseconds into the tick, read until no tick came in between.
pub fn now(time: &mut Monotonic) -> Instant {
    const RELOAD: u32 = CLOCK_HZ / 1000 - 1;
    loop {
        let ticks = TICKS.read();
        let current = SYST::get_current();
        if TICKS.read() == ticks {
            return time.at(ticks, micros_into_tick(RELOAD, current));
        }
    }
}

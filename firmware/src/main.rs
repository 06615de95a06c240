//! The firmware image: start-up and interrupt vectors; everything else is in the library (`lib.rs`).
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use lm3s6965::interrupt;

#[entry]
fn main() -> ! {
    tmcl_lm3s6965::run()
}

#[exception]
fn SysTick() {
    tmcl_lm3s6965::clock::TICKS.tick();
}

#[interrupt]
fn UART0() {
    tmcl_lm3s6965::uart::on_interrupt();
}

#[interrupt]
fn TIMER_0A() {
    tmcl_lm3s6965::steps::on_interrupt();
}

// SAFETY: cortex-m-rt requires the hard fault handler to be an `unsafe fn`; this one only resets, as the
// panic handler does (a hard fault would otherwise hang the module silently).
#[allow(unsafe_code)]
#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

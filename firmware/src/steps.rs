//! The step/direction output (see [`tmcl_mcu::step`]): STEP on PB0, DIR on PB1, the driver's active-low
//! enable (ENN, as on the TMC262) on PB2; timer 0 gives one step per interrupt.

use crate::clock::CLOCK_HZ;
use crate::shim::{sysctl, GPIOB, TIMER0};
use tmcl_core::motion::TICK;
use tmcl_mcu::step::{period, StepOutput};

/// The steps between the core and the driver.
pub static STEPS: StepOutput = StepOutput::new();

/// STEP pin (PB0).
pub const STEP: u8 = 1 << 0;
/// DIR pin (PB1): high = positive.
pub const DIR: u8 = 1 << 1;
/// ENN pin (PB2): low = driver on.
pub const ENN: u8 = 1 << 2;

/// The fastest step rate, 100 kHz (500 cycles between step interrupts): well above the 51 200 pps of a
/// revolution per second at 256 microsteps, and a fifth of the processor at most.
pub const MIN_PERIOD: u32 = CLOCK_HZ / 100_000;

/// Clocks port B and timer 0; STEP, DIR, ENN as outputs, the driver off.
pub fn init() {
    sysctl::RCGC1.modify(|r| r | 1 << 16);
    sysctl::RCGC2.modify(|r| r | 1 << 1);
    let pins = u32::from(STEP | DIR | ENN);
    GPIOB.dir().modify(|r| r | pins);
    GPIOB.den().modify(|r| r | pins);
    GPIOB.data(STEP | DIR | ENN).write(u32::from(ENN));
    TIMER0.ctl().write(0);
    TIMER0.cfg().write(0);
    TIMER0.tamr().write(2);
    TIMER0.imr().write(1);
}

/// Switches the driver stage on or off.
pub fn enable(on: bool) {
    GPIOB.data(ENN).write(if on { 0 } else { u32::from(ENN) });
}

/// Adds the core's steps and sets the step timer to spread what is pending over the next motion tick.
pub fn add(moved: i64) {
    let pending = STEPS.add(moved);
    cortex_m::interrupt::free(|_| {
        if let Some(cycles) = period(CLOCK_HZ, TICK.micros() as u32, pending, MIN_PERIOD) {
            TIMER0.tailr().write(cycles - 1);
            TIMER0.ctl().modify(|c| c | 1);
        }
    });
}

/// The timer 0 interrupt: one step, or stop when none is pending.
pub fn on_interrupt() {
    TIMER0.icr().write(1);
    match STEPS.take() {
        Some(positive) => {
            GPIOB.data(DIR).write(if positive { u32::from(DIR) } else { 0 });
            GPIOB.data(STEP).write(u32::from(STEP));
            GPIOB.data(STEP).write(0);
        }
        None => TIMER0.ctl().modify(|c| c & !1),
    }
}

//! The ADC: sequencer 0 samples the analog input (ADC0), sequencer 1 the temperature sensor (ADC1), both
//! triggered by timer 1 every 10 ms; the board reads the newest result.
//!
//! QEMU's model of the ADC accepts only single-sample sequences triggered by a timer and has no real
//! inputs (it returns mid-scale with a little noise), which is why the sensor is wired to ADC1 rather than
//! selected with the TS bit of the internal sensor; see docs/qemu.md.

use crate::clock::CLOCK_HZ;
use crate::shim::{adc, sysctl, TIMER1};

/// Sequencer control: one sample, then end and raise the (masked) interrupt flag.
const END_AND_FLAG: u32 = 0b0110;
const FIFO_EMPTY: u32 = 1 << 8;

/// Clocks the ADC and timer 1 and starts sampling.
pub fn init() {
    sysctl::RCGC0.modify(|r| r | 1 << 16);
    sysctl::RCGC1.modify(|r| r | 1 << 17);
    adc::ACTSS.write(0);
    // Both sequencers triggered by a timer.
    adc::EMUX.write(0x55);
    adc::ssmux(0).write(0);
    adc::ssctl(0).write(END_AND_FLAG);
    adc::ssmux(1).write(1);
    adc::ssctl(1).write(END_AND_FLAG);
    adc::ACTSS.write(0b11);
    TIMER1.ctl().write(0);
    TIMER1.cfg().write(0);
    TIMER1.tamr().write(2);
    TIMER1.tailr().write(CLOCK_HZ / 100 - 1);
    // Enable, with the ADC trigger output.
    TIMER1.ctl().write(1 | 1 << 5);
}

/// The newest 10-bit result of sequencer `n`, or `last` when it has none since.
pub fn latest(n: usize, last: u16) -> u16 {
    let mut value = last;
    // A FIFO holds at most 8 results; the bound keeps a stuck status from hanging the caller.
    for _ in 0..16 {
        if adc::ssfstat(n).read() & FIFO_EMPTY != 0 {
            break;
        }
        value = (adc::ssfifo(n).read() & 0x3FF) as u16;
    }
    value
}

/// °C from the 10-bit reading of the temperature sensor, with the transfer function of the LM3S6965's
/// internal sensor (data sheet §13.3.6: TEMP = 147.5 − 225 × ADC / 1023), rounded.
pub fn celsius(reading: u16) -> i32 {
    let tenths = 1475 - (2250 * i32::from(reading) + 511) / 1023;
    (tenths + if tenths >= 0 { 5 } else { -5 }) / 10
}

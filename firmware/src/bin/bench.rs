//! Placeholder; replaced below.
#![no_std]
#![no_main]
use cortex_m_rt::entry;
#[entry]
fn main() -> ! {
    tmcl_lm3s6965::run()
}

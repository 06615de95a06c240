//! The UART divisors a 16×-oversampling UART (the ARM PL011 of the LM3S6965) needs for each baud rate
//! of GP 65 (PD28-1021 TMCL firmware manual §5.1, Table 17) at a 50 MHz clock, with the rate each gives;
//! then a request frame through the byte queue an interrupt handler fills and the main loop drains.
//!
//! Run with `cargo run -p tmcl-mcu --example uart_and_ring`.

use tmcl_mcu::ring::ByteRing;
use tmcl_mcu::uart::{actual_millibaud, divisors, BAUD_RATES};

const CLOCK_HZ: u32 = 50_000_000;

fn main() {
    println!("GP 65  baud     IBRD  FBRD  actual      error");
    for (code, &baud) in BAUD_RATES.iter().enumerate() {
        let d = divisors(CLOCK_HZ, baud);
        let actual = actual_millibaud(CLOCK_HZ, d) as f64 / 1000.0;
        let error = (actual - f64::from(baud)) / f64::from(baud) * 100.0;
        println!("{code:>5}  {baud:<8} {:>5} {:>5}  {actual:<11.1} {error:+.3} %", d.integer, d.fraction);
        assert!(error.abs() < 2.0, "a UART tolerates about 2 %");
    }

    // The receive interrupt pushes each byte; the main loop takes what has arrived in one go.
    static RX: ByteRing<64> = ByteRing::new();
    for b in [0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08] {
        assert!(RX.push(b), "room for a frame");
    }
    let mut frame = [0u8; 9];
    let n = RX.pop_into(&mut frame);
    println!("\nmain loop took {n} bytes: {frame:02X?} (GAP 1, 0 to module 1)");
}

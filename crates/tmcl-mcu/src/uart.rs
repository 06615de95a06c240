//! UART baud-rate divisors for the GP 65 baud rates (PD28-1021 manual §5.1, Table 17).
//!
//! A 16×-oversampling UART (the ARM PL011, the Stellaris and Tiva UARTs, the STM32 USART with OVER8 = 0)
//! divides its clock by 16 × (integer + fraction / 64). [`divisors`] rounds to the nearest 64th, which
//! puts every rate of Table 17 within 0.1 % at the clocks a Cortex-M3 runs at, far inside the ±2 % that
//! 8N1 framing tolerates.

pub use tmcl_core::model::{baud_rate, BAUD_RATES};

/// A UART's baud-rate divisor: clock / (16 × baud) = `integer` + `fraction` / 64.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Divisors {
    /// The integer part (the PL011's IBRD, 1..=65535).
    pub integer: u16,
    /// The fraction in 64ths (the PL011's FBRD, 0..=63).
    pub fraction: u8,
}

/// The divisors nearest to `baud` at a UART clock of `clock_hz`; out-of-range results are clamped to
/// what the registers hold (a baud rate of 0 counts as 1).
pub const fn divisors(clock_hz: u32, baud: u32) -> Divisors {
    let baud = if baud == 0 { 1 } else { baud as u64 };
    // 64 × clock / (16 × baud), rounded to the nearest integer.
    let sixty_fourths = (clock_hz as u64 * 8 / baud).div_ceil(2);
    let integer = sixty_fourths / 64;
    if integer == 0 {
        Divisors { integer: 1, fraction: 0 }
    } else if integer > 0xFFFF {
        Divisors { integer: 0xFFFF, fraction: 0 }
    } else {
        Divisors { integer: integer as u16, fraction: (sixty_fourths % 64) as u8 }
    }
}

/// The baud rate that `divisors` give at `clock_hz`, in millibaud (for checks and logs).
pub const fn actual_millibaud(clock_hz: u32, divisors: Divisors) -> u64 {
    let sixty_fourths = divisors.integer as u64 * 64 + divisors.fraction as u64;
    clock_hz as u64 * 4 * 1000 / sixty_fourths
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rate_of_table_17_within_a_tenth_of_a_percent() {
        for clock in [8_000_000u32, 12_500_000, 16_000_000, 50_000_000, 72_000_000] {
            for (index, &baud) in BAUD_RATES.iter().enumerate() {
                let d = divisors(clock, baud);
                let actual = actual_millibaud(clock, d);
                let wanted = u64::from(baud) * 1000;
                let error_ppm = actual.abs_diff(wanted) * 1_000_000 / wanted;
                assert!(error_ppm < 1000, "GP 65 = {index} at {clock} Hz: {d:?} gives {actual} mbaud");
                assert!(d.fraction < 64);
            }
        }
    }

    #[test]
    fn the_pl011_example_and_the_edges() {
        // The PL011 TRM's example: 4 MHz clock, 230400 baud → 1 + 5/64... (4e6 / (16 × 230400) = 1.085).
        assert_eq!(divisors(4_000_000, 230_400), Divisors { integer: 1, fraction: 5 });
        // 50 MHz, 115200 baud: 27.126 → 27 + 8/64.
        assert_eq!(divisors(50_000_000, 115_200), Divisors { integer: 27, fraction: 8 });
        assert_eq!(divisors(1_000, 230_400), Divisors { integer: 1, fraction: 0 });
        assert_eq!(divisors(u32::MAX, 0), Divisors { integer: 0xFFFF, fraction: 0 });
    }

    #[test]
    fn gp_65_values_past_the_table_are_9600() {
        assert_eq!(baud_rate(0), 9600);
        assert_eq!(baud_rate(7), 115_200);
        assert_eq!(baud_rate(8), 230_400);
        assert_eq!(baud_rate(9), 9600);
        assert_eq!(baud_rate(255), 9600);
    }
}

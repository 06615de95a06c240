//! The parsers of the command line's numbers: values, bytes and seconds, one of each for every command.

use std::time::Duration;

/// A decimal or `0x` hexadecimal number, with an optional sign (one parser for every tool:
/// [`tmcl_wire::ascii::parse_number`]).
pub(crate) use tmcl_wire::ascii::parse_number;

/// A 32-bit value: -2147483648..=2147483647, or up to 0xFFFFFFFF written in hex or decimal (two's complement,
/// as pytrinamic packs values unsigned).
pub(crate) fn parse_value(text: &str) -> Result<i32, String> {
    let n = parse_number(text).ok_or_else(|| format!("{text:?} is not a number"))?;
    tmcl_wire::ascii::value32(n).ok_or_else(|| format!("{text} does not fit in 32 bits"))
}

/// A byte, decimal or `0x` hexadecimal.
pub(crate) fn parse_byte(text: &str) -> Result<u8, String> {
    let n = parse_number(text).ok_or_else(|| format!("{text:?} is not a number"))?;
    u8::try_from(n).map_err(|_| format!("{text} is out of range 0..255"))
}

/// A positive number of seconds, at most 10^9, with at most six decimals (microseconds, the resolution
/// of the module's clock): `3600`, `0.5`, `.25`, `1.000001`. It is read exactly, as decimal digits (no
/// floating point, no exponent), so `--for 0.1` is 100 000 µs of simulated time and not a rounding of
/// it. Every option that takes seconds parses them so: `--timeout`, `--every`, `--for`, `--limit`.
pub(crate) fn parse_seconds(text: &str) -> Result<Duration, String> {
    let bad = || format!("`{text}` is not a number of seconds (e.g. 60 or 0.5)");
    let (whole, fraction) = text.trim().split_once('.').unwrap_or((text.trim(), ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if fraction.len() > 6 || !digits(whole) || !digits(fraction) || (whole.is_empty() && fraction.is_empty()) {
        return Err(bad());
    }
    let whole: u64 = if whole.is_empty() { 0 } else { whole.parse().map_err(|_| bad())? };
    let fraction: u64 = format!("{fraction:0<6}").parse().map_err(|_| bad())?;
    let micros = whole.checked_mul(1_000_000).and_then(|w| w.checked_add(fraction)).ok_or_else(bad)?;
    match micros {
        0 => Err(format!("`{text}`: the number of seconds must be more than 0")),
        m if m > 1_000_000 * 1_000_000_000 => Err(format!("`{text}`: at most 1000000000 seconds")),
        m => Ok(Duration::from_micros(m)),
    }
}

/// [`parse_seconds`] as simulated time.
pub(crate) fn parse_sim_seconds(text: &str) -> Result<tmcl_core::Duration, String> {
    parse_seconds(text).map(|d| tmcl_core::Duration::from_micros(d.as_micros() as u64))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_parse_exactly() {
        assert_eq!(parse_seconds("3600"), Ok(Duration::from_secs(3600)));
        assert_eq!(parse_seconds("0.5"), Ok(Duration::from_millis(500)));
        assert_eq!(parse_seconds(".25"), Ok(Duration::from_millis(250)));
        assert_eq!(parse_seconds("5."), Ok(Duration::from_secs(5)));
        assert_eq!(parse_seconds(" 0.005 "), Ok(Duration::from_millis(5)));
        assert_eq!(parse_seconds("1.000001"), Ok(Duration::from_micros(1_000_001)));
        assert_eq!(parse_seconds("1000000000"), Ok(Duration::from_secs(1_000_000_000)));
        assert_eq!(parse_sim_seconds("0.1"), Ok(tmcl_core::Duration::from_micros(100_000)));
        for bad in [
            "",
            ".",
            "-1",
            "+1",
            "1e3",
            "1.0000001",
            "x",
            "0",
            "0.000000",
            "1000000000.1",
            "99999999999999999999",
            "inf",
            "NaN",
        ] {
            assert!(parse_seconds(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_seconds("0").unwrap_err(), "`0`: the number of seconds must be more than 0");
    }

    #[test]
    fn values_and_bytes() {
        assert_eq!(parse_value("-1"), Ok(-1));
        assert_eq!(parse_value("0xFFFFFFFF"), Ok(-1));
        assert_eq!(parse_value("4294967295"), Ok(-1));
        assert!(parse_value("0x100000000").is_err());
        assert_eq!(parse_byte("0x10"), Ok(16));
        assert!(parse_byte("256").is_err());
    }
}

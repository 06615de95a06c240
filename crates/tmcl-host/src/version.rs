//! The firmware version of command 136 (PD28-1021 TMCL manual §3.7.38, Table 13).

use core::fmt;

/// The binary version of command 136 type 1.
///
/// The manual only says "binary format". Trinamic's reference firmware (TMC-EvalSystem `tmc/TMCL.c`,
/// `GetVersion`) packs the version string `1021V142` into the value as bytes 3..0 = `10`, `21`, `1`, `42`:
/// the module number as two decimal-digit pairs, then the major and minor firmware version. Older manuals say
/// the two high bytes are "currently not used" (0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FirmwareVersion {
    /// The module number (1021 for the PD28-1021), when the high bytes carry one.
    pub module: Option<u16>,
    /// Major firmware version (byte 1).
    pub major: u8,
    /// Minor firmware version (byte 0), two decimal digits: 42 means .42.
    pub minor: u8,
}

impl FirmwareVersion {
    /// Decodes the value of a command 136 type 1 reply.
    pub fn from_value(value: i32) -> FirmwareVersion {
        let [high, low, major, minor] = value.to_be_bytes();
        let module = match (high, low) {
            (0, 0) => None,
            (h, l) if h < 100 && l < 100 => Some(u16::from(h) * 100 + u16::from(l)),
            (h, l) => Some(u16::from_be_bytes([h, l])),
        };
        FirmwareVersion { module, major, minor }
    }

    /// Decodes a type 1 value with the type 0 string beside it (`1310V114`): the high word's two readings
    /// — digit pairs (`10`, `21` = 1021, the reference firmware) or one 16-bit number (`0x051E` = 1310,
    /// the TMCM-1310 V1.11 manual's p.63) — are told apart by the module number the string starts with.
    /// Without a match the digit-pair reading stands, as in [`FirmwareVersion::from_value`].
    pub fn from_value_and_string(value: i32, string: &str) -> FirmwareVersion {
        let v = FirmwareVersion::from_value(value);
        let named: Option<u16> = string.split(['V', 'v']).next().and_then(|n| n.trim().parse().ok());
        let [high, low, ..] = value.to_be_bytes();
        let word = u16::from_be_bytes([high, low]);
        match named {
            Some(n) if v.module != Some(n) && word == n => FirmwareVersion { module: Some(word), ..v },
            _ => v,
        }
    }

    /// The value a module puts in a command 136 type 1 reply (the inverse of [`FirmwareVersion::from_value`]
    /// for module numbers up to 9999).
    pub fn to_value(self) -> i32 {
        let module = self.module.unwrap_or(0);
        i32::from_be_bytes([(module / 100) as u8, (module % 100) as u8, self.major, self.minor])
    }
}

impl fmt::Display for FirmwareVersion {
    /// `1.42`, or `1.42 (module 1021)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:02}", self.major, self.minor)?;
        if let Some(module) = self.module {
            write!(f, " (module {module})")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_firmware_layout() {
        // 1021V142 as TMC-EvalSystem `GetVersion` packs it: 10, 21, 1, 42.
        let v = FirmwareVersion::from_value(0x0A15_012A);
        assert_eq!(v, FirmwareVersion { module: Some(1021), major: 1, minor: 42 });
        assert_eq!(v.to_string(), "1.42 (module 1021)");
        assert_eq!(v.to_value(), 0x0A15_012A);
        // The TMCM-1310's 0x051E is 1310 as one number: the string says which reading is meant.
        let v = FirmwareVersion::from_value_and_string(0x051E_010E, "1310V114");
        assert_eq!(v.to_string(), "1.14 (module 1310)");
        let v = FirmwareVersion::from_value_and_string(0x0A15_012A, "1021V142");
        assert_eq!(v.module, Some(1021));
        let old = FirmwareVersion::from_value(0x0000_0107);
        assert_eq!(old.to_string(), "1.07");
    }
}

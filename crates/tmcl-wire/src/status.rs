//! Reply status codes (PD28-1021 TMCL manual §3.2.1, Table 4; code 8 from the TMCM-1310 manual §3.7).

use core::fmt;

/// The status byte of a reply (§3.2.1). Codes outside the table are kept as [`Status::Unknown`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Status {
    /// 100: successfully executed, no error.
    Ok,
    /// 101: command loaded into TMCL program EEPROM (download mode, §3.7.38 command 132).
    Loaded,
    /// 1: wrong checksum.
    WrongChecksum,
    /// 2: invalid command.
    InvalidCommand,
    /// 3: wrong type.
    WrongType,
    /// 4: invalid value.
    InvalidValue,
    /// 5: configuration EEPROM locked.
    EepromLocked,
    /// 6: command not available.
    NotAvailable,
    /// 8: parameter is password protected (TMCM-1310 manual §3.7, "Status Codes" table). Not in the
    /// PD28-1021's Table 4.
    PasswordProtected,
    /// 128: the delayed second reply of command 138, "target position reached" (§3.7.37). Not in Table 4.
    TargetReached,
    /// Any other code, kept as received.
    Unknown(u8),
}

impl Status {
    /// Whether the code means success (100, 101 and the 128 event).
    pub fn is_success(self) -> bool {
        matches!(self, Status::Ok | Status::Loaded | Status::TargetReached)
    }

    /// The manual's wording (Table 4; TMCM-1310 manual §3.7 for code 8).
    pub fn description(self) -> &'static str {
        match self {
            Status::Ok => "successfully executed, no error",
            Status::Loaded => "command loaded into TMCL program EEPROM",
            Status::WrongChecksum => "wrong checksum",
            Status::InvalidCommand => "invalid command",
            Status::WrongType => "wrong type",
            Status::InvalidValue => "invalid value",
            Status::EepromLocked => "configuration EEPROM locked",
            Status::NotAvailable => "command not available",
            Status::PasswordProtected => "parameter is password protected",
            Status::TargetReached => "target position reached",
            Status::Unknown(_) => "unknown status",
        }
    }
}

impl From<u8> for Status {
    #[inline]
    fn from(code: u8) -> Status {
        match code {
            100 => Status::Ok,
            101 => Status::Loaded,
            1 => Status::WrongChecksum,
            2 => Status::InvalidCommand,
            3 => Status::WrongType,
            4 => Status::InvalidValue,
            5 => Status::EepromLocked,
            6 => Status::NotAvailable,
            8 => Status::PasswordProtected,
            128 => Status::TargetReached,
            other => Status::Unknown(other),
        }
    }
}

impl From<Status> for u8 {
    #[inline]
    fn from(status: Status) -> u8 {
        match status {
            Status::Ok => 100,
            Status::Loaded => 101,
            Status::WrongChecksum => 1,
            Status::InvalidCommand => 2,
            Status::WrongType => 3,
            Status::InvalidValue => 4,
            Status::EepromLocked => 5,
            Status::NotAvailable => 6,
            Status::PasswordProtected => 8,
            Status::TargetReached => 128,
            Status::Unknown(code) => code,
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", u8::from(*self), self.description())
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Status {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_roundtrips() {
        for code in 0..=255u8 {
            assert_eq!(u8::from(Status::from(code)), code);
        }
    }

    #[test]
    fn table_4() {
        assert_eq!(Status::from(100), Status::Ok);
        assert_eq!(Status::from(1), Status::WrongChecksum);
        assert_eq!(Status::from(6), Status::NotAvailable);
        assert!(Status::Ok.is_success() && !Status::InvalidValue.is_success());
    }

    #[test]
    fn tmcm_1310_code_8() {
        assert_eq!(Status::from(8), Status::PasswordProtected);
        assert_eq!(u8::from(Status::PasswordProtected), 8);
        assert!(!Status::PasswordProtected.is_success());
        assert_eq!(Status::PasswordProtected.description(), "parameter is password protected");
        assert_eq!(std::format!("{}", Status::PasswordProtected), "8 (parameter is password protected)");
        assert_eq!(Status::from(7), Status::Unknown(7));
    }
}

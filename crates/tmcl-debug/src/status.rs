//! The program's state as command 135 reports it.

/// The application status of command 135 type 1 (PD28-1021 TMCL manual §3.7.38): the mode (0 stop,
/// 1 run, 2 step, 3 reset; GP 128), the wait flag and the program counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct AppStatus {
    /// 0 stop, 1 run, 2 step, 3 reset.
    pub mode: u8,
    /// A WAIT is pending.
    pub waiting: bool,
    /// The program counter.
    pub pc: u16,
}

impl AppStatus {
    /// Unpacks the 135 type 1 value: mode in byte 3, wait flag in byte 2, PC in bytes 1..0.
    pub fn from_packed(value: i32) -> AppStatus {
        AppStatus { mode: (value >> 24) as u8, waiting: (value >> 16) & 0xFF != 0, pc: value as u16 }
    }

    /// The mode in words: `stopped`, `running`, `stepped`, `reset` (`unknown` for any other).
    pub fn mode_name(&self) -> &'static str {
        tmcl_host::ApplicationStatus::name_of(self.mode)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_status() {
        let s = AppStatus::from_packed(0x0201_0007);
        assert_eq!(s, AppStatus { mode: 2, waiting: true, pc: 7 });
        assert_eq!(s.mode_name(), "stepped");
        assert_eq!(AppStatus::from_packed(0x0100_0000).mode_name(), "running");
    }
}

//! Process data (TMCM-1310 manual §3.4): what the master writes every cycle and what it reads back.
//!
//! **Outputs** (master → slave, 8 bytes, little-endian): controller mode (UNSIGNED32) and value
//! (SIGNED32). The manual heads the mode table "Bit" but lists 0 "no operation" among 1, 2, 3: the mode is
//! a **value**, 0..3, not a bit mask.
//!
//! | mode | the value is | what the firmware does, when it changes |
//! |---|---|---|
//! | 0 no operation | ignored | nothing: the process data leave the motor to TMCL |
//! | 1 position | target position, microsteps | `MVP ABS, 0, value` |
//! | 2 velocity | velocity, pps (signed) | `ROR 0, value` (negative turns left) |
//! | 3 torque | torque-mode current, mA (signed) | `SAP 14, 0, value` (the closed loop must be on) |
//! | other | ignored | nothing |
//!
//! **Inputs** (slave → master, little-endian): the manual's table in its order, all **twelve** fields,
//! **48 bytes**. The text says "first 44 bytes", which would drop the last field (gamma); the table lists
//! twelve 4-byte fields and nothing says which one to leave out, so all are mapped (see
//! `docs/decisions.md`, "EtherCAT"). The word the manual prints as "Error flags" with the bit table
//! "0 target reached … 11 overtemperature" is read as: the status word (AP 18) carries the bit table,
//! and the error flags field carries the module's error flags: AP 207 (stall, deviation) in bits 0..8
//! and AP 208 (the driver's flags) in bits 8..16, read without clearing them.

use tmcl_core::hal::Board;
use tmcl_core::{Instant, Module};
use tmcl_wire::{Command, MoveTarget, Status};

/// Length of the outputs.
pub const OUTPUTS_LEN: usize = 8;
/// Length of the inputs.
pub const INPUTS_LEN: usize = 4 * INPUT_FIELDS.len();

/// CoE data type INTEGER32 (ETG.1000.6, "Basic data types").
pub const INTEGER32: u8 = 0x04;
/// CoE data type UNSIGNED32.
pub const UNSIGNED32: u8 = 0x07;

/// Object index of the inputs' entries (subindex = position in the table, from 1), in the range
/// ETG.5001 gives input data.
pub const INPUT_OBJECT: u16 = 0x6000;
/// Object index of the outputs' entries, in the range ETG.5001 gives output data.
pub const OUTPUT_OBJECT: u16 = 0x7000;
/// The TxPDO (inputs).
pub const TX_PDO: u16 = 0x1A00;
/// The RxPDO (outputs).
pub const RX_PDO: u16 = 0x1600;

/// Where an input field comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// An axis parameter of motor 0, as GAP reads it.
    Axis(u8),
    /// AP 207 | AP 208 << 8, read without clearing.
    ErrorFlags,
}

/// One field of the process data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    /// Its name in the manual's table.
    pub name: &'static str,
    /// CoE data type.
    pub data_type: u8,
    /// Where an input comes from (outputs: unused).
    pub source: Source,
}

const fn input(name: &'static str, data_type: u8, source: Source) -> Field {
    Field { name, data_type, source }
}

/// The inputs, in the manual's order (§3.4, "Data input buffer"), with the GAP it names.
pub static INPUT_FIELDS: [Field; 12] = [
    input("Target position", INTEGER32, Source::Axis(0)),
    input("Actual position", INTEGER32, Source::Axis(1)),
    input("Virtual actual position", INTEGER32, Source::Axis(233)),
    input("Encoder position", INTEGER32, Source::Axis(209)),
    input("Target velocity", INTEGER32, Source::Axis(2)),
    input("Actual velocity", INTEGER32, Source::Axis(3)),
    input("Measured velocity", INTEGER32, Source::Axis(131)),
    // Printed "GAP 18)".
    input("Status word", UNSIGNED32, Source::Axis(18)),
    input("Error flags", UNSIGNED32, Source::ErrorFlags),
    input("Scaler", INTEGER32, Source::Axis(123)),
    input("Delta / torque", INTEGER32, Source::Axis(14)),
    // Printed "Command for read out: 230".
    input("Gamma", INTEGER32, Source::Axis(230)),
];

/// The outputs (§3.4, "Data output buffer").
pub static OUTPUT_FIELDS: [Field; 2] =
    [input("Controller mode", UNSIGNED32, Source::Axis(0)), input("Value", INTEGER32, Source::Axis(0))];

/// The controller mode of the outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerMode {
    /// 0: the process data do not command the motor.
    None,
    /// 1: the value is a target position.
    Position,
    /// 2: the value is a velocity.
    Velocity,
    /// 3: the value is a torque-mode current.
    Torque,
    /// Any other value: treated as no operation, kept as sent.
    Unknown(u32),
}

impl From<u32> for ControllerMode {
    fn from(v: u32) -> ControllerMode {
        match v {
            0 => ControllerMode::None,
            1 => ControllerMode::Position,
            2 => ControllerMode::Velocity,
            3 => ControllerMode::Torque,
            other => ControllerMode::Unknown(other),
        }
    }
}

impl From<ControllerMode> for u32 {
    fn from(m: ControllerMode) -> u32 {
        match m {
            ControllerMode::None => 0,
            ControllerMode::Position => 1,
            ControllerMode::Velocity => 2,
            ControllerMode::Torque => 3,
            ControllerMode::Unknown(v) => v,
        }
    }
}

/// The outputs as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outputs {
    /// Controller mode.
    pub mode: ControllerMode,
    /// Value.
    pub value: i32,
}

impl Outputs {
    /// Reads the 8 output bytes.
    pub fn parse(bytes: &[u8; OUTPUTS_LEN]) -> Outputs {
        Outputs {
            mode: u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]).into(),
            value: i32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]),
        }
    }

    /// The 8 output bytes.
    pub fn to_bytes(self) -> [u8; OUTPUTS_LEN] {
        let mut b = [0; OUTPUTS_LEN];
        b[..4].copy_from_slice(&u32::from(self.mode).to_le_bytes());
        b[4..].copy_from_slice(&self.value.to_le_bytes());
        b
    }

    /// Whether these outputs command the motor.
    pub fn commands_motor(self) -> bool {
        matches!(self.mode, ControllerMode::Position | ControllerMode::Velocity | ControllerMode::Torque)
    }

    /// The TMCL command these outputs stand for (none for "no operation").
    pub fn command(self) -> Option<Command> {
        match self.mode {
            ControllerMode::Position => Some(Command::Mvp { motor: 0, target: MoveTarget::Abs(self.value) }),
            ControllerMode::Velocity => Some(Command::Ror { motor: 0, velocity: self.value }),
            ControllerMode::Torque => Some(Command::Sap { param: 14, motor: 0, value: self.value }),
            ControllerMode::None | ControllerMode::Unknown(_) => None,
        }
    }

    /// Executes the command these outputs stand for; the status of a refusal (a torque without closed
    /// loop, say) shows in the status word, there is nowhere else to report it.
    pub fn apply<B: Board>(self, module: &mut Module<B>, now: Instant) -> Result<(), Status> {
        match self.command() {
            Some(c) => module.execute(c, now).map(|_| ()),
            None => Ok(()),
        }
    }
}

/// Reads the inputs from the module into `out` (little-endian, the manual's order). A parameter the
/// model lacks reads 0.
pub fn read_inputs<B: Board>(module: &mut Module<B>, out: &mut [u8; INPUTS_LEN]) {
    for (field, slot) in INPUT_FIELDS.iter().zip(out.chunks_exact_mut(4)) {
        let v = match field.source {
            Source::Axis(n) => module.get_axis(n).unwrap_or(0) as u32,
            Source::ErrorFlags => {
                u32::from(module.error_flags()) | u32::from(module.board_timeline().driver_flags()) << 8
            }
        };
        slot.copy_from_slice(&v.to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_round_trip() {
        let o = Outputs { mode: ControllerMode::Velocity, value: -51200 };
        let b = o.to_bytes();
        assert_eq!(b, [2, 0, 0, 0, 0x00, 0x38, 0xff, 0xff]);
        assert_eq!(Outputs::parse(&b), o);
        assert_eq!(Outputs::parse(&[7, 0, 0, 0, 0, 0, 0, 0]).mode, ControllerMode::Unknown(7));
    }

    #[test]
    fn forty_eight_bytes() {
        assert_eq!(INPUTS_LEN, 48);
    }
}

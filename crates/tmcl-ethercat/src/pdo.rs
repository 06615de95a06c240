//! Process data (TMCM-1310 manual §3.4): what the master writes every cycle and what it reads back, as
//! the model's [`EtherCatDesc`] describes them by meaning (the map itself, with the decisions the
//! manual's contradictions forced, is `tmcl_model::tmcm_1310::ETHERCAT`).
//!
//! **Outputs** (master → slave, 8 bytes, little-endian): controller mode (UNSIGNED32) and value
//! (SIGNED32). In OP, a change of either carries out the mode's [`OutputAction`]: a target position
//! (`MVP ABS, 0, value`), a velocity (`ROR 0, value`) or a parameter write (`SAP n, 0, value`, n the
//! model's parameter with the role); a mode without action, or one the map does not know, commands
//! nothing.
//!
//! **Inputs** (slave → master, little-endian): each entry of the map in its order, read from the
//! module's parameter with the entry's role (as GAP reads it), or the error and driver flags read without
//! clearing them.

use tmcl_core::hal::Board;
use tmcl_core::model::ethercat::{InputSource, OutputAction, MAX_INPUTS};
use tmcl_core::model::{EtherCatDesc, ModelSpec, Role};
use tmcl_core::{Instant, Module};
use tmcl_wire::{Command, MoveTarget, Status};

/// Length of the outputs.
pub const OUTPUTS_LEN: usize = EtherCatDesc::OUTPUTS_LEN;
/// The longest inputs a map may have.
pub const MAX_INPUTS_LEN: usize = 4 * MAX_INPUTS;

/// Object index of the inputs' entries (subindex = position in the map, from 1), in the range
/// ETG.5001 gives input data.
pub const INPUT_OBJECT: u16 = 0x6000;
/// Object index of the outputs' entries, in the range ETG.5001 gives output data.
pub const OUTPUT_OBJECT: u16 = 0x7000;
/// The TxPDO (inputs).
pub const TX_PDO: u16 = 0x1A00;
/// The RxPDO (outputs).
pub const RX_PDO: u16 = 0x1600;

/// The outputs as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outputs {
    /// Controller mode, as sent (the map says what it means).
    pub mode: u32,
    /// Value.
    pub value: i32,
}

impl Outputs {
    /// Reads the 8 output bytes.
    pub fn parse(bytes: &[u8; OUTPUTS_LEN]) -> Outputs {
        Outputs {
            mode: u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
            value: i32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]),
        }
    }

    /// The 8 output bytes.
    pub fn to_bytes(self) -> [u8; OUTPUTS_LEN] {
        let mut b = [0; OUTPUTS_LEN];
        b[..4].copy_from_slice(&self.mode.to_le_bytes());
        b[4..].copy_from_slice(&self.value.to_le_bytes());
        b
    }

    /// What these outputs do under `map`: their mode's action, if it has one.
    pub fn action(self, map: &EtherCatDesc) -> Option<OutputAction> {
        map.mode(self.mode).and_then(|m| m.action)
    }

    /// The TMCL command these outputs stand for on a module of model `spec` (none for a mode without
    /// action).
    pub fn command(self, spec: &ModelSpec, map: &EtherCatDesc) -> Option<Command> {
        Some(match self.action(map)? {
            OutputAction::MoveTo => Command::Mvp { motor: 0, target: MoveTarget::Abs(self.value) },
            OutputAction::Rotate => Command::Ror { motor: 0, velocity: self.value },
            OutputAction::Param(role) => Command::Sap { param: param_number(spec, role)?, motor: 0, value: self.value },
        })
    }

    /// Executes the command these outputs stand for; the status of a refusal (a torque without closed
    /// loop, say) shows in the status word, there is nowhere else to report it.
    pub fn apply<B: Board>(self, module: &mut Module<B>, map: &EtherCatDesc, now: Instant) -> Result<(), Status> {
        match self.command(module.spec(), map) {
            Some(c) => module.execute(c, now).map(|_| ()),
            None => Ok(()),
        }
    }
}

/// The number of the model's axis parameter with `role`.
fn param_number(spec: &ModelSpec, role: Role) -> Option<u8> {
    spec.axis.role(role).map(|i| spec.axis.params[i].number)
}

/// Reads the inputs of `map` from the module into `out` (little-endian, the map's order); returns the
/// bytes written. A parameter the model lacks (the model check rules it out) reads 0.
pub fn read_inputs<B: Board>(module: &mut Module<B>, map: &EtherCatDesc, out: &mut [u8]) -> usize {
    let spec = module.spec();
    let mut n = 0;
    for (entry, slot) in map.inputs.iter().zip(out.chunks_exact_mut(4)) {
        let v = match entry.source {
            InputSource::Param(role) => {
                param_number(spec, role).and_then(|p| module.get_axis(p).ok()).unwrap_or(0) as u32
            }
            InputSource::ErrorAndDriverFlags => {
                u32::from(module.error_flags()) | u32::from(module.board_timeline().driver_flags(0)) << 8
            }
        };
        slot.copy_from_slice(&v.to_le_bytes());
        n += 4;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_core::model::tmcm_1310::{ETHERCAT, SPEC};

    #[test]
    fn outputs_round_trip() {
        let o = Outputs { mode: 2, value: -51200 };
        let b = o.to_bytes();
        assert_eq!(b, [2, 0, 0, 0, 0x00, 0x38, 0xff, 0xff]);
        assert_eq!(Outputs::parse(&b), o);
    }

    #[test]
    fn modes_by_meaning() {
        let cmd = |mode, value| Outputs { mode, value }.command(&SPEC, &ETHERCAT);
        assert_eq!(cmd(0, 5), None);
        assert_eq!(cmd(1, -3000), Some(Command::Mvp { motor: 0, target: MoveTarget::Abs(-3000) }));
        assert_eq!(cmd(2, 51200), Some(Command::Ror { motor: 0, velocity: 51200 }));
        // Torque: the parameter with the target-current role, AP 14 on the TMCM-1310.
        assert_eq!(cmd(3, 500), Some(Command::Sap { param: 14, motor: 0, value: 500 }));
        assert_eq!(cmd(7, 1), None, "a mode the map does not know commands nothing");
    }

    #[test]
    fn forty_eight_bytes() {
        assert_eq!(ETHERCAT.inputs_len(), 48);
        assert!(ETHERCAT.inputs_len() <= MAX_INPUTS_LEN);
    }
}

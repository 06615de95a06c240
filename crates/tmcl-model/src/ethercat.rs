//! What a model shows an EtherCAT master, by meaning: its identity and its process-data map.
//!
//! One [`EtherCatDesc`] per model with an EtherCAT interface is the single description the slave's SII
//! EEPROM, its cyclic process data and its ESI file (EtherCAT Slave Information) are all generated from
//! (`tmcl-ethercat`): an input entry names the parameter it carries by [`Role`], never by number, and an
//! output mode says what it does ([`OutputAction`]), so the same map fits a model whose parameters are
//! numbered otherwise. [`crate::ModelSpec::new`] checks that every role an entry names is in the model's
//! axis table and that the map fits the slave's buffers ([`MAX_INPUTS`]).

use crate::param::Role;

/// The most input entries a map may have (each is 32 bits: the slave's input buffer holds 64 bytes).
pub const MAX_INPUTS: usize = 16;

/// The data type of an entry (ETG.1000.6, "Basic data types"; ETG.2000 for the ESI names).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataType {
    /// INTEGER32 (ESI `DINT`).
    Integer32,
    /// UNSIGNED32 (ESI `UDINT`).
    Unsigned32,
}

impl DataType {
    /// The CoE data type code in the SII PDO entries (0x0004 INTEGER32, 0x0007 UNSIGNED32).
    pub const fn code(self) -> u8 {
        match self {
            DataType::Integer32 => 0x04,
            DataType::Unsigned32 => 0x07,
        }
    }

    /// The length in bits.
    pub const fn bits(self) -> u8 {
        32
    }

    /// The name an ESI file gives the type (ETG.2000, `DataType` of a PDO entry).
    pub const fn esi_name(self) -> &'static str {
        match self {
            DataType::Integer32 => "DINT",
            DataType::Unsigned32 => "UDINT",
        }
    }
}

/// Where an input entry's value comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputSource {
    /// The axis parameter of motor 0 with this role, as GAP reads it.
    Param(Role),
    /// The module's error flags ([`Role::ErrorFlags`]) in bits 0..8 and the driver's flags
    /// ([`Role::DriverFlags`]) in bits 8..16, read without clearing them.
    ErrorAndDriverFlags,
}

/// One entry of the inputs (slave → master).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputEntry {
    /// Its name (the manual's table): SII string, ESI name.
    pub name: &'static str,
    /// Its type.
    pub data_type: DataType,
    /// Where the value comes from.
    pub source: InputSource,
}

/// What the outputs' value does in a controller mode, when mode or value change in OP.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputAction {
    /// The value is a target position: `MVP ABS, 0, value`.
    MoveTo,
    /// The value is a signed velocity: `ROR 0, value` (negative turns left).
    Rotate,
    /// The value is written to the axis parameter with this role: `SAP n, 0, value`.
    Param(Role),
}

/// One controller mode of the outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputMode {
    /// The value of the mode field.
    pub code: u32,
    /// Its name (the manual's table).
    pub name: &'static str,
    /// What the value does; `None`: nothing ("no operation").
    pub action: Option<OutputAction>,
}

/// A model's EtherCAT identity and process data.
///
/// The outputs are always two 32-bit entries, the controller mode (UNSIGNED32) and its value
/// (INTEGER32), the layout Trinamic's TMCL-over-EtherCAT modules share; a mode not in [`Self::modes`]
/// does nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EtherCatDesc {
    /// Vendor ID in the ETG's vendor list.
    pub vendor_id: u32,
    /// The vendor's name, for the ESI file.
    pub vendor_name: &'static str,
    /// Product code.
    pub product_code: u32,
    /// Revision number.
    pub revision: u32,
    /// The device group (ESI `Group`, SII group string).
    pub group: &'static str,
    /// Name of the outputs' first entry.
    pub mode_name: &'static str,
    /// Name of the outputs' second entry.
    pub value_name: &'static str,
    /// The controller modes.
    pub modes: &'static [OutputMode],
    /// The inputs, in order.
    pub inputs: &'static [InputEntry],
}

impl EtherCatDesc {
    /// The mode with `code`, if the map defines it.
    pub fn mode(&self, code: u32) -> Option<&'static OutputMode> {
        self.modes.iter().find(|m| m.code == code)
    }

    /// Length of the inputs in bytes.
    pub const fn inputs_len(&self) -> usize {
        let mut n = 0;
        let mut i = 0;
        while i < self.inputs.len() {
            n += self.inputs[i].data_type.bits() as usize / 8;
            i += 1;
        }
        n
    }

    /// Length of the outputs in bytes (mode and value).
    pub const OUTPUTS_LEN: usize = 8;
}

/// Why a process-data map does not fit the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapError {
    /// More than [`MAX_INPUTS`] inputs, or none.
    Inputs,
    /// An entry or a mode names a role the model's axis table does not have.
    Role,
}

/// Checks a map against a model's axis table (at compile time, from [`crate::ModelSpec::new`]).
pub const fn check(map: &EtherCatDesc, axis: &crate::Table) -> Result<(), MapError> {
    if map.inputs.is_empty() || map.inputs.len() > MAX_INPUTS {
        return Err(MapError::Inputs);
    }
    let mut i = 0;
    while i < map.inputs.len() {
        let known = match map.inputs[i].source {
            InputSource::Param(role) => axis.role(role).is_some(),
            InputSource::ErrorAndDriverFlags => {
                axis.role(Role::ErrorFlags).is_some() && axis.role(Role::DriverFlags).is_some()
            }
        };
        if !known {
            return Err(MapError::Role);
        }
        i += 1;
    }
    let mut i = 0;
    while i < map.modes.len() {
        if let Some(OutputAction::Param(role)) = map.modes[i].action {
            if axis.role(role).is_none() {
                return Err(MapError::Role);
            }
        }
        i += 1;
    }
    Ok(())
}

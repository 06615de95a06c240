//! Parameter descriptors (the tables of `tmcl-model`, re-exported), the global banks in RAM ([`banks`])
//! and the EEPROM image ([`persist`]).

pub mod banks;
pub mod persist;

pub use tmcl_model::param::*;

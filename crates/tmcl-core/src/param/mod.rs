//! Parameter descriptors (the tables of `tmcl-model`, re-exported) and the EEPROM image ([`persist`]).

pub mod persist;

pub use tmcl_model::param::*;

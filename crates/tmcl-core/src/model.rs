//! Product models as data: the tables of `tmcl-model`, re-exported so that the firmware's users find
//! them beside it. Product differences are data in those tables, not branches in the firmware.

pub use tmcl_model::*;

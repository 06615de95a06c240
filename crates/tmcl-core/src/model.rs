//! Product models as data: the tables of `tmcl-model`, re-exported so that the firmware's users find
//! them beside it (STYLE.md §3.9).

pub use tmcl_model::*;

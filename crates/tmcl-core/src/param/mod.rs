//! Parameter descriptors (the tables of `tmcl-model`, re-exported), the global banks in RAM ([`banks`])
//! and the EEPROM image ([`persist`]).

pub mod banks;
pub mod persist;

pub use tmcl_model::param::*;
use tmcl_wire::Status;

/// Refuses a write or store of a password-protected parameter while the module is locked (`unlocked`
/// false): status 8 (TMCM-1310 manual §3.7).
#[inline]
pub(crate) fn unlocked_for(unlocked: bool, d: &ParamDesc) -> Result<(), Status> {
    if d.access.protected && !unlocked {
        Err(ParamError::Protected.into())
    } else {
        Ok(())
    }
}

/// A parameter of `table` that allows what `allowed` asks (read, write, store, ...): unknown → 3, not
/// permitted → 3 (see [`ParamError`]).
pub(crate) fn permitted(
    table: &Table,
    number: u8,
    allowed: impl Fn(&ParamDesc) -> bool,
) -> Result<(usize, &'static ParamDesc), Status> {
    let (i, d) = table.find(number)?;
    if allowed(d) {
        Ok((i, d))
    } else {
        Err(ParamError::NotPermitted.into())
    }
}

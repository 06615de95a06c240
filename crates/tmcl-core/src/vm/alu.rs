//! The arithmetic of the TMCL machine (PD28-1021 manual §3.7.16 CALC, §3.7.17 COMP, §3.7.18 JC,
//! §3.7.28 CALCX, §3.7.31 CLE): pure functions of the registers, used by the program machine for its
//! own registers and by the dispatcher for the host's (direct-mode CALC and CALCX, §3.6.5).
//!
//! The operations take the type byte as stored, so that a decoded program cell (`vm/decode.rs`) runs
//! without a second look-up; a type byte that names no operation is status 3 (wrong type), which a
//! decoded cell never has.

use super::{flags, Registers};
use tmcl_wire::{ErrorFlag, Status};

/// CALC (§3.7.16): A ← A op operand. Division by 0 is status 4 (−1 divides without overflow).
#[inline(always)]
pub fn calc(regs: &mut Registers, op: u8, operand: i32) -> Result<(), Status> {
    let a = regs.accumulator;
    let r = match op {
        0 => a.wrapping_add(operand),
        1 => a.wrapping_sub(operand),
        2 => a.wrapping_mul(operand),
        3 => divide(a, operand)?,
        4 => remainder(a, operand)?,
        5 => a & operand,
        6 => a | operand,
        7 => a ^ operand,
        8 => !a,
        9 => operand,
        _ => return Err(Status::WrongType),
    };
    regs.load(r);
    Ok(())
}

/// CALCX (§3.7.28): A ← A op X; LOAD copies A to X, SWAP exchanges them, NOT inverts X (Table of
/// §3.7.28: "logical invert X register", although every other operation writes A).
#[inline(always)]
pub fn calcx(regs: &mut Registers, op: u8) -> Result<(), Status> {
    let Registers { accumulator: a, x, .. } = *regs;
    let r = match op {
        0 => a.wrapping_add(x),
        1 => a.wrapping_sub(x),
        2 => a.wrapping_mul(x),
        3 => divide(a, x)?,
        4 => remainder(a, x)?,
        5 => a & x,
        6 => a | x,
        7 => a ^ x,
        8 => {
            regs.x = !x;
            return Ok(());
        }
        9 => {
            regs.x = a;
            return Ok(());
        }
        10 => {
            regs.x = a;
            x
        }
        _ => return Err(Status::WrongType),
    };
    regs.load(r);
    Ok(())
}

/// COMP (§3.7.17): the flags from A − operand.
#[inline(always)]
pub fn comp(regs: &mut Registers, operand: i32) {
    regs.set_compare(regs.accumulator.cmp(&operand));
}

/// JC's condition (§3.7.18) by its type byte: ZE ≡ EQ, NZ ≡ NE. A type byte that names no condition
/// is never met (a decoded cell never has one).
#[inline(always)]
pub fn condition(flags: u16, condition: u8) -> bool {
    use flags::*;
    match condition {
        0 | 2 => flags & ZERO != 0,
        1 | 3 => flags & ZERO == 0,
        4 => flags & GREATER != 0,
        5 => flags & (GREATER | ZERO) != 0,
        6 => flags & LOWER != 0,
        7 => flags & (LOWER | ZERO) != 0,
        8 => flags & TIMEOUT != 0,
        9 => flags & ALARM != 0,
        10 => flags & DEVIATION != 0,
        11 => flags & POSITION != 0,
        _ => false,
    }
}

/// The error flags CLE clears (§3.7.31).
pub fn error_mask(flag: ErrorFlag) -> u16 {
    use flags::*;
    match flag {
        ErrorFlag::All => TIMEOUT | ALARM | DEVIATION | POSITION | SHUTDOWN,
        ErrorFlag::Timeout => TIMEOUT,
        ErrorFlag::ExternalAlarm => ALARM,
        ErrorFlag::Deviation => DEVIATION,
        ErrorFlag::PositionError => POSITION,
        ErrorFlag::Shutdown => SHUTDOWN,
    }
}

/// A ÷ b, as CALC and CALCX divide: b = −1 negates without overflow, b = 0 is status 4.
fn divide(a: i32, b: i32) -> Result<i32, Status> {
    a.checked_div(b).or((b == -1).then(|| a.wrapping_neg())).ok_or(Status::InvalidValue)
}

/// A mod b, as CALC and CALCX take it: b = −1 gives 0, b = 0 is status 4.
fn remainder(a: i32, b: i32) -> Result<i32, Status> {
    a.checked_rem(b).or((b == -1).then_some(0)).ok_or(Status::InvalidValue)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_wire::{CalcOp, CalcxOp, Condition};

    #[test]
    fn the_type_bytes_are_the_wire_codes() {
        // Every operation and condition the wire knows has an arm here, and nothing else does.
        for code in 0..=255u8 {
            let mut r = Registers { accumulator: 7, x: 3, flags: 0 };
            assert_eq!(calc(&mut r, code, 2).is_ok(), CalcOp::from_code(code).is_some(), "CALC {code}");
            let mut r = Registers { accumulator: 7, x: 3, flags: 0 };
            assert_eq!(calcx(&mut r, code).is_ok(), CalcxOp::from_code(code).is_some(), "CALCX {code}");
            if Condition::from_code(code).is_none() {
                assert!(!condition(u16::MAX, code));
            }
        }
        let mut r = Registers { accumulator: 7, x: 3, flags: 0 };
        assert_eq!(calc(&mut r, CalcOp::Div.code(), 0), Err(Status::InvalidValue));
        calc(&mut r, CalcOp::Div.code(), -1).unwrap();
        assert_eq!((r.accumulator, r.flags), (-7, flags::LOWER));
        calcx(&mut r, CalcxOp::Swap.code()).unwrap();
        assert_eq!((r.accumulator, r.x, r.flags), (3, -7, flags::GREATER));
        comp(&mut r, 3);
        assert!(condition(r.flags, Condition::Equal.code()) && condition(r.flags, Condition::GreaterOrEqual.code()));
        assert!(!condition(r.flags, Condition::Lower.code()));
    }
}

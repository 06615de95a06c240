//! Parameter rules of chapters 4 and 5: ranges, access, storage, restore at start-up.

use super::*;
use crate::param::{Access, Range, Role};

/// A value just outside a range, if there is one.
fn outside(range: &Range) -> Option<i32> {
    match *range {
        Range::Signed(min, max) => {
            if max < i32::MAX {
                Some(max + 1)
            } else if min > i32::MIN {
                Some(min - 1)
            } else {
                None
            }
        }
        Range::Unsigned32 => None,
        Range::OneOf(_) => Some(0),
    }
}

#[test]
fn every_axis_parameter_rule() {
    for d in SPEC.axis.params {
        let mut b = Bench::new();
        let before = b.gap(d.number);
        if !d.access.write {
            // A read-only parameter: status 3, nothing changes.
            assert_eq!(b.sap(d.number, before), Status::WrongType, "SAP {} ({})", d.number, d.name);
            assert_eq!(b.gap(d.number), before);
            continue;
        }
        if let Some(bad) = outside(&d.range) {
            assert_eq!(b.sap(d.number, bad), Status::InvalidValue, "SAP {} {bad}", d.number);
            assert_eq!(b.gap(d.number), before, "AP {} unchanged", d.number);
        }
        if d.role == Role::Plain {
            let good = match d.range {
                Range::Signed(min, max) => {
                    if max > min {
                        max
                    } else {
                        min
                    }
                }
                _ => d.default,
            };
            assert_eq!(b.sap(d.number, good), Status::Ok, "SAP {} {good}", d.number);
            assert_eq!(b.gap(d.number), good, "AP {}", d.number);
        }
        // STAP/RSAP only on E parameters.
        let expect = if d.access.store { Status::Ok } else { Status::WrongType };
        assert_eq!(b.cmd(Command::Stap { param: d.number, motor: 0 }).0, expect, "STAP {}", d.number);
        assert_eq!(b.cmd(Command::Rsap { param: d.number, motor: 0 }).0, expect, "RSAP {}", d.number);
    }
}

#[test]
fn unknown_parameters_motors_and_banks() {
    let mut b = Bench::new();
    for n in [14u8, 129, 131, 159, 185, 201, 205, 211, 213, 255] {
        assert_eq!(b.cmd(Command::Gap { param: n, motor: 0 }).0, Status::WrongType, "GAP {n}");
        assert_eq!(b.sap(n, 0), Status::WrongType, "SAP {n}");
    }
    assert_eq!(b.cmd(Command::Gap { param: 1, motor: 1 }).0, Status::InvalidValue);
    assert_eq!(b.cmd(Command::Sap { param: 4, motor: 2, value: 5 }).0, Status::InvalidValue);
    assert_eq!(b.cmd(Command::Ggp { param: 0, bank: 1 }).0, Status::InvalidValue, "bank 1 is not available");
    assert_eq!(b.cmd(Command::Ggp { param: 64, bank: 0 }).0, Status::WrongType);
    assert_eq!(b.cmd(Command::Ggp { param: 3, bank: 3 }).0, Status::WrongType);
    assert_eq!(b.cmd(Command::Ggp { param: 0, bank: 4 }).0, Status::InvalidValue);
}

#[test]
fn every_global_parameter_rule() {
    for d in SPEC.global.params.iter().chain(SPEC.interrupt.params) {
        let bank = if SPEC.global.params.contains(d) { 0 } else { 3 };
        let mut b = Bench::new();
        let before = b.ggp(d.number, bank);
        if !d.access.write {
            assert_eq!(b.sgp(d.number, bank, 1), Status::WrongType, "SGP {}", d.number);
            continue;
        }
        if let Some(bad) = outside(&d.range) {
            assert_eq!(b.sgp(d.number, bank, bad), Status::InvalidValue, "SGP {} {bad}", d.number);
            if !matches!(d.role, Role::RandomNumber | Role::TickTimer) {
                assert_eq!(b.ggp(d.number, bank), before, "GP {} unchanged", d.number);
            }
        }
        let expect = if d.access.auto { Status::Ok } else { Status::WrongType };
        assert_eq!(b.cmd(Command::Stgp { param: d.number, bank }).0, expect, "STGP {}, {bank}", d.number);
        assert_eq!(b.cmd(Command::Rsgp { param: d.number, bank }).0, expect, "RSGP {}, {bank}", d.number);
    }
}

#[test]
fn bank_0_a_parameters_are_stored_automatically() {
    let mut b = Bench::new();
    for (n, v) in [(65, 7), (67, 16), (68, 500), (75, 3), (77, 1), (79, 1), (81, 2), (84, 1), (85, 1), (87, 9), (90, 1)]
    {
        assert_eq!(b.sgp(n, 0, v), Status::Ok, "SGP {n}");
    }
    b.power_cycle();
    for (n, v) in [(65, 7), (67, 16), (68, 500), (75, 3), (77, 1), (79, 1), (81, 2), (84, 1), (85, 1), (87, 9), (90, 1)]
    {
        assert_eq!(b.ggp(n, 0), v, "GP {n} after restart");
    }
    // GP 65: the new rate takes effect only after a restart (§5.1).
    assert_eq!(b.module.active_baud(), 7);
}

#[test]
fn a_failed_eeprom_write_changes_nothing() {
    let mut b = Bench::new();
    b.module.board_mut().nvm.fail_writes = true;
    assert_eq!(b.sgp(77, 0, 1), Status::EepromLocked);
    assert_eq!(b.ggp(77, 0), 0);
    assert_eq!(b.cmd(Command::Stap { param: 4, motor: 0 }).0, Status::EepromLocked);
}

#[test]
fn stap_rsap_and_restore_at_start() {
    let mut b = Bench::new();
    assert_eq!(b.sap(4, 1000), Status::Ok);
    assert_eq!(b.sap(5, 2000), Status::Ok);
    // §3.7.7 example: STAP 6, 0 (the manual's own example stores AP 6).
    b.sap(6, 100);
    let out = b.bytes(&[0x01, 0x07, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0E]);
    assert_eq!(out[2], 100);
    assert_eq!(b.cmd(Command::Stap { param: 4, motor: 0 }).0, Status::Ok);
    b.sap(4, 3000);
    // RSAP brings the stored value back.
    assert_eq!(b.cmd(Command::Rsap { param: 4, motor: 0 }).0, Status::Ok);
    assert_eq!(b.gap(4), 1000);
    b.power_cycle();
    assert_eq!(b.gap(4), 1000, "stored");
    assert_eq!(b.gap(5), 51200, "not stored: default");
    assert_eq!(b.gap(6), 100);
}

#[test]
fn user_variables() {
    let mut b = Bench::new();
    for n in [0u8, 42, 55, 56, 255] {
        assert_eq!(b.sgp(n, 2, -(i32::from(n)) - 1), Status::Ok);
    }
    // §3.7.11 example STGP 42, 2.
    assert_eq!(b.bytes(&[0x01, 0x0B, 0x2A, 0x02, 0x00, 0x00, 0x00, 0x00, 0x38])[2], 100);
    assert_eq!(b.cmd(Command::Stgp { param: 55, bank: 2 }).0, Status::Ok);
    // §5.3's text: only the first 56 can be stored (Table 18 marks 56..255 storable too; we follow the text).
    assert_eq!(b.cmd(Command::Stgp { param: 56, bank: 2 }).0, Status::WrongType);
    b.sgp(42, 2, 5);
    // §3.7.12 example RSGP 42, 2.
    assert_eq!(b.bytes(&[0x01, 0x0C, 0x2A, 0x02, 0x00, 0x00, 0x00, 0x00, 0x39])[2], 100);
    assert_eq!(b.ggp(42, 2), -43);
    b.power_cycle();
    assert_eq!((b.ggp(42, 2), b.ggp(55, 2), b.ggp(0, 2), b.ggp(56, 2)), (-43, -56, 0, 0));
    // GP 85 = 1: not restored at start-up.
    b.sgp(85, 0, 1);
    b.power_cycle();
    assert_eq!(b.ggp(42, 2), 0);
    assert_eq!(b.cmd(Command::Rsgp { param: 42, bank: 2 }).0, Status::Ok);
    assert_eq!(b.ggp(42, 2), -43);
}

#[test]
fn tick_timer_and_random() {
    let mut b = Bench::new();
    let t0 = b.ggp(132, 0);
    b.run(Duration::from_millis(250));
    assert_eq!(b.ggp(132, 0) - t0, 250, "GP 132 counts milliseconds");
    assert_eq!(b.sgp(132, 0, 1_000_000), Status::Ok);
    b.run(Duration::from_millis(5));
    assert_eq!(b.ggp(132, 0), 1_000_005);
    assert_eq!(b.sgp(132, 0, -1), Status::InvalidValue);
    let (r1, r2) = (b.ggp(133, 0), b.ggp(133, 0));
    assert_ne!(r1, r2);
    assert!(r1 >= 0 && r2 >= 0);
    assert_eq!(b.sgp(133, 0, 42), Status::Ok);
    let seq: Vec<i32> = (0..3).map(|_| b.ggp(133, 0)).collect();
    b.sgp(133, 0, 42);
    let again: Vec<i32> = (0..3).map(|_| b.ggp(133, 0)).collect();
    assert_eq!(seq, again, "seedable");
}

#[test]
fn read_only_globals() {
    let mut b = Bench::new();
    assert_eq!((b.ggp(128, 0), b.ggp(129, 0), b.ggp(130, 0)), (0, 0, 0));
    assert_eq!(b.sgp(128, 0, 1), Status::WrongType);
}

#[test]
fn access_letters_are_consistent() {
    for d in SPEC.axis.params.iter().chain(SPEC.global.params) {
        assert!(!(d.access.store && d.access.auto));
        if d.access == Access::R {
            assert!(!d.access.persistent());
        }
    }
}

#[test]
fn a_module_built_in_two_steps_is_the_one_new_builds() {
    // A microcontroller port builds the module in place: `unpowered`, then `power_up` (firmware/).
    let mut b = Bench::new();
    assert_eq!(b.sap(4, 12345), Status::Ok);
    assert_eq!(b.cmd(Command::Stap { param: 4, motor: 0 }).0, Status::Ok);
    b.sgp(7, 2, -9);
    let board = b.module.board().clone();
    let mut two = crate::Module::unpowered(board.clone(), &SPEC, b.now);
    two.power_up(b.now);
    let one = crate::Module::new(board, &SPEC, b.now);
    assert_eq!(format!("{:?}", two.state()), format!("{:?}", one.state()));
    assert_eq!(two.registers(), one.registers());
    b.module = two;
    assert_eq!(b.gap(4), 12345);
    assert_eq!(b.ggp(7, 2), 0);
}

/// The module address set by its meaning (the model's serial address setting, GP 66 here): stored at
/// once as SGP 66 would, answered on the new address from the next frame, kept across a power cycle; out
/// of range is status 4 and changes nothing.
#[test]
fn the_address_is_set_by_meaning() {
    let mut b = Bench::new();
    let now = b.now;
    b.module.set_address(5, now).unwrap();
    assert_eq!(b.module.address(), 5);
    assert!(b.to(1, Opcode::Gap, 1, 0, 0).is_none(), "the old address is not answered");
    assert_eq!(b.to(5, Opcode::Ggp, 66, 0, 0).unwrap().value, 5);
    b.power_cycle();
    assert_eq!(b.module.address(), 5, "stored in the EEPROM");
    assert_eq!(b.module.set_address(0, now), Err(Status::InvalidValue));
    assert_eq!(b.module.address(), 5);
}

//! Direct-mode commands (manual §3.7): motion, I/O, coordinates, calculations.

use super::*;
use tmcl_wire::{CalcOp, CalcxOp, MoveTarget, RfsAction};

fn mvp(b: &mut Bench, target: MoveTarget) -> Status {
    b.cmd(Command::Mvp { motor: 0, target }).0
}

#[test]
fn ror_rol_mst() {
    let mut b = Bench::new();
    // §3.7.1 example ROR 0, 51200: velocity mode, AP 2 = 51200.
    assert_eq!(b.bytes(&[0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0xC8, 0x00, 0xCA])[2], 100);
    assert_eq!((b.gap(128), b.gap(2)), (1, 51200));
    b.run(Duration::from_secs(2));
    assert_eq!(b.gap(3), 51200);
    assert!(b.gap(1) > 51200);
    // §3.7.3 example MST: decelerates with AP 5 to 0 (1 s at 51200 pps²).
    b.bytes(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04]);
    assert_eq!(b.gap(2), 0);
    b.run(Duration::from_millis(500));
    assert!((20_000..30_000).contains(&b.gap(3)));
    b.run(Duration::from_millis(600));
    assert_eq!(b.gap(3), 0);
    // §3.7.2 example ROL 0, 51200: AP 2 = −51200, the counter decreases.
    b.bytes(&[0x01, 0x02, 0x00, 0x00, 0x00, 0x00, 0xC8, 0x00, 0xCB]);
    assert_eq!(b.gap(2), -51200);
    let p = b.gap(1);
    b.run(Duration::from_millis(100));
    assert!(b.gap(1) < p);
    // pytrinamic's rotate(-v) is ROR with a negative velocity: turns left.
    assert_eq!(b.cmd(Command::Ror { motor: 0, velocity: -100 }).0, Status::Ok);
    assert_eq!(b.gap(2), -100);
    // ROL's range is −2147483648..2147483647 (§3.7.2); the lowest value, whose negation does not fit,
    // turns right at the highest velocity (it was refused with status 4).
    assert_eq!(b.cmd(Command::Rol { motor: 0, velocity: i32::MIN }), (Status::Ok, i32::MIN));
    assert_eq!(b.gap(2), i32::MAX);
    assert_eq!(b.cmd(Command::Ror { motor: 1, velocity: 5 }).0, Status::InvalidValue);
}

#[test]
fn mvp_abs_rel_coord() {
    let mut b = Bench::new();
    // §3.7.4 example MVP ABS, 0, 90000.
    assert_eq!(b.bytes(&[0x01, 0x04, 0x00, 0x00, 0x00, 0x01, 0x5F, 0x90, 0xF5])[2], 100);
    assert_eq!((b.gap(0), b.gap(128), b.gap(8)), (90000, 0, 0));
    b.run(Duration::from_secs(3));
    assert_eq!((b.gap(1), b.gap(8), b.gap(3)), (90000, 1, 0));
    // §3.7.4 example MVP REL, 0, -10000: relative to the actual position.
    b.bytes(&[0x01, 0x04, 0x01, 0x00, 0xFF, 0xFF, 0xD8, 0xF0, 0xCC]);
    assert_eq!(b.gap(0), 80000);
    b.run(Duration::from_secs(2));
    assert_eq!(b.gap(1), 80000);
    // REL past the 32-bit range: status 4, nothing changes.
    assert_eq!(mvp(&mut b, MoveTarget::Rel(i32::MAX)), Status::InvalidValue);
    assert_eq!(b.gap(0), 80000);
    // §3.7.4 example MVP COORD, 0, 8, after SCO 8.
    assert_eq!(b.cmd(Command::Sco { coord: 8, motor: 0, position: -1234 }).0, Status::Ok);
    b.bytes(&[0x01, 0x04, 0x02, 0x00, 0x00, 0x00, 0x00, 0x08, 0x0F]);
    b.run(Duration::from_secs(3));
    assert_eq!(b.gap(1), -1234);
    assert_eq!(mvp(&mut b, MoveTarget::Coord(21)), Status::InvalidValue);
    assert_eq!(mvp(&mut b, MoveTarget::Coord(-1)), Status::InvalidValue);
    assert_eq!(b.send(Opcode::Mvp, 3, 0, 0).status, Status::WrongType);
}

#[test]
fn target_change_during_a_move() {
    let mut b = Bench::new();
    mvp(&mut b, MoveTarget::Abs(200_000));
    b.run(Duration::from_millis(700));
    mvp(&mut b, MoveTarget::Abs(-5000));
    b.run(Duration::from_secs(8));
    assert_eq!(b.gap(1), -5000);
    // SAP 0 also starts a move (§3.7.29 AAP example).
    assert_eq!(b.sap(0, 0), Status::Ok);
    b.run(Duration::from_secs(2));
    assert_eq!(b.gap(1), 0);
}

#[test]
fn set_actual_position_does_not_move() {
    let mut b = Bench::new();
    assert_eq!(b.sap(1, 5000), Status::Ok);
    b.run(Duration::from_millis(100));
    assert_eq!((b.gap(1), b.gap(0), b.gap(3)), (5000, 5000, 0));
    assert_eq!(b.module.board().physical, 0, "the motor did not turn");
}

#[test]
fn limit_switches_stop_motion_towards_them() {
    let mut b = Bench::new();
    b.cmd(Command::Ror { motor: 0, velocity: 10000 });
    b.run(Duration::from_millis(300));
    b.module.board_mut().switches.right = true;
    assert_eq!(b.gap(10), 1);
    b.run(Duration::from_millis(5));
    assert_eq!(b.gap(3), 0, "stopped at the right switch");
    let p = b.gap(1);
    b.run(Duration::from_millis(100));
    assert_eq!(b.gap(1), p);
    // Away from the switch is allowed.
    b.cmd(Command::Rol { motor: 0, velocity: 10000 });
    b.run(Duration::from_millis(100));
    assert!(b.gap(1) < p);
    // AP 12 = 1 disables the right switch.
    b.sap(12, 1);
    b.cmd(Command::Ror { motor: 0, velocity: 10000 });
    b.run(Duration::from_millis(300));
    assert!(b.gap(3) > 0);
    // GP 79 reverses the polarity: the pressed switch now reads 0 and the open left one 1.
    b.sgp(79, 0, 1);
    assert_eq!((b.gap(10), b.gap(11)), (0, 1));
}

#[test]
fn currents_follow_motion_and_delays() {
    let mut b = Bench::new();
    b.sap(6, 200);
    b.sap(7, 20);
    b.sap(200, 250);
    b.sap(214, 50); // 0.5 s
    b.cmd(Command::Ror { motor: 0, velocity: 51200 });
    b.run(Duration::from_millis(100));
    assert_eq!(b.module.board().drive.current, 250, "boost while accelerating");
    b.run(Duration::from_secs(2));
    assert_eq!(b.module.board().drive.current, 200, "run current at constant speed");
    b.cmd(Command::Mst { motor: 0 });
    b.run(Duration::from_millis(1200));
    assert_eq!(b.module.board().drive.current, 200, "still run current right after the stop");
    b.run(Duration::from_millis(400));
    assert_eq!(b.module.board().drive.current, 20, "standby after AP 214");
    assert_eq!(b.gap(180), 20 >> 3);
    // AP 204: freewheel after the delay.
    b.sap(204, 10);
    b.run(Duration::from_millis(10));
    assert!(!b.module.board().drive.enabled);
    // AP 167 = 0 switches the driver off.
    b.sap(204, 0);
    b.run(Duration::from_millis(1));
    assert!(b.module.board().drive.enabled);
    b.sap(167, 0);
    b.run(Duration::from_millis(1));
    assert!(!b.module.board().drive.enabled);
}

#[test]
fn deadline_when_idle_is_the_standby_timer() {
    let mut b = Bench::new();
    b.cmd(Command::Mvp { motor: 0, target: MoveTarget::Abs(100) });
    let next = b.module.poll(b.now, &mut |_: &[u8]| {}).unwrap();
    assert_eq!(next, b.now + Duration::from_millis(1), "moving: every tick");
    b.run(Duration::from_secs(1));
    let next = b.module.poll(b.now, &mut |_: &[u8]| {}).unwrap();
    assert!(next > b.now && next <= b.now + Duration::from_secs(2));
    b.run(Duration::from_secs(3));
    assert_eq!(b.module.poll(b.now, &mut |_: &[u8]| {}), None, "nothing left to do");
}

#[test]
fn microstep_resolution_reaches_the_driver() {
    let mut b = Bench::new();
    b.sap(140, 4); // 16 microsteps
    mvp(&mut b, MoveTarget::Abs(16));
    b.run(Duration::from_millis(500));
    assert_eq!(b.module.board().drive.resolution, 4);
    assert_eq!(b.module.board().physical, 256, "one full step");
}

#[test]
fn encoder_follows_on_a_free_axis() {
    // §6.2 Table 20: with the matching prescaler the encoder position equals the step position.
    for (res, p) in [(8, 25600), (7, 12800), (6, 6400), (5, 3200), (4, 1600), (3, 800), (2, 400), (1, 200)] {
        let mut b = Bench::new();
        assert_eq!(b.sap(140, res), Status::Ok);
        assert_eq!(b.sap(210, p), Status::Ok);
        let steps = 3 * (200 << res); // three revolutions
        mvp(&mut b, MoveTarget::Abs(steps));
        b.run(Duration::from_secs(10));
        assert_eq!(b.gap(1), steps);
        let e = b.gap(209);
        assert!((e - steps).abs() <= (1 << res) / 4 + 1, "res {res}: encoder {e} vs {steps}");
    }
    let mut b = Bench::new();
    assert_eq!(b.sap(209, 1000), Status::Ok);
    assert_eq!(b.gap(209), 1000);
    assert_eq!(b.gap(215), 0);
    assert_eq!(b.send(Opcode::Gio, 11, 0, 0).value, 1, "at absolute zero");
}

#[test]
fn reverse_shaft_turns_the_motor_the_other_way() {
    let mut b = Bench::new();
    b.sgp(90, 0, 1);
    mvp(&mut b, MoveTarget::Abs(512));
    b.run(Duration::from_secs(1));
    assert_eq!(b.gap(1), 512);
    assert_eq!(b.module.board().physical, -512);
    assert!((b.gap(209) - 512).abs() <= 50, "the encoder is reversed with the motor");
}

#[test]
fn io_ports() {
    let mut b = Bench::new();
    b.module.board_mut().inputs = 0b1010;
    assert_eq!(b.send(Opcode::Gio, 1, 0, 0).value, 1);
    assert_eq!(b.send(Opcode::Gio, 0, 0, 0).value, 0);
    assert_eq!(b.send(Opcode::Gio, 255, 0, 0).value, 0b1010);
    b.module.board_mut().analog = 4095;
    assert_eq!(b.send(Opcode::Gio, 0, 1, 0).value, 4095);
    assert_eq!(b.send(Opcode::Gio, 9, 1, 0).value, 25);
    // §3.7.14 example SIO 0, 2, 1.
    assert_eq!(b.bytes(&[0x01, 0x0E, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x12])[2], 100);
    assert_eq!(b.module.board().outputs, 1);
    assert_eq!(b.send(Opcode::Gio, 0, 2, 0).value, 1);
    assert_eq!(b.send(Opcode::Sio, 1, 2, 1).status, Status::Ok);
    assert_eq!(b.module.board().outputs, 3);
    assert_eq!(b.send(Opcode::Sio, 255, 2, 0).status, Status::Ok);
    assert_eq!(b.module.board().outputs, 0);
    // SIO 255, 2, -1 takes the bit vector from the accumulator.
    b.cmd(Command::Calc { op: CalcOp::Load, operand: 2 });
    assert_eq!(b.send(Opcode::Sio, 255, 2, -1).status, Status::Ok);
    assert_eq!(b.module.board().outputs, 2);
    // Bad ports, banks and values.
    assert_eq!(b.send(Opcode::Sio, 2, 2, 1).status, Status::WrongType);
    assert_eq!(b.send(Opcode::Sio, 0, 2, 2).status, Status::InvalidValue);
    assert_eq!(b.send(Opcode::Sio, 255, 2, 256).status, Status::InvalidValue);
    assert_eq!(b.send(Opcode::Sio, 0, 0, 1).status, Status::InvalidValue);
    assert_eq!(b.send(Opcode::Gio, 4, 0, 0).status, Status::WrongType);
    assert_eq!(b.send(Opcode::Gio, 0, 3, 0).status, Status::InvalidValue);
    assert_eq!(b.module.board().outputs, 2);
}

#[test]
fn coordinates_and_their_eeprom_copies() {
    let mut b = Bench::new();
    // §3.7.24 example SCO 1, 0, 1000; §3.7.25 example GCO 1, 0.
    assert_eq!(b.bytes(&[0x01, 0x1E, 0x01, 0x00, 0x00, 0x00, 0x03, 0xE8, 0x0B])[2], 100);
    assert_eq!(b.cmd(Command::Gco { coord: 1, motor: 0 }), (Status::Ok, 1000));
    assert_eq!(b.cmd(Command::Sco { coord: 21, motor: 0, position: 0 }).0, Status::WrongType);
    // §3.7.26 example (captioned CCO 3, 0, its bytes encode CCO 1, 0): capture the actual position.
    b.sap(1, 777);
    assert_eq!(b.cmd(Command::Cco { coord: 1, motor: 0 }), (Status::Ok, 777));
    // ACO: from the accumulator.
    b.cmd(Command::Calc { op: CalcOp::Load, operand: -9 });
    assert_eq!(b.cmd(Command::Aco { coord: 2, motor: 0 }).0, Status::Ok);
    assert_eq!(b.cmd(Command::Gco { coord: 2, motor: 0 }).1, -9);
    // GP 84 = 0: RAM only, until SCO 0, 255, 0 copies them.
    b.power_cycle();
    assert_eq!(b.cmd(Command::Gco { coord: 1, motor: 0 }).1, 0);
    b.cmd(Command::Sco { coord: 1, motor: 0, position: 11 });
    b.cmd(Command::Sco { coord: 2, motor: 0, position: 22 });
    assert_eq!(b.cmd(Command::Sco { coord: 0, motor: 255, position: 0 }).0, Status::Ok);
    b.cmd(Command::Sco { coord: 1, motor: 0, position: 0 });
    assert_eq!(b.cmd(Command::Gco { coord: 1, motor: 255 }).0, Status::Ok);
    assert_eq!(b.cmd(Command::Gco { coord: 1, motor: 0 }).1, 11);
    // GP 84 = 1: every write also goes to the EEPROM and comes back at start-up.
    b.sgp(84, 0, 1);
    b.cmd(Command::Sco { coord: 3, motor: 0, position: 33 });
    b.cmd(Command::Sco { coord: 0, motor: 0, position: 44 });
    b.power_cycle();
    assert_eq!(b.cmd(Command::Gco { coord: 3, motor: 0 }).1, 33);
    assert_eq!(b.cmd(Command::Gco { coord: 2, motor: 0 }).1, 22);
    assert_eq!(b.cmd(Command::Gco { coord: 0, motor: 0 }).1, 0, "coordinate 0 is RAM only");
}

#[test]
fn calc_calcx_aap_agp() {
    let mut b = Bench::new();
    let calc = |b: &mut Bench, op, v| b.cmd(Command::Calc { op, operand: v });
    calc(&mut b, CalcOp::Load, 10);
    calc(&mut b, CalcOp::Mul, -5000);
    assert_eq!(b.module.host_registers().accumulator, -50000);
    calc(&mut b, CalcOp::Div, 7);
    assert_eq!(b.module.host_registers().accumulator, -7142);
    calc(&mut b, CalcOp::Mod, 1000);
    assert_eq!(b.module.host_registers().accumulator, -142);
    assert_eq!(calc(&mut b, CalcOp::Div, 0).0, Status::InvalidValue);
    assert_eq!(b.module.host_registers().accumulator, -142, "unchanged after a division by zero");
    calc(&mut b, CalcOp::Load, i32::MIN);
    assert_eq!(calc(&mut b, CalcOp::Div, -1).0, Status::Ok, "wraps, never panics");
    calc(&mut b, CalcOp::Load, 0b1100);
    calc(&mut b, CalcOp::And, 0b1010);
    calc(&mut b, CalcOp::Or, 1);
    calc(&mut b, CalcOp::Xor, 0xFF);
    assert_eq!(b.module.host_registers().accumulator, 0b1111_0110);
    calc(&mut b, CalcOp::Not, 0);
    assert_eq!(b.module.host_registers().accumulator, !0b1111_0110);
    // CALCX.
    calc(&mut b, CalcOp::Load, 6);
    b.cmd(Command::Calcx { op: CalcxOp::Load });
    calc(&mut b, CalcOp::Load, 7);
    b.cmd(Command::Calcx { op: CalcxOp::Mul });
    assert_eq!(b.module.host_registers().accumulator, 42);
    b.cmd(Command::Calcx { op: CalcxOp::Swap });
    assert_eq!((b.module.host_registers().accumulator, b.module.host_registers().x), (6, 42));
    // AAP 4, AGP 42, 2: the accumulator into parameters, range-checked.
    calc(&mut b, CalcOp::Load, 12345);
    assert_eq!(b.cmd(Command::Aap { param: 4, motor: 0 }).0, Status::Ok);
    assert_eq!(b.gap(4), 12345);
    assert_eq!(b.cmd(Command::Agp { param: 42, bank: 2 }).0, Status::Ok);
    assert_eq!(b.ggp(42, 2), 12345);
    calc(&mut b, CalcOp::Load, 0);
    assert_eq!(b.cmd(Command::Aap { param: 4, motor: 0 }).0, Status::InvalidValue);
    assert_eq!(b.gap(4), 12345);
    // GAP in direct mode never touches the accumulator (§3.6.5).
    b.gap(1);
    assert_eq!(b.module.host_registers().accumulator, 0);
}

#[test]
fn standalone_only_commands_from_the_host() {
    let mut b = Bench::new();
    for c in [
        Command::Ja { address: 0 },
        Command::Jc { condition: tmcl_wire::Condition::Zero, address: 0 },
        Command::Comp { operand: 0 },
        Command::Csub { address: 0 },
        Command::Rsub,
        Command::Wait { condition: tmcl_wire::WaitCondition::Ticks, motor: 0, ticks: 1 },
        Command::Stop,
        Command::Vect { interrupt: 0, address: 0 },
        Command::Reti,
        Command::UserFunction { function: 3, kind: 0, motor: 0, value: 0 },
    ] {
        assert_eq!(b.cmd(c).0, Status::NotAvailable, "{c:?}");
    }
    for code in [16u8, 17, 18, 29, 40, 72, 127, 140, 157] {
        assert_eq!(b.send(Opcode::from(code), 0, 0, 0).status, Status::InvalidCommand, "opcode {code}");
    }
}

#[test]
fn cle_ei_di() {
    let mut b = Bench::new();
    // §3.7.31–3.7.33 examples CLE ETO, EI 255, DI 255.
    assert_eq!(b.bytes(&[0x01, 0x24, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x26])[2], 100);
    assert_eq!(b.bytes(&[0x01, 0x19, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x19])[2], 100);
    assert!(b.module.vm().interrupt_enabled(255));
    assert_eq!(b.bytes(&[0x01, 0x1A, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1A])[2], 100);
    assert!(!b.module.vm().interrupt_enabled(255));
    assert_eq!(b.cmd(Command::Ei { interrupt: 15 }).0, Status::Ok);
    assert_eq!(b.cmd(Command::Ei { interrupt: 4 }).0, Status::WrongType, "no interrupt 4 (Table 12)");
}

#[test]
fn reference_search_status_idle() {
    let mut b = Bench::new();
    assert_eq!(b.cmd(Command::Rfs { action: RfsAction::Status, motor: 0 }), (Status::Ok, 0));
}

#[test]
fn state_fits_in_4_kib_per_motor() {
    // The extra host links of a simulator (feature `host-links`) are not the microcontroller's to carry.
    let extra = (crate::iface::HOST_LINKS - 1) * core::mem::size_of::<crate::iface::Port>();
    let axis = core::mem::size_of::<crate::module::Axis>();
    let motors = usize::from(tmcl_model::capacity::MAX_MOTORS);
    let size = core::mem::size_of::<crate::State>() - extra;
    // One motor's state and the rest in 4 KiB, as before there were several; each further motor ~1 KiB.
    assert!(size - (motors - 1) * axis <= 4096, "{size} with {motors} motors of {axis}");
    assert!(axis <= 1024, "{axis}");
}

//! The module as seen on the wire: framing, checksums, addressing, special replies (manual §3.1–3.2,
//! §3.7.37–3.7.38, §5.1 GP 66/75/76/87/255).

use super::*;

#[test]
fn manual_gio_reply_layout() {
    // §3.7.15: GIO 0, 1 → `02 01 64 0F 00 00 01 2E A5` when the analog value is 302.
    let mut b = Bench::new();
    b.module.board_mut().analog = 302;
    let out = b.bytes(&[0x01, 0x0F, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x11]);
    assert_eq!(out, [0x02, 0x01, 0x64, 0x0F, 0x00, 0x00, 0x01, 0x2E, 0xA5]);
}

#[test]
fn manual_calc_reply_layout() {
    // §3.7.16: CALC MUL, -5000 → `02 01 64 13 FF FF EC 78 DC` (the value is the operand).
    let mut b = Bench::new();
    let out = b.bytes(&[0x01, 0x13, 0x02, 0x00, 0xFF, 0xFF, 0xEC, 0x78, 0x78]);
    assert_eq!(out, [0x02, 0x01, 0x64, 0x13, 0xFF, 0xFF, 0xEC, 0x78, 0xDC]);
}

#[test]
fn wrong_checksum_gets_status_1() {
    let mut b = Bench::new();
    let out = b.bytes(&[0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x09]);
    let r = Reply::parse(&ReplyFrame::new_checked(&out[..]).unwrap()).unwrap();
    assert_eq!((r.status, r.opcode, r.value), (Status::WrongChecksum, 0, 0));
    // ... and changes nothing: a SAP with a bad checksum is not executed.
    let mut sap = Request { address: 1, instruction: Instruction::new(Opcode::Sap, 4, 0, 1000) }.to_bytes();
    sap[8] = sap[8].wrapping_add(1);
    b.bytes(&sap);
    assert_eq!(b.gap(4), 51200);
}

#[test]
fn other_addresses_get_no_reply() {
    let mut b = Bench::new();
    assert_eq!(b.to(2, Opcode::Gap, 1, 0, 0), None);
    // Not even a wrong checksum to another address is answered.
    assert!(b.bytes(&[0x05, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]).is_empty());
    assert!(b.to(1, Opcode::Gap, 1, 0, 0).is_some());
}

#[test]
fn split_frames_and_resync_after_garbage() {
    let mut b = Bench::new();
    let frame = [0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08];
    assert!(b.bytes(&frame[..3]).is_empty());
    b.now += Duration::from_millis(2);
    assert_eq!(b.bytes(&frame[3..]).len(), 9);
    // Garbage, then a pause longer than 5 ms: the partial frame is dropped and the next one parses.
    assert!(b.bytes(&[0xFF, 0x00, 0x13]).is_empty());
    b.now += Duration::from_millis(6);
    let out = b.bytes(&frame);
    assert_eq!(out.len(), 9);
    assert_eq!(out[2], 100);
}

#[test]
fn module_and_host_address() {
    let mut b = Bench::new();
    // §3.7.9 example: SGP 66, 0, 3 — the reply already comes from the new address.
    let out = b.bytes(&[0x01, 0x09, 0x42, 0x00, 0x00, 0x00, 0x00, 0x03, 0x4F]);
    assert_eq!(&out[..3], &[0x02, 0x03, 0x64]);
    assert_eq!(b.to(1, Opcode::Gap, 1, 0, 0), None);
    assert_eq!(b.to(3, Opcode::Ggp, 66, 0, 0).unwrap().value, 3);
    // GP 76: the host address in byte 0 of replies.
    assert_eq!(b.to(3, Opcode::Sgp, 76, 0, 9).unwrap().host, 9);
    assert_eq!(b.to(3, Opcode::Gap, 1, 0, 0).unwrap().host, 9);
    // Both are automatically stored (A): they survive a power cycle.
    b.power_cycle();
    let r = b.to(3, Opcode::Gap, 1, 0, 0).unwrap();
    assert_eq!((r.host, r.module), (9, 3));
}

/// The settings as the model's table gives them now, each looked up by its meaning (as the way of a
/// frame did before they were kept ready, `param::banks::FrameSettings`): they must be what is kept, and
/// the next frames must follow them (§3.1 and §5.1 GP 66, 68, 75, 76, 87, 255).
fn frame_settings_seen(b: &mut Bench) {
    use crate::model::Setting;
    let gp = |s| b.module.gp(s);
    let expected = crate::param::banks::FrameSettings {
        address: gp(Setting::SerialAddress).map_or(1, |a| a as u8),
        secondary: gp(Setting::SecondaryAddress).unwrap_or(0) as u8,
        host: gp(Setting::HostAddress).map_or(2, |a| a as u8),
        suppress: gp(Setting::SuppressReply) == Some(1),
        pause_ms: gp(Setting::TelegramPause).unwrap_or(0).max(0) as u32,
        heartbeat: gp(Setting::SerialHeartbeat).unwrap_or(0),
    };
    assert_eq!(*b.module.st.banks.ready(), expected);
    let address = expected.address;
    // Addresses: the primary one answers with the host and module address; the secondary one answers too;
    // another one does not.
    let r = b.to(address, Opcode::Gap, 1, 0, 0).expect("a reply on the primary address");
    assert_eq!((r.host, r.module), (expected.host, address));
    if expected.secondary != 0 {
        assert_eq!(b.to(expected.secondary, Opcode::Gap, 1, 0, 0).map(|r| r.module), Some(address));
    }
    let other = (1..=255).find(|a| *a != address && *a != expected.secondary).unwrap();
    assert_eq!(b.to(other, Opcode::Gap, 1, 0, 0), None);
    // GP 255: a command that is not GAP, GGP or GIO (a user variable set) is answered or not.
    assert_eq!(b.to(address, Opcode::Sgp, 0, 2, 0).is_some(), !expected.suppress);
    // GP 75: the reply waits for the telegram pause.
    let frame = Request { address, instruction: Instruction::new(Opcode::Gap, 1, 0, 0) }.to_bytes();
    let mut out = Vec::new();
    b.module.receive(b.now, &frame, &mut |x: &[u8]| out.extend_from_slice(x));
    if expected.pause_ms == 0 {
        assert_eq!(out.len(), 9);
    } else {
        assert!(out.is_empty());
        let due = b.module.state().port(0).and_then(|p| p.outbox.next_due());
        assert_eq!(due, Some(b.now + Duration::from_millis(u64::from(expected.pause_ms))));
        b.now = due.unwrap();
        b.module.poll(b.now, &mut |x: &[u8]| out.extend_from_slice(x));
        assert_eq!(out.len(), 9);
    }
    // GP 68: without a command for longer than the heartbeat the motor stops; without a heartbeat it turns.
    b.to(address, Opcode::Ror, 0, 0, 5000);
    b.run(Duration::from_millis(expected.heartbeat.max(0) as u64 + 400));
    let turning = b.to(address, Opcode::Gap, 3, 0, 0).unwrap().value != 0;
    assert_eq!(turning, expected.heartbeat <= 0);
    b.to(address, Opcode::Mst, 0, 0, 0);
    b.run(Duration::from_millis(400));
    assert_eq!(b.to(address, Opcode::Gap, 3, 0, 0).unwrap().value, 0);
}

/// The bank 0 settings every frame reads are kept ready behind the banks' one write function: every way
/// of changing them (SGP, AGP, `Module::set_address`, RSGP, a program's SGP, the EEPROM's values at a
/// restart and a power cycle, the factory defaults) is seen by the next frame.
#[test]
fn frame_settings_follow_every_way_of_changing_them() {
    use tmcl_wire::CalcOp;
    let mut b = Bench::new();
    let index = |n: u8| SPEC.global.index(n).unwrap();
    let in_eeprom = |b: &mut Bench, n: u8, v: i32| {
        persist::store_global(b.module.board_mut(), &SPEC, index(n), v).unwrap();
    };
    frame_settings_seen(&mut b);
    // SGP of each, from the host (§3.7.9); each reply already follows the setting.
    let mut address = 1;
    for (n, v) in [(66, 3), (87, 7), (76, 9), (75, 5), (68, 50), (255, 1)] {
        b.to(address, Opcode::Sgp, n, 0, v);
        address = b.module.address();
        frame_settings_seen(&mut b);
    }
    assert_eq!(address, 3);
    // AGP: the host's accumulator into GP 66 (§3.7.30).
    b.cmd_to(address, Command::Calc { op: CalcOp::Load, operand: 4 });
    b.cmd_to(address, Command::Agp { param: 66, bank: 0 });
    assert_eq!(b.module.address(), 4);
    frame_settings_seen(&mut b);
    // By meaning, from the caller.
    let now = b.now;
    b.module.set_address(6, now).unwrap();
    frame_settings_seen(&mut b);
    // RSGP: the EEPROM's value back into RAM (§3.7.12).
    in_eeprom(&mut b, 76, 11);
    b.cmd_to(6, Command::Rsgp { param: 76, bank: 0 });
    assert_eq!(b.module.gp(crate::model::Setting::HostAddress), Some(11));
    frame_settings_seen(&mut b);
    // A program's SGP (GP 255 off first, so that the download's replies come).
    b.cmd_to(6, Command::Sgp { param: 255, bank: 0, value: 0 });
    frame_settings_seen(&mut b);
    b.cmd_to(6, Command::StartDownload { address: 0 });
    b.cmd_to(6, Command::Sgp { param: 75, bank: 0, value: 0 });
    b.cmd_to(6, Command::Stop);
    b.cmd_to(6, Command::QuitDownload);
    b.cmd_to(6, Command::RunApplication { from: Some(0) });
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.gp(crate::model::Setting::TelegramPause), Some(0));
    frame_settings_seen(&mut b);
    // A restart (255) loads the EEPROM's values.
    in_eeprom(&mut b, 87, 0);
    in_eeprom(&mut b, 68, 0);
    b.cmd_to(6, Command::SoftwareReset);
    frame_settings_seen(&mut b);
    // So does a power cycle.
    in_eeprom(&mut b, 66, 12);
    b.power_cycle();
    assert_eq!(b.module.address(), 12);
    frame_settings_seen(&mut b);
    // Factory defaults (137): no reply, then a restart on the defaults.
    b.cmd_to(12, Command::FactoryDefault);
    assert_eq!(b.module.address(), 1);
    frame_settings_seen(&mut b);
}

#[test]
fn secondary_address() {
    let mut b = Bench::new();
    assert_eq!(b.to(7, Opcode::Gap, 1, 0, 0), None);
    assert_eq!(b.sgp(87, 0, 7), Status::Ok);
    let r = b.to(7, Opcode::Gap, 1, 0, 0).unwrap();
    // Byte 1 of the reply names the module by its primary address (§5.1 GP 87 does not say which; our decision).
    assert_eq!(r.module, 1);
    assert_eq!(b.sgp(87, 0, 0), Status::Ok);
    assert_eq!(b.to(7, Opcode::Gap, 1, 0, 0), None);
}

#[test]
fn suppress_reply_except_gap_ggp_gio() {
    let mut b = Bench::new();
    assert_eq!(b.to(1, Opcode::Sgp, 255, 0, 1), None, "the SGP itself is already suppressed");
    assert_eq!(b.to(1, Opcode::Sap, 4, 0, 1000), None);
    assert_eq!(b.to(1, Opcode::Mst, 0, 0, 0), None);
    assert_eq!(b.to(1, Opcode::Sap, 4, 0, -1), None, "errors are suppressed too");
    assert!(b.to(1, Opcode::GetVersion, 0, 0, 0).is_none());
    assert_eq!(b.gap(4), 1000);
    assert_eq!(b.ggp(255, 0), 1);
    assert_eq!(b.send(Opcode::Gio, 0, 0, 0).status, Status::Ok);
    // Not storable, 0 again after a restart.
    assert_eq!(b.to(1, Opcode::Stgp, 255, 0, 0), None);
    b.power_cycle();
    assert_eq!(b.ggp(255, 0), 0);
}

#[test]
fn telegram_pause_delays_the_reply() {
    let mut b = Bench::new();
    assert_eq!(b.sgp(75, 0, 20), Status::Ok);
    let frame = Request { address: 1, instruction: Instruction::new(Opcode::Gap, 1, 0, 0) }.to_bytes();
    let mut out = Vec::new();
    b.module.receive(b.now, &frame, &mut |x: &[u8]| out.extend_from_slice(x));
    assert!(out.is_empty());
    let deadline = b.module.poll(b.now, &mut |_: &[u8]| {}).unwrap();
    assert_eq!(deadline, b.now + Duration::from_millis(20));
    b.run(Duration::from_millis(19));
    assert!(b.out.is_empty());
    b.run(Duration::from_millis(1));
    assert_eq!(b.out.len(), 9);
}

#[test]
fn version_string_and_binary() {
    let mut b = Bench::new();
    // 136 type 0: host address + "1021V142", no checksum (the manual gives no layout; pytrinamic's
    // `get_version_string` decodes bytes 1..8 as ASCII).
    let out = b.bytes(&[0x01, 0x88, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x89]);
    assert_eq!(out, [0x02, b'1', b'0', b'2', b'1', b'V', b'1', b'4', b'2']);
    let r = b.send(Opcode::GetVersion, 1, 0, 0);
    assert_eq!(r.value.to_be_bytes(), [10, 21, 1, 42]);
    assert_eq!(b.send(Opcode::GetVersion, 2, 0, 0).status, Status::WrongType);
}

#[test]
fn target_reached_event_next_and_every() {
    let mut b = Bench::new();
    // §3.7.37 example: 138 type 1, mask 1; the first reply at once.
    let out = b.bytes(&[0x01, 0x8A, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0x8D]);
    assert_eq!(out, [0x02, 0x01, 0x64, 0x8A, 0x00, 0x00, 0x00, 0x01, 0xF2]);
    for target in [1000, -500] {
        assert_eq!(b.cmd(Command::Mvp { motor: 0, target: tmcl_wire::MoveTarget::Abs(target) }).0, Status::Ok);
        b.run(Duration::from_secs(2));
        // The second reply: status 128, opcode 138, value = mask.
        assert_eq!(b.out, [0x02, 0x01, 0x80, 0x8A, 0x00, 0x00, 0x00, 0x01, 0x0E]);
        b.out.clear();
    }
    // Type 0: only the next MVP.
    assert_eq!(b.send(Opcode::RequestTargetReachedEvent, 0, 0, 1).status, Status::Ok);
    b.cmd(Command::Mvp { motor: 0, target: tmcl_wire::MoveTarget::Abs(0) });
    b.run(Duration::from_secs(2));
    assert_eq!(b.out.len(), 9);
    b.out.clear();
    b.cmd(Command::Mvp { motor: 0, target: tmcl_wire::MoveTarget::Abs(100) });
    b.run(Duration::from_secs(2));
    assert!(b.out.is_empty());
    // A move interrupted by MST is never reported.
    b.send(Opcode::RequestTargetReachedEvent, 1, 0, 1);
    b.cmd(Command::Mvp { motor: 0, target: tmcl_wire::MoveTarget::Abs(100_000) });
    b.run(Duration::from_millis(100));
    b.cmd(Command::Mst { motor: 0 });
    b.run(Duration::from_secs(3));
    assert!(b.out.is_empty());
    // Mask 0 cancels; other motors do not exist.
    assert_eq!(b.send(Opcode::RequestTargetReachedEvent, 1, 0, 2).status, Status::InvalidValue);
    assert_eq!(b.send(Opcode::RequestTargetReachedEvent, 1, 0, 0).status, Status::Ok);
    b.cmd(Command::Mvp { motor: 0, target: tmcl_wire::MoveTarget::Abs(0) });
    b.run(Duration::from_secs(5));
    assert!(b.out.is_empty());
}

#[test]
fn event_for_a_move_to_where_it_stands() {
    let mut b = Bench::new();
    b.send(Opcode::RequestTargetReachedEvent, 0, 0, 1);
    b.cmd(Command::Mvp { motor: 0, target: tmcl_wire::MoveTarget::Abs(0) });
    b.run(Duration::from_millis(2));
    assert_eq!(b.out.len(), 9);
}

#[test]
fn software_reset_replies_then_restarts() {
    let mut b = Bench::new();
    b.cmd(Command::Ror { motor: 0, velocity: 1000 });
    b.run(Duration::from_millis(500));
    assert!(b.gap(1) > 0);
    b.sap(4, 777);
    assert_eq!(b.send(Opcode::SoftwareReset, 0, 0, 1234).status, Status::Ok);
    assert_eq!(b.gap(1), 0, "the step counter starts at 0");
    assert_eq!(b.gap(3), 0, "the motor stands");
    assert_eq!(b.gap(4), 51200, "unstored RAM values are gone");
    // Without the key: status 4, nothing happens.
    b.sap(4, 777);
    assert_eq!(b.send(Opcode::SoftwareReset, 0, 0, 1).status, Status::InvalidValue);
    assert_eq!(b.gap(4), 777);
}

#[test]
fn factory_defaults_no_reply_and_restart() {
    let mut b = Bench::new();
    b.sap(4, 1000);
    assert_eq!(b.cmd(Command::Stap { param: 4, motor: 0 }).0, Status::Ok);
    b.sgp(76, 0, 5);
    b.sgp(42, 2, 99);
    b.cmd(Command::Stgp { param: 42, bank: 2 });
    assert_eq!(b.to(1, Opcode::FactoryDefault, 0, 0, 1234), None);
    assert_eq!(b.gap(4), 51200);
    let r = b.send(Opcode::Ggp, 76, 0, 0);
    assert_eq!((r.host, r.value), (2, 2));
    assert_eq!(b.ggp(42, 2), 0);
    // Wrong key: a normal reply with status 4.
    assert_eq!(b.send(Opcode::FactoryDefault, 0, 0, 0).status, Status::InvalidValue);
}

#[test]
fn boot_request_is_silent() {
    let mut b = Bench::new();
    assert_eq!(b.to(1, Opcode::Boot, 0x81, 0x92, 0xA3B4C5D6u32 as i32), None);
    assert_eq!(b.gap(4), 51200);
}

#[test]
fn heartbeat_stops_the_motor() {
    let mut b = Bench::new();
    assert_eq!(b.sgp(68, 0, 200), Status::Ok);
    b.cmd(Command::Ror { motor: 0, velocity: 5000 });
    b.run(Duration::from_millis(150));
    assert!(b.gap(3) > 0, "a command within the heartbeat keeps it running");
    b.run(Duration::from_millis(150));
    assert!(b.gap(3) > 0);
    b.run(Duration::from_millis(400));
    assert_eq!(b.gap(3), 0, "no command for 200 ms: stopped");
}

#[test]
fn garbage_never_panics_and_the_module_still_answers() {
    let mut b = Bench::new();
    let mut x: u32 = 12345;
    let mut junk = Vec::new();
    for _ in 0..5000 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        junk.push(x as u8);
    }
    b.bytes(&junk);
    b.now += Duration::from_millis(10);
    assert_eq!(b.send(Opcode::Gap, 4, 0, 0).status, Status::Ok);
}

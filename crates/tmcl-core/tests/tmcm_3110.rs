//! The TMCM-3110 and TMCM-6110 models (`tmcl_core::model::tmcm_3110`, `tmcm_6110`) on a minimal board:
//! frames byte for byte in the binary format of their TMCL firmware manuals (TMCM-3110 V1.11, TMCM-6110
//! V1.19: the command and reply formats; the motor byte names the axis), the version replies (command
//! 136, TMCM-6110 manual §5.6.39: the string and the binary form, which odemis decodes with the module
//! number in the high word), every axis moving on its own in TMC429 units, AP 2 reading the TMC429's
//! v_target per axis in position mode, the EEPROM keeping each axis's parameters, and the ports odemis'
//! TMCL driver uses (GIO 8, 1 the supply voltage, SIO 0, 0 the reference switches' pull-ups).

use std::vec::Vec;
use tmcl_core::model::{tmcm_3110, tmcm_6110, ModelSpec};
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::{Instruction, Opcode, Reply, ReplyFrame, Request, Status};

mod support;
use support::Board;

struct Rig {
    module: Module<Board>,
    spec: &'static ModelSpec,
    now: Instant,
}

impl Rig {
    fn of(spec: &'static ModelSpec) -> Rig {
        let now = Instant::from_secs(1);
        Rig { module: Module::new(Board::new(spec, 1024), spec, now), spec, now }
    }

    /// Power off and on: the same board (its EEPROM), fresh firmware.
    fn restart(&mut self) {
        let board = self.module.board().clone();
        self.module = Module::new(board, self.spec, self.now);
    }

    /// Raw bytes on the primary interface (USB): everything the module sends back.
    fn bytes(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        self.module.receive_on(0, self.now, bytes, &mut |b: &[u8]| out.extend_from_slice(b));
        while out.is_empty() {
            let Some(due) = self.module.state().port(0).and_then(|p| p.outbox.next_due()) else { break };
            self.now = due;
            self.module.poll(self.now, &mut |b: &[u8]| out.extend_from_slice(b));
        }
        out
    }

    fn cmd(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> (Status, i32) {
        let frame = Request { address: 1, instruction: Instruction::new(op, t, m, v) }.to_bytes();
        let out = self.bytes(&frame);
        let r = Reply::parse(&ReplyFrame::new_checked(&out[..]).expect("a 9-byte reply")).expect("checksum");
        (r.status, r.value)
    }

    fn ok(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> i32 {
        let (s, v) = self.cmd(op, t, m, v);
        assert_eq!(s, Status::Ok, "{op:?} {t}, {m}");
        v
    }

    fn gap(&mut self, n: u8, motor: u8) -> i32 {
        self.ok(Opcode::Gap, n, motor, 0)
    }

    fn run(&mut self, d: Duration) {
        let end = self.now + d;
        let mut sink = |_: &[u8]| {};
        loop {
            match self.module.poll(self.now, &mut sink) {
                Some(t) if t <= end => self.now = t.max(self.now + Duration::from_micros(1)),
                _ => break,
            }
        }
        self.now = end;
        self.module.poll(self.now, &mut sink);
    }
}

/// The reply `host 2, module 1, status, command, value` with its checksum.
fn reply(status: u8, op: u8, value: i32) -> [u8; 9] {
    let mut r = [2, 1, status, op, 0, 0, 0, 0, 0];
    r[4..8].copy_from_slice(&value.to_be_bytes());
    r[8] = tmcl_wire::checksum(&r[..8]);
    r
}

#[test]
fn frames_byte_for_byte_on_every_axis() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    // ROR 2, 1000 (motor byte 2): 01 01 00 02 00 00 03 E8, checksum EF; the reply echoes the value.
    assert_eq!(
        r.bytes(&[0x01, 0x01, 0x00, 0x02, 0x00, 0x00, 0x03, 0xE8, 0xEF]),
        [0x02, 0x01, 0x64, 0x01, 0x00, 0x00, 0x03, 0xE8, 0x53]
    );
    // MST 2.
    assert_eq!(r.bytes(&[0x01, 0x03, 0x00, 0x02, 0x00, 0x00, 0x00, 0x00, 0x06]), reply(100, 3, 0));
    // GAP 4, 1: motor 1's maximum positioning speed, 1000 TMC429 units at the start.
    assert_eq!(
        r.bytes(&[0x01, 0x06, 0x04, 0x01, 0x00, 0x00, 0x00, 0x00, 0x0C]),
        [0x02, 0x01, 0x64, 0x06, 0x00, 0x00, 0x03, 0xE8, 0x58]
    );
    // GAP 1, 3: the TMCM-3110 has motors 0..2: status 4 (invalid value of the motor byte).
    assert_eq!(r.bytes(&[0x01, 0x06, 0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x0B]), reply(4, 6, 0));
    // 136 type 0: the host address and eight characters, no checksum (TMCM-6110 manual §5.6.39).
    assert_eq!(r.bytes(&[0x01, 0x88, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x89]), *b"\x023110V111");
    // 136 type 1: 3110 (0x0C26) in the high word, firmware 1.11 (0x01, 0x0B) in the low word.
    assert_eq!(
        r.bytes(&[0x01, 0x88, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x8A]),
        [0x02, 0x01, 0x64, 0x88, 0x0C, 0x26, 0x01, 0x0B, 0x2D]
    );
    // GIO 0, 1 (the manuals' GIO example, "get the analogue value of ADC channel 0"): 01 0F 00 01 …, 11.
    // The minimal board's channel 0 reads 1000.
    assert_eq!(r.bytes(&[0x01, 0x0F, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x11]), reply(100, 15, 1000));

    let mut r = Rig::of(&tmcm_6110::SPEC);
    assert_eq!(r.bytes(&[0x01, 0x88, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x89]), *b"\x026110V119");
    // 6110 = 0x17DE, firmware 1.19 = 0x01, 0x13.
    assert_eq!(
        r.bytes(&[0x01, 0x88, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x8A]),
        [0x02, 0x01, 0x64, 0x88, 0x17, 0xDE, 0x01, 0x13, 0xF8]
    );
    // MVP ABS, 5, 2000 (motor 5, the sixth): 01 04 00 05 00 00 07 D0, checksum E1.
    assert_eq!(r.bytes(&[0x01, 0x04, 0x00, 0x05, 0x00, 0x00, 0x07, 0xD0, 0xE1]), reply(100, 4, 2000));
    // Motor 6 is beyond the six.
    assert_eq!(r.cmd(Opcode::Gap, 1, 6, 0).0, Status::InvalidValue);
}

/// Each axis its own ramp: three targets at once, each reached; the others stand meanwhile.
#[test]
fn every_axis_moves_on_its_own() {
    for spec in [&tmcm_3110::SPEC, &tmcm_6110::SPEC] {
        let mut r = Rig::of(spec);
        let motors = spec.motors;
        for m in 0..motors {
            r.ok(Opcode::Mvp, 0, m, 1000 * (i32::from(m) + 1) * if m % 2 == 0 { 1 } else { -1 });
        }
        r.run(Duration::from_millis(2000));
        for m in 0..motors {
            let want = 1000 * (i32::from(m) + 1) * if m % 2 == 0 { 1 } else { -1 };
            assert_eq!((r.gap(1, m), r.gap(8, m)), (want, 1), "{} motor {m}", spec.name);
        }
        // One axis turning, the rest at rest.
        r.ok(Opcode::Ror, 0, motors - 1, 500);
        r.run(Duration::from_millis(200));
        assert_eq!(r.gap(3, motors - 1), 500);
        assert!((0..motors - 1).all(|m| r.gap(3, m) == 0));
    }
}

/// AP 2 in position mode is the TMC429's v_target: v_max (AP 4) in the direction of travel while the
/// axis accelerates or runs, 0 while it brakes and at rest; each axis its own.
#[test]
fn ap2_reads_v_target_per_axis() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    r.ok(Opcode::Sap, 4, 1, 800);
    r.ok(Opcode::Mvp, 0, 1, -200_000);
    r.run(Duration::from_millis(20));
    assert_eq!((r.gap(2, 0), r.gap(2, 1), r.gap(2, 2)), (0, -800, 0), "motor 1 driving backwards");
    r.run(Duration::from_secs(10));
    assert_eq!((r.gap(1, 1), r.gap(2, 1)), (-200_000, 0), "at rest: 0");
    // In velocity mode AP 2 is what ROR set.
    r.ok(Opcode::Ror, 0, 2, 300);
    assert_eq!(r.gap(2, 2), 300);
}

/// STAP keeps each axis's parameter in the EEPROM: after a power cycle motor 2 has its value, motor 0
/// the start value.
#[test]
fn eeprom_per_axis() {
    let mut r = Rig::of(&tmcm_6110::SPEC);
    r.ok(Opcode::Sap, 4, 5, 1234);
    r.ok(Opcode::Stap, 4, 5, 0);
    r.ok(Opcode::Sap, 4, 2, 777);
    r.ok(Opcode::Stap, 4, 2, 0);
    r.ok(Opcode::Sap, 4, 0, 111); // not stored
    r.restart();
    assert_eq!((r.gap(4, 0), r.gap(4, 2), r.gap(4, 5), r.gap(4, 3)), (1000, 777, 1234, 1000));
}

/// The ports odemis' TMCL driver uses beyond pytrinamic's `IO`: GIO 8, 1 is the supply voltage in 0.1 V
/// (the minimal board measures none: the nominal 24.0 V), SIO 0, 0 the switches' pull-ups (0..3), which
/// GIO does not read back: GIO 0, 0 is input IN0.
#[test]
fn odemis_ports() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    assert_eq!(r.ok(Opcode::Gio, 8, 1, 0), 240);
    assert_eq!(r.ok(Opcode::Sio, 0, 0, 3), 3);
    r.module.board_mut().inputs = 0b1;
    assert_eq!(r.ok(Opcode::Gio, 0, 0, 0), 1, "GIO 0, 0 reads IN0");
    assert_eq!(r.cmd(Opcode::Sio, 0, 0, 4).0, Status::InvalidValue, "two bits");
    assert_eq!(r.cmd(Opcode::Sio, 1, 0, 1).0, Status::WrongType, "no other port of bank 0 is set");
    assert_eq!(r.cmd(Opcode::Sio, 0, 1, 1).0, Status::InvalidValue, "bank 1 is read only");
    // The outputs of bank 2 as before.
    assert_eq!(r.ok(Opcode::Sio, 7, 2, 1), 1);
    assert_eq!(r.ok(Opcode::Gio, 7, 2, 0), 1);
}

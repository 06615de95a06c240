//! The TMCM-1140 model (`tmcl_core::model::tmcm_1140`) on a minimal board: frames byte for byte in the
//! binary format of the TMCM-1140 TMCL firmware manual V1.27 (§3.1 command, §3.2 reply), its version
//! replies (command 136: the string and the binary form with the module number in the high word), the
//! TMC429's units (TMCM-1140 hardware manual §8.1: 16 MHz · v / (2^pulse_div · 2048 · 32)) and 24-bit
//! positions, the USB port that answers every address and the same module on RS485, which does not.

use std::vec::Vec;
use tmcl_core::model::{tmcm_1140, ModelSpec, Role};
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::{Instruction, Opcode, Reply, ReplyFrame, Request, Status};

mod support;
use support::Board;

struct Rig {
    module: Module<Board>,
    now: Instant,
}

impl Rig {
    fn of(spec: &'static ModelSpec) -> Rig {
        let now = Instant::from_secs(1);
        Rig { module: Module::new(Board::new(spec, 1024), spec, now), now }
    }

    fn new() -> Rig {
        Rig::of(&tmcm_1140::SPEC)
    }

    /// Raw bytes on the primary interface: everything the module sends back.
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

    fn gap(&mut self, n: u8) -> i32 {
        self.ok(Opcode::Gap, n, 0, 0)
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

/// The reply `host 2, module 1, status, command, value` with its checksum (§3.2).
fn reply(status: u8, op: u8, value: i32) -> [u8; 9] {
    let mut r = [2, 1, status, op, 0, 0, 0, 0, 0];
    r[4..8].copy_from_slice(&value.to_be_bytes());
    r[8] = tmcl_wire::checksum(&r[..8]);
    r
}

#[test]
fn frames_byte_for_byte() {
    let mut r = Rig::new();
    // ROR 0, 1000: 01 01 00 00 00 00 03 E8, checksum ED; the reply echoes the value.
    assert_eq!(
        r.bytes(&[0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x03, 0xE8, 0xED]),
        [0x02, 0x01, 0x64, 0x01, 0x00, 0x00, 0x03, 0xE8, 0x53]
    );
    // MST 0.
    assert_eq!(r.bytes(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04]), reply(100, 3, 0));
    // GAP 4, 0: the maximum positioning speed at the start, 1000 TMC429 units.
    assert_eq!(
        r.bytes(&[0x01, 0x06, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0B]),
        [0x02, 0x01, 0x64, 0x06, 0x00, 0x00, 0x03, 0xE8, 0x58]
    );
    // SAP 140, 0, 4: 16 microsteps.
    assert_eq!(r.bytes(&[0x01, 0x05, 0x8C, 0x00, 0x00, 0x00, 0x00, 0x04, 0x96]), reply(100, 5, 4));
    // A wrong checksum: status 1.
    assert_eq!(r.bytes(&[0x01, 0x06, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0C]), reply(1, 0, 0));
    // 136 type 0: the host address and eight characters, no checksum.
    assert_eq!(r.bytes(&[0x01, 0x88, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x89]), *b"\x021140V127");
    // 136 type 1: module number 1140 (0x0474) in the high word, then 1 and 27 (0x1B).
    assert_eq!(
        r.bytes(&[0x01, 0x88, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x8A]),
        [0x02, 0x01, 0x64, 0x88, 0x04, 0x74, 0x01, 0x1B, 0x83]
    );
}

/// The TMC429's units: at the start values (pulse divisor 2, ramp divisor 3) `ROR 0, 1000` turns at
/// 16 MHz · 1000 / (4 · 2048 · 32) = 61 035 microsteps/s, reached within 8.2 ms (a = 500 is
/// 16 MHz² · 500 / 2^34 = 7 450 580 microsteps/s²); AP 2 and AP 3 read in units.
#[test]
fn tmc429_units() {
    let mut r = Rig::new();
    assert_eq!((r.gap(153), r.gap(154), r.gap(140)), (3, 2, 8), "divisors and 256 microsteps at the start");
    r.ok(Opcode::Ror, 0, 0, 1000);
    r.run(Duration::from_millis(1000));
    assert_eq!((r.gap(2), r.gap(3)), (1000, 1000));
    let p = r.gap(1);
    assert!((60_700..=61_035).contains(&p), "after 1 s: {p}");
    // Pulse divisor 4: a quarter of the speed, the units unchanged.
    r.ok(Opcode::Sap, 154, 0, 4);
    r.ok(Opcode::Sap, 1, 0, 0);
    r.run(Duration::from_millis(1000));
    let p = r.gap(1);
    assert!((15_200..=15_259).contains(&p), "after 1 s at pulse divisor 4: {p}");
    assert_eq!(r.gap(3), 1000);
    // Velocities are 0..2047: 2048 is an invalid value.
    assert_eq!(r.cmd(Opcode::Sap, 4, 0, 2048).0, Status::InvalidValue);
    assert_eq!(r.cmd(Opcode::Ror, 0, 0, 2048).0, Status::InvalidValue);
}

#[test]
fn positions_are_24_bit() {
    let mut r = Rig::new();
    assert_eq!(r.ok(Opcode::Mvp, 0, 0, (1 << 23) - 1), (1 << 23) - 1);
    assert_eq!(r.cmd(Opcode::Mvp, 0, 0, 1 << 23).0, Status::InvalidValue);
    assert_eq!(r.cmd(Opcode::Sap, 1, 0, -(1 << 23) - 1).0, Status::InvalidValue);
}

#[test]
fn what_the_model_does_not_have() {
    let mut r = Rig::new();
    // AP 135 (the TMC429's actual acceleration) and the external encoder AP 216–218: not provided.
    for n in [135, 216, 217, 218] {
        assert_eq!(r.cmd(Opcode::Gap, n, 0, 0).0, Status::WrongType, "AP {n}");
    }
    // One motor: motor 1 is an invalid value.
    assert_eq!(r.cmd(Opcode::Gap, 1, 1, 0).0, Status::InvalidValue);
    // SAC is not a command of this generation.
    assert_eq!(r.cmd(Opcode::Sac, 0, 4, 0).0, Status::InvalidCommand);
    // The roles the TMC262 and the encoder bring are there.
    for role in [Role::LoadValue, Role::ActualCurrent, Role::EncoderPosition, Role::EncoderAbsolute] {
        assert!(tmcm_1140::SPEC.axis.role(role).is_some(), "{role:?}");
    }
}

/// On USB every address byte is answered, with the module's own address in the reply; on RS485 only
/// the module's address (GP 66) is.
#[test]
fn usb_answers_every_address_rs485_its_own() {
    let frame = Request { address: 7, instruction: Instruction::new(Opcode::Gap, 4, 0, 0) }.to_bytes();
    let mut usb = Rig::new();
    assert_eq!(usb.bytes(&frame), reply(100, 6, 1000));
    let mut rs485 = Rig::of(&tmcm_1140::SPEC_RS485);
    assert!(rs485.bytes(&frame).is_empty(), "not its address");
    assert_eq!(rs485.gap(4), 1000);
}

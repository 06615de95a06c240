//! The PDx-113 model (`tmcl_core::model::pd_113`) on a minimal board: the manual's 22 frame examples
//! (PDx-113-57/60-SE TMCL firmware manual V1.04, §5.7.1–5.7.17) byte for byte, its ASCII example
//! (§5.6.2), the commands it lacks (§5.4, §5.5), 135 without types (§5.5), the global banks (§5.7.9),
//! 24-bit positions (§5.7.4), the TMC428 units for every pulse divisor and the ramp's durations, and SAC
//! (§5.4.3) to the emulated TMC428.

use std::vec::Vec;
use tmcl_core::model::{pd_113, Kinematics, ModelSpec};
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::tmc428::{status, Answer, Datagram};
use tmcl_wire::{Instruction, Opcode, Reply, ReplyFrame, Request, Status};

const SPEC: &ModelSpec = &pd_113::SPEC;
const TMC428: Kinematics = Kinematics::Tmc428 { clock_hz: 16_000_000 };

mod support;
use support::Board;

struct Rig {
    module: Module<Board>,
    now: Instant,
}

impl Rig {
    fn new() -> Rig {
        let now = Instant::from_secs(1);
        Rig { module: Module::new(Board::new(SPEC, 256), SPEC, now), now }
    }

    /// Raw bytes on the serial port: everything the module sends back (after the telegram pause).
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

    fn cmd(&mut self, op: u8, t: u8, m: u8, v: i32) -> (Status, i32) {
        let frame = Request { address: 1, instruction: Instruction::new(Opcode::from(op), t, m, v) }.to_bytes();
        let out = self.bytes(&frame);
        let r = Reply::parse(&ReplyFrame::new_checked(&out[..]).expect("a 9-byte reply")).expect("checksum");
        (r.status, r.value)
    }

    fn ok(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> i32 {
        let (s, v) = self.cmd(op.code(), t, m, v);
        assert_eq!(s, Status::Ok, "{op:?} {t}, {m}");
        v
    }

    fn gap(&mut self, n: u8) -> i32 {
        self.ok(Opcode::Gap, n, 0, 0)
    }

    fn sap(&mut self, n: u8, v: i32) {
        self.ok(Opcode::Sap, n, 0, v);
    }

    fn text(&mut self, line: &str) -> String {
        String::from_utf8(self.bytes(line.as_bytes())).unwrap()
    }

    /// SAC 0, 4, `datagram`: the TMC428's answer.
    fn sac(&mut self, datagram: Datagram) -> Answer {
        Answer::parse(self.ok(Opcode::Sac, 0, 4, datagram.emit() as i32) as u32)
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

    /// Runs until AP 8 (target reached) reads 1, in 1 ms steps: the time it took.
    fn run_until_reached(&mut self, limit: Duration) -> Duration {
        let start = self.now;
        while self.gap(8) == 0 {
            assert!(self.now - start < limit, "not reached within {limit:?}");
            self.run(Duration::from_millis(1));
        }
        self.now - start
    }
}

/// The reply `host 2, module 1, status, command, value` with its checksum.
fn reply(status: u8, op: u8, value: i32) -> [u8; 9] {
    let mut r = [2, 1, status, op, 0, 0, 0, 0, 0];
    r[4..8].copy_from_slice(&value.to_be_bytes());
    r[8] = tmcl_wire::checksum(&r[..8]);
    r
}

// ---- the manual's 22 frame examples (§5.7.1–5.7.17) ------------------------------------------------

/// Each request exactly as printed, and the reply (printed where the manual prints one: GAP, GGP, GIO;
/// otherwise status 100 with the value the firmware echoes, "don't care" in the manual).
#[test]
fn the_manuals_frames_byte_for_byte() {
    let mut r = Rig::new();
    // §5.7.1 ROR 0, 350: printed `01 01 00 02 00 00 01 5E 61`, motor byte 02, but the checksum 61 is that
    // of motor 00 (with 02 it would be 63). As printed the frame fails its checksum: status 1, command 0.
    assert_eq!(r.bytes(&[0x01, 0x01, 0x00, 0x02, 0x00, 0x00, 0x01, 0x5E, 0x61]), reply(1, 0, 0));
    // The erratum decided: the motor byte is 00, as the mnemonic says.
    assert_eq!(r.bytes(&[0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0x5E, 0x61]), reply(100, 1, 350));
    // §5.7.2 ROL 0, 1200.
    assert_eq!(r.bytes(&[0x01, 0x02, 0x00, 0x00, 0x00, 0x00, 0x04, 0xB0, 0xB7]), reply(100, 2, 1200));
    // §5.7.3 MST 0.
    assert_eq!(r.bytes(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04]), reply(100, 3, 0));
    // §5.7.4 MVP ABS, 0, 9000; MVP REL, 0, -1000; MVP COORD, 0, 8.
    assert_eq!(r.bytes(&[0x01, 0x04, 0x00, 0x00, 0x00, 0x00, 0x23, 0x28, 0x50]), reply(100, 4, 9000));
    assert_eq!(r.bytes(&[0x01, 0x04, 0x01, 0x00, 0xFF, 0xFF, 0xFC, 0x18, 0x18]), reply(100, 4, -1000));
    assert_eq!(r.bytes(&[0x01, 0x04, 0x02, 0x00, 0x00, 0x00, 0x00, 0x08, 0x0F]), reply(100, 4, 8));
    // §5.7.5 SAP 6, 0, 182 (2 A RMS).
    assert_eq!(r.bytes(&[0x01, 0x05, 0x06, 0x00, 0x00, 0x00, 0x00, 0xB6, 0xC2]), reply(100, 5, 182));
    // §5.7.6 "GAP 0, 1": the bytes are GAP 1, 0 (actual position), the reply value 711.
    r.ok(Opcode::Mst, 0, 0, 0);
    r.run(Duration::from_secs(1));
    r.sap(1, 711);
    assert_eq!(
        r.bytes(&[0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08]),
        [0x02, 0x01, 0x64, 0x06, 0x00, 0x00, 0x02, 0xC7, 0x36]
    );
    // §5.7.7 STAP 4, 0; §5.7.8 RSAP 6, 0.
    assert_eq!(r.bytes(&[0x01, 0x07, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0C]), reply(100, 7, 0));
    assert_eq!(r.bytes(&[0x01, 0x08, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0F]), reply(100, 8, 0));
    // §5.7.10 GGP 66, 0: address 1.
    assert_eq!(
        r.bytes(&[0x01, 0x0A, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x4D]),
        [0x02, 0x01, 0x64, 0x0A, 0x00, 0x00, 0x00, 0x01, 0x72]
    );
    // §5.7.11 STGP 66, 0: the manual's example stores a global parameter although it calls STGP "user
    // variables only"; bank 0 parameters that are stored anyway may be stored again.
    assert_eq!(r.bytes(&[0x01, 0x0B, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x4E]), reply(100, 11, 0));
    // §5.7.12 RSGP 42, 2 (printed "RSAP" in the mnemonic line; the example is RSGP).
    assert_eq!(r.bytes(&[0x01, 0x0C, 0x2A, 0x02, 0x00, 0x00, 0x00, 0x00, 0x39]), reply(100, 12, 0));
    // §5.7.13 RFS START, 0.
    assert_eq!(r.bytes(&[0x01, 0x0D, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0E]), reply(100, 13, 0));
    r.ok(Opcode::Rfs, 1, 0, 0);
    // §5.7.14 SIO 1, 2, 1.
    assert_eq!(r.bytes(&[0x01, 0x0E, 0x01, 0x02, 0x00, 0x00, 0x00, 0x01, 0x13]), reply(100, 14, 1));
    assert_eq!(r.module.board().outputs, 0b10);
    // §5.7.15 "GIO 1, 1": the bytes are GIO 0, 1 (analog IN_0), the reply 506 of 0…1023.
    r.module.board_mut().analog = 506 * 4;
    assert_eq!(
        r.bytes(&[0x01, 0x0F, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x11]),
        [0x02, 0x01, 0x64, 0x0F, 0x00, 0x00, 0x01, 0xFA, 0x71]
    );
    // §5.7.16 CALC MUL, -5000 (direct mode works on the host's accumulator).
    assert_eq!(r.bytes(&[0x01, 0x13, 0x02, 0x00, 0xFF, 0xFF, 0xEC, 0x78, 0x78]), reply(100, 19, -5000));
    // §5.7.17 COMP 1000: "no meaning in direct mode": status 6, as every program-only command.
    assert_eq!(r.bytes(&[0x01, 0x14, 0x00, 0x00, 0x00, 0x00, 0x03, 0xE8, 0x00]), reply(6, 20, 1000));
    // §5.7.9 SGP 66, 0, 3: the module takes address 3 and answers from it.
    assert_eq!(r.bytes(&[0x01, 0x09, 0x42, 0x00, 0x00, 0x00, 0x00, 0x03, 0x4F]), {
        let mut a = reply(100, 9, 3);
        a[1] = 3;
        a[8] = tmcl_wire::checksum(&a[..8]);
        a
    });
    assert!(r.bytes(&[0x01, 0x0A, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x4D]).is_empty(), "address 1 is gone");
}

// ---- ASCII (§5.6) ------------------------------------------------------------------------------------

#[test]
fn ascii_reply_with_a_negative_value() {
    let mut r = Rig::new();
    r.sap(1, -5000);
    assert_eq!(r.ok(Opcode::EnterAscii, 0, 0, 0), 0);
    // §5.6.2: "BA 100 -5000" for the actual position -5000 (host 2, module 1). The manual's "AGAP 0, 1"
    // names axis 1, which this one-axis module lacks: status 4; the actual position is AP 1 of motor 0.
    assert_eq!(r.text("AGAP 1, 0\r"), "AGAP 1, 0\rBA 100 -5000\r");
    assert_eq!(r.text("AGAP 0, 1\r"), "AGAP 0, 1\rBA 4 0\r");
    // §5.6.3 lists SAC: the type/version register of the TMC429.
    let word = Datagram { ram: false, address: 0x39, read: true, data: 0 }.emit() as i32;
    let expected = format!("ASAC 0, 4, {word}\rBA 100 {}\r", (0x1500_0000u32 | 0x42_9101) as i32);
    assert_eq!(r.text(&format!("ASAC 0, 4, {word}\r")), expected);
    // Commands §5.6.3 does not list answer 6.
    assert_eq!(r.text("ACALC ADD, 1\r"), "ACALC ADD, 1\rBA 6 1\r");
    assert_eq!(r.text("ABIN\r"), "ABIN\rBA 100 0\r");
}

// ---- the command set (§5.4, §5.5) -------------------------------------------------------------------

#[test]
fn commands_the_pdx_113_lacks_answer_status_2() {
    let mut r = Rig::new();
    // EI, DI, VECT, RETI, ACO (no interrupts, no ACO), 138, 242 and 255: in no list of the manual.
    for op in [25, 26, 37, 38, 39, 138, 242, 255] {
        assert_eq!(r.cmd(op, 0, 0, 1234).0, Status::InvalidCommand, "command {op}");
    }
    // Unknown numbers too; and nothing changed.
    for op in [0, 16, 17, 18, 40, 140, 254] {
        assert_eq!(r.cmd(op, 0, 0, 0).0, Status::InvalidCommand, "command {op}");
    }
    // In download mode they are refused and not stored.
    r.ok(Opcode::StartDownload, 0, 0, 0);
    assert_eq!(r.cmd(25, 0, 0, 0).0, Status::InvalidCommand);
    assert_eq!(r.cmd(Opcode::Mvp.code(), 0, 0, 100).0, Status::Loaded);
    r.ok(Opcode::QuitDownload, 0, 0, 0);
    let first = r.bytes(&Request { address: 1, instruction: Instruction::new(Opcode::ReadMemory, 0, 0, 0) }.to_bytes());
    assert_eq!(first[1], Opcode::Mvp.code(), "the MVP is the first command in memory");
}

#[test]
fn status_135_has_no_types() {
    let mut r = Rig::new();
    // §5.5: 0 stop, 1 run, 2 step, 3 reset; type, motor/bank and value "don't care".
    for t in [0, 1, 2, 3, 7, 255] {
        assert_eq!(r.ok(Opcode::GetStatus, t, 0, 0), 0, "type {t}");
    }
    r.ok(Opcode::StartDownload, 0, 0, 0);
    assert_eq!(r.cmd(Opcode::Wait.code(), 0, 0, 1_000_000).0, Status::Loaded);
    r.ok(Opcode::QuitDownload, 0, 0, 0);
    r.ok(Opcode::RunApplication, 1, 0, 0);
    r.run(Duration::from_millis(5));
    assert_eq!(r.ok(Opcode::GetStatus, 9, 9, 9), 1, "running");
}

#[test]
fn global_banks_0_1_2_and_no_3() {
    let mut r = Rig::new();
    assert_eq!(r.ok(Opcode::Ggp, 66, 0, 0), 1);
    r.ok(Opcode::Sgp, 42, 2, -7);
    assert_eq!(r.ok(Opcode::Ggp, 42, 2, 0), -7);
    // Bank 1 exists (§5.7.9) but no source names a parameter in it: wrong type (3).
    assert_eq!(r.cmd(Opcode::Ggp.code(), 0, 1, 0).0, Status::WrongType);
    assert_eq!(r.cmd(Opcode::Sgp.code(), 0, 1, 5).0, Status::WrongType);
    // No bank 3 (no interrupts): invalid value (4), as any bank the module lacks.
    for op in [Opcode::Ggp, Opcode::Sgp, Opcode::Stgp, Opcode::Rsgp] {
        assert_eq!(r.cmd(op.code(), 0, 3, 0).0, Status::InvalidValue, "{op:?}");
        assert_eq!(r.cmd(op.code(), 0, 4, 0).0, Status::InvalidValue, "{op:?}");
    }
    // The ranges of the TMC428 generation: 0…2047, divisors 0…13, 16 microsteps at most.
    for (n, bad) in [(4, 2048), (5, -1), (154, 14), (153, 14), (140, 5), (193, 4), (138, 3)] {
        let before = r.gap(n);
        assert_eq!(r.cmd(Opcode::Sap.code(), n, 0, bad).0, Status::InvalidValue, "AP {n} = {bad}");
        assert_eq!(r.gap(n), before, "AP {n} unchanged");
    }
    // Parameters the sources do not give for this module: wrong type.
    for n in [128, 135, 206, 208, 210] {
        assert_eq!(r.cmd(Opcode::Gap.code(), n, 0, 0).0, Status::WrongType, "AP {n}");
    }
}

#[test]
fn version() {
    let mut r = Rig::new();
    let raw = r.bytes(&Request { address: 1, instruction: Instruction::new(Opcode::GetVersion, 0, 0, 0) }.to_bytes());
    assert_eq!(&raw[..], b"\x02113V1.04");
    assert_eq!(r.ok(Opcode::GetVersion, 1, 0, 0), 0x010D_0104);
}

// ---- 24-bit positions (§5.7.4) ----------------------------------------------------------------------

#[test]
fn positions_wrap_at_24_bits() {
    let mut r = Rig::new();
    // MVP ABS outside −2^23 … 2^23 − 1, and an MVP REL that leaves it: status 4, nothing moves.
    assert_eq!(r.cmd(Opcode::Mvp.code(), 0, 0, 1 << 23).0, Status::InvalidValue);
    assert_eq!(r.cmd(Opcode::Mvp.code(), 0, 0, -(1 << 23) - 1).0, Status::InvalidValue);
    r.sap(1, 8_388_000);
    assert_eq!(r.cmd(Opcode::Mvp.code(), 1, 0, 1000).0, Status::InvalidValue);
    assert_eq!(r.gap(0), 8_388_000, "the target followed the counter, nothing else");
    assert_eq!(r.cmd(Opcode::Sap.code(), 1, 0, 1 << 23).0, Status::InvalidValue);
    // Turning right past 2^23 − 1 the counter wraps to −2^23.
    r.ok(Opcode::Ror, 0, 0, 100); // 3051 µsteps/s at pulse divisor 3
    r.run(Duration::from_secs(1));
    let p = r.gap(1);
    assert!((-(1 << 23)..-(1 << 23) + 3000).contains(&p), "wrapped: {p}");
    r.ok(Opcode::Mst, 0, 0, 0);
    r.run(Duration::from_secs(1));
    // "the distance … should not be more than 8388607 microsteps. Otherwise the motor will run in the
    // wrong direction for taking a shorter way": from near −2^23 to +8 000 000 it turns left, across the
    // wrap.
    r.sap(1, -8_000_000);
    r.ok(Opcode::Mvp, 0, 0, 8_000_000);
    r.run(Duration::from_millis(200));
    assert!(r.gap(3) < 0, "left, the shorter way: {}", r.gap(3));
    r.run_until_reached(Duration::from_secs(60));
    assert_eq!(r.gap(1), 8_000_000);
}

// ---- TMC428 units (TMC428 datasheet; module docs of `tmcl_model::variant`) ---------------------------

/// For every pulse divisor 0–13 at a few velocities the motor turns at 16 MHz · v / (2^pd · 2048 · 32)
/// microsteps per second, within the ramp's whole microsteps per second.
#[test]
fn velocity_units_for_every_pulse_divisor() {
    let mut r = Rig::new();
    r.sap(153, 0); // ramp divisor 0, a = 2047: the fastest ramp at every pulse divisor
    r.sap(5, 2047);
    r.sap(130, 0);
    for pd in 0..=13 {
        r.sap(154, pd);
        for v in [1, 100, 1000, 2047] {
            let pps = 16_000_000.0 * f64::from(v) / f64::from(1u32 << (pd + 16));
            r.ok(Opcode::Ror, 0, 0, v);
            r.run(Duration::from_secs(2)); // at speed long before (≥ 119 µsteps/s² for 61 µsteps/s)
            let from = r.module.board().steps(4);
            r.run(Duration::from_secs(2));
            let measured = (r.module.board().steps(4) - from) as f64 / 2.0;
            assert!((measured - pps).abs() <= 1.5, "pd {pd} v {v}: {measured} µsteps/s, formula {pps}");
            if pd <= 7 {
                assert_eq!(r.gap(3), v, "pd {pd}: AP 3 reads the velocity back");
            }
            assert_eq!(r.gap(2), if pd <= 7 { v } else { r.gap(2) }, "AP 2");
            r.ok(Opcode::Mst, 0, 0, 0);
            r.run(Duration::from_secs(1));
        }
    }
}

/// A move's duration in ramp mode is the TMC428's trapezoid: accelerate with a (µsteps/s²) to v, run,
/// decelerate, or a triangle when the distance is short: d/v + v/a, or 2·sqrt(d/a).
#[test]
fn move_durations_follow_the_tmc428_ramp() {
    let mut r = Rig::new();
    r.sap(130, 0);
    for (pd, rd, vmax, amax, distance) in [
        (3, 7, 1000, 500, 150_000), // the start values and §4.2's move
        (3, 7, 1000, 500, 2_000),   // a triangle
        (2, 4, 2047, 100, 400_000),
        (5, 9, 300, 2047, 20_000),
        (0, 3, 800, 1000, 1_000_000),
        (6, 6, 2047, 50, 30_000),
    ] {
        r.sap(154, pd);
        r.sap(153, rd);
        r.sap(4, vmax);
        r.sap(5, amax);
        r.sap(1, 0);
        let v = f64::from(TMC428.velocity_to_pps(vmax, pd));
        let a = 16e6 * 16e6 * f64::from(amax) / f64::from(1u32 << (pd + rd)) / f64::from(1u32 << 29);
        let d = f64::from(distance);
        let expected = if d >= v * v / a { d / v + v / a } else { 2.0 * (d / a).sqrt() };
        r.ok(Opcode::Mvp, 0, 0, distance);
        let took = r.run_until_reached(Duration::from_secs(120)).micros() as f64 / 1e6;
        assert!(
            (took - expected).abs() <= expected * 0.005 + 0.003,
            "pd {pd} rd {rd} v {vmax} a {amax} d {distance}: {took} s, TMC428 ramp {expected} s"
        );
        assert_eq!(r.gap(1), distance);
    }
}

#[test]
fn sixteen_microsteps() {
    let mut r = Rig::new();
    assert_eq!(r.gap(140), 4, "16 microsteps at the start (§2)");
    r.ok(Opcode::Mvp, 0, 0, 3200); // one revolution of a 200-step motor at 16 microsteps
    r.run_until_reached(Duration::from_secs(10));
    assert_eq!(r.module.board().physical, support::PHYSICAL_PER_REV);
    // The sensOstep reads 0…255 per revolution (AP 209): a whole turn later, 0 again.
    assert_eq!(r.gap(209), 0);
    r.ok(Opcode::Mvp, 0, 0, 3200 + 800);
    r.run_until_reached(Duration::from_secs(10));
    assert_eq!(r.gap(209), 64, "a quarter turn");
}

// ---- SAC (§5.4.3) and the TMC428 registers -------------------------------------------------------------

fn write(smda: u8, idx: u8, data: u32) -> Datagram {
    Datagram { ram: false, address: (smda << 4) | idx, read: false, data }
}

fn read(smda: u8, idx: u8) -> Datagram {
    Datagram { ram: false, address: (smda << 4) | idx, read: true, data: 0 }
}

#[test]
fn sac_round_trips() {
    let mut r = Rig::new();
    let at_targets = status::XEQT1 | status::XEQT2 | status::XEQT3;
    // The TMC429's type and version; at power-up every motor is at its target.
    assert_eq!(r.sac(read(3, 9)), Answer { status: at_targets, data: 0x42_9101 });
    // A write answers the status bits and 0.
    assert_eq!(r.sac(write(0, 3, 1500)), Answer { status: at_targets, data: 0 });
    assert_eq!(r.gap(4), 1500, "v_max is AP 4");
    assert_eq!(r.sac(read(0, 3)).data, 1500);
    r.sap(5, 300);
    assert_eq!(r.sac(read(0, 6)).data, 300, "a_max is AP 5");
    // pulse_div, ramp_div, usrs = AP 154, 153, 140.
    assert_eq!(r.sac(read(0, 12)).data, (3 << 12) | (7 << 8) | 4);
    r.sac(write(0, 12, (2 << 12) | (5 << 8) | 3));
    assert_eq!((r.gap(154), r.gap(153), r.gap(140)), (2, 5, 3));
    // usrs 5 (32 microsteps) is more than the board has: status 4, nothing changed.
    let bad = write(0, 12, (1 << 12) | (1 << 8) | 5).emit() as i32;
    assert_eq!(r.cmd(Opcode::Sac.code(), 0, 4, bad).0, Status::InvalidValue);
    assert_eq!((r.gap(154), r.gap(153), r.gap(140)), (2, 5, 3));
    r.sac(write(0, 12, (3 << 12) | (7 << 8) | 4));
    // pmul/pdiv follow a_max and the divisors as the firmware computes them (a_max 300, pulse_div 3,
    // ramp_div 7: p_reduced 0.145, · 8 · 2^7 = 148.5: pmul 148, pdiv 7); a value a host writes stands
    // until one of them changes.
    assert_eq!(r.sac(read(0, 9)).data, (148 << 8) | 7);
    r.sac(write(0, 9, (200 << 8) | 5));
    assert_eq!(r.sac(read(0, 9)).data, (200 << 8) | 5);
    r.sap(5, 1000);
    assert_eq!(r.sac(read(0, 9)).data, (247 << 8) | 6);
    r.sap(5, 300);
    // x_target: a move in ramp mode; x_actual and v_actual follow the motor.
    r.sac(write(0, 0, 20_000));
    assert_eq!(r.gap(0), 20_000);
    r.run(Duration::from_millis(100));
    let moving = r.sac(read(0, 1));
    assert_eq!(moving.status & status::XEQT1, 0, "on its way");
    assert_eq!(moving.data as i32, r.gap(1));
    assert_eq!(r.sac(read(0, 5)).data as i32, r.gap(3));
    r.run_until_reached(Duration::from_secs(10));
    assert_eq!(r.sac(read(0, 1)), Answer { status: at_targets, data: 20_000 });
    // A negative x_actual reads back in 24 bits.
    r.sac(write(0, 1, 0xFF_FFFF & (-5i32) as u32));
    assert_eq!(r.gap(1), -5);
    assert_eq!(r.sac(read(0, 1)).data, 0xFF_FFFB);
    // v_target in velocity mode (ramp mode 2): the motor turns; v_actual 0 stops it at once.
    r.sac(write(0, 10, 2));
    assert_eq!(r.gap(138), 2);
    r.sac(write(0, 4, 0xFFF & (-200i32) as u32));
    r.run(Duration::from_secs(1));
    assert_eq!(r.gap(3), -200);
    assert_eq!(r.sac(read(0, 4)).data, 0xFFF & (-200i32) as u32);
    r.sac(write(0, 4, 0));
    r.sac(write(0, 5, 0));
    assert_eq!(r.gap(3), 0, "hard stop");
    // Ramp mode 3 (hold) is not one the firmware uses: status 4.
    assert_eq!(r.cmd(Opcode::Sac.code(), 0, 4, write(0, 10, 3).emit() as i32).0, Status::InvalidValue);
    // ref_conf: DISABLE_STOP_L / _R are AP 13 / AP 12.
    r.sac(write(0, 10, (1 << 8) | (1 << 9)));
    assert_eq!((r.gap(13), r.gap(12), r.gap(138)), (1, 1, 0));
    // Motor 2 (SMDA 1) has no motor on this board: its registers are kept; xEQt2 follows them.
    r.sac(write(1, 0, 1234));
    let a = r.sac(read(1, 0));
    assert_eq!((a.data, a.status & status::XEQT2), (1234, 0));
    r.sac(write(1, 1, 1234));
    assert_eq!(r.sac(read(1, 1)).status & status::XEQT2, status::XEQT2);
    // The RAM (RRS = 1): two 6-bit entries per address.
    r.sac(Datagram { ram: true, address: 0x21, read: false, data: 0x3F15 });
    assert_eq!(r.sac(Datagram { ram: true, address: 0x21, read: true, data: 0 }).data, 0x3F15);
    // Another bus is wrong type, another length invalid value; nothing changes.
    assert_eq!(r.cmd(Opcode::Sac.code(), 1, 4, write(0, 3, 5).emit() as i32).0, Status::WrongType);
    assert_eq!(r.cmd(Opcode::Sac.code(), 0, 3, write(0, 3, 5).emit() as i32).0, Status::InvalidValue);
    assert_eq!(r.gap(4), 1500);
}

#[test]
fn sac_on_a_model_without_a_tmc428_is_not_a_command() {
    // The PD28-1021 and the TMCM-1310 do not list SAC: status 2 (their tests); here the model lists it.
    let mut r = Rig::new();
    assert_eq!(r.cmd(Opcode::Sac.code(), 0, 4, 0x7300_0000).0, Status::Ok);
}

/// SAC in a program: the value read goes into the accumulator, like every command that reads.
#[test]
fn a_manual_program_runs() {
    let mut r = Rig::new();
    // §4.2's program: SAP 4, 0, 1000; Loop: MVP ABS, 0, 150000; WAIT POS; WAIT TICKS 200; MVP ABS 0;
    // WAIT POS; WAIT TICKS 100; JA Loop.
    let program = [
        Instruction::new(Opcode::Sap, 4, 0, 1000),
        Instruction::new(Opcode::Mvp, 0, 0, 150_000),
        Instruction::new(Opcode::Wait, 1, 0, 0),
        Instruction::new(Opcode::Wait, 0, 0, 200),
        Instruction::new(Opcode::Mvp, 0, 0, 0),
        Instruction::new(Opcode::Wait, 1, 0, 0),
        Instruction::new(Opcode::Wait, 0, 0, 100),
        Instruction::new(Opcode::Ja, 0, 0, 1),
    ];
    r.ok(Opcode::StartDownload, 0, 0, 0);
    for i in program {
        assert_eq!(r.cmd(i.opcode.code(), i.kind, i.motor, i.value).0, Status::Loaded, "{i:?}");
    }
    r.ok(Opcode::QuitDownload, 0, 0, 0);
    r.ok(Opcode::RunApplication, 1, 0, 0);
    // 150000 µsteps at 30 518 µsteps/s with 232 831 µsteps/s²: 5.05 s.
    r.run(Duration::from_millis(5000));
    assert!(r.gap(1) > 145_000 && r.gap(8) == 0);
    r.run(Duration::from_millis(200));
    assert_eq!(r.gap(1), 150_000);
    assert_eq!(r.ok(Opcode::GetStatus, 0, 0, 0), 1);
}

/// The pulse divisor changed while the motor turns (SAP 154 3 → 6 during ROR 1000): on the TMC428 the
/// velocity registers hold their values in units and the divisor only scales the clock they count in
/// (TMC428 datasheet's velocity formula; PDx-113 manual §6), so AP 2 and AP 3 still read 1000, SAC's
/// read of v_actual agrees with AP 3, and the motor turns at 16 MHz · 1000 / (2^6 · 2^16) = 3814.7
/// µsteps/s. Before, the ramp kept 30 518 µsteps/s and AP 2/AP 3 read 8000, outside ±2047.
#[test]
fn the_pulse_divisor_scales_the_clock_under_a_turning_motor() {
    let mut r = Rig::new();
    r.sap(154, 3);
    r.ok(Opcode::Ror, 0, 0, 1000);
    r.run(Duration::from_secs(3));
    assert_eq!((r.gap(2), r.gap(3)), (1000, 1000));
    r.sap(154, 6);
    assert_eq!((r.gap(2), r.gap(3)), (1000, 1000), "AP 2, AP 3 in units after the change");
    assert_eq!(r.sac(read(0, 4)).data, 1000, "v_target");
    assert_eq!(r.sac(read(0, 5)).data, 1000, "v_actual agrees with AP 3");
    let from = r.module.board().steps(4);
    r.run(Duration::from_secs(2));
    let measured = (r.module.board().steps(4) - from) as f64 / 2.0;
    let formula = 16e6 * 1000.0 / f64::from(1u32 << (6 + 16));
    assert!((measured - formula).abs() <= 1.5, "{measured} µsteps/s, the TMC428 formula {formula}");
    assert_eq!((r.gap(2), r.gap(3)), (1000, 1000));
    // Back to 3: the same 1000 units, eight times as fast again; MST stops from there.
    r.sap(154, 3);
    assert_eq!(r.gap(3), 1000);
    r.ok(Opcode::Mst, 0, 0, 0);
    r.run(Duration::from_secs(3));
    assert_eq!((r.gap(2), r.gap(3)), (0, 0));
}

/// AP 2 during a positioning move (PDx-113 manual V1.10 p. 25: in position mode the hardware sets the
/// target speed, v_max while accelerating, 0 when decelerating or at rest): 1000 (AP 4) from the start
/// until the ramp begins to brake, then 0; −1000 on the way back. Before, it read 0 all along.
#[test]
fn ap_2_follows_the_ramp_in_position_mode() {
    let mut r = Rig::new();
    r.sap(154, 3);
    r.sap(153, 7);
    r.sap(4, 1000);
    r.sap(5, 500);
    for (target, sign) in [(150_000, 1), (0, -1)] {
        r.ok(Opcode::Mvp, 0, 0, target);
        let (mut peak, mut braking, mut accelerating) = (0, false, 0);
        while r.gap(8) == 0 {
            r.run(Duration::from_millis(5));
            let (v2, v3) = (r.gap(2), r.gap(3));
            if r.gap(8) == 1 {
                break;
            }
            if v3.abs() < peak {
                braking = true;
            }
            peak = peak.max(v3.abs());
            if braking {
                assert_eq!(v2, 0, "decelerating at {v3}");
            } else {
                assert_eq!(v2, sign * 1000, "accelerating or at top speed at {v3}");
                accelerating += 1;
            }
        }
        assert!(braking && accelerating > 10, "both phases seen");
        assert_eq!(peak, 1000);
        assert_eq!((r.gap(2), r.gap(3)), (0, 0), "at rest");
        assert_eq!(r.sac(read(0, 4)).data, 0, "v_target at rest");
    }
    // Velocity mode reads the velocity written again.
    r.ok(Opcode::Ror, 0, 0, 300);
    assert_eq!(r.gap(2), 300);
}

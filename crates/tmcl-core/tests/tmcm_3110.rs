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

impl Rig {
    /// Runs in steps of 1 ms until every motor of `mask` has reached its target (AP 8), at most
    /// `limit`; returns each one's arrival time since the start, in ms (`u32::MAX` for one not in the mask).
    fn arrivals(&mut self, mask: u8, limit: Duration) -> Vec<u32> {
        let motors = self.spec.motors;
        let mut at = vec![u32::MAX; usize::from(motors)];
        let mut ms = 0;
        while at.iter().enumerate().any(|(m, t)| mask & (1 << m) != 0 && *t == u32::MAX) {
            assert!(Duration::from_millis(u64::from(ms)) < limit, "not all arrived: {at:?}");
            self.run(Duration::from_millis(1));
            ms += 1;
            for m in 0..motors {
                if mask & (1 << m) != 0 && at[usize::from(m)] == u32::MAX && self.gap(8, m) == 1 {
                    at[usize::from(m)] = ms;
                }
            }
        }
        at
    }
}

/// MVP COORD with a motor mask, interpolated (bit 6; TMCM-3110/6110 manuals, MVP): the manual's form as
/// bytes, `MVP COORD, $47, 1` = 01 04 02 47 00 00 00 01, checksum 4F; the reply carries the coordinate
/// number. The three motors start and arrive together, on a straight line between the two points (their
/// positions in proportion all the way), none faster than its own AP 4; AP 4 and 5 read as set.
#[test]
fn mvp_coord_interpolated_moves_on_a_straight_line() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    let to = [60_000, -20_000, 5_000];
    for (m, p) in to.iter().enumerate() {
        r.ok(Opcode::Sco, 1, m as u8, *p);
    }
    r.ok(Opcode::Sap, 4, 1, 300); // motor 1 the slow one: the whole move at its pace
    assert_eq!(r.bytes(&[0x01, 0x04, 0x02, 0x47, 0x00, 0x00, 0x00, 0x01, 0x4F]), reply(100, 4, 1));
    // On the way: each position the same fraction of its distance (within 1 %), none over its AP 4.
    let mut samples = 0;
    loop {
        r.run(Duration::from_millis(50));
        let p: Vec<i32> = (0..3).map(|m| r.gap(1, m)).collect();
        if p[0] == to[0] {
            break;
        }
        let f = f64::from(p[0]) / f64::from(to[0]);
        for m in 1..3 {
            let g = f64::from(p[m]) / f64::from(to[m]);
            assert!((f - g).abs() < 0.01, "motor {m} at {g:.4} of its way, motor 0 at {f:.4}");
        }
        assert!(r.gap(3, 1).abs() <= 300, "motor 1 over its AP 4: {}", r.gap(3, 1));
        samples += 1;
    }
    assert!(samples > 10, "the move took {samples} samples");
    assert_eq!((0..3).map(|m| r.gap(1, m)).collect::<Vec<_>>(), to);
    assert_eq!((r.gap(4, 0), r.gap(4, 1), r.gap(4, 2)), (1000, 300, 1000), "AP 4 as set");

    // Back to coordinate 2 (0 for all): arrivals within a few ms of each other.
    for m in 0..3 {
        r.ok(Opcode::Sco, 2, m, 0);
    }
    r.ok(Opcode::Mvp, 2, 0x47, 2);
    let at = r.arrivals(0b111, Duration::from_secs(60));
    let (first, last) = (at.iter().min().unwrap(), at.iter().max().unwrap());
    assert!(last - first <= 3, "arrivals {at:?} ms");
    // A plain MVP afterwards runs at the motor's own speed again.
    r.ok(Opcode::Mvp, 0, 2, 2_000_000);
    r.run(Duration::from_secs(1));
    assert_eq!(r.gap(3, 2), 1000);
}

/// MVP COORD with bit 7 (`$80 | mask`): the motors start together, each at its own speed; the nearest
/// arrives first. The 6110's six motors: `MVP COORD, $BF, 3` = 01 04 02 BF 00 00 00 03, checksum C9.
#[test]
fn mvp_coord_together_each_at_its_own_speed() {
    let mut r = Rig::of(&tmcm_6110::SPEC);
    for m in 0..6u8 {
        r.ok(Opcode::Sco, 3, m, 10_000 * (i32::from(m) + 1));
    }
    assert_eq!(r.bytes(&[0x01, 0x04, 0x02, 0xBF, 0x00, 0x00, 0x00, 0x03, 0xC9]), reply(100, 4, 3));
    let at = r.arrivals(0b11_1111, Duration::from_secs(60));
    assert!(at.windows(2).all(|w| w[0] < w[1]), "the nearest first: {at:?}");
    assert!((0..6).all(|m| r.gap(1, m) == 10_000 * (i32::from(m) + 1)));
    // A mask of some: only those move.
    for m in 0..6u8 {
        r.ok(Opcode::Sco, 4, m, -5_000);
    }
    r.ok(Opcode::Mvp, 2, 0x80 | 0b10_0100, 4);
    r.arrivals(0b10_0100, Duration::from_secs(60));
    let p: Vec<i32> = (0..6).map(|m| r.gap(1, m)).collect();
    assert_eq!(p, [10_000, 20_000, -5_000, 40_000, 50_000, -5_000]);
}

/// Refusals leave every motor as it was, status 4: bits 6 and 7 both, an empty mask, a motor beyond the
/// model's, a coordinate number beyond 20, a coordinate outside the 24-bit position counter on one of the
/// motors. A one-motor model knows no mask (status 4, as any other motor byte).
#[test]
fn mvp_coord_mask_refusals_move_nothing() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    for m in 0..3 {
        r.ok(Opcode::Sco, 1, m, 1000);
    }
    r.ok(Opcode::Sco, 5, 0, 1000);
    r.ok(Opcode::Sco, 5, 1, 1000);
    r.ok(Opcode::Sco, 5, 2, 1 << 24); // beyond the counter
    for (motor, coord) in [(0xC7, 1), (0x40, 1), (0x80, 1), (0x48, 1), (0x87, 21), (0x87, -1), (0x47, 5), (0x87, 5)] {
        assert_eq!(r.cmd(Opcode::Mvp, 2, motor, coord).0, Status::InvalidValue, "MVP COORD, {motor:#x}, {coord}");
    }
    r.run(Duration::from_millis(100));
    assert!((0..3).all(|m| r.gap(1, m) == 0 && r.gap(0, m) == 0 && r.gap(3, m) == 0));
    // The TMCM-1140 (one motor): $41 is not a motor.
    let mut one = Rig::of(&tmcl_core::model::tmcm_1140::SPEC);
    assert_eq!(one.cmd(Opcode::Mvp, 2, 0x41, 1).0, Status::InvalidValue);
}

/// The EEPROM keeps each motor's coordinates apart (motor-major): SCO n, 255 stores every motor's
/// coordinate n, GCO 0, 255 brings them all back after a power cycle, and MVP COORD with a mask moves
/// each motor to its own.
#[test]
fn coordinates_per_axis_across_a_power_cycle() {
    let mut r = Rig::of(&tmcm_6110::SPEC);
    for m in 0..6u8 {
        r.ok(Opcode::Sco, 7, m, 1000 * (i32::from(m) + 1));
        r.ok(Opcode::Sco, 8, m, -7 * (i32::from(m) + 1));
    }
    r.ok(Opcode::Sco, 7, 255, 0); // every motor's coordinate 7 to the EEPROM; coordinate 8 stays in RAM
    r.restart();
    // GP 84 = 0 (the start value): the coordinates in RAM start at 0; GCO n, 255 copies them back from the
    // EEPROM (PD28-1021 manual §3.7.25), each motor its own.
    assert!((0..6).all(|m| r.ok(Opcode::Gco, 7, m, 0) == 0));
    r.ok(Opcode::Gco, 0, 255, 0);
    assert_eq!((0..6).map(|m| r.ok(Opcode::Gco, 7, m, 0)).collect::<Vec<_>>(), [1000, 2000, 3000, 4000, 5000, 6000]);
    assert!((0..6).all(|m| r.ok(Opcode::Gco, 8, m, 0) == 0), "coordinate 8 was not stored");
    r.ok(Opcode::Mvp, 2, 0x40 | 0b11_1111, 7);
    r.arrivals(0b11_1111, Duration::from_secs(30));
    assert_eq!((0..6).map(|m| r.gap(1, m)).collect::<Vec<_>>(), [1000, 2000, 3000, 4000, 5000, 6000]);
}

/// VECT from the host (direct mode) on the TMCM-3110/6110 (`ModelDesc::host_vect`), as odemis' TMCL driver
/// sends it before starting its referencing routine: `VECT 41, 95` = 01 25 29 00 00 00 00 5F, checksum AE,
/// sets interrupt 41's vector (IN2's input interrupt) and replies with the address; an interrupt the model
/// lacks is status 3, an address beyond program memory status 4. On the TMCM-1140 VECT stays
/// program-only: status 6.
#[test]
fn vect_from_the_host() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    assert_eq!(r.bytes(&[0x01, 0x25, 0x29, 0x00, 0x00, 0x00, 0x00, 0x5F, 0xAE]), reply(100, 0x25, 95));
    assert_eq!(r.module.vm().vector(41), Some(95));
    assert_eq!(r.cmd(Opcode::Vect, 200, 0, 10).0, Status::WrongType, "no interrupt 200");
    assert_eq!(r.cmd(Opcode::Vect, 41, 0, 2048).0, Status::InvalidValue, "program memory is 0..2047");
    assert_eq!(r.cmd(Opcode::Vect, 41, 0, -1).0, Status::InvalidValue);
    assert_eq!(r.module.vm().vector(41), Some(95), "refusals change nothing");
    let mut one = Rig::of(&tmcl_core::model::tmcm_1140::SPEC);
    assert_eq!(one.cmd(Opcode::Vect, 0, 0, 10).0, Status::NotAvailable);
}

/// The scaled speed of an interpolated move holds for that move only: a new target (SAP 0) on the way, or
/// any other motion command, runs the motor at its own AP 4 again.
#[test]
fn interpolation_ends_with_a_new_target() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    r.ok(Opcode::Sco, 1, 0, 1_000_000);
    r.ok(Opcode::Sco, 1, 2, 100_000); // a tenth of motor 0's way: a tenth of its speed
    r.ok(Opcode::Mvp, 2, 0x45, 1);
    r.run(Duration::from_millis(500));
    assert_eq!((r.gap(3, 0), r.gap(3, 2)), (1000, 100), "motor 2 at a tenth of AP 4");
    r.ok(Opcode::Sap, 0, 2, 2_000_000);
    r.run(Duration::from_millis(500));
    assert_eq!((r.gap(3, 0), r.gap(3, 2)), (1000, 1000), "motor 2's own AP 4 for its new target");
}

/// The pulse divisor (AP 154) of one axis scales that axis's TMC429 clock: its velocity registers keep
/// their values in units (AP 2 and AP 3 read the same after the write, the speed in microsteps per second
/// follows), and the other axes are not touched. (Before the motor became a component of its own, a
/// divisor written on motor 1 kept motor 1's speed in microsteps per second, so its AP 3 jumped.)
#[test]
fn pulse_divisor_keeps_each_axis_velocity_in_units() {
    let mut r = Rig::of(&tmcm_3110::SPEC);
    r.ok(Opcode::Ror, 0, 0, 300);
    r.ok(Opcode::Ror, 0, 1, 300);
    r.run(Duration::from_millis(500));
    assert_eq!((r.gap(3, 0), r.gap(3, 1)), (300, 300), "both turning at 300");
    let divisor = r.gap(154, 1);
    let position = r.gap(1, 1);
    r.ok(Opcode::Sap, 154, 1, divisor + 1);
    assert_eq!((r.gap(2, 1), r.gap(3, 1)), (300, 300), "motor 1's registers keep their units");
    assert_eq!((r.gap(2, 0), r.gap(3, 0), r.gap(154, 0)), (300, 300, divisor), "motor 0 untouched");
    // Half the clock: motor 1 now covers half the distance motor 0 does in the same time.
    let (p0, p1) = (r.gap(1, 0), r.gap(1, 1));
    r.run(Duration::from_millis(1000));
    let (d0, d1) = (r.gap(1, 0) - p0, r.gap(1, 1) - p1);
    assert!(d1 > 0 && (2 * d1 - d0).abs() <= 2, "motor 0 moved {d0}, motor 1 {d1} (from {position})");
}

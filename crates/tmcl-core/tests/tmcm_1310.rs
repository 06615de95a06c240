//! The TMCM-1310 model (`tmcl_core::model::tmcm_1310`) in direct mode and in programs, on a minimal
//! board: USB frames as the TMCM-1310 manual's chapter 4 lays them out, the ASCII interface of §5, the
//! EtherCAT mailbox of §3.5–3.6, status 8 (§3.7) with the password GP 200, the 1024 commands of program
//! memory (§1), the input interrupts 39–46 and the timer example of §6.6, and the commands the TMCM-1310
//! shares with the PD28-1021 answering alike on both.
//!
//! The frames are written out byte for byte: `01 04 00 01 00 00 C3 50 19` is `MVP ABS, 1, 50000` to
//! address 1 with its checksum (§4.1: the 8-bit sum of the other eight bytes).

use std::vec::Vec;
use tmcl_core::model::{pd28_1021, tmcm_1310, ModelSpec};
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::{
    CalcOp, Command, Condition, Instruction, MoveTarget, Opcode, Reply, ReplyFrame, Request, Status, StatusKind,
    WaitCondition,
};

use Command as C;

const SPEC: &ModelSpec = &tmcm_1310::SPEC;
/// The password of GP 200 (`tmcm_1310.rs`'s decision).
const PASSWORD: i32 = 4321;
/// Port 0 is USB (chapter 4), port 1 the EtherCAT mailbox (§3.5).
const USB: usize = 0;
const MAILBOX: usize = 1;

mod support;
use support::Board;

/// A module on the board with a host clock.
struct Rig {
    module: Module<Board>,
    spec: &'static ModelSpec,
    now: Instant,
}

impl Rig {
    fn new() -> Rig {
        Rig::of(SPEC)
    }

    fn of(spec: &'static ModelSpec) -> Rig {
        let now = Instant::from_secs(1);
        Rig { module: Module::new(Board::new(spec, 4096), spec, now), spec, now }
    }

    /// Power off and on: same board (EEPROM), fresh firmware.
    fn power_cycle(&mut self) {
        let board = self.module.board().clone();
        self.module = Module::new(board, self.spec, self.now);
    }

    /// Raw bytes on USB (port 0): everything the module sends back (waiting for a delayed reply, as a host
    /// would; the PD28-1021's RS485 port has a telegram pause, USB none).
    fn bytes(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        self.module.receive_on(USB, self.now, bytes, &mut |b: &[u8]| out.extend_from_slice(b));
        while out.is_empty() {
            let Some(due) = self.module.state().port(USB).and_then(|p| p.outbox.next_due()) else { break };
            self.now = due;
            self.module.poll(self.now, &mut |b: &[u8]| out.extend_from_slice(b));
        }
        out
    }

    /// A request frame to `address`: its parsed reply, if any.
    fn to(&mut self, address: u8, op: Opcode, t: u8, m: u8, v: i32) -> Option<Reply> {
        let frame = Request { address, instruction: Instruction::new(op, t, m, v) }.to_bytes();
        let out = self.bytes(&frame);
        match out.len() {
            0 => None,
            9 => Some(Reply::parse(&ReplyFrame::new_checked(&out[..]).unwrap()).expect("reply checksum")),
            n => panic!("{n} bytes of reply: {out:02X?}"),
        }
    }

    /// A request to address 1: the raw bytes of its reply (a special reply is no `Reply`).
    fn frame(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> Vec<u8> {
        self.bytes(&Request { address: 1, instruction: Instruction::new(op, t, m, v) }.to_bytes())
    }

    /// A request to address 1: (status, value) of its reply.
    fn cmd(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> (Status, i32) {
        let r = self.to(1, op, t, m, v).expect("a reply");
        (r.status, r.value)
    }

    fn command(&mut self, c: Command) -> (Status, i32) {
        let i = c.encode();
        self.cmd(i.opcode, i.kind, i.motor, i.value)
    }

    fn gap(&mut self, n: u8) -> i32 {
        let (s, v) = self.cmd(Opcode::Gap, n, 0, 0);
        assert_eq!(s, Status::Ok, "GAP {n}");
        v
    }

    fn ggp(&mut self, n: u8, bank: u8) -> i32 {
        let (s, v) = self.cmd(Opcode::Ggp, n, bank, 0);
        assert_eq!(s, Status::Ok, "GGP {n}, {bank}");
        v
    }

    /// A mailbox message (§3.6: address, command, type, motor/bank, value MSB first; no checksum): the
    /// 8-byte reply and anything else due on the mailbox.
    fn mailbox(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> Vec<u8> {
        let mut msg = [1, op.code(), t, m, 0, 0, 0, 0];
        msg[4..].copy_from_slice(&v.to_be_bytes());
        let mut out = Vec::new();
        self.module.request(MAILBOX, self.now, &msg, &mut |b: &[u8]| out.extend_from_slice(b));
        out
    }

    /// Text on USB in ASCII mode: the echo and the reply.
    fn text(&mut self, line: &str) -> String {
        String::from_utf8(self.bytes(line.as_bytes())).unwrap()
    }

    /// Runs simulated time; what the module sends meanwhile is dropped.
    fn run(&mut self, d: Duration) {
        let end = self.now + d;
        let mut sink = |_: &[u8]| {};
        loop {
            let next = self.module.poll(self.now, &mut sink);
            self.module.poll_port(MAILBOX, self.now, &mut sink);
            match next {
                Some(t) if t <= end => self.now = t.max(self.now + Duration::from_micros(1)),
                _ => break,
            }
        }
        self.now = end;
        self.module.poll(self.now, &mut sink);
    }

    /// Downloads a program with commands 132/133 from address 0; every command answers 101.
    fn download(&mut self, program: &[Command]) {
        assert_eq!(self.cmd(Opcode::StartDownload, 0, 0, 0).0, Status::Ok);
        for c in program {
            assert_eq!(self.command(*c).0, Status::Loaded, "{c:?}");
        }
        assert_eq!(self.cmd(Opcode::QuitDownload, 0, 0, 0).0, Status::Ok);
    }

    fn run_from(&mut self, address: i32) {
        assert_eq!(self.command(C::RunApplication { from: Some(address) }).0, Status::Ok);
    }
}

/// The 9-byte reply `host 2, module 1, status, command, value` with its checksum.
fn reply(status: u8, op: u8, value: i32) -> [u8; 9] {
    let mut r = [2, 1, status, op, 0, 0, 0, 0, 0];
    r[4..8].copy_from_slice(&value.to_be_bytes());
    r[8] = tmcl_wire::checksum(&r[..8]);
    r
}

// ---- USB: the binary format of chapter 4 ------------------------------------------------------------

#[test]
fn usb_frames_byte_for_byte() {
    let mut r = Rig::new();
    // MVP ABS, 1, 50000: motor 1 on a one-motor module is an invalid value (status 4); the reply keeps the
    // value sent.
    assert_eq!(
        r.bytes(&[0x01, 0x04, 0x00, 0x01, 0x00, 0x00, 0xC3, 0x50, 0x19]),
        [0x02, 0x01, 0x04, 0x04, 0x00, 0x00, 0xC3, 0x50, 0x1E]
    );
    assert_eq!(r.gap(0), 0, "nothing moved");
    // ... and to motor 0 it moves.
    assert_eq!(
        r.bytes(&[0x01, 0x04, 0x00, 0x00, 0x00, 0x00, 0xC3, 0x50, 0x18]),
        [0x02, 0x01, 0x64, 0x04, 0x00, 0x00, 0xC3, 0x50, 0x7E]
    );
    // GAP 0, 0: the target position.
    assert_eq!(r.bytes(&[0x01, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x07]), reply(100, 6, 50000));
    // ROL 0, 500 and MST 0.
    assert_eq!(r.bytes(&[0x01, 0x02, 0x00, 0x00, 0x00, 0x00, 0x01, 0xF4, 0xF8]), reply(100, 2, 500));
    assert_eq!(r.gap(2), -500, "ROL: target velocity to the left");
    r.run(Duration::from_secs(1));
    assert_eq!(r.gap(3), -500);
    assert_eq!(r.bytes(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04]), reply(100, 3, 0));
    r.run(Duration::from_secs(1));
    assert_eq!((r.gap(2), r.gap(3)), (0, 0), "stopped");
    // SGP 0, 3, 1000: timer 0's period (§6.6.5's example).
    assert_eq!(
        r.bytes(&[0x01, 0x09, 0x00, 0x03, 0x00, 0x00, 0x03, 0xE8, 0xF8]),
        [0x02, 0x01, 0x64, 0x09, 0x00, 0x00, 0x03, 0xE8, 0x5B]
    );
    assert_eq!(r.ggp(0, 3), 1000);
    // SIO 3, 2, 1 (§6.6.5's example) sets OUT3; GIO 0, 2 reads OUT0 back, GIO 3, 2 OUT3.
    assert_eq!(r.bytes(&[0x01, 0x0E, 0x03, 0x02, 0x00, 0x00, 0x00, 0x01, 0x15]), reply(100, 14, 1));
    assert_eq!(r.module.board().outputs, 0b1000);
    assert_eq!(r.bytes(&[0x01, 0x0F, 0x00, 0x02, 0x00, 0x00, 0x00, 0x00, 0x12]), reply(100, 15, 0));
    assert_eq!(r.bytes(&[0x01, 0x0F, 0x03, 0x02, 0x00, 0x00, 0x00, 0x00, 0x15]), reply(100, 15, 1));
}

#[test]
fn version_and_factory_default_frames() {
    let mut r = Rig::new();
    // 136 type 0: the host address, then the 8 characters, no checksum.
    assert_eq!(r.bytes(&[0x01, 0x88, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x89]), *b"\x021310V114");
    // 136 type 1: module number 1310 = 0x051E, then version 1.14.
    assert_eq!(
        r.bytes(&[0x01, 0x88, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x8A]),
        [0x02, 0x01, 0x64, 0x88, 0x05, 0x1E, 0x01, 0x0E, 0x21]
    );
    // 137 with 1234: factory defaults, no reply; a stored parameter is back at its default.
    assert_eq!(r.cmd(Opcode::Sap, 4, 0, 1000).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Stap, 4, 0, 0).0, Status::Ok);
    assert!(r.bytes(&[0x01, 0x89, 0x00, 0x00, 0x00, 0x00, 0x04, 0xD2, 0x60]).is_empty(), "no reply to 137");
    assert_eq!(r.gap(4), 51200);
    r.power_cycle();
    assert_eq!(r.gap(4), 51200, "the EEPROM holds the defaults");
    // 137 without the key is an invalid value.
    assert_eq!(r.cmd(Opcode::FactoryDefault, 0, 0, 1).0, Status::InvalidValue);
}

#[test]
fn checksum_error_is_status_1() {
    let mut r = Rig::new();
    // GAP 0, 0 with checksum 00 instead of 07: status 1, command and value 0.
    assert_eq!(r.bytes(&[0x01, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]), reply(1, 0, 0));
    // A SAP with a wrong checksum is not executed.
    let mut sap = Request { address: 1, instruction: Instruction::new(Opcode::Sap, 4, 0, 1000) }.to_bytes();
    sap[8] = sap[8].wrapping_add(1);
    assert_eq!(r.bytes(&sap)[2], 1);
    assert_eq!(r.gap(4), 51200);
}

#[test]
fn usb_answers_every_address_byte_with_its_own() {
    let mut r = Rig::new();
    // A USB link has one module: the address byte is not filtered (USB.address_filter = false); the reply
    // names host 2 and module 1 (GP 76, GP 66).
    for address in [0, 1, 2, 5, 255] {
        let reply = r.to(address, Opcode::Gap, 4, 0, 0).unwrap_or_else(|| panic!("address {address} answered"));
        assert_eq!((reply.host, reply.module, reply.status, reply.value), (2, 1, Status::Ok, 51200), "{address}");
    }
    // GAP 4 to address 5, byte for byte.
    assert_eq!(r.bytes(&[0x05, 0x06, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0F]), reply(100, 6, 51200));
    // ... a checksum error to another address as well.
    assert_eq!(r.bytes(&[0x05, 0x06, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]), reply(1, 0, 0));
    // A new module address (GP 66) and host address (GP 76) show in the replies; address 1 still answers.
    assert_eq!(r.cmd(Opcode::Sgp, 66, 0, 4).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Sgp, 76, 0, 3).0, Status::Ok);
    let reply = r.to(1, Opcode::Gap, 4, 0, 0).unwrap();
    assert_eq!((reply.host, reply.module), (3, 4));
    // Both are stored at once (A parameters): a restart keeps them.
    r.power_cycle();
    let reply = r.to(9, Opcode::Ggp, 66, 0, 0).unwrap();
    assert_eq!((reply.host, reply.module, reply.value), (3, 4, 4));
}

#[test]
fn commands_the_model_has_and_lacks() {
    let mut r = Rig::new();
    // No SAC (29): the manual never names it.
    assert_eq!(r.cmd(Opcode::Sac, 0, 1, 5).0, Status::InvalidCommand);
    // Program-only commands from the host: status 6.
    assert_eq!(r.cmd(Opcode::Ja, 0, 0, 0).0, Status::NotAvailable);
    assert_eq!(r.cmd(Opcode::Vect, 0, 0, 0).0, Status::NotAvailable);
    // No RS485 settings (GP 65, 75, 87, 68) on the 1310.
    for gp in [65, 68, 75, 87] {
        assert_eq!(r.cmd(Opcode::Ggp, gp, 0, 0).0, Status::WrongType, "GP {gp}");
    }
    // No sense-range switch AP 179.
    assert_eq!(r.cmd(Opcode::Gap, 179, 0, 0).0, Status::WrongType);
    // The closed-loop parameters read (their defaults).
    assert_eq!((r.gap(129), r.gap(132), r.gap(133)), (0, 0, 0));
    assert_eq!((r.gap(202), r.gap(210)), (200, 4096));
    // 8 inputs (bank 0), the analog IN0/IN1 (bank 1), 8 outputs (bank 2).
    r.module.board_mut().inputs = 0b1000_0001;
    assert_eq!(r.cmd(Opcode::Gio, 7, 0, 0), (Status::Ok, 1));
    assert_eq!(r.cmd(Opcode::Gio, 255, 0, 0), (Status::Ok, 0x81));
    assert_eq!(r.cmd(Opcode::Gio, 1, 1, 0), (Status::Ok, 1001));
    assert_eq!(r.cmd(Opcode::Gio, 2, 1, 0).0, Status::WrongType, "IN2 is not analog");
    assert_eq!(r.cmd(Opcode::Sio, 7, 2, 1).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Sio, 8, 2, 1).0, Status::WrongType);
    assert_eq!(r.cmd(Opcode::Sio, 255, 2, 0xA5).0, Status::Ok);
    assert_eq!(r.module.board().outputs, 0xA5);
}

// ---- ASCII (§5) and the mailbox (§3.5–3.6) ----------------------------------------------------------

/// 139 over USB: answered in binary, then ASCII.
fn ascii_rig() -> Rig {
    let mut r = Rig::new();
    assert_eq!(r.bytes(&[0x01, 0x8B, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x8C]), reply(100, 139, 0));
    assert!(r.module.ascii_mode_on(USB));
    assert!(!r.module.ascii_mode_on(MAILBOX));
    r
}

#[test]
fn ascii_over_usb() {
    let mut r = ascii_rig();
    // §5.2: "BA 100 5000" for the actual position 5000, host address 2, module address 1 (the manual's
    // "AGAP 0, 1" names axis 1, which this one-axis module lacks: status 4).
    assert_eq!(r.text("ASAP 1, 0, 5000\r"), "ASAP 1, 0, 5000\rBA 100 5000\r");
    assert_eq!(r.text("AGAP 1, 0\r"), "AGAP 1, 0\rBA 100 5000\r");
    assert_eq!(r.text("AGAP 0, 1\r"), "AGAP 0, 1\rBA 4 0\r");
    // Setting the actual position at standstill sets the target with it: nothing moves.
    assert_eq!(r.text("AGAP 0, 0\r"), "AGAP 0, 0\rBA 100 5000\r");
    // §5.1's example lines: motors 1 and 2 do not exist (status 4); to motor 0 they run.
    assert_eq!(r.text("AMVP ABS, 1, 50000\r"), "AMVP ABS, 1, 50000\rBA 4 50000\r");
    assert_eq!(r.text("A MVP ABS, 1, 50000\r"), "A MVP ABS, 1, 50000\rBA 4 50000\r");
    assert_eq!(r.text("AROL 2, 500\r"), "AROL 2, 500\rBA 4 500\r");
    assert_eq!(r.text("A MST 1\r"), "A MST 1\rBA 4 0\r");
    assert_eq!(r.text("A MVP ABS, 0, 50000\r"), "A MVP ABS, 0, 50000\rBA 100 50000\r");
    assert_eq!(r.text("AGAP 0, 0\r"), "AGAP 0, 0\rBA 100 50000\r");
    assert_eq!(r.text("AROL 0, 500\r"), "AROL 0, 500\rBA 100 500\r");
    assert_eq!(r.text("A MST 0\r"), "A MST 0\rBA 100 0\r");
    assert_eq!(r.text("ASIO 3, 2, 1\r"), "ASIO 3, 2, 1\rBA 100 1\r");
    assert_eq!(r.module.board().outputs, 0b1000);
    assert_eq!(r.text("AGGP 200, 0\r"), "AGGP 200, 0\rBA 100 0\r");
    // §5.3: only the listed commands; CALC is not one (6); SAC is no command of the 1310 at all (2).
    assert_eq!(r.text("ACALC ADD, 7\r"), "ACALC ADD, 7\rBA 6 7\r");
    assert_eq!(r.text("ASAC 0, 1, 5\r"), "ASAC 0, 1, 5\rBA 2 5\r");
    // Status 8 in ASCII too.
    assert_eq!(r.text("ASAP 25, 0, 500\r"), "ASAP 25, 0, 500\rBA 8 500\r");
    // A line for module 2 is ignored whole, as on a bus (iface/ascii.rs), although a binary frame to any
    // address is answered on USB.
    assert_eq!(r.text("BGAP 1, 0\r"), "");
    // BIN (§5, §6.8.38): answered, then binary again.
    assert_eq!(r.text("ABIN\r"), "ABIN\rBA 100 0\r");
    assert!(!r.module.ascii_mode_on(USB));
    assert_eq!(r.bytes(&[0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08]), reply(100, 6, 5000));
}

#[test]
fn ascii_run_and_stop() {
    let mut r = Rig::new();
    r.download(&[C::Calc { op: CalcOp::Add, operand: 1 }, C::Agp { param: 1, bank: 2 }, C::Ja { address: 0 }]);
    r.cmd(Opcode::EnterAscii, 0, 0, 0);
    assert_eq!(r.text("ASGP 67, 0, 32\r"), "ASGP 67, 0, 32\rBA 100 32\r");
    // GP 67 bit 5 (§5.4): from the next line on, no echo.
    assert_eq!(r.text("ARUN\r"), "BA 100 0\r");
    r.run(Duration::from_millis(10));
    assert_eq!(r.text("ASTOP\r"), "BA 100 0\r");
    assert_eq!(r.text("AGGP 128, 0\r"), "BA 100 0\r", "stopped");
    assert_ne!(r.text("AGGP 1, 2\r"), "BA 100 0\r", "the program counted");
}

#[test]
fn ascii_at_start_up_on_usb_only() {
    let mut r = Rig::new();
    // §5.4: GP 67 bit 0 = start in ASCII mode; on USB (§5: "with the USB interface, only").
    assert_eq!(r.cmd(Opcode::Sgp, 67, 0, 1).0, Status::Ok);
    r.power_cycle();
    assert!(r.module.ascii_mode_on(USB));
    assert!(!r.module.ascii_mode_on(MAILBOX));
    assert_eq!(r.text("AGAP 4, 0\r"), "AGAP 4, 0\rBA 100 51200\r");
    assert_eq!(r.mailbox(Opcode::Gap, 4, 0, 0), [2, 1, 100, 6, 0, 0, 0xC8, 0x00]);
}

#[test]
fn the_mailbox_has_no_ascii() {
    let mut r = Rig::new();
    // 8 bytes in, 8 out (§3.6).
    assert_eq!(r.mailbox(Opcode::Gap, 4, 0, 0), [2, 1, 100, 6, 0, 0, 0xC8, 0x00]);
    // 139 in the mailbox: command not available (6), and nothing changes on either interface.
    assert_eq!(r.mailbox(Opcode::EnterAscii, 0, 0, 0), [2, 1, 6, 139, 0, 0, 0, 0]);
    assert!(!r.module.ascii_mode_on(MAILBOX));
    assert!(!r.module.ascii_mode_on(USB));
    assert_eq!(r.mailbox(Opcode::Gap, 4, 0, 0)[2], 100);
    // 136 type 0 in the mailbox: the 8 characters; type 1 the number.
    assert_eq!(r.mailbox(Opcode::GetVersion, 0, 0, 0), b"1310V114");
    assert_eq!(r.mailbox(Opcode::GetVersion, 1, 0, 0), [2, 1, 100, 136, 0x05, 0x1E, 0x01, 0x0E]);
    // Text bytes on the mailbox port are dropped (it takes whole messages only).
    let mut out = Vec::new();
    r.module.receive_on(MAILBOX, r.now, b"AGAP 4, 0\r", &mut |b: &[u8]| out.extend_from_slice(b));
    assert!(out.is_empty());
    // ASCII on USB leaves the mailbox binary.
    r.cmd(Opcode::EnterAscii, 0, 0, 0);
    assert_eq!(r.mailbox(Opcode::Gap, 4, 0, 0), [2, 1, 100, 6, 0, 0, 0xC8, 0x00]);
    assert_eq!(r.mailbox(Opcode::Sap, 25, 0, 500)[2], 8, "status 8 in the mailbox too");
}

// ---- status 8: the password GP 200 (§3.7) ------------------------------------------------------------

const PROTECTED: [(u8, i32); 3] = [(25, 3000), (26, 0), (112, 0)];

#[test]
fn protected_parameters_answer_8_until_unlocked() {
    let mut r = Rig::new();
    assert_eq!(r.ggp(200, 0), 0, "locked");
    for (n, default) in PROTECTED {
        assert_eq!(r.gap(n), default, "reading AP {n} is never protected");
        assert_eq!(r.cmd(Opcode::Sap, n, 0, 500).0, Status::PasswordProtected, "SAP {n}");
        assert_eq!(r.cmd(Opcode::Stap, n, 0, 0).0, Status::PasswordProtected, "STAP {n}");
        assert_eq!(r.gap(n), default, "AP {n} unchanged");
    }
    // AAP (the host's accumulator) is a write as well.
    r.command(C::Calc { op: CalcOp::Load, operand: 500 });
    assert_eq!(r.cmd(Opcode::Aap, 25, 0, 0).0, Status::PasswordProtected);
    // An unprotected parameter is written as always.
    assert_eq!(r.cmd(Opcode::Sap, 4, 0, 1000).0, Status::Ok);
    // A wrong password: accepted as a write, still locked.
    assert_eq!(r.cmd(Opcode::Sgp, 200, 0, 1111), (Status::Ok, 1111));
    assert_eq!(r.ggp(200, 0), 0);
    assert_eq!(r.cmd(Opcode::Sap, 25, 0, 500).0, Status::PasswordProtected);
    // SGP 200, 0, 4321: unlocked; GGP 200 reads 1, not the password.
    assert_eq!(r.cmd(Opcode::Sgp, 200, 0, PASSWORD), (Status::Ok, PASSWORD));
    assert_eq!(r.ggp(200, 0), 1);
    for (n, _) in PROTECTED {
        assert_eq!(r.cmd(Opcode::Sap, n, 0, 500).0, Status::Ok, "SAP {n}");
        assert_eq!(r.cmd(Opcode::Stap, n, 0, 0).0, Status::Ok, "STAP {n}");
        assert_eq!(r.gap(n), 500);
    }
    assert_eq!(r.cmd(Opcode::Aap, 26, 0, 0), (Status::Ok, 500));
    // A wrong password locks again.
    assert_eq!(r.cmd(Opcode::Sgp, 200, 0, 0).0, Status::Ok);
    assert_eq!(r.ggp(200, 0), 0);
    assert_eq!(r.cmd(Opcode::Sap, 25, 0, 600).0, Status::PasswordProtected);
    assert_eq!(r.gap(25), 500);
    // RSAP brings back what was stored (with the password): it needs none.
    assert_eq!(r.cmd(Opcode::Rsap, 112, 0, 0).0, Status::Ok);
    assert_eq!(r.gap(112), 500);
    // The password itself is never stored.
    assert_eq!(r.cmd(Opcode::Stgp, 200, 0, 0).0, Status::WrongType);
}

#[test]
fn a_restart_locks_again() {
    let mut r = Rig::new();
    assert_eq!(r.cmd(Opcode::Sgp, 200, 0, PASSWORD).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Sap, 25, 0, 700).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Stap, 25, 0, 0).0, Status::Ok);
    // Command 255 (with 1234): answered, then the module starts again, locked; the stored value stays.
    assert_eq!(r.cmd(Opcode::SoftwareReset, 0, 0, 1234), (Status::Ok, 1234));
    assert_eq!(r.ggp(200, 0), 0);
    assert_eq!(r.gap(25), 700);
    assert_eq!(r.cmd(Opcode::Sap, 25, 0, 800).0, Status::PasswordProtected);
    // A power cycle (a new Module on the same board) too.
    assert_eq!(r.cmd(Opcode::Sgp, 200, 0, PASSWORD).0, Status::Ok);
    r.power_cycle();
    assert_eq!(r.ggp(200, 0), 0);
    assert_eq!(r.cmd(Opcode::Stap, 26, 0, 0).0, Status::PasswordProtected);
    // Factory defaults (137) as well, and AP 25 is back at its default.
    assert_eq!(r.cmd(Opcode::Sgp, 200, 0, PASSWORD).0, Status::Ok);
    assert!(r.frame(Opcode::FactoryDefault, 0, 0, 1234).is_empty(), "no reply to 137");
    assert_eq!(r.ggp(200, 0), 0);
    assert_eq!(r.gap(25), 3000);
}

#[test]
fn a_program_cannot_write_protected_parameters_while_locked() {
    let mut r = Rig::new();
    // A program's SAP that fails is skipped (vm/mod.rs): AP 25 stays, the program goes on.
    r.download(&[
        C::Sap { param: 25, motor: 0, value: 700 },
        C::Calc { op: CalcOp::Load, operand: 1 },
        C::Agp { param: 3, bank: 2 },
        C::Stop,
    ]);
    r.run_from(0);
    r.run(Duration::from_millis(10));
    assert_eq!((r.gap(25), r.ggp(3, 2)), (3000, 1));
    // Unlocked by the host, the same program writes it.
    r.cmd(Opcode::Sgp, 200, 0, PASSWORD);
    r.run_from(0);
    r.run(Duration::from_millis(10));
    assert_eq!(r.gap(25), 700);
}

// ---- 1024 commands of program memory (§1) ------------------------------------------------------------

/// 1023 × `CALC ADD, 1` and a STOP: 1024 commands.
fn full_program() -> Vec<Command> {
    let mut p = vec![C::Calc { op: CalcOp::Add, operand: 1 }; 1023];
    p.push(C::Stop);
    p
}

#[test]
fn program_memory_holds_1024_commands() {
    let mut r = Rig::new();
    assert_eq!(SPEC.program_memory, 1024);
    r.download(&full_program());
    // 134 reads every cell back; the last is the STOP at 1023; 1024 is past memory (4).
    let raw = r.frame(Opcode::ReadMemory, 0, 0, 1023);
    assert_eq!(raw[0..2], [2, 28], "host address, then the cell: STOP");
    assert_eq!(raw[1..8], Instruction::new(Opcode::Stop, 0, 0, 0).to_bytes());
    assert_eq!(r.cmd(Opcode::ReadMemory, 0, 0, 1024).0, Status::InvalidValue);
    // 132 at 1023 is the last cell; at 1024 there is none.
    assert_eq!(r.cmd(Opcode::StartDownload, 0, 0, 1023).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::QuitDownload, 0, 0, 0).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::StartDownload, 0, 0, 1024).0, Status::InvalidValue);
    assert_eq!(r.cmd(Opcode::RunApplication, 1, 0, 1024).0, Status::InvalidValue);
    // The whole program runs: 1023 additions, then STOP.
    r.run_from(0);
    r.run(Duration::from_millis(100));
    assert_eq!(r.ggp(128, 0), 0, "stopped");
    assert_eq!(r.command(C::GetStatus { kind: StatusKind::Accumulator }), (Status::Ok, 1023));
    // It survives a power cycle (the EEPROM's program area holds 1024 cells).
    r.power_cycle();
    let raw = r.frame(Opcode::ReadMemory, 0, 0, 1023);
    assert_eq!(raw[1], 28);
    // Tools load at most 1024 commands too.
    let image: Vec<Instruction> = full_program().iter().map(Command::encode).collect();
    assert_eq!(r.module.load_program(&image), Ok(()));
    let mut too_long = image.clone();
    too_long.push(Instruction::new(Opcode::Stop, 0, 0, 0));
    assert_eq!(r.module.load_program(&too_long), Err(Status::InvalidValue));
}

/// The 1025th command of a download: memory is full.
///
/// Ignored: the core answers it with 101 (loaded) and writes it over cell 1023, so the 1024th command is
/// lost without a word (`download` in vm/run.rs keeps the download pointer at the last cell). A full
/// memory should refuse it and keep cell 1023 — with 4 (invalid value), as command 132 to address 1024
/// answers; the manual names no status for it.
#[test]
fn the_1025th_download_is_refused() {
    let mut r = Rig::new();
    assert_eq!(r.cmd(Opcode::StartDownload, 0, 0, 0).0, Status::Ok);
    for c in full_program() {
        assert_eq!(r.command(c).0, Status::Loaded);
    }
    let extra = C::Calc { op: CalcOp::Load, operand: 77 };
    assert_eq!(r.command(extra).0, Status::InvalidValue, "memory full");
    assert_eq!(r.cmd(Opcode::QuitDownload, 0, 0, 0).0, Status::Ok);
    let raw = r.frame(Opcode::ReadMemory, 0, 0, 1023);
    assert_eq!(raw[1], 28, "cell 1023 still holds the STOP");
}

// ---- interrupts (§6.6) ------------------------------------------------------------------------------

/// A program with one input-change vector `n` (trigger `edges`: 1 rising, 2 falling, 3 both) whose
/// handler counts in user variable 0.
fn counting_program(n: u8, edges: i32) -> Vec<Command> {
    vec![
        C::Vect { interrupt: n, address: 5 },
        C::Sgp { param: n, bank: 3, value: edges },
        C::Ei { interrupt: n },
        C::Ei { interrupt: 255 },
        C::Ja { address: 4 },         // main loop
        C::Ggp { param: 0, bank: 2 }, // 5: handler
        C::Calc { op: CalcOp::Add, operand: 1 },
        C::Agp { param: 0, bank: 2 },
        C::Reti,
    ]
}

fn set_input(r: &mut Rig, bit: u8, level: bool) {
    let b = r.module.board_mut();
    b.inputs = if level { b.inputs | (1 << bit) } else { b.inputs & !(1 << bit) };
    r.run(Duration::from_millis(5));
}

#[test]
fn input_7_interrupt_on_both_edges() {
    let mut r = Rig::new();
    r.download(&counting_program(46, 3));
    r.run_from(0);
    r.run(Duration::from_millis(20));
    assert_eq!(r.ggp(46, 3), 3);
    assert_eq!(r.ggp(0, 2), 0);
    set_input(&mut r, 7, true);
    assert_eq!(r.ggp(0, 2), 1, "IN7 rising");
    set_input(&mut r, 7, false);
    assert_eq!(r.ggp(0, 2), 2, "IN7 falling");
    set_input(&mut r, 6, true);
    assert_eq!(r.ggp(0, 2), 2, "IN6 is interrupt 45, not enabled");
    set_input(&mut r, 7, true);
    assert_eq!(r.ggp(0, 2), 3);
    assert!(!r.module.vm().in_handler());
    assert_eq!(r.ggp(128, 0), 1, "still running the main loop");
}

#[test]
fn input_4_interrupt_on_the_rising_edge() {
    let mut r = Rig::new();
    r.download(&counting_program(43, 1));
    r.run_from(0);
    r.run(Duration::from_millis(20));
    set_input(&mut r, 4, true);
    assert_eq!(r.ggp(0, 2), 1, "IN4 rising");
    set_input(&mut r, 4, false);
    assert_eq!(r.ggp(0, 2), 1, "falling: not configured");
    set_input(&mut r, 4, true);
    assert_eq!(r.ggp(0, 2), 2);
    // DI 43 from the host (§6.8.34: "could be used in direct mode"): no more interrupts.
    assert_eq!(r.cmd(Opcode::Di, 43, 0, 0).0, Status::Ok);
    set_input(&mut r, 4, false);
    set_input(&mut r, 4, true);
    assert_eq!(r.ggp(0, 2), 2);
}

#[test]
fn every_input_has_its_vector_39_to_46() {
    // Handler k (for interrupt 39 + k) counts in user variable k; every trigger on both edges.
    let mut program = Vec::new();
    for k in 0..8u8 {
        program.push(C::Vect { interrupt: 39 + k, address: 26 + 4 * i32::from(k) });
        program.push(C::Sgp { param: 39 + k, bank: 3, value: 3 });
        program.push(C::Ei { interrupt: 39 + k });
    }
    program.push(C::Ei { interrupt: 255 }); // 24
    program.push(C::Ja { address: 25 }); // 25
    for k in 0..8u8 {
        program.extend([
            C::Ggp { param: k, bank: 2 },
            C::Calc { op: CalcOp::Add, operand: 1 },
            C::Agp { param: k, bank: 2 },
            C::Reti,
        ]);
    }
    let mut r = Rig::new();
    r.download(&program);
    r.run_from(0);
    r.run(Duration::from_millis(20));
    for bit in 0..8u8 {
        set_input(&mut r, bit, true);
        for k in 0..8u8 {
            assert_eq!(r.ggp(k, 2), i32::from(k == bit), "IN{bit} rose: variable {k}");
        }
        set_input(&mut r, bit, false);
        assert_eq!(r.ggp(bit, 2), 2, "IN{bit} fell");
        r.command(C::Sgp { param: bit, bank: 2, value: 0 });
    }
}

#[test]
fn interrupt_numbers_of_the_model() {
    let mut r = Rig::new();
    // §6.6.3: 0–2, 3, 15, 21, 27, 28, 39–46 and 255; nothing else.
    for n in [0, 1, 2, 3, 15, 21, 27, 28, 39, 46, 255] {
        assert_eq!(r.cmd(Opcode::Ei, n, 0, 0).0, Status::Ok, "EI {n}");
        assert_eq!(r.cmd(Opcode::Di, n, 0, 0).0, Status::Ok, "DI {n}");
    }
    for n in [4, 14, 38, 47, 254] {
        assert_eq!(r.cmd(Opcode::Ei, n, 0, 0).0, Status::WrongType, "EI {n}");
    }
    // Bank 3: the timer periods and the trigger transitions of 27, 28, 39–46 (0..3).
    assert_eq!(r.cmd(Opcode::Sgp, 46, 3, 3).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Sgp, 46, 3, 4).0, Status::InvalidValue);
    assert_eq!(r.cmd(Opcode::Sgp, 47, 3, 1).0, Status::WrongType);
    assert_eq!(r.cmd(Opcode::Sgp, 3, 3, 1).0, Status::WrongType, "target reached needs no configuration");
}

#[test]
fn manual_timer_interrupt_example() {
    // §6.6.5, as printed: the main loop toggles OUT3 every 50 ticks (0.5 s), timer 0 toggles OUT0 every
    // 1000 ms.
    let program = vec![
        C::Vect { interrupt: 0, address: 9 },
        C::Sgp { param: 0, bank: 3, value: 1000 },
        C::Ei { interrupt: 0 },
        C::Ei { interrupt: 255 },
        C::Sio { port: 3, bank: 2, value: 1 }, // Loop = 4
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 50 },
        C::Sio { port: 3, bank: 2, value: 0 },
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 50 },
        C::Ja { address: 4 },
        C::Gio { port: 0, bank: 2 }, // Timer0Irq = 9
        C::Jc { condition: Condition::NotZero, address: 13 },
        C::Sio { port: 0, bank: 2, value: 1 },
        C::Reti,
        C::Sio { port: 0, bank: 2, value: 0 }, // Out0Off = 13
        C::Reti,
    ];
    let mut r = Rig::new();
    r.download(&program);
    r.run_from(0);
    let (mut out0, mut out3) = (Vec::new(), Vec::new());
    r.run(Duration::from_millis(250));
    for _ in 0..8 {
        let outputs = r.module.board().outputs;
        out0.push(outputs & 1);
        out3.push((outputs >> 3) & 1);
        r.run(Duration::from_millis(500));
    }
    assert_eq!(out3, [1, 0, 1, 0, 1, 0, 1, 0], "OUT3: 0.5 s high, 0.5 s low");
    assert_eq!(out0, [0, 0, 1, 1, 0, 0, 1, 1], "OUT0: toggled every second");
}

// ---- the TMCM-1310 and the PD28-1021 alike ------------------------------------------------------------

/// One step of the shared sequence: a command, or simulated time.
enum Step {
    Send(Command),
    Wait(u64),
}

#[test]
fn shared_commands_answer_alike_on_the_pd28_1021() {
    use Step::{Send as S, Wait as W};
    let sequence = [
        S(C::Sap { param: 4, motor: 0, value: 100_000 }),
        S(C::Sap { param: 5, motor: 0, value: 200_000 }),
        S(C::Sap { param: 6, motor: 0, value: 100 }),
        S(C::Gap { param: 4, motor: 0 }),
        S(C::Gap { param: 5, motor: 0 }),
        S(C::Gap { param: 6, motor: 0 }),
        S(C::Sap { param: 6, motor: 0, value: 256 }), // out of range on both
        S(C::Mvp { motor: 0, target: MoveTarget::Abs(51200) }),
        S(C::Gap { param: 0, motor: 0 }),
        S(C::Gap { param: 8, motor: 0 }),
        W(3000),
        S(C::Gap { param: 1, motor: 0 }),
        S(C::Gap { param: 3, motor: 0 }),
        S(C::Gap { param: 8, motor: 0 }),
        S(C::Cco { coord: 2, motor: 0 }),
        S(C::Mvp { motor: 0, target: MoveTarget::Rel(-25600) }),
        W(3000),
        S(C::Gap { param: 1, motor: 0 }),
        S(C::Mvp { motor: 0, target: MoveTarget::Coord(2) }),
        W(3000),
        S(C::Gap { param: 1, motor: 0 }),
        S(C::Ror { motor: 0, velocity: 1000 }),
        W(1000),
        S(C::Gap { param: 3, motor: 0 }),
        S(C::Mst { motor: 0 }),
        W(1000),
        S(C::Gap { param: 3, motor: 0 }),
        S(C::Gap { param: 2, motor: 0 }),
        S(C::Sap { param: 1, motor: 0, value: -7 }),
        S(C::Gap { param: 1, motor: 0 }),
        // Bank 2 user variables, stored and restored.
        S(C::Sgp { param: 10, bank: 2, value: -77 }),
        S(C::Ggp { param: 10, bank: 2 }),
        S(C::Stgp { param: 10, bank: 2 }),
        S(C::Sgp { param: 10, bank: 2, value: 5 }),
        S(C::Rsgp { param: 10, bank: 2 }),
        S(C::Ggp { param: 10, bank: 2 }),
        S(C::Stgp { param: 56, bank: 2 }), // only 0..55 are stored
        S(C::Ggp { param: 255, bank: 2 }),
        // Axis parameters stored and restored.
        S(C::Sap { param: 4, motor: 0, value: 12_345 }),
        S(C::Stap { param: 4, motor: 0 }),
        S(C::Sap { param: 4, motor: 0, value: 1 }),
        S(C::Rsap { param: 4, motor: 0 }),
        S(C::Gap { param: 4, motor: 0 }),
        // Coordinates.
        S(C::Sco { coord: 1, motor: 0, position: 4321 }),
        S(C::Gco { coord: 1, motor: 0 }),
        S(C::Gco { coord: 2, motor: 0 }),
        S(C::Sco { coord: 21, motor: 0, position: 1 }),
        S(C::Sco { coord: 1, motor: 255, position: 0 }),
        S(C::Sco { coord: 1, motor: 0, position: 0 }),
        S(C::Gco { coord: 1, motor: 255 }),
        S(C::Gco { coord: 1, motor: 0 }),
        // CALC in direct mode (the reply carries the operand) and what it leaves in the accumulator.
        S(C::Calc { op: CalcOp::Load, operand: 6 }),
        S(C::Calc { op: CalcOp::Mul, operand: 7 }),
        S(C::Calc { op: CalcOp::Div, operand: 0 }),
        S(C::Aap { param: 4, motor: 0 }),
        S(C::Gap { param: 4, motor: 0 }),
        S(C::Agp { param: 11, bank: 2 }),
        S(C::Ggp { param: 11, bank: 2 }),
        // Addresses, outputs, unknown numbers, a second motor.
        S(C::Ggp { param: 66, bank: 0 }),
        S(C::Ggp { param: 76, bank: 0 }),
        S(C::Sio { port: 0, bank: 2, value: 1 }),
        S(C::Gio { port: 0, bank: 2 }),
        S(C::Gap { param: 99, motor: 0 }),
        S(C::Gap { param: 1, motor: 1 }),
        S(C::Ggp { param: 0, bank: 4 }),
    ];
    let mut rigs = [Rig::of(&pd28_1021::SPEC), Rig::new()];
    for (i, step) in sequence.iter().enumerate() {
        match step {
            S(c) => {
                let frame = Request { address: 1, instruction: c.encode() }.to_bytes();
                let [a, b] = rigs.each_mut().map(|r| r.bytes(&frame));
                assert_eq!(a.len(), 9, "step {i}: {c:?}");
                assert_eq!(a, b, "step {i}: {c:?}: PD28-1021 {a:02X?}, TMCM-1310 {b:02X?}");
            }
            W(ms) => rigs.iter_mut().for_each(|r| r.run(Duration::from_millis(*ms))),
        }
    }
    // The checks above are replies; spot-check that they said what we meant.
    let r = &mut rigs[1];
    assert_eq!((r.gap(1), r.gap(4), r.ggp(10, 2)), (-7, 42, -77));
}

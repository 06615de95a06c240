//! The ASCII interface (manual §3.4): entering and leaving, lines, echo modes, replies.

use super::*;

fn text(out: &[u8]) -> String {
    String::from_utf8_lossy(out).into_owned()
}

fn ascii_bench() -> Bench {
    let mut b = Bench::new();
    // 139: answered in binary, then ASCII.
    let r = b.send(Opcode::EnterAscii, 0, 0, 0);
    assert_eq!(r.status, Status::Ok);
    assert!(b.module.ascii_mode());
    b
}

#[test]
fn manual_gap_example_with_echo() {
    let mut b = ascii_bench();
    b.sap_ascii("ASAP 1, 0, -5000");
    // §3.4.3: "AGAP 1, 0" (the manual's "AGAP 0, 1" names motor 1, which this single-axis module lacks)
    // → "BA 100 -5000".
    assert_eq!(text(&b.bytes(b"AGAP 1, 0\r")), "AGAP 1, 0\rBA 100 -5000\r");
}

#[test]
fn manual_command_line_examples() {
    let mut b = ascii_bench();
    b.module.board_mut().nvm.writes = 0;
    // §3.4.2's examples use motors 1 and 2, which this one-axis module does not have: status 4.
    assert_eq!(text(&b.bytes(b"AMVP ABS, 1, 50000\r")), "AMVP ABS, 1, 50000\rBA 4 50000\r");
    assert_eq!(text(&b.bytes(b"A MVP ABS, 0, 50000\r")), "A MVP ABS, 0, 50000\rBA 100 50000\r");
    assert_eq!(text(&b.bytes(b"AROL 2, 500\r")), "AROL 2, 500\rBA 4 500\r");
    assert_eq!(text(&b.bytes(b"A MST 0\r")), "A MST 0\rBA 100 0\r");
    assert_eq!(text(&b.bytes(b"ABIN\r")), "ABIN\rBA 100 0\r");
    assert!(!b.module.ascii_mode());
    assert_eq!(b.send(Opcode::Gap, 0, 0, 0).value, 50000, "binary again");
}

#[test]
fn echo_modes() {
    let mut b = ascii_bench();
    // bit 4: the whole line after <CR>.
    b.bytes(b"ASGP 67, 0, 16\r");
    let out = b.bytes(b"AGAP 4, 0");
    assert!(out.is_empty(), "no immediate echo");
    assert_eq!(text(&b.bytes(b"\r")), "AGAP 4, 0\rBA 100 51200\r");
    // bit 5: no echo, only the reply.
    b.bytes(b"ASGP 67, 0, 32\r");
    assert_eq!(text(&b.bytes(b"AGAP 4, 0\r")), "BA 100 51200\r");
    // Backspace edits the line.
    assert_eq!(text(&b.bytes(b"AGAP 5\x084, 0\r")), "BA 100 51200\r");
    b.bytes(b"ASGP 67, 0, 0\r");
    assert_eq!(text(&b.bytes(b"AGAP 44\x08, 0\r")), "AGAP 44\x08 \x08, 0\rBA 100 51200\r");
}

#[test]
fn other_addresses_and_bad_lines() {
    let mut b = ascii_bench();
    assert!(b.bytes(b"BGAP 1, 0\r").is_empty(), "another module's line: no echo, no reply");
    assert_eq!(text(&b.bytes(b"aGAP 4, 0\r")), "aGAP 4, 0\rBA 100 51200\r", "lower-case address");
    let reply = |b: &mut Bench, line: &str| {
        let out = text(&b.bytes(format!("{line}\r").as_bytes()));
        out[line.len() + 1..].to_string()
    };
    assert_eq!(reply(&mut b, "AFOO 1"), "BA 2 0\r");
    assert_eq!(reply(&mut b, "A"), "BA 2 0\r");
    assert_eq!(reply(&mut b, "AMVP SIDEWAYS, 0, 1"), "BA 3 0\r");
    assert_eq!(reply(&mut b, "ASAP 4, 0, 0"), "BA 4 0\r", "out of range");
    assert_eq!(reply(&mut b, "ACALC ADD, 7"), "BA 6 7\r", "not an ASCII-mode command");
    assert_eq!(reply(&mut b, &format!("AGAP {}", "1".repeat(80))), "BA 2 0\r", "line too long");
    assert_eq!(reply(&mut b, "AGAP 4, 0"), "BA 100 51200\r", "still in step");
    // A secondary address answers too, with the primary in the reply.
    b.bytes(b"ASGP 87, 0, 3\r");
    assert_eq!(reply(&mut b, "CGAP 4, 0"), "BA 100 51200\r");
}

#[test]
fn run_and_stop_control_the_program() {
    let mut b = Bench::new();
    let program: Vec<Instruction> = [
        Command::Calc { op: tmcl_wire::CalcOp::Add, operand: 1 },
        Command::Agp { param: 1, bank: 2 },
        Command::Ja { address: 0 },
    ]
    .iter()
    .map(Command::encode)
    .collect();
    b.module.load_program(&program).unwrap();
    b.send(Opcode::EnterAscii, 0, 0, 0);
    b.bytes(b"ASGP 67, 0, 32\r");
    assert_eq!(text(&b.bytes(b"ARUN\r")), "BA 100 0\r");
    b.run(Duration::from_millis(10));
    assert_eq!(text(&b.bytes(b"ASTOP\r")), "BA 100 0\r");
    assert_eq!(text(&b.bytes(b"AGGP 128, 0\r")), "BA 100 0\r", "stopped");
    let counted = text(&b.bytes(b"AGGP 1, 2\r"));
    assert!(counted.starts_with("BA 100 ") && counted != "BA 100 0\r", "{counted}");
}

#[test]
fn start_up_in_ascii_mode() {
    let mut b = Bench::new();
    assert_eq!(b.sgp(67, 0, 1), Status::Ok);
    b.power_cycle();
    assert!(b.module.ascii_mode(), "GP 67 bit 0");
    assert_eq!(text(&b.bytes(b"AGAP 4, 0\r")), "AGAP 4, 0\rBA 100 51200\r");
    // Back to binary for this session; the next start is ASCII again.
    b.bytes(b"ABIN\r");
    assert_eq!(b.send(Opcode::Gap, 4, 0, 0).value, 51200);
    b.power_cycle();
    assert!(b.module.ascii_mode());
}

#[test]
fn suppressed_replies_in_ascii() {
    let mut b = ascii_bench();
    b.bytes(b"ASGP 67, 0, 32\r");
    assert!(b.bytes(b"ASGP 255, 0, 1\r").is_empty());
    assert!(b.bytes(b"ASAP 4, 0, 1000\r").is_empty());
    assert_eq!(text(&b.bytes(b"AGAP 4, 0\r")), "BA 100 1000\r");
}

/// The request frame `address, op, t, m, v` as bytes: what a binary host sends.
fn frame(address: u8, op: Opcode, t: u8, m: u8, v: i32) -> [u8; 9] {
    Request { address, instruction: Instruction::new(op, t, m, v) }.to_bytes()
}

#[test]
fn binary_frames_then_abin_return_to_binary() {
    // A host that does not know the module is in ASCII mode sends frames (pytrinamic's version request and
    // a GAP): their bytes from 0x01 up are no command line; each control byte or byte above 0x7F discards
    // the line, so nothing is left in front of the `ABIN` typed next.
    let mut b = ascii_bench();
    let mut junk = Vec::new();
    junk.extend_from_slice(&frame(1, Opcode::GetVersion, 0, 0, 0));
    junk.extend_from_slice(&frame(1, Opcode::Gap, 4, 0, 0));
    junk.extend_from_slice(&frame(1, Opcode::Sap, 4, 0, 0x0D42_4741)); // CR 'B' 'G' 'A' in the value
    assert!(b.bytes(&junk).is_empty(), "no echo, no reply");
    assert!(b.module.ascii_mode());
    assert_eq!(text(&b.bytes(b"ABIN\r")), "ABIN\rBA 100 0\r");
    assert!(!b.module.ascii_mode());
    assert_eq!(b.send(Opcode::Gap, 4, 0, 0).value, 51200, "binary again");
}

#[test]
fn a_frame_ending_in_printable_bytes_needs_a_cr_first() {
    // GAP 4 with value 0x36: its last two bytes are '6' and the checksum 'A'. They start a line for the
    // address '6', which swallows the `ABIN` typed after them; its CR ends that line, the next one works.
    let mut b = ascii_bench();
    let request = frame(1, Opcode::Gap, 4, 0, 0x36);
    assert_eq!(&request[7..], b"6A");
    assert!(b.bytes(&request).is_empty());
    assert!(b.bytes(b"ABIN\r").is_empty(), "part of the line `6AABIN`, for another address");
    assert!(b.module.ascii_mode());
    assert_eq!(text(&b.bytes(b"ABIN\r")), "ABIN\rBA 100 0\r");
    assert!(!b.module.ascii_mode());
    // The same frame, then CR (or ESC) before `ABIN`: back at the first try.
    for clear in [b"\r", b"\x1b"] {
        b.send(Opcode::EnterAscii, 0, 0, 0);
        b.bytes(&request);
        assert!(b.bytes(clear).is_empty());
        assert_eq!(text(&b.bytes(b"ABIN\r")), "ABIN\rBA 100 0\r");
        assert!(!b.module.ascii_mode());
    }
}

#[test]
fn partial_line_then_cr_then_abin() {
    let mut b = ascii_bench();
    // A partial line of this module's: its CR gets the reply to what it holds, then ABIN works.
    assert_eq!(text(&b.bytes(b"AGA")), "AGA");
    assert_eq!(text(&b.bytes(b"\r")), "\rBA 2 0\r");
    // A partial line of another address: its CR ends it silently.
    assert!(b.bytes(b"xGAP 4").is_empty());
    assert!(b.bytes(b"\r").is_empty());
    assert_eq!(text(&b.bytes(b"ABIN\r")), "ABIN\rBA 100 0\r");
    assert!(!b.module.ascii_mode());
}

#[test]
fn esc_and_binary_bytes_discard_the_line() {
    let mut b = ascii_bench();
    // Echo mode 00: the characters were echoed as typed; ESC discards the line without a reply.
    assert_eq!(text(&b.bytes(b"AGAP 4, 0\x1b")), "AGAP 4, 0");
    assert_eq!(text(&b.bytes(b"AGAP 5, 0\r")), "AGAP 5, 0\rBA 100 51200\r");
    // A binary byte in the middle of a line: the rest (` 4, 0`, address ' ') is a line for nobody.
    assert_eq!(text(&b.bytes(b"AGAP\x00 4, 0\r")), "AGAP");
    assert!(b.bytes(b"AGGP 66\xfe, 0\r").len() == "AGGP 66".len());
    // TAB is text (the parser takes it as a space); LF is ignored.
    assert_eq!(text(&b.bytes(b"AGAP\t4, 0\r\n")), "AGAP\t4, 0\rBA 100 51200\r");
    assert!(b.module.ascii_mode());
}

impl Bench {
    fn sap_ascii(&mut self, line: &str) {
        let out = self.bytes(format!("{line}\r").as_bytes());
        assert!(text(&out).ends_with(" 100 -5000\r") || text(&out).contains(" 100 "), "{}", text(&out));
    }
}

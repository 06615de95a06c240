//! Every request frame printed in the PD28-1021 TMCL manual (the 38 examples of §3.7.1–3.7.37), decoded and
//! encoded again. Where the manual's printed bytes are wrong the corrected frame is used and the erratum noted.

use super::*;
use crate::frame::{Frame, Request};

fn request(bytes: [u8; 9]) -> Request {
    Request::parse(&Frame::new_unchecked(&bytes[..])).expect("manual vector has a valid checksum")
}

fn check(bytes: [u8; 9], expected: Command) {
    let request = request(bytes);
    assert_eq!(request.address, 1);
    let command = Command::decode(request.instruction).unwrap();
    assert_eq!(command, expected, "{bytes:02X?}");
    let again = Request { address: 1, instruction: command.encode() }.to_bytes();
    assert_eq!(again, bytes, "encode({command:?})");
}

#[test]
fn manual_request_vectors() {
    use Command as C;
    // §3.7.1 ROR 0, 51200
    check([0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0xC8, 0x00, 0xCA], C::Ror { motor: 0, velocity: 51200 });
    // §3.7.2 ROL 0, 51200
    check([0x01, 0x02, 0x00, 0x00, 0x00, 0x00, 0xC8, 0x00, 0xCB], C::Rol { motor: 0, velocity: 51200 });
    // §3.7.3 MST 0
    check([0x01, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04], C::Mst { motor: 0 });
    // §3.7.4 MVP ABS, 0, 90000
    check([0x01, 0x04, 0x00, 0x00, 0x00, 0x01, 0x5F, 0x90, 0xF5], C::Mvp { motor: 0, target: MoveTarget::Abs(90000) });
    // §3.7.4 MVP REL, 0, -10000
    check([0x01, 0x04, 0x01, 0x00, 0xFF, 0xFF, 0xD8, 0xF0, 0xCC], C::Mvp { motor: 0, target: MoveTarget::Rel(-10000) });
    // §3.7.4 MVP COORD, 0, 8
    check([0x01, 0x04, 0x02, 0x00, 0x00, 0x00, 0x00, 0x08, 0x0F], C::Mvp { motor: 0, target: MoveTarget::Coord(8) });
    // §3.7.5 SAP 4, 0, 51200
    check([0x01, 0x05, 0x04, 0x00, 0x00, 0x00, 0xC8, 0x00, 0xD2], C::Sap { param: 4, motor: 0, value: 51200 });
    // §3.7.6 GAP 1, 0
    check([0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08], C::Gap { param: 1, motor: 0 });
    // §3.7.7: captioned "STAP 7, 6" / "STAP 6, 12"; the bytes encode STAP 6, 0; the caption is wrong.
    check([0x01, 0x07, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0E], C::Stap { param: 6, motor: 0 });
    // §3.7.8: printed `01 08 06 00 00 00 00 00 0A` has a wrong checksum (erratum); 0F is right.
    assert!(Request::parse(&Frame::new_unchecked(&[0x01u8, 0x08, 0x06, 0, 0, 0, 0, 0, 0x0A][..])).is_err());
    check([0x01, 0x08, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0F], C::Rsap { param: 6, motor: 0 });
    // §3.7.9 SGP 66, 0, 3
    check([0x01, 0x09, 0x42, 0x00, 0x00, 0x00, 0x00, 0x03, 0x4F], C::Sgp { param: 66, bank: 0, value: 3 });
    // §3.7.10 GGP 66, 0
    check([0x01, 0x0A, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x4D], C::Ggp { param: 66, bank: 0 });
    // §3.7.11 STGP 42, 2
    check([0x01, 0x0B, 0x2A, 0x02, 0x00, 0x00, 0x00, 0x00, 0x38], C::Stgp { param: 42, bank: 2 });
    // §3.7.12 RSGP 42, 2
    check([0x01, 0x0C, 0x2A, 0x02, 0x00, 0x00, 0x00, 0x00, 0x39], C::Rsgp { param: 42, bank: 2 });
    // §3.7.13 RFS START, 0
    check([0x01, 0x0D, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0E], C::Rfs { action: RfsAction::Start, motor: 0 });
    // §3.7.14 SIO 0, 2, 1
    check([0x01, 0x0E, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x12], C::Sio { port: 0, bank: 2, value: 1 });
    // §3.7.15 GIO 0, 1
    check([0x01, 0x0F, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x11], C::Gio { port: 0, bank: 1 });
    // §3.7.16 CALC MUL, -5000
    check([0x01, 0x13, 0x02, 0x00, 0xFF, 0xFF, 0xEC, 0x78, 0x78], C::Calc { op: CalcOp::Mul, operand: -5000 });
    // §3.7.17 COMP 1000
    check([0x01, 0x14, 0x00, 0x00, 0x00, 0x00, 0x03, 0xE8, 0x00], C::Comp { operand: 1000 });
    // §3.7.18 JC GE, Label (Label = 10)
    check(
        [0x01, 0x15, 0x05, 0x00, 0x00, 0x00, 0x00, 0x0A, 0x25],
        C::Jc { condition: Condition::GreaterOrEqual, address: 10 },
    );
    // §3.7.19 JA Loop (Loop = 10)
    check([0x01, 0x16, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0A, 0x21], C::Ja { address: 10 });
    // §3.7.20 CSUB SubW (SubW = 100)
    check([0x01, 0x17, 0x00, 0x00, 0x00, 0x00, 0x00, 0x64, 0x7C], C::Csub { address: 100 });
    // §3.7.21 RSUB
    check([0x01, 0x18, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x19], C::Rsub);
    // §3.7.22 WAIT POS, 0, 0
    check(
        [0x01, 0x1B, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1D],
        C::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
    );
    // §3.7.23 STOP
    check([0x01, 0x1C, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1D], C::Stop);
    // §3.7.24 SCO 1, 0, 1000
    check([0x01, 0x1E, 0x01, 0x00, 0x00, 0x00, 0x03, 0xE8, 0x0B], C::Sco { coord: 1, motor: 0, position: 1000 });
    // §3.7.25 GCO 1, 0
    check([0x01, 0x1F, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x21], C::Gco { coord: 1, motor: 0 });
    // §3.7.26: captioned "CCO 3, 0"; the bytes encode CCO 1, 0; the caption is wrong.
    check([0x01, 0x20, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x22], C::Cco { coord: 1, motor: 0 });
    // §3.7.27 ACO 1, 0
    check([0x01, 0x27, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x29], C::Aco { coord: 1, motor: 0 });
    // §3.7.28 CALCX MUL
    check([0x01, 0x21, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x24], C::Calcx { op: CalcxOp::Mul });
    // §3.7.29 AAP 0, 0
    check([0x01, 0x22, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x23], C::Aap { param: 0, motor: 0 });
    // §3.7.30 AGP 42, 2
    check([0x01, 0x23, 0x2A, 0x02, 0x00, 0x00, 0x00, 0x00, 0x50], C::Agp { param: 42, bank: 2 });
    // §3.7.31 CLE ETO
    check([0x01, 0x24, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x26], C::Cle { flag: ErrorFlag::Timeout });
    // §3.7.32 EI 255
    check([0x01, 0x19, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x19], C::Ei { interrupt: 255 });
    // §3.7.33 DI 255
    check([0x01, 0x1A, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1A], C::Di { interrupt: 255 });
    // §3.7.34: printed with type FF, but checksum 58 fits type 00 (a typo): VECT 0, 50.
    assert!(Request::parse(&Frame::new_unchecked(&[0x01u8, 0x25, 0xFF, 0, 0, 0, 0, 0x32, 0x58][..])).is_err());
    check([0x01, 0x25, 0x00, 0x00, 0x00, 0x00, 0x00, 0x32, 0x58], C::Vect { interrupt: 0, address: 50 });
    // §3.7.35: printed with type FF, checksum 27 fits type 00 (a typo; RETI ignores its type).
    check([0x01, 0x26, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x27], C::Reti);
    // §3.7.37 command 138 type 1, mask 1
    check(
        [0x01, 0x8A, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0x8D],
        C::RequestTargetReachedEvent { mode: EventMode::Every, mask: 1 },
    );
    // §8.6 run application at 0, 1, 2 (the manual's jump-table example; checksums computed).
    check([0x01, 0x81, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x83], C::RunApplication { from: Some(0) });
    check([0x01, 0x81, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0x84], C::RunApplication { from: Some(1) });
    check([0x01, 0x81, 0x01, 0x00, 0x00, 0x00, 0x00, 0x02, 0x85], C::RunApplication { from: Some(2) });
}

#[test]
fn unknown_opcodes_are_invalid_commands() {
    // 29 was here until SAC (PDx-113 manual §5.4.3) was added; see `sac_roundtrips`.
    for code in [0u8, 16, 17, 18, 40, 63, 72, 127, 140, 200, 254] {
        let i = Instruction::new(code.into(), 0, 0, 0);
        assert_eq!(Command::decode(i), Err(Status::InvalidCommand), "opcode {code}");
    }
}

#[test]
fn sac_roundtrips() {
    // SAC <bus number>, <number of bytes>, <send data>: type, motor/bank, value (PDx-113 manual §5.4.3 names
    // the command; no manual prints a frame, so the checksums are computed).
    check([0x01, 0x1D, 0x00, 0x02, 0x00, 0x00, 0x12, 0x34, 0x66], Command::Sac { bus: 0, bytes: 2, data: 0x1234 });
    check([0x01, 0x1D, 0x01, 0x03, 0xFF, 0xFF, 0xFF, 0xFF, 0x1E], Command::Sac { bus: 1, bytes: 3, data: -1 });
    // No field is checked here: the model decides which buses and lengths exist.
    let any = Instruction::new(Opcode::Sac, 255, 255, i32::MIN);
    assert_eq!(Command::decode(any).map(|c| c.encode()), Ok(any));
}

#[test]
fn opcode_matches_encode() {
    for code in 0..=255u8 {
        for t in [0u8, 1, 2, 255] {
            if let Ok(c) = Command::decode(Instruction::new(code.into(), t, 0, MAGIC_KEY)) {
                assert_eq!(c.opcode(), c.encode().opcode, "{c:?}");
                assert_eq!(c.opcode().code(), code);
            }
        }
    }
}

#[test]
fn reads_value_follows_the_table() {
    let reads = |c: Command| c.reads_value();
    assert!(reads(Command::Gap { param: 1, motor: 0 }));
    assert!(reads(Command::Ggp { param: 66, bank: 0 }));
    assert!(reads(Command::Gio { port: 0, bank: 1 }));
    assert!(reads(Command::Gco { coord: 1, motor: 0 }));
    assert!(reads(Command::Sac { bus: 0, bytes: 1, data: 0 }));
    assert!(reads(Command::Rfs { action: RfsAction::Status, motor: 0 }));
    assert!(!reads(Command::Rfs { action: RfsAction::Start, motor: 0 }));
    assert!(!reads(Command::Rfs { action: RfsAction::Stop, motor: 0 }));
    assert!(!reads(Command::Sap { param: 4, motor: 0, value: 1 }));
    assert!(!reads(Command::GetStatus { kind: StatusKind::Accumulator }));
    // Same answers as the list it replaced (GAP, GGP, GIO, GCO, RFS STATUS), SAC aside.
    for code in 0..=255u8 {
        for t in 0..=255u8 {
            if let Ok(c) = Command::decode(Instruction::new(code.into(), t, 0, MAGIC_KEY)) {
                let before = matches!(
                    c,
                    Command::Gap { .. }
                        | Command::Ggp { .. }
                        | Command::Gio { .. }
                        | Command::Gco { .. }
                        | Command::Rfs { action: RfsAction::Status, .. }
                );
                assert_eq!(c.reads_value(), before || matches!(c, Command::Sac { .. }), "{c:?}");
            }
        }
    }
}

#[test]
fn enumerated_types_are_checked() {
    let bad = |op: Opcode, t: u8| Command::decode(Instruction::new(op, t, 0, 0));
    assert_eq!(bad(Opcode::Mvp, 3), Err(Status::WrongType));
    assert_eq!(bad(Opcode::Rfs, 3), Err(Status::WrongType));
    assert_eq!(bad(Opcode::Calc, 10), Err(Status::WrongType));
    assert_eq!(bad(Opcode::Calcx, 11), Err(Status::WrongType));
    assert_eq!(bad(Opcode::Jc, 12), Err(Status::WrongType));
    assert_eq!(bad(Opcode::Wait, 5), Err(Status::WrongType));
    assert_eq!(bad(Opcode::Cle, 6), Err(Status::WrongType));
    assert_eq!(bad(Opcode::GetStatus, 4), Err(Status::WrongType));
    assert_eq!(bad(Opcode::GetVersion, 2), Err(Status::WrongType));
    assert_eq!(bad(Opcode::RequestTargetReachedEvent, 2), Err(Status::WrongType));
    assert_eq!(bad(Opcode::RunApplication, 2), Err(Status::WrongType));
}

#[test]
fn keys_of_137_and_255() {
    let with = |op: Opcode, v: i32| Command::decode(Instruction::new(op, 0, 0, v));
    assert_eq!(with(Opcode::FactoryDefault, 1234), Ok(Command::FactoryDefault));
    assert_eq!(with(Opcode::FactoryDefault, 1233), Err(Status::InvalidValue));
    assert_eq!(with(Opcode::SoftwareReset, 1234), Ok(Command::SoftwareReset));
    assert_eq!(with(Opcode::SoftwareReset, 0), Err(Status::InvalidValue));
}

#[test]
fn type_words() {
    assert_eq!(Condition::from_word("ge"), Some(Condition::GreaterOrEqual));
    assert_eq!(CalcxOp::from_word("SWAP").map(CalcxOp::code), Some(10));
    assert_eq!(WaitCondition::Rfs.word(), "RFS");
    assert_eq!(ErrorFlag::ALL.len(), 6);
}

proptest::proptest! {
    /// decode never panics, and whatever it accepts encodes back to an instruction that decodes the same.
    #[test]
    fn decode_encode_stable(op: u8, t: u8, m: u8, v: i32) {
        if let Ok(c) = Command::decode(Instruction::new(op.into(), t, m, v)) {
            proptest::prop_assert_eq!(Command::decode(c.encode()), Ok(c));
        }
    }
}

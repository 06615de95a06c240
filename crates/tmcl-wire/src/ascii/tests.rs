//! Mnemonic lines of the PD28-1021 TMCL manual §3.7 and the ASCII examples of §3.4.

use super::*;
use std::string::String;

fn no_symbols(_: &str) -> Option<i32> {
    None
}

fn parse(text: &str) -> Result<Instruction, ParseError> {
    parse_instruction(text, &mut no_symbols)
}

fn with_labels(text: &str) -> Result<Instruction, ParseError> {
    parse_instruction(text, &mut |name| match name {
        "Label" | "Loop" => Some(10),
        "SubW" => Some(100),
        "TI_GLOBAL" => Some(255),
        "Big" => Some(300),
        _ => None,
    })
}

fn format(i: &Instruction) -> String {
    let mut s = String::new();
    format_instruction(i, &mut s, None).unwrap();
    s
}

/// (opcode, type, motor, value).
type Tuple = (u8, u8, u8, i32);

fn tuple(i: Instruction) -> Tuple {
    (i.opcode.into(), i.kind, i.motor, i.value)
}

#[test]
fn manual_mnemonic_examples() {
    // The mnemonic examples of §3.7.1–3.7.35 and a few more, as (opcode, type, motor, value).
    let cases: &[(&str, Tuple)] = &[
        ("ROR 0, 51200", (1, 0, 0, 51200)),
        ("ROL 0, 51200", (2, 0, 0, 51200)),
        ("MST 0", (3, 0, 0, 0)),
        ("MVP ABS, 0, 90000", (4, 0, 0, 90000)),
        ("MVP REL, 0, -10000", (4, 1, 0, -10000)),
        ("MVP COORD, 0, 8", (4, 2, 0, 8)),
        ("SAP 4, 0, 51200", (5, 4, 0, 51200)),
        ("GAP 1, 0", (6, 1, 0, 0)),
        ("STAP 6, 0", (7, 6, 0, 0)),
        ("RSAP 6, 0", (8, 6, 0, 0)),
        ("SGP 66, 0, 3", (9, 66, 0, 3)),
        ("GGP 66, 0", (10, 66, 0, 0)),
        ("STGP 42, 2", (11, 42, 2, 0)),
        ("RSGP 42, 2", (12, 42, 2, 0)),
        ("RFS START, 0", (13, 0, 0, 0)),
        ("SIO 0, 2, 1", (14, 0, 2, 1)),
        ("GIO 0, 1", (15, 0, 1, 0)),
        ("CALC MUL, -5000", (19, 2, 0, -5000)),
        ("COMP 1000", (20, 0, 0, 1000)),
        ("JC GE, Label", (21, 5, 0, 10)),
        ("JA Loop", (22, 0, 0, 10)),
        ("CSUB SubW", (23, 0, 0, 100)),
        ("RSUB", (24, 0, 0, 0)),
        ("WAIT POS, 0, 0", (27, 1, 0, 0)),
        ("WAIT TICKS, 0, 500", (27, 0, 0, 500)),
        ("STOP", (28, 0, 0, 0)),
        ("SCO 1, 0, 1000", (30, 1, 0, 1000)),
        ("GCO 1, 0", (31, 1, 0, 0)),
        ("GCO 0, 255, 0", (31, 0, 255, 0)),
        ("CCO 1, 0", (32, 1, 0, 0)),
        ("ACO 1, 0", (39, 1, 0, 0)),
        ("CALCX MUL", (33, 2, 0, 0)),
        ("CALCX SWAP", (33, 10, 0, 0)),
        ("AAP 0, 0", (34, 0, 0, 0)),
        ("AGP 42, 2", (35, 42, 2, 0)),
        ("CLE ETO", (36, 1, 0, 0)),
        ("EI 255", (25, 255, 0, 0)),
        ("EI TI_GLOBAL", (25, 255, 0, 0)),
        ("DI 255", (26, 255, 0, 0)),
        ("VECT 0, Label", (37, 0, 0, 10)),
        ("RETI", (38, 0, 0, 0)),
        ("SIO 255, 2, -1", (14, 255, 2, -1)),
        ("UF3 1, 2, 3", (67, 1, 2, 3)),
        // SAC <bus number>, <number of bytes>, <send data> (PDx-113 manual §5.4.3 names the command).
        ("SAC 0, 2, 0x1234", (29, 0, 2, 0x1234)),
        ("sac 1, 3, -1", (29, 1, 3, -1)),
        ("#op 200, 1, 2, 3", (200, 1, 2, 3)),
        ("#OP rsub, 7, 0, 0", (24, 7, 0, 0)),
    ];
    for &(text, expected) in cases {
        assert_eq!(with_labels(text).map(tuple), Ok(expected), "{text}");
    }
}

#[test]
fn spelling_variants() {
    // §3.4.2 and the listings: any case, spaces around commas, hex, no spaces at all.
    assert_eq!(parse("mvp abs , 0 , 51200").map(tuple), Ok((4, 0, 0, 51200)));
    assert_eq!(parse("GIO 0,1").map(tuple), Ok((15, 0, 1, 0)));
    assert_eq!(parse("  SAP 0x8C, 0, $1F  ").map(tuple), Ok((5, 140, 0, 31)));
    assert_eq!(parse("COMP -0x10").map(tuple), Ok((20, 0, 0, -16)));
    assert_eq!(parse("COMP 0b101").map(tuple), Ok((20, 0, 0, 5)));
    assert_eq!(parse("COMP 0xFFFFFFFF").map(tuple), Ok((20, 0, 0, -1)));
    assert_eq!(parse("COMP -2147483648").map(tuple), Ok((20, 0, 0, i32::MIN)));
    assert_eq!(parse("MVP 2, 0, 8").map(tuple), Ok((4, 2, 0, 8)));
    assert_eq!(parse("WAIT rfs, 0, 0").map(tuple), Ok((27, 4, 0, 0)));
    assert_eq!(parse("RFS STATUS, 0").map(tuple), Ok((13, 2, 0, 0)));
    assert_eq!(parse("\tRSUB\t").map(tuple), Ok((24, 0, 0, 0)));
}

#[test]
fn errors_have_kinds_and_spans() {
    let err = |text| parse(text).unwrap_err();
    assert_eq!(err(""), ParseError::new(ParseErrorKind::Empty, Span::new(0, 0)));
    assert_eq!(err("  MVPP ABS"), ParseError::new(ParseErrorKind::UnknownMnemonic, Span::new(2, 6)));
    let e = err("MVP ABS, 0");
    assert_eq!(e.span, Span::new(0, 3));
    assert_eq!(std::format!("{e}"), "MVP takes 3 operands, found 2");
    assert_eq!(std::format!("{}", err("GAP 1")), "GAP takes 2 or 3 operands, found 1");
    assert_eq!(std::format!("{}", err("RSUB 1")), "RSUB takes no operands, found 1");
    assert_eq!(std::format!("{}", err("SAC 0, 2")), "SAC takes 3 operands, found 2");
    assert_eq!(std::format!("{}", err("JA")), "JA takes 1 operand, found 0");
    let e = err("SAP 4, 300, 1");
    assert_eq!(e.span, Span::new(7, 10));
    assert_eq!(std::format!("{e}"), "value 300 does not fit the motor/bank byte (0..255)");
    assert_eq!(err("EI -1").kind, ParseErrorKind::OutOfRange { field: Field::Type, value: -1 });
    assert_eq!(err("COMP 4294967296").kind, ParseErrorKind::OutOfRange { field: Field::Value, value: 1 << 32 });
    assert_eq!(err("COMP 12a").kind, ParseErrorKind::BadNumber);
    assert_eq!(err("COMP 0x").kind, ParseErrorKind::BadNumber);
    assert_eq!(err("COMP 99999999999999999999").kind, ParseErrorKind::BadNumber);
    assert_eq!(err("COMP (1)").kind, ParseErrorKind::BadOperand);
    assert_eq!(err("SAP 4, , 1"), ParseError::new(ParseErrorKind::MissingOperand, Span::new(7, 7)));
    let e = err("JA Lop");
    assert_eq!(e, ParseError::new(ParseErrorKind::UnknownSymbol, Span::new(3, 6)));
    assert_eq!(std::format!("{}", e.with_text("JA Lop")), "unknown symbol `Lop`");
    let text = "MVP ABSS, 0, 1";
    let e = err(text);
    assert_eq!(e.kind, ParseErrorKind::UnknownTypeWord { opcode: Opcode::Mvp });
    assert_eq!(std::format!("{}", e.with_text(text)), "`ABSS` is not a type of MVP (one of ABS, REL, COORD)");
    assert_eq!(
        with_labels("MVP Big, 0, 1").unwrap_err().kind,
        ParseErrorKind::OutOfRange { field: Field::Type, value: 300 }
    );
    assert_eq!(err("#op 256, 0, 0, 0").kind, ParseErrorKind::OutOfRange { field: Field::Opcode, value: 256 });
    assert_eq!(std::format!("{}", err("#op 1, 2")), "#op takes 4 operands, found 2");
}

#[test]
fn formats_type_words_and_labels() {
    let i = |op: u8, t, m, v| Instruction::new(op.into(), t, m, v);
    assert_eq!(format(&i(4, 0, 0, 50000)), "MVP ABS, 0, 50000");
    assert_eq!(format(&i(4, 7, 0, 1)), "MVP 7, 0, 1");
    assert_eq!(format(&i(1, 0, 0, 500)), "ROR 0, 500");
    assert_eq!(format(&i(6, 1, 0, 0)), "GAP 1, 0");
    assert_eq!(format(&i(6, 1, 0, 9)), "GAP 1, 0, 9");
    assert_eq!(format(&i(24, 0, 0, 0)), "RSUB");
    assert_eq!(format(&i(24, 3, 0, 0)), "#op RSUB, 3, 0, 0");
    assert_eq!(format(&i(33, 10, 0, 0)), "CALCX SWAP");
    assert_eq!(format(&i(36, 1, 0, 0)), "CLE ETO");
    assert_eq!(format(&i(67, 1, 2, 3)), "UF3 1, 2, 3");
    assert_eq!(format(&i(29, 0, 2, 4660)), "SAC 0, 2, 4660");
    assert_eq!(format(&i(29, 0, 0, 0)), "SAC 0, 0, 0");
    assert_eq!(format(&i(200, 1, 2, 3)), "#op 200, 1, 2, 3");
    assert_eq!(format(&i(129, 1, 0, 5)), "#op 129, 1, 0, 5");
    let mut s = String::new();
    let names = |a: i32| (a == 10).then_some("Loop");
    format_instruction(&i(21, 5, 0, 10), &mut s, Some(&names)).unwrap();
    assert_eq!(s, "JC GE, Loop");
    s.clear();
    format_instruction(&i(22, 0, 0, 11), &mut s, Some(&names)).unwrap();
    assert_eq!(s, "JA 11");
}

#[test]
fn ascii_lines() {
    // §3.4.2 examples (module address 1), §3.4.3 reply.
    assert_eq!(char_address(b'A'), Some(1));
    assert_eq!(address_char(2), Some(b'B'));
    assert_eq!(address_char(27), None);
    assert_eq!(
        parse_ascii_command("MVP ABS, 1, 50000", &mut no_symbols),
        Ok(AsciiCommand::Instruction(Instruction::new(Opcode::Mvp, 0, 1, 50000)))
    );
    assert_eq!(
        parse_ascii_command(" MST 1", &mut no_symbols),
        Ok(AsciiCommand::Instruction(Instruction::new(Opcode::Mst, 0, 1, 0)))
    );
    assert_eq!(parse_ascii_command("BIN", &mut no_symbols), Ok(AsciiCommand::Binary));
    assert_eq!(parse_ascii_command("stop", &mut no_symbols), Ok(AsciiCommand::Stop));
    assert!(ascii_allowed(Opcode::Cco) && ascii_allowed(Opcode::UserFunction(7)));
    assert!(!ascii_allowed(Opcode::Calc) && !ascii_allowed(Opcode::Aco) && !ascii_allowed(Opcode::Wait));
    // PDx-113 manual §5.6.3 adds SAC to the PD28-1021's §3.4 list.
    assert!(ascii_allowed(Opcode::Sac));
    assert_eq!(
        parse_ascii_command("SAC 0, 1, 255", &mut no_symbols),
        Ok(AsciiCommand::Instruction(Instruction::new(Opcode::Sac, 0, 1, 255)))
    );
    // Otherwise the list it replaced (opcodes 1..=15, 30..=32, 64..=71).
    for code in 0..=255u8 {
        let before = matches!(code, 1..=15 | 30..=32 | 64..=71);
        assert_eq!(ascii_allowed(Opcode::from(code)), before || code == 29, "{code}");
    }
    assert!(!ascii_allowed(Opcode::Unknown(16)) && !ascii_allowed(Opcode::EnterAscii));
    let mut s = String::new();
    write_reply(&mut s, 2, 1, Status::Ok, -5000).unwrap();
    assert_eq!(s, "BA 100 -5000\r");
    assert_eq!(Status::from(parse("FOO").unwrap_err()), Status::InvalidCommand);
}

fn any_instruction() -> impl proptest::strategy::Strategy<Value = Instruction> {
    use proptest::prelude::*;
    let small = || prop_oneof![Just(0u8), 0..16u8, any::<u8>()];
    (any::<u8>(), small(), small(), prop_oneof![Just(0i32), -100..100i32, any::<i32>()])
        .prop_map(|(op, t, m, v)| Instruction::new(op.into(), t, m, v))
}

proptest::proptest! {
    /// Every instruction, decodable or not, formats to text that parses back to it.
    #[test]
    fn format_parse_roundtrip(i in any_instruction()) {
        let text = format(&i);
        proptest::prop_assert_eq!(parse(&text), Ok(i), "{}", text);
        // With labels for every address.
        let mut s = String::new();
        let name = |a: i32| (a >= 0).then_some("Target");
        format_instruction(&i, &mut s, Some(&name)).unwrap();
        let back = parse_instruction(&s, &mut |n| (n == "Target").then_some(i.value));
        proptest::prop_assert_eq!(back, Ok(i), "{}", s);
    }

    /// The parser never panics, and its spans always lie inside the text.
    #[test]
    fn parse_never_panics(text in "\\PC{0,40}") {
        if let Err(e) = parse(&text) {
            proptest::prop_assert!(e.span.start <= e.span.end && e.span.end <= text.len());
            let _ = std::format!("{} {}", e, e.with_text(&text));
        }
    }

    /// Likelier-looking garbage: mnemonics and operands.
    #[test]
    fn parse_never_panics_on_near_misses(text in "(MVP|SAP|JA|#op|CALCX|UF1)( [A-Za-z0-9$#+-]{0,6}(, ?[A-Za-z0-9$+-]{0,12}){0,5})?") {
        let _ = with_labels(&text);
    }
}

#[test]
fn numbers_of_the_host_tools() {
    for (text, n) in
        [("0", 0), ("-5", -5), ("+5", 5), ("0x1F", 31), ("0X1f", 31), ("-0x10", -16), ("4294967295", 4294967295)]
    {
        assert_eq!(parse_number(text), Some(n), "{text}");
    }
    for bad in
        ["", "-", "+", "0x", "0x+1", "--5", "++5", "+-5", " 5", "5 ", "1e3", "$10", "0b1", "x", "99999999999999999999"]
    {
        assert_eq!(parse_number(bad), None, "{bad:?}");
    }
    assert_eq!(value32(-1), Some(-1));
    assert_eq!(value32(0xFFFF_FFFF), Some(-1));
    assert_eq!(value32(i64::from(i32::MIN)), Some(i32::MIN));
    assert_eq!(value32(0x1_0000_0000), None);
    assert_eq!(value32(i64::from(i32::MIN) - 1), None);
}

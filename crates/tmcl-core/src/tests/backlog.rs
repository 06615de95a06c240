//! A backlog of frames, as a pty or a TCP socket delivers it: any number of complete frames in one read,
//! each answered in order, none lost (issue "no frame lost"; the RS485 line of manual §3.1 never holds more
//! than one, a buffer does).

use super::*;

/// `SGP k, 2, v` (user variable k) then `GGP k, 2`: the second reply carries `v` only when the replies
/// come in order, each after its own request.
fn pairs(n: usize) -> (Vec<u8>, Vec<i32>) {
    let mut bytes = Vec::new();
    let mut values = Vec::new();
    for k in 0..n {
        let var = (k % 50) as u8;
        let v = 1_000 + k as i32;
        bytes.extend(Request { address: 1, instruction: Instruction::new(Opcode::Sgp, var, 2, v) }.to_bytes());
        bytes.extend(Request { address: 1, instruction: Instruction::new(Opcode::Ggp, var, 2, 0) }.to_bytes());
        values.push(v);
        values.push(v);
    }
    (bytes, values)
}

fn replies(out: &[u8]) -> Vec<Reply> {
    assert_eq!(out.len() % 9, 0, "whole replies only");
    out.chunks(9).map(|c| Reply::parse(&ReplyFrame::new_checked(c).unwrap()).expect("checksum")).collect()
}

#[test]
fn a_thousand_frames_in_one_read_get_a_thousand_replies_in_order() {
    let mut b = Bench::new();
    let (bytes, values) = pairs(500);
    let mut out = Vec::new();
    b.module.receive(b.now, &bytes, &mut |x: &[u8]| out.extend_from_slice(x));
    let got = replies(&out);
    assert_eq!(got.len(), 1_000);
    assert!(got.iter().all(|r| r.status == Status::Ok));
    assert_eq!(got.iter().map(|r| r.value).collect::<Vec<_>>(), values);
}

#[test]
fn with_a_telegram_pause_the_backlog_is_taken_in_turn() {
    let mut b = Bench::new();
    assert_eq!(b.sgp(75, 0, 2), Status::Ok);
    let (bytes, values) = pairs(100);
    let mut out = Vec::new();
    let mut rest = &bytes[..];
    let mut rounds = 0;
    while !rest.is_empty() {
        let taken = b.module.receive_in_turn(0, b.now, rest, &mut |x: &[u8]| out.extend_from_slice(x));
        assert!(taken == 9 || rest.len() < 9 || taken == 0, "one frame per reply: {taken}");
        rest = &rest[taken..];
        // What a server does: sleep until the module's deadline, poll, offer the rest again.
        if let Some(due) = b.module.poll(b.now, &mut |x: &[u8]| out.extend_from_slice(x)) {
            b.now = b.now.max(due);
            b.module.poll(b.now, &mut |x: &[u8]| out.extend_from_slice(x));
        }
        rounds += 1;
        assert!(rounds < 1_000);
    }
    let got = replies(&out);
    assert_eq!(got.iter().map(|r| r.value).collect::<Vec<_>>(), values);
    assert_eq!(rounds, 200, "each frame waited for the reply before it");
}

#[test]
fn without_a_timeout_a_frame_in_slow_pieces_is_answered() {
    let mut b = Bench::new();
    b.module.set_inter_byte_timeout(None);
    let frame = [0x01, 0x06, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08];
    for (k, byte) in frame.iter().enumerate() {
        let out = b.bytes(&[*byte]);
        assert_eq!(out.len(), if k == 8 { 9 } else { 0 });
        b.now += Duration::from_millis(50);
    }
    // The default (a serial line): the same pieces are dropped after 5 ms.
    b.module.set_inter_byte_timeout(Some(crate::iface::INTER_BYTE_TIMEOUT));
    for byte in frame {
        assert!(b.bytes(&[byte]).is_empty());
        b.now += Duration::from_millis(50);
    }
}

#[test]
fn a_backlog_of_ascii_lines_is_answered_line_by_line() {
    let mut b = Bench::new();
    assert_eq!(b.send(Opcode::EnterAscii, 0, 0, 0).status, Status::Ok);
    let mut text = Vec::new();
    let mut expected = String::new();
    for k in 0..300 {
        let line = format!("ASGP {}, 2, {}\r", k % 50, k);
        expected.push_str(&format!("{line}BA 100 {k}\r"));
        text.extend_from_slice(line.as_bytes());
    }
    let mut out = Vec::new();
    b.module.receive(b.now, &text, &mut |x: &[u8]| out.extend_from_slice(x));
    assert_eq!(String::from_utf8_lossy(&out), expected);
}

/// A read's reply goes to the host at once only when nothing waits before it: behind a reply held by
/// the telegram pause (§5.1 GP 75) it waits its turn, although it is due at once itself (the pause set
/// to 0 in between).
#[test]
fn a_reads_reply_never_passes_a_reply_that_waits() {
    let mut b = Bench::new();
    assert_eq!(b.sgp(75, 0, 10), Status::Ok);
    assert_eq!(b.sgp(7, 2, 77), Status::Ok);
    let t0 = b.now + Duration::from_millis(50);
    let frame = |opcode, kind, bank, value| {
        Request { address: 1, instruction: Instruction::new(opcode, kind, bank, value) }.to_bytes()
    };
    let mut out = Vec::new();
    // The first read: its reply waits 10 ms.
    b.module.receive(t0, &frame(Opcode::Gap, 4, 0, 0), &mut |x: &[u8]| out.extend_from_slice(x));
    // The pause set to 0, and a second read, both due at once, both behind the first reply.
    let t1 = t0 + Duration::from_millis(1);
    b.module.receive(t1, &frame(Opcode::Sgp, 75, 0, 0), &mut |x: &[u8]| out.extend_from_slice(x));
    let t2 = t0 + Duration::from_millis(2);
    b.module.receive(t2, &frame(Opcode::Ggp, 7, 2, 0), &mut |x: &[u8]| out.extend_from_slice(x));
    assert!(out.is_empty(), "nothing passes the reply that waits");
    assert_eq!(b.module.poll(t2, &mut |x: &[u8]| out.extend_from_slice(x)), Some(t0 + Duration::from_millis(10)));
    b.module.poll(t0 + Duration::from_millis(10), &mut |x: &[u8]| out.extend_from_slice(x));
    let got = replies(&out);
    let max_speed = b.gap(4);
    assert_eq!(
        got.iter().map(|r| (r.opcode, r.status, r.value)).collect::<Vec<_>>(),
        [
            (Opcode::Gap.code(), Status::Ok, max_speed),
            (Opcode::Sgp.code(), Status::Ok, 0),
            (Opcode::Ggp.code(), Status::Ok, 77)
        ]
    );
    // With the outbox empty again, a read's reply comes at once.
    out.clear();
    b.module.receive(t0 + Duration::from_millis(11), &frame(Opcode::Ggp, 7, 2, 0), &mut |x: &[u8]| {
        out.extend_from_slice(x)
    });
    assert_eq!(replies(&out).iter().map(|r| r.value).collect::<Vec<_>>(), [77]);
}

//! Builds the request frame of `ROR 0, 500` (PD28-1021 TMCL firmware manual §3.7.1), parses it back,
//! and reads a module's reply to `GIO 0, 1` (§3.2 and §3.7.15).
//!
//! Run with `cargo run -p tmcl-wire --example frames`.

use tmcl_wire::{Command, Frame, Reply, ReplyFrame, Request, Status};

fn main() {
    // The validated command, its raw instruction, and the nine bytes a host sends to module 1.
    let command = Command::Ror { motor: 0, velocity: 500 };
    let request = Request { address: 1, instruction: command.encode() };
    let bytes = request.to_bytes();
    println!("ROR 0, 500 -> {bytes:02X?}");
    assert_eq!(bytes, [0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0xF4, 0xF7]);

    // A module parses untrusted bytes through the checked view: a short buffer or a bad checksum is an
    // error value, never a panic.
    let parsed = Request::parse(&Frame::new_checked(&bytes[..]).expect("nine bytes")).expect("checksum");
    assert_eq!(Command::decode(parsed.instruction), Ok(command));
    let mut corrupted = bytes;
    corrupted[8] ^= 1;
    println!("corrupted checksum -> {:?}", Request::parse(&Frame::new_unchecked(&corrupted[..])));

    // The reply to `GIO 0, 1` with the value 302, as printed in the manual.
    let reply_bytes = [0x02, 0x01, 0x64, 0x0F, 0x00, 0x00, 0x01, 0x2E, 0xA5];
    let reply = Reply::parse(&ReplyFrame::new_checked(&reply_bytes[..]).expect("nine bytes")).expect("checksum");
    println!(
        "reply: module {} status {} ({}) value {}",
        reply.module,
        u8::from(reply.status),
        reply.status.description(),
        reply.value
    );
    assert_eq!((reply.status, reply.value), (Status::Ok, 302));
}

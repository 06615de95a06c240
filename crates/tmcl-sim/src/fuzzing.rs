//! Fuzz harnesses, shared by the cargo-fuzz targets in `fuzz/` and by the stable property tests, so that
//! "never panics" is checked on every `cargo test` too.

use crate::board::SimBoard;
use tmcl_core::model::pd28_1021::{self, SPEC};
use tmcl_core::model::{pd_113, tmcm_1310};
use tmcl_core::model::{InterfaceDesc, ModelDesc, ModelSpec};
use tmcl_core::module::MAILBOX_LEN;
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::{Command, Frame, Reply, ReplyFrame, Request, Status, FRAME_LEN};

/// The PD28-1021 with a second interface, an EtherCAT mailbox: a module that serves two interfaces.
static PD28_WITH_MAILBOX: ModelSpec = ModelSpec::new(ModelDesc {
    interfaces: &[InterfaceDesc::RS485, InterfaceDesc::ETHERCAT_MAILBOX],
    ..pd28_1021::DESC
});

/// Feeds arbitrary bytes to a module on a simulated board, in chunks with arbitrary gaps between them,
/// and checks what comes out: only whole 9-byte frames, each a valid reply or the 136 special reply.
///
/// Input layout: repeated `[gap, len, bytes...]`, where `gap` is in tenths of a millisecond (0..=25.5 ms:
/// around the 5 ms inter-byte timeout, and short enough that a run's motion stays cheap, so that a
/// campaign makes millions of runs) and `len` the number of following bytes to deliver at once.
pub fn module_stream(data: &[u8]) {
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    let mut now = Instant::ZERO;
    let mut out = Vec::new();
    let mut rest = data;
    let mut ascii = false;
    while let [gap, len, tail @ ..] = rest {
        now += Duration::from_micros(100 * u64::from(*gap));
        let n = usize::from(*len).min(tail.len());
        module.receive(now, &tail[..n], &mut |b: &[u8]| out.extend_from_slice(b));
        // Once a 139 switched to ASCII mode the output is text: frames are not checked any more.
        ascii |= module.ascii_mode();
        rest = &tail[n..];
        if let Some(next) = module.poll(now, &mut |b: &[u8]| out.extend_from_slice(b)) {
            // Time moves on a little, as it would between reads.
            now = next.min(now + Duration::from_millis(10));
        }
    }
    module.poll(now + Duration::from_millis(100), &mut |b: &[u8]| out.extend_from_slice(b));
    if !ascii {
        check_replies(&out);
    }
}

/// Feeds an arbitrary line stream to a module in ASCII mode (entered with 139) and checks that every
/// line addressed to it gets one reply of the §3.4.3 form.
///
/// (A 10-million-run campaign found that a line can stop being addressed to the module while it is
/// typed — `A`, backspace, `C…` — after its first characters were echoed; such a line gets no reply, as
/// every line for another address.)
pub fn ascii_lines(data: &[u8]) {
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    let mut out = Vec::new();
    let enter = Request { address: 1, instruction: Command::EnterAscii.encode() }.to_bytes();
    module.receive(Instant::ZERO, &enter, &mut |_: &[u8]| {});
    // No echo, so the output is replies only.
    module.receive(Instant::ZERO, b"ASGP 67, 0, 32\r", &mut |_: &[u8]| {});
    let mut now = Instant::ZERO;
    for line in data.split(|b| *b == b'\r') {
        now += Duration::from_millis(1);
        out.clear();
        module.receive(now, line, &mut |b: &[u8]| out.extend_from_slice(b));
        module.receive(now, b"\r", &mut |b: &[u8]| out.extend_from_slice(b));
        if !module.ascii_mode() {
            return; // BIN (or a line that was one after editing) left ASCII mode
        }
        // A line addressed to the module when its CR arrives ends in a reply (after an echo, if echo is
        // on); one that is not (its address character erased and another typed) leaves at most the echo
        // of what was typed while it was, and no CR.
        if out.contains(&b'\r') {
            // The reply is the last CR-terminated segment (a line may have turned echo on):
            // two address characters, a space, the status, a space, the value.
            let text = String::from_utf8_lossy(&out);
            assert!(text.ends_with('\r'), "reply {text:?} to {line:?}");
            let reply = text.trim_end_matches('\r').rsplit('\r').next().unwrap_or_default();
            let fields: Vec<&str> = reply.split(' ').collect();
            assert!(
                fields.len() == 3
                    && fields[0].len() == 2
                    && fields[1].parse::<u8>().is_ok()
                    && fields[2].parse::<i32>().is_ok(),
                "reply {reply:?} to {line:?}"
            );
        }
    }
}

/// Decodes and executes one arbitrary 9-byte frame on a fresh module.
pub fn one_frame(data: &[u8]) {
    let Ok(frame) = Frame::new_checked(data) else { return };
    if let Ok(request) = Request::parse(&frame) {
        if let Ok(command) = Command::decode(request.instruction) {
            assert_eq!(Command::decode(command.encode()), Ok(command));
            let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
            let _ = module.execute(command, Instant::ZERO);
            module.poll(Instant::from_secs(1), &mut |_: &[u8]| {});
        }
    }
    let mut out = Vec::new();
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    module.receive(Instant::ZERO, &data[..FRAME_LEN], &mut |b: &[u8]| out.extend_from_slice(b));
    check_replies(&out);
}

/// Runs an arbitrary program: the bytes are 8-byte cells (opcode, type, motor, value, and one byte that
/// the host sends as an extra direct-mode command's type), loaded as they are, then run for 60 ms of
/// module time (3000 instructions at most, enough to reach every instruction's code and a few WAIT
/// ticks and timer periods, short enough for millions of runs) while a host pokes at the module.
/// The machine must stay bounded: every poll returns, and the program never panics the core.
pub fn program(data: &[u8]) {
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    let mut cells = Vec::new();
    let mut inputs = Vec::new();
    for chunk in data.chunks_exact(8).take(usize::from(SPEC.program_memory)) {
        let mut seven = [0u8; 7];
        seven.copy_from_slice(&chunk[..7]);
        cells.push(tmcl_wire::Instruction::from_bytes(seven));
        inputs.push(chunk[7]);
    }
    if module.load_program(&cells).is_err() {
        return;
    }
    let _ = module.execute(Command::RunApplication { from: Some(0) }, Instant::ZERO);
    let mut now = Instant::ZERO;
    let mut out = Vec::new();
    for poke in inputs.iter().cycle().take(60) {
        // A host reading and writing beside the program (GAP, SGP to a user variable, SIO).
        let _ = module.execute(Command::Gap { param: *poke, motor: 0 }, now);
        let _ = module.execute(Command::Sgp { param: *poke, bank: 2, value: i32::from(*poke) }, now);
        let _ = module.execute(Command::Sio { port: *poke & 1, bank: 2, value: i32::from(*poke >> 7) }, now);
        now += Duration::from_millis(1);
        let next = module.poll(now, &mut |b: &[u8]| out.extend_from_slice(b));
        assert!(next.is_none_or(|t| t >= now), "a deadline in the past: {next:?} at {now}");
    }
    check_replies(&out);
}

/// Feeds two interfaces of one module at once: arbitrary bytes on its RS485 port and arbitrary 8-byte
/// mailbox messages, interleaved, with arbitrary gaps. Each interface must get only what belongs to it:
/// whole 9-byte frames on the serial port (until it switches to ASCII); in the mailbox exactly one 8-byte
/// reply per request (none for 242 and 137) with a known status (134 and 136 have their special layouts),
/// and between requests only 138 events.
///
/// Input layout: repeated `[kind, gap, ...]`: an even `kind` is followed by one 8-byte mailbox message, an
/// odd one by `len` and `len` bytes for the serial port; `gap` is in tenths of a millisecond.
pub fn two_interfaces(data: &[u8]) {
    let mut module = Module::new(SimBoard::in_memory_for(&PD28_WITH_MAILBOX), &PD28_WITH_MAILBOX, Instant::ZERO);
    let mut now = Instant::ZERO;
    let mut serial = Vec::new();
    let mut ascii = false;
    let mut rest = data;
    let mut events = Vec::new();
    while let [kind, gap, tail @ ..] = rest {
        now += Duration::from_micros(100 * u64::from(*gap));
        if kind % 2 == 0 {
            let Some(message) = tail.first_chunk::<MAILBOX_LEN>() else { break };
            let mut reply = Vec::new();
            module.request(1, now, message, &mut |b: &[u8]| reply.extend_from_slice(b));
            check_mailbox_reply(message, &reply);
            rest = &tail[MAILBOX_LEN..];
        } else {
            let [len, tail @ ..] = tail else { break };
            let n = usize::from(*len).min(tail.len());
            module.receive_on(0, now, &tail[..n], &mut |b: &[u8]| serial.extend_from_slice(b));
            rest = &tail[n..];
        }
        ascii |= module.ascii_mode_on(0);
        assert!(!module.ascii_mode_on(1), "no ASCII mode in a mailbox");
        let next = module.poll_port(0, now, &mut |b: &[u8]| serial.extend_from_slice(b));
        module.poll_port(1, now, &mut |b: &[u8]| events.extend_from_slice(b));
        if let Some(next) = next {
            now = next.min(now + Duration::from_millis(10));
        }
    }
    now += Duration::from_millis(100);
    module.poll_port(0, now, &mut |b: &[u8]| serial.extend_from_slice(b));
    module.poll_port(1, now, &mut |b: &[u8]| events.extend_from_slice(b));
    if !ascii {
        check_replies(&serial);
    }
    assert_eq!(events.len() % MAILBOX_LEN, 0, "mailbox events come whole");
    for event in events.chunks(MAILBOX_LEN) {
        assert_eq!((event[2], event[3]), (128, 138), "only 138 events arrive between requests: {event:02X?}");
    }
}

/// The TMCM-1310's closed loop under arbitrary commands: the encoder is initialised and the loop closed,
/// then each 9-byte chunk `[gap, command, type, motor, value (4), poll]` runs one instruction (direct
/// mode) after `gap` tenths of a millisecond, polling `poll` milliseconds afterwards, in a world where the
/// shaft seizes for a while. Whatever is written — resolutions, gains, β, torques, the loop opened and
/// closed again — nothing panics, deadlines never lie in the past, and while the loop stays closed the
/// field stays within half an electrical period of the rotor: no step is lost, whatever the speed.
pub fn closed_loop(data: &[u8]) {
    let spec = &tmcm_1310::SPEC;
    let world = crate::World::from_toml_str(
        "[motor]\nholding_torque = 0.45\nrated_current = 2.0\n[[faults.stall]]\nat = 30.0\nfrom = 0.35\nuntil = 0.5\n",
    )
    .expect("valid world");
    let board = SimBoard::in_memory_for(spec).with_world(world).expect("valid world");
    let mut module = Module::new(board, spec, Instant::ZERO);
    let mut out = Vec::new();
    let mut sink = |b: &[u8]| out.extend_from_slice(b);
    let _ = module.execute(Command::Sap { param: 132, motor: 0, value: 1 }, Instant::ZERO);
    let mut now = Instant::ZERO + Duration::from_millis(310);
    module.poll(now, &mut sink);
    let _ = module.execute(Command::Sap { param: 129, motor: 0, value: 1 }, now);
    assert!(module.state().closed_loop().active, "the loop closes after the initialisation");
    let mut always_closed = true;
    for chunk in data.chunks_exact(9) {
        now += Duration::from_micros(100 * u64::from(chunk[0]));
        let value = i32::from_be_bytes([chunk[4], chunk[5], chunk[6], chunk[7]]);
        let instruction = tmcl_wire::Instruction::new(chunk[1].into(), chunk[2], chunk[3], value);
        let _ = module.execute_instruction(now, instruction);
        now += Duration::from_millis(u64::from(chunk[8] % 64));
        let next = module.poll(now, &mut sink);
        assert!(next.is_none_or(|t| t >= now), "a deadline in the past: {next:?} at {now}");
        always_closed &= module.state().closed_loop().active;
        if always_closed {
            assert_eq!(module.board().lost_full_steps(), 0, "the field ran away from the rotor");
        }
    }
    // Stopped and left alone (at the steepest deceleration, so that the stop takes a tick, not seconds
    // at an arbitrary speed), the loop still commutates on the rotor.
    let _ = module.execute(Command::Sap { param: 5, motor: 0, value: i32::MAX }, now);
    let _ = module.execute(Command::Mst { motor: 0 }, now);
    now += Duration::from_millis(300);
    module.poll(now, &mut sink);
    always_closed &= module.state().closed_loop().active;
    if always_closed {
        assert_eq!(module.board().lost_full_steps(), 0, "the field is not on the rotor after a stop");
    }
}

/// The PDx-113's SAC (PDx-113 manual §5.4.3) with arbitrary TMC428 datagrams, mixed with arbitrary
/// commands: every answer is a status of the manual's list and leaves a position the 24-bit counter
/// holds (§5.7.4).
///
/// Input layout: repeated 6-byte chunks `[gap, selector, word (4)]`: `gap` in tenths of a millisecond
/// before the command, then 1..64 ms of motion after it; an even `selector` sends `SAC 0, 4, word`, an
/// odd one the command `word[0]` with type `word[1]`, motor `word[2] % 2` and value `word[3]` − 128 times
/// a few thousand, so moves stay short.
pub fn sac_datagrams(data: &[u8]) {
    let spec = &pd_113::SPEC;
    let mut module = Module::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO);
    let mut now = Instant::ZERO;
    let mut sink = |_: &[u8]| {};
    for chunk in data.chunks_exact(6) {
        now += Duration::from_micros(100 * u64::from(chunk[0]));
        let word = [chunk[2], chunk[3], chunk[4], chunk[5]];
        let instruction = if chunk[1] % 2 == 0 {
            tmcl_wire::Instruction::new(tmcl_wire::Opcode::Sac, 0, 4, i32::from_be_bytes(word))
        } else {
            let value = (i32::from(word[3]) - 128) * (1 + i32::from(chunk[1] >> 1));
            tmcl_wire::Instruction::new(word[0].into(), word[1], word[2] % 2, value)
        };
        match module.execute_instruction(now, instruction) {
            Ok(_) => {}
            Err(status) => assert!(
                matches!(
                    status,
                    Status::InvalidCommand
                        | Status::WrongType
                        | Status::InvalidValue
                        | Status::NotAvailable
                        | Status::EepromLocked
                ),
                "{instruction:?}: {status:?}"
            ),
        }
        now += Duration::from_millis(1 + u64::from(chunk[1] % 64));
        module.poll(now, &mut sink);
        let position = module.ramp().position;
        assert!((-(1 << 23)..(1 << 23)).contains(&position), "position {position} beyond 24 bits");
    }
}

/// The mailbox's answer to one request (and what else fell due with it, which can only be 138 events).
fn check_mailbox_reply(request: &[u8; MAILBOX_LEN], out: &[u8]) {
    assert_eq!(out.len() % MAILBOX_LEN, 0, "mailbox replies come whole: {out:02X?}");
    let value = i32::from_be_bytes([request[4], request[5], request[6], request[7]]);
    let silent = request[1] == 242 || (request[1] == 137 && value == 1234);
    let is_event = |c: &[u8]| (c[2], c[3]) == (128, 138);
    if silent {
        // No reply; a 138 event that fell due since the last poll may go out before the command runs.
        assert!(out.chunks(MAILBOX_LEN).all(is_event), "no reply to {request:02X?}, only events: {out:02X?}");
        return;
    }
    let Some((before, reply)) = out.split_last_chunk::<MAILBOX_LEN>() else {
        panic!("every mailbox request is answered: {request:02X?}");
    };
    for event in before.chunks(MAILBOX_LEN) {
        assert_eq!((event[2], event[3]), (128, 138), "before the reply only 138 events: {out:02X?}");
    }
    // 134 answers with the cell (its opcode where the status would be), 136 type 0 with its string.
    let special = matches!(request[1], 134 | 136);
    let known = !matches!(Status::from(reply[2]), Status::Unknown(_)) && reply[3] == request[1];
    assert!(known || special || reply.iter().all(|b| b.is_ascii_graphic()), "bad mailbox reply {reply:02X?}");
}

fn check_replies(out: &[u8]) {
    assert_eq!(out.len() % FRAME_LEN, 0, "replies come as whole frames");
    for chunk in out.chunks(FRAME_LEN) {
        let frame = ReplyFrame::new_checked(chunk).expect("9 bytes");
        let special = chunk[1..].iter().all(|b| b.is_ascii_alphanumeric());
        assert!(Reply::parse(&frame).is_ok() || special, "bad reply {chunk:02X?}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sac_datagrams_on_a_few_inputs() {
        sac_datagrams(&[]);
        sac_datagrams(&[0, 0, 0x73, 0, 0, 0, 5, 2, 0x06, 0, 0x07, 0xFF, 0, 1, 1, 0, 0, 255]);
        let every_register: Vec<u8> = (0..=255u8).flat_map(|a| [1, 0, a, 0xFF, 0xFF, 0xFF]).collect();
        sac_datagrams(&every_register);
    }

    /// The campaign's find: `A`, backspace, NULs, then a line for module C: echoed while addressed, no
    /// reply.
    #[test]
    fn a_line_that_stops_being_addressed_gets_no_reply() {
        ascii_lines(&[65, 8, 0, 0, 0, 99, 115, 114, 74]);
    }

    /// The campaign's find: a move ends between two mailbox requests, and the second is 242 (no reply):
    /// its output is the 138 event alone.
    #[test]
    fn an_event_before_a_silent_mailbox_request() {
        two_interfaces(&[
            138, 138, 138, 138, 0, 0, 0, 0, 0, 1, 33, 4, 2, 0, 138, 138, 138, 138, 144, 138, 138, 138, 138, 138, 138,
            138, 138, 232, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 0, 0, 1, 33, 4, 2, 138, 138, 144,
            138, 138, 138, 138, 136, 138, 138, 138, 232, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 4, 0,
            0, 0, 0, 1, 33, 4, 2, 0, 0, 103, 15, 3, 0, 3, 3, 0, 0, 0, 9, 3, 0, 0, 0, 0, 0, 0, 0, 40, 128, 128, 128, 0,
            13, 0, 0, 0, 180, 38, 180, 180, 180, 180, 41, 1, 1, 44, 1, 1, 1, 1, 1, 1, 50, 0, 0, 138, 138, 138, 138, 0,
            0, 0, 0, 0, 1, 33, 4, 2, 0, 138, 138, 138, 138, 144, 138, 138, 138, 138, 138, 0, 0, 0, 0, 0, 1, 33, 4, 2,
            0, 138, 138, 138, 138, 144, 138, 138, 138, 138, 138, 138, 138, 138, 232, 138, 138, 138, 138, 138, 138, 138,
            138, 138, 138, 138, 0, 0, 0, 86, 2, 2, 0, 2, 2, 2, 1, 4, 2, 0, 0, 0, 0, 0, 0, 0, 130, 167, 0, 0, 242, 242,
            242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 242, 0, 0,
            0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 251, 251, 251, 251, 141, 251, 38, 114,
            221, 251, 251, 165, 0, 1, 0, 0, 1, 1, 1, 0, 0, 0, 41, 1, 1, 44, 1, 1, 1, 1, 1, 1, 50, 0, 0, 138, 138, 138,
            138, 0, 0, 0, 0, 0, 1, 33, 4, 2, 0, 138, 138, 138, 138, 144, 138, 138, 138, 138, 138, 138, 138, 138, 232,
            138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 0, 0, 1, 33, 4, 2, 138, 138, 144, 138, 138, 138,
            138, 138, 138, 138, 138, 232, 47, 155, 253, 255, 138, 138, 138, 138, 138, 138, 232, 138, 138, 138, 138,
            138, 138, 138, 138, 138, 138, 138, 0, 0, 1, 33, 4, 2, 138, 138, 144, 138, 138, 138, 138, 138, 138, 138,
            138, 232, 170, 155, 253, 255, 255, 138, 138, 138, 138, 138, 138, 4, 0, 0, 0, 0, 1, 33, 4, 2, 0, 0, 172,
            141, 59, 132, 255, 48, 0, 0, 0, 0, 0, 138, 138, 138, 138, 138, 138, 10, 138, 138, 138, 138, 138, 138, 138,
            138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 138, 0, 0, 15, 103, 36, 0, 252,
            0, 0, 2, 0, 103, 15, 36, 0, 252, 0, 0, 2, 138, 138, 138, 138, 103, 15, 3, 0, 3, 3, 0, 0, 0, 9, 3, 138, 138,
            138, 138, 138, 138, 138, 138, 138, 0, 0, 0, 0, 0, 0, 138, 0, 40, 128, 138, 138,
        ]);
    }

    /// The campaign's find: at 1.4 M pps the rotor hits the seizure. The commutation window was centred
    /// on the rotor's predicted position (its last move continued): the field ended more than half a
    /// period ahead of the held rotor, and a rotor following the field fed the prediction — a runaway.
    /// The window is now centred on the measured rotor.
    #[test]
    fn a_rotor_that_hits_the_seizure_at_speed() {
        closed_loop(&[
            48, 128, 42, 30, 0, 0, 0, 0, 0, 135, 135, 135, 135, 135, 135, 135, 135, 135, 135, 135, 135, 135, 203, 150,
            216, 216, 216, 216, 216, 216, 216, 216, 216, 255, 255, 255, 255, 255, 255, 255, 10, 21, 21, 21, 5, 5, 1, 0,
            0, 10, 5, 5, 5, 5, 5, 5, 5, 0, 21, 59, 59, 59, 50, 216, 216, 216, 135, 135, 135, 135, 0, 216, 115, 199, 0,
            0, 0,
        ]);
    }

    /// Found by a structured search: encoder resolution, full steps or microsteps changed while the loop
    /// was closed made the encoder's position jump, and the loop swung the rotor through millions of
    /// microsteps per tick (minutes of computing, and a field off the rotor). Such a change now opens the
    /// loop, and the encoder position carries on.
    #[test]
    fn the_encoder_rescaled_under_a_closed_loop() {
        closed_loop(&[
            15, 5, 210, 0, 0, 0, 5, 137, 53, 3, 6, 140, 0, 0, 2, 8, 160, 54, 39, 2, 126, 0, 255, 255, 144, 107, 45, 24,
            4, 6, 0, 0, 1, 174, 120, 41, 26, 14, 129, 0, 0, 0, 129, 182, 9, 11, 5, 125, 0, 0, 0, 19, 143, 7, 33, 14,
            129, 0, 255, 253, 110, 224, 55, 5, 13, 202, 0, 255, 255, 28, 98, 19,
        ]);
        closed_loop(&[
            0, 4, 114, 0, 0, 2, 151, 97, 48, 8, 2, 111, 0, 255, 253, 216, 230, 0, 12, 14, 202, 0, 255, 253, 78, 157,
            58, 10, 3, 114, 0, 0, 1, 57, 147, 51, 13, 4, 0, 0, 0, 0, 214, 55, 49, 23, 3, 4, 0, 0, 0, 57, 27, 34, 16, 3,
            138, 0, 0, 1, 70, 164, 16, 31, 13, 5, 0, 0, 1, 97, 68, 57, 39, 6, 126, 0, 0, 1, 191, 75, 31, 29, 3, 202, 0,
            255, 253, 161, 125, 19, 35, 5, 0, 0, 255, 253, 32, 138, 56, 33, 1, 2, 0, 0, 2, 220, 181, 26,
        ]);
    }

    /// The second campaign's find: AP 130 (minimum speed) = 39 855 360 and `ROR 989 922 397`, both within
    /// what the model accepts, start the ramp at 39.9 M pps; the loop holds the field within half a
    /// period of the rotor, which turns at the loop's limit (just under two full steps per millisecond).
    /// `AAP 167` with the accumulator at 0 (chopper off time 0: the driver stages off) then freed the
    /// rotor at the ramp's speed instead of the field's, and the freewheeling rotor ran whole electrical
    /// periods ahead of the field.
    #[test]
    fn the_driver_off_frees_the_rotor_at_the_fields_speed() {
        closed_loop(&[
            0, 5, 130, 0, 2, 96, 37, 0, 5, 0, 1, 0, 0, 59, 1, 4, 93, 20, 0, 34, 167, 0, 0, 0, 0, 0, 20, 0, 6, 1, 0, 0,
            0, 0, 0, 30,
        ]);
    }

    /// The `closed_loop` campaign's find on this round's code: the shaft seized (the world's stall fault)
    /// while the loop held the field at the rotor and the ramp ran on at 60 M pps; the driver stages went
    /// off (AAP 167 with A = 0) at the moment the seizure ended. The field had stood over the board's
    /// last update while the step counter moved, which the board took as "moves with the counter" and
    /// handed the freed rotor the ramp's speed: it ran 200 full steps ahead of the field within a
    /// millisecond. A field that stands while the counter moves now stands (speed 0).
    #[test]
    fn a_rotor_freed_after_a_seizure_coasts_at_the_fields_speed_not_the_ramps() {
        closed_loop(&[
            2, 35, 35, 35, 35, 35, 35, 35, 35, 35, 35, 1, 41, 164, 42, 0, 29, 0, 213, 1, 0, 15, 33, 33, 33, 33, 26, 13,
            2, 0, 0, 128, 128, 128, 128, 128, 5, 5, 5, 0, 35, 35, 35, 35, 13, 255, 33, 128, 128, 128, 128, 5, 251, 255,
            0, 1, 0, 0, 0, 0, 0, 255, 0, 9, 34, 167, 0, 29, 0, 213, 1, 0, 90, 90, 90, 90, 90, 90, 90, 90, 90, 90, 90,
            213, 1, 6, 0, 201, 132, 255, 118, 90, 90, 90, 90, 90, 90, 223, 90,
        ]);
    }

    proptest::proptest! {
        #[test]
        fn module_stream_never_panics(data in proptest::collection::vec(proptest::num::u8::ANY, 0..600)) {
            module_stream(&data);
        }

        #[test]
        fn two_interfaces_never_mix(data in proptest::collection::vec(proptest::num::u8::ANY, 0..600)) {
            two_interfaces(&data);
        }

        #[test]
        fn closed_loop_loses_no_step(data in proptest::collection::vec(proptest::num::u8::ANY, 0..270)) {
            closed_loop(&data);
        }

        #[test]
        fn closed_loop_under_motion_commands(
            cmds in proptest::collection::vec((0u8..40, proptest::sample::select(vec![1u8, 2, 3, 4, 5, 6, 13, 14]),
                proptest::sample::select(vec![0u8, 1, 2, 4, 5, 6, 14, 111, 113, 114, 122, 124, 125, 126, 129, 136, 138, 140, 193, 201, 202, 210]),
                -200_000i32..200_000, 0u8..64), 0..30)
        ) {
            let data: Vec<u8> = cmds.iter().flat_map(|(gap, op, t, v, poll)| {
                let v = v.to_be_bytes();
                [*gap, *op, *t, 0, v[0], v[1], v[2], v[3], *poll]
            }).collect();
            closed_loop(&data);
        }

        #[test]
        fn one_frame_never_panics(data in proptest::array::uniform9(proptest::num::u8::ANY)) {
            one_frame(&data);
        }

        #[test]
        fn ascii_lines_never_panic(data in proptest::collection::vec(proptest::num::u8::ANY, 0..300)) {
            ascii_lines(&data);
        }

        #[test]
        fn ascii_lines_of_words(words in proptest::collection::vec("[A-Za-z ,0-9-]{0,12}", 0..20)) {
            ascii_lines(words.join("\r").as_bytes());
        }

        #[test]
        fn arbitrary_programs_stay_bounded(data in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
            program(&data);
        }

        #[test]
        fn valid_frames_of_every_opcode(op in 0u8..=255, t: u8, m: u8, v: i32) {
            let bytes = Request { address: 1, instruction: tmcl_wire::Instruction::new(op.into(), t, m, v) }.to_bytes();
            one_frame(&bytes);
        }
    }
}

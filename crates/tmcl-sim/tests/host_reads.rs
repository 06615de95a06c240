//! The host's reads (GAP, GGP, GIO) take a short way from the frame to the reply (`Module::host_read` in
//! tmcl-core); the dispatcher runs the same arms for them. Here both ways are compared on every model, for
//! every type number and a spread of motor and bank numbers, with the motor turning: the same status and
//! value in every reply, and the same module afterwards.

use tmcl_core::{Instant, Module, Outcome};
use tmcl_sim::SimBoard;
use tmcl_wire::{Command, Instruction, Opcode, Reply, ReplyFrame, Request, Status};

/// Two modules of `spec` started the same way: motor 0 turning, polled to 0.2 s.
fn pair(spec: &'static tmcl_core::model::ModelSpec) -> (Module<SimBoard>, Module<SimBoard>) {
    let start = |_| {
        let mut module = Module::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO);
        let _ = module.execute(Command::Ror { motor: 0, velocity: 300 }, Instant::ZERO);
        module.poll(Instant::from_millis(200), &mut |_: &[u8]| {});
        module
    };
    (start(0), start(1))
}

#[test]
fn a_read_the_short_way_is_the_dispatchers_read() {
    let motors_and_banks: Vec<u8> = (0..=8).chain(250..=255).collect();
    for spec in tmcl_core::model::MODELS {
        let (mut short, mut general) = pair(spec);
        let mut t = Instant::from_millis(200);
        let mut answered = 0;
        for opcode in [Opcode::Gap, Opcode::Ggp, Opcode::Gio] {
            for kind in 0..=255u8 {
                for &motor in &motors_and_banks {
                    t += tmcl_core::Duration::from_micros(1);
                    let instruction = Instruction::new(opcode, kind, motor, 0x0102_0304);
                    // The short way: a frame, as a host sends it.
                    let frame = Request { address: 1, instruction }.to_bytes();
                    let mut out = Vec::new();
                    short.receive(t, &frame, &mut |b: &[u8]| out.extend_from_slice(b));
                    let reply = Reply::parse(&ReplyFrame::new_checked(&out[..]).expect("one reply frame"))
                        .expect("a valid reply");
                    // The dispatcher's way: the decoded command through `Module::execute`.
                    general.poll(t, &mut |_: &[u8]| {});
                    let expected = match Command::decode(instruction).and_then(|c| general.execute(c, t)) {
                        Ok(Outcome::Value(v)) => (Status::Ok, v),
                        Ok(other) => panic!("{spec:?} {instruction:?}: a read gave {other:?}"),
                        Err(status) => (status, instruction.value),
                    };
                    assert_eq!(
                        (reply.status, reply.value),
                        expected,
                        "{} {opcode:?} type {kind} motor/bank {motor}",
                        spec.name
                    );
                    answered += usize::from(reply.status == Status::Ok);
                }
            }
        }
        assert!(answered > 50, "{}: only {answered} reads answered with status 100", spec.name);
        assert_eq!(firmware_state(&short), firmware_state(&general), "{}", spec.name);
        assert_eq!(format!("{:?}", short.vm()), format!("{:?}", general.vm()), "{}", spec.name);
    }
}

/// The module's state but what frames touch and a call without one does not (the interfaces' framers and
/// outboxes, the time of the last command, when each board was last brought up to date): what a read
/// could change besides.
fn firmware_state(module: &Module<SimBoard>) -> String {
    let mut state = format!("{:?}", module.state());
    if let (Some(from), Some(to)) = (state.find(", ports: ["), state.find(", asking_port")) {
        state.replace_range(from..to, "");
    }
    for field in ["last_command: ", "board_time: "] {
        while let Some(at) = state.find(field) {
            let end = state[at..].find('}').map_or(state.len(), |e| at + e + 1);
            state.replace_range(at..end, "");
        }
    }
    state
}

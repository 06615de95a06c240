//! The loop skip's "did anything change" (`tmcl_core`'s `module/spin.rs`): a program spinning in a fixed
//! point needs no poll until something from outside reaches the module. Each write path that reaches it
//! without a host frame — the library calls a simulator, a debugger or a process-data image use — must
//! wake it: before the change counter each one had to remember a hand-placed call, and these did not.

use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::{Duration, Instant, Module, Outcome};
use tmcl_sim::SimBoard;
use tmcl_wire::{Command, Condition};

/// `Loop: <read> / JC ZE, Loop / SIO 0, 2, 1 / STOP`: spins until what `read` loads is not zero.
fn waits_for(read: Command) -> Vec<tmcl_wire::Instruction> {
    [
        read,
        Command::Jc { condition: Condition::Zero, address: 0 },
        Command::Sio { port: 0, bank: 2, value: 1 },
        Command::Stop,
    ]
    .iter()
    .map(Command::encode)
    .collect()
}

/// A module running `program` after `setup`, polled for a second: it spins in its fixed point and says it
/// needs no poll.
fn resting(program: &[tmcl_wire::Instruction], setup: &[Command]) -> (Module<SimBoard>, Instant) {
    let mut m = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    for c in setup {
        m.execute(*c, Instant::ZERO).unwrap();
    }
    m.load_program(program).unwrap();
    m.execute(Command::RunApplication { from: Some(0) }, Instant::ZERO).unwrap();
    let t = Instant::from_secs(1);
    let deadline = m.poll(t, &mut |_: &[u8]| {});
    assert!(deadline.is_none_or(|d| d > t + Duration::from_millis(100)), "the loop rests: {deadline:?}");
    (m, t)
}

/// After a change at `t`, the module wants a poll at once and the program leaves its loop.
fn wakes(mut m: Module<SimBoard>, t: Instant) {
    let deadline = m.poll(t, &mut |_: &[u8]| {});
    assert!(deadline.is_some_and(|d| d <= t + Duration::from_millis(1)), "deadline after the change: {deadline:?}");
    let later = t + Duration::from_millis(1);
    m.poll(later, &mut |_: &[u8]| {});
    let out0 = m.execute(Command::Gio { port: 0, bank: 2 }, later).unwrap();
    assert_eq!(out0, Outcome::Value(1), "the program left its loop");
}

#[test]
fn a_user_variable_set_through_the_library_wakes_a_resting_loop() {
    let (mut m, t) = resting(&waits_for(Command::Ggp { param: 0, bank: 2 }), &[]);
    m.set_global(0, 2, 1, t).unwrap();
    wakes(m, t);
}

#[test]
fn an_axis_parameter_set_through_the_library_wakes_a_resting_loop() {
    // AP 12, right limit switch disable: 0 by default, read back as written.
    let (mut m, t) = resting(&waits_for(Command::Gap { param: 12, motor: 0 }), &[]);
    m.set_axis(12, 1, t).unwrap();
    wakes(m, t);
}

//! The loop skip's "did anything change" (`tmcl_sim::hook`, behind the firmware's hook): a program spinning in a fixed
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

/// The loop skip and the breakpoints now live behind the board's hook (`tmcl_sim::hook`), outside the
/// firmware: a breakpoint set in a resting loop through the board must wake it, and the program stops
/// there, though no host frame reached the module and the firmware knows nothing of breakpoints.
#[test]
fn a_breakpoint_set_in_a_resting_loop_stops_it_there() {
    let (mut m, t) = resting(&waits_for(Command::Ggp { param: 0, bank: 2 }), &[]);
    m.board_mut().breakpoints_mut().set(1, true);
    let deadline = m.poll(t, &mut |_: &[u8]| {});
    assert!(deadline.is_some_and(|d| d <= t + Duration::from_millis(1)), "deadline after the change: {deadline:?}");
    m.poll(t + Duration::from_millis(1), &mut |_: &[u8]| {});
    assert!(m.board().breakpoints().stopped_at(), "stopped at the breakpoint");
    assert_eq!((m.vm().pc, m.vm().state()), (1, tmcl_core::vm::RunState::Stopped));
}

/// A debugger that changes the program machine (its registers, its PC) through the library wakes a
/// resting loop too: the skip's fixed point was found for the machine as it was.
#[test]
fn the_program_machine_changed_through_the_library_wakes_a_resting_loop() {
    let (mut m, t) = resting(&waits_for(Command::Ggp { param: 0, bank: 2 }), &[]);
    m.vm_mut().pc = 2; // past the loop: SIO 0, 2, 1, then STOP
    wakes(m, t);
}

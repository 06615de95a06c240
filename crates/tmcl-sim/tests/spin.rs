//! Programs that never wait and spin in a fixed point (the loop skip, `tmcl_sim::hook`): the manual's busy
//! listings run event-driven exactly as tick by tick, across several polls' worth of instructions (one
//! poll runs at most 2^20, 21 s of module time), an hour of each takes a few polls, and an input timeline
//! reaches the copy loop at the instant it does tick by tick.

use std::time::Instant as WallInstant;
use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::{Duration, Instant, Module};
use tmcl_sim::equivalence::Scenario;
use tmcl_sim::{SimBoard, World};
use tmcl_wire::{CalcOp, Command, Instruction};

/// `tests/programs/manual_p04_copy_inputs.tmc` (§3.7.14): `Loop: GIO 255, 0 / SIO 255, 2, -1 / JA Loop`.
fn p04() -> Vec<Command> {
    vec![
        Command::Gio { port: 255, bank: 0 },
        Command::Sio { port: 255, bank: 2, value: -1 },
        Command::Ja { address: 0 },
    ]
}

/// `tests/programs/manual_p09_vect.tmc` (§3.7.34): `VECT 0, Timer0Irq / Loop: JA Loop / Timer0Irq: SIO 0,
/// 2, 1 / RETI`.
fn p09() -> Vec<Command> {
    vec![
        Command::Vect { interrupt: 0, address: 2 },
        Command::Ja { address: 1 },
        Command::Sio { port: 0, bank: 2, value: 1 },
        Command::Reti,
    ]
}

/// `tests/programs/manual_p10_aap.tmc` (§3.7.29): `Start: GIO 0, 1 / CALC MUL, 4 / AAP 0, 0 / JA Start`.
fn p10() -> Vec<Command> {
    vec![
        Command::Gio { port: 0, bank: 1 },
        Command::Calc { op: CalcOp::Mul, operand: 4 },
        Command::Aap { param: 0, motor: 0 },
        Command::Ja { address: 0 },
    ]
}

/// Inputs IN0 and IN2 high, analog input 0 at 1000.
const WORLD: &str = "[inputs]\ndigital = 5\nanalog = 1000\n";

fn scenario(program: Vec<Command>, world: &str, host: Vec<(Instant, Command)>, end: Instant) -> Scenario {
    Scenario { spec: &SPEC, world: world.to_string(), settings: Vec::new(), program, host, polls: Vec::new(), end }
}

/// A host command at each of `times` that reads the outputs back (its reply is compared too).
fn reads_at(times: &[u64]) -> Vec<(Instant, Command)> {
    times.iter().map(|t| (Instant::from_micros(*t), Command::Gio { port: 255, bank: 2 })).collect()
}

/// 65 s: more than three polls' worth of instructions (3 × 2^20 × 20 µs ≈ 63 s).
const LONG: Instant = Instant::from_secs(65);

#[test]
fn the_copy_loop_runs_as_tick_by_tick() {
    let s = scenario(p04(), WORLD, reads_at(&[21_000_000, 42_000_010, 63_000_030]), LONG);
    s.check().unwrap();
}

#[test]
fn the_vect_spin_runs_as_tick_by_tick() {
    let s = scenario(p09(), WORLD, reads_at(&[21_000_000, 42_000_010]), LONG);
    s.check().unwrap();
}

#[test]
fn the_aap_loop_runs_as_tick_by_tick() {
    let s = scenario(p10(), WORLD, reads_at(&[300_000, 21_000_000, 42_000_010]), LONG);
    s.check().unwrap();
}

/// A loop that waits for the driver's standstill flag (AP 208 bit 7, up 2^20 driver clocks after the last
/// step) after a short move: the flag comes up by itself, with no move and no instruction to say so, so
/// the skip must end where it does and the program leave the loop at the instruction it leaves it tick by
/// tick. (Found by the equivalence property test.)
#[test]
fn a_loop_that_waits_for_the_standstill_flag_runs_as_tick_by_tick() {
    use tmcl_wire::{Condition, MoveTarget, WaitCondition};
    let program = vec![
        Command::Mvp { motor: 0, target: MoveTarget::Rel(2000) },
        Command::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        Command::Gap { param: 208, motor: 0 },
        Command::Calc { op: CalcOp::And, operand: 0x80 },
        Command::Jc { condition: Condition::Zero, address: 2 },
        Command::Sio { port: 0, bank: 2, value: 1 },
        Command::Mvp { motor: 0, target: MoveTarget::Rel(-2000) },
        Command::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        Command::Sio { port: 0, bank: 2, value: 0 },
        Command::Ja { address: 2 },
    ];
    let s = scenario(program, WORLD, reads_at(&[500_000, 1_000_013, 2_500_000]), Instant::from_secs(5));
    s.check().unwrap();
}

/// The copy loop with the timer interrupt of the VECT example switched on (every 700 ms the handler sets
/// OUT0, the loop copies the inputs over it again): the skips end before each timer.
#[test]
fn the_copy_loop_with_a_timer_runs_as_tick_by_tick() {
    let mut program = p04();
    program.splice(
        0..0,
        [
            Command::Vect { interrupt: 0, address: 7 },
            Command::Sgp { param: 0, bank: 3, value: 700 },
            Command::Ei { interrupt: 0 },
            Command::Ei { interrupt: 255 },
        ],
    );
    // Loop at 4..=6, the handler at 7.
    program[6] = Command::Ja { address: 4 };
    program.extend([Command::Sio { port: 0, bank: 2, value: 1 }, Command::Reti]);
    let s = scenario(program, "[inputs]\ndigital = 4\n", reads_at(&[700_000, 700_990, 1_400_500, 20_000_000]), LONG);
    s.check().unwrap();
}

/// The input timeline: the inputs change at odd instants; the copy loop's outputs follow at the same
/// instruction as tick by tick (the host reads them back just before, at and after each change).
#[test]
fn an_input_timeline_reaches_the_copy_loop_at_its_instant() {
    let changes = [10_000_030u64, 30_500_000, 50_000_010];
    let mut world = String::from("[inputs]\ndigital = 1\n");
    for (t, d) in changes.iter().zip([2, 3, 0]) {
        world += &format!("[[inputs.timeline]]\nat = \"{t} us\"\ndigital = {d}\n");
    }
    let mut reads = Vec::new();
    for t in changes {
        reads.extend([t - 1000, t - 1, t, t + 20, t + 40, t + 60, t + 100, t + 5000]);
    }
    let s = scenario(p04(), &world, reads_at(&reads), LONG);
    s.check().unwrap();
    // And what the outputs are, event-driven, polled as a runner polls: at the timeline's entries.
    let mut m = module(&p04(), &world);
    let mut t = Instant::ZERO;
    let mut seen = Vec::new();
    let probes: Vec<Instant> = changes.iter().flat_map(|c| [*c - 1, *c + 100]).map(Instant::from_micros).collect();
    for probe in probes {
        while t < probe {
            let next = m.board().next_event().filter(|e| *e > t && *e < probe).unwrap_or(probe);
            m.poll(next, &mut |_: &[u8]| {});
            m.board_timeline().advance(next);
            t = next;
        }
        seen.push(m.board().outputs());
    }
    // Before each change the old inputs (masked to OUT0, OUT1), 100 µs after it the new ones.
    assert_eq!(seen, [1, 2, 2, 3, 3, 0]);
}

/// A module running `program` from 0 in `world`, event-driven.
fn module(program: &[Command], world: &str) -> Module<SimBoard> {
    let board = SimBoard::in_memory_for(&SPEC).with_world(World::from_toml_str(world).unwrap()).unwrap();
    let mut m = Module::new(board, &SPEC, Instant::ZERO);
    let cells: Vec<Instruction> = program.iter().map(|c| c.encode()).collect();
    m.load_program(&cells).unwrap();
    m.execute(Command::RunApplication { from: Some(0) }, Instant::ZERO).unwrap();
    m
}

/// An hour of each listing, event-driven, polled at its deadlines: every one of the 180 000 001
/// instructions counted (one at every 20 µs from 0 to 3600 s), in a handful of polls.
#[test]
fn an_hour_of_each_busy_listing_takes_a_few_polls() {
    let hour = Instant::from_secs(3600);
    // (program, pc after the last instruction, A, outputs, position)
    let cases = [(p04(), 1, 5, 1, 0), (p09(), 1, 0, 0, 0), (p10(), 1, 1000, 0, 4000)];
    for (program, pc, a, outputs, position) in cases {
        let started = WallInstant::now();
        let mut m = module(&program, WORLD);
        let mut t = Instant::ZERO;
        let mut polls = 0;
        while t < hour {
            let deadline = m.poll(t, &mut |_: &[u8]| {});
            polls += 1;
            // A deadline that is due: on at the next tick, as `tmcl run` does; none: at the end.
            t = match deadline {
                Some(d) if d > t => d.min(hour),
                Some(_) => t + Duration::from_millis(1),
                None => hour,
            };
        }
        m.poll(hour, &mut |_: &[u8]| {});
        let wall = started.elapsed();
        assert_eq!(m.vm().executed(), 180_000_001, "{program:?}");
        assert_eq!(m.vm().pc, pc, "{program:?}");
        assert_eq!(m.registers().accumulator, a, "{program:?}");
        assert_eq!(m.board().outputs(), outputs, "{program:?}");
        assert_eq!(m.ramp().position, position, "{program:?}");
        // p10's move to 4000 (some 25 000 instructions, each a deadline while the axis moves), then the loop
        // stands: a handful.
        assert!(polls < 40_000, "{program:?}: {polls} polls");
        // Tick by tick an hour is 180 million instructions, minutes in a debug build.
        assert!(wall.as_secs() < 20, "{program:?}: {wall:?}");
    }
}

//! Axes as data: the three-axis test model (`tmcl_model::test_three_axes`) in direct mode, running a
//! program and taking interrupts on every axis, on a board with a motor and switches per axis.

use super::RamNvm;
use crate::hal::{
    Analog, DriveState, EncoderCounter, Inputs, LoadSensor, Nvm, Outputs, Quiet, StepDriver, SwitchInputs, Switches,
};
use crate::model::test_three_axes::SPEC;
use crate::param::persist;
use crate::time::{Duration, Instant};
use crate::vm::RunState;
use crate::Module;
use std::vec::Vec;
use tmcl_wire::{
    Command, EventMode, Instruction, MoveTarget, Opcode, Reply, ReplyFrame, Request, Status, WaitCondition,
};

const MOTORS: usize = 3;

/// One ideal motor: the physical position integrates the steps; a right stop switch from `right_from`.
#[derive(Debug, Clone, Default)]
struct Motor {
    drive: DriveState,
    /// Physical position in 1/256 microsteps.
    physical: i64,
    /// The right stop switch reads pressed at or beyond this physical position.
    right_from: Option<i64>,
    updates: usize,
}

/// A board with a motor, switches and an encoder per axis; quiet for good (so that the module may take
/// its shortcuts) unless `quiet` is off.
#[derive(Debug, Clone)]
struct AxesBoard {
    nvm: RamNvm,
    motors: [Motor; MOTORS],
    quiet: bool,
}

impl AxesBoard {
    fn new(quiet: bool) -> AxesBoard {
        AxesBoard {
            nvm: RamNvm { bytes: std::vec![0xFF; persist::capacity(&SPEC)], fail_writes: false, writes: 0 },
            motors: Default::default(),
            quiet,
        }
    }
}

impl Nvm for AxesBoard {
    type Error = ();
    fn capacity(&self) -> usize {
        self.nvm.capacity()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), ()> {
        self.nvm.read(offset, buf)
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), ()> {
        self.nvm.write(offset, data)
    }
}

impl Inputs for AxesBoard {
    fn digital_inputs(&mut self) -> u8 {
        0
    }
}

impl Outputs for AxesBoard {
    fn set_outputs(&mut self, _: u8) {}
}

impl Analog for AxesBoard {
    fn analog_input(&mut self, _: u8) -> u16 {
        0
    }
    fn temperature(&mut self) -> i32 {
        25
    }
}

impl SwitchInputs for AxesBoard {
    fn switches(&mut self, motor: usize) -> Switches {
        let m = &self.motors[motor];
        Switches { left: false, right: m.right_from.is_some_and(|r| m.physical >= r), home: false }
    }
}

impl crate::hal::Hook for AxesBoard {}

impl StepDriver for AxesBoard {
    fn update(&mut self, motor: usize, _: Instant, state: &DriveState) {
        let m = &mut self.motors[motor];
        m.physical += state.moved << (8 - state.resolution.min(8));
        m.drive = *state;
        m.updates += 1;
    }

    fn quiet(&mut self, motor: usize, _: Instant, state: &DriveState) -> Option<Quiet> {
        if !self.quiet {
            return None;
        }
        let m = &self.motors[motor];
        // Quiet up to the switch (in the current resolution's microsteps), for good in time.
        let scale = 1i64 << (8 - state.resolution.min(8));
        let forward = m.right_from.map_or(u64::MAX / 2, |r| ((r - m.physical).max(1) / scale) as u64);
        Some(Quiet { until: None, forward, backward: u64::MAX / 2, min_speed: 0, max_speed: u32::MAX, load: 1023 })
    }
}

impl LoadSensor for AxesBoard {}

impl EncoderCounter for AxesBoard {
    fn encoder_counts(&mut self, motor: usize) -> i64 {
        self.motors[motor].physical.div_euclid(50)
    }
}

struct Bench {
    module: Module<AxesBoard>,
    now: Instant,
    out: Vec<u8>,
}

impl Bench {
    fn new() -> Bench {
        Bench::with(AxesBoard::new(true), false)
    }

    fn with(board: AxesBoard, exact: bool) -> Bench {
        let now = Instant::from_secs(1);
        let mut module = Module::new(board, &SPEC, now);
        module.set_exact_ticks(exact);
        Bench { module, now, out: Vec::new() }
    }

    fn send(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> Reply {
        let frame = Request { address: 1, instruction: Instruction::new(op, t, m, v) }.to_bytes();
        let mut out = Vec::new();
        self.module.receive(self.now, &frame, &mut |b: &[u8]| out.extend_from_slice(b));
        assert_eq!(out.len(), 9, "{out:02X?}");
        Reply::parse(&ReplyFrame::new_checked(&out[..]).unwrap()).unwrap()
    }

    fn cmd(&mut self, c: Command) -> (Status, i32) {
        let i = c.encode();
        let r = self.send(i.opcode, i.kind, i.motor, i.value);
        (r.status, r.value)
    }

    fn gap(&mut self, n: u8, motor: u8) -> i32 {
        let (s, v) = self.cmd(Command::Gap { param: n, motor });
        assert_eq!(s, Status::Ok, "GAP {n}, {motor}");
        v
    }

    fn run(&mut self, d: Duration) {
        let end = self.now + d;
        let mut out = Vec::new();
        while let Some(t) = self.module.poll(self.now, &mut |b: &[u8]| out.extend_from_slice(b)) {
            if t > end {
                break;
            }
            self.now = t.max(self.now + Duration::from_micros(1));
        }
        self.now = end;
        self.module.poll(self.now, &mut |b: &[u8]| out.extend_from_slice(b));
        self.out.extend_from_slice(&out);
    }
}

fn mvp(motor: u8, to: i32) -> Command {
    Command::Mvp { motor, target: MoveTarget::Abs(to) }
}

#[test]
fn direct_mode_addresses_each_motor_and_refuses_a_fourth() {
    let mut b = Bench::new();
    assert_eq!(b.module.motors(), 3);
    // Each motor its own maximum speed (AP 4) and target.
    for (m, speed) in [(0u8, 1000), (1, 2000), (2, 4000)] {
        assert_eq!(b.cmd(Command::Sap { param: 4, motor: m, value: speed }), (Status::Ok, speed));
        assert_eq!(b.cmd(Command::Sap { param: 5, motor: m, value: 100_000 }).0, Status::Ok);
    }
    for (m, to) in [(0u8, 1000), (1, -2000), (2, 3000)] {
        assert_eq!(b.cmd(mvp(m, to)), (Status::Ok, to));
    }
    // §3.5: the motor byte names a motor of the module; one the model lacks is status 4 (invalid value).
    for c in [
        mvp(3, 10),
        Command::Gap { param: 1, motor: 3 },
        Command::Sap { param: 4, motor: 3, value: 1 },
        Command::Ror { motor: 6, velocity: 1 },
        Command::Mst { motor: 3 },
        Command::Stap { param: 4, motor: 3 },
    ] {
        assert_eq!(b.cmd(c).0, Status::InvalidValue, "{c:?}");
    }
    b.run(Duration::from_secs(3));
    for (m, to, speed) in [(0u8, 1000, 1000), (1, -2000, 2000), (2, 3000, 4000)] {
        assert_eq!(b.gap(1, m), to, "motor {m} at its target");
        assert_eq!(b.gap(8, m), 1, "motor {m}: position reached");
        assert_eq!(b.gap(4, m), speed);
        let physical = b.module.board().motors[usize::from(m)].physical;
        assert_eq!(physical, i64::from(to), "motor {m}'s own driver moved (256 microsteps: 1:1)");
    }
    // The ramps are the motors' own: ROR on motor 1 leaves 0 and 2 standing.
    assert_eq!(b.cmd(Command::Ror { motor: 1, velocity: 500 }).0, Status::Ok);
    b.run(Duration::from_millis(100));
    assert_eq!((b.gap(3, 0), b.gap(3, 2)), (0, 0));
    assert!(b.gap(3, 1) > 0);
    assert_eq!(b.cmd(Command::Mst { motor: 1 }).0, Status::Ok);
    b.run(Duration::from_secs(1));
    assert_eq!(b.gap(3, 1), 0);
}

#[test]
fn each_motor_stores_its_own_parameters_and_coordinates() {
    let mut b = Bench::new();
    for m in 0..3u8 {
        let v = 100 + i32::from(m);
        assert_eq!(b.cmd(Command::Sap { param: 4, motor: m, value: v }).0, Status::Ok);
        assert_eq!(b.cmd(Command::Stap { param: 4, motor: m }).0, Status::Ok);
        assert_eq!(b.cmd(Command::Sco { coord: 1, motor: m, position: -v }).0, Status::Ok);
    }
    // SCO 1, 255: every motor's coordinate 1 into the EEPROM.
    assert_eq!(b.cmd(Command::Sco { coord: 1, motor: 255, position: 0 }).0, Status::Ok);
    let board = b.module.board().clone();
    b.module = Module::new(board, &SPEC, b.now);
    for m in 0..3u8 {
        assert_eq!(b.gap(4, m), 100 + i32::from(m), "motor {m}'s AP 4 restored from its own slot");
        assert_eq!(b.cmd(Command::Gco { coord: 1, motor: m }), (Status::Ok, 0), "RAM coordinates start at 0");
    }
    assert_eq!(b.cmd(Command::Gco { coord: 1, motor: 255 }).0, Status::Ok);
    for m in 0..3u8 {
        assert_eq!(b.cmd(Command::Gco { coord: 1, motor: m }), (Status::Ok, -100 - i32::from(m)));
    }
}

/// A program that moves each motor in turn, waiting for each (WAIT POS, motor byte), then all three at
/// once; the target-reached interrupt of each motor counts in its own user variable.
fn program() -> Vec<Instruction> {
    use Command as C;
    let mut p: Vec<Command> = std::vec![
        C::Vect { interrupt: 3, address: 0 }, // patched below: the handlers' addresses
        C::Vect { interrupt: 4, address: 0 },
        C::Vect { interrupt: 5, address: 0 },
        C::Ei { interrupt: 3 },
        C::Ei { interrupt: 4 },
        C::Ei { interrupt: 5 },
        C::Ei { interrupt: 255 },
    ];
    for m in 0..3u8 {
        p.push(C::Sap { param: 4, motor: m, value: 2000 });
        p.push(mvp(m, 1000 * (i32::from(m) + 1)));
        p.push(C::Wait { condition: WaitCondition::Pos, motor: m, ticks: 0 });
    }
    for m in 0..3u8 {
        p.push(mvp(m, 0));
    }
    for m in 0..3u8 {
        p.push(C::Wait { condition: WaitCondition::Pos, motor: m, ticks: 0 });
    }
    p.push(C::Stop);
    let handlers = p.len();
    for m in 0..3u8 {
        p.push(C::Ggp { param: m, bank: 2 });
        p.push(C::Calc { op: tmcl_wire::CalcOp::Add, operand: 1 });
        p.push(C::Agp { param: m, bank: 2 });
        p.push(C::Reti);
    }
    for (i, m) in (0..3).enumerate() {
        p[i] = C::Vect { interrupt: 3 + m, address: (handlers + 4 * usize::from(m)) as i32 };
    }
    p.into_iter().map(|c| c.encode()).collect()
}

fn run_program(exact: bool) -> Bench {
    let mut b = Bench::with(AxesBoard::new(true), exact);
    b.module.load_program(&program()).unwrap();
    assert_eq!(b.cmd(Command::RunApplication { from: Some(0) }).0, Status::Ok);
    b.run(Duration::from_secs(10));
    b
}

#[test]
fn a_program_moves_every_axis_and_takes_each_axis_interrupt() {
    let mut b = run_program(false);
    assert_eq!(b.module.vm().state(), RunState::Stopped, "the program ran to its STOP");
    for m in 0..3u8 {
        assert_eq!(b.gap(1, m), 0, "motor {m} back at 0");
        // Each motor reached a target twice: its own move, and the move back (all three at once).
        assert_eq!(b.cmd(Command::Ggp { param: m, bank: 2 }), (Status::Ok, 2), "interrupt {} twice", 3 + m);
        assert!(b.module.board().motors[usize::from(m)].updates > 0);
    }
}

#[test]
fn three_axes_event_driven_as_tick_by_tick() {
    let mut spans = run_program(false);
    let mut exact = run_program(true);
    assert_eq!(spans.module.state().axes(), exact.module.state().axes());
    for m in 0..MOTORS {
        assert_eq!(spans.module.board().motors[m].physical, exact.module.board().motors[m].physical);
        assert_eq!(spans.module.board().motors[m].drive, exact.module.board().motors[m].drive);
    }
    assert_eq!(spans.module.vm().executed, exact.module.vm().executed);
    for m in 0..3u8 {
        assert_eq!(spans.cmd(Command::Ggp { param: m, bank: 2 }), exact.cmd(Command::Ggp { param: m, bank: 2 }));
    }
}

#[test]
fn a_stop_switch_stops_its_own_motor_and_raises_its_own_vector() {
    let mut board = AxesBoard::new(true);
    // Motor 2's right stop switch at 500 microsteps; motors 0 and 1 have none.
    board.motors[2].right_from = Some(500);
    let mut b = Bench::with(board, false);
    use Command as C;
    let p: Vec<Instruction> = [
        C::Vect { interrupt: 32, address: 8 },
        C::Sgp { param: 32, bank: 3, value: 1 }, // low → high
        C::Ei { interrupt: 32 },
        C::Ei { interrupt: 255 },
        C::Ror { motor: 2, velocity: 1000 },
        C::Ror { motor: 0, velocity: 1000 },
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 200 },
        C::Stop,
        // 8: the handler counts in user variable 9.
        C::Ggp { param: 9, bank: 2 },
        C::Calc { op: tmcl_wire::CalcOp::Add, operand: 1 },
        C::Agp { param: 9, bank: 2 },
        C::Reti,
    ]
    .into_iter()
    .map(|c| c.encode())
    .collect();
    b.module.load_program(&p).unwrap();
    assert_eq!(b.cmd(Command::RunApplication { from: Some(0) }).0, Status::Ok);
    b.run(Duration::from_secs(3));
    assert_eq!(b.cmd(Command::Ggp { param: 9, bank: 2 }), (Status::Ok, 1), "vector 32: motor 2's right switch");
    assert_eq!(b.gap(10, 2), 1, "AP 10: motor 2's right switch pressed");
    assert_eq!(b.gap(10, 0), 0);
    assert_eq!(b.gap(3, 2), 0, "motor 2 stopped at its switch");
    assert!(b.gap(3, 0) > 0, "motor 0 goes on");
}

#[test]
fn the_event_of_138_waits_for_every_motor_of_its_mask() {
    let mut b = Bench::new();
    assert_eq!(
        b.cmd(Command::RequestTargetReachedEvent { mode: EventMode::Every, mask: 0b1000 }).0,
        Status::InvalidValue
    );
    assert_eq!(b.cmd(Command::RequestTargetReachedEvent { mode: EventMode::Every, mask: 0b101 }).0, Status::Ok);
    b.cmd(Command::Sap { param: 4, motor: 2, value: 200 });
    b.cmd(mvp(0, 100));
    b.cmd(mvp(2, 400));
    b.out.clear();
    b.run(Duration::from_millis(800));
    assert!(b.out.is_empty(), "motor 2 not there yet: {:02X?}", b.out);
    b.run(Duration::from_secs(3));
    assert_eq!(b.out.len(), 9, "one event: {:02X?}", b.out);
    assert_eq!(b.out[2], u8::from(Status::TargetReached));
}

//! The drive features of the firmware on simulated mechanics (PD28-1021 manual §6.2, §7.2, §7.3, AP 168–215,
//! interrupts 15 and 21): stop on stall, coolStep, the encoder's deviation check, through the whole
//! module as a host or a program sees them.

use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::module::flags;
use tmcl_core::param::persist;
use tmcl_core::{Duration, Instant, Module};
use tmcl_sim::{SimBoard, World};
use tmcl_wire::{CalcOp, Command, Condition, Instruction, MoveTarget};

struct Bench {
    m: Module<SimBoard>,
    now: Instant,
}

impl Bench {
    fn new(world: &str) -> Bench {
        let world = World::from_toml_str(world).expect("world");
        let board = SimBoard::in_memory(persist::capacity(&SPEC)).with_world(world).expect("board");
        Bench { m: Module::new(board, &SPEC, Instant::ZERO), now: Instant::ZERO }
    }

    fn cmd(&mut self, c: Command) -> i32 {
        match self.m.execute(c, self.now) {
            Ok(tmcl_core::Outcome::Value(v)) => v,
            other => panic!("{c:?}: {other:?}"),
        }
    }

    fn sap(&mut self, n: u8, v: i32) {
        self.cmd(Command::Sap { param: n, motor: 0, value: v });
    }

    fn gap(&mut self, n: u8) -> i32 {
        self.cmd(Command::Gap { param: n, motor: 0 })
    }

    fn run(&mut self, ms: u64) {
        let end = self.now + Duration::from_millis(ms);
        while self.now < end {
            self.now = (self.now + Duration::from_millis(1)).min(end);
            self.m.poll(self.now, &mut |_: &[u8]| {});
        }
    }

    fn program(&mut self, commands: &[Command]) {
        let cells: Vec<Instruction> = commands.iter().map(Command::encode).collect();
        self.m.load_program(&cells).unwrap();
        self.cmd(Command::RunApplication { from: Some(0) });
    }
}

/// A linear axis (2 mm lead: 1 mm = 25600 µsteps) that jams solid at 2 mm.
const JAM: &str = r#"
[axis]
kind = "linear"
lead = 2.0
[load]
friction = 0.002
[[load.jam]]
at = [2.0, 2.5]
torque = 100.0
"#;

#[test]
fn a_jam_stops_the_motor_above_ap_181() {
    let mut b = Bench::new(JAM);
    b.sap(181, 20_000);
    b.cmd(Command::Ror { motor: 0, velocity: 51_200 });
    b.run(2500);
    assert_eq!(b.gap(3), 0, "stopped by stallGuard2");
    assert_eq!(b.gap(207) & 1, 1, "AP 207: stallGuard error");
    assert_eq!(b.gap(207), 0, "cleared by reading");
    // The shaft stands at the jam (2 mm = 51200 µsteps), give or take the last steps before the stop.
    let shaft = b.m.board().shaft();
    assert!((50_000..54_000).contains(&shaft), "{shaft}");
}

#[test]
fn below_ap_181_the_motor_is_not_stopped() {
    let mut b = Bench::new(JAM);
    b.sap(181, 60_000);
    b.cmd(Command::Ror { motor: 0, velocity: 51_200 });
    b.run(2500);
    assert_eq!(b.gap(3), 51_200, "still commanded, though the rotor is jammed");
    assert_eq!(b.gap(207), 0);
    assert!(b.gap(1) > 100_000, "AP 1 runs on");
    assert!(b.m.board().shaft() < 54_000, "the shaft does not");
}

#[test]
fn stall_interrupt_in_a_program() {
    let mut b = Bench::new(JAM);
    b.sap(181, 20_000);
    b.program(&[
        Command::Vect { interrupt: 15, address: 5 },
        Command::Ei { interrupt: 15 },
        Command::Ei { interrupt: 255 },
        Command::Ror { motor: 0, velocity: 51_200 },
        Command::Ja { address: 4 },
        Command::Calc { op: CalcOp::Load, operand: 15 }, // 5: handler
        Command::Agp { param: 0, bank: 2 },
        Command::Reti,
    ]);
    b.run(2500);
    assert_eq!(b.cmd(Command::Ggp { param: 0, bank: 2 }), 15, "interrupt 15 ran");
    assert_eq!(b.gap(3), 0);
}

/// A free axis whose load steps up at 3 s (the coolStep run).
const LOAD_STEP: &str = r#"
[load]
friction = 0.002
[[load.script]]
at = 3.0
torque = 0.04
"#;

fn coolstep_run(on: bool) -> (Vec<i32>, f64) {
    let mut b = Bench::new(LOAD_STEP);
    b.sap(6, 255);
    if on {
        for (n, v) in [(168, 0), (169, 3), (170, 2), (171, 2), (172, 3), (182, 10_000), (173, 0)] {
            b.sap(n, v);
        }
    }
    b.cmd(Command::Ror { motor: 0, velocity: 51_200 });
    let mut scales = Vec::new();
    for _ in 0..6 {
        b.run(1000);
        scales.push(b.gap(180));
    }
    (scales, b.m.board().energy())
}

#[test]
fn coolstep_lowers_the_current_under_light_load_and_raises_it_under_load() {
    let (with, energy_with) = coolstep_run(true);
    let (without, energy_without) = coolstep_run(false);
    assert!(without.iter().all(|&s| s == 31), "{without:?}");
    assert!(with[2] < 31, "light load: current lowered {with:?}");
    assert!(with[5] > with[2], "heavy load from 3 s: current raised {with:?}");
    assert!(energy_with < energy_without, "{energy_with} vs {energy_without}");
}

#[test]
fn encoder_slip_beyond_ap_212_stops_the_motor_and_sets_edv() {
    let slip = r#"
[[faults.encoder_slip]]
at = 1.0
counts = -40
"#;
    let mut b = Bench::new(slip);
    b.sap(212, 1000); // 40 counts × 50 = 2000 µsteps of deviation
    b.program(&[
        Command::Vect { interrupt: 21, address: 5 },
        Command::Ei { interrupt: 21 },
        Command::Ei { interrupt: 255 },
        Command::Ror { motor: 0, velocity: 25_600 },
        Command::Ja { address: 4 },
        Command::Jc { condition: Condition::Deviation, address: 7 }, // 5: handler
        Command::Reti,
        Command::Calc { op: CalcOp::Load, operand: 21 }, // 7
        Command::Agp { param: 1, bank: 2 },
        Command::Reti,
    ]);
    b.run(900);
    assert!(b.gap(3) > 0 && (b.gap(1) - b.gap(209)).abs() < 100, "tracking before the slip");
    b.run(300);
    assert_eq!(b.gap(3), 0, "stopped by the deviation check");
    assert_eq!(b.gap(207) & 2, 2);
    assert_eq!(b.cmd(Command::Ggp { param: 1, bank: 2 }), 21, "interrupt 21 saw EDV");
    assert_ne!(b.m.registers().flags & flags::DEVIATION, 0);
}

#[test]
fn table_20_prescalers_follow_a_free_axis() {
    for (res, p) in [(8, 25600), (7, 12800), (6, 6400), (5, 3200), (4, 1600), (3, 800), (2, 400), (1, 200)] {
        let mut b = Bench::new("");
        b.sap(140, res);
        b.sap(210, p);
        let target = 5 * (200 << res) + 7;
        b.cmd(Command::Mvp { motor: 0, target: MoveTarget::Abs(target) });
        b.run(12_000);
        assert_eq!(b.gap(1), target);
        let e = b.gap(209);
        assert!((e - target).abs() <= (1 << res) / 4 + 1, "AP 140 = {res}: encoder {e}, steps {target}");
    }
}

#[test]
fn after_a_stall_stop_the_motor_holds_then_goes_to_standby() {
    let mut b = Bench::new(JAM);
    b.sap(181, 20_000);
    b.sap(6, 200);
    b.sap(7, 40);
    b.cmd(Command::Ror { motor: 0, velocity: 51_200 });
    b.run(2500);
    assert_eq!(b.gap(3), 0, "stopped by stallGuard2");
    assert_eq!(b.m.board().drive().current, 200, "holding with the run current after the stop");
    b.run(2100);
    assert_eq!(b.m.board().drive().current, 40, "standby current after AP 214");
}

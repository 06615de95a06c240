//! Reference search (PD28-1021 manual §7.1, Table 21, AP 193–197) on worlds with known switch positions:
//! every mode and variant ends with its zero exactly where the decisions in `motion/reference.rs` put
//! it, to the microstep.

use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::param::persist;
use tmcl_core::{Duration, Instant, Module, Outcome};
use tmcl_sim::{SimBoard, World};
use tmcl_wire::{Command, RfsAction};

struct Search {
    m: Module<SimBoard>,
    now: Instant,
}

impl Search {
    fn on(world: &str) -> Search {
        let world = World::from_toml_str(world).expect("world");
        let board = SimBoard::in_memory(persist::capacity(&SPEC)).with_world(world).expect("board");
        let mut s = Search { m: Module::new(board, &SPEC, Instant::ZERO), now: Instant::ZERO };
        s.sap(194, 51_200);
        s.sap(195, 2_000);
        s
    }

    fn cmd(&mut self, c: Command) -> i32 {
        match self.m.execute(c, self.now) {
            Ok(Outcome::Value(v)) => v,
            other => panic!("{c:?}: {other:?}"),
        }
    }

    fn sap(&mut self, n: u8, v: i32) {
        self.cmd(Command::Sap { param: n, motor: 0, value: v });
    }

    fn gap(&mut self, n: u8) -> i32 {
        self.cmd(Command::Gap { param: n, motor: 0 })
    }

    /// Runs mode `mode` to its end (at most `secs`); returns the shaft position (µsteps) of the new zero.
    fn run(&mut self, mode: i32, secs: u64) -> Option<i64> {
        self.sap(193, mode);
        self.cmd(Command::Rfs { action: RfsAction::Start, motor: 0 });
        for _ in 0..secs * 10 {
            self.now += Duration::from_millis(100);
            self.m.poll(self.now, &mut |_: &[u8]| {});
            if self.cmd(Command::Rfs { action: RfsAction::Status, motor: 0 }) == 0 {
                return Some(self.m.board().shaft() - i64::from(self.gap(1)));
            }
        }
        None
    }
}

/// A long linear axis (2 mm lead); positions in µsteps of the shaft (AP 140 = 8: one per count).
fn world(left: &str, right: &str, home: &str) -> String {
    let mut w = String::from("[axis]\nkind = \"linear\"\nlead = 2.0\n");
    for (name, at) in [("left", left), ("right", right), ("home", home)] {
        if !at.is_empty() {
            w += &format!("[switches.{name}]\nat = {at}\n");
        }
    }
    w
}

const FAR: &str = "1000000 usteps";

fn ends() -> String {
    world(&format!("[\"-{FAR}\", \"-10000 usteps\"]"), &format!("[\"30000 usteps\", \"{FAR}\"]"), "")
}

#[test]
fn mode_1_zero_at_the_left_switch_edge() {
    let mut s = Search::on(&ends());
    assert_eq!(s.run(1, 30), Some(-10_000));
    // AP 197: the counter just before it was zeroed (it started at 0 at the shaft's 0).
    assert_eq!(s.gap(197), -10_000);
    assert_eq!((s.gap(1), s.gap(3)), (0, 0), "stands at its new zero");
}

#[test]
fn mode_65_zero_at_the_right_switch_edge() {
    let mut s = Search::on(&ends());
    assert_eq!(s.run(65, 30), Some(30_000));
}

#[test]
fn mode_2_and_66_measure_the_switch_distance() {
    let mut s = Search::on(&ends());
    assert_eq!(s.run(2, 30), Some(-10_000));
    assert_eq!(s.gap(196), 40_000, "AP 196: right switch to the left one");
    let mut s = Search::on(&ends());
    assert_eq!(s.run(66, 30), Some(30_000));
    assert_eq!(s.gap(196), -40_000);
}

/// Reference switches of finite width: left −11000..−9000, right 19000..21000.
fn flags() -> String {
    world("[\"-11000 usteps\", \"-9000 usteps\"]", "[\"19000 usteps\", \"21000 usteps\"]", "")
}

#[test]
fn modes_3_4_67_68_zero_in_the_middle_of_the_switch() {
    for (mode, zero) in [(3, -10_000), (4, -10_000), (67, 20_000), (68, 20_000)] {
        let mut s = Search::on(&flags());
        assert_eq!(s.run(mode, 30), Some(zero), "mode {mode}");
    }
    let mut s = Search::on(&flags());
    s.run(3, 30);
    assert_eq!(s.gap(196), 19_000 + 10_000, "mode 3: right switch to the middle of the left one");
}

fn homed(active: &str) -> String {
    let mut w = world(&format!("[\"-{FAR}\", \"-50000 usteps\"]"), &format!("[\"50000 usteps\", \"{FAR}\"]"), "");
    w += &format!("[switches.home]\nat = [\"-20500 usteps\", \"-19500 usteps\"]\nactive = \"{active}\"\n");
    w
}

#[test]
fn modes_5_to_8_zero_in_the_middle_of_home() {
    // 5: negative; 6: positive, reversing at the right switch; 8: negative (Table 21; §7.1.8's "positive" is copied from mode 7), ends ignored.
    for mode in [5, 6, 8] {
        let mut s = Search::on(&homed("high"));
        assert_eq!(s.run(mode, 30), Some(-20_000), "mode {mode}");
    }
    // 7: positive with the end switches ignored: home on the positive side.
    let mut w = world("", "", "");
    w += "[switches.home]\nat = [\"39000 usteps\", \"41000 usteps\"]\n";
    let mut s = Search::on(&w);
    assert_eq!(s.run(7, 30), Some(40_000));
}

#[test]
fn inverted_home_plus_128_and_the_printed_aliases() {
    // A normally-closed home switch: +128 (133..136), and the 129..132 that §7.1.5–7.1.8 print for the inverted modes 5..8.
    for mode in [133, 134, 136, 129, 130, 132] {
        let mut s = Search::on(&homed("low"));
        assert_eq!(s.run(mode, 30), Some(-20_000), "mode {mode}");
    }
}

#[test]
fn a_switch_that_is_never_found() {
    // Mode 1 on an axis without switches searches until RFS STOP, as on the module.
    let mut s = Search::on(&world("", "", ""));
    assert_eq!(s.run(1, 5), None);
    assert_ne!(s.gap(3), 0);
    s.cmd(Command::Rfs { action: RfsAction::Stop, motor: 0 });
    s.now += Duration::from_secs(3);
    s.m.poll(s.now, &mut |_: &[u8]| {});
    assert_eq!(s.gap(3), 0);
    // Modes 5/6 give up between the end switches (no home switch): nothing zeroed.
    let mut s = Search::on(&ends());
    assert!(s.run(5, 60).is_some());
    assert_eq!(s.gap(197), 0);
}

/// A rotary table's home switch passes once a revolution: mode 7 ("home switch in positive direction,
/// ignore end switches", §7.1), the mode made for rotary tables, starting a quarter turn past it, finds it
/// after three quarters of a turn, at the same angle. The world is the shipped example
/// (`examples/worlds/rotary-home.toml`: normally closed, so mode 7 + 128, and `every_turn = true`).
#[test]
fn a_rotary_home_switch_is_found_after_a_turn() {
    let mut s = Search::on(include_str!("../../../examples/worlds/rotary-home.toml"));
    let zero = s.run(135, 5).expect("found within a turn");
    // One revolution is 51 200 µsteps; the switch's middle is a whole turn (less the start) away.
    let middle = 51_200 - 12_800;
    assert!((zero - middle).abs() <= 2, "zero at {zero}, the switch's middle at {middle}");
}

/// Without `every_turn` a switch on a rotary axis is met only at its place (the shaft's position counted on
/// from power-up): the same search turns on past 360° and does not find it.
#[test]
fn a_rotary_switch_not_met_every_turn_is_not_found_again() {
    let world = include_str!("../../../examples/worlds/rotary-home.toml").replace("every_turn = true", "");
    let mut s = Search::on(&world);
    assert_eq!(s.run(135, 5), None, "found a switch that is behind the start");
}

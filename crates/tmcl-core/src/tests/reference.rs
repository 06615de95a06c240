//! Reference search (manual §7.1, Table 21) on a test axis with switch zones.

use super::*;
use tmcl_wire::RfsAction;

const FAR: i64 = 1 << 40;

/// Runs a search to its end (at most 60 s) and returns the physical position of the new zero.
fn search(b: &mut Bench, mode: i32) -> Option<i64> {
    assert_eq!(b.sap(193, mode), Status::Ok, "mode {mode}");
    assert_eq!(b.cmd(Command::Rfs { action: RfsAction::Start, motor: 0 }), (Status::Ok, 0));
    for _ in 0..600 {
        b.run(Duration::from_millis(100));
        if b.cmd(Command::Rfs { action: RfsAction::Status, motor: 0 }).1 == 0 {
            let counter = i64::from(b.gap(1));
            return Some(b.module.board().physical - counter);
        }
    }
    None
}

/// A fresh bench with the given zones (left, right, home) and a 1000 pps switch speed.
fn axis(zones: [Option<core::ops::RangeInclusive<i64>>; 3]) -> Bench {
    let mut board = TestBoard::new();
    board.zones = zones;
    let mut b = Bench::with_board(board);
    b.sap(195, 1000);
    b
}

/// One tick of the slow phase: the resolution of a switching point.
const SLOW_TICK: i64 = 1;
const FAST_TICK: i32 = 52;

#[test]
fn mode_1_left_switch_edge() {
    let mut b = axis([Some(-FAR..=-10_000), Some(30_000..=FAR), None]);
    let zero = search(&mut b, 1).unwrap();
    assert!((zero + 10_000).abs() <= SLOW_TICK + 1, "zero at {zero}");
    // AP 197: the counter just before zeroing (it started at 0, so about −10000).
    assert!((b.gap(197) + 10_000).abs() <= FAST_TICK);
    assert_eq!(b.gap(3), 0);
}

#[test]
fn mode_65_right_switch_edge() {
    let mut b = axis([Some(-FAR..=-10_000), Some(30_000..=FAR), None]);
    let zero = search(&mut b, 65).unwrap();
    assert!((zero - 30_000).abs() <= SLOW_TICK + 1, "zero at {zero}");
}

#[test]
fn mode_2_measures_the_switch_distance() {
    let mut b = axis([Some(-FAR..=-10_000), Some(30_000..=FAR), None]);
    let zero = search(&mut b, 2).unwrap();
    assert!((zero + 10_000).abs() <= SLOW_TICK + 1);
    assert!((b.gap(196) - 40_000).abs() <= FAST_TICK + 2, "AP 196 = {}", b.gap(196));
    let mut b = axis([Some(-FAR..=-10_000), Some(30_000..=FAR), None]);
    let zero = search(&mut b, 66).unwrap();
    assert!((zero - 30_000).abs() <= SLOW_TICK + 1);
    assert!((b.gap(196) + 40_000).abs() <= FAST_TICK + 2, "AP 196 = {}", b.gap(196));
}

#[test]
fn modes_3_and_4_middle_of_the_switch() {
    // A left reference switch of finite width, 2000 wide, centred on −10000.
    for (mode, expect) in [(3, -10_000), (4, -10_000), (67, 20_000), (68, 20_000)] {
        let mut b = axis([Some(-11_000..=-9_000), Some(19_000..=21_000), None]);
        let zero = search(&mut b, mode).unwrap();
        assert!((zero - expect).abs() <= i64::from(FAST_TICK / 2 + 2), "mode {mode}: zero at {zero}");
    }
}

#[test]
fn modes_5_to_8_middle_of_home() {
    let zones = || [Some(-FAR..=-50_000), Some(50_000..=FAR), Some(-20_500..=-19_500)];
    for mode in [5, 8] {
        let mut b = axis(zones());
        let zero = search(&mut b, mode).unwrap();
        assert!((zero + 20_000).abs() <= i64::from(FAST_TICK / 2 + 2), "mode {mode}: zero at {zero}");
    }
    // Modes 6 and 7 search positive: with home on the negative side, 6 reverses at the right switch,
    // 7 (end switches ignored) runs on and never finds it on a linear axis.
    let mut b = axis(zones());
    let zero = search(&mut b, 6).unwrap();
    assert!((zero + 20_000).abs() <= i64::from(FAST_TICK / 2 + 2), "mode 6: zero at {zero}");
    let mut b = axis(zones());
    b.sap(194, 100_000);
    assert_eq!(search(&mut b, 7), None, "never found: still searching");
    assert_eq!(b.cmd(Command::Rfs { action: RfsAction::Stop, motor: 0 }).0, Status::Ok);
    b.run(Duration::from_secs(3));
    assert_eq!((b.cmd(Command::Rfs { action: RfsAction::Status, motor: 0 }).1, b.gap(3)), (0, 0));
}

#[test]
fn inverted_home_switch() {
    // +128: the home switch is active low: "pressed" everywhere except −20500..−19500.
    let mut board = TestBoard::new();
    board.zones = [None, None, Some(-20_500..=-19_500)];
    let mut b = Bench::with_board(board);
    b.sap(195, 1000);
    // The search for an inverted home starts outside the inverted zone: at 0 the raw switch is open,
    // which inverted reads pressed, so use mode 8+128 from inside the notch.
    b.sap(1, 0);
    let zero = search(&mut b, 136).unwrap();
    assert!(zero < 0, "found the inverted switch at {zero}");
    // 132, which §7.1.8 prints for the inverted mode 8 (128 + 8 is 136), is the same mode.
    assert_eq!(b.sap(193, 132), Status::Ok);
}

#[test]
fn modes_5_6_give_up_between_end_switches() {
    let mut b = axis([Some(-FAR..=-5_000), Some(5_000..=FAR), None]);
    b.sap(194, 20_000);
    assert!(search(&mut b, 5).is_some(), "ends");
    assert_eq!(b.gap(197), 0, "nothing zeroed");
    assert_eq!(b.gap(3), 0);
}

#[test]
fn a_motion_command_aborts_the_search_and_bad_speeds_are_refused() {
    let mut b = axis([None, None, None]);
    b.sap(193, 1);
    b.cmd(Command::Rfs { action: RfsAction::Start, motor: 0 });
    b.run(Duration::from_millis(100));
    assert_ne!(b.cmd(Command::Rfs { action: RfsAction::Status, motor: 0 }).1, 0);
    b.cmd(Command::Mst { motor: 0 });
    assert_eq!(b.cmd(Command::Rfs { action: RfsAction::Status, motor: 0 }).1, 0);
    b.sap(194, 0);
    assert_eq!(b.cmd(Command::Rfs { action: RfsAction::Start, motor: 0 }).0, Status::InvalidValue);
    assert_eq!(b.sap(193, 9), Status::InvalidValue);
    assert_eq!(b.sap(193, 69), Status::InvalidValue);
}

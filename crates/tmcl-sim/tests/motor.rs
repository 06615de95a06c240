//! The motor, driver and sensor models of `SimBoard`, driven directly through `StepDriver::update` and
//! through a module running the firmware.

use proptest::prelude::*;
use tmcl_core::hal::{Analog, DriveState, DriverSettings, Inputs, LoadSensor, StepDriver, SwitchInputs};
use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::param::persist;
use tmcl_core::{Duration, Instant, Module, Outcome};
use tmcl_sim::{SimBoard, World};
use tmcl_wire::{Command, MoveTarget};

fn board(toml: &str) -> SimBoard {
    SimBoard::in_memory(16).with_world(World::from_toml_str(toml).unwrap()).unwrap()
}

fn module(toml: &str) -> Module<SimBoard> {
    let b = SimBoard::in_memory(persist::capacity(&SPEC)).with_world(World::from_toml_str(toml).unwrap()).unwrap();
    Module::new(b, &SPEC, Instant::ZERO)
}

fn sap(m: &mut Module<SimBoard>, param: u8, value: i32, now: Instant) {
    m.execute(Command::Sap { param, motor: 0, value }, now).unwrap();
}

fn gap(m: &mut Module<SimBoard>, param: u8, now: Instant) -> i32 {
    match m.execute(Command::Gap { param, motor: 0 }, now) {
        Ok(Outcome::Value(v)) => v,
        other => panic!("GAP {param}: {other:?}"),
    }
}

/// Runs the module to `t`, then lets the world catch up (a freewheeling rotor, the timeline).
fn run_to(m: &mut Module<SimBoard>, t: Instant) {
    m.poll(t, &mut |_: &[u8]| {});
    m.board_mut().advance(t);
}

/// Steps a board at constant velocity (µsteps/s at 256 µsteps) for `ms` ticks of 1 ms.
fn run_board(b: &mut SimBoard, from: Instant, ms: u64, velocity: i32, current: u8) -> Instant {
    let mut t = from;
    let per_tick = i64::from(velocity) / 1000;
    for _ in 0..ms {
        t += Duration::from_millis(1);
        let s =
            DriveState { moved: per_tick, velocity, resolution: 8, current, enabled: true, ..DriveState::default() };
        b.update(0, t, &s);
    }
    t
}

#[derive(Debug, Clone)]
struct Tick {
    moved: i64,
    resolution: u8,
    velocity: i32,
    current: u8,
    reverse: bool,
    gap_ms: u64,
}

fn tick() -> impl Strategy<Value = Tick> {
    (-4000i64..4000, 0u8..=8, any::<i32>(), any::<u8>(), any::<bool>(), 0u64..50).prop_map(
        |(moved, resolution, velocity, current, reverse, gap_ms)| Tick {
            moved,
            resolution,
            velocity,
            current,
            reverse,
            gap_ms,
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// A free axis never loses a step, whatever the step sequence, resolution, speed and current.
    #[test]
    fn free_axis_never_loses_a_step(ticks in prop::collection::vec(tick(), 1..200)) {
        let mut b = SimBoard::in_memory(16);
        let mut t = Instant::ZERO;
        let mut expected = 0i64;
        for k in ticks {
            t += Duration::from_millis(1 + k.gap_ms);
            let s = DriveState {
                moved: k.moved,
                velocity: k.velocity,
                resolution: k.resolution,
                current: k.current,
                enabled: true,
                reverse: k.reverse,
                position: 0,
            };
            b.update(0, t, &s);
            let m = k.moved << (8 - k.resolution);
            expected += if k.reverse { -m } else { m };
            prop_assert_eq!(b.shaft(), expected);
            prop_assert_eq!(b.commanded(), expected);
            prop_assert_eq!(b.lost_full_steps(), 0);
            prop_assert_eq!(b.feedback().encoder_counts, expected.div_euclid(50));
        }
    }

    /// A load below the available torque lags the rotor by less than a full step and loses nothing.
    #[test]
    fn a_load_below_the_limit_loses_no_step(
        friction in 0.0f64..0.025,
        constant in -0.005f64..0.005,
        moves in prop::collection::vec(-300i64..300, 1..300),
    ) {
        let toml = format!("[load]\nfriction = {friction}\nconstant = {constant}");
        let mut b = board(&toml);
        let mut t = Instant::ZERO;
        for moved in moves {
            t += Duration::from_millis(1);
            // Current 255: 1 A peak, 0.707 A RMS → 0.0606 N·m.
            let s = DriveState { moved, velocity: 51200, resolution: 8, current: 255, enabled: true, ..DriveState::default() };
            b.update(0, t, &s);
            prop_assert_eq!(b.lost_full_steps(), 0);
            prop_assert!((b.commanded() - b.shaft()).abs() <= 256, "lag {}", b.commanded() - b.shaft());
        }
    }

    /// Through the firmware: any positioning move on a free axis ends with shaft = AP 1 and the encoder
    /// on the shaft.
    #[test]
    fn free_axis_through_the_firmware(
        target in -200_000i32..200_000,
        speed in 2_000i32..400_000,
        accel in 5_000i32..2_000_000,
    ) {
        let mut m = module("");
        let t = Instant::ZERO;
        sap(&mut m, 4, speed, t);
        sap(&mut m, 5, accel, t);
        m.execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(target) }, t).unwrap();
        let end = Instant::from_secs(250);
        run_to(&mut m, end);
        prop_assert_eq!(gap(&mut m, 1, end), target);
        prop_assert_eq!(m.board().shaft(), i64::from(target));
        let counts = m.board_mut().feedback().encoder_counts;
        prop_assert_eq!(counts, i64::from(target).div_euclid(50));
    }
}

#[test]
fn encoder_equals_the_step_position_for_every_table_20_setting() {
    // PD28-1021 manual §6.2 Table 20: SAP 140 with the matching SAP 210; a quarter revolution is a whole
    // number of encoder counts (256) at every resolution.
    for (res, p) in [(8, 25600), (7, 12800), (6, 6400), (5, 3200), (4, 1600), (3, 800), (2, 400), (1, 200)] {
        for reverse in [0, 1] {
            let mut m = module("");
            let t = Instant::ZERO;
            sap(&mut m, 140, res, t);
            sap(&mut m, 210, p, t);
            m.execute(Command::Sgp { param: 90, bank: 0, value: reverse }, t).unwrap();
            let per_rev = 200 << res;
            let mut now = t;
            for quarters in [5, -3, 12, 0, -9] {
                let target = per_rev * quarters / 4;
                sap(&mut m, 4, per_rev, now);
                sap(&mut m, 5, per_rev * 4, now);
                m.execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(target) }, now).unwrap();
                now += Duration::from_secs(10);
                run_to(&mut m, now);
                assert_eq!(gap(&mut m, 1, now), target, "res {res}");
                assert_eq!(gap(&mut m, 209, now), target, "AP 209 at res {res}, p {p}, GP 90 = {reverse}");
                let shaft = m.board().shaft();
                let physical = i64::from(target) << (8 - res);
                assert_eq!(shaft, if reverse == 1 { -physical } else { physical });
                assert_eq!(m.board_mut().feedback().encoder_counts, shaft.div_euclid(50));
            }
        }
    }
}

#[test]
fn a_jammed_axis_diverges_from_ap1() {
    // The jam starts at 2 mm = 51200 µsteps (lead 2 mm).
    let mut m =
        module("[axis]\nkind = \"linear\"\nlead = 2.0\n[load]\nfriction = 0.003\n[[load.jam]]\nat = [2.0, 2.5]\n");
    let t = Instant::ZERO;
    m.execute(Command::Ror { motor: 0, velocity: 51200 }, t).unwrap();
    run_to(&mut m, Instant::from_secs(2));
    // Against the jam the rotor bounces back half a period as the field passes it: most stallGuard2
    // readings are 0, and AP 208 bit 0 is set with them.
    let (mut zeros, mut flagged) = (0, 0);
    for ms in 2001..=4000 {
        let now = Instant::from_millis(ms);
        run_to(&mut m, now);
        zeros += usize::from(gap(&mut m, 206, now) == 0);
        flagged += usize::from(gap(&mut m, 208, now) & 1 == 1);
    }
    assert!(zeros > 1000 && zeros == flagged, "{zeros} zero readings of 2000, {flagged} flagged");
    let end = Instant::from_secs(4);
    let b = m.board();
    assert!((50_600..=51_200).contains(&b.shaft()), "the rotor stops at the jam: {}", b.shaft());
    assert!(b.commanded() > 150_000, "the field runs on: {}", b.commanded());
    assert_eq!(b.lost_full_steps() % 4, 0);
    assert!(b.lost_full_steps() > 300, "{} full steps lost", b.lost_full_steps());
    let ap1 = gap(&mut m, 1, end);
    let ap209 = gap(&mut m, 209, end);
    assert!(ap1 > 150_000 && (50_600..=51_200).contains(&ap209), "AP 1 {ap1}, AP 209 {ap209}");
    // Back out of the jam: the rotor follows again, from where it is.
    m.execute(Command::Ror { motor: 0, velocity: -51200 }, end).unwrap();
    let back = end + Duration::from_secs(3);
    run_to(&mut m, back);
    let b = m.board();
    assert!(b.shaft() < 0, "backed out: {}", b.shaft());
    assert!(gap(&mut m, 206, back) > 900, "light load again");
}

#[test]
fn a_seized_shaft_stops_at_the_fault_position_while_it_lasts() {
    let mut m = module("[[faults.stall]]\nat = \"20000 usteps\"\nfrom = 0\nuntil = 3\n");
    m.execute(Command::Ror { motor: 0, velocity: 25600 }, Instant::ZERO).unwrap();
    run_to(&mut m, Instant::from_secs(2));
    assert_eq!(m.board().shaft(), 20_000);
    // The fault ends: the rotor snaps to the field's nearest stable point and follows again.
    run_to(&mut m, Instant::from_secs(4));
    let b = m.board();
    assert!(b.shaft() > 40_000 && (b.commanded() - b.shaft()) % 1024 == 0, "{} vs {}", b.shaft(), b.commanded());
}

#[test]
fn an_end_stop_holds_the_rotor_and_steps_are_lost() {
    let mut b = board("[axis]\ntravel = [\"-1000 usteps\", \"5000 usteps\"]\n");
    run_board(&mut b, Instant::ZERO, 200, 51200, 128);
    assert_eq!(b.shaft(), 5000);
    assert!(b.lost_full_steps() >= 16);
}

#[test]
fn a_spring_back_drives_a_freewheeling_rotor() {
    // 0.0005 N·m per degree toward 0°; 20° out is 0.01 N·m, held by the powered motor.
    let mut m = module("[load.spring]\nrate = 0.0005\nrest = 0\n[motor]\ndetent_torque = 0.0\n");
    let t = Instant::ZERO;
    sap(&mut m, 204, 10, t); // freewheel 100 ms after the motor stops
    m.execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(2844) }, t).unwrap(); // 20°
    run_to(&mut m, Instant::from_millis(400));
    let held = m.board().shaft();
    assert!((2844 - held).abs() < 256, "held with a load angle: {held}");
    let stopped = Instant::from_secs(1);
    run_to(&mut m, stopped);
    run_to(&mut m, stopped + Duration::from_secs(2));
    let b = m.board();
    assert_eq!(b.available_torque(), 0.0, "freewheeling");
    assert!(b.shaft().abs() < 30, "back-driven to the spring's rest: {}", b.shaft());
    assert_eq!(gap(&mut m, 1, stopped), 2844, "AP 1 does not know");
}

#[test]
fn without_current_the_rotor_stays_and_snaps_back_in_whole_periods() {
    let mut b = SimBoard::in_memory(16);
    let off = DriveState { moved: 700, resolution: 8, enabled: false, ..DriveState::default() };
    b.update(0, Instant::from_millis(1), &off);
    assert_eq!((b.shaft(), b.commanded()), (0, 700));
    let on = DriveState { moved: 0, resolution: 8, current: 100, enabled: true, ..DriveState::default() };
    b.update(0, Instant::from_millis(2), &on);
    // 700 µsteps ahead is nearer to one period (1024) than to zero: the rotor jumps to 700 − 1024.
    assert_eq!(b.shaft(), -324);
    assert_eq!(b.lost_full_steps(), 4);
}

#[test]
fn stallguard_value_falls_with_the_load() {
    // Current 255: 0.0606 N·m available. Load ratio r gives 1023 · (1 − r).
    let available = 0.06 / 0.7 * std::f64::consts::FRAC_1_SQRT_2;
    let mut last = 1024;
    for ratio in [0.0, 0.2, 0.4, 0.6, 0.8, 0.95] {
        let torque = ratio * available;
        let mut b = board(&format!("[load]\nfriction = {torque}"));
        run_board(&mut b, Instant::ZERO, 100, 51200, 255);
        let load = b.feedback().load;
        let expected = 1023.0 * (1.0 - ratio);
        assert!((f64::from(load) - expected).abs() <= 3.0, "ratio {ratio}: {load}, expected {expected}");
        assert!(load < last);
        last = load;
    }
}

#[test]
fn stallguard_threshold_filter_and_minimum_speed() {
    let available = 0.06 / 0.7 * std::f64::consts::FRAC_1_SQRT_2;
    let mut b = board(&format!("[load]\nfriction = {}", 0.5 * available));
    b.configure(0, &DriverSettings { stall_threshold: 10, ..DriverSettings::default() });
    let t = run_board(&mut b, Instant::ZERO, 50, 51200, 255);
    let load = b.feedback().load;
    assert!((671..=673).contains(&load), "AP 174 = 10 shifts by 160: {load}");
    // Filtered: one measurement per 4 full steps (1024 µsteps).
    b.configure(0, &DriverSettings { stall_filter: true, ..DriverSettings::default() });
    let before = b.load_measurements(0);
    let t = run_board(&mut b, t, 100, 51200, 255); // 5120 µsteps... 20 full steps
    assert_eq!(b.load_measurements(0) - before, 5);
    // Below 0.2 rev/s (40 full steps/s): no measurement, the value is held.
    let before = b.load_measurements(0);
    let held = b.feedback().load;
    run_board(&mut b, t, 1000, 5000, 255);
    assert_eq!(b.load_measurements(0), before);
    assert_eq!(b.feedback().load, held);
}

#[test]
fn energy_is_current_squared_times_time() {
    for (current, high, amps) in [(255u8, false, 1.0), (127, false, 0.5), (255, true, 2.0), (7, false, 1.0 / 32.0)] {
        let mut b = SimBoard::in_memory(16);
        b.configure(0, &DriverSettings { high_range: high, ..DriverSettings::default() });
        let s = DriveState { current, enabled: true, resolution: 8, ..DriveState::default() };
        b.update(0, Instant::ZERO, &s);
        b.advance(Instant::from_secs(2));
        let expected = amps * amps * 2.0;
        assert!((b.energy() - expected).abs() < 1e-9, "current {current}: {} vs {expected}", b.energy());
        assert_eq!(b.coil_current(), amps);
    }
    let mut b = SimBoard::in_memory(16);
    b.update(0, Instant::ZERO, &DriveState { current: 255, enabled: false, ..DriveState::default() });
    b.advance(Instant::from_secs(5));
    assert_eq!(b.energy(), 0.0, "off: no current");
}

#[test]
fn standstill_flag_after_2_pow_20_clocks() {
    let mut b = SimBoard::in_memory(16);
    let t = run_board(&mut b, Instant::ZERO, 10, 51200, 100);
    assert_eq!(b.feedback().driver_flags & 0x80, 0);
    b.advance(t + Duration::from_micros(65_535));
    assert_eq!(b.feedback().driver_flags & 0x80, 0);
    b.advance(t + Duration::from_micros(65_536));
    assert_eq!(b.feedback().driver_flags & 0x80, 0x80);
}

#[test]
fn timeline_inputs_faults_and_encoder_slip() {
    let mut b = board(
        "[inputs]\ndigital = 2\nanalog = 100\n[[inputs.timeline]]\nat = 0.5\nin0 = true\nanalog = 4000\n\
         [[inputs.timeline]]\nat = 1\ndigital = 8\ntemperature = 120\n\
         [[faults.encoder_slip]]\nat = 0.7\ncounts = -40\n\
         [[faults.driver]]\nfrom = 2\nuntil = 3\nflags = [\"short_b\", \"open_a\"]\n\
         [[faults.supply_drop]]\nfrom = 4\nuntil = 5\nvoltage = 6\n",
    );
    let s = DriveState { current: 255, enabled: true, resolution: 8, ..DriveState::default() };
    b.update(0, Instant::ZERO, &s);
    assert_eq!((b.digital_inputs(), b.analog_input(0)), (2, 100));
    b.advance(Instant::from_millis(600));
    assert_eq!((b.digital_inputs(), b.analog_input(0)), (3, 4000));
    b.advance(Instant::from_millis(800));
    assert_eq!(b.feedback().encoder_counts, -40);
    b.advance(Instant::from_millis(1500));
    assert_eq!((b.digital_inputs(), b.temperature()), (8, 120));
    assert_eq!(b.feedback().driver_flags & 0x7E, 0x04, "pre-warning from 100 °C");
    b.world.temperature = 25;
    b.advance(Instant::from_millis(2500));
    assert_eq!(b.feedback().driver_flags & 0x7E, 0x10 | 0x20);
    assert_eq!(b.available_torque(), 0.0, "short to ground: bridges off");
    b.advance(Instant::from_millis(3500));
    assert_eq!(b.feedback().driver_flags & 0x7E, 0);
    assert!(b.available_torque() > 0.0);
    b.advance(Instant::from_millis(4500));
    assert_eq!((b.supply_voltage(), b.available_torque()), (6.0, 0.0));
    b.advance(Instant::from_millis(5500));
    assert_eq!(b.supply_voltage(), 24.0);
}

#[test]
fn scripted_load_pushes_the_rotor() {
    let mut b = board("[[load.script]]\nat = 1\ntorque = 0.03\n[[load.script]]\nat = 2\ntorque = 0\n");
    let s = DriveState { current: 255, enabled: true, resolution: 8, ..DriveState::default() };
    b.update(0, Instant::ZERO, &s);
    b.advance(Instant::from_millis(1500));
    // 0.03 of 0.0606 N·m: sin φ ≈ 0.495 → about 30° = 84 µsteps ahead of the field.
    let lead = b.shaft() - b.commanded();
    assert!((80..=88).contains(&lead), "{lead}");
    b.advance(Instant::from_millis(2500));
    assert!(b.shaft().abs() <= 1);
}

#[test]
fn switch_polarity_and_bounce() {
    let mut b = board(
        "[switches.left]\nat = [\"-100 usteps\", \"100 usteps\"]\nactive = \"low\"\n\
         [switches.home]\nat = [\"1000 usteps\", \"2000 usteps\"]\nbounce = { time = \"5 ms\", count = 2 }\n",
    );
    let at = |ms| Instant::from_millis(ms);
    let s = DriveState { resolution: 8, current: 100, enabled: true, ..DriveState::default() };
    b.update(0, at(0), &s);
    let sw = b.switches(0);
    assert!(!sw.left && !sw.right && !sw.home, "left pressed but active low: reads inactive");
    b.update(0, at(1), &DriveState { moved: 1000, ..s });
    assert!(b.switches(0).left, "released: reads active");
    // The home switch closed at 1 ms; 5 slots of 1 ms: closed, open, closed, open, closed.
    let levels: Vec<bool> = (1..8)
        .map(|ms| {
            b.advance(at(ms));
            b.switches(0).home
        })
        .collect();
    assert_eq!(levels, [true, false, true, false, true, true, true]);
}

#[test]
fn clock_runs_the_timeline_between_updates() {
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::sync::Arc;
    let now = Arc::new(AtomicU64::new(0));
    let clock = Arc::clone(&now);
    let mut b = board("[[inputs.timeline]]\nat = 1\ndigital = 5\n")
        .with_clock(move || Instant::from_micros(clock.load(Ordering::Relaxed)));
    assert_eq!(b.digital_inputs(), 0);
    now.store(1_000_000, Ordering::Relaxed);
    assert_eq!(b.digital_inputs(), 5);
}

/// Table 22: the slow-run current AP 183 applies at or below the threshold speed AP 182 whether or not
/// coolStep (AP 172) is on. Before the fix it took effect only with AP 172 ≠ 0: AP 180 read 31 here.
#[test]
fn slow_run_current_without_coolstep() {
    let mut m = module("");
    let t = Instant::ZERO;
    sap(&mut m, 182, 100_000, t);
    sap(&mut m, 183, 64, t);
    m.execute(Command::Ror { motor: 0, velocity: 51200 }, t).unwrap();
    let t = t + Duration::from_secs(2);
    run_to(&mut m, t);
    assert_eq!(gap(&mut m, 3, t), 51200);
    assert_eq!(gap(&mut m, 180, t), 8, "AP 183 / 8");
    assert_eq!(m.board().drive().current, 64);
    // Above the threshold: the run current again.
    sap(&mut m, 182, 10_000, t);
    let t = t + Duration::from_millis(10);
    run_to(&mut m, t);
    assert_eq!(gap(&mut m, 180, t), i32::from(m.board().drive().current >> 3));
    assert_eq!(m.board().drive().current, 128, "AP 6's default");
}

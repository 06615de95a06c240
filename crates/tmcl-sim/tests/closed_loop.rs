//! The TMCM-1310's closed loop against the simulated motor: where a load makes an open-loop motor lose
//! steps, the closed loop stalls without losing any and reaches the target with the encoder agreeing;
//! a load it cannot overcome trips the following error.

use tmcl_core::model::{pd28_1021, tmcm_1310, ModelSpec};
use tmcl_core::{Duration, Instant, Module, Outcome};
use tmcl_sim::{SimBoard, World};
use tmcl_wire::{Command, Status};

/// A NEMA 17 motor (0.45 N·m at 2 A) on a rotary axis whose shaft seizes at 20° for 0.3 s from `from`
/// (a move from 0 at the default ramp gets there after 0.33 s).
fn seized_for_a_while(from: f64) -> String {
    format!(
        "[motor]\nholding_torque = 0.45\nrated_current = 2.0\n[[faults.stall]]\nat = 20.0\nfrom = {from}\nuntil = {}\n",
        from + 0.3
    )
}

fn module(spec: &'static ModelSpec, toml: &str) -> Module<SimBoard> {
    let world = World::from_toml_str(toml).unwrap();
    let board = SimBoard::in_memory_for(spec).with_world(world).unwrap();
    Module::new(board, spec, Instant::ZERO)
}

fn exec(m: &mut Module<SimBoard>, c: Command, now: Instant) -> Result<i32, Status> {
    match m.execute(c, now)? {
        Outcome::Value(v) => Ok(v),
        other => panic!("{c:?}: {other:?}"),
    }
}

fn sap(m: &mut Module<SimBoard>, param: u8, value: i32, now: Instant) {
    exec(m, Command::Sap { param, motor: 0, value }, now).unwrap_or_else(|s| panic!("SAP {param}, {value}: {s:?}"));
}

fn gap(m: &mut Module<SimBoard>, param: u8, now: Instant) -> i32 {
    exec(m, Command::Gap { param, motor: 0 }, now).unwrap()
}

/// Runs the module to `t`, then lets the world catch up (its timeline, faults).
fn run_to(m: &mut Module<SimBoard>, t: Instant) {
    m.poll(t, &mut |_: &[u8]| {});
    m.board_mut().advance(t);
}

/// Runs until `done` or `limit`, polling every millisecond; returns the time.
fn run_until(
    m: &mut Module<SimBoard>,
    from: Instant,
    limit: Duration,
    mut done: impl FnMut(&mut Module<SimBoard>, Instant) -> bool,
) -> Instant {
    let mut t = from;
    while t < from + limit {
        t += Duration::from_millis(1);
        run_to(m, t);
        if done(m, t) {
            return t;
        }
    }
    t
}

/// Initialises the encoder and closes the loop, as pytrinamic's TMCM-1311 demo does.
fn close_the_loop(m: &mut Module<SimBoard>) -> Instant {
    let t = Instant::ZERO;
    sap(m, 132, 1, t);
    let t = run_until(m, t, Duration::from_secs(2), |m, t| gap(m, 132, t) != 1);
    assert_eq!(gap(m, 132, t), 2, "encoder initialisation done");
    sap(m, 129, 1, t);
    let t = run_until(m, t, Duration::from_millis(10), |m, t| gap(m, 133, t) == 1);
    assert_eq!(gap(m, 133, t), 1, "the loop is closed");
    assert_eq!(gap(m, 18, t) & 4, 4, "status word: closed loop");
    t
}

/// One revolution in microsteps (200 full steps · 256).
const REV: i32 = 51200;

fn encoder_usteps(m: &mut Module<SimBoard>) -> f64 {
    m.board().shaft() as f64
}

#[test]
fn open_loop_loses_steps_where_closed_loop_does_not() {
    // Open loop, the TMCM-1310 with AP 129 = 0: the seized shaft makes the rotor drop behind.
    let mut open = module(&tmcm_1310::SPEC, &seized_for_a_while(0.3));
    sap(&mut open, 0, 2 * REV, Instant::ZERO);
    let t = run_until(&mut open, Instant::ZERO, Duration::from_secs(10), |m, t| gap(m, 8, t) == 1);
    let lost = open.board().lost_full_steps();
    assert!(lost.abs() >= 4, "open loop: {lost} full steps lost");
    assert_eq!(gap(&mut open, 1, t), 2 * REV, "the step counter believes it arrived");
    let shaft = open.board().shaft();
    assert!((shaft - i64::from(2 * REV)).abs() >= 1024, "but the shaft is at {shaft}");

    // The PD28-1021 loses steps the same way.
    let mut pd28 = module(&pd28_1021::SPEC, &seized_for_a_while(0.3));
    sap(&mut pd28, 0, 2 * REV, Instant::ZERO);
    run_until(&mut pd28, Instant::ZERO, Duration::from_secs(10), |m, t| gap(m, 8, t) == 1);
    assert!(pd28.board().lost_full_steps().abs() >= 4);

    // Closed loop: the rotor waits at the seizure, then catches up; it arrives where it was sent.
    // The initialisation takes 0.3 s: the seizure comes as late.
    let mut cl = module(&tmcm_1310::SPEC, &seized_for_a_while(0.55));
    let t0 = close_the_loop(&mut cl);
    assert!(t0 <= Instant::ZERO + Duration::from_millis(310), "{t0:?}");
    let target = gap(&mut cl, 1, t0) + 2 * REV;
    sap(&mut cl, 0, target, t0);
    let mut worst = 0;
    let t = run_until(&mut cl, t0, Duration::from_secs(10), |m, t| {
        worst = worst.max(gap(m, 237, t).abs());
        gap(m, 8, t) == 1
    });
    assert_eq!(gap(&mut cl, 8, t), 1, "target reached");
    assert!(worst > 3000, "the seizure held the rotor back ({worst} microsteps)");
    let actual = gap(&mut cl, 1, t);
    assert!((actual - target).abs() <= 100, "encoder {actual} within the window of {target}");
    assert_eq!(gap(&mut cl, 209, t), actual, "AP 1 is the encoder in closed loop");
    assert_eq!(cl.board().lost_full_steps(), 0, "no step lost");
    let shaft = encoder_usteps(&mut cl);
    assert!((shaft - f64::from(target)).abs() <= 100.0, "the shaft is at {shaft}");
    let status = gap(&mut cl, 18, t);
    assert_eq!(
        status & 0b1_0000_0000_1101,
        0b1_0000_0000_1101,
        "reached, closed loop, position mode, hold: {status:b}"
    );
}

#[test]
fn a_load_beyond_the_current_trips_the_following_error() {
    let world = "[motor]\nholding_torque = 0.45\nrated_current = 2.0\n[[faults.stall]]\nat = 20.0\nfrom = 0.3\n";
    let mut m = module(&tmcm_1310::SPEC, world);
    let t0 = close_the_loop(&mut m);
    sap(&mut m, 125, 5000, t0);
    let target = gap(&mut m, 1, t0) + 2 * REV;
    sap(&mut m, 0, target, t0);
    let t = run_until(&mut m, t0, Duration::from_secs(5), |m, t| gap(m, 207, t) & 2 != 0 || gap(m, 8, t) == 1);
    assert!(t < t0 + Duration::from_secs(5), "stopped by the following error");
    assert_eq!(gap(&mut m, 3, t), 0, "the ramp stands");
    assert_eq!(gap(&mut m, 233, t), gap(&mut m, 1, t), "at the rotor: no catch-up later");
    assert_eq!(m.board().lost_full_steps(), 0);
    assert_eq!(gap(&mut m, 18, t) & 4, 4, "still closed loop, holding");
}

#[test]
fn torque_mode_pushes_with_the_target_current() {
    let mut m =
        module(&tmcm_1310::SPEC, "[motor]\nholding_torque = 0.45\nrated_current = 2.0\n[load]\nfriction = 0.01\n");
    assert_eq!(
        exec(&mut m, Command::Sap { param: 14, motor: 0, value: 500 }, Instant::ZERO),
        Err(Status::InvalidValue),
        "open loop: no torque mode"
    );
    let t0 = close_the_loop(&mut m);
    let p0 = gap(&mut m, 1, t0);
    sap(&mut m, 14, 1000, t0);
    let t = t0 + Duration::from_millis(200);
    run_to(&mut m, t);
    assert_eq!(gap(&mut m, 18, t) & (1 << 5), 1 << 5, "torque mode");
    assert_eq!(gap(&mut m, 19, t), 1000);
    assert!(gap(&mut m, 1, t) > p0 + REV / 10, "turning forward");
    exec(&mut m, Command::Mst { motor: 0 }, t).unwrap();
    assert_eq!(gap(&mut m, 18, t) & (1 << 5), 0, "MST leaves torque mode");
}

#[test]
fn initialisation_fails_with_the_wrong_encoder_resolution() {
    let mut m = module(&tmcm_1310::SPEC, "[encoder]\nkind = \"abn\"\ncounts_per_rev = 2000\n");
    sap(&mut m, 132, 1, Instant::ZERO);
    let t = run_until(&mut m, Instant::ZERO, Duration::from_secs(2), |m, t| gap(m, 132, t) != 1);
    assert_eq!(gap(&mut m, 132, t), 3, "4096 expected, 2000 counted");
    sap(&mut m, 210, 2000, t);
    sap(&mut m, 132, 1, t);
    let t = run_until(&mut m, t, Duration::from_secs(2), |m, t| gap(m, 132, t) != 1);
    assert_eq!(gap(&mut m, 132, t), 2);
}

#[test]
fn an_ssi_encoder_is_read_when_selected() {
    let world = "[encoder]\nkind = \"ssi\"\ncounts_per_rev = 4096\n";
    let mut m = module(&tmcm_1310::SPEC, world);
    sap(&mut m, 132, 1, Instant::ZERO);
    let t = run_until(&mut m, Instant::ZERO, Duration::from_secs(2), |m, t| gap(m, 132, t) != 1);
    assert_eq!(gap(&mut m, 132, t), 3, "A/B/N selected, nothing counts");
    sap(&mut m, 201, 1, t);
    sap(&mut m, 132, 1, t);
    let t = run_until(&mut m, t, Duration::from_secs(2), |m, t| gap(m, 132, t) != 1);
    assert_eq!(gap(&mut m, 132, t), 2);
    sap(&mut m, 129, 1, t);
    // Three revolutions: the turns are counted across the SSI angle's wrap.
    let target = gap(&mut m, 1, t) + 3 * REV;
    run_to(&mut m, t + Duration::from_millis(5));
    sap(&mut m, 0, target, t + Duration::from_millis(5));
    let t = run_until(&mut m, t, Duration::from_secs(10), |m, t| gap(m, 8, t) == 1);
    assert!((gap(&mut m, 1, t) - target).abs() <= 100);
}

#[test]
fn velocity_mode_in_closed_loop_is_measured_by_the_encoder() {
    let mut m = module(&tmcm_1310::SPEC, "");
    let t0 = close_the_loop(&mut m);
    exec(&mut m, Command::Ror { motor: 0, velocity: 25600 }, t0).unwrap();
    let t = t0 + Duration::from_secs(2);
    run_to(&mut m, t);
    let measured = gap(&mut m, 131, t);
    assert!((measured - 25600).abs() <= 1600, "AP 131 = {measured}: the encoder's 8 ms, 4096 counts per turn");
    assert_eq!(gap(&mut m, 16, t), 1, "velocity reached");
    let status = gap(&mut m, 18, t);
    assert_eq!(status & 0b11_1110, 0b01_0110, "velocity reached, closed loop, velocity mode: {status:b}");
}

#[test]
fn supply_temperature_and_i2t_in_the_status_word() {
    let world = "[[faults.supply_drop]]\nfrom = 0.5\nuntil = 0.6\nvoltage = 9.0\n\
                 [[faults.supply_drop]]\nfrom = 0.7\nuntil = 0.8\nvoltage = 9.5\n\
                 [[faults.driver]]\nfrom = 0.9\nuntil = 1.0\nflags = [\"overtemperature\"]\n";
    let mut m = module(&tmcm_1310::SPEC, world);
    let bits = |m: &mut Module<SimBoard>, ms: u64| {
        let t = Instant::ZERO + Duration::from_millis(ms);
        run_to(m, t);
        gap(m, 18, t) & (0b111 << 9)
    };
    assert_eq!(bits(&mut m, 100), 0, "24 V, cool");
    assert_eq!(bits(&mut m, 550), 1 << 9, "9 V: undervoltage");
    assert_eq!(bits(&mut m, 950), 1 << 11, "driver overtemperature");
    // I²t: with a 100 ms time constant and a limit below what the run current gives, the flag comes and
    // stays until AP 29 clears it; AP 28 counts the event; the limits need the password (status 8).
    let t0 = close_the_loop(&mut m);
    assert_eq!(exec(&mut m, Command::Sap { param: 25, motor: 0, value: 100 }, t0), Err(Status::PasswordProtected));
    exec(&mut m, Command::Sgp { param: 200, bank: 0, value: 4321 }, t0).unwrap();
    sap(&mut m, 25, 100, t0);
    sap(&mut m, 26, 10_000, t0);
    let t = t0 + Duration::from_secs(1);
    run_to(&mut m, t);
    assert_eq!(gap(&mut m, 18, t) & (1 << 13), 1 << 13, "I²t exceeded");
    assert_eq!(gap(&mut m, 28, t), 1);
    assert!(gap(&mut m, 27, t) > 10_000, "the sum is over the limit");
    sap(&mut m, 26, 0, t);
    sap(&mut m, 29, 0, t);
    assert_eq!(gap(&mut m, 18, t) & (1 << 13), 0, "cleared by AP 29");
}

#[test]
fn a_reference_search_in_closed_loop() {
    use tmcl_wire::RfsAction;
    // The left switch from -90° to -80°: mode 1 searches it and zeroes the counters at its edge.
    let mut m = module(&tmcm_1310::SPEC, "[switches.left]\nat = [-90.0, -80.0]\n");
    let t0 = close_the_loop(&mut m);
    sap(&mut m, 194, 20000, t0);
    sap(&mut m, 195, 2000, t0);
    exec(&mut m, Command::Rfs { action: RfsAction::Start, motor: 0 }, t0).unwrap();
    let t = run_until(&mut m, t0, Duration::from_secs(10), |m, t| {
        exec(m, Command::Rfs { action: RfsAction::Status, motor: 0 }, t).unwrap() == 0
    });
    let t = run_until(&mut m, t, Duration::from_millis(200), |_, _| false);
    assert_eq!(gap(&mut m, 18, t) & 4, 4, "still closed loop");
    let (actual, virtual_position) = (gap(&mut m, 1, t), gap(&mut m, 233, t));
    assert!((actual - virtual_position).abs() <= 100, "encoder {actual} and ramp {virtual_position} agree");
    // The switch's edge at -80° is the new zero: the shaft stands there (±1 encoder count, 12.5 µsteps).
    let edge = -80.0 / 360.0 * f64::from(REV);
    let shaft = m.board().shaft() as f64;
    assert!((shaft - actual as f64 - edge).abs() <= 150.0, "shaft {shaft} at zero {actual} + edge {edge}");
    assert_eq!(m.board().lost_full_steps(), 0);
}

#[test]
fn changing_the_encoder_scale_opens_the_loop() {
    let mut m = module(&tmcm_1310::SPEC, "");
    let t0 = close_the_loop(&mut m);
    sap(&mut m, 0, REV, t0);
    let t = run_until(&mut m, t0, Duration::from_secs(5), |m, t| gap(m, 8, t) == 1);
    let before = gap(&mut m, 209, t);
    // A new encoder resolution: the loop opens, the initialisation is to be done again, the encoder
    // position carries on (it does not jump by the ratio of the resolutions).
    sap(&mut m, 210, 2048, t);
    assert_eq!((gap(&mut m, 133, t), gap(&mut m, 132, t)), (0, 0));
    assert_eq!(gap(&mut m, 209, t), before);
    assert_eq!(gap(&mut m, 18, t) & 4, 0, "open loop");
    let shaft = m.board().shaft();
    run_to(&mut m, t + Duration::from_millis(500));
    assert_eq!(m.board().shaft(), shaft, "nothing moved");
}

/// AP 129 := 1 during the encoder initialisation (AP 132 reads 1) is accepted and kept, and the loop
/// closes by itself when the initialisation ends (AP 133 reads 1, status word bit 2), without another
/// command — our decision (docs/decisions.md): AP 129 is the closed-loop mode, a setting the host may
/// write before the initialisation as well as after it (pytrinamic's TMCM-1311 demo writes it after);
/// it takes effect as soon as the loop can be closed. A failed initialisation leaves the loop open with
/// AP 129 still 1. Before, the loop stayed open until the next MVP closed it as a side effect.
#[test]
fn ap_129_during_the_initialisation_closes_the_loop_when_it_ends() {
    let mut m = module(&tmcm_1310::SPEC, "");
    let t = Instant::ZERO;
    sap(&mut m, 132, 1, t);
    let t = t + Duration::from_millis(50);
    run_to(&mut m, t);
    assert_eq!(gap(&mut m, 132, t), 1, "initialising");
    sap(&mut m, 129, 1, t);
    assert_eq!((gap(&mut m, 129, t), gap(&mut m, 133, t)), (1, 0), "kept, the loop not closed yet");
    // The next deadlines only, as a server polls: 400 ms later the initialisation (300 ms) is over.
    let mut now = t;
    let end = t + Duration::from_millis(400);
    while let Some(due) = m.poll(now, &mut |_: &[u8]| {}) {
        if due > end {
            break;
        }
        now = due.max(now + Duration::from_micros(1));
    }
    run_to(&mut m, end);
    assert_eq!(gap(&mut m, 132, end), 2, "initialisation done");
    assert_eq!(gap(&mut m, 133, end), 1, "the loop closed when it ended");
    assert_eq!(gap(&mut m, 18, end) & 4, 4, "status word: closed loop");
    let shaft = m.board().shaft();
    run_to(&mut m, end + Duration::from_millis(200));
    assert_eq!(m.board().shaft(), shaft, "closing moved nothing");

    // With the wrong encoder resolution the initialisation fails: AP 129 stays 1, the loop open.
    let mut m = module(&tmcm_1310::SPEC, "[encoder]\nkind = \"abn\"\ncounts_per_rev = 2000\n");
    sap(&mut m, 132, 1, Instant::ZERO);
    sap(&mut m, 129, 1, Instant::ZERO);
    let end = Instant::ZERO + Duration::from_millis(400);
    run_to(&mut m, end);
    assert_eq!((gap(&mut m, 132, end), gap(&mut m, 129, end), gap(&mut m, 133, end)), (3, 1, 0));
    assert_eq!(gap(&mut m, 18, end) & 4, 0, "open loop");
}

/// Polls `m` at its own deadlines from `from` to `until` (as `tmcl serve` and `tmcl run` do); returns
/// how many polls that took.
fn polls_to(m: &mut Module<SimBoard>, from: Instant, until: Instant) -> usize {
    let (mut t, mut polls) = (from, 0);
    while t < until {
        polls += 1;
        let next = m.poll(t, &mut |_: &[u8]| {});
        t = next.map_or(until, |n| n.min(until).max(t + Duration::from_micros(1)));
    }
    run_to(m, until);
    polls
}

#[test]
fn a_closed_loop_at_rest_sleeps_and_agrees_with_ticking() {
    // The loop closed, a move and back, then a minute standing: ticking takes a poll every millisecond;
    // the loop at rest (no error, the current scaler at its minimum) sleeps through the minute, but for
    // the I²t sum settling over the first seconds (one poll per stretch it computes ahead). Both end in
    // the same state.
    let mut runs = [true, false].map(|exact| {
        let mut m = module(&tmcm_1310::SPEC, "");
        m.set_exact_ticks(exact);
        let t0 = close_the_loop(&mut m);
        sap(&mut m, 0, REV, t0);
        let t = run_until(&mut m, t0, Duration::from_secs(5), |m, t| gap(m, 8, t) == 1);
        sap(&mut m, 0, 0, t);
        let t = run_until(&mut m, t, Duration::from_secs(5), |m, t| gap(m, 8, t) == 1);
        (m, t)
    });
    assert_eq!(runs[0].1, runs[1].1, "both arrive at the same tick");
    let t = runs[0].1;
    let end = t + Duration::from_secs(60);
    let [(exact, _), (fast, _)] = &mut runs;
    let ticked = polls_to(exact, t, end);
    let slept = polls_to(fast, t, end);
    assert!(ticked >= 59_000, "ticking: {ticked} polls");
    assert!(slept <= 100, "a loop at rest sleeps: {slept} polls in a minute");
    // (When each last called the board differs, as the equivalence harness allows: ticking brings the
    // board's clock to every tick.)
    let (a, b) = (&fast.state().axes()[0], &exact.state().axes()[0]);
    assert_eq!(a.closed_loop(), b.closed_loop());
    assert_eq!(a.ramp(), b.ramp());
    assert_eq!(fast.board().shaft(), exact.board().shaft());
    assert_eq!(fast.board().energy().to_bits(), exact.board().energy().to_bits());
    for p in [1, 8, 18, 27, 123, 131, 133, 230, 237] {
        assert_eq!(gap(fast, p, end), gap(exact, p, end), "AP {p}");
    }
    // The I²t sum settled on the way: I²·τ at the scaled-down current.
    assert!(gap(fast, 27, end) > 0);
    assert_eq!(gap(fast, 123, end), 100, "the scaler at its minimum (AP 113)");
}

#[test]
fn an_open_loop_turning_takes_spans_and_measures_as_ticking() {
    // Open loop, the TMCM-1310 measures its velocity (AP 131) from the encoder over the last 32 ms: a
    // minute of turning is spans but for the last 33 ticks before each poll, and reads as ticking.
    let mut runs = [true, false].map(|exact| {
        let mut m = module(&tmcm_1310::SPEC, "");
        m.set_exact_ticks(exact);
        exec(&mut m, Command::Ror { motor: 0, velocity: 51200 }, Instant::ZERO).unwrap();
        m
    });
    let end = Instant::ZERO + Duration::from_secs(60);
    let [exact, fast] = &mut runs;
    let ticked = polls_to(exact, Instant::ZERO, end);
    let spanned = polls_to(fast, Instant::ZERO, end);
    assert!(ticked >= 59_000, "ticking: {ticked} polls");
    assert!(spanned <= 100, "turning takes spans: {spanned} polls in a minute");
    let (a, b) = (&fast.state().axes()[0], &exact.state().axes()[0]);
    assert_eq!(a.closed_loop(), b.closed_loop());
    assert_eq!(a.ramp(), b.ramp());
    assert_eq!(gap(fast, 131, end), gap(exact, 131, end));
    assert!((gap(fast, 131, end) - 51200).abs() <= 400, "AP 131 {}", gap(fast, 131, end));
    // Read in the middle of a cruise too (the window then holds the last 32 ticks before the read).
    let t = end + Duration::from_micros(12_345_678);
    run_to(exact, t);
    run_to(fast, t);
    assert_eq!(fast.state().axes()[0].closed_loop(), exact.state().axes()[0].closed_loop());
    assert_eq!(gap(fast, 131, t), gap(exact, 131, t));
}

//! A span against the same ticks one by one.

use super::*;
use crate::motion::ramp::TickResult;

/// Bounds that hold nothing back but the length (the check ticks one by one).
const FREE: Bounds = Bounds {
    ticks: 200_000,
    forward: u64::MAX,
    backward: u64::MAX,
    min_speed: 1,
    max_speed: u32::MAX,
    ramping: true,
    work: u64::MAX,
};

/// Ticks `ramp` one by one as often as `span` did and checks that every tick was one a span may take,
/// that the state is the same, and that the span ends on a step (or has none).
fn check(ramp: Ramp, p: &RampParams, limits: Limits, b: &Bounds) -> Span {
    let mut fast = ramp;
    let span = fast.span(p, limits, b);
    let mut slow = ramp;
    let (mut steps, mut last) = (0i64, TickResult::default());
    let mut any = false;
    // The steps up to each tick, ticking.
    let mut upto = vec![0i64];
    for k in 0..span.ticks {
        let before = slow;
        last = slow.tick(TICK, p, limits);
        steps += last.steps;
        upto.push(steps);
        any |= last.steps != 0;
        assert!(!last.arrived && !last.stopped_by_switch, "tick {k} of {span:?} is an event: {last:?} from {before:?}");
        assert_eq!(last.ramping, b.ramping, "tick {k}: ramping");
        assert_eq!(slow.velocity.signum(), ramp.velocity.signum(), "tick {k}: direction");
        let speed = slow.velocity().unsigned_abs();
        assert!(speed >= b.min_speed.max(1) && speed <= b.max_speed, "tick {k}: speed {speed}");
        assert!(if steps >= 0 { steps.unsigned_abs() <= b.forward } else { steps.unsigned_abs() <= b.backward });
    }
    assert!(span.ticks <= b.ticks);
    assert_eq!(fast, slow, "after {} ticks, from {ramp:?} with {p:?}", span.ticks);
    assert_eq!(span.steps, steps);
    assert!(!any || last.steps != 0, "the span ends on a tick without a step");
    // The same span noting its trail: the same span, and what the trail tells is what ticking made, for
    // the last ticks (a closed loop's velocity window) and a sample of the others.
    let mut noted = ramp;
    let mut trail = Trail::default();
    assert_eq!(noted.span_noting(p, limits, b, &mut trail), span);
    assert_eq!(noted, fast);
    let n = span.ticks;
    let sample = (0..=n).step_by((n / 64).max(1) as usize).chain(n.saturating_sub(80)..=n);
    for k in sample {
        if let Some(s) = trail.steps_to(k) {
            assert_eq!(s, upto[k as usize], "the trail's steps up to tick {k} of {span:?} from {ramp:?}");
        }
    }
    let last_ticks = n.min(40);
    let mut told = vec![0i64; last_ticks as usize + 1];
    if trail.steps_from(n - last_ticks, &mut told) {
        assert_eq!(told, upto[(n - last_ticks) as usize..], "the trail's last ticks of {span:?} from {ramp:?}");
    }
    span
}

/// A span's trail tells the steps up to each of its last ticks (as many as a closed loop's velocity
/// window needs, and the one before) on every span of a move: its closed-form runs and its braking.
#[test]
fn a_trail_tells_the_last_ticks_of_every_span_of_a_move() {
    let mut ramp = Ramp::default();
    ramp.move_to(102_400);
    ramp.tick(TICK, &P, Limits::default());
    while !ramp.is_idle() {
        let ramping = ramp.velocity() != 51200;
        let span = check(ramp, &P, Limits::default(), &Bounds { ramping, ..FREE });
        let mut trail = Trail::default();
        ramp.span_noting(&P, Limits::default(), &Bounds { ramping, ..FREE }, &mut trail);
        let back = span.ticks.min(33);
        let mut told = [0i64; 34];
        assert!(trail.steps_from(span.ticks - back, &mut told[..=back as usize]), "{span:?}");
        assert_eq!(told[back as usize], span.steps);
        ramp.tick(TICK, &P, Limits::default());
    }
}

const P: RampParams = RampParams { max_speed: 51200, max_accel: 51200, min_speed: 0 };

#[test]
fn the_first_steps_move_takes_few_spans() {
    // §2.4: MVP ABS 512000 at 51200 pps, 51200 pps². The ramp up and the cruise are closed forms; the
    // braking ticks run one by one inside one span.
    let mut ramp = Ramp::default();
    ramp.move_to(512_000);
    ramp.tick(TICK, &P, Limits::default()); // the start, a normal tick
    let mut spans = 0;
    let mut ticks = 1;
    while !ramp.is_idle() {
        let ramping = ramp.velocity() != 51200;
        let span = check(ramp, &P, Limits::default(), &Bounds { ramping, ..FREE });
        ramp.span(&P, Limits::default(), &Bounds { ramping, ..FREE });
        spans += 1;
        ticks += span.ticks;
        if span.ticks == 0 {
            ramp.tick(TICK, &P, Limits::default()); // an event tick
            ticks += 1;
        }
        assert!(spans < 8, "{spans} spans");
    }
    assert_eq!(ramp.position, 512_000);
    assert!((10_990..=11_020).contains(&ticks), "{ticks}");
}

#[test]
fn a_slow_cruise_ends_on_its_last_step() {
    let mut ramp = Ramp::default();
    ramp.rotate(300); // 0.3 steps per tick
    for _ in 0..10 {
        ramp.tick(TICK, &P, Limits::default());
    }
    let span = check(ramp, &P, Limits::default(), &Bounds { ramping: false, ticks: 1000, ..FREE });
    assert!((995..=1000).contains(&span.ticks), "{span:?}");
    assert_eq!(span.steps, 300);
}

#[test]
fn bounds_stop_a_span() {
    let mut ramp = Ramp::default();
    ramp.rotate(-51200);
    ramp.tick(TICK, &P, Limits::default());
    let b = Bounds { backward: 10_000, ..FREE };
    let span = check(ramp, &P, Limits::default(), &b);
    assert!(span.steps >= -10_000 && span.steps < -9_900, "{span:?}");
    let b = Bounds { max_speed: 20_000, ..FREE };
    let span = check(ramp, &P, Limits::default(), &b);
    assert_eq!(span.ticks, 389, "up to 20000 pps, AP 3 truncated");
    let span = check(ramp, &P, Limits { block_negative: true, block_positive: false }, &FREE);
    assert_eq!(span.ticks, 0, "a switch stops the next tick");
}

/// A ramp in a random state: random commands, each followed by random ticks.
fn state(commands: &[(u8, i32, u16)], p: &RampParams, bits: u32) -> Ramp {
    let mut ramp = Ramp::default();
    ramp.set_position_bits(bits);
    for &(kind, value, ticks) in commands {
        match kind % 4 {
            0 => ramp.move_to(value),
            1 => ramp.move_to(ramp.position.wrapping_add(value / 64)),
            2 => ramp.rotate(value / 16),
            _ => ramp.set_position(value),
        }
        for _ in 0..ticks {
            ramp.tick(TICK, p, Limits::default());
        }
    }
    ramp
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]
    /// Any state, parameters and bounds: the span is exactly its ticks one by one.
    #[test]
    fn a_span_is_its_ticks(
        commands in proptest::collection::vec((0u8..4, -2_000_000i32..2_000_000, 0u16..1500), 1..5),
        vmax in proptest::prop_oneof![1i32..300_000, 1i32..i32::MAX],
        amax in proptest::prop_oneof![1i32..600_000, 1i32..i32::MAX],
        vmin in proptest::prop_oneof![0i32..3000, 0i32..i32::MAX],
        ticks in proptest::prop_oneof![0u64..3000, 0u64..200_000],
        forward in proptest::prop_oneof![0u64..50_000, proptest::strategy::Just(u64::MAX)],
        backward in proptest::prop_oneof![0u64..50_000, proptest::strategy::Just(u64::MAX)],
        speeds in (0u32..100_000, 0u32..u32::MAX),
        block in 0u8..4,
        bits in proptest::prop_oneof![proptest::strategy::Just(32u32), 20u32..32],
        work in proptest::prop_oneof![proptest::strategy::Just(u64::MAX), 0u64..300],
    ) {
        let p = RampParams { max_speed: vmax, max_accel: amax, min_speed: vmin };
        let ramp = state(&commands, &p, bits);
        let limits = Limits { block_negative: block & 1 != 0, block_positive: block & 2 != 0 };
        for ramping in [false, true] {
            let b = Bounds { ticks, forward, backward, min_speed: speeds.0, max_speed: speeds.1.max(speeds.0), ramping, work };
            check(ramp, &p, limits, &b);
            check(ramp, &p, Limits::default(), &Bounds { ramping, ..FREE });
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4096))]
    /// The braking root is the integer square root, from any start below it.
    #[test]
    fn the_braking_root_is_the_square_root(g in proptest::prop_oneof![0u64..1 << 40, 0u64..1 << 52], extra in proptest::prop_oneof![0u128..1 << 40, 0u128..1 << 100]) {
        let sq = (u128::from(g) + 1) * (u128::from(g) + 1) + extra;
        proptest::prop_assert_eq!(u128::from(root_above(sq, g)), sq.isqrt());
    }
}

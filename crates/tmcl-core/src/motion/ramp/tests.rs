use super::*;

const P: RampParams = RampParams { max_speed: 51200, max_accel: 51200, min_speed: 0 };

fn run_until_idle(ramp: &mut Ramp, p: &RampParams, max_ticks: u32) -> (u32, i32, i64) {
    let mut max_v = 0i64;
    let mut prev = ramp.velocity;
    let mut max_dv = 0i64;
    for t in 0..max_ticks {
        let r = ramp.tick(TICK, p, Limits::default());
        max_v = max_v.max(ramp.velocity.abs());
        if r.arrived {
            // The last microstep is taken at about sqrt(2·a·1 µstep), then the motor stands: that final
            // step down is physical (a stepper stops on a step), so it is bounded separately.
            let last = (2.0 * f64::from(p.max_accel)).sqrt() as i64 * MICRO + 2 * i64::from(p.max_accel) * 1000;
            assert!(prev.abs() <= last.max(i64::from(p.min_speed) * MICRO + 2 * i64::from(p.max_accel) * 1000));
        } else {
            max_dv = max_dv.max((ramp.velocity - prev).abs());
        }
        prev = ramp.velocity;
        if ramp.is_idle() {
            return (t + 1, (max_v / MICRO) as i32, max_dv);
        }
    }
    panic!("not idle after {max_ticks} ticks: {ramp:?}");
}

#[test]
fn trapezoid_reaches_target_exactly() {
    // §2.4: SAP 4/5 = 51200, MVP ABS 512000: 1 s ramp up (25600 µsteps), 9 s cruise, 1 s down.
    let mut ramp = Ramp::default();
    ramp.move_to(512_000);
    let (ticks, vmax, _) = run_until_idle(&mut ramp, &P, 20_000);
    assert_eq!(ramp.position, 512_000);
    assert_eq!(vmax, 51200);
    // 11 s ideal; allow a few ticks for the discrete arrival.
    assert!((10_990..=11_020).contains(&ticks), "{ticks} ticks");
    assert!(ramp.position_reached());
}

#[test]
fn triangle_when_too_short_for_full_speed() {
    let mut ramp = Ramp::default();
    ramp.move_to(-1000);
    let (ticks, vmax, _) = run_until_idle(&mut ramp, &P, 10_000);
    assert_eq!(ramp.position, -1000);
    // Peak speed of a triangle: sqrt(a·d) = sqrt(51200·1000) ≈ 7155 pps.
    assert!((6900..=7400).contains(&vmax), "{vmax}");
    // 2·sqrt(d/a) ≈ 0.28 s.
    assert!((270..=300).contains(&ticks), "{ticks}");
}

#[test]
fn acceleration_is_bounded() {
    let mut ramp = Ramp::default();
    ramp.move_to(300_000);
    let (_, _, max_dv) = run_until_idle(&mut ramp, &P, 20_000);
    // One tick may change the speed by at most AP5 × 1 ms, plus the final stop from the arrival speed.
    // Every tick but the arrival changes the speed by at most AP 5 × 1 ms (+1 µpps of rounding).
    assert!(max_dv <= 51200 * 1000 + 1, "{max_dv}");
}

#[test]
fn start_stop_speed() {
    let p = RampParams { min_speed: 5000, ..P };
    let mut ramp = Ramp::default();
    ramp.move_to(100_000);
    ramp.tick(TICK, &p, Limits::default());
    assert!(ramp.velocity() >= 5000, "ramp starts at AP 130");
    run_until_idle(&mut ramp, &p, 20_000);
    assert_eq!(ramp.position, 100_000);
}

#[test]
fn velocity_mode_accelerates_and_stops() {
    let mut ramp = Ramp::default();
    ramp.rotate(-51200);
    for _ in 0..500 {
        ramp.tick(TICK, &P, Limits::default());
    }
    assert_eq!(ramp.velocity(), -25600);
    for _ in 0..600 {
        ramp.tick(TICK, &P, Limits::default());
    }
    assert_eq!(ramp.velocity(), -51200);
    // 1 s up: ½·a·t² = 25600 µsteps, then 0.1 s at full speed = 5120.
    assert!((ramp.position + 30720).abs() <= 60, "{}", ramp.position);
    ramp.rotate(0);
    let (ticks, _, _) = run_until_idle(&mut ramp, &P, 5000);
    assert!((995..=1005).contains(&ticks), "{ticks}");
}

#[test]
fn velocity_reversal_goes_through_zero() {
    let mut ramp = Ramp::default();
    ramp.rotate(1000);
    for _ in 0..100 {
        ramp.tick(TICK, &P, Limits::default());
    }
    assert_eq!(ramp.velocity(), 1000);
    ramp.rotate(-1000);
    let mut seen_zero = false;
    for _ in 0..100 {
        ramp.tick(TICK, &P, Limits::default());
        seen_zero |= ramp.velocity() == 0;
    }
    assert!(seen_zero);
    assert_eq!(ramp.velocity(), -1000);
}

#[test]
fn target_behind_is_overshot_and_reached() {
    let mut ramp = Ramp::default();
    ramp.rotate(51200);
    for _ in 0..1000 {
        ramp.tick(TICK, &P, Limits::default());
    }
    let here = ramp.position;
    ramp.move_to(here + 100); // far too close to stop at 51200 pps
    let (_, _, max_dv) = run_until_idle(&mut ramp, &P, 10_000);
    assert_eq!(ramp.position, here + 100);
    assert!(max_dv <= 51200 * 1000 + 1, "{max_dv}");
}

#[test]
fn wraps_the_short_way() {
    // §3.7.4 note: a distance beyond 2^31-1 runs the other way.
    let mut ramp = Ramp::default();
    ramp.set_position(i32::MAX - 10);
    ramp.move_to(i32::MIN + 10);
    run_until_idle(&mut ramp, &P, 1000);
    assert_eq!(ramp.position, i32::MIN + 10);
}

#[test]
fn limit_switch_blocks_one_direction() {
    let mut ramp = Ramp::default();
    ramp.rotate(-1000);
    let block = Limits { block_negative: true, block_positive: false };
    for _ in 0..10 {
        ramp.tick(TICK, &P, block);
    }
    assert_eq!(ramp.position, 0);
    ramp.rotate(1000);
    for _ in 0..100 {
        ramp.tick(TICK, &P, block);
    }
    assert!(ramp.position > 0);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    /// Any move with any ramp parameters ends exactly on the target and never exceeds AP 4.
    #[test]
    fn moves_end_on_target(target in -200_000i32..200_000, vmax in 500i32..400_000, amax in 1000i32..2_000_000, vmin in 0i32..2000) {
        let p = RampParams { max_speed: vmax, max_accel: amax, min_speed: vmin };
        let mut ramp = Ramp::default();
        ramp.move_to(target);
        let mut max_v = 0;
        for _ in 0..1_000_000 {
            ramp.tick(TICK, &p, Limits::default());
            max_v = max_v.max(ramp.velocity().abs());
            if ramp.is_idle() { break; }
        }
        proptest::prop_assert!(ramp.is_idle());
        proptest::prop_assert_eq!(ramp.position, target);
        proptest::prop_assert!(max_v <= vmax.max(vmin.min(vmax)));
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    /// Position mode with targets changed at random times: the speed never exceeds AP 4 (nor the start
    /// speed AP 130 where that is higher) and changes by at most AP 5 per second, except for the final
    /// stop from the speed of the last microstep.
    #[test]
    fn position_ramps_respect_ap4_and_ap5(
        targets in proptest::collection::vec((-300_000i32..300_000, 1u32..3000), 1..6),
        vmax in 500i32..200_000,
        amax in 1000i32..500_000,
        vmin in 0i32..1000,
    ) {
        let p = RampParams { max_speed: vmax, max_accel: amax, min_speed: vmin };
        let mut ramp = Ramp::default();
        let step = i64::from(amax) * 1000 + 1; // µpps per 1 ms tick
        // The speed of the last microstep: decelerating with AP 5 to AP 130 over one microstep.
        let vmin_f = f64::from(vmin.min(vmax));
        let last_step = ((2.0 * f64::from(amax) + vmin_f * vmin_f).sqrt() as i64 + 2 * i64::from(amax) / 1000 + 1) * MICRO;
        for (target, ticks) in targets {
            ramp.move_to(target);
            for _ in 0..ticks {
                let before = ramp.velocity;
                let r = ramp.tick(TICK, &p, Limits::default());
                let dv = (ramp.velocity - before).abs();
                proptest::prop_assert!(ramp.velocity.abs() <= i64::from(vmax.max(vmin)) * MICRO);
                if r.arrived {
                    proptest::prop_assert!(dv <= last_step + 2 * step, "arrival step {dv} > {}", last_step + 2 * step);
                } else if before != 0 && ramp.velocity != 0 && before.signum() == ramp.velocity.signum() {
                    proptest::prop_assert!(dv <= step, "dv {dv} > {step}");
                }
            }
        }
    }

    /// Velocity mode: the speed approaches AP 2 with AP 5 and never overshoots it.
    #[test]
    fn velocity_ramps_respect_ap5(v1 in -300_000i32..300_000, v2 in -300_000i32..300_000, amax in 1000i32..500_000) {
        let p = RampParams { max_speed: 51200, max_accel: amax, min_speed: 0 };
        let mut ramp = Ramp::default();
        let step = i64::from(amax) * 1000 + 1;
        for v in [v1, v2] {
            ramp.rotate(v);
            for _ in 0..2000 {
                let before = ramp.velocity;
                ramp.tick(TICK, &p, Limits::default());
                proptest::prop_assert!((ramp.velocity - before).abs() <= step);
                proptest::prop_assert!(ramp.velocity.abs() <= i64::from(v1.unsigned_abs().max(v2.unsigned_abs())) * MICRO);
            }
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4096))]
    /// The u64 fast path of `braking_speed` answers exactly as the u128 computation, over the whole input
    /// range (distances up to 2³², speeds up to AP 4's i32 range and the `i64::MAX` cap of arrivals).
    #[test]
    fn braking_speed_fast_path_is_exact(
        distance in proptest::prop_oneof![0i64..100_000, 0i64..(1i64 << 33)],
        accel in proptest::prop_oneof![-5i32..100_000, proptest::num::i32::ANY],
        v_min in proptest::prop_oneof![0i64..2_000_000_000, -5i64..(i64::from(i32::MAX) * MICRO)],
        cap in proptest::prop_oneof![-5i64..(i64::from(i32::MAX) * MICRO), 0i64..300_000_000_000, proptest::strategy::Just(i64::MAX)],
    ) {
        proptest::prop_assert_eq!(braking_speed(distance, accel, v_min, cap), braking_speed_exact(distance, accel, v_min, cap));
    }
}

/// Around the braking point, where the fast path gives way to the exact test.
#[test]
fn braking_speed_fast_path_at_the_boundary() {
    for accel in [1, 7, 999, 1000, 1001, 51_200, 2_000_000, i32::MAX] {
        for v_min in [0, 1, MICRO * 100, MICRO * 51_200] {
            for distance in [0, 1, 2, 3, 100, 25_600, 1 << 20, 1 << 31] {
                let exact = braking_speed_exact(distance, accel, v_min, i64::MAX);
                for cap in [0, 1, exact - 1_000_001, exact - 1, exact, exact + 1, exact + 999_999, exact + 2_000_000] {
                    assert_eq!(
                        braking_speed(distance, accel, v_min, cap),
                        braking_speed_exact(distance, accel, v_min, cap)
                    );
                }
            }
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4096))]
    /// `braking_speed_above` is `braking_speed(…).max(toward − a·dt)`, the tick's formula before the
    /// square root was skipped where the floor wins.
    #[test]
    fn braking_speed_above_is_the_max_with_the_floor(
        distance in proptest::prop_oneof![0i64..100_000, 0i64..(1i64 << 33)],
        accel in proptest::prop_oneof![1i32..100_000, proptest::num::i32::ANY],
        v_min in proptest::prop_oneof![0i64..2_000_000_000, 0i64..(i64::from(i32::MAX) * MICRO)],
        toward in proptest::prop_oneof![0i64..300_000_000_000, 0i64..(i64::from(i32::MAX) * MICRO)],
        up in proptest::prop_oneof![0i64..300_000_000_000, 0i64..(i64::from(i32::MAX) * MICRO)],
    ) {
        let a_dt = i64::from(accel.max(1)) * 1000;
        proptest::prop_assert_eq!(
            braking_speed_above(distance, accel, v_min, up, toward).max(toward - a_dt),
            braking_speed(distance, accel, v_min, up).max(toward - a_dt)
        );
    }
}

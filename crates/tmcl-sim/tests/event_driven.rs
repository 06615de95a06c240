//! Event-driven time against the tick-by-tick reference (`tmcl_sim::equivalence`): random models, worlds,
//! settings, programs and host commands run both ways must show the same state, parameters, program
//! machine, board and replies at every host command and at the end.

use tmcl_sim::equivalence::Scenario;

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(
        std::env::var("EVENT_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(48)
    ))]
    #[test]
    fn event_driven_runs_are_tick_by_tick_runs(data in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
        let scenario = Scenario::decode(&data);
        if let Err(e) = scenario.check() {
            // EVENT_DIAG=1: also poll both on the same schedule, to tell a difference of the spans from one
            // of the polls (slow: the whole state is compared at every tick).
            let same = match std::env::var_os("EVENT_DIAG") {
                Some(_) => scenario.first_difference().unwrap_or_else(|| "none on the same polls".into()),
                None => "(EVENT_DIAG=1 to look)".into(),
            };
            proptest::prop_assert!(false, "{e}\n{scenario:?}\nsame polls: {same}");
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(
        std::env::var("EVENT_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(16)
    ))]
    /// The same for a TMCM-1310 with its loop closed at the start: the loop sleeps while it is at rest
    /// (`tmcl_core`'s `drive/closed_loop.rs`), and must do exactly what ticking does. (Fewer cases by
    /// default: both runs of a closed loop tick while it moves, about 2.4 s a case in a release build;
    /// `EVENT_CASES=200` ran before this was committed.)
    #[test]
    fn closed_loops_event_driven_are_closed_loops_tick_by_tick(
        data in proptest::collection::vec(proptest::num::u8::ANY, 0..400)
    ) {
        let scenario = Scenario::decode_closed_loop(&data);
        if let Err(e) = scenario.check() {
            let same = match std::env::var_os("EVENT_DIAG") {
                Some(_) => scenario.first_difference().unwrap_or_else(|| "none on the same polls".into()),
                None => "(EVENT_DIAG=1 to look)".into(),
            };
            proptest::prop_assert!(false, "{e}\n{scenario:?}\nsame polls: {same}");
        }
    }
}

/// The TMCM-3110 case the property test found (proptest seed `286fcb50…`, shrunk): nothing moves, a
/// program loops, the host reads AP 3. The two runs agree on everything; what differed was when each had
/// last called the board of motors 1 and 2 (a tick-by-tick run brings every motor's board clock on at
/// each tick, an event-driven one never calls a motor that stands), which the comparison left out for
/// motor 0 only.
#[test]
fn a_three_axis_module_at_rest_is_the_same_both_ways() {
    use tmcl_core::Instant;
    use tmcl_wire::Command;
    let world = "[[inputs.timeline]]\nat = \"8269 ms\"\ndigital = 5\n[[inputs.timeline]]\nat = \"8052 ms\"\n\
        digital = 9\n[[faults.driver]]\nfrom = \"8001 ms\"\nuntil = \"15313 ms\"\nflags = [\"short_a\"]\n\
        [[faults.encoder_slip]]\nat = \"4218 ms\"\ncounts = -4\n[[faults.supply_drop]]\nfrom = \"8794 ms\"\n\
        until = \"10264 ms\"\nvoltage = 15\n";
    let scenario = Scenario {
        spec: Scenario::decode(&[7]).spec,
        world: world.into(),
        settings: vec![
            Command::Sap { param: 154, motor: 0, value: 8 },
            Command::Sap { param: 153, motor: 0, value: 9 },
            Command::Sap { param: 174, motor: 0, value: 12 },
        ],
        program: vec![
            Command::Sgp { param: 2, bank: 3, value: 1905 },
            Command::Ei { interrupt: 27 },
            Command::Sgp { param: 1, bank: 3, value: 2280 },
            Command::Agp { param: 2, bank: 2 },
            Command::Ja { address: 3 },
            Command::Agp { param: 2, bank: 2 },
            Command::Reti,
        ],
        host: vec![
            (Instant::from_micros(802_928), Command::Gap { param: 3, motor: 0 }),
            (Instant::from_micros(3_155_226), Command::RunApplication { from: None }),
        ],
        polls: vec![Instant::from_micros(6_942_254)],
        end: Instant::from_micros(7_056_000),
    };
    assert_eq!(scenario.spec.motors, 3, "{}", scenario.spec.id);
    scenario.check().unwrap();
}

/// The scenarios draw both multi-axis models: a first byte of 7, then an odd byte, the TMCM-6110; an even
/// one (or none), the TMCM-3110.
#[test]
fn the_scenarios_draw_the_tmcm_6110_too() {
    assert_eq!(Scenario::decode(&[7, 1]).spec.name, "TMCM-6110");
    assert_eq!(Scenario::decode(&[7, 2]).spec.name, "TMCM-3110");
    assert_eq!(Scenario::decode(&[7]).spec.name, "TMCM-3110");
}

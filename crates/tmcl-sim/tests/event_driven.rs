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

//! Event-driven time against the tick-by-tick reference (`tmcl_sim::equivalence`): random models, worlds,
//! settings, programs and host commands run both ways must show the same state, parameters, program
//! machine, board and replies at every host command and at the end.

use tmcl_core::Instant;
use tmcl_sim::equivalence::Scenario;
use tmcl_wire::Command;

/// The scenario run event-driven and tick by tick must agree; on a difference the failure names it and
/// the scenario. EVENT_DIAG=1: also poll both on the same schedule, to tell a difference of the spans from
/// one of the polls (slow: the whole state is compared at every tick).
fn same_both_ways(scenario: &Scenario) -> Result<(), proptest::test_runner::TestCaseError> {
    if let Err(e) = scenario.check() {
        let same = match std::env::var_os("EVENT_DIAG") {
            Some(_) => scenario.first_difference().unwrap_or_else(|| "none on the same polls".into()),
            None => "(EVENT_DIAG=1 to look)".into(),
        };
        return Err(proptest::test_runner::TestCaseError::fail(format!("{e}\n{scenario:?}\nsame polls: {same}")));
    }
    Ok(())
}

/// A PD28-1021 without a world, settings, host commands or polls, running `program` for `end_ms`: the
/// shape of the loop skip's finds, cut down.
fn pd28_program(program: Vec<Command>, end_ms: u64) -> Scenario {
    Scenario {
        spec: &tmcl_core::model::pd28_1021::SPEC,
        world: String::new(),
        settings: Vec::new(),
        program,
        host: Vec::new(),
        polls: Vec::new(),
        end: Instant::from_millis(end_ms),
    }
}

/// The scenario must run the same both ways; on a difference the test fails with it.
fn assert_same(scenario: &Scenario) {
    if let Err(e) = scenario.check() {
        panic!("{e}");
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(
        std::env::var("EVENT_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(48)
    ))]
    #[test]
    fn event_driven_runs_are_tick_by_tick_runs(data in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
        let scenario = Scenario::decode(&data);
        same_both_ways(&scenario)?;
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
        same_both_ways(&scenario)?;
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

/// Several motors take their ticks at once (`several_spans` in tmcl-core's `module/spans.rs`) while one
/// of them stands, reaches its standby current by itself and then slips under a load its standby current
/// cannot hold: the standby's instant ends the run of ticks (the board hears of the new current at its
/// instant, as ticking has it), and the slipping motor's board, no longer quiet, makes the others tick.
#[test]
fn several_motors_one_standing_and_slipping_under_a_load() {
    let world = "[load]\nfriction = 0.002\n[[load.script]]\nat = \"700 ms\"\ntorque = 0.03\n\
        [[load.script]]\nat = \"1900 ms\"\ntorque = 0.0\n";
    for spec in [Scenario::decode(&[7, 1]).spec, Scenario::decode(&[7]).spec] {
        let scenario = Scenario {
            spec,
            world: world.into(),
            settings: vec![
                Command::Sap { param: 7, motor: 1, value: 4 },
                Command::Sap { param: 214, motor: 1, value: 30 },
                Command::Sap { param: 4, motor: 0, value: 1200 },
                Command::Sap { param: 4, motor: 2, value: 700 },
            ],
            program: vec![],
            host: vec![
                (Instant::from_millis(1), Command::Ror { motor: 0, velocity: 1000 }),
                (Instant::from_millis(2), Command::Mvp { motor: 1, target: tmcl_wire::MoveTarget::Rel(3000) }),
                (Instant::from_millis(3), Command::Ror { motor: 2, velocity: 500 }),
                (Instant::from_millis(2_500), Command::Gap { param: 1, motor: 1 }),
            ],
            polls: vec![Instant::from_millis(800), Instant::from_millis(1_234)],
            end: Instant::from_millis(3_000),
        };
        if let Err(e) = scenario.check() {
            panic!("{}: {e}\nsame polls: {:?}", spec.id, scenario.first_difference());
        }
    }
}

/// A stored scenario of the multi-axis property test on the TMCM-6110 (`data` after the bytes that
/// choose it) gives the same both ways.
fn same_on_the_tmcm_6110(data: &[u8]) {
    let mut bytes = vec![7, 1];
    bytes.extend_from_slice(data);
    let scenario = Scenario::decode(&bytes);
    assert_eq!(scenario.spec.motors, 6);
    assert_same(&scenario);
}

/// The multi-axis property test's first find (shrunk): a TMCM-6110 whose motors the heartbeat stops;
/// a motor that stopped in the tick before is still "ramping" (the boost current, AP 200, holds until
/// its next tick ends the speed change), and a run of ticks of the others skipped that tick.
#[test]
fn a_motor_stopped_in_the_tick_before_ticks_once_more() {
    same_on_the_tmcm_6110(&[
        103, 28, 10, 193, 254, 143, 254, 169, 143, 11, 101, 228, 23, 162, 118, 250, 65, 71, 121, 174, 78, 125, 242, 95,
        236, 14, 164, 125, 191, 242, 52, 143, 74, 40, 143, 12, 237, 174, 103, 198, 86, 34, 166, 180, 185, 154, 0, 68,
        19, 209, 34, 39, 211, 188, 172, 139, 84, 159, 245, 154, 224, 199, 107, 158, 166, 208, 143, 72, 14, 157, 71,
        222, 6, 236, 62, 120, 107, 118, 161, 132, 230, 232, 165, 151, 218, 95, 145, 74, 160, 153, 28, 137, 229, 162,
        242, 174, 170, 75, 71, 109, 239, 21, 224, 173, 139, 37, 164, 183, 184, 71, 169, 124, 85, 12, 52, 216, 145, 222,
        253, 100, 121, 21, 227, 66, 31, 139, 68, 71, 164, 191, 228, 182, 103, 62, 3, 228, 140, 25, 157, 221, 79, 193,
        101, 9, 170, 9, 44, 84, 78, 73, 176, 168, 32, 113, 22, 121, 213, 127, 155, 160, 157, 17,
    ]);
}

/// The multi-axis property test's find at 1 000 cases (shrunk): a TMCM-6110 whose motor 4 turns at about
/// half a step a tick against a detent torque, its rotor lagging the field. A look for the deadline brought
/// each moving motor's board to the tick's start before a tick did; a tick brings it there only after
/// the motors before it have ticked, whose boards bring its clock on with theirs, so its rotor settled at
/// another instant than ticking lets it, and after 6 s it stood a microstep elsewhere. With several
/// motors a look asks each board as it is.
#[test]
fn a_look_ahead_leaves_every_motors_board_as_ticking_finds_it() {
    same_on_the_tmcm_6110(&[
        222, 102, 64, 98, 108, 79, 184, 163, 54, 194, 32, 150, 249, 68, 46, 50, 251, 25, 23, 222, 89, 110, 147, 138,
        146, 95, 80, 114, 97, 190, 126, 67, 255, 127, 243, 78, 47, 235, 105, 248, 238, 190, 24, 141, 27, 254, 92, 246,
        14, 127, 73, 95, 231, 241, 232, 159, 105, 45, 97, 76, 168, 251, 19, 61, 34, 72, 120, 232, 92, 51, 113, 250,
        251, 4, 23, 4, 94, 178, 229, 143, 223, 245, 177, 101, 70, 217, 91, 45, 101, 123, 56, 11, 186, 254, 106, 46, 6,
        235, 219, 158, 91, 112, 47, 171, 98, 200, 191, 243, 100, 255, 74, 219, 114, 57, 110, 249, 78, 56, 84, 103, 152,
        172, 236, 2, 7, 235, 174, 233, 138, 171, 186, 141, 223, 61, 19, 248, 220, 87, 252, 64, 116, 87, 88, 223, 116,
        11, 140, 101, 183, 79, 45, 234, 225, 134, 75, 45, 141, 79, 94, 113, 6, 170, 205,
    ]);
}

/// The `event_driven` fuzz target's find (campaign on this round's code): a PD28-1021 moving at 120 pps
/// against a detent torque and a weak spring. After a step the rotor settles in two moves, the second at
/// the board's next update; a look for the deadline brought the board to the tick's start before the
/// next tick did, so at 3 s the event-driven board showed the second move and the ticked one not yet,
/// though a read at that instant (which brings the board there first) finds the same in both. The
/// comparison now looks at the boards as a read does (`Module::sync_boards`).
#[test]
fn boards_are_compared_as_a_read_finds_them() {
    let scenario = Scenario::decode(&[
        228, 126, 105, 116, 0, 95, 44, 32, 113, 27, 27, 27, 27, 27, 27, 27, 27, 27, 27, 27, 27, 27, 27, 113, 113, 63,
        1, 6, 0, 0, 0, 0, 119, 1, 0, 255, 103, 104, 255, 255, 255, 157, 255, 85, 34, 34, 34, 34, 34, 164, 48, 0, 126,
        105, 0, 58, 58, 58, 59, 0, 27, 27, 0, 0, 0, 0,
    ])
    .compressed(3_000);
    assert_eq!(scenario.spec.motors, 1);
    assert_same(&scenario);
}

/// The `event_driven` fuzz target's find: a PD28-1021 standing at its target in position mode, a
/// program that enabled the left-switch interrupt (so every tick samples the interrupt sources) and a
/// heartbeat (GP 68, 464 ms) that runs out with the motor standing. The ticks jumped over reached past the
/// heartbeat's expiry, so the tick after it was sampled with the motor still in position mode, and the
/// target-reached source's last level stayed "at the target" where a ticking module, stopped by the
/// heartbeat, had it leave. A jump now ends at the heartbeat's expiry.
#[test]
fn a_heartbeat_that_runs_out_while_standing_is_sampled_at_its_tick() {
    let scenario = Scenario::decode(&[
        108, 47, 126, 21, 63, 116, 65, 255, 255, 41, 255, 255, 108, 111, 98, 97, 97, 97, 97, 97, 41, 97, 102, 37, 158,
        158, 158, 156, 158, 88, 8, 97, 100, 29, 13, 29, 29, 29,
    ])
    .compressed(3_000);
    assert_eq!(scenario.spec.motors, 1);
    assert!(scenario.host.iter().any(|(_, c)| matches!(c, Command::Sgp { param: 68, .. })));
    assert_same(&scenario);
}

/// The `event_driven` fuzz target's fourth find, cut down: a PD28-1021 standing, its program setting the
/// freewheeling delay (AP 204, PD28-1021 manual §4) to 1 (10 ms) and back to 12 (120 ms) in a loop. Every
/// pass through the loop's jump back shows the delay of 120 ms, so the loop looked like a fixed point with
/// nothing due before 120 ms, and whole turns were jumped over past 10 ms: the driver kept its current
/// where a ticking module cuts it for the part of each turn with the delay of 1 (the coils' energy 0.023
/// against 0.013 A²s after 3 s). The instants a turn's states name are now gathered between the passes.
#[test]
fn a_loop_that_sets_a_delay_and_sets_it_back_is_sampled_where_it_runs_out() {
    assert_same(&pd28_program(
        vec![
            Command::Sap { param: 204, motor: 0, value: 1 },
            Command::Sap { param: 204, motor: 0, value: 12 },
            Command::Ja { address: 0 },
        ],
        3_000,
    ));
}

/// The `event_driven` fuzz target's fifth find, cut down (it came on a PD-113): a program that spins
/// reading the tick timer (GP 132, "incremented every 1 ms", PD28-1021 manual §5.1), jumps back at once
/// while it reads 8 and otherwise overwrites it with GIO 255 before its jump back. Every pass showed the
/// same state — the timer's value is the clock's, not the state's — so whole turns were jumped over the
/// millisecond in which it reads 8, and the program's turns fell out of step with ticking. A read of the
/// tick timer now names its next increment.
#[test]
fn a_loop_that_reads_the_tick_timer_is_sampled_where_it_changes() {
    use tmcl_wire::Condition;
    let program = vec![
        Command::Ggp { param: 132, bank: 0 },
        Command::Comp { operand: 8 },
        Command::Jc { condition: Condition::Zero, address: 0 },
        Command::Gio { port: 255, bank: 0 },
        Command::Ja { address: 0 },
    ];
    assert_same(&Scenario {
        host: vec![(Instant::from_micros(1_126_486), Command::StopApplication)],
        ..pd28_program(program, 1_500)
    });
}

/// The same for a timer (PD28-1021 manual §3.6.6): timer 0 every 50 ms, its interrupt enabled in the middle
/// of each turn and disabled before the jump back, where the pass shows no interrupt enabled. The ticks
/// that fall between EI and DI (a turn of 7 instructions against a tick of 50: every phase comes round)
/// sample the timer and run its handler, which counts its runs in a user variable.
#[test]
fn a_loop_that_enables_a_timer_only_between_its_passes_is_sampled_where_it_fires() {
    use tmcl_wire::CalcOp;
    let scenario = pd28_program(
        vec![
            Command::Vect { interrupt: 0, address: 10 },
            Command::Sgp { param: 0, bank: 3, value: 50 },
            Command::Ei { interrupt: 255 },
            // 3: the loop
            Command::Ei { interrupt: 0 },
            Command::Calc { op: CalcOp::Add, operand: 0 },
            Command::Calc { op: CalcOp::Add, operand: 0 },
            Command::Calc { op: CalcOp::Add, operand: 0 },
            Command::Calc { op: CalcOp::Add, operand: 0 },
            Command::Di { interrupt: 0 },
            Command::Ja { address: 3 },
            // 10: the handler: user variable 0 (GP 0, bank 2) counts its runs (RETI restores the accumulator)
            Command::Ggp { param: 0, bank: 2 },
            Command::Calc { op: CalcOp::Add, operand: 1 },
            Command::Agp { param: 0, bank: 2 },
            Command::Reti,
        ],
        3_000,
    );
    assert_same(&scenario);
    let mut module = scenario.module(false).expect("the scenario loads");
    module.poll(scenario.end, &mut |_: &[u8]| {});
    let runs = module.get_global(0, 2, scenario.end).expect("GP 0, bank 2");
    assert!(runs > 10, "the timer's handler ran {runs} times");
}

/// A PD28-1021 whose program waits (`WAIT TICKS`, 10 s) with timer 0 (PD28-1021 manual §3.6.6, every
/// 272 ms) enabled, its handler starting a `WAIT TICKS` of its own (1 s) and setting OUT0 after it.
fn waiting_program_with_a_timer_handler() -> Vec<Command> {
    use tmcl_wire::WaitCondition::Ticks;
    vec![
        Command::Vect { interrupt: 0, address: 6 },
        Command::Sgp { param: 0, bank: 3, value: 272 },
        Command::Ei { interrupt: 0 },
        Command::Ei { interrupt: 255 },
        // 4: the main program waits
        Command::Wait { condition: Ticks, motor: 0, ticks: 1_000 },
        Command::Ja { address: 4 },
        // 6: the handler
        Command::Wait { condition: Ticks, motor: 0, ticks: 100 },
        Command::Sio { port: 0, bank: 2, value: 1 },
        Command::Reti,
    ]
}

/// The `event_driven` fuzz target's seventh find, cut down (it came on a TMCM-1310 whose timer handler
/// started a `WAIT POS` with a timeout): a program waiting while the motor stands, a timer interrupt
/// sampled at a tick after standing ticks jumped over. A waiting program sleeps up to every tick, so
/// ticking leaves its clock at the tick that raised the interrupt; the jump left it where the program had
/// last been looked at, and the handler ran from there, in the past: its WAIT's end reckoned from an
/// earlier instant, which depended on when the module had last been polled (an extra poll of the
/// event-driven run at 150.7 ms against none: ends at 1.151 s and 1.000 s, where ticking has 1.273 s).
/// A jump over standing ticks now brings a waiting program's clock to its last tick, as a span does.
#[test]
fn a_timer_handler_after_standing_ticks_starts_at_the_tick_that_raised_it() {
    let mut scenario = pd28_program(waiting_program_with_a_timer_handler(), 600);
    scenario.polls = vec![Instant::from_micros(150_694)];
    assert_same(&scenario);
}

/// The same program, polled only at the module's deadlines (as `tmcl run` and `tmcl serve` do) and at
/// every tick: timer 0's period is set by the second instruction (at 20 µs), so it fires at 272.02 ms and
/// is sampled at the tick of 273 ms, where the handler starts its 1 s WAIT; OUT0 goes high at 1.273 s.
#[test]
fn a_timer_handler_runs_at_its_tick_however_the_module_is_polled() {
    let scenario = pd28_program(waiting_program_with_a_timer_handler(), 1_400);
    for exact in [false, true] {
        for every_tick in [false, true] {
            let mut module = scenario.module(exact).expect("the scenario loads");
            let mut t = Instant::ZERO;
            let mut out0_at = None;
            let check_at = Instant::from_millis(400);
            while t <= scenario.end {
                let deadline = module.poll(t, &mut |_: &[u8]| {});
                module.board_timeline().advance(t);
                if t == check_at {
                    let wait = module.vm().wait.expect("the handler waits");
                    assert_eq!(
                        (module.vm().pc, wait.until),
                        (6, Some(Instant::from_millis(1_273))),
                        "exact {exact}, every tick {every_tick}"
                    );
                }
                if out0_at.is_none() && module.board().outputs() & 1 == 1 {
                    out0_at = Some(t);
                }
                let tick = Instant::from_micros((t.micros() / 1000 + 1) * 1000);
                let mut next = if every_tick { tick } else { deadline.filter(|d| *d > t).unwrap_or(tick) };
                if t < check_at {
                    next = next.min(check_at);
                }
                t = next;
            }
            assert_eq!(out0_at, Some(Instant::from_millis(1_273)), "exact {exact}, every tick {every_tick}");
        }
    }
}

/// The `event_driven` fuzz target's find (a slow unit, 76 s): a TMCM-3110 whose three motors move slower
/// than a step a tick, each at its own rate (the TMC428's pulse divisors 9 to 11). A span ends on its last
/// step, so the three rarely ended on the same tick, and the first cut looked for one tick by tick; the
/// ticks after a motor's last step, which move none, are now taken as a second span.
#[test]
fn several_slow_motors_take_the_ticks_after_their_last_steps() {
    let scenario = Scenario::decode(&[
        255, 120, 0, 0, 33, 0, 0, 32, 0, 94, 0, 0, 0, 53, 37, 96, 247, 112, 152, 93, 159, 159, 159, 159, 159, 159, 159,
        205, 1, 35, 0, 0, 0, 10, 1, 102, 116, 108, 43, 101, 152, 93, 159, 159, 159, 159, 159, 159, 159, 205, 1, 35, 20,
    ])
    .compressed(3_000);
    assert_eq!(scenario.spec.motors, 3);
    assert_same(&scenario);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(
        std::env::var("EVENT_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(16)
    ))]
    /// The same for the models of several motors only (a scenario of `decode` is one of them one time in
    /// eight): their motors take runs of ticks together while others stand.
    #[test]
    fn several_motors_event_driven_are_several_motors_tick_by_tick(
        six in proptest::bool::ANY,
        data in proptest::collection::vec(proptest::num::u8::ANY, 0..400)
    ) {
        let mut bytes = vec![7, u8::from(six)];
        bytes.extend_from_slice(&data);
        let scenario = Scenario::decode(&bytes);
        same_both_ways(&scenario)?;
    }
}

/// The scenarios draw both multi-axis models: a first byte of 7, then an odd byte, the TMCM-6110; an even
/// one (or none), the TMCM-3110.
#[test]
fn the_scenarios_draw_the_tmcm_6110_too() {
    assert_eq!(Scenario::decode(&[7, 1]).spec.name, "TMCM-6110");
    assert_eq!(Scenario::decode(&[7, 2]).spec.name, "TMCM-3110");
    assert_eq!(Scenario::decode(&[7]).spec.name, "TMCM-3110");
}

/// The fuzz target's bound ([`Scenario::compressed`]): a scenario over the budget keeps every host
/// command and extra poll, in order and at the same fraction of the run; one within it is unchanged.
#[test]
fn a_compressed_scenario_keeps_its_events_closer_together() {
    let mut scenario = Scenario::decode(&[7, 1]);
    scenario.end = Instant::from_millis(12_000);
    scenario.host = vec![
        (Instant::from_millis(3_000), Command::Mst { motor: 0 }),
        (Instant::from_millis(3_000), Command::Mst { motor: 1 }),
        (Instant::from_micros(11_999_999), Command::Mst { motor: 2 }),
    ];
    scenario.polls = vec![Instant::from_millis(6_000)];
    // Six motors, 3 000 motor ticks: 500 ms.
    let short = scenario.clone().compressed(3_000);
    assert_eq!(short.end, Instant::from_millis(500));
    let times: Vec<_> = short.host.iter().map(|(t, _)| t.micros()).collect();
    assert_eq!(times, [125_000, 125_000, 499_999]);
    assert_eq!(
        short.host.iter().map(|(_, c)| *c).collect::<Vec<_>>(),
        scenario.host.iter().map(|(_, c)| *c).collect::<Vec<_>>()
    );
    assert_eq!(short.polls, [Instant::from_millis(250)]);
    assert!(short.check().is_ok());
    // Within the budget: as it was.
    let same = scenario.clone().compressed(72_000);
    assert_eq!((same.end, same.host.len(), same.polls.clone()), (scenario.end, 3, scenario.polls.clone()));
    assert_eq!(same.host[2].0, Instant::from_micros(11_999_999));
}

/// Closed-loop settings drawn for a cruising loop: current scaling and its times, I²t, the controller.
const CRUISING: &[(u8, i32, i32)] = &[
    (116, 0, 300),
    (117, 0, 300),
    (120, 0, 50),
    (121, 0, 50),
    (122, 0, 1),
    (124, 0, 200),
    (126, 0, 100_000),
    (136, 0, 1024),
    (25, 1, 20_000),
    (26, 0, 3_000_000),
    (111, 0, 256),
];

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(
        std::env::var("EVENT_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(24)
    ))]
    /// A TMCM-1310 whose closed loop cruises for seconds (ROR, or an MVP to a far target) at speeds,
    /// resolutions, encoder resolutions and controller settings drawn at random, with host commands now and
    /// then (reads, a new speed, a parameter, a stop): event-driven, the loop's ticks are taken in whole
    /// periods where they repeat (`module/periods.rs` in tmcl-core), and must do exactly what ticking does.
    #[test]
    fn closed_loops_cruising_event_driven_are_closed_loops_tick_by_tick(
        full_steps in -1_800i32..1_800,
        round in proptest::bool::ANY,
        odd in proptest::option::of(0i32..100),
        accel in 20_000i32..400_000,
        resolution in 0i32..=8,
        encoder in proptest::sample::select(vec![4096, 4096, 1024, 16_384, 2000, 4000]),
        far in proptest::bool::ANY,
        settings in proptest::collection::vec((0usize..CRUISING.len(), proptest::num::u32::ANY), 0..4),
        host in proptest::collection::vec((0u64..20_000, 0u8..6, -100_000i32..100_000), 0..4),
        polls in proptest::collection::vec(0u64..20_000, 0..4),
        switch in proptest::option::of(-2_000_000i64..2_000_000),
    ) {
        use tmcl_core::{Duration, Instant};
        use tmcl_sim::equivalence::Scenario;
        use tmcl_wire::{Command, MoveTarget};
        // Within the loop's reach (just under two full steps a tick), a whole number of full steps a
        // second or not.
        // Half the time a multiple of 50 full steps a second: periods short enough to repeat within the run.
        let full_steps = if round { full_steps / 50 * 50 } else { full_steps };
        let speed = full_steps * (1 << resolution) + odd.unwrap_or(0) * full_steps.signum();
        let mut first = vec![
            Command::Sap { param: 140, motor: 0, value: resolution },
            Command::Sap { param: 210, motor: 0, value: encoder },
            Command::Sap { param: 5, motor: 0, value: accel },
            Command::Sap { param: 4, motor: 0, value: speed.abs().max(1) },
            Command::Sap { param: 132, motor: 0, value: 1 },
            Command::Sap { param: 129, motor: 0, value: 1 },
        ];
        first.extend(settings.iter().map(|&(i, v)| {
            let (param, lo, hi) = CRUISING[i];
            Command::Sap { param, motor: 0, value: lo + (v % (hi - lo + 1) as u32) as i32 }
        }));
        let start = if far {
            Command::Mvp { motor: 0, target: MoveTarget::Abs(speed.signum() * 2_000_000_000) }
        } else if speed >= 0 {
            Command::Ror { motor: 0, velocity: speed }
        } else {
            Command::Rol { motor: 0, velocity: -speed }
        };
        let mut host: Vec<(Instant, Command)> = host
            .iter()
            .map(|&(ms, kind, v)| {
                let c = match kind {
                    0 => Command::Gap { param: 1, motor: 0 },
                    1 => Command::Gap { param: 131, motor: 0 },
                    2 => Command::Ror { motor: 0, velocity: v },
                    3 => Command::Sap { param: 124, motor: 0, value: v.rem_euclid(200) },
                    4 => Command::Mst { motor: 0 },
                    _ => Command::Sap { param: 209, motor: 0, value: v },
                };
                (Instant::from_millis(ms + 500), c)
            })
            .collect();
        // The move starts once the loop is closed (the initialisation takes 300 ms).
        host.push((Instant::from_millis(400), start));
        host.sort_by_key(|(t, _)| *t);
        let world = match switch {
            Some(at) => format!("[switches.right]\nat = [\"{at} usteps\", \"{} usteps\"]\n", at + 5_000),
            None => String::new(),
        };
        let mut polls: Vec<Instant> = polls.iter().map(|&ms| Instant::from_millis(ms) + Duration::from_micros(ms % 997)).collect();
        polls.sort();
        let scenario = Scenario {
            spec: &tmcl_core::model::tmcm_1310::SPEC,
            world,
            settings: first,
            program: Vec::new(),
            host,
            polls,
            end: Instant::from_millis(21_000),
        };
        same_both_ways(&scenario)?;
    }
}

/// pytrinamic's closed-loop demo, then ROR at 51 200 pps: event-driven and tick by tick agree after a
/// minute, with reads of AP 1 and AP 131 now and then; and polled only at its deadlines, the module
/// needs a handful of polls for an hour of it (the loop's ticks repeat every 250 ticks and are taken in
/// whole periods, `module/periods.rs` in tmcl-core), not one a millisecond.
#[test]
fn a_closed_loop_turning_steadily_sleeps_and_is_what_ticking_gives() {
    use tmcl_core::Instant;
    use tmcl_sim::equivalence::Scenario;
    use tmcl_wire::Command;
    let spec = &tmcl_core::model::tmcm_1310::SPEC;
    let setup = vec![Command::Sap { param: 132, motor: 0, value: 1 }, Command::Sap { param: 129, motor: 0, value: 1 }];
    let ror = Command::Ror { motor: 0, velocity: 51_200 };
    let scenario = Scenario {
        spec,
        world: String::new(),
        settings: setup.clone(),
        program: Vec::new(),
        host: vec![
            (Instant::from_millis(400), ror),
            (Instant::from_millis(7_777), Command::Gap { param: 1, motor: 0 }),
            (Instant::from_millis(31_003), Command::Gap { param: 131, motor: 0 }),
        ],
        polls: vec![Instant::from_micros(12_345_678)],
        end: Instant::from_millis(60_000),
    };
    scenario.check().unwrap();

    let (mut module, polls) = turned_at_deadlines(spec, &setup, ror, Instant::from_secs(3600));
    assert_eq!(module.get_axis(133), Ok(1), "the loop stays closed");
    assert_eq!(module.get_axis(3), Ok(51_200));
    let measured = module.get_axis(131).unwrap();
    assert!((measured - 51_200).abs() < 1_000, "the measured speed: {measured}");
    assert!(polls < 5_000, "{polls} polls for an hour");
}

/// A closed loop cruising slower than a microstep a tick (ROR 200 at 4 microsteps a full step: 0.2
/// microsteps a tick, a step every fifth tick), the case the property test above found: a period of 500
/// ticks ends four ticks after its last step, and the jump over whole periods once took the ramp's state
/// from a span, which ends on its last step, so each jump lost those four ticks' 0.8 microsteps of
/// fraction (AP 1 one microstep behind ticking from 1.9 s on). Event-driven and tick by tick agree over
/// 21 s, and polled only at its deadlines the module still sleeps through whole periods.
#[test]
fn a_slow_closed_loop_cruise_keeps_the_ramps_fraction_over_whole_periods() {
    use tmcl_core::Instant;
    use tmcl_sim::equivalence::Scenario;
    use tmcl_wire::Command;
    let spec = &tmcl_core::model::tmcm_1310::SPEC;
    let setup = vec![
        Command::Sap { param: 140, motor: 0, value: 2 },
        Command::Sap { param: 210, motor: 0, value: 4096 },
        Command::Sap { param: 5, motor: 0, value: 33_334 },
        Command::Sap { param: 4, motor: 0, value: 200 },
        Command::Sap { param: 132, motor: 0, value: 1 },
        Command::Sap { param: 129, motor: 0, value: 1 },
    ];
    let ror = Command::Ror { motor: 0, velocity: 200 };
    let scenario = Scenario {
        spec,
        world: String::new(),
        settings: setup.clone(),
        program: Vec::new(),
        host: vec![(Instant::from_millis(400), ror)],
        polls: Vec::new(),
        end: Instant::from_millis(21_000),
    };
    scenario.check().unwrap();

    let (mut module, polls) = turned_at_deadlines(spec, &setup, ror, Instant::from_secs(600));
    assert_eq!(module.get_axis(133), Ok(1), "the loop stays closed");
    // 200 microsteps a second from 0.4 s on (the ramp reaches its speed within 6 ms, AP 5 = 33 334); with
    // the loop closed AP 1 is the rotor's, a few microsteps behind the ramp.
    let position = module.get_axis(1).unwrap();
    assert!((position - 119_919).abs() <= 5, "AP 1 after 600 s: {position}");
    assert!(polls < 2_000, "{polls} polls for 10 minutes (600 000 ticks)");
}

/// A module of `spec` set up with `setup` at 0 and sent `ror` at 0.4 s, then polled only at its deadlines
/// up to `end`: the module and how many polls it took.
fn turned_at_deadlines(
    spec: &'static tmcl_core::model::ModelSpec,
    setup: &[tmcl_wire::Command],
    ror: tmcl_wire::Command,
    end: tmcl_core::Instant,
) -> (tmcl_core::Module<tmcl_sim::SimBoard>, usize) {
    use tmcl_core::{Instant, Module};
    let mut module = Module::new(tmcl_sim::SimBoard::in_memory_for(spec), spec, Instant::ZERO);
    for &c in setup {
        module.execute(c, Instant::ZERO).unwrap();
    }
    module.poll(Instant::from_millis(400), &mut |_: &[u8]| {});
    module.execute(ror, Instant::from_millis(400)).unwrap();
    let (mut t, mut polls) = (Instant::from_millis(400), 0);
    while t < end {
        t = module.poll(t, &mut |_: &[u8]| {}).unwrap_or(end).clamp(t + tmcl_core::Duration::from_micros(1), end);
        polls += 1;
    }
    module.poll(end, &mut |_: &[u8]| {});
    (module, polls)
}

/// The `event_driven` fuzz target's sixth find (a slow unit: 34.6 s for one run, 13.6 s of it
/// event-driven): a PD28-1021 with its maximum current (AP 6) at 0 searching its reference twice against
/// a constant load beyond the torque it still gives, a jam ahead. The rotor slides 64 periods at every
/// settle, and the settle's march looked 4 096 times for a place to stop, a sine each, at every part of
/// every tick. A slide nothing on the way can stop is now taken in one step (`Mechanics::settle`):
/// 25 ms both ways.
#[test]
fn a_search_against_a_load_beyond_the_torque_slides_at_once() {
    let scenario = Scenario::decode(&[
        43, 131, 0, 0, 0, 0, 0, 32, 0, 0, 2, 192, 171, 91, 255, 118, 0, 32, 0, 0, 0, 118, 0, 104, 111, 105, 101, 131,
        0, 8, 0, 0, 2, 192, 43, 91, 255, 118, 0, 40, 8, 32, 42, 255, 42, 43, 42, 131, 44, 32, 1, 0,
    ])
    .compressed(3_000);
    assert_eq!(scenario.spec.id, "pd28-1021");
    assert!(scenario.settings.contains(&Command::Sap { param: 6, motor: 0, value: 0 }));
    assert!(scenario.world.contains("[[load.jam]]"));
    assert_same(&scenario);
}

//! The library as a program other than `tmcl` uses it: the same traces as the checked-in ones, the trace
//! in memory and the CSV written on the fly byte for byte alike, setup errors, positions in the world.

use std::path::{Path, PathBuf};
use tmcl_core::Duration;
use tmcl_run::{
    run, Csv, Event, Options, Quantity, RunError, Setting, Setup, SetupError, Simulation, Sink, Source, Tee, Trace,
    Unit,
};
use tmcl_sim::World;

/// The model of the manual's programs.
const PD28: &tmcl_core::model::ModelSpec = &tmcl_core::model::pd28_1021::SPEC;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn options(secs: u64, every_ms: u64) -> Options {
    Options { every: Duration::from_millis(every_ms), ..Options::new(Duration::from_secs(secs)) }
}

#[test]
fn the_library_gives_the_checked_in_traces() {
    // The same runs as crates/tmcl-cli/tests/expected_traces.rs, through the library.
    for (name, model, secs, every, world, drive) in [
        ("manual_p02_timer_interrupt", "pd28-1021", 5, 50, None, false),
        ("manual_p08_csub", "pd28-1021", 5, 50, None, false),
        ("pd113_first_program", "pd-113", 12, 100, None, false),
        ("tmcm1310_closed_loop", "tmcm-1310", 6, 20, Some("examples/worlds/closed-loop-seizure.toml"), true),
        ("tmcm3110_xyz", "tmcm-3110", 3600, 20000, Some("examples/worlds/xyz-stage.toml"), false),
    ] {
        let mut setup = Setup::new(model).unwrap();
        let source = Source::load(&root().join(format!("tests/programs/{name}.tmc")), setup.model).unwrap();
        if let Some(world) = world {
            setup = setup.with_world(World::load(root().join(world)).unwrap());
        }
        let options = Options { drive, ..options(secs, every) };
        let (trace, summary) = run(&source, &setup, &options).unwrap();
        let mut csv = Vec::new();
        trace.write_csv(&mut csv).unwrap();
        let expected = std::fs::read(root().join(format!("tests/programs/expected/{name}.csv"))).unwrap();
        assert!(csv == expected, "{name}: the library's trace differs from the checked-in one");
        assert_eq!(summary.rows as usize, trace.len(), "{name}");
    }
}

#[test]
fn a_streamed_csv_and_the_trace_in_memory_agree() {
    let source = Source::load(&root().join("tests/programs/manual_p01_first_steps.tmc"), PD28).unwrap();
    let setup = Setup::new("pd28-1021").unwrap().with_setting(Setting::Global { number: 7, bank: 2, value: 5 });
    let mut simulation = Simulation::new(&source, &setup).unwrap();
    let mut trace = Trace::new();
    let mut streamed = Vec::new();
    let mut reports = 0;
    let mut progress = |_| reports += 1;
    let options = Options { drive: true, ..options(30, 10) };
    let sink: &mut dyn Sink = &mut Tee(Csv::new(&mut streamed), &mut trace);
    simulation.run(&options, Some(sink), Some(&mut progress)).unwrap();
    assert!(reports >= 30, "progress about every simulated second: {reports}");
    let mut written = Vec::new();
    trace.write_csv(&mut written).unwrap();
    assert!(streamed == written, "the CSV of the trace in memory is the CSV written during the run");
    // Typed columns with their units.
    let var7 = trace.position(Quantity::Variable(7)).expect("the --set variable has a column");
    assert_eq!(trace.columns()[var7].name, "var7");
    assert!(trace.values[var7].iter().all(|v| v == Some(5)));
    let energy = trace.position(Quantity::Energy).unwrap();
    assert_eq!(trace.columns()[energy].unit, Unit::AmpereSquaredSeconds);
    let joules = trace.scaled(energy);
    assert!(joules.windows(2).all(|w| w[1] >= w[0]), "the energy only grows");
    assert_eq!(trace.columns()[trace.position(Quantity::Velocity).unwrap()].unit.symbol(), "pps");
    assert!(trace.events.iter().any(|e| e.event == Event::Target(512_000)));
    // A simulation runs once.
    assert!(matches!(simulation.run(&options, None, None), Err(RunError::AlreadyRun)));
}

#[test]
fn setup_errors_say_what_is_wrong() {
    assert!(matches!(Setup::new("tmcm-9999"), Err(SetupError::UnknownModel(_))));
    let sac = Source::assemble("sac.tmc", "SAC 0, 1, 5\nSTOP\n", PD28).unwrap();
    let Err(SetupError::Commands { diagnostics, model, .. }) = Simulation::new(&sac, &Setup::new("pd28-1021").unwrap())
    else {
        panic!("SAC is a PDx-113 command only")
    };
    assert_eq!((diagnostics.len(), diagnostics[0].line, model), (1, 1, "PD28-1021"));
    assert!(Simulation::new(&sac, &Setup::new("pd-113").unwrap()).is_ok());
    let refused = Setup::new("pd28-1021").unwrap().with_setting(Setting::Axis { number: 4, motor: 0, value: -5 });
    let stop = Source::assemble("stop.tmc", "STOP\n", PD28).unwrap();
    assert!(matches!(Simulation::new(&stop, &refused), Err(SetupError::Setting { .. })));
}

#[test]
fn positions_are_placed_in_the_world_also_after_a_reference_search() {
    // The linear stage: 2 mm per revolution (51200 µsteps), the carriage at 25 mm at power-up, the left
    // switch up to 0 mm. A search to the left switch sets the step counter's 0 there; then 1 280 000 µsteps
    // are 50 mm from it.
    let source = Source::assemble(
        "rfs.tmc",
        "SAP 193, 0, 1\nSAP 194, 0, 100000\nSAP 4, 0, 200000\nRFS START, 0\nWait: RFS STATUS, 0\nJC NZ, Wait\n\
         MVP ABS, 0, 1280000\nWAIT POS, 0, 0\nSTOP\n",
        PD28,
    )
    .unwrap();
    let world = World::load(root().join("examples/worlds/linear-stage.toml")).unwrap();
    let setup = Setup::new("pd28-1021").unwrap().with_world(world);
    let (trace, summary) = run(&source, &setup, &options(20, 20)).unwrap();
    assert_eq!(summary.state, "stopped");
    let unit = trace.header.as_ref().unwrap().world_unit.as_ref().expect("a world unit");
    assert_eq!(unit.name, "mm");
    assert_eq!(trace.placements.len(), trace.len());
    let first = trace.placements[0];
    assert!((first.place(0) - 25.0).abs() < 1e-9, "the step counter's 0 at the start: {first:?}");
    assert!((first.per_microstep - 2.0 / 51200.0).abs() < 1e-15);
    let actual = trace.column(Quantity::ActualPosition).unwrap();
    let last = trace.len() - 1;
    let at_end = trace.placements[last].place(actual.get(last).unwrap());
    assert!((at_end - 50.0).abs() < 0.01, "50 mm from the left switch: {at_end}");
    // The left switch was pressed and released during the search, the home flag at 50 mm is pressed at the
    // end.
    let left = |l: &tmcl_run::Levels| l.switches & 0b010 != 0;
    assert!(trace.levels.iter().any(left));
    assert!(trace.levels.last().is_some_and(|l| l.switches & 0b001 != 0), "{:?}", trace.levels.last());
}

/// A multi-axis run in a world with `[motors.N]`: every motor's positions are placed in its own world, in
/// its own unit (the XYZ stage: X on a 2 mm lead, Y on 1 mm, Z on 0.5 mm). After the reference searches
/// and the first interpolated move the three stand at corner 1, X 10 mm, Y 10 mm, Z 5 mm from their left
/// switches; at power-up each was where its world puts it (25, 10 and 5 mm).
#[test]
fn every_motor_is_placed_in_its_own_world() {
    let spec = tmcl_core::model::by_id("tmcm-3110").unwrap();
    let source = Source::load(&root().join("tests/programs/tmcm3110_xyz.tmc"), spec).unwrap();
    let world = World::load(root().join("examples/worlds/xyz-stage.toml")).unwrap();
    let setup = Setup::new("tmcm-3110").unwrap().with_world(world);
    let (trace, _) = run(&source, &setup, &options(10, 100)).unwrap();
    let header = trace.header.as_ref().unwrap();
    assert_eq!(header.motor_world_units.iter().map(|u| u.name.as_str()).collect::<Vec<_>>(), ["mm", "mm"]);
    assert_eq!(trace.motor_placements.len(), 2);
    assert!(trace.motor_placements.iter().all(|p| p.len() == trace.len()));
    // The row of the second move's start (MVP COORD to corner 2): every motor still at corner 1.
    let second = trace.events.iter().find(|e| e.event == tmcl_run::Event::Target(80_000)).expect("the second move").row;
    let actual = |m: u8| trace.column_of(Quantity::ActualPosition, m).unwrap();
    let place = |m: u8, row: usize| match m {
        0 => trace.placements[row].place(actual(0).get(row).unwrap()),
        m => trace.motor_placements[usize::from(m) - 1][row].place(actual(m).get(row).unwrap()),
    };
    let at = |row| [place(0, row), place(1, row), place(2, row)];
    for (got, want) in at(0).iter().zip([25.0, 10.0, 5.0]) {
        assert!((got - want).abs() < 1e-9, "at power-up {:?}", at(0));
    }
    for (got, want) in at(second).iter().zip([10.0, 10.0, 5.0]) {
        assert!((got - want).abs() < 0.01, "at corner 1 {:?}", at(second));
    }
}

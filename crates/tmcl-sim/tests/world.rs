//! World files: the examples parse, and every mistake is reported with its key and line.

use std::path::PathBuf;
use tmcl_sim::world::{Active, AxisKind, DriverFlag, Pos};
use tmcl_sim::{SimBoard, World, WorldError};

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/worlds")
}

fn err(toml: &str) -> WorldError {
    World::from_toml_str(toml).expect_err("must be rejected")
}

fn assert_err(toml: &str, key: &str, line: usize, says: &str) {
    let e = err(toml);
    assert_eq!(e.key.as_deref(), Some(key), "{e}");
    assert_eq!(e.line, Some(line), "{e}");
    assert!(e.message.contains(says), "{e}");
    let shown = e.to_string();
    assert!(shown.contains(&format!("line {line}")) && shown.contains(key), "{shown}");
}

#[test]
fn every_example_world_loads() {
    let mut n = 0;
    for entry in std::fs::read_dir(examples()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let world = World::load(&path).unwrap_or_else(|e| panic!("{e}"));
            if world.motors.is_empty() {
                SimBoard::in_memory(16).with_world(world).unwrap();
            } else {
                // A world with `[motors.N]` tables is for a module with several motors.
                let spec = tmcl_core::model::by_id("tmcm-6110").unwrap();
                let nvm = tmcl_sim::Eeprom::Memory(tmcl_sim::MemNvm::new(4096));
                SimBoard::for_model(spec, nvm).with_world(world).unwrap();
            }
            n += 1;
        }
    }
    assert!(n >= 4, "examples/worlds has {n} files");
}

#[test]
fn linear_stage_example_reads_as_written() {
    let w = World::load(examples().join("linear-stage.toml")).unwrap();
    assert_eq!(w.axis.kind, AxisKind::Linear);
    assert_eq!(*w.axis.lead.get_ref(), 2.0);
    assert_eq!(*w.axis.start.get_ref(), Pos::Axis(25.0));
    let home = w.switches.home.as_ref().unwrap();
    assert_eq!(home.active, Active::High);
    assert_eq!(home.bounce.unwrap().count, 2);
    assert_eq!(home.bounce.unwrap().time.0.micros(), 2000);
}

#[test]
fn empty_file_is_the_default_world() {
    assert_eq!(World::from_toml_str("").unwrap(), World::default());
}

#[test]
fn units_of_positions_and_times() {
    let w = World::from_toml_str(
        "[axis]\nkind = \"linear\"\nstart = \"3 rev\"\n[[faults.stall]]\nat = \"800 fullsteps\"\nfrom = \"1.5 s\"\n\
         until = \"1600 ms\"\n[[faults.driver]]\nfrom = 2\nflags = [\"prewarning\", \"open_b\"]",
    )
    .unwrap();
    assert_eq!(*w.axis.start.get_ref(), Pos::Rev(3.0));
    assert_eq!(*w.faults.stall[0].at.get_ref(), Pos::FullSteps(800.0));
    assert_eq!(w.faults.stall[0].from.0.micros(), 1_500_000);
    assert_eq!(w.faults.stall[0].until.unwrap().0.micros(), 1_600_000);
    assert_eq!(w.faults.driver[0].flags, [DriverFlag::Prewarning, DriverFlag::OpenB]);
}

#[test]
fn unknown_top_level_table() {
    assert_err("[motor]\nfull_steps = 200\n\n[axle]\nkind = \"rotary\"\n", "axle", 4, "unknown field `axle`");
}

#[test]
fn unknown_top_level_key() {
    assert_err("# a comment\nbogus = 1\n[motor]\n", "bogus", 2, "unknown field `bogus`");
}

#[test]
fn unknown_key_in_a_table() {
    assert_err("[motor]\nfull_steps = 200\nholding_torqe = 0.1\n", "motor.holding_torqe", 3, "unknown field");
}

#[test]
fn unknown_key_in_an_array_of_tables() {
    assert_err(
        "[[load.jam]]\nat = [1, 2]\n\n[[load.jam]]\nat = [5, 6]\ntorq = 3\n",
        "load.jam.torq",
        6,
        "unknown field",
    );
}

#[test]
fn unknown_key_in_an_inline_table() {
    assert_err(
        "[switches.home]\nat = [0, 1]\nbounce = { time = \"1 ms\", cnt = 3 }\n",
        "switches.home.bounce.cnt",
        3,
        "unknown field",
    );
}

#[test]
fn wrong_type() {
    assert_err("[motor]\n\nfull_steps = \"many\"\n", "motor.full_steps", 3, "invalid type");
}

#[test]
fn bad_unit() {
    assert_err("[axis]\nstart = \"3 furlongs\"\n", "axis.start", 2, "unknown position unit `furlongs`");
    assert_err("[[load.script]]\nat = \"3 days\"\ntorque = 0.1\n", "load.script.at", 2, "unknown time unit");
}

#[test]
fn bad_enum_value() {
    assert_err("[switches.left]\nat = [0, 1]\nactive = \"sideways\"\n", "switches.left.active", 3, "unknown variant");
    assert_err("[[faults.driver]]\nfrom = 1\nflags = [\"melted\"]\n", "faults.driver.flags", 3, "unknown variant");
}

#[test]
fn missing_required_key() {
    let e = err("[switches.right]\nactive = \"low\"\n");
    assert!(e.message.contains("missing field `at`"), "{e}");
    assert_eq!(e.key.as_deref(), Some("switches.right"), "{e}");
}

#[test]
fn a_unit_the_axis_does_not_have() {
    assert_err("# rotary by default\n[switches.home]\nat = [\"1 mm\", \"2 mm\"]\n", "switches.home.at", 3, "`mm`");
    assert_err(
        "[axis]\nkind = \"linear\"\n[load.spring]\nrate = 0.1\nrest = \"5 deg\"\n",
        "load.spring.rest",
        5,
        "`deg`",
    );
}

#[test]
fn out_of_range_values() {
    assert_err("[motor]\nfull_steps = 202\n", "motor.full_steps", 2, "multiple of 4");
    assert_err("[motor]\nholding_torque = -1.0\n", "motor.holding_torque", 2, "above 0");
    assert_err("[axis]\nkind = \"linear\"\nlead = 0\n", "axis.lead", 3, "above 0");
    assert_err("[switches.left]\nat = [5, 1]\n", "switches.left.at", 2, "[low, high]");
    assert_err(
        "[axis]\nkind = \"linear\"\n[switches.home]\nat = [0, 1]\nevery_turn = true\n",
        "switches.home.at",
        4,
        "rotary axis",
    );
    assert_err("[switches.home]\nat = [-200, 200]\nevery_turn = true\n", "switches.home.at", 2, "narrower than a turn");
    assert_err("[inputs]\nanalog = 5000\n", "inputs.analog", 2, "0..=4095");
    assert_err("[axis]\ntravel = [0, 10]\nstart = 20\n", "axis.start", 3, "within axis.travel");
    assert_err("[[faults.supply_drop]]\nfrom = 1\nvoltage = -3\n", "faults.supply_drop.voltage", 3, "at least 0");
}

#[test]
fn syntax_error_has_a_line() {
    let e = err("[motor]\nfull_steps = 200\nrated_current = = 1\n");
    assert_eq!(e.line, Some(3), "{e}");
}

#[test]
fn load_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, "[motor]\nfull_steps = 200\nbogus = 1\n").unwrap();
    let e = World::load(&path).unwrap_err();
    assert!(e.to_string().contains("bad.toml") && e.to_string().contains("line 3"), "{e}");
    let missing = World::load(dir.path().join("none.toml")).unwrap_err();
    assert!(missing.to_string().contains("cannot read"), "{missing}");
}

#[test]
fn check_catches_worlds_built_in_code() {
    let mut w = World::default();
    w.motor.full_steps = tmcl_sim::world::Spanned::new(0..0, 3);
    let e = w.check().unwrap_err();
    assert_eq!((e.key.as_deref(), e.line), (Some("motor.full_steps"), None));
    assert!(SimBoard::in_memory(16).with_world(w).is_err());
}

/// `[motors.N]` gives motor N its own mechanics, merged over the file's top level: the XYZ example's Y and
/// Z axes have their own lead, start and switches and keep X's motor; every other motor has the top level.
#[test]
fn motor_tables_give_each_axis_its_own_world() {
    let w = World::load(examples().join("xyz-stage.toml")).unwrap();
    assert_eq!(w.motors.iter().map(|(m, _)| *m).collect::<Vec<_>>(), [1, 2]);
    let (x, y, z, other) = (w.of_motor(0), w.of_motor(1), w.of_motor(2), w.of_motor(3));
    assert_eq!((*x.axis.lead.get_ref(), *y.axis.lead.get_ref(), *z.axis.lead.get_ref()), (2.0, 1.0, 0.5));
    assert_eq!(y.motor, x.motor, "Y keeps X's motor");
    assert_eq!(y.load, x.load, "and its load");
    assert_ne!(z.load, x.load, "Z has its own friction");
    assert_eq!(y.switches.left, x.switches.left, "Y keeps X's left switch");
    assert_ne!(y.switches.right, x.switches.right);
    assert_eq!(other, x, "a motor without a table: the top level");
    assert!(x.motors.is_empty() && x.motor_tables.is_empty());

    // On a TMCM-3110's board each axis starts where its world says.
    let spec = tmcl_core::model::by_id("tmcm-3110").unwrap();
    let board =
        SimBoard::for_model(spec, tmcl_sim::Eeprom::Memory(tmcl_sim::MemNvm::new(4096))).with_world(w.clone()).unwrap();
    let at = |m: usize| board.axis(m).unwrap().axis_position();
    assert_eq!((at(0), at(1), at(2)), (25.0, 10.0, 5.0), "each axis where its world puts it");
    assert_eq!(board.axis(1).unwrap().description().axis.lead.get_ref(), &1.0);
    // A motor the module lacks is refused with its key.
    let two = "[motors.3.axis]\nlead = 1.0\n";
    let w3 = World::from_toml_str(two).unwrap();
    let e =
        SimBoard::for_model(spec, tmcl_sim::Eeprom::Memory(tmcl_sim::MemNvm::new(4096))).with_world(w3).unwrap_err();
    assert_eq!(e.key.as_deref(), Some("motors.3"), "{e}");
}

/// Mistakes in a `[motors.N]` table name their key under it.
#[test]
fn motor_table_mistakes_name_their_key() {
    let e = err("[axis]\nkind = \"linear\"\n[motors.1.axis]\nlead = -1.0\n");
    assert!(e.key.as_deref().is_some_and(|k| k.starts_with("motors.1")), "{e}");
    assert_eq!(e.line, Some(3), "{e}");
    let e = err("[motors.x.axis]\nlead = 1.0\n");
    assert_eq!(e.key.as_deref(), Some("motors.x"), "{e}");
    let e = err("[motors.1.inputs]\ndigital = 1\n");
    assert_eq!(e.key.as_deref(), Some("motors.1.inputs"), "{e}");
    let e = err("[motors.1.axis]\nbogus = 1\n");
    assert!(e.message.contains("bogus"), "{e}");
}

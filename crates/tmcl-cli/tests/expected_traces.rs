//! The manual's programs run in the simulator and compared, byte for byte, with checked-in traces
//! (tests/programs/expected/*.csv). A change that moves any position, register or event by a microstep
//! or a microsecond shows up here. To accept an intended change, run with `UPDATE_EXPECTED=1` and review
//! the diff of the .csv files.

use std::path::{Path, PathBuf};
use std::process::Command;

const TMCL: &str = env!("CARGO_BIN_EXE_tmcl");

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// (program, simulated seconds, sample period in ms, extra arguments)
const RUNS: &[(&str, &str, &str, &[&str])] = &[
    // §2.4: rotate left, right, then move between ±512000 forever.
    ("manual_p01_first_steps", "60", "100", &[]),
    // §3.6.6.4: the timer interrupt toggles OUT0 every second.
    ("manual_p02_timer_interrupt", "5", "50", &[]),
    // §3.7.14: copy the inputs to the outputs (no inputs set: all stay 0, the loop runs).
    ("manual_p04_copy_inputs", "0.2", "20", &[]),
    // §3.7.20: CSUB/RSUB between two moves.
    ("manual_p08_csub", "5", "50", &[]),
    // §8.2: the main-loop skeleton.
    ("manual_p11_main_loop", "10", "50", &[]),
    // §8.3: symbolic constants from TMCLParam.tmc.
    ("manual_p12_constants", "30", "100", &[]),
    // §8.6: the jump table, entered at 0 (Func1: a move there and back, then STOP).
    ("manual_p14_jump_table", "3", "20", &[]),
    // TMCM-1310 manual §6.6.5: the same timer example on a module with OUT3.
    ("tmcm1310_timer_interrupt", "3", "50", &["--module", "tmcm-1310"]),
    // PDx-113 manual §4.2: the first program, in TMC428 units (AP 4 = 1000 at pulse divisor 3).
    ("pd113_first_program", "12", "100", &["--module", "pd-113"]),
    // TMCM-1140: a reference search on the linear stage, moves in TMC429 units, a timer interrupt blinking OUT1.
    ("tmcm1140_stage", "30", "250", &["--module", "tmcm-1140", "--world", "examples/worlds/linear-stage.toml"]),
    // TMCM-3110: an XYZ stage, each axis its own world; a reference search on all three at once, then an
    // hour of moves of the three together, interpolated (MVP COORD, $47) and each at its own speed ($87).
    ("tmcm3110_xyz", "3600", "20000", &["--module", "tmcm-3110", "--world", "examples/worlds/xyz-stage.toml"]),
    // TMCM-1310 closed loop through a seizure (position error, scaler and status word with --drive).
    (
        "tmcm1310_closed_loop",
        "6",
        "20",
        &["--module", "tmcm-1310", "--drive", "--world", "examples/worlds/closed-loop-seizure.toml"],
    ),
];

#[test]
fn manual_programs_match_their_expected_traces() {
    let root = root();
    let update = std::env::var_os("UPDATE_EXPECTED").is_some();
    let out_dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for (name, secs, every, extra) in RUNS {
        let program = root.join("tests/programs").join(format!("{name}.tmc"));
        let trace = out_dir.path().join(format!("{name}.csv"));
        let status = Command::new(TMCL)
            .current_dir(&root)
            .arg("run")
            .arg(&program)
            .args(["--for", secs, "--every", every, "--trace"])
            .arg(&trace)
            .args(*extra)
            .output()
            .expect("tmcl run");
        assert!(status.status.success(), "{name}: {}", String::from_utf8_lossy(&status.stderr));
        let got = std::fs::read_to_string(&trace).unwrap();
        let expected_path = root.join("tests/programs/expected").join(format!("{name}.csv"));
        if update {
            std::fs::write(&expected_path, &got).unwrap();
            continue;
        }
        let expected = std::fs::read_to_string(&expected_path)
            .unwrap_or_else(|_| panic!("{} is missing (UPDATE_EXPECTED=1 writes it)", expected_path.display()));
        if got != expected {
            let line = got.lines().zip(expected.lines()).position(|(a, b)| a != b).unwrap_or(0);
            failures.push(format!(
                "{name}: first difference at line {}:\n  got      {}\n  expected {}",
                line + 1,
                got.lines().nth(line).unwrap_or("<end>"),
                expected.lines().nth(line).unwrap_or("<end>")
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every manual program in every example world, traced with `--drive` (and plotted), event-driven and
/// with `--exact-ticks`: the traces are the same byte for byte, and so are the summaries (instructions
/// executed, PC, program state) of the runs without a trace.
#[test]
fn event_driven_traces_are_the_tick_by_tick_traces() {
    let root = root();
    let out_dir = tempfile::tempdir().unwrap();
    let mut programs: Vec<PathBuf> = std::fs::read_dir(root.join("tests/programs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "tmc"))
        .collect();
    programs.sort();
    let worlds = ["", "linear-stage", "jammed-axis", "timeline", "rotary-home", "encoder-slip"];
    let mut failures = Vec::new();
    for program in &programs {
        let name = program.file_stem().unwrap().to_string_lossy().to_string();
        let model: &[&str] = if name.starts_with("tmcm1310") {
            &["--module", "tmcm-1310"]
        } else if name.starts_with("pd113") {
            &["--module", "pd-113"]
        } else if name.starts_with("tmcm1140") {
            &["--module", "tmcm-1140"]
        } else if name.starts_with("tmcm3110") {
            &["--module", "tmcm-3110"]
        } else if name.starts_with("tmcm6110") {
            &["--module", "tmcm-6110"]
        } else {
            &[]
        };
        // A multi-axis program also in the world with an axis of each motor's own.
        let multi = name.starts_with("tmcm3110") || name.starts_with("tmcm6110");
        for world in worlds.iter().copied().chain(multi.then_some("xyz-stage")) {
            let world_args: Vec<String> =
                if world.is_empty() { vec![] } else { vec!["--world".into(), format!("examples/worlds/{world}.toml")] };
            let run = |exact: bool, traced: bool| {
                let trace = out_dir.path().join(format!("{name}-{world}-{exact}.csv"));
                let mut cmd = Command::new(TMCL);
                cmd.current_dir(&root).arg("run").arg(program).args(["--for", "20", "--every", "7"]);
                cmd.args(model).args(&world_args);
                if traced {
                    cmd.arg("--trace").arg(&trace).arg("--drive");
                }
                if exact {
                    cmd.arg("--exact-ticks");
                }
                let out = cmd.output().expect("tmcl run");
                assert!(out.status.success(), "{name} {world}: {}", String::from_utf8_lossy(&out.stderr));
                // The summary without the wall time: "simulated 20 s in … wall (…), N instructions …".
                let summary = String::from_utf8_lossy(&out.stdout).to_string();
                let summary = summary.split_once("instructions").map_or(summary.clone(), |(_, rest)| rest.to_string());
                let executed = String::from_utf8_lossy(&out.stdout)
                    .split(", ")
                    .find(|p| p.ends_with("instructions executed"))
                    .unwrap_or_default()
                    .to_string();
                let csv = if traced { std::fs::read_to_string(&trace).unwrap() } else { String::new() };
                (format!("{executed} {summary}"), csv)
            };
            for traced in [true, false] {
                let (fast, slow) = (run(false, traced), run(true, traced));
                if fast != slow {
                    let line = fast.1.lines().zip(slow.1.lines()).position(|(a, b)| a != b).unwrap_or(0);
                    failures.push(format!(
                        "{name} in {world:?} (traced: {traced}): summaries {:?} / {:?}; first difference at line {}:\n  event-driven {}\n  tick by tick {}",
                        fast.0,
                        slow.0,
                        line + 1,
                        fast.1.lines().nth(line).unwrap_or("<end>"),
                        slow.1.lines().nth(line).unwrap_or("<end>")
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

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

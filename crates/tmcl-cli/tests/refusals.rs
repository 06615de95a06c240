//! Programs that explain themselves (issue: refused instructions pass silently): `tmcl run` and
//! `tmcl debug` list every instruction the module refused with its status, pc, source line and the
//! model table's reason; `tmcl asm --module` warns where a constant operand is outside the model's range.

use std::io::Write;
use std::process::{Command, Output, Stdio};

const TMCL: &str = env!("CARGO_BIN_EXE_tmcl");

/// The audit's four refused instructions (PD28-1021: AP 4 is 1.., one motor, outputs 0 and 1 only, no
/// AP 99), then one the module takes.
const REFUSED: &str = "SAP 4, 0, 0\nMVP ABS, 5, 100\nSIO 7, 2, 1\nGAP 99, 0\nROR 0, 1000\nSTOP\n";

fn program(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("tmcl-refusals-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn tmcl(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(TMCL)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(stdin.as_bytes()).unwrap();
    child.wait_with_output().unwrap()
}

#[test]
fn run_lists_each_refusal() {
    let path = program("refused.tmc", REFUSED);
    let p = path.to_str().unwrap();
    let out = tmcl(&["--json", "run", "--for", "1", p], "");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let row: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(row["refused"], 4);
    assert_eq!(row["executed"], 6);
    let list = row["refusals"].as_array().unwrap();
    let got: Vec<(u64, u64, u64, &str)> = list
        .iter()
        .map(|r| {
            (
                r["pc"].as_u64().unwrap(),
                r["line"].as_u64().unwrap(),
                r["status"].as_u64().unwrap(),
                r["instruction"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        got,
        [(0, 1, 4, "SAP 4, 0, 0"), (1, 2, 4, "MVP ABS, 5, 100"), (2, 3, 3, "SIO 7, 2, 1"), (3, 4, 3, "GAP 99, 0")]
    );
    let reason = list[0]["reason"].as_str().unwrap();
    assert!(reason.contains("AP 4 (Maximum positioning speed) takes 1..2147483647"), "{reason}");
    assert!(list[3]["reason"].as_str().unwrap().contains("no AP 99"));

    // The text: one line per refusal, and the count on the summary line.
    let out = tmcl(&["run", "--for", "1", p], "");
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.lines().filter(|l| l.starts_with("refused: ")).count(), 4, "{text}");
    assert!(text.contains(":2: MVP ABS, 5, 100 (pc 1) at 0.000020 s: status 4: motor 5"), "{text}");
    assert!(text.trim_end().ends_with("program stopped, 4 instructions refused"), "{text}");

    // The trace: an event per refusal at its row.
    let csv = path.with_extension("csv");
    let out = tmcl(&["run", "--for", "0.01", "--trace", csv.to_str().unwrap(), p], "");
    assert!(out.status.success());
    let trace = std::fs::read_to_string(&csv).unwrap();
    for (pc, status) in [(0, 4), (1, 4), (2, 3), (3, 3)] {
        assert!(trace.contains(&format!("refused=pc {pc} status {status}")), "{trace}");
    }
}

/// PD28-1021 manual §2.4 under `--module pd-113`: its velocities and 51200 are out of range there.
#[test]
fn the_first_steps_program_on_the_pdx_113() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/programs/manual_p01_first_steps.tmc");
    let p = path.to_str().unwrap();
    let out = tmcl(&["asm", "--module", "pd-113", "-o", program("p01.bin", "").to_str().unwrap(), p], "");
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    // SAP 4, 0, 51200 is line 9 of the file, 51200 at column 11.
    assert!(
        err.contains("manual_p01_first_steps.tmc:9:11: warning: AP 4 (Maximum positioning speed) takes 0..2047"),
        "{err}"
    );
    assert!(err.contains(": 51200 is outside"), "{err}");
    assert_eq!(err.matches(": warning: ").count(), 4, "ROL, ROR, SAP 4, SAP 5: {err}");
    // On its own model: no warning.
    let out = tmcl(&["asm", "-o", program("p01b.bin", "").to_str().unwrap(), p], "");
    assert!(out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    // Run there, the refusals are listed (the ROL is refused, the program waits 5 s).
    let out = tmcl(&["--json", "run", "--module", "pd-113", "--for", "12", p], "");
    let row: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let lines: Vec<u64> = row["refusals"].as_array().unwrap().iter().map(|r| r["line"].as_u64().unwrap()).collect();
    assert_eq!(lines, [2, 5, 9, 10]);
}

#[test]
fn debug_shows_the_status_at_each_step() {
    let path = program("refused-debug.tmc", REFUSED);
    let out = tmcl(&["--json", "debug", path.to_str().unwrap()], "step\nstep 3\nstep\n");
    let rows: Vec<serde_json::Value> =
        String::from_utf8_lossy(&out.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(rows.len(), 4, "banner and three commands");
    let refused = |n: usize| -> Vec<u64> {
        rows[n]["refused"].as_array().unwrap().iter().map(|r| r["pc"].as_u64().unwrap()).collect()
    };
    assert_eq!(refused(1), [0]);
    assert_eq!(refused(2), [1, 2, 3]);
    assert!(refused(3).is_empty());
    assert_eq!(rows[1]["refused"][0]["status"], 4);
    let output: Vec<&str> = rows[3]["output"].as_array().unwrap().iter().map(|l| l.as_str().unwrap()).collect();
    assert!(output[0].starts_with("status 100, pc 5"), "{output:?}");
    let first: Vec<&str> = rows[1]["output"].as_array().unwrap().iter().map(|l| l.as_str().unwrap()).collect();
    assert!(first[0].starts_with("refused: ") && first[0].contains("status 4"), "{first:?}");
}

/// A program written with the PD28-1021's names assembles for every model (the TMCM-1310 names AP 4
/// `MaxVelocity`).
#[test]
fn ap_max_positioning_speed_on_every_model() {
    let path = program("names.tmc", "#include TMCLParam.tmc\nSAP APMaxPositioningSpeed, Motor0, 1000\nSTOP\n");
    for model in ["pd28-1021", "pd-113", "tmcm-1310"] {
        let bin = program(&format!("names-{model}.bin"), "");
        let out = tmcl(&["asm", "--module", model, "-o", bin.to_str().unwrap(), path.to_str().unwrap()], "");
        assert!(out.status.success(), "{model}: {}", String::from_utf8_lossy(&out.stderr));
        assert_eq!(std::fs::read(&bin).unwrap()[..7], [5, 4, 0, 0, 0, 3, 0xE8], "{model}: SAP 4, 0, 1000");
    }
}

//! `tmcl run`'s trace columns and plots end to end: the header is what `--help` lists, the energy column
//! is in the unit it is named after, and the plot has a lane for each input and output that changes.

use std::path::{Path, PathBuf};
use std::process::Command;

const TMCL: &str = env!("CARGO_BIN_EXE_tmcl");

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `tmcl` in the repository's root and returns its standard output; fails the test if it fails.
fn tmcl(args: &[&str]) -> String {
    let out = Command::new(TMCL).current_dir(root()).args(args).output().expect("tmcl runs");
    assert!(out.status.success(), "tmcl {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// Which runs a column of the help comes with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum With {
    Always,
    Drive,
    ClosedLoop,
    Units,
}

/// The columns `tmcl run --help` lists, in order: a line that starts with two spaces and a name; its
/// description says `--drive:` or `--drive, closed loop:` for the columns of `--drive`.
fn help_columns() -> Vec<(String, With)> {
    let help = tmcl(&["run", "--help"]);
    let start = help.find("Trace columns").expect("the help lists the trace columns");
    let mut columns = Vec::new();
    for line in help[start..].lines().skip(1).take_while(|l| !l.trim().is_empty()) {
        let Some(rest) = line.strip_prefix("  ") else { continue };
        if rest.starts_with(' ') {
            continue; // a continuation line
        }
        let (name, description) = rest.split_once(' ').unwrap_or((rest, ""));
        let description = description.trim_start();
        let with = if description.starts_with("TMC428 units:") {
            With::Units
        } else if description.starts_with("--drive, closed loop:") {
            With::ClosedLoop
        } else if description.starts_with("--drive:") {
            With::Drive
        } else {
            With::Always
        };
        columns.push((name.to_string(), with));
    }
    columns
}

/// The header of a trace of `program` (in tests/programs) with `extra` options.
fn header(dir: &Path, program: &str, extra: &[&str]) -> Vec<String> {
    let trace = dir.join("header.csv");
    let program = root().join("tests/programs").join(program);
    let args =
        [&["run", program.to_str().unwrap(), "--for", "0.05", "--trace", trace.to_str().unwrap()], extra].concat();
    tmcl(&args);
    let text = std::fs::read_to_string(&trace).unwrap();
    text.lines().next().unwrap().split(',').map(str::to_string).collect()
}

#[test]
fn the_trace_header_lists_exactly_the_columns_the_help_lists() {
    let help = help_columns();
    let names: Vec<&str> = help.iter().map(|(n, _)| n.as_str()).collect();
    for unit_less in ["accumulator", "x", "pc", "outputs", "event"] {
        assert!(names.contains(&unit_less), "{unit_less} in {names:?}");
    }
    assert!(names.contains(&"energy_a2s"), "{names:?}");
    let dir = tempfile::tempdir().unwrap();
    // The columns a run has: those it comes with; `varN` stands for the program's user variables (none
    // in these programs).
    let expected = |with: &[With]| -> Vec<String> {
        help.iter().filter(|(n, w)| with.contains(w) && n != "varN").map(|(n, _)| n.clone()).collect()
    };
    assert_eq!(header(dir.path(), "manual_p01_first_steps.tmc", &[]), expected(&[With::Always]), "plain");
    assert_eq!(
        header(dir.path(), "manual_p01_first_steps.tmc", &["--drive"]),
        expected(&[With::Always, With::Drive]),
        "--drive"
    );
    assert_eq!(
        header(dir.path(), "tmcm1310_closed_loop.tmc", &["--drive", "--module", "tmcm-1310"]),
        expected(&[With::Always, With::Drive, With::ClosedLoop]),
        "--drive on the TMCM-1310"
    );
    assert_eq!(
        header(dir.path(), "pd113_first_program.tmc", &["--module", "pd-113"]),
        expected(&[With::Always, With::Units]),
        "the PDx-113's own velocity unit"
    );
    // A user variable takes the place of `varN`.
    let with_variable = header(dir.path(), "manual_p01_first_steps.tmc", &["--drive", "--set", "gp7.2=1"]);
    let at = names.iter().position(|n| *n == "varN").unwrap();
    assert_eq!(with_variable[at], "var7");
}

#[test]
fn energy_is_in_ampere_squared_seconds() {
    // On the PD28-1021, AP 179 = 1 is the low current range, 1 A peak at AP 6 = 255 (manual chapter 4,
    // Table 22). AP 6 = 127 is current scale CS = 127 / 8 = 15, so the coil peak current is
    // (CS + 1) / 32 · 1 A = 16/32 A = 0.5 A. The two coils carry I·sin and I·cos, so i_A² + i_B² = I² =
    // 0.25 A² at every instant: from 1 s to 2 s, cruising at 1000 pps (the run current, no boost, no
    // standby), the energy grows by 0.25 A² · 1 s = 0.250000 A²·s (250 000 in µA²·s, 0.25 in milli-A²·s
    // would be 250).
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("cruise.tmc");
    std::fs::write(&program, "ROR 0, 1000\nLoop: WAIT TICKS, 0, 100\nJA Loop\n").unwrap();
    let trace = dir.path().join("cruise.csv");
    tmcl(&[
        "run",
        program.to_str().unwrap(),
        "--for",
        "2",
        "--every",
        "500",
        "--drive",
        "--set",
        "ap6=127",
        "--set",
        "ap179=1",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&trace).unwrap();
    let mut lines = text.lines();
    let columns: Vec<&str> = lines.next().unwrap().split(',').collect();
    let energy = columns.iter().position(|c| *c == "energy_a2s").expect("an energy_a2s column");
    let velocity = columns.iter().position(|c| *c == "velocity").unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let at = |time: &str| rows.iter().find(|r| r[0] == time).unwrap_or_else(|| panic!("a row at {time}"));
    assert_eq!(at("1.000000")[velocity], "1000");
    // Six decimals, formatted from integer µA²·s.
    let micro = |r: &Vec<&str>| -> i64 {
        let (whole, fraction) = r[energy].split_once('.').expect("six decimals");
        assert_eq!(fraction.len(), 6, "{}", r[energy]);
        whole.parse::<i64>().unwrap() * 1_000_000 + fraction.parse::<i64>().unwrap()
    };
    assert_eq!(micro(at("2.000000")) - micro(at("1.000000")), 250_000, "0.25 A²·s in 1 s at 0.5 A peak");
    assert_eq!(micro(at("1.500000")) - micro(at("1.000000")), 125_000);
}

#[test]
fn the_plot_has_a_lane_for_each_input_and_output_that_changes() {
    // examples/worlds/timeline.toml raises IN0 from 0.5 s to 1 s; the program copies the inputs to the
    // outputs, so OUT0 follows. No other input or output changes: no lane for them.
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("copy.tmc");
    std::fs::write(&program, "Loop: GIO 255, 0\nSIO 255, 2, -1\nWAIT TICKS, 0, 1\nJA Loop\n").unwrap();
    let svg = dir.path().join("copy.svg");
    let world = root().join("examples/worlds/timeline.toml");
    tmcl(&[
        "run",
        program.to_str().unwrap(),
        "--for",
        "2",
        "--world",
        world.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&svg).unwrap();
    let labels: Vec<&str> = text.lines().map(str::trim).collect();
    assert!(labels.contains(&"IN0"), "an IN0 lane");
    assert!(labels.contains(&"OUT0"), "an OUT0 lane");
    assert!(!labels.contains(&"IN1") && !labels.contains(&"OUT1"), "no lane for a signal that stays");
    // The output changes are in the OUT0 lane, not repeated as event lanes.
    assert!(!labels.contains(&"out0=1"), "no out0=1 lane");
}

#[test]
fn plots_have_units_and_no_negative_zero() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("closed-loop.svg");
    let program = root().join("tests/programs/tmcm1310_closed_loop.tmc");
    tmcl(&[
        "run",
        program.to_str().unwrap(),
        "--module",
        "tmcm-1310",
        "--world",
        "examples/worlds/closed-loop-seizure.toml",
        "--drive",
        "--for",
        "6",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&svg).unwrap();
    let texts: Vec<&str> = text.lines().map(str::trim).filter(|l| !l.starts_with('<')).collect();
    for unit in [
        "position [µsteps]",
        "velocity [pps]",
        "load value (0–1023)",
        "current scaler (/255)",
        "position error [µsteps]",
        "coil energy [A²·s]",
        "time [s] — 2 program events",
    ] {
        assert!(texts.contains(&unit), "{unit} missing");
    }
    // The velocity stands at 0 for 0.3 s, then the axis runs from -50000 to 50000: no label reads -0.
    assert!(!texts.iter().any(|t| t.starts_with("-0") && t.trim_start_matches(['-', '0', '.']).is_empty()), "-0");
    // A flat series: the program waits, nothing moves; its position axis still has distinct labels.
    let svg = dir.path().join("flat.svg");
    let program = root().join("tests/programs/manual_p02_timer_interrupt.tmc");
    tmcl(&["run", program.to_str().unwrap(), "--for", "2", "--plot", svg.to_str().unwrap()]);
    let text = std::fs::read_to_string(&svg).unwrap();
    let texts: Vec<&str> = text.lines().map(str::trim).filter(|l| !l.starts_with('<')).collect();
    assert!(texts.windows(3).any(|w| w == ["1", "0", "-1"] || w == ["-1", "0", "1"]), "ticks -1, 0, 1: {texts:?}");
}

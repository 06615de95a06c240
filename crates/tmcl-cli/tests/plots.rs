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
    // The drive's columns by meaning: the PDx-113 has no stallGuard2, coolStep or encoder parameter, so
    // its trace has no such column (never a column of made-up zeros), only the coil energy.
    let pd113 = header(dir.path(), "pd113_first_program.tmc", &["--module", "pd-113", "--drive"]);
    let drive_columns: Vec<&str> = help
        .iter()
        .filter(|(_, w)| *w == With::Drive)
        .map(|(n, _)| n.as_str())
        .filter(|n| pd113.iter().any(|c| c == n))
        .collect();
    assert_eq!(drive_columns, ["energy_a2s"], "{pd113:?}");
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
        "position [°]",
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
}

/// The text elements of an SVG, trimmed (one per line, as plotters writes them).
fn texts(svg: &str) -> Vec<String> {
    svg.lines().map(str::trim).filter(|l| !l.starts_with('<')).map(str::to_string).collect()
}

/// The `points` of every `<polyline>` drawn in `color` (`#RRGGBB`), as (x, y) pairs.
fn polylines(svg: &str, color: &str) -> Vec<Vec<(f64, f64)>> {
    svg.lines()
        .filter(|l| l.starts_with("<polyline") && l.contains(&format!("stroke=\"{color}\"")))
        .filter_map(|l| l.split("points=\"").nth(1)?.split('"').next().map(str::to_string))
        .map(|points| {
            points
                .split_whitespace()
                .filter_map(|p| p.split_once(','))
                .map(|(x, y)| (x.parse().unwrap(), y.parse().unwrap()))
                .collect()
        })
        .collect()
}

/// Runs `program` (in tests/programs, or a path) for `secs` with `extra` options and returns the plot.
fn plot(dir: &Path, program: &str, secs: &str, extra: &[&str]) -> String {
    let svg = dir.join("plot.svg");
    let program =
        if Path::new(program).is_absolute() { program.into() } else { root().join("tests/programs").join(program) };
    let args = [&["run", program.to_str().unwrap(), "--for", secs, "--plot", svg.to_str().unwrap()], extra].concat();
    tmcl(&args);
    std::fs::read_to_string(&svg).unwrap()
}

#[test]
fn curves_are_drawn_at_sub_pixel_coordinates() {
    // §2.4's ramps: whole-pixel points would make each slope a staircase of repeated x or y values.
    let dir = tempfile::tempdir().unwrap();
    let svg = plot(dir.path(), "manual_p01_first_steps.tmc", "60", &["--every", "100"]);
    // The actual position's colour; the key's short stroke has two points.
    let actual: Vec<_> = polylines(&svg, "#1E5AC8").into_iter().filter(|l| l.len() > 2).collect();
    assert_eq!(actual.len(), 1, "one curve of the actual position");
    let points = &actual[0];
    assert!(points.len() > 500, "{}", points.len());
    let fractional = points.iter().filter(|(x, y)| x.fract() != 0.0 && y.fract() != 0.0).count();
    assert!(fractional * 2 > points.len(), "most points between pixels: {fractional} of {}", points.len());
    // Sampled every 100 ms over 60 s and 1054 pixel columns: the samples have their own x (an event row
    // shares its time with a sample).
    assert!(points.windows(2).all(|w| w[1].0 >= w[0].0), "in time order");
    assert!(points.windows(2).filter(|w| w[1].0 > w[0].0).count() >= 600, "a column of its own per sample");
}

#[test]
fn a_signal_that_never_moved_is_a_note_not_a_panel() {
    // §3.6.6.4: the timer toggles OUT0, the motor never moves. No position or velocity panel (they took
    // 85 % of the plot), a note with their values, and the lanes.
    let dir = tempfile::tempdir().unwrap();
    let svg = plot(dir.path(), "manual_p02_timer_interrupt.tmc", "5", &["--every", "50"]);
    let texts = texts(&svg);
    assert!(!texts.iter().any(|t| t.starts_with("position [") || t.starts_with("velocity [")), "{texts:?}");
    let note = texts.iter().find(|t| t.starts_with("Constant over the run (not drawn):")).expect("a note");
    for part in ["target position (AP 0) 0 µsteps", "actual position (AP 1) 0 µsteps", "actual velocity (AP 3) 0 pps"]
    {
        assert!(note.contains(part), "{part} in {note}");
    }
    assert!(texts.iter().any(|t| t == "OUT0") && texts.iter().any(|t| t == "interrupt 0"), "{texts:?}");
    let height: u32 = svg.split("height=\"").nth(1).unwrap().split('"').next().unwrap().parse().unwrap();
    assert!(height < 250, "the plot is the note and the lanes: {height} px");
    // With --drive, a drive signal that moves keeps its panel: the coil energy grows while current flows.
    let svg = plot(dir.path(), "manual_p02_timer_interrupt.tmc", "5", &["--drive"]);
    assert!(svg.lines().any(|l| l.trim() == "coil energy [A²·s]"));
}

#[test]
fn switch_lanes_and_positions_in_world_units() {
    // A reference search to the left switch on the linear stage (2 mm per revolution, the carriage at
    // 25 mm at power-up, the left switch up to 0 mm, home at 49.5–50.5 mm), then out to 50 mm and back.
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("rfs.tmc");
    std::fs::write(
        &program,
        "SAP 193, 0, 1\nSAP 194, 0, 100000\nSAP 4, 0, 200000\nRFS START, 0\nWait: RFS STATUS, 0\nJC NZ, Wait\n\
         MVP ABS, 0, 1280000\nWAIT POS, 0, 0\nMVP ABS, 0, 0\nWAIT POS, 0, 0\nSTOP\n",
    )
    .unwrap();
    let world = root().join("examples/worlds/linear-stage.toml");
    let svg = plot(dir.path(), program.to_str().unwrap(), "30", &["--every", "20", "--world", world.to_str().unwrap()]);
    let texts = texts(&svg);
    assert!(texts.iter().any(|t| t == "position [mm]"), "{texts:?}");
    assert!(texts.iter().any(|t| t == "HOME") && texts.iter().any(|t| t == "LEFT"), "{texts:?}");
    assert!(!texts.iter().any(|t| t == "RIGHT"), "the right switch is never reached: no lane");
    // The targets in the lane are in mm too.
    assert!(texts.iter().any(|t| t == "50 mm"), "{texts:?}");
    // The position axis is in mm: 0 (after the search) to 50 (1 280 000 µsteps of 2/51200 mm) and the
    // start at 25; its ticks stay within that.
    for tick in ["0", "10", "20", "30", "40", "50"] {
        assert!(texts.iter().any(|t| t == tick), "tick {tick}");
    }
    assert!(!texts.iter().any(|t| t == "1200000" || t == "-600000"), "no µsteps on the axis");
}

#[test]
fn event_lines_leave_the_value_axis_alone() {
    // §3.7.20: the first MVP comes at 0 s; its line would cover the value axis.
    let dir = tempfile::tempdir().unwrap();
    let svg = plot(dir.path(), "manual_p08_csub.tmc", "5", &["--every", "50"]);
    let lines = polylines(&svg, "#FF0000");
    assert!(!lines.is_empty(), "the later events have lines");
    let axis_x = 110.0; // MARGIN_LEFT + Y_LABELS: the value axis
    assert!(lines.iter().all(|l| l.iter().all(|p| p.0 > axis_x + 1.0)), "{lines:?}");
}

/// A multi-axis model: motor 0's columns as listed, then each further motor's own, named with `_mM`, as
/// the help says.
#[test]
fn a_multi_axis_trace_has_every_motors_columns() {
    let dir = tempfile::tempdir().unwrap();
    let names = header(dir.path(), "tmcm3110_xyz.tmc", &["--module", "tmcm-3110", "--drive"]);
    let per_motor = |m: u8| {
        ["target_position", "actual_position", "velocity", "load", "current_scale", "encoder", "velocity_units"]
            .map(|n| format!("{n}_m{m}"))
    };
    let tail: Vec<String> = [per_motor(1), per_motor(2)].concat().into_iter().chain(["event".to_string()]).collect();
    assert!(names.ends_with(&tail), "{names:?}");
    assert_eq!(names.iter().filter(|n| n.ends_with("_m3")).count(), 0);
}

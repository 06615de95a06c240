//! `tmcl run` and `tmcl debug` end to end: the manual's programs in simulated time, traces, plots, and a
//! debugger session scripted on stdin.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const TMCL: &str = env!("CARGO_BIN_EXE_tmcl");

/// PD28-1021 manual §2.4, "First steps with TMCL" (used if the checked-in copy is missing).
const FIRST_STEPS: &str = "\
ROL 0, 51200
WAIT TICKS, 0, 500
MST 0
ROR 0, 5120
WAIT TICKS, 0, 500
MST 0
SAP 4, 0, 51200
SAP 5, 0, 51200
Loop:
MVP ABS, 0, 512000
WAIT POS, 0, 0
MVP ABS, 0, -512000
WAIT POS, 0, 0
JA Loop
";

/// PD28-1021 manual §3.6.6.4, the timer interrupt example (used if the checked-in copy is missing).
const TIMER: &str = "\
VECT 0, Timer0Irq
SGP 0, 3, 1000
EI 0
EI 255
Loop:
SIO 3, 2, 1
WAIT TICKS, 0, 50
SIO 3, 2, 0
WAIT TICKS, 0, 50
JA Loop
Timer0Irq:
GIO 0, 2
JC NZ, Out0Off
SIO 0, 2, 1
RETI
Out0Off:
SIO 0, 2, 0
RETI
";

/// A program for the debugger: a loop that adds 10 to user variable 7 and doubles A in a subroutine.
const COUNTER: &str = "\
Counter = 7
    SGP Counter, 2, 5
Loop:
    GGP Counter, 2
    CALC ADD, 10
    AGP Counter, 2
    CSUB Double
    WAIT TICKS, 0, 10
    COMP 100
    JC LT, Loop
    STOP
Double:
    CALC MUL, 2
    RSUB
";

/// The checked-in manual listing `name`, or `fallback` written into `dir`.
fn program(dir: &Path, name: &str, fallback: &str) -> PathBuf {
    let checked_in = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/programs").join(name);
    if checked_in.is_file() {
        return checked_in;
    }
    let path = dir.join(name);
    std::fs::write(&path, fallback).unwrap();
    path
}

fn tmcl(args: &[&str]) -> Output {
    Command::new(TMCL).args(args).output().expect("tmcl runs")
}

fn ok(output: &Output) -> String {
    assert!(
        output.status.success(),
        "tmcl failed: {}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// A trace as its header and rows of fields.
struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    fn read(path: &Path) -> Csv {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap().split(',').map(str::to_string).collect();
        let rows = lines.map(|l| l.split(',').map(str::to_string).collect()).collect();
        Csv { header, rows }
    }

    fn column(&self, name: &str) -> usize {
        self.header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name}: {:?}", self.header))
    }

    fn ints(&self, name: &str) -> Vec<i64> {
        let c = self.column(name);
        self.rows.iter().map(|r| r[c].parse().unwrap()).collect()
    }

    /// (time in µs, event text) of every row with an event.
    fn events(&self) -> Vec<(u64, String)> {
        let (t, e) = (self.column("time_s"), self.column("event"));
        self.rows
            .iter()
            .filter(|r| !r[e].is_empty())
            .map(|r| {
                let (s, us) = r[t].split_once('.').unwrap();
                (s.parse::<u64>().unwrap() * 1_000_000 + us.parse::<u64>().unwrap(), r[e].clone())
            })
            .collect()
    }
}

#[test]
fn first_steps_alternate_between_plus_and_minus_512000() {
    let dir = tempfile::tempdir().unwrap();
    let prog = program(dir.path(), "manual_p01_first_steps.tmc", FIRST_STEPS);
    let trace = dir.path().join("p01.csv");
    let out = ok(&tmcl(&["run", prog.to_str().unwrap(), "--for", "200", "--trace", trace.to_str().unwrap()]));
    assert!(out.contains("simulated 200 s") && out.contains("instructions executed"), "{out}");
    let csv = Csv::read(&trace);
    assert_eq!(
        &csv.header[..8],
        ["time_s", "target_position", "actual_position", "velocity", "accumulator", "x", "pc", "outputs"]
    );
    assert_eq!(csv.header.last().map(String::as_str), Some("event"));
    let samples = csv.rows.iter().filter(|r| r.last().is_some_and(String::is_empty)).count();
    assert!((200 * 100 + 1 - 20..=200 * 100 + 1).contains(&samples), "a row every 10 ms, 0 s to 200 s: {samples}");
    // Count the arrivals at each end: the actual position reaches +512000 and −512000 in turn.
    let positions = csv.ints("actual_position");
    assert!(positions.iter().all(|p| (-512_000..=512_000).contains(p)));
    let mut ends = Vec::new();
    for p in positions {
        if p.abs() == 512_000 && ends.last() != Some(&p) {
            ends.push(p);
        }
    }
    assert!(ends.len() >= 8, "arrivals: {ends:?}");
    // Each new target is an event row, showing the arrival at the previous one.
    let moves = csv.events().iter().filter(|(_, e)| e.starts_with("target=")).count();
    assert!(moves >= 9, "{:?}", csv.events());
    assert!(ends.windows(2).all(|w| w[0] == -w[1]), "alternating: {ends:?}");
    assert_eq!(ends[0], 512_000);
    let velocities = csv.ints("velocity");
    assert_eq!(velocities.iter().max(), Some(&51_200));
    assert_eq!(velocities.iter().min(), Some(&-51_200));
}

#[test]
fn the_timer_interrupt_toggles_out0_once_a_second() {
    let dir = tempfile::tempdir().unwrap();
    let prog = program(dir.path(), "manual_p02_timer_interrupt.tmc", TIMER);
    let trace = dir.path().join("p02.csv");
    ok(&tmcl(&["run", prog.to_str().unwrap(), "--for", "10.5", "--trace", trace.to_str().unwrap()]));
    let events = Csv::read(&trace).events();
    let toggles: Vec<&(u64, String)> = events.iter().filter(|(_, e)| e.contains("out0=")).collect();
    let interrupts = events.iter().filter(|(_, e)| e == "interrupt 0").count();
    assert_eq!(toggles.len(), 10, "{events:?}");
    assert_eq!(interrupts, 10, "{events:?}");
    for (n, (t, e)) in toggles.iter().enumerate() {
        let second = n as u64 + 1;
        assert!((second * 1_000_000..second * 1_000_000 + 2_000).contains(t), "toggle {n} at {t} µs");
        assert_eq!(e, if n % 2 == 0 { "out0=1" } else { "out0=0" });
    }
}

#[test]
fn traces_are_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [("manual_p01_first_steps.tmc", FIRST_STEPS), ("manual_p02_timer_interrupt.tmc", TIMER)] {
        let prog = program(dir.path(), name, text);
        let traces: Vec<Vec<u8>> = (0..2)
            .map(|n| {
                let trace = dir.path().join(format!("{name}.{n}.csv"));
                ok(&tmcl(&[
                    "run",
                    prog.to_str().unwrap(),
                    "--for",
                    "30",
                    "--every",
                    "7",
                    "--trace",
                    trace.to_str().unwrap(),
                ]));
                std::fs::read(&trace).unwrap()
            })
            .collect();
        assert!(traces[0].len() > 1000);
        assert!(traces[0] == traces[1], "{name}: the two traces differ");
    }
}

/// A program that never waits executes one instruction every 20 µs of module time for the whole run, with
/// and without a trace, event-driven and tick by tick. (One poll of the core runs at most 2^20
/// instructions, 21 s of module time; a run without a trace polls rarely and must poll again until the
/// program has caught up.)
#[test]
fn a_busy_program_runs_for_the_whole_run() {
    let dir = tempfile::tempdir().unwrap();
    let prog = dir.path().join("busy.tmc");
    // PD28-1021 manual §3.7.14's copy loop, with a counter in user variable 0.
    std::fs::write(&prog, "Loop:\nGIO 255, 0\nSIO 255, 2, -1\nGGP 0, 2\nCALC ADD, 1\nAGP 0, 2\nJA Loop\n").unwrap();
    let trace = dir.path().join("busy.csv");
    let json = |extra: &[&str]| -> serde_json::Value {
        let out = ok(&tmcl(&[&["--json", "run", prog.to_str().unwrap(), "--for", "30"], extra].concat()));
        serde_json::from_str(out.lines().last().unwrap()).unwrap()
    };
    // 30 s / 20 µs = 1 500 000 instructions, and the one at 30 s itself.
    for extra in [&[][..], &["--exact-ticks"], &["--trace", trace.to_str().unwrap(), "--every", "30000"]] {
        let summary = json(extra);
        assert_eq!(summary["executed"], 1_500_001, "{extra:?}: {summary}");
    }
}

/// The manual's busy listings (they never WAIT): an hour of each event-driven executes every one of its
/// 180 000 001 instructions (one every 20 µs from 0 to 3600 s) in a fraction of a second, a loop in a
/// fixed point being jumped over (`tmcl_sim::hook`); and over 65 s, more than three polls'
/// worth of instructions, it ends where the tick-by-tick reference ends.
#[test]
fn the_busy_listings_spin_through_an_hour() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["manual_p04_copy_inputs.tmc", "manual_p09_vect.tmc", "manual_p10_aap.tmc"] {
        let prog = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/programs").join(name);
        if !prog.is_file() {
            continue; // (a copy of the crate without the listings)
        }
        let json = |args: &[&str]| -> serde_json::Value {
            let out = ok(&tmcl(&[&["--json", "run", prog.to_str().unwrap()], args].concat()));
            serde_json::from_str(out.lines().last().unwrap()).unwrap()
        };
        let hour = json(&["--for", "3600"]);
        assert_eq!(hour["executed"], 180_000_001, "{name}: {hour}");
        assert_eq!(hour["pc"], 1, "{name}: {hour}");
        assert!(hour["wall_s"].as_f64().unwrap() < 10.0, "{name}: {hour}");
        let trace = dir.path().join("t.csv");
        // Event-driven traced (polled every 5 s and at its deadlines) and not, against tick by tick.
        let traced = json(&["--for", "65", "--trace", trace.to_str().unwrap(), "--every", "5000"]);
        let (fast, exact) = (json(&["--for", "65"]), json(&["--for", "65", "--exact-ticks"]));
        for key in ["executed", "pc", "state"] {
            assert_eq!(traced[key], exact[key], "{name}: {traced} {exact}");
        }
        for key in ["executed", "pc", "state"] {
            assert_eq!(fast[key], exact[key], "{name}: {fast} {exact}");
        }
    }
}

#[test]
fn set_changes_parameters_before_the_start() {
    let dir = tempfile::tempdir().unwrap();
    let prog = dir.path().join("move.tmc");
    std::fs::write(&prog, "MVP ABS, 0, 100000\nWAIT POS, 0, 0\nSTOP\n").unwrap();
    let trace = dir.path().join("move.csv");
    let args = ["run", prog.to_str().unwrap(), "--for", "5", "--trace", trace.to_str().unwrap()];
    ok(&tmcl(&[&args[..], &["--set", "ap4=2000", "--set", "ap5=100000", "--set", "gp3.2=77"]].concat()));
    let csv = Csv::read(&trace);
    assert_eq!(csv.ints("velocity").iter().max(), Some(&2000), "AP 4 limits the speed");
    assert!(csv.ints("var3").iter().all(|v| *v == 77), "user variable 3 from --set");
    let positions = csv.ints("actual_position");
    assert!(positions.iter().all(|p| *p <= 10_100), "at 2000 pps it cannot get far in 5 s");
    // The default speed is far higher: the move ends and the trace shows the STOP.
    ok(&tmcl(&args));
    let csv = Csv::read(&trace);
    assert!(csv.ints("velocity").iter().max().unwrap() > &2000);
    assert!(csv.events().iter().any(|(_, e)| e.split(';').any(|e| e == "stop")), "{:?}", csv.events());

    let bad = tmcl(&[&args[..], &["--set", "ap4=-5"]].concat());
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--set ap4=-5"), "{bad:?}");
    let bad = tmcl(&[&args[..], &["--set", "speed=5"]].concat());
    assert!(!bad.status.success());
}

#[test]
fn the_plot_is_an_svg_with_both_panels() {
    let dir = tempfile::tempdir().unwrap();
    let prog = program(dir.path(), "manual_p02_timer_interrupt.tmc", TIMER);
    let svg = dir.path().join("p02.svg");
    ok(&tmcl(&["run", prog.to_str().unwrap(), "--for", "5", "--plot", svg.to_str().unwrap()]));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"), "{}", &text[..text.len().min(200)]);
    // The motor never moves: a note instead of the position and velocity panels, and the lanes.
    for label in ["Constant over the run (not drawn):", "actual velocity (AP 3) 0 pps", "interrupt 0", "OUT0"] {
        assert!(text.contains(label), "{label} missing");
    }
}

/// Runs `tmcl debug` with `script` on stdin and returns its output.
fn debug(prog: &Path, script: &str) -> String {
    let mut child = Command::new(TMCL)
        .args(["debug", prog.to_str().unwrap()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(script.as_bytes()).unwrap();
    ok(&child.wait_with_output().unwrap())
}

#[test]
fn debug_session_from_stdin() {
    let dir = tempfile::tempdir().unwrap();
    let prog = dir.path().join("counter.tmc");
    std::fs::write(&prog, COUNTER).unwrap();
    let out = debug(&prog, "break Double\ncontinue\nprint\nstep\np\nset var 7 = 123\nprint var 7\nquit\nprint\n");
    let lines: Vec<&str> = out.lines().collect();
    assert!(!out.contains("(tmcl)"), "no prompt when stdin is not a terminal");
    assert!(
        lines.iter().any(|l| l.starts_with("breakpoint 1 at 9: ") && l.ends_with("counter.tmc:13: CALC MUL, 2")),
        "{out}"
    );
    assert!(lines.iter().any(|l| l.starts_with("breakpoint 1, pc 9 (Double), time ")), "{out}");
    // At the breakpoint A holds 5 + 10; one step doubles it.
    assert!(lines.contains(&"A = 15  X = 0  flags = GT (0x0002)"), "{out}");
    assert!(lines.contains(&"A = 30  X = 0  flags = GT (0x0002)"), "{out}");
    assert!(lines.contains(&"stack [5]"), "the CSUB at 4 returns to 5: {out}");
    assert!(lines.iter().any(|l| l.ends_with("counter.tmc:14: RSUB")), "{out}");
    assert!(lines.contains(&"var 7 = 123"), "{out}");
    assert_eq!(lines.iter().filter(|l| l.starts_with("pc 10: ")).count(), 1, "nothing runs after quit: {out}");
}

/// `continue` from a breakpoint the program was stepped onto executes it and goes on (it used to report
/// the same breakpoint again without moving), and a run restarted elsewhere stops at the first breakpoint.
#[test]
fn continue_from_a_breakpoint_stepped_onto_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let prog = dir.path().join("counter.tmc");
    std::fs::write(&prog, COUNTER).unwrap();
    // Address 1 is `Loop` (GGP); the step from 0 (SGP) lands on it.
    let out = debug(&prog, "break Loop\nstep\nprint var 7\ncontinue\nprint var 7\ncontinue\nprint var 7\n");
    let vars: Vec<&str> = out.lines().filter(|l| l.starts_with("var 7 = ")).collect();
    // 5 before the loop, then one turn each: 5 + 10 = 15, 15 + 10 = 25.
    assert_eq!(vars, ["var 7 = 5", "var 7 = 15", "var 7 = 25"], "{out}");
    // Reached by the step, then by each `continue`.
    assert_eq!(out.lines().filter(|l| l.starts_with("breakpoint 1, pc 1 (Loop)")).count(), 3, "{out}");
}

#[test]
fn debug_goes_on_after_unknown_commands_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let prog = dir.path().join("counter.tmc");
    std::fs::write(&prog, COUNTER).unwrap();
    let out = debug(&prog, "frobnicate\nbreak Lop\nstep 0\nnext 3\nc\nc\ntime\n");
    assert!(out.contains("unknown command `frobnicate`."), "{out}");
    assert!(out.contains("Debugger commands"), "help follows: {out}");
    assert!(out.contains("`Lop` is not a label, an address or FILE:LINE. Did you mean `Loop`?"), "{out}");
    assert!(out.contains("`0` is not a count of instructions."), "{out}");
    // Three steps, then the loop runs five times to its STOP; a second `continue` says so.
    assert!(out.contains("program stopped (STOP), pc 8"), "{out}");
    assert!(out.contains("The program has ended at 8; `run` starts it again."), "{out}");
    assert!(out.lines().last().is_some_and(|l| l.starts_with("time 0.5")), "{out}");
}

#[test]
fn a_command_the_model_lacks_is_an_error_at_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sac.tmc");
    std::fs::write(&src, "Loop: SAP 4, 0, 1000\n  SAC 0, 1, 5\nJA Loop\n").unwrap();
    let bin = dir.path().join("sac.bin");
    let asm = Command::new(TMCL).arg("asm").arg(&src).arg("-o").arg(&bin).output().unwrap();
    let err = String::from_utf8_lossy(&asm.stderr);
    assert_eq!(asm.status.code(), Some(2), "assembly errors are input errors: {err}");
    assert!(err.contains("sac.tmc:2:3: error: `SAC` is not a command of the PD28-1021"), "{err}");
    assert!(err.contains("\n      SAC 0, 1, 5\n      ^^^"), "{err}");
    assert!(!bin.exists(), "nothing written");
    let run = Command::new(TMCL).arg("run").arg(&src).arg("--for").arg("1").output().unwrap();
    assert_eq!(run.status.code(), Some(2), "the same exit code as `tmcl asm`");
    assert!(String::from_utf8_lossy(&run.stderr).contains("1 command(s) the PD28-1021 does not have"));
}

/// A world's input timeline reaches a program while the motor stands (issue: with `tmcl run` only the
/// change at 2 s was seen, the others were stepped over). The program copies GIO 255 into variable 0 and
/// counts the changes in variable 1; the inputs change at 1, 2, 3 and 4 s.
#[test]
fn an_input_timeline_reaches_a_standing_module() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("inputs.tmc");
    // Variable 1 counts the edges: each new value differs from variable 0's.
    std::fs::write(
        &program,
        "    SGP 1, 2, 0\nLoop:\n    GIO 255, 0\n    CALCX SWAP\n    GGP 0, 2\n    CALCX SWAP\n    CALCX SUB\n    \
         JC ZE, Same\n    GIO 255, 0\n    AGP 0, 2\n    GGP 1, 2\n    CALC ADD, 1\n    AGP 1, 2\nSame:\n    \
         WAIT TICKS, 0, 1\n    JA Loop\n",
    )
    .unwrap();
    let world = dir.path().join("timeline.toml");
    std::fs::write(
        &world,
        "[[inputs.timeline]]\nat = 1.0\ndigital = 1\n[[inputs.timeline]]\nat = 2.0\ndigital = 3\n\
         [[inputs.timeline]]\nat = 3.0\ndigital = 2\n[[inputs.timeline]]\nat = 4.0\ndigital = 0\n",
    )
    .unwrap();
    for traced in [false, true] {
        let trace = dir.path().join("t.csv");
        let mut cmd = Command::new(TMCL);
        cmd.arg("run").arg(&program).arg("--world").arg(&world).args(["--for", "5"]);
        if traced {
            cmd.arg("--trace").arg(&trace);
        }
        cmd.args(["--set", "gp0.2=0"]);
        let out = cmd.output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        if traced {
            let csv = std::fs::read_to_string(&trace).unwrap();
            let last = csv.lines().last().unwrap().to_string();
            let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
            let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
            let fields: Vec<&str> = last.split(',').collect();
            assert_eq!(fields[col("var1")], "4", "four input changes seen: {last}");
            assert_eq!(fields[col("var0")], "0", "the last value: {last}");
        }
    }
}

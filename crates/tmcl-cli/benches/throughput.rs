//! Figures for docs/benchmarks.md: frames per second through the core, pty round-trip latency, memory,
//! EtherCAT frames through the slave in process.
//!
//! Run: `cargo bench -p tmcl-cli --bench throughput` (a plain harness that prints its figures; pass
//! `--quick` for a short run, `--only core|gap|vm|motion|events|run|growth|serve|pty|memory|fleet|serve1310|
//! closed-loop` for one part; `fleet` is what `scripts/fleet-bench.sh` runs, `serve1310` the TMCM-1310 under
//! `tmcl serve`, `closed-loop [--poll end|deadlines|MS]` an hour of the TMCM-1310's closed-loop program).

use std::hint::black_box;
use std::process::{Child, Command as Process, Stdio};
use std::time::{Duration as StdDuration, Instant as StdInstant};
use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::{Instant, Module, State};
use tmcl_host::{Client, SerialTransport};
use tmcl_sim::SimBoard;
use tmcl_wire::{Instruction, Opcode, Request};

fn frame(op: Opcode, t: u8, v: i32) -> [u8; 9] {
    Request { address: 1, instruction: Instruction::new(op, t, 0, v) }.to_bytes()
}

/// Frames per second through `Module::receive`, time advancing 1 µs per frame (so the motion controller
/// and timers run as they would).
fn core_rate(name: &str, frames: &[[u8; 9]], n: u64) {
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    let mut reply_bytes = 0u64;
    let mut sink = |b: &[u8]| reply_bytes += b.len() as u64;
    let start = StdInstant::now();
    for i in 0..n {
        let f = &frames[(i % frames.len() as u64) as usize];
        module.receive(Instant::from_micros(i), black_box(f), &mut sink);
    }
    let secs = start.elapsed().as_secs_f64();
    assert_eq!(reply_bytes, n * 9, "every frame answered");
    println!(
        "core {name:<28} {:>8.2} M frames/s  ({:.0} ns/frame, {n} frames)",
        n as f64 / secs / 1e6,
        secs * 1e9 / n as f64
    );
}

struct Server(Child, std::path::PathBuf);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = Process::new("kill").arg("-TERM").arg(self.0.id().to_string()).status();
        let _ = self.0.wait();
        let _ = std::fs::remove_file(&self.1);
    }
}

/// A client on the pty link of a `tmcl serve` just started (waits up to 10 s for the link).
fn connect(link: &std::path::Path) -> Client<SerialTransport> {
    let deadline = StdInstant::now() + StdDuration::from_secs(10);
    while std::fs::symlink_metadata(link).is_err() {
        assert!(StdInstant::now() < deadline, "server did not start");
        std::thread::sleep(StdDuration::from_millis(10));
    }
    Client::new(SerialTransport::open(link.to_str().unwrap(), 115_200).expect("open the pty"))
}

/// Round trips of GAP 1 over the pty of a `tmcl serve` started here, or with `PTY_LINK=LINK` of one
/// already serving there (`scripts/pty-bench.sh` starts it, to count its system calls); `PTY_N` requests.
fn pty_latency(n: usize) {
    let n = std::env::var("PTY_N").ok().and_then(|v| v.parse().ok()).unwrap_or(n);
    let dir = std::env::temp_dir().join(format!("tmcl-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let given = std::env::var_os("PTY_LINK").map(std::path::PathBuf::from);
    let link = given.clone().unwrap_or_else(|| dir.join("tmcl0"));
    let _server = given.is_none().then(|| {
        let child = Process::new(env!("CARGO_BIN_EXE_tmcl"))
            .args(["serve", "--pty"])
            .arg(&link)
            .stdout(Stdio::piped())
            .spawn()
            .expect("start tmcl serve");
        Server(child, link.clone())
    });
    let mut client = connect(&link);
    for _ in 0..100 {
        client.get_axis_parameter(1, 0).unwrap();
    }
    let mut samples = Vec::with_capacity(n);
    for _ in 0..n {
        let t = StdInstant::now();
        black_box(client.get_axis_parameter(1, 0).unwrap());
        samples.push(t.elapsed());
    }
    samples.sort();
    let pct = |p: f64| samples[((samples.len() - 1) as f64 * p) as usize].as_secs_f64() * 1e6;
    println!(
        "pty round trip (GAP 1, Rust client)  median {:.1} µs, p90 {:.1} µs, p99 {:.1} µs, max {:.1} µs ({n} requests)",
        pct(0.5),
        pct(0.9),
        pct(0.99),
        pct(1.0)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A module with `program` downloaded (132, the commands, 133) and started at 0 (129 type 1), as a host
/// would do it.
fn module_running(program: &[tmcl_wire::Command]) -> Module<SimBoard> {
    use tmcl_wire::Command;
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    let frames = std::iter::once(Command::StartDownload { address: 0 })
        .chain(program.iter().copied())
        .chain([Command::QuitDownload, Command::RunApplication { from: Some(0) }]);
    for c in frames {
        let f = Request { address: 1, instruction: c.encode() }.to_bytes();
        module.receive(Instant::ZERO, &f, &mut |_: &[u8]| {});
    }
    module
}

/// Runs a module for `virtual_secs` of module time, jumping from deadline to deadline (at least 100 ms
/// at a time, as `tmcl run` without a trace does); returns the wall time.
fn run_for(module: &mut Module<SimBoard>, virtual_secs: u64) -> f64 {
    let mut sink = |_: &[u8]| {};
    let start = StdInstant::now();
    let end = Instant::from_secs(virtual_secs);
    let mut t = Instant::ZERO;
    while t < end {
        t = module.poll(t, &mut sink).unwrap_or(end).max(t + tmcl_core::Duration::from_millis(100)).min(end);
    }
    module.poll(end, &mut sink);
    start.elapsed().as_secs_f64()
}

/// Instructions per second of the program machine on an ALU loop (CALC, COMP, JC), and how much faster
/// than real time that is (each instruction takes 20 µs of module time).
fn vm_rate(virtual_secs: u64) {
    use tmcl_wire::{CalcOp, Command, Condition};
    let mut module = module_running(&[
        Command::Calc { op: CalcOp::Add, operand: 1 },
        Command::Comp { operand: i32::MAX },
        Command::Jc { condition: Condition::Lower, address: 0 },
        Command::Stop,
    ]);
    let secs = run_for(&mut module, virtual_secs);
    let executed = module.vm().executed() as f64;
    println!(
        "vm ALU loop (CALC/COMP/JC)            {:>8.2} M instructions/s  ({:.1} ns/instruction; {:.0}x real time)",
        executed / secs / 1e6,
        secs * 1e9 / executed,
        virtual_secs as f64 / secs
    );
    assert!(module.registers().accumulator > 0);
}

/// The §2.4 program (moves between ±512000 with WAIT POS) for an hour of module time, ticking every 1 ms
/// (`exact`, the reference, and what `scripts/instruction-counts.sh` divides by 3.6 M ticks) or from
/// event to event.
fn motion_program_ratio(virtual_secs: u64, exact: bool) {
    use tmcl_wire::{Command, MoveTarget, WaitCondition};
    let mut module = module_running(&[
        Command::Mvp { motor: 0, target: MoveTarget::Abs(512_000) },
        Command::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        Command::Mvp { motor: 0, target: MoveTarget::Abs(-512_000) },
        Command::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        Command::Ja { address: 0 },
    ]);
    module.set_exact_ticks(exact);
    // Tick by tick as before event-driven time (a poll at least every 100 ms); event-driven as `tmcl run`
    // without a trace now polls: at the end.
    let secs = if exact { run_for(&mut module, virtual_secs) } else { run_for_coarse(&mut module, virtual_secs) };
    let how = if exact { "tick by tick" } else { "event-driven" };
    println!(
        "motion program (§2.4 loop), {virtual_secs} s, {how}  {:.0}x real time ({:.4} s wall)",
        virtual_secs as f64 / secs,
        secs
    );
}

/// The TMCM-1310's closed-loop program (`tests/programs/tmcm1310_closed_loop.tmc`, assembled: the encoder
/// initialisation, the loop closed, two revolutions forth and back, a free axis) for an hour of module
/// time, polled as its callers poll: `end` once at the end (`tmcl run` without a trace), `deadlines` at
/// every deadline the module gives (`tmcl serve` with no host traffic), or every `N` ms (a host that
/// polls). Prints the wall time, the polls and the position at the end.
fn closed_loop_hour(poll: &str) {
    use tmcl_wire::Command;
    let spec = &tmcl_core::model::tmcm_1310::SPEC;
    let mut module = Module::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO);
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/programs/tmcm1310_closed_loop.tmc");
    let cells = tmcl_asm::assemble(&file).expect("the program assembles").instructions;
    module.load_program(&cells).expect("the program loads");
    module.execute(Command::RunApplication { from: Some(0) }, Instant::ZERO).expect("the program starts");
    let end = Instant::from_secs(3600);
    let every = match poll {
        "end" | "deadlines" => None,
        ms => Some(tmcl_core::Duration::from_millis(ms.parse().expect("--poll end|deadlines|MS"))),
    };
    let (mut t, mut polls) = (Instant::ZERO, 0u64);
    let start = StdInstant::now();
    loop {
        let now = if poll == "end" { end } else { t };
        let deadline = module.poll(now, &mut |_: &[u8]| {});
        polls += 1;
        if now >= end {
            break;
        }
        let next = match every {
            Some(every) => t + every,
            None => deadline.unwrap_or(end),
        };
        t = next.max(t + tmcl_core::Duration::from_micros(1)).min(end);
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "closed-loop hour (TMCM-1310), polled {poll:>9}: {polls:>7} polls, {:>8.4} s wall, {:>8.0}x real time, \
         AP 1 {}",
        secs,
        3600.0 / secs,
        module.ramp().position
    );
}

/// `tmcl run` of the §2.4 program for an hour, event-driven and with `--exact-ticks`, in worlds and with
/// or without a trace, `rounds` times each, alternating: the wall time the run reports (module built,
/// program assembled; the process start-up not counted) as min–max, and the speed-up.
fn run_hour(rounds: usize) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = std::env::temp_dir().join(format!("tmcl-bench-run-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let trace = dir.join("t.csv");
    let plot = dir.join("t.svg");
    let trace_every = |ms: &str, plotted: bool| {
        let mut args: Vec<String> =
            ["--trace", trace.to_str().unwrap(), "--every", ms, "--drive"].map(String::from).to_vec();
        if plotted {
            args.extend(["--plot".to_string(), plot.to_str().unwrap().to_string()]);
        }
        args
    };
    let stage = || vec!["--world".to_string(), "examples/worlds/linear-stage.toml".to_string()];
    let cases: Vec<(&str, Vec<String>)> = vec![
        ("free axis", vec![]),
        ("linear stage", stage()),
        ("jammed axis", vec!["--world".into(), "examples/worlds/jammed-axis.toml".into()]),
        ("free axis, traced every 1 s (--drive)", trace_every("1000", false)),
        ("free axis, traced every 10 ms (--drive)", trace_every("10", false)),
        ("linear stage, traced every 10 ms, plotted", [stage(), trace_every("10", true)].concat()),
    ];
    for (name, args) in cases {
        let mut walls = [Vec::new(), Vec::new()];
        let mut summaries = [String::new(), String::new()];
        for _ in 0..rounds {
            for (i, exact) in [false, true].into_iter().enumerate() {
                let mut cmd = Process::new(env!("CARGO_BIN_EXE_tmcl"));
                cmd.current_dir(&root).args([
                    "--json",
                    "run",
                    "tests/programs/manual_p01_first_steps.tmc",
                    "--for",
                    "3600",
                ]);
                cmd.args(&args);
                if exact {
                    cmd.arg("--exact-ticks");
                }
                let out = cmd.output().expect("tmcl run");
                assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
                let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("a JSON summary");
                walls[i].push(v["wall_s"].as_f64().unwrap());
                summaries[i] = format!("{} {} {} {}", v["executed"], v["pc"], v["state"], v["rows"]);
            }
        }
        assert_eq!(summaries[0], summaries[1], "{name}: the same run both ways");
        let range = |w: &[f64]| {
            let (lo, hi) = (w.iter().cloned().fold(f64::MAX, f64::min), w.iter().cloned().fold(0.0, f64::max));
            format!("{:.4}–{:.4} s ({:.0}–{:.0}x)", lo, hi, 3600.0 / hi, 3600.0 / lo)
        };
        let median = |w: &mut Vec<f64>| {
            w.sort_by(f64::total_cmp);
            w[w.len() / 2]
        };
        println!(
            "hour of §2.4, {name:<42} event-driven {}  tick by tick {}  speed-up {:.0}x",
            range(&walls[0]),
            range(&walls[1]),
            median(&mut walls[1].clone()) / median(&mut walls[0].clone())
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// How the cost grows with the number of events, not with time: a program moving to targets that change
/// from move to move (no two braking phases alike, so no span is remembered), with a pause after each
/// move; event-driven, for 1 hour at several pauses (more moves, more events) and for 1, 10 and 100 hours
/// at one pause (more time, as many events per hour).
fn event_growth() {
    use tmcl_wire::{CalcOp, Command, WaitCondition};
    let program = |pause: i32| {
        [
            Command::Calc { op: CalcOp::Add, operand: 77_777 },
            Command::Calc { op: CalcOp::Mod, operand: 400_000 },
            Command::Aap { param: 0, motor: 0 },
            Command::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
            Command::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: pause },
            Command::Ja { address: 0 },
        ]
    };
    let run = |pause: i32, hours: u64| {
        let mut module = module_running(&program(pause));
        let secs = run_for_coarse(&mut module, hours * 3600);
        let moves = module.vm().executed() / 6;
        (secs, moves)
    };
    for pause in [30_000, 3_000, 300, 30, 0] {
        let (secs, moves) = run(pause, 1);
        println!(
            "growth: 1 h, pause {:>5} ms: {moves:>6} moves, {:>8.2} ms wall, {:>6.2} µs per move, {:.0}x real time",
            pause * 10,
            secs * 1e3,
            secs * 1e6 / moves.max(1) as f64,
            3600.0 / secs
        );
    }
    for hours in [1, 10, 100] {
        let (secs, moves) = run(3_000, hours);
        println!(
            "growth: {hours:>3} h, pause 30 s: {moves:>6} moves, {:>8.2} ms wall, {:>6.2} µs per move, {:.0}x real time",
            secs * 1e3,
            secs * 1e6 / moves.max(1) as f64,
            hours as f64 * 3600.0 / secs
        );
    }
}

/// Runs for `virtual_secs` polling only at the end, as `tmcl run` without a trace does (the module
/// catches up on everything in between); returns the wall time.
fn run_for_coarse(module: &mut Module<SimBoard>, virtual_secs: u64) -> f64 {
    let start = StdInstant::now();
    module.poll(Instant::from_secs(virtual_secs), &mut |_: &[u8]| {});
    start.elapsed().as_secs_f64()
}

/// CPU time of a `tmcl serve` whose motor turns (ROR 51200) with no host traffic for `secs` seconds of
/// wall time, event-driven and with `--exact-ticks`: the server's whole CPU time (user and system, µs
/// resolution, from `getrusage` of the reaped child), start-up and the request included. One GAP at the
/// end computes the position at that instant.
fn serve_cpu(secs: u64) {
    use nix::sys::resource::{getrusage, UsageWho};
    let children = || {
        let usage = getrusage(UsageWho::RUSAGE_CHILDREN).expect("getrusage");
        let (u, s) = (usage.user_time(), usage.system_time());
        (u.tv_sec() + s.tv_sec()) as f64 + (u.tv_usec() + s.tv_usec()) as f64 * 1e-6
    };
    for exact in [false, true] {
        let dir = std::env::temp_dir().join(format!("tmcl-bench-serve-{}-{exact}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let link = dir.join("tmcl0");
        let mut cmd = Process::new(env!("CARGO_BIN_EXE_tmcl"));
        cmd.args(["serve", "--pty"]).arg(&link).stdout(Stdio::piped());
        if exact {
            cmd.arg("--exact-ticks");
        }
        let before = children();
        let wall0 = StdInstant::now();
        let position = {
            let _server = Server(cmd.spawn().expect("start tmcl serve"), link.clone());
            let mut client = connect(&link);
            client.rotate(0, 51_200).unwrap();
            std::thread::sleep(StdDuration::from_secs(secs));
            client.get_axis_parameter(1, 0).unwrap()
        }; // the server is stopped and reaped here
        let (used, wall) = (children() - before, wall0.elapsed().as_secs_f64());
        let how = if exact { "tick by tick" } else { "event-driven" };
        println!(
            "serve, motor turning at 51200 pps, no host traffic, {how}: {:.1} ms CPU in {wall:.1} s = {:.4} % of a \
             core (GAP 1 at the end: {position})",
            used * 1e3,
            100.0 * used / wall
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// CPU time of `tmcl serve --module tmcm-1310` without host traffic over `secs` seconds of wall time
/// (user + system of its threads, `/proc/PID/stat`, after a host set it up and 2 s of settling): the
/// loop closed as pytrinamic's closed-loop demo closes it (AP 132 = 1 until it reads 2, then AP 129 = 1),
/// standing or turning (ROR 51200), and the loop open turning. `SERVE_BEFORE=PATH`: another build's
/// `tmcl`, measured alternately in the same run.
fn serve_1310(secs: u64, rounds: usize) {
    let this = env!("CARGO_BIN_EXE_tmcl").to_string();
    let mut builds = vec![("this build", this)];
    if let Ok(before) = std::env::var("SERVE_BEFORE") {
        builds.insert(0, ("before", before));
    }
    let cases = [
        ("loop closed, standing", true, 0),
        ("loop closed, turning", true, 51_200),
        ("loop open, turning", false, 51_200),
    ];
    for round in 0..rounds {
        for (case, closed, velocity) in cases {
            for (build, tmcl) in &builds {
                let dir = std::env::temp_dir().join(format!("tmcl-bench-1310-{}", std::process::id()));
                let _ = std::fs::remove_dir_all(&dir);
                std::fs::create_dir_all(&dir).unwrap();
                let link = dir.join("usb");
                let child = Process::new(tmcl)
                    .args(["serve", "--module", "tmcm-1310", "--pty"])
                    .arg(&link)
                    .stdout(Stdio::null())
                    .spawn()
                    .expect("start tmcl serve");
                let server = Server(child, link.clone());
                let line = FleetLine { link: link.clone(), modules: vec![("tmcm-1310", 1, velocity != 0)] };
                fleet_wait_for_links(std::slice::from_ref(&line));
                {
                    let transport = SerialTransport::open(link.to_str().unwrap(), 115_200).unwrap();
                    let mut client = Client::new(transport);
                    if closed {
                        client.set_axis_parameter(132, 0, 1).unwrap();
                        while client.get_axis_parameter(132, 0).unwrap() != 2 {
                            std::thread::sleep(StdDuration::from_millis(5));
                        }
                        client.set_axis_parameter(129, 0, 1).unwrap();
                    }
                    if velocity != 0 {
                        client.rotate(0, velocity).unwrap();
                    }
                }
                std::thread::sleep(StdDuration::from_secs(2));
                let pid = server.0.id();
                let (cpu0, _) = proc_usage(pid);
                let wall0 = StdInstant::now();
                std::thread::sleep(StdDuration::from_secs(secs));
                let (cpu1, _) = proc_usage(pid);
                let wall = wall0.elapsed().as_secs_f64();
                println!(
                    "serve tmcm-1310 {case:<24} {build:<10} [{round}]: {:.3} % of a core ({:.0} ms CPU in {wall:.1} s)",
                    100.0 * (cpu1 - cpu0) / wall,
                    (cpu1 - cpu0) * 1e3
                );
                drop(server);
                let _ = std::fs::remove_dir_all(&dir);
            }
        }
    }
}

/// What one module holds in RAM, without the heap (there is none): the firmware state (with every host
/// interface's framer, outbox and ASCII line) and the program machine, but not program memory nor the
/// debugger's breakpoints (a simulator feature a module does not have; printed apart).
fn memory() {
    use std::mem::size_of;
    use tmcl_core::iface::Port;
    use tmcl_core::vm::{Program, Vm, MAX_PROGRAM};
    // `Vm::breakpoints`: one bit per program cell.
    let breakpoints = size_of::<[u64; MAX_PROGRAM / 64]>();
    let (state, vm) = (size_of::<State>(), size_of::<Vm>() - breakpoints);
    let ports = size_of::<[Port; tmcl_core::model::capacity::MAX_INTERFACES]>();
    println!(
        "firmware RAM but program memory: State {state} (of it {ports} in host interface ports) + Vm {vm} = {} \
         bytes (goal <= 4096)",
        state + vm
    );
    println!("debugger breakpoints (not counted): {breakpoints} bytes");
    println!("program memory: {} bytes", size_of::<Program>());
    println!("size_of::<Module<SimBoard>>() = {} bytes", size_of::<Module<SimBoard>>());
    // Per axis: the state holds MAX_MOTORS axes (6 in a host build, 1 in the firmware image), each an
    // `Axis`; a build for n axes holds the rest once and n of them.
    let (axis, slots) = (size_of::<tmcl_core::axis::Axis>(), usize::from(tmcl_core::model::capacity::MAX_MOTORS));
    let base = state + vm - slots * axis;
    println!(
        "per axis: Axis {axis} bytes, {slots} slots in this build; module RAM but program memory = {base} + n x {axis}: \
         1 axis {}, 3 axes {}, 6 axes {} bytes",
        base + axis,
        base + 3 * axis,
        base + 6 * axis
    );
    println!(
        "simulated board: SimBoard {} bytes, one more per axis beyond the first (without its world's heap)",
        size_of::<SimBoard>()
    );
}

/// EtherCAT frames per second through `Slave::process` in process (no socket): SOEM's cyclic LRW of the
/// whole image (8 output bytes, velocity mode; 48 input bytes read from the module) in OP, time advancing
/// 1 ms per frame, so the motor turns and every input is fresh; and an FPRD of AL status.
fn ethercat_rate(n: u64) {
    use tmcl_ethercat::fuzzing::{bring_up, build_frame, MAX_FRAME};
    use tmcl_ethercat::wire::datagram::{Command, Repr};
    use tmcl_ethercat::{AlState, NoFiles, Slave};
    let spec = &tmcl_core::model::tmcm_1310::SPEC;
    let mut module = Module::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO);
    let mut slave = Slave::new(spec).unwrap();
    bring_up(&mut slave, &mut module, Instant::ZERO, AlState::Op);
    assert_eq!(slave.status().state, AlState::Op);
    let mut t = Instant::ZERO;
    let mut image = [0u8; 56];
    image[..8].copy_from_slice(&[2, 0, 0, 0, 0x00, 0xC8, 0, 0]);
    for (name, datagram) in [
        ("LRW 56 bytes (process data)", (Command::Lrw, 0u32, &image[..])),
        ("FPRD AL status", (Command::Fprd, Repr::physical(0x1001, 0x0130), &[0u8; 6][..])),
    ] {
        let mut template = [0u8; MAX_FRAME];
        let len = build_frame(&mut template, &[datagram]).unwrap();
        let mut frame = template;
        let start = StdInstant::now();
        for _ in 0..n {
            frame[..len].copy_from_slice(&template[..len]);
            t += tmcl_core::Duration::from_millis(1);
            black_box(slave.process(t, black_box(&mut frame[..len]), &mut module, &mut NoFiles)).unwrap();
        }
        let secs = start.elapsed().as_secs_f64();
        println!(
            "ethercat {name:<28} {:>8.2} M frames/s  ({:.0} ns/frame, {n} frames)",
            n as f64 / secs / 1e6,
            secs * 1e9 / n as f64
        );
        if datagram.0 == Command::Lrw {
            // (Without process data the watchdog then takes the slave to SAFE-OP, as it should.)
            assert_eq!(slave.status().state, AlState::Op);
            assert!(module.ramp().position > 0, "the motor turned");
        }
    }
}

/// The fleet of `--only fleet`: 100 modules of the three models on 37 lines. Each TMCM-1310 alone on its
/// pty (its USB port answers every address), its loop closed as pytrinamic's closed-loop demo closes it;
/// PD28-1021s and PDx-113s on three RS485 buses of 22. Every third module turns (ROR).
const FLEET_USB: usize = 34;
const FLEET_BUSES: usize = 3;
const FLEET_PER_BUS: usize = 22;

/// One line of the fleet: its link, and its modules as (model, address, turning).
struct FleetLine {
    link: std::path::PathBuf,
    modules: Vec<(&'static str, u8, bool)>,
}

fn fleet_lines(dir: &std::path::Path) -> Vec<FleetLine> {
    let mut lines = Vec::new();
    let mut k = 0usize;
    for n in 0..FLEET_USB {
        lines.push(FleetLine {
            link: dir.join(format!("usb{n}")),
            modules: vec![("tmcm-1310", 1, k.is_multiple_of(3))],
        });
        k += 1;
    }
    for b in 0..FLEET_BUSES {
        let modules = (0..FLEET_PER_BUS)
            .map(|i| {
                k += 1;
                (if i % 2 == 0 { "pd28-1021" } else { "pd-113" }, i as u8 + 1, (k - 1).is_multiple_of(3))
            })
            .collect();
        lines.push(FleetLine { link: dir.join(format!("bus{b}")), modules });
    }
    lines
}

/// CPU time (user + system) of a process and its threads so far, and its resident memory, from /proc.
fn proc_usage(pid: u32) -> (f64, u64) {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // The fields after the command name (which may hold spaces) in parentheses.
    let fields: Vec<&str> = stat.rsplit_once(')').map_or("", |(_, rest)| rest).split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    // In USER_HZ, which Linux keeps at 100 for what it reports to user space.
    let hz = 100.0;
    // utime and stime are fields 14 and 15 of stat, 11 and 12 after the name.
    let cpu = (ticks(11) + ticks(12)) / hz;
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let rss = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .unwrap_or(0);
    (cpu, rss)
}

/// Sets the fleet going as a host would: on each TMCM-1310 the encoder initialised (AP 132 = 1 until it
/// reads 2) and the loop closed (AP 129 = 1), and every third module turned (ROR).
fn fleet_setup(lines: &[FleetLine], closed_loop: bool, turn: bool) {
    for line in lines {
        let transport = loop {
            match SerialTransport::open(line.link.to_str().unwrap(), 115_200) {
                Ok(t) => break t,
                Err(_) => std::thread::sleep(StdDuration::from_millis(20)),
            }
        };
        let mut client = Client::new(transport);
        for &(model, address, turning) in &line.modules {
            client = client.with_module_address(address);
            if model == "tmcm-1310" && closed_loop {
                client.set_axis_parameter(132, 0, 1).unwrap();
                let deadline = StdInstant::now() + StdDuration::from_secs(10);
                while client.get_axis_parameter(132, 0).unwrap() != 2 {
                    assert!(StdInstant::now() < deadline, "encoder initialisation did not end");
                    std::thread::sleep(StdDuration::from_millis(5));
                }
                client.set_axis_parameter(129, 0, 1).unwrap();
                assert_eq!(client.get_axis_parameter(129, 0).unwrap(), 1, "the loop is closed");
            }
            if turning && turn {
                // 10 000 pps on the PD28-1021 and the TMCM-1310; 500 in the PDx-113's TMC428 units.
                client.rotate(0, if model == "pd-113" { 500 } else { 10_000 }).unwrap();
            }
        }
    }
}

/// Waits until every line's link is there (up to 60 s).
fn fleet_wait_for_links(lines: &[FleetLine]) {
    let deadline = StdInstant::now() + StdDuration::from_secs(60);
    while !lines.iter().all(|l| std::fs::symlink_metadata(&l.link).is_ok()) {
        assert!(StdInstant::now() < deadline, "the fleet did not start");
        std::thread::sleep(StdDuration::from_millis(20));
    }
}

/// Starts the fleet with `tmcl` (`--fleet FILE` in one process, or with `processes` one `tmcl serve` per
/// line, as without `--fleet`), sets it going, leaves it without host traffic for `idle` and measures the
/// CPU time and resident memory of all its processes over that time.
fn fleet_run(tmcl: &str, name: &str, processes: bool, closed_loop: bool, turn: bool, idle: StdDuration) {
    let dir = std::env::temp_dir().join(format!("tmcl-bench-fleet-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let lines = fleet_lines(&dir);
    let modules: usize = lines.iter().map(|l| l.modules.len()).sum();
    let mut children = Vec::new();
    if processes {
        for line in &lines {
            let mut cmd = Process::new(tmcl);
            cmd.arg("serve").arg("--pty").arg(&line.link).stdout(Stdio::null());
            for (model, address, _) in &line.modules {
                cmd.arg("--module").arg(format!("{model}@{address}"));
            }
            children.push(Server(cmd.spawn().expect("start tmcl serve"), line.link.clone()));
        }
    } else {
        let mut toml = String::new();
        for line in &lines {
            let modules: Vec<String> = line.modules.iter().map(|(m, a, _)| format!("\"{m}@{a}\"")).collect();
            toml += &format!("[[line]]\npty = {:?}\nmodule = [{}]\n\n", line.link, modules.join(", "));
        }
        let file = dir.join("fleet.toml");
        std::fs::write(&file, toml).unwrap();
        let child = Process::new(tmcl)
            .arg("serve")
            .arg("--fleet")
            .arg(&file)
            .stdout(Stdio::null())
            .spawn()
            .expect("start tmcl serve");
        children.push(Server(child, dir.join("none")));
    }
    fleet_wait_for_links(&lines);
    fleet_setup(&lines, closed_loop, turn);
    // Settle (the closed loops' start, the ramps to speed), then measure.
    std::thread::sleep(StdDuration::from_secs(2));
    let usage = || children.iter().map(|c| proc_usage(c.0.id())).fold((0.0, 0), |(c, r), (c1, r1)| (c + c1, r + r1));
    let (cpu0, _) = usage();
    let wall0 = StdInstant::now();
    std::thread::sleep(idle);
    let (cpu1, rss) = usage();
    let wall = wall0.elapsed().as_secs_f64();
    println!(
        "fleet {name:<44} {modules} modules on {} lines in {} process(es): {:.3} % of a core ({:.0} ms CPU in {wall:.1} s), \
         RSS {} KiB in all",
        lines.len(),
        children.len(),
        100.0 * (cpu1 - cpu0) / wall,
        (cpu1 - cpu0) * 1e3,
        rss
    );
    drop(children);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The resident memory of `tmcl serve` with one PD28-1021 on one pty (the process without the fleet),
/// and with the fleet as one `--fleet` process, modules standing: what a module costs beyond the process.
fn fleet_memory(tmcl: &str) {
    let dir = std::env::temp_dir().join(format!("tmcl-bench-fleet-mem-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let link = dir.join("one");
    let one = Server(
        Process::new(tmcl).args(["serve", "--pty"]).arg(&link).stdout(Stdio::null()).spawn().expect("tmcl serve"),
        link.clone(),
    );
    let mut client = connect(&link);
    client.get_axis_parameter(1, 0).unwrap();
    std::thread::sleep(StdDuration::from_millis(500));
    let (_, rss_one) = proc_usage(one.0.id());
    drop(client);
    drop(one);
    let lines = fleet_lines(&dir);
    let modules: usize = lines.iter().map(|l| l.modules.len()).sum();
    let mut toml = String::new();
    for line in &lines {
        let m: Vec<String> = line.modules.iter().map(|(m, a, _)| format!("\"{m}@{a}\"")).collect();
        toml += &format!("[[line]]\npty = {:?}\nmodule = [{}]\n\n", line.link, m.join(", "));
    }
    std::fs::write(dir.join("fleet.toml"), toml).unwrap();
    let fleet = Server(
        Process::new(tmcl)
            .arg("serve")
            .arg("--fleet")
            .arg(dir.join("fleet.toml"))
            .stdout(Stdio::null())
            .spawn()
            .unwrap(),
        dir.join("none"),
    );
    fleet_wait_for_links(&lines);
    // One request to each module, so that each line's loop has run and its buffers exist.
    for line in &lines {
        let mut c = Client::new(SerialTransport::open(line.link.to_str().unwrap(), 115_200).unwrap());
        for &(_, address, _) in &line.modules {
            c = c.with_module_address(address);
            c.get_axis_parameter(1, 0).unwrap();
        }
    }
    std::thread::sleep(StdDuration::from_millis(500));
    let (_, rss_fleet) = proc_usage(fleet.0.id());
    println!(
        "fleet memory: one module {rss_one} KiB RSS; {modules} modules on {} lines {rss_fleet} KiB; {:.1} KiB per \
         module beyond the process",
        lines.len(),
        (rss_fleet.saturating_sub(rss_one)) as f64 / (modules - 1) as f64
    );
    drop(fleet);
    let _ = std::fs::remove_dir_all(&dir);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    // `--only core|vm|motion|events|run|growth|serve|pty|memory|ethercat|fleet` runs one part (for instruction
    // counts under valgrind: `motion` is the §2.4 hour tick by tick, `events` the same hour event-driven).
    let only = args.iter().position(|a| a == "--only").and_then(|i| args.get(i + 1)).map(String::as_str);
    let part = |name: &str| only.is_none_or(|o| o == name);
    let n = if quick { 1_000_000 } else { 20_000_000 };
    if part("memory") {
        memory();
    }
    if part("core") {
        core_rate("GAP 1 (actual position)", &[frame(Opcode::Gap, 1, 0)], n);
        core_rate("SAP 4 (max speed)", &[frame(Opcode::Sap, 4, 51200)], n);
        core_rate("MVP ABS (alternating)", &[frame(Opcode::Mvp, 0, 100_000), frame(Opcode::Mvp, 0, -100_000)], n);
    }
    if only == Some("gap") {
        core_rate("GAP 1 (actual position)", &[frame(Opcode::Gap, 1, 0)], n);
    }
    if part("vm") {
        vm_rate(if quick { 20 } else { 200 });
    }
    if part("motion") {
        motion_program_ratio(3600, true);
    }
    if part("events") {
        motion_program_ratio(3600, false);
    }
    if part("run") {
        run_hour(if quick { 2 } else { 5 });
    }
    if part("growth") {
        event_growth();
    }
    if part("serve") {
        serve_cpu(if quick { 10 } else { 60 });
    }
    if only == Some("serve1310") {
        serve_1310(if quick { 5 } else { 20 }, if quick { 1 } else { 2 });
    }
    if part("pty") {
        pty_latency(if quick { 2_000 } else { 20_000 });
    }
    if only == Some("closed-loop") {
        // `--poll end|deadlines|MS` (default: each of end, deadlines, 10, 100, 1000 in turn).
        let poll = args.iter().position(|a| a == "--poll").and_then(|i| args.get(i + 1));
        match poll {
            Some(p) => closed_loop_hour(p),
            None => ["end", "deadlines", "10", "100", "1000"].into_iter().for_each(closed_loop_hour),
        }
    }
    if only == Some("fleet") {
        // `FLEET_BEFORE=PATH`: a `tmcl` from before --fleet, served as one process per line, in the same run.
        let tmcl = env!("CARGO_BIN_EXE_tmcl");
        let idle = StdDuration::from_secs(if quick { 10 } else { 30 });
        fleet_memory(tmcl);
        let before = std::env::var("FLEET_BEFORE").ok();
        for round in 0..if quick { 1 } else { 2 } {
            if let Some(before) = &before {
                let name = format!("before: one process per line, loop closed [{round}]");
                fleet_run(before, &name, true, true, true, idle);
            }
            if let Ok(other) = std::env::var("FLEET_COMPARE") {
                // `FLEET_COMPARE=PATH`: another build's `tmcl --fleet`, loop closed, alternating with this one.
                fleet_run(&other, &format!("--fleet, other build, loop closed [{round}]"), false, true, true, idle);
            }
            fleet_run(tmcl, &format!("--fleet, loop closed [{round}]"), false, true, true, idle);
            fleet_run(tmcl, &format!("--fleet, loop closed, all standing [{round}]"), false, true, false, idle);
            fleet_run(tmcl, &format!("--fleet, loop open [{round}]"), false, false, true, idle);
            fleet_run(tmcl, &format!("--fleet, loop open, all standing [{round}]"), false, false, false, idle);
        }
    }
    if part("ethercat") {
        ethercat_rate(if quick { 100_000 } else { 2_000_000 });
    }
}

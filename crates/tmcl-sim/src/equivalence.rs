//! Event-driven against tick-by-tick: the same module, world, program and host commands run twice — once
//! jumping from event to event (the default), once ticking the motion controller every 1 ms
//! ([`Module::set_exact_ticks`]) — and everything either run shows is compared: the firmware state
//! (ramp, registers, flags, timers, interrupts, every parameter), the program machine (PC, stack, WAIT,
//! handler), the board (shaft, field, energy, load measurements, encoder, outputs) and the replies with
//! the time each went out.
//!
//! Each run is polled the way a runner polls it: at its own deadlines (the event-driven one far less
//! often), at the world's own changes, at the host's commands, and — the event-driven one — at extra
//! times of the input's choosing, since a module must not depend on how often it is polled.
//!
//! [`Scenario::decode`] turns arbitrary bytes into a scenario (a model, a world, settings, a program and
//! timed host commands) so that the property tests (`tests/event_driven.rs`) and the fuzz target
//! `event_driven` share it; every byte string decodes to something valid.

use crate::board::SimBoard;
use crate::world::World;
use tmcl_core::model::{pd28_1021, pd_113, tmcm_1140, tmcm_1310, tmcm_3110, tmcm_6110, Kinematics, ModelSpec, Setting};
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::{CalcOp, Command, Condition, EventMode, Instruction, MoveTarget, Request, RfsAction, WaitCondition};

/// Reads a scenario out of bytes: every read succeeds (0 past the end).
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }

    fn u16(&mut self) -> u16 {
        u16::from(self.u8()) << 8 | u16::from(self.u8())
    }

    fn u32(&mut self) -> u32 {
        u32::from(self.u16()) << 16 | u32::from(self.u16())
    }

    /// `true` one time in `n`.
    fn one_in(&mut self, n: u8) -> bool {
        self.u8().is_multiple_of(n)
    }

    /// A value in `lo..=hi`.
    fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + i64::from(self.u32()) % (hi - lo + 1)
    }

    /// One of `choices`.
    fn pick<T: Copy>(&mut self, choices: &[T]) -> T {
        choices[usize::from(self.u8()) % choices.len()]
    }
}

/// A run to compare: what both modules get.
#[derive(Clone)]
pub struct Scenario {
    /// The model.
    pub spec: &'static ModelSpec,
    /// The world file's text (empty: the default world).
    pub world: String,
    /// Settings before the program starts (host commands at time 0).
    pub settings: Vec<Command>,
    /// The program, started at time 0 (empty: none).
    pub program: Vec<Command>,
    /// Host commands with the time they arrive, in order.
    pub host: Vec<(Instant, Command)>,
    /// Extra polls of the event-driven module.
    pub polls: Vec<Instant>,
    /// How long both run.
    pub end: Instant,
}

/// Axis parameters a scenario sets, with a value range for each (motion, currents, switches, drive).
const AXIS: &[(u8, i64, i64)] = &[
    (4, 1, 400_000),
    (4, 100, 60_000),
    (5, 1, 2_000_000),
    (5, 1000, 200_000),
    (130, 0, 5_000),
    (140, 0, 8),
    (6, 0, 255),
    (7, 0, 255),
    (200, 0, 255),
    (204, 0, 30),
    (214, 0, 30),
    (12, 0, 1),
    (13, 0, 1),
    (181, 0, 60_000),
    (182, 0, 60_000),
    (183, 0, 255),
    (172, 0, 3),
    (173, 0, 1),
    (174, -64, 63),
    (179, 0, 1),
    (193, 1, 8),
    (194, 1, 60_000),
    (195, 1, 20_000),
    (210, 25_600, 25_604),
    (212, 0, 3000),
];

/// Closed-loop parameters a closed-loop scenario sets (TMCM-1310: I²t, β, current scaling, the
/// controller, the following error, the position window), with a value range for each.
const CLOSED_LOOP: &[(u8, i64, i64)] = &[
    (25, 1, 20_000),
    (26, 0, 3_000_000),
    (111, 0, 256),
    (113, 0, 255),
    (114, 0, 255),
    (115, 0, 1),
    (116, 0, 300),
    (117, 0, 300),
    (118, 0, 40),
    (119, 0, 40),
    (120, 0, 50),
    (121, 0, 50),
    (122, 0, 1),
    (124, 0, 200),
    (125, 0, 20_000),
    (126, 0, 100_000),
    (134, 0, 300),
    (136, 0, 1024),
    (138, 0, 2000),
];

impl std::fmt::Debug for Scenario {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "model {}, until {}", self.spec.id, self.end)?;
        writeln!(f, "world:\n{}", self.world)?;
        writeln!(f, "settings: {:?}", self.settings)?;
        for (n, c) in self.program.iter().enumerate() {
            writeln!(f, "  {n:2}: {c:?}")?;
        }
        for (t, c) in &self.host {
            writeln!(f, "at {t}: {c:?}")?;
        }
        write!(f, "extra polls: {:?}", self.polls.iter().map(|p| p.to_string()).collect::<Vec<_>>())
    }
}

impl Scenario {
    /// Decodes arbitrary bytes into a scenario (see the module docs).
    pub fn decode(data: &[u8]) -> Scenario {
        Scenario::decode_as(data, false)
    }

    /// [`Scenario::decode`] for a TMCM-1310 with its loop closed at the start, whatever the bytes say
    /// (the property test of closed loops, which one scenario in sixteen of `decode` is).
    pub fn decode_closed_loop(data: &[u8]) -> Scenario {
        Scenario::decode_as(data, true)
    }

    fn decode_as(data: &[u8], closed_loop: bool) -> Scenario {
        let mut b = Bytes(data);
        // (The model's byte is read either way, so that the rest decodes alike; 0 is the TMCM-1310.)
        let model = b.u8();
        let model = if closed_loop { 0 } else { model };
        // 6: the TMCM-1140 (a value no stored regression starts with, so that they decode as before).
        let spec: &'static ModelSpec = match model % 8 {
            0 => &tmcm_1310::SPEC,
            1 => &pd_113::SPEC,
            6 => &tmcm_1140::SPEC,
            // 7: the TMCM-3110 or the TMCM-6110 (the next byte picks), so that event-driven runs of several
            // moving motors are checked against tick-by-tick ones.
            7 if b.u8() % 2 == 1 => &tmcm_6110::SPEC,
            7 => &tmcm_3110::SPEC,
            _ => &pd28_1021::SPEC,
        };
        let world = world(&mut b);
        let mut settings = Vec::new();
        if matches!(spec.kinematics, Kinematics::Tmc428 { .. }) {
            // The TMC428 generation's pulse and ramp divisors (AP 154, 153), which scale its velocities
            // and accelerations (read only for this model, so other scenarios decode as before).
            // Every motor's (one of each for a one-motor model, as before).
            for motor in 0..spec.motors {
                settings.push(Command::Sap { param: 154, motor, value: b.range(0, 13) as i32 });
                settings.push(Command::Sap { param: 153, motor, value: b.range(0, 13) as i32 });
            }
        }
        for _ in 0..b.u8() % 6 {
            settings.push(setting(&mut b));
        }
        let mut program = Vec::new();
        let len = b.u8() % 20;
        for _ in 0..len {
            program.push(instruction(&mut b, len));
        }
        let end = Instant::from_millis(b.range(1, 12_000) as u64);
        let mut host = Vec::new();
        let mut t = Instant::ZERO;
        for _ in 0..b.u8() % 8 {
            t += Duration::from_micros(b.range(0, 3_000_000) as u64);
            if t < end {
                host.push((t, host_command(&mut b)));
            }
        }
        let mut polls: Vec<Instant> =
            (0..b.u8() % 6).map(|_| Instant::from_micros(b.range(0, end.micros() as i64) as u64)).collect();
        polls.sort();
        // One time in three a program that never waits and spins (read last, so that the byte strings of
        // earlier failures decode as before: past the end every byte reads 0).
        if b.u8() % 3 == 1 {
            program = spin_program(&mut b);
        }
        if spec.motors > 1 {
            // A model of several motors: the commands go to its motors in turn, from one the input picks
            // (read last, so that one-motor scenarios decode as before), so that several move at once.
            let first = b.u8();
            let skip = 2 * usize::from(spec.motors) * usize::from(matches!(spec.kinematics, Kinematics::Tmc428 { .. }));
            for (i, c) in
                settings.iter_mut().skip(skip).chain(&mut program).chain(host.iter_mut().map(|(_, c)| c)).enumerate()
            {
                on_motor(c, ((i + usize::from(first)) % usize::from(spec.motors)) as u8);
            }
            // Every `every`-th move (none for 0) becomes an MVP COORD of several motors at once,
            // interpolated or each at its own speed (`module/coordinated.rs` in tmcl-core).
            let every = usize::from(b.u8() % 4);
            let all = (1u16 << spec.motors) as u8 - 1;
            let moves = program.iter_mut().chain(host.iter_mut().map(|(_, c)| c));
            for (i, c) in moves.filter(|c| matches!(c, Command::Mvp { .. })).enumerate() {
                if every > 0 && i % every == 0 {
                    let mask = (b.u8() & all).max(1);
                    let mode = if b.u8() % 2 == 0 { 0x40 } else { 0x80 };
                    *c = Command::Mvp { motor: mode | mask, target: MoveTarget::Coord(i32::from(b.u8() % 21)) };
                }
            }
        }
        if spec.axis.has(Setting::ClosedLoop) && (b.u8() % 2 == 1 || closed_loop) {
            // A closed-loop model, one time in two (read last, so that earlier scenarios decode as
            // before): the encoder initialised and the loop closed at the start, as pytrinamic's
            // closed-loop demo does (AP 129 written during the initialisation closes the loop when it is
            // done), with closed-loop settings drawn too (current scaling, I²t, the controller).
            let mut first =
                vec![Command::Sap { param: 132, motor: 0, value: 1 }, Command::Sap { param: 129, motor: 0, value: 1 }];
            for _ in 0..b.u8() % 6 {
                let (param, lo, hi) = b.pick(CLOSED_LOOP);
                first.push(Command::Sap { param, motor: 0, value: b.range(lo, hi) as i32 });
            }
            settings.splice(0..0, first);
            // Host commands that open and close the loop, or enter torque mode.
            for (_, c) in host.iter_mut() {
                if b.one_in(4) {
                    *c = match b.u8() % 3 {
                        0 => Command::Sap { param: 129, motor: 0, value: i32::from(b.u8() % 2) },
                        1 => Command::Sap { param: 14, motor: 0, value: b.range(-1500, 1500) as i32 },
                        _ => {
                            let (param, lo, hi) = b.pick(CLOSED_LOOP);
                            Command::Sap { param, motor: 0, value: b.range(lo, hi) as i32 }
                        }
                    };
                }
            }
        }
        if matches!(spec.kinematics, Kinematics::Tmc428 { .. }) {
            // Velocities and accelerations in its units, 0..2047, so that they are taken, not refused.
            for c in settings.iter_mut().chain(&mut program).chain(host.iter_mut().map(|(_, c)| c)) {
                fit_tmc428(c);
            }
        }
        Scenario { spec, world, settings, program, host, polls, end }
    }

    /// The scenario with its time line compressed so that the tick-by-tick run ticks at most
    /// `motor_ticks` motion ticks of all its motors together: the end, the host's commands and the extra
    /// polls move closer to time 0 in proportion (each keeps its place in the run; commands that land on
    /// the same microsecond keep their order), so a long scenario keeps everything that happens in it,
    /// only closer together. The world's own times and the program's (WAIT, timers) are left as they are.
    /// A scenario within the budget is returned unchanged.
    ///
    /// The fuzz target `event_driven` runs its scenarios so: the tick-by-tick reference costs about a
    /// microsecond per motor and tick, and a scenario decodes to up to 12 s of six motors, so without a
    /// bound a few inputs (the slowest 1 % took 78 % of the time) set the campaign's pace. The property
    /// tests (`tests/event_driven.rs`) run scenarios at their full length.
    pub fn compressed(mut self, motor_ticks: u64) -> Scenario {
        let ticks = self.end.millis().max(1) * u64::from(self.spec.motors);
        if ticks <= motor_ticks {
            return self;
        }
        let (from, to) =
            (u128::from(self.end.micros()), u128::from(motor_ticks / u64::from(self.spec.motors)).max(1) * 1000);
        let scale = |t: Instant| Instant::from_micros((u128::from(t.micros()) * to / from) as u64);
        for (t, _) in &mut self.host {
            *t = scale(*t);
        }
        for t in &mut self.polls {
            *t = scale(*t);
        }
        self.end = scale(self.end);
        self
    }

    /// Runs the scenario event-driven and tick by tick, and compares; `Err` describes the first
    /// difference.
    pub fn check(&self) -> Result<(), String> {
        let Some(mut fast) = self.module(false) else { return Ok(()) };
        let Some(mut slow) = self.module(true) else { return Ok(()) };
        let (mut fast_out, mut slow_out) = (Vec::new(), Vec::new());
        // The times at which both are compared: the host's commands and the end.
        let mut stops: Vec<Instant> = self.host.iter().map(|(t, _)| *t).collect();
        stops.push(self.end);
        let mut host = self.host.iter().peekable();
        let mut extra = self.polls.iter().peekable();
        let (mut t_fast, mut t_slow) = (Instant::ZERO, Instant::ZERO);
        for stop in stops {
            run_to(&mut fast, &mut t_fast, stop, &mut extra, &mut fast_out);
            run_to(&mut slow, &mut t_slow, stop, &mut std::iter::empty().peekable(), &mut slow_out);
            compare(&mut fast, &mut slow, stop)?;
            while let Some((_, command)) = host.next_if(|(t, _)| *t == stop) {
                let frame = Request { address: 1, instruction: command.encode() }.to_bytes();
                fast.receive(stop, &frame, &mut |bytes: &[u8]| fast_out.push((stop, bytes.to_vec())));
                slow.receive(stop, &frame, &mut |bytes: &[u8]| slow_out.push((stop, bytes.to_vec())));
            }
            if fast_out != slow_out {
                return Err(format!(
                    "replies differ by {stop}:\n  event-driven {fast_out:?}\n  tick by tick {slow_out:?}"
                ));
            }
        }
        Ok(())
    }

    /// For a scenario that fails [`Scenario::check`]: both modules polled on the same schedule (every
    /// tick, each one's deadlines, the host's commands), compared after each poll, and the first
    /// difference described with the time of the poll before it.
    pub fn first_difference(&self) -> Option<String> {
        let (mut fast, mut slow) = (self.module(false)?, self.module(true)?);
        let mut host = self.host.iter().peekable();
        let mut t = Instant::ZERO;
        let mut before = Instant::ZERO;
        while t <= self.end {
            let a = fast.poll(t, &mut |_: &[u8]| {});
            let b = slow.poll(t, &mut |_: &[u8]| {});
            if let Err(e) = compare(&mut fast, &mut slow, t) {
                return Some(format!("after the poll at {t} (the one before at {before}): {e}"));
            }
            while let Some((_, command)) = host.next_if(|(at, _)| *at == t) {
                let frame = Request { address: 1, instruction: command.encode() }.to_bytes();
                fast.receive(t, &frame, &mut |_: &[u8]| {});
                slow.receive(t, &frame, &mut |_: &[u8]| {});
            }
            fast.board_timeline().advance(t);
            slow.board_timeline().advance(t);
            let tick = Instant::from_micros((t.micros() / 1000 + 1) * 1000);
            let next = [a, b, host.peek().map(|(at, _)| *at), Some(tick)]
                .into_iter()
                .flatten()
                .filter(|n| *n > t)
                .min()
                .unwrap_or(tick);
            before = t;
            t = next;
        }
        None
    }

    /// A module with the world, settings and program, started at 0, event-driven or (`exact`) ticking
    /// one by one; `None` if the world does not load. (For a closer look at a scenario that fails.)
    pub fn module(&self, exact: bool) -> Option<Module<SimBoard>> {
        let mut board = SimBoard::in_memory_for(self.spec);
        if !self.world.is_empty() {
            board = board.with_world(World::from_toml_str(&self.world).ok()?).ok()?;
        }
        let mut module = Module::new(board, self.spec, Instant::ZERO);
        module.set_exact_ticks(exact);
        for c in &self.settings {
            let _ = module.execute(*c, Instant::ZERO);
        }
        if !self.program.is_empty() {
            let cells: Vec<Instruction> = self.program.iter().map(|c| c.encode()).collect();
            module.load_program(&cells).ok()?;
            let _ = module.execute(Command::RunApplication { from: Some(0) }, Instant::ZERO);
        }
        Some(module)
    }
}

/// Debugging aid (`EVENT_TRACE=1`): the board's rotor, field and load at each of a run's polls.
fn trace(module: &mut Module<SimBoard>, now: Instant) {
    // (Looked up once: a run polls thousands of times.)
    static TRACING: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    if *TRACING.get_or_init(|| std::env::var_os("EVENT_TRACE").is_some()) {
        let exact = module.exact_ticks();
        let st = format!("{:?}", module.state());
        let enc = st.split("encoder: ").nth(1).unwrap_or("").split(", error_flags").next().unwrap_or("").to_string();
        let lc = st.split("last_counts: ").nth(1).unwrap_or("").split(',').next().unwrap_or("").to_string();
        eprintln!(
            "{} {now} pos {} v {} enc {enc} last {lc}",
            if exact { "T" } else { "E" },
            module.ramp().position,
            module.ramp().velocity()
        );
        let b = module.board_mut();
        let f = b.feedback();
        eprintln!(
            "{} {now} shaft {} field {} load {} flags {} coil {} drive {:?}",
            if exact { "T" } else { "E" },
            b.shaft(),
            b.commanded(),
            f.load,
            f.driver_flags,
            b.coil_current(),
            b.drive()
        );
    }
}

/// Polls `module` from `*t` up to `stop` at its deadlines and the world's changes (and the extra polls
/// before `stop`), as a runner does, collecting what it sends with the time.
fn run_to<'a>(
    module: &mut Module<SimBoard>,
    t: &mut Instant,
    stop: Instant,
    extra: &mut std::iter::Peekable<impl Iterator<Item = &'a Instant>>,
    out: &mut Vec<(Instant, Vec<u8>)>,
) {
    // The next poll of a runner (at a deadline or a change of the world), apart from the extra ones.
    let mut due = *t;
    loop {
        let now = *t;
        let deadline = module.poll(now, &mut |bytes: &[u8]| out.push((now, bytes.to_vec())));
        if now == due {
            // A runner moves the world on at its polls (`tmcl run`'s `sim::poll`); an extra poll only asks
            // the module.
            module.board_timeline().advance(now);
            trace(module, now);
            if now >= stop {
                return;
            }
            let mut next = deadline.unwrap_or(stop).max(now).min(stop);
            if let Some(e) = module.board().next_event().filter(|e| *e > now) {
                next = next.min(e);
            }
            // A deadline that is due and brings nothing new (a timer between ticks is sampled at the next
            // tick): on at the next tick, as `tmcl run` does.
            due = if next == now { Instant::from_micros((now.micros() / 1000 + 1) * 1000).min(stop) } else { next };
        }
        *t = due;
        while let Some(&&p) = extra.peek() {
            if p <= now {
                extra.next();
                continue;
            }
            *t = due.min(p);
            break;
        }
    }
}

/// Everything both modules show at `t`.
fn compare(fast: &mut Module<SimBoard>, slow: &mut Module<SimBoard>, t: Instant) -> Result<(), String> {
    let (a, b) = (view(fast, t), view(slow, t));
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        if x != y {
            // Where the two texts part, with some context before it.
            let at = x.bytes().zip(y.bytes()).position(|(p, q)| p != q).unwrap_or(x.len().min(y.len()));
            let from = x.char_indices().map(|(i, _)| i).rfind(|i| *i + 160 <= at).unwrap_or(0);
            let cut = |s: &str| s.get(from..).unwrap_or(s).chars().take(320).collect::<String>();
            return Err(format!("at {t}, {name}:\n  event-driven …{}\n  tick by tick …{}", cut(x), cut(y)));
        }
    }
    Ok(())
}

/// What a module shows at `t`: named values, as text.
fn view(m: &mut Module<SimBoard>, t: Instant) -> Vec<(String, String)> {
    // The boards as a read at `t` finds them: a look for the deadline may have brought a board to `t`
    // already (a rotor settling after a step moves then), where ticking brings it there at its next tick.
    m.sync_boards(t);
    // When the module last called the board is not compared: a tick-by-tick run brings the board's clock
    // to every tick it reads the board at, a span reads nothing in between (the board's state at any
    // instant is the same: its world runs on composably, see `SimBoard::quiet`).
    // Every motor's (a module of several motors has one per axis).
    let mut state = format!("{:?}", m.state());
    while let Some((head, tail)) = state.split_once("board_time: ") {
        state = format!("{head}{}", tail.split_once("}, ").map_or("", |(_, rest)| rest));
    }
    let mut v = vec![
        ("state".to_string(), state),
        ("program machine".to_string(), format!("{:?}", m.vm())),
        ("registers".to_string(), format!("{:?} {:?}", m.registers(), m.host_registers())),
    ];
    // Every motor's axis of the board (motor 0: the board itself).
    for motor in 0..m.board().motors() {
        let Some(board) = m.board_mut().axis_mut(motor) else { continue };
        let feedback = board.feedback();
        v.push((
            if motor == 0 { "board".to_string() } else { format!("board of motor {motor}") },
            format!(
                "shaft {} field {} lost {} energy {:x} outputs {} drive {:?} feedback {:?} coil {:x}",
                board.shaft(),
                board.commanded(),
                board.lost_full_steps(),
                board.energy().to_bits(),
                board.outputs(),
                // The last update's own move is a span's sum (`StepDriver::update`); where it went is compared.
                tmcl_core::hal::DriveState { moved: 0, ..*board.drive() },
                feedback,
                board.coil_current().to_bits(),
            ),
        ));
    }
    let spec = m.spec();
    for motor in 0..spec.motors {
        for d in spec.axis.params {
            let name = if motor == 0 { format!("AP {}", d.number) } else { format!("AP {}, {motor}", d.number) };
            v.push((name, format!("{:?}", m.get_axis_of(motor, d.number))));
        }
    }
    for d in spec.global.params {
        v.push((format!("GP {}", d.number), format!("{:?}", m.get_global(d.number, 0, t))));
    }
    for n in 0..8 {
        v.push((format!("GP {n}, 2"), format!("{:?}", m.get_global(n, 2, t))));
    }
    v
}

/// A world: free, switches, friction and stops, a timeline, loads, or a stage as in the examples.
fn world(b: &mut Bytes) -> String {
    let pos = |b: &mut Bytes| b.range(-300_000, 300_000);
    let span = |b: &mut Bytes| b.range(1, 80_000);
    let time = |b: &mut Bytes| b.range(0, 10_000);
    let mut text = String::new();
    match b.u8() % 8 {
        0 => {}
        1 | 2 => {
            for name in ["left", "right", "home"] {
                if !b.one_in(3) {
                    let at = pos(b);
                    let to = at + span(b);
                    text += &format!("[switches.{name}]\nat = [\"{at} usteps\", \"{to} usteps\"]\n");
                    // A quarter of the switches narrower than a turn (51 200 µsteps on the default rotary axis)
                    // are a rotary table's, met every turn. Decided from where the switch is rather than from
                    // a byte of its own, so that stored cases decode as they did before this choice existed.
                    if to - at < 51_200 && at.rem_euclid(4) == 0 {
                        text += "every_turn = true\n";
                    }
                    if b.one_in(3) {
                        text += "active = \"low\"\n";
                    }
                    if b.one_in(2) {
                        text +=
                            &format!("bounce = {{ time = \"{} us\", count = {} }}\n", b.range(1, 5000), b.range(1, 4));
                    }
                }
            }
        }
        3 => {
            text += &format!("[load]\nfriction = {}\n", b.range(0, 12) as f64 * 0.001);
            if b.one_in(2) {
                text += &format!("constant = {}\n", b.range(-8, 8) as f64 * 0.001);
            }
            if b.one_in(2) {
                let at = pos(b);
                text += &format!(
                    "[[load.jam]]\nat = [\"{at} usteps\", \"{} usteps\"]\ntorque = {}\n",
                    at + span(b),
                    b.range(1, 300) as f64 * 0.001
                );
            }
            if b.one_in(2) {
                let lo = -b.range(1_000, 400_000);
                let hi = b.range(1_000, 400_000);
                text += &format!("[axis]\ntravel = [\"{lo} usteps\", \"{hi} usteps\"]\n");
            }
        }
        4 => {
            for _ in 0..b.range(0, 4) {
                text += &format!("[[inputs.timeline]]\nat = \"{} ms\"\ndigital = {}\n", time(b), b.u8() % 16);
            }
            if b.one_in(2) {
                let from = time(b);
                text += &format!(
                    "[[faults.driver]]\nfrom = \"{from} ms\"\nuntil = \"{} ms\"\nflags = [\"{}\"]\n",
                    from + time(b),
                    b.pick(&["prewarning", "open_a", "short_a", "overtemperature"])
                );
            }
            if b.one_in(2) {
                text += &format!("[[faults.encoder_slip]]\nat = \"{} ms\"\ncounts = {}\n", time(b), b.range(-200, 200));
            }
            if b.one_in(2) {
                let from = time(b);
                text += &format!(
                    "[[faults.supply_drop]]\nfrom = \"{from} ms\"\nuntil = \"{} ms\"\nvoltage = {}\n",
                    from + time(b),
                    b.range(5, 23)
                );
            }
        }
        5 => {
            text += &format!("[load]\nfriction = {}\n", b.range(1, 8) as f64 * 0.001);
            for _ in 0..b.range(0, 3) {
                text += &format!(
                    "[[load.script]]\nat = \"{} ms\"\ntorque = {}\n",
                    time(b),
                    b.range(-10, 10) as f64 * 0.001
                );
            }
            if b.one_in(2) {
                text += &format!(
                    "[[faults.stall]]\nat = \"{} usteps\"\nfrom = \"{} ms\"\nuntil = \"{} ms\"\n",
                    pos(b),
                    time(b),
                    10_000 + time(b)
                );
            }
        }
        6 => {
            text += &format!(
                "[motor]\ndetent_torque = {}\n[load]\nspring = {{ rate = {}, rest = {} }}\n",
                b.range(0, 4) as f64 * 0.001,
                b.range(0, 5) as f64 * 0.00001,
                b.range(-90, 90)
            );
        }
        _ => text += LINEAR_STAGE,
    }
    text
}

/// The example linear stage (`examples/worlds/linear-stage.toml`), inline.
const LINEAR_STAGE: &str = "[axis]\nkind = \"linear\"\nlead = 2.0\ntravel = [-4.0, 104.0]\nstart = 25.0\n\
load_inertia = 2e-7\n[load]\nfriction = 0.004\n[switches.left]\nat = [-4.0, 0.0]\n[switches.right]\n\
at = [100.0, 104.0]\n[switches.home]\nat = [49.5, 50.5]\nbounce = { time = \"2 ms\", count = 2 }\n";

/// Velocities (ROR, ROL, SAP 2, 4, 130, 194, 195) and accelerations (SAP 5) folded into the TMC428's
/// 0..2047, the sign kept.
fn fit_tmc428(c: &mut Command) {
    let fold = |v: &mut i32| *v %= 2048;
    match c {
        Command::Ror { velocity, .. } | Command::Rol { velocity, .. } => fold(velocity),
        Command::Sap { param: 2 | 4 | 5 | 130 | 194 | 195, value, .. } => fold(value),
        _ => {}
    }
}

/// `c` sent to motor `m` instead, if it names a motor.
fn on_motor(c: &mut Command, m: u8) {
    match c {
        Command::Ror { motor, .. }
        | Command::Rol { motor, .. }
        | Command::Mst { motor }
        | Command::Mvp { motor, .. }
        | Command::Sap { motor, .. }
        | Command::Gap { motor, .. }
        | Command::Stap { motor, .. }
        | Command::Rsap { motor, .. }
        | Command::Rfs { motor, .. }
        | Command::Wait { motor, .. }
        | Command::Sco { motor, .. }
        | Command::Gco { motor, .. }
        | Command::Cco { motor, .. }
        | Command::Aap { motor, .. }
        | Command::Aco { motor, .. } => *motor = m,
        _ => {}
    }
}

/// A setting: SAP of a motion, current, switch or drive parameter, or an interrupt's bank 3 setting.
fn setting(b: &mut Bytes) -> Command {
    if b.one_in(5) {
        // Timer periods (bank 3, 0..2) and the trigger transitions of switch and input interrupts.
        let param = b.pick(&[0u8, 1, 2, 27, 28, 39, 40]);
        let value = if param < 3 { b.range(1, 3000) } else { b.range(0, 3) };
        return Command::Sgp { param, bank: 3, value: value as i32 };
    }
    let (param, lo, hi) = b.pick(AXIS);
    Command::Sap { param, motor: 0, value: b.range(lo, hi) as i32 }
}

/// A program instruction; jumps stay within the program's `len` cells.
fn instruction(b: &mut Bytes, len: u8) -> Command {
    let address = |b: &mut Bytes| i32::from(b.u8() % len.max(1));
    match b.u8() % 22 {
        0..=3 => Command::Mvp { motor: 0, target: MoveTarget::Abs(b.range(-600_000, 600_000) as i32) },
        4 => Command::Mvp { motor: 0, target: MoveTarget::Rel(b.range(-200_000, 200_000) as i32) },
        5 => Command::Ror { motor: 0, velocity: b.range(0, 80_000) as i32 },
        6 => Command::Rol { motor: 0, velocity: b.range(0, 80_000) as i32 },
        7 => Command::Mst { motor: 0 },
        8 | 9 => {
            let condition = b.pick(&[
                WaitCondition::Ticks,
                WaitCondition::Pos,
                WaitCondition::RefSw,
                WaitCondition::LimSw,
                WaitCondition::Rfs,
            ]);
            Command::Wait { condition, motor: 0, ticks: b.range(0, 300) as i32 }
        }
        10 | 11 => setting(b),
        12 => Command::Sio { port: b.u8() % 3, bank: 2, value: i32::from(b.u8() % 2) },
        13 => Command::Calc { op: b.pick(&[CalcOp::Add, CalcOp::Sub, CalcOp::Load]), operand: b.range(-5, 5) as i32 },
        14 => Command::Comp { operand: b.range(-3, 3) as i32 },
        15 => Command::Jc {
            condition: b.pick(&[Condition::Zero, Condition::NotZero, Condition::Greater]),
            address: address(b),
        },
        16 => Command::Ja { address: address(b) },
        17 => Command::Gap { param: b.pick(&[1u8, 3, 8, 9, 10, 206, 208, 209]), motor: 0 },
        18 => Command::Vect { interrupt: b.pick(&[0u8, 1, 2, 3, 27, 28, 39]), address: address(b) },
        19 => Command::Ei { interrupt: b.pick(&[0u8, 1, 2, 3, 27, 28, 39, 255]) },
        20 => Command::Reti,
        _ => Command::Rfs { action: b.pick(&[RfsAction::Start, RfsAction::Stop]), motor: 0 },
    }
}

/// A program that never waits: a prelude (timers, vectors, interrupts, a first move, a setting), then a
/// busy loop of reads, writes, calculations, comparisons and conditional jumps within it, closed by a JA,
/// then an interrupt handler. Many such loops reach a fixed point once the axis stands (the copy loop, the
/// potentiometer loop); others change every turn (a counter, the tick timer) or only every few turns.
fn spin_program(b: &mut Bytes) -> Vec<Command> {
    const HANDLER: i32 = -1; // patched below
    let mut program = Vec::new();
    for _ in 0..b.u8() % 5 {
        program.push(match b.u8() % 6 {
            0 => Command::Sgp { param: b.u8() % 3, bank: 3, value: b.range(1, 3000) as i32 },
            1 => Command::Sgp { param: b.pick(&[27u8, 28, 39, 40]), bank: 3, value: b.range(0, 3) as i32 },
            2 => Command::Vect { interrupt: b.pick(&[0u8, 1, 2, 3, 27, 28, 39, 40]), address: HANDLER },
            3 => Command::Ei { interrupt: b.pick(&[0u8, 1, 2, 3, 27, 28, 39, 40, 255]) },
            4 => Command::Mvp { motor: 0, target: MoveTarget::Abs(b.range(-20_000, 20_000) as i32) },
            _ => setting(b),
        });
    }
    let start = program.len() as i32;
    let body = i32::from(b.u8() % 6) + 1;
    // Jumps within the loop: its first instruction up to the closing JA.
    let within = |b: &mut Bytes| start + b.range(0, i64::from(body)) as i32;
    for _ in 0..body {
        program.push(match b.u8() % 16 {
            0 | 1 => Command::Gio { port: 255, bank: 0 },
            2 => Command::Gio { port: b.u8() % 4, bank: 0 },
            3 => Command::Gio { port: 0, bank: 1 },
            4 | 5 => Command::Sio { port: 255, bank: 2, value: -1 },
            6 => Command::Sio { port: b.u8() % 2, bank: 2, value: i32::from(b.u8() % 2) },
            7 | 8 => Command::Calc {
                op: b.pick(&[CalcOp::Add, CalcOp::Sub, CalcOp::Mul, CalcOp::And, CalcOp::Or, CalcOp::Load]),
                operand: b.range(-4, 4) as i32,
            },
            9 => Command::Comp { operand: b.range(-2, 8) as i32 },
            10 => Command::Jc {
                condition: b.pick(&[Condition::Zero, Condition::NotZero, Condition::Greater, Condition::Lower]),
                address: within(b),
            },
            11 | 12 => Command::Aap { param: 0, motor: 0 },
            13 => Command::Agp { param: b.u8() % 3, bank: 2 },
            14 => Command::Ggp { param: b.u8() % 3, bank: 2 },
            _ => match b.u8() % 3 {
                0 => Command::Ggp { param: 132, bank: 0 }, // the tick timer: a new value every turn
                1 => Command::Gap { param: b.pick(&[1u8, 8, 9, 10, 206]), motor: 0 },
                _ => Command::Ja { address: within(b) },
            },
        });
    }
    program.push(Command::Ja { address: start });
    let handler = program.len() as i32;
    for _ in 0..b.u8() % 3 {
        program.push(match b.u8() % 3 {
            0 => Command::Sio { port: b.u8() % 2, bank: 2, value: i32::from(b.u8() % 2) },
            1 => Command::Calc { op: CalcOp::Add, operand: 1 },
            _ => Command::Agp { param: 2, bank: 2 },
        });
    }
    program.push(Command::Reti);
    for c in &mut program {
        if let Command::Vect { address, .. } = c {
            if *address == HANDLER {
                *address = handler;
            }
        }
    }
    program
}

/// A host command: a move, a setting, a question, an event request, the program stopped or restarted.
fn host_command(b: &mut Bytes) -> Command {
    match b.u8() % 10 {
        0 | 1 => Command::Mvp { motor: 0, target: MoveTarget::Abs(b.range(-600_000, 600_000) as i32) },
        2 => Command::Ror { motor: 0, velocity: b.range(-80_000, 80_000) as i32 },
        3 => Command::Mst { motor: 0 },
        4 => setting(b),
        5 => Command::Gap { param: b.pick(&[1u8, 3, 8, 206, 208, 209]), motor: 0 },
        6 => Command::RequestTargetReachedEvent { mode: b.pick(&[EventMode::Next, EventMode::Every]), mask: 1 },
        7 => Command::Sgp { param: 68, bank: 0, value: b.range(0, 3000) as i32 },
        8 => Command::StopApplication,
        _ => Command::RunApplication { from: None },
    }
}

//! The module: a board, a model and the firmware state, fed with bytes and time.
//!
//! [`Module::receive`] takes bytes from the host interface with the time they arrived; [`Module::poll`]
//! advances the motion controller and timers to a given time. Both send what the module has to say to a
//! [`Sink`], and `poll` returns the next instant at which the module needs to run again (the deadline), so
//! a caller can sleep until then or, in simulation, jump straight to it. The module never reads a clock.

use crate::drive::coolstep::CoolStep;
use crate::hal::{Board, DriveState};
use crate::iface::ascii::AsciiLine;
use crate::iface::{Framer, Outbox, Sink};
use crate::model::ModelSpec;
use crate::motion::reference::{Action, SwitchLevels};
use crate::motion::{Limits, Mode, Ramp, RampParams, Reference, TICK};
use crate::param::persist;
use crate::time::{Duration, Instant};
use crate::vm::run::BUDGET;
use crate::vm::{Program, RunState, Vm};
use tmcl_wire::{Command, EventMode, Frame, Opcode, Reply, Request, Status, FRAME_LEN};

/// Axis parameter slots in RAM (the PD28-1021 has 58).
pub const MAX_AXIS_PARAMS: usize = 64;
/// Bank 0 slots in RAM (19).
pub const MAX_GLOBAL_PARAMS: usize = 32;
/// Bank 3 slots in RAM (9).
pub const MAX_INTERRUPT_PARAMS: usize = 16;
/// User variables (bank 2).
pub const MAX_USER_VARIABLES: usize = 256;
/// Coordinates 0..=20.
pub const MAX_COORDINATES: usize = 21;

/// Comparison and error flags (manual §3.7.17, §3.7.18, §3.7.31).
pub mod flags {
    /// Result of the last comparison or accumulator load was zero / equal.
    pub const ZERO: u16 = 1 << 0;
    /// Greater.
    pub const GREATER: u16 = 1 << 1;
    /// Lower.
    pub const LOWER: u16 = 1 << 2;
    /// ETO: timeout.
    pub const TIMEOUT: u16 = 1 << 8;
    /// EAL: external alarm.
    pub const ALARM: u16 = 1 << 9;
    /// EDV: deviation.
    pub const DEVIATION: u16 = 1 << 10;
    /// EPO: position error.
    pub const POSITION: u16 = 1 << 11;
    /// ESD: shutdown.
    pub const SHUTDOWN: u16 = 1 << 12;
}

/// The TMCL machine's registers (manual §3.6: accumulator, X register, flags).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Registers {
    /// The accumulator.
    pub accumulator: i32,
    /// The X register.
    pub x: i32,
    /// Flags, see [`flags`].
    pub flags: u16,
}

/// AP 207 bits (Table 15): 1 = stallGuard error, 2 = deviation error.
pub mod error_flags {
    /// stallGuard2 stopped the motor.
    pub const STALL: u8 = 1;
    /// The encoder deviation check stopped the motor.
    pub const DEVIATION: u8 = 2;
}

/// Command 138's request (§3.7.39).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct EventRequest {
    /// Armed for the next MVP or every MVP; `None` = off.
    pub mode: Option<EventMode>,
    /// The motor mask to report.
    pub mask: i32,
    /// An MVP is under way whose arrival must be reported.
    pub pending: bool,
}

/// The encoder counter's reference point: AP 209 = `value` + (counts − `counts`) × prescaler.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EncoderBase {
    /// Encoder counts (logical direction) at the reference.
    pub counts: i64,
    /// AP 209 at the reference.
    pub value: i32,
}

/// Everything the firmware keeps in RAM, except program memory: fits in 4 KiB, no heap.
#[derive(Debug, Clone)]
pub struct State {
    pub(crate) axis: [i32; MAX_AXIS_PARAMS],
    pub(crate) global: [i32; MAX_GLOBAL_PARAMS],
    pub(crate) interrupt: [i32; MAX_INTERRUPT_PARAMS],
    pub(crate) user: [i32; MAX_USER_VARIABLES],
    pub(crate) coords: [i32; MAX_COORDINATES],
    pub(crate) ramp: Ramp,
    pub(crate) reference: Reference,
    /// The program's registers.
    pub(crate) regs: Registers,
    /// The host's registers (direct-mode CALC and friends), kept apart so that a host never disturbs a
    /// running program's accumulator, X register or flags (§8.5).
    pub(crate) host_regs: Registers,
    pub(crate) event: EventRequest,
    pub(crate) framer: Framer,
    pub(crate) outbox: Outbox,
    /// Time up to which motion has been simulated (tick aligned).
    pub(crate) motion_time: Instant,
    /// The latest time the module has been told.
    pub(crate) now: Instant,
    /// GP 132's reference: (time, value at that time).
    pub(crate) tick_base: (Instant, u32),
    pub(crate) rng: u32,
    /// When the last command addressed to this module arrived (GP 68 heartbeat).
    pub(crate) last_command: Instant,
    pub(crate) heartbeat_tripped: bool,
    /// Since when the motor stands still (`None` while it moves).
    pub(crate) standstill_since: Option<Instant>,
    /// The last tick changed the speed (boost current, AP 200).
    pub(crate) ramping: bool,
    pub(crate) encoder: EncoderBase,
    /// AP 207.
    pub(crate) error_flags: u8,
    /// The outputs as last set (bit n = OUTn).
    pub(crate) outputs: u8,
    /// GP 65 as it was at the last start (a new baud rate needs a restart, manual §5.1).
    pub(crate) active_baud: u8,
    /// Steps moved since the board was last updated.
    pub(crate) unreported_steps: i64,
    /// What the board was last told (with `moved` = 0), to skip updates that change nothing.
    pub(crate) last_drive: Option<DriveState>,
    /// When the driver current next changes on its own (standby, freewheeling), if it will.
    pub(crate) drive_due: Option<Instant>,
    /// The coolStep regulator (AP 168–183).
    pub(crate) coolstep: CoolStep,
    /// The board's stallGuard2 measurement count at the last look.
    pub(crate) load_measurements: u32,
    /// Encoder counts at the last look (clear-on-null).
    pub(crate) last_counts: i64,
}

impl State {
    fn new(now: Instant) -> State {
        State {
            axis: [0; MAX_AXIS_PARAMS],
            global: [0; MAX_GLOBAL_PARAMS],
            interrupt: [0; MAX_INTERRUPT_PARAMS],
            user: [0; MAX_USER_VARIABLES],
            coords: [0; MAX_COORDINATES],
            ramp: Ramp::default(),
            reference: Reference::Idle,
            regs: Registers::default(),
            host_regs: Registers::default(),
            event: EventRequest::default(),
            framer: Framer::new(),
            outbox: Outbox::new(),
            motion_time: now,
            now,
            tick_base: (now, 0),
            rng: RNG_SEED,
            last_command: now,
            heartbeat_tripped: false,
            standstill_since: Some(now),
            ramping: false,
            encoder: EncoderBase::default(),
            error_flags: 0,
            outputs: 0,
            active_baud: 0,
            unreported_steps: 0,
            last_drive: None,
            drive_due: None,
            coolstep: CoolStep::new(),
            load_measurements: 0,
            last_counts: 0,
        }
    }
}

/// GP 133's generator starts from this seed at every start (a write to GP 133 reseeds it).
const RNG_SEED: u32 = 0x2545_F491;

/// Who sent a command: the host (direct mode) or the stored program (standalone mode, §3.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// Direct mode: a frame from the host.
    Host,
    /// Standalone mode: an instruction of the running program.
    Program,
}

/// What executing one command produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// A normal reply with this value.
    Value(i32),
    /// A special reply (136 type 0).
    Raw([u8; FRAME_LEN]),
    /// No reply (137, 242).
    Silent,
    /// Reply with this value, then restart as after a power cycle (255).
    Restart(i32),
    /// Reply, then switch to ASCII mode (139).
    EnterAscii,
}

/// A TMCL module: firmware state on a board.
pub struct Module<B: Board> {
    pub(crate) board: B,
    pub(crate) spec: &'static ModelSpec,
    pub(crate) st: State,
    pub(crate) vm: Vm,
    pub(crate) program: Program,
    pub(crate) ascii: AsciiLine,
}

impl<B: Board> Module<B> {
    /// Powers the module up at `now`: loads the configuration from the board's EEPROM, formatting it with
    /// factory defaults if it holds no valid image for this model.
    pub fn new(board: B, spec: &'static ModelSpec, now: Instant) -> Module<B> {
        let mut module = Module {
            board,
            spec,
            st: State::new(now),
            vm: Vm::default(),
            program: Program::default(),
            ascii: AsciiLine::default(),
        };
        module.start(now);
        module
    }

    /// The model.
    pub fn spec(&self) -> &'static ModelSpec {
        self.spec
    }

    /// The board.
    pub fn board(&self) -> &B {
        &self.board
    }

    /// The board, mutably (the simulator changes its world through this).
    pub fn board_mut(&mut self) -> &mut B {
        &mut self.board
    }

    /// The firmware's RAM state.
    pub fn state(&self) -> &State {
        &self.st
    }

    /// The program's registers.
    pub fn registers(&self) -> Registers {
        self.st.regs
    }

    /// The host's registers (direct-mode calculations).
    pub fn host_registers(&self) -> Registers {
        self.st.host_regs
    }

    /// The ramp generator (positions, velocity).
    pub fn ramp(&self) -> &Ramp {
        &self.st.ramp
    }

    /// The module (primary) address, GP 66.
    pub fn address(&self) -> u8 {
        self.global_value(66) as u8
    }

    /// The baud-rate index (GP 65) in force since the last start.
    pub fn active_baud(&self) -> u8 {
        self.st.active_baud
    }

    /// Start-up, as after a power cycle (manual §3.7.38 command 255, chapter 8 "power-up restores").
    pub(crate) fn start(&mut self, now: Instant) {
        let spec = self.spec;
        if !persist::is_formatted(&mut self.board, spec) {
            // A fresh or foreign EEPROM: factory image. If even that fails, run on defaults in RAM.
            let _ = persist::format(&mut self.board, spec, true);
        }
        let outbox = self.st.outbox.clone();
        let counts = self.board.feedback().encoder_counts;
        self.st = State::new(now);
        self.st.outbox = outbox;
        for (i, d) in spec.axis.params.iter().enumerate() {
            self.st.axis[i] = d.default;
            if d.access.persistent() {
                if let Ok(v) = persist::load_axis(&mut self.board, spec, i) {
                    self.st.axis[i] = if d.range.contains(v) { v } else { d.default };
                }
            }
        }
        for (i, d) in spec.global.params.iter().enumerate() {
            self.st.global[i] = d.default;
            if d.access.persistent() {
                if let Ok(v) = persist::load_global(&mut self.board, spec, i) {
                    self.st.global[i] = if d.range.contains(v) { v } else { d.default };
                }
            }
        }
        for (i, d) in spec.interrupt.params.iter().enumerate() {
            self.st.interrupt[i] = d.default;
        }
        // §5.3 / §8.4: user variables are restored unless GP 85 = 1.
        if self.global_value(85) == 0 {
            for n in 0..spec.stored_user_variables.min(MAX_USER_VARIABLES as u16) as u8 {
                self.st.user[usize::from(n)] = persist::load_user(&mut self.board, spec, n).unwrap_or(0);
            }
        }
        // §3.7.24: with GP 84 = 1 the coordinates are copied back at start-up.
        if self.global_value(84) == 1 {
            for n in 1..=spec.coordinates {
                self.st.coords[usize::from(n)] = persist::load_coordinate(&mut self.board, spec, n).unwrap_or(0);
            }
        }
        self.st.active_baud = self.global_value(65) as u8;
        self.st.encoder = EncoderBase { counts: self.logical_counts(counts), value: 0 };
        self.st.last_counts = self.st.encoder.counts;
        self.configure_driver();
        self.board.set_outputs(0);
        self.update_board(now);
        self.vm = Vm::default();
        self.vm.time = now;
        self.read_program();
        self.auto_start(now);
        // §3.4.4: GP 67 bit 0 = start up in ASCII mode.
        self.ascii = AsciiLine::default();
        if self.global_value(67) & 1 == 1 {
            self.enter_ascii();
        }
    }

    /// Feeds bytes that arrived at `now`. Complete frames are executed; replies go to `sink` (at once, or
    /// after the telegram pause GP 75).
    pub fn receive(&mut self, now: Instant, bytes: &[u8], sink: &mut impl Sink) {
        self.advance(now, sink);
        let mut rest = bytes;
        while let Some((&b, tail)) = rest.split_first() {
            if self.ascii.active {
                self.ascii_byte(b, now);
                rest = tail;
                continue;
            }
            // A whole frame at once (the usual case: hosts write 9 bytes in one go) skips the byte-wise
            // framer; it is exactly what pushing its bytes one by one at `now` would give.
            let frame = match rest.first_chunk::<FRAME_LEN>() {
                Some(whole) if self.st.framer.pending() == 0 => {
                    rest = &rest[FRAME_LEN..];
                    self.st.framer.touch(now);
                    Some(*whole)
                }
                _ => {
                    rest = tail;
                    self.st.framer.push(b, now)
                }
            };
            if let Some(frame) = frame {
                self.handle_frame(frame, now);
                // Reads change nothing the driver sees; anything else may (currents, direction, ...).
                let read = matches!(
                    Opcode::from(frame[1]),
                    Opcode::Gap | Opcode::Ggp | Opcode::Gio | Opcode::Gco | Opcode::GetVersion
                );
                if !read {
                    self.update_board(now);
                }
            }
        }
        self.st.outbox.flush(now, sink);
    }

    /// Drops a partial frame: the link was interrupted (a new TCP connection, a host that went away), so
    /// bytes from before cannot belong to the next request.
    pub fn reset_link(&mut self) {
        self.st.framer.clear();
    }

    /// Advances the module to `now` and returns when it next needs to run: the next motion tick while the
    /// motor moves, else the next timer (standby current, freewheeling, heartbeat, a delayed reply), or
    /// `None` when nothing will happen until the next command.
    pub fn poll(&mut self, now: Instant, sink: &mut impl Sink) -> Option<Instant> {
        self.advance(now, sink);
        self.next_deadline()
    }

    /// Executes one instruction as if a host had sent it at `now`, without the framing: for tests and
    /// tools. Returns the reply's status and value.
    pub fn execute_instruction(
        &mut self,
        now: Instant,
        instruction: tmcl_wire::Instruction,
    ) -> Result<Outcome, Status> {
        self.advance(now, &mut |_: &[u8]| {});
        let result = Command::decode(instruction).and_then(|c| self.execute(c, now));
        match result {
            Ok(Outcome::Restart(_)) | Ok(Outcome::Silent)
                if matches!(instruction.opcode, Opcode::SoftwareReset | Opcode::FactoryDefault) =>
            {
                self.start(now)
            }
            Ok(Outcome::EnterAscii) => self.enter_ascii(),
            _ => {}
        }
        self.update_board(now);
        result
    }

    fn handle_frame(&mut self, bytes: [u8; FRAME_LEN], now: Instant) {
        let frame = Frame::new_unchecked(&bytes[..]);
        let address = frame.address();
        let secondary = self.global_value(87) as u8;
        // §3.1 / §5.1 GP 66, GP 87: frames for other addresses get no reply at all.
        if address != self.address() && (secondary == 0 || address != secondary) {
            return;
        }
        self.st.last_command = now;
        self.st.heartbeat_tripped = false;
        let (opcode, reply) = match Request::parse(&frame) {
            // §3.2.1 status 1; the reply carries opcode 0 and value 0, as Trinamic's TMCL code does.
            Err(_) => (frame.opcode(), Ok((Status::WrongChecksum, 0, 0u8))),
            Ok(request) if self.vm.download.is_some() && !request.instruction.opcode.is_control() => {
                // §3.7.38 132: in download mode every command but the control commands is stored.
                let i = request.instruction;
                let op = u8::from(i.opcode);
                match self.download(i) {
                    Ok(()) => (op, Ok((Status::Loaded, i.value, op))),
                    Err(status) => (op, Ok((status, i.value, op))),
                }
            }
            Ok(request) => {
                let i = request.instruction;
                let op = u8::from(i.opcode);
                match Command::decode(i).and_then(|c| self.execute(c, now)) {
                    Ok(Outcome::Value(v)) => (op, Ok((Status::Ok, v, op))),
                    Ok(Outcome::Raw(raw)) => (op, Err(raw)),
                    Ok(Outcome::Silent) => {
                        if i.opcode == Opcode::FactoryDefault {
                            self.start(now);
                        }
                        return;
                    }
                    Ok(Outcome::Restart(v)) => {
                        self.queue_reply(op, Ok((Status::Ok, v, op)), now);
                        self.start(now);
                        return;
                    }
                    Ok(Outcome::EnterAscii) => {
                        self.queue_reply(op, Ok((Status::Ok, 0, op)), now);
                        self.enter_ascii();
                        return;
                    }
                    Err(status) => (op, Ok((status, i.value, op))),
                }
            }
        };
        self.queue_reply(opcode, reply, now);
    }

    fn queue_reply(&mut self, opcode: u8, reply: Result<(Status, i32, u8), [u8; FRAME_LEN]>, now: Instant) {
        // §5.1 GP 255: replies are suppressed, except for GAP, GGP and GIO.
        let exempt = matches!(Opcode::from(opcode), Opcode::Gap | Opcode::Ggp | Opcode::Gio);
        if self.global_value(255) == 1 && !exempt {
            return;
        }
        let bytes = match reply {
            Ok((status, value, op)) => self.reply_bytes(status, op, value),
            Err(raw) => raw,
        };
        // §5.1 GP 75: the telegram pause before a reply (milliseconds, inventory AMB-17).
        let pause = Duration::from_millis(self.global_value(75).max(0) as u64);
        self.st.outbox.push(&bytes, now + pause);
    }

    pub(crate) fn reply_bytes(&self, status: Status, opcode: u8, value: i32) -> [u8; FRAME_LEN] {
        Reply { host: self.global_value(76) as u8, module: self.address(), status, opcode, value }.to_bytes()
    }

    /// Reads a bank 0 parameter's RAM value by number (0 if the model has no such parameter).
    pub(crate) fn global_value(&self, number: u8) -> i32 {
        self.spec.global.find(number).map(|(i, _)| self.st.global[i]).unwrap_or(0)
    }

    /// Reads an axis parameter's RAM value by number (0 if the model has no such parameter).
    pub(crate) fn axis_value(&self, number: u8) -> i32 {
        self.spec.axis.find(number).map(|(i, _)| self.st.axis[i]).unwrap_or(0)
    }

    fn ramp_params(&self) -> RampParams {
        RampParams { max_speed: self.axis_value(4), max_accel: self.axis_value(5), min_speed: self.axis_value(130) }
    }

    /// Logical switch states (AP 9, 10, 11): GP 79 reverses the polarity of the end switches.
    pub(crate) fn switches(&mut self) -> (bool, bool, bool) {
        let s = self.board.switches();
        let invert = self.global_value(79) == 1;
        (s.left ^ invert, s.right ^ invert, s.home)
    }

    fn limits(&mut self) -> Limits {
        if self.st.reference.is_active() {
            // The reference search handles the switches itself (§7.1: AP 12/13 do not affect it).
            return Limits::default();
        }
        let (left, right, _) = self.switches();
        Limits { block_negative: left && self.axis_value(13) == 0, block_positive: right && self.axis_value(12) == 0 }
    }

    /// Encoder counts in the logical direction (GP 90 reverses motor and encoder, manual §5.1).
    pub(crate) fn logical_counts(&self, physical: i64) -> i64 {
        if self.global_value(90) == 1 {
            -physical
        } else {
            physical
        }
    }

    /// The current setting now (AP 6, 7, 200, 204, 214, 167) and whether the driver is on.
    #[inline]
    pub(crate) fn current(&self, now: Instant) -> (u8, bool) {
        if self.axis_value(167) == 0 {
            return (0, false); // AP 167 = 0 "completely disables all driver transistors"
        }
        match self.st.standstill_since {
            None => {
                let run = self.run_current();
                (self.regulated_current(run), true)
            }
            Some(since) => {
                let still = now - since;
                let freewheel = self.axis_value(204);
                if freewheel != 0 && still >= Duration::from_millis(freewheel as u64 * 10) {
                    (0, false)
                } else if still >= Duration::from_millis(self.axis_value(214) as u64 * 10) {
                    (self.axis_value(7) as u8, true)
                } else {
                    (self.axis_value(6) as u8, true)
                }
            }
        }
    }

    /// The current for a moving motor before coolStep: the boost current AP 200 while the speed changes
    /// (if not 0), else the run current AP 6 (Table 22). AP 200 is not looked up while cruising.
    #[inline]
    pub(crate) fn run_current(&self) -> i32 {
        let boost = if self.st.ramping { self.axis_value(200) } else { 0 };
        if boost != 0 {
            boost
        } else {
            self.axis_value(6)
        }
    }

    fn update_board(&mut self, now: Instant) {
        let (current, enabled) = self.current(now);
        let state = DriveState {
            moved: self.st.unreported_steps,
            position: self.st.ramp.position,
            velocity: self.st.ramp.velocity(),
            resolution: self.axis_value(140) as u8,
            current,
            enabled,
            reverse: self.global_value(90) == 1,
        };
        self.st.drive_due = self.st.standstill_since.and_then(|since| {
            [self.axis_value(214), self.axis_value(204)]
                .into_iter()
                .filter(|d| *d > 0)
                .map(|d| since + Duration::from_millis(d as u64 * 10))
                .filter(|t| *t > now)
                .min()
        });
        let unchanged = DriveState { moved: 0, ..state };
        if state.moved == 0 && self.st.last_drive == Some(unchanged) {
            return;
        }
        self.st.unreported_steps = 0;
        self.st.last_drive = Some(unchanged);
        self.board.update(now, &state);
    }

    /// Runs the motion controller and timers up to `now`.
    fn advance(&mut self, now: Instant, sink: &mut impl Sink) {
        if now < self.st.now {
            // Time never runs backwards for the module; a caller's late timestamp is taken as "now".
            self.st.outbox.flush(self.st.now, sink);
            return;
        }
        self.st.now = now;
        // The ramp parameters in force for this call's ticks, read at its start. When no tick is due
        // (a frame between two ticks), none runs in this call: the loop's first pass takes `tick_at`
        // before the program runs and breaks on it. So the three lookups are skipped and the placeholder
        // is never used.
        let params = if self.st.motion_time + TICK <= now {
            self.ramp_params()
        } else {
            RampParams { max_speed: 0, max_accel: 0, min_speed: 0 }
        };
        let mut ticked = false;
        let mut budget = BUDGET;
        // Instructions up to and including `now`.
        let horizon = now + Duration::from_micros(1);
        loop {
            let tick_at = self.st.motion_time + TICK;
            if self.vm.state == RunState::Running {
                self.run_program(tick_at.min(horizon), &mut budget);
                if budget == 0 {
                    break; // the rest at the next poll (its deadline is now)
                }
            }
            if tick_at > now {
                break;
            }
            if self.st.ramp.is_idle() && !self.st.reference.is_active() && !self.needs_every_tick() {
                // A stop outside the ramp (a stall, a deviation, the end of a reference search) leaves
                // the motor standing: the standby and freewheeling delays run from the last tick.
                if self.st.standstill_since.is_none() {
                    self.st.standstill_since = Some(self.st.motion_time);
                    ticked = true; // the board hears of it (and of the standby timer) below
                }
                // Nothing moves: jump to the last tick boundary before the next timed event (or `now`).
                let until =
                    [self.program_deadline(), self.timer_deadline()].into_iter().flatten().fold(now, Instant::min);
                if until >= tick_at {
                    let ticks = (until - self.st.motion_time).micros() / TICK.micros();
                    self.st.motion_time += Duration::from_micros(ticks * TICK.micros());
                    self.st.ramping = false;
                    if self.vm.enabled != 0 {
                        self.sample_interrupts(self.st.motion_time);
                    }
                    continue;
                }
            }
            ticked = true;
            // A reference search looks at its switch after every microstep (sub-ticks), so that the
            // switching points, and with them the zero point, are exact to the microstep (§7.1).
            let parts = if self.st.reference.is_active() {
                (u64::from(self.st.ramp.velocity().unsigned_abs()) / 1000 + 1).min(TICK.micros())
            } else {
                1
            };
            // (Most ticks are one part: no 64-bit division for them.)
            let step = if parts == 1 { TICK.micros() } else { TICK.micros() / parts };
            for k in 1..=parts {
                let t = if k == parts { tick_at } else { self.st.motion_time + Duration::from_micros(step * k) };
                let dt = if k == parts { TICK.micros() - step * (parts - 1) } else { step };
                let limits = self.limits();
                let r = self.st.ramp.tick(Duration::from_micros(dt), &params, limits);
                self.st.ramping = r.ramping;
                self.st.unreported_steps += r.steps;
                let moving = self.st.ramp.velocity() != 0;
                match (moving, self.st.standstill_since) {
                    (true, Some(_)) => self.st.standstill_since = None,
                    (false, None) => self.st.standstill_since = Some(t),
                    _ => {}
                }
                self.update_board(t);
                if self.st.reference.is_active() {
                    self.step_reference();
                }
            }
            self.st.motion_time = tick_at;
            let t = tick_at;
            self.drive_tick();
            self.check_event(t);
            if self.vm.enabled != 0 {
                self.sample_interrupts(t);
            }
        }
        self.check_event(now);
        self.check_heartbeat(now);
        if ticked || self.st.drive_due.is_some_and(|t| t <= now) {
            self.update_board(now);
        }
        self.st.outbox.flush(now, sink);
    }

    /// Whether interrupts that watch switches or inputs are enabled: then every tick is sampled.
    fn needs_every_tick(&self) -> bool {
        const WATCHED: u64 = 1 << 27 | 1 << 28 | 0xF << 39;
        self.vm.enabled & WATCHED != 0
    }

    /// One step of the reference search after a motion tick (§7.1).
    fn step_reference(&mut self) {
        let (left, right, home) = self.switches();
        let levels = SwitchLevels { left, right, home };
        let (fast, slow) = (self.axis_value(194), self.axis_value(195));
        let position = self.st.ramp.position;
        match self.st.reference.step(levels, position, fast, slow) {
            Action::Continue => {}
            Action::Rotate(v) => {
                self.st.ramp.hard_stop();
                self.st.ramp.rotate(v);
            }
            Action::Done { zero, far_distance } => {
                self.st.ramp.hard_stop();
                // AP 197: "position value just before the counter is zeroed"; AP 196: end switch distance.
                self.set_axis_raw(197, position);
                if let Some(d) = far_distance {
                    self.set_axis_raw(196, d);
                }
                self.st.ramp.mode = Mode::Position;
                self.st.ramp.set_position(position.wrapping_sub(zero));
                self.st.ramp.target_position = self.st.ramp.position;
            }
            Action::Failed => self.st.ramp.hard_stop(),
        }
    }

    /// Sets a parameter's RAM slot directly (results the firmware produces, e.g. AP 196/197).
    pub(crate) fn set_axis_raw(&mut self, number: u8, v: i32) {
        if let Ok((i, _)) = self.spec.axis.find(number) {
            self.st.axis[i] = v;
        }
    }

    /// §3.7.39: the second reply of command 138 when an MVP's target is reached.
    fn check_event(&mut self, now: Instant) {
        let ramp = &self.st.ramp;
        if self.st.event.pending && ramp.mode == Mode::Position && ramp.is_idle() {
            self.st.event.pending = false;
            let bytes =
                self.reply_bytes(Status::TargetReached, Opcode::RequestTargetReachedEvent.into(), self.st.event.mask);
            self.st.outbox.push(&bytes, now);
        }
    }

    /// §5.1 GP 68: stop the motor when no command arrived within the heartbeat time (milliseconds,
    /// inventory AMB-17).
    fn check_heartbeat(&mut self, now: Instant) {
        let limit = self.global_value(68);
        if limit > 0 && !self.st.heartbeat_tripped && now - self.st.last_command > Duration::from_millis(limit as u64) {
            self.st.heartbeat_tripped = true;
            self.st.ramp.rotate(0);
            self.st.event.pending = false;
        }
    }

    fn next_deadline(&self) -> Option<Instant> {
        let mut next: Option<Instant> = self.st.outbox.next_due();
        let mut consider = |t: Instant| next = Some(next.map_or(t, |n| n.min(t)));
        if !self.st.ramp.is_idle() || self.st.event.pending || self.st.reference.is_active() || self.needs_every_tick()
        {
            consider(self.st.motion_time + TICK);
        }
        for t in [self.program_deadline(), self.timer_deadline()].into_iter().flatten() {
            consider(t.max(self.st.now));
        }
        if let Some(since) = self.st.standstill_since {
            for delay in [self.axis_value(214), self.axis_value(204)] {
                let t = since + Duration::from_millis(delay.max(0) as u64 * 10);
                if delay > 0 && t > self.st.now {
                    consider(t);
                }
            }
        }
        let heartbeat = self.global_value(68);
        if heartbeat > 0 && !self.st.heartbeat_tripped {
            consider(self.st.last_command + Duration::from_millis(heartbeat as u64 + 1));
        }
        next
    }
}

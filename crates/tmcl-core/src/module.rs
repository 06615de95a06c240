//! The module: a board, a model and the firmware state, fed with bytes and time (the entry points for
//! bytes and time are in `module/host.rs`).
//!
//! [`Module::receive_on`] takes bytes from one of the model's host interfaces with the time they arrived
//! ([`Module::receive`] is the primary interface), [`Module::request`] takes a whole mailbox message;
//! [`Module::poll`] advances the motion controller and timers to a given time. What the module has to say
//! goes back to the interface that asked, through a [`crate::iface::Sink`], and `poll` returns the next instant at
//! which the module needs to run again (the deadline), so a caller can sleep until then or, in
//! simulation, jump straight to it. The module never reads a clock.
//!
//! # Settings a model may lack
//!
//! The firmware reads its settings by meaning ([`Setting`]), never by number; a model without a setting
//! lacks the feature, and this is what that means (PD28-1021 numbers for orientation):
//! - no serial address (GP 66): the module is module 1, the factory address; no host address (GP 76):
//!   replies go to host 2 (manual §3.2's examples); no secondary address (GP 87), heartbeat (GP 68),
//!   telegram pause (GP 75) or reply suppression (GP 255): none of them;
//! - no run current (AP 6): full current; no standby current or power-down delay (AP 7, 214): the motor
//!   keeps its run current at standstill; no freewheeling delay (AP 204) or chopper off time (AP 167):
//!   the driver is never switched off; no boost current (AP 200): none;
//! - no start/stop speed (AP 130): ramps start and stop at 0; no switch disables (AP 12, 13): the stop
//!   switches always stop; no end switch polarity (GP 79) or reverse shaft (GP 90): normal ones;
//! - no coolStep, stall or deviation settings: no coolStep, no stop on stall, no deviation check;
//! - no ASCII mode (GP 67): binary at start-up, echo of each character; no auto start (GP 77), code
//!   protection (GP 81), coordinate storage (GP 84): none; no "do not restore" (GP 85): user variables
//!   are always restored.

use crate::axis::Axes;
use crate::drive::closed_loop::ClosedLoop;
use crate::hal::prelude::*;
use crate::hal::Board;
use crate::iface::Port;
use crate::model::{ModelSpec, Setting};
use crate::motion::{Ramp, RampParams};
use crate::param::banks::Banks;
use crate::param::persist;
use crate::time::{Duration, Instant};
use crate::vm::{Program, Vm};
use tmcl_model::capacity::MAX_INTERFACES;
use tmcl_wire::{EventMode, Status, FRAME_LEN};

pub use crate::axis::{Axis, EncoderBase};
use crate::axis::{Faults, Motor};
pub use crate::drive::error_flags;
pub use crate::iface::MAILBOX_LEN;
pub use crate::vm::{flags, Registers};

mod advance;
mod ascii;
mod coordinated;
mod exec;
mod host;
#[cfg(feature = "loop-periods")]
mod loop_span;
mod params;
mod pass;
#[cfg(feature = "loop-periods")]
mod periods;
mod program;
mod sac;

mod spans;

use crate::seam::Seam;

/// Command 138's request (§3.7.37).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct EventRequest {
    /// Armed for the next MVP or every MVP; `None` = off.
    pub mode: Option<EventMode>,
    /// The motor mask to report.
    pub mask: i32,
    /// An MVP is under way whose arrival must be reported.
    pub pending: bool,
    /// The interface that asked: the event goes back there.
    pub port: u8,
}

impl EventRequest {
    /// Command 138 (PD28-1021 manual §3.7.37) from the interface `port`, on a model with `motors` motors:
    /// type 0 arms the next MVP's event, type 1 every MVP's, for the motors of `mask`. Mask 0 cancels (our
    /// decision: the manual gives no way to turn type 1 off); a motor the model lacks is status 4. The
    /// reply carries the mask.
    pub(crate) fn request(&mut self, motors: u8, port: u8, mode: EventMode, mask: i32) -> Result<i32, Status> {
        let all = (1i32 << motors) - 1;
        if mask & !all != 0 {
            return Err(Status::InvalidValue);
        }
        self.mode = (mask != 0).then_some(mode);
        self.mask = mask;
        self.port = port;
        if mask == 0 {
            self.pending = false;
        }
        Ok(mask)
    }
}

/// Everything the firmware keeps in RAM, except program memory and the program machine: no heap.
#[derive(Debug, Clone)]
pub struct State {
    /// The motors, one [`Axis`] each (`crate::axis`).
    pub(crate) axes: Axes,
    /// The global banks: bank 0 settings, user variables, interrupt configuration (`crate::param::banks`).
    pub(crate) banks: Banks,
    /// The program's registers.
    pub(crate) regs: Registers,
    /// The host's registers (direct-mode CALC and friends), kept apart so that a host never disturbs a
    /// running program's accumulator, X register or flags (§8.5).
    pub(crate) host_regs: Registers,
    pub(crate) event: EventRequest,
    /// Per host interface: framer, outbox, ASCII line; then the extra host links (`host-links`).
    pub(crate) ports: [Port; crate::iface::PORTS],
    /// The interface whose command runs (a 138 event goes back there).
    pub(crate) asking_port: u8,
    /// Time up to which motion has been simulated (tick aligned; one clock for every motor).
    pub(crate) motion_time: Instant,
    /// The latest time the module has been told.
    pub(crate) now: Instant,
    /// When the last command addressed to this module arrived (GP 68 heartbeat).
    pub(crate) last_command: Instant,
    pub(crate) heartbeat_tripped: bool,
    /// The outputs as last set (bit n = OUTn).
    pub(crate) outputs: u8,
    /// GP 65 as it was at the last start (a new baud rate needs a restart, manual §5.1).
    pub(crate) active_baud: u8,
    /// The TMC428 registers SAC reaches that no firmware state stands behind (TMC428-generation models).
    pub(crate) tmc428: crate::drive::tmc428::Tmc428Regs,
}

impl State {
    fn new(spec: &ModelSpec, now: Instant) -> State {
        State {
            axes: Axes::new(spec.motors, now),
            banks: Banks::new(spec, now),
            regs: Registers::default(),
            host_regs: Registers::default(),
            event: EventRequest::default(),
            ports: Default::default(),
            asking_port: 0,
            motion_time: now,
            now,
            last_command: now,
            heartbeat_tripped: false,
            outputs: 0,
            active_baud: 0,
            tmc428: Default::default(),
        }
    }

    /// The motors.
    pub fn axes(&self) -> &Axes {
        &self.axes
    }

    /// The closed loop's state of motor 0 (closed-loop models).
    pub fn closed_loop(&self) -> &ClosedLoop {
        &self.axes[0].cl
    }

    /// The state of host interface `port` (framer, outbox, ASCII line), if the core has it.
    pub fn port(&self, port: usize) -> Option<&Port> {
        self.ports.get(port)
    }
}

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
    /// A special reply (136 type 0, 134).
    Raw([u8; FRAME_LEN]),
    /// No reply (137, 242).
    Silent,
    /// Reply with this value, then restart as after a power cycle (255).
    Restart(i32),
    /// Reply, then switch to ASCII mode (139).
    EnterAscii,
}

/// A reply to queue: a normal one (status, value, command) or a raw special one.
pub(crate) type ReplyOf = Result<(Status, i32, u8), [u8; FRAME_LEN]>;

/// A TMCL module: firmware state on a board.
pub struct Module<B: Board> {
    /// The board, behind the seam that counts every change (`seam.rs`).
    pub(crate) board: Seam<B>,
    pub(crate) spec: &'static ModelSpec,
    pub(crate) st: State,
    pub(crate) vm: Vm,
    pub(crate) program: Program,
    /// Tick the motion controller one by one (the reference), no spans (see `module/advance.rs`).
    pub(crate) exact: bool,
    /// The spans computed last (see `module/spans.rs`).
    pub(crate) memos: spans::Memos,
    /// A closed loop turning at a steady speed, looked at period by period (`module/periods.rs`).
    #[cfg(feature = "loop-periods")]
    pub(crate) periods: periods::Periods,
    /// Within a poll's advance: a jump back of the program is reported to the board's hook
    /// (`hal::Hook::jumped_back`); in a single step (command 130) it is not.
    pub(crate) advancing: bool,
    /// The earliest instant at which something changes by itself (a standby or freewheeling delay, the
    /// heartbeat, an enabled timer) that a state of the running program named since the board's hook last
    /// copied the whole state (`module/pass.rs`): a turn of a loop passes through states its pass does not
    /// show (a loop that sets AP 204 to 1 and back to 12 names the freewheeling delay of 1 only in between).
    pub(crate) named: Option<Instant>,
    /// The gap after which a partial binary frame is dropped (`None`: never), see
    /// [`Module::set_inter_byte_timeout`].
    pub(crate) inter_byte_timeout: Option<Duration>,
}

impl<B: Board> Module<B> {
    /// Powers the module up at `now`: loads the configuration from the board's EEPROM, formatting it with
    /// factory defaults if it holds no valid image for this model. The model was checked against the
    /// core's capacities when it was compiled ([`ModelSpec::new`]).
    pub fn new(board: B, spec: &'static ModelSpec, now: Instant) -> Module<B> {
        let mut module = Module::unpowered(board, spec, now);
        module.power_up(now);
        module
    }

    /// [`Module::new`] in two steps, for a caller that has to build the module where it will live: a
    /// microcontroller port, whose RAM holds one module but not the temporary copies that returning a
    /// powered-up module by value takes. This is the module before power-up, with empty RAM tables; it
    /// must be given [`Module::power_up`] before anything else.
    pub fn unpowered(board: B, spec: &'static ModelSpec, now: Instant) -> Module<B> {
        Module {
            board: Seam::new(board),
            spec,
            st: State::new(spec, now),
            vm: Vm::default(),
            program: Program::default(),
            exact: false,
            memos: Default::default(),
            #[cfg(feature = "loop-periods")]
            periods: Default::default(),
            advancing: false,
            named: None,
            inter_byte_timeout: Some(crate::iface::INTER_BYTE_TIMEOUT),
        }
    }

    /// Powers an [`Module::unpowered`] module up at `now`, as [`Module::new`] does.
    pub fn power_up(&mut self, now: Instant) {
        self.board.input();
        self.start(now);
    }

    /// The model.
    pub fn spec(&self) -> &'static ModelSpec {
        self.spec
    }

    /// The board.
    pub fn board(&self) -> &B {
        self.board.get()
    }

    /// The board, mutably (the simulator changes its world, or its hook's breakpoints, through this).
    /// The module takes it that the board may have changed in any way: it counts as a change
    /// (`seam.rs`); to move the board's world on along its own timeline, or to read it, use
    /// [`Module::board_timeline`].
    pub fn board_mut(&mut self) -> &mut B {
        self.board.changed()
    }

    /// The board, mutably, only to move its world on along its own timeline — the changes the board
    /// announces as the end of its quiet windows ([`crate::hal::StepDriver::quiet`]), as a simulator does
    /// at its polls — or to take readings. Any other change goes through [`Module::board_mut`].
    pub fn board_timeline(&mut self) -> &mut B {
        self.board.timeline()
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

    /// Motor 0's error flags AP 207 reads (see [`error_flags`]), without clearing them as a GAP 207 does:
    /// for an observer that must not take them from the host (the EtherCAT process data). Another motor's:
    /// [`Axis::error_flags`] of [`Module::axis`].
    pub fn error_flags(&self) -> u8 {
        self.st.axes[0].error_flags
    }

    /// Motor 0's ramp generator (positions, velocity); another motor's: [`Axis::ramp`] of [`Module::axis`].
    pub fn ramp(&self) -> &Ramp {
        &self.st.axes[0].ramp
    }

    /// Motor `m`'s state, if the model has motor `m`.
    pub fn axis(&self, m: usize) -> Option<&Axis> {
        self.st.axes.get(m)
    }

    /// How many motors the module drives (the model's, 1 to [`tmcl_model::capacity::MAX_MOTORS`]).
    pub fn motors(&self) -> usize {
        self.st.axes.count()
    }

    /// The module (primary) address: GP 66, or 1 for a model without one.
    #[inline]
    pub fn address(&self) -> u8 {
        self.st.banks.ready().address
    }

    /// Sets the module (primary) address by its meaning, the model's serial address setting (GP 66 on the
    /// PD28-1021, §5.1), as SGP of it would: stored in the EEPROM at once, in force for the next frame. A
    /// model without one is always module 1: 1 is accepted, another address is status 6 (not available);
    /// an address outside the setting's range is status 4.
    pub fn set_address(&mut self, address: u8, now: Instant) -> Result<(), Status> {
        let Some(i) = self.spec.global.setting(Setting::SerialAddress) else {
            return if address == 1 { Ok(()) } else { Err(Status::NotAvailable) };
        };
        let number = self.spec.global.params[i].number;
        self.set_global(number, 0, i32::from(address), now)
    }

    /// The host address replies go to: GP 76, or 2 for a model without one (manual §3.2's examples).
    #[inline]
    pub(crate) fn host_address(&self) -> u8 {
        self.st.banks.ready().host
    }

    /// The baud-rate index (GP 65) in force since the last start (0 for a model without one).
    pub fn active_baud(&self) -> u8 {
        self.st.active_baud
    }

    /// The value of the axis parameter with `setting`, if the model has one.
    #[inline]
    pub(crate) fn ap(&self, m: usize, setting: Setting) -> Option<i32> {
        self.st.axes[m].ap(&self.spec.axis, setting)
    }

    /// The value of the bank 0 parameter with `setting`, if the model has one.
    #[inline]
    pub(crate) fn gp(&self, setting: Setting) -> Option<i32> {
        self.st.banks.gp(self.spec, setting)
    }

    /// Whether the bank 0 flag with `setting` is set (a model without it: not set).
    #[inline]
    pub(crate) fn gp_flag(&self, setting: Setting) -> bool {
        self.st.banks.flag(self.spec, setting)
    }

    /// A velocity in the model's unit as microsteps per second (the ramp's unit; [`Axis::units_to_pps`]).
    #[inline]
    pub(crate) fn units_to_pps(&self, m: usize, v: i32) -> i32 {
        self.st.axes[m].units_to_pps(self.spec, v)
    }

    /// Start-up, as after a power cycle (manual §3.7.38 command 255, chapter 8 "power-up restores").
    pub(crate) fn start(&mut self, now: Instant) {
        let spec = self.spec;
        if !persist::is_formatted(&mut self.board, spec) {
            // A fresh or foreign EEPROM: factory image. If even that fails, run on defaults in RAM.
            let _ = persist::format(&mut self.board, spec, true);
        }
        // Replies already queued (the reply of 255 itself) still go out.
        let outboxes = self.st.ports.each_mut().map(|p| core::mem::take(&mut p.outbox));
        self.st = State::new(spec, now);
        for (port, outbox) in self.st.ports.iter_mut().zip(outboxes) {
            port.outbox = outbox;
        }
        for m in 0..self.st.axes.count() {
            let axis = &mut self.st.axes[m];
            axis.ramp.set_position_bits(spec.kinematics.position_bits());
            for (i, d) in spec.axis.params.iter().enumerate() {
                axis.params[i] = d.default;
                if d.access.persistent() {
                    if let Ok(v) = persist::load_axis(&mut self.board, spec, m, i) {
                        axis.params[i] = if d.range.contains(v) { v } else { d.default };
                    }
                }
            }
        }
        for (i, d) in spec.global.params.iter().enumerate() {
            let mut v = d.default;
            if d.access.persistent() {
                if let Ok(stored) = persist::load_global(&mut self.board, spec, i) {
                    v = if d.range.contains(stored) { stored } else { d.default };
                }
            }
            self.st.banks.set_global(spec, i, v);
        }
        for (i, d) in spec.interrupt.params.iter().enumerate() {
            self.st.banks.interrupt[i] = d.default;
        }
        // §5.3 / §8.4: user variables are restored unless GP 85 = 1.
        if !self.gp_flag(Setting::DoNotRestoreUserVariables) {
            for n in 0..spec.stored_user_variables {
                let n = n as u8; // stored_user_variables ≤ 256, checked by ModelSpec::new
                self.st.banks.user[usize::from(n)] = persist::load_user(&mut self.board, spec, n).unwrap_or(0);
            }
        }
        // §3.7.24: with GP 84 = 1 the coordinates are copied back at start-up.
        if self.gp_flag(Setting::CoordinateStorage) {
            for m in 0..self.st.axes.count() {
                for n in 1..=spec.coordinates {
                    self.st.axes[m].coords[usize::from(n)] =
                        persist::load_coordinate(&mut self.board, spec, m, n).unwrap_or(0);
                }
            }
        }
        self.st.active_baud = self.gp(Setting::BaudRate).unwrap_or(0) as u8;
        for m in 0..self.st.axes.count() {
            let mut motor = self.motor_at(m);
            motor.configure_driver();
            let counts = motor.encoder_counts_now();
            motor.axis.encoder = EncoderBase { counts, value: 0 };
            motor.axis.last_counts = counts;
        }
        self.board.set_outputs(0);
        self.update_boards(now);
        self.vm = Vm::default();
        self.vm.time = now;
        self.read_program();
        self.auto_start(now);
        // §3.4.4: GP 67 bit 0 = start up in ASCII mode, on the first interface that has it.
        if self.gp(Setting::AsciiMode).unwrap_or(0) & 1 == 1 {
            if let Some(port) = spec.interfaces.iter().position(|i| i.ascii) {
                self.enter_ascii(port);
                // The extra host links (the ports after the model's interfaces; none without the
                // `host-links` feature) are the first interface again.
                if port == 0 {
                    for link in MAX_INTERFACES..self.st.ports.len() {
                        self.enter_ascii(link);
                    }
                }
            }
        }
    }

    /// The ramp parameters motor `m` runs with ([`Axis::ramp_params`]).
    #[inline]
    pub(crate) fn ramp_params(&self, m: usize) -> RampParams {
        self.st.axes[m].ramp_params(self.spec)
    }

    /// The ramp parameters motor `m`'s own AP 4, 5 and 130 give ([`Axis::own_ramp_params`]).
    #[inline]
    pub(crate) fn own_ramp_params(&self, m: usize) -> RampParams {
        self.st.axes[m].own_ramp_params(self.spec)
    }

    /// Tells the board every motor's drive state at `now` (after a command that may have changed any).
    pub(crate) fn update_boards(&mut self, now: Instant) {
        for m in 0..self.st.axes.count() {
            self.motor_at(m).update_board(now);
        }
    }

    /// Motor `m` with what it reaches, for one call ([`Motor`]: its tick, its board, the parameters that
    /// read them).
    #[inline(always)]
    pub(crate) fn motor_at(&mut self, m: usize) -> Motor<'_, B> {
        Motor { m, axis: &mut self.st.axes[m], spec: self.spec, banks: &self.st.banks, board: &mut self.board }
    }

    /// Notes an instant at which something changes by itself that a state of the running program named,
    /// for the board's hook (`module/pass.rs`; cleared at each copy of the whole state).
    #[inline(always)]
    pub(crate) fn name(&mut self, at: Option<Instant>) {
        if let Some(at) = at {
            self.named = Some(self.named.map_or(at, |n| n.min(at)));
        }
    }

    /// What motor `m` did beyond itself ([`Faults`]): the program's deviation flag, the stall and
    /// deviation interrupts, the pending 138 event.
    #[inline(always)]
    pub(crate) fn apply(&mut self, m: usize, faults: Faults) {
        if faults.any() {
            self.apply_faults(m, faults);
        }
    }

    #[inline(never)] // (rare: out of the tick's way)
    fn apply_faults(&mut self, m: usize, faults: Faults) {
        if faults.drop_event {
            self.st.event.pending = false;
        }
        if faults.stops & error_flags::STALL != 0 {
            if let Some(n) = self.spec.interrupts.stall(m) {
                self.raise_interrupt(n);
            }
        }
        if faults.stops & error_flags::DEVIATION != 0 {
            self.st.regs.flags |= flags::DEVIATION;
            if let Some(n) = self.spec.interrupts.deviation(m) {
                self.raise_interrupt(n);
            }
        }
    }
}

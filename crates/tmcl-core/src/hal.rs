//! The board behind the firmware: small capability traits (after embedded-hal).
//!
//! The core keeps its EEPROM ([`Nvm`]), reads inputs ([`Inputs`]), analog values ([`Analog`]) and the
//! stop switches ([`SwitchInputs`]), sets outputs ([`Outputs`]), drives the motor ([`StepDriver`]) and
//! reads its load ([`LoadSensor`]) and encoder ([`EncoderCounter`]) through these traits only, each
//! small enough for a board to implement what it has. The simulator (`tmcl-sim`) implements them; a
//! microcontroller port implements them over its peripherals.
//!
//! What belongs to a motor — its stop switches, driver, load measurement and encoder — is asked for by
//! the motor's index (`motor`, 0 to the model's motors − 1); a one-motor board is only ever asked for
//! motor 0.
//!
//! [`Hook`] is the one trait a real board leaves at its defaults (`impl Hook for MyBoard {}`): the points
//! where a simulator hooks its shortcuts in (breakpoints, the loop skip), as a CPU emulator hooks its
//! bus.

use crate::time::{Duration, Instant};
use core::fmt::Debug;

/// Non-volatile memory: the module's configuration and program EEPROM.
///
/// # Contract
///
/// A [`Nvm::write`] call is atomic: after a crash or power loss at any moment, a later read sees either
/// all of `data` or none of it. The core relies on this and never writes one logical value in two calls.
pub trait Nvm {
    /// What can go wrong.
    type Error: Debug;

    /// Size of the memory in bytes.
    fn capacity(&self) -> usize;

    /// Reads `buf.len()` bytes from `offset`. Offsets past the end are an error, never a panic.
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error>;

    /// Writes `data` at `offset`, atomically (see the trait docs).
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Self::Error>;
}

impl<T: Nvm + ?Sized> Nvm for &mut T {
    type Error = T::Error;
    fn capacity(&self) -> usize {
        T::capacity(self)
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        T::read(self, offset, buf)
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Self::Error> {
        T::write(self, offset, data)
    }
}

/// Raw levels of the reference switches. `true` = the switch input is active with normal polarity
/// (GP 79 = 0); the core applies the polarity itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Switches {
    /// Left stop switch (negative direction).
    pub left: bool,
    /// Right stop switch (positive direction).
    pub right: bool,
    /// Home (reference) switch.
    pub home: bool,
}

/// General-purpose digital inputs (PD28-1021 manual §3.7.15, bank 0).
pub trait Inputs {
    /// Levels of the digital inputs; bit n = INn.
    fn digital_inputs(&mut self) -> u8;
}

/// General-purpose digital outputs (PD28-1021 manual §3.7.14, bank 2).
pub trait Outputs {
    /// Drives the outputs; bit n = OUTn.
    fn set_outputs(&mut self, bits: u8);

    /// Switches the reference switch inputs' pull-up resistors (SIO on a model's `PortKind::PullUps`
    /// port, 0..=3); a board without switchable pull-ups ignores it (the default).
    fn set_pull_ups(&mut self, bits: u8) {
        let _ = bits;
    }
}

/// Analog inputs and the temperature sensor (PD28-1021 manual §3.7.15, bank 1).
pub trait Analog {
    /// A 12-bit ADC reading (0..=4095) of analog channel `channel`.
    fn analog_input(&mut self, channel: u8) -> u16;

    /// Module temperature in °C.
    fn temperature(&mut self) -> i32;

    /// Supply voltage in 0.1 V (the TMCM-1310's status word flags under- and overvoltage); a board that
    /// does not measure it reads the nominal 24.0 V (the default).
    fn supply_voltage(&mut self) -> u16 {
        240
    }
}

/// Bits of [`LoadSensor::driver_flags`] the firmware looks at (the TMC262's flags, PD28-1021 manual
/// chapter 4 Table 15, AP 208).
pub mod driver_flag {
    /// Overtemperature: the driver has shut down.
    pub const OVERTEMPERATURE: u8 = 1 << 1;
}

/// The stop and home switches.
pub trait SwitchInputs {
    /// The reference switches, as they are now (the board knows where the axis is from
    /// [`StepDriver::update`]).
    fn switches(&mut self, motor: usize) -> Switches;
}

/// What the step generator asks of the motor driver, passed to [`StepDriver::update`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriveState {
    /// Microsteps (of the current resolution) the field moved since the previous update, signed. Setting
    /// the step counter (SAP 1) or a reset changes `position` without moving: `moved` is then 0. In open
    /// loop the field moves with the step counter; in closed loop (TMCM-1310) the firmware commands it
    /// from the encoder, so its moves add up to the step counter's plus the loop's corrections.
    pub moved: i64,
    /// The step counter (axis parameter 1; in closed loop the virtual position, AP 233) in microsteps of
    /// the current resolution.
    pub position: i32,
    /// Signed velocity in microsteps per second.
    pub velocity: i32,
    /// Microstep resolution as a power of two: microsteps per full step = 1 << resolution (AP 140).
    pub resolution: u8,
    /// Current setting 0..=255 (255 = the module's maximum), after run/boost/standby selection.
    pub current: u8,
    /// Whether the driver stages are on; off = the motor freewheels (AP 204, AP 167 = 0).
    pub enabled: bool,
    /// Reverse shaft (GP 90): the motor turns the other way for the same step counter.
    pub reverse: bool,
}

/// Driver settings besides the current, passed to [`StepDriver::configure`]: the load measurement
/// (stallGuard) filter and threshold and the current range. A model without one of the parameters gets
/// the default here. The default is the PD28-1021's factory setting (manual chapter 4, Table 15: AP 173,
/// 174, 179).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriverSettings {
    /// Load measurement filter; `true` = one measurement per 4 full steps (filtered mode).
    pub stall_filter: bool,
    /// Load measurement threshold, −64..=63; higher = less sensitive (the load value reads higher).
    pub stall_threshold: i8,
    /// The high current range (on the PD28-1021: AP 179 = 0, 2 A peak / 1.4 A RMS at current 255);
    /// `false` (the default) = the low range, 1 A peak / 0.7 A RMS.
    pub high_range: bool,
    /// The encoder input reads an absolute SSI encoder instead of A/B/N (TMCM-1310: AP 201 bit 0); a
    /// board with one encoder input ignores it.
    pub ssi_encoder: bool,
}

/// A stretch of time and travel in which nothing the board models changes except through the motor's
/// own moves, as [`StepDriver::quiet`] reports it. Within it the core may report a run of motion ticks in
/// one [`StepDriver::update`] (see there for what the board promises).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Quiet {
    /// Nothing changes by itself before this instant (exclusive): a timeline entry, a fault window, a
    /// bouncing switch settling. `None`: nothing is due.
    pub until: Option<Instant>,
    /// How far the step counter (microsteps of the current resolution) may move up from where it is
    /// before a reading changes with the position (a switch edge, a jam, an end stop): every position up
    /// to this many microsteps further is quiet. 0: none.
    pub forward: u64,
    /// How far it may move down.
    pub backward: u64,
    /// The lowest |velocity| (pps) at which the readings behave as now (a load measurement starts or
    /// stops below a speed, for one).
    pub min_speed: u32,
    /// The highest.
    pub max_speed: u32,
    /// The load value (AP 206) every load measurement in the window reads.
    pub load: u16,
}

/// The motor driver, fed by the step generator.
pub trait StepDriver {
    /// Called after every motion tick with the state the motor should now be in — or, within a window
    /// the board reported with [`StepDriver::quiet`], once for a run of ticks.
    ///
    /// # Runs of ticks
    ///
    /// Within a [`Quiet`] window the core may leave out the updates of a run of motion ticks and make
    /// only the last one, with `moved` the sum of the run's moves, `now` the time of its last tick and
    /// `state` as after it. It does so only when, over the whole run:
    /// - the step counter moves in one direction and stays within `forward`/`backward` of where it was
    ///   when the window was asked for, and every tick's |velocity| lies within `min_speed..=max_speed`;
    /// - nothing else of the drive state changes (current, enabled, resolution, reverse);
    /// - the last tick moved a step, unless none of the run's ticks did;
    /// - the last tick comes before `until`.
    ///
    /// The board promises that such an update leaves it as the updates of every tick would have, and
    /// that what the core reads between those ticks would have read as before the run: the switches,
    /// inputs, flags and the load value (every new load measurement reads `load`), and the encoder
    /// counts moving monotonically with the step counter.
    fn update(&mut self, motor: usize, now: Instant, state: &DriveState);

    /// Applies driver settings that change rarely. A board without them ignores the call (the default).
    fn configure(&mut self, motor: usize, settings: &DriverSettings) {
        let _ = (motor, settings);
    }

    /// Whether, at `now` and with the driver last updated to `state`, the board is in a [`Quiet`]
    /// window, and how far it reaches. `None` (the default, for a board that cannot tell): the core
    /// reports every motion tick.
    fn quiet(&mut self, motor: usize, now: Instant, state: &DriveState) -> Option<Quiet> {
        let _ = (motor, now, state);
        None
    }

    /// Whether, within the window `quiet` that [`StepDriver::quiet`] has just reported for `state`, the
    /// board is *periodic* in the field's position, and with which period (microsteps of the current
    /// resolution; 0, the default: it cannot say). Periodic: the rotor follows the field's position, not
    /// its history, and where the field stands `period` further on, every reading is what it is here, the
    /// encoder counts moved on by exactly `period` × counts per revolution / microsteps per revolution (a
    /// whole number). The board narrows `quiet.forward`/`backward` to where that holds. A closed loop
    /// turning at a steady speed repeats its ticks with such a period, and the core takes whole periods at
    /// once (`module/periods.rs`); the core asks only then.
    fn period(&mut self, motor: usize, state: &DriveState, quiet: &mut Quiet) -> u64 {
        let _ = (motor, state, quiet);
        0
    }

    /// Within a window in which [`StepDriver::period`] found the board periodic for `state` (the rotor
    /// stands on the field): the encoder counts (as [`EncoderCounter::encoder_counts`] reads them) with
    /// the field `ahead` microsteps of the resolution in force from where it stands now, or `None` (the
    /// default) if the board cannot say. The core reads a closed loop's measurements over a run of
    /// ticks from it (`module/loop_span.rs`); `ahead` stays within the window's travel.
    fn counts_at(&mut self, motor: usize, state: &DriveState, ahead: i64) -> Option<i64> {
        let _ = (motor, state, ahead);
        None
    }
}

/// The driver's load measurement (stallGuard2 on the TMC262) and its error flags.
pub trait LoadSensor {
    /// The load value 0..=1023 of the last measurement (AP 206); 0 = maximum load. A board without a
    /// load measurement reads 1023, no load (the default).
    fn load(&mut self, motor: usize) -> u16 {
        let _ = motor;
        1023
    }

    /// How many load measurements the driver has taken since power-up (wrapping). Each new one is a new
    /// [`LoadSensor::load`] reading: the core runs one coolStep step per measurement
    /// ([`crate::drive::coolstep`]). A board without them never measures (the default, 0).
    fn load_measurements(&mut self, motor: usize) -> u32 {
        let _ = motor;
        0
    }

    /// The driver's error flags (AP 208 on the PD28-1021); none by default.
    fn driver_flags(&mut self, motor: usize) -> u8 {
        let _ = motor;
        0
    }
}

/// The encoder counter.
pub trait EncoderCounter {
    /// Physical encoder counts since power-up, in the motor's physical direction (the model's
    /// [`tmcl_model::Encoder::counts_per_rev`] per revolution). A board without an encoder reads 0.
    /// With an SSI encoder selected ([`DriverSettings::ssi_encoder`]) the reading is the absolute angle
    /// within one revolution, 0..counts per revolution; the firmware counts the turns.
    fn encoder_counts(&mut self, motor: usize) -> i64 {
        let _ = motor;
        0
    }
}

macro_rules! forward {
    ($($trait:ident { $(fn $name:ident(&mut self $(, $arg:ident: $ty:ty)*) $(-> $ret:ty)?;)* })*) => {
        $(impl<T: $trait + ?Sized> $trait for &mut T {
            $(#[inline]
            fn $name(&mut self $(, $arg: $ty)*) $(-> $ret)? {
                T::$name(self $(, $arg)*)
            })*
        })*
    };
}

forward! {
    Inputs { fn digital_inputs(&mut self) -> u8; }
    Outputs { fn set_outputs(&mut self, bits: u8); fn set_pull_ups(&mut self, bits: u8); }
    Analog { fn analog_input(&mut self, channel: u8) -> u16; fn temperature(&mut self) -> i32; fn supply_voltage(&mut self) -> u16; }
    SwitchInputs { fn switches(&mut self, motor: usize) -> Switches; }
    StepDriver {
        fn update(&mut self, motor: usize, now: Instant, state: &DriveState);
        fn configure(&mut self, motor: usize, settings: &DriverSettings);
        fn quiet(&mut self, motor: usize, now: Instant, state: &DriveState) -> Option<Quiet>;
        fn period(&mut self, motor: usize, state: &DriveState, quiet: &mut Quiet) -> u64;
        fn counts_at(&mut self, motor: usize, state: &DriveState, ahead: i64) -> Option<i64>;
    }
    LoadSensor {
        fn load(&mut self, motor: usize) -> u16;
        fn load_measurements(&mut self, motor: usize) -> u32;
        fn driver_flags(&mut self, motor: usize) -> u8;
    }
    EncoderCounter { fn encoder_counts(&mut self, motor: usize) -> i64; }
}

/// A simulator's hook into the program machine, as a CPU emulator has hooks on its bus: the firmware
/// calls it at fixed points and it does nothing by default — a microcontroller's board implements it
/// with `impl Hook for MyBoard {}`, and the calls compile to nothing. The simulator (`tmcl-sim`) puts its
/// shortcuts behind it: a debugger's breakpoints and the loop skip (a program spinning in a fixed point
/// jumped over in whole turns). The firmware knows none of them; it only says where it is.
pub trait Hook {
    /// Whether the program machine is to ask [`Hook::stop_before`] before each instruction (a
    /// debugger's breakpoints are set). Asked once per run of the program, when its first instruction
    /// is due; `false` (the default) lets the machine run plain instructions without asking.
    #[inline(always)]
    fn watches_instructions(&self) -> bool {
        false
    }

    /// Before the instruction at `pc` of a running program, when [`Hook::watches_instructions`]: whether
    /// the program stops there, before executing it (its run state becomes stopped, as after command
    /// 128). Never by default.
    #[inline(always)]
    fn stop_before(&mut self, pc: u16) -> bool {
        let _ = pc;
        false
    }

    /// After a jump back of a running program (the PC not past where it was), within a poll and in
    /// event-driven mode (not in a single step, command 130, nor tick by tick): the hook may move the
    /// program and the motion controller on by whole turns of a loop ([`Pass::skip`]). Returns whether
    /// it did. Never by default.
    #[inline(always)]
    fn jumped_back<P: Pass>(&mut self, pass: &mut P) -> bool {
        let _ = pass;
        false
    }

    /// When the running program next needs a poll, if the hook knows better than the program's next
    /// instruction: `Some(Some(t))` not before `t`, `Some(None)` not by itself; `now` is the module's
    /// time, `changes` its count of changes ([`Pass::changes`]). `None` (the default): at its next
    /// instruction, as the firmware says.
    #[inline(always)]
    fn program_rest(&self, now: Instant, changes: u32) -> Option<Option<Instant>> {
        let _ = (now, changes);
        None
    }
}

/// The firmware at a jump back of its program, as [`Hook::jumped_back`] sees it: where the program is,
/// what may change by itself ahead, and a copy of the whole state to compare a later pass with (a save
/// state, as an emulator has). Implemented by the module; a hook only reads it and may move it on.
pub trait Pass {
    /// The whole firmware state and program machine at a pass.
    type Saved: Clone + Debug + Send + 'static;

    /// The pass's key; `None` when the program is not at an instruction that runs by itself alone (it
    /// is not running, a WAIT is in progress, or its clock is not after the last motion tick).
    fn key(&self) -> Option<PassKey>;
    /// Instructions executed since power-up.
    fn executed(&self) -> u64;
    /// The program's clock: when its next instruction runs.
    fn time(&self) -> Instant;
    /// The motion controller's clock (tick-aligned).
    fn motion_time(&self) -> Instant;
    /// The time the caller's poll runs up to: instructions up to and including it run in this poll.
    fn now(&self) -> Instant;
    /// The module's count of changes (every board write, EEPROM write and input from outside moves it
    /// on): equal counts at two passes say nothing was told to the board or came from outside between.
    fn changes(&self) -> u32;
    /// The number of motors.
    fn motors(&self) -> usize;
    /// Whether every motor stands with its standstill begun, and nothing ticks by itself (no closed
    /// loop): then only the board's readings, within their quiet windows, could change what a turn does.
    fn standing(&self) -> bool;
    /// The drive state motor `motor` was last given (to ask the board's quiet window with).
    fn drive(&self, motor: usize) -> DriveState;
    /// The next instant at which something changes by itself, whatever the program does: a standby or
    /// freewheeling delay, the heartbeat, an enabled timer — as the pass names them, and as every state
    /// the program passed through since the last [`Pass::save`] named them (a turn of a loop may set a
    /// delay and set it back: every later turn names that instant again). An instant at or before
    /// [`Pass::time`] has passed within the turns seen: what later turns name is not known from them.
    fn next_event(&self) -> Option<Instant>;
    /// A copy of the whole state; from here on [`Pass::next_event`] gathers the instants named anew.
    fn save(&mut self) -> Self::Saved;
    /// Whether the state now is `saved` a whole number of turns later: every field equal but the clocks,
    /// the program's and the motion controller's by the same Δ > 0, and the instruction count by n > 0.
    /// Returns (Δ, n).
    fn turned(&self, saved: &Self::Saved) -> Option<(Duration, u64)>;
    /// Moves the program's and the motion controller's clocks on by `by` and the instruction count by
    /// `instructions`: what whole turns of a loop in a fixed point do.
    fn skip(&mut self, by: Duration, instructions: u64);
}

/// What a pass of a program is recognised by, cheaply ([`Pass::key`]): two passes with different keys are
/// in different states.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PassKey {
    /// The program counter.
    pub pc: u16,
    /// Microseconds from the last motion tick to the next instruction.
    pub phase: u64,
    /// The program's accumulator, X register and flags.
    pub registers: (i32, i32, u16),
    /// The subroutine stack's depth.
    pub sp: u8,
    /// Whether an interrupt handler runs.
    pub handler: bool,
}

impl<T: Hook + ?Sized> Hook for &mut T {
    #[inline(always)]
    fn watches_instructions(&self) -> bool {
        T::watches_instructions(self)
    }
    #[inline(always)]
    fn stop_before(&mut self, pc: u16) -> bool {
        T::stop_before(self, pc)
    }
    #[inline(always)]
    fn jumped_back<P: Pass>(&mut self, pass: &mut P) -> bool {
        T::jumped_back(self, pass)
    }
    #[inline(always)]
    fn program_rest(&self, now: Instant, changes: u32) -> Option<Option<Instant>> {
        T::program_rest(self, now, changes)
    }
}

/// Everything a module needs from its board: one trait per capability, so a board implements what it
/// has (with the defaults of [`LoadSensor`] and [`EncoderCounter`] for what it has not, and of [`Hook`],
/// which only a simulator fills in).
pub trait Board:
    Nvm + Inputs + Outputs + Analog + SwitchInputs + StepDriver + LoadSensor + EncoderCounter + Hook
{
}

impl<T: Nvm + Inputs + Outputs + Analog + SwitchInputs + StepDriver + LoadSensor + EncoderCounter + Hook> Board for T {}

/// The capability traits under no names, for code that calls them on a concrete board type (the
/// module's board behind its seam).
pub mod prelude {
    pub use super::{
        Analog as _, EncoderCounter as _, Hook as _, Inputs as _, LoadSensor as _, Nvm as _, Outputs as _,
        StepDriver as _, SwitchInputs as _,
    };
}

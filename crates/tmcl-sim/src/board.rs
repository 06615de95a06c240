//! The simulated board: a stepper on an axis described by a [`World`] (switches, loads, inputs on a
//! timeline, faults), the driver's sensors, and an EEPROM in memory or in a crash-safe file. What the
//! board is — encoder, driver, inputs and outputs — comes from the model, as a [`Profile`]
//! ([`SimBoard::for_model`]; see [`crate::profile`] for what is taken from the model and what not).
//!
//! Positions in the world are physical: 1/256 microsteps of the motor shaft (51200 per revolution with a
//! 200-step motor, the PD28-1021's motor, manual §6.1). The firmware's step counter is at the resolution
//! AP 140 selects; [`SimBoard`] converts every move it is told about ([`DriveState::moved`]) and applies
//! the reverse-shaft setting, so a reset or a `SAP 1` that changes the counter does not move the shaft.
//!
//! # Time
//!
//! The world's times (timeline, faults) are on the module's clock: `Instant::ZERO` is power-up, as in
//! `tmcl run` and `tmcl serve`. The board moves its world forward whenever the firmware updates the
//! driver ([`StepDriver::update`]), when [`SimBoard::advance`] is called, and — if it has a clock
//! ([`SimBoard::with_clock`]) — before every sensor or input read, so a timeline runs on while the motor
//! stands still and the core does not call the board.

use crate::driver::{self, Driver};
use crate::motor::{self, Follow, Mechanics, USTEPS_PER_FULL_STEP};
use crate::nvm::{FileNvm, MemNvm, NvmError};
use crate::profile::Profile;
use crate::world::{Active, DriverFlag, EncoderType, Invalid, World, WorldError};

pub mod change;
use crate::hook::{Breakpoints, LoopSkip};
pub use change::{Change, SwitchId};
use tmcl_core::hal::{
    Analog, DriveState, DriverSettings, EncoderCounter, Hook, Inputs, LoadSensor, Nvm, Outputs, Pass, Quiet,
    StepDriver, SwitchInputs, Switches,
};
use tmcl_core::model::{EncoderKind, ModelSpec};
use tmcl_core::param::persist;
use tmcl_core::{Duration, Instant};

/// Physical 1/256 microsteps per revolution of the default world's 200-step motor.
pub const MICROSTEPS_PER_REV: i64 = 200 * 256;

/// 2^−r for r = 0..=8: multiplying by these is exact, as dividing by 2^r is.
const INVERSE_POWERS_OF_TWO: [f64; 9] = [1.0, 0.5, 0.25, 0.125, 0.0625, 0.031_25, 0.015_625, 0.007_812_5, 0.003_906_25];

/// The EEPROM behind a simulated board.
#[derive(Debug)]
pub enum Eeprom {
    /// In memory: state lives as long as the process.
    Memory(MemNvm),
    /// In a crash-safe file.
    File(FileNvm),
}

impl Nvm for Eeprom {
    type Error = NvmError;
    fn capacity(&self) -> usize {
        match self {
            Eeprom::Memory(m) => m.capacity(),
            Eeprom::File(f) => f.capacity(),
        }
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), NvmError> {
        match self {
            Eeprom::Memory(m) => m.read(offset, buf),
            Eeprom::File(f) => f.read(offset, buf),
        }
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), NvmError> {
        match self {
            Eeprom::Memory(m) => m.write(offset, data),
            Eeprom::File(f) => f.write(offset, data),
        }
    }
}

impl Eeprom {
    /// Makes sure everything written is on disk (a no-op in memory).
    pub fn sync(&mut self) -> Result<(), NvmError> {
        match self {
            Eeprom::Memory(_) => Ok(()),
            Eeprom::File(f) => f.sync(),
        }
    }
}

/// A switch zone in µsteps with its polarity and bounce.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Switch {
    lo: f64,
    hi: f64,
    active_high: bool,
    /// (bounce time, falls back this many times).
    bounce: Option<(Duration, u32)>,
    /// Pressed now (ideal contact).
    pressed: bool,
    /// The last edge: when, and the level before it.
    edge: Option<(Instant, bool)>,
    /// Pressed (`true`) or released (`false`) at run time whatever the position ([`Change::Switch`]);
    /// `None`: pressed within `lo..=hi`.
    forced: Option<bool>,
    /// For a switch met every turn of a rotary axis (`every_turn`), one revolution of the shaft (µsteps,
    /// more than `hi - lo`): the switch is pressed within `lo..=hi` plus any whole number of revolutions, as
    /// a rotary table's switch passes once a turn. `None`: pressed only within `lo..=hi`.
    period: Option<f64>,
}

impl Switch {
    /// Tracks the ideal contact at rotor position `x` and time `now`.
    fn track(&mut self, x: f64, now: Instant) {
        let pressed = self.forced.unwrap_or_else(|| self.contains(x));
        if pressed != self.pressed {
            self.edge = Some((now, self.pressed));
            self.pressed = pressed;
        }
    }

    /// Whether rotor position `x` lies in the switch's zone (on a rotary axis, in one of its images a whole
    /// number of revolutions away).
    fn contains(&self, x: f64) -> bool {
        match self.period {
            Some(p) => (x - self.lo).rem_euclid(p) <= self.hi - self.lo,
            None => (self.lo..=self.hi).contains(&x),
        }
    }

    /// Narrows the window `lo..=hi` around `x` so that it crosses no edge of the switch's zone (on a
    /// rotary axis, of its images on either side of `x`).
    fn zone(&self, x: f64, lo: &mut f64, hi: &mut f64) {
        match self.period {
            Some(p) => {
                let k = ((x - self.lo) / p).floor();
                for image in [k - 1.0, k, k + 1.0] {
                    motor::zone(x, self.lo + image * p, self.hi + image * p, lo, hi);
                }
            }
            None => motor::zone(x, self.lo, self.hi, lo, hi),
        }
    }

    /// When the input level next changes by itself after `now` (the next slot of a bounce), if it will.
    fn next_change(&self, now: Instant) -> Option<Instant> {
        let ((time, count), (at, _)) = (self.bounce?, self.edge?);
        let (since, time) = (now.saturating_duration_since(at).micros(), time.micros());
        if since >= time {
            return None;
        }
        // `level`'s slot is ⌊since · slots / time⌋: the next one starts at ⌈(slot + 1) · time / slots⌉.
        let slots = 2 * u64::from(count) + 1;
        let slot = since * slots / time.max(1);
        Some(at + Duration::from_micros(((slot + 1) * time).div_ceil(slots)))
    }

    /// The input level at `now`: `true` = active with normal polarity.
    fn level(&self, now: Instant) -> bool {
        let mut contact = self.pressed;
        if let (Some((time, count)), Some((at, before))) = (self.bounce, self.edge) {
            let since = now.saturating_duration_since(at).micros();
            if since < time.micros() {
                // 2·count + 1 equal slots: the new level in even slots, the old one in odd slots.
                let slot = since * (2 * u64::from(count) + 1) / time.micros().max(1);
                if slot % 2 == 1 {
                    contact = before;
                }
            }
        }
        contact == self.active_high
    }
}

/// Something that happens at a time.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    /// A change of the world: from the world file's timeline (inputs, scripted load, encoder slip) or
    /// scheduled at run time ([`SimBoard::schedule`]).
    Change(Change),
    /// A fault window opens or closes.
    Faults,
}

/// A world compiled for the board: everything converted to µsteps and `Instant`s.
#[derive(Debug, Clone)]
pub(crate) struct Plan {
    mech: Mechanics,
    switches: [Option<Switch>; 3],
    events: Vec<(Instant, Event)>,
    /// Seizure points with their windows.
    seizures: Vec<(f64, Instant, Option<Instant>)>,
    encoder_zero: f64,
    min_speed: f64,
    undervoltage: f64,
    supply: f64,
}

/// The period of a switch's zone (µsteps): one revolution where it is met every turn (`every_turn`, a
/// rotary axis only, a zone narrower than a turn), `None` where it is met only at its place.
fn every_turn(
    world: &World,
    spec: &crate::world::SwitchSpec,
    (lo, hi): (f64, f64),
    rev: f64,
    key: &'static str,
) -> Result<Option<f64>, Invalid> {
    if !spec.every_turn {
        Ok(None)
    } else if world.axis.kind != crate::world::AxisKind::Rotary {
        Err(Invalid::new(spec.at.span(), key, "`every_turn` needs a rotary axis (`[axis] kind = \"rotary\"`)"))
    } else if hi - lo >= rev {
        Err(Invalid::new(spec.at.span(), key, "a switch met every turn must be narrower than a turn"))
    } else {
        Ok(Some(rev))
    }
}

impl Plan {
    /// Checks and compiles a world.
    pub(crate) fn compile(world: &World) -> Result<Plan, Invalid> {
        let mech = Mechanics::compile(world)?;
        let zone = |spec: &Option<crate::world::SwitchSpec>, key| -> Result<Option<Switch>, Invalid> {
            let Some(s) = spec else { return Ok(None) };
            let (lo, hi) = motor::range(world, &s.at, key)?;
            Ok(Some(Switch {
                lo,
                hi,
                active_high: s.active == Active::High,
                bounce: s.bounce.map(|b| (Duration::from_micros(b.time.0.micros()), b.count)),
                pressed: false,
                edge: None,
                forced: None,
                period: every_turn(world, s, (lo, hi), mech.usteps_per_rev(), key)?,
            }))
        };
        let sw = &world.switches;
        let switches = [
            zone(&sw.left, "switches.left.at")?,
            zone(&sw.right, "switches.right.at")?,
            zone(&sw.home, "switches.home.at")?,
        ];
        let mut events = Vec::new();
        for c in &world.inputs.timeline {
            if let Some(a) = &c.analog {
                if *a.get_ref() > 4095 {
                    return Err(Invalid::new(a.span(), "inputs.timeline.analog", "must be 0..=4095"));
                }
            }
            events.push((c.at.0, Event::Change(Change::Inputs(c.clone()))));
        }
        for s in &world.load.script {
            events.push((s.at.0, Event::Change(Change::Load(s.torque))));
        }
        for s in &world.faults.encoder_slip {
            events.push((s.at.0, Event::Change(Change::EncoderSlip(s.counts))));
        }
        let mut seizures = Vec::new();
        for s in &world.faults.stall {
            seizures.push((motor::usteps(world, &s.at, "faults.stall.at")?, s.from.0, s.until.map(|t| t.0)));
            events.push((s.from.0, Event::Faults));
            events.extend(s.until.map(|t| (t.0, Event::Faults)));
        }
        for d in &world.faults.driver {
            events.push((d.from.0, Event::Faults));
            events.extend(d.until.map(|t| (t.0, Event::Faults)));
        }
        for d in &world.faults.supply_drop {
            motor::positive(&d.voltage, "faults.supply_drop.voltage", 0.0, false)?;
            events.push((d.from.0, Event::Faults));
            events.extend(d.until.map(|t| (t.0, Event::Faults)));
        }
        // Stable: events at the same time keep the file's order.
        events.sort_by_key(|(t, _)| *t);
        let inputs = &world.inputs;
        if *inputs.analog.get_ref() > 4095 {
            return Err(Invalid::new(inputs.analog.span(), "inputs.analog", "must be 0..=4095"));
        }
        if world.encoder.is_some_and(|e| e.counts_per_rev < 4) {
            return Err(Invalid::new(0..0, "encoder.counts_per_rev", "must be at least 4"));
        }
        let d = &world.driver;
        let full_steps = f64::from(*world.motor.full_steps.get_ref());
        Ok(Plan {
            encoder_zero: motor::usteps(world, &d.encoder_zero, "driver.encoder_zero")?,
            min_speed: motor::positive(&d.stallguard_min_speed, "driver.stallguard_min_speed", 0.0, false)?
                * full_steps,
            undervoltage: motor::positive(&d.undervoltage, "driver.undervoltage", 0.0, false)?,
            supply: motor::positive(&d.supply_voltage, "driver.supply_voltage", 0.0, true)?,
            mech,
            switches,
            events,
            seizures,
        })
    }
}

/// The module's inputs as they are now. The world's timeline sets them; a test or tool may too, at any
/// time (`board.world.inputs = 0b101`), until the timeline's next change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Levels {
    /// Digital input levels (bit n = INn).
    pub inputs: u8,
    /// ADC reading of analog input 0, 0..=4095 (larger values read as 4095).
    pub analog: u16,
    /// Module temperature in °C.
    pub temperature: i32,
}

impl From<&World> for Levels {
    fn from(world: &World) -> Levels {
        let i = &world.inputs;
        Levels { inputs: i.digital, analog: *i.analog.get_ref(), temperature: i.temperature }
    }
}

/// The torque factor of a supply voltage: below the nominal 24 V the chopper reaches proportionally less
/// current at speed (a crude model, see [`SimBoard::power`]).
fn supply_factor(supply: f64) -> f64 {
    (supply / 24.0).min(1.0)
}

/// The inputs of the coil current and torque in [`SimBoard::power`]: driver on, current setting, range
/// (AP 179), error flags (faults, temperature), supply voltage (bits). The rest is fixed per world.
type PowerInputs = (bool, u8, bool, u8, u64);

/// Sensor readings of the board: encoder, load, driver flags (what the firmware reads through
/// [`EncoderCounter`] and [`LoadSensor`], in one call: [`SimBoard::feedback`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Feedback {
    /// Physical encoder counts since power-up, the model's counts per revolution (1024 on the PD28-1021,
    /// sensOstep, manual §6.2), in the motor's physical direction; 0 without an encoder.
    pub encoder_counts: i64,
    /// stallGuard2 load value 0..=1023 (AP 206); 0 = maximum load; 1023 without a load measurement.
    pub load: u16,
    /// Driver error flags (AP 208).
    pub driver_flags: u8,
}

impl Default for Feedback {
    fn default() -> Feedback {
        Feedback { encoder_counts: 0, load: 1023, driver_flags: 0 }
    }
}

/// A clock the board reads before sensor and input reads.
struct Clock(Box<dyn FnMut() -> Instant + Send>);

impl std::fmt::Debug for Clock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Clock")
    }
}

/// A simulated board of one model (the PD28-1021 unless built with [`SimBoard::for_model`]).
#[derive(Debug)]
pub struct SimBoard {
    eeprom: Eeprom,
    /// What the board is: from the model.
    profile: Profile,
    /// The inputs now; change them at any time.
    pub world: Levels,
    spec: World,
    plan: Plan,
    /// Index of the next event in `plan.events`.
    next_event: usize,
    driver: Driver,
    clock: Option<Clock>,
    /// Time up to which the world has been simulated.
    now: Instant,
    supply: f64,
    /// `(supply / 24).min(1)`, the supply's torque factor in [`SimBoard::power`], kept with `supply` (spares
    /// a division per update).
    supply_factor: f64,
    /// Everything [`SimBoard::power`] computed the coil current and torque from, when it last did: the
    /// same inputs give the same figures, so it skips to the settle (see there).
    powered_by: Option<PowerInputs>,
    /// AP 208 bits 1..6 from fault windows.
    fault_flags: u8,
    /// Seizure points added at run time ([`Change::Seize`]), besides the world file's windows.
    held: Vec<f64>,
    encoder_slip: i64,
    /// The encoder's period in µsteps and its reach for (µsteps, counts) a revolution, as last computed
    /// (`SimBoard::encoder_period`).
    encoder_period_of: Option<(u64, u64, u64, f64)>,
    /// Coil peak current now (A).
    coil: f64,
    /// Its square in (mA/32)², for the energy figure ([`driver::coil_square`]).
    coil_square: u64,
    outputs: u8,
    /// The reference switches' pull-ups as SIO set them (`PortKind::PullUps`, 0..=3).
    pull_ups: u8,
    drive: DriveState,
    updated: Instant,
    /// The field's own speed (µsteps per second, axis frame) over the last update, when the field did
    /// not move with the step counter: a closed loop commands the field from the encoder, and it falls
    /// short of the ramp where the rotor cannot follow (or runs ahead of it to catch up). `None` while it
    /// moves with the counter, which is always in open loop: the ramp's velocity is then the field's.
    /// What [`SimBoard::power`] hands a rotor the driver stages let go of.
    field_speed: Option<f64>,
    /// Motors 1.. of a model with several: each an axis of its own in a world of its own (the same world
    /// as motor 0's by default, [`SimBoard::set_world`]; one of them alone: [`SimBoard::set_world_of`]).
    /// Only their motor, switches, driver and encoder are used: the EEPROM, inputs, outputs and analog
    /// values are this board's.
    axes: Vec<SimBoard>,
    /// A debugger's breakpoints, behind the firmware's hook (`hook.rs`).
    breakpoints: Breakpoints,
    /// The loop skip, behind the firmware's hook (`hook.rs`).
    loop_skip: LoopSkip,
}

/// The simulator's shortcuts behind the firmware's hook (see `hook.rs`): breakpoints and the loop skip.
impl Hook for SimBoard {
    #[inline(always)]
    fn watches_instructions(&self) -> bool {
        self.breakpoints.any()
    }

    #[inline]
    fn stop_before(&mut self, pc: u16) -> bool {
        self.breakpoints.stop_before(pc)
    }

    #[inline(always)]
    fn jumped_back<P: Pass>(&mut self, pass: &mut P) -> bool {
        // (At every jump back only the key is looked at; the skip is lent out only for a look, which asks
        // the board's quiet windows.)
        if !self.loop_skip.due(pass) {
            return false;
        }
        let mut skip = std::mem::take(&mut self.loop_skip);
        let jumped = skip.look(pass, |m, now, drive| self.quiet(m, now, drive));
        self.loop_skip = skip;
        jumped
    }

    #[inline]
    fn program_rest(&self, now: Instant, changes: u32) -> Option<Option<Instant>> {
        self.loop_skip.rest(now, changes)
    }
}

impl SimBoard {
    /// A PD28-1021 board ([`Profile::PD28_1021`]) on a free axis (the default [`World`]) with the given
    /// EEPROM.
    pub fn new(eeprom: Eeprom) -> SimBoard {
        SimBoard::for_profile(Profile::PD28_1021, eeprom)
    }

    /// A board of the model `spec` on a free axis with the given EEPROM.
    pub fn for_model(spec: &ModelSpec, eeprom: Eeprom) -> SimBoard {
        SimBoard::for_profile(Profile::of(spec), eeprom)
    }

    /// A board of the model `spec` with an in-memory EEPROM of the size the model needs
    /// ([`persist::capacity`]).
    pub fn in_memory_for(spec: &ModelSpec) -> SimBoard {
        SimBoard::for_model(spec, Eeprom::Memory(MemNvm::new(persist::capacity(spec))))
    }

    /// A board with the given profile on a free axis with the given EEPROM.
    pub fn for_profile(profile: Profile, eeprom: Eeprom) -> SimBoard {
        let world = World::default();
        let plan = Plan::compile(&world).expect("the default world is valid");
        let mut board = SimBoard {
            eeprom,
            profile,
            driver: Driver::new(plan.min_speed),
            next_event: 0,
            clock: None,
            now: Instant::ZERO,
            world: Levels::from(&world),
            supply: plan.supply,
            supply_factor: supply_factor(plan.supply),
            powered_by: None,
            fault_flags: 0,
            held: Vec::new(),
            encoder_slip: 0,
            encoder_period_of: None,
            coil: 0.0,
            coil_square: 0,
            outputs: 0,
            pull_ups: 0,
            drive: DriveState::default(),
            updated: Instant::ZERO,
            field_speed: None,
            spec: world,
            plan,
            axes: Vec::new(),
            breakpoints: Breakpoints::default(),
            loop_skip: LoopSkip::default(),
        };
        board.fire(Instant::ZERO);
        for _ in 1..profile.motors.max(1) {
            let axis = SimBoard::for_profile(Profile { motors: 1, ..profile }, Eeprom::Memory(MemNvm::new(0)));
            board.axes.push(axis);
        }
        board
    }

    /// A PD28-1021 board with an in-memory EEPROM of `capacity` bytes.
    pub fn in_memory(capacity: usize) -> SimBoard {
        SimBoard::new(Eeprom::Memory(MemNvm::new(capacity)))
    }

    /// A debugger's breakpoints: the program stops before an address that has one (see [`Breakpoints`]).
    pub fn breakpoints(&self) -> &Breakpoints {
        &self.breakpoints
    }

    /// The breakpoints, to set or clear one. Reach them through `Module::board_mut`, which tells the
    /// module that something changed (a program resting in a loop is polled again, and stops at a
    /// breakpoint set in it).
    pub fn breakpoints_mut(&mut self) -> &mut Breakpoints {
        &mut self.breakpoints
    }

    /// The same board in `world`, at power-up (the rotor at `axis.start`, time 0).
    pub fn with_world(mut self, world: World) -> Result<SimBoard, WorldError> {
        self.set_world(world)?;
        Ok(self)
    }

    /// Puts the board into `world`, as at power-up: the rotor at `axis.start`, inputs and faults as at
    /// time 0, the energy figure and stallGuard2 reset. The EEPROM, the profile and the outputs are kept.
    ///
    /// Every motor of a model with several gets its own axis in a copy of `world` (one world per axis),
    /// with what the file's `[motors.N]` table gives motor N ([`World::of_motor`]);
    /// [`SimBoard::set_world_of`] puts one motor into a world of its own.
    pub fn set_world(&mut self, world: World) -> Result<(), WorldError> {
        world.check()?;
        let motors = 1 + self.axes.len();
        if let Some((m, _)) = world.motors.iter().find(|(m, _)| *m >= motors) {
            return Err(WorldError {
                file: None,
                key: Some(format!("motors.{m}")),
                line: None,
                message: format!("the module has {motors} motor(s), 0…{}", motors - 1),
            });
        }
        for (m, axis) in self.axes.iter_mut().enumerate() {
            axis.set_world(world.of_motor(m + 1))?;
        }
        self.set_own_world(world.of_motor(0))
    }

    /// Puts motor `motor`'s axis into `world`, as [`SimBoard::set_world`] does for all of them. A motor the
    /// board lacks: nothing happens (`Ok`).
    pub fn set_world_of(&mut self, motor: usize, world: World) -> Result<(), WorldError> {
        world.check()?;
        match motor {
            0 => self.set_own_world(world),
            m => self.axes.get_mut(m - 1).map_or(Ok(()), |axis| axis.set_own_world(world)),
        }
    }

    /// The axis of motor `motor` (0: this board itself), to read it or change its world; `None` for a
    /// motor the board lacks.
    pub fn axis_mut(&mut self, motor: usize) -> Option<&mut SimBoard> {
        match motor {
            0 => Some(self),
            m => self.axes.get_mut(m - 1),
        }
    }

    /// The axis of motor `motor` (0: this board itself), to read it.
    pub fn axis(&self, motor: usize) -> Option<&SimBoard> {
        match motor {
            0 => Some(self),
            m => self.axes.get(m - 1),
        }
    }

    /// How many motors the board simulates.
    pub fn motors(&self) -> usize {
        1 + self.axes.len()
    }

    /// Motor 0's world (this board's), keeping the further axes.
    fn set_own_world(&mut self, world: World) -> Result<(), WorldError> {
        world.check()?;
        let axes = std::mem::take(&mut self.axes);
        let fresh = SimBoard::for_profile(self.profile, Eeprom::Memory(MemNvm::new(0)));
        let eeprom = std::mem::replace(&mut self.eeprom, fresh.eeprom);
        let clock = self.clock.take();
        let outputs = self.outputs;
        let breakpoints = std::mem::take(&mut self.breakpoints);
        let plan = Plan::compile(&world).expect("checked");
        *self = SimBoard {
            eeprom,
            driver: Driver::new(plan.min_speed),
            clock,
            outputs,
            world: Levels::from(&world),
            supply: plan.supply,
            supply_factor: supply_factor(plan.supply),
            powered_by: None, // new mechanics (torque per amp, undervoltage): compute the power afresh
            spec: world,
            plan,
            axes,
            breakpoints,
            ..fresh
        };
        self.fire(Instant::ZERO);
        Ok(())
    }

    /// The same board, reading `clock` before every sensor and input read so the world runs on between
    /// driver updates (`tmcl serve` passes its wall clock).
    pub fn with_clock(mut self, clock: impl FnMut() -> Instant + Send + 'static) -> SimBoard {
        self.clock = Some(Clock(Box::new(clock)));
        self
    }

    /// What the board is (from the model).
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// Sensor readings now: what the firmware reads through [`EncoderCounter::encoder_counts`],
    /// [`LoadSensor::load`] and [`LoadSensor::driver_flags`].
    pub fn feedback(&mut self) -> Feedback {
        self.sync();
        Feedback { encoder_counts: self.counts(), load: self.driver.load(), driver_flags: self.flags() }
    }

    /// The description of the world the board is in.
    pub fn description(&self) -> &World {
        &self.spec
    }

    /// The EEPROM.
    pub fn eeprom(&mut self) -> &mut Eeprom {
        &mut self.eeprom
    }

    /// Rotor (shaft) position since power-up in physical 1/256 microsteps, rounded.
    pub fn shaft(&self) -> i64 {
        (self.plan.mech.rotor() - self.plan.mech.start()).round() as i64
    }

    /// Where the driver's field is since power-up in physical 1/256 microsteps: the step counter's
    /// position in the motor's physical direction (the shaft of an ideal motor).
    pub fn commanded(&self) -> i64 {
        self.plan.mech.field() - self.plan.mech.start().round() as i64
    }

    /// Full steps the rotor has fallen behind the field (a multiple of 4; negative = ahead).
    pub fn lost_full_steps(&self) -> i64 {
        self.plan.mech.lost_full_steps()
    }

    /// The axis position in its unit (mm on a linear axis, degrees on a rotary one).
    pub fn axis_position(&self) -> f64 {
        self.plan.mech.rotor() / self.plan.mech.usteps_per_unit()
    }

    /// The load the motor holds or moves against now (N·m).
    pub fn load_torque(&self) -> f64 {
        self.plan.mech.load_torque()
    }

    /// The torque the motor can give now (N·m; 0 = freewheeling).
    pub fn available_torque(&self) -> f64 {
        self.plan.mech.available()
    }

    /// Coil peak current now (A; 0 = off).
    pub fn coil_current(&self) -> f64 {
        self.coil
    }

    /// The energy figure ∫ I_peak² dt so far, in A²·s (see [`crate::driver`]).
    pub fn energy(&self) -> f64 {
        self.driver.energy()
    }

    /// The supply voltage now (V).
    pub fn supply_voltage(&self) -> f64 {
        self.supply
    }

    /// The driver settings last configured (AP 173, 174, 179).
    pub fn driver_settings(&self) -> &DriverSettings {
        &self.driver.settings
    }

    /// Output levels (bit n = OUTn).
    pub fn outputs(&self) -> u8 {
        self.outputs
    }

    /// The reference switches' pull-ups as the firmware last set them (SIO 0, 0 on the TMCM-3110/6110):
    /// kept, no effect on the simulated switches, whose levels are defined by the world.
    pub fn pull_ups(&self) -> u8 {
        self.pull_ups
    }

    /// What the firmware last asked of the driver.
    pub fn drive(&self) -> &DriveState {
        &self.drive
    }

    /// When the firmware last updated the driver.
    pub fn updated(&self) -> Instant {
        self.updated
    }

    /// Time up to which the world has been simulated.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// When the world changes next by itself, if it will: a timeline entry (inputs, a scripted load, a
    /// fault window, encoder slip) or the next level of a bouncing switch. A simulation that steps from
    /// deadline to deadline stops there too, and [`SimBoard::advance`]s the board, so that no change is
    /// stepped over while the motor stands, however seldom the module itself needs to run. (The driver's
    /// standstill flag, AP 208 bit 7, also comes up by itself, but the firmware reads it only with the
    /// board brought to the instant of the read.)
    pub fn next_event(&self) -> Option<Instant> {
        let own = [self.timeline_event(), self.next_bounce()].into_iter().flatten().min();
        self.axes.iter().filter_map(SimBoard::next_event).chain(own).min()
    }

    /// The next timeline entry.
    fn timeline_event(&self) -> Option<Instant> {
        self.plan.events.get(self.next_event).map(|(at, _)| *at)
    }

    /// The next level of a bouncing switch.
    fn next_bounce(&self) -> Option<Instant> {
        self.plan.switches.iter().flatten().filter_map(|s| s.next_change(self.now)).min()
    }

    /// Runs the world forward to `now` (timeline, faults, a freewheeling rotor, the energy figure) with
    /// the driver as last updated. Earlier times are ignored.
    pub fn advance(&mut self, now: Instant) {
        for axis in &mut self.axes {
            axis.advance(now);
        }
        if now <= self.now {
            return;
        }
        while let Some(at) = self.timeline_event() {
            if at > now {
                break;
            }
            self.run_to(at);
            self.fire(at);
        }
        self.run_to(now);
    }

    fn sync(&mut self) {
        if let Some(clock) = &mut self.clock {
            let now = (clock.0)();
            self.advance(now);
        }
    }

    /// Integrates from `self.now` to `t` with nothing changing but the freewheeling rotor.
    fn run_to(&mut self, t: Instant) {
        if t <= self.now {
            return;
        }
        let dt = t - self.now;
        self.driver.integrate(self.coil_square, dt);
        self.plan.mech.coast(dt.micros() as f64 * 1e-6);
        self.now = t;
        self.track_switches();
    }

    /// Applies every event due at or before `t` (the board is at `t`).
    fn fire(&mut self, t: Instant) {
        let mut faults = self.next_event == 0;
        while let Some((at, event)) = self.plan.events.get(self.next_event).cloned() {
            if at > t {
                break;
            }
            self.next_event += 1;
            match event {
                Event::Change(change) => faults |= self.apply(change, t),
                Event::Faults => faults = true,
            }
        }
        if faults {
            self.apply_faults(t);
        }
        self.power();
        self.track_switches();
    }

    /// Recomputes the fault windows' effect at `t`.
    fn apply_faults(&mut self, t: Instant) {
        let open = |from: Instant, until: Option<Instant>| from <= t && until.is_none_or(|u| t < u);
        let windows = self.plan.seizures.iter().filter(|(_, f, u)| open(*f, *u)).map(|(p, _, _)| *p);
        let seized = windows.chain(self.held.iter().copied()).collect();
        self.plan.mech.set_seized(seized);
        let f = &self.spec.faults;
        self.fault_flags = f
            .driver
            .iter()
            .filter(|d| open(d.from.0, d.until.map(|u| u.0)))
            .flat_map(|d| d.flags.iter())
            .fold(0, |acc, flag| acc | flag.bit());
        self.supply = f
            .supply_drop
            .iter()
            .filter(|d| open(d.from.0, d.until.map(|u| u.0)))
            .map(|d| *d.voltage.get_ref())
            .fold(self.plan.supply, f64::min);
        self.supply_factor = supply_factor(self.supply);
    }

    /// AP 208 bits 1..6 now: fault windows plus the module temperature.
    fn error_flags(&self) -> u8 {
        let mut f = self.fault_flags;
        if self.world.temperature >= 100 {
            f |= DriverFlag::Prewarning.bit();
        }
        if self.world.temperature >= 150 {
            f |= DriverFlag::Overtemperature.bit();
        }
        f
    }

    /// Sets the coil current and the motor's available torque from the drive state, supply and faults.
    fn power(&mut self) {
        const SHUTDOWN: u8 = (1 << 1) | (1 << 3) | (1 << 4);
        let flags = self.error_flags();
        let inputs =
            (self.drive.enabled, self.drive.current, self.driver.settings.high_range, flags, self.supply.to_bits());
        if self.powered_by == Some(inputs) {
            // Same inputs, same coil current and torque (bit for bit), and `set_available` with an
            // unchanged torque changes nothing: the speed only counts when the power goes off, and ω is
            // already 0 while powered (only that call and freewheeling, which needs no power, set it).
            self.plan.mech.settle();
            return;
        }
        self.powered_by = Some(inputs);
        let off = flags & SHUTDOWN != 0 || self.supply < self.plan.undervoltage;
        let peak = self.profile.peak_current_ma.map(|ma| f64::from(ma) / 1000.0);
        self.coil = if off { 0.0 } else { driver::coil_current(&self.drive, &self.driver.settings, peak) };
        self.coil_square =
            if off { 0 } else { driver::coil_square(&self.drive, &self.driver.settings, self.profile.peak_current_ma) };
        // A crude supply model: below the nominal 24 V the chopper reaches proportionally less current
        // at speed; only the torque is scaled.
        let supply = self.supply_factor;
        let torque = self.plan.mech.torque_per_amp() * self.coil * std::f64::consts::FRAC_1_SQRT_2 * supply;
        let speed = self
            .field_speed
            .unwrap_or_else(|| f64::from(self.drive.velocity) * self.per_step() as f64 * self.sign() as f64);
        self.plan.mech.set_available(torque, speed);
        self.plan.mech.settle();
    }

    /// The highest speed (pps) at which one 1 ms tick moves the field over at most 64 full-step
    /// positions: at most |v|/1000 + 1 steps of `per_step` µsteps, at most 63 full steps and one more
    /// position.
    fn uncapped_speed(&self) -> u32 {
        ((63 * USTEPS_PER_FULL_STEP / self.per_step() - 1) * 1000) as u32
    }

    fn per_step(&self) -> i64 {
        1i64 << (8 - self.drive.resolution.min(8))
    }

    fn sign(&self) -> i64 {
        if self.drive.reverse {
            -1
        } else {
            1
        }
    }

    fn track_switches(&mut self) {
        let x = self.plan.mech.rotor();
        let now = self.now;
        for s in self.plan.switches.iter_mut().flatten() {
            s.track(x, now);
        }
    }

    fn level(&self, n: usize) -> bool {
        self.plan.switches[n].as_ref().is_some_and(|s| s.level(self.now))
    }

    /// The quiet window of [`StepDriver::quiet`]: how far and how long updates for many motion ticks at
    /// once give what updates for each would (see [`StepDriver::update`]). The board is quiet when
    /// - the rotor follows the field steadily ([`Mechanics::steady`]): it stays (no current, held by
    ///   friction), it moves exactly with the field (a world without loads, locked on the field), or it
    ///   slides at a constant lag against friction and constant torques — then only onwards, in the
    ///   direction it has been moving;
    /// - no switch, jam or end stop lies in the way (the window ends one µstep before one), and no
    ///   bouncing switch is still settling;
    /// - the stallGuard2 measurement reads the same value at every full step of the window: the motor is
    ///   locked on the field (load 0), or its sliding lag keeps the reading off a rounding edge; and the
    ///   speed stays on the same side of the measurement's minimum speed, and below 64 full steps per
    ///   update (the most one update counts).
    ///
    /// It ends at the next timeline entry (inputs, loads, faults, encoder slip).
    fn quiet_window(&mut self, now: Instant, state: &DriveState) -> Option<Quiet> {
        let measuring = state.enabled && self.profile.measures_load();
        if measuring && self.driver.stall_seen() {
            return None;
        }
        let (per_step, sign) = (self.per_step(), self.sign());
        // The physical direction of the motion (0: standing).
        let dir = i64::from(state.velocity.signum()) * sign;
        let steady = self.plan.mech.steady(dir)?;
        if measuring && steady.follow == Follow::Still && self.plan.mech.available() <= 0.0 {
            return None; // measuring a field that moves away from a rotor without current: no steady reading
        }
        let x = self.plan.mech.rotor();
        let (mut lo, mut hi) = (steady.lo, steady.hi);
        for sw in self.plan.switches.iter().flatten() {
            sw.zone(x, &mut lo, &mut hi);
        }
        // The field's moves (physical µsteps) that keep the rotor within `lo..hi`, one µstep clear of the
        // edges (the sliding rotor's position is rounded).
        let field = self.plan.mech.field() as f64;
        let (mut ahead, mut behind) = match steady.follow {
            Follow::Still => (u64::MAX, u64::MAX),
            Follow::Exact | Follow::Sliding => (clear(hi - x), clear(x - lo)),
            // The rotor stays: the field may move up to where its pull frees the rotor.
            Follow::Held => (clear(steady.lag - field), clear(field - steady.lag)),
        };
        if matches!(steady.follow, Follow::Sliding | Follow::Held) || dir == 0 {
            // Sliding only onwards; standing: not at all.
            if dir <= 0 {
                ahead = 0;
            }
            if dir >= 0 {
                behind = 0;
            }
        }
        let (forward, backward) = if sign > 0 { (ahead, behind) } else { (behind, ahead) };
        let (forward, backward) = (forward / per_step as u64, backward / per_step as u64);
        let (mut min_speed, mut max_speed, mut load) = (0u32, u32::MAX, self.driver.load());
        if measuring {
            // A measurement at each full step at or above the minimum speed (|v| · 2^−r full steps per
            // second ≥ the minimum ⇔ |v| ≥ ⌈minimum · 2^r⌉, exactly), at most 64 per update: at most 63
            // full steps of field move per tick of 1 ms (a tick moves at most |v|/1000 + 1 steps).
            let r = self.drive.resolution.min(8);
            let threshold = (self.plan.min_speed * f64::from(1u32 << r)).ceil();
            let threshold = if threshold >= f64::from(u32::MAX) { u32::MAX } else { threshold as u32 };
            if state.velocity.unsigned_abs() >= threshold {
                if steady.follow == Follow::Held {
                    return None; // the rotor does not follow: the readings are 0 (no back-EMF)
                }
                min_speed = threshold;
                max_speed = self.uncapped_speed();
            } else {
                max_speed = threshold - 1;
            }
            let ratio = match steady.follow {
                Follow::Exact => 0.0,
                _ => {
                    // The reading rounds 1023 · (1 − sin θ): the lag's angle θ is the same at every position
                    // but for the rounding of the rotor's position, 2⁻¹⁶ µstep within 2³⁶ µsteps: some 10⁻⁷
                    // of a reading, far inside the margin kept from a rounding edge.
                    let angle = self.plan.mech.load_angle().abs();
                    let ratio = if angle >= std::f64::consts::FRAC_PI_2 { 1.0 } else { angle.sin() };
                    let reading = 1023.0 * (1.0 - ratio);
                    let edge = (reading - reading.floor() - 0.5).abs();
                    if x.abs().max(field.abs()) > (1u64 << 36) as f64 || edge < 1e-3 {
                        return None;
                    }
                    ratio
                }
            };
            load = driver::load_value(ratio, self.driver.settings.stall_threshold);
        }
        // A standing motor's driver raises its standstill flag (AP 208 bit 7) by itself, 2^20 driver clocks
        // after the last step: a reading that changes without a move ends the window. (While the motor
        // moves, every update brings that flag's state with it, and a span ends at every instruction that
        // could read it; ending spans there would cut them into 65 ms pieces for nothing.)
        // (`now`, the module's clock, not the board's: a standing motor's board hears of nothing for long.)
        let standstill = if dir == 0 { self.driver.standstill_at(now.max(self.now)) } else { None };
        let until = [self.timeline_event(), self.next_bounce(), standstill].into_iter().flatten().min();
        Some(Quiet { until, forward, backward, min_speed, max_speed, load })
    }

    /// [`StepDriver::period`]: a rotor locked on the field at whole µsteps is periodic in the field's
    /// position where its encoder counts are exact (the window is narrowed to there).
    fn period_window(&mut self, state: &DriveState, quiet: &mut Quiet) -> u64 {
        let (per_step, sign) = (self.per_step(), self.sign());
        let dir = i64::from(state.velocity.signum()) * sign;
        if self.plan.mech.steady(dir).map(|s| s.follow) != Some(Follow::Exact) {
            return 0;
        }
        let (mut ahead, mut behind) = (u64::MAX, u64::MAX);
        let period = self.encoder_period(&mut ahead, &mut behind);
        let (forward, backward) = if sign > 0 { (ahead, behind) } else { (behind, ahead) };
        quiet.forward = quiet.forward.min(forward / per_step as u64);
        quiet.backward = quiet.backward.min(backward / per_step as u64);
        // In µsteps of the resolution in force: the fewest whose physical move is a multiple of it.
        period / gcd(period, per_step as u64)
    }

    /// The period (physical µsteps) in which a rotor locked on the field at whole µsteps reads the same
    /// encoder counts, moved on by a whole number, per [`StepDriver::period`]; 0 if the counts are not
    /// provably periodic. Narrows `ahead`/`behind` (physical µsteps, physical directions) to where they
    /// are.
    ///
    /// The counts are ⌊(x − zero) · cpr / upr⌋ computed as ((x − zero) / upr) · cpr in `f64` (`counts`).
    /// With g = gcd(upr, cpr) and p = upr / g, the exact value is a whole number exactly when x − zero is
    /// a multiple j·p; then the quotient is j / g, exact in `f64` when g is a power of two, and so is the
    /// product. Elsewhere the exact value lies at least 1/p from a whole number, and the two roundings
    /// (relative error below 2⁻⁵²) cannot cross one while |x − zero| · cpr < 2⁵⁰. So within that range the
    /// floor is the exact one, and the counts move on by cpr/g whenever x moves on by p.
    fn encoder_period(&mut self, ahead: &mut u64, behind: &mut u64) -> u64 {
        let Some(model) = self.profile.encoder else { return 1 }; // no encoder: nothing to read
        let (ssi, per_rev) = match self.spec.encoder {
            Some(e) => (e.kind == EncoderType::Ssi, e.counts_per_rev),
            None => (model.kind == EncoderKind::Ssi, model.counts_per_rev),
        };
        if ssi != self.driver.settings.ssi_encoder {
            return 1; // it reads 0 everywhere
        }
        let (x, zero, upr) = (self.plan.mech.rotor(), self.plan.encoder_zero, self.plan.mech.usteps_per_rev());
        if ssi || !whole(x) || !whole(zero) || !whole(upr) || !(1.0..4_294_967_296.0).contains(&upr) || per_rev == 0 {
            return 0;
        }
        let (upr, cpr) = (upr as u64, u64::from(per_rev));
        // p for this upr and cpr (0: g is no power of two) and the reach below, computed once for both (a
        // span asks often).
        let (period, reach) = match self.encoder_period_of {
            Some((u, c, p, r)) if u == upr && c == cpr => (p, r),
            _ => {
                let g = gcd(upr, cpr);
                let p = if g.is_power_of_two() { upr / g } else { 0 };
                // |x − zero| below 2⁵⁰ / cpr all through the window.
                let r = ((1u64 << 50) / cpr) as f64;
                self.encoder_period_of = Some((upr, cpr, p, r));
                (p, r)
            }
        };
        if period == 0 {
            return 0;
        }
        let d = x - zero;
        if d.abs() >= reach {
            return 0;
        }
        *ahead = (*ahead).min((reach - d) as u64 - 1);
        *behind = (*behind).min((reach + d) as u64 - 1);
        period
    }

    /// Encoder counts now (see [`Feedback::encoder_counts`]).
    fn counts(&self) -> i64 {
        let Some(model) = self.profile.encoder else { return 0 };
        let (ssi, per_rev) = match self.spec.encoder {
            Some(e) => (e.kind == EncoderType::Ssi, e.counts_per_rev),
            None => (model.kind == EncoderKind::Ssi, model.counts_per_rev),
        };
        if ssi != self.driver.settings.ssi_encoder {
            return 0; // nothing of that kind on the selected input
        }
        let turns = (self.plan.mech.rotor() - self.plan.encoder_zero) / self.plan.mech.usteps_per_rev();
        let counts = floor_i64(turns * f64::from(per_rev)) + self.encoder_slip;
        if ssi {
            counts.rem_euclid(i64::from(per_rev.max(1)))
        } else {
            counts
        }
    }

    /// AP 208 now.
    fn flags(&self) -> u8 {
        self.driver.flags(self.now, self.error_flags())
    }
}

/// How many whole µsteps fit into `room` (a distance to an edge, ≥ 0 or infinite) with one µstep to
/// spare.
fn clear(room: f64) -> u64 {
    if room.is_nan() || room < 2.0 {
        0
    } else if room >= 1e18 {
        u64::MAX
    } else {
        room as u64 - 1
    }
}

/// `x.floor() as i64` without the `floor` library call (x86-64 has no rounding instruction before
/// SSE4.1): truncate, and step down when that went up. The same for every `x`: saturating at the ends
/// (then `t as f64 > x` only for `x` below `i64::MIN`, where `t` stays `i64::MIN`), 0 for NaN.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if t as f64 > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

impl Nvm for SimBoard {
    type Error = NvmError;
    fn capacity(&self) -> usize {
        self.eeprom.capacity()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), NvmError> {
        self.eeprom.read(offset, buf)
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), NvmError> {
        self.eeprom.write(offset, data)
    }
}

impl Inputs for SimBoard {
    fn digital_inputs(&mut self) -> u8 {
        self.sync();
        self.world.inputs & self.profile.input_mask()
    }
}

impl Analog for SimBoard {
    fn analog_input(&mut self, channel: u8) -> u16 {
        self.sync();
        if channel == 0 {
            self.world.analog.min(4095)
        } else {
            0
        }
    }
    fn temperature(&mut self) -> i32 {
        self.sync();
        self.world.temperature
    }
    fn supply_voltage(&mut self) -> u16 {
        self.sync();
        (self.supply * 10.0).round().clamp(0.0, 65535.0) as u16
    }
}

impl Outputs for SimBoard {
    fn set_outputs(&mut self, bits: u8) {
        self.outputs = bits & self.profile.output_mask();
    }
    fn set_pull_ups(&mut self, bits: u8) {
        self.pull_ups = bits;
    }
}

impl SwitchInputs for SimBoard {
    fn switches(&mut self, motor: usize) -> Switches {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].switches(0);
        }
        self.sync();
        Switches { left: self.level(0), right: self.level(1), home: self.level(2) }
    }
}

impl StepDriver for SimBoard {
    fn update(&mut self, motor: usize, now: Instant, state: &DriveState) {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].update(0, now, state);
        }
        self.advance(now);
        // Whether the field moved with the step counter (see `field_speed`); a new resolution says nothing
        // about the field's speed. A field that stood while the counter moved (a closed loop holding a
        // seized rotor: the ramp runs on) stood: its speed is 0, not the ramp's (a counter set without a
        // move, SAP 1, is taken the same way; the next tick's update says again how the field moves).
        let counted = i64::from(state.position.wrapping_sub(self.drive.position));
        let own_speed = state.moved != counted && state.resolution == self.drive.resolution;
        let dt = now.saturating_duration_since(self.updated).micros();
        self.drive = *state;
        self.power();
        let moved = state.moved.saturating_mul(self.per_step()).saturating_mul(self.sign());
        if !own_speed {
            self.field_speed = None;
        } else if dt > 0 {
            self.field_speed = Some(moved as f64 * 1e6 / dt as f64);
        }
        if moved != 0 {
            self.driver.stepped(self.now);
            let old = self.plan.mech.field();
            let new = old.saturating_add(moved);
            let rotor = self.plan.mech.rotor();
            let was_locked = self.plan.mech.locked();
            let mut stalled = self.plan.mech.drive_to(new);
            // Locked on the field before and after, the rotor went exactly as far as the field: following.
            let locked = was_locked && self.plan.mech.locked();
            if !locked {
                // Not following: the rotor went less than half as far as the field, in its direction.
                let followed = (self.plan.mech.rotor() - rotor) * moved.signum() as f64;
                stalled |= followed * 2.0 < moved.unsigned_abs() as f64;
            }
            let full = |p: i64| p.div_euclid(USTEPS_PER_FULL_STEP);
            let crossings = full(new).abs_diff(full(old));
            // Full steps per second: x / 2^r, as x · 2^−r (the same number exactly, without a division).
            let speed = f64::from(state.velocity).abs() * INVERSE_POWERS_OF_TWO[usize::from(state.resolution.min(8))];
            let ratio = if locked {
                0.0 // the rotor exactly on the field (trivial world): load angle ±0, sin(0) = 0
            } else {
                let angle = self.plan.mech.load_angle().abs();
                if angle >= std::f64::consts::FRAC_PI_2 {
                    1.0
                } else {
                    angle.sin()
                }
            };
            if state.enabled && self.profile.measures_load() {
                // At most 64 measurements per update, as many as one 1 ms tick can make at speeds up to
                // `uncapped_speed` — below it the limit is left out, so that an update for many ticks (see
                // `quiet_window`) counts what the updates of each would have.
                let capped = crossings > 64 && state.velocity.unsigned_abs() > self.uncapped_speed();
                let counted = if capped { 64 } else { crossings };
                self.driver.measure(counted, speed, ratio, stalled);
            }
            self.track_switches();
        }
        self.updated = now;
    }

    fn configure(&mut self, motor: usize, settings: &DriverSettings) {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].configure(0, settings);
        }
        self.driver.settings = *settings;
        self.power();
    }

    fn quiet(&mut self, motor: usize, now: Instant, state: &DriveState) -> Option<Quiet> {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].quiet(0, now, state);
        }
        self.sync();
        self.quiet_window(now, state)
    }

    fn period(&mut self, motor: usize, state: &DriveState, quiet: &mut Quiet) -> u64 {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].period(0, state, quiet);
        }
        self.period_window(state, quiet)
    }

    fn counts_at(&mut self, motor: usize, state: &DriveState, ahead: i64) -> Option<i64> {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].counts_at(0, state, ahead);
        }
        // As `counts` reads them, with the rotor (on the field) `ahead` µsteps of the resolution in force
        // further on.
        let model = self.profile.encoder?;
        let (ssi, per_rev) = match self.spec.encoder {
            Some(e) => (e.kind == EncoderType::Ssi, e.counts_per_rev),
            None => (model.kind == EncoderKind::Ssi, model.counts_per_rev),
        };
        if ssi || self.driver.settings.ssi_encoder {
            return None;
        }
        let per_step = 1i64 << (8 - state.resolution.min(8));
        let sign = if state.reverse { -1 } else { 1 };
        let x = self.plan.mech.rotor() + (ahead * per_step * sign) as f64;
        let turns = (x - self.plan.encoder_zero) / self.plan.mech.usteps_per_rev();
        Some(floor_i64(turns * f64::from(per_rev)) + self.encoder_slip)
    }
}

/// The load measurement: stallGuard2 when the model's driver is a TMC262 (else no measurement is taken
/// in [`StepDriver::update`], and the load stays 1023).
impl LoadSensor for SimBoard {
    fn load(&mut self, motor: usize) -> u16 {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].load(0);
        }
        self.sync();
        self.driver.load()
    }

    fn load_measurements(&mut self, motor: usize) -> u32 {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].load_measurements(0);
        }
        self.sync();
        self.driver.measurements()
    }

    fn driver_flags(&mut self, motor: usize) -> u8 {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].driver_flags(0);
        }
        self.sync();
        self.flags()
    }
}

/// The model's encoder (none: 0 counts).
impl EncoderCounter for SimBoard {
    fn encoder_counts(&mut self, motor: usize) -> i64 {
        if motor > 0 && motor <= self.axes.len() {
            return self.axes[motor - 1].encoder_counts(0);
        }
        self.sync();
        self.counts()
    }
}

/// Whether `x` is a whole number (of at most 63 bits), without a rounding library call.
#[inline]
fn whole(x: f64) -> bool {
    x == (x as i64) as f64
}

/// The greatest common divisor (0 with 0 gives 0).
fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_core::model::pd28_1021::SPEC;
    use tmcl_core::param::persist;
    use tmcl_core::{Duration, Module};
    use tmcl_wire::{Command, MoveTarget};

    fn module() -> Module<SimBoard> {
        Module::new(SimBoard::in_memory(persist::capacity(&SPEC)), &SPEC, Instant::ZERO)
    }

    #[test]
    fn one_revolution_moves_the_shaft_and_the_encoder() {
        let mut m = module();
        let t = Instant::ZERO;
        m.execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(51200) }, t).unwrap();
        m.poll(t + Duration::from_secs(3), &mut |_: &[u8]| {});
        assert_eq!(m.board().shaft(), MICROSTEPS_PER_REV);
        assert_eq!(m.board_mut().feedback().encoder_counts, 1024);
    }

    #[test]
    fn floor_i64_is_floor_as_i64() {
        let mut xs = vec![0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5, 1e300, -1e300, f64::NAN, f64::INFINITY];
        xs.extend([f64::NEG_INFINITY, f64::MIN_POSITIVE, -f64::MIN_POSITIVE, 4503599627370495.5, -4503599627370495.5]);
        xs.extend([9.223372036854776e18, -9.223372036854776e18, -9.223372036854778e18, 1023.9999999999999]);
        for k in -3000..3000 {
            xs.push(f64::from(k) * 0.37 + 1e-9 * f64::from(k));
        }
        for x in xs {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn switch_zones() {
        let world = World::from_toml_str("[switches.right]\nat = [\"10000 usteps\", \"20000 usteps\"]").unwrap();
        let mut m = module();
        m.board_mut().set_world(world).unwrap();
        let t = Instant::ZERO;
        m.execute(Command::Ror { motor: 0, velocity: 5000 }, t).unwrap();
        m.poll(t + Duration::from_secs(4), &mut |_: &[u8]| {});
        let shaft = m.board().shaft();
        assert!((10_000..10_200).contains(&shaft), "stopped at the right switch: {shaft}");
        assert!(m.board_mut().switches(0).right);
    }
}

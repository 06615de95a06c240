//! The world around the simulated motor, as described in a TOML world file (`docs/world.md`).
//!
//! A [`World`] says what the motor is (full steps, holding torque, inertia, detent), what it drives (a
//! rotary axis or a linear stage with a lead and hard end stops), where the switches are, which loads act
//! on the shaft (friction, a spring, a constant torque, jams, a time script), what the inputs read over
//! time, and which faults to inject. [`World::default`] is a free NEMA 11 axis with nothing attached: the
//! rotor follows every step, and the encoder reads the shaft.
//!
//! Every table rejects unknown keys; [`World::from_toml_str`] reports the key and the line of the first
//! mistake ([`WorldError`]).
//!
//! # Units
//!
//! Torques are in N·m at the motor shaft, inertias in kg·m², currents in A RMS, times in seconds (a
//! number) or a string with a unit (`"250 ms"`, `"2 s"`, `"1 min"`). A position ([`Pos`]) is a number in
//! the axis unit (mm on a linear axis, degrees on a rotary one) or a string with a unit: `"12.5 mm"`,
//! `"90 deg"`, `"2 rev"`, `"8 fullsteps"`, `"51200 usteps"` (1/256 microsteps of the motor, the unit the
//! simulator works in, PD28-1021 manual §6.1).

use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;
use std::fmt;
use tmcl_core::Instant;
/// A value with its place in the world file (re-exported from `toml`); build one with `Spanned::new(0..0, v)`.
pub use toml::Spanned;

/// A position on the axis, as written in the world file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pos {
    /// A bare number: mm on a linear axis, degrees on a rotary axis.
    Axis(f64),
    /// Millimetres (linear axes only).
    Mm(f64),
    /// Degrees of the output (rotary axes only).
    Deg(f64),
    /// Motor revolutions.
    Rev(f64),
    /// Motor full steps.
    FullSteps(f64),
    /// 1/256 microsteps of the motor.
    Usteps(f64),
}

impl Default for Pos {
    fn default() -> Pos {
        Pos::Axis(0.0)
    }
}

impl Pos {
    fn parse(s: &str) -> Result<Pos, String> {
        let s = s.trim();
        let split = s.find(|c: char| c.is_ascii_alphabetic() || c == 'µ' || c == '°').unwrap_or(s.len());
        let (number, unit) = (s[..split].trim(), s[split..].trim());
        let v: f64 = number.parse().map_err(|_| format!("`{s}` is not a position (a number and a unit)"))?;
        if !v.is_finite() {
            return Err(format!("`{s}` is not a finite position"));
        }
        Ok(match unit {
            "" => Pos::Axis(v),
            "mm" => Pos::Mm(v),
            "deg" | "°" => Pos::Deg(v),
            "rev" | "revs" => Pos::Rev(v),
            "fullstep" | "fullsteps" => Pos::FullSteps(v),
            "ustep" | "usteps" | "µstep" | "µsteps" => Pos::Usteps(v),
            u => return Err(format!("unknown position unit `{u}` (mm, deg, rev, fullsteps, usteps)")),
        })
    }
}

impl<'de> Deserialize<'de> for Pos {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Pos, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Pos;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a position: a number in the axis unit or a string such as \"12 mm\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Pos, E> {
                Ok(Pos::Axis(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Pos, E> {
                Ok(Pos::Axis(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Pos, E> {
                Pos::parse(v).map_err(E::custom)
            }
        }
        d.deserialize_any(V)
    }
}

/// A time since power-up, as written in the world file: seconds, or a string with a unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time(pub Instant);

impl<'de> Deserialize<'de> for Time {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Time, D::Error> {
        struct V;
        fn secs<E: de::Error>(s: f64) -> Result<Time, E> {
            if !(0.0..1e9).contains(&s) {
                return Err(E::custom(format!("time {s} s is out of range (0 .. 1e9 s)")));
            }
            Ok(Time(Instant::from_micros((s * 1e6).round() as u64)))
        }
        impl Visitor<'_> for V {
            type Value = Time;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a time: seconds, or a string such as \"250 ms\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Time, E> {
                secs(v)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Time, E> {
                secs(v as f64)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Time, E> {
                let v = v.trim();
                let split = v.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(v.len());
                let n: f64 = v[..split].trim().parse().map_err(|_| E::custom(format!("`{v}` is not a time")))?;
                let scale = match v[split..].trim() {
                    "" | "s" => 1.0,
                    "ms" => 1e-3,
                    "us" => 1e-6,
                    "min" => 60.0,
                    u => return Err(E::custom(format!("unknown time unit `{u}` (us, ms, s, min)"))),
                };
                secs(n * scale)
            }
        }
        d.deserialize_any(V)
    }
}

/// The motor (`[motor]`). Defaults: a NEMA 11 motor of the PD28-1021 class.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotorSpec {
    /// Full steps per revolution; a multiple of 4 (one electrical period is 4 full steps). Default 200.
    pub full_steps: Spanned<u32>,
    /// Holding torque in N·m at `rated_current`. Default 0.06.
    pub holding_torque: Spanned<f64>,
    /// The RMS current at which `holding_torque` is reached, in A. Default 0.7 (the module's 100 % in the
    /// low range, AP 179 = 1). Torque is taken proportional to current (no saturation).
    pub rated_current: Spanned<f64>,
    /// Rotor inertia in kg·m². Default 9e-7 (9 g·cm²).
    pub rotor_inertia: Spanned<f64>,
    /// Detent torque (unpowered holding) in N·m, period one full step. Default 0.
    pub detent_torque: Spanned<f64>,
    /// Viscous damping in N·m·s/rad, acting while the motor freewheels. Default 5e-5.
    pub damping: Spanned<f64>,
}

impl Default for MotorSpec {
    fn default() -> MotorSpec {
        MotorSpec {
            full_steps: Spanned::new(0..0, 200),
            holding_torque: Spanned::new(0..0, 0.06),
            rated_current: Spanned::new(0..0, 0.7),
            rotor_inertia: Spanned::new(0..0, 9e-7),
            detent_torque: Spanned::new(0..0, 0.0),
            damping: Spanned::new(0..0, 5e-5),
        }
    }
}

/// What kind of axis the motor drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisKind {
    /// A rotating output on the motor shaft; positions in degrees.
    #[default]
    Rotary,
    /// A linear stage (lead screw or belt); positions in mm.
    Linear,
}

/// The axis (`[axis]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AxisSpec {
    /// `"rotary"` (default) or `"linear"`.
    pub kind: AxisKind,
    /// Travel per motor revolution in mm (linear axes). Default 2.
    pub lead: Spanned<f64>,
    /// Hard mechanical end stops `[low, high]`; none by default. The rotor cannot pass them.
    pub travel: Option<Spanned<[Pos; 2]>>,
    /// Where the axis is at power-up (step counter 0). Default 0.
    pub start: Spanned<Pos>,
    /// Load inertia reflected to the motor shaft in kg·m² (adds to the rotor's). Default 0.
    pub load_inertia: Spanned<f64>,
}

impl Default for AxisSpec {
    fn default() -> AxisSpec {
        AxisSpec {
            kind: AxisKind::Rotary,
            lead: Spanned::new(0..0, 2.0),
            travel: None,
            start: Spanned::new(0..0, Pos::default()),
            load_inertia: Spanned::new(0..0, 0.0),
        }
    }
}

/// Which electrical level a pressed switch gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Active {
    /// The input reads active (with normal polarity, GP 79 = 0) while the switch is pressed.
    #[default]
    High,
    /// The input reads active while the switch is *released* (a normally-closed switch); the firmware
    /// needs GP 79 = 1 (end switches) or the +128 search mode (home switch) to see it right.
    Low,
}

/// Contact bounce after each edge of a switch.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bounce {
    /// How long the contact bounces after an edge.
    pub time: Time,
    /// How many times it falls back to the old level in that time (evenly spread). Default 3.
    #[serde(default = "three")]
    pub count: u32,
}

fn three() -> u32 {
    3
}

/// One switch (`[switches.left]`, `[switches.right]`, `[switches.home]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SwitchSpec {
    /// The positions `[from, to]` where the switch is pressed (inclusive).
    pub at: Spanned<[Pos; 2]>,
    /// `"high"` (default) or `"low"`.
    #[serde(default)]
    pub active: Active,
    /// Optional contact bounce.
    #[serde(default)]
    pub bounce: Option<Bounce>,
    /// Rotary axes only: `true` where the switch is met again every turn of the shaft (a rotary table's
    /// switch: pressed at `at` plus any whole number of revolutions). Default `false`: pressed only at
    /// `at`, positions counted on from power-up (a limit of a shaft that turns many times).
    #[serde(default)]
    pub every_turn: bool,
}

/// The three reference switches (`[switches]`).
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SwitchesSpec {
    /// Left stop switch (negative end).
    pub left: Option<SwitchSpec>,
    /// Right stop switch (positive end).
    pub right: Option<SwitchSpec>,
    /// Home switch.
    pub home: Option<SwitchSpec>,
}

/// A spring pulling the axis back to `rest`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spring {
    /// N·m at the motor per axis unit (mm or degree) away from `rest`.
    pub rate: Spanned<f64>,
    /// Where the spring is relaxed. Default 0.
    #[serde(default = "origin")]
    pub rest: Spanned<Pos>,
}

/// A region where moving takes a high torque (`[[load.jam]]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jam {
    /// Where the region begins and ends `[from, to]`.
    pub at: Spanned<[Pos; 2]>,
    /// Torque in N·m needed to move inside the region (either way). Default 100: solid.
    #[serde(default = "solid")]
    pub torque: Spanned<f64>,
}

fn origin() -> Spanned<Pos> {
    Spanned::new(0..0, Pos::default())
}

fn solid() -> Spanned<f64> {
    Spanned::new(0..0, 100.0)
}

/// A step in the scripted external torque (`[[load.script]]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScriptedLoad {
    /// From when.
    pub at: Time,
    /// External torque in N·m from then on (replaces the previous step); positive pushes toward +.
    pub torque: f64,
}

/// The loads on the shaft (`[load]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoadSpec {
    /// Coulomb friction in N·m, opposing motion. Default 0.
    pub friction: Spanned<f64>,
    /// A constant torque in N·m (gravity on a vertical axis); positive pushes toward +. Default 0.
    pub constant: f64,
    /// An optional spring.
    pub spring: Option<Spring>,
    /// Jam regions.
    pub jam: Vec<Jam>,
    /// A time script of an external torque.
    pub script: Vec<ScriptedLoad>,
}

impl Default for LoadSpec {
    fn default() -> LoadSpec {
        LoadSpec { friction: Spanned::new(0..0, 0.0), constant: 0.0, spring: None, jam: Vec::new(), script: Vec::new() }
    }
}

/// A change of the inputs at a time (`[[inputs.timeline]]`).
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputChange {
    /// When.
    pub at: Time,
    /// All digital inputs as a mask (bit n = INn).
    #[serde(default)]
    pub digital: Option<u8>,
    /// IN0 level.
    #[serde(default)]
    pub in0: Option<bool>,
    /// IN1 level.
    #[serde(default)]
    pub in1: Option<bool>,
    /// IN2 level.
    #[serde(default)]
    pub in2: Option<bool>,
    /// IN3 level.
    #[serde(default)]
    pub in3: Option<bool>,
    /// Analog input 0, 0..=4095.
    #[serde(default)]
    pub analog: Option<Spanned<u16>>,
    /// Module temperature in °C.
    #[serde(default)]
    pub temperature: Option<i32>,
}

/// The inputs (`[inputs]`): levels at power-up and a timeline of changes.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InputsSpec {
    /// Digital inputs at power-up (bit n = INn). Default 0.
    pub digital: u8,
    /// Analog input 0 at power-up, 0..=4095. Default 0.
    pub analog: Spanned<u16>,
    /// Module temperature at power-up in °C. Default 25.
    pub temperature: i32,
    /// Changes over time.
    pub timeline: Vec<InputChange>,
}

impl Default for InputsSpec {
    fn default() -> InputsSpec {
        InputsSpec { digital: 0, analog: Spanned::new(0..0, 0), temperature: 25, timeline: Vec::new() }
    }
}

/// The shaft seizes at a position (`[[faults.stall]]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StallFault {
    /// Where: once the rotor reaches it, it cannot move past it either way.
    pub at: Spanned<Pos>,
    /// From when (default: power-up).
    #[serde(default)]
    pub from: Time,
    /// Until when (default: forever).
    #[serde(default)]
    pub until: Option<Time>,
}

/// The encoder loses counts (`[[faults.encoder_slip]]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderSlip {
    /// When.
    pub at: Time,
    /// Counts (1024 per revolution) added to the encoder reading, signed.
    pub counts: i64,
}

/// A TMC262 error condition (AP 208, manual chapter 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriverFlag {
    /// Bit 1: overtemperature shutdown (the bridges are off).
    Overtemperature,
    /// Bit 2: overtemperature pre-warning.
    Prewarning,
    /// Bit 3: short to ground, coil A (the bridges are off).
    ShortA,
    /// Bit 4: short to ground, coil B (the bridges are off).
    ShortB,
    /// Bit 5: open load, coil A.
    OpenA,
    /// Bit 6: open load, coil B.
    OpenB,
}

impl DriverFlag {
    /// The AP 208 bit value.
    pub fn bit(self) -> u8 {
        match self {
            DriverFlag::Overtemperature => 1 << 1,
            DriverFlag::Prewarning => 1 << 2,
            DriverFlag::ShortA => 1 << 3,
            DriverFlag::ShortB => 1 << 4,
            DriverFlag::OpenA => 1 << 5,
            DriverFlag::OpenB => 1 << 6,
        }
    }

    /// Whether the driver shuts its bridges down while the flag is set (TMC262: overtemperature, short).
    pub fn shuts_down(self) -> bool {
        matches!(self, DriverFlag::Overtemperature | DriverFlag::ShortA | DriverFlag::ShortB)
    }
}

/// Driver error flags over a time window (`[[faults.driver]]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriverFault {
    /// From when.
    pub from: Time,
    /// Until when (default: forever).
    #[serde(default)]
    pub until: Option<Time>,
    /// Which flags.
    pub flags: Vec<DriverFlag>,
}

/// The supply voltage drops over a time window (`[[faults.supply_drop]]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupplyDrop {
    /// From when.
    pub from: Time,
    /// Until when (default: forever).
    #[serde(default)]
    pub until: Option<Time>,
    /// The supply in V meanwhile.
    pub voltage: Spanned<f64>,
}

/// Faults to inject (`[faults]`).
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaultsSpec {
    /// The shaft seizes at a position.
    pub stall: Vec<StallFault>,
    /// The encoder slips.
    pub encoder_slip: Vec<EncoderSlip>,
    /// Driver error flags.
    pub driver: Vec<DriverFault>,
    /// Supply drops.
    pub supply_drop: Vec<SupplyDrop>,
}

/// The driver and its supply (`[driver]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriverSpec {
    /// Supply voltage in V. Default 24 (manual §1: 24 V nominal, 10..27 V).
    pub supply_voltage: Spanned<f64>,
    /// Below this supply voltage in V the bridges are off. Default 8.
    pub undervoltage: Spanned<f64>,
    /// stallGuard2 takes measurements only above this speed, in motor revolutions per second. Default 0.2.
    pub stallguard_min_speed: Spanned<f64>,
    /// Encoder absolute zero (AP 215 = 0, clear-on-null), as a position. Default 0.
    pub encoder_zero: Spanned<Pos>,
}

impl Default for DriverSpec {
    fn default() -> DriverSpec {
        DriverSpec {
            supply_voltage: Spanned::new(0..0, 24.0),
            undervoltage: Spanned::new(0..0, 8.0),
            stallguard_min_speed: Spanned::new(0..0, 0.2),
            encoder_zero: Spanned::new(0..0, Pos::default()),
        }
    }
}

/// The kind of encoder on the motor (`[encoder] kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EncoderType {
    /// Incremental A/B/N: counts from power-up.
    Abn,
    /// Absolute single-turn on SSI: the angle within one revolution.
    Ssi,
}

/// The encoder on the motor (`[encoder]`), for a module that takes an external one (TMCM-1310: A/B/N or
/// SSI, its manual chapter 1). Without the table the module's own encoder is there (the PD28-1021's
/// sensOstep; the TMCM-1310's default: A/B/N, 4096 counts per revolution).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderSpec {
    /// A/B/N or SSI.
    pub kind: EncoderType,
    /// Counts per motor revolution (A/B/N: lines × 4), at least 4.
    pub counts_per_rev: u32,
}

/// The whole world. [`World::default`] is a free rotary NEMA 11 axis with no switches, no load and no
/// faults.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct World {
    /// The motor.
    pub motor: MotorSpec,
    /// The axis it drives.
    pub axis: AxisSpec,
    /// The driver and supply.
    pub driver: DriverSpec,
    /// Reference switches.
    pub switches: SwitchesSpec,
    /// Loads on the shaft.
    pub load: LoadSpec,
    /// Inputs and their timeline.
    pub inputs: InputsSpec,
    /// Faults to inject.
    pub faults: FaultsSpec,
    /// The encoder, if it is not the module's own.
    pub encoder: Option<EncoderSpec>,
    /// `[motors.N]` as written: what motor N's axis has other than the file's top level (a module with
    /// several motors; see [`World::of_motor`]).
    #[serde(rename = "motors")]
    pub motor_tables: std::collections::BTreeMap<String, toml::Table>,
    /// The world of each motor with a `[motors.N]` table: the top level with that table merged over it
    /// (filled by [`World::from_toml_str`]).
    #[serde(skip)]
    pub motors: Vec<(usize, World)>,
}

/// What is wrong with a world file: the key, its line (1-based) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}{}: {message}", .file.as_ref().map(|f| format!("{f}: ")).unwrap_or_default(), place(*.line, .key))]
pub struct WorldError {
    /// The file, if the world came from one.
    pub file: Option<String>,
    /// The dotted key path (`switches.left.at`), if known.
    pub key: Option<String>,
    /// The line (1-based), if known.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

fn place(line: Option<usize>, key: &Option<String>) -> String {
    match (line, key) {
        (Some(l), Some(k)) => format!("line {l}, key `{k}`"),
        (Some(l), None) => format!("line {l}"),
        (None, Some(k)) => format!("key `{k}`"),
        (None, None) => "world".into(),
    }
}

/// A value the world check rejected, with the span of the value in the source (empty = not from a file).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Invalid {
    pub span: std::ops::Range<usize>,
    pub key: &'static str,
    pub message: String,
}

impl Invalid {
    /// A rejected value at `span` under `key`.
    pub fn new(span: std::ops::Range<usize>, key: &'static str, message: impl Into<String>) -> Invalid {
        Invalid { span, key, message: message.into() }
    }

    pub(crate) fn into_error(self, source: Option<&str>) -> WorldError {
        let line = match source {
            Some(src) if self.span.end > 0 => Some(line_of(src, self.span.start)),
            _ => None,
        };
        WorldError { file: None, key: Some(self.key.into()), line, message: self.message }
    }
}

pub(crate) fn line_of(source: &str, offset: usize) -> usize {
    source.as_bytes()[..offset.min(source.len())].iter().filter(|b| **b == b'\n').count() + 1
}

impl World {
    /// A free axis: the default world.
    pub fn free() -> World {
        World::default()
    }
}

//! The trace of a run: one row per sample and per program event, each value in a typed column with its
//! unit, plus the program's events and every change of the digital inputs, outputs and switches.
//!
//! A run hands its rows to a [`Sink`]: [`Csv`] writes them as they come (an hour sampled every
//! millisecond never sits in memory), [`Trace`] keeps them as columns for a program (the Python package,
//! the plot), [`Tee`] does both.
//!
//! # Columns by meaning
//! Which columns a run has is decided from the model's parameter tables, by the role a parameter plays,
//! never by its number: the stallGuard2 load value is the parameter with [`Role::LoadValue`] (AP 206 on
//! the PD28-1021), the closed loop's position error the one with [`Role::PositionError`] (AP 237 on the
//! TMCM-1310). A column whose parameter the model does not have is absent from the trace, never a column
//! of made-up zeros; a value the module refuses to give is an empty cell (`None`).
//!
//! The columns, in order (the CSV header; `tmcl run --help` lists them with their units and a test checks
//! the two agree): `time_s`, [`Quantity::FIXED`], a `varN` per user variable, [`Quantity::DRIVE`] and
//! [`Quantity::CLOSED_LOOP`] with `drive`, [`Quantity::VelocityUnits`] on a model with velocity units of
//! its own, then on a model with several motors the per-axis columns of motors 1, 2, … ([`Column::motor`]:
//! `target_position_m1`, `actual_position_m1`, `velocity_m1`, with `drive` the load value, current scale
//! and encoder, and the velocity in the model's units, each named with `_mN`), and `event`.
//!
//! Every value is an integer, except two with six decimals that are formatted from integers: the time
//! (from integer microseconds) and the coil energy (from integer µA²·s). The same run gives byte-identical
//! files everywhere.

use serde::{Deserialize, Serialize};
use std::fmt::{self, Write as _};
use std::io::{self, Write};
use tmcl_core::model::Role;

/// What a column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// The ramp's target position (AP 0), µsteps.
    TargetPosition,
    /// The actual position (AP 1): the step counter, or the encoder while a closed loop is closed; µsteps.
    ActualPosition,
    /// The ramp's actual velocity (AP 3) in pps, signed, whatever the model's own unit.
    Velocity,
    /// The program's accumulator.
    Accumulator,
    /// The program's X register.
    X,
    /// The program counter: the address of the next instruction.
    Pc,
    /// The digital outputs, bit n = OUTn.
    Outputs,
    /// User variable N (bank 2).
    Variable(u8),
    /// `drive`: the stallGuard2 load value ([`Role::LoadValue`], AP 206), 0..1023.
    Load,
    /// `drive`: the coolStep current scale ([`Role::ActualCurrent`], AP 180), 0..31.
    CurrentScale,
    /// `drive`: the encoder position ([`Role::EncoderPosition`], AP 209), µsteps.
    Encoder,
    /// `drive`: the coils' ∫ I_peak² dt since power-up, in µA²·s (shown as A²·s with six decimals).
    Energy,
    /// `drive`, closed loop: the virtual position ([`Role::VirtualPosition`], AP 233), µsteps.
    VirtualPosition,
    /// `drive`, closed loop: virtual − actual position ([`Role::PositionError`], AP 237), µsteps.
    PositionError,
    /// `drive`, closed loop: the current scaler ([`Role::CurrentScale`], AP 123), /255.
    Scaler,
    /// `drive`, closed loop: the status word ([`Role::StatusWord`], AP 18), a bit field.
    StatusWord,
    /// `drive`, closed loop: the velocity measured at the encoder ([`Role::MeasuredVelocity`], AP 131,
    /// TMCM-1310 manual §3.4), pps; next to the ramp's [`Quantity::Velocity`] it shows the rotor lagging.
    MeasuredVelocity,
    /// On a model with velocity units of its own (the TMC428 generation): AP 3 ([`Role::ActualSpeed`]) in
    /// them.
    VelocityUnits,
}

impl Quantity {
    /// The columns every trace has, before the user variables.
    pub const FIXED: [Quantity; 7] = [
        Quantity::TargetPosition,
        Quantity::ActualPosition,
        Quantity::Velocity,
        Quantity::Accumulator,
        Quantity::X,
        Quantity::Pc,
        Quantity::Outputs,
    ];
    /// The columns `drive` adds after the user variables (those the model has).
    pub const DRIVE: [Quantity; 4] = [Quantity::Load, Quantity::CurrentScale, Quantity::Encoder, Quantity::Energy];
    /// The columns `drive` adds after [`Quantity::DRIVE`] on a closed-loop model (those it has).
    pub const CLOSED_LOOP: [Quantity; 5] = [
        Quantity::VirtualPosition,
        Quantity::PositionError,
        Quantity::Scaler,
        Quantity::StatusWord,
        Quantity::MeasuredVelocity,
    ];

    /// The column's name in the CSV header.
    pub fn name(self) -> String {
        match self {
            Quantity::TargetPosition => "target_position".into(),
            Quantity::ActualPosition => "actual_position".into(),
            Quantity::Velocity => "velocity".into(),
            Quantity::Accumulator => "accumulator".into(),
            Quantity::X => "x".into(),
            Quantity::Pc => "pc".into(),
            Quantity::Outputs => "outputs".into(),
            Quantity::Variable(n) => format!("var{n}"),
            Quantity::Load => "load".into(),
            Quantity::CurrentScale => "current_scale".into(),
            Quantity::Encoder => "encoder".into(),
            Quantity::Energy => "energy_a2s".into(),
            Quantity::VirtualPosition => "virtual_position".into(),
            Quantity::PositionError => "position_error".into(),
            Quantity::Scaler => "scaler".into(),
            Quantity::StatusWord => "status_word".into(),
            Quantity::MeasuredVelocity => "measured_velocity".into(),
            Quantity::VelocityUnits => "velocity_units".into(),
        }
    }

    /// The unit of its values (after [`Column::scale`]).
    pub fn unit(self) -> Unit {
        match self {
            Quantity::TargetPosition
            | Quantity::ActualPosition
            | Quantity::Encoder
            | Quantity::VirtualPosition
            | Quantity::PositionError => Unit::Microsteps,
            Quantity::Velocity | Quantity::MeasuredVelocity => Unit::Pps,
            Quantity::Energy => Unit::AmpereSquaredSeconds,
            Quantity::VelocityUnits => Unit::ModelVelocity,
            Quantity::Accumulator
            | Quantity::X
            | Quantity::Pc
            | Quantity::Outputs
            | Quantity::Variable(_)
            | Quantity::Load
            | Quantity::CurrentScale
            | Quantity::Scaler
            | Quantity::StatusWord => Unit::None,
        }
    }

    /// The parameter role it is read from, if it is a parameter.
    pub fn role(self) -> Option<Role> {
        Some(match self {
            Quantity::Load => Role::LoadValue,
            Quantity::CurrentScale => Role::ActualCurrent,
            Quantity::Encoder => Role::EncoderPosition,
            Quantity::VirtualPosition => Role::VirtualPosition,
            Quantity::PositionError => Role::PositionError,
            Quantity::Scaler => Role::CurrentScale,
            Quantity::StatusWord => Role::StatusWord,
            Quantity::MeasuredVelocity => Role::MeasuredVelocity,
            Quantity::VelocityUnits => Role::ActualSpeed,
            _ => return None,
        })
    }
}

/// The unit of a column's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Unit {
    /// A number without unit: a register, a count, a bit field, a scale.
    None,
    /// Microsteps.
    Microsteps,
    /// Microsteps per second.
    Pps,
    /// A²·s (the coil energy).
    AmpereSquaredSeconds,
    /// The model's own velocity unit (a TMC428 velocity, −2047..2047).
    ModelVelocity,
}

impl Unit {
    /// The unit as written after a value (empty for [`Unit::None`]).
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::None => "",
            Unit::Microsteps => "µsteps",
            Unit::Pps => "pps",
            Unit::AmpereSquaredSeconds => "A²·s",
            Unit::ModelVelocity => "TMC428 units",
        }
    }
}

/// One column of a trace.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Column {
    /// Its name in the CSV header.
    pub name: String,
    /// What it holds.
    pub quantity: Quantity,
    /// The unit of `value × scale`.
    pub unit: Unit,
    /// Decimals: a stored integer `v` means `v / 10^decimals` in `unit` (6 for the energy, else 0).
    pub decimals: u8,
    /// The motor a per-axis column is of (0 for the rest); its name ends in `_mN` for N > 0.
    #[serde(default)]
    pub motor: u8,
}

impl Column {
    /// A per-axis column of motor `motor`: `target_position_m1`, `velocity_m2`, … (motor 0's keep their
    /// plain names).
    pub(crate) fn of_motor(quantity: Quantity, motor: u8) -> Column {
        let decimals = if quantity == Quantity::Energy { 6 } else { 0 };
        let name = if motor == 0 { quantity.name() } else { format!("{}_m{motor}", quantity.name()) };
        Column { name, quantity, unit: quantity.unit(), decimals, motor }
    }

    /// A stored integer in the column's unit.
    pub fn scale(&self, value: i64) -> f64 {
        value as f64 / 10f64.powi(i32::from(self.decimals))
    }
}

/// A program event, at the row it happened.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Event {
    /// The program entered the handler of interrupt N.
    Interrupt(u8),
    /// The program stopped at a STOP.
    Stop,
    /// The program stopped at a cell it cannot execute.
    End,
    /// Output N changed to the level.
    Output {
        /// The output.
        number: u8,
        /// Its new level.
        level: bool,
    },
    /// A new target position (MVP, SAP 0); the row still shows where the motor stands.
    Target(i32),
    /// A new target position of motor 1, 2, … of a model with several (`target_m1=…`).
    MotorTarget {
        /// The motor (1 or more).
        motor: u8,
        /// Its new target.
        target: i32,
    },
    /// The module refused the instruction at `pc` with `status`; the program went on without it.
    Refused {
        /// Its address.
        pc: u16,
        /// The status (PD28-1021 manual §3.2.1, Table 4).
        status: u8,
    },
}

impl Event {
    /// The kind of event: its lane in a plot (`interrupt 0`, `stop`, `end`, `out0`, `target`).
    pub fn kind(&self) -> String {
        match self {
            Event::Output { number, .. } => format!("out{number}"),
            Event::Target(_) => "target".into(),
            Event::MotorTarget { motor, .. } => format!("target_m{motor}"),
            Event::Refused { .. } => "refused".into(),
            other => other.to_string(),
        }
    }

    /// The value it carries, if any (the new level, the target).
    pub fn value(&self) -> Option<String> {
        match self {
            Event::Output { level, .. } => Some(u8::from(*level).to_string()),
            Event::Target(t) | Event::MotorTarget { target: t, .. } => Some(t.to_string()),
            Event::Refused { pc, status } => Some(format!("pc {pc} status {status}")),
            _ => None,
        }
    }
}

impl fmt::Display for Event {
    /// As in the trace's `event` column: `interrupt 0`, `stop`, `end`, `out0=1`, `target=512000`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Event::Interrupt(n) => write!(f, "interrupt {n}"),
            Event::Stop => f.write_str("stop"),
            Event::End => f.write_str("end"),
            Event::Output { number, level } => write!(f, "out{number}={}", u8::from(*level)),
            Event::Target(t) => write!(f, "target={t}"),
            Event::MotorTarget { motor, target } => write!(f, "target_m{motor}={target}"),
            Event::Refused { pc, status } => write!(f, "refused=pc {pc} status {status}"),
        }
    }
}

/// An event with the time it happened.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stamped {
    /// Simulated time in µs.
    pub micros: u64,
    /// The row it is recorded in.
    pub row: usize,
    /// What happened.
    pub event: Event,
}

/// The digital inputs, outputs and reference switches from a time on (kept at every change).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Levels {
    /// Simulated time in µs.
    pub micros: u64,
    /// Bit n = INn.
    pub inputs: u8,
    /// Bit n = OUTn.
    pub outputs: u8,
    /// The reference switches as the board sees them (pressed = true, before any polarity setting):
    /// bit 0 home, bit 1 left, bit 2 right ([`SWITCHES`]).
    pub switches: u8,
}

/// The reference switches' names, by bit of [`Levels::switches`].
pub const SWITCHES: [&str; 3] = ["HOME", "LEFT", "RIGHT"];

/// The position axis in the world's own unit, when the run has a world file: mm on a linear axis, degrees
/// on a rotary one. Each row carries its [`Placement`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorldUnit {
    /// `mm` (linear axis) or `°` (rotary axis).
    pub name: String,
}

/// Where positions of a row are in the world: `p` µsteps (AP 0, AP 1) are at `offset + p × per_microstep`
/// in the [`WorldUnit`]. Per row, because the microstep resolution may change and a reference search or
/// `SAP 1` moves the step counter's 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Placement {
    /// World units per µstep (negative with the shaft reversed).
    pub per_microstep: f64,
    /// Where the step counter's 0 is, in world units.
    pub offset: f64,
}

impl Placement {
    /// A position in µsteps in world units.
    pub fn place(&self, microsteps: i64) -> f64 {
        self.offset + microsteps as f64 * self.per_microstep
    }
}

/// What a trace is about: its columns, the model, and the world's unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// The value columns, in order (without the time and the events).
    pub columns: Vec<Column>,
    /// The model's product name.
    pub model: String,
    /// With a world file: the position axis in its unit.
    pub world_unit: Option<WorldUnit>,
    /// With a world file, on a model with several motors: motor 1's, 2's, … position axis in its unit
    /// (each motor's own world, `[motors.N]`).
    #[serde(default)]
    pub motor_world_units: Vec<WorldUnit>,
}

/// One row as a run records it.
#[derive(Debug, Clone, Copy)]
pub struct Row<'a> {
    /// Simulated time in µs.
    pub micros: u64,
    /// One value per column of the [`Header`] (`None`: the module refused to give it).
    pub values: &'a [Option<i64>],
    /// The events that happened at this row (empty for a plain sample).
    pub events: &'a [Event],
    /// With a [`WorldUnit`]: where the row's positions are in the world.
    pub placement: Option<Placement>,
    /// With [`Header::motor_world_units`]: where motor 1's, 2's, … positions are in its world.
    pub motor_placements: &'a [Placement],
}

/// Where a run's rows go.
pub trait Sink {
    /// Called once, before the first row.
    fn start(&mut self, header: &Header) -> io::Result<()>;
    /// One row.
    fn row(&mut self, row: Row<'_>) -> io::Result<()>;
    /// The inputs, outputs and switches after a change (and at the start). Between samples too: a change
    /// is kept at the time it happened.
    fn levels(&mut self, _levels: Levels) {}
    /// Called once, after the last row.
    fn finish(&mut self) -> io::Result<()> {
        Ok(())
    }
    /// Whether it takes [`Sink::levels`] (watching them costs a little at every poll).
    fn wants_levels(&self) -> bool {
        false
    }
}

impl<S: Sink + ?Sized> Sink for &mut S {
    fn start(&mut self, header: &Header) -> io::Result<()> {
        (**self).start(header)
    }
    fn row(&mut self, row: Row<'_>) -> io::Result<()> {
        (**self).row(row)
    }
    fn levels(&mut self, levels: Levels) {
        (**self).levels(levels)
    }
    fn finish(&mut self) -> io::Result<()> {
        (**self).finish()
    }
    fn wants_levels(&self) -> bool {
        (**self).wants_levels()
    }
}

/// Two sinks at once (a CSV file and a trace in memory for the plot).
#[derive(Debug)]
pub struct Tee<A, B>(pub A, pub B);

impl<A: Sink, B: Sink> Sink for Tee<A, B> {
    fn start(&mut self, header: &Header) -> io::Result<()> {
        self.0.start(header)?;
        self.1.start(header)
    }
    fn row(&mut self, row: Row<'_>) -> io::Result<()> {
        self.0.row(row)?;
        self.1.row(row)
    }
    fn levels(&mut self, levels: Levels) {
        self.0.levels(levels);
        self.1.levels(levels);
    }
    fn finish(&mut self) -> io::Result<()> {
        self.0.finish()?;
        self.1.finish()
    }
    fn wants_levels(&self) -> bool {
        self.0.wants_levels() || self.1.wants_levels()
    }
}

/// Writes the rows as CSV: a header line, then one line per row (values as integers, the time and the
/// energy with six decimals, an empty cell for a refused value, the events joined with `;`).
#[derive(Debug)]
pub struct Csv<W: Write> {
    out: W,
    decimals: Vec<u8>,
    line: String,
}

impl<W: Write> Csv<W> {
    /// CSV to `out` (give it a buffered writer).
    pub fn new(out: W) -> Csv<W> {
        Csv { out, decimals: Vec::new(), line: String::new() }
    }

    /// The writer back.
    pub fn into_inner(self) -> W {
        self.out
    }
}

impl<W: Write> Sink for Csv<W> {
    fn start(&mut self, header: &Header) -> io::Result<()> {
        self.decimals = header.columns.iter().map(|c| c.decimals).collect();
        let mut line = String::from("time_s");
        for c in &header.columns {
            line.push(',');
            line.push_str(&c.name);
        }
        line.push_str(",event\n");
        self.out.write_all(line.as_bytes())
    }

    fn row(&mut self, row: Row<'_>) -> io::Result<()> {
        let line = &mut self.line;
        line.clear();
        line.push_str(&seconds(row.micros));
        for (value, &decimals) in row.values.iter().zip(&self.decimals) {
            line.push(',');
            if let Some(v) = value {
                write_fixed(line, *v, decimals);
            }
        }
        line.push(',');
        for (i, e) in row.events.iter().enumerate() {
            if i > 0 {
                line.push(';');
            }
            let _ = write!(line, "{e}");
        }
        line.push('\n');
        self.out.write_all(line.as_bytes())
    }

    fn finish(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

/// One column of a [`Trace`] in memory, compactly: 32-bit integers for the quantities that are 32-bit in
/// the module (all but the energy), 64-bit for the energy, and the rows without a value (the module
/// refused to give one) listed apart. An hour sampled every millisecond is 3.6 million values a column.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Values {
    data: Data,
    /// The rows without a value, ascending.
    missing: Vec<usize>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
enum Data {
    Narrow(Vec<i32>),
    Wide(Vec<i64>),
}

impl Values {
    fn for_quantity(quantity: Quantity) -> Values {
        let data = if quantity == Quantity::Energy { Data::Wide(Vec::new()) } else { Data::Narrow(Vec::new()) };
        Values { data, missing: Vec::new() }
    }

    /// Appends the value of row `row` (the next one).
    fn push(&mut self, value: Option<i64>, row: usize) {
        if value.is_none() {
            self.missing.push(row);
        }
        let v = value.unwrap_or(0);
        match &mut self.data {
            // A narrow quantity is an i32 in the module; saturating keeps a wrong caller from wrapping.
            Data::Narrow(d) => d.push(v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32),
            Data::Wide(d) => d.push(v),
        }
    }

    /// Rows.
    pub fn len(&self) -> usize {
        match &self.data {
            Data::Narrow(d) => d.len(),
            Data::Wide(d) => d.len(),
        }
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The value at row `row` (`None`: no such row, or the module gave no value there).
    pub fn get(&self, row: usize) -> Option<i64> {
        if !self.missing.is_empty() && self.missing.binary_search(&row).is_ok() {
            return None;
        }
        match &self.data {
            Data::Narrow(d) => d.get(row).map(|&v| i64::from(v)),
            Data::Wide(d) => d.get(row).copied(),
        }
    }

    /// The last row's value (`None` if there are no rows).
    pub fn last(&self) -> Option<Option<i64>> {
        self.len().checked_sub(1).map(|r| self.get(r))
    }

    /// Every row's value, in order.
    pub fn iter(&self) -> impl Iterator<Item = Option<i64>> + '_ {
        (0..self.len()).map(|r| self.get(r))
    }
}

/// A trace in memory, as columns: the times, one vector of values per column, the events, and the
/// inputs, outputs and switches at every change.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    /// The columns and what the trace is about (empty until the run starts).
    pub header: Option<Header>,
    /// Each row's time in µs.
    pub times: Vec<u64>,
    /// `values[c]`: column `c`, a value per row.
    pub values: Vec<Values>,
    /// The events, in order.
    pub events: Vec<Stamped>,
    /// The inputs, outputs and switches at the start and after each change.
    pub levels: Vec<Levels>,
    /// With a world unit: where each row's positions are in the world.
    pub placements: Vec<Placement>,
    /// With [`Header::motor_world_units`]: `motor_placements[m - 1][row]`, where motor m's positions are.
    #[serde(default)]
    pub motor_placements: Vec<Vec<Placement>>,
}

impl Trace {
    /// An empty trace, to run into.
    pub fn new() -> Trace {
        Trace::default()
    }

    /// The columns (none before the run).
    pub fn columns(&self) -> &[Column] {
        self.header.as_ref().map_or(&[], |h| &h.columns)
    }

    /// Rows recorded.
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// Whether no row was recorded.
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// The index of the column holding `quantity` (of motor 0, for a per-axis one), if the trace has it.
    pub fn position(&self, quantity: Quantity) -> Option<usize> {
        self.position_of(quantity, 0)
    }

    /// The index of the column holding `quantity` of motor `motor`, if the trace has it.
    pub fn position_of(&self, quantity: Quantity, motor: u8) -> Option<usize> {
        self.columns().iter().position(|c| c.quantity == quantity && c.motor == motor)
    }

    /// The values of the column holding `quantity` (of motor 0, for a per-axis one), if the trace has it.
    pub fn column(&self, quantity: Quantity) -> Option<&Values> {
        self.column_of(quantity, 0)
    }

    /// The values of the column holding `quantity` of motor `motor`, if the trace has it.
    pub fn column_of(&self, quantity: Quantity, motor: u8) -> Option<&Values> {
        self.position_of(quantity, motor).map(|i| &self.values[i])
    }

    /// The motors the trace has per-axis columns of (at least motor 0).
    pub fn motors(&self) -> u8 {
        self.columns().iter().map(|c| c.motor + 1).max().unwrap_or(1)
    }

    /// The values of column `index` in its unit (the energy in A²·s, the rest as they are), `None` where
    /// the module refused to give one.
    pub fn scaled(&self, index: usize) -> Vec<Option<f64>> {
        let column = &self.columns()[index];
        self.values[index].iter().map(|v| v.map(|v| column.scale(v))).collect()
    }

    /// Each row's time in seconds.
    pub fn seconds(&self) -> Vec<f64> {
        self.times.iter().map(|&t| t as f64 / 1e6).collect()
    }

    /// Writes the trace as CSV, byte for byte what [`Csv`] writes during the run.
    pub fn write_csv(&self, out: impl Write) -> io::Result<()> {
        let mut csv = Csv::new(out);
        let Some(header) = &self.header else { return Ok(()) };
        csv.start(header)?;
        let mut values = vec![None; self.values.len()];
        let mut next_event = 0;
        for (r, &micros) in self.times.iter().enumerate() {
            for (c, column) in self.values.iter().enumerate() {
                values[c] = column.get(r);
            }
            let first = next_event;
            while self.events.get(next_event).is_some_and(|e| e.row == r) {
                next_event += 1;
            }
            let events: Vec<Event> = self.events[first..next_event].iter().map(|e| e.event.clone()).collect();
            csv.row(Row { micros, values: &values, events: &events, placement: None, motor_placements: &[] })?;
        }
        csv.finish()
    }
}

impl Sink for Trace {
    fn start(&mut self, header: &Header) -> io::Result<()> {
        self.values = header.columns.iter().map(|c| Values::for_quantity(c.quantity)).collect();
        self.header = Some(header.clone());
        Ok(())
    }

    fn row(&mut self, row: Row<'_>) -> io::Result<()> {
        let r = self.times.len();
        self.times.push(row.micros);
        for (column, value) in self.values.iter_mut().zip(row.values) {
            column.push(*value, r);
        }
        self.events.extend(row.events.iter().map(|e| Stamped { micros: row.micros, row: r, event: e.clone() }));
        if let Some(p) = row.placement {
            self.placements.push(p);
        }
        self.motor_placements.resize(row.motor_placements.len().max(self.motor_placements.len()), Vec::new());
        for (list, p) in self.motor_placements.iter_mut().zip(row.motor_placements) {
            list.push(*p);
        }
        Ok(())
    }

    fn levels(&mut self, levels: Levels) {
        self.levels.push(levels);
    }

    fn wants_levels(&self) -> bool {
        true
    }
}

/// `value / 10^decimals` with exactly `decimals` decimals, from the integer (no floating point).
fn write_fixed(line: &mut String, value: i64, decimals: u8) {
    if decimals == 0 {
        let _ = write!(line, "{value}");
        return;
    }
    let unit = 10u64.pow(u32::from(decimals));
    let sign = if value < 0 { "-" } else { "" };
    let magnitude = value.unsigned_abs();
    let width = usize::from(decimals);
    let _ = write!(line, "{sign}{}.{:0width$}", magnitude / unit, magnitude % unit);
}

/// Integer millionths as a decimal number with six decimals (no floating point: the same everywhere):
/// microseconds as seconds, µA²·s as A²·s.
pub fn seconds(micros: u64) -> String {
    format!("{}.{:06}", micros / 1_000_000, micros % 1_000_000)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_are_exact() {
        assert_eq!(seconds(0), "0.000000");
        assert_eq!(seconds(1_000_020), "1.000020");
        assert_eq!(seconds(3_600_000_000), "3600.000000");
    }

    #[test]
    fn columns_in_memory_keep_every_value_and_the_missing_ones() {
        let mut narrow = Values::for_quantity(Quantity::Accumulator);
        for (r, v) in [Some(i64::from(i32::MIN)), None, Some(7), Some(i64::from(i32::MAX))].into_iter().enumerate() {
            narrow.push(v, r);
        }
        assert_eq!(
            narrow.iter().collect::<Vec<_>>(),
            [Some(i64::from(i32::MIN)), None, Some(7), Some(i64::from(i32::MAX))]
        );
        assert_eq!((narrow.len(), narrow.last(), narrow.get(9)), (4, Some(Some(i64::from(i32::MAX))), None));
        let mut wide = Values::for_quantity(Quantity::Energy);
        wide.push(Some(1 << 40), 0);
        assert_eq!(wide.get(0), Some(1 << 40));
    }

    #[test]
    fn fixed_point_values_are_exact() {
        let text = |v, d| {
            let mut line = String::new();
            write_fixed(&mut line, v, d);
            line
        };
        assert_eq!(text(1_250_000, 6), "1.250000");
        assert_eq!(text(-5, 6), "-0.000005");
        assert_eq!(text(-42, 0), "-42");
        assert_eq!(text(i64::MIN, 6), "-9223372036854.775808");
    }

    #[test]
    fn events_read_as_in_the_event_column() {
        let events = [Event::Interrupt(0), Event::Stop, Event::End, Event::Output { number: 2, level: true }];
        let text: Vec<String> = events.iter().map(|e| e.to_string()).collect();
        assert_eq!(text, ["interrupt 0", "stop", "end", "out2=1"]);
        assert_eq!(Event::Target(-512_000).to_string(), "target=-512000");
        assert_eq!((Event::Target(5).kind(), Event::Target(5).value()), ("target".into(), Some("5".into())));
    }
}

//! Reading a trace's rows off a running module: which columns a run has, decided once from the model's
//! tables by meaning ([`Quantity::role`]), and each row's values, placement in the world and levels.

use crate::trace::{Column, Event, Header, Levels, Placement, Quantity, Row, Sink, WorldUnit};
use std::io;
use tmcl_core::hal::{Inputs as _, SwitchInputs as _};
use tmcl_core::model::{Kinematics, ModelSpec, Role, Setting};
use tmcl_core::{Instant, Module};
use tmcl_sim::world::AxisKind;
use tmcl_sim::SimBoard;

/// Reads the rows off a module: the columns decided from the model's tables once, at the start.
pub(crate) struct Recorder {
    header: Header,
    /// Per column: where its value comes from.
    sources: Vec<Read>,
    /// AP 1 by role, read while a closed loop is closed (else the step counter).
    actual: Option<u8>,
    closed_loop: bool,
    /// With a world unit: how to place positions in it.
    world: Option<WorldScale>,
    /// The last placement (kept while a closed loop is closed: the field does not follow the step counter).
    placement: Option<Placement>,
    /// Motors 1, 2, …: how to place their positions in their worlds, and this row's placements.
    motor_worlds: Vec<WorldScale>,
    motor_placements: Vec<Placement>,
    values: Vec<Option<i64>>,
    last_levels: Option<(u8, u8, u8)>,
    /// Rows recorded.
    pub rows: u64,
}

/// How a column's value is read.
#[derive(Debug, Clone, Copy)]
enum Read {
    Target,
    Actual,
    Velocity,
    Accumulator,
    X,
    Pc,
    Outputs,
    Variable(u8),
    Energy,
    Axis(u8),
    /// Motor N > 0's AP 0, AP 1 (its step counter), AP 3 (pps), and an axis parameter of it.
    TargetOf(u8),
    ActualOf(u8),
    VelocityOf(u8),
    AxisOf(u8, u8),
}

/// What it takes to place the step counter in the world.
#[derive(Debug, Clone, Copy)]
struct WorldScale {
    /// The microstep resolution's parameter (AP 140, by role).
    resolution: u8,
    full_steps: f64,
    /// mm or degrees per motor revolution.
    units_per_rev: f64,
    /// The reverse-shaft global parameter (GP 90, by setting), if the model has it.
    reverse: Option<u8>,
    /// Where the axis is at power-up (the world's `axis.start`), in its unit.
    start: f64,
}

/// The number of the axis parameter with `role` on the model, if it has one.
fn axis_number(spec: &ModelSpec, role: Role) -> Option<u8> {
    spec.axis.role(role).map(|i| spec.axis.params[i].number)
}

impl Recorder {
    /// The columns of a run of `spec` with these user variables (ascending), with or without the drive's
    /// columns; `world`: the world file's axis, if one was given.
    pub fn new(spec: &'static ModelSpec, variables: &[u8], drive: bool, world: Option<&tmcl_sim::World>) -> Recorder {
        let mut columns: Vec<(Quantity, Read)> = vec![
            (Quantity::TargetPosition, Read::Target),
            (Quantity::ActualPosition, Read::Actual),
            (Quantity::Velocity, Read::Velocity),
            (Quantity::Accumulator, Read::Accumulator),
            (Quantity::X, Read::X),
            (Quantity::Pc, Read::Pc),
            (Quantity::Outputs, Read::Outputs),
        ];
        columns.extend(
            variables
                .iter()
                .filter(|&&n| u16::from(n) < spec.user_variables)
                .map(|&n| (Quantity::Variable(n), Read::Variable(n))),
        );
        let closed_loop = drive && spec.axis.setting(Setting::ClosedLoop).is_some();
        let by_role = |q: Quantity| q.role().and_then(|r| axis_number(spec, r)).map(|n| (q, Read::Axis(n)));
        if drive {
            for q in Quantity::DRIVE {
                columns.extend(if q == Quantity::Energy { Some((q, Read::Energy)) } else { by_role(q) });
            }
        }
        if closed_loop {
            columns.extend(Quantity::CLOSED_LOOP.into_iter().filter_map(by_role));
        }
        if spec.kinematics != Kinematics::Pps {
            columns.extend(by_role(Quantity::VelocityUnits));
        }
        let mut motors = vec![0u8; columns.len()];
        // The other motors' own columns, motor by motor (a model with several).
        for m in 1..spec.motors {
            let before = columns.len();
            columns.extend([
                (Quantity::TargetPosition, Read::TargetOf(m)),
                (Quantity::ActualPosition, Read::ActualOf(m)),
                (Quantity::Velocity, Read::VelocityOf(m)),
            ]);
            let of = |q: Quantity| q.role().and_then(|r| axis_number(spec, r)).map(|n| (q, Read::AxisOf(n, m)));
            if drive {
                columns.extend([Quantity::Load, Quantity::CurrentScale, Quantity::Encoder].into_iter().filter_map(of));
            }
            if spec.kinematics != Kinematics::Pps {
                columns.extend(of(Quantity::VelocityUnits));
            }
            motors.resize(motors.len() + columns.len() - before, m);
        }
        // Each motor's world (`[motors.N]`): how its step counter is placed in it, and its unit.
        let scale_of = |w: &tmcl_sim::World| -> Option<(WorldScale, WorldUnit)> {
            let units_per_rev = match w.axis.kind {
                AxisKind::Linear => *w.axis.lead.get_ref(),
                AxisKind::Rotary => 360.0,
            };
            let scale = WorldScale {
                resolution: axis_number(spec, Role::MicrostepResolution)?,
                full_steps: f64::from(*w.motor.full_steps.get_ref()),
                units_per_rev,
                reverse: spec.global.setting(Setting::ReverseShaft).map(|i| spec.global.params[i].number),
                start: start_in_units(w, f64::from(*w.motor.full_steps.get_ref()), units_per_rev),
            };
            let name = match w.axis.kind {
                AxisKind::Linear => "mm".into(),
                AxisKind::Rotary => "°".into(),
            };
            Some((scale, WorldUnit { name }))
        };
        let scales: Vec<Option<(WorldScale, WorldUnit)>> =
            (0..usize::from(spec.motors)).map(|m| world.and_then(|w| scale_of(&w.of_motor(m)))).collect();
        let (world_scale, world_unit) = scales[0].clone().unzip();
        let others: Vec<(WorldScale, WorldUnit)> = scales.into_iter().skip(1).flatten().collect();
        let header = Header {
            columns: columns.iter().zip(&motors).map(|(&(q, _), &m)| Column::of_motor(q, m)).collect(),
            model: spec.name.to_string(),
            world_unit,
            motor_world_units: others.iter().map(|(_, u)| u.clone()).collect(),
        };
        Recorder {
            sources: columns.iter().map(|&(_, r)| r).collect(),
            values: vec![None; columns.len()],
            header,
            actual: axis_number(spec, Role::ActualPosition),
            closed_loop,
            world: world_scale,
            motor_worlds: others.into_iter().map(|(s, _)| s).collect(),
            motor_placements: Vec::new(),
            placement: None,
            last_levels: None,
            rows: 0,
        }
    }

    /// The trace's header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Records the module's state at `now`, with the events that happened (empty for a plain sample).
    pub fn record(
        &mut self,
        module: &mut Module<SimBoard>,
        now: Instant,
        events: &[Event],
        sink: &mut dyn Sink,
    ) -> io::Result<()> {
        let ramp = *module.ramp();
        // AP 1: the step counter, or the encoder while a closed loop is closed.
        let actual = match self.actual {
            Some(n) if self.closed_loop || module.state().closed_loop().active => {
                module.get_axis(n).unwrap_or(ramp.position)
            }
            _ => ramp.position,
        };
        for (value, source) in self.values.iter_mut().zip(&self.sources) {
            *value = match *source {
                Read::Target => Some(i64::from(ramp.target_position)),
                Read::Actual => Some(i64::from(actual)),
                Read::Velocity => Some(i64::from(ramp.velocity())),
                Read::Accumulator => Some(i64::from(module.registers().accumulator)),
                Read::X => Some(i64::from(module.registers().x)),
                Read::Pc => Some(i64::from(module.vm().pc)),
                Read::Outputs => Some(i64::from(module.board().outputs())),
                Read::Variable(n) => module.get_global(n, crate::USER_BANK, now).ok().map(i64::from),
                // Rounded to an integer number of µA²·s, so traces stay byte-identical everywhere.
                Read::Energy => Some((module.board().energy() * 1e6).round() as i64),
                Read::Axis(n) => module.get_axis(n).ok().map(i64::from),
                Read::TargetOf(m) => module.axis(usize::from(m)).map(|a| i64::from(a.ramp().target_position)),
                Read::ActualOf(m) => module.axis(usize::from(m)).map(|a| i64::from(a.ramp().position)),
                Read::VelocityOf(m) => module.axis(usize::from(m)).map(|a| i64::from(a.ramp().velocity())),
                Read::AxisOf(n, m) => module.get_axis_of(m, n).ok().map(i64::from),
            };
        }
        if let Some(w) = self.world {
            // The step counter's 0 in the world: where the driver's field is (it follows the step counter
            // exactly in open loop) minus the step counter. A closed loop drives the field itself: the
            // last placement stays.
            if self.placement.is_none() || !module.state().closed_loop().active {
                let resolution = module.get_axis(w.resolution).unwrap_or(0).clamp(0, 8);
                let reverse = w.reverse.is_some_and(|n| module.get_global(n, 0, now).unwrap_or(0) != 0);
                let sign = if reverse { -1.0 } else { 1.0 };
                let per_microstep = sign * w.units_per_rev / (w.full_steps * f64::from(1u32 << resolution));
                let field = w.start + module.board().commanded() as f64 * w.units_per_rev / (w.full_steps * 256.0);
                let offset = field - f64::from(ramp.position) * per_microstep;
                self.placement = Some(Placement { per_microstep, offset });
            }
        }
        // The other motors (no closed loop on a multi-axis model: the field follows the step counter).
        self.motor_placements.clear();
        for (i, w) in self.motor_worlds.iter().enumerate() {
            let m = i + 1;
            let resolution = module.get_axis_of(m as u8, w.resolution).unwrap_or(0).clamp(0, 8);
            let reverse = w.reverse.is_some_and(|n| module.get_global(n, 0, now).unwrap_or(0) != 0);
            let sign = if reverse { -1.0 } else { 1.0 };
            let per_microstep = sign * w.units_per_rev / (w.full_steps * f64::from(1u32 << resolution));
            let commanded = module.board().axis(m).map_or(0, |a| a.commanded());
            let field = w.start + commanded as f64 * w.units_per_rev / (w.full_steps * 256.0);
            let position = module.axis(m).map_or(0, |a| a.ramp().position);
            self.motor_placements
                .push(Placement { per_microstep, offset: field - f64::from(position) * per_microstep });
        }
        self.rows += 1;
        sink.row(Row {
            micros: now.micros(),
            values: &self.values,
            events,
            placement: self.placement,
            motor_placements: &self.motor_placements,
        })
    }

    /// Hands the digital inputs, outputs and reference switches at `now` to the sink if they changed
    /// since the last call (or if this is the first). Called after every poll, so a change is kept at the
    /// time it happened, between samples too. Nothing is written to a CSV file.
    pub fn watch_levels(&mut self, module: &mut Module<SimBoard>, now: Instant, sink: &mut dyn Sink) {
        if !sink.wants_levels() {
            return;
        }
        let outputs = module.board().outputs();
        let inputs = module.board_timeline().digital_inputs();
        let s = module.board_timeline().switches(0);
        let switches = u8::from(s.home) | u8::from(s.left) << 1 | u8::from(s.right) << 2;
        if self.last_levels != Some((inputs, outputs, switches)) {
            self.last_levels = Some((inputs, outputs, switches));
            sink.levels(Levels { micros: now.micros(), inputs, outputs, switches });
        }
    }
}

/// Where the axis is at power-up (the world's `axis.start`), in its unit.
fn start_in_units(world: &tmcl_sim::World, full_steps: f64, per_rev: f64) -> f64 {
    use tmcl_sim::world::Pos;
    match *world.axis.start.get_ref() {
        Pos::Axis(v) | Pos::Mm(v) | Pos::Deg(v) => v,
        Pos::Rev(v) => v * per_rev,
        Pos::FullSteps(v) => v / full_steps * per_rev,
        Pos::Usteps(v) => v / (full_steps * 256.0) * per_rev,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_come_from_the_models_roles() {
        let pd28 = tmcl_core::model::by_id("pd28-1021").unwrap();
        let names = |r: &Recorder| r.header().columns.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
        let plain = Recorder::new(pd28, &[3], false, None);
        assert_eq!(
            names(&plain),
            ["target_position", "actual_position", "velocity", "accumulator", "x", "pc", "outputs", "var3"]
        );
        let drive = Recorder::new(pd28, &[], true, None);
        assert!(names(&drive).ends_with(&[
            "load".into(),
            "current_scale".into(),
            "encoder".into(),
            "energy_a2s".into()
        ]));
        let tmcm = tmcl_core::model::by_id("tmcm-1310").unwrap();
        let closed = Recorder::new(tmcm, &[], true, None);
        assert!(names(&closed).ends_with(&[
            "virtual_position".into(),
            "position_error".into(),
            "scaler".into(),
            "status_word".into(),
            "measured_velocity".into()
        ]));
        // Every drive column of every model is read from a parameter the model has, by role.
        for spec in tmcl_core::model::MODELS {
            let r = Recorder::new(spec, &[], true, None);
            for (column, source) in r.header().columns.iter().zip(&r.sources) {
                if let Read::Axis(n) = source {
                    let role = column.quantity.role().unwrap();
                    assert_eq!(spec.axis.find(*n).unwrap().1.role, role, "{} {}", spec.id, column.name);
                }
            }
        }
    }
}

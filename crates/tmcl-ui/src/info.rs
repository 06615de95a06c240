//! What the page learns about the module: the model's tables ([`ModelInfo`]), and refusals explained from
//! them.

use serde::Serialize;
use tmcl_model::{Kinematics, ModelSpec, ParamDesc, PortKind, Range, Role, Setting, Table};
use tmcl_wire::Status;

use tmcl_model::names::INTERRUPT_BANK;

/// One parameter as the page's table shows it.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct ParamInfo {
    /// `ap` or `gp`.
    pub kind: &'static str,
    /// The bank of a global parameter (`null` for axis parameters).
    pub bank: Option<u8>,
    pub number: u8,
    /// The identifier (`MaxPositioningSpeed`).
    pub name: &'static str,
    /// The manual's name.
    pub title: &'static str,
    pub unit: &'static str,
    /// The range in words (`1..2147483647`).
    pub range: String,
    /// `R`, `RW`, `RWE`, ...
    pub access: String,
    pub read: bool,
    pub write: bool,
    pub store: bool,
    pub default: i32,
    /// The manual's section.
    pub section: &'static str,
}

impl ParamInfo {
    fn of(kind: &'static str, bank: Option<u8>, d: &'static ParamDesc) -> ParamInfo {
        ParamInfo {
            kind,
            bank,
            number: d.number,
            name: d.ident,
            title: d.name,
            unit: d.unit.symbol(),
            range: d.range.to_string(),
            access: d.access.to_string(),
            read: d.access.read,
            write: d.access.write,
            store: d.access.store,
            default: d.default,
            section: d.section,
        }
    }
}

/// One port as the I/O view shows it.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct PortInfo {
    pub bank: u8,
    pub port: u8,
    /// `input`, `analog`, `temperature` or `output`.
    pub kind: &'static str,
    pub name: &'static str,
}

/// The model as the page needs it: names, tables, ports, counts.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct ModelInfo {
    pub id: &'static str,
    pub name: &'static str,
    pub manual: &'static str,
    pub motors: u8,
    pub user_variables: u16,
    pub program_memory: u16,
    /// The axis parameters, then banks 0 and 3.
    pub params: Vec<ParamInfo>,
    /// The ports the I/O view shows (not the all-inputs/all-outputs words).
    pub ports: Vec<PortInfo>,
    pub motion: MotionInfo,
    pub closed_loop: Option<ClosedLoopInfo>,
    /// A first program for the editor.
    pub sample_program: String,
}

impl ModelInfo {
    pub(crate) fn of(model: &'static ModelSpec) -> ModelInfo {
        let table = |kind, bank, t: &'static Table| t.params.iter().map(move |d| ParamInfo::of(kind, bank, d));
        let params = table("ap", None, &model.axis)
            .chain(table("gp", Some(0), &model.global))
            .chain(table("gp", Some(INTERRUPT_BANK), &model.interrupt))
            .collect();
        let ports = model
            .ports
            .iter()
            .filter(|p| !matches!(p.kind, PortKind::AllInputs | PortKind::AllOutputs | PortKind::PullUps))
            .map(|p| PortInfo {
                bank: p.bank,
                port: p.port,
                kind: match p.kind {
                    PortKind::DigitalInput(_) | PortKind::EncoderNearZero => "input",
                    PortKind::Analog(_) | PortKind::Analog10(_) => "analog",
                    PortKind::Temperature => "temperature",
                    PortKind::SupplyVoltage => "supply",
                    PortKind::Output(_) => "output",
                    PortKind::AllInputs | PortKind::AllOutputs | PortKind::PullUps => "all",
                },
                name: p.name,
            })
            .collect();
        ModelInfo {
            id: model.id,
            name: model.name,
            manual: model.manual,
            motors: model.motors,
            user_variables: model.user_variables,
            program_memory: model.program_memory,
            params,
            ports,
            motion: MotionInfo::of(model),
            closed_loop: ClosedLoopInfo::of(model),
            sample_program: sample_program(model),
        }
    }
}

/// The smallest and largest value of a range (for the page's number inputs).
fn bounds(range: Range) -> (i64, i64) {
    match range {
        Range::Signed(min, max) => (i64::from(min), i64::from(max)),
        Range::Unsigned32 => (0, i64::from(u32::MAX)),
        Range::OneOf(set) => (
            set.iter().map(|r| i64::from(*r.start())).min().unwrap_or(0),
            set.iter().map(|r| i64::from(*r.end())).max().unwrap_or(0),
        ),
    }
}

/// What the Motion view needs to speak the model's units: the velocity unit and range that ROR, ROL and
/// the maximum positioning speed take, a sensible speed to start with, and how to turn the model's
/// velocity unit into microsteps per second (the PDx-113's TMC428 units, PDx-113 manual §5.7.1).
#[derive(Debug, Clone, Serialize)]
pub(crate) struct MotionInfo {
    /// The unit of AP 2, 3 and 4 and of ROR/ROL (`pps`, `TMC428 v units`).
    pub velocity_unit: &'static str,
    /// The most ROR/ROL take (the target speed's range, PD28-1021 manual §3.7.1).
    pub velocity_max: i64,
    /// The smallest and largest maximum positioning speed (AP 4).
    pub speed_min: i64,
    pub speed_max: i64,
    /// The speed the Motion view starts with: the factory default of AP 4.
    pub speed_default: i64,
    /// The unit of positions.
    pub position_unit: &'static str,
    /// The position counter's width: MVP takes ±2^(bits-1).
    pub position_bits: u32,
    /// `pps` or `tmc428`.
    pub kinematics: &'static str,
    /// The TMC428's clock (for `tmc428`).
    pub clock_hz: Option<u32>,
    /// The pulse divisor's axis parameter (for `tmc428`), read to show microsteps per second.
    pub pulse_divisor: Option<u8>,
}

impl MotionInfo {
    pub(crate) fn of(model: &'static ModelSpec) -> MotionInfo {
        let by_role = |role: Role| model.axis.params.iter().find(|d| d.role == role);
        let by_setting = |setting: Setting| model.axis.params.iter().find(|d| d.setting == Some(setting));
        let speed = by_setting(Setting::MaxPositioningSpeed);
        let target = by_role(Role::TargetSpeed);
        let (speed_min, speed_max) = speed.map_or((0, i64::from(i32::MAX)), |d| bounds(d.range));
        let velocity_max = target.map_or(speed_max, |d| bounds(d.range).1);
        let (kinematics, clock_hz) = match model.kinematics {
            Kinematics::Pps => ("pps", None),
            Kinematics::Tmc428 { clock_hz } => ("tmc428", Some(clock_hz)),
        };
        MotionInfo {
            velocity_unit: speed.or(target).map_or("pps", |d| d.unit.symbol()),
            velocity_max,
            speed_min,
            speed_max,
            speed_default: speed.map_or(1000, |d| i64::from(d.default)).clamp(speed_min, speed_max),
            position_unit: by_role(Role::ActualPosition).map_or("µsteps", |d| d.unit.symbol()),
            position_bits: model.kinematics.position_bits(),
            kinematics,
            clock_hz,
            pulse_divisor: clock_hz.and(by_setting(Setting::PulseDivisor).map(|d| d.number)),
        }
    }
}

/// The closed loop of a model that has one (the TMCM-1310): the parameters its panel reads and writes, by
/// their roles and settings in the model's table, and the names of the status word's bits.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct ClosedLoopInfo {
    /// AP 132: write 1 to start the encoder initialisation; reads 0 not done, 1 running, 2 done, 3 failed.
    pub encoder_init: u8,
    /// AP 129: the closed loop on (1) or off (0).
    pub closed_loop: u8,
    /// AP 133: 1 while the loop is closed.
    pub active: u8,
    /// AP 18: the status word.
    pub status_word: Option<u8>,
    /// AP 237: virtual minus actual position.
    pub position_error: Option<u8>,
    /// AP 123: the closed loop's current scale.
    pub current_scale: Option<u8>,
    /// AP 131: the velocity measured from the encoder.
    pub measured_velocity: Option<u8>,
    /// The settings shown beside the plots: following error, windows, gains.
    pub settings: Vec<u8>,
    /// The status word's bits, bit 0 first.
    pub status_bits: &'static [&'static str],
}

/// The bits of the status word (AP 18), bit 0 first: the TMCM-1311 firmware manual's order, which the
/// TMCM-1310 model follows where its own manual stops (the firmware core's `drive::closed_loop::status`).
const STATUS_BITS: &[&str] = &[
    "target reached",
    "velocity reached",
    "closed loop",
    "position mode",
    "velocity mode",
    "torque mode",
    "home switch",
    "left switch",
    "right switch",
    "undervoltage",
    "overvoltage",
    "overtemperature",
    "position hold",
    "I²t exceeded",
];

impl ClosedLoopInfo {
    pub(crate) fn of(model: &'static ModelSpec) -> Option<ClosedLoopInfo> {
        let role = |r: Role| model.axis.params.iter().find(|d| d.role == r).map(|d| d.number);
        let setting = |s: Setting| model.axis.params.iter().find(|d| d.setting == Some(s)).map(|d| d.number);
        let settings = [
            Setting::MaxFollowingError,
            Setting::PositionWindow,
            Setting::VelocityWindow,
            Setting::CorrectionGain,
            Setting::MaxCorrectionVelocity,
            Setting::CurrentScaleMin,
            Setting::CurrentScaleMax,
        ];
        Some(ClosedLoopInfo {
            encoder_init: role(Role::EncoderInit)?,
            closed_loop: setting(Setting::ClosedLoop)?,
            active: role(Role::ClosedLoopActive)?,
            status_word: role(Role::StatusWord),
            position_error: role(Role::PositionError),
            current_scale: role(Role::CurrentScale),
            measured_velocity: role(Role::MeasuredVelocity),
            settings: settings.into_iter().filter_map(setting).collect(),
            status_bits: STATUS_BITS,
        })
    }
}

/// A first program for `model`: back and forth between two positions at the model's own default speed
/// (in its own unit), counting the moves in user variable 0.
pub(crate) fn sample_program(model: &'static ModelSpec) -> String {
    let motion = MotionInfo::of(model);
    let distance = if motion.position_bits < 32 { 12800 } else { 25600 };
    format!(
        "// A first program for the {name}: back and forth between two positions.\n\
         #include TMCLParam.tmc\n\n\
         Speed = {speed}           // {unit}, {min}..{max} on the {name}\n\n\
         \x20   SAP AP{ident}, Motor0, Speed\n\
         \x20   SGP 0, 2, 0            // user variable 0 counts the moves\n\
         Loop:\n\
         \x20   MVP ABS, Motor0, {distance}\n\
         \x20   WAIT POS, Motor0, 0\n\
         \x20   MVP ABS, Motor0, 0\n\
         \x20   WAIT POS, Motor0, 0\n\
         \x20   GGP 0, 2\n\
         \x20   CALC ADD, 1\n\
         \x20   AGP 0, 2\n\
         \x20   JA Loop\n",
        name = model.name,
        ident = model
            .axis
            .params
            .iter()
            .find(|d| d.setting == Some(Setting::MaxPositioningSpeed))
            .map_or("MaxPositioningSpeed", |d| d.ident),
        speed = motion.speed_default,
        unit = motion.velocity_unit,
        min = motion.speed_min,
        max = motion.speed_max,
    )
}

/// Why the module refused a motion command, from the tables: the velocity or position range.
pub(crate) fn explain_motion(model: Option<&'static ModelSpec>, velocity: bool, value: i32) -> Option<String> {
    let model = model?;
    let motion = MotionInfo::of(model);
    if velocity {
        let max = motion.velocity_max;
        (i64::from(value).abs() > max).then(|| {
            format!(
                "the {} rotates at 0..{max} {} (ROR/ROL take the target speed's range)",
                model.name, motion.velocity_unit
            )
        })
    } else {
        let half = 1i64 << (motion.position_bits - 1);
        (!(-half..half).contains(&i64::from(value))).then(|| {
            format!("the {} counts positions from {} to {} {}", model.name, -half, half - 1, motion.position_unit)
        })
    }
}

/// The descriptor of a parameter, if the model has it.
pub(crate) fn find_param(model: &'static ModelSpec, axis: bool, index: u8, number: u8) -> Option<&'static ParamDesc> {
    tmcl_model::names::find(model, axis, index, number)
}

/// Why the module refused a parameter request, in words, from what the tables say (as `tmcl set` does:
/// [`tmcl_model::names::explain`]). `value` is the value of a write; `store` whether it was a store or
/// restore.
pub(crate) fn explain(
    model: Option<&'static ModelSpec>,
    axis: bool,
    index: u8,
    number: u8,
    status: Status,
    value: Option<i32>,
    store: bool,
) -> Option<String> {
    tmcl_model::names::explain(model, axis, index, number, status, value, store).map(|r| r.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_model::MODELS;

    #[test]
    fn the_tables_as_json() {
        let m = tmcl_model::by_id("pd28-1021").unwrap();
        let j = serde_json::to_value(ModelInfo::of(m)).unwrap();
        let params = j["params"].as_array().unwrap();
        let speed = params.iter().find(|p| p["kind"] == "ap" && p["number"] == 4).unwrap();
        assert_eq!(speed["name"], "MaxPositioningSpeed");
        assert_eq!(speed["access"], "RWE");
        assert_eq!(speed["range"], "1..2147483647");
        assert!(params.iter().any(|p| p["kind"] == "gp" && p["bank"] == 3));
        assert!(j["ports"].as_array().unwrap().iter().any(|p| p["kind"] == "output"));
    }

    #[test]
    fn every_model_has_its_units_and_a_program_that_assembles() {
        for model in MODELS.iter().copied() {
            let motion = MotionInfo::of(model);
            assert!(motion.speed_default >= motion.speed_min && motion.speed_default <= motion.speed_max);
            let source = sample_program(model);
            let mut resolver = tmcl_asm::BuiltinResolver { model };
            let program = tmcl_asm::assemble_str("sample", &source, &mut resolver);
            assert!(program.is_ok(), "{}: {:?}", model.id, program.err());
        }
        let pd113 = tmcl_model::by_id("pd-113").unwrap();
        let motion = MotionInfo::of(pd113);
        assert_eq!((motion.velocity_unit, motion.speed_max, motion.speed_default), ("TMC428 v units", 2047, 1000));
        assert_eq!((motion.kinematics, motion.pulse_divisor), ("tmc428", Some(154)));
        assert!(sample_program(pd113).contains("Speed = 1000"));
        assert!(ClosedLoopInfo::of(pd113).is_none());
        let cl = ClosedLoopInfo::of(tmcl_model::by_id("tmcm-1310").unwrap()).unwrap();
        assert_eq!((cl.encoder_init, cl.closed_loop, cl.active, cl.position_error), (132, 129, 133, Some(237)));
        assert_eq!(cl.settings, [125, 134, 17, 124, 126, 113, 114]);
        let why = explain_motion(Some(pd113), true, 51200).unwrap();
        assert!(why.contains("0..2047 TMC428 v units"), "{why}");
        assert_eq!(explain_motion(Some(pd113), true, 700), None);
    }

    #[test]
    fn refusals_in_words() {
        let m = tmcl_model::by_id("pd28-1021");
        let why = explain(m, true, 0, 4, Status::InvalidValue, Some(0), false).unwrap();
        assert_eq!(why, "MaxPositioningSpeed takes 1..2147483647");
        let why = explain(m, true, 0, 8, Status::WrongType, Some(1), false).unwrap();
        assert_eq!(why, "PositionReachedFlag is read-only (R)");
        assert!(explain(m, true, 0, 250, Status::WrongType, None, false).unwrap().contains("no axis parameter 250"));
        assert_eq!(explain(None, true, 0, 4, Status::InvalidCommand, None, false), None);
    }
}

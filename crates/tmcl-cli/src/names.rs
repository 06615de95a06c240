//! Parameters by name in the host commands, and `tmcl params`.
//!
//! The names are the firmware tables' identifiers, the ones the assembler's include file `TMCLParam.tmc`
//! defines (`MaxPositioningSpeed`, with or without its `AP`/`GP`/`IP` prefix), or the manual's names
//! ("Maximum positioning speed"), in any case and with or without spaces. Which table: `--module MODEL`,
//! or else the module is asked for its version string (command 136) and the model is found by it.

use crate::connection::{Connection, HostClient};
use crate::error::{CliError, ReplyJson};
use clap::{Args, ValueEnum};
use std::io::Write;
use tmcl_core::model::names::{self as by_name, NameError, INTERRUPT_BANK};
use tmcl_core::model::{ModelSpec, ParamDesc, Table, Unit};
use tmcl_host::models::ModelError;
use tmcl_host::HostError;
use tmcl_wire::{Instruction, Opcode, Reply, Status};

/// `--module MODEL`: which parameter tables the names come from.
#[derive(Debug, Clone, Args)]
pub struct ModelOption {
    /// The module's model, for parameter names, ranges and units (pd28-1021, tmcm-1310, pd-113,
    /// tmcm-1140, tmcm-3110, tmcm-6110). Default: ask the module for its version string (command 136) when a name needs it.
    #[arg(long = "module", value_name = "MODEL", global = true)]
    pub module: Option<String>,
}

/// A parameter as the user wrote it.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ParamRef<'a> {
    /// `ap P --motor M`.
    Axis { param: &'a str, motor: u8 },
    /// `gp P [BANK]`.
    Global { param: &'a str, bank: Option<u8> },
}

/// The model, from `--module` or, once needed, from the module itself ([`tmcl_host::models::Models`]), and
/// the parameters named by it.
pub(crate) struct Models(tmcl_host::models::Models);

impl From<ModelError> for CliError {
    fn from(e: ModelError) -> CliError {
        match e {
            ModelError::Host(e) => CliError::Host(e),
            e @ ModelError::UnknownId(_) => CliError::Usage(e.to_string()),
            e @ ModelError::UnknownVersion { .. } => {
                CliError::Usage(format!("{e}: give parameters by number (or --module MODEL)"))
            }
        }
    }
}

impl Models {
    /// From `--module` (checked now), or to be asked.
    pub(crate) fn new(option: &ModelOption) -> Result<Models, CliError> {
        Ok(Models(tmcl_host::models::Models::new(option.module.as_deref())?))
    }

    /// The model if it is known without asking.
    pub(crate) fn known(&self) -> Option<&'static ModelSpec> {
        self.0.known()
    }

    /// The model, asking the module for its version string the first time.
    pub(crate) fn get(&mut self, client: &mut HostClient) -> Result<&'static ModelSpec, CliError> {
        Ok(self.0.get(client)?)
    }

    /// The parameter `p` names: by number (no request), or by name (asks for the model if needed).
    pub(crate) fn resolve(&mut self, p: ParamRef<'_>, client: &mut HostClient) -> Result<Target, CliError> {
        let (text, axis, index) = match p {
            ParamRef::Axis { param, motor } => (param, true, Some(motor)),
            ParamRef::Global { param, bank } => (param, false, bank),
        };
        if let Some(number) = param_number(text) {
            let index = index.unwrap_or(0);
            let known = self.known();
            let desc = known.and_then(|m| by_name::find(m, axis, index, number));
            return Ok(Target { axis, number, index, desc, model: known });
        }
        let model = self.get(client)?;
        lookup(model, text, axis, index)
    }
}

/// `target` with the descriptor `model` has for its number.
pub(crate) fn lookup_number(model: &'static ModelSpec, target: Target) -> Target {
    let desc = by_name::find(model, target.axis, target.index, target.number);
    Target { desc, model: Some(model), ..target }
}

/// Finds a parameter of `model` by name ([`tmcl_core::model::names::lookup`]); `index` is the motor of an axis
/// parameter or the bank of a global one.
pub(crate) fn lookup(model: &'static ModelSpec, text: &str, axis: bool, index: Option<u8>) -> Result<Target, CliError> {
    match by_name::lookup(model, text, axis, if axis { None } else { index }) {
        Ok(found) => {
            let index = if axis { index.unwrap_or(0) } else { found.bank };
            Ok(Target { axis, number: found.number, index, desc: Some(found.desc), model: Some(model) })
        }
        Err(e @ NameError::Unknown { .. }) => {
            Err(CliError::Usage(format!("{e} (`tmcl params --module {}` lists them)", model.id)))
        }
        Err(e) => Err(CliError::Usage(e.to_string())),
    }
}

/// A resolved parameter: what to send, and what the tables say about it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Target {
    /// An axis parameter (else global).
    pub axis: bool,
    /// Its number (the type byte).
    pub number: u8,
    /// The motor (axis) or bank (global).
    pub index: u8,
    /// The descriptor, if the model is known and has the parameter.
    pub desc: Option<&'static ParamDesc>,
    /// The model, if known.
    pub model: Option<&'static ModelSpec>,
}

/// A parameter's reply as `--json` prints it: the reply, the parameter's number (`type`), its motor or
/// bank, and its name and unit when the tables know them. (Keys in the order of their names, as the output
/// always had them.)
#[derive(Debug, serde::Serialize)]
pub(crate) struct ParamReplyJson {
    pub address: u8,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bank: Option<u8>,
    pub host: u8,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor: Option<u8>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<&'static str>,
    pub opcode: u8,
    pub status: u8,
    pub status_text: &'static str,
    #[serde(rename = "type")]
    pub kind: u8,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unit: Option<&'static str>,
    pub value: i32,
}

impl Target {
    /// The instruction `opcode` on this parameter with `value`.
    pub(crate) fn instruction(&self, opcode: Opcode, value: i32) -> Instruction {
        Instruction::new(opcode, self.number, self.index, value)
    }

    /// GAP or GGP.
    pub(crate) fn read_opcode(&self) -> Opcode {
        if self.axis {
            Opcode::Gap
        } else {
            Opcode::Ggp
        }
    }

    /// SAP or SGP.
    pub(crate) fn write_opcode(&self) -> Opcode {
        if self.axis {
            Opcode::Sap
        } else {
            Opcode::Sgp
        }
    }

    /// `axis` for axis parameters, else `global`.
    pub(crate) fn store_opcode(&self, axis: Opcode, global: Opcode) -> Opcode {
        if self.axis {
            axis
        } else {
            global
        }
    }

    /// `ap 4`, `ap 4 (motor 1)`, `gp 0 (bank 3)`, followed by the name when it is known.
    pub(crate) fn label(&self) -> String {
        let mut label = match (self.axis, self.index) {
            (true, 0) => format!("ap {}", self.number),
            (true, m) => format!("ap {} (motor {m})", self.number),
            (false, 0) => format!("gp {}", self.number),
            (false, b) => format!("gp {} (bank {b})", self.number),
        };
        if let Some(desc) = self.desc {
            label.push(' ');
            label.push_str(desc.ident);
        }
        label
    }

    /// `value` followed by the unit, when it is known.
    pub(crate) fn with_unit(&self, value: i32) -> String {
        match self.desc.map(|d| d.unit) {
            Some(unit) if unit != Unit::None => format!("{value} {}", unit.symbol()),
            _ => value.to_string(),
        }
    }

    /// The reply as JSON, with the parameter's name and unit when they are known.
    pub(crate) fn json(&self, reply: &Reply) -> ParamReplyJson {
        let r = ReplyJson::from(reply);
        ParamReplyJson {
            address: r.address,
            bank: (!self.axis).then_some(self.index),
            host: r.host,
            motor: self.axis.then_some(self.index),
            name: self.desc.map(|d| d.ident),
            opcode: r.opcode,
            status: r.status,
            status_text: r.status_text,
            kind: self.number,
            unit: self.desc.map(|d| d.unit.symbol()),
            value: r.value,
        }
    }

    /// A refusal of the module, explained from the tables where they say why
    /// ([`tmcl_core::model::names::explain`]).
    pub(crate) fn explain(&self, err: HostError, value: Option<i32>) -> CliError {
        let HostError::Status { status, .. } = &err else { return err.into() };
        if let Some(model) =
            self.model.filter(|m| self.axis && *status == Status::InvalidValue && self.index >= m.motors)
        {
            let explanation = format!("{} (--motor {} given)", motors_of(model), self.index);
            return CliError::Explained { source: err, explanation };
        }
        let Some(refusal) = by_name::explain(self.model, self.axis, self.index, self.number, *status, value, false)
        else {
            return err.into();
        };
        let explanation = match (&refusal, self.model) {
            (by_name::Refusal::NoSuchParam { .. }, Some(model)) => {
                format!("{refusal} (`tmcl params --module {}` lists them)", model.id)
            }
            _ => refusal.to_string(),
        };
        CliError::Explained { source: err, explanation }
    }
}

/// `the TMCM-3110 has motors 0..2`, `the PD28-1021 has motor 0`.
pub(crate) fn motors_of(model: &ModelSpec) -> String {
    match model.motors {
        1 => format!("the {} has motor 0", model.name),
        n => format!("the {} has motors 0..{}", model.name, n - 1),
    }
}

/// A parameter number: decimal or 0x hexadecimal, 0..255.
fn param_number(text: &str) -> Option<u8> {
    crate::args::parse_number(text).and_then(|n| u8::try_from(n).ok())
}

/// Which tables `tmcl params` lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Which {
    /// Axis parameters (GAP/SAP).
    Ap,
    /// Global parameters of bank 0 (GGP/SGP).
    Gp,
    /// The interrupt configuration, global parameters of bank 3.
    Ip,
    /// All three.
    All,
}

/// Options of `tmcl params`.
#[derive(Debug, Clone, Args)]
pub struct ParamsArgs {
    #[command(flatten)]
    pub conn: Connection,
    #[command(flatten)]
    pub model: ModelOption,
    /// Which parameters.
    #[arg(value_enum, default_value_t = Which::All)]
    pub which: Which,
    /// The motor whose axis parameters are listed (without it: every motor of the model, `ap N:M` for
    /// motor M > 0).
    #[arg(long, short)]
    pub motor: Option<u8>,
    /// List the tables only, without reading values (needs no module with --module).
    #[arg(long)]
    pub no_values: bool,
    /// Save every readable parameter (all motors, banks 0 and 3, the user variables) with the model, version,
    /// names and units to FILE (TOML).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["load", "diff", "no_values"])]
    pub save: Option<std::path::PathBuf>,
    /// Write the settings of a saved FILE to the module: read-only values, state (target and actual
    /// position, speeds, ...) and the settings that decide how the module is reached are skipped, each
    /// refusal is reported (exit 1 if any).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["diff", "no_values"])]
    pub load: Option<std::path::PathBuf>,
    /// With --load: store each value in the EEPROM too (STAP/STGP), where the parameter can be stored.
    #[arg(long, requires = "load")]
    pub store: bool,
    /// With --load: accept a file of another model, matching parameters by number and refusing those whose
    /// unit differs.
    #[arg(long, requires = "load")]
    pub any_model: bool,
    /// Show what differs between the module and a saved FILE (exit 5 if anything does).
    #[arg(long, value_name = "FILE", conflicts_with = "no_values")]
    pub diff: Option<std::path::PathBuf>,
}

/// `tmcl params`.
pub(crate) fn params(args: ParamsArgs, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let action = match (&args.save, &args.load, &args.diff) {
        (Some(path), _, _) => Some(crate::params::SetAction::Save(path)),
        (_, Some(path), _) => {
            Some(crate::params::SetAction::Load { path, store: args.store, any_model: args.any_model })
        }
        (_, _, Some(path)) => Some(crate::params::SetAction::Diff(path)),
        _ => None,
    };
    if let Some(action) = action {
        if !args.conn.given() {
            return Err(CliError::Usage("parameter sets need a module: give --port or --tcp".into()));
        }
        let mut models = Models::new(&args.model)?;
        let mut client = args.conn.open()?;
        let model = models.get(&mut client)?;
        return crate::params::run(action, &mut client, model, json, out);
    }
    let offline = args.no_values || !args.conn.given();
    let mut models = Models::new(&args.model)?;
    let (model, mut client) = if offline {
        let Some(model) = models.known() else {
            return Err(CliError::Usage(
                "give --module MODEL to list a model's parameters, or --port/--tcp to ask a module".into(),
            ));
        };
        (model, None)
    } else {
        let mut client = args.conn.open()?;
        (models.get(&mut client)?, Some(client))
    };
    let motors = match args.motor {
        Some(m) if m >= model.motors => {
            return Err(CliError::Usage(format!("{} (--motor {m} given)", motors_of(model))));
        }
        Some(m) => m..m + 1,
        None => 0..model.motors,
    };
    let axes = motors.map(|m| (Which::Ap, "ap", &model.axis, true, m));
    let tables: Vec<(&str, &'static Table, bool, u8)> = axes
        .chain([(Which::Gp, "gp", &model.global, false, 0), (Which::Ip, "gp", &model.interrupt, false, INTERRUPT_BANK)])
        .filter(|(w, ..)| args.which == Which::All || args.which == *w)
        .map(|(_, kind, table, axis, index)| (kind, table, axis, index))
        .collect();
    if !json {
        writeln!(out, "{} ({}), {}", model.name, model.id, model.manual)?;
        writeln!(out, "{:<11} {:<28} {:<6} {:<24} {:<22} value", "parameter", "name", "access", "range", "unit")?;
    }
    for (kind, table, axis, index) in tables {
        for desc in table.params {
            let target = Target { axis, number: desc.number, index, desc: Some(desc), model: Some(model) };
            let value = match client.as_mut() {
                Some(client) if desc.access.read => {
                    Some(client.request(target.instruction(target.read_opcode(), 0)).map(|r| r.value))
                }
                _ => None,
            };
            let value = match value {
                None => None,
                Some(Ok(v)) => Some(Ok(v)),
                Some(Err(HostError::Status { status, .. })) => Some(Err(status)),
                Some(Err(e)) => return Err(e.into()),
            };
            let place = match (axis, index) {
                (true, 0) | (false, 0) => format!("{kind} {}", desc.number),
                (true, m) => format!("{kind} {}:{m}", desc.number),
                (false, b) => format!("{kind} {}:{b}", desc.number),
            };
            if json {
                let row = crate::output::ParamRow {
                    access: desc.access.to_string(),
                    bank: (!axis).then_some(index),
                    default: desc.default,
                    motor: axis.then_some(index),
                    name: desc.ident,
                    range: desc.range.to_string(),
                    section: desc.section,
                    status: match value {
                        Some(Err(status)) => Some(u8::from(status)),
                        _ => None,
                    },
                    title: desc.name,
                    kind: desc.number,
                    unit: desc.unit.symbol(),
                    value: match value {
                        Some(Ok(v)) => Some(Some(v)),
                        Some(Err(_)) => None,
                        None => Some(None),
                    },
                };
                crate::output::json_line(out, &row)?;
            } else {
                let value = match value {
                    None if !desc.access.read && !offline => "(write only)".to_string(),
                    None => String::new(),
                    Some(Ok(v)) => v.to_string(),
                    Some(Err(status)) => format!("status {status}"),
                };
                writeln!(
                    out,
                    "{place:<11} {:<28} {:<6} {:<24} {:<22} {value}",
                    desc.ident,
                    desc.access.to_string(),
                    desc.range.to_string(),
                    desc.unit.symbol()
                )?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_core::model::{self, Range};
    use tmcl_wire::Status;

    fn pd28() -> &'static ModelSpec {
        model::by_id("pd28-1021").unwrap()
    }

    #[test]
    fn names_in_any_spelling() {
        for text in ["MaxPositioningSpeed", "maxpositioningspeed", "APMaxPositioningSpeed", "Maximum positioning speed"]
        {
            let t = lookup(pd28(), text, true, None).unwrap();
            assert_eq!((t.number, t.index, t.axis), (4, 0, true), "{text}");
        }
        let t = lookup(pd28(), "SerialAddress", false, None).unwrap();
        assert_eq!((t.number, t.index), (66, 0));
        // A bank 3 name picks bank 3.
        let t = lookup(pd28(), "Timer0Period", false, None).unwrap();
        assert_eq!((t.number, t.index), (0, 3));
        let t = lookup(pd28(), "ipTimer0Period", false, Some(3)).unwrap();
        assert_eq!((t.number, t.index), (0, 3));
        assert!(lookup(pd28(), "Timer0Period", false, Some(0)).unwrap_err().to_string().contains("bank 3"));
        let t = lookup(pd28(), "MaxCurrent", true, Some(0)).unwrap();
        assert_eq!(t.label(), "ap 6 MaxCurrent");
        assert_eq!(t.with_unit(128), "128 /255 of max. current");
    }

    #[test]
    fn unknown_names_suggest_the_closest() {
        let err = lookup(pd28(), "maxspeed", true, None).unwrap_err();
        assert_eq!(err.exit_code(), crate::error::EXIT_USAGE);
        assert!(err.to_string().contains("did you mean MaxPositioningSpeed?"), "{err}");
        let err = lookup(pd28(), "speed", true, None).unwrap_err().to_string();
        assert!(err.contains("did you mean one of TargetSpeed, ActualSpeed, MinimumSpeed?"), "{err}");
        let err = lookup(pd28(), "MaxPositionSpeed", true, None).unwrap_err().to_string();
        assert!(err.contains("did you mean MaxPositioningSpeed?"), "{err}");
        assert!(err.contains("tmcl params --module pd28-1021"), "{err}");
    }

    #[test]
    fn refusals_are_explained() {
        let t = lookup(pd28(), "MaxPositioningSpeed", true, None).unwrap();
        let reply = Reply { host: 2, module: 1, status: Status::InvalidValue, opcode: 5, value: 0 };
        let err = t.explain(HostError::Status { status: Status::InvalidValue, reply }, Some(0));
        assert_eq!(err.exit_code(), crate::error::EXIT_STATUS);
        assert!(err.to_string().ends_with("MaxPositioningSpeed takes 1..2147483647"), "{err}");
        let t = Target { axis: true, number: 100, index: 0, desc: None, model: Some(pd28()) };
        let reply = Reply { status: Status::WrongType, opcode: 6, ..reply };
        let err = t.explain(HostError::Status { status: Status::WrongType, reply }, None);
        assert!(
            err.to_string()
                .ends_with("the PD28-1021 has no axis parameter 100 (`tmcl params --module pd28-1021` lists them)"),
            "{err}"
        );
        let t = lookup(pd28(), "ActualSpeed", true, None).unwrap();
        assert_eq!(t.desc.unwrap().access.to_string(), "RW");
    }

    #[test]
    fn a_motor_the_model_lacks_is_explained() {
        let m3110 = model::by_id("tmcm-3110").unwrap();
        let t = lookup(m3110, "MaxVelocity", true, Some(3)).unwrap();
        let reply = Reply { host: 2, module: 1, status: Status::InvalidValue, opcode: 6, value: 0 };
        let err = t.explain(HostError::Status { status: Status::InvalidValue, reply }, None);
        assert!(err.to_string().ends_with("the TMCM-3110 has motors 0..2 (--motor 3 given)"), "{err}");
        assert_eq!(motors_of(pd28()), "the PD28-1021 has motor 0");
    }

    #[test]
    fn ranges_as_text() {
        assert_eq!(Range::Signed(1, 8).to_string(), "1..8");
        assert_eq!(Range::OneOf(&[1..=8, 65..=68, 129..=129]).to_string(), "1..8, 65..68, 129");
        assert_eq!(Range::Unsigned32.to_string(), "0..4294967295");
    }
}

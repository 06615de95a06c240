//! Parameter sets: `tmcl params --save FILE`, `--load FILE [--store]` and `--diff FILE`.
//!
//! A set is a TOML file with the module's model, version string and address, and one `[[param]]` table per
//! readable parameter: which (axis parameter and motor, or global parameter and bank), its number, its
//! name and unit from the model's tables, and the value read (PD28-1021 TMCL manual §3.7.6 GAP, §3.7.10
//! GGP; bank 2 holds the user variables, §5.3).
//!
//! **Loading** writes back what is a setting: plain stored values and those the firmware reads by meaning
//! (speeds, currents, switches, closed-loop gains, ...). It skips what cannot or must not be written:
//! read-only values, the state a write would act on (a target position starts a move, a target speed a
//! rotation, an actual position sets the counter), and the settings that decide how the module is reached
//! (its address, baud rate, host address, reply switch): a set carried to another module must not cut the
//! line it is loaded over. Each refusal of the module is reported with what the tables say about it.
//!
//! **Another model.** A file of another model is refused unless `--any-model` says so; then each
//! parameter is matched by its kind, bank and number, and one whose unit differs on this model (the
//! PDx-113's TMC428 velocity units against the PD28-1021's pps) is refused, never converted silently.

use crate::{Client, HostError, Transport};
use serde::{Deserialize, Serialize};
use tmcl_model::{ModelSpec, ParamDesc, Role, Setting, MODELS};
use tmcl_wire::{Command, Status};

/// The bank of the user variables (PD28-1021 manual §5.3).
pub const USER_BANK: u8 = 2;
/// The bank of the interrupt configuration (PD28-1021 manual §5.4).
const INTERRUPT_BANK: u8 = 3;

/// An axis or a global parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// An axis parameter (SAP/GAP), of a motor.
    Ap,
    /// A global parameter (SGP/GGP), of a bank.
    Gp,
}

/// A parameter set as saved.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ParamFile {
    /// Where the values came from.
    pub module: ModuleInfo,
    /// The values, one table each.
    #[serde(default, rename = "param")]
    pub params: Vec<Entry>,
}

/// The module a set was read from.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ModuleInfo {
    /// The model's id (`pd28-1021`).
    pub model: String,
    /// The model's name (`PD28-1021`).
    #[serde(default)]
    pub name: String,
    /// The version string (command 136), if the module answered it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub version: Option<String>,
    /// The module address the set was read at.
    #[serde(default)]
    pub address: u8,
    /// When, in seconds since the Unix epoch.
    #[serde(default)]
    pub saved_unix: u64,
    /// What wrote it.
    #[serde(default)]
    pub tool: String,
}

/// One parameter and its value.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Entry {
    /// `ap` or `gp`.
    pub kind: Kind,
    /// The motor of an axis parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motor: Option<u8>,
    /// The bank of a global parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bank: Option<u8>,
    /// The parameter number (the type byte).
    pub number: u8,
    /// The tables' name (`MaxPositioningSpeed`; `UserVariable7` in bank 2).
    #[serde(default)]
    pub name: String,
    /// The unit of the value (`pps`), empty for a plain number.
    #[serde(default)]
    pub unit: String,
    /// The value read.
    pub value: i32,
}

impl Entry {
    /// `ap 4` (motor 0), `ap 4:1`, `gp 66`, `gp 0:3`, `gp 7:2`, as `tmcl params` writes them.
    pub fn place(&self) -> String {
        match (self.kind, self.motor.unwrap_or(0), self.bank.unwrap_or(0)) {
            (Kind::Ap, 0, _) => format!("ap {}", self.number),
            (Kind::Ap, m, _) => format!("ap {}:{m}", self.number),
            (Kind::Gp, _, 0) => format!("gp {}", self.number),
            (Kind::Gp, _, b) => format!("gp {}:{b}", self.number),
        }
    }

    /// The motor or bank.
    fn index(&self) -> u8 {
        match self.kind {
            Kind::Ap => self.motor.unwrap_or(0),
            Kind::Gp => self.bank.unwrap_or(0),
        }
    }

    fn read_command(&self) -> Command {
        match self.kind {
            Kind::Ap => Command::Gap { param: self.number, motor: self.index() },
            Kind::Gp => Command::Ggp { param: self.number, bank: self.index() },
        }
    }
}

/// What a parameter of a model is, for a set.
enum Place {
    /// In one of the model's tables.
    Table(&'static ParamDesc),
    /// A user variable (bank 2): read, written and stored (STGP) like a plain setting.
    UserVariable,
}

/// The model's descriptor of `entry`, or why the model has none.
fn place_of(model: &'static ModelSpec, entry: &Entry) -> Result<Place, String> {
    let index = entry.index();
    let (table, what) = match (entry.kind, index) {
        (Kind::Ap, m) if m >= model.motors => {
            return Err(format!("the {} has no motor {m}", model.name));
        }
        (Kind::Ap, _) => (&model.axis, "axis parameter"),
        (Kind::Gp, 0) => (&model.global, "global parameter"),
        (Kind::Gp, INTERRUPT_BANK) => (&model.interrupt, "interrupt parameter (bank 3)"),
        (Kind::Gp, USER_BANK) if u16::from(entry.number) < model.user_variables => return Ok(Place::UserVariable),
        (Kind::Gp, USER_BANK) => {
            return Err(format!("the {} has {} user variables", model.name, model.user_variables));
        }
        (Kind::Gp, b) => return Err(format!("the {} has no global parameters in bank {b}", model.name)),
    };
    table
        .params
        .iter()
        .find(|d| d.number == entry.number)
        .map(Place::Table)
        .ok_or_else(|| format!("the {} has no {what} {}", model.name, entry.number))
}

/// The factory default of `entry` on `model` (0 for a user variable), if the model has it.
pub fn default_of(model: &'static ModelSpec, entry: &Entry) -> Option<i32> {
    match place_of(model, entry).ok()? {
        Place::Table(d) => Some(d.default),
        Place::UserVariable => Some(0),
    }
}

/// The settings that decide how the module is reached (PD28-1021 manual §5.1 Table 17: GP 65, 66, 67, 75,
/// 76, 87, 255): a set loaded over a line does not change them.
fn is_interface(desc: &ParamDesc) -> bool {
    matches!(
        desc.setting,
        Some(
            Setting::BaudRate
                | Setting::SerialAddress
                | Setting::AsciiMode
                | Setting::SerialHeartbeat
                | Setting::TelegramPause
                | Setting::HostAddress
                | Setting::SecondaryAddress
                | Setting::SuppressReply
        )
    ) || desc.role == Role::Password
}

/// Whether writing `desc` sets a value rather than acting on the module's state: plain stored values,
/// the settings the firmware reads by meaning, and the microstep resolution, ramp mode and encoder
/// prescaler. A target position, a target speed, an actual position or velocity, an encoder counter, a
/// torque target, an encoder initialisation and the like are state.
fn is_setting(desc: &ParamDesc) -> bool {
    desc.role == Role::Plain
        || desc.setting.is_some()
        || matches!(desc.role, Role::MicrostepResolution | Role::RampMode | Role::EncoderPrescaler)
}

/// Every parameter of the model's tables with its place: the axis parameters of each motor, then the
/// global parameters of bank 0 and of the interrupt bank (the user variables are not in the tables).
fn tabled(model: &'static ModelSpec) -> impl Iterator<Item = (Kind, u8, &'static ParamDesc)> {
    let axes = (0..model.motors).flat_map(move |motor| model.axis.params.iter().map(move |d| (Kind::Ap, motor, d)));
    let global = model.global.params.iter().map(|d| (Kind::Gp, 0, d));
    let interrupt = model.interrupt.params.iter().map(|d| (Kind::Gp, INTERRUPT_BANK, d));
    axes.chain(global).chain(interrupt)
}

impl Entry {
    /// The entry of parameter `d` at motor or bank `index`, its value not read yet (0).
    fn of(kind: Kind, index: u8, d: &ParamDesc) -> Entry {
        Entry {
            kind,
            motor: (kind == Kind::Ap).then_some(index),
            bank: (kind == Kind::Gp).then_some(index),
            number: d.number,
            name: d.ident.to_string(),
            unit: d.unit.symbol().to_string(),
            value: 0,
        }
    }
}

/// Reads every readable parameter of `model` from the module: the axis parameters of every motor, the
/// global parameters of banks 0 and 3, and the user variables. A value the module refuses to give is
/// left out and named in the returned notes.
pub fn read_all(
    client: &mut Client<impl Transport>,
    model: &'static ModelSpec,
) -> Result<(Vec<Entry>, Vec<String>), HostError> {
    let mut entries = Vec::new();
    let mut notes = Vec::new();
    let mut wanted: Vec<Entry> =
        tabled(model).filter(|(_, _, d)| d.access.read).map(|(kind, index, d)| Entry::of(kind, index, d)).collect();
    for n in 0..model.user_variables.min(256) {
        wanted.push(Entry {
            kind: Kind::Gp,
            motor: None,
            bank: Some(USER_BANK),
            number: n as u8,
            name: format!("UserVariable{n}"),
            unit: String::new(),
            value: 0,
        });
    }
    for mut entry in wanted {
        match client.request(entry.read_command().encode()) {
            Ok(reply) => {
                entry.value = reply.value;
                entries.push(entry);
            }
            Err(HostError::Status { status, .. }) => {
                notes.push(format!("{} {}: not read, the module answered status {status}", entry.place(), entry.name));
            }
            Err(e) => return Err(e),
        }
    }
    Ok((entries, notes))
}

fn now_unix() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

/// A parameter set of `model` read from the module now.
pub fn snapshot(
    client: &mut Client<impl Transport>,
    model: &'static ModelSpec,
) -> Result<(ParamFile, Vec<String>), HostError> {
    let version = client.version_string().ok();
    let (params, notes) = read_all(client, model)?;
    let module = ModuleInfo {
        model: model.id.to_string(),
        name: model.name.to_string(),
        version,
        address: client.module_address,
        saved_unix: now_unix(),
        tool: format!("tmcl {}", env!("CARGO_PKG_VERSION")),
    };
    Ok((ParamFile { module, params }, notes))
}

/// The set as TOML, with a header saying what it is.
pub fn to_toml(file: &ParamFile) -> Result<String, String> {
    let body = toml::to_string(file).map_err(|e| format!("cannot write the parameter set: {e}"))?;
    Ok(format!(
        "# A parameter set of a {} (`tmcl params --save`). `tmcl params --load FILE [--store]` writes it to a\n\
         # module, `tmcl params --diff FILE` compares. Values are in the units named beside them.\n\n{body}",
        file.module.name
    ))
}

/// A set from its TOML text.
pub fn from_toml(text: &str) -> Result<ParamFile, String> {
    toml::from_str(text).map_err(|e| format!("not a parameter set: {e}"))
}

/// What happened to one parameter of a set (a `--json` line of `--load` and `--diff`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Outcome {
    /// `ap 4`, `gp 66`, `gp 7:2`.
    pub param: String,
    /// The tables' name.
    pub name: String,
    /// `written`, `stored`, `unchanged`, `skipped`, `refused` (load); `same`, `differs`, `live`, `unread` (diff).
    pub result: String,
    /// The value in the file.
    pub value: i32,
    /// Its unit.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub unit: String,
    /// The module's value (diff; after a load, what it reads back).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub module: Option<i32>,
    /// Why, in words (skips and refusals).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub why: Option<String>,
}

/// How to load a set.
#[derive(Debug, Clone, Copy, Default)]
pub struct LoadOptions {
    /// Store each value in the EEPROM as well (STAP/STGP), where the parameter can be stored.
    pub store: bool,
    /// Write the settings that decide how the module is reached too (the twin, which is made in process).
    pub interface: bool,
}

/// Checks that `file` is of `model`, unless `any_model`.
pub fn check_model(file: &ParamFile, model: &'static ModelSpec, any_model: bool) -> Result<(), String> {
    if file.module.model == model.id || any_model {
        return Ok(());
    }
    let known = MODELS.iter().any(|m| m.id == file.module.model);
    Err(format!(
        "the set is of a {}{}, the module is a {} ({}): load it as another model's set to load what matches by \
         number and unit",
        if file.module.name.is_empty() { &file.module.model } else { &file.module.name },
        if known { "" } else { " (a model OpenTMCL does not know)" },
        model.name,
        model.id
    ))
}

/// Writes the settings of `file` to the module; one outcome per parameter.
pub fn load(
    client: &mut Client<impl Transport>,
    model: &'static ModelSpec,
    file: &ParamFile,
    options: LoadOptions,
) -> Result<Vec<Outcome>, HostError> {
    let mut out = Vec::new();
    for entry in &file.params {
        let outcome = |result: &str, why: Option<String>| Outcome {
            param: entry.place(),
            name: entry.name.clone(),
            result: result.into(),
            value: entry.value,
            unit: entry.unit.clone(),
            module: None,
            why,
        };
        let desc = match place_of(model, entry) {
            Ok(Place::Table(d)) => Some(d),
            Ok(Place::UserVariable) => None,
            Err(why) => {
                out.push(outcome("skipped", Some(why)));
                continue;
            }
        };
        if let Some(d) = desc {
            let skip = if !d.access.write {
                Some(format!("read-only ({})", d.access))
            } else if !is_setting(d) {
                Some("state, not a setting: writing it would act on the module".to_string())
            } else if !options.interface && is_interface(d) {
                Some("decides how the module is reached: set it by hand".to_string())
            } else if d.unit.symbol() != entry.unit {
                Some(format!(
                    "the unit differs: {} in the file, {} on the {}; not converted",
                    if entry.unit.is_empty() { "none" } else { &entry.unit },
                    if d.unit.symbol().is_empty() { "none" } else { d.unit.symbol() },
                    model.name
                ))
            } else {
                None
            };
            if let Some(why) = skip {
                out.push(outcome("skipped", Some(why)));
                continue;
            }
        }
        let (index, number, value) = (entry.index(), entry.number, entry.value);
        // A value the module holds already is not written again: a protected or otherwise touchy
        // parameter is only asked for where it changes.
        let readable = desc.is_none_or(|d| d.access.read);
        let current = if readable { client.request(entry.read_command().encode()).ok().map(|r| r.value) } else { None };
        let protected = desc.is_some_and(|d| d.access.protected);
        if current == Some(value) && (!options.store || protected) {
            out.push(outcome("unchanged", None));
            continue;
        }
        let write = match entry.kind {
            Kind::Ap => Command::Sap { param: number, motor: index, value },
            Kind::Gp => Command::Sgp { param: number, bank: index, value },
        };
        match client.request(write.encode()) {
            Ok(_) => {}
            Err(HostError::Status { status, .. }) => {
                let why = explain(model, desc, status, value);
                out.push(outcome("refused", Some(why)));
                continue;
            }
            Err(e) => return Err(e),
        }
        // User variables 0..stored_user_variables can be stored (STGP bank 2, PD28-1021 manual §5.3).
        let storable = desc.map_or(u16::from(number) < model.stored_user_variables, |d| d.access.store);
        let mut result = "written";
        if options.store && storable {
            let store = match entry.kind {
                Kind::Ap => Command::Stap { param: number, motor: index },
                Kind::Gp => Command::Stgp { param: number, bank: index },
            };
            match client.request(store.encode()) {
                Ok(_) => result = "stored",
                Err(HostError::Status { status, .. }) => {
                    out.push(outcome("refused", Some(format!("written, but not stored: status {status}"))));
                    continue;
                }
                Err(e) => return Err(e),
            }
        } else if desc.is_some_and(|d| d.access.auto) {
            result = "stored";
        }
        out.push(outcome(result, None));
    }
    Ok(out)
}

/// Stores every parameter of `model` that can be stored (E in the tables) in the EEPROM: STAP for each
/// motor, STGP for banks 0 and 3 (PD28-1021 manual §3.7.7, §3.7.11).
pub fn store_all(client: &mut Client<impl Transport>, model: &'static ModelSpec) -> Result<Vec<Outcome>, HostError> {
    let mut out = Vec::new();
    for (kind, index, d) in tabled(model) {
        if d.access.store {
            let entry = Entry::of(kind, index, d);
            let store = match kind {
                Kind::Ap => Command::Stap { param: d.number, motor: index },
                Kind::Gp => Command::Stgp { param: d.number, bank: index },
            };
            let (result, why) = match client.request(store.encode()) {
                Ok(_) => ("stored", None),
                Err(HostError::Status { status, .. }) => ("refused", Some(explain(model, Some(d), status, 0))),
                Err(e) => return Err(e),
            };
            out.push(Outcome {
                param: entry.place(),
                name: entry.name,
                result: result.into(),
                value: 0,
                unit: entry.unit,
                module: None,
                why,
            });
        }
    }
    Ok(out)
}

fn explain(model: &'static ModelSpec, desc: Option<&ParamDesc>, status: Status, value: i32) -> String {
    let base = format!("status {status}");
    match (desc, status) {
        (Some(d), Status::InvalidValue) if !d.range.contains(value) => {
            format!("{base}: {} takes {} on the {}", d.ident, d.range, model.name)
        }
        (Some(d), Status::PasswordProtected) => {
            format!("{base}: {} is password protected; write the password parameter first", d.ident)
        }
        (_, Status::EepromLocked) => format!("{base}: the configuration EEPROM is locked"),
        _ => base,
    }
}

/// Compares the module with `file`: the settings a load would write and the user variables. Live
/// values (positions, speeds, flags, the tick timer) are not compared: they are `live`.
pub fn diff(
    client: &mut Client<impl Transport>,
    model: &'static ModelSpec,
    file: &ParamFile,
) -> Result<Vec<Outcome>, HostError> {
    let mut out = Vec::new();
    for entry in &file.params {
        let live = match place_of(model, entry) {
            Ok(Place::Table(d)) => !d.access.write || !is_setting(d),
            Ok(Place::UserVariable) | Err(_) => false,
        };
        let (result, module, why) = match client.request(entry.read_command().encode()) {
            Ok(reply) if live => ("live", Some(reply.value), None),
            Ok(reply) if reply.value == entry.value => ("same", Some(reply.value), None),
            Ok(reply) => ("differs", Some(reply.value), None),
            Err(HostError::Status { status, .. }) => ("unread", None, Some(format!("status {status}"))),
            Err(e) => return Err(e),
        };
        out.push(Outcome {
            param: entry.place(),
            name: entry.name.clone(),
            result: result.into(),
            value: entry.value,
            unit: entry.unit.clone(),
            module,
            why,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_round_trips_through_toml() {
        let file = ParamFile {
            module: ModuleInfo {
                model: "pd28-1021".into(),
                name: "PD28-1021".into(),
                version: Some("1021V142".into()),
                address: 1,
                saved_unix: 1,
                tool: "tmcl".into(),
            },
            params: vec![
                Entry {
                    kind: Kind::Ap,
                    motor: Some(0),
                    bank: None,
                    number: 4,
                    name: "MaxPositioningSpeed".into(),
                    unit: "pps".into(),
                    value: 30000,
                },
                Entry {
                    kind: Kind::Gp,
                    motor: None,
                    bank: Some(2),
                    number: 7,
                    name: "UserVariable7".into(),
                    unit: String::new(),
                    value: -5,
                },
            ],
        };
        let text = to_toml(&file).unwrap();
        assert!(text.contains("[[param]]") && text.contains("model = \"pd28-1021\""), "{text}");
        let back: ParamFile = toml::from_str(&text).unwrap();
        assert_eq!(back.params, file.params);
        assert_eq!(back.params[1].place(), "gp 7:2");
    }

    #[test]
    fn state_and_interface_are_not_settings_to_load() {
        let m = tmcl_model::by_id("pd28-1021").unwrap();
        let find = |n: u8| m.axis.params.iter().find(|d| d.number == n).unwrap();
        assert!(!is_setting(find(0)) && !is_setting(find(1)) && !is_setting(find(2)));
        assert!(is_setting(find(4)) && is_setting(find(6)) && is_setting(find(140)));
        let address = m.global.params.iter().find(|d| d.number == 66).unwrap();
        assert!(is_interface(address));
    }
}

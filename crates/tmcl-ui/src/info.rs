//! What the page learns about the module: the model's tables as JSON, and refusals explained from them.

use serde_json::{json, Value};
use tmcl_model::{ModelSpec, ParamDesc, PortKind, Table, MODELS};
use tmcl_wire::Status;

/// The bank of the interrupt configuration (PD28-1021 manual §5.4).
pub(crate) const INTERRUPT_BANK: u8 = 3;

/// The model whose version string starts like `text` (the module number and the `V`, e.g. `1021V`).
pub(crate) fn model_by_version(text: &str) -> Option<&'static ModelSpec> {
    let prefix = text.get(..5)?;
    MODELS.iter().copied().find(|m| m.version_string.get(..5) == Some(prefix.as_bytes()))
}

/// One parameter as the page's table shows it.
fn param_json(kind: &str, bank: Option<u8>, d: &ParamDesc) -> Value {
    json!({
        "kind": kind, "bank": bank, "number": d.number, "name": d.ident, "title": d.name,
        "unit": d.unit.symbol(), "range": d.range.to_string(), "access": d.access.to_string(),
        "read": d.access.read, "write": d.access.write, "store": d.access.store,
        "default": d.default, "section": d.section,
    })
}

/// The model as the page needs it: names, tables, ports, counts.
pub(crate) fn model_json(model: &'static ModelSpec) -> Value {
    let table = |kind: &str, bank: Option<u8>, t: &Table| -> Vec<Value> {
        t.params.iter().map(|d| param_json(kind, bank, d)).collect()
    };
    let mut params = table("ap", None, &model.axis);
    params.extend(table("gp", Some(0), &model.global));
    params.extend(table("gp", Some(INTERRUPT_BANK), &model.interrupt));
    let ports: Vec<Value> = model
        .ports
        .iter()
        .filter(|p| !matches!(p.kind, PortKind::AllInputs | PortKind::AllOutputs))
        .map(|p| {
            let kind = match p.kind {
                PortKind::DigitalInput(_) | PortKind::EncoderNearZero => "input",
                PortKind::Analog(_) | PortKind::Analog10(_) => "analog",
                PortKind::Temperature => "temperature",
                PortKind::Output(_) => "output",
                PortKind::AllInputs | PortKind::AllOutputs => "all",
            };
            json!({"bank": p.bank, "port": p.port, "kind": kind, "name": p.name})
        })
        .collect();
    json!({
        "id": model.id, "name": model.name, "manual": model.manual, "motors": model.motors,
        "user_variables": model.user_variables, "program_memory": model.program_memory,
        "params": params, "ports": ports,
    })
}

/// The descriptor of a parameter, if the model has it.
pub(crate) fn find_param(model: &'static ModelSpec, axis: bool, index: u8, number: u8) -> Option<&'static ParamDesc> {
    let table = match (axis, index) {
        (true, _) => &model.axis,
        (false, 0) => &model.global,
        (false, INTERRUPT_BANK) => &model.interrupt,
        (false, _) => return None,
    };
    table.params.iter().find(|d| d.number == number)
}

/// Why the module refused a parameter request, in words, from what the tables say (as `tmcl set` does).
pub(crate) fn explain(
    model: Option<&'static ModelSpec>,
    axis: bool,
    index: u8,
    number: u8,
    status: Status,
    value: Option<i32>,
) -> Option<String> {
    let desc = model.and_then(|m| find_param(m, axis, index, number));
    let kind = if axis { "axis" } else { "global" };
    Some(match (model, desc, status) {
        (Some(model), None, Status::WrongType) => format!("the {} has no {kind} parameter {number}", model.name),
        (_, Some(d), Status::WrongType) if value.is_some() && !d.access.write => {
            format!("{} is read-only ({})", d.ident, d.access)
        }
        (_, Some(d), Status::WrongType) if value.is_none() && !d.access.read => {
            format!("{} cannot be read ({})", d.ident, d.access)
        }
        (_, Some(d), Status::InvalidValue) if value.is_some_and(|v| !d.range.contains(v)) => {
            format!("{} takes {}", d.ident, d.range)
        }
        (_, Some(d), Status::InvalidValue) if value.is_none() && !d.access.store => {
            format!("{} cannot be stored in the EEPROM ({})", d.ident, d.access)
        }
        (_, _, Status::PasswordProtected) => {
            "the parameter is password protected: write the password to the model's password parameter first".into()
        }
        (_, _, Status::EepromLocked) => "the configuration EEPROM is locked".into(),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tables_as_json() {
        let m = tmcl_model::by_id("pd28-1021").unwrap();
        let j = model_json(m);
        let params = j["params"].as_array().unwrap();
        let speed = params.iter().find(|p| p["kind"] == "ap" && p["number"] == 4).unwrap();
        assert_eq!(speed["name"], "MaxPositioningSpeed");
        assert_eq!(speed["access"], "RWE");
        assert_eq!(speed["range"], "1..2147483647");
        assert!(params.iter().any(|p| p["kind"] == "gp" && p["bank"] == 3));
        assert!(j["ports"].as_array().unwrap().iter().any(|p| p["kind"] == "output"));
        assert_eq!(model_by_version("1021V142").map(|m| m.id), Some("pd28-1021"));
        assert!(model_by_version("10").is_none());
    }

    #[test]
    fn refusals_in_words() {
        let m = tmcl_model::by_id("pd28-1021");
        let why = explain(m, true, 0, 4, Status::InvalidValue, Some(0)).unwrap();
        assert_eq!(why, "MaxPositioningSpeed takes 1..2147483647");
        let why = explain(m, true, 0, 8, Status::WrongType, Some(1)).unwrap();
        assert_eq!(why, "PositionReachedFlag is read-only (R)");
        assert!(explain(m, true, 0, 250, Status::WrongType, None).unwrap().contains("no axis parameter 250"));
        assert_eq!(explain(None, true, 0, 4, Status::InvalidCommand, None), None);
    }
}

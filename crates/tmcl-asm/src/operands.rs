//! What a model's tables say about an instruction's constant operands: a parameter, bank, port or motor
//! the model lacks, a value outside a parameter's range. The module refuses such an instruction with a
//! status (PD28-1021 manual §3.2.1, Table 4: 3 wrong type, 4 invalid value) and a program skips it; the
//! assembler warns at its line ([`check_operands`]) and the simulator explains a refusal with the same
//! sentence ([`why_refused`]).
//!
//! Only what the tables decide is checked: whether a command can run *now* (a reference search while
//! the loop is open, a write to a protected parameter before the password) depends on the module's state
//! and is left to the run.

use crate::assemble::Program;
use crate::diag::Diagnostic;
use tmcl_model::{ModelSpec, ParamDesc, PortKind, Role, Table};
use tmcl_wire::{Command, Instruction, MoveTarget, Status};

/// Why the tables of a model refuse an instruction.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Finding {
    /// Which operand, counting from 0 in source order (`SAP type, motor, value`; `MVP ABS, motor,
    /// value`; `ROR motor, velocity`; `SIO port, bank, value`).
    pub operand: usize,
    /// The status the module answers.
    pub status: Status,
    /// A plain sentence (no trailing period), e.g. "AP 4 (Maximum positioning speed) takes 0..2047 on
    /// the PDx-113: 51200 is outside".
    pub message: String,
}

fn finding(operand: usize, status: Status, message: String) -> Option<Finding> {
    Some(Finding { operand, status, message })
}

/// Why `model` refuses `instruction` by its tables alone, or `None` if nothing in them does.
pub fn why_refused(instruction: Instruction, model: &ModelSpec) -> Option<Finding> {
    let command = Command::decode(instruction).ok()?;
    let m = model.name;
    let motor = |operand: usize, motor: u8| -> Option<Finding> {
        (motor >= model.motors).then(|| Finding {
            operand,
            status: Status::InvalidValue,
            message: format!("motor {motor}: the {m} has {}", plural(model.motors)),
        })
    };
    use Command as C;
    match command {
        C::Ror { motor: n, velocity } | C::Rol { motor: n, velocity } => {
            if let Some(f) = motor(0, n) {
                return Some(f);
            }
            let v =
                if matches!(command, C::Rol { .. }) { velocity.checked_neg().unwrap_or(i32::MAX) } else { velocity };
            let d = model.axis.role(Role::TargetSpeed).map(|i| &model.axis.params[i])?;
            (!d.range.contains(v)).then(|| Finding {
                operand: 1,
                status: Status::InvalidValue,
                message: format!(
                    "a velocity on the {m} is {} (AP {}, {}): {velocity} is outside",
                    d.range, d.number, d.name
                ),
            })
        }
        C::Mst { motor: n } => motor(0, n),
        C::Rfs { motor: n, .. } => motor(1, n),
        // MVP COORD with a motor mask (bit 7 or 6; the TMCM-3110/6110 manuals' MVP, tmcl-core's
        // `module/coordinated.rs`): the motors of the mask, on a model with several.
        C::Mvp { motor: n, target: MoveTarget::Coord(c) } if n & 0xC0 != 0 && model.motors > 1 => {
            let mask = n & 0x3F;
            let all = ((1u16 << model.motors) - 1) as u8;
            if n & 0xC0 == 0xC0 {
                finding(
                    1,
                    Status::InvalidValue,
                    format!("a motor mask has bit 7 ($80, together) or bit 6 ($40, interpolated), not both: {n:#04X}"),
                )
            } else if mask == 0 || mask & !all != 0 {
                let motors = plural(model.motors);
                finding(
                    1,
                    Status::InvalidValue,
                    format!("motor mask {mask:#04X}: the {m} has {motors} (mask bits {all:#04X})"),
                )
            } else if c < 0 || c > i32::from(model.coordinates) {
                finding(
                    2,
                    Status::InvalidValue,
                    format!("the {m} has coordinates 0..{}: {c} is not one", model.coordinates),
                )
            } else {
                None
            }
        }
        C::Mvp { motor: n, target } => motor(1, n).or_else(|| match target {
            MoveTarget::Abs(p) => {
                let d = model.axis.role(Role::TargetPosition).map(|i| &model.axis.params[i])?;
                (!d.range.contains(p)).then(|| Finding {
                    operand: 2,
                    status: Status::InvalidValue,
                    message: format!("a position on the {m} is {} (AP {}): {p} is outside", d.range, d.number),
                })
            }
            MoveTarget::Coord(c) if c < 0 || c > i32::from(model.coordinates) => finding(
                2,
                Status::InvalidValue,
                format!("the {m} has coordinates 0..{}: {c} is not one", model.coordinates),
            ),
            _ => None,
        }),
        C::Sap { param, motor: n, value } => {
            motor(1, n).or_else(|| axis(model, param, Some(value), |d| d.access.write))
        }
        C::Gap { param, motor: n } => motor(1, n).or_else(|| axis(model, param, None, |d| d.access.read)),
        C::Stap { param, motor: n } | C::Rsap { param, motor: n } => {
            motor(1, n).or_else(|| axis(model, param, None, |d| d.access.store))
        }
        C::Aap { param, motor: n } => motor(1, n).or_else(|| axis(model, param, None, |d| d.access.write)),
        C::Sgp { param, bank, value } => global(model, param, bank, Some(value), |d| d.access.write),
        C::Ggp { param, bank } => global(model, param, bank, None, |d| d.access.read),
        C::Agp { param, bank } => global(model, param, bank, None, |d| d.access.write),
        C::Stgp { param, bank } | C::Rsgp { param, bank } => global(model, param, bank, None, |d| d.access.auto),
        C::Sio { port, bank, value } => {
            if !model.writes_bank(bank) {
                return finding(1, Status::InvalidValue, format!("SIO sets outputs, bank 2 (bank {bank} given)"));
            }
            match model.output_port(bank, port).map(|p| p.kind) {
                None if bank != 2 => {
                    finding(0, Status::WrongType, format!("the {m} has no port {port} SIO sets in bank {bank}"))
                }
                None => {
                    finding(0, Status::WrongType, format!("the {m} has no output {port} (bank 2: {})", ports(model, 2)))
                }
                Some(PortKind::Output(_)) if !(0..=1).contains(&value) => {
                    finding(2, Status::InvalidValue, format!("an output is set to 0 or 1: {value} is neither"))
                }
                Some(PortKind::AllOutputs) if !(-1..=255).contains(&value) => finding(
                    2,
                    Status::InvalidValue,
                    format!("SIO 255 takes a bit vector 0..255 (or -1, the accumulator): {value} is outside"),
                ),
                Some(PortKind::PullUps) if !(0..=3).contains(&value) => {
                    finding(2, Status::InvalidValue, format!("the pull-ups take 0..3: {value} is outside"))
                }
                _ => None,
            }
        }
        C::Gio { port, bank } => match model.port(bank, port) {
            Some(_) => None,
            None if !(0..=2).contains(&bank) => {
                finding(1, Status::InvalidValue, format!("GIO reads banks 0, 1 and 2 (bank {bank} given)"))
            }
            None => finding(
                0,
                Status::WrongType,
                format!("the {m} has no port {port} in bank {bank} ({})", ports(model, bank)),
            ),
        },
        _ => None,
    }
}

fn plural(motors: u8) -> String {
    if motors == 1 {
        "one motor, 0".into()
    } else {
        format!("{motors} motors, 0..{}", motors.saturating_sub(1))
    }
}

/// The ports of a bank, as `0..7, 255`.
fn ports(model: &ModelSpec, bank: u8) -> String {
    let list: Vec<String> = model.ports.iter().filter(|p| p.bank == bank).map(|p| p.port.to_string()).collect();
    if list.is_empty() {
        "none".into()
    } else {
        list.join(", ")
    }
}

fn param_in(
    model: &ModelSpec,
    table: &Table,
    what: &str,
    param: u8,
    value: Option<i32>,
    allowed: impl Fn(&ParamDesc) -> bool,
) -> Option<Finding> {
    let Ok((_, d)) = table.find(param) else {
        return finding(0, Status::WrongType, format!("the {} has no {what} {param}", model.name));
    };
    if !allowed(d) {
        let access = d.access;
        return finding(
            0,
            Status::WrongType,
            format!("{what} {param} ({}) does not take this command (access {access})", d.name),
        );
    }
    let v = value?;
    (!d.range.contains(v)).then(|| Finding {
        operand: 2,
        status: Status::InvalidValue,
        message: format!("{what} {param} ({}) takes {} on the {}: {v} is outside", d.name, d.range, model.name),
    })
}

fn axis(model: &ModelSpec, param: u8, value: Option<i32>, allowed: impl Fn(&ParamDesc) -> bool) -> Option<Finding> {
    param_in(model, &model.axis, "AP", param, value, allowed)
}

fn global(
    model: &ModelSpec,
    param: u8,
    bank: u8,
    value: Option<i32>,
    allowed: impl Fn(&ParamDesc) -> bool,
) -> Option<Finding> {
    if !model.banks.has(bank) {
        return finding(1, Status::InvalidValue, format!("the {} has no bank {bank}", model.name));
    }
    match bank {
        0 => param_in(model, &model.global, "GP", param, value, allowed),
        3 => param_in(model, &model.interrupt, "bank 3 parameter", param, value, allowed),
        // The PDx-113's bank 1 (its manual §5.7.9): no source names a parameter in it.
        1 => finding(0, Status::WrongType, format!("the {} has no parameter {param} in bank 1", model.name)),
        2 if u16::from(param) >= model.user_variables => finding(
            0,
            Status::WrongType,
            format!(
                "the {} has user variables 0..{}: {param} is not one",
                model.name,
                model.user_variables.saturating_sub(1)
            ),
        ),
        _ => None,
    }
}

/// One warning per instruction of `program` that `model`'s tables refuse, at its source line, with the
/// operand underlined where the line spells it. `line_text` gives a line's text (as for
/// [`crate::check_model`]). Instructions whose command the model lacks are [`crate::check_model`]'s.
pub fn check_operands(
    program: &Program,
    model: &ModelSpec,
    line_text: &mut dyn FnMut(&str, u32) -> Option<String>,
) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    for (address, &i) in program.instructions.iter().enumerate() {
        if !model.commands.contains(i.opcode) {
            continue;
        }
        let Some(f) = why_refused(i, model) else { continue };
        let message = format!("{} (status {} on the {})", f.message, u8::from(f.status), model.name);
        let Some(place) = program.source_lines.get(address) else {
            out.push(Diagnostic::file("program", format!("address {address}: {message}")));
            continue;
        };
        let text = line_text(&place.file, place.line).unwrap_or_default();
        let (start, end) = operand_span(&text, f.operand).unwrap_or((0, text.len()));
        out.push(Diagnostic::at(&place.file, place.line, &text, start, end, message));
    }
    out
}

/// The byte range of operand `n` (from 0) in a source line `[Label:] MNEMONIC op, op, op // comment`.
pub fn operand_span(line: &str, n: usize) -> Option<(usize, usize)> {
    let code = line.find("//").map_or(line, |c| &line[..c]);
    // Skip a label: a first word ending in ':' (also `Loop :`).
    let mut rest_at = 0;
    if let Some(colon) = code.find(':') {
        if code[..colon].trim().chars().all(|c| c.is_alphanumeric() || c == '_') {
            rest_at = colon + 1;
        }
    }
    let rest = &code[rest_at..];
    let lead = rest.len() - rest.trim_start().len();
    let after_mnemonic = rest[lead..].find(char::is_whitespace)? + lead + rest_at;
    let mut start = after_mnemonic;
    for (k, part) in code[after_mnemonic..].split(',').enumerate() {
        if k == n {
            let trimmed = part.trim();
            let offset = start + part.find(trimmed).unwrap_or(0);
            return Some((offset, offset + trimmed.len().max(1)));
        }
        start += part.len() + 1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::includes::BuiltinResolver;
    use tmcl_model::{pd28_1021, pd_113, tmcm_1310};
    use tmcl_wire::Opcode;

    fn check(model: &'static ModelSpec, text: &str) -> Vec<Diagnostic> {
        let mut resolver = BuiltinResolver { model };
        let program = crate::assemble_str("p.tmc", text, &mut resolver).unwrap();
        check_operands(&program, model, &mut |_, line| text.lines().nth(line as usize - 1).map(String::from))
    }

    #[test]
    fn the_first_steps_program_on_the_pdx_113_warns_about_51200() {
        // PD28-1021 manual §2.4's program: fine on the PD28-1021, out of range on the PDx-113 (0..2047).
        let text = "ROL 0, 51200\nWAIT TICKS, 0, 500\nMST 0\nROR 0, 5120\nWAIT TICKS, 0, 500\nMST 0\n\
                    SAP 4, 0, 51200\nSAP 5, 0, 51200\nLoop: MVP ABS, 0, 512000\nWAIT POS, 0, 0\nJA Loop\n";
        assert!(check(&pd28_1021::SPEC, text).is_empty());
        let d = check(&pd_113::SPEC, text);
        let lines: Vec<u32> = d.iter().map(|d| d.line).collect();
        assert_eq!(lines, [1, 4, 7, 8], "{d:#?}");
        assert_eq!((d[2].column, d[2].width), (11, 5), "51200 underlined");
        assert!(
            d[2].message.starts_with("AP 4 (Maximum positioning speed) takes 0..2047 on the PDx-113")
                && d[2].message.contains(": 51200 is outside"),
            "{}",
            d[2].message
        );
        assert!(d[2].message.contains("(status 4 on the PDx-113"));
        assert!(d[0].message.contains("velocity"), "{}", d[0].message);
    }

    #[test]
    fn what_the_tables_refuse() {
        let spec = &pd28_1021::SPEC;
        let f = |op, t, m, v| why_refused(Instruction::new(op, t, m, v), spec).map(|f| (f.operand, f.status));
        assert_eq!(f(Opcode::Gap, 99, 0, 0), Some((0, Status::WrongType)));
        assert_eq!(f(Opcode::Mvp, 0, 5, 100), Some((1, Status::InvalidValue)));
        assert_eq!(f(Opcode::Sio, 0, 2, 1), None);
        assert_eq!(f(Opcode::Sio, 7, 2, 1), Some((0, Status::WrongType)), "no OUT7 on the PD28-1021");
        assert_eq!(f(Opcode::Sap, 4, 0, 0), Some((2, Status::InvalidValue)), "AP 4 is 1..");
        assert_eq!(f(Opcode::Sap, 4, 0, 1000), None);
        assert_eq!(f(Opcode::Sgp, 0, 1, 0), Some((1, Status::InvalidValue)), "no bank 1");
        assert_eq!(f(Opcode::Ggp, 0, 2, 0), None);
        assert!(why_refused(Instruction::new(Opcode::Sap, 4, 0, 0), &tmcm_1310::SPEC).is_some());
        let pdx =
            |op, t, m, v| why_refused(Instruction::new(op, t, m, v), &pd_113::SPEC).map(|f| (f.operand, f.status));
        assert_eq!(pdx(Opcode::Ggp, 0, 1, 0), Some((0, Status::WrongType)), "bank 1 names nothing");
        assert_eq!(pdx(Opcode::Mvp, 0, 0, 1 << 23), Some((2, Status::InvalidValue)), "24-bit positions");
        assert_eq!(pdx(Opcode::Ror, 0, 0, 2047), None);
    }

    #[test]
    fn operands_are_found_in_the_line() {
        assert_eq!(operand_span("SAP 4, 0, 51200", 2), Some((10, 15)));
        assert_eq!(operand_span("Loop: MVP ABS, 0, 512000 // far", 2), Some((18, 24)));
        assert_eq!(operand_span("  SAP APMaxPositioningSpeed, Motor0, 3", 0), Some((6, 27)));
        assert_eq!(operand_span("STOP", 0), None);
    }

    /// MVP COORD with a motor mask on a multi-axis model: the motors of the mask, not a motor number; the
    /// mask's mistakes are named. A one-motor model knows no mask (a motor it lacks).
    #[test]
    fn a_motor_mask_of_mvp_coord_is_checked_as_a_mask() {
        let text = "MVP COORD, $47, 1\nMVP COORD, $87, 20\nMVP COORD, $C7, 1\nMVP COORD, $48, 1\nMVP COORD, $40, 1\nMVP COORD, $47, 21\n";
        let d = check(&tmcl_model::tmcm_3110::SPEC, text);
        assert_eq!(d.iter().map(|d| d.line).collect::<Vec<_>>(), [3, 4, 5, 6], "{d:#?}");
        assert!(d[0].message.contains("not both"), "{}", d[0].message);
        assert!(d[1].message.starts_with("motor mask 0x08: the TMCM-3110 has 3 motors"), "{}", d[1].message);
        assert!(d[3].message.contains("coordinates 0..20"), "{}", d[3].message);
        let one = check(&pd28_1021::SPEC, "MVP COORD, $41, 1\n");
        assert!(one[0].message.starts_with("motor 65: the PD28-1021 has one motor"), "{}", one[0].message);
    }
}

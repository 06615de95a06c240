//! The page's requests (JSON over the WebSocket) and what the link thread does for each.
//!
//! A request is `{"id": N, "op": NAME, ...}`; the answer is `{"id": N, "ok": {...}}` or
//! `{"id": N, "error": TEXT, ...}` with, for a refusal of the module, its `status` and `status_text` and,
//! where the model's tables say why, an `explanation`. A message that is not a known request is answered
//! with an error, never a panic.

use crate::debug::{self, SOURCE_NAME};
use crate::info;
use crate::link::{DebugEvent, Hello, HelloEvent, Link, Poll, ProgressEvent, ValueEvent, Watch};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::time::Duration;
use tmcl_asm::{assemble_str, BuiltinResolver, Diagnostic};
use tmcl_debug::remote::Action;
use tmcl_host::paramset;
use tmcl_host::HostError;
use tmcl_wire::{format_instruction, parse_instruction, Command, Instruction, MoveTarget, Opcode, RfsAction};

/// The longest console line and program the page may send: more is refused, not parsed.
pub(crate) const MAX_LINE: usize = 1024;
pub(crate) const MAX_SOURCE: usize = 1 << 20;

/// A parameter: `ap` with its motor, or `gp` with its bank.
#[derive(Debug, Clone, Copy, Deserialize)]
pub(crate) struct Param {
    kind: ParamKind,
    number: u8,
    #[serde(default)]
    index: u8,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum ParamKind {
    Ap,
    Gp,
}

/// What the motion panel asks for (PD28-1021 TMCL manual §3.7.1–3.7.4, §3.7.13).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Motion {
    /// ROR: rotate right at the value's speed.
    RotateRight,
    /// ROL: rotate left.
    RotateLeft,
    /// MST.
    Stop,
    /// MVP ABS.
    MoveAbsolute,
    /// MVP REL.
    MoveRelative,
    /// RFS START.
    ReferenceStart,
    /// RFS STOP.
    ReferenceStop,
}

/// One request of the page.
#[derive(Debug, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub(crate) enum Op {
    /// The module, the model's tables, the link.
    Hello,
    /// What this page shows (what to poll for it).
    Watch {
        #[serde(default)]
        views: Vec<String>,
        #[serde(default)]
        motor: u8,
        #[serde(default)]
        vars: (u8, u8),
        /// More values to plot, by key: `ap.MOTOR.NUMBER` or `gp.BANK.NUMBER` (the charts of any parameter).
        #[serde(default)]
        extra: Vec<String>,
    },
    /// GAP/GGP.
    Get { param: Param },
    /// SAP/SGP.
    Set { param: Param, value: i64 },
    /// STAP/STGP.
    Store { param: Param },
    /// RSAP/RSGP.
    Restore { param: Param },
    /// The motion panel.
    Motion {
        action: Motion,
        #[serde(default)]
        motor: u8,
        #[serde(default)]
        value: i64,
    },
    /// SIO: an output (bank 2).
    Output { port: u8, bank: u8, value: i64 },
    /// A console line: one instruction in the assembler's syntax.
    Console { line: String },
    /// Assembles the editor's text.
    Assemble { source: String },
    /// Assembles and downloads it.
    Download { source: String },
    /// Start, stop, step, continue, reset.
    Program { action: Action },
    /// The breakpoints, as source lines.
    Breakpoints { lines: Vec<u32> },
    /// Every readable parameter as a parameter set (TOML), as `tmcl params --save`.
    SaveParams,
    /// Writes the settings of a parameter set, as `tmcl params --load [--store] [--any-model]`.
    LoadParams {
        text: String,
        #[serde(default)]
        store: bool,
        #[serde(default)]
        any_model: bool,
    },
    /// Stores every parameter that can be stored in the EEPROM (STAP/STGP of each).
    StoreAll,
    /// Asks every address in first..=last for its version.
    Scan { first: u8, last: u8 },
    /// Talks to another address.
    Select { address: u8 },
}

impl Op {
    /// The request's name, as the page sends it (`op`), for the log.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            Op::Hello => "hello",
            Op::Watch { .. } => "watch",
            Op::Get { .. } => "get",
            Op::Set { .. } => "set",
            Op::Store { .. } => "store",
            Op::Restore { .. } => "restore",
            Op::Motion { .. } => "motion",
            Op::Output { .. } => "output",
            Op::Console { .. } => "console",
            Op::Assemble { .. } => "assemble",
            Op::Download { .. } => "download",
            Op::Program { .. } => "program",
            Op::Breakpoints { .. } => "breakpoints",
            Op::SaveParams => "save_params",
            Op::LoadParams { .. } => "load_params",
            Op::StoreAll => "store_all",
            Op::Scan { .. } => "scan",
            Op::Select { .. } => "select",
        }
    }
}

/// The most parameters one page may chart besides the standard plots.
const MAX_CHARTED: usize = 32;

/// The poll of a value key as the events name them: `ap.MOTOR.NUMBER` or `gp.BANK.NUMBER`.
fn poll_of_key(key: &str) -> Option<Poll> {
    let mut parts = key.split('.');
    let (kind, index, number) = (parts.next()?, parts.next()?.parse().ok()?, parts.next()?.parse().ok()?);
    if parts.next().is_some() {
        return None;
    }
    match kind {
        "ap" => Some(Poll::Axis { param: number, motor: index }),
        "gp" => Some(Poll::Global { param: number, bank: index }),
        _ => None,
    }
}

/// A failed request, as the page reads it: the words, and for a refusal of the module its status, what
/// the model's tables say about it, and (console) the instruction sent or the place of a syntax error.
/// (Boxed: it is the error of every request's result.)
#[derive(Debug)]
pub(crate) struct Failure(Box<FailureBody>);

/// What a [`Failure`] says.
#[derive(Debug, Default, Serialize)]
pub(crate) struct FailureBody {
    error: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    status: Option<u8>,
    #[serde(skip_serializing_if = "Option::is_none")]
    status_text: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    explanation: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sent: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    column: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    width: Option<usize>,
}

impl std::ops::Deref for Failure {
    type Target = FailureBody;
    fn deref(&self) -> &FailureBody {
        &self.0
    }
}

impl std::ops::DerefMut for Failure {
    fn deref_mut(&mut self) -> &mut FailureBody {
        &mut self.0
    }
}

impl From<FailureBody> for Failure {
    fn from(body: FailureBody) -> Failure {
        Failure(Box::new(body))
    }
}

impl From<HostError> for Failure {
    fn from(e: HostError) -> Failure {
        let mut f = FailureBody { error: e.to_string(), ..FailureBody::default() };
        if let HostError::Status { status, .. } = e {
            f.status = Some(u8::from(status));
            f.status_text = Some(status.description());
        }
        f.into()
    }
}

impl From<String> for Failure {
    fn from(error: String) -> Failure {
        FailureBody::from_error(error).into()
    }
}

impl FailureBody {
    /// A failure said in words only.
    pub(crate) fn from_error(error: String) -> FailureBody {
        FailureBody { error, ..FailureBody::default() }
    }
}

impl Failure {
    /// The failure in words, for the log.
    pub(crate) fn message(&self) -> &str {
        &self.error
    }

    /// The failure as the body of an answer.
    pub(crate) fn body(&self) -> &FailureBody {
        &self.0
    }
}

/// What a request answers when it succeeds: the `ok` of `{"id": N, "ok": ...}`. Each request has its own
/// shape; the page reads them by these names.
#[derive(Debug, Serialize)]
#[serde(untagged)]
pub(crate) enum Answer {
    /// `hello`, `select`.
    Hello(Box<Hello>),
    /// `watch`: `{}`.
    Watching(Empty),
    /// `get`, `set`, `store`, `restore`, `motion`, `output`.
    Replied(Replied),
    /// `console`.
    Console(Console),
    /// `assemble`.
    Assembled(Assembled),
    /// `download`.
    Downloaded(Downloaded),
    /// `program`.
    Debug(Box<DebugEvent>),
    /// `breakpoints`.
    Breakpoints(Breakpoints),
    /// `save_params`.
    Saved(Saved),
    /// `load_params`, `store_all`.
    Loaded(Loaded),
    /// `scan`.
    Scanned(Scanned),
}

/// An answer without content (`{}`).
#[derive(Debug, Serialize)]
pub(crate) struct Empty {}

/// One diagnostic of the assembler (or of the model's tables) at its place in the editor's text.
#[derive(Debug, Serialize)]
pub(crate) struct DiagnosticInfo {
    pub file: String,
    /// From 1; 0 for the whole program.
    pub line: u32,
    pub column: u32,
    pub width: u32,
    pub message: String,
}

impl From<&Diagnostic> for DiagnosticInfo {
    fn from(d: &Diagnostic) -> DiagnosticInfo {
        DiagnosticInfo {
            file: d.file.clone(),
            line: d.line,
            column: d.column,
            width: d.width,
            message: d.message.clone(),
        }
    }
}

/// The answer to `assemble`: the errors, the model's warnings, and the count of instructions (`null` when
/// the program has errors).
#[derive(Debug, Serialize)]
pub(crate) struct Assembled {
    diagnostics: Vec<DiagnosticInfo>,
    warnings: Vec<DiagnosticInfo>,
    instructions: Option<usize>,
}

/// The answer to `download`: only `diagnostics` when the program has errors (nothing was downloaded);
/// else the instructions stored, the editor line of each address, and the model's warnings.
#[derive(Debug, Serialize)]
pub(crate) struct Downloaded {
    #[serde(skip_serializing_if = "Option::is_none")]
    stored: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lines: Option<Vec<Option<u32>>>,
    diagnostics: Vec<DiagnosticInfo>,
    #[serde(skip_serializing_if = "Option::is_none")]
    warnings: Option<Vec<DiagnosticInfo>>,
}

/// The answer to `breakpoints`: the lines where they took effect (the first instruction on or after each).
#[derive(Debug, Serialize)]
pub(crate) struct Breakpoints {
    lines: Vec<u32>,
}

fn value32(value: i64) -> Result<i32, Failure> {
    // Values are 32 bits; 2^31..2^32 are the upper half of an unsigned value (as the assembler takes them).
    match value {
        v if (i64::from(i32::MIN)..=i64::from(u32::MAX)).contains(&v) => Ok(v as u32 as i32),
        v => Err(format!("{v} does not fit in 32 bits").into()),
    }
}

/// Runs one request on the link thread. `page` identifies the connection (for `watch`).
pub(crate) fn handle(link: &mut Link, page: u64, op: Op) -> Result<Answer, Failure> {
    match op {
        Op::Hello => Ok(Answer::Hello(Box::new(link.hello()))),
        Op::Watch { views, motor, vars, extra } => {
            let vars = (vars.0, vars.1.min(64));
            let mut polls = Vec::new();
            for key in extra.iter().take(MAX_CHARTED) {
                polls.push(
                    poll_of_key(key).ok_or_else(|| format!("{key:?} names no parameter (ap.MOTOR.N or gp.BANK.N)"))?,
                );
            }
            link.watch(page, Some(Watch { views: views.into_iter().take(16).collect(), motor, vars, extra: polls }));
            Ok(Answer::Watching(Empty {}))
        }
        Op::Get { param } => param_request(link, param, ParamOp::Get),
        Op::Set { param, value } => param_request(link, param, ParamOp::Set(value32(value)?)),
        Op::Store { param } => param_request(link, param, ParamOp::Store),
        Op::Restore { param } => param_request(link, param, ParamOp::Restore),
        Op::Motion { action, motor, value } => {
            let answer = motion(link, action, motor, value32(value)?);
            link.hurry_live(Some(motor));
            answer
        }
        Op::Output { port, bank, value } => {
            let reply = link.request(Command::Sio { port, bank, value: value32(value)? }.encode());
            link.hurry(|p| matches!(p, Poll::Input { .. }));
            let reply = reply?;
            Ok(Answer::Replied(Replied { status: u8::from(reply.status), value: reply.value, t: None }))
        }
        Op::Console { line } => {
            // A console line may change anything: what the pages show of the motors, I/O and program.
            let answer = console(link, &line);
            link.hurry_live(None);
            answer
        }
        Op::Assemble { source } => {
            let (program, diagnostics) = assemble(link, &source)?;
            let warnings = warnings(link, program.as_ref(), &source);
            let instructions = program.map(|p| p.instructions.len());
            Ok(Answer::Assembled(Assembled { diagnostics, warnings, instructions }))
        }
        Op::Download { source } => download(link, &source),
        Op::Program { action } => Ok(Answer::Debug(Box::new(debug::act(link, action)?))),
        Op::Breakpoints { lines } => {
            let lines: Vec<u32> = lines.into_iter().take(4096).collect();
            let effective = link.debug.set_breakpoint_lines(&lines);
            debug::breakpoints_changed(link)?;
            Ok(Answer::Breakpoints(Breakpoints { lines: effective }))
        }
        Op::SaveParams => save_params(link),
        Op::LoadParams { text, store, any_model } => load_params(link, &text, store, any_model),
        Op::StoreAll => store_all(link),
        Op::Scan { first, last } => scan(link, first, last),
        Op::Select { address } => {
            link.select(address);
            let hello = link.hello();
            link.emit_typed(&HelloEvent { e: "hello", hello: &hello });
            Ok(Answer::Hello(Box::new(hello)))
        }
    }
}

enum ParamOp {
    Get,
    Set(i32),
    Store,
    Restore,
}

fn param_request(link: &mut Link, p: Param, op: ParamOp) -> Result<Answer, Failure> {
    let axis = p.kind == ParamKind::Ap;
    let (param, index) = (p.number, p.index);
    let (command, value) = match (&op, axis) {
        (ParamOp::Get, true) => (Command::Gap { param, motor: index }, None),
        (ParamOp::Get, false) => (Command::Ggp { param, bank: index }, None),
        (ParamOp::Set(v), true) => (Command::Sap { param, motor: index, value: *v }, Some(*v)),
        (ParamOp::Set(v), false) => (Command::Sgp { param, bank: index, value: *v }, Some(*v)),
        (ParamOp::Store, true) => (Command::Stap { param, motor: index }, None),
        (ParamOp::Store, false) => (Command::Stgp { param, bank: index }, None),
        (ParamOp::Restore, true) => (Command::Rsap { param, motor: index }, None),
        (ParamOp::Restore, false) => (Command::Rsgp { param, bank: index }, None),
    };
    match link.request(command.encode()) {
        Ok(reply) => {
            // After a write, store or restore, read the value back: what the module keeps is what counts.
            let value = match op {
                ParamOp::Get => reply.value,
                _ => {
                    let read =
                        if axis { Command::Gap { param, motor: index } } else { Command::Ggp { param, bank: index } };
                    link.request(read.encode()).map(|r| r.value).unwrap_or(reply.value)
                }
            };
            let key = if axis { format!("ap.{index}.{param}") } else { format!("gp.{index}.{param}") };
            link.emit_typed(&ValueEvent::value(key, value, crate::link::now_ms()));
            Ok(Answer::Replied(Replied { status: u8::from(reply.status), value, t: None }))
        }
        Err(e) => {
            let mut failure = Failure::from(e);
            if let Some(status) = failure.status {
                let status = tmcl_wire::Status::from(status);
                // A store of a parameter without E is refused as an invalid value by some firmware.
                let store = matches!(op, ParamOp::Store | ParamOp::Restore);
                let value = if store { None } else { value };
                if let Some(why) = info::explain(link.model, axis, index, param, status, value, store) {
                    failure.explanation = Some(why);
                }
            }
            Err(failure)
        }
    }
}

fn motion(link: &mut Link, action: Motion, motor: u8, value: i32) -> Result<Answer, Failure> {
    let command = match action {
        Motion::RotateRight => Command::Ror { motor, velocity: value },
        Motion::RotateLeft => Command::Rol { motor, velocity: value },
        Motion::Stop => Command::Mst { motor },
        Motion::MoveAbsolute => Command::Mvp { motor, target: MoveTarget::Abs(value) },
        Motion::MoveRelative => Command::Mvp { motor, target: MoveTarget::Rel(value) },
        Motion::ReferenceStart => Command::Rfs { action: RfsAction::Start, motor },
        Motion::ReferenceStop => Command::Rfs { action: RfsAction::Stop, motor },
    };
    let reply = link.request(command.encode()).map_err(|e| {
        let refused = e.is_status_error();
        let mut f = Failure::from(e);
        let velocity = matches!(action, Motion::RotateRight | Motion::RotateLeft);
        let moves = matches!(action, Motion::MoveAbsolute | Motion::MoveRelative);
        if refused && (velocity || moves) {
            if let Some(why) = info::explain_motion(link.model, velocity, value) {
                f.explanation = Some(why);
            }
        }
        f
    })?;
    let t = Some(crate::link::now_ms());
    Ok(Answer::Replied(Replied { status: u8::from(reply.status), value: reply.value, t }))
}

/// The symbols the console knows: the model's parameter names (`APMaxPositioningSpeed`, ...) and motors, as
/// the built-in include file `TMCLParam.tmc` defines them for the assembler.
fn console_symbols(link: &Link) -> HashMap<String, i32> {
    let model = link.model.unwrap_or(&tmcl_model::pd28_1021::SPEC);
    let mut resolver = BuiltinResolver { model };
    let mut symbols: HashMap<String, i32> = assemble_str("console", "#include TMCLParam.tmc\n", &mut resolver)
        .map(|p| p.constants.into_iter().collect())
        .unwrap_or_default();
    // Also the bare identifiers (`MaxPositioningSpeed`), where no other table uses the same name.
    for table in [&model.axis, &model.global] {
        for d in table.params {
            symbols.entry(d.ident.to_string()).or_insert(i32::from(d.number));
        }
    }
    symbols
}

/// A module's reply to a request of the page: its status and value (and when it came, for the motion
/// panel's plot).
#[derive(Debug, Serialize)]
pub(crate) struct Replied {
    status: u8,
    value: i32,
    #[serde(skip_serializing_if = "Option::is_none")]
    t: Option<f64>,
}

/// The answer to a console line: the instruction sent (as text and bytes) and the reply in words, with
/// what the reply carried.
#[derive(Debug, Default, Serialize)]
pub(crate) struct Console {
    sent: String,
    bytes: String,
    reply: String,
    /// The version string (136 type 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    text: Option<String>,
    /// For a command that may get no reply: whether one came.
    #[serde(skip_serializing_if = "Option::is_none")]
    replied: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    status: Option<u8>,
    #[serde(skip_serializing_if = "Option::is_none")]
    status_text: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    value: Option<i32>,
    /// The parameter's name, `null` when the tables do not know it (parameter commands only).
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<Option<&'static str>>,
}

/// One console line: parsed as the assembler parses an instruction, sent, the reply decoded.
fn console(link: &mut Link, line: &str) -> Result<Answer, Failure> {
    if line.len() > MAX_LINE {
        return Err(format!("the line is longer than {MAX_LINE} characters").into());
    }
    let text = line.split("//").next().unwrap_or("").trim();
    let symbols = console_symbols(link);
    let instruction = parse_instruction(text, &mut |name| symbols.get(name).copied()).map_err(|e| {
        Failure::from(FailureBody {
            error: e.with_text(text).to_string(),
            column: Some(e.span.start + 1),
            width: Some((e.span.end - e.span.start).max(1)),
            ..FailureBody::default()
        })
    })?;
    let mut sent = String::new();
    let _ = format_instruction(&instruction, &mut sent, None);
    let bytes = tmcl_wire::Request { address: link.address(), instruction }.to_bytes();
    let base = Console { sent: sent.clone(), bytes: tmcl_wire::Hex(&bytes).to_string(), ..Console::default() };
    match instruction.opcode {
        Opcode::GetVersion if instruction.kind == 0 => {
            let text = link.version_string()?;
            Ok(Answer::Console(Console { reply: format!("version {text}"), text: Some(text), ..base }))
        }
        Opcode::ReadMemory => {
            let address = u16::try_from(instruction.value).map_err(|_| format!("no address {}", instruction.value))?;
            let stored = link.read_program_memory(address)?;
            let mut text = String::new();
            let _ = format_instruction(&stored, &mut text, None);
            Ok(Answer::Console(Console { reply: format!("address {address}: {text}"), ..base }))
        }
        // 137 (factory defaults), 242 (boot loader) and 255 (reset) are documented to get no reply
        // (§3.7.38), and while GP 255 keeps replies off only GAP, GGP and GIO reply (§5.1 Table 17). A
        // reply that does come is shown as what it is (a refusal as a refusal); "no reply" only when none came.
        op if no_reply_expected(link, &instruction) => {
            let opcode = u8::from(op);
            let reply = link.request_maybe_reply(instruction).map_err(|e| {
                let mut f = Failure::from(e);
                f.sent = Some(sent.clone());
                f
            });
            let switches = replies_switch(&instruction);
            let reply = match reply {
                Ok(reply) => reply,
                Err(f) => {
                    // The module answered, and refused: replies stay as they were.
                    return Err(f);
                }
            };
            if let Some(off) = switches {
                link.replies_off = off;
            }
            let text = match (reply, switches) {
                (Some(r), Some(true)) => format!(
                    "{} {}, value {}: replies are now off (GP 255); SGP 255, 0, 0 turns them back on",
                    u8::from(r.status),
                    r.status.description(),
                    r.value
                ),
                (None, Some(true)) => {
                    "no reply: replies are now off (GP 255); SGP 255, 0, 0 turns them back on".to_string()
                }
                (Some(r), Some(false)) => format!(
                    "{} {}, value {}: replies are on again",
                    u8::from(r.status),
                    r.status.description(),
                    r.value
                ),
                (Some(r), _) => format!("{} {}, value {}", u8::from(r.status), r.status.description(), r.value),
                (None, Some(false)) => "no reply; replies are on again".to_string(),
                (None, None) if link.replies_off => "no reply (replies are off, GP 255)".to_string(),
                (None, None) => match opcode {
                    137 => "no reply, as documented for 137: the factory defaults are being restored".into(),
                    242 => "no reply, as documented for 242: the module is in its boot loader".into(),
                    _ => "no reply, as documented for 255: the module is resetting".into(),
                },
            };
            let answer = Answer::Console(Console {
                reply: text,
                replied: Some(reply.is_some()),
                status: reply.map(|r| u8::from(r.status)),
                value: reply.map(|r| r.value),
                ..base
            });
            if switches.is_some() || link.replies_off {
                link.emit_line();
            }
            Ok(answer)
        }
        _ => {
            let reply = link.request(instruction).map_err(|e| {
                let mut f = Failure::from(e);
                if let (Some(status), Some((axis, index))) = (f.status, param_place(&instruction)) {
                    let value = matches!(instruction.opcode, Opcode::Sap | Opcode::Sgp).then_some(instruction.value);
                    let status = tmcl_wire::Status::from(status);
                    let store = matches!(instruction.opcode, Opcode::Stap | Opcode::Stgp | Opcode::Rsap | Opcode::Rsgp);
                    let (kind, model) = (instruction.kind, link.model);
                    if let Some(why) = info::explain(model, axis, index, kind, status, value, store) {
                        f.explanation = Some(why);
                    }
                }
                f.sent = Some(sent.clone());
                f
            })?;
            let name = param_place(&instruction)
                .and_then(|(axis, index)| info::find_param(link.model?, axis, index, instruction.kind))
                .map(|d| d.ident);
            let status = reply.status;
            let text = format!("{} {}, value {}", u8::from(status), status.description(), reply.value);
            Ok(Answer::Console(Console {
                status: Some(u8::from(status)),
                status_text: Some(status.description()),
                value: Some(reply.value),
                reply: text,
                name: Some(name),
                ..base
            }))
        }
    }
}

/// Whether `instruction` is one that may get no reply: 137, 242 and 255 (§3.7.38), SGP 255 (which may
/// switch replies off before replying), and, while replies are off, any but GAP, GGP and GIO (§5.1
/// Table 17).
fn no_reply_expected(link: &Link, instruction: &Instruction) -> bool {
    let op = instruction.opcode;
    let documented = matches!(op, Opcode::FactoryDefault | Opcode::Boot | Opcode::SoftwareReset);
    let always = op.info().is_some_and(|i| i.always_replies);
    documented || replies_switch(instruction).is_some() || (link.replies_off && !always)
}

/// `Some(true)` for SGP 255, 0 with a value that switches replies off, `Some(false)` for one that switches
/// them on again (PD28-1021 manual §5.1 Table 17).
fn replies_switch(instruction: &Instruction) -> Option<bool> {
    (instruction.opcode == Opcode::Sgp && instruction.kind == 255 && instruction.motor == 0)
        .then_some(instruction.value != 0)
}

/// Whether an instruction names an axis parameter (`Some((true, motor))`) or a global one
/// (`Some((false, bank))`).
fn param_place(i: &Instruction) -> Option<(bool, u8)> {
    match i.opcode {
        Opcode::Sap | Opcode::Gap | Opcode::Stap | Opcode::Rsap | Opcode::Aap => Some((true, i.motor)),
        Opcode::Sgp | Opcode::Ggp | Opcode::Stgp | Opcode::Rsgp | Opcode::Agp => Some((false, i.motor)),
        _ => None,
    }
}

/// What the model's tables refuse in an assembled program (`tmcl asm --module`'s warnings): a constant
/// operand outside a parameter's range, a parameter, bank, port or motor the model lacks. The module
/// would skip such an instruction (a program gets no status), so the page marks its line; it does not
/// keep the program from being downloaded.
fn warnings(link: &Link, program: Option<&tmcl_asm::Program>, source: &str) -> Vec<DiagnosticInfo> {
    let (Some(program), Some(model)) = (program, link.model) else { return Vec::new() };
    let mut text = |file: &str, line: u32| {
        (file == SOURCE_NAME).then(|| source.lines().nth(line as usize - 1).map(String::from)).flatten()
    };
    tmcl_asm::check_operands(program, model, &mut text)
        .into_iter()
        .filter(|d| d.file == SOURCE_NAME)
        .map(|d| DiagnosticInfo::from(&d))
        .collect()
}

/// Assembles the editor's text with the model's built-in include files.
fn assemble(link: &Link, source: &str) -> Result<(Option<tmcl_asm::Program>, Vec<DiagnosticInfo>), Failure> {
    if source.len() > MAX_SOURCE {
        return Err(format!("the program is longer than {MAX_SOURCE} bytes").into());
    }
    let model = link.model.unwrap_or(&tmcl_model::pd28_1021::SPEC);
    let mut resolver = BuiltinResolver { model };
    match assemble_str(SOURCE_NAME, source, &mut resolver) {
        Ok(program) => {
            let capacity = usize::from(model.program_memory);
            if program.instructions.len() > capacity {
                let message = format!(
                    "the program has {} instructions; the {} holds {capacity}",
                    program.instructions.len(),
                    model.name
                );
                let d = DiagnosticInfo { file: SOURCE_NAME.into(), line: 0, column: 0, width: 0, message };
                return Ok((None, vec![d]));
            }
            Ok((Some(program), Vec::new()))
        }
        Err(diagnostics) => Ok((None, diagnostics.iter().map(DiagnosticInfo::from).collect())),
    }
}

fn download(link: &mut Link, source: &str) -> Result<Answer, Failure> {
    let (program, diagnostics) = assemble(link, source)?;
    let Some(program) = program else {
        return Ok(Answer::Downloaded(Downloaded { stored: None, lines: None, diagnostics, warnings: None }));
    };
    let warnings = warnings(link, Some(&program), source);
    let total = program.instructions.len();
    debug::download(link, &program.instructions, |link, n| {
        if n % 8 == 0 || n == total {
            link.emit_typed(&ProgressEvent { e: "progress", what: "download", done: n, total });
        }
    })?;
    let lines: Vec<Option<u32>> =
        program.source_lines.iter().map(|s| (&*s.file == SOURCE_NAME).then_some(s.line)).collect();
    link.debug.set_program(program, SOURCE_NAME);
    Ok(Answer::Downloaded(Downloaded {
        stored: Some(total),
        lines: Some(lines),
        diagnostics: Vec::new(),
        warnings: Some(warnings),
    }))
}

/// The answer to `save_params`.
#[derive(Debug, Serialize)]
pub(crate) struct Saved {
    /// The set as TOML.
    toml: String,
    /// How many values it holds.
    count: usize,
    /// Values the module would not give.
    notes: Vec<String>,
    /// A file name for it: `MODEL-ADDRESS-params.toml`.
    file_name: String,
}

/// The answer to `load_params` and `store_all`.
#[derive(Debug, Serialize)]
pub(crate) struct Loaded {
    written: usize,
    stored: usize,
    unchanged: usize,
    skipped: usize,
    refused: usize,
    /// Every parameter that was skipped or refused, with why.
    outcomes: Vec<paramset::Outcome>,
}

impl Loaded {
    fn of(outcomes: Vec<paramset::Outcome>) -> Loaded {
        let count = |r: &str| outcomes.iter().filter(|o| o.result == r).count();
        Loaded {
            written: count("written"),
            stored: count("stored"),
            unchanged: count("unchanged"),
            skipped: count("skipped"),
            refused: count("refused"),
            outcomes: outcomes.into_iter().filter(|o| o.result == "refused" || o.result == "skipped").collect(),
        }
    }
}

fn save_params(link: &mut Link) -> Result<Answer, Failure> {
    let model = link.model.ok_or_else(|| "the model is unknown: give --module MODEL".to_string())?;
    let address = link.address();
    let (file, notes) = link.with_client(|c| paramset::snapshot(c, model))?;
    let toml = paramset::to_toml(&file)?;
    let file_name = format!("{}-{address}-params.toml", model.id);
    Ok(Answer::Saved(Saved { toml, count: file.params.len(), notes, file_name }))
}

fn load_params(link: &mut Link, text: &str, store: bool, any_model: bool) -> Result<Answer, Failure> {
    if text.len() > MAX_SOURCE {
        return Err(format!("the set is longer than {MAX_SOURCE} bytes").into());
    }
    let model = link.model.ok_or_else(|| "the model is unknown: give --module MODEL".to_string())?;
    let file = paramset::from_toml(text)?;
    paramset::check_model(&file, model, any_model)?;
    let options = paramset::LoadOptions { store, interface: false };
    let outcomes = link.with_client(|c| paramset::load(c, model, &file, options))?;
    link.hurry(|p| matches!(p, Poll::Axis { .. } | Poll::Global { .. }));
    Ok(Answer::Loaded(Loaded::of(outcomes)))
}

fn store_all(link: &mut Link) -> Result<Answer, Failure> {
    let model = link.model.ok_or_else(|| "the model is unknown: give --module MODEL".to_string())?;
    let outcomes = link.with_client(|c| paramset::store_all(c, model))?;
    Ok(Answer::Loaded(Loaded::of(outcomes)))
}

/// A module that answered a scan.
#[derive(Debug, Serialize)]
pub(crate) struct Found {
    address: u8,
    /// `null` when the module answered the binary version but not the string.
    version: Option<String>,
}

/// The answer to `scan`: the modules that answered, by address.
#[derive(Debug, Serialize)]
pub(crate) struct Scanned {
    modules: Vec<Found>,
}

/// Asks each address for its binary version (136 type 1) with a short wait, as `tmcl scan` does, then
/// goes back to the address it talked to.
fn scan(link: &mut Link, first: u8, last: u8) -> Result<Answer, Failure> {
    if first > last {
        return Err(format!("the first address {first} is after the last {last}").into());
    }
    let address = link.address();
    let wait = Duration::from_secs_f64((2.0 / link.rate).max(0.02) + 0.02);
    let old = link.set_timeout(wait);
    link.scanning = true;
    let mut found = Vec::new();
    let probe = Command::GetVersion { format: tmcl_wire::VersionFormat::Binary }.encode();
    let mut client_result = Ok(());
    for a in first..=last {
        link.set_address(a);
        match link.request(probe) {
            Ok(reply) => found.push(reply.module),
            Err(HostError::Io(e)) => {
                client_result = Err(HostError::Io(e));
                break;
            }
            Err(_) => {}
        }
        found.extend(link.settle().into_iter().filter(|r| r.opcode == u8::from(Opcode::GetVersion)).map(|r| r.module));
        let (done, total) = (u16::from(a - first) + 1, u16::from(last - first) + 1);
        if done % 8 == 0 || a == last {
            link.emit_typed(&ProgressEvent { e: "progress", what: "scan", done: done.into(), total: total.into() });
        }
    }
    link.set_timeout(old);
    link.scanning = false;
    found.sort_unstable();
    found.dedup();
    let mut modules = Vec::new();
    for a in found {
        link.set_address(a);
        let version = link.version_string().ok();
        modules.push(Found { address: a, version });
    }
    link.set_address(address);
    link.settle();
    client_result?;
    Ok(Answer::Scanned(Scanned { modules }))
}

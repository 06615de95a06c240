//! Host commands of `tmcl`: talk to a real or virtual module over a serial port, a pty or TCP.
//!
//! Each command opens the connection, sends its requests with [`tmcl_host::Client`], prints one line (or one
//! JSON object with `--json`) and returns what happened; `main` turns a failure into its exit code
//! ([`crate::error::EXIT_CODES`]).

use crate::args::{parse_byte, parse_number, parse_value};
use crate::connection::{Connection, HostClient};
use crate::error::{CliError, ReplyJson, EXIT_CODES};
use crate::names::{self, ModelOption, ParamRef};
use crate::output::{self, json_line};
use clap::Subcommand;
use std::io::{self, Write};
use std::time::Duration;
use tmcl_host::{Client, FirmwareVersion, HostError, Transport};
use tmcl_wire::command::{
    CalcOp, CalcxOp, Condition, ErrorFlag, EventMode, MoveKind, RfsAction, StatusKind, VersionFormat, WaitCondition,
};
use tmcl_wire::{Command, Instruction, Opcode, Reply};

/// Commands sent to a module (PD28-1021 TMCL manual §3.7).
#[derive(Debug, Clone, Subcommand)]
pub enum HostCommand {
    /// Print the firmware version (command 136: the string, such as 1021V142, and the binary form).
    #[command(after_help = EXIT_CODES)]
    Version {
        #[command(flatten)]
        conn: Connection,
    },
    /// Read an axis parameter (GAP) or a global parameter (GGP), by number or name.
    #[command(after_help = EXIT_CODES)]
    Get {
        #[command(flatten)]
        conn: Connection,
        #[command(flatten)]
        model: ModelOption,
        #[command(subcommand)]
        param: Parameter,
    },
    /// Write an axis parameter (SAP) or a global parameter (SGP), by number or name.
    #[command(after_help = EXIT_CODES)]
    Set {
        #[command(flatten)]
        conn: Connection,
        #[command(flatten)]
        model: ModelOption,
        #[command(subcommand)]
        param: ParameterValue,
    },
    /// Store a parameter in the EEPROM (STAP, STGP).
    #[command(after_help = EXIT_CODES)]
    Store {
        #[command(flatten)]
        conn: Connection,
        #[command(flatten)]
        model: ModelOption,
        #[command(subcommand)]
        param: Parameter,
    },
    /// Restore a parameter from the EEPROM (RSAP, RSGP).
    #[command(after_help = EXIT_CODES)]
    Restore {
        #[command(flatten)]
        conn: Connection,
        #[command(flatten)]
        model: ModelOption,
        #[command(subcommand)]
        param: Parameter,
    },
    /// Send one raw command and print the reply's status and value.
    ///
    /// OPCODE is a number (0-255) or a mnemonic (MVP, SAP, ...); TYPE is a number or the command's type word
    /// (ABS, REL, COORD for MVP; START, STOP, STATUS for RFS; ADD, SUB, ... for CALC; ...). Commands 137 and 242
    /// get no reply when carried out, 255 may not: for them `tmcl` shows a reply that comes within --timeout (a
    /// refusal, such as a wrong key, exits 1) and says "no reply" only when none came. 136 type 0 prints the
    /// version string.
    #[command(after_help = EXIT_CODES, allow_negative_numbers = true)]
    Send {
        #[command(flatten)]
        conn: Connection,
        /// Command number or mnemonic.
        opcode: String,
        /// Type number or type word.
        #[arg(value_name = "TYPE")]
        kind: String,
        /// Motor or bank number (0-255, decimal or 0x-prefixed hexadecimal).
        #[arg(value_parser = parse_byte)]
        motor: u8,
        /// Value: decimal (may be negative) or 0x-prefixed hexadecimal (32 bits).
        #[arg(value_parser = parse_value)]
        value: i32,
    },
    /// List the modules answering on the line: every address from --first to --last is asked for its
    /// version (command 136), each with a short wait. The modules go to stdout, progress and notes to
    /// stderr; no module at all is exit code 3.
    ///
    /// A reply that comes after its --wait still counts for the address it names (the line is drained
    /// after every unanswered address), and the scan says which addresses answered late.
    #[command(after_help = EXIT_CODES)]
    Scan {
        #[command(flatten)]
        conn: Connection,
        /// First address to ask.
        #[arg(long, default_value_t = 1)]
        first: u8,
        /// Last address to ask.
        #[arg(long, default_value_t = 255)]
        last: u8,
        /// How long to wait for each address, in milliseconds [default: the time of a request and its
        /// reply at --baud plus 20 ms: 39 at 9600 baud].
        #[arg(long, value_name = "MS")]
        wait: Option<u64>,
    },
    /// List a model's parameters: number, name, access, range, unit, and each value read from the module.
    #[command(after_help = EXIT_CODES)]
    Params(names::ParamsArgs),
    /// Wait until a move has ended, a reference search is done, or a value meets a condition.
    #[command(after_help = EXIT_CODES)]
    Wait(crate::watch::WaitArgs),
    /// Read values over and over and print them as a table (or JSON lines), until interrupted.
    #[command(after_help = EXIT_CODES)]
    Watch(crate::watch::WatchArgs),
}

impl HostCommand {
    /// The command's name, for error messages.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            HostCommand::Version { .. } => "version",
            HostCommand::Get { .. } => "get",
            HostCommand::Set { .. } => "set",
            HostCommand::Store { .. } => "store",
            HostCommand::Restore { .. } => "restore",
            HostCommand::Send { .. } => "send",
            HostCommand::Scan { .. } => "scan",
            HostCommand::Params(_) => "params",
            HostCommand::Wait(_) => "wait",
            HostCommand::Watch(_) => "watch",
        }
    }
}

/// Which parameter: `ap P [--motor M]` or `gp P [BANK]`; P is a number or a name.
#[derive(Debug, Clone, Subcommand)]
pub enum Parameter {
    /// An axis parameter.
    #[command(after_help = EXIT_CODES)]
    Ap {
        /// Parameter number (manual chapter 4) or name, e.g. 4 or MaxPositioningSpeed (any case).
        #[arg(value_name = "NUMBER|NAME")]
        param: String,
        /// Motor number.
        #[arg(long, short, default_value_t = 0)]
        motor: u8,
    },
    /// A global parameter.
    #[command(after_help = EXIT_CODES)]
    Gp {
        /// Parameter number (manual chapter 5) or name, e.g. 66 or SerialAddress (any case).
        #[arg(value_name = "NUMBER|NAME")]
        param: String,
        /// Bank number (default 0; a name of a bank 3 parameter selects bank 3).
        #[arg(value_parser = parse_byte)]
        bank: Option<u8>,
    },
}

/// Which parameter and what to write: `ap P V [--motor M]` or `gp P V [BANK]`.
#[derive(Debug, Clone, Subcommand)]
pub enum ParameterValue {
    /// An axis parameter.
    #[command(after_help = EXIT_CODES, allow_negative_numbers = true)]
    Ap {
        /// Parameter number (manual chapter 4) or name, e.g. 4 or MaxPositioningSpeed (any case).
        #[arg(value_name = "NUMBER|NAME")]
        param: String,
        /// Value: decimal (may be negative) or 0x-prefixed hexadecimal.
        #[arg(value_parser = parse_value)]
        value: i32,
        /// Motor number.
        #[arg(long, short, default_value_t = 0)]
        motor: u8,
    },
    /// A global parameter.
    #[command(after_help = EXIT_CODES, allow_negative_numbers = true)]
    Gp {
        /// Parameter number (manual chapter 5) or name, e.g. 66 or SerialAddress (any case).
        #[arg(value_name = "NUMBER|NAME")]
        param: String,
        /// Value: decimal (may be negative) or 0x-prefixed hexadecimal.
        #[arg(value_parser = parse_value)]
        value: i32,
        /// Bank number (default 0; a name of a bank 3 parameter selects bank 3).
        #[arg(value_parser = parse_byte)]
        bank: Option<u8>,
    },
}

impl Parameter {
    /// The parameter's kind, text and motor or bank.
    fn parts(&self) -> ParamRef<'_> {
        match self {
            Parameter::Ap { param, motor } => ParamRef::Axis { param, motor: *motor },
            Parameter::Gp { param, bank } => ParamRef::Global { param, bank: *bank },
        }
    }
}

impl ParameterValue {
    fn parts(&self) -> (ParamRef<'_>, i32) {
        match self {
            ParameterValue::Ap { param, value, motor } => (ParamRef::Axis { param, motor: *motor }, *value),
            ParameterValue::Gp { param, value, bank } => (ParamRef::Global { param, bank: *bank }, *value),
        }
    }
}

/// Runs one host command, printing its result on standard output.
pub(crate) fn run(cmd: HostCommand, json: bool) -> Result<(), CliError> {
    execute(cmd, json, &mut io::stdout().lock())
}

/// Runs `cmd`, printing its result to `out`.
fn execute(cmd: HostCommand, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    match cmd {
        HostCommand::Version { conn } => version(&mut conn.open()?, json, out),
        HostCommand::Scan { conn, first, last, wait } => {
            let plan = ScanPlan::new(first, last, wait, &conn)?;
            scan(&mut conn.open()?, &plan, json, out)
        }
        HostCommand::Params(args) => names::params(args, json, out),
        HostCommand::Wait(args) => crate::watch::wait(args, json, out),
        HostCommand::Watch(args) => crate::watch::watch(args, json, out),
        HostCommand::Get { conn, model, param } => {
            let mut client = conn.open()?;
            let mut models = names::Models::new(&model)?;
            let target = models.resolve(param.parts(), &mut client)?;
            let reply = client
                .request(target.instruction(target.read_opcode(), 0))
                .map_err(|e| explain(&mut models, &mut client, target, e, None))?;
            if json {
                json_line(out, &target.json(&reply))?;
            } else {
                writeln!(out, "{} = {}", target.label(), target.with_unit(reply.value))?;
            }
            Ok(())
        }
        HostCommand::Set { conn, model, param } => {
            let mut client = conn.open()?;
            let mut models = names::Models::new(&model)?;
            let (param, value) = param.parts();
            let target = models.resolve(param, &mut client)?;
            let instruction = target.instruction(target.write_opcode(), value);
            if instruction.opcode == Opcode::Sgp && instruction.kind == 255 && value != 0 {
                return replies_off(&mut client, instruction, json, out);
            }
            let reply =
                client.request(instruction).map_err(|e| explain(&mut models, &mut client, target, e, Some(value)))?;
            ok(&target, reply, json, out)
        }
        HostCommand::Store { conn, model, param } => {
            let mut client = conn.open()?;
            let target = names::Models::new(&model)?.resolve(param.parts(), &mut client)?;
            let reply = client
                .request(target.instruction(target.store_opcode(Opcode::Stap, Opcode::Stgp), 0))
                .map_err(|e| why_silent(&mut client, e))?;
            ok(&target, reply, json, out)
        }
        HostCommand::Restore { conn, model, param } => {
            let mut client = conn.open()?;
            let target = names::Models::new(&model)?.resolve(param.parts(), &mut client)?;
            let reply = client
                .request(target.instruction(target.store_opcode(Opcode::Rsap, Opcode::Rsgp), 0))
                .map_err(|e| why_silent(&mut client, e))?;
            ok(&target, reply, json, out)
        }
        HostCommand::Send { conn, opcode, kind, motor, value } => {
            // Usage errors first: they should not wait for a port.
            let instruction = parse_instruction(&opcode, &kind, motor, value)?;
            send(&mut conn.open()?, instruction, json, out)
        }
    }
}

/// A refusal explained from the parameter tables; the model is asked for if it is not known yet (only on
/// this error path, so that a read by number costs one request).
fn explain(
    models: &mut names::Models,
    client: &mut HostClient,
    mut target: names::Target,
    err: HostError,
    value: Option<i32>,
) -> CliError {
    if matches!(err, HostError::Timeout { received: 0, .. }) {
        return why_silent(client, err);
    }
    if matches!(err, HostError::Status { .. }) && target.model.is_none() {
        if let Ok(model) = models.get(client) {
            target = names::lookup_number(model, target);
        }
    }
    target.explain(err, value)
}

/// Prints `ok` (or the reply as JSON) for commands whose value means nothing.
fn ok(target: &names::Target, reply: Reply, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    if json {
        json_line(out, &target.json(&reply))?;
    } else {
        writeln!(out, "ok")?;
    }
    Ok(())
}

/// `tmcl version`: command 136 type 0, then type 1.
fn version(client: &mut HostClient, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let text = client.version_string()?;
    let binary = client.version_binary()?;
    let decoded = FirmwareVersion::from_value_and_string(binary, &text);
    if json {
        let value = output::Version {
            address: client.module_address,
            binary,
            firmware: format!("{}.{:02}", decoded.major, decoded.minor),
            model: decoded.module,
            version: text,
        };
        json_line(out, &value)?;
    } else {
        writeln!(out, "{text}")?;
        writeln!(out, "firmware {decoded}, binary {binary:#010x}")?;
    }
    Ok(())
}

/// What `tmcl scan` asks and how long it waits.
struct ScanPlan {
    first: u8,
    last: u8,
    /// How long each address gets.
    wait: Duration,
    /// The quiet interval of the drain after an unanswered address.
    quiet: Duration,
    /// How long the version string of a module found may take (--timeout).
    timeout: Duration,
    /// The default wait at --baud, suggested when replies came late.
    default_wait: Duration,
}

impl ScanPlan {
    fn new(first: u8, last: u8, wait_ms: Option<u64>, conn: &Connection) -> Result<ScanPlan, CliError> {
        if first > last {
            return Err(CliError::Usage(format!("--first {first} is after --last {last}")));
        }
        // One 9-byte frame of 10-bit characters (8N1) at --baud: 9.4 ms at 9600.
        let frame = Duration::from_micros(90_000_000 / u64::from(conn.baud.max(1)));
        let default_wait = 2 * frame + Duration::from_millis(20);
        let wait = wait_ms.map_or(default_wait, |ms| Duration::from_millis(ms.max(1)));
        let quiet = (2 * frame).max(Duration::from_millis(10));
        Ok(ScanPlan { first, last, wait, quiet, timeout: conn.timeout, default_wait })
    }
}

/// The scan's progress line on stderr, when stderr is a terminal.
struct Progress {
    on: bool,
    shown: bool,
}

impl Progress {
    fn show(&mut self, plan: &ScanPlan, address: u8) {
        if self.on {
            let done = usize::from(address - plan.first) + 1;
            let total = usize::from(plan.last - plan.first) + 1;
            eprint!("\rscanning {}..{}: {done}/{total} ", plan.first, plan.last);
            self.shown = true;
        }
    }

    fn clear(&mut self) {
        if self.shown {
            eprint!("\r\x1b[K");
            self.shown = false;
        }
    }
}

/// `tmcl scan`: the modules on the line, by address.
///
/// Each address is asked for its binary version (136 type 1): unlike the version string, its reply names the
/// module, so a reply that comes late (during the drain after its address, or while a later address waits)
/// still counts for the module that sent it. The version string of each module found is asked for then.
fn scan(
    client: &mut Client<Box<dyn Transport + Send>>,
    plan: &ScanPlan,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    use std::io::IsTerminal;
    let mut progress = Progress { on: io::stderr().is_terminal(), shown: false };
    let mut probed = [false; 256];
    let mut found = Vec::new();
    let mut late = Vec::new();
    let mut elsewhere = Vec::new();
    client.quiet = plan.quiet;
    let probe = Command::GetVersion { format: VersionFormat::Binary }.encode();
    for address in plan.first..=plan.last {
        progress.show(plan, address);
        probed[usize::from(address)] = true;
        client.module_address = address;
        client.timeout = plan.wait;
        let answer = match client.request(probe) {
            Ok(reply) | Err(HostError::Status { reply, .. }) => Some(reply),
            Err(e @ (HostError::Io(_) | HostError::Open { .. } | HostError::InUse { .. })) => {
                progress.clear();
                return Err(e.into());
            }
            // Nothing, or a reply to another address: see the skipped replies below.
            Err(_) => None,
        };
        // Drain now after an unanswered address, so that its late reply is counted for it at once.
        client.settle()?;
        let mut answered: Vec<(Reply, bool)> = answer.into_iter().map(|r| (r, false)).collect();
        answered.extend(client.take_skipped().into_iter().map(|r| (r, true)));
        for (reply, is_late) in answered {
            let module = reply.module;
            if reply.opcode != u8::from(Opcode::GetVersion) || !probed[usize::from(module)] {
                progress.clear();
                eprintln!(
                    "tmcl scan: ignored a reply that answers no request of this scan: module {module}, command {}, value {}",
                    Opcode::from(reply.opcode),
                    reply.value
                );
            } else if found.contains(&module) {
                // A module that answers from another address than the one asked (USB answers every address,
                // a secondary address GP 87 answers from the primary one).
                if !elsewhere.contains(&module) {
                    elsewhere.push(module);
                }
            } else {
                found.push(module);
                if is_late {
                    late.push(module);
                }
                progress.clear();
                report_module(client, plan, &reply, json, out)?;
            }
        }
    }
    client.settle()?;
    progress.clear();
    if !json {
        writeln!(out, "{} module(s) found", found.len())?;
    }
    let list = |modules: &[u8]| modules.iter().map(u8::to_string).collect::<Vec<_>>().join(", ");
    if !elsewhere.is_empty() {
        eprintln!(
            "tmcl scan: module(s) {} also answered at other addresses (a USB link answers every address; a \
             secondary address, GP 87, answers from the module's own)",
            list(&elsewhere)
        );
    }
    let ms = |d: Duration| d.as_secs_f64() * 1000.0;
    if !late.is_empty() {
        let suggest = plan.default_wait.max(plan.wait * 4);
        eprintln!(
            "tmcl scan: address(es) {} answered after --wait {:.0} ms (late replies, counted); give a longer wait, \
             e.g. --wait {:.0}",
            list(&late),
            ms(plan.wait),
            ms(suggest).ceil()
        );
    }
    if found.is_empty() {
        return Err(CliError::Io(format!(
            "no module answered at addresses {}..{} (waited {:.0} ms each, and for late replies)",
            plan.first,
            plan.last,
            ms(plan.wait)
        )));
    }
    Ok(())
}

/// Prints one module found: its version string (with --timeout), or the binary version of `reply` if the
/// string does not come.
fn report_module(
    client: &mut Client<Box<dyn Transport + Send>>,
    plan: &ScanPlan,
    reply: &Reply,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    client.module_address = reply.module;
    client.timeout = plan.timeout;
    let text = match client.version_string() {
        Ok(text) => text,
        Err(e @ (HostError::Io(_) | HostError::Open { .. } | HostError::InUse { .. })) => return Err(e.into()),
        Err(e) => {
            eprintln!("tmcl scan: address {}: no version string ({e})", reply.module);
            FirmwareVersion::from_value(reply.value).to_string()
        }
    };
    if json {
        json_line(out, &output::Found { address: Some(reply.module), version: text })?;
    } else {
        writeln!(out, "{:>3}  {text}", reply.module)?;
    }
    Ok(())
}

/// `tmcl send`: one raw command, with the special cases of the control commands.
fn send(client: &mut HostClient, instruction: Instruction, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    match (instruction.opcode, instruction.kind) {
        (Opcode::GetVersion, 0) => {
            // The raw 136 type 0 reply has no status: the version string is the answer.
            let text = client.version_string()?;
            if json {
                json_line(out, &output::Found { address: None, version: text })?;
            } else {
                writeln!(out, "{text}")?;
            }
        }
        (Opcode::FactoryDefault | Opcode::Boot | Opcode::SoftwareReset, _) => {
            // Documented to get no reply when carried out (§3.7.38), but a refusal (a wrong key: status 4)
            // is answered: show what comes within the timeout, and "no reply" only when nothing did.
            match client.request_optional(instruction)? {
                Some(reply) if json => json_line(out, &ReplyJson::from(&reply))?,
                Some(reply) => writeln!(out, "status {}, value {}", reply.status, reply.value)?,
                None if json => {
                    let sent = Sent { sent: true, opcode: u8::from(instruction.opcode), reply: None };
                    writeln!(out, "{}", serde_json::to_string(&sent)?)?
                }
                None => writeln!(
                    out,
                    "sent; no reply within {} s (this command gets none when it is carried out)",
                    client.timeout.as_secs_f64()
                )?,
            }
        }
        _ => {
            let reply = client.request(instruction).map_err(|e| why_silent(client, e))?;
            if json {
                json_line(out, &ReplyJson::from(&reply))?;
            } else {
                writeln!(out, "status {}, value {}", reply.status, reply.value)?;
            }
        }
    }
    Ok(())
}

/// `tmcl send` of a command that got no reply, with --json.
#[derive(Debug, serde::Serialize)]
struct Sent {
    /// Always true: the request went out.
    sent: bool,
    /// The command number.
    opcode: u8,
    /// Always null: nothing came within the timeout.
    reply: Option<()>,
}

/// `tmcl set gp 255 N` with N other than 0, with --json.
#[derive(Debug, serde::Serialize)]
struct RepliesOff {
    /// The value set.
    value: i32,
    /// "off".
    replies: &'static str,
    /// The command that turns them on again.
    turn_on: &'static str,
}

/// `set gp 255 N` (N not 0): replies off (§5.1 GP 255). The module suppresses the reply to this very
/// command, so silence is success; a refusal still comes (a module without GP 255) and fails.
fn replies_off(
    client: &mut HostClient,
    instruction: Instruction,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    client.request_optional(instruction)?;
    // Silence is expected, but check that it is the module's choice: GGP is always answered.
    let value = client.get_global_parameter(255, 0)?;
    if value == 0 {
        return Err(CliError::Io("the module answered but kept its replies on (GP 255 reads 0)".into()));
    }
    if json {
        let off = RepliesOff { value, replies: "off", turn_on: "tmcl set gp 255 0" };
        writeln!(out, "{}", serde_json::to_string(&off)?)?;
    } else {
        writeln!(
            out,
            "ok: replies are now off (GP 255 = {value}): the module answers only GAP, GGP and GIO, so other \
             commands get no reply and time out; `tmcl set gp 255 0` turns them on again (a restart does too: \
             GP 255 is not stored)"
        )?;
    }
    Ok(())
}

/// A request that got no reply at all: if the module's replies are off (GP 255, asked with GGP, which is
/// always answered), says so and how to turn them on, instead of a hint about the port.
fn why_silent(client: &mut HostClient, err: HostError) -> CliError {
    if matches!(err, HostError::Timeout { received: 0, .. }) {
        // A module answers within milliseconds; a dead line should not cost a second full timeout.
        let timeout = client.timeout;
        client.timeout = timeout.min(std::time::Duration::from_millis(500));
        let probe = client.get_global_parameter(255, 0);
        client.timeout = timeout;
        if let Ok(value) = probe {
            if value != 0 {
                return CliError::Explained {
                    source: err,
                    explanation: format!(
                        "the module's replies are off (GP 255 = {value}): it answers only GAP, GGP and GIO; \
                         `tmcl set gp 255 0` turns them on again"
                    ),
                };
            }
        }
    }
    err.into()
}

/// Builds the instruction of `tmcl send` from its words.
fn parse_instruction(opcode: &str, kind: &str, motor: u8, value: i32) -> Result<Instruction, CliError> {
    let opcode = match parse_number(opcode) {
        Some(n) => u8::try_from(n)
            .map(Opcode::from)
            .map_err(|_| CliError::Usage(format!("opcode {opcode} is out of range 0..255")))?,
        None => Opcode::from_mnemonic(opcode).ok_or_else(|| {
            CliError::Usage(format!("unknown opcode {opcode:?}: give a number or a mnemonic like MVP"))
        })?,
    };
    let kind = match parse_number(kind) {
        Some(n) => u8::try_from(n).map_err(|_| CliError::Usage(format!("type {kind} is out of range 0..255")))?,
        None => tmcl_wire::ascii::type_word(opcode, kind).ok_or_else(|| {
            CliError::Usage(format!(
                "{kind:?} is not a type word of {opcode}: give a number or one of {}",
                words(opcode)
            ))
        })?,
    };
    Ok(Instruction::new(opcode, kind, motor, value))
}

/// The type words of `opcode`, for error messages.
fn words(opcode: Opcode) -> String {
    fn list<T: Copy>(all: &[T], word: fn(T) -> &'static str) -> String {
        all.iter().map(|&t| word(t)).collect::<Vec<_>>().join(", ")
    }
    match opcode {
        Opcode::Mvp => list(MoveKind::ALL, MoveKind::word),
        Opcode::Rfs => list(RfsAction::ALL, RfsAction::word),
        Opcode::Calc => list(CalcOp::ALL, CalcOp::word),
        Opcode::Calcx => list(CalcxOp::ALL, CalcxOp::word),
        Opcode::Jc => list(Condition::ALL, Condition::word),
        Opcode::Wait => list(WaitCondition::ALL, WaitCondition::word),
        Opcode::Cle => list(ErrorFlag::ALL, ErrorFlag::word),
        Opcode::GetStatus => list(StatusKind::ALL, StatusKind::word),
        Opcode::GetVersion => list(VersionFormat::ALL, VersionFormat::word),
        Opcode::RequestTargetReachedEvent => list(EventMode::ALL, EventMode::word),
        _ => "none (this command has no type words)".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::{EXIT_BAD_REPLY, EXIT_IO, EXIT_STATUS, EXIT_USAGE};
    use clap::Parser;
    use serde_json::json;
    use std::io::Read;
    use std::net::TcpListener;
    use std::thread;
    use tmcl_wire::{Frame, Request, Status, FRAME_LEN};

    /// The shape `main.rs` gives the command line.
    #[derive(Debug, Parser)]
    #[command(name = "tmcl")]
    struct TestCli {
        #[arg(long, global = true)]
        json: bool,
        #[command(subcommand)]
        command: HostCommand,
    }

    /// Parses a command line; connection options may come first, as `main` lets them.
    fn parse(args: &[&str]) -> Result<TestCli, clap::Error> {
        let mut leading = Vec::new();
        let mut rest = args;
        while let Some((first, tail)) = rest.split_first() {
            if first.starts_with("--") {
                leading.push(*first);
                if *first != "--json" {
                    leading.push(tail[0]);
                    rest = &tail[1..];
                } else {
                    rest = tail;
                }
            } else {
                break;
            }
        }
        let line: Vec<&str> = std::iter::once("tmcl")
            .chain(rest.first().copied())
            .chain(leading)
            .chain(rest.iter().skip(1).copied())
            .collect();
        TestCli::try_parse_from(line)
    }

    fn connection(command: &HostCommand) -> &Connection {
        match command {
            HostCommand::Version { conn }
            | HostCommand::Get { conn, .. }
            | HostCommand::Set { conn, .. }
            | HostCommand::Store { conn, .. }
            | HostCommand::Restore { conn, .. }
            | HostCommand::Send { conn, .. }
            | HostCommand::Scan { conn, .. } => conn,
            HostCommand::Params(a) => &a.conn,
            HostCommand::Wait(a) => &a.conn,
            HostCommand::Watch(a) => &a.conn,
        }
    }

    #[test]
    fn connection_options_anywhere() {
        let cli = parse(&["get", "ap", "1", "--tcp", "127.0.0.1:2323", "--timeout", "0.5", "--json"]).unwrap();
        assert_eq!(connection(&cli.command).tcp.as_deref(), Some("127.0.0.1:2323"));
        assert_eq!(connection(&cli.command).timeout, Duration::from_millis(500));
        assert!(cli.json);
        let cli = parse(&["get", "--port", "/tmp/link", "gp", "66"]).unwrap();
        assert_eq!(connection(&cli.command).port.as_deref(), Some("/tmp/link"));
        let cli = parse(&["--port", "/tmp/link", "--baud", "115200", "--address", "3", "version"]).unwrap();
        let conn = connection(&cli.command);
        assert_eq!(conn.port.as_deref(), Some("/tmp/link"));
        assert_eq!((conn.baud, conn.address), (115_200, 3));
        let cli = parse(&["version"]).unwrap();
        let conn = connection(&cli.command);
        assert_eq!((conn.baud, conn.address), (9600, 1));
        assert_eq!(conn.timeout, Duration::from_secs(5));
    }

    #[test]
    fn negative_and_hex_values_parse() {
        let cli = parse(&["set", "ap", "4", "-5000", "--motor", "1"]).unwrap();
        assert!(matches!(cli.command,
            HostCommand::Set { param: ParameterValue::Ap { ref param, value: -5000, motor: 1 }, .. } if param == "4"));
        let cli = parse(&["set", "gp", "77", "-1", "2"]).unwrap();
        assert!(matches!(cli.command,
            HostCommand::Set { param: ParameterValue::Gp { ref param, value: -1, bank: Some(2) }, .. } if param == "77"));
        let cli = parse(&["send", "242", "0x81", "0x92", "0xA3B4C5D6"]).unwrap();
        assert!(matches!(cli.command, HostCommand::Send { value, .. } if value == 0xA3B4C5D6u32 as i32));
        let cli = parse(&["send", "MVP", "ABS", "0", "-2147483648"]).unwrap();
        assert!(matches!(cli.command, HostCommand::Send { value: i32::MIN, .. }));
        assert!(parse(&["send", "MVP", "ABS", "0", "4294967296"]).is_err());
        assert!(parse(&["get", "gp", "66"])
            .is_ok_and(|c| matches!(c.command, HostCommand::Get { param: Parameter::Gp { bank: None, .. }, .. })));
    }

    #[test]
    fn usage_errors_are_clap_errors() {
        assert!(parse(&["--port", "a", "--tcp", "b", "version"]).is_err());
        assert!(parse(&["--timeout", "0", "version"]).is_err());
        assert!(parse(&["--timeout", "-1", "version"]).is_err());
        assert!(parse(&["set", "ap", "4"]).is_err());
        assert_eq!(parse(&["frobnicate"]).unwrap_err().exit_code(), 2);
    }

    #[test]
    fn send_words() {
        let i = parse_instruction("mvp", "rel", 0, -10).unwrap();
        assert_eq!(i, Instruction::new(Opcode::Mvp, 1, 0, -10));
        assert_eq!(parse_instruction("RFS", "STATUS", 0, 0).unwrap().kind, 2);
        assert_eq!(parse_instruction("136", "string", 0, 0).unwrap(), Instruction::new(Opcode::GetVersion, 0, 0, 0));
        assert_eq!(parse_instruction("0x8A", "EVERY", 0, 1).unwrap().kind, 1);
        assert_eq!(parse_instruction("UF3", "7", 0, 0).unwrap().opcode, Opcode::UserFunction(3));
        for (op, kind) in [("MVX", "0"), ("256", "0"), ("SAP", "ABS"), ("MVP", "300"), ("MVP", "-1")] {
            let err = parse_instruction(op, kind, 0, 0).unwrap_err();
            assert_eq!(err.exit_code(), EXIT_USAGE, "{op} {kind}: {err}");
        }
    }

    #[test]
    fn missing_connection_is_a_usage_error() {
        let cli = parse(&["version"]).unwrap();
        let err = execute(cli.command, false, &mut Vec::new()).unwrap_err();
        assert_eq!(err.exit_code(), EXIT_USAGE);
        assert!(err.to_string().contains("--port"));
    }

    /// A module on a local TCP port that answers each request with `answer`, then closes.
    fn fake_module(answers: Vec<Option<[u8; FRAME_LEN]>>) -> (String, thread::JoinHandle<Vec<Request>>) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        let handle = thread::spawn(move || {
            let (mut stream, _) = listener.accept().unwrap();
            let mut requests = Vec::new();
            for answer in answers {
                let mut frame = [0u8; FRAME_LEN];
                stream.read_exact(&mut frame).unwrap();
                requests.push(Request::parse(&Frame::new_unchecked(&frame[..])).unwrap());
                if let Some(bytes) = answer {
                    stream.write_all(&bytes).unwrap();
                }
            }
            // Wait for the host to hang up before closing.
            let _ = stream.read(&mut [0u8; 1]);
            requests
        });
        (addr, handle)
    }

    fn reply(status: Status, opcode: u8, value: i32) -> Option<[u8; FRAME_LEN]> {
        Some(Reply { host: 2, module: 1, status, opcode, value }.to_bytes())
    }

    /// Runs `args` against a fake module; returns the exit code (0 on success), the output and the requests.
    fn run_against(args: &[&str], answers: Vec<Option<[u8; FRAME_LEN]>>) -> (u8, String, Vec<Request>) {
        let (addr, module) = fake_module(answers);
        let mut full = vec!["--tcp", addr.as_str(), "--timeout", "0.3"];
        full.extend_from_slice(args);
        let cli = parse(&full).unwrap();
        let mut out = Vec::new();
        let code = execute(cli.command, cli.json, &mut out).map_or_else(|e| e.exit_code(), |()| 0);
        (code, String::from_utf8(out).unwrap(), module.join().unwrap())
    }

    #[test]
    fn get_set_store_against_a_fake_module() {
        let (code, out, requests) = run_against(&["get", "ap", "1"], vec![reply(Status::Ok, 6, -5000)]);
        assert_eq!((code, out.as_str()), (0, "ap 1 = -5000\n"));
        assert_eq!(requests[0].instruction, Instruction::new(Opcode::Gap, 1, 0, 0));
        assert_eq!(requests[0].address, 1);

        let from_7 = Some(Reply { host: 2, module: 7, status: Status::Ok, opcode: 9, value: -3 }.to_bytes());
        let (code, out, requests) = run_against(&["--address", "7", "set", "gp", "77", "-3", "2"], vec![from_7]);
        assert_eq!((code, out.as_str()), (0, "ok\n"));
        assert_eq!((requests[0].address, requests[0].instruction), (7, Instruction::new(Opcode::Sgp, 77, 2, -3)));

        let (code, out, requests) = run_against(&["store", "ap", "4", "-m", "1"], vec![reply(Status::Ok, 7, 0)]);
        assert_eq!((code, out.as_str()), (0, "ok\n"));
        assert_eq!(requests[0].instruction, Instruction::new(Opcode::Stap, 4, 1, 0));
    }

    #[test]
    fn json_output() {
        let (code, out, _) = run_against(&["--json", "get", "gp", "66"], vec![reply(Status::Ok, 10, 1)]);
        assert_eq!(code, 0);
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(
            v,
            json!({"status":100,"status_text":"successfully executed, no error","value":1,"address":1,"host":2,
                   "opcode":10,"type":66,"bank":0})
        );
    }

    #[test]
    fn send_prints_status_and_value() {
        let (code, out, requests) =
            run_against(&["send", "MVP", "ABS", "0", "-1000"], vec![reply(Status::Ok, 4, -1000)]);
        assert_eq!((code, out.as_str()), (0, "status 100 (successfully executed, no error), value -1000\n"));
        assert_eq!(requests[0].instruction, Instruction::new(Opcode::Mvp, 0, 0, -1000));
        let (code, out, requests) = run_against(&["send", "137", "0", "0", "1234"], vec![None]);
        assert_eq!(
            (code, out.as_str()),
            (0, "sent; no reply within 0.3 s (this command gets none when it is carried out)\n")
        );
        assert_eq!(requests[0].instruction, Instruction::new(Opcode::FactoryDefault, 0, 0, 1234));
        // A refusal of a command that gets no reply when carried out is shown, and exits 1.
        for op in ["137", "255"] {
            let (code, _, _) =
                run_against(&["send", op, "0", "0", "0"], vec![reply(Status::InvalidValue, op.parse().unwrap(), 0)]);
            assert_eq!(code, EXIT_STATUS, "send {op} refused");
        }
    }

    #[test]
    fn version_string_and_binary() {
        let mut raw = [2u8; FRAME_LEN];
        raw[1..].copy_from_slice(b"1021V142");
        let (code, out, _) = run_against(&["version"], vec![Some(raw), reply(Status::Ok, 136, 0x0A15_012A)]);
        assert_eq!(code, 0);
        assert_eq!(out, "1021V142\nfirmware 1.42 (module 1021), binary 0x0a15012a\n");
        let (_, out, _) = run_against(&["--json", "version"], vec![Some(raw), reply(Status::Ok, 136, 0x0A15_012A)]);
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(v, json!({"version":"1021V142","binary":0x0A15_012A,"firmware":"1.42","model":1021,"address":1}));
    }

    #[test]
    fn exit_codes() {
        let (code, out, _) = run_against(&["set", "ap", "4", "99999999"], vec![reply(Status::InvalidValue, 5, 0)]);
        assert_eq!((code, out.as_str()), (EXIT_STATUS, ""));
        let mut damaged = reply(Status::Ok, 6, 1).unwrap();
        damaged[8] ^= 1;
        let (code, _, _) = run_against(&["get", "ap", "1"], vec![Some(damaged)]);
        assert_eq!(code, EXIT_BAD_REPLY);
        // A reply from another module (a late one) is never the answer.
        let (code, out, _) = run_against(&["--address", "2", "get", "ap", "5"], vec![reply(Status::Ok, 6, 1000)]);
        assert_eq!((code, out.as_str()), (EXIT_BAD_REPLY, ""));
        let (code, _, _) = run_against(&["get", "ap", "1"], vec![None]);
        assert_eq!(code, EXIT_IO);
    }
}

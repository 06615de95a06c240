//! Host commands of `tmcl`: talk to a real or virtual module over a serial port, a pty or TCP.
//!
//! Each command opens the connection, sends its requests with [`tmcl_host::Client`], prints one line (or one
//! JSON object with `--json`) and exits with a code that says what happened (see [`EXIT_CODES`]).

use clap::{Args, Subcommand};
use serde_json::json;
use std::io::{self, Write};
use std::process::ExitCode;
use std::time::Duration;
use tmcl_host::{Client, FirmwareVersion, HostError, SerialTransport, TcpTransport, Transport};
use tmcl_wire::command::{
    CalcOp, CalcxOp, Condition, ErrorFlag, EventMode, MoveKind, RfsAction, StatusKind, VersionFormat, WaitCondition,
};
use tmcl_wire::{Command, Instruction, Opcode, Reply};

/// The exit codes of the host commands, as printed in `--help`.
pub const EXIT_CODES: &str = "\
Exit codes of host commands:
  0  success
  1  the module answered with an error status
  2  usage error (bad arguments, no or both of --port/--tcp)
  3  no reply in time, or the port/connection could not be opened, is in use or failed
  4  a damaged, late or foreign reply (checksum wrong, or a reply to another request)";

/// Exit code 1: the module said no, or its reply was damaged.
const EXIT_REPLY: u8 = 1;
/// Exit code 2: usage error (also clap's own code).
const EXIT_USAGE: u8 = 2;
/// Exit code 3: timeout or I/O failure.
const EXIT_IO: u8 = 3;
/// Exit code 4: a damaged, late or foreign reply.
const EXIT_BAD_REPLY: u8 = 4;

/// How to reach the module: global options of every host command.
#[derive(Debug, Clone, Args)]
#[command(after_help = EXIT_CODES)]
pub struct Connection {
    /// Serial port or pty to use, e.g. /dev/ttyUSB0 or the LINK made by `tmcl serve --pty LINK`.
    #[arg(long, global = true, value_name = "PATH", conflicts_with = "tcp", help_heading = "Connection")]
    pub port: Option<String>,
    /// Baud rate of the serial port (ignored by ptys).
    #[arg(long, global = true, value_name = "N", default_value_t = 9600, help_heading = "Connection")]
    pub baud: u32,
    /// TCP address of the module, HOST:PORT (e.g. 127.0.0.1:2323 for `tmcl serve --tcp`).
    #[arg(long, global = true, value_name = "HOST:PORT", help_heading = "Connection")]
    pub tcp: Option<String>,
    /// Module address (global parameter 66; default 1). For `serve`: the address a module with a new
    /// EEPROM answers at (a module keeps the address stored in its EEPROM).
    #[arg(long, global = true, value_name = "N", help_heading = "Connection")]
    pub address: Option<u8>,
    /// How long to wait for each reply, in seconds (fractions allowed).
    #[arg(long, global = true, value_name = "SECONDS", default_value = "5", value_parser = parse_seconds,
          help_heading = "Connection")]
    pub timeout: Duration,
    /// Print one JSON object per command instead of text.
    #[arg(long, global = true, help_heading = "Connection")]
    pub json: bool,
}

/// Commands sent to a module (PD28-1021 TMCL manual §3.7).
#[derive(Debug, Clone, Subcommand)]
pub enum HostCommand {
    /// Print the firmware version (command 136: the string, such as 1021V142, and the binary form).
    #[command(after_help = EXIT_CODES)]
    Version,
    /// Read an axis parameter (GAP) or a global parameter (GGP).
    #[command(subcommand)]
    Get(Parameter),
    /// Write an axis parameter (SAP) or a global parameter (SGP).
    #[command(subcommand)]
    Set(ParameterValue),
    /// Store a parameter in the EEPROM (STAP, STGP).
    #[command(subcommand)]
    Store(Parameter),
    /// Restore a parameter from the EEPROM (RSAP, RSGP).
    #[command(subcommand)]
    Restore(Parameter),
    /// Send one raw command and print the reply's status and value.
    ///
    /// OPCODE is a number (0-255) or a mnemonic (MVP, SAP, ...); TYPE is a number or the command's type word
    /// (ABS, REL, COORD for MVP; START, STOP, STATUS for RFS; ADD, SUB, ... for CALC; ...). Commands 137 and 242
    /// get no reply, 255 may not; for them `tmcl` only sends. 136 type 0 prints the version string.
    #[command(after_help = EXIT_CODES, allow_negative_numbers = true)]
    Send {
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
}

/// Which parameter: `ap N [--motor M]` or `gp N [BANK]`.
#[derive(Debug, Clone, Subcommand)]
pub enum Parameter {
    /// An axis parameter.
    #[command(after_help = EXIT_CODES)]
    Ap {
        /// Parameter number (manual chapter 4).
        number: u8,
        /// Motor number.
        #[arg(long, short, default_value_t = 0)]
        motor: u8,
    },
    /// A global parameter.
    #[command(after_help = EXIT_CODES)]
    Gp {
        /// Parameter number (manual chapter 5).
        number: u8,
        /// Bank number.
        #[arg(default_value_t = 0)]
        bank: u8,
    },
}

/// Which parameter and what to write: `ap N V [--motor M]` or `gp N V [BANK]`.
#[derive(Debug, Clone, Subcommand)]
pub enum ParameterValue {
    /// An axis parameter.
    #[command(after_help = EXIT_CODES, allow_negative_numbers = true)]
    Ap {
        /// Parameter number (manual chapter 4).
        number: u8,
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
        /// Parameter number (manual chapter 5).
        number: u8,
        /// Value: decimal (may be negative) or 0x-prefixed hexadecimal.
        #[arg(value_parser = parse_value)]
        value: i32,
        /// Bank number.
        #[arg(default_value_t = 0)]
        bank: u8,
    },
}

/// Runs one host command and returns the process exit code (see [`EXIT_CODES`]).
pub fn run(conn: &Connection, cmd: HostCommand) -> ExitCode {
    let stdout = io::stdout();
    let mut out = stdout.lock();
    match execute(conn, cmd, &mut out) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            if conn.json {
                if let CliError::Host(HostError::Status { reply, .. }) = &err {
                    let _ = writeln!(out, "{}", reply_json(reply));
                }
            }
            eprintln!("tmcl: {err}");
            ExitCode::from(err.exit_code())
        }
    }
}

/// Why a host command failed.
#[derive(Debug, thiserror::Error)]
pub(crate) enum CliError {
    /// Bad arguments that clap could not catch.
    #[error("{0}")]
    Usage(String),
    /// The module or the connection failed.
    #[error(transparent)]
    Host(#[from] HostError),
    /// Writing the output failed.
    #[error("cannot write the output: {0}")]
    Output(#[from] io::Error),
    /// No module answered a scan.
    #[error("{0}")]
    NoModule(String),
}

impl CliError {
    /// The process exit code for this failure (see [`EXIT_CODES`]).
    pub(crate) fn exit_code(&self) -> u8 {
        match self {
            CliError::Usage(_) => EXIT_USAGE,
            CliError::Host(err) if err.is_bad_reply() => EXIT_BAD_REPLY,
            CliError::Host(err) if err.is_status_error() => EXIT_REPLY,
            CliError::Host(_) | CliError::Output(_) | CliError::NoModule(_) => EXIT_IO,
        }
    }
}

impl Connection {
    /// Opens the one connection the options name.
    pub(crate) fn open(&self) -> Result<Client<Box<dyn Transport>>, CliError> {
        let transport: Box<dyn Transport> = match (&self.port, &self.tcp) {
            (Some(path), None) => Box::new(SerialTransport::open(path, self.baud)?),
            (None, Some(addr)) => Box::new(TcpTransport::connect(addr)?),
            (Some(_), Some(_)) => return Err(CliError::Usage("give either --port or --tcp, not both".into())),
            (None, None) => {
                return Err(CliError::Usage(
                    "no connection: give --port PATH (serial port or pty) or --tcp HOST:PORT".into(),
                ))
            }
        };
        Ok(Client::new(transport).with_module_address(self.address.unwrap_or(1)).with_timeout(self.timeout))
    }
}

/// Runs `cmd`, printing its result to `out`.
fn execute(conn: &Connection, cmd: HostCommand, out: &mut dyn Write) -> Result<(), CliError> {
    let json = conn.json;
    match cmd {
        HostCommand::Version => version(&mut conn.open()?, json, out),
        HostCommand::Scan { first, last, wait } => {
            let plan = ScanPlan::new(first, last, wait, conn)?;
            scan(&mut conn.open()?, &plan, json, out)
        }
        HostCommand::Get(p) => {
            let mut client = conn.open()?;
            let (reply, label) = match p {
                Parameter::Ap { number, motor } => (gap(&mut client, number, motor)?, ap_label(number, motor)),
                Parameter::Gp { number, bank } => (ggp(&mut client, number, bank)?, gp_label(number, bank)),
            };
            if json {
                writeln!(out, "{}", reply_json(&reply))?;
            } else {
                writeln!(out, "{label} = {}", reply.value)?;
            }
            Ok(())
        }
        HostCommand::Set(p) => {
            let instruction = match p {
                ParameterValue::Ap { number, value, motor } => Instruction::new(Opcode::Sap, number, motor, value),
                ParameterValue::Gp { number, value, bank } => Instruction::new(Opcode::Sgp, number, bank, value),
            };
            ok(conn.open()?.request(instruction)?, json, out)
        }
        HostCommand::Store(p) => ok(conn.open()?.request(parameter(p, Opcode::Stap, Opcode::Stgp))?, json, out),
        HostCommand::Restore(p) => ok(conn.open()?.request(parameter(p, Opcode::Rsap, Opcode::Rsgp))?, json, out),
        HostCommand::Send { opcode, kind, motor, value } => {
            // Usage errors first: they should not wait for a port.
            let instruction = parse_instruction(&opcode, &kind, motor, value)?;
            send(&mut conn.open()?, instruction, json, out)
        }
    }
}

fn gap(client: &mut Client<Box<dyn Transport>>, number: u8, motor: u8) -> Result<Reply, HostError> {
    client.request(Instruction::new(Opcode::Gap, number, motor, 0))
}

fn ggp(client: &mut Client<Box<dyn Transport>>, number: u8, bank: u8) -> Result<Reply, HostError> {
    client.request(Instruction::new(Opcode::Ggp, number, bank, 0))
}

fn parameter(p: Parameter, axis: Opcode, global: Opcode) -> Instruction {
    match p {
        Parameter::Ap { number, motor } => Instruction::new(axis, number, motor, 0),
        Parameter::Gp { number, bank } => Instruction::new(global, number, bank, 0),
    }
}

fn ap_label(number: u8, motor: u8) -> String {
    match motor {
        0 => format!("ap {number}"),
        m => format!("ap {number} (motor {m})"),
    }
}

fn gp_label(number: u8, bank: u8) -> String {
    match bank {
        0 => format!("gp {number}"),
        b => format!("gp {number} (bank {b})"),
    }
}

/// Prints `ok` (or the reply as JSON) for commands whose value means nothing.
fn ok(reply: Reply, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    if json {
        writeln!(out, "{}", reply_json(&reply))?;
    } else {
        writeln!(out, "ok")?;
    }
    Ok(())
}

/// `tmcl version`: command 136 type 0, then type 1.
fn version(client: &mut Client<Box<dyn Transport>>, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let text = client.version_string()?;
    let binary = client.version_binary()?;
    let decoded = FirmwareVersion::from_value_and_string(binary, &text);
    if json {
        let value = json!({
            "version": text,
            "binary": binary,
            "firmware": format!("{}.{:02}", decoded.major, decoded.minor),
            "module": decoded.module,
        });
        writeln!(out, "{value}")?;
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
    client: &mut Client<Box<dyn Transport>>,
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
        return Err(CliError::NoModule(format!(
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
    client: &mut Client<Box<dyn Transport>>,
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
        writeln!(out, "{}", json!({ "address": reply.module, "version": text }))?;
    } else {
        writeln!(out, "{:>3}  {text}", reply.module)?;
    }
    Ok(())
}

/// `tmcl send`: one raw command, with the special cases of the control commands.
fn send(
    client: &mut Client<Box<dyn Transport>>,
    instruction: Instruction,
    json: bool,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    match (instruction.opcode, instruction.kind) {
        (Opcode::GetVersion, 0) => {
            // The raw 136 type 0 reply has no status: the version string is the answer.
            let text = client.version_string()?;
            if json {
                writeln!(out, "{}", json!({ "version": text }))?;
            } else {
                writeln!(out, "{text}")?;
            }
        }
        (Opcode::FactoryDefault | Opcode::Boot | Opcode::SoftwareReset, _) => {
            client.request_no_reply(instruction)?;
            if json {
                writeln!(out, "{}", json!({ "sent": true, "opcode": u8::from(instruction.opcode) }))?;
            } else {
                writeln!(out, "sent (this command gets no reply)")?;
            }
        }
        _ => {
            let reply = client.request(instruction)?;
            if json {
                writeln!(out, "{}", reply_json(&reply))?;
            } else {
                writeln!(out, "status {}, value {}", reply.status, reply.value)?;
            }
        }
    }
    Ok(())
}

/// One reply as a JSON object.
fn reply_json(reply: &Reply) -> serde_json::Value {
    json!({
        "status": u8::from(reply.status),
        "status_text": reply.status.description(),
        "value": reply.value,
        "module": reply.module,
        "opcode": reply.opcode,
    })
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

/// A decimal (optionally negative) or `0x` hexadecimal number.
fn parse_number(text: &str) -> Option<i64> {
    let (negative, digits) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let magnitude = match digits.strip_prefix("0x").or_else(|| digits.strip_prefix("0X")) {
        Some(hex) => i64::from_str_radix(hex, 16).ok()?,
        None if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) => digits.parse().ok()?,
        None => return None,
    };
    Some(if negative { -magnitude } else { magnitude })
}

/// A 32-bit value: -2147483648..=2147483647, or up to 0xFFFFFFFF written in hex or decimal (two's complement,
/// as pytrinamic packs values unsigned).
fn parse_value(text: &str) -> Result<i32, String> {
    let n = parse_number(text).ok_or_else(|| format!("{text:?} is not a number"))?;
    if let Ok(v) = i32::try_from(n) {
        Ok(v)
    } else if let Ok(v) = u32::try_from(n) {
        Ok(v as i32)
    } else {
        Err(format!("{text} does not fit in 32 bits"))
    }
}

/// A byte, decimal or `0x` hexadecimal.
fn parse_byte(text: &str) -> Result<u8, String> {
    let n = parse_number(text).ok_or_else(|| format!("{text:?} is not a number"))?;
    u8::try_from(n).map_err(|_| format!("{text} is out of range 0..255"))
}

/// A positive number of seconds.
fn parse_seconds(text: &str) -> Result<Duration, String> {
    let seconds: f64 = text.parse().map_err(|_| format!("{text:?} is not a number of seconds"))?;
    if seconds.is_finite() && seconds > 0.0 && seconds < 1e9 {
        Ok(Duration::from_secs_f64(seconds))
    } else {
        Err(format!("the timeout must be a positive number of seconds, not {text}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use std::io::Read;
    use std::net::TcpListener;
    use std::thread;
    use tmcl_wire::{Frame, Request, Status, FRAME_LEN};

    /// The shape `main.rs` gives the command line.
    #[derive(Debug, Parser)]
    #[command(name = "tmcl")]
    struct TestCli {
        #[command(flatten)]
        connection: Connection,
        #[command(subcommand)]
        command: HostCommand,
    }

    fn parse(args: &[&str]) -> Result<TestCli, clap::Error> {
        TestCli::try_parse_from(std::iter::once("tmcl").chain(args.iter().copied()))
    }

    #[test]
    fn connection_options_anywhere() {
        let cli = parse(&["get", "ap", "1", "--tcp", "127.0.0.1:2323", "--timeout", "0.5", "--json"]).unwrap();
        assert_eq!(cli.connection.tcp.as_deref(), Some("127.0.0.1:2323"));
        assert_eq!(cli.connection.timeout, Duration::from_millis(500));
        assert!(cli.connection.json);
        let cli = parse(&["--port", "/tmp/link", "--baud", "115200", "--address", "3", "version"]).unwrap();
        assert_eq!(cli.connection.port.as_deref(), Some("/tmp/link"));
        assert_eq!((cli.connection.baud, cli.connection.address), (115_200, Some(3)));
        let cli = parse(&["version"]).unwrap();
        assert_eq!((cli.connection.baud, cli.connection.address), (9600, None));
        assert_eq!(cli.connection.timeout, Duration::from_secs(5));
    }

    #[test]
    fn negative_and_hex_values_parse() {
        let cli = parse(&["set", "ap", "4", "-5000", "--motor", "1"]).unwrap();
        assert!(matches!(cli.command, HostCommand::Set(ParameterValue::Ap { number: 4, value: -5000, motor: 1 })));
        let cli = parse(&["set", "gp", "77", "-1", "2"]).unwrap();
        assert!(matches!(cli.command, HostCommand::Set(ParameterValue::Gp { number: 77, value: -1, bank: 2 })));
        let cli = parse(&["send", "242", "0x81", "0x92", "0xA3B4C5D6"]).unwrap();
        assert!(matches!(cli.command, HostCommand::Send { value, .. } if value == 0xA3B4C5D6u32 as i32));
        let cli = parse(&["send", "MVP", "ABS", "0", "-2147483648"]).unwrap();
        assert!(matches!(cli.command, HostCommand::Send { value: i32::MIN, .. }));
        assert!(parse(&["send", "MVP", "ABS", "0", "4294967296"]).is_err());
        assert!(parse(&["get", "gp", "66"])
            .is_ok_and(|c| matches!(c.command, HostCommand::Get(Parameter::Gp { bank: 0, .. }))));
    }

    #[test]
    fn usage_errors_are_clap_errors() {
        assert!(parse(&["--port", "a", "--tcp", "b", "version"]).is_err());
        assert!(parse(&["--timeout", "0", "version"]).is_err());
        assert!(parse(&["--timeout", "-1", "version"]).is_err());
        assert!(parse(&["get", "ap", "256"]).is_err());
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
        let err = execute(&cli.connection, cli.command, &mut Vec::new()).unwrap_err();
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
        let code = execute(&cli.connection, cli.command, &mut out).map_or_else(|e| e.exit_code(), |()| 0);
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
            json!({"status":100,"status_text":"successfully executed, no error","value":1,"module":1,"opcode":10})
        );
    }

    #[test]
    fn send_prints_status_and_value() {
        let (code, out, requests) =
            run_against(&["send", "MVP", "ABS", "0", "-1000"], vec![reply(Status::Ok, 4, -1000)]);
        assert_eq!((code, out.as_str()), (0, "status 100 (successfully executed, no error), value -1000\n"));
        assert_eq!(requests[0].instruction, Instruction::new(Opcode::Mvp, 0, 0, -1000));
        let (code, out, requests) = run_against(&["send", "137", "0", "0", "1234"], vec![None]);
        assert_eq!((code, out.as_str()), (0, "sent (this command gets no reply)\n"));
        assert_eq!(requests[0].instruction, Instruction::new(Opcode::FactoryDefault, 0, 0, 1234));
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
        assert_eq!(v, json!({"version":"1021V142","binary":0x0A15_012A,"firmware":"1.42","module":1021}));
    }

    #[test]
    fn exit_codes() {
        let (code, out, _) = run_against(&["set", "ap", "4", "99999999"], vec![reply(Status::InvalidValue, 5, 0)]);
        assert_eq!((code, out.as_str()), (EXIT_REPLY, ""));
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

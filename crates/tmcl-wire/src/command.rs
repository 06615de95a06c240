//! The validated command: what the firmware executes (PD28-1021 TMCL manual §3.5, §3.7).
//!
//! [`Command::decode`] checks what the command itself defines: a known opcode (else status 2, "invalid
//! command") and a known type for commands whose type is an enumeration (MVP, RFS, CALC, CALCX, JC, WAIT,
//! CLE, 129, 135, 136, 138; else status 3, "wrong type"), and the key 1234 of commands 137 and 255 (else
//! status 4, "invalid value"). Everything that depends on the module (which commands it has, motor
//! numbers, parameter numbers, ports, value ranges) is checked by the firmware core against the model's
//! tables: `decode` accepts every named opcode, SAC (29) included, and a model without SAC rejects it with
//! its [`CommandSet`](crate::CommandSet).

use crate::instruction::Instruction;
use crate::opcode::Opcode;
use crate::status::Status;

macro_rules! kind_enum {
    ($(#[$m:meta])* $name:ident { $( $(#[$d:meta])* $variant:ident = $code:literal, $word:literal; )* }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum $name { $( $(#[$d])* #[doc = concat!("`", $word, "` = type ", stringify!($code))] $variant, )* }

        impl $name {
            /// Every value, in code order.
            pub const ALL: &'static [$name] = &[$( $name::$variant, )*];

            /// Decodes a type byte.
            pub fn from_code(code: u8) -> Option<$name> {
                match code { $( $code => Some($name::$variant), )* _ => None }
            }

            /// The type byte.
            pub fn code(self) -> u8 {
                match self { $( $name::$variant => $code, )* }
            }

            /// The assembler's symbolic word for this type.
            pub fn word(self) -> &'static str {
                match self { $( $name::$variant => $word, )* }
            }

            /// Looks up a symbolic word, ignoring ASCII case.
            pub fn from_word(word: &str) -> Option<$name> {
                $( if word.eq_ignore_ascii_case($word) { return Some($name::$variant); } )*
                None
            }
        }
    };
}

kind_enum! {
    /// MVP types (§3.7.4).
    MoveKind { Abs = 0, "ABS"; Rel = 1, "REL"; Coord = 2, "COORD"; }
}

kind_enum! {
    /// RFS types (§3.7.13).
    RfsAction {
        /// Start the reference search.
        Start = 0, "START";
        /// Stop the reference search.
        Stop = 1, "STOP";
        /// Query: 0 = no search active.
        Status = 2, "STATUS";
    }
}

kind_enum! {
    /// CALC operations (§3.7.16): the result goes to the accumulator.
    CalcOp {
        Add = 0, "ADD"; Sub = 1, "SUB"; Mul = 2, "MUL"; Div = 3, "DIV"; Mod = 4, "MOD";
        And = 5, "AND"; Or = 6, "OR"; Xor = 7, "XOR"; Not = 8, "NOT"; Load = 9, "LOAD";
    }
}

kind_enum! {
    /// CALCX operations (§3.7.28): accumulator and X register.
    CalcxOp {
        Add = 0, "ADD"; Sub = 1, "SUB"; Mul = 2, "MUL"; Div = 3, "DIV"; Mod = 4, "MOD";
        And = 5, "AND"; Or = 6, "OR"; Xor = 7, "XOR"; Not = 8, "NOT"; Load = 9, "LOAD"; Swap = 10, "SWAP";
    }
}

kind_enum! {
    /// JC conditions (§3.7.18).
    Condition {
        Zero = 0, "ZE"; NotZero = 1, "NZ"; Equal = 2, "EQ"; NotEqual = 3, "NE"; Greater = 4, "GT";
        GreaterOrEqual = 5, "GE"; Lower = 6, "LT"; LowerOrEqual = 7, "LE"; Timeout = 8, "ETO";
        ExternalAlarm = 9, "EAL"; Deviation = 10, "EDV"; PositionError = 11, "EPO";
    }
}

kind_enum! {
    /// WAIT conditions (§3.7.22).
    WaitCondition { Ticks = 0, "TICKS"; Pos = 1, "POS"; RefSw = 2, "REFSW"; LimSw = 3, "LIMSW"; Rfs = 4, "RFS"; }
}

kind_enum! {
    /// CLE flags (§3.7.31).
    ErrorFlag {
        All = 0, "ALL"; Timeout = 1, "ETO"; ExternalAlarm = 2, "EAL"; Deviation = 3, "EDV";
        PositionError = 4, "EPO"; Shutdown = 5, "ESD";
    }
}

kind_enum! {
    /// Command 135 types (§3.7.38).
    StatusKind {
        /// Mode, wait flag, memory pointer.
        MemoryPointer = 0, "POINTER";
        /// Mode, wait flag, program counter.
        ProgramCounter = 1, "PC";
        /// The accumulator.
        Accumulator = 2, "ACC";
        /// The X register.
        XRegister = 3, "X";
    }
}

kind_enum! {
    /// Command 136 types (§3.7.38).
    VersionFormat {
        /// The special 9-byte reply with an 8-character string.
        String = 0, "STRING";
        /// A normal reply with the version in the value.
        Binary = 1, "BINARY";
    }
}

kind_enum! {
    /// Command 138 types (§3.7.37).
    EventMode {
        /// Report only the next MVP.
        Next = 0, "NEXT";
        /// Report every following MVP.
        Every = 1, "EVERY";
    }
}

/// Where an MVP goes (§3.7.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MoveTarget {
    /// MVP ABS: an absolute position.
    Abs(i32),
    /// MVP REL: an offset from the actual position.
    Rel(i32),
    /// MVP COORD: a stored coordinate number.
    Coord(i32),
}

/// The key that commands 137 and 255 need in their value (§3.7.38).
pub const MAGIC_KEY: i32 = 1234;

/// A validated TMCL command. The `motor` and `bank` fields are passed through unchecked: the model decides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[allow(missing_docs)] // the fields are named after the manual's columns
pub enum Command {
    /// ROR: rotate right with a signed velocity (§3.7.1).
    Ror { motor: u8, velocity: i32 },
    /// ROL: rotate left (§3.7.2).
    Rol { motor: u8, velocity: i32 },
    /// MST: stop the motor (§3.7.3).
    Mst { motor: u8 },
    /// MVP ABS/REL/COORD (§3.7.4). For COORD the motor byte is kept as sent.
    Mvp { motor: u8, target: MoveTarget },
    /// SAP (§3.7.5).
    Sap { param: u8, motor: u8, value: i32 },
    /// GAP (§3.7.6).
    Gap { param: u8, motor: u8 },
    /// STAP (§3.7.7).
    Stap { param: u8, motor: u8 },
    /// RSAP (§3.7.8).
    Rsap { param: u8, motor: u8 },
    /// SGP (§3.7.9).
    Sgp { param: u8, bank: u8, value: i32 },
    /// GGP (§3.7.10).
    Ggp { param: u8, bank: u8 },
    /// STGP (§3.7.11).
    Stgp { param: u8, bank: u8 },
    /// RSGP (§3.7.12).
    Rsgp { param: u8, bank: u8 },
    /// RFS START/STOP/STATUS (§3.7.13).
    Rfs { action: RfsAction, motor: u8 },
    /// SIO (§3.7.14).
    Sio { port: u8, bank: u8, value: i32 },
    /// GIO (§3.7.15).
    Gio { port: u8, bank: u8 },
    /// CALC (§3.7.16).
    Calc { op: CalcOp, operand: i32 },
    /// COMP (§3.7.17).
    Comp { operand: i32 },
    /// JC (§3.7.18).
    Jc { condition: Condition, address: i32 },
    /// JA (§3.7.19).
    Ja { address: i32 },
    /// CSUB (§3.7.20).
    Csub { address: i32 },
    /// RSUB (§3.7.21).
    Rsub,
    /// EI (§3.7.32); 255 = global.
    Ei { interrupt: u8 },
    /// DI (§3.7.33); 255 = global.
    Di { interrupt: u8 },
    /// WAIT (§3.7.22).
    Wait { condition: WaitCondition, motor: u8, ticks: i32 },
    /// STOP (§3.7.23).
    Stop,
    /// SAC: access to an external SPI device (PDx-113 manual §5.4.3). That manual names the command but
    /// is cut off before its own section; the operands follow TMCL's `SAC <bus number>, <number of
    /// bytes>, <send data>`: the type byte selects the SPI bus or device, the motor/bank byte the number
    /// of bytes to send, the value the data sent. The reply value is the data received. All fields are
    /// passed through: what is valid depends on the module.
    Sac { bus: u8, bytes: u8, data: i32 },
    /// SCO (§3.7.24); motor 255 = copy to EEPROM.
    Sco { coord: u8, motor: u8, position: i32 },
    /// GCO (§3.7.25); motor 255 = copy from EEPROM.
    Gco { coord: u8, motor: u8 },
    /// CCO (§3.7.26).
    Cco { coord: u8, motor: u8 },
    /// CALCX (§3.7.28).
    Calcx { op: CalcxOp },
    /// AAP (§3.7.29).
    Aap { param: u8, motor: u8 },
    /// AGP (§3.7.30).
    Agp { param: u8, bank: u8 },
    /// CLE (§3.7.31).
    Cle { flag: ErrorFlag },
    /// VECT (§3.7.34).
    Vect { interrupt: u8, address: i32 },
    /// RETI (§3.7.35). The type byte is ignored: the table says `<interrupt number>`, the example prints FF
    /// with a checksum that fits 0.
    Reti,
    /// ACO (§3.7.27).
    Aco { coord: u8, motor: u8 },
    /// UF0–UF7 (§3.7.36): all fields passed through.
    UserFunction { function: u8, kind: u8, motor: u8, value: i32 },
    /// 128: stop application.
    StopApplication,
    /// 129: run application; `None` = from the current address (type 0), `Some(address)` = type 1.
    RunApplication { from: Option<i32> },
    /// 130: step application.
    StepApplication,
    /// 131: reset application.
    ResetApplication,
    /// 132: enter download mode at an address.
    StartDownload { address: i32 },
    /// 133: exit download mode.
    QuitDownload,
    /// 134: read program memory.
    ReadMemory { address: i32 },
    /// 135: get application status.
    GetStatus { kind: StatusKind },
    /// 136: get firmware version.
    GetVersion { format: VersionFormat },
    /// 137: restore factory defaults (value 1234 checked).
    FactoryDefault,
    /// 138: request target-position-reached events for a motor mask (§3.7.37).
    RequestTargetReachedEvent { mode: EventMode, mask: i32 },
    /// 139: enter ASCII mode (§3.4.1).
    EnterAscii,
    /// 242: boot loader request (not supported by the PD28-1021).
    Boot,
    /// 255: software reset (value 1234 checked).
    SoftwareReset,
}

fn kind<T>(decoded: Option<T>) -> Result<T, Status> {
    decoded.ok_or(Status::WrongType)
}

impl Command {
    /// Validates an instruction (see the module docs for what is checked here).
    #[inline]
    pub fn decode(i: Instruction) -> Result<Command, Status> {
        let (t, m, v) = (i.kind, i.motor, i.value);
        Ok(match i.opcode {
            Opcode::Ror => Command::Ror { motor: m, velocity: v },
            Opcode::Rol => Command::Rol { motor: m, velocity: v },
            Opcode::Mst => Command::Mst { motor: m },
            Opcode::Mvp => Command::Mvp {
                motor: m,
                target: match kind(MoveKind::from_code(t))? {
                    MoveKind::Abs => MoveTarget::Abs(v),
                    MoveKind::Rel => MoveTarget::Rel(v),
                    MoveKind::Coord => MoveTarget::Coord(v),
                },
            },
            Opcode::Sap => Command::Sap { param: t, motor: m, value: v },
            Opcode::Gap => Command::Gap { param: t, motor: m },
            Opcode::Stap => Command::Stap { param: t, motor: m },
            Opcode::Rsap => Command::Rsap { param: t, motor: m },
            Opcode::Sgp => Command::Sgp { param: t, bank: m, value: v },
            Opcode::Ggp => Command::Ggp { param: t, bank: m },
            Opcode::Stgp => Command::Stgp { param: t, bank: m },
            Opcode::Rsgp => Command::Rsgp { param: t, bank: m },
            Opcode::Rfs => Command::Rfs { action: kind(RfsAction::from_code(t))?, motor: m },
            Opcode::Sio => Command::Sio { port: t, bank: m, value: v },
            Opcode::Gio => Command::Gio { port: t, bank: m },
            Opcode::Calc => Command::Calc { op: kind(CalcOp::from_code(t))?, operand: v },
            Opcode::Comp => Command::Comp { operand: v },
            Opcode::Jc => Command::Jc { condition: kind(Condition::from_code(t))?, address: v },
            Opcode::Ja => Command::Ja { address: v },
            Opcode::Csub => Command::Csub { address: v },
            Opcode::Rsub => Command::Rsub,
            Opcode::Ei => Command::Ei { interrupt: t },
            Opcode::Di => Command::Di { interrupt: t },
            Opcode::Wait => Command::Wait { condition: kind(WaitCondition::from_code(t))?, motor: m, ticks: v },
            Opcode::Stop => Command::Stop,
            Opcode::Sac => Command::Sac { bus: t, bytes: m, data: v },
            Opcode::Sco => Command::Sco { coord: t, motor: m, position: v },
            Opcode::Gco => Command::Gco { coord: t, motor: m },
            Opcode::Cco => Command::Cco { coord: t, motor: m },
            Opcode::Calcx => Command::Calcx { op: kind(CalcxOp::from_code(t))? },
            Opcode::Aap => Command::Aap { param: t, motor: m },
            Opcode::Agp => Command::Agp { param: t, bank: m },
            Opcode::Cle => Command::Cle { flag: kind(ErrorFlag::from_code(t))? },
            Opcode::Vect => Command::Vect { interrupt: t, address: v },
            Opcode::Reti => Command::Reti,
            Opcode::Aco => Command::Aco { coord: t, motor: m },
            Opcode::UserFunction(function) => Command::UserFunction { function, kind: t, motor: m, value: v },
            Opcode::StopApplication => Command::StopApplication,
            Opcode::RunApplication => match t {
                0 => Command::RunApplication { from: None },
                1 => Command::RunApplication { from: Some(v) },
                _ => return Err(Status::WrongType),
            },
            Opcode::StepApplication => Command::StepApplication,
            Opcode::ResetApplication => Command::ResetApplication,
            Opcode::StartDownload => Command::StartDownload { address: v },
            Opcode::QuitDownload => Command::QuitDownload,
            Opcode::ReadMemory => Command::ReadMemory { address: v },
            Opcode::GetStatus => Command::GetStatus { kind: kind(StatusKind::from_code(t))? },
            Opcode::GetVersion => Command::GetVersion { format: kind(VersionFormat::from_code(t))? },
            Opcode::FactoryDefault if v == MAGIC_KEY => Command::FactoryDefault,
            Opcode::FactoryDefault => return Err(Status::InvalidValue),
            Opcode::RequestTargetReachedEvent => {
                Command::RequestTargetReachedEvent { mode: kind(EventMode::from_code(t))?, mask: v }
            }
            Opcode::EnterAscii => Command::EnterAscii,
            Opcode::Boot => Command::Boot,
            Opcode::SoftwareReset if v == MAGIC_KEY => Command::SoftwareReset,
            Opcode::SoftwareReset => return Err(Status::InvalidValue),
            Opcode::Unknown(_) => return Err(Status::InvalidCommand),
        })
    }

    /// The inverse of [`Command::decode`], for assemblers and hosts. Fields `decode` ignores (the type of
    /// RETI, the motor of CALC) are encoded as 0.
    pub fn encode(&self) -> Instruction {
        use Command as C;
        let i = |op: Opcode, t: u8, m: u8, v: i32| Instruction::new(op, t, m, v);
        match *self {
            C::Ror { motor, velocity } => i(Opcode::Ror, 0, motor, velocity),
            C::Rol { motor, velocity } => i(Opcode::Rol, 0, motor, velocity),
            C::Mst { motor } => i(Opcode::Mst, 0, motor, 0),
            C::Mvp { motor, target } => match target {
                MoveTarget::Abs(v) => i(Opcode::Mvp, 0, motor, v),
                MoveTarget::Rel(v) => i(Opcode::Mvp, 1, motor, v),
                MoveTarget::Coord(v) => i(Opcode::Mvp, 2, motor, v),
            },
            C::Sap { param, motor, value } => i(Opcode::Sap, param, motor, value),
            C::Gap { param, motor } => i(Opcode::Gap, param, motor, 0),
            C::Stap { param, motor } => i(Opcode::Stap, param, motor, 0),
            C::Rsap { param, motor } => i(Opcode::Rsap, param, motor, 0),
            C::Sgp { param, bank, value } => i(Opcode::Sgp, param, bank, value),
            C::Ggp { param, bank } => i(Opcode::Ggp, param, bank, 0),
            C::Stgp { param, bank } => i(Opcode::Stgp, param, bank, 0),
            C::Rsgp { param, bank } => i(Opcode::Rsgp, param, bank, 0),
            C::Rfs { action, motor } => i(Opcode::Rfs, action.code(), motor, 0),
            C::Sio { port, bank, value } => i(Opcode::Sio, port, bank, value),
            C::Gio { port, bank } => i(Opcode::Gio, port, bank, 0),
            C::Calc { op, operand } => i(Opcode::Calc, op.code(), 0, operand),
            C::Comp { operand } => i(Opcode::Comp, 0, 0, operand),
            C::Jc { condition, address } => i(Opcode::Jc, condition.code(), 0, address),
            C::Ja { address } => i(Opcode::Ja, 0, 0, address),
            C::Csub { address } => i(Opcode::Csub, 0, 0, address),
            C::Rsub => i(Opcode::Rsub, 0, 0, 0),
            C::Ei { interrupt } => i(Opcode::Ei, interrupt, 0, 0),
            C::Di { interrupt } => i(Opcode::Di, interrupt, 0, 0),
            C::Wait { condition, motor, ticks } => i(Opcode::Wait, condition.code(), motor, ticks),
            C::Stop => i(Opcode::Stop, 0, 0, 0),
            C::Sac { bus, bytes, data } => i(Opcode::Sac, bus, bytes, data),
            C::Sco { coord, motor, position } => i(Opcode::Sco, coord, motor, position),
            C::Gco { coord, motor } => i(Opcode::Gco, coord, motor, 0),
            C::Cco { coord, motor } => i(Opcode::Cco, coord, motor, 0),
            C::Calcx { op } => i(Opcode::Calcx, op.code(), 0, 0),
            C::Aap { param, motor } => i(Opcode::Aap, param, motor, 0),
            C::Agp { param, bank } => i(Opcode::Agp, param, bank, 0),
            C::Cle { flag } => i(Opcode::Cle, flag.code(), 0, 0),
            C::Vect { interrupt, address } => i(Opcode::Vect, interrupt, 0, address),
            C::Reti => i(Opcode::Reti, 0, 0, 0),
            C::Aco { coord, motor } => i(Opcode::Aco, coord, motor, 0),
            C::UserFunction { function, kind, motor, value } => {
                i(Opcode::UserFunction(function & 7), kind, motor, value)
            }
            C::StopApplication => i(Opcode::StopApplication, 0, 0, 0),
            C::RunApplication { from: None } => i(Opcode::RunApplication, 0, 0, 0),
            C::RunApplication { from: Some(a) } => i(Opcode::RunApplication, 1, 0, a),
            C::StepApplication => i(Opcode::StepApplication, 0, 0, 0),
            C::ResetApplication => i(Opcode::ResetApplication, 0, 0, 0),
            C::StartDownload { address } => i(Opcode::StartDownload, 0, 0, address),
            C::QuitDownload => i(Opcode::QuitDownload, 0, 0, 0),
            C::ReadMemory { address } => i(Opcode::ReadMemory, 0, 0, address),
            C::GetStatus { kind } => i(Opcode::GetStatus, kind.code(), 0, 0),
            C::GetVersion { format } => i(Opcode::GetVersion, format.code(), 0, 0),
            C::FactoryDefault => i(Opcode::FactoryDefault, 0, 0, MAGIC_KEY),
            C::RequestTargetReachedEvent { mode, mask } => i(Opcode::RequestTargetReachedEvent, mode.code(), 0, mask),
            C::EnterAscii => i(Opcode::EnterAscii, 0, 0, 0),
            C::Boot => i(Opcode::Boot, 0x81, 0x92, 0xA3B4C5D6u32 as i32),
            C::SoftwareReset => i(Opcode::SoftwareReset, 0, 0, MAGIC_KEY),
        }
    }

    /// The command's number: the opcode of [`Command::encode`].
    pub const fn opcode(&self) -> Opcode {
        use Command as C;
        match *self {
            C::Ror { .. } => Opcode::Ror,
            C::Rol { .. } => Opcode::Rol,
            C::Mst { .. } => Opcode::Mst,
            C::Mvp { .. } => Opcode::Mvp,
            C::Sap { .. } => Opcode::Sap,
            C::Gap { .. } => Opcode::Gap,
            C::Stap { .. } => Opcode::Stap,
            C::Rsap { .. } => Opcode::Rsap,
            C::Sgp { .. } => Opcode::Sgp,
            C::Ggp { .. } => Opcode::Ggp,
            C::Stgp { .. } => Opcode::Stgp,
            C::Rsgp { .. } => Opcode::Rsgp,
            C::Rfs { .. } => Opcode::Rfs,
            C::Sio { .. } => Opcode::Sio,
            C::Gio { .. } => Opcode::Gio,
            C::Calc { .. } => Opcode::Calc,
            C::Comp { .. } => Opcode::Comp,
            C::Jc { .. } => Opcode::Jc,
            C::Ja { .. } => Opcode::Ja,
            C::Csub { .. } => Opcode::Csub,
            C::Rsub => Opcode::Rsub,
            C::Ei { .. } => Opcode::Ei,
            C::Di { .. } => Opcode::Di,
            C::Wait { .. } => Opcode::Wait,
            C::Stop => Opcode::Stop,
            C::Sac { .. } => Opcode::Sac,
            C::Sco { .. } => Opcode::Sco,
            C::Gco { .. } => Opcode::Gco,
            C::Cco { .. } => Opcode::Cco,
            C::Calcx { .. } => Opcode::Calcx,
            C::Aap { .. } => Opcode::Aap,
            C::Agp { .. } => Opcode::Agp,
            C::Cle { .. } => Opcode::Cle,
            C::Vect { .. } => Opcode::Vect,
            C::Reti => Opcode::Reti,
            C::Aco { .. } => Opcode::Aco,
            C::UserFunction { function, .. } => Opcode::UserFunction(function & 7),
            C::StopApplication => Opcode::StopApplication,
            C::RunApplication { .. } => Opcode::RunApplication,
            C::StepApplication => Opcode::StepApplication,
            C::ResetApplication => Opcode::ResetApplication,
            C::StartDownload { .. } => Opcode::StartDownload,
            C::QuitDownload => Opcode::QuitDownload,
            C::ReadMemory { .. } => Opcode::ReadMemory,
            C::GetStatus { .. } => Opcode::GetStatus,
            C::GetVersion { .. } => Opcode::GetVersion,
            C::FactoryDefault => Opcode::FactoryDefault,
            C::RequestTargetReachedEvent { .. } => Opcode::RequestTargetReachedEvent,
            C::EnterAscii => Opcode::EnterAscii,
            C::Boot => Opcode::Boot,
            C::SoftwareReset => Opcode::SoftwareReset,
        }
    }

    /// Whether the command, run in a program, loads the accumulator with what it reads (PD28-1021 manual
    /// §3.6.5: "all TMCL commands that read a value store the result in the accumulator" in standalone
    /// mode): the opcodes whose [`OpcodeInfo::reads_value`](crate::OpcodeInfo::reads_value) is set (GAP,
    /// GGP, GIO, GCO, SAC), and RFS with type STATUS only (PD28-1021 manual §12.1, firmware V1.35: "RFS
    /// STATUS command also copies its result to the accumulator register").
    pub const fn reads_value(&self) -> bool {
        match self {
            Command::Rfs { action, .. } => matches!(action, RfsAction::Status),
            other => match other.opcode().info() {
                Some(info) => info.reads_value,
                None => false,
            },
        }
    }
}

#[cfg(test)]
mod tests;

//! Command numbers and their properties. One table, the `opcodes!` invocation below, lists every TMCL
//! command with its number, mnemonic, where it may run, whether it reads a value, whether it always
//! replies, whether it only reads, whether ASCII mode takes it, and the manual section that defines it.
//! [`Opcode::info`] reads the table; [`Opcode::is_control`],
//! [`Command::reads_value`](crate::Command::reads_value), [`ascii_allowed`](crate::ascii::ascii_allowed)
//! and [`CommandSet::ascii_subset`](crate::CommandSet::ascii_subset) are built on it, so each property is
//! written down once.
//!
//! Sources: PD28-1021 TMCL manual §3.5 Table 5 "Overview of all TMCL commands", §3.4 (the ASCII list),
//! §3.6 (commands by subject), §3.7.36 UF0–UF7, §3.7.37 command 138, §3.7.38 Table 13 "TMCL control
//! commands", §3.4.1 command 139, §5.1 Table 17 (global parameter 255); PDx-113 manual §5.4.3 and §5.6.3
//! (SAC).

use core::fmt;

/// Where a command may run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Availability {
    /// Direct mode only: the control commands (PD28-1021 manual §3.7.38: "can only be used in direct mode
    /// and not in a standalone program"), 138 (§3.7.37), 139 (§3.4.1) and 242. Download mode executes
    /// them instead of storing them (§3.7.38 command 132).
    Direct,
    /// Standalone programs only: the branch commands (PD28-1021 manual §3.6.3: "intended for standalone
    /// mode only") and the interrupt vector commands VECT and RETI (§3.6.6, §3.7.34, §3.7.35).
    Program,
    /// Direct mode and programs.
    Both,
}

impl Availability {
    /// Whether a host may send the command in direct mode.
    #[inline]
    pub const fn in_direct_mode(self) -> bool {
        !matches!(self, Availability::Program)
    }

    /// Whether the command may sit in a stored program.
    #[inline]
    pub const fn in_program(self) -> bool {
        !matches!(self, Availability::Direct)
    }
}

/// The properties of one command, from the table in this module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct OpcodeInfo {
    /// Where the command may run.
    pub availability: Availability,
    /// Whether the command reads a value, which in a program it loads into the accumulator (PD28-1021
    /// manual §3.6.5: "all TMCL commands that read a value store the result in the accumulator"): GAP,
    /// GGP, GIO, GCO, RFS and SAC. RFS reads only with type STATUS, which
    /// [`Command::reads_value`](crate::Command::reads_value) checks.
    pub reads_value: bool,
    /// Whether the command replies even when global parameter 255 suppresses replies (PD28-1021 manual
    /// §5.1 Table 17, GP 255: "The reply will not be suppressed for GAP, GGP and GIO commands").
    pub always_replies: bool,
    /// Whether the command only reports state: it changes no parameter, output, motion or program state.
    /// GAP, GGP, GIO, GCO and the control commands 134, 135 and 136 (PD28-1021 manual §3.7.6, §3.7.10,
    /// §3.7.15, §3.7.25, §3.7.38). Effects of reading that stay inside the firmware, with nothing for the
    /// motor driver or the outputs, do not count: reading axis parameter 207 clears the error flags it
    /// reports (PD28-1021 manual §4 Table 15), and GCO with motor 255 reloads a coordinate from the EEPROM.
    pub read_only: bool,
    /// Whether the command may be entered in ASCII mode: the PD28-1021 manual §3.4 list (ROL, ROR, MST,
    /// MVP, SAP, GAP, STAP, RSAP, SGP, GGP, STGP, RSGP, RFS, SIO, GIO, SCO, GCO, CCO, UF0..UF7) plus SAC
    /// (PDx-113 manual §5.6.3).
    pub ascii: bool,
    /// Where a manual defines the command, e.g. `"PD28-1021 §3.7.1"`.
    pub section: &'static str,
}

/// The property columns of the table: bit flags, or-ed together.
const NONE: u8 = 0;
/// [`OpcodeInfo::reads_value`].
const READS: u8 = 1;
/// [`OpcodeInfo::always_replies`].
const REPLIES: u8 = 2;
/// [`OpcodeInfo::ascii`].
const ASCII: u8 = 4;
/// [`OpcodeInfo::read_only`].
const READ_ONLY: u8 = 8;

impl OpcodeInfo {
    const fn new(availability: Availability, properties: u8, section: &'static str) -> OpcodeInfo {
        OpcodeInfo {
            availability,
            reads_value: properties & READS != 0,
            always_replies: properties & REPLIES != 0,
            read_only: properties & READ_ONLY != 0,
            ascii: properties & ASCII != 0,
            section,
        }
    }
}

macro_rules! opcodes {
    // The table as written: rows in number order, UF0–UF7 in their place. Passes the rows on as one list,
    // and the variants in number order for `Opcode::ALL`.
    (
        $( $(#[$ldoc:meta])* $lvariant:ident = $lcode:literal, $lmnemonic:literal, $lavailability:ident,
            $lproperties:expr, $lsection:literal; )*
        64..=71 => UserFunction, $uf_availability:ident, $uf_properties:expr, $uf_section:literal;
        $( $(#[$hdoc:meta])* $hvariant:ident = $hcode:literal, $hmnemonic:literal, $havailability:ident,
            $hproperties:expr, $hsection:literal; )*
    ) => {
        opcodes! {
            @rows [
                $( $(#[$ldoc])* $lvariant = $lcode, $lmnemonic, $lavailability, $lproperties, $lsection; )*
                $( $(#[$hdoc])* $hvariant = $hcode, $hmnemonic, $havailability, $hproperties, $hsection; )*
            ]
            @user_functions [$uf_availability, $uf_properties, $uf_section]
            @all [$( $lvariant )*] [$( $hvariant )*]
        }
    };
    (
        @rows [ $( $(#[$doc:meta])* $variant:ident = $code:literal, $mnemonic:literal, $availability:ident,
            $properties:expr, $section:literal; )* ]
        @user_functions [$uf_availability:ident, $uf_properties:expr, $uf_section:literal]
        @all [$( $low:ident )*] [$( $high:ident )*]
    ) => {
        /// A TMCL command number. Numbers that name no command are kept as [`Opcode::Unknown`], so that
        /// traces, the disassembler and "invalid command" replies keep the original byte.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Opcode {
            $(
                $(#[$doc])*
                #[doc = ""]
                #[doc = concat!("Command number ", stringify!($code), " (", $section, ").")]
                $variant,
            )*
            /// UF0–UF7: user functions 64..=71; the field holds 0..=7.
            #[doc = ""]
            #[doc = concat!("Command numbers 64..=71 (", $uf_section, ").")]
            UserFunction(u8),
            /// Any other number.
            Unknown(u8),
        }

        impl From<u8> for Opcode {
            #[inline]
            fn from(code: u8) -> Opcode {
                Opcode::from_code(code)
            }
        }

        impl Opcode {
            /// The opcode of a command number: `Opcode::from(code)`, usable in constants.
            #[inline(always)]
            pub const fn from_code(code: u8) -> Opcode {
                match code {
                    $( $code => Opcode::$variant, )*
                    64..=71 => Opcode::UserFunction(code - 64),
                    other => Opcode::Unknown(other),
                }
            }

            /// The command number: `u8::from(self)`, usable in constants.
            #[inline]
            pub const fn code(self) -> u8 {
                match self {
                    $( Opcode::$variant => $code, )*
                    Opcode::UserFunction(n) => 64 + (n & 7),
                    Opcode::Unknown(code) => code,
                }
            }

            /// The command's properties, or `None` for an unknown number.
            #[inline]
            pub const fn info(self) -> Option<OpcodeInfo> {
                Some(match self {
                    $( Opcode::$variant =>
                        OpcodeInfo::new(Availability::$availability, $properties, $section), )*
                    Opcode::UserFunction(_) =>
                        OpcodeInfo::new(Availability::$uf_availability, $uf_properties, $uf_section),
                    Opcode::Unknown(_) => return None,
                })
            }

            /// The assembler mnemonic, or `None` for commands that have none (control commands, unknown
            /// numbers). UF0–UF7 are spelled by its `Display` implementation.
            pub fn mnemonic(self) -> Option<&'static str> {
                match self {
                    $( Opcode::$variant => if $mnemonic.is_empty() { None } else { Some($mnemonic) }, )*
                    Opcode::UserFunction(_) | Opcode::Unknown(_) => None,
                }
            }

            /// Looks a mnemonic up, ignoring ASCII case (`"mvp"`, `"UF3"`).
            pub fn from_mnemonic(word: &str) -> Option<Opcode> {
                $( if !$mnemonic.is_empty() && word.eq_ignore_ascii_case($mnemonic) {
                    return Some(Opcode::$variant);
                } )*
                let bytes = word.as_bytes();
                if bytes.len() == 3 && bytes[..2].eq_ignore_ascii_case(b"UF") && (b'0'..=b'7').contains(&bytes[2]) {
                    return Some(Opcode::UserFunction(bytes[2] - b'0'));
                }
                None
            }

            /// Every named opcode, in number order (UF0–UF7 included).
            pub const ALL: &'static [Opcode] = &[
                $( Opcode::$low, )*
                Opcode::UserFunction(0), Opcode::UserFunction(1), Opcode::UserFunction(2), Opcode::UserFunction(3),
                Opcode::UserFunction(4), Opcode::UserFunction(5), Opcode::UserFunction(6), Opcode::UserFunction(7),
                $( Opcode::$high, )*
            ];
        }
    };
}

// The table. Each row: variant = number, mnemonic ("" for none), availability, properties (READS,
// REPLIES, READ_ONLY, ASCII, or NONE), section. Rows in number order, so that `Opcode::ALL` is too;
// UF0–UF7 have a row of their own shape.
opcodes! {
    /// ROR: rotate right.
    Ror = 1, "ROR", Both, ASCII, "PD28-1021 §3.7.1";
    /// ROL: rotate left.
    Rol = 2, "ROL", Both, ASCII, "PD28-1021 §3.7.2";
    /// MST: motor stop.
    Mst = 3, "MST", Both, ASCII, "PD28-1021 §3.7.3";
    /// MVP: move to position.
    Mvp = 4, "MVP", Both, ASCII, "PD28-1021 §3.7.4";
    /// SAP: set axis parameter.
    Sap = 5, "SAP", Both, ASCII, "PD28-1021 §3.7.5";
    /// GAP: get axis parameter.
    Gap = 6, "GAP", Both, READS | REPLIES | READ_ONLY | ASCII, "PD28-1021 §3.7.6";
    /// STAP: store axis parameter.
    Stap = 7, "STAP", Both, ASCII, "PD28-1021 §3.7.7";
    /// RSAP: restore axis parameter.
    Rsap = 8, "RSAP", Both, ASCII, "PD28-1021 §3.7.8";
    /// SGP: set global parameter.
    Sgp = 9, "SGP", Both, ASCII, "PD28-1021 §3.7.9";
    /// GGP: get global parameter.
    Ggp = 10, "GGP", Both, READS | REPLIES | READ_ONLY | ASCII, "PD28-1021 §3.7.10";
    /// STGP: store global parameter.
    Stgp = 11, "STGP", Both, ASCII, "PD28-1021 §3.7.11";
    /// RSGP: restore global parameter.
    Rsgp = 12, "RSGP", Both, ASCII, "PD28-1021 §3.7.12";
    /// RFS: reference search. Reads a value with type STATUS only.
    Rfs = 13, "RFS", Both, READS | ASCII, "PD28-1021 §3.7.13";
    /// SIO: set output.
    Sio = 14, "SIO", Both, ASCII, "PD28-1021 §3.7.14";
    /// GIO: get input/output.
    Gio = 15, "GIO", Both, READS | REPLIES | READ_ONLY | ASCII, "PD28-1021 §3.7.15";
    /// CALC: calculate.
    Calc = 19, "CALC", Both, NONE, "PD28-1021 §3.7.16";
    /// COMP: compare.
    Comp = 20, "COMP", Program, NONE, "PD28-1021 §3.7.17";
    /// JC: jump conditional.
    Jc = 21, "JC", Program, NONE, "PD28-1021 §3.7.18";
    /// JA: jump always.
    Ja = 22, "JA", Program, NONE, "PD28-1021 §3.7.19";
    /// CSUB: call subroutine.
    Csub = 23, "CSUB", Program, NONE, "PD28-1021 §3.7.20";
    /// RSUB: return from subroutine.
    Rsub = 24, "RSUB", Program, NONE, "PD28-1021 §3.7.21";
    /// EI: enable interrupt.
    Ei = 25, "EI", Both, NONE, "PD28-1021 §3.7.32";
    /// DI: disable interrupt.
    Di = 26, "DI", Both, NONE, "PD28-1021 §3.7.33";
    /// WAIT: wait for an event.
    Wait = 27, "WAIT", Program, NONE, "PD28-1021 §3.7.22";
    /// STOP: stop program execution.
    Stop = 28, "STOP", Program, NONE, "PD28-1021 §3.7.23";
    /// SAC: access to an external SPI device. Only the PDx-113 manual lists it, and only in its overview
    /// (the manual is cut off before the command's own section); the reply value is the data received.
    Sac = 29, "SAC", Both, READS | ASCII, "PDx-113 §5.4.3";
    /// SCO: set coordinate.
    Sco = 30, "SCO", Both, ASCII, "PD28-1021 §3.7.24";
    /// GCO: get coordinate.
    Gco = 31, "GCO", Both, READS | READ_ONLY | ASCII, "PD28-1021 §3.7.25";
    /// CCO: capture coordinate.
    Cco = 32, "CCO", Both, ASCII, "PD28-1021 §3.7.26";
    /// CALCX: calculate using the X register.
    Calcx = 33, "CALCX", Both, NONE, "PD28-1021 §3.7.28";
    /// AAP: accumulator to axis parameter.
    Aap = 34, "AAP", Both, NONE, "PD28-1021 §3.7.29";
    /// AGP: accumulator to global parameter.
    Agp = 35, "AGP", Both, NONE, "PD28-1021 §3.7.30";
    /// CLE: clear error flags.
    Cle = 36, "CLE", Both, NONE, "PD28-1021 §3.7.31";
    /// VECT: set interrupt vector.
    Vect = 37, "VECT", Program, NONE, "PD28-1021 §3.7.34";
    /// RETI: return from interrupt.
    Reti = 38, "RETI", Program, NONE, "PD28-1021 §3.7.35";
    /// ACO: accumulator to coordinate.
    Aco = 39, "ACO", Both, NONE, "PD28-1021 §3.7.27";
    // UF0–UF7: user functions, `Opcode::UserFunction(0..=7)`.
    64..=71 => UserFunction, Both, ASCII, "PD28-1021 §3.7.36";
    /// Stop application.
    StopApplication = 128, "", Direct, NONE, "PD28-1021 §3.7.38";
    /// Run application.
    RunApplication = 129, "", Direct, NONE, "PD28-1021 §3.7.38";
    /// Step application.
    StepApplication = 130, "", Direct, NONE, "PD28-1021 §3.7.38";
    /// Reset application.
    ResetApplication = 131, "", Direct, NONE, "PD28-1021 §3.7.38";
    /// Enter download mode.
    StartDownload = 132, "", Direct, NONE, "PD28-1021 §3.7.38";
    /// Exit download mode.
    QuitDownload = 133, "", Direct, NONE, "PD28-1021 §3.7.38";
    /// Read TMCL program memory.
    ReadMemory = 134, "", Direct, READ_ONLY, "PD28-1021 §3.7.38";
    /// Get application status.
    GetStatus = 135, "", Direct, READ_ONLY, "PD28-1021 §3.7.38";
    /// Get firmware version.
    GetVersion = 136, "", Direct, READ_ONLY, "PD28-1021 §3.7.38";
    /// Restore factory defaults.
    FactoryDefault = 137, "", Direct, NONE, "PD28-1021 §3.7.38";
    /// Request the target-position-reached event ("can only be used in direct mode").
    RequestTargetReachedEvent = 138, "", Direct, NONE, "PD28-1021 §3.7.37";
    /// Enter ASCII mode (a binary command).
    EnterAscii = 139, "", Direct, NONE, "PD28-1021 §3.4.1";
    /// Enter the boot loader. In none of the manuals; pytrinamic's `send_boot` sends it.
    Boot = 242, "", Direct, NONE, "no manual; pytrinamic send_boot";
    /// Software reset.
    SoftwareReset = 255, "", Direct, NONE, "PD28-1021 §3.7.38";
}

impl From<Opcode> for u8 {
    #[inline]
    fn from(opcode: Opcode) -> u8 {
        opcode.code()
    }
}

impl Opcode {
    /// Whether this is a control command, which runs in direct mode only and which download mode executes
    /// rather than stores (PD28-1021 manual §3.7.38): every opcode the table marks
    /// [`Availability::Direct`] (128..=139, 242, 255), and any unknown number from 128 up, the range the
    /// manual gives control commands, so that a download never stores one.
    #[inline]
    pub const fn is_control(self) -> bool {
        match self.info() {
            Some(info) => matches!(info.availability, Availability::Direct),
            None => self.code() >= 128,
        }
    }
}

impl fmt::Display for Opcode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.mnemonic(), self) {
            (Some(m), _) => f.write_str(m),
            (None, Opcode::UserFunction(n)) => write!(f, "UF{n}"),
            (None, other) => write!(f, "{}", u8::from(*other)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_roundtrips() {
        for code in 0..=255u8 {
            assert_eq!(u8::from(Opcode::from(code)), code);
            assert_eq!(Opcode::from(code).code(), code);
        }
    }

    #[test]
    fn mnemonics_roundtrip() {
        for &op in Opcode::ALL {
            if let Some(m) = op.mnemonic() {
                assert_eq!(Opcode::from_mnemonic(m), Some(op));
            }
        }
        assert_eq!(Opcode::from_mnemonic("uf7"), Some(Opcode::UserFunction(7)));
        assert_eq!(Opcode::from_mnemonic("UF8"), None);
        assert_eq!(Opcode::from_mnemonic("mvp"), Some(Opcode::Mvp));
        assert_eq!(Opcode::from_mnemonic("sac"), Some(Opcode::Sac));
    }

    #[test]
    fn table_5_numbers() {
        assert_eq!(u8::from(Opcode::Aco), 39);
        assert_eq!(u8::from(Opcode::UserFunction(0)), 64);
        assert_eq!(Opcode::from(16), Opcode::Unknown(16));
        // 29 is SAC (PDx-113 manual §5.4.3); the PD28-1021's Table 5 skips it.
        assert_eq!(Opcode::from(29), Opcode::Sac);
        // 35 mnemonic commands of PD28-1021 Table 5, SAC (PDx-113 only: the count was 35 + 14 + 8 before SAC
        // was added), UF0..UF7 and 14 control commands (incl. 138, 139, 242, 255).
        assert_eq!(Opcode::ALL.len(), 35 + 1 + 14 + 8);
        assert!(Opcode::ALL.windows(2).all(|w| w[0].code() < w[1].code()), "ALL is in number order");
    }

    /// Every opcode with these properties, by number.
    fn codes_where(f: impl Fn(OpcodeInfo) -> bool) -> std::vec::Vec<u8> {
        (0..=255u8).filter(|&c| Opcode::from(c).info().is_some_and(&f)).collect()
    }

    #[test]
    fn table_names_every_opcode_and_nothing_else() {
        for code in 0..=255u8 {
            let op = Opcode::from(code);
            assert_eq!(op.info().is_some(), !matches!(op, Opcode::Unknown(_)), "{code}");
            assert_eq!(Opcode::ALL.contains(&op), op.info().is_some(), "{code}");
        }
        for &op in Opcode::ALL {
            let section = op.info().unwrap().section;
            assert!(section.starts_with("PD28-1021 §3.") || section.starts_with("PDx-113 §5.") || op == Opcode::Boot);
        }
    }

    #[test]
    fn availability_column() {
        // PD28-1021 §3.7.38 Table 13, §3.7.37 (138), §3.4.1 (139), and 242.
        let direct: std::vec::Vec<u8> = (128..=139).chain([242, 255]).collect();
        assert_eq!(codes_where(|i| i.availability == Availability::Direct), direct);
        // §3.6.3 branch commands and the interrupt vector commands VECT, RETI.
        assert_eq!(codes_where(|i| i.availability == Availability::Program), [20, 21, 22, 23, 24, 27, 28, 37, 38]);
        assert!(Availability::Both.in_direct_mode() && Availability::Both.in_program());
        assert!(!Availability::Direct.in_program() && !Availability::Program.in_direct_mode());
    }

    #[test]
    fn is_control_is_unchanged() {
        // Before the table, `is_control` was `code >= 128`; unknown numbers from 128 up still count.
        for code in 0..=255u8 {
            assert_eq!(Opcode::from(code).is_control(), code >= 128, "{code}");
        }
    }

    #[test]
    fn property_columns() {
        // §3.6.5 (commands that read a value), with SAC's reply value.
        assert_eq!(codes_where(|i| i.reads_value), [6, 10, 13, 15, 29, 31]);
        // §5.1 Table 17, GP 255.
        assert_eq!(codes_where(|i| i.always_replies), [6, 10, 15]);
        assert_eq!(codes_where(|i| i.read_only), [6, 10, 15, 31, 134, 135, 136]);
        // §3.4 list plus SAC (PDx-113 §5.6.3).
        let ascii: std::vec::Vec<u8> = (1..=15).chain([29, 30, 31, 32]).chain(64..=71).collect();
        assert_eq!(codes_where(|i| i.ascii), ascii);
    }

    #[test]
    fn usable_in_constants() {
        const SAC: u8 = Opcode::Sac.code();
        const GAP_REPLIES: bool = match Opcode::Gap.info() {
            Some(info) => info.always_replies,
            None => false,
        };
        assert_eq!(SAC, 29);
        const { assert!(GAP_REPLIES) };
        assert_eq!(Opcode::Unknown(29).info(), None);
        assert_eq!(Opcode::Mvp.info().map(|i| i.section), Some("PD28-1021 §3.7.4"));
    }
}

//! Command numbers (PD28-1021 TMCL manual §3.5 Table 5 "Overview of all TMCL commands", §3.7.37 UF0–UF7,
//! §3.7.38 Table 13 "TMCL control commands", §3.4.1 command 139).

use core::fmt;

macro_rules! opcodes {
    ($( $(#[$doc:meta])* $variant:ident = $code:literal, $mnemonic:literal; )*) => {
        /// A TMCL command number. Numbers that name no command are kept as [`Opcode::Unknown`], so that
        /// traces, the disassembler and "invalid command" replies keep the original byte.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Opcode {
            $( $(#[$doc])* $variant, )*
            /// UF0–UF7: user functions 64..=71 (§3.7.37); the field holds 0..=7.
            UserFunction(u8),
            /// Any other number.
            Unknown(u8),
        }

        impl From<u8> for Opcode {
            #[inline]
            fn from(code: u8) -> Opcode {
                match code {
                    $( $code => Opcode::$variant, )*
                    64..=71 => Opcode::UserFunction(code - 64),
                    other => Opcode::Unknown(other),
                }
            }
        }

        impl From<Opcode> for u8 {
            #[inline]
            fn from(opcode: Opcode) -> u8 {
                match opcode {
                    $( Opcode::$variant => $code, )*
                    Opcode::UserFunction(n) => 64 + (n & 7),
                    Opcode::Unknown(code) => code,
                }
            }
        }

        impl Opcode {
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
                $( Opcode::$variant, )*
                Opcode::UserFunction(0), Opcode::UserFunction(1), Opcode::UserFunction(2), Opcode::UserFunction(3),
                Opcode::UserFunction(4), Opcode::UserFunction(5), Opcode::UserFunction(6), Opcode::UserFunction(7),
            ];
        }
    };
}

opcodes! {
    /// 1 ROR: rotate right (§3.7.1).
    Ror = 1, "ROR";
    /// 2 ROL: rotate left (§3.7.2).
    Rol = 2, "ROL";
    /// 3 MST: motor stop (§3.7.3).
    Mst = 3, "MST";
    /// 4 MVP: move to position (§3.7.4).
    Mvp = 4, "MVP";
    /// 5 SAP: set axis parameter (§3.7.5).
    Sap = 5, "SAP";
    /// 6 GAP: get axis parameter (§3.7.6).
    Gap = 6, "GAP";
    /// 7 STAP: store axis parameter (§3.7.7).
    Stap = 7, "STAP";
    /// 8 RSAP: restore axis parameter (§3.7.8).
    Rsap = 8, "RSAP";
    /// 9 SGP: set global parameter (§3.7.9).
    Sgp = 9, "SGP";
    /// 10 GGP: get global parameter (§3.7.10).
    Ggp = 10, "GGP";
    /// 11 STGP: store global parameter (§3.7.11).
    Stgp = 11, "STGP";
    /// 12 RSGP: restore global parameter (§3.7.12).
    Rsgp = 12, "RSGP";
    /// 13 RFS: reference search (§3.7.13).
    Rfs = 13, "RFS";
    /// 14 SIO: set output (§3.7.14).
    Sio = 14, "SIO";
    /// 15 GIO: get input/output (§3.7.15).
    Gio = 15, "GIO";
    /// 19 CALC: calculate (§3.7.16).
    Calc = 19, "CALC";
    /// 20 COMP: compare (§3.7.17).
    Comp = 20, "COMP";
    /// 21 JC: jump conditional (§3.7.18).
    Jc = 21, "JC";
    /// 22 JA: jump always (§3.7.19).
    Ja = 22, "JA";
    /// 23 CSUB: call subroutine (§3.7.20).
    Csub = 23, "CSUB";
    /// 24 RSUB: return from subroutine (§3.7.21).
    Rsub = 24, "RSUB";
    /// 25 EI: enable interrupt (§3.7.32).
    Ei = 25, "EI";
    /// 26 DI: disable interrupt (§3.7.33).
    Di = 26, "DI";
    /// 27 WAIT: wait for an event (§3.7.22).
    Wait = 27, "WAIT";
    /// 28 STOP: stop program execution (§3.7.23).
    Stop = 28, "STOP";
    /// 30 SCO: set coordinate (§3.7.24).
    Sco = 30, "SCO";
    /// 31 GCO: get coordinate (§3.7.25).
    Gco = 31, "GCO";
    /// 32 CCO: capture coordinate (§3.7.26).
    Cco = 32, "CCO";
    /// 33 CALCX: calculate using the X register (§3.7.28).
    Calcx = 33, "CALCX";
    /// 34 AAP: accumulator to axis parameter (§3.7.29).
    Aap = 34, "AAP";
    /// 35 AGP: accumulator to global parameter (§3.7.30).
    Agp = 35, "AGP";
    /// 36 CLE: clear error flags (§3.7.31).
    Cle = 36, "CLE";
    /// 37 VECT: set interrupt vector (§3.7.34).
    Vect = 37, "VECT";
    /// 38 RETI: return from interrupt (§3.7.35).
    Reti = 38, "RETI";
    /// 39 ACO: accumulator to coordinate (§3.7.27).
    Aco = 39, "ACO";
    /// 128: stop application (§3.7.38).
    StopApplication = 128, "";
    /// 129: run application (§3.7.38).
    RunApplication = 129, "";
    /// 130: step application (§3.7.38).
    StepApplication = 130, "";
    /// 131: reset application (§3.7.38).
    ResetApplication = 131, "";
    /// 132: enter download mode (§3.7.38).
    StartDownload = 132, "";
    /// 133: exit download mode (§3.7.38).
    QuitDownload = 133, "";
    /// 134: read TMCL program memory (§3.7.38).
    ReadMemory = 134, "";
    /// 135: get application status (§3.7.38).
    GetStatus = 135, "";
    /// 136: get firmware version (§3.7.38).
    GetVersion = 136, "";
    /// 137: restore factory defaults (§3.7.38).
    FactoryDefault = 137, "";
    /// 138: request the target-position-reached event (§3.7.39).
    RequestTargetReachedEvent = 138, "";
    /// 139: enter ASCII mode (§3.4.1).
    EnterAscii = 139, "";
    /// 242: enter the boot loader. Not a PD28-1021 command; pytrinamic's `send_boot` sends it.
    Boot = 242, "";
    /// 255: software reset (§3.7.38).
    SoftwareReset = 255, "";
}

impl Opcode {
    /// Control commands (128..=139, 242, 255) are direct-mode only and are never stored in download mode
    /// (§3.6.5, §3.7.38).
    pub fn is_control(self) -> bool {
        u8::from(self) >= 128
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
    }

    #[test]
    fn table_5_numbers() {
        assert_eq!(u8::from(Opcode::Aco), 39);
        assert_eq!(u8::from(Opcode::UserFunction(0)), 64);
        assert_eq!(Opcode::from(16), Opcode::Unknown(16));
        assert_eq!(Opcode::from(29), Opcode::Unknown(29));
        // 35 mnemonic commands + UF0..UF7 + 14 control commands (incl. 139, 242, 255).
        assert_eq!(Opcode::ALL.len(), 35 + 14 + 8);
    }
}

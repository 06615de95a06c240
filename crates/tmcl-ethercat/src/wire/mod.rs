//! The byte formats an EtherCAT slave sees, as views over untrusted buffers and reprs (STYLE.md §3.2).
//!
//! - [`ethernet`]: the Ethernet II header that carries EtherCAT (EtherType 0x88A4).
//! - [`frame`]: the EtherCAT frame header and the walk over the datagrams behind it.
//! - [`datagram`]: one datagram (ETG.1000.4 "EtherCAT PDU"): command, index, address, length, IRQ, data,
//!   working counter.
//! - [`mailbox`]: the standard mailbox header (ETG.1000.4 "Mailbox"), used here only in BOOT.
//! - [`foe`]: File access over EtherCAT (ETG.1000.6 "FoE").
//! - [`sii`]: the Slave Information Interface EEPROM: its fixed words and its categories.
//!
//! # The contract
//!
//! Every view has `new_unchecked` (accessors may panic if the buffer is too short), `new_checked` and
//! `check_len`: once `check_len` passed, **no accessor or setter panics**, whatever the bytes say. Reprs
//! parse from a checked view and emit into a buffer of at least `buffer_len()` bytes. Codes a format
//! defines map to enums that end in `Unknown(..)`, so an unknown command or category keeps its number.
//! Nothing here knows about motors, registers or time.

pub mod datagram;
pub mod ethernet;
pub mod foe;
pub mod frame;
pub mod mailbox;
pub mod sii;

use core::fmt;

/// What is wrong with bytes that should hold a wire format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// The buffer is shorter than the format (or a length field in it) needs.
    Truncated,
    /// A field holds a value the format does not allow.
    Malformed,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Truncated => f.write_str("buffer too short for the format"),
            Error::Malformed => f.write_str("a field holds a value the format does not allow"),
        }
    }
}

impl core::error::Error for Error {}

/// An enum over a code of a wire format whose last variant keeps any code it does not name (as smoltcp's
/// `enum_with_unknown!`): `From` both ways, so a parsed code always emits back to the same number.
macro_rules! enum_with_unknown {
    (
        $(#[$meta:meta])*
        pub enum $name:ident($ty:ty) {
            $( $(#[$vmeta:meta])* $variant:ident = $value:expr ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum $name {
            $( $(#[$vmeta])* $variant, )+
            /// A code this crate does not name, kept as it was.
            Unknown($ty),
        }

        impl From<$ty> for $name {
            fn from(value: $ty) -> Self {
                match value {
                    $( $value => $name::$variant, )+
                    other => $name::Unknown(other),
                }
            }
        }

        impl From<$name> for $ty {
            fn from(value: $name) -> Self {
                match value {
                    $( $name::$variant => $value, )+
                    $name::Unknown(other) => other,
                }
            }
        }
    };
}
pub(crate) use enum_with_unknown;

/// Little-endian helpers on checked slices (callers guarantee the length).
pub(crate) mod le {
    #[inline]
    pub fn u16(b: &[u8], at: usize) -> u16 {
        u16::from_le_bytes([b[at], b[at + 1]])
    }

    #[inline]
    pub fn u32(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
    }

    #[inline]
    pub fn set_u16(b: &mut [u8], at: usize, v: u16) {
        b[at..at + 2].copy_from_slice(&v.to_le_bytes());
    }

    #[inline]
    pub fn set_u32(b: &mut [u8], at: usize, v: u32) {
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
}

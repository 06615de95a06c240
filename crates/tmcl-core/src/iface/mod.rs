//! Host interfaces: the byte-fed binary framer, the ASCII command line, and the reply outbox — one set per
//! host interface of the model ([`Port`]), so that a module serves several interfaces at once and answers
//! each on its own.

pub mod ascii;
pub mod binary;

pub use binary::{Framer, Outbox, Sink, INTER_BYTE_TIMEOUT};

/// Host links on the first interface: 1, or with the feature `host-links` 4 (see [`crate::Module::link_port`]).
pub const HOST_LINKS: usize = if cfg!(feature = "host-links") { 4 } else { 1 };

/// Ports a module keeps: one per interface of the largest model, and the extra host links.
pub const PORTS: usize = tmcl_model::capacity::MAX_INTERFACES + HOST_LINKS - 1;

/// The length of a mailbox message (TMCM-1310 manual §3.6: an 8-byte command, an 8-byte reply).
pub const MAILBOX_LEN: usize = 8;

/// The state of one host interface.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Port {
    /// Collects bytes into frames (binary interfaces).
    pub framer: Framer,
    /// Replies and events waiting for their time.
    pub outbox: Outbox,
    /// ASCII mode and the line being typed.
    pub ascii: ascii::AsciiLine,
}

//! Host interfaces: the byte-fed binary framer, the ASCII command line, and the reply outbox.

pub mod ascii;
pub mod binary;

pub use binary::{Framer, Outbox, Sink, INTER_BYTE_TIMEOUT};

//! Host interfaces: the byte-fed binary framer and the reply outbox.

pub mod binary;

pub use binary::{Framer, Outbox, Sink, INTER_BYTE_TIMEOUT};

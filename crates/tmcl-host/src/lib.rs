//! The host side of TMCL: send 9-byte requests to a module and read its replies (PD28-1021 TMCL firmware
//! manual §3.1–3.2), over a serial port, a pty or TCP.
//!
//! The layers, from the bytes up:
//!
//! - [`Transport`]: a byte pipe with a read timeout. [`SerialTransport`] (RS485/RS232 adapters, and ptys such
//!   as the link `tmcl serve --pty LINK` makes), [`TcpTransport`], and [`MockTransport`] for tests.
//! - [`Client`]: one request in flight, checksum and status checks, each reply matched to its request (module
//!   address and command number; late and foreign replies are skipped and reported, never taken as the
//!   answer), the line drained after a timeout, the raw reply of command 136 type 0, the unsolicited second
//!   reply of command 138, and thin wrappers (`get_axis_parameter`, ...) over
//!   [`tmcl_wire::Command::encode`]. Framing itself is `tmcl_wire`'s.
//! - [`HostError`]: what went wrong, in plain words.
//! - [`poll`]: reading a module until a condition holds, or in rows at a steady pace (`tmcl wait`, `tmcl watch`).
//! - [`models`]: the model of the module on the line, named by the user or found by its version string.
//! - [`paramset`]: a module's parameters saved to a TOML file, loaded back and compared (`tmcl params
//!   --save/--load/--diff`, the workbench's save and load), by the model's tables in `tmcl_model`.
//!
//! The behaviour follows what existing host software does (pytrinamic 0.2.26) where that is safe: host address
//! not checked, statuses 100, 101 and 128 accepted, 5 s default timeout. Unlike pytrinamic, serial ports are
//! opened exclusively and replies are matched to their requests.
//!
//! ```
//! use tmcl_host::{Client, MockTransport};
//! use tmcl_wire::{Reply, Status};
//!
//! let mut transport = MockTransport::new();
//! transport.push_input(&Reply { host: 2, module: 1, status: Status::Ok, opcode: 6, value: -5000 }.to_bytes());
//! let mut client = Client::new(transport);
//! assert_eq!(client.get_axis_parameter(1, 0).unwrap(), -5000);
//! assert_eq!(client.transport_mut().sent, [1, 6, 1, 0, 0, 0, 0, 0, 8]);
//! ```
#![forbid(unsafe_code)]

mod client;
mod error;
pub mod models;
pub mod paramset;
pub mod poll;
mod serial;
mod tcp;
mod transport;
mod version;

pub use client::{ApplicationStatus, Client, DEFAULT_MODULE_ADDRESS, DEFAULT_QUIET, DEFAULT_TIMEOUT};
pub use error::HostError;
pub use serial::{check_link, openers, Opener, SerialTransport};
pub use tcp::TcpTransport;
pub use transport::{MockTransport, Transport};
pub use version::FirmwareVersion;

//! How the host commands reach a module: the connection options and the client they open.

use crate::args::parse_seconds;
use crate::error::CliError;
use clap::Args;
use std::time::Duration;
use tmcl_host::{Client, SerialTransport, TcpTransport, Transport};

/// A client on whatever link the options name.
pub(crate) type HostClient = Client<Box<dyn Transport + Send>>;

/// How to reach the module: the options of every command that talks to one. They may also come before
/// the command's name (`tmcl --port LINK get ap 4`).
#[derive(Debug, Clone, Args)]
pub struct Connection {
    /// Serial port or pty to use, e.g. /dev/ttyUSB0 or the LINK made by `tmcl serve --pty LINK`.
    #[arg(long, global = true, value_name = "PATH", conflicts_with = "tcp", help_heading = "Connection")]
    pub port: Option<String>,
    /// Use the port even when other processes have it open (without a lock, as pyserial and pytrinamic
    /// open ports). Without it such a port is refused, naming them: two hosts on one line read each other's
    /// replies.
    #[arg(long, global = true, help_heading = "Connection")]
    pub shared: bool,
    /// Baud rate of the serial port (ignored by ptys).
    #[arg(long, global = true, value_name = "N", default_value_t = 9600, help_heading = "Connection")]
    pub baud: u32,
    /// TCP address of the module, HOST:PORT (e.g. 127.0.0.1:2323 for `tmcl serve --tcp`).
    #[arg(long, global = true, value_name = "HOST:PORT", help_heading = "Connection")]
    pub tcp: Option<String>,
    /// Module address (global parameter 66).
    #[arg(long, global = true, value_name = "N", default_value_t = 1, help_heading = "Connection")]
    pub address: u8,
    /// How long to wait for each reply, in seconds (fractions allowed).
    #[arg(long, global = true, value_name = "SECONDS", default_value = "5", value_parser = parse_seconds,
          help_heading = "Connection")]
    pub timeout: Duration,
}

impl Connection {
    /// Opens the one connection the options name.
    pub(crate) fn open(&self) -> Result<HostClient, CliError> {
        match (&self.port, &self.tcp) {
            (Some(_), Some(_)) => Err(CliError::Usage("give either --port or --tcp, not both".into())),
            (None, None) => {
                Err(CliError::Usage("no connection: give --port PATH (serial port or pty) or --tcp HOST:PORT".into()))
            }
            _ => Ok(self.connect()?),
        }
    }

    /// Opens the connection again (the workbench, after the link went away): the options were checked by
    /// [`Connection::open`] already, so only the link itself can fail.
    pub(crate) fn connect(&self) -> Result<HostClient, tmcl_host::HostError> {
        let transport: Box<dyn Transport + Send> = match (&self.port, &self.tcp) {
            (Some(path), _) if self.shared => Box::new(SerialTransport::open(path, self.baud)?),
            (Some(path), _) => Box::new(SerialTransport::open_alone(path, self.baud)?),
            (None, Some(addr)) => Box::new(TcpTransport::connect(addr)?),
            (None, None) => {
                return Err(tmcl_host::HostError::Io(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "no connection: give --port PATH (serial port or pty) or --tcp HOST:PORT",
                )))
            }
        };
        Ok(Client::new(transport).with_module_address(self.address).with_timeout(self.timeout))
    }

    /// Whether a port or TCP address was given.
    pub(crate) fn given(&self) -> bool {
        self.port.is_some() || self.tcp.is_some()
    }
}

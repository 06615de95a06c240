//! Serial ports (RS485 or RS232 adapters) and ptys, such as the link that `tmcl serve --pty LINK` creates.

use crate::error::HostError;
use crate::transport::{recv_until_deadline, Transport};
use serialport::{ClearBuffer, SerialPort};
use std::io::{self, Read, Write};
use std::time::Duration;

/// How long one `write` may block: a 9-byte frame at 9600 baud takes under 10 ms.
const WRITE_TIMEOUT: Duration = Duration::from_secs(2);

/// A serial port opened 8N1, raw, without flow control, in the way pyserial opens one.
///
/// The port is not locked with `TIOCEXCL` (other programs, and the virtual module's own kept-open fd, may
/// share it, and pyserial does not lock either) and the modem lines are left alone, so ptys, which
/// ignore the baud rate and reject modem-line ioctls, open like real ports. Input pending at open time is
/// discarded.
pub struct SerialTransport {
    port: Box<dyn SerialPort>,
}

impl std::fmt::Debug for SerialTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialTransport").field("port", &self.port.name()).finish()
    }
}

impl SerialTransport {
    /// Opens `path` (a device such as `/dev/ttyUSB0`, or a pty or a symlink to one) at `baud` bits per second.
    ///
    /// # Errors
    ///
    /// [`HostError::Open`] naming the path.
    pub fn open(path: &str, baud: u32) -> Result<SerialTransport, HostError> {
        let open_error = |source: io::Error| HostError::Open { target: path.to_owned(), source };
        let port = serialport::new(path, baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .exclusive(false)
            .timeout(WRITE_TIMEOUT)
            .open()
            .map_err(|e| open_error(e.into()))?;
        let mut transport = SerialTransport { port };
        transport.clear_input();
        Ok(transport)
    }

    /// The port's name as given to [`SerialTransport::open`].
    pub fn name(&self) -> Option<String> {
        self.port.name()
    }
}

impl Transport for SerialTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.set_timeout(WRITE_TIMEOUT).map_err(io::Error::from)?;
        self.port.write_all(bytes).map_err(hung_up)?;
        self.port.flush().map_err(hung_up)
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        let port = &mut self.port;
        recv_until_deadline(buf, timeout, |chunk, left| {
            port.set_timeout(left).map_err(io::Error::from)?;
            port.read(chunk).map_err(hung_up)
        })
    }

    fn clear_input(&mut self) {
        // A port that cannot flush will fail the next read too, with a better message.
        let _ = self.port.clear(ClearBuffer::Input);
    }
}

/// Words for the `BrokenPipe` that `serialport` reports on `POLLHUP`: on a pty it means the module process
/// closed its side (pyserial says "device reports readiness to read but returned no data").
fn hung_up(e: io::Error) -> io::Error {
    if e.kind() == io::ErrorKind::BrokenPipe {
        io::Error::new(io::ErrorKind::BrokenPipe, "the port hung up (on a pty: the module side closed it)")
    } else {
        e
    }
}

//! Request/reply over a [`Transport`], with the special replies of commands 136 and 138.

use crate::error::HostError;
use crate::transport::Transport;
use crate::version::FirmwareVersion;
use std::collections::VecDeque;
use std::time::{Duration, Instant};
use tmcl_wire::command::{MoveTarget, RfsAction, VersionFormat};
use tmcl_wire::{checksum, Command, Instruction, Opcode, Reply, ReplyFrame, Request, Status, FRAME_LEN};

/// How long to wait for a reply unless told otherwise: 5 s, as pytrinamic (`timeout_s=5`).
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(5);

/// The module address a fresh module answers to (global parameter 66, PD28-1021 TMCL manual §5.1).
pub const DEFAULT_MODULE_ADDRESS: u8 = 1;

/// A TMCL host talking to one module address over a [`Transport`], one request in flight at a time
/// (PD28-1021 TMCL manual §3.1: "do not send the next command before having received the reply").
///
/// Like pytrinamic, replies are not matched against the request by address or opcode: a bus has one master
/// and answers come in order. Two things are handled that pytrinamic leaves to the user:
///
/// - The unsolicited second reply of command 138 (status 128, §3.7.37) may arrive while another request is
///   waiting for its answer. It is then set aside for [`Client::wait_event`] and the real answer is read.
/// - After a timeout or a damaged reply, stale bytes may be left in the input; they are discarded before the
///   next request so that one lost byte does not shift every later reply.
#[derive(Debug)]
pub struct Client<T: Transport> {
    transport: T,
    /// Address put in byte 0 of every request (global parameter 66 of the module). Default 1.
    pub module_address: u8,
    /// How long [`Client::request`] waits for a reply. Default [`DEFAULT_TIMEOUT`].
    pub timeout: Duration,
    events: VecDeque<Reply>,
    resync: bool,
}

impl<T: Transport> Client<T> {
    /// A client for module address 1 with a 5 s timeout.
    pub fn new(transport: T) -> Client<T> {
        Client {
            transport,
            module_address: DEFAULT_MODULE_ADDRESS,
            timeout: DEFAULT_TIMEOUT,
            events: VecDeque::new(),
            resync: false,
        }
    }

    /// Sets the module address (builder style).
    pub fn with_module_address(mut self, address: u8) -> Client<T> {
        self.module_address = address;
        self
    }

    /// Sets the reply timeout (builder style).
    pub fn with_timeout(mut self, timeout: Duration) -> Client<T> {
        self.timeout = timeout;
        self
    }

    /// The transport, for raw access.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Gives the transport back.
    pub fn into_transport(self) -> T {
        self.transport
    }

    /// Discards unread input and any events set aside.
    pub fn clear_input(&mut self) {
        self.transport.clear_input();
        self.events.clear();
        self.resync = false;
    }

    /// Sends one request and returns the module's reply.
    ///
    /// # Errors
    ///
    /// [`HostError::Status`] for a status below 100 (the reply is kept in the error),
    /// [`HostError::Checksum`] for a damaged reply, [`HostError::Timeout`] and [`HostError::Io`] when no
    /// reply arrives. Statuses 100, 101 and 128 and unknown codes from 100 up count as success, as in pytrinamic.
    pub fn request(&mut self, instruction: Instruction) -> Result<Reply, HostError> {
        self.send(instruction)?;
        let deadline = Instant::now() + self.timeout;
        loop {
            let frame = self.recv_frame(deadline, self.timeout)?;
            let reply = self.parse_reply(&frame)?;
            if is_event(&reply) {
                self.events.push_back(reply);
                continue;
            }
            return check_status(reply);
        }
    }

    /// Sends one request without reading a reply: for command 137 (factory defaults, no reply, §3.7.38), 242
    /// (boot) and any command while global parameter 255 suppresses replies.
    pub fn request_no_reply(&mut self, instruction: Instruction) -> Result<(), HostError> {
        self.send(instruction)
    }

    /// Reads the next unsolicited frame, normally the second reply of command 138 (status 128, value = the
    /// motor mask, §3.7.37), waiting at most `timeout`. An event that arrived during an earlier request is
    /// returned first.
    pub fn wait_event(&mut self, timeout: Duration) -> Result<Reply, HostError> {
        if let Some(event) = self.events.pop_front() {
            return Ok(event);
        }
        let frame = self.recv_frame(Instant::now() + timeout, timeout)?;
        let reply = self.parse_reply(&frame)?;
        check_status(reply)
    }

    /// Command 136 type 0: the version string, such as `1021V142` (module 1021, firmware 1.42).
    ///
    /// The reply is special (§3.7.38): the host address and eight ASCII characters, with no status and no
    /// checksum.
    ///
    /// # Errors
    ///
    /// [`HostError::BadVersionString`] when the eight bytes are not printable ASCII, or [`HostError::Status`]
    /// when they form a normal error reply instead (a module without command 136).
    pub fn version_string(&mut self) -> Result<String, HostError> {
        self.send(Command::GetVersion { format: VersionFormat::String }.encode())?;
        let deadline = Instant::now() + self.timeout;
        loop {
            let frame = self.recv_frame(deadline, self.timeout)?;
            let text = &frame[1..];
            if text.iter().all(|b| b.is_ascii_graphic() || *b == b' ') {
                return Ok(text.iter().map(|&b| char::from(b)).collect());
            }
            match parse_reply(&frame) {
                Ok(reply) if is_event(&reply) => self.events.push_back(reply),
                Ok(reply) if u8::from(reply.status) < 100 => {
                    return Err(HostError::Status { status: reply.status, reply });
                }
                _ => {
                    self.resync = true;
                    return Err(HostError::BadVersionString { frame });
                }
            }
        }
    }

    /// Command 136 type 1: the version as a number (see [`FirmwareVersion::from_value`]).
    pub fn version_binary(&mut self) -> Result<i32, HostError> {
        Ok(self.request(Command::GetVersion { format: VersionFormat::Binary }.encode())?.value)
    }

    /// Command 136 type 1, decoded.
    pub fn firmware_version(&mut self) -> Result<FirmwareVersion, HostError> {
        self.version_binary().map(FirmwareVersion::from_value)
    }

    /// GAP (§3.7.6): reads axis parameter `param` of `motor`.
    pub fn get_axis_parameter(&mut self, param: u8, motor: u8) -> Result<i32, HostError> {
        self.value_of(Command::Gap { param, motor })
    }

    /// SAP (§3.7.5): writes axis parameter `param` of `motor`.
    pub fn set_axis_parameter(&mut self, param: u8, motor: u8, value: i32) -> Result<(), HostError> {
        self.run(Command::Sap { param, motor, value })
    }

    /// STAP (§3.7.7): stores axis parameter `param` of `motor` in the EEPROM.
    pub fn store_axis_parameter(&mut self, param: u8, motor: u8) -> Result<(), HostError> {
        self.run(Command::Stap { param, motor })
    }

    /// RSAP (§3.7.8): restores axis parameter `param` of `motor` from the EEPROM.
    pub fn restore_axis_parameter(&mut self, param: u8, motor: u8) -> Result<(), HostError> {
        self.run(Command::Rsap { param, motor })
    }

    /// GGP (§3.7.10): reads global parameter `param` of `bank`.
    pub fn get_global_parameter(&mut self, param: u8, bank: u8) -> Result<i32, HostError> {
        self.value_of(Command::Ggp { param, bank })
    }

    /// SGP (§3.7.9): writes global parameter `param` of `bank`.
    pub fn set_global_parameter(&mut self, param: u8, bank: u8, value: i32) -> Result<(), HostError> {
        self.run(Command::Sgp { param, bank, value })
    }

    /// STGP (§3.7.11): stores global parameter `param` of `bank` in the EEPROM.
    pub fn store_global_parameter(&mut self, param: u8, bank: u8) -> Result<(), HostError> {
        self.run(Command::Stgp { param, bank })
    }

    /// RSGP (§3.7.12): restores global parameter `param` of `bank` from the EEPROM.
    pub fn restore_global_parameter(&mut self, param: u8, bank: u8) -> Result<(), HostError> {
        self.run(Command::Rsgp { param, bank })
    }

    /// ROR (§3.7.1) with a signed velocity, negative = left, as pytrinamic's `rotate`.
    pub fn rotate(&mut self, motor: u8, velocity: i32) -> Result<(), HostError> {
        self.run(Command::Ror { motor, velocity })
    }

    /// MST (§3.7.3).
    pub fn stop(&mut self, motor: u8) -> Result<(), HostError> {
        self.run(Command::Mst { motor })
    }

    /// MVP ABS (§3.7.4).
    pub fn move_to(&mut self, motor: u8, position: i32) -> Result<(), HostError> {
        self.run(Command::Mvp { motor, target: MoveTarget::Abs(position) })
    }

    /// MVP REL (§3.7.4).
    pub fn move_by(&mut self, motor: u8, offset: i32) -> Result<(), HostError> {
        self.run(Command::Mvp { motor, target: MoveTarget::Rel(offset) })
    }

    /// RFS (§3.7.13); the value answers RFS STATUS (0 = no search running).
    pub fn reference_search(&mut self, action: RfsAction, motor: u8) -> Result<i32, HostError> {
        self.value_of(Command::Rfs { action, motor })
    }

    /// GIO (§3.7.15): reads input/output `port` of `bank` (0 digital in, 1 analog in, 2 digital out).
    pub fn get_io(&mut self, port: u8, bank: u8) -> Result<i32, HostError> {
        self.value_of(Command::Gio { port, bank })
    }

    /// SIO (§3.7.14): sets output `port` of `bank`.
    pub fn set_io(&mut self, port: u8, bank: u8, value: i32) -> Result<(), HostError> {
        self.run(Command::Sio { port, bank, value })
    }

    /// Command 137: restores the factory defaults. The module sends no reply (§3.7.38).
    pub fn factory_default(&mut self) -> Result<(), HostError> {
        self.request_no_reply(Command::FactoryDefault.encode())
    }

    /// Command 255: software reset. Whatever reply gets through before the restart is discarded before the
    /// next request (§3.7.38: "the reply of this command might not always get through").
    pub fn software_reset(&mut self) -> Result<(), HostError> {
        self.request_no_reply(Command::SoftwareReset.encode())?;
        self.resync = true;
        Ok(())
    }

    fn value_of(&mut self, command: Command) -> Result<i32, HostError> {
        Ok(self.request(command.encode())?.value)
    }

    fn run(&mut self, command: Command) -> Result<(), HostError> {
        self.request(command.encode()).map(drop)
    }

    fn send(&mut self, instruction: Instruction) -> Result<(), HostError> {
        if self.resync {
            self.transport.clear_input();
            self.resync = false;
        }
        let request = Request { address: self.module_address, instruction };
        self.transport.send(&request.to_bytes()).map_err(HostError::Io)
    }

    /// Reads one frame by `deadline`; a timeout reports `waited` (the whole wait, not just the rest of it).
    fn recv_frame(&mut self, deadline: Instant, waited: Duration) -> Result<[u8; FRAME_LEN], HostError> {
        let mut frame = [0u8; FRAME_LEN];
        let left = deadline.saturating_duration_since(Instant::now());
        match self.transport.recv_exact(&mut frame, left) {
            Ok(()) => Ok(frame),
            Err(HostError::Timeout { received, .. }) => {
                self.resync = true;
                Err(HostError::Timeout { waited, received })
            }
            Err(e) => {
                self.resync = true;
                Err(e)
            }
        }
    }

    fn parse_reply(&mut self, frame: &[u8; FRAME_LEN]) -> Result<Reply, HostError> {
        parse_reply(frame).inspect_err(|_| self.resync = true)
    }
}

/// Parses a normal reply (§3.2, Table 3), checksum verified.
fn parse_reply(frame: &[u8; FRAME_LEN]) -> Result<Reply, HostError> {
    let view = ReplyFrame::new_unchecked(&frame[..]);
    if !view.verify_checksum() {
        return Err(HostError::Checksum { expected: checksum(&frame[..8]), found: view.checksum(), frame: *frame });
    }
    Ok(Reply {
        host: view.host(),
        module: view.module(),
        status: view.status(),
        opcode: view.opcode(),
        value: view.value(),
    })
}

/// The second reply of command 138 (§3.7.37).
fn is_event(reply: &Reply) -> bool {
    reply.status == Status::TargetReached && reply.opcode == u8::from(Opcode::RequestTargetReachedEvent)
}

/// Statuses below 100 are errors (§3.2.1, Table 4); pytrinamic applies the same test.
fn check_status(reply: Reply) -> Result<Reply, HostError> {
    if u8::from(reply.status) < 100 {
        Err(HostError::Status { status: reply.status, reply })
    } else {
        Ok(reply)
    }
}

mod program;
#[cfg(test)]
mod tests;

pub use program::ApplicationStatus;

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

/// How long the line must stay silent before the client takes it as clean again after a timeout, a damaged
/// or a foreign reply: 30 ms, three 9-byte frames at 9600 baud (one takes 9.4 ms there).
pub const DEFAULT_QUIET: Duration = Duration::from_millis(30);

/// The module address a fresh module answers to (global parameter 66, PD28-1021 TMCL manual §5.1).
pub const DEFAULT_MODULE_ADDRESS: u8 = 1;

/// The longest one drain of late bytes may take, however busy the line is.
const DRAIN_LIMIT: Duration = Duration::from_secs(1);

/// How many skipped replies are kept for [`Client::take_skipped`].
const SKIPPED_LIMIT: usize = 64;

/// A TMCL host talking to one module address over a [`Transport`], one request in flight at a time
/// (PD28-1021 TMCL manual §3.1: "do not send the next command before having received the reply").
///
/// **Which reply answers a request.** A normal reply (§3.2, Table 3: reply address, module address, status,
/// command number, value, checksum) answers a request when its module address is the request's address
/// and its command number the request's. Special cases:
///
/// - a request that arrived damaged is answered with status 1 and command number 0 (Trinamic's TMCL code
///   does this), which counts as an answer from the addressed module;
/// - SGP 66 (bank 0) changes the module address, so its reply may come from the new address;
/// - the raw reply of command 136 type 0 (the host address and eight characters, §3.7.38) has no module
///   address: any such frame answers [`Client::version_string`]; command 134 (§3.7.38) answers with the
///   instruction in place of status and command number, see [`Client::read_program_memory`];
/// - commands 137, 242 and (maybe) 255 are not answered ([`Client::request_no_reply`]);
/// - the unsolicited second reply of command 138 (status 128, §3.7.37) may arrive while another request is
///   waiting for its answer. It is set aside for [`Client::wait_event`].
///
/// Any other reply is a late or foreign one: a reply to an earlier request that timed out (perhaps in
/// another process on the same port), or another host's traffic. It is never taken as the answer: the
/// client keeps waiting for the real one until the timeout, then reports [`HostError::Foreign`] with the
/// reply that came instead. [`Client::take_skipped`] lists the replies skipped so far. A module that answers
/// from another address than the one asked (a request to its secondary address, GP 87, or to any address
/// over USB) needs [`Client::match_address`] off.
///
/// **Keeping the line clean.** After a timeout, a damaged or a foreign reply the line may still carry late
/// bytes. Before the next request the client reads them until the line has been quiet for
/// [`Client::quiet`] (at most 1 s), and sorts out the replies among them (138 events are kept, the others
/// are skipped), so that a late reply cannot be taken for the answer to the next request. It cannot help a
/// reply that arrives later still, from the same module to the same command number: the reply carries no
/// more than those two to match on.
///
/// **Resynchronisation.** A frame with a wrong checksum is searched for a valid frame starting 1 to 8 bytes
/// later (garbage before a reply), among the bytes that arrive within [`Client::quiet`]; without one the
/// damaged frame is reported ([`HostError::Checksum`]) and the line is drained before the next request.
#[derive(Debug)]
pub struct Client<T: Transport> {
    transport: T,
    /// Address put in byte 0 of every request (global parameter 66 of the module). Default 1.
    pub module_address: u8,
    /// How long [`Client::request`] waits for a reply. Default [`DEFAULT_TIMEOUT`].
    pub timeout: Duration,
    /// How long the line must be silent after a timeout, a damaged or a foreign reply before the next
    /// request goes out. Default [`DEFAULT_QUIET`]; at baud rates below 9600, give three frame times.
    pub quiet: Duration,
    /// Whether a reply must come from the addressed module (default `true`). Turn it off for a module that
    /// answers from another address than the one asked: a request to its secondary address (GP 87), or a
    /// module on USB that answers every address.
    pub match_address: bool,
    events: VecDeque<Reply>,
    skipped: Vec<Reply>,
    /// Bytes received and not consumed yet: a partial frame after a timeout, or bytes read while
    /// resynchronising.
    rx: Vec<u8>,
    resync: bool,
}

/// What answers a request (see [`Client`]).
#[derive(Debug, Clone, Copy)]
struct Expect {
    address: u8,
    /// Another module address that may answer: the new one of SGP 66.
    also: Option<u8>,
    opcode: u8,
    any_module: bool,
}

impl Expect {
    fn new(address: u8, instruction: &Instruction, any_module: bool) -> Expect {
        let sets_address = instruction.opcode == Opcode::Sgp && instruction.kind == 66 && instruction.motor == 0;
        let also = if sets_address { u8::try_from(instruction.value).ok() } else { None };
        Expect { address, also, opcode: u8::from(instruction.opcode), any_module }
    }

    fn answered_by(&self, reply: &Reply) -> bool {
        let module = self.any_module || reply.module == self.address || Some(reply.module) == self.also;
        let opcode = reply.opcode == self.opcode || (reply.status == Status::WrongChecksum && reply.opcode == 0);
        module && opcode
    }

    fn foreign(&self, reply: Reply) -> HostError {
        HostError::Foreign { address: self.address, opcode: self.opcode, reply }
    }
}

/// A 9-byte frame as read: one that passed the caller's check, or a damaged one.
enum Received {
    Frame([u8; FRAME_LEN]),
    Damaged([u8; FRAME_LEN]),
}

impl<T: Transport> Client<T> {
    /// A client for module address 1 with a 5 s timeout.
    pub fn new(transport: T) -> Client<T> {
        Client {
            transport,
            module_address: DEFAULT_MODULE_ADDRESS,
            timeout: DEFAULT_TIMEOUT,
            quiet: DEFAULT_QUIET,
            match_address: true,
            events: VecDeque::new(),
            skipped: Vec::new(),
            rx: Vec::new(),
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

    /// Sets the quiet interval of the drain (builder style; see [`Client::quiet`]).
    pub fn with_quiet(mut self, quiet: Duration) -> Client<T> {
        self.quiet = quiet;
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

    /// Discards unread input and any events set aside, without waiting for the line to be quiet.
    pub fn clear_input(&mut self) {
        self.transport.clear_input();
        self.events.clear();
        self.rx.clear();
        self.resync = false;
    }

    /// The late or foreign replies skipped since the last call (the latest 64), oldest first: replies that
    /// arrived while a request waited for its answer, or during a drain.
    pub fn take_skipped(&mut self) -> Vec<Reply> {
        std::mem::take(&mut self.skipped)
    }

    /// Drains the line now if a timeout, a damaged or a foreign reply left it unclean (see [`Client`]), so
    /// that late replies are in [`Client::take_skipped`] and gone from the line; does nothing otherwise.
    pub fn settle(&mut self) -> Result<(), HostError> {
        if self.resync || !self.rx.is_empty() {
            self.drain()?;
        }
        Ok(())
    }

    /// Sends one request and returns the module's reply to it.
    ///
    /// # Errors
    ///
    /// [`HostError::Status`] for a status below 100 (the reply is kept in the error),
    /// [`HostError::Checksum`] for a damaged reply, [`HostError::Foreign`] when only replies to other requests
    /// arrived, [`HostError::Timeout`] and [`HostError::Io`] when nothing did. Statuses 100, 101 and 128 and
    /// unknown codes from 100 up count as success, as in pytrinamic.
    pub fn request(&mut self, instruction: Instruction) -> Result<Reply, HostError> {
        let expect = Expect::new(self.module_address, &instruction, !self.match_address);
        self.send(instruction)?;
        let deadline = Instant::now() + self.timeout;
        let mut foreign = None;
        loop {
            let frame = match self.next_frame(deadline, checksum_ok)? {
                Some(Received::Frame(frame)) => frame,
                Some(Received::Damaged(frame)) => return Err(checksum_error(&frame)),
                None => return Err(self.timed_out(foreign.map(|r| expect.foreign(r)))),
            };
            let reply = parse_reply(&frame)?;
            if is_event(&reply) {
                self.events.push_back(reply);
            } else if expect.answered_by(&reply) {
                return check_status(reply);
            } else {
                self.skip(reply);
                foreign.get_or_insert(reply);
            }
        }
    }

    /// Sends one request that may get no reply (command 137 carried out, 242, 255 on a module that does
    /// not answer it, anything while GP 255 suppresses replies) and returns the reply that answers it within
    /// the timeout, or `None` when none came. A refusal (status below 100) is [`HostError::Status`], as for
    /// [`Client::request`]: the module did not do what was asked.
    ///
    /// # Errors
    ///
    /// As [`Client::request`], except that silence is `Ok(None)`.
    pub fn request_optional(&mut self, instruction: Instruction) -> Result<Option<Reply>, HostError> {
        match self.request(instruction) {
            Ok(reply) => Ok(Some(reply)),
            Err(HostError::Timeout { received: 0, .. }) => {
                // Nothing came, so nothing is left on the line to drain.
                self.resync = false;
                Ok(None)
            }
            Err(e) => Err(e),
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
        match self.next_frame(Instant::now() + timeout, checksum_ok)? {
            Some(Received::Frame(frame)) => check_status(parse_reply(&frame)?),
            Some(Received::Damaged(frame)) => Err(checksum_error(&frame)),
            None => {
                self.resync = true;
                Err(HostError::Timeout { waited: timeout, received: self.rx.len() })
            }
        }
    }

    /// Command 136 type 0: the version string, such as `1021V142` (module 1021, firmware 1.42).
    ///
    /// The reply is special (§3.7.38): the host address and eight ASCII characters, with no status and no
    /// checksum. It carries no module address either, so any such frame is taken as the answer; normal
    /// replies to other requests are skipped as in [`Client::request`].
    ///
    /// # Errors
    ///
    /// [`HostError::BadVersionString`] when the eight bytes are not printable ASCII, or [`HostError::Status`]
    /// when they form a normal error reply instead (a module without command 136).
    pub fn version_string(&mut self) -> Result<String, HostError> {
        let instruction = Command::GetVersion { format: VersionFormat::String }.encode();
        let expect = Expect::new(self.module_address, &instruction, !self.match_address);
        self.send(instruction)?;
        let deadline = Instant::now() + self.timeout;
        let mut foreign = None;
        loop {
            let frame = match self.next_frame(deadline, |w| is_version_text(w) || checksum_ok(w))? {
                Some(Received::Frame(frame)) => frame,
                Some(Received::Damaged(frame)) => return Err(HostError::BadVersionString { frame }),
                None => return Err(self.timed_out(foreign.map(|r| expect.foreign(r)))),
            };
            if is_version_text(&frame) {
                return Ok(frame[1..].iter().map(|&b| char::from(b)).collect());
            }
            let reply = parse_reply(&frame)?;
            if is_event(&reply) {
                self.events.push_back(reply);
            } else if expect.answered_by(&reply) {
                // A module without the string form answers with a normal reply, an error status.
                return check_status(reply).and_then(|_| {
                    self.resync = true;
                    Err(HostError::BadVersionString { frame })
                });
            } else {
                self.skip(reply);
                foreign.get_or_insert(reply);
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

    /// Sends a request, after draining the line if it is not known to be clean.
    fn send(&mut self, instruction: Instruction) -> Result<(), HostError> {
        self.settle()?;
        let request = Request { address: self.module_address, instruction };
        self.transport.send(&request.to_bytes()).map_err(HostError::Io)
    }

    /// The error for a request that got no answer by its deadline: `foreign` if a reply to another request
    /// came, else a timeout. The line is drained before the next request.
    fn timed_out(&mut self, foreign: Option<HostError>) -> HostError {
        self.resync = true;
        foreign.unwrap_or(HostError::Timeout { waited: self.timeout, received: self.rx.len() })
    }

    fn skip(&mut self, reply: Reply) {
        if self.skipped.len() == SKIPPED_LIMIT {
            self.skipped.remove(0);
        }
        self.skipped.push(reply);
        // Whatever else is on its way belongs to other requests too.
        self.resync = true;
    }

    /// Reads until `rx` holds `n` bytes; `Ok(false)` when `until` passes first (what did arrive stays in
    /// `rx`).
    fn fill(&mut self, n: usize, until: Instant) -> Result<bool, HostError> {
        while self.rx.len() < n {
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(false);
            }
            let mut chunk = vec![0u8; n - self.rx.len()];
            match self.transport.recv_exact(&mut chunk, left) {
                Ok(()) => self.rx.extend_from_slice(&chunk),
                Err(HostError::Timeout { received, .. }) => {
                    self.rx.extend_from_slice(&chunk[..received.min(chunk.len())]);
                    return Ok(false);
                }
                Err(e) => {
                    self.resync = true;
                    return Err(e);
                }
            }
        }
        Ok(true)
    }

    /// The next frame by `deadline`: the first 9 bytes if they pass `ok`, else the first window 1 to 8 bytes
    /// later that does among the bytes arriving within [`Client::quiet`] (the bytes before it are dropped as
    /// garbage), else the damaged first 9 bytes. `None` when fewer than 9 bytes arrive in time.
    fn next_frame(&mut self, deadline: Instant, ok: fn(&[u8]) -> bool) -> Result<Option<Received>, HostError> {
        if !self.fill(FRAME_LEN, deadline)? {
            return Ok(None);
        }
        if !ok(&self.rx[..FRAME_LEN]) {
            let grace = deadline.max(Instant::now()).min(Instant::now() + self.quiet);
            let mut found = None;
            for skip in 1..FRAME_LEN {
                if !self.fill(skip + FRAME_LEN, grace)? {
                    break;
                }
                if ok(&self.rx[skip..skip + FRAME_LEN]) {
                    found = Some(skip);
                    break;
                }
            }
            match found {
                Some(skip) => drop(self.rx.drain(..skip)),
                None => {
                    let frame = take_frame(&mut self.rx);
                    self.resync = true;
                    return Ok(Some(Received::Damaged(frame)));
                }
            }
        }
        Ok(Some(Received::Frame(take_frame(&mut self.rx))))
    }

    /// Reads what is still on its way until the line has been quiet for [`Client::quiet`] (at most 1 s in
    /// all) and sorts the replies among it: 138 events are kept for [`Client::wait_event`], other replies
    /// are skipped (see [`Client::take_skipped`]), bytes that form no frame are dropped.
    fn drain(&mut self) -> Result<(), HostError> {
        let limit = Instant::now() + DRAIN_LIMIT;
        loop {
            let before = self.rx.len();
            let until = (Instant::now() + self.quiet).min(limit);
            self.fill(before + 64, until)?;
            if self.rx.len() == before || Instant::now() >= limit {
                break;
            }
        }
        let bytes = std::mem::take(&mut self.rx);
        let mut at = 0;
        while at + FRAME_LEN <= bytes.len() {
            let window = &bytes[at..at + FRAME_LEN];
            let mut frame = [0u8; FRAME_LEN];
            frame.copy_from_slice(window);
            match parse_reply(&frame) {
                Ok(reply) => {
                    if is_event(&reply) {
                        self.events.push_back(reply);
                    } else {
                        self.skip(reply);
                    }
                    at += FRAME_LEN;
                }
                Err(_) => at += 1,
            }
        }
        self.resync = false;
        Ok(())
    }
}

/// Takes the first 9 bytes out of `rx` (which holds at least 9).
fn take_frame(rx: &mut Vec<u8>) -> [u8; FRAME_LEN] {
    let mut frame = [0u8; FRAME_LEN];
    frame.copy_from_slice(&rx[..FRAME_LEN]);
    rx.drain(..FRAME_LEN);
    frame
}

/// Whether `window` (9 bytes) ends in the 8-bit sum of the others (§3.2).
fn checksum_ok(window: &[u8]) -> bool {
    window.len() == FRAME_LEN && checksum(&window[..8]) == window[8]
}

/// Whether `window` is the raw reply of 136 type 0: any host address, then eight printable characters.
fn is_version_text(window: &[u8]) -> bool {
    window.len() == FRAME_LEN && window[1..].iter().all(|b| b.is_ascii_graphic() || *b == b' ')
}

fn checksum_error(frame: &[u8; FRAME_LEN]) -> HostError {
    HostError::Checksum { expected: checksum(&frame[..8]), found: frame[8], frame: *frame }
}

/// Parses a normal reply (§3.2, Table 3), checksum verified.
fn parse_reply(frame: &[u8; FRAME_LEN]) -> Result<Reply, HostError> {
    let view = ReplyFrame::new_unchecked(&frame[..]);
    if !view.verify_checksum() {
        return Err(checksum_error(frame));
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

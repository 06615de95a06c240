//! The module's host interfaces: bytes and whole mailbox messages in, replies out on the interface that
//! asked, and time (PD28-1021 manual §3.1–3.2; TMCM-1310 manual §3.5–3.6 for the mailbox).
//!
//! Each interface of the model ([`crate::model::InterfaceDesc`]) has its own framer, outbox and ASCII
//! line ([`crate::iface::Port`]); what it filters (addresses), delays (telegram pause) and suppresses
//! (GP 255) is the interface's data.

use super::{Module, Origin, Outcome, ReplyOf};
use crate::hal::Board;
use crate::iface::{Sink, MAILBOX_LEN};
use crate::model::{AppStatusReply, Framing, InterfaceDesc};
use crate::time::{Duration, Instant};
use tmcl_model::capacity::MAX_INTERFACES;
use tmcl_wire::{Command, CommandSet, Frame, Instruction, Opcode, Reply, Request, Status, StatusKind, FRAME_LEN};

impl<B: Board> Module<B> {
    /// The interface `port` of the model, if it has one; an extra host link is the first interface again.
    #[inline]
    pub(crate) fn interface(&self, port: usize) -> Option<&'static InterfaceDesc> {
        match self.spec.interfaces.get(port) {
            Some(iface) => Some(iface),
            None if (MAX_INTERFACES..crate::iface::PORTS).contains(&port) => self.spec.interfaces.first(),
            None => None,
        }
    }

    /// The port of host link `link` on the first interface: link 0 is the interface itself (port 0); with
    /// the feature `host-links`, links 1 to [`crate::iface::HOST_LINKS`] - 1 are ports of their own after
    /// the model's interfaces, each with its own framer, outbox and ASCII line, filtered, paused and
    /// suppressed as the first interface is. A host on one link never sees a reply to another; a 138 event
    /// goes to the link that asked for it. `None` beyond the links the core keeps.
    pub fn link_port(&self, link: usize) -> Option<usize> {
        match link {
            0 => Some(0),
            n if n < crate::iface::HOST_LINKS => Some(MAX_INTERFACES + n - 1),
            _ => None,
        }
    }

    /// Feeds bytes that arrived at `now` on the primary interface (see [`Module::receive_on`]).
    pub fn receive(&mut self, now: Instant, bytes: &[u8], sink: &mut impl Sink) {
        self.receive_on(0, now, bytes, sink);
    }

    /// Feeds bytes that arrived at `now` on host interface `port` (an index into the model's interfaces).
    /// Complete frames are executed in order; each one's reply, and what else is due on that interface, goes
    /// to `sink` before the next frame is taken (at once, or after the telegram pause GP 75: a reply still
    /// waiting for its time stays in the outbox, which drops its oldest messages when a flood overfills it).
    /// Bytes for an interface the model does not have, or for a mailbox interface (which takes whole
    /// messages, [`Module::request`]), are dropped. A caller that holds a backlog (a pty, a TCP socket)
    /// and wants one reply per frame whatever the pause uses [`Module::receive_in_turn`].
    pub fn receive_on(&mut self, port: usize, now: Instant, bytes: &[u8], sink: &mut impl Sink) {
        self.take_bytes(port, now, bytes, sink, false);
    }

    /// As [`Module::receive_on`], but takes no byte after a frame (or ASCII line) whose reply is still
    /// waiting for its time (the telegram pause, GP 75): returns how many bytes were taken, and the caller
    /// offers the rest again once the reply has gone out (after a [`Module::poll_port`] at or after the
    /// deadline it returns). So a backlog of any length is answered in order, one reply per frame, and the
    /// outbox never overflows.
    pub fn receive_in_turn(&mut self, port: usize, now: Instant, bytes: &[u8], sink: &mut impl Sink) -> usize {
        self.take_bytes(port, now, bytes, sink, true)
    }

    /// Sets the gap after which a partial binary frame is dropped on every interface: the UART's receive
    /// timeout of a real serial line ([`crate::iface::INTER_BYTE_TIMEOUT`], the default), or `None` where
    /// the bytes come through a buffer that spaces them by chance (a pty, a TCP socket), so that a frame
    /// is never dropped because the host wrote it in pieces. See docs/decisions.md, "No frame lost".
    pub fn set_inter_byte_timeout(&mut self, timeout: Option<Duration>) {
        self.inter_byte_timeout = timeout;
    }

    #[inline(never)]
    fn take_bytes(&mut self, port: usize, now: Instant, bytes: &[u8], sink: &mut impl Sink, in_turn: bool) -> usize {
        let Some(iface) = self.open_port(port, Framing::Binary, now, sink) else { return bytes.len() };
        let mut rest = bytes;
        while let Some((&b, tail)) = rest.split_first() {
            if in_turn && !self.st.ports[port].outbox.is_empty() {
                break;
            }
            if self.st.ports[port].ascii.active {
                self.ascii_byte(port, b, now);
                rest = tail;
                self.st.ports[port].outbox.flush(now, sink);
                continue;
            }
            // A whole frame at once (the usual case: hosts write 9 bytes in one go) skips the byte-wise
            // framer; it is exactly what pushing its bytes one by one at `now` would give.
            let timeout = self.inter_byte_timeout;
            let framer = &mut self.st.ports[port].framer;
            let frame = match rest.first_chunk::<FRAME_LEN>() {
                Some(whole) if framer.pending() == 0 => {
                    rest = &rest[FRAME_LEN..];
                    framer.touch(now);
                    Some(*whole)
                }
                _ => {
                    rest = tail;
                    framer.push_within(b, now, timeout)
                }
            };
            if let Some(frame) = frame {
                self.handle_frame(port, iface, frame, now, sink);
                // A command that only reads changes nothing the driver sees; anything else may.
                if !CommandSet::READ_ONLY.contains_code(frame[1]) {
                    self.update_boards(now);
                }
                self.st.ports[port].outbox.flush(now, sink);
            }
        }
        self.st.ports[port].outbox.flush(now, sink);
        bytes.len() - rest.len()
    }

    /// Takes one mailbox message (an 8-byte request without checksum, TMCM-1310 manual §3.6) that
    /// arrived at `now` on interface `port`, executes it and sends what is due on that interface, its
    /// 8-byte reply first, to `sink`. A message for an interface that is not a mailbox is dropped.
    pub fn request(&mut self, port: usize, now: Instant, message: &[u8; MAILBOX_LEN], sink: &mut impl Sink) {
        let Some(iface) = self.open_port(port, Framing::Mailbox, now, sink) else { return };
        let value = i32::from_be_bytes([message[4], message[5], message[6], message[7]]);
        let instruction = Instruction::new(message[1].into(), message[2], message[3], value);
        self.st.last_command = now;
        self.st.heartbeat_tripped = false;
        self.handle_instruction(port, iface, instruction, message[1], now, sink);
        if !CommandSet::READ_ONLY.contains_code(message[1]) {
            self.update_boards(now);
        }
        self.st.ports[port].outbox.flush(now, sink);
    }

    /// What `receive_on` and `request` do first: advance to `now`, send what is already due on `port`, and
    /// give its interface if it has the `framing` the caller takes.
    #[inline(always)]
    fn open_port(
        &mut self,
        port: usize,
        framing: Framing,
        now: Instant,
        sink: &mut impl Sink,
    ) -> Option<&'static InterfaceDesc> {
        self.advance(now);
        self.st.ports.get_mut(port)?.outbox.flush(self.st.now, sink);
        self.interface(port).filter(|i| i.framing == framing)
    }

    /// Drops a partial frame on the primary interface: the link was interrupted (a new TCP connection, a
    /// host that went away), so bytes from before cannot belong to the next request.
    pub fn reset_link(&mut self) {
        self.reset_port(0);
    }

    /// Drops a partial frame on interface `port`.
    pub fn reset_port(&mut self, port: usize) {
        if let Some(p) = self.st.ports.get_mut(port) {
            p.framer.clear();
        }
    }

    /// Advances the module to `now`, sends what is due on the primary interface to `sink`, and returns
    /// when the module next needs to run: the next motion tick while the motor moves, else the next timer
    /// (standby current, freewheeling, heartbeat, a delayed reply on any interface), or `None` when
    /// nothing will happen until the next command.
    pub fn poll(&mut self, now: Instant, sink: &mut impl Sink) -> Option<Instant> {
        self.poll_port(0, now, sink)
    }

    /// As [`Module::poll`], sending what is due on interface `port`.
    pub fn poll_port(&mut self, port: usize, now: Instant, sink: &mut impl Sink) -> Option<Instant> {
        self.advance(now);
        if let Some(p) = self.st.ports.get_mut(port) {
            p.outbox.flush(self.st.now, sink);
        }
        self.next_deadline()
    }

    /// Executes one instruction as if a host had sent it on the primary interface at `now`, without the
    /// framing: for tests and tools. Returns the reply's status and value; what else becomes due (a 138
    /// event, a delayed reply) stays queued for the next poll.
    pub fn execute_instruction(&mut self, now: Instant, instruction: Instruction) -> Result<Outcome, Status> {
        self.advance(now);
        self.st.asking_port = 0;
        let result = self.decode_host(instruction).and_then(|c| self.exec(c, now, Origin::Host));
        match result {
            Ok(Outcome::Restart(_)) | Ok(Outcome::Silent)
                if matches!(instruction.opcode, Opcode::SoftwareReset | Opcode::FactoryDefault) =>
            {
                self.start(now)
            }
            Ok(Outcome::EnterAscii) => self.enter_ascii(0),
            _ => {}
        }
        self.update_boards(now);
        result
    }

    /// Validates an instruction for this model: a command the model lacks is status 2 (invalid command),
    /// then the command's own checks ([`Command::decode`]).
    #[inline]
    pub(crate) fn decode(&self, instruction: Instruction) -> Result<Command, Status> {
        self.decode_code(instruction, instruction.opcode.code())
    }

    /// [`Module::decode`] with the command number `code` at hand.
    #[inline(always)]
    fn decode_code(&self, instruction: Instruction, code: u8) -> Result<Command, Status> {
        if !self.spec.commands.contains_code(code) {
            return Err(Status::InvalidCommand);
        }
        // PDx-113 manual §5.5: 135 has no type variants; its type byte is "don't care".
        if code == Opcode::GetStatus.code() && self.spec.app_status == AppStatusReply::Plain {
            return Ok(Command::GetStatus { kind: StatusKind::MemoryPointer });
        }
        Command::decode(instruction)
    }

    /// [`Module::decode`] for a command from the host: those the opcode table marks as program-only
    /// (JA, JC, COMP, CSUB, RSUB, WAIT, STOP, VECT, RETI; §3.6.3) are status 6, command not available.
    #[inline]
    pub(crate) fn decode_host(&self, instruction: Instruction) -> Result<Command, Status> {
        let code = instruction.opcode.code();
        let command = self.decode_code(instruction, code)?;
        if self.program_only(code) {
            return Err(Status::NotAvailable);
        }
        Ok(command)
    }

    /// Whether command `code` is one the host may not send: the program-only commands (§3.6.3), but VECT
    /// on a model that takes it in direct mode (`ModelDesc::host_vect`).
    #[inline]
    fn program_only(&self, code: u8) -> bool {
        CommandSet::PROGRAM_ONLY.contains_code(code) && !(self.spec.host_vect && code == Opcode::Vect.code())
    }

    #[inline(always)]
    fn handle_frame(
        &mut self,
        port: usize,
        iface: &InterfaceDesc,
        bytes: [u8; FRAME_LEN],
        now: Instant,
        sink: &mut impl Sink,
    ) {
        let frame = Frame::new_unchecked(&bytes[..]);
        let address = frame.address();
        // §3.1 / §5.1 GP 66, GP 87: on a bus, frames for other addresses get no reply at all.
        if iface.address_filter {
            let ready = self.st.banks.ready();
            if address != ready.address && (ready.secondary == 0 || address != ready.secondary) {
                return;
            }
        }
        self.st.last_command = now;
        self.st.heartbeat_tripped = false;
        match Request::parse(&frame) {
            // §3.2.1 status 1; the reply carries opcode 0 and value 0, as Trinamic's TMCL code does.
            Err(_) => self.queue_reply_aside(port, iface, frame.opcode(), Ok((Status::WrongChecksum, 0, 0u8)), now),
            Ok(request) => self.handle_instruction(port, iface, request.instruction, bytes[1], now, sink),
        }
    }

    /// Executes a host's instruction (download mode stores it instead) and queues the reply on `port`
    /// (a read's reply, due at once on an empty binary outbox, goes straight to `sink`). `op` is the
    /// command byte as it arrived (`i.opcode.code()`, taken from the frame rather than computed back from
    /// the opcode: one table lookup less per frame).
    #[inline(always)]
    fn handle_instruction(
        &mut self,
        port: usize,
        iface: &InterfaceDesc,
        i: Instruction,
        op: u8,
        now: Instant,
        sink: &mut impl Sink,
    ) {
        if self.vm.download.is_some() && !i.opcode.is_control() {
            // §3.7.38 132: in download mode every command but the control commands is stored.
            let status = match self.download(i) {
                Ok(()) => Status::Loaded,
                Err(status) => status,
            };
            self.queue_reply_aside(port, iface, op, Ok((status, i.value, op)), now);
            return;
        }
        self.st.asking_port = port as u8;
        // A read, the short way (`Module::host_read`): it always replies (§5.1 GP 255: GAP, GGP and GIO
        // are never suppressed), and nothing follows its reply.
        if let Some(read) = self.host_read(&i, now) {
            let reply = match read {
                Ok(v) => (Status::Ok, v),
                Err(status) => (status, i.value),
            };
            self.send_reply(port, iface, op, reply, now, sink);
            return;
        }
        // As `decode_host`, with one check more: no ASCII mode on an interface without it.
        let result = self.decode_code(i, op).and_then(|c| {
            if self.program_only(op) || (matches!(c, Command::EnterAscii) && !iface.ascii) {
                return Err(Status::NotAvailable);
            }
            self.exec(c, now, Origin::Host)
        });
        let reply = match result {
            Ok(Outcome::Value(v) | Outcome::Restart(v)) => Ok((Status::Ok, v, op)),
            Ok(Outcome::Raw(raw)) => Err(raw),
            Ok(Outcome::Silent) => {
                if i.opcode == Opcode::FactoryDefault {
                    self.start(now);
                }
                return;
            }
            Ok(Outcome::EnterAscii) => Ok((Status::Ok, 0, op)),
            Err(status) => Ok((status, i.value, op)),
        };
        // One place queues the reply (so that its code, inlined, is there once); a restart and the switch
        // to ASCII mode come after it.
        self.queue_reply(port, iface, op, reply, now);
        match result {
            Ok(Outcome::Restart(_)) => self.start(now),
            Ok(Outcome::EnterAscii) => self.enter_ascii(port),
            _ => {}
        }
    }

    /// A read's reply on `port`: straight to `sink` when it is due at once on a binary interface whose
    /// outbox is empty (what queueing it and flushing the outbox would send, without the copy into the
    /// outbox and back), else queued behind what waits there ([`Module::queue_reply`]).
    #[inline(always)]
    fn send_reply(
        &mut self,
        port: usize,
        iface: &InterfaceDesc,
        op: u8,
        (status, value): (Status, i32),
        now: Instant,
        sink: &mut impl Sink,
    ) {
        let idle = self.st.ports.get(port).is_some_and(|p| p.outbox.is_empty());
        if iface.framing == Framing::Binary && idle && self.reply_due(iface, now) <= now {
            sink.send(&self.reply_bytes(status, op, value));
        } else {
            self.queue_reply(port, iface, op, Ok((status, value, op)), now);
        }
    }

    /// Whether replies on `iface` are suppressed for command `opcode` (§5.1 GP 255; GAP, GGP and GIO
    /// always reply).
    #[inline]
    pub(crate) fn suppressed(&self, iface: &InterfaceDesc, opcode: u8) -> bool {
        iface.suppressible && self.st.banks.ready().suppress && !CommandSet::ALWAYS_REPLY.contains_code(opcode)
    }

    /// When a reply on `iface` to a command at `now` is due (§5.1 GP 75: the telegram pause, in ms).
    #[inline]
    pub(crate) fn reply_due(&self, iface: &InterfaceDesc, now: Instant) -> Instant {
        if !iface.telegram_pause {
            return now;
        }
        now + Duration::from_millis(u64::from(self.st.banks.ready().pause_ms))
    }

    /// Queues `reply` to command `opcode` on `port` unless suppressed, due after the telegram pause.
    #[inline(always)]
    fn queue_reply(&mut self, port: usize, iface: &InterfaceDesc, opcode: u8, reply: ReplyOf, now: Instant) {
        if self.suppressed(iface, opcode) {
            return;
        }
        let due = self.reply_due(iface, now);
        match reply {
            // The common case, built straight into the outbox.
            Ok((status, value, op)) if iface.framing == Framing::Binary => {
                let bytes = self.reply_bytes(status, op, value);
                if let Some(p) = self.st.ports.get_mut(port) {
                    p.outbox.push_frame(bytes, due);
                }
            }
            _ => self.push_reply(port, iface.framing, opcode, reply, due),
        }
    }

    /// [`Module::queue_reply`] for the replies off the usual way (a wrong checksum, download mode), not
    /// inlined there.
    #[inline(never)]
    fn queue_reply_aside(&mut self, port: usize, iface: &InterfaceDesc, opcode: u8, reply: ReplyOf, now: Instant) {
        if !self.suppressed(iface, opcode) {
            let due = self.reply_due(iface, now);
            self.push_reply(port, iface.framing, opcode, reply, due);
        }
    }

    /// Queues a reply to command `opcode` on `port` in the interface's framing: 9 bytes, or 8 in a mailbox
    /// (the frame without its checksum; for the special reply of 136, its 8 characters without the host
    /// address).
    pub(crate) fn push_reply(&mut self, port: usize, framing: Framing, opcode: u8, reply: ReplyOf, due: Instant) {
        let special = reply.is_err();
        let bytes = match reply {
            Ok((status, value, op)) => self.reply_bytes(status, op, value),
            Err(raw) => raw,
        };
        let Some(p) = self.st.ports.get_mut(port) else { return };
        match framing {
            Framing::Binary => p.outbox.push(&bytes, due),
            Framing::Mailbox if special && opcode == Opcode::GetVersion.code() => p.outbox.push(&bytes[1..], due),
            Framing::Mailbox => p.outbox.push(&bytes[..MAILBOX_LEN], due),
        }
    }

    #[inline(always)]
    pub(crate) fn reply_bytes(&self, status: Status, opcode: u8, value: i32) -> [u8; FRAME_LEN] {
        Reply { host: self.host_address(), module: self.address(), status, opcode, value }.to_bytes()
    }
}

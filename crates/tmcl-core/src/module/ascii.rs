//! ASCII mode on the module (PD28-1021 manual §3.4): the line typed on an interface is run as a command
//! and answered in text. The line itself is [`crate::iface::ascii`]'s.

use super::{Module, Origin, Outcome};
use crate::hal::Board;
use crate::iface::ascii::{is_line_breaker, AsciiLine, BACKSPACE, CR, DELETE, LF, LINE_MAX};
use crate::model::Setting;
use crate::time::Instant;
use tmcl_wire::ascii::{char_address, parse_ascii_command, write_reply, AsciiCommand};
use tmcl_wire::{Command, Opcode, Status};

/// A small fixed-capacity text buffer for building replies without a heap.
struct Text<const N: usize> {
    buf: [u8; N],
    len: usize,
}

impl<const N: usize> Text<N> {
    fn new() -> Self {
        Text { buf: [0; N], len: 0 }
    }
    fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }
}

impl<const N: usize> core::fmt::Write for Text<N> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let b = s.as_bytes();
        let end = self.len + b.len();
        if end > N {
            return Err(core::fmt::Error);
        }
        self.buf[self.len..end].copy_from_slice(b);
        self.len = end;
        Ok(())
    }
}

impl<B: Board> Module<B> {
    /// Whether the module talks ASCII on its primary interface (§3.4).
    pub fn ascii_mode(&self) -> bool {
        self.ascii_mode_on(0)
    }

    /// Whether the module talks ASCII on interface `port`.
    pub fn ascii_mode_on(&self, port: usize) -> bool {
        self.st.ports.get(port).is_some_and(|p| p.ascii.active)
    }

    /// Echo mode from GP 67 bits 5 and 4: 0 each character, 1 whole line, 2 and 3 none.
    fn echo_mode(&self) -> i32 {
        (self.gp(Setting::AsciiMode).unwrap_or(0) >> 4) & 3
    }

    /// Whether `c` is this module's address character (primary or secondary, GP 66/87).
    fn is_my_address(&self, c: u8) -> bool {
        let Some(a) = char_address(c.to_ascii_uppercase()) else { return false };
        let ready = self.st.banks.ready();
        a == ready.address || (ready.secondary != 0 && a == ready.secondary)
    }

    /// One byte of input in ASCII mode on interface `port` (which exists: the caller checked).
    pub(crate) fn ascii_byte(&mut self, port: usize, b: u8, now: Instant) {
        let echo_each = self.echo_mode() == 0;
        match b {
            LF => {}
            CR => {
                let addressed =
                    self.st.ports[port].ascii.first != 0 && self.is_my_address(self.st.ports[port].ascii.first);
                if addressed {
                    if echo_each {
                        self.st.ports[port].outbox.push(&[CR], now);
                    } else if self.echo_mode() == 1 {
                        let mut line = [0u8; LINE_MAX + 2];
                        line[0] = self.st.ports[port].ascii.first;
                        let n = self.st.ports[port].ascii.len;
                        line[1..=n].copy_from_slice(&self.st.ports[port].ascii.buf[..n]);
                        line[n + 1] = CR;
                        self.st.ports[port].outbox.push(&line[..n + 2], now);
                    }
                    self.ascii_line(port, now);
                }
                self.st.ports[port].ascii.clear();
            }
            BACKSPACE | DELETE => {
                let addressed =
                    self.st.ports[port].ascii.first != 0 && self.is_my_address(self.st.ports[port].ascii.first);
                if self.st.ports[port].ascii.len > 0 {
                    self.st.ports[port].ascii.len -= 1;
                } else {
                    self.st.ports[port].ascii.first = 0;
                }
                if addressed && echo_each {
                    self.st.ports[port].outbox.push(&[BACKSPACE, b' ', BACKSPACE], now);
                }
            }
            // A byte no command line contains (binary data, ESC): the line so far is discarded.
            _ if is_line_breaker(b) => self.st.ports[port].ascii.clear(),
            _ => {
                if self.st.ports[port].ascii.first == 0 {
                    self.st.ports[port].ascii.first = b;
                } else if self.st.ports[port].ascii.len < LINE_MAX {
                    self.st.ports[port].ascii.buf[self.st.ports[port].ascii.len] = b;
                    self.st.ports[port].ascii.len += 1;
                } else {
                    self.st.ports[port].ascii.overflow = true;
                }
                if echo_each && self.is_my_address(self.st.ports[port].ascii.first) {
                    self.st.ports[port].outbox.push(&[b], now);
                }
            }
        }
    }

    /// Executes a complete line addressed to this module and queues its reply.
    fn ascii_line(&mut self, port: usize, now: Instant) {
        self.st.asking_port = port as u8;
        self.st.last_command = now;
        self.st.heartbeat_tripped = false;
        let n = self.st.ports[port].ascii.len;
        let mut buf = [0u8; LINE_MAX];
        buf[..n].copy_from_slice(&self.st.ports[port].ascii.buf[..n]);
        let (status, value, opcode, leave) = if self.st.ports[port].ascii.overflow {
            (Status::InvalidCommand, 0, Opcode::Unknown(0), false)
        } else {
            match core::str::from_utf8(&buf[..n]).map_err(|_| Status::InvalidCommand).and_then(|text| {
                parse_ascii_command(text, &mut |_| None).map_err(|e| {
                    // An empty line after the address character is a command missing: invalid command.
                    Status::from(e)
                })
            }) {
                Err(status) => (status, 0, Opcode::Unknown(0), false),
                Ok(AsciiCommand::Binary) => (Status::Ok, 0, Opcode::Unknown(0), true),
                Ok(AsciiCommand::Run) => self.ascii_exec(Command::RunApplication { from: None }, now),
                Ok(AsciiCommand::Stop) => self.ascii_exec(Command::StopApplication, now),
                Ok(AsciiCommand::Instruction(i)) if !self.spec.commands.contains(i.opcode) => {
                    (Status::InvalidCommand, i.value, i.opcode, false)
                }
                Ok(AsciiCommand::Instruction(i)) if !self.spec.ascii_commands.contains(i.opcode) => {
                    (Status::NotAvailable, i.value, i.opcode, false)
                }
                Ok(AsciiCommand::Instruction(i)) => match self.decode_host(i) {
                    Ok(c) => self.ascii_exec(c, now),
                    Err(status) => (status, i.value, i.opcode, false),
                },
            }
        };
        // §5.1 GP 255 applies to ASCII replies as well (GAP, GGP, GIO always answer).
        let Some(iface) = self.interface(port) else { return };
        if !self.suppressed(iface, opcode.code()) {
            let mut text: Text<32> = Text::new();
            let _ = write_reply(&mut text, self.host_address(), self.address(), status, value);
            let due = self.reply_due(iface, now);
            self.st.ports[port].outbox.push(text.bytes(), due);
        }
        if leave {
            self.st.ports[port].ascii.active = false;
            self.st.ports[port].framer.clear();
        }
    }

    fn ascii_exec(&mut self, c: Command, now: Instant) -> (Status, i32, Opcode, bool) {
        let opcode = c.encode().opcode;
        match self.exec(c, now, Origin::Host) {
            Ok(Outcome::Value(v)) | Ok(Outcome::Restart(v)) => (Status::Ok, v, opcode, false),
            Ok(Outcome::Raw(_)) | Ok(Outcome::Silent) | Ok(Outcome::EnterAscii) => (Status::Ok, 0, opcode, false),
            Err(s) => (s, c.encode().value, opcode, false),
        }
    }

    /// Switches interface `port` to ASCII mode (command 139, or GP 67 bit 0 at start-up).
    pub(crate) fn enter_ascii(&mut self, port: usize) {
        if let Some(p) = self.st.ports.get_mut(port) {
            p.ascii = AsciiLine { active: true, ..AsciiLine::default() };
            p.framer.clear();
        }
    }
}

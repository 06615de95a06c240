//! The ASCII command interface (PD28-1021 manual §3.4): entered with command 139 or at start-up when
//! GP 67 bit 0 is set, left with `BIN`; per host interface, on the interfaces whose model allows it.
//!
//! A line is the address character (`A` = address 1, …), optional spaces, a command in the assembler's
//! syntax, and `<CR>`. Only the direct-mode commands §3.4 lists are executed; `RUN` and `STOP` control
//! the stored program. The reply is `<host char><module char> <status> <value><CR>`, e.g. `BA 100 -5000`.
//! Echo follows GP 67 bits 4/5 (§3.4.4).
//!
//! Decisions (the manual is silent; docs/decisions.md):
//! - Lines for another address are ignored whole: no echo, no reply. A lower-case address character
//!   counts as the upper-case one. Addresses above 26 have no character and cannot be reached in ASCII.
//! - Echo mode `00` echoes each character once the line's address character matched, a backspace as
//!   `BS SP BS` (erasing it on a terminal), and the closing `<CR>`; `01` echoes the whole line and `<CR>`
//!   after `<CR>`; `10` and the undefined `11` do not echo. `<LF>` is ignored (terminals that send CR LF).
//! - Every line addressed to the module that reaches its `<CR>` gets a reply: a command the model lacks
//!   gets status 2, one that is not allowed in ASCII mode status 6 (command not available), a line that
//!   does not parse gets the parser's status (2 unknown command, 3 bad type word, 4 bad value or
//!   operand), a line longer than [`LINE_MAX`] gets status 2.
//! - A byte that no command line holds — a control character other than CR, LF, backspace (BS or DEL)
//!   and TAB, ESC among them, or a byte from 0x80 up — discards the line typed so far, silently, and the
//!   next byte starts a new line. So the binary frames a host sends to a module in ASCII mode (they begin
//!   with the address byte 0x01…) leave no partial line in front of the `ABIN` typed after them, and ESC
//!   clears a line. Only a frame that ends in printable bytes leaves them in the way: a `<CR>` or ESC
//!   before `ABIN` clears them (docs/troubleshooting.md).
//! - `BIN` is answered (`BA 100 0`) before the module returns to binary mode; the 139 that enters ASCII
//!   mode is answered in binary before the switch. `RUN` is command 129 type 0 (from the current PC,
//!   address 0 after a start or reset), `STOP` is command 128.

use tmcl_wire::ascii::address_char;

/// The longest line the module takes (after the address character).
pub const LINE_MAX: usize = 64;

pub(crate) const CR: u8 = b'\r';
pub(crate) const LF: u8 = b'\n';
pub(crate) const BACKSPACE: u8 = 0x08;
pub(crate) const DELETE: u8 = 0x7F;
pub(crate) const TAB: u8 = b'\t';

/// The line being typed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AsciiLine {
    /// ASCII mode is on.
    pub active: bool,
    pub(crate) buf: [u8; LINE_MAX],
    pub(crate) len: usize,
    /// The line's first character, if any (0 = none yet).
    pub(crate) first: u8,
    pub(crate) overflow: bool,
}

impl Default for AsciiLine {
    fn default() -> AsciiLine {
        AsciiLine { active: false, buf: [0; LINE_MAX], len: 0, first: 0, overflow: false }
    }
}

impl AsciiLine {
    pub(crate) fn clear(&mut self) {
        self.len = 0;
        self.first = 0;
        self.overflow = false;
    }
}

/// Whether `b` discards the line being typed: a control character other than the line end, the editing
/// keys and TAB (ESC among them), or a byte above 0x7F — bytes that no §3.4.2 command line holds and that
/// binary frames sent to a module in ASCII mode are full of.
pub(crate) fn is_line_breaker(b: u8) -> bool {
    (b < 0x20 && !matches!(b, CR | LF | BACKSPACE | TAB)) || b >= 0x80
}

/// The address character of this module, for messages (`?` above 26).
pub fn module_char(address: u8) -> char {
    address_char(address).map_or('?', char::from)
}

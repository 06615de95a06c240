//! The EtherCAT slave controller (ESC): its register space, its process RAM, the SyncManagers that
//! guard the RAM, the FMMUs that map logical addresses onto it, and the datagram commands that reach it.
//!
//! What a master sees is modelled on the ET1100 that the TMCM-1310 carries (its manual §3.1: "the dual
//! port memory of the ET1100"): 8 FMMUs, 8 SyncManagers, 8 KiB of process RAM at 0x1000–0x2FFF, ports 0
//! and 1 MII. The behaviour follows Beckhoff's ET1100 datasheet and ETG.1000.4:
//!
//! - **Registers** (0x0000–0x0FFF) are bytes. A master writes only those the datasheet makes writable
//!   (station address, DL control, AL control, event mask, watchdogs, the SII interface, FMMUs, the
//!   writable SyncManager bytes, DC SYNC activation, user RAM); other writes are dropped but still count
//!   in the working counter, as on the chip. Unimplemented registers read 0; the DC block reads 0 except
//!   the SYNC activation, because this ESC advertises no DC (register 0x0008 bit 2 = 0).
//! - **Process RAM** outside an active SyncManager is plain memory. Inside one, the SyncManager decides
//!   (manual §3.1): an access must begin at the buffer's start address, otherwise it is denied; it ends
//!   when the last byte is accessed, in the same frame or a later one (the ESC detects a buffer change by
//!   its first and last byte, ET1100 datasheet section I §8.9, and "the time it takes to read or write
//!   the mailbox does not matter", §8.2: a master may split a mailbox over several frames). In **mailbox** mode a write is denied while the mailbox is full and
//!   a read while it is empty; in **buffered** (3-buffer) mode the master always gets the latest complete
//!   buffer and a write only becomes visible to the application when it reaches the end. A denied access
//!   leaves data and working counter alone. Access in the wrong direction (reading a buffer the master
//!   writes) is denied, and so is any access to the buffer of a SyncManager the master enabled but the
//!   application switched off (the ET1100's SyncManager then locks its memory area).
//! - **Working counter** (ETG.1000.4): +1 for a successful read, +1 for a write, +1/+2/+3 for the read,
//!   write or both of a read/write command; a logical command counts once per direction however many
//!   FMMUs hit.
//! - **FMMUs** work byte-wise (register 0x0008 bit 0 says so); start and stop bits are stored and ignored.
//!
//! The application side (the "PDI": here the TMCL firmware) takes and puts mailbox messages and
//! process-data buffers through the `*_mailbox`, `take_outputs` and `put_inputs` methods, and switches
//! SyncManagers off and on as the AL state requires (ET1100 SM "PDI control" bit 0).

use crate::register as reg;
use crate::wire::datagram::{Addressing, Command, Datagram, MAX_DATA};

/// Size of the register space.
pub const REGISTER_SPACE: usize = 0x1000;
/// Size of the process RAM (8 KiB, as the ET1100).
pub const RAM_LEN: usize = 0x2000;
/// First address past the ESC's memory.
pub const MEMORY_END: u32 = (REGISTER_SPACE + RAM_LEN) as u32;
/// Number of FMMUs.
pub const FMMUS: usize = 8;
/// Number of SyncManagers.
pub const SMS: usize = 8;

/// ESC type (register 0x0000): 0x11, the ET1100 the TMCM-1310 carries (its manual §3.1).
pub const ESC_TYPE: u8 = 0x11;
/// ESC revision (register 0x0001): 0x00, the revision of every ET1100 (Beckhoff EtherCAT slave controller
/// datasheet, section II "Register description", register 0x0001, with section III, ET1100).
pub const ESC_REVISION: u8 = 0x00;
/// ESC build (registers 0x0002–0x0003): 0x0003, the ET1100-0003, the chip version current when the
/// TMCM-1310's firmware V1.14 was released (the datasheet's section I revision history introduces it
/// with version 2.1; section II, register 0x0002, "Build": the chip version's number).
pub const ESC_BUILD: u16 = 0x0003;

/// The run-time state of a SyncManager beside its registers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct SmState {
    /// The application switched it off (PDI control bit 0).
    pdi_off: bool,
    /// An access began at the start address and has not reached the end yet (in this frame or an
    /// earlier one).
    open: bool,
    /// Mailbox: the buffer is full.
    full: bool,
    /// Buffered, master writes: a complete buffer the application has not taken yet.
    fresh: bool,
    /// Buffered: the buffer written last (0..3), 3 = none yet.
    buffer: u8,
    /// The repeat acknowledge the application gave last (PDI control bit 1).
    repeat_ack: bool,
}

impl SmState {
    const OFF: SmState =
        SmState { pdi_off: true, open: false, full: false, fresh: false, buffer: 3, repeat_ack: false };
}

/// Register writes and buffer events the application has to act on, collected since the last
/// [`Esc::take_events`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Events {
    /// AL control (0x0120) was written.
    pub al_control: bool,
    /// The SII command byte (0x0503) was written.
    pub sii_command: bool,
    /// The process-data watchdog time (0x0420) was written.
    pub watchdog_time: bool,
    /// SyncManagers (bit n) whose repeat request bit toggled.
    pub repeat: u8,
    /// SyncManagers (bit n) whose buffer the master completed: a mailbox written, or a process-data
    /// buffer written.
    pub written: u8,
    /// SyncManagers (bit n) whose buffer the master read completely (a mailbox emptied).
    pub read: u8,
}

/// The ESC's memory and SyncManager state.
#[derive(Clone, PartialEq, Eq)]
pub struct Esc {
    regs: [u8; REGISTER_SPACE],
    ram: [u8; RAM_LEN],
    sm: [SmState; SMS],
    events: Events,
}

impl core::fmt::Debug for Esc {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Esc")
            .field("station", &self.reg16(reg::STATION_ADDRESS))
            .field("al_status", &self.reg16(reg::AL_STATUS))
            .finish_non_exhaustive()
    }
}

impl Default for Esc {
    fn default() -> Esc {
        Esc::new()
    }
}

impl Esc {
    /// The ESC after power-on: identity registers set, every SyncManager off, watchdogs at the
    /// ET1100's defaults (100 µs ticks, 100 ms process-data watchdog).
    pub fn new() -> Esc {
        let mut esc =
            Esc { regs: [0; REGISTER_SPACE], ram: [0; RAM_LEN], sm: [SmState::OFF; SMS], events: Events::default() };
        esc.regs[usize::from(reg::TYPE)] = ESC_TYPE;
        esc.regs[usize::from(reg::REVISION)] = ESC_REVISION;
        esc.set_reg16(reg::BUILD, ESC_BUILD);
        esc.regs[usize::from(reg::FMMU_COUNT)] = FMMUS as u8;
        esc.regs[usize::from(reg::SM_COUNT)] = SMS as u8;
        esc.regs[usize::from(reg::RAM_SIZE)] = (RAM_LEN / 1024) as u8;
        // Ports 0 and 1 MII, 2 and 3 not implemented.
        esc.regs[usize::from(reg::PORT_DESCRIPTOR)] = 0x0F;
        // Byte-oriented FMMUs; no DC; LRW and the read/write commands supported.
        esc.set_reg16(reg::FEATURES, 0x0001);
        // DL control: non-EtherCAT frames are destroyed, all ports in auto loop mode (ET1100 default).
        esc.set_reg32(reg::DL_CONTROL, 0x0000_0001);
        // DL status: PDI operational, watchdog reloaded, port 0 with link and communication, ports 1..3
        // closed (nothing behind this slave).
        esc.set_reg16(reg::DL_STATUS, 0x0001 | 0x0002 | 0x0010 | 0x0200 | 0x0400 | 0x1000 | 0x4000);
        esc.set_reg16(reg::AL_STATUS, 0x0001);
        esc.set_reg16(reg::ECAT_EVENT_MASK, 0x0000);
        esc.set_reg16(reg::WATCHDOG_DIVIDER, 0x09C2);
        esc.set_reg16(reg::WATCHDOG_TIME_PDI, 0x03E8);
        esc.set_reg16(reg::WATCHDOG_TIME_PD, 0x03E8);
        esc.set_reg16(reg::WATCHDOG_STATUS, 0x0001);
        // SII: 8-byte reads, one address byte (an EEPROM up to 16 Kbit).
        esc.set_reg16(reg::SII_CONTROL, 0x0040);
        for n in 0..SMS {
            esc.update_sm_status(n);
        }
        esc
    }

    // ---- register access for the application (no write masks) ----

    /// A register byte (0 beyond the register space).
    pub fn reg8(&self, addr: u16) -> u8 {
        self.regs.get(usize::from(addr)).copied().unwrap_or(0)
    }

    /// A 16-bit register.
    pub fn reg16(&self, addr: u16) -> u16 {
        u16::from_le_bytes([self.reg8(addr), self.reg8(addr.wrapping_add(1))])
    }

    /// A 32-bit register.
    pub fn reg32(&self, addr: u16) -> u32 {
        u32::from(self.reg16(addr)) | u32::from(self.reg16(addr.wrapping_add(2))) << 16
    }

    /// Sets a register byte (ignored beyond the register space).
    pub fn set_reg8(&mut self, addr: u16, v: u8) {
        if let Some(r) = self.regs.get_mut(usize::from(addr)) {
            *r = v;
        }
    }

    /// Sets a 16-bit register.
    pub fn set_reg16(&mut self, addr: u16, v: u16) {
        let [a, b] = v.to_le_bytes();
        self.set_reg8(addr, a);
        self.set_reg8(addr.wrapping_add(1), b);
    }

    /// Sets a 32-bit register.
    pub fn set_reg32(&mut self, addr: u16, v: u32) {
        self.set_reg16(addr, v as u16);
        self.set_reg16(addr.wrapping_add(2), (v >> 16) as u16);
    }

    /// The events since the last call.
    pub fn take_events(&mut self) -> Events {
        core::mem::take(&mut self.events)
    }

    // ---- SyncManagers and FMMUs ----

    /// SyncManager `n`'s configuration (n < [`SMS`]).
    pub fn sm_config(&self, n: usize) -> SmConfig {
        let base = reg::SM + reg::SM_LEN * n as u16;
        SmConfig {
            start: self.reg16(base + reg::sm::START),
            length: self.reg16(base + reg::sm::LENGTH),
            control: self.reg8(base + reg::sm::CONTROL),
            activate: self.reg8(base + reg::sm::ACTIVATE),
        }
    }

    /// Whether SyncManager `n` guards its buffer now: the master enabled it, the application did not
    /// switch it off, it has a length, and its buffers lie in the process RAM.
    pub fn sm_active(&self, n: usize) -> bool {
        self.sm_guards(n) && self.sm.get(n).is_some_and(|s| !s.pdi_off)
    }

    /// Whether SyncManager `n` guards its buffer's addresses: the master enabled it with a length and its
    /// buffers lie in the process RAM. While the application has it switched off, it locks them (ET1100
    /// datasheet, SM "PDI control" bit 0: the SyncManager "locks access to the memory area").
    fn sm_guards(&self, n: usize) -> bool {
        let c = self.sm_config(n);
        c.enabled()
            && c.length > 0
            && u32::from(c.start) >= REGISTER_SPACE as u32
            && u32::from(c.start) + c.footprint() <= MEMORY_END
    }

    /// Lets SyncManager `n` work (`on`) or switches it off for the application (PDI control bit 0). Off
    /// forgets its state: a mailbox is empty again.
    pub fn set_sm_enabled(&mut self, n: usize, on: bool) {
        if let Some(s) = self.sm.get_mut(n) {
            if on {
                s.pdi_off = false;
            } else {
                *s = SmState { repeat_ack: s.repeat_ack, ..SmState::OFF };
            }
            self.update_sm_status(n);
        }
    }

    /// FMMU `n`'s configuration.
    pub fn fmmu(&self, n: usize) -> FmmuConfig {
        let base = reg::FMMU + reg::FMMU_LEN * n as u16;
        let kind = self.reg8(base + reg::fmmu::TYPE);
        FmmuConfig {
            logical_start: self.reg32(base + reg::fmmu::LOGICAL_START),
            length: self.reg16(base + reg::fmmu::LENGTH),
            physical_start: self.reg16(base + reg::fmmu::PHYSICAL_START),
            read: kind & 0x01 != 0,
            write: kind & 0x02 != 0,
            active: self.reg8(base + reg::fmmu::ACTIVATE) & 0x01 != 0,
        }
    }

    fn update_sm_status(&mut self, n: usize) {
        let c = self.sm_config(n);
        let Some(s) = self.sm.get(n).copied() else { return };
        let mut status = 0u8;
        match c.mode() {
            SmMode::Mailbox if s.full => {
                status |= 0x08;
                if c.direction() == SmDirection::MasterWrites {
                    status |= 0x01;
                }
            }
            SmMode::Buffered => {
                status |= (s.buffer & 0x03) << 4;
                if s.fresh {
                    status |= 0x01;
                }
            }
            _ => {}
        }
        let base = reg::SM + reg::SM_LEN * n as u16;
        self.set_reg8(base + reg::sm::STATUS, status);
        self.set_reg8(base + reg::sm::PDI_CONTROL, u8::from(s.pdi_off) | u8::from(s.repeat_ack) << 1);
    }

    // ---- the application's side of the buffers ----

    /// The message in mailbox SyncManager `n` (master writes), if it is full.
    pub fn mailbox_message(&self, n: usize) -> Option<&[u8]> {
        let c = self.sm_config(n);
        let full = self.sm.get(n).is_some_and(|s| s.full);
        if !full || !self.sm_active(n) || c.mode() != SmMode::Mailbox || c.direction() != SmDirection::MasterWrites {
            return None;
        }
        let start = usize::from(c.start) - REGISTER_SPACE;
        self.ram.get(start..start + usize::from(c.length))
    }

    /// Empties mailbox SyncManager `n` (the application has read it): the master may write again.
    pub fn release_mailbox(&mut self, n: usize) {
        if let Some(s) = self.sm.get_mut(n) {
            s.full = false;
            self.update_sm_status(n);
        }
    }

    /// Whether mailbox SyncManager `n` (master reads) is active and empty, ready for a message.
    pub fn mailbox_ready(&self, n: usize) -> bool {
        let c = self.sm_config(n);
        self.sm_active(n)
            && c.mode() == SmMode::Mailbox
            && c.direction() == SmDirection::MasterReads
            && self.sm.get(n).is_some_and(|s| !s.full)
    }

    /// Puts `message` into mailbox SyncManager `n` (master reads), zero-padded to the buffer's length, and
    /// marks it full. Returns false (and changes nothing) if the mailbox is not ready; a message longer
    /// than the buffer is cut.
    pub fn put_mailbox(&mut self, n: usize, message: &[u8]) -> bool {
        if !self.mailbox_ready(n) {
            return false;
        }
        let c = self.sm_config(n);
        let start = usize::from(c.start) - REGISTER_SPACE;
        if let Some(buffer) = self.ram.get_mut(start..start + usize::from(c.length)) {
            let k = message.len().min(buffer.len());
            buffer[..k].copy_from_slice(&message[..k]);
            buffer[k..].fill(0);
        }
        if let Some(s) = self.sm.get_mut(n) {
            s.full = true;
        }
        self.update_sm_status(n);
        true
    }

    /// Acknowledges a repeat request on SyncManager `n` (PDI control bit 1 := `bit`).
    pub fn set_repeat_ack(&mut self, n: usize, bit: bool) {
        if let Some(s) = self.sm.get_mut(n) {
            s.repeat_ack = bit;
            self.update_sm_status(n);
        }
    }

    /// Copies the complete buffer the master wrote last into buffered SyncManager `n` (master writes)
    /// into `out`, if the application has not taken it yet.
    pub fn take_outputs(&mut self, n: usize, out: &mut [u8]) -> bool {
        let c = self.sm_config(n);
        if !self.sm_active(n) || !self.sm.get(n).is_some_and(|s| s.fresh) {
            return false;
        }
        let start = usize::from(c.start) - REGISTER_SPACE;
        let k = out.len().min(usize::from(c.length));
        if let Some(b) = self.ram.get(start..start + k) {
            out[..k].copy_from_slice(b);
        }
        if let Some(s) = self.sm.get_mut(n) {
            s.fresh = false;
        }
        self.update_sm_status(n);
        true
    }

    /// Puts the application's latest inputs into buffered SyncManager `n` (master reads).
    pub fn put_inputs(&mut self, n: usize, data: &[u8]) {
        let c = self.sm_config(n);
        if !self.sm_active(n) {
            return;
        }
        let start = usize::from(c.start) - REGISTER_SPACE;
        let k = data.len().min(usize::from(c.length));
        if let Some(b) = self.ram.get_mut(start..start + k) {
            b.copy_from_slice(&data[..k]);
        }
        if let Some(s) = self.sm.get_mut(n) {
            s.buffer = if s.buffer >= 2 { 0 } else { s.buffer + 1 };
        }
        self.update_sm_status(n);
    }

    // ---- the master's side ----

    /// Executes one datagram that reached this slave: addresses it, reads or writes, adds to its working
    /// counter, and increments the position of auto-increment commands. Unknown commands pass unchanged.
    pub fn execute<T: AsRef<[u8]> + AsMut<[u8]>>(&mut self, d: &mut Datagram<T>) {
        let command = d.command();
        let adp = d.adp();
        let ado = d.ado();
        let mut wkc = 0u16;
        match command.addressing() {
            Addressing::AutoIncrement => {
                d.set_adp(adp.wrapping_add(1));
                wkc = self.physical(command, adp == 0, ado, d.data_mut());
            }
            Addressing::Configured => {
                let alias_on = self.reg8(reg::DL_CONTROL + 3) & 0x01 != 0;
                let me = adp == self.reg16(reg::STATION_ADDRESS) || (alias_on && adp == self.reg16(reg::STATION_ALIAS));
                wkc = self.physical(command, me, ado, d.data_mut());
            }
            Addressing::Broadcast => {
                // Every slave increments the position of a broadcast too (ETG.1000.4, "Broadcast
                // read/write": "ADP ... incremented by each slave"), so a master can count slaves in it.
                d.set_adp(adp.wrapping_add(1));
                wkc = self.physical(command, true, ado, d.data_mut());
            }
            Addressing::Logical => {
                let address = d.address();
                let (read, write) = self.logical(address, d.data_mut(), command.reads(), command.writes());
                wkc = u16::from(read)
                    + if write {
                        if command == Command::Lrw {
                            2
                        } else {
                            1
                        }
                    } else {
                        0
                    };
            }
            Addressing::None => {}
        }
        if wkc != 0 {
            d.set_wkc(d.wkc().wrapping_add(wkc));
        }
    }

    /// A physical-address command at `ado`; `addressed`: this slave is the one ADP names. Returns the
    /// working-counter increment.
    fn physical(&mut self, command: Command, addressed: bool, ado: u16, data: &mut [u8]) -> u16 {
        match command {
            // ARMW/FRMW: the addressed slave reads, every other one writes (ETG.1000.4).
            Command::Armw | Command::Frmw if addressed => u16::from(self.ecat_read(ado, data, false)),
            Command::Armw | Command::Frmw => u16::from(self.ecat_write(ado, data)),
            _ if !addressed => 0,
            Command::Aprd | Command::Fprd => u16::from(self.ecat_read(ado, data, false)),
            Command::Brd => u16::from(self.ecat_read(ado, data, true)),
            Command::Apwr | Command::Fpwr | Command::Bwr => u16::from(self.ecat_write(ado, data)),
            Command::Aprw | Command::Fprw | Command::Brw => {
                // Read the old contents, write the new ones, then hand the old ones back (ORed for BRW).
                let mut old = [0u8; MAX_DATA];
                let n = data.len().min(MAX_DATA);
                let read = self.ecat_read(ado, &mut old[..n], false);
                let written = self.ecat_write(ado, &data[..n]);
                if read {
                    for (d, o) in data.iter_mut().zip(&old[..n]) {
                        *d = if command == Command::Brw { *d | *o } else { *o };
                    }
                }
                u16::from(read) + if written { 2 } else { 0 }
            }
            _ => 0,
        }
    }

    /// A logical command: writes through every active write FMMU, then reads through every active read
    /// FMMU. Returns (a read succeeded, a write succeeded).
    fn logical(&mut self, address: u32, data: &mut [u8], read: bool, write: bool) -> (bool, bool) {
        let (mut read_ok, mut write_ok) = (false, false);
        let start = u64::from(address);
        let end = start + data.len() as u64;
        for pass_write in [true, false] {
            if (pass_write && !write) || (!pass_write && !read) {
                continue;
            }
            for n in 0..FMMUS {
                let f = self.fmmu(n);
                if !f.active || f.length == 0 || (pass_write && !f.write) || (!pass_write && !f.read) {
                    continue;
                }
                let f_start = u64::from(f.logical_start);
                let lo = start.max(f_start);
                let hi = end.min(f_start + u64::from(f.length));
                if lo >= hi {
                    continue;
                }
                let physical = u64::from(f.physical_start) + (lo - f_start);
                if physical > u64::from(u16::MAX) {
                    continue;
                }
                let range = (lo - start) as usize..(hi - start) as usize;
                if pass_write {
                    write_ok |= self.ecat_write(physical as u16, &data[range]);
                } else {
                    read_ok |= self.ecat_read(physical as u16, &mut data[range], false);
                }
            }
        }
        (read_ok, write_ok)
    }

    /// The active SyncManager whose buffer begins first among those that intersect `[from, to)`:
    /// (index, start, end).
    fn sm_in(&self, from: u32, to: u32) -> Option<(usize, u32, u32)> {
        (0..SMS)
            .filter(|&n| self.sm_guards(n))
            .map(|n| {
                let c = self.sm_config(n);
                (n, u32::from(c.start), c.end())
            })
            .filter(|&(_, s, e)| s < to && e > from)
            .min_by_key(|&(_, s, _)| s.max(from))
    }

    /// The stretch of the memory that begins at `a` (below [`MEMORY_END`]) and what lies there, at most
    /// `rest` bytes long: registers, a SyncManager's buffer the access starts in, or plain process RAM up
    /// to the next buffer. Never empty.
    fn segment(&self, a: u32, rest: u32) -> (Segment, usize) {
        if a < REGISTER_SPACE as u32 {
            return (Segment::Registers, rest.min(REGISTER_SPACE as u32 - a) as usize);
        }
        let to = (a + rest).min(MEMORY_END);
        match self.sm_in(a, to) {
            Some((sm, s, e)) if s <= a => (Segment::Sm(sm), (e.min(to) - a) as usize),
            hit => (Segment::Ram, (hit.map_or(to, |(_, s, _)| s) - a) as usize),
        }
    }

    /// The master reads `out.len()` bytes at `addr` (ORed into `out` for a broadcast). Returns whether
    /// any byte was read.
    pub fn ecat_read(&mut self, addr: u16, out: &mut [u8], or: bool) -> bool {
        let mut ok = false;
        let mut i = 0usize;
        while i < out.len() {
            let a = u32::from(addr) + i as u32;
            if a >= MEMORY_END {
                break;
            }
            let (segment, n) = self.segment(a, (out.len() - i) as u32);
            let out = &mut out[i..i + n];
            ok |= match segment {
                Segment::Registers => {
                    for (k, o) in out.iter_mut().enumerate() {
                        put(o, self.read_register(a as usize + k), or);
                    }
                    true
                }
                Segment::Sm(sm) => self.sm_read(sm, a, out, or),
                Segment::Ram => {
                    let r = a as usize - REGISTER_SPACE;
                    out.iter_mut().zip(&self.ram[r..r + n]).for_each(|(o, &v)| put(o, v, or));
                    true
                }
            };
            i += n.max(1);
        }
        ok
    }

    /// The master writes `data` at `addr`. Returns whether any byte was accepted (a write to a
    /// read-only register counts: the chip drops it but answers).
    pub fn ecat_write(&mut self, addr: u16, data: &[u8]) -> bool {
        let mut ok = false;
        let mut i = 0usize;
        while i < data.len() {
            let a = u32::from(addr) + i as u32;
            if a >= MEMORY_END {
                break;
            }
            let (segment, n) = self.segment(a, (data.len() - i) as u32);
            let data = &data[i..i + n];
            ok |= match segment {
                Segment::Registers => {
                    for (k, &v) in data.iter().enumerate() {
                        self.write_register(a as u16 + k as u16, v);
                    }
                    true
                }
                Segment::Sm(sm) => self.sm_write(sm, a, data),
                Segment::Ram => {
                    let r = a as usize - REGISTER_SPACE;
                    self.ram[r..r + n].copy_from_slice(data);
                    true
                }
            };
            i += n.max(1);
        }
        ok
    }

    /// The start-address rule (manual §3.1): an access must begin at the buffer's start; once begun, it
    /// may go on anywhere in the buffer, in this frame or a later one, until the last byte ends it.
    fn begin(&mut self, n: usize, at: u32, start: u16) -> bool {
        let s = &mut self.sm[n];
        if at == u32::from(start) {
            s.open = true;
        }
        s.open
    }

    fn sm_read(&mut self, n: usize, a: u32, out: &mut [u8], or: bool) -> bool {
        let c = self.sm_config(n);
        if c.direction() != SmDirection::MasterReads || self.sm[n].pdi_off {
            return false;
        }
        match c.mode() {
            SmMode::Mailbox if !self.sm[n].full => return false,
            SmMode::Mailbox | SmMode::Buffered => {}
            SmMode::Reserved(_) => return false,
        }
        if !self.begin(n, a, c.start) {
            return false;
        }
        let (r, len) = (a as usize - REGISTER_SPACE, out.len());
        out.iter_mut().zip(&self.ram[r..r + len]).for_each(|(o, &v)| put(o, v, or));
        if a + out.len() as u32 == c.end() {
            self.sm[n].open = false;
            if c.mode() == SmMode::Mailbox {
                self.sm[n].full = false;
                self.events.read |= 1 << n;
            }
            self.update_sm_status(n);
        }
        true
    }

    fn sm_write(&mut self, n: usize, a: u32, data: &[u8]) -> bool {
        let c = self.sm_config(n);
        if c.direction() != SmDirection::MasterWrites || self.sm[n].pdi_off {
            return false;
        }
        match c.mode() {
            SmMode::Mailbox if self.sm[n].full => return false,
            SmMode::Mailbox | SmMode::Buffered => {}
            SmMode::Reserved(_) => return false,
        }
        if !self.begin(n, a, c.start) {
            return false;
        }
        let offset = (a - u32::from(c.start)) as usize;
        let base = usize::from(c.start) - REGISTER_SPACE;
        // Mailbox: straight into the buffer. Buffered: into the next buffer (the second third of the
        // SyncManager's footprint), which becomes the visible one only when complete.
        let at = match c.mode() {
            SmMode::Mailbox => base + offset,
            _ => base + usize::from(c.length) + offset,
        };
        self.ram[at..at + data.len()].copy_from_slice(data);
        if a + data.len() as u32 == c.end() {
            let s = &mut self.sm[n];
            s.open = false;
            match c.mode() {
                SmMode::Mailbox => s.full = true,
                _ => {
                    s.fresh = true;
                    s.buffer = if s.buffer >= 2 { 0 } else { s.buffer + 1 };
                    let len = usize::from(c.length);
                    self.ram.copy_within(base + len..base + 2 * len, base);
                }
            }
            self.events.written |= 1 << n;
            self.update_sm_status(n);
        }
        true
    }

    fn read_register(&self, a: usize) -> u8 {
        let a16 = a as u16;
        if (reg::DC_START..=reg::DC_END).contains(&a16)
            && a16 != reg::DC_CYCLIC_CONTROL
            && a16 != reg::DC_SYNC_ACTIVATION
        {
            return 0;
        }
        self.regs[a]
    }

    /// One register byte written by the master, with the ET1100's write permissions.
    fn write_register(&mut self, a: u16, v: u8) {
        let i = usize::from(a);
        match a {
            0x0010..=0x0011 | 0x0100..=0x0103 | 0x0108..=0x0109 | 0x0121 | 0x0138..=0x0139 | 0x0200..=0x0201 => {
                self.regs[i] = v
            }
            // The 8 FMMUs this ESC has (FMMUs 8–15, 0x0680–0x06FF, are not implemented).
            0x0400..=0x0401 | 0x0410..=0x0411 | 0x0504..=0x050F | 0x0600..=0x067F => self.regs[i] = v,
            0x0980..=0x0981 | 0x0F80..=0x0FFF => self.regs[i] = v,
            reg::AL_CONTROL => {
                self.regs[i] = v;
                self.events.al_control = true;
            }
            // Error counters and the watchdog counter: a write clears them.
            0x0300..=0x0313 | 0x0442..=0x0443 => self.regs[i] = 0,
            0x0420..=0x0421 => {
                self.regs[i] = v;
                self.events.watchdog_time = true;
            }
            reg::SII_CONFIGURATION => self.regs[i] = v & 0x03,
            // SII control: only the write enable (bit 0) and the command (bits 8..11) are the master's.
            0x0502 => self.regs[i] = (self.regs[i] & !0x01) | (v & 0x01),
            0x0503 => {
                self.regs[i] = (self.regs[i] & !0x07) | (v & 0x07);
                self.events.sii_command = true;
            }
            // The 8 SyncManagers this ESC has (0x0840–0x087F, SyncManagers 8–15, are not implemented).
            0x0800..=0x083F => {
                let n = usize::from((a - reg::SM) / reg::SM_LEN);
                match (a - reg::SM) % reg::SM_LEN {
                    0..=4 => self.regs[i] = v,
                    6 => {
                        let old = self.regs[i];
                        self.regs[i] = v;
                        if (old ^ v) & 0x01 != 0 {
                            // Enabling or disabling a SyncManager starts its buffer afresh.
                            let s = &mut self.sm[n];
                            *s = SmState { pdi_off: s.pdi_off, repeat_ack: s.repeat_ack, ..SmState::OFF };
                        }
                        if (old ^ v) & 0x02 != 0 {
                            self.events.repeat |= 1 << n;
                        }
                    }
                    _ => {} // status and PDI control belong to the ESC and the application
                }
                self.update_sm_status(n);
            }
            _ => {} // read-only or not implemented
        }
    }

    /// Bytes of the process RAM, for tests and diagnostics (`addr` ≥ 0x1000).
    pub fn ram(&self, addr: u16, len: usize) -> &[u8] {
        let start = usize::from(addr).saturating_sub(REGISTER_SPACE);
        self.ram.get(start..start + len).unwrap_or(&[])
    }

    /// The SII data register as the application sees it (for the EEPROM emulation).
    pub(crate) fn sii_data_mut(&mut self) -> &mut [u8] {
        let at = usize::from(reg::SII_DATA);
        &mut self.regs[at..at + 8]
    }
}

mod config;
pub use config::{FmmuConfig, SmConfig, SmDirection, SmMode};

/// What lies at an address of the ESC's memory (see `Esc::segment`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Segment {
    /// The register space, 0x0000..0x1000.
    Registers,
    /// The buffer of SyncManager n.
    Sm(usize),
    /// Process RAM outside every buffer.
    Ram,
}

/// A byte the master reads: ORed into what the frame carries for a broadcast read, set otherwise.
fn put(o: &mut u8, v: u8, or: bool) {
    *o = if or { *o | v } else { v };
}

#[cfg(test)]
mod tests;

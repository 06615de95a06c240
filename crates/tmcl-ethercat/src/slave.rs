//! The slave: the ESC, its EEPROM and the firmware's EtherCAT side, wrapped around a TMCL [`Module`].
//!
//! [`Slave::process`] takes one Ethernet frame that arrived at `now` and turns it, in place, into the
//! frame that goes back: every datagram executed in order with its working counter, side effects of
//! register writes carried out after each datagram (AL control, the SII command, a mailbox repeat), then
//! the firmware's turn at the end of the frame (a request in SM0 executed on the module and its reply put
//! in SM1; new outputs applied in OP; a waiting SAFE-OP → OP completed). A frame that is not EtherCAT, or
//! whose datagram chain is broken, is refused before anything changes: `None`, no answer.
//! [`Slave::poll`] lets time pass: the process-data watchdog, the wait for outputs before OP, and the
//! module's late messages on the mailbox (a command-138 event).
//!
//! The module is borrowed per call, so the same module can serve its USB port between two frames (the
//! `tmcl` command line does exactly that). Nothing here reads a clock or allocates.

use crate::al::{self, AlState, AlStatus, AlStatusCode, Decision, Step};
use crate::eeprom::{Eeprom, RestoreError, Volatile};
use crate::esc::{Esc, SmDirection, SmMode};
use crate::foe::{FileStore, Foe};
use crate::layout::{self, SmLayout, FOE_DATA, MAILBOX_IN, MAILBOX_OUT, OUTPUTS};
use crate::pdo::{self, Outputs, MAX_INPUTS_LEN, OUTPUTS_LEN};
use crate::register as reg;
use crate::wire::datagram::{Command, Datagram};
use crate::wire::ethernet::{self, ETHERTYPE_ETHERCAT};
use crate::wire::frame::{self, FrameType};
use crate::wire::{foe as foe_wire, mailbox};
use tmcl_core::hal::{Board, Nvm};
use tmcl_core::model::{EtherCatDesc, InterfaceKind, ModelSpec};
use tmcl_core::module::MAILBOX_LEN;
use tmcl_core::{Duration, Instant, Module};

/// How long SAFE-OP → OP waits for the first valid outputs before it is refused with 0x0019 (no valid
/// outputs). Our choice: the manual asks for valid outputs first and gives no time.
pub const OUTPUT_WAIT: Duration = Duration::from_millis(1000);

/// Mailbox messages (8-byte TMCL replies, or BOOT replies) waiting for SM1.
const QUEUE: usize = 8;
/// The longest message SM1 takes.
const REPLY_LEN: usize = MAILBOX_IN.length as usize;

/// A message for SM1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Message {
    bytes: [u8; REPLY_LEN],
    len: usize,
}

impl Message {
    fn new(bytes: &[u8]) -> Message {
        let mut m = Message { bytes: [0; REPLY_LEN], len: bytes.len().min(REPLY_LEN) };
        m.bytes[..m.len].copy_from_slice(&bytes[..m.len]);
        m
    }
}

/// A bounded queue of messages for SM1, and the reassembly of the module's 8-byte replies (its outbox
/// may hand one over in two pieces).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Replies {
    items: [Message; QUEUE],
    head: usize,
    len: usize,
    partial: [u8; MAILBOX_LEN],
    partial_len: usize,
}

impl Replies {
    const EMPTY: Replies = Replies {
        items: [Message { bytes: [0; REPLY_LEN], len: 0 }; QUEUE],
        head: 0,
        len: 0,
        partial: [0; MAILBOX_LEN],
        partial_len: 0,
    };

    fn push(&mut self, m: Message) {
        if self.len < QUEUE {
            self.items[(self.head + self.len) % QUEUE] = m;
            self.len += 1;
        }
    }

    /// Bytes from the module's mailbox interface: cut into 8-byte messages.
    fn push_tmcl(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() {
            let k = (MAILBOX_LEN - self.partial_len).min(bytes.len());
            self.partial[self.partial_len..self.partial_len + k].copy_from_slice(&bytes[..k]);
            self.partial_len += k;
            bytes = &bytes[k..];
            if self.partial_len == MAILBOX_LEN {
                self.partial_len = 0;
                let m = Message::new(&self.partial);
                self.push(m);
            }
        }
    }

    /// Puts a message back at the front (a repeat took it out of SM1 again).
    fn push_front(&mut self, m: Message) {
        if self.len < QUEUE {
            self.head = (self.head + QUEUE - 1) % QUEUE;
            self.items[self.head] = m;
            self.len += 1;
        }
    }

    fn pop(&mut self) -> Option<Message> {
        if self.len == 0 {
            return None;
        }
        let m = self.items[self.head];
        self.head = (self.head + 1) % QUEUE;
        self.len -= 1;
        Some(m)
    }

    fn room(&self) -> usize {
        QUEUE - self.len
    }
}

/// The model has no EtherCAT mailbox interface, or no EtherCAT description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NoEtherCat;

impl core::fmt::Display for NoEtherCat {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the model has no EtherCAT interface")
    }
}

impl core::error::Error for NoEtherCat {}

/// Why a slave with a store could not be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoreError<E> {
    /// The model has no EtherCAT interface.
    NoEtherCat,
    /// The SII store could not be read back.
    Restore(RestoreError<E>),
}

impl<E: core::fmt::Debug> core::fmt::Display for StoreError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StoreError::NoEtherCat => NoEtherCat.fmt(f),
            StoreError::Restore(e) => e.fmt(f),
        }
    }
}

impl<E: core::fmt::Debug> core::error::Error for StoreError<E> {}

/// The EtherCAT slave of one module; `S` keeps the words a master writes into the SII EEPROM (see
/// [`crate::eeprom`]: [`Volatile`] keeps nothing).
#[derive(Clone, PartialEq, Eq)]
pub struct Slave<S = Volatile> {
    esc: Esc,
    eeprom: Eeprom,
    /// Where SII writes go before they count.
    store: S,
    /// SII words restored from the store at power-on.
    restored: usize,
    /// The model's identity and process-data map.
    map: &'static EtherCatDesc,
    /// SM3, the inputs, as long as the map's.
    inputs: SmLayout,
    status: AlStatus,
    /// The module's EtherCAT mailbox interface.
    port: usize,
    replies: Replies,
    /// The messages put in SM1 last and the one before (a repeat request puts the one the master lost
    /// there again).
    last_reply: Option<Message>,
    previous_reply: Option<Message>,
    foe: Foe,
    /// Mailbox counter of the slave's BOOT replies (1..7).
    counter: u8,
    /// The outputs the master wrote last, and whether any arrived since SAFE-OP was entered.
    outputs: Option<Outputs>,
    outputs_valid: bool,
    /// The outputs applied last in OP, and whether they commanded the motor since OP was entered.
    applied: Option<Outputs>,
    commanded: bool,
    /// SAFE-OP → OP waits for outputs until then.
    await_outputs: Option<Instant>,
    /// The process-data watchdog expires then (OP only).
    watchdog_due: Option<Instant>,
}

impl<S> core::fmt::Debug for Slave<S> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Slave").field("status", &self.status).field("esc", &self.esc).finish_non_exhaustive()
    }
}

impl Slave {
    /// The slave of a module of model `spec`, as after power-on: INIT, its EEPROM generated from the
    /// model and loaded; what a master writes into the EEPROM lasts as long as the slave.
    pub fn new(spec: &'static ModelSpec) -> Result<Slave, NoEtherCat> {
        Slave::with_store(spec, Volatile).map_err(|_| NoEtherCat)
    }
}

impl<S: Nvm> Slave<S> {
    /// The slave of a module of model `spec`, as after power-on, whose SII writes go to `store` (at
    /// least [`crate::eeprom::SII_STORE_LEN`] bytes): the EEPROM generated from the model with the words
    /// kept in `store` laid over it, then loaded (the station alias among them).
    pub fn with_store(spec: &'static ModelSpec, mut store: S) -> Result<Slave<S>, StoreError<S::Error>> {
        let port = spec
            .interfaces
            .iter()
            .position(|i| i.kind == InterfaceKind::EtherCatMailbox)
            .ok_or(StoreError::NoEtherCat)?;
        let map = spec.ethercat.ok_or(StoreError::NoEtherCat)?;
        let mut eeprom = Eeprom::for_model(spec, map);
        let restored = eeprom.restore(&mut store).map_err(StoreError::Restore)?;
        let mut slave = Slave {
            esc: Esc::new(),
            eeprom,
            store,
            restored,
            map,
            inputs: layout::inputs(map),
            status: AlStatus::INIT,
            port,
            replies: Replies::EMPTY,
            last_reply: None,
            previous_reply: None,
            foe: Foe::Idle,
            counter: 0,
            outputs: None,
            outputs_valid: false,
            applied: None,
            commanded: false,
            await_outputs: None,
            watchdog_due: None,
        };
        slave.eeprom.load_into(&mut slave.esc, true);
        slave.write_status();
        Ok(slave)
    }

    /// The AL status.
    pub fn status(&self) -> AlStatus {
        self.status
    }

    /// The ESC (registers and RAM).
    pub fn esc(&self) -> &Esc {
        &self.esc
    }

    /// The SII EEPROM.
    pub fn eeprom(&self) -> &Eeprom {
        &self.eeprom
    }

    /// How many SII words a master had written before, restored from the store at power-on.
    pub fn restored_words(&self) -> usize {
        self.restored
    }

    /// The store of SII writes.
    pub fn store(&self) -> &S {
        &self.store
    }

    /// The store of SII writes, to sync it (a file store's `sync`).
    pub fn store_mut(&mut self) -> &mut S {
        &mut self.store
    }

    /// The SyncManagers the slave expects: the mailboxes, the outputs and the inputs of its map.
    pub fn sync_managers(&self) -> [SmLayout; 4] {
        layout::sync_managers(self.map)
    }

    /// The model's identity and process-data map.
    pub fn map(&self) -> &'static EtherCatDesc {
        self.map
    }

    /// The module interface the mailbox serves.
    pub fn port(&self) -> usize {
        self.port
    }

    /// Processes one Ethernet frame that arrived at `now`, in place. Returns the length of the answer (the
    /// frame as it goes back, same length) or `None` for a frame that is not EtherCAT or is broken,
    /// which changes nothing.
    pub fn process<B: Board>(
        &mut self,
        now: Instant,
        bytes: &mut [u8],
        module: &mut Module<B>,
        files: &mut impl FileStore,
    ) -> Option<usize> {
        let len = bytes.len();
        let mut eth = ethernet::Frame::new_checked(&mut *bytes).ok()?;
        if eth.ethertype() != ETHERTYPE_ETHERCAT {
            return None;
        }
        let ecat = frame::Frame::new_checked(eth.payload()).ok()?;
        if ecat.frame_type() != FrameType::Datagrams || ecat.check_datagrams().is_err() {
            return None;
        }
        let reads_inputs = self.reads_inputs(&ecat);
        // From here on the frame is sound: it may change things.
        self.tick(now, module);
        if reads_inputs {
            self.refresh_inputs(module);
        }
        let mut ecat = frame::Frame::new_unchecked(eth.payload_mut());
        let region = ecat.datagrams_mut();
        let mut at = 0;
        while let Some(mut d) = region.get_mut(at..).and_then(|b| Datagram::new_checked(b).ok()) {
            at += d.total_len();
            let more = d.more();
            self.esc.execute(&mut d);
            self.after_datagram(now, module, files);
            if !more {
                break;
            }
        }
        self.firmware(now, module, files);
        eth.mark_processed();
        Some(len)
    }

    /// Lets time pass to `now`: the watchdog, the wait for outputs, the module's late messages on the
    /// mailbox. Returns when the slave or the module next needs to run.
    pub fn poll<B: Board>(
        &mut self,
        now: Instant,
        module: &mut Module<B>,
        files: &mut impl FileStore,
    ) -> Option<Instant> {
        let module_next = self.tick(now, module);
        self.firmware(now, module, files);
        [module_next, self.await_outputs, self.watchdog_due].into_iter().flatten().min()
    }

    /// Advances the module, takes its late mailbox messages, and runs the timers. Returns the module's
    /// next deadline.
    fn tick<B: Board>(&mut self, now: Instant, module: &mut Module<B>) -> Option<Instant> {
        let replies = &mut self.replies;
        let mailbox = matches!(self.status.state, AlState::PreOp | AlState::SafeOp | AlState::Op);
        let next = module.poll_port(self.port, now, &mut |b: &[u8]| {
            if mailbox {
                replies.push_tmcl(b)
            }
        });
        if self.await_outputs.is_some_and(|t| t <= now) {
            self.await_outputs = None;
            self.refuse(AlStatusCode::NoValidOutputs);
        }
        if self.status.state == AlState::Op && self.watchdog_due.is_some_and(|t| t <= now) {
            // ETG.1000.6: an expired process-data watchdog takes the slave to SAFE-OP with 0x001B.
            self.enter(AlState::SafeOp, now, module);
            self.refuse(AlStatusCode::SmWatchdog);
            self.esc.set_reg16(reg::WATCHDOG_STATUS, 0);
            let count = self.esc.reg8(reg::WATCHDOG_COUNTER_PD);
            self.esc.set_reg8(reg::WATCHDOG_COUNTER_PD, count.saturating_add(1));
        }
        next
    }

    /// Whether a frame reads the input buffer: any logical read, or a physical read that touches SM3.
    fn reads_inputs(&self, ecat: &frame::Frame<&[u8]>) -> bool {
        if !matches!(self.status.state, AlState::SafeOp | AlState::Op) {
            return false;
        }
        let region = ecat.datagrams();
        let inputs = u32::from(self.inputs.start)..u32::from(self.inputs.start) + u32::from(self.inputs.length);
        ecat.spans().any(|span| {
            let d = Datagram::new_unchecked(&region[span]);
            let c = d.command();
            if matches!(c, Command::Lrd | Command::Lrw) {
                return true;
            }
            let from = u32::from(d.ado());
            c.reads() && from < inputs.end && from + u32::from(d.length()) > inputs.start
        })
    }

    fn refresh_inputs<B: Board>(&mut self, module: &mut Module<B>) {
        let mut inputs = [0u8; MAX_INPUTS_LEN];
        let n = pdo::read_inputs(module, self.map, &mut inputs);
        self.esc.put_inputs(self.inputs.index, &inputs[..n]);
    }

    /// What the register writes of one datagram set off.
    fn after_datagram<B: Board>(&mut self, now: Instant, module: &mut Module<B>, files: &mut impl FileStore) {
        let events = self.esc.take_events();
        if events.sii_command {
            self.eeprom.command(&mut self.esc, &mut self.store);
        }
        if events.al_control {
            self.al_control(now, module, files);
        }
        if events.repeat & (1 << MAILBOX_IN.index) != 0 {
            self.repeat();
        }
        if events.written & (1 << OUTPUTS.index) != 0 && self.status.state == AlState::Op {
            self.watchdog_due = self.watchdog().map(|d| now + d);
        }
    }

    /// The master lost the reply it read (SOEM toggles the repeat request then, ETG.1000.4 "mailbox
    /// repeat"): put it in SM1 again. If the next reply already took its place and is still unread, that
    /// one goes back to the front of the queue.
    fn repeat(&mut self) {
        let bit = self.esc.sm_config(MAILBOX_IN.index).activate & 0x02 != 0;
        let lost = if self.esc.mailbox_ready(MAILBOX_IN.index) {
            self.last_reply
        } else if let (Some(unread), Some(lost)) = (self.last_reply, self.previous_reply) {
            self.esc.release_mailbox(MAILBOX_IN.index);
            self.replies.push_front(unread);
            self.last_reply = Some(lost);
            self.previous_reply = None;
            Some(lost)
        } else {
            None
        };
        if let Some(m) = lost {
            self.esc.put_mailbox(MAILBOX_IN.index, &m.bytes[..m.len]);
        }
        self.esc.set_repeat_ack(MAILBOX_IN.index, bit);
    }

    /// The process-data watchdog time: SM2's watchdog trigger on and a time set (ET1100: the tick is
    /// (divider + 2) × 40 ns).
    fn watchdog(&self) -> Option<Duration> {
        if !self.esc.sm_config(OUTPUTS.index).watchdog_trigger() {
            return None;
        }
        let divider = u64::from(self.esc.reg16(reg::WATCHDOG_DIVIDER));
        let ticks = u64::from(self.esc.reg16(reg::WATCHDOG_TIME_PD));
        (ticks > 0).then(|| Duration::from_micros(((divider + 2) * 40 * ticks / 1000).max(1)))
    }

    /// The firmware's turn after a frame (or a poll): requests from SM0, outputs from SM2, replies into
    /// SM1.
    fn firmware<B: Board>(&mut self, now: Instant, module: &mut Module<B>, files: &mut impl FileStore) {
        while self.replies.room() >= 2 {
            let mut request = [0u8; MAILBOX_OUT.length as usize];
            let Some(message) = self.esc.mailbox_message(MAILBOX_OUT.index) else { break };
            let n = message.len().min(request.len());
            request[..n].copy_from_slice(&message[..n]);
            self.esc.release_mailbox(MAILBOX_OUT.index);
            match self.status.state {
                AlState::PreOp | AlState::SafeOp | AlState::Op => self.tmcl(&request, now, module),
                AlState::Boot => self.boot_mailbox(&request[..n], files),
                AlState::Init => {}
            }
        }
        let mut bytes = [0u8; OUTPUTS_LEN];
        if self.esc.take_outputs(OUTPUTS.index, &mut bytes) {
            let outputs = Outputs::parse(&bytes);
            self.outputs = Some(outputs);
            self.outputs_valid = true;
            match self.status.state {
                AlState::Op => self.apply(outputs, now, module),
                AlState::SafeOp if self.await_outputs.is_some() => {
                    self.await_outputs = None;
                    self.enter(AlState::Op, now, module);
                    self.write_status();
                }
                _ => {}
            }
        }
        if self.esc.mailbox_ready(MAILBOX_IN.index) {
            if let Some(m) = self.replies.pop() {
                self.esc.put_mailbox(MAILBOX_IN.index, &m.bytes[..m.len]);
                self.previous_reply = self.last_reply.replace(m);
            }
        }
    }

    /// A TMCL request: the first 8 bytes of the buffer, raw (manual §3.5–3.6).
    fn tmcl<B: Board>(&mut self, request: &[u8], now: Instant, module: &mut Module<B>) {
        let mut message = [0u8; MAILBOX_LEN];
        message.copy_from_slice(&request[..MAILBOX_LEN]);
        let replies = &mut self.replies;
        module.request(self.port, now, &message, &mut |b: &[u8]| replies.push_tmcl(b));
    }

    /// A message in BOOT: a standard mailbox header, FoE inside.
    fn boot_mailbox(&mut self, request: &[u8], files: &mut impl FileStore) {
        let Ok(m) = mailbox::Mailbox::new_checked(request) else {
            self.mailbox_error(mailbox::ErrorDetail::InvalidSize);
            return;
        };
        if m.mailbox_type() != mailbox::MailboxType::Foe {
            self.mailbox_error(mailbox::ErrorDetail::UnsupportedProtocol);
            return;
        }
        let answer = match foe_wire::Repr::parse(m.data()) {
            Ok(message) => self.foe.handle(message, FOE_DATA, files),
            Err(_) => {
                self.mailbox_error(mailbox::ErrorDetail::InvalidHeader);
                return;
            }
        };
        if let Some(answer) = answer {
            let mut out = [0u8; REPLY_LEN];
            let Some(body) = out.get_mut(mailbox::HEADER_LEN..mailbox::HEADER_LEN + answer.buffer_len()) else {
                return;
            };
            let n = answer.emit(body);
            mailbox::Repr {
                length: n as u16,
                address: 0,
                channel: 0,
                priority: 0,
                mailbox_type: mailbox::MailboxType::Foe,
                counter: self.next_counter(),
            }
            .emit(&mut out);
            self.replies.push(Message::new(&out[..mailbox::HEADER_LEN + n]));
        }
    }

    fn mailbox_error(&mut self, detail: mailbox::ErrorDetail) {
        let mut out = [0u8; REPLY_LEN];
        let counter = self.next_counter();
        let n = mailbox::emit_error(&mut out, counter, detail);
        self.replies.push(Message::new(&out[..n]));
    }

    fn next_counter(&mut self) -> u8 {
        self.counter = if self.counter >= 7 { 1 } else { self.counter + 1 };
        self.counter
    }

    /// New outputs in OP: executed when they differ from the ones applied last.
    fn apply<B: Board>(&mut self, outputs: Outputs, now: Instant, module: &mut Module<B>) {
        if self.applied == Some(outputs) {
            return;
        }
        self.applied = Some(outputs);
        if outputs.action(self.map).is_some() {
            self.commanded = true;
            // A refusal (torque without closed loop) shows in the status word.
            let _ = outputs.apply(module, self.map, now);
        }
    }

    /// A master wrote AL control.
    fn al_control<B: Board>(&mut self, now: Instant, module: &mut Module<B>, files: &mut impl FileStore) {
        let control = self.esc.reg8(reg::AL_CONTROL);
        if control & 0x10 != 0 && self.status.error {
            self.status.error = false;
            self.status.code = AlStatusCode::NoError;
        }
        self.await_outputs = None;
        let decision = al::decide(self.status, control, |step| self.check(step));
        match decision {
            Decision::Stay => {}
            Decision::Go(state) => {
                if state == AlState::Init || state == AlState::Boot || self.status.state == AlState::Boot {
                    self.foe.reset(files);
                }
                self.enter(state, now, module);
            }
            Decision::Refuse(code) => self.refuse(code),
            Decision::AwaitOutputs => self.await_outputs = Some(now + OUTPUT_WAIT),
        }
        self.write_status();
    }

    fn refuse(&mut self, code: AlStatusCode) {
        self.status.error = true;
        self.status.code = code;
        self.write_status();
    }

    fn write_status(&mut self) {
        self.esc.set_reg16(reg::AL_STATUS, self.status.register());
        self.esc.set_reg16(reg::AL_STATUS_CODE, self.status.code.into());
    }

    /// The checks of manual §3.2 for a step up.
    fn check(&self, step: Step) -> Result<(), AlStatusCode> {
        match step {
            Step::InitToPreOp | Step::InitToBoot => {
                let code = if step == Step::InitToBoot {
                    AlStatusCode::InvalidBootMailbox
                } else {
                    AlStatusCode::InvalidMailbox
                };
                let ok = self.sm_as(MAILBOX_OUT, SmMode::Mailbox, SmDirection::MasterWrites)
                    && self.sm_as(MAILBOX_IN, SmMode::Mailbox, SmDirection::MasterReads);
                if ok {
                    Ok(())
                } else {
                    Err(code)
                }
            }
            Step::PreOpToSafeOp => {
                // No distributed clocks: SYNC0/SYNC1 cannot be switched on.
                if self.esc.reg8(reg::DC_SYNC_ACTIVATION) & 0x07 != 0 {
                    return Err(AlStatusCode::InvalidDcSync);
                }
                if !self.sm_as(OUTPUTS, SmMode::Buffered, SmDirection::MasterWrites) {
                    return Err(AlStatusCode::InvalidOutputs);
                }
                if !self.sm_as(self.inputs, SmMode::Buffered, SmDirection::MasterReads) {
                    return Err(AlStatusCode::InvalidInputs);
                }
                Ok(())
            }
            Step::SafeOpToOp if self.outputs_valid => Ok(()),
            Step::SafeOpToOp => Err(AlStatusCode::NoValidOutputs),
        }
    }

    /// Whether the master configured a SyncManager as the slave's layout has it: start, length, mode,
    /// direction, enabled.
    fn sm_as(&self, want: SmLayout, mode: SmMode, direction: SmDirection) -> bool {
        let c = self.esc.sm_config(want.index);
        c.start == want.start
            && c.length == want.length
            && c.mode() == mode
            && c.direction() == direction
            && c.enabled()
    }

    /// Enters `to` from the current state: SyncManagers on and off as the state allows, outputs held
    /// safe when leaving OP.
    fn enter<B: Board>(&mut self, to: AlState, now: Instant, module: &mut Module<B>) {
        let from = self.status.state;
        self.status.state = to;
        if from == AlState::Op && to != AlState::Op {
            // §3.2: below OP "the slave holds its outputs in a safe situation": stop a motor the process
            // data drove.
            if self.commanded {
                let _ = module.execute(tmcl_wire::Command::Mst { motor: 0 }, now);
            }
            self.commanded = false;
            self.applied = None;
            self.watchdog_due = None;
        }
        // The mailbox works in every state but INIT, the process data in SAFE-OP and OP (§3.2); switching
        // a SyncManager off forgets its buffer, switching on one that is on changes nothing.
        let mailbox = to != AlState::Init;
        let process_data = matches!(to, AlState::SafeOp | AlState::Op);
        for sm in [MAILBOX_OUT, MAILBOX_IN] {
            self.esc.set_sm_enabled(sm.index, mailbox);
        }
        for sm in [OUTPUTS, self.inputs] {
            self.esc.set_sm_enabled(sm.index, process_data);
        }
        match to {
            AlState::Init => {
                self.replies = Replies::EMPTY;
                self.last_reply = None;
                self.previous_reply = None;
                self.outputs = None;
                self.outputs_valid = false;
            }
            AlState::PreOp | AlState::Boot => {
                self.outputs_valid = false;
                if from == AlState::Init {
                    self.replies = Replies::EMPTY;
                    self.last_reply = None;
                    self.previous_reply = None;
                }
            }
            AlState::SafeOp if from == AlState::PreOp => {
                self.outputs_valid = false;
                // §3.2: "Before accepting the change of state, the EtherCAT slave copies actual input
                // data into the accordant DP-RAM array".
                self.refresh_inputs(module);
            }
            AlState::SafeOp => {}
            AlState::Op => {
                self.applied = None;
                self.commanded = false;
                self.watchdog_due = self.watchdog().map(|d| now + d);
                self.esc.set_reg16(reg::WATCHDOG_STATUS, 1);
                if let Some(outputs) = self.outputs {
                    self.apply(outputs, now, module);
                }
            }
        }
        self.write_status();
    }
}

#[cfg(test)]
mod tests;

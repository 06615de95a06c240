//! The one thread that talks to the module: it owns the blocking [`Client`], runs the page's requests
//! (jobs) first, and polls the values the open pages show in between.
//!
//! **Turns.** The loop takes every job waiting in the queue before the next poll request, so a console
//! command or a debugger step waits at most for the one poll request already on the line. While the
//! debugger runs a program to a breakpoint (by single steps: the workbench's `debug` module) steps and
//! polls take turns, so the plots and the other pages stay live.
//!
//! **Rate.** Every request, jobs and polls alike, goes through one [`Limiter`]: never more requests per
//! second than the line carries (`baud / 180` on a serial port: a 9-byte request and a 9-byte reply of
//! 10-bit characters), and a fixed cap on a pty or TCP link, which have no baud rate of their own.
//!
//! **Events.** Every value read is sent to the pages as it arrives (a JSON text on a broadcast channel,
//! which the web server hands to every open page); so are changes of the link state, the debugger's stops,
//! progress of long jobs, and once a second the requests per second on the line.

use crate::info::ModelInfo;
pub(crate) use crate::schedule::Poll;
use crate::schedule::{Limiter, Schedule};
use serde::Serialize;
use std::collections::{BTreeSet, HashMap};
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use tmcl_debug::remote::{self, ProgramState, Remote, Report};
use tmcl_host::{Client, HostError, Transport};
use tmcl_model::{ModelSpec, PortKind, Role};
use tmcl_wire::{Command, Instruction, Reply, StatusKind};

/// A client on whatever link the command line named.
pub type HostClient = Client<Box<dyn Transport + Send>>;

/// How to open the link again after it went away (a restarted `tmcl serve`, an unplugged USB adapter):
/// the command line's own way of opening it, so the new client passes the same checks.
#[derive(Clone)]
pub struct Reopen(pub std::sync::Arc<dyn Fn() -> Result<HostClient, HostError> + Send + Sync>);

impl std::fmt::Debug for Reopen {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Reopen(..)")
    }
}

/// The state of the line as the header's indicator shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum LineState {
    /// Every request got its own answer.
    Answering,
    /// Replies arrive that answer other requests (another host on the same line, or a late reply): the
    /// values read in this time are in doubt; those that are provably not ours are not shown.
    Mismatched,
    /// The last request got no (usable) answer.
    NoAnswer,
    /// GP 255 switched the module's replies off.
    RepliesOff,
    /// The link itself went away; it is reopened every second.
    Down,
}

/// The `link` event: the line's state, in words, and the count of mismatched replies.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct LineEvent {
    pub e: &'static str,
    pub state: LineState,
    /// Whether values read now can be trusted (`answering`).
    pub ok: bool,
    /// What is wrong, in words (`None` while answering).
    pub error: Option<String>,
    /// Replies that answered another request than the one asked, since the start.
    pub mismatched: u64,
    /// Of those, in the last [`MISMATCH_WINDOW`].
    pub mismatched_recent: u64,
}

/// A new trace begins (the module address or the link changed): the pages drop what they plotted.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct EpochEvent {
    pub e: &'static str,
    pub n: u64,
    /// `module` or `link`.
    pub why: &'static str,
    pub t: f64,
}

/// The `prog` event: the program's state as the poll read it.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct ProgEvent {
    pub e: &'static str,
    #[serde(flatten)]
    pub state: ProgramState,
    pub t: f64,
}

/// The `debug` event: the debugger's report after an editor action or at the end of a run by single
/// steps (also the answer to the `program` request).
#[derive(Debug, Clone, Serialize)]
pub(crate) struct DebugEvent {
    pub e: &'static str,
    #[serde(flatten)]
    pub report: Report,
    pub t: f64,
}

/// The `debug` event of a run by single steps that a failed request ended.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct DebugError {
    pub e: &'static str,
    pub reason: &'static str,
    pub error: String,
}

/// The `v` event: one value read, by key (`ap.MOTOR.N`, `gp.BANK.N`, `io.BANK.PORT`, `rfs.MOTOR`, `acc`,
/// `x`): its value, or the status of the module's refusal.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct ValueEvent {
    pub e: &'static str,
    pub k: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v: Option<i32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub s: Option<u8>,
    pub t: f64,
}

impl ValueEvent {
    /// A value read.
    pub(crate) fn value(k: String, v: i32, t: f64) -> ValueEvent {
        ValueEvent { e: "v", k, v: Some(v), s: None, t }
    }

    /// A refusal with its status.
    pub(crate) fn refused(k: String, s: u8, t: f64) -> ValueEvent {
        ValueEvent { e: "v", k, v: None, s: Some(s), t }
    }
}

/// The `stats` event, once a second: requests per second, the total, the rate limit, the values polled.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct StatsEvent {
    pub e: &'static str,
    pub rps: f64,
    pub requests: u64,
    pub rate: f64,
    pub polled: usize,
}

/// The `progress` event of a long job (`download`, `scan`): how much of it is done.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct ProgressEvent {
    pub e: &'static str,
    pub what: &'static str,
    pub done: usize,
    pub total: usize,
}

/// The `hello` request's answer: the link, the module and its model, and what the pages plot.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Hello {
    pub line: LineEvent,
    pub epoch: u64,
    pub version: Option<String>,
    pub address: u8,
    pub link: String,
    pub link_ok: bool,
    pub link_error: Option<String>,
    pub rate: f64,
    pub model: Option<ModelInfo>,
    pub roles: Roles,
}

/// The `hello` event: the same, to every page, after the link or the module changed.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct HelloEvent<'a> {
    pub e: &'static str,
    pub hello: &'a Hello,
}

/// How long mismatched replies keep the indicator on its warning.
pub(crate) const MISMATCH_WINDOW: Duration = Duration::from_secs(10);
/// How often a link that went away is opened again.
const REOPEN_PERIOD: Duration = Duration::from_secs(1);
/// How long the console waits for the reply of a command that may get none while replies are off.
const QUIET_WAIT: Duration = Duration::from_millis(500);

/// Work for the link thread, sent by a page's connection.
pub(crate) type Job = Box<dyn FnOnce(&mut Link) + Send>;

/// What one page shows, so what must be polled for it.
#[derive(Debug, Clone, Default)]
pub(crate) struct Watch {
    /// The views open: `params`, `motion`, `io`, `program` (the plot values are always read).
    pub views: BTreeSet<String>,
    /// The motor whose axis parameters are shown.
    pub motor: u8,
    /// The user variables shown: first and count (bank 2, PD28-1021 manual §5.3).
    pub vars: (u8, u8),
    /// More values to plot (the charts of any parameter, the pulse divisor of a TMC428 model).
    pub extra: Vec<Poll>,
}

/// The axis parameter numbers the workbench reads by meaning. A model without a table (an unknown
/// version string) gets the numbers most TMCL modules share (PD28-1021 manual §4, Table 15). The page
/// reads them by these names (`null`: the model has no such parameter).
#[derive(Debug, Clone, Copy, Serialize)]
pub(crate) struct Roles {
    pub target_position: Option<u8>,
    pub actual_position: Option<u8>,
    pub target_speed: Option<u8>,
    pub actual_speed: Option<u8>,
    pub load: Option<u8>,
    pub current: Option<u8>,
    pub encoder: Option<u8>,
    pub reached: Option<u8>,
    pub home: Option<u8>,
    pub right: Option<u8>,
    pub left: Option<u8>,
}

impl Roles {
    pub(crate) fn of(model: Option<&'static ModelSpec>) -> Roles {
        let Some(model) = model else {
            return Roles {
                target_position: Some(0),
                actual_position: Some(1),
                target_speed: Some(2),
                actual_speed: Some(3),
                load: Some(206),
                current: Some(180),
                encoder: Some(209),
                reached: Some(8),
                home: Some(9),
                right: Some(10),
                left: Some(11),
            };
        };
        let find = |role: Role| model.axis.params.iter().find(|d| d.role == role && d.access.read).map(|d| d.number);
        Roles {
            target_position: find(Role::TargetPosition),
            actual_position: find(Role::ActualPosition),
            target_speed: find(Role::TargetSpeed),
            actual_speed: find(Role::ActualSpeed),
            load: find(Role::LoadValue),
            current: find(Role::ActualCurrent).or_else(|| find(Role::CurrentScale)),
            encoder: find(Role::EncoderPosition),
            reached: find(Role::PositionReached),
            home: find(Role::HomeSwitch),
            right: find(Role::RightSwitch),
            left: find(Role::LeftSwitch),
        }
    }

    /// The plotted values, fastest first.
    fn plotted(&self) -> impl Iterator<Item = u8> {
        [
            self.actual_position,
            self.target_position,
            self.actual_speed,
            self.target_speed,
            self.load,
            self.current,
            self.encoder,
        ]
        .into_iter()
        .flatten()
    }
}

/// How often each kind of value is read when the line allows (see [`crate::schedule`]).
const PLOT_PERIOD: Duration = Duration::from_millis(20);
const SWITCH_PERIOD: Duration = Duration::from_millis(150);
const PROGRAM_PERIOD: Duration = Duration::from_millis(100);
const PROGRAM_IDLE_PERIOD: Duration = Duration::from_millis(1000);
const REGISTER_PERIOD: Duration = Duration::from_millis(200);
const VARIABLE_PERIOD: Duration = Duration::from_millis(400);
const IO_PERIOD: Duration = Duration::from_millis(250);
const PARAM_PERIOD: Duration = Duration::from_millis(2000);
/// How long the loop sleeps at most without a job or a due value (the stats event needs a beat).
const IDLE: Duration = Duration::from_millis(250);
/// The longest a poll request waits for its reply (the page's own requests wait `--timeout`): a module
/// answers a read within a few frame times, and a poll must not keep the page's requests waiting long.
const POLL_TIMEOUT: Duration = Duration::from_millis(500);
/// After a poll that got no answer, polling pauses this long (the page's requests still go out), so a
/// module that is off or at another address costs one timeout a second, not one per value.
const BACKOFF: Duration = Duration::from_secs(1);

/// Milliseconds since the Unix epoch: the time stamp of every event, comparable with the page's
/// `Date.now()` on the same machine.
pub(crate) fn now_ms() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

/// The link thread's state.
pub(crate) struct Link {
    client: HostClient,
    limiter: Limiter,
    /// The most requests per second.
    pub rate: f64,
    events: tokio::sync::broadcast::Sender<Arc<str>>,
    /// The model, from `--module` or the version string.
    pub model: Option<&'static ModelSpec>,
    /// Whether the model came from `--module` (then a change of address keeps it).
    model_fixed: bool,
    /// The version string, once read.
    pub version: Option<String>,
    /// The link in words (`/dev/ttyUSB0 at 9600 baud`).
    pub link_name: String,
    link_error: Option<String>,
    schedule: Schedule,
    watches: HashMap<u64, Watch>,
    /// The program debugger.
    pub debug: Remote,
    /// Whose turn it is while the debugger steps: a step (true) or a poll.
    step_turn: bool,
    requests: u64,
    window: (Instant, u64),
    /// Requests per second over the last full second.
    pub rps: f64,
    stopped: bool,
    /// No polling before this instant (after a poll without an answer).
    backoff: Option<Instant>,
    /// A scan is under way: unanswered addresses say nothing about the link.
    pub scanning: bool,
    /// How to open the link again.
    reopen: Option<Reopen>,
    /// The link went away: when it was last tried again.
    down: Option<Instant>,
    /// Replies that answered other requests: the total, and when each of the recent ones came.
    mismatched: u64,
    mismatched_at: std::collections::VecDeque<Instant>,
    /// GP 255 switched replies off (the console said so; SGP 255, 0, 0 turns them back on).
    pub replies_off: bool,
    /// The trace number: one more at each change of module or link.
    pub epoch: u64,
    /// The line state last sent to the pages.
    line: Option<LineEvent>,
}

impl Link {
    /// A link over `client`, `rate` requests per second at most.
    pub(crate) fn new(
        client: HostClient,
        rate: f64,
        model: Option<&'static ModelSpec>,
        link_name: String,
        events: tokio::sync::broadcast::Sender<Arc<str>>,
    ) -> Link {
        Link {
            client,
            limiter: Limiter::new(rate),
            rate,
            events,
            model,
            model_fixed: model.is_some(),
            version: None,
            link_name,
            link_error: None,
            schedule: Schedule::default(),
            watches: HashMap::new(),
            debug: Remote::default(),
            step_turn: false,
            requests: 0,
            window: (Instant::now(), 0),
            rps: 0.0,
            stopped: false,
            backoff: None,
            scanning: false,
            reopen: None,
            down: None,
            mismatched: 0,
            mismatched_at: std::collections::VecDeque::new(),
            replies_off: false,
            epoch: 0,
            line: None,
        }
    }

    /// Lets the link thread open the link again when it goes away.
    pub(crate) fn with_reopen(mut self, reopen: Option<Reopen>) -> Link {
        self.reopen = reopen;
        self
    }

    /// The line's state now (see [`LineState`]).
    pub(crate) fn line_event(&mut self) -> LineEvent {
        let now = Instant::now();
        while self.mismatched_at.front().is_some_and(|&t| now.saturating_duration_since(t) > MISMATCH_WINDOW) {
            self.mismatched_at.pop_front();
        }
        let recent = self.mismatched_at.len() as u64;
        let (state, error) = if self.down.is_some() {
            let why = self.link_error.clone().unwrap_or_else(|| "the link went away".into());
            (LineState::Down, Some(format!("{why}; opening {} again every second", self.link_name)))
        } else if self.replies_off {
            (
                LineState::RepliesOff,
                Some("replies are off (GP 255): SGP 255, 0, 0 in the console turns them back on".into()),
            )
        } else if let Some(e) = &self.link_error {
            (LineState::NoAnswer, Some(e.clone()))
        } else if recent > 0 {
            let text = format!(
                "{recent} repl{} in the last {} s answered other requests than this workbench's ({} since the start): \
                 another host on this line? Values that are not answers to our requests are not shown",
                if recent == 1 { "y" } else { "ies" },
                MISMATCH_WINDOW.as_secs(),
                self.mismatched
            );
            (LineState::Mismatched, Some(text))
        } else {
            (LineState::Answering, None)
        };
        LineEvent {
            e: "link",
            state,
            ok: state == LineState::Answering,
            error,
            mismatched: self.mismatched,
            mismatched_recent: recent,
        }
    }

    /// Sends the line's state to the pages now (the console changed whether replies are on).
    pub(crate) fn emit_line(&mut self) {
        self.update_line();
    }

    /// Sends the line's state to the pages if it changed.
    fn update_line(&mut self) {
        let event = self.line_event();
        if self.line.as_ref() != Some(&event) {
            self.emit_typed(&event);
            self.line = Some(event);
        }
    }

    /// Counts `n` replies that answered other requests than ours.
    pub(crate) fn note_mismatched(&mut self, n: usize) {
        if n == 0 {
            return;
        }
        let now = Instant::now();
        self.mismatched += n as u64;
        for _ in 0..n.min(1000) {
            self.mismatched_at.push_back(now);
        }
        while self.mismatched_at.len() > 1000 {
            self.mismatched_at.pop_front();
        }
        self.update_line();
    }

    /// Opens the link again if it went away and a second has passed since the last try; `true` when it
    /// is up.
    fn try_reopen(&mut self) -> bool {
        let Some(last) = self.down else { return true };
        let Some(reopen) = self.reopen.clone() else { return false };
        if last.elapsed() < REOPEN_PERIOD {
            return false;
        }
        self.down = Some(Instant::now());
        match (reopen.0)() {
            Ok(client) => {
                let old = std::mem::replace(&mut self.client, client);
                self.client.module_address = old.module_address;
                self.client.timeout = old.timeout;
                self.client.quiet = old.quiet;
                self.client.match_address = old.match_address;
                drop(old);
                self.down = None;
                self.link_error = None;
                self.replies_off = false;
                tracing::info!(link = %self.link_name, "the link is back");
                self.new_epoch("link");
                self.debug = Remote::default();
                self.identify();
                self.reschedule();
                let hello = self.hello();
                self.emit_typed(&HelloEvent { e: "hello", hello: &hello });
                self.update_line();
                true
            }
            Err(e) => {
                let text = format!("the link went away ({e})");
                if self.link_error.as_deref() != Some(text.as_str()) {
                    tracing::warn!(link = %self.link_name, "{text}");
                    self.link_error = Some(text);
                    self.update_line();
                }
                false
            }
        }
    }

    /// Starts a new trace: the pages drop what they plotted.
    fn new_epoch(&mut self, why: &'static str) {
        self.epoch += 1;
        let event = EpochEvent { e: "epoch", n: self.epoch, why, t: now_ms() };
        self.emit_typed(&event);
    }

    /// The `hello` answer: the link, the module and its model.
    pub(crate) fn hello(&mut self) -> Hello {
        Hello {
            line: self.line_event(),
            epoch: self.epoch,
            version: self.version.clone(),
            address: self.address(),
            link: self.link_name.clone(),
            link_ok: self.link_error().is_none(),
            link_error: self.link_error.clone(),
            rate: self.rate,
            model: self.model.map(ModelInfo::of),
            roles: Roles::of(self.model),
        }
    }

    /// Runs `f` with the debugger and the link apart (the debugger drives the link).
    pub(crate) fn with_debugger<R>(&mut self, f: impl FnOnce(&mut Remote, &mut Link) -> R) -> R {
        let mut debugger = std::mem::take(&mut self.debug);
        let result = f(&mut debugger, self);
        self.debug = debugger;
        result
    }

    /// Sends the debugger's report to every page as the `debug` event, and returns the event.
    pub(crate) fn emit_debug(&self, report: Report) -> DebugEvent {
        let event = DebugEvent { e: "debug", report, t: now_ms() };
        self.emit_typed(&event);
        event
    }

    /// One step of the debugger's run towards a breakpoint (the link thread calls it between polls); the
    /// pages hear where the run ended.
    pub(crate) fn debug_step(&mut self) {
        match self.with_debugger(|debugger, link| debugger.continue_step(link)) {
            None => {}
            Some(Ok(report)) => {
                self.emit_debug(report);
            }
            Some(Err(e)) => {
                tracing::warn!("the debugger's run stopped: {e}");
                self.emit_typed(&DebugError { e: "debug", reason: "error", error: e.to_string() })
            }
        }
    }

    /// Sends a typed event to every page.
    pub(crate) fn emit_typed<E: Serialize>(&self, event: &E) {
        if let Ok(text) = serde_json::to_string(event) {
            let _ = self.events.send(Arc::from(text));
        }
    }

    /// Ends the link thread after the job that calls it.
    pub(crate) fn stop(&mut self) {
        self.stopped = true;
    }

    /// The module address requests go to.
    pub(crate) fn address(&self) -> u8 {
        self.client.module_address
    }

    /// The link's trouble, if the last request failed on the line.
    pub(crate) fn link_error(&self) -> Option<&str> {
        self.link_error.as_deref()
    }

    /// Runs `f` on the client after waiting for the rate limit; notes the link state, counts the replies
    /// that answered other requests, and notices a link that went away.
    fn on_line<R>(&mut self, f: impl FnOnce(&mut HostClient) -> Result<R, HostError>) -> Result<R, HostError> {
        if self.down.is_some() && !self.try_reopen() {
            let why = self.link_error.clone().unwrap_or_else(|| "the link went away".into());
            return Err(HostError::Io(std::io::Error::new(
                std::io::ErrorKind::NotConnected,
                format!("{why}; waiting for it to come back"),
            )));
        }
        self.limiter.wait();
        self.requests += 1;
        let result = f(&mut self.client);
        if self.scanning {
            return result;
        }
        let skipped = self.client.take_skipped().len();
        if skipped > 0 {
            self.note_mismatched(skipped);
        }
        let trouble = match &result {
            // A refusal is an answer: the line is fine.
            Err(HostError::Status { .. }) => None,
            Err(e @ (HostError::Timeout { .. } | HostError::Io(_))) => Some(e.to_string()),
            Err(e) if e.is_reply_error() => Some(e.to_string()),
            _ => None,
        };
        if matches!(result, Err(HostError::Io(_))) && self.reopen.is_some() && self.down.is_none() {
            // The port hung up or the connection closed: the link is gone, not the module.
            self.down = Some(Instant::now());
        }
        self.link_error = trouble;
        self.update_line();
        result
    }

    /// A request that may get no reply (commands 137, 242 and 255, §3.7.38, and any while GP 255 keeps
    /// replies off): `Ok(None)` when none came within the timeout, which is then no trouble of the line.
    pub(crate) fn request_maybe_reply(&mut self, instruction: Instruction) -> Result<Option<Reply>, HostError> {
        let wait = if self.replies_off { QUIET_WAIT.min(self.client.timeout) } else { self.client.timeout };
        let old = self.set_timeout(wait);
        let result = self.on_line(|c| match c.request(instruction) {
            Ok(reply) => Ok(Some(reply)),
            Err(HostError::Timeout { received: 0, .. }) => Ok(None),
            Err(e) => Err(e),
        });
        self.client.timeout = old;
        result
    }

    /// Runs a whole series of requests (a parameter set) on the client as one turn of the line.
    pub(crate) fn with_client<R>(
        &mut self,
        f: impl FnOnce(&mut HostClient) -> Result<R, HostError>,
    ) -> Result<R, HostError> {
        self.on_line(f)
    }

    /// One request and its reply (PD28-1021 TMCL manual §3.1).
    pub(crate) fn request(&mut self, instruction: Instruction) -> Result<Reply, HostError> {
        self.on_line(|c| c.request(instruction))
    }

    /// Command 136 type 0 (§3.7.38).
    pub(crate) fn version_string(&mut self) -> Result<String, HostError> {
        self.on_line(|c| c.version_string())
    }

    /// Command 134 (§3.7.38).
    pub(crate) fn read_program_memory(&mut self, address: u16) -> Result<Instruction, HostError> {
        self.on_line(|c| c.read_program_memory(address))
    }

    /// Sets the reply timeout, returning the old one (the scan waits briefly at each address).
    pub(crate) fn set_timeout(&mut self, timeout: Duration) -> Duration {
        std::mem::replace(&mut self.client.timeout, timeout)
    }

    /// Drains late replies and returns those skipped (the scan counts late answers).
    pub(crate) fn settle(&mut self) -> Vec<Reply> {
        let _ = self.client.settle();
        self.client.take_skipped()
    }

    /// Sends the next requests to `address` (the scan; [`Link::select`] for a change of module).
    pub(crate) fn set_address(&mut self, address: u8) {
        self.client.module_address = address;
    }

    /// Talks to another module address, and asks it who it is.
    pub(crate) fn select(&mut self, address: u8) {
        self.client.module_address = address;
        if !self.model_fixed {
            self.model = None;
        }
        self.version = None;
        self.debug = Remote::default();
        self.new_epoch("module");
        self.identify();
        self.reschedule();
    }

    /// Reads the version string and, unless `--module` named it, finds the model by it.
    pub(crate) fn identify(&mut self) {
        match self.version_string() {
            Ok(text) => {
                if !self.model_fixed {
                    self.model = tmcl_model::by_version(&text);
                }
                self.version = Some(text);
            }
            Err(_) => self.version = None,
        }
    }

    /// A page's view changed (`None`: the page went away).
    pub(crate) fn watch(&mut self, page: u64, watch: Option<Watch>) {
        match watch {
            Some(w) => self.watches.insert(page, w),
            None => self.watches.remove(&page),
        };
        self.reschedule();
    }

    /// Builds the poll schedule from what the open pages show.
    pub(crate) fn reschedule(&mut self) {
        let mut polls: Vec<(Poll, Duration)> = Vec::new();
        let roles = Roles::of(self.model);
        let model = self.model;
        let mut watches: Vec<&Watch> = self.watches.values().collect();
        watches.sort_by_key(|w| w.motor);
        for w in &watches {
            let motor = w.motor;
            polls.extend(roles.plotted().map(|param| (Poll::Axis { param, motor }, PLOT_PERIOD)));
            let switches = [roles.reached, roles.home, roles.right, roles.left];
            polls.extend(switches.into_iter().flatten().map(|param| (Poll::Axis { param, motor }, SWITCH_PERIOD)));
            polls.extend(w.extra.iter().map(|&p| (p, PLOT_PERIOD)));
            let program = w.views.contains("program");
            polls.push((Poll::ProgramCounter, if program { PROGRAM_PERIOD } else { PROGRAM_IDLE_PERIOD }));
            if program {
                if !remote::plain_status(self.model) {
                    polls.push((Poll::Accumulator, REGISTER_PERIOD));
                    polls.push((Poll::XRegister, REGISTER_PERIOD));
                }
                let (first, count) = w.vars;
                let limit = model.map_or(256, |m| usize::from(m.user_variables));
                for n in usize::from(first)..(usize::from(first) + usize::from(count)).min(limit) {
                    polls.push((Poll::Global { param: n as u8, bank: 2 }, VARIABLE_PERIOD));
                }
            }
            if w.views.contains("motion") {
                polls.push((Poll::Reference { motor }, SWITCH_PERIOD));
                // The axes table of a model with several motors: every other motor's positions, speed,
                // position-reached flag and switches, at the switches' pace.
                let overview = [
                    roles.actual_position,
                    roles.target_position,
                    roles.actual_speed,
                    roles.reached,
                    roles.left,
                    roles.home,
                    roles.right,
                ];
                for m in (0..model.map_or(1, |m| m.motors)).filter(|m| *m != motor) {
                    let axis =
                        overview.into_iter().flatten().map(|param| (Poll::Axis { param, motor: m }, SWITCH_PERIOD));
                    polls.extend(axis);
                }
            }
            if w.views.contains("io") {
                for p in model.map_or(&[][..], |m| m.ports) {
                    let all = matches!(p.kind, PortKind::AllInputs | PortKind::AllOutputs);
                    if !all && p.kind.is_readable() {
                        polls.push((Poll::Input { port: p.port, bank: p.bank }, IO_PERIOD));
                    }
                }
            }
            if w.views.contains("params") {
                if let Some(m) = model {
                    let tables = [(&m.axis, None), (&m.global, Some(0)), (&m.interrupt, Some(3))];
                    for (table, bank) in tables {
                        for d in table.params.iter().filter(|d| d.access.read) {
                            let poll = match bank {
                                None => Poll::Axis { param: d.number, motor },
                                Some(bank) => Poll::Global { param: d.number, bank },
                            };
                            polls.push((poll, PARAM_PERIOD));
                        }
                    }
                }
            }
        }
        self.schedule.set(polls);
    }

    /// Reads the values `which` picks next, before any other (see [`Schedule::hurry`]).
    pub(crate) fn hurry(&mut self, which: impl FnMut(&Poll) -> bool) {
        self.schedule.hurry(which);
    }

    /// After a request that may have changed what moves: reads the plotted values, switches and reference
    /// status of `motor` next, or (`None`, after a console line, which may change anything) those of every
    /// motor and the I/O, the program status and the user variables as well.
    pub(crate) fn hurry_live(&mut self, motor: Option<u8>) {
        let roles = Roles::of(self.model);
        let switches = [roles.reached, roles.home, roles.right, roles.left];
        let live: Vec<u8> = roles.plotted().chain(switches.into_iter().flatten()).collect();
        let this = |m: u8| motor.is_none_or(|x| x == m);
        self.schedule.hurry(|p| match *p {
            Poll::Axis { param, motor: m } => live.contains(&param) && this(m),
            Poll::Reference { motor: m } => this(m),
            Poll::Global { bank, .. } => bank == 2 && motor.is_none(),
            Poll::Input { .. } | Poll::ProgramCounter | Poll::Accumulator | Poll::XRegister => motor.is_none(),
        });
    }

    /// Reads one value and sends it to the pages.
    fn poll(&mut self, poll: Poll) {
        let t = now_ms();
        let (key, command) = match poll {
            Poll::Axis { param, motor } => (format!("ap.{motor}.{param}"), Command::Gap { param, motor }),
            Poll::Global { param, bank } => (format!("gp.{bank}.{param}"), Command::Ggp { param, bank }),
            Poll::Input { port, bank } => (format!("io.{bank}.{port}"), Command::Gio { port, bank }),
            Poll::Reference { motor } => {
                (format!("rfs.{motor}"), Command::Rfs { action: tmcl_wire::RfsAction::Status, motor })
            }
            Poll::ProgramCounter => {
                let timeout = self.set_timeout(POLL_TIMEOUT.min(self.client.timeout));
                let status = remote::read_status(self);
                self.client.timeout = timeout;
                if self.link_error.is_some() {
                    self.backoff = Some(Instant::now() + BACKOFF);
                }
                if let Ok(status) = status {
                    self.debug.observe(&status);
                    self.emit_typed(&ProgEvent { e: "prog", state: self.debug.state(&status), t });
                }
                return;
            }
            Poll::Accumulator => ("acc".into(), Command::GetStatus { kind: StatusKind::Accumulator }),
            Poll::XRegister => ("x".into(), Command::GetStatus { kind: StatusKind::XRegister }),
        };
        let timeout = self.set_timeout(POLL_TIMEOUT.min(self.client.timeout));
        let result = self.request(command.encode());
        self.client.timeout = timeout;
        if self.link_error.is_some() {
            self.backoff = Some(Instant::now() + BACKOFF);
        }
        // A plain stored value (read back as written, and written only within its range) outside the
        // model's range is no answer of this module to this request: a reply to another host's request
        // (the reply names no parameter, so one of another parameter of the same command can pass the
        // client's check). It is counted, never shown. Values the firmware computes (flags, states,
        // counters) are not checked: their tables give the range a write takes, not what a read returns.
        let desc = match (poll, self.model) {
            (Poll::Axis { param, .. }, Some(m)) => crate::info::find_param(m, true, 0, param),
            (Poll::Global { param, bank }, Some(m)) => crate::info::find_param(m, false, bank, param),
            _ => None,
        };
        match result {
            Ok(reply) if desc.is_some_and(|d| d.role == tmcl_model::Role::Plain && !d.range.contains(reply.value)) => {
                self.note_mismatched(1)
            }
            Ok(reply) => self.emit_typed(&ValueEvent::value(key, reply.value, t)),
            Err(HostError::Status { status, .. }) => self.emit_typed(&ValueEvent::refused(key, u8::from(status), t)),
            Err(_) => {}
        }
    }

    /// Counts requests per second and says so once a second.
    fn tick(&mut self, now: Instant) {
        let elapsed = now.saturating_duration_since(self.window.0);
        if elapsed >= Duration::from_secs(1) {
            self.rps = (self.requests - self.window.1) as f64 / elapsed.as_secs_f64();
            self.window = (now, self.requests);
            self.emit_typed(&StatsEvent {
                e: "stats",
                rps: self.rps,
                requests: self.requests,
                rate: self.rate,
                polled: self.schedule.len(),
            });
            // Mismatched replies age out of the warning.
            self.update_line();
        }
    }
}

/// The link thread: jobs first, then the debugger's steps and the polls, until the job queue closes.
pub(crate) fn run(mut link: Link, jobs: Receiver<Job>) {
    link.identify();
    loop {
        match jobs.try_recv() {
            Ok(job) => {
                job(&mut link);
                if link.stopped {
                    return;
                }
                continue;
            }
            Err(TryRecvError::Disconnected) => return,
            Err(TryRecvError::Empty) => {}
        }
        let now = Instant::now();
        link.tick(now);
        if link.debug.is_continuing() {
            link.step_turn = !link.step_turn;
            if link.step_turn {
                link.debug_step();
                continue;
            }
        }
        // A link that went away is opened again once a second; with replies off there is nothing to poll.
        let idle = (link.down.is_some() && !link.try_reopen()) || link.replies_off;
        let backoff = if idle { Some(now + IDLE) } else { link.backoff };
        if let Some(until) = backoff.filter(|&until| until > now) {
            match jobs.recv_timeout(until - now) {
                Ok(job) => {
                    job(&mut link);
                    if link.stopped {
                        return;
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    if !idle {
                        link.backoff = None;
                    }
                }
                Err(RecvTimeoutError::Disconnected) => return,
            }
            continue;
        }
        let wait = match link.schedule.next(now) {
            Ok(poll) => {
                link.poll(poll);
                continue;
            }
            // Nothing due: the debugger's next step, or a nap until the next value is.
            Err(_) if link.debug.is_continuing() => continue,
            Err(Some(due)) => due.saturating_duration_since(now).min(IDLE),
            Err(None) => IDLE,
        };
        match jobs.recv_timeout(wait) {
            Ok(job) => {
                job(&mut link);
                if link.stopped {
                    return;
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}

/// The debugger drives the module over the link, as every other request.
impl remote::Target for Link {
    type Error = HostError;

    fn request(&mut self, instruction: Instruction) -> Result<Reply, HostError> {
        Link::request(self, instruction)
    }

    fn model(&self) -> Option<&'static ModelSpec> {
        self.model
    }
}

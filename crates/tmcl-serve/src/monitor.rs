//! The protocol monitor: every transaction on a server's links as one record ([`Transaction`]), written
//! live to a log file (`--log FILE`) and to the clients of the monitor socket (`tmcl monitor`).
//!
//! **The monitor socket.** A server with a pty link listens on a Unix socket beside its first link,
//! `LINK.monitor` (or where [`MonitorOptions::socket`] says). Each client that connects gets every
//! transaction from then on, one JSON object per line ([`Transaction`] with serde); it sends nothing. A
//! client that does not read its lines falls behind by at most [`CLIENT_BACKLOG`] bytes and is then
//! disconnected (the server never waits for a monitor). The socket is removed when the server stops; one
//! left by a server that was killed is replaced by the next server on that link.
//!
//! **The log file.** `--log FILE` appends the same records, as text lines ([`Transaction::line`]) or, with
//! `--json`, as JSON lines. Each record is written when its transaction ends (the reply, or its timeout).

use crate::ServeError;
use serde::{Deserialize, Serialize};
use std::io::{self, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use tmcl_core::model::{ModelSpec, ParamDesc, Table, Unit};
use tmcl_wire::{Instruction, Opcode, Reply, ReplyFrame, Request, Status};

/// The most line bytes held for a monitor client that does not read; beyond it the client is dropped.
pub const CLIENT_BACKLOG: usize = 1 << 20;

/// What became of a request, or what a frame that answers none is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// The reply came within the timeout (whatever its status).
    Answered,
    /// No reply within the wait: the command gets none (137 carried out, 242, 255, GP 255 set), or the
    /// module did not answer.
    NoReply,
    /// The reply came damaged (wrong checksum); it went to the asker as it came.
    Damaged,
    /// A reply that came after its request had timed out, given to the host that asked.
    Late,
    /// The unsolicited second reply of command 138 (status 128), given to the host that asked for it.
    Event,
    /// A frame from the module that answers no request here (another master on the line, a late reply to
    /// a host that has gone): shown to no host.
    Foreign,
    /// A partial frame dropped after the line had been quiet (a host wrote part of a frame and stopped).
    Partial,
    /// Answered by the server itself, not by the module (an ASCII line that does not parse, `BIN`).
    Local,
}

impl Outcome {
    fn word(self) -> &'static str {
        match self {
            Outcome::Answered => "",
            Outcome::NoReply => "no reply",
            Outcome::Damaged => "DAMAGED reply",
            Outcome::Late => "LATE reply",
            Outcome::Event => "event",
            Outcome::Foreign => "FOREIGN frame, shown to no host",
            Outcome::Partial => "PARTIAL frame dropped",
            Outcome::Local => "answered by the server",
        }
    }
}

/// A frame, raw and decoded.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Decoded {
    /// The bytes, in hex (`01 06 04 00 00 00 00 00 0B`), or the text of an ASCII line.
    pub raw: String,
    /// What they say, with the model's names and units where it is known (`GAP 4, 0 (Maximum
    /// positioning speed)`, `100 ok: 1234 pps`).
    pub text: String,
}

/// One transaction, as the monitor and the log show it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Transaction {
    /// When it ended, UTC, `HH:MM:SS.mmm`.
    pub time: String,
    /// When it ended, in milliseconds since the Unix epoch.
    pub unix_ms: u64,
    /// The host link it came from or went to (the LINK path or the TCP address); `-` for none.
    pub host: String,
    /// What became of it.
    pub outcome: Outcome,
    /// The request (none for events and foreign frames).
    pub request: Option<Decoded>,
    /// The reply (none when none came).
    pub reply: Option<Decoded>,
    /// The reply's status code.
    pub status: Option<u8>,
    /// From the request to its reply (or to the end of the wait), in microseconds.
    pub round_trip_us: Option<u64>,
    /// Why the module refused it, or what else a user needs to know.
    pub note: Option<String>,
}

impl Transaction {
    /// A record now, with nothing decoded yet.
    pub fn now(host: &str, outcome: Outcome) -> Transaction {
        let since = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        let ms = since.as_millis() as u64;
        let day = (ms / 1000) % 86_400;
        let time = format!("{:02}:{:02}:{:02}.{:03}", day / 3600, day / 60 % 60, day % 60, ms % 1000);
        Transaction {
            time,
            unix_ms: ms,
            host: host.to_string(),
            outcome,
            request: None,
            reply: None,
            status: None,
            round_trip_us: None,
            note: None,
        }
    }

    /// The transaction as one line of text: time, host, request, reply, round trip, notes.
    pub fn line(&self) -> String {
        let mut line = format!("{} {}", self.time, self.host);
        if let Some(r) = &self.request {
            line.push_str(&format!("  {}", r.text));
        }
        match &self.reply {
            Some(r) => line.push_str(&format!("  -> {}", r.text)),
            None if self.request.is_some() => line.push_str("  -> (none)"),
            None => {}
        }
        if let Some(us) = self.round_trip_us {
            line.push_str(&format!("  {:.1} ms", us as f64 / 1000.0));
        }
        let word = self.outcome.word();
        if !word.is_empty() {
            line.push_str(&format!("  [{word}]"));
        }
        if let Some(note) = &self.note {
            line.push_str(&format!("  {note}"));
        }
        line
    }
}

/// Bytes in hex, separated by spaces.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

/// The parameter a request names, if the model has it: the table of axis parameters for SAP/GAP/STAP/
/// RSAP, of bank 0 or 3 for SGP/GGP/STGP/RSGP.
fn param_of(model: Option<&'static ModelSpec>, i: &Instruction) -> Option<&'static ParamDesc> {
    let model = model?;
    let table: &Table = match i.opcode {
        Opcode::Sap | Opcode::Gap | Opcode::Stap | Opcode::Rsap => &model.axis,
        Opcode::Sgp | Opcode::Ggp | Opcode::Stgp | Opcode::Rsgp => match i.motor {
            0 => &model.global,
            3 => &model.interrupt,
            _ => return None,
        },
        _ => return None,
    };
    table.find(i.kind).ok().map(|(_, d)| d)
}

fn with_unit(value: i32, unit: Unit) -> String {
    match unit.symbol() {
        "" => value.to_string(),
        symbol => format!("{value} {symbol}"),
    }
}

/// A request frame decoded: `to 1: SAP 4, 0, 1234 (Maximum positioning speed = 1234 pps)`.
pub fn decode_request(bytes: &[u8], model: Option<&'static ModelSpec>) -> Decoded {
    let raw = hex(bytes);
    let text = match tmcl_wire::Frame::new_checked(bytes).map(|f| Request::parse(&f)) {
        Ok(Ok(Request { address, instruction: i })) => {
            let mut text = format!("to {address}: ");
            let _ = tmcl_wire::ascii::format_instruction(&i, &mut text, None);
            if text.contains(tmcl_wire::ascii::RAW_MNEMONIC) && !matches!(i.opcode, Opcode::Unknown(_)) {
                // A command without a mnemonic (136, 138, 255, ...): its name.
                text.push_str(&format!(" ({:?})", i.opcode));
            }
            if let Some(d) = param_of(model, &i) {
                if matches!(i.opcode, Opcode::Sap | Opcode::Sgp) {
                    text.push_str(&format!(" ({} = {})", d.name, with_unit(i.value, d.unit)));
                } else {
                    text.push_str(&format!(" ({})", d.name));
                }
            }
            text
        }
        Ok(Err(e)) => format!("damaged request: {e}"),
        Err(_) => format!("{} bytes, not a frame", bytes.len()),
    };
    Decoded { raw, text }
}

/// A reply frame decoded (`100 ok: 1234 pps`), with the note that explains a refusal; `request` is the
/// request it answers, for the unit of the value and the range of a refused parameter.
pub fn decode_reply(
    bytes: &[u8],
    request: Option<&[u8]>,
    model: Option<&'static ModelSpec>,
) -> (Decoded, Option<Status>, Option<String>) {
    let raw = hex(bytes);
    let asked = request
        .and_then(|r| tmcl_wire::Frame::new_checked(r).ok().and_then(|f| Request::parse(&f).ok()))
        .map(|r| r.instruction);
    // The raw reply of 136 type 0: the host address and eight characters (§3.7.38).
    if asked.is_some_and(|i| i.opcode == Opcode::GetVersion && i.kind == 0) && bytes.len() == 9 {
        let text = format!("version {:?}", String::from_utf8_lossy(&bytes[1..]));
        return (Decoded { raw, text }, None, None);
    }
    match ReplyFrame::new_checked(bytes).map(|f| Reply::parse(&f)) {
        Ok(Ok(r)) => {
            let param = asked.and_then(|i| param_of(model, &i));
            let value = match (param, asked) {
                (Some(d), Some(i)) if matches!(i.opcode, Opcode::Gap | Opcode::Ggp) => with_unit(r.value, d.unit),
                _ => r.value.to_string(),
            };
            let status = match r.status {
                Status::Ok => "100 (ok)".to_string(),
                s => s.to_string(),
            };
            let mut text = format!("{status}: {value}");
            if asked.is_some_and(|i| u8::from(i.opcode) != r.opcode) {
                text = format!("{} (command {}, from {})", text, r.opcode, r.module);
            }
            let note = (!r.status.is_success()).then(|| match (param, asked) {
                (Some(d), Some(i))
                    if r.status == Status::InvalidValue && matches!(i.opcode, Opcode::Sap | Opcode::Sgp) =>
                {
                    format!("refused: {} takes {} ({})", d.name, d.range, d.section)
                }
                _ => format!("refused: {}", r.status.description()),
            });
            (Decoded { raw, text }, Some(r.status), note)
        }
        Ok(Err(e)) => (Decoded { raw, text: format!("damaged: {e}") }, None, None),
        Err(_) => (Decoded { raw, text: format!("{} bytes, not a reply", bytes.len()) }, None, None),
    }
}

/// Where transactions go: the log file and the monitor socket's clients.
#[derive(Debug, Clone, Default)]
pub struct MonitorOptions {
    /// Append every transaction to this file.
    pub log: Option<PathBuf>,
    /// Write the log file as JSON lines.
    pub log_json: bool,
    /// The monitor socket; `None`: `LINK.monitor` beside the first pty link (none without a pty link).
    pub socket: Option<PathBuf>,
    /// Also print every transaction's line on stderr (`--verbose`).
    pub stderr: bool,
}

/// The log file, the monitor socket and its clients.
pub(crate) struct Monitor {
    log: Option<(io::BufWriter<std::fs::File>, bool)>,
    stderr: bool,
    listener: Option<(UnixListener, PathBuf)>,
    clients: Vec<(UnixStream, Vec<u8>)>,
}

/// `LINK.monitor`, beside LINK.
pub fn socket_beside(link: &Path) -> PathBuf {
    let mut name = link.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".monitor");
    link.with_file_name(name)
}

impl Monitor {
    /// Opens the log file and the socket (`default_socket` when the options name none).
    pub(crate) fn open(options: &MonitorOptions, default_socket: Option<PathBuf>) -> Result<Monitor, ServeError> {
        let log = match &options.log {
            Some(path) => {
                let file = std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(path)
                    .map_err(|e| ServeError::Io(format!("cannot open the log file {}: {e}", path.display())))?;
                Some((io::BufWriter::new(file), options.log_json))
            }
            None => None,
        };
        let explicit = options.socket.is_some();
        let listener = match options.socket.clone().or(default_socket) {
            Some(path) => {
                // A socket left by a server that was killed: nobody listens, so it is replaced. One a live
                // server listens on is that server's (its link's lock already kept us out of its LINK).
                if std::fs::symlink_metadata(&path).is_ok() {
                    if UnixStream::connect(&path).is_ok() {
                        return Err(ServeError::Io(format!(
                            "{} is the monitor socket of another running server",
                            path.display()
                        )));
                    }
                    let _ = std::fs::remove_file(&path);
                }
                match UnixListener::bind(&path).and_then(|l| l.set_nonblocking(true).map(|()| l)) {
                    Ok(listener) => Some((listener, path)),
                    Err(e) if explicit => {
                        return Err(ServeError::Io(format!("cannot make the monitor socket {}: {e}", path.display())))
                    }
                    // The default place (beside LINK) may not take a socket (a path longer than a socket
                    // address holds, a file system without sockets): served without a monitor, said once.
                    Err(e) => {
                        eprintln!(
                            "tmcl: no monitor socket at {} ({e}); give --monitor-socket PATH for `tmcl monitor`",
                            path.display()
                        );
                        None
                    }
                }
            }
            None => None,
        };
        Ok(Monitor { log, stderr: options.stderr, listener, clients: Vec::new() })
    }

    /// The monitor socket's path, if there is one.
    pub(crate) fn socket(&self) -> Option<&Path> {
        self.listener.as_ref().map(|(_, p)| p.as_path())
    }

    /// The socket to wait on for new clients.
    pub(crate) fn listener(&self) -> Option<&UnixListener> {
        self.listener.as_ref().map(|(l, _)| l)
    }

    /// Whether anything wants the records (so that the caller may skip decoding).
    pub(crate) fn wanted(&self) -> bool {
        self.log.is_some() || self.stderr || !self.clients.is_empty()
    }

    /// Takes the clients that connected.
    pub(crate) fn accept(&mut self) {
        let Some((listener, _)) = &self.listener else { return };
        while let Ok((stream, _)) = listener.accept() {
            let _ = stream.set_nonblocking(true);
            self.clients.push((stream, Vec::new()));
        }
    }

    /// Writes one record everywhere.
    pub(crate) fn record(&mut self, t: &Transaction) {
        let json = serde_json::to_string(t).unwrap_or_default();
        if self.stderr {
            eprintln!("{}", t.line());
        }
        if let Some((file, as_json)) = &mut self.log {
            let _ = if *as_json { writeln!(file, "{json}") } else { writeln!(file, "{}", t.line()) };
            let _ = file.flush();
        }
        for (_, pending) in &mut self.clients {
            pending.extend_from_slice(json.as_bytes());
            pending.push(b'\n');
        }
        self.flush();
    }

    /// Writes what the clients can take now; drops those that closed or fell too far behind.
    pub(crate) fn flush(&mut self) {
        self.clients.retain_mut(|(stream, pending)| {
            while !pending.is_empty() {
                match stream.write(pending) {
                    Ok(0) => return false,
                    Ok(n) => {
                        pending.drain(..n);
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                    Err(_) => return false,
                }
            }
            pending.len() <= CLIENT_BACKLOG
        });
    }
}

impl Drop for Monitor {
    fn drop(&mut self) {
        if let Some((file, _)) = &mut self.log {
            let _ = file.flush();
        }
        if let Some((_, path)) = &self.listener {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// A request seen on a link of `tmcl serve`, not answered yet.
struct Waiting {
    /// The frame (binary) or the line (ASCII).
    bytes: Vec<u8>,
    since: std::time::Instant,
}

/// One link of `tmcl serve` as the monitor follows it.
#[derive(Default)]
struct Track {
    rx: Vec<u8>,
    rx_last: Option<std::time::Instant>,
    tx: Vec<u8>,
    waiting: std::collections::VecDeque<Waiting>,
    ascii: bool,
}

/// How long a request of `tmcl serve` waits for its reply before the monitor says it got none (GP 255
/// set, 137 carried out, an address no module on the bus has).
const SERVE_NO_REPLY: std::time::Duration = std::time::Duration::from_secs(1);

/// The transactions of `tmcl serve`'s links, pieced together from the bytes each link carries: the
/// module's replies on a link come in the order of its requests (each is answered before the next is
/// taken), so each reply answers the oldest request of its link with the same command number; requests
/// it passes by got none. The second reply of 138 is an event.
pub(crate) struct Recorder {
    monitor: Monitor,
    tracks: Vec<Track>,
    names: Vec<String>,
    models: Vec<(u8, &'static ModelSpec)>,
}

impl Recorder {
    pub(crate) fn new(monitor: Monitor, names: Vec<String>, models: Vec<(u8, &'static ModelSpec)>) -> Recorder {
        let tracks = names.iter().map(|_| Track::default()).collect();
        Recorder { monitor, tracks, names, models }
    }

    pub(crate) fn monitor_mut(&mut self) -> &mut Monitor {
        &mut self.monitor
    }

    pub(crate) fn listener(&self) -> Option<&UnixListener> {
        self.monitor.listener()
    }

    fn model(&self, address: u8) -> Option<&'static ModelSpec> {
        self.models.iter().find(|(a, _)| *a == address).or(self.models.first()).map(|(_, m)| *m)
    }

    /// A link's client went away: what it left unanswered is forgotten.
    pub(crate) fn reset(&mut self, n: usize) {
        if let Some(t) = self.tracks.get_mut(n) {
            *t = Track::default();
        }
    }

    /// Bytes a host sent on link `n`.
    pub(crate) fn request(&mut self, n: usize, bytes: &[u8]) {
        if !self.monitor.wanted() {
            return;
        }
        let now = std::time::Instant::now();
        let Some(t) = self.tracks.get_mut(n) else { return };
        if !t.ascii
            && t.rx_last.is_some_and(|l| now.duration_since(l).as_micros() as u64 > crate::bus::STREAM_RESYNC.micros())
        {
            t.rx.clear();
        }
        t.rx.extend_from_slice(bytes);
        t.rx_last = Some(now);
        if t.ascii {
            while let Some(end) = t.rx.iter().position(|&b| b == b'\r') {
                let line: Vec<u8> = t.rx.drain(..=end).filter(|&b| b != b'\n').collect();
                t.waiting.push_back(Waiting { bytes: line, since: now });
            }
        } else {
            while t.rx.len() >= 9 {
                let frame: Vec<u8> = t.rx.drain(..9).collect();
                t.waiting.push_back(Waiting { bytes: frame, since: now });
            }
        }
    }

    /// Bytes a module sent on link `n`.
    pub(crate) fn reply(&mut self, n: usize, bytes: &[u8]) {
        if !self.monitor.wanted() {
            return;
        }
        let Some(t) = self.tracks.get_mut(n) else { return };
        t.tx.extend_from_slice(bytes);
        loop {
            let t = &mut self.tracks[n];
            if t.ascii {
                let Some(end) = t.tx.iter().position(|&b| b == b'\r') else { return };
                let line: Vec<u8> = t.tx.drain(..=end).collect();
                // The echo of a line (GP 67) is not its reply.
                if t.waiting.front().is_some_and(|w| w.bytes == line) {
                    continue;
                }
                let asked = t.waiting.pop_front();
                let leave = asked.as_ref().is_some_and(|w| {
                    String::from_utf8_lossy(&w.bytes)
                        .trim()
                        .get(1..)
                        .is_some_and(|c| c.trim().eq_ignore_ascii_case("BIN"))
                });
                if leave {
                    t.ascii = false;
                }
                let mut rec = Transaction::now(&self.names[n], Outcome::Answered);
                rec.request = asked.as_ref().map(|w| {
                    let text = String::from_utf8_lossy(&w.bytes).trim_end().to_string();
                    Decoded { raw: text.clone(), text: format!("ASCII {text:?}") }
                });
                rec.round_trip_us = asked.map(|w| w.since.elapsed().as_micros() as u64);
                let text = String::from_utf8_lossy(&line).trim_end().to_string();
                rec.status = text.split(' ').nth(1).and_then(|s| s.parse().ok());
                rec.reply = Some(Decoded { raw: text.clone(), text });
                self.monitor.record(&rec);
                continue;
            }
            if t.tx.len() < 9 {
                return;
            }
            let frame: Vec<u8> = t.tx.drain(..9).collect();
            let event = frame[3] == 138 && frame[2] == 128;
            if event {
                let mut rec = Transaction::now(&self.names[n], Outcome::Event);
                let (decoded, status, _) = decode_reply(&frame, None, self.model(frame[1]));
                rec.reply = Some(decoded);
                rec.status = status.map(u8::from);
                self.monitor.record(&rec);
                continue;
            }
            // The oldest request this reply answers; those before it got none.
            let raw_version = |w: &Waiting| w.bytes.len() == 9 && w.bytes[1] == 136 && w.bytes[2] == 0;
            let answers = |w: &Waiting| {
                raw_version(w)
                    || (w.bytes.len() == 9
                        && (w.bytes[1] == frame[3] || w.bytes[1] == 134 || (frame[2] == 1 && frame[3] == 0)))
            };
            let k = t.waiting.iter().position(answers);
            let skipped: Vec<Waiting> = match k {
                Some(k) => t.waiting.drain(..k).collect(),
                None => Vec::new(),
            };
            let asked = k.and_then(|_| self.tracks[n].waiting.pop_front());
            for w in skipped {
                self.no_reply(n, &w);
            }
            let model = self.model(asked.as_ref().map_or(frame[1], |w| w.bytes[0]));
            let mut rec =
                Transaction::now(&self.names[n], if asked.is_some() { Outcome::Answered } else { Outcome::Foreign });
            let (decoded, status, note) = decode_reply(&frame, asked.as_ref().map(|w| &w.bytes[..]), model);
            rec.request = asked.as_ref().map(|w| decode_request(&w.bytes, model));
            rec.reply = Some(decoded);
            rec.status = status.map(u8::from);
            rec.note = note;
            rec.round_trip_us = asked.as_ref().map(|w| w.since.elapsed().as_micros() as u64);
            if asked.as_ref().is_some_and(|w| w.bytes[1] == 139) && status == Some(Status::Ok) {
                self.tracks[n].ascii = true;
                self.tracks[n].rx.clear();
            }
            self.monitor.record(&rec);
        }
    }

    fn no_reply(&mut self, n: usize, w: &Waiting) {
        let mut rec = Transaction::now(&self.names[n], Outcome::NoReply);
        rec.request = Some(if self.tracks[n].ascii || w.bytes.len() != 9 {
            let text = String::from_utf8_lossy(&w.bytes).trim_end().to_string();
            Decoded { raw: text.clone(), text: format!("ASCII {text:?}") }
        } else {
            decode_request(&w.bytes, self.model(w.bytes[0]))
        });
        rec.round_trip_us = Some(w.since.elapsed().as_micros() as u64);
        self.monitor.record(&rec);
    }

    /// Writes what the monitor clients can take, and says which requests got no reply. No system call
    /// without a client (this runs every turn of the serve loop; new clients are taken when the loop's
    /// wait finds the socket readable).
    pub(crate) fn tick(&mut self) {
        self.monitor.flush();
        for n in 0..self.tracks.len() {
            while self.tracks[n].waiting.front().is_some_and(|w| w.since.elapsed() >= SERVE_NO_REPLY) {
                let w = self.tracks[n].waiting.pop_front().expect("checked");
                self.no_reply(n, &w);
            }
        }
    }

    /// When [`Recorder::tick`] has something to say next.
    pub(crate) fn next_due(&self) -> Option<std::time::Instant> {
        self.tracks.iter().filter_map(|t| t.waiting.front().map(|w| w.since + SERVE_NO_REPLY)).min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(address: u8, opcode: u8, kind: u8, motor: u8, value: i32) -> [u8; 9] {
        let mut f = [0u8; 9];
        f[..4].copy_from_slice(&[address, opcode, kind, motor]);
        f[4..8].copy_from_slice(&value.to_be_bytes());
        f[8] = tmcl_wire::checksum(&f[..8]);
        f
    }

    #[test]
    fn requests_and_replies_read_with_the_model_names_and_units() {
        let model = tmcl_core::model::by_id("pd28-1021");
        let gap = frame(1, 6, 4, 0, 0);
        let request = decode_request(&gap, model);
        assert_eq!(request.raw, hex(&gap));
        assert!(request.text.starts_with("to 1: GAP 4"), "{}", request.text);
        assert!(request.text.contains("(Max"), "{}", request.text);
        let (reply, status, note) = decode_reply(&frame(2, 1, 100, 6, 1234), Some(&gap), model);
        assert_eq!(status, Some(Status::Ok));
        assert!(reply.text.contains("1234 pps"), "{}", reply.text);
        assert_eq!(note, None);
        // A refused SAP says what the parameter takes.
        let sap = frame(1, 5, 4, 0, -5);
        let (reply, status, note) = decode_reply(&frame(2, 1, 4, 5, -5), Some(&sap), model);
        assert_eq!(status, Some(Status::InvalidValue));
        assert!(reply.text.starts_with("4 (invalid value)"), "{}", reply.text);
        assert!(note.as_deref().is_some_and(|n| n.contains("takes")), "{note:?}");
        // The version string.
        let version = frame(1, 136, 0, 0, 0);
        let (reply, _, _) = decode_reply(b"\x021021V142", Some(&version), model);
        assert!(reply.text.contains("1021V142"), "{}", reply.text);
    }

    #[test]
    fn a_default_socket_place_that_takes_none_is_no_error() {
        let dir = tempfile::tempdir().unwrap();
        let long = dir.path().join("x".repeat(120)); // longer than a socket address holds
        let monitor = Monitor::open(&MonitorOptions::default(), Some(long.clone())).unwrap();
        assert!(monitor.socket().is_none());
        let asked = MonitorOptions { socket: Some(long), ..MonitorOptions::default() };
        assert!(Monitor::open(&asked, None).is_err(), "an explicit --monitor-socket must work");
        let fine = dir.path().join("m.monitor");
        let monitor = Monitor::open(&MonitorOptions::default(), Some(fine.clone())).unwrap();
        assert_eq!(monitor.socket(), Some(fine.as_path()));
        drop(monitor);
        assert!(!fine.exists(), "removed when the server stops");
    }

    #[test]
    fn a_line_has_time_host_request_reply_and_round_trip() {
        let mut t = Transaction::now("/tmp/a", Outcome::Answered);
        t.request = Some(decode_request(&frame(1, 6, 4, 0, 0), None));
        t.reply = Some(decode_reply(&frame(2, 1, 100, 6, 7), None, None).0);
        t.round_trip_us = Some(1500);
        let line = t.line();
        assert!(line.contains("/tmp/a  to 1: GAP 4") && line.contains("-> 100 (ok): 7  1.5 ms"), "{line}");
        let back: Transaction = serde_json::from_str(&serde_json::to_string(&t).unwrap()).unwrap();
        assert_eq!(back, t);
    }
}

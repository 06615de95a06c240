//! Several lines in one process (`tmcl serve --fleet FILE`): a CI machine's whole rack of virtual modules,
//! each line with its own modules and links, as separate `tmcl serve` processes would serve them.
//!
//! Each line is a [`Server`] of its own, on a thread of its own: a line is served exactly as it would be
//! alone (its links, its bus, its timing), a busy line never delays another, and two hosts on two lines are
//! answered on two cores at once. An idle line costs its thread's stack and nothing else: its loop sleeps
//! until its modules' next event (see [`Server::run`]).

use crate::serve::{Server, Stopper};
use crate::{LinkOptions, Options, ServeError};
use std::collections::HashMap;

/// Lines to serve together, open and ready (see the module docs).
pub struct Fleet {
    servers: Vec<Server>,
}

/// What says which line an error is about.
fn on_line(n: usize, e: ServeError) -> ServeError {
    match e {
        ServeError::Config(m) => ServeError::Config(format!("line {n}: {m}")),
        ServeError::Input(m) => ServeError::Input(format!("line {n}: {m}")),
        ServeError::Io(m) => ServeError::Io(format!("line {n}: {m}")),
    }
}

impl Fleet {
    /// Opens every line (its modules, links, EEPROM files), in order; fails before serving anything if one
    /// cannot be had (the lines opened before it are closed again, their links removed). Lines are numbered
    /// from 1 in errors.
    ///
    /// # Errors
    ///
    /// Those of [`Server::new`], and [`ServeError::Config`] for no line at all or a link given to two lines.
    pub fn new(lines: Vec<Options>) -> Result<Fleet, ServeError> {
        if lines.is_empty() {
            return Err(ServeError::Config("a fleet of no line".into()));
        }
        let mut seen: HashMap<String, usize> = HashMap::new();
        for (n, line) in lines.iter().enumerate() {
            for link in &line.links {
                let key = match link {
                    LinkOptions::Pty(path) => format!("pty {}", path.display()),
                    LinkOptions::Tcp(addr) => format!("tcp {addr}"),
                };
                if let Some(first) = seen.insert(key.clone(), n + 1) {
                    return Err(ServeError::Config(format!("lines {first} and {} both serve {key}", n + 1)));
                }
            }
        }
        let servers = lines
            .into_iter()
            .enumerate()
            .map(|(n, o)| Server::new(o).map_err(|e| on_line(n + 1, e)))
            .collect::<Result<_, _>>()?;
        Ok(Fleet { servers })
    }

    /// The lines, in order.
    pub fn lines(&self) -> &[Server] {
        &self.servers
    }

    /// As [`Server::set_flush_on_stop`], for every line.
    pub fn set_flush_on_stop(&mut self, flush: bool) {
        for server in &mut self.servers {
            server.set_flush_on_stop(flush);
        }
    }

    /// The handles that stop the lines, one per line; [`Fleet::run`] stops them all when one stops.
    pub fn stoppers(&self) -> Vec<Stopper> {
        self.servers.iter().map(Server::stopper).collect()
    }

    /// Serves every line, each on a thread of its own, until one of them stops (its [`Stopper`], a signal
    /// given to [`Stopper::stop_on_signals`], or a failure); then stops the others and waits for them all.
    ///
    /// # Errors
    ///
    /// The first line's error in line order, as [`Server::run`] reports it, with the line's number.
    pub fn run(self) -> Result<(), ServeError> {
        let stoppers = self.stoppers();
        let (done, finished) = std::sync::mpsc::channel();
        let mut threads = Vec::new();
        for (n, server) in self.servers.into_iter().enumerate() {
            let done = done.clone();
            let thread = std::thread::Builder::new().name(format!("tmcl-serve-{}", n + 1)).spawn(move || {
                let result = server.run();
                let _ = done.send(n);
                result
            });
            match thread {
                Ok(t) => threads.push(t),
                Err(e) => {
                    stoppers.iter().for_each(Stopper::stop);
                    for t in threads {
                        let _ = t.join();
                    }
                    return Err(ServeError::Io(format!("cannot start the thread of line {}: {e}", n + 1)));
                }
            }
        }
        drop(done);
        // The first line to end (stopped or failed) ends the fleet.
        let _ = finished.recv();
        stoppers.iter().for_each(Stopper::stop);
        let mut first = Ok(());
        for (n, thread) in threads.into_iter().enumerate() {
            let result = thread
                .join()
                .unwrap_or_else(|_| Err(ServeError::Io("the server's thread panicked".into())))
                .map_err(|e| on_line(n + 1, e));
            if first.is_ok() {
                first = result;
            }
        }
        first
    }
}

//! A host transport straight into a module in this process: no pty, no socket, no thread. Each request
//! lets 1 ms of module time pass before the module receives it, and a reply not yet there lets up to 50 ms
//! more pass (at most the client's timeout), so a host client drives a simulated module in simulated time.
//! `tmcl twin` writes its EEPROM images through it; tests drive the workbench's link with it.

use std::collections::VecDeque;
use std::io;
use std::time::Duration;
use tmcl_core::{Instant, Module};
use tmcl_host::{HostError, Transport};
use tmcl_sim::SimBoard;

/// The most module time one wait for a reply lets pass.
const MAX_WAIT: Duration = Duration::from_millis(50);

/// A [`Transport`] into a [`Module`] on a [`SimBoard`] in this process (see the module docs).
pub struct InProcess {
    module: Module<SimBoard>,
    now: Instant,
    rx: VecDeque<u8>,
}

impl InProcess {
    /// A transport into `module`, whose clock starts at 0.
    pub fn new(module: Module<SimBoard>) -> InProcess {
        InProcess { module, now: Instant::ZERO, rx: VecDeque::new() }
    }

    fn advance(&mut self, d: Duration) {
        self.now += tmcl_core::Duration::from_micros(d.as_micros() as u64);
        let rx = &mut self.rx;
        self.module.poll(self.now, &mut |b: &[u8]| rx.extend(b));
    }
}

impl Transport for InProcess {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.advance(Duration::from_millis(1));
        let rx = &mut self.rx;
        self.module.receive(self.now, bytes, &mut |b: &[u8]| rx.extend(b));
        Ok(())
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        if self.rx.len() < buf.len() {
            self.advance(timeout.min(MAX_WAIT));
        }
        if self.rx.len() < buf.len() {
            let received = self.rx.len();
            self.rx.clear();
            return Err(HostError::Timeout { waited: timeout, received });
        }
        for b in buf.iter_mut() {
            *b = self.rx.pop_front().unwrap_or_default();
        }
        Ok(())
    }

    fn clear_input(&mut self) {
        self.rx.clear();
    }
}

//! An RS485 line with one or more virtual modules on it (PD28-1021 manual §3.1, §5.1 GP 65–87).
//!
//! Every module hears every byte the host sends and answers only its own address (GP 66) or secondary
//! address (GP 87), after its telegram pause (GP 75). Their replies share the one line back to the host.
//!
//! **Wire timing** (`--wire-timing`): each byte takes 10 bit times (8N1) at the module's baud rate (GP 65
//! as it was at the module's last start, manual §5.1). A module receives the host's bytes one byte time
//! apart, so a 9-byte request completes 9 byte times after it was written; a reply occupies the line for
//! 9 byte times, and a reply that is ready while the line is busy waits for it. Without wire timing the
//! line is as fast as the pty.
//!
//! **No frame lost.** Without wire timing the host's bytes come through a buffer (a pty, a TCP socket), in
//! any number per read: each module keeps the bytes it has not taken yet (its backlog) and takes the next
//! frame only when the reply to the one before has gone out ([`Module::receive_in_turn`]), so a backlog of
//! any length is answered in order, one reply per frame, telegram pause or not. The inter-byte timeout of a
//! serial line (5 ms, [`tmcl_core::iface::INTER_BYTE_TIMEOUT`]) applies with wire timing only; without it a
//! partial frame is dropped after [`STREAM_RESYNC`] of silence (see docs/decisions.md, "No frame lost").
//!
//! **Decisions.** Two modules answering at once (a shared secondary address) would garble each other on
//! a real bus; here the line sends the replies one after the other, whole, in the order they became due.
//! A module in ASCII mode on the line reads binary frames for others as text: their control bytes and
//! bytes above 0x7F discard its line, and a line it is left with is ignored unless it starts with its
//! address character; its text replies travel on the same line (a host mixing modes must expect them),
//! see docs/decisions.md.

use std::collections::VecDeque;
use tmcl_core::{Duration, Instant, Module};
use tmcl_sim::SimBoard;

/// Without wire timing, the silence after which a partial frame is dropped: ten times the serial line's
/// 5 ms, so that a frame a host writes in pieces (byte by byte from a script, or delayed by a loaded
/// machine) is still one frame, and short enough that a stray byte (a text line for a module in ASCII
/// mode, what a killed host left behind) is forgotten before a host's next request, as a host that pauses
/// after an error expects.
pub const STREAM_RESYNC: Duration = Duration::from_millis(50);

/// One module on the line.
pub struct Node {
    /// The module.
    pub module: Module<SimBoard>,
    /// A name for logs (model@address as started).
    pub name: String,
    /// Bytes on their way to this module (due time, byte), with wire timing.
    inbound: VecDeque<(Instant, u8)>,
    /// Bytes the module has not taken yet (without wire timing): it takes a frame when the reply to the
    /// one before has gone out.
    backlog: Vec<VecDeque<u8>>,
}

impl Node {
    /// A module on the line.
    pub fn new(module: Module<SimBoard>, name: String) -> Node {
        Node { module, name, inbound: VecDeque::new(), backlog: vec![VecDeque::new()] }
    }

    /// Time of one byte (10 bits) at the module's baud rate.
    pub fn byte_time(&self) -> Duration {
        let baud = tmcl_core::model::baud_rate(self.module.active_baud());
        Duration::from_micros(10_000_000 / u64::from(baud))
    }
}

/// Where the modules' bytes go: to host link `link` (0 for the only one).
pub type LinkSink<'a> = dyn FnMut(usize, &[u8]) + 'a;

/// The line and the modules on it.
pub struct Bus {
    /// The modules, in command-line order.
    pub nodes: Vec<Node>,
    wire_timing: bool,
    /// How many host links reach the modules.
    links: usize,
    /// Bytes waiting to go to the host (with wire timing): (byte, its byte time).
    outbound: VecDeque<(u8, Duration)>,
    /// When the line back to the host is free again.
    line_free: Instant,
}

impl Bus {
    /// A line with these modules, reached by one host link.
    pub fn new(nodes: Vec<Node>, wire_timing: bool) -> Bus {
        Bus::with_links(nodes, wire_timing, 1)
    }

    /// A line with these modules, reached by `links` host links: each is a host interface of its own on
    /// every module (its own framer, ASCII line and replies, [`Module::link_port`]), so a host never sees
    /// the replies to another. Wire timing is for one link (one wire).
    ///
    /// # Panics
    ///
    /// If `links` is 0, more than the core keeps ([`tmcl_core::iface::HOST_LINKS`]), or more than 1 with wire
    /// timing.
    pub fn with_links(mut nodes: Vec<Node>, wire_timing: bool, links: usize) -> Bus {
        assert!((1..=tmcl_core::iface::HOST_LINKS).contains(&links) && (links == 1 || !wire_timing));
        for node in &mut nodes {
            let timeout = if wire_timing { tmcl_core::iface::INTER_BYTE_TIMEOUT } else { STREAM_RESYNC };
            node.module.set_inter_byte_timeout(Some(timeout));
            node.backlog = (0..links).map(|_| VecDeque::new()).collect();
        }
        Bus { nodes, wire_timing, links, outbound: VecDeque::new(), line_free: Instant::ZERO }
    }

    /// How many host links reach the modules.
    pub fn links(&self) -> usize {
        self.links
    }

    /// Bytes from the host on link `link`, written at `now`.
    pub fn receive(&mut self, link: usize, now: Instant, bytes: &[u8], sink: &mut LinkSink<'_>) {
        for i in 0..self.nodes.len() {
            if self.wire_timing {
                let node = &mut self.nodes[i];
                let byte = node.byte_time();
                let start = node.inbound.back().map_or(now, |(t, _)| (*t).max(now));
                for (k, &b) in bytes.iter().enumerate() {
                    node.inbound.push_back((start + Duration::from_micros(byte.micros() * (k as u64 + 1)), b));
                }
            } else {
                self.nodes[i].backlog[link].extend(bytes);
                self.pump(i, link, now, sink);
            }
        }
        self.poll(now, sink);
    }

    /// Drops partial frames of link `link` everywhere (a host connection ended or began).
    pub fn reset_link(&mut self, link: usize) {
        for node in &mut self.nodes {
            if let Some(port) = node.module.link_port(link) {
                node.module.reset_port(port);
            }
            if link == 0 {
                node.inbound.clear();
            }
            node.backlog[link].clear();
        }
    }

    /// Advances every module and the line to `now`; returns the next deadline.
    pub fn poll(&mut self, now: Instant, sink: &mut LinkSink<'_>) -> Option<Instant> {
        let mut next: Option<Instant> = None;
        let mut consider = |t: Option<Instant>| {
            if let Some(t) = t {
                next = Some(next.map_or(t, |n: Instant| n.min(t)));
            }
        };
        for i in 0..self.nodes.len() {
            // Deliver the bytes due, each at its own time.
            while let Some(&(t, b)) = self.nodes[i].inbound.front() {
                if t > now {
                    break;
                }
                self.nodes[i].inbound.pop_front();
                let mut out = Vec::new();
                self.nodes[i].module.receive(t, &[b], &mut |x: &[u8]| out.extend_from_slice(x));
                self.emit(i, 0, t, &out, sink);
            }
            for link in 0..self.links {
                let Some(port) = self.nodes[i].module.link_port(link) else { continue };
                let mut out = Vec::new();
                let mut deadline = self.nodes[i].module.poll_port(port, now, &mut |x: &[u8]| out.extend_from_slice(x));
                self.emit(i, link, now, &out, sink);
                if !self.nodes[i].backlog[link].is_empty() && self.pump(i, link, now, sink) {
                    let mut out = Vec::new();
                    deadline = self.nodes[i].module.poll_port(port, now, &mut |x: &[u8]| out.extend_from_slice(x));
                    self.emit(i, link, now, &out, sink);
                }
                consider(deadline);
            }
            consider(self.nodes[i].inbound.front().map(|(t, _)| *t));
        }
        consider(self.drain(now, sink));
        next
    }

    /// Offers module `i` the backlog of link `link`; returns whether it took anything.
    fn pump(&mut self, i: usize, link: usize, now: Instant, sink: &mut LinkSink<'_>) -> bool {
        let node = &mut self.nodes[i];
        let Some(port) = node.module.link_port(link) else { return false };
        let mut out = Vec::new();
        let taken = node
            .module
            .receive_in_turn(port, now, node.backlog[link].make_contiguous(), &mut |b: &[u8]| out.extend_from_slice(b));
        node.backlog[link].drain(..taken);
        self.emit(i, link, now, &out, sink);
        taken > 0
    }

    /// Bytes not yet taken by the modules (without wire timing), the most any one module holds on a link.
    pub fn backlog(&self) -> usize {
        self.nodes.iter().flat_map(|n| n.backlog.iter().map(VecDeque::len)).max().unwrap_or(0)
    }

    /// What module `i` sent at `at` on link `link`: straight to the host, or onto the timed line.
    fn emit(&mut self, i: usize, link: usize, at: Instant, bytes: &[u8], sink: &mut LinkSink<'_>) {
        if bytes.is_empty() {
            return;
        }
        if !self.wire_timing {
            sink(link, bytes);
            return;
        }
        let byte = self.nodes[i].byte_time();
        if self.outbound.is_empty() {
            self.line_free = self.line_free.max(at);
        }
        self.outbound.extend(bytes.iter().map(|&b| (b, byte)));
    }

    /// Sends the bytes whose transmission has ended by `now`; returns when the next one will have.
    fn drain(&mut self, now: Instant, sink: &mut LinkSink<'_>) -> Option<Instant> {
        let mut ready = Vec::new();
        while let Some(&(b, time)) = self.outbound.front() {
            let done = self.line_free + time;
            if done > now {
                break;
            }
            self.line_free = done;
            self.outbound.pop_front();
            ready.push(b);
        }
        if !ready.is_empty() {
            sink(0, &ready);
        }
        self.outbound.front().map(|(_, time)| self.line_free + *time)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tmcl_core::model::pd28_1021::SPEC;
    use tmcl_wire::{Instruction, Opcode, Reply, ReplyFrame, Request};

    fn bus(addresses: &[u8], wire: bool) -> Bus {
        let nodes = addresses
            .iter()
            .map(|&a| {
                let mut m = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
                m.set_address(a, Instant::ZERO).unwrap();
                Node::new(m, format!("pd28-1021@{a}"))
            })
            .collect();
        Bus::new(nodes, wire)
    }

    fn gap(address: u8) -> [u8; 9] {
        Request { address, instruction: Instruction::new(Opcode::Gap, 4, 0, 0) }.to_bytes()
    }

    #[test]
    fn each_module_answers_its_address() {
        let mut b = bus(&[1, 2, 3], false);
        for a in 1..=3 {
            let mut out = Vec::new();
            b.receive(0, Instant::ZERO, &gap(a), &mut |_, x: &[u8]| out.extend_from_slice(x));
            let r = Reply::parse(&ReplyFrame::new_checked(&out[..]).unwrap()).unwrap();
            assert_eq!((out.len(), r.module), (9, a));
        }
        let mut out = Vec::new();
        b.receive(0, Instant::ZERO, &gap(4), &mut |_, x: &[u8]| out.extend_from_slice(x));
        assert!(out.is_empty());
    }

    #[test]
    fn wire_timing_at_9600_baud() {
        let mut b = bus(&[1, 2], true);
        let mut out = Vec::new();
        let t0 = Instant::from_secs(1);
        b.receive(0, t0, &gap(2), &mut |_, x: &[u8]| out.extend_from_slice(x));
        assert!(out.is_empty());
        // 9 bytes in (9 × 1.041 ms), then 9 bytes out.
        let (mut t, mut done) = (t0, t0);
        while out.len() < 9 {
            done = t;
            t = b.poll(t, &mut |_, x: &[u8]| out.extend_from_slice(x)).expect("something pending");
        }
        let elapsed = (done - t0).micros();
        assert!((18 * 1041..=18 * 1041 + 20).contains(&elapsed), "{elapsed} µs");
        assert_eq!(out[1], 2);
    }
}

//! Polling a module: read one value until it meets a condition (`tmcl wait`), or several values in rows
//! at a steady pace (`tmcl watch`).
//!
//! Both only read (GAP, GGP, GIO, RFS STATUS; PD28-1021 manual §3.7), one request at a time, so they never
//! ask faster than the line answers, and they work on real and virtual modules alike. A stop flag (set by
//! a signal handler, say) ends them between two requests.

use crate::{Client, HostError, Transport};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tmcl_wire::{Command, RfsAction};

/// One value a host reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reading {
    /// Axis parameter `param` of `motor` (GAP).
    Axis {
        /// The parameter's number.
        param: u8,
        /// The motor.
        motor: u8,
    },
    /// Global parameter `param` of `bank` (GGP).
    Global {
        /// The parameter's number.
        param: u8,
        /// The bank.
        bank: u8,
    },
    /// Input or output `port` of `bank` (GIO).
    Port {
        /// The port.
        port: u8,
        /// The bank (0 digital inputs, 1 analog inputs, 2 outputs).
        bank: u8,
    },
    /// The reference search of `motor` (RFS STATUS: 0 once it has ended).
    Reference {
        /// The motor.
        motor: u8,
    },
}

impl Reading {
    /// The command that reads it.
    pub fn command(self) -> Command {
        match self {
            Reading::Axis { param, motor } => Command::Gap { param, motor },
            Reading::Global { param, bank } => Command::Ggp { param, bank },
            Reading::Port { port, bank } => Command::Gio { port, bank },
            Reading::Reference { motor } => Command::Rfs { action: RfsAction::Status, motor },
        }
    }

    /// Reads it.
    pub fn read<T: Transport>(self, client: &mut Client<T>) -> Result<i32, HostError> {
        match self {
            Reading::Reference { motor } => client.reference_search(RfsAction::Status, motor),
            other => Ok(client.request(other.command().encode())?.value),
        }
    }
}

/// A comparison of a value with another (`tmcl wait value … ge 51200`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Comparison {
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
}

impl Comparison {
    /// Whether `a` compares so with `b`.
    pub fn holds(self, a: i32, b: i32) -> bool {
        match self {
            Comparison::Eq => a == b,
            Comparison::Ne => a != b,
            Comparison::Lt => a < b,
            Comparison::Le => a <= b,
            Comparison::Gt => a > b,
            Comparison::Ge => a >= b,
        }
    }

    /// `==`, `!=`, `<`, `<=`, `>`, `>=`.
    pub fn symbol(self) -> &'static str {
        match self {
            Comparison::Eq => "==",
            Comparison::Ne => "!=",
            Comparison::Lt => "<",
            Comparison::Le => "<=",
            Comparison::Gt => ">",
            Comparison::Ge => ">=",
        }
    }
}

impl std::str::FromStr for Comparison {
    type Err = String;

    /// `eq`, `ne`, `lt`, `le`, `gt`, `ge` (any case) or the symbols (`=` too).
    fn from_str(text: &str) -> Result<Comparison, String> {
        Ok(match text.to_ascii_lowercase().as_str() {
            "eq" | "==" | "=" => Comparison::Eq,
            "ne" | "!=" => Comparison::Ne,
            "lt" | "<" => Comparison::Lt,
            "le" | "<=" => Comparison::Le,
            "gt" | ">" => Comparison::Gt,
            "ge" | ">=" => Comparison::Ge,
            _ => return Err(format!("`{text}` is no comparison: use eq, ne, lt, le, gt or ge")),
        })
    }
}

/// How a wait ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Waited {
    /// The condition came true: the value read, after how long.
    Met {
        /// The value that met it.
        value: i32,
        /// Since the first request.
        elapsed: Duration,
    },
    /// The time given ran out; the last value read.
    TimedOut {
        /// The last value.
        value: i32,
    },
    /// The stop flag was set; the last value read.
    Stopped {
        /// The last value.
        value: i32,
    },
}

/// Reads `reading` every `every` until it compares with `wanted` as `op` says, `within` runs out or `stop`
/// is set. Never asks faster than the module answers.
pub fn wait_until<T: Transport>(
    client: &mut Client<T>,
    reading: Reading,
    op: Comparison,
    wanted: i32,
    every: Duration,
    within: Option<Duration>,
    stop: &AtomicBool,
) -> Result<Waited, HostError> {
    let started = Instant::now();
    loop {
        let value = reading.read(client)?;
        let elapsed = started.elapsed();
        if op.holds(value, wanted) {
            return Ok(Waited::Met { value, elapsed });
        }
        if within.is_some_and(|w| elapsed >= w) {
            return Ok(Waited::TimedOut { value });
        }
        if stop.load(Ordering::Relaxed) {
            return Ok(Waited::Stopped { value });
        }
        let pause = match within {
            Some(w) => every.min(w.saturating_sub(elapsed)),
            None => every,
        };
        pause_until(Instant::now() + pause, stop);
    }
}

/// When a watch ends: after so many rows, after so long (whichever comes first), or only on the stop flag.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Limits {
    /// The most rows.
    pub count: Option<u64>,
    /// The longest time.
    pub duration: Option<Duration>,
}

/// Reads `readings` in rows, row n due n × `every` after the start (never before the module has answered
/// the last one), and hands each row to `row` with its time since the start, until `limits` or `stop` end
/// it. `row`'s error ends the watch too.
pub fn watch<T: Transport, E: From<HostError>>(
    client: &mut Client<T>,
    readings: &[Reading],
    every: Duration,
    limits: Limits,
    stop: &AtomicBool,
    mut row: impl FnMut(Duration, &[i32]) -> Result<(), E>,
) -> Result<(), E> {
    let started = Instant::now();
    let mut rows = 0u64;
    let mut values = Vec::with_capacity(readings.len());
    while !stop.load(Ordering::Relaxed) {
        let t = started.elapsed();
        if limits.duration.is_some_and(|d| t > d) || limits.count.is_some_and(|n| rows >= n) {
            break;
        }
        values.clear();
        for reading in readings {
            values.push(reading.read(client)?);
        }
        row(t, &values)?;
        rows += 1;
        pause_until(started + every.saturating_mul(u32::try_from(rows).unwrap_or(u32::MAX)), stop);
    }
    Ok(())
}

/// Sleeps until `deadline`, waking up early (within 50 ms) once `stop` is set.
pub fn pause_until(deadline: Instant, stop: &AtomicBool) {
    while !stop.load(Ordering::Relaxed) {
        let Some(left) = deadline.checked_duration_since(Instant::now()) else { return };
        std::thread::sleep(left.min(Duration::from_millis(50)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MockTransport;
    use tmcl_wire::{Reply, Status};

    #[test]
    fn comparisons() {
        for (text, a, b, holds) in [("ge", 5, 5, true), (">", 5, 5, false), ("lt", -1, 0, true), ("!=", 1, 1, false)] {
            assert_eq!(text.parse::<Comparison>().unwrap().holds(a, b), holds, "{a} {text} {b}");
        }
        assert!("~".parse::<Comparison>().is_err());
    }

    fn replies(values: &[i32], opcode: u8) -> Client<MockTransport> {
        let mut transport = MockTransport::new();
        for &value in values {
            transport.push_input(&Reply { host: 2, module: 1, status: Status::Ok, opcode, value }.to_bytes());
        }
        Client::new(transport)
    }

    #[test]
    fn a_wait_reads_until_the_condition_holds() {
        let mut client = replies(&[0, 0, 1], 6);
        let stop = AtomicBool::new(false);
        let ap8 = Reading::Axis { param: 8, motor: 0 };
        let waited = wait_until(&mut client, ap8, Comparison::Eq, 1, Duration::from_millis(1), None, &stop).unwrap();
        assert!(matches!(waited, Waited::Met { value: 1, .. }), "{waited:?}");
        assert_eq!(client.transport_mut().sent.len(), 27);
    }

    #[test]
    fn a_watch_gives_its_rows() {
        let mut client = replies(&[1, 10, 2, 20], 6);
        let stop = AtomicBool::new(false);
        let readings = [Reading::Axis { param: 1, motor: 0 }, Reading::Axis { param: 3, motor: 0 }];
        let mut rows = Vec::new();
        let limits = Limits { count: Some(2), duration: None };
        watch::<_, HostError>(&mut client, &readings, Duration::from_millis(1), limits, &stop, |_, v| {
            rows.push(v.to_vec());
            Ok(())
        })
        .unwrap();
        assert_eq!(rows, [[1, 10], [2, 20]]);
    }
}

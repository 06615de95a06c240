//! `tmcl wait` and `tmcl watch`: poll a module until something is true, or print values as they change.
//!
//! The polling itself is the host library's ([`tmcl_host::poll`]): both only read, one request at a time.
//! Here: the arguments, the names of what is read, and the printing.

use crate::args::{parse_byte, parse_seconds, parse_value};
use crate::connection::{Connection, HostClient};
use crate::error::CliError;
use crate::names::{ModelOption, Models, ParamRef, Target};
use clap::{Args, Subcommand, ValueEnum};
use std::io::Write;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;
use tmcl_core::model::Role;
use tmcl_host::poll::{self, Comparison, Reading};

/// Options of `tmcl wait`.
#[derive(Debug, Clone, Args)]
pub struct WaitArgs {
    #[command(flatten)]
    pub conn: Connection,
    #[command(flatten)]
    pub model: ModelOption,
    #[command(subcommand)]
    pub what: WaitFor,
    /// Give up after SECONDS (exit code 5); without it, wait until the condition is true or Ctrl-C.
    #[arg(long, global = true, value_name = "SECONDS", value_parser = parse_seconds)]
    pub within: Option<Duration>,
    /// Ask every SECONDS.
    #[arg(long, global = true, value_name = "SECONDS", default_value = "0.05", value_parser = parse_seconds)]
    pub every: Duration,
}

/// What `tmcl wait` waits for.
#[derive(Debug, Clone, Subcommand)]
pub enum WaitFor {
    /// Until the motor has reached its target position: the model's position reached flag (AP 8, PD28-1021
    /// manual §4 Table 15) reads 1 (on a closed-loop module, within the position window AP 134).
    Reached {
        /// Motor number.
        #[arg(long, short, default_value_t = 0)]
        motor: u8,
    },
    /// Until the reference search has ended: RFS STATUS answers 0 (manual §3.7.13).
    Reference {
        /// Motor number.
        #[arg(long, short, default_value_t = 0)]
        motor: u8,
    },
    /// Until a value meets a condition, e.g. `tmcl wait value ap ActualPosition ge 51200`.
    #[command(allow_negative_numbers = true)]
    Value {
        /// What to read: ap (GAP), gp (GGP) or io (GIO).
        kind: Kind,
        /// Parameter number or name (ap, gp), or port number (io); `:N` picks the motor or bank, e.g.
        /// `gp 0:2` (user variable 0) or `io 0:1` (analog input 0).
        #[arg(value_name = "NUMBER|NAME[:N]")]
        param: String,
        /// The comparison: eq, ne, lt, le, gt, ge (or ==, !=, <, <=, >, >=).
        #[arg(value_parser = parse_comparison)]
        op: Comparison,
        /// The value to compare with.
        #[arg(value_parser = parse_value)]
        value: i32,
    },
}

/// What kind of value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Kind {
    /// An axis parameter (GAP).
    Ap,
    /// A global parameter (GGP).
    Gp,
    /// An input or output port (GIO).
    Io,
}

fn parse_comparison(text: &str) -> Result<Comparison, String> {
    text.parse()
}

/// One value to read: a parameter or a port.
#[derive(Debug, Clone)]
enum Source {
    Param(Target),
    Port { port: u8, bank: u8 },
    Reference { motor: u8 },
}

impl Source {
    /// Resolves `kind param[:N]`.
    fn resolve(kind: Kind, text: &str, models: &mut Models, client: &mut HostClient) -> Result<Source, CliError> {
        let (name, index) = match text.rsplit_once(':') {
            Some((name, n)) => {
                let n = parse_byte(n).map_err(CliError::Usage)?;
                (name, Some(n))
            }
            None => (text, None),
        };
        Ok(match kind {
            Kind::Ap => {
                Source::Param(models.resolve(ParamRef::Axis { param: name, motor: index.unwrap_or(0) }, client)?)
            }
            Kind::Gp => Source::Param(models.resolve(ParamRef::Global { param: name, bank: index }, client)?),
            Kind::Io => Source::Port { port: parse_byte(name).map_err(CliError::Usage)?, bank: index.unwrap_or(0) },
        })
    }

    /// `ap 1`, `gp 0 (bank 2)`, `io 0:1`: the label of a column or a condition.
    fn label(&self) -> String {
        match self {
            Source::Param(target) => target.label(),
            Source::Port { port, bank: 0 } => format!("io {port}"),
            Source::Port { port, bank } => format!("io {port}:{bank}"),
            Source::Reference { motor } => format!("reference search of motor {motor}"),
        }
    }

    /// What the module is asked.
    fn reading(&self) -> Reading {
        match self {
            Source::Param(target) if target.axis => Reading::Axis { param: target.number, motor: target.index },
            Source::Param(target) => Reading::Global { param: target.number, bank: target.index },
            Source::Port { port, bank } => Reading::Port { port: *port, bank: *bank },
            Source::Reference { motor } => Reading::Reference { motor: *motor },
        }
    }
}

/// A flag that turns true on SIGINT or SIGTERM, so that `wait` and `watch` end cleanly.
fn interrupted() -> Result<Arc<AtomicBool>, CliError> {
    let flag = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&flag)).map_err(CliError::Signals)?;
    }
    Ok(flag)
}

/// `tmcl wait`.
pub(crate) fn wait(args: WaitArgs, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    let mut client = args.conn.open()?;
    let mut models = Models::new(&args.model)?;
    let (source, op, wanted) = match &args.what {
        WaitFor::Reached { motor } => {
            // By meaning: the model's position-reached flag; AP 8, which every TMCL module shares (PD28-1021
            // manual §4 Table 15), when the module's version is not one of our tables.
            let model = match models.get(&mut client) {
                Ok(model) => Some(model),
                Err(CliError::Host(e)) => return Err(e.into()),
                Err(_) => None,
            };
            let flag = model.and_then(|m| m.axis.role(Role::PositionReached).map(|i| m.axis.params[i].number));
            let number = flag.unwrap_or(8).to_string();
            let target = models.resolve(ParamRef::Axis { param: &number, motor: *motor }, &mut client)?;
            (Source::Param(target), Comparison::Eq, 1)
        }
        WaitFor::Reference { motor } => (Source::Reference { motor: *motor }, Comparison::Eq, 0),
        WaitFor::Value { kind, param, op, value } => {
            (Source::resolve(*kind, param, &mut models, &mut client)?, *op, *value)
        }
    };
    let condition = match &args.what {
        WaitFor::Reached { motor } => {
            let number = match &source {
                Source::Param(target) => target.number,
                _ => 8,
            };
            format!("motor {motor} reached its target (ap {number} == 1)")
        }
        WaitFor::Reference { motor } => format!("the reference search of motor {motor} ended (RFS STATUS == 0)"),
        WaitFor::Value { .. } => format!("{} {} {wanted}", source.label(), op.symbol()),
    };
    let stop = interrupted()?;
    let waited = poll::wait_until(&mut client, source.reading(), op, wanted, args.every, args.within, &stop)?;
    let (why, value) = match waited {
        poll::Waited::Met { value, elapsed } => {
            if json {
                let row = crate::output::Met {
                    condition: condition.to_string(),
                    elapsed_s: elapsed.as_secs_f64(),
                    met: true,
                    value,
                };
                crate::output::json_line(out, &row)?;
            } else {
                writeln!(out, "{condition} after {:.3} s (value {value})", elapsed.as_secs_f64())?;
            }
            return Ok(());
        }
        poll::Waited::TimedOut { value } => {
            (format!("within {} s", args.within.unwrap_or_default().as_secs_f64()), value)
        }
        poll::Waited::Stopped { value } => ("before the interrupt".to_string(), value),
    };
    Err(CliError::NotMet(format!("not {why}: {condition} (last value {value})")))
}

/// Options of `tmcl watch`.
#[derive(Debug, Clone, Args)]
#[command(allow_negative_numbers = true)]
pub struct WatchArgs {
    #[command(flatten)]
    pub conn: Connection,
    #[command(flatten)]
    pub model: ModelOption,
    /// What to read, as pairs: `ap 1 ap ActualSpeed gp 132 io 0:1` (ap = GAP, gp = GGP, io = GIO; `:N` picks
    /// the motor or bank).
    #[arg(value_name = "KIND NUMBER|NAME[:N]", required = true, num_args = 2..)]
    pub items: Vec<String>,
    /// Read every SECONDS (at most as fast as the module answers).
    #[arg(long, value_name = "SECONDS", default_value = "0.1", value_parser = parse_seconds)]
    pub every: Duration,
    /// Stop after N rows.
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Stop after SECONDS.
    #[arg(long = "for", value_name = "SECONDS", value_parser = parse_seconds)]
    pub duration: Option<Duration>,
}

/// `tmcl watch`.
pub(crate) fn watch(args: WatchArgs, json: bool, out: &mut dyn Write) -> Result<(), CliError> {
    if !args.items.len().is_multiple_of(2) {
        return Err(CliError::Usage(format!(
            "give the values as pairs of kind and parameter, e.g. `ap 1 gp 132`: `{}` has no parameter",
            args.items.last().map(String::as_str).unwrap_or_default()
        )));
    }
    let mut client = args.conn.open()?;
    let mut models = Models::new(&args.model)?;
    let mut sources = Vec::new();
    for pair in args.items.chunks(2) {
        let kind = Kind::from_str(&pair[0], true).map_err(|_| {
            CliError::Usage(format!("`{}` is no kind of value: use ap, gp or io (then a number or name)", pair[0]))
        })?;
        sources.push(Source::resolve(kind, &pair[1], &mut models, &mut client)?);
    }
    let labels: Vec<String> = sources.iter().map(Source::label).collect();
    let width = labels.iter().map(String::len).max().unwrap_or(0).max(11);
    if !json {
        write!(out, "{:>10}", "time_s")?;
        for label in &labels {
            write!(out, "  {label:>width$}")?;
        }
        writeln!(out)?;
        out.flush()?;
    }
    let stop = interrupted()?;
    let readings: Vec<Reading> = sources.iter().map(Source::reading).collect();
    let limits = poll::Limits { count: args.count, duration: args.duration };
    poll::watch(&mut client, &readings, args.every, limits, &stop, |t, values| -> Result<(), CliError> {
        if json {
            let time_s = t.as_millis() as f64 / 1000.0;
            crate::output::json_line(out, &crate::output::WatchRow { time_s, labels: &labels, values })?;
        } else {
            write!(out, "{:>10.3}", t.as_secs_f64())?;
            for value in values {
                write!(out, "  {value:>width$}")?;
            }
            writeln!(out)?;
        }
        out.flush()?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comparisons() {
        assert_eq!(parse_comparison(">="), Ok(Comparison::Ge));
        assert!(parse_comparison("~").unwrap_err().contains("use eq, ne, lt, le, gt or ge"));
    }
}

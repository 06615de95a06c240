//! `tmcl share`: one module, several hosts, each on a link of its own; and `tmcl monitor`, which shows
//! every transaction of a `tmcl share` or `tmcl serve` as it happens.
//!
//! Both are the `tmcl_serve` library (`Share`, `monitor`); this file parses the options, prints where the
//! share serves, wires SIGINT and SIGTERM to its stop, and prints what the monitor socket says.

use crate::args::parse_seconds;
use crate::error::CliError;
use clap::Args;
use serde::Serialize;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::Duration;
use tmcl_host::models::model_by_id;
use tmcl_serve::monitor::{socket_beside, Transaction};
use tmcl_serve::{DeviceOptions, LinkOptions, MonitorOptions, Share, ShareOptions};

/// Options of `tmcl share`.
#[derive(Debug, Args)]
pub struct ShareArgs {
    /// The module's serial port (e.g. /dev/ttyUSB0), or a pty such as the LINK of `tmcl serve --pty` or
    /// of `scripts/qemu-serve.sh`. The share opens it exclusively; a port other processes have open is
    /// refused, naming them, unless --shared.
    #[arg(long, value_name = "PATH", required_unless_present = "connect", conflicts_with = "connect")]
    pub port: Option<PathBuf>,
    /// The module on a TCP port instead, HOST:PORT (`tmcl serve --tcp`, a serial-to-network adapter).
    #[arg(long, value_name = "HOST:PORT")]
    pub connect: Option<String>,
    /// Baud rate of the serial port (ignored by ptys).
    #[arg(long, value_name = "N", default_value_t = 9600)]
    pub baud: u32,
    /// Open --port even when other processes have it open (they would read the module's replies).
    #[arg(long)]
    pub shared: bool,
    /// A host link on a pseudo-terminal: LINK becomes a symlink that a host opens as a serial port
    /// (pytrinamic, pyserial, `tmcl --port LINK`, `tmcl ui --port LINK`). Give --pty and --tcp as often as
    /// there are hosts (up to 16); each host gets only the replies to its own requests.
    ///
    /// LINK.lock beside it names the share's PID, as for `tmcl serve`; the first pty link also gets the
    /// monitor socket LINK.monitor (`tmcl monitor LINK`).
    #[arg(long, value_name = "LINK", required_unless_present = "tcp")]
    pub pty: Vec<PathBuf>,
    /// A host link on a TCP port, HOST:PORT (a bare PORT means 127.0.0.1; port 0 picks a free one); one
    /// client at a time, as `tmcl serve --tcp`.
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Vec<String>,
    /// How long to wait for the module's reply to a request before the next host's request goes out, in
    /// seconds. A host's own timeout should be longer (pytrinamic's is 5 s).
    #[arg(long, value_name = "SECONDS", default_value = "1", value_parser = parse_seconds)]
    pub timeout: Duration,
    /// How long to wait for a reply to a command that may get none: 137, 242, 255, and any command but
    /// GAP, GGP and GIO while GP 255 has switched replies off. A refusal comes within it.
    #[arg(long, value_name = "SECONDS", default_value = "0.1", value_parser = parse_seconds)]
    pub no_reply_wait: Duration,
    /// The module's model, for parameter names and units in the monitor and the log (default: learnt
    /// from the version string when a host asks for it, command 136).
    #[arg(long = "module", value_name = "MODEL")]
    pub module: Option<String>,
    /// Append every transaction to FILE, one line each (with --json, one JSON object each).
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Where the monitor socket goes (default: LINK.monitor beside the first --pty link; without a pty
    /// link there is none unless this names one).
    #[arg(long, value_name = "PATH")]
    pub monitor_socket: Option<PathBuf>,
}

/// The first line of `tmcl share --json`.
#[derive(Debug, Serialize)]
struct Sharing {
    /// The module's device.
    sharing: String,
    /// The host links, in the order given (pty links first, then TCP).
    links: Vec<String>,
    /// The monitor socket, if any.
    monitor: Option<PathBuf>,
}

/// Runs the share until SIGINT or SIGTERM.
pub(crate) fn run(args: ShareArgs, json: bool, verbose: u8) -> Result<(), CliError> {
    let device = match (&args.port, &args.connect) {
        (Some(path), _) => DeviceOptions::Serial { path: path.clone(), baud: args.baud, shared: args.shared },
        (None, Some(addr)) => DeviceOptions::Tcp(addr.clone()),
        (None, None) => return Err(CliError::Usage("give the module's --port (or --connect HOST:PORT)".into())),
    };
    let mut links: Vec<LinkOptions> = args.pty.iter().cloned().map(LinkOptions::Pty).collect();
    links.extend(args.tcp.iter().cloned().map(LinkOptions::Tcp));
    let mut options = ShareOptions::new(device, links);
    options.reply_timeout = args.timeout;
    options.no_reply_wait = args.no_reply_wait;
    options.model = args.module.as_deref().map(model_by_id).transpose()?;
    options.monitor = MonitorOptions {
        log: args.log.clone(),
        log_json: json,
        socket: args.monitor_socket.clone(),
        stderr: verbose > 0,
    };
    let share = Share::new(options)?;
    let stop = share.stopper().flag();
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, std::sync::Arc::clone(&stop)).map_err(CliError::Signals)?;
    }
    let places: Vec<String> = share.links().iter().map(ToString::to_string).collect();
    let monitor = share.monitor_socket();
    if json {
        let line = Sharing { sharing: share.device().to_string(), links: places, monitor };
        println!("{}", serde_json::to_string(&line)?);
    } else {
        let watch = monitor.map(|m| format!(" (tmcl monitor --socket {})", m.display())).unwrap_or_default();
        println!("sharing {} on {}{watch}", share.device(), places.join(" and "));
    }
    let _ = std::io::stdout().flush();
    share.run()?;
    Ok(())
}

/// Options of `tmcl monitor`.
#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// A link of `tmcl share` or `tmcl serve` (its first --pty LINK): the monitor reads LINK.monitor.
    #[arg(value_name = "LINK", required_unless_present = "socket")]
    pub link: Option<PathBuf>,
    /// The monitor socket itself (`--monitor-socket` of the server).
    #[arg(long, value_name = "PATH", conflicts_with = "link")]
    pub socket: Option<PathBuf>,
    /// Stop after N transactions (default: until the server stops or SIGINT).
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
}

/// Prints every transaction the server reports, as it happens: one line each (with --json, the server's
/// JSON object).
pub(crate) fn monitor(args: MonitorArgs, json: bool) -> Result<(), CliError> {
    let socket = match (&args.socket, &args.link) {
        (Some(s), _) => s.clone(),
        (None, Some(link)) => socket_beside(link),
        (None, None) => return Err(CliError::Usage("give a LINK or --socket PATH".into())),
    };
    let stream = std::os::unix::net::UnixStream::connect(&socket)
        .map_err(|source| CliError::MonitorSocket { path: socket.clone(), source })?;
    let mut out = std::io::stdout().lock();
    let count = args.count.map_or(usize::MAX, |c| usize::try_from(c).unwrap_or(usize::MAX));
    for line in std::io::BufReader::new(stream).lines().take(count) {
        let line = line.map_err(CliError::MonitorLost)?;
        if json {
            writeln!(out, "{line}")?;
        } else {
            match serde_json::from_str::<Transaction>(&line) {
                Ok(t) => writeln!(out, "{}", t.line())?,
                Err(_) => writeln!(out, "{line}")?,
            }
        }
        out.flush()?;
    }
    Ok(())
}

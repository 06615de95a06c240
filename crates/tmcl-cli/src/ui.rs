//! `tmcl ui`: the browser workbench ([`tmcl_ui`]) on the module the connection options name.

use crate::connection::Connection;
use crate::error::CliError;
use crate::names::ModelOption;
use clap::Args;
use std::io::Write;
use std::net::SocketAddr;
use tmcl_host::models::model_by_id;

/// Options of `tmcl ui`.
#[derive(Debug, Args)]
pub struct UiArgs {
    #[command(flatten)]
    pub conn: Connection,
    #[command(flatten)]
    pub model: ModelOption,
    /// Where the workbench listens: an IP address and a port (port 0 picks a free one). Loopback by
    /// default, so no other machine reaches the module; 0.0.0.0:PORT lets others in (see
    /// docs/workbench.md, "Security").
    #[arg(long, value_name = "IP:PORT", default_value = tmcl_ui::DEFAULT_LISTEN)]
    pub listen: SocketAddr,
    /// The most requests per second the workbench sends [default: what --baud carries on a serial port,
    /// --baud / 180 (53 at 9600); 200 on a pty or TCP].
    #[arg(long, value_name = "N", value_parser = parse_rate)]
    pub rate: Option<f64>,
}

fn parse_rate(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(r) if r.is_finite() && (0.1..=100_000.0).contains(&r) => Ok(r),
        _ => Err(format!("`{text}` is not a rate from 0.1 to 100000 requests per second")),
    }
}

/// Whether `path` is a pseudo-terminal (such as the link of `tmcl serve --pty`), which has no baud rate.
fn is_pty(path: &str) -> bool {
    std::fs::canonicalize(path).is_ok_and(|p| p.starts_with("/dev/pts") || p.starts_with("/dev/ptmx"))
}

/// Runs the workbench until SIGINT or SIGTERM.
pub(crate) fn run(args: UiArgs, json: bool) -> Result<(), CliError> {
    let model = args.model.module.as_deref().map(model_by_id).transpose()?;
    let client = args.conn.open()?;
    let (link_name, line_rate) = match (&args.conn.port, &args.conn.tcp) {
        (Some(path), _) if is_pty(path) => (format!("{path} (pty)"), tmcl_ui::UNTIMED_RATE),
        (Some(path), _) => (format!("{path} at {} baud", args.conn.baud), tmcl_ui::line_rate(args.conn.baud)),
        (None, Some(addr)) => (format!("TCP {addr}"), tmcl_ui::UNTIMED_RATE),
        (None, None) => unreachable!("Connection::open fails without a link"),
    };
    // The same way of opening, for when the link goes away and comes back (a restarted `tmcl serve`).
    let conn = args.conn.clone();
    let reopen = tmcl_ui::Reopen(std::sync::Arc::new(move || conn.connect()));
    let options = tmcl_ui::Options {
        listen: args.listen,
        rate: args.rate.unwrap_or(line_rate),
        model,
        link_name,
        reopen: Some(reopen),
    };
    let address = args.conn.address;
    tmcl_ui::run(client, options, |addr| {
        let url = format!("http://{addr}/");
        let mut out = std::io::stdout().lock();
        // The first line is the address, for scripts; then how to stop.
        if json {
            let _ = crate::output::json_line(&mut out, &crate::output::Workbench { address, url: url.clone() });
        } else {
            let _ = writeln!(out, "{url}");
        }
        let _ = out.flush();
        eprintln!("tmcl ui: the workbench of module {address} is at {url} (Ctrl-C stops it)");
    })
    .map_err(CliError::from)
}

//! The logs of the servers (`tmcl serve`, `tmcl share`, the workbench of `tmcl ui`): the libraries emit
//! `tracing` events, and this is the one subscriber, set up once in `main` for every command.
//!
//! Logs go to stderr only: stdout carries what scripts and tests parse (the ready line, `--json`
//! objects). How much: warnings and errors by default; `-v` adds what the servers do (links opened and
//! closed, pages connected, and `tmcl serve`'s every request and reply); `-vv` adds the details
//! (each workbench request, reopened links); `-vvv` everything. `RUST_LOG` overrides it with the
//! `tracing` filter syntax (`RUST_LOG=tmcl_ui=debug`).

use std::io::IsTerminal;
use tracing_subscriber::EnvFilter;

/// The crates whose events `-v` turns on (other crates, such as the HTTP server's, stay at warnings).
const OURS: &[&str] = &["tmcl", "tmcl_serve", "tmcl_ui", "tmcl_host", "tmcl_debug", "tmcl_sim", "tmcl_run"];

/// The filter for `-v` given `verbosity` times, when `RUST_LOG` does not say.
fn default_filter(verbosity: u8) -> String {
    let level = match verbosity {
        0 => "warn",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let mut filter = String::from("warn");
    for target in OURS {
        filter.push_str(&format!(",{target}={level}"));
    }
    filter
}

/// Sets up the subscriber: `RUST_LOG` if it is set (and valid), else `verbosity` (`-v` counted).
pub(crate) fn init(verbosity: u8) {
    let filter = std::env::var("RUST_LOG")
        .ok()
        .and_then(|text| EnvFilter::try_new(text).ok())
        .unwrap_or_else(|| EnvFilter::new(default_filter(verbosity)));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .try_init();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verbosity_raises_our_crates_only() {
        assert!(default_filter(0).starts_with("warn,tmcl=warn,tmcl_serve=warn"));
        assert!(default_filter(1).contains("tmcl_ui=info"));
        assert!(default_filter(2).contains("tmcl_serve=debug"));
        assert!(default_filter(9).contains("tmcl=trace"));
        for v in 0..4 {
            assert!(EnvFilter::try_new(default_filter(v)).is_ok());
        }
    }
}

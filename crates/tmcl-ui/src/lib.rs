//! The browser workbench of OpenTMCL (`tmcl ui`): a local web server that talks TMCL to one module and
//! serves a page with its parameters, motion, live plots, I/O, a direct-mode console, and a program
//! editor with a debugger.
//!
//! The layers:
//!
//! - `link`: the one thread that owns the blocking host client. It runs the page's requests
//!   first and polls the values the open pages show in between, never faster than the line allows
//!   (`schedule`).
//! - `ops`: the page's requests (JSON) and what the link thread does for each;
//!   `debug` the program debugger (breakpoints by single steps, since TMCL has no
//!   breakpoint command).
//! - `server`: the HTTP and WebSocket server (axum on a single-threaded tokio runtime),
//!   the page's files compiled into the binary, and the `guard` that refuses requests
//!   whose `Host` or `Origin` is not the server's own.
//!
//! The page itself (`assets/`) is plain HTML, CSS and JavaScript with its own canvas plots; it loads
//! nothing from anywhere but this server.

#![forbid(unsafe_code)]

mod debug;
mod guard;
mod info;
mod link;
mod ops;
mod schedule;
mod server;
#[cfg(test)]
mod tests;

pub use link::{HostClient, Reopen};

use std::future::Future;
use std::net::SocketAddr;
use std::sync::atomic::AtomicU64;
use std::sync::Arc;
use tmcl_model::ModelSpec;

/// The default address: loopback only, so that no other machine can reach the module.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:8080";

/// The request rate on links without a baud rate of their own (a pty, TCP): requests per second.
pub const UNTIMED_RATE: f64 = 200.0;

/// The most requests per second a serial line at `baud` carries (a 9-byte request and its 9-byte reply of
/// 10-bit characters): 53 at 9600 baud.
pub fn line_rate(baud: u32) -> f64 {
    schedule::line_rate(baud)
}

/// How to run the workbench.
#[derive(Debug, Clone)]
pub struct Options {
    /// Where to listen.
    pub listen: SocketAddr,
    /// The most requests per second on the line.
    pub rate: f64,
    /// The model, when the command line named it; otherwise found by the module's version string.
    pub model: Option<&'static ModelSpec>,
    /// The link in words, for the page (`/dev/ttyUSB0 at 9600 baud`).
    pub link_name: String,
    /// How to open the link again when it goes away (`None`: the workbench waits for a restart).
    pub reopen: Option<Reopen>,
}

/// Why the workbench could not run.
#[derive(Debug, thiserror::Error)]
pub enum UiError {
    /// The address cannot be listened on (in use, not this machine's).
    #[error("cannot listen on {addr}: {source}")]
    Listen {
        /// The address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// The runtime or the server failed.
    #[error("the web server failed: {0}")]
    Server(std::io::Error),
}

/// Runs the workbench on `client` until SIGINT or SIGTERM. `ready` is called with the address the
/// server listens on once it does (the port may have been 0).
pub fn run(client: HostClient, options: Options, ready: impl FnOnce(SocketAddr)) -> Result<(), UiError> {
    run_until(client, options, ready, async {
        use tokio::signal::unix::{signal, SignalKind};
        match (signal(SignalKind::interrupt()), signal(SignalKind::terminate())) {
            (Ok(mut int), Ok(mut term)) => {
                tokio::select! {
                    _ = int.recv() => {},
                    _ = term.recv() => {},
                }
            }
            _ => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    })
}

/// Runs the workbench on `client` until `stop` completes (tests; [`run`] stops on a signal).
pub fn run_until(
    client: HostClient,
    options: Options,
    ready: impl FnOnce(SocketAddr),
    stop: impl Future<Output = ()> + Send + 'static,
) -> Result<(), UiError> {
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().map_err(UiError::Server)?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(options.listen)
            .await
            .map_err(|source| UiError::Listen { addr: options.listen, source })?;
        let addr = listener.local_addr().map_err(UiError::Server)?;
        let (events, _) = tokio::sync::broadcast::channel(4096);
        let (jobs, queue) = std::sync::mpsc::channel::<link::Job>();
        let (stop_pages, shutdown) = tokio::sync::watch::channel(false);
        let state = Arc::new(server::AppState {
            guard: guard::Guard::new(addr),
            jobs: jobs.clone(),
            events: events.clone(),
            shutdown,
            next_page: AtomicU64::new(1),
        });
        let link =
            link::Link::new(client, options.rate, options.model, options.link_name, events).with_reopen(options.reopen);
        let worker = std::thread::Builder::new()
            .name("tmcl-ui-link".into())
            .spawn(move || link::run(link, queue))
            .map_err(UiError::Server)?;
        tracing::info!(%addr, "the workbench is listening");
        ready(addr);
        let app = server::router(state);
        // Small WebSocket messages must go out at once: with Nagle's algorithm an answer waits for the
        // browser's delayed acknowledgement of the last event (tens of milliseconds).
        use axum::serve::ListenerExt;
        let listener = listener.tap_io(|tcp| {
            let _ = tcp.set_nodelay(true);
        });
        let served = axum::serve(listener, app).with_graceful_shutdown(async move {
            stop.await;
            let _ = stop_pages.send(true);
        });
        let result = served.await.map_err(UiError::Server);
        tracing::info!("the workbench stopped");
        // Stop the link thread after its current request.
        let _ = jobs.send(Box::new(|link| link.stop()));
        drop(jobs);
        let _ = worker.join();
        result
    })
}

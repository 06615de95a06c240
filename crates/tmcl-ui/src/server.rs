//! The web server: the page's files (compiled into the binary), and one WebSocket per open page.
//!
//! Every request passes the [`Guard`] first (the `Host` and `Origin` checks); the page's files are served
//! with a content security policy that lets them load nothing from elsewhere and forbids framing.
//!
//! On the WebSocket the page sends requests (see [`crate::ops`]) and receives their answers and the
//! events of the link thread. Events that arrive together go out as one JSON array, so a fast link does
//! not mean one WebSocket message per value.

use crate::guard::Guard;
use crate::link::Job;
use crate::ops::{self, Op};
use axum::body::Body;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::State;
use axum::http::{header, HeaderValue, Request, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use tokio::sync::{broadcast, mpsc, watch};

/// The page's files.
const INDEX_HTML: &str = include_str!("../assets/index.html");
const APP_CSS: &str = include_str!("../assets/app.css");
const APP_JS: &str = include_str!("../assets/app.js");
const PLOT_JS: &str = include_str!("../assets/plot.js");
const EDITOR_JS: &str = include_str!("../assets/editor.js");
const FAVICON_SVG: &str = include_str!("../assets/favicon.svg");

/// The most events sent in one WebSocket message.
const BATCH: usize = 256;

/// What every request handler shares.
pub(crate) struct AppState {
    pub guard: Guard,
    pub jobs: Sender<Job>,
    pub events: broadcast::Sender<Arc<str>>,
    pub shutdown: watch::Receiver<bool>,
    pub next_page: AtomicU64,
}

/// The router of the workbench.
pub(crate) fn router(state: Arc<AppState>) -> Router {
    Router::new()
        .route("/", get(|| async { asset(INDEX_HTML, "text/html; charset=utf-8") }))
        .route("/app.css", get(|| async { asset(APP_CSS, "text/css; charset=utf-8") }))
        .route("/app.js", get(|| async { asset(APP_JS, "text/javascript; charset=utf-8") }))
        .route("/plot.js", get(|| async { asset(PLOT_JS, "text/javascript; charset=utf-8") }))
        .route("/editor.js", get(|| async { asset(EDITOR_JS, "text/javascript; charset=utf-8") }))
        .route("/favicon.svg", get(|| async { asset(FAVICON_SVG, "image/svg+xml") }))
        .route("/ws", get(ws))
        .fallback(|| async { (StatusCode::NOT_FOUND, "tmcl ui: no such page\n") })
        .layer(middleware::from_fn_with_state(state.clone(), guard))
        .with_state(state)
}

fn asset(body: &'static str, content_type: &'static str) -> Response {
    let mut response = body.into_response();
    let headers = response.headers_mut();
    headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    headers.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(
            "default-src 'self'; connect-src 'self'; img-src 'self' data: blob:; style-src 'self'; \
             script-src 'self'; frame-ancestors 'none'; form-action 'none'; base-uri 'none'",
        ),
    );
    headers.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    headers.insert(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff"));
    headers.insert(header::REFERRER_POLICY, HeaderValue::from_static("no-referrer"));
    response
}

/// Refuses requests whose `Host` or `Origin` is not this server's (see [`crate::guard`]).
async fn guard(State(state): State<Arc<AppState>>, request: Request<Body>, next: Next) -> Response {
    let headers = request.headers();
    let host = headers.get(header::HOST).and_then(|v| v.to_str().ok());
    let origin = headers.get(header::ORIGIN).map(|v| v.to_str().unwrap_or("(not text)"));
    match state.guard.check(host, origin) {
        Ok(()) => next.run(request).await,
        Err(why) => {
            tracing::warn!(host, origin, "refused a request: {why}");
            (StatusCode::FORBIDDEN, format!("tmcl ui: refused: {why}\n")).into_response()
        }
    }
}

async fn ws(State(state): State<Arc<AppState>>, upgrade: WebSocketUpgrade) -> Response {
    upgrade.max_message_size(ops::MAX_SOURCE + 64 * 1024).on_upgrade(move |socket| page(socket, state))
}

/// One request as it arrives: its id and the operation.
#[derive(Deserialize)]
struct Incoming {
    id: u64,
    #[serde(flatten)]
    op: Op,
}

/// The answer to the request `id`: `{"id": N, "ok": ANSWER}`.
#[derive(Serialize)]
struct Answered {
    id: u64,
    ok: ops::Answer,
}

/// A request that failed: `{"id": N, "error": TEXT, ...}` (see [`ops::FailureBody`]). For a message that
/// is no request, `id` is whatever id it carried (`null` if none); a binary message gets no `id`.
#[derive(Serialize)]
struct Failed<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    id: Option<Value>,
    #[serde(flatten)]
    failure: &'a ops::FailureBody,
}

/// The `lagged` event: the page missed `n` events (it was too slow to take them).
#[derive(Serialize)]
struct Lagged {
    e: &'static str,
    n: u64,
}

/// `value` as JSON text (these types always serialise).
fn to_text(value: &impl Serialize) -> String {
    serde_json::to_string(value).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
}

/// Serves one open page until it closes or the server stops.
async fn page(mut socket: WebSocket, state: Arc<AppState>) {
    let page = state.next_page.fetch_add(1, Ordering::Relaxed);
    let mut events = state.events.subscribe();
    let mut shutdown = state.shutdown.clone();
    let (answers, mut answered) = mpsc::unbounded_channel::<String>();
    tracing::info!(page, "page connected");
    loop {
        let outgoing = tokio::select! {
            message = socket.recv() => match message {
                Some(Ok(Message::Text(text))) => match submit(&state, page, text.as_str(), &answers) {
                    Ok(None) => continue,
                    Ok(Some(refusal)) => refusal,
                    Err(()) => break,
                },
                Some(Ok(Message::Binary(_))) => {
                    let failure = ops::FailureBody::from_error("requests are JSON text".into());
                    to_text(&Failed { id: None, failure: &failure })
                }
                Some(Ok(_)) => continue,
                Some(Err(_)) | None => break,
            },
            answer = answered.recv() => match answer {
                Some(answer) => answer,
                None => break,
            },
            event = events.recv() => match event {
                Ok(first) => {
                    let mut batch = vec![first];
                    while batch.len() < BATCH {
                        match events.try_recv() {
                            Ok(next) => batch.push(next),
                            Err(_) => break,
                        }
                    }
                    let text = format!("[{}]", batch.iter().map(|e| &**e).collect::<Vec<_>>().join(","));
                    if socket.send(Message::Text(text.into())).await.is_err() {
                        break;
                    }
                    continue;
                }
                Err(broadcast::error::RecvError::Lagged(n)) => to_text(&[Lagged { e: "lagged", n }]),
                Err(broadcast::error::RecvError::Closed) => break,
            },
            _ = shutdown.changed() => break,
        };
        if socket.send(Message::Text(outgoing.into())).await.is_err() {
            break;
        }
    }
    // The page is gone: stop polling for it.
    tracing::info!(page, "page closed");
    let _ = state.jobs.send(Box::new(move |link| link.watch(page, None)));
}

/// Hands a request to the link thread. `Ok(Some(answer))` for a message that is no request; `Err` when
/// the link thread is gone.
fn submit(
    state: &AppState,
    page: u64,
    text: &str,
    answers: &mpsc::UnboundedSender<String>,
) -> Result<Option<String>, ()> {
    let incoming: Incoming = match serde_json::from_str(text) {
        Ok(incoming) => incoming,
        Err(e) => {
            let id = serde_json::from_str::<Value>(text).ok().and_then(|v| v.get("id").cloned());
            tracing::warn!(page, "not a request: {e}");
            let failure = ops::FailureBody::from_error(format!("not a request: {e}"));
            return Ok(Some(to_text(&Failed { id: Some(id.unwrap_or(Value::Null)), failure: &failure })));
        }
    };
    let answers = answers.clone();
    let job: Job = Box::new(move |link| {
        let id = incoming.id;
        tracing::debug!(page, id, op = incoming.op.name(), "request");
        let answer = match ops::handle(link, page, incoming.op) {
            Ok(ok) => to_text(&Answered { id, ok }),
            Err(failure) => {
                tracing::debug!(page, id, "refused: {}", failure.message());
                to_text(&Failed { id: Some(Value::from(id)), failure: failure.body() })
            }
        };
        let _ = answers.send(answer);
    });
    state.jobs.send(job).map(|()| None).map_err(drop)
}

//! The workbench against a real firmware core in process: the page's requests on a [`Link`], and the
//! server over a real socket (Host/Origin refusals, WebSocket requests that are no requests).

use crate::debug;
use crate::link::{HostClient, Link};
use crate::ops::{handle, Op};
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::Arc;
use std::time::Duration;
use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::{Instant, Module};
use tmcl_debug::remote::Action;
use tmcl_host::{Client, Transport};
use tmcl_sim::SimBoard;

/// A transport into a simulated PD28-1021; each request lets 1 ms of module time pass.
/// A host client into a virtual PD28-1021 in this process.
fn client() -> HostClient {
    client_for(&SPEC)
}

/// A host client into a virtual module of `spec` in this process, in simulated time.
fn client_for(spec: &'static tmcl_core::model::ModelSpec) -> HostClient {
    let module = Module::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO);
    let transport = tmcl_serve::InProcess::new(module);
    Client::new(Box::new(transport) as Box<dyn Transport + Send>).with_timeout(Duration::from_millis(50))
}

fn link() -> (Link, tokio::sync::broadcast::Receiver<Arc<str>>) {
    let (events, rx) = tokio::sync::broadcast::channel(4096);
    let mut link = Link::new(client(), 100_000.0, None, "in process".into(), events);
    link.identify();
    (link, rx)
}

fn op(link: &mut Link, request: Value) -> Result<Value, Value> {
    let op: Op = serde_json::from_value(request).expect("a request");
    // The answers as the page reads them: JSON.
    fn json(v: &impl serde::Serialize) -> Value {
        serde_json::to_value(v).expect("answers serialise")
    }
    handle(link, 1, op).map(|a| json(&a)).map_err(|f| json(f.body()))
}

#[test]
fn hello_names_the_model_by_its_version_string() {
    let (mut link, _) = link();
    let hello = op(&mut link, json!({"op": "hello"})).unwrap();
    assert_eq!(hello["version"], "1021V142");
    assert_eq!(hello["model"]["id"], "pd28-1021");
    assert_eq!(hello["roles"]["actual_position"], 1);
    assert_eq!(hello["link_ok"], true);
}

#[test]
fn parameters_are_written_read_back_and_refusals_explained() {
    let (mut link, _) = link();
    let speed = json!({"kind": "ap", "number": 4, "index": 0});
    let ok = op(&mut link, json!({"op": "set", "param": speed, "value": 12345})).unwrap();
    assert_eq!(ok["value"], 12345);
    assert_eq!(op(&mut link, json!({"op": "get", "param": speed})).unwrap()["value"], 12345);
    let refused = op(&mut link, json!({"op": "set", "param": speed, "value": 0})).unwrap_err();
    assert_eq!(refused["status"], 4);
    assert_eq!(refused["explanation"], "MaxPositioningSpeed takes 1..2147483647");
    let too_big = op(&mut link, json!({"op": "set", "param": speed, "value": 1_i64 << 40})).unwrap_err();
    assert!(too_big["error"].as_str().unwrap().contains("does not fit in 32 bits"));
    let stored = op(&mut link, json!({"op": "store", "param": speed})).unwrap();
    assert_eq!(stored["value"], 12345);
}

#[test]
fn console_lines_are_parsed_as_the_assembler_does() {
    let (mut link, _) = link();
    let ok =
        op(&mut link, json!({"op": "console", "line": "SAP APMaxPositioningSpeed, Motor0, 40000 // comment"})).unwrap();
    assert_eq!(ok["sent"], "SAP 4, 0, 40000");
    assert_eq!(ok["bytes"], "01 05 04 00 00 00 9C 40 E6");
    assert_eq!(ok["name"], "MaxPositioningSpeed");
    let ok = op(&mut link, json!({"op": "console", "line": "GAP MaxPositioningSpeed, 0"})).unwrap();
    assert_eq!(ok["value"], 40000);
    let ok = op(&mut link, json!({"op": "console", "line": "#op 136, 0, 0, 0"})).unwrap();
    assert_eq!(ok["reply"], "version 1021V142");
    let bad = op(&mut link, json!({"op": "console", "line": "MVP ABS, 0"})).unwrap_err();
    assert!(bad["error"].as_str().unwrap().contains("MVP"), "{bad}");
    let bad = op(&mut link, json!({"op": "console", "line": "x".repeat(5000)})).unwrap_err();
    assert!(bad["error"].as_str().unwrap().contains("longer than"));
    let refused = op(&mut link, json!({"op": "console", "line": "SAP 4, 0, 0"})).unwrap_err();
    assert_eq!(refused["explanation"], "MaxPositioningSpeed takes 1..2147483647");
}

const PROGRAM: &str = "    SGP 0, 2, 0\nLoop:\n    GGP 0, 2\n    CALC ADD, 1\n    AGP 0, 2\n    JA Loop\n";

/// Runs the link's single steps until the debugger stops (as the link thread does between polls).
fn run_to_stop(link: &mut Link, events: &mut tokio::sync::broadcast::Receiver<Arc<str>>) -> Value {
    for _ in 0..1000 {
        if !link.debug.is_continuing() {
            break;
        }
        link.debug_step();
    }
    let mut last = Value::Null;
    while let Ok(e) = events.try_recv() {
        let e: Value = serde_json::from_str(&e).unwrap();
        if e["e"] == "debug" {
            last = e;
        }
    }
    last
}

#[test]
fn the_debugger_stops_at_breakpoints_by_single_steps() {
    let (mut link, mut events) = link();
    let bad = op(&mut link, json!({"op": "assemble", "source": "  JA Nowhere\n"})).unwrap();
    assert_eq!(bad["diagnostics"][0]["line"], 1);
    assert_eq!(bad["diagnostics"][0]["column"], 6);
    let ok = op(&mut link, json!({"op": "download", "source": PROGRAM})).unwrap();
    assert_eq!(ok["stored"], 5);
    assert_eq!(ok["lines"], json!([1, 3, 4, 5, 6]));
    // Line 2 is the label: the breakpoint lands on line 3.
    let set = op(&mut link, json!({"op": "breakpoints", "lines": [2, 5]})).unwrap();
    assert_eq!(set["lines"], json!([3, 5]));
    op(&mut link, json!({"op": "program", "action": "start"})).unwrap();
    let stop = run_to_stop(&mut link, &mut events);
    assert_eq!(
        (stop["reason"].as_str(), stop["line"].as_u64(), stop["pc"].as_u64()),
        (Some("breakpoint"), Some(3), Some(1))
    );
    debug::act(&mut link, Action::Continue).unwrap();
    let stop = run_to_stop(&mut link, &mut events);
    assert_eq!((stop["line"].as_u64(), stop["acc"].as_i64()), (Some(5), Some(1)));
    debug::act(&mut link, Action::Continue).unwrap();
    let stop = run_to_stop(&mut link, &mut events);
    assert_eq!((stop["line"].as_u64(), stop["acc"].as_i64()), (Some(3), Some(1)));
    let var = op(&mut link, json!({"op": "get", "param": {"kind": "gp", "number": 0, "index": 2}})).unwrap();
    assert_eq!(var["value"], 1);
    // Without breakpoints the program runs at full speed (129) and Stop stops it.
    op(&mut link, json!({"op": "breakpoints", "lines": []})).unwrap();
    let running = op(&mut link, json!({"op": "program", "action": "continue"})).unwrap();
    assert_eq!(running["mode"], 1);
    let stopped = op(&mut link, json!({"op": "program", "action": "stop"})).unwrap();
    assert_eq!(stopped["mode"], 0);
}

/// On a PDx-113 (135 answers the state alone, PDx-113 manual §5.5) the debugger reads the program
/// counter from GP 130 and shows no accumulator or X register; breakpoints work as elsewhere.
#[test]
fn the_debugger_on_a_module_whose_135_answers_the_state_alone() {
    let (events_tx, mut events) = tokio::sync::broadcast::channel(4096);
    let client = client_for(&tmcl_core::model::pd_113::SPEC);
    let mut link = Link::new(client, 100_000.0, None, "in process".into(), events_tx);
    link.identify();
    assert_eq!(link.model.map(|m| m.id), Some("pd-113"));
    let source = "    SGP 0, 2, 0\nLoop:\n    GGP 0, 2\n    CALC ADD, 1\n    AGP 0, 2\n    JA Loop\n";
    op(&mut link, json!({"op": "download", "source": source})).unwrap();
    // Line 5 (the label takes no cell): address 3.
    let set = op(&mut link, json!({"op": "breakpoints", "lines": [5]})).unwrap();
    assert_eq!(set["lines"], json!([5]));
    op(&mut link, json!({"op": "program", "action": "start"})).unwrap();
    let stop = run_to_stop(&mut link, &mut events);
    assert_eq!(
        (stop["reason"].as_str(), stop["line"].as_u64(), stop["pc"].as_u64()),
        (Some("breakpoint"), Some(5), Some(3))
    );
    assert!(stop["acc"].is_null() && stop["x"].is_null(), "{stop}");
    debug::act(&mut link, Action::Continue).unwrap();
    let stop = run_to_stop(&mut link, &mut events);
    assert_eq!((stop["line"].as_u64(), stop["pc"].as_u64()), (Some(5), Some(3)));
    let var = op(&mut link, json!({"op": "get", "param": {"kind": "gp", "number": 0, "index": 2}})).unwrap();
    assert_eq!(var["value"], 1, "one turn of the loop between the two stops");
}

#[test]
fn motion_requests_and_the_scan() {
    let (mut link, _) = link();
    let ok = op(&mut link, json!({"op": "motion", "action": "rotate_right", "value": 1000})).unwrap();
    assert_eq!(ok["status"], 100);
    let speed = op(&mut link, json!({"op": "get", "param": {"kind": "ap", "number": 2}})).unwrap();
    assert_eq!(speed["value"], 1000);
    op(&mut link, json!({"op": "motion", "action": "stop"})).unwrap();
    let found = op(&mut link, json!({"op": "scan", "first": 1, "last": 3})).unwrap();
    assert_eq!(found["modules"], json!([{"address": 1, "version": "1021V142"}]));
    assert_eq!(link.address(), 1);
    assert!(op(&mut link, json!({"op": "scan", "first": 3, "last": 1})).is_err());
    // Every address, 0 and 255 included (the in-process line does not wait out its timeouts).
    let found = op(&mut link, json!({"op": "scan", "first": 0, "last": 255})).unwrap();
    assert_eq!(found["modules"][0]["address"], 1);
    assert_eq!(link.link_error(), None, "unanswered addresses say nothing about the link");
}

// ---- the server over a socket ------------------------------------------------------------------------

/// Starts the workbench on an ephemeral port; the returned sender stops it.
fn server() -> (SocketAddr, tokio::sync::oneshot::Sender<()>, std::thread::JoinHandle<()>) {
    let (addr_tx, addr_rx) = std::sync::mpsc::channel();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let options = crate::Options {
        listen: "127.0.0.1:0".parse().unwrap(),
        rate: 1000.0,
        model: None,
        link_name: "in process".into(),
        reopen: None,
    };
    let thread = std::thread::spawn(move || {
        crate::run_until(client(), options, |a| addr_tx.send(a).unwrap(), async {
            let _ = stop_rx.await;
        })
        .unwrap();
    });
    (addr_rx.recv_timeout(Duration::from_secs(10)).unwrap(), stop_tx, thread)
}

fn http(addr: SocketAddr, request: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut head = Vec::new();
    let mut byte = [0u8; 1];
    while !head.ends_with(b"\r\n\r\n") && s.read(&mut byte).unwrap_or(0) == 1 {
        head.push(byte[0]);
    }
    String::from_utf8_lossy(&head).into_owned()
}

/// A masked WebSocket text frame (RFC 6455 §5.2), as a browser sends one.
fn ws_frame(text: &str) -> Vec<u8> {
    let mask = [0x12u8, 0x34, 0x56, 0x78];
    let payload = text.as_bytes();
    let mut frame = vec![0x81];
    match payload.len() {
        n if n < 126 => frame.push(0x80 | n as u8),
        n => {
            frame.push(0x80 | 126);
            frame.extend_from_slice(&(n as u16).to_be_bytes());
        }
    }
    frame.extend_from_slice(&mask);
    frame.extend(payload.iter().enumerate().map(|(i, b)| b ^ mask[i % 4]));
    frame
}

/// Reads server frames until a text frame with an `"id"` arrives (events, arrays, are skipped).
fn ws_answer(s: &mut TcpStream) -> Value {
    loop {
        let mut head = [0u8; 2];
        s.read_exact(&mut head).unwrap();
        let len = match head[1] & 0x7F {
            126 => {
                let mut l = [0u8; 2];
                s.read_exact(&mut l).unwrap();
                u16::from_be_bytes(l) as usize
            }
            127 => {
                let mut l = [0u8; 8];
                s.read_exact(&mut l).unwrap();
                u64::from_be_bytes(l) as usize
            }
            n => n as usize,
        };
        let mut payload = vec![0u8; len];
        s.read_exact(&mut payload).unwrap();
        let v: Value = serde_json::from_slice(&payload).unwrap_or(Value::Null);
        if v.get("id").is_some() {
            return v;
        }
    }
}

#[test]
fn the_server_refuses_foreign_hosts_and_origins_and_survives_bad_messages() {
    let (addr, stop, thread) = server();
    let own = addr.to_string();
    let page = http(addr, &format!("GET / HTTP/1.1\r\nHost: {own}\r\nConnection: close\r\n\r\n"));
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    assert!(page.to_ascii_lowercase().contains("content-security-policy: default-src 'self'"), "{page}");
    let foreign = http(addr, &format!("GET / HTTP/1.1\r\nHost: {own}\r\nOrigin: http://evil.example\r\n\r\n"));
    assert!(foreign.starts_with("HTTP/1.1 403"), "{foreign}");
    let rebound = http(addr, &format!("GET / HTTP/1.1\r\nHost: evil.example:{}\r\n\r\n", addr.port()));
    assert!(rebound.starts_with("HTTP/1.1 403"), "{rebound}");
    let upgrade = "Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\n\
                   Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n";
    let foreign_ws =
        http(addr, &format!("GET /ws HTTP/1.1\r\nHost: {own}\r\nOrigin: http://evil.example\r\n{upgrade}\r\n"));
    assert!(foreign_ws.starts_with("HTTP/1.1 403"), "{foreign_ws}");

    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(format!("GET /ws HTTP/1.1\r\nHost: {own}\r\nOrigin: http://{own}\r\n{upgrade}\r\n").as_bytes())
        .unwrap();
    let mut head = Vec::new();
    let mut byte = [0u8; 1];
    while !head.ends_with(b"\r\n\r\n") {
        s.read_exact(&mut byte).unwrap();
        head.push(byte[0]);
    }
    assert!(head.starts_with(b"HTTP/1.1 101"), "{}", String::from_utf8_lossy(&head));
    for (message, expect) in [
        ("not json", "not a request"),
        (r#"{"id": 7, "op": "launch_missiles"}"#, "unknown variant"),
        (r#"{"id": 8, "op": "set", "param": {"kind": "ap", "number": 999}, "value": 1}"#, "not a request"),
        (r#"{"id": 9, "op": "console", "line": "\u0000\u0001"}"#, ""),
    ] {
        s.write_all(&ws_frame(message)).unwrap();
        let answer = ws_answer(&mut s);
        let error = answer["error"].as_str().unwrap_or_default();
        assert!(error.contains(expect), "{message}: {answer}");
    }
    s.write_all(&ws_frame(r#"{"id": 10, "op": "hello"}"#)).unwrap();
    let hello = ws_answer(&mut s);
    assert_eq!(hello["id"], 10);
    assert_eq!(hello["ok"]["version"], "1021V142");
    stop.send(()).unwrap();
    thread.join().unwrap();
}

#[test]
fn commands_that_may_get_no_reply_show_what_came() {
    let (mut link, _) = link();
    // 137 without its key is refused by the module: a refusal, not "no reply".
    let refused = op(&mut link, json!({"op": "console", "line": "#op 137, 0, 0, 0"})).unwrap_err();
    assert_eq!(refused["status"], 4, "{refused}");
    // GP 255 switches replies off: the console says so, the line too, and SGP 255, 0, 0 turns them on.
    let off = op(&mut link, json!({"op": "console", "line": "SGP 255, 0, 1"})).unwrap();
    assert!(off["reply"].as_str().unwrap().contains("replies are now off"), "{off}");
    assert!(link.replies_off);
    assert_eq!(link.line_event().state, crate::link::LineState::RepliesOff);
    let on = op(&mut link, json!({"op": "console", "line": "SGP 255, 0, 0"})).unwrap();
    assert!(on["reply"].as_str().unwrap().contains("replies are on again"), "{on}");
    assert!(!link.replies_off);
    assert_eq!(op(&mut link, json!({"op": "console", "line": "GAP 6, 0"})).unwrap()["value"], 128);
    assert_eq!(link.line_event().state, crate::link::LineState::Answering);
}

#[test]
fn a_refusal_leaves_the_line_answering_and_mismatched_replies_warn() {
    let (mut link, _) = link();
    let speed = json!({"kind": "ap", "number": 4, "index": 0});
    op(&mut link, json!({"op": "set", "param": speed, "value": 0})).unwrap_err();
    let line = link.line_event();
    assert_eq!((line.state, line.ok), (crate::link::LineState::Answering, true));
    link.note_mismatched(3);
    let line = link.line_event();
    assert_eq!((line.state, line.mismatched, line.mismatched_recent), (crate::link::LineState::Mismatched, 3, 3));
    assert!(line.error.unwrap().contains("another host on this line?"));
}

#[test]
fn a_parameter_set_is_saved_loaded_and_stored() {
    let (mut link, _) = link();
    let speed = json!({"kind": "ap", "number": 4, "index": 0});
    op(&mut link, json!({"op": "set", "param": speed, "value": 30000})).unwrap();
    let saved = op(&mut link, json!({"op": "save_params"})).unwrap();
    let text = saved["toml"].as_str().unwrap().to_string();
    assert!(text.contains("model = \"pd28-1021\"") && saved["count"].as_u64().unwrap() > 300);
    op(&mut link, json!({"op": "set", "param": speed, "value": 1000})).unwrap();
    let loaded = op(&mut link, json!({"op": "load_params", "text": text, "store": true})).unwrap();
    assert_eq!(loaded["refused"], 0, "{loaded}");
    assert_eq!(op(&mut link, json!({"op": "get", "param": speed})).unwrap()["value"], 30000);
    let stored = op(&mut link, json!({"op": "store_all"})).unwrap();
    assert!(stored["stored"].as_u64().unwrap() > 10 && stored["refused"] == 0, "{stored}");
    let wrong = text.replace("model = \"pd28-1021\"", "model = \"pd-113\"");
    let refused = op(&mut link, json!({"op": "load_params", "text": wrong})).unwrap_err();
    assert!(refused["error"].as_str().unwrap().contains("the set is of a"), "{refused}");
}

/// The program view marks at their line what the model's tables refuse (the module would skip the
/// instruction): PD28-1021 manual §2.4's `SAP 4, 0, 51200` on a PDx-113 (0..2047), a warning that does
/// not keep the program from being downloaded.
#[test]
fn the_program_view_warns_where_the_model_would_refuse() {
    let (events, _rx) = tokio::sync::broadcast::channel(4096);
    let client = client_for(&tmcl_core::model::pd_113::SPEC);
    let mut link = Link::new(client, 100_000.0, None, "in process".into(), events);
    link.identify();
    let source = "SAP 5, 0, 100\nSAP 4, 0, 51200 // §2.4\nSTOP\n";
    let ok = op(&mut link, json!({"op": "assemble", "source": source})).unwrap();
    assert_eq!(ok["diagnostics"], json!([]));
    assert_eq!(ok["instructions"], 3);
    let w = &ok["warnings"];
    assert_eq!(w.as_array().map(Vec::len), Some(1), "{w}");
    assert_eq!((w[0]["line"].as_u64(), w[0]["column"].as_u64(), w[0]["width"].as_u64()), (Some(2), Some(11), Some(5)));
    assert!(w[0]["message"].as_str().unwrap().contains("takes 0..2047"), "{w}");
    let ok = op(&mut link, json!({"op": "download", "source": source})).unwrap();
    assert_eq!(ok["stored"], 3);
    assert_eq!(ok["warnings"][0]["line"], 2);
    // On the PD28-1021, 51200 is fine.
    let (mut pd28, _) = self::link();
    let ok = op(&mut pd28, json!({"op": "assemble", "source": source})).unwrap();
    assert_eq!(ok["warnings"], json!([]));
}

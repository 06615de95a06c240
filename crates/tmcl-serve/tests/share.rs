//! `Share`: one module behind a device (here a `Server` on a pty standing in for a real module), several
//! hosts on links of their own.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;
use tmcl_host::{Client, SerialTransport, TcpTransport, Transport};
use tmcl_serve::monitor::{Outcome, Transaction};
use tmcl_serve::{
    DeviceOptions, LinkOptions, ModuleOptions, MonitorOptions, Options, RunningServer, RunningShare, Server, Share,
    ShareOptions,
};

fn pd28() -> &'static tmcl_core::model::ModelSpec {
    tmcl_core::model::by_id("pd28-1021").unwrap()
}

fn frame(address: u8, opcode: u8, kind: u8, motor: u8, value: i32) -> [u8; 9] {
    let mut f = [0u8; 9];
    f[..4].copy_from_slice(&[address, opcode, kind, motor]);
    f[4..8].copy_from_slice(&value.to_be_bytes());
    f[8] = tmcl_wire::checksum(&f[..8]);
    f
}

/// A virtual module on `dir/module` and a share of it on `dir/a`, `dir/b` and a TCP port.
fn setup(dir: &Path, log: Option<PathBuf>) -> (RunningServer, RunningShare) {
    let module = dir.join("module");
    let server =
        Server::new(Options::new(vec![ModuleOptions::new(pd28())], vec![LinkOptions::Pty(module.clone())])).unwrap();
    let server = server.spawn().unwrap();
    let mut options = ShareOptions::new(
        DeviceOptions::Serial { path: module, baud: 9600, shared: false },
        vec![LinkOptions::Pty(dir.join("a")), LinkOptions::Pty(dir.join("b")), LinkOptions::Tcp("127.0.0.1:0".into())],
    );
    options.monitor = MonitorOptions { log, log_json: true, socket: None, stderr: false };
    let share = Share::new(options).unwrap().spawn().unwrap();
    (server, share)
}

fn open(path: &Path) -> Client<SerialTransport> {
    Client::new(SerialTransport::open(path.to_str().unwrap(), 9600).unwrap()).with_timeout(Duration::from_secs(5))
}

#[test]
fn hosts_on_their_own_links_never_get_each_others_replies() {
    let dir = tempfile::tempdir().unwrap();
    let (server, share) = setup(dir.path(), None);
    let mut a = open(&dir.path().join("a"));
    a.set_axis_parameter(4, 0, 1234).unwrap();
    a.set_axis_parameter(6, 0, 128).unwrap();
    let b_path = dir.path().join("b");
    let tcp = share.links()[2].to_string();
    let b = std::thread::spawn(move || {
        let mut b = open(&b_path);
        for _ in 0..1500 {
            assert_eq!(b.get_axis_parameter(6, 0).unwrap(), 128);
        }
        b.take_skipped()
    });
    let c = std::thread::spawn(move || {
        let mut c = Client::new(TcpTransport::connect(&tcp).unwrap());
        for _ in 0..1500 {
            assert_eq!(c.get_global_parameter(66, 0).unwrap(), 1);
        }
        c.take_skipped()
    });
    for _ in 0..1500 {
        assert_eq!(a.get_axis_parameter(4, 0).unwrap(), 1234);
    }
    assert!(b.join().unwrap().is_empty(), "no foreign reply on b");
    assert!(c.join().unwrap().is_empty(), "no foreign reply on the TCP link");
    assert!(a.take_skipped().is_empty(), "no foreign reply on a");
    drop(a);
    share.stop().unwrap();
    assert!(std::fs::symlink_metadata(dir.path().join("a")).is_err(), "the share's links are removed");
    assert!(!dir.path().join("a.monitor").exists(), "and its monitor socket");
    server.stop().unwrap();
}

#[test]
fn a_backlog_of_frames_is_answered_in_order_and_the_other_host_gets_its_turn() {
    let dir = tempfile::tempdir().unwrap();
    let (server, share) = setup(dir.path(), None);
    let mut a = std::fs::OpenOptions::new().read(true).write(true).open(dir.path().join("a")).unwrap();
    let mut backlog = Vec::new();
    for k in 0..1000 {
        backlog.extend_from_slice(&frame(1, 5, 4, 0, k + 1)); // SAP 4, k + 1: each reply carries its value
    }
    a.write_all(&backlog).unwrap();
    // Meanwhile the other host is answered too (the links take turns).
    let mut b = open(&dir.path().join("b"));
    assert_eq!(b.get_global_parameter(66, 0).unwrap(), 1);
    let mut replies = vec![0u8; 9000];
    a.read_exact(&mut replies).unwrap();
    for (k, reply) in replies.chunks(9).enumerate() {
        assert_eq!((reply[2], reply[3]), (100, 5), "reply {k}");
        assert_eq!(i32::from_be_bytes(reply[4..8].try_into().unwrap()), k as i32 + 1, "reply {k} in order");
    }
    drop((a, b));
    share.stop().unwrap();
    server.stop().unwrap();
}

#[test]
fn the_second_reply_of_138_goes_to_the_host_that_asked() {
    let dir = tempfile::tempdir().unwrap();
    let (server, share) = setup(dir.path(), None);
    let mut a = open(&dir.path().join("a"));
    let mut b = open(&dir.path().join("b"));
    a.set_axis_parameter(4, 0, 2047).unwrap();
    let asked = a.request(tmcl_wire::Instruction::new(tmcl_wire::Opcode::RequestTargetReachedEvent, 0, 0, 1)).unwrap();
    assert_eq!(asked.status, tmcl_wire::Status::Ok);
    a.move_to(0, 3000).unwrap();
    // b keeps polling while the motor moves: the event must not reach b.
    for _ in 0..50 {
        assert_eq!(b.get_global_parameter(66, 0).unwrap(), 1);
    }
    let event = a.wait_event(Duration::from_secs(10)).unwrap();
    assert_eq!((event.opcode, event.status), (138, tmcl_wire::Status::TargetReached));
    assert!(b.take_skipped().is_empty(), "b saw no event");
    drop((a, b));
    share.stop().unwrap();
    server.stop().unwrap();
}

#[test]
fn commands_without_reply_and_replies_off_keep_the_line_in_step() {
    let dir = tempfile::tempdir().unwrap();
    let (server, share) = setup(dir.path(), None);
    let mut a = open(&dir.path().join("a")).with_timeout(Duration::from_millis(500));
    let mut b = open(&dir.path().join("b"));
    // 137 without the key: refused, and the refusal reaches the asker.
    let refused = a.request_optional(tmcl_wire::Instruction::new(tmcl_wire::Opcode::FactoryDefault, 0, 0, 0));
    assert!(matches!(refused, Err(tmcl_host::HostError::Status { .. })), "{refused:?}");
    // Replies off: SGP 255 gets none, GAP still does; the other host's requests go on.
    assert_eq!(a.request_optional(tmcl_wire::Instruction::new(tmcl_wire::Opcode::Sgp, 255, 0, 1)).unwrap(), None);
    // While replies are off the share waits its no-reply window (100 ms) for SAP, not its reply timeout
    // (1 s): the request right behind it is answered long before that.
    let started = std::time::Instant::now();
    a.request_no_reply(tmcl_wire::Instruction::new(tmcl_wire::Opcode::Sap, 4, 0, 99)).unwrap();
    assert_eq!(a.get_axis_parameter(4, 0).unwrap(), 99, "GAP is answered with replies off");
    assert!(started.elapsed() < Duration::from_millis(800), "{:?}", started.elapsed());
    assert_eq!(b.get_axis_parameter(4, 0).unwrap(), 99);
    a.set_global_parameter(255, 0, 0).unwrap();
    assert_eq!(a.get_axis_parameter(4, 0).unwrap(), 99);
    // 137 with its key is carried out without a reply (§3.7.38): the share waits its no-reply window, and
    // the next request, from the other host, finds the factory defaults.
    let factory = tmcl_wire::Instruction::new(tmcl_wire::Opcode::FactoryDefault, 0, 0, 1234);
    assert_eq!(a.request_optional(factory).unwrap(), None);
    assert_eq!(b.get_axis_parameter(4, 0).unwrap(), 51200);
    assert!(a.take_skipped().is_empty() && b.take_skipped().is_empty());
    drop((a, b));
    share.stop().unwrap();
    server.stop().unwrap();
}

#[test]
fn a_host_in_ascii_mode_is_translated_and_the_module_stays_binary() {
    let dir = tempfile::tempdir().unwrap();
    let (server, share) = setup(dir.path(), None);
    let mut a = std::fs::OpenOptions::new().read(true).write(true).open(dir.path().join("a")).unwrap();
    let mut b = open(&dir.path().join("b"));
    a.write_all(&frame(1, 139, 0, 0, 0)).unwrap();
    let mut reply = [0u8; 9];
    a.read_exact(&mut reply).unwrap();
    assert_eq!((reply[0], reply[1], reply[2], reply[3]), (2, 1, 100, 139), "139 answered in binary");
    a.write_all(b"ASAP 4, 0, 777\r").unwrap();
    assert_eq!(read_line(&mut a), "BA 100 777");
    // The other host still speaks binary to the same module.
    assert_eq!(b.get_axis_parameter(4, 0).unwrap(), 777);
    a.write_all(b"AGAP 4, 0\r").unwrap();
    assert_eq!(read_line(&mut a), "BA 100 777");
    a.write_all(b"AXYZ\r").unwrap();
    assert_eq!(read_line(&mut a), "BA 2 0", "a line that does not parse");
    a.write_all(b"ABIN\r").unwrap();
    assert_eq!(read_line(&mut a), "BA 100 0");
    a.write_all(&frame(1, 6, 4, 0, 0)).unwrap();
    a.read_exact(&mut reply).unwrap();
    assert_eq!(i32::from_be_bytes(reply[4..8].try_into().unwrap()), 777, "binary again");
    drop((a, b));
    share.stop().unwrap();
    server.stop().unwrap();
}

fn read_line(port: &mut std::fs::File) -> String {
    let mut line = Vec::new();
    let mut byte = [0u8; 1];
    while port.read(&mut byte).unwrap() == 1 && byte[0] != b'\r' {
        line.push(byte[0]);
    }
    String::from_utf8(line).unwrap()
}

#[test]
fn every_transaction_is_logged_and_monitored_with_its_host() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("share.log");
    let (server, share) = setup(dir.path(), Some(log.clone()));
    let monitor = std::os::unix::net::UnixStream::connect(dir.path().join("a.monitor")).unwrap();
    std::thread::sleep(Duration::from_millis(100)); // the share takes the client in its next turn
    let mut a = open(&dir.path().join("a"));
    let mut b = open(&dir.path().join("b"));
    a.set_axis_parameter(4, 0, 1000).unwrap();
    assert_eq!(b.get_axis_parameter(4, 0).unwrap(), 1000);
    assert!(a.set_axis_parameter(4, 0, -5).is_err());
    drop((a, b));
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(monitor));
    let mut seen: Vec<Transaction> = Vec::new();
    for _ in 0..3 {
        seen.push(serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap());
    }
    share.stop().unwrap();
    let logged: Vec<Transaction> =
        std::fs::read_to_string(&log).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(logged, seen, "the log and the monitor say the same");
    let a = dir.path().join("a").display().to_string();
    let b = dir.path().join("b").display().to_string();
    assert_eq!(seen.iter().map(|t| t.host.as_str()).collect::<Vec<_>>(), [&a, &b, &a]);
    assert!(seen.iter().all(|t| t.outcome == Outcome::Answered && t.round_trip_us.is_some()));
    assert_eq!(seen[1].status, Some(100));
    assert!(seen[1].reply.as_ref().unwrap().text.contains("1000"), "{:?}", seen[1]);
    assert_eq!(seen[2].status, Some(4));
    assert!(seen[2].note.as_ref().is_some_and(|n| n.contains("refused")), "{:?}", seen[2]);
    server.stop().unwrap();
}

#[test]
fn a_device_another_process_holds_or_a_dead_link_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // A link whose server has exited (what kill -9 leaves): refused, nothing written.
    let stale = dir.path().join("stale");
    std::os::unix::fs::symlink("/dev/null", &stale).unwrap();
    std::fs::write(dir.path().join("stale.lock"), "999999999\n").unwrap();
    let options = ShareOptions::new(
        DeviceOptions::Serial { path: stale, baud: 9600, shared: false },
        vec![LinkOptions::Pty(dir.path().join("a"))],
    );
    let err = Share::new(options).err().expect("refused");
    assert!(err.to_string().contains("999999999"), "{err}");
    assert!(std::fs::symlink_metadata(dir.path().join("a")).is_err(), "no link made");
}

#[test]
fn tmcl_serve_logs_every_transaction_of_every_link() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("serve.log");
    let mut options = Options::new(
        vec![ModuleOptions::new(pd28())],
        vec![LinkOptions::Pty(dir.path().join("a")), LinkOptions::Tcp("127.0.0.1:0".into())],
    );
    options.monitor = MonitorOptions { log: Some(log.clone()), log_json: true, socket: None, stderr: false };
    let server = Server::new(options).unwrap().spawn().unwrap();
    let tcp = server.links()[1].to_string();
    let mut a = open(&dir.path().join("a"));
    let mut b = Client::new(TcpTransport::connect(&tcp).unwrap());
    a.set_axis_parameter(4, 0, 1000).unwrap();
    assert_eq!(b.get_axis_parameter(4, 0).unwrap(), 1000);
    // A burst of three frames in one write, and a command that gets no reply while GP 255 is set.
    a.transport_mut().send(&[frame(1, 6, 4, 0, 0), frame(1, 6, 6, 0, 0), frame(1, 10, 66, 0, 0)].concat()).unwrap();
    let mut replies = [0u8; 27];
    a.transport_mut().recv_exact(&mut replies, Duration::from_secs(5)).unwrap();
    a.request_no_reply(tmcl_wire::Instruction::new(tmcl_wire::Opcode::Sgp, 255, 0, 1)).unwrap();
    std::thread::sleep(Duration::from_millis(1300)); // the monitor says "no reply" after 1 s
    a.set_global_parameter(255, 0, 0).ok();
    drop((a, b));
    server.stop().unwrap();
    let logged: Vec<Transaction> =
        std::fs::read_to_string(&log).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let a = dir.path().join("a").display().to_string();
    let outcomes: Vec<(&str, Outcome, Option<u8>)> = logged
        .iter()
        .map(|t| {
            (t.host.as_str(), t.outcome, t.request.as_ref().map(|r| u8::from_str_radix(&r.raw[3..5], 16).unwrap()))
        })
        .collect();
    assert_eq!(
        outcomes[..6],
        [
            (a.as_str(), Outcome::Answered, Some(5)),
            (tcp.as_str(), Outcome::Answered, Some(6)),
            (a.as_str(), Outcome::Answered, Some(6)),
            (a.as_str(), Outcome::Answered, Some(6)),
            (a.as_str(), Outcome::Answered, Some(10)),
            (a.as_str(), Outcome::NoReply, Some(9)),
        ]
    );
    assert!(logged[1].reply.as_ref().unwrap().text.ends_with("1000 pps"), "{:?}", logged[1]);
}

#[test]
fn a_reply_to_a_tcp_client_that_left_never_reaches_the_next_client() {
    let dir = tempfile::tempdir().unwrap();
    let (server, share) = setup(dir.path(), None);
    let tcp = share.links()[2].to_string();
    let mut a = open(&dir.path().join("a"));
    a.set_axis_parameter(4, 0, 1111).unwrap();
    a.set_axis_parameter(6, 0, 99).unwrap();
    a.set_global_parameter(75, 0, 200).unwrap(); // every reply waits 200 ms (telegram pause, §5.1)
    {
        // The first client asks for AP 4 and leaves before its reply comes.
        let mut first = std::net::TcpStream::connect(&tcp).unwrap();
        first.write_all(&frame(1, 6, 4, 0, 0)).unwrap();
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(Duration::from_millis(50));
    let mut second = Client::new(TcpTransport::connect(&tcp).unwrap()).with_timeout(Duration::from_secs(5));
    assert_eq!(second.get_axis_parameter(6, 0).unwrap(), 99, "its own reply, not the first client's");
    assert!(second.take_skipped().is_empty(), "the first client's reply never reached it");
    a.set_global_parameter(75, 0, 0).unwrap();
    drop((a, second));
    share.stop().unwrap();
    server.stop().unwrap();
}

//! The real transports against tiny scripted modules: a pty behind a symlink, as `tmcl serve --pty LINK`
//! makes, and a TCP listener.

use std::fs::File;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::thread;
use std::time::Duration;
use tmcl_host::{Client, HostError, SerialTransport, TcpTransport};
use tmcl_wire::{Frame, Reply, Request, Status, FRAME_LEN};

/// Answers every GAP/GGP with `value = type byte * -100`, everything else with its own value, and 136 type 0
/// with the raw version string.
fn answer(request: &[u8; FRAME_LEN]) -> [u8; FRAME_LEN] {
    let request = Request::parse(&Frame::new_unchecked(&request[..])).expect("the host sends valid frames");
    let i = request.instruction;
    let opcode = u8::from(i.opcode);
    if opcode == 136 && i.kind == 0 {
        let mut raw = [2u8; FRAME_LEN];
        raw[1..].copy_from_slice(b"1021V142");
        return raw;
    }
    let value = if opcode == 6 || opcode == 10 { -100 * i32::from(i.kind) } else { i.value };
    Reply { host: 2, module: request.address, status: Status::Ok, opcode, value }.to_bytes()
}

fn serve(mut io: impl Read + Write, requests: usize) {
    let mut frame = [0u8; FRAME_LEN];
    for _ in 0..requests {
        io.read_exact(&mut frame).unwrap();
        io.write_all(&answer(&frame)).unwrap();
    }
}

#[test]
fn serial_transport_on_a_pty_symlink() {
    let pty = nix::pty::openpty(None, None).unwrap();
    let slave_path = nix::unistd::ttyname(&pty.slave).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("tmcl-link");
    std::os::unix::fs::symlink(&slave_path, &link).unwrap();

    let master = File::from(pty.master);
    let module = thread::spawn(move || {
        serve(&master, 3);
        master
    });

    // Any baud rate: a pty ignores it, and the open must not fail on it.
    let transport = SerialTransport::open(link.to_str().unwrap(), 115_200).unwrap();
    let mut client = Client::new(transport).with_timeout(Duration::from_secs(5));
    assert_eq!(client.get_axis_parameter(7, 0).unwrap(), -700);
    client.set_axis_parameter(4, 0, -5000).unwrap();
    assert_eq!(client.version_string().unwrap(), "1021V142");
    let master = module.join().unwrap();

    // Nobody answers now: a timeout, not a hang.
    let mut client = client.with_timeout(Duration::from_millis(200));
    assert!(matches!(client.get_axis_parameter(1, 0), Err(HostError::Timeout { received: 0, .. })));

    // The module side has gone: an I/O error at once.
    drop(master);
    drop(pty.slave);
    client.timeout = Duration::from_secs(5);
    let started = std::time::Instant::now();
    assert!(matches!(client.get_axis_parameter(1, 0), Err(HostError::Io(_))));
    assert!(started.elapsed() < Duration::from_secs(2));
}

/// A pty pair: the master as a file (the module's side) and the slave's path (the host's).
fn pty() -> (File, std::path::PathBuf, std::os::fd::OwnedFd) {
    let pty = nix::pty::openpty(None, None).unwrap();
    let slave_path = nix::unistd::ttyname(&pty.slave).unwrap();
    (File::from(pty.master), slave_path, pty.slave)
}

/// A wait for a reply ends when asked, not sooner and not much later: one measured in the terminal's tenths
/// of a second (`VTIME`), one shorter than a tenth, one longer than the longest `VTIME`'s first tenths.
/// Stale input is cleared. A reply that arrives in two pieces is put together, and the next request reads
/// as the first did.
#[test]
fn serial_timeouts_end_when_asked_and_replies_in_pieces_arrive_whole() {
    use tmcl_host::Transport;
    let (master, path, _slave) = pty();
    let mut transport = SerialTransport::open(path.to_str().unwrap(), 9600).unwrap();
    let mut buf = [0u8; FRAME_LEN];
    for ms in [40, 250, 1_230] {
        let timeout = Duration::from_millis(ms);
        let started = std::time::Instant::now();
        let err = transport.recv_exact(&mut buf, timeout).unwrap_err();
        let waited = started.elapsed();
        assert!(matches!(err, HostError::Timeout { received: 0, .. }), "{err:?}");
        // Loose bounds: the machine may be busy.
        assert!(waited >= timeout && waited < timeout + Duration::from_secs(2), "{ms} ms: waited {waited:?}");
    }

    // Input from before is dropped: the next wait gets nothing.
    (&master).write_all(b"stale").unwrap();
    thread::sleep(Duration::from_millis(20));
    transport.clear_input();
    let err = transport.recv_exact(&mut buf, Duration::from_millis(150)).unwrap_err();
    assert!(matches!(err, HostError::Timeout { received: 0, .. }), "{err:?}");

    let module = thread::spawn(move || {
        let mut frame = [0u8; FRAME_LEN];
        for _ in 0..2 {
            (&master).read_exact(&mut frame).unwrap();
            let reply = answer(&frame);
            (&master).write_all(&reply[..4]).unwrap();
            thread::sleep(Duration::from_millis(150));
            (&master).write_all(&reply[4..]).unwrap();
        }
        master
    });
    let mut client = Client::new(transport).with_timeout(Duration::from_secs(5));
    assert_eq!(client.get_axis_parameter(3, 0).unwrap(), -300);
    assert_eq!(client.get_axis_parameter(2, 0).unwrap(), -200);
    drop(module.join().unwrap());
}

/// The module side closing the pty is reported at once as a hang-up, in words: while the host waits for a
/// reply (not after its 10 s timeout), and when it sends the next request.
#[test]
fn serial_hang_up_is_reported_at_once() {
    use tmcl_host::Transport;
    let (master, path, slave) = pty();
    let mut transport = SerialTransport::open(path.to_str().unwrap(), 9600).unwrap();
    drop(slave);
    let module = thread::spawn(move || {
        thread::sleep(Duration::from_millis(300));
        drop(master);
    });
    let mut buf = [0u8; FRAME_LEN];
    let started = std::time::Instant::now();
    let err = transport.recv_exact(&mut buf, Duration::from_secs(10)).unwrap_err();
    assert!(started.elapsed() < Duration::from_secs(3), "waited {:?}", started.elapsed());
    assert!(matches!(err, HostError::Io(_)), "{err:?}");
    assert!(err.to_string().contains("hung up"), "{err}");
    module.join().unwrap();

    let started = std::time::Instant::now();
    let err = transport.recv_exact(&mut buf, Duration::from_secs(10)).unwrap_err();
    assert!(err.to_string().contains("hung up") && started.elapsed() < Duration::from_secs(3), "{err}");
    let err = transport.send(&[1; FRAME_LEN]).unwrap_err();
    assert!(err.to_string().contains("hung up"), "{err}");
}

/// A module that reads nothing: once the pty is full, a request fails after the write timeout (2 s)
/// instead of blocking the host for good.
#[test]
fn serial_write_times_out_when_the_module_reads_nothing() {
    use tmcl_host::Transport;
    let (_master, path, _slave) = pty();
    let mut transport = SerialTransport::open(path.to_str().unwrap(), 9600).unwrap();
    let mut sent = 0usize;
    // (Only the request that fails is timed: filling the pty first takes as long as the machine's load
    // makes it.)
    let (err, waited) = loop {
        let started = std::time::Instant::now();
        match transport.send(&[1; FRAME_LEN]) {
            Ok(()) => sent += FRAME_LEN,
            Err(e) => break (e, started.elapsed()),
        }
        assert!(sent < 1 << 24, "the pty never filled");
    };
    assert_eq!(err.kind(), std::io::ErrorKind::TimedOut, "{err}");
    assert!(waited >= Duration::from_secs(2) && waited < Duration::from_secs(10), "after {sent} bytes, {waited:?}");
}

#[test]
fn serial_transport_open_error_names_the_path() {
    let err = SerialTransport::open("/nonexistent/tmcl-port", 9600).unwrap_err();
    assert!(matches!(err, HostError::Open { .. }));
    assert!(err.to_string().starts_with("cannot open /nonexistent/tmcl-port: "), "{err}");
}

#[test]
fn tcp_transport_round_trip_and_timeout() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let module = thread::spawn(move || {
        let (stream, _) = listener.accept().unwrap();
        serve(&stream, 2);
        // Keep the connection open without answering, so the next request times out.
        let mut frame = [0u8; FRAME_LEN];
        (&stream).read_exact(&mut frame).unwrap();
        thread::sleep(Duration::from_millis(500));
    });
    let mut client = Client::new(TcpTransport::connect(&addr).unwrap()).with_module_address(3);
    assert_eq!(client.get_global_parameter(66, 0).unwrap(), -6600);
    assert_eq!(client.request(tmcl_wire::Command::Mst { motor: 0 }.encode()).unwrap().module, 3);
    client.timeout = Duration::from_millis(200);
    assert!(matches!(client.get_axis_parameter(1, 0), Err(HostError::Timeout { received: 0, .. })));
    module.join().unwrap();
    // The peer has gone: an I/O error, not a timeout.
    client.timeout = Duration::from_secs(2);
    assert!(matches!(client.get_axis_parameter(1, 0), Err(HostError::Io(_))));
}

#[test]
fn tcp_connect_refused() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    drop(listener);
    assert!(matches!(TcpTransport::connect(&addr), Err(HostError::Open { .. })));
}

/// Two hosts on one pty would read each other's replies: the second open is refused while the first
/// holds the port, and works again once it is closed.
#[test]
fn serial_port_is_opened_exclusively() {
    let pty = nix::pty::openpty(None, None).unwrap();
    let slave_path = nix::unistd::ttyname(&pty.slave).unwrap();
    let path = slave_path.to_str().unwrap();
    let first = SerialTransport::open(path, 9600).unwrap();
    let err = SerialTransport::open(path, 9600).unwrap_err();
    assert!(matches!(err, HostError::InUse { .. }), "{err:?}");
    assert!(err.to_string().contains("is in use"), "{err}");
    assert!(err.is_no_reply());
    drop(first);
    SerialTransport::open(path, 9600).unwrap();
}

/// A server that closes a connection before answering anything (as `tmcl serve --tcp` does with a second
/// client) is reported as busy, not as a bare I/O error.
#[test]
fn tcp_server_that_turns_the_client_away() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let server = thread::spawn(move || drop(listener.accept().unwrap()));
    let mut client = Client::new(TcpTransport::connect(&addr).unwrap()).with_timeout(Duration::from_secs(5));
    server.join().unwrap();
    let err = client.get_axis_parameter(1, 0).unwrap_err();
    assert!(matches!(err, HostError::InUse { .. }), "{err:?}");
    assert!(err.to_string().contains("already in use by another client"), "{err}");
}

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

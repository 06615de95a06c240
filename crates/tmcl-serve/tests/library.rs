//! The library as an embedding program uses it: a server on a thread, hosts on its links, a clean stop.

use tmcl_host::{Client, SerialTransport, TcpTransport};
use tmcl_serve::{LinkInfo, LinkOptions, ModuleOptions, Options, ServeError, Server};

fn pd28() -> &'static tmcl_core::model::ModelSpec {
    tmcl_core::model::by_id("pd28-1021").unwrap()
}

#[test]
fn a_server_on_a_thread_answers_on_tcp_and_stops() {
    let options =
        Options::new(vec![ModuleOptions::new(pd28()).address(3)], vec![LinkOptions::Tcp("127.0.0.1:0".into())]);
    let server = Server::new(options).unwrap().spawn().unwrap();
    let LinkInfo::Tcp { address } = server.links()[0].clone() else { panic!("a TCP link") };
    assert_ne!(address.port(), 0, "the bound port, not 0");
    assert_eq!(server.modules()[0].address, 3);
    let mut client = Client::new(TcpTransport::connect(&address.to_string()).unwrap()).with_module_address(3);
    client.set_axis_parameter(4, 0, 1234).unwrap();
    assert_eq!(client.get_axis_parameter(4, 0).unwrap(), 1234);
    drop(client);
    server.stop().unwrap();
    assert!(std::net::TcpStream::connect(address).is_err(), "nobody listens after the stop");
}

#[test]
fn a_pty_link_and_its_eeprom_outlive_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("tmcl0");
    let eeprom = dir.path().join("m.eeprom");
    let module = ModuleOptions::new(pd28()).eeprom(&eeprom);
    let server = Server::new(Options::new(vec![module.clone()], vec![LinkOptions::Pty(link.clone())])).unwrap();
    let running = server.spawn().unwrap();
    assert!(matches!(&running.links()[0], LinkInfo::Pty { link: l, .. } if *l == link));
    {
        let mut client = Client::new(SerialTransport::open(link.to_str().unwrap(), 9600).unwrap());
        client.set_axis_parameter(6, 0, 77).unwrap();
        client.store_axis_parameter(6, 0).unwrap();
    }
    drop(running); // dropping stops it
    assert!(std::fs::symlink_metadata(&link).is_err(), "the link is removed");
    assert!(!dir.path().join("tmcl0.lock").exists(), "and its lock file");
    // The stored value is in the file: a new server on it starts with it.
    let again = Server::new(Options::new(vec![module], vec![LinkOptions::Pty(link.clone())])).unwrap().spawn().unwrap();
    let mut client = Client::new(SerialTransport::open(link.to_str().unwrap(), 9600).unwrap());
    assert_eq!(client.get_axis_parameter(6, 0).unwrap(), 77);
    drop(client);
    again.stop().unwrap();
}

#[test]
fn a_held_link_is_refused_before_anything_is_made() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("tmcl0");
    let first =
        Server::new(Options::new(vec![ModuleOptions::new(pd28())], vec![LinkOptions::Pty(link.clone())])).unwrap();
    let second = Server::new(Options::new(vec![ModuleOptions::new(pd28())], vec![LinkOptions::Pty(link)]));
    assert!(matches!(second, Err(ServeError::Io(m)) if m.contains("already served")));
    drop(first);
}

#[test]
fn several_links_reach_one_module_each_with_its_own_replies() {
    let links = vec![LinkOptions::Tcp("127.0.0.1:0".into()), LinkOptions::Tcp("127.0.0.1:0".into())];
    let server = Server::new(Options::new(vec![ModuleOptions::new(pd28())], links)).unwrap().spawn().unwrap();
    let addresses: Vec<String> = server.links().iter().map(ToString::to_string).collect();
    assert_eq!(addresses.len(), 2);
    let mut a = Client::new(TcpTransport::connect(&addresses[0]).unwrap());
    let mut b = Client::new(TcpTransport::connect(&addresses[1]).unwrap());
    a.set_axis_parameter(4, 0, 1111).unwrap();
    assert_eq!(b.get_axis_parameter(4, 0).unwrap(), 1111, "one module");
    for k in 0..200 {
        a.set_axis_parameter(6, 0, k % 200).unwrap();
        assert_eq!(b.get_axis_parameter(4, 0).unwrap(), 1111);
        assert_eq!(a.get_axis_parameter(6, 0).unwrap(), k % 200);
    }
    assert!(a.take_skipped().is_empty() && b.take_skipped().is_empty(), "no foreign reply on either link");
    drop((a, b));
    server.stop().unwrap();
}

#[test]
fn wire_timing_takes_one_link() {
    let links = vec![LinkOptions::Tcp("127.0.0.1:0".into()), LinkOptions::Tcp("127.0.0.1:0".into())];
    let mut options = Options::new(vec![ModuleOptions::new(pd28())], links);
    options.wire_timing = true;
    assert!(matches!(Server::new(options), Err(ServeError::Config(m)) if m.contains("one link")));
}

#[test]
fn a_fleet_serves_each_line_on_its_own_links_and_stops_together() {
    use tmcl_serve::Fleet;
    let dir = tempfile::tempdir().unwrap();
    let tmcm = tmcl_core::model::by_id("tmcm-1310").unwrap();
    // A USB module alone on its pty, and a bus of two on another (and on TCP).
    let usb = dir.path().join("usb0");
    let bus = dir.path().join("bus");
    let lines = vec![
        Options::new(vec![ModuleOptions::new(tmcm)], vec![LinkOptions::Pty(usb.clone())]),
        Options::new(
            vec![ModuleOptions::new(pd28()).address(1), ModuleOptions::new(pd28()).address(2)],
            vec![LinkOptions::Pty(bus.clone()), LinkOptions::Tcp("127.0.0.1:0".into())],
        ),
    ];
    let fleet = Fleet::new(lines).unwrap();
    assert_eq!(fleet.lines().len(), 2);
    let LinkInfo::Tcp { address } = fleet.lines()[1].links()[1].clone() else { panic!("a TCP link") };
    let stopper = fleet.stoppers()[0].clone();
    let running = std::thread::spawn(move || fleet.run());
    let mut usb_host = Client::new(SerialTransport::open(usb.to_str().unwrap(), 9600).unwrap());
    let mut bus_host = Client::new(SerialTransport::open(bus.to_str().unwrap(), 9600).unwrap()).with_module_address(2);
    let mut tcp_host = Client::new(TcpTransport::connect(&address.to_string()).unwrap()).with_module_address(2);
    usb_host.set_axis_parameter(4, 0, 1111).unwrap();
    bus_host.set_axis_parameter(4, 0, 2222).unwrap();
    assert_eq!(usb_host.get_axis_parameter(4, 0).unwrap(), 1111, "the lines are separate modules");
    assert_eq!(tcp_host.get_axis_parameter(4, 0).unwrap(), 2222, "a line's links reach the same module");
    drop((usb_host, bus_host, tcp_host));
    // Stopping one line stops the fleet, and every line's links go.
    stopper.stop();
    running.join().unwrap().unwrap();
    assert!(std::fs::symlink_metadata(&usb).is_err() && std::fs::symlink_metadata(&bus).is_err());
}

#[test]
fn a_fleet_refuses_a_link_given_to_two_lines() {
    use tmcl_serve::Fleet;
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("tmcl0");
    let line = || Options::new(vec![ModuleOptions::new(pd28())], vec![LinkOptions::Pty(link.clone())]);
    let err = Fleet::new(vec![line(), line()]).err().expect("refused");
    assert!(matches!(&err, ServeError::Config(m) if m.contains("lines 1 and 2")), "{err}");
    assert!(std::fs::symlink_metadata(&link).is_err(), "nothing was made");
}

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

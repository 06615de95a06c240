//! `Access`: work on a served module from another thread while hosts use the link.

use std::io::{Read, Write};
use tmcl_serve::{LinkInfo, LinkOptions, ModuleOptions, Options, Server};
use tmcl_wire::{Command, Request};

#[test]
fn access_reads_and_changes_a_served_module() {
    let spec = tmcl_core::model::by_id("pd28-1021").unwrap();
    let options = Options::new(vec![ModuleOptions::new(spec)], vec![LinkOptions::Tcp("127.0.0.1:0".into())]);
    let server = Server::new(options).unwrap().spawn().unwrap();
    let access = server.access();
    // SAP 4 directly, then GAP 4 by a host on the link sees it.
    let set = access.with_module(0, |module, now| module.execute(Command::Sap { param: 4, motor: 0, value: 777 }, now));
    assert!(matches!(set, Some(Ok(_))));
    let LinkInfo::Tcp { address } = server.links()[0].clone() else { panic!("a TCP link") };
    let mut stream = std::net::TcpStream::connect(address).unwrap();
    stream
        .write_all(&Request { address: 1, instruction: Command::Gap { param: 4, motor: 0 }.encode() }.to_bytes())
        .unwrap();
    let mut reply = [0u8; 9];
    stream.read_exact(&mut reply).unwrap();
    assert_eq!(i32::from_be_bytes([reply[4], reply[5], reply[6], reply[7]]), 777);
    assert_eq!(access.with_module(1, |module, _| module.address()), None, "no second module");
    server.stop().unwrap();
    assert_eq!(access.with_module(0, |module, _| module.address()), None, "stopped");
}

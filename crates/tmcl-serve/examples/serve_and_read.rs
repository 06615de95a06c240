//! Serves a virtual PD28-1021 on a loopback TCP port from a thread of this program, reads its maximum
//! positioning speed (GAP 4, PD28-1021 TMCL firmware manual §4 Table 15) as a host on the link, changes
//! it directly through `Access` between the serve loop's polls, reads it again, and stops the server.
//!
//! Run with `cargo run -p tmcl-serve --example serve_and_read`.

use tmcl_host::{Client, TcpTransport};
use tmcl_serve::{LinkOptions, ModuleOptions, Options, Server};
use tmcl_wire::Command;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let spec = tmcl_core::model::by_id("pd28-1021").ok_or("no such model")?;
    let options = Options::new(vec![ModuleOptions::new(spec).address(1)], vec![LinkOptions::Tcp("127.0.0.1:0".into())]);
    let server = Server::new(options)?.spawn()?;
    let link = server.links()[0].to_string();
    println!("serving {} on {link}", server.modules()[0].name);

    let mut host = Client::new(TcpTransport::connect(&link)?);
    println!("GAP 4 over the link: {}", host.get_axis_parameter(4, 0)?);
    server
        .access()
        .with_module(0, |module, now| module.execute(Command::Sap { param: 4, motor: 0, value: 1000 }, now))
        .ok_or("the server stopped")?
        .map_err(|status| format!("SAP refused: {status}"))?;
    let speed = host.get_axis_parameter(4, 0)?;
    println!("GAP 4 after SAP 4 through Access: {speed}");
    assert_eq!(speed, 1000);
    drop(host);
    server.stop()?;
    println!("stopped");
    Ok(())
}

//! A host client reading a parameter: the module's firmware version (command 136, PD28-1021 TMCL
//! firmware manual §3.7.38) and the maximum positioning speed (GAP 4, §4 Table 15).
//!
//! ```text
//! cargo run -p tmcl-host --example read_parameter -- /dev/ttyACM0    # a real module on a serial port
//! cargo run -p tmcl-host --example read_parameter -- 127.0.0.1:2323  # `tmcl serve --tcp 2323`
//! cargo run -p tmcl-host --example read_parameter                    # a virtual module of its own
//! ```
//!
//! Without an argument the example serves a virtual PD28-1021 (the firmware core on the simulated board)
//! on a loopback TCP port in a thread of its own and reads from that.

use std::io::{Read, Write};
use std::net::TcpListener;
use tmcl_host::{Client, HostError, SerialTransport, TcpTransport, Transport};

fn main() -> Result<(), HostError> {
    let target = match std::env::args().nth(1) {
        Some(target) => target,
        None => serve_virtual_module()?,
    };
    // A serial device is a path; anything else is HOST:PORT.
    if target.starts_with('/') {
        read(Client::new(SerialTransport::open(&target, 9600)?))
    } else {
        read(Client::new(TcpTransport::connect(&target)?))
    }
}

fn read<T: Transport>(mut client: Client<T>) -> Result<(), HostError> {
    println!("firmware: {}", client.version_string()?);
    let speed = client.get_axis_parameter(4, 0)?;
    println!("AP 4 (maximum positioning speed) of motor 0: {speed}");
    Ok(())
}

/// Serves a virtual PD28-1021 on 127.0.0.1 (a free port) to one client, in a thread; returns the address.
fn serve_virtual_module() -> Result<String, HostError> {
    use tmcl_core::{model::pd28_1021, Instant, Module};
    use tmcl_sim::SimBoard;

    let listener = TcpListener::bind("127.0.0.1:0").map_err(HostError::Io)?;
    let address = listener.local_addr().map_err(HostError::Io)?.to_string();
    std::thread::spawn(move || {
        let start = std::time::Instant::now();
        let now = || Instant::from_micros(start.elapsed().as_micros() as u64);
        let mut module = Module::new(SimBoard::in_memory_for(&pd28_1021::SPEC), &pd28_1021::SPEC, now());
        let Ok((mut stream, _)) = listener.accept() else { return };
        let mut buf = [0u8; 64];
        while let Ok(n @ 1..) = stream.read(&mut buf) {
            let mut out = Vec::new();
            module.receive(now(), &buf[..n], &mut |bytes: &[u8]| out.extend_from_slice(bytes));
            if stream.write_all(&out).is_err() {
                return;
            }
        }
    });
    Ok(address)
}

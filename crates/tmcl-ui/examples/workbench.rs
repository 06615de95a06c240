//! The workbench on a virtual module: serves a PD28-1021 (the firmware core on the simulated board) on
//! a loopback TCP port in a thread, starts the workbench's web server on a free loopback port against
//! it, and fetches the page once. With `--keep` it keeps running until Ctrl-C: open the printed address
//! in a browser.
//!
//! Run with `cargo run -p tmcl-ui --example workbench [-- --keep]`.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use tmcl_host::{Client, TcpTransport, Transport};
use tmcl_ui::{Options, UNTIMED_RATE};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let keep = std::env::args().any(|a| a == "--keep");
    let module = serve_virtual_module()?;
    let transport: Box<dyn Transport + Send> = Box::new(TcpTransport::connect(&module)?);
    let options = Options {
        listen: "127.0.0.1:0".parse()?,
        rate: UNTIMED_RATE,
        model: tmcl_model::by_id("pd28-1021"),
        link_name: format!("a virtual PD28-1021 on {module}"),
        reopen: None,
    };
    let (tx, rx) = std::sync::mpsc::channel();
    let stop = async move {
        if keep {
            let _ = tokio::signal::ctrl_c().await;
        } else {
            // Long enough for the check below; the page is served as soon as the server listens.
            tokio::time::sleep(std::time::Duration::from_secs(2)).await;
        }
    };
    let ui = std::thread::spawn(move || {
        tmcl_ui::run_until(Client::new(transport), options, |addr| tx.send(addr).unwrap(), stop)
    });
    let addr = rx.recv()?;
    println!("workbench on http://{addr}/");
    let mut http = TcpStream::connect(addr)?;
    write!(http, "GET / HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n")?;
    let mut page = String::new();
    http.read_to_string(&mut page)?;
    println!("{}", page.lines().next().unwrap_or("no answer"));
    assert!(page.starts_with("HTTP/1.1 200"));
    ui.join().map_err(|_| "the workbench thread panicked")??;
    Ok(())
}

/// Serves a virtual PD28-1021 on 127.0.0.1 (a free port) to one client, in a thread; returns the address.
fn serve_virtual_module() -> std::io::Result<String> {
    use tmcl_core::{model::pd28_1021, Instant, Module};
    use tmcl_sim::SimBoard;

    let listener = TcpListener::bind("127.0.0.1:0")?;
    let address = listener.local_addr()?.to_string();
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

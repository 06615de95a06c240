//! Who may talk to the workbench: requests whose `Host` or `Origin` is not the server's own are refused.
//!
//! A web page on another site can make the browser send requests to `127.0.0.1`: a form post, an image,
//! a WebSocket. Without a check such a page could drive a motor. Two checks keep it out:
//!
//! - **Origin.** Browsers name the page that makes a request in its `Origin` header (always for a
//!   WebSocket handshake and for a cross-site request). A request with an `Origin` that is not this
//!   server (`http://` and one of its own host names, see below) is refused, `Origin: null` too. A request
//!   without one (a navigation, `curl`) passes this check.
//! - **Host.** A page on a domain that resolves to 127.0.0.1 (DNS rebinding) is same-origin with itself,
//!   not with us: its requests carry its own name in `Host`. So `Host` must be one of the server's names:
//!   the address it listens on (`127.0.0.1:8080`) and, on a loopback address, `localhost:PORT` too. On an
//!   unspecified address (`--listen 0.0.0.0:8080`, for other machines to connect) the server cannot know
//!   its names: any `Host` with its port passes, and only the `Origin` check is left.
//!
//! Refusals are `403 Forbidden` with a sentence that says why.

use std::net::{IpAddr, SocketAddr};

/// The names a request may use for this server.
#[derive(Debug, Clone)]
pub(crate) struct Guard {
    hosts: Vec<String>,
    /// Any host name with this port (the server listens on an unspecified address).
    any_host_port: Option<u16>,
}

impl Guard {
    /// The guard of a server listening on `addr`.
    pub(crate) fn new(addr: SocketAddr) -> Guard {
        let port = addr.port();
        let ip = addr.ip();
        if ip.is_unspecified() {
            return Guard { hosts: Vec::new(), any_host_port: Some(port) };
        }
        let mut hosts = vec![host_of(ip, port)];
        if ip.is_loopback() {
            for name in ["localhost".to_string(), "127.0.0.1".to_string(), "[::1]".to_string()] {
                let host = format!("{name}:{port}");
                if !hosts.contains(&host) {
                    hosts.push(host);
                }
            }
        }
        Guard { hosts, any_host_port: None }
    }

    /// Whether a request with these headers may pass; `Err` says why not.
    pub(crate) fn check(&self, host: Option<&str>, origin: Option<&str>) -> Result<(), String> {
        let Some(host) = host else { return Err("the request names no Host".into()) };
        let host = host.trim().to_ascii_lowercase();
        if !self.host_ok(&host) {
            return Err(format!("Host {host:?} is not this server ({})", self.names()));
        }
        if let Some(origin) = origin {
            let origin = origin.trim().to_ascii_lowercase();
            if origin.strip_prefix("http://") != Some(host.as_str()) {
                return Err(format!("Origin {origin:?} is not this server: only the workbench's own page may use it"));
            }
        }
        Ok(())
    }

    fn host_ok(&self, host: &str) -> bool {
        match self.any_host_port {
            Some(port) => port_of(host) == Some(port),
            None => self.hosts.iter().any(|h| h == host),
        }
    }

    fn names(&self) -> String {
        match self.any_host_port {
            Some(port) => format!("any name with port {port}"),
            None => self.hosts.join(", "),
        }
    }
}

/// `ip:port` as a `Host` header writes it (IPv6 in brackets).
fn host_of(ip: IpAddr, port: u16) -> String {
    match ip {
        IpAddr::V4(v4) => format!("{v4}:{port}"),
        IpAddr::V6(v6) => format!("[{v6}]:{port}"),
    }
}

/// The port of a `Host` value; a host without one means port 80.
fn port_of(host: &str) -> Option<u16> {
    let after_bracket = host.rfind(']').map_or(0, |i| i + 1);
    match host[after_bracket..].rfind(':') {
        Some(i) => host[after_bracket + i + 1..].parse().ok(),
        None => Some(80),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guard(addr: &str) -> Guard {
        Guard::new(addr.parse().unwrap())
    }

    #[test]
    fn loopback_names_pass_and_others_do_not() {
        let g = guard("127.0.0.1:8080");
        assert!(g.check(Some("127.0.0.1:8080"), None).is_ok());
        assert!(g.check(Some("localhost:8080"), Some("http://localhost:8080")).is_ok());
        assert!(g.check(Some("LOCALHOST:8080"), Some("http://localhost:8080")).is_ok());
        assert!(g.check(Some("[::1]:8080"), None).is_ok());
        // DNS rebinding: a foreign name for our address.
        assert!(g.check(Some("evil.example:8080"), None).unwrap_err().contains("not this server"));
        assert!(g.check(Some("127.0.0.1:9090"), None).is_err());
        assert!(g.check(None, None).is_err());
    }

    #[test]
    fn foreign_origins_are_refused() {
        let g = guard("127.0.0.1:8080");
        let err = g.check(Some("127.0.0.1:8080"), Some("http://evil.example")).unwrap_err();
        assert!(err.contains("Origin \"http://evil.example\""), "{err}");
        assert!(g.check(Some("127.0.0.1:8080"), Some("null")).is_err());
        assert!(g.check(Some("127.0.0.1:8080"), Some("https://127.0.0.1:8080")).is_err());
        // Same names, but the page was loaded under another one of them.
        assert!(g.check(Some("127.0.0.1:8080"), Some("http://localhost:8080")).is_err());
    }

    #[test]
    fn unspecified_addresses_check_the_port_and_the_origin() {
        let g = guard("0.0.0.0:8080");
        assert!(g.check(Some("bench-pc:8080"), Some("http://bench-pc:8080")).is_ok());
        assert!(g.check(Some("bench-pc:8080"), Some("http://evil.example")).is_err());
        assert!(g.check(Some("bench-pc:9000"), None).is_err());
        assert!(g.check(Some("bench-pc"), None).is_err());
        let g = guard("[::]:80");
        assert!(g.check(Some("bench-pc"), None).is_ok());
        assert!(g.check(Some("[fe80::1]:80"), None).is_ok());
        let g = guard("[::1]:8080");
        assert!(g.check(Some("[::1]:8080"), None).is_ok());
        assert!(g.check(Some("localhost:8080"), None).is_ok());
    }
}

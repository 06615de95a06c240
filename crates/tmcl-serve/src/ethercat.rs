//! `tmcl serve --ethercat IFACE`: the module's EtherCAT slave on a Linux network interface.
//!
//! The OS shim is a packet socket (`AF_PACKET`, `SOCK_RAW`) for EtherType 0x88A4 and nothing else, made
//! from safe calls only: `rustix` opens it (it takes any protocol number), `nix` receives with the
//! sender's link address (`recvfrom` into a `LinkAddr`: interface index and packet type) and sends the
//! answer back to that same link address (`sendto`). The socket is not bound to the interface (neither
//! crate builds a `sockaddr_ll` without `unsafe`): frames of other interfaces are dropped by index, and
//! since it asks for 0x88A4 only, the kernel hands it neither other traffic nor its own outgoing frames.
//!
//! The slave is `tmcl_ethercat::Slave` around the module the pty or TCP link also serves; FoE files
//! written in BOOT go to [`FoeFiles`].

use std::fs::File;
use std::io::Write;
use std::path::PathBuf;
use tmcl_ethercat::wire::foe::ErrorCode;
use tmcl_ethercat::FileStore;

#[cfg(target_os = "linux")]
pub use packet::RawSocket;
#[cfg(not(target_os = "linux"))]
pub use unsupported::RawSocket;

#[cfg(target_os = "linux")]
mod packet {
    use crate::ServeError;
    use nix::sys::socket::{recvfrom, sendto, LinkAddr, MsgFlags};
    use std::io;
    use std::os::fd::{AsFd, AsRawFd, BorrowedFd, OwnedFd};

    /// EtherType of EtherCAT.
    const ETHERTYPE: u16 = 0x88A4;

    /// `PACKET_OUTGOING`: a frame this host sent (never seen with a protocol-bound socket; checked
    /// anyway).
    const PACKET_OUTGOING: u8 = 4;

    /// Where a frame came from: its interface (and the master's address), to answer to.
    pub type Peer = LinkAddr;

    /// A packet socket for EtherCAT frames on one interface.
    pub struct RawSocket {
        fd: OwnedFd,
        ifindex: usize,
        /// The interface's name, for messages.
        pub name: String,
    }

    impl RawSocket {
        /// Opens the socket for interface `name`.
        pub fn open(name: &str) -> Result<RawSocket, ServeError> {
            let ifindex = nix::net::if_::if_nametoindex(name).map_err(|e| {
                ServeError::Io(format!("--ethercat {name}: no such network interface ({e}); `ip link` lists them"))
            })?;
            let protocol = rustix::net::RawProtocol::new(u32::from(ETHERTYPE.to_be())).expect("0x88A4 is not 0");
            let fd = rustix::net::socket_with(
                rustix::net::AddressFamily::PACKET,
                rustix::net::SocketType::RAW,
                rustix::net::SocketFlags::NONBLOCK | rustix::net::SocketFlags::CLOEXEC,
                Some(rustix::net::Protocol::from_raw(protocol)),
            )
            .map_err(|e| {
                let why = if e == rustix::io::Errno::PERM || e == rustix::io::Errno::ACCESS {
                    " (raw Ethernet needs CAP_NET_RAW: run as root, or give the binary the capability with \
                     `setcap cap_net_raw+ep`)"
                } else {
                    ""
                };
                ServeError::Io(format!("--ethercat {name}: cannot open a packet socket: {e}{why}"))
            })?;
            Ok(RawSocket { fd, ifindex: ifindex as usize, name: name.to_string() })
        }

        /// The next EtherCAT frame that arrived on the interface, with the address to answer to; `None`
        /// when nothing is waiting.
        pub fn recv(&self, buf: &mut [u8]) -> io::Result<Option<(usize, Peer)>> {
            loop {
                match recvfrom::<LinkAddr>(self.fd.as_raw_fd(), buf) {
                    Ok((n, Some(from))) => {
                        if from.ifindex() == self.ifindex && from.pkttype() != PACKET_OUTGOING {
                            return Ok(Some((n, from)));
                        }
                    }
                    Ok((_, None)) => {}
                    Err(nix::Error::EAGAIN) => return Ok(None),
                    Err(nix::Error::EINTR) => {}
                    Err(e) => return Err(io::Error::from_raw_os_error(e as i32)),
                }
            }
        }

        /// Sends an answer to where a frame came from (its interface).
        pub fn send(&self, bytes: &[u8], to: &Peer) -> io::Result<()> {
            sendto(self.fd.as_raw_fd(), bytes, to, MsgFlags::empty())
                .map(|_| ())
                .map_err(|e| io::Error::from_raw_os_error(e as i32))
        }
    }

    impl AsFd for RawSocket {
        fn as_fd(&self) -> BorrowedFd<'_> {
            self.fd.as_fd()
        }
    }
}

/// Elsewhere there is no `AF_PACKET`: `--ethercat` fails with a message, the rest of `tmcl` builds.
#[cfg(not(target_os = "linux"))]
mod unsupported {
    use crate::ServeError;
    use std::io;
    use std::os::fd::{AsFd, BorrowedFd};

    /// No peer can exist.
    pub enum Peer {}

    /// No socket can exist.
    pub struct RawSocket {
        never: Peer,
        pub name: String,
    }

    impl RawSocket {
        pub fn open(name: &str) -> Result<RawSocket, ServeError> {
            Err(ServeError::Io(format!("--ethercat {name}: raw Ethernet (AF_PACKET) needs Linux")))
        }

        pub fn recv(&self, _: &mut [u8]) -> io::Result<Option<(usize, Peer)>> {
            match self.never {}
        }

        pub fn send(&self, _: &[u8], to: &Peer) -> io::Result<()> {
            match *to {}
        }
    }

    impl AsFd for RawSocket {
        fn as_fd(&self) -> BorrowedFd<'_> {
            match self.never {}
        }
    }
}

/// Where FoE files go: `PATH` (beside the EEPROM file). The bytes are collected in memory while the
/// master sends them and written out (a temporary file, renamed) by [`FoeFiles::write_pending`] when
/// no frame is waiting, so that no disk write delays an answer (SOEM gives a frame 2 ms). Each file is
/// reported on stderr; without a path the bytes are counted and reported, not kept.
pub struct FoeFiles {
    path: Option<PathBuf>,
    current: Option<(String, Vec<u8>)>,
    complete: Option<(String, Vec<u8>)>,
}

impl FoeFiles {
    /// Files kept at `path` (none: counted and reported only).
    pub fn new(path: Option<PathBuf>) -> FoeFiles {
        FoeFiles { path, current: None, complete: None }
    }

    /// Writes a completed file out and reports it (call while no frame is waiting).
    pub fn write_pending(&mut self) {
        let Some((name, data)) = self.complete.take() else { return };
        let place = match &self.path {
            Some(path) => {
                let mut tmp = path.clone().into_os_string();
                tmp.push(".part");
                let tmp = PathBuf::from(tmp);
                let written =
                    File::create(&tmp).and_then(|mut f| f.write_all(&data)).and_then(|()| std::fs::rename(&tmp, path));
                match written {
                    Ok(()) => format!("kept in {}", path.display()),
                    Err(e) => format!("NOT kept: cannot write {}: {e}", path.display()),
                }
            }
            None => "not kept (the EEPROM is in memory: give --eeprom to keep it)".to_string(),
        };
        eprintln!("tmcl serve: FoE: received {name:?}, {} bytes, {place}; nothing is flashed", data.len());
    }
}

/// The largest file kept (the TMCM-1310's firmware is far smaller).
const MAX_FILE: usize = 16 << 20;

impl FileStore for FoeFiles {
    fn begin(&mut self, name: &[u8], password: u32) -> Result<(), ErrorCode> {
        self.abort();
        let name: String = String::from_utf8_lossy(name).chars().filter(|c| !c.is_control()).collect();
        eprintln!("tmcl serve: FoE: the master writes {name:?} (password {password:#x})");
        self.current = Some((name, Vec::new()));
        Ok(())
    }

    fn append(&mut self, data: &[u8]) -> Result<(), ErrorCode> {
        let (_, bytes) = self.current.as_mut().ok_or(ErrorCode::Illegal)?;
        if bytes.len() + data.len() > MAX_FILE {
            return Err(ErrorCode::DiskFull);
        }
        bytes.extend_from_slice(data);
        Ok(())
    }

    fn finish(&mut self) -> Result<(), ErrorCode> {
        self.complete = Some(self.current.take().ok_or(ErrorCode::Illegal)?);
        Ok(())
    }

    fn abort(&mut self) {
        if let Some((name, bytes)) = self.current.take() {
            eprintln!("tmcl serve: FoE: the transfer of {name:?} broke off after {} bytes", bytes.len());
        }
    }
}

//! File access over EtherCAT in BOOT (TMCM-1310 manual §3.3: "For firmware updates the EtherCAT state
//! machine of the slave has to be switched to Bootstrap state. The file access over EtherCAT protocol
//! (FoE) is used.").
//!
//! The slave takes **writes** only: each file a master writes goes, packet by packet, to a [`FileStore`]
//! (the `tmcl` command line puts it in a file beside the EEPROM and reports it). Nothing is flashed: the
//! virtual module keeps running the firmware it has. A read request answers "not found"; the manual says
//! nothing about reading files back. The password is handed to the store and not checked (the manual
//! names none).
//!
//! The exchange (ETG.1000.6, "FoE"): write request → ack 0; data 1 → ack 1; … A data packet shorter than
//! the mailbox allows ([`crate::layout::FOE_DATA`] bytes) is the last; its ack ends the transfer.

use crate::wire::foe::{ErrorCode, Repr};

/// Where the files a master writes go.
pub trait FileStore {
    /// A master starts writing file `name` with `password`.
    fn begin(&mut self, name: &[u8], password: u32) -> Result<(), ErrorCode>;
    /// The next bytes of the file.
    fn append(&mut self, data: &[u8]) -> Result<(), ErrorCode>;
    /// The file is complete.
    fn finish(&mut self) -> Result<(), ErrorCode>;
    /// The transfer broke off (an error, a state change, a new request): forget the partial file.
    fn abort(&mut self);
}

impl<F: FileStore + ?Sized> FileStore for &mut F {
    fn begin(&mut self, name: &[u8], password: u32) -> Result<(), ErrorCode> {
        (**self).begin(name, password)
    }
    fn append(&mut self, data: &[u8]) -> Result<(), ErrorCode> {
        (**self).append(data)
    }
    fn finish(&mut self) -> Result<(), ErrorCode> {
        (**self).finish()
    }
    fn abort(&mut self) {
        (**self).abort()
    }
}

/// A store that takes no files (every write request: access denied).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoFiles;

impl FileStore for NoFiles {
    fn begin(&mut self, _: &[u8], _: u32) -> Result<(), ErrorCode> {
        Err(ErrorCode::AccessDenied)
    }
    fn append(&mut self, _: &[u8]) -> Result<(), ErrorCode> {
        Err(ErrorCode::AccessDenied)
    }
    fn finish(&mut self) -> Result<(), ErrorCode> {
        Err(ErrorCode::AccessDenied)
    }
    fn abort(&mut self) {}
}

/// The FoE server's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Foe {
    /// No transfer.
    #[default]
    Idle,
    /// Receiving a file; the next packet expected.
    Receiving {
        /// The packet number expected next.
        next: u32,
    },
}

/// The answer to one FoE message: a message to send (text borrowed from a static), or none.
pub type Answer = Option<Repr<'static>>;

impl Foe {
    /// Handles one FoE message from the master; `max_data` is the largest data packet the mailbox
    /// carries. Returns what to answer.
    pub fn handle(&mut self, message: Repr<'_>, max_data: usize, files: &mut impl FileStore) -> Answer {
        match (*self, message) {
            (state, Repr::Write { password, name }) => {
                if state != Foe::Idle {
                    files.abort();
                }
                match files.begin(name, password) {
                    Ok(()) => {
                        *self = Foe::Receiving { next: 1 };
                        Some(Repr::Ack { packet: 0 })
                    }
                    Err(code) => self.fail(code, files, false),
                }
            }
            (Foe::Receiving { next }, Repr::Data { packet, data }) if packet == next => {
                if data.len() > max_data {
                    return self.fail(ErrorCode::Illegal, files, true);
                }
                if let Err(code) = files.append(data) {
                    return self.fail(code, files, true);
                }
                if data.len() < max_data {
                    *self = Foe::Idle;
                    if let Err(code) = files.finish() {
                        return self.fail(code, files, false);
                    }
                } else {
                    *self = Foe::Receiving { next: next.wrapping_add(1) };
                }
                Some(Repr::Ack { packet })
            }
            (Foe::Receiving { .. }, Repr::Data { .. }) => self.fail(ErrorCode::PacketNumberWrong, files, true),
            (Foe::Idle, Repr::Data { .. }) => Some(error(ErrorCode::Illegal)),
            (state, Repr::Read { .. }) => {
                if state != Foe::Idle {
                    files.abort();
                    *self = Foe::Idle;
                }
                Some(error(ErrorCode::NotFound))
            }
            // The master gives up: drop the partial file, answer nothing.
            (state, Repr::Error { .. }) => {
                if state != Foe::Idle {
                    files.abort();
                }
                *self = Foe::Idle;
                None
            }
            // Acks and busy messages are the slave's to send in a write; from the master they mean nothing.
            (_, Repr::Ack { .. } | Repr::Busy { .. }) => Some(error(ErrorCode::Illegal)),
        }
    }

    /// Breaks off the transfer (a state change).
    pub fn reset(&mut self, files: &mut impl FileStore) {
        if *self != Foe::Idle {
            files.abort();
        }
        *self = Foe::Idle;
    }

    fn fail(&mut self, code: ErrorCode, files: &mut impl FileStore, abort: bool) -> Answer {
        if abort {
            files.abort();
        }
        *self = Foe::Idle;
        Some(error(code))
    }
}

fn error(code: ErrorCode) -> Repr<'static> {
    let text: &'static [u8] = match code {
        ErrorCode::NotFound => b"no such file",
        ErrorCode::AccessDenied => b"no file store",
        ErrorCode::PacketNumberWrong => b"packet number",
        ErrorCode::DiskFull => b"disk full",
        _ => b"",
    };
    Repr::Error { code, text }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default)]
    struct Files {
        name: Vec<u8>,
        data: Vec<u8>,
        done: bool,
        aborted: bool,
    }

    impl FileStore for Files {
        fn begin(&mut self, name: &[u8], _: u32) -> Result<(), ErrorCode> {
            self.name = name.to_vec();
            self.data.clear();
            Ok(())
        }
        fn append(&mut self, data: &[u8]) -> Result<(), ErrorCode> {
            self.data.extend_from_slice(data);
            Ok(())
        }
        fn finish(&mut self) -> Result<(), ErrorCode> {
            self.done = true;
            Ok(())
        }
        fn abort(&mut self) {
            self.aborted = true;
        }
    }

    #[test]
    fn a_file_in_two_packets() {
        let mut foe = Foe::Idle;
        let mut f = Files::default();
        assert_eq!(foe.handle(Repr::Write { password: 0, name: b"fw.bin" }, 4, &mut f), Some(Repr::Ack { packet: 0 }));
        assert_eq!(foe.handle(Repr::Data { packet: 1, data: b"abcd" }, 4, &mut f), Some(Repr::Ack { packet: 1 }));
        assert!(!f.done);
        assert_eq!(foe.handle(Repr::Data { packet: 2, data: b"e" }, 4, &mut f), Some(Repr::Ack { packet: 2 }));
        assert!(f.done && !f.aborted);
        assert_eq!((f.name.as_slice(), f.data.as_slice()), (&b"fw.bin"[..], &b"abcde"[..]));
        assert_eq!(foe, Foe::Idle);
    }

    #[test]
    fn a_file_of_full_packets_ends_with_an_empty_one() {
        let mut foe = Foe::Idle;
        let mut f = Files::default();
        foe.handle(Repr::Write { password: 0, name: b"x" }, 2, &mut f);
        foe.handle(Repr::Data { packet: 1, data: b"ab" }, 2, &mut f);
        assert!(!f.done);
        assert_eq!(foe.handle(Repr::Data { packet: 2, data: b"" }, 2, &mut f), Some(Repr::Ack { packet: 2 }));
        assert!(f.done);
    }

    #[test]
    fn refusals() {
        let mut foe = Foe::Idle;
        let mut f = Files::default();
        assert!(matches!(
            foe.handle(Repr::Data { packet: 1, data: b"" }, 4, &mut f),
            Some(Repr::Error { code: ErrorCode::Illegal, .. })
        ));
        foe.handle(Repr::Write { password: 0, name: b"x" }, 4, &mut f);
        assert!(matches!(
            foe.handle(Repr::Data { packet: 3, data: b"" }, 4, &mut f),
            Some(Repr::Error { code: ErrorCode::PacketNumberWrong, .. })
        ));
        assert!(f.aborted);
        assert!(matches!(
            foe.handle(Repr::Read { password: 0, name: b"x" }, 4, &mut f),
            Some(Repr::Error { code: ErrorCode::NotFound, .. })
        ));
        assert!(matches!(
            Foe::Idle.handle(Repr::Write { password: 0, name: b"x" }, 4, &mut NoFiles),
            Some(Repr::Error { code: ErrorCode::AccessDenied, .. })
        ));
    }
}

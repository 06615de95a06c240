//! EEPROM backends of the simulator: [`MemNvm`] in memory, [`FileNvm`] in a crash-safe file.
//!
//! Both implement [`tmcl_core::hal::Nvm`] and start erased (every byte [`ERASED`], as a real EEPROM). Both keep the
//! whole image in memory, so reads never touch the disk.
//!
//! # Crash safety of `FileNvm`
//!
//! The trait promises that a [`Nvm::write`] is atomic: after a crash at any moment a later open sees all of the
//! written bytes or none of them. `FileNvm` keeps that promise across `kill -9`, and across power loss as far as the
//! file system honours `fsync` and `rename`. It stores the EEPROM in two files:
//!
//! * `FILE`, the **snapshot**: a header and the full image, replaced only by write-temp-then-rename;
//! * `FILE.journal`, the **journal**: a header and one record per `write` call, appended with a single `write(2)` on
//!   an `O_APPEND` descriptor.
//!
//! Each record carries a sequence number and a CRC-32 over the whole record. On open the snapshot is loaded and every
//! record that is complete, checks and has the next sequence number is replayed; replay stops at the first one that
//! does not, and the journal is truncated there. A torn tail (a write cut short by `kill -9`, which can interrupt a
//! multi-page `write(2)`, or a lost page after power loss) is therefore dropped whole. No `fsync` is needed per
//! record for `kill -9`, since the page cache outlives the process; [`FileNvm::sync`] (or [`Options::sync_writes`])
//! makes writes durable against power loss too.
//!
//! When the journal would grow past [`Options::compact_after`] bytes, the next write first **compacts**: the image
//! goes to `FILE.tmp` (fsynced), which is renamed over `FILE`, the directory is fsynced, and only then is the
//! journal reset to an empty one that continues the new snapshot. A crash at any step opens to the latest data:
//!
//! | crash during / after | on open |
//! |---|---|
//! | writing `FILE.tmp` | `FILE.tmp` is deleted; old snapshot + full journal |
//! | the rename | the new snapshot; the journal's base sequence is older, so it is *stale* and reset |
//! | the journal reset (journal empty, shorter than its header, or zeroed) | the new snapshot; journal re-created |
//!
//! The journal is also the lock file: an open `FileNvm` holds an exclusive lock on it ([`std::fs::File::try_lock`],
//! `flock(2)` on Linux), so a second open of the same EEPROM, from this or another process, fails with
//! [`NvmError::Locked`].
//!
//! # On-disk format, version 1
//!
//! All integers little-endian; CRC-32 is the IEEE 802.3 polynomial (as zlib, PNG, Ethernet).
//!
//! Snapshot `FILE`, 32 bytes of header, then `capacity` bytes of image:
//!
//! | bytes | field |
//! |---|---|
//! | 0..8 | magic `OTMCL-EE` |
//! | 8..10 | format version, `1` |
//! | 10..12 | reserved, `0` |
//! | 12..16 | capacity in bytes (the image length) |
//! | 16..24 | sequence number of the last write folded into the image (0 = none) |
//! | 24..28 | CRC-32 of the image |
//! | 28..32 | CRC-32 of bytes 0..28 |
//!
//! Journal `FILE.journal`, 24 bytes of header, then records back to back:
//!
//! | bytes | field |
//! |---|---|
//! | 0..8 | magic `OTMCL-JL` |
//! | 8..10 | format version, `1` |
//! | 10..12 | reserved, `0` |
//! | 12..20 | base sequence: the snapshot's sequence number this journal continues |
//! | 20..24 | CRC-32 of bytes 0..20 |
//!
//! Record, `24 + len` bytes; the first record has sequence number base + 1, each next one + 1:
//!
//! | bytes | field |
//! |---|---|
//! | 0..4 | magic `OTRC` |
//! | 4..12 | sequence number |
//! | 12..16 | offset in the image |
//! | 16..20 | `len`, the number of data bytes |
//! | 20..20+len | data |
//! | 20+len..24+len | CRC-32 of bytes 0..20+len |
//!
//! A file whose magic is not ours is refused with [`NvmError::NotAnEeprom`] and never written to; an empty `FILE`
//! counts as absent. A snapshot smaller than the requested capacity is extended with [`ERASED`] bytes (and rewritten
//! at once); a larger one is refused with [`NvmError::TooLarge`].

use std::fmt;
use std::fs::{self, File, OpenOptions, TryLockError};
use std::io::{self, Read, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};

use tmcl_core::hal::Nvm;

/// The value of an erased EEPROM byte.
pub const ERASED: u8 = 0xFF;

/// The current on-disk format version of [`FileNvm`].
pub const FORMAT_VERSION: u16 = 1;

/// What can go wrong with an EEPROM backend.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NvmError {
    /// An access past the end of the EEPROM. Nothing was read or written.
    #[error("EEPROM access of {len} bytes at offset {offset} is out of range (capacity {capacity})")]
    OutOfRange {
        /// Offset of the access.
        offset: usize,
        /// Length of the access.
        len: usize,
        /// Capacity of the EEPROM.
        capacity: usize,
    },
    /// The operating system refused a file operation.
    #[error("EEPROM file {}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The error from the OS.
        #[source]
        source: io::Error,
    },
    /// The file does not start with our magic: it is something else, and is left alone.
    #[error("{} is not an OpenTMCL EEPROM file (bad magic); refusing to touch it", path.display())]
    NotAnEeprom {
        /// The file concerned.
        path: PathBuf,
    },
    /// The file is ours but written in a format version this build does not read.
    #[error("EEPROM file {} has format version {version}, this build reads version {FORMAT_VERSION}", path.display())]
    UnsupportedVersion {
        /// The file concerned.
        path: PathBuf,
        /// The version found in the file.
        version: u16,
    },
    /// The file is ours but damaged in a way a crash cannot explain (a bad snapshot checksum, for instance).
    #[error("EEPROM file {} is corrupt: {reason}", path.display())]
    Corrupt {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The stored image is larger than the capacity asked for; opening it would lose data.
    #[error("EEPROM file {} holds {stored} bytes, more than the requested capacity {capacity}", path.display())]
    TooLarge {
        /// The file concerned.
        path: PathBuf,
        /// Capacity recorded in the file.
        stored: usize,
        /// Capacity asked for.
        capacity: usize,
    },
    /// Another `FileNvm`, in this process or another, has the EEPROM open.
    #[error("EEPROM file {} is in use by another process (its journal is locked)", path.display())]
    Locked {
        /// The EEPROM file.
        path: PathBuf,
    },
}

/// Checks that `len` bytes at `offset` fit into `capacity` bytes and returns the byte range.
fn range(offset: usize, len: usize, capacity: usize) -> Result<Range<usize>, NvmError> {
    match offset.checked_add(len) {
        Some(end) if end <= capacity => Ok(offset..end),
        _ => Err(NvmError::OutOfRange { offset, len, capacity }),
    }
}

/// An in-memory EEPROM, erased when created. Its contents end with the process.
///
/// Kept in pages of [`MemNvm::PAGE`] bytes, each allocated when something other than erased bytes is first
/// written to it: a module's EEPROM is mostly program memory that is never written (16 KiB of the
/// PD28-1021's 17 KiB), and a fleet of virtual modules keeps one each (docs/benchmarks.md, "A fleet on one
/// machine").
#[derive(Debug, Clone)]
pub struct MemNvm {
    capacity: usize,
    /// `None`: the page is erased.
    pages: Vec<Option<Box<[u8; MemNvm::PAGE]>>>,
}

impl PartialEq for MemNvm {
    /// The same contents (however they are kept).
    fn eq(&self, other: &MemNvm) -> bool {
        self.image() == other.image()
    }
}

impl Eq for MemNvm {}

impl MemNvm {
    /// The unit in which memory is taken for written bytes.
    pub const PAGE: usize = 256;

    /// An erased EEPROM of `capacity` bytes.
    pub fn new(capacity: usize) -> MemNvm {
        MemNvm { capacity, pages: vec![None; capacity.div_ceil(Self::PAGE)] }
    }

    /// An EEPROM holding `image`; its capacity is `image.len()`.
    pub fn from_image(image: Vec<u8>) -> MemNvm {
        let mut nvm = MemNvm::new(image.len());
        nvm.write(0, &image).expect("the image fits its own capacity");
        nvm
    }

    /// The whole contents.
    pub fn image(&self) -> Vec<u8> {
        let mut image = vec![ERASED; self.capacity];
        for (n, page) in self.pages.iter().enumerate() {
            if let Some(page) = page {
                let at = n * Self::PAGE;
                let len = Self::PAGE.min(self.capacity - at);
                image[at..at + len].copy_from_slice(&page[..len]);
            }
        }
        image
    }

    /// How many pages hold written bytes (the rest take no memory).
    pub fn pages_in_use(&self) -> usize {
        self.pages.iter().filter(|p| p.is_some()).count()
    }
}

impl Nvm for MemNvm {
    type Error = NvmError;

    fn capacity(&self) -> usize {
        self.capacity
    }

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), NvmError> {
        let r = range(offset, buf.len(), self.capacity)?;
        let mut at = r.start;
        while at < r.end {
            let (n, within) = (at / Self::PAGE, at % Self::PAGE);
            let len = (Self::PAGE - within).min(r.end - at);
            let out = &mut buf[at - r.start..at - r.start + len];
            match &self.pages[n] {
                Some(page) => out.copy_from_slice(&page[within..within + len]),
                None => out.fill(ERASED),
            }
            at += len;
        }
        Ok(())
    }

    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), NvmError> {
        let r = range(offset, data.len(), self.capacity)?;
        let mut at = r.start;
        while at < r.end {
            let (n, within) = (at / Self::PAGE, at % Self::PAGE);
            let len = (Self::PAGE - within).min(r.end - at);
            let part = &data[at - r.start..at - r.start + len];
            match &mut self.pages[n] {
                Some(page) => page[within..within + len].copy_from_slice(part),
                // Erased bytes onto an erased page: nothing to keep.
                None if part.iter().all(|&b| b == ERASED) => {}
                slot @ None => {
                    let mut page = Box::new([ERASED; Self::PAGE]);
                    page[within..within + len].copy_from_slice(part);
                    *slot = Some(page);
                }
            }
            at += len;
        }
        Ok(())
    }
}

/// Tuning of a [`FileNvm`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Options {
    /// Compact (fold the journal into the snapshot) before a write that would grow the journal past this many
    /// bytes. `None`: the larger of 64 KiB and 4 × the capacity.
    pub compact_after: Option<usize>,
    /// `fsync` the journal after every write, making each write durable against power loss, not only atomic.
    /// Costs a disk flush per write. Default `false`.
    pub sync_writes: bool,
}

impl Options {
    /// The journal bound in effect for an EEPROM of `capacity` bytes.
    pub fn compact_after_for(&self, capacity: usize) -> usize {
        self.compact_after.unwrap_or(usize::max(64 * 1024, capacity.saturating_mul(4)))
    }
}

/// What [`FileNvm::open`] found and repaired.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Recovery {
    /// Journal records replayed over the snapshot.
    pub replayed: u64,
    /// Bytes cut from the end of the journal: a torn or corrupt tail, the remains of an interrupted write.
    pub discarded_bytes: u64,
    /// The journal predated the snapshot or lacked its header (a crash between a compaction's rename and the end of
    /// the journal reset), and was reset.
    pub stale_journal: bool,
    /// A compaction's temporary file was found (a crash before its rename) and deleted.
    pub leftover_temp: bool,
}

/// Whether the journal on disk may be appended to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum JournalState {
    /// Ends exactly at `journal_len` and continues the snapshot.
    Clean,
    /// A failed append may have left a partial record past `journal_len`; truncate before appending.
    Dirty,
    /// The snapshot already holds everything (or the journal is missing its header); reset before appending.
    Stale,
}

/// A file-backed EEPROM whose every [`Nvm::write`] survives a crash whole or not at all.
///
/// See the [module docs](self) for the design and the on-disk format.
///
/// # Example
///
/// ```
/// use tmcl_core::hal::Nvm;
/// use tmcl_sim::FileNvm;
///
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("eeprom.bin");
/// let mut nvm = FileNvm::open(&path, 2048)?;
/// nvm.write(16, &[1, 2, 3, 4])?;
/// drop(nvm);
///
/// let mut nvm = FileNvm::open(&path, 2048)?;
/// let mut buf = [0; 5];
/// nvm.read(16, &mut buf)?;
/// assert_eq!(buf, [1, 2, 3, 4, 0xFF]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct FileNvm {
    path: PathBuf,
    journal_path: PathBuf,
    tmp_path: PathBuf,
    /// The journal, opened `O_APPEND` and locked for as long as `self` lives.
    journal: File,
    image: Vec<u8>,
    /// Sequence number of the last write applied to `image`.
    seq: u64,
    /// Length of the valid journal on disk.
    journal_len: u64,
    journal_state: JournalState,
    compact_after: u64,
    sync_writes: bool,
    recovery: Recovery,
    compactions: u64,
}

impl fmt::Debug for FileNvm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FileNvm")
            .field("path", &self.path)
            .field("capacity", &self.image.len())
            .field("seq", &self.seq)
            .field("journal_len", &self.journal_len)
            .field("journal_state", &self.journal_state)
            .finish_non_exhaustive()
    }
}

impl FileNvm {
    /// Opens the EEPROM stored at `path` (and `path.journal`), creating it erased if absent, with default
    /// [`Options`]. See [`FileNvm::open_with`].
    pub fn open(path: impl AsRef<Path>, capacity: usize) -> Result<FileNvm, NvmError> {
        FileNvm::open_with(path, capacity, Options::default())
    }

    /// Opens the EEPROM stored at `path` (and `path.journal`), creating it erased if absent.
    ///
    /// Recovers from any earlier crash (see [`FileNvm::recovery`]). Fails with [`NvmError::NotAnEeprom`] on a file
    /// that is not ours, [`NvmError::Locked`] if the EEPROM is already open, [`NvmError::TooLarge`] if it holds more
    /// than `capacity` bytes. A capacity above 4 GiB is an [`NvmError::Io`] error of kind `InvalidInput`.
    pub fn open_with(path: impl AsRef<Path>, capacity: usize, options: Options) -> Result<FileNvm, NvmError> {
        let path = path.as_ref().to_path_buf();
        let journal_path = sibling(&path, ".journal");
        let tmp_path = sibling(&path, ".tmp");
        if u32::try_from(capacity).is_err() {
            let e = io::Error::new(io::ErrorKind::InvalidInput, "EEPROM capacity above 4 GiB");
            return Err(io_error(&path, e));
        }

        // Refuse a foreign file before creating or locking anything next to it.
        if let Some(prefix) = read_prefix(&path, format::SNAPSHOT_MAGIC.len())? {
            if prefix != format::SNAPSHOT_MAGIC {
                return Err(NvmError::NotAnEeprom { path });
            }
        }
        let mut journal = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(&journal_path)
            .map_err(|e| io_error(&journal_path, e))?;
        match journal.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => return Err(NvmError::Locked { path }),
            Err(TryLockError::Error(e)) => return Err(io_error(&journal_path, e)),
        }

        // Under the lock, nobody else changes the files: read them for good, and clear a dead compaction's leftover.
        let snapshot = read_if_present(&path)?;
        let mut jbytes = Vec::new();
        journal.read_to_end(&mut jbytes).map_err(|e| io_error(&journal_path, e))?;
        let leftover_temp = match fs::remove_file(&tmp_path) {
            Ok(()) => true,
            Err(e) if e.kind() == io::ErrorKind::NotFound => false,
            Err(e) => return Err(io_error(&tmp_path, e)),
        };

        let (mut image, snapshot_seq, stored) = match &snapshot {
            Some(bytes) => format::parse_snapshot(&path, bytes)?,
            None => (Vec::new(), 0, 0),
        };
        if stored > capacity {
            return Err(NvmError::TooLarge { path, stored, capacity });
        }
        image.resize(capacity, ERASED);

        let mut recovery = Recovery { leftover_temp, ..Recovery::default() };
        let mut seq = snapshot_seq;
        let mut journal_state = JournalState::Clean;
        let mut valid_len = jbytes.len();
        match format::parse_journal_header(&journal_path, &jbytes)? {
            // Brand new, or a crash during a journal reset: the snapshot has everything.
            None => {
                journal_state = JournalState::Stale;
                recovery.stale_journal = snapshot.is_some();
            }
            Some(base) if base < snapshot_seq => {
                journal_state = JournalState::Stale;
                recovery.stale_journal = true;
            }
            Some(base) if base > snapshot_seq => {
                let reason = format!("journal continues write {base}, snapshot holds only up to write {snapshot_seq}");
                return Err(NvmError::Corrupt { path: journal_path, reason });
            }
            Some(_) if snapshot.is_none() && jbytes.len() > format::JOURNAL_HEADER_LEN => {
                let reason = "journal records without a snapshot (was the snapshot deleted?)".to_string();
                return Err(NvmError::Corrupt { path: journal_path, reason });
            }
            Some(_) => {
                let mut pos = format::JOURNAL_HEADER_LEN;
                while let Some(rec) = format::parse_record(&jbytes[pos..], seq + 1) {
                    let Ok(r) = range(rec.offset, rec.data.len(), stored) else {
                        let reason = format!(
                            "record {} writes {} bytes at {} past the capacity {stored}",
                            seq + 1,
                            rec.data.len(),
                            rec.offset
                        );
                        return Err(NvmError::Corrupt { path: journal_path, reason });
                    };
                    image[r].copy_from_slice(rec.data);
                    seq += 1;
                    pos += rec.total_len;
                    recovery.replayed += 1;
                }
                valid_len = pos;
                recovery.discarded_bytes = (jbytes.len() - pos) as u64;
            }
        }

        let mut nvm = FileNvm {
            path,
            journal_path,
            tmp_path,
            journal,
            image,
            seq,
            journal_len: valid_len as u64,
            journal_state,
            compact_after: options.compact_after_for(capacity) as u64,
            sync_writes: options.sync_writes,
            recovery,
            compactions: 0,
        };
        if recovery.discarded_bytes > 0 {
            // Cut the torn tail so that new records follow the last good one.
            nvm.journal_state = JournalState::Dirty;
            nvm.truncate_journal()?;
            nvm.journal.sync_data().map_err(|e| io_error(&nvm.journal_path, e))?;
        }
        if snapshot.is_none() || stored != capacity || nvm.journal_len > nvm.compact_after {
            nvm.compact()?;
        } else if nvm.journal_state == JournalState::Stale {
            nvm.reset_journal()?;
        }
        Ok(nvm)
    }

    /// The snapshot file; the journal is [`FileNvm::journal_path`].
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The journal file: the snapshot's path with `.journal` appended.
    pub fn journal_path(&self) -> &Path {
        &self.journal_path
    }

    /// The whole contents.
    pub fn image(&self) -> &[u8] {
        &self.image
    }

    /// What opening found and repaired.
    pub fn recovery(&self) -> Recovery {
        self.recovery
    }

    /// How many compactions this handle has done (opening may do one).
    pub fn compactions(&self) -> u64 {
        self.compactions
    }

    /// Makes every completed write durable against power loss (`fdatasync` of the journal).
    pub fn sync(&mut self) -> Result<(), NvmError> {
        if self.journal_state == JournalState::Stale {
            self.reset_journal()?;
        }
        self.journal.sync_data().map_err(|e| io_error(&self.journal_path, e))
    }

    /// Folds the journal into the snapshot now, and leaves an empty journal. Everything written so far is then
    /// durable against power loss.
    ///
    /// Writes compact on their own when the journal grows past [`Options::compact_after`]; call this to start
    /// from a short journal, at shutdown for instance.
    pub fn compact(&mut self) -> Result<(), NvmError> {
        let header = format::snapshot_header(self.image.len() as u32, self.seq, format::crc32(&self.image));
        let written = (|| {
            let mut tmp = File::create(&self.tmp_path)?;
            tmp.write_all(&[&header[..], &self.image].concat())?;
            tmp.sync_all()?;
            fs::rename(&self.tmp_path, &self.path)
        })();
        if let Err(e) = written {
            let _ = fs::remove_file(&self.tmp_path);
            return Err(io_error(&self.tmp_path, e));
        }
        // The snapshot now holds every write: the journal must not be appended to before its reset.
        self.journal_state = JournalState::Stale;
        self.compactions += 1;
        sync_dir(&self.path)?;
        self.reset_journal()
    }

    /// Empties the journal and writes a header continuing the current snapshot (whose sequence number is `seq`).
    fn reset_journal(&mut self) -> Result<(), NvmError> {
        let header = format::journal_header(self.seq);
        let reset = (|| {
            self.journal.set_len(0)?;
            self.journal.write_all(&header)?;
            self.journal.sync_data()
        })();
        reset.map_err(|e| io_error(&self.journal_path, e))?;
        self.journal_len = header.len() as u64;
        self.journal_state = JournalState::Clean;
        Ok(())
    }

    /// Cuts whatever follows the last good record.
    fn truncate_journal(&mut self) -> Result<(), NvmError> {
        self.journal.set_len(self.journal_len).map_err(|e| io_error(&self.journal_path, e))?;
        self.journal_state = JournalState::Clean;
        Ok(())
    }

    /// Brings the journal into a state where a record of `record_len` bytes can be appended.
    fn prepare_append(&mut self, record_len: u64) -> Result<(), NvmError> {
        match self.journal_state {
            JournalState::Clean => {}
            JournalState::Dirty => self.truncate_journal()?,
            JournalState::Stale => self.reset_journal()?,
        }
        let has_records = self.journal_len > format::JOURNAL_HEADER_LEN as u64;
        if has_records && self.journal_len + record_len > self.compact_after {
            self.compact()?;
        }
        Ok(())
    }
}

impl Nvm for FileNvm {
    type Error = NvmError;

    fn capacity(&self) -> usize {
        self.image.len()
    }

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), NvmError> {
        let r = range(offset, buf.len(), self.image.len())?;
        buf.copy_from_slice(&self.image[r]);
        Ok(())
    }

    /// Appends one journal record with a single `write(2)`, then updates the image.
    ///
    /// On an error nothing is applied and a later open does not see the data, with one exception: with
    /// [`Options::sync_writes`], a failed `fsync` after a complete append is reported but the write is applied
    /// (its durability against power loss is then unknown).
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), NvmError> {
        let r = range(offset, data.len(), self.image.len())?;
        if data.is_empty() {
            return Ok(());
        }
        let record = format::record(self.seq + 1, offset as u32, data);
        self.prepare_append(record.len() as u64)?;
        if let Err(e) = self.journal.write_all(&record) {
            self.journal_state = JournalState::Dirty;
            let _ = self.truncate_journal();
            return Err(io_error(&self.journal_path, e));
        }
        self.seq += 1;
        self.journal_len += record.len() as u64;
        self.image[r].copy_from_slice(data);
        if self.sync_writes {
            self.journal.sync_data().map_err(|e| io_error(&self.journal_path, e))?;
        }
        Ok(())
    }
}

fn io_error(path: &Path, source: io::Error) -> NvmError {
    NvmError::Io { path: path.to_path_buf(), source }
}

/// `path` with `suffix` appended to its file name.
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.as_os_str().to_os_string();
    name.push(suffix);
    PathBuf::from(name)
}

/// The file's contents, or `None` if it is absent or empty.
fn read_if_present(path: &Path) -> Result<Option<Vec<u8>>, NvmError> {
    match fs::read(path) {
        Ok(bytes) if bytes.is_empty() => Ok(None),
        Ok(bytes) => Ok(Some(bytes)),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_error(path, e)),
    }
}

/// The first `n` bytes of the file (fewer if it is shorter), or `None` if it is absent or empty.
fn read_prefix(path: &Path, n: usize) -> Result<Option<Vec<u8>>, NvmError> {
    let mut prefix = Vec::with_capacity(n);
    match File::open(path).and_then(|f| f.take(n as u64).read_to_end(&mut prefix)) {
        Ok(0) => Ok(None),
        Ok(_) => Ok(Some(prefix)),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_error(path, e)),
    }
}

/// Makes a rename in the directory holding `path` durable.
fn sync_dir(path: &Path) -> Result<(), NvmError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    File::open(dir).and_then(|d| d.sync_all()).map_err(|e| io_error(dir, e))
}

/// Byte layouts of the snapshot, the journal header and the journal records (see the module docs).
mod format {
    use super::{NvmError, FORMAT_VERSION};
    use std::path::Path;

    pub const SNAPSHOT_MAGIC: &[u8; 8] = b"OTMCL-EE";
    pub const JOURNAL_MAGIC: &[u8; 8] = b"OTMCL-JL";
    pub const RECORD_MAGIC: &[u8; 4] = b"OTRC";
    pub const SNAPSHOT_HEADER_LEN: usize = 32;
    pub const JOURNAL_HEADER_LEN: usize = 24;
    pub const RECORD_OVERHEAD: usize = 24;

    /// Byte ranges of the fields.
    mod field {
        use core::ops::Range;

        pub const MAGIC: Range<usize> = 0..8;
        pub const VERSION: Range<usize> = 8..10;
        pub const RESERVED: Range<usize> = 10..12;

        pub const SNAP_CAPACITY: Range<usize> = 12..16;
        pub const SNAP_SEQ: Range<usize> = 16..24;
        pub const SNAP_IMAGE_CRC: Range<usize> = 24..28;
        pub const SNAP_HEADER_CRC: Range<usize> = 28..32;

        pub const JNL_BASE_SEQ: Range<usize> = 12..20;
        pub const JNL_HEADER_CRC: Range<usize> = 20..24;

        pub const REC_MAGIC: Range<usize> = 0..4;
        pub const REC_SEQ: Range<usize> = 4..12;
        pub const REC_OFFSET: Range<usize> = 12..16;
        pub const REC_LEN: Range<usize> = 16..20;
        pub const REC_DATA: usize = 20;
    }

    fn u16_at(b: &[u8], r: core::ops::Range<usize>) -> u16 {
        u16::from_le_bytes(b[r].try_into().unwrap_or_default())
    }

    fn u32_at(b: &[u8], r: core::ops::Range<usize>) -> u32 {
        u32::from_le_bytes(b[r].try_into().unwrap_or_default())
    }

    fn u64_at(b: &[u8], r: core::ops::Range<usize>) -> u64 {
        u64::from_le_bytes(b[r].try_into().unwrap_or_default())
    }

    fn corrupt(path: &Path, reason: &str) -> NvmError {
        NvmError::Corrupt { path: path.to_path_buf(), reason: reason.to_string() }
    }

    pub fn snapshot_header(capacity: u32, seq: u64, image_crc: u32) -> [u8; SNAPSHOT_HEADER_LEN] {
        let mut h = [0; SNAPSHOT_HEADER_LEN];
        h[field::MAGIC].copy_from_slice(SNAPSHOT_MAGIC);
        h[field::VERSION].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
        h[field::SNAP_CAPACITY].copy_from_slice(&capacity.to_le_bytes());
        h[field::SNAP_SEQ].copy_from_slice(&seq.to_le_bytes());
        h[field::SNAP_IMAGE_CRC].copy_from_slice(&image_crc.to_le_bytes());
        let crc = crc32(&h[..field::SNAP_HEADER_CRC.start]);
        h[field::SNAP_HEADER_CRC].copy_from_slice(&crc.to_le_bytes());
        h
    }

    /// Checks a snapshot whose magic is ours; returns its image, sequence number and capacity.
    pub fn parse_snapshot(path: &Path, b: &[u8]) -> Result<(Vec<u8>, u64, usize), NvmError> {
        if b.len() < SNAPSHOT_HEADER_LEN {
            return Err(corrupt(path, "snapshot shorter than its header"));
        }
        let version = u16_at(b, field::VERSION);
        if version != FORMAT_VERSION {
            return Err(NvmError::UnsupportedVersion { path: path.to_path_buf(), version });
        }
        if crc32(&b[..field::SNAP_HEADER_CRC.start]) != u32_at(b, field::SNAP_HEADER_CRC) {
            return Err(corrupt(path, "snapshot header checksum mismatch"));
        }
        if u16_at(b, field::RESERVED) != 0 {
            return Err(corrupt(path, "reserved snapshot header bytes are not zero"));
        }
        let capacity = u32_at(b, field::SNAP_CAPACITY) as usize;
        let image = &b[SNAPSHOT_HEADER_LEN..];
        if image.len() != capacity {
            let reason = format!("snapshot image is {} bytes, its header says {capacity}", image.len());
            return Err(NvmError::Corrupt { path: path.to_path_buf(), reason });
        }
        if crc32(image) != u32_at(b, field::SNAP_IMAGE_CRC) {
            return Err(corrupt(path, "snapshot image checksum mismatch"));
        }
        Ok((image.to_vec(), u64_at(b, field::SNAP_SEQ), capacity))
    }

    pub fn journal_header(base_seq: u64) -> [u8; JOURNAL_HEADER_LEN] {
        let mut h = [0; JOURNAL_HEADER_LEN];
        h[field::MAGIC].copy_from_slice(JOURNAL_MAGIC);
        h[field::VERSION].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
        h[field::JNL_BASE_SEQ].copy_from_slice(&base_seq.to_le_bytes());
        let crc = crc32(&h[..field::JNL_HEADER_CRC.start]);
        h[field::JNL_HEADER_CRC].copy_from_slice(&crc.to_le_bytes());
        h
    }

    /// The journal's base sequence number, or `None` if the journal is shorter than its header or its header is
    /// all zeros (new, or cut during a reset; a file system may expose zeros after a power loss).
    pub fn parse_journal_header(path: &Path, b: &[u8]) -> Result<Option<u64>, NvmError> {
        if b.len() >= JOURNAL_HEADER_LEN && b[..JOURNAL_HEADER_LEN].iter().all(|&x| x == 0) {
            return Ok(None);
        }
        if b.len() < JOURNAL_HEADER_LEN {
            let prefix = &b[..b.len().min(JOURNAL_MAGIC.len())];
            if !JOURNAL_MAGIC.starts_with(prefix) {
                return Err(NvmError::NotAnEeprom { path: path.to_path_buf() });
            }
            return Ok(None);
        }
        if &b[field::MAGIC] != JOURNAL_MAGIC {
            return Err(NvmError::NotAnEeprom { path: path.to_path_buf() });
        }
        let version = u16_at(b, field::VERSION);
        if version != FORMAT_VERSION {
            return Err(NvmError::UnsupportedVersion { path: path.to_path_buf(), version });
        }
        if crc32(&b[..field::JNL_HEADER_CRC.start]) != u32_at(b, field::JNL_HEADER_CRC) {
            return Err(corrupt(path, "journal header checksum mismatch"));
        }
        Ok(Some(u64_at(b, field::JNL_BASE_SEQ)))
    }

    pub fn record(seq: u64, offset: u32, data: &[u8]) -> Vec<u8> {
        let mut r = vec![0; RECORD_OVERHEAD + data.len()];
        r[field::REC_MAGIC].copy_from_slice(RECORD_MAGIC);
        r[field::REC_SEQ].copy_from_slice(&seq.to_le_bytes());
        r[field::REC_OFFSET].copy_from_slice(&offset.to_le_bytes());
        r[field::REC_LEN].copy_from_slice(&(data.len() as u32).to_le_bytes());
        let end = field::REC_DATA + data.len();
        r[field::REC_DATA..end].copy_from_slice(data);
        let crc = crc32(&r[..end]);
        r[end..].copy_from_slice(&crc.to_le_bytes());
        r
    }

    /// A record that parsed and checked.
    pub struct Record<'a> {
        pub offset: usize,
        pub data: &'a [u8],
        pub total_len: usize,
    }

    /// The record at the start of `b` if it is complete, checks, and has sequence number `seq`; never panics.
    pub fn parse_record(b: &[u8], seq: u64) -> Option<Record<'_>> {
        if b.len() < RECORD_OVERHEAD || &b[field::REC_MAGIC] != RECORD_MAGIC || u64_at(b, field::REC_SEQ) != seq {
            return None;
        }
        let len = u32_at(b, field::REC_LEN) as usize;
        let end = field::REC_DATA.checked_add(len)?;
        let total_len = end.checked_add(4)?;
        if b.len() < total_len || crc32(&b[..end]) != u32_at(b, end..total_len) {
            return None;
        }
        Some(Record { offset: u32_at(b, field::REC_OFFSET) as usize, data: &b[field::REC_DATA..end], total_len })
    }

    const CRC_TABLE: [u32; 256] = {
        let mut table = [0u32; 256];
        let mut i = 0;
        while i < 256 {
            let mut c = i as u32;
            let mut k = 0;
            while k < 8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
                k += 1;
            }
            table[i] = c;
            i += 1;
        }
        table
    };

    /// CRC-32 (IEEE 802.3, reflected, as zlib's `crc32`).
    pub fn crc32(data: &[u8]) -> u32 {
        !data.iter().fold(!0u32, |c, &b| CRC_TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8))
    }

    #[cfg(test)]
    mod tests {
        #[test]
        fn crc32_check_value() {
            // The standard check value of CRC-32/ISO-HDLC (the catalogue of parametrised CRC algorithms).
            assert_eq!(super::crc32(b"123456789"), 0xCBF4_3926);
        }
    }
}

#[cfg(test)]
mod tests;

//! Unit tests of the EEPROM backends. The `kill -9` test and the model-based proptest are in `tests/`.

use super::format::{self, JOURNAL_HEADER_LEN, RECORD_OVERHEAD};
use super::*;
use tempfile::TempDir;

const CAP: usize = 256;

fn dir() -> TempDir {
    tempfile::tempdir().expect("temp dir")
}

fn read_all(nvm: &mut impl Nvm<Error = NvmError>) -> Vec<u8> {
    let mut buf = vec![0; nvm.capacity()];
    nvm.read(0, &mut buf).expect("read");
    buf
}

fn journal_len(path: &Path) -> u64 {
    fs::metadata(sibling(path, ".journal")).expect("journal").len()
}

#[test]
fn mem_starts_erased_and_reads_back_writes() {
    let mut nvm = MemNvm::new(CAP);
    assert_eq!(nvm.capacity(), CAP);
    assert_eq!(read_all(&mut nvm), vec![ERASED; CAP]);
    nvm.write(10, &[1, 2, 3]).unwrap();
    let mut buf = [0; 5];
    nvm.read(9, &mut buf).unwrap();
    assert_eq!(buf, [ERASED, 1, 2, 3, ERASED]);
    assert_eq!(&nvm.image()[10..13], &[1, 2, 3]);
}

#[test]
fn mem_out_of_range_is_an_error_and_changes_nothing() {
    let mut nvm = MemNvm::new(CAP);
    let mut buf = [0; 4];
    assert!(matches!(nvm.read(CAP - 3, &mut buf), Err(NvmError::OutOfRange { offset: 253, len: 4, capacity: CAP })));
    assert!(matches!(nvm.write(CAP, &[0]), Err(NvmError::OutOfRange { .. })));
    assert!(matches!(nvm.write(usize::MAX, &[0, 0]), Err(NvmError::OutOfRange { .. })));
    assert!(matches!(nvm.read(usize::MAX, &mut buf), Err(NvmError::OutOfRange { .. })));
    nvm.write(CAP, &[]).unwrap();
    nvm.read(CAP - 4, &mut buf).unwrap();
    assert_eq!(read_all(&mut nvm), vec![ERASED; CAP]);
}

#[test]
fn file_starts_erased_and_creates_both_files() {
    let d = dir();
    let path = d.path().join("eeprom.bin");
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    assert_eq!(nvm.path(), path);
    assert_eq!(nvm.journal_path(), d.path().join("eeprom.bin.journal"));
    assert_eq!(nvm.capacity(), CAP);
    assert_eq!(read_all(&mut nvm), vec![ERASED; CAP]);
    assert_eq!(fs::metadata(&path).unwrap().len(), (format::SNAPSHOT_HEADER_LEN + CAP) as u64);
    assert_eq!(journal_len(&path), JOURNAL_HEADER_LEN as u64);
    assert!(fs::read(&path).unwrap().starts_with(b"OTMCL-EE"));
}

#[test]
fn file_reopen_sees_writes() {
    let d = dir();
    let path = d.path().join("e");
    {
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        nvm.write(0, &[0xAA; 8]).unwrap();
        nvm.write(4, &[1, 2]).unwrap();
        nvm.write(CAP - 1, &[7]).unwrap();
        assert_eq!(journal_len(&path), (JOURNAL_HEADER_LEN + 3 * RECORD_OVERHEAD + 11) as u64);
    }
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    assert_eq!(nvm.recovery(), Recovery { replayed: 3, ..Recovery::default() });
    let mut want = vec![ERASED; CAP];
    want[..8].fill(0xAA);
    want[4..6].copy_from_slice(&[1, 2]);
    want[CAP - 1] = 7;
    assert_eq!(read_all(&mut nvm), want);
}

#[test]
fn file_out_of_range_is_an_error_and_writes_nothing() {
    let d = dir();
    let path = d.path().join("e");
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    assert!(matches!(nvm.write(CAP - 1, &[1, 2]), Err(NvmError::OutOfRange { offset: 255, len: 2, capacity: CAP })));
    assert!(matches!(nvm.write(usize::MAX, &[1]), Err(NvmError::OutOfRange { .. })));
    assert!(matches!(nvm.read(CAP, &mut [0]), Err(NvmError::OutOfRange { .. })));
    nvm.write(3, &[]).unwrap();
    assert_eq!(journal_len(&path), JOURNAL_HEADER_LEN as u64);
}

/// Cuts the journal at every byte of its last record: a reopen sees the old value or the new one, never a mix.
#[test]
fn file_torn_tail_at_every_byte_is_old_or_new() {
    let d = dir();
    let path = d.path().join("e");
    let (old, new) = ([0x11; 16], [0x22; 16]);
    {
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        nvm.write(40, &old).unwrap();
    }
    let start = journal_len(&path);
    {
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        nvm.write(40, &new).unwrap();
    }
    let end = journal_len(&path);
    assert_eq!(end - start, (RECORD_OVERHEAD + 16) as u64);
    let snapshot = fs::read(&path).unwrap();
    let journal = fs::read(sibling(&path, ".journal")).unwrap();
    for cut in start..=end {
        let case = d.path().join(format!("cut{cut}"));
        fs::write(&case, &snapshot).unwrap();
        fs::write(sibling(&case, ".journal"), &journal[..cut as usize]).unwrap();
        let mut nvm = FileNvm::open(&case, CAP).unwrap();
        let mut buf = [0; 16];
        nvm.read(40, &mut buf).unwrap();
        let want = if cut == end { new } else { old };
        assert_eq!(buf, want, "journal cut at byte {cut}");
        let discarded = if cut == end { 0 } else { cut - start };
        assert_eq!(nvm.recovery().discarded_bytes, discarded, "cut at {cut}");
        // The torn tail is gone: a new write lands after the last good record and survives.
        nvm.write(0, &[cut as u8]).unwrap();
        drop(nvm);
        let mut nvm = FileNvm::open(&case, CAP).unwrap();
        assert_eq!(nvm.recovery().discarded_bytes, 0);
        let mut buf = [0; 1];
        nvm.read(0, &mut buf).unwrap();
        assert_eq!(buf, [cut as u8]);
    }
}

/// A bit flip anywhere in a record stops the replay at that record; later records are dropped with it.
#[test]
fn file_bit_flip_stops_replay_at_that_record() {
    let d = dir();
    let path = d.path().join("e");
    {
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        for i in 0..3u8 {
            nvm.write(usize::from(i) * 8, &[i + 1; 8]).unwrap();
        }
    }
    let snapshot = fs::read(&path).unwrap();
    let journal = fs::read(sibling(&path, ".journal")).unwrap();
    let second = JOURNAL_HEADER_LEN + RECORD_OVERHEAD + 8;
    for byte in second..second + RECORD_OVERHEAD + 8 {
        for bit in [0, 7] {
            let case = d.path().join(format!("flip{byte}.{bit}"));
            let mut damaged = journal.clone();
            damaged[byte] ^= 1 << bit;
            fs::write(&case, &snapshot).unwrap();
            fs::write(sibling(&case, ".journal"), &damaged).unwrap();
            let mut nvm = FileNvm::open(&case, CAP).unwrap();
            let image = read_all(&mut nvm);
            assert_eq!(&image[..8], &[1; 8], "flip at {byte}.{bit}");
            assert_eq!(&image[8..24], &[ERASED; 16], "flip at {byte}.{bit}");
            assert_eq!(nvm.recovery().replayed, 1);
            assert_eq!(journal_len(&case), second as u64);
        }
    }
}

#[test]
fn file_compaction_preserves_data() {
    let d = dir();
    let path = d.path().join("e");
    let mut model = vec![ERASED; CAP];
    let options = Options { compact_after: Some(300), ..Options::default() };
    {
        let mut nvm = FileNvm::open_with(&path, CAP, options).unwrap();
        let created = nvm.compactions();
        for i in 0..100usize {
            let offset = (i * 37) % (CAP - 10);
            let data = [i as u8; 10];
            nvm.write(offset, &data).unwrap();
            model[offset..offset + 10].copy_from_slice(&data);
            assert!(journal_len(&path) <= 300);
        }
        assert!(nvm.compactions() - created >= 10, "compactions: {}", nvm.compactions());
        assert_eq!(nvm.image(), &model[..]);
    }
    let mut nvm = FileNvm::open_with(&path, CAP, options).unwrap();
    assert_eq!(read_all(&mut nvm), model);
    nvm.compact().unwrap();
    assert_eq!(journal_len(&path), JOURNAL_HEADER_LEN as u64);
    drop(nvm);
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    assert_eq!(nvm.recovery().replayed, 0);
    assert_eq!(read_all(&mut nvm), model);
}

/// A crash after a compaction's rename and before the journal reset leaves a journal older than the snapshot.
#[test]
fn file_stale_journal_is_ignored() {
    let d = dir();
    let path = d.path().join("e");
    let jpath = sibling(&path, ".journal");
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    nvm.write(0, &[1; 4]).unwrap();
    let old_journal = fs::read(&jpath).unwrap();
    nvm.write(0, &[2; 4]).unwrap();
    nvm.compact().unwrap();
    drop(nvm);
    fs::write(&jpath, &old_journal).unwrap();
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    assert!(nvm.recovery().stale_journal);
    assert_eq!(&read_all(&mut nvm)[..5], &[2, 2, 2, 2, ERASED]);
    assert_eq!(journal_len(&path), JOURNAL_HEADER_LEN as u64);
}

/// Crashes inside a compaction: a half-written temp file, a journal emptied but without its header.
#[test]
fn file_interrupted_compaction_leftovers_are_cleaned() {
    let d = dir();
    let path = d.path().join("e");
    {
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        nvm.write(8, &[5; 4]).unwrap();
    }
    fs::write(sibling(&path, ".tmp"), b"OTMCL-EE half a snapshot").unwrap();
    {
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        assert!(!sibling(&path, ".tmp").exists());
        assert!(nvm.recovery().leftover_temp);
        assert_eq!(&read_all(&mut nvm)[8..12], &[5; 4]);
        nvm.compact().unwrap();
    }
    for torn_header in [&b""[..], &b"OTMCL-J"[..], &[0; 40][..]] {
        fs::write(sibling(&path, ".journal"), torn_header).unwrap();
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        assert!(nvm.recovery().stale_journal);
        assert_eq!(&read_all(&mut nvm)[8..12], &[5; 4]);
        nvm.write(0, &[9]).unwrap();
        drop(nvm);
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        assert_eq!(&read_all(&mut nvm)[..1], &[9]);
    }
}

#[test]
fn file_foreign_file_is_refused_and_left_alone() {
    let d = dir();
    let path = d.path().join("notes.txt");
    fs::write(&path, b"my precious notes").unwrap();
    let err = FileNvm::open(&path, CAP).unwrap_err();
    assert!(matches!(&err, NvmError::NotAnEeprom { path: p } if *p == path), "{err}");
    assert!(err.to_string().contains("not an OpenTMCL EEPROM"), "{err}");
    assert_eq!(fs::read(&path).unwrap(), b"my precious notes");
    assert!(!sibling(&path, ".journal").exists());

    let path = d.path().join("e");
    drop(FileNvm::open(&path, CAP).unwrap());
    fs::write(sibling(&path, ".journal"), b"something else entirely").unwrap();
    let err = FileNvm::open(&path, CAP).unwrap_err();
    assert!(matches!(err, NvmError::NotAnEeprom { .. }), "{err}");
    assert_eq!(fs::read(sibling(&path, ".journal")).unwrap(), b"something else entirely");
}

#[test]
fn file_empty_file_counts_as_new() {
    let d = dir();
    let path = d.path().join("e");
    fs::write(&path, b"").unwrap();
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    assert_eq!(read_all(&mut nvm), vec![ERASED; CAP]);
}

#[test]
fn file_damaged_snapshot_is_corrupt() {
    let d = dir();
    let path = d.path().join("e");
    drop(FileNvm::open(&path, CAP).unwrap());
    let good = fs::read(&path).unwrap();
    for byte in [12, 20, 40] {
        let mut bad = good.clone();
        bad[byte] ^= 4;
        fs::write(&path, &bad).unwrap();
        let err = FileNvm::open(&path, CAP).unwrap_err();
        assert!(matches!(err, NvmError::Corrupt { .. }), "byte {byte}: {err}");
    }
    let mut bad = good.clone();
    bad[8] = 2;
    fs::write(&path, &bad).unwrap();
    assert!(matches!(FileNvm::open(&path, CAP), Err(NvmError::UnsupportedVersion { version: 2, .. })));
}

#[test]
fn file_journal_without_snapshot_is_corrupt() {
    let d = dir();
    let path = d.path().join("e");
    {
        let mut nvm = FileNvm::open(&path, CAP).unwrap();
        nvm.write(0, &[1]).unwrap();
    }
    fs::remove_file(&path).unwrap();
    assert!(matches!(FileNvm::open(&path, CAP), Err(NvmError::Corrupt { .. })));
}

#[test]
fn file_smaller_snapshot_is_extended_larger_is_refused() {
    let d = dir();
    let path = d.path().join("e");
    {
        let mut nvm = FileNvm::open(&path, 64).unwrap();
        nvm.write(60, &[1, 2, 3, 4]).unwrap();
    }
    {
        let mut nvm = FileNvm::open(&path, 128).unwrap();
        let image = read_all(&mut nvm);
        assert_eq!(&image[60..64], &[1, 2, 3, 4]);
        assert_eq!(&image[64..], &[ERASED; 64]);
        nvm.write(120, &[8; 8]).unwrap();
    }
    let err = FileNvm::open(&path, 64).unwrap_err();
    assert!(matches!(err, NvmError::TooLarge { stored: 128, capacity: 64, .. }), "{err}");
    let mut nvm = FileNvm::open(&path, 128).unwrap();
    assert_eq!(&read_all(&mut nvm)[120..], &[8; 8]);
}

#[test]
fn file_second_open_is_locked_out() {
    let d = dir();
    let path = d.path().join("e");
    let mut first = FileNvm::open(&path, CAP).unwrap();
    first.write(0, &[3]).unwrap();
    let err = FileNvm::open(&path, CAP).unwrap_err();
    assert!(matches!(&err, NvmError::Locked { path: p } if *p == path), "{err}");
    assert!(err.to_string().contains("in use"), "{err}");
    drop(first);
    let mut second = FileNvm::open(&path, CAP).unwrap();
    assert_eq!(&read_all(&mut second)[..1], &[3]);
}

#[test]
fn file_sync_writes_and_sync() {
    let d = dir();
    let path = d.path().join("e");
    let mut nvm = FileNvm::open_with(&path, CAP, Options { sync_writes: true, ..Options::default() }).unwrap();
    nvm.write(1, &[4, 5]).unwrap();
    nvm.sync().unwrap();
    drop(nvm);
    let mut nvm = FileNvm::open(&path, CAP).unwrap();
    assert_eq!(&read_all(&mut nvm)[..3], &[ERASED, 4, 5]);
}

#[test]
fn default_compaction_bound() {
    assert_eq!(Options::default().compact_after_for(2048), 64 * 1024);
    assert_eq!(Options::default().compact_after_for(64 * 1024), 256 * 1024);
    assert_eq!(Options { compact_after: Some(100), ..Options::default() }.compact_after_for(2048), 100);
}

/// Record layout, byte for byte (module docs, "On-disk format, version 1").
#[test]
fn record_layout() {
    let r = format::record(0x0102, 0x30, &[0xDE, 0xAD]);
    assert_eq!(&r[..20], b"OTRC\x02\x01\0\0\0\0\0\0\x30\0\0\0\x02\0\0\0");
    assert_eq!(&r[20..22], &[0xDE, 0xAD]);
    assert_eq!(u32::from_le_bytes(r[22..26].try_into().unwrap()), format::crc32(&r[..22]));
    let rec = format::parse_record(&r, 0x0102).expect("parses");
    assert_eq!((rec.offset, rec.data, rec.total_len), (0x30, &[0xDE, 0xAD][..], 26));
    assert!(format::parse_record(&r, 0x0103).is_none());
    assert!(format::parse_record(&r[..25], 0x0102).is_none());
}

#[test]
fn mem_nvm_takes_memory_only_for_written_pages() {
    let mut nvm = MemNvm::new(17_408);
    assert_eq!(nvm.pages_in_use(), 0, "erased: nothing kept");
    // Erased bytes written keep nothing either.
    nvm.write(1000, &[ERASED; 600]).unwrap();
    assert_eq!(nvm.pages_in_use(), 0);
    // A write across a page boundary, read back whole and in pieces.
    let data: Vec<u8> = (0..20).collect();
    nvm.write(MemNvm::PAGE - 10, &data).unwrap();
    assert_eq!(nvm.pages_in_use(), 2);
    let mut back = [0u8; 24];
    nvm.read(MemNvm::PAGE - 12, &mut back).unwrap();
    assert_eq!(&back[..2], &[ERASED, ERASED]);
    assert_eq!(&back[2..22], &data[..]);
    assert_eq!(&back[22..], &[ERASED, ERASED]);
    let image = nvm.image();
    assert_eq!(image.len(), 17_408);
    assert_eq!(&image[MemNvm::PAGE - 10..MemNvm::PAGE + 10], &data[..]);
    assert_eq!(MemNvm::from_image(image), nvm, "the same contents");
    // The last, partial page.
    nvm.write(17_407, &[7]).unwrap();
    assert_eq!(nvm.image()[17_407], 7);
    assert!(nvm.write(17_407, &[7, 7]).is_err());
}

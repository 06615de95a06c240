//! `kill -9` a process that is writing a `FileNvm`, then check what a reopen sees.
//!
//! The test binary re-executes itself (`current_exe() --exact kill9_child --ignored`) with `KILL9_PATH` set; in that mode
//! `kill9_child` writes forever. Write number `c` fills block `c % BLOCKS` with eight copies of `c` as a `u64`, then
//! prints `done c`. The parent reads some lines, sends SIGKILL, drains the pipe for the last reported `c`, reopens
//! the file and checks that every block is uniform and holds exactly the latest write to it, and that the last
//! write found is the last reported one or the one after it (killed between write and print). Two rounds in three
//! use a tiny compaction bound, so that many kills land inside a compaction.

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use tmcl_core::hal::Nvm;
use tmcl_sim::{FileNvm, Options};

const BLOCK: usize = 64;
const BLOCKS: u64 = 16;
const CAPACITY: usize = BLOCK * BLOCKS as usize;
const PATH_VAR: &str = "KILL9_PATH";
const COMPACT_VAR: &str = "KILL9_COMPACT_AFTER";
const ROUNDS: usize = 21;

fn options(compact_after: Option<usize>) -> Options {
    Options { compact_after, ..Options::default() }
}

/// The write number held by each block (`None`: erased), or a panic on a block mixing two writes.
fn blocks(nvm: &mut FileNvm) -> Vec<Option<u64>> {
    (0..BLOCKS as usize)
        .map(|b| {
            let mut buf = [0; BLOCK];
            nvm.read(b * BLOCK, &mut buf).unwrap();
            let words: Vec<u64> = buf.chunks(8).map(|w| u64::from_le_bytes(w.try_into().unwrap())).collect();
            assert!(words.iter().all(|&w| w == words[0]), "block {b} mixes two writes: {words:x?}");
            (words[0] != u64::MAX).then_some(words[0])
        })
        .collect()
}

/// Child mode: write blocks until killed. Ignored, so that an ordinary test run neither runs nor counts
/// it: `kill9_during_writes_and_compactions` starts it with `--ignored`.
#[test]
#[ignore = "the child process of kill9_during_writes_and_compactions, which starts it"]
fn kill9_child() {
    let Some(path) = std::env::var_os(PATH_VAR) else { return };
    let compact_after = std::env::var(COMPACT_VAR).ok().map(|v| v.parse().unwrap());
    let mut nvm = FileNvm::open_with(Path::new(&path), CAPACITY, options(compact_after)).unwrap();
    let mut c = blocks(&mut nvm).into_iter().flatten().max().unwrap_or(0);
    let stdout = std::io::stdout();
    // Bounded so that a lost parent never leaves a child writing for ever.
    for _ in 0..5_000_000 {
        c += 1;
        nvm.write((c % BLOCKS) as usize * BLOCK, &[c.to_le_bytes(); BLOCK / 8].concat()).unwrap();
        let mut out = stdout.lock();
        writeln!(out, "done {c}").unwrap();
        out.flush().unwrap();
    }
}

#[test]
fn kill9_during_writes_and_compactions() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("eeprom.bin");
    let exe = std::env::current_exe().unwrap();
    let mut stats = [0u32; 4];
    for round in 0..ROUNDS {
        // Default bound; a compaction every other write; one before every write.
        let compact_after = [None, Some(200), Some(0)][round % 3];
        let mut cmd = Command::new(&exe);
        cmd.args(["--exact", "kill9_child", "--ignored", "--nocapture", "--test-threads=1"]).env(PATH_VAR, &path);
        match compact_after {
            Some(n) => cmd.env(COMPACT_VAR, n.to_string()),
            None => cmd.env_remove(COMPACT_VAR),
        };
        let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::null()).spawn().unwrap();
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let mut last_seen = 0u64;
        let mut seen = 0;
        let wanted = 150 + 37 * round;
        for line in lines.by_ref() {
            let line = line.unwrap();
            if let Some(n) = line.strip_prefix("done ") {
                last_seen = n.parse().unwrap();
                seen += 1;
                if seen == wanted {
                    break;
                }
            }
        }
        assert_eq!(seen, wanted, "round {round}: the child stopped early");
        // Spread the kills over the child's loop; the child keeps writing meanwhile.
        std::thread::sleep(Duration::from_micros(round as u64 * 7919 % 3000));
        child.kill().unwrap(); // SIGKILL on Unix
        child.wait().unwrap();
        // What the child managed to report before it died.
        let mut last_reported = last_seen;
        for line in lines {
            if let Some(n) = line.unwrap().strip_prefix("done ") {
                last_reported = n.parse().unwrap();
            }
        }

        let mut nvm = FileNvm::open_with(&path, CAPACITY, options(compact_after)).unwrap();
        let found = blocks(&mut nvm);
        let last = found.iter().flatten().copied().max().unwrap();
        assert!(
            last == last_reported || last == last_reported + 1,
            "round {round}: last write {last}, reported {last_reported}"
        );
        for (b, &value) in found.iter().enumerate() {
            // The latest write c <= last with c % BLOCKS == b, if any.
            let back = (last + BLOCKS - b as u64) % BLOCKS;
            let want = last.checked_sub(back).filter(|&c| c > 0);
            assert_eq!(value, want, "round {round}: block {b} lost a write (last write {last})");
        }
        let r = nvm.recovery();
        let events = [r.discarded_bytes > 0, r.leftover_temp, r.stale_journal, last == last_reported + 1];
        for (n, e) in stats.iter_mut().zip(events) {
            *n += u32::from(e);
        }
        eprintln!("round {round}: last write {last}, reported {last_reported}, recovery {r:?}");
    }
    eprintln!(
        "{ROUNDS} kills: {} torn tails cut, {} killed compactions before the rename, {} after it, \
         {} writes done but not reported",
        stats[0], stats[1], stats[2], stats[3]
    );
}

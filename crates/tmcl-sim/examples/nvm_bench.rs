//! How long one `FileNvm::write` of 4 bytes takes. Run with
//! `cargo run --release -p tmcl-sim --example nvm_bench [-- WRITES]`.
//!
//! The EEPROM lives in a temporary directory under `$TMPDIR` (or `/tmp`): its file system decides the cost of the
//! fsyncs in compactions and in `sync_writes` mode.

use std::time::{Duration, Instant};

use tmcl_core::hal::Nvm;
use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::param::persist;
use tmcl_sim::{FileNvm, MemNvm, Options};

/// The PD28-1021's real image: 17 408 bytes (header, parameter regions, 2048 program cells). Compactions
/// rewrite the whole image, so their cost depends on it.
const CAPACITY: usize = persist::capacity(&SPEC);

/// Times `writes` writes of 4 bytes at spread offsets; returns the sorted durations.
fn time_writes(nvm: &mut impl Nvm, writes: usize) -> Vec<Duration> {
    let mut times: Vec<Duration> = (0..writes)
        .map(|i| {
            let offset = (i * 4 * 97) % CAPACITY;
            let data = (i as u32).to_le_bytes();
            let start = Instant::now();
            nvm.write(offset, &data).expect("write");
            start.elapsed()
        })
        .collect();
    times.sort();
    times
}

fn report(name: &str, times: &[Duration]) {
    let pct = |p: usize| times[(times.len() - 1) * p / 100];
    let mean = times.iter().sum::<Duration>() / times.len() as u32;
    println!(
        "{name:<28} n={:<6} median {:>9.2?}  p99 {:>9.2?}  max {:>9.2?}  mean {:>9.2?}",
        times.len(),
        pct(50),
        pct(99),
        times[times.len() - 1],
        mean
    );
}

fn main() {
    let writes: usize = std::env::args().nth(1).map_or(10_000, |n| n.parse().expect("WRITES must be a number"));
    let dir = tempfile::tempdir().expect("temp dir");

    report("MemNvm", &time_writes(&mut MemNvm::new(CAPACITY), writes));

    let mut nvm = FileNvm::open(dir.path().join("default.eeprom"), CAPACITY).expect("open");
    let times = time_writes(&mut nvm, writes);
    report("FileNvm (default options)", &times);
    println!("{:<28} {} compactions (64 KiB journal bound)", "", nvm.compactions() - 1);

    let start = Instant::now();
    nvm.compact().expect("compact");
    println!("{:<28} {:.2?}", "FileNvm::compact", start.elapsed());

    let options = Options { sync_writes: true, ..Options::default() };
    let mut nvm = FileNvm::open_with(dir.path().join("synced.eeprom"), CAPACITY, options).expect("open");
    report("FileNvm (sync_writes)", &time_writes(&mut nvm, writes.min(2000)));
}

//! A session of SOEM (pysoem 1.1.13) with `tmcl serve --module tmcm-1310 --ethercat`, recorded on the
//! veth pair by `tests/python/ethercat_master.py record` (`tests/data/soem-session.txt`): `config_init`,
//! `config_map`, SAFE-OP, OP with process data, a TMCL GAP through the mailbox, back to INIT. Every
//! frame the master sent is replayed against a fresh slave at the time it was sent, and the answer must
//! be the one recorded, byte for byte. So the exact traffic of a second, independent master runs in
//! `cargo test`, without root or a network.
//!
//! Re-record after a change that alters what the slave answers (and check the difference first):
//! `unshare -n .venv/bin/python tests/python/ethercat_master.py record --tmcl target/debug/tmcl --dir
//! /tmp/rec --out crates/tmcl-ethercat/tests/data/soem-session.txt` (as root).

use tmcl_core::model::tmcm_1310::SPEC;
use tmcl_core::{Instant, Module};
use tmcl_ethercat::{AlState, NoFiles, Slave};
use tmcl_sim::SimBoard;

const SESSION: &str = include_str!("data/soem-session.txt");

fn hex(s: &str) -> Vec<u8> {
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
}

#[test]
fn soem_session_replays_byte_for_byte() {
    let mut slave = Slave::new(&SPEC).unwrap();
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    let mut answer: Option<Vec<u8>> = None;
    let (mut requests, mut checked) = (0, 0);
    let mut highest = AlState::Init;
    for (n, line) in SESSION.lines().enumerate().filter(|(_, l)| !l.starts_with('#')) {
        let mut fields = line.split(' ');
        let (t, direction, bytes) = (fields.next().unwrap(), fields.next().unwrap(), hex(fields.next().unwrap()));
        let now = Instant::from_micros(t.parse().unwrap());
        match direction {
            ">" => {
                let mut frame = bytes;
                let len = slave.process(now, &mut frame, &mut module, &mut NoFiles);
                assert_eq!(len, Some(frame.len()), "line {}: the frame is answered", n + 1);
                answer = Some(frame);
                requests += 1;
                if slave.status().state.above(highest) {
                    highest = slave.status().state;
                }
            }
            "<" => {
                let mut ours = answer.take().unwrap_or_else(|| panic!("line {}: an answer without a request", n + 1));
                let mut theirs = bytes;
                mask_driver_flags(&mut ours);
                mask_driver_flags(&mut theirs);
                assert_eq!(hex_string(&ours), hex_string(&theirs), "line {}: the answer differs", n + 1);
                checked += 1;
            }
            other => panic!("line {}: direction {other:?}", n + 1),
        }
    }
    assert!(requests > 100 && checked == requests, "{requests} requests, {checked} answers checked");
    assert_eq!(highest, AlState::Op);
    assert_eq!(slave.status().state, AlState::Init);
}

/// The driver's flags in the process image (AP 208 in bits 8..16 of the error-flags input, SOEM's LRW of
/// the whole image: 8 output bytes, then the inputs) come from the simulated driver, whose standstill
/// flag follows the board's own clock; the recording does not share that clock, so those bits are not
/// compared.
fn mask_driver_flags(frame: &mut [u8]) {
    // Ethernet 14, EtherCAT header 2, datagram header 10: an LRW (12) of 56 bytes at logical 0.
    if frame.len() >= 26 + 56 && frame[16] == 12 && frame[18..22] == [0; 4] && frame[22] == 56 {
        let flags = 26 + 8 + 4 * 8;
        frame[flags + 1] = 0;
    }
}

fn hex_string(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

//! The fuzz harnesses (`tmcl_ethercat::fuzzing`, also run by the cargo-fuzz targets `ethercat_frames`
//! and `ethercat_parsers`) as property tests, so that every `cargo test` checks them on fresh input.

use proptest::prelude::*;
use tmcl_core::model::tmcm_1310::SPEC;
use tmcl_core::{Instant, Module};
use tmcl_ethercat::fuzzing;
use tmcl_sim::SimBoard;

/// A sound EtherCAT payload of one datagram with arbitrary command, address and data: `[control |
/// 0x80, n, payload]` chunks that the harness repairs into sound frames.
fn repaired_chunks() -> impl Strategy<Value = Vec<u8>> {
    let chunk = (0u8..0x80, prop::collection::vec(any::<u8>(), 14..120)).prop_map(|(gap, payload)| {
        let mut c = vec![gap | 0x80, payload.len() as u8];
        c.extend(payload);
        c
    });
    (0u8..4, prop::collection::vec(chunk, 1..12)).prop_map(|(setup, chunks)| {
        let mut data = vec![setup];
        data.extend(chunks.concat());
        data
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn parsers_never_panic(data in prop::collection::vec(any::<u8>(), 0..600)) {
        fuzzing::parsers(&data);
    }

    #[test]
    fn arbitrary_frames_never_panic_nor_change_a_refusing_slave(data in prop::collection::vec(any::<u8>(), 0..600)) {
        let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
        fuzzing::frames(&mut module, &data);
    }

    #[test]
    fn sound_frames_with_arbitrary_datagrams_keep_their_shape(data in repaired_chunks()) {
        let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
        fuzzing::frames(&mut module, &data);
    }
}

/// Inputs the `ethercat_frames` fuzz target found crashing, kept as tests.
#[test]
fn fuzz_regressions() {
    // A BWR that activated SyncManager 8 (register 0x0846); the ESC has 8 SyncManagers, 0..7.
    let activate_sm8: &[u8] = &[
        0x20, 0xff, 0xff, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00, 0x29, 0x08, 0x20, 0xff, 0x15, 0x00, 0x00, 0x00, 0xcf,
        0xbc, 0xcd, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x03, 0x00, 0xb4, 0x9d, 0x03, 0x10, 0x40, 0x00, 0x00, 0x3d,
        0x00, 0x00, 0x5c, 0x10, 0xf6, 0x7a, 0x00, 0x2c, 0x11, 0x10, 0x00, 0x00, 0x30, 0x39, 0x30,
    ];
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    fuzzing::frames(&mut module, activate_sm8);
}

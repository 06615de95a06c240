//! The EtherCAT slave of a TMCM-1310, brought to INIT, PRE-OP, SAFE-OP or OP, fed arbitrary frames: no
//! panic, a refused frame changes nothing, an answered one keeps its shape.
#![no_main]
use tmcl_core::model::tmcm_1310::SPEC;
use tmcl_core::{Instant, Module};
use tmcl_sim::SimBoard;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let mut module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
    tmcl_ethercat::fuzzing::frames(&mut module, data);
});

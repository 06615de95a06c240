//! Event-driven against tick-by-tick: any model, world, settings, program and host commands the bytes
//! decode to give the same state, parameters, board and replies both ways (`tmcl_sim::equivalence`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(difference) = tmcl_sim::equivalence::Scenario::decode(data).check() {
        panic!("{difference}");
    }
});

//! Event-driven against tick-by-tick: any model, world, settings, program and host commands the bytes
//! decode to give the same state, parameters, board and replies both ways (`tmcl_sim::equivalence`).
//! Each scenario's time line is compressed to at most 3 000 motion ticks of all its motors together
//! (3 s of a one-motor model, 0.5 s of the TMCM-6110; `Scenario::compressed`), so that every run costs a
//! few milliseconds; the property tests run scenarios at their full length.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(difference) = tmcl_sim::equivalence::Scenario::decode(data).compressed(3_000).check() {
        panic!("{difference}");
    }
});

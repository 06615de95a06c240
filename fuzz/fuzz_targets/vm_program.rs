//! The program machine on arbitrary programs: never panics, every poll returns.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| tmcl_sim::fuzzing::program(data));

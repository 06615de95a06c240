//! The byte-fed framer and the whole module: arbitrary bytes with arbitrary gaps.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| tmcl_sim::fuzzing::module_stream(data));

//! The ASCII command line (139 mode): arbitrary lines, every addressed one answered.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| tmcl_sim::fuzzing::ascii_lines(data));

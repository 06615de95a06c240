//! One frame through the wire parser, the command decoder and the executor.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: [u8; 9]| tmcl_sim::fuzzing::one_frame(&data));

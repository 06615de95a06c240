//! The TMCM-1310's closed loop under arbitrary direct-mode commands: no panic, no step lost.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| tmcl_sim::fuzzing::closed_loop(data));

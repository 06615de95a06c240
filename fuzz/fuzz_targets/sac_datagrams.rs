//! The PDx-113's SAC with arbitrary TMC428 datagrams, mixed with arbitrary commands: statuses of the
//! manual's list only, positions within 24 bits.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| tmcl_sim::fuzzing::sac_datagrams(data));

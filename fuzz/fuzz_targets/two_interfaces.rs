//! One module serving two interfaces at once: RS485 bytes and EtherCAT mailbox messages, interleaved.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| tmcl_sim::fuzzing::two_interfaces(data));

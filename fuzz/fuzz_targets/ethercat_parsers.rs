//! Every EtherCAT wire parser (Ethernet, frame, datagrams, mailbox, FoE, SII categories) on arbitrary
//! bytes: no panic, and what parses emits back the same.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| tmcl_ethercat::fuzzing::parsers(data));

//! A virtual TMCM-1310's EtherCAT slave driven by hand-built frames, as a master's first steps are:
//! read the ESC type and the AL status (ETG.1000.4 register 0x0000 and 0x0130), give the slave a station
//! address (0x0010), request PRE-OP through AL control (0x0120) before the mailbox SyncManagers are
//! set up, and read the refusal back: the error flag in AL status and the reason in AL status code
//! (0x0134). No network: each frame is handed to `Slave::process` in memory and comes back with the
//! working counter. (`tests/ethercrab.rs` brings the slave to OP with a real master.)
//!
//! Run with `cargo run -p tmcl-ethercat --example al_states`.

use tmcl_core::model::tmcm_1310;
use tmcl_core::{Instant, Module};
use tmcl_ethercat::foe::NoFiles;
use tmcl_ethercat::fuzzing::{answers, build_frame, MAX_FRAME};
use tmcl_ethercat::register as reg;
use tmcl_ethercat::wire::datagram::Command;
use tmcl_ethercat::Slave;
use tmcl_sim::SimBoard;

/// Sends one datagram, returns the working counter and the data that came back.
fn datagram(
    slave: &mut Slave,
    module: &mut Module<SimBoard>,
    command: Command,
    address: u32,
    data: &[u8],
) -> (u16, Vec<u8>) {
    let mut frame = [0u8; MAX_FRAME];
    let n = build_frame(&mut frame, &[(command, address, data)]).expect("fits");
    slave.process(Instant::ZERO, &mut frame[..n], module, &mut NoFiles).expect("an EtherCAT frame");
    let mut out = (0, Vec::new());
    answers(&frame[..n], |_, wkc, data| out = (wkc, data.to_vec()));
    out
}

fn main() {
    let spec = &tmcm_1310::SPEC;
    let mut module = Module::new(SimBoard::in_memory_for(spec), spec, Instant::ZERO);
    let mut slave = Slave::new(spec).expect("the TMCM-1310 has EtherCAT");

    // A datagram's address: the register offset in the high 16 bits, the slave in the low 16 (its
    // position for auto-increment commands, position 0 = the first slave; its station address for
    // configured-address commands).
    let at = |slave: u16, register: u16| u32::from(slave) | (u32::from(register) << 16);
    let (wkc, esc_type) = datagram(&mut slave, &mut module, Command::Aprd, at(0, reg::TYPE), &[0; 1]);
    println!("ESC type 0x{:02X} (working counter {wkc})", esc_type[0]);
    let (_, status) = datagram(&mut slave, &mut module, Command::Aprd, at(0, reg::AL_STATUS), &[0; 2]);
    println!("AL status {:#04x} (1 = INIT)", status[0]);
    assert_eq!(status[0] & 0x0F, 1);

    // Station address 0x1001, then configured-address access.
    datagram(&mut slave, &mut module, Command::Apwr, at(0, reg::STATION_ADDRESS), &0x1001u16.to_le_bytes());
    let (wkc, _) = datagram(&mut slave, &mut module, Command::Fpwr, at(0x1001, reg::AL_CONTROL), &[2, 0]);
    let (_, status) = datagram(&mut slave, &mut module, Command::Fprd, at(0x1001, reg::AL_STATUS), &[0; 2]);
    let (_, code) = datagram(&mut slave, &mut module, Command::Fprd, at(0x1001, reg::AL_STATUS_CODE), &[0; 2]);
    let code = u16::from_le_bytes([code[0], code[1]]);
    println!("PRE-OP requested (working counter {wkc}) without mailbox SyncManagers:");
    println!("  AL status {:#04x} (INIT, error flag 0x10), AL status code {code:#06x}", status[0]);
    assert_eq!(status[0], 0x11, "refused: still INIT, with the error flag");
}

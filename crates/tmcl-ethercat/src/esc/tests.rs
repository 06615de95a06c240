//! The ESC on its own: addressing, working counters, register permissions, SyncManager handshakes and
//! FMMUs, one datagram at a time.

use super::*;
use crate::wire::datagram::Repr;

/// Runs one datagram; returns (working counter, data, ADP after).
fn run(esc: &mut Esc, command: Command, address: u32, data: &[u8]) -> (u16, Vec<u8>, u16) {
    let mut bytes = vec![0u8; 12 + data.len()];
    let mut d = Datagram::new_unchecked(&mut bytes[..]);
    Repr { command, index: 0, address, length: data.len() as u16, circulating: false, more: false, irq: 0, wkc: 0 }
        .emit(&mut d);
    d.data_mut().copy_from_slice(data);
    esc.execute(&mut d);
    (d.wkc(), d.data().to_vec(), d.adp())
}

fn at(adp: u16, ado: u16) -> u32 {
    Repr::physical(adp, ado)
}

/// SM `n` configured and enabled by the master, and switched on by the application.
fn sm(esc: &mut Esc, n: usize, start: u16, length: u16, control: u8) {
    let mut b = [0u8; 8];
    b[..2].copy_from_slice(&start.to_le_bytes());
    b[2..4].copy_from_slice(&length.to_le_bytes());
    b[4] = control;
    b[6] = 1;
    esc.ecat_write(reg::SM + 8 * n as u16, &b);
    esc.set_sm_enabled(n, true);
}

fn fmmu(esc: &mut Esc, n: usize, logical: u32, length: u16, physical: u16, kind: u8) {
    let mut b = [0u8; 16];
    b[..4].copy_from_slice(&logical.to_le_bytes());
    b[4..6].copy_from_slice(&length.to_le_bytes());
    b[7] = 7;
    b[8..10].copy_from_slice(&physical.to_le_bytes());
    b[11] = kind;
    b[12] = 1;
    esc.ecat_write(reg::FMMU + 16 * n as u16, &b);
}

#[test]
fn information_registers_and_auto_increment() {
    let mut esc = Esc::new();
    // APRD with ADP 0 hits this slave and comes back with ADP 1 (every slave increments).
    let (wkc, data, adp) = run(&mut esc, Command::Aprd, at(0, 0x0000), &[0; 8]);
    assert_eq!((wkc, adp), (1, 1));
    // Type, revision and build of an ET1100-0003.
    assert_eq!(data, [0x11, 0x00, 0x03, 0x00, FMMUS as u8, SMS as u8, 8, 0x0F]);
    // ADP 0xFFFF (the second slave) is not this one, but still incremented.
    let (wkc, _, adp) = run(&mut esc, Command::Aprd, at(0xFFFF, 0x0000), &[0; 2]);
    assert_eq!((wkc, adp), (0, 0));
    // BRD: every slave answers; its data are ORed into what came; it increments the position too
    // (ETG.1000.4), whatever the position.
    let (wkc, data, adp) = run(&mut esc, Command::Brd, at(0, 0x0000), &[0x20, 0]);
    assert_eq!((wkc, data, adp), (1, vec![0x31, 0], 1));
    let (wkc, _, adp) = run(&mut esc, Command::Bwr, at(0xFFFE, 0x0F80), &[0]);
    assert_eq!((wkc, adp), (1, 0xFFFF));
    assert_eq!(run(&mut esc, Command::Brw, at(7, 0x0F80), &[0]).2, 8);
    // Features: byte-oriented FMMUs, no DC.
    assert_eq!(esc.reg16(reg::FEATURES) & 0x0004, 0);
}

#[test]
fn configured_addressing_and_the_alias() {
    let mut esc = Esc::new();
    assert_eq!(run(&mut esc, Command::Apwr, at(0, reg::STATION_ADDRESS), &[0x01, 0x10]).0, 1);
    assert_eq!(run(&mut esc, Command::Fprd, at(0x1001, reg::STATION_ADDRESS), &[0, 0]).1, [0x01, 0x10]);
    assert_eq!(run(&mut esc, Command::Fprd, at(0x1002, reg::STATION_ADDRESS), &[0, 0]).0, 0);
    // The alias (from the EEPROM) answers only once DL control enables it.
    esc.set_reg16(reg::STATION_ALIAS, 0x0042);
    assert_eq!(run(&mut esc, Command::Fprd, at(0x0042, 0), &[0]).0, 0);
    run(&mut esc, Command::Fpwr, at(0x1001, reg::DL_CONTROL + 3), &[1]);
    assert_eq!(run(&mut esc, Command::Fprd, at(0x0042, 0), &[0]).0, 1);
}

#[test]
fn read_only_registers_drop_writes_but_count() {
    let mut esc = Esc::new();
    assert_eq!(run(&mut esc, Command::Bwr, at(0, reg::TYPE), &[0x55]).0, 1);
    assert_eq!(esc.reg8(reg::TYPE), 0x11);
    run(&mut esc, Command::Bwr, at(0, reg::AL_STATUS), &[0x08, 0]);
    assert_eq!(esc.reg16(reg::AL_STATUS), 0x0001);
    // Error counters: any write clears.
    esc.set_reg8(reg::ERROR_COUNTERS, 7);
    run(&mut esc, Command::Bwr, at(0, reg::ERROR_COUNTERS), &[0x33]);
    assert_eq!(esc.reg8(reg::ERROR_COUNTERS), 0);
    // AL control is stored and reported.
    run(&mut esc, Command::Bwr, at(0, reg::AL_CONTROL), &[0x12, 0]);
    assert!(esc.take_events().al_control);
    assert_eq!(esc.reg8(reg::AL_CONTROL), 0x12);
}

#[test]
fn dc_registers_read_zero_but_sync_activation() {
    let mut esc = Esc::new();
    run(&mut esc, Command::Bwr, at(0, 0x0910), &[0xAA; 8]);
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x0910), &[0; 8]).1, [0; 8]);
    run(&mut esc, Command::Bwr, at(0, reg::DC_SYNC_ACTIVATION), &[0x03]);
    assert_eq!(esc.reg8(reg::DC_SYNC_ACTIVATION), 0x03);
}

#[test]
fn read_write_commands() {
    let mut esc = Esc::new();
    esc.ecat_write(reg::USER_RAM, &[1, 2]);
    // APRW: the old contents come back, the new ones stay; read + write = 3.
    let (wkc, data, _) = run(&mut esc, Command::Aprw, at(0, reg::USER_RAM), &[7, 8]);
    assert_eq!((wkc, data), (3, vec![1, 2]));
    assert_eq!(esc.reg16(reg::USER_RAM), 0x0807);
    // BRW ORs the old contents into the data.
    let (wkc, data, _) = run(&mut esc, Command::Brw, at(0, reg::USER_RAM), &[0x10, 0]);
    assert_eq!((wkc, data), (3, vec![0x17, 8]));
    // ARMW: the addressed slave reads; FRMW at another station writes.
    let (wkc, data, _) = run(&mut esc, Command::Armw, at(0, reg::USER_RAM), &[0, 0]);
    assert_eq!((wkc, data), (1, vec![0x10, 0]));
    let (wkc, _, _) = run(&mut esc, Command::Frmw, at(0x7777, reg::USER_RAM), &[5, 5]);
    assert_eq!(wkc, 1);
    assert_eq!(esc.reg16(reg::USER_RAM), 0x0505);
    // NOP and unknown commands pass.
    assert_eq!(run(&mut esc, Command::Nop, 0, &[1]).0, 0);
    assert_eq!(run(&mut esc, Command::Unknown(0x33), 0, &[1]).0, 0);
}

#[test]
fn memory_ends_at_0x3000() {
    let mut esc = Esc::new();
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x2FFE), &[1, 2]).0, 1);
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x3000), &[1, 2]).0, 0);
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x2FFF), &[0, 9]).1, [2, 9]);
}

#[test]
fn mailbox_handshake() {
    let mut esc = Esc::new();
    sm(&mut esc, 0, 0x1000, 16, 0x26);
    sm(&mut esc, 1, 0x1010, 16, 0x22);
    // Write: must start at the start address; complete only at the end.
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1004), &[1; 12]).0, 0, "not from the start");
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1000), &[2; 8]).0, 1);
    assert!(esc.mailbox_message(0).is_none(), "the end was not written");
    assert_eq!(esc.take_events().written, 0);
    // The rest in a later frame completes it, as on the ET1100 (datasheet section I §8.2, §8.9).
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1008), &[3; 8]).0, 1, "a split write goes on");
    assert_eq!(esc.reg8(reg::SM + 5) & 0x08, 0x08, "SM0 status: full");
    assert!(esc.take_events().written & 1 != 0);
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1000), &[5; 16]).0, 0, "full: refused");
    assert_eq!(esc.mailbox_message(0), Some(&[2, 2, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3, 3, 3][..]));
    esc.release_mailbox(0);
    // Whole in one datagram, as SOEM and ethercrab write it.
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1000), &[4; 16]).0, 1);
    assert_eq!(esc.mailbox_message(0), Some(&[4u8; 16][..]));
    esc.release_mailbox(0);
    assert_eq!(esc.reg8(reg::SM + 5) & 0x08, 0);
    // Read: refused while empty; after a put, readable once.
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x1010), &[0; 16]).0, 0);
    assert!(esc.put_mailbox(1, &[9, 8, 7]));
    assert!(!esc.put_mailbox(1, &[1]), "full: the application waits");
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x1014), &[0; 4]).0, 0, "not from the start");
    let (wkc, data, _) = run(&mut esc, Command::Brd, at(0, 0x1010), &[0; 16]);
    assert_eq!(wkc, 1);
    assert_eq!(data[..4], [9, 8, 7, 0]);
    assert!(esc.mailbox_ready(1));
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x1010), &[0; 16]).0, 0, "read: empty again");
    // A read may be split too: the first part opens, the last byte empties the mailbox.
    assert!(esc.put_mailbox(1, &[6; 16]));
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x1010), &[0; 10]).1, [6; 10]);
    assert!(!esc.mailbox_ready(1), "still full until its end is read");
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x101A), &[0; 6]), (1, vec![6; 6], 1));
    assert!(esc.mailbox_ready(1));
    // The master cannot read its own mailbox, nor write the slave's.
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x1000), &[0; 16]).0, 0);
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1010), &[0; 16]).0, 0);
}

#[test]
fn a_syncmanager_the_application_switched_off_locks_its_buffer() {
    let mut esc = Esc::new();
    sm(&mut esc, 0, 0x1000, 8, 0x26);
    esc.set_sm_enabled(0, false);
    assert_eq!(esc.reg8(reg::SM + 7) & 1, 1, "PDI control: deactivated");
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1000), &[1; 8]).0, 0);
    assert!(esc.mailbox_message(0).is_none());
    // Disabled by the master, the area is plain memory.
    run(&mut esc, Command::Bwr, at(0, reg::SM + 6), &[0]);
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1004), &[1; 4]).0, 1);
    assert_eq!(esc.ram(0x1004, 4), [1; 4]);
}

#[test]
fn three_buffers_and_fmmus() {
    let mut esc = Esc::new();
    sm(&mut esc, 2, 0x1200, 8, 0x64);
    sm(&mut esc, 3, 0x1300, 4, 0x20);
    fmmu(&mut esc, 0, 0x100, 8, 0x1200, 2);
    fmmu(&mut esc, 1, 0x108, 4, 0x1300, 1);
    esc.put_inputs(3, &[1, 2, 3, 4]);
    // LRW over outputs and inputs: write +2, read +1.
    let mut data = [0u8; 12];
    data[..8].copy_from_slice(&[10, 11, 12, 13, 14, 15, 16, 17]);
    let (wkc, back, _) = run(&mut esc, Command::Lrw, 0x100, &data);
    assert_eq!(wkc, 3);
    assert_eq!(back[8..], [1, 2, 3, 4]);
    let mut out = [0u8; 8];
    assert!(esc.take_outputs(2, &mut out));
    assert_eq!(out, [10, 11, 12, 13, 14, 15, 16, 17]);
    assert!(!esc.take_outputs(2, &mut out), "taken once");
    // A write that stops short is not seen by the application until its end is written.
    assert_eq!(run(&mut esc, Command::Lwr, 0x100, &[1, 1, 1, 1]).0, 1);
    assert!(!esc.take_outputs(2, &mut out));
    assert_eq!(run(&mut esc, Command::Lwr, 0x104, &[2, 2, 2, 2]).0, 1);
    assert!(esc.take_outputs(2, &mut out));
    assert_eq!(out, [1, 1, 1, 1, 2, 2, 2, 2]);
    // LRD sees only read FMMUs, LWR only write FMMUs; a logical address nobody maps counts nothing.
    assert_eq!(run(&mut esc, Command::Lrd, 0x108, &[0; 4]), (1, vec![1, 2, 3, 4], 0x108));
    assert_eq!(run(&mut esc, Command::Lrd, 0x100, &[0; 4]).0, 0);
    assert_eq!(run(&mut esc, Command::Lrw, 0x5000, &[0; 4]).0, 0);
    // The inputs cannot be written by the master.
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x1300), &[9; 4]).0, 0);
    assert_eq!(esc.ram(0x1300, 4), [1, 2, 3, 4]);
}

#[test]
fn repeat_request_is_reported() {
    let mut esc = Esc::new();
    sm(&mut esc, 1, 0x1010, 16, 0x22);
    esc.take_events();
    run(&mut esc, Command::Bwr, at(0, reg::SM + 8 + 6), &[0x03]);
    assert_eq!(esc.take_events().repeat, 0b10);
    esc.set_repeat_ack(1, true);
    assert_eq!(esc.reg8(reg::SM + 8 + 7) & 0x02, 0x02);
}

#[test]
fn syncmanagers_8_to_15_are_not_there() {
    // Found by the `ethercat_frames` fuzz target: activating SyncManager 8 (0x0846) indexed past the 8
    // SyncManagers. Their registers are not implemented: written (and counted), read back as 0.
    let mut esc = Esc::new();
    assert_eq!(run(&mut esc, Command::Bwr, at(0, 0x0840), &[0x00, 0x10, 8, 0, 0x26, 0, 1, 0]).0, 1);
    assert_eq!(run(&mut esc, Command::Brd, at(0, 0x0840), &[0; 64]).1, [0; 64]);
}

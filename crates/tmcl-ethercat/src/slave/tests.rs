//! The slave driven frame by frame, as a master would: the AL checks and their codes, the TMCL mailbox,
//! BOOT with FoE, process data in each state, refused frames.

use super::*;
use crate::foe::FileStore;
use crate::fuzzing::{answers, bring_up, build_frame, MAX_FRAME};
use crate::wire::datagram::Repr as D;
use crate::wire::foe::ErrorCode;
use tmcl_core::model::tmcm_1310::{ETHERCAT, SPEC};

const INPUTS: SmLayout = layout::inputs(&ETHERCAT);
use tmcl_sim::SimBoard;

#[derive(Default)]
struct Files {
    name: Vec<u8>,
    data: Vec<u8>,
    finished: Vec<(Vec<u8>, usize)>,
}

impl FileStore for Files {
    fn begin(&mut self, name: &[u8], _: u32) -> Result<(), ErrorCode> {
        self.name = name.to_vec();
        self.data.clear();
        Ok(())
    }
    fn append(&mut self, data: &[u8]) -> Result<(), ErrorCode> {
        self.data.extend_from_slice(data);
        Ok(())
    }
    fn finish(&mut self) -> Result<(), ErrorCode> {
        self.finished.push((self.name.clone(), self.data.len()));
        Ok(())
    }
    fn abort(&mut self) {
        self.data.clear();
    }
}

struct Rig {
    slave: Slave,
    module: Module<SimBoard>,
    files: Files,
    now: Instant,
}

const STATION: u16 = 0x1001;

impl Rig {
    fn new() -> Rig {
        Rig {
            slave: Slave::new(&SPEC).unwrap(),
            module: Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO),
            files: Files::default(),
            now: Instant::ZERO,
        }
    }

    fn up(target: AlState) -> Rig {
        let mut r = Rig::new();
        bring_up(&mut r.slave, &mut r.module, r.now, target);
        assert_eq!(r.slave.status().state, target);
        r
    }

    /// Several datagrams in one frame; their (working counter, data).
    fn frame(&mut self, datagrams: &[(Command, u32, &[u8])]) -> Vec<(u16, Vec<u8>)> {
        self.now += Duration::from_micros(100);
        let mut buf = [0u8; MAX_FRAME];
        let n = build_frame(&mut buf, datagrams).unwrap();
        assert_eq!(self.slave.process(self.now, &mut buf[..n], &mut self.module, &mut self.files), Some(n));
        assert_eq!(buf[6], 0x03, "source address marked as processed");
        let mut out = Vec::new();
        answers(&buf[..n], |_, wkc, d| out.push((wkc, d.to_vec())));
        out
    }

    fn one(&mut self, command: Command, address: u32, data: &[u8]) -> (u16, Vec<u8>) {
        self.frame(&[(command, address, data)]).remove(0)
    }

    fn fpwr(&mut self, register: u16, data: &[u8]) -> u16 {
        self.one(Command::Fpwr, D::physical(STATION, register), data).0
    }

    fn fprd(&mut self, register: u16, len: usize) -> (u16, Vec<u8>) {
        self.one(Command::Fprd, D::physical(STATION, register), &vec![0; len])
    }

    /// AL status and code after writing AL control.
    fn al(&mut self, control: u16) -> (u16, u16) {
        self.fpwr(reg::AL_CONTROL, &control.to_le_bytes());
        let (_, d) = self.fprd(reg::AL_STATUS, 6);
        (u16::from_le_bytes([d[0], d[1]]), u16::from_le_bytes([d[4], d[5]]))
    }

    fn sm(&mut self, layout: SmLayout, length: u16) {
        let mut b = [0u8; 8];
        b[..2].copy_from_slice(&layout.start.to_le_bytes());
        b[2..4].copy_from_slice(&length.to_le_bytes());
        b[4] = layout.control;
        b[6] = 1;
        self.fpwr(reg::SM + 8 * layout.index as u16, &b);
    }

    /// A mailbox request (the whole SM0 buffer) and the SM1 buffer read back.
    fn mailbox(&mut self, message: &[u8]) -> Vec<u8> {
        let mut request = [0u8; MAILBOX_OUT.length as usize];
        request[..message.len()].copy_from_slice(message);
        assert_eq!(self.fpwr(MAILBOX_OUT.start, &request), 1, "SM0 takes the request");
        let (status, _) = self.fprd(reg::SM + 8 + 5, 1);
        assert_eq!(status, 1);
        let (wkc, reply) = self.fprd(MAILBOX_IN.start, MAILBOX_IN.length as usize);
        assert_eq!(wkc, 1, "SM1 holds the reply");
        reply
    }

    fn tmcl(&mut self, opcode: u8, kind: u8, value: i32) -> (u8, i32) {
        let mut m = [1, opcode, kind, 0, 0, 0, 0, 0];
        m[4..].copy_from_slice(&value.to_be_bytes());
        let reply = self.mailbox(&m);
        (reply[2], i32::from_be_bytes([reply[4], reply[5], reply[6], reply[7]]))
    }

    fn inputs(&mut self) -> Vec<u8> {
        let out = self.one(Command::Lrw, 0, &[0u8; 56]);
        assert_eq!(out.0, 3);
        out.1[8..].to_vec()
    }

    fn cycle(&mut self, outputs: Outputs, ms: u64) -> (u16, Vec<u8>) {
        let mut data = [0u8; 56];
        data[..8].copy_from_slice(&outputs.to_bytes());
        let r = self.one(Command::Lrw, 0, &data);
        self.now += Duration::from_millis(ms);
        self.slave.poll(self.now, &mut self.module, &mut self.files);
        r
    }
}

fn field(inputs: &[u8], n: usize) -> i32 {
    i32::from_le_bytes(inputs[4 * n..4 * n + 4].try_into().unwrap())
}

#[test]
fn init_to_pre_op_checks_the_mailbox() {
    let mut r = Rig::new();
    r.one(Command::Apwr, D::physical(0, reg::STATION_ADDRESS), &STATION.to_le_bytes());
    // No mailbox configured: refused with 0x0016, INIT with the error flag.
    assert_eq!(r.al(0x0002), (0x11, 0x0016));
    // Higher states are ignored until the error is acknowledged.
    r.sm(MAILBOX_OUT, MAILBOX_OUT.length);
    r.sm(MAILBOX_IN, MAILBOX_IN.length);
    assert_eq!(r.al(0x0002), (0x11, 0x0016));
    assert_eq!(r.al(0x0012), (0x02, 0x0000));
    // A mailbox of the wrong length is refused as well.
    assert_eq!(r.al(0x0011), (0x01, 0));
    r.sm(MAILBOX_IN, 32);
    assert_eq!(r.al(0x0012), (0x11, 0x0016));
    // Skipping states: 0x0011; unknown states: 0x0012.
    assert_eq!(r.al(0x0018), (0x11, 0x0011));
    assert_eq!(r.al(0x0016), (0x11, 0x0012));
}

#[test]
fn pre_op_to_safe_op_checks_process_data_and_dc() {
    let mut r = Rig::up(AlState::PreOp);
    assert_eq!(r.al(0x0004), (0x12, 0x001D), "no output SyncManager");
    r.sm(OUTPUTS, 8);
    assert_eq!(r.al(0x0014), (0x12, 0x001E), "no input SyncManager");
    r.sm(INPUTS, 44);
    assert_eq!(r.al(0x0014), (0x12, 0x001E), "44 bytes: the slave maps 48");
    r.sm(INPUTS, 48);
    r.fpwr(reg::DC_SYNC_ACTIVATION, &[0x03]);
    assert_eq!(r.al(0x0014), (0x12, 0x0030), "SYNC0 without DC");
    r.fpwr(reg::DC_SYNC_ACTIVATION, &[0x00]);
    assert_eq!(r.al(0x0014), (0x04, 0x0000));
    // The inputs were filled before SAFE-OP was accepted: the status word has position mode and
    // target reached.
    let (wkc, d) = r.fprd(INPUTS.start, 48);
    assert_eq!(wkc, 1);
    assert_eq!(field(&d, 7) & 0b1001, 0b1001);
}

#[test]
fn tmcl_through_the_raw_mailbox() {
    let mut r = Rig::up(AlState::PreOp);
    // GAP 4: the 8-byte reply, no checksum, at offset 0 of SM1; the rest of the buffer zero.
    let reply = r.mailbox(&[1, 6, 4, 0, 0, 0, 0, 0]);
    assert_eq!(reply[..8], [2, 1, 100, 6, 0, 0, 0xC8, 0]);
    assert!(reply[8..].iter().all(|b| *b == 0));
    assert_eq!(r.tmcl(5, 4, 25600), (100, 25600));
    assert_eq!(r.tmcl(6, 4, 0), (100, 25600));
    // Invalid command 2, wrong type 3, password protected 8, ASCII mode not on this interface 6.
    assert_eq!(r.tmcl(0xC8, 0, 0).0, 2);
    assert_eq!(r.tmcl(6, 250, 0).0, 3);
    assert_eq!(r.tmcl(5, 25, 1).0, 8);
    assert_eq!(r.tmcl(139, 0, 0).0, 6);
    // Program download: 132 enters download mode, instructions answer 101, 133 leaves it.
    assert_eq!(r.tmcl(132, 0, 0).0, 100);
    assert_eq!(r.tmcl(4, 0, 1000).0, 101);
    assert_eq!(r.tmcl(28, 0, 0).0, 101);
    assert_eq!(r.tmcl(133, 0, 0).0, 100);
    // The USB port sees what the mailbox set.
    let mut out = Vec::new();
    let gap = tmcl_wire::Request { address: 1, instruction: tmcl_wire::Instruction::new(Opcode::Gap, 4, 0, 0) };
    r.module.receive(r.now, &gap.to_bytes(), &mut |b: &[u8]| out.extend_from_slice(b));
    assert_eq!(i32::from_be_bytes([out[4], out[5], out[6], out[7]]), 25600);
}

use tmcl_wire::Opcode;

#[test]
fn the_mailbox_handshake_and_repeat() {
    let mut r = Rig::up(AlState::PreOp);
    // Reading an empty SM1: no working counter.
    assert_eq!(r.fprd(MAILBOX_IN.start, 40).0, 0);
    let mut request = [0u8; 268];
    request[..8].copy_from_slice(&[1, 6, 1, 0, 0, 0, 0, 0]);
    assert_eq!(r.fpwr(MAILBOX_OUT.start, &request), 1);
    // Before the reply is read, a second request: taken, its reply waits for the first to be read.
    request[2] = 4;
    assert_eq!(r.fpwr(MAILBOX_OUT.start, &request), 1);
    let (_, first) = r.fprd(MAILBOX_IN.start, 40);
    // SOEM's recovery: toggle the repeat request, wait for the acknowledge, read the same reply again.
    r.fpwr(reg::SM + 8 + 6, &[0x03]);
    let (_, pdi) = r.fprd(reg::SM + 8 + 7, 1);
    assert_eq!(pdi[0] & 0x02, 0x02, "repeat acknowledged");
    let (wkc, again) = r.fprd(MAILBOX_IN.start, 40);
    assert_eq!((wkc, &again), (1, &first));
    let (wkc, second) = r.fprd(MAILBOX_IN.start, 40);
    assert_eq!(wkc, 1);
    assert_eq!((first[3], second[3]), (6, 6));
    assert_eq!(i32::from_be_bytes(second[4..8].try_into().unwrap()), 51200, "GAP 4 after GAP 1");
}

#[test]
fn safe_op_holds_op_drives_leaving_op_stops() {
    let mut r = Rig::up(AlState::SafeOp);
    let velocity = Outputs { mode: 2, value: 51200 };
    for _ in 0..100 {
        r.cycle(velocity, 1);
    }
    assert_eq!(field(&r.inputs(), 1), 0, "SAFE-OP: no motion");
    // OP comes as soon as it is asked for: the outputs are there.
    assert_eq!(r.al(0x0008), (0x08, 0));
    // 1 s to full speed at the default acceleration (AP 5 = 51200 pps²), then a bit.
    for _ in 0..1100 {
        r.cycle(velocity, 1);
    }
    let inputs = r.inputs();
    assert_eq!(field(&inputs, 5), 51200, "actual velocity");
    assert!(field(&inputs, 1) > 10_000);
    // Position mode: the target in the inputs is the output value.
    let target = Outputs { mode: 1, value: -3000 };
    r.cycle(target, 1);
    assert_eq!(field(&r.inputs(), 0), -3000);
    // Back to SAFE-OP: the motor stops (velocity 0 requested at once).
    r.cycle(velocity, 1);
    assert_eq!(r.module.ramp().target_velocity, 51200);
    assert_eq!(r.al(0x0004), (0x04, 0));
    assert_eq!(r.module.ramp().target_velocity, 0);
    // Mode 0 leaves the motor to TMCL: in OP, a mailbox ROR is not undone by the process data.
    assert_eq!(r.al(0x0008), (0x08, 0));
    let idle = Outputs { mode: 0, value: 0 };
    r.cycle(idle, 1);
    assert_eq!(r.tmcl(1, 0, 1000).0, 100);
    r.cycle(idle, 1);
    assert_eq!(r.module.ramp().target_velocity, 1000);
}

#[test]
fn boot_takes_a_file_by_foe() {
    let mut r = Rig::up(AlState::PreOp);
    assert_eq!(r.al(0x0003), (0x12, 0x0011), "BOOT only from INIT");
    assert_eq!(r.al(0x0011), (0x01, 0));
    assert_eq!(r.al(0x0003), (0x03, 0));
    // TMCL is not spoken in BOOT: a raw request gets a mailbox error (the header is not FoE).
    let reply = r.mailbox(&[8, 0, 0, 0, 0, 0x13, 1, 6]);
    assert_eq!(reply[5] & 0x0F, 0, "mailbox error reply");
    assert_eq!(u16::from_le_bytes([reply[8], reply[9]]), 0x0002, "unsupported protocol");
    // Write "fw.bin", 600 bytes: 256 + 256 + 88.
    let file: Vec<u8> = (0..600u32).map(|i| (i * 7) as u8).collect();
    let foe_message = |r: &mut Rig, foe: &[u8]| {
        let mut m = vec![0u8; 6 + foe.len()];
        m[..2].copy_from_slice(&(foe.len() as u16).to_le_bytes());
        m[5] = 0x04;
        m[6..].copy_from_slice(foe);
        let reply = r.mailbox(&m);
        assert_eq!(reply[5] & 0x0F, 4, "FoE reply");
        let n = usize::from(u16::from_le_bytes([reply[0], reply[1]]));
        reply[6..6 + n].to_vec()
    };
    let mut write = vec![2, 0, 0, 0, 0, 0];
    write.extend_from_slice(b"fw.bin");
    assert_eq!(foe_message(&mut r, &write), [4, 0, 0, 0, 0, 0], "ack 0");
    for (k, chunk) in file.chunks(256).enumerate() {
        let packet = k as u32 + 1;
        let mut data = vec![3, 0];
        data.extend_from_slice(&packet.to_le_bytes());
        data.extend_from_slice(chunk);
        let ack = foe_message(&mut r, &data);
        assert_eq!(ack[..2], [4, 0]);
        assert_eq!(u32::from_le_bytes(ack[2..6].try_into().unwrap()), packet);
    }
    assert_eq!(r.files.finished, [(b"fw.bin".to_vec(), 600)]);
    assert_eq!(r.files.data, file);
    // Reading a file: not found.
    let mut read = vec![1, 0, 0, 0, 0, 0];
    read.extend_from_slice(b"fw.bin");
    let error = foe_message(&mut r, &read);
    assert_eq!((error[0], u32::from_le_bytes(error[2..6].try_into().unwrap())), (5, 0x8001));
    // No process data in BOOT; out only to INIT.
    assert_eq!(r.al(0x0004), (0x13, 0x0011));
    assert_eq!(r.al(0x0011), (0x01, 0));
}

#[test]
fn refused_frames_change_nothing() {
    let mut r = Rig::up(AlState::PreOp);
    let before = r.slave.clone();
    let mut buf = [0u8; MAX_FRAME];
    let n = build_frame(&mut buf, &[(Command::Fpwr, D::physical(STATION, reg::AL_CONTROL), &[0x01, 0])]).unwrap();
    let process = |r: &mut Rig, bytes: &mut [u8]| r.slave.process(r.now, bytes, &mut r.module, &mut r.files);
    // Cut short, wrong EtherType, wrong frame type, a datagram longer than the frame, a chain that
    // promises more.
    let mut short = buf;
    assert_eq!(process(&mut r, &mut short[..n - 1]), None);
    let mut other = buf;
    other[12] = 0x08;
    assert_eq!(process(&mut r, &mut other[..n]), None);
    let mut other = buf;
    other[15] = 0x40;
    assert_eq!(process(&mut r, &mut other[..n]), None);
    let mut other = buf;
    other[14 + 2 + 6] = 0x20;
    assert_eq!(process(&mut r, &mut other[..n]), None);
    let mut other = buf;
    other[14 + 2 + 7] |= 0x80;
    assert_eq!(process(&mut r, &mut other[..n]), None);
    assert!(r.slave == before, "nothing changed");
    assert_eq!(process(&mut r, &mut buf[..n]), Some(n), "the same frame, sound");
    let after = r.slave.clone();
    assert_eq!(after.status().state, AlState::Init, "does what it says");
    assert!(before != after);
}

#[test]
fn several_datagrams_in_one_frame_as_soem_polls() {
    let mut r = Rig::up(AlState::PreOp);
    let out = r.frame(&[
        (Command::Brd, D::physical(0, reg::AL_STATUS), &[0, 0]),
        (Command::Fprd, D::physical(STATION, reg::AL_STATUS), &[0; 6]),
        (Command::Fprd, D::physical(STATION + 1, reg::AL_STATUS), &[0; 6]),
    ]);
    assert_eq!(out[0], (1, vec![2, 0]));
    assert_eq!(out[1], (1, vec![2, 0, 0, 0, 0, 0]));
    assert_eq!(out[2].0, 0, "another station");
}

#[test]
fn a_mailbox_written_in_two_frames_is_taken_as_the_esc_does() {
    let mut r = Rig::up(AlState::PreOp);
    // GAP 4 (maximum positioning speed): the first 100 bytes of SM0 in one frame, the other 168 later.
    let mut request = [0u8; MAILBOX_OUT.length as usize];
    request[..8].copy_from_slice(&[1, 6, 4, 0, 0, 0, 0, 0]);
    assert_eq!(r.fpwr(MAILBOX_OUT.start, &request[..100]), 1, "the first part opens SM0");
    assert_eq!(r.fprd(reg::SM + 8 + 5, 1).1[0] & 0x08, 0, "no reply yet: SM0 is not complete");
    assert_eq!(r.fpwr(MAILBOX_OUT.start + 100, &request[100..]), 1, "the rest completes it");
    let (wkc, reply) = r.fprd(MAILBOX_IN.start, MAILBOX_IN.length as usize);
    assert_eq!(wkc, 1, "SM1 holds the reply");
    assert_eq!(reply[..4], [2, 1, 100, 6]);
    // A part that does not begin at the start address still opens nothing.
    assert_eq!(r.fpwr(MAILBOX_OUT.start + 8, &request[8..]), 0);
}

#[test]
fn broadcasts_increment_the_position() {
    let mut r = Rig::up(AlState::Init);
    // SOEM's first frame: a BRD of the ESC type; the position comes back incremented (ETG.1000.4).
    let mut buf = [0u8; MAX_FRAME];
    let n = build_frame(&mut buf, &[(Command::Brd, D::physical(0, 0x0000), &[0, 0])]).unwrap();
    r.slave.process(r.now, &mut buf[..n], &mut r.module, &mut r.files).unwrap();
    let d = crate::wire::datagram::Datagram::new_checked(&buf[16..n]).unwrap();
    assert_eq!((d.adp(), d.wkc(), d.data()), (1, 1, &[0x11, 0x00][..]));
}

#[test]
fn the_alias_a_master_writes_survives_a_restart_with_a_store() {
    use crate::eeprom::SII_STORE_LEN;
    use tmcl_sim::MemNvm;
    let mut store = MemNvm::new(SII_STORE_LEN);
    {
        let mut r = Rig::up(AlState::Init);
        let mut slave = Slave::with_store(&SPEC, &mut store).unwrap();
        // eepromtool -walias 0x0BAD: SII to the master, write word 4 with write enable.
        let mut frame = |command, register, data: &[u8]| {
            let mut buf = [0u8; MAX_FRAME];
            let n = build_frame(&mut buf, &[(command, D::physical(0, register), data)]).unwrap();
            slave.process(r.now, &mut buf[..n], &mut r.module, &mut r.files).unwrap();
        };
        frame(Command::Apwr, reg::SII_CONFIGURATION, &[2]);
        frame(Command::Apwr, reg::SII_DATA, &[0xAD, 0x0B]);
        frame(Command::Apwr, reg::SII_CONTROL, &[0x01, 0x02, 0x04, 0, 0, 0]);
        assert_eq!(slave.eeprom().word(4), 0x0BAD);
        assert_eq!(slave.esc().reg16(reg::STATION_ALIAS), 0, "the alias register waits for power-on");
    }
    // Power-on again with the same store: the alias is loaded; without it, it is gone.
    let slave = Slave::with_store(&SPEC, &mut store).unwrap();
    assert_eq!((slave.esc().reg16(reg::STATION_ALIAS), slave.restored_words()), (0x0BAD, 1));
    assert_eq!(Slave::new(&SPEC).unwrap().esc().reg16(reg::STATION_ALIAS), 0);
}

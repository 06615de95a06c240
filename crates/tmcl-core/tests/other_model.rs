//! A model that differs from the PD28-1021 in every dimension the firmware makes data — and runs direct
//! mode, a program, the ASCII line and a second interface with nothing but this file.
//!
//! The "TEST-428" is no real product: TMC428-generation units and 24-bit positions, parameters the
//! PD28-1021 lacks (the TMC428 divisors, a protected one, a password) and many it has missing (currents,
//! switch disables, GP 66/75/255, coolStep, interrupts), 8 inputs and 8 outputs, 64 user variables,
//! 5 coordinates, 128 commands of program memory, no interrupts at all, a 4096-count encoder, and two
//! interfaces: an RS232 port without address filter, with ASCII mode, and a mailbox.

use std::vec::Vec;
use tmcl_core::model::{
    Access, AppStatusReply, Driver, Encoder, EncoderKind, FitError, Framing, GlobalBanks, InterfaceDesc, InterfaceKind,
    Interrupts, Kinematics, ModelDesc, ModelSpec, ParamDesc, PortDesc, PortKind, Range, ReferenceModes, Role, Setting,
    Table,
};
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::{CommandSet, Instruction, Opcode, Reply, ReplyFrame, Request, Status};

const S: &str = "test model";
const POS24: Range = Range::Signed(-(1 << 23), (1 << 23) - 1);
const V11: Range = Range::Signed(0, 2047);

static AXIS: [ParamDesc; 14] = [
    ParamDesc::plain(0, "Target position", "TargetPosition", POS24, Access::RW, 0, S).with_role(Role::TargetPosition),
    ParamDesc::plain(1, "Actual position", "ActualPosition", POS24, Access::RW, 0, S).with_role(Role::ActualPosition),
    ParamDesc::plain(2, "Target speed", "TargetSpeed", Range::Signed(-2047, 2047), Access::RW, 0, S)
        .with_role(Role::TargetSpeed),
    ParamDesc::plain(3, "Actual speed", "ActualSpeed", Range::Signed(-2047, 2047), Access::R, 0, S)
        .with_role(Role::ActualSpeed),
    ParamDesc::plain(4, "Maximum positioning speed", "MaxSpeed", V11, Access::RWE, 1000, S)
        .with_setting(Setting::MaxPositioningSpeed),
    ParamDesc::plain(5, "Maximum acceleration", "MaxAccel", V11, Access::RWE, 2047, S)
        .with_setting(Setting::MaxAcceleration),
    ParamDesc::plain(8, "Position reached", "PositionReached", Range::FLAG, Access::R, 0, S)
        .with_role(Role::PositionReached),
    ParamDesc::plain(140, "Microstep resolution", "Microsteps", Range::Signed(0, 4), Access::RWE, 4, S)
        .with_role(Role::MicrostepResolution),
    ParamDesc::plain(153, "Ramp divisor", "RampDivisor", Range::Signed(0, 13), Access::RWE, 2, S)
        .with_setting(Setting::RampDivisor),
    ParamDesc::plain(154, "Pulse divisor", "PulseDivisor", Range::Signed(0, 13), Access::RWE, 3, S)
        .with_setting(Setting::PulseDivisor),
    ParamDesc::plain(193, "Reference search mode", "RefMode", Range::Signed(1, 3), Access::RWE, 1, S)
        .with_setting(Setting::ReferenceSearchMode),
    ParamDesc::plain(194, "Reference search speed", "RefSpeed", V11, Access::RWE, 500, S)
        .with_setting(Setting::ReferenceSearchSpeed),
    ParamDesc::plain(195, "Reference switch speed", "RefSwitchSpeed", V11, Access::RWE, 100, S)
        .with_setting(Setting::ReferenceSwitchSpeed),
    ParamDesc::plain(250, "Calibration", "Calibration", Range::ANY, Access::RWE.protected(), 7, S),
];

static GLOBAL: [ParamDesc; 4] = [
    ParamDesc::plain(64, "Password", "Password", Range::ANY, Access::RW, 0, S).with_role(Role::Password),
    ParamDesc::plain(77, "Auto start", "AutoStart", Range::FLAG, Access::RWA, 0, S).with_setting(Setting::AutoStart),
    ParamDesc::plain(128, "Application status", "ApplicationStatus", Range::Signed(0, 3), Access::R, 0, S)
        .with_role(Role::ApplicationStatus),
    ParamDesc::plain(130, "Program counter", "ProgramCounter", Range::ANY, Access::R, 0, S)
        .with_role(Role::ProgramCounter),
];

static PORTS: [PortDesc; 5] = [
    PortDesc { bank: 0, port: 7, kind: PortKind::DigitalInput(7), name: "IN7" },
    PortDesc { bank: 0, port: 255, kind: PortKind::AllInputs, name: "all inputs" },
    PortDesc { bank: 1, port: 0, kind: PortKind::Analog(0), name: "AIN0" },
    PortDesc { bank: 2, port: 7, kind: PortKind::Output(7), name: "OUT7" },
    PortDesc { bank: 2, port: 255, kind: PortKind::AllOutputs, name: "all outputs" },
];

static INTERFACES: [InterfaceDesc; 2] = [
    InterfaceDesc {
        name: "rs232",
        kind: InterfaceKind::Rs232,
        framing: Framing::Binary,
        address_filter: false,
        ascii: true,
        telegram_pause: false,
        suppressible: false,
    },
    InterfaceDesc::ETHERCAT_MAILBOX,
];

/// Every named command but the interrupt commands (the model has no interrupts).
const COMMANDS: CommandSet =
    CommandSet::ALL_NAMED.without(Opcode::Ei).without(Opcode::Di).without(Opcode::Vect).without(Opcode::Reti);

const DESC: ModelDesc = ModelDesc {
    id: "test-428",
    name: "TEST-428",
    version_string: *b"0428V100",
    version_binary: 0x0428_0100,
    eeprom_tag: 428,
    motors: 1,
    axis: Table::new(&AXIS),
    global: Table::new(&GLOBAL),
    interrupt: Table::EMPTY,
    user_variables: 64,
    stored_user_variables: 16,
    coordinates: 5,
    program_memory: 128,
    ports: &PORTS,
    interrupts: Interrupts::NONE,
    inputs: 8,
    outputs: 8,
    interfaces: &INTERFACES,
    ethercat: None,
    commands: COMMANDS,
    ascii_commands: COMMANDS.ascii_subset(),
    host_vect: false,
    app_status: AppStatusReply::Typed,
    banks: GlobalBanks::ARM,
    kinematics: Kinematics::Tmc428 { clock_hz: 16_000_000 },
    reference_modes: ReferenceModes::Tmc428,
    driver: Driver::Tmc428Tmc24x,
    encoder: Some(Encoder { kind: EncoderKind::Abn, counts_per_rev: 4096 }),
    password: Some(1234),
    peak_current_ma: [1500, 1500],
    manual: "none: a test model",
};

static TEST_428: ModelSpec = ModelSpec::new(DESC);

// The same model with more program memory than the core holds does not fit: `ModelSpec::new` of it in
// a `static` is a compile error (tmcl-model's compile_fail doctest); here, the reason as a value.
const _: () =
    assert!(matches!(ModelSpec::check(&ModelDesc { program_memory: 4096, ..DESC }), Err(FitError::ProgramMemory)));
// ... and protected parameters without a password do not fit either.
const _: () = assert!(matches!(ModelSpec::check(&ModelDesc { password: None, ..DESC }), Err(FitError::Password)));

mod support;
use support::Board;

struct Rig {
    module: Module<Board>,
    now: Instant,
}

impl Rig {
    fn new() -> Rig {
        let now = Instant::from_secs(1);
        let board = Board { analog: 1234, temperature: 30, ..Board::new(&TEST_428, 4096) };
        Rig { module: Module::new(board, &TEST_428, now), now }
    }

    /// A 9-byte frame on the serial interface (port 0): the reply's (status, value).
    fn send(&mut self, address: u8, op: Opcode, t: u8, m: u8, v: i32) -> (Status, i32) {
        let frame = Request { address, instruction: Instruction::new(op, t, m, v) }.to_bytes();
        let mut out = Vec::new();
        self.module.receive_on(0, self.now, &frame, &mut |b: &[u8]| out.extend_from_slice(b));
        let r = Reply::parse(&ReplyFrame::new_checked(&out[..]).expect("a 9-byte reply")).expect("checksum");
        assert_eq!((r.host, r.module), (2, 1), "host 2, module 1: the defaults of a model without GP 66/76");
        (r.status, r.value)
    }

    fn cmd(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> (Status, i32) {
        self.send(1, op, t, m, v)
    }

    /// A mailbox message on port 1: the 8-byte reply (and anything else due there).
    fn mailbox(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> Vec<u8> {
        let mut msg = [0u8; 8];
        msg[0] = 1;
        msg[1] = op.code();
        msg[2] = t;
        msg[3] = m;
        msg[4..].copy_from_slice(&v.to_be_bytes());
        let mut out = Vec::new();
        self.module.request(1, self.now, &msg, &mut |b: &[u8]| out.extend_from_slice(b));
        out
    }

    fn text(&mut self, line: &str) -> String {
        let mut out = Vec::new();
        self.module.receive_on(0, self.now, line.as_bytes(), &mut |b: &[u8]| out.extend_from_slice(b));
        String::from_utf8(out).unwrap()
    }

    /// Runs simulated time, collecting what each interface sends.
    fn run(&mut self, d: Duration) -> [Vec<u8>; 2] {
        let end = self.now + d;
        let mut out = [Vec::new(), Vec::new()];
        loop {
            let next = self.module.poll(self.now, &mut |b: &[u8]| out[0].extend_from_slice(b));
            self.module.poll_port(1, self.now, &mut |b: &[u8]| out[1].extend_from_slice(b));
            match next {
                Some(t) if t <= end => self.now = t.max(self.now + Duration::from_micros(1)),
                _ => break,
            }
        }
        self.now = end;
        self.module.poll(self.now, &mut |b: &[u8]| out[0].extend_from_slice(b));
        self.module.poll_port(1, self.now, &mut |b: &[u8]| out[1].extend_from_slice(b));
        out
    }
}

#[test]
fn the_layout_follows_the_model() {
    let l = TEST_428.layout();
    // 10 E axis parameters, 1 A global, 16 stored user variables, 5 coordinates (each region a whole
    // block of 128 bytes), 128 commands from the next 1 KiB.
    assert_eq!((l.axis, l.global, l.user, l.coords, l.program), (0x10, 0x90, 0x110, 0x190, 0x400));
    assert_eq!(l.end, 0x400 + 128 * 8);
}

#[test]
fn direct_mode_with_its_own_parameters() {
    let mut r = Rig::new();
    assert_eq!(r.cmd(Opcode::Gap, 4, 0, 0), (Status::Ok, 1000));
    assert_eq!(r.cmd(Opcode::Gap, 154, 0, 0), (Status::Ok, 3), "an axis parameter the PD28-1021 lacks");
    assert_eq!(r.cmd(Opcode::Sap, 4, 0, 2048).0, Status::InvalidValue, "velocities are 0..2047");
    assert_eq!(r.cmd(Opcode::Sap, 6, 0, 100).0, Status::WrongType, "no run current in this model");
    assert_eq!(r.cmd(Opcode::Ggp, 255, 0, 0).0, Status::WrongType, "no reply suppression");
    assert_eq!(r.cmd(Opcode::Sap, 3, 0, 1).0, Status::WrongType, "AP 3 is read-only here");
    // No interrupts: EI, DI, VECT and RETI are not commands of this model.
    assert_eq!(r.cmd(Opcode::Ei, 3, 0, 0).0, Status::InvalidCommand);
    // Any address byte is answered: RS232 has no address filter.
    assert_eq!(r.send(7, Opcode::Gap, 4, 0, 0), (Status::Ok, 1000));
    assert_eq!(r.cmd(Opcode::GetVersion, 1, 0, 0), (Status::Ok, 0x0428_0100));
    // 8 outputs and 8 inputs.
    assert_eq!(r.cmd(Opcode::Sio, 7, 2, 1).0, Status::Ok);
    assert_eq!(r.module.board().outputs, 0x80);
    assert_eq!(r.cmd(Opcode::Sio, 255, 2, 0x1FF).0, Status::InvalidValue);
    r.module.board_mut().inputs = 0x81;
    assert_eq!(r.cmd(Opcode::Gio, 7, 0, 0), (Status::Ok, 1));
    assert_eq!(r.cmd(Opcode::Gio, 255, 0, 0), (Status::Ok, 0x81));
    // 64 user variables, 5 coordinates.
    assert_eq!(r.cmd(Opcode::Sgp, 63, 2, 5).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Sgp, 64, 2, 5).0, Status::WrongType);
    assert_eq!(r.cmd(Opcode::Stgp, 16, 2, 0).0, Status::WrongType, "only 0..15 can be stored");
    assert_eq!(r.cmd(Opcode::Sco, 5, 0, 9).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Sco, 6, 0, 9).0, Status::WrongType);
}

#[test]
fn a_protected_parameter_answers_8_until_unlocked() {
    let mut r = Rig::new();
    assert_eq!(r.cmd(Opcode::Gap, 250, 0, 0), (Status::Ok, 7), "reading is never protected");
    assert_eq!(r.cmd(Opcode::Sap, 250, 0, 99).0, Status::PasswordProtected);
    assert_eq!(r.cmd(Opcode::Stap, 250, 0, 0).0, Status::PasswordProtected);
    assert_eq!(r.cmd(Opcode::Gap, 250, 0, 0), (Status::Ok, 7), "unchanged");
    assert_eq!(r.cmd(Opcode::Sgp, 64, 0, 1111).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Ggp, 64, 0, 0), (Status::Ok, 0), "a wrong password: still locked");
    assert_eq!(r.cmd(Opcode::Sap, 250, 0, 99).0, Status::PasswordProtected);
    assert_eq!(r.cmd(Opcode::Sgp, 64, 0, 1234).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Ggp, 64, 0, 0), (Status::Ok, 1), "unlocked; the password is not read back");
    assert_eq!(r.cmd(Opcode::Sap, 250, 0, 99).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Stap, 250, 0, 0).0, Status::Ok);
    // A restart locks again; the stored value stays.
    assert_eq!(r.cmd(Opcode::SoftwareReset, 0, 0, 1234).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::Gap, 250, 0, 0), (Status::Ok, 99));
    assert_eq!(r.cmd(Opcode::Sap, 250, 0, 1).0, Status::PasswordProtected);
}

#[test]
fn tmc428_units_and_24_bit_positions() {
    let mut r = Rig::new();
    // v = 1000 with pulse divisor 3: 16 MHz · 1000 / (2^3 · 2048 · 32) = 30517 microsteps/s.
    assert_eq!(r.cmd(Opcode::Ror, 0, 0, 1000).0, Status::Ok);
    r.run(Duration::from_secs(3));
    assert_eq!(r.module.board().drive.velocity, 30517, "the driver sees microsteps per second");
    assert_eq!(r.cmd(Opcode::Gap, 3, 0, 0), (Status::Ok, 1000), "AP 3 reads in TMC428 units again");
    assert_eq!(r.cmd(Opcode::Gap, 2, 0, 0), (Status::Ok, 1000));
    assert_eq!(r.module.board().drive.resolution, 4, "16 microsteps (AP 140)");
    // Near the top of the 24-bit counter the position wraps to the bottom.
    r.cmd(Opcode::Mst, 0, 0, 0);
    r.run(Duration::from_secs(3));
    assert_eq!(r.cmd(Opcode::Sap, 1, 0, (1 << 23) - 1000).0, Status::Ok);
    r.cmd(Opcode::Ror, 0, 0, 100);
    r.run(Duration::from_secs(1));
    let (_, p) = r.cmd(Opcode::Gap, 1, 0, 0);
    assert!((-(1 << 23)..0).contains(&p), "wrapped at 24 bits: {p}");
    // A move the shorter way round: from just below the top to just above the bottom is 2000 steps.
    r.cmd(Opcode::Mst, 0, 0, 0);
    r.run(Duration::from_secs(3));
    r.cmd(Opcode::Sap, 1, 0, (1 << 23) - 1000);
    let before = r.module.board().steps(4);
    assert_eq!(r.cmd(Opcode::Mvp, 0, 0, -(1 << 23) + 1000).0, Status::Ok);
    r.run(Duration::from_secs(5));
    assert_eq!(r.cmd(Opcode::Gap, 8, 0, 0), (Status::Ok, 1));
    assert_eq!(r.module.board().steps(4) - before, 2000);
}

#[test]
fn a_program_in_its_small_memory() {
    let mut r = Rig::new();
    let program = [
        Instruction::new(Opcode::Sio, 7, 2, 1),
        Instruction::new(Opcode::Calc, 9, 0, 42), // CALC LOAD, 42
        Instruction::new(Opcode::Agp, 63, 2, 0),  // AGP 63, 2
        Instruction::new(Opcode::Gio, 255, 0, 0), // A = inputs
        Instruction::new(Opcode::Agp, 62, 2, 0),
        Instruction::new(Opcode::Stop, 0, 0, 0),
    ];
    assert_eq!(r.cmd(Opcode::StartDownload, 0, 0, 0).0, Status::Ok);
    for i in program {
        assert_eq!(r.cmd(i.opcode, i.kind, i.motor, i.value).0, Status::Loaded);
    }
    // A command the model lacks is refused in download mode too, and not stored.
    assert_eq!(r.cmd(Opcode::Ei, 0, 0, 0).0, Status::InvalidCommand);
    assert_eq!(r.cmd(Opcode::QuitDownload, 0, 0, 0).0, Status::Ok);
    assert_eq!(r.cmd(Opcode::StartDownload, 0, 0, 127).0, Status::Ok, "the last of 128 cells");
    assert_eq!(r.cmd(Opcode::StartDownload, 0, 0, 128).0, Status::InvalidValue, "memory ends at 128");
    assert_eq!(r.cmd(Opcode::QuitDownload, 0, 0, 0).0, Status::Ok);
    r.module.board_mut().inputs = 0x5A;
    assert_eq!(r.cmd(Opcode::RunApplication, 1, 0, 0).0, Status::Ok);
    r.run(Duration::from_millis(10));
    assert_eq!(r.cmd(Opcode::Ggp, 128, 0, 0), (Status::Ok, 0), "stopped at STOP");
    assert_eq!(r.module.board().outputs, 0x80);
    assert_eq!(r.cmd(Opcode::Ggp, 63, 2, 0), (Status::Ok, 42));
    assert_eq!(r.cmd(Opcode::Ggp, 62, 2, 0), (Status::Ok, 0x5A));
}

#[test]
fn a_command_the_model_lacks_ends_a_program() {
    let mut r = Rig::new();
    // Tools load programs without the download checks; an EI (no interrupts here) still never runs.
    let program = [
        Instruction::new(Opcode::Calc, 9, 0, 5),
        Instruction::new(Opcode::Ei, 255, 0, 0),
        Instruction::new(Opcode::Calc, 9, 0, 6),
    ];
    r.module.load_program(&program).unwrap();
    assert_eq!(r.cmd(Opcode::RunApplication, 1, 0, 0).0, Status::Ok);
    r.run(Duration::from_millis(10));
    assert_eq!(r.cmd(Opcode::Ggp, 128, 0, 0), (Status::Ok, 0), "stopped");
    assert_eq!(r.cmd(Opcode::Ggp, 130, 0, 0), (Status::Ok, 1), "at the EI");
    assert_eq!(r.cmd(Opcode::GetStatus, 2, 0, 0), (Status::Ok, 5), "the accumulator from before it");
}

#[test]
fn the_ascii_line_with_its_command_set() {
    let mut r = Rig::new();
    assert_eq!(r.cmd(Opcode::EnterAscii, 0, 0, 0).0, Status::Ok);
    assert!(r.module.ascii_mode_on(0));
    assert_eq!(r.text("AGAP 154, 0\r"), "AGAP 154, 0\rBA 100 3\r");
    assert_eq!(r.text("ASIO 7, 2, 1\r"), "ASIO 7, 2, 1\rBA 100 1\r");
    assert_eq!(r.module.board().outputs, 0x80);
    assert_eq!(r.text("ASAP 250, 0, 5\r"), "ASAP 250, 0, 5\rBA 8 5\r", "protected");
    // SAC may be typed (its manual lists it) and reaches the emulated TMC428 of its driver: one byte is
    // no datagram (status 4), four are (the TMC429's type/version register, all motors at their targets).
    assert_eq!(r.text("ASAC 0, 1, 5\r"), "ASAC 0, 1, 5\rBA 4 5\r");
    assert_eq!(r.text("ASAC 0, 4, 1929379840\r"), "ASAC 0, 4, 1929379840\rBA 100 356684033\r");
    assert_eq!(r.text("ABIN\r"), "ABIN\rBA 100 0\r");
    assert!(!r.module.ascii_mode_on(0));
}

#[test]
fn two_interfaces_at_once() {
    let mut r = Rig::new();
    // The mailbox: 8 bytes in, 8 out (reply address, module address, status, command, value).
    assert_eq!(r.mailbox(Opcode::Gap, 4, 0, 0), [2, 1, 100, 6, 0, 0, 0x03, 0xE8]);
    assert_eq!(r.mailbox(Opcode::Sap, 6, 0, 0)[2], 3, "statuses as on any interface");
    // 136 type 0 in the mailbox: the 8 characters.
    assert_eq!(r.mailbox(Opcode::GetVersion, 0, 0, 0), b"0428V100");
    // ASCII on the serial interface does not change the mailbox, nor ASCII mode (139) in it.
    assert_eq!(r.cmd(Opcode::EnterAscii, 0, 0, 0).0, Status::Ok);
    assert_eq!(r.mailbox(Opcode::EnterAscii, 0, 0, 0)[2], 6, "no ASCII mode in a mailbox");
    assert_eq!(r.mailbox(Opcode::Gap, 154, 0, 0)[7], 3);
    // 134 in the mailbox: host address and the cell's 7 bytes, even when they all look like text (an AAP
    // cell whose bytes and checksum are printable is not taken for a version string).
    let cell = Instruction::new(Opcode::Aap, 33, 88, 0x2121_2121);
    r.module.load_program(&[cell]).unwrap();
    let mut read = vec![2];
    read.extend_from_slice(&cell.to_bytes());
    assert_eq!(r.mailbox(Opcode::ReadMemory, 0, 0, 0), read);
    // A 138 event goes back to the interface that asked for it.
    assert_eq!(r.mailbox(Opcode::RequestTargetReachedEvent, 0, 0, 1)[2], 100);
    assert_eq!(r.text("AMVP ABS, 0, 3200\r"), "AMVP ABS, 0, 3200\rBA 100 3200\r");
    let [serial, mailbox] = r.run(Duration::from_secs(5));
    assert!(serial.is_empty(), "nothing on the serial line: {serial:02X?}");
    assert_eq!(mailbox, [2, 1, 128, 138, 0, 0, 0, 1]);
    assert_eq!(r.text("AGAP 1, 0\r"), "AGAP 1, 0\rBA 100 3200\r");
}

#[test]
fn a_model_without_an_interface_drops_its_bytes() {
    let mut r = Rig::new();
    let mut out = Vec::new();
    let frame = Request { address: 1, instruction: Instruction::new(Opcode::Gap, 4, 0, 0) }.to_bytes();
    // Beyond every port the core keeps (with the feature `host-links`, port 2 is a host link).
    r.module.receive_on(tmcl_core::iface::PORTS, r.now, &frame, &mut |b: &[u8]| out.extend_from_slice(b));
    r.module.receive_on(1, r.now, &frame, &mut |b: &[u8]| out.extend_from_slice(b));
    r.module.request(0, r.now, &[1, 6, 4, 0, 0, 0, 0, 0], &mut |b: &[u8]| out.extend_from_slice(b));
    assert!(out.is_empty(), "no interface 2; port 1 takes whole messages; port 0 takes a byte stream");
    assert_eq!(r.cmd(Opcode::Gap, 4, 0, 0), (Status::Ok, 1000));
}

#[test]
fn a_model_without_an_address_setting_is_module_1() {
    let mut r = Rig::new();
    assert_eq!(r.module.set_address(1, r.now), Ok(()));
    assert_eq!(r.module.set_address(2, r.now), Err(Status::NotAvailable));
    assert_eq!(r.module.address(), 1);
    assert_eq!(r.cmd(Opcode::Gap, 1, 0, 0).0, Status::Ok);
}

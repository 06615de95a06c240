//! Fixtures and state tests of the whole module: a module on a test board, driven with
//! frames and time exactly as a host would.

mod ascii;
mod axes;
mod backlog;
mod commands;
mod params;
mod reference;
mod vm;
mod wire;

use crate::hal::{
    Analog, DriveState, EncoderCounter, Inputs, LoadSensor, Nvm, Outputs, StepDriver, SwitchInputs, Switches,
};
use crate::model::pd28_1021::SPEC;
use crate::param::persist;
use crate::time::{Duration, Instant};
use crate::Module;
use std::vec::Vec;
use tmcl_wire::{Command, Instruction, Opcode, Reply, ReplyFrame, Request, Status};

/// A RAM EEPROM (erased = 0xFF) that can be made to fail.
#[derive(Debug, Clone)]
pub struct RamNvm {
    pub bytes: Vec<u8>,
    pub fail_writes: bool,
    pub writes: usize,
}

impl Nvm for RamNvm {
    type Error = ();
    fn capacity(&self) -> usize {
        self.bytes.len()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), ()> {
        buf.copy_from_slice(self.bytes.get(offset..offset + buf.len()).ok_or(())?);
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), ()> {
        if self.fail_writes {
            return Err(());
        }
        self.writes += 1;
        self.bytes.get_mut(offset..offset + data.len()).ok_or(())?.copy_from_slice(data);
        Ok(())
    }
}

/// A test board: an ideal motor whose physical position integrates the steps, switches set by the test.
#[derive(Debug, Clone)]
pub struct TestBoard {
    pub nvm: RamNvm,
    pub inputs: u8,
    pub analog: u16,
    pub outputs: u8,
    pub switches: Switches,
    /// Switch zones in physical 1/256 microsteps; a switch reads pressed inside its zone (or if set).
    pub zones: [Option<core::ops::RangeInclusive<i64>>; 3],
    pub drive: DriveState,
    /// Physical position in 1/256 microsteps.
    pub physical: i64,
    pub updates: usize,
    /// A breakpoint behind the board's hook: the program stops before this address once.
    pub stop_at: Option<u16>,
    /// The hook stopped the program (cleared when it lets it pass).
    pub stopped: bool,
    /// The board says it is quiet for good while the motor stands (`StepDriver::quiet`).
    pub quiet: bool,
}

impl TestBoard {
    pub fn new() -> TestBoard {
        TestBoard {
            nvm: RamNvm { bytes: std::vec![0xFF; persist::capacity(&SPEC)], fail_writes: false, writes: 0 },
            inputs: 0,
            analog: 0,
            outputs: 0,
            switches: Switches::default(),
            zones: [None, None, None],
            drive: DriveState::default(),
            physical: 0,
            updates: 0,
            stop_at: None,
            stopped: false,
            quiet: false,
        }
    }
}

impl Nvm for TestBoard {
    type Error = ();
    fn capacity(&self) -> usize {
        self.nvm.capacity()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), ()> {
        self.nvm.read(offset, buf)
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), ()> {
        self.nvm.write(offset, data)
    }
}

impl Inputs for TestBoard {
    fn digital_inputs(&mut self) -> u8 {
        self.inputs
    }
}

impl Analog for TestBoard {
    fn analog_input(&mut self, _channel: u8) -> u16 {
        self.analog
    }
    fn temperature(&mut self) -> i32 {
        25
    }
}

impl Outputs for TestBoard {
    fn set_outputs(&mut self, bits: u8) {
        self.outputs = bits;
    }
}

impl SwitchInputs for TestBoard {
    fn switches(&mut self, _motor: usize) -> Switches {
        let at = |z: &Option<core::ops::RangeInclusive<i64>>| z.as_ref().is_some_and(|z| z.contains(&self.physical));
        Switches {
            left: self.switches.left || at(&self.zones[0]),
            right: self.switches.right || at(&self.zones[1]),
            home: self.switches.home || at(&self.zones[2]),
        }
    }
}

/// The hook, as a debugger would fill it in: one breakpoint that stops the program once.
impl crate::hal::Hook for TestBoard {
    fn watches_instructions(&self) -> bool {
        self.stop_at.is_some()
    }
    fn stop_before(&mut self, pc: u16) -> bool {
        if self.stop_at == Some(pc) {
            self.stopped = !self.stopped;
            return self.stopped;
        }
        false
    }
}

impl StepDriver for TestBoard {
    fn update(&mut self, _motor: usize, _now: Instant, state: &DriveState) {
        let scale = 1i64 << (8 - state.resolution.min(8));
        let moved = state.moved * scale;
        self.physical += if state.reverse { -moved } else { moved };
        self.drive = *state;
        self.updates += 1;
    }
    fn quiet(&mut self, _motor: usize, _now: Instant, state: &DriveState) -> Option<crate::hal::Quiet> {
        (self.quiet && state.velocity == 0).then_some(crate::hal::Quiet {
            until: None,
            forward: 0,
            backward: 0,
            min_speed: 0,
            max_speed: 0,
            load: 700,
        })
    }
}

impl LoadSensor for TestBoard {
    fn load(&mut self, _motor: usize) -> u16 {
        700
    }
}

impl EncoderCounter for TestBoard {
    fn encoder_counts(&mut self, _motor: usize) -> i64 {
        // 51200 physical 1/256 microsteps per revolution (200 full steps), 1024 counts per revolution.
        self.physical.div_euclid(50)
    }
}

/// A module on a test board with a host clock.
pub struct Bench {
    pub module: Module<TestBoard>,
    pub now: Instant,
    pub out: Vec<u8>,
}

impl Bench {
    pub fn new() -> Bench {
        Bench::with_board(TestBoard::new())
    }

    pub fn with_board(board: TestBoard) -> Bench {
        let now = Instant::from_secs(1);
        Bench { module: Module::new(board, &SPEC, now), now, out: Vec::new() }
    }

    /// Power-cycles: same board (EEPROM), fresh firmware state.
    pub fn power_cycle(&mut self) {
        let board = self.module.board().clone();
        self.module = Module::new(board, &SPEC, self.now);
        self.out.clear();
    }

    /// Sends raw bytes and returns everything the module sent back at once.
    pub fn bytes(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        self.module.receive(self.now, bytes, &mut |b: &[u8]| out.extend_from_slice(b));
        // A reply held back by the telegram pause (GP 75): wait for it, as a host would.
        while out.is_empty() {
            let Some(due) = self.module.state().port(0).and_then(|p| p.outbox.next_due()) else { break };
            self.now = due;
            self.module.poll(self.now, &mut |b: &[u8]| out.extend_from_slice(b));
        }
        out
    }

    /// Sends a request frame to `address` and returns the parsed reply, if any.
    pub fn to(&mut self, address: u8, op: Opcode, t: u8, m: u8, v: i32) -> Option<Reply> {
        let frame = Request { address, instruction: Instruction::new(op, t, m, v) }.to_bytes();
        let out = self.bytes(&frame);
        match out.len() {
            0 => None,
            9 => Some(Reply::parse(&ReplyFrame::new_checked(&out[..]).unwrap()).expect("reply checksum")),
            n => panic!("{n} bytes of reply: {out:02X?}"),
        }
    }

    /// Sends to address 1 and expects a reply.
    pub fn send(&mut self, op: Opcode, t: u8, m: u8, v: i32) -> Reply {
        self.to(1, op, t, m, v).expect("a reply")
    }

    /// Sends a command to `address`; the reply, if any.
    pub fn cmd_to(&mut self, address: u8, c: Command) -> Option<Reply> {
        let i = c.encode();
        self.to(address, i.opcode, i.kind, i.motor, i.value)
    }

    /// Sends a command and returns (status, value).
    pub fn cmd(&mut self, c: Command) -> (Status, i32) {
        let i = c.encode();
        let r = self.send(i.opcode, i.kind, i.motor, i.value);
        (r.status, r.value)
    }

    pub fn gap(&mut self, n: u8) -> i32 {
        let (s, v) = self.cmd(Command::Gap { param: n, motor: 0 });
        assert_eq!(s, Status::Ok, "GAP {n}");
        v
    }

    pub fn sap(&mut self, n: u8, v: i32) -> Status {
        self.cmd(Command::Sap { param: n, motor: 0, value: v }).0
    }

    pub fn ggp(&mut self, n: u8, bank: u8) -> i32 {
        let (s, v) = self.cmd(Command::Ggp { param: n, bank });
        assert_eq!(s, Status::Ok, "GGP {n}, {bank}");
        v
    }

    pub fn sgp(&mut self, n: u8, bank: u8, v: i32) -> Status {
        self.cmd(Command::Sgp { param: n, bank, value: v }).0
    }

    /// Advances simulated time, collecting what the module sends.
    pub fn run(&mut self, d: Duration) {
        let end = self.now + d;
        let mut out = Vec::new();
        loop {
            let next = self.module.poll(self.now, &mut |b: &[u8]| out.extend_from_slice(b));
            match next {
                Some(t) if t <= end => self.now = t.max(self.now + Duration::from_micros(1)),
                _ => break,
            }
        }
        self.now = end;
        self.module.poll(self.now, &mut |b: &[u8]| out.extend_from_slice(b));
        self.out.extend_from_slice(&out);
    }
}

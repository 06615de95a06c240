//! The firmware core on a board of your own: the eight small hardware traits of `tmcl_core::hal` on a
//! RAM EEPROM and an ideal motor, then `ROR 0, 1000` as nine bytes from a host (PD28-1021 TMCL firmware
//! manual §3.7.1), simulated time passed in, and `GAP 1, 0` (actual position, §4 Table 15) read back.
//!
//! A port to a microcontroller implements the same traits on its peripherals (see `firmware/`);
//! `tmcl-sim`'s `SimBoard` implements them on a stepper model with a world around it.
//!
//! Run with `cargo run -p tmcl-core --example own_board`.

use tmcl_core::hal::{
    Analog, DriveState, EncoderCounter, Inputs, LoadSensor, Nvm, Outputs, StepDriver, SwitchInputs, Switches,
};
use tmcl_core::model::pd28_1021;
use tmcl_core::param::persist;
use tmcl_core::{Duration, Instant, Module};
use tmcl_wire::{Command, Reply, ReplyFrame, Request};

/// A board: an EEPROM in RAM (erased, 0xFF) and a motor that follows every step.
struct Bench {
    eeprom: Vec<u8>,
    /// The motor's position in 1/256 microsteps.
    position: i64,
}

impl Nvm for Bench {
    type Error = ();
    fn capacity(&self) -> usize {
        self.eeprom.len()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), ()> {
        buf.copy_from_slice(self.eeprom.get(offset..offset + buf.len()).ok_or(())?);
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), ()> {
        self.eeprom.get_mut(offset..offset + data.len()).ok_or(())?.copy_from_slice(data);
        Ok(())
    }
}
impl Inputs for Bench {
    fn digital_inputs(&mut self) -> u8 {
        0
    }
}
impl Outputs for Bench {
    fn set_outputs(&mut self, _bits: u8) {}
}
impl Analog for Bench {
    fn analog_input(&mut self, _channel: u8) -> u16 {
        0
    }
    fn temperature(&mut self) -> i32 {
        25
    }
}
impl SwitchInputs for Bench {
    fn switches(&mut self, _motor: usize) -> Switches {
        Switches::default()
    }
}
/// No simulator's shortcuts (the hook's defaults do nothing).
impl tmcl_core::hal::Hook for Bench {}

impl StepDriver for Bench {
    /// The firmware reports the microsteps it made since the last update.
    fn update(&mut self, _motor: usize, _now: Instant, state: &DriveState) {
        let moved = state.moved << (8 - state.resolution.min(8));
        self.position += if state.reverse { -moved } else { moved };
    }
}
impl LoadSensor for Bench {}
impl EncoderCounter for Bench {}

fn main() {
    let spec = &pd28_1021::SPEC;
    let board = Bench { eeprom: vec![0xFF; persist::capacity(spec)], position: 0 };
    let mut module = Module::new(board, spec, Instant::ZERO);

    // A host sends ROR 0, 1000 to module 1; the reply goes to the sink.
    let mut replies = Vec::new();
    let ror = Request { address: 1, instruction: Command::Ror { motor: 0, velocity: 1000 }.encode() };
    module.receive(Instant::ZERO, &ror.to_bytes(), &mut |bytes: &[u8]| replies.extend_from_slice(bytes));

    // Time is passed in: poll at each deadline the module asks for, here up to two simulated seconds.
    let end = Instant::ZERO + Duration::from_millis(2000);
    let mut now = Instant::ZERO;
    while now < end {
        let next = module.poll(now, &mut |bytes: &[u8]| replies.extend_from_slice(bytes));
        now = next.map_or(end, |n| n.min(end)).max(now + Duration::from_millis(1));
    }
    module.poll(end, &mut |bytes: &[u8]| replies.extend_from_slice(bytes));

    let gap = Request { address: 1, instruction: Command::Gap { param: 1, motor: 0 }.encode() };
    module.receive(end, &gap.to_bytes(), &mut |bytes: &[u8]| replies.extend_from_slice(bytes));
    for frame in replies.chunks_exact(9) {
        let reply = Reply::parse(&ReplyFrame::new_unchecked(frame)).expect("the module's checksum is right");
        println!("reply to command {:>3}: status {} value {}", reply.opcode, u8::from(reply.status), reply.value);
    }
    println!("motor at {} 1/256 microsteps after 2 s", module.board().position);
    assert!(module.board().position > 0);
}

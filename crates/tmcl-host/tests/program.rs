//! The program commands of the client against a real firmware core, in process: a transport that feeds
//! a simulated module and advances its clock by the time the host waits.

use std::collections::VecDeque;
use std::io;
use std::time::Duration;
use tmcl_core::model::pd28_1021::SPEC;
use tmcl_core::param::persist;
use tmcl_core::{Instant, Module};
use tmcl_host::{Client, HostError, Transport};
use tmcl_sim::SimBoard;
use tmcl_wire::{CalcOp, Command, Instruction, MoveTarget, Status, WaitCondition};

struct InProcess {
    module: Module<SimBoard>,
    now: Instant,
    rx: VecDeque<u8>,
}

impl InProcess {
    fn new() -> InProcess {
        InProcess {
            module: Module::new(SimBoard::in_memory(persist::capacity(&SPEC)), &SPEC, Instant::ZERO),
            now: Instant::ZERO,
            rx: VecDeque::new(),
        }
    }

    fn advance(&mut self, d: Duration) {
        self.now += tmcl_core::Duration::from_micros(d.as_micros() as u64);
        let rx = &mut self.rx;
        self.module.poll(self.now, &mut |b: &[u8]| rx.extend(b));
    }
}

impl Transport for InProcess {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        let rx = &mut self.rx;
        self.module.receive(self.now, bytes, &mut |b: &[u8]| rx.extend(b));
        Ok(())
    }

    fn recv_exact(&mut self, buf: &mut [u8], timeout: Duration) -> Result<(), HostError> {
        if self.rx.len() < buf.len() {
            self.advance(timeout);
        }
        if self.rx.len() < buf.len() {
            let received = self.rx.len();
            for (slot, b) in buf.iter_mut().zip(self.rx.drain(..)) {
                *slot = b;
            }
            return Err(HostError::Timeout { waited: timeout, received });
        }
        for b in buf.iter_mut() {
            *b = self.rx.pop_front().unwrap_or_default();
        }
        Ok(())
    }

    fn clear_input(&mut self) {
        self.rx.clear();
    }
}

fn program() -> Vec<Instruction> {
    [
        Command::Calc { op: CalcOp::Load, operand: 7 },
        Command::Agp { param: 3, bank: 2 },
        Command::Mvp { motor: 0, target: MoveTarget::Abs(1000) },
        Command::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        Command::Stop,
    ]
    .iter()
    .map(Command::encode)
    .collect()
}

#[test]
fn download_read_back_run_and_status() {
    let mut client = Client::new(InProcess::new()).with_timeout(Duration::from_millis(100));
    let mut seen = 0;
    client.download_program(&program(), 0, |n| seen = n).unwrap();
    assert_eq!(seen, 5);
    assert_eq!(client.upload_program(2048, |_| {}).unwrap(), program());
    assert_eq!(client.application_status().unwrap().mode, 0);
    client.run_program(Some(0)).unwrap();
    client.transport_mut().advance(Duration::from_millis(500));
    assert_eq!(client.get_global_parameter(3, 2).unwrap(), 7);
    assert_eq!(client.get_axis_parameter(1, 0).unwrap(), 1000);
    let status = client.application_status().unwrap();
    assert_eq!((status.mode_name(), status.pc, status.accumulator), ("stopped", 4, 7));
}

#[test]
fn protected_program_is_not_read_back() {
    let mut client = Client::new(InProcess::new()).with_timeout(Duration::from_millis(100));
    client.download_program(&program(), 0, |_| {}).unwrap();
    client.set_global_parameter(81, 0, 1).unwrap();
    match client.read_program_memory(0) {
        Err(HostError::Status { status, .. }) => assert_eq!(status, Status::NotAvailable),
        other => panic!("{other:?}"),
    }
    // The client is still in step with the module.
    assert_eq!(client.get_global_parameter(81, 0).unwrap(), 1);
}

#[test]
fn download_of_an_invalid_instruction_leaves_download_mode() {
    let mut client = Client::new(InProcess::new()).with_timeout(Duration::from_millis(100));
    let bad = [Instruction::new(tmcl_wire::Opcode::Mvp, 9, 0, 0)];
    assert!(matches!(
        client.download_program(&bad, 0, |_| {}),
        Err(HostError::Status { status: Status::WrongType, .. })
    ));
    assert_eq!(client.get_global_parameter(129, 0).unwrap(), 0, "not in download mode any more");
}

//! Standalone programs on a module: download, read back, run, stop, status (PD28-1021 manual §3.7.38,
//! commands 128–135).

use super::{checksum_error, checksum_ok, parse_reply, Client, Received};
use crate::error::HostError;
use crate::transport::Transport;
use std::time::Instant;
use tmcl_wire::{Command, Instruction, Opcode, Status, StatusKind};

/// The application status (command 135 and GP 128–130), decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ApplicationStatus {
    /// 0 stop, 1 run, 2 step, 3 reset (GP 128).
    pub mode: u8,
    /// A WAIT is pending.
    pub waiting: bool,
    /// The program counter.
    pub pc: u16,
    /// The accumulator (135 type 2).
    pub accumulator: i32,
    /// The X register (135 type 3).
    pub x: i32,
}

impl ApplicationStatus {
    /// The mode in words.
    pub fn mode_name(&self) -> &'static str {
        Self::name_of(self.mode)
    }

    /// A mode (0 stop, 1 run, 2 step, 3 reset: 135's mode byte, GP 128) in words.
    pub fn name_of(mode: u8) -> &'static str {
        match mode {
            0 => "stopped",
            1 => "running",
            2 => "stepped",
            3 => "reset",
            _ => "unknown",
        }
    }
}

impl<T: Transport> Client<T> {
    /// Downloads `program` from `start` (commands 132, then each instruction answered with status 101,
    /// then 133). `progress` is called with the number of instructions stored so far.
    pub fn download_program(
        &mut self,
        program: &[Instruction],
        start: u16,
        mut progress: impl FnMut(usize),
    ) -> Result<(), HostError> {
        self.request(Command::StartDownload { address: i32::from(start) }.encode())?;
        let result = (|| {
            for (n, i) in program.iter().enumerate() {
                let reply = self.request(*i)?;
                if reply.status != Status::Loaded {
                    return Err(HostError::Status { status: reply.status, reply });
                }
                progress(n + 1);
            }
            Ok(())
        })();
        // Leave download mode even after an error, so the module executes commands again.
        let quit = self.request(Command::QuitDownload.encode());
        result.and(quit.map(drop))
    }

    /// Command 134: the instruction at `address`. The reply is the special layout
    /// `[host, opcode, type, motor, value, checksum]`; an error reply (status < 100 for opcode 134, e.g.
    /// when the program is protected) is told apart by its module address and opcode bytes. The special
    /// layout has no module address, so a late reply cannot be told from it: the line is drained first
    /// if a timeout left it unclean.
    pub fn read_program_memory(&mut self, address: u16) -> Result<Instruction, HostError> {
        self.send(Command::ReadMemory { address: i32::from(address) }.encode())?;
        let deadline = Instant::now() + self.timeout;
        let frame = match self.next_frame(deadline, checksum_ok)? {
            Some(Received::Frame(frame)) => frame,
            Some(Received::Damaged(frame)) => return Err(checksum_error(&frame)),
            None => return Err(self.timed_out(None)),
        };
        let looks_like_error =
            frame[1] == self.module_address && frame[3] == u8::from(Opcode::ReadMemory) && (1..100).contains(&frame[2]);
        if looks_like_error {
            let reply = parse_reply(&frame)?;
            return Err(HostError::Status { status: reply.status, reply });
        }
        let mut seven = [0u8; 7];
        seven.copy_from_slice(&frame[1..8]);
        Ok(Instruction::from_bytes(seven))
    }

    /// Reads the program back from address 0 up to the first empty cell (opcode 0) or `limit` cells.
    pub fn upload_program(
        &mut self,
        limit: u16,
        mut progress: impl FnMut(usize),
    ) -> Result<Vec<Instruction>, HostError> {
        let mut out = Vec::new();
        for address in 0..limit {
            let i = self.read_program_memory(address)?;
            if u8::from(i.opcode) == 0 {
                break;
            }
            out.push(i);
            progress(out.len());
        }
        Ok(out)
    }

    /// Command 129: run from the current address (`None`) or from `address`.
    pub fn run_program(&mut self, address: Option<u16>) -> Result<(), HostError> {
        self.run(Command::RunApplication { from: address.map(i32::from) })
    }

    /// Command 128: stop the program.
    pub fn stop_program(&mut self) -> Result<(), HostError> {
        self.run(Command::StopApplication)
    }

    /// Command 131: reset the program (PC 0, registers cleared).
    pub fn reset_program(&mut self) -> Result<(), HostError> {
        self.run(Command::ResetApplication)
    }

    /// Command 130: execute one instruction.
    pub fn step_program(&mut self) -> Result<(), HostError> {
        self.run(Command::StepApplication)
    }

    /// Commands 135 types 1–3: mode, wait flag, PC, accumulator, X.
    pub fn application_status(&mut self) -> Result<ApplicationStatus, HostError> {
        let packed = self.value_of(Command::GetStatus { kind: StatusKind::ProgramCounter })?;
        Ok(ApplicationStatus {
            mode: (packed >> 24) as u8,
            waiting: (packed >> 16) & 0xFF != 0,
            pc: packed as u16,
            accumulator: self.value_of(Command::GetStatus { kind: StatusKind::Accumulator })?,
            x: self.value_of(Command::GetStatus { kind: StatusKind::XRegister })?,
        })
    }
}

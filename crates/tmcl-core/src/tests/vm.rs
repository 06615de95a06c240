//! Standalone mode: download, run, the program machine's rules (manual §3.6, §3.7.16–3.7.38, chapter 8).

use super::*;
use crate::module::flags;
use crate::vm::RunState;
use tmcl_wire::{CalcOp, CalcxOp, Condition, ErrorFlag, MoveTarget, WaitCondition};

/// Downloads a program with commands 132/133 (each stored command answers status 101).
fn download(b: &mut Bench, program: &[Command]) {
    assert_eq!(b.send(Opcode::StartDownload, 0, 0, 0).status, Status::Ok);
    for c in program {
        let i = c.encode();
        let r = b.send(i.opcode, i.kind, i.motor, i.value);
        assert_eq!(r.status, Status::Loaded, "{c:?}");
    }
    // GP 129 cannot be asked now: a GGP would be stored too. The machine says it.
    assert!(b.module.vm().download_address().is_some());
    assert_eq!(b.send(Opcode::QuitDownload, 0, 0, 0).status, Status::Ok);
    assert_eq!(b.ggp(129, 0), 0);
}

fn run_from(b: &mut Bench, address: i32) {
    assert_eq!(b.cmd(Command::RunApplication { from: Some(address) }).0, Status::Ok);
}

use Command as C;

/// §2.4 "first steps" program: rotate, then move between ±512000 forever.
fn first_steps() -> Vec<Command> {
    vec![
        C::Rol { motor: 0, velocity: 51200 },
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 500 },
        C::Mst { motor: 0 },
        C::Ror { motor: 0, velocity: 5120 },
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 500 },
        C::Mst { motor: 0 },
        C::Sap { param: 4, motor: 0, value: 51200 },
        C::Sap { param: 5, motor: 0, value: 51200 },
        C::Mvp { motor: 0, target: MoveTarget::Abs(512_000) },
        C::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        C::Mvp { motor: 0, target: MoveTarget::Abs(-512_000) },
        C::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        C::Ja { address: 8 },
    ]
}

#[test]
fn manual_first_steps_alternates() {
    let mut b = Bench::new();
    download(&mut b, &first_steps());
    run_from(&mut b, 0);
    assert_eq!(b.ggp(128, 0), 1, "running");
    b.run(Duration::from_secs(3));
    assert!(b.gap(1) < 0, "ROL first: {}", b.gap(1));
    // Every MVP's arrival is reported by 138 (also for a program's MVPs).
    b.send(Opcode::RequestTargetReachedEvent, 1, 0, 1);
    b.out.clear();
    // Rotation phases (10 s), then moves of 1 024 000 µsteps (about 21 s each).
    let (mut targets, mut lo, mut hi) = (Vec::new(), 0, 0);
    for _ in 0..900 {
        b.run(Duration::from_millis(100));
        let (t, p) = (b.gap(0), b.gap(1));
        (lo, hi) = (lo.min(p), hi.max(p));
        if targets.last() != Some(&t) {
            targets.push(t);
        }
    }
    let targets: Vec<i32> = targets.into_iter().filter(|t| t.abs() == 512_000).collect();
    assert!(targets.len() >= 4, "targets {targets:?}");
    assert!(targets.windows(2).all(|w| w[0] == -w[1]), "alternates: {targets:?}");
    assert!(lo <= -500_000 && hi >= 500_000, "{lo}..{hi}");
    // One status-128 frame per arrival.
    assert!(b.out.len() / 9 >= targets.len() - 1, "{} events", b.out.len() / 9);
}

#[test]
fn timer_interrupt_toggles_out0() {
    // §3.6.6.4 example, with OUT0 (the listing's SIO 3 is not a port of this module, which has OUT0 and
    // OUT1 only: those SIOs fail and the program goes on).
    let program = vec![
        C::Vect { interrupt: 0, address: 9 },
        C::Sgp { param: 0, bank: 3, value: 1000 },
        C::Ei { interrupt: 0 },
        C::Ei { interrupt: 255 },
        C::Sio { port: 3, bank: 2, value: 1 }, // Loop = 4
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 50 },
        C::Sio { port: 3, bank: 2, value: 0 },
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 50 },
        C::Ja { address: 4 },
        C::Gio { port: 0, bank: 2 }, // Timer0Irq = 9
        C::Jc { condition: Condition::NotZero, address: 13 },
        C::Sio { port: 0, bank: 2, value: 1 },
        C::Reti,
        C::Sio { port: 0, bank: 2, value: 0 }, // Out0Off = 13
        C::Reti,
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    run_from(&mut b, 0);
    let mut levels = Vec::new();
    b.run(Duration::from_millis(250));
    for _ in 0..8 {
        b.run(Duration::from_millis(500));
        levels.push(b.module.board().outputs & 1);
    }
    // Toggles once a second: high for 1 s, low for 1 s.
    assert_eq!(levels, [0, 1, 1, 0, 0, 1, 1, 0]);
    assert!(!b.module.vm().in_handler());
}

#[test]
fn jump_table_entry_points() {
    // §8.6 example: routines called with 129 type 1 at addresses 0, 1, 2.
    let program = vec![
        C::Ja { address: 3 },
        C::Ja { address: 8 },
        C::Ja { address: 12 },
        C::Mvp { motor: 0, target: MoveTarget::Abs(1000) }, // Func1Start = 3
        C::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        C::Mvp { motor: 0, target: MoveTarget::Abs(0) },
        C::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 0 },
        C::Stop,
        C::Rol { motor: 0, velocity: 500 }, // Func2Start = 8
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 100 },
        C::Mst { motor: 0 },
        C::Stop,
        C::Ror { motor: 0, velocity: 1000 }, // Func3Start = 12
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 700 },
        C::Mst { motor: 0 },
        C::Stop,
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    // 01 81 01 00 00 00 00 00 83: run at 0.
    assert_eq!(b.bytes(&[0x01, 0x81, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x83])[2], 100);
    b.run(Duration::from_millis(100));
    assert!(b.gap(1) > 0 && b.gap(0) == 1000);
    b.run(Duration::from_secs(3));
    assert_eq!((b.gap(1), b.ggp(128, 0)), (0, 0), "back at 0 and stopped");
    run_from(&mut b, 1);
    b.run(Duration::from_millis(500));
    assert_eq!(b.gap(2), -500, "Func2 turns left");
    b.run(Duration::from_secs(2));
    assert_eq!(b.ggp(128, 0), 0);
    run_from(&mut b, 2);
    b.run(Duration::from_millis(500));
    assert_eq!(b.gap(2), 1000, "Func3 turns right");
}

#[test]
fn subroutine_stack_is_8_deep() {
    // A subroutine that calls itself until the stack (8 deep) is full.
    let program = vec![
        C::Csub { address: 3 },                                     // 0
        C::Stop,                                                    // 1
        C::Stop,                                                    // 2
        C::Calc { op: CalcOp::Add, operand: 1 },                    // 3: depth counter
        C::Comp { operand: 9 },                                     // 4
        C::Jc { condition: Condition::GreaterOrEqual, address: 7 }, // 5
        C::Csub { address: 3 },                                     // 6: recurse (the 9th is ignored and falls through)
        C::Calc { op: CalcOp::Add, operand: 100 },                  // 7: count returns (and the fall-through)
        C::Rsub,                                                    // 8
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(100));
    assert_eq!(b.ggp(128, 0), 0, "stopped at address 1");
    assert_eq!(b.module.vm().pc, 1);
    let a = b.module.registers().accumulator;
    // CSUBs at 0 and 6 reach depth 8: eight entries (A = 8). The ninth CSUB is ignored (stack full) and
    // falls through to 7; then 7 returns land on 7 and the last on 1: 8 × 100 through address 7.
    assert_eq!(a, 8 + 800, "{a}");
    assert_eq!(b.module.vm().stack_depth(), 0);
}

#[test]
fn rsub_on_empty_stack_is_ignored() {
    let mut b = Bench::new();
    download(&mut b, &[C::Rsub, C::Calc { op: CalcOp::Load, operand: 7 }, C::Stop]);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.registers().accumulator, 7);
}

#[test]
fn reading_commands_load_the_accumulator_only_in_programs() {
    let mut b = Bench::new();
    b.sap(4, 4321);
    download(&mut b, &[C::Gap { param: 4, motor: 0 }, C::Stop]);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.registers().accumulator, 4321);
    // A host GAP does not touch A; a host CALC works on the host's registers.
    b.gap(1);
    b.cmd(C::Calc { op: CalcOp::Load, operand: 5 });
    assert_eq!(b.module.registers().accumulator, 4321);
    assert_eq!(b.module.host_registers().accumulator, 5);
    // 135 type 2/3: the program's A and X.
    assert_eq!(b.send(Opcode::GetStatus, 2, 0, 0).value, 4321);
}

#[test]
fn flags_comp_jc_and_loads() {
    // A = 5; COMP 5 → EQ; COMP 9 → LT; load 0 → ZE; load −1 → LT (a load compares with 0, as the §3.6.6.4
    // example's GIO then JC NZ implies).
    let program = vec![
        C::Calc { op: CalcOp::Load, operand: 5 },
        C::Comp { operand: 5 },
        C::Jc { condition: Condition::Equal, address: 4 },
        C::Stop,
        C::Comp { operand: 9 }, // 4
        C::Jc { condition: Condition::Lower, address: 7 },
        C::Stop,
        C::Calc { op: CalcOp::Load, operand: 0 }, // 7
        C::Jc { condition: Condition::Zero, address: 10 },
        C::Stop,
        C::Calc { op: CalcOp::Sub, operand: 1 }, // 10
        C::Jc { condition: Condition::LowerOrEqual, address: 13 },
        C::Stop,
        C::Calcx { op: CalcxOp::Load }, // 13: X = −1
        C::Calc { op: CalcOp::Load, operand: 3 },
        C::Calcx { op: CalcxOp::Mul }, // A = −3
        C::Jc { condition: Condition::Greater, address: 18 },
        C::Calc { op: CalcOp::Add, operand: 1000 }, // reached: −3 is not > 0
        C::Stop,                                    // 18
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.registers().accumulator, 997);
    assert_eq!(b.module.registers().x, -1);
}

#[test]
fn wait_timeout_sets_eto() {
    let program = vec![
        C::Mvp { motor: 0, target: MoveTarget::Abs(10_000_000) },
        C::Wait { condition: WaitCondition::Pos, motor: 0, ticks: 20 }, // 200 ms, far too short
        C::Jc { condition: Condition::Timeout, address: 4 },
        C::Stop,
        C::Calc { op: CalcOp::Load, operand: 1 }, // 4
        C::Cle { flag: ErrorFlag::Timeout },
        C::Jc { condition: Condition::Timeout, address: 0 },
        C::Stop,
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(150));
    assert_eq!(b.module.vm().pc, 1, "still waiting");
    assert!(b.module.vm().wait.is_some());
    b.run(Duration::from_millis(100));
    assert_eq!(b.module.registers().accumulator, 1);
    assert_eq!(b.module.registers().flags & flags::TIMEOUT, 0, "CLE ETO cleared it");
    assert_eq!(b.ggp(128, 0), 0);
}

#[test]
fn wait_ticks_from_the_accumulator() {
    let program = vec![
        C::Calc { op: CalcOp::Load, operand: 30 },
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: -1 }, // 300 ms
        C::Sio { port: 0, bank: 2, value: 1 },
        C::Stop,
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(290));
    assert_eq!(b.module.board().outputs, 0);
    b.run(Duration::from_millis(20));
    assert_eq!(b.module.board().outputs, 1);
}

#[test]
fn interrupt_priority_no_nesting_and_context() {
    // Timers 1 and 2 both fire at 100 ms; 1 has priority. Each handler adds to a user variable (so the
    // main loop's registers can be checked untouched); the main loop keeps A = 42.
    let program = vec![
        C::Vect { interrupt: 1, address: 7 },
        C::Vect { interrupt: 2, address: 12 },
        C::Sgp { param: 1, bank: 3, value: 100 },
        C::Sgp { param: 2, bank: 3, value: 100 },
        C::Ei { interrupt: 1 },
        C::Ei { interrupt: 2 },
        C::Ei { interrupt: 255 },
        // 7: handler 1: var0 = var0 * 10 + 1
        C::Ggp { param: 0, bank: 2 },
        C::Calc { op: CalcOp::Mul, operand: 10 },
        C::Calc { op: CalcOp::Add, operand: 1 },
        C::Agp { param: 0, bank: 2 },
        C::Reti,
        // 12: handler 2: var0 = var0 * 10 + 2
        C::Ggp { param: 0, bank: 2 },
        C::Calc { op: CalcOp::Mul, operand: 10 },
        C::Calc { op: CalcOp::Add, operand: 2 },
        C::Agp { param: 0, bank: 2 },
        C::Reti,
    ];
    // The main loop lives after the handlers: 17: A = 42, 18: JA 18.
    let mut program = program;
    program.insert(7, C::Ja { address: 18 });
    // Fix the addresses after the insertion: handlers moved by one.
    program[0] = C::Vect { interrupt: 1, address: 8 };
    program[1] = C::Vect { interrupt: 2, address: 13 };
    program.push(C::Calc { op: CalcOp::Load, operand: 42 }); // 18
    program.push(C::Ja { address: 19 }); // 19: loop
    program[7] = C::Ja { address: 18 };
    let mut b = Bench::new();
    download(&mut b, &program);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(150));
    assert_eq!(b.ggp(0, 2), 12, "timer 1 first, then timer 2");
    b.run(Duration::from_millis(100));
    assert_eq!(b.ggp(0, 2), 1212);
    assert_eq!(b.module.registers().accumulator, 42, "RETI restored A");
}

#[test]
fn input_change_interrupt() {
    let program = vec![
        C::Vect { interrupt: 40, address: 5 },
        C::Sgp { param: 40, bank: 3, value: 1 }, // IN1 low → high
        C::Ei { interrupt: 40 },
        C::Ei { interrupt: 255 },
        C::Ja { address: 4 },
        C::Sio { port: 1, bank: 2, value: 1 }, // 5
        C::Reti,
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(50));
    assert_eq!(b.module.board().outputs, 0);
    b.module.board_mut().inputs = 0b10;
    b.run(Duration::from_millis(5));
    assert_eq!(b.module.board().outputs, 0b10);
}

#[test]
fn step_stop_reset_and_status() {
    let program = vec![
        C::Calc { op: CalcOp::Load, operand: 1 },
        C::Calc { op: CalcOp::Add, operand: 1 },
        C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 1000 },
        C::Stop,
    ];
    let mut b = Bench::new();
    download(&mut b, &program);
    assert_eq!(b.send(Opcode::StepApplication, 0, 0, 0).status, Status::Ok);
    assert_eq!((b.module.registers().accumulator, b.module.vm().pc, b.ggp(128, 0)), (1, 1, 2));
    b.send(Opcode::StepApplication, 0, 0, 0);
    assert_eq!(b.module.registers().accumulator, 2);
    run_from(&mut b, 2);
    b.run(Duration::from_millis(50));
    // 135 type 1: mode 1 (run), wait flag 1, PC 2.
    assert_eq!(b.send(Opcode::GetStatus, 1, 0, 0).value, 1 << 24 | 1 << 16 | 2);
    assert_eq!(b.send(Opcode::StopApplication, 0, 0, 0).status, Status::Ok);
    assert_eq!(b.ggp(128, 0), 0);
    assert_eq!(b.ggp(130, 0), 2);
    assert_eq!(b.send(Opcode::ResetApplication, 0, 0, 0).status, Status::Ok);
    assert_eq!((b.ggp(128, 0), b.ggp(130, 0), b.module.registers().accumulator), (3, 0, 0));
    assert_eq!(b.cmd(C::RunApplication { from: Some(5000) }).0, Status::InvalidValue);
}

#[test]
fn read_memory_and_protection() {
    let mut b = Bench::new();
    download(&mut b, &first_steps());
    // 134: [host, opcode, type, motor, value, checksum].
    let out = b.bytes(&Request { address: 1, instruction: Instruction::new(Opcode::ReadMemory, 0, 0, 8) }.to_bytes());
    assert_eq!(out, [0x02, 0x04, 0x00, 0x00, 0x00, 0x07, 0xD0, 0x00, tmcl_wire::checksum(&out[..8])]);
    // Unprogrammed memory reads opcode 0 (host tools stop there).
    let out = b.bytes(&Request { address: 1, instruction: Instruction::new(Opcode::ReadMemory, 0, 0, 13) }.to_bytes());
    assert_eq!(&out[1..8], &[0; 7]);
    assert_eq!(b.send(Opcode::ReadMemory, 0, 0, 2048).status, Status::InvalidValue);
    // GP 81 = 1: no read-back; = 2: no overwrite; 1 → 0 erases the program first (§5.1).
    b.sgp(81, 0, 3);
    assert_eq!(b.send(Opcode::ReadMemory, 0, 0, 0).status, Status::NotAvailable);
    assert_eq!(b.send(Opcode::StartDownload, 0, 0, 0).status, Status::EepromLocked);
    b.sgp(81, 0, 0);
    assert!(b.module.program().is_empty());
    b.power_cycle();
    assert!(b.module.program().is_empty(), "erased in the EEPROM too");
}

#[test]
fn program_survives_restart_and_auto_starts() {
    let mut b = Bench::new();
    download(&mut b, &[C::Sio { port: 1, bank: 2, value: 1 }, C::Stop]);
    b.power_cycle();
    assert_eq!(b.module.program().len(), 2);
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.board().outputs, 0, "no auto start by default");
    b.sgp(77, 0, 1);
    b.power_cycle();
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.board().outputs, 0b10, "GP 77 = 1: started at power-up");
}

#[test]
fn download_mode_details() {
    let mut b = Bench::new();
    assert_eq!(b.send(Opcode::StartDownload, 0, 0, 100).status, Status::Ok);
    // Control commands still execute in download mode.
    assert_eq!(b.send(Opcode::GetVersion, 1, 0, 0).status, Status::Ok);
    // An undecodable instruction is refused and not stored.
    assert_eq!(b.send(Opcode::Mvp, 7, 0, 0).status, Status::WrongType);
    assert_eq!(b.send(Opcode::Ja, 0, 0, 0).status, Status::Loaded);
    b.send(Opcode::QuitDownload, 0, 0, 0);
    assert_eq!(b.module.program().get(100).unwrap().opcode, Opcode::Ja);
    assert_eq!(b.module.program().len(), 101);
    assert_eq!(b.send(Opcode::StartDownload, 0, 0, 2048).status, Status::InvalidValue);
}

#[test]
fn running_off_the_end_or_into_empty_memory_stops() {
    let mut b = Bench::new();
    download(&mut b, &[C::Calc { op: CalcOp::Load, operand: 3 }]);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.vm().state(), RunState::Stopped);
    assert_eq!(b.module.vm().pc, 1);
}

#[test]
fn direct_mode_works_while_a_program_runs() {
    let mut b = Bench::new();
    download(&mut b, &[C::Calc { op: CalcOp::Add, operand: 1 }, C::Ja { address: 0 }]);
    run_from(&mut b, 0);
    for _ in 0..10 {
        b.run(Duration::from_millis(7));
        assert_eq!(b.sap(4, 1000), Status::Ok);
        assert_eq!(b.gap(4), 1000);
    }
    // 70 ms at 20 µs per instruction: about 3500 instructions, half of them ADD.
    let a = b.module.registers().accumulator;
    assert!((1700..=1800).contains(&a), "{a}");
}

#[test]
fn load_program_and_breakpoints() {
    let mut b = Bench::new();
    let program: Vec<Instruction> = [
        C::Calc { op: CalcOp::Load, operand: 1 },
        C::Calc { op: CalcOp::Add, operand: 1 },
        C::Calc { op: CalcOp::Add, operand: 1 },
        C::Stop,
    ]
    .iter()
    .map(Command::encode)
    .collect();
    b.module.load_program(&program).unwrap();
    // A breakpoint behind the board's hook (a simulator's shortcut the firmware only calls).
    b.module.board_mut().stop_at = Some(2);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(1));
    assert!(b.module.board().stopped);
    assert_eq!((b.module.vm().pc, b.module.registers().accumulator, b.ggp(128, 0)), (2, 2, 0));
    // Continue: the breakpoint's instruction runs, then on to STOP.
    b.cmd(C::RunApplication { from: None });
    b.run(Duration::from_millis(1));
    assert_eq!((b.module.vm().pc, b.module.registers().accumulator), (3, 3));
    assert_eq!(b.module.vm().executed(), 4);
    // The program went to the EEPROM too.
    b.power_cycle();
    assert_eq!(b.module.program().len(), 4);
}

#[test]
fn manual_copy_inputs_to_outputs() {
    // §3.7.14 example: GIO 255, 0 loads all inputs into A; SIO 255, 2, -1 sets the outputs from A.
    let mut b = Bench::new();
    download(&mut b, &[C::Gio { port: 255, bank: 0 }, C::Sio { port: 255, bank: 2, value: -1 }, C::Ja { address: 0 }]);
    run_from(&mut b, 0);
    for inputs in [0b01, 0b10, 0b11, 0b00] {
        b.module.board_mut().inputs = inputs;
        b.run(Duration::from_millis(2));
        assert_eq!(b.module.board().outputs, inputs, "OUT0/OUT1 follow IN0/IN1");
    }
}

#[test]
fn manual_potentiometer_to_position() {
    // §3.7.29 example: GIO 0, 1; CALC MUL, 4; AAP 0, 0: the target follows the analog input × 4.
    let mut b = Bench::new();
    download(
        &mut b,
        &[
            C::Gio { port: 0, bank: 1 },
            C::Calc { op: CalcOp::Mul, operand: 4 },
            C::Aap { param: 0, motor: 0 },
            C::Ja { address: 0 },
        ],
    );
    run_from(&mut b, 0);
    b.module.board_mut().analog = 1000;
    b.run(Duration::from_millis(2));
    assert_eq!(b.gap(0), 4000);
    b.run(Duration::from_secs(2));
    assert_eq!(b.gap(1), 4000, "the motor moved there");
    b.module.board_mut().analog = 4095;
    b.run(Duration::from_secs(2));
    assert_eq!(b.gap(1), 16380);
}

#[test]
fn a_current_set_at_rest_reaches_the_driver_at_once() {
    // Table 15: AP 6 is the current of a moving motor and of one standing within the power-down delay
    // (AP 214). Set by a program or through `Module::execute` while the motor stands and nothing ticks,
    // it reached the driver only when the motor next moved.
    let mut b = Bench::new();
    b.run(Duration::from_millis(10));
    assert_eq!(b.module.board().drive.current, 128);
    download(
        &mut b,
        &[
            C::Wait { condition: WaitCondition::Ticks, motor: 0, ticks: 10 },
            C::Sap { param: 6, motor: 0, value: 200 },
            C::Stop,
        ],
    );
    run_from(&mut b, 0);
    b.run(Duration::from_millis(200));
    assert_eq!(b.module.vm().state(), crate::vm::RunState::Stopped);
    assert_eq!(b.module.board().drive.current, 200);
    let now = b.now;
    assert!(b.module.execute(C::Sap { param: 6, motor: 0, value: 64 }, now).is_ok());
    b.module.poll(now, &mut |_: &[u8]| {});
    assert_eq!(b.module.board().drive.current, 64);
}

/// An instruction the module refuses is skipped and the program goes on (our decision for §3.6: a
/// program gets no status); the program machine notes each refusal — its address, the instruction and
/// the status a host would have got — for a simulator to report, without changing what the program does.
#[test]
fn refused_instructions_are_skipped_and_noted() {
    let mut b = Bench::new();
    let program = [
        C::Gap { param: 99, motor: 0 },                    // 0: no AP 99: status 3
        C::Mvp { motor: 5, target: MoveTarget::Abs(100) }, // 1: no motor 5: status 4
        C::Sap { param: 4, motor: 0, value: 100 },         // 2: fine
        C::Sap { param: 140, motor: 0, value: 99 },        // 3: out of range: status 4
        C::Stop,                                           // 4
    ];
    download(&mut b, &program);
    run_from(&mut b, 0);
    b.run(Duration::from_millis(10));
    assert_eq!(b.ggp(128, 0), 0, "the program ran to its STOP");
    assert_eq!(b.gap(4), 100, "the instruction between the refused ones ran");
    let r = b.module.vm().refusals();
    assert_eq!(r.count(), 3);
    let seen: Vec<(u16, Opcode, Status)> = r.since(0).map(|r| (r.pc, r.instruction.opcode, r.status)).collect();
    assert_eq!(
        seen,
        [
            (0, Opcode::Gap, Status::WrongType),
            (1, Opcode::Mvp, Status::InvalidValue),
            (3, Opcode::Sap, Status::InvalidValue)
        ]
    );
    let numbers: Vec<u64> = r.since(0).map(|r| r.number).collect();
    assert_eq!(numbers, [1, 2, 3]);
    assert_eq!(r.since(2).count(), 1);
    // The instructions ran 20 µs apart (INSTRUCTION_TIME).
    let at: Vec<Instant> = r.since(0).map(|r| r.at).collect();
    assert_eq!(at[1] - at[0], crate::vm::INSTRUCTION_TIME);
}

//! Instruction counts of the firmware's hot paths on the Cortex-M3, for docs/benchmarks.md.
//!
//! Run under QEMU with `-icount shift=0`, where every instruction advances the virtual clock by exactly one
//! nanosecond, so the microseconds SysTick measures are thousands of instructions (scripts/qemu-budgets.sh
//! runs it). Prints one line per figure on UART0 (`NAME runs=N micros=T`: N runs took T µs = T × 1000
//! instructions), then resets, which ends QEMU under `-no-reboot`.
#![no_std]
#![no_main]

use core::fmt::Write;
use cortex_m::peripheral::NVIC;
use cortex_m_rt::{entry, exception};
use lm3s6965::{interrupt, Interrupt};
use tmcl_core::iface::Sink;
use tmcl_core::{Instant, Module};
use tmcl_lm3s6965::board::Lm3sBoard;
use tmcl_lm3s6965::{clock, shim, steps, uart};
use tmcl_mcu::clock::Monotonic;

/// GAP 4 (maximum positioning speed) to module 1.
const GAP: [u8; 9] = [1, 6, 4, 0, 0, 0, 0, 0, 11];
/// ROR 0, 51200: a revolution per second at 256 microsteps.
const ROR: [u8; 9] = [1, 1, 0, 0, 0, 0, 0xC8, 0x00, 0xCA];

/// Prints on UART0.
struct Out;

impl Write for Out {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        uart::Tx.send(s.as_bytes());
        Ok(())
    }
}

/// Counts what the module sends without sending it.
struct Count(usize);

impl Sink for Count {
    fn send(&mut self, bytes: &[u8]) {
        self.0 += bytes.len();
    }
}

#[entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else { cortex_m::peripheral::SCB::sys_reset() };
    let spec = tmcl_mcu::strap::model(shim::strap_word());
    clock::init();
    let board = Lm3sBoard::new(spec);
    let mut module = unpowered(board, spec);
    module.power_up(Instant::ZERO);
    uart::init(module.active_baud());
    clock::start_systick(&mut core.SYST);
    shim::enable_interrupts();
    NVIC::mask(Interrupt::TIMER_0A);
    let mut time = Monotonic::new();
    let mut out = Out;
    let mut module_time = Instant::ZERO;

    // A GAP frame as the main loop handles it: the 9 bytes in the receive queue (as the UART interrupt
    // leaves them), taken out, parsed, executed, the reply queued for the UART and written to it. Module
    // time advances 1 µs per frame, so the motion controller and timers run as they would.
    const FRAMES: u32 = 20_000;
    let mut chunk = [0u8; 64];
    let mut tx = uart::Tx;
    let start = clock::now(&mut time);
    for _ in 0..FRAMES {
        module_time += tmcl_core::Duration::from_micros(1);
        for b in GAP {
            uart::RX.push(b);
        }
        let n = uart::RX.pop_into(&mut chunk);
        module.receive(module_time, &chunk[..n], &mut Quiet(&mut tx));
        let _ = module.poll(module_time, &mut Quiet(&mut tx));
    }
    let gap = clock::now(&mut time) - start;

    // The same frames through `Module::receive` alone (the figure the host benchmark gives).
    let mut sink = Count(0);
    let start = clock::now(&mut time);
    for _ in 0..FRAMES {
        module_time += tmcl_core::Duration::from_micros(1);
        module.receive(module_time, &GAP, &mut sink);
    }
    let gap_core = clock::now(&mut time) - start;

    // One 1 ms motion tick at a constant 51 200 pps: the ramp, the drive state to the board, the step
    // timer set for the tick's 51 steps (the step interrupt is masked: its cost is the next figure).
    module.receive(module_time, &ROR, &mut sink);
    const TICKS: u32 = 10_000;
    let start = clock::now(&mut time);
    for _ in 0..TICKS {
        module_time += tmcl_core::motion::TICK;
        let _ = module.poll(module_time, &mut sink);
    }
    let tick = clock::now(&mut time) - start;

    // One step pulse: the step interrupt's body (pins, pending count).
    const PULSES: u32 = 20_000;
    let start = clock::now(&mut time);
    for _ in 0..PULSES {
        steps::on_interrupt();
    }
    let pulse = clock::now(&mut time) - start;

    let _ = writeln!(out, "gap_frame_main_loop runs={FRAMES} micros={}", gap.micros());
    let _ = writeln!(out, "gap_frame_module_receive runs={FRAMES} micros={}", gap_core.micros());
    let _ = writeln!(out, "motion_tick runs={TICKS} micros={}", tick.micros());
    let _ = writeln!(out, "step_pulse runs={PULSES} micros={}", pulse.micros());
    let _ = writeln!(out, "replies_bytes {}", sink.0);
    let _ = writeln!(out, "done");
    while !uart::idle() {}
    cortex_m::peripheral::SCB::sys_reset()
}

/// The main loop's sink, minus the bytes: the reply is queued and written to the UART like a real one.
struct Quiet<'a>(&'a mut uart::Tx);

impl Sink for Quiet<'_> {
    fn send(&mut self, bytes: &[u8]) {
        self.0.send(bytes);
    }
}

#[inline(never)]
fn unpowered(board: Lm3sBoard, spec: &'static tmcl_core::model::ModelSpec) -> Module<Lm3sBoard> {
    Module::unpowered(board, spec, Instant::ZERO)
}

#[exception]
fn SysTick() {
    clock::TICKS.tick();
}

#[interrupt]
fn UART0() {
    uart::on_interrupt();
}

#[interrupt]
fn TIMER_0A() {
    steps::on_interrupt();
}

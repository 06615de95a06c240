//! The OpenTMCL firmware on a Stellaris LM3S6965 (Cortex-M3, 50 MHz, 256 KiB flash, 64 KiB SRAM), as
//! QEMU's `lm3s6965evb` machine emulates it: the same `tmcl-core` that `tmcl serve` runs on simulated
//! boards, here on the microcontroller's peripherals.
//!
//! - [`shim`]: the registers (the only `unsafe`, with the start-up code in `main.rs`);
//! - [`clock`]: the PLL at 50 MHz and SysTick, the 1 ms time base;
//! - [`uart`]: UART0, the module's serial port, interrupt-driven;
//! - [`steps`]: the step/direction output, one step per timer interrupt;
//! - [`adc`]: the analog input and the temperature sensor;
//! - [`board`]: the core's hardware traits on those;
//! - [`run`]: the main loop.
//!
//! A panic (which the core never does on input: its parsers are fuzzed and its arithmetic checked) resets
//! the microcontroller, as a watchdog would: the EEPROM in RAM survives the reset, the host sees no reply
//! to the request that caused it, and the module starts again from its stored configuration. docs/qemu.md
//! describes the port and its decisions.
#![no_std]

pub mod adc;
pub mod board;
pub mod clock;
pub mod shim;
pub mod steps;
pub mod uart;

use board::Lm3sBoard;
use tmcl_core::model::ModelSpec;
use tmcl_core::{Instant, Module};
use tmcl_mcu::clock::Monotonic;

/// Resets the microcontroller: the panic handler.
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// The module before power-up, built straight into the caller's frame: out of line, so that its 20 KiB
/// are not copied through temporaries of `run` (docs/benchmarks.md has the stack it takes).
#[inline(never)]
fn unpowered(board: Lm3sBoard, spec: &'static ModelSpec, now: Instant) -> Module<Lm3sBoard> {
    Module::unpowered(board, spec, now)
}

/// Brings the board up and serves TMCL on UART0, forever.
pub fn run() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        // Taken twice: cannot happen, as `run` is the entry point's only call.
        cortex_m::peripheral::SCB::sys_reset()
    };
    let spec = tmcl_mcu::strap::model(shim::strap_word());
    clock::init();
    let board = Lm3sBoard::new(spec);
    let mut time = Monotonic::new();
    let now = time.at(0, 0);
    let mut module = unpowered(board, spec, now);
    module.power_up(now);
    let mut baud = module.active_baud();
    uart::init(baud);
    clock::start_systick(&mut core.SYST);
    shim::enable_interrupts();

    let mut tx = uart::Tx;
    let mut chunk = [0u8; 64];
    // chunk[taken..len]: bytes received and not taken by the module yet.
    let (mut taken, mut len) = (0, 0);
    loop {
        let now = clock::now(&mut time);
        loop {
            if taken == len {
                len = uart::RX.pop_into(&mut chunk);
                taken = 0;
                // Room in the ring: the bytes the UART held back come in.
                uart::resume();
                if len == 0 {
                    break;
                }
            }
            // A reply waiting for its telegram pause (GP 75) takes no further byte until it has gone
            // out; the bytes behind it wait here, then in the ring, then in the UART's FIFO.
            taken += module.receive_in_turn(0, now, &chunk[taken..len], &mut tx);
            if taken < len {
                break;
            }
        }
        let deadline = module.poll(now, &mut tx);
        // GP 65 takes effect at a restart (manual §5.1), once the reply to the restart has left.
        if module.active_baud() != baud && uart::idle() {
            baud = module.active_baud();
            uart::set_baud(baud);
        }
        // Sleep until the next interrupt (SysTick within 1 ms, or a byte), unless work is waiting. Checked
        // with interrupts masked: an interrupt after the check still ends the WFI.
        cortex_m::interrupt::free(|_| {
            let due = deadline.is_some_and(|d| d <= now);
            if (taken < len || uart::RX.is_empty()) && !due {
                cortex_m::asm::wfi();
            }
        });
    }
}

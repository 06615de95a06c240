//! UART0 as the module's RS485/RS232 port (PD28-1021 manual §3.1): 8N1 at the baud rate of GP 65,
//! interrupt-driven receive and transmit through two lock-free queues.
//!
//! The receive interrupt moves every byte the FIFO holds into [`RX`] (a byte with a framing, parity, break
//! or overrun error is dropped, as a damaged byte on the line; the core's framer then times the frame
//! out); while [`RX`] is full, bytes stay in the FIFO until the main loop has made room ([`resume`]). The main loop feeds [`RX`] to the core and queues the core's replies in [`TX`]; the transmit
//! interrupt keeps the FIFO filled from [`TX`]. The main loop also fills the FIFO itself, with
//! interrupts masked, so that [`TX`] has one consumer at a time.

use crate::clock::CLOCK_HZ;
use crate::shim::{sysctl, uart0, GPIOA};
use core::sync::atomic::{AtomicBool, Ordering};
use tmcl_core::iface::Sink;
use tmcl_mcu::ring::ByteRing;
use tmcl_mcu::uart::{baud_rate, divisors};

/// Bytes received, for the main loop.
pub static RX: ByteRing<256> = ByteRing::new();
/// Bytes to send, from the main loop.
pub static TX: ByteRing<512> = ByteRing::new();

const FR_BUSY: u32 = 1 << 3;
const FR_RXFE: u32 = 1 << 4;
const FR_TXFF: u32 = 1 << 5;
const INT_RX: u32 = 1 << 4;
const INT_TX: u32 = 1 << 5;
const INT_RT: u32 = 1 << 6;
const DR_ERRORS: u32 = 0xF00;

/// Clocks UART0 and its pins (PA0 receive, PA1 transmit) and starts it at GP 65 = `baud_index`.
pub fn init(baud_index: u8) {
    sysctl::RCGC1.modify(|r| r | 1);
    sysctl::RCGC2.modify(|r| r | 1);
    GPIOA.afsel().modify(|r| r | 0b11);
    GPIOA.den().modify(|r| r | 0b11);
    set_baud(baud_index);
    // Receive interrupt at 1/8 full, and the receive time-out for the bytes below that level.
    uart0::IFLS.write(0);
    uart0::IM.write(INT_RX | INT_RT);
}

/// Sets the baud rate of GP 65 value `index` (manual §5.1, Table 17) at the system clock.
pub fn set_baud(index: u8) {
    let d = divisors(CLOCK_HZ, baud_rate(index));
    uart0::CTL.write(0);
    uart0::IBRD.write(u32::from(d.integer));
    uart0::FBRD.write(u32::from(d.fraction));
    // 8 data bits, FIFOs on, no parity, one stop bit; this write latches the divisors.
    uart0::LCRH.write(0x60 | 0x10);
    // UART, transmitter and receiver on.
    uart0::CTL.write(1 | 1 << 8 | 1 << 9);
}

/// Whether everything queued has left the UART (a new baud rate may be set).
pub fn idle() -> bool {
    TX.is_empty() && uart0::FR.read() & FR_BUSY == 0
}

/// Set while received bytes wait in the FIFO because [`RX`] is full (the receive interrupts are masked
/// meanwhile); [`resume`] takes them once the main loop has made room.
static HELD: AtomicBool = AtomicBool::new(false);

/// The UART0 interrupt.
pub fn on_interrupt() {
    let status = uart0::MIS.read();
    uart0::ICR.write(status);
    drain();
    if status & INT_TX != 0 {
        refill();
    }
}

/// Moves received bytes from the FIFO into [`RX`] while it has room. When it is full the rest stay in the
/// FIFO and the receive interrupts are masked until [`resume`]: a byte is never read to be dropped. On
/// a real line a sender that goes on meanwhile overruns the FIFO, as it would have overrun the ring; a
/// sender that waits for room (QEMU, whose UART takes no byte from its pty while the FIFO is full) loses
/// nothing. Runs in the interrupt or with interrupts masked: it is the one producer of [`RX`].
fn drain() {
    while uart0::FR.read() & FR_RXFE == 0 {
        if RX.room() == 0 {
            HELD.store(true, Ordering::Relaxed);
            uart0::IM.modify(|m| m & !(INT_RX | INT_RT));
            return;
        }
        let data = uart0::DR.read();
        if data & DR_ERRORS != 0 {
            uart0::ECR.write(0);
            continue;
        }
        RX.push(data as u8);
    }
}

/// Takes the bytes held in the FIFO and unmasks the receive interrupts, once [`RX`] has room again (from
/// the main loop, after it took bytes from [`RX`]).
pub fn resume() {
    if !HELD.load(Ordering::Relaxed) || RX.room() == 0 {
        return;
    }
    cortex_m::interrupt::free(|_| {
        HELD.store(false, Ordering::Relaxed);
        drain();
        if !HELD.load(Ordering::Relaxed) {
            uart0::IM.modify(|m| m | INT_RX | INT_RT);
        }
    });
}

/// Moves queued bytes into the transmit FIFO; arms the transmit interrupt while bytes are left. Runs in
/// the interrupt or with interrupts masked: it is the one consumer of [`TX`].
fn refill() {
    while uart0::FR.read() & FR_TXFF == 0 {
        match TX.pop() {
            Some(b) => uart0::DR.write(u32::from(b)),
            None => {
                uart0::IM.modify(|m| m & !INT_TX);
                return;
            }
        }
    }
    uart0::IM.modify(|m| m | INT_TX);
}

/// Starts sending what is queued (from the main loop).
pub fn kick() {
    cortex_m::interrupt::free(|_| refill());
}

/// The core's [`Sink`]: queues the bytes and starts sending them. When the queue is full it waits for
/// room, so a reply is never cut.
pub struct Tx;

impl Sink for Tx {
    fn send(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while TX.room() == 0 {
                kick();
            }
            TX.push(b);
        }
        kick();
    }
}

//! A real EtherCAT master, ethercrab 0.7, drives the virtual TMCM-1310 over an in-memory link: its PDU
//! loop hands every frame to [`Slave::process`] and the answer back, so no network and no privileges are
//! needed. Time on the slave side is virtual: every frame advances it 50 µs, a process-data cycle 1 ms,
//! so the motor moves as fast as the test runs and nothing sleeps.
//!
//! What it shows: discovery and identity from the SII, INIT → PRE-OP → SAFE-OP → OP the way ethercrab
//! does it (its own SyncManager and FMMU choices: FMMU n for SM n, inputs first in its image), process
//! data in position and velocity mode with the motor following, TMCL through the raw mailbox in PRE-OP
//! and OP (status 100, 2, 8), the USB port seeing the same module, a refused transition with its AL
//! status code, and the way back down.

use ethercrab::{MainDevice, MainDeviceConfig, PduRx, PduStorage, PduTx, SubDeviceState, Timeouts};
use std::cell::RefCell;
use std::future::Future;
use std::pin::pin;
use std::task::Poll;
use tmcl_core::model::tmcm_1310::SPEC;
use tmcl_core::{Duration, Instant, Module};
use tmcl_ethercat::{AlState, NoFiles, Slave};
use tmcl_sim::SimBoard;
use tmcl_wire::{Instruction, Opcode, Request};

/// The slave, its module and the virtual clock, shared by the link and the test.
struct Bench {
    slave: Slave,
    module: Module<SimBoard>,
    now: Instant,
    frames: u64,
}

impl Bench {
    fn new() -> Bench {
        let module = Module::new(SimBoard::in_memory_for(&SPEC), &SPEC, Instant::ZERO);
        Bench { slave: Slave::new(&SPEC).unwrap(), module, now: Instant::ZERO, frames: 0 }
    }

    /// A 9-byte request on the USB port (interface 0); the reply's status and value.
    fn usb(&mut self, opcode: Opcode, kind: u8, value: i32) -> (u8, i32) {
        let request = Request { address: 1, instruction: Instruction::new(opcode, kind, 0, value) }.to_bytes();
        let mut out = Vec::new();
        self.module.receive(self.now, &request, &mut |b: &[u8]| out.extend_from_slice(b));
        assert_eq!(out.len(), 9, "one USB reply");
        (out[2], i32::from_be_bytes([out[4], out[5], out[6], out[7]]))
    }

    /// Lets `d` pass on the slave side (between process-data cycles).
    fn advance(&mut self, d: Duration) {
        self.now += d;
        let Bench { slave, module, now, .. } = self;
        slave.poll(*now, module, &mut NoFiles);
    }
}

/// The in-memory link: whenever ethercrab has a frame to send, the slave processes it and ethercrab
/// receives the answer. Never finishes; run it beside the test with `or`.
fn link<'a>(mut tx: PduTx<'a>, mut rx: PduRx<'a>, bench: &'a RefCell<Bench>) -> impl Future<Output = ()> + 'a {
    std::future::poll_fn(move |cx| {
        tx.replace_waker(cx.waker());
        while let Some(frame) = tx.next_sendable_frame() {
            let mut answer = Vec::new();
            frame
                .send_blocking(|bytes| {
                    let mut b = bench.borrow_mut();
                    let Bench { slave, module, now, frames } = &mut *b;
                    *now += Duration::from_micros(50);
                    *frames += 1;
                    let mut buf = bytes.to_vec();
                    if slave.process(*now, &mut buf, module, &mut NoFiles).is_some() {
                        answer = buf;
                    }
                    Ok(bytes.len())
                })
                .expect("send");
            if !answer.is_empty() {
                rx.receive_frame(&answer).expect("receive");
            }
        }
        Poll::<()>::Pending
    })
}

/// Runs `test` with a master on the link, to completion.
fn with_master<T>(bench: &RefCell<Bench>, test: impl AsyncFnOnce(&MainDevice<'_>) -> T) -> T {
    let storage: PduStorage<16, { PduStorage::element_size(1100) }> = PduStorage::new();
    let (tx, rx, pdu_loop) = storage.try_split().expect("split once");
    let master = MainDevice::new(
        pdu_loop,
        // ethercrab's timeouts run on the wall clock: generous ones, so that a loaded machine (the tests run
        // in parallel on a shared one) cannot fail a test; the slave answers every frame at once anyway.
        Timeouts {
            pdu: std::time::Duration::from_secs(2),
            eeprom: std::time::Duration::from_secs(2),
            state_transition: std::time::Duration::from_secs(20),
            ..Timeouts::default()
        },
        MainDeviceConfig { dc_static_sync_iterations: 0, ..MainDeviceConfig::default() },
    );
    let link = pin!(link(tx, rx, bench));
    let run = pin!(test(&master));
    async_io::block_on(futures_lite::future::or(run, async {
        link.await;
        unreachable!("the link never ends")
    }))
}

/// A TMCL request through the raw mailbox: 8 bytes at offset 0 of SM0 (written whole, as the
/// SyncManager wants), then SM1 polled until full and read whole; the 8-byte reply.
async fn tmcl<S: std::ops::Deref<Target = ethercrab::SubDevice>>(
    subdevice: &ethercrab::SubDeviceRef<'_, S>,
    opcode: u8,
    kind: u8,
    value: i32,
) -> [u8; 8] {
    let mut request = [0u8; 268];
    request[..4].copy_from_slice(&[1, opcode, kind, 0]);
    request[4..8].copy_from_slice(&value.to_be_bytes());
    subdevice.register_write(0x1000u16, request).await.expect("SM0 takes the request");
    for _ in 0..100 {
        let status: u8 = subdevice.register_read(0x080Du16).await.expect("SM1 status");
        if status & 0x08 != 0 {
            let reply: [u8; 40] = subdevice.register_read(0x110Cu16).await.expect("SM1 read");
            assert_eq!(reply[8..], [0u8; 32], "nothing but the 8-byte reply");
            return reply[..8].try_into().unwrap();
        }
    }
    panic!("no reply in SM1");
}

fn status_value(reply: [u8; 8]) -> (u8, u8, i32) {
    (reply[2], reply[3], i32::from_be_bytes([reply[4], reply[5], reply[6], reply[7]]))
}

fn field(inputs: &[u8], n: usize) -> i32 {
    i32::from_le_bytes(inputs[4 * n..4 * n + 4].try_into().unwrap())
}

#[test]
fn ethercrab_brings_the_tmcm_1310_to_op_and_moves_it() {
    let bench = RefCell::new(Bench::new());
    with_master(&bench, async |master| {
        let group = master.init_single_group::<4, 128>(|| 0).await.expect("init: discovery to PRE-OP");
        assert_eq!(group.len(), 1, "one slave found");
        {
            let s = group.subdevice(master, 0).unwrap();
            let id = s.identity();
            assert_eq!((id.vendor_id, id.product_id, id.revision), (0x286, 1310, 0x0001_000E));
            assert_eq!(s.name(), "TMCM-1310");
            assert_eq!(s.status().await.unwrap().0, SubDeviceState::PreOp);
            // TMCL in PRE-OP: GAP 4 (maximum positioning speed) = 51200, status 100.
            let r = tmcl(&s, 6, 4, 0).await;
            assert_eq!((r[0], r[1]), (2, 1), "reply address 2, module address 1");
            assert_eq!(status_value(r), (100, 6, 51200));
            // A command the module does not know: status 2.
            assert_eq!(status_value(tmcl(&s, 200, 0, 0).await).0, 2);
            // The password-protected I²t limit (AP 26): status 8 (manual §3.7).
            assert_eq!(status_value(tmcl(&s, 5, 26, 100).await).0, 8);
            // SAP 4 through the mailbox; the USB port reads it back.
            assert_eq!(status_value(tmcl(&s, 5, 4, 102400).await).0, 100);
        }
        assert_eq!(bench.borrow_mut().usb(Opcode::Gap, 4, 0), (100, 102400));

        let group = group.into_safe_op(master).await.expect("PRE-OP -> SAFE-OP");
        assert_eq!(bench.borrow().slave.status().state, AlState::SafeOp);
        {
            let s = group.subdevice(master, 0).unwrap();
            assert_eq!((s.inputs_raw().len(), s.outputs_raw().len()), (48, 8));
            // SAFE-OP: velocity outputs are held safe, the motor does not move.
            s.outputs_raw_mut().copy_from_slice(&[2, 0, 0, 0, 0x00, 0xC8, 0, 0]);
        }
        for _ in 0..50 {
            group.tx_rx(master).await.expect("cycle");
            bench.borrow_mut().advance(Duration::from_millis(1));
        }
        assert_eq!(bench.borrow().module.ramp().velocity(), 0);
        assert_eq!(bench.borrow_mut().usb(Opcode::Gap, 1, 0), (100, 0));

        // SAFE-OP -> OP with the cycle running, as a watchdog-guarded slave wants it.
        let group = group.request_into_op(master).await.expect("request OP");
        let mut op = false;
        for _ in 0..20 {
            let r = group.tx_rx(master).await.expect("cycle");
            bench.borrow_mut().advance(Duration::from_millis(1));
            assert_eq!(r.working_counter, 3, "outputs written (2) and inputs read (1)");
            if r.all_op() {
                op = true;
                break;
            }
        }
        assert!(op, "OP reached");

        // Velocity mode: 51200 pps. The inputs follow, in the manual's order.
        group.subdevice(master, 0).unwrap().outputs_raw_mut().copy_from_slice(&[2, 0, 0, 0, 0x00, 0xC8, 0, 0]);
        for _ in 0..1500 {
            group.tx_rx(master).await.expect("cycle");
            bench.borrow_mut().advance(Duration::from_millis(1));
        }
        let (position, velocity) = {
            let s = group.subdevice(master, 0).unwrap();
            let inputs = s.inputs_raw();
            assert_eq!(field(&inputs, 4), 51200, "target velocity");
            assert_eq!(field(&inputs, 5), 51200, "actual velocity");
            assert_eq!(field(&inputs, 7) & (1 << 4), 1 << 4, "status word: velocity mode");
            (field(&inputs, 1), field(&inputs, 5))
        };
        assert!(position > 40_000, "moved: {position}");
        // The USB port sees the same module: its position is at least what the last inputs said.
        let (status, usb_position) = bench.borrow_mut().usb(Opcode::Gap, 1, 0);
        assert_eq!(status, 100);
        assert!(usb_position >= position && usb_position - position < velocity / 100, "{usb_position} vs {position}");

        // Position mode: to 0, and the status word says the target is reached.
        group.subdevice(master, 0).unwrap().outputs_raw_mut().copy_from_slice(&[1, 0, 0, 0, 0, 0, 0, 0]);
        let mut reached = false;
        for _ in 0..5000 {
            group.tx_rx(master).await.expect("cycle");
            bench.borrow_mut().advance(Duration::from_millis(1));
            let s = group.subdevice(master, 0).unwrap();
            let inputs = s.inputs_raw();
            if field(&inputs, 1) == 0 && field(&inputs, 7) & 1 == 1 {
                reached = true;
                break;
            }
        }
        assert!(reached, "position 0 reached");
        assert_eq!(bench.borrow_mut().usb(Opcode::Gap, 0, 0), (100, 0));

        // TMCL in OP, between cycles.
        {
            let s = group.subdevice(master, 0).unwrap();
            assert_eq!(status_value(tmcl(&s, 6, 1, 0).await), (100, 6, 0));
            // A refused transition answers with an AL status code: OP -> BOOT skips INIT.
            s.register_write(0x0120u16, 0x0003u16).await.expect("AL control");
            let status: u16 = s.register_read(0x0130u16).await.unwrap();
            let code: u16 = s.register_read(0x0134u16).await.unwrap();
            assert_eq!((status, code), (0x18, 0x0011), "OP with error, invalid requested state change");
        }
        group.tx_rx(master).await.expect("cycle");
        // Acknowledge, then down: OP -> SAFE-OP -> PRE-OP -> INIT.
        group.subdevice(master, 0).unwrap().register_write(0x0120u16, 0x0018u16).await.unwrap();
        let group = group.into_safe_op(master).await.expect("OP -> SAFE-OP");
        let group = group.into_pre_op(master).await.expect("SAFE-OP -> PRE-OP");
        let _group = group.into_init(master).await.expect("PRE-OP -> INIT");
        assert_eq!(bench.borrow().slave.status().state, AlState::Init);
    });
    let frames = bench.borrow().frames;
    assert!(frames > 1000, "{frames} frames");
}

#[test]
fn op_without_outputs_is_refused_with_an_al_code() {
    let bench = RefCell::new(Bench::new());
    with_master(&bench, async |master| {
        let group = master.init_single_group::<4, 128>(|| 0).await.expect("init");
        let group = group.into_safe_op(master).await.expect("SAFE-OP");
        // OP requested, but no outputs ever sent: after a second (slave time) the request is refused
        // with 0x0019 (no valid outputs) instead of hanging.
        let s = group.subdevice(master, 0).unwrap();
        s.register_write(0x0120u16, 0x0008u16).await.unwrap();
        bench.borrow_mut().advance(Duration::from_millis(1001));
        let status: u16 = s.register_read(0x0130u16).await.unwrap();
        let code: u16 = s.register_read(0x0134u16).await.unwrap();
        assert_eq!((status, code), (0x14, 0x0019));
    });
}

#[test]
fn the_watchdog_holds_the_motor_when_the_master_stops() {
    let bench = RefCell::new(Bench::new());
    with_master(&bench, async |master| {
        let group = master.init_single_group::<4, 128>(|| 0).await.expect("init");
        let group = group.into_safe_op(master).await.expect("SAFE-OP");
        group.subdevice(master, 0).unwrap().outputs_raw_mut().copy_from_slice(&[2, 0, 0, 0, 0x00, 0x64, 0, 0]);
        let group = group.request_into_op(master).await.expect("request OP");
        for _ in 0..200 {
            group.tx_rx(master).await.expect("cycle");
            bench.borrow_mut().advance(Duration::from_millis(1));
        }
        assert_eq!(bench.borrow().module.ramp().target_velocity, 25600);
        // The master stops cycling: after the ESC's default 100 ms, SAFE-OP with 0x001B and a stop.
        bench.borrow_mut().advance(Duration::from_millis(150));
        let s = group.subdevice(master, 0).unwrap();
        let status: u16 = s.register_read(0x0130u16).await.unwrap();
        let code: u16 = s.register_read(0x0134u16).await.unwrap();
        assert_eq!((status, code), (0x14, 0x001B));
        assert_eq!(bench.borrow().module.ramp().target_velocity, 0);
    });
}

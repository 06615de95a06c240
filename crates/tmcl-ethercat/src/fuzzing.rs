//! Fuzz harnesses, shared by the cargo-fuzz targets in `fuzz/` and by the property tests, so that "never
//! panics, never changes state on a bad frame" is checked on every `cargo test` too.
//!
//! - [`parsers`]: every view and repr of [`crate::wire`] on arbitrary bytes.
//! - [`frames`]: a slave (brought to INIT, PRE-OP, SAFE-OP or OP first) fed arbitrary frames.

use crate::foe::{FileStore, NoFiles};
use crate::layout::{MAILBOX_IN, MAILBOX_OUT, OUTPUTS};
use crate::register as reg;
use crate::slave::Slave;
use crate::wire::datagram::{self, Command, Datagram};
use crate::wire::{ethernet, foe, frame, mailbox, sii};
use crate::AlState;
use tmcl_core::hal::Board;
use tmcl_core::{Duration, Instant, Module};

/// The largest Ethernet frame without its check sequence.
pub const MAX_FRAME: usize = 1514;

/// Builds an Ethernet frame carrying `datagrams` (command, address, data) into `out`; returns its
/// length, or `None` if it does not fit. Source 01:01:01:01:01:01 (SOEM's), broadcast destination.
pub fn build_frame(out: &mut [u8], datagrams: &[(Command, u32, &[u8])]) -> Option<usize> {
    let body: usize = datagrams.iter().map(|(_, _, d)| datagram::HEADER_LEN + d.len() + datagram::WKC_LEN).sum();
    let total = ethernet::HEADER_LEN + frame::HEADER_LEN + body;
    if total > out.len() || body > frame::MAX_LENGTH {
        return None;
    }
    let out = &mut out[..total];
    ethernet::Repr { destination: [0xFF; 6], source: [1; 6], ethertype: ethernet::ETHERTYPE_ETHERCAT }
        .emit(&mut ethernet::Frame::new_unchecked(&mut *out));
    let payload = &mut out[ethernet::HEADER_LEN..];
    frame::Repr { length: body as u16, frame_type: frame::FrameType::Datagrams }
        .emit(&mut frame::Frame::new_unchecked(&mut *payload));
    let mut at = frame::HEADER_LEN;
    for (k, (command, address, data)) in datagrams.iter().enumerate() {
        let n = datagram::HEADER_LEN + data.len() + datagram::WKC_LEN;
        let mut d = Datagram::new_unchecked(&mut payload[at..at + n]);
        datagram::Repr {
            command: *command,
            index: k as u8,
            address: *address,
            length: data.len() as u16,
            circulating: false,
            more: k + 1 < datagrams.len(),
            irq: 0,
            wkc: 0,
        }
        .emit(&mut d);
        d.data_mut().copy_from_slice(data);
        at += n;
    }
    Some(total)
}

/// The working counters and data of a processed frame's datagrams, in order (for tests).
pub fn answers(frame_bytes: &[u8], mut each: impl FnMut(usize, u16, &[u8])) {
    let Ok(eth) = ethernet::Frame::new_checked(frame_bytes) else { return };
    let Ok(f) = frame::Frame::new_checked(eth.payload()) else { return };
    let region = f.datagrams();
    for (k, span) in f.spans().enumerate() {
        let d = Datagram::new_unchecked(&region[span]);
        each(k, d.wkc(), d.data());
    }
}

/// One datagram to a slave at `now`; returns its working counter and data.
pub fn one<B: Board>(
    slave: &mut Slave,
    module: &mut Module<B>,
    files: &mut impl FileStore,
    now: Instant,
    (command, address, data): (Command, u32, &[u8]),
    out: &mut [u8],
) -> Option<u16> {
    let mut buf = [0u8; MAX_FRAME];
    let n = build_frame(&mut buf, &[(command, address, data)])?;
    slave.process(now, &mut buf[..n], module, files)?;
    let mut wkc = None;
    answers(&buf[..n], |_, w, d| {
        let k = d.len().min(out.len());
        out[..k].copy_from_slice(&d[..k]);
        wkc = Some(w);
    });
    wkc
}

/// A configured-address write to station 0x1001 of `data` at `register`.
fn fpwr<B: Board>(slave: &mut Slave, module: &mut Module<B>, now: Instant, register: u16, data: &[u8]) {
    let _ = one(
        slave,
        module,
        &mut NoFiles,
        now,
        (Command::Fpwr, datagram::Repr::physical(0x1001, register), data),
        &mut [],
    );
}

/// Brings a fresh slave to `target` (INIT, PRE-OP, SAFE-OP or OP) the way SOEM does: station address,
/// SyncManagers and FMMUs from the layout, AL control, outputs before OP.
pub fn bring_up<B: Board>(slave: &mut Slave, module: &mut Module<B>, now: Instant, target: AlState) {
    if target == AlState::Init {
        return;
    }
    let _ = one(
        slave,
        module,
        &mut NoFiles,
        now,
        (Command::Apwr, datagram::Repr::physical(0, reg::STATION_ADDRESS), &[0x01, 0x10]),
        &mut [],
    );
    let sm = |s: crate::layout::SmLayout| {
        let mut b = [0u8; 8];
        b[..2].copy_from_slice(&s.start.to_le_bytes());
        b[2..4].copy_from_slice(&s.length.to_le_bytes());
        b[4] = s.control;
        b[6] = 1;
        b
    };
    let mut both = [0u8; 16];
    both[..8].copy_from_slice(&sm(MAILBOX_OUT));
    both[8..].copy_from_slice(&sm(MAILBOX_IN));
    fpwr(slave, module, now, reg::SM, &both);
    fpwr(slave, module, now, reg::AL_CONTROL, &[0x12, 0]);
    if target == AlState::PreOp || target == AlState::Boot {
        return;
    }
    let inputs = slave.sync_managers()[3];
    fpwr(slave, module, now, reg::SM + 16, &sm(OUTPUTS));
    fpwr(slave, module, now, reg::SM + 24, &sm(inputs));
    // FMMU0: logical 0..8 → SM2 (write); FMMU1: logical 8.. → SM3 (read).
    let fmmu = |logical: u32, s: crate::layout::SmLayout, kind: u8| {
        let mut b = [0u8; 16];
        b[..4].copy_from_slice(&logical.to_le_bytes());
        b[4..6].copy_from_slice(&s.length.to_le_bytes());
        b[7] = 7;
        b[8..10].copy_from_slice(&s.start.to_le_bytes());
        b[11] = kind;
        b[12] = 1;
        b
    };
    fpwr(slave, module, now, reg::FMMU, &fmmu(0, OUTPUTS, 2));
    fpwr(slave, module, now, reg::FMMU + 16, &fmmu(8, inputs, 1));
    fpwr(slave, module, now, reg::AL_CONTROL, &[0x04, 0]);
    if target == AlState::SafeOp {
        return;
    }
    let image = [0u8; 8 + crate::pdo::MAX_INPUTS_LEN];
    let _ = one(slave, module, &mut NoFiles, now, (Command::Lrw, 0, &image[..8 + usize::from(inputs.length)]), &mut []);
    fpwr(slave, module, now, reg::AL_CONTROL, &[0x08, 0]);
}

/// Whether a frame is one the slave must answer: Ethernet with EtherType 0x88A4, an EtherCAT frame of
/// datagrams whose chain fits its length.
pub fn sound(bytes: &[u8]) -> bool {
    let Ok(eth) = ethernet::Frame::new_checked(bytes) else { return false };
    let Ok(f) = frame::Frame::new_checked(eth.payload()) else { return false };
    eth.ethertype() == ethernet::ETHERTYPE_ETHERCAT
        && f.frame_type() == frame::FrameType::Datagrams
        && f.check_datagrams().is_ok()
}

/// Runs every parser of [`crate::wire`] on `data` and checks that what parses emits back the same.
pub fn parsers(data: &[u8]) {
    if let Ok(eth) = ethernet::Frame::new_checked(data) {
        let repr = ethernet::Repr::parse(&eth).expect("checked");
        let mut head = [0u8; ethernet::HEADER_LEN];
        repr.emit(&mut ethernet::Frame::new_unchecked(&mut head[..]));
        assert_eq!(head[..], data[..ethernet::HEADER_LEN]);
        if let Ok(f) = frame::Frame::new_checked(eth.payload()) {
            let n = f.check_datagrams();
            let spans = f.spans().count();
            if let Ok(n) = n {
                assert_eq!(n, spans, "a sound chain walks the same either way");
            }
            let region = f.datagrams();
            for span in f.spans() {
                let d = Datagram::new_checked(&region[span.clone()]).expect("spans are checked");
                let r = datagram::Repr::parse(&d).expect("checked");
                assert_eq!(r.buffer_len(), span.len());
                let _ = (d.command().addressing(), d.command().reads(), d.data());
            }
        }
    }
    if let Ok(m) = mailbox::Mailbox::new_checked(data) {
        let r = mailbox::Repr::parse(&m).expect("checked");
        let mut head = [0u8; mailbox::HEADER_LEN];
        r.emit(&mut head);
        let again = mailbox::Repr::parse(&mailbox::Mailbox::new_unchecked(&head[..])).ok();
        if r.length == 0 {
            assert_eq!(again, Some(r));
        }
        if let Ok(message) = foe::Repr::parse(m.data()) {
            let mut out = [0u8; 2048];
            if let Some(buf) = out.get_mut(..message.buffer_len()) {
                let n = message.emit(buf);
                assert_eq!(foe::Repr::parse(&out[..n]), Ok(message));
            }
        }
    }
    for c in sii::categories(data) {
        let d = c.data();
        match c.category_type() {
            sii::CategoryType::Strings => {
                for i in 0..=d.first().copied().unwrap_or(0) {
                    let _ = sii::string(d, i);
                }
            }
            sii::CategoryType::General => {
                if let Ok(g) = sii::General::parse(d) {
                    let mut out = [0u8; sii::General::LEN];
                    g.emit(&mut out);
                    assert_eq!(sii::General::parse(&out), Ok(g));
                }
            }
            sii::CategoryType::SyncManager => {
                for e in d.chunks(sii::SyncManager::LEN) {
                    let _ = sii::SyncManager::parse(e);
                }
            }
            sii::CategoryType::TxPdo | sii::CategoryType::RxPdo => {
                if let Ok(p) = sii::Pdo::parse(d) {
                    for e in d[sii::Pdo::LEN..].chunks(sii::PdoEntry::LEN).take(usize::from(p.entries)) {
                        let _ = sii::PdoEntry::parse(e);
                    }
                }
            }
            _ => {}
        }
    }
    let _ = sii::crc8(data);
}

/// A slave session on `module`: the first byte picks the state to start from (bits 0..2: INIT, PRE-OP,
/// SAFE-OP, OP), then chunks `[control, n, payload × n]` follow: `control` bits 0..7 are the gap before
/// the frame in 100 µs, bit 7 "repair" turns the payload into one sound datagram (the EtherCAT header
/// and the datagram length set to fit), so that the fuzzer reaches deep into the ESC; otherwise the
/// payload goes as it is, header and all.
///
/// Checked: no panic; a refused frame changes nothing; an answered frame keeps its length, and every
/// datagram keeps its command, index and length and gains at most 3 on its working counter.
pub fn frames<B: Board>(module: &mut Module<B>, data: &[u8]) {
    let Some((&setup, mut rest)) = data.split_first() else { return };
    let mut slave = Slave::new(module.spec()).expect("a model with EtherCAT");
    let mut now = Instant::ZERO;
    let target = [AlState::Init, AlState::PreOp, AlState::SafeOp, AlState::Op][usize::from(setup & 3)];
    bring_up(&mut slave, module, now, target);
    let mut buf = [0u8; MAX_FRAME];
    let mut before = [0u8; MAX_FRAME];
    while let [control, n, tail @ ..] = rest {
        let n = usize::from(*n).min(tail.len());
        let payload = &tail[..n];
        rest = &tail[n..];
        now += Duration::from_micros(100 * u64::from(control & 0x7F));
        slave.poll(now, module, &mut NoFiles);
        let len = ethernet::HEADER_LEN + n;
        ethernet::Repr { destination: [0xFF; 6], source: [1; 6], ethertype: ethernet::ETHERTYPE_ETHERCAT }
            .emit(&mut ethernet::Frame::new_unchecked(&mut buf[..]));
        buf[ethernet::HEADER_LEN..len].copy_from_slice(payload);
        if control & 0x80 != 0 && n >= frame::HEADER_LEN + datagram::HEADER_LEN + datagram::WKC_LEN {
            let body = n - frame::HEADER_LEN;
            buf[ethernet::HEADER_LEN] = body as u8;
            buf[ethernet::HEADER_LEN + 1] = 0x10 | (body >> 8) as u8 & 0x07;
            let data_len = (body - datagram::HEADER_LEN - datagram::WKC_LEN) as u16;
            let at = ethernet::HEADER_LEN + frame::HEADER_LEN + 6;
            buf[at..at + 2].copy_from_slice(&data_len.to_le_bytes());
        }
        before[..len].copy_from_slice(&buf[..len]);
        // The slave is copied (14 KiB) only for the frames it must refuse.
        let snapshot = (!sound(&buf[..len])).then(|| slave.clone());
        match slave.process(now, &mut buf[..len], module, &mut NoFiles) {
            None => {
                let snapshot = snapshot.expect("a sound frame is answered");
                assert!(slave == snapshot, "a refused frame changed the slave");
            }
            Some(answer) => {
                assert!(snapshot.is_none(), "a broken frame was answered");
                assert_eq!(answer, len);
                let mut sent = [(Command::Nop, 0u8, 0u16, 0u16); 64];
                let mut k = 0;
                let eth = ethernet::Frame::new_unchecked(&before[..len]);
                let f = frame::Frame::new_unchecked(eth.payload());
                let region = f.datagrams();
                for span in f.spans().take(64) {
                    let d = Datagram::new_unchecked(&region[span]);
                    sent[k] = (d.command(), d.index(), d.length(), d.wkc());
                    k += 1;
                }
                let mut seen = 0;
                answers(&buf[..len], |i, wkc, _| {
                    if let Some(&(_, _, _, old)) = sent.get(i).filter(|_| i < k) {
                        assert!(wkc.wrapping_sub(old) <= 3, "working counter {old} -> {wkc}");
                    }
                    seen += 1;
                });
                assert_eq!(seen, f.spans().count());
                let eth2 = ethernet::Frame::new_unchecked(&buf[..len]);
                let f2 = frame::Frame::new_unchecked(eth2.payload());
                let region2 = f2.datagrams();
                for (i, span) in f2.spans().take(k).enumerate() {
                    let d = Datagram::new_unchecked(&region2[span]);
                    assert_eq!((d.command(), d.index(), d.length()), (sent[i].0, sent[i].1, sent[i].2));
                }
            }
        }
    }
}

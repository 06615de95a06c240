//! `-v`: every request and reply, and the EtherCAT AL state changes, as `tracing` events (target
//! `tmcl_serve::trace`, level INFO; `tmcl` writes them to stderr).

use tmcl_core::Instant;
use tmcl_ethercat::AlStatus;
use tmcl_wire::{Frame, Hex, Instruction, Reply, ReplyFrame, Request};

pub(crate) fn log_request(now: Instant, bytes: &[u8]) {
    let what = match Frame::new_checked(bytes).map(|f| Request::parse(&f)) {
        Ok(Ok(Request { address, instruction })) if bytes.len() == 9 => describe(address, instruction),
        Ok(Err(e)) if bytes.len() == 9 => e.to_string(),
        _ => format!("{} bytes", bytes.len()),
    };
    tracing::info!("[{now}] -> {}  {what}", Hex(bytes));
}

fn describe(address: u8, i: Instruction) -> String {
    format!("to {address}: {} {}, {}, {}", i.opcode, i.kind, i.motor, i.value)
}

pub(crate) fn log_reply(now: Instant, bytes: &[u8]) {
    let what = match ReplyFrame::new_checked(bytes).map(|f| Reply::parse(&f)) {
        Ok(Ok(r)) => format!("status {}, value {}", r.status, r.value),
        _ => format!("special reply {:?}", String::from_utf8_lossy(&bytes[1.min(bytes.len())..])),
    };
    tracing::info!("[{now}] <- {}  {what}", Hex(bytes));
}

/// Logs a change of the slave's AL status (with -v).
pub(crate) fn log_al(verbose: bool, now: Instant, before: AlStatus, after: AlStatus) {
    if !verbose || before == after {
        return;
    }
    if after.error {
        tracing::warn!("[{now}] EtherCAT: {} with error, AL status code {:#06x}", after.state, u16::from(after.code));
    } else {
        tracing::info!("[{now}] EtherCAT: {} -> {}", before.state, after.state);
    }
}

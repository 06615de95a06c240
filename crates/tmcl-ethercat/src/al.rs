//! The application-layer (AL) state machine: INIT, PRE-OP, SAFE-OP, OP and BOOT (TMCM-1310 manual §3.2,
//! Figure 3.4; ETG.1000.6 "AL state machine"), with the error indication and the AL status codes of
//! ETG.1000.6 (the table of AL status codes, also in ETG.1020).
//!
//! [`decide`] is the one transition `match`: given the state, the request a master wrote into AL control
//! (0x0120) and the outcome of the checks the manual lists for the transition, it says what happens.
//! The checks themselves look at SyncManager registers and live in the slave; this module is pure.

use crate::wire::enum_with_unknown;
use core::fmt;

/// An AL state (the low nibble of AL control and AL status).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AlState {
    /// INIT: no mailbox, no process data; the master sets up the DL registers.
    Init,
    /// PRE-OPERATIONAL: the mailbox works (TMCL), no process data.
    PreOp,
    /// BOOTSTRAP: only FoE through the mailbox (firmware update, manual §3.3).
    Boot,
    /// SAFE-OPERATIONAL: inputs are updated, outputs are held safe.
    SafeOp,
    /// OPERATIONAL: outputs drive the motor.
    Op,
}

impl AlState {
    /// The state's code in AL control and AL status.
    pub const fn code(self) -> u8 {
        match self {
            AlState::Init => 1,
            AlState::PreOp => 2,
            AlState::Boot => 3,
            AlState::SafeOp => 4,
            AlState::Op => 8,
        }
    }

    /// The state a code names, if any.
    pub const fn from_code(code: u8) -> Option<AlState> {
        match code {
            1 => Some(AlState::Init),
            2 => Some(AlState::PreOp),
            3 => Some(AlState::Boot),
            4 => Some(AlState::SafeOp),
            8 => Some(AlState::Op),
            _ => None,
        }
    }

    /// Rank for "higher" and "lower" (INIT < PRE-OP < SAFE-OP < OP; BOOT just above INIT).
    const fn rank(self) -> u8 {
        match self {
            AlState::Init => 0,
            AlState::Boot => 1,
            AlState::PreOp => 2,
            AlState::SafeOp => 3,
            AlState::Op => 4,
        }
    }

    /// Whether `self` is a higher state than `other`.
    pub const fn above(self, other: AlState) -> bool {
        self.rank() > other.rank()
    }
}

impl fmt::Display for AlState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            AlState::Init => "INIT",
            AlState::PreOp => "PRE-OP",
            AlState::Boot => "BOOT",
            AlState::SafeOp => "SAFE-OP",
            AlState::Op => "OP",
        })
    }
}

enum_with_unknown! {
    /// AL status codes (ETG.1000.6, "AL status codes"): why a transition was refused or the slave fell
    /// back. Only those this slave raises, and the common ones a master reports, are named.
    pub enum AlStatusCode(u16) {
        /// No error.
        NoError = 0x0000,
        /// Unspecified error.
        Unspecified = 0x0001,
        /// Invalid requested state change.
        InvalidStateChange = 0x0011,
        /// Unknown requested state.
        UnknownState = 0x0012,
        /// Bootstrap not supported.
        BootNotSupported = 0x0013,
        /// Invalid mailbox configuration (BOOT).
        InvalidBootMailbox = 0x0015,
        /// Invalid mailbox configuration (PRE-OP).
        InvalidMailbox = 0x0016,
        /// Invalid sync manager configuration.
        InvalidSmConfiguration = 0x0017,
        /// No valid outputs.
        NoValidOutputs = 0x0019,
        /// Sync manager watchdog.
        SmWatchdog = 0x001B,
        /// Invalid sync manager types.
        InvalidSmTypes = 0x001C,
        /// Invalid output configuration.
        InvalidOutputs = 0x001D,
        /// Invalid input configuration.
        InvalidInputs = 0x001E,
        /// Invalid watchdog configuration.
        InvalidWatchdog = 0x001F,
        /// Invalid DC SYNC configuration.
        InvalidDcSync = 0x0030,
    }
}

/// A step the master asked for that needs the slave's checks (manual §3.2's table of state changes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// INIT → PRE-OP: "the EtherCAT slave checks the correct initialization of the mailbox".
    InitToPreOp,
    /// INIT → BOOT: the bootstrap mailbox must be configured.
    InitToBoot,
    /// PRE-OP → SAFE-OP: "checks the correct initialization of the SyncManager channels for the process
    /// data as well as the adjustments for the Distributed Clocks".
    PreOpToSafeOp,
    /// SAFE-OP → OP: "Before the EtherCAT slave changes the state to Operational it has to transfer
    /// valid output data".
    SafeOpToOp,
}

/// What a request in AL control leads to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// Nothing changes (the requested state is the current one, or an error waits for its
    /// acknowledge).
    Stay,
    /// The slave enters the state.
    Go(AlState),
    /// The slave stays, sets the error indication and this code.
    Refuse(AlStatusCode),
    /// SAFE-OP → OP waits for the first valid outputs (AL status stays SAFE-OP until then).
    AwaitOutputs,
}

/// The AL status a slave shows: state, error indication, code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AlStatus {
    /// The state.
    pub state: AlState,
    /// The error indication (AL status bit 4).
    pub error: bool,
    /// The AL status code (0x0134).
    pub code: AlStatusCode,
}

impl AlStatus {
    /// INIT without error, as after power-on.
    pub const INIT: AlStatus = AlStatus { state: AlState::Init, error: false, code: AlStatusCode::NoError };

    /// The AL status register value.
    pub const fn register(&self) -> u16 {
        self.state.code() as u16 | if self.error { 0x10 } else { 0 }
    }
}

/// The transition `match`: what the request `control` (AL control's low byte) does to `status`. `check`
/// runs the slave's checks for a step that needs them and says why it fails, if it does; it is called
/// only for the step taken.
///
/// Error handling (ETG.1000.6, "AL control"): with the error indication set and no acknowledge (bit 4),
/// a request for a higher state is ignored, a request for a lower one is carried out and the indication
/// stays. An acknowledge clears the indication and the code, then the request is carried out.
pub fn decide(status: AlStatus, control: u8, check: impl FnOnce(Step) -> Result<(), AlStatusCode>) -> Decision {
    let acknowledge = control & 0x10 != 0;
    let Some(target) = AlState::from_code(control & 0x0F) else {
        return Decision::Refuse(AlStatusCode::UnknownState);
    };
    if status.error && !acknowledge && target.above(status.state) {
        return Decision::Stay;
    }
    use AlState::*;
    match (status.state, target) {
        // The state it is in: nothing to do (an acknowledge alone clears the error, done by the caller).
        (s, t) if s == t => Decision::Stay,
        // §3.2: Init → Pre-Operational "checks the correct initialization of the mailbox".
        (Init, PreOp) => check(Step::InitToPreOp).map_or_else(Decision::Refuse, |()| Decision::Go(PreOp)),
        // §3.2: Bootstrap "is reachable from the Init state", with its own mailbox.
        (Init, Boot) => check(Step::InitToBoot).map_or_else(Decision::Refuse, |()| Decision::Go(Boot)),
        // §3.2: Pre-Operational → Safe-Operational checks the process-data SyncManagers and the DC.
        (PreOp, SafeOp) => check(Step::PreOpToSafeOp).map_or_else(Decision::Refuse, |()| Decision::Go(SafeOp)),
        // §3.2: Safe-Operational → Operational needs valid outputs first.
        (SafeOp, Op) => match check(Step::SafeOpToOp) {
            Ok(()) => Decision::Go(Op),
            Err(AlStatusCode::NoValidOutputs) => Decision::AwaitOutputs,
            Err(code) => Decision::Refuse(code),
        },
        // Down, to any lower state, is always allowed (ETG.1000.6 state diagram).
        (PreOp | SafeOp | Op, Init) | (SafeOp | Op, PreOp) | (Op, SafeOp) => Decision::Go(target),
        // §3.2: Bootstrap "State changes only from and to Init".
        (Boot, Init) => Decision::Go(Init),
        // Everything else skips a state or leaves BOOT sideways: ETG.1000.6 refuses it with 0x0011.
        _ => Decision::Refuse(AlStatusCode::InvalidStateChange),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use AlState::*;

    fn st(state: AlState) -> AlStatus {
        AlStatus { state, error: false, code: AlStatusCode::NoError }
    }

    fn pass(_: Step) -> Result<(), AlStatusCode> {
        Ok(())
    }

    #[test]
    fn the_way_up_and_down() {
        assert_eq!(decide(st(Init), 0x02, pass), Decision::Go(PreOp));
        assert_eq!(decide(st(PreOp), 0x04, pass), Decision::Go(SafeOp));
        assert_eq!(decide(st(SafeOp), 0x08, pass), Decision::Go(Op));
        assert_eq!(decide(st(Op), 0x04, pass), Decision::Go(SafeOp));
        assert_eq!(decide(st(Op), 0x01, pass), Decision::Go(Init));
        assert_eq!(decide(st(Init), 0x03, pass), Decision::Go(Boot));
        assert_eq!(decide(st(Boot), 0x01, pass), Decision::Go(Init));
        assert_eq!(decide(st(Op), 0x08, pass), Decision::Stay);
    }

    #[test]
    fn skipping_a_state_is_refused() {
        for (from, to) in
            [(Init, 0x04), (Init, 0x08), (PreOp, 0x08), (PreOp, 0x03), (Op, 0x03), (Boot, 0x02), (Boot, 0x08)]
        {
            assert_eq!(
                decide(st(from), to, pass),
                Decision::Refuse(AlStatusCode::InvalidStateChange),
                "{from} -> {to}"
            );
        }
        assert_eq!(decide(st(Init), 0x05, pass), Decision::Refuse(AlStatusCode::UnknownState));
        assert_eq!(decide(st(Init), 0x00, pass), Decision::Refuse(AlStatusCode::UnknownState));
    }

    #[test]
    fn failed_checks_refuse_with_their_code() {
        let bad_mailbox = |_| Err(AlStatusCode::InvalidMailbox);
        assert_eq!(decide(st(Init), 0x02, bad_mailbox), Decision::Refuse(AlStatusCode::InvalidMailbox));
        let no_outputs = |_| Err(AlStatusCode::NoValidOutputs);
        assert_eq!(decide(st(SafeOp), 0x08, no_outputs), Decision::AwaitOutputs);
    }

    #[test]
    fn an_error_blocks_the_way_up_until_acknowledged() {
        let err = AlStatus { state: PreOp, error: true, code: AlStatusCode::InvalidOutputs };
        assert_eq!(decide(err, 0x04, pass), Decision::Stay);
        assert_eq!(decide(err, 0x14, pass), Decision::Go(SafeOp));
        assert_eq!(decide(err, 0x01, pass), Decision::Go(Init));
    }

    #[test]
    fn register_value() {
        assert_eq!(AlStatus { state: SafeOp, error: true, code: AlStatusCode::SmWatchdog }.register(), 0x14);
        assert_eq!(u16::from(AlStatusCode::SmWatchdog), 0x001B);
    }
}

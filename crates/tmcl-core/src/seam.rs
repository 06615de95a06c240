//! The one seam between the firmware and everything outside it, which counts what changes.
//!
//! The module holds its board inside a [`Seam`]: every write to the board (a new drive state, driver
//! settings, outputs that differ from the last ones, an EEPROM write) passes the seam's trait impls and
//! counts one change, whichever path of the firmware makes it; every input from outside (a host frame, a
//! mailbox message, a library call that writes firmware state, the board changed from outside) counts one
//! at the module's public entry points ([`Seam::input`]). What keeps a result that holds only while
//! nothing changes — a simulator that found the program spinning in a fixed point, behind the board's
//! hook ([`crate::hal::Hook`], [`crate::hal::Pass::changes`]) — remembers the count it was found at and
//! is void when the count moved on: no write path has to remember a call.
//!
//! What the board does along its own timeline (the module bringing the board's clock to an instant with
//! the state it was last told, [`Seam::timeline`]) is not a change.

use crate::hal::{
    Analog, DriveState, DriverSettings, EncoderCounter, Inputs, LoadSensor, Nvm, Outputs, Quiet, StepDriver,
    SwitchInputs, Switches,
};
use crate::time::Instant;

/// A board behind the counting seam (see the module docs).
#[derive(Debug)]
pub(crate) struct Seam<B> {
    board: B,
    /// Changes counted since power-up (wrapping).
    changes: u32,
    /// The outputs as the board was last told them (`None`: not yet).
    outputs: Option<u8>,
}

impl<B> Seam<B> {
    pub(crate) fn new(board: B) -> Seam<B> {
        Seam { board, changes: 0, outputs: None }
    }

    /// The count of changes so far: equal counts at two instants say nothing changed between them.
    #[inline(always)]
    pub(crate) fn changes(&self) -> u32 {
        self.changes
    }

    /// Something reached the module from outside (a host input, a library call that writes its state).
    #[inline(always)]
    pub(crate) fn input(&mut self) {
        self.changes = self.changes.wrapping_add(1);
    }

    /// The board, to read.
    #[inline(always)]
    pub(crate) fn get(&self) -> &B {
        &self.board
    }

    /// The board, changed from outside: counts as a change.
    pub(crate) fn changed(&mut self) -> &mut B {
        self.input();
        &mut self.board
    }

    /// The board, to move it along its own timeline or take readings: no change.
    #[inline(always)]
    pub(crate) fn timeline(&mut self) -> &mut B {
        &mut self.board
    }
}

impl<B: Nvm> Nvm for Seam<B> {
    type Error = B::Error;
    #[inline]
    fn capacity(&self) -> usize {
        self.board.capacity()
    }
    #[inline]
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.board.read(offset, buf)
    }
    /// An EEPROM write: a change.
    #[inline]
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Self::Error> {
        self.input();
        self.board.write(offset, data)
    }
}

impl<B: Outputs> Outputs for Seam<B> {
    /// Outputs other than the last ones: a change.
    #[inline]
    fn set_outputs(&mut self, bits: u8) {
        if self.outputs != Some(bits) {
            self.outputs = Some(bits);
            self.input();
        }
        self.board.set_outputs(bits);
    }
    /// The switches' pull-ups: a change (rare: a host's SIO).
    #[inline]
    fn set_pull_ups(&mut self, bits: u8) {
        self.input();
        self.board.set_pull_ups(bits);
    }
}

impl<B: StepDriver> StepDriver for Seam<B> {
    /// A drive state for the board: a change (the module tells the board only what is new; the same state
    /// again, to bring its clock on, goes through [`Seam::timeline`]).
    #[inline]
    fn update(&mut self, motor: usize, now: Instant, state: &DriveState) {
        self.input();
        self.board.update(motor, now, state);
    }
    /// Driver settings: a change.
    #[inline]
    fn configure(&mut self, motor: usize, settings: &DriverSettings) {
        self.input();
        self.board.configure(motor, settings);
    }
    #[inline]
    fn quiet(&mut self, motor: usize, now: Instant, state: &DriveState) -> Option<Quiet> {
        self.board.quiet(motor, now, state)
    }
    #[inline]
    fn period(&mut self, motor: usize, state: &DriveState, quiet: &mut Quiet) -> u64 {
        self.board.period(motor, state, quiet)
    }
    #[inline]
    fn counts_at(&mut self, motor: usize, state: &DriveState, ahead: i64) -> Option<i64> {
        self.board.counts_at(motor, state, ahead)
    }
}

impl<B: Inputs> Inputs for Seam<B> {
    #[inline]
    fn digital_inputs(&mut self) -> u8 {
        self.board.digital_inputs()
    }
}

impl<B: Analog> Analog for Seam<B> {
    #[inline]
    fn analog_input(&mut self, channel: u8) -> u16 {
        self.board.analog_input(channel)
    }
    #[inline]
    fn temperature(&mut self) -> i32 {
        self.board.temperature()
    }
    #[inline]
    fn supply_voltage(&mut self) -> u16 {
        self.board.supply_voltage()
    }
}

impl<B: SwitchInputs> SwitchInputs for Seam<B> {
    #[inline]
    fn switches(&mut self, motor: usize) -> Switches {
        self.board.switches(motor)
    }
}

impl<B: LoadSensor> LoadSensor for Seam<B> {
    #[inline]
    fn load(&mut self, motor: usize) -> u16 {
        self.board.load(motor)
    }
    #[inline]
    fn load_measurements(&mut self, motor: usize) -> u32 {
        self.board.load_measurements(motor)
    }
    #[inline]
    fn driver_flags(&mut self, motor: usize) -> u8 {
        self.board.driver_flags(motor)
    }
}

impl<B: EncoderCounter> EncoderCounter for Seam<B> {
    #[inline]
    fn encoder_counts(&mut self, motor: usize) -> i64 {
        self.board.encoder_counts(motor)
    }
}

#[cfg(test)]
mod tests {
    use super::Seam;
    use crate::hal::{DriveState, Nvm, Outputs, StepDriver};
    use crate::time::Instant;

    #[derive(Default)]
    struct Probe {
        writes: usize,
        outputs: usize,
        updates: usize,
    }
    impl Nvm for Probe {
        type Error = ();
        fn capacity(&self) -> usize {
            16
        }
        fn read(&mut self, _: usize, _: &mut [u8]) -> Result<(), ()> {
            Ok(())
        }
        fn write(&mut self, _: usize, _: &[u8]) -> Result<(), ()> {
            self.writes += 1;
            Ok(())
        }
    }
    impl Outputs for Probe {
        fn set_outputs(&mut self, _: u8) {
            self.outputs += 1;
        }
    }
    impl StepDriver for Probe {
        fn update(&mut self, _: usize, _: Instant, _: &DriveState) {
            self.updates += 1;
        }
    }

    #[test]
    fn every_write_counts_and_passes_reads_and_the_timeline_do_not() {
        let mut s = Seam::new(Probe::default());
        let c0 = s.changes();
        s.write(0, &[1]).unwrap();
        assert_eq!(s.changes(), c0 + 1, "an EEPROM write");
        s.read(0, &mut [0]).unwrap();
        assert_eq!(s.changes(), c0 + 1, "a read");
        s.set_outputs(3);
        s.set_outputs(3);
        assert_eq!(s.changes(), c0 + 2, "new outputs count once; the same again is no change");
        assert_eq!(s.get().outputs, 2, "but both reach the board");
        s.update(0, Instant::ZERO, &DriveState::default());
        assert_eq!(s.changes(), c0 + 3, "a drive state");
        s.timeline().update(0, Instant::from_millis(1), &DriveState::default());
        assert_eq!(s.changes(), c0 + 3, "the board's own timeline");
        assert_eq!(s.get().updates, 2);
        s.changed();
        s.input();
        assert_eq!(s.changes(), c0 + 5, "the board changed from outside, a host input");
        assert_eq!(s.get().writes, 1);
    }
}

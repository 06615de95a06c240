//! Interrupt vectors as data (PD28-1021 manual §3.6.6 Table 12, §5.4 Table 19): each vector names the
//! event that raises it ([`Source`]) and the bank 3 parameter that configures it, so the firmware fires a
//! model's vectors from its table and knows nothing of their numbers.

use crate::capacity::{MAX_MOTORS, MAX_TIMERS, MAX_VECTORS};

/// The global interrupt switch of EI/DI (PD28-1021 manual §3.7.32).
pub const GLOBAL_INTERRUPTS: u8 = 255;

/// The event behind an interrupt vector. The motion sources name their motor (0 = the first): Table 12
/// of the PD28-1021 manual numbers them per axis ("Target position reached 0", "stallGuard axis 0",
/// "Deviation axis 0", "Left stop switch 0", "Right stop switch 0") and leaves the numbers between for
/// further axes (3.., 15.., 21.., 27/28..).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Timer n: fires every period (its configuration parameter, in ms; 0 = off).
    Timer(u8),
    /// Motor n reached its target position.
    TargetReached(u8),
    /// stallGuard stopped motor n.
    Stall(u8),
    /// The encoder deviation check stopped motor n.
    Deviation(u8),
    /// A transition of motor n's left stop switch (its configuration parameter selects which).
    LeftStop(u8),
    /// A transition of motor n's right stop switch.
    RightStop(u8),
    /// A transition of digital input n.
    Input(u8),
}

impl Source {
    /// Whether the source is a level whose transitions raise it (switches and inputs).
    pub const fn is_level(self) -> bool {
        matches!(self, Source::LeftStop(_) | Source::RightStop(_) | Source::Input(_))
    }
}

/// One interrupt vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InterruptDesc {
    /// The interrupt number (EI/DI/VECT type byte; priority: lower first).
    pub number: u8,
    /// The manual's name.
    pub name: &'static str,
    /// The assembler symbol (TMCL-IDE's `Interrupts.inc`).
    pub symbol: &'static str,
    /// What raises it.
    pub source: Source,
    /// The bank 3 parameter that configures it (a timer's period, a transition's trigger), if any.
    pub config: Option<u8>,
}

/// Marks a source a model does not have.
const NONE: u8 = 0xFF;

/// A model's interrupt vectors with masks and lookups computed at compile time.
#[derive(Debug)]
pub struct Interrupts {
    /// The vectors, in number order.
    pub list: &'static [InterruptDesc],
    /// Bit n: vector n exists.
    pub all: u64,
    /// Bit n: vector n is a timer.
    pub timers_mask: u64,
    /// Bit n: vector n watches a switch or an input level.
    pub levels_mask: u64,
    timers: [u8; MAX_TIMERS],
    target_reached: [u8; MAX_MOTORS as usize],
    stall: [u8; MAX_MOTORS as usize],
    deviation: [u8; MAX_MOTORS as usize],
}

impl Interrupts {
    /// Builds the table; fails to compile if a number is ≥ 64 or used twice, the list is out of order, a
    /// timer index is beyond the firmware's timers, or a source appears twice.
    pub const fn new(list: &'static [InterruptDesc]) -> Interrupts {
        let mut t = Interrupts {
            list,
            all: 0,
            timers_mask: 0,
            levels_mask: 0,
            timers: [NONE; MAX_TIMERS],
            target_reached: [NONE; MAX_MOTORS as usize],
            stall: [NONE; MAX_MOTORS as usize],
            deviation: [NONE; MAX_MOTORS as usize],
        };
        let mut i = 0;
        while i < list.len() {
            let d = &list[i];
            assert!((d.number as usize) < MAX_VECTORS, "interrupt numbers are below 64");
            assert!(i == 0 || list[i - 1].number < d.number, "interrupts must be in number order");
            let bit = 1u64 << d.number;
            t.all |= bit;
            match d.source {
                Source::Timer(n) => {
                    assert!((n as usize) < MAX_TIMERS, "more timers than the firmware has");
                    assert!(t.timers[n as usize] == NONE, "a timer with two vectors");
                    t.timers[n as usize] = d.number;
                    t.timers_mask |= bit;
                }
                Source::TargetReached(m) => {
                    assert!((m as usize) < MAX_MOTORS as usize, "a motor the firmware does not drive");
                    assert!(t.target_reached[m as usize] == NONE, "two target-reached vectors for a motor");
                    t.target_reached[m as usize] = d.number;
                }
                Source::Stall(m) => {
                    assert!((m as usize) < MAX_MOTORS as usize, "a motor the firmware does not drive");
                    assert!(t.stall[m as usize] == NONE, "two stall vectors for a motor");
                    t.stall[m as usize] = d.number;
                }
                Source::Deviation(m) => {
                    assert!((m as usize) < MAX_MOTORS as usize, "a motor the firmware does not drive");
                    assert!(t.deviation[m as usize] == NONE, "two deviation vectors for a motor");
                    t.deviation[m as usize] = d.number;
                }
                Source::LeftStop(_) | Source::RightStop(_) | Source::Input(_) => t.levels_mask |= bit,
            }
            i += 1;
        }
        t
    }

    /// No interrupts at all.
    pub const NONE: Interrupts = Interrupts::new(&[]);

    /// The vector of `number`, if the model has it.
    pub fn find(&self, number: u8) -> Option<&'static InterruptDesc> {
        if usize::from(number) >= MAX_VECTORS || self.all & (1 << number) == 0 {
            return None;
        }
        self.list.iter().find(|d| d.number == number)
    }

    /// The vector number of timer `n`.
    #[inline]
    pub fn timer(&self, n: usize) -> Option<u8> {
        self.timers.get(n).copied().filter(|v| *v != NONE)
    }

    /// The vector number of motor `motor`'s target-reached interrupt, if the model has one.
    #[inline]
    pub fn target_reached(&self, motor: usize) -> Option<u8> {
        self.target_reached.get(motor).copied().filter(|v| *v != NONE)
    }

    /// The vector number of motor `motor`'s stall interrupt, if the model has one.
    #[inline]
    pub fn stall(&self, motor: usize) -> Option<u8> {
        self.stall.get(motor).copied().filter(|v| *v != NONE)
    }

    /// The vector number of motor `motor`'s deviation interrupt, if the model has one.
    #[inline]
    pub fn deviation(&self, motor: usize) -> Option<u8> {
        self.deviation.get(motor).copied().filter(|v| *v != NONE)
    }

    /// Number of vectors.
    pub const fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether the model has no interrupts.
    pub const fn is_empty(&self) -> bool {
        self.list.is_empty()
    }
}

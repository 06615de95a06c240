//! The global banks in RAM (PD28-1021 manual chapter 5): bank 0's settings (§5.1), bank 2's user
//! variables (§5.3), bank 3's interrupt configuration (§5.4), and what bank 0's computed parameters keep
//! (GP 132's tick base, GP 133's generator, the password's lock). A component of its own: it knows the
//! model's tables it is given, never the module; the module's glue (`module/params.rs`) adds the EEPROM
//! and the program machine.

use crate::model::{ModelSpec, Setting};
use crate::time::Instant;
use tmcl_model::capacity::{MAX_GLOBAL_PARAMS, MAX_INTERRUPT_PARAMS, MAX_USER_VARIABLES};

/// GP 133's generator starts from this seed at every start (a write to GP 133 reseeds it).
pub(crate) const RNG_SEED: u32 = 0x2545_F491;

/// The global banks' RAM (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Banks {
    /// Bank 0, in the model's global table order.
    pub(crate) global: [i32; MAX_GLOBAL_PARAMS],
    /// Bank 3, in the model's interrupt table order.
    pub(crate) interrupt: [i32; MAX_INTERRUPT_PARAMS],
    /// Bank 2: the user variables.
    pub(crate) user: [i32; MAX_USER_VARIABLES],
    /// GP 132's reference: (time, value at that time).
    pub(crate) tick_base: (Instant, u32),
    /// GP 133's generator (xorshift32).
    pub(crate) rng: u32,
    /// Password-protected parameters may be written (see [`crate::model::Role::Password`]).
    pub(crate) unlocked: bool,
}

impl Banks {
    /// Empty banks at a start at `now`: every value 0, GP 132 counting from 0, the generator at its seed,
    /// locked.
    pub(crate) fn new(now: Instant) -> Banks {
        Banks {
            global: [0; MAX_GLOBAL_PARAMS],
            interrupt: [0; MAX_INTERRUPT_PARAMS],
            user: [0; MAX_USER_VARIABLES],
            tick_base: (now, 0),
            rng: RNG_SEED,
            unlocked: false,
        }
    }

    /// The value of the bank 0 parameter with `setting` in `spec`'s global table, if the model has one.
    #[inline]
    pub(crate) fn gp(&self, spec: &ModelSpec, setting: Setting) -> Option<i32> {
        spec.global.setting(setting).map(|i| self.global[i])
    }

    /// Whether the bank 0 flag with `setting` is set (a model without it: not set).
    #[inline]
    pub(crate) fn flag(&self, spec: &ModelSpec, setting: Setting) -> bool {
        self.gp(spec, setting) == Some(1)
    }

    /// GP 132 at `now`: "incremented every 1 ms" (§5.1) from the value last written, 31 bits.
    #[inline]
    pub(crate) fn tick_timer(&self, now: Instant) -> i32 {
        let (at, base) = self.tick_base;
        ((u64::from(base) + (now - at).millis()) & 0x7FFF_FFFF) as i32
    }

    /// GP 133: a new random number 0..2^31−1 on every read (§5.1; xorshift32).
    #[inline]
    pub(crate) fn random(&mut self) -> i32 {
        let mut x = self.rng;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.rng = x;
        (x & 0x7FFF_FFFF) as i32
    }

    /// A write of GP 133 seeds the generator (0 would stick; it becomes the start seed).
    #[inline]
    pub(crate) fn seed(&mut self, v: i32) {
        self.rng = if v == 0 { RNG_SEED } else { v as u32 };
    }
}

//! The global banks in RAM (PD28-1021 manual chapter 5): bank 0's settings (§5.1), bank 2's user
//! variables (§5.3), bank 3's interrupt configuration (§5.4), and what bank 0's computed parameters keep
//! (GP 132's tick base, GP 133's generator, the password's lock). A component of its own: it knows the
//! model's tables it is given, never the module; the module's glue (`module/params.rs`) adds the EEPROM
//! and the program machine.
//!
//! Bank 0 changes through one function, `Banks::set_global`, which also keeps the settings every frame
//! reads (`FrameSettings`) ready: no other code can write the bank, so they are never stale.

use crate::model::{ModelSpec, Setting};
use crate::time::{Duration, Instant};
use tmcl_model::capacity::{MAX_GLOBAL_PARAMS, MAX_INTERRUPT_PARAMS, MAX_USER_VARIABLES};

/// GP 133's generator starts from this seed at every start (a write to GP 133 reseeds it).
pub(crate) const RNG_SEED: u32 = 0x2545_F491;

/// The bank 0 settings the way of a frame reads (§5.1), kept ready by [`Banks::set_global`] instead of
/// looked up through the model's table at every frame: each is the value of its setting in bank 0, or what
/// a model without the setting does (the list of settings a model may lack, in `module.rs`'s docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct FrameSettings {
    /// The module (primary) address: GP 66, or 1.
    pub address: u8,
    /// The secondary address: GP 87, or 0 (none).
    pub secondary: u8,
    /// The host address replies go to: GP 76, or 2.
    pub host: u8,
    /// Replies suppressed: GP 255 = 1.
    pub suppress: bool,
    /// The telegram pause in ms: GP 75 (a negative value counts as 0), or 0.
    pub pause_ms: u32,
    /// The heartbeat in ms: GP 68 (0 or less: off), or 0.
    pub heartbeat: i32,
}

impl FrameSettings {
    /// A model with none of the settings.
    const ABSENT: FrameSettings =
        FrameSettings { address: 1, secondary: 0, host: 2, suppress: false, pause_ms: 0, heartbeat: 0 };

    /// The settings of bank 0 `global` of a model with global table `spec.global`.
    fn of(spec: &ModelSpec, global: &[i32; MAX_GLOBAL_PARAMS]) -> FrameSettings {
        let mut ready = FrameSettings::ABSENT;
        for (d, &v) in spec.global.params.iter().zip(global) {
            if let Some(setting) = d.setting {
                ready.note(setting, v);
            }
        }
        ready
    }

    /// Takes in that `setting` is now `v` (only the setting's own field depends on it).
    #[inline]
    fn note(&mut self, setting: Setting, v: i32) {
        match setting {
            Setting::SerialAddress => self.address = v as u8,
            Setting::SecondaryAddress => self.secondary = v as u8,
            Setting::HostAddress => self.host = v as u8,
            Setting::SuppressReply => self.suppress = v == 1,
            Setting::TelegramPause => self.pause_ms = v.max(0) as u32,
            Setting::SerialHeartbeat => self.heartbeat = v,
            _ => {}
        }
    }
}

/// The global banks' RAM (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Banks {
    /// Bank 0, in the model's global table order: written by [`Banks::set_global`] only.
    global: [i32; MAX_GLOBAL_PARAMS],
    /// What the way of a frame reads of bank 0, kept with it.
    ready: FrameSettings,
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
    /// Empty banks of a model with `spec`'s tables at a start at `now`: every value 0, GP 132 counting
    /// from 0, the generator at its seed, locked.
    pub(crate) fn new(spec: &ModelSpec, now: Instant) -> Banks {
        let global = [0; MAX_GLOBAL_PARAMS];
        Banks {
            global,
            ready: FrameSettings::of(spec, &global),
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

    /// Bank 0's parameter `i` (an index into the model's global table).
    #[inline]
    pub(crate) fn global(&self, i: usize) -> i32 {
        self.global[i]
    }

    /// The whole of bank 0 (a closed loop's period compares it).
    #[cfg(feature = "loop-periods")]
    #[inline]
    pub(crate) fn globals(&self) -> &[i32; MAX_GLOBAL_PARAMS] {
        &self.global
    }

    /// Bank 0's parameter `i` of `spec`'s global table := `v`: the one way bank 0 changes (SGP, RSGP, the
    /// EEPROM's values at a start, the factory defaults, `Module::set_address`), and what keeps the
    /// [`FrameSettings`] ready.
    #[inline]
    pub(crate) fn set_global(&mut self, spec: &ModelSpec, i: usize, v: i32) {
        self.global[i] = v;
        if let Some(setting) = spec.global.params[i].setting {
            self.ready.note(setting, v);
        }
        debug_assert_eq!(self.ready, FrameSettings::of(spec, &self.global));
    }

    /// The bank 0 settings every frame reads.
    #[inline(always)]
    pub(crate) fn ready(&self) -> &FrameSettings {
        &self.ready
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

    /// When GP 132 next changes after `now`: its next increment.
    #[inline]
    pub(crate) fn tick_timer_changes(&self, now: Instant) -> Instant {
        let (at, _) = self.tick_base;
        at + Duration::from_millis((now - at).millis() + 1)
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

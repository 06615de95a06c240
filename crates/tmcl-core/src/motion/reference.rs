//! Reference search (PD28-1021 manual §3.7.13 RFS, §7.1 Table 21, AP 193–197).
//!
//! The figures that showed each mode's path are missing from the manual; the text gives
//! the general sequence ("move at AP 194 towards the switch until it is found, then slowly at AP 195 ...
//! the reference point is the centre of the two switching points; the counter is set to zero there") and
//! the per-mode table. Our decisions, each written beside its mode below:
//!
//! - The switch is looked at after every microstep; a switching point is the last microstep at which the
//!   switch was pressed. The motor stops at once at each one (as at an end switch) and starts the next
//!   phase from standstill with AP 5.
//! - After the search the motor stands where the last phase stopped (it does not drive to 0); the counter
//!   is shifted so that the reference point reads 0. AP 197 keeps the counter value just before.
//! - The limit-switch disables AP 12/13 do not affect the search (§7.1); while a search runs it handles
//!   the switches itself.
//! - A switch that is never found: the search goes on until RFS STOP, as on the real module, except in
//!   modes 5/6, which give up (motor stopped, nothing zeroed) when the second end switch is reached.
//! - AP 193 decodes bitwise: bit 6 (+64) = use the right switch instead of the left (modes 1–4), bit 7
//!   (+128) = inverted home switch (modes 5–8). The manual's examples print 129..132 for the inverted
//!   modes 5..8; since 128 + 1..4 has no other meaning, those are accepted as that alias.
//! - Mode 8 searches in the negative direction (Table 21 and AP 193; §7.1.8's "positive" is copied from
//!   mode 7).
//! - Which values AP 193 takes is the model's ([`ReferenceModes`]): the PD28-1021's modes above, or the
//!   TMC428 generation's 1–3.

use tmcl_model::ReferenceModes;

/// Which switch a phase watches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Switch {
    /// Left stop switch.
    Left,
    /// Right stop switch.
    Right,
    /// Home switch (inverted with +128).
    Home,
}

/// One phase of a search: drive in `dir` at the fast or slow speed until `switch` reads `until`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Phase {
    switch: Switch,
    dir: i8,
    fast: bool,
    until: bool,
    /// What the position at the switching point is used for.
    mark: Mark,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mark {
    /// Nothing.
    None,
    /// The first of the two points whose centre is the reference.
    A,
    /// The second; after it the counter is zeroed.
    B,
    /// The far end switch (for AP 196).
    Far,
}

const fn phase(switch: Switch, dir: i8, fast: bool, until: bool, mark: Mark) -> Phase {
    Phase { switch, dir, fast, until, mark }
}

/// A decoded AP 193 value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SearchMode {
    /// 1..=8.
    pub mode: u8,
    /// +64: the right switch instead of the left (modes 1–4).
    pub mirrored: bool,
    /// +128: the home switch is active low (modes 5–8).
    pub inverted_home: bool,
}

impl SearchMode {
    /// Decodes AP 193 for a model's mode set: the PD28-1021's (see the module docs), or the TMC428
    /// generation's modes 1–3.
    pub fn decode(value: i32, modes: ReferenceModes) -> Option<SearchMode> {
        if modes == ReferenceModes::Tmc428 {
            // 1 left switch only and 2 right switch, then left, as the PD28-1021's modes 1 and 2; 3 right
            // switch, then the reference switch (a phase plan of its own, mode 9 here).
            let mode = match value {
                1 | 2 => value as u8,
                3 => 9,
                _ => return None,
            };
            return Some(SearchMode { mode, mirrored: false, inverted_home: false });
        }
        let v = u8::try_from(value).ok()?;
        let (base, mirrored, inverted) = (v & 0x3F, v & 64 != 0, v & 128 != 0);
        match (base, mirrored, inverted) {
            (1..=4, false, true) => Some(SearchMode { mode: base + 4, mirrored: false, inverted_home: true }),
            (1..=4, m, false) => Some(SearchMode { mode: base, mirrored: m, inverted_home: false }),
            (5..=8, false, i) => Some(SearchMode { mode: base, mirrored: false, inverted_home: i }),
            _ => None,
        }
    }

    /// The phases of this mode, in order (at most 4).
    fn phases(self) -> ([Phase; 4], usize) {
        use Mark::*;
        use Switch::*;
        // Mirroring swaps the end switches and the directions of modes 1–4.
        let (near, far, d) = if self.mirrored { (Right, Left, 1) } else { (Left, Right, -1) };
        let none = phase(Home, 0, false, false, None);
        match self.mode {
            // 1: "search the left stop switch only": fast onto it, slowly off it, slowly onto it again;
            // the reference is the centre of the two switching points (§7.1 general sequence).
            1 => (
                [
                    phase(near, d, true, true, None),
                    phase(near, -d, false, false, A),
                    phase(near, d, false, true, B),
                    none,
                ],
                3,
            ),
            // 2: the right switch first (for AP 196), then as mode 1 on the left.
            2 => (
                [
                    phase(far, -d, true, true, Far),
                    phase(near, d, true, true, None),
                    phase(near, -d, false, false, A),
                    phase(near, d, false, true, B),
                ],
                4,
            ),
            // 3: the right switch first, then the left one from both sides: its middle is the reference.
            3 => (
                [phase(far, -d, true, true, Far), phase(near, d, true, true, A), phase(near, d, false, false, B), none],
                3,
            ),
            // 4: the left switch from both sides: its middle is the reference.
            4 => ([phase(near, d, true, true, A), phase(near, d, false, false, B), none, none], 2),
            // 5: home switch in the negative direction (reversing at the left stop switch); 6: positive,
            // reversing at the right one. The middle of the home switch is the reference.
            5 => ([phase(Home, -1, true, true, A), phase(Home, -1, false, false, B), none, none], 2),
            6 => ([phase(Home, 1, true, true, A), phase(Home, 1, false, false, B), none, none], 2),
            // 7: home switch in the positive direction, end switches ignored; 8: negative (Table 21; §7.1.8's
            // "positive" is copied from mode 7).
            7 => ([phase(Home, 1, true, true, A), phase(Home, 1, false, false, B), none, none], 2),
            8 => ([phase(Home, -1, true, true, A), phase(Home, -1, false, false, B), none, none], 2),
            // The TMC428 generation's mode 3: the right switch first (for AP 196), then the reference
            // switch from both sides in the negative direction; its middle is the reference.
            _ => (
                [
                    phase(Right, 1, true, true, Far),
                    phase(Home, -1, true, true, A),
                    phase(Home, -1, false, false, B),
                    none,
                ],
                3,
            ),
        }
    }
}

/// Switch levels as the search sees them (after GP 79 for the end switches).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SwitchLevels {
    /// Left stop switch.
    pub left: bool,
    /// Right stop switch.
    pub right: bool,
    /// Home switch.
    pub home: bool,
}

/// What the search asks of the ramp generator after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Keep going.
    Continue,
    /// Stop at once and rotate with this signed velocity (pps).
    Rotate(i32),
    /// Stop at once; the search is over. `zero` is the position (old counter) that becomes 0 and
    /// `far_distance` the AP 196 value, if measured.
    Done {
        /// The reference point in the old counter.
        zero: i32,
        /// AP 196.
        far_distance: Option<i32>,
    },
    /// Stop at once; the search failed (modes 5/6 found no home switch between the end switches).
    Failed,
}

/// The search state machine: idle, or in phase `n` of a mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Reference {
    /// No search (RFS STATUS 0).
    #[default]
    Idle,
    /// Searching.
    Active {
        /// The mode.
        mode: SearchMode,
        /// Index of the running phase.
        phase: u8,
        /// Direction of the running phase (modes 5/6 reverse at an end switch).
        dir: i8,
        /// Reversals so far (modes 5/6).
        reversals: u8,
        /// Switching point A.
        a: i32,
        /// The far end switch position (modes 2, 3).
        far: Option<i32>,
    },
}

impl Reference {
    /// RFS STATUS: 0 = no search active, otherwise the phase number from 1 (§3.7.13: "any other value =
    /// active").
    pub fn status(&self) -> i32 {
        match self {
            Reference::Idle => 0,
            Reference::Active { phase, .. } => i32::from(*phase) + 1,
        }
    }

    /// Whether a search runs.
    pub fn is_active(&self) -> bool {
        !matches!(self, Reference::Idle)
    }

    /// RFS START: begins a search; returns the first velocity (fast speed in the first direction).
    pub fn start(&mut self, mode: SearchMode, fast: i32) -> Action {
        let (phases, _) = mode.phases();
        let dir = phases[0].dir;
        *self = Reference::Active { mode, phase: 0, dir, reversals: 0, a: 0, far: None };
        Action::Rotate(fast.saturating_mul(i32::from(dir)))
    }

    /// RFS STOP.
    pub fn stop(&mut self) {
        *self = Reference::Idle;
    }

    /// One step after a motion tick: looks at the switches at `position` and decides.
    pub fn step(&mut self, s: SwitchLevels, position: i32, fast: i32, slow: i32) -> Action {
        let Reference::Active { mode, phase, dir, reversals, a, far } = self else {
            return Action::Continue;
        };
        let (phases, count) = mode.phases();
        let p = phases[usize::from(*phase)];
        let home = s.home ^ mode.inverted_home;
        // Modes 5/6: an end switch in the search direction reverses the search, once (Table 21).
        if p.switch == Switch::Home && matches!(mode.mode, 5 | 6) {
            let blocked = (*dir < 0 && s.left) || (*dir > 0 && s.right);
            if blocked {
                if *reversals >= 1 {
                    *self = Reference::Idle;
                    return Action::Failed;
                }
                *reversals += 1;
                *dir = -*dir;
                return Action::Rotate(fast.saturating_mul(i32::from(*dir)));
            }
        }
        let level = match p.switch {
            Switch::Left => s.left,
            Switch::Right => s.right,
            Switch::Home => home,
        };
        if level != p.until {
            return Action::Continue;
        }
        // A switching point is the last microstep at which the switch was pressed: the position where it
        // closed, or the one before the position where it opened. So the middle of a switch from both
        // sides, or the centre of its two switching points, is exact to the microstep.
        let position = if p.until { position } else { position.wrapping_sub(i32::from(*dir)) };
        match p.mark {
            Mark::A => *a = position,
            Mark::Far => *far = Some(position),
            Mark::None => {}
            Mark::B => {
                let zero = midpoint(*a, position);
                let far_distance = far.map(|f| f.wrapping_sub(zero));
                *self = Reference::Idle;
                return Action::Done { zero, far_distance };
            }
        }
        let next = usize::from(*phase) + 1;
        if next >= count {
            // Only reachable with a mark-less last phase, which no mode has; end without zeroing.
            *self = Reference::Idle;
            return Action::Failed;
        }
        let n = phases[next];
        // Modes 5/6 keep the direction they found the switch in.
        let ndir = if p.switch == Switch::Home && n.switch == Switch::Home { *dir } else { n.dir };
        *phase = next as u8;
        *dir = ndir;
        let speed = if n.fast { fast } else { slow };
        Action::Rotate(speed.saturating_mul(i32::from(ndir)))
    }
}

/// The centre of two positions without overflow.
fn midpoint(a: i32, b: i32) -> i32 {
    ((i64::from(a) + i64::from(b)).div_euclid(2)) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decode_modes() {
        let m = |v| SearchMode::decode(v, ReferenceModes::Pd28).map(|m| (m.mode, m.mirrored, m.inverted_home));
        assert_eq!(m(1), Some((1, false, false)));
        assert_eq!(m(66), Some((2, true, false)));
        assert_eq!(m(135), Some((7, false, true)));
        // The manual's printed 129..132 for inverted 5..8.
        assert_eq!(m(129), Some((5, false, true)));
        assert_eq!(m(132), Some((8, false, true)));
        assert_eq!(m(69), None);
        assert_eq!(m(0), None);
        assert_eq!(m(9), None);
        assert_eq!(m(-1), None);
    }

    #[test]
    fn tmc428_modes() {
        let m = |v| SearchMode::decode(v, ReferenceModes::Tmc428).map(|m| m.mode);
        assert_eq!((m(1), m(2), m(3)), (Some(1), Some(2), Some(9)));
        assert_eq!((m(0), m(4), m(65), m(129)), (None, None, None, None));
        let (phases, n) = SearchMode::decode(3, ReferenceModes::Tmc428).unwrap().phases();
        assert_eq!((n, phases[0].switch, phases[1].switch), (3, Switch::Right, Switch::Home));
    }

    #[test]
    fn status_counts_phases() {
        let mut r = Reference::default();
        assert_eq!(r.status(), 0);
        r.start(SearchMode::decode(1, ReferenceModes::Pd28).unwrap(), 100);
        assert_eq!(r.status(), 1);
        r.stop();
        assert!(!r.is_active());
    }

    #[test]
    fn midpoints() {
        assert_eq!(midpoint(i32::MAX, i32::MAX - 2), i32::MAX - 1);
        assert_eq!(midpoint(-3, 0), -2);
    }
}

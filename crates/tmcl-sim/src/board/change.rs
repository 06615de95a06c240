//! Changes of the world while the module runs: a test or tool presses a switch, seizes the shaft, puts a
//! load on it, sets the inputs — now ([`SimBoard::change`]) or at a later instant
//! ([`SimBoard::schedule`]).
//!
//! A change goes the way of the world file's timeline: the timeline's entries (inputs, scripted load,
//! encoder slip) are [`Change`]s too, and both are applied by one function, so a change at run time does
//! exactly what the same entry in the file would do at that instant.
//!
//! # Changes and the firmware's shortcuts
//!
//! The core takes runs of motion ticks at once while the board reports a quiet window
//! ([`tmcl_core::hal::StepDriver::quiet`]), and a program spinning in a fixed point rests until something
//! changes. A change from outside must end both: make it through [`tmcl_core::Module::board_mut`], which
//! counts it as a change (the core's seam), at an instant the module has been polled to; the board's next
//! quiet window is computed from the changed world. A change scheduled for later is a timeline entry: the
//! board's quiet windows end at it ([`SimBoard::next_event`]), as they end at the file's entries.

use super::{Event, SimBoard, Switch};
use crate::world::{InputChange, WorldError};
use tmcl_core::Instant;

/// One of the board's three reference switches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SwitchId {
    /// The left stop switch (negative end; its state is AP 11, PD28-1021 manual chapter 4, Table 15).
    Left,
    /// The right stop switch (positive end; AP 10, the same table).
    Right,
    /// The home switch (the reference search, AP 193, §7.1).
    Home,
}

impl SwitchId {
    fn index(self) -> usize {
        match self {
            SwitchId::Left => 0,
            SwitchId::Right => 1,
            SwitchId::Home => 2,
        }
    }
}

/// A change of the world: an entry of the world file's timeline, or one made at run time.
#[derive(Debug, Clone, PartialEq)]
pub enum Change {
    /// The inputs change as an `[[inputs.timeline]]` entry says (its `at` is not used).
    Inputs(InputChange),
    /// The external torque on the shaft (N·m, positive pushes toward +) from now on, replacing the last
    /// one, as a `[[load.script]]` entry.
    Load(f64),
    /// The encoder gains this many counts, as a `[[faults.encoder_slip]]` entry.
    EncoderSlip(i64),
    /// The Coulomb friction on the shaft (N·m, ≥ 0) from now on, in place of `load.friction`.
    Friction(f64),
    /// A switch is pressed (`Some(true)`) or released (`Some(false)`) whatever the axis position, or
    /// (`None`) follows the position again (pressed within its `at` zone; never without a zone). A
    /// pressed switch's input reads with the switch's polarity (`active`) and bounces as it is told to.
    /// A switch the world file has no table for is a normally-open one without bounce.
    Switch(SwitchId, Option<bool>),
    /// The shaft seizes where the rotor is now: it cannot move either way until [`Change::Free`].
    Seize,
    /// The shaft is free: the seizures made at run time end, and so do the world file's seizure windows
    /// (`[[faults.stall]]`) open now; windows still to come open as the file says.
    Free,
}

impl Change {
    /// Checks the values (finite torques, friction ≥ 0, analog input 0..=4095).
    pub fn check(&self) -> Result<(), WorldError> {
        let bad = |key: &str, message: &str| {
            Err(WorldError { file: None, key: Some(key.into()), line: None, message: message.into() })
        };
        match self {
            Change::Load(t) if !t.is_finite() => bad("load.script.torque", "must be finite"),
            Change::Friction(f) if !(f.is_finite() && *f >= 0.0) => bad("load.friction", "must be finite and ≥ 0"),
            Change::Inputs(c) if c.analog.as_ref().is_some_and(|a| *a.get_ref() > 4095) => {
                bad("inputs.timeline.analog", "must be 0..=4095")
            }
            _ => Ok(()),
        }
    }
}

impl SimBoard {
    /// Changes the world now, at the board's time ([`SimBoard::now`]; a board with a clock is brought to
    /// it first). Call it through [`tmcl_core::Module::board_mut`] after polling the module to the
    /// instant, so that the firmware counts it as a change (see the [module docs](self)).
    pub fn change(&mut self, change: Change) -> Result<(), WorldError> {
        change.check()?;
        self.sync();
        let t = self.now;
        if self.apply(change, t) {
            self.apply_faults(t);
        }
        self.power();
        self.track_switches();
        Ok(())
    }

    /// Changes the world at `at`, as a timeline entry would: now if `at` is not after the board's time,
    /// else when the board gets there ([`SimBoard::next_event`] reports it, after the entries already
    /// due at the same instant).
    pub fn schedule(&mut self, at: Instant, change: Change) -> Result<(), WorldError> {
        change.check()?;
        self.sync();
        if at <= self.now {
            return self.change(change);
        }
        let pending = &self.plan.events[self.next_event..];
        let place = self.next_event + pending.partition_point(|(t, _)| *t <= at);
        self.plan.events.insert(place, (at, Event::Change(change)));
        Ok(())
    }

    /// Whether switch `id`'s contact is closed now (pressed; before polarity and bounce).
    pub fn switch_pressed(&self, id: SwitchId) -> bool {
        self.plan.switches[id.index()].as_ref().is_some_and(|s| s.pressed)
    }

    /// Whether a seizure holds the shaft now (at run time or a world file's window).
    pub fn seized(&self) -> bool {
        self.plan.mech.seized()
    }

    /// The Coulomb friction on the shaft now (N·m).
    pub fn friction(&self) -> f64 {
        self.plan.mech.friction()
    }

    /// The external torque on the shaft now (N·m; [`Change::Load`], `load.script`).
    pub fn external_torque(&self) -> f64 {
        self.plan.mech.script()
    }

    /// Applies `change` at `t` (the board is at `t`); returns whether the fault windows need a new look.
    pub(super) fn apply(&mut self, change: Change, t: Instant) -> bool {
        match change {
            Change::Inputs(c) => {
                let levels = &mut self.world;
                if let Some(d) = c.digital {
                    levels.inputs = d;
                }
                for (bit, level) in [c.in0, c.in1, c.in2, c.in3].into_iter().enumerate() {
                    match level {
                        Some(true) => levels.inputs |= 1 << bit,
                        Some(false) => levels.inputs &= !(1 << bit),
                        None => {}
                    }
                }
                if let Some(a) = &c.analog {
                    levels.analog = *a.get_ref();
                }
                if let Some(temp) = c.temperature {
                    levels.temperature = temp;
                }
            }
            Change::Load(torque) => self.plan.mech.set_script(torque),
            Change::EncoderSlip(counts) => self.encoder_slip += counts,
            Change::Friction(f) => self.plan.mech.set_friction(f),
            Change::Switch(id, forced) => {
                let switch = self.plan.switches[id.index()].get_or_insert(Switch {
                    lo: f64::INFINITY,
                    hi: f64::NEG_INFINITY,
                    active_high: true,
                    bounce: None,
                    pressed: false,
                    edge: None,
                    forced: None,
                    period: None, // (no zone: pressed only as forced)
                });
                switch.forced = forced;
            }
            Change::Seize => {
                self.held.push(self.plan.mech.rotor());
                return true;
            }
            Change::Free => {
                self.held.clear();
                for (_, from, until) in &mut self.plan.seizures {
                    if *from <= t && until.is_none_or(|u| t < u) {
                        *until = Some(t);
                    }
                }
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::World;
    use tmcl_core::model::{pd28_1021, tmcm_1310, ModelSpec};
    use tmcl_core::{Duration, Module, Outcome};
    use tmcl_wire::{Command, MoveTarget};

    fn module(spec: &'static ModelSpec, world: &str, exact: bool) -> Module<SimBoard> {
        let board = SimBoard::in_memory_for(spec).with_world(World::from_toml_str(world).unwrap()).unwrap();
        let mut m = Module::new(board, spec, Instant::ZERO);
        m.set_exact_ticks(exact);
        m
    }

    fn at(ms: u64) -> Instant {
        Instant::ZERO + Duration::from_millis(ms)
    }

    fn gap(m: &mut Module<SimBoard>, param: u8, t: Instant) -> i32 {
        match m.execute(Command::Gap { param, motor: 0 }, t) {
            Ok(Outcome::Value(v)) => v,
            other => panic!("GAP {param}: {other:?}"),
        }
    }

    /// Polls `m` from deadline to deadline (and to the board's own changes) up to `until`.
    fn run(m: &mut Module<SimBoard>, until: Instant) {
        let mut t = m.board().now();
        while t < until {
            let next = m.poll(t, &mut |_: &[u8]| {});
            m.board_timeline().advance(t);
            let board = m.board().next_event();
            t = [next, board, Some(until)].into_iter().flatten().filter(|n| *n > t).min().unwrap_or(until);
        }
        m.poll(until, &mut |_: &[u8]| {});
        m.board_timeline().advance(until);
    }

    #[test]
    fn a_pressed_left_switch_stops_a_rotation_to_the_left() {
        for exact in [false, true] {
            let mut m = module(&pd28_1021::SPEC, "", exact);
            m.execute(Command::Rol { motor: 0, velocity: 51200 }, Instant::ZERO).unwrap();
            run(&mut m, at(500));
            let before = m.board().shaft();
            assert!(before < -5_000, "turning left: {before}");
            assert_eq!(gap(&mut m, 11, at(500)), 0, "left switch released");
            m.board_mut().change(Change::Switch(SwitchId::Left, Some(true))).unwrap();
            run(&mut m, at(1000));
            assert_eq!(gap(&mut m, 11, at(1000)), 1, "AP 11 reads the pressed switch");
            assert_eq!(gap(&mut m, 3, at(1000)), 0, "stopped (exact ticks: {exact})");
            let stopped = m.board().shaft();
            run(&mut m, at(1500));
            assert_eq!(m.board().shaft(), stopped);
            // Released: the rotation may go on (ROL again).
            m.board_mut().change(Change::Switch(SwitchId::Left, None)).unwrap();
            assert_eq!(gap(&mut m, 11, at(1500)), 0);
            assert!(!m.board().switch_pressed(SwitchId::Left));
        }
    }

    #[test]
    fn run_time_changes_give_the_same_run_event_driven_and_tick_by_tick() {
        let world = "[switches.right]\nat = [\"40 rev\", \"41 rev\"]\n";
        let changes = [
            (300, Change::Friction(0.02)),
            (600, Change::Load(-0.01)),
            (900, Change::Seize),
            (1200, Change::Free),
            (1500, Change::Switch(SwitchId::Right, Some(true))),
        ];
        let mut runs = Vec::new();
        for exact in [false, true] {
            let mut m = module(&pd28_1021::SPEC, world, exact);
            m.execute(Command::Ror { motor: 0, velocity: 51200 }, Instant::ZERO).unwrap();
            let mut seen = Vec::new();
            for (ms, change) in changes.iter().cloned() {
                run(&mut m, at(ms));
                seen.push((m.board().shaft(), m.board().commanded(), gap(&mut m, 1, at(ms)), gap(&mut m, 206, at(ms))));
                m.board_mut().change(change).unwrap();
            }
            run(&mut m, at(2000));
            seen.push((m.board().shaft(), m.board().commanded(), gap(&mut m, 1, at(2000)), gap(&mut m, 3, at(2000))));
            runs.push(seen);
        }
        assert_eq!(runs[0], runs[1], "event-driven against tick by tick");
        let seized = runs[0][2].0;
        assert_eq!(runs[0][3].0, seized, "the shaft stayed where it seized while the field ran on");
        assert!(runs[0][3].1 > seized + 5_000, "{:?}", runs[0]);
        assert_eq!(runs[0][5].3, 0, "stopped at the pressed right switch");
    }

    #[test]
    fn a_seized_shaft_grows_the_closed_loop_position_error() {
        let world = "[motor]\nholding_torque = 0.45\nrated_current = 2.0\n";
        let mut m = module(&tmcm_1310::SPEC, world, false);
        // Encoder initialisation (AP 132), then the loop closed (AP 129), as pytrinamic's TMCM-1311 demo.
        m.execute(Command::Sap { param: 132, motor: 0, value: 1 }, Instant::ZERO).unwrap();
        run(&mut m, at(1000));
        assert_eq!(gap(&mut m, 132, at(1000)), 2, "encoder initialised");
        m.execute(Command::Sap { param: 129, motor: 0, value: 1 }, at(1000)).unwrap();
        run(&mut m, at(1100));
        assert_eq!(gap(&mut m, 133, at(1100)), 1, "the loop is closed");
        let target = gap(&mut m, 1, at(1100)) + 4 * 51200;
        m.execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(target) }, at(1100)).unwrap();
        run(&mut m, at(1300));
        let free = gap(&mut m, 237, at(1300)).abs();
        m.board_mut().change(Change::Seize).unwrap();
        assert!(m.board().seized());
        run(&mut m, at(1600));
        let error = gap(&mut m, 237, at(1600)).abs();
        assert!(error > free + 3000, "the position error grows at a seized shaft: {free} → {error}");
        assert_eq!(m.board().lost_full_steps(), 0, "closed loop: no step lost");
        m.board_mut().change(Change::Free).unwrap();
        assert!(!m.board().seized());
    }

    #[test]
    fn a_load_shows_in_the_stallguard_value_and_friction_in_the_load_torque() {
        let mut m = module(&pd28_1021::SPEC, "", false);
        m.execute(Command::Ror { motor: 0, velocity: 51200 }, Instant::ZERO).unwrap();
        run(&mut m, at(500));
        let light = gap(&mut m, 206, at(500));
        m.board_mut().change(Change::Load(-0.03)).unwrap();
        assert_eq!(m.board().external_torque(), -0.03);
        run(&mut m, at(1000));
        let heavy = gap(&mut m, 206, at(1000));
        assert!(heavy < light, "stallGuard2 reads a higher load lower: {light} → {heavy}");
        m.board_mut().change(Change::Friction(0.01)).unwrap();
        assert_eq!(m.board().friction(), 0.01);
        assert!(m.board().load_torque() > 0.03);
        assert!(m.board_mut().change(Change::Friction(-1.0)).is_err());
        assert!(m.board_mut().change(Change::Load(f64::NAN)).is_err());
    }

    #[test]
    fn a_scheduled_change_is_a_timeline_entry() {
        let mut m = module(&pd28_1021::SPEC, "[[inputs.timeline]]\nat = 0.5\nin1 = true\n", false);
        let press = InputChange { in2: Some(true), ..InputChange::default() };
        m.board_mut().schedule(at(300), Change::Inputs(press)).unwrap();
        m.board_mut()
            .schedule(at(500), Change::Inputs(InputChange { digital: Some(0), ..Default::default() }))
            .unwrap();
        assert_eq!(m.board().next_event(), Some(at(300)));
        run(&mut m, at(400));
        assert_eq!(m.board().world.inputs, 0b100);
        run(&mut m, at(600));
        assert_eq!(m.board().world.inputs, 0, "the file's entry at 0.5 s first, then the scheduled one");
        // Not after the board's time: now.
        m.board_mut().schedule(at(100), Change::EncoderSlip(5)).unwrap();
        assert_eq!(m.board_mut().feedback().encoder_counts, 5);
    }

    #[test]
    fn freeing_ends_the_world_files_seizure_window() {
        let mut m = module(&pd28_1021::SPEC, "[[faults.stall]]\nat = 0\n", false);
        assert!(m.board().seized());
        m.board_mut().change(Change::Free).unwrap();
        assert!(!m.board().seized());
        m.execute(Command::Ror { motor: 0, velocity: 51200 }, Instant::ZERO).unwrap();
        run(&mut m, at(500));
        assert!(m.board().shaft() > 5_000);
    }
}

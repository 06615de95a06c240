//! The board is configured from the model: encoder counts per revolution, no encoder, a driver without
//! stallGuard2, and the model's inputs and outputs (`tmcl_sim::profile`).

use tmcl_core::hal::{DriveState, EncoderCounter, Inputs, LoadSensor, Outputs, StepDriver};
use tmcl_core::model::{pd28_1021, Driver, Encoder, EncoderKind, ModelDesc, ModelSpec};
use tmcl_core::{Duration, Instant, Module, Outcome};
use tmcl_sim::{Eeprom, MemNvm, Profile, SimBoard, World};
use tmcl_wire::{Command, MoveTarget};

/// The PD28-1021 with a 4096-count incremental encoder.
static ABN_4096: ModelSpec = ModelSpec::new(ModelDesc {
    encoder: Some(Encoder { kind: EncoderKind::Abn, counts_per_rev: 4096 }),
    ..pd28_1021::DESC
});
/// The PD28-1021 without its encoder.
static NO_ENCODER: ModelSpec = ModelSpec::new(ModelDesc { encoder: None, ..pd28_1021::DESC });
/// The PD28-1021 with a TMC428 + TMC24x driver chain: no stallGuard2.
static TMC24X: ModelSpec = ModelSpec::new(ModelDesc { driver: Driver::Tmc428Tmc24x, ..pd28_1021::DESC });
/// Two inputs and one output (and no ports naming the others).
static SMALL_IO: ModelSpec = ModelSpec::new(ModelDesc { inputs: 2, outputs: 1, ports: &[], ..pd28_1021::DESC });

/// Steps a board at 1 rev/s (51200 µsteps/s at 256 µsteps) for `ms` ticks of 1 ms, at full current.
fn run_board(b: &mut SimBoard, ms: u64) {
    let mut t = b.updated();
    for _ in 0..ms {
        t += Duration::from_millis(1);
        let s = DriveState {
            moved: 51,
            velocity: 51200,
            resolution: 8,
            current: 255,
            enabled: true,
            ..DriveState::default()
        };
        b.update(0, t, &s);
    }
}

fn gap(m: &mut Module<SimBoard>, param: u8, now: Instant) -> i32 {
    match m.execute(Command::Gap { param, motor: 0 }, now) {
        Ok(Outcome::Value(v)) => v,
        other => panic!("GAP {param}: {other:?}"),
    }
}

#[test]
fn the_default_board_is_the_pd28_1021() {
    let pd28 = Profile::of(&pd28_1021::SPEC);
    assert_eq!(SimBoard::in_memory(16).profile(), &pd28);
    assert_eq!(SimBoard::in_memory_for(&pd28_1021::SPEC).profile(), &pd28);
    assert_eq!(pd28, Profile::PD28_1021);
    assert_eq!(pd28.encoder_counts_per_rev(), Some(1024));
}

#[test]
fn encoder_counts_per_revolution_come_from_the_model() {
    for (spec, per_rev) in [(&pd28_1021::SPEC, 1024), (&ABN_4096, 4096)] {
        let mut b = SimBoard::in_memory_for(spec);
        b.update(
            0,
            Instant::ZERO,
            &DriveState { moved: 51200, resolution: 8, current: 255, enabled: true, ..DriveState::default() },
        );
        assert_eq!(b.shaft(), 51200);
        assert_eq!(b.encoder_counts(0), per_rev, "{}", spec.name);
        assert_eq!(b.feedback().encoder_counts, per_rev);
    }
}

#[test]
fn a_model_without_an_encoder_reads_0_counts() {
    let world = World::from_toml_str("[[faults.encoder_slip]]\nat = 0.001\ncounts = 40\n").unwrap();
    let mut b = SimBoard::in_memory_for(&NO_ENCODER).with_world(world).unwrap();
    assert_eq!(b.profile().encoder, None, "kept through the new world");
    run_board(&mut b, 100);
    assert!(b.shaft() > 5000);
    assert_eq!((b.encoder_counts(0), b.feedback().encoder_counts), (0, 0), "no encoder: nothing counts, nothing slips");

    // The firmware on it: the encoder position stays 0 while the motor turns.
    let mut m = Module::new(SimBoard::in_memory_for(&NO_ENCODER), &NO_ENCODER, Instant::ZERO);
    m.execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(51200) }, Instant::ZERO).unwrap();
    let t = Instant::from_secs(3);
    m.poll(t, &mut |_: &[u8]| {});
    assert_eq!((m.board().shaft(), gap(&mut m, 209, t)), (51200, 0));
}

#[test]
fn only_the_tmc262_measures_the_load() {
    let mut pd28 = SimBoard::in_memory_for(&pd28_1021::SPEC);
    run_board(&mut pd28, 100);
    assert!(pd28.load_measurements(0) > 0, "stallGuard2 measures at 1 rev/s");

    let mut b = SimBoard::in_memory_for(&TMC24X);
    assert!(!b.profile().measures_load());
    run_board(&mut b, 100);
    assert_eq!((b.load_measurements(0), b.load(0)), (0, 1023), "no measurement: no load");
    assert_eq!(b.driver_flags(0) & 1, 0, "no stall flag");
    assert_eq!(b.feedback().load, 1023);
}

#[test]
fn inputs_and_outputs_are_the_models() {
    let world = World::from_toml_str("[inputs]\ndigital = 0xFF\n").unwrap();
    let mut pd28 = SimBoard::in_memory_for(&pd28_1021::SPEC).with_world(world.clone()).unwrap();
    let mut small = SimBoard::for_model(&SMALL_IO, Eeprom::Memory(MemNvm::new(16))).with_world(world).unwrap();
    assert_eq!((pd28.digital_inputs(), small.digital_inputs()), (0b1111, 0b11));
    assert_eq!(small.world.inputs, 0xFF, "the world's levels stay as set");
    pd28.set_outputs(0xFF);
    small.set_outputs(0xFF);
    assert_eq!((pd28.outputs(), small.outputs()), (0b11, 0b1));
}

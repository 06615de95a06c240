//! A virtual module in a test: the firmware core on the simulated board, in a world with a jam the
//! motor cannot pass, driven in simulated time (no clock, no sleep; the run is deterministic).
//!
//! `MVP ABS` towards the far side of the jam (PD28-1021 TMCL firmware manual §3.7.4): the firmware's
//! counter arrives, the shaft stops at the jam and the board reports the lost steps.
//!
//! Run with `cargo run -p tmcl-sim --example simulated_module`.

use tmcl_core::model::pd28_1021;
use tmcl_core::Outcome;
use tmcl_core::{Duration, Instant, Module};
use tmcl_sim::{SimBoard, World};
use tmcl_wire::{Command, MoveTarget};

const WORLD: &str = r#"
[axis]
kind = "linear"
lead = 2.0            # mm per revolution
travel = [0.0, 100.0]
start = 10.0

[[load.jam]]
at = [12.0, 12.5]     # mm
torque = 5.0          # N·m: far more than the motor gives
"#;

fn main() {
    let spec = &pd28_1021::SPEC;
    let world = World::from_toml_str(WORLD).expect("a valid world");
    let board = SimBoard::in_memory_for(spec).with_world(world).expect("fits the model");
    let mut module = Module::new(board, spec, Instant::ZERO);

    // 5 revolutions forward (200 full steps × 256 microsteps each, the default resolution): 10 mm.
    module
        .execute(Command::Mvp { motor: 0, target: MoveTarget::Abs(5 * 200 * 256) }, Instant::ZERO)
        .expect("the module takes the move");
    let mut now = Instant::ZERO;
    let end = Instant::ZERO + Duration::from_millis(60_000);
    while now < end {
        // Step from deadline to deadline, and let the world catch up in between (a switch, a load).
        let next = module.poll(now, &mut |_: &[u8]| {});
        module.board_timeline().advance(now);
        let next = [next, module.board().next_event()].into_iter().flatten().min();
        now = next.map_or(end, |n| n.min(end)).max(now + Duration::from_millis(1));
    }
    let Ok(Outcome::Value(counter)) = module.execute(Command::Gap { param: 1, motor: 0 }, end) else {
        panic!("GAP 1 answers a value")
    };
    let board = module.board();
    println!(
        "firmware position {counter}, axis at {:.2} mm, {} full steps lost",
        board.axis_position(),
        board.lost_full_steps()
    );
    assert!(board.axis_position() < 12.5, "the jam holds the axis");
    assert!(board.lost_full_steps() > 0);
}

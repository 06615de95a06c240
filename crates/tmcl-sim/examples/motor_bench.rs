//! Cost of one `StepDriver::update` (one 1 ms motion tick) of the simulated board, on a free and on loaded
//! axes. Run with `cargo run --release -p tmcl-sim --example motor_bench`.

use std::hint::black_box;
use std::time::Instant as Wall;
use tmcl_core::hal::{DriveState, StepDriver};
use tmcl_core::{Duration, Instant};
use tmcl_sim::{SimBoard, World};

/// Runs `ticks` updates at `velocity` µsteps/s (256 µsteps), reversing every second so the axis stays
/// in its travel, and returns ns per update.
fn bench(world: &str, velocity: i32, back_and_forth: bool, ticks: u32) -> (f64, SimBoard) {
    let world = World::from_toml_str(world).expect("valid world");
    let mut board = SimBoard::in_memory(16).with_world(world).expect("valid world");
    let mut state = DriveState {
        moved: i64::from(velocity / 1000),
        velocity,
        resolution: 8,
        current: 255,
        enabled: true,
        ..DriveState::default()
    };
    let mut t = Instant::ZERO;
    // Warm up.
    for _ in 0..1000 {
        t += Duration::from_millis(1);
        board.update(0, t, black_box(&state));
    }
    let start = Wall::now();
    for i in 0..ticks {
        if back_and_forth && i % 1000 == 0 {
            (state.moved, state.velocity) = (-state.moved, -state.velocity);
        }
        t += Duration::from_millis(1);
        board.update(0, t, black_box(&state));
    }
    let ns = start.elapsed().as_nanos() as f64 / f64::from(ticks);
    (ns, board)
}

fn main() {
    let ticks = 2_000_000;
    let spring = "[load]\nfriction = 0.01\n[load.spring]\nrate = 0.000005\n";
    let cases = [
        ("free axis (default world), 1 rev/s", "", 51_200, true),
        ("free axis (default world), 10 rev/s", "", 512_000, true),
        (
            "linear stage: 3 switches, friction, end stops, 1 rev/s",
            include_str!("../../../examples/worlds/linear-stage.toml"),
            51_200,
            true,
        ),
        ("friction + spring (loaded, below the limit), 1 rev/s", spring, 51_200, true),
        ("friction + spring (loaded, below the limit), 10 rev/s", spring, 512_000, true),
        (
            "jammed at 2 mm (stalled rotor), 1 rev/s",
            include_str!("../../../examples/worlds/jammed-axis.toml"),
            51_200,
            false,
        ),
    ];
    println!("{:<62} {:>10} {:>12}", "case", "ns/update", "lost steps");
    for (name, world, velocity, back_and_forth) in cases {
        let (ns, board) = bench(world, velocity, back_and_forth, ticks);
        println!("{name:<62} {ns:>10.1} {:>12}", board.lost_full_steps());
    }
    // Freewheeling under a spring: the rotor integrates at 0.1 ms steps; one `advance` of 1 ms.
    let world = World::from_toml_str("[load.spring]\nrate = 0.0005\nrest = 90\n[motor]\ndamping = 0.0\n").unwrap();
    let mut board = SimBoard::in_memory(16).with_world(world).unwrap();
    board.update(0, Instant::ZERO, &DriveState { resolution: 8, enabled: false, ..DriveState::default() });
    let n = 200_000u32;
    let start = Wall::now();
    for i in 1..=n {
        board.advance(Instant::from_millis(u64::from(i)));
    }
    let ns = start.elapsed().as_nanos() as f64 / f64::from(n);
    println!("{:<62} {ns:>10.1} {:>12}", "freewheeling, spring back-drive (advance 1 ms)", "-");
}

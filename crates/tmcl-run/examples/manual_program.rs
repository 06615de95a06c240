//! Runs the PD28-1021 TMCL firmware manual's §2.4 program (out and back between ±10000 for ever) for an
//! hour of simulated time, a row every 10 ms, and prints what the trace holds and how long it took.
//!
//! Run with `cargo run --release -p tmcl-run --example manual_program`.

use tmcl_core::Duration;
use tmcl_run::{run, Options, Quantity, Setup, Source};

const SOURCE: &str = "\
    SAP 4, 0, 500     // maximum positioning speed
    SAP 5, 0, 50      // maximum acceleration
Loop:
    MVP ABS, 0, 10000
    WAIT POS, 0, 0
    MVP ABS, 0, -10000
    WAIT POS, 0, 0
    JA Loop
";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let setup = Setup::new("pd28-1021")?;
    let source = Source::assemble("manual.tmc", SOURCE, setup.model)?;
    let options = Options::new(Duration::from_secs(3600));
    let (trace, summary) = run(&source, &setup, &options)?;
    let columns: Vec<String> = trace.columns().iter().map(|c| format!("{} [{}]", c.name, c.unit.symbol())).collect();
    println!("{} rows: {}", trace.len(), columns.join(", "));
    let position = trace.column(Quantity::ActualPosition).ok_or("no position column")?;
    let reached = position.iter().flatten().max().unwrap_or_default();
    println!("furthest position {reached}; {} instructions in {:.3} s wall time", summary.executed, summary.wall_s);
    assert_eq!(reached, 10000);
    Ok(())
}

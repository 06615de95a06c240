//! Lists the models and the axis parameters of the PD28-1021 with their numbers, access, range, unit
//! and the manual section that defines each (PD28-1021 TMCL firmware manual §4).
//!
//! Run with `cargo run -p tmcl-model --example parameters [MODEL]`.

fn main() {
    for model in tmcl_model::MODELS {
        println!("{:<10} {} ({} program cells)", model.id, model.name, model.program_memory);
    }
    let id = std::env::args().nth(1).unwrap_or_else(|| "pd28-1021".into());
    let Some(model) = tmcl_model::by_id(&id) else {
        eprintln!("unknown model {id}");
        std::process::exit(2);
    };
    println!("\naxis parameters of the {}:", model.name);
    for p in model.axis.params {
        println!("{:>3} {:<28} {:<4} default {:>8}  {}", p.number, p.ident, p.access.to_string(), p.default, p.section);
    }
    let speed = model.axis.params.iter().find(|p| p.ident == "MaxPositioningSpeed").expect("every model has it");
    println!("\nAP {} {}: range {}", speed.number, speed.name, speed.range);
}

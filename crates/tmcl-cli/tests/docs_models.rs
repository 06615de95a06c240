//! docs/models.md says how many parameters each model has and what the core's capacities are: the
//! numbers are checked here against the tables, so that the page cannot drift from the code again (it
//! once said 64 axis parameters where the capacity was 112).

use tmcl_core::model::{capacity, MODELS};

fn page() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/models.md");
    std::fs::read_to_string(path).expect("docs/models.md")
}

#[test]
fn every_model_row_counts_its_parameters_as_the_tables_do() {
    let page = page();
    for model in MODELS {
        let row = format!("| `{}` |", model.id);
        let Some(line) = page.lines().find(|l| l.starts_with(&row)) else {
            panic!("docs/models.md has no row for `{}` in its table of models", model.id);
        };
        let counts = [
            (model.axis.params.len(), "axis"),
            (model.global.params.len(), "bank 0"),
            (model.interrupt.params.len(), "bank 3"),
        ];
        for (n, what) in counts.into_iter().filter(|(n, _)| *n > 0) {
            assert!(line.contains(&format!("{n} {what}")), "docs/models.md, {}: not \"{n} {what}\":\n{line}", model.id);
        }
    }
}

#[test]
fn the_capacities_are_the_cores() {
    let page = page().split_whitespace().collect::<Vec<_>>().join(" ");
    for said in [
        format!("{} axis parameters per motor", capacity::MAX_AXIS_PARAMS),
        format!("{} bank 0 parameters", capacity::MAX_GLOBAL_PARAMS),
        format!("{} bank 3 parameters", capacity::MAX_INTERRUPT_PARAMS),
        format!("{} user variables", capacity::MAX_USER_VARIABLES),
        format!("{} coordinates per motor with coordinate 0", capacity::MAX_COORDINATES),
        format!("{} commands", capacity::MAX_PROGRAM),
        format!("{} interrupt numbers", capacity::MAX_VECTORS),
        format!("{} timers", capacity::MAX_TIMERS),
        format!("{} interfaces", capacity::MAX_INTERFACES),
        format!("{} inputs and {} outputs", capacity::MAX_INPUTS, capacity::MAX_OUTPUTS),
    ] {
        assert!(page.contains(&said), "docs/models.md does not say \"{said}\"");
    }
}

//! Assembles the PD28-1021 manual's first example program (§2.4), prints its image and labels,
//! disassembles it again, and shows how an error is reported with its line and column.
//!
//! Run with `cargo run -p tmcl-asm --example assemble`.

use tmcl_asm::{assemble_str, disassemble, from_bin, BuiltinResolver, DisasmOptions};

const SOURCE: &str = "\
// PD28-1021 TMCL firmware manual §2.4: move between two positions for ever.
#include TMCLParam.tmc

    SAP APMaxPositioningSpeed, 0, 1000   // maximum speed
    SAP APMaxAcceleration, 0, 500        // acceleration
Loop:
    MVP ABS, 0, 10000
    WAIT POS, 0, 0
    MVP ABS, 0, -10000
    WAIT POS, 0, 0
    JA Loop
";

fn main() {
    let mut resolver = BuiltinResolver { model: &tmcl_model::pd28_1021::SPEC };
    let program = assemble_str("example.tmc", SOURCE, &mut resolver).expect("the manual's program assembles");
    println!("{} instructions, labels {:?}", program.instructions.len(), program.labels);
    let image = program.to_bin();
    println!("image: {} bytes, first record {:02X?}", image.len(), &image[..8]);
    assert_eq!(from_bin(&image).expect("own image"), program.instructions);

    println!("\ndisassembled:\n{}", disassemble(&program.instructions, DisasmOptions { addresses: true }));

    let errors = assemble_str("typo.tmc", "Loop:\n    MVP ABS, 0, 100\n    JA Lop\n", &mut resolver).unwrap_err();
    for d in &errors {
        println!("{d}");
    }
    assert_eq!((errors[0].line, errors[0].column), (3, 8));
}

//! `tmcl asm` and `tmcl disasm`: the assembler and disassembler of `tmcl-asm` on files.

use crate::error::CliError;
use crate::output::{json_line, Assembled, Disassembled, Includes};
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};
use tmcl_asm::includes::{builtin_files, BuiltinResolver};
use tmcl_asm::{assemble_file, disassemble, from_bin, DisasmOptions, FileResolver};

/// Options of `tmcl asm`.
#[derive(Debug, Args)]
pub struct AsmArgs {
    /// The TMCL source file.
    #[arg(value_name = "IN.tmc", required_unless_present = "emit_includes")]
    pub input: Option<PathBuf>,
    /// The image to write: 8 bytes per instruction (default: IN with the extension .bin).
    #[arg(short, long, value_name = "OUT.bin")]
    pub output: Option<PathBuf>,
    /// Also write a symbol file: one `label address` line per label, sorted by address.
    #[arg(long, value_name = "OUT.sym")]
    pub symbols: Option<PathBuf>,
    /// Search DIR for #include files after the including file's directory (repeatable).
    #[arg(short = 'I', long = "include-dir", value_name = "DIR")]
    pub include_dirs: Vec<PathBuf>,
    /// Write the built-in include files (TMCLParam.tmc, Interrupts.inc) into DIR.
    #[arg(long, value_name = "DIR")]
    pub emit_includes: Option<PathBuf>,
    /// The module whose tables the built-in include files come from, and whose commands, parameters,
    /// ranges and ports the program is checked against (an operand the module would refuse is a warning).
    #[arg(long, value_name = "MODEL", default_value = "pd28-1021")]
    pub module: String,
}

/// Options of `tmcl disasm`.
#[derive(Debug, Args)]
pub struct DisasmArgs {
    /// The image to read (8 bytes per instruction, checksums checked).
    #[arg(value_name = "IN.bin")]
    pub input: PathBuf,
    /// Where to write the source (default: standard output).
    #[arg(short, long, value_name = "OUT.tmc")]
    pub output: Option<PathBuf>,
    /// Append each instruction's address as a comment.
    #[arg(long)]
    pub addresses: bool,
}

/// Runs `tmcl asm`.
pub(crate) fn run_asm(args: AsmArgs, json: bool) -> Result<(), CliError> {
    let model = tmcl_host::models::model_by_id(&args.module)?;
    if let Some(dir) = &args.emit_includes {
        std::fs::create_dir_all(dir).map_err(|source| CliError::Write {
            action: "create",
            path: dir.to_path_buf(),
            source,
        })?;
        for (name, text) in builtin_files(model) {
            write(&dir.join(name), text.as_bytes())?;
        }
    }
    let Some(input) = args.input else {
        if json {
            let dir = args.emit_includes.as_ref().map(|d| d.display().to_string());
            json_line(&mut std::io::stdout(), &Includes { includes: dir })?;
        }
        return Ok(());
    };
    let mut resolver = FileResolver { include_dirs: args.include_dirs, builtins: BuiltinResolver { model } };
    let file = input.display().to_string();
    let program = assemble_file(&input, &mut resolver)
        .map_err(|diagnostics| CliError::Assembly { file: file.clone(), diagnostics })?;
    let wrong = tmcl_asm::check_model(&program, model, &mut source_line);
    if !wrong.is_empty() {
        return Err(CliError::Assembly { file, diagnostics: wrong });
    }
    // Constant operands the model's tables refuse: the module would skip the instruction (status 3 or 4).
    for warning in tmcl_asm::check_operands(&program, model, &mut source_line) {
        eprintln!("{}", warning.warning());
    }
    if program.instructions.len() > model.program_memory as usize {
        eprintln!(
            "tmcl asm: warning: {} instructions do not fit the {}'s program memory of {}",
            program.instructions.len(),
            model.name,
            model.program_memory
        );
    }
    let output = args.output.unwrap_or_else(|| input.with_extension("bin"));
    write(&output, &program.to_bin())?;
    if let Some(symbols) = &args.symbols {
        write(symbols, program.symbols().as_bytes())?;
    }
    if json {
        let row = Assembled {
            output: output.display().to_string(),
            instructions: program.instructions.len(),
            symbols: args.symbols.as_ref().map(|p| p.display().to_string()),
        };
        json_line(&mut std::io::stdout(), &row)?;
    }
    Ok(())
}

/// Runs `tmcl disasm`.
pub(crate) fn run_disasm(args: DisasmArgs, json: bool) -> Result<(), CliError> {
    let image = std::fs::read(&args.input)
        .map_err(|source| CliError::Content { path: args.input.clone(), source: source.into() })?;
    let instructions =
        from_bin(&image).map_err(|source| CliError::Content { path: args.input.clone(), source: source.into() })?;
    let text = disassemble(&instructions, DisasmOptions { addresses: args.addresses });
    match (&args.output, json) {
        (Some(path), _) => {
            write(path, text.as_bytes())?;
            if json {
                let row = Disassembled {
                    instructions: instructions.len(),
                    output: Some(path.display().to_string()),
                    source: None,
                };
                json_line(&mut std::io::stdout(), &row)?;
            }
        }
        (None, true) => json_line(
            &mut std::io::stdout(),
            &Disassembled { instructions: instructions.len(), output: None, source: Some(text) },
        )?,
        (None, false) => std::io::stdout().write_all(text.as_bytes())?,
    }
    Ok(())
}

/// Line `line` (from 1) of the file `file` names, for diagnostics (`None` if it cannot be read).
pub(crate) fn source_line(file: &str, line: u32) -> Option<String> {
    let text = std::fs::read_to_string(file).ok()?;
    text.lines().nth(usize::try_from(line).ok()?.checked_sub(1)?).map(String::from)
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    std::fs::write(path, bytes).map_err(|source| CliError::Write { action: "write", path: path.to_path_buf(), source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn asm_disasm_and_includes_on_files() {
        let dir = tempfile::tempdir().unwrap();
        let path = |n: &str| dir.path().join(n);
        std::fs::write(path("p.tmc"), "#include TMCLParam.tmc\nLoop: SAP APMaxAcceleration, Motor0, 100\nJA Loop\n")
            .unwrap();
        let args = AsmArgs {
            input: Some(path("p.tmc")),
            output: None,
            symbols: Some(path("p.sym")),
            include_dirs: vec![],
            emit_includes: Some(path("inc")),
            module: "pd28-1021".into(),
        };
        run_asm(args, false).unwrap();
        let image = std::fs::read(path("p.bin")).unwrap();
        assert_eq!(image, [5, 5, 0, 0, 0, 0, 100, 110, 22, 0, 0, 0, 0, 0, 0, 22]);
        assert_eq!(std::fs::read_to_string(path("p.sym")).unwrap(), "Loop 0\n");
        assert!(path("inc/TMCLParam.tmc").is_file() && path("inc/Interrupts.inc").is_file());

        let args = DisasmArgs { input: path("p.bin"), output: Some(path("d.tmc")), addresses: false };
        run_disasm(args, false).unwrap();
        let text = std::fs::read_to_string(path("d.tmc")).unwrap();
        assert_eq!(text, "// 2 instructions\nL0000:\n    SAP 5, 0, 100\n    JA L0000\n");

        std::fs::write(path("bad.tmc"), "JA Nowhere\n").unwrap();
        let args = AsmArgs {
            input: Some(path("bad.tmc")),
            output: None,
            symbols: None,
            include_dirs: vec![],
            emit_includes: None,
            module: "pd28-1021".into(),
        };
        assert_eq!(run_asm(args, false).unwrap_err().exit_code(), crate::error::EXIT_USAGE);
        assert!(!path("bad.bin").exists());
    }
}

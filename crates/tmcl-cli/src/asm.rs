//! `tmcl asm` and `tmcl disasm`: the assembler and disassembler of `tmcl-asm` on files.

use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
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
    /// The module whose tables the built-in include files come from.
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
pub fn run_asm(args: AsmArgs) -> ExitCode {
    match asm(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tmcl asm: {e}");
            ExitCode::FAILURE
        }
    }
}

fn asm(args: AsmArgs) -> Result<(), String> {
    let model = tmcl_core::model::by_id(&args.module).ok_or_else(|| format!("unknown module `{}`", args.module))?;
    if let Some(dir) = &args.emit_includes {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for (name, text) in builtin_files(model) {
            write(&dir.join(name), text.as_bytes())?;
        }
    }
    let Some(input) = args.input else { return Ok(()) };
    let mut resolver = FileResolver { include_dirs: args.include_dirs, builtins: BuiltinResolver { model } };
    let program = match assemble_file(&input, &mut resolver) {
        Ok(p) => p,
        Err(diagnostics) => {
            for d in &diagnostics {
                eprintln!("{d}");
            }
            let n = diagnostics.len();
            return Err(format!("{n} error{}; nothing written", if n == 1 { "" } else { "s" }));
        }
    };
    let wrong = tmcl_asm::check_model(&program, model, &mut source_line);
    if !wrong.is_empty() {
        for d in &wrong {
            eprintln!("{d}");
        }
        let n = wrong.len();
        return Err(format!("{n} error{}; nothing written", if n == 1 { "" } else { "s" }));
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
    Ok(())
}

/// Runs `tmcl disasm`.
pub fn run_disasm(args: DisasmArgs) -> ExitCode {
    match disasm(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tmcl disasm: {e}");
            ExitCode::FAILURE
        }
    }
}

fn disasm(args: DisasmArgs) -> Result<(), String> {
    let image = std::fs::read(&args.input).map_err(|e| format!("{}: {e}", args.input.display()))?;
    let instructions = from_bin(&image).map_err(|e| format!("{}: {e}", args.input.display()))?;
    let text = disassemble(&instructions, DisasmOptions { addresses: args.addresses });
    match &args.output {
        Some(path) => write(path, text.as_bytes()),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

/// Line `line` (from 1) of the file `file` names, for diagnostics (`None` if it cannot be read).
pub(crate) fn source_line(file: &str, line: u32) -> Option<String> {
    let text = std::fs::read_to_string(file).ok()?;
    text.lines().nth(usize::try_from(line).ok()?.checked_sub(1)?).map(String::from)
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
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
        assert_eq!(run_asm(args), ExitCode::SUCCESS);
        let image = std::fs::read(path("p.bin")).unwrap();
        assert_eq!(image, [5, 5, 0, 0, 0, 0, 100, 110, 22, 0, 0, 0, 0, 0, 0, 22]);
        assert_eq!(std::fs::read_to_string(path("p.sym")).unwrap(), "Loop 0\n");
        assert!(path("inc/TMCLParam.tmc").is_file() && path("inc/Interrupts.inc").is_file());

        let args = DisasmArgs { input: path("p.bin"), output: Some(path("d.tmc")), addresses: false };
        assert_eq!(run_disasm(args), ExitCode::SUCCESS);
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
        assert_eq!(run_asm(args), ExitCode::FAILURE);
        assert!(!path("bad.bin").exists());
    }
}

//! `od-gen`: check, generate, document and export CiA 306 EDS/DCF files.

use std::path::PathBuf;
use std::process::ExitCode;

use od_gen::{Options, codegen, doc, export, load_path};

const USAGE: &str = "usage:
  od-gen check [--strict] FILE...     exit 0 when valid (warnings on stderr), 1 with the diagnostics
  od-gen gen [--strict] FILE [-o OUT.rs]   generate the Rust module
  od-gen doc FILE [-o OUT.md]         Markdown table of the dictionary
  od-gen export FILE [-o OUT.eds]     normalised EDS";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(code) => code,
        Err(msg) => {
            eprintln!("{msg}");
            ExitCode::from(2)
        }
    }
}

fn run(args: &[String]) -> Result<ExitCode, String> {
    let (cmd, rest) = args.split_first().ok_or(USAGE)?;
    let mut files: Vec<PathBuf> = Vec::new();
    let mut out: Option<PathBuf> = None;
    let mut opts = Options::default();
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "-o" | "--output" => out = Some(it.next().ok_or("-o needs a file name")?.into()),
            "--strict" => opts.strict = true,
            "-h" | "--help" => {
                println!("{USAGE}");
                return Ok(ExitCode::SUCCESS);
            }
            s if s.starts_with('-') => return Err(format!("unknown option {s}\n{USAGE}")),
            s => files.push(s.into()),
        }
    }
    if files.is_empty() {
        return Err(USAGE.into());
    }
    if cmd == "check" {
        let mut ok = true;
        for f in &files {
            let (_, d) = load_path(f, opts)?;
            eprint!("{d}");
            ok &= !d.has_errors();
        }
        return Ok(if ok { ExitCode::SUCCESS } else { ExitCode::FAILURE });
    }
    let [file] = files.as_slice() else { return Err(format!("{cmd} takes one file\n{USAGE}")) };
    let (eds, d) = load_path(file, opts)?;
    eprint!("{d}");
    if d.has_errors() {
        return Ok(ExitCode::FAILURE);
    }
    let text = match cmd.as_str() {
        "gen" => codegen::generate(&eds, &d.file).map_err(|e| format!("{}: error: {}", d.file, e.0))?,
        "doc" => doc::markdown(&eds),
        "export" => export::export(&eds),
        other => return Err(format!("unknown command {other}\n{USAGE}")),
    };
    match out {
        Some(path) => std::fs::write(&path, text).map_err(|e| format!("{}: error: {e}", path.display()))?,
        None => print!("{text}"),
    }
    Ok(ExitCode::SUCCESS)
}

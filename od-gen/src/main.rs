//! `od-gen`: check, generate, document and export CiA 306 EDS/DCF files.
//!
//! Findings go to stderr as `file:line: error: message` (one line each, for
//! tools and editors), or with `--format human` as rustc shows them, with
//! the line and a caret. Exit codes: 0 valid, 1 the file has errors, 2 a
//! usage error or a file that cannot be read.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use od_gen::{Diagnostics, Eds, Options, codegen, doc, export, load};

/// CiA 306 EDS/DCF files to object dictionaries for canopen-core.
#[derive(Parser)]
#[command(name = "od-gen", version)]
struct Cli {
    #[command(subcommand)]
    command: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Check files: exit 0 when valid (warnings on stderr), 1 with the errors.
    Check {
        #[command(flatten)]
        read: ReadArgs,
        /// The EDS or DCF files.
        #[arg(required = true, value_name = "FILE")]
        files: Vec<PathBuf>,
    },
    /// Generate the Rust module of a dictionary.
    Gen(OneFile),
    /// A Markdown table of the dictionary.
    Doc(OneFile),
    /// The normalised EDS (parse, export, parse again: the same dictionary).
    Export(OneFile),
}

/// How files are read and findings shown.
#[derive(Args)]
struct ReadArgs {
    /// Make every warning an error.
    #[arg(long)]
    strict: bool,
    /// How findings are shown on stderr.
    #[arg(long, value_enum, default_value_t = Format::Short)]
    format: Format,
}

/// One input file and where the output goes.
#[derive(Args)]
struct OneFile {
    #[command(flatten)]
    read: ReadArgs,
    /// The EDS or DCF file.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// Write to this file instead of stdout.
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    /// `file:line: error: message`, one line each.
    Short,
    /// rustc style: the message, the offending line and a caret.
    Human,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli.command) {
        Ok(code) => code,
        Err(msg) => {
            let _ = writeln!(std::io::stderr(), "{msg}");
            ExitCode::from(2)
        }
    }
}

/// Reads and validates a file and shows its findings; `Err` when it cannot be read.
fn read(path: &Path, args: &ReadArgs) -> Result<(Eds, Diagnostics), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: error: {e}", path.display()))?;
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let (eds, d) = load(&name, &bytes, Options { strict: args.strict });
    // A closed stderr loses the findings, not the exit code that sums them up.
    let _ = match args.format {
        Format::Short => write!(std::io::stderr(), "{d}"),
        // The lines as the reader decoded and counted them (a Latin-1 file, a
        // lone CR as a line end), so each finding finds its line and quoted text.
        Format::Human => {
            let text = od_gen::lexer::decode(&bytes).0.replace("\r\n", "\n").replace('\r', "\n");
            write!(std::io::stderr(), "{}", d.render_human(&text))
        }
    };
    Ok((eds, d))
}

/// What `gen`, `doc` or `export` makes of a valid dictionary (read from the named file).
type Output = fn(&Eds, &str) -> Result<String, String>;

fn run(task: Task) -> Result<ExitCode, String> {
    let (one, make): (OneFile, Output) = match task {
        Task::Check { read: args, files } => {
            let mut ok = true;
            for f in &files {
                ok &= !read(f, &args)?.1.has_errors();
            }
            return Ok(if ok { ExitCode::SUCCESS } else { ExitCode::FAILURE });
        }
        Task::Gen(one) => (one, |eds, file| codegen::generate(eds, file).map_err(|e| format!("{file}: error: {}", e.0))),
        Task::Doc(one) => (one, |eds, _| Ok(doc::markdown(eds))),
        Task::Export(one) => (one, |eds, _| Ok(export::export(eds))),
    };
    let (eds, d) = read(&one.file, &one.read)?;
    if d.has_errors() {
        return Ok(ExitCode::FAILURE);
    }
    // A dictionary the tables cannot hold is the file's error (1), not a usage error.
    let text = match make(&eds, &d.file) {
        Ok(text) => text,
        Err(msg) => {
            let _ = writeln!(std::io::stderr(), "{msg}");
            return Ok(ExitCode::FAILURE);
        }
    };
    match one.output {
        Some(path) => std::fs::write(&path, text).map_err(|e| format!("{}: error: {e}", path.display()))?,
        None => {
            if let Err(e) = std::io::stdout().lock().write_all(text.as_bytes()) {
                let _ = writeln!(std::io::stderr(), "od-gen: stdout: {e}");
                return Ok(ExitCode::FAILURE);
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

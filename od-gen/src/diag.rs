//! Diagnostics that name the file and line: `drive.eds:123: error: ...`,
//! or for people, with the line and a caret ([`Diagnostics::render_human`]).

#[cfg(feature = "cli")]
mod human;

use std::fmt;

/// How bad a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    /// The file is usable; the finding is worth a look.
    Warning,
    /// Part of the dictionary cannot be determined; the file is rejected.
    Error,
}

/// One finding about an input file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// 1-based physical line, or 0 for the file as a whole.
    pub line: usize,
    /// What is wrong, in one sentence.
    pub message: String,
}

/// The findings about one file, in the order they were made.
#[derive(Clone, Debug, Default)]
pub struct Diagnostics {
    /// The file name the messages are reported under.
    pub file: String,
    /// The findings.
    pub items: Vec<Diagnostic>,
}

impl Diagnostics {
    /// An empty list for `file`.
    pub fn new(file: impl Into<String>) -> Self {
        Diagnostics { file: file.into(), items: Vec::new() }
    }

    /// Records an error at `line`.
    pub fn error(&mut self, line: usize, message: impl Into<String>) {
        self.push(Severity::Error, line, message);
    }

    /// Records a warning at `line`.
    pub fn warn(&mut self, line: usize, message: impl Into<String>) {
        self.push(Severity::Warning, line, message);
    }

    /// Records a finding.
    pub fn push(&mut self, severity: Severity, line: usize, message: impl Into<String>) {
        self.items.push(Diagnostic { severity, line, message: message.into() });
    }

    /// Whether any error was recorded.
    pub fn has_errors(&self) -> bool {
        self.items.iter().any(|d| d.severity == Severity::Error)
    }

    /// The errors only.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.items.iter().filter(|d| d.severity == Severity::Error)
    }

    /// The warnings only.
    pub fn warnings(&self) -> impl Iterator<Item = &Diagnostic> {
        self.items.iter().filter(|d| d.severity == Severity::Warning)
    }

    /// The findings sorted by line, errors before warnings on the same line.
    fn sorted(&self) -> Vec<&Diagnostic> {
        let mut items: Vec<&Diagnostic> = self.items.iter().collect();
        items.sort_by_key(|d| (d.line, std::cmp::Reverse(d.severity)));
        items
    }

    /// Whether some finding at `line` contains `text` (for tests and tools).
    pub fn mentions(&self, severity: Severity, line: usize, text: &str) -> bool {
        self.items.iter().any(|d| d.severity == severity && d.line == line && d.message.contains(text))
    }
}

impl fmt::Display for Diagnostics {
    /// One line per finding, sorted by line, errors before warnings on the same line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for d in self.sorted() {
            let kind = match d.severity {
                Severity::Error => "error",
                Severity::Warning => "warning",
            };
            if d.line == 0 {
                writeln!(f, "{}: {}: {}", self.file, kind, d.message)?;
            } else {
                writeln!(f, "{}:{}: {}: {}", self.file, d.line, kind, d.message)?;
            }
        }
        Ok(())
    }
}

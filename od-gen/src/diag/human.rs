//! Diagnostics for people: each finding with the offending line and a
//! caret under it, as rustc shows them (`od-gen --format human`).
//!
//! ```text
//! error: value `0.0f` is not a REAL32 number
//!     --> heig-vd__od.eds:1276:14
//!      |
//! 1276 | DefaultValue=0.0f
//!      |              ^^^^
//! ```
//!
//! Findings carry a line, not a column: the caret marks the first text
//! the message quotes in backticks where the line contains it, else the
//! whole line. A finding about the file as a whole (line 0) names the file
//! in a note.

use super::{Diagnostic, Diagnostics, Severity};
use codespan_reporting::diagnostic::{Diagnostic as Report, Label};
use codespan_reporting::files::SimpleFile;
use codespan_reporting::term::{self, Chars, Config};
use std::ops::Range;

impl Diagnostics {
    /// The findings in the order [`Display`](std::fmt::Display) prints them,
    /// each with its line of `source` (the file's text) and a caret.
    pub fn render_human(&self, source: &str) -> String {
        let file = SimpleFile::new(self.file.as_str(), source);
        let config = Config { chars: Chars::ascii(), ..Config::default() };
        let mut out = String::new();
        for d in self.sorted() {
            let report = match d.severity {
                Severity::Error => Report::error(),
                Severity::Warning => Report::warning(),
            }
            .with_message(d.message.as_str());
            let report = match line_span(source, d) {
                Some(span) => report.with_labels(vec![Label::primary((), span)]),
                None => report.with_notes(vec![format!("in {}", self.file)]),
            };
            // Rendering fails only for a span outside the text, which
            // `line_span` never gives; fall back to the short form.
            match term::emit_into_string(&config, &file, &report) {
                Ok(text) => out.push_str(&text),
                Err(_) => out.push_str(&format!("{}:{}: {}\n", self.file, d.line, d.message)),
            }
        }
        out
    }
}

/// The bytes of `source` the caret goes under, if the finding has a line.
fn line_span(source: &str, d: &Diagnostic) -> Option<Range<usize>> {
    let index = d.line.checked_sub(1)?;
    let start: usize = source.split_inclusive('\n').take(index).map(str::len).sum();
    let line = source.split_inclusive('\n').nth(index)?;
    let text = line.trim_end_matches(['\r', '\n']);
    let quoted = d.message.split('`').nth(1).filter(|q| !q.is_empty());
    let (offset, len) = match quoted.and_then(|q| text.find(q).map(|at| (at, q.len()))) {
        Some(found) => found,
        None => {
            let body = text.trim_start();
            (text.len() - body.len(), body.trim_end().len().max(1))
        }
    };
    Some(start + offset..start + offset + len)
}

#[cfg(test)]
mod tests {
    use crate::Diagnostics;

    const SOURCE: &str = "[1000]\r\nParameterName=Device type\r\nDefaultValue=0.0f\r\n  AccessType=rx\r\n";

    #[test]
    fn shows_the_line_with_a_caret_under_the_quoted_text() {
        let mut d = Diagnostics::new("x.eds");
        d.error(3, "value `0.0f` is not a REAL32 number");
        assert_eq!(
            d.render_human(SOURCE),
            "error: value `0.0f` is not a REAL32 number\n  --> x.eds:3:14\n  |\n3 | DefaultValue=0.0f\n  |              ^^^^\n\n"
        );
    }

    #[test]
    fn marks_the_whole_line_without_a_quote_and_notes_the_file_for_line_0() {
        let mut d = Diagnostics::new("x.eds");
        d.warn(4, "unknown access type");
        d.error(0, "no [FileInfo] section");
        assert_eq!(
            d.render_human(SOURCE),
            "error: no [FileInfo] section\n = in x.eds\n\n\
             warning: unknown access type\n  --> x.eds:4:3\n  |\n4 |   AccessType=rx\n  |   ^^^^^^^^^^^^^\n\n"
        );
    }
}

//! The INI layer of CiA 306 §4: text decoding, sections, `key=value` lines and
//! comments, each remembered with its physical line.

use crate::diag::Diagnostics;

/// One `key=value` line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pair {
    /// The key as written.
    pub key: String,
    /// The value, trimmed.
    pub value: String,
    /// 1-based physical line.
    pub line: usize,
}

/// One `[name]` section with its lines.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Section {
    /// The name as written, without brackets.
    pub name: String,
    /// 1-based line of the header.
    pub line: usize,
    /// The `key=value` lines in order.
    pub pairs: Vec<Pair>,
}

impl Section {
    /// The value of `key` (case-insensitive) with its line; the last one wins
    /// if a key repeats (the lexer has already reported that).
    pub fn get(&self, key: &str) -> Option<&Pair> {
        self.pairs.iter().rev().find(|p| p.key.eq_ignore_ascii_case(key))
    }
}

/// Decodes file bytes: UTF-8 (a BOM is dropped), otherwise Latin-1, which
/// every byte sequence is. Returns the text and whether it fell back to Latin-1.
pub fn decode(bytes: &[u8]) -> (String, bool) {
    let bytes = bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(bytes);
    match std::str::from_utf8(bytes) {
        Ok(s) => (s.to_owned(), false),
        Err(_) => (bytes.iter().map(|&b| char::from(b)).collect(), true),
    }
}

/// Splits text into sections. Lines end in LF, CRLF or a lone CR.
/// Comment lines start with `;`. Repeated sections and keys are reported here.
pub fn sections(text: &str, diags: &mut Diagnostics) -> Vec<Section> {
    let mut out: Vec<Section> = Vec::new();
    let mut seen: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut skipping = false;
    for (n, raw) in physical_lines(text).enumerate() {
        let line = n + 1;
        let text = raw.trim();
        if text.is_empty() || text.starts_with(';') {
            continue;
        }
        if let Some(rest) = text.strip_prefix('[') {
            let Some((name, after)) = rest.split_once(']') else {
                diags.error(line, format!("section header `{text}` has no closing `]`"));
                skipping = true;
                continue;
            };
            // `[1000] ; comment`: INI readers (python's configparser among
            // them) take the header and drop the comment.
            let after = after.trim();
            if after.starts_with(';') {
                diags.warn(line, format!("comment `{}` after a section header; CiA 306 comments are lines of their own", clip(after)));
            } else if !after.is_empty() {
                diags.error(line, format!("text `{}` after the section header `[{name}]`", clip(after)));
                skipping = true;
                continue;
            }
            let name = name.trim().to_owned();
            let key = name.to_ascii_lowercase();
            if let Some(first) = seen.get(&key) {
                diags.error(line, format!("duplicate section [{name}] (first at line {first})"));
                skipping = true;
                continue;
            }
            seen.insert(key, line);
            skipping = false;
            out.push(Section { name, line, pairs: Vec::new() });
            continue;
        }
        if skipping {
            continue;
        }
        let Some((key, value)) = text.split_once('=') else {
            diags.warn(line, format!("line `{}` is neither a section, a key=value pair nor a comment; ignored", clip(text)));
            continue;
        };
        let Some(section) = out.last_mut() else {
            diags.warn(line, "key=value line before the first section; ignored");
            continue;
        };
        let key = key.trim().to_owned();
        let value = value.trim().to_owned();
        if let Some(prev) = section.pairs.iter().find(|p| p.key.eq_ignore_ascii_case(&key)) {
            if prev.value == value {
                diags.warn(line, format!("key {key} repeated in [{}] (first at line {})", section.name, prev.line));
            } else {
                diags.error(line, format!("key {key} repeated in [{}] with a different value (first at line {})", section.name, prev.line));
            }
        }
        section.pairs.push(Pair { key, value, line });
    }
    out
}

fn physical_lines(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(text);
    std::iter::from_fn(move || {
        let s = rest?;
        match s.find(['\n', '\r']) {
            Some(i) => {
                let skip = if s[i..].starts_with("\r\n") { 2 } else { 1 };
                rest = Some(&s[i + skip..]);
                Some(&s[..i])
            }
            None => {
                rest = None;
                if s.is_empty() { None } else { Some(s) }
            }
        }
    })
}

/// Shortens text for a message.
pub(crate) fn clip(s: &str) -> String {
    if s.chars().count() > 40 { format!("{}…", s.chars().take(40).collect::<String>()) } else { s.to_owned() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::Severity;

    #[test]
    fn line_numbers_count_every_ending_style() {
        let mut d = Diagnostics::new("t.eds");
        let s = sections("[A]\r\nx=1\r\n;c\n[B]\ry = 2 \n", &mut d);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].pairs[0], Pair { key: "x".into(), value: "1".into(), line: 2 });
        assert_eq!(s[1].line, 4);
        assert_eq!(s[1].pairs[0].line, 5);
        assert_eq!(s[1].pairs[0].value, "2");
        assert!(d.items.is_empty());
    }

    #[test]
    fn keys_and_sections_are_case_insensitive() {
        let mut d = Diagnostics::new("t.eds");
        let s = sections("[FileInfo]\nFILENAME=a\n[fileinfo]\n", &mut d);
        assert_eq!(s[0].get("filename").map(|p| p.value.as_str()), Some("a"));
        assert!(d.mentions(Severity::Error, 3, "duplicate section [fileinfo] (first at line 1)"));
    }

    #[test]
    fn repeated_keys_are_reported() {
        let mut d = Diagnostics::new("t.eds");
        sections("[1000]\nA=1\na=1\nA=2\n", &mut d);
        assert!(d.mentions(Severity::Warning, 3, "key a repeated"));
        assert!(d.mentions(Severity::Error, 4, "different value"));
    }

    #[test]
    fn stray_lines_are_warnings() {
        let mut d = Diagnostics::new("t.eds");
        sections("x=1\n[A]\nnonsense\n[B\n", &mut d);
        assert!(d.mentions(Severity::Warning, 1, "before the first section"));
        assert!(d.mentions(Severity::Warning, 3, "neither"));
        assert!(d.mentions(Severity::Error, 4, "no closing"));
    }

    #[test]
    fn decodes_utf8_bom_and_latin1() {
        assert_eq!(decode(b"\xEF\xBB\xBFab"), ("ab".to_owned(), false));
        assert_eq!(decode("€".as_bytes()), ("€".to_owned(), false));
        assert_eq!(decode(b"M\xFCller"), ("Müller".to_owned(), true));
    }
}

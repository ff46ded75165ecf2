//! Rust names from EDS names: the rule docs/od-gen.md states ("Names").
//!
//! - An object is named by its `ParameterName` in snake_case ([`snake`]);
//!   a name an earlier object (by index) has gets `_<index>` (hex).
//! - A VAR's accessors, and the indexed pair of a uniform ARRAY, carry the
//!   object's name.
//! - A sub-index's accessors carry the object's name, then the sub-index's
//!   own name ([`own_name`]): its `ParameterName` less the words it repeats
//!   from the start of the object's name; sub-index 0 named as the highest
//!   sub-index is `highest_sub_index`; nothing left is `sub<n>`.
//! - [`Taken`] keeps every name unique: a name is taken when it, or its
//!   setter, is a getter or setter given before or a method of `Ram`.

use std::collections::{BTreeMap, HashSet};

use crate::model::{Eds, Object, SubObject};

/// Rust keywords, and the methods `Ram` has besides the accessors.
pub(super) const RESERVED: &[&str] = &[
    "as",
    "break",
    "const",
    "continue",
    "crate",
    "else",
    "enum",
    "extern",
    "false",
    "fn",
    "for",
    "if",
    "impl",
    "in",
    "let",
    "loop",
    "match",
    "mod",
    "move",
    "mut",
    "pub",
    "ref",
    "return",
    "self",
    "static",
    "struct",
    "super",
    "trait",
    "true",
    "type",
    "unsafe",
    "use",
    "where",
    "while",
    "async",
    "await",
    "dyn",
    "abstract",
    "become",
    "box",
    "do",
    "final",
    "macro",
    "override",
    "priv",
    "typeof",
    "unsized",
    "virtual",
    "yield",
    "try",
    "gen",
    // Methods of `Ram` itself.
    "new",
    "reset_communication",
    "reset_application",
    "dictionary",
    "image",
    "image_mut",
    "clone",
    "fmt",
    "eq",
    "zeroed",
];

/// snake_case words of an EDS name: split at every character that is not
/// an ASCII letter or digit and where an upper-case letter follows a
/// lower-case letter or a digit.
fn words(name: &str) -> Vec<String> {
    let mut out = String::new();
    let mut prev_lower = false;
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            if c.is_ascii_uppercase() && prev_lower {
                out.push('_');
            }
            prev_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
            out.push(c.to_ascii_lowercase());
        } else {
            prev_lower = false;
            out.push('_');
        }
    }
    out.split('_').filter(|w| !w.is_empty()).map(str::to_owned).collect()
}

/// snake_case identifier from an EDS name: its [`words`] joined by `_`,
/// with `o_` before a leading digit (or for no word at all) and `_` after
/// a Rust keyword or a method name of `Ram`.
pub fn snake(name: &str) -> String {
    let mut out = words(name).join("_");
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert_str(0, "o_");
    }
    if RESERVED.contains(&out.as_str()) {
        out.push('_');
    }
    out
}

/// The name of every object (by index): its [`snake`] name, with
/// `_<index>` (4 hex digits) when an object of a lower index has it.
pub(super) fn object_names(eds: &Eds) -> BTreeMap<u16, String> {
    let mut used = HashSet::new();
    let mut names = BTreeMap::new();
    for o in eds.objects.values().filter(|o| !o.opaque) {
        let mut n = snake(&o.name);
        if !used.insert(n.clone()) {
            n = format!("{n}_{:04x}", o.index);
            used.insert(n.clone());
        }
        names.insert(o.index, n);
    }
    names
}

/// Whether `words` end in a name of the highest sub-index: "highest" or
/// "largest", "sub-index", "subindex" or "sub index", and "supported" or not.
fn ends_as_highest_sub_index(words: &[String]) -> bool {
    let w: Vec<&str> = words.iter().map(String::as_str).collect();
    let w = w.strip_suffix(&["supported"]).unwrap_or(&w);
    let Some(w) = w.strip_suffix(&["subindex"]).or_else(|| w.strip_suffix(&["sub", "index"])) else { return false };
    matches!(w.last(), Some(&"highest" | &"largest"))
}

/// A sub-index's own name, the part of its accessor name after the
/// object's: sub-index 0 named as the highest sub-index is
/// `highest_sub_index` (whatever precedes it: "TPDO1 communication highest
/// sub-index" too); any other is its snake_case words less those it shares
/// with the start of the object's name, or of that name with its closing
/// number joined to its first word ("TPDO4 transmission type" in "TPDO
/// communication parameter 4" is `transmission_type`), and a word that is
/// the object's next word with a number is that number; with no word left,
/// `sub<n>` (the sub-index in decimal).
pub(super) fn own_name(object: &Object, sub: &SubObject) -> String {
    let own = words(&sub.name);
    if sub.sub == 0 && ends_as_highest_sub_index(&own) {
        return "highest_sub_index".to_owned();
    }
    let object_words = words(&object.name);
    let plain = strip_shared(&own, &object_words);
    let numbered = strip_shared(&own, &numbered_first_word(&object_words));
    let length = |w: &[String]| w.iter().map(String::len).sum::<usize>();
    let rest = if length(&numbered) < length(&plain) { numbered } else { plain };
    if rest.is_empty() { format!("sub{}", sub.sub) } else { rest.join("_") }
}

/// `own` less the words it shares with the start of `object`; a word that
/// is the object's next word followed by a number ("parameter1" after
/// "TPDO mapping" in "TPDO mapping parameter") leaves the number.
fn strip_shared(own: &[String], object: &[String]) -> Vec<String> {
    let shared = own.iter().zip(object).take_while(|(a, b)| a == b).count();
    let mut rest: Vec<String> = own.get(shared..).unwrap_or_default().to_vec();
    if let (Some(first), Some(next)) = (rest.first_mut(), object.get(shared))
        && let Some(number) = first.strip_prefix(next.as_str())
        && !number.is_empty()
        && number.bytes().all(|b| b.is_ascii_digit())
    {
        *first = number.to_owned();
    }
    rest
}

/// An object's words with its closing number joined to its first word,
/// as sub-index names often spell it ("TPDO communication parameter 4" →
/// "tpdo4 communication parameter"); empty unless the last word is a number.
fn numbered_first_word(words: &[String]) -> Vec<String> {
    match words {
        [first, middle @ .., last] if last.bytes().all(|b| b.is_ascii_digit()) => {
            let mut out = vec![format!("{first}{last}")];
            out.extend(middle.iter().cloned());
            out
        }
        _ => Vec::new(),
    }
}

/// The accessor names given so far, with their setters, and the methods of
/// `Ram`: what a new accessor name must not be.
pub(super) struct Taken(HashSet<String>);

impl Taken {
    /// Nothing given yet; `Ram`'s own methods are taken.
    pub(super) fn new() -> Self {
        Taken(RESERVED.iter().map(|s| (*s).to_owned()).collect())
    }

    /// Gives `name` if neither it nor `set_<name>` is taken.
    fn try_give(&mut self, name: String) -> Result<String, String> {
        let setter = format!("set_{name}");
        if self.0.contains(&name) || self.0.contains(&setter) {
            return Err(name);
        }
        self.0.insert(setter);
        self.0.insert(name.clone());
        Ok(name)
    }

    /// The first free name of `candidates`, else the last one with `_`
    /// appended until it is free.
    fn give(&mut self, candidates: impl IntoIterator<Item = String>) -> String {
        let mut last = String::new();
        for c in candidates {
            match self.try_give(c) {
                Ok(name) => return name,
                Err(name) => last = name,
            }
        }
        loop {
            last.push('_');
            if let Ok(name) = self.try_give(last.clone()) {
                return name;
            }
        }
    }

    /// The accessor name of a VAR or a uniform ARRAY: the object's name, or
    /// `<object>_<index>` (hex) if that is taken.
    pub(super) fn object(&mut self, object_name: &str, index: u16) -> String {
        self.give([object_name.to_owned(), format!("{object_name}_{index:04x}")])
    }

    /// The accessor name of a sub-index: `<object>_<own name>`, else
    /// `<object>_sub<n>`, else `<object>_<index>_sub<n>` (index in hex).
    pub(super) fn sub(&mut self, object_name: &str, object: &Object, sub: &SubObject) -> String {
        let n = sub.sub;
        self.give([
            format!("{object_name}_{}", own_name(object, sub)),
            format!("{object_name}_sub{n}"),
            format!("{object_name}_{:04x}_sub{n}", object.index),
        ])
    }
}

#[cfg(test)]
mod tests;

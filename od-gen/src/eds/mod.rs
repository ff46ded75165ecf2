//! CiA 306 v1.3 reader: sections → [`Eds`].
//!
//! Tolerant of what real tools write (each tolerance is a warning) and strict
//! about what leaves part of the dictionary undetermined (an error). See
//! `tests/corpus/MANIFEST.md` for the real files this was built against.
//!
//! [`read`] sorts the lexer's sections by kind (`sections`) and reads
//! them: the file's own sections (`device`: `[DeviceInfo]`, `[DummyUsage]`,
//! `[Comments]`, the object lists, `[DeviceComissioning]`), each object with
//! its sub-index and compact sections (`objects`), and the PDO objects
//! `CompactPDO` implies (`compact_pdo`).

mod compact_pdo;
mod device;
mod objects;
mod sections;

use std::collections::{BTreeMap, BTreeSet};

use crate::diag::Diagnostics;
use crate::lexer::{self, Pair, Section};
use crate::model::{Eds, ObjectKind};
use crate::value::parse_int;
use sections::{Kind, OBJECT_KEYS, classify};

/// Reads an EDS/DCF from its bytes. Never panics; every problem is a diagnostic.
pub fn read(file: &str, bytes: &[u8]) -> (Eds, Diagnostics) {
    let mut d = Diagnostics::new(file);
    // Read as Latin-1, UTF-16 gives a NUL between letters: a finding per line and no section.
    let utf16 = bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]);
    if utf16 || bytes.iter().take(64).filter(|&&b| b == 0).count() > 16 {
        d.error(0, "file is UTF-16 (or holds NUL bytes): an EDS or DCF is 8-bit text (CiA 306); save it as UTF-8 or ASCII");
        return (Eds { file: file.to_owned(), ..Eds::default() }, d);
    }
    let (text, latin1) = lexer::decode(bytes);
    if latin1 {
        d.warn(0, "file is not UTF-8; read as Latin-1");
    }
    let sections = lexer::sections(&text, &mut d);
    let eds =
        Reader { d: &mut d, unknown_keys: BTreeSet::new(), is_eds: file.to_ascii_lowercase().ends_with(".eds") }.build(file, sections);
    (eds, d)
}

struct Reader<'a> {
    d: &'a mut Diagnostics,
    unknown_keys: BTreeSet<String>,
    /// An EDS describes a device type; `ParameterValue` belongs in a DCF.
    is_eds: bool,
}

impl Reader<'_> {
    fn build(mut self, file: &str, sections: Vec<Section>) -> Eds {
        let mut eds = Eds { file: file.to_owned(), ..Eds::default() };
        let mut object_sections: BTreeMap<u16, Section> = BTreeMap::new();
        let mut sub_sections: BTreeMap<(u16, u8), Section> = BTreeMap::new();
        let mut names: BTreeMap<u16, Section> = BTreeMap::new();
        let mut values: BTreeMap<u16, Section> = BTreeMap::new();
        let mut links: BTreeMap<u16, Section> = BTreeMap::new();
        let mut dummy_usage = None;
        for s in sections {
            match classify(&s.name) {
                Kind::FileInfo => eds.file_info = Some(s),
                Kind::DeviceInfo => eds.device_info = Some(s),
                Kind::DummyUsage => dummy_usage = Some(s),
                Kind::Comments => eds.comments = self.comments(&s),
                Kind::Mandatory => eds.lists.mandatory = self.listed(&mut eds.lists, &s),
                Kind::Optional => eds.lists.optional = self.listed(&mut eds.lists, &s),
                Kind::Manufacturer => eds.lists.manufacturer = self.listed(&mut eds.lists, &s),
                Kind::Commissioning => {
                    eds.node_id = self.commissioning_node_id(&s);
                    eds.commissioning = Some(s);
                }
                // CiA 301 leaves index 0x0000 unused: no SDO can name it.
                Kind::Object(0) => self.d.warn(s.line, format!("[{}]: index 0x0000 is not used (CiA 301); left out", s.name)),
                Kind::Object(i) => {
                    object_sections.insert(i, s);
                }
                Kind::Sub(i, sub) => {
                    // Sub-index sections are hex; `sub10` is 0x10, not decimal 10.
                    if let Some(prev) = sub_sections.get(&(i, sub)) {
                        self.d.error(
                            s.line,
                            format!("[{}] repeats sub-index 0x{sub:02X} of 0x{i:04X} (first at line {})", s.name, prev.line),
                        );
                    } else {
                        sub_sections.insert((i, sub), s);
                    }
                }
                Kind::Names(i) => {
                    names.insert(i, s);
                }
                Kind::Values(i) => {
                    values.insert(i, s);
                }
                Kind::Links(i) => {
                    links.insert(i, s);
                }
                Kind::Other => {
                    self.d.warn(s.line, format!("section [{}] is not interpreted; kept as is", s.name));
                    eds.other_sections.push(s);
                }
            }
        }
        eds.device = self.device_facts(eds.device_info.as_ref(), dummy_usage.as_ref());
        for (index, s) in &object_sections {
            let subs: Vec<Section> = sub_sections.range((*index, 0)..=(*index, 0xFF)).map(|(_, s)| s.clone()).collect();
            if let Some(o) = self.object(*index, s, subs, names.get(index), values.get(index)) {
                eds.objects.insert(*index, o);
            }
        }
        for ((index, sub), s) in &sub_sections {
            if !object_sections.contains_key(index) {
                self.d.error(
                    s.line,
                    format!("[{}] describes sub-index 0x{sub:02X} of 0x{index:04X}, which has no [{index:04X}] section", s.name),
                );
            }
        }
        for (index, s) in names.iter().chain(values.iter()) {
            let compact = eds.objects.get(index).is_some_and(|o| o.compact_sub_obj.is_some());
            if !compact {
                self.d.warn(s.line, format!("[{}] belongs to no object with CompactSubObj; ignored", s.name));
            }
        }
        for (index, s) in &links {
            let list = self.object_list(s, "ObjectLinks");
            match eds.objects.get_mut(index) {
                Some(o) => o.links = list,
                None => self.d.warn(s.line, format!("[{}] links an object that does not exist", s.name)),
            }
        }
        self.synthesize_compact_pdo(&mut eds);
        eds
    }

    fn flag(&mut self, s: &Section, key: &str) -> bool {
        match s.get(key) {
            None => false,
            Some(p) => match parse_int(&p.value).map(|e| e.value) {
                Ok(0) => false,
                Ok(1) => true,
                _ => {
                    self.d.warn(p.line, format!("{key}=`{}` is not 0 or 1; read as 0", p.value));
                    false
                }
            },
        }
    }

    fn small(&mut self, s: &Section, key: &str, max: i128) -> i128 {
        let Some(p) = s.get(key) else { return 0 };
        match self.int(p) {
            Some(v) if (0..=max).contains(&v) => v,
            Some(v) => {
                self.d.error(p.line, format!("{key}={v} is outside 0..={max}"));
                0
            }
            None => 0,
        }
    }

    fn int(&mut self, p: &Pair) -> Option<i128> {
        match parse_int(&p.value) {
            Ok(e) if !e.node_id => Some(e.value),
            Ok(_) => {
                self.d.error(p.line, format!("{} may not depend on $NODEID", p.key));
                None
            }
            Err(e) => {
                self.d.error(p.line, format!("{}: {e}", p.key));
                None
            }
        }
    }

    /// An object the dictionary leaves out because of where it sits says so:
    /// CiA 301 keeps data type definitions (NULL, DEFTYPE, DEFSTRUCT) at
    /// 0x0001-0x025F and reserves 0x0260-0x0FFF, so a VAR typed DEFTYPE by
    /// mistake (0x5 for 0x7) would otherwise vanish from the device unreported.
    fn check_index_range(&mut self, index: u16, kind: ObjectKind, line: usize) {
        let type_definition = matches!(kind, ObjectKind::Null | ObjectKind::DefType | ObjectKind::DefStruct);
        if type_definition && index >= 0x1000 {
            self.d.warn(
                line,
                format!(
                    "ObjectType {} of 0x{index:04X} defines a data type, which CiA 301 keeps at 0x0001-0x025F; the object is left out",
                    kind.name()
                ),
            );
        } else if (0x0260..0x1000).contains(&index) {
            self.d.warn(line, format!("0x{index:04X} is in the range CiA 301 reserves (0x0260-0x0FFF); the object is left out"));
        }
    }

    fn check_keys(&mut self, s: &Section) {
        for p in &s.pairs {
            let k = p.key.to_ascii_lowercase();
            if !OBJECT_KEYS.contains(&k.as_str()) && self.unknown_keys.insert(k) {
                self.d.warn(p.line, format!("unknown key {} (further uses of it are not reported)", p.key));
            }
        }
    }
}

#[cfg(test)]
mod tests;

//! Object sections: `[xxxx]` with its `[xxxxsubN]` sections, or with the
//! `[xxxxName]`/`[xxxxValue]` sections of a `CompactSubObj` (CiA 306
//! §4.5.2.2), into [`Object`]s and their [`SubObject`]s.

use std::collections::BTreeMap;

use canopen_core::od::{DataType, Number};

use super::Reader;
use super::sections::{Kind, classify};
use crate::lexer::{Pair, Section};
use crate::model::{Access, Object, ObjectKind, SubObject, Text};
use crate::value::{self, parse_int};

impl Reader<'_> {
    pub(super) fn object(
        &mut self,
        index: u16,
        s: &Section,
        subs: Vec<Section>,
        names: Option<&Section>,
        values: Option<&Section>,
    ) -> Option<Object> {
        self.check_keys(s);
        let name = s.get("ParameterName").map(|p| p.value.clone()).unwrap_or_else(|| {
            self.d.warn(s.line, format!("[{}] has no ParameterName", s.name));
            format!("Object {index:04X}")
        });
        let kind = match s.get("ObjectType") {
            None => ObjectKind::Var,
            Some(p) => match parse_int(&p.value).ok().and_then(|e| ObjectKind::from_code(e.value)) {
                Some(k) => k,
                None => {
                    self.d.error(p.line, format!("ObjectType `{}` is not 0x0, 0x2, 0x5, 0x6, 0x7, 0x8 or 0x9", p.value));
                    return None;
                }
            },
        };
        self.check_index_range(index, kind, s.get("ObjectType").map_or(s.line, |p| p.line));
        let sub_number = s.get("SubNumber").and_then(|p| self.int(p)).map(|n| n.clamp(0, 0x100) as u16);
        let sub_number_line = s.get("SubNumber").map_or(s.line, |p| p.line);
        let compact = s.get("CompactSubObj").and_then(|p| self.int(p)).map(|n| n.clamp(0, 0x100) as u16);
        let compact_line = s.get("CompactSubObj").map_or(s.line, |p| p.line);
        if name.trim().is_empty() || name.trim().eq_ignore_ascii_case("None") {
            let line = s.get("ParameterName").map_or(s.line, |p| p.line);
            self.d.warn(line, format!("ParameterName `{name}` of 0x{index:04X} is a placeholder, not a name"));
        }
        let mut o = Object {
            index,
            name,
            kind,
            sub_number,
            sub_number_line,
            compact_sub_obj: compact,
            denotation: s.get("Denotation").map(|p| p.value.clone()),
            links: Vec::new(),
            subs: BTreeMap::new(),
            opaque: false,
            synthesized: false,
            line: s.line,
        };
        if !kind.has_subs() {
            for sub in &subs {
                self.d.error(sub.line, format!("[{}] is a sub-object of 0x{index:04X}, which is a {}", sub.name, kind.name()));
            }
            if let Some(v) = self.sub_object(s, 0, &o.name, None) {
                o.subs.insert(0, v);
            }
        } else if let Some(n) = compact.filter(|&n| n > 0) {
            if kind == ObjectKind::Record {
                self.d.warn(
                    compact_line,
                    format!("CompactSubObj on RECORD 0x{index:04X}; CiA 306 defines it for ARRAY, expanded the same way"),
                );
            }
            if n > 0xFE {
                self.d.warn(
                    compact_line,
                    format!("CompactSubObj={n} on 0x{index:04X} reaches sub-index 0x{:02X}; the highest is 0xFE", n.min(0xFF)),
                );
            }
            for sub in &subs {
                self.d.warn(sub.line, format!("[{}] is ignored: 0x{index:04X} uses CompactSubObj", sub.name));
            }
            self.expand_compact(&mut o, s, n.min(0xFF) as u8, names, values);
        } else {
            // An ARRAY's elements share one type, which its header may give.
            let element_type = s
                .get("DataType")
                .filter(|_| kind == ObjectKind::Array)
                .and_then(|p| parse_int(&p.value).ok())
                .and_then(|e| u16::try_from(e.value).ok());
            for sub in &subs {
                self.check_keys(sub);
                let Kind::Sub(_, si) = classify(&sub.name) else { continue };
                let default_name = format!("{} sub{si}", o.name);
                let sub_name = sub.get("ParameterName").map(|p| p.value.clone()).unwrap_or(default_name);
                let implied = if si == 0 { Some(DataType::Unsigned8.index()) } else { element_type };
                if let Some(v) = self.sub_object(sub, si, &sub_name, implied) {
                    o.subs.insert(si, v);
                }
            }
        }
        Some(o)
    }

    /// CiA 306 §4.5.2.2: the header gives the type of entries 1..=n, the
    /// `[xxxxName]`/`[xxxxValue]` sections name and set them by sub-index.
    fn expand_compact(&mut self, o: &mut Object, s: &Section, n: u8, names: Option<&Section>, values: Option<&Section>) {
        let index = o.index;
        let Some(template) = self.sub_object(s, 1, &o.name, None) else { return };
        let entry_key = |p: &Pair| parse_int(&p.key).ok().and_then(|e| u8::try_from(e.value).ok());
        let mut value_count = 0u8;
        let mut overrides: BTreeMap<u8, &Pair> = BTreeMap::new();
        for p in values.map(|v| v.pairs.as_slice()).unwrap_or(&[]) {
            if p.key.eq_ignore_ascii_case("NrOfEntries") {
                continue;
            }
            match entry_key(p) {
                Some(k) if (1..=n).contains(&k) => {
                    overrides.insert(k, p);
                    value_count = value_count.max(k);
                }
                _ => self.d.warn(p.line, format!("key {} in [{:04X}Value] is not a sub-index 1..={n}", p.key, index)),
            }
        }
        let mut sub_names: BTreeMap<u8, String> = BTreeMap::new();
        for p in names.map(|v| v.pairs.as_slice()).unwrap_or(&[]) {
            if p.key.eq_ignore_ascii_case("NrOfEntries") {
                continue;
            }
            match entry_key(p) {
                Some(k) if (1..=n).contains(&k) => {
                    sub_names.insert(k, p.value.clone());
                }
                _ => self.d.warn(p.line, format!("key {} in [{:04X}Name] is not a sub-index 1..={n}", p.key, index)),
            }
        }
        // Sub-index 0. For the error history and PDO mappings it counts the
        // entries in use, so it is writable and starts at the values given.
        let counts_use = index == 0x1003 || (0x1600..=0x17FF).contains(&index) || (0x1A00..=0x1BFF).contains(&index);
        let sub0_default = if counts_use { value_count } else { n };
        o.subs.insert(
            0,
            SubObject {
                sub: 0,
                name: "Highest sub-index supported".into(),
                type_index: DataType::Unsigned8.index(),
                type_line: s.line,
                data_type: Some(DataType::Unsigned8),
                access: if counts_use { Access::Rw } else { Access::Ro },
                pdo_mapping: false,
                default: Some(Text { text: sub0_default.to_string(), line: s.line }),
                parameter_value: None,
                denotation: None,
                low: None,
                high: None,
                obj_flags: 0,
                upload_file: None,
                download_file: None,
                value: vec![sub0_default],
                node_id: false,
                limits: None,
                line: s.line,
            },
        );
        for k in 1..=n {
            let mut e = template.clone();
            e.sub = k;
            e.name = sub_names.remove(&k).unwrap_or_else(|| format!("{}{k}", o.name));
            if let Some(p) = overrides.get(&k) {
                e.parameter_value = None;
                e.default = Some(Text { text: p.value.clone(), line: p.line });
                if let Some(t) = e.data_type {
                    self.set_value(&mut e, t, &p.value, p.line);
                }
            }
            o.subs.insert(k, e);
        }
    }

    fn set_value(&mut self, e: &mut SubObject, t: DataType, text: &str, line: usize) {
        match value::encode(t, text) {
            Ok(v) => {
                if let Some(note) = v.note {
                    self.d.warn(line, note);
                }
                e.value = v.bytes;
                e.node_id = v.node_id;
            }
            Err(msg) => self.d.error(line, format!("value {msg}")),
        }
    }

    /// Reads the entry keys of a VAR section or a `[xxxxsubN]` section.
    /// `implied` is the type a sub-object without DataType has all the same:
    /// UNSIGNED8 for sub-index 0 (CiA 301), an ARRAY's header type for its
    /// elements. Without one, a missing DataType leaves the entry undecided.
    fn sub_object(&mut self, s: &Section, sub: u8, name: &str, implied: Option<u16>) -> Option<SubObject> {
        let text = |key: &str| s.get(key).map(|p| Text { text: p.value.clone(), line: p.line });
        let (type_index, type_line) = match (s.get("DataType"), implied) {
            (Some(dt), _) => match parse_int(&dt.value).ok().and_then(|e| u16::try_from(e.value).ok()) {
                Some(t) => (t, dt.line),
                None => {
                    self.d.error(dt.line, format!("DataType `{}` is not a type index", dt.value));
                    return None;
                }
            },
            (None, Some(t)) => {
                let why = if sub == 0 { "the type of every sub-index 0" } else { "the ARRAY's DataType" };
                self.d.warn(s.line, format!("[{}] has no DataType; read as 0x{t:04X}, {why}", s.name));
                (t, s.line)
            }
            (None, None) => {
                self.d.error(s.line, format!("[{}] has no DataType", s.name));
                return None;
            }
        };
        let data_type = DataType::from_index(type_index);
        let access = match s.get("AccessType") {
            Some(p) => match Access::parse(&p.value) {
                Some(a) => a,
                None => {
                    self.d.error(p.line, format!("AccessType `{}` is not ro, wo, rw, rwr, rww or const", p.value));
                    return None;
                }
            },
            None => {
                self.d.error(s.line, format!("[{}] has no AccessType", s.name));
                return None;
            }
        };
        let pdo_mapping = match s.get("PDOMapping") {
            None => false,
            Some(p) => match parse_int(&p.value).map(|e| e.value) {
                Ok(0) => false,
                Ok(1) => true,
                _ => {
                    self.d.error(p.line, format!("PDOMapping `{}` is not 0 or 1", p.value));
                    false
                }
            },
        };
        let obj_flags = s.get("ObjFlags").and_then(|p| self.int(p)).and_then(|v| u32::try_from(v).ok()).unwrap_or(0);
        let mut e = SubObject {
            sub,
            name: name.to_owned(),
            type_index,
            type_line,
            data_type,
            access,
            pdo_mapping,
            default: text("DefaultValue"),
            parameter_value: text("ParameterValue"),
            denotation: s.get("Denotation").map(|p| p.value.clone()),
            low: text("LowLimit").filter(|t| !t.text.is_empty()),
            high: text("HighLimit").filter(|t| !t.text.is_empty()),
            obj_flags,
            upload_file: s.get("UploadFile").map(|p| p.value.clone()),
            download_file: s.get("DownloadFile").map(|p| p.value.clone()),
            value: Vec::new(),
            node_id: false,
            limits: None,
            line: s.line,
        };
        if let Some(pv) = e.parameter_value.as_ref().filter(|_| self.is_eds) {
            self.d.warn(pv.line, "ParameterValue belongs in a DCF; in this EDS it is taken as the value");
        }
        let Some(t) = data_type else { return Some(e) };
        e.value = vec![0; t.size().unwrap_or(0)];
        // A DCF's ParameterValue is the configured value; it wins over the default.
        let chosen = e.parameter_value.clone().filter(|p| !p.text.is_empty()).or_else(|| e.default.clone());
        if let Some(v) = chosen.filter(|v| !v.text.is_empty()) {
            self.set_value(&mut e, t, &v.text, v.line);
        }
        if (e.low.is_some() || e.high.is_some()) && t.size().is_some() && t.kind() != canopen_core::od::Kind::Bytes {
            // A single limit still bounds the value; the type's own range is the other bound.
            let parse = |this: &mut Self, lim: &Option<Text>, what: &str| -> Option<Option<Number>> {
                let Some(lim) = lim else { return Some(None) };
                match value::parse_number(t, &lim.text) {
                    Ok((_, true, _)) => {
                        this.d.warn(lim.line, format!("{what} relative to $NODEID is not checked"));
                        None
                    }
                    Ok((n, false, note)) => {
                        if let Some(n) = note {
                            this.d.warn(lim.line, format!("{what} {n}"));
                        }
                        Some(Some(n))
                    }
                    Err(m) => {
                        this.d.error(lim.line, format!("{what} {m}"));
                        None
                    }
                }
            };
            let low = parse(self, &e.low, "LowLimit");
            let high = parse(self, &e.high, "HighLimit");
            if let (Some(low), Some(high)) = (low, high) {
                let (min, max) = value::type_bounds(t);
                e.limits = Some((low.unwrap_or(min), high.unwrap_or(max)));
            }
        }
        Some(e)
    }
}

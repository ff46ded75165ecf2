//! The file's own sections: `[DeviceInfo]` and `[DummyUsage]` (the device
//! facts), `[Comments]`, the `[xxxObjects]` lists, `[DeviceComissioning]`.

use std::collections::BTreeMap;

use super::Reader;
use super::sections::{BAUD_KEYS, DEVICE_INFO_KEYS};
use crate::lexer::Section;
use crate::model::DeviceFacts;
use crate::value::parse_int;

impl Reader<'_> {
    pub(super) fn comments(&mut self, s: &Section) -> Vec<String> {
        let lines = s.get("Lines").and_then(|p| self.int(p)).unwrap_or(0);
        // Walk the keys, not 1..=Lines: `Lines` may be any number up to 10^40.
        let numbered: BTreeMap<i128, String> = s
            .pairs
            .iter()
            .filter_map(|p| {
                let n: i128 = p.key.get(4..)?.parse().ok()?;
                ((1..=lines).contains(&n) && p.key.eq_ignore_ascii_case(&format!("Line{n}"))).then(|| (n, p.value.clone()))
            })
            .collect();
        let out: Vec<String> = numbered.into_values().collect();
        if out.len() as i128 != lines {
            self.d.warn(s.line, format!("[Comments] Lines={lines} but {} LineN keys", out.len()));
        }
        out
    }

    /// An `[xxxObjects]` list, remembering where each index is listed.
    pub(super) fn listed(&mut self, lists: &mut crate::model::ObjectLists, s: &Section) -> Vec<u16> {
        lists.present = true;
        let out = self.object_list(s, "SupportedObjects");
        for p in &s.pairs {
            if let Ok(e) = parse_int(&p.value)
                && let (Ok(i), false) = (u16::try_from(e.value), p.key.eq_ignore_ascii_case("SupportedObjects"))
            {
                lists.lines.entry(i).or_insert(p.line);
            }
        }
        out
    }

    pub(super) fn object_list(&mut self, s: &Section, count_key: &str) -> Vec<u16> {
        let mut out = Vec::new();
        let mut count = None;
        for p in &s.pairs {
            if p.key.eq_ignore_ascii_case(count_key) {
                count = self.int(p).map(|n| (n, p.line));
                continue;
            }
            if parse_int(&p.key).is_err() {
                self.d.warn(p.line, format!("key {} in [{}] is not a list position; ignored", p.key, s.name));
                continue;
            }
            match parse_int(&p.value).ok().and_then(|e| u16::try_from(e.value).ok().filter(|_| !e.node_id)) {
                Some(i) if out.contains(&i) => self.d.warn(p.line, format!("0x{i:04X} is listed twice in [{}]", s.name)),
                Some(i) => out.push(i),
                None => self.d.error(p.line, format!("`{}` in [{}] is not an object index", p.value, s.name)),
            }
        }
        match count {
            Some((n, line)) if n != s.pairs.len() as i128 - 1 => {
                self.d.warn(line, format!("[{}] {count_key}={n} but it has {} entries", s.name, s.pairs.len().saturating_sub(1)))
            }
            None => self.d.warn(s.line, format!("[{}] has no {count_key} key", s.name)),
            _ => {}
        }
        out
    }

    pub(super) fn commissioning_node_id(&mut self, s: &Section) -> Option<u8> {
        let p = s.get("NodeID")?;
        let id = self.int(p)?;
        if (1..=127).contains(&id) {
            Some(id as u8)
        } else {
            self.d.warn(p.line, format!("NodeID {id} is outside 1..=127, i.e. not configured (LSS)"));
            None
        }
    }

    pub(super) fn device_facts(&mut self, info: Option<&Section>, dummy: Option<&Section>) -> DeviceFacts {
        let mut f = DeviceFacts::default();
        if let Some(s) = info {
            for p in &s.pairs {
                if !DEVICE_INFO_KEYS.contains(&p.key.to_ascii_lowercase().as_str()) {
                    self.d.warn(p.line, format!("unknown key {} in [DeviceInfo]", p.key));
                }
            }
            for key in ["VendorName", "VendorNumber", "ProductName", "ProductNumber", "RevisionNumber", "OrderCode"] {
                match s.get(key) {
                    None => self.d.warn(s.line, format!("[DeviceInfo] has no {key}")),
                    Some(p) if p.value.is_empty() || p.value == "\"\"" => self.d.warn(p.line, format!("{key} is empty")),
                    Some(p) if key.ends_with("Number") && parse_int(&p.value).is_err() => {
                        self.d.error(p.line, format!("{key} `{}` is not a number", p.value))
                    }
                    _ => {}
                }
            }
            for (key, bit) in BAUD_KEYS {
                if self.flag(s, key) {
                    f.baud_rates |= 1 << bit;
                }
            }
            if f.baud_rates == 0 {
                self.d.warn(s.line, "no supported bit rate (every BaudRate_* is 0 or missing)");
            }
            f.lss_supported = self.flag(s, "LSS_Supported");
            f.simple_boot_up_master = self.flag(s, "SimpleBootUpMaster");
            f.simple_boot_up_slave = self.flag(s, "SimpleBootUpSlave");
            f.dynamic_channels = self.flag(s, "DynamicChannelsSupported");
            f.group_messaging = self.flag(s, "GroupMessaging");
            f.granularity = self.small(s, "Granularity", 64) as u8;
            f.nr_rx_pdo = self.small(s, "NrOfRXPDO", 512) as u16;
            f.nr_tx_pdo = self.small(s, "NrOfTXPDO", 512) as u16;
            f.compact_pdo = self.small(s, "CompactPDO", 0xFF) as u8;
        } else {
            self.d.warn(0, "no [DeviceInfo] section");
        }
        if let Some(s) = dummy {
            for p in &s.pairs {
                let t = p.key.to_ascii_lowercase().strip_prefix("dummy").and_then(|t| u16::from_str_radix(t, 16).ok());
                match t {
                    Some(t @ 1..=0x1F) if self.int(p) == Some(1) => f.dummy_usage |= 1 << t,
                    Some(1..=0x1F) => {}
                    _ => self.d.warn(p.line, format!("unknown key {} in [DummyUsage]", p.key)),
                }
            }
        }
        f
    }
}

//! CiA 306 §4.5.2.3: the PDO objects a `CompactPDO` file leaves out.

use std::collections::BTreeMap;

use canopen_core::od::DataType;

use super::Reader;
use crate::model::{Access, Eds, Object, ObjectKind, SubObject, Text};
use crate::value;

impl Reader<'_> {
    /// CiA 306 §4.5.2.3: with `CompactPDO`, PDO objects the file leaves out
    /// exist with default values for each PDO up to `NrOfRXPDO`/`NrOfTXPDO`.
    pub(super) fn synthesize_compact_pdo(&mut self, eds: &mut Eds) {
        let f = eds.device.clone();
        if f.compact_pdo == 0 {
            return;
        }
        for (count, comm, map, base) in [(f.nr_rx_pdo, 0x1400u16, 0x1600u16, 0x200u32), (f.nr_tx_pdo, 0x1800, 0x1A00, 0x180)] {
            for n in 0..count.min(512) {
                let tx = comm == 0x1800;
                let cob = if n < 4 { format!("$NODEID+0x{:X}", base + 0x100 * u32::from(n)) } else { "0x80000000".into() };
                let mut comm_subs: Vec<(u8, &str, DataType, String)> = Vec::new();
                let bits = f.compact_pdo;
                if bits & 0x01 != 0 {
                    comm_subs.push((1, "COB-ID", DataType::Unsigned32, cob));
                }
                if bits & 0x02 != 0 {
                    comm_subs.push((2, "Transmission type", DataType::Unsigned8, "0xFF".into()));
                }
                if bits & 0x04 != 0 {
                    comm_subs.push((3, "Inhibit time", DataType::Unsigned16, "0".into()));
                }
                if bits & 0x10 != 0 {
                    comm_subs.push((5, "Event timer", DataType::Unsigned16, "0".into()));
                }
                if tx && bits & 0x20 != 0 {
                    comm_subs.push((6, "SYNC start value", DataType::Unsigned8, "0".into()));
                }
                let ci = comm + n;
                if !eds.objects.contains_key(&ci) && !comm_subs.is_empty() {
                    let highest = comm_subs.last().map_or(0, |s| s.0);
                    let mut subs =
                        vec![(0u8, "Highest sub-index supported".to_owned(), DataType::Unsigned8, highest.to_string(), Access::Ro)];
                    subs.extend(comm_subs.into_iter().map(|(s, name, t, v)| (s, name.to_owned(), t, v, Access::Rw)));
                    let name = format!("{} communication parameter {}", if tx { "TPDO" } else { "RPDO" }, n + 1);
                    eds.objects.insert(ci, synthetic(ci, &name, subs));
                }
                let mi = map + n;
                eds.objects.entry(mi).or_insert_with(|| {
                    let mut subs = vec![(0u8, "Number of mapped objects".to_owned(), DataType::Unsigned8, "0".to_owned(), Access::Rw)];
                    subs.extend((1..=8u8).map(|k| (k, format!("Mapped object {k}"), DataType::Unsigned32, "0".to_owned(), Access::Rw)));
                    let name = format!("{} mapping parameter {}", if tx { "TPDO" } else { "RPDO" }, n + 1);
                    synthetic(mi, &name, subs)
                });
            }
        }
    }
}

fn synthetic(index: u16, name: &str, subs: Vec<(u8, String, DataType, String, Access)>) -> Object {
    let subs = subs
        .into_iter()
        .map(|(sub, name, t, text, access)| {
            let v = value::encode(t, &text).unwrap_or(value::Encoded { bytes: vec![0; t.size().unwrap_or(0)], node_id: false, note: None });
            let e = SubObject {
                sub,
                name,
                type_index: t.index(),
                type_line: 0,
                data_type: Some(t),
                access,
                pdo_mapping: false,
                default: Some(Text { text, line: 0 }),
                parameter_value: None,
                denotation: None,
                low: None,
                high: None,
                obj_flags: 0,
                upload_file: None,
                download_file: None,
                value: v.bytes,
                node_id: v.node_id,
                limits: None,
                line: 0,
            };
            (sub, e)
        })
        .collect::<BTreeMap<_, _>>();
    Object {
        index,
        name: name.to_owned(),
        kind: ObjectKind::Record,
        sub_number: Some(subs.len() as u16),
        sub_number_line: 0,
        compact_sub_obj: None,
        denotation: None,
        links: Vec::new(),
        subs,
        opaque: false,
        synthesized: true,
        line: 0,
    }
}

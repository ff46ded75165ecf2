//! Where each entry lies: its offset in the RAM image or in the flash
//! constants, its row of the limits table, and which entries are
//! `$NODEID`-relative. [`crate::runtime`] builds the same tables from it.

use canopen_core::od::{Attr, DataType, NO_LIMITS};

use crate::model::{Eds, Object, SubObject};

/// Why a dictionary cannot be laid out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayoutError(pub String);

/// One table entry, placed.
pub(crate) struct Placed<'a> {
    pub(crate) obj: &'a Object,
    pub(crate) sub: &'a SubObject,
    pub(crate) data_type: DataType,
    pub(crate) attr: Attr,
    pub(crate) len: usize,
    pub(crate) offset: usize,
    pub(crate) limits: u8,
}

/// The placed dictionary: what the generated module and [`crate::runtime`] hold.
pub(crate) struct Layout<'a> {
    pub(crate) entries: Vec<Placed<'a>>,
    pub(crate) limits: Vec<(u64, u64)>,
    pub(crate) rom: Vec<u8>,
    pub(crate) ram: Vec<u8>,
    pub(crate) comm_len: usize,
    pub(crate) comm_rest: usize,
    pub(crate) stored_len: usize,
    pub(crate) node_id_relative: Vec<usize>,
}

/// Whether a stored parameter set carries the RAM value of `attr`, `len`
/// bytes, of object `index`: what a reset loads from it (a writable value,
/// `StoredSet::load`), or a read-only one the device stores itself
/// ([`Eds::kept`]). A `$NODEID` value is in RAM even when `const`, but is
/// stored only if writable.
fn stored(eds: &Eds, index: u16, attr: Attr, len: usize) -> bool {
    !attr.contains(Attr::IN_ROM) && len > 0 && !NEVER_STORED.contains(&index) && (attr.contains(Attr::WRITE) || eds.kept.contains(&index))
}

/// Writable objects that are commands or a record of events, not parameters:
/// a stored set never carries them. 0x1003 sub 0 is written only to clear
/// the history, whose entries are read-only and not stored either (a stored
/// count would show errors after a reset that has none, CiA 301 §7.5.2.5);
/// 0x1010/0x1011 are the store and restore commands, 0x1F51 program control.
pub const NEVER_STORED: [u16; 4] = [0x1003, 0x1010, 0x1011, 0x1F51];

pub(crate) fn layout(eds: &Eds) -> Result<Layout<'_>, LayoutError> {
    let mut l = Layout {
        entries: Vec::new(),
        limits: Vec::new(),
        rom: Vec::new(),
        ram: Vec::new(),
        comm_len: 0,
        comm_rest: 0,
        stored_len: 0,
        node_id_relative: Vec::new(),
    };
    // The RAM values in four runs, each in index order: stored communication,
    // other stored, the rest of communication, the rest of the others. The
    // stored set is then the prefix of the first two; each reset part is two runs.
    let mut runs: [Vec<u8>; 4] = Default::default();
    let mut ram_run = Vec::new();
    for o in eds.objects.values().filter(|o| !o.opaque) {
        for s in o.subs.values() {
            let Some(t) = s.data_type else { continue };
            let mut attr = s.access.attr(s.pdo_mapping);
            if s.node_id {
                // A `$NODEID` value changes with the node-id, so even a `const` one lives in RAM.
                attr = Attr(attr.union(Attr::NODE_ID).0 & !Attr::IN_ROM.0);
            }
            let len = s.size();
            let mut value = s.value.clone();
            value.resize(len, 0);
            let offset = if t == DataType::Domain {
                0
            } else if attr.contains(Attr::IN_ROM) {
                l.rom.extend_from_slice(&value);
                l.rom.len() - len
            } else {
                let run = usize::from(!stored(eds, o.index, attr, len)) * 2 + usize::from(o.index >= 0x2000);
                ram_run.push((l.entries.len(), run));
                let bytes = &mut runs[run];
                bytes.extend_from_slice(&value);
                bytes.len() - len
            };
            let limits = match s.limits {
                Some((lo, hi)) => {
                    let pair = (lo.to_limit(), hi.to_limit());
                    let pos = l.limits.iter().position(|p| *p == pair).unwrap_or_else(|| {
                        l.limits.push(pair);
                        l.limits.len() - 1
                    });
                    // The entry's limits field is one byte, NO_LIMITS its last value.
                    u8::try_from(pos).ok().filter(|&p| p != NO_LIMITS).ok_or_else(|| {
                        LayoutError(format!("more than {NO_LIMITS} distinct LowLimit/HighLimit pairs (0x{:04X}:{:02X})", o.index, s.sub))
                    })?
                }
                None => NO_LIMITS,
            };
            // The entry's length is one byte (validation reports a longer value with its line).
            if len > usize::from(u8::MAX) {
                return Err(LayoutError(format!("0x{:04X}:{:02X} has {len} bytes, more than the 255 an entry holds", o.index, s.sub)));
            }
            if s.node_id && !attr.contains(Attr::IN_ROM) {
                l.node_id_relative.push(l.entries.len());
            }
            l.entries.push(Placed { obj: o, sub: s, data_type: t, attr, len, offset, limits });
        }
    }
    // Each offset was within its run: move it by the runs before.
    let starts = [0, runs[0].len(), runs[0].len() + runs[1].len(), runs[0].len() + runs[1].len() + runs[2].len()];
    for (entry, run) in ram_run {
        l.entries[entry].offset += starts[run];
    }
    (l.comm_len, l.stored_len, l.comm_rest) = (runs[0].len(), starts[2], runs[2].len());
    l.ram = runs.concat();
    if l.ram.len() > usize::from(u16::MAX) || l.rom.len() > usize::from(u16::MAX) {
        return Err(LayoutError(format!("RAM image {} B / ROM {} B exceed 65535 B", l.ram.len(), l.rom.len())));
    }
    if l.entries.len() > usize::from(u16::MAX) {
        return Err(LayoutError("more than 65535 entries".into()));
    }
    Ok(l)
}
